"""The compiled sparse mode loop (circuitnsds.engine.sparse_loop) against the Python one.

Two properties: the triangular solves with SuperLU's factors taken apart equal
``lu.solve`` (which fixes the permutation convention), and ``run_compiled_sparse``
stops where ``run_sparse_mode`` (the same loop written plainly around scipy, below)
stops, for the same reason,
having written the same rows. The modes are built by hand from random sparse
matrices (a decoupled integrator unknown ``y_0`` gives each stop a known cause).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.engine import sparse_loop as sparse_kernel
from circuitnsds.engine.sparse_loop import (
    STOP_END,
    STOP_LEFT_MODE,
    STOP_SCHEDULE,
    STOP_SWITCH,
    CompiledSparseMap,
    SparseModeMap,
    compile_sparse_map,
    run_compiled_sparse,
    solve_compiled,
)

RTOL = 1e-12
SENTINEL = -12345.678  # rows a loop must not write keep it (a value no step produces)


def run_sparse_mode(mode: SparseModeMap, k0: int, k_end: int, y: np.ndarray, current: np.ndarray,
                    F: np.ndarray, step_class: np.ndarray, schedule: np.ndarray,
                    controls: np.ndarray, on_threshold: np.ndarray, off_threshold: np.ndarray,
                    switch_on: np.ndarray) -> tuple[int, int]:
    """The reference: the same loop written plainly around scipy (sparse products and
    SuperLU's own ``solve``), against which the compiled loop is checked."""
    n = mode.n
    rhs = np.empty(n + mode.active.size)
    rhs[n:] = mode.rhs_pairs
    k = k0
    while k < k_end:
        if k > k0 and (step_class[k] != step_class[k0] or schedule[k] != schedule[k0]):
            return k, STOP_SCHEDULE
        rhs[:n] = mode.carry @ y[k] + mode.S_next @ F[k + 1] + mode.S_now @ F[k]
        x = mode.lu.solve(rhs)
        if (x[n:] < 0.0).any() or (mode.W @ x + mode.e_w < 0.0).any():
            return k, STOP_LEFT_MODE
        y[k + 1] = x[:n]
        current[k + 1, mode.active] = x[n:]
        k += 1
        if controls.shape[0]:
            value = controls @ y[k]
            if (np.where(switch_on, value < off_threshold, value > on_threshold)).any():
                return k, STOP_SWITCH
    return k, STOP_END


def random_sparse(rng: np.random.Generator, rows: int, cols: int, density: float, scale: float) -> np.ndarray:
    """Dense array with about ``density`` of its entries uniform in ``[-scale, scale]``."""
    mask = rng.random((rows, cols)) < density
    return np.where(mask, rng.uniform(-scale, scale, (rows, cols)), 0.0)


def dominant_matrix(rng: np.random.Generator, size: int, density: float, pivot: bool) -> np.ndarray:
    """Row diagonally dominant (margin 2, so well conditioned); with ``pivot`` its rows are
    rotated by one, which puts every column's largest entry off the diagonal (SuperLU pivots)."""
    off = random_sparse(rng, size, size, density, 1.0)
    np.fill_diagonal(off, 0.0)
    matrix = off + np.diag(2.0 + np.abs(off).sum(axis=1) + rng.uniform(0.0, 1.0, size))
    return np.roll(matrix, 1, axis=0) if pivot else matrix


def mode_for(matrix: np.ndarray, fmt: str = "csc") -> SparseModeMap:
    """A SparseModeMap around ``matrix`` whose other parts are irrelevant (no pairs)."""
    size = matrix.shape[0]
    lu = spla.splu(sp.csc_matrix(matrix))
    empty = sp.csr_matrix((size, 1)) if fmt == "csr" else sp.csc_matrix((size, 1))
    return SparseModeMap(lu=lu, carry=sp.identity(size, format=fmt), S_next=empty, S_now=empty,
                         rhs_pairs=np.zeros(0), W=sp.csr_matrix((0, size)), e_w=np.zeros(0),
                         active=np.zeros(0, dtype=np.int64), n=size)


def assert_close(actual: np.ndarray, expected: np.ndarray) -> None:
    scale = max(1.0, float(np.nanmax(np.abs(expected)))) if expected.size else 1.0
    np.testing.assert_allclose(actual, expected, rtol=RTOL, atol=RTOL * scale)


# --- the factor solve -------------------------------------------------------------------------


@settings(max_examples=120, deadline=None, derandomize=True)
@given(size=st.integers(1, 120), density=st.floats(0.0, 0.4), seed=st.integers(0, 2**32 - 1),
       pivot=st.booleans(), fmt=st.sampled_from(["csr", "csc"]))
def test_factor_solve_equals_superlu(size, density, seed, pivot, fmt):
    rng = np.random.default_rng(seed)
    matrix = dominant_matrix(rng, size, density, pivot)
    mode = mode_for(matrix, fmt)
    cmap = compile_sparse_map(mode)
    for _ in range(3):
        rhs = rng.normal(size=size) * 10.0 ** rng.uniform(-3, 3)
        expected = mode.lu.solve(rhs)
        np.testing.assert_allclose(solve_compiled(cmap, rhs), expected, rtol=RTOL,
                                   atol=RTOL * np.abs(expected).max())
    if pivot and size >= 2:
        # without row pivoting SuperLU permutes symmetrically (perm_r == perm_c)
        assert not np.array_equal(cmap.perm_r, cmap.perm_c)


def test_permutation_convention():
    """``Pr·A·Pc = L·U`` with ``Pr[perm_r[i], i] = 1``, ``Pc[i, perm_c[i]] = 1``, and the stored
    arrays (unit diagonal of L implied, U's diagonal apart) rebuild SuperLU's factors."""
    rng = np.random.default_rng(3)
    size = 40
    matrix = dominant_matrix(rng, size, 0.15, pivot=True)
    mode = mode_for(matrix)
    cmap = compile_sparse_map(mode)
    shape = (size, size)
    L = sp.csr_matrix((cmap.L_data, cmap.L_indices, cmap.L_indptr), shape=shape) + sp.identity(size)
    U = sp.csr_matrix((cmap.U_data, cmap.U_indices, cmap.U_indptr), shape=shape) + sp.diags(cmap.U_diag)
    rows = np.arange(size)
    Pr = sp.csr_matrix((np.ones(size), (cmap.perm_r, rows)), shape=shape)
    Pc = sp.csr_matrix((np.ones(size), (rows, cmap.perm_c)), shape=shape)
    np.testing.assert_allclose((Pr @ matrix @ Pc), (L @ U).toarray(), atol=1e-13)
    assert abs(L - mode.lu.L).max() == 0.0 and abs(U - mode.lu.U).max() == 0.0
    assert cmap.factor_nnz <= mode.lu.L.nnz + mode.lu.U.nnz
    for name in ("L_indptr", "L_indices", "U_indptr", "U_indices", "perm_r", "perm_c", "active"):
        assert getattr(cmap, name).dtype == np.int64, name


def test_compile_rejects_wrong_shapes():
    mode = mode_for(np.eye(3) * 2.0)
    mode.rhs_pairs = np.ones(1)
    with pytest.raises(ValueError, match="rhs_pairs"):
        compile_sparse_map(mode)
    mode = mode_for(np.eye(3) * 2.0)
    mode.n = 2
    with pytest.raises(ValueError, match="factorisation"):
        compile_sparse_map(mode)


# --- the stepping loop ------------------------------------------------------------------------


def build_case(seed: int, scenario: str, *, n: int = 24, a: int = 4, inactive: int = 5, kstim: int = 3,
               steps: int = 300, k0: int = 5, pivot: bool = False, fmt: str = "csr") -> dict:
    """A mode, its inputs and the stop the scenario is built to produce.

    ``y_0`` is an integrator decoupled from everything (its row of the bordered matrix
    and of ``carry`` is ``e_0``, no other row or column uses it) fed by source 0, a
    constant ``rate``: ``y_0`` rises linearly from 0 at ``k0``, and each scenario makes
    one check watch it. The rest is a contraction (rows diagonally dominant with
    margin 2, ``carry`` rows of norm 0.9) driven by bounded sources, with pair currents
    near 1 (``D`` dominant, ``rhs_pairs = diag(D)``) and inactive ``w`` near 1.
    """
    rng = np.random.default_rng(seed)
    size = n + a
    m = a + inactive
    K = dominant_matrix(rng, n, 3.0 / n, pivot=False)
    K[0, :] = K[:, 0] = 0.0
    K[0, 0] = 1.0
    if pivot:  # rotate rows 1..n-1: SuperLU must pivot
        K[1:] = np.roll(K[1:], 1, axis=0)
    B = random_sparse(rng, n, a, 0.3, 0.1)
    B[0] = 0.0
    C = random_sparse(rng, a, n, 0.3, 0.05)
    C[:, 0] = 0.0
    D = np.diag(rng.uniform(2.0, 3.0, a)) + random_sparse(rng, a, a, 0.2, 0.1) * (1 - np.eye(a))
    carry = random_sparse(rng, n, n, 3.0 / n, 1.0)
    carry[0, :] = carry[:, 0] = 0.0
    sums = np.abs(carry).sum(axis=1)
    carry *= np.where(sums > 0, 0.9 / np.where(sums > 0, sums, 1.0), 0.0)[:, None]
    carry[0, 0] = 1.0
    S_next = random_sparse(rng, n, kstim, 0.5, 0.5)
    S_now = random_sparse(rng, n, kstim, 0.5, 0.5)
    S_next[0] = 0.0
    S_next[0, 0] = 1.0
    S_now[0] = 0.0
    W = random_sparse(rng, inactive, size, 0.3, 0.05)
    W[:, 0] = 0.0
    e_w = np.ones(inactive)
    rhs_pairs = np.diag(D).copy()

    count = steps + 1
    t = np.arange(count)
    F = np.empty((count, kstim))
    F[:, 1:] = np.sin(t[:, None] * rng.uniform(0.01, 0.3, kstim - 1) + rng.uniform(0, 6, kstim - 1))
    step_class = np.zeros(steps, dtype=np.int64)
    schedule = np.zeros(steps, dtype=np.int64)
    controls = np.zeros((0, n))
    on_threshold = off_threshold = np.zeros(0)
    switch_on = np.zeros(0, dtype=bool)
    middle = (steps - k0) // 2  # steps after k0 at which the watched check fires
    rate = 0.0
    expected = {"end": STOP_END, "pair": STOP_LEFT_MODE, "w": STOP_LEFT_MODE, "switch_off": STOP_SWITCH,
                "switch_on": STOP_SWITCH, "step_class": STOP_SCHEDULE, "schedule": STOP_SCHEDULE}[scenario]
    if scenario == "pair":  # λ_r ≈ (rhs_r - y_0)/D_rr turns negative about the middle
        r = int(rng.integers(a))
        C[r, 0] = 1.0
        rate = rhs_pairs[r] / middle
    elif scenario == "w":  # w_0 = threshold - y_0
        rate = 1.0
        W[0] = 0.0
        W[0, 0] = -1.0
        e_w[0] = middle - 0.5
    elif scenario in ("switch_off", "switch_on"):
        rate = 1.0
        sign = 1.0 if scenario == "switch_off" else -1.0
        controls = random_sparse(rng, 2, n, 0.3, 0.1)
        controls[:, 0] = 0.0
        controls[0, 0] = sign
        on_threshold = np.array([middle - 0.5, 10.0])
        off_threshold = np.array([-(middle - 0.5), -10.0])
        switch_on = np.array([scenario == "switch_on", True])  # the second never changes
    elif scenario == "step_class":
        step_class[k0 + middle:] = 4
    elif scenario == "schedule":
        schedule[k0 + middle + 3:] = 2
    F[:, 0] = rate

    bordered = np.block([[K, -B], [C, D]])
    convert = sp.csr_matrix if fmt == "csr" else sp.csc_matrix
    mode = SparseModeMap(lu=spla.splu(sp.csc_matrix(bordered)), carry=convert(carry),
                         S_next=convert(S_next), S_now=convert(S_now), rhs_pairs=rhs_pairs,
                         W=convert(W), e_w=e_w, active=np.sort(rng.choice(m, a, replace=False)), n=n)
    y = np.full((count, n), SENTINEL)
    y[k0] = rng.uniform(-1.0, 1.0, n)
    y[k0, 0] = 0.0
    current = np.full((count, m), SENTINEL)
    return dict(mode=mode, k0=k0, k_end=steps, y=y, current=current, F=F, step_class=step_class,
                schedule=schedule, controls=controls, on_threshold=on_threshold,
                off_threshold=off_threshold, switch_on=switch_on, expected=expected, middle=middle)


def run_both(case: dict, loop=None) -> tuple:
    """``(reference (k, reason), compiled (k, reason), reference arrays, compiled arrays)``."""
    arrays = {}
    results = {}
    for name in ("reference", "compiled"):
        y, current = case["y"].copy(), case["current"].copy()
        rest = (case["F"], case["step_class"], case["schedule"], case["controls"], case["on_threshold"],
                case["off_threshold"], case["switch_on"])
        if name == "reference":
            results[name] = run_sparse_mode(case["mode"], case["k0"], case["k_end"], y, current, *rest)
        elif loop is None:
            results[name] = run_compiled_sparse(compile_sparse_map(case["mode"]), case["k0"],
                                                case["k_end"], y, current, *rest)
        else:
            results[name] = loop(compile_sparse_map(case["mode"]), case["k0"], case["k_end"], y, current,
                                 *rest)
        arrays[name] = (y, current)
    return results["reference"], results["compiled"], arrays["reference"], arrays["compiled"]


SCENARIOS = ["end", "pair", "w", "switch_off", "switch_on", "step_class", "schedule"]


@settings(max_examples=60, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), scenario=st.sampled_from(SCENARIOS), pivot=st.booleans(),
       fmt=st.sampled_from(["csr", "csc"]), k0=st.integers(0, 20))
def test_loop_matches_run_sparse_mode(seed, scenario, pivot, fmt, k0):
    case = build_case(seed, scenario, pivot=pivot, fmt=fmt, k0=k0)
    reference, result, (y_ref, cur_ref), (y, cur) = run_both(case)
    k, reason = reference
    # the construction produces the intended stop (otherwise the comparison tests little)
    assert reason == case["expected"], (reference, scenario)
    if reason == STOP_END:
        assert k == case["k_end"]
    else:
        assert abs(k - (case["k0"] + case["middle"])) <= 5, (k, scenario)
    assert result == reference
    assert isinstance(result[0], int) and isinstance(result[1], int)
    assert_close(y, y_ref)
    assert_close(cur, cur_ref)
    # exactly the rows k0+1 .. k written, and only the active pairs' currents
    written = np.zeros(y.shape[0], dtype=bool)
    written[case["k0"] + 1: k + 1] = True
    assert (y[~written] == case["y"][~written]).all()
    assert (y[written] != SENTINEL).all()
    inactive = np.setdiff1d(np.arange(cur.shape[1]), case["mode"].active)
    assert (cur[:, inactive] == SENTINEL).all()
    assert (cur[np.ix_(written, case["mode"].active)] != SENTINEL).all()
    assert (cur[np.ix_(written, case["mode"].active)] >= 0.0).all()


def test_pair_leaving_writes_nothing_for_that_step():
    case = build_case(11, "pair")
    reference, result, (y_ref, _), (y, _) = run_both(case)
    k, reason = result
    assert reason == STOP_LEFT_MODE and result == reference
    assert (y[k + 1:] == SENTINEL).all() and (y[k] != SENTINEL).all()


def test_empty_run_and_first_step_leaving():
    case = build_case(2, "end")
    case["k_end"] = case["k0"]  # nothing to do
    assert run_both(case)[:2] == ((case["k0"], STOP_END),) * 2
    case = build_case(2, "w")
    case["mode"].e_w[0] = -1.0  # w < 0 already at the first step
    reference, result, *_ = run_both(case)
    assert reference == result == (case["k0"], STOP_LEFT_MODE)


def test_schedule_change_only_counts_after_k0():
    """The class at ``k0`` is the reference (whatever came before): a change right after
    ``k0`` stops the run after one step."""
    case = build_case(5, "end")
    case["step_class"][: case["k0"] + 1] = 9
    reference, result, *_ = run_both(case)
    assert result == reference == (case["k0"] + 1, STOP_SCHEDULE)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_python_fallback_loop(scenario):
    """The same scalar loop uncompiled (what runs without numba) agrees too."""

    def python_loop(cmap: CompiledSparseMap, *rest):
        return run_compiled_sparse(cmap, *rest, use_compiled=False)

    case = build_case(21, scenario, n=10, a=2, inactive=3, steps=60, pivot=True)
    reference, result, (y_ref, cur_ref), (y, cur) = run_both(case, loop=python_loop)
    assert result == reference and reference[1] == case["expected"]
    assert_close(y, y_ref)
    assert_close(cur, cur_ref)


def test_numba_compiled():
    assert sparse_kernel.compiled()


@pytest.mark.parametrize("netlist, theta", [("bridge_rectifier.cir", 1.0), ("buck_converter.cir", 0.5)])
def test_dense_mode_blocks_hold_the_numbers_of_the_sparse_ones(netlist, theta):
    """The dense mode maps slice numpy copies of the step system (a fast path for small
    circuits); the sparse maps slice the scipy matrices: every block of every mode must be
    the same numbers, so the two builders cannot drift apart."""
    import itertools

    import circuitnsds
    from circuitnsds.engine.step_system import mode_blocks, step_system
    from circuitnsds.specs import SourceDefaults
    from tests.conftest import NETLISTS

    circuit = circuitnsds.read_netlist(NETLISTS / netlist)
    mlcs = circuit.mlcs(SourceDefaults(1e-6, 1e-3))
    for states in itertools.product((False, True), repeat=len(mlcs.switches)):
        system = step_system(mlcs, 1e-6, states, theta)
        for active in itertools.product((False, True), repeat=min(mlcs.m, 6)):
            mask = np.zeros(mlcs.m, dtype=bool)
            mask[:len(active)] = active
            sparse, dense = mode_blocks(system, mask), mode_blocks(system, mask, dense=True)
            for name in ("bordered", "carry", "S_next", "S_now", "W"):
                assert isinstance(getattr(dense, name), np.ndarray)
                np.testing.assert_array_equal(getattr(dense, name), getattr(sparse, name).toarray())
            for name in ("rhs_pairs", "e_w", "active", "inactive"):
                np.testing.assert_array_equal(getattr(dense, name), getattr(sparse, name))
