"""Nonlinear behavioural sources as smooth relations and the Newton stepper that integrates
them (issue 33): derivatives against finite differences, ngspice's meaning of the
functions, closed-form solutions (a capacitor discharged by a square-law sink, a diode law
at DC, a located switching), the choice of stepper, and agreement with ngspice 39 running
the same netlists (marker ``ngspice``)."""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import circuitnsds
from circuitnsds.errors import RunNote
from circuitnsds.netlist.behavioural import parse
from circuitnsds.netlist.smooth_expression import smooth_expression
from tests.conftest import circuit_from

# expression, the same as a Python function of (a, b, c) = (v(a), v(b), i(v1)) and t
EXPRESSIONS = [
    ("v(a)*v(b)", lambda a, b, c, t: a * b),
    ("exp(v(a)/2)*i(v1)", lambda a, b, c, t: math.exp(a / 2) * c),
    ("sqrt(v(a)+v(b))", lambda a, b, c, t: math.sqrt(a + b)),
    ("log(v(a))*v(b)**3", lambda a, b, c, t: math.log(a) * b**3),
    ("tanh(v(a)-v(b))*1e3", lambda a, b, c, t: math.tanh(a - b) * 1e3),
    ("pow(v(a), v(b))", lambda a, b, c, t: a**b),
    ("v(a)/v(b) - v(a,b)", lambda a, b, c, t: a / b - (a - b)),
    ("sin(v(a))*cos(i(v1)) + atan(v(a)*v(b))",
     lambda a, b, c, t: math.sin(a) * math.cos(c) + math.atan(a * b)),
    ("max(v(a), v(b))*v(a) + min(v(a), 2*v(b), 3)", lambda a, b, c, t: max(a, b) * a + min(a, 2 * b, 3)),
    ("abs(v(a)-1.3)*time", lambda a, b, c, t: abs(a - 1.3) * t),
    ("v(a) > v(b) ? v(a)^2 : -v(b)", lambda a, b, c, t: a**2 if a > b else -b),
    ("(v(a) > 1 && v(b) < 1.5) + 2*(v(a) < 0.7 || !(v(b) > 1))",
     lambda a, b, c, t: float(a > 1 and b < 1.5) + 2 * float(a < 0.7 or not b > 1)),
    ("cosh(v(b))/sinh(v(a)) + log10(i(v1))",
     lambda a, b, c, t: math.cosh(b) / math.sinh(a) + math.log10(c)),
]
POINT = st.tuples(*(st.floats(min_value=0.5, max_value=2.0) for _ in range(3)),
                  st.floats(min_value=0.0, max_value=1e-3))


def _values(expression, a, b, c):
    order = {("v", "a"): a, ("v", "b"): b, ("i", "v1"): c}
    return [order[key] for key in expression.inputs]


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(EXPRESSIONS), POINT)
def test_value_and_gradient_agree_with_the_formula_and_its_finite_differences(case, point):
    text, formula = case
    a, b, c, t = point
    expression = smooth_expression(parse(text))
    x = _values(expression, a, b, c)
    value, gradient = expression.evaluate(x, t)
    assert value == pytest.approx(formula(a, b, c, t), rel=1e-12, abs=1e-12)
    for k, key in enumerate(expression.inputs):
        step = 1e-6
        up, down = list(x), list(x)
        up[k] += step
        down[k] -= step
        plus, minus = expression.evaluate(up, t)[0], expression.evaluate(down, t)[0]
        if abs(plus - minus) > 1e3 * step * (1 + abs(gradient[k])):
            continue  # a jump (comparison) inside the difference: no derivative
        forward, backward = (plus - value) / step, (value - minus) / step
        if abs(forward - backward) > 1e-3 * (1 + abs(forward)):  # a kink (min/max, abs): one side's
            assert min(abs(gradient[k] - forward), abs(gradient[k] - backward)) < 1e-3 * (1 + abs(forward))
            continue
        assert gradient[k] == pytest.approx((plus - minus) / (2 * step), rel=1e-5, abs=1e-6), (text, key)


@pytest.mark.parametrize(("text", "value"), [
    ("(-2)^2", 4.0), ("(-8)**(1/3)", 2.0), ("pow(-8, 1/3)", 2.0),  # ngspice: |x|^y
    ("pwr(-2, 3)", -8.0), ("u(0)", 0.5), ("uramp(-1)", 0.0), ("temper", 27.0),
])
def test_functions_mean_what_they_mean_in_ngspice(text, value):
    assert smooth_expression(parse(text)).evaluate([], 0.0)[0] == pytest.approx(value, rel=1e-12)


def test_an_undefined_value_is_nan_not_an_exception():
    expression = smooth_expression(parse("sqrt(v(a)) + exp(v(b))"))
    assert math.isnan(expression.evaluate([-1.0, 0.0], 0.0)[0])
    assert math.isnan(expression.evaluate([1.0, 1e4], 0.0)[0])


def _run(body: str, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return circuit_from(body).transient(**kwargs)


SQUARE_LAW = """C1 x 0 1u ic=2
G1 x 0 cur={5e-4*v(x)*v(x)}
.tran 10u 5m uic
"""


def test_square_law_sink_discharges_the_capacitor_as_the_closed_form():
    # C v' = -k v²  =>  v(t) = v0 / (1 + k v0 t / C)
    waves = _run(SQUARE_LAW)
    exact = 2.0 / (1.0 + 5e-4 * 2.0 * waves.time / 1e-6)
    assert np.max(np.abs(waves["v(x)"] - exact)) < 0.01 * 2.0
    assert waves.stats["newton_iterations"] >= waves.stats["steps"]


def test_trapezoidal_newton_converges_at_second_order_on_the_closed_form():
    errors = []
    for step in (40e-6, 20e-6):
        waves = _run(SQUARE_LAW.replace("10u 5m", f"{step} 5m"), theta=0.5)
        exact = 2.0 / (1.0 + 5e-4 * 2.0 * waves.time / 1e-6)
        errors.append(np.max(np.abs(waves["v(x)"] - exact)))
    assert errors[1] < errors[0] / 2.5


def test_a_diode_law_at_dc_matches_the_transcendental_equation():
    # 5 V through 1 kΩ into I = Is (exp(v/Vt) - 1): plain Newton from 0 V does not reach it in
    # its iterations (it climbs down 25 mV per iteration from 5 V); gmin stepping does
    from scipy.optimize import brentq

    circuit = circuit_from("V1 in 0 5\nR1 in x 1k\nG1 x 0 cur={1e-14*(exp(v(x)/0.025)-1)}\n.tran 1u 10u")
    v = circuit.operating_point()["v(x)"]
    exact = brentq(lambda u: (5 - u) / 1e3 - 1e-14 * (math.exp(u / 0.025) - 1), 0.0, 1.0, xtol=1e-14)
    assert v == pytest.approx(exact, abs=1e-6)


def test_a_switch_controlled_by_a_smooth_circuit_switches_at_the_closed_form_instant():
    # C v' = -k v² from 2 V: v reaches 1 V at t* = C/k (1/1 - 1/2) = 1 ms; the switch closes then
    body = SQUARE_LAW + "S1 x y x 0 swm\nRy y 0 1meg\n.model swm sw(vt=1 vh=0.0 ron=1 roff=1e12)\n"
    body = body.replace("S1 x y x 0", "S1 y 0 0 x")  # control v(0) - v(x) > -1: v(x) < 1
    body = body.replace("vt=1 ", "vt=-1 ")
    waves = _run(body, theta=0.5)
    closing = [event.time for event in waves.events if event.element == "s1" and event.state]
    assert closing and closing[0] == pytest.approx(1e-3, rel=2e-3)


def test_theta_refuses_smooth_relations_and_names_newton():
    circuit = circuit_from(SQUARE_LAW)
    with pytest.raises(circuitnsds.CircuitError, match=r"g1 is a smooth nonlinear element.*method=newton"):
        circuit.transient(method="theta")


def test_a_transient_with_smooth_relations_picks_newton_and_says_so():
    with pytest.warns(RunNote, match=r"g1: smooth nonlinear element.*Newton stepper"):
        waves = circuit_from(SQUARE_LAW).transient()
    assert "newton_iterations" in waves.stats


def test_a_circuit_without_smooth_relations_keeps_the_theta_stepper():
    waves = _run("V1 in 0 1\nR1 in x 1k\nC1 x 0 1u\n.tran 10u 1m")
    assert "newton_iterations" not in waves.stats


# --- against ngspice --------------------------------------------------------------------------

NGSPICE_CASES = {
    "product": ("va a 0 sin(0 2 1k)\nvb b 0 sin(0.5 1 300)\nb1 out 0 v={v(a)*v(b)}\nr1 out 0 1k\n"
                ".tran 5u 4m", ["v(out)"], 1e-3),
    "multiplier into a rectifier": (
        "va a 0 sin(0 2 1k)\nvb b 0 sin(0 3 50)\nb1 m 0 v={v(a)*v(b)}\nr0 m p 10\nd1 p out dmod\n"
        "c1 out 0 10u\nr1 out 0 1k\n.model dmod d(is=1e-14 n=0.05)\n.tran 5u 20m",
        ["v(out)", "v(p)"], 0.01),
    "exponential source beside a switch": (
        "vin in 0 pulse(0 5 0 1u 1u 0.5m 1m)\nr1 in x 1k\ng1 x 0 cur={1e-12*(exp(v(x)/0.025)-1)}\n"
        "s1 x y ctl 0 swm\nvctl ctl 0 pulse(0 1 0.25m 1n 1n 0.25m 1m)\nr2 y 0 2k\nc1 x 0 10n\n"
        ".model swm sw(vt=0.5 ron=1 roff=1e9)\n.tran 2u 3m", ["v(x)", "i(vin)"], 0.03),
    "diode law into an RC": (
        "vin in 0 sin(0 3 2k)\nr1 in x 100\nb1 x 0 i={1e-12*(exp(v(x)/0.025)-1)}\nc1 x 0 100n\n"
        ".tran 2u 2m", ["v(x)", "i(vin)"], 0.02),
}


@pytest.mark.ngspice
@pytest.mark.parametrize("case", sorted(NGSPICE_CASES))
def test_nonlinear_sources_agree_with_ngspice(case):
    from circuitnsds.compare import run_ngspice

    body, signals, bound = NGSPICE_CASES[case]
    stop = circuit_from(body).analyses["tran"].stop
    theirs = run_ngspice(f"ngspice\n{body}\n.end\n", signals, stop)
    assert theirs.ok, theirs.message
    ours = _run(body)
    for signal in signals:
        resampled = np.interp(ours.time, theirs.waveforms.time, theirs.waveforms[signal])
        error = ours[signal] - resampled
        relative_rms = np.sqrt(np.mean(error**2)) / np.sqrt(np.mean(np.asarray(ours[signal]) ** 2))
        assert relative_rms < bound, (signal, relative_rms)


def test_ac_linearises_smooth_sources_at_the_operating_point():
    # out = vin²·vc: gain 2·vin·vc = 2 at vin = 0.5 V, vc = 2 V; a nonlinear conductance
    # I = k·v² fed from 3 V through 1 kΩ sits where v² + v − 3 = 0 (v = (√13 − 1)/2), its
    # small-signal conductance 2kv there, beside 1 µF: H = (1/1k)/(1/1k + 2kv + jωC)
    circuit = circuit_from("vin in 0 dc 0.5 ac 1\nvc c 0 dc 2\nb1 out 0 v={v(in)*v(c)*v(in)}\n"
                           "r1 out 0 1k\nvs s 0 dc 3\nrs s x 1k\ng1 x 0 cur={1e-3*v(x)*v(x)}\n"
                           "c1 x 0 1u")
    frequencies = np.array([1.0, 477.46, 1e5])
    result = circuit.ac(input="vin", outputs=["v(out)"], frequencies=frequencies)
    assert np.allclose(result.transfer["v(out)"], 2.0, rtol=1e-9)
    result = circuit.ac(input="vs", outputs=["v(x)"], frequencies=frequencies)
    v = (math.sqrt(13.0) - 1.0) / 2.0
    exact = 1e-3 / (1e-3 + 2e-3 * v + 2j * np.pi * frequencies * 1e-6)
    assert np.allclose(result.transfer["v(x)"], exact, rtol=1e-6)


def test_pss_through_a_square_law_load_returns_the_capacitor_s_charge_each_period():
    # before: pss refused the smooth relation ("pss cannot run through smooth ... (g1)"). On the
    # periodic orbit c1's charge comes back: over the implicit-Euler steps of a period, what
    # rs brings in equals what g1 takes out, Σ h·((v(s) − v(x))/1k − 1e-3·v(x)²) = 0
    circuit = circuit_from("vs s 0 sin(0 1 1k)\nrs s x 1k\ng1 x 0 cur={1e-3*v(x)*v(x)}\nc1 x 0 1u\n"
                           ".tran 10u 2m")
    result = circuit.pss(period=1e-3)
    waves = result.waveforms
    v_s, v_x = waves["v(s)"][1:], waves["v(x)"][1:]
    brought_in = np.sum(np.diff(waves.time) * (v_s - v_x) / 1e3)
    taken_out = np.sum(np.diff(waves.time) * 1e-3 * v_x**2)
    assert taken_out > 1e-8  # the load draws charge: the balance is not 0 = 0
    assert brought_in == pytest.approx(taken_out, rel=1e-6)


def test_info_says_which_elements_are_smooth_and_which_ideal():
    from circuitnsds.cli.info import circuit_report

    circuit = circuit_from("vin in 0 pulse(0 5 0 1u 1u 0.5m 1m)\nr1 in x 1k\n"
                           "g1 x 0 cur={1e-12*(exp(v(x)/0.025)-1)}\ns1 x y ctl 0 swm\n"
                           "vctl ctl 0 pulse(0 1 0.25m 1n 1n 0.25m 1m)\nr2 y 0 2k\nd1 y 0 dm\n"
                           ".model dm d(vfwd=0.7)\n.model swm sw(vt=0.5 ron=1 roff=1e9)\n.tran 2u 1m")
    text, _ = circuit_report(circuit)
    assert "smooth:   g1: smooth nonlinear element(s)" in text and "Newton stepper" in text
    assert "ideal:    s1, d1: complementarity pairs and switches" in text
    # the stepper the run takes without .options method (info named theta, "which cannot run it")
    assert re.search(r"^method: +newton \(taken by itself for the smooth nonlinear elements\)$", text,
                     re.MULTILINE)
    assert re.search(r"cost: +the first step \([\d.]+ [nµ]s\) from the starting point took [1-9]\d* Newton "
                     r"iteration\(s\), \d+ µs each", text)


def test_the_run_summary_gives_iterations_per_step_and_time_per_iteration():
    from circuitnsds.cli.main import newton_summary

    waves = _run(SQUARE_LAW)
    summary = newton_summary(waves.stats)
    per_step = waves.stats["newton_iterations"] / waves.stats["steps"]
    assert f"Newton: {per_step:.2f} iterations per step" in summary and "µs per iteration" in summary
    assert newton_summary(_run("V1 in 0 1\nR1 in x 1k\nC1 x 0 1u\n.tran 10u 1m").stats) == ""


def test_a_run_in_parts_is_the_run_in_one_part():
    # the stepper contract: the same arithmetic, bit for bit, whatever the parts (its step
    # length and truncation-error history carry over from one part to the next)
    from circuitnsds.engine.driver import drive
    from circuitnsds.engine.newton_stepper import NewtonStepper
    from circuitnsds.engine.stepper import StartState
    from circuitnsds.engine.timegrid import time_grid

    circuit = circuit_from(NGSPICE_CASES["exponential source beside a switch"][0])
    mlcs = circuit.mlcs()
    grid = time_grid(2e-6, 1.2e-3, mlcs.breakpoints(1.2e-3))
    class Keep:
        def __init__(self):
            self.rows = []

        def record(self, trajectory, first):
            self.rows.append(trajectory.y[first:].copy())

    runs = []
    for part_steps in (None, 37):
        keep = Keep()
        drive(NewtonStepper(mlcs), grid, StartState(np.zeros(mlcs.n)), keep, part_steps=part_steps)
        runs.append(np.vstack(keep.rows))
    assert np.array_equal(runs[0], runs[1])


def _period_means(time: np.ndarray, values: np.ndarray, period: float, stop: float) -> np.ndarray:
    """The mean of ``values`` over each switching period up to ``stop`` (trapezoids)."""
    edges = np.arange(0.0, stop + 0.5 * period, period)
    fine = np.linspace(0.0, stop, int(round(stop / period)) * 200 + 1)
    sampled = np.interp(fine, time, values)
    return np.array([np.trapezoid(sampled[(fine >= a) & (fine <= b)], fine[(fine >= a) & (fine <= b)])
                     / (b - a) for a, b in zip(edges[:-1], edges[1:])])


@pytest.mark.ngspice
def test_the_average_current_mode_pfc_agrees_with_ngspice(netlists):
    # netlists/smooth/pfc_boost_acm.cir: the multiplier |v(l, n)|·v(ea) sets the inductor
    # current's reference; its first 2 ms (the current rising with the line voltage) against
    # ngspice: the output, the error amplifier and the inductor current averaged over each
    # 50 µs switching period (what the current loop controls; the ripple's phase inside a
    # period depends on each simulator's instants)
    from circuitnsds.compare import run_ngspice

    path = netlists / "smooth" / "pfc_boost_acm.cir"
    stop, period = 2e-3, 50e-6
    signals = ["v(out)", "v(ea)", "i(vsense)"]
    theirs = run_ngspice(path.read_text(), signals, stop)
    assert theirs.ok, theirs.message
    with warnings.catch_warnings():  # (the diodes' fit fixed to 10 A: no refitted rerun)
        warnings.simplefilter("ignore")
        text = path.read_text().replace("\n.end", "\n.options pwlfit=10\n.end")
        ours = circuitnsds.read_netlist(text).transient(stop=stop)
    for signal in signals:
        mine = _period_means(ours.time, np.asarray(ours[signal]), period, stop)
        other = _period_means(theirs.waveforms.time, np.asarray(theirs.waveforms[signal]), period, stop)
        relative_rms = np.sqrt(np.mean((mine - other) ** 2)) / np.sqrt(np.mean(mine**2))
        assert relative_rms < 0.05, (signal, relative_rms)


# --- the interface the smooth devices stamp (system/smooth.py): charges and limiting ------------

def _one_node_system(relation_of, current: float = 0.0, conductance: float = 0.0):
    """An MLCS of one node ``x`` fed by ``current`` [A] (a source) with ``conductance`` [S] to
    ground and the smooth relation ``relation_of(x)``."""
    from circuitnsds.system.mlcs import MLCSBuilder
    from circuitnsds.system.stimuli import Dc

    builder = MLCSBuilder(["x"])
    x = builder.node("x")
    if current:
        builder.add("S", x, builder.stimulus(Dc(current), "i1"), 1.0)
    if conductance:
        builder.add("A", x, x, -conductance)
    builder.smooth(relation_of(x))
    return builder.build()


def test_a_nonlinear_charge_charged_by_a_constant_current_follows_its_closed_form():
    # q(v) = C0 v + a v³ charged by I: q(t) = I t, so v(t) is the real root of a v³ + C0 v − I t
    from circuitnsds.engine.driver import drive
    from circuitnsds.engine.newton_stepper import NewtonStepper
    from circuitnsds.engine.stepper import StartState
    from circuitnsds.system.smooth import SmoothRelation

    c0, a, current = 1e-6, 2e-7, 1e-3

    def evaluate(x, t):
        v = x[0]
        return (np.zeros(1), np.zeros((1, 1)), np.array([c0 * v + a * v**3]),
                np.array([[c0 + 3 * a * v * v]]))

    mlcs = _one_node_system(lambda x: SmoothRelation("cnl", (x,), (x,), evaluate, charges=True),
                            current=current)
    grid = np.linspace(0.0, 5e-3, 101)

    class Keep:
        def record(self, trajectory, first):
            self.trajectory = trajectory

    keep = Keep()
    drive(NewtonStepper(mlcs, theta=0.5), grid, StartState(np.zeros(1)), keep)
    exact = [np.real([r for r in np.roots([a, 0.0, c0, -current * t]) if abs(r.imag) < 1e-9][0])
             for t in grid]
    assert np.max(np.abs(keep.trajectory.y[:, 0] - exact)) < 1e-3 * max(exact)


def test_junction_limiting_is_applied_and_reaches_the_same_point():
    # a diode law fed by 5 mA through nothing else: v = Vt ln(1 + I/Is); the relation's limit
    # (a pnjlim-like step: at most 2 Vt up per iteration beyond the last point) is used by the
    # DC Newton, which then reaches the root without overflowing exp()
    from circuitnsds.engine.newton_dc import smooth_operating_point
    from circuitnsds.system.smooth import SmoothRelation

    vt, saturation, current = 0.025, 1e-14, 5e-3
    calls = []

    def evaluate(x, t):
        e = math.exp(x[0] / vt)
        return (np.array([saturation * (e - 1.0)]), np.array([[saturation * e / vt]]),
                np.zeros(1), np.zeros((1, 1)))

    def limit(new, old):
        calls.append((float(new[0]), float(old[0])))
        return np.minimum(new, old + 2 * vt) if new[0] > 0.3 else new

    mlcs = _one_node_system(lambda x: SmoothRelation("dj", (x,), (x,), evaluate, limit=limit),
                            current=current, conductance=1e-12)
    result = smooth_operating_point(mlcs, (), [])
    assert calls and any(new > old + 2 * vt for new, old in calls)     # it did limit
    assert result.y[0] == pytest.approx(vt * math.log1p(current / saturation), abs=1e-6)


def test_a_run_kept_in_parts_counts_its_steps_once(monkeypatch):
    import circuitnsds.analyses.recorders as recorders

    body = NGSPICE_CASES["exponential source beside a switch"][0]
    whole = _run(body)
    monkeypatch.setattr(recorders.SignalRecorder, "part_steps", lambda self: 97)  # 16 parts
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from circuitnsds.analyses.transient import run_transient, transient_spec

        circuit = circuit_from(body)
        kept = run_transient(circuit, transient_spec(circuit), signals=["v(x)"])
    assert np.array_equal(kept["v(x)"], whole["v(x)"])
    for key in ("steps", "newton_iterations", "events"):
        assert kept.stats[key] == whole.stats[key], key


def test_the_command_line_summary_names_the_newton_stepper(tmp_path, capsys):
    # it said "11512 θ-method steps" for the NPN netlist the Newton stepper had run
    from circuitnsds.cli.main import main

    netlist = tmp_path / "square.cir"
    netlist.write_text(f"square law\n{SQUARE_LAW}\n.end\n")
    assert main(["run", str(netlist), "-o", str(tmp_path / "out.csv")]) == 0
    summary = capsys.readouterr().err
    assert re.search(r"circuitnsds: \d+ Newton-stepper steps in .*Newton: [\d.]+ iterations per step",
                     summary), summary
    assert "θ-method" not in summary.split("\n")[0]
