"""Resistor, capacitor, inductor.

Sign convention: the element current flows from ``nodes[0]`` to ``nodes[1]``
through the element; its voltage is ``v(nodes[0]) - v(nodes[1])``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.circuit.elements.base import Element
from circuitnsds.system.mlcs import MLCSBuilder


@dataclass(frozen=True)
class Resistor(Element):
    """Linear resistor, ``resistance`` in ohms (> 0); ``model``: the ``R`` model it names, if any."""

    resistance: float = 1.0
    model: str | None = None

    def stamp(self, builder: MLCSBuilder) -> None:
        a, b = (builder.node(n) for n in self.nodes)
        builder.add_conductance("A", a, b, -1.0 / self.resistance)
        g = 1.0 / self.resistance
        builder.output(f"i({self.name})", [(a, g), (b, -g)])


@dataclass(frozen=True)
class Capacitor(Element):
    """Linear capacitor, ``capacitance`` in farads; ``initial_voltage`` [V] from ``ic=`` (used with UIC)."""

    capacitance: float = 1.0
    initial_voltage: float | None = None
    topology: ClassVar[str] = "capacitor"

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

    def stamp(self, builder: MLCSBuilder) -> None:
        a, b = (builder.node(n) for n in self.nodes)
        k = builder.branch(f"i({self.name})")
        builder.add("E", k, k, self.inductance)
        builder.add("A", k, a, 1.0)
        builder.add("A", k, b, -1.0)
        builder.add("A", a, k, -1.0)
        builder.add("A", b, k, 1.0)
        builder.output(f"i({self.name})", [(k, 1.0)])
