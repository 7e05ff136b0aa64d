"""XSPICE digital parts (d_inverter, d_and, d_or, d_srlatch, d_dff, adc_bridge, dac_bridge)
in ngspice's syntax (issue 21): truth tables and edges against hand-derived expectations,
random input sequences against reference state machines written here, every state change
an event, clear errors, and the three converters against ngspice running the same files."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.errors import NetlistError
from tests.conftest import NETLISTS, circuit_from

SLOT = 1e-6  # one input pattern per slot [s]; edges are 1 ns ramps at the start of a slot


def _pwl(name: str, bits: list[int]) -> str:
    points = [f"0 {bits[0]}"]
    for k in range(1, len(bits)):
        if bits[k] != bits[k - 1]:
            points += [f"{k * SLOT:.9g} {bits[k - 1]}", f"{k * SLOT + 1e-9:.9g} {bits[k]}"]
    return f"V{name} {name} 0 PWL({' '.join(points)})"


def run_digital(inputs: dict[str, list[int]], parts: str, outputs: list[str]):
    """Drive digital nodes d<name> from 0/1 PWL sources through an adc_bridge, run the parts,
    and return (waves, {output: value sampled in the middle of each slot})."""
    names = list(inputs)
    slots = len(next(iter(inputs.values())))
    body = [_pwl(name, bits) for name, bits in inputs.items()]
    body.append(f"Aadc [{' '.join(names)}] [{' '.join('d' + n for n in names)}] adc")
    body.append(".model adc adc_bridge(in_low=0.5 in_high=0.5)")
    body.append(parts)
    body.append(f".tran {SLOT / 10:.9g} {slots * SLOT:.9g}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuit_from("\n".join(body)).transient()
    middle = (np.arange(slots) + 0.5) * SLOT
    sampled = {out: np.round(np.interp(middle, waves.time, waves[f"v({out})"]), 12)
               for out in outputs}
    return waves, sampled


def changes(values) -> int:
    return int(np.count_nonzero(np.diff(values)))


# --- combinational parts ---------------------------------------------------------------------

def test_gates_follow_their_truth_tables_with_inverted_ports():
    a = [0, 0, 1, 1, 0, 1, 0, 0]
    b = [0, 1, 0, 1, 1, 1, 0, 1]
    c = [1, 1, 1, 1, 0, 0, 0, 0]
    parts = ("Aand [da db dc] y1 and3\n.model and3 d_and\n"
             "Aor [da ~db] y2 or2\n.model or2 d_or\n"
             "Ainv da y3 inv\n.model inv d_inverter\n"
             "Anand [da db] ~y4 and2\n.model and2 d_and\n")
    waves, got = run_digital({"a": a, "b": b, "c": c}, parts, ["y1", "y2", "y3", "y4"])
    A, B, C = (np.array(x) for x in (a, b, c))
    np.testing.assert_array_equal(got["y1"], A & B & C)
    np.testing.assert_array_equal(got["y2"], A | (1 - B))
    np.testing.assert_array_equal(got["y3"], 1 - A)
    np.testing.assert_array_equal(got["y4"], 1 - (A & B))
    # every change of an output is one event of its part, at a slot boundary (the inputs'
    # 1 ns edges cross 0.5 V half-way: 0.5 ns after the boundary)
    for part, out in (("aand", "y1"), ("aor", "y2"), ("ainv", "y3"), ("anand", "y4")):
        events = [e for e in waves.events if e.element == part]
        assert len(events) == changes(got[out]), part
        for event in events:
            assert event.time / SLOT - round(event.time / SLOT) == pytest.approx(5e-4, abs=1e-9)


def test_dac_bridge_levels_and_differential_output():
    a = [0, 1, 1, 0]
    parts = ("Adac [da ~da] [o1 %vd(o2 o3)] dac\n.model dac dac_bridge(out_low=-2 out_high=3)\n"
             "R1 o1 0 1k\nR2 o2 o3 1k\nR3 o3 0 1k\nV3 o3x 0 0\n")
    waves, _ = run_digital({"a": a}, parts, [])
    middle = (np.arange(4) + 0.5) * SLOT
    o1 = np.interp(middle, waves.time, waves["v(o1)"])
    o23 = np.interp(middle, waves.time, waves["v(o2)"] - waves["v(o3)"])
    np.testing.assert_allclose(o1, [-2, 3, 3, -2], rtol=0, atol=1e-12)
    np.testing.assert_allclose(o23, [3, -2, -2, 3], rtol=0, atol=1e-12)


def test_adc_bridge_switches_at_the_edges_of_its_band_and_holds_inside():
    # v(in) = 1 V·t/0.1 ms rising then falling (triangle 0 -> 1 -> 0 in 0.2 ms); the band is
    # [0.3, 0.7]: the output rises where v(in) = 0.7 (70 µs) and falls where it is 0.3 (170 µs)
    with pytest.warns(Warning, match="in_low=0.3 and in_high=0.7.*UNKNOWN"):
        circuit = circuit_from("V1 in 0 PWL(0 0 0.1m 1 0.2m 0)\nA1 [in] [d] adc\n"
                               ".model adc adc_bridge(in_low=0.3 in_high=0.7)\n"
                               "A2 [d] [o] dac\n.model dac dac_bridge\nR1 o 0 1\n.tran 1u 0.2m")
    waves = circuit.transient()
    events = [(e.time, e.state) for e in waves.events if e.element == "a1"]
    assert [s for _, s in events] == [True, False]
    # (the thresholds sit a round-off margin, 1e-9 V, inside the band: 0.1 ps on this slope)
    assert events[0][0] == pytest.approx(70e-6, abs=1e-12)
    assert events[1][0] == pytest.approx(170e-6, abs=1e-12)
    o = waves["v(o)"]
    assert np.all(o[(waves.time > 71e-6) & (waves.time < 169e-6)] == 1.0)
    assert np.all(o[(waves.time < 69e-6) | (waves.time > 171e-6)] == 0.0)


def test_adc_bridge_band_edges_are_inclusive_as_in_ngspice():
    # ngspice 39's adc_bridge (src/xspice/icm/digital/adc_bridge/cfunc.mod) gives 0 when
    # in <= in_low and 1 when in >= in_high: with the band [0, 1], a 0/1 V pulse reaches each
    # edge exactly and switches the output both ways (ngspice 39 run on this netlist: v(o) =
    # 1 at 3 µs and 13 µs, 0 at 8 µs). A DC input exactly at in_high is 1 from the start.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuit_from("V1 in 0 PULSE(0 1 1u 1n 1n 5u 10u)\nV2 h 0 1\n"
                             "A1 [in h] [d e] adc\n.model adc adc_bridge(in_low=0 in_high=1)\n"
                             "A2 [d e] [o p] dac\n.model dac dac_bridge\nR1 o 0 1\nR2 p 0 1\n"
                             ".tran 10n 20u").transient()
    o = np.interp([0.5e-6, 3e-6, 8e-6, 13e-6, 18e-6], waves.time, waves["v(o)"])
    np.testing.assert_array_equal(o, [0, 1, 0, 1, 0])
    assert [e.state for e in waves.events if e.element == "a1.0"] == [True, False, True, False]
    assert np.all(waves["v(p)"] == 1.0)
    # in_low = in_high = t: exactly at t the output is 0 (ngspice 39 tests in <= in_low first)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuit_from("V1 in 0 PWL(0 0 1u 1 2u 0.5)\nA1 [in] [d] adc\n"
                             ".model adc adc_bridge(in_low=0.5 in_high=0.5)\n"
                             "A2 [d] [o] dac\n.model dac dac_bridge\nR1 o 0 1\n"
                             ".tran 10n 3u").transient()
    assert np.interp(2.5e-6, waves.time, waves["v(o)"]) == 0.0


# --- latches and flip-flops against reference state machines ---------------------------------

def reference_srlatch(s, r, en, set_, reset, q0=0):
    """d_srlatch as documented: reset dominant where ngspice would give UNKNOWN."""
    q, out = q0, []
    for k in range(len(s)):
        if set_[k] or reset[k]:
            q = 0 if reset[k] else 1
        elif en[k] and r[k]:
            q = 0
        elif en[k] and s[k]:
            q = 1
        out.append(q)
    return out


def reference_dff(d, clk, set_, reset, q0=0):
    """d_dff: q takes data at a rising clock edge; set/reset asynchronous, reset dominant.
    A master follows data while the clock is low, so after a set/reset that ends while the
    clock is high, q keeps the forced value until the next rising edge."""
    q, master, out = q0, q0, []
    for k in range(len(d)):
        if set_[k] or reset[k]:
            q = master = 0 if reset[k] else 1
        elif not clk[k]:
            master = d[k]
        elif k > 0 and not clk[k - 1]:   # a rising edge
            q = master
        out.append(q)
    return out


def bits(n: int):
    return st.lists(st.integers(0, 1), min_size=n, max_size=n)


@settings(max_examples=12, deadline=None)
@given(st.data())
def test_srlatch_follows_the_reference_state_machine(data):
    n = 10
    s, r, en, set_, reset = (data.draw(bits(n)) for _ in range(5))
    parts = "Al ds dr den dset dreset q nq lat\n.model lat d_srlatch\n"
    waves, got = run_digital({"s": s, "r": r, "en": en, "set": set_, "reset": reset}, parts,
                             ["q", "nq"])
    expected = reference_srlatch(s, r, en, set_, reset)
    np.testing.assert_array_equal(got["q"], expected)
    np.testing.assert_array_equal(got["nq"], 1 - np.array(expected))
    assert len([e for e in waves.events if e.element == "al"]) == changes(expected)


@settings(max_examples=12, deadline=None)
@given(st.data())
def test_dff_follows_the_reference_state_machine(data):
    n = 12
    d, clk = data.draw(bits(n)), data.draw(bits(n))
    # data and clock change in different slots (ngspice's 1 ns delays would order a
    # simultaneous change; here the data of a simultaneous change is not defined)
    for k in range(1, n):
        if d[k] != d[k - 1] and clk[k] != clk[k - 1]:
            d[k] = d[k - 1]
    quiet = data.draw(st.booleans())
    set_ = [0] * n if quiet else data.draw(bits(n))
    reset = [0] * n if quiet else data.draw(bits(n))
    parts = "Af dd dclk dset dreset q NULL ff\n.model ff d_dff\n"
    waves, got = run_digital({"d": d, "clk": clk, "set": set_, "reset": reset}, parts, ["q"])
    expected = reference_dff(d, clk, set_, reset)
    np.testing.assert_array_equal(got["q"], expected)
    # the state at t = 0 comes from the operating point, not from an event
    assert len([e for e in waves.events if e.element == "af"]) == changes(expected)


def test_dff_divides_the_clock_by_two_with_its_inverted_output_as_data():
    clk = [0, 1] * 6
    parts = "Af nq dclk NULL NULL q nq ff\n.model ff d_dff(ic=1)\n"
    _, got = run_digital({"clk": clk}, parts, ["q"])
    # ic = 1: q toggles at each rising edge (slots 1, 3, 5, ...)
    np.testing.assert_array_equal(got["q"], [1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1])


def test_dff_takes_the_data_from_just_before_a_simultaneous_clock_edge():
    # documented difference (docs/control.md, "Delays: zero"): data and clock rise at the same
    # instant (two bits of one adc_bridge on one source), q keeps the data of before the edge,
    # 0; ngspice 39 (1 ns delays on both) gives 1 from the first edge on
    parts = "Af dd dclk NULL NULL q NULL ff\n.model ff d_dff\n"
    _, got = run_digital({"d": [0, 1, 0, 1, 0, 1], "clk": [0, 1, 0, 1, 0, 1]}, parts, ["q"])
    np.testing.assert_array_equal(got["q"], [0, 0, 0, 0, 0, 0])
    # one slot later the data is there before the edge and is taken
    _, got = run_digital({"d": [0, 1, 1, 1, 0, 0], "clk": [0, 0, 1, 0, 0, 1]}, parts, ["q"])
    np.testing.assert_array_equal(got["q"], [0, 0, 1, 1, 1, 0])


def test_latch_initial_states_hold_under_uic():
    # ic = 1 on a d_dff (clock low, data 0) and on a d_srlatch (enable low) under UIC: both
    # hold 1 until the clock's first rising edge at 1 µs (then the flip-flop takes data 0),
    # as without UIC; ngspice 39 on this netlist gives the same (v(o1) = 1, 1, 0, 0; v(o3) =
    # 1 throughout). Before, the first step read every latch control at the all-zero UIC
    # state and both latches dropped to 0.
    body = ("V1 c 0 PULSE(0 1 1u 1n 1n 1u 2u)\nV2 d 0 0\nAad [c d] [dc dd] adc\n"
            ".model adc adc_bridge(in_low=0.5 in_high=0.5)\n"
            "Af dd dc NULL NULL q nq ff\n.model ff d_dff(ic=1)\n"
            "Al dd dd dc NULL NULL s NULL lat\n.model lat d_srlatch(ic=1)\n"
            "Ao [q nq s] [o1 o2 o3] dac\n.model dac dac_bridge\n"
            "R1 o1 0 1k\nR2 o2 0 1k\nR3 o3 0 1k\n.tran 10n 3u uic")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuit_from(body).transient()
    middle = np.array([0.05, 0.5, 1.5, 2.5]) * 1e-6
    np.testing.assert_array_equal(np.interp(middle, waves.time, waves["v(o1)"]), [1, 1, 0, 0])
    np.testing.assert_array_equal(np.interp(middle, waves.time, waves["v(o2)"]), [0, 0, 1, 1])
    np.testing.assert_array_equal(np.interp(middle, waves.time, waves["v(o3)"]), [1, 1, 1, 1])
    assert [(e.element, e.state) for e in waves.events if e.element in ("af", "al")] == \
        [("af", False)]


# --- errors and warnings name the line and the parameter -------------------------------------

@pytest.mark.parametrize(
    ("lines", "words"),
    [
        ("A1 a b and2\n.model and2 d_and", ["a1", "the in port is a vector"]),
        ("A1 [a b] y and2\n.model and2 d_and(rise_dly=1n)", ["unknown parameter 'rise_dly'"]),
        ("A1 [a] [b] and2\n.model and2 d_and", ["needs at least two inputs"]),
        ("A1 a [b] inv\n.model inv d_inverter", ["single digital node, not a vector"]),
        ("A1 null y inv\n.model inv d_inverter", ["in port cannot be NULL"]),
        ("A1 0 y inv\n.model inv d_inverter", ["cannot be ground"]),
        ("A1 a y z inv\n.model inv d_inverter", ["unexpected 'z'"]),
        ("A1 a b c null null q l\n.model l d_srlatch(ic=2)", ["ic=2 is not 0 or 1"]),
        ("A1 a b null null null null l\n.model l d_dff", ["every output of d_dff is NULL"]),
        ("A1 a b l\n.model l d_dff", ["missing the set port"]),
        ("A1 a b [c] l\n.model l adc_bridge", ["in port of a bridge is a vector"]),
        ("A1 [a b] [c] l\n.model l adc_bridge", ["2 input(s) and 1 output(s)"]),
        ("A1 [%i(a)] [c] l\n.model l adc_bridge", ["port type %i"]),
        ("A1 [a] [%d b] l\n.model l dac_bridge", ["port type %d"]),
        ("A1 [~null] y l\n.model l dac_bridge", ["cannot be NULL"]),
        # an unclosed bracket was read as "model 'y' is not defined"
        ("A1 [a y\n.model and2 d_and", ["unbalanced brackets"]),
        ("A1 [a b]] y and2\n.model and2 d_and", ["unbalanced brackets"]),
        ("A1 a y inv2\n.model inv d_inverter", ["model 'inv2' is not defined", "d_inverter"]),
        # a vector value for a single-valued parameter (an internal error before)
        ("A1 [a] [b] l\n.model l adc_bridge(in_low=[0.1 0.2])", ["in_low is a single value"]),
        ("A1 a b null null q null l\n.model l d_dff(ic=[1])", ["ic is a single value"]),
        ("A1 [a] [b] l\n.model l dac_bridge(out_low=[0 1])", ["out_low is a single value"]),
        ("A1 [a] b l\n.model l summer(in_gain=2)", ["in_gain is a vector", "[v1 v2 ...]"]),
        ("A1 a b l\n.model l gain(gain=[2 3])", ["gain is a single value"]),
        ("A1 a b l\n.model l limit(out_lower_limit=[0] out_upper_limit=1)",
         ["out_lower_limit is a single value"]),
    ],
)
def test_malformed_digital_lines_are_refused_with_their_line(lines, words):
    with pytest.raises(NetlistError) as info, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit_from("V1 a 0 1\n" + lines + "\nR1 a 0 1k\n.tran 1u 10u")
    message = str(info.value)
    assert "<text>:3:" in message or "<text>:4:" in message, message
    for word in words:
        assert word in message, message


def test_an_analog_node_on_a_digital_input_is_refused():
    # ngspice refuses it too: a digital port needs a digital node (an adc_bridge converts)
    with pytest.raises(NetlistError) as info:
        circuit_from("V1 a 0 1\nA1 a y inv\n.model inv d_inverter\n"
                     "A2 [y] [o] dac\n.model dac dac_bridge\nR1 o 0 1k\n.tran 1u 10u")
    message = str(info.value)
    assert "<text>:3:" in message and "node 'a' is a digital input" in message
    assert "adc_bridge" in message


@pytest.mark.parametrize(("line", "element"), [
    ("R2 d 0 1k", "r2"),                                       # a load on a digital node
    ("A3 d g gn\n.model gn gain(gain=2)\nR3 g 0 1k", "a3"),   # an analog block reads it
    ("A3 [d] [e] adc2\n.model adc2 adc_bridge(in_low=0.5 in_high=0.5)\nA4 [e] [f] dac\n"
     "R3 f 0 1k", "a3"),                                        # an adc_bridge reads it
])
def test_an_analog_element_on_a_digital_node_is_refused(line, element):
    # ngspice 39 inserts a dac_bridge with out_high = vcc (3.3 V unless .param vcc) between
    # a digital node and an analog element (src/xspice/evt/evtcheck_nodes.c; ngspice 39 on
    # "A1 [a] [o] adc ... R1 o 0 1k" gives v(o) = 3.3 V); circuitnsds would give the digital
    # node's 0/1 V: refused, naming the element, its line and the bridge to write
    body = ("V1 a 0 PULSE(0 1 1u 1n 1n 1u 2u)\nA1 [a] [d] adc\n"
            ".model adc adc_bridge(in_low=0.5 in_high=0.5)\nA2 [d] [o] dac\n.model dac dac_bridge\n"
            f"R1 o 0 1k\n{line}\n.tran 10n 4u")
    with pytest.raises(NetlistError) as info, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit_from(body)
    message = str(info.value)
    assert f"{element}: node 'd' is a digital node" in message and "<text>:8:" in message, message
    assert "dac_bridge" in message and "3.3 V" in message, message


def test_ignored_delays_and_loads_are_named_in_warnings():
    body = ("V1 a 0 1\nA1 [a] [d] adc\n.model adc adc_bridge(in_low=0.5 in_high=0.5 rise_delay=2n)\n"
            "A2 d y inv\n.model inv d_inverter(input_load=2p fall_delay=1n)\n"
            "A3 [y] [o] dac\n.model dac dac_bridge(out_undef=0.3)\nR1 o 0 1k\n.tran 1u 2u")
    with pytest.warns(Warning) as record:
        circuit_from(body)
    messages = [str(w.message) for w in record]
    assert any("<text>:4:" in m and "rise_delay ignored" in m for m in messages), messages
    assert any("<text>:6:" in m and "fall_delay ignored" in m for m in messages), messages
    assert any("<text>:6:" in m and "input_load ignored" in m for m in messages), messages
    assert any("<text>:8:" in m and "out_undef ignored" in m for m in messages), messages


def test_digital_parts_inside_a_subcircuit_keep_inversions_and_null_ports():
    body = (".subckt latch s r q\nAl s ~r one NULL NULL q NULL lat\n.model lat d_srlatch\n"
            "Vone x 0 1\nAx [x] [one] adc\n.model adc adc_bridge(in_low=0.5 in_high=0.5)\n.ends\n"
            "V1 a 0 PULSE(0 1 1u 1n 1n 1u 4u)\nV2 b 0 1\nAi [a b] [da db] adc\n"
            ".model adc adc_bridge(in_low=0.5 in_high=0.5)\nX1 da db q latch\n"
            "Ao [q] [o] dac\n.model dac dac_bridge\nR1 o 0 1k\n.tran 0.1u 4u")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuit_from(body).transient()
    # r is inverted (~r, r = 1: no reset), so the first set pulse at 1 µs latches q = 1
    o = waves["v(o)"]
    assert np.all(o[waves.time < 0.99e-6] == 0) and np.all(o[waves.time > 1.01e-6] == 1)
    assert [e.element for e in waves.events if e.element.startswith("x1.al")] == ["x1.al"]


# --- the XSPICE integrator's limits hold by complementarity in every step -----------------

def test_limited_xspice_int_holds_its_limits_by_complementarity_in_every_step():
    # the same integrator as test_behavioural's anti-windup test, checked pair by pair: each
    # limit's gap (distance to the rail) and multiplier are >= 0 and one of them is 0, to
    # round-off, in every step; the output is the state, so it stays within [-0.2, 0.4]
    from tests.test_behavioural import _trajectory

    circuit = circuit_from("V1 in 0 PULSE(1 -1 1m 1n 1n 1m 2m)\nA1 in out integ\n"
                           ".model integ int(gain=1000 out_ic=0 out_lower_limit=-0.2 "
                           "out_upper_limit=0.4)\nR1 out 0 1k\n.tran 1u 4m uic")
    mlcs, trajectory = _trajectory(circuit)
    assert mlcs.m == 2
    C = mlcs.C.toarray()
    gap = trajectory.y @ C.T + mlcs.e
    multiplier = trajectory.current
    roundoff = 64 * np.finfo(float).eps * (np.abs(trajectory.y) @ np.abs(C).T + np.abs(mlcs.e)
                                           + np.abs(multiplier))
    assert np.all(gap >= -roundoff) and np.all(multiplier >= -roundoff)
    assert np.all(np.abs(np.minimum(gap, multiplier)) <= roundoff)
    out = trajectory.y[:, mlcs.unknowns.index("v(out)")]
    assert np.all(out <= 0.4 + 1e-15) and np.all(out >= -0.2 - 1e-15)
    assert np.sum(np.isclose(out, 0.4, rtol=0, atol=1e-12)) > 100   # it does sit on each limit
    assert np.sum(np.isclose(out, -0.2, rtol=0, atol=1e-12)) > 100


# --- the three converters -------------------------------------------------------------------

PERIOD = 10e-6


def pcm_xspice(ramp: float, output: float | None = None) -> str:
    """netlists/buck_peak_current_xspice.cir with slope compensation ``ramp`` [A], the output
    capacitor starting at ``output`` [V] (near its steady state) when given."""
    text = (NETLISTS / "buck_peak_current_xspice.cir").read_text()
    assert ".param vramp=0\n" in text and "C1 out 0 20u\n" in text
    if output is not None:
        text = text.replace("C1 out 0 20u\n", f"C1 out 0 20u IC={output}\n")
    return text.replace(".param vramp=0\n", f".param vramp={ramp}\n")


@pytest.mark.parametrize(("ramp", "start", "subharmonic"), [(0.0, 7.7, True), (0.8, 6.47, False)])
def test_xspice_peak_current_buck_subharmonic_oscillation_and_slope_compensation(
        ramp, start, subharmonic, tmp_path):
    # D ≈ 0.65 > 0.5 (the output starts near its steady state, so that 20 periods show it):
    # without compensation the peaks of the inductor current alternate (measured ratios
    # 0.91-1.10 over periods 10-20; 0.91-1.10 over periods 40-50 from 0 V); the ramp of slope
    # Vout/L makes them equal, up to the slow settling of the output (measured 0.998-0.9998,
    # all on one side of 1; 0.9999-1.0000 over periods 40-50)
    import circuitnsds
    from tests.test_comparators import peak_ratios

    path = tmp_path / "pcm.cir"
    path.write_text(pcm_xspice(ramp, start))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuitnsds.read_netlist(path).transient(stop=0.2e-3)
    assert 0.5 < waves["v(out)"][waves.time > 0.1e-3].mean() / 12.0 < 0.7   # D above 0.5
    ratios = peak_ratios(waves.time, waves["i(vsense)"], 10, 20)
    if subharmonic:
        assert np.abs(ratios - 1).max() > 0.03
    else:
        assert np.abs(ratios - 1).max() < 3e-3 and np.all(ratios < 1)
    resets = [e for e in waves.events if e.element == "alatch" and not e.state]
    assert len(resets) >= 5   # skipped cycles without compensation (9 resets in 20 periods)


@pytest.mark.ngspice
def test_xspice_hysteretic_buck_agrees_with_ngspice():
    # h = 40 ns for both, 100-400 µs: measured mean v(a) -1.0e-4, frequency +2.1e-3, duty
    # +7.2e-4 (ngspice's adc/dac delays, 1 ns each, widen its band a little)
    from tests.test_comparators import _agrees_with_ngspice

    _agrees_with_ngspice(NETLISTS / "buck_hysteretic_xspice.cir", 4e-8, 400e-6, "v(a)", 100e-6)


@pytest.mark.ngspice
def test_xspice_compensated_peak_current_buck_agrees_with_ngspice(tmp_path):
    # h = 20 ns, 0.3-0.4 ms (measured over 0.4-0.6 ms: mean -8.6e-4, frequency 0, duty -1.3e-3)
    from tests.test_comparators import _agrees_with_ngspice

    path = tmp_path / "pcm.cir"
    path.write_text(pcm_xspice(0.8))
    _agrees_with_ngspice(path, 2e-8, 0.4e-3, "v(out)", 0.3e-3)


@pytest.mark.ngspice
def test_xspice_voltage_mode_buck_agrees_with_ngspice():
    # h = 40 ns for both (ngspice: gear, N = 0.03), 1.4-1.8 ms after the soft start: measured
    # mean v(out) -1.5e-5, frequency -4.3e-5, duty -6.4e-3 (the diode's drop in ngspice)
    from tests.test_comparators import _agrees_with_ngspice

    _agrees_with_ngspice(NETLISTS / "buck_voltage_mode_xspice.cir", 4e-8, 1.8e-3, "v(out)", 1.4e-3,
                         ngspice_options="method=gear")


def _no_unknowns(rng: np.random.Generator, n: int) -> dict[str, list[int]]:
    """Random 0/1 sequences without the input patterns on which ngspice's output is UNKNOWN
    (s = r = 1 enabled, set = reset = 1) and without data and clock changing together."""
    seq = {name: rng.integers(0, 2, n) for name in ("a", "b", "s", "r", "en")}
    seq["set"], seq["reset"] = ((rng.random(n) < 0.15).astype(int) for _ in range(2))
    seq["r"] &= 1 - seq["s"]
    seq["reset"] &= 1 - seq["set"]
    seq["clk"] = (np.arange(n) // 2) % 2   # a clock of 4 slots
    for k in range(1, n):
        if seq["clk"][k] != seq["clk"][k - 1] and seq["a"][k] != seq["a"][k - 1]:
            seq["a"][k] = seq["a"][k - 1]
    return {name: [int(x) for x in values] for name, values in seq.items()}


@pytest.mark.ngspice
def test_digital_parts_agree_with_ngspice_slot_by_slot(tmp_path):
    # the same netlist in both: gates, an SR latch and a D flip-flop with set/reset, driven by
    # random 0/1 sequences (1 ns edges, 1 µs slots) through an adc_bridge and read through a
    # dac_bridge; in the middle of every slot every output is the same 0/1 value (ngspice's
    # 1 ns delays are over by then)
    from circuitnsds.compare import compare

    inputs = _no_unknowns(np.random.default_rng(21), 24)
    names = list(inputs)
    body = ["digital parts against ngspice"] + [_pwl(n, b) for n, b in inputs.items()]
    body += [f"Aadc [{' '.join(names)}] [{' '.join('d' + n for n in names)}] adc",
             ".model adc adc_bridge(in_low=0.5 in_high=0.5)",
             "Aand [da ~db ds] y1 and3\n.model and3 d_and",
             "Aor %d [da db] ~y2 or2\n.model or2 d_or",
             "Ainv %d(da) y3 inv\n.model inv d_inverter",
             "Al ds dr den dset NULL y4 y5 lat\n.model lat d_srlatch",
             "Af da dclk NULL dreset y6 NULL ff\n.model ff d_dff(ic=1)",
             "Adac [y1 y2 y3 y4 y5 y6] [o1 o2 o3 o4 o5 o6] dac\n.model dac dac_bridge",
             *(f"R{k} o{k} 0 1k" for k in range(1, 7)),
             ".tran 0.1u 24u", ".end"]
    path = tmp_path / "digital.cir"
    path.write_text("\n".join(body) + "\n")
    outputs = [f"v(o{k})" for k in range(1, 7)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = compare(path, n=1.0, signals=outputs)
    assert comparison.run.ok, comparison.run.ngspice.message
    ours, theirs = comparison.circuitnsds, comparison.run.ngspice.waveforms
    middle = (np.arange(24) + 0.5) * SLOT
    for signal in outputs:
        mine = np.interp(middle, ours.time, ours[signal])
        reference = np.interp(middle, theirs.time, theirs[signal])
        assert set(np.unique(mine)) <= {0.0, 1.0}, signal
        np.testing.assert_array_equal(mine, reference, err_msg=signal)
    assert changes(np.interp(middle, ours.time, ours["v(o6)"])) >= 2   # the flip-flop moved


# --- the port reader, property-based ---------------------------------------------------------

PORT = st.tuples(st.sampled_from(["p", "q", "r", "s"]), st.booleans(),
                 st.sampled_from(["plain", "%d", "%d()"]))


def _spell(node: str, inverted: bool, style: str) -> str:
    text = ("~" if inverted else "") + node
    return {"plain": text, "%d": f"%d {text}", "%d()": f"%d({text})"}[style]


@settings(max_examples=60, deadline=None)
@given(st.lists(PORT, min_size=2, max_size=5), st.sampled_from(["d_and", "d_or"]),
       st.booleans(), st.booleans())
def test_gate_inputs_are_read_with_their_inversions(ports, kind, vector_type, inverted_out):
    # d_and/d_or with inputs spelled node, ~node, %d node, %d(node) (and %d before the
    # vector): the comparator's control is Σ ±v(node) + (number of inversions) - threshold
    from circuitnsds.circuit.elements.behavioural import Select

    inputs = " ".join(_spell(*port) for port in ports)
    line = (f"A1 {'%d ' if vector_type else ''}[{inputs}] {'~' if inverted_out else ''}y g\n"
            f".model g {kind}")
    body = ("V1 a 0 1\nAd [a a a a] [p q r s] adc\n.model adc adc_bridge(in_low=0.5 in_high=0.5)\n"
            f"{line}\nAo [y] [o] dac\n.model dac dac_bridge\nR1 o 0 1k\n.tran 1u 10u")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuit_from(body)
    gate = next(e for e in circuit.elements if e.name == "a1")
    (select,) = gate.auxiliaries
    assert isinstance(select, Select) and select.name == "a1"
    expected: dict[str, float] = {}
    for node, inverted, _ in ports:
        expected[node] = expected.get(node, 0.0) + (-1.0 if inverted else 1.0)
    assert dict(select.control.voltages) == {n: c for n, c in expected.items() if c != 0}
    threshold = len(ports) - 0.5 if kind == "d_and" else 0.5
    inversions = sum(inverted for _, inverted, _ in ports)
    assert select.control.constant == pytest.approx(inversions - threshold, abs=1e-12)
    # the output: the state, or 1 - state for ~y
    assert gate.value.auxiliaries == ((0, -1.0 if inverted_out else 1.0),)
    assert gate.value.constant == (1.0 if inverted_out else 0.0)
