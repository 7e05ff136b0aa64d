"""One sweep point: build the circuit for its parameters, run the analysis, measure.

Everything a point needs travels as plain data: a :class:`Job` (the netlist as
:class:`~circuitnsds.frontend.build.NetlistSource` text, the analysis and the
measurements, the same for every point) and a :class:`Point` (index, parameter values,
seed). :func:`run_point` never raises for a failure of the point: its row says
``status="failed"`` and the error message.
"""

from __future__ import annotations

import functools
import time
import warnings
from dataclasses import dataclass, field

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.errors import CircuitError, CircuitnsdsError
from circuitnsds.frontend.build import CircuitBuilder, NetlistSource
from circuitnsds.netlist.steps import point_generator
from circuitnsds.output.measure import evaluate, parse_measurement


def is_meas_line(expression: str) -> bool:
    """Whether a measurement is written as ngspice's ``.meas`` (``"tran vavg AVG v(out)
    from=1m to=2m"``, as ``run --measure`` takes it) rather than as ``mean(v(out), 1m, 2m)``."""
    return expression.split()[:1] != [] and expression.split()[0].lower() == "tran"


def check_measurement(expression: str) -> None:
    """Raise the syntax error of a measurement in either form (before any point runs)."""
    if is_meas_line(expression):
        from circuitnsds.frontend.cards.meas import parse_meas

        parse_meas(f".meas {expression}")
    else:
        parse_measurement(expression)


def measured(expression: str, waves, circuit: Circuit) -> float:
    """The value of a measurement in either form (:func:`is_meas_line`) on ``waves``."""
    if is_meas_line(expression):
        from circuitnsds.frontend.cards.meas import parse_meas
        from circuitnsds.output.meas import run_measurement

        return float(run_measurement(parse_meas(f".meas {expression}"), waves).value)
    return evaluate(parse_measurement(expression), waves, circuit).value


ANALYSES: dict[str, str] = {"tran": "transient", "pss": "pss"}
"""Analysis name -> the :class:`~circuitnsds.circuit.circuit.Circuit` method that runs it
(``method(**options) -> Waveforms``); a new analysis is one entry here."""


def check_analysis(analysis: str, options: dict | None = None) -> None:
    """Raise a clear error for an analysis that is unknown or not in this version, or for
    settings it does not take.

    Raises:
        CircuitError: unknown name, the circuit has no such method here, or an option the
            method does not accept.
    """
    if analysis not in ANALYSES:
        raise CircuitError(f"unknown analysis {analysis!r}", where="sweep(analysis=...)",
                           hint=f"known: {', '.join(ANALYSES)}")
    if not hasattr(Circuit, ANALYSES[analysis]):
        raise CircuitError(f"analysis {analysis!r} is not available in this version of circuitnsds "
                           f"(Circuit.{ANALYSES[analysis]} is missing)", where="sweep(analysis=...)",
                           hint="use analysis='tran'")
    import inspect

    accepted = inspect.signature(getattr(Circuit, ANALYSES[analysis])).parameters
    refused = [name for name in options or {} if name not in accepted]
    if refused:
        raise CircuitError(f"analysis {analysis!r} takes no {', '.join(refused)}", where="sweep",
                           hint=f"its settings: {', '.join(n for n in accepted if n != 'self')}")


@dataclass(frozen=True)
class Job:
    """What every point of a sweep shares.

    Attributes:
        source: the netlist, includes resolved.
        analysis: a key of :data:`ANALYSES`.
        options: keyword arguments of the analysis (``step``, ``stop``, ``theta`` ...).
        measure: measurement expressions (:func:`circuitnsds.output.measure.evaluate`).
        signals: signals kept with ``keep_waveforms`` (``None``: all).
        keep_waveforms: return each point's waveforms with its row.
        losses: the loads of the loss table whose figures each point adds to its values
            (:func:`circuitnsds.thermal.junction.loss_columns`); ``None``: no loss table.
    """

    source: NetlistSource
    analysis: str = "tran"
    options: dict = field(default_factory=dict)
    measure: tuple[str, ...] = ()
    signals: tuple[str, ...] | None = None
    keep_waveforms: bool = False
    losses: tuple[str, ...] | None = None


@dataclass(frozen=True)
class Point:
    """One point: its position in the sweep, its parameters (names as written) and the seed."""

    index: int
    params: dict[str, float]
    seed: int


def _loss_columns(job: Job, circuit: Circuit, waves) -> dict[str, float]:
    """The point's loss table as columns (:func:`circuitnsds.thermal.junction.loss_columns`),
    its datasheet devices driven period by period as ``run --losses`` drives them."""
    from circuitnsds.output.measure import losses
    from circuitnsds.thermal import junction

    result = None
    if any(getattr(getattr(element, "model", None), "thermal", None) for element in circuit.elements):
        period, start = junction.switching_period(circuit)
        result = junction.analyse(circuit, waves, steady=job.analysis == "pss", period=period,
                                  start=start)
    parts = None if result is None else (
        lambda t0, t1: {name: device.average(t0, t1) for name, device in result.losses.items()})
    return junction.loss_columns(losses(waves, circuit, outputs=job.losses, devices=parts), result)


@functools.lru_cache(maxsize=8)
def builder_for(source: NetlistSource) -> CircuitBuilder:
    """The builder of a netlist source, kept per process: a worker parses a netlist once."""
    return CircuitBuilder.from_source(source)


def run_point(job: Job, point: Point) -> dict:
    """Run one point.

    Returns:
        ``{"index", "params", "values" (measurement -> float), "status" ("ok" or "failed"),
        "error" (message or ""), "warnings" (messages, one a line), "seconds" (wall time),
        "cpu_seconds" (CPU time of the process while it ran: less than "seconds" when other
        work shares the cores),
        "waveforms" (kept waveforms or None)}``.
    """
    started, cpu = time.perf_counter(), time.process_time()
    values = {expression: float("nan") for expression in job.measure}
    status, error, waves = "ok", "", None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            circuit = builder_for(job.source).build(point.params, point_generator(point.seed, point.index))
            result = getattr(circuit, ANALYSES[job.analysis])(**job.options)
            waves = getattr(result, "waveforms", result)  # pss: one settled period
            for expression in job.measure:
                values[expression] = measured(expression, waves, circuit)
            if job.losses is not None:
                values.update(_loss_columns(job, circuit, waves))
            if job.keep_waveforms:
                unknown = [name for name in job.signals or () if name not in waves]
                if unknown:
                    raise CircuitError(f"unknown signal(s) {', '.join(unknown)}", where="signals",
                                       hint=f"available: {', '.join(waves.names)}")
                waves = waves.select(job.signals or waves.names)
        except CircuitnsdsError as exc:
            status, error, waves = "failed", str(exc), None
        except MemoryError as exc:  # a limit of the worker (ulimit -v, a cgroup), not a bug
            status, error, waves = "failed", f"out of memory{f' ({exc})' if str(exc) else ''}", None
        except Exception as exc:  # a bug: still one row, not a dead sweep
            status, error, waves = "failed", f"internal error: {type(exc).__name__}: {exc}", None
    messages = list(dict.fromkeys(str(w.message) for w in caught))
    return {"index": point.index, "params": point.params, "values": values, "status": status,
            "error": error, "warnings": "\n".join(messages), "seconds": time.perf_counter() - started,
            "cpu_seconds": time.process_time() - cpu,
            "waveforms": waves if job.keep_waveforms else None}
