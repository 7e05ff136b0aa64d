"""The dense LU of :mod:`circuitnsds.solvers.linalg` in C against scipy's LAPACK (issue 19:
small runs without scipy); prints two tables.

Table 1, per call (µs, the best of ``--repeats`` rounds of many calls): ``factorise`` by the
C library and by scipy (``lu_factor`` + ``gecon``, the fallback and what it replaced),
``LU.solve`` with one right-hand side and with ``n + 3`` of them (a mode map's width), and
the bare f2py ``dgetrs`` call the solve replaced, for n = 5, 10, 20, 40; then the same for
large matrices (the C library forced beyond ``NATIVE_MAX``, where scipy takes over).

Table 2, imports in fresh processes (``python -X importtime``): what ``import
circuitnsds.solvers.linalg`` costs itself (the cumulative time of its line: the imports it
triggers), the whole import, and whether scipy ends up loaded (other modules of
``circuitnsds.solvers`` may load it). ``--root`` times another checkout (e.g. a ``git
archive`` of main) for the before/after figures.

Usage: ``python benchmarks/lu_native.py [--repeats 5] [--root PATH]``.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import timeit
from contextlib import contextmanager
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from circuitnsds.solvers import linalg  # noqa: E402


def per_call(statement, repeats: int) -> float:
    """Microseconds per call of ``statement`` (a callable): the best of ``repeats`` rounds."""
    timer = timeit.Timer(statement)
    number, _ = timer.autorange()
    return min(timer.repeat(repeats, number)) / number * 1e6


ROWS = ("factorise, C", "factorise, scipy", "solve 1-D, C", "solve 1-D, scipy", "bare dgetrs 1-D",
        "solve n+3 cols, C", "solve n+3 cols, scipy")


@contextmanager
def scipy_lapack():
    """``linalg.factorise`` by its fallback, scipy's LAPACK, inside the block."""
    original = linalg._native_functions
    linalg._native_functions = lambda: None
    try:
        yield
    finally:
        linalg._native_functions = original


def times_for(n: int, repeats: int) -> dict[str, float]:
    """The :data:`ROWS` for one ``n`` (a random, well-conditioned ``K``)."""
    from scipy.linalg import lapack

    rng = np.random.default_rng(n)
    K = rng.standard_normal((n, n)) + n * np.eye(n)
    b = rng.standard_normal(n)
    B = rng.standard_normal((n, n + 3))
    native = linalg.factorise(K)
    times = {"factorise, C": per_call(lambda: linalg.factorise(K), repeats)}
    with scipy_lapack():
        fallback = linalg.factorise(K)
        times["factorise, scipy"] = per_call(lambda: linalg.factorise(K), repeats)
    assert type(native) is linalg.LU and type(fallback) is not linalg.LU
    times["solve 1-D, C"] = per_call(lambda: native.solve(b), repeats)
    times["solve 1-D, scipy"] = per_call(lambda: fallback.solve(b), repeats)
    times["solve n+3 cols, C"] = per_call(lambda: native.solve(B), repeats)
    times["solve n+3 cols, scipy"] = per_call(lambda: fallback.solve(B), repeats)
    getrs, lu, piv = lapack.dgetrs, fallback.lu, fallback.piv
    times["bare dgetrs 1-D"] = per_call(lambda: getrs(lu, piv, b), repeats)
    return times


def call_table(repeats: int) -> None:
    sizes = (5, 10, 20, 40)
    columns = [times_for(n, repeats) for n in sizes]
    print("per call [µs]       n:" + "".join(f"{n:8d}" for n in sizes))
    for name in ROWS:
        print(f"{name:24s}" + "".join(f"{times[name]:8.2f}" for times in columns))


def crossover_table(repeats: int) -> None:
    """``factorise`` and a 5-column solve of large matrices, C (NATIVE_MAX lifted) and scipy:
    where :data:`circuitnsds.solvers.linalg.NATIVE_MAX` comes from."""
    from scipy.linalg import lapack

    print("\nlarge n [ms]: factorise C / scipy, solve 5 columns C / scipy")
    limit = linalg.NATIVE_MAX
    linalg.NATIVE_MAX = 10**9
    try:
        for n in (60, 100, 200, 400, 1000):
            K = np.random.default_rng(n).standard_normal((n, n)) + np.sqrt(n) * np.eye(n)
            B = np.ones((n, 5))
            native = linalg.factorise(K)
            factor_c = per_call(lambda: linalg.factorise(K), repeats) / 1e3  # noqa: B023
            solve_c = per_call(lambda: native.solve(B), repeats) / 1e3  # noqa: B023
            lu, piv = lapack.dgetrf(K)[:2]
            fallback = linalg._LapackLU(lu, piv, 1.0)
            with scipy_lapack():
                factor_s = per_call(lambda: linalg.factorise(K), repeats) / 1e3  # noqa: B023
            solve_s = per_call(lambda: fallback.solve(B), repeats) / 1e3  # noqa: B023
            print(f"  n = {n:5d}   {factor_c:8.3f} / {factor_s:8.3f}   {solve_c:8.3f} / {solve_s:8.3f}")
    finally:
        linalg.NATIVE_MAX = limit


def import_table(root: Path, repeats: int) -> None:
    script = "import sys, circuitnsds.solvers.linalg; print('scipy' in sys.modules)"
    environment = dict(os.environ, PYTHONPATH=str(root))
    own, total, scipy_loaded = [], [], None
    for _ in range(repeats):
        result = subprocess.run([sys.executable, "-X", "importtime", "-c", script], capture_output=True,
                                text=True, env=environment, cwd=root, check=True)
        scipy_loaded = result.stdout.strip()
        cumulative = {}
        for line in result.stderr.splitlines():
            match = re.match(r"import time:\s+\d+ \|\s+(\d+) \|( *)(\S+)", line)
            if match:
                # a module's first line is its own import; a statement's module comes again
                # at the end, at the top level, with all the statement imported
                cumulative.setdefault(match.group(3), []).append((int(match.group(1)), len(match.group(2))))
        own.append(cumulative["circuitnsds.solvers.linalg"][0][0] / 1e3)
        top_level = [value for lines in cumulative.values() for value, depth in lines if depth == 1]
        total.append(sum(top_level) / 1e3)
    print(f"\nimport circuitnsds.solvers.linalg ({root}), best of {repeats} processes:")
    print(f"  its own line (what it imports) {min(own):7.1f} ms")
    print(f"  all top-level imports          {min(total):7.1f} ms")
    print(f"  scipy loaded afterwards        {scipy_loaded}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--root", type=Path, default=HERE.parent, help="the checkout whose imports are timed")
    arguments = parser.parse_args()
    assert linalg.native_loaded(), "the C LU is not built (python setup.py build_ext --inplace)"
    call_table(arguments.repeats)
    crossover_table(arguments.repeats)
    import_table(arguments.root.resolve(), arguments.repeats)


if __name__ == "__main__":
    main()
