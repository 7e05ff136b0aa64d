"""A behavioural source whose value is a smooth nonlinear function of the unknowns and of
time (``B1 out 0 V={v(a)*v(b)}``, ``G1 a 0 CUR={1e-12*(exp(v(a)/0.025)-1)}``): one
:class:`~circuitnsds.system.smooth.SmoothRelation`, which the Newton stepper linearises at
every iteration (DESIGN.md, "Smooth nonlinear elements beside the ideal ones").

Sign conventions are those of the affine source
(:class:`~circuitnsds.circuit.elements.behavioural.BehaviouralSource`): a voltage output
imposes ``v(n+) − v(n−) = g(x, t)`` and its current ``i(name)`` flows into ``n+`` through
the source; a current output drives ``g(x, t)`` [A] from ``n+`` through the source to ``n−``.
Either way ``i(name)`` is an unknown of its own, and the relation sits on its branch row:
``0 = v(n+) − v(n−) − g`` (``f = g``) or ``0 = g − i(name)`` (``f = −g``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from circuitnsds.circuit.elements.behavioural import BehaviouralSource
from circuitnsds.system.mlcs import MLCSBuilder
from circuitnsds.system.smooth import SmoothEvaluation, SmoothRelation

ValueAndGradient = Callable[[Sequence[float], float], tuple[float, np.ndarray]]
"""``(x, t) -> (g, dg/dx)``: the expression's value and its gradient over its inputs."""


@dataclass(frozen=True)
class SmoothBehaviouralSource(BehaviouralSource):
    """A ``B``/``E``/``G`` source of a nonlinear expression (module docstring).

    Attributes:
        inputs: what the expression reads, in the order of its ``x``: ``("v", node)`` [V] or
            ``("i", voltage source)`` [A].
        law: ``law(x, t)`` → ``(g, dg/dx)`` (``nan`` where undefined).
        uses_time: the expression reads ``time``.
    """

    inputs: tuple[tuple[str, str], ...] = ()
    law: ValueAndGradient | None = None
    uses_time: bool = False

    @property
    def smooth(self) -> bool:
        """Whether the element is a smooth nonlinear one (for ``info``): always."""
        return True

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus = (builder.node(n) for n in self.nodes[:2])
        k = builder.branch(f"i({self.name})")
        builder.add("A", plus, k, -1.0)
        builder.add("A", minus, k, 1.0)
        if self.output == "v":
            builder.add("A", k, plus, 1.0)
            builder.add("A", k, minus, -1.0)
            sign = 1.0
        else:
            builder.add("A", k, k, -1.0)
            sign = -1.0
        columns = tuple(builder.node(name) if kind == "v" else builder.branch(f"i({name})")
                        for kind, name in self.inputs)
        law = self.law
        empty = np.zeros((1, 0))

        def evaluate(x: np.ndarray, t: float) -> SmoothEvaluation:
            value, gradient = law(x, t)
            f = np.array([sign * value])
            return f, (sign * np.asarray(gradient, dtype=float)).reshape(1, -1), np.zeros(1), (
                np.zeros((1, len(columns))) if columns else empty)

        builder.smooth(SmoothRelation(self.name, columns, (k,), evaluate))
        builder.output(f"i({self.name})", [(k, 1.0)])
