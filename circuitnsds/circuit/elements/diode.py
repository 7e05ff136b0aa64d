"""Ideal, piecewise-linear and Zener diodes as complementarity pairs.

Sign conventions: the diode current ``i`` flows from anode (``nodes[0]``) to
cathode (``nodes[1]``); ``v = v(anode) - v(cathode)``.

* forward pair:  ``0 <= i_f  ⊥  Ron·i_f + Vfwd - v >= 0``
* reverse pair (Zener only): ``0 <= i_r  ⊥  Rrev·i_r + Vz + v >= 0``
* off-conductance ``1/Roff`` in parallel (SPICE's gmin by default).

The net diode current reported as ``i(name)`` is ``i_f - i_r + v/Roff``.
With ``area`` (the SPICE instance multiplier) the device behaves as ``area``
diodes in parallel: ``Ron``, ``Rrev`` and ``Roff`` are divided by it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.circuit.elements.base import Element, junction_conductances
from circuitnsds.circuit.elements.diode_fit import ShockleyDiode, fit_breakdown, fit_forward
from circuitnsds.circuit.elements.diode_notes import FitRangeObserver
from circuitnsds.errors import SourceLocation
from circuitnsds.system.mlcs import MLCSBuilder

DEFAULT_OFF_RESISTANCE = 1e12
"""Default ``Roff`` [Ω]: the conductance 1e-12 S is SPICE's default gmin."""


@dataclass(frozen=True)
class DiodeModel:
    """What the ideal engine takes from a ``.model NAME D(...)`` card.

    Attributes:
        name: model name, lower-case.
        forward_drop: ``Vfwd`` [V], forward voltage of the conducting diode.
        on_resistance: ``Ron`` [Ω], slope of the conducting branch.
        off_resistance: ``Roff`` [Ω], resistance of the blocking diode.
        breakdown_voltage: ``BV`` or ``Vrev`` [V] (> 0); ``None`` for a plain diode.
        breakdown_resistance: ``Rrev`` [Ω], slope of the breakdown branch.
        origin: how the card was read, for ``info``: ``ideal``, ``LTspice PWL`` or the
            Shockley fit (:mod:`circuitnsds.circuit.elements.diode_fit`) with its figures.
        shockley: the Shockley curve a fitted model came from (``None`` otherwise), so that
            it can be refitted (``.options pwlfit=auto``).
        fit_range: the forward currents ``(low, high)`` [A] the line was fitted over, for a
            fitted model.
        breakdown_fit_range: the reverse currents ``(low, high)`` [A] the breakdown line was
            fitted over, for a fitted model with ``BV``.
        location: where the card was written.
        thermal: the PLECS thermal description of its losses and junction-to-case network
            (``thermal="file.xml"``; used by the loss table and ``tj(...)``), or ``None``.
    """

    name: str
    forward_drop: float = 0.0
    on_resistance: float = 0.0
    off_resistance: float = DEFAULT_OFF_RESISTANCE
    breakdown_voltage: float | None = None
    breakdown_resistance: float = 0.0
    origin: str = "ideal"
    shockley: ShockleyDiode | None = None
    fit_range: tuple[float, float] | None = None
    breakdown_fit_range: tuple[float, float] | None = None
    location: SourceLocation | None = None
    thermal: str | None = None

    @property
    def kind(self) -> str:
        """``ideal``, ``piecewise-linear`` or ``zener``."""
        if self.breakdown_voltage is not None:
            return "zener"
        if self.forward_drop or self.on_resistance:
            return "piecewise-linear"
        return "ideal"


def fitted_model(model: DiodeModel, diode: ShockleyDiode, forward_current: float | None = None,
                 breakdown_current: float | None = None) -> DiodeModel:
    """``model`` with ``Vfwd``/``Ron`` (and ``Vrev``/``Rrev`` when it has a breakdown) fitted
    to ``diode``'s curve over ``[I/10, I]`` (defaults: ``IAVE``/``IBV``/1 A, see
    :mod:`~circuitnsds.circuit.elements.diode_fit`)."""
    from dataclasses import replace

    forward = fit_forward(diode, forward_current)
    origin = "Shockley fit: " + forward.describe("Vfwd", "Ron")
    model = replace(model, forward_drop=forward.drop, on_resistance=forward.resistance,
                    shockley=diode, fit_range=(forward.low, forward.high))
    if diode.breakdown_voltage is not None:
        reverse = fit_breakdown(diode, breakdown_current)
        origin += "; " + reverse.describe("Vrev", "Rrev")
        model = replace(model, breakdown_voltage=max(reverse.drop, 1e-9),
                        breakdown_resistance=reverse.resistance,
                        breakdown_fit_range=(reverse.low, reverse.high))
    return replace(model, origin=origin)


@dataclass(frozen=True)
class Diode(Element):
    """A diode instance ``D name anode cathode model [area]``."""

    model: DiodeModel = DiodeModel("ideal")
    area: float = 1.0
    junction: ClassVar[str | None] = "diode"

    def conductances(self, step: float) -> list[tuple[str, float]]:
        return junction_conductances(self.model)
    run_observers: ClassVar[tuple] = (FitRangeObserver.of,)

    def stamp(self, builder: MLCSBuilder) -> None:
        anode, cathode = (builder.node(n) for n in self.nodes)
        model = self.model
        g_off = self.area / model.off_resistance
        builder.add_conductance("A", anode, cathode, -g_off)

        forward = builder.pair(self.name if model.kind != "zener" else f"{self.name}.forward",
                               self.name, model.forward_drop)
        self._stamp_pair(builder, forward, anode, cathode, model.on_resistance / self.area)
        current_terms = [(forward, 1.0)]
        if model.kind == "zener":
            reverse = builder.pair(f"{self.name}.reverse", self.name, model.breakdown_voltage, sign=-1.0)
            self._stamp_pair(builder, reverse, cathode, anode,
                             model.breakdown_resistance / self.area)
            current_terms.append((reverse, -1.0))
        builder.output(f"i({self.name})", [(anode, g_off), (cathode, -g_off)], current_terms)

    @staticmethod
    def _stamp_pair(builder: MLCSBuilder, pair: int, into: int, out_of: int,
                    resistance: float) -> None:
        """Pair current flows from node ``into`` to node ``out_of``; ``w = R·λ + e - (v_into - v_out_of)``."""
        builder.add("B", into, pair, -1.0)
        builder.add("B", out_of, pair, 1.0)
        builder.add("C", pair, into, -1.0)
        builder.add("C", pair, out_of, 1.0)
        builder.add("D", pair, pair, resistance)
