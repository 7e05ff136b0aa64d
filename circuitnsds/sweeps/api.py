"""``circuitnsds.sweep``: a netlist at many parameter values -> a pandas table.

The points are the outer product of the netlist's ``.step`` lines and of ``params``
(a ``params`` entry replaces a ``.step`` of the same parameter), times ``samples``
Monte Carlo runs (a parameter ``run`` = 1..N, the innermost loop). Point ``i`` draws its
random numbers from ``point_generator(seed, i)`` (:mod:`circuitnsds.netlist.steps`), so a
table is reproducible from its seed whatever executes it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from circuitnsds.errors import CircuitError
from circuitnsds.frontend.build import CircuitBuilder
from circuitnsds.netlist.steps import Step, StepSyntaxError, grid, linear_values, steps_from_mapping
from circuitnsds.output.files import OutputError, writing
from circuitnsds.sweeps.task import Job, Point, check_analysis, check_measurement

RUN = "run"
"""The Monte Carlo run-count parameter (``samples=N`` steps it from 1 to N)."""


def sweep_steps(builder: CircuitBuilder, params: Mapping[str, object] | None,
                samples: int | None) -> list[Step]:
    """The sweeps of a sweep: the netlist's ``.step`` lines, ``params``, then the runs.

    Raises:
        CircuitError: bad ``params`` or ``samples``.
    """
    try:
        given = steps_from_mapping(params or {})
    except StepSyntaxError as exc:
        raise CircuitError(f"params: {exc}", where="sweep(params=...)",
                           hint='give {"NAME": value or [values]}') from None
    names = {s.name.lower() for s in given}
    if samples is not None:
        if samples != int(samples) or samples < 1:
            raise CircuitError(f"samples={samples!r}: give a positive number of Monte Carlo runs")
        names.add(RUN)
    steps = [s for s in builder.steps if s.name.lower() not in names] + given
    if samples is not None:
        steps.append(Step(RUN, linear_values(1.0, float(samples), 1.0)))
    return steps


def sweep(netlist: str | Path | CircuitBuilder, params: Mapping[str, object] | None = None, *,
          samples: int | None = None, analysis: str = "tran", measure: Sequence[str] = (),
          signals: Sequence[str] | None = None, executor=None, workers: int | None = None,
          scheduler: str | None = None, seed: int | None = None,
          keep_waveforms: bool | str | Path = False, step: float | None = None,
          stop: float | None = None, theta: float | None = None, uic: bool | None = None,
          progress: Callable[[int, int], None] | None = None,
          losses: Sequence[str] | None = None,
          connect_timeout: float | None = None, worker_timeout: float | None = None):
    """Run a netlist at every point of a parameter grid or Monte Carlo sample.

    Args:
        netlist: a path, netlist text, or a :class:`~circuitnsds.frontend.build.CircuitBuilder`.
        params: ``{"D": [0.2, 0.4, 0.6], "Rl": 5}``: values of each parameter (a scalar is
            one value); the grid is the outer product with the netlist's ``.step`` lines,
            the netlist's first ``.step`` outermost and ``params`` after them in order.
        samples: number of Monte Carlo runs (parameter ``run`` = 1..N, innermost).
        analysis: ``"tran"`` (or ``"pss"`` where that analysis exists).
        measure: measurement expressions, as ``circuitnsds run --measure`` takes them
            (``"mean(v(out))"``, ``"ripple(v(out), 1m, 2m)"``); one column each, named
            as written.
        signals: the signals kept with ``keep_waveforms`` (default: all).
        executor: a ``distributed.Client`` of a running cluster.
        workers: local worker processes (default one per core); 0 runs every point in
            this process, without Dask.
        scheduler: address of a running Dask scheduler (``tcp://host:8786``).
        seed: the Monte Carlo seed (default ``.options seed``, else 1).
        keep_waveforms: ``True``: a column ``waveforms`` holds each point's
            :class:`~circuitnsds.Waveforms`; a directory: each point's waveforms are
            written there as ``point_0007.csv`` and a column ``file`` names it.
        step, stop, theta, uic: the transient's settings (defaults from the netlist).
        progress: ``progress(finished, total)``, called as points finish.
        losses: the load elements of each point's loss table (``()``: a table without
            outputs; ``None``: none): columns ``efficiency`` (with loads), ``losses_W``, ``stored_W``, each
            datasheet device's ``NAME.conduction_W`` … ``NAME.recovery_W`` and
            ``max(tj(NAME))`` (docs/losses.md), named in ``attrs["loss_columns"]``.
        connect_timeout: how long to try to reach ``scheduler`` and to wait for one answer
            from it [s] (default :data:`~circuitnsds.sweeps.execute.CONNECT_TIMEOUT`, 10 s).
        worker_timeout: how long the sweep waits while the cluster has no worker or its
            scheduler does not answer before the points not finished are lost [s] (default
            :data:`~circuitnsds.sweeps.execute.WORKER_TIMEOUT`, 60 s).

    Returns:
        a pandas DataFrame, one row per point in grid order: the parameter columns (names
        as written), one column per measurement, ``status`` (``"ok"``, ``"failed"``: the
        point's own error, or ``"lost"``: the cluster lost its task, see
        :mod:`~circuitnsds.sweeps.execute`), ``error`` (the message of a failed or lost
        point, else empty) and ``warnings``. Its
        ``attrs`` hold ``seed``, ``seconds`` (wall time of the sweep), ``point_seconds``
        and ``point_cpu_seconds`` (wall and CPU time of each point where it ran).

    Raises:
        NetlistError: the netlist cannot be read (a point's failure is in its row instead).
        CircuitError: bad arguments; ExecutorError: Dask cannot be started or reached.
    """
    import pandas as pd

    from circuitnsds.sweeps import execute

    started = time.perf_counter()
    chosen = [name for name, value in (("executor", executor), ("scheduler", scheduler),
                                       ("workers", workers)) if value is not None]
    if len(chosen) > 1:
        raise CircuitError(f"{' and '.join(chosen)} are both given: they choose where the points run",
                           where="sweep", hint="give one of them (workers=0: in this process)")
    timeouts = {"connect_timeout": execute.CONNECT_TIMEOUT if connect_timeout is None else connect_timeout,
                "worker_timeout": execute.WORKER_TIMEOUT if worker_timeout is None else worker_timeout}
    for name, value in timeouts.items():
        if not (isinstance(value, (int, float)) and 0 < value < float("inf")):
            raise CircuitError(f"{name}={value!r}: give a positive number of seconds", where="sweep")
    if scheduler is not None:  # a malformed address refused before anything runs
        scheduler = execute.scheduler_address(scheduler)
    for expression in measure:  # syntax errors now, not at every point
        check_measurement(expression)
    builder = netlist if isinstance(netlist, CircuitBuilder) else CircuitBuilder.load(netlist)
    steps = sweep_steps(builder, params, samples)
    unknown = builder.unknown({s.name: 0.0 for s in steps if s.name.lower() != RUN})
    if unknown:
        raise CircuitError(f"the netlist neither defines nor uses the swept parameter(s) "
                           f"{', '.join(unknown)}", hint="check the spelling (names are case-insensitive)")
    seed = int(seed) if seed is not None else builder.default_seed
    if seed < 0:
        raise CircuitError(f"seed={seed} must be a non-negative integer", where="--seed",
                           hint="any integer from 0 up; the same seed draws the same points")
    options = {key: value for key, value in (("step", step), ("stop", stop), ("theta", theta),
                                             ("uic", uic)) if value is not None}
    check_analysis(analysis, options)
    if signals and not keep_waveforms:
        raise CircuitError("signals select the waveforms kept, and none are kept", where="--signals",
                           hint="keep them: keep_waveforms=True or a folder (sweep --waveforms DIR); "
                           "or leave the signals out (a sweep's table holds measurements only)")
    directory = None if isinstance(keep_waveforms, bool) else Path(keep_waveforms)
    if directory is not None:  # before the run, not after it
        with writing(directory):
            if directory.exists() and not directory.is_dir():
                raise OutputError(f"cannot write {directory}: not a folder", where=str(directory),
                                  hint="--waveforms (keep_waveforms) names a folder, made if missing")
            directory.mkdir(parents=True, exist_ok=True)
    job = Job(builder.source(), analysis, options, tuple(measure),
              tuple(signals) if signals else None, bool(keep_waveforms),
              None if losses is None else tuple(name.lower() for name in losses))
    points = [Point(index, values, seed) for index, values in enumerate(grid(steps))]
    rows = execute.run_points(job, points, executor=executor, workers=workers, scheduler=scheduler,
                              progress=progress, **timeouts)
    loss_columns = list(dict.fromkeys(key for row in rows for key in row["values"]
                                      if key not in measure))
    table = pd.DataFrame({
        **{s.name: [row["params"][s.name] for row in rows] for s in steps},
        **{expression: [row["values"][expression] for row in rows] for expression in measure},
        **{column: [row["values"].get(column, float("nan")) for row in rows]
           for column in loss_columns},
        "status": [row["status"] for row in rows],
        "error": [row["error"] for row in rows],
        "warnings": [row["warnings"] for row in rows],
    })
    if directory is not None:
        files = []
        for row in rows:
            path = directory / f"point_{row['index']:04d}.csv"
            if row["waveforms"] is not None:
                with writing(path):
                    row["waveforms"].to_csv(path)
                files.append(str(path))
            else:
                files.append("")
        table["file"] = files
    elif keep_waveforms:
        table["waveforms"] = [row["waveforms"] for row in rows]
    table.attrs.update(seed=seed, seconds=time.perf_counter() - started, loss_columns=loss_columns,
                       point_seconds=[row["seconds"] for row in rows],
                       point_cpu_seconds=[row["cpu_seconds"] for row in rows])
    return table
