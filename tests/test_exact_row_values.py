"""What the exact integrator reports on its rows (issue 31, its wrong answers with exit 0):
a capacitor's current at a row is ``C dv/dt`` at the row's instant, as every other current
there, so Kirchhoff's current law holds on every row (it was ΔQ/Δt over the interval before
the row: a switched RC off by 0.045 A where the currents are 0.034 A)."""

from __future__ import annotations

import math

import numpy as np

import circuitnsds
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
