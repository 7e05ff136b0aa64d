"""Resistors named with a model (``R1 a b RMOD``): ngspice's resistance rules.

ngspice (restemp.c): without an instance value, ``RSH·(L - SHORT)/(W - NARROW)`` when
``L·W·RSH > 0`` (``L`` defaults to the model's ``DEFL`` = 10 um, ``W`` to ``DEFW`` = 10 um),
else the model's ``R`` (``RES``).
"""

import pytest

import circuitnsds
from tests.conftest import circuit_from


def resistance(instance: str, model: str) -> float:
    circuit = circuit_from(f"V1 a 0 1\n{instance}\n.model rm {model}")
    assert circuit.element("r1").model == "rm"
    return circuit.element("r1").resistance


@pytest.mark.parametrize(
    ("instance", "model", "expected"),
    [
        ("R1 a 0 rm", "R(R=2k)", 2e3),                       # the model's default value
        ("R1 a 0 rm", "RES(RES=5)", 5.0),                    # RES synonyms
        ("R1 a 0 rm 3k", "R(R=2k)", 3e3),                    # the instance value wins
        ("R1 a 0 3k rm", "R(R=2k)", 3e3),                    # in either order
        ("R1 a 0 rm r=3k", "R(R=2k)", 3e3),
        ("R1 a 0 rm l=10u w=2u", "R(RSH=100)", 500.0),       # 100 ohm/sq x 5 squares
        ("R1 a 0 rm l=30u", "R(RSH=100)", 300.0),            # W = DEFW = 10 um
        ("R1 a 0 rm l=30u", "R(RSH=100 DEFW=5u)", 600.0),
        ("R1 a 0 rm l=10u w=2u", "R(RSH=100 NARROW=0.5u SHORT=1u)", 600.0),  # 9/1.5 squares
        ("R1 a 0 rm 1k m=4", "R(R=2k)", 250.0),              # m parallel copies
        ("R1 a 0 rm", "R(R=2k TC1=1m TC2=1u TNOM=27)", 2e3),  # temperature terms ignored
    ],
)
def test_model_resistance_rules(instance, model, expected):
    assert resistance(instance, model) == pytest.approx(expected, rel=1e-12)


def test_sheet_resistance_takes_precedence_over_the_model_value():
    # ngspice: L·W·RSH > 0 -> geometry, whatever R says
    assert resistance("R1 a 0 rm l=10u w=2u", "R(R=2k RSH=100)") == pytest.approx(500.0, rel=1e-12)


def test_length_defaults_to_the_model_defl():
    # ngspice: L = DEFL (10 um by default), W = DEFW (10 um): one square
    assert resistance("R1 a 0 rm", "R(RSH=100)") == pytest.approx(100.0, rel=1e-12)
    assert resistance("R1 a 0 rm", "R(RSH=100 L=40u)") == pytest.approx(400.0, rel=1e-12)


def test_model_resistor_in_a_circuit():
    op = circuit_from("V1 a 0 10\nR1 a b rm\nR2 b 0 rm 3k\n.model rm R(R=2k)").operating_point()
    assert op["v(b)"] == pytest.approx(10 * 3 / 5, rel=1e-12)


@pytest.mark.parametrize(
    ("instance", "model", "words"),
    [
        ("R1 a 0 rm", "D", ["diode"]),
        ("R1 a 0 rm", "R(TC1=1m)", ["no resistance"]),
        ("R1 a 0 rm", "R(R=-2k)", ["positive"]),
        ("R1 a 0 rm l=1u w=2u", "R(RSH=100 SHORT=2u)", ["positive"]),
    ],
)
def test_model_resistor_errors_name_the_line(instance, model, words):
    with pytest.raises(circuitnsds.NetlistError) as info:
        circuit_from(f"V1 a 0 1\n{instance}\n.model rm {model}")
    message = str(info.value).lower()
    assert "<text>:3:" in message
    for word in words:
        assert word in message
