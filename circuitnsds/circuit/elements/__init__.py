"""Circuit elements. Each class knows its terminals and stamps itself into an MLCS.

The controlled sources (:mod:`~circuitnsds.circuit.elements.controlled`) and the behavioural
elements (:mod:`~circuitnsds.circuit.elements.behavioural`) are imported when first named
here, so that a run of a netlist without them does not build their classes.
"""

from typing import TYPE_CHECKING

from circuitnsds.circuit.elements.base import Element
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

if TYPE_CHECKING:
    from circuitnsds.circuit.elements.behavioural import Affine, BehaviouralSource, Integrator, MinMax
    from circuitnsds.circuit.elements.controlled import (
        CurrentControlledCurrentSource,
        CurrentControlledVoltageSource,
        VoltageControlledCurrentSource,
        VoltageControlledVoltageSource,
    )

_LAZY = {
    "CurrentControlledCurrentSource": "controlled", "CurrentControlledVoltageSource": "controlled",
    "VoltageControlledCurrentSource": "controlled", "VoltageControlledVoltageSource": "controlled",
    "Affine": "behavioural", "BehaviouralSource": "behavioural", "Integrator": "behavioural",
    "MinMax": "behavioural",
}
"""The names imported on first use -> their module in this package."""


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
