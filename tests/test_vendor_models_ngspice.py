"""Issue 18: circuits built from real vendor diode models (1N4007, 1N5819 Schottky, 1N4733
Zener, as their makers publish them; sources in each netlist) agree with ngspice running the
same models at their own N: mean output within 2 %, diode-current peak within 5 %.

circuitnsds reads each Shockley model as the PWL diode fitted to its curve
(circuitnsds.circuit.elements.diode_fit); before, they were ideal 0 V diodes and a flat Zener.
"""

import warnings

import numpy as np
import pytest

from circuitnsds.compare import compare
from tests.conftest import NETLISTS

pytestmark = pytest.mark.ngspice
VENDOR = NETLISTS / "vendor"


def _mean(time, values, window):
    inside = (time >= window[0]) & (time <= window[1])
    t, v = time[inside], values[inside]
    return float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(t)) / (t[-1] - t[0]))


def _peak(time, values, window):
    inside = (time >= window[0]) & (time <= window[1])
    return float(np.abs(values[inside]).max())


@pytest.mark.parametrize(("name", "output", "window"), [
    ("halfwave_1n4007", ("v(out)",), (0.1, 0.2)),
    ("bridge_1n5819", ("v(out)", "v(neg)"), (0.1, 0.2)),
    ("zener_1n4733", ("v(out)",), (0.0, 0.04)),
])
def test_vendor_diode_circuit_agrees_with_ngspice(name, output, window):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = compare(VENDOR / f"{name}.cir", signals=[*output, "i(d1)"])
    run = comparison.run
    assert run.ok, run.ngspice.message
    ours, theirs = comparison.circuitnsds, run.ngspice.waveforms

    def out(waves):
        return waves[output[0]] - (waves[output[1]] if len(output) > 1 else 0.0)

    mean_ours, mean_theirs = _mean(ours.time, out(ours), window), _mean(theirs.time, out(theirs), window)
    assert mean_ours == pytest.approx(mean_theirs, rel=0.02)
    peak_ours = _peak(ours.time, ours["i(d1)"], window)
    peak_theirs = _peak(theirs.time, theirs["i(d1)"], window)
    assert peak_ours == pytest.approx(peak_theirs, rel=0.05)


def test_zener_line_regulation_follows_ngspice():
    # d v(out) / d v(in) above the knee: ngspice's Shockley breakdown (NBV Vt / I + RS)
    # against the fitted Rrev; before, circuitnsds's flat Zener gave exactly 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = compare(VENDOR / "zener_1n4733.cir", signals=["v(in)", "v(out)"])
    slopes = []
    for waves in (comparison.circuitnsds, comparison.run.ngspice.waveforms):
        t = waves.time
        at = [np.searchsorted(t, instant) for instant in (12e-3, 19e-3)]
        slopes.append((waves["v(out)"][at[1]] - waves["v(out)"][at[0]])
                      / (waves["v(in)"][at[1]] - waves["v(in)"][at[0]]))
    assert slopes[0] > 0.005
    # issue 34: within 25 % of ngspice's (measured 0.0124 against 0.0133); a single line
    # fitted over IBV/10..IBV (Rrev 2.0 ohm against the curve's 1.45 ohm at 35-50 mA) gave 0.020
    assert 0.75 < slopes[0] / slopes[1] < 1.25


def test_zener_shunt_regulator_with_a_spice_breakdown_model_agrees_with_ngspice():
    """Issue 34: D(IS=1e-14 N=0.05 BV=5.1 IBV=1m) carrying up to ~93 mA. A single breakdown
    line fitted over 0.1..1 mA made v(out) peak at 8.8 V against ngspice's 5.1 V (nRMS 20 %);
    the branches fitted where the circuit works agree within 1 % at default settings."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = compare(VENDOR / "zener_shunt_spice_model.cir", signals=["v(out)", "i(dz1)"])
    assert comparison.run.ok, comparison.run.ngspice.message
    metrics = comparison.metrics
    assert metrics["v(out)"].nrms < 0.01 and metrics["i(dz1)"].nrms < 0.01
    ours = comparison.circuitnsds["v(out)"]
    assert ours.max() == pytest.approx(comparison.run.ngspice.waveforms["v(out)"].max(), rel=0.01)


def test_high_injection_and_recombination_follow_ngspice():
    """IKF and ISR/NR were dropped without a word: the BAV21 (IKF = 19 mA) at 1 A and a model
    with recombination at 1 mA were 17.8 % and 30.6 % (nRMS) off ngspice's diode voltages;
    ngspice's full forward equation, fitted where the circuit works, brings both within 2 %
    (measured 0.8 % and 1.3 %)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = compare(VENDOR / "diode_high_injection.cir", signals=["v(a)", "v(b)"])
    assert comparison.run.ok, comparison.run.ngspice.message
    assert comparison.metrics["v(a)"].nrms < 0.02 and comparison.metrics["v(b)"].nrms < 0.02


def test_schottky_multiplier_with_a_bar42_model_agrees_with_ngspice():
    """Issue 34's held-out check: a four-stage multiplier of BAR42 Schottky diodes (IS = 11 nA,
    RS = 0.99 ohm) whose drops, 0.2..0.35 V at 1..20 mA, add up eight times: v(d4) within 5 %
    (nRMS) of ngspice at default settings (measured 0.14 %; the issue's own netlist was 15.8 %
    off before the multi-branch fits)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = compare(VENDOR / "multiplier_bar42.cir", signals=["v(d4)", "v(d2)"])
    assert comparison.run.ok, comparison.run.ngspice.message
    assert comparison.metrics["v(d4)"].nrms < 0.05 and comparison.metrics["v(d2)"].nrms < 0.05
    ours, theirs = comparison.circuitnsds, comparison.run.ngspice.waveforms
    window = (8e-3, 10e-3)
    assert _mean(ours.time, ours["v(d4)"], window) == pytest.approx(
        _mean(theirs.time, theirs["v(d4)"], window), rel=0.02)


def test_three_phase_1n4007_rectifier_currents_agree_with_ngspice():
    """Issue 34's held-out check: a six-diode bridge of OnSemi 1N4007 (N = 1.81) from three
    20 V phases: every diode current within 2 % (nRMS and peak) of ngspice's at default
    settings (measured 0.14 % nRMS; the issue's own netlist was 7-10 % off before the
    multi-branch fits)."""
    diodes = [f"i(d{k})" for k in range(1, 7)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = compare(VENDOR / "three_phase_1n4007.cir", signals=diodes)
    assert comparison.run.ok, comparison.run.ngspice.message
    ours, theirs = comparison.circuitnsds, comparison.run.ngspice.waveforms
    for name in diodes:
        assert comparison.metrics[name].nrms < 0.02, name
        assert _peak(ours.time, ours[name], (0.05, 0.1)) == pytest.approx(
            _peak(theirs.time, theirs[name], (0.05, 0.1)), rel=0.02), name
