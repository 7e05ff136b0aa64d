"""Large circuits: sparse step maps (compiled), block principal pivoting at mode changes.

A ladder of diode-RC sections has more than 64 unknowns and pairs, so its modes are
stepped with sparse LUs, and with 50 pairs or more the MLCP solver finds its mode
changes by pivoting from the previous active set. Every path must give the same
waveforms as one Lemke-solved MLCP per step.
"""

from __future__ import annotations

import numpy as np
import pytest

import circuitnsds
import circuitnsds.engine.integrate
import circuitnsds.solvers.mlcp


def ladder(sections: int, stop: float) -> str:
    """N diode-RC sections from a 10 V source with a 1 V, 1 kHz ripple: the diodes block
    together while the source falls faster than the capacitors discharge."""
    lines = [f"Ladder of {sections} diode-RC sections", "V1 n0 0 SIN(10 1 1k)"]
    for k in range(1, sections + 1):
        lines += [f"D{k} n{k - 1} n{k} dl", f"R{k} n{k} 0 {1e3 * sections!r}", f"C{k} n{k} 0 1u"]
    lines += [".model dl D(Ron=1)", f".tran 10u {stop!r}", ".end"]
    return "\n".join(lines) + "\n"


def test_ladder_paths_agree_with_one_lemke_mlcp_per_step(monkeypatch):
    circuit = circuitnsds.read_netlist(ladder(60, 3e-3))
    fast = circuit.transient(method="theta")  # (θ's three stepping paths and counters: pinned)
    stats = fast.stats
    assert circuit.mlcs().n + circuit.mlcs().m > circuitnsds.engine.integrate.DENSE_MAP_LIMIT  # sparse maps
    assert stats["mlcp_steps"] >= 3  # the diodes block and conduct again: mode changes
    assert stats["pivoting_solves"] >= 2  # found by pivoting, not Lemke
    assert stats["mapped_steps"] > 0.9 * stats["steps"]
    numpy_loop = circuit.transient(stepping="numpy", method="theta")
    with monkeypatch.context() as patch:  # no maps, no pivoting: Lemke for every step
        patch.setattr(circuitnsds.solvers.mlcp, "PIVOTING_MIN_PAIRS", 10**9)
        lemke = circuit.transient(stepping="mlcp", method="theta")
    assert lemke.stats["mlcp_steps"] == lemke.stats["steps"]
    for other in (numpy_loop, lemke):
        for name in ("v(n1)", "v(n30)", "v(n60)", "i(d1)", "i(d60)"):
            scale = np.abs(fast[name]).max()
            np.testing.assert_allclose(other[name], fast[name], rtol=0, atol=1e-9 * scale, err_msg=name)


@pytest.mark.parametrize("sections", [120, 200])  # 200: past SPARSE_MIN, a sparse LU per trial
def test_ladder_operating_point_by_pivoting_matches_lemke(monkeypatch, sections):
    """At DC every diode of the ladder conducts: pivoting from 'none conducts' reaches that
    set (the front moves tens of pairs per trial) and must agree with Lemke."""
    circuit = circuitnsds.read_netlist(ladder(sections, 1e-3))
    pivoted = circuit.operating_point()
    with monkeypatch.context() as patch:
        patch.setattr(circuitnsds.solvers.mlcp, "PIVOTING_MIN_PAIRS", 10**9)
        reference = circuit.operating_point()
    for name, value in reference.items():
        assert abs(pivoted[name] - value) <= 1e-9 * max(1.0, abs(value)), name
    # every diode conducting (Vfwd = 0, Ron = 1 Ω) makes the ladder a resistive network:
    # (v_{k-1} - v_k)/Ron = v_k/R + (v_k - v_{k+1})/Ron, solved here independently
    ron, r = 1.0, 1e3 * sections
    G = np.zeros((sections, sections))
    rhs = np.zeros(sections)
    for k in range(sections):
        G[k, k] = 1 / ron + 1 / r + (1 / ron if k + 1 < sections else 0.0)
        if k > 0:
            G[k, k - 1] = -1 / ron
        if k + 1 < sections:
            G[k, k + 1] = -1 / ron
    rhs[0] = 10.0 / ron
    expected = np.linalg.solve(G, rhs)
    got = np.array([pivoted[f"v(n{k})"] for k in range(1, sections + 1)])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)


def test_large_problems_stay_sparse_and_agree_with_the_dense_solver(monkeypatch):
    """Above DENSE_LIMIT unknowns + pairs the MLCP solver never builds a dense K (a 50,000-node
    circuit would need 20 GB per copy): pivoting with sparse LUs, no Lemke beyond
    SPARSE_LEMKE_MAX pairs. Lowered here so that a small ladder takes that path."""
    text = ladder(120, 1e-3)
    dense = circuitnsds.read_netlist(text)
    reference_op, reference = dense.operating_point(), dense.transient()
    built = []
    original = circuitnsds.solvers.mlcp.MLCPSolver.__init__

    def recording(self, *args, **kwargs):
        original(self, *args, **kwargs)
        built.append(self)

    monkeypatch.setattr(circuitnsds.solvers.mlcp, "DENSE_LIMIT", 100)
    monkeypatch.setattr(circuitnsds.solvers.mlcp, "SPARSE_LEMKE_MAX", 10)
    monkeypatch.setattr(circuitnsds.solvers.mlcp.MLCPSolver, "__init__", recording)
    sparse = circuitnsds.read_netlist(text)
    op, waves = sparse.operating_point(), sparse.transient()
    assert built and all(solver.sparse_only and not isinstance(solver._K, np.ndarray) for solver in built)
    assert all(solver.stats["lemke_fallbacks"] == 0 for solver in built)
    for name in ("v(n1)", "v(n60)", "v(n120)", "i(d1)", "i(d120)"):
        assert op[name] == pytest.approx(reference_op[name], rel=1e-9, abs=1e-12)
        scale = np.abs(reference[name]).max()
        np.testing.assert_allclose(waves[name], reference[name], rtol=0, atol=1e-9 * scale, err_msg=name)
