"""What every element has: a name, terminals, where it was written, and a stamp."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.errors import SourceLocation
from circuitnsds.system.mlcs import MLCSBuilder


@dataclass(frozen=True)
class Element:
    """Base of all elements.

    Attributes:
        name: lower-case element name as in the netlist (``r1``).
        nodes: terminal node names, lower-case, ground is ``0``.
        location: netlist file and line, or ``None`` for elements made in Python.
        topology: how the element connects its nodes, for the circuit checks:
            ``conductive`` (R, D), ``capacitor``, ``inductor``, ``voltage``, ``current``.
        run_observers: factories of the observers a run of a circuit holding this element
            runs (:mod:`circuitnsds.circuit.observers`: run-time notes of the device).
    """

    name: str
    nodes: tuple[str, ...]
    location: SourceLocation | None = None
    topology: ClassVar[str] = "conductive"
    run_observers: ClassVar[tuple[Callable, ...]] = ()

    def stamp(self, builder: MLCSBuilder) -> None:
        """Add this element's entries to the MLCS under construction."""
        raise NotImplementedError

    def describe(self) -> str:
        """Short human description for messages: ``r1 (line 4)``."""
        return f"{self.name} ({self.location})" if self.location else self.name


def stamp_voltage_branch(builder: MLCSBuilder, name: str, plus: int, minus: int) -> int:
    """The branch of a voltage-defined element (``V``, ``E``, ``H``): the unknown ``i(name)``
    [A] flowing into ``plus`` through the element to ``minus`` (declared as an output), and
    its row ``0 = v(plus) - v(minus) - ...``, which the caller completes. Returns the
    unknown's index."""
    k = builder.branch(f"i({name})")
    builder.add("A", plus, k, -1.0)
    builder.add("A", minus, k, 1.0)
    builder.add("A", k, plus, 1.0)
    builder.add("A", k, minus, -1.0)
    builder.output(f"i({name})", [(k, 1.0)])
    return k
