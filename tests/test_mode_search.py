"""Mode changes found inside the compiled mode loop (``dense_loop._find_mode_scalar``).

When a step leaves its mode, the loop looks for the step's solution among the stored
modes of its class and switch states, but only when the step's LCP is certified to have
exactly one solution (``solvers.uniqueness``), and it hands the step to the MLCP solver
when the mode it finds has a pair at zero on both sides. Checked here:

* the certificate never certifies a matrix that is not a P-matrix (every principal minor
  computed by brute force) and certifies the positive definite ones;
* on random P-matrix LCPs, cast as a mode table (one unknown per pair carrying ``q``,
  every active set a mode), the loop started in a wrong mode ends in the mode of the
  solution that enumeration (and Lemke) find, compiled and in Python alike;
* on degenerate LCPs (a pair with ``z = w = 0``) and on uncertified tables it does not
  pick: the step is left to the MLCP solver;
* a ringing flyback and a 16-diode voltage multiplier change modes inside the loop and
  agree with ``stepping="mlcp"`` (every step solved by the MLCP solver) to rounding.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import circuitnsds
from circuitnsds.engine.dense_loop import (
    STOP_END,
    STOP_LEFT_MODE,
    FreeSwitches,
    ModeMap,
    ModeTable,
    run_table,
)
from circuitnsds.engine.integrate import integrate
from circuitnsds.engine.timegrid import time_grid
from circuitnsds.solvers import MLCPSolver, enumerate_lcp, solve_lcp
from circuitnsds.solvers.testing import lcp_with_solution, p_matrix, psd_matrix
from circuitnsds.solvers.uniqueness import certified_p_matrix

SETTINGS = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
BENCH = Path(__file__).parents[1] / "benchmarks" / "netlists"


def all_minors_positive(M: np.ndarray) -> bool:
    m = M.shape[0]
    return all(np.linalg.det(M[np.ix_(s, s)]) > 0.0
               for r in range(1, m + 1) for s in itertools.combinations(range(m), r))


@SETTINGS
@given(m=st.integers(1, 6), seed=st.integers(0, 2**32 - 1),
       kind=st.sampled_from(["pd", "diagdom", "triangular", "psd", "singular", "random"]))
def test_certificate_only_for_p_matrices(m: int, seed: int, kind: str) -> None:
    rng = np.random.default_rng(seed)
    if kind in ("pd", "diagdom", "triangular"):
        M = p_matrix(m, rng, kind)
    elif kind == "psd":
        M = psd_matrix(m, rng)
    elif kind == "singular":
        M = psd_matrix(m, rng, rank=m - 1)
    else:
        M = rng.standard_normal((m, m)) + rng.uniform(0, 2) * np.eye(m)
    if certified_p_matrix(M):
        assert all_minors_positive(M)
    if kind == "pd":  # symmetric part G Gᵀ/m + 0.1 I: positive definite by a margin
        assert certified_p_matrix(M)
    if kind == "singular" and m > 1:
        assert not certified_p_matrix(M)


def lcp_table(M: np.ndarray, unique: bool, table: ModeTable | None = None,
              cls: int = 0) -> tuple[ModeTable, dict[bytes, int]]:
    """``LCP(M, q)`` as a mode table (of step class ``cls``): unknowns ``y = q`` (the source
    values of the step's end), one mode per active set ``α``: ``z_α = -M_αα⁻¹ q_α``,
    ``w = q + M[:, α] z_α``."""
    m = M.shape[0]
    table = ModeTable(m, m, m) if table is None else table
    index = {}
    for bits in range(2**m):
        mask = np.array([(bits >> j) & 1 for j in range(m)], dtype=bool)
        act, inact = np.flatnonzero(mask), np.flatnonzero(~mask)
        a = act.size
        inverse = np.linalg.inv(M[np.ix_(act, act)]) if a else np.zeros((0, 0))
        Q1 = np.zeros((m + a, m))
        Q1[:m] = np.eye(m)
        Q1[m:, act] = -inverse
        W = np.zeros((m, m + a))
        order = np.concatenate([inact, act])
        W[np.arange(m), order] = 1.0
        W[:, m:] = M[np.ix_(order, act)]
        resistance = 1.0 / np.diagonal(inverse) if a else np.zeros(0)
        mode = ModeMap(P=np.zeros((m + a, m)), Q1=Q1, Q0=np.zeros((m + a, m)), c=np.zeros(m + a), W=W,
                       e_w=np.zeros(m), resistance=resistance, active=act.astype(np.int64))
        index[mask.tobytes()] = table.add((cls, 0, 0, mask.tobytes()), mode, unique=unique)
    return table, index


def step_once(table: ModeTable, start: int, q: np.ndarray, compiled: bool) -> tuple[int, int, np.ndarray]:
    """One loop step of ``table`` from mode ``start`` with ``q`` the sources at its end:
    ``(steps done, stop reason, mode used)``; the pair currents in the third's row."""
    m = q.size
    y, z = np.zeros((2, m)), np.zeros((2, m))
    F = np.vstack([np.zeros(m), q])
    used = np.zeros(2, dtype=np.int64)
    free = FreeSwitches(np.zeros((0, m)), np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool))
    zeros = np.zeros(1, dtype=np.int64)
    done, reason, last = run_table(table, start, 0, 0, 1, y, z, F, zeros, zeros, 0, free, used,
                                   use_compiled=compiled)
    return done, reason, z[1]


@SETTINGS
@given(m=st.integers(1, 5), seed=st.integers(0, 2**32 - 1), kind=st.sampled_from(["pd", "diagdom"]),
       frac=st.floats(0.0, 1.0), compiled=st.booleans())
def test_loop_finds_the_unique_solution(m: int, seed: int, kind: str, frac: float, compiled: bool) -> None:
    rng = np.random.default_rng(seed)
    M = p_matrix(m, rng, kind)
    q, z_star, active = lcp_with_solution(M, rng, frac_active=frac)
    certified = certified_p_matrix(M)
    table, index = lcp_table(M, unique=certified)
    z_enum = enumerate_lcp(M, q).z
    np.testing.assert_allclose(z_enum, z_star, atol=1e-9 * (1 + np.abs(z_star).max()))
    np.testing.assert_allclose(solve_lcp(M, q, method="lemke").z, z_star,
                               atol=1e-7 * (1 + np.abs(z_star).max()))
    wrong = active.copy()
    wrong[rng.integers(m)] ^= True  # a mode that is not the solution's
    done, reason, z = step_once(table, index[wrong.tobytes()], q, compiled)
    if not certified:  # not certified unique: the MLCP solver decides
        assert (done, reason) == (0, STOP_LEFT_MODE)
        return
    assert (done, reason) == (1, STOP_END)
    np.testing.assert_allclose(z, z_enum, rtol=1e-9, atol=1e-12 * (1 + np.abs(z_star).max()))


@SETTINGS
@given(m=st.integers(1, 4), seed=st.integers(0, 2**32 - 1), compiled=st.booleans())
def test_search_stays_in_the_step_class(m: int, seed: int, compiled: bool) -> None:
    """Modes of another step class (another step size: another LCP) are never taken, even
    when stored first and when their signs would hold."""
    rng = np.random.default_rng(seed)
    M, other = p_matrix(m, rng, "pd"), p_matrix(m, rng, "pd")
    q, z_star, active = lcp_with_solution(M, rng, frac_active=0.5)
    table, _ = lcp_table(other, unique=True, cls=1)
    table, index = lcp_table(M, unique=True, table=table, cls=0)
    wrong = active.copy()
    wrong[rng.integers(m)] ^= True
    done, reason, z = step_once(table, index[wrong.tobytes()], q, compiled)
    if certified_p_matrix(M):
        assert (done, reason) == (1, STOP_END)
        np.testing.assert_allclose(z, z_star, rtol=1e-9, atol=1e-12 * (1 + np.abs(z_star).max()))


@SETTINGS
@given(m=st.integers(2, 5), seed=st.integers(0, 2**32 - 1), compiled=st.booleans())
def test_degenerate_step_is_left_to_the_mlcp_solver(m: int, seed: int, compiled: bool) -> None:
    rng = np.random.default_rng(seed)
    M = p_matrix(m, rng, "pd")
    active = rng.random(m) < 0.5
    z_star = np.where(active, rng.uniform(0.1, 2.0, m), 0.0)
    w_star = np.where(active, 0.0, rng.uniform(0.1, 2.0, m))
    degenerate = int(rng.integers(m))
    z_star[degenerate] = w_star[degenerate] = 0.0  # two active sets give the solution
    q = w_star - M @ z_star
    table, index = lcp_table(M, unique=True)
    # start from a mode wrong at another pair (its sign fails clearly)
    other = (degenerate + 1) % m
    wrong = active.copy()
    wrong[degenerate] = False
    wrong[other] ^= True
    done, reason, _ = step_once(table, index[wrong.tobytes()], q, compiled)
    assert (done, reason) == (0, STOP_LEFT_MODE)


def test_uncertified_table_never_searches() -> None:
    M = np.array([[2.0, 1.0], [1.0, 2.0]])  # a P-matrix, but the table does not say so
    q = np.array([-1.0, 1.0])  # solution: pair 0 active, z0 = 0.5
    table, index = lcp_table(M, unique=False)
    assert step_once(table, index[np.array([False, False]).tobytes()], q, True)[:2] == (0, STOP_LEFT_MODE)
    table, index = lcp_table(M, unique=True)
    done, reason, z = step_once(table, index[np.array([False, False]).tobytes()], q, True)
    assert (done, reason) == (1, STOP_END)
    np.testing.assert_allclose(z, [0.5, 0.0])


def _engine_runs(netlist: Path, stop: float, theta: float, reference: str) -> tuple:
    circuit = circuitnsds.read_netlist(netlist.read_text())
    step = 1e-8 if "flyback" in netlist.name else 1e-10
    mlcs = circuit.mlcs()  # the sources define their own timing
    grid = time_grid(step, stop, mlcs.breakpoints(stop))
    y0 = np.zeros(mlcs.n)
    loop = integrate(mlcs, grid, y0, theta=theta, stepping="compiled")
    if reference == "mlcp":
        return loop, integrate(mlcs, grid, y0, theta=theta, stepping="mlcp")
    # the engine before mode changes were found in the loop: no step certified unique, so the
    # MLCP solver decides every change of mode
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(MLCPSolver, "unique_solutions", lambda self: False)
        return loop, integrate(mlcs, grid, y0, theta=theta, stepping="compiled")


# The flyback agrees with the MLCP solver at every step. The voltage multiplier's diodes
# often sit at zero current and voltage at once (degenerate steps): there the loop keeps a
# mode whose current is -3e-9 A beside milliamperes (within SIGN_TOL) where the MLCP solver
# drops it (dense_loop's docstring), so its trajectory is compared with the engine that
# leaves every change of mode to the MLCP solver, and must equal it to rounding.
@pytest.mark.parametrize(("netlist", "stop", "theta", "reference"),
                         [("flyback_coss.cir", 40e-6, 0.5, "mlcp"),
                          ("rf_multiplier.cir", 40e-9, 1.0, "mlcp decides mode changes")])
def test_mode_changes_in_the_loop_match_the_mlcp_solver(netlist: str, stop: float, theta: float,
                                                        reference: str) -> None:
    loop, other = _engine_runs(BENCH / netlist, stop, theta, reference)
    changes = int((loop.active[2:] != loop.active[1:-1]).any(axis=1).sum())
    # the mode changed far more often than the MLCP solver was called: the loop found them
    assert changes >= 10 and loop.stats["mlcp_steps"] < changes / 2
    assert other.stats["mlcp_steps"] > changes
    assert (loop.active == other.active).all()
    scale = np.abs(other.y).max(axis=0) + 1e-300
    assert (np.abs(loop.y - other.y).max(axis=0) / scale).max() < 1e-9
    current_scale = np.abs(other.current).max() + 1e-300
    assert np.abs(loop.current - other.current).max() / current_scale < 1e-9


def test_solver_certificate_is_not_fooled_by_its_noise_filter() -> None:
    """The MLCP solver zeroes the entries of ``M̂`` below ``1e3·eps`` of its largest (noise
    for Lemke); the certificate must judge the matrix as computed. Three pairs whose block
    ``[[a, b, b], [b, a, b], [b, b, a]]`` (``a = 2.3e-13``, ``b = -2.1e-13``, so
    ``a + 2b < 0``: not a P-matrix, its 3x3 minor is negative) sit beside a pair of size 1;
    the block's off-diagonal entries fall under the filter, leaving a positive diagonal.
    With ``q = (1, 1, 1, 1)·1e-13`` both ``z = 0`` and ``z_{1..3} = 1e-13/|a + 2b|`` solve
    it (before, ``unique_solutions`` certified it and the loop would pick either)."""
    a, b = 2.3e-13, -2.1e-13
    M = np.array([[a, b, b, 0.0], [b, a, b, 0.0], [b, b, a, 0.0], [0.0, 0.0, 0.0, 1.0]])
    assert not all_minors_positive(M)
    q = np.full(4, 1e-13)
    for z in (np.zeros(4), np.array([1, 1, 1, 0]) * 1e-13 / abs(a + 2 * b)):
        w = M @ z + q
        assert (z >= 0).all() and (w >= -1e-25).all() and abs(z @ w) < 1e-25  # two solutions
    solver = MLCPSolver(np.zeros((0, 0)), np.zeros((0, 4)), np.zeros((4, 0)), M)
    assert not solver.unique_solutions()
