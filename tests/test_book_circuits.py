"""Qualitative facts of the circuits of Acary & Brogliato, ch. 1 (the book of docs/theory.md)."""

import numpy as np

import circuitnsds
from tests.conftest import NETLISTS


def stored_energy(waves, caps, inductors):
    energy = np.zeros_like(waves.time)
    for (a, b), c in caps:
        v = waves[f"v({a})"] - (waves[f"v({b})"] if b != "0" else 0)
        energy += 0.5 * c * v**2
    for name, inductance in inductors:
        energy += 0.5 * inductance * waves[f"i({name})"] ** 2
    return energy


C_BOOK = 1 / (2 * np.pi) ** 2


def test_circuit_c_current_never_positive_and_charge_frozen_after_blocking():
    waves = circuitnsds.read_netlist(NETLISTS / "book_fig1_3c.cir").transient()
    current = waves["i(l1)"]
    assert current.max() <= 1e-9
    assert current.min() < -1.0  # it did conduct
    # once the current is back to zero the diode blocks for good: capacitor voltage frozen
    blocked = np.flatnonzero(np.abs(current) < 1e-9)  # Roff leakage: 1e-12 S x 30 V
    start = blocked[blocked > 10][0]
    frozen = waves["v(n3)"][start:]
    # only the Roff leakage (1e-12 S x 30 V for 1.5 s into C = 0.0253 F: 1.8e-9 V) moves it
    assert np.ptp(frozen) < 3e-9
    assert frozen[0] < 0  # the half-swing reversed the capacitor


def test_source_free_circuits_never_gain_energy():
    for name, caps, inductors in [
        ("book_fig1_3c.cir", [(("n3", "0"), C_BOOK)], [("l1", 1.0)]),
        ("book_zener_rlc.cir", [(("n3", "0"), C_BOOK)], [("l1", 1.0)]),
        ("book_fig1_3d.cir", [(("n1", "0"), C_BOOK)], [("l1", 1.0)]),
        ("book_fig1_3b.cir", [(("n1", "0"), C_BOOK)], [("l1", 1.0)]),
    ]:
        # θ's implicit Euler never raises the stored energy (the exact integrator raises a
        # lossless LC's by the round-off of its eigenvalues, 1e-10 of it): pinned to θ
        waves = circuitnsds.read_netlist(NETLISTS / name).transient(method="theta")
        energy = stored_energy(waves, caps, inductors)
        assert np.all(np.diff(energy) <= 1e-12 * energy[0]), name
        assert energy[-1] < energy[0], name


def test_zener_rlc_ends_sliding_inside_the_band():
    waves = circuitnsds.read_netlist(NETLISTS / "book_zener_rlc.cir").transient()
    current, v_cap, v_zener = waves["i(l1)"], waves["v(n3)"], waves["v(n1)"]
    sliding = waves.time > 2.0
    assert np.all(np.abs(current[sliding]) < 1e-9)
    assert 0.0 <= v_cap[sliding].min() and v_cap[sliding].max() <= 10.0
    assert np.ptp(v_cap[sliding]) < 1e-9
    # while sliding, the Zener holds the capacitor voltage: v = x1/C inside [0, Vz]
    np.testing.assert_allclose(v_zener[sliding], v_cap[sliding], atol=1e-9)
    # before sliding, the reverse half-waves saw exactly Vz across the Zener
    reverse = current < -1e-6
    np.testing.assert_allclose(v_zener[reverse], 10.0, atol=1e-9)
