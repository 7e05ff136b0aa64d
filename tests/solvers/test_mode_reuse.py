"""Mode reuse ("direct"): cached factorisations, right and wrong guesses, statistics."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from circuitnsds.solvers import LCPSolverFailure, MLCPSolver, solve_lcp, solve_mlcp
from circuitnsds.solvers.testing import lcp_with_solution, p_matrix, psd_matrix

EMPTY = np.zeros(0)


def lcp_solver(M: np.ndarray, **kw) -> MLCPSolver:
    n = M.shape[0]
    return MLCPSolver(np.zeros((0, 0)), np.zeros((0, n)), np.zeros((n, 0)), M, **kw)


def test_right_guess_is_a_direct_solve_without_pivots() -> None:
    rng = np.random.default_rng(0)
    M = p_matrix(20, rng)
    q, z_star, active = lcp_with_solution(M, rng)
    ref = solve_lcp(M, q, method="lemke")
    assert ref.iterations > 0
    res = solve_lcp(M, q, guess=active)
    assert res.method == "direct"
    assert res.iterations == 0
    np.testing.assert_allclose(res.z, ref.z, atol=1e-12)
    np.testing.assert_array_equal(res.active, active)
    # index-array guesses are accepted too
    res = solve_lcp(M, q, guess=np.flatnonzero(active))
    assert res.method == "direct"
    np.testing.assert_allclose(res.z, z_star, atol=1e-10)


def test_wrong_guess_falls_back_to_lemke_and_is_right() -> None:
    rng = np.random.default_rng(1)
    M = p_matrix(15, rng)
    q, z_star, active = lcp_with_solution(M, rng)
    wrong = active.copy()
    wrong[:3] = ~wrong[:3]
    res = solve_lcp(M, q, guess=wrong)
    assert res.method == "direct->lemke"
    assert res.iterations > 0
    np.testing.assert_allclose(res.z, z_star, atol=1e-10)
    np.testing.assert_array_equal(res.active, active)


def test_method_direct_rejects_a_wrong_guess() -> None:
    rng = np.random.default_rng(2)
    M = p_matrix(6, rng)
    q, _, active = lcp_with_solution(M, rng, frac_active=0.5)
    with pytest.raises(LCPSolverFailure) as info:
        solve_lcp(M, q, method="direct", guess=~active)
    assert info.value.reason == "guess rejected"
    assert "not a solution" in str(info.value)
    with pytest.raises(ValueError):
        solve_lcp(M, q, method="direct")


def test_direct_rejects_a_singular_mode() -> None:
    M = np.array([[1.0, 1.0], [1.0, 1.0]])
    q = np.array([-1.0, -1.0])
    with pytest.raises(LCPSolverFailure) as info:
        solve_lcp(M, q, method="direct", guess=[0, 1])
    assert info.value.reason == "singular mode"
    res = solve_lcp(M, q, guess=[0, 1])  # auto falls back and finds z1 + z2 = 1
    assert res.z.sum() == pytest.approx(1.0)


def test_repeated_solves_hit_the_cache() -> None:
    rng = np.random.default_rng(3)
    M = psd_matrix(12, rng)
    q, _, _ = lcp_with_solution(M, rng)
    solver = lcp_solver(M)
    first = solver.solve(EMPTY, q)
    assert first.method == "lemke"
    fact = solver.stats["factorisations"]
    for k in range(5):
        res = solver.solve(EMPTY, q * (1 + 0.01 * k), guess=first.active)
        assert res.method == "direct"
        assert res.iterations == 0
    assert solver.stats["factorisations"] == fact  # no new factorisation
    assert solver.stats["cache_hits"] >= 5
    assert solver.stats["direct_accepted"] == 5
    assert solver.stats["lemke_fallbacks"] == 1


def test_lru_eviction() -> None:
    rng = np.random.default_rng(4)
    M = p_matrix(5, rng)
    solver = lcp_solver(M, cache_size=2)
    qs = [lcp_with_solution(M, np.random.default_rng(s), frac_active=0.5) for s in range(6)]
    masks = {q[2].tobytes() for q in qs}
    assert len(masks) >= 3
    for q, z_star, active in qs:
        res = solver.solve(EMPTY, q, guess=active)
        np.testing.assert_allclose(res.z, z_star, atol=1e-10)
    assert solver.stats["evictions"] >= 1
    assert solver.stats["factorisations"] - solver.stats["evictions"] <= 2


def sine_bridge(Ron=0.05, Vf=0.6, R=20.0, Cap=1e-3, h=1e-4, gmin=0.0):
    """Bridge rectifier with an RC load, implicit Euler: fixed matrices, new a, b each step.

    u = [va, vb, vp, iV]; the capacitor adds Cap/h to node p and Cap/h * vp_old to a.
    """
    Dv = np.array([[1, 0, -1, 0], [0, 1, -1, 0], [-1, 0, 0, 0], [0, -1, 0, 0]], dtype=float)
    C = np.array([[1, 0, -1, 0], [0, 1, 0, -1], [-1, -1, 0, 0], [0, 0, 0, 0]], dtype=float)
    A = np.array(
        [[0, 0, 0, 1], [0, 0, 0, -1], [0, 0, 1 / R + Cap / h, 0], [1, -1, 0, 0]], dtype=float
    )
    A = A + gmin * (C @ Dv)
    return A, C, -Dv, Ron * np.eye(4), Vf * np.ones(4), Cap / h


@pytest.mark.parametrize("gmin", [0.0, 1e-12])
def test_time_stepping_loop_mostly_hits_the_cache(gmin: float) -> None:
    A, C, D, B, b, c_over_h = sine_bridge(gmin=gmin)
    solver = MLCPSolver(sp.csr_array(A), C, D, B)
    vp = 0.0
    guess = None
    methods = []
    for k in range(400):
        t = k * 1e-4
        Vs = 10 * np.sin(2 * np.pi * 50 * t)
        a = np.array([0.0, 0.0, -c_over_h * vp, -Vs])
        res = solver.solve(a, b, guess=guess)
        ref = solve_mlcp(A, C, D, B, a, b, method="enum")
        np.testing.assert_allclose(res.z, ref.z, atol=1e-9)
        np.testing.assert_allclose(res.u[2], ref.u[2], atol=1e-9)
        methods.append(res.method)
        guess = res.active
        vp = res.u[2]
    direct = methods.count("direct")
    assert direct >= 350, methods
    # every miss is a switching instant, handled by a fallback
    assert solver.stats["lemke_fallbacks"] == len(methods) - direct
    assert solver.stats["direct_accepted"] == direct
    assert solver.stats["cache_hits"] >= direct
    assert solver.stats["start_bases"] == 1  # the Lemke start basis is built once
    assert 0.5 < vp < 10.0  # the filter capacitor is charged
