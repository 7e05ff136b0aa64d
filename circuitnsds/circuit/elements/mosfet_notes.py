"""The MOSFET's run-time observer (:class:`GateDriveObserver`, declared by
:class:`~circuitnsds.circuit.elements.mosfet.Mosfet`): it notes a MOSFET that conducts mostly
at a weak gate drive, where its channel is not the switch of on-resistance Ron its model was
read as, and measures what the analysis re-evaluates a MOSFET at
(:func:`circuitnsds.analyses.refits.refit_mosfets`): the highest gate drive ``|Vgs|`` [V]
while the channel conducts (the drive the circuit applies) and the highest blocking voltage
[V] while it is open (the voltage its output capacitance switches), in :attr:`levels`."""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING

import numpy as np

from circuitnsds.errors import RunNote
from circuitnsds.system.mlcs import MLCS

if TYPE_CHECKING:
    from circuitnsds.circuit.circuit import Circuit
    from circuitnsds.circuit.elements.mosfet import Mosfet

STACKLEVEL = 6
"""Frames from a note's ``warnings.warn`` to the user's call of the analysis."""
WEAK_DRIVE_SHARE = 0.5
"""Share of a MOSFET's conducting time spent with a weak gate drive (an overdrive ``|Vgs| - Vto``
below half of the one its on-resistance was computed at) beyond which the run notes it."""


class GateDriveObserver:
    """Adds up, over a run, each MOSFET's conducting time and the part of it at a weak gate
    drive (:func:`mosfet_drives`); notes those beyond :data:`WEAK_DRIVE_SHARE`."""

    def __init__(self, circuit: Circuit, mosfets: list[Mosfet]):
        self.circuit, self.mosfets = circuit, mosfets
        self.drives: dict[str, list[float]] = {}
        self.levels: dict[str, list[float]] = {}
        """MOSFET name -> ``[highest |Vgs| while conducting, highest blocking voltage while
        open]`` [V] over the run (``0.0``: never in that state)."""
        self.limited: dict[str, list[float]] = {}
        """MOSFET name -> ``[conducting time, time of it carrying more than its channel's
        saturation current]`` [s] over the run (:func:`mosfet_current_limits`)."""

    def observe(self, mlcs: MLCS, trajectory, first: int) -> None:
        mosfet_drives(self.mosfets, mlcs, trajectory, self.drives)
        mosfet_levels(self.mosfets, mlcs, trajectory, self.levels)
        mosfet_current_limits(self.mosfets, mlcs, trajectory, self.limited)

    def report(self) -> None:
        note_weak_gate_drives(self.circuit, self.mosfets, self.drives)
        note_mosfet_values(self.circuit, self.mosfets, self.levels)


def _conducting_steps(mosfets: list[Mosfet], mlcs: MLCS, trajectory):
    """``(element, switch, lengths, closed, control)`` for each of ``mosfets`` that conducts in
    some step of ``trajectory``: the steps' lengths [s], whether each ran closed, and the gate
    control ``|Vgs|`` [V] at each step's end."""
    named = {e.name: e for e in mosfets}
    if not named or trajectory.time.size < 2:
        return
    lengths = np.diff(trajectory.time)
    for j, switch in enumerate(mlcs.switches):
        element = named.get(switch.name)
        if element is None:
            continue
        closed = np.asarray(trajectory.switches[1:, j], dtype=bool)
        if closed.any():
            control = sum(value * trajectory.y[1:, column] for column, value in switch.control)
            yield element, switch, lengths, closed, control


def mosfet_drives(mosfets: list[Mosfet], mlcs: MLCS, trajectory,
                  drives: dict[str, list[float]]) -> dict[str, list[float]]:
    """MOSFET name -> ``[conducting time, time of it with a weak gate drive, smallest |Vgs|]``
    ([s], [s], [V]) of each of ``mosfets`` over the steps of ``trajectory``, added to ``drives``
    (of earlier parts of the same run), which is updated and returned. A step counts with the
    state it ran in and the gate drive at its end; "weak": an overdrive below half of
    ``gate_drive - Vto``."""
    for element, switch, lengths, closed, control in _conducting_steps(mosfets, mlcs, trajectory):
        threshold = element.model.threshold
        weak = closed & (control < threshold + 0.5 * (element.gate_drive - threshold))
        total = drives.setdefault(switch.name, [0.0, 0.0, math.inf])
        total[0] += float(lengths[closed].sum())
        total[1] += float(lengths[weak].sum())
        total[2] = min(total[2], float(np.min(control[closed])))
    return drives


CURRENT_LIMIT_MARGIN = 1.5
"""A conducting switch's current above this many times its channel's saturation current at the
gate drive of the step counts as beyond what the device can carry."""


def mosfet_current_limits(mosfets: list[Mosfet], mlcs: MLCS, trajectory,
                          limited: dict[str, list[float]]) -> dict[str, list[float]]:
    """MOSFET name -> ``[conducting time, time of it with the switch's current above
    :data:`CURRENT_LIMIT_MARGIN` times the channel's saturation current at the step's gate
    drive]`` [s] of each of ``mosfets`` with a channel law, over the steps of ``trajectory``,
    added to ``limited`` (earlier parts of the same run), which is updated and returned. A
    switch fully driven but carrying more than its channel can (a VDMOS at 5 V of gate with a
    3.6 V threshold, asked for 8 A where it saturates near 1.3 A) is a current source, not
    the resistor Ron."""
    with_law = [e for e in mosfets if e.channel is not None]
    for element, switch, lengths, closed, control in _conducting_steps(with_law, mlcs, trajectory):
        current = np.abs(trajectory.y[1:, switch.row])
        saturation = np.array([element.channel.saturation_current(abs(float(v))) for v in control[closed]])
        beyond = np.zeros_like(closed)
        beyond[closed] = current[closed] > CURRENT_LIMIT_MARGIN * saturation
        total = limited.setdefault(switch.name, [0.0, 0.0])
        total[0] += float(lengths[closed].sum())
        total[1] += float(lengths[beyond].sum())
    return limited


def current_limited_mosfets(mosfets: list[Mosfet], limited: dict[str, list[float]],
                            share: float) -> list[str]:
    """The names of ``mosfets`` that carry more than their saturation current for more than
    ``share`` of their conducting time (``limited``: :func:`mosfet_current_limits`)."""
    return [e.name for e in mosfets if (lambda t: t[0] > 0 and t[1] > share * t[0])(
        limited.get(e.name, (0.0, 0.0)))]


def mosfet_levels(mosfets: list[Mosfet], mlcs: MLCS, trajectory,
                  levels: dict[str, list[float]]) -> dict[str, list[float]]:
    """MOSFET name -> ``[highest |Vgs| while conducting, highest blocking voltage while
    open]`` [V] of each of ``mosfets`` over the rows of ``trajectory``, merged into ``levels``
    (of earlier parts of the same run), which is updated and returned. The blocking voltage
    is ``polarity·(v(d) − v(s))``; a row counts with the state the step into it ran in."""
    named = {e.name: e for e in mosfets}
    if not named or trajectory.time.size < 2:
        return levels
    column = {name: k for k, name in enumerate(mlcs.nodes)}

    def voltage(node: str) -> np.ndarray | float:
        return trajectory.y[1:, column[node]] if node in column else 0.0

    for j, switch in enumerate(mlcs.switches):
        element = named.get(switch.name)
        if element is None:
            continue
        closed = np.asarray(trajectory.switches[1:, j], dtype=bool)
        control = sum(value * trajectory.y[1:, k] for k, value in switch.control)
        blocking = element.polarity * (voltage(element.nodes[0]) - voltage(element.nodes[1]))
        blocking = np.broadcast_to(blocking, closed.shape)
        highest = levels.setdefault(switch.name, [0.0, 0.0])
        if closed.any():
            highest[0] = max(highest[0], float(np.max(control[closed])))
        if not closed.all():
            highest[1] = max(highest[1], float(np.max(blocking[~closed])))
    return levels


def waveform_mosfet_levels(mosfets: list[Mosfet], waves) -> dict[str, list[float]]:
    """:func:`mosfet_levels` read from the waveforms ``waves`` (node voltages ``v(name)``),
    the channel taken as conducting where its control ``polarity·(v(g) − v(s))`` exceeds its
    threshold; MOSFETs whose nodes ``waves`` does not hold are left out."""
    levels: dict[str, list[float]] = {}
    for element in mosfets:
        try:
            drain, source, gate = (np.asarray(waves[f"v({n})"]) if n != "0" else 0.0
                                   for n in element.nodes[:3])
        except KeyError:  # a run that kept only some signals
            continue
        control = np.broadcast_to(element.polarity * (gate - source), np.shape(waves.time))
        blocking = np.broadcast_to(element.polarity * (drain - source), control.shape)
        closed = control > element.model.threshold
        levels[element.name] = [float(control[closed].max()) if closed.any() else 0.0,
                                max(0.0, float(blocking[~closed].max())) if not closed.all() else 0.0]
    return levels


def weak_drive_mosfets(mosfets: list[Mosfet], drives: dict[str, list[float]],
                       share: float = WEAK_DRIVE_SHARE) -> list[str]:
    """The names of ``mosfets`` that spend more than ``share`` of their conducting time with
    a weak gate drive (``drives``: :func:`mosfet_drives`)."""
    found = []
    for element in mosfets:
        conducting, weak, _ = drives.get(element.name, (0.0, 0.0, 0.0))
        if conducting > 0 and weak > share * conducting:
            found.append(element.name)
    return found


def note_weak_gate_drives(circuit: Circuit, mosfets: list[Mosfet],
                          drives: dict[str, list[float]]) -> None:
    """A :class:`RunNote` for each of ``mosfets`` that spends more than :data:`WEAK_DRIVE_SHARE`
    of its conducting time with a weak gate drive (``drives``: :func:`mosfet_drives`): read as
    a switch whose Ron was computed at ``gate_drive``, it is then not what the circuit does."""
    weak_ones = weak_drive_mosfets(mosfets, drives)
    for element in mosfets:
        if element.name in weak_ones:
            conducting, weak, lowest = drives[element.name]
            threshold = element.model.threshold
            warnings.warn(RunNote(
                f"{circuit.file}: {element.describe()} spends {100 * weak / conducting:.0f} % of "
                f"its conducting time at a weak gate drive (|Vgs| down to {lowest:.3g} V, "
                f"threshold {threshold:g} V), while its Ron is computed at |Vgs| = "
                f"{element.gate_drive:g} V: there its channel resistance is several times Ron and "
                "the MOSFET is not a switch; set .options mosdrive to the gate drive it works "
                "at, or drive its gate to that level"), stacklevel=STACKLEVEL)


MOSFETS_NAMED = 4
"""MOSFETs the run's summary note names one by one (the rest are counted)."""


def note_mosfet_values(circuit: Circuit, mosfets: list[Mosfet],
                       levels: dict[str, list[float]] | None = None) -> None:
    """One :class:`RunNote` saying, for the run's MOSFETs, the on-resistance and the output
    capacitance it used and where their gate drive and switched voltage came from; with the
    run's ``levels`` (:func:`mosfet_levels`), the drive it applied when that is another."""
    said = []
    for element in mosfets[:MOSFETS_NAMED]:
        text = f"{element.name}: Ron {element.model.on_resistance:.4g} Ω"
        if element.channel is not None:
            text += f" at |Vgs| = {element.gate_drive:.4g} V ({element.drive_origin})"
            applied = (levels or {}).get(element.name, (0.0, 0.0))[0]
            if applied > 0 and abs(applied - element.gate_drive) > 1e-3 * element.gate_drive:
                text += (f"; the run applied |Vgs| up to {applied:.4g} V, where it is "
                         f"{element.channel.resistance(applied):.4g} Ω")
        if element.output is not None:
            value = element.output.equivalent(element.switched_voltage)
            text += (f", Coss {value * 1e12:.4g} pF charge-equivalent over "
                     f"0..{element.switched_voltage:.4g} V ({element.voltage_origin})")
        said.append(text)
    if not said:
        return
    rest = len(mosfets) - MOSFETS_NAMED
    more = f"; and {rest} more (circuitnsds info)" if rest > 0 else ""
    warnings.warn(RunNote(f"{circuit.file}: MOSFETs read as switches with {'; '.join(said)}{more}"),
                  stacklevel=STACKLEVEL)
