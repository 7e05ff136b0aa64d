"""The pencil eigen-solver of the exact integrator's modes (circuitnsds/solvers/pencil.py),
which calls LAPACK's dggev without importing scipy.linalg: every finite eigenpair satisfies
``A v = λ B v`` to round-off, the eigenvalues are scipy.linalg.eig's, and a process that
builds an exact mode does not import scipy.linalg."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.solvers.pencil import _flapack, pencil_eigen


def _pencils(seed: int, size: int, singular: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((size, size))
    B = rng.standard_normal((size, size))
    B[:, :singular] = 0.0  # (a DAE's pencil: B = diag(E, 0) has zero columns: infinite eigenvalues)
    return A, B


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 9), st.integers(0, 3))
def test_eigenpairs_satisfy_the_pencil(seed, size, singular):
    A, B = _pencils(seed, size, min(singular, size - 1))
    alpha, beta, vectors = pencil_eigen(A, B)
    assert alpha.shape == beta.shape == (size,) and vectors.shape == (size, size)
    for j in range(size):
        v = vectors[:, j]
        # the homogeneous form β A v = α B v holds for finite and infinite eigenvalues alike
        residual = np.linalg.norm(beta[j] * (A @ v) - alpha[j] * (B @ v))
        scale = abs(beta[j]) * np.linalg.norm(A, 2) + abs(alpha[j]) * np.linalg.norm(B, 2)
        scale *= np.linalg.norm(v)
        assert residual <= 1e-12 * scale


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 8))
def test_eigenvalues_are_scipys(seed, size):
    from scipy.linalg import eig

    A, B = _pencils(seed, size, 0)
    alpha, beta, _ = pencil_eigen(A, B)
    expected = eig(A, B, right=False)
    ours = alpha / beta
    for value in expected:
        assert np.min(np.abs(ours - value)) <= 1e-9 * max(1.0, abs(value))


def test_complex_pair_vectors_are_conjugate():
    # a rotation has the eigenvalues ±i: dggev stores the pair's vector in two real columns
    A = np.array([[0.0, -1.0], [1.0, 0.0]])
    alpha, beta, vectors = pencil_eigen(A, np.eye(2))
    assert np.allclose(sorted((alpha / beta).imag), [-1.0, 1.0])
    assert np.allclose(vectors[:, 0], np.conj(vectors[:, 1]))
    for j in range(2):
        assert np.allclose(A @ vectors[:, j], alpha[j] / beta[j] * vectors[:, j])


def test_lapack_is_loaded_without_scipy_linalg():
    code = ("import sys; from circuitnsds.solvers.pencil import _flapack; "
            "assert _flapack() is not None; print('scipy.linalg' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"
    assert _flapack() is not None


def test_scipy_fallback_gives_the_same_eigenvalues(monkeypatch):
    import circuitnsds.solvers.pencil as pencil

    A, B = _pencils(7, 6, 2)
    alpha, beta, _ = pencil_eigen(A, B)
    monkeypatch.setattr(pencil, "_FLAPACK", [None])
    alpha2, beta2, vectors2 = pencil_eigen(A, B)
    finite = np.abs(beta) > 1e-12
    assert np.allclose(np.sort_complex(alpha[finite] / beta[finite]),
                       np.sort_complex(alpha2[np.abs(beta2) > 1e-12] / beta2[np.abs(beta2) > 1e-12]))
    assert vectors2.shape == (6, 6)
