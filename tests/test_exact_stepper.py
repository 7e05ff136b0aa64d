"""The exact integrator as a stepper (issue 31): chosen by ``method=exact`` (or ``auto``), its
rows at the grid's points exact against closed forms through the run path, its impulses the
charge of each interval, its diode events listed, a run in parts the run in one part, and a
sliding control handed to the θ-method."""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

import circuitnsds
from circuitnsds.analyses.operating_point import operating_point
from circuitnsds.analyses.recorders import TrajectoryRecorder
from circuitnsds.engine.driver import drive
from circuitnsds.engine.exact.charge import interval_integrals
from circuitnsds.engine.exact.exppoly import ExpPoly
from circuitnsds.engine.exact.stepper import ExactStepper
from circuitnsds.engine.stepper import choose_stepper
from circuitnsds.engine.timegrid import time_grid
from circuitnsds.errors import RunNote
from circuitnsds.system.smooth import SmoothRelation
from tests.conftest import NETLISTS, circuit_from

RC_SWITCH = """rc triggered switch
V1 in 0 10
R1 in c 1k
C1 c 0 1u
S1 out 0 c 0 sw
V2 a 0 5
R2 a out 1k
.model sw SW(VT=5 RON=1 ROFF=1e9)
.tran 10u 2m uic
.end
"""

DISCHARGE = """inductor discharging into 5 V through an ideal diode, 1 kohm across it
L1 0 a 1m IC=2
D1 a out dideal
Vo out 0 5
R1 a 0 1k
.model dideal D
.tran 1u 1m uic
.end
"""


def _exact(netlist: str, **settings):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RunNote)
        return circuitnsds.read_netlist(netlist).transient(method="exact", **settings)


def test_an_rc_triggered_switch_closes_at_its_closed_form_instant_through_the_run():
    circuit = circuitnsds.read_netlist(RC_SWITCH)
    threshold = circuit.mlcs().switches[0].on_threshold  # VT and ngspice's round-off margin
    waves = _exact(RC_SWITCH)
    (event,) = waves.events
    instant = -1e-3 * math.log(1 - threshold / 10)  # 10 V (1 - e^{-t/RC}) = threshold
    assert event.element == "s1" and event.state
    assert abs(event.time - instant) < 1e-8 * instant
    t = waves.time
    assert np.max(np.abs(waves["v(c)"] - 10 * (1 - np.exp(-t / 1e-3)))) < 1e-12


def test_a_dcm_diode_turns_off_at_its_closed_form_instant_and_its_charge_is_the_integral():
    waves = _exact(DISCHARGE)
    assert [(e.element, e.state) for e in waves.events] == [("d1", True), ("d1", False)]
    t_off = 1e-3 * (2 - 5 / 1e3) / 5  # L di/dt = -5 V until the diode's current i - 5 mA is 0
    assert abs(waves.events[1].time - t_off) < 1e-9 * t_off
    # the diode's impulses are its charge per interval: in all ∫ (1.995 A - 5000 A/s t) dt
    charge = 1.995 * t_off - 2500 * t_off**2
    assert abs(np.sum(waves.impulse("d1")) - charge) < 1e-12 * charge
    # and interval by interval (a row before the turn-off: 1 µs of a straight line)
    k = 100
    t0, t1 = waves.time[k - 1], waves.time[k]
    assert waves.impulse("d1")[k] == pytest.approx(1.995 * (t1 - t0) - 2500 * (t1**2 - t0**2), rel=1e-12)


def test_the_buck_in_parts_is_the_buck_in_one_part_bit_for_bit():
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    mlcs = circuit.mlcs()
    start = operating_point(circuit, mlcs)
    grid = time_grid(0.1e-6, 0.1e-3, mlcs.breakpoints(0.1e-3))

    whole = TrajectoryRecorder()
    drive(ExactStepper(mlcs), grid, start, whole)
    parts = _Concatenated()
    drive(ExactStepper(mlcs), grid, start, parts, part_steps=37)
    one = whole.trajectory
    for name in ("y", "current", "impulse", "active", "switches", "exact_rows"):
        np.testing.assert_array_equal(parts.arrays[name], getattr(one, name))
    assert parts.events == one.events
    # the diode turns on as S1 opens (k·10 µs + 5.005 µs) and off as it closes (5 ns later)
    assert sum(e.element == "d1" for e in one.events) == 19


class _Concatenated:
    """A recorder joining the parts' new rows."""

    def __init__(self):
        self.arrays: dict[str, np.ndarray] = {}
        self.events: list = []

    def record(self, trajectory, first):
        for name in ("y", "current", "impulse", "active", "switches", "exact_rows"):
            rows = getattr(trajectory, name)[first:].copy()
            self.arrays[name] = rows if name not in self.arrays else np.concatenate([self.arrays[name], rows])
        self.events += [e for e in trajectory.events if e not in self.events]


def test_theta_converges_at_first_order_to_the_exact_stepper():
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    exact = _exact(NETLISTS / "buck_converter.cir", step=0.1e-6, stop=0.3e-3)
    differences = []
    for step in (1e-7, 1e-8):
        theta = circuit.transient(step=step, stop=0.3e-3, method="theta")  # (θ, whatever the default)
        differences.append([np.max(np.abs(np.interp(exact.time, theta.time, theta[name]) - exact[name]))
                            for name in ("v(out)", "i(l1)")])
    coarse, fine = np.array(differences)
    assert np.all(coarse < 0.02)
    assert np.all((coarse / fine > 8) & (coarse / fine < 12))


SLIDING = """comparator without hysteresis holding a capacitor at its 1 V threshold
V1 in 0 2
R1 in a 1k
S1 a c 0 c sw
C1 c 0 1u
R2 c 0 10k
.model sw SW(VT=-1 VH=0 RON=1 ROFF=1e9)
.tran 10u 3m uic
.end
"""


def test_a_comparator_sliding_on_its_threshold_fails_as_the_theta_method_does():
    # S1 closes while v(c) < 1 V; at 1 V each state drives v(c) back across the threshold (a
    # sliding mode, no finite sequence of events). The exact loop finds no mode that holds
    # and hands the stretch to the θ-method, which stops with its chattering error naming
    # the switch: an error, as with θ alone, not a run that never ends or a wrong answer.
    with pytest.raises(circuitnsds.SimulationError, match=r"switch s1 chatters"):
        circuitnsds.read_netlist(SLIDING).transient(method="exact")


PEAK = """peak detector: an ideal diode charging a capacitor straight from a sine
V1 in 0 SIN(0 5 1k)
D1 in c dideal
C1 c 0 1u
R1 c 0 10k
.model dideal D
.tran 5u 2.5m
.end
"""


def test_a_capacitor_held_to_a_source_by_a_diode_goes_to_theta_and_back():
    # While D1 conducts, C1 sits across V1 (index 2: no state equations); the θ-method takes
    # those stretches (16 grid steps, doubled while the exact loop fails at once: 0.08, 0.16,
    # 0.32 ms). Once D1 blocks, the exact loop is back: C1 decays through R1 as v e^{-Δt/RC}.
    with pytest.warns(RunNote, match=r"handed to the θ-method, the first at t = 0 s \(a mode without "
                      r"state equations \(index 2: a capacitor held to a source"):
        waves = circuitnsds.read_netlist(PEAK).transient(method="exact")
    assert waves.stats["handoffs"] >= 2 and 0 < waves.stats["theta_steps"] < waves.time.size / 2
    t, vc = waves.time, np.asarray(waves["v(c)"])
    theta = circuitnsds.read_netlist(PEAK).transient(method="theta")
    conducting = np.asarray(theta.impulse("d1")) > 0
    # while it conducts, v(c) is the source's value at the point (θ's algebraic rows)
    assert np.max(np.abs(vc[conducting] - 5 * np.sin(2e3 * math.pi * t[conducting]))) < 1e-9
    blocking = (t > 0.7e-3) & (t < 1.1e-3) & ~conducting
    first = int(np.flatnonzero(blocking)[0])
    decay = vc[first] * np.exp(-(t[blocking] - t[first]) / 1e-2)
    # (and the blocking diode's 1 TΩ: a few pA, 3e-9 V over these 0.4 ms)
    assert np.max(np.abs(vc[blocking] - decay)) < 1e-8


def test_the_xspice_buck_s_diode_at_its_threshold_at_start_up_does_not_chatter():
    # the XSPICE voltage-mode buck at start-up: the open switch's 1e9 Ω leaks 12 nA and the
    # freewheeling diode sits at its threshold; the exact loop turned it on and off every 2 ps
    # for 8 µs (4.1 million events, 77 s), then, with the floor of run.CHATTERING, handed 5
    # stretches to θ. The turn-ons were false: the modal sum at τ = 0 missed the mode's
    # algebraic values by 1e-6 of its parasitic part (mode.vector_gap, now in the round-off).
    # Now one hand-off, its limiter's at the start, and the settled output is θ's to 1e-4 V
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_voltage_mode_xspice.cir")
    with pytest.warns(RunNote, match=r"1 stretch\(es\) handed to the θ-method, the first at t = 8\.0\d*e-13"):
        waves = circuit.transient(method="exact", signals=["v(out)"])
    assert waves.stats["handoffs"] == 1 and len(waves.events) < 2_000
    theta = circuit.transient(method="theta", signals=["v(out)"])
    settled = waves.time >= 1.8e-3
    assert np.mean(waves["v(out)"][settled]) == pytest.approx(np.mean(theta["v(out)"][settled]), abs=1e-4)


AT_REST_BEHIND_ROFF = """V1 in 0 DC 10
Vctl ctl 0 PULSE(0 1 30u 1n 1n 20u 1)
S1 in a ctl 0 sw
R1 a b 0.1
L1 b c {inductance}
C1 c 0 1u
D1 0 b dfw
Rc c 0 1k
.model sw SW(VT=0.5 VH=0 RON=10m ROFF=1e9)
.model dfw D(Ron=1m)
.tran 50n 60u"""


@pytest.mark.parametrize("inductance", ["1u", "100u"])
def test_a_circuit_at_rest_through_an_open_switch_s_roff_runs_exactly(inductance):
    # Before S1 closes at 30 us the circuit rests on the open switch's 1e9 ohm: 10 nA through
    # L1 into Rc, v(c) = v(b) = 10 V * 1k / (1e9 + 1k) = 1e-5 V, D1 blocking at +1e-5 V. The
    # mode's parasitic part (L1 through 1e9 ohm) has eigenpairs known to 1e-6 of themselves, and
    # the modal sum at tau = 0 put D1 at -1e-5 V: no mode held, and the rest went to theta (6
    # hand-offs, "a sliding or chattering control"). The gap to the mode's algebraic values
    # (mode.vector_gap) is now in the round-off: no hand-off, and the rest is the rest.
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        waves = circuit_from(AT_REST_BEHIND_ROFF.format(inductance=inductance)).transient(method="exact")
    assert waves.stats["handoffs"] == 0
    assert not [w for w in said if "handed to the" in str(w.message)]
    resting = waves.time < 30e-6
    rest = np.asarray(waves["v(c)"])[resting]
    assert rest[0] == pytest.approx(10.0 * 1e3 / (1e9 + 0.1 + 1e3), rel=1e-6)
    assert np.abs(rest - rest[0]).max() < 1e-12  # (it rests: 3e-13 V of drift over 30 us)
    assert np.abs(waves["i(d1)"][resting]).max() < 1e-15  # (blocking: its Roff leaks 1e-17 A)
    assert waves["v(c)"][-1] > 5.0  # (S1 closed at 30 us, rang the tank up; D1 freewheels after 50 us)


def test_auto_takes_exact_where_it_qualifies_and_says_why_theta_otherwise():
    buck = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    chosen, why = choose_stepper("auto", buck.mlcs())
    assert chosen is ExactStepper and "piecewise linear" in why
    with pytest.warns(RunNote, match=r"exact event-driven method \(method=auto.*TSTEP sets the rows "
                      r"reported, not the accuracy"):
        auto = buck.transient(step=0.1e-6, stop=20e-6, method="auto")
    exact = _exact(NETLISTS / "buck_converter.cir", step=0.1e-6, stop=20e-6)
    np.testing.assert_array_equal(auto["v(out)"], exact["v(out)"])
    with pytest.warns(RunNote, match=r"θ-method \(method=auto: the exact integrator cannot run it: "
                      r"it has 2\d\d unknowns"):
        circuitnsds.read_netlist(_ladder(210)).transient(method="auto")


def _ladder(sections: int) -> str:
    lines = ["RC ladder", "V1 n0 0 PULSE(0 1 0 1u 1u 1 2)"]
    for k in range(1, sections + 1):
        lines += [f"R{k} n{k - 1} n{k} 1k", f"C{k} n{k} 0 1n"]
    return "\n".join([*lines, ".tran 1u 5u", ".end", ""])


def test_exact_refuses_smooth_relations_naming_them():
    mlcs = circuitnsds.read_netlist(RC_SWITCH).mlcs()
    smooth = replace(mlcs, smooth=[SmoothRelation("q1", (0,), (0,), lambda y, t: None)])
    assert ExactStepper.unsuited(mlcs) is None
    assert ExactStepper.unsuited(smooth) == ("it has smooth nonlinear elements (q1), which are not "
                                             "piecewise linear")


@pytest.mark.parametrize("default", ["theta", "auto"])
def test_info_says_which_method_a_run_would_use_and_why(tmp_path, capsys, monkeypatch, default):
    from circuitnsds.engine import stepper
    from tests.test_info import run_info

    monkeypatch.setattr(stepper, "DEFAULT_STEPPER", default)  # (either default, the words of each)
    auto = (NETLISTS / "buck_converter.cir").read_text().replace(".end", ".options method=auto\n.end")
    _, out, _ = run_info(tmp_path, capsys, auto)
    assert ("method:    exact, event-driven (.tran TSTEP sets the rows reported, not the accuracy) "
            "(method=auto: the circuit is piecewise linear and its sources have closed forms)") in out
    _, out, _ = run_info(tmp_path, capsys, path=NETLISTS / "buck_converter.cir")
    assert ("method:    the θ-method (the default; .options method=auto would integrate this circuit "
            "exactly, its switching instants located, slower to start)\n" if default == "theta" else
            "method:    exact, event-driven (.tran TSTEP sets the rows reported, not the accuracy) "
            "(the default, method=auto: the circuit is piecewise linear and its sources have closed "
            "forms)\n") in out
    if default == "auto":  # θ where the exact integrator cannot run the circuit, and why
        am = "am\nV1 a 0 AM(1 0 1k 10 0)\nR1 a 0 1\n.tran 1u 1m\n.end\n"
        _, out, _ = run_info(tmp_path, capsys, am)
        assert ("method:    the θ-method (the default, method=auto: the exact integrator cannot run "
                "it: its source(s) v1 (AM) have no closed form it integrates") in out
    _, out, _ = run_info(tmp_path, capsys, _ladder(210).replace(".end", ".options method=auto\n.end"))
    assert re.search(r"method:    the θ-method \(method=auto: the exact integrator cannot run it: it has "
                     r"2\d\d unknowns and 0 pairs, more than the 200", out)


FLYBACK = NETLISTS.parent / "benchmarks" / "netlists" / "flyback_rcd.cir"


def test_the_flyback_clamp_at_its_netlists_step_is_the_converged_value():
    # The converged clamp voltage v(clamp) - v(in) at 0.3 ms, from the θ-method's first-order
    # Richardson extrapolation at 0.25 and 0.125 ns (33.2130621 and 33.2409165 V, measured):
    # 33.26877 V. θ at the netlist's 0.2 µs gives 17.34 V; the exact run at that step is the
    # converged value (measured 33.26882 V, 1.4e-6 of it; the issue asks for 0.1 %).
    waves = _exact(FLYBACK, stop=0.3e-3, signals=["v(clamp)", "v(in)"])
    clamp = float(waves["v(clamp)"][-1] - waves["v(in)"][-1])
    assert abs(clamp - 33.26877) < 1e-4 * 33.26877
    # the exact integrator ran it all but the first 16 grid steps: at t = 0 every diode is at
    # 0 V and 0 A, and the leakages (1e-12 A) decide no mode, so θ starts it
    assert waves.stats["handoffs"] <= 1 and waves.stats["theta_steps"] <= 16


def test_theta_converges_at_first_order_to_the_exact_flyback():
    # half the step, half the difference, in every state (the secondary diode turning on
    # 5 ns late or the primary's slow eigenvalue off by eps·|F| made it level off)
    exact = _exact(FLYBACK, step=0.1e-6, stop=30e-6)
    circuit = circuitnsds.read_netlist(FLYBACK)
    differences = []
    for step in (2e-9, 1e-9):
        theta = circuit.transient(step=step, stop=30e-6, method="theta")  # (θ, whatever the default)
        differences.append([np.max(np.abs(np.interp(exact.time, theta.time, theta[name]) - exact[name]))
                            for name in ("v(clamp)", "v(out)", "i(lp)", "i(ls)")])
    coarse, fine = np.array(differences)
    assert np.all((coarse / fine > 1.8) & (coarse / fine < 2.3)), coarse / fine


# (a coefficient near the subnormal range integrates to a subnormal charge, which holds no
# relative precision to compare: 7.3e-305 over a microsecond failed once)
_charge_coefficient = st.floats(-3, 3).filter(lambda c: c == 0.0 or abs(c) > 1e-100)
_charge_term = st.tuples(_charge_coefficient, _charge_coefficient, st.integers(0, 2),
                         st.sampled_from([0.0, -1e-9, -20.0, -3e3, -1e6]), st.sampled_from([0.0, 0.0, 5e3]))


@settings(max_examples=25, deadline=None)
@given(st.lists(_charge_term, min_size=1, max_size=4), st.floats(0, 2e-3), st.floats(1e-9, 1e-3),
       st.floats(0.1, 0.9))
def test_the_interval_charges_are_the_integral_and_add_up(terms, a, width, split):
    # the closed form against scipy's adaptive quadrature, and ∫_a^b = ∫_a^m + ∫_m^b (the
    # charge of an interval cut by an event is the sum of its segments')
    coefficients = np.array([[complex(re, im)] for re, im, *_ in terms])
    powers = np.array([p for _, _, p, _, _ in terms])
    exponents = np.array([complex(real, imag) for *_, real, imag in terms])
    f = ExpPoly(coefficients, powers, exponents)
    b, m = a + width, a + split * width
    whole = interval_integrals(f, np.array([a]), np.array([b]))[0, 0]
    reference, error = quad(lambda t: float(f(t)[0]), a, b, epsabs=1e-16, epsrel=1e-12, limit=100)
    scale = float(np.sum(np.abs(coefficients))) * width * max(1.0, b) ** 2
    assert abs(whole - reference) <= 1e-9 * scale + 10 * error
    parts = interval_integrals(f, np.array([a, m]), np.array([m, b]))[:, 0]
    assert abs(parts.sum() - whole) <= 1e-12 * scale


def test_the_run_summary_says_the_theta_method_ran(tmp_path, capsys):
    from circuitnsds.cli.main import main
    from tests.conftest import pinned_copy

    netlist = str(pinned_copy(NETLISTS / "buck_converter.cir", tmp_path))  # (θ named)
    assert main(["run", netlist, "--stop", "2u", "-o", str(tmp_path / "out.csv")]) == 0
    err = capsys.readouterr().err
    assert re.search(r"circuitnsds: \d+ θ-method steps in ", err) and "method=" not in err


def test_the_run_summary_says_which_method_the_default_auto_took_and_why(tmp_path, capsys,
                                                                        monkeypatch):
    """With auto the default, the summary line says which stepper ran and why; no note (every
    run of the default would carry one), unless the exact loop handed a stretch to θ."""
    from circuitnsds.analyses import transient
    from circuitnsds.cli.main import main
    from circuitnsds.engine import stepper

    for module in (stepper, transient):
        monkeypatch.setattr(module, "DEFAULT_STEPPER", "auto")
    netlist = str(NETLISTS / "buck_converter.cir")
    assert main(["run", netlist, "--stop", "2u", "-o", str(tmp_path / "out.csv")]) == 0
    err = capsys.readouterr().err
    assert re.search(r"circuitnsds: \d+ rows from \d+ exact segments \(\d+ events located\) in .*; "
                     r"method=auto \(the default\): the circuit is piecewise linear and its sources "
                     r"have closed forms; .tran TSTEP sets the rows reported, not the accuracy", err)
    assert "note:" not in err
    am = tmp_path / "am.cir"
    am.write_text("am\nV1 a 0 AM(1 0 1k 10 0)\nR1 a 0 1\n.tran 1u 1m\n.end\n")
    assert main(["run", str(am), "-o", str(tmp_path / "out.csv")]) == 0
    err = capsys.readouterr().err
    assert re.search(r"circuitnsds: 1000 θ-method steps in .*; method=auto \(the default\): the "
                     r"exact integrator cannot run it: its source\(s\) v1 \(AM\) have no closed form", err)
    assert "note:" not in err
    peak = tmp_path / "peak.cir"  # a hand-off to θ is still noted
    peak.write_text(PEAK)
    assert main(["run", str(peak), "-o", str(tmp_path / "out.csv")]) == 0
    err = capsys.readouterr().err
    assert "stretch(es) of the exact integration handed to the θ-method, the first at t = 0 s" in err


def test_the_run_summary_counts_rows_segments_and_events(tmp_path, capsys):
    from circuitnsds.cli.main import main

    path = tmp_path / "discharge.cir"
    path.write_text(DISCHARGE.replace(".end", ".options method=exact\n.end"))
    assert main(["run", str(path), "-o", str(tmp_path / "out.csv")]) == 0
    err = capsys.readouterr().err
    assert "1000 rows from 2 exact segments (2 events located) in" in err
    assert "TSTEP sets the rows reported, not the accuracy" in err


def test_a_run_with_hand_offs_to_theta_in_parts_is_the_run_in_one_part():
    # the peak detector's θ stretches (16, 32, 64 steps, ...) cut by parts of 7 steps: the
    # stretches share one θ stepping state, and the doubling is the stepper's, not a part's
    circuit = circuitnsds.read_netlist(PEAK)
    mlcs = circuit.mlcs()
    start = operating_point(circuit, mlcs)
    grid = time_grid(5e-6, 2.5e-3, mlcs.breakpoints(2.5e-3))
    whole = TrajectoryRecorder()
    drive(ExactStepper(mlcs), grid, start, whole)
    assert whole.trajectory.stats["handoffs"] >= 2
    parts = _Concatenated()
    drive(ExactStepper(mlcs), grid, start, parts, part_steps=7)
    for name in ("y", "current", "impulse", "active", "switches", "exact_rows"):
        np.testing.assert_array_equal(parts.arrays[name], getattr(whole.trajectory, name))


def test_the_three_phase_inverter_runs_exactly_and_theta_converges_to_it():
    # a mode of the inverter's pencil has fewer finite eigenvalues to working precision than
    # states (its differential part 0 at one of them): the exact run stopped there with
    # numpy's "SVD did not converge" before F's own eigenvalues were taken for that mode
    inverter = NETLISTS.parent / "benchmarks" / "netlists" / "inverter_three_phase.cir"
    exact = _exact(inverter, step=1e-6, stop=0.4e-3)
    circuit = circuitnsds.read_netlist(inverter)
    differences = []
    for step in (1e-7, 1e-8):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RunNote)
            theta = circuit.transient(step=step, stop=0.4e-3, method="theta")  # (θ, whatever the default)
        differences.append(max(np.max(np.abs(np.interp(exact.time, theta.time, theta[name]) - exact[name]))
                               / np.max(np.abs(exact[name])) for name in ("i(lab)", "i(lbc)")))
    coarse, fine = differences
    assert coarse < 0.01
    assert 5 < coarse / fine < 20


def test_a_zener_regulator_on_a_ramp_from_zero_breaks_down_at_its_closed_form_instant():
    # v(in) = 2000 t V; v(out) = v(in)/1.1 until it reaches BV = 5.1 V at t = 2.805 ms, then
    # 5.1 V. A PWL from 0 V has no constant on its only interval: the loop's maps had left the
    # constant out, so each piece from an event on restarted the ramp from 0 V and the Zener
    # never broke down (a wrong answer, exit 0)
    waves = _exact(NETLISTS / "zener_regulator.cir")
    t = waves.time
    np.testing.assert_allclose(waves["v(in)"], 2000 * t, rtol=1e-12, atol=1e-12)
    # (to 1e-9: the blocking diode's Roff, 1e-12 S, loads the divider by 1e-10)
    np.testing.assert_allclose(waves["v(out)"], np.minimum(2000 * t / 1.1, 5.1), rtol=1e-9, atol=1e-12)
    assert [(e.element, e.state) for e in waves.events] == [("dz1.reverse", True)]
    assert waves.events[0].time == pytest.approx(2.805e-3, rel=1e-12)


# ---------------------------------------------------------------- what auto may give the exact loop


@pytest.mark.parametrize(("body", "words"), [
    ("V1 a 0 AM(1 0 1k 10 0)\nR1 a 0 1", r"its source\(s\) v1 \(AM\) have no closed form"),
    ("V1 a 0 SFFM(0 1 1k 2 100)\nR1 a 0 1", r"its source\(s\) v1 \(SFFM\) have no closed form"),
    # a resistor stepping in time: switches that follow a PWL alone (the exact loop's event
    # functions saw no control: i(r1) was 0 after t = 0 instead of 1 A, then 0.5 A)
    ("V1 a 0 1\nR1 a 0 {time < 1m ? 1 : 2}", r"its switch\(es\) r1#1, r1#2 follow a source's time "
                                               r"function without a circuit quantity"),
])
def test_auto_takes_theta_where_the_exact_loop_has_no_closed_form(body, words):
    circuit = circuitnsds.read_netlist(f"refused\n{body}\n.tran 10u 3m\n.end\n")
    chosen, why = choose_stepper("auto", circuit.mlcs())
    assert chosen.name == "theta" and re.search(words, why)
    with pytest.raises(circuitnsds.CircuitError, match=r"'exact' cannot run this circuit: " + words):
        circuit.transient(method="exact")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RunNote)
        waves = circuit.transient(method="auto")
    if "time <" in body:  # the θ-method's answer: 1 A before the corner, 0.5 A after it
        t = waves.time
        np.testing.assert_allclose(waves["i(r1)"][t <= 1e-3], 1.0, rtol=1e-9)
        np.testing.assert_allclose(waves["i(r1)"][t > 1e-3 + 1e-9], 0.5, rtol=1e-9)


UNSTABLE = ("unstable\nI1 0 a pulse(0 1m 0 1u 1u 1m 1)\nC1 a 0 1u\nR1 a 0 2k\nG1 a 0 a 0 -1m\n"
            ".tran 1m 3\n.end\n")


@pytest.mark.parametrize("signals", [None, ["v(a)"]])
def test_an_exact_state_that_overflows_stops_the_run_with_the_rows_before_it(signals):
    # v' = 500 v + i/C: after the first pulse (1 mA, 1 µs edges, 1 ms wide) v = K e^{500 t} with
    # K = ∫ 1000·p(s) e^{-500 s} ds (the pulse at 1 s adds e^-500 of that), beyond the largest
    # double at 1.4199 s; the first grid point after it is 1.421 s. Before, the exact loop wrote
    # NaN from there on, and the run ended as if nothing had happened.
    def shape(s: float) -> float:
        return min(s / 1e-6, 1.0) if s < 1.001e-3 else max(1.0 - (s - 1.001e-3) / 1e-6, 0.0)

    weight = quad(lambda s: 1e3 * shape(s) * math.exp(-500 * s), 0, 1.002e-3, points=[1e-6, 1.001e-3],
                  epsabs=0, epsrel=1e-12)[0]
    with pytest.raises(circuitnsds.SimulationError, match=r"the state is not finite at t = ") as caught:
        circuitnsds.read_netlist(UNSTABLE).transient(method="exact", signals=signals)
    error = caught.value
    overflow = (math.log(1.7976931348623157e308) - math.log(weight)) / 500
    assert overflow < error.time <= overflow + 1e-3
    assert error.cause == circuitnsds.SimulationError.STATE_NOT_FINITE
    assert "the circuit is unstable" in error.hint
    partial = error.partial
    assert partial.time[-1] < error.time and np.isfinite(partial["v(a)"]).all()
    t = partial.time[partial.time > 2e-3]
    np.testing.assert_allclose(partial["v(a)"][partial.time > 2e-3],
                               np.exp(500 * t + math.log(weight)), rtol=1e-6)


def test_a_step_without_solution_in_a_theta_stretch_keeps_the_rows_before_it():
    # a negative resistance across an ideal diode: the exact loop hands the stretch to θ, whose
    # step at 10.1 ms has no solution; the rows of the part before the stretch are kept (before:
    # the error held only the stretch's one row)
    netlist = ("negative resistance drives an ideal diode\nI1 0 a sin(0 1m 50)\nD1 a 0 d\nR1 a 0 2k\n"
               "G1 a 0 a 0 -1m\n.model d D\n.tran 100u 40m\n.end\n")
    with pytest.raises(circuitnsds.SimulationError, match=r"has no solution with ideal devices") as caught:
        circuitnsds.read_netlist(netlist).transient(method="exact")
    error = caught.value
    assert error.time == pytest.approx(10.1e-3)
    partial = error.partial
    assert partial.time.size == 101 and partial.time[-1] == pytest.approx(10e-3)
    # v(a) = -2k · i: the diode blocks while the source current is positive (Roff's 1e-12 S aside)
    np.testing.assert_allclose(partial["v(a)"], -2.0 * np.sin(2 * np.pi * 50 * partial.time), atol=1e-8)


def test_the_transformer_bridge_sees_every_turn_on():
    # netlists/transformer_rectifier.cir: with every diode blocking, the secondary's leakage
    # through them is a −1.8e17 /s mode. Its amplification of the state's round-off had made
    # the blocked diodes' tolerance grow to 1.4 V (and F's eigenvalue +32 /s for the primary's
    # −0.1 /s): forward biases of 0.6 to 2 V went unseen, and the exact run's mean output was
    # 12.7 V (θ: 16.3 V). Against θ at the netlist's 20 µs (itself ~0.03 V off its converged
    # mean): every half-cycle conducts, the mean and the ripple agree
    circuit = circuitnsds.read_netlist(NETLISTS / "transformer_rectifier.cir")
    exact = _exact(NETLISTS / "transformer_rectifier.cir")
    theta = circuit.transient(method="theta")
    last = exact.time > 0.08
    v_exact, v_theta = np.asarray(exact["v(out)"]), np.asarray(theta["v(out)"])
    assert abs(v_exact[last].mean() - v_theta[last].mean()) < 0.1
    assert abs(np.ptp(v_exact[last]) / np.ptp(v_theta[last]) - 1) < 0.05
    charging = np.asarray(exact["i(d1)"]) + np.asarray(exact["i(d2)"])  # into the output
    for k in range(1, 10):  # each half-cycle of the mains charges the capacitor
        inside = (exact.time > k * 0.01) & (exact.time < (k + 1) * 0.01)
        assert charging[inside].max() > 0.5


def test_the_transformer_bridge_runs_exactly_whatever_its_rows():
    # netlists/transformer_rectifier.cir: its blocking mode's diode voltages are known to
    # ~1e-5 V only (the floating secondary's −1.8e17 /s leakage part). With P W for its slow
    # parts each conduction start found no mode that holds (10 hand-offs to θ, θ's 20 µs
    # steps in each); with the pencil's vectors, each turn-off of the start-up ringing did
    # (one diode of the pair at zero, the other 4 round-offs above it and falling: the
    # flipping moved one alone). Now the run is exact throughout: its state at every row of
    # the netlist's 20 µs grid is the same with rows every 1 µs, and over the last 40 ms its
    # diodes deliver the charge that its load and capacitor draw (the rows' trapezoids,
    # 1 µs apart)
    text = (NETLISTS / "transformer_rectifier.cir").read_text()
    coarse = circuitnsds.read_netlist(text).transient(method="exact", signals=["v(out)"])
    fine = circuitnsds.read_netlist(text.replace(".tran 20u 100m", ".tran 1u 100m")).transient(
        method="exact", signals=["v(out)", "i(d1)", "i(d2)"])
    assert coarse.stats["handoffs"] == 0 and fine.stats["handoffs"] == 0
    v_fine = np.asarray(fine["v(out)"])
    np.testing.assert_allclose(np.asarray(coarse["v(out)"]), v_fine[::20], rtol=0, atol=1e-9)
    last = fine.time >= 0.06
    t, v = fine.time[last], v_fine[last]
    delivered = np.trapezoid((np.asarray(fine["i(d1)"]) + np.asarray(fine["i(d2)"]))[last], t)
    drawn = np.trapezoid(v / 100.0, t) + 1000e-6 * (v[-1] - v[0])
    assert abs(delivered / drawn - 1) < 1e-6
    # and its start-up ringing is θ's: θ = ½ at 0.2 µs over the first 2 ms (itself within
    # 3.3e-3 V of θ = ½ at 0.05 µs) within 1e-2 V, the exact run 2.9e-3 V from it (a θ stretch
    # of 16 steps of 20 µs at the first turn-off had put it 0.16 V off)
    start = text.replace(".tran 20u 100m", ".tran 1u 2m").replace(".end", ".options theta=0.5\n.end")
    theta = circuitnsds.read_netlist(start).transient(method="theta", step=0.2e-6, signals=["v(out)"])
    v_theta = np.asarray(theta["v(out)"])[::5]
    np.testing.assert_array_equal(fine.time[:v_theta.size], theta.time[::5])
    assert np.max(np.abs(v_fine[:v_theta.size] - v_theta)) < 1e-2


def test_a_current_ramping_into_a_capacitor_held_by_gmin_charges_linearly():
    # 1 mA from 0.1 ms (1 ns edge) into 1 µF whose node only gmin (1e-12 S) holds: a mode of
    # λ = −1e-6 /s under a ramp. The closed form's terms c/δ² (1e12 of the answer) cancelled
    # to 6e7 V; the near-resonance series gives the line 1e-3 V/µs to within the edge's
    # 0.5 ns·1 mA/1 µF = 5e-7 V
    circuit = circuitnsds.read_netlist("t\nI1 0 1 PULSE(0 1m 0.1m 1n 1n 1 2)\nC1 1 0 1u\n.tran 1u 1m\n.end\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuit.transient(method="exact")
    t = waves.time
    expected = np.where(t > 0.1e-3, 1e-3 * (t - 0.1e-3) / 1e-6, 0.0)
    assert np.max(np.abs(np.asarray(waves["v(1)"]) - expected)) < 6e-7


def test_a_winding_diode_turning_on_while_its_current_dips_by_less_than_round_off_holds():
    # The flyback with Coss of benchmarks/netlists (k = 0.99: a leakage inductance on each
    # side): at a turn-off the drain rises at 1.9e10 V/s, and when the output diode's
    # blocking voltage reaches 0 its current in the conducting mode starts at −117 A/s but
    # turns up at 1.2e16 A/s² (a dip of 0.5 pA over 19 fs, below its 1.3 pA round-off).
    # Refusing that mode left no mode that holds: each such instant went to θ for 16 grid
    # steps, the ringing damped there (505 hand-offs in the 3 ms run). Now the mode holds
    # (the certified search would catch a deeper dip as an event). Against θ = 0.5 at 50 ps
    # over 30 µs: no hand-off (the clamp diode's turn-on at 4.01 µs went to θ too until the
    # pencil's vectors served the slow parts of modes with a fast one: mode._closer) where
    # there were 3; v(drain) 0.0095 V and v(clamp) 8e-5 V off instead of 0.22 V and 0.12 V.
    text = (NETLISTS.parent / "benchmarks" / "netlists" / "flyback_coss.cir").read_text()
    text = text.replace(".tran 10n 3m", ".tran 1n 30u")
    signals = ["v(out)", "v(drain)", "v(clamp)"]
    exact = circuitnsds.read_netlist(text).transient(method="exact", signals=signals)
    reference = circuitnsds.read_netlist(text.replace(".end", ".options theta=0.5\n.end")).transient(
        step=50e-12, method="theta", signals=signals)
    assert exact.stats["handoffs"] == 0
    for name, bound in (("v(out)", 2e-5), ("v(drain)", 0.02), ("v(clamp)", 0.001)):
        expected = np.interp(exact.time, reference.time, np.asarray(reference[name]))
        assert np.max(np.abs(np.asarray(exact[name]) - expected)) < bound, name


def test_an_inductor_current_an_opening_switch_cuts_turns_the_freewheeling_diode_on():
    # netlists/external/buck_sw_ron_only.cir (SW with RON alone: ROFF the default 1e9 Ω).
    # When S1 opens, L1 (1.02 A) sees only the open switch's 1e-9 S until D1 conducts: a mode
    # of -1.06e16 /s, which a segment's solution leaves out (mode.FAST_DECAY). Left out at
    # the choice too, the current vanished into it, D1 never turned on and v(out) settled at
    # 0.38 V, exit 0. The state's part along it now counts at the choice (run.fast_offsets):
    # D1's blocking voltage is -1e9 V there, so it conducts, and v(out) is D·12 V as with θ.
    path = NETLISTS / "external" / "buck_sw_ron_only.cir"
    exact = circuitnsds.read_netlist(path).transient(method="exact")
    theta = circuitnsds.read_netlist(path).transient(method="theta")
    steady = exact.time > 0.8e-3
    duty = (4e-6 + 10e-9) / 10e-6
    assert np.asarray(exact["v(out)"])[steady].mean() == pytest.approx(duty * 12, rel=0.01)
    assert np.max(np.abs(np.asarray(exact["v(out)"]) - np.asarray(theta["v(out)"]))) < 0.02
    assert sum(1 for e in exact.events if e.element == "d1" and e.state) >= 99  # each turn-off
