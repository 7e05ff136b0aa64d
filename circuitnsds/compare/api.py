"""``compare()``: one netlist in circuitnsds (ideal devices) and in ngspice (Shockley diodes)."""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from circuitnsds.compare.errors import CompareError
from circuitnsds.compare.metrics import (
    SignalMetrics,
    flag_negligible,
    resample,
    signal_metrics,
    window_mask,
)
from circuitnsds.compare.ngspice import NgspiceRun, ngspice_version, pyspice_version, run_ngspice
from circuitnsds.compare.translate import DiodeOverrides, ngspice_vector, translate_netlist
from circuitnsds.output.waveforms import Waveforms

#: Element letters whose currents are compared by default (with every node voltage).
DEFAULT_CURRENT_LETTERS = ("v", "l", "d")


@dataclass
class RunComparison:
    """One ngspice run (one set of diode overrides) measured against circuitnsds.

    Attributes:
        ngspice: the run itself (status, failure message and time, runtime, raw waveforms).
        metrics: signal -> :class:`SignalMetrics`; empty when ngspice did not finish
            (a failure is reported, not measured).
        resampled: signal -> ngspice's values on circuitnsds's time grid [V or A]
            (NaN where ngspice has no value: after it stopped).
        measurements: ``.meas`` name -> (circuitnsds's value, ngspice's printed value; NaN
            where one of them has none).
    """

    ngspice: NgspiceRun
    metrics: dict[str, SignalMetrics] = field(default_factory=dict)
    resampled: dict[str, np.ndarray] = field(default_factory=dict)
    measurements: dict[str, tuple[float, float]] = field(default_factory=dict)

    @property
    def overrides(self) -> DiodeOverrides:
        return self.ngspice.overrides

    @property
    def ok(self) -> bool:
        return self.ngspice.ok

    def worst(self, measure: str = "error") -> SignalMetrics | None:
        """The signal with the largest ``measure`` (``"error"``, ``"nrms"``, ``"rrms"`` or
        ``"nmax"``), negligible
        signals left out; ``None`` if nothing was measured."""
        candidates = [metric for metric in self.metrics.values() if not metric.negligible]
        if not candidates:
            return None
        return max(candidates, key=lambda m: getattr(m, measure))


@dataclass
class Comparison:
    """circuitnsds's transient of a netlist against one or more ngspice runs of it.

    Attributes:
        netlist: the file name (or ``<text>``).
        title: the netlist title.
        signals: the compared signals, circuitnsds names.
        window: ``(t0, t1)`` [s] over which every measure is taken.
        circuitnsds: circuitnsds's waveforms (the reference grid).
        circuitnsds_seconds: wall time of ``Circuit.transient()`` [s] (one-time costs of
            the process, such as loading compiled kernels, excluded by a warm-up run).
        runs: one per value of the overrides grid (e.g. per emission coefficient N).
        ngspice_version, pyspice_version: of the ngspice runs.
        notes: what was changed in the netlist for ngspice.
        theta: θ of circuitnsds's run.
        ngspice_options: the ``.options`` text added for ngspice ("" for none).
    """

    netlist: str
    title: str
    signals: list[str]
    window: tuple[float, float]
    circuitnsds: Waveforms
    circuitnsds_seconds: float
    runs: list[RunComparison]
    ngspice_version: str = ""
    pyspice_version: str = ""
    notes: list[str] = field(default_factory=list)
    theta: float = 1.0
    ngspice_options: str = ""

    @property
    def run(self) -> RunComparison:
        """The only run (raises ``ValueError`` for a convergence study with several)."""
        if len(self.runs) != 1:
            raise ValueError(f"this comparison has {len(self.runs)} ngspice runs; use .runs")
        return self.runs[0]

    @property
    def metrics(self) -> dict[str, SignalMetrics]:
        """Metrics of the only run (see :attr:`run`)."""
        return self.run.metrics

    def to_dict(self) -> dict:
        """Everything a report needs, JSON-serialisable (NaN becomes ``None``)."""
        from circuitnsds.compare.report import comparison_dict

        return comparison_dict(self)

    def to_json(self, path: str | Path) -> None:
        from circuitnsds.compare.report import write_json

        write_json(self, path)

    def table(self) -> str:
        """The text report (as printed by ``circuitnsds compare``)."""
        from circuitnsds.compare.report import format_table

        return format_table(self)

    def plot(self, path: str | Path) -> None:
        """PNG: per signal, both waveforms overlaid (left) and ngspice − circuitnsds (right)."""
        from circuitnsds.compare.report import plot_overlay

        plot_overlay(self, path)

    def plot_convergence(self, path: str | Path) -> None:
        """PNG: normalised errors and ngspice's runtime against the swept parameter."""
        from circuitnsds.compare.report import plot_convergence

        plot_convergence(self, path)


def compare(
    netlist: str | Path,
    *,
    signals: Iterable[str] | None = None,
    window: tuple[float, float] | None = None,
    n: float | Sequence[float] | None = None,
    is_: float | None = None,
    rs: float | None = None,
    cjo: float | None = None,
    step: float | None = None,
    stop: float | None = None,
    theta: float | None = None,
    ngspice_options: str = "",
    ltspice: bool | None = None,
) -> Comparison:
    """Run a netlist in circuitnsds and in ngspice and measure the difference.

    circuitnsds runs once (ideal devices); ngspice runs once per value of ``n``
    (Shockley diodes), on a copy of the netlist translated for it (see
    :mod:`circuitnsds.compare.translate`). ngspice's adaptive time points are
    interpolated linearly onto circuitnsds's grid, and each signal is measured
    over ``window`` (see :mod:`circuitnsds.compare.metrics`). An ngspice run that
    stops early is reported in its :class:`RunComparison` (``ngspice.status``,
    ``message``, ``stopped_at``), never raised.

    Args:
        netlist: a netlist file or netlist text.
        signals: circuitnsds signal names; default every node voltage and the
            currents of voltage sources, inductors and diodes.
        window: ``(t0, t1)`` [s]; default the whole output span.
        n: emission coefficient(s) forced on every diode model for ngspice; a
            sequence makes a convergence study (one ngspice run per value). With ``n``,
            circuitnsds reads SPICE diode models as their limit N -> 0 (``.options
            diode=limit``: ideal diodes with their series resistance RS); without it, as the
            PWL diodes fitted to them, compared with ngspice at the models' own N.
        is_, rs, cjo: saturation current [A], series resistance [Ω], junction
            capacitance [F] forced on every diode model (``None``: the netlist's).
        step, stop: ``.tran`` TSTEP and TSTOP [s] for both simulators (default: the netlist's).
        theta: θ of circuitnsds's θ-method (default: ``.options theta``, else 1).
        ngspice_options: an ``.options`` line for ngspice only, e.g. ``"method=gear"``
            (see docs/compare.md on trapezoidal ringing).
        ltspice: run ngspice in its LTspice compatibility mode (``set ngbehavior=lta``), in
            which LTspice PWL diode models (``Ron``, ``Vfwd``, ``Vrev``, ``Rrev`` ...) mean the
            same device as in circuitnsds. ``None`` (default): when the netlist has such
            models and ``n`` is not given; with ``n`` (a convergence study towards the ideal
            diode) those models are Shockley diodes for ngspice, their PWL parameters dropped.

    Raises:
        NetlistError, CircuitError, SimulationError: from reading or running circuitnsds.
        CompareError: unknown signal, bad window or bad override.
        NgspiceUnavailable: PySpice or ngspice's shared library is missing (the hint
            says how to install them).
    """
    from circuitnsds.frontend.build import CircuitBuilder

    source = netlist
    grid = _grid(n)
    overrides = [DiodeOverrides(n=value, is_=is_, rs=rs, cjo=cjo) for value in grid]
    version = ngspice_version()  # a missing ngspice is reported before circuitnsds runs
    circuit = CircuitBuilder.load(source).build()
    fitted = n is not None and any(getattr(model, "shockley", None) is not None
                                   for model in circuit.models.values())
    if fitted:  # a study in N converges to the N -> 0 limit (RS kept), not to the fitted diode
        circuit = CircuitBuilder.load(source).build(options={"diode": "limit"})
    if signals is not None:  # refused before the run (a long one), not after it
        _check_signal_names(circuit, signals)
    _warm_up()
    started = time.perf_counter()
    waves = circuit.transient(step, stop, theta=theta)
    seconds = time.perf_counter() - started
    chosen = _signals(waves, signals)
    span = (float(waves.time[0]), float(waves.time[-1]))
    chosen_window = _window(window, span, waves.time)
    stop_time = stop if stop is not None else span[1]
    saves = sorted({save for name in chosen if (save := ngspice_vector(name)[1]) is not None})
    if ltspice is None:
        ltspice = n is None and any(str(getattr(model, "origin", "")).startswith("LTspice")
                                    for model in circuit.models.values())
    off_resistance = 1.0 / float(circuit.options.get("gmin", 1e-12))
    ammeters = sorted({name[2:-1].split(".")[-1] for name in chosen if _element_letter(name) == "d"})

    if step is None and "tran" in circuit.analyses:
        step = circuit.analyses["tran"].step  # LTspice's .tran 0 TSTOP / .tran TSTOP: ngspice needs TSTEP > 0
    runs, notes = [], []
    for override in overrides:
        translation = translate_netlist(source, overrides=override, step=step, stop=stop,
                                        saves=saves, ammeters=ammeters, options=ngspice_options,
                                        ltspice=ltspice, off_resistance=off_resistance,
                                        measures=bool(circuit.measurements))
        notes = notes or ((["ngspice runs in its LTspice compatibility mode (set "
                            "ngbehavior=lta): the LTspice PWL diode models run as its "
                            "sidiode code model"] if ltspice else [])
                          + (["circuitnsds reads the SPICE diode models as their N -> 0 "
                              "limit (diode=limit: ideal diodes with their RS), the limit of "
                              "the study in N"] if fitted else [])
                          + translation.notes)
        result = run_ngspice(translation.text, chosen, stop_time, overrides=override,
                             title=circuit.title, ltspice=ltspice)
        if ammeters and not result.ok:  # compare's own edit may be what ngspice failed on
            as_written = translate_netlist(source, overrides=override, step=step, stop=stop,
                                           saves=sorted({*saves, *_junction_currents(chosen)}),
                                           options=ngspice_options, ltspice=ltspice,
                                           off_resistance=off_resistance,
                                           measures=bool(circuit.measurements))
            failure = result.message
            result = run_ngspice(as_written.text, chosen, stop_time, overrides=override,
                                 title=circuit.title, ltspice=ltspice)
            notes.append(f"ngspice failed on the netlist with compare's 0 V ammeters in series "
                         f"with {', '.join(ammeters)} ({failure}); it ran again on the netlist "
                         "as written, where a diode's current is ngspice's @d[id] (its junction "
                         "current at the last linearisation)"
                         + ("" if result.ok else ", and failed there too: its own failure"))
        runs.append(_measure(result, waves, chosen, chosen_window))
        if circuit.measurements:
            from circuitnsds.output.meas import run_measurements

            ours = {r.name: r.value for r in run_measurements(circuit.measurements, waves)}
            runs[-1].measurements = {name: (value, result.measurements.get(name, float("nan")))
                                     for name, value in ours.items()}
    return Comparison(
        netlist=str(source) if "\n" not in str(source) else "<text>",
        title=circuit.title,
        signals=chosen,
        window=chosen_window,
        circuitnsds=waves,
        circuitnsds_seconds=seconds,
        runs=runs,
        ngspice_version=version,
        pyspice_version=pyspice_version(),
        notes=notes,
        theta=float(theta if theta is not None else getattr(circuit, "options", {}).get("theta", 1.0)),
        ngspice_options=ngspice_options.strip(),
    )


_WARM_UP = """warm-up: one diode, a few steps
V1 in 0 SIN(0 1 1k)
D1 in out d
R1 out 0 1k
C1 out 0 1u
.model d D
.tran 10u 50u
.end
"""
_warmed_up = False


def _warm_up() -> None:
    """Run a tiny circuit once per process, so that one-time costs (lazy imports, loading
    compiled kernels) are not counted in circuitnsds's runtime, as ngspice's library
    loading and parsing are not counted in its runtime."""
    global _warmed_up
    if _warmed_up:
        return
    import warnings

    from circuitnsds.errors import CircuitnsdsError
    from circuitnsds.frontend.build import CircuitBuilder

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            CircuitBuilder.load(_WARM_UP).build().transient()
        except CircuitnsdsError:  # pragma: no cover - only timing depends on it
            pass
    _warmed_up = True


def _grid(n: float | Sequence[float] | None) -> list[float | None]:
    if n is None:
        return [None]
    if isinstance(n, int | float):
        return [float(n)]
    values = [float(value) for value in n]
    if not values:
        raise CompareError("no emission coefficient given", where="n", hint="e.g. n=[1, 0.3, 0.1]")
    return values


def _check_signal_names(circuit, signals: Iterable[str]) -> None:
    """Refuse, before the run, signals the run will not have: a differential ``v(a,b)``
    (ngspice and circuitnsds each have ``v(a)`` and ``v(b)``) or an unknown name."""
    chosen = [name.strip().lower() for name in signals if name.strip() and name.strip().lower() != "time"]
    differential = [name for name in chosen if name.startswith("v(") and "," in name]
    if differential:
        raise CompareError(f"differential voltage(s) {', '.join(differential)} are not compared",
                           where="signals", hint="compare each node's voltage, e.g. "
                           + ", ".join(f"v({node.strip()})" for node in differential[0][2:-1].split(",")))
    available = list(circuit.mlcs().output_names) + [
        f"i({element.name})" for element in circuit.elements if hasattr(element, "capacitance")]
    unknown = [name for name in chosen if name not in available]
    if unknown:
        raise CompareError(f"unknown signal(s) {', '.join(unknown)}", where="signals",
                           hint=f"available: {', '.join(available)}")


def _signals(waves: Waveforms, signals: Iterable[str] | None) -> list[str]:
    if signals is None:
        return [name for name in waves.names
                if name.startswith("v(") or _element_letter(name) in DEFAULT_CURRENT_LETTERS]
    chosen = [name.strip().lower() for name in signals if name.strip() and name.strip().lower() != "time"]
    unknown = [name for name in chosen if name not in waves]
    if unknown:
        raise CompareError(f"unknown signal(s) {', '.join(unknown)}", where="signals",
                           hint=f"available: {', '.join(waves.names)}")
    if not chosen:
        raise CompareError("no signal to compare", where="signals",
                           hint=f"available: {', '.join(waves.names)}")
    return chosen


def _junction_currents(signals: list[str]) -> list[str]:
    """The ``@d[id]`` vectors of the diode currents among ``signals`` (saved when ngspice runs
    the netlist as written, without ammeters)."""
    return [save for name in signals if _element_letter(name) == "d"
            and (save := ngspice_vector(name, ammeter=False)[1]) is not None]


def _element_letter(signal: str) -> str:
    """``i(x1.d1)`` -> ``d``: the type letter of the element a current belongs to."""
    return signal[2:-1].split(".")[-1][:1] if signal.startswith("i(") else ""


def _window(window: tuple[float, float] | None, span: tuple[float, float],
            grid: np.ndarray) -> tuple[float, float]:
    if window is None:
        return span
    t0, t1 = (float(value) for value in window)
    if not t0 < t1:
        raise CompareError(f"the window {t0:g}:{t1:g} s is empty", where="window",
                           hint="give t0:t1 with t0 < t1, in seconds (e.g. 20m:40m)")
    clipped = (max(t0, span[0]), min(t1, span[1]))
    if not window_mask(grid, clipped).any() or clipped[0] > clipped[1]:
        raise CompareError(f"the window {t0:g}:{t1:g} s lies outside the simulated span "
                           f"{span[0]:g}:{span[1]:g} s", where="window")
    return clipped


def _measure(result: NgspiceRun, waves: Waveforms, signals: list[str],
             window: tuple[float, float]) -> RunComparison:
    comparison = RunComparison(result)
    if result.waveforms is None:
        return comparison
    for name in signals:
        if name in result.waveforms.signals:
            comparison.resampled[name] = resample(result.waveforms.time, result.waveforms[name], waves.time)
    if result.ok:
        metrics = {name: _on_both_grids(signal_metrics(waves.time, waves[name], values, window, name),
                                        waves, result, name, window)
                   for name, values in comparison.resampled.items()}
        comparison.metrics = flag_negligible(metrics)
    return comparison


def _on_both_grids(ours: SignalMetrics, waves: Waveforms, result: NgspiceRun, name: str,
                   window: tuple[float, float]) -> SignalMetrics:
    """``ours`` (measured on circuitnsds's grid) with the largest difference and ngspice's
    ripple taken over ngspice's own time points too (circuitnsds's values interpolated there):
    on a grid coarser than the circuit's dynamics ngspice's peaks fall between our points (a
    series RLC stepped at 100 µs: nMAX 1.3 % on our grid while the peaks differed by 8.4 V)."""
    time = np.asarray(result.waveforms.time, dtype=float)
    theirs = np.asarray(result.waveforms[name], dtype=float)
    mask = (time >= window[0]) & (time <= window[1]) & np.isfinite(theirs)
    if not mask.any():
        return ours
    ref = resample(waves.time, waves[name], time[mask])
    valid = np.isfinite(ref)
    if not valid.any():
        return ours
    diff = np.abs(theirs[mask][valid] - ref[valid])
    worst = int(np.argmax(diff))
    ripple = float(theirs[mask].max() - theirs[mask].min())
    changes: dict[str, float] = {"ripple_other": max(ours.ripple_other, ripple)}
    changes["ripple_diff"] = changes["ripple_other"] - ours.ripple_ref
    if diff[worst] / ours.scale > ours.nmax:
        changes.update(nmax=float(diff[worst]) / ours.scale, max_at=float(time[mask][valid][worst]))
    return replace(ours, **changes)
