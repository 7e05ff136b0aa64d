"""Linear controlled sources (SPICE ``E``, ``G``, ``F``, ``H``; sign conventions as in SPICE).

* ``E n+ n- nc+ nc- gain``: ``v(n+) - v(n-) = gain·(v(nc+) - v(nc-))``; unknown
  ``i(name)`` [A] flows into ``n+`` through the source, like a voltage source's.
* ``G n+ n- nc+ nc- gm``: a current ``gm·(v(nc+) - v(nc-))`` [A] flows from ``n+``
  through the source to ``n-``.
* ``F n+ n- vname gain``: a current ``gain·i(vname)`` flows from ``n+`` through the
  source to ``n-``; ``i(vname)`` is the current of voltage source ``vname``.
* ``H n+ n- vname r``: ``v(n+) - v(n-) = r·i(vname)`` [V]; unknown ``i(name)`` as for ``E``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.circuit.elements.base import Element, stamp_voltage_branch
from circuitnsds.system.mlcs import MLCSBuilder


@dataclass(frozen=True)
class VoltageControlledVoltageSource(Element):
    """``E``: nodes are ``(n+, n-, nc+, nc-)``; ``gain`` is dimensionless."""

    gain: float = 1.0
    topology: ClassVar[str] = "voltage"

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus, cplus, cminus = (builder.node(n) for n in self.nodes)
        k = stamp_voltage_branch(builder, self.name, plus, minus)
        builder.add("A", k, cplus, -self.gain)
        builder.add("A", k, cminus, self.gain)


@dataclass(frozen=True)
class VoltageControlledCurrentSource(Element):
    """``G``: nodes are ``(n+, n-, nc+, nc-)``; ``transconductance`` in siemens."""

    transconductance: float = 1.0
    topology: ClassVar[str] = "current"

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus, cplus, cminus = (builder.node(n) for n in self.nodes)
        g = self.transconductance
        builder.add("A", plus, cplus, -g)
        builder.add("A", plus, cminus, g)
        builder.add("A", minus, cplus, g)
        builder.add("A", minus, cminus, -g)
        builder.output(f"i({self.name})", [(cplus, g), (cminus, -g)])


@dataclass(frozen=True)
class _CurrentControlled(Element):
    """What ``F`` and ``H`` share: nodes ``(n+, n-)``; ``control`` names the voltage source
    whose current ``i(control)`` [A] controls the element."""

    control: str = ""

    def control_branch(self, builder: MLCSBuilder) -> int:
        """The index of the unknown ``i(control)``."""
        return builder.branch(f"i({self.control})")


@dataclass(frozen=True)
class CurrentControlledCurrentSource(_CurrentControlled):
    """``F``: ``gain`` is dimensionless."""

    gain: float = 1.0
    topology: ClassVar[str] = "current"

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus = (builder.node(n) for n in self.nodes)
        controlling = self.control_branch(builder)
        builder.add("A", plus, controlling, -self.gain)
        builder.add("A", minus, controlling, self.gain)
        builder.output(f"i({self.name})", [(controlling, self.gain)])


@dataclass(frozen=True)
class CurrentControlledVoltageSource(_CurrentControlled):
    """``H``: ``transresistance`` in ohms."""

    transresistance: float = 1.0
    topology: ClassVar[str] = "voltage"

    def stamp(self, builder: MLCSBuilder) -> None:
        k = stamp_voltage_branch(builder, self.name, *(builder.node(n) for n in self.nodes))
        builder.add("A", k, self.control_branch(builder), -self.transresistance)
