"""ngspice's ``.meas tran`` statements and ``.four``, executed on circuitnsds's waveforms.

Supported (ngspice manual, "MEASUREMENTS"; semantics of ngspice 39's ``com_measure2.c``):

* ``.meas tran NAME AVG|RMS|MIN|MAX|PP|INTEG|MIN_AT|MAX_AT OUT [FROM=t] [TO=t] [TD=t]``:
  AVG is the trapezoidal average over the grid points inside the window, RMS and INTEG
  integrate the piecewise-linear curve with the window's ends interpolated, MIN/MAX (and
  their instants, MIN_AT/MAX_AT: the last of equal ones, as ngspice) are taken over the
  grid points inside the window; PP is
  MAX − MIN. ``TD`` moves the window's start (``max(FROM, TD)``).
* ``.meas tran NAME WHEN OUT=VAL [RISE=n|FALL=n|CROSS=n|...=LAST] [TD=t] [FROM=t] [TO=t]``:
  the instant of that crossing (linear interpolation between grid points); ``OUT=OUT2``
  compares two signals. Without RISE/FALL/CROSS: the first crossing. As in ngspice, a
  sample equal to VAL counts as reaching it, so a stretch lying at VAL counts a crossing at
  each sample; such a crossing has no instant and fails ("out of interval", as ngspice's).
* ``.meas tran NAME FIND OUT AT=t`` and ``FIND OUT WHEN OUT2=VAL ...``: the value of OUT there;
  ``DERIV OUT AT=t`` / ``DERIV OUT WHEN ...``: its time derivative there (the slope of the
  grid segment that holds the instant).
* ``.meas tran NAME TRIG OUT VAL=v [TD RISE FALL CROSS] TARG OUT VAL=v [...]`` (or
  ``TRIG AT=t``): the time from the trigger crossing to the target crossing.
* ``.meas tran NAME PARAM='expr'``: an expression of the measurements before it, by name.
* In place of any ``OUT``: ``par('expr')``, an expression of the run's signals (``v(a)*i(r1)``)
  evaluated at every grid point, as ngspice's vector expression; a WHEN (TRIG, TARG) level
  may name an earlier measurement (``WHEN v(2)=ymax``): its value.

The lines are read into specifications by :mod:`circuitnsds.frontend.cards.meas`.
``OUT`` is ``v(node)``, ``v(a,b)`` or ``i(element)`` (any circuitnsds signal). Results print as
ngspice prints them (``name = value`` with the window or instant). ``.four FREQ OUT ...`` prints
the first nine harmonics of each output over the last period, as ngspice's Fourier analysis.
"""

from __future__ import annotations

import math
from collections import ChainMap
from dataclasses import dataclass, field, replace

import numpy as np

from circuitnsds.output.measure import MeasurementError, series, window
from circuitnsds.output.waveforms import Waveforms


@dataclass
class MeasureResult:
    """A measurement's value and ngspice's printed line.

    Attributes:
        name: the measurement's name.
        value: the result [unit of the signal, its integral, or s]; NaN when the condition
            never holds (ngspice then prints an error and no value).
        line: the line as ngspice prints it (``name = value ...``) or its failure message.
        extra: the instants printed with it (``from``/``to``/``at``/``targ``/``trig``).
    """

    name: str
    value: float
    line: str
    extra: dict[str, float] = field(default_factory=dict)


def crossing_time(waves: Waveforms, condition) -> float:
    """The instant [s] where ``condition`` holds (NaN if it never does)."""
    if condition.at is not None:
        return float(condition.at)
    time, values = series(waves, condition.signal)
    if isinstance(condition.level, str):
        values = values - series(waves, condition.level)[1]
        level = 0.0
    else:
        level = float(condition.level)
    start = max(condition.delay, condition.start if condition.start is not None else -math.inf)
    keep = time >= start
    if condition.stop is not None:
        keep &= time <= condition.stop
    t, v = time[keep], values[keep] - level
    if t.size < 2:
        return math.nan
    above = v[0] >= 0
    found: list[float] = []
    for k in range(1, t.size):
        rising = not above and v[k] >= 0
        falling = above and v[k] <= 0
        if not (rising or falling):
            continue
        above = rising
        if (condition.direction == "rise" and not rising) or (condition.direction == "fall"
                                                            and not falling):
            continue
        slope = v[k] - v[k - 1]
        # a segment lying at the level (both ends equal to it) is counted, as ngspice counts
        # it, but has no crossing instant: ngspice's interpolation is 0/0 there, "out of
        # interval" (placing it at t[k] put a crossing at every sample of a flat stretch)
        instant = math.nan if slope == 0 else t[k - 1] - v[k - 1] * (t[k] - t[k - 1]) / slope
        found.append(float(instant))
        if condition.count in (0, len(found)):
            return found[-1]
    if condition.count < 0 and found:  # RISE=LAST (frontend.cards.meas.LAST)
        return found[-1]
    return math.nan


def _value_at(waves: Waveforms, signal: str, instant: float) -> float:
    time, values = series(waves, signal)
    if not time[0] <= instant <= time[-1]:
        return math.nan
    return float(np.interp(instant, time, values))


def _slope_at(waves: Waveforms, signal: str, instant: float) -> float:
    time, values = series(waves, signal)
    if not time[0] <= instant <= time[-1]:
        return math.nan
    k = int(np.clip(np.searchsorted(time, instant, side="right") - 1, 0, time.size - 2))
    return float((values[k + 1] - values[k]) / (time[k + 1] - time[k]))


def run_measurement(spec, waves: Waveforms) -> MeasureResult:
    """Execute one measurement on ``waves``; a condition that never holds gives NaN and
    ngspice's message (``out of interval``)."""
    derived = getattr(spec, "derived", None)
    if derived:  # par('expr') signals: computed on the run's grid, added beside its own
        computed = {token: function(lambda name: series(waves, name)[1] if name != "time"
                                    else waves.time) for token, function in derived.items()}
        waves = replace(waves, signals=ChainMap(computed, waves.signals))
    try:
        return _run(spec, waves)
    except MeasurementError as exc:
        raise MeasurementError(exc.message, where=str(spec.location or ".meas"),
                               hint=exc.hint) from None


def _line(name: str, value: float, **extra: float) -> str:
    return f"{name:<20}=  {value:e}" + "".join(f" {key}=  {number:e}" for key, number in extra.items())


def _failed(spec) -> MeasureResult:
    return MeasureResult(spec.name, math.nan,
                         f"Error: measure  {spec.name}  {spec.kind.upper()} : out of interval")


def _run(spec, waves: Waveforms) -> MeasureResult:
    kind = spec.kind
    if kind not in {"when", "find", "deriv", "trig"}:  # AVG RMS MIN MAX PP INTEG MIN_AT MAX_AT
        time, values = series(waves, spec.signal)
        start = max(spec.delay, spec.start if spec.start is not None else time[0])
        stop = spec.stop if spec.stop else time[-1]
        inside = (time >= start) & (time <= stop)
        if inside.sum() < 1 or start >= stop:
            return _failed(spec)
        t, v = time[inside], values[inside]
        if kind == "avg":
            if t.size < 2:
                return _failed(spec)
            value = float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(t)) / (t[-1] - t[0]))
            return MeasureResult(spec.name, value, _line(spec.name, value, **{"from": start, "to": t[-1]}),
                                 {"from": start, "to": float(t[-1])})
        if kind in {"rms", "integ"}:
            wt, wv = window(time, values, start, min(stop, time[-1]))
            integral = float(np.sum(0.5 * (wv[1:] + wv[:-1]) * np.diff(wt)))
            if kind == "integ":
                value = integral
            else:
                squares = float(np.sum(np.diff(wt) * (wv[1:] ** 2 + wv[1:] * wv[:-1] + wv[:-1] ** 2) / 3))
                value = math.sqrt(squares / (wt[-1] - wt[0]))
            extra = {"from": float(wt[0]), "to": float(wt[-1])}
            return MeasureResult(spec.name, value, _line(spec.name, value, **extra), extra)
        # of equal extremes, the last (ngspice compares with <= and >=)
        low, high = v.size - 1 - int(np.argmin(v[::-1])), v.size - 1 - int(np.argmax(v[::-1]))
        if kind == "pp":
            value = float(v[high] - v[low])
            extra = {"from": start, "to": stop}
            return MeasureResult(spec.name, value, _line(spec.name, value, **extra), extra)
        index = low if kind.startswith("min") else high
        if kind.endswith("_at"):
            value = float(t[index])
            return MeasureResult(spec.name, value, _line(spec.name, value, **{"with": float(v[index])}),
                                 {"with": float(v[index])})
        value = float(v[index])
        return MeasureResult(spec.name, value, _line(spec.name, value, at=float(t[index])),
                             {"at": float(t[index])})
    if kind == "when":
        value = crossing_time(waves, spec.when)
        if math.isnan(value):
            return _failed(spec)
        return MeasureResult(spec.name, value, _line(spec.name, value))
    if kind in {"find", "deriv"}:
        instant = crossing_time(waves, spec.when)
        if math.isnan(instant):
            return _failed(spec)
        value = (_value_at if kind == "find" else _slope_at)(waves, spec.signal, instant)
        if math.isnan(value):
            return _failed(spec)
        return MeasureResult(spec.name, value, _line(spec.name, value), {"at": instant})
    trig, targ = crossing_time(waves, spec.trig), crossing_time(waves, spec.targ)
    if math.isnan(trig) or math.isnan(targ):
        return _failed(spec)
    value = targ - trig
    return MeasureResult(spec.name, value, _line(spec.name, value, targ=targ, trig=trig),
                         {"targ": targ, "trig": trig})


def run_measurements(specs: list, waves: Waveforms) -> list[MeasureResult]:
    """Every measurement of a netlist, in order; a ``PARAM`` one from the values of those
    before it (a failed one, or an unknown name, fails it as in ngspice)."""
    results: list[MeasureResult] = []
    for spec in specs:
        known = {r.name: r.value for r in results if not math.isnan(r.value)}
        if spec.kind != "param":
            results.append(run_measurement(_levels_measured(spec, known, waves), waves))
            continue
        try:
            value = float(spec.formula(known))
        except ValueError as exc:  # an expression error: a name not measured, a division by 0
            results.append(MeasureResult(spec.name, math.nan, f"Error: measure  {spec.name}  PARAM : {exc}"))
            continue
        results.append(MeasureResult(spec.name, value, _line(spec.name, value)))
    return results


def _levels_measured(spec, known: dict[str, float], waves: Waveforms):
    """``spec`` with each WHEN/TRIG/TARG level that names an earlier measurement (``WHEN
    v(2)=ymax``) replaced by that measurement's value, as ngspice replaces a vector of its
    script; a level naming a signal stays a signal."""
    changed = {}
    for part in ("when", "trig", "targ"):
        crossing = getattr(spec, part, None)
        level = getattr(crossing, "level", None)
        if isinstance(level, str) and level in known and level not in waves:
            changed[part] = replace(crossing, level=known[level])
    return replace(spec, **changed) if changed else spec


FOURIER_HARMONICS = 9
"""Harmonics above DC: ngspice 39's default table has 10 rows, DC and harmonics 1-9."""


def fourier_coefficients(waves: Waveforms, signal: str, frequency: float,
                         count: int = FOURIER_HARMONICS, samples: int = 1024
                         ) -> tuple[float, np.ndarray, np.ndarray]:
    """``(dc, magnitudes, phases [degrees])`` of harmonics 1..``count`` over the last period.

    The period is resampled uniformly (linear interpolation) on ``samples`` points; phases
    are SPICE's: relative to a sine, ``atan2(cosine part, sine part)`` (a sine has 0°).
    """
    period = 1.0 / frequency
    t1 = float(waves.time[-1])
    t, y = window(waves, signal, t1 - period, t1)
    uniform = t1 - period + period * np.arange(samples) / samples
    spectrum = np.fft.rfft(np.interp(uniform, t, y)) / samples
    phase0 = 2 * np.pi * (t1 - period) * frequency * np.arange(1, count + 1)
    coefficients = 2.0 * spectrum[1:count + 1] * np.exp(-1j * phase0)  # cos - j sin parts
    cosine, sine = coefficients.real, -coefficients.imag
    return (float(spectrum[0].real), np.hypot(cosine, sine),
            np.degrees(np.arctan2(cosine, sine)))


def fourier(spec, waves: Waveforms) -> str:
    """ngspice-style Fourier table of each output over the last period of the run.

    Raises:
        MeasurementError: at the ``.four`` line: an unknown signal, or a run shorter than
            one period of the fundamental.
    """
    from circuitnsds.units import format_si

    where = str(spec.location or ".four")
    span = float(waves.time[-1] - waves.time[0])
    if span < (1 - 1e-9) / spec.frequency:
        raise MeasurementError(
            f"the run ({format_si(float(waves.time[0]), 's')} .. {format_si(float(waves.time[-1]), 's')}) "
            f"is shorter than one period of the fundamental ({format_si(spec.frequency, 'Hz')}: "
            f"{format_si(1 / spec.frequency, 's')})", where=where,
            hint="simulate at least one period (the table is of the last one)")
    blocks = []
    for signal in spec.signals:
        try:
            dc, magnitudes, phases = fourier_coefficients(waves, signal, spec.frequency)
        except MeasurementError as exc:
            raise MeasurementError(exc.message, where=where, hint=exc.hint) from None
        fundamental = magnitudes[0]
        thd = (math.sqrt(float(np.sum(magnitudes[1:] ** 2))) / fundamental * 100
               if fundamental else math.nan)
        lines = [f"Fourier analysis for {signal}:",
                 f"No. Harmonics: {FOURIER_HARMONICS + 1}, THD: {thd:g} %, Gridsize: 1024, "
                 "Interpolation Degree: 1",
                 "Harmonic Frequency   Magnitude   Phase       Norm. Mag   Norm. Phase",
                 "-------- ---------   ---------   -----       ---------   -----------",
                 f" 0       0           {dc:<11.6g} 0           0           0"]
        for k in range(FOURIER_HARMONICS):
            norm = magnitudes[k] / fundamental if fundamental else math.nan
            lines.append(f" {k + 1:<7d} {(k + 1) * spec.frequency:<11.6g} {magnitudes[k]:<11.6g} "
                         f"{phases[k]:<11.6g} {norm:<11.6g} {phases[k] - phases[0]:.6g}")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)
