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

from circuitnsds.solvers.pencil import _flapack, _numpy_dggev, pencil_eigen


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
    # (nor scipy's package: its test utilities alone cost 0.02 s of every exact run's start)
    code = ("import sys; from circuitnsds.solvers.pencil import _flapack; "
            "assert _flapack() is not None; print('scipy.linalg' in sys.modules, 'scipy' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False False"
    assert _flapack() is not None


def test_scipy_fallback_gives_the_same_eigenvalues(monkeypatch):
    import circuitnsds.solvers.pencil as pencil

    A, B = _pencils(7, 6, 2)
    alpha, beta, _ = pencil_eigen(A, B)
    monkeypatch.setattr(pencil, "_FLAPACK", [None])
    monkeypatch.setattr(pencil, "_NUMPY_DGGEV", [None])
    alpha2, beta2, vectors2 = pencil_eigen(A, B)
    finite = np.abs(beta) > 1e-12
    assert np.allclose(np.sort_complex(alpha[finite] / beta[finite]),
                       np.sort_complex(alpha2[np.abs(beta2) > 1e-12] / beta2[np.abs(beta2) > 1e-12]))
    assert vectors2.shape == (6, 6)


def test_balancing_scales_by_powers_of_two_and_keeps_the_eigenvalues():
    from circuitnsds.solvers.pencil import balancing

    A, B = _pencils(3, 5, 1)
    A[0] *= 1e12
    B[:, 2] *= 1e-9
    rows, columns = balancing(A, B)
    assert np.all(np.log2(rows) == np.round(np.log2(rows)))
    assert np.all(np.log2(columns) == np.round(np.log2(columns)))
    plain = pencil_eigen(A, B, balance=False)
    balanced = pencil_eigen(A, B)
    finite = [np.sort_complex(a[np.abs(b) > 1e-9 * np.abs(a)] / b[np.abs(b) > 1e-9 * np.abs(a)])
              for a, b, _ in (plain, balanced)]
    assert finite[0].size == finite[1].size
    assert np.allclose(finite[0], finite[1], rtol=1e-6)


def test_the_blocked_transformer_bridges_slow_modes_are_its_closed_forms():
    # netlists/transformer_rectifier.cir with all four diodes blocking: the primary's L1 = 1 H
    # through Rpri = 0.1 Ω (−0.1 /s), the output's 1000 µF through 100 Ω (−10 /s), and the
    # secondary's leakage through the blocked diodes (−1.8e17 /s). The pencil as it is has two
    # finite eigenvalues (the third's β is round-off); F's own gave +32 /s for the first, a
    # magnetising current that grew, and the exact integrator missed every diode turn-on
    import warnings

    import circuitnsds
    from circuitnsds.engine.exact.run import ExactSystem
    from tests.conftest import NETLISTS

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mlcs = circuitnsds.read_netlist(NETLISTS / "transformer_rectifier.cir").mlcs()
    mode = ExactSystem(mlcs).mode(np.zeros(mlcs.m, bool), ())
    slow = np.sort(mode.eigenvalues.real)[::-1][:2]
    assert np.allclose(slow, [-0.1, -10.0], rtol=1e-6)
    assert mode.eigenvalues.real.min() < -1e16


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 12), st.integers(0, 4), st.booleans())
def test_numpys_dggev_gives_scipys_bits(seed, size, singular, balance):
    # the LAPACK numpy is linked with (ctypes) and scipy's _flapack: the same routine, the same
    # workspace, the same results (to the bit with numpy 2.4 / scipy 1.17's OpenBLAS builds, what
    # kept the exact modes' values; to round-off asserted, as other builds may round otherwise)
    import circuitnsds.solvers.pencil as pencil

    if _numpy_dggev() is None or _flapack() is None:
        import pytest

        pytest.skip("this numpy has no OpenBLAS library of its own to call")
    A, B = _pencils(seed, size, min(singular, size - 1))
    ours = pencil_eigen(A, B, balance=balance)
    saved = pencil._NUMPY_DGGEV[:]
    pencil._NUMPY_DGGEV[:] = [None]
    try:
        theirs = pencil_eigen(A, B, balance=balance)
    finally:
        pencil._NUMPY_DGGEV[:] = saved
    for mine, scipys in zip(ours, theirs):
        scale = max(1.0, float(np.max(np.abs(scipys))))
        np.testing.assert_allclose(mine, scipys, rtol=1e-10, atol=1e-12 * scale)


def test_an_exact_mode_loads_no_second_lapack():
    # numpy's own LAPACK is in the process already; scipy's (13 ms of CPU to load) is not needed
    code = ("import sys, numpy as np; from circuitnsds.solvers.pencil import _numpy_dggev, pencil_eigen; "
            "pencil_eigen(np.eye(3), np.diag([1.0, 2.0, 0.0]), balance=False); "
            "print(_numpy_dggev() is not None, 'scipy.linalg._flapack' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    found, loaded = done.stdout.split()
    assert loaded == ("False" if found == "True" else "True")
