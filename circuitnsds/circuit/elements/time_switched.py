"""A resistor whose value steps at known instants (``R1 a b {time < 12m ? 10 : 5}``).

The MLCS keeps constant matrices, so a resistance that changes with time is stamped as
one branch per value it takes, in parallel between ``nodes[0]`` and ``nodes[1]``: branch
``j`` carries ``i_j = (v(n0) - v(n1)) / R_j`` while the resistance is ``R_j`` and
``i_j = 0`` otherwise. Each branch is a switch scheduled by its own time function (an
indicator, 1 while the resistance is ``R_j``, a PWL with vertical corners), so exactly
one branch conducts in every step and the changes fall on grid points (the corners are
breakpoints of the time grid): the element is exact, not an approximation.

``i(name)`` is the sum of the branches: the current from ``nodes[0]`` through the
resistor to ``nodes[1]``, as for :class:`~circuitnsds.circuit.elements.passive.Resistor`.
"""

from __future__ import annotations

from dataclasses import dataclass

from circuitnsds.circuit.elements.base import Element
from circuitnsds.system.mlcs import MLCSBuilder
from circuitnsds.system.stimuli import Pwl


@dataclass(frozen=True)
class TimeSwitchedResistor(Element):
    """Resistances ``resistances`` [Ω] (each > 0, distinct), the ``j``-th in force while
    ``selectors[j]`` (a PWL of 0 and 1 over time [s]) is 1; ``expression``: the value as
    written, for messages."""

    resistances: tuple[float, ...] = (1.0,)
    selectors: tuple[Pwl, ...] = (Pwl((0.0,), (1.0,)),)
    expression: str = ""

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus = (builder.node(n) for n in self.nodes)
        branches = []
        for j, (resistance, selector) in enumerate(zip(self.resistances, self.selectors)):
            k = builder.branch(f"i({self.name}#{j + 1})")
            branches.append((k, 1.0))
            builder.add("A", plus, k, -1.0)
            builder.add("A", minus, k, 1.0)
            builder.add("A", k, k, -1.0)  # open: i_j = 0
            g = 1.0 / resistance
            closed = tuple((c, v) for c, v in ((plus, g), (minus, -g), (k, -1.0)) if c != builder.GROUND)
            builder.switch(dict(
                name=f"{self.name}#{j + 1}", row=k, open_row=((k, -1.0),), closed_row=closed,
                control=(), on_threshold=0.5, off_threshold=0.5, initially_on=selector.value(0.0) > 0.5,
                control_stimulus=(builder.stimulus(selector, self.name), 1.0)))
        builder.output(f"i({self.name})", branches)
