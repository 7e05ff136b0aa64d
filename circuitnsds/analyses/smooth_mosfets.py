"""MOSFETs that are no switch, made the smooth device and the run made again (issue 33).

An ``M`` line is the ideal switch unless its line or its model says ``smooth=1``
(:data:`circuitnsds.frontend.cards.smooth_devices.SMOOTH_FLAG`). The automatic case: a run
of the switch shows that the device is not one, and the analysis runs again with it as
ngspice's smooth VDMOS (through the Newton stepper), saying so in a note
that names the elements:

* the switch chatters (the engine's :data:`~circuitnsds.errors.SimulationError.SWITCH_CHATTERS`):
  its own state moves its gate back across the threshold, the signature of a device held in
  saturation (an amplifier, a linear regulator, a source follower);
* in the run returned (its Ron taken at the drive the circuit applies), it spends more than
  :data:`SMOOTH_SHARE` of its conducting time between threshold and half that drive
  (:func:`~circuitnsds.circuit.elements.mosfet_notes.weak_drive_mosfets`), where its channel
  is a current source, not the resistor Ron. A switch driven hard spends only its gate's
  edges there (a few % of the time); a share this large is a device held in its active
  region, or a gate that settles towards a threshold of 0 V (a VDMOS without VTO behind
  Rg·Ciss), which the switch reads as conducting for ever.

When one MOSFET is found no switch, every MOSFET of the circuit is made smooth, or none is
(when one of them cannot be: a level 1–3 card, ``m`` > 1): a mix of switches and smooth
devices chosen by a share is not what ngspice runs, and is not right either (ngspice's
inverter example: made smooth alone, the p-channel device leaves the n-channel switch
conducting for ever behind its gate's Rg·Ciss tail, 66 % RMS off ngspice; both smooth,
0.08 %).

``.options mosfet=switch`` keeps every switch as read (the note of a weak gate drive is made
then, as before).
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from typing import TYPE_CHECKING

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements.diode import DEFAULT_OFF_RESISTANCE
from circuitnsds.errors import NetlistError, RunNote

if TYPE_CHECKING:
    from circuitnsds.circuit.elements.mosfet import Mosfet

SMOOTH_SHARE = 0.25
"""Share of a MOSFET's conducting time at a weak gate drive beyond which a run makes it the
smooth device (the note of a weak drive, :data:`~circuitnsds.circuit.elements.mosfet_notes.WEAK_DRIVE_SHARE`,
comes at 0.5 where the switch is kept)."""
KEEP_SWITCHES = ("mosfet", "switch")
"""``.options mosfet=switch``: no automatic smooth device."""


def automatic(circuit: Circuit) -> bool:
    """Whether ``circuit`` lets a run make its MOSFETs smooth (not ``.options mosfet=switch``)."""
    key, value = KEEP_SWITCHES
    return str(circuit.options.get(key, "")).lower() != value


def _terminals(circuit: Circuit, element: Mosfet) -> tuple[str, str, str]:
    """Drain, external gate and source of a MOSFET read as a switch (its gate resistor's
    outer node when it has one)."""
    drain, source, gate = element.nodes[:3]
    resistor = f"{element.name}.rg"
    if resistor in element.parts:
        gate = circuit.element(resistor).nodes[0]
    return drain, gate, source


def as_smooth(circuit: Circuit, names: list[str]) -> tuple[Circuit, list[str]]:
    """A copy of ``circuit`` whose MOSFETs ``names`` (read as switches) are ngspice's smooth
    VDMOS of the same card, with the names made smooth; ``(circuit, [])`` unless every one
    of them can be: a VDMOS card of one device (``m=1``) the smooth VDMOS takes (a level
    1–3 switch keeps no channel geometry to rebuild the smooth device from)."""
    from circuitnsds.frontend.cards.reader import StatementReader
    from circuitnsds.frontend.cards.smooth_devices import smooth_mosfet
    from circuitnsds.netlist.parser import Statement

    off_resistance = 1.0 / float(circuit.options.get("gmin", 1.0 / DEFAULT_OFF_RESISTANCE))
    replaced: dict[str, object] = {}
    dropped: set[str] = set()
    for name in names:
        element = circuit.element(name)
        if element.device != "vdmos" or element.channel is None or element.channel.count != 1:
            return circuit, []
        drain, gate, source = _terminals(circuit, element)
        tokens = (name, drain, gate, source, element.model.name)
        statement = Statement(tokens, element.location, " ".join(tokens))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                replaced[name] = smooth_mosfet(StatementReader(statement), circuit.models, off_resistance)
        except NetlistError:
            return circuit, []
        dropped.update(element.parts)
    if not replaced:
        return circuit, []
    smooth = replace(circuit, elements=[], nodes=[])
    for element in circuit.elements:
        if element.name in dropped:
            continue
        smooth.add(replaced.get(element.name, element))
    return smooth, list(replaced)


def note(circuit: Circuit, names: list[str], why: str) -> None:
    """The note that the run is made again with ``names`` smooth, and ``why``."""
    key, value = KEEP_SWITCHES
    warnings.warn(RunNote(
        f"{circuit.file}: MOSFETs that are no switch {why}: the run made again with "
        f"{', '.join(names)} as ngspice's smooth MOSFET of the same card "
        f"(Newton stepper); write smooth=1 on the model to choose that from the start, or "
        f".options {key}={value} to keep the switch"), stacklevel=4)


def failed(circuit: Circuit, error: Exception, then: str) -> None:
    """The note that the smooth rerun failed (``error``), and what is returned ``then``."""
    warnings.warn(RunNote(f"{circuit.file}: the run with smooth MOSFETs failed ({error}); {then}"),
                  stacklevel=4)


__all__ = ["KEEP_SWITCHES", "SMOOTH_SHARE", "as_smooth", "automatic", "failed", "note"]
