"""Running the points of a sweep: in this process, or on dask.distributed.

* ``workers=0``: every point in this process, in order (for debugging: tracebacks and
  breakpoints work, no Dask involved).
* ``executor=Client(...)`` or ``scheduler="tcp://host:8786"``: the points are tasks of a
  running Dask cluster (the Client made from an address is closed at the end).
* otherwise a ``LocalCluster`` of ``workers`` processes (default: one per core), one
  thread each, is started for the sweep and closed after it (on Linux the workers are
  forked from this process after it has run the first point: see :data:`FORK`).

A task carries the :class:`~circuitnsds.sweeps.task.Job` (netlist text with its includes
resolved, analysis, measurements) and one :class:`~circuitnsds.sweeps.task.Point`;
workers need circuitnsds installed, not the netlist's files.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Sequence

from circuitnsds.errors import CircuitnsdsError
from circuitnsds.sweeps.task import Job, Point, run_point

CONNECT_TIMEOUT = "10s"
"""How long to try to reach a scheduler given by its address."""

Progress = Callable[[int, int], None]
"""``progress(finished, total)``, called as points finish."""


class ExecutorError(CircuitnsdsError):
    """The Dask cluster cannot be reached or started."""


def run_points(job: Job, points: Sequence[Point], *, executor=None, workers: int | None = None,
               scheduler: str | None = None, progress: Progress | None = None) -> list[dict]:
    """The rows of :func:`~circuitnsds.sweeps.task.run_point` for every point, in point order.

    Raises:
        ExecutorError: Dask is missing, or the scheduler cannot be reached.
    """
    if executor is None and scheduler is None and workers == 0:
        rows = []
        for done, point in enumerate(points, start=1):
            rows.append(run_point(job, point))
            if progress is not None:
                progress(done, len(points))
        return rows
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise ExecutorError("a sweep on workers needs dask.distributed, which is not installed",
                            hint='pip install "dask[distributed]" (or run with workers=0 / '
                            "--workers 0: every point in this process)") from None
    if executor is not None:
        return _gather(executor, job, points, progress)
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            raise ExecutorError(f"cannot reach the Dask scheduler at {scheduler}: {exc}",
                                hint="start one with `dask scheduler` and workers with `dask worker "
                                "ADDRESS`, or leave --scheduler out for a local cluster") from None
        with client:
            return _gather(client, job, points, progress)
    count = workers if workers is not None else (os.cpu_count() or 1)
    if count < 1:
        raise ExecutorError(f"workers={count}: give a positive number, or 0 to run in this process")
    first: list[dict] = []
    if FORK and points:  # the first point here: it warms this process, which the workers copy
        first.append(run_point(job, points[0]))
        if progress is not None:
            progress(1, len(points))
        if len(points) == 1:
            return first
    rest = points[len(first):]
    shifted = None if progress is None else (lambda done, _: progress(done + len(first), len(points)))
    with local_worker_config(), LocalCluster(
            n_workers=min(count, len(rest)), threads_per_worker=1, processes=True,
            dashboard_address=None, silence_logs=40) as cluster, Client(cluster) as client:
        return first + _gather(client, job, rest, shifted)


FORK = sys.platform == "linux"
"""Start the sweep's local workers by forking this process (Linux): they begin with its
imports and its loaded stepping loops instead of importing everything anew, and a script
needs no ``if __name__ == "__main__":`` guard. This process runs the first point itself
first, so what the workers copy is warm. Measured on the buck (40 points, 10 ms each, 2
workers, loaded machine): first point in a worker 0.8 s instead of 5-7 s, the sweep 1.3x
the serial time instead of 1.9-2.6x. Elsewhere workers are spawned (Python's default)."""


def local_worker_config():
    """Dask settings for the sweep's own local workers (a context manager).

    Two of Dask's defaults were measured to slow a point down 1.5-2x in a worker against
    the same point in a plain process (benchmarks/sweep.py, on the buck): the statistical
    profiler, which samples every thread's stack every 10 ms while holding the GIL, and
    ``MALLOC_TRIM_THRESHOLD_=65536``, which makes glibc give freed memory back at once
    (and map large arrays anew each time). Both are off here; one BLAS thread stays.
    Workers of a cluster you start yourself can be given the same settings:
    ``DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False dask worker ... --no-nanny``.
    """
    import dask

    environment = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}))
    environment.pop("MALLOC_TRIM_THRESHOLD_", None)
    settings = {"distributed.worker.profile.enabled": False,
                "distributed.nanny.pre-spawn-environ": environment}
    if FORK:
        settings["distributed.worker.multiprocessing-method"] = "fork"
    return dask.config.set(settings)


def _gather(client, job: Job, points: Sequence[Point], progress: Progress | None) -> list[dict]:
    from distributed import as_completed

    futures = client.map(run_point, [job] * len(points), points, pure=False)
    rows: dict[int, dict] = {}
    try:
        for done, future in enumerate(as_completed(futures), start=1):
            row = future.result()
            rows[row["index"]] = row
            if progress is not None:
                progress(done, len(points))
    finally:
        for future in futures:
            future.release()
    return [rows[point.index] for point in points]
