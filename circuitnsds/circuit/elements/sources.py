"""Independent voltage and current sources (SPICE sign conventions).

* ``V name n+ n- ...``: ``v(n+) - v(n-) = V(t)``; the unknown ``i(name)`` is the
  current flowing *into* ``n+`` through the source to ``n-`` (so a source that
  delivers power has a negative current, as in SPICE).
* ``I name n+ n- ...``: a current ``I(t)`` flows from ``n+`` through the source
  to ``n-`` (it leaves the circuit at ``n+`` and enters it at ``n-``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.circuit.elements.base import Element, stamp_voltage_branch
from circuitnsds.system.mlcs import MLCSBuilder
from circuitnsds.system.stimuli import Dc, Stimulus


@dataclass(frozen=True)
class IndependentSource(Element):
    """What V and I sources share: the time function ``function`` [V or A] and the AC stimulus
    ``ac`` (magnitude [V or A], phase [deg]) of the small-signal ``.ac``."""

    function: Stimulus = Dc(0.0)
    ac: tuple[float, float] | None = None
    independent_source: ClassVar[bool] = True


@dataclass(frozen=True)
class VoltageSource(IndependentSource):
    """Independent voltage source (``function`` in volts)."""

    topology: ClassVar[str] = "voltage"

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus = (builder.node(n) for n in self.nodes)
        k = stamp_voltage_branch(builder, self.name, plus, minus)
        column = builder.stimulus(self.function, self.name)
        builder.add("S", k, column, -1.0)
        builder.voltage_source_stimulus(plus, minus, column)


@dataclass(frozen=True)
class CurrentSource(IndependentSource):
    """Independent current source (``function`` in amperes, flowing from n+ through the
    source to n-)."""

    topology: ClassVar[str] = "current"

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus = (builder.node(n) for n in self.nodes)
        column = builder.stimulus(self.function, self.name)
        builder.add("S", plus, column, -1.0)
        builder.add("S", minus, column, 1.0)
