"""Ideal, piecewise-linear and Zener diodes as complementarity pairs.

Sign conventions: the diode current ``i`` flows from anode (``nodes[0]``) to
cathode (``nodes[1]``); ``v = v(anode) - v(cathode)``.

* forward pair:  ``0 <= i_f  ⊥  Ron·i_f + Vfwd - v >= 0``
* reverse pair (Zener only): ``0 <= i_r  ⊥  Rrev·i_r + Vz + v >= 0``
* off-conductance ``1/Roff`` in parallel (SPICE's gmin by default).

A model fitted to a SPICE diode (:mod:`~circuitnsds.circuit.elements.diode_fit`) has
``k`` forward (and breakdown) pairs in parallel, one per branch ``(V_j, R_j)`` of its fit;
the first is the one above (named ``d1``, or ``dz1.forward``/``dz1.reverse``), the others
``d1.forward2``, ``d1.reverse2``, ... The net diode current reported as ``i(name)`` is
the sum of the forward pairs' currents minus the reverse pairs', plus ``v/Roff``.
With ``area`` (the SPICE instance multiplier) the device behaves as ``area``
diodes in parallel: ``Ron``, ``Rrev`` and ``Roff`` are divided by it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.circuit.elements.base import Element, junction_conductances
from circuitnsds.circuit.elements.diode_fit import (
    MAX_BRANCHES,
    PiecewiseFit,
    ShockleyDiode,
    coarse_breakdown,
    fit_breakdown,
    fit_forward,
)
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
        shockley: the SPICE curve a fitted model came from (``None`` otherwise), so that
            it can be refitted to the currents of a run.
        forward_fit: the forward branches of a fitted model (its first is ``Vfwd``/``Ron``).
        breakdown_fit: the breakdown branches of a fitted model with ``BV`` (its first is
            ``BV``/``Rrev`` above).
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
    forward_fit: PiecewiseFit | None = None
    breakdown_fit: PiecewiseFit | None = None
    location: SourceLocation | None = None
    thermal: str | None = None

    @property
    def forward_branches(self) -> tuple[tuple[float, float], ...]:
        """``(V_j, R_j)`` [V, Ω] of each forward pair, the first ``(Vfwd, Ron)``."""
        return self.forward_fit.branches if self.forward_fit else ((self.forward_drop, self.on_resistance),)

    @property
    def breakdown_branches(self) -> tuple[tuple[float, float], ...]:
        """``(V_j, R_j)`` [V, Ω] of each breakdown pair (none without a breakdown)."""
        if self.breakdown_voltage is None:
            return ()
        if self.breakdown_fit:
            return self.breakdown_fit.branches
        return ((self.breakdown_voltage, self.breakdown_resistance),)

    @property
    def fit_range(self) -> tuple[float, float] | None:
        """The forward currents ``(low, high)`` [A] a fitted model's branches cover."""
        return None if self.forward_fit is None else (self.forward_fit.low, self.forward_fit.high)

    @property
    def kind(self) -> str:
        """``ideal``, ``piecewise-linear`` or ``zener``."""
        if self.breakdown_voltage is not None:
            return "zener"
        if self.forward_drop or self.on_resistance:
            return "piecewise-linear"
        return "ideal"


def fitted_model(model: DiodeModel, diode: ShockleyDiode, forward_current: float | None = None,
                 breakdown_current: float | None = None,
                 breakdown_branches: int = MAX_BRANCHES) -> DiodeModel:
    """``model`` with its forward (and, with ``BV``, breakdown: at most ``breakdown_branches``)
    branches fitted to ``diode``'s curves over ``FIT_DECADES`` decades of current up to
    ``forward_current`` and ``breakdown_current`` [A] (defaults: ``IAVE`` or 1 A, see
    :mod:`~circuitnsds.circuit.elements.diode_fit`)."""
    from dataclasses import replace

    forward = fit_forward(diode, forward_current)
    origin = "SPICE diode fit: forward " + forward.describe("Vfwd")
    model = replace(model, forward_drop=forward.knees[0], on_resistance=forward.resistances[0],
                    shockley=diode, forward_fit=forward)
    if diode.breakdown_voltage is not None:
        reverse = fit_breakdown(diode, breakdown_current, breakdown_branches)
        origin += "; breakdown " + reverse.describe("Vrev")
        if breakdown_branches == 1:
            origin += " (one branch until a run shows breakdown current)"
        model = replace(model, breakdown_voltage=max(reverse.knees[0], 1e-9),
                        breakdown_resistance=reverse.resistances[0], breakdown_fit=reverse)
    return replace(model, origin=origin)


REFIT_MARGIN = 2.0
"""A refit covers up to this factor above the peak current that asked for it (the currents
of a run with the refitted model move: they were those of a fit that missed the curve)."""
UNUSED_DECADES = 3.0
"""A peak current more than this many decades below the top of its fit range asks for a
refit (most of the range then lies above what the circuit carries)."""


def refit_to(model: DiodeModel, forward_peak: float, reverse_peak: float) -> DiodeModel | None:
    """``model`` refitted where its diodes work: a range of :data:`FIT_DECADES` decades up to
    :data:`REFIT_MARGIN` times each peak current [A per unit area] that lies above the
    range or :data:`UNUSED_DECADES` below its top (a breakdown with no current: one
    branch); ``None`` when neither peak asks for it (or the model is not fitted)."""
    if model.shockley is None or model.forward_fit is None:
        return None
    wanted = []
    for peak, fit in ((forward_peak, model.forward_fit), (reverse_peak, model.breakdown_fit)):
        moved = (fit is not None and peak > 1e-9
                 and (peak > fit.high or peak < fit.high * 10.0 ** -UNUSED_DECADES))
        wanted.append(REFIT_MARGIN * peak if moved else (None if fit is None else fit.high))
    coarse = coarse_breakdown(model.breakdown_fit) and reverse_peak > 1e-9
    if not coarse and wanted == [model.forward_fit.high,
                                 None if model.breakdown_fit is None else model.breakdown_fit.high]:
        return None
    # a breakdown the run never reached stays one branch (each branch is a pair in every step)
    return fitted_model(model, model.shockley, *wanted,
                        breakdown_branches=MAX_BRANCHES if reverse_peak > 1e-9 else 1)


@dataclass(frozen=True)
class Diode(Element):
    """A diode instance ``D name anode cathode model [area]``."""

    model: DiodeModel = DiodeModel("ideal")
    area: float = 1.0
    junction: ClassVar[str | None] = "diode"
    run_observers: ClassVar[tuple] = (FitRangeObserver.of,)

    def conductances(self, step: float) -> list[tuple[str, float]]:
        return junction_conductances(self.model)

    def stamp(self, builder: MLCSBuilder) -> None:
        anode, cathode = (builder.node(n) for n in self.nodes)
        model = self.model
        g_off = self.area / model.off_resistance
        builder.add_conductance("A", anode, cathode, -g_off)

        current_terms = []
        for j, (knee, resistance) in enumerate(model.forward_branches):
            if j == 0:
                name = self.name if model.kind != "zener" else f"{self.name}.forward"
            else:
                name = f"{self.name}.forward{j + 1}"
            pair = builder.pair(name, self.name, knee)
            self._stamp_pair(builder, pair, anode, cathode, resistance / self.area)
            current_terms.append((pair, 1.0))
        for j, (knee, resistance) in enumerate(model.breakdown_branches):
            pair = builder.pair(f"{self.name}.reverse" + str(j + 1) * (j > 0), self.name, knee,
                                sign=-1.0)
            self._stamp_pair(builder, pair, cathode, anode, resistance / self.area)
            current_terms.append((pair, -1.0))
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
