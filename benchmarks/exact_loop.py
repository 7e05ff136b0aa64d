"""Cost of the exact integrator's event loop itself, C (``_exact_native.c``) against numba
(``loop.py``): µs per output row and µs per segment (issue 31 asks ≤ 0.15 µs per row and
≤ 5 µs per segment for the bucks).

Each case runs :func:`circuitnsds.engine.exact.run.run_exact` from its operating point twice
per loop: on the ``.tran`` grid (rows dominate) and on every ``--sparse``-th row of it
(segments dominate: the same segments, events and loop calls). Timed: the thread CPU time
inside the loop's calls only (``run._native_call`` for C, ``run.exact_loop`` for numba; not the
Python choosing new modes, not the system's set-up), the median of ``--repeat`` runs after one
warm-up run (numba's compile or cache load is not counted). µs per segment = sparse time /
segments; µs per row = (dense time − sparse time) / (dense rows − sparse rows). The dense
time also pays the kernel's first touch of the output arrays (they are allocated per run).

Usage: ``PYTHONPATH=$PWD python benchmarks/exact_loop.py [--repeat 5] [--fraction 0.1] [--only X.cir ...]``
(``PYTHONPATH=<another tree> ... --loops numba`` measures that tree's numba loop, e.g. before the C loop.)
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from pathlib import Path

import circuitnsds
from circuitnsds.analyses.operating_point import operating_point, uic_state
from circuitnsds.engine.exact import run as exact_run

ROOT = Path(__file__).resolve().parent.parent
CASES = [("netlists/buck_voltage_mode.cir", 0.1), ("netlists/buck_peak_current.cir", 0.1),
         ("netlists/buck_hysteretic.cir", 0.1), ("benchmarks/netlists/inverter_three_phase.cir", 0.4),
         ("benchmarks/netlists/buck_100ms.cir", 0.1)]


def prepared(path: Path, stop: float, every: int):
    """``(arguments of run_exact, rows)`` on every ``every``-th row of the ``.tran`` grid."""
    import numpy as np

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuitnsds.read_netlist(path)
        tran = circuit.analyses["tran"]
        mlcs = circuit.mlcs()
        state = uic_state(circuit, mlcs) if tran.uic else operating_point(circuit, mlcs)
    times = np.arange(round(stop / tran.step / every) + 1) * tran.step * every
    active = np.zeros(mlcs.m, bool) if state.active is None else np.asarray(state.active, bool)
    return (mlcs, times, state.y, active, tuple(state.switches)), times.size


def loop_seconds(arguments, which: str, repeat: int) -> tuple[float, int]:
    """Median thread CPU seconds inside the loop's calls, and the segments."""
    spent = [0.0]
    name = "_native_call" if which == "C" else "exact_loop"
    original = getattr(exact_run, name)
    native_loop = getattr(exact_run, "native_loop", None)  # (None: a tree from before the C loop)

    def timed(*args):
        start = time.thread_time()
        try:
            return original(*args)
        finally:
            spent[0] += time.thread_time() - start

    setattr(exact_run, name, timed)
    if which != "C" and native_loop is not None:
        exact_run.native_loop = lambda: None
    try:
        system = exact_run.ExactSystem(arguments[0])
        exact_run.run_exact(*arguments, system=system)  # (warm-up: numba's load, the modes)
        runs = []
        for _ in range(repeat):
            spent[0] = 0.0
            result = exact_run.run_exact(*arguments, system=system)
            runs.append(spent[0])
    finally:
        setattr(exact_run, name, original)
        if native_loop is not None:
            exact_run.native_loop = native_loop
    return statistics.median(runs), result.segments


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--fraction", type=float, default=0.1, help="run this fraction of each stop")
    parser.add_argument("--sparse", type=int, default=1000, help="the sparse grid takes every N-th row")
    parser.add_argument("--loops", nargs="*", default=["C", "numba"])
    parser.add_argument("--only", nargs="*", help="netlists to run (default: all)")
    args = parser.parse_args()
    if "C" in args.loops and getattr(exact_run, "native_loop", lambda: None)() is None:
        raise SystemExit("the C loop is not built (python setup.py build_ext --inplace)")
    print(f"{'netlist':<46} {'stop':>6} {'loop':>5} {'rows':>9} {'segments':>9} {'dense s':>8} "
          f"{'sparse s':>8} {'µs/row':>7} {'µs/seg':>7}")
    for name, stop in CASES:
        if args.only and Path(name).name not in args.only:
            continue
        stop *= args.fraction
        dense, rows = prepared(ROOT / name, stop, 1)
        sparse, sparse_rows = prepared(ROOT / name, stop, args.sparse)
        for which in args.loops:
            dense_s, segments = loop_seconds(dense, which, args.repeat)
            sparse_s, _ = loop_seconds(sparse, which, args.repeat)
            per_row = 1e6 * (dense_s - sparse_s) / (rows - sparse_rows)
            print(f"{name:<46} {stop:>6.3g} {which:>5} {rows:>9} {segments:>9} {dense_s:>8.3f} "
                  f"{sparse_s:>8.3f} {per_row:>7.3f} {1e6 * sparse_s / segments:>7.2f}", flush=True)


if __name__ == "__main__":
    main()
