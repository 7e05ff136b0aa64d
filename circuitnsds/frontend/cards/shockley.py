"""A piecewise-linear diode (``Vfwd``, ``Ron``) from Shockley parameters (``IS``, ``N``, ``RS``).

The Shockley diode with series resistance has the forward characteristic

    v(i) = N·Vt·ln(1 + i/IS) + RS·i            (Vt = k·T/q at 27 °C)

and the piecewise-linear diode ``v = Vfwd + Ron·i`` (for ``i > 0``) replaces it by the
chord through the two points ``i = I/10`` and ``i = I`` of that curve: over that decade
the two differ by at most a few tens of millivolts, and the knee sits where the real
diode starts to carry a current that matters. ``I`` defaults to
:data:`DEFAULT_FIT_CURRENT`.

This is one small function on purpose: the general Shockley → PWL fit of diode models
(issue 18, with a user-set current range) replaces it when it lands, and the MOSFET body
diode then calls that one.
"""

from __future__ import annotations

import math

BOLTZMANN = 1.380649e-23
"""[J/K]"""
ELEMENTARY_CHARGE = 1.602176634e-19
"""[C]"""
THERMAL_VOLTAGE = BOLTZMANN * 300.15 / ELEMENTARY_CHARGE
"""``k·T/q`` at 27 °C (SPICE's nominal temperature) [V], about 25.86 mV."""
DEFAULT_FIT_CURRENT = 1.0
"""Upper end ``I`` [A] of the fitted decade ``[I/10, I]``."""


def shockley_voltage(current: float, saturation_current: float, emission: float = 1.0,
                     series_resistance: float = 0.0) -> float:
    """Forward voltage [V] of the Shockley diode carrying ``current`` [A] (> 0)."""
    return (emission * THERMAL_VOLTAGE * math.log1p(current / saturation_current)
            + series_resistance * current)


def piecewise_linear_fit(saturation_current: float, emission: float = 1.0,
                         series_resistance: float = 0.0,
                         current: float = DEFAULT_FIT_CURRENT) -> tuple[float, float]:
    """``(Vfwd [V], Ron [Ω])`` of the chord of the Shockley curve over ``[current/10, current]``.

    ``Ron`` is ``RS`` plus the junction's chord slope ``N·Vt·ln(…)/(0.9·I)``; ``Vfwd`` is
    where the chord meets ``i = 0`` (never negative).
    """
    if saturation_current <= 0 or emission <= 0 or current <= 0:
        raise ValueError("IS, N and the fit current must be positive")
    low, high = current / 10.0, current
    v_low = shockley_voltage(low, saturation_current, emission, series_resistance)
    v_high = shockley_voltage(high, saturation_current, emission, series_resistance)
    on_resistance = (v_high - v_low) / (high - low)
    return max(v_low - on_resistance * low, 0.0), on_resistance
