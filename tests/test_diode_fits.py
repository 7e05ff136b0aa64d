"""Issue 34: diodes fitted to SPICE models are fitted where the circuit works in every
analysis: the periodic steady state and the small-signal analysis around an operating point
refit them as the transient does (before, pss and ac kept the fit made when the netlist
was read, and `pss` ignored pwlfit=auto)."""

import math
import warnings

import numpy as np
import pytest

import circuitnsds
from circuitnsds.errors import RunNote

VT = 1.380649e-23 * 300.15 / 1.602176634e-19

ZENER_CLIPPER_5A = """Zener clipper at 5 A
V1 in 0 SIN(0 20 1k)
R1 in out 3
DZ1 0 out zspice
.model zspice D(IS=1e-14 N=0.05 BV=5.1 IBV=1m)
.tran 10u 2m
.end
"""


def test_pss_refits_to_the_currents_of_its_periodic_steady_state():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = circuitnsds.read_netlist(ZENER_CLIPPER_5A).pss()
    assert any(issubclass(w.category, RunNote) and "refitted" in str(w.message) for w in caught)
    waves = result.waveforms
    reverse = -float(waves["i(dz1)"].min())
    assert reverse > 4  # 20 V through 3 ohm, less the Zener's 5.1 V
    # the model's breakdown curve (NBV defaults to N in ngspice), written out here
    model = 5.1 + 0.05 * VT * math.log(reverse / 1e-3)
    assert float(waves["v(out)"].max()) == pytest.approx(model, abs=2e-3)  # fit within 1 mV


def test_ac_around_an_operating_point_refits_to_its_currents():
    """A diode biased at 47 nA (1 V through 10 Mohm): its small-signal resistance N·Vt/I is
    554 kohm, so the gain to v(a) is 0.0525. The branches fitted 5 decades below 1 A gave
    5.7e-9 (their first branch's slope); refitted at the operating point, the chord of the
    branch that carries it is within a factor of 2 of the tangent."""
    text = """diode biased at 50 nA
V1 in 0 DC 1 AC 1
R1 in a 10meg
D1 a 0 dd
.model dd D(IS=1e-14 N=1)
.end
"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = circuitnsds.read_netlist(text).ac("v1", ["v(a)"], [1.0], around="op")
    low, high = 0.0, 1.0  # the operating point: (1 - v)/10M = IS (exp(v/Vt) - 1)
    for _ in range(100):
        v = (low + high) / 2
        low, high = (v, high) if (1 - v) / 10e6 > 1e-14 * math.expm1(v / VT) else (low, v)
    current = (1 - v) / 10e6
    resistance = VT / current
    gain = resistance / (10e6 + resistance)
    assert 0.5 < abs(complex(result.transfer["v(a)"][0])) / gain < 2


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from circuitnsds.circuit.elements.diode_fit import ShockleyDiode, fit_forward  # noqa: E402


@settings(max_examples=25, deadline=None)
@given(saturation=st.floats(1e-16, 1e-6), emission=st.floats(0.03, 2.5),
       series=st.floats(0, 1), knee=st.one_of(st.none(), st.floats(1e-4, 10)),
       recombination=st.one_of(st.none(), st.floats(1e-14, 1e-6)), high=st.floats(1e-4, 30))
def test_full_equation_fits_keep_a_p_matrix_and_their_stated_error(saturation, emission, series,
                                                                    knee, recombination, high):
    """Every fitted branch adds conductance (R_j > 0, knees ascending: the LCP stays a
    P-matrix) and the stated error holds between the fit's own samples; the curve is the
    ngspice forward equation with IKF and ISR, inverted here by bisection."""
    diode = ShockleyDiode(saturation, emission, series, knee_current=knee,
                          recombination_current=recombination)
    fit = fit_forward(diode, high)
    assert len(fit.branches) <= 6 and list(fit.knees) == sorted(fit.knees)
    assert all(r > 0 for r in fit.resistances) or len(fit.branches) == 1
    for current in np.geomspace(fit.low, fit.high, 13):
        low, top = 0.0, 50.0
        for _ in range(80):  # v with Id(v - RS·i) = i, Id from the equation written out
            v = (low + top) / 2
            vd = v - series * current
            if vd / (min(emission, 2.0) * VT) > 700:  # beyond any current of the range
                top = v
                continue
            total = saturation * math.expm1(vd / (emission * VT)) if vd > 0 else 0.0
            if recombination and vd > 0:
                total += recombination * math.expm1(vd / (2 * VT)) * ((1 - vd) ** 2 + 0.005) ** 0.25
            if knee and total > 0:
                total /= 1 + math.sqrt(total / knee)
            low, top = (v, top) if total < current else (low, v)
        assert abs(float(fit.voltage(current)) - v) <= fit.max_error * 1.05 + 1e-6


def test_a_streamed_run_that_leaves_a_fit_warns_naming_the_diode():
    """A run whose rows go to a sink as it goes cannot be repeated refitted: the Zener
    clipper at 5 A (its breakdown fitted up to 1 A) warns, naming the diode and the way out."""
    from circuitnsds.errors import CircuitWarning

    class Rows:
        def append(self, time, columns, residual):
            pass

    circuit = circuitnsds.read_netlist(ZENER_CLIPPER_5A)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        circuit.transient(signals=["v(out)"], sink=Rows())
    found = [str(w.message) for w in caught if issubclass(w.category, CircuitWarning)]
    assert any("diode dz1 (.model zspice)" in m and "breakdown" in m and "--signals" in m
               for m in found), found


def test_a_refitted_rerun_warns_of_the_time_scales_once():
    """A run refitted and run again warns of a ringing the step misses once, for the run it
    returns (the merge of issue 36 into issue 34's reruns said it after each of the two runs):
    beside the 5 A clipper, L1-C1 rings at 1/(2π√(LC)) = 159 kHz, 0.63 steps of 10 µs a period."""
    from circuitnsds.errors import CircuitWarning

    netlist = ZENER_CLIPPER_5A.replace(".tran", "R2 in a 0.1\nL1 a b 1u\nC1 b 0 1u\n.tran")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        circuitnsds.read_netlist(netlist).transient()
    said = [str(w.message) for w in caught]
    assert any("refitted" in m for m in said), said  # (the rerun happened)
    ringing = [w for w in caught
               if issubclass(w.category, CircuitWarning) and "rings at 159 kHz" in str(w.message)]
    assert len(ringing) == 1, said


def test_the_command_line_says_a_note_of_a_refitted_run_once(tmp_path, capsys):
    """The checks before a run are made again before its refitted rerun: the command line
    printed every one of them twice (here the note on a PULSE written with PW = 0)."""
    from circuitnsds.cli.main import main

    netlist = tmp_path / "clipper.cir"
    netlist.write_text(ZENER_CLIPPER_5A.replace(".tran", "V2 p 0 PULSE(0 1 0 100u 100u 0 400u)\n"
                                                "R2 p 0 1k\n.tran"))
    assert main(["run", str(netlist), "-o", str(tmp_path / "out.csv")]) == 0
    err = capsys.readouterr().err
    assert "refitted where its diodes work" in err  # (the rerun happened)
    assert err.count("v2: PULSE with PW = 0 is read as PW = TSTOP") == 1, err
