"""Issue 18: netlists mean what their authors meant (ngspice/LTspice semantics), offline part.

Each test reproduces one of the problems found by running netlists written by other people
(the ngspice-backed checks of the same netlists are in test_compat_ngspice.py).
"""

import math
import warnings

import numpy as np
import pytest

import circuitnsds
from circuitnsds.circuit.elements.diode_fit import (
    ShockleyDiode,
    fit_breakdown,
    fit_forward,
    fit_piecewise,
)
from circuitnsds.compare.metrics import signal_metrics
from tests.conftest import NETLISTS, circuit_from

EXTERNAL = NETLISTS / "external"
VT = 1.380649e-23 * 300.15 / 1.602176634e-19


def run(path, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return circuitnsds.read_netlist(path).transient(**kwargs)


# problem 2: a switch exactly at VT with VH = 0 (ngspice 39 swload.c / cswload.c open it)

@pytest.mark.parametrize("name", ["buck_sw_ron_only", "buck_csw_ron_only"])
def test_switch_with_ron_only_opens_when_its_gate_returns_to_zero(name):
    waves = run(EXTERNAL / f"{name}.cir")
    steady = waves.time > 0.8e-3
    # an ideal buck: v(out) = D * Vin with D = on time / period = (4u + 10n) / 10u, less the
    # drops of the 10 mohm switch and diode at ~2 A (a few mV). Before: the switch never opened,
    # v(out) -> 12 V and the inductor current ramped without bound.
    duty = (4e-6 + 10e-9) / 10e-6
    assert waves["v(out)"][steady].mean() == pytest.approx(duty * 12, rel=0.01)
    assert waves["i(l1)"].max() < 6.0  # the start-up overshoot; before: 255 A at 1 ms


def test_switch_at_threshold_semantics():
    # VT = 0, VH = 0: closed for v > 0, open at v = 0 (coming from closed) and below
    body = ("V1 c 0 PWL(0 0 1m 0 1.001m 1 2m 1 2.001m 0 3m 0 3.001m -1 4m -1)\n"
            "S1 a 0 c 0 sw\nR1 a b 1\nV2 b 0 1\n.model sw SW(RON=1)\n.tran 10u 4m")
    waves = circuit_from(body).transient()
    t, i = waves.time, -waves["i(v2)"]
    closed = i > 0.4  # 1 V over 1 + 1 ohm
    assert not closed[(t > 0.1e-3) & (t < 0.99e-3)].any()     # exactly at VT from the start: open
    assert closed[(t > 1.01e-3) & (t < 1.99e-3)].all()         # above VT: closed
    assert not closed[(t > 2.01e-3)].any()                     # back at VT, then below: open
    # with hysteresis the band keeps the state (unchanged): VT=0.5 VH=0.2 closes above 0.7
    info = circuit_from("V1 c 0 0\nS1 a 0 c 0 sw\nR1 a 0 1\n.model sw SW(VT=0.5 VH=0.2)\n.tran 1u 1m")
    assert info.elements[1].model.thresholds() == pytest.approx((0.7, 0.3))


def test_a_switch_starting_exactly_at_its_threshold_is_warned_about():
    """VH = 0 and a control exactly at VT at the operating point (the 0/1 V gate of
    netlists/external/buck_sw_ron_only.cir and of the PWL test above): circuitnsds starts the
    switch open, ngspice 39 closed (run here: `ngspice -b` on the PWL netlist above gives
    i(v2) = -0.5 A at 0.5 ms; on the buck, v(out) = 11.94 V at t = 0). Before: no word, and
    `compare` showed the buck 192 % apart at t = 0."""
    from circuitnsds.errors import NetlistWarning

    def warned(body):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            circuit_from(body).transient()
        return [str(w.message) for w in caught if issubclass(w.category, NetlistWarning)
                and "exactly at its threshold" in str(w.message)]

    at_vt = warned("V1 c 0 PWL(0 0 1m 0 1.001m 1 2m 1)\nS1 a 0 c 0 sw\nR1 a b 1\nV2 b 0 1\n"
                   ".model sw SW(RON=1)\n.tran 10u 2m")
    assert len(at_vt) == 1 and "s1" in at_vt[0] and "ngspice" in at_vt[0], at_vt
    assert not warned("V1 c 0 PWL(0 0 1m 0 1.001m 1 2m 1)\nS1 a 0 c 0 sw\nR1 a b 1\n"
                      "V2 b 0 1\n.model sw SW(RON=1 VT=0.5)\n.tran 10u 2m")  # VT mid-swing
    assert not warned("V1 c 0 -1\nS1 a 0 c 0 sw\nR1 a b 1\nV2 b 0 1\n"
                      ".model sw SW(RON=1)\n.tran 10u 1m")  # below VT: open in both
    assert not warned("V1 c 0 0\nS1 a 0 c 0 sw\nR1 a b 1\nV2 b 0 1\n"
                      ".model sw SW(RON=1 VH=0.1)\n.tran 10u 1m")  # in a real band: OFF in both


# problem 3: LTspice PWL diode defaults (Ron = 1 ohm, Rrev = Ron)

def test_ltspice_diode_defaults_follow_ltspice_help():
    # ngspice examples/xspice/various/simple-diode.cir (model A), edited: see the file
    waves = run(EXTERNAL / "ngspice_simple_diode.cir")
    v, i = waves["v(in)"], waves["i(r1)"]
    # Vrev = 2 V, Rrev = Ron = 1 ohm: at -5 V the breakdown carries (5 - 2) / (1 + 1u) = 3 A
    # (before: Rrev = 0 gave -3 MA through the 1 uohm load); forward: (5 - 1) / 1 = 4 A
    assert i[np.argmin(v)] == pytest.approx(-3.0, rel=1e-5)
    assert i[np.argmax(v)] == pytest.approx(4.0, rel=1e-5)
    model = circuit_from("D1 a 0 m\nR1 a 0 1\n.model m D(Vfwd=0.7)\n.tran 1u 1u").elements[0].model
    assert model.on_resistance == 1.0 and model.origin.startswith("LTspice PWL")


# problem 4: Shockley models -> PWL diodes

def _branch_voltage(fit, current):
    """The voltage [V] at which parallel branches ``(V_j, R_j)`` carry ``current`` [A] in
    total, by bisection on ``sum max(0, (v - V_j)/R_j)`` (independent of the fit's own)."""
    low, high = 0.0, 100.0
    for _ in range(200):
        v = (low + high) / 2
        if sum(max(0.0, (v - knee) / r) for knee, r in fit.branches) < current:
            low = v
        else:
            high = v
    return (low + high) / 2


def test_shockley_fit_matches_the_curve_within_a_few_millivolts_over_five_decades():
    # a 1N5819-like Schottky (LTspice standard.dio: Is=31.7u Rs=.051 N=1.373 Iave=1)
    diode = ShockleyDiode(31.7e-6, 1.373, 0.051, average_current=1.0)
    fit = fit_forward(diode)
    assert (fit.low, fit.high) == pytest.approx((1e-5, 1.0))
    assert 1 < len(fit.branches) <= 6 and all(r > 0 for r in fit.resistances)
    assert list(fit.knees) == sorted(fit.knees)  # each knee adds conductance
    currents = np.geomspace(1e-5, 1.0, 37)
    exact = 1.373 * VT * np.log1p(currents / 31.7e-6) + 0.051 * currents
    ours = np.array([_branch_voltage(fit, i) for i in currents])
    assert np.abs(ours - exact).max() <= fit.max_error + 1e-9
    # minimax with 6 chords of N·Vt·ln over 5 decades: about N × 5.7 mV
    assert fit.max_error < 1.373 * 6e-3
    # breakdown: v = BV + NBV Vt ln(r / IBV) + RS r, the same way
    zener = ShockleyDiode(0.703e-15, 1.0, 0.871, breakdown_voltage=5.059, breakdown_current=49e-3)
    reverse = fit_breakdown(zener, 0.5)
    for r in np.geomspace(5e-6, 0.5, 11):
        exact = 5.059 + VT * math.log(r / 49e-3) + 0.871 * r
        assert _branch_voltage(reverse, r) == pytest.approx(exact, abs=reverse.max_error + 1e-9)
    assert reverse.max_error < 6e-3


def test_full_ngspice_forward_curve_ikf_and_isr():
    """IKF (high injection) and ISR/NR (recombination) as ngspice's dioload.c computes them,
    written out here for junction voltages and compared with the inverse the fit uses."""
    diode = ShockleyDiode(1e-9, 1.0, 0.01, knee_current=2.0, recombination_current=1e-8,
                          recombination_emission=2.0, junction_potential=0.8, grading=0.4)
    for vd in (0.2, 0.45, 0.6, 0.75):
        diffusion = 1e-9 * math.expm1(vd / VT)
        recombination = 1e-8 * math.expm1(vd / (2 * VT)) * ((1 - vd / 0.8) ** 2 + 0.005) ** 0.2
        total = diffusion + recombination
        current = total / (1 + math.sqrt(total / 2.0))
        assert float(diode.forward_voltage(current)) == pytest.approx(vd + 0.01 * current, abs=1e-9)
    # high injection doubles the slope of ln(i): at 9 A with IKF = 2 A the drop is well above
    # the plain Shockley one
    plain = ShockleyDiode(1e-9, 1.0, 0.01)
    assert diode.forward_voltage(9.0) > plain.forward_voltage(9.0) + 0.03


def test_fit_piecewise_of_a_flat_curve_is_one_branch():
    fit = fit_piecewise(lambda i: 0.5 * np.ones_like(i), 1e-3, 1.0)
    assert fit.branches == ((pytest.approx(0.5), 0.0),) and fit.max_error < 1e-12
    with pytest.raises(ValueError):
        fit_piecewise(lambda i: i, 0.0, 1.0)


def test_zener_with_shockley_breakdown_regulates_with_a_slope():
    # the Motorola ZN4733 model (KiCad-Spice-Library DIODE2.LIB): Rs and the breakdown's
    # dynamic resistance make the output rise with the input (before: exactly flat)
    body = ("V1 in 0 PWL(0 8 1m 12)\nR1 in out 100\nD1 0 out zn4733\n"
            ".model ZN4733 D (IS=.703F RS=.871 N=1 BV=5.059 IBV=49M CJO=189P VJ=.75 M=.33 TT=50.1N)\n"
            ".tran 10u 1m")
    waves = circuit_from(body).transient()
    vout = waves["v(out)"]

    def model_output(vin):  # solve v = BV + Vt ln(r/IBV) + RS r with r = (vin - v)/100
        low, high = 5.0, vin
        for _ in range(100):
            v = (low + high) / 2
            r = (vin - v) / 100
            low, high = (low, v) if 5.059 + VT * math.log(r / 49e-3) + 0.871 * r < v else (v, high)
        return v

    fit = circuit_from(body).elements[2].model.breakdown_fit
    assert vout[0] == pytest.approx(model_output(8.0), abs=fit.max_error + 1e-6)
    assert vout[-1] == pytest.approx(model_output(12.0), abs=fit.max_error + 1e-6)
    regulation = (vout[-1] - vout[0]) / (waves["v(in)"][-1] - waves["v(in)"][0])
    assert 0.01 < regulation < 0.05


# problem 8: errors relative to the RMS value for DC-like signals

def test_rms_relative_error_for_a_dc_like_signal():
    t = np.linspace(0, 1e-3, 1001)
    ref = 4.5 + 0.005 * np.sin(2 * math.pi * 1e4 * t)
    metric = signal_metrics(t, ref, ref - 0.08)
    assert metric.nrms == pytest.approx(0.08 / 0.01, rel=1e-3)   # 800 % of the 10 mV ripple
    assert metric.dc_like and metric.error == metric.rrms
    assert metric.rrms == pytest.approx(0.08 / math.sqrt(4.5**2 + 0.005**2 / 2), rel=1e-4)
    swinging = signal_metrics(t, np.sin(2 * math.pi * 1e3 * t), np.sin(2 * math.pi * 1e3 * t) + 0.01)
    assert not swinging.dc_like and swinging.error == swinging.nrms


# problem 5: a TSTEP that cannot resolve a SIN or PULSE

DOUBLER = """voltage doubler at 100 MHz with .tran 5n (TSTEP = half the period)
V1 in 0 SIN(0 5 100meg)
C1 in a 1n
D1 0 a dd
D2 a out dd
C2 out 0 1n
RL out 0 100k
.model dd D
.tran 5n 2u
.end
"""


def test_a_tstep_that_cannot_resolve_a_sine_is_refined_and_reported_on_tstep():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # (the step refined for θ, which steps on the grid; the exact integrator needs no
        # refinement and notes its hand-offs here: pinned to θ)
        waves = circuitnsds.read_netlist(DOUBLER).transient(method="theta")
    notes = [str(w.message) for w in caught if issubclass(w.category, circuitnsds.errors.RunNote)]
    assert len(notes) == 1 and "TSTEP/10" in notes[0] and "v1" in notes[0]
    # reported on the TSTEP grid
    np.testing.assert_allclose(np.diff(waves.time), 5e-9, rtol=1e-9)
    # the ideal doubler charges its output to 2 x 5 V (before: the sine was sampled at its
    # zeros only and the output stayed at 1e-11 V)
    assert waves["v(out)"][-1] == pytest.approx(10.0, rel=0.03)


def test_an_explicit_step_is_obeyed_with_a_warning_and_refused_under_strict():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        waves = circuitnsds.read_netlist(DOUBLER).transient(step=5e-9)
    assert any("cannot resolve" in str(w.message) for w in caught)
    assert abs(waves["v(out)"][-1]) < 1e-6  # what the step asked for: the sine's zeros
    with pytest.raises(circuitnsds.errors.CircuitError, match="cannot resolve"):
        circuitnsds.read_netlist(DOUBLER, strict=True).transient(step=5e-9)


# problem 6: two .tran lines (a KiCad export included by a wrapper): ngspice runs the first

def test_two_tran_lines_run_the_first_with_a_warning():
    body = "V1 a 0 1\nR1 a 0 1k\n.tran 1u 1m\n.tran 2u 5m"
    with pytest.warns(circuitnsds.errors.NetlistWarning, match="second .tran line ignored"):
        circuit = circuit_from(body)
    assert (circuit.analyses["tran"].step, circuit.analyses["tran"].stop) == (1e-6, 1e-3)
    assert circuit.transient().time[-1] == pytest.approx(1e-3)


@pytest.mark.parametrize("line", [".tran 0 10m", ".tran 10m"])
def test_ltspice_tran_forms(line):
    with pytest.warns(circuitnsds.errors.NetlistWarning, match="TSTOP/1000"):
        circuit = circuit_from(f"V1 a 0 1\nR1 a 0 1k\n{line}")
    assert circuit.analyses["tran"].stop == 10e-3 and circuit.analyses["tran"].step == pytest.approx(10e-6)


# source syntax of LTspice exports (spicelib's top_circuit.net has PULSE(... 1) and 1µ)

def test_pulse_number_of_pulses_and_sine_cycles():
    from circuitnsds.system.stimuli import Pulse, Sin

    pulse = Pulse(0, 1, 1e-6, 0, 0, 1e-6, 2e-6, 2)  # two pulses, then V1
    t = [0.5e-6, 1.5e-6, 2.5e-6, 3.5e-6, 4.5e-6, 5.5e-6, 7.5e-6]
    assert [pulse.value(x) for x in t] == [0, 1, 0, 1, 0, 0, 0]
    np.testing.assert_array_equal(pulse.sample(np.array(t)), [0, 1, 0, 1, 0, 0, 0])
    assert max(pulse.breakpoints(10e-6)) <= 4e-6
    sine = Sin(1.0, 2.0, 1e3, 0.0, 0.0, 30.0, 2)  # LTspice NCYCLES: two periods, then held
    assert sine.value(1.5e-3) == pytest.approx(1 + 2 * math.sin(2 * math.pi * 1.5 + math.pi / 6))
    assert sine.value(5e-3) == pytest.approx(1 + 2 * math.sin(math.pi / 6))
    assert 2e-3 in sine.breakpoints(10e-3)
    circuit = circuit_from("V1 a 0 PULSE(0 1 1n 1n 1n 1u 1u 1)\nR1 a b 10\nL1 b 0 1µ\n.tran 2u\n.backanno")
    assert circuit.element("l1").inductance == 1e-6
    assert circuit.elements[0].function.count == 1


def test_pwl_file_reads_time_value_pairs_relative_to_the_netlist(tmp_path):
    (tmp_path / "wave.txt").write_text("* time value\n0 0\n1m, 2\n2m\t2\n3m 0\n")
    netlist = tmp_path / "pwl.cir"
    netlist.write_text('pwl file\nV1 a 0 PWL file="wave.txt"\nR1 a 0 1k\n.tran 10u 3m\n.end\n')
    waves = circuitnsds.read_netlist(netlist).transient()
    t = waves.time
    assert waves["v(a)"][np.searchsorted(t, 0.5e-3)] == pytest.approx(1.0)
    assert waves["v(a)"][np.searchsorted(t, 1.5e-3)] == pytest.approx(2.0)
    netlist.write_text("pwl file\nV1 a 0 PWL(file=missing.txt)\nR1 a 0 1k\n.tran 10u 3m\n.end\n")
    with pytest.raises(circuitnsds.errors.NetlistError, match="cannot read PWL file"):
        circuitnsds.read_netlist(netlist)


def test_cli_differential_signals_window_and_decimation(tmp_path):
    import csv
    import subprocess
    import sys

    out = tmp_path / "o.csv"
    done = subprocess.run([sys.executable, "-m", "circuitnsds", "run",
                           str(EXTERNAL / "buck_sw_ron_only.cir"), "-q", "-o", str(out),
                           "--signals", "v(sw,out), i(l1)", "--tstart", "0.9m", "--tstop", "1m",
                           "--every", "10"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rows = list(csv.reader(out.open()))
    assert rows[0] == ["time", "v(sw,out)", "i(l1)"]
    times = np.array([float(row[0]) for row in rows[1:]])
    assert times[0] >= 0.9e-3 - 1e-12 and times[-1] == pytest.approx(1e-3)
    full = run(EXTERNAL / "buck_sw_ron_only.cir")
    inside = (full.time >= 0.9e-3) & (full.time <= 1e-3)
    assert len(times) == len(np.unique(np.append(np.flatnonzero(inside)[::10], np.flatnonzero(inside)[-1])))
    k = int(np.searchsorted(full.time, times[1]))
    assert float(rows[2][1]) == pytest.approx(full["v(sw)"][k] - full["v(out)"][k], abs=1e-8)


def test_pwlfit_auto_refits_to_the_peak_current_of_a_first_run():
    # Xyce's DIODE/diode.cir (IS=100f): 5 V through 2 kohm, 2.19 mA (its comment)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        circuit = circuitnsds.read_netlist(EXTERNAL / "xy_diode_pulse_autofit.cir")
        waves = circuit.transient()
    peak = waves["i(d1)"].max()
    assert peak == pytest.approx(2.19e-3, rel=0.01)
    # the diode's drop at its operating point is the Shockley one (Xyce's comment: 0.6158 V) to
    # within the fit's error (a single line fitted over 0.1..1 A gave 0.72 V)
    assert not any("misses the model" in str(w.message) for w in caught)
    assert waves["v(3)"].max() == pytest.approx(0.6158, abs=0.01)


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=100, deadline=None)
@given(saturation=st.floats(1e-16, 1e-4), emission=st.floats(0.02, 3.0), series=st.floats(0, 5),
       high=st.floats(1e-4, 10))
def test_fitted_branches_stay_within_their_reported_error(saturation, emission, series, high):
    diode = ShockleyDiode(saturation, emission, series)
    fit = fit_forward(diode, high)
    assert len(fit.branches) <= 6 and list(fit.knees) == sorted(fit.knees)
    assert all(r > 0 for r in fit.resistances) or len(fit.branches) == 1
    currents = np.geomspace(fit.low, fit.high, 29)  # not the fit's own samples
    exact = emission * VT * np.log1p(currents / saturation) + series * currents
    deviation = np.abs(fit.voltage(currents) - exact)
    assert deviation.max() <= fit.max_error * 1.05 + 1e-9
    assert fit.knees[0] >= 0


def test_info_says_junction_capacitance_and_transit_time_are_ignored():
    model = circuit_from("D1 a 0 zn\nR1 a 0 1\n.MODEL ZN D (IS=.703F RS=.871 N=1 BV=5.059 IBV=49M "
                         "CJO=189P VJ=.75 M=.33 TT=50.1N)").elements[0].model
    assert "CJO, TT ignored" in model.origin


SMALL_RECTIFIER = """small-current rectifier
V1 in 0 SIN(0 5 1k)
D1 in out dd
R1 out 0 10k
C1 out 0 100n
.model dd D(IS=2.5n N=1.75 RS=0.6)
.tran 1u 3m
.end
"""


def test_a_fit_range_the_circuit_leaves_is_a_warning_naming_the_diode():
    """A fit range fixed by .options pwlfit far above the circuit's 0.5 mA: the branches miss
    the model's curve there and the run warns, naming the diode (before: a note)."""
    from circuitnsds.errors import CircuitWarning

    text = SMALL_RECTIFIER.replace(".tran", ".options pwlfit=1k\n.tran")
    for signals in (None, ["v(out)"]):  # also when only v(out) is kept (segments, no i(d1))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            circuitnsds.read_netlist(text).transient(signals=signals)
        found = [str(w.message) for w in caught if issubclass(w.category, CircuitWarning)]
        assert any("diode d1 (.model dd)" in message and "misses the model" in message
                   for message in found), (signals, found)


def test_the_default_fit_follows_the_circuits_currents():
    """Without pwlfit the fit range comes from the run: the rectifier's diode drop at its
    peak current is the model's (written out here) to within the fit's error, and no warning."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        circuit = circuitnsds.read_netlist(SMALL_RECTIFIER)
        waves = circuit.transient()
    assert not any("misses the model" in str(w.message) for w in caught)
    k = int(np.argmax(waves["i(d1)"]))
    peak = float(waves["i(d1)"][k])
    drop = 1.75 * VT * math.log1p(peak / 2.5e-9) + 0.6 * peak
    assert waves["v(in)"][k] - waves["v(out)"][k] == pytest.approx(drop, abs=0.012)


def test_a_breakdown_fit_follows_the_circuits_currents():
    """Xyce_Regression Netlists/SENS/fullWaveRectDiode.cir (netlists/external/
    xy_fullwave_bridge_sens.cir): a bridge of BV = 7.255 V diodes straight across a 15 V sine,
    two of them in breakdown at a time, RS = 10.8 ohm: the model (and ngspice) carries ~0.3 A.
    A single breakdown line fitted over IBV/10..IBV gave 89 mA peaks; the branches fitted
    where the circuit works give the model's peak, solved here from the Shockley curves."""
    path = NETLISTS / "external" / "xy_fullwave_bridge_sens.cir"

    def drops(i):  # forward + breakdown drop of the model (IS=1e-14 N=1 RS=10.8 BV=7.255 IBV=1m)
        return VT * math.log1p(i / 1e-14) + 7.255 + VT * math.log(i / 1e-3) + 2 * 10.8 * i

    low, high = 1e-3, 1.0
    for _ in range(80):
        low, high = ((low + high) / 2, high) if drops((low + high) / 2) < 15 else (low, (low + high) / 2)
    assert low > 0.3
    for signals in (None, ["i(d1)"]):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            waves = circuitnsds.read_netlist(path).transient(signals=signals)
        assert not any("misses the model" in str(w.message) for w in caught)
        assert float(np.max(np.abs(waves["i(d1)"]))) == pytest.approx(low, rel=0.01)


def test_no_breakdown_warning_on_leakage_far_below_breakdown():
    """A 1N4007 (BV = 1000 V) blocking 13.6 V carries only its off-conductance's 1.4e-11 A:
    that is no breakdown current (before: a note said it carried 1.36e-11 A in breakdown and
    advised pwlfit=1.36e-11, which refitted the forward branch to 9 µV / 6.5 MΩ)."""
    text = """half-wave rectifier, 1N4007
V1 in 0 SIN(0 13.6 50)
D1 in out d1n4007
R1 out 0 100
.model d1n4007 D(IS=7.02767n RS=0.0341512 N=1.80803 BV=1000 IBV=5e-08 CJO=1e-11 TT=1e-07)
.tran 20u 40m
.end
"""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        waves = circuitnsds.read_netlist(text).transient()
    messages = [str(w.message) for w in caught]
    assert not any("breakdown" in message and "carries" in message for message in messages), messages
    assert waves["i(d1)"].min() < -1e-11  # the leakage is there
