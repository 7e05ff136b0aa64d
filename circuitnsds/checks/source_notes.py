"""Notes on source parameters that mean something other than what they look like."""

from __future__ import annotations

import warnings

from circuitnsds.errors import RunNote
from circuitnsds.system.stimuli import Pulse


def note_zero_pulse_widths(circuit, stop: float) -> None:
    """A :class:`RunNote` for each ``PULSE`` written with ``PW = 0``: ngspice (and circuitnsds,
    to mean the same) reads it as ``PW = TSTOP``, so the source stays at ``V2`` from the end of
    its rise to the end of its period (never falling, when ``TR + PW`` exceeds it): a
    "triangle" carrier ``PULSE(0 1 0 5u 5u 0 10u)`` became a sawtooth with a flat top, with
    no word."""
    for element in circuit.elements:
        function = getattr(element, "function", None)
        if not isinstance(function, Pulse) or function.width is None or function.width != 0:
            continue
        where = f"{element.location}: " if getattr(element, "location", None) else f"{circuit.file}: "
        warnings.warn(RunNote(
            f"{where}{element.name}: PULSE with PW = 0 is read as PW = TSTOP ({stop:g} s), as "
            "ngspice reads it: it stays at V2 from the end of each rise to the end of its period "
            "(no fall: a triangle becomes a sawtooth with a flat top); for a triangle give a tiny "
            "width (PW = 1p)"), stacklevel=3)
