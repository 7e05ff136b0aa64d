"""Hand-made LCPs: degenerate data, infeasible problems, errors and input handling."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from circuitnsds.solvers import (
    LCPError,
    LCPNoSolution,
    LCPResult,
    LCPSolverFailure,
    lcp_residual,
    solve_lcp,
)
from circuitnsds.solvers.testing import lcp_with_solution, p_matrix, psd_matrix

METHODS = ["auto", "lemke", "enum", "newton"]


def assert_solution(M, q, res: LCPResult, tol=1e-9) -> None:
    z = res.z
    w = M @ z + q
    scale = 1.0 + np.abs(q).max() + np.abs(M).max() * np.abs(z).max()
    assert z.min() >= -tol * scale
    assert w.min() >= -tol * scale
    assert np.abs(z * w).max() <= tol * scale * (1 + np.abs(z).max())
    assert res.residual <= tol
    assert res.z.dtype == np.float64 and res.w.dtype == np.float64
    assert res.active.dtype == bool and res.active.shape == q.shape


@pytest.mark.parametrize("method", METHODS)
def test_q_zero(method: str) -> None:
    M = psd_matrix(5, np.random.default_rng(0), rank=2)
    res = solve_lcp(M, np.zeros(5), method=method)
    np.testing.assert_allclose(res.z, 0.0, atol=1e-14)
    assert_solution(M, np.zeros(5), res)


@pytest.mark.parametrize("method", METHODS)
def test_q_nonnegative_is_trivial(method: str) -> None:
    M = p_matrix(4, np.random.default_rng(1))
    q = np.array([0.0, 1.0, 2.0, 0.0])
    res = solve_lcp(M, q, method=method)
    np.testing.assert_allclose(res.z, 0.0, atol=1e-14)


@pytest.mark.parametrize("method", METHODS)
def test_ties_in_q(method: str) -> None:
    # 2I + ones is positive definite; every ratio of the first pivot ties
    M = 2 * np.eye(4) + np.ones((4, 4))
    q = -np.ones(4)
    res = solve_lcp(M, q, method=method)
    np.testing.assert_allclose(res.z, np.full(4, 1 / 6), atol=1e-12)
    assert_solution(M, q, res)


@pytest.mark.parametrize("method", METHODS)
def test_repeated_columns(method: str) -> None:
    # columns 0 and 1 equal; PSD (symmetric, eigenvalues >= 0); solutions z0 + z1 = 1
    M = np.array([[2.0, 2.0, 1.0], [2.0, 2.0, 1.0], [1.0, 1.0, 3.0]])
    assert np.linalg.eigvalsh(M).min() > -1e-12
    q = np.array([-2.0, -2.0, 1.0])
    res = solve_lcp(M, q, method=method)
    assert_solution(M, q, res)
    assert res.z[0] + res.z[1] == pytest.approx(1.0, abs=1e-9)
    assert res.z[2] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("method", METHODS)
def test_zero_diagonal_skew(method: str) -> None:
    M = np.array([[0.0, 1.0], [-1.0, 0.0]])  # skew: PSD with zero diagonal
    q = np.array([-1.0, 1.0])
    res = solve_lcp(M, q, method=method)
    assert_solution(M, q, res)
    assert res.z[1] == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("method", METHODS)
def test_zero_diagonal_entries_mixed(method: str) -> None:
    M = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 1.0], [0.0, -1.0, 1.0]])
    q = np.array([-1.0, 0.5, -0.5])
    res = solve_lcp(M, q, method=method)
    assert_solution(M, q, res)


@pytest.mark.parametrize("method", METHODS)
def test_singular_psd_non_unique(method: str) -> None:
    # the two pairs of an ideal Zener at Vz = 0: any z with z0 - z1 = 1 solves
    M = np.array([[1.0, -1.0], [-1.0, 1.0]])
    q = np.array([-1.0, 1.0])
    res = solve_lcp(M, q, method=method)
    assert_solution(M, q, res)
    assert res.z[0] - res.z[1] == pytest.approx(1.0, abs=1e-9)


def test_degenerate_random_psd_all_methods_agree_on_w() -> None:
    # for symmetric PSD M, w (and M z) is the same for every solution
    rng = np.random.default_rng(5)
    for _ in range(10):
        G = rng.standard_normal((8, 3))
        M = G @ G.T
        q, _, _ = lcp_with_solution(M, rng, degenerate=0.5)
        ws = [solve_lcp(M, q, method=m).w for m in METHODS]
        for w in ws[1:]:
            np.testing.assert_allclose(w, ws[0], atol=1e-8)


@pytest.mark.parametrize("method", ["auto", "lemke", "enum"])
def test_infeasible_one_dimensional(method: str) -> None:
    with pytest.raises(LCPNoSolution) as info:
        solve_lcp(np.array([[-1.0]]), np.array([-1.0]), method=method)
    err = info.value
    assert isinstance(err, LCPError)
    assert err.size == {"n": 1}
    assert "n=1" in str(err)
    if method != "enum":
        assert err.pivots >= 1
        assert err.ray_z.shape == (1,)
        assert "ray" in str(err)


def test_infeasible_newton_is_a_solver_failure() -> None:
    with pytest.raises(LCPSolverFailure) as info:
        solve_lcp(np.array([[-1.0]]), np.array([-1.0]), method="newton")
    assert info.value.residual > 1e-9
    assert "newton" in str(info.value)


def test_infeasible_psd_ray_is_evidence() -> None:
    # w0 + w1 = -2 for every z: infeasible, M PSD so Lemke's ray is a proof
    M = np.array([[1.0, -1.0], [-1.0, 1.0]])
    q = np.array([-1.0, -1.0])
    with pytest.raises(LCPNoSolution) as info:
        solve_lcp(M, q, method="lemke")
    err = info.value
    # along the ray (z, z0) -> + t (ray_z, ray_z0): w changes by M ray_z + ray_z0 (d = ones)
    np.testing.assert_allclose(err.ray_w, M @ err.ray_z + err.ray_z0, atol=1e-12)
    assert np.all(err.ray_z >= -1e-12) and err.ray_z.max() > 0


def test_large_infeasible_auto_no_enumeration() -> None:
    n = 15
    M = np.eye(n)
    M[:2, :2] = [[1.0, -1.0], [-1.0, 1.0]]
    q = np.ones(n)
    q[:2] = -1.0
    with pytest.raises(LCPNoSolution) as info:
        solve_lcp(M, q)
    assert info.value.confirmed_by_enumeration is False


def test_small_infeasible_auto_confirms_by_enumeration() -> None:
    with pytest.raises(LCPNoSolution) as info:
        solve_lcp(np.array([[1.0, -1.0], [-1.0, 1.0]]), np.array([-1.0, -1.0]))
    assert info.value.confirmed_by_enumeration is True


def test_pivot_limit() -> None:
    rng = np.random.default_rng(3)
    M = p_matrix(30, rng)
    q, _, _ = lcp_with_solution(M, rng, frac_active=0.9)
    with pytest.raises(LCPSolverFailure) as info:
        solve_lcp(M, q, method="lemke", max_pivots=2)
    assert info.value.reason == "pivot limit"
    assert info.value.pivots == 2
    assert "pivot limit" in str(info.value)


def test_residual_detects_wrong_answers() -> None:
    rng = np.random.default_rng(4)
    M = p_matrix(10, rng)
    q, z_star, active = lcp_with_solution(M, rng)
    assert lcp_residual(M, q, z_star)[0] <= 1e-14
    bad = z_star.copy()
    bad[np.flatnonzero(active)[0]] *= 1.001  # equation no longer holds
    assert lcp_residual(M, q, bad)[0] > 1e-6
    bad = z_star.copy()
    bad[np.flatnonzero(~active)[0]] = 1e-3  # both z and w positive
    assert lcp_residual(M, q, bad)[0] > 1e-6
    bad = -np.abs(z_star)  # negative z
    assert lcp_residual(M, q, bad)[0] > 1e-3


def test_residual_is_scale_invariant() -> None:
    rng = np.random.default_rng(6)
    M = p_matrix(8, rng)
    q, z, _ = lcp_with_solution(M, rng)
    z_bad = z + 1e-4
    r1 = lcp_residual(M, q, z_bad)[0]
    r2 = lcp_residual(1e6 * M, 1e3 * q, 1e-3 * z_bad)[0]
    assert r1 == pytest.approx(r2, rel=1e-9)


@pytest.mark.parametrize("method", METHODS)
def test_sparse_matrix_same_answer(method: str) -> None:
    rng = np.random.default_rng(8)
    M = p_matrix(9, rng, "diagdom")
    M[np.abs(M) < 0.5] = 0.0
    M += np.diag(np.abs(M).sum(axis=1))  # keep it a P-matrix after sparsifying
    q, z_star, _ = lcp_with_solution(M, rng)
    for fmt in (sp.csr_array, sp.csc_matrix):
        res = solve_lcp(fmt(M), q, method=method)
        np.testing.assert_allclose(res.z, z_star, atol=1e-10)
        assert isinstance(res.z, np.ndarray) and res.z.shape == (9,)


def test_badly_scaled_problem() -> None:
    rng = np.random.default_rng(9)
    n = 40
    M = psd_matrix(n, rng, rank=20)
    d = np.exp(rng.uniform(-6, 6, n))
    M = d[:, None] * M * d[None, :]
    q, _, _ = lcp_with_solution(M, rng, degenerate=0.3)
    q *= 1e5
    for method in ["auto", "lemke", "newton"]:
        assert_solution(M, q, solve_lcp(M, q, method=method))


def test_input_validation() -> None:
    M = np.eye(2)
    with pytest.raises(ValueError):
        solve_lcp(M, [1.0, 2.0, 3.0])
    with pytest.raises(ValueError):
        solve_lcp(M, [np.nan, 1.0])
    with pytest.raises(ValueError):
        solve_lcp(M, [1.0, 1.0], method="simplex")
    with pytest.raises(ValueError):
        solve_lcp(np.eye(13), -np.ones(13), method="enum")
    with pytest.raises(ValueError):
        solve_lcp(M, [1.0, 1.0], guess=[True])
    res = solve_lcp([[2.0]], [-4.0])  # lists accepted
    assert res.z[0] == pytest.approx(2.0)


def test_empty_problem() -> None:
    for method in ["auto", "lemke", "enum", "newton"]:
        res = solve_lcp(np.zeros((0, 0)), np.zeros(0), method=method)
        assert res.z.shape == (0,)
