"""Circuit elements. Each class knows its terminals and stamps itself into an MLCS."""

from circuitnsds.elements.base import Element
from circuitnsds.elements.diode import Diode, DiodeModel
from circuitnsds.elements.passive import Capacitor, Inductor, Resistor
from circuitnsds.elements.sources import CurrentSource, VoltageSource

__all__ = [
    "Capacitor", "CurrentSource", "Diode", "DiodeModel", "Element", "Inductor", "Resistor",
    "VoltageSource",
]
