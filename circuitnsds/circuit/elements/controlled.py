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

from circuitnsds.circuit.elements.base import Element
from circuitnsds.system.mlcs import MLCSBuilder


def _stamp_voltage_branch(builder: MLCSBuilder, name: str, plus: int, minus: int) -> int:
    """Branch unknown ``i(name)`` into ``plus``, and the row ``0 = v+ - v- - ...`` (completed by caller)."""
    k = builder.branch(f"i({name})")
    builder.add("A", plus, k, -1.0)
    builder.add("A", minus, k, 1.0)
    builder.add("A", k, plus, 1.0)
    builder.add("A", k, minus, -1.0)
    builder.output(f"i({name})", [(k, 1.0)])
    return k


@dataclass(frozen=True)
class VoltageControlledVoltageSource(Element):
    """``E``: nodes are ``(n+, n-, nc+, nc-)``; ``gain`` is dimensionless."""

    gain: float = 1.0
    topology: ClassVar[str] = "voltage"

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus, cplus, cminus = (builder.node(n) for n in self.nodes)
        k = _stamp_voltage_branch(builder, self.name, plus, minus)
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
class CurrentControlledCurrentSource(Element):
    """``F``: nodes ``(n+, n-)``; ``control`` is the controlling voltage source's name."""

    control: str = ""
    gain: float = 1.0
    topology: ClassVar[str] = "current"

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus = (builder.node(n) for n in self.nodes)
        controlling = builder.branch(f"i({self.control})")
        builder.add("A", plus, controlling, -self.gain)
        builder.add("A", minus, controlling, self.gain)
        builder.output(f"i({self.name})", [(controlling, self.gain)])


@dataclass(frozen=True)
class CurrentControlledVoltageSource(Element):
    """``H``: nodes ``(n+, n-)``; ``control`` names a voltage source; ``transresistance`` in ohms."""

    control: str = ""
    transresistance: float = 1.0
    topology: ClassVar[str] = "voltage"

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus = (builder.node(n) for n in self.nodes)
        k = _stamp_voltage_branch(builder, self.name, plus, minus)
        builder.add("A", k, builder.branch(f"i({self.control})"), -self.transresistance)
