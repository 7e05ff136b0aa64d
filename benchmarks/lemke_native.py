"""Lemke's pivoting in C (``circuitnsds_lemke``, circuitnsds/solvers/_lu_native.c) against the
Python loop it replaces (issue 19: a step whose mode is new leaves the compiled mode loop
for an MLCP solve, and Lemke's pivots were numpy calls on tiny arrays); prints two tables.

Table 1, per call (µs, the best of ``--repeats`` rounds of many calls) on random P-matrix
LCPs (``p_matrix(n, "pd")``, ``q`` with half the pairs active) for n = 2 … 64 and, above
``lemke.NATIVE_MAX`` where ``lemke_pivot`` pivots in Python, 128 and 256 (the loop alone):

* ``lemke_pivot`` whole (scaling, loop, answer) with the C loop and with the Python loop;
* ``LemkeTableau.pivot`` with the C loop: the MLCP solver's path, which keeps the scaling
  of ``M̂`` per start basis;
* the loop alone, C (``_pivot_native``) and Python (``_pivot_python``), on the same tableau.

Table 2, in-process stepping time (``waves.stats['seconds']`` / steps, µs per step) and the
time spent in Lemke per run (the tableau's scaling, the loop, the answer: the steadier figure
on a shared machine), medians of ``--runs`` runs, the three variants interleaved in the same
process, for the RF voltage multiplier (benchmarks/netlists/rf_multiplier.cir, 16 pairs) and
the flyback with Coss at θ = 0.5 (benchmarks/netlists/flyback_coss.cir), with the Lemke
calls and pivots of a run: the C loop (the MLCP solver keeps each start basis's scaled
tableau: now), the Python loop with the same kept tableau, and the Python loop with ``M̂``
scaled at every call (before).

Usage: ``python benchmarks/lemke_native.py [--repeats 5] [--runs 5]``.
"""

from __future__ import annotations

import argparse
import importlib
import statistics
import sys
import time
import timeit
import warnings
from contextlib import contextmanager, nullcontext
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import circuitnsds  # noqa: E402
from circuitnsds.solvers import mlcp  # noqa: E402
from circuitnsds.solvers.testing import lcp_with_solution, p_matrix  # noqa: E402

lemke = importlib.import_module("circuitnsds.solvers.lemke")  # (the package exports the function)


def per_call(statement, repeats: int) -> float:
    """Microseconds per call of ``statement`` (a callable): the best of ``repeats`` rounds."""
    timer = timeit.Timer(statement)
    number, _ = timer.autorange()
    return min(timer.repeat(repeats, number)) / number * 1e6


@contextmanager
def python_loop():
    """Lemke pivots in Python inside the block, as without the C library."""
    original = lemke._native_lemke
    lemke._native_lemke = lambda: None
    try:
        yield
    finally:
        lemke._native_lemke = original


def problem(n: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(n)
    M = p_matrix(n, rng, "pd")
    q = lcp_with_solution(M, rng, frac_active=0.5)[0]
    while np.all(q >= 0):  # (no pivot at all otherwise)
        q = lcp_with_solution(M, rng, frac_active=0.5)[0]
    return M, q


def table_per_call(repeats: int) -> None:
    print("Table 1: per call, µs (random P-matrix LCPs; best of", repeats, "rounds)")
    header = ("n", "pivots", "lemke_pivot C", "lemke_pivot Py", "kept tableau C", "loop C", "loop Py",
              "loop Py/C")
    print(" | ".join(header))
    print(" | ".join("---" for _ in header))
    for n in (2, 4, 8, 16, 32, 64, 128, 256):
        print(" | ".join(str(cell) for cell in row(n, repeats)))


def row(n: int, repeats: int) -> tuple:
    """Table 1's row of order ``n``."""
    run = lemke._native_lemke()
    M, q = problem(n)
    pivots = lemke.lemke_pivot(M, q)[2]
    tableau = lemke.LemkeTableau(M)
    T0 = tableau.T0.copy()
    qs = tableau.rs * q
    T0[:, -1] = qs / np.abs(qs).max()
    native_loop = per_call(lambda: lemke._pivot_native(run, T0, 10**6), repeats)
    python_loop_us = per_call(lambda: lemke._pivot_python(T0, 10**6), repeats)
    assert lemke._pivot_native(run, T0, 10**6)[3] == lemke._pivot_python(T0, 10**6)[3] == pivots
    if n <= lemke.NATIVE_MAX:
        whole_c = f"{per_call(lambda: lemke.lemke_pivot(M, q), repeats):.1f}"
        kept = f"{per_call(lambda: tableau.pivot(q), repeats):.1f}"
    else:
        whole_c = kept = "(Python)"
    with python_loop():
        whole_py = per_call(lambda: lemke.lemke_pivot(M, q), repeats)
    return (n, pivots, whole_c, f"{whole_py:.1f}", kept, f"{native_loop:.1f}", f"{python_loop_us:.1f}",
            f"{python_loop_us / native_loop:.1f}")

CIRCUITS = (("RF multiplier, 16 pairs", HERE / "netlists" / "rf_multiplier.cir", 1.0),
            ("flyback Coss, θ = 0.5", HERE / "netlists" / "flyback_coss.cir", 0.5))


VARIANTS = ("C", "Python", "before")
"""Table 2's variants: the C loop with the kept scaling (now), the Python loop with it, and
the Python loop with ``M̂`` scaled at every call (before this change)."""


def table_stepping(runs: int) -> None:
    print(f"\nTable 2: in-process stepping (median of {runs} runs, the variants interleaved): µs per step, "
          "and ms per run in Lemke (scaling, loop, answer)")
    header = ("circuit", "steps", "Lemke calls", "pivots", "µs/step C", "µs/step Python", "µs/step before",
              "Lemke ms C", "Lemke ms Python", "Lemke ms before")
    print(" | ".join(header))
    print(" | ".join("---" for _ in header))
    for name, path, theta in CIRCUITS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            circuit = circuitnsds.read_netlist(path.read_text())
            circuit.transient(theta=theta)  # (compiled code loaded, caches warm)
            per_step: dict[str, list[float]] = {label: [] for label in VARIANTS}
            in_lemke: dict[str, list[float]] = {label: [] for label in VARIANTS}
            for _ in range(runs):
                for label in VARIANTS:
                    with python_loop() if label != "C" else nullcontext(), \
                            scaled_per_call() if label == "before" else nullcontext(), lemke_clock() as clock:
                        waves = circuit.transient(theta=theta)
                    per_step[label].append(1e6 * waves.stats["seconds"] / waves.stats["steps"])
                    in_lemke[label].append(1e3 * clock["seconds"])
        steps = [f"{statistics.median(per_step[label]):.3f}" for label in VARIANTS]
        spent = [f"{statistics.median(in_lemke[label]):.2f}" for label in VARIANTS]
        counts = [str(waves.stats["steps"]), str(clock["calls"]), str(clock["pivots"])]
        print(" | ".join([name, *counts, *steps, *spent]))


@contextmanager
def scaled_per_call():
    """Inside the block the MLCP solver scales ``M̂`` at every Lemke call (a new
    ``LemkeTableau`` each time), as ``lemke_pivot`` did before the tableau was kept."""
    original = mlcp._StartBasis.lemke
    mlcp._StartBasis.lemke = lambda self: lemke.LemkeTableau(self.Mhat)
    try:
        yield
    finally:
        mlcp._StartBasis.lemke = original


@contextmanager
def lemke_clock():
    """Inside the block the MLCP solver's Lemke work is timed: the start basis's tableau
    (scaled when it is made) and its ``pivot``; yields ``{"seconds", "calls", "pivots"}``."""
    record = {"seconds": 0.0, "calls": 0, "pivots": 0}
    tableau, pivot = mlcp._StartBasis.lemke, lemke.LemkeTableau.pivot

    def timed_tableau(self):
        started = time.perf_counter()
        try:
            return tableau(self)
        finally:
            record["seconds"] += time.perf_counter() - started

    def timed_pivot(self, q, max_pivots=None):
        started = time.perf_counter()
        try:
            answer = pivot(self, q, max_pivots)
        finally:
            record["seconds"] += time.perf_counter() - started
        record["calls"] += 1
        record["pivots"] += answer[2]
        return answer

    mlcp._StartBasis.lemke, lemke.LemkeTableau.pivot = timed_tableau, timed_pivot
    try:
        yield record
    finally:
        mlcp._StartBasis.lemke, lemke.LemkeTableau.pivot = tableau, pivot


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    if not lemke.native_loaded():
        sys.exit("the C library is not built: python setup.py build_ext --inplace")
    table_per_call(args.repeats)
    table_stepping(args.runs)


if __name__ == "__main__":
    main()
