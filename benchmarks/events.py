"""Cost and accuracy of event location (circuit-controlled switches), and MOSFET circuits
against ngspice.

Run from the repository root::

    python benchmarks/events.py [--repeat 3]

Prints two tables:

1. The hysteretic buck of ``tests/test_events.py`` (W switch on the inductor current
   between 1 A and 2 A, analytic period 38.107 µs) at 25 ... 400 steps per period:
   relative error of the mean period measured from ``waves.events``, wall time, events,
   and solves of the step system per event.
2. The synchronous buck with two vendor VDMOS models (``netlists/mosfet/``):
   circuitnsds's wall time (median of ``--repeat``, parsing excluded) and the share spent
   locating events, against ngspice's (shared library through PySpice, same netlist).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import circuitnsds

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from tests.test_events import hysteretic_buck, hysteretic_period  # noqa: E402


def hysteretic_table(repeat: int) -> None:
    period = hysteretic_period()
    print("hysteretic buck, 10 periods")
    print(f"{'steps/period':>12} {'theta':>5} {'period error':>12} {'seconds':>8} {'events':>6} "
          f"{'solves/event':>12}")
    for theta in (0.5, 1.0):
        for steps in (25, 50, 100, 200, 400):
            circuit = circuitnsds.read_netlist(
                "hysteretic buck\n" + hysteretic_buck(period / steps, 10 * period) + "\n.end\n")
            times = []
            for _ in range(repeat):
                start = time.perf_counter()
                waves = circuit.transient(theta=theta, method="theta")
                times.append(time.perf_counter() - start)
            closings = waves.switchings("w1", True)
            error = abs(np.diff(closings[1:]).mean() - period) / period
            events = waves.stats["events"]
            print(f"{steps:>12} {theta:>5} {error:>12.2e} {statistics.median(times):>8.3f} "
                  f"{events:>6} {waves.stats['event_solves'] / max(events, 1):>12.1f}")


def sync_buck_table(repeat: int) -> None:
    path = ROOT / "netlists" / "mosfet" / "sync_buck_vdmos.cir"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuitnsds.read_netlist(path)
        times = []
        for _ in range(repeat):
            start = time.perf_counter()
            waves = circuit.transient(method="theta")
            times.append(time.perf_counter() - start)
    print(f"\nsynchronous buck (VDMOS), {waves.stats['steps']} steps, {waves.stats['events']} events")
    print(f"{'simulator':>12} {'seconds':>8}")
    print(f"{'circuitnsds':>12} {statistics.median(times):>8.3f}   "
          f"(mapped steps {waves.stats['mapped_seconds']:.3f} s, "
          f"{waves.stats['event_solves']} partial-step solves)")
    try:
        from circuitnsds.compare import run_ngspice
    except ImportError:
        print(f"{'ngspice':>12} {'n/a':>8}   (PySpice not installed)")
        return
    text = path.read_text()
    ng_times = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = run_ngspice(text, ["v(out)", "i(l1)"], 200e-6)
        ng_times.append(time.perf_counter() - start)
    status = "" if result.ok else f"   ({result.status}: {result.message})"
    print(f"{'ngspice':>12} {statistics.median(ng_times):>8.3f}{status}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    hysteretic_table(args.repeat)
    sync_buck_table(args.repeat)


if __name__ == "__main__":
    main()
