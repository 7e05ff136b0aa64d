"""``.meas tran`` and ``.four`` on analytic waveforms (the ngspice comparison is in
test_meas_ngspice.py)."""

import math
import subprocess
import sys

import numpy as np
import pytest

from circuitnsds.errors import NetlistError
from circuitnsds.frontend.cards.meas import parse_meas
from circuitnsds.output.meas import fourier_coefficients, run_measurement
from circuitnsds.output.waveforms import Waveforms
from tests.conftest import circuit_from

RC = ("V1 in 0 PULSE(0 1 0 0 0 1 2)\nR1 in out 1k\nC1 out 0 1u\n.options theta=0.5\n"
      ".tran 1u 5m")


def meas(line, waves):
    return run_measurement(parse_meas(".meas tran " + line), waves)


@pytest.fixture(scope="module")
def rc():
    return circuit_from(RC).transient()


def test_rc_charging_measurements_match_the_exponential(rc):
    tau = 1e-3
    # WHEN: v = 1 - exp(-t/tau) = 0.5 at tau ln 2
    assert meas("t50 WHEN v(out)=0.5", rc).value == pytest.approx(tau * math.log(2), rel=1e-4)
    # TRIG/TARG 10 % -> 90 %: tau ln 9
    rise = meas("tr TRIG v(out) VAL=0.1 RISE=1 TARG v(out) VAL=0.9 RISE=1", rc)
    assert rise.value == pytest.approx(tau * math.log(9), rel=1e-4)
    # AVG over 0..5 tau: 1 - (1 - e^-5)/5; INTEG = 5 tau * AVG
    average = 1 - (1 - math.exp(-5)) / 5
    assert meas("a AVG v(out) from=0 to=5m", rc).value == pytest.approx(average, rel=1e-5)
    assert meas("q INTEG v(out) from=0 to=5m", rc).value == pytest.approx(5e-3 * average, rel=1e-5)
    # RMS: sqrt(mean((1 - e^-x)^2)) over x in 0..5
    mean_square = 1 - 2 * (1 - math.exp(-5)) / 5 + (1 - math.exp(-10)) / 10
    assert meas("r RMS v(out) from=0 to=5m", rc).value == pytest.approx(math.sqrt(mean_square), rel=1e-5)
    # FIND AT and DERIV AT: v and dv/dt = e^-t/tau / tau at 2 ms
    assert meas("f FIND v(out) AT=2m", rc).value == pytest.approx(1 - math.exp(-2), rel=1e-6)
    assert meas("d DERIV v(out) AT=2m", rc).value == pytest.approx(math.exp(-2) / tau, rel=1e-3)
    # MAX, MIN, PP; FIND ... WHEN (the current when v(out) = 0.5 is 0.5 mA)
    assert meas("m MAX v(out) from=1m to=2m", rc).value == pytest.approx(1 - math.exp(-2), rel=1e-6)
    assert meas("n MIN v(out) from=1m to=2m", rc).value == pytest.approx(1 - math.exp(-1), rel=1e-6)
    assert meas("p PP v(out) from=1m to=2m", rc).value == pytest.approx(math.exp(-1) - math.exp(-2),
                                                                        rel=1e-5)
    assert meas("i FIND i(v1) WHEN v(out)=0.5", rc).value == pytest.approx(-0.5e-3, rel=1e-4)
    # a level never reached: NaN and ngspice's message
    missing = meas("x WHEN v(out)=2", rc)
    assert math.isnan(missing.value) and "out of interval" in missing.line


def test_crossing_counts_rise_fall_cross_and_last():
    t = np.linspace(0, 3, 3001)
    waves = Waveforms(t, {"v(x)": np.sin(2 * np.pi * t)})
    assert meas("a WHEN v(x)=0.5 RISE=2", waves).value == pytest.approx(1 + 1 / 12, abs=1e-6)
    assert meas("b WHEN v(x)=0.5 FALL=1", waves).value == pytest.approx(5 / 12, abs=1e-6)
    assert meas("c WHEN v(x)=0.5 CROSS=3", waves).value == pytest.approx(1 + 1 / 12, abs=1e-6)
    assert meas("d WHEN v(x)=0.5 RISE=LAST", waves).value == pytest.approx(2 + 1 / 12, abs=1e-6)
    assert meas("e WHEN v(x)=0.5 RISE=1 TD=1.5", waves).value == pytest.approx(2 + 1 / 12, abs=1e-6)


def _plateaus() -> Waveforms:
    """v(a) = PWL(0 1 1m 0 3m 0 4m 1 5m 1 6m 0 8m 0 9m 1) sampled every 0.1 ms up to 10 ms:
    flat at 0 over 1-3 ms and 6-8 ms, at 1 over 4-5 ms and from 9 ms on."""
    t = np.round(np.linspace(0, 10e-3, 101), 12)
    x = np.interp(t, [0, 1e-3, 3e-3, 4e-3, 5e-3, 6e-3, 8e-3, 9e-3, 10e-3],
                  [1, 0, 0, 1, 1, 0, 0, 1, 1])
    return Waveforms(t, {"v(a)": x})


def test_a_signal_sitting_at_the_level_is_not_a_crossing_at_each_sample():
    # hunt3: on a stretch where the signal equals VAL exactly (a diode current at 0, a node
    # at 0 before its source starts), the crossing was placed at a sample inside the flat
    # stretch (here 1.1 ms, 1.2 ms, ...). ngspice 39 (`ngspice -b`, this PWL on a 0.1 ms
    # grid) prints "out of interval" for these: the crossing's instant is 0/0 there.
    waves = _plateaus()
    assert meas("c1 WHEN v(a)=0 CROSS=1", waves).value == pytest.approx(1e-3)
    for line in ("c2 WHEN v(a)=0 CROSS=2", "c3 WHEN v(a)=0 CROSS=3", "r1 WHEN v(a)=0 RISE=1",
                 "f2 WHEN v(a)=0 FALL=2"):
        result = meas(line, waves)
        assert math.isnan(result.value) and "out of interval" in result.line, line
    # a signal at the level from its first sample does not cross it at the second
    t = waves.time
    waves = Waveforms(t, {"v(a)": np.where(t < 5e-3, 0.0, t - 5e-3)})
    assert math.isnan(meas("s WHEN v(a)=0", waves).value)


def test_min_at_and_max_at_take_the_last_of_equal_extremes_as_ngspice():
    # ngspice 39 (`ngspice -b` on V1 a 0 PWL(0 1 1m 0 3m 0 4m 1 5m 1 6m 0 8m 0 9m 1), .tran
    # 0.1m 10m) prints MIN_AT v(a) = 8 ms and MAX_AT v(a) = 10 ms: of equal samples, the last
    waves = _plateaus()
    assert meas("a MIN_AT v(a)", waves).value == pytest.approx(8e-3)
    assert meas("b MAX_AT v(a)", waves).value == pytest.approx(10e-3)
    low = meas("c MIN v(a)", waves)
    assert low.value == 0.0 and low.extra["at"] == pytest.approx(8e-3)


def test_printed_like_ngspice(rc):
    assert meas("t50 WHEN v(out)=0.5", rc).line.startswith("t50                 =  6.93")
    assert " from=  0.000000e+00 to=  5.000000e-03" in meas("a AVG v(out) from=0 to=5m", rc).line


def test_fourier_of_a_known_wave():
    t = np.linspace(0, 2e-2, 20001)
    wave = 1 + 3 * np.sin(2 * np.pi * 100 * t) + 0.5 * np.cos(2 * np.pi * 300 * t)
    dc, magnitudes, phases = fourier_coefficients(Waveforms(t, {"v(x)": wave}), "v(x)", 100)
    assert dc == pytest.approx(1, abs=1e-6)
    np.testing.assert_allclose(magnitudes[:4], [3, 0, 0.5, 0], atol=1e-5)
    assert phases[0] == pytest.approx(0, abs=1e-3) and phases[2] == pytest.approx(90, abs=1e-2)


@pytest.mark.parametrize(("line", "message"), [
    (".meas tran x PARAM='a*'", "PARAM: "),
    (".meas tran x AVG", "too few fields|needs a signal"),
    (".meas tran x WHEN v(a)", "WHEN needs OUT=VAL"),
    (".meas tran x TRIG v(a) VAL=1", "TARG"),
    (".meas tran x FIND v(a)", "AT=t or WHEN"),
    (".meas tran x AVG v(a) at=1", "does not take at"),
    (".meas tran x AVG v(a) from=", "expected key=value"),
    (".meas tran x AVG from=1m", "needs a signal"),
    (".meas tran x FOO v(a)", "not supported"),
])
def test_meas_errors_say_what_to_write(line, message):
    with pytest.raises(NetlistError, match=message):
        parse_meas(line)


def test_meas_in_a_netlist_runs_from_the_command_line(tmp_path):
    path = tmp_path / "rc.cir"
    path.write_text("rc\n" + RC + "\n.meas tran t50 WHEN v(out)=0.5\n.meas ac x MAX v(out)\n"
                    ".four 200 v(in)\n.end\n")
    done = subprocess.run([sys.executable, "-m", "circuitnsds", "run", str(path), "-q",
                           "--measure", "tran avg1 AVG v(out) from=0 to=1m"],
                          capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "t50                 =  6.93" in done.stdout
    assert "avg1" in done.stdout and "Fourier analysis for v(in)" in done.stdout
    assert ".meas ignored (only .meas tran" in done.stderr


def test_a_four_line_that_cannot_be_evaluated_names_its_line(tmp_path, capsys):
    # before: "measure: window -0.018 s .. 0.002 s is not inside ..." and "measure: no signal",
    # with no file:line; .meas errors named theirs
    from circuitnsds.cli.main import main

    path = tmp_path / "rc.cir"
    for four, message in [(".four 50 v(out)", "the run (0 s .. 5 ms) is shorter than one period "
                           "of the fundamental (50 Hz: 20 ms)"),
                          (".four 1k v(zz)", "no signal 'v(zz)'")]:
        path.write_text("rc\n" + RC + f"\n{four}\n.end\n")
        assert main(["run", str(path), "-q", "-o", str(tmp_path / "o.csv")]) == 1
        err = capsys.readouterr().err
        assert f"error: {path}:7: {message}" in err, err


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

WORDS = st.sampled_from(["tran", "ac", "x", "avg", "rms", "when", "find", "deriv", "trig", "targ",
                         "v(a)", "i(v1)", "=", "from", "to", "td", "rise", "fall", "cross", "last",
                         "val", "at", "1m", "-2", "abc", "'p'", "pp", "integ", "max_at",
                         "par(v(a)", "par(v(a))", "par('v(a)*k')", "par('sqrt(v(a))')"])


@settings(max_examples=300, deadline=None)
@given(st.lists(WORDS, max_size=12))
def test_any_meas_line_parses_or_says_what_to_write(words):
    try:
        spec = parse_meas(".meas " + " ".join(words))
    except NetlistError as exc:
        assert exc.hint  # every refusal says what to write
    else:
        assert spec is None or spec.name


def test_par_expression_of_signals_is_measured_as_its_values_on_the_grid(rc):
    # ngspice's par('expr') in place of OUT (simple-meas-tran.sp: FIND par('v(2)*v(1)') AT=2.3m);
    # before: no signal "par('v(in)*v(out)')". v(in) = 1 for t < 1 s, so the product is v(out).
    found = meas("p FIND par('v(in)*v(out)') AT=1m", rc).value
    assert found == pytest.approx(1 - math.exp(-1), rel=1e-4)
    # the power in R1, v(in,out)²/R, integrated over 5 τ: C/2 (1 - e^-10) for the RC charge
    energy = meas("e INTEG par('v(in, out)**2 / 1k') from=0 to=5m", rc).value
    assert energy == pytest.approx(0.5e-6 * (1 - math.exp(-10)), rel=1e-3)
    # in a WHEN condition too: the product crosses 0.5 where v(out) does
    assert meas("w WHEN par('v(in)*v(out)')=0.5", rc).value == pytest.approx(1e-3 * math.log(2), rel=1e-4)


def test_a_par_expression_that_is_not_one_is_refused_at_its_line():
    with pytest.raises(NetlistError, match=r"par\('v\(out\) \*'\)"):
        parse_meas(".meas tran p FIND par('v(out) *') AT=1m")


@pytest.mark.parametrize("expression, message", [
    ("par(v(out)", "single quotes"),  # was a TypeError: the run ended in 'internal error'
    ("par('v(out)*k')", "undefined parameter 'k' in 'v\\(out\\)\\*k'"),
    ("par('foo(v(out))')", r"unknown function foo\(\)"),
    ("par('pow(v(out))')", r"pow\(\) takes 2 argument"),
])
def test_a_par_expression_that_fails_at_every_point_is_refused_at_its_line(expression, message):
    # an undefined name or function failed at each point alike: the measurement printed NaN, exit 0
    with pytest.raises(NetlistError, match=message):
        parse_meas(f".meas tran p MAX {expression}")


def test_param_names_and_measured_levels_in_meas_are_the_values_ngspice_gives_them():
    from circuitnsds.output.meas import run_measurements

    circuit = circuit_from(RC + "\n.param fval=5 offset=0.25\n.meas tran yadd param='fval + 7'\n"
                           ".meas tran vmax MAX v(out)\n.meas tran vhalf param='vmax/2 - offset + 0.25'\n"
                           ".meas tran thalf WHEN v(out)=vhalf\n")
    results = {r.name: r.value for r in run_measurements(circuit.measurements, circuit.transient())}
    assert results["yadd"] == 12  # before: undefined parameter 'fval'
    vmax = 1 - math.exp(-5)
    assert results["vhalf"] == pytest.approx(vmax / 2)
    # a WHEN level naming an earlier measurement is its value (before: no signal 'vhalf')
    assert results["thalf"] == pytest.approx(-1e-3 * math.log(1 - vmax / 2), rel=1e-4)


def test_a_when_level_written_as_an_expression_of_signals_is_that_expression(rc):
    # ngspice's meas_expression.cir, in its script: WHEN v(1)= 0.9*v(2) (before: no signal '0.9*v(in)')
    written = meas("w WHEN v(out)=0.5*v(in)+0.25", rc).value
    assert written == pytest.approx(meas("w WHEN v(out)=par('0.5*v(in)+0.25')", rc).value)
    assert written == pytest.approx(1e-3 * math.log(4), rel=1e-4)  # 1 - exp(-t/τ) = 0.75
