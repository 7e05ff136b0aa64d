"""The Shockley diode as ngspice's level-1 diode has it, a smooth device (where a netlist
asks for it: ``smooth=1`` on its model; otherwise a ``D`` line is the ideal or
piecewise-linear diode of :mod:`circuitnsds.circuit.elements.diode`).

``D name a k MODEL``: the junction between the internal anode ``a'`` (the anode when ``RS`` is
0) and the cathode, ``RS`` as a linear resistor. Equations are ngspice 39's (``dioload.c``,
``diotemp.c``) at the nominal temperature 27 °C, with ``vd = v(a') − v(k)``:

* ``IS·(exp(vd/(N·Vt)) − 1)`` above ``−3·N·Vt``; below it ngspice's cubic tail toward
  ``−IS``; below ``−BV'`` (when ``BV`` is given) the breakdown ``−IS·exp(−(BV' + vd)/(NBV·Vt))``,
  where ``BV'`` is the voltage at which the reverse current is ``IBV`` (ngspice's iteration,
  to its default ``RELTOL``);
* the high-injection knees ``IKF`` (forward) and ``IKR`` (reverse): ``i/(1 + sqrt(|i|/IK))``;
* ``GMIN`` across the junction;
* the charge ``TT·i`` plus the depletion charge of ``CJO`` (``VJ``, ``M``, ``FC``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from circuitnsds.circuit.elements.base import Element
from circuitnsds.circuit.elements.smooth.junctions import (
    DEFAULT_GMIN,
    critical_voltage,
    depletion_charge,
    pnjlim,
    thermal_voltage,
)
from circuitnsds.circuit.elements.smooth.terminals import TerminalMap, scattered_evaluator
from circuitnsds.errors import SourceLocation
from circuitnsds.system.mlcs import MLCSBuilder
from circuitnsds.system.smooth import SmoothRelation

A, K, AI = range(3)
"""Terminal positions: anode, cathode, internal anode."""
NGSPICE_RELTOL = 1e-3
"""ngspice's default ``RELTOL``, the tolerance of its breakdown-voltage iteration."""


@dataclass(frozen=True)
class ShockleyDiodeModel:
    """``.model NAME D(... smooth=1)``: ngspice 39's level-1 diode parameters, SI units.

    Attributes:
        is_: saturation current [A]; n: emission coefficient.
        rs: series resistance [Ω].
        bv: breakdown voltage [V] (``None``: no breakdown); ibv: current at ``BV`` [A];
            nbv: breakdown emission coefficient (defaults to ``N``).
        ikf, ikr: forward and reverse knee currents [A] (0: none).
        cjo, vj, m, fc: zero-bias junction capacitance [F], potential [V], grading, and the
            forward-bias coefficient.
        tt: transit time [s].
    """

    name: str
    is_: float = 1e-14
    n: float = 1.0
    rs: float = 0.0
    bv: float | None = None
    ibv: float = 1e-3
    nbv: float | None = None
    ikf: float = 0.0
    ikr: float = 0.0
    cjo: float = 0.0
    vj: float = 1.0
    m: float = 0.5
    fc: float = 0.5
    tt: float = 0.0
    location: SourceLocation | None = field(default=None, compare=False)

    @property
    def breakdown_emission(self) -> float:
        return self.n if self.nbv is None else self.nbv


def breakdown_voltage(model: ShockleyDiodeModel, vt: float,
                      reltol: float = NGSPICE_RELTOL) -> float | None:
    """``BV'`` [V]: where the reverse current reaches ``IBV``, by ngspice's iteration (at most
    25 steps, to ``reltol·IBV``); ``BV`` itself when ``IBV`` is below ``IS·BV/Vt``."""
    if model.bv is None:
        return None
    current, saturation, nvt = model.ibv, model.is_, model.breakdown_emission * vt
    if current < saturation * model.bv / vt:
        return model.bv
    tolerance = reltol * current
    voltage = model.bv - nvt * math.log(1.0 + current / saturation)
    for _ in range(25):
        voltage = model.bv - nvt * math.log(current / saturation + 1.0 - voltage / vt)
        reached = saturation * (math.exp((model.bv - voltage) / nvt) - 1.0 + voltage / vt)
        if abs(reached - current) <= tolerance:
            break
    return voltage


def diode_current(model: ShockleyDiodeModel, vd: float, vt: float, breakdown: float | None,
                  gmin: float = DEFAULT_GMIN) -> tuple[float, float]:
    """``(i [A], di/dvd [S])`` of the junction at ``vd`` [V] as ngspice's load computes it."""
    vte = model.n * vt
    saturation = model.is_
    if vd >= -3.0 * vte:
        grown = math.exp(vd / vte)
        current, slope = saturation * (grown - 1.0), saturation * grown / vte
    elif breakdown is None or vd >= -breakdown:
        cube = (3.0 * vte / (vd * math.e)) ** 3
        current, slope = -saturation * (1.0 + cube), saturation * 3.0 * cube / vd
    else:
        vtebrk = model.breakdown_emission * vt
        grown = math.exp(-(breakdown + vd) / vtebrk)
        current, slope = -saturation * grown, saturation * grown / vtebrk
    if vd >= -3.0 * vte:
        if model.ikf and current > 1e-18:
            root = math.sqrt(current / model.ikf)
            slope = (((1 + root) * slope - current * slope / (2 * root * model.ikf))
                     / (1 + 2 * root + current / model.ikf))
            current = current / (1 + root)
    elif model.ikr and current < -1e-18:
        root = math.sqrt(-current / model.ikr)
        slope = (((1 + root) * slope + current * slope / (2 * root * model.ikr))
                 / (1 + 2 * root - current / model.ikr))
        current = current / (1 + root)
    return current + gmin * vd, slope + gmin


@dataclass(frozen=True)
class ShockleyDiode(Element):
    """``D name a k MODEL`` with a ``smooth=1`` model: ngspice's level-1 diode.

    Attributes:
        nodes: ``(anode, cathode)``.
        model: its :class:`ShockleyDiodeModel`.
        gmin: the conductance across the junction [S].
        temperature: [K], ngspice's nominal 27 °C.
    """

    model: ShockleyDiodeModel = ShockleyDiodeModel("")
    gmin: float = DEFAULT_GMIN
    temperature: float = 300.15
    topology: ClassVar[str] = "conductive"

    def conductances(self, step: float) -> list[tuple[str, float]]:
        return [(f"RS = {self.model.rs:.3g} Ω", 1.0 / self.model.rs)] if self.model.rs else []

    def stamp(self, builder: MLCSBuilder) -> None:
        """The internal anode ``RS`` needs (``v(d1#internal)``) and the diode as one smooth
        relation."""
        outer = [builder.node(node) for node in self.nodes[:2]]
        inner = builder.branch(f"v({self.name}#internal)") if self.model.rs else outer[A]
        terminals = TerminalMap((*outer, inner))
        builder.smooth(SmoothRelation(
            name=self.name, inputs=terminals.inputs, rows=terminals.inputs,
            evaluate=diode_evaluator(self, terminals), limit=diode_limiter(self, terminals),
            charges=bool(self.model.cjo or self.model.tt)))


def diode_terminal_values(diode: ShockleyDiode, v: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                      np.ndarray, np.ndarray]:
    """``(f, df/dv, q, dq/dv)`` over the terminals ``a, k, a'`` at their voltages ``v`` [V]:
    ``f`` the current [A] leaving each node into the diode, ``q`` the charge [C] there."""
    model = diode.model
    vt = thermal_voltage(diode.temperature)
    vd = float(v[AI] - v[K])
    current, slope = diode_current(model, vd, vt, breakdown_voltage(model, vt), diode.gmin)
    across = np.zeros(3)
    across[AI], across[K] = 1.0, -1.0
    f = np.zeros(3)
    jacobian = np.zeros((3, 3))
    f[AI] += current
    f[K] -= current
    jacobian[AI] += slope * across
    jacobian[K] -= slope * across
    if model.rs:
        series = np.zeros(3)
        series[A], series[AI] = 1.0 / model.rs, -1.0 / model.rs
        f[A] += series @ v
        f[AI] -= series @ v
        jacobian[A] += series
        jacobian[AI] -= series
    depletion, capacitance = depletion_charge(vd, model.cjo, model.vj, model.m, model.fc)
    charge, charge_slope = model.tt * current + depletion, model.tt * slope + capacitance
    q = np.zeros(3)
    q_jacobian = np.zeros((3, 3))
    q[AI], q[K] = charge, -charge
    q_jacobian[AI] += charge_slope * across
    q_jacobian[K] -= charge_slope * across
    return f, jacobian, q, q_jacobian


def diode_evaluator(diode: ShockleyDiode, terminals: TerminalMap):
    """``evaluate(x, t)`` of the diode's :class:`SmoothRelation` over ``terminals.inputs``."""
    return scattered_evaluator(diode_terminal_values, diode, terminals)


def diode_limiter(diode: ShockleyDiode, terminals: TerminalMap):
    """``limit(x_new, x_old)``: ngspice's ``pnjlim`` on ``vd`` (with ``N·Vt``), in the
    breakdown's own frame near and beyond ``−BV'``; written back by moving ``a'`` (the
    cathode when ``a'`` is ground)."""
    scatter = terminals.scatter
    model = diode.model
    vt = thermal_voltage(diode.temperature)
    vte, vtebrk = model.n * vt, model.breakdown_emission * vt
    vcrit = critical_voltage(model.is_, vte)
    breakdown = breakdown_voltage(model, vt)
    unknowns = terminals.unknowns
    position = {unknown: j for j, unknown in enumerate(terminals.inputs)}

    def limit(x_new: np.ndarray, x_old: np.ndarray) -> np.ndarray:
        new, old = scatter @ x_new, scatter @ x_old
        vd_new, vd_old = new[AI] - new[K], old[AI] - old[K]
        if breakdown is not None and vd_new < min(0.0, -breakdown + 10.0 * vtebrk):
            vd = -(pnjlim(-(vd_new + breakdown), -(vd_old + breakdown), vtebrk, vcrit) + breakdown)
        else:
            vd = pnjlim(vd_new, vd_old, vte, vcrit)
        if vd == vd_new:
            return x_new
        limited = np.array(x_new, dtype=float)
        if unknowns[AI] >= 0:
            limited[position[unknowns[AI]]] = new[K] + vd
        elif unknowns[K] >= 0:
            limited[position[unknowns[K]]] = new[AI] - vd
        return limited

    return limit
