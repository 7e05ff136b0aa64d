"""Exit 0 with a wrong number (issue 36): each case gave a wrong or misleading result with
no word; each test pins the right answer (closed form, or ngspice's) or the warning."""

from __future__ import annotations

import re

import numpy as np
import pytest

import circuitnsds
from circuitnsds.errors import RunNote
from tests.conftest import NETLISTS, circuit_from

# --- 1. θ = ½ after a circuit-controlled switch closes onto a capacitor -----------------------

GATE_RC_CLOSES_ONTO_C = """V1 in 0 12
Vg g0 0 PULSE(0 5 1u 0 0 5u 10u)
Rg g0 g 3
Cg g 0 5n
S1 in sw g 0 sw1
C1 sw 0 3n
R1 sw 0 10
.model sw1 SW(VT=2.6 RON=10m)
.tran 1n 3u"""


def test_theta_half_does_not_ring_after_a_switch_closes_onto_a_capacitor():
    # Ron·C1 = 30 ps against h = 1 ns: once closed, v(sw) = 12·10/10.01 V within a few
    # steps and i(s1) = 12/10.01 A (C1 charged). One implicit-Euler restart left the fast mode
    # ringing: i(s1) = +37, -31, +30, -24 A.
    waves = circuit_from(GATE_RC_CLOSES_ONTO_C).transient(theta=0.5)
    current = waves["i(s1)"]
    closed = int(np.argmax(np.abs(current) > 0.5))
    settled = 12 / 10.01
    np.testing.assert_allclose(current[closed + 4:], settled, rtol=2e-3)
    np.testing.assert_allclose(waves["v(sw)"][closed + 4:], 10 * settled, rtol=1e-4)


# --- 3. a consistent .ic ------------------------------------------------------------------------

IC_ON_A_DRIVEN_NODE = """V1 n 0 {v}
R1 n a 1k
C1 a 0 1u
.ic v(n)={ic}
.tran 10u 1m"""


def test_an_ic_that_repeats_the_source_is_accepted():
    # v(n) is held by V1; an .ic that says the same (0 against the solver's -0, or within
    # rounding) is consistent: the operating point (C1 open, no current in R1) has v(a) = v
    for v, ic in (("0", "0"), ("5", "5.0000000001"), ("-3.3", "-3.3")):
        waves = circuit_from(IC_ON_A_DRIVEN_NODE.format(v=v, ic=ic)).transient()
        np.testing.assert_allclose(waves["v(n)"], float(v), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(waves["v(a)"], float(v), rtol=1e-9, atol=1e-15)


def test_an_ic_that_contradicts_the_source_names_it_without_a_minus_zero():
    with pytest.raises(circuitnsds.SimulationError) as raised:
        circuit_from(IC_ON_A_DRIVEN_NODE.format(v="0", ic="0.1")).transient()
    assert ".ic v(n)=0.1 contradicts the sources, which hold n at 0 V" in str(raised.value)


# --- 2. UIC with a capacitor's ic= in series with its ESR ------------------------------------

def test_uic_start_of_a_capacitor_behind_its_esr_is_consistent():
    # C1 at 10 V discharging into Rl = 10 Ω through its ESR of 0.1 Ω: at t = 0 the divider gives
    # v(out) = 10·10/10.1 V and v(esr) = -10·0.1/10.1 V (it showed 0 V and 0 V), and the
    # power balance closes: the energy ½·C·v² the capacitor gives up over the run goes into
    # Rl and Resr (the stored row was +0.69 W and 5 W unaccounted)
    from circuitnsds.output.measure import losses

    circuit = circuit_from("C1 out esr 100u ic=10\nResr esr 0 0.1\nRl out 0 10\n.tran 1u 1m uic")
    waves = circuit.transient()
    assert waves["v(out)"][0] == pytest.approx(10 * 10 / 10.1, rel=1e-12)
    assert waves["v(esr)"][0] == pytest.approx(-10 * 0.1 / 10.1, rel=1e-12)
    table = losses(waves, circuit)
    tau = 100e-6 * 10.1
    stored = 0.5 * 100e-6 * 100 * (np.exp(-2 * 1e-3 / tau) - 1) / 1e-3
    assert table.total("stored") == pytest.approx(stored, rel=2e-3)
    assert abs(table.unaccounted) < 1e-3 * table.total("loss")


# --- 5. the DC operating point closes a switch the circuit controls ---------------------------

SOFT_START_BUCK = """Vin in 0 12
Vss s0 0 1.2
Rss s0 ss 1k
Css ss 0 1u
Bq q 0 V={v(ss) > 0.6 ? 1 : 0}
S1 in sw q 0 smod
D1 0 sw dfw
L1 sw out 10u
C1 out 0 100u
Rl out 0 0.25
.model smod SW(VT=0.5 RON=10m)
.model dfw D()
.tran 100n 20u"""


def test_an_operating_point_with_a_switch_closed_by_the_circuit_is_noted():
    # at DC Css is open, so v(ss) = 1.2 V and the comparator closes S1: the buck starts at its
    # full-duty output 12·0.25/0.26 V (what the operating point gives), and the note says so
    with pytest.warns(RunNote) as notes:
        waves = circuit_from(SOFT_START_BUCK).transient()
    named = " ".join(str(note.message) for note in notes)
    assert "s1: the DC operating point starts it closed" in named
    assert "bq.cmp0: the DC operating point starts it closed" in named
    assert waves["v(out)"][0] == pytest.approx(12 * 0.25 / 0.26, rel=1e-9)
    # under UIC every switch starts in its OFF state: no note
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", RunNote)
        circuit_from(SOFT_START_BUCK.replace(".tran 100n 20u", ".tran 100n 20u uic")).transient()


# --- 8. a step far too long for the circuit's own dynamics -------------------------------------

SERIES_RLC = """V1 in 0 PULSE(0 10 0 1n 1n 1 2)
R1 in a 0.1
L1 a b 1u
C1 b 0 1u
.tran {step} 1m"""


def test_a_step_longer_than_the_circuits_ringing_is_warned_naming_the_pair():
    # ω0 = 1/√(LC) = 1e6 rad/s, ζ = R/2·√(C/L) = 0.05, so it rings at ω0·√(1-ζ²) (159 kHz,
    # period 6.291 µs) and the step response peaks at 10·(1 + exp(-πζ/√(1-ζ²))) = 18.55 V
    # (ngspice: 18.44 V). At 100 µs implicit Euler peaked at 10.0 V, no word.
    with pytest.warns(circuitnsds.CircuitWarning, match=r"c1, l1 rings at 159 kHz \(period "
                      r"6\.291 µs, damping ratio 0\.05.*Use a step of 314\.\d ns or less"):
        coarse = circuit_from(SERIES_RLC.format(step="100u")).transient(method="theta")
    assert coarse["v(b)"].max() < 10.5  # (what the warning is about)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", circuitnsds.CircuitWarning)
        fine = circuit_from(SERIES_RLC.format(step="50n").replace("1m", "20u")).transient(
            theta=0.5, method="theta")
    peak = 10 * (1 + np.exp(-np.pi * 0.05 / np.sqrt(1 - 0.05**2)))
    assert fine["v(b)"].max() == pytest.approx(peak, rel=2e-3)


def test_rows_too_far_apart_to_show_a_ringing_are_warned_under_the_default():
    # the default takes the exact integrator here: each row at 100 µs is exact (the ringing
    # has decayed by then: v(b) = 10 V), but the 18.55 V peak at 3.2 µs falls between rows;
    # at TSTEP 50 ns the rows show it, and nothing is said
    peak = 10 * (1 + np.exp(-np.pi * 0.05 / np.sqrt(1 - 0.05**2)))
    with pytest.warns(circuitnsds.CircuitWarning, match=r"c1, l1 rings at 159 kHz \(period "
                      r"6\.291 µs, damping ratio 0\.05\) but the rows are 100 µs apart.*the exact "
                      r"integrator follows the ringing and each row is exact.*TSTEP of 314\.\d ns"):
        coarse = circuit_from(SERIES_RLC.format(step="100u")).transient()
    assert coarse["v(b)"].max() < 10.1  # (what the warning is about: 9.95 V at 100 µs, then 10 V)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", circuitnsds.CircuitWarning)
        fine = circuit_from(SERIES_RLC.format(step="50n").replace("1m", "20u")).transient()
    assert fine["v(b)"].max() == pytest.approx(peak, rel=1e-3)  # (rows 50 ns apart: within 0.1 %)


def test_the_exact_integrator_is_warned_of_the_peaks_its_rows_hide_not_of_a_step():
    # The same series RLC at 100 µs rows under method=exact: its rows are the closed form at
    # their instants whatever their spacing (the rows sample the true ringing, not a damped
    # one): the warning says that its peak, 18.55 V, falls between them, not that a step
    # damps it (as it said before; its θ hand-offs' steps are still watched as θ's)
    with pytest.warns(circuitnsds.CircuitWarning, match=r"rows are 100 µs apart.*each row is exact") as said:
        exact = circuit_from(SERIES_RLC.format(step="100u")).transient(method="exact")
    assert not any("implicit Euler" in str(w.message) for w in said)
    t, vb = exact.time[2:], np.asarray(exact["v(b)"])[2:]  # (after the 1 ns edge: a step 0.5 ns late)
    t = t - 0.5e-9
    zeta, w0 = 0.05, 1e6
    wd = w0 * np.sqrt(1 - zeta**2)
    closed_form = 10 * (1 - np.exp(-zeta * w0 * t) * (np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2)
                                                      * np.sin(wd * t)))
    assert np.max(np.abs(vb - closed_form)) < 1e-6


def test_a_step_longer_than_a_time_constant_between_switchings_is_warned(netlists):
    # the hysteretic buck's L/R = 50 µs at a 100 µs step switched every 47 µs (analytic 38.1 µs)
    with pytest.warns(RunNote, match=r"the mode of l1 settles with a time "
                      r"constant of 50 µs but the step is 100 µs"):
        circuitnsds.read_netlist(netlists / "buck_hysteretic.cir").transient(step=100e-6, stop=400e-6,
                                                                             method="theta")


def test_a_run_keeping_some_signals_in_parts_is_checked_as_the_whole_run(netlists, monkeypatch):
    # the check watches the modes part by part (the driver's parts, here 3 steps each): a
    # run keeping v(b) was not checked at all before, and the buck's modes span its parts
    import circuitnsds.analyses.recorders as recorders

    monkeypatch.setattr(recorders, "segment_steps", lambda mlcs: 3)
    with pytest.warns(circuitnsds.CircuitWarning, match=r"c1, l1 rings at 159 kHz.*implicit Euler"):
        circuit_from(SERIES_RLC.format(step="100u")).transient(signals=["v(b)"], method="theta")
    with pytest.warns(circuitnsds.CircuitWarning, match=r"c1, l1 rings at 159 kHz.*rows are 100 µs"):
        circuit_from(SERIES_RLC.format(step="100u")).transient(signals=["v(b)"])  # (the default: exact rows)
    with pytest.warns(RunNote, match=r"the mode of l1 settles with a time "
                      r"constant of 50 µs but the step is 100 µs"):
        kept = circuitnsds.read_netlist(netlists / "buck_hysteretic.cir").transient(
            step=100e-6, stop=400e-6, signals=["i(l1)"], method="theta")
    assert kept.time.size == 5


# --- 10. pss of a circuit with no periodic solution --------------------------------------------

LC_DRIVEN = """V1 in 0 SIN(0 1 {f})
L1 in a 1m
C1 a 0 1u
.tran 1u 2m"""
ON_THETA = "\n.options method=theta"  # (the θ shooting; the default shoots on the exact map)


def test_pss_of_an_undamped_lc_driven_at_resonance_is_refused():
    # f0 = 1/(2π√(LC)) = 5032.92 Hz: the response grows without bound; the period map's
    # implicit-Euler damping gave a 'steady state' of 31.7 V at 1 µs, 316 V at 100 ns
    with pytest.raises(circuitnsds.SimulationError, match=r"no periodic steady state to show: "
                       r"along v\(a\) the circuit forgets"):
        circuit_from(LC_DRIVEN.format(f="5032.92") + ON_THETA).pss()


def test_exact_pss_of_an_undamped_lc_near_resonance_is_refused():
    # on the exact map (the default) 5032.92 Hz is 2.4e-7 below f0 = 5032.9212 Hz: the periodic
    # solution exists, v(a) = sin(ωt)/(1 - (ω/ω0)²) = 2.08 MV, but no transient reaches it
    # (the tank is undamped: multipliers on the unit circle, 1.5e-6 from 1): refused as the θ
    # shooting refuses it, not shown with a warning (exit 0 with megavolts), and final under
    # auto (the θ shooting is not tried instead); method=exact says the same
    for text in (LC_DRIVEN.format(f="5032.92"), LC_DRIVEN.format(f="5032.92") + "\n.options method=exact"):
        with pytest.raises(circuitnsds.SimulationError, match=r"no periodic steady state to show: along "
                           r"v\(a\) the circuit is undamped .* \(\|1 − μ\| = 1\.5e-06\): the exact "
                           r"periodic solution, about 6\.6e\+05 times"):
            circuit_from(text).pss()


def test_pss_of_a_half_bridge_driving_an_undamped_lc_at_resonance_is_refused():
    # the same tank switched between 12 V and 0 at its resonance (two modes per period): the
    # 'steady state' was 248 V at 1 µs and 2422 V at 100 ns
    body = ("Vin in 0 12\nVg g 0 PULSE(0 1 0 0 0 99.3456u 198.6914u)\nS1 in sw g 0 sw\n"
            "S2 sw 0 0 g swn\nL1 sw a 1m\nC1 a 0 1u\nRb a 0 1e9\n.model sw SW(VT=0.5 RON=1u)\n"
            ".model swn SW(VT=-0.5 RON=1u)\n.tran 1u 2m")
    with pytest.raises(circuitnsds.SimulationError, match="no periodic steady state to show"):
        circuit_from(body + ON_THETA).pss()
    # the exact map's orbit is the circuit's own steady state, 2.1 MV, damped by the 1 GΩ
    # bleeder and the switches' 1 µΩ alone: |λ| = 1 - 2e-7 per period, 5e6 periods to settle,
    # which it says (damped, however slowly: not refused)
    with pytest.warns(circuitnsds.CircuitWarning, match=r"attracts only slowly: the state along "
                      r"v\(a\) comes 2(\.\d)?e-07 .* about 5e\+06 periods \((9\d\d|1e\+03) s\)"):
        result = circuit_from(body).pss()
    assert result.waveforms["v(a)"].max() > 1e6


def test_exact_pss_of_an_rc_of_100_s_at_100_khz_is_warned_of_its_settling_time():
    # τ = 100 MΩ · 1 µF = 100 s against T = 10 µs: |λ| = e^{-1e-7}; the orbit (a sine's
    # response, 0 mean) is the steady state, reached over about 1e7 periods
    text = "V1 in 0 SIN(0 1 100k)\nR1 in a 100meg\nC1 a 0 1u\n.tran 0.1u 1m"
    with pytest.warns(circuitnsds.CircuitWarning, match=r"attracts only slowly: the state along v\(a\) "
                      r"comes 1e-07 of its distance .* about 1e\+07 periods \(100 s\)"):
        result = circuit_from(text).pss()
    # v(a) = Re[1/(1 + jωRC)]-shaped: amplitude 1/√(1 + (ωRC)²) = 1.6e-8 V
    omega = 2 * np.pi * 100e3
    assert np.abs(result.waveforms["v(a)"]).max() == pytest.approx(1 / np.hypot(1, omega * 100), rel=1e-3)


def test_pss_of_an_undamped_lc_driven_off_resonance_is_its_forced_response():
    # at 1 kHz the periodic solution exists and is unique: v(a) = sin(ωt)/(1 - (ω/ω0)²);
    # implicit Euler's damping makes it attracting (within 1e-5), the exact map's orbit is the
    # closed form, and not attracting (the tank is undamped), which it says
    import warnings

    omega, omega0 = 2 * np.pi * 1000, 1 / np.sqrt(1e-3 * 1e-6)
    expected = 1 / (1 - (omega / omega0) ** 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", circuitnsds.CircuitWarning)
        result = circuit_from(LC_DRIVEN.format(f="1000") + ON_THETA).pss()
    assert result.waveforms["v(a)"].max() == pytest.approx(expected, rel=1e-5)
    with pytest.warns(circuitnsds.CircuitWarning, match=r"not attracting, the state along v\(a\)"):
        exact = circuit_from(LC_DRIVEN.format(f="1000")).pss()
    assert exact.waveforms["v(a)"].max() == pytest.approx(expected, rel=1e-12)


# --- 11. loops of ideal diodes: the solution is not unique ---------------------------------------

@pytest.mark.parametrize(("diodes", "loop"), [
    ("D1 a b dd\nD2 b a dd", "d1, d2 form a loop of ideal diodes (a → b → a)"),
    ("D1 a b dd\nD2 b c dd\nD3 c a dd", "d1, d2, d3 form a loop of ideal diodes (a → b → c → a)"),
])
def test_a_loop_of_ideal_diodes_is_warned_and_refused_under_strict(diodes, loop, tmp_path):
    from circuitnsds.cli.main import main

    body = f"V1 in 0 SIN(0 5 1k)\nR1 in a 1k\nR2 b 0 1k\nR3 c 0 1k\n{diodes}\n.model dd D()\n.tran 10u 2m"
    with pytest.warns(circuitnsds.CircuitWarning, match=re.escape(loop)):
        circuit_from(body).transient()
    netlist = tmp_path / "loop.cir"
    netlist.write_text(f"loop\n{body}\n.end\n")
    assert main(["run", str(netlist), "-o", str(tmp_path / "out.csv"), "--strict", "-q"]) != 0


def test_diodes_with_a_drop_or_a_resistance_in_the_loop_are_not_warned():
    import warnings

    for model in ("D(Vfwd=0.7)", "D(Ron=0.1)"):
        with warnings.catch_warnings():
            warnings.simplefilter("error", circuitnsds.CircuitWarning)
            circuit_from(f"V1 in 0 SIN(0 5 1k)\nR1 in a 1k\nR2 b 0 1k\nD1 a b dd\nD2 b a dd\n"
                         f".model dd {model}\n.tran 10u 2m").transient()


# --- 4. PULSE with PW = 0 ---------------------------------------------------------------------

def test_a_pulse_with_zero_width_is_noted_naming_the_source():
    # PW = 0 is PW = TSTOP (ngspice): 5 µs rise, then flat at 1 V to the end of each 10 µs
    # period (a sawtooth with a flat top, not the triangle it looks like)
    with pytest.warns(RunNote, match=r"vcarrier: PULSE with PW = 0 is read as PW = TSTOP"):
        waves = circuit_from("Vcarrier c 0 PULSE(0 1 0 5u 5u 0 10u)\nR1 c 0 1k\n.tran 1u 40u"
                             ).transient()
    assert waves["v(c)"][(waves.time > 6e-6) & (waves.time < 9.5e-6)] == pytest.approx(1.0)


# --- 6. sweep's .meas form, compare's signals checked before the run, --version ----------------

def test_sweep_takes_the_meas_form_that_run_takes(netlists):
    from circuitnsds.sweeps.api import sweep

    table = sweep(netlists / "sweeps" / "buck_param.cir", {"D": [0.25, 0.5]}, workers=0, stop=1e-3,
                  measure=["tran vavg AVG v(out) from=0.5m to=1m", "mean(v(out), 0.5m, 1m)"])
    assert list(table["status"]) == ["ok", "ok"]
    np.testing.assert_allclose(table["tran vavg AVG v(out) from=0.5m to=1m"],
                               table["mean(v(out), 0.5m, 1m)"], rtol=1e-9)
    with pytest.raises(circuitnsds.CircuitnsdsError, match="AVG does not take fro"):
        sweep(netlists / "sweeps" / "buck_param.cir", {"D": [0.5]}, workers=0,
              measure=["tran vavg AVG v(out) fro=1m"])


@pytest.mark.parametrize(("signals", "message"), [("v(out,sw)", "differential voltage"),
                                                  ("v(outt)", r"unknown signal\(s\) v\(outt\)")])
def test_compare_refuses_signals_before_running_anything(monkeypatch, netlists, signals, message):
    import circuitnsds.compare.api as api
    from circuitnsds.circuit.circuit import Circuit
    from circuitnsds.compare import CompareError

    def no_run(*args, **kwargs):
        raise AssertionError("the simulation ran before the signals were checked")

    monkeypatch.setattr(api, "ngspice_version", lambda: "39")
    monkeypatch.setattr(Circuit, "transient", no_run)
    with pytest.raises(CompareError, match=message):
        api.compare(netlists / "buck_converter.cir", signals=[signals])


def test_version(capsys):
    from circuitnsds.cli.main import main

    with pytest.raises(SystemExit) as exited:
        main(["--version"])
    assert exited.value.code == 0
    assert capsys.readouterr().out.strip() == f"circuitnsds {circuitnsds.__version__}"


# --- 9. compare also measures on ngspice's own time points -------------------------------------

def test_compare_measures_the_largest_difference_on_ngspices_points_too():
    # ours on a 100 µs grid (flat 10 V), ngspice's at 1 µs ringing to 18.44 V between two of
    # our points: on our grid alone the difference was 0; on its points it is 8.44 V at 3 µs
    from circuitnsds.compare.api import _on_both_grids
    from circuitnsds.compare.metrics import resample, signal_metrics
    from circuitnsds.output.waveforms import Waveforms

    ours_time = np.array([0.0, 100e-6, 200e-6])
    ours = Waveforms(ours_time, {"v(b)": np.array([10.0, 10.0, 10.0])})
    ng_time = np.linspace(0.0, 200e-6, 201)
    ng = np.where(np.isclose(ng_time, 3e-6), 18.44, 10.0)
    class Run:  # (what _on_both_grids reads of an NgspiceRun)
        waveforms = type("W", (), {"time": ng_time, "__getitem__": lambda self, name: ng})()

    on_ours = signal_metrics(ours_time, ours["v(b)"], resample(ng_time, ng, ours_time),
                             (0.0, 200e-6), "v(b)")
    assert on_ours.nmax == 0.0
    both = _on_both_grids(on_ours, ours, Run(), "v(b)", (0.0, 200e-6))
    assert both.nmax * both.scale == pytest.approx(8.44)
    assert both.max_at == pytest.approx(3e-6)
    assert both.ripple_other == pytest.approx(8.44)


@pytest.mark.ngspice
def test_compare_of_the_under_resolved_rlc_shows_the_peak_difference(tmp_path):
    from circuitnsds.compare import compare

    netlist = tmp_path / "rlc.cir"
    netlist.write_text("rlc\n" + SERIES_RLC.format(step="100u") + "\n.end\n")
    with pytest.warns(circuitnsds.CircuitWarning, match="rings at 159 kHz"):
        result = compare(netlist, signals=["v(b)"])
    metric = result.runs[0].metrics["v(b)"]
    assert metric.ripple_other - metric.ripple_ref > 8.0   # ngspice's peak 18.44 V against 10 V
    assert metric.nmax * metric.scale > 8.0


# --- 12. perfect coupling, library warnings, theta's message, the loss table ---------------------

FLYBACK_K = """V1 in 0 12
Vg g 0 PULSE(0 5 0 0 0 5u 10u)
Lp in d 100u
Ls 0 s 100u
K1 Lp Ls {k}
S1 d 0 g 0 sw
D1 s out dd
Cout out 0 10u
R1 out 0 10
.model sw SW(VT=2.5 RON=10m)
.model dd D()
.tran 10n 40u"""


def test_perfect_coupling_moves_the_flux_instead_of_cutting_a_current():
    # K = 1: when S1 opens, lp's current stops and ls's takes the flux (no Dirac voltage, no
    # warning); K = 0.9: the leakage flux is cut, and that is warned about
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", circuitnsds.CircuitWarning)
        waves = circuit_from(FLYBACK_K.format(k="1")).transient()
    opened = np.searchsorted(waves.time, 5e-6) + 1
    flux = 100e-6 * (waves["i(lp)"] + waves["i(ls)"])  # Lp·ip + M·is (M = Lp = Ls)
    assert abs(flux[opened + 1] - flux[opened - 1]) < 1e-3 * abs(flux[opened - 1])
    with pytest.warns(circuitnsds.CircuitWarning, match="the current of lp .* is cut"):
        circuit_from(FLYBACK_K.format(k="0.9")).transient()


def test_a_library_warning_is_printed_once_with_its_count_not_as_ours(capsys):
    import warnings

    from circuitnsds.cli.main import _print_warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(178):
            warnings.warn_explicit("overflow encountered in multiply", RuntimeWarning, "lemke.py", 253)
        warnings.warn(circuitnsds.CircuitWarning("a finding"), stacklevel=1)
    _print_warnings(caught)
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == ["circuitnsds: warning: a finding",
                     "circuitnsds: library RuntimeWarning (lemke.py:253, 178 times): overflow "
                     "encountered in multiply (from a library the run uses, not a finding about the "
                     "circuit)"]


def test_theta_just_below_one_half_is_quoted_as_given():
    with pytest.raises(circuitnsds.CircuitError, match=r"theta = 0\.4999999999 is outside"):
        circuit_from("V1 a 0 1\nR1 a b 1\nC1 b 0 1u\n.tran 1u 10u").transient(theta=0.4999999999)


def test_loss_table_without_input_or_loads_has_no_nan_and_no_zero_efficiency():
    from circuitnsds.output.measure import losses

    circuit = circuit_from("C1 out esr 100u ic=10\nResr esr 0 0.1\nRl out 0 10\n.tran 1u 1m uic")
    text = losses(circuit.transient(), circuit).format()
    assert "nan" not in text and "efficiency 0" not in text
    assert "no source delivers net power over the window" in text
    buck = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    waves = buck.transient()
    assert "name the loads" in losses(waves, buck).format()
    for line in losses(waves, buck, outputs=("rload",)).format().splitlines()[2:-1]:
        # element, kind, power with its unit, share: separated however wide each one is
        assert len(line.split()) >= 3 + (line.split()[1] in ("input", "loss", "output", "stored"))
    assert "efficiency" in losses(waves, buck, outputs=("rload",)).format()


# --- 7. default plots ----------------------------------------------------------------------------

def test_default_plot_gives_small_signals_a_panel_of_their_scale_and_keeps_device_currents():
    from circuitnsds.output.plot import figure_data
    from circuitnsds.output.waveforms import Waveforms

    time = np.linspace(0.0, 1e-3, 11)
    signals = {"v(bus)": 400 + 0 * time, "v(sw)": 380 * (time > 5e-4), "v(ctl)": 0.8 + 0 * time,
               "v(ramp)": time / 1e-3}
    currents = [f"i(v{k})" for k in range(6)] + [f"i(c{k})" for k in range(6)] + [
        "i(lr)", "i(d1)", "i(d2)", "i(s1)", "i(r1)"]
    signals.update({name: np.sin(time * 1e4 * (k + 1)) for k, name in enumerate(currents)})
    data = figure_data(Waveforms(time, signals, title="llc"))
    traces = [[name for name, _ in panel.traces] for panel in data.panels]
    assert traces[0] == ["v(bus)", "v(sw)"]           # 400 V scale
    assert traces[1] == ["v(ctl)", "v(ramp)"]         # 1 V scale: not flat under 400 V
    drawn = [name for panel in traces[2:] for name in panel]
    assert {"i(lr)", "i(d1)", "i(d2)", "i(s1)"} <= set(drawn)   # kept beyond the first 8
    assert "i(r1)" not in drawn and len(drawn) == 8


def test_bode_crossover_label_in_engineering_notation(tmp_path, monkeypatch):
    import circuitnsds.output.bode as bode

    labels = []
    monkeypatch.setattr(bode, "save_figure", lambda figure, path, dpi: labels.extend(
        text.get_text() for axis in figure.axes for text in axis.texts))

    result = circuit_from("V1 in 0 DC 0 AC 1\nR1 in out 1k\nC1 out 0 1u\n.ac dec 10 10 100k").ac()
    bode.plot_bode(result, tmp_path / "b.png", marks={"v(out)": (56040.0, 45.0)})
    assert any("crossover 56 kHz" in label for label in labels)


def test_theta_half_does_not_ring_after_a_source_driven_switch_closes_onto_a_capacitor():
    # the same closing driven by the gate source itself (a scheduled switching, which the mode
    # loop takes on its own): i(s1) swung ±2 % about 1.2 A after one restart step
    waves = circuit_from(GATE_RC_CLOSES_ONTO_C.replace("Rg g0 g 3\nCg g 0 5n\n", "")
                         .replace("S1 in sw g 0", "S1 in sw g0 0")).transient(theta=0.5)
    current = waves["i(s1)"]
    closed = int(np.argmax(np.abs(current) > 0.5))
    np.testing.assert_allclose(current[closed + 5:], 12 / 10.01, rtol=2e-3)


def test_a_run_of_one_step_longer_than_the_time_constant_is_noted():
    # .tran 1 1m uic: one step of 1 ms = RC; implicit Euler gives 0.5 V for 1 - 1/e = 0.632 V,
    # and the check looked at TSTEP (1 s: 'negligible') instead of the step taken
    with pytest.warns(RunNote, match="the mode of c1 settles with a time constant of 1 ms but "
                      "the step is 1 ms"):
        circuit_from("V1 in 0 1\nR1 in a 1k\nC1 a 0 1u\n.tran 1 1m uic").transient(method="theta")


# --- found by the adversarial trial ---------------------------------------------------------------

def test_uic_start_shows_the_current_of_a_diode_conducting_at_t0():
    # C1 at 10 V discharging through D1 into 1 kΩ: at t = 0 i(d1) = i(r1) = 10 mA (it showed 0 A
    # beside i(r1) = 10 mA: Kirchhoff's current law broken in the first row)
    waves = circuit_from("C1 a 0 1u ic=10\nD1 a b dd\nR1 b 0 1k\n.model dd D()\n.tran 1u 10u uic"
                         ).transient()
    assert waves["i(d1)"][0] == pytest.approx(0.01, rel=1e-9)
    assert waves["i(r1)"][0] == pytest.approx(0.01, rel=1e-9)


def test_a_sin_of_negative_frequency_runs_as_sin_of_minus_omega_t():
    # SIN(0 1 -1k) at a step too long for it: the refinement divided by zero (a traceback)
    with pytest.warns(RunNote, match="cannot resolve the sources"):
        waves = circuit_from("V1 a 0 SIN(0 1 -1k)\nR1 a 0 1\n.tran 100u 2m").transient()
    np.testing.assert_allclose(waves["v(a)"], -np.sin(2 * np.pi * 1e3 * waves.time), atol=1e-12)


def test_a_sin_of_negative_frequency_ends_after_its_ncycles_periods_of_1_over_f():
    # LTspice's NCYCLES of SIN(0 5 -50 0 0 0 0.25) ends the sine a quarter period (5 ms) in,
    # holding -5·sin(π/2) = -5 V; it ended at -0.25/50 s, before it began: 0 V throughout
    waves = circuit_from("V1 a 0 SIN(0 5 -50 0 0 0 0.25)\nR1 a 0 1\n.tran 100u 10m").transient()
    expected = -5 * np.sin(2 * np.pi * 50 * np.minimum(waves.time, 5e-3))
    np.testing.assert_allclose(waves["v(a)"], expected, atol=1e-9)


def test_the_period_of_a_sin_of_negative_frequency_is_1_over_its_magnitude():
    # the periodic steady state of SIN(0 5 -50) through R-C (ωRC = π/10): it was refused,
    # "the period must be positive, got -0.02 s"; its fundamental is -5/√(1+(ωRC)²) sin(ωt - atan ωRC)
    result = circuit_from("V1 a 0 SIN(0 5 -50)\nR1 a b 1k\nC1 b 0 1u\n.tran 10u 20m").pss()
    waves = result.waveforms
    omega = 2 * np.pi * 50
    wrc = omega * 1e3 * 1e-6
    expected = -5 / np.hypot(1, wrc) * np.sin(omega * waves.time - np.arctan(wrc))
    np.testing.assert_allclose(waves["v(b)"], expected, atol=3e-3)  # implicit Euler: 2.2 mV at 10 µs


def test_theta_half_does_not_ring_after_a_source_corner_across_a_fast_rc():
    # a PWL source dropping from 1 V to 0 in zero time across 1 Ω into 1 µF (τ = 1 µs) at
    # h = 10 µs: i(r1) alternated -91, +61, -40 mA after the drop (true: -1 A decaying in 1 µs)
    waves = circuit_from("V1 in 0 PWL(0 0 1m 1 1m 0 2m 0)\nR1 in a 1\nC1 a 0 1u\n.tran 10u 3m"
                         ).transient(theta=0.5)
    after = waves["i(r1)"][(waves.time > 1.035e-3) & (waves.time < 2e-3)]
    assert np.abs(after).max() < 1e-3


def test_a_coupling_just_above_one_is_quoted_as_written():
    with pytest.raises(circuitnsds.NetlistError, match=r"k=1\.0000001 must satisfy"):
        circuit_from("V1 p 0 1\nL1 p 0 1m\nL2 s 0 4m\nK1 L1 L2 1.0000001\nR1 s 0 1k\n.tran 1u 3m uic")


def test_a_fast_decaying_mode_under_smooth_forcing_only_is_not_noted():
    # L1/R1 = 1 µs at h = 1 µs, fed by a sine current from the operating point: nothing starts
    # a transient of that mode, v(a) = L·di/dt = 2π·1k·1 V peak is followed (0.005 % off);
    # the note was spurious there
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", RunNote)
        waves = circuit_from("I1 0 a SIN(0 1 1k)\nL1 a 0 1\nR1 a 0 1e6\n.tran 1u 2m").transient()
    assert np.abs(waves["v(a)"]).max() == pytest.approx(2 * np.pi * 1e3, rel=1e-4)


@pytest.mark.parametrize("cut", [1, 7, 40, 99])
def test_the_modes_tallied_part_by_part_are_those_of_the_whole_run(cut):
    from circuitnsds.checks.time_scales import ModeTally, visited_modes

    rng = np.random.default_rng(cut)
    switches = rng.random((100, 2)) < 0.5
    active = rng.random((100, 3)) < [0.9, 0.5, 0.1]
    tally = ModeTally()
    tally.add(switches[1:cut], active[1:cut])  # (row 0, the initial state, left out)
    tally.add(switches[cut:], active[cut:])
    whole = visited_modes(switches, active, most=100)
    rows = {(s.tobytes(), a.tobytes()):
            int(((switches[1:] == s).all(axis=1) & (active[1:] == a).all(axis=1)).sum())
            for s, a in whole}
    assert sum(rows.values()) == 99  # every row after the first is one of the modes found
    counts = [rows[(s.tobytes(), a.tobytes())] for s, a in tally.modes(most=100)]
    assert sorted(rows) == sorted((s.tobytes(), a.tobytes()) for s, a in tally.modes(most=100))
    assert counts == sorted(counts, reverse=True)  # the most visited first
