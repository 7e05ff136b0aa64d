"""XSPICE d_pwm (ngspice's duty-cycle-controlled digital oscillator, issue 33): the edges of
its output where ngspice's cfunc.mod puts them (rising when the phase reaches 1 − dc, falling
at each period's end), its table interpolated, extrapolated and clamped as ngspice's, clear
errors, and ngspice 39's edges on the same netlist."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from circuitnsds.errors import NetlistError
from circuitnsds.system.stimuli import Sawtooth
from tests.conftest import circuit_from

PERIOD = 10e-6  # 100 kHz


def pwm_edges(control: str, table: str, stop: float, phase: float = 0.0):
    """(rising, falling) instants [s] of a 100 kHz d_pwm driven by ``control`` (a V source)."""
    text = (f"Vc c 0 {control}\nAp c d pwm\n"
            f".model pwm d_pwm({table} frequency=100k init_phase={phase:g})\n"
            "Ab [d] [o] dac\n.model dac dac_bridge(out_low=0 out_high=1)\nR1 o 0 1k\n"
            f".tran 0.1u {stop:g}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuit_from(text).transient()
    events = [e for e in waves.events if e.element == "ap"]
    rising = np.array([e.time for e in events if e.state])
    falling = np.array([e.time for e in events if not e.state])
    return rising, falling, waves


TABLE = "cntl_array=[-1 1] dc_array=[0 1]"


def test_duty_follows_a_constant_control():
    # dc = (0.5 + 1)/2 = 0.75: high from 2.5 µs to 10 µs of each period
    rising, falling, waves = pwm_edges("DC 0.5", TABLE, 5 * PERIOD)
    np.testing.assert_allclose(rising, (np.arange(5) + 0.25) * PERIOD, rtol=0, atol=1e-12)
    np.testing.assert_allclose(falling, (np.arange(1, 5)) * PERIOD, rtol=0, atol=1e-4 * PERIOD)
    assert set(np.round(waves["v(o)"], 12)) <= {0.0, 1.0}


def test_init_phase_shifts_the_period():
    # init_phase = 90: the phase starts at 0.25; dc 0.5 -> rising when the phase is 0.5
    rising, falling, _ = pwm_edges("DC 0", TABLE, 3 * PERIOD, phase=90)
    np.testing.assert_allclose(rising, (np.arange(3) + 0.25) * PERIOD, atol=1e-12)
    np.testing.assert_allclose(falling, (np.arange(3) + 0.75) * PERIOD, atol=1e-4 * PERIOD)


def test_a_ramp_control_moves_the_rising_edge_where_phase_meets_one_minus_dc():
    # control 0 -> 1 V over 100 µs: dc(t) = (1 + t/100µ)/2; in period k the edge t solves
    # frac(t/T) = 1 - dc(t)
    rising, falling, _ = pwm_edges("PWL(0 0 100u 1)", TABLE, 10 * PERIOD)
    k = np.arange(10)
    expected = (k * PERIOD + 0.5 * PERIOD) / (1 + 0.5 * PERIOD / 100e-6)
    np.testing.assert_allclose(rising, expected, atol=1e-11)


def test_the_table_is_extrapolated_and_clamped_as_ngspice_does():
    # points (0, 0.2) (1, 0.6): slope 0.4 beyond both ends; control 2 -> 1.0, clamped to 1
    # (high the whole period after its first rise); control -1 -> -0.2, clamped to 0 (low)
    table = "cntl_array=[0 1] dc_array=[0.2 0.6]"
    rising, falling, waves = pwm_edges("DC 1.5", table, 3 * PERIOD)
    np.testing.assert_allclose(rising, (np.arange(3) + 0.2) * PERIOD, atol=1e-12)  # dc 0.8
    _, _, waves = pwm_edges("DC -1", table, 3 * PERIOD)
    assert np.max(waves["v(o)"]) == 0.0
    rising, falling, waves = pwm_edges("DC 2", table, 3 * PERIOD)
    assert np.min(waves["v(o)"][waves.time > 0.5 * PERIOD]) == 1.0


def test_sawtooth_drops_at_each_period_end_and_is_left_continuous():
    saw = Sawtooth(1e5, 0.25)
    assert saw.value(0.0) == 0.25 and saw.value(7.5e-6) == 1.0 and saw.value(7.5001e-6) < 1e-4
    # each drop, and 1e-4 of a period after it (the comparator's first step)
    np.testing.assert_allclose(saw.breakpoints(3e-5)[::2], [7.5e-6, 17.5e-6, 27.5e-6])
    np.testing.assert_allclose(np.diff(saw.breakpoints(3e-5))[::2], 1e-9, rtol=1e-3)


def test_a_step_longer_than_the_low_part_misses_no_edge():
    # the .tran step (2 µs) is longer than the whole period (1 µs at 1 MHz) and dc = 0.9: each
    # period still has its fall (within 1e-4 of a period of its end) and its rise
    text = ("Vc c 0 0.8\nAp c d pwm\n.model pwm d_pwm(cntl_array=[-1 1] dc_array=[0 1] "
            "frequency=1Meg)\nAb [d] [o] dac\n.model dac dac_bridge(out_low=0 out_high=1)\n"
            "R1 o 0 1k\n.tran 2u 20u")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuit_from(text).transient()
    events = [e for e in waves.events if e.element == "ap"]
    rising = np.array([e.time for e in events if e.state])
    falling = np.array([e.time for e in events if not e.state])
    np.testing.assert_allclose(rising, (np.arange(20) + 0.1) * 1e-6, atol=1e-13)
    np.testing.assert_allclose(falling, np.arange(1, 20) * 1e-6, atol=1e-10)


@pytest.mark.parametrize(("table", "message"), [
    ("cntl_array=[0 1 2] dc_array=[0 1]", r"cntl_array has 3 values and dc_array 2"),
    ("cntl_array=[1 0] dc_array=[0 1]", r"cntl_array must increase"),
    ("cntl_array=[0 1] dc_array=[0 1.5]", r"dc_array values must lie in \[0, 1\]"),
    ("dc_array=[0 1]", r"cntl_array and dc_array are both required"),
    ("cntl_array=0 dc_array=[0 1]", r"cntl_array is a vector"),
])
def test_bad_tables_are_refused_by_name(table, message):
    with pytest.raises(NetlistError, match=message):
        pwm_edges("DC 0", table, PERIOD)


NGSPICE_PWM = """d_pwm against ngspice
Vc c 0 SIN(0 0.9 5k)
Ap c d pwm
.model pwm d_pwm(cntl_array=[-1 -0.99 0.99 1] dc_array=[0.01 0.01 0.99 0.99] frequency=100k
+ init_phase=90)
Ab [d] [o] dac
.model dac dac_bridge(out_low=0 out_high=1)
R1 o 0 1k
.tran 0.1u 400u
.end
"""


def _crossings(time, values, rising: bool):
    above = values > 0.5
    k = np.flatnonzero(above[1:] != above[:-1])
    k = k[above[k + 1] == rising]
    return time[k] + (0.5 - values[k]) * (time[k + 1] - time[k]) / (values[k + 1] - values[k])


@pytest.mark.ngspice
def test_edges_agree_with_ngspice_39():
    # ngspice delays each edge by rise_delay/fall_delay (1 ns) and ramps the dac_bridge over
    # t_rise (1 ns): its 0.5 V crossings lag ours by 1.5 ns. Its falling edges are the period
    # ends; its rising edge is extrapolated from its previous time point holding dc there
    # (cfunc.mod: t1 = T(1) + (1 - dc - phase)/F), off by up to |d dc/dt|·h/F: here
    # 0.49·0.9·2π·5k /s · 0.1 µs / 100 kHz = 13.9 ns (ours is the exact crossing)
    from circuitnsds.compare.ngspice import run_ngspice

    run = run_ngspice(NGSPICE_PWM, ["v(o)"], 400e-6)
    assert run.status == "ok", run.message
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours = circuit_from(NGSPICE_PWM.split("\n", 1)[1]).transient()
    events = [e for e in ours.events if e.element == "ap"]
    bound = {True: 0.49 * 0.9 * 2 * np.pi * 5e3 * 0.1e-6 / 100e3, False: 0.3e-9 + 1e-4 * PERIOD}
    for rising in (True, False):
        theirs = _crossings(run.waveforms.time, run.waveforms["v(o)"], rising)
        mine = np.array([e.time for e in events if e.state == rising])
        assert len(mine) == len(theirs) == 40
        np.testing.assert_allclose(theirs - mine, 1.5e-9, atol=bound[rising])


def test_pss_refuses_d_pwm_by_name():
    # (it said the sawtooth "makes one transition")
    from circuitnsds.errors import CircuitError

    text = ("Vc c 0 0.5\nAp c d pwm\n.model pwm d_pwm(cntl_array=[-1 1] dc_array=[0 1] "
            "frequency=100k)\nAb [d] [o] dac\n.model dac dac_bridge(out_low=0 out_high=1)\n"
            "R1 o 0 1k\n.tran 1u 100u")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuit_from(text)
    with pytest.raises(CircuitError, match=r"AP.RAMP.*the phase of an XSPICE d_pwm, which pss "
                       r"does not support yet"):
        circuit.pss()
