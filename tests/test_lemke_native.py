"""Lemke's pivoting in C (``circuitnsds_lemke`` of circuitnsds/solvers/_lu_native.c) against the
Python loop it replaces (``lemke._pivot_python``, the fallback and the reference):

* the library is built from this very source and the C loop is loaded (a missing library
  fails here: the package is installed with a C compiler, see tests/test_native_loop.py);
* on random LCPs (P-matrices, positive semidefinite, degenerate right-hand sides with exact
  ties and zeros, infeasible copositive-plus problems, pivot limits, frequent reinversions,
  ill-conditioned data) both loops end the same way: the same exception with the same
  evidence, or the same pivots, basis and ``z`` bit for bit — the C loop does numpy's
  arithmetic in numpy's order;
* on raw tableaus with infinities, NaN, zeros and huge or tiny entries (no scaling in
  front) both return the same status, tableau and basis;
* the C loop's answers are right, checked independently of the package: complementarity of
  ``z`` and ``w = M z + q``, the unique solution of P-matrix problems, and a secondary ray
  that proves infeasibility (``ray_w = M ray_z + d ray_z0``, all ``>= 0``, on the problems
  built infeasible);
* without the library (its function lookup patched to ``None``) and above ``NATIVE_MAX``
  the Python loop runs and gives the same results.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from circuitnsds import native
from circuitnsds.solvers import LCPNoSolution, LCPSolverFailure, linalg, solve_mlcp
from circuitnsds.solvers.testing import lcp_with_solution, monotone_mlcp, p_matrix, psd_matrix
from tests.conftest import assert_native_library_current

lemke = importlib.import_module("circuitnsds.solvers.lemke")  # (the package exports the function)

ROOT = Path(__file__).parents[1]
BUILD = "python setup.py build_ext --inplace (or pip install -e .) with a C compiler"
SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def test_library_built_from_this_source_and_loaded() -> None:
    assert_native_library_current(linalg.LIBRARY)
    assert lemke.native_loaded(), f"the C library is built but not loaded (stale? {BUILD})"
    assert lemke.NATIVE_MAX == linalg.NATIVE_MAX  # the C loop reinverts with the C LU


# -- running both loops -----------------------------------------------------------------------


@contextmanager
def python_loop():
    """Inside the block Lemke pivots in Python, as without the C library."""
    original = lemke._native_lemke
    lemke._native_lemke = lambda: None
    try:
        assert not lemke.native_loaded()
        yield
    finally:
        lemke._native_lemke = original


def outcome(M: np.ndarray, q: np.ndarray, **options) -> tuple:
    """``lemke_pivot``'s answer, or its exception as ``(type, message, pivots, evidence)``."""
    try:
        return ("answer", *lemke.lemke_pivot(M, q, **options))
    except (LCPNoSolution, LCPSolverFailure) as error:
        return (type(error), error.message, error.pivots, error.evidence)


def same(a: object, b: object) -> bool:
    """Equal, arrays bit for bit (NaN equal to NaN, signed zeros told apart)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape or a.dtype != b.dtype:
            return False
        if a.dtype.kind == "f":
            return bool(np.array_equal(a, b, equal_nan=True) and np.array_equal(np.signbit(a), np.signbit(b)))
        return bool(np.array_equal(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and isinstance(b, float) and np.isnan(a) and np.isnan(b):
        return True
    return a == b


def both(M: np.ndarray, q: np.ndarray, **options) -> tuple:
    """The C loop's outcome, asserted identical to the Python loop's."""
    assert lemke.native_loaded() and M.shape[0] <= lemke.NATIVE_MAX
    ours = outcome(M, q, **options)
    with python_loop():
        reference = outcome(M, q, **options)
    assert same(ours, reference), f"C {ours}\nPython {reference}"
    return ours


def assert_solves(M: np.ndarray, q: np.ndarray, z: np.ndarray, tol: float = 1e-8) -> None:
    """Complementarity of ``z`` and ``w = M z + q``, relative to the data's scale."""
    w = M @ z + q
    scale = np.abs(q).max() + np.abs(M).sum(axis=1).max() * np.abs(z).max()
    zs = np.abs(M).sum(axis=1).max()
    assert z.min() * zs >= -tol * scale and w.min() >= -tol * scale
    assert np.max(np.minimum(np.abs(z) * zs, np.abs(w))) <= tol * scale


# -- random LCPs ------------------------------------------------------------------------------


@SETTINGS
@given(n=st.integers(1, 40), seed=st.integers(0, 2**32 - 1),
       kind=st.sampled_from(["pd", "diagdom", "triangular"]), frac=st.floats(0.0, 1.0))
def test_p_matrices(n: int, seed: int, kind: str, frac: float) -> None:
    rng = np.random.default_rng(seed)
    M = p_matrix(n, rng, kind)
    q, z_star, _ = lcp_with_solution(M, rng, frac_active=frac)
    kind_, z, active, pivots = both(M, q)
    assert kind_ == "answer"
    assert_solves(M, q, z)
    # a P-matrix LCP has one solution
    np.testing.assert_allclose(z, z_star, atol=1e-8 * (1 + np.abs(z_star).max()))


@SETTINGS
@given(n=st.integers(1, 40), seed=st.integers(0, 2**32 - 1), rank_frac=st.floats(0.0, 1.0),
       degenerate=st.sampled_from([0.0, 0.3, 1.0]))
def test_positive_semidefinite(n: int, seed: int, rank_frac: float, degenerate: float) -> None:
    rng = np.random.default_rng(seed)
    M = psd_matrix(n, rng, rank=int(rank_frac * n))
    q, _, _ = lcp_with_solution(M, rng, degenerate=degenerate)
    answer = both(M, q)
    # a feasible PSD (copositive-plus) LCP: Lemke ends on a solution
    assert answer[0] == "answer", answer
    assert_solves(M, q, answer[1], tol=1e-7)


@SETTINGS
@given(n=st.integers(1, 12), seed=st.integers(0, 2**32 - 1), zeros=st.floats(0.0, 1.0),
       span=st.integers(1, 3))
@example(n=3, seed=0, zeros=0.0, span=1)  # q = -1 everywhere: every ratio of the first pivot tied
def test_degenerate_integer_data(n: int, seed: int, zeros: float, span: int) -> None:
    # small integers: exact ties in the ratio tests (q entries equal, zero), where only the
    # lexicographic rule and the z0 preference decide
    rng = np.random.default_rng(seed)
    G = rng.integers(-span, span + 1, (n, n)).astype(float)
    M = np.eye(n) + G @ G.T + (G - G.T)  # positive definite: identity + PSD + skew
    q = rng.integers(-span, span + 1, n).astype(float)
    q[rng.random(n) < zeros] = 0.0
    if seed % 3 == 0:
        q[:] = -1.0
    answer = both(M, q)
    assert answer[0] == "answer"
    assert_solves(M, q, answer[1])


@SETTINGS
@given(n=st.integers(2, 30), seed=st.integers(0, 2**32 - 1), rank=st.integers(1, 30))
def test_infeasible_copositive_plus_ends_on_a_secondary_ray(n: int, seed: int, rank: int) -> None:
    # M = Eᵀ (G Gᵀ + S) E with E the (n-1) x n differences (rows e_i - e_i+1) and integer G,
    # S = -Sᵀ: exact, positive semidefinite (so copositive-plus) with M 1 = Mᵀ 1 = 0; then
    # sum(w) = sum(q) < 0 for every z, no w >= 0
    rng = np.random.default_rng(seed)
    E = np.eye(n - 1, n) - np.eye(n - 1, n, 1)
    G = rng.integers(-3, 4, (n - 1, min(rank, n - 1))).astype(float)
    S = np.triu(rng.integers(-3, 4, (n - 1, n - 1)), 1).astype(float)
    M = E.T @ (G @ G.T + S - S.T) @ E
    q = rng.standard_normal(n)
    q -= (q.sum() + rng.uniform(0.1, 1.0)) / n
    assert q.sum() < 0
    answer = both(M, q)
    assert answer[0] is LCPNoSolution, answer
    evidence = answer[3]
    ray_z, ray_w, ray_z0 = evidence["ray_z"], evidence["ray_w"], evidence["ray_z0"]
    # the ray of the last basis: w = M z + d z0 along it, every component >= 0
    big = max(np.abs(ray_z).max(), np.abs(ray_w).max(), abs(ray_z0))
    assert big == pytest.approx(1.0)
    tol = 1e-8 * (1 + np.abs(M).max())
    np.testing.assert_allclose(ray_w, M @ ray_z + ray_z0, atol=tol)
    assert ray_z.min() >= -tol and ray_w.min() >= -tol and ray_z0 >= -tol


@SETTINGS
@given(n=st.integers(2, 30), seed=st.integers(0, 2**32 - 1), limit=st.integers(1, 6))
def test_pivot_limit(n: int, seed: int, limit: int) -> None:
    rng = np.random.default_rng(seed)
    M = p_matrix(n, rng, "pd")
    q, _, _ = lcp_with_solution(M, rng, frac_active=1.0)
    answer = both(M, q, max_pivots=limit)
    unlimited = both(M, q)
    if unlimited[3] <= limit:
        assert same(answer, unlimited)
    else:
        assert answer[0] is LCPSolverFailure and answer[3]["reason"] == "pivot limit"
        assert answer[2] == limit


@SETTINGS
@given(n=st.integers(2, 40), seed=st.integers(0, 2**32 - 1), every=st.integers(1, 4),
       log_cond=st.floats(0.0, 18.0))
def test_reinversions_and_ill_conditioned_data(n: int, seed: int, every: int, log_cond: float) -> None:
    # frequent reinversions (the C loop factorises with the LU the Python loop's factorise
    # uses), and data conditioned up to 1e18, where reinversions for lost feasibility and
    # the failures of numerical trouble happen
    rng = np.random.default_rng(seed)
    U = np.linalg.qr(rng.standard_normal((n, n)))[0]
    V = np.linalg.qr(rng.standard_normal((n, n)))[0] if seed % 2 else U
    M = U @ np.diag(np.logspace(0, -log_cond, n)) @ V.T
    q = rng.standard_normal(n) * np.exp(rng.uniform(-5, 5, n))
    saved = lemke._REINVERT_EVERY
    lemke._REINVERT_EVERY = every
    try:
        answer = both(M, q)
    finally:
        lemke._REINVERT_EVERY = saved
    if answer[0] == "answer" and log_cond < 6 and seed % 2 == 0:  # PSD, well conditioned
        assert_solves(M, q, answer[1], tol=1e-6)


# -- raw tableaus: the arithmetic of infinities, NaN and zeros ----------------------------------

SPECIAL = st.sampled_from([0.0, -0.0, 1.0, -1.0, 1e-300, -1e-300, 1e300, -1e300, np.inf, -np.inf, np.nan])
ENTRY = st.one_of(st.floats(-4.0, 4.0), st.integers(-2, 2).map(float), SPECIAL)


@SETTINGS
@given(n=st.integers(1, 6), data=st.data())
def test_raw_tableaus(n: int, data: st.DataObject) -> None:
    entries = data.draw(st.lists(ENTRY, min_size=n * (n + 2), max_size=n * (n + 2)))
    X = np.array(entries).reshape(n, n + 2)
    d = np.array(data.draw(st.lists(st.sampled_from([1.0, 0.5, 1e-300, 1e300]), min_size=n, max_size=n)))
    T0 = np.hstack([np.eye(n), X[:, :n], -d[:, None], X[:, n:n + 1]])
    limit = data.draw(st.integers(1, 30))
    saved = lemke._REINVERT_EVERY
    lemke._REINVERT_EVERY = data.draw(st.sampled_from([1, 2, saved]))
    try:
        ours = lemke._pivot_native(lemke._native_lemke(), T0, limit)
        reference = lemke._pivot_python(T0, limit)
    finally:
        lemke._REINVERT_EVERY = saved
    assert same(ours, reference), f"C {ours}\nPython {reference}"


# -- without the library, and above its limit ---------------------------------------------------


def test_fallback_without_the_library_gives_the_same() -> None:
    rng = np.random.default_rng(5)
    problems = []
    for n in (1, 3, 8, 20):
        M = p_matrix(n, rng, "triangular")
        problems.append((M, lcp_with_solution(M, rng)[0]))
    problems.append((np.array([[0.0, 0.0], [0.0, 0.0]]), np.array([-1.0, 2.0])))  # a ray
    native_answers = [outcome(M, q) for M, q in problems]
    with python_loop():
        assert [type(a[0]) for a in native_answers] == [str, str, str, str, type]
        for (M, q), expected in zip(problems, native_answers, strict=True):
            assert same(outcome(M, q), expected)
    # an MLCP of a circuit's shape, solved whole (start basis, Lemke, verification)
    A, C, D, B, a, b = monotone_mlcp(4, 9, np.random.default_rng(8))
    with_c = solve_mlcp(A, C, D, B, a, b, method="lemke")
    with python_loop():
        without = solve_mlcp(A, C, D, B, a, b, method="lemke")
    assert same((with_c.u, with_c.z, with_c.active, with_c.iterations),
                (without.u, without.z, without.active, without.iterations))


def test_no_memory_falls_back_to_python() -> None:
    # the C loop returns -1 (lemke_status LEMKE_NO_MEMORY) when it cannot allocate its work
    # space: lemke_pivot then pivots in Python
    M = p_matrix(5, np.random.default_rng(2), "pd")
    q = -np.ones(5)
    expected = outcome(M, q)
    original = lemke._native_lemke
    lemke._native_lemke = lambda: (lambda *arguments: -1)
    try:
        assert same(outcome(M, q), expected)
    finally:
        lemke._native_lemke = original


def test_above_the_limit_python_pivots(monkeypatch) -> None:
    calls = []
    original = lemke._pivot_native
    monkeypatch.setattr(lemke, "_pivot_native", lambda *arguments: calls.append(1) or original(*arguments))
    rng = np.random.default_rng(4)
    for n in (lemke.NATIVE_MAX, lemke.NATIVE_MAX + 1):
        M = p_matrix(n, rng, "diagdom")
        q, z_star, _ = lcp_with_solution(M, rng)
        z = lemke.lemke_pivot(M, q)[0]
        np.testing.assert_allclose(z, z_star, atol=1e-8 * (1 + np.abs(z_star).max()))
    assert len(calls) == 1  # n = NATIVE_MAX only


def test_a_kept_tableau_solves_each_q_as_a_fresh_one() -> None:
    # the MLCP solver keeps one LemkeTableau per start basis and pivots it for every new q
    rng = np.random.default_rng(6)
    M = psd_matrix(7, rng, rank=4)
    tableau = lemke.LemkeTableau(M)
    for _ in range(5):
        q = lcp_with_solution(M, rng, degenerate=0.2)[0]
        try:
            kept = ("answer", *tableau.pivot(q))
        except (LCPNoSolution, LCPSolverFailure) as error:
            kept = (type(error), error.message, error.pivots, error.evidence)
        assert same(kept, outcome(M, q))
    with pytest.raises(ValueError, match="covering vector"):
        lemke.LemkeTableau(M, d=np.ones(6))


def test_switched_off_by_the_environment() -> None:
    # CIRCUITNSDS_NATIVE=0: the Python loop, with the same answer as the C loop here
    script = ("import importlib, numpy as np\n"
              "lemke = importlib.import_module('circuitnsds.solvers.lemke')\n"
              "M, q = np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-5.0, -6.0])\n"
              "z, active, pivots = lemke.lemke_pivot(M, q)\n"
              "print(lemke.native_loaded(), z.tolist(), active.tolist(), pivots)")
    answers = []
    for switch in ("1", "0"):
        environment = dict(os.environ, PYTHONPATH=str(ROOT), **{native.DISABLE_ENV: switch})
        result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                                env=environment, cwd=ROOT, check=True)
        answers.append(result.stdout.split(maxsplit=1))
    assert [answer[0] for answer in answers] == ["True", "False"]
    assert answers[0][1] == answers[1][1]
    # w = M z + q = 0 with z = M⁻¹ (5, 6) = (4/3, 7/3): both pairs active, after three pivots
    # (z0 enters at the row of -6, then z2, then z1 as z0 leaves)
    assert answers[0][1].startswith("[1.333333333333333") and "[True, True] 3" in answers[0][1]
