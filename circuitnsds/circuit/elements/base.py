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
        junction: the ideal junction it holds, for the checks: ``"diode"`` (a complementarity
            pair that opens and closes by its own voltage and current, with a ``model``
            giving ``forward_drop``, ``on_resistance``, ``off_resistance``), ``"switch"``
            (one that a control opens and closes; ``model`` gives ``on_resistance`` and
            ``off_resistance``, ``initially_on`` its state at the start), ``None`` (none).
        owns_branch_current: it adds the unknown ``i(name)`` that ``F``, ``H`` and ``W``
            may sense: by default a voltage-defined element (``topology == "voltage"``, whose
            branch current is an unknown of MNA); inductors and switches declare it too.
        independent_source: its value is a known function of time (``function``), not of
            the circuit's unknowns.
        run_observers: factories of the observers a run of a circuit holding this element
            runs (:mod:`circuitnsds.circuit.observers`: run-time notes of the device).
    """

    name: str
    nodes: tuple[str, ...]
    location: SourceLocation | None = None
    topology: ClassVar[str] = "conductive"
    junction: ClassVar[str | None] = None
    independent_source: ClassVar[bool] = False
    run_observers: ClassVar[tuple[Callable, ...]] = ()

    def stamp(self, builder: MLCSBuilder) -> None:
        """Add this element's entries to the MLCS under construction."""
        raise NotImplementedError

    @property
    def owns_branch_current(self) -> bool:
        return self.topology == "voltage"

    @property
    def model_name(self) -> str | None:
        """The ``.model`` this element names, or ``None``."""
        model = getattr(self, "model", None)
        return model if isinstance(model, str) or model is None else model.name

    def value_errors(self) -> list[tuple[str, str | None]]:
        """``(message, hint)`` for each value that makes the element meaningless (a resistance
        that is not positive, a missing terminal), most basic first; empty when it is sound."""
        if len(self.nodes) < 2:
            return [(f"needs two terminals, has {len(self.nodes)}", None)]
        return []

    def value_warnings(self) -> list[str]:
        """Sentences about values that are legal but rarely meant (a 0 F capacitor)."""
        return []

    def conductances(self, step: float) -> list[tuple[str, float]]:
        """``(what, siemens)`` of each conductance-like term of the step's equations for this
        element (``1/R``, ``C/h``, ``h/L``, ``1/Ron``, ``1/Roff``) at step ``step`` [s]."""
        return []

    def describe(self) -> str:
        """Short human description for messages: ``r1 (line 4)``."""
        return f"{self.name} ({self.location})" if self.location else self.name


def negative_value(value: float, what: str, unit: str) -> list[tuple[str, str | None]]:
    """The error ``(message, hint)`` of a ``value`` [``unit``] that must not be negative."""
    return [(f"{what} must not be negative, got {value:g} {unit}", None)] if value < 0 else []


def junction_conductances(model) -> list[tuple[str, float]]:
    """``(what, siemens)`` of an ideal junction's ``Roff`` and, when positive, ``Ron``."""
    found = [(f"Roff = {model.off_resistance:.3g} Ω", 1.0 / model.off_resistance)]
    if model.on_resistance > 0:
        found.append((f"Ron = {model.on_resistance:.3g} Ω", 1.0 / model.on_resistance))
    return found


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
