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

Faults of the cluster never cost the finished points: a point whose task is lost (its
worker killed again and again, by its nanny's memory limit for one: ``KilledWorker``; the
scheduler gone; no worker left for ``worker_timeout`` seconds; a scheduler that stops
answering as long) gets a row with status :data:`LOST` and the reason, and the sweep
returns the rows it has.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import sys
import time
from collections.abc import Callable, Sequence

from circuitnsds.errors import CircuitnsdsError
from circuitnsds.sweeps.task import Job, Point, run_point

CONNECT_TIMEOUT = 10.0
"""How long to try to reach a scheduler given by its address, and to wait for one answer
from it [s] (``sweep(connect_timeout=...)``, ``--connect-timeout``)."""
WORKER_TIMEOUT = 60.0
"""How long a sweep waits while the cluster has no worker, or its scheduler does not
answer, before it marks the points not finished as lost [s] (``sweep(worker_timeout=...)``,
``--worker-timeout``)."""
POLL_SECONDS = 0.2
"""How often the sweep looks for finished points and asks whether the cluster lives [s]."""
LOST = "lost"
"""Status of a point whose task the cluster lost (the other statuses: ``"ok"``, ``"failed"``)."""
_SCHEME = re.compile(r"([A-Za-z][A-Za-z0-9+.-]*)://")
_ADDRESS = re.compile(r"(?:(?P<scheme>tcp|tls)://)?"
                      r"(?P<host>\[[0-9a-fA-F:.]+\]|[A-Za-z0-9._-]+):(?P<port>\d{1,5})")

Progress = Callable[[int, int], None]
"""``progress(finished, total)``, called as points finish."""


class ExecutorError(CircuitnsdsError):
    """The Dask cluster cannot be reached or started."""


def scheduler_address(address: str) -> str:
    """A scheduler address checked before anything connects: ``tcp://HOST:PORT`` (or
    ``HOST:PORT``), or ``tls://HOST:PORT`` when Dask's configuration names the certificates.
    The port is required: a word alone (``garbage``) is far likelier a mistake than a host.

    Returns:
        the address with its scheme written out.

    Raises:
        ExecutorError: anything else (``inproc://`` and other in-process or unknown schemes,
            no host, a port out of range, ``tls://`` without certificates).
    """
    hint = "give the address the scheduler printed, e.g. tcp://127.0.0.1:8786"
    text = address.strip() if isinstance(address, str) else ""
    scheme = _SCHEME.match(text)
    if scheme is not None and scheme[1] not in ("tcp", "tls"):
        raise ExecutorError(f"scheduler address {address!r}: the {scheme[1]}:// scheme is not a "
                            "network address a sweep can use", where="--scheduler", hint=hint)
    match = _ADDRESS.fullmatch(text)
    if match is None:
        raise ExecutorError(f"scheduler address {address!r}: not HOST:PORT", where="--scheduler",
                            hint=hint)
    scheme, host = match["scheme"] or "tcp", match["host"]
    port = int(match["port"])
    if not 0 < port < 65536:
        raise ExecutorError(f"scheduler address {address!r}: port {port} is not in 1..65535",
                            where="--scheduler", hint=hint)
    if scheme == "tls":
        import dask

        missing = [key for key in ("distributed.comm.tls.ca-file", "distributed.comm.tls.client.cert")
                   if not dask.config.get(key, None)]
        if missing:
            raise ExecutorError(f"scheduler address {address!r}: tls:// needs certificates, and Dask's "
                                f"configuration has no {' and no '.join(missing)}", where="--scheduler",
                                hint="set DASK_DISTRIBUTED__COMM__TLS__CA_FILE, ..._CLIENT__CERT and "
                                "..._CLIENT__KEY (or Dask's configuration file), or use tcp://")
    return f"{scheme}://{host}:{port}"


def run_points(job: Job, points: Sequence[Point], *, executor=None, workers: int | None = None,
               scheduler: str | None = None, progress: Progress | None = None,
               connect_timeout: float = CONNECT_TIMEOUT,
               worker_timeout: float = WORKER_TIMEOUT) -> list[dict]:
    """The rows of :func:`~circuitnsds.sweeps.task.run_point` for every point, in point order
    (a point the cluster lost: a row with status :data:`LOST`).

    Args:
        connect_timeout: see :data:`CONNECT_TIMEOUT` [s].
        worker_timeout: see :data:`WORKER_TIMEOUT` [s].

    Raises:
        ExecutorError: Dask is missing, a bad scheduler address, or the scheduler cannot be
            reached.
    """
    if executor is None and scheduler is None and workers == 0:
        rows = []
        for done, point in enumerate(points, start=1):
            rows.append(run_point(job, point))
            if progress is not None:
                progress(done, len(points))
        return rows
    try:
        import distributed  # noqa: F401 - present?
    except ImportError:
        raise ExecutorError("a sweep on workers needs dask.distributed, which is not installed",
                            hint='pip install "dask[distributed]" (or run with workers=0 / '
                            "--workers 0: every point in this process)") from None
    with quiet_distributed():
        return _on_dask(job, points, executor, workers, scheduler, progress, connect_timeout,
                        worker_timeout)


def _on_dask(job: Job, points: Sequence[Point], executor, workers: int | None, scheduler: str | None,
             progress: Progress | None, connect_timeout: float, worker_timeout: float) -> list[dict]:
    """:func:`run_points` on a Dask cluster: the caller's, the scheduler's, or a local one."""
    import asyncio

    from distributed import Client, LocalCluster

    patience = (connect_timeout, worker_timeout)
    if executor is not None:
        return _gather(executor, job, points, progress, *patience)
    if scheduler is not None:
        address = scheduler_address(scheduler)
        try:  # Client() alone waits for ever on a port that accepts and never answers
            asyncio.run(_identity(address, connect_timeout))
            client = Client(address, timeout=f"{connect_timeout}s")
        except (OSError, TimeoutError) as exc:
            why = str(exc) or f"no answer in {connect_timeout:g} s"
            raise ExecutorError(f"cannot reach the Dask scheduler at {scheduler}: {why}",
                                hint="start one with `dask scheduler` and workers with `dask worker "
                                "ADDRESS`, or leave --scheduler out for a local cluster") from None
        with client:
            return _gather(client, job, points, progress, *patience)
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
        return first + _gather(client, job, rest, shifted, *patience)


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


async def _identity(address: str, timeout: float) -> dict:
    """The scheduler's answer to ``identity``, within ``timeout`` seconds per exchange."""
    import asyncio

    from distributed.comm import connect

    comm = await asyncio.wait_for(connect(address, timeout=timeout), timeout)
    try:
        await asyncio.wait_for(comm.write({"op": "identity", "reply": True}), timeout)
        return await asyncio.wait_for(comm.read(), timeout)
    finally:
        comm.abort()


@contextlib.contextmanager
def quiet_distributed():
    """Dask's own log records off while a sweep talks to a cluster: a lost connection or a
    dead worker is logged with tracebacks there, and the sweep reports it in its rows."""
    names = ["distributed", *(name for name in logging.root.manager.loggerDict
                              if name.startswith("distributed."))]  # some have their own level
    levels = {name: logging.getLogger(name).level for name in names}
    for name in names:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for name, level in levels.items():
            logging.getLogger(name).setLevel(level)


def lost_row(point: Point, job: Job, reason: str) -> dict:
    """The row of a point the cluster lost: NaN measurements, status :data:`LOST`."""
    return {"index": point.index, "params": point.params,
            "values": {expression: float("nan") for expression in job.measure}, "status": LOST,
            "error": f"lost: {reason}", "warnings": "", "seconds": float("nan"),
            "cpu_seconds": float("nan"), "waveforms": None}


def _why_lost(future, timeout: float) -> str:
    """Why the cluster gave no result for a future that is done (``timeout``: to fetch the
    exception [s])."""
    if future.status == "cancelled":
        return "the Dask scheduler went away (its connection closed) before the point finished"
    exception = future.exception(timeout=timeout)
    name = type(exception).__name__
    if name == "KilledWorker":
        return ("every worker that ran it died (KilledWorker: a worker above its memory limit is "
                "killed by its nanny; distributed.scheduler.allowed-failures tries)")
    return f"the cluster gave {name}: {exception}"


def _cluster_trouble(client, connect_timeout: float) -> str | None:
    """What keeps the cluster from running points now (``None``: a scheduler answers and
    has at least one worker)."""
    if client.status not in ("running", "newly-created"):
        return "the Dask scheduler went away (the client's connection closed)"
    try:
        workers = client.nthreads(callback_timeout=connect_timeout)
    except Exception:  # noqa: BLE001 - any failure to get an answer is the same trouble
        return f"the Dask scheduler did not answer within {connect_timeout:g} s"
    return None if workers else "the Dask cluster has no worker"


def _gather(client, job: Job, points: Sequence[Point], progress: Progress | None,
            connect_timeout: float, worker_timeout: float) -> list[dict]:
    """Every point's row from the cluster; the points still running when the cluster has been
    in trouble (:func:`_cluster_trouble`) for ``worker_timeout`` seconds are lost."""
    from distributed import as_completed

    futures = client.map(run_point, [job] * len(points), points, pure=False)
    point_of = {future.key: point for future, point in zip(futures, points)}
    rows: dict[int, dict] = {}
    finished = as_completed(futures)
    trouble_since, last_check = None, time.monotonic()
    try:
        while not finished.is_empty():
            batch = finished.next_batch(block=False)
            for future in batch:
                point = point_of[future.key]
                try:
                    rows[point.index] = (future.result(timeout=connect_timeout)
                                         if future.status == "finished" else
                                         lost_row(point, job, _why_lost(future, connect_timeout)))
                except Exception as exc:  # noqa: BLE001 - a result that cannot be fetched
                    rows[point.index] = lost_row(point, job, "its result could not be fetched "
                                                 "(the Dask scheduler or the worker holding it went "
                                                 f"away: {type(exc).__name__})")
                if progress is not None:
                    progress(len(rows), len(points))
            if batch:
                trouble_since = None
                continue
            time.sleep(POLL_SECONDS)
            now = time.monotonic()
            if now - last_check < 1.0:
                continue
            trouble, last_check = _cluster_trouble(client, connect_timeout), time.monotonic()
            if trouble is None:
                trouble_since = None
                continue
            trouble_since = trouble_since if trouble_since is not None else now
            if last_check - trouble_since >= worker_timeout:
                reason = f"{trouble} for {worker_timeout:g} s (sweep worker_timeout)"
                for point in points:
                    rows.setdefault(point.index, lost_row(point, job, reason))
                break
    finally:
        for future in futures:
            with contextlib.suppress(Exception):
                future.release()
    return [rows[point.index] for point in points]
