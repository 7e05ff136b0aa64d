"""The power MOSFET as ngspice's VDMOS model has it, a smooth device.

``M name d g s MODEL`` with a VDMOS model read as a smooth device (``smooth=1``): the channel
between the internal drain, gate and source ``d'``, ``g'``, ``s'`` (``RD``, ``RG``, ``RS``; the
terminals when 0), ``RDS`` across the terminals, and the body diode from the source through
``RB`` to the drain. Equations are ngspice 39's (``vdmosload.c``, ``vdmostemp.c``) at the
nominal temperature 27 °C, without self-heating:

* ``vgs = type·(v(g') − v(s'))``, ``vds = type·(v(d') − v(s'))``; for ``vds < 0`` the gate
  overdrive is taken from ``vgd`` (drain and source exchanged), while ``λ`` and ``θ`` keep
  ``vds`` and ``vgs`` as ngspice does;
* overdrive ``Vov = KSUBTHRES·ln(1 + exp((vg − type·VTO − SUBSHIFT)/KSUBTHRES))`` (the weak
  inversion smoothing), ``β' = KP·(1 + λ·vds)/(1 + θ·vgs)``, ``vdss = MTRIODE·|vds|``;
  saturation (``Vov ≤ vdss``) ``β'·Vov²/2``, linear ``β'·vdss·(Vov − vdss/2)``;
* body diode ``IS·(exp(v/(N·Vt)) − 1)`` with ngspice's cubic reverse tail and breakdown at
  ``BV`` matched to ``IBV`` (``NBV``), ``GMIN`` across;
* charges: ``CGS`` linear; the gate–drain charge whose capacitance is ngspice's
  ``Cgd(vgd) = s·tanh(A·vgd) + y`` above 0, ``s·atan(A·vgd) + y`` below (``s = (CGDMAX −
  CGDMIN)/(1 + π/2)``, ``y = CGDMAX − s``), integrated from 0; the body diode's ``TT·i`` and
  ``CJO`` depletion charge (``VJ``, ``M``, ``FC``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial
from typing import ClassVar

import numpy as np

from circuitnsds.circuit.elements.base import Element
from circuitnsds.circuit.elements.smooth.diode import ShockleyDiodeModel, breakdown_voltage
from circuitnsds.circuit.elements.smooth.junctions import (
    DEFAULT_GMIN,
    critical_voltage,
    depletion_charge,
    fetlim,
    junction_current,
    limvds,
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

D, G, S, DI, GI, SI, BD = range(7)
"""Terminal positions: drain, gate, source, internal drain, gate and source, body-diode anode."""


@dataclass(frozen=True)
class VdmosModel:
    """``.model NAME VDMOS(... smooth=1)``: ngspice 39's parameters, SI units.

    Attributes:
        polarity: +1 n-channel, −1 p-channel (``pchan``).
        vto: ``VTO`` as written [V]; kp: ``KP`` [A/V²]; lam: ``LAMBDA`` [1/V];
            theta: ``THETA`` [1/V]; mtriode: ``MTRIODE``; ksubthres: ``KSUBTHRES`` [V];
            subshift: ``SUBSHIFT`` [V].
        rd, rs, rg: drain, source, gate resistances [Ω]; rds: drain–source shunt [Ω] (0: not
            given, ngspice's 1e15 Ω).
        cgs, cgdmin, cgdmax, a: gate capacitances [F] and the shape ``A`` [1/V] of Cgd.
        diode: the body diode (``IS``, ``N``, ``RB`` as its series resistance, ``BV``, ``IBV``,
            ``NBV``, ``CJO``, ``VJ``, ``M``, ``FC``, ``TT``).
    """

    name: str
    polarity: int = 1
    vto: float = 0.0
    kp: float = 1.0
    lam: float = 0.0
    theta: float = 0.0
    mtriode: float = 1.0
    ksubthres: float = 0.1
    subshift: float = 0.0
    rd: float = 0.0
    rs: float = 0.0
    rg: float = 0.0
    rds: float = 0.0
    cgs: float = 0.0
    cgdmin: float = 0.0
    cgdmax: float = 0.0
    a: float = 1.0
    diode: ShockleyDiodeModel = ShockleyDiodeModel("body", ibv=1e-10, nbv=1.0, vj=0.8)
    location: SourceLocation | None = field(default=None, compare=False)

    @property
    def has_charges(self) -> bool:
        return any((self.cgs, self.cgdmin, self.cgdmax, self.diode.cjo, self.diode.tt))

    @property
    def shunt(self) -> float:
        """The drain–source resistance [Ω]: ``RDS``, or ngspice's 1/(1e-15 S) when not given
        or not positive."""
        return self.rds if self.rds > 0 else 1e15


def channel_current(model: VdmosModel, vgs: float, vds: float) -> tuple[float, float, float]:
    """``(Id [A], dId/dvgs, dId/dvds [S])``: the channel current from ``d'`` to ``s'`` at the
    ``type``-signed ``vgs``, ``vds`` [V], as ngspice's VDMOS load computes it."""
    mode = 1.0 if vds >= 0 else -1.0
    control = vgs if vds >= 0 else vgs - vds
    control_vds = 0.0 if vds >= 0 else -1.0
    overdrive = control - model.polarity * model.vto - model.subshift
    x = overdrive / model.ksubthres
    if x > 0:
        vov = model.ksubthres * (x + math.log1p(math.exp(-x)))
        slope = 1.0 / (1.0 + math.exp(-x))
    else:
        grown = math.exp(x)
        vov = model.ksubthres * math.log1p(grown)
        slope = grown / (1.0 + grown)
    vov_vgs, vov_vds = slope, slope * control_vds
    t0 = 1.0 + model.lam * vds
    t1 = 1.0 + model.theta * vgs
    betap = model.kp * t0 / t1
    betap_vgs, betap_vds = -model.kp * model.theta * t0 / (t1 * t1), model.kp * model.lam / t1
    vdss, vdss_vds = vds * model.mtriode * mode, model.mtriode * mode
    if vov <= vdss:
        current = 0.5 * betap * vov * vov
        by_vgs = 0.5 * betap_vgs * vov * vov + betap * vov * vov_vgs
        by_vds = 0.5 * betap_vds * vov * vov + betap * vov * vov_vds
    else:
        half = vov - 0.5 * vdss
        current = betap * vdss * half
        by_vgs = betap_vgs * vdss * half + betap * vdss * vov_vgs
        by_vds = (betap_vds * vdss * half + betap * vdss_vds * half
                  + betap * vdss * (vov_vds - 0.5 * vdss_vds))
    return mode * current, mode * by_vgs, mode * by_vds


def gate_drain_charge(model: VdmosModel, vgd: float) -> tuple[float, float]:
    """``(q [C], dq/dvgd [F])``: the charge of ngspice's gate–drain capacitance
    ``s·tanh(A·vgd) + y`` (``vgd > 0``) or ``s·atan(A·vgd) + y``, integrated from 0 V."""
    s = (model.cgdmax - model.cgdmin) / (1.0 + math.pi / 2.0)
    y = model.cgdmax - s
    a = model.a
    if vgd > 0:
        return (s * (abs(a * vgd) + math.log1p(math.exp(-2.0 * abs(a * vgd))) - math.log(2.0)) / a
                + y * vgd, s * math.tanh(a * vgd) + y)
    return (s * (vgd * math.atan(a * vgd) - math.log1p((a * vgd) ** 2) / (2.0 * a)) + y * vgd,
            s * math.atan(a * vgd) + y)


def body_diode_current(model: VdmosModel, vd: float, vt: float, breakdown: float | None,
                       gmin: float) -> tuple[float, float]:
    """``(i [A], di/dvd [S])`` of the body diode (ngspice's VDMOS diode: Shockley, cubic tail,
    breakdown; no knees) with ``GMIN``."""
    diode = model.diode
    vte = diode.n * vt
    if vd >= -3.0 * vte or breakdown is None or vd >= -breakdown:
        current, slope = junction_current(vd, diode.is_, vte)
    else:
        vtebrk = diode.breakdown_emission * vt
        grown = math.exp(-(breakdown + vd) / vtebrk)
        current, slope = -diode.is_ * grown, diode.is_ * grown / vtebrk
    return current + gmin * vd, slope + gmin


@dataclass(frozen=True)
class Vdmos(Element):
    """``M name d g s MODEL`` with a ``smooth=1`` VDMOS model.

    Attributes:
        nodes: ``(d, g, s)``.
        model: its :class:`VdmosModel`.
        gmin: [S], across the body diode.
        temperature: [K], ngspice's nominal 27 °C.
    """

    model: VdmosModel = VdmosModel("")
    gmin: float = DEFAULT_GMIN
    temperature: float = 300.15
    topology: ClassVar[str] = "conductive"
    owns_branch_current: ClassVar[bool] = False

    def value_errors(self) -> list[tuple[str, str | None]]:
        if len(self.nodes) < 3:
            return [(f"needs drain, gate and source nodes, has {len(self.nodes)}", None)]
        return []

    def conductances(self, step: float) -> list[tuple[str, float]]:
        return [(f"{what} = {value:.3g} Ω", 1.0 / value) for what, value in
                (("RD", self.model.rd), ("RS", self.model.rs), ("RG", self.model.rg),
                 ("RB", self.model.diode.rs)) if value]

    def stamp(self, builder: MLCSBuilder) -> None:
        """The internal nodes its resistances need (``v(m1#drain)``, ``#gate``, ``#source``,
        ``#body diode``) and the device as one smooth relation."""
        model = self.model
        outer = [builder.node(node) for node in self.nodes[:3]]
        inner = []
        for position, (resistance, which) in enumerate(
                ((model.rd, "drain"), (model.rg, "gate"), (model.rs, "source"))):
            inner.append(builder.branch(f"v({self.name}#{which})") if resistance else outer[position])
        body = builder.branch(f"v({self.name}#body diode)") if model.diode.rs else outer[S]
        terminals = TerminalMap((*outer, *inner, body))
        builder.smooth(SmoothRelation(
            name=self.name, inputs=terminals.inputs, rows=terminals.inputs,
            evaluate=vdmos_evaluator(self, terminals), limit=vdmos_limiter(self, terminals),
            charges=model.has_charges))


_difference = partial(difference_gradient, 7)
"""The gradient of ``sign·(v[plus] − v[minus])`` over the 7 terminals."""


def vdmos_terminal_values(mosfet: Vdmos, v: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                               np.ndarray, np.ndarray]:
    """``(f, df/dv, q, dq/dv)`` over the terminals ``d, g, s, d', g', s', body`` at their
    voltages ``v`` [V]: ``f`` the current [A] leaving each node into the device, ``q`` the
    charge [C] stored there."""
    model, sign = mosfet.model, float(mosfet.model.polarity)
    vt = thermal_voltage(mosfet.temperature)
    d_gs, d_ds, d_gd = _difference(GI, SI, sign), _difference(DI, SI, sign), _difference(GI, DI, sign)
    d_body = _difference(BD, D, sign)
    vgs, vds, vgd, vbody = (float(d @ v) for d in (d_gs, d_ds, d_gd, d_body))
    drain, by_vgs, by_vds = channel_current(model, vgs, vds)
    breakdown = breakdown_voltage(model.diode, vt)
    diode, diode_slope = body_diode_current(model, vbody, vt, breakdown, mosfet.gmin)
    f = np.zeros(7)
    jacobian = np.zeros((7, 7))
    add_branches(f, jacobian, ((DI, SI, drain, by_vgs * d_gs + by_vds * d_ds),
                               (BD, D, diode, diode_slope * d_body)), sign)
    add_resistors(f, jacobian, v, ((D, DI, model.rd), (G, GI, model.rg), (S, SI, model.rs),
                                   (S, BD, model.diode.rs), (D, S, model.shunt)))
    q = np.zeros(7)
    q_jacobian = np.zeros((7, 7))
    if model.has_charges:
        body = model.diode
        depletion, capacitance = depletion_charge(vbody, body.cjo, body.vj, body.m, body.fc)
        gate_drain, gate_drain_c = gate_drain_charge(model, vgd)
        for plus, minus, charge, gradient in (
                (GI, SI, model.cgs * vgs, model.cgs * d_gs),
                (GI, DI, gate_drain, gate_drain_c * d_gd),
                (BD, D, body.tt * diode + depletion, (body.tt * diode_slope + capacitance) * d_body)):
            q[plus] += sign * charge
            q[minus] -= sign * charge
            q_jacobian[plus] += sign * gradient
            q_jacobian[minus] -= sign * gradient
    return f, jacobian, q, q_jacobian


def vdmos_evaluator(mosfet: Vdmos, terminals: TerminalMap):
    """``evaluate(x, t)`` of the VDMOS's :class:`SmoothRelation` over ``terminals.inputs``."""
    return scattered_evaluator(vdmos_terminal_values, mosfet, terminals)


def vdmos_limiter(mosfet: Vdmos, terminals: TerminalMap):
    """``limit(x_new, x_old)``: ``fetlim`` on the controlling gate voltage around the threshold
    and ``limvds`` (ngspice's VDMOS limiting), written back around ``s'``; ``pnjlim`` on the
    body diode, written back by moving its anode (or the drain when it is ground)."""
    scatter = terminals.scatter
    model = mosfet.model
    sign = float(model.polarity)
    vt = thermal_voltage(mosfet.temperature)
    vte = model.diode.n * vt
    vcrit = critical_voltage(model.diode.is_, vte)
    von = sign * model.vto
    unknowns = terminals.unknowns
    position = {unknown: j for j, unknown in enumerate(terminals.inputs)}

    def move(limited: np.ndarray, terminal: int, value: float, fixed: tuple[int, ...]) -> None:
        unknown = unknowns[terminal]
        if unknown >= 0 and all(unknown != unknowns[other] for other in fixed):
            limited[position[unknown]] = value

    def limit(x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        new, old = scatter @ x_new, scatter @ x_old
        vgs, vds = sign * (new[GI] - new[SI]), sign * (new[DI] - new[SI])
        vgs_old, vds_old = sign * (old[GI] - old[SI]), sign * (old[DI] - old[SI])
        if vds_old >= 0:
            vgs_l = fetlim(vgs, vgs_old, von)
            vds_l = limvds(vgs_l - (vgs - vds), vds_old)
        else:
            vgd_l = fetlim(vgs - vds, vgs_old - vds_old, von)
            vds_l = -limvds(-(vgs - vgd_l), -vds_old)
            vgs_l = vgd_l + vds_l
        vbody, vbody_old = sign * (new[BD] - new[D]), sign * (old[BD] - old[D])
        vbody_l = pnjlim(vbody, vbody_old, vte, vcrit)
        if (vgs_l, vds_l, vbody_l) == (vgs, vds, vbody):
            return x_new
        limited = np.array(x_new, dtype=float)
        move(limited, GI, new[SI] + sign * vgs_l, (SI,))
        move(limited, DI, new[SI] + sign * vds_l, (SI, GI))
        if unknowns[BD] >= 0 and unknowns[BD] not in (unknowns[SI], unknowns[GI], unknowns[DI]):
            move(limited, BD, new[D] + sign * vbody_l, (D,))
        return limited

    return limit
