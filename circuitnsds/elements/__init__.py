"""Circuit elements. Each class knows its terminals and stamps itself into an MLCS."""

from circuitnsds.elements.base import Element
from circuitnsds.elements.controlled import (
    CurrentControlledCurrentSource,
    CurrentControlledVoltageSource,
    VoltageControlledCurrentSource,
    VoltageControlledVoltageSource,
)
from circuitnsds.elements.coupling import MutualInductance
from circuitnsds.elements.diode import Diode, DiodeModel
from circuitnsds.elements.passive import Capacitor, Inductor, Resistor
from circuitnsds.elements.sources import CurrentSource, VoltageSource
from circuitnsds.elements.switch import Switch, SwitchModel

__all__ = [
    "Capacitor", "CurrentControlledCurrentSource", "CurrentControlledVoltageSource",
    "CurrentSource", "Diode", "DiodeModel", "Element", "Inductor", "MutualInductance",
    "Resistor", "Switch", "SwitchModel", "VoltageControlledCurrentSource",
    "VoltageControlledVoltageSource", "VoltageSource",
]
