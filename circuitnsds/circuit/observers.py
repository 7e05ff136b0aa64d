"""Run-time observers: what a device watches during a run to note afterwards that the run
left the conditions its ideal model was made for (a fitted diode driven beyond its fit
range, a MOSFET conducting at a weak gate drive).

An element class declares the observers it needs in :attr:`Element.run_observers`: each a
factory ``factory(circuit, elements) -> observer | None`` called once per run with the
circuit and its elements that declared it (``None``: nothing to watch). An observer has

* ``observe(mlcs, trajectory, first)``: called for every part of the run (every step's
  state, before any decimation; ``first``: the first row that is new, see
  :mod:`circuitnsds.engine.driver`); it keeps only what it needs (peaks, times);
* ``report()``: called once after a run that finished; it warns
  (:class:`~circuitnsds.errors.RunNote`) about what it saw.

The analysis only runs the declared observers (:func:`observers_of`): a new note is an
observer beside its device and one entry in that device's ``run_observers``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from circuitnsds.circuit.circuit import Circuit
    from circuitnsds.circuit.elements.base import Element


class RunObserver(Protocol):
    """What an observer provides (see the module docstring)."""

    def observe(self, mlcs: Any, trajectory: Any, first: int) -> None:
        """Watch the rows ``first:`` of a part of the run."""

    def report(self) -> None:
        """Note (warn) what the run showed."""


ObserverFactory = Callable[["Circuit", list["Element"]], "RunObserver | None"]
"""``factory(circuit, elements)``: the observer of a run over ``elements``, or ``None``."""


def observers_of(circuit: Circuit) -> list[RunObserver]:
    """The observers the elements of ``circuit`` declare (each factory called once, with the
    elements that declared it, in the circuit's order)."""
    declared: dict[ObserverFactory, list[Element]] = {}
    for element in circuit.elements:
        for factory in type(element).run_observers:
            declared.setdefault(factory, []).append(element)
    observers = [factory(circuit, elements) for factory, elements in declared.items()]
    return [observer for observer in observers if observer is not None]
