"""What ngspice's semiconductor devices share: the thermal voltage, the pn-junction current
and depletion charge as its load routines write them, and SPICE's Newton limiting
(``DEVpnjlim``, ``DEVfetlim``, ``DEVlimvds`` of ngspice's ``devsup.c``).

Sign conventions: a junction voltage ``v`` [V] is anode minus cathode (p side minus n side);
its current [A] flows from anode to cathode through the junction; its charge [C] is the one
stored on the anode side.
"""

from __future__ import annotations

import math

BOLTZMANN = 1.38064852e-23
"""[J/K], ngspice 39's ``CONSTboltz``."""
CHARGE = 1.6021766208e-19
"""[C], ngspice 39's ``CHARGE``."""
NOMINAL_TEMPERATURE = 27.0 + 273.15
"""[K]: ngspice's ``TNOM`` and circuit temperature (27 °C) unless the netlist sets them."""
ROOT2 = math.sqrt(2.0)
DEFAULT_GMIN = 1e-12
"""[S]: ngspice's ``GMIN``, the conductance it puts across every junction."""


def thermal_voltage(temperature: float = NOMINAL_TEMPERATURE) -> float:
    """``kT/q`` [V] at ``temperature`` [K] with ngspice's constants."""
    return temperature * BOLTZMANN / CHARGE


def critical_voltage(saturation: float, vt: float) -> float:
    """``Vcrit = Vt·ln(Vt/(√2·Is))`` [V]: where SPICE starts limiting a junction's steps
    (``saturation`` [A], ``vt`` [V]); infinite for ``IS = 0`` (never limited)."""
    if saturation <= 0.0:  # no junction current (IS=0): nothing to limit
        return math.inf
    return vt * math.log(vt / (ROOT2 * saturation))


def junction_current(v: float, saturation: float, vtn: float) -> tuple[float, float]:
    """``(i [A], di/dv [S])`` of a pn junction as ngspice's BJT load writes it: Shockley's
    ``Is·(exp(v/(N·Vt)) − 1)`` above ``−3·N·Vt``, below it ``−Is·(1 + (3·N·Vt/(e·v))³)``,
    which meets it with its slope there and tends to ``−Is``. ``vtn`` is ``N·Vt`` [V]."""
    if saturation == 0.0:
        return 0.0, 0.0
    if v >= -3.0 * vtn:
        grown = math.exp(v / vtn)
        return saturation * (grown - 1.0), saturation * grown / vtn
    cube = (3.0 * vtn / (v * math.e)) ** 3
    return -saturation * (1.0 + cube), saturation * 3.0 * cube / v


def depletion_coefficients(vj: float, m: float, fc: float) -> tuple[float, float, float]:
    """``(f1, f2, f3)`` of ngspice's depletion charge above ``FC·VJ``: ``f1 = VJ·(1 −
    (1 − FC)^(1−M))/(1 − M)`` [V], ``f2 = (1 − FC)^(1+M)``, ``f3 = 1 − FC·(1 + M)``."""
    xfc = math.log(1.0 - fc)
    return (vj * (1.0 - math.exp((1.0 - m) * xfc)) / (1.0 - m), math.exp((1.0 + m) * xfc),
            1.0 - fc * (1.0 + m))


def depletion_charge(v: float, cj: float, vj: float, m: float, fc: float) -> tuple[float, float]:
    """``(q [C], dq/dv [F])`` of a junction's depletion capacitance ``cj`` [F] at zero bias,
    built-in potential ``vj`` [V], grading ``m``: ``cj/(1 − v/vj)^m`` below ``fc·vj``, its
    linear extrapolation above (ngspice's form), integrated from 0 V."""
    if cj == 0.0:
        return 0.0, 0.0
    corner = fc * vj
    if v < corner:
        arg = 1.0 - v / vj
        sarg = math.exp(-m * math.log(arg))
        return vj * cj * (1.0 - arg * sarg) / (1.0 - m), cj * sarg
    f1, f2, f3 = depletion_coefficients(vj, m, fc)
    scaled = cj / f2
    charge = cj * f1 + scaled * (f3 * (v - corner) + m / (2.0 * vj) * (v * v - corner * corner))
    return charge, scaled * (f3 + m * v / vj)


def pnjlim(vnew: float, vold: float, vt: float, vcrit: float) -> float:
    """SPICE's junction limiting (``DEVpnjlim``): the junction voltage [V] to evaluate at
    instead of Newton's ``vnew``, after ``vold``; above ``vcrit`` a step of more than ``2·Vt``
    becomes logarithmic, so that ``exp(v/Vt)`` grows at most in proportion to the step."""
    if vnew > vcrit and abs(vnew - vold) > vt + vt:
        if vold > 0:
            arg = (vnew - vold) / vt
            if arg > 0:
                return vold + vt * (2.0 + math.log(arg - 2.0))
            return vold - vt * (2.0 + math.log(2.0 - arg))
        return vt * math.log(vnew / vt)
    if vnew < 0:
        floor = -vold - 1.0 if vold > 0 else 2.0 * vold - 1.0
        return max(vnew, floor)
    return vnew


def fetlim(vnew: float, vold: float, vto: float) -> float:
    """SPICE's gate-voltage limiting of a field-effect transistor (``DEVfetlim``): ``vnew``
    [V] held to steps that stay near the threshold ``vto`` [V] where the current turns on."""
    high = abs(2.0 * (vold - vto)) + 2.0
    low = abs(vold - vto) + 1.0
    on = vto + 3.5
    step = vnew - vold
    if vold >= vto:
        if vold >= on:
            if step <= 0:
                if vnew >= on:
                    return vold - low if -step > low else vnew
                return max(vnew, vto + 2.0)
            return vold + high if step >= high else vnew
        return max(vnew, vto - 0.5) if step <= 0 else min(vnew, vto + 4.0)
    if step <= 0:
        return vold - high if -step > high else vnew
    if vnew <= vto + 0.5:
        return vold + low if step > low else vnew
    return vto + 0.5


def limvds(vnew: float, vold: float) -> float:
    """SPICE's drain–source voltage limiting (``DEVlimvds``) [V]."""
    if vold >= 3.5:
        if vnew > vold:
            return min(vnew, 3.0 * vold + 2.0)
        return max(vnew, 2.0) if vnew < 3.5 else vnew
    return min(vnew, 4.0) if vnew > vold else max(vnew, -0.5)
