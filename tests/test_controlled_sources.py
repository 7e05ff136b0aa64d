"""Linear controlled sources E, G, F, H against hand-derived circuit solutions.

SPICE sign conventions (docs/netlist.md):

* ``E n+ n- nc+ nc- A``: ``v(n+) - v(n-) = A·(v(nc+) - v(nc-))``; ``i(e1)`` flows into
  ``n+`` from the outside and through the source to ``n-`` (like ``i(v1)``), so a source
  that *delivers* power has a negative current.
* ``G n+ n- nc+ nc- gm``: the current ``gm·v(nc+, nc-)`` flows from ``n+`` through the
  source to ``n-`` (it is pushed *into* node ``n-``).
* ``F n+ n- VNAME B``: the current ``B·i(VNAME)`` flows from ``n+`` through the source to ``n-``.
* ``H n+ n- VNAME R``: ``v(n+) - v(n-) = R·i(VNAME)``.
"""

import numpy as np
import pytest

import circuitnsds
from tests.conftest import circuit_from

# V1 = 2 V.  Ra (200) -> node a -> Vs (0 V sensor, a -> s) -> Rs (300) -> ground, so
# i(vs) = 2 / 500 = 4 mA, flowing from n+ (a) through Vs to n- (s): positive.
SIGN_CIRCUIT = """V1 in 0 2
R1 in 0 1k
E1 out 0 in 0 3
RL out 0 1k
E2 0 neg in 0 2
RN neg 0 1k
G1 0 g in 0 2m
RG g 0 500
G2 g2 0 in 0 2m
RG2 g2 0 500
Ra in a 200
Vs a s 0
Rs s 0 300
F1 0 f Vs 4
RF f 0 100
F2 f2 0 Vs 4
RF2 f2 0 100
H1 h 0 Vs 50
RH h 0 1k
"""


def sign_expectations() -> dict[str, float]:
    vin, i_sense = 2.0, 2.0 / 500
    return {
        "v(out)": 3 * vin,               # E: output = gain x control
        "i(e1)": -3 * vin / 1e3,         # delivers 6 mA into RL: the current *into* n+ is -6 mA
        "v(neg)": -2 * vin,              # E2's n+ is ground: v(0) - v(neg) = 2 x 2 V
        "i(e2)": -(2 * vin) / 1e3,       # RN carries 4 mA from ground to neg, i.e. out of E2's n-
        "v(g)": 2e-3 * vin * 500,        # G1: 4 mA from ground through G1 into g, then RG to ground
        "i(g1)": 2e-3 * vin,
        "v(g2)": -2e-3 * vin * 500,      # G2: 4 mA pulled out of g2 to ground
        "i(g2)": 2e-3 * vin,
        "i(vs)": i_sense,
        "v(a)": 300 * i_sense,
        "v(f)": 4 * i_sense * 100,       # F1: 16 mA from ground into f
        "i(f1)": 4 * i_sense,
        "v(f2)": -4 * i_sense * 100,     # F2: 16 mA out of f2 to ground
        "v(h)": 50 * i_sense,            # H1: 50 ohm x 4 mA
        "i(h1)": -50 * i_sense / 1e3,    # delivers 0.2 mA into RH
        "i(v1)": -(vin / 1e3 + i_sense),  # V1 feeds R1 and the Ra branch; control nodes draw nothing
    }


def test_operating_point_signs_of_e_g_f_h():
    op = circuit_from(SIGN_CIRCUIT).operating_point()
    for name, expected in sign_expectations().items():
        assert op[name] == pytest.approx(expected, rel=1e-9, abs=1e-15), name


def test_transient_of_a_dc_circuit_holds_the_operating_point():
    waves = circuit_from(SIGN_CIRCUIT).transient(1e-6, 1e-5)
    for name, expected in sign_expectations().items():
        np.testing.assert_allclose(waves[name], expected, rtol=1e-9, atol=1e-15, err_msg=name)


def test_gain_chain_e_e_g_h_f():
    # in = 0.5 V; E1: a = 3·in; E2 (inverting through its control nodes): b = 2·(0 - a);
    # G1 pushes gm·b into c, which returns to ground through Rc and the 0 V sensor Vsc:
    # v(c) = 2k·gm·b and i(vsc) = gm·b; H1: e = 500·i(vsc); F1 pushes 2·i(vsc) from
    # ground into f: v(f) = 2·i(vsc)·1k.
    vin, gm = 0.5, 1e-3
    body = """V1 in 0 0.5
E1 a 0 in 0 3
E2 b 0 0 a 2
G1 0 c b 0 1m
Rc c d 2k
Vsc d 0 0
H1 e 0 Vsc 500
Re e 0 1k
F1 0 f Vsc 2
Rf f 0 1k
"""
    op = circuit_from(body).operating_point()
    a = 3 * vin
    b = -2 * a
    i_sense = gm * b
    assert op["v(a)"] == pytest.approx(a, rel=1e-12)
    assert op["v(b)"] == pytest.approx(b, rel=1e-12)
    assert op["v(c)"] == pytest.approx(2e3 * i_sense, rel=1e-9)
    assert op["i(vsc)"] == pytest.approx(i_sense, rel=1e-9)
    assert op["v(e)"] == pytest.approx(500 * i_sense, rel=1e-9)
    assert op["v(e)"] == pytest.approx(-3 * vin, rel=1e-9)  # overall: 500·gm·(-2)·3
    assert op["v(f)"] == pytest.approx(2 * i_sense * 1e3, rel=1e-9)


def test_high_gain_e_in_feedback_is_a_non_inverting_amplifier():
    # E as an op-amp with open-loop gain A; feedback divider beta = Rg/(Rg+Rf) = 0.1:
    # v(out) = A·vin / (1 + A·beta)
    for gain in (10.0, 1e3, 1e6):
        body = f"Vp p 0 1\nE1 out 0 p n {gain}\nRf out n 9k\nRg n 0 1k\nRL out 0 100"
        op = circuit_from(body).operating_point()
        assert op["v(out)"] == pytest.approx(gain / (1 + gain * 0.1), rel=1e-9)
        assert op["v(n)"] == pytest.approx(op["v(out)"] * 0.1, rel=1e-9)


def test_g_charging_a_capacitor_follows_implicit_euler_exactly():
    # G1 pushes gm·Vin into node out: C v' = gm·Vin - v/R, from v(0) = 0 (UIC).
    # Implicit Euler: v_{k+1} = (v_k + h·gm·Vin/C) / (1 + h/(RC)).
    vin, gm, R, C, h = 2.0, 1e-3, 1e3, 1e-6, 1e-5
    waves = circuit_from(f"V1 in 0 {vin}\nG1 0 out in 0 {gm}\nR1 out 0 {R}\nC1 out 0 {C}\n"
                         f".tran {h} 3m uic").transient(method="theta")  # θ's recurrence, pinned
    expected = np.zeros(waves.time.size)
    for k in range(1, expected.size):
        expected[k] = (expected[k - 1] + h * gm * vin / C) / (1 + h / (R * C))
    np.testing.assert_allclose(waves["v(out)"], expected, rtol=1e-10, atol=1e-13)
    # and the continuous solution to first order in h
    exact = gm * vin * R * (1 - np.exp(-waves.time / (R * C)))
    assert np.max(np.abs(waves["v(out)"] - exact)) < h / (R * C) * gm * vin * R
    # (row 0 is the UIC state, whose algebraic unknowns such as v(in) are not solved)
    np.testing.assert_allclose(waves["i(g1)"][1:], gm * vin, rtol=1e-12)


def test_h_as_a_current_sensor_on_a_half_wave_rectifier():
    # H1 reads the diode current through the 0 V source Vsense with 1 ohm: v(meas) = i(d1).
    body = """V1 in 0 SIN(0 10 50)
D1 in x dideal
Vsense x out 0
Rload out 0 1k
H1 meas 0 Vsense 1
Rm meas 0 1meg
.model dideal D
.tran 50u 40m
"""
    waves = circuit_from(body).transient()
    load_current = np.maximum(10 * np.sin(2 * np.pi * 50 * waves.time), 0) / 1e3
    np.testing.assert_allclose(waves["v(meas)"], load_current, atol=1e-10)
    np.testing.assert_allclose(waves["v(meas)"], waves["i(d1)"], atol=1e-12)
    np.testing.assert_allclose(waves["i(vsense)"], waves["i(d1)"], atol=1e-12)


def test_f_mirrors_a_sine_current_with_gain():
    # i(vs) = v(in)/1k; F1 0 f Vs -3 pushes -3·i(vs) into f: v(f) = -3·v(in)/1k·250
    body = """V1 in 0 SIN(0 4 1k)
R1 in a 1k
Vs a 0 0
F1 0 f Vs -3
Rf f 0 250
.tran 10u 2m
"""
    waves = circuit_from(body).transient()
    vin = 4 * np.sin(2 * np.pi * 1e3 * waves.time)
    np.testing.assert_allclose(waves["i(vs)"], vin / 1e3, atol=1e-12)
    np.testing.assert_allclose(waves["v(f)"], -3 * vin / 1e3 * 250, atol=1e-9)
    np.testing.assert_allclose(waves["i(f1)"], -3 * vin / 1e3, atol=1e-12)


def test_controlled_source_declared_before_its_controlling_source():
    # F and H may name a source defined later in the netlist
    body = "H1 h 0 Vs 10\nRh h 0 1k\nV1 in 0 1\nR1 in a 100\nVs a 0 0"
    assert circuit_from(body).operating_point()["v(h)"] == pytest.approx(10 * 1 / 100, rel=1e-12)


@pytest.mark.parametrize(
    ("line", "words"),
    [
        ("F1 0 f Vx 4", ["vx", "not a voltage source"]),        # missing source
        ("F1 0 f R1 4", ["r1", "not a voltage source"]),        # names a resistor
        ("H1 f 0 I1 4", ["i1", "not a voltage source"]),        # names a current source
        ("E1 f 0 in 2", ["missing"]),                           # 3 control/output nodes
        ("G1 f 0 5", ["missing"]),                              # 3 nodes
        ("E1 f 0 in 0 2 3", ["unexpected", "3"]),               # a 5th node / extra token
        ("F1 f 0", ["missing"]),
        ("H1 f 0 V1", ["missing"]),
        ("E1 f 0 in 0 abc", ["not a number"]),
        ("E1 f 0 poly(1) in 0 0 1", ["not supported"]),
        ("G1 f 0 poly(2) in 0 a 0 0 1 1", ["not supported"]),
        ("F1 f 0 poly(1) V1 0 2", ["not supported"]),
        ("E1 f 0 in value={2}", ["not supported"]),
        ("E1 f 0 in 0 2 m=2", ["m="]),
    ],
)
def test_malformed_controlled_sources_name_the_line(line, words):
    body = f"V1 in 0 1\nR1 in 0 1k\nI1 0 a 1m\nRa a 0 1\n{line}\nRf f 0 1k"
    with pytest.raises(circuitnsds.NetlistError) as info:
        circuit_from(body)
    message = str(info.value).lower()
    assert "<text>:6:" in message  # title is line 1, the faulty line is the 6th
    for word in words:
        assert word in message


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        ("E1 f 0 value={v(in)*2}", 2.0),           # v(in) = 1 V
        ("G1 0 f cur={v(in)*1m}", 1.0),            # 1 mA into f, through Rf = 1k
        ("E1 f 0 vol='v(in)*2'", 2.0),
        ("E1 f 0 table {v(in)} = (0,0) (2,4)", 2.0),
    ],
)
def test_behavioural_forms_of_e_and_g(line, expected):
    # ngspice's behavioural forms name circuit quantities (v(in)) inside the expression
    op = circuit_from(f"V1 in 0 1\nR1 in 0 1k\n{line}\nRf f 0 1k").operating_point()
    assert op["v(f)"] == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("line", ["E1 f 0 poly(1) in 0 0 2", "E1 f 0 laplace {v(in)} = {1/(1+s)}"])
def test_polynomial_and_laplace_sources_are_reported_as_unsupported(line):
    with pytest.raises(circuitnsds.NetlistError) as info:
        circuit_from(f"V1 in 0 1\nR1 in 0 1k\n{line}\nRf f 0 1k")
    message = str(info.value).lower()
    assert "<text>:4:" in message
    assert "not supported" in message


@pytest.mark.parametrize(
    ("line", "what"),
    [
        ("T1 f 0 in 0 z0=50 td=1n", "transmission"),
        ("U1 f in 0 urc l=1m n=10", "rc lines"),
    ],
)
def test_unsupported_elements_say_so_with_the_line(line, what):
    with pytest.raises(circuitnsds.NetlistError) as info:
        circuit_from(f"V1 in 0 1\nR1 in 0 1k\n{line}\nRf f 0 1k")
    message = str(info.value).lower()
    assert "<text>:4:" in message
    assert "not supported" in message
    assert what in message
