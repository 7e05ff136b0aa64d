"""Cost of the Newton stepper (issue 33) on the netlists with smooth nonlinear elements in
``netlists/smooth/``: accepted steps, Newton iterations per step, µs per iteration and per
step (the whole run, operating point excluded), rejected steps, best of ``--repeat`` runs in
one process.

Usage: ``PYTHONPATH=$PWD python benchmarks/newton_steps.py [--repeat 3] [--only NAME.cir ...]``
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import circuitnsds

NETLISTS = Path(__file__).resolve().parent.parent / "netlists" / "smooth"
CASES = [("multiplier_rectifier.cir", None), ("exponential_source_switch.cir", None),
         ("pfc_boost_acm.cir", 5e-3)]


def measured(name: str, stop: float | None, repeat: int) -> dict:
    """The best of ``repeat`` runs of ``name`` (to ``stop`` [s], else its ``.tran``'s)."""
    best = None
    for _ in range(repeat):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            circuit = circuitnsds.read_netlist(NETLISTS / name)
            started = time.perf_counter()
            waves = circuit.transient(**({} if stop is None else {"stop": stop}))
            wall = time.perf_counter() - started
        stats = dict(waves.stats, wall=wall)
        if best is None or stats["seconds"] < best["seconds"]:
            best = stats
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--only", nargs="*", default=None)
    args = parser.parse_args()
    print(f"{'netlist':32} {'n+m':>5} {'steps':>7} {'it/step':>8} {'µs/it':>7} {'µs/step':>8} "
          f"{'rej.':>5} {'events':>7}")
    for name, stop in CASES:
        if args.only and name not in args.only:
            continue
        s = measured(name, stop, args.repeat)
        steps, iterations = s["steps"], s["newton_iterations"]
        print(f"{name:32} {s['unknowns'] + s['pairs']:5d} {steps:7d} {iterations / steps:8.2f} "
              f"{1e6 * s['newton_seconds'] / iterations:7.0f} {1e6 * s['seconds'] / steps:8.0f} "
              f"{s['rejected_newton'] + s['rejected_lte']:5d} {s['events']:7d}")


if __name__ == "__main__":
    main()
