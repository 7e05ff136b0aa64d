"""Parameter sweeps and Monte Carlo runs of one netlist, serially or on a Dask cluster.

* :mod:`~circuitnsds.sweeps.task`: one point (build, analyse, measure) as plain data in
  and out; the analysis registry.
* :mod:`~circuitnsds.sweeps.execute`: running the points in-process or on dask.distributed.
* :mod:`~circuitnsds.sweeps.api`: :func:`~circuitnsds.sweeps.api.sweep`, the table.

Nothing here imports dask or pandas at import time (``import circuitnsds`` stays light).
"""
