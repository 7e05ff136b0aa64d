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
class _VoltageControlled(Element):
    """What ``E`` and ``G`` share: nodes ``(n+, n-, nc+, nc-)``, controlled by the voltage
    ``v(nc+) - v(nc-)``."""

    def add_control(self, builder: MLCSBuilder, row: int, coefficient: float) -> None:
        """Add ``coefficient·(v(nc+) - v(nc-))`` to ``row`` of ``A``."""
        cplus, cminus = (builder.node(n) for n in self.nodes[2:])
        builder.add("A", row, cplus, coefficient)
        builder.add("A", row, cminus, -coefficient)


@dataclass(frozen=True)
class VoltageControlledVoltageSource(_VoltageControlled):
    """``E``: ``gain`` is dimensionless."""

    gain: float = 1.0
    topology: ClassVar[str] = "voltage"

    def stamp(self, builder: MLCSBuilder) -> None:
        k = stamp_voltage_branch(builder, self.name, *(builder.node(n) for n in self.nodes[:2]))
        self.add_control(builder, k, -self.gain)


@dataclass(frozen=True)
class VoltageControlledCurrentSource(_VoltageControlled):
    """``G``: ``transconductance`` in siemens; its current ``i(name)`` is an output."""

    transconductance: float = 1.0
    topology: ClassVar[str] = "current"

    def stamp(self, builder: MLCSBuilder) -> None:
        g = self.transconductance
        plus, minus, cplus, cminus = (builder.node(n) for n in self.nodes)
        self.add_control(builder, plus, -g)  # the current leaves n+ ...
        self.add_control(builder, minus, g)  # ... and enters n-
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
