"""Block principal pivoting (circuitnsds.solvers.pivoting) inside MLCPSolver, for m >= 50 pairs.

For a P-matrix the LCP has exactly one solution, so the answer pivoting finds must be
Lemke's, and it must satisfy complementarity on its own.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.solvers import MLCPSolver
from circuitnsds.solvers.mlcp import PIVOTING_MIN_PAIRS
from circuitnsds.solvers.pivoting import BlockPivoting
from circuitnsds.solvers.testing import p_matrix


def _mixed_problem(rng: np.random.Generator, n: int, m: int, kind: str):
    """A well-posed MLCP: A invertible, the Schur complement B - D A⁻¹ C a P-matrix."""
    A = rng.standard_normal((n, n)) + n * np.eye(n)
    C = rng.standard_normal((n, m)) / n
    D = rng.standard_normal((m, n)) / n
    schur = p_matrix(m, rng, kind)
    B = schur + D @ np.linalg.solve(A, C)
    return A, C, D, B, rng.standard_normal(n), rng.standard_normal(m)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), m=st.integers(PIVOTING_MIN_PAIRS, 90),
       kind=st.sampled_from(["pd", "diagdom", "triangular"]), warm=st.booleans())
def test_pivoting_finds_the_unique_solution(seed, m, kind, warm):
    rng = np.random.default_rng(seed)
    A, C, D, B, a, b = _mixed_problem(rng, 4, m, kind)
    solver = MLCPSolver(A, C, D, B)
    reference = MLCPSolver(A, C, D, B).solve_lemke(a, b)
    guess = (rng.random(m) < 0.5) if warm else None
    result = solver.solve(a, b, guess)
    # complementarity of the answer itself, then uniqueness: Lemke's answer
    z, w = result.z, D @ result.u + B @ result.z + b
    scale = 1.0 + np.abs(z).max() + np.abs(w).max()
    assert np.all(z >= -1e-9 * scale) and np.all(w >= -1e-9 * scale)
    assert np.abs(z * w).max() <= 1e-9 * scale**2
    np.testing.assert_allclose(result.z, reference.z, atol=1e-8 * scale)
    np.testing.assert_allclose(result.u, reference.u, atol=1e-8 * scale)


def test_pivoting_answers_most_problems_without_lemke():
    """The point of the stage: on P-matrix problems it replaces Lemke, not just precedes it."""
    rng = np.random.default_rng(7)
    answered = 0
    for _ in range(20):
        A, C, D, B, a, b = _mixed_problem(rng, 4, 60, "diagdom")
        solver = MLCPSolver(A, C, D, B)
        result = solver.solve(a, b, np.zeros(60, dtype=bool))
        answered += result.method == "direct->pivoting"
    assert answered >= 18


def test_block_rule_switches_to_single_pair_when_it_would_cycle():
    pivoting = BlockPivoting(np.zeros(4, dtype=bool))
    pivoting.update(np.array([0, 2]))
    assert pivoting.mask.tolist() == [True, False, True, False]
    pivoting.update(np.array([0, 2]))  # back to the start: a cycle, so only pair 2 moves
    assert pivoting.mask.tolist() == [True, False, False, False]
    pivoting.update(np.array([1, 3]))  # and from then on, always one pair: the largest index
    assert pivoting.mask.tolist() == [True, False, False, True]


def test_small_problems_do_not_pivot():
    m = PIVOTING_MIN_PAIRS - 1
    rng = np.random.default_rng(3)
    A, C, D, B, a, b = _mixed_problem(rng, 3, m, "pd")
    solver = MLCPSolver(A, C, D, B)
    result = solver.solve(a, b, ~np.zeros(m, dtype=bool))  # all active: wrong for this q
    assert solver.stats["fallbacks"] == 1 and solver.stats["lemke_fallbacks"] == 1
    assert solver.stats["pivoting_solves"] == 0 and result.method == "direct->lemke"
