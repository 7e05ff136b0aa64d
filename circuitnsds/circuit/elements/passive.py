"""Resistor, capacitor, inductor.

Sign convention: the element current flows from ``nodes[0]`` to ``nodes[1]``
through the element; its voltage is ``v(nodes[0]) - v(nodes[1])``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.circuit.elements.base import Element, negative_value
from circuitnsds.system.mlcs import MLCSBuilder


@dataclass(frozen=True)
class Resistor(Element):
    """Linear resistor, ``resistance`` in ohms (> 0); ``model``: the ``R`` model it names, if any."""

    resistance: float = 1.0
    model: str | None = None

    def value_errors(self) -> list[tuple[str, str | None]]:
        errors = super().value_errors()
        if self.resistance <= 0:
            errors.append((f"resistance must be positive, got {self.resistance:g}",
                           "use a 0 V voltage source for a short circuit"))
        return errors

    def conductances(self, step: float) -> list[tuple[str, float]]:
        return [(f"R = {self.resistance:.3g} Ω", 1.0 / self.resistance)]

    def stamp(self, builder: MLCSBuilder) -> None:
        a, b = (builder.node(n) for n in self.nodes)
        builder.add_conductance("A", a, b, -1.0 / self.resistance)
        g = 1.0 / self.resistance
        builder.output(f"i({self.name})", [(a, g), (b, -g)])


@dataclass(frozen=True)
class GminLeak(Element):
    """A conductance ``conductance`` [S] from ``nodes[0]`` to ``nodes[1]`` (ground) that the netlist
    does not have: what SPICE's GMIN gives a node without a DC path to ground (a node held only by
    capacitors, a transformer's floating secondary). Added by the netlist reader with a warning,
    never silently (:mod:`circuitnsds.frontend.dc_paths`); it has no output signal of its own,
    since it is not the user's element."""

    conductance: float = 1e-12

    def value_errors(self) -> list[tuple[str, str | None]]:
        errors = super().value_errors()
        if not self.conductance > 0:
            errors.append((f"gmin must be positive, got {self.conductance:g} S", None))
        return errors

    def conductances(self, step: float) -> list[tuple[str, float]]:
        # named as an off-resistance: tiny on purpose, like a diode's Roff (the conditioning
        # check leaves the smallest Roff out of the values it blames)
        return [(f"Roff = {1.0 / self.conductance:.3g} Ω (gmin to ground)", self.conductance)]

    def stamp(self, builder: MLCSBuilder) -> None:
        a, b = (builder.node(n) for n in self.nodes)
        builder.add_conductance("A", a, b, -self.conductance)


@dataclass(frozen=True)
class Capacitor(Element):
    """Linear capacitor, ``capacitance`` in farads; ``initial_voltage`` [V] from ``ic=`` (used with UIC)."""

    capacitance: float = 1.0
    initial_voltage: float | None = None
    topology: ClassVar[str] = "capacitor"

    def value_errors(self) -> list[tuple[str, str | None]]:
        return super().value_errors() + negative_value(self.capacitance, "capacitance", "F")

    def value_warnings(self) -> list[str]:
        return ["0 F capacitor: it is an open circuit (and adds no state)"] if self.capacitance == 0 else []

    def conductances(self, step: float) -> list[tuple[str, float]]:
        return [(f"C = {self.capacitance:.3g} F", self.capacitance / step)] if self.capacitance > 0 else []

    def stamp(self, builder: MLCSBuilder) -> None:
        a, b = (builder.node(n) for n in self.nodes)
        builder.add_conductance("E", a, b, self.capacitance)


@dataclass(frozen=True)
class Inductor(Element):
    """Linear inductor, ``inductance`` in henries; ``initial_current`` [A] from ``ic=`` (used with UIC).

    Adds the unknown ``i(name)`` (current from ``nodes[0]`` to ``nodes[1]``) and
    the branch equation ``L i' = v(nodes[0]) - v(nodes[1])``.
    """

    inductance: float = 1.0
    initial_current: float | None = None
    topology: ClassVar[str] = "inductor"
    owns_branch_current: ClassVar[bool] = True

    def value_errors(self) -> list[tuple[str, str | None]]:
        return super().value_errors() + negative_value(self.inductance, "inductance", "H")

    def value_warnings(self) -> list[str]:
        return ["0 H inductor: it is a short circuit (a 0 V voltage source)"] if self.inductance == 0 else []

    def conductances(self, step: float) -> list[tuple[str, float]]:
        return [(f"L = {self.inductance:.3g} H", step / self.inductance)] if self.inductance > 0 else []

    def stamp(self, builder: MLCSBuilder) -> None:
        a, b = (builder.node(n) for n in self.nodes)
        k = builder.branch(f"i({self.name})")
        builder.add("E", k, k, self.inductance)
        builder.add("A", k, a, 1.0)
        builder.add("A", k, b, -1.0)
        builder.add("A", a, k, -1.0)
        builder.add("A", b, k, 1.0)
        builder.output(f"i({self.name})", [(k, 1.0)])
