"""AM and SFFM independent sources as ngspice 39 reads them (issues 32, 33): the waveforms in
closed form, their defaults, the warning for a line written in a later ngspice's order, and
ngspice 39's own values on its time points for the same lines."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.errors import NetlistWarning
from circuitnsds.system.stimuli import Am, Sffm, resolving_step
from tests.conftest import NETLISTS, circuit_from


def test_am_is_a_carrier_times_an_offset_envelope_after_its_delay():
    # AM(VA VO MF FC TD): VA·(VO + sin(2π·MF·τ))·sin(2π·FC·τ), τ = t − TD, zero before TD
    am = Am(2.0, 0.5, 1e3, 10e3, 1e-4)
    assert am.value(0.5e-4) == 0.0 and am.value(1e-4) == 0.0
    # a quarter carrier period after TD: carrier sin = 1, envelope 0.5 + sin(2π·1k·25 µs)
    t = 1e-4 + 25e-6
    assert am.value(t) == pytest.approx(2.0 * (0.5 + math.sin(2 * math.pi * 1e3 * 25e-6)))
    assert am.breakpoints(1.0) == [1e-4]


def test_am_phases_shift_both_sines_by_phases_as_ngspice_39():
    # ngspice 39 reads PHASEC and applies PHASES to the carrier and the modulation
    am = Am(1.0, 0.0, 1e3, 1e3, 0.0, 45.0, 90.0)
    t = 1e-5
    expected = math.sin(2 * math.pi * 1e3 * t + math.pi / 2) ** 2
    assert am.value(t) == pytest.approx(expected)


def test_sffm_without_modulation_index_is_a_sine_of_the_carrier():
    sffm = Sffm(0.1, 2.0, 1e3).resolve(1e-6, 1e-2)
    times = np.linspace(0, 1e-2, 101)
    np.testing.assert_allclose(sffm.sample(times), 0.1 + 2.0 * np.sin(2 * math.pi * 1e3 * times),
                               atol=1e-12)


def test_defaults_are_one_over_tstop_also_when_given_as_zero():
    am = Am(1.0, 1.0, 0.0).resolve(1e-6, 5e-3)
    assert am.modulation_frequency == pytest.approx(200.0) and am.carrier_frequency == 0.0
    sffm = Sffm(0.0, 1.0, 0.0, 3.0).resolve(1e-6, 5e-3)
    assert sffm.carrier_frequency == pytest.approx(200.0)
    assert sffm.signal_frequency == pytest.approx(200.0)


def test_the_step_resolves_the_highest_frequency():
    # SFFM's instantaneous frequency reaches FC + MDI·FS: 1k + 5·10k = 51 kHz, 20 points
    assert resolving_step(Sffm(0, 1, 1e3, 5.0, 10e3), 1.0) == pytest.approx(1 / (51e3 * 20))
    # AM's upper side band FC + MF
    assert resolving_step(Am(1, 1, 1e3, 10e3), 1.0) == pytest.approx(1 / (11e3 * 20))
    assert resolving_step(Am(0, 1, 1e3, 10e3), 1.0) is None  # VA = 0: constant zero


@settings(max_examples=40, deadline=None)
@given(st.floats(-5, 5), st.floats(0.1, 5), st.floats(1, 1e4), st.floats(0, 10),
       st.floats(1, 1e4), st.floats(-180, 180), st.floats(-180, 180))
def test_sample_and_value_agree_and_stay_within_the_envelope(vo, va, fc, mdi, fs, pc, ps):
    sffm = Sffm(vo, va, fc, mdi, fs, pc, ps)
    times = np.linspace(0.0, 1e-3, 37)
    sampled = sffm.sample(times)
    assert all(sampled[k] == pytest.approx(sffm.value(t), abs=1e-12) for k, t in enumerate(times))
    assert np.all(np.abs(sampled - vo) <= va + 1e-12)
    am = Am(va, vo, fs, fc, 1e-4, pc, ps)
    sampled = am.sample(times)
    assert np.all(np.abs(sampled) <= va * (abs(vo) + 1) + 1e-12)
    assert np.all(sampled[times <= 1e-4] == 0.0)


def test_a_source_runs_as_its_waveform():
    waves = circuit_from("V1 a 0 AM(1.5 0.5 2k 20k 0.1m 30 60)\nR1 a 0 1k\n"
                         "I2 0 b SFFM(0.1 2 200 4 10k)\nR2 b 0 1\n.tran 1u 1m").transient()
    am, sffm = Am(1.5, 0.5, 2e3, 20e3, 1e-4, 30, 60), Sffm(0.1, 2, 200, 4, 10e3)
    np.testing.assert_allclose(waves["v(a)"], am.sample(waves.time), atol=1e-12)
    np.testing.assert_allclose(waves["v(b)"], sffm.sample(waves.time), atol=1e-12)


def test_eight_values_are_read_in_ngspice_39s_order_with_a_warning():
    # ngspice 39 ignores the 8th value; ngspice 40 reads AM(VO VMO VMA FM FC TD PHASEM PHASEC)
    with pytest.warns(NetlistWarning, match=r"v1: AM with 8 values: read as ngspice 39 does"):
        circuit = circuit_from("V1 a 0 AM 0.5 2 1.8 1k 100k 1m 0 0\nR1 a 0 1\n.tran 1u 1m")
    function = circuit.element("v1").function
    assert function == Am(0.5, 2.0, 1.8, 1e3, 1e5, 1e-3, 0.0)


def test_too_many_values_are_an_error():
    from circuitnsds.errors import NetlistError

    with pytest.raises(NetlistError, match=r"v1: SFFM takes 2 to 8 numbers, got 9"):
        circuit_from("V1 a 0 SFFM(0 1 1k 1 1k 0 0 0 0)\nR1 a 0 1\n.tran 1u 1m")


NGSPICE_LINES = """modulated sources as ngspice 39 reads them
V1 1 0 AM 0.5 2 1.8 1k 100k 1m 0 0
R1 1 0 1k
V2 2 0 SFFM 0.1 2 200 45 10k 1m 0 0
R2 2 0 1k
V3 3 0 AM 1.5 0.5 2k 20k 0.1m 30 60
R3 3 0 1k
V4 4 0 SFFM(0.1 2 200 4 10k)
R4 4 0 1k
V5 5 0 AM(1.5 0.5 2k 20k)
R5 5 0 1k
I6 0 6 SFFM(0 1m 0 2)
R6 6 0 1k
.tran 1u 3m
.end
"""


@pytest.mark.ngspice
def test_each_form_agrees_with_ngspice_39_on_its_own_time_points():
    # ngspice 39 on these lines (measured: within 5.2e-9 V, its printed precision); V1 is zero
    # throughout (its TD is 100k s in ngspice 39's order), V3's PHASEC is unused
    from circuitnsds.compare.ngspice import run_ngspice

    nodes = [f"v({k})" for k in range(1, 7)]
    run = run_ngspice(NGSPICE_LINES, nodes, 3e-3)
    assert run.status == "ok", run.message
    theirs = run.waveforms
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuit_from(NGSPICE_LINES.split("\n", 1)[1])
    for k, node in enumerate(nodes, start=1):
        source = circuit.element(f"{'i' if k == 6 else 'v'}{k}")
        function = source.function.resolve(1e-6, 3e-3)
        scale = 1e3 if k == 6 else 1.0  # I6 into 1 kΩ
        np.testing.assert_allclose(scale * function.sample(theirs.time), theirs[node], atol=2e-8,
                                   err_msg=node)
    assert np.max(np.abs(theirs["v(3)"])) > 1.0 and np.max(np.abs(theirs["v(1)"])) == 0.0


@pytest.mark.ngspice
def test_ngspices_am_fm_example_runs_and_agrees_with_ngspice():
    # ngspice's examples/various/v-i-sources-am-ffm.cir: ngspice 39 reads its 8-value lines in
    # its own order (both AM sources zero throughout, the SFFM a 200 Hz carrier phase-modulated
    # at 10 kHz); compared on ngspice's time points, where the linear interpolation of a
    # 450 kHz instantaneous frequency does not enter
    from circuitnsds.compare import compare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = compare(NETLISTS / "external" / "ng_v-i-sources-am-ffm.cir",
                             signals=["v(1)", "v(2)", "v(3)", "v(10)", "v(20)"])
    assert comparison.run.ok, comparison.run.ngspice.message
    ours, theirs = comparison.circuitnsds, comparison.run.ngspice.waveforms
    for node in ("v(1)", "v(2)", "v(3)", "v(20)"):
        assert np.max(np.abs(ours[node])) == 0.0 and np.max(np.abs(theirs[node])) < 1e-12, node
    carrier = Sffm(0.1, 2, 200, 45, 10e3, 1e-3, 0.0)
    np.testing.assert_allclose(carrier.sample(theirs.time), theirs["v(10)"], atol=2e-8)
    np.testing.assert_allclose(carrier.sample(ours.time), ours["v(10)"], atol=1e-12)


def test_pss_refuses_am_and_sffm_by_name():
    from circuitnsds.errors import CircuitError

    for line, words in (("V1 a 0 AM(1 0.5 1k 10k)", "AM sources are not supported by pss"),
                        ("V1 a 0 SFFM(0 1 10k 2 1k)", "SFFM sources are not supported by pss")):
        circuit = circuit_from(f"{line}\nR1 a 0 1\n.tran 1u 1m")
        with pytest.raises(CircuitError, match=words):
            circuit.pss()
