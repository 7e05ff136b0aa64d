"""A MOSFET used as a switch (SPICE ``M`` with a ``VDMOS`` or level-1 ``NMOS``/``PMOS`` model).

The channel is an ideal switch between drain and source (an :class:`~circuitnsds.circuit.
elements.switch.Switch`, so it takes the switch's stamps, hysteresis, events and checks)
whose control is the gate–source voltage:

* n-channel: closes when ``v(g) - v(s)`` exceeds ``Vto`` (+ ``|VH|``), opens below ``Vto``
  (- ``|VH|``); the control row is ``v(g) - v(s)``;
* p-channel: closes when ``v(g) - v(s)`` falls below ``Vto`` (negative); the control row is
  ``v(s) - v(g)`` against ``-Vto``.

``nodes`` is ``(drain, source, gate)`` (the switched pair first, as for ``S``). The gate
draws no current through this element. The body diode, the gate resistance and the
linear capacitances are separate elements (``m1.dbody``, ``m1.rg``, ``m1.cgs``,
``m1.cgd``, ``m1.cds``) made by the card reader; ``parts`` names them. ``i(m1)`` is the
channel current from drain to source [A] (body diode and capacitor currents excluded).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from circuitnsds.circuit.elements.mosfet_notes import GateDriveObserver
from circuitnsds.circuit.elements.switch import Switch


@dataclass(frozen=True)
class Mosfet(Switch):
    """``M name d g s [b] MODEL``: an ideal drain–source switch driven by ``v(g, s)``.

    Attributes:
        polarity: ``+1`` n-channel, ``-1`` p-channel.
        device: ``vdmos``, ``nmos`` or ``pmos`` (the model type).
        on_resistance_rule: how ``model.on_resistance`` was obtained, in words (for ``info``).
        gate_drive: ``|Vgs|`` [V] at which the channel's on-resistance was computed
            (``.options mosdrive``).
        parts: names of the companion elements (body diode, capacitors, gate resistor).
    """

    polarity: int = 1
    device: str = "vdmos"
    run_observers: ClassVar[tuple] = (GateDriveObserver,)
    on_resistance_rule: str = ""
    gate_drive: float = 10.0
    parts: tuple[str, ...] = ()
    owns_branch_current: ClassVar[bool] = False  # F, H and W do not sense an M line (as in SPICE)

    @property
    def gate(self) -> str:
        return self.nodes[2]

    def control_nodes(self) -> tuple[str, str]:
        """``(g, s)`` for an n-channel device, ``(s, g)`` for a p-channel one."""
        drain, source, gate = self.nodes[:3]
        return (gate, source) if self.polarity > 0 else (source, gate)
