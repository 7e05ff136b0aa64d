"""Measurements on waveforms: mean, RMS, extremes, ripple, average power, THD.

Every function takes either a :class:`~circuitnsds.Waveforms` and a signal name
(``v(out)``, ``i(l1)``, or ``v(a,b)`` for ``v(a) - v(b)``), or a time array [s] and a
value array::

    from circuitnsds import measure
    measure.mean(waves, "v(out)", 0.1, 0.2)          # time average over 0.1 s .. 0.2 s
    measure.rms(waves.time, waves["i(l1)"])          # over the whole run
    measure.thd(waves, "v(in)", 50.0)                # fundamental 50 Hz, last whole periods

Windows ``(t0, t1)`` are in seconds and default to the whole run. Inside a window
the waveform is the piecewise-linear curve through the samples (the grid may be
non-uniform; the window's ends are interpolated), and averages are integrals of it
(trapezoidal rule) divided by the window's length. With ``period=T`` the window
is shortened to the largest whole number of periods that ends at ``t1``.

``evaluate("ripple(v(out), 0.1, 0.2)", waves, circuit)`` evaluates the text form
used by ``circuitnsds run --measure`` (see :data:`FUNCTIONS` and docs/usage.md).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from circuitnsds.errors import CircuitnsdsError
from circuitnsds.output.waveforms import Waveforms
from circuitnsds.units import format_si
from circuitnsds.values import parse_value

DEFAULT_SAMPLES_PER_PERIOD = 4096
"""Uniform samples per period on which :func:`harmonics` resamples before the FFT."""


class MeasurementError(CircuitnsdsError):
    """A measurement cannot be made: unknown signal, bad window, unknown function."""


def _trapezoid(y: np.ndarray, t: np.ndarray) -> float:
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(t)))


def series(source: Waveforms | np.ndarray, signal: str | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(time [s], values)`` of ``signal``: from a :class:`Waveforms` and a signal's name
    (``v(a,b)`` the difference of two node voltages, as in SPICE), or from two arrays
    (``source`` the time, ``signal`` the values). The reader every measurement and the CLI's
    extra columns use.

    Raises:
        MeasurementError: ``source`` holds no signal of that name.
    """
    if isinstance(source, Waveforms):
        if not isinstance(signal, str):
            raise TypeError("with a Waveforms, give the signal by name, e.g. 'v(out)'")
        differential = re.fullmatch(r"\s*v\(\s*([^,()\s]+)\s*,\s*([^,()\s]+)\s*\)\s*", signal,
                                    flags=re.IGNORECASE)
        if differential:  # v(a,b) = v(a) - v(b), as in SPICE
            return np.asarray(source.time, dtype=float), element_voltage(
                source, tuple(node.lower() for node in differential.groups()))
        if signal not in source:
            raise MeasurementError(f"no signal {signal!r}", where="measure",
                                   hint=f"available: {', '.join(source.names)}")
        return np.asarray(source.time, dtype=float), np.asarray(source[signal], dtype=float)
    time, values = np.asarray(source, dtype=float), np.asarray(signal, dtype=float)
    if time.ndim != 1 or time.shape != values.shape or time.size < 2:
        raise MeasurementError("time and values must be 1-D arrays of the same length (>= 2)",
                               where="measure")
    return time, values


def window(
    source: Waveforms | np.ndarray,
    signal: str | np.ndarray,
    t0: float | None = None,
    t1: float | None = None,
    *,
    period: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The samples of a signal inside ``[t0, t1]``, with interpolated values at both ends.

    Args:
        source, signal: a Waveforms and a signal name, or time [s] and values arrays.
        t0, t1: the window [s] (default: the whole run).
        period: if given [s], ``t0`` moves up to ``t1 - n·period`` with ``n`` the
            largest whole number of periods that fits.

    Returns:
        ``(time, values)``, both starting at ``t0`` and ending at ``t1``.
    """
    time, values = series(source, signal)
    start, stop = float(time[0]), float(time[-1])
    t0 = start if t0 is None else float(t0)
    t1 = stop if t1 is None else float(t1)
    slack = 1e-9 * max(stop - start, abs(stop))
    if not t0 < t1:
        raise MeasurementError(f"window {t0:g} s .. {t1:g} s is empty", where="measure",
                               hint="give t0 < t1")
    if t0 < start - slack or t1 > stop + slack:
        raise MeasurementError(f"window {t0:g} s .. {t1:g} s is not inside the simulated time "
                               f"{start:g} s .. {stop:g} s", where="measure")
    t0, t1 = max(t0, start), min(t1, stop)
    if period is not None:
        if not period > 0:
            raise MeasurementError(f"period {period:g} s must be positive", where="measure")
        whole = np.floor((t1 - t0) / period * (1 + 1e-9))
        if whole < 1:
            raise MeasurementError(f"window {t0:g} s .. {t1:g} s is shorter than one period "
                                   f"({period:g} s)", where="measure",
                                   hint="widen the window or simulate longer")
        t0 = max(t1 - whole * period, start)
    inside = (time > t0) & (time < t1)
    ends = np.interp([t0, t1], time, values)
    return (np.concatenate([[t0], time[inside], [t1]]),
            np.concatenate([[ends[0]], values[inside], [ends[1]]]))


def mean(source, signal, t0=None, t1=None, *, period=None) -> float:
    """Time average ``(1/(t1-t0)) ∫ x dt`` over the window (unit of the signal)."""
    t, y = window(source, signal, t0, t1, period=period)
    return _trapezoid(y, t) / (t[-1] - t[0])


def rms(source, signal, t0=None, t1=None, *, period=None) -> float:
    """Root mean square ``sqrt((1/(t1-t0)) ∫ x² dt`` over the window (unit of the signal)."""
    t, y = window(source, signal, t0, t1, period=period)
    return float(np.sqrt(_trapezoid(y * y, t) / (t[-1] - t[0])))


def minimum(source, signal, t0=None, t1=None) -> float:
    """Smallest value in the window."""
    return float(window(source, signal, t0, t1)[1].min())


def maximum(source, signal, t0=None, t1=None) -> float:
    """Largest value in the window."""
    return float(window(source, signal, t0, t1)[1].max())


def peak_to_peak(source, signal, t0=None, t1=None) -> float:
    """``max - min`` in the window: the peak-to-peak ripple (unit of the signal)."""
    y = window(source, signal, t0, t1)[1]
    return float(y.max() - y.min())


ripple = peak_to_peak


def element_voltage(waves: Waveforms, element) -> np.ndarray:
    """``v(n1) - v(n2)`` [V] across an element's first two terminals (ground is 0 V); for a
    device built of parts (an IGBT, a thyristor) across its ``terminals``.

    ``element`` is an :class:`~circuitnsds.circuit.elements.Element` (``circuit.element("r1")``)
    or a pair of node names.
    """
    nodes = getattr(element, "terminals", None) or getattr(element, "nodes", element)
    values = []
    for node in nodes[:2]:
        if node in ("0", "gnd"):
            values.append(np.zeros_like(waves.time))
        elif f"v({node})" in waves:
            values.append(waves[f"v({node})"])
        else:
            raise MeasurementError(f"no voltage of node {node!r} in the results", where="measure",
                                   hint="measure on the full results, before --signals selects")
    return values[0] - values[1]


def power(waves: Waveforms, element, t0=None, t1=None, *, period=None) -> float:
    """Average power [W] absorbed by an element: mean of ``v·i`` over the window.

    Sign convention (SPICE's passive one): ``v = v(n1) - v(n2)`` across the element's
    first two terminals and ``i = i(name)`` flowing from ``n1`` through the element to
    ``n2``, so the power is positive when the element absorbs energy (a resistor,
    a conducting diode) and negative when it delivers it (a source feeding the
    circuit). For the average of a periodic regime give ``period`` (or a window of
    whole periods): a window cutting a period would add a part-period error.

    Args:
        waves: the results (with node voltages and the element's current).
        element: an :class:`~circuitnsds.circuit.elements.Element`, e.g. ``circuit.element("rload")``.
        t0, t1: the window [s] (default: the whole run).
        period: average over whole periods [s] ending at ``t1``.
    """
    name = f"i({element.name})"
    if name not in waves:
        raise MeasurementError(f"the results have no current {name}", where="measure",
                               hint=f"available: {', '.join(waves.names)}")
    return mean(waves.time, element_voltage(waves, element) * waves[name], t0, t1, period=period)


def harmonics(source, signal, frequency: float, t0=None, t1=None, *, count: int | None = None,
              samples_per_period: int = DEFAULT_SAMPLES_PER_PERIOD) -> np.ndarray:
    """Amplitudes of the DC term and the harmonics of a periodic signal.

    The whole periods of ``1/frequency`` that end at ``t1`` (at least one must fit in
    the window) are resampled onto a uniform grid of ``samples_per_period`` points per
    period (linear interpolation), and the FFT gives the Fourier coefficients.

    Returns:
        ``a`` with ``a[0]`` the mean and ``a[k]`` the peak amplitude of harmonic ``k``
        (``k·frequency``), for ``k`` up to ``count`` (default: ``samples_per_period/2 - 1``).
    """
    if not frequency > 0:
        raise MeasurementError(f"fundamental frequency {frequency:g} Hz must be positive",
                               where="measure")
    if count is not None and not count >= 1:
        raise MeasurementError(f"count={count} must be at least 1", where="measure",
                               hint="count is the highest harmonic, 1 the fundamental")
    period = 1.0 / frequency
    t, y = window(source, signal, t0, t1, period=period)
    periods = int(round((t[-1] - t[0]) / period))
    samples = samples_per_period * periods
    uniform = t[0] + (t[-1] - t[0]) * np.arange(samples) / samples
    spectrum = np.fft.rfft(np.interp(uniform, t, y)) / samples
    highest = samples_per_period // 2 - 1
    count = highest if count is None else min(int(count), highest)
    amplitudes = 2.0 * np.abs(spectrum[: (count + 1) * periods: periods])
    amplitudes[0] /= 2.0
    return amplitudes


def thd(source, signal, frequency: float, t0=None, t1=None, *, count: int | None = None,
        samples_per_period: int = DEFAULT_SAMPLES_PER_PERIOD) -> float:
    """Total harmonic distortion ``sqrt(sum_{k>=2} a_k²) / a_1`` as a fraction (not %).

    ``a_k`` are the harmonic amplitudes of :func:`harmonics` (same arguments): harmonics
    2 to ``count`` (default: all that the resampling resolves), relative to the
    fundamental at ``frequency`` [Hz]. A pure sine gives 0, a square wave
    ``sqrt(π²/8 - 1) ≈ 0.483``. ngspice's ``.four`` counts only harmonics 2 to 9.
    """
    if count is not None and not count >= 2:
        raise MeasurementError(f"count={count} leaves no harmonic to measure", where="measure",
                               hint="count is the highest harmonic counted, at least 2 (default: all)")
    a = harmonics(source, signal, frequency, t0, t1, count=count,
                  samples_per_period=samples_per_period)
    if not a[1] > 1e-6 * max(np.abs(a[1:]).max(), 1e-300):  # below: interpolation noise
        raise MeasurementError(f"the signal has no component at {frequency:g} Hz", where="measure",
                               hint="check the fundamental frequency")
    return float(np.sqrt(np.sum(a[2:] ** 2)) / a[1])


# --- the text form used by ``circuitnsds run --measure`` ---

@dataclass(frozen=True)
class Measurement:
    """A measured value: the expression, the value in SI units and its unit."""

    expression: str
    value: float
    unit: str

    def formatted(self) -> str:
        """The value for people: ``317.2 V``, ``48.34 %``."""
        if self.unit == "%":
            return f"{100 * self.value:.4g} %"
        return format_si(self.value, self.unit)


def _signal_unit(name: str) -> str:
    return {"v": "V", "i": "A"}.get(name.strip().lower()[:1], "") if "(" in name else ""


FUNCTIONS: dict[str, tuple[Callable, str, str]] = {
    # name: (function, argument pattern, unit rule)
    "mean": (mean, "SIGNAL[, T0, T1][, period=T]", "signal"),
    "avg": (mean, "SIGNAL[, T0, T1][, period=T]", "signal"),
    "rms": (rms, "SIGNAL[, T0, T1][, period=T]", "signal"),
    "min": (minimum, "SIGNAL[, T0, T1]", "signal"),
    "max": (maximum, "SIGNAL[, T0, T1]", "signal"),
    "pp": (peak_to_peak, "SIGNAL[, T0, T1]", "signal"),
    "ripple": (peak_to_peak, "SIGNAL[, T0, T1]", "signal"),
    "power": (power, "ELEMENT[, T0, T1][, period=T]", "W"),
    "thd": (thd, "SIGNAL, FREQ[, T0, T1][, count=N]", "%"),
}
"""The functions of :func:`evaluate` with their arguments (numbers take SPICE suffixes)."""

_KEYWORDS = {"period": float, "count": int}


def _split_arguments(text: str) -> list[str]:
    """Split at the commas that are not inside parentheses."""
    parts, depth, current = [], 0, ""
    for char in text:
        if char == "," and depth == 0:
            parts.append(current.strip())
            current = ""
            continue
        depth += (char == "(") - (char == ")")
        current += char
    parts.append(current.strip())
    return parts


@dataclass(frozen=True)
class ParsedMeasurement:
    """A measurement read from text: function name, subject (signal or element), numbers."""

    expression: str
    function: str
    subject: str
    numbers: tuple[float, ...]
    keywords: dict[str, float | int]


def _usage() -> str:
    return "; ".join(f"{name}({pattern})" for name, (_, pattern, _) in FUNCTIONS.items()
                     if name not in ("avg", "pp"))


def parse_measurement(expression: str) -> ParsedMeasurement:
    """Read ``FUNCTION(SUBJECT[, numbers][, key=value])`` (see :data:`FUNCTIONS`).

    Raises:
        MeasurementError: unknown function, missing subject, a bad number or keyword.
    """
    match = re.fullmatch(r"\s*([a-z]+)\s*\((.*)\)\s*", expression, flags=re.IGNORECASE | re.DOTALL)
    if not match or match.group(1).lower() not in FUNCTIONS:
        raise MeasurementError(f"cannot read the measurement {expression!r}", where="--measure",
                               hint=f"write one of: {_usage()}")
    name = match.group(1).lower()
    pattern = FUNCTIONS[name][1]
    arguments = _split_arguments(match.group(2))
    where = f"--measure {expression.strip()}"
    numbers: list[float] = []
    keywords: dict[str, float | int] = {}
    for argument in arguments[1:]:
        key, equals, value = argument.partition("=")
        key = key.strip().lower()
        if equals and (key not in _KEYWORDS or f"{key}=" not in pattern):
            raise MeasurementError(f"{name}() takes no {key}=", where=where,
                                   hint=f"write {name}({pattern})")
        try:
            if equals:
                number = parse_value(value)
                if _KEYWORDS[key] is int and number != int(number):
                    raise MeasurementError(f"{key}={value.strip()} is not a whole number",
                                           where=where, hint=f"write {name}({pattern})")
                keywords[key] = _KEYWORDS[key](number)
            else:
                numbers.append(parse_value(argument))
        except ValueError:
            raise MeasurementError(f"{argument!r} is not a number", where=where,
                                   hint="numbers may carry SPICE suffixes: 20m, 1k, 2.5u") from None
    required = 1 if name == "thd" else 0
    if not arguments[0] or len(numbers) not in (required, required + 2):
        raise MeasurementError(f"wrong arguments for {name}()", where=where,
                               hint=f"write {name}({pattern}); a window needs both T0 and T1")
    return ParsedMeasurement(expression.strip(), name, arguments[0].strip().lower(),
                             tuple(numbers), keywords)


def evaluate(expression: str | ParsedMeasurement, waves: Waveforms, circuit=None) -> Measurement:
    """Evaluate a measurement written as text, e.g. ``"ripple(v(out), 0.1, 0.2)"``.

    Args:
        expression: ``FUNCTION(ARGUMENTS)`` with a function of :data:`FUNCTIONS`
            (or what :func:`parse_measurement` made of it).
        waves: the results.
        circuit: the circuit, needed by ``power(ELEMENT)`` to find the element's nodes.
    """
    parsed = expression if isinstance(expression, ParsedMeasurement) else parse_measurement(expression)
    function, _, unit = FUNCTIONS[parsed.function]
    where = f"--measure {parsed.expression}"
    subject: object = parsed.subject
    try:
        if parsed.function == "power":
            if circuit is None:
                raise MeasurementError("power() needs the circuit to find the element's nodes",
                                       where=where)
            try:
                subject = circuit.element(parsed.subject)
            except KeyError:
                raise MeasurementError(f"no element {parsed.subject!r}", where=where,
                                       hint="give an element name, e.g. power(rload)") from None
        value = function(waves, subject, *parsed.numbers, **parsed.keywords)
    except MeasurementError as exc:
        raise MeasurementError(exc.message, where=where, hint=exc.hint) from None
    unit = _signal_unit(parsed.subject) if unit == "signal" else unit
    return Measurement(parsed.expression, value, unit)


def format_table(measurements: list[Measurement]) -> str:
    """A two-column text table: the expression and its value with units."""
    if not measurements:
        return ""
    width = max(len("measurement"), *(len(m.expression) for m in measurements))
    lines = [f"{'measurement':<{width}}  value"]
    lines += [f"{m.expression:<{width}}  {m.formatted()}" for m in measurements]
    return "\n".join(lines)


# --- loss table: where the input power goes ---

LOSS_COLUMNS = ("conduction", "turn_on", "turn_off", "recovery")
"""The parts of a loss row [W]: conduction and the switching energies per second."""


@dataclass(frozen=True)
class LossRow:
    """One element's share [W] (average over the window): ``kind`` is ``input`` (power
    delivered by a source), ``output`` (a load named by the caller), ``loss`` (absorbed by a
    resistor, switch, diode or controlled source) or ``stored`` (rate of change of the
    energy of inductors and capacitors, ``ΔE/T``).

    A loss row also has its parts (:data:`LOSS_COLUMNS`; ``None`` on the other rows): a
    device with a datasheet (``thermal=``) its conduction and switching powers, any other
    its whole power as conduction. ``electrical`` is what the circuit itself dissipates in
    it (``mean(v·i)``, the balance's term): the datasheet's switching energy is beyond it, as
    an ideal switch commutates without loss.
    """

    element: str
    kind: str
    power: float
    conduction: float | None = None
    turn_on: float | None = None
    turn_off: float | None = None
    recovery: float | None = None
    electrical: float | None = None

    @property
    def circuit_power(self) -> float:
        """The row's term in the electrical balance [W]."""
        return self.power if self.electrical is None else self.electrical


@dataclass
class LossTable:
    """The rows and the balance ``input − output − losses − stored`` [W] over ``[t0, t1]``.

    ``unaccounted`` is what no row holds: the energy dissipated in impulses (a capacitor
    discharged through an ideal switch or diode in zero time: ``½CΔv²``) and the numerical
    dissipation of the time stepper; ``relative`` is it divided by the input power. Losses
    from datasheets beyond the circuit's own (``datasheet_extra``: switching energy, a
    conduction table's excess) are not drawn from the ideal circuit's sources: the
    efficiency adds them to the input, as the real converter would draw them.
    """

    rows: list[LossRow]
    t0: float
    t1: float
    has_outputs: bool = True

    def total(self, kind: str) -> float:
        return float(sum(row.circuit_power for row in self.rows if row.kind == kind))

    @property
    def unaccounted(self) -> float:
        return (self.total("input") - self.total("output") - self.total("loss")
                - self.total("stored"))

    @property
    def relative(self) -> float:
        inflow = self.total("input")
        return self.unaccounted / inflow if inflow else float("nan")

    @property
    def datasheet_extra(self) -> float:
        """Loss [W] the datasheets add to the circuit's own (see the class docstring)."""
        return float(sum(row.power - row.circuit_power for row in self.rows if row.kind == "loss"))

    @property
    def efficiency(self) -> float:
        inflow = self.total("input") + self.datasheet_extra
        return self.total("output") / inflow if inflow else float("nan")

    def format(self) -> str:
        """The table as text; columns separated by at least one space whatever the widths,
        a share only where a source delivers net power, the efficiency only with loads named."""
        watts = [("power", "power")] + [(column, column.replace("_", "-")) for column in LOSS_COLUMNS]
        lines = [f"power balance over {format_si(self.t0, 's')} .. {format_si(self.t1, 's')}",
                 f"  {'element':<16} {'kind':<8}" + "".join(f" {title:>12}" for _, title in watts)
                 + f" {'share':>9}"]
        inflow = self.total("input")

        def share(power: float) -> str:
            return f"{100 * power / inflow + 0.0:>8.3g}%" if inflow > 0 else f"{'-':>9}"

        for row in self.rows:
            values = (getattr(row, field) for field, _ in watts)
            cells = "".join(f" {'' if value is None else format_si(value + 0.0, 'W'):>12}"
                            for value in values)
            lines.append(f"  {row.element:<16} {row.kind:<8}{cells} {share(row.power)}")
        blank = "".join(f" {'':>12}" for _ in LOSS_COLUMNS)
        lines.append(f"  {'unaccounted':<16} {'':<8} {format_si(self.unaccounted, 'W'):>12}{blank} "
                     f"{share(self.unaccounted)}  (impulses, numerical dissipation)")
        if any(row.kind == "loss" and row.turn_on is None for row in self.rows):
            lines.append("  turn-on, turn-off, recovery left blank: no datasheet (thermal= on the device's "
                         "model, docs/losses.md); the ideal devices commutate without loss")
        extra = self.datasheet_extra
        if extra:
            lines.append(f"  datasheet losses beyond the circuit's own: {format_si(extra, 'W')} "
                         "(switching energy, conduction tables; not drawn by the ideal circuit)")
        if not inflow > 0:
            lines.append("  no source delivers net power over the window: no shares, no "
                         + ("efficiency" if self.has_outputs else "outputs / inputs"))
        elif not self.has_outputs:
            lines.append("  name the loads (--losses rload) to get outputs / inputs")
        elif extra:
            lines.append(f"  efficiency {100 * self.efficiency:.4g} % (outputs / (inputs + "
                         "datasheet losses))")
        else:
            lines.append(f"  efficiency {100 * self.efficiency:.4g} % (outputs / inputs)")
        return "\n".join(lines)

    def to_csv(self, path) -> None:
        """Write the rows as CSV: ``element,kind,power_W,conduction_W,turn_on_W,turn_off_W,
        recovery_W`` (empty parts on rows that are not losses), then the ``unaccounted`` row."""
        import csv

        from circuitnsds.output.files import atomic_path

        def number(value: float | None) -> str:
            return "" if value is None else f"{value:.12g}"

        with atomic_path(path) as temporary, open(temporary, "w", encoding="utf-8",
                                                  newline="") as handle:
            writer = csv.writer(handle, lineterminator="\n")
            writer.writerow(["element", "kind", "power_W", *(f"{c}_W" for c in LOSS_COLUMNS)])
            for row in self.rows:
                writer.writerow([row.element, row.kind, number(row.power),
                                 *(number(getattr(row, c)) for c in LOSS_COLUMNS)])
            writer.writerow(["unaccounted", "balance", number(self.unaccounted), "", "", "", ""])


def _source_current(source, circuit, time: np.ndarray) -> np.ndarray:
    """An independent current source's current [A] at ``time`` (from ``n+`` through it to
    ``n-``): its function, with the omitted fields filled from the netlist's ``.tran`` line
    (else from the grid: its first step and its end), as the run fills them."""
    tran = circuit.analyses.get("tran") if hasattr(circuit, "analyses") else None
    defaults = ((tran.step, tran.stop) if tran is not None
                else (float(time[1] - time[0]), float(time[-1])))
    with np.errstate(all="ignore"):
        return np.asarray(source.function.resolve(*defaults).sample(time), dtype=float)


def losses(waves: Waveforms, circuit, t0=None, t1=None, *, period=None,
           outputs: tuple[str, ...] = (),
           devices: Callable[[float, float], dict[str, dict[str, float]]] | None = None
           ) -> LossTable:
    """Where the power delivered by the sources goes, element by element.

    Every element's average absorbed power ``mean(v·i)`` over the window (SPICE's passive
    sign convention, as :func:`power`): sources with a net delivery are ``input`` rows,
    elements named in ``outputs`` (the load resistors) ``output`` rows, the other resistors,
    switches (``Ron·i²`` closed, ``v²/Roff`` open), diodes (``Vfwd·i + Ron·i²``), IGBTs and
    thyristors (one row each, their on-state diode included: ``(V0 + r·i)·i``) and
    controlled sources ``loss`` rows (a current source, which has no ``i(name)`` signal, by its
    function sampled on the grid, with the ``.tran`` line's TSTEP/TSTOP for omitted fields);
    inductors, capacitors and couplings give one ``stored`` row, ``ΔE/(t1 − t0)``. A periodic
    steady state over whole periods has no stored term, and the balance
    (:attr:`LossTable.unaccounted`) closes to the energy of impulses and the stepper's
    numerical dissipation.

    An element named in ``outputs`` is an ``output`` row whatever its kind (a current sink
    as load); a controlled source (E, F, G, H, B) that delivers power on average (a gate
    driver) is an ``input`` row, as the supply it stands for pays it.

    Args:
        waves: the full results (node voltages and element currents).
        circuit: the circuit that produced them.
        t0, t1, period: the window [s], as for :func:`mean`.
        outputs: names of the load elements (``("rload",)``).
        devices: the parts of the devices with datasheets over a window ``(t0, t1)``:
            name -> ``conduction``, ``turn_on``, ``turn_off``, ``recovery``, ``total``,
            ``electrical`` [W] (:meth:`circuitnsds.thermal.device_losses.DeviceLosses.average`).
    """
    wanted = {name.lower() for name in outputs}
    unknown = wanted - {element.name for element in circuit.elements}
    if unknown:
        raise MeasurementError(f"no element {', '.join(sorted(unknown))}", where="losses",
                               hint="name the load resistors, e.g. outputs=('rload',)")
    time = np.asarray(waves.time, dtype=float)
    start, stop = window(time, time, t0, t1, period=period)[0][[0, -1]]
    parts = devices(float(start), float(stop)) if devices is not None else {}
    rows: list[LossRow] = []
    stored = 0.0
    # parts whose power is in their device's row (an IGBT's on-state diode)
    absorbed_parts = {part for element in circuit.elements
                      for part in getattr(element, "absorbed_parts", ())}
    for element in circuit.elements:
        if element.name in absorbed_parts:
            continue
        # the element kinds by their attributes (output/ does not import circuit/)
        if hasattr(element, "inductance"):
            current = np.interp([start, stop], time, waves[f"i({element.name})"])
            stored += 0.5 * element.inductance * (current[1] ** 2 - current[0] ** 2)
            continue
        if hasattr(element, "capacitance"):
            voltage = np.interp([start, stop], time, element_voltage(waves, element))
            stored += 0.5 * element.capacitance * (voltage[1] ** 2 - voltage[0] ** 2)
            continue
        if hasattr(element, "mutual") and hasattr(element, "inductors"):
            first, second = (np.interp([start, stop], time, waves[f"i({name})"])
                             for name in element.inductors)
            stored += element.mutual * (first[1] * second[1] - first[0] * second[0])
            continue
        if len(element.nodes) < 2:
            continue
        if f"i({element.name})" in waves:
            current = waves[f"i({element.name})"]
        elif hasattr(element, "function"):  # a current source: no signal holds its current
            current = _source_current(element, circuit, time)
        else:
            continue
        absorbed = mean(time, element_voltage(waves, element) * current, start, stop)
        dissipative = hasattr(element, "resistance") or hasattr(element, "model") and \
            hasattr(element.model, "on_resistance")
        if element.name in wanted:
            rows.append(LossRow(element.name, "output", absorbed))
        elif hasattr(element, "function") or (not dissipative and absorbed < 0):
            rows.append(LossRow(element.name, "input", -absorbed))  # a source, a gate driver
        elif element.name in parts:
            part = parts[element.name]
            rows.append(LossRow(element.name, "loss", part["total"],
                                *(part[column] for column in LOSS_COLUMNS), electrical=absorbed))
        else:  # no datasheet: its switching energy is unknown, not 0 (an ideal switch takes none)
            rows.append(LossRow(element.name, "loss", absorbed, absorbed))
    rows.append(LossRow("L, C, K", "stored", stored / (stop - start)))
    return LossTable(rows, float(start), float(stop), has_outputs=bool(wanted))
