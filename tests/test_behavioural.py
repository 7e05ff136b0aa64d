"""Behavioural sources (B, E/G VALUE= and TABLE) and XSPICE analog blocks (gain, summer,
limit, int): what they stamp, the limiter's complementarity in every step, refusals that
name the term, and agreement with ngspice running the same netlist (marker ``ngspice``)."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import circuitnsds
from circuitnsds.analyses.operating_point import uic_state
from circuitnsds.engine.integrate import integrate
from circuitnsds.engine.timegrid import time_grid
from circuitnsds.frontend.cards.behavioural import classify
from tests.conftest import circuit_from

SOURCES = """V1 a 0 SIN(0 2 1k)
V2 b 0 PULSE(-1 1 0.2m 10u 10u 0.3m 1m)
Vs a s 0
Rs s 0 1k
"""


def waves_of(body: str, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return circuit_from(body).transient(**kwargs)


def test_affine_b_source_equals_hand_built_controlled_sources():
    # v(out) = 2 v(a) - 0.5 v(a, b) + 300 i(vs) + 0.25, into an RC load: the B source against
    # the same sum built from E, E, H and a 0.25 V source in series; and a B current source
    # against G and F in parallel.
    load = "Rl{k} out{k} c{k} 1k\nCl{k} c{k} 0 1u\nRg{k} out{k} 0 2k\n"
    body = (SOURCES
            + "B1 out1 0 V={2*v(a) - 0.5*v(a,b) + 300*i(vs) + 0.25}\n" + load.format(k=1)
            + "E1 n1 0 a 0 2\nE2 n2 n1 a b -0.5\nH1 n3 n2 vs 300\nV3 out2 n3 0.25\n"
            + load.format(k=2)
            + "B2 0 out3 I={1m*v(a) + 2*i(vs) - 0.5m}\n" + load.format(k=3)
            + "G1 0 out4 a 0 1m\nF1 0 out4 vs 2\nI1 out4 0 0.5m\n" + load.format(k=4)
            + ".tran 2u 2m")
    waves = waves_of(body)
    for ours, reference in (("1", "2"), ("3", "4")):
        for signal in ("v(out{})", "v(c{})"):
            np.testing.assert_allclose(waves[signal.format(ours)], waves[signal.format(reference)],
                                       rtol=0, atol=1e-12)
    np.testing.assert_allclose(waves["i(b2)"], 1e-3 * waves["v(a)"] + 2 * waves["i(vs)"] - 0.5e-3,
                               rtol=0, atol=1e-15)


def test_min_max_abs_uramp_and_table_are_exact_in_every_step():
    body = ("V1 a 0 PWL(0 -3 1 3)\nV2 b 0 PWL(0 1 1 -1)\n"
            "B1 o1 0 V={max(v(a), v(b)) - min(v(a), 0.5) + abs(v(b)) + uramp(v(a) - 1)}\nR1 o1 0 1k\n"
            "E1 o2 0 TABLE {2*v(a)} = (-2, 1) (0, -1) (1, 0.5) (4, 0.5) (5, 2)\nR2 o2 0 1k\n"
            "G1 0 o3 value={min(max(1m*v(a), -1m), 2m)}\nR3 o3 0 1k\n"
            ".tran 1m 1")
    waves = waves_of(body)
    a, b = waves["v(a)"], waves["v(b)"]
    expected = np.maximum(a, b) - np.minimum(a, 0.5) + np.abs(b) + np.maximum(a - 1, 0)
    np.testing.assert_allclose(waves["v(o1)"], expected, rtol=0, atol=1e-12)
    table = np.interp(2 * a, [-2, 0, 1, 4, 5], [1, -1, 0.5, 0.5, 2])   # held at the ends
    np.testing.assert_allclose(waves["v(o2)"], table, rtol=0, atol=1e-12)
    np.testing.assert_allclose(waves["v(o3)"], np.clip(a, -1, 2), rtol=0, atol=1e-12)


def test_behavioural_sources_in_subcircuits_see_their_parameters_and_nodes():
    body = (".subckt amp in out params: k=2\nR1 in mid 1k\nR2 mid 0 1k\n"
            "B1 out 0 V={k*v(in) + v(mid)}\nA1 mid out2 g\n.model g gain(gain={k})\n"
            "R3 out2 0 1k\n.ends\n"
            "V1 a 0 2\nX1 a o amp k=3\nRo o 0 1k\nX2 a p amp\nRp p 0 1k\n.tran 1u 10u")
    op = circuit_from(body).operating_point()
    assert op["v(o)"] == pytest.approx(3 * 2 + 1, rel=1e-12)
    assert op["v(p)"] == pytest.approx(2 * 2 + 1, rel=1e-12)
    assert op["v(x1.out2)"] == pytest.approx(3 * 1, rel=1e-12)


# --- the limiter's complementarity in every step ---------------------------------------------

LIMITED_INTEGRATOR = """V1 in 0 PULSE(-1 1 0 1u 1u 0.5m 1m)
R1 in inv 50
C1 inv out 1u
{limiter}
.tran 1u 3m uic
"""
LIMITERS = [
    "B1 out 0 V={min(max(-1e5*v(inv), -2), 3)}",
    "E1 out 0 VALUE={limit(-1e5*v(inv), -2, 3)}",
    "A1 %vd(0 inv) out lim\n.model lim limit(gain=1e5 out_lower_limit=-2 out_upper_limit=3)",
]


def _trajectory(circuit):
    mlcs = circuit.mlcs()
    tran = circuit.analyses["tran"]
    grid = time_grid(tran.step, tran.stop, mlcs.breakpoints(tran.stop))
    state = uic_state(circuit, mlcs)
    return mlcs, integrate(mlcs, grid, state.y, state.charge, state.current, state.active,
                           state.switches, theta=1.0, tol=1e-9)


@pytest.mark.parametrize("limiter", LIMITERS)
def test_limiter_clamped_integrator_stays_within_its_rails_in_every_step(limiter):
    # An op-amp integrator (gain 1e5) whose output saturates at -2 V and 3 V: slope
    # -v(in)/(R C) = -+20 V/ms, so each 0.5 ms half period drives it into a rail (the
    # inverting node leaves virtual ground while the output sits on a rail). The rails
    # hold by complementarity in every step: each pair's multiplier and its gap are both
    # >= 0 and one of them is zero, to round-off; nothing is clamped afterwards.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuit_from(LIMITED_INTEGRATOR.format(limiter=limiter))
    mlcs, trajectory = _trajectory(circuit)
    assert mlcs.m == 2
    C = mlcs.C.toarray()
    gap = trajectory.y @ C.T + mlcs.e                       # D = 0
    multiplier = trajectory.current
    # round-off: relative to the terms that make up each gap (1e5·v(inv) reaches 1e5 V)
    roundoff = 64 * np.finfo(float).eps * (np.abs(trajectory.y) @ np.abs(C).T + np.abs(mlcs.e)
                                           + np.abs(multiplier))
    assert np.all(gap[1:] >= -roundoff[1:]) and np.all(multiplier[1:] >= -roundoff[1:])
    assert np.all(np.abs(np.minimum(gap, multiplier))[1:] <= roundoff[1:])
    out = trajectory.y[:, mlcs.unknowns.index("v(out)")]
    rail = 64 * np.finfo(float).eps * 1e5 * np.abs(trajectory.y[:, mlcs.unknowns.index("v(inv)")])
    assert np.all(out >= -2 - rail - 1e-15) and np.all(out <= 3 + rail + 1e-15)
    assert np.sum(np.isclose(out, 3, rtol=0, atol=1e-9)) > 100     # it does sit on each rail
    assert np.sum(np.isclose(out, -2, rtol=0, atol=1e-9)) > 100
    # between the rails it is the integrator: slope -v(in)/(R C) (finite gain: 1e-4 relative)
    slope = np.diff(out) / np.diff(trajectory.time)
    inside = (out[1:] > -1.99) & (out[1:] < 2.99) & (out[:-1] > -1.99) & (out[:-1] < 2.99)
    vin = trajectory.y[1:, mlcs.unknowns.index("v(in)")]
    steady = inside & (np.abs(vin) == 1)
    assert steady.sum() > 500
    np.testing.assert_allclose(slope[steady], -vin[steady] / (50 * 1e-6), rtol=2e-3)


def test_limited_xspice_integrator_stops_at_its_limits_without_windup():
    # int with limits: d out/dt = 1000·v(in) while inside [-0.2, 0.4]; at a limit the state
    # stops and leaves it as soon as v(in) changes sign (ngspice overwrites its state likewise)
    body = ("V1 in 0 PULSE(1 -1 1m 10u 10u 1m 2m)\nA1 in out integ\n"
            ".model integ int(gain=1000 out_ic=0 out_lower_limit=-0.2 out_upper_limit=0.4)\n"
            "R1 out 0 1k\n.tran 1u 4m uic")
    waves = waves_of(body)
    out, t = waves["v(out)"], waves.time
    assert out.max() <= 0.4 + 1e-12 and out.min() >= -0.2 - 1e-12
    # ramps of ±1 V/ms between the limits; the 10 µs edges of v(in) round the turns (5 mV)
    expected = np.interp(t, [0, 0.4e-3, 1.005e-3, 1.605e-3, 2.015e-3, 2.615e-3, 3.005e-3,
                             3.605e-3, 4e-3], [0, 0.4, 0.4, -0.2, -0.2, 0.4, 0.4, -0.2, -0.2])
    assert np.abs(out - expected).max() < 6e-3
    # with 1 ns edges the steps at the edges are 1 ns long: the limits still hold
    sharp = waves_of(body.replace("10u 10u", "1n 1n"))["v(out)"]
    assert sharp.max() <= 0.4 + 1e-12 and sharp.min() >= -0.2 - 1e-12


# --- refusals name the term ------------------------------------------------------------------

@pytest.mark.parametrize(
    ("expression", "term", "reason"),
    [
        ("3*foo(v(a))", "foo(v(a))", "unknown function"),
        ("ddt(abs(v(a)))", "ddt(abs(v(a)))", "ddt() of a min/max, comparator or ddt() value is nonlinear"),
        ("ddt(ddt(v(a)))", "ddt(ddt(v(a)))", "issue 33"),
        ("max(ddt(v(a)), 0)", "max(...)", "a max() of a ddt() term is nonlinear"),
        ("ddt(v(a)) > 1 ? 1 : 0", "(ddt(v(a))>1.0)", "involving ddt() is nonlinear"),
        ("ddt(v(a))*v(b)", "(ddt(v(a))*v(b))", "product of two unknowns"),
        ("v(a) + sqrt(-1)", "sqrt((-1.0))", "undefined for these constant arguments"),
    ],
)
@pytest.mark.parametrize("form", ["B1 o 0 V={{{}}}", "E1 o 0 VALUE={{{}}}", "G1 o 0 cur='{}'"])
def test_every_refused_expression_names_its_term(expression, term, reason, form):
    # (nonlinear terms are smooth relations now: tests/test_smooth_sources.py)
    line = form.format(expression)
    with pytest.raises(circuitnsds.NetlistError) as info:
        circuit_from(f"V1 a 0 1\nV2 b 0 2\nR1 a b 1k\n{line}\nRo o 0 1k\n.tran 1u 1m")
    message = str(info.value)
    assert "<text>:5:" in message
    assert f"cannot represent the term {term} of" in message
    assert reason in message
    assert "affine combinations of v(node)" in message          # what the engine does represent


@pytest.mark.parametrize(
    ("lines", "words"),
    [
        ("A1 a b c o ff\n.model ff d_jkff(clk_delay=1n)", ["a1", "d_jkff", "not supported"]),
        ("A1 a o h\n.model h slew(rise_slope=1)", ["a1", "slew", "not supported"]),
        ("A1 %i(a) o g\n.model g gain(gain=2)", ["a1", "%i", "not supported"]),
        ("A1 a o g\n.model g gain(gian=2)", ["unknown parameter 'gian'"]),
        ("A1 a o l\n.model l limit(gain=2)", ["needs out_lower_limit and out_upper_limit"]),
        ("A1 [a b] o g\n.model g gain(gain=2)", ["gain takes one input"]),
        ("A1 [a b] o s\n.model s summer(in_gain=[1 2 3])", ["in_gain", "3 values for 2 inputs"]),
        ("A1 a o nomodel", ["model 'nomodel' is not defined"]),
        ("B1 o 0 V={2*i(r1)}", ["i(r1)", "not a voltage source"]),
    ],
)
def test_unsupported_blocks_and_ports_are_refused_by_name(lines, words):
    with pytest.raises(circuitnsds.NetlistError) as info:
        circuit_from(f"V1 a 0 1\nV2 b 0 2\nR1 a b 1k\n{lines}\nRo o 0 1k\n.tran 1u 1m")
    message = str(info.value)
    for word in words:
        assert word in message


def test_limit_warns_that_ngspice_reads_it_otherwise():
    with pytest.warns(UserWarning, match=r"min\(max\(x, lo\), hi\)"):
        circuit_from("V1 a 0 1\nB1 o 0 V={limit(v(a), 0, 2)}\nRo o 0 1k\n.tran 1u 1m")


# --- the affine classifier (property) --------------------------------------------------------

coefficients = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False).filter(lambda c: abs(c) > 1e-3)
probes = st.sampled_from(["v(a)", "v(b)", "v(x1.mid)", "v(7)", "i(v1)", "i(x1.vs)"])


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(coefficients, probes, st.integers(0, 3)), min_size=1, max_size=6),
       st.floats(min_value=-1e3, max_value=1e3, allow_nan=False))
def test_random_affine_combinations_classify_with_their_coefficients(terms, constant):
    forms = ["{c!r}*{p}", "{p}*{c!r}", "-({m!r})*{p}", "{p}/({r!r})"]
    text = " + ".join(forms[k].format(c=c, p=p, m=-c, r=1 / c) for c, p, k in terms)
    text += f" - ({-constant!r})"
    value, auxiliaries = classify(text)
    assert auxiliaries == []
    expected: dict[tuple[str, str], float] = {}
    for c, probe, _ in terms:
        key = (probe[0], probe[2:-1])
        expected[key] = expected.get(key, 0.0) + c
    for key, c in expected.items():
        assert value.terms.get(key, 0.0) == pytest.approx(c, rel=1e-12, abs=1e-9)
    assert set(value.terms) <= set(expected)
    assert value.constant == pytest.approx(constant, rel=1e-12, abs=1e-12)


@given(coefficients, coefficients, coefficients)
def test_differential_probe_is_the_difference_of_two_node_voltages(c, lo, hi):
    # ground (0, gnd) contributes nothing
    value, _ = classify(f"{c!r}*v(a, b) + {lo!r}*v(0) + {hi!r}*v(b, gnd)")
    assert set(value.terms) <= {("v", "a"), ("v", "b")}
    assert value.terms[("v", "a")] == c
    assert value.terms.get(("v", "b"), 0.0) == pytest.approx(hi - c, abs=1e-12)
    assert value.constant == 0.0


# --- against ngspice --------------------------------------------------------------------------

NGSPICE_NETLIST = SOURCES + """B1 o1 0 V={2*v(a) - 0.5*v(a,b) + 300*i(vs) + 0.25}
R1 o1 0 1k
B2 o2 0 V={max(v(a), v(b)) - min(v(a), 0.5) + abs(v(b)) + uramp(v(a) - 1)}
R2 o2 0 1k
G1 0 o3 value={1m*v(a) - 2m*v(b)}
R3 o3 0 1k
A1 a o4 amp
.model amp gain(gain=2 in_offset=0.1 out_offset=-0.3)
A2 [a %vd(a b)] o5 sum
.model sum summer(in_gain=[1 -2] in_offset=[0 0.1] out_gain=0.5 out_offset=1)
A3 %v(a) o6 lim
.model lim limit(gain=3 out_lower_limit=-1 out_upper_limit=2)
A4 a o7 integ
.model integ int(gain=1000 out_ic=0.5 out_lower_limit=-1e12 out_upper_limit=1e12)
A5 a o8 integ2
.model integ2 int(gain=1000 out_ic=0.1 out_lower_limit=-0.2 out_upper_limit=0.4)
R4 o4 0 1k
R5 o5 0 1k
R6 o6 0 1k
R7 o7 0 1k
R8 o8 0 1k
.tran 1u 2m uic
.end
"""


@pytest.mark.ngspice
def test_blocks_agree_with_ngspice_running_the_same_netlist():
    from circuitnsds.compare import run_ngspice

    signals = [f"v(o{k})" for k in range(1, 9)]
    theirs = run_ngspice("ngspice\n" + NGSPICE_NETLIST, signals, 2e-3)
    assert theirs.ok, theirs.message
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours = circuitnsds.read_netlist("ours\n" + NGSPICE_NETLIST).transient(theta=0.5)
    for signal in signals:
        resampled = np.interp(ours.time, theirs.waveforms.time, theirs.waveforms[signal])
        error = np.abs(ours[signal] - resampled)[1:]             # t = 0: algebraic outputs unset (UIC)
        scale = np.ptp(ours[signal])
        if signal in {"v(o2)", "v(o6)"}:
            # kinks (min/max/abs, the limiter's corners) between ngspice's time points: linear
            # interpolation of its output misses them by up to slope x step (0.1 V for abs(v(b))
            # on its 0.2 V/µs edge); the RMS shows that the two agree elsewhere
            assert np.sqrt(np.mean(error**2)) < 3e-3 * scale, signal
        elif signal in {"v(o7)", "v(o8)"}:
            # integrators: ngspice's code model integrates its input one step apart from the
            # θ-method (gain·|in|·h = 2 mV at most); the limits hold in both
            assert error.max() < 2e-3 * scale, signal
        else:
            assert error.max() < 1e-5 * scale, signal


def _converter_figures(time, out, sw, start):
    """Time-averaged output [V], switching frequency [Hz] and duty cycle of v(sw) > 6 V
    (half the 12 V input) over ``time >= start``."""
    keep = time >= start
    t, v, on = time[keep], out[keep], sw[keep] > 6.0
    span = t[-1] - t[0]
    rising = t[1:][on[1:] & ~on[:-1]]
    duty = np.trapezoid(on.astype(float), t) / span
    return np.trapezoid(v, t) / span, 1.0 / np.diff(rising).mean(), duty


@pytest.mark.ngspice
def test_voltage_mode_buck_agrees_with_ngspice():
    # netlists/buck_voltage_mode.cir: the E-source op-amp with a min/max limiter closes the
    # loop; ngspice runs the same file with its smooth diode at N = 0.03 (h = 40 ns for both).
    # From 1.4 to 1.8 ms (after the 1 ms soft start) the mean output, the switching frequency
    # and the duty cycle agree within 1 % (measured: 1e-6, 3e-5 and 0.18 %; the duty cycle
    # differs by the diode's forward drop, which the loop compensates: 9.0 % at N = 1,
    # 0.87 % at N = 0.1).
    from circuitnsds.compare import compare
    from tests.conftest import NETLISTS

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = compare(NETLISTS / "buck_voltage_mode.cir", n=0.03, step=4e-8, stop=1.8e-3,
                             signals=["v(out)", "v(sw)"], ngspice_options="method=gear")
    run = comparison.run
    assert run.ok, run.ngspice.message
    ours, theirs = comparison.circuitnsds, run.ngspice.waveforms
    mean, frequency, duty = _converter_figures(ours.time, ours["v(out)"], ours["v(sw)"], 1.4e-3)
    assert mean == pytest.approx(5.0, rel=2e-3)             # the loop regulates to Vref·2
    assert frequency == pytest.approx(100e3, rel=1e-3)
    assert duty == pytest.approx(5.0 / 12.0, rel=0.01)      # ideal switch and diode: D = Vout/Vin
    figures = _converter_figures(theirs.time, theirs["v(out)"], theirs["v(sw)"], 1.4e-3)
    for name, value, reference in zip(("mean", "frequency", "duty"), figures, (mean, frequency, duty)):
        assert value == pytest.approx(reference, rel=0.01), name


@pytest.mark.parametrize(
    ("lines", "pattern"),
    [
        ("B1 o 0 {v(a)}", r"b1: expected V=\{expr\} or I=\{expr\} after the two nodes"),
        ("B1 o 0 V={k*v(a)}", r"b1: undefined parameter 'k'"),
        ("B1 o 0 V={v(a) + }", r"b1: syntax error"),
        ("B1 o 0 V={v(a)} tc1=1", r"instance parameters of behavioural sources are not supported"),
        ("E1 o 0 TABLE {v(a)} = (1, 0) (0, 1)", r"TABLE x values must increase"),
        ("E1 o 0 TABLE {v(a)} = (1, 0) (2)", r"TABLE needs \(x, y\) pairs"),
    ],
)
def test_malformed_behavioural_lines_name_the_line(lines, pattern):
    with pytest.raises(circuitnsds.NetlistError, match=pattern) as info:
        circuit_from(f"V1 a 0 1\n{lines}\nRo o 0 1k\n.tran 1u 1m")
    assert "<text>:3:" in str(info.value)


def test_unused_block_model_is_reported_with_its_kind():
    with pytest.warns(UserWarning, match=r"\.model g \(GAIN\) is not used"):
        circuit_from("V1 a 0 1\nR1 a 0 1k\n.model g gain(gain=2)\n.tran 1u 1m")


@pytest.mark.parametrize(("text", "value"), [
    ("10-3-2", 5.0), ("64/4/2", 8.0), ("2^3^2", 64.0), ("2**-1", 0.5), ("-2^2", -4.0),
    ("--3", 3.0), ("!!!0", 1.0), ("1<2==1", 1.0), ("0&&1||1", 1.0), ("1||0&&0", 1.0),
    ("0?1:0?2:3", 3.0), ("max(1, 2*3, 4)-1", 5.0),
])
def test_behavioural_tree_keeps_the_order_of_the_shared_parser(text, value):
    # behavioural.parse reuses netlist/expressions.py's parser and writes its chains of
    # left-associative operators as nested binary nodes: the text written back must keep the
    # meaning (hand-computed values, ngspice's precedence and left-associative ^).
    from circuitnsds.netlist.behavioural import parse, to_text
    from circuitnsds.netlist.expressions import evaluate

    assert evaluate(to_text(parse(text))) == value


def test_behavioural_probes_are_leaves_with_raw_names():
    from circuitnsds.netlist.behavioural import parse

    assert parse("V(X1.Mid, 1) - i(Vs)") == ("op", "-", ("v", "x1.mid", "1"), ("i", "vs"))


def test_ddt_of_a_capacitor_voltage_is_its_current_over_c_in_every_step():
    # ngspice's ddt-test3.cir: B2 22 0 v = ddt(V(2))/1000 on an RC (1 kΩ, 1 µF): ddt(v(2))/1000 =
    # i(C1)/(C·1000) = v(1,2)/(RC·1000) = v(1,2). Implicit Euler's step of the capacitor is the
    # same difference quotient as ddt's, so the identity holds at every step (before: "unknown
    # function ddt()")
    result = circuit_from("V1 1 0 PULSE(0 2 1u 1n 1n 100u 200u)\nR1 1 2 1k\nC1 2 0 1u\n"
                          "B2 22 0 v = ddt(V(2))/1000\nR22 22 0 1k\n.tran 1u 1m").transient()
    assert np.max(np.abs(result["v(22)"] - (result["v(1)"] - result["v(2)"]))) < 1e-9
    assert np.max(result["v(22)"]) > 1.5  # the edges show


def test_a_current_of_c_times_ddt_of_a_node_voltage_is_that_capacitor():
    base = "V1 in 0 PULSE(0 1 0 1u 1u 1m 2m)\nR1 in out 1k\n{}\n.options theta=0.5\n.tran 10u 3m"
    capacitor = circuit_from(base.format("C1 out 0 1u")).transient()
    behavioural = circuit_from(base.format("B1 out 0 I = {1u*ddt(v(out)) + 0*v(in)}")).transient()
    assert behavioural["v(out)"] == pytest.approx(capacitor["v(out)"], abs=1e-12)


@pytest.mark.parametrize(("condition", "truth"), [
    ("v(a) > 0 && v(b) > 0", lambda a, b: (a > 0) & (b > 0)),
    ("v(a) > 0 || v(b) > 0", lambda a, b: (a > 0) | (b > 0)),
    ("!(v(a) > 0) && v(b) < 0", lambda a, b: (a <= 0) & (b < 0)),
])
def test_conditions_of_and_or_not_are_chains_of_comparators(condition, truth):
    # ngspice's memristor.sp writes (f1(v) > 0) && (v(x) < Roff) ? ... (before: "a condition
    # that is not one comparison")
    result = circuit_from("V1 a 0 SIN(0 1 1k)\nV2 b 0 SIN(0 1 1.3k)\n"
                          f"B1 o 0 V={{({condition}) ? 2 : -1}}\nR1 o 0 1k\n.tran 1u 3m").transient()
    a, b, o = result["v(a)"], result["v(b)"], result["v(o)"]
    clear = (np.abs(a) > 0.01) & (np.abs(b) > 0.01)  # away from the thresholds' instants
    assert np.array_equal(o[clear], np.where(truth(a, b), 2.0, -1.0)[clear])


def test_a_func_inside_a_behavioural_expression_is_its_body_with_the_arguments_in_place():
    # ngspice's memristor.sp: .func f1(y)={beta*y+0.5*(alpha-beta)*(abs(y+Vt)-abs(y-Vt))} in a
    # B source (before: "unknown function f1()")
    result = circuit_from(".param beta=3 vt=0.5\n.func f1(y)={beta*y + 0.5*(1-beta)*(abs(y+vt)-abs(y-vt))}\n"
                          "V1 a 0 SIN(0 2 1k)\nB1 o 0 V={f1(v(a)) + 1}\nR1 o 0 1k\n.tran 1u 1m").transient()
    y = result["v(a)"]
    expected = 3 * y + 0.5 * (1 - 3) * (np.abs(y + 0.5) - np.abs(y - 0.5)) + 1
    assert result["v(o)"] == pytest.approx(expected, abs=1e-9)
