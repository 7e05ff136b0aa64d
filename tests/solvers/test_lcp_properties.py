"""Property tests: every LCP method solves random P-matrix and PSD problems.

The checks here are written independently of the package's own residual: a
solution must satisfy z >= 0, w = M z + q >= 0 and z_i w_i = 0 up to a small
tolerance relative to the problem's scale.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from circuitnsds.solvers import LCPNoSolution, lcp_residual, solve_lcp
from circuitnsds.solvers.testing import lcp_with_solution, p_matrix, psd_matrix

SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def assert_solves(M: np.ndarray, q: np.ndarray, z: np.ndarray, tol: float = 1e-9) -> None:
    """Independent check of complementarity, scaled by the size of the data and of z."""
    assert z.shape == q.shape and np.all(np.isfinite(z))
    w = M @ z + q
    scale = np.abs(q).max() + np.abs(M).sum(axis=1).max() * np.abs(z).max() + 1e-300
    zs = np.abs(M).sum(axis=1).max()
    assert z.min() * zs >= -10 * tol * scale, f"z negative: {z.min()}"
    assert w.min() >= -10 * tol * scale, f"w negative: {w.min()}"
    assert np.max(np.minimum(np.abs(z) * zs, np.abs(w))) <= 10 * tol * scale, "not complementary"


P_KINDS = st.sampled_from(["pd", "diagdom", "triangular"])
METHODS = ["lemke", "newton", "auto"]


@SETTINGS
@given(n=st.integers(1, 60), seed=st.integers(0, 2**32 - 1), kind=P_KINDS, frac=st.floats(0.0, 1.0))
def test_p_matrix_all_methods_find_the_unique_solution(
    n: int, seed: int, kind: str, frac: float
) -> None:
    rng = np.random.default_rng(seed)
    M = p_matrix(n, rng, kind)
    q, z_star, _ = lcp_with_solution(M, rng, frac_active=frac)
    for method in METHODS + (["enum"] if n <= 10 else []):
        res = solve_lcp(M, q, method=method)
        assert res.residual <= 1e-9, method
        assert_solves(M, q, res.z)
        # P-matrix: the solution is unique, so every method must find z_star
        np.testing.assert_allclose(
            res.z, z_star, atol=1e-7 * (1 + np.abs(z_star).max()), err_msg=method
        )
        # the reported residual is the package's definition, recomputed here
        assert lcp_residual(M, q, res.z)[0] == pytest.approx(res.residual, abs=1e-15)
        np.testing.assert_allclose(res.w, M @ res.z + q, atol=1e-12 * (1 + np.abs(q).max()))


@SETTINGS
@given(n=st.integers(1, 10), seed=st.integers(0, 2**32 - 1), kind=P_KINDS)
def test_p_matrix_enumeration_and_lemke_agree_for_random_q(n: int, seed: int, kind: str) -> None:
    rng = np.random.default_rng(seed)
    M = p_matrix(n, rng, kind)
    q = rng.standard_normal(n) * rng.choice([1e-3, 1.0, 1e3])
    a = solve_lcp(M, q, method="enum")
    b = solve_lcp(M, q, method="lemke")
    np.testing.assert_allclose(a.z, b.z, atol=1e-8 * (1 + np.abs(a.z).max()))
    assert_solves(M, q, b.z)


@SETTINGS
@given(
    n=st.integers(1, 60),
    seed=st.integers(0, 2**32 - 1),
    rank_frac=st.floats(0.1, 1.0),
    degenerate=st.sampled_from([0.0, 0.3]),
)
def test_psd_all_methods_solve_feasible_problems(
    n: int, seed: int, rank_frac: float, degenerate: float
) -> None:
    rng = np.random.default_rng(seed)
    M = psd_matrix(n, rng, rank=max(1, int(rank_frac * n)))
    q, _, _ = lcp_with_solution(M, rng, degenerate=degenerate)
    for method in METHODS + (["enum"] if n <= 10 else []):
        res = solve_lcp(M, q, method=method)
        assert res.residual <= 1e-9, method
        assert_solves(M, q, res.z)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 6), seed=st.integers(0, 2**32 - 1))
def test_integer_psd_lemke_solves_exactly_when_enumeration_does(n: int, seed: int) -> None:
    """Small integer data: many ties and degenerate bases, and infeasible instances.

    For copositive-plus (here PSD) M, Lemke either solves or proves infeasibility,
    so it must agree with exhaustive enumeration on whether a solution exists.
    """
    rng = np.random.default_rng(seed)
    G = rng.integers(-2, 3, size=(n, max(1, n - 1)))
    S = np.triu(rng.integers(-2, 3, size=(n, n)), 1)
    M = (G @ G.T + S - S.T).astype(float)
    q = rng.integers(-3, 4, size=n).astype(float)
    try:
        ref = solve_lcp(M, q, method="enum")
    except LCPNoSolution:
        ref = None
    if ref is None:
        with pytest.raises(LCPNoSolution):
            solve_lcp(M, q, method="lemke")
    else:
        res = solve_lcp(M, q, method="lemke")
        assert_solves(M, q, res.z)
        res = solve_lcp(M, q)
        assert_solves(M, q, res.z)
