"""Power semiconductors built from ideal pieces: the IGBT and the thyristor (SCR).

Both are a controlled :class:`~circuitnsds.circuit.elements.switch.Switch` in series with a
piecewise-linear diode (a complementarity pair) that gives the on-state characteristic
``v = V0 + r·i`` and stops the main current from reversing. The card reader
(:mod:`circuitnsds.frontend.cards.power_devices`) makes the diode and the other parts.

* IGBT (``nodes = (collector, inner, gate, emitter)``): the switch from the collector to the
  inner node closes when ``v(gate) - v(emitter)`` exceeds ``VT`` (a voltage-controlled
  switch, with the ``S`` switch's rules at the threshold); the diode from the inner node to
  the emitter has ``Vfwd = VCESAT``, ``Ron = RON``. ``i(z1)`` flows from the collector to the
  emitter through the switch.
* Thyristor (``nodes = (anode, inner, gate, gate_inner)``): the switch from the anode to the
  inner node is controlled by the *current* ``i_g + i_a`` [A]: the gate current ``i_g``
  (the unknown ``i(z1.gate)``, flowing into the gate terminal towards the cathode through
  the gate junction) plus the anode current ``i_a`` (the switch's own, ``i(z1)``). It
  closes (fires) when ``i_g + i_a > IGT``, while the anode current is zero, so when the gate
  current exceeds ``IGT``; it stays closed (latches) while ``i_g + i_a >= IH``, and opens
  when the sum falls below ``IH``: with the gate off, when the anode current falls below
  the holding current, which the series diode makes happen exactly at the anode current's
  zero. A switch fired while reverse biased carries nothing (the diode blocks) and opens
  when the gate current stops. The memory is the switch's state, which the step loop
  keeps between the thresholds as it keeps any switch's hysteresis.

The device's voltage (``terminals``: collector/anode to emitter/cathode) is what losses and
measures take; the on-state diode ``z1.on`` is part of it (``absorbed_parts``), so the loss
table has one row ``z1`` whose power is ``v·i = (V0 + r·i)·i`` while it conducts.
"""

from __future__ import annotations

from dataclasses import dataclass

from circuitnsds.circuit.elements.base import stamp_voltage_branch
from circuitnsds.circuit.elements.switch import Switch
from circuitnsds.system.mlcs import MLCSBuilder


@dataclass(frozen=True)
class Igbt(Switch):
    """``Z name c g e MODEL`` with an ``IGBT`` model: the gate-controlled switch of the chain.

    Attributes:
        parts: names of the companion elements (the conduction diode ``z1.vce``, the
            antiparallel diode ``z1.dfree`` when the model has one).
    """

    parts: tuple[str, ...] = ()

    @property
    def gate(self) -> str:
        return self.nodes[2]

    @property
    def terminals(self) -> tuple[str, str]:
        """``(collector, emitter)``: the device's voltage is ``v(c) - v(e)`` (losses, measures)."""
        return self.nodes[0], self.nodes[3]

    @property
    def absorbed_parts(self) -> tuple[str, ...]:
        """The part whose power is the device's own (``v(c, e)·i`` includes the on-state diode's)."""
        return (f"{self.name}.on",)


@dataclass(frozen=True)
class Thyristor(Switch):
    """``Z name a g k MODEL`` with an ``SCR`` model: the latching switch of the chain.

    ``model`` is a current-controlled :class:`~circuitnsds.circuit.elements.switch.SwitchModel`
    whose thresholds are ``(IGT, IH)``.

    Attributes:
        parts: names of the companion elements (the conduction diode, the gate junction).
        cathode: the cathode node (where both diodes return).
    """

    parts: tuple[str, ...] = ()
    cathode: str = "0"

    @property
    def gate(self) -> str:
        return self.nodes[2]

    @property
    def terminals(self) -> tuple[str, str]:
        """``(anode, cathode)``: the device's voltage is ``v(a) - v(k)`` (losses, measures)."""
        return self.nodes[0], self.cathode

    @property
    def absorbed_parts(self) -> tuple[str, ...]:
        """The part whose power is the device's own (``v(a, k)·i`` includes the on-state diode's)."""
        return (f"{self.name}.on",)

    def control_row(self, builder: MLCSBuilder, branch: int) -> tuple[list[tuple[int, float]], None]:
        """``i_g + i_a``: the gate branch (a 0 V branch from the gate to the gate junction,
        stamped here) plus the switch's own current ``branch``."""
        gate, junction = builder.node(self.nodes[2]), builder.node(self.nodes[3])
        gate_current = stamp_voltage_branch(builder, f"{self.name}.gate", gate, junction)
        return [(gate_current, 1.0), (branch, 1.0)], None

    def control_nodes(self) -> tuple[str, str]:
        """The gate and its junction node (the control is a current, not their voltage)."""
        return self.nodes[2], self.nodes[3]
