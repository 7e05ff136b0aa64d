"""Piecewise-linear diode fitted to a SPICE (ngspice level-1) diode model.

A vendor ``.model NAME D(IS N RS IKF ISR NR VJ M BV IBV NBV IKR)`` describes the static
characteristic; at ``TNOM`` = 27 °C ngspice (``dioload.c``) computes, for a junction
voltage ``vd`` [V] and ``Vt = kT/q``:

* forward (``vd >= 0``): ``Id = IS·(exp(vd/(N·Vt)) − 1)
  + ISR·(exp(vd/(NR·Vt)) − 1)·((1 − vd/VJ)² + 0.005)^(M/2)`` (the recombination term only
  when ``ISR`` is given), then high injection ``Id/(1 + sqrt(Id/IKF))`` when ``IKF > 0``;
* breakdown, reverse current ``r > 0``: ``r = IS·exp((|vd| − BVeff)/(NBV·Vt))`` with
  ``BVeff`` placed so that ``r = IBV`` at ``|vd| = BV`` (to within ``IS``), then
  ``r/(1 + sqrt(r/IKR))`` when ``IKR > 0``;

and the terminal voltage adds ``RS·i``. Defaults are ngspice's (``N = 1``, ``NR = 2``,
``VJ = 1``, ``M = 0.5``, ``NBV = N``, ``IBV = 1 mA``).

Both curves ``v(i)`` are concave and increasing in the current (the junction current is a
convex function of ``vd``; ``RS·i`` is linear), so the chords of a partition of the
current range lie below the curve and their slopes fall from one to the next. circuitnsds
represents such a curve by ``k`` parallel branches ``0 <= i_j ⊥ R_j·i_j + V_j − v >= 0``
(each knee ``V_j`` adds the conductance ``1/R_j > 0``, so the complementarity problem stays
a P-matrix): :func:`fit_piecewise` chooses the breakpoints so that every chord deviates
from the curve by the same largest amount ``2e`` (the fewest chords for that ``e``, ``e``
the smallest that ``k`` chords reach) and lifts the chords by ``e``: the fit is then within
``±e`` of the curve over the range, minimax in volts. :data:`FIT_DECADES` decades of
current are fitted with at most :data:`MAX_BRANCHES` branches (a Shockley curve at
``N = 1``: ±6 mV over 5 decades with 6 branches); fewer branches when
:data:`TARGET_ERROR` is reached with fewer.

This module is shared by every element that has a PN junction (diodes, the body
diode of a MOSFET): it knows no netlist syntax.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

BOLTZMANN = 1.380649e-23
"""[J/K]"""
ELEMENTARY_CHARGE = 1.602176634e-19
"""[C]"""
NOMINAL_TEMPERATURE = 300.15
"""[K]: 27 °C, SPICE's ``TNOM``."""
THERMAL_VOLTAGE = BOLTZMANN * NOMINAL_TEMPERATURE / ELEMENTARY_CHARGE
"""``kT/q`` at ``TNOM`` [V] (0.025865 V)."""

FIT_DECADES = 5.0
"""A fit range is ``[high·10^-FIT_DECADES, high]``."""
DEFAULT_FIT_CURRENT = 1.0
"""``high`` [A] when neither ``.options pwlfit`` nor the run nor ``IAVE`` gives one."""
MAX_BRANCHES = 6
"""Most parallel branches of one fitted curve."""
TARGET_ERROR = 2.5e-3
"""[V]: a fit stops adding branches once it is this close to the curve."""
SAMPLES = 600
"""Currents (log-spaced) at which the curve is sampled over the fit range."""


@dataclass(frozen=True)
class ShockleyDiode:
    """The static parameters of an ngspice level-1 diode (ngspice's defaults).

    Attributes:
        saturation_current: ``IS`` [A] (> 0).
        emission: ``N`` (> 0).
        series_resistance: ``RS`` [Ω].
        breakdown_voltage: ``BV`` [V] (> 0), ``None`` for none.
        breakdown_current: ``IBV`` [A] (> 0), the reverse current at ``-BV``.
        breakdown_emission: ``NBV`` (ngspice's default is ``N``: the card reader passes it).
        average_current: ``IAVE`` [A] (LTspice's rated average current), or ``None``.
        knee_current: ``IKF`` [A], forward high-injection knee; ``None`` for none.
        reverse_knee_current: ``IKR`` [A], reverse high-injection knee; ``None`` for none.
        recombination_current: ``ISR`` [A], recombination saturation current; ``None``.
        recombination_emission: ``NR``.
        junction_potential: ``VJ`` [V]; grading: ``M`` (of the recombination term's
            generation factor).
    """

    saturation_current: float = 1e-14
    emission: float = 1.0
    series_resistance: float = 0.0
    breakdown_voltage: float | None = None
    breakdown_current: float = 1e-3
    breakdown_emission: float = 1.0
    average_current: float | None = None
    knee_current: float | None = None
    reverse_knee_current: float | None = None
    recombination_current: float | None = None
    recombination_emission: float = 2.0
    junction_potential: float = 1.0
    grading: float = 0.5

    def junction_current(self, vd: np.ndarray | float) -> np.ndarray:
        """Forward junction current [A] at junction voltage ``vd`` [V] (>= 0), ngspice's
        (``IS``, ``N``, ``ISR``, ``NR``, ``IKF``; no ``RS``)."""
        vd = np.asarray(vd, dtype=float)
        current = self.saturation_current * np.expm1(vd / (self.emission * THERMAL_VOLTAGE))
        if self.recombination_current:
            generation = ((1 - vd / self.junction_potential) ** 2 + 0.005) ** (self.grading / 2)
            current = current + self.recombination_current * generation * np.expm1(
                vd / (self.recombination_emission * THERMAL_VOLTAGE))
        if self.knee_current:
            current = current / (1 + np.sqrt(np.maximum(current, 0.0) / self.knee_current))
        return current

    def forward_voltage(self, current: np.ndarray | float) -> np.ndarray:
        """Terminal voltage [V] at forward current ``current`` [A] (> 0)."""
        i = np.asarray(current, dtype=float)
        if not (self.recombination_current or self.knee_current):
            vt = self.emission * THERMAL_VOLTAGE
            junction = vt * np.log1p(i / self.saturation_current)
        else:
            junction = _inverse(self.junction_current, i)
        return junction + self.series_resistance * i

    def breakdown_drop(self, current: np.ndarray | float) -> np.ndarray:
        """Magnitude of the terminal voltage [V] at reverse current ``current`` [A] (> 0)
        in breakdown."""
        if self.breakdown_voltage is None:
            raise ValueError("the model has no breakdown voltage")
        r = np.asarray(current, dtype=float)
        vt = self.breakdown_emission * THERMAL_VOLTAGE
        if self.reverse_knee_current:  # the junction carries r_j, r = r_j/(1 + sqrt(r_j/IKR))
            knee = self.reverse_knee_current
            root = (r + np.sqrt(r * r + 4 * knee * r)) / (2 * knee)  # sqrt(r_j/IKR)
            r_junction = knee * root ** 2
        else:
            r_junction = r
        return (self.breakdown_voltage + vt * np.log(r_junction / self.breakdown_current)
                + self.series_resistance * r)


def _inverse(current_of: Callable[[np.ndarray], np.ndarray], current: np.ndarray) -> np.ndarray:
    """The junction voltage ``vd >= 0`` [V] at which the increasing ``current_of(vd)`` equals
    ``current`` [A] (> 0), by bisection to a fraction of a microvolt."""
    low = np.zeros_like(current)
    high = np.full_like(current, 0.5)
    while True:  # widen until the current is bracketed
        short = current_of(high) < current
        if not short.any():
            break
        high = np.where(short, 2 * high, high)
        if high.max() > 1e4:
            raise ValueError("the diode's junction current does not reach the fit current")
    for _ in range(64):
        middle = (low + high) / 2
        below = current_of(middle) < current
        low, high = np.where(below, middle, low), np.where(below, high, middle)
    return (low + high) / 2


@dataclass(frozen=True)
class PiecewiseFit:
    """A concave increasing curve ``v(i)`` as ``k`` parallel branches: the current is
    ``Σ_j max(0, (v − V_j)/R_j)``.

    Attributes:
        knees: ``V_j`` [V], ascending (the first is ``Vfwd``/``Vrev``).
        resistances: ``R_j`` [Ω] (> 0 when ``k > 1``; a single branch may have 0).
        low, high: the current range [A] the branches were fitted over.
        max_error: largest ``|v_fit − v_curve|`` over the range [V].
    """

    knees: tuple[float, ...]
    resistances: tuple[float, ...]
    low: float
    high: float
    max_error: float

    @property
    def branches(self) -> tuple[tuple[float, float], ...]:
        """``((V_1, R_1), ..., (V_k, R_k))``."""
        return tuple(zip(self.knees, self.resistances))

    def voltage(self, current: np.ndarray | float) -> np.ndarray:
        """Voltage [V] of the branches at total current ``current`` [A] (>= 0)."""
        i = np.asarray(current, dtype=float)
        if self.resistances[0] == 0:
            return np.full_like(i, self.knees[0])
        conductances = 1 / np.asarray(self.resistances)
        knees = np.asarray(self.knees)
        # current at each knee: from branches below it
        at_knee = np.array([float(np.sum(conductances[:j] * (knees[j] - knees[:j])))
                            for j in range(len(knees))])
        branch = np.searchsorted(at_knee, i, side="right") - 1
        g = np.cumsum(conductances)[branch]
        weighted = np.cumsum(conductances * knees)[branch]
        return (i + weighted) / g

    def describe(self, drop_name: str) -> str:
        if len(self.knees) == 1:
            shape = f"{drop_name}={self.knees[0]:.4g} V R={self.resistances[0]:.4g} Ω"
        else:
            shape = (f"{len(self.knees)} branches, {drop_name}={self.knees[0]:.4g}.."
                     f"{self.knees[-1]:.4g} V")
        return (f"{shape} (minimax over {self.low:.3g}..{self.high:.3g} A, "
                f"within {1e3 * self.max_error:.3g} mV)")


def coarse_breakdown(fit: PiecewiseFit | None) -> bool:
    """Whether a breakdown ``fit`` has fewer branches than its error asks for: the one branch
    a SPICE model's breakdown gets until a run shows breakdown current (a rectifier's
    ``BV = 1000`` is never reached; each branch is a pair in every step)."""
    return fit is not None and len(fit.knees) < MAX_BRANCHES and fit.max_error > 2 * TARGET_ERROR


def _chord_deviation(currents: np.ndarray, volts: np.ndarray, a: int, b: int) -> float:
    """Largest ``|curve − chord|`` [V] between samples ``a`` and ``b``."""
    i, v = currents[a:b + 1], volts[a:b + 1]
    slope = (v[-1] - v[0]) / (i[-1] - i[0])
    return float(np.max(np.abs(v - v[0] - slope * (i - i[0]))))


def _greedy(currents: np.ndarray, volts: np.ndarray, deviation: float) -> list[int]:
    """Breakpoint indices ``[0, ..., n-1]``: each chord as long as it can be while it
    deviates from the curve by at most ``deviation`` [V]."""
    points, a, last = [0], 0, currents.size - 1
    while a < last:
        lo, hi = a + 1, last  # the farthest b with deviation(a, b) <= deviation
        if _chord_deviation(currents, volts, a, hi) <= deviation:
            lo = hi
        else:
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if _chord_deviation(currents, volts, a, mid) <= deviation:
                    lo = mid
                else:
                    hi = mid
        points.append(lo)
        a = lo
    return points


def fit_piecewise(voltage: Callable[[np.ndarray], np.ndarray], low: float, high: float,
                  max_branches: int = MAX_BRANCHES) -> PiecewiseFit:
    """The parallel branches of at most ``max_branches`` within ``±e`` of the concave
    increasing ``voltage(i)`` over ``[low, high]`` [A], ``e`` minimal (see the module)."""
    if not (0 < low < high and np.isfinite(high)):
        raise ValueError(f"fit range must satisfy 0 < low < high, got {low}..{high}")
    currents = np.geomspace(low, high, SAMPLES)
    volts = np.asarray(voltage(currents), dtype=float)
    whole = _chord_deviation(currents, volts, 0, currents.size - 1)
    points = [0, currents.size - 1]
    if whole > 2 * TARGET_ERROR and max_branches > 1:
        small, large = 0.0, whole  # bisection on the largest chord deviation
        for _ in range(50):
            middle = (small + large) / 2
            if len(_greedy(currents, volts, middle)) - 1 <= max_branches:
                large = middle
            else:
                small = middle
            if large - small < 1e-6 * whole or large <= 2 * TARGET_ERROR and small > 0:
                break
        points = _greedy(currents, volts, max(large, 2 * TARGET_ERROR))
    return _branches(currents, volts, points)


def _branches(currents: np.ndarray, volts: np.ndarray, points: list[int]) -> PiecewiseFit:
    """The fit whose chords join the samples ``points``, lifted to centre the error; a knee
    whose conductance would not be positive (a curve not concave there) is dropped."""
    slopes = [(volts[b] - volts[a]) / (currents[b] - currents[a]) for a, b in zip(points, points[1:])]
    keep = [0]
    for m in range(1, len(slopes)):  # a chord must be flatter than the one before it
        if slopes[m] < slopes[keep[-1]] * (1 - 1e-9) and slopes[m] > 0:
            keep.append(m)
    if len(keep) < len(slopes):  # refit the chords between the breakpoints kept
        points = [points[m] for m in keep] + [points[-1]]
        slopes = [(volts[b] - volts[a]) / (currents[b] - currents[a])
                  for a, b in zip(points, points[1:])]
        if any(later >= earlier for earlier, later in zip(slopes, slopes[1:])):
            points = [points[0], points[-1]]
            slopes = [(volts[-1] - volts[0]) / (currents[-1] - currents[0])]
    slopes = [max(s, 0.0) for s in slopes]
    below = np.concatenate([volts[a:b + 1] - volts[a] - s * (currents[a:b + 1] - currents[a])
                            for a, b, s in zip(points, points[1:], slopes)])
    lift = (float(below.max()) + float(below.min())) / 2
    knees = [volts[points[0]] - slopes[0] * currents[points[0]] + lift]
    knees += [volts[p] + lift for p in points[1:-1]]
    resistances = [slopes[0]] + [1 / (1 / s - 1 / r) for r, s in zip(slopes, slopes[1:])]
    if knees[0] < 0:  # no conduction at zero voltage
        knees[0] = 0.0
    fit = PiecewiseFit(tuple(float(v) for v in knees), tuple(float(r) for r in resistances),
                       float(currents[0]), float(currents[-1]), 0.0)
    error = float(np.max(np.abs(fit.voltage(currents) - volts)))
    return PiecewiseFit(fit.knees, fit.resistances, fit.low, fit.high, error)


def fit_range(high: float, decades: float = FIT_DECADES) -> tuple[float, float]:
    """``(high·10^-decades, high)`` [A]."""
    return high * 10.0 ** -decades, high


def fit_forward(diode: ShockleyDiode, high: float | None = None) -> PiecewiseFit:
    """The forward branches of ``diode`` over :func:`fit_range` of ``high`` [A] (default
    ``IAVE`` or :data:`DEFAULT_FIT_CURRENT`)."""
    high = high or diode.average_current or DEFAULT_FIT_CURRENT
    return fit_piecewise(diode.forward_voltage, *fit_range(high))


def fit_breakdown(diode: ShockleyDiode, high: float | None = None,
                  max_branches: int = MAX_BRANCHES) -> PiecewiseFit:
    """The breakdown branches (at most ``max_branches``) of ``diode`` (which needs ``BV``)
    over :func:`fit_range` of ``high`` [A] (default :data:`DEFAULT_FIT_CURRENT`)."""
    return fit_piecewise(diode.breakdown_drop, *fit_range(high or DEFAULT_FIT_CURRENT),
                         max_branches)
