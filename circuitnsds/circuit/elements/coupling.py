"""Mutual inductance ``K name L1 L2 k`` (SPICE's dot convention: the first node of each inductor).

With ``M = k·sqrt(L1·L2)`` the branch equations of the two inductors become

    L1 i1' + M i2' = v(L1+) - v(L1-)
    M i1' + L2 i2' = v(L2+) - v(L2-)

so the element only adds ``M`` to the two off-diagonal entries of ``E``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.circuit.elements.base import Element
from circuitnsds.system.mlcs import MLCSBuilder


@dataclass(frozen=True)
class MutualInductance(Element):
    """Coupling of two inductors; ``nodes`` is empty (the element has no terminals of its own).

    Attributes:
        inductors: the two inductor names.
        inductances: their inductances [H], copied at elaboration.
        coupling: ``k``, with ``0 < |k| <= 1``.
    """

    inductors: tuple[str, str] = ("", "")
    inductances: tuple[float, float] = (1.0, 1.0)
    coupling: float = 1.0
    topology: ClassVar[str] = "coupling"

    def value_errors(self) -> list[tuple[str, str | None]]:
        return []  # no terminals of its own: the inductors it names are checked by the circuit

    @property
    def mutual(self) -> float:
        """``M = k·sqrt(L1·L2)`` [H]."""
        return self.coupling * math.sqrt(self.inductances[0] * self.inductances[1])

    def stamp(self, builder: MLCSBuilder) -> None:
        first, second = (builder.branch(f"i({name})") for name in self.inductors)
        builder.add("E", first, second, self.mutual)
        builder.add("E", second, first, self.mutual)
