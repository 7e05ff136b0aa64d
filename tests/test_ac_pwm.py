"""Control-to-output of a PWM converter (issue 16) and the exact periodic steady state of a
circuit-controlled switch (issue 14): a comparator switch (ramp PULSE against a DC control
source) switches at located instants, and the period map's Jacobian carries each instant's
sensitivity (engine/step_maps.split_map). Checked against finite differences of the period
map, the ramp geometry, the averaged model and sine-injection transients."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import circuitnsds
from tests.sine_injection import injected_response

PERIOD, STEP = 10e-6, 0.2e-6
RISE, WIDTH, FALL = 9.9e-6, 50e-9, 50e-9  # the ramp: 0 -> 1 V over RISE, back over FALL
VIN, VC, L, C, R = 12.0, 0.4, 47e-6, 220e-6, 0.5
LOOP_GAIN = 0.2  # the closed loop's error amplifier: v(ctrl) = 0.2·(3 V − v(out))
GAIN = (RISE + FALL) / PERIOD  # duty per volt of control: the switch is on while v(ctrl) > v(ramp)


def buck(control: str = f"DC {VC}", loop: bool = False, method: str = "theta") -> str:
    """The PWM buck, run by ``method`` (the θ shooting's located duty cycle and split steps are
    what this file tests; the exact map's ac of the same buck: test_exact_ac.py)."""
    source = (f"Vref ref 0 DC 3\nE1 ctrl 0 ref out {LOOP_GAIN}" if loop else f"Vc ctrl 0 {control}")
    return f"""PWM buck: S1 closed while v(ctrl) > v(ramp) (as netlists/buck_voltage_mode.cir)
Vin in 0 DC {VIN}
{source}
Vramp ramp 0 PULSE(0 1 0 {RISE} {FALL} {WIDTH} {PERIOD})
S1 in sw ctrl ramp swmod
D1 0 sw dfree
L1 sw out {L}
C1 out 0 {C}
Rload out 0 {R}
.model swmod SW(VT=0 VH=0 RON=1m ROFF=1e9)
.model dfree D(Ron=1m)
.tran {STEP} 1m{" uic" if loop else ""}
.options method={method}
.end
"""


def read(text: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return circuitnsds.read_netlist(text)


@pytest.fixture(scope="module")
def settled():
    circuit = read(buck())
    return circuit, circuit.pss(step=STEP)


def test_pwm_buck_pss_converges_with_the_located_duty_cycle(settled):
    circuit, result = settled
    assert result.iterations <= 3
    assert result.relative_residual < 1e-10
    events = result.maps.trajectory.events
    opening = [e.time for e in events if not e.state]
    closing = [e.time for e in events if e.state]
    assert len(opening) == len(closing) == 1
    # the ramp crosses VC rising at VC·RISE and falling at RISE + WIDTH + (1 - VC)·FALL
    assert opening[0] == pytest.approx(VC * RISE, abs=1e-4 * PERIOD)
    assert closing[0] == pytest.approx(RISE + WIDTH + (1 - VC) * FALL, abs=1e-4 * PERIOD)
    on = opening[0] + PERIOD - closing[0]
    assert on / PERIOD == pytest.approx(VC * GAIN, abs=1e-4)


def test_split_step_jacobian_matches_finite_differences_of_the_period_map():
    # proportional loop: the comparator's control moves with v(out), so the instants depend
    # on the state; Φ built analytically (saltation included) against central differences
    # of the period map P(x0)
    circuit = read(buck(loop=True))
    result = circuit.pss(step=STEP)
    assert result.iterations <= 4 and result.relative_residual < 1e-10
    vout = VIN * GAIN * LOOP_GAIN * 3 / (1 + VIN * GAIN * LOOP_GAIN)  # averaged, lossless
    out = result.maps.trajectory.y[1:, result.mlcs.unknowns.index("v(out)")]
    assert np.mean(out) == pytest.approx(vout, rel=2e-3)
    maps = result.maps
    assert maps.splits, "the comparator's switchings are located inside steps"
    assert all(np.abs(sensitivity).max() > 0 for split in maps.splits.values()
               for _, sensitivity in split.instants)
    phi, _ = maps.composition()
    from circuitnsds.engine.step_maps import StepMapper

    mapper = StepMapper(result.mlcs, maps.trajectory.time)
    start = maps.trajectory
    columns = []
    for j, scale in enumerate((1e-4, 1e-4)):
        ends = []
        for sign in (1, -1):
            y = start.y[0].copy()
            y[maps.state[j]] += sign * scale
            run = mapper.run(y, None, start.active[0], start.switches[0])
            ends.append(run.trajectory.y[-1, maps.state])
        columns.append((ends[0] - ends[1]) / (2 * scale))
    numeric = np.array(columns).T
    assert np.abs(numeric - phi).max() < 1e-5 * np.abs(phi).max()
    # the split steps matter: the product of the other steps alone is far from Φ
    whole = np.eye(maps.state.size)
    for k in range(maps.steps):
        split = maps.splits.get(k)
        if split is None:
            whole = maps.step(k)[0] @ whole
    assert np.abs(numeric - phi).max() < 1e-3 * np.abs(numeric - whole).max()


def test_pwm_buck_control_to_output_matches_the_averaged_model(settled):
    circuit, result = settled
    frequencies = np.array([100.0, 1e3, 3e3, 1e4])  # up to fs/10
    got = circuit.ac("vc", "v(out)", frequencies, pss=result).transfer["v(out)"]
    s = 2j * np.pi * frequencies
    expected = VIN * GAIN / (1 + s * L / R + s * s * L * C)
    ratio = got / expected
    assert np.abs(20 * np.log10(np.abs(ratio))).max() < 0.5
    assert np.abs(np.degrees(np.angle(ratio))).max() < 3


@pytest.mark.parametrize("frequency", [2e3, 20e3, 46e3])
def test_pwm_buck_control_to_output_matches_sine_injection(settled, frequency):
    # brute force: Vc + 4 mV·sin(ωt), a transient from the periodic steady state for 1.2 ms
    # (the LC's start-up decays with time constant 2L/R = 0.19 ms), then the DFT of v(out)
    # over 0.5 ms (whole periods of the sine and of the switching)
    circuit, result = settled
    ours = circuit.ac("vc", "v(out)", [frequency], pss=result).transfer["v(out)"][0]
    amplitude = 4e-3
    injected = read(buck(f"SIN({VC} {amplitude} {frequency})"))
    theirs = injected_response(injected, result.maps.trajectory, STEP, frequency, amplitude,
                               settle=1.2e-3, window=0.5e-3)
    assert abs(20 * np.log10(abs(ours / theirs))) < 0.2
    assert abs(np.degrees(np.angle(ours / theirs))) < 2


def test_pwm_boost_control_to_output_shows_the_right_half_plane_zero():
    # CCM boost, D = 0.4: averaged control-to-output (ideal switch and diode)
    # GAIN·Vin/(1−D)² · (1 − s/ωz)/(1 + sL/(R(1−D)²) + s²LC/(1−D)²), ωz = R(1−D)²/L (2.86 kHz)
    duty, vin, inductance, capacitance, load = 0.4, 5.0, 100e-6, 100e-6, 5.0
    circuit = read(f"""PWM boost: S1 closed while v(ctrl) > v(ramp)
Vin in 0 DC {vin}
Vc ctrl 0 DC {duty / GAIN}
Vramp ramp 0 PULSE(0 1 0 {RISE} {FALL} {WIDTH} {PERIOD})
L1 in sw {inductance}
S1 sw 0 ctrl ramp swmod
D1 sw out dfree
C1 out 0 {capacitance}
Rload out 0 {load}
.model swmod SW(VT=0 VH=0 RON=1m ROFF=1e9)
.model dfree D(Ron=1m)
.tran {STEP} 1m
.end
""")
    result = circuit.pss(step=STEP)
    assert result.iterations <= 3 and result.relative_residual < 1e-10
    frequencies = np.array([100.0, 1e3, 2e3, 3e3, 5e3, 1e4])  # up to fs/10
    ac = circuit.ac("vc", "v(out)", frequencies, pss=result)
    got = ac.transfer["v(out)"]
    s = 2j * np.pi * frequencies
    off = 1 - duty
    zero = load * off**2 / inductance  # [rad/s]
    poles = 1 + s * inductance / (load * off**2) + s * s * inductance * capacitance / off**2
    expected = GAIN * vin / off**2 * (1 - s / zero) / poles
    ratio = got / expected
    assert np.abs(20 * np.log10(np.abs(ratio))).max() < 0.5
    assert np.abs(np.degrees(np.angle(ratio))).max() < 3
    assert ac.phase_deg("v(out)")[-1] < -225  # falls past −180° (poles) by the zero's −atan(f/fz)
    # the zero from the response itself: the numerator G·poles has phase −atan(f/fz)
    numerator = np.angle(got * poles)
    estimates = frequencies[1:5] / np.tan(-numerator[1:5])
    assert np.abs(estimates / (zero / (2 * np.pi)) - 1).max() < 0.05


def test_cli_ac_takes_the_comparator_control_as_input(tmp_path):
    from circuitnsds.cli.main import main

    netlist = tmp_path / "pwm.cir"
    netlist.write_text(buck().replace(".end", ".ac dec 2 100 1k\n.end"))
    table = tmp_path / "bode.csv"
    assert main(["ac", str(netlist), "--input", "Vc", "--output", "v(out)", "-o", str(table),
                 "-q"]) == 0
    lines = table.read_text().splitlines()
    assert lines[0] == "frequency,mag(v(out)),phase(v(out))"
    frequency, magnitude, phase = map(float, lines[1].split(","))
    s = 2j * np.pi * frequency
    expected = VIN * GAIN / (1 + s * L / R + s * s * L * C)
    assert magnitude == pytest.approx(20 * np.log10(abs(expected)), abs=0.05)
    assert phase == pytest.approx(np.degrees(np.angle(expected)), abs=0.5)
