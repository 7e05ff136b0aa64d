"""The checks ask an element what it declares (``junction``, ``topology``,
``owns_branch_current``, ``independent_source``, ``value_errors``, ``conductances``), not
which class it is: a new device with the same declarations gets the same checks."""

import warnings
from dataclasses import dataclass
from typing import ClassVar

import pytest

from circuitnsds.checks.rules import check_circuit, conductance_scales
from circuitnsds.checks.wellposed import blocked_currents
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import (
    Capacitor,
    CurrentSource,
    Diode,
    DiodeModel,
    Element,
    Inductor,
    Resistor,
    Switch,
    SwitchModel,
    VoltageSource,
)
from circuitnsds.circuit.elements.mosfet import Mosfet
from circuitnsds.errors import CircuitError, CircuitWarning
from circuitnsds.system.stimuli import Dc


@dataclass(frozen=True)
class OtherJunction(Element):
    """A device written outside the package: an ideal junction that is no subclass of ours."""

    model: object = DiodeModel("dx")
    area: float = 1.0
    junction: ClassVar[str | None] = "diode"


def _circuit(*elements: Element) -> Circuit:
    circuit = Circuit()
    for element in elements:
        circuit.add(element)
    return circuit


def _warnings(circuit: Circuit) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_circuit(circuit)
    return [str(w.message) for w in caught if issubclass(w.category, CircuitWarning)]


def test_a_declared_diode_junction_gets_the_parallel_diode_warning():
    circuit = _circuit(VoltageSource("v1", ("a", "0"), function=Dc(1.0)),
                       Resistor("r1", ("a", "b"), resistance=1.0),
                       OtherJunction("d1", ("b", "0")), OtherJunction("d2", ("b", "0")))
    assert any("d1, d2 are ideal (Ron = 0) and in parallel" in m for m in _warnings(circuit))


def test_a_declared_diode_junction_blocks_a_current_source():
    """``I1 0 a 1m`` into ``a`` with only a reversed junction to leave by: no step solution."""
    circuit = _circuit(CurrentSource("i1", ("0", "a"), function=Dc(1e-3)), OtherJunction("d1", ("0", "a")))
    found = blocked_currents(circuit, [0.0, 1.0])
    assert len(found) == 1 and "i1" in found[0][0] and "d1" in found[0][0]


def test_conductances_are_the_ones_each_element_declares():
    elements = [Resistor("r1", ("a", "0"), resistance=2.0), Capacitor("c1", ("a", "0"), capacitance=1e-6),
                Inductor("l1", ("a", "0"), inductance=1e-3), Capacitor("c0", ("a", "0"), capacitance=0.0),
                Diode("d1", ("a", "0"), model=DiodeModel("d", on_resistance=0.5, off_resistance=1e6)),
                Switch("s1", ("a", "0", "c", "0"),
                       model=SwitchModel("s", on_resistance=0.0, off_resistance=1e9))]
    found = {(e.name, what.split(" =")[0]): siemens
             for e, what, siemens in conductance_scales(elements, 1e-6)}
    assert found == pytest.approx({("r1", "R"): 0.5, ("c1", "C"): 1.0, ("l1", "L"): 1e-3,
                                   ("d1", "Roff"): 1e-6, ("d1", "Ron"): 2.0, ("s1", "Roff"): 1e-9})


@pytest.mark.parametrize(("element", "message"), [
    (Resistor("r1", ("a", "0"), resistance=0.0), "r1: resistance must be positive, got 0"),
    (Capacitor("c1", ("a", "0"), capacitance=-1.0), "c1: capacitance must not be negative, got -1 F"),
    (Inductor("l1", ("a", "0"), inductance=-1.0), "l1: inductance must not be negative, got -1 H"),
    (Resistor("r1", ("a",), resistance=-1.0), "r1: needs two terminals, has 1"),
])
def test_value_errors_name_the_element(element, message):
    with pytest.raises(CircuitError, match=message):
        check_circuit(_circuit(VoltageSource("v1", ("a", "0")), element))


def test_only_elements_owning_a_branch_current_may_control_w_f_h():
    """A W switch may sense a V source, not a MOSFET's channel (nor a resistor)."""
    for owner, fine in [(VoltageSource("vs", ("a", "0")), True),
                        (Resistor("vs", ("a", "0"), resistance=1.0), False),
                        (Mosfet("vs", ("a", "0", "g"), model=SwitchModel("m")), False)]:
        circuit = _circuit(owner, Resistor("r1", ("a", "0"), resistance=1.0), VoltageSource("vg", ("g", "0")),
                           Switch("w1", ("a", "0"), model=SwitchModel("w", current_controlled=True),
                                  control="vs"))
        if fine:
            _warnings(circuit)
        else:
            with pytest.raises(CircuitError, match="controlling source 'vs' has no current unknown"):
                check_circuit(circuit)


def test_the_elements_f_h_and_w_may_sense_are_v_l_e_h_and_switches():
    from circuitnsds.circuit import elements

    owners = {name for name in elements.__all__
              if isinstance(getattr(elements, name), type) and issubclass(getattr(elements, name), Element)
              and getattr(elements, name)("x", ("a", "0")).owns_branch_current}
    assert owners == {"VoltageSource", "Inductor", "Switch", "VoltageControlledVoltageSource",
                      "CurrentControlledVoltageSource"}
    assert not Mosfet("m1", ("d", "s", "g")).owns_branch_current
