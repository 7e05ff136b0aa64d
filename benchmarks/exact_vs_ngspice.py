"""The exact integrator against ngspice 39, whole processes, on issue 31's long runs: the
closed-loop bucks over 100 ms (10,000 switching periods) and the three-phase sine-PWM
inverter over 400 ms (20 line cycles).

Ours is ``python benchmarks/exact_run.py NETLIST --stop S`` (start-up, parsing, operating
point, the exact run on the ``.tran`` grid with every unknown kept in memory; no file
written), until ``.options method=exact`` reaches ``circuitnsds run``. ngspice's is
``ngspice -b -r out.raw`` on the netlist as ``circuitnsds compare`` translates it (the
idealised-diode parameters dropped: its Shockley diode), with ``.tran`` stretched to ``S``
(start-up, parsing and writing every vector at its own time points). The table: wall
seconds of each, ngspice / ours, the exact run's segments (pieces between events and
source corners) and events, and the exact run's own µs per segment (its in-process time:
start-up and parsing excluded). ``--fraction 0.1`` runs a tenth of each stop.

Usage: ``PYTHONPATH=$PWD python benchmarks/exact_vs_ngspice.py [--fraction 1] [--only X.cir ...]``
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from circuitnsds.compare.translate import translate_netlist

ROOT = Path(__file__).resolve().parent.parent
CASES = [("buck_voltage_mode.cir", 0.1), ("buck_peak_current.cir", 0.1), ("buck_hysteretic.cir", 0.1),
         ("inverter_three_phase.cir", 0.4)]


def ours(path: Path, stop: float, timeout: float) -> tuple[float, dict]:
    """Wall seconds of the whole process, and what it printed."""
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    start = time.perf_counter()
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "exact_run.py"), str(path),
                           "--stop", repr(stop)], capture_output=True, text=True, timeout=timeout,
                          env=environment)
    seconds = time.perf_counter() - start
    if done.returncode:
        return seconds, {"failed": (done.stderr.strip().splitlines() or ["?"])[-1][:80]}
    return seconds, json.loads(done.stdout.strip().splitlines()[-1])


def ngspice(path: Path, stop: float, timeout: float) -> float | None:
    """Wall seconds of ``ngspice -b``, or ``None`` when it failed."""
    with tempfile.TemporaryDirectory() as scratch:
        deck = Path(scratch) / "deck.cir"
        deck.write_text(translate_netlist(path, stop=stop).text)
        start = time.perf_counter()
        done = subprocess.run(["ngspice", "-b", "-r", str(Path(scratch) / "out.raw"), str(deck)],
                              capture_output=True, text=True, timeout=timeout)
        seconds = time.perf_counter() - start
    output = done.stdout + done.stderr
    return None if done.returncode or "too small" in output.lower() else seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fraction", type=float, default=1.0, help="run this fraction of each stop")
    parser.add_argument("--only", nargs="*", help="netlists to run (default: all)")
    parser.add_argument("--timeout", type=float, default=1800.0)
    args = parser.parse_args()
    print(f"{'netlist':<26} {'stop':>6} {'ours s':>8} {'ngspice s':>9} {'ratio':>6} "
          f"{'segments':>8} {'events':>7} {'µs/segment':>10}")
    for name, stop in CASES:
        if args.only and name not in args.only:
            continue
        path = ROOT / "netlists" / name
        stop *= args.fraction
        seconds, result = ours(path, stop, args.timeout)
        theirs = ngspice(path, stop, args.timeout)
        spice = f"{theirs:>9.2f}" if theirs is not None else f"{'failed':>9}"
        if "failed" in result:
            print(f"{name:<26} {stop:>6.3g} {'failed':>8} {spice}  {result['failed']}")
            continue
        ratio = f"{theirs / seconds:>6.2f}" if theirs is not None else f"{'-':>6}"
        print(f"{name:<26} {stop:>6.3g} {seconds:>8.2f} {spice} {ratio} {result['segments']:>8} "
              f"{result['events']:>7} {1e6 * result['seconds'] / result['segments']:>10.0f}")


if __name__ == "__main__":
    main()
