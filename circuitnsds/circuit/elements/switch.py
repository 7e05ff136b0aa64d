"""Ideal controlled switches (SPICE ``S`` and ``W``) with ngspice's hysteresis.

``S name n+ n- nc+ nc- model [ON|OFF]`` is controlled by ``v(nc+) - v(nc-)`` [V];
``W name n+ n- vname model [ON|OFF]`` by the current of voltage source ``vname`` [A].
The model gives ``VT``/``VH`` (or ``IT``/``IH``), ``RON`` and ``ROFF``:

* closed: ``v(n+) - v(n-) = RON·i`` (``RON = 0`` is a perfect short);
* open:   ``i = (v(n+) - v(n-)) / ROFF`` (default ``ROFF = 1e12 Ω``, SPICE's gmin, so that
  a node reached only through open switches keeps a defined potential, as in ngspice);
* the switch closes when the control exceeds ``VT + |VH|``, opens when it falls
  below ``VT - |VH|``, and keeps its state in between;
* with ``VH = 0`` (the default: ``SW(RON=1)`` alone has ``VT = VH = 0``) a control sitting
  exactly at ``VT`` opens a closed switch and keeps an open one open, as ngspice 39's
  ``swload.c``/``cswload.c`` do (there ``VH <= 0`` takes the "negative hysteresis" branch:
  ``v > VT`` on, ``v < VT`` off, and at ``v = VT`` a switch coming from REALLY_ON becomes
  HYST_OFF): both thresholds are then ``VT + AT_THRESHOLD·max(1, |VT|)``, so a 0/1 V gate
  with ``VT = 0`` opens the switch at 0 V. (ngspice closes a switch whose control rises
  from below ``VT`` to exactly ``VT``, and one whose control starts at ``VT``: at its
  operating point the previous state is REALLY_OFF, so it becomes HYST_ON; circuitnsds keeps
  both open, and warns about the second, see ``analyses/operating_point.py``.)

``i(name)`` flows from ``n+`` through the switch to ``n-``. The switch is an
exogenous mode, not a complementarity pair: its state is decided from the
control, then the step's MLCP is solved with it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.circuit.elements.base import Element, junction_conductances
from circuitnsds.system.mlcs import MLCSBuilder

DEFAULT_OFF_RESISTANCE = 1e12
"""Default ``ROFF`` [Ω] (ngspice: 1/GMIN)."""
AT_THRESHOLD = 1e-9
"""With ``VH = 0``, a control within this fraction of ``max(1, |VT|)`` above ``VT`` counts as
"exactly at ``VT``" (round-off of a node voltage), where ngspice opens the switch."""


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
        thermal: the PLECS thermal description of its losses and junction-to-case network
            (``thermal="file.xml"``; used by the loss table and ``tj(...)``), or ``None``.
    """

    name: str
    current_controlled: bool = False
    threshold: float = 0.0
    hysteresis: float = 0.0
    on_resistance: float = 1.0
    off_resistance: float = DEFAULT_OFF_RESISTANCE
    location: object | None = None
    thermal: str | None = None

    def thresholds(self) -> tuple[float, float]:
        """``(on, off)``: the switch closes when the control exceeds ``on`` and opens when it
        falls below ``off`` [V or A] (see the module docstring for ``VH = 0``)."""
        if self.hysteresis == 0:
            level = self.threshold + AT_THRESHOLD * max(1.0, abs(self.threshold))
            return level, level
        half_band = abs(self.hysteresis)
        return self.threshold + half_band, self.threshold - half_band


@dataclass(frozen=True)
class Switch(Element):
    """``S`` (nodes ``n+, n-, nc+, nc-``) or ``W`` (nodes ``n+, n-``, ``control`` = source name)."""

    model: SwitchModel = SwitchModel("sw")
    control: str | None = None
    initially_on: bool = False
    topology: ClassVar[str] = "conductive"
    junction: ClassVar[str | None] = "switch"
    owns_branch_current: ClassVar[bool] = True

    def conductances(self, step: float) -> list[tuple[str, float]]:
        return junction_conductances(self.model)

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
        control, control_nodes = self.control_row(builder, k)
        on_threshold, off_threshold = self.model.thresholds()
        builder.switch(
            dict(
                name=self.name, row=k,
                open_row=_keep(open_row), closed_row=_keep(closed_row), control=_keep(control),
                on_threshold=on_threshold, off_threshold=off_threshold,
                crossing=self.model.threshold if self.model.hysteresis == 0 else None,
                initially_on=self.initially_on,
            ),
            control_nodes,
        )
        builder.output(f"i({self.name})", [(k, 1.0)])

    def control_row(self, builder: MLCSBuilder, branch: int) -> tuple[list[tuple[int, float]],
                                                                       tuple[int, int] | None]:
        """``(control, control_nodes)``: the control as ``(unknown, coefficient)`` terms (the
        switch's own current is the unknown ``branch``), and the indexes ``(nc+, nc-)`` of a
        voltage control (``None`` for a current control)."""
        if self.control is not None:
            return [(builder.branch(f"i({self.control})"), 1.0)], None
        cplus, cminus = (builder.node(n) for n in self.control_nodes())
        return [(cplus, 1.0), (cminus, -1.0)], (cplus, cminus)

    def control_nodes(self) -> tuple[str, str]:
        """``(nc+, nc-)``: the control of an ``S`` switch is ``v(nc+) - v(nc-)`` [V]."""
        return self.nodes[2], self.nodes[3]


def _keep(row: list[tuple[int, float]]) -> tuple[tuple[int, float], ...]:
    """Drop ground (index -1) entries."""
    return tuple((column, value) for column, value in row if column != MLCSBuilder.GROUND)
