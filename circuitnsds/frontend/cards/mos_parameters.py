"""Level 1–3 MOSFET parameters a model leaves out, derived as ngspice derives them.

A vendor model often gives the process (``NSUB``, ``TOX``, ``UO``, ``XJ``, ``LD``) instead of
``VTO`` and ``KP``; ngspice then computes them at ``TNOM`` (``mos1temp.c``, ``mos3temp.c``):

* ``Cox = εox/TOX``; ``TOX`` defaults to 1e-7 m for levels 2 and 3, and level 1 derives
  nothing without it;
* ``KP = UO·Cox·1e-4`` (``UO`` [cm²/Vs], default 600) when ``KP`` is not given;
* with ``NSUB`` [cm⁻³] (which must exceed the intrinsic density ``ni``, 1.45e10 cm⁻³ at
  300 K; level 3 scales it to ``TNOM``): ``PHI = 2·Vt·ln(NSUB/ni)`` (at least 0.1 V)
  unless given, ``GAMMA = sqrt(2·εsi·q·NSUB)/Cox`` unless given, and, unless ``VTO`` is
  given, ``VTO = Vfb + type·(GAMMA·sqrt(PHI) + PHI)`` with the flat-band voltage
  ``Vfb = Φms − NSS·q/Cox`` of a polysilicon gate (``TPG``, default 1: opposite to the
  substrate; 0: aluminium, work function 3.2 V) and the band gap
  ``Eg = 1.16 − 7.02e-4·T²/(T + 1108)``.

Level 3 lowers the threshold of a short channel (``XJ``, ``LD``: the body effect scaled
by ``fshort``) and raises that of a narrow one (``DELTA``), as its load routine does at
``Vbs = 0``; its drain feedback ``ETA`` (a shift ``−η·Vds``) depends on the drain voltage
and is left out (said where the rule is printed).
"""

from __future__ import annotations

import math

VACUUM_PERMITTIVITY = 8.854214871e-12
"""[F/m], ngspice's value."""
OXIDE_PERMITTIVITY = 3.9 * VACUUM_PERMITTIVITY
"""[F/m]"""
SILICON_PERMITTIVITY = 11.7 * VACUUM_PERMITTIVITY
"""[F/m]"""
CHARGE = 1.602176634e-19
"""[C]"""
BOLTZMANN = 1.380649e-23
"""[J/K]"""
NOMINAL_TEMPERATURE = 300.15
"""[K]: ``TNOM`` 27 °C."""
INTRINSIC_DENSITY = 1.45e16
"""[m⁻³] at 300 K."""
DEFAULT_OXIDE = 1e-7
"""``TOX`` [m] of levels 2 and 3 when not given."""
DEFAULT_MOBILITY = 600.0
"""``UO`` [cm²/Vs]."""
SHORT_CHANNEL_COEFFICIENTS = (0.0631353, 0.8013292, -0.01110777)
"""Level 3's fit of the depletion-region corner (SPICE2's coefficients)."""


def _level(params: dict[str, float]) -> int:
    return int(params.get("level", 1))


def oxide_capacitance(params: dict[str, float]) -> float | None:
    """``Cox`` [F/m²], or ``None`` for a level-1 model without ``TOX``."""
    tox = params.get("tox")
    if tox is None and _level(params) != 1:
        tox = DEFAULT_OXIDE
    return None if not tox else OXIDE_PERMITTIVITY / tox


def transconductance(params: dict[str, float]) -> tuple[float, str]:
    """``(KP [A/V²], how it was found)``."""
    if "kp" in params:
        return params["kp"], "KP"
    cox = oxide_capacitance(params)
    if cox is None:
        return 2e-5, "ngspice's default KP"
    mobility = params.get("u0", params.get("uo", DEFAULT_MOBILITY))
    return mobility * cox * 1e-4, f"KP = UO·εox/TOX (UO={mobility:g})"


def _band_gap(temperature: float) -> float:
    return 1.16 - 7.02e-4 * temperature ** 2 / (temperature + 1108)


def _process(params: dict[str, float], polarity: int) -> dict[str, float] | None:
    """``phi``, ``gamma``, ``vt0`` [V, √V, V] and ``cox``, ``depletion`` (the depletion width
    coefficient [m/√V]) derived from ``NSUB``; ``None`` without ``NSUB`` (or ``Cox``)."""
    cox = oxide_capacitance(params)
    if cox is None or "nsub" not in params:
        return None
    temperature = params.get("tnom", NOMINAL_TEMPERATURE - 273.15) + 273.15
    vt = BOLTZMANN * temperature / CHARGE
    gap = _band_gap(temperature)
    intrinsic = INTRINSIC_DENSITY
    if _level(params) == 3:  # ni at TNOM
        intrinsic *= (temperature / 300) ** 1.5 * math.exp(
            0.5 * gap * (1 / 300 - 1 / temperature) / (BOLTZMANN / CHARGE))
    doping = params["nsub"] * 1e6
    if doping <= intrinsic:
        raise ValueError(f"NSUB={params['nsub']:g} is below the intrinsic carrier density")
    phi = params.get("phi", max(0.1, 2 * vt * math.log(doping / intrinsic)))
    gamma = params.get("gamma", math.sqrt(2 * SILICON_PERMITTIVITY * CHARGE * doping) / cox)
    gate = params.get("tpg", 1.0)
    work = 3.2 if gate == 0 else 3.25 + 0.5 * gap - polarity * gate * 0.5 * gap
    flat_band = (work - (3.25 + 0.5 * gap + polarity * 0.5 * phi)
                 - params.get("nss", 0.0) * 1e4 * CHARGE / cox)
    vt0 = params.get("vto", params.get("vt0",
                                       flat_band + polarity * (gamma * math.sqrt(phi) + phi)))
    depletion = math.sqrt(2 * SILICON_PERMITTIVITY / (CHARGE * doping))
    return {"phi": phi, "gamma": gamma, "vt0": vt0, "cox": cox, "depletion": depletion}


def threshold(params: dict[str, float], polarity: int, length: float,
              width: float) -> tuple[float, str]:
    """``(Vto [V] as written, i.e. negative for an enhancement p-channel device, how it was
    found)`` of a level 1–3 model for a channel ``length`` × ``width`` [m] at ``Vbs = 0``."""
    given = params.get("vto", params.get("vt0"))
    process = _process(params, polarity)
    if process is None:
        return (given, "VTO") if given is not None else (0.0, "ngspice's default VTO")
    vt0 = process["vt0"]
    rule = "VTO" if given is not None else (
        f"VTO from NSUB, TOX (PHI={process['phi']:.4g} V, GAMMA={process['gamma']:.4g} √V)")
    if _level(params) != 3:
        return vt0, rule
    phi, gamma = process["phi"], process["gamma"]
    effective = length - 2 * params.get("ld", 0.0)
    junction = params.get("xj", 0.0)
    fshort = 1.0
    if junction > 0 and effective > 0:
        c0, c1, c2 = SHORT_CHANNEL_COEFFICIENTS
        ratio = process["depletion"] * math.sqrt(phi) / junction
        lateral = params.get("ld", 0.0) / junction
        corner = c0 + c1 * ratio + c2 * ratio * ratio + lateral
        shape = math.sqrt(1 - (ratio / (1 + ratio)) ** 2)
        fshort = 1 - junction / effective * (corner * shape - lateral)
    narrow = params.get("delta", 0.0) * 0.5 * math.pi * SILICON_PERMITTIVITY / process["cox"]
    effective_width = width - 2 * params.get("wd", 0.0)
    built_in = vt0 - polarity * gamma * math.sqrt(phi)
    value = built_in + polarity * (gamma * fshort * math.sqrt(phi) + narrow * phi / effective_width)
    shifted = abs(value - vt0) > 1e-12
    note = (f"; level 3 at Vbs=0: {value:.4g} V (short channel fshort={fshort:.4g}"
            f"{', narrow channel DELTA' if narrow else ''})" if shifted else "")
    eta = "; ETA's drain feedback left out" if params.get("eta") else ""
    return value, rule + note + eta
