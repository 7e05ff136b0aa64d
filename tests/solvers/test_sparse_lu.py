"""SparseLU (large bordered systems) against the dense LU it stands in for."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.solvers.linalg import factorise, factorise_sparse


def _sparse_matrix(rng: np.random.Generator, size: int, density: float, dominance: float) -> np.ndarray:
    K = sp.random(size, size, density=density, random_state=rng, data_rvs=rng.standard_normal).toarray()
    return K + np.diag(dominance * (np.abs(K).sum(axis=1) + 1.0) * rng.choice([-1.0, 1.0], size))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), size=st.integers(1, 80), density=st.floats(0.0, 0.2),
       dominance=st.floats(0.01, 2.0))
def test_solves_and_condition_estimate_match_the_dense_lu(seed, size, density, dominance):
    rng = np.random.default_rng(seed)
    K = _sparse_matrix(rng, size, density, dominance)
    dense, sparse = factorise(K), factorise_sparse(sp.csr_matrix(K))
    b = rng.standard_normal((size, 3))
    x = sparse.solve(b)
    # normwise backward stable: a residual at rounding level of ‖K‖‖x‖ + ‖b‖ ...
    norm_K = np.abs(K).sum(axis=1).max()
    for j in range(3):
        residual = np.abs(K @ x[:, j] - b[:, j]).max()
        assert residual <= 1e-11 * (norm_K * np.abs(x[:, j]).max() + np.abs(b[:, j]).max())
    # ... and the dense LU's answer to within the forward error bound ~cond(K)·eps·‖x‖ (the
    # two factorisations pivot differently; the generator makes some K nearly singular)
    reference = dense.solve(b)
    bound = 1e-13 / max(dense.rcond, 1e-300)
    np.testing.assert_allclose(x, reference, rtol=0, atol=max(bound, 1e-12) * np.abs(reference).max())
    np.testing.assert_allclose(sparse.solve(b[:, 0]), x[:, 0], rtol=0, atol=1e-12 * np.abs(x).max())
    # both are 1-norm estimates of the same quantity: within a factor of 10 of each other
    assert dense.rcond / 10 <= sparse.rcond <= dense.rcond * 10
    assert sparse.ok == dense.ok or min(sparse.rcond, dense.rcond) < 1e-13


def test_singular_and_non_finite_matrices_are_not_ok():
    K = np.eye(4)
    K[2, 2] = 0.0
    assert not factorise_sparse(sp.csr_matrix(K)).ok
    K = np.eye(4)
    K[1, 1] = np.inf
    assert not factorise_sparse(sp.csr_matrix(K)).ok
    K = np.eye(4)
    K[3] = K[0]  # two equal rows, structurally non-zero
    K[3, 3] = 0.0
    assert not factorise_sparse(sp.csr_matrix(K)).ok


def test_condition_estimate_is_deterministic_and_leaves_numpy_random_alone():
    rng = np.random.default_rng(11)
    K = sp.csr_matrix(_sparse_matrix(rng, 60, 0.05, 0.3))
    np.random.seed(5)
    before = np.random.get_state()[1].copy()
    estimates = {factorise_sparse(K).rcond for _ in range(3)}
    assert len(estimates) == 1
    np.testing.assert_array_equal(np.random.get_state()[1], before)
