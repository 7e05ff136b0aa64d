"""MOSFETs re-evaluated where the circuit works: the analysis' side of the MOSFET observer
(:class:`~circuitnsds.circuit.elements.mosfet_notes.GateDriveObserver`), as
:mod:`~circuitnsds.analyses.refits` is the fitted diodes'.

A MOSFET read as a switch has two values the circuit decides
(:mod:`~circuitnsds.circuit.elements.mosfet_laws`): its on-resistance at the gate drive
the circuit applies, and its charge-equivalent output capacitance over the voltage it
switches. Before a run the capacitance is taken over the circuit's largest source voltage
(:func:`at_supply`: the supply it most often blocks); after a first run, each MOSFET whose
highest conducting ``|Vgs|`` or highest blocking voltage changes its on-resistance or its
capacitance by more than :data:`RESISTANCE_TOLERANCE` / :data:`CAPACITANCE_TOLERANCE` is
re-evaluated there (:func:`refit_mosfets`) and the analysis runs again, once.
``.options mosdrive=V`` fixes the drive instead."""

from __future__ import annotations

import warnings
from dataclasses import replace
from typing import TYPE_CHECKING

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import Capacitor, VoltageSource
from circuitnsds.errors import RunNote
from circuitnsds.lazy import is_loaded_instance

if TYPE_CHECKING:  # imported only by netlists with MOSFETs
    from circuitnsds.circuit.elements.mosfet import Mosfet
    from circuitnsds.circuit.elements.mosfet_notes import GateDriveObserver

RESISTANCE_TOLERANCE = 0.02
"""Relative change of a MOSFET's on-resistance beyond which a run is made again."""
CAPACITANCE_TOLERANCE = 0.05
"""Relative change of a MOSFET's output capacitance beyond which a run is made again."""
SUPPLY_ORIGIN = "the circuit's largest source voltage, before a run"
RUN_ORIGIN = "the highest blocking voltage of a first run"
DRIVE_ORIGIN = "the highest |Vgs| the circuit applied while it conducted, in a first run"


def mosfets(circuit: Circuit) -> list[Mosfet]:
    """The MOSFETs of ``circuit``."""
    return [e for e in circuit.elements
            if is_loaded_instance(e, "circuitnsds.circuit.elements.mosfet", "Mosfet")]


def supply_voltage(circuit: Circuit) -> float:
    """The largest magnitude [V] any independent voltage source of ``circuit`` takes (its DC
    level, the two levels of a ``PULSE``/``EXP``, offset + amplitude of a ``SIN``, the points
    of a ``PWL``); 0 without voltage sources."""
    largest = 0.0
    for element in circuit.elements:
        if not isinstance(element, VoltageSource):
            continue
        stimulus = element.function
        levels = [getattr(stimulus, name) for name in ("level", "initial", "pulsed")
                  if isinstance(getattr(stimulus, name, None), float | int)]
        if hasattr(stimulus, "amplitude"):
            levels.append(abs(stimulus.offset) + abs(stimulus.amplitude))
        levels += list(getattr(stimulus, "values", ()))
        largest = max([largest, *(abs(float(v)) for v in levels)])
    return largest


def _with(circuit: Circuit, changed: dict[str, Mosfet]) -> Circuit:
    """``circuit`` with the MOSFETs ``changed`` (by name) and their ``.coss`` capacitors at the
    charge-equivalent value over their switched voltage."""
    if not changed:
        return circuit
    capacitors = {f"{m.name}.coss": m.output.equivalent(m.switched_voltage)
                  for m in changed.values() if m.output is not None}
    elements = []
    for element in circuit.elements:
        if element.name in changed:
            element = changed[element.name]
        elif isinstance(element, Capacitor) and element.name in capacitors:
            element = replace(element, capacitance=capacitors[element.name])
        elements.append(element)
    return replace(circuit, elements=elements)


def at_supply(circuit: Circuit) -> Circuit:
    """``circuit`` with the output capacitance of each MOSFET not yet placed (read from its
    card, at zero bias) taken over :func:`supply_voltage`; ``circuit`` itself when none."""
    supply = supply_voltage(circuit)
    changed = {m.name: m.at_voltage(supply, SUPPLY_ORIGIN) for m in mosfets(circuit)
               if m.output is not None and m.switched_voltage == 0 and supply > 0}
    return _with(circuit, changed)


def is_mosfet_observer(observer: object) -> bool:
    """Whether ``observer`` is the MOSFETs' (:class:`GateDriveObserver`)."""
    return is_loaded_instance(observer, "circuitnsds.circuit.elements.mosfet_notes", "GateDriveObserver")


def mosfet_observer(observers: list) -> GateDriveObserver | None:
    """The MOSFETs' observer among a run's ``observers`` (``None``: none)."""
    return next((o for o in observers if is_mosfet_observer(o)), None)


def _changed(before: float, after: float, tolerance: float) -> bool:
    return abs(after - before) > tolerance * abs(before)


def refit_mosfets(circuit: Circuit, levels: dict[str, list[float]]) -> Circuit:
    """A copy of ``circuit`` whose MOSFETs are re-evaluated at the ``levels`` a run measured
    (``name -> [highest conducting |Vgs|, highest blocking voltage]`` [V],
    :attr:`GateDriveObserver.levels`) where that changes their on-resistance or output
    capacitance beyond the tolerances, with a note for each; ``circuit`` itself when none."""
    changed: dict[str, Mosfet] = {}
    for element in mosfets(circuit):
        drive, blocking = levels.get(element.name, (0.0, 0.0))
        updated, said = element, []
        if (element.channel is not None and not element.drive_fixed and drive > 0
                and _changed(element.model.on_resistance, element.channel.resistance(drive),
                             RESISTANCE_TOLERANCE)):
            updated = updated.at_drive(drive, DRIVE_ORIGIN)
            said.append(f"Ron = {updated.model.on_resistance:.4g} Ω at |Vgs| = {drive:.4g} V "
                        f"(was {element.model.on_resistance:.4g} Ω at {element.gate_drive:.4g} V)")
        output = element.output
        if (output is not None and blocking > 0
                and _changed(output.equivalent(element.switched_voltage), output.equivalent(blocking),
                             CAPACITANCE_TOLERANCE)):
            updated = updated.at_voltage(blocking, RUN_ORIGIN)
            said.append(f"Coss = {output.equivalent(blocking) * 1e12:.4g} pF over 0..{blocking:.4g} V "
                        f"(was {output.equivalent(element.switched_voltage) * 1e12:.4g} pF over "
                        f"0..{element.switched_voltage:.4g} V)")
        if said:
            changed[element.name] = updated
            warnings.warn(RunNote(f"{circuit.file}: {element.describe()} re-evaluated where the "
                                  f"circuit works, and the run made again: {'; '.join(said)}"),
                          stacklevel=3)
    return _with(circuit, changed)


def refit_mosfets_to(circuit: Circuit, waves) -> Circuit:
    """:func:`refit_mosfets` at the levels the waveforms ``waves`` of a run show (an analysis
    that keeps no observer, pss); ``circuit`` itself when no MOSFET moves."""
    devices = mosfets(circuit)
    if not devices:
        return circuit
    from circuitnsds.circuit.elements.mosfet_notes import waveform_mosfet_levels

    return refit_mosfets(circuit, waveform_mosfet_levels(devices, waves))
