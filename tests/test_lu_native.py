"""The dense LU in C (circuitnsds/solvers/_lu_native.c, used by solvers.linalg) against
LAPACK (scipy's) and against what the theory of LU with partial pivoting guarantees:

* the library is built from this very source and loaded (a missing library fails here: the
  package is installed with a C compiler, see tests/test_native_loop.py);
* solves are backward stable (Higham, *Accuracy and Stability of Numerical Algorithms*,
  Thm 9.4: ``|K x̂ - b| <= γ_3n |L̂||Û||x̂|``), agree with scipy's to ``cond·eps``, and the
  pivots are LAPACK's (``|L| <= 1``; the same rows as ``getrf`` where no two candidates
  are close);
* the condition estimate is ``gecon``'s: on the same factors to rounding, on our own factors
  to ``cond·eps``; it never exceeds the exact ``‖K⁻¹‖₁`` (dlacn2 gives a lower bound), and
  it is 0 for exactly singular or non-finite matrices;
* without the library (``CIRCUITNSDS_NATIVE=0`` or absent) scipy's LAPACK gives the same;
* the QR with column pivoting of :func:`~circuitnsds.solvers.pivot_transform.completion_mask`
  chooses LAPACK ``geqp3``'s columns;
* the modules moved off scipy do not import it (module level, nor on these calls).
"""

from __future__ import annotations

import copy
import ctypes
import gc
import json
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.linalg import lapack

from circuitnsds import native
from circuitnsds.solvers import linalg
from circuitnsds.solvers.lemke import solve_active_set
from circuitnsds.solvers.linalg import LU, factorise
from circuitnsds.solvers.pivot_transform import completion_mask, pivoted_qr_order
from tests.conftest import assert_native_library_current

ROOT = Path(__file__).parents[1]
BUILD = "python setup.py build_ext --inplace (or pip install -e .) with a C compiler"
EPS = np.finfo(float).eps


def test_library_built_from_this_source_and_loaded() -> None:
    assert_native_library_current(linalg.LIBRARY)
    assert linalg.native_loaded(), f"the C LU is built but not loaded (stale? {BUILD})"
    assert type(factorise(np.eye(3))) is LU


# -- random matrices ---------------------------------------------------------------------------


def _matrix(seed: int, n: int, log_cond: float, kind: str) -> np.ndarray:
    """A random ``n x n`` matrix, scaled by a random power of ten: standard normal entries
    ("normal"); ``U diag(s) Vᵀ`` with singular values from 1 down to ``10**-log_cond`` and
    random orthogonal ``U``, ``V`` ("conditioned"); or the rows of an upper triangular matrix
    of small integers (diagonal ±2, ±3) in random order ("triangular": factorised without
    rounding, LAPACK's factors exactly; ties in the estimate's searches, and the cases where
    its final alternating-sign vector decides, e.g. ``[[3, 2], [0, 2]]``)."""
    rng = np.random.default_rng(seed)
    if kind == "normal":
        K = rng.standard_normal((n, n))
    elif kind == "conditioned":
        U, _ = np.linalg.qr(rng.standard_normal((n, n)))
        V, _ = np.linalg.qr(rng.standard_normal((n, n)))
        K = (U * np.logspace(0, -log_cond, n)) @ V.T
    else:
        K = np.triu(rng.integers(-1, 2, (n, n)), 1) + np.diag(rng.choice([-3, -2, 2, 3], n))
        K = K[rng.permutation(n)].astype(float)
    return K * 10.0 ** rng.integers(-6, 7)


matrices = st.builds(_matrix, st.integers(0, 2**32 - 1), st.integers(0, 40), st.floats(0.0, 13.0),
                     st.sampled_from(["normal", "conditioned", "triangular"]))


def _unpack(lu: LU) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(P, L, U)`` with ``K = P L U`` from LAPACK-style factors and 0-based pivots."""
    n = lu.size
    L = np.tril(lu.lu, -1) + np.eye(n)
    U = np.triu(lu.lu)
    order = np.arange(n)
    for k, p in enumerate(lu.piv):
        order[[k, p]] = order[[p, k]]
    P = np.eye(n)[:, order]  # row k of L U is row order[k] of K
    return P, L, U


@settings(max_examples=80, deadline=None)
@given(matrices, st.integers(0, 3), st.integers(0, 2**32 - 1))
def test_solve_backward_stable_and_as_lapack(K: np.ndarray, columns: int, seed: int) -> None:
    n = K.shape[0]
    rng = np.random.default_rng(seed)
    b = rng.standard_normal(n) if columns == 0 else rng.standard_normal((n, columns))
    b_before = b.copy()
    lu = factorise(K)
    assert type(lu) is LU and lu.size == n
    x = lu.solve(b)
    assert x.shape == b.shape and x.flags.c_contiguous and not np.shares_memory(x, b)
    assert np.array_equal(b, b_before)
    if n == 0:
        assert lu.rcond == 1.0
        return
    assert lu.ok
    P, L, U = _unpack(lu)
    # the pivots are partial pivoting's: no multiplier above 1 in magnitude, and K = P L U
    assert np.abs(L).max() <= 1.0
    scale = P @ np.abs(L) @ np.abs(U)
    assert np.all(np.abs(P @ L @ U - K) <= 3 * n * EPS * scale + 1e-300)
    # backward stability, componentwise (Higham Thm 9.4), plus the rounding of the residual
    gamma = 3 * n * EPS / 2 / (1 - 3 * n * EPS / 2)
    X = x.reshape(n, -1)
    residual = np.abs(K @ X - b.reshape(n, -1))
    bound = gamma * scale @ np.abs(X) + (n + 1) * EPS * (np.abs(K) @ np.abs(X) + np.abs(b.reshape(n, -1)))
    assert np.all(residual <= 2 * bound + 1e-300)
    # scipy's getrf/getrs: the same pivots (no near ties: every |multiplier| well below 1)
    lu2, piv2 = sla.lu_factor(K)
    if np.abs(np.tril(lu2, -1)).max(initial=0.0) < 1.0 - 1e-6:
        assert np.array_equal(lu.piv, piv2)
    x2 = lapack.dgetrs(lu2, piv2, b)[0]
    cond = 1.0 / lu.rcond
    assert np.abs(x - x2).max() <= 4 * n * cond * EPS * np.abs(x2).max()


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 40), st.floats(0.0, 13.0),
       st.sampled_from(["normal", "conditioned", "triangular"]))
@example(262144, 4, 0.0, "triangular")  # the two estimates differ (0.3, exact, against gecon's 0.375)
def test_condition_estimate_is_gecons(seed: int, size: int, log_cond: float, kind: str) -> None:
    K = _matrix(seed, size, log_cond, kind)
    n = K.shape[0]
    lu = factorise(K)
    if n == 0:
        assert lu.rcond == 1.0
        return
    anorm = float(np.abs(K).sum(axis=0).max())
    lu2, piv2 = sla.lu_factor(K)
    reference, info = lapack.dgecon(lu2, anorm, norm="1")
    assert info == 0
    cond = 1.0 / reference
    # the same algorithm on the same factors (scipy's, in C order): to rounding
    rcond = native.library(linalg.LIBRARY).circuitnsds_lu_rcond
    rcond.argtypes = [ctypes.c_int64, ctypes.c_void_p, ctypes.c_double]
    rcond.restype = ctypes.c_double
    factors = np.ascontiguousarray(lu2)  # kept alive through the call
    same = rcond(n, factors.ctypes.data, anorm)
    exact = 1.0 / (anorm * np.abs(np.linalg.inv(K)).sum(axis=0).max())
    if kind != "triangular":
        assert abs(same / reference - 1.0) <= 100 * n * EPS + cond * EPS
        # on our own factors: they differ from LAPACK's by rounding, the estimate by cond·eps
        # (measured: at most 0.36 cond·eps over 3000 matrices of n <= 40 and cond <= 1e14)
        assert abs(lu.rcond / reference - 1.0) <= n * cond * EPS
    # The integer triangular matrices have exact ties among the entries the estimate's
    # searches compare; which entry wins then depends on the last bit of each solve, which
    # dlatrs (gecon's) and our plain solves round differently, and the two estimates may take
    # different paths (92 of 20,000 such matrices with n <= 11: ours the lower estimate of
    # ‖K⁻¹‖₁ in 16, the higher in 76). What holds for every matrix: each is a lower bound of
    # ‖K⁻¹‖₁, so at least the exact reciprocal condition number (up to the error of the
    # computed inverse, cond·eps); measured: at most 3.2 times it
    assert lu.rcond >= exact * (1.0 - n * cond * EPS)
    assert same >= exact * (1.0 - n * cond * EPS)


def test_pivot_ties_go_to_the_first_row() -> None:
    # candidates of equal magnitude (exact arithmetic: multipliers ±1): LAPACK takes the first
    K = np.array([[1.0, 2.0, 3.0, 1.0], [-1.0, 5.0, 1.0, 2.0], [1.0, 1.0, 1.0, -3.0], [-1.0, -1.0, 4.0, 4.0]])
    lu = factorise(K)
    assert lu.piv.tolist() == sla.lu_factor(K)[1].tolist()
    assert np.allclose(lu.lu, sla.lu_factor(K)[0], rtol=0, atol=1e-15 * 8)  # (1/7: rounding differs)


# -- singular and non-finite matrices --------------------------------------------------------


def _singular_cases() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(7)
    zero_column = rng.standard_normal((6, 6))
    zero_column[:, 3] = 0.0
    duplicate_rows = rng.standard_normal((6, 6))
    duplicate_rows[4] = duplicate_rows[1]
    return {"zero": np.zeros((4, 4)), "zero column": zero_column, "duplicate rows": duplicate_rows,
            "rank one": np.outer([1.0, 2.0, 4.0], [3.0, 5.0, 7.0])}  # exact multipliers


@pytest.mark.parametrize("name", list(_singular_cases()))
def test_exactly_singular(name: str) -> None:
    K = _singular_cases()[name]
    lu = factorise(K)
    assert lu.rcond == 0.0 and not lu.ok
    assert np.min(np.abs(np.diag(lu.lu))) == 0.0  # an exactly zero pivot, as LAPACK's
    assert np.min(np.abs(np.diag(sla.lu_factor(K)[0]))) == 0.0
    assert solve_active_set(K, np.ones(K.shape[0]), np.ones(K.shape[0], dtype=bool)) is None


@pytest.mark.parametrize("bad", [np.inf, -np.inf, np.nan])
@pytest.mark.parametrize("where", [(0, 0), (2, 1), (3, 3)])
def test_not_finite(bad: float, where: tuple[int, int]) -> None:
    K = np.random.default_rng(3).standard_normal((4, 4)) + 4 * np.eye(4)
    K[where] = bad
    lu = factorise(K)
    assert lu.rcond == 0.0 and not lu.ok
    assert solve_active_set(K, np.ones(4), np.ones(4, dtype=bool)) is None


def test_solve_arguments() -> None:
    K = np.array([[4.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 2.0, 5.0]])
    lu = factorise(K)
    expected = np.linalg.solve(K, np.array([1.0, 2.0, 3.0]))
    # any layout and dtype of b, which is left alone; x is new
    for b in (np.array([1, 2, 3]), np.array([[1.0, 9.0], [2.0, 9.0], [3.0, 9.0]], order="F")[:, 0],
              np.array([[1.0], [2.0], [3.0]], order="F"), np.array([1.0, 0.0, 2.0, 0.0, 3.0, 0.0])[::2]):
        x = lu.solve(b)
        assert np.allclose(x.reshape(-1), expected, rtol=1e-14) and not np.shares_memory(x, b)
    assert lu.solve(np.zeros((3, 0))).shape == (3, 0)
    for wrong in (np.ones(2), np.ones((4, 1)), np.ones((3, 1, 1)), np.float64(1.0)):
        with pytest.raises(ValueError, match="LU.solve"):
            lu.solve(wrong)
    with pytest.raises(ValueError, match="square"):
        factorise(np.ones((2, 3)))
    empty = factorise(np.zeros((0, 0)))
    assert empty.ok and empty.solve(np.zeros(0)).shape == (0,)
    # the public constructor takes the C library's factors only
    again = LU(lu.lu, lu.piv, lu.rcond)
    assert np.array_equal(again.solve(np.array([1.0, 2.0, 3.0])), lu.solve(np.array([1.0, 2.0, 3.0])))
    with pytest.raises(ValueError, match="C-ordered"):
        LU(np.asfortranarray(lu.lu), lu.piv, lu.rcond)
    # K itself is not modified (factorised in a copy)
    K_before = K.copy()
    factorise(K)
    assert np.array_equal(K, K_before)


def test_copies_and_pickles_take_their_own_addresses(monkeypatch) -> None:
    K = np.random.default_rng(5).standard_normal((7, 7)) + 7 * np.eye(7)
    b = np.arange(7.0)
    expected = np.linalg.solve(K, b)
    lu = factorise(K)
    copies = [copy.copy(lu), copy.deepcopy(lu), pickle.loads(pickle.dumps(lu))]
    del lu
    gc.collect()  # the deep copy and the unpickled one own their arrays, not the original's
    for other in copies:
        assert type(other) is LU and other.rcond > 0
        assert np.allclose(other.solve(b), expected, rtol=1e-13)
    data = pickle.dumps(copies[0])
    monkeypatch.setattr(linalg, "_native_functions", lambda: None)  # unpickled where the library is not built
    fallback = pickle.loads(data)
    assert type(fallback) is not LU and np.allclose(fallback.solve(b), expected, rtol=1e-13)
    assert np.allclose(pickle.loads(pickle.dumps(fallback)).solve(b), expected, rtol=1e-13)


def test_large_matrices_go_to_lapack() -> None:
    # above NATIVE_MAX scipy's blocked LAPACK is faster (benchmarks/lu_native.py)
    n = linalg.NATIVE_MAX
    for size, native_type in ((n, True), (n + 1, False)):
        K = np.random.default_rng(size).standard_normal((size, size)) + size * np.eye(size)
        lu = factorise(K)
        assert (type(lu) is LU) is native_type
        b = np.ones(size)
        assert np.abs(K @ lu.solve(b) - b).max() < 1e-12


# -- without the library ----------------------------------------------------------------------


def test_fallback_to_scipy(monkeypatch) -> None:
    rng = np.random.default_rng(11)
    K = rng.standard_normal((12, 12))
    b = rng.standard_normal((12, 2))
    native_lu = factorise(K)
    monkeypatch.setattr(linalg, "_native_functions", lambda: None)
    assert not linalg.native_loaded()
    lapack_lu = factorise(K)
    assert type(lapack_lu) is not LU and lapack_lu.lu.flags.f_contiguous
    assert np.array_equal(lapack_lu.piv, native_lu.piv)
    assert np.allclose(lapack_lu.lu, native_lu.lu, rtol=0, atol=1e-13)
    assert abs(lapack_lu.rcond / native_lu.rcond - 1.0) < 1e-10
    assert np.allclose(lapack_lu.solve(b), native_lu.solve(b), rtol=1e-12)
    assert np.allclose(lapack_lu.solve(b[:, 0]), native_lu.solve(b[:, 0]), rtol=1e-12)
    assert factorise(np.zeros((3, 3))).rcond == 0.0
    assert factorise(np.zeros((0, 0))).solve(np.zeros(0)).shape == (0,)
    K_before = K.copy()
    factorise(K)
    assert np.array_equal(K, K_before)
    with pytest.raises(ValueError, match="square"):
        factorise(np.ones((2, 3)))


def test_switched_off_by_the_environment() -> None:
    script = ("import numpy as np\n"
              "from circuitnsds.solvers import linalg\n"
              "lu = linalg.factorise(np.array([[0.0, 2.0], [1.0, 1.0]]))\n"
              "x = lu.solve(np.array([2.0, 2.0]))\n"
              "print(linalg.native_loaded(), type(lu).__name__, lu.piv.tolist(), x.tolist())")
    environment = dict(os.environ, PYTHONPATH=str(ROOT), **{native.DISABLE_ENV: "0"})
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=environment,
                            cwd=ROOT, check=True)
    assert result.stdout.split() == ["False", "_LapackLU", "[1,", "1]", "[1.0,", "1.0]"]


# -- QR with column pivoting ------------------------------------------------------------------


def _projected_norms(P: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """The norms of ``P``'s columns orthogonal to the span of the columns ``chosen``."""
    if chosen.size == 0:
        return np.linalg.norm(P, axis=0)
    Q, _ = np.linalg.qr(P[:, chosen])
    return np.linalg.norm(P - Q @ (Q.T @ P), axis=0)


def _pivots_agree(P: np.ndarray, ours: np.ndarray, reference: np.ndarray, steps: int) -> int:
    """The number of leading pivots compared: each step's choice is compared while the
    largest remaining norm beats the next by a relative 1e-6 (else rounding decides)."""
    for j in range(steps):
        norms = _projected_norms(P, reference[:j])
        norms[reference[:j]] = -1.0
        top = np.sort(norms)[::-1]
        if top.size > 1 and top[0] - top[1] <= 1e-6 * top[0]:
            return j
        assert ours[j] == reference[j], f"step {j}: column {ours[j]}, LAPACK's {reference[j]}"
    return steps


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 8), st.integers(1, 8), st.integers(0, 8))
def test_pivoted_qr_is_geqp3s(seed: int, rows: int, columns: int, rank: int) -> None:
    rng = np.random.default_rng(seed)
    rank = min(rank, rows, columns)
    P = rng.standard_normal((rows, rank)) @ rng.standard_normal((rank, columns))
    P *= rng.uniform(0.1, 10.0, columns)  # distinct column norms
    P_before = P.copy()
    order = pivoted_qr_order(P)
    assert np.array_equal(P, P_before) and sorted(order) == list(range(columns))
    scale = max(float(np.abs(P).max()), 1.0)
    # Businger–Golub: each chosen column has the largest norm left after the earlier ones
    for j in range(min(rank, rows, columns)):
        norms = _projected_norms(P, order[:j])
        assert norms[order[j]] >= np.delete(norms, order[:j]).max() * (1 - 1e-9) - 1e-12 * scale
    # the first `rank` columns span P's columns
    assert _projected_norms(P, order[:rank]).max() <= 1e-9 * scale
    _, reference = sla.qr(P, pivoting=True, mode="r")
    _pivots_agree(P, order, reference, rank)


def test_pivoted_qr_ties_and_limits() -> None:
    P = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 0.0]])  # three columns of norm 1
    assert list(pivoted_qr_order(P)) == list(sla.qr(P, pivoting=True, mode="r")[1]) == [0, 1, 2]
    assert list(pivoted_qr_order(np.zeros((2, 3)))) == [0, 1, 2]
    assert list(pivoted_qr_order(np.array([[1.0, 3.0, 2.0]]), 1)) == [1, 0, 2]


def test_completion_mask_picks_the_pair_at_the_floating_node() -> None:
    # two nodes, node 1 floating (A singular); pair 0 touches node 0, pair 1 node 1:
    # activating pair 1 completes the rank
    K = np.array([[1.0, 0.0, 1.0, 0.0],
                  [0.0, 0.0, 0.0, 1.0],
                  [1.0, 0.0, 0.0, 0.0],
                  [0.0, 1.0, 0.0, 0.0]])
    assert completion_mask(K, 2).tolist() == [False, True]
    K_bad = K.copy()
    K_bad[0, 0] = np.nan
    assert completion_mask(K_bad, 2) is None


# -- no scipy ---------------------------------------------------------------------------------


OWN = ("circuitnsds.solvers.linalg", "circuitnsds.solvers.lemke", "circuitnsds.solvers.pivot_transform",
       "circuitnsds.checks.wellposed", "circuitnsds.engine.dense_loop")

_RECORD_SCIPY_IMPORTS = """
import builtins, json, sys
importers = []
original = builtins.__import__
def recording(name, globals=None, locals=None, fromlist=(), level=0):
    if name == "scipy" or name.startswith("scipy."):
        importers.append(((globals or {}).get("__name__"), name))
    return original(name, globals, locals, fromlist, level)
builtins.__import__ = recording
import importlib
for module in %r:
    importlib.import_module(module)
at_import = list(importers)
importers.clear()
import numpy as np
from circuitnsds.solvers.linalg import factorise
from circuitnsds.solvers.lemke import solve_active_set
from circuitnsds.solvers.pivot_transform import PivotTransform, completion_mask
K = np.array([[1.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0], [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
lu = factorise(K[:2, :2] + np.eye(2))
lu.solve(np.ones(2)); lu.solve(np.ones((2, 3)))
solve_active_set(K, -np.ones(4), np.ones(4, dtype=bool))
mask = completion_mask(K, 2)
PivotTransform(K, 2, mask, factorise(K[np.ix_([0, 1, 3], [0, 1, 3])])).rhs(np.ones(4))
print(json.dumps({"import": at_import, "calls": importers}))
"""


def test_own_modules_import_no_scipy() -> None:
    # the modules of this change import scipy neither at module level nor when these run;
    # (other modules they import still may: reported, not asserted, until they stop)
    result = subprocess.run([sys.executable, "-c", _RECORD_SCIPY_IMPORTS % (OWN,)], capture_output=True,
                            text=True, env=dict(os.environ, PYTHONPATH=str(ROOT)), cwd=ROOT, check=True)
    record = json.loads(result.stdout.splitlines()[-1])
    assert not [item for item in record["import"] if item[0] in OWN], record["import"]
    assert record["calls"] == []
