"""The exact integrator's wrong answers with exit 0 (issue 31, docs/method.md "Digital
parts"), each under ``method=exact``: a capacitor's current at a row is ``C dv/dt`` at the
row's instant, as every other current there, so Kirchhoff's current law holds on every row
(it was ΔQ/Δt over the interval before the row: a switched RC off by 0.045 A where the
currents are 0.034 A); the Zener RLC's Zener holds the capacitor's voltage while sliding
(it was 2.8e-5 V off); an XSPICE latch takes the right states (a clock divider took wrong
ones)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import circuitnsds
from circuitnsds.engine.stepper import choose_stepper
from circuitnsds.errors import RunNote
from tests.conftest import NETLISTS, circuit_from


def test_a_charging_capacitor_s_current_is_its_closed_form_at_each_row():
    # a 1 V ramp over 1 ns into R = 1 kΩ, C = 1 µF (RC = 1 ms), rows every 7 µs: during the
    # ramp (slope a = 1/τr) v = a(t − RC(1 − e^{−t/RC})), after it i = (1 − v(τr))/R e^{−(t−τr)/RC}.
    # ΔQ/Δt over a row's 7 µs is off by about 7 µs / 2 ms = 3.5e-3 of it.
    waves = circuit_from("V1 a 0 PWL(0 0 1n 1 1 1)\nR1 a b 1k\nC1 b 0 1u\n.tran 7u 3m").transient(
        method="exact")
    rc, ramp = 1e-3, 1e-9
    v_ramp = (ramp - rc * -math.expm1(-ramp / rc)) / ramp
    t = waves.time[waves.time >= ramp]
    expected = (1.0 - v_ramp) / 1e3 * np.exp(-(t - ramp) / rc)
    current = np.asarray(waves["i(c1)"])[waves.time >= ramp]
    assert t.size > 400
    np.testing.assert_allclose(current, expected, rtol=1e-9, atol=0)
    # and it is the resistor's current at every row, the start included (both 0 at t = 0)
    np.testing.assert_allclose(waves["i(c1)"], waves["i(r1)"], rtol=0, atol=1e-15)


def test_kirchhoff_holds_on_every_row_of_a_switched_rc():
    # the relaxation oscillator: S1 discharges C1 through 10 Ω whenever v(b) exceeds 2.25 V
    waves = circuit_from("V1 a 0 SIN(0 5 1k)\nR1 a b 100\nC1 b 0 1u\nS1 b 0 b 0 sw\n"
                         ".model sw SW(Vt=2 Vh=0.5 Ron=10 Roff=1e6)\n.tran 10u 2m").transient(method="exact")
    assert waves.stats["events"] >= 10 and waves.stats["handoffs"] == 0
    kcl = waves["i(r1)"] - waves["i(c1)"] - waves["i(s1)"]
    assert np.abs(waves["i(c1)"]).max() > 0.1
    assert np.abs(kcl).max() < 1e-15


def test_kirchhoff_holds_at_a_node_between_two_capacitors():
    # C1 couples a diode-clamped node into C2 ∥ R2: i(c1) = i(r2) + i(c2) at node b, and the
    # clamp at a: i(r1) = i(c1) + i(d1); the diode's turn-ons and turn-offs are events
    waves = circuit_from("V1 in 0 SIN(0 5 10k)\nR1 in a 100\nD1 a 0 dx\nC1 a b 1u\nR2 b 0 50\n"
                         "C2 b 0 2u\n.model dx D(Vfwd=0.6 Ron=1)\n.tran 3u 1m").transient(method="exact")
    assert sum(event.element == "d1" for event in waves.events) >= 10
    scale = np.abs(waves["i(r1)"]).max()
    assert np.abs(waves["i(c1)"] - waves["i(r2)"] - waves["i(c2)"]).max() < 1e-12 * scale
    assert np.abs(waves["i(r1)"] - waves["i(c1)"] - waves["i(d1)"]).max() < 1e-12 * scale


def test_the_synchronous_buck_s_output_node_balances_on_every_row():
    circuit = circuitnsds.read_netlist(NETLISTS / "meas" / "sync_buck_losses.cir")
    waves = circuit.transient(method="exact")
    balance = waves["i(l1)"] - waves["i(c1)"] - waves["i(rload)"]
    assert np.abs(balance).max() < 1e-12 * np.abs(waves["i(l1)"]).max()


def test_the_zener_rlc_s_zener_holds_the_capacitor_s_voltage_while_sliding():
    # Acary & Brogliato §1.2: once x1/C lies in [0, Vz] the loop current stays 0 and the
    # Zener's reverse voltage is the capacitor's (v(n1) − v(n3) = L i' + R i = 0; here gmin
    # holds the blocked Zener's node: R·i(l1) ≈ 1.5e-13 V). The slow mode's v(n1) was taken
    # through P, which multiplies i(l1)'s round-off by 1/gmin: 2.8e-5 V off.
    waves = circuitnsds.read_netlist(NETLISTS / "book_zener_rlc.cir").transient(method="exact")
    assert waves.stats["handoffs"] == 0
    sliding = waves.time > 2.0
    v_cap = np.asarray(waves["v(n3)"])[sliding]
    assert 0.5 < v_cap.min() and v_cap.max() < 10.0  # (inside the band, away from its ends)
    assert np.abs(np.asarray(waves["i(l1)"])[sliding]).max() < 1e-11
    np.testing.assert_allclose(np.asarray(waves["v(n1)"])[sliding], v_cap, rtol=0, atol=1e-12)


DIVIDER = """d_dff clock divider
Vclk clk 0 PULSE(0 1 0.5u 1n 1n 0.5u 1u)
Aadc [clk] [dclk] adc
.model adc adc_bridge(in_low=0.5 in_high=0.5)
Af nq dclk NULL NULL q nq ff
.model ff d_dff(ic=1)
.tran 0.1u 6u
.end
"""
FLIP_FLOP = "Af nq dclk NULL NULL q nq ff\n.model ff d_dff(ic=1)"


def _sampled(text: str, slots: int, slot: float) -> np.ndarray:
    """``v(q)`` of the exact run of ``text`` in the middle of each slot [s]."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        waves = circuitnsds.read_netlist(text).transient(method="exact")
    return np.round(np.interp((np.arange(slots) + 0.5) * slot, waves.time, waves["v(q)"]), 12)


def test_a_d_dff_clock_divider_takes_the_right_states():
    # q toggles at each rising edge (ic = 1: the master takes data 0 while the clock is low
    # first). At the falling edges q = 1 with the master at 0 is also a fixpoint of the
    # states' equations at the instant (data is not q at the same instant); the slave read
    # min(low, q) in its pair's mode of before the edge (= low = 1) and took it: q was
    # 1 0 0 1 1 0 1 0 1 0 1 0. The pairs settle first now, the states then.
    assert choose_stepper("auto", circuitnsds.read_netlist(DIVIDER).mlcs())[0].name == "exact"
    np.testing.assert_array_equal(_sampled(DIVIDER, 12, 0.5e-6), [1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1])


@pytest.mark.parametrize("seed", range(4))
def test_latches_follow_their_reference_state_machines_under_the_exact_integrator(seed):
    # the reference state machines of tests/test_xspice_digital.py (written from ngspice's
    # definitions), on fixed random inputs, run with method=exact
    from tests.test_xspice_digital import reference_dff, reference_srlatch, run_digital

    rng = np.random.default_rng(seed)
    s, r, en, set_, reset = (rng.integers(0, 2, 10).tolist() for _ in range(5))
    parts = "Al ds dr den dset dreset q nq lat\n.model lat d_srlatch\n.options method=exact\n"
    waves, got = run_digital({"s": s, "r": r, "en": en, "set": set_, "reset": reset}, parts, ["q"])
    assert waves.stats["exact_segments"] > 0
    np.testing.assert_array_equal(got["q"], reference_srlatch(s, r, en, set_, reset))
    d, clk = rng.integers(0, 2, 12).tolist(), rng.integers(0, 2, 12).tolist()
    for k in range(1, 12):  # (data and clock change in different slots, as there)
        if d[k] != d[k - 1] and clk[k] != clk[k - 1]:
            d[k] = d[k - 1]
    zeros = [0] * 12
    parts = "Af dd dclk dset dreset q NULL ff\n.model ff d_dff\n.options method=exact\n"
    waves, got = run_digital({"d": d, "clk": clk, "set": zeros, "reset": zeros}, parts, ["q"])
    assert waves.stats["exact_segments"] > 0
    np.testing.assert_array_equal(got["q"], reference_dff(d, clk, zeros, zeros))


def test_an_inverter_follows_its_input_under_the_exact_integrator():
    circuit = circuitnsds.read_netlist(DIVIDER.replace(FLIP_FLOP, "Ai dclk q inv\n.model inv d_inverter"))
    assert choose_stepper("auto", circuit.mlcs())[0].name == "exact"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RunNote)
        waves = circuit.transient(method="exact")
    middle = (np.arange(12) + 0.5) * 0.5e-6
    np.testing.assert_array_equal(np.round(np.interp(middle, waves.time, waves["v(q)"]), 12),
                                  [1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0])
