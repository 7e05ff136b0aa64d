"""Time functions of independent sources: DC, SIN, PULSE, PWL, EXP, AM, SFFM (ngspice semantics).

Each function is a small frozen dataclass with ``value(t)`` (SI units of the
source: volts or amperes; ``t`` in seconds) and ``breakpoints(stop)`` (the
instants where its slope jumps, which the time grid steps onto).

Omitted fields take ngspice's defaults, several of which depend on the
analysis (``TSTEP``, ``TSTOP``); the parser therefore stores ``None`` for an
omitted field and :meth:`resolve` fills it in once the analysis is known. As in
ngspice's source loader, a field given as 0 also takes its default where 0 would
be meaningless: SIN FREQ, PULSE PW and PER, EXP TAU1 and TAU2. PULSE TR and TF
given as 0 are kept (an ideal jump), unlike ngspice, which uses TSTEP.

At a corner where the value itself jumps (``PULSE`` with a zero rise time, a
``PWL`` with two points at one time) the function is *left*-continuous: the
value at the corner is the value before it, so the jump happens in the step
that *starts* at the corner.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np


def _with_defaults(stimulus, defaults: dict[str, float], zero_too: tuple[str, ...] = ()):
    """``stimulus`` with each field named in ``defaults`` that was omitted (``None``) set to
    its default, and those in ``zero_too`` also when given as 0 (see the module docstring)."""
    changes = {name: default for name, default in defaults.items()
               if getattr(stimulus, name) is None or (name in zero_too and not getattr(stimulus, name))}
    return replace(stimulus, **changes)


@dataclass(frozen=True)
class Dc:
    """Constant value."""

    level: float

    def resolve(self, tstep: float, tstop: float) -> Dc:
        return self

    def value(self, t: float) -> float:
        return self.level

    def sample(self, times: np.ndarray) -> np.ndarray:
        return np.full(np.shape(times), self.level, dtype=float)

    def breakpoints(self, stop: float) -> list[float]:
        return []


@dataclass(frozen=True)
class Sin:
    """``SIN(VO VA FREQ TD THETA PHASE)``: VO + VA·exp(-(t-TD)·THETA)·sin(2π·FREQ·(t-TD) + PHASE).

    Before ``TD`` the value is ``VO + VA·sin(PHASE)``. ``PHASE`` is in degrees,
    ``THETA`` in 1/s. Default ``FREQ`` (omitted or 0) is ``1/TSTOP``. LTspice's 7th
    argument ``NCYCLES`` ends the sine after that many periods: the value then holds
    ``VO + VA·exp(-THETA·NCYCLES/|FREQ|)·sin(PHASE)``, its value at that instant (a negative
    ``FREQ`` is ngspice's sin(-ωt), of period 1/|FREQ|).
    """

    offset: float
    amplitude: float
    frequency: float | None = None
    delay: float = 0.0
    damping: float = 0.0
    phase_deg: float = 0.0
    cycles: float | None = None

    def resolve(self, tstep: float, tstop: float) -> Sin:
        return _with_defaults(self, {"frequency": 1.0 / tstop}, zero_too=("frequency",))

    def value(self, t: float) -> float:
        phase = math.radians(self.phase_deg)
        if self.cycles:
            t = min(t, self.delay + self.cycles / abs(self.frequency))
        if t <= self.delay:
            return self.offset + self.amplitude * math.sin(phase)
        tau = t - self.delay
        try:
            return self.offset + self.amplitude * math.exp(-tau * self.damping) * math.sin(
                2 * math.pi * self.frequency * tau + phase
            )
        except (ValueError, OverflowError):  # a phase or a growth beyond the doubles: inf or
            with np.errstate(all="ignore"):  # NaN as sample() gives, which the engine reports
                return float(self.sample(np.array([t]))[0])

    def sample(self, times: np.ndarray) -> np.ndarray:
        """:meth:`value` at every instant of ``times`` [s]."""
        times = np.asarray(times, dtype=float)
        if self.cycles:
            times = np.minimum(times, self.delay + self.cycles / abs(self.frequency))
        phase = math.radians(self.phase_deg)
        tau = np.maximum(times - self.delay, 0.0)
        wave = self.offset + self.amplitude * np.exp(-tau * self.damping) * np.sin(
            2 * math.pi * self.frequency * tau + phase)
        return np.where(times <= self.delay, self.offset + self.amplitude * math.sin(phase), wave)

    def breakpoints(self, stop: float) -> list[float]:
        points = [self.delay] if 0 < self.delay < stop else []
        if self.cycles and 0 < self.delay + self.cycles / abs(self.frequency) < stop:
            points.append(self.delay + self.cycles / abs(self.frequency))
        return points


@dataclass(frozen=True)
class _TwoLevels:
    """A waveform between two levels (the ``V1 V2`` of ``PULSE`` and ``EXP``), in the
    source's unit (V or A)."""

    initial: float
    pulsed: float


@dataclass(frozen=True)
class Pulse(_TwoLevels):
    """``PULSE(V1 V2 TD TR TF PW PER [NP])``; after ``NP`` pulses (ngspice, LTspice's
    ``Ncycles``) the value stays at ``V1``.

    Defaults: ``TD = 0``, ``TR = TF = TSTEP``, ``PW = PER = TSTOP`` (also for a
    PW or PER given as 0). A rise or fall time given as 0 is kept as an
    instantaneous jump (the ideal engine handles it exactly).
    """

    delay: float = 0.0
    rise: float | None = None
    fall: float | None = None
    width: float | None = None
    period: float | None = None
    count: float | None = None

    def resolve(self, tstep: float, tstop: float) -> Pulse:
        return _with_defaults(self, {"rise": tstep, "fall": tstep, "width": tstop, "period": tstop},
                              zero_too=("width", "period"))

    def value(self, t: float) -> float:
        if t <= self.delay or self._finished(t):
            return self.initial
        local = t - self.delay
        if self.period > 0:
            cycles = math.floor(local / self.period)
            local -= cycles * self.period
            # grid points land on corners up to rounding: snap, so that the value at
            # a corner is always the value before it (a corner at 0 is the previous
            # period's end)
            snap = 64 * np.finfo(float).eps * max(t, self.period)
            if cycles > 0 and local <= snap:
                local = self.period
            else:
                for corner in (self.rise, self.rise + self.width,
                               self.rise + self.width + self.fall, self.period):
                    if abs(local - corner) <= snap:
                        local = corner
                        break
        span = self.pulsed - self.initial
        if local <= self.rise:
            return self.initial + span * (local / self.rise if self.rise > 0 else 1.0)
        if local <= self.rise + self.width:
            return self.pulsed
        if local <= self.rise + self.width + self.fall:
            return self.pulsed - span * ((local - self.rise - self.width) / self.fall)
        return self.initial

    def sample(self, times: np.ndarray) -> np.ndarray:
        """:meth:`value` at every instant of ``times`` [s] (same corner snapping).

        Instants on the flat parts of a period, farther from every corner than the largest
        snapping distance, take ``V2`` or ``V1`` at once; only the others (ramps, corners,
        before ``TD``) go through :meth:`_sample_corners` (which gives a flat instant the
        same value). On a regular grid most instants are flat: a million-point grid of a
        100 kHz PWM gate is sampled ~3x faster. Increasing instants, many to a period (a
        time grid), find the flat stretches of each period by bisection
        (:meth:`_flat_runs`), without arithmetic on each instant."""
        times = np.asarray(times, dtype=float)
        if self.period <= 0 or times.size == 0:
            return self._sample_corners(times)
        result = self._flat_runs(times)
        if result is not None:
            other = np.isnan(result)
        else:
            local = np.maximum(times - self.delay, 0.0)
            local -= np.floor(local / self.period) * self.period
            margin = 2 * 64 * np.finfo(float).eps * max(float(np.max(np.abs(times))), self.period)
            fall_start = self.rise + self.width
            high = (local > self.rise + margin) & (local < fall_start - margin)
            low = (local > fall_start + self.fall + margin) & (local < self.period - margin)
            result = np.where(high, float(self.pulsed), float(self.initial))
            other = ~(high | low)
        result[other] = self._sample_corners(times[other])
        if self.count:
            result[self._finished(times)] = self.initial
        return result

    def _flat_runs(self, times: np.ndarray) -> np.ndarray | None:
        """For increasing ``times`` (1-D) with many instants to a period: ``V2`` at the instants
        of each period's top and ``V1`` at those of its bottom, away from the corners by four
        times :meth:`sample`'s margin (every such instant is flat for :meth:`sample` too: its
        phase is computed to a few ulps), NaN at the others; ``None`` when the instants are
        not such (or the levels, the pulse's fields are not ordinary), for the caller to
        compare each instant."""
        rise, width, fall, period = self.rise, self.width, self.fall, self.period
        if (times.ndim != 1 or times.size < 64 or not np.isfinite([self.initial, self.pulsed]).all()
                or min(rise, width, fall) < 0 or rise + width + fall > period):
            return None
        first, last = float(times[0]), float(times[-1])
        periods = (last - first) / period + 2
        if not (last >= first and times.size >= 16 * periods) or not (times[1:] >= times[:-1]).all():
            return None
        guard = 4 * 2 * 64 * np.finfo(float).eps * max(abs(first), abs(last), period)
        start = max(0, math.floor((first - self.delay) / period) - 1)
        starts = self.delay + period * np.arange(start, start + math.ceil(periods) + 2)
        top, bottom = starts + (rise + guard), starts + (rise + width + fall + guard)
        edges = np.column_stack([top, np.maximum(top, starts + (rise + width - guard)),
                                 bottom, np.maximum(bottom, starts + (period - guard))]).ravel()
        edges = np.maximum.accumulate(edges)  # (increasing but for rounding where edges meet)
        # open stretches (a, b): the instants after a (side right) and before b (side left)
        bounds = np.searchsorted(times, edges, side="right")
        bounds[1::2] = np.searchsorted(times, edges[1::2], side="left")
        bounds = np.maximum.accumulate(np.concatenate([[0], bounds, [times.size]]))
        levels = np.full(bounds.size - 1, np.nan)
        levels[1::4], levels[3::4] = self.pulsed, self.initial  # other, top, other, bottom, ...
        return np.repeat(levels, np.diff(bounds))

    def _sample_corners(self, times: np.ndarray) -> np.ndarray:
        """:meth:`value` at every instant of ``times``, each compared with every corner."""
        local = np.maximum(times - self.delay, 0.0)
        if self.period > 0:
            cycles = np.floor(local / self.period)
            local = local - cycles * self.period
            snap = 64 * np.finfo(float).eps * np.maximum(times, self.period)
            # as value(): a period's start is the previous period's end, else the first
            # corner (in time order) within the snapping distance, each instant snapped once
            # (two corners closer than that, e.g. a fall ending 1e-17 s after the period,
            # must not snap an instant twice)
            snapped = (cycles > 0) & (local <= snap)
            local = np.where(snapped, self.period, local)
            for corner in (self.rise, self.rise + self.width, self.rise + self.width + self.fall,
                           self.period):
                hit = ~snapped & (np.abs(local - corner) <= snap)
                local = np.where(hit, corner, local)
                snapped |= hit
        span = self.pulsed - self.initial
        rise_end, fall_start = self.rise, self.rise + self.width
        fall_end = fall_start + self.fall
        with np.errstate(divide="ignore", invalid="ignore"):
            rising = self.initial + span * (local / self.rise if self.rise > 0 else 1.0)
            falling = self.pulsed - span * ((local - fall_start) / self.fall)
        result = np.select(
            [local <= rise_end, local <= fall_start, local <= fall_end],
            [rising, np.full_like(local, self.pulsed), falling],
            default=self.initial,
        )
        done = self._finished(times)
        return np.where((times <= self.delay) | done, self.initial, result)

    def _finished(self, t):
        """After ``count`` pulses (ngspice's 8th argument ``NP``) the source stays at ``V1``."""
        if not self.count:
            return np.zeros_like(t, dtype=bool) if isinstance(t, np.ndarray) else False
        return t >= self.delay + self.count * self.period

    def breakpoints(self, stop: float) -> list[float]:
        corners = np.array([0.0, self.rise, self.rise + self.width,
                            self.rise + self.width + self.fall])
        if self.period <= 0:
            starts = np.array([self.delay])
        else:
            pulses = max(1, math.ceil((stop - self.delay) / self.period) + 1)
            if self.count:
                pulses = min(pulses, math.ceil(self.count))
            starts = self.delay + self.period * np.arange(pulses)
        times = (starts[:, None] + corners[None, :]).ravel()
        return np.sort(times[(times > 0) & (times < stop)]).tolist()


MAX_PWL_POINTS = 10_000_000
"""Most points a repeated PWL (``r=``) may expand to over a run."""


@dataclass(frozen=True)
class Pwl:
    """``PWL(T1 V1 T2 V2 ...) [r=R] [td=TD]``: linear between points, constant before the
    first and after the last. As in ngspice, ``td`` [s] delays the whole waveform and ``r``
    [s] (one of the times, or 0) repeats the part from ``r`` to the last point for ever
    (period: last time − ``r``); :meth:`resolve` writes the repetitions out up to TSTOP."""

    times: tuple[float, ...]
    values: tuple[float, ...]
    repeat: float | None = None
    delay: float = 0.0

    def resolve(self, tstep: float, tstop: float) -> Pwl:
        if self.repeat is None and not self.delay:
            return self
        times, values = [t + self.delay for t in self.times], list(self.values)
        if self.repeat is not None:
            first = self.times.index(self.repeat)  # (the reader checks it is one of the times)
            period = self.times[-1] - self.repeat
            copies = math.ceil((tstop - times[-1]) / period) if tstop > times[-1] else 0
            if copies * (len(self.times) - first) > MAX_PWL_POINTS:
                raise ValueError(f"PWL r={self.repeat:g} repeats a {period:g} s stretch "
                                 f"{copies:,} times up to TSTOP: more than {MAX_PWL_POINTS:,} points")
            part_times = [t + self.delay for t in self.times[first:]]
            for copy in range(1, copies + 1):
                times += [t + copy * period for t in part_times]
                values += self.values[first:]
        return Pwl(tuple(times), tuple(values))

    def value(self, t: float) -> float:
        times = self.times
        if t <= times[0]:
            return self.values[0]
        if t > times[-1]:
            return self.values[-1]
        if t == times[-1]:
            # left-continuous: at a vertical last segment take the value before the jump
            first = times.index(times[-1])
            return self.values[first]
        # left-continuous at a vertical segment: take the last index with times[i] < t
        index = int(np.searchsorted(times, t, side="left")) - 1
        t0, t1 = times[index], times[index + 1]
        v0, v1 = self.values[index], self.values[index + 1]
        return v0 + (v1 - v0) * (t - t0) / (t1 - t0)

    def sample(self, times: np.ndarray) -> np.ndarray:
        """:meth:`value` at every instant of ``times`` [s]."""
        return np.array([self.value(t) for t in np.asarray(times, dtype=float).ravel()]
                        ).reshape(np.shape(times))

    def breakpoints(self, stop: float) -> list[float]:
        return sorted({t for t in self.times if 0 < t < stop})


@dataclass(frozen=True)
class Exp(_TwoLevels):
    """``EXP(V1 V2 TD1 TAU1 TD2 TAU2)``: rise towards V2 from TD1, fall back towards V1 from TD2.

    Defaults: ``TD1 = 0``, ``TAU1 = TSTEP``, ``TD2 = TD1 + TSTEP``, ``TAU2 = TSTEP``
    (the time constants also when given as 0).
    """

    rise_delay: float = 0.0
    rise_tau: float | None = None
    fall_delay: float | None = None
    fall_tau: float | None = None

    def resolve(self, tstep: float, tstop: float) -> Exp:
        defaults = {"rise_tau": tstep, "fall_delay": self.rise_delay + tstep, "fall_tau": tstep}
        return _with_defaults(self, defaults, zero_too=("rise_tau", "fall_tau"))

    def value(self, t: float) -> float:
        span = self.pulsed - self.initial
        result = self.initial
        if t > self.rise_delay:
            result += span * (1 - math.exp(-(t - self.rise_delay) / self.rise_tau))
        if t > self.fall_delay:
            result -= span * (1 - math.exp(-(t - self.fall_delay) / self.fall_tau))
        return result

    def sample(self, times: np.ndarray) -> np.ndarray:
        """:meth:`value` at every instant of ``times`` [s]."""
        times = np.asarray(times, dtype=float)
        span = self.pulsed - self.initial
        rise = np.where(times > self.rise_delay,
                        1 - np.exp(-np.maximum(times - self.rise_delay, 0) / self.rise_tau), 0.0)
        fall = np.where(times > self.fall_delay,
                        1 - np.exp(-np.maximum(times - self.fall_delay, 0) / self.fall_tau), 0.0)
        return self.initial + span * (rise - fall)

    def breakpoints(self, stop: float) -> list[float]:
        return [t for t in (self.rise_delay, self.fall_delay) if 0 < t < stop]


@dataclass(frozen=True)
class Am:
    """``AM(VA VO MF FC TD PHASEC PHASES)`` as ngspice 39 reads it:
    ``VA·(VO + sin(2π·MF·τ + PHASES))·sin(2π·FC·τ + PHASES)`` with ``τ = t − TD``, and 0 up to
    ``TD`` [s]. ``VA`` is in the source's unit (V or A), ``VO`` is the carrier offset relative
    to the modulation's unit amplitude, ``MF`` and ``FC`` are the modulating and carrier
    frequencies [Hz], the phases are in degrees.

    Defaults: ``MF = 1/TSTOP`` (also when given as 0), ``FC = 0``, ``TD = 0``. ngspice 39 reads
    ``PHASEC`` and does not use it: ``PHASES`` shifts both sines (kept here, so that the
    waveform is ngspice's).
    """

    amplitude: float
    offset: float
    modulation_frequency: float | None = None
    carrier_frequency: float = 0.0
    delay: float = 0.0
    carrier_phase_deg: float = 0.0
    modulation_phase_deg: float = 0.0

    def resolve(self, tstep: float, tstop: float) -> Am:
        return _with_defaults(self, {"modulation_frequency": 1.0 / tstop},
                              zero_too=("modulation_frequency",))

    def value(self, t: float) -> float:
        return float(self.sample(np.array([t]))[0])

    def sample(self, times: np.ndarray) -> np.ndarray:
        """:meth:`value` at every instant of ``times`` [s]."""
        times = np.asarray(times, dtype=float)
        tau = times - self.delay
        phase = math.radians(self.modulation_phase_deg)
        envelope = self.offset + np.sin(2 * math.pi * self.modulation_frequency * tau + phase)
        wave = self.amplitude * envelope * np.sin(2 * math.pi * self.carrier_frequency * tau + phase)
        return np.where(tau <= 0, 0.0, wave)

    def breakpoints(self, stop: float) -> list[float]:
        return [self.delay] if 0 < self.delay < stop else []

    def highest_frequency(self) -> float:
        """The highest frequency [Hz] of the waveform: the carrier's upper side band."""
        return abs(self.carrier_frequency) + abs(self.modulation_frequency)


@dataclass(frozen=True)
class Sffm:
    """``SFFM(VO VA FC MDI FS PHASEC PHASES)`` as ngspice 39 reads it:
    ``VO + VA·sin(2π·FC·t + PHASEC + MDI·sin(2π·FS·t + PHASES))``, a carrier of frequency ``FC``
    [Hz] whose phase is modulated at ``FS`` [Hz] with index ``MDI`` (radians); the phases in
    degrees, ``VO`` and ``VA`` in the source's unit (V or A). There is no delay.

    Defaults: ``FC = FS = 1/TSTOP`` (also when given as 0), ``MDI = 0``.
    """

    offset: float
    amplitude: float
    carrier_frequency: float | None = None
    modulation_index: float = 0.0
    signal_frequency: float | None = None
    carrier_phase_deg: float = 0.0
    signal_phase_deg: float = 0.0

    def resolve(self, tstep: float, tstop: float) -> Sffm:
        return _with_defaults(self, {"carrier_frequency": 1.0 / tstop, "signal_frequency": 1.0 / tstop},
                              zero_too=("carrier_frequency", "signal_frequency"))

    def value(self, t: float) -> float:
        return float(self.sample(np.array([t]))[0])

    def sample(self, times: np.ndarray) -> np.ndarray:
        """:meth:`value` at every instant of ``times`` [s]."""
        times = np.asarray(times, dtype=float)
        signal = np.sin(2 * math.pi * self.signal_frequency * times + math.radians(self.signal_phase_deg))
        return self.offset + self.amplitude * np.sin(
            2 * math.pi * self.carrier_frequency * times + math.radians(self.carrier_phase_deg)
            + self.modulation_index * signal)

    def breakpoints(self, stop: float) -> list[float]:
        return []

    def highest_frequency(self) -> float:
        """The highest instantaneous frequency [Hz]: ``|FC| + |MDI|·|FS|``."""
        return abs(self.carrier_frequency) + abs(self.modulation_index * self.signal_frequency)


@dataclass(frozen=True)
class Sawtooth:
    """``frac(start + frequency·t)``: rises from ``start`` (a fraction of a period, in [0, 1))
    at ``frequency`` [Hz] (per second, dimensionless value) and drops to 0 at each period's
    end. The phase of XSPICE's ``d_pwm`` oscillator; no netlist card writes it. At a drop the
    value is 1 (the value before it; see the module docstring)."""

    frequency: float
    start: float = 0.0

    def resolve(self, tstep: float, tstop: float) -> Sawtooth:
        return self

    def value(self, t: float) -> float:
        return float(self.sample(np.array([t]))[0])

    def sample(self, times: np.ndarray) -> np.ndarray:
        """:meth:`value` at every instant of ``times`` [s]; an instant within rounding of a drop
        is at the drop (the value 1 before it, 0 at time 0's phase 0)."""
        phase = self.start + self.frequency * np.asarray(times, dtype=float)
        whole = np.floor(phase)
        fraction = phase - whole
        at_drop = (fraction <= 64 * np.finfo(float).eps * np.maximum(phase, 1.0)) & (phase > 0)
        return np.where(at_drop, 1.0, fraction)

    def breakpoints(self, stop: float) -> list[float]:
        """Each drop, and :data:`SAWTOOTH_SETTLE` of a period after it: a comparator of the
        sawtooth sees the drop in that short first step, so that a step after a drop never
        holds both the comparator's fall and its next rise (where neither would be seen)."""
        first = (1.0 - self.start) / self.frequency
        count = max(0, math.ceil((stop - first) * self.frequency))
        drops = first + np.arange(count + 1) / self.frequency
        points = np.column_stack([drops, drops + SAWTOOTH_SETTLE / self.frequency]).ravel()
        return points[(points > 0) & (points < stop)].tolist()


SAWTOOTH_SETTLE = 1e-4
"""The first step after a sawtooth's drop [periods]: a comparator's fall at the drop is located
within it (1e-6 located it closer but ran ng_pwm-sin.cir 3 times slower)."""


Stimulus = Dc | Sin | Pulse | Pwl | Exp | Am | Sffm | Sawtooth


POINTS_PER_PERIOD = 20
"""A SIN, or a PULSE that repeats within the run, is resolved by a step of at most
1/POINTS_PER_PERIOD of its period."""


def resolving_step(stimulus: Stimulus, stop: float) -> float | None:
    """The largest step [s] that resolves a resolved ``stimulus`` over ``[0, stop]``: its
    period / :data:`POINTS_PER_PERIOD` for a SIN of nonzero amplitude or a PULSE whose period
    is shorter than ``stop``, the period of the highest frequency of an AM or SFFM over the
    same; ``None`` for the others (their corners are grid points)."""
    if isinstance(stimulus, Sin) and stimulus.amplitude != 0 and stimulus.frequency:
        # (a negative frequency is sin(-ωt): the same period; it divided by 0 when refining)
        return 1.0 / (abs(stimulus.frequency) * POINTS_PER_PERIOD)
    if isinstance(stimulus, (Am, Sffm)) and stimulus.amplitude != 0 and stimulus.highest_frequency():
        return 1.0 / (stimulus.highest_frequency() * POINTS_PER_PERIOD)
    if (isinstance(stimulus, Pulse) and stimulus.initial != stimulus.pulsed
            and stimulus.period is not None and 0 < stimulus.period < stop
            and (stimulus.count is None or stimulus.count > 1)):
        return stimulus.period / POINTS_PER_PERIOD
    return None


def breakpoint_bound(stimulus: Stimulus, stop: float) -> float:
    """At most how many instants ``stimulus.breakpoints(stop)`` lists, found without listing
    them (a 10 µs PULSE over 100 s has 4e7): a float, ``inf`` when the count overflows."""
    if isinstance(stimulus, Pulse):
        if not stimulus.period or stimulus.period <= 0:
            return 4.0
        with np.errstate(over="ignore"):
            pulses = max(0.0, (stop - stimulus.delay) / stimulus.period) + 2.0
        if stimulus.count:
            pulses = min(pulses, math.ceil(stimulus.count))
        return 4.0 * pulses
    if isinstance(stimulus, Pwl):
        return float(len(stimulus.times))
    return float(len(stimulus.breakpoints(stop)))


def threshold_crossings(stimulus: Stimulus, level: float, stop: float) -> list[float]:
    """Instants in ``(0, stop)`` where a piecewise-linear function crosses ``level`` mid-piece.

    Only ``PULSE`` and ``PWL`` are piecewise linear between their breakpoints;
    for them each linear piece is fitted from two interior samples and its
    crossing of ``level`` computed exactly. Crossings at a breakpoint itself (an
    ideal jump) are already grid points and are not repeated. Other functions
    give no crossings (a switch they drive changes state at the first grid
    point past the crossing; see docs/netlist.md).
    """
    if not isinstance(stimulus, (Pulse, Pwl)):
        return []
    edges = np.array([0.0, *stimulus.breakpoints(stop), stop])
    left, right = edges[:-1], edges[1:]
    span = right - left
    quarter = stimulus.sample(left + 0.25 * span)
    three_quarters = stimulus.sample(left + 0.75 * span)
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = (three_quarters - quarter) / (0.5 * span)
        crossing = left + 0.25 * span + (level - quarter) / slope
    margin = 1e-9 * span
    inside = (span > 0) & (slope != 0) & (crossing > left + margin) & (crossing < right - margin)
    return crossing[inside].tolist()
