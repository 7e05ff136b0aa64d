"""Circuit elements. Each class knows its terminals and stamps itself into an MLCS."""

from circuitnsds.circuit.elements.base import Element
from circuitnsds.circuit.elements.behavioural import Affine, BehaviouralSource, Integrator, MinMax
from circuitnsds.circuit.elements.controlled import (
    CurrentControlledCurrentSource,
    CurrentControlledVoltageSource,
    VoltageControlledCurrentSource,
    VoltageControlledVoltageSource,
)
from circuitnsds.circuit.elements.coupling import MutualInductance
from circuitnsds.circuit.elements.diode import Diode, DiodeModel
from circuitnsds.circuit.elements.passive import Capacitor, Inductor, Resistor
from circuitnsds.circuit.elements.sources import CurrentSource, VoltageSource
from circuitnsds.circuit.elements.switch import Switch, SwitchModel

__all__ = [
    "Affine", "BehaviouralSource", "Integrator", "MinMax",
    "Capacitor", "CurrentControlledCurrentSource", "CurrentControlledVoltageSource",
    "CurrentSource", "Diode", "DiodeModel", "Element", "Inductor", "MutualInductance",
    "Resistor", "Switch", "SwitchModel", "VoltageControlledCurrentSource",
    "VoltageControlledVoltageSource", "VoltageSource",
]
