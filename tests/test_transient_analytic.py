"""Transient results against closed-form solutions (continuous and discrete)."""

import math

import numpy as np
import pytest

from tests.conftest import circuit_from


def test_rc_discharge_matches_implicit_euler_exactly_and_the_exponential():
    R, C, h = 1e3, 1e-6, 1e-5
    waves = circuit_from(f"C1 a 0 {C} ic=1\nR1 a 0 {R}\n.tran {h} 5m uic").transient(method="theta")  # (θ's)
    v = waves["v(a)"]
    k = np.arange(v.size)
    np.testing.assert_allclose(v, (1 / (1 + h / (R * C))) ** k, rtol=1e-12)
    # first-order accurate: error at 5 ms below h/(2RC) * max|v| * t/RC e^{-t/RC}-ish
    assert np.max(np.abs(v - np.exp(-waves.time / (R * C)))) < h / (R * C)


def test_rl_step_response():
    R, L, V, h = 10.0, 1e-2, 5.0, 1e-5
    # (implicit Euler's recurrence: pinned to θ)
    waves = circuit_from(f"V1 a 0 {V}\nR1 a b {R}\nL1 b 0 {L}\n.tran {h} 5m uic").transient(method="theta")
    i = waves["i(l1)"]
    expected = V / R * (1 - np.exp(-waves.time * R / L))
    assert np.max(np.abs(i - expected)) < 0.01 * V / R
    discrete = np.zeros_like(i)
    for k in range(1, i.size):
        discrete[k] = (discrete[k - 1] + h * V / L) / (1 + h * R / L)
    np.testing.assert_allclose(i, discrete, rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize(("theta", "tolerance"), [(1.0, 0.05), (0.5, 2e-4)])
def test_series_rlc_ringdown(theta, tolerance):
    R, L, C = 1.0, 1e-3, 1e-6
    h = 2e-7
    waves = circuit_from(f"C1 a 0 {C} ic=1\nL1 a b {L}\nR1 b 0 {R}\n.tran {h} 0.5m uic"
                         ).transient(theta=theta)
    alpha, w0 = R / (2 * L), 1 / math.sqrt(L * C)
    wd = math.sqrt(w0**2 - alpha**2)
    t = waves.time
    v = np.exp(-alpha * t) * (np.cos(wd * t) + alpha / wd * np.sin(wd * t))
    assert np.max(np.abs(waves["v(a)"] - v)) < tolerance


def test_half_wave_rectifier_into_resistor(netlists):
    import circuitnsds

    waves = circuitnsds.read_netlist(netlists / "half_wave_rectifier.cir").transient()
    v_in = 10 * np.sin(2 * np.pi * 50 * waves.time)
    np.testing.assert_allclose(waves["v(out)"], np.maximum(v_in, 0), atol=1e-7)
    np.testing.assert_allclose(waves["i(d1)"], waves["v(out)"] / 1e3, atol=1e-9)


def test_zener_shunt_regulator_clamps_at_breakdown(netlists):
    import circuitnsds

    waves = circuitnsds.read_netlist(netlists / "zener_regulator.cir").transient()
    v_in = 20 * waves.time / 10e-3
    expected = np.minimum(v_in * 1e3 / 1.1e3, 5.1)
    np.testing.assert_allclose(waves["v(out)"], expected, atol=1e-6)
    # in breakdown the Zener current is negative (cathode to anode is node out -> 0 here)
    breakdown = expected >= 5.1
    zener = waves["i(dz1)"]
    np.testing.assert_allclose(zener[breakdown],
                               -((v_in[breakdown] - 5.1) / 100 - 5.1 / 1e3), atol=1e-6)


def test_diode_clamp(netlists):
    import circuitnsds

    waves = circuitnsds.read_netlist(netlists / "diode_clamp.cir").transient()
    v_in = 5 * np.sin(2 * np.pi * 1e3 * waves.time)
    np.testing.assert_allclose(waves["v(out)"], np.minimum(v_in, 2.0), atol=1e-6)


def test_operating_point_of_a_zener_regulator_and_held_ic():
    circuit = circuit_from("V1 in 0 12\nRs in out 100\nDZ 0 out z\nRl out 0 1k\n"
                           ".model z D(BV=5.1)\n.tran 1u 10u")
    op = circuit.operating_point()
    assert op["v(out)"] == pytest.approx(5.1, abs=1e-9)
    assert op["i(dz)"] == pytest.approx(-(6.9 / 100 - 5.1 / 1e3), abs=1e-9)
    held = circuit_from("V1 in 0 10\nR1 in out 1k\nC1 out 0 1u\n.ic v(out)=3\n.tran 1u 10u")
    waves = held.transient()
    assert waves["v(out)"][0] == pytest.approx(3.0)
    assert waves["v(out)"][1] > 3.0


def test_uic_uses_element_and_node_initial_conditions():
    circuit = circuit_from("C1 a b 1u ic=2\nR1 a 0 1k\nR2 b 0 1k\n.ic v(b)=1\n.tran 1n 2n uic")
    waves = circuit.transient()
    assert waves["v(a)"][0] == pytest.approx(3.0) and waves["v(b)"][0] == pytest.approx(1.0)
    # after one tiny step the capacitor voltage is still 2 V and split over the resistors
    assert waves["v(a)"][1] - waves["v(b)"][1] == pytest.approx(2.0, rel=1e-3)
    assert waves["v(a)"][1] == pytest.approx(1.0, rel=1e-3)


def test_ic_without_uic_warns():
    import circuitnsds

    circuit = circuit_from("V1 a 0 1\nR1 a b 1\nC1 b 0 1u ic=3\n.tran 1u 5u")
    with pytest.warns(circuitnsds.NetlistWarning, match="ic=3 is ignored without UIC"):
        waves = circuit.transient()
    assert waves["v(b)"][0] == pytest.approx(1.0)
