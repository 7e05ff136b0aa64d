"""Small-signal AC around the exact periodic orbit (issue 31: ``pss`` and ``ac`` on the exact
maps, saltation at every located event, diodes included): closed forms on each segment, the
event instants moving with the perturbation (circuitnsds/engine/exact/small_signal.py).
Checked against the continuous transfer function of a circuit that does not switch, the
averaged model of a PWM buck, and sine injections into exact transients of a DCM boost."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import circuitnsds
from circuitnsds.engine.exact.run import run_exact
from circuitnsds.engine.exact.small_signal import phi1, phi2
from tests.test_ac_pwm import GAIN, VIN, C, L, R, buck

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks" / "netlists"


def _read(text: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return circuitnsds.read_netlist(text)


def _injected_response(injected, settled, frequency: float, amplitude: float, *, settle: float,
                       window: float, step: float = 0.02e-6) -> complex:
    """v(out)'s complex amplitude per unit of the ``a·sin(ωt)`` injected into ``injected``, from
    an exact transient started on the orbit of ``settled`` (its pss on the exact map): its
    fundamental over ``window`` [s] after ``settle`` [s] (the trapezoid rule on rows ``step``
    apart)."""
    mlcs = injected.mlcs()
    times = np.arange(round((settle + window) / step) + 1) * step
    first = settled.exact.segments[0]
    run = run_exact(mlcs, times, first.z(0.0)[:mlcs.n].real, first.mode.active, first.closed)
    out = run.y[:, mlcs.unknowns.index("v(out)")]
    inside = times >= settle - 1e-12
    coefficient = np.trapezoid(out[inside] * np.exp(-2j * np.pi * frequency * times[inside]),
                               times[inside]) / window
    return 2 * coefficient / (-1j * amplitude)  # a·sin(ωt) = Re(−j a e^{jωt})


def test_phi_functions_are_continuous_through_their_series():
    # φ₁(w) = (e^w − 1)/w and φ₂(w) = (e^w − 1 − w)/w² from their series below |w| = 0.5 and
    # their closed forms above: both sides of the switch-over agree, and the limits at 0 hold
    for w in (0.5 * np.exp(1j * np.linspace(0, 2 * np.pi, 13)),):
        inside, outside = w * (1 - 1e-12), w * (1 + 1e-12)
        assert np.allclose(phi1(inside), phi1(outside), rtol=1e-11, atol=0)
        assert np.allclose(phi2(inside), phi2(outside), rtol=1e-11, atol=0)
    assert phi1(np.array([0j]))[0] == 1.0 and phi2(np.array([0j]))[0] == 0.5
    w = np.array([-40.0 + 3j, 2.0 - 1j, -1e12 + 0j])
    assert np.allclose(phi1(w), np.expm1(w) / w, rtol=1e-14)
    assert np.allclose(phi2(w), (np.exp(w) - 1 - w) / w**2, rtol=1e-12)


def test_a_circuit_that_does_not_switch_answers_with_its_continuous_transfer_function():
    # an RC low-pass beside a clock that only sets the period: around any periodic orbit the
    # response is H(jω) = 1/(1 + jωRC) itself, not implicit Euler's H(s_d) as the θ-based ac has
    text = """RC beside a clock
Vclk clk 0 PULSE(0 1 0 1u 1u 4u 10u)
Rclk clk 0 1k
Vin in 0 DC 1
R1 in out 1k
C1 out 0 1u
.tran 0.1u 1m
.options method=exact
.end
"""
    circuit = _read(text)
    frequencies = np.array([10.0, 159.15, 1e3, 3.3e4, 1e5])  # 1e5 Hz: the period's own
    result = circuit.ac("vin", "v(out)", frequencies, pss=circuit.pss())
    expected = 1 / (1 + 2j * np.pi * frequencies * 1e3 * 1e-6)
    assert np.max(np.abs(result.transfer["v(out)"] / expected - 1)) < 1e-9


def test_the_pwm_bucks_control_to_output_has_no_integration_lag():
    # tests/test_ac_pwm.py's open-loop buck: against the averaged model GAIN·Vin/(1 + sL/R +
    # s²LC) the θ-based ac is off by implicit Euler's phase lag ≈ ωh/2 (+1.8° at 46 kHz with
    # h = 0.2 µs); on the exact orbit what is left is the 1 mΩ drops at low frequency
    circuit = _read(buck().replace(".end", ".options method=exact\n.end"))
    frequencies = np.array([2e3, 4e3, 1e4, 2e4, 4.6e4])
    result = circuit.ac("vc", "v(out)", frequencies, pss=circuit.pss())
    s = 2j * np.pi * frequencies
    averaged = GAIN * VIN / (1 + s * L / R + s * s * L * C)
    ratio = result.transfer["v(out)"] / averaged
    assert np.max(np.abs(20 * np.log10(np.abs(ratio)))) < 0.015
    assert np.max(np.abs(np.degrees(np.angle(ratio)))) < 0.15
    assert np.max(np.abs(np.degrees(np.angle(ratio[2:])))) < 0.03  # (θ: 0.43° to 1.8°)


def _ac_over_injection(base: str, source: str, line: str, sine: str, frequency: float,
                       amplitude: float, settle: float) -> complex:
    """The exact orbit's ac from ``source`` to ``v(out)`` over the same ratio measured by
    ``amplitude`` of sine on it (``line`` of ``base`` replaced by ``sine``, formatted with the
    amplitude and frequency) in an exact transient from the orbit, over ``settle`` [s] after
    ``settle`` of start-up."""
    circuit = _read(base.replace(".end", ".options method=exact\n.end"))
    settled = circuit.pss()
    response = circuit.ac(source, "v(out)", [frequency], pss=settled).transfer["v(out)"][0]
    injected = _read(base.replace(line, sine.format(amplitude=amplitude, frequency=frequency)))
    injection = _injected_response(injected, settled, frequency, amplitude, settle=settle, window=settle)
    return response / injection


@pytest.mark.parametrize("frequency", [1e3])
def test_a_dcm_boosts_line_to_output_is_the_sine_injections(frequency):
    # DCM: the diode turns off where the inductor current reaches 0, an instant that moves
    # with the perturbation (the θ-based ac moves it by whole steps: 0.1 dB and 1.6° off here).
    # Reference: 10 mV of sine on Vin in an exact transient from the orbit, its fundamental
    # over whole periods after the start-up (the output pole's RC/2 = 0.25 ms: e^-12 left)
    ratio = _ac_over_injection((BENCHMARKS / "boost_dcm.cir").read_text(), "vin", "Vin in 0 DC 12",
                               "Vin in 0 SIN(12 {amplitude} {frequency})", frequency, 0.01, 3e-3)
    assert abs(20 * np.log10(abs(ratio))) < 2e-3
    assert abs(np.degrees(np.angle(ratio))) < 0.02


@pytest.mark.parametrize("frequency", [3e3])
def test_a_closed_loops_reference_to_output_is_the_sine_injections(frequency):
    # tests/test_ac_pwm.py's voltage-mode loop: the control 0.2·(3 V − v(out)) meets the ramp
    # at an instant that moves with the state (the saltation) and with the reference (the
    # input's own push on the event function, the only path from the reference: without it
    # the response is 0; without the saltation it is 0.066 dB off)
    ratio = _ac_over_injection(buck(loop=True), "vref", "Vref ref 0 DC 3",
                               "Vref ref 0 SIN(3 {amplitude} {frequency})", frequency, 0.005, 2e-3)
    assert abs(20 * np.log10(abs(ratio))) < 5e-3
    assert abs(np.degrees(np.angle(ratio))) < 0.05


def test_ac_around_an_exact_orbit_warns_of_a_diode_at_its_threshold():
    # tests/test_ac.py's DEGENERATE circuit (no capacitor or inductor: the exact pss of a
    # circuit without state was a ValueError traceback): D0 blocks at exactly 0 V for half
    # the period, so the response to a current into n1 is one-sided there. The exact orbit
    # has no step maps to tell whether the perturbation moves it, so it is warned about
    from tests.test_ac import DEGENERATE

    circuit = _read(DEGENERATE.replace(".end", ".options method=exact\n.end"))
    settled = circuit.pss(step=2e-6)
    assert settled.exact is not None
    with pytest.warns(circuitnsds.CircuitWarning, match=r"d0 .*neither current nor voltage"):
        circuit.ac("iinj", "v(n1)", [0.75 / settled.period], pss=settled)
