"""The bipolar transistor as ngspice's level 1 (Gummel–Poon) has it, a smooth device.

``Q name c b e [s] MODEL``: the intrinsic transistor between the internal nodes ``c'``,
``b'``, ``e'`` (the external ones when ``RC``, ``RB``, ``RE`` are 0), ``RC`` and ``RE`` as
linear resistors from the terminals to them, the base resistance (which falls with the
base charge when ``RBM < RB``, or with the base current when ``IRB`` is given) and the
junction charges. Equations and defaults are ngspice 39's (``bjtload.c``, ``bjtsetup.c``,
``bjttemp.c``) at the nominal temperature (27 °C = ``TNOM``):

* junction voltages ``vbe = type·(v(b') − v(e'))``, ``vbc = type·(v(b') − v(c'))``,
  ``vbx = type·(v(b) − v(c'))`` (``type`` +1 NPN, −1 PNP);
* ``Ibe = IS·(exp(vbe/(NF·Vt)) − 1)``, ``Ibc = IS·(exp(vbc/(NR·Vt)) − 1)`` (below −3·N·Vt
  ngspice's cubic tail, :func:`~circuitnsds.circuit.elements.smooth.junctions.junction_current`),
  the leakages ``ISE`` (``NE``) and ``ISC`` (``NC``), with ``GMIN`` across each junction;
* base charge ``qb = q1·(1 + sqrt(1 + 4·q2))/2``, ``q1 = 1/(1 − vbc/VAF − vbe/VAR)``,
  ``q2 = Ibe/IKF + Ibc/IKR``;
* collector current into ``c'``: ``Ic = (Ibe − Ibc)/qb − Ibc/BR − Ibcn``; base current into
  ``b'``: ``Ib = Ibe/BF + Iben + Ibc/BR + Ibcn``; the emitter's is ``−(Ic + Ib)``;
* charges: ``Qbe = TF·Ibe·(1 + XTF·exp(vbc/(1.44·VTF))·(Ibe/(Ibe + ITF))²)/qb`` (for
  ``vbe > 0``) plus the depletion charge of ``CJE``; ``Qbc = TR·Ibc`` plus that of
  ``XCJC·CJC``; ``Qbx`` the depletion charge of ``(1 − XCJC)·CJC`` between ``b`` and ``c'``;
* ``GMIN`` between the substrate (ground for a three-terminal line) and ``c'`` (vertical,
  NPN's default) or ``b'`` (lateral, PNP's default), as ngspice's substrate junction without
  ``ISS``.

Currents and charges are per device, multiplied by the instance's ``M``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial
from typing import ClassVar

import numpy as np

from circuitnsds.circuit.elements.base import Element
from circuitnsds.circuit.elements.smooth.junctions import (
    DEFAULT_GMIN,
    critical_voltage,
    depletion_charge,
    junction_current,
    pnjlim,
    thermal_voltage,
)
from circuitnsds.circuit.elements.smooth.terminals import (
    TerminalMap,
    add_branches,
    add_resistors,
    difference_gradient,
    scattered_evaluator,
)
from circuitnsds.errors import SourceLocation
from circuitnsds.system.mlcs import MLCSBuilder
from circuitnsds.system.smooth import SmoothRelation

C, B, E, S, CI, BI, EI = range(7)
"""Terminal positions of a BJT's equations: collector, base, emitter, substrate, and the
internal collector, base and emitter."""


@dataclass(frozen=True)
class BjtModel:
    """``.model NAME NPN|PNP(...)``: Gummel–Poon parameters, ngspice 39's defaults and units.

    Attributes:
        polarity: +1 NPN, −1 PNP.
        is_: ``IS`` transport saturation current [A].
        bf, br: ``BF``, ``BR`` ideal forward and reverse beta.
        nf, nr: ``NF``, ``NR`` emission coefficients.
        vaf, var: ``VAF``, ``VAR`` Early voltages [V] (0: none).
        ikf, ikr: ``IKF``, ``IKR`` high-injection knee currents [A] (0: none).
        ise, ne, isc, nc: B-E and B-C leakage saturation currents [A] (a value above 1e-4 is
            a multiple of ``IS``, as SPICE2 had it) and their emission coefficients.
        rb, rbm, irb: zero-bias and minimum base resistance [Ω] (``RBM`` defaults to ``RB``),
            current where it is halfway between them [A] (0: none).
        rc, re: collector and emitter resistances [Ω].
        cje, vje, mje: B-E zero-bias depletion capacitance [F], potential [V], grading.
        cjc, vjc, mjc, xcjc: the same of B-C, and the fraction of it at the internal base.
        tf, xtf, vtf, itf: forward transit time [s], its bias coefficient, its ``vbc``
            dependence [V] (0: none), its high-current parameter [A].
        tr: reverse transit time [s].
        fc: forward-bias depletion capacitance coefficient.
        lateral: the substrate junction is at the base (``SUBS=-1``, PNP's default) rather
            than at the collector (``SUBS=1``, NPN's default).
        cjs: ``CJS`` (``CCS``, ``CSUB``) substrate capacitance [F] across that junction,
            constant as ngspice's with its default grading ``MJS = 0``.
    """

    name: str
    polarity: int = 1
    is_: float = 1e-16
    bf: float = 100.0
    br: float = 1.0
    nf: float = 1.0
    nr: float = 1.0
    vaf: float = 0.0
    var: float = 0.0
    ikf: float = 0.0
    ikr: float = 0.0
    ise: float = 0.0
    ne: float = 1.5
    isc: float = 0.0
    nc: float = 2.0
    rb: float = 0.0
    rbm: float | None = None
    irb: float = 0.0
    rc: float = 0.0
    re: float = 0.0
    cje: float = 0.0
    vje: float = 0.75
    mje: float = 0.33
    cjc: float = 0.0
    vjc: float = 0.75
    mjc: float = 0.33
    xcjc: float = 1.0
    tf: float = 0.0
    xtf: float = 0.0
    vtf: float = 0.0
    itf: float = 0.0
    tr: float = 0.0
    fc: float = 0.5
    lateral: bool = False
    cjs: float = 0.0
    location: SourceLocation | None = field(default=None, compare=False)

    @property
    def kind(self) -> str:
        return "npn" if self.polarity > 0 else "pnp"

    @property
    def has_charges(self) -> bool:
        """Whether any junction stores charge."""
        return any((self.cje, self.cjc, self.tf, self.tr, self.cjs))

    @property
    def base_leakage(self) -> tuple[float, float]:
        """``(ISE, ISC)`` [A], a value above 1e-4 read as a multiple of ``IS``."""
        return tuple(value * self.is_ if value > 1e-4 else value for value in (self.ise, self.isc))


@dataclass(frozen=True)
class GummelPoonDC:
    """The DC currents of the intrinsic transistor and their derivatives.

    Attributes:
        collector, base: ``Ic`` into ``c'``, ``Ib`` into ``b'`` [A] (NPN sense: for a PNP
            the terminal currents are these times −1).
        collector_vbe, collector_vbc, base_vbe, base_vbc: their derivatives [S].
        qb, qb_vbe, qb_vbc: the normalised base charge and its derivatives [1/V].
        ibe, gbe, ibc, gbc: the ideal junction currents ``Ibe``, ``Ibc`` [A] and slopes [S].
    """

    collector: float
    base: float
    collector_vbe: float
    collector_vbc: float
    base_vbe: float
    base_vbc: float
    qb: float
    qb_vbe: float
    qb_vbc: float
    ibe: float
    gbe: float
    ibc: float
    gbc: float


def gummel_poon_dc(model: BjtModel, vbe: float, vbc: float, vt: float,
                   gmin: float = DEFAULT_GMIN) -> GummelPoonDC:
    """The intrinsic transistor's DC currents at the junction voltages ``vbe``, ``vbc`` [V]
    (``type``-signed: positive forward for both NPN and PNP), thermal voltage ``vt`` [V] and
    junction conductance ``gmin`` [S], as ngspice's ``bjtload.c`` computes them."""
    ise, isc = model.base_leakage
    ibe, gbe = junction_current(vbe, model.is_, model.nf * vt)
    iben, gben = junction_current(vbe, ise, model.ne * vt)
    iben, gben = iben + gmin * vbe, gben + gmin
    ibc, gbc = junction_current(vbc, model.is_, model.nr * vt)
    ibcn, gbcn = junction_current(vbc, isc, model.nc * vt)
    ibcn, gbcn = ibcn + gmin * vbc, gbcn + gmin
    inv_vaf = 1.0 / model.vaf if model.vaf else 0.0
    inv_var = 1.0 / model.var if model.var else 0.0
    inv_ikf = 1.0 / model.ikf if model.ikf else 0.0
    inv_ikr = 1.0 / model.ikr if model.ikr else 0.0
    q1 = 1.0 / (1.0 - inv_vaf * vbc - inv_var * vbe)
    if inv_ikf == 0.0 and inv_ikr == 0.0:
        qb, qb_vbe, qb_vbc = q1, q1 * q1 * inv_var, q1 * q1 * inv_vaf
    else:
        q2 = inv_ikf * ibe + inv_ikr * ibc
        arg = max(0.0, 1.0 + 4.0 * q2)
        root = math.sqrt(arg) if arg != 0.0 else 1.0
        qb = q1 * (1.0 + root) / 2.0
        slope = 0.0 if arg == 0.0 else 1.0 / root  # d(root)/d(q2) / 2
        qb_vbe = q1 * (qb * inv_var + inv_ikf * gbe * slope)
        qb_vbc = q1 * (qb * inv_vaf + inv_ikr * gbc * slope)
    transport = (ibe - ibc) / qb
    return GummelPoonDC(
        collector=transport - ibc / model.br - ibcn,
        base=ibe / model.bf + iben + ibc / model.br + ibcn,
        collector_vbe=gbe / qb - transport * qb_vbe / qb,
        collector_vbc=-gbc / qb - transport * qb_vbc / qb - gbc / model.br - gbcn,
        base_vbe=gbe / model.bf + gben,
        base_vbc=gbc / model.br + gbcn,
        qb=qb, qb_vbe=qb_vbe, qb_vbc=qb_vbc, ibe=ibe, gbe=gbe, ibc=ibc, gbc=gbc,
    )


_CRIT = 14.59025
_SCALE = 2.4317


SHAPE_SERIES_BELOW = 0.1
"""``z`` below which :func:`_base_shape` sums its Taylor series (its closed form subtracts
nearly equal numbers there: ``tan z − z`` of a small base current lost 7 digits, which made
the base resistance jitter by 1e-5 Ω, enough to show as 6e-6 S in a finite difference)."""
_SHAPE_SERIES = (1 / 3, -4 / 45, -4 / 315, -8 / 4725, -4 / 18711, -5528 / 212837625)
"""Coefficients of ``z^0, z^2, ..., z^10`` of ``(tan z − z)/(z·tan² z)``."""


def _base_shape(z: float) -> tuple[float, float]:
    """``(s, ds/dz)`` of ``s(z) = (tan z − z)/(z·tan² z)``, SPICE2's base-resistance shape
    (``1/3`` at ``z = 0``)."""
    if z < SHAPE_SERIES_BELOW:
        square = z * z
        value = slope = 0.0
        for k in range(len(_SHAPE_SERIES) - 1, -1, -1):
            value = value * square + _SHAPE_SERIES[k]
            if k:
                slope = slope * square + 2 * k * _SHAPE_SERIES[k]
        return value, slope * z
    t = math.tan(z)
    numerator, denominator = t * t, z * t * t
    slope_denominator = t * t + 2.0 * z * t * (1.0 + t * t)
    return ((t - z) / denominator,
            (numerator * denominator - (t - z) * slope_denominator) / denominator ** 2)


def base_resistance(model: BjtModel, dc: GummelPoonDC) -> tuple[float, float, float]:
    """``(rbb [Ω], drbb/dvbe, drbb/dvbc [Ω/V])``: ngspice's base resistance, ``RBM + (RB −
    RBM)/qb``, or with ``IRB`` the SPICE2 form ``RBM + 3·(RB − RBM)·(tan z − z)/(z·tan² z)``,
    ``z`` a function of ``Ib/IRB``."""
    minimum = model.rb if model.rbm is None else model.rbm
    extra = model.rb - minimum
    if model.irb == 0.0:
        return (minimum + extra / dc.qb, -extra * dc.qb_vbe / dc.qb ** 2,
                -extra * dc.qb_vbc / dc.qb ** 2)
    ratio = dc.base / model.irb
    clamped = ratio <= 1e-9
    a = max(ratio, 1e-9)
    root = math.sqrt(1.0 + _CRIT * a)
    # z = (root − 1)/(SCALE·√a), written without the difference of nearly equal numbers
    z = _CRIT * math.sqrt(a) / (_SCALE * (root + 1.0))
    shape, shape_z = _base_shape(z)
    z_a = 0.0 if clamped else (_CRIT / _SCALE) * ((root + 1.0) / (2.0 * math.sqrt(a))
                                                  - math.sqrt(a) * _CRIT / (2.0 * root)) / (root + 1.0) ** 2
    scale = 3.0 * extra * shape_z * z_a / model.irb
    return minimum + 3.0 * extra * shape, scale * dc.base_vbe, scale * dc.base_vbc


def emitter_charge(model: BjtModel, dc: GummelPoonDC, vbe: float,
                   vbc: float) -> tuple[float, float, float]:
    """``(Qbe [C], dQbe/dvbe, dQbe/dvbc [F])``: the diffusion charge of ``TF`` (with ``XTF``,
    ``VTF``, ``ITF`` and the base charge ``qb`` for ``vbe > 0``) and ``CJE``'s depletion
    charge, as ngspice's load computes them."""
    depletion, capacitance = depletion_charge(vbe, model.cje, model.vje, min(model.mje, 0.999),
                                              model.fc)
    ibe, gbe = dc.ibe, dc.gbe
    if model.tf == 0.0:
        return depletion, capacitance, 0.0
    if vbe <= 0.0:
        return model.tf * ibe + depletion, model.tf * gbe + capacitance, 0.0
    factor = slope = factor_vbc = 0.0
    if model.xtf != 0.0:
        inverse_vtf = 1.0 / (model.vtf * 1.44) if model.vtf else 0.0
        factor = model.xtf * math.exp(vbc * inverse_vtf)
        slope = factor
        if model.itf != 0.0:
            share = ibe / (ibe + model.itf)
            factor *= share * share
            slope = factor * (3.0 - 2.0 * share)
        factor_vbc = ibe * factor * inverse_vtf
    diffusion = ibe * (1.0 + factor) / dc.qb
    d_vbe = (gbe * (1.0 + slope) - diffusion * dc.qb_vbe) / dc.qb
    d_vbc = (factor_vbc - diffusion * dc.qb_vbc) / dc.qb
    return (model.tf * diffusion + depletion, model.tf * d_vbe + capacitance,
            model.tf * d_vbc)


def collector_charges(model: BjtModel, dc: GummelPoonDC, vbc: float,
                      vbx: float) -> tuple[float, float, float, float]:
    """``(Qbc [C], dQbc/dvbc [F], Qbx [C], dQbx/dvbx [F])``: ``TR·Ibc`` plus the depletion
    charge of ``XCJC·CJC`` at the internal base, and that of ``(1 − XCJC)·CJC`` at the
    external base."""
    mjc = min(model.mjc, 0.999)
    inner, inner_c = depletion_charge(vbc, model.cjc * model.xcjc, model.vjc, mjc, model.fc)
    outer, outer_c = depletion_charge(vbx, model.cjc * (1.0 - model.xcjc), model.vjc, mjc,
                                      model.fc)
    return model.tr * dc.ibc + inner, model.tr * dc.gbc + inner_c, outer, outer_c


@dataclass(frozen=True)
class Bjt(Element):
    """``Q name c b e [s] MODEL [M=m]``: a Gummel–Poon bipolar transistor.

    Attributes:
        nodes: ``(c, b, e, s)``, the substrate ``0`` when the line gives three nodes.
        model: its :class:`BjtModel`.
        multiplier: ``M``, the number of devices in parallel.
        gmin: the conductance across each junction [S] (``.options gmin``).
        temperature: the device temperature [K] (ngspice's nominal 27 °C).
    """

    model: BjtModel = BjtModel("")
    multiplier: float = 1.0
    gmin: float = DEFAULT_GMIN
    temperature: float = 300.15
    topology: ClassVar[str] = "conductive"

    @property
    def internal_nodes(self) -> tuple[str, ...]:
        """ngspice's names of the internal nodes it adds (``q1#collector`` for ``RC``...)."""
        names = []
        for resistance, which in ((self.model.rc, "collector"), (self.model.rb, "base"),
                                  (self.model.re, "emitter")):
            if resistance:
                names.append(f"{self.name}#{which}")
        return tuple(names)

    def value_errors(self) -> list[tuple[str, str | None]]:
        if len(self.nodes) < 4:
            return [(f"needs collector, base and emitter nodes, has {len(self.nodes)}", None)]
        return []

    def conductances(self, step: float) -> list[tuple[str, float]]:
        found = [(f"{what} = {value:.3g} Ω", self.multiplier / value)
                 for what, value in (("RC", self.model.rc), ("RB", self.model.rb),
                                     ("RE", self.model.re)) if value]
        return found

    def stamp(self, builder: MLCSBuilder) -> None:
        """The internal nodes ``RC``, ``RB``, ``RE`` need (unknowns ``v(q1#collector)``...
        whose rows are Kirchhoff's law there) and the whole device, its series resistances
        included, as one smooth relation."""
        model = self.model
        outer = [builder.node(node) for node in self.nodes[:4]]
        inner = list(outer[:3])
        for position, (resistance, which) in enumerate(
                ((model.rc, "collector"), (model.rb, "base"), (model.re, "emitter"))):
            if resistance:
                inner[position] = builder.branch(f"v({self.name}#{which})")
        terminals = TerminalMap(tuple(outer + inner))
        builder.smooth(SmoothRelation(
            name=self.name, inputs=terminals.inputs, rows=terminals.inputs,
            evaluate=bjt_evaluator(self, terminals), limit=bjt_limiter(self, terminals),
            charges=model.has_charges))


_difference = partial(difference_gradient, 7)
"""The gradient of ``sign·(v[plus] − v[minus])`` over the 7 terminals."""


def bjt_terminal_values(bjt: Bjt, v: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                        np.ndarray, np.ndarray]:
    """``(f, df/dv, q, dq/dv)`` over the seven terminals ``c, b, e, s, c', b', e'`` at their
    voltages ``v`` [V]: ``f`` the current [A] leaving each node into the device, ``q`` the
    charge [C] it stores there (``M`` devices, their series resistances included)."""
    model, sign, m = bjt.model, float(bjt.model.polarity), bjt.multiplier
    vt = thermal_voltage(bjt.temperature)
    d_be, d_bc = _difference(BI, EI, sign), _difference(BI, CI, sign)
    vbe, vbc = float(d_be @ v), float(d_bc @ v)
    dc = gummel_poon_dc(model, vbe, vbc, vt, bjt.gmin)
    f = np.zeros(7)
    jacobian = np.zeros((7, 7))
    collector = dc.collector_vbe * d_be + dc.collector_vbc * d_bc
    base = dc.base_vbe * d_be + dc.base_vbc * d_bc
    for row, value, gradient in ((CI, dc.collector, collector), (BI, dc.base, base),
                                 (EI, -dc.collector - dc.base, -collector - base)):
        f[row] += sign * value
        jacobian[row] += sign * gradient
    if model.rb:
        rbb, rbb_vbe, rbb_vbc = base_resistance(model, dc)
        drop = v[B] - v[BI]
        current = drop / rbb
        gradient = _difference(B, BI, 1.0) / rbb - current / rbb * (rbb_vbe * d_be + rbb_vbc * d_bc)
        add_branches(f, jacobian, ((B, BI, current, gradient),))
    add_resistors(f, jacobian, v, ((C, CI, model.rc), (E, EI, model.re)))
    substrate_node = BI if model.lateral else CI
    leak = bjt.gmin * (v[S] - v[substrate_node])
    f[S] += leak
    f[substrate_node] -= leak
    jacobian[S] += _difference(S, substrate_node, bjt.gmin)
    jacobian[substrate_node] -= _difference(S, substrate_node, bjt.gmin)
    q = np.zeros(7)
    q_jacobian = np.zeros((7, 7))
    if model.has_charges:
        d_bx = _difference(B, CI, sign)
        vbx = float(d_bx @ v)
        qbe, qbe_vbe, qbe_vbc = emitter_charge(model, dc, vbe, vbc)
        qbc, qbc_vbc, qbx, qbx_vbx = collector_charges(model, dc, vbc, vbx)
        add_branches(q, q_jacobian, ((BI, EI, qbe, qbe_vbe * d_be + qbe_vbc * d_bc),
                                     (BI, CI, qbc, qbc_vbc * d_bc), (B, CI, qbx, qbx_vbx * d_bx)), sign)
        substrate = _difference(S, substrate_node, model.cjs)  # q = CJS·(v_s − v_c'), linear
        q[S] += substrate @ v
        q[substrate_node] -= substrate @ v
        q_jacobian[S] += substrate
        q_jacobian[substrate_node] -= substrate
    return m * f, m * jacobian, m * q, m * q_jacobian


def bjt_evaluator(bjt: Bjt, terminals: TerminalMap):
    """``evaluate(x, t)`` of the BJT's :class:`SmoothRelation` over ``terminals.inputs``."""
    return scattered_evaluator(bjt_terminal_values, bjt, terminals)


def bjt_limiter(bjt: Bjt, terminals: TerminalMap):
    """``limit(x_new, x_old)``: SPICE's ``pnjlim`` on ``vbe`` and ``vbc`` (ngspice's thermal
    voltage and ``Vcrit`` of ``IS``). The limited junction voltages are written back by
    moving ``e'`` and ``c'`` against ``b'`` (``b'`` against ``e'`` when ``e'`` is ground,
    and a junction whose both sides are fixed is left as it is)."""
    scatter = terminals.scatter
    sign = float(bjt.model.polarity)
    vt = thermal_voltage(bjt.temperature)
    vcrit = critical_voltage(bjt.model.is_, vt)
    unknowns = terminals.unknowns
    position = {unknown: j for j, unknown in enumerate(terminals.inputs)}

    def limit(x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        new, old = scatter @ x_new, scatter @ x_old
        vbe_new, vbc_new = sign * (new[BI] - new[EI]), sign * (new[BI] - new[CI])
        vbe = pnjlim(vbe_new, sign * (old[BI] - old[EI]), vt, vcrit)
        vbc = pnjlim(vbc_new, sign * (old[BI] - old[CI]), vt, vcrit)
        if vbe == vbe_new and vbc == vbc_new:
            return x_new
        limited = np.array(x_new, dtype=float)
        base = new[BI]
        if unknowns[EI] >= 0 and unknowns[EI] != unknowns[BI]:
            limited[position[unknowns[EI]]] = base - sign * vbe
        elif unknowns[BI] >= 0:
            base = new[EI] + sign * vbe
            limited[position[unknowns[BI]]] = base
        if unknowns[CI] >= 0 and unknowns[CI] not in (unknowns[BI], unknowns[EI]):
            limited[position[unknowns[CI]]] = base - sign * vbc
        return limited

    return limit
