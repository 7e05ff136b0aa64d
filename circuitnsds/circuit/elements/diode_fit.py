"""Piecewise-linear diode fitted to a Shockley (SPICE level-1) model.

A vendor ``.model NAME D(IS=.. N=.. RS=.. BV=.. IBV=.. NBV=..)`` describes the
static characteristic (ngspice ``dioload.c``/``diotemp.c``, at ``TNOM`` = 27 °C)

* forward, current ``i > 0``:  ``v(i) = N·Vt·ln(1 + i/IS) + RS·i``
* breakdown, reverse current ``r > 0`` (``v = -(BV + NBV·Vt·ln(r/IBV) + RS·r)``):
  ``v_rev(r) = BV + NBV·Vt·ln(r/IBV) + RS·r``

(ngspice places its internal breakdown voltage so that the reverse current at
``-BV`` is ``IBV``, which is the form above to within ``IS``).

circuitnsds's diode is piecewise linear: ``v = Vfwd + Ron·i`` while conducting and
``v = -(Vrev + Rrev·r)`` in breakdown. :func:`fit_line` chooses the straight line
that is the least-squares fit, in volts, of the Shockley curve sampled at
:data:`FIT_POINTS` currents spaced evenly over ``[high/FIT_DECADE, high]``; ``high``
is the fit current (``.options pwlfit=`` [A], else the model's ``IAVE`` for the
forward branch and ``IBV`` for the breakdown branch, else :data:`DEFAULT_FIT_CURRENT`).
The fitted line meets the curve within the range; below it the line overestimates
the drop (a diode conducting a few mA drops less than ``Vfwd``).

This module is shared by every element that has a PN junction (diodes, the body
diode of a MOSFET): it knows no netlist syntax.
"""

from __future__ import annotations

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

FIT_POINTS = 41
"""Currents sampled in the fit range."""
FIT_DECADE = 10.0
"""The fit range is ``[high/FIT_DECADE, high]``."""
DEFAULT_FIT_CURRENT = 1.0
"""``high`` [A] when neither ``.options pwlfit`` nor ``IAVE``/``IBV`` gives one."""


@dataclass(frozen=True)
class ShockleyDiode:
    """The static parameters of a SPICE level-1 diode (ngspice's defaults).

    Attributes:
        saturation_current: ``IS`` [A] (> 0).
        emission: ``N`` (> 0).
        series_resistance: ``RS`` [Ω].
        breakdown_voltage: ``BV`` [V] (> 0), ``None`` for none.
        breakdown_current: ``IBV`` [A] (> 0), the reverse current at ``-BV``.
        breakdown_emission: ``NBV``.
        average_current: ``IAVE`` [A] (LTspice's rated average current), or ``None``.
    """

    saturation_current: float = 1e-14
    emission: float = 1.0
    series_resistance: float = 0.0
    breakdown_voltage: float | None = None
    breakdown_current: float = 1e-3
    breakdown_emission: float = 1.0
    average_current: float | None = None

    def forward_voltage(self, current: np.ndarray | float) -> np.ndarray:
        """Terminal voltage [V] at forward current ``current`` [A] (> 0)."""
        i = np.asarray(current, dtype=float)
        vt = self.emission * THERMAL_VOLTAGE
        return vt * np.log1p(i / self.saturation_current) + self.series_resistance * i

    def breakdown_drop(self, current: np.ndarray | float) -> np.ndarray:
        """Magnitude of the terminal voltage [V] at reverse current ``current`` [A] (> 0)
        in breakdown."""
        if self.breakdown_voltage is None:
            raise ValueError("the model has no breakdown voltage")
        r = np.asarray(current, dtype=float)
        vt = self.breakdown_emission * THERMAL_VOLTAGE
        return (self.breakdown_voltage + vt * np.log(r / self.breakdown_current)
                + self.series_resistance * r)


@dataclass(frozen=True)
class LineFit:
    """``v ≈ drop + resistance·i`` over ``low <= i <= high``.

    Attributes:
        drop: intercept [V] (``Vfwd`` or ``Vrev``), >= 0.
        resistance: slope [Ω] (``Ron`` or ``Rrev``), >= 0.
        low, high: the fit range [A].
        max_error: largest ``|v_line - v_shockley|`` over the range [V].
    """

    drop: float
    resistance: float
    low: float
    high: float
    max_error: float

    def describe(self, drop_name: str, resistance_name: str) -> str:
        return (f"{drop_name}={self.drop:.4g} V {resistance_name}={self.resistance:.4g} Ω "
                f"(least squares over {self.low:.3g}..{self.high:.3g} A, "
                f"within {1e3 * self.max_error:.3g} mV)")


def fit_line(voltage, high: float, low: float | None = None) -> LineFit:
    """Least-squares line through ``voltage(i)`` for :data:`FIT_POINTS` currents evenly
    spaced in ``[low, high]`` (default ``low = high/FIT_DECADE``).

    The line is kept physical: a negative intercept becomes 0 (the line through the
    origin is then refitted) and a negative slope 0.
    """
    if not high > 0:
        raise ValueError(f"fit current must be positive, got {high}")
    low = high / FIT_DECADE if low is None else low
    if not 0 < low < high:
        raise ValueError(f"fit range must satisfy 0 < low < high, got {low}..{high}")
    currents = np.linspace(low, high, FIT_POINTS)
    volts = np.asarray(voltage(currents), dtype=float)
    slope, intercept = np.polyfit(currents, volts, 1)
    if intercept < 0:
        intercept, slope = 0.0, float(currents @ volts / (currents @ currents))
    if slope < 0:
        slope, intercept = 0.0, float(volts.mean())
    error = float(np.max(np.abs(intercept + slope * currents - volts)))
    return LineFit(float(intercept), float(slope), float(low), float(high), error)


def fit_forward(diode: ShockleyDiode, high: float | None = None) -> LineFit:
    """``Vfwd``/``Ron`` of ``diode``; ``high`` [A] defaults to ``IAVE`` or
    :data:`DEFAULT_FIT_CURRENT`."""
    high = high or diode.average_current or DEFAULT_FIT_CURRENT
    return fit_line(diode.forward_voltage, high)


def fit_breakdown(diode: ShockleyDiode, high: float | None = None) -> LineFit:
    """``Vrev``/``Rrev`` of ``diode`` (which needs ``BV``); ``high`` [A] defaults to
    ``IBV``."""
    high = high or diode.breakdown_current
    return fit_line(diode.breakdown_drop, high)
