"""The MOSFET as ngspice's level 1 (Shichman–Hodges) has it, a smooth device.

``M name d g s b MODEL`` read as a smooth device (the rule that chooses it over the ideal
switch is the card reader's): the channel between the internal drain and source ``d'``,
``s'`` (the terminals when ``RD``, ``RS`` are 0), the bulk junctions, ``RD``, ``RS`` as
linear resistors, the overlap capacitances and the bulk junctions' depletion charges.
Equations are ngspice 39's (``mos1load.c``) at the nominal temperature 27 °C:

* ``vgs = type·(v(g) − v(s'))``, ``vds = type·(v(d') − v(s'))``, ``vbs = type·(v(b) − v(s'))``
  (``type`` +1 NMOS, −1 PMOS); for ``vds < 0`` drain and source exchange roles;
* threshold ``von = VTO + GAMMA·(sqrt(PHI − vbs) − sqrt(PHI))`` (for ``vbs > 0`` the
  square root's tangent at 0, at least 0), ``vgst = vgs − von``;
* channel current from ``d'`` to ``s'``: 0 for ``vgst ≤ 0``; ``β/2·(1 + λ·vds)·vgst²`` in
  saturation (``vgst ≤ vds``); ``β·(1 + λ·vds)·vds·(vgst − vds/2)`` in the linear region;
  ``β = KP·W/(L − 2·LD)``;
* bulk junctions ``IS·(exp(v/Vt) − 1)`` above ``−3·Vt`` and ``−IS`` below (ngspice's), with
  ``GMIN``; their depletion charges of ``CBD``, ``CBS`` (``MJ``, ``PB``, ``FC``);
* overlap capacitances ``CGSO·W``, ``CGDO·W``, ``CGBO·(L − 2·LD)`` (linear).

Meyer's intrinsic gate capacitances (ngspice's with ``TOX``) are not a charge function of the
voltages in ngspice and are left out (the card reader says so).
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
    fetlim,
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

D, G, S, B, DI, SI = range(6)
"""Terminal positions of a MOSFET's equations: drain, gate, source, bulk, internal drain and
source."""


@dataclass(frozen=True)
class Mos1Model:
    """A level-1 MOSFET's parameters for one instance (geometry applied), SI units.

    Attributes:
        polarity: +1 NMOS, −1 PMOS.
        vto: ``VTO`` zero-bias threshold [V] (negative for an enhancement PMOS).
        beta: ``KP·W/(L − 2·LD)`` [A/V²].
        gamma: ``GAMMA`` body effect [√V]; phi: ``PHI`` surface potential [V].
        lam: ``LAMBDA`` [1/V].
        rd, rs: drain and source resistances [Ω].
        is_: bulk junction saturation current [A].
        cbd, cbs: zero-bias bulk junction capacitances [F]; mj, pb, fc: their grading,
            potential [V] and forward-bias coefficient.
        cgs, cgd, cgb: overlap capacitances [F].
    """

    name: str
    polarity: int = 1
    vto: float = 0.0
    beta: float = 2e-5
    gamma: float = 0.0
    phi: float = 0.6
    lam: float = 0.0
    rd: float = 0.0
    rs: float = 0.0
    is_: float = 1e-14
    cbd: float = 0.0
    cbs: float = 0.0
    mj: float = 0.5
    pb: float = 0.8
    fc: float = 0.5
    cgs: float = 0.0
    cgd: float = 0.0
    cgb: float = 0.0
    location: SourceLocation | None = field(default=None, compare=False)

    @property
    def has_charges(self) -> bool:
        return any((self.cbd, self.cbs, self.cgs, self.cgd, self.cgb))


def channel_current(model: Mos1Model, vgs: float, vds: float,
                    vbs: float) -> tuple[float, float, float, float]:
    """``(Id [A], dId/dvgs, dId/dvds, dId/dvbs [S])`` in normal mode (``vds ≥ 0``), the
    voltages ``type``-signed, as ngspice's level-1 load computes the current."""
    root_phi = math.sqrt(model.phi)
    if vbs <= 0.0:
        sarg = math.sqrt(model.phi - vbs)
        sarg_vbs = -0.5 / sarg
    else:
        sarg = root_phi - vbs / (root_phi + root_phi)
        sarg_vbs = -0.5 / root_phi
        if sarg <= 0.0:
            sarg, sarg_vbs = 0.0, 0.0
    von = model.vto - model.gamma * root_phi + model.gamma * sarg
    vgst = vgs - von
    if vgst <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    modulation = 1.0 + model.lam * vds
    betap = model.beta * modulation
    if vgst <= vds:
        current = 0.5 * betap * vgst * vgst
        gm = betap * vgst
        gds = 0.5 * model.lam * model.beta * vgst * vgst
    else:
        current = betap * vds * (vgst - 0.5 * vds)
        gm = betap * vds
        gds = betap * (vgst - vds) + model.lam * model.beta * vds * (vgst - 0.5 * vds)
    return current, gm, gds, -gm * model.gamma * sarg_vbs


def drain_current(model: Mos1Model, vgs: float, vds: float,
                  vbs: float) -> tuple[float, float, float, float]:
    """``(Id [A], dId/dvgs, dId/dvds, dId/dvbs [S])``: the channel current from ``d'`` to
    ``s'``, the inverse mode (``vds < 0``) by exchanging drain and source."""
    if vds >= 0.0:
        return channel_current(model, vgs, vds, vbs)
    # with d and s exchanged: vgd = vgs - vds, vsd = -vds, vbd = vbs - vds
    current, gm, gds, gmbs = channel_current(model, vgs - vds, -vds, vbs - vds)
    return -current, -gm, gm + gds + gmbs, -gmbs


def bulk_junction(v: float, saturation: float, vt: float, gmin: float) -> tuple[float, float]:
    """``(i [A], di/dv [S])`` of a bulk junction as ngspice's MOSFET load writes it:
    Shockley's law above ``−3·Vt``, ``−IS`` below, ``GMIN`` across."""
    if v <= -3.0 * vt:
        return gmin * v - saturation, gmin
    grown = math.exp(min(709.0, v / vt))
    return saturation * (grown - 1.0) + gmin * v, saturation * grown / vt + gmin


@dataclass(frozen=True)
class Mos1(Element):
    """``M name d g s b MODEL`` as ngspice's level-1 smooth device.

    Attributes:
        nodes: ``(d, g, s, b)``.
        model: its :class:`Mos1Model` (geometry applied).
        multiplier: ``M``.
        gmin: the conductance across each bulk junction [S].
        temperature: [K], ngspice's nominal 27 °C.
    """

    model: Mos1Model = Mos1Model("")
    multiplier: float = 1.0
    gmin: float = DEFAULT_GMIN
    temperature: float = 300.15
    topology: ClassVar[str] = "conductive"
    owns_branch_current: ClassVar[bool] = False

    def value_errors(self) -> list[tuple[str, str | None]]:
        if len(self.nodes) < 4:
            return [(f"needs drain, gate, source and bulk nodes, has {len(self.nodes)}", None)]
        return []

    def conductances(self, step: float) -> list[tuple[str, float]]:
        return [(f"{what} = {value:.3g} Ω", self.multiplier / value)
                for what, value in (("RD", self.model.rd), ("RS", self.model.rs)) if value]

    def stamp(self, builder: MLCSBuilder) -> None:
        """The internal nodes ``RD``, ``RS`` need (``v(m1#drain)``, ``v(m1#source)``) and the
        device as one smooth relation."""
        outer = [builder.node(node) for node in self.nodes[:4]]
        inner = [outer[D], outer[S]]
        for position, (resistance, which) in enumerate(((self.model.rd, "drain"),
                                                        (self.model.rs, "source"))):
            if resistance:
                inner[position] = builder.branch(f"v({self.name}#{which})")
        terminals = TerminalMap(tuple(outer + inner))
        builder.smooth(SmoothRelation(
            name=self.name, inputs=terminals.inputs, rows=terminals.inputs,
            evaluate=mos1_evaluator(self, terminals), limit=mos1_limiter(self, terminals),
            charges=self.model.has_charges))


_difference = partial(difference_gradient, 6)
"""The gradient of ``sign·(v[plus] − v[minus])`` over the 6 terminals."""


def mos1_terminal_values(mosfet: Mos1, v: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                             np.ndarray, np.ndarray]:
    """``(f, df/dv, q, dq/dv)`` over the six terminals ``d, g, s, b, d', s'`` at their voltages
    ``v`` [V]: ``f`` the current [A] leaving each node into the device, ``q`` the charge [C]
    it stores there (``M`` devices, series resistances included)."""
    model, sign = mosfet.model, float(mosfet.model.polarity)
    vt = thermal_voltage(mosfet.temperature)
    d_gs, d_ds, d_bs = _difference(G, SI, sign), _difference(DI, SI, sign), _difference(B, SI, sign)
    d_bd = _difference(B, DI, sign)
    vgs, vds, vbs, vbd = (float(d @ v) for d in (d_gs, d_ds, d_bs, d_bd))
    drain, by_gs, by_ds, by_bs = drain_current(model, vgs, vds, vbs)
    gmin = mosfet.gmin / mosfet.multiplier  # ngspice's GMIN is once per instance, not per M
    ibs, gbs = bulk_junction(vbs, model.is_, vt, gmin)
    ibd, gbd = bulk_junction(vbd, model.is_, vt, gmin)
    f = np.zeros(6)
    jacobian = np.zeros((6, 6))
    add_branches(f, jacobian, ((DI, SI, drain, by_gs * d_gs + by_ds * d_ds + by_bs * d_bs),
                               (B, SI, ibs, gbs * d_bs), (B, DI, ibd, gbd * d_bd)), sign)
    add_resistors(f, jacobian, v, ((D, DI, model.rd), (S, SI, model.rs)))
    q = np.zeros(6)
    q_jacobian = np.zeros((6, 6))
    if model.has_charges:
        fc = model.fc
        junctions = [(B, SI, vbs, d_bs, *depletion_charge(vbs, model.cbs, model.pb, model.mj, fc)),
                     (B, DI, vbd, d_bd, *depletion_charge(vbd, model.cbd, model.pb, model.mj, fc))]
        for plus, minus, capacitance in ((G, SI, model.cgs), (G, DI, model.cgd), (G, B, model.cgb)):
            across = _difference(plus, minus, sign)
            voltage = float(across @ v)
            junctions.append((plus, minus, voltage, across, capacitance * voltage, capacitance))
        for plus, minus, _, gradient, charge, slope in junctions:
            q[plus] += sign * charge
            q[minus] -= sign * charge
            q_jacobian[plus] += sign * slope * gradient
            q_jacobian[minus] -= sign * slope * gradient
    m = mosfet.multiplier
    return m * f, m * jacobian, m * q, m * q_jacobian


def mos1_evaluator(mosfet: Mos1, terminals: TerminalMap):
    """``evaluate(x, t)`` of the MOSFET's :class:`SmoothRelation` over ``terminals.inputs``."""
    return scattered_evaluator(mos1_terminal_values, mosfet, terminals)


def limited_voltages(model: Mos1Model, new: tuple[float, float, float],
                     old: tuple[float, float, float], vt: float) -> tuple[float, float, float]:
    """ngspice's level-1 limiting of ``(vgs, vds, vbs)`` [V] (``type``-signed) after the old
    iterate's: ``fetlim`` on the controlling gate voltage around the threshold, ``limvds`` on
    ``vds``, ``pnjlim`` on the forward-going bulk junction."""
    vgs, vds, vbs = new
    vgs_old, vds_old, vbs_old = old
    von = drain_threshold(model, vbs_old if vds_old >= 0 else vbs_old - vds_old)
    vgd, vgd_old = vgs - vds, vgs_old - vds_old
    if vds_old >= 0:
        vgs = fetlim(vgs, vgs_old, von)
        vds = limvds(vgs - vgd, vds_old)
    else:
        vgd = fetlim(vgd, vgd_old, von)
        vds = -limvds(-(vgs - vgd), -vds_old)
        vgs = vgd + vds
    vcrit = critical_voltage(model.is_, vt)
    if vds >= 0:
        vbs = pnjlim(vbs, vbs_old, vt, vcrit)
    else:
        vbd = pnjlim(vbs - vds, vbs_old - vds_old, vt, vcrit)
        vbs = vbd + vds
    return vgs, vds, vbs


def drain_threshold(model: Mos1Model, vbs: float) -> float:
    """``von`` [V] at the bulk voltage ``vbs`` (of the source in normal mode)."""
    root_phi = math.sqrt(model.phi)
    sarg = math.sqrt(model.phi - vbs) if vbs <= 0 else max(0.0, root_phi - vbs / (2 * root_phi))
    return model.vto - model.gamma * root_phi + model.gamma * sarg


def mos1_limiter(mosfet: Mos1, terminals: TerminalMap):
    """``limit(x_new, x_old)``: ngspice's limiting (:func:`limited_voltages`) written back
    around ``s'`` (each other terminal moved to the limited voltage it has to ``s'``; a
    terminal that is ground, or ``s'`` itself, stays)."""
    scatter = terminals.scatter
    sign = float(mosfet.model.polarity)
    vt = thermal_voltage(mosfet.temperature)
    unknowns = terminals.unknowns
    position = {unknown: j for j, unknown in enumerate(terminals.inputs)}

    def voltages(v: np.ndarray) -> tuple[float, float, float]:
        return (sign * (v[G] - v[SI]), sign * (v[DI] - v[SI]), sign * (v[B] - v[SI]))

    def limit(x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        new, old = scatter @ x_new, scatter @ x_old
        proposed = voltages(new)
        limited_values = limited_voltages(mosfet.model, proposed, voltages(old), vt)
        if limited_values == proposed:
            return x_new
        limited = np.array(x_new, dtype=float)
        for terminal, value in zip((G, DI, B), limited_values, strict=True):
            unknown = unknowns[terminal]
            if unknown >= 0 and unknown != unknowns[SI]:
                limited[position[unknown]] = new[SI] + sign * value
        return limited

    return limit
