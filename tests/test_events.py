"""Switching instants of circuit-controlled switches are located inside the step.

When a switch's control (a circuit voltage or current, not a source's time function)
crosses its threshold during a step, the step is split at the crossing, found by a root
finder on the partial step length (docs/method.md, "Event location"). Expected values
are analytic: piecewise-exponential RL currents between two thresholds, a linear ramp
against a constant voltage.
"""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import circuitnsds
from circuitnsds.engine.events import MAX_EVENTS_PER_STEP, regula_falsi
from circuitnsds.errors import SimulationError
from tests.conftest import NETLISTS, circuit_from, pinned
from tests.device_checks import assert_device_laws

# --- hysteretic buck: a W switch on the inductor current between two thresholds -------------
#
# Vin = 12 V, the load is Vout = 5 V behind R = 2 ohm; W1 closes when i(l1) < 1 A and
# opens when i(l1) > 2 A (it senses -i(l1)), an ideal diode freewheels. Between
# switchings i(l1) relaxes exponentially (L/R = 50 us) towards (Vin - Vout)/R (closed)
# or -Vout/R (open), so the phase durations are logarithms.
VIN, VOUT, L, R, I_LOW, I_HIGH = 12.0, 5.0, 100e-6, 2.0, 1.0, 2.0


def hysteretic_period() -> float:
    towards_on, towards_off = (VIN - VOUT) / R, -VOUT / R
    on = L / R * np.log((towards_on - I_LOW) / (towards_on - I_HIGH))
    off = L / R * np.log((I_HIGH - towards_off) / (I_LOW - towards_off))
    return on + off


def hysteretic_buck(h: float, stop: float) -> str:
    return f"""Vin in 0 {VIN}
W1 in sw Vsense wmod
D1 0 sw dfw
L1 sw a {L}
R1 a b {R}
Vsense out b 0
Vout out 0 {VOUT}
.model wmod CSW(IT=-1.5 IH=0.5 RON=0 ROFF=1e9)
.model dfw D()
.tran {h} {stop} uic"""


def period_error(steps_per_period: int, theta: float) -> float:
    period = hysteretic_period()
    # (θ's period error and its order: pinned to θ)
    waves = circuit_from(hysteretic_buck(period / steps_per_period, 10 * period)).transient(theta=theta,
                                                                                           method="theta")
    closings = waves.switchings("w1", True)
    # it closes at t = 0 (i = 0 < 1 A: the state at the start, not an event), then once a period
    assert closings.size == 9
    return abs(np.diff(closings[1:]).mean() - period) / period


def test_hysteretic_buck_switches_at_the_analytic_frequency():
    # θ = 0.5: second order between switchings, and the switchings located, so the period is
    # right to 0.1 % at 100 steps per period and the error falls faster than h (measured
    # 1.2e-4, 4.6e-5, 7.3e-6 at 50, 100, 200 steps; one step late it was 3 %, 2 %, 1.5 %)
    errors = [period_error(n, 0.5) for n in (50, 100, 200)]
    assert errors[1] < 1e-3
    assert errors[0] / errors[2] > 4 * 1.5            # halving h twice: more than 4x (linear)


def test_hysteretic_buck_thresholds_are_met_at_the_events():
    period = hysteretic_period()
    # (θ's split steps and their impulses: pinned to θ)
    waves = circuit_from(hysteretic_buck(period / 100, 5 * period)).transient(theta=0.5, method="theta")
    current = waves["i(l1)"]
    assert current[waves.time > period].max() < I_HIGH + 1e-9   # never beyond the band
    assert current[waves.time > period].min() > I_LOW - 1e-9
    assert [e.state for e in waves.events][:4] == [False, True, False, True]
    # in a step split at a switching the diode carries the inductor current for the part
    # in which W1 is open: its charge in that step is i(l1)·(that part), not i·h
    for time, _, closed in waves.events:
        k = int(np.searchsorted(waves.time, time))
        part = time - waves.time[k - 1] if closed else waves.time[k] - time
        assert 0 < part < waves.time[k] - waves.time[k - 1]
        assert waves.impulse("d1")[k] == pytest.approx(current[k] * part, rel=0.02)


# --- voltage-mode PWM: a ramp source against a circuit voltage ---------------------------------
#
# The ramp rises 0 -> 1 V over T - 20 ns and falls back in 10 ns; the comparator S1 closes
# while v(ctrl) > v(ramp). v(ctrl) = 0.3719 V comes from a divider (a circuit voltage: not
# a source across the control nodes). S1 opens at 0.3719·(T - 20 ns) into each period and
# closes on the ramp's fall, 0.6281 of the way down.
T = 10e-6
RISE, FALL, WIDTH = T - 20e-9, 10e-9, 1e-12
CONTROL = 0.3719


def pwm_buck(h: float, stop: float) -> str:
    return f"""Vin in 0 12
Vramp ramp 0 PULSE(0 1 0 {RISE} {FALL} {WIDTH} {T})
Vref r 0 1
R1 r ctrl 6281
R2 ctrl 0 3719
S1 in sw ctrl ramp smod
D1 0 sw dfw
L1 sw out 22u
C1 out 0 47u
Rl out 0 3
.model smod SW(VT=0 VH=0 RON=10m ROFF=1e9)
.model dfw D()
.tran {h} {stop}"""


def test_pwm_duty_cycle_from_the_events_matches_the_ramp_crossing():
    circuit = circuit_from(pwm_buck(T / 100, 20 * T))
    waves = circuit.transient()
    opening = waves.switchings("s1", False)
    closing = waves.switchings("s1", True)
    periods = np.arange(20)
    np.testing.assert_allclose(opening, periods * T + CONTROL * RISE, rtol=0, atol=1e-4 * T)
    np.testing.assert_allclose(closing, periods[:closing.size] * T + RISE + WIDTH
                               + (1 - CONTROL) * FALL, rtol=0, atol=1e-4 * T)
    duty = (opening[1:] - closing[:opening.size - 1]) / T
    expected = (CONTROL * RISE + T - (RISE + WIDTH + (1 - CONTROL) * FALL)) / T
    np.testing.assert_allclose(duty, expected, rtol=0, atol=1e-4)
    # at every sample, split steps included, the diode obeys its law (the sample is the
    # state after the last part of the step, not an average over the parts)
    assert_device_laws(circuit, waves)
    # the switch node follows: v(sw) = 12 V while closed, -0 V (the diode) while open
    closed = (waves.time > opening[3] - CONTROL * RISE + 1e-7) & (waves.time < opening[3] - 1e-7)
    assert np.all(waves["v(sw)"][closed] > 11)


def test_events_are_written_and_source_driven_switches_listed(tmp_path):
    # a source-driven switch (a voltage source across its control nodes) switches at grid
    # points: its events are those grid points
    waves = circuit_from("V1 in 0 10\nR1 in a 1k\nS1 a 0 c 0 sw\nVc c 0 PULSE(0 5 1u 0 0 2u 10u)\n"
                         ".model sw SW(VT=2.5)\n.tran 0.1u 5u").transient()
    assert waves.events == [(pytest.approx(1e-6), "s1", True), (pytest.approx(3e-6), "s1", False)]
    path = tmp_path / "events.csv"
    waves.events_to_csv(path)
    lines = path.read_text().splitlines()
    assert lines[0] == "time,element,state" and lines[1].endswith(",s1,1")


# --- chattering -------------------------------------------------------------------------------


def test_a_switch_that_moves_its_own_control_back_gives_a_clear_error():
    # S1 shorts the node that controls it, with no hysteresis: closing pulls v(a) to 0 V,
    # which opens it, which lets v(a) jump back above VT ...
    circuit = circuit_from("V1 in 0 PWL(0 0 1m 5)\nR1 in a 1k\nS1 a 0 a 0 sw\n"
                           ".model sw SW(VT=1 VH=0 RON=0)\n.tran 10u 1m")
    with pytest.raises(SimulationError) as caught:
        circuit.transient()
    error = caught.value
    assert "switch s1 chatters" in error.message
    assert f"{MAX_EVENTS_PER_STEP} switchings" in error.message
    assert error.time == pytest.approx(0.2e-3, abs=10e-6)       # where v(in)/... reaches 1 V
    assert "hysteresis" in error.hint
    assert error.trajectory is not None and error.trajectory.time[-1] < 0.21e-3
    assert error.partial is not None and error.partial.events == []   # nothing switched before


# --- the root finder ---------------------------------------------------------------------------


@pytest.mark.parametrize("root", [1e-6, 0.3, 0.999999])
def test_regula_falsi_brackets_the_root_of_a_convex_function(root):
    calls = []

    def g(x):
        calls.append(x)
        return np.expm1(5 * (x - root))          # strongly curved: plain regula falsi stalls

    found = regula_falsi(g, 0.0, 1.0, g(0.0), g(1.0), 1e-12)
    assert g(found) >= 0 and found - root < 1e-11
    assert len(calls) < 40


@settings(max_examples=200, deadline=None)
@given(root=st.floats(1e-6, 1 - 1e-6),
       curvature=st.one_of(st.just(0.0), st.floats(1e-3, 8.0), st.floats(-8.0, -1e-3)),
       scale=st.floats(1e-9, 1e6), rising=st.booleans())
def test_regula_falsi_ends_on_the_crossed_side_within_the_tolerance(root, curvature, scale,
                                                                   rising):
    # g(x) = ±scale·(exp(c·(x - root)) - 1)/c: monotone, convex or concave, root inside
    def g(x):
        value = x - root if curvature == 0 else np.expm1(curvature * (x - root)) / curvature
        return scale * value if rising else -scale * value

    found = regula_falsi(g, 0.0, 1.0, g(0.0), g(1.0), 1e-9)
    assert np.sign(g(found)) in (0.0, np.sign(g(1.0)))       # the crossing has happened
    assert -1e-12 <= found - root <= 1e-9 + 1e-12                 # on the far side, within xtol


def test_event_location_costs_a_few_solves_per_switching():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        period = hysteretic_period()
        # (θ's event solves and mapped steps: pinned to θ)
        waves = circuit_from(hysteretic_buck(period / 100, 20 * period)).transient(method="theta")
    assert waves.stats["events"] == 38                 # 2 per period but the closing at t = 0
    assert waves.stats["event_solves"] < 12 * waves.stats["events"]
    assert waves.stats["mapped_steps"] > 0.8 * waves.stats["steps"]   # the fast path is kept


@pytest.mark.parametrize("method", ["theta", "auto"])
def test_command_line_writes_the_events_and_the_plot_marks_them(tmp_path, monkeypatch, method):
    from matplotlib.figure import Figure

    from circuitnsds.cli.main import main
    from circuitnsds.output.plot import draw

    netlist = tmp_path / "pwm.cir"
    text = pinned("pwm\n" + pwm_buck(T / 100, 3 * T) + "\n.end\n", method)
    netlist.write_text(text)
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(netlist), "-q", "--events", "events.csv"]) == 0
    lines = (tmp_path / "events.csv").read_text().splitlines()
    assert lines[0] == "time,element,state"
    rows = [line.split(",") for line in lines[1:]]
    switch = [row for row in rows if row[1] == "s1"]
    assert [(e, s) for _, e, s in switch] == [("s1", "0"), ("s1", "1")] * 3
    assert float(switch[0][0]) == pytest.approx(CONTROL * RISE, abs=1e-4 * T)
    # the θ-method lists the switches' events, the exact integrator the diode's too
    assert {e for _, e, _ in rows} == ({"s1"} if method == "theta" else {"s1", "d1"})
    waves = circuitnsds.read_netlist(text).transient()
    figure = Figure()
    draw(figure, waves, ["v(sw)"], events=True)
    (axis,) = figure.axes
    assert len(axis.lines) == 1 + len(waves.events)        # the signal and one mark per event


def test_events_file_keeps_the_switchings_with_every_and_a_window(tmp_path):
    # before: --every N, --tstart/--tstop and a differential --signals v(a,b) each rebuilt the
    # waveforms without their events, so --events wrote a header alone (and --mark-events drew
    # nothing); the buck's gate closes S1 at 5 ns + k·10 µs and opens it 5 µs later
    from circuitnsds.cli.main import main
    from tests.conftest import NETLISTS

    netlist = str(NETLISTS / "buck_converter.cir")
    base = ["run", netlist, "-q", "-o", str(tmp_path / "o.csv"), "--stop", "20u", "--events",
            str(tmp_path / "e.csv")]

    def switchings(*extra):
        assert main([*base, *extra]) == 0
        rows = (tmp_path / "e.csv").read_text().splitlines()
        assert rows[0] == "time,element,state"
        # (s1's rows; the exact integrator, which auto takes, lists the diode's events too)
        return [(round(float(t) * 1e9), s) for t, e, s in (row.split(",") for row in rows[1:]) if e == "s1"]

    every = [(5, "1"), (5005, "0"), (10005, "1"), (15005, "0")]  # ns
    assert switchings() == every
    assert switchings("--every", "7") == every
    assert switchings("--signals", "v(out,sw)") == every
    assert switchings("--tstart", "6u", "--tstop", "16u") == every[2:]


def test_many_switches_switching_within_one_step_are_not_called_chattering():
    """ngspice examples/p-to-n-examples/switch-oscillators.cir (netlists/external/
    ng_switch_oscillators.cir): a 17-stage ring oscillator of S switches (period 4.5 ns in
    ngspice) at its .tran TSTEP of 10 ns. Twenty switchings of many switches fall in the first
    step; before, the error called one of them chattering and advised hysteresis or an RC,
    while the cause is the step (at --step 10p it runs, 4.7 ns; ngspice 4.47 ns)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # .control, .options method=gear, an unused model
        circuit = circuitnsds.read_netlist(NETLISTS / "external" / "ng_switch_oscillators.cir")
    with pytest.raises(SimulationError) as caught:
        circuit.transient()
    error = caught.value
    assert "chatters" not in error.message
    assert f"{MAX_EVENTS_PER_STEP} switchings of" in error.message
    assert "step" in error.hint and "hysteresis" not in error.hint
