"""A device's losses from a run's waveforms and its datasheet (:class:`~.plecs.DeviceData`).

Ideal switches and diodes commutate in zero time, so their switching energy is the
datasheet's, charged at each commutation:

* a switch (``S``, ``W``, a MOSFET's channel) at each of its events (``waves.events``, and
  a change of state in the first step, which the engine does not list as an event):
  turn-on ``E_on(i, v, Tj)`` with the current it takes on (the first sample after the event)
  and the voltage it blocked (the last sample at or before it); turn-off ``E_off`` with the
  current it carried (last sample at or before) and the voltage it blocks (first after);
* a diode at each change of its mode (its forward pair's current ``i − v/Roff`` becoming
  positive, or zero again): recovery ``E_rr`` = the file's ``<TurnOffLoss>`` with the
  forward current before and the reverse voltage after, and ``<TurnOnLoss>`` if the file
  gives one. Vendors write a diode's voltages negative; against a table whose voltage axis is
  positive the magnitude is used.

An event whose current or voltage has the wrong sign for a table that starts at 0 (a switch
turned on at negative current, as a synchronous rectifier is) costs nothing: no current was
commutated in the device's direction. Conduction is ``v_table(|i|, Tj)·|i|`` while the device
conducts where the file has a ``<ConductionLoss>``, else the circuit's own ``v·i``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from circuitnsds.output.measure import element_voltage, mean
from circuitnsds.output.waveforms import Waveforms
from circuitnsds.thermal.plecs import DeviceData
from circuitnsds.thermal.tables import EnergyTable

KINDS = ("turn_on", "turn_off", "recovery")
"""The kinds of switching event, as the loss table's columns name them."""
DIODE_ON = 1e-9
"""A diode conducts when its forward current exceeds this fraction of its largest one (and
:data:`DIODE_FLOOR`)."""
DIODE_FLOOR = 1e-12
"""[A]: below this a diode's forward current is round-off (SPICE's gmin current at 1 V)."""

Temperature = Callable[[np.ndarray], np.ndarray]
"""Junction temperature [°C] at given instants [s]."""


@dataclass
class DeviceLosses:
    """One device's losses over a run.

    Attributes:
        element: the device's name.
        time: the run's instants [s].
        conduction_power: conduction power [W] at each instant.
        electrical_power: ``v·i`` [W] at each instant (what the circuit itself dissipates).
        events: ``(time [s], kind, energy [J])`` of each commutation, ``kind`` in :data:`KINDS`.
    """

    element: str
    time: np.ndarray
    conduction_power: np.ndarray
    electrical_power: np.ndarray
    events: list[tuple[float, str, float]] = field(default_factory=list)

    def average(self, t0: float, t1: float) -> dict[str, float]:
        """Average powers [W] over ``[t0, t1)``: ``conduction``, each of :data:`KINDS`,
        ``total`` and ``electrical``."""
        span = t1 - t0
        powers = {"conduction": mean(self.time, self.conduction_power, t0, t1)}
        for kind in KINDS:
            powers[kind] = sum(energy for time, which, energy in self.events
                               if which == kind and t0 <= time < t1) / span
        powers["total"] = sum(powers.values())
        powers["electrical"] = mean(self.time, self.electrical_power, t0, t1)
        return powers

    def energy(self) -> np.ndarray:
        """Energy dissipated from the start up to each instant [J] (events included at
        their instant)."""
        steps = 0.5 * (self.conduction_power[1:] + self.conduction_power[:-1]) * np.diff(self.time)
        energy = np.concatenate([[0.0], np.cumsum(steps)])
        for time, _, joules in self.events:
            energy[np.searchsorted(self.time, time, side="right"):] += joules
        return energy


def _switching(table: EnergyTable | None, current: float, voltage: float, temperature: float,
               diode: bool) -> float:
    """One event's energy [J] (0 without a table, or against the table's quadrant)."""
    if table is None:
        return 0.0
    if diode:  # the blocking voltage with the sign of the table's axis
        voltage = -abs(voltage) if table.voltage[-1] <= 0 else abs(voltage)
    if (current <= 0 and table.current[0] >= 0) or (voltage <= 0 and table.voltage[0] >= 0):
        return 0.0
    return table(current, voltage, temperature)


def device_losses(waves: Waveforms, element, data: DeviceData,
                  temperature: Temperature) -> DeviceLosses:
    """The losses of ``element`` (a switch, MOSFET or diode) over the whole run.

    Args:
        waves: the full results (the element's current and node voltages, the events).
        element: the device (its ``model`` says whether it is a diode).
        data: its thermal description.
        temperature: its junction temperature [°C] at given instants (the tables' ``Tj``).
    """
    time = np.asarray(waves.time, dtype=float)
    voltage = element_voltage(waves, element)
    current = np.asarray(waves[f"i({element.name})"], dtype=float)
    diode = hasattr(element.model, "forward_drop")
    tj = np.broadcast_to(np.asarray(temperature(time), dtype=float), time.shape)
    events: list[tuple[float, str, float]] = []
    if diode:
        leak = getattr(element, "area", 1.0) / element.model.off_resistance
        forward = current - voltage * leak
        conducting = forward > max(DIODE_ON * float(np.abs(forward).max()), DIODE_FLOOR)
        changes = np.flatnonzero(conducting[1:] != conducting[:-1]) + 1
        for k in changes:
            if conducting[k]:  # turned on: current after, voltage before
                joules = _switching(data.turn_on, forward[k], voltage[k - 1], tj[k - 1], True)
                events.append((time[k - 1], "turn_on", joules))
            else:
                joules = _switching(data.turn_off, forward[k - 1], voltage[k], tj[k - 1], True)
                events.append((time[k - 1], "recovery", joules))
        magnitude = np.where(conducting, forward, 0.0)
    else:
        model = element.model
        conducting = (np.abs(voltage - model.on_resistance * current)
                      <= np.abs(voltage - model.off_resistance * current))
        switchings = [(float(t), closed) for t, name, closed in waves.events if name == element.name]
        if time.size > 1 and conducting[0] != conducting[1] and not any(
                time[0] <= t <= time[1] for t, _ in switchings):
            # the first step's switching is the start's, which the engine does not list (a
            # gate stepping at t = 0, the period's first commutation in a periodic steady state)
            switchings.insert(0, (float(time[0]), bool(conducting[1])))
        for event_time, closed in switchings:
            after = min(int(np.searchsorted(time, event_time, side="right")), time.size - 1)
            before = max(after - 1, 0)
            if closed:
                joules = _switching(data.turn_on, current[after], voltage[before], tj[before], False)
            else:
                joules = _switching(data.turn_off, current[before], voltage[after], tj[before], False)
            events.append((event_time, "turn_on" if closed else "turn_off", joules))
        magnitude = np.where(conducting, np.abs(current), 0.0)
    electrical = voltage * current
    if data.conduction is None:
        conduction = electrical.copy()
    else:
        conduction = np.where(conducting, data.conduction(magnitude, tj) * magnitude, 0.0)
    return DeviceLosses(element.name, time, conduction, electrical, events)
