"""Measurements against analytic signals, and the text form of ``run --measure``."""

import numpy as np
import pytest

import circuitnsds
from circuitnsds.cli.main import main
from circuitnsds.output import measure
from circuitnsds.output.measure import MeasurementError, evaluate, parse_measurement
from circuitnsds.output.waveforms import Waveforms
from tests.conftest import NETLISTS, circuit_from

F = 50.0


@pytest.fixture
def grid() -> np.ndarray:
    """A deliberately non-uniform grid over 5 periods of 50 Hz."""
    rng = np.random.default_rng(7)
    return np.unique(np.concatenate([np.linspace(0, 0.1, 8001), rng.uniform(0, 0.1, 4000)]))


def test_mean_and_rms_of_a_sine_on_a_non_uniform_grid(grid):
    y = 2.0 + 3.0 * np.sin(2 * np.pi * F * grid)
    assert measure.mean(grid, y, period=1 / F) == pytest.approx(2.0, abs=1e-6)
    assert measure.rms(grid, y - 2.0) == pytest.approx(3 / np.sqrt(2), rel=1e-6)
    assert measure.rms(grid, y, period=1 / F) == pytest.approx(np.sqrt(4 + 4.5), rel=1e-6)


def test_window_ends_are_interpolated():
    t = np.array([0.0, 1.0, 2.0])
    y = np.array([0.0, 10.0, 0.0])  # a triangle
    assert measure.mean(t, y, 0.5, 1.5) == pytest.approx(7.5)  # from 5 up to 10 and back to 5
    assert measure.maximum(t, y, 1.5, 2.0) == pytest.approx(5.0)
    assert measure.minimum(t, y, 0.25, 1.75) == pytest.approx(2.5)
    assert measure.peak_to_peak(t, y, 0.25, 1.75) == pytest.approx(7.5)
    assert measure.ripple is measure.peak_to_peak


def test_period_keeps_the_whole_periods_ending_at_t1(grid):
    y = np.sin(2 * np.pi * F * grid) + (grid > 0.05)  # a step at 50 ms
    # 0.035 .. 0.1 holds 3 whole periods: 0.04 .. 0.1, the step at 0.05 is 5/6 of it
    assert measure.mean(grid, y, 0.035, 0.1, period=1 / F) == pytest.approx(5 / 6, abs=1e-3)
    with pytest.raises(MeasurementError, match="shorter than one period"):
        measure.mean(grid, y, 0.09, 0.1, period=1 / F)


def test_thd_of_pure_sine_square_and_known_harmonics(grid):
    sine = 5 * np.sin(2 * np.pi * F * grid + 0.3)
    assert measure.thd(grid, sine, F) < 1e-5
    uniform = np.linspace(0, 0.1, 200001)
    square = np.where((uniform * F) % 1 < 0.5, 1.0, -1.0)
    assert measure.thd(uniform, square, F) == pytest.approx(np.sqrt(np.pi ** 2 / 8 - 1), rel=3e-3)
    # harmonics 3, 5, 7, 9 only (as ngspice's .four counts to 9)
    expected = np.sqrt(sum(1 / k ** 2 for k in (3, 5, 7, 9)))
    assert measure.thd(uniform, square, F, count=9) == pytest.approx(expected, rel=1e-3)
    mixed = np.sin(2 * np.pi * F * grid) + 0.1 * np.sin(2 * np.pi * 3 * F * grid) \
        + 0.05 * np.cos(2 * np.pi * 5 * F * grid)
    assert measure.thd(grid, mixed, F) == pytest.approx(np.hypot(0.1, 0.05), rel=1e-3)
    a = measure.harmonics(grid, 1.5 + mixed, F, count=5)
    np.testing.assert_allclose(a, [1.5, 1, 0, 0.1, 0, 0.05], atol=2e-4)


def test_thd_without_the_fundamental_is_an_error(grid):
    with pytest.raises(MeasurementError, match="no component at 50 Hz"):
        measure.thd(grid, np.sin(2 * np.pi * 2 * F * grid), F)


def test_a_count_without_harmonics_is_an_error_not_a_crash(grid, tmp_path, capsys):
    # count=0 or a negative count indexed an empty spectrum (IndexError, exit status 2 from
    # the command); count=1 gave a THD of 0 with no harmonic counted at all
    sine = np.sin(2 * np.pi * F * grid)
    for count in (-1, 0, 1):
        with pytest.raises(MeasurementError, match=f"count={count} leaves no harmonic"):
            measure.thd(grid, sine, F, count=count)
    with pytest.raises(MeasurementError, match="count=0 must be at least 1"):
        measure.harmonics(grid, sine, F, count=0)
    with pytest.raises(MeasurementError, match=r"count=2\.5 is not a whole number"):
        parse_measurement("thd(v(a), 50, count=2.5)")
    status = main(["run", str(NETLISTS / "half_wave_rectifier.cir"), "-q", "-o",
                   str(tmp_path / "o.csv"), "--measure", "thd(v(out), 50, count=0)"])
    err = capsys.readouterr().err
    assert status == 1, err
    assert "error: --measure thd(v(out), 50, count=0): count=0 leaves no harmonic" in err


def test_bad_windows_are_errors(grid):
    y = np.sin(grid)
    with pytest.raises(MeasurementError, match="is empty"):
        measure.mean(grid, y, 0.05, 0.05)
    with pytest.raises(MeasurementError, match="not inside the simulated time"):
        measure.mean(grid, y, 0.05, 0.2)


def test_power_of_resistor_and_source_in_a_divider():
    """10 V sine on 1 kΩ + 3 kΩ: P(R) = V_R,rms² / R; the source delivers the sum (negative)."""
    circuit = circuit_from("V1 in 0 SIN(0 10 50)\nR1 in mid 1k\nR2 mid 0 3k\n.tran 100u 40m")
    waves = circuit.transient()
    p1 = measure.power(waves, circuit.element("r1"), period=1 / F)
    p2 = measure.power(waves, circuit.element("r2"), period=1 / F)
    assert p1 == pytest.approx((2.5 ** 2 / 2) / 1e3, rel=1e-3)
    assert p2 == pytest.approx((7.5 ** 2 / 2) / 3e3, rel=1e-3)
    assert measure.power(waves, circuit.element("v1"), period=1 / F) == pytest.approx(-(p1 + p2),
                                                                                        rel=1e-9)


def test_half_wave_rectifier_measurements():
    """Ideal diode, 10 V peak, 1 kΩ: mean = 10/π V, rms = 5 V, P(R) = 25/1k W, P(D) = 0."""
    circuit = circuitnsds.read_netlist(NETLISTS / "half_wave_rectifier.cir")
    waves = circuit.transient(step=10e-6, stop=40e-3)
    assert measure.mean(waves, "v(out)", period=1 / F) == pytest.approx(10 / np.pi, rel=1e-4)
    assert measure.rms(waves, "v(out)", period=1 / F) == pytest.approx(5.0, rel=1e-4)
    assert measure.power(waves, circuit.element("r1"), period=1 / F) == pytest.approx(0.025, rel=1e-4)
    assert abs(measure.power(waves, circuit.element("d1"), period=1 / F)) < 1e-9
    # half-wave rectified sine: harmonics 2, 4, 6, ... with a_k = 2/(π(k²-1)), a_1 = 1/2 of the peak
    a = measure.harmonics(waves, "v(out)", F, count=4)
    np.testing.assert_allclose(a, 10 * np.array([1 / np.pi, 0.5, 2 / (3 * np.pi), 0, 2 / (15 * np.pi)]),
                               atol=2e-3)


def test_text_form_and_its_errors():
    waves = Waveforms(np.linspace(0, 1, 101), {"v(a)": np.linspace(0, 1, 101) ** 2})
    assert evaluate("mean(v(a))", waves).value == pytest.approx(1 / 3, rel=1e-3)
    ripple = evaluate("ripple( V(A) , 500m, 1)", waves)
    assert ripple.value == pytest.approx(0.75) and ripple.unit == "V"
    assert ripple.formatted() == "750 mV"
    assert parse_measurement("thd(v(a), 1k, 0, 1, count=9)").keywords == {"count": 9}
    # differential voltages, as in SPICE: v(a,b) = v(a) - v(b); v(a,0) = v(a)
    waves.signals["v(b)"] = np.full(101, 0.25)
    assert evaluate("max(v(a, b))", waves).value == pytest.approx(0.75)
    assert evaluate("min(V(A,0))", waves).value == pytest.approx(0.0)
    for text, message in [("foo(v(a))", "cannot read the measurement"),
                          ("mean(v(a), 0.5)", "wrong arguments for mean()"),
                          ("mean(v(a), x, 1)", "'x' is not a number"),
                          ("ripple(v(a), period=1)", "ripple() takes no period="),
                          ("thd(v(a))", "wrong arguments for thd()"),
                          ("mean(v(c))", "no signal 'v(c)'"),
                          ("mean(v(a, c))", "no voltage of node 'c'")]:
        with pytest.raises(MeasurementError, match=message.replace("(", r"\(").replace(")", r"\)")):
            evaluate(text, waves)


def test_cli_prints_a_table(tmp_path, capsys):
    status = main(["run", str(NETLISTS / "half_wave_rectifier.cir"), "-o", str(tmp_path / "o.csv"),
                   "--step", "10u", "-q", "--measure", "mean(v(out), 20m, 40m)",
                   "--measure", "power(r1, period=20m)", "--measure", "thd(v(in), 50)",
                   "--measure", "max(i(d1))"])
    out = capsys.readouterr().out.splitlines()
    assert status == 0
    assert out[0].split() == ["measurement", "value"]
    rows = {line[:24].strip(): line[24:].strip() for line in out[1:]}
    assert rows["mean(v(out), 20m, 40m)"] == "3.183 V"
    assert rows["power(r1, period=20m)"] == "25 mW"
    assert rows["thd(v(in), 50)"].endswith(" %") and float(rows["thd(v(in), 50)"][:-2]) < 1e-3
    assert rows["max(i(d1))"] == "10 mA"


def test_cli_rejects_a_bad_measurement_before_running(tmp_path, capsys):
    status = main(["run", str(NETLISTS / "half_wave_rectifier.cir"), "-o", str(tmp_path / "o.csv"),
                   "--measure", "power(r1, 1m)"])
    err = capsys.readouterr().err
    assert status == 1
    assert "wrong arguments for power()" in err and "Traceback" not in err
    assert not (tmp_path / "o.csv").exists()
    status = main(["run", str(NETLISTS / "half_wave_rectifier.cir"), "-o", str(tmp_path / "o.csv"),
                   "-q", "--measure", "power(rx)"])
    assert status == 1 and "no element 'rx'" in capsys.readouterr().err
