"""One whole-process run of the exact integrator on a netlist, for
``benchmarks/exact_vs_ngspice.py`` (until ``.options method=exact`` reaches the command
line, the benchmark times this script): read the netlist, start from its operating point
(or UIC), run :func:`~circuitnsds.engine.exact.run.run_exact` on the ``.tran`` grid up to
``--stop``, and print one JSON line: segments, events, rows and the seconds of the run itself (wall and
CPU).

Usage: ``PYTHONPATH=$PWD python benchmarks/exact_run.py NETLIST --stop 0.1``
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import circuitnsds
from circuitnsds.analyses.operating_point import operating_point, uic_state
from circuitnsds.engine.exact.run import run_exact

# numpy is imported inside the functions, after circuitnsds: one BLAS thread, as the command line
# has it (circuitnsds/_blas.py; a threaded BLAS on a busy machine was 2x slower here)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("netlist")
    parser.add_argument("--stop", type=float, help="stop time [s] (default: the .tran stop)")
    args = parser.parse_args()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuitnsds.read_netlist(args.netlist)
        tran = circuit.analyses["tran"]
        mlcs = circuit.mlcs()
        state = uic_state(circuit, mlcs) if tran.uic else operating_point(circuit, mlcs)
    stop = tran.stop if args.stop is None else args.stop
    import numpy as np

    times = np.arange(round(stop / tran.step) + 1) * tran.step
    active = np.zeros(mlcs.m, bool) if state.active is None else np.asarray(state.active, bool)
    start, cpu = time.perf_counter(), time.process_time()
    run = run_exact(mlcs, times, state.y, active, tuple(state.switches))
    seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
    print(json.dumps({"segments": run.segments, "events": len(run.events), "rows": len(run.times),
                      "seconds": seconds, "cpu": cpu}))


if __name__ == "__main__":
    main()
