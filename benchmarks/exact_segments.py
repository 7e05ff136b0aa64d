"""Cost per segment of the exact integrator (``circuitnsds/engine/exact/``, issue 31): each
bundled netlist over its ``.tran`` (or the stop given), from its operating point, output on
the ``.tran`` grid; segments (pieces between events and source corners), events, seconds,
µs per segment, best of ``--repeat`` runs in one process. ``--profile`` adds cProfile's
headline (top functions by own time) for the first case run.

Usage: ``PYTHONPATH=$PWD python benchmarks/exact_segments.py [--repeat 3] [--profile] [--only X.cir ...]``
(with ``PYTHONPATH`` at another tree it measures that tree's exact core, e.g. before a change).
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time
import warnings
from pathlib import Path

import circuitnsds
from circuitnsds.analyses.operating_point import operating_point, uic_state
from circuitnsds.engine.exact.run import run_exact

# numpy is imported inside the functions, after circuitnsds: one BLAS thread, as the command line
# has it (circuitnsds/_blas.py; a threaded BLAS on a busy machine was 2x slower here)

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"
CASES = [("buck_converter.cir", 0.4e-3), ("boost_converter.cir", 2e-3), ("buck_hysteretic.cir", None),
         ("bridge_rectifier.cir", None), ("half_wave_rectifier.cir", None), ("diode_clamp.cir", None)]


def prepared(name: str, stop: float | None):
    """``(run, arguments)``: a callable running the exact core on the netlist ``name``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuitnsds.read_netlist(NETLISTS / name)
        tran = circuit.analyses["tran"]
        mlcs = circuit.mlcs()
        state = uic_state(circuit, mlcs) if tran.uic else operating_point(circuit, mlcs)
    stop = tran.stop if stop is None else stop
    import numpy as np

    times = np.arange(round(stop / tran.step) + 1) * tran.step
    active = np.zeros(mlcs.m, bool) if state.active is None else np.asarray(state.active, bool)
    return lambda: run_exact(mlcs, times, state.y, active, tuple(state.switches)), stop


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--profile", action="store_true")
    parser.add_argument("--only", nargs="*", help="netlists to run (default: all)")
    args = parser.parse_args()
    print(f"{'netlist':<26} {'stop':>8} {'segments':>9} {'events':>7} {'s':>7} {'µs/segment':>11}")
    profiled = not args.profile
    for name, stop in CASES:
        if args.only and name not in args.only:
            continue
        run, stop = prepared(name, stop)
        best, result = float("inf"), None
        for _ in range(args.repeat):
            start = time.perf_counter()
            result = run()
            best = min(best, time.perf_counter() - start)
        print(f"{name:<26} {stop:>8.3g} {result.segments:>9} {len(result.events):>7} {best:>7.3f} "
              f"{1e6 * best / result.segments:>11.0f}")
        if not profiled:
            profiled = True
            profile = cProfile.Profile()
            profile.runcall(run)
            pstats.Stats(profile).sort_stats("tottime").print_stats(8)


if __name__ == "__main__":
    main()
