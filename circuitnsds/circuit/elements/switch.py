"""Ideal controlled switches (SPICE ``S`` and ``W``) with ngspice's hysteresis.

``S name n+ n- nc+ nc- model [ON|OFF]`` is controlled by ``v(nc+) - v(nc-)`` [V];
``W name n+ n- vname model [ON|OFF]`` by the current of voltage source ``vname`` [A].
The model gives ``VT``/``VH`` (or ``IT``/``IH``), ``RON`` and ``ROFF``:

* closed: ``v(n+) - v(n-) = RON·i`` (``RON = 0`` is a perfect short);
* open:   ``i = (v(n+) - v(n-)) / ROFF`` (default ``ROFF = 1e12 Ω``, SPICE's gmin, so that
  a node reached only through open switches keeps a defined potential, as in ngspice);
* the switch closes when the control exceeds ``VT + |VH|``, opens when it falls
  below ``VT - |VH|``, and keeps its state in between.

``i(name)`` flows from ``n+`` through the switch to ``n-``. The switch is an
exogenous mode, not a complementarity pair: its state is decided from the
control, then the step's MLCP is solved with it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.circuit.elements.base import Element
from circuitnsds.system.mlcs import MLCSBuilder

DEFAULT_OFF_RESISTANCE = 1e12
"""Default ``ROFF`` [Ω] (ngspice: 1/GMIN)."""


@dataclass(frozen=True)
class SwitchModel:
    """A ``.model NAME SW(...)`` or ``CSW(...)`` card.

    Attributes:
        name: model name.
        current_controlled: ``CSW`` (thresholds in amperes) rather than ``SW`` (volts).
        threshold: ``VT`` or ``IT``.
        hysteresis: ``VH`` or ``IH`` (its magnitude is used, as a half-width).
        on_resistance: ``RON`` [Ω], may be 0 (ngspice default 1 Ω).
        off_resistance: ``ROFF`` [Ω] (> 0).
    """

    name: str
    current_controlled: bool = False
    threshold: float = 0.0
    hysteresis: float = 0.0
    on_resistance: float = 1.0
    off_resistance: float = DEFAULT_OFF_RESISTANCE
    location: object | None = None


@dataclass(frozen=True)
class Switch(Element):
    """``S`` (nodes ``n+, n-, nc+, nc-``) or ``W`` (nodes ``n+, n-``, ``control`` = source name)."""

    model: SwitchModel = SwitchModel("sw")
    control: str | None = None
    initially_on: bool = False
    topology: ClassVar[str] = "conductive"

    def stamp(self, builder: MLCSBuilder) -> None:
        plus, minus = builder.node(self.nodes[0]), builder.node(self.nodes[1])
        k = builder.branch(f"i({self.name})")
        builder.add("A", plus, k, -1.0)
        builder.add("A", minus, k, 1.0)
        g_off = 1.0 / self.model.off_resistance
        open_row = [(plus, g_off), (minus, -g_off), (k, -1.0)]
        closed_row = [(plus, 1.0), (minus, -1.0), (k, -self.model.on_resistance)]
        for column, value in open_row:
            builder.add("A", k, column, value)
        if self.control is None:
            cplus, cminus = (builder.node(n) for n in self.control_nodes())
            control = [(cplus, 1.0), (cminus, -1.0)]
            control_nodes = (cplus, cminus)
        else:
            control = [(builder.branch(f"i({self.control})"), 1.0)]
            control_nodes = None
        half_band = abs(self.model.hysteresis)
        builder.switch(
            dict(
                name=self.name, row=k,
                open_row=_keep(open_row), closed_row=_keep(closed_row), control=_keep(control),
                on_threshold=self.model.threshold + half_band,
                off_threshold=self.model.threshold - half_band,
                initially_on=self.initially_on,
            ),
            control_nodes,
        )
        builder.output(f"i({self.name})", [(k, 1.0)])

    def control_nodes(self) -> tuple[str, str]:
        """``(nc+, nc-)``: the control of an ``S`` switch is ``v(nc+) - v(nc-)`` [V]."""
        return self.nodes[2], self.nodes[3]


def _keep(row: list[tuple[int, float]]) -> tuple[tuple[int, float], ...]:
    """Drop ground (index -1) entries."""
    return tuple((column, value) for column, value in row if column != MLCSBuilder.GROUND)
