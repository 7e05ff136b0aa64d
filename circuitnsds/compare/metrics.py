"""Error measures between two waveforms of the same signal (plain numpy, no simulator).

All integrals over time use the trapezoidal rule on the reference grid, so a
non-uniform grid (breakpoints) weighs every instant by the time it represents.
With ``ref`` the circuitnsds signal and ``other`` the ngspice one, both on the
reference grid and restricted to the window ``[t0, t1]``:

* ``scale`` = max(ref) − min(ref), the signal's range [V or A]. When the
  reference is constant (its range is below 1e-9 of its magnitude, i.e. rounding:
  a DC supply node), its magnitude max|ref| instead, so the errors are relative
  to the value; and 1 when it is zero everywhere (the "normalised" errors are then
  absolute, in V or A);
* ``nrms`` = sqrt(mean((other − ref)²)) / scale (time-weighted mean);
* ``rrms`` = sqrt(mean((other − ref)²)) / sqrt(mean(ref²)): the RMS error relative to the
  signal's RMS value (1 when the reference is zero everywhere);
* ``error``: ``rrms`` for a DC-like signal (its range is below :data:`DC_LIKE` of its RMS:
  a converter's output, whose few-mV ripple would make ``nrms`` read 100 % for a 0.08 V
  offset on 4.5 V), ``nrms`` otherwise; summaries rank signals by it;
* ``nmax`` = max|other − ref| / scale, reached at ``max_at`` [s];
* ``mean_diff`` = mean(other) − mean(ref) [V or A] (time averages: DC value);
* ``ripple_diff`` = (max − min of other) − (max − min of ref) [V or A], the
  difference of the peak-to-peak ripple.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

#: A reference whose range is below this fraction of its magnitude counts as constant.
CONSTANT_RANGE = 1e-9
#: A reference whose range is below this fraction of its RMS value is DC-like.
DC_LIKE = 0.2

_trapezoid = getattr(np, "trapezoid", None) or np.trapz  # numpy < 2 has only trapz


@dataclass(frozen=True)
class SignalMetrics:
    """How far one signal of the ngspice run is from circuitnsds's (see the module docstring).

    Attributes:
        signal: the signal name (``v(out)``).
        scale: range of the circuitnsds signal over the window [V or A] (its
            magnitude if it is constant, 1 if it is zero).
        nrms: RMS of the difference divided by ``scale``.
        nmax: largest difference divided by ``scale``.
        max_at: where the largest difference occurs [s].
        mean_ref, mean_other: time averages over the window [V or A].
        mean_diff: ``mean_other − mean_ref`` [V or A].
        ripple_ref, ripple_other: peak-to-peak values over the window [V or A].
        ripple_diff: ``ripple_other − ripple_ref`` [V or A].
        points: grid points measured (inside the window, where both have values).
        negligible: set by :func:`flag_negligible`: the signal neither varies nor differs
            by more than a tiny fraction of the other signals of its kind (a diode that
            never conducts); reports leave it out of their summaries.
    """

    signal: str
    scale: float
    nrms: float
    nmax: float
    max_at: float
    mean_ref: float
    mean_other: float
    mean_diff: float
    ripple_ref: float
    ripple_other: float
    ripple_diff: float
    points: int
    negligible: bool = False
    rrms: float = float("nan")
    rms_ref: float = float("nan")

    @property
    def dc_like(self) -> bool:
        """The reference's range is below ``DC_LIKE`` of its RMS value."""
        return self.rms_ref > 0 and self.ripple_ref < DC_LIKE * self.rms_ref

    @property
    def error(self) -> float:
        """``rrms`` for a DC-like signal, ``nrms`` otherwise (see the module docstring)."""
        return self.rrms if self.dc_like else self.nrms

    def to_dict(self) -> dict[str, float | int | str]:
        return {**asdict(self), "dc_like": self.dc_like, "error": self.error}


def resample(time_from: np.ndarray, values: np.ndarray, time_to: np.ndarray) -> np.ndarray:
    """Linear interpolation of ``values`` (at ``time_from``) onto ``time_to``.

    Points of ``time_to`` outside ``[time_from[0], time_from[-1]]`` are NaN (a run
    that stopped early has no values there). A repeated time point (ngspice writes
    some breakpoints twice, before and after a jump) is a jump: before it the first
    value is used, at and after it the last.
    """
    time_from = np.asarray(time_from, dtype=float)
    values = np.asarray(values, dtype=float)
    time_to = np.asarray(time_to, dtype=float)
    out = np.full(time_to.shape, np.nan)
    if time_from.size == 0:
        return out
    if time_from.size == 1:
        out[time_to == time_from[0]] = values[0]
        return out
    slack = 1e-9 * max(abs(time_from[-1]), time_from[-1] - time_from[0])  # rounding of the ends
    inside = (time_to >= time_from[0] - slack) & (time_to <= time_from[-1] + slack)
    x = np.clip(time_to[inside], time_from[0], time_from[-1])
    # the segment [time_from[j-1], time_from[j]) holding x; side="right" picks the last of
    # repeated points, so a jump takes effect at its instant
    j = np.clip(np.searchsorted(time_from, x, side="right"), 1, time_from.size - 1)
    t0, t1 = time_from[j - 1], time_from[j]
    v0, v1 = values[j - 1], values[j]
    width = t1 - t0
    fraction = np.divide(x - t0, width, out=np.zeros_like(x), where=width > 0)
    out[inside] = v0 + fraction * (v1 - v0)
    return out


def window_mask(time: np.ndarray, window: tuple[float, float] | None) -> np.ndarray:
    """Boolean mask of the grid points with ``t0 <= t <= t1`` (all points for ``None``)."""
    time = np.asarray(time, dtype=float)
    if window is None:
        return np.ones(time.shape, dtype=bool)
    t0, t1 = window
    span = max(abs(t0), abs(t1), 1e-300)
    return (time >= t0 - 1e-12 * span) & (time <= t1 + 1e-12 * span)


def time_mean(time: np.ndarray, values: np.ndarray) -> float:
    """Time average of ``values`` (trapezoidal rule); the value itself for a single point."""
    if time.size < 2 or time[-1] == time[0]:
        return float(np.mean(values))
    return float(_trapezoid(values, time) / (time[-1] - time[0]))


def signal_metrics(
    time: np.ndarray,
    ref: np.ndarray,
    other: np.ndarray,
    window: tuple[float, float] | None = None,
    signal: str = "",
) -> SignalMetrics:
    """Compare ``other`` with the reference ``ref``, both sampled at ``time`` [s].

    Args:
        time: the common grid (increasing) [s].
        ref: circuitnsds's values [V or A].
        other: ngspice's values resampled on ``time`` (see :func:`resample`); NaN
            where it has none (ngspice writes no t = 0 point under UIC, a failed run
            has none after it stopped): those points are left out.
        window: ``(t0, t1)`` [s] to restrict every measure to; ``None`` for the whole grid.
        signal: name, for the record.

    Raises:
        ValueError: the window holds no grid point, or ``other`` has no value inside it.
    """
    time = np.asarray(time, dtype=float)
    ref = np.asarray(ref, dtype=float)
    other = np.asarray(other, dtype=float)
    mask = window_mask(time, window)
    if not mask.any():
        raise ValueError(f"the window {window} holds no time point of the grid "
                         f"[{time[0]:g}, {time[-1]:g}] s")
    mask &= np.isfinite(other)
    if not mask.any():
        raise ValueError(f"{signal or 'the signal'} has no value inside the window")
    t, r, o = time[mask], ref[mask], other[mask]
    diff = o - r
    ripple_ref = float(r.max() - r.min())
    magnitude = float(np.abs(r).max())
    scale = ripple_ref if ripple_ref > CONSTANT_RANGE * magnitude else magnitude
    scale = scale if scale > 0 else 1.0
    worst = int(np.argmax(np.abs(diff)))
    mean_ref, mean_other = time_mean(t, r), time_mean(t, o)
    ripple_other = float(o.max() - o.min())
    rms_error = float(np.sqrt(max(time_mean(t, diff**2), 0.0)))
    rms_ref = float(np.sqrt(max(time_mean(t, r**2), 0.0)))
    return SignalMetrics(
        signal=signal,
        scale=scale,
        nrms=rms_error / scale,
        rrms=rms_error / rms_ref if rms_ref > 0 else rms_error,
        rms_ref=rms_ref,
        nmax=float(abs(diff[worst])) / scale,
        max_at=float(t[worst]),
        mean_ref=mean_ref,
        mean_other=mean_other,
        mean_diff=mean_other - mean_ref,
        ripple_ref=ripple_ref,
        ripple_other=ripple_other,
        ripple_diff=ripple_other - ripple_ref,
        points=int(mask.sum()),
    )


#: A signal is negligible when its ranges and its largest difference are all below this
#: fraction of the largest range among the compared signals of the same kind (V or A).
NEGLIGIBLE = 1e-4


def flag_negligible(metrics: dict[str, SignalMetrics]) -> dict[str, SignalMetrics]:
    """Mark the signals that carry nothing next to the others of their kind.

    A current of picoamperes through a diode that never conducts has a tiny range,
    so its normalised error is huge and meaningless; a DC supply node neither
    varies nor differs. Such a signal is ``negligible`` when ``max(ripple_ref,
    ripple_other, nmax·scale) < NEGLIGIBLE × (largest ripple_ref among the signals
    of its kind)``; voltages (``v(...)``) and currents (``i(...)``) are separate kinds.
    """
    largest: dict[str, float] = {}
    for name, metric in metrics.items():
        kind = name[:1]
        largest[kind] = max(largest.get(kind, 0.0), metric.ripple_ref)
    flagged = {}
    for name, metric in metrics.items():
        size = max(metric.ripple_ref, metric.ripple_other, metric.nmax * metric.scale)
        small = size < NEGLIGIBLE * largest[name[:1]]
        flagged[name] = replace(metric, negligible=small)
    return flagged
