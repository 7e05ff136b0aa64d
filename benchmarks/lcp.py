"""Timing of the LCP solvers: Lemke, semismooth Newton, and a cache-hit mode-reuse solve.

Run:  PYTHONPATH=. python benchmarks/lcp.py [--quick]

Test problems: ``M`` positive definite and non-symmetric (``G Gᵀ/n + S/√n + 0.1 I``,
``S`` skew) and positive semidefinite of rank n/2; ``q`` built from a known
solution in which about half of the pairs are active. Each timing is the median
of repeated solves of the same problem. "hit" is ``MLCPSolver.solve`` (with no
free unknowns) when the guessed active set is right and its factorisation is
already cached, i.e. what a time step costs between switching instants.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from circuitnsds.solvers import MLCPSolver, solve_lcp
from circuitnsds.solvers.testing import lcp_with_solution, monotone_mlcp, p_matrix, psd_matrix

SIZES = (2, 5, 10, 20, 50, 100, 200)
MLCP_SIZES = ((5, 1), (20, 4), (50, 10), (100, 20), (200, 50))


def median_time(
    fn: Callable[[], object], budget: float, min_reps: int = 5, max_reps: int = 2000
) -> float:
    """Median wall time of ``fn()`` over repetitions filling about ``budget`` seconds."""
    times: list[float] = []
    start = time.perf_counter()
    while len(times) < max_reps and (len(times) < min_reps or time.perf_counter() - start < budget):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def bench(n: int, kind: str, rng: np.random.Generator, budget: float) -> dict[str, float]:
    M = p_matrix(n, rng, "pd") if kind == "pd" else psd_matrix(n, rng, rank=max(1, n // 2))
    while True:  # a mix of active and inactive pairs
        q, _, act = lcp_with_solution(M, rng, frac_active=0.5)
        if 0 < act.sum() < n:
            break
    ref = solve_lcp(M, q, method="lemke")
    newt = solve_lcp(M, q, method="newton")
    solver = MLCPSolver(np.zeros((0, 0)), np.zeros((0, n)), np.zeros((n, 0)), M)
    empty = np.zeros(0)
    hit = solver.solve(empty, q, guess=ref.active)
    assert hit.method == "direct" and hit.iterations == 0
    assert np.allclose(hit.z, ref.z, atol=1e-8 * (1 + np.abs(ref.z).max()))
    guess = hit.active
    return {
        "lemke": median_time(lambda: solve_lcp(M, q, method="lemke"), budget),
        "pivots": ref.iterations,
        "newton": median_time(lambda: solve_lcp(M, q, method="newton"), budget),
        "newton_it": newt.iterations,
        "hit": median_time(lambda: solver.solve(empty, q, guess=guess), budget),
        "active": int(ref.active.sum()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter timing budget")
    args = parser.parse_args()
    budget = 0.05 if args.quick else 0.3
    rng = np.random.default_rng(20240601)
    header = (
        f"{'kind':>4} {'n':>4} {'active':>6} | {'lemke [ms]':>10} {'pivots':>6} | "
        f"{'newton [ms]':>11} {'iters':>5} | {'hit [us]':>8} | {'lemke/hit':>9}"
    )
    print(header)
    print("-" * len(header))
    for kind in ("pd", "psd"):
        for n in SIZES:
            r = bench(n, kind, rng, budget)
            print(
                f"{kind:>4} {n:>4} {r['active']:>6} | {r['lemke'] * 1e3:>10.3f} {r['pivots']:>6} | "
                f"{r['newton'] * 1e3:>11.3f} {r['newton_it']:>5} | {r['hit'] * 1e6:>8.1f} | "
                f"{r['lemke'] / r['hit']:>9.1f}"
            )
    print()
    print("MLCP (monotone, A invertible): MLCPSolver.solve without guess (Schur-complement")
    print("Lemke + bordered solve, Schur complement cached), Newton, and a cache hit")
    header = (
        f"{'n':>4} {'m':>4} {'act':>4} | {'lemke [ms]':>10} {'pivots':>6} | "
        f"{'newton [ms]':>11} | {'hit [us]':>8} | {'lemke/hit':>9}"
    )
    print(header)
    print("-" * len(header))
    for n, m in MLCP_SIZES:
        r = bench_mlcp(n, m, rng, budget)
        print(
            f"{n:>4} {m:>4} {r['active']:>4} | {r['lemke'] * 1e3:>10.3f} {r['pivots']:>6} | "
            f"{r['newton'] * 1e3:>11.3f} | {r['hit'] * 1e6:>8.1f} | "
            f"{r['lemke'] / r['hit']:>9.1f}"
        )


def bench_mlcp(n: int, m: int, rng: np.random.Generator, budget: float) -> dict[str, float]:
    A, C, D, B, a, b = monotone_mlcp(n, m, rng, singular_a=False)
    solver = MLCPSolver(A, C, D, B)
    first = solver.solve(a, b)
    hit = solver.solve(a, b, guess=first.active)
    assert hit.method == "direct"
    guess = hit.active

    def lemke_fallback() -> object:  # what a switching step costs: Lemke on M + bordered solve
        return solver.solve(a, b)

    return {
        "lemke": median_time(lemke_fallback, budget),
        "pivots": first.iterations,
        "newton": median_time(lambda: solver.solve_newton(a, b), budget),
        "hit": median_time(lambda: solver.solve(a, b, guess=guess), budget),
        "active": int(first.active.sum()),
    }


if __name__ == "__main__":
    main()
