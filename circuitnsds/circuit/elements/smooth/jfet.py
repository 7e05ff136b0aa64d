"""The junction field-effect transistor as ngspice's level 1 has it, a smooth device.

``J name d g s MODEL``: the channel between the internal drain and source ``d'``, ``s'``
(the terminals when ``RD``, ``RS`` are 0), the two gate junctions, and ``RD``, ``RS`` as
linear resistors to the terminals. Equations and defaults are ngspice 39's (``jfetload.c``
with the Sydney University doping-profile parameter ``B``, ``jfetset.c``, ``jfettemp.c``) at
the nominal temperature 27 °C:

* ``vgs = type·(v(g) − v(s'))``, ``vgd = type·(v(g) − v(d'))``, ``vds = vgs − vgd`` (``type``
  +1 NJF, −1 PJF; ``VTO`` is negative for a depletion device of either type);
* gate junctions ``IS·(exp(v/Vt) − 1)`` (emission coefficient 1; ngspice's cubic tail below
  −3·Vt) with ``GMIN`` across each;
* channel current from ``d'`` to ``s'`` for ``vds ≥ 0`` and ``vgst = vgs − VTO > 0``:
  saturation (``vgst < vds``) ``β·(1 + λ·vds)·vgst²·(B + b·vgst)``, linear
  ``β·(1 + λ·vds)·vds·(vds·(b·vds − B) + vgst·(2B + 3b·(vgst − vds)))`` with
  ``b = (1 − B)/(PB − VTO)`` (``B = 1``: the square law ``β·vds·(2·vgst − vds)``); for
  ``vds < 0`` the same with drain and source exchanged;
* gate charges: the depletion charges of ``CGS`` and ``CGD`` (grading 1/2, ``PB``, ``FC``).
"""

from __future__ import annotations

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

D, G, S, DI, SI = range(5)
"""Terminal positions of a JFET's equations: drain, gate, source, internal drain and source."""


@dataclass(frozen=True)
class JfetModel:
    """``.model NAME NJF|PJF(...)``: ngspice 39's level-1 parameters, defaults and units.

    Attributes:
        polarity: +1 n-channel (NJF), −1 p-channel (PJF).
        vto: ``VTO`` threshold voltage [V] (negative: depletion).
        beta: ``BETA`` transconductance parameter [A/V²].
        lam: ``LAMBDA`` channel-length modulation [1/V].
        rd, rs: drain and source resistances [Ω].
        cgs, cgd: zero-bias gate-source and gate-drain junction capacitances [F].
        pb: ``PB`` gate junction potential [V].
        is_: ``IS`` gate junction saturation current [A].
        fc: forward-bias depletion capacitance coefficient (at most 0.95).
        b: ``B``, the doping-profile parameter (1: the square law).
    """

    name: str
    polarity: int = 1
    vto: float = -2.0
    beta: float = 1e-4
    lam: float = 0.0
    rd: float = 0.0
    rs: float = 0.0
    cgs: float = 0.0
    cgd: float = 0.0
    pb: float = 1.0
    is_: float = 1e-14
    fc: float = 0.5
    b: float = 1.0
    location: SourceLocation | None = field(default=None, compare=False)

    @property
    def kind(self) -> str:
        return "njf" if self.polarity > 0 else "pjf"

    @property
    def profile(self) -> float:
        """``(1 − B)/(PB − VTO)`` [1/V], ngspice's ``bFac``."""
        return (1.0 - self.b) / (self.pb - self.vto)


def channel_current(model: JfetModel, vgst: float, vds: float) -> tuple[float, float, float]:
    """``(Id [A], dId/dvgst, dId/dvds [S])`` of the channel in normal mode (``vds ≥ 0``)
    at the gate overdrive ``vgst = vgs − VTO`` [V], as ngspice's load computes it (zero in
    cut-off)."""
    if vgst <= 0.0:
        return 0.0, 0.0, 0.0
    b, profile = model.b, model.profile
    modulation = 1.0 + model.lam * vds
    scaled = model.beta * modulation
    if vgst >= vds:
        apart = 2.0 * b + 3.0 * profile * (vgst - vds)
        cpart = vds * (vds * (profile * vds - b) + vgst * apart)
        return (scaled * cpart, scaled * vds * (apart + 3.0 * profile * vgst),
                scaled * (vgst - vds) * apart + model.beta * model.lam * cpart)
    cpart = vgst * vgst * (b + profile * vgst)
    return (scaled * cpart, scaled * vgst * (2.0 * b + 3.0 * profile * vgst),
            model.beta * model.lam * cpart)


def drain_current(model: JfetModel, vgs: float, vgd: float) -> tuple[float, float, float]:
    """``(Id [A], dId/dvgs, dId/dvgd [S])``: the channel current from ``d'`` to ``s'`` at the
    gate junction voltages (``type``-signed), normal or inverse mode by the sign of
    ``vds = vgs − vgd`` (inverse: drain and source exchanged)."""
    vds = vgs - vgd
    if vds >= 0.0:
        current, by_gate, by_drain = channel_current(model, vgs - model.vto, vds)
        return current, by_gate + by_drain, -by_drain
    current, by_gate, by_drain = channel_current(model, vgd - model.vto, -vds)
    return -current, by_drain, -(by_gate + by_drain)


@dataclass(frozen=True)
class Jfet(Element):
    """``J name d g s MODEL [m=M]``: a level-1 JFET.

    Attributes:
        nodes: ``(d, g, s)``.
        model: its :class:`JfetModel`.
        multiplier: ``M``, the number of devices in parallel.
        gmin: the conductance across each gate junction [S] (``.options gmin``).
        temperature: the device temperature [K] (ngspice's nominal 27 °C).
    """

    model: JfetModel = JfetModel("")
    multiplier: float = 1.0
    gmin: float = DEFAULT_GMIN
    temperature: float = 300.15
    topology: ClassVar[str] = "conductive"

    def value_errors(self) -> list[tuple[str, str | None]]:
        if len(self.nodes) < 3:
            return [(f"needs drain, gate and source nodes, has {len(self.nodes)}", None)]
        return []

    def conductances(self, step: float) -> list[tuple[str, float]]:
        return [(f"{what} = {value:.3g} Ω", self.multiplier / value)
                for what, value in (("RD", self.model.rd), ("RS", self.model.rs)) if value]

    def stamp(self, builder: MLCSBuilder) -> None:
        """The internal nodes ``RD``, ``RS`` need (``v(j1#drain)``, ``v(j1#source)``) and the
        device, its series resistances included, as one smooth relation."""
        outer = [builder.node(node) for node in self.nodes[:3]]
        inner = [outer[D], outer[S]]
        for position, (resistance, which) in enumerate(((self.model.rd, "drain"),
                                                        (self.model.rs, "source"))):
            if resistance:
                inner[position] = builder.branch(f"v({self.name}#{which})")
        terminals = TerminalMap(tuple(outer + inner))
        builder.smooth(SmoothRelation(
            name=self.name, inputs=terminals.inputs, rows=terminals.inputs,
            evaluate=jfet_evaluator(self, terminals), limit=jfet_limiter(self, terminals),
            charges=bool(self.model.cgs or self.model.cgd)))


_difference = partial(difference_gradient, 5)
"""The gradient of ``sign·(v[plus] − v[minus])`` over the 5 terminals."""


def jfet_terminal_values(jfet: Jfet, v: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                          np.ndarray, np.ndarray]:
    """``(f, df/dv, q, dq/dv)`` over the five terminals ``d, g, s, d', s'`` at their voltages
    ``v`` [V]: ``f`` the current [A] leaving each node into the device, ``q`` the charge [C]
    it stores there (``M`` devices, series resistances included)."""
    model, sign = jfet.model, float(jfet.model.polarity)
    vt = thermal_voltage(jfet.temperature)
    d_gs, d_gd = _difference(G, SI, sign), _difference(G, DI, sign)
    vgs, vgd = float(d_gs @ v), float(d_gd @ v)
    igs, ggs = junction_current(vgs, model.is_, vt)
    igd, ggd = junction_current(vgd, model.is_, vt)
    igs, ggs, igd, ggd = igs + jfet.gmin * vgs, ggs + jfet.gmin, igd + jfet.gmin * vgd, ggd + jfet.gmin
    drain, drain_vgs, drain_vgd = drain_current(model, vgs, vgd)
    f = np.zeros(5)
    jacobian = np.zeros((5, 5))
    add_branches(f, jacobian, ((G, SI, igs, ggs * d_gs), (G, DI, igd, ggd * d_gd),
                               (DI, SI, drain, drain_vgs * d_gs + drain_vgd * d_gd)), sign)
    add_resistors(f, jacobian, v, ((D, DI, model.rd), (S, SI, model.rs)))
    q = np.zeros(5)
    q_jacobian = np.zeros((5, 5))
    fc = min(model.fc, 0.95)
    for minus, voltage, gradient, capacitance in ((SI, vgs, d_gs, model.cgs),
                                                  (DI, vgd, d_gd, model.cgd)):
        charge, slope = depletion_charge(voltage, capacitance, model.pb, 0.5, fc)
        q[G] += sign * charge
        q[minus] -= sign * charge
        q_jacobian[G] += sign * slope * gradient
        q_jacobian[minus] -= sign * slope * gradient
    m = jfet.multiplier
    return m * f, m * jacobian, m * q, m * q_jacobian


def jfet_evaluator(jfet: Jfet, terminals: TerminalMap):
    """``evaluate(x, t)`` of the JFET's :class:`SmoothRelation` over ``terminals.inputs``."""
    return scattered_evaluator(jfet_terminal_values, jfet, terminals)


def jfet_limiter(jfet: Jfet, terminals: TerminalMap):
    """``limit(x_new, x_old)``: ngspice's limiting of the gate junctions, ``pnjlim`` then
    ``fetlim`` (around ``VTO``) on ``vgs`` and ``vgd``, written back by moving ``s'`` and
    ``d'`` against the gate (the gate against ``s'`` when ``s'`` is ground; a junction whose
    both sides are fixed is left as it is)."""
    scatter = terminals.scatter
    model = jfet.model
    sign = float(model.polarity)
    vt = thermal_voltage(jfet.temperature)
    vcrit = critical_voltage(model.is_, vt)
    unknowns = terminals.unknowns
    position = {unknown: j for j, unknown in enumerate(terminals.inputs)}

    def limited_junction(vnew: float, vold: float) -> float:
        return fetlim(pnjlim(vnew, vold, vt, vcrit), vold, model.vto)

    def limit(x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        new, old = scatter @ x_new, scatter @ x_old
        vgs_new, vgd_new = sign * (new[G] - new[SI]), sign * (new[G] - new[DI])
        vgs = limited_junction(vgs_new, sign * (old[G] - old[SI]))
        vgd = limited_junction(vgd_new, sign * (old[G] - old[DI]))
        if vgs == vgs_new and vgd == vgd_new:
            return x_new
        limited = np.array(x_new, dtype=float)
        gate = new[G]
        if unknowns[SI] >= 0 and unknowns[SI] != unknowns[G]:
            limited[position[unknowns[SI]]] = gate - sign * vgs
        elif unknowns[G] >= 0:
            gate = new[SI] + sign * vgs
            limited[position[unknowns[G]]] = gate
        if unknowns[DI] >= 0 and unknowns[DI] not in (unknowns[G], unknowns[SI]):
            limited[position[unknowns[DI]]] = gate - sign * vgd
        return limited

    return limit
