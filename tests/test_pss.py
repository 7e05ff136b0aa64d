"""Periodic steady state (analyses/pss.py, engine/step_maps.py): closed forms, averaged
converter relations, agreement with the last period of long transients, Floquet multipliers
against the decay a transient shows, and the errors of circuits without a (unique) period."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import circuitnsds
from circuitnsds.engine.integrate import integrate
from circuitnsds.engine.step_maps import StepMapper
from circuitnsds.engine.timegrid import time_grid
from circuitnsds.errors import RunNote
from tests.conftest import pinned
from tests.device_checks import assert_device_laws
from tests.test_exact_stepper import PEAK

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"
# converters for the periodic steady state only: ngspice cannot run the flyback (Timestep too
# small at the clamp), and the DCM boost's switch node floats in its idle interval, so they
# are kept out of netlists/ (whose every file is compared with ngspice)
CONVERTER_NETLISTS = NETLISTS.parent / "benchmarks" / "netlists"


def rc_square(h: float, tau_ratio: float = 1.0) -> str:
    """RC (τ = RC = tau_ratio · T) driven by a 0/1 V square wave of period T = 10 µs whose
    edges last one step h (so every grid point samples a plateau or a corner)."""
    period, rc = 10e-6, tau_ratio * 10e-6
    return (f"RC square wave\nV1 in 0 PULSE(0 1 0 {h:.12g} {h:.12g} {period / 2 - h:.12g} {period})\n"
            f"R1 in out 1k\nC1 out 0 {rc / 1e3:.12g}\n.tran {h:.12g} 1m\n.end\n")


@pytest.mark.parametrize("steps", [20, 100])
def test_rc_square_wave_is_the_closed_form_of_the_implicit_euler_recursion(steps):
    # v_{k+1} = g v_k + (1 - g) u_{k+1}, g = 1/(1 + h/RC), u = 1 on the N/2 steps ending in
    # (0, T/2], 0 on the others: v(0) = g^{N/2} (1 - g^{N/2}) / (1 - g^N), and Φ = g^N.
    period = 10e-6
    h = period / steps
    result = circuitnsds.read_netlist(pinned(rc_square(h))).pss()  # (θ's maps: the default is exact)
    g = 1.0 / (1.0 + h / period)
    half = steps // 2
    expected = g**half * (1 - g**half) / (1 - g**steps)
    out = result.waveforms["v(out)"]
    assert result.state_names == ["v(out)"]
    assert out[0] == pytest.approx(expected, rel=1e-12, abs=1e-14)
    assert out[-1] == pytest.approx(expected, rel=1e-12, abs=1e-14)
    assert out[half] == pytest.approx(g**half * expected + 1 - g**half, rel=1e-12)
    assert result.multipliers == pytest.approx([g**steps], rel=1e-12)
    assert result.iterations == 1  # a linear circuit: one Newton step is exact


def test_rc_square_wave_tends_to_the_continuous_steady_state():
    # as h -> 0: v(0) = e^{-T/2τ} / (1 + e^{-T/2τ}) (τ = T), with a first-order error (θ)
    exact = math.exp(-0.5) / (1 + math.exp(-0.5))
    errors = []
    for steps in (200, 400, 800):
        result = circuitnsds.read_netlist(pinned(rc_square(10e-6 / steps))).pss()
        errors.append(abs(result.waveforms["v(out)"][0] - exact))
    assert errors[-1] < 2e-4
    assert errors[0] / errors[1] == pytest.approx(2.0, rel=0.05)
    assert errors[1] / errors[2] == pytest.approx(2.0, rel=0.05)


@pytest.mark.parametrize("steps", [4, 20, 800])
def test_rc_square_wave_on_the_default_exact_map_is_the_continuous_steady_state(steps):
    # the default (method=auto) shoots on the exact period map: the edges (one step long, as
    # above) are ramps it integrates in closed form, so at any step v(0) is the continuous
    # solution of the ramped square wave. From v(0) = v0 over the ramp up (0..h), the top
    # (h..T/2), the ramp down (T/2..T/2+h) and the bottom: v(T) = v0 by symmetry of the
    # square wave: v(T/2) = 1 - v0. With τ = T: over a ramp of length h from v_a, the end
    # is v_a e^{-h/τ} ± (1 - τ/h (1 - e^{-h/τ})) (up: +, from 0 to 1; down: from 1 to 0).
    period = tau = 10e-6
    h = period / steps
    decay = math.exp(-h / tau)
    ramp = 1 - tau / h * (1 - decay)  # a ramp 0 -> 1 over h from v = 0 ends at this
    flat = math.exp(-(period / 2 - h) / tau)
    # v(T/2) = [v0·decay + ramp]·flat + (1 - flat) = 1 - v0
    v0 = flat * (1 - ramp) / (1 + decay * flat)
    result = circuitnsds.read_netlist(rc_square(h)).pss()
    out = result.waveforms["v(out)"]
    assert out[0] == pytest.approx(v0, rel=1e-10, abs=1e-14)
    assert result.multipliers == pytest.approx([math.exp(-period / tau)], rel=1e-10)


BUCK = """Buck 24 V, 100 kHz, D = 0.5, with switch, diode and inductor resistances
Vin in 0 DC 24
Vgate gate 0 PULSE(0 5 0 10n 10n 4.99u 10u)
S1 in sw gate 0 swmod
D1 0 sw dfree
L1 sw x 100u
RL x out 50m
C1 out 0 100u
Rload out 0 5
.model swmod SW(VT=2.5 VH=0 RON=40m ROFF=1e9)
.model dfree D(Ron=20m)
.tran 0.1u 2m
.end
"""


def test_buck_average_output_is_d_vin_minus_resistive_drops():
    # averaged CCM buck (D = 0.5 exactly: the gate is above VT for PW + (TR+TF)/2 = 5 µs):
    # Vout = D·Vin − I·(D·Ron_s + (1−D)·Ron_d + R_L), I = Vout/R. The discrete steady state
    # satisfies the per-phase averages exactly; what remains is the correlation of the
    # resistive drops with the inductor ripple (~Ron·ΔI²/(12 I) ≈ 1e-5 V here).
    result = circuitnsds.read_netlist(pinned(BUCK)).pss()
    duty, vin, load = 0.5, 24.0, 5.0
    drops = duty * 40e-3 + (1 - duty) * 20e-3 + 50e-3
    expected = duty * vin / (1 + drops / load)
    waves = result.waveforms
    weights = np.diff(waves.time) / result.period  # the grid holds the gate's corners

    def mean(signal):  # implicit Euler balances the steps' end values
        return float(weights @ waves[signal][1:])

    assert mean("v(out)") == pytest.approx(expected, abs=2e-4)
    assert mean("i(l1)") == pytest.approx(mean("v(out)") / load, rel=1e-10)  # charge balance on C1
    assert result.iterations <= 3
    assert result.relative_residual < 1e-9


def test_buck_average_output_on_the_default_exact_map():
    # the same relations on the exact period map (the default): the means are the closed-form
    # integrals over the period (PSSResult.means), so the charge balance on C1 holds to its
    # Newton tolerance
    result = circuitnsds.read_netlist(BUCK).pss()
    duty, vin, load = 0.5, 24.0, 5.0
    drops = duty * 40e-3 + (1 - duty) * 20e-3 + 50e-3
    assert result.maps is None and result.exact is not None
    assert result.means["v(out)"] == pytest.approx(duty * vin / (1 + drops / load), abs=2e-4)
    assert result.means["i(l1)"] == pytest.approx(result.means["v(out)"] / load, rel=1e-9)
    assert result.relative_residual < 1e-12


def _settled_last_period(circuit, result, step, periods):
    """The transient of ``periods`` periods on the same step; its last period's samples."""
    # (pss shoots on θ's period map unless .options method=exact: its transient is θ's)
    waves = circuit.transient(step, periods * result.period, method="theta")
    last = waves.time >= waves.time[-1] - result.period * (1 + 1e-9)
    return waves, last


CONVERTERS = {
    "boost_ccm": ((NETLISTS / "boost_converter.cir").read_text(), 0.2e-6, 2500),
    "boost_dcm": ((CONVERTER_NETLISTS / "boost_dcm.cir").read_text(), 0.2e-6, 400),
    "flyback_rcd": ((CONVERTER_NETLISTS / "flyback_rcd.cir").read_text(), 0.2e-6, 600),
    "bridge": ("""Full-wave bridge 50 Hz, 100 uF, 100 ohm
Vmains line acn SIN(0 325 50)
Rsrc line acp 0.5
D1 acp out drect
D2 acn out drect
D3 0 acp drect
D4 0 acn drect
C1 out 0 100u
Rload out 0 100
.model drect D(Vfwd=0.8 Ron=20m)
.end
""", 50e-6, 8),
}


@pytest.mark.parametrize("name", sorted(CONVERTERS))
def test_pss_is_the_last_period_of_a_settled_transient(name):
    text, step, periods = CONVERTERS[name]
    circuit = circuitnsds.read_netlist(pinned(text))  # (θ's shooting against θ's transient)
    result = circuit.pss(step=step)
    assert result.relative_residual <= 1e-9
    assert result.iterations <= 6
    assert_device_laws(circuit, result.waveforms)  # every device law holds in the settled period
    # the transient's distance from the periodic solution after `periods` periods is at most
    # |λ|^periods times where it started (a bound once the mode sequence is the settled one)
    largest = float(np.abs(result.multipliers).max())
    assert largest < 1
    remaining = largest ** (periods - 10)
    waves, last = _settled_last_period(circuit, result, step, periods)
    start = np.array([waves[name_][0] for name_ in result.waveforms.names])
    for signal in result.waveforms.names:
        ours, theirs = result.waveforms[signal], waves[signal][last]
        assert ours.shape == theirs.shape
        span = np.ptp(ours)
        if span < 1e-9 * (1 + np.abs(ours).max()):
            continue
        tolerance = max(1e-6 * span, 10 * remaining * np.abs(start).max())
        assert np.abs(ours - theirs).max() <= tolerance, signal
    assert 10 * remaining * np.abs(start).max() < 1e-3 * np.ptp(result.waveforms["v(out)"])


def test_monodromy_is_the_decay_a_transient_shows():
    # from the periodic state plus a small disturbance δ, the state at the end of period j
    # is x* + Φ^j δ (same mode sequence); its decay rate is -ln|λ_max| / T
    text, step, _ = CONVERTERS["boost_ccm"]
    circuit = circuitnsds.read_netlist(pinned(text))  # (θ's step maps)
    result = circuit.pss(step=step)
    mlcs = circuit.mlcs(circuit.analyses["tran"].source_defaults)
    periods = 200
    grid = time_grid(step, periods * result.period, mlcs.breakpoints(periods * result.period))
    state = result.maps.state
    y0 = result.maps.trajectory.y[0].copy()
    delta = np.zeros(y0.size)
    delta[state] = 1e-3 * np.abs(result.state)
    run = integrate(mlcs, grid, y0 + delta, None, None, result.maps.trajectory.active[0],
                    result.maps.trajectory.switches[0])
    ends = np.searchsorted(grid, np.arange(periods + 1) * result.period - 1e-15)
    deviation = run.y[ends][:, state] - result.state
    predicted = [delta[state]]
    for _ in range(periods):
        predicted.append(result.monodromy @ predicted[-1])
    # (to the rounding of 10⁴ steps and of x* itself, amplified by 1/(1 − |λ|) ≈ 120)
    assert np.abs(deviation - np.array(predicted)).max() < 1e-7 * np.abs(delta).max()
    norms = np.linalg.norm(deviation, axis=1)
    fitted = -np.polyfit(np.arange(100, periods + 1) * result.period, np.log(norms[100:]), 1)[0]
    assert fitted == pytest.approx(result.decay_rate, rel=0.02)


def test_step_maps_reproduce_the_run():
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    mlcs = circuit.mlcs()
    grid = time_grid(0.1e-6, 30e-6, mlcs.breakpoints(30e-6))
    from circuitnsds.analyses.operating_point import operating_point

    start = operating_point(circuit, mlcs)
    maps = StepMapper(mlcs, grid).run(start.y, start.charge, start.active, start.switches)
    assert maps.map_error() < 1e-10
    phi, c = maps.composition()
    x = maps.trajectory.y[:, maps.state]
    assert np.abs(phi @ x[0] + c - x[-1]).max() < 1e-10 * np.abs(x).max()
    Y, g = maps.full_map(5)  # every unknown from the state
    assert np.abs(Y[:mlcs.n] @ x[5] + g[:mlcs.n] - maps.trajectory.y[6]).max() < 1e-9
    with pytest.raises(ValueError, match="theta = 1"):
        StepMapper(mlcs, grid, theta=0.5).run(start.y)


def test_period_from_the_sources_and_from_pss_line():
    text = ("two sources\nV1 a 0 SIN(0 1 50)\nV2 b 0 PULSE(0 1 0 1u 1u 3m {1/150})\nR1 a c 1k\n"
            "C1 c 0 1u\nR2 b c 1k\n.tran 50u 0.1\n.end\n")
    result = circuitnsds.read_netlist(text).pss()
    assert result.period == pytest.approx(0.02, rel=1e-12)  # lcm(20 ms, 6.67 ms)
    assert result.waveforms.time[-1] - result.waveforms.time[0] == pytest.approx(0.02)
    text_pss = text.replace(".tran 50u 0.1", ".pss 25 0 0 200")
    result = circuitnsds.read_netlist(text_pss).pss()
    assert result.period == pytest.approx(0.04)
    assert result.waveforms.time.size - 1 >= 200


@pytest.mark.parametrize("sources, message", [
    ("V1 a 0 DC 1", "no periodic source"),
    ("V1 a 0 PWL(0 0 1m 1)", "V1 .* is not periodic"),
    ("V1 a 0 SIN(0 1 50 0 10)", "no damping"),
    ("V1 a 0 SIN(0 1 50)\nV2 b 0 SIN(0 1 70.7106781187)", "no common multiple"),
])
def test_no_period_is_refused_in_words(sources, message):
    text = f"t\n{sources}\nR1 a 0 1k\nR2 b 0 1k\nV9 b 0 0\n.end\n" if "V2" not in sources else \
        f"t\n{sources}\nR1 a 0 1k\nR2 b 0 1k\n.end\n"
    with pytest.raises(circuitnsds.CircuitError, match=message):
        circuitnsds.read_netlist(text).pss()


@pytest.mark.parametrize("source, message", [
    # each ran with .pss GFREQ and reported a converged "periodic" state, exit 0
    ("AM(1 0 1.3k 10k)", "V1 .* is not periodic: AM"),
    ("PWL(0 0 1m 1)", "V1 .* is not periodic"),
    ("SIN(0 1 1.3k)", r"V1 repeats every 0.000769231 s, and the period given to pss, 0.001 s"),
])
def test_a_given_period_that_a_source_does_not_repeat_with_is_refused(source, message):
    text = f"t\nV1 a 0 {source}\nD1 a b dm\nR1 b 0 1k\nC1 b 0 1u\n.model dm d\n.pss 1k\n.end\n"
    with pytest.raises(circuitnsds.CircuitError, match=message):
        circuitnsds.read_netlist(text).pss()
    # a harmonic of the given period is periodic with it
    harmonic = text.replace(source, "SIN(0 1 3k)")
    assert circuitnsds.read_netlist(harmonic).pss().period == pytest.approx(1e-3)


@pytest.mark.parametrize("method", ["theta", "exact"])
def test_undamped_state_is_diagnosed(method):
    # an inductor across a square wave of non-zero mean: its current ramps every period, so
    # I − Φ is singular (on the exact map that was a LinAlgError, an internal error)
    text = pinned("t\nV1 a 0 PULSE(0 1 0 1u 1u 6u 10u)\nL1 a 0 1m\n.tran 0.1u 1m uic\n.end\n", method)
    with pytest.raises(circuitnsds.SimulationError, match=r"singular.*i\(l1\) is not damped"):
        circuitnsds.read_netlist(text).pss()
    # a capacitor in a cut-set of capacitors: every charge on it is periodic
    text = "t\nV1 a 0 PULSE(0 1 0 1u 1u 4u 10u)\nC1 a b 1u\nC2 b 0 1u\n.tran 0.1u 1m uic\n.end\n"
    with pytest.warns(circuitnsds.CircuitWarning, match=r"not unique.*v\(b\)"):
        circuitnsds.read_netlist(text).pss()


def test_theta_below_one_is_refused_and_the_netlist_option_warned():
    from circuitnsds.analyses.pss import run_pss

    text = rc_square(0.1e-6)
    with pytest.raises(circuitnsds.CircuitError, match="implicit Euler"):
        run_pss(circuitnsds.read_netlist(text), None, theta=0.5)
    with pytest.warns(circuitnsds.CircuitWarning, match=r"theta=0.5 applies to the transient"):
        result = circuitnsds.read_netlist(text.replace(".end", ".options theta=0.5\n.end")).pss()
    assert result.iterations == 1


def test_pss_line_errors():
    with pytest.raises(circuitnsds.NetlistError, match="GFREQ"):
        circuitnsds.read_netlist("t\nV1 a 0 SIN(0 1 50)\nR1 a 0 1\n.pss\n.end\n")
    with pytest.raises(circuitnsds.NetlistError, match="PSSPOINTS"):
        circuitnsds.read_netlist("t\nV1 a 0 SIN(0 1 50)\nR1 a 0 1\n.pss 50 0 0 2.5\n.end\n")
    with pytest.warns(circuitnsds.NetlistWarning, match="OSCNOB"):
        circuitnsds.read_netlist("t\nV1 a 0 SIN(0 1 50)\nR1 a 0 1\n.pss 50 0 a\n.end\n")


def test_cli_pss_writes_the_period_and_measures(tmp_path, capsys):
    from circuitnsds.cli.main import main

    output = tmp_path / "buck.csv"
    status = main(["pss", str(NETLISTS / "buck_converter.cir"), "-o", str(output), "-q",
                   "--measure", "mean(v(out))"])
    assert status == 0
    lines = output.read_text().splitlines()
    assert lines[0].startswith("time,")
    assert float(lines[-1].split(",")[0]) == pytest.approx(10e-6)
    assert "mean(v(out))" in capsys.readouterr().out
    assert main(["pss", str(NETLISTS / "bridge_rectifier.cir"), "--period", "0", "-q",
                 "-o", str(output)]) == 1


def test_fallback_periods_when_newton_is_capped():
    # the DCM boost needs three Newton steps from its operating point; with one allowed per
    # round, transient periods are run from the best state and Newton starts again (θ's
    # shooting: the exact map's failure falls back to it, test_exact_pss_that_cannot_settle_...)
    circuit = circuitnsds.read_netlist(pinned((CONVERTER_NETLISTS / "boost_dcm.cir").read_text()))
    reference = circuit.pss()
    capped = circuit.pss(max_iterations=1)
    assert capped.transient_periods >= 10
    assert capped.relative_residual <= 1e-9
    assert np.abs(capped.state - reference.state).max() <= 1e-8 * np.abs(reference.state).max()


def test_autonomous_switching_is_refused_naming_the_switch():
    # a relaxation oscillator: S1 (hysteresis 3..7 V) discharges C1, which R1 charges
    text = ("relaxation oscillator\nV1 in 0 DC 10\nR1 in c 1k\nC1 c 0 1u\nS1 c x c 0 sw\nR2 x 0 10\n"
            ".model sw SW(VT=5 VH=2 RON=1 ROFF=1e9)\n.tran 1u 10m\n.end\n")
    with pytest.raises(circuitnsds.CircuitError, match=r"S1 are controlled by the circuit.*autonomous"):
        circuitnsds.read_netlist(text).pss()


def test_pss_line_stabilisation_runs_warmup_periods():
    text = rc_square(0.1e-6).replace(".tran", ".pss 100k 35u 0 100\n.tran")
    result = circuitnsds.read_netlist(text).pss()
    assert result.transient_periods == 4  # TSTAB = 35 µs rounded up to whole 10 µs periods
    assert result.waveforms.time.size == 101
    assert result.iterations == 1


def test_a_fallback_that_cannot_fit_in_memory_is_refused_before_it_runs(monkeypatch):
    # the period maps fit, the ten transient periods of the first fallback round do not
    import circuitnsds.analyses.memory as memory
    from circuitnsds.engine.integrate import trajectory_bytes
    from circuitnsds.errors import CircuitError
    circuit = circuitnsds.read_netlist(pinned((CONVERTER_NETLISTS / "boost_dcm.cir").read_text()))
    reference = circuit.pss()
    per_period = trajectory_bytes(reference.mlcs, reference.waveforms.time.size)
    # 0.8 × available = 6 periods' worth: 4 for the maps fit, 10 + 4 for the fallback do not
    monkeypatch.setattr(memory, "available_memory", lambda: 6 * per_period / 0.8)
    with pytest.raises(CircuitError, match=r"a fallback of 10 transient periods would take"):
        circuit.pss(max_iterations=1)


def test_newton_cycling_between_mode_sequences_goes_to_the_fallback():
    # the voltage multiplier's Newton steps cycle (0.077, 1.4, 0.63, 0.077, ...): the cycle is
    # noticed when a sequence comes back without progress, 10 transient periods break it
    circuit = circuitnsds.read_netlist(NETLISTS / "cockcroft_walton.cir")
    result = circuit.pss()
    assert result.transient_periods == 10
    assert result.iterations < 10
    assert result.relative_residual <= 1e-9
    assert_device_laws(circuit, result.waveforms)


def test_voltage_mode_buck_with_a_circuit_controlled_pwm_settles():
    # the voltage-mode buck's S1 compares the error amplifier with the ramp: its instants are
    # located and the period map's Jacobian carries their sensitivity (saltation), so Newton
    # ends quadratically once the fallback's transient periods have brought it near
    text = (NETLISTS / "buck_voltage_mode.cir").read_text().replace(
        "Vref ref 0 PWL(0 0 1m 2.5)", "Vref ref 0 DC 2.5")
    circuit = circuitnsds.read_netlist(text)
    result = circuit.pss()
    assert result.relative_residual <= 1e-9
    last = result.history[-4:]
    assert last[-1] < 1e-10
    # quadratic at the end (a Jacobian without the saltation term would converge linearly
    # at best: each of these would be a fixed fraction of the one before)
    assert last[-1] < 100 * last[-2] ** 2 and last[-2] < 100 * last[-3] ** 2
    out = result.waveforms["v(out)"]
    # the loop's reference: 2.5 V·(1 + Rtop/Rbot); op-amp gain 1e4 leaves ~1e-4
    assert float(np.mean(out)) == pytest.approx(5.0, rel=1e-3)
    # the settled period's switchings: one opening, one closing, at located instants
    events = result.waveforms.events
    assert sorted({e.state for e in events}) == [False, True]
    assert any(e.time not in set(result.waveforms.time) for e in events)
    with pytest.raises(circuitnsds.SimulationError, match=r"(?s)S1 are controlled by the circuit.*"
                       r"sequence.*tol="):
        circuitnsds.read_netlist(text).pss(step=0.2e-6, max_iterations=1)


def test_bad_tolerance_iterations_or_warmup_are_errors_and_zero_iterations_is_obeyed(tmp_path, capsys):
    # before: max_iterations=-2 crashed (TypeError, exit status 2 from the command), tol=-1 or nan
    # ran every fallback round to fail with "Newton cycled" at residual 0, periods_warmup=-1 ran
    # as 0, and max_iterations=0 was read as "not given" (10 Newton steps)
    from circuitnsds.cli.main import main

    circuit = circuitnsds.read_netlist(NETLISTS / "half_wave_rectifier.cir")
    for keywords, message in [({"max_iterations": -2}, "max_iterations = -2 must be 0 or more"),
                              ({"tol": -1.0}, "tol = -1 must be positive"),
                              ({"tol": math.nan}, "tol = nan must be positive"),
                              ({"periods_warmup": -1}, "periods_warmup = -1 must be 0 or more")]:
        with pytest.raises(circuitnsds.CircuitError, match=message):
            circuit.pss(**keywords)
    # tol = 0 too, also for a circuit without states (its first period is periodic at residual 0)
    stateless = circuitnsds.read_netlist("no states\nV1 a 0 SIN(0 1 1k)\nD1 a b dd\nR1 b 0 1k\n"
                                         ".model dd D(Ron=1)\n.tran 10u 3m\n.end\n")
    assert stateless.pss().relative_residual == 0.0
    with pytest.raises(circuitnsds.CircuitError, match="tol = 0 must be positive"):
        stateless.pss(tol=0.0)
    # no Newton step allowed: the fallback's transient periods alone reach the steady state
    result = circuitnsds.read_netlist(NETLISTS / "bridge_rectifier.cir").pss(max_iterations=0)
    assert result.iterations == 0 and result.transient_periods >= 10
    assert result.relative_residual <= 1e-9
    status = main(["pss", str(NETLISTS / "half_wave_rectifier.cir"), "-q", "-o",
                   str(tmp_path / "p.csv"), "--max-iterations", "-2"])
    err = capsys.readouterr().err
    assert status == 1 and "half_wave_rectifier.cir: max_iterations = -2 must be 0 or more" in err


def test_the_exact_maps_newton_takes_max_iterations_and_tol():
    # the exact map took neither (30 steps, 1e-12 whatever was asked): max_iterations=0 from
    # the bridge's operating point, which is not periodic, is an error under method=exact and,
    # under the default, a note and the θ shooting's transient periods (as above)
    from circuitnsds.errors import SimulationError

    text = (NETLISTS / "bridge_rectifier.cir").read_text()
    with pytest.raises(SimulationError, match=r"did not converge in 0 step\(s\): residuals 3\d\d"):
        circuitnsds.read_netlist(pinned(text, "exact")).pss(max_iterations=0)
    with pytest.warns(RunNote, match=r"did not converge in 0 step\(s\).*the θ shooting's instead"):
        result = circuitnsds.read_netlist(text).pss(max_iterations=0)
    assert result.iterations == 0 and result.transient_periods >= 10
    # a tolerance tighter than the map's own 1e-12 is met, down to its round-off (64 ε: at
    # 1e-16 Newton stalled at 1.8e-16 for its 30 steps and auto fell back to θ's less accurate
    # orbit); a looser one keeps 1e-12
    for tol, bound in ((1e-14, 1e-14), (1e-16, 64 * np.finfo(float).eps), (1e-6, 1e-12)):
        settled = circuitnsds.read_netlist(text).pss(tol=tol)
        assert settled.exact is not None and settled.relative_residual <= bound
    # the steps allowed run out: an orbit within the tolerance asked for is taken (a .pss
    # line's SCITER with a loose STEADYCOEFF), not the θ shooting's
    loose = circuitnsds.read_netlist(text).pss(max_iterations=1, tol=5e-3)
    assert loose.exact is not None and loose.iterations == 1 and loose.relative_residual <= 5e-3


def test_a_period_or_warm_up_needing_too_many_steps_is_an_error_not_a_crash(tmp_path, capsys):
    # before: the time grid's ValueError escaped (exit status 2, "internal error"); the
    # transient turns the same condition into an error naming the file
    from circuitnsds.cli.main import main

    circuit = circuitnsds.read_netlist(NETLISTS / "half_wave_rectifier.cir")
    for keywords in ({"period": 1e300}, {"period": math.inf}, {"periods_warmup": 10**9}):
        with pytest.raises(circuitnsds.CircuitError, match=r"steps requested \(limit 5e\+07\)"):
            circuit.pss(**keywords)
    status = main(["pss", str(NETLISTS / "half_wave_rectifier.cir"), "-q", "-o",
                   str(tmp_path / "p.csv"), "--warmup", "1000000000"])
    err = capsys.readouterr().err
    assert status == 1 and "half_wave_rectifier.cir: 1e+12 steps requested (limit 5e+07)" in err


PEAK_DETECTOR = PEAK.replace(".tran 5u 2.5m", ".options method={method}")


def test_an_exact_period_map_that_stops_is_an_error_and_auto_takes_the_theta_shooting():
    # While D1 conducts, C1 sits across V1 (index 2: no state equations), which the exact
    # period map cannot cross (a transient hands it to θ). With method=exact that is an
    # error naming the instant and the cause (it was an internal error, a traceback's
    # class name); with method=auto the θ shooting takes the pss, noted, and gives what
    # method=theta gives.
    exact = circuitnsds.read_netlist(PEAK_DETECTOR.format(method="exact"))
    with pytest.raises(circuitnsds.SimulationError, match=r"exact period map stopped at t = 0 s: a mode "
                       r"without state equations") as raised:
        exact.pss()
    assert "method=theta" in raised.value.hint
    with pytest.warns(RunNote, match=r"method=auto: the periodic steady state on the exact "
                      r"period map failed .*θ shooting's instead"):
        auto = circuitnsds.read_netlist(PEAK_DETECTOR.format(method="auto")).pss()
    theta = circuitnsds.read_netlist(PEAK_DETECTOR.format(method="theta")).pss()
    assert np.array_equal(auto.waveforms["v(c)"], theta.waveforms["v(c)"])
    assert auto.means is None and auto.maps is not None  # (the θ shooting's result)


def test_auto_shoots_on_the_exact_period_map_where_the_circuit_qualifies():
    # The bundled boost under method=auto: the exact map's orbit (its closed-form means), the
    # same orbit as method=exact's, bit for bit.
    text = (NETLISTS / "boost_converter.cir").read_text()
    auto = circuitnsds.read_netlist(text.replace(".end", ".options method=auto\n.end")).pss()
    exact = circuitnsds.read_netlist(text.replace(".end", ".options method=exact\n.end")).pss()
    assert auto.means is not None and auto.exact is not None
    assert np.array_equal(auto.means, exact.means)


def test_the_exact_period_map_refuses_an_undamped_tank_near_resonance_and_warns_away_from_it():
    # (an undamped inductor's state on the exact map: test_undamped_state_is_diagnosed)
    # an undamped LC driven next to its resonance (f0 = 5032.9212 Hz): the exact map has a
    # periodic solution, 1/|1 − μ| ≈ 6.6e5 times the drive along the tank, which no transient
    # reaches (|μ| = 1): refused, as the θ shooting refuses it (test_exit_zero.py); driven at
    # 1 kHz, far from it, the forced response, warned as not attracting
    lc = "t\nV1 in 0 SIN(0 1 {f})\nL1 in a 1m\nC1 a 0 1u\n.options method=exact\n.end\n"
    with pytest.raises(circuitnsds.SimulationError, match=r"no periodic steady state to show"):
        circuitnsds.read_netlist(lc.format(f="5032.92")).pss()
    with pytest.warns(circuitnsds.CircuitWarning, match=r"not attracting, the state along .*v\(a\).* "
                      r"undamped \(largest Floquet multiplier \|λ\| = 1\)"):
        circuitnsds.read_netlist(lc.format(f="1000")).pss()
