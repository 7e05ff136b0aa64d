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

from dataclasses import dataclass, replace
from typing import ClassVar

from circuitnsds.circuit.elements.mosfet_laws import ChannelLaw, OutputCapacitance
from circuitnsds.circuit.elements.mosfet_notes import GateDriveObserver
from circuitnsds.circuit.elements.switch import Switch


@dataclass(frozen=True)
class Mosfet(Switch):
    """``M name d g s [b] MODEL``: an ideal drain–source switch driven by ``v(g, s)``.

    Attributes:
        polarity: ``+1`` n-channel, ``-1`` p-channel.
        device: ``vdmos``, ``nmos`` or ``pmos`` (the model type).
        channel_rule: the on-resistance's equation and its parameters, in words (for ``info``).
        gate_drive: ``|Vgs|`` [V] at which the channel's on-resistance was computed.
        drive_origin: where ``gate_drive`` comes from, in words (``.options mosdrive``, the
            default, the drive a first run applied).
        channel: the on-resistance as a function of the gate drive (``None``: fixed).
        output: the output capacitance ``Coss(v)`` (``None``: the model has none); the
            drain–source capacitor ``{name}.coss`` holds its charge-equivalent value over
            ``0..switched_voltage``.
        switched_voltage: the blocking voltage [V] that value was computed over.
        voltage_origin: where ``switched_voltage`` comes from, in words.
        parts: names of the companion elements (body diode, capacitors, gate resistor).
    """

    polarity: int = 1
    device: str = "vdmos"
    run_observers: ClassVar[tuple] = (GateDriveObserver,)
    channel_rule: str = ""
    gate_drive: float = 10.0
    drive_origin: str = "the default"
    channel: ChannelLaw | None = None
    output: OutputCapacitance | None = None
    switched_voltage: float = 0.0
    voltage_origin: str = ""
    parts: tuple[str, ...] = ()
    owns_branch_current: ClassVar[bool] = False  # F, H and W do not sense an M line (as in SPICE)

    @property
    def gate(self) -> str:
        return self.nodes[2]

    @property
    def drive_fixed(self) -> bool:
        """Whether ``.options mosdrive`` sets the gate drive (a run does not change it)."""
        return self.drive_origin == ".options mosdrive"

    @property
    def on_resistance_rule(self) -> str:
        """How ``model.on_resistance`` was obtained, in words (for ``info`` and the notes)."""
        if self.channel is None:
            return self.channel_rule
        return (f"{self.channel.rule(self.gate_drive)} at |Vgs| = {self.gate_drive:.4g} V "
                f"({self.drive_origin}); {self.channel_rule}")

    @property
    def output_rule(self) -> str:
        """How ``{name}.coss`` was obtained, in words; empty without an output capacitance."""
        if self.output is None:
            return ""
        volts = self.switched_voltage
        picofarads = [1e12 * c for c in (self.output.equivalent(volts), self.output.capacitance(0.0),
                                         self.output.capacitance(volts))]
        return (f"Coss = Q(V)/V = {picofarads[0]:.4g} pF, charge-equivalent over 0..{volts:.4g} V "
                f"({self.voltage_origin}); {picofarads[1]:.4g} pF at 0 V, {picofarads[2]:.4g} pF "
                f"at {volts:.4g} V")

    def at_drive(self, drive: float, origin: str) -> Mosfet:
        """This MOSFET with its on-resistance at the gate drive ``drive`` [V] (``origin``: where
        the drive comes from); itself when its on-resistance is fixed."""
        if self.channel is None:
            return self
        model = replace(self.model, on_resistance=self.channel.resistance(drive))
        return replace(self, model=model, gate_drive=drive, drive_origin=origin)

    def at_voltage(self, voltage: float, origin: str) -> Mosfet:
        """This MOSFET noting its output capacitance is taken over ``0..voltage`` [V]."""
        return replace(self, switched_voltage=voltage, voltage_origin=origin)

    def control_nodes(self) -> tuple[str, str]:
        """``(g, s)`` for an n-channel device, ``(s, g)`` for a p-channel one."""
        drain, source, gate = self.nodes[:3]
        return (gate, source) if self.polarity > 0 else (source, gate)
