"""The exact integrator against ngspice 39, whole processes, through the command line, on
issue 31's long runs: the closed-loop bucks over 100 ms (10,000 switching periods), the
three-phase sine-PWM inverter over 400 ms (20 line cycles) and the open-loop buck over
100 ms (``benchmarks/netlists/``, with the long runs: in ``netlists/`` every test of the
bundled netlists would run them).

Ours is ``python -m circuitnsds run NETLIST --stop S -o out.csv`` on the netlist with
``.options method=exact`` added and ``--signals`` one output (start-up with the package's
bytecode compiled, as after an install; parsing, the operating point, the exact run on the
``.tran`` grid and the signal written to the CSV at every row).
ngspice's is ``ngspice -b -r out.raw`` on the netlist as ``circuitnsds compare`` translates it
(the idealised-diode parameters dropped: its Shockley diode), with ``.tran`` stretched to ``S``
(start-up, parsing and writing every vector at its own time points). The table: wall and CPU
seconds of each whole process and ngspice / ours (the CPU figures are the ones to read on a
shared machine), the exact run's segments (pieces between events and source corners) and events
as the run summary prints them, and the run's own seconds per segment (as the summary times it:
start-up, parsing, the operating point and the CSV excluded; mode building and the rows
included). ``--fraction 0.1`` runs a tenth of each stop; ``--method theta`` runs ours with the
θ-method instead (its steps in place of segments). ``--repeat N`` runs each side N times,
interleaved (ours, ngspice, ours, ...), and prints the medians: on the shared 2-core VM one
run of the inverter's took 0.95 to 1.5 CPU seconds within a minute, so a single pair's ratio
moved by half.

Usage: ``PYTHONPATH=$PWD python benchmarks/exact_vs_ngspice.py [--fraction 1] [--repeat 3] [--only X ...]``
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from circuitnsds.compare.translate import translate_netlist

ROOT = Path(__file__).resolve().parent.parent
CASES = [("netlists/buck_voltage_mode.cir", 0.1, "v(out)"), ("netlists/buck_peak_current.cir", 0.1, "v(out)"),
         ("netlists/buck_hysteretic.cir", 0.1, "v(out)"),
         ("benchmarks/netlists/inverter_three_phase.cir", 0.4, "i(lab)"),
         ("benchmarks/netlists/buck_100ms.cir", 0.1, "v(out)")]
SUMMARY = re.compile(r"(\d+) rows from (\d+) exact segments \((\d+) events located\).* in ([\d.]+) s")
THETA_SUMMARY = re.compile(r"(\d+) θ-method steps.* in ([\d.]+) s")


def timed(command: list[str], timeout: float, **options) -> tuple[float, float, subprocess.CompletedProcess]:
    """``(wall seconds, CPU seconds, result)`` of a child process (its user + system time:
    on a shared machine the wall time also counts the other processes' turns)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, timeout=timeout, **options)
    seconds = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return seconds, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, done


def ours(path: Path, stop: float, signal: str, timeout: float, method: str = "exact"
         ) -> tuple[float, float, dict]:
    """Wall and CPU seconds of the whole ``circuitnsds run`` process, and its summary's figures."""
    # without PYTHONDONTWRITEBYTECODE, as after an install (which writes the .pyc files): with it
    # every process compiled the package's source again, 0.3 s of each figure (performance.py)
    environment = {key: value for key, value in os.environ.items() if key != "PYTHONDONTWRITEBYTECODE"}
    environment["PYTHONPATH"] = str(ROOT)
    with tempfile.TemporaryDirectory() as scratch:
        deck = Path(scratch) / path.name
        lines = path.read_text().splitlines()
        end = max((k for k, line in enumerate(lines) if line.strip().lower() == ".end"), default=len(lines))
        deck.write_text("\n".join([*lines[:end], f".options method={method}", *lines[end:]]) + "\n")
        seconds, cpu, done = timed([sys.executable, "-m", "circuitnsds", "run", str(deck), "--stop",
                                    repr(stop),
                                    "-o", str(Path(scratch) / "out.csv"), "--signals", signal], timeout,
                                   env=environment)
    if done.returncode:
        return seconds, cpu, {"failed": (done.stderr.strip().splitlines() or ["?"])[-1][:80]}
    found = SUMMARY.search(done.stderr)
    if found:
        return seconds, cpu, {"segments": int(found[2]), "events": int(found[3]), "run": float(found[4])}
    found = THETA_SUMMARY.search(done.stderr)
    return seconds, cpu, {"segments": int(found[1]), "events": 0, "run": float(found[2])}


def ngspice(path: Path, stop: float, timeout: float) -> tuple[float, float] | None:
    """Wall and CPU seconds of ``ngspice -b``, or ``None`` when it failed."""
    with tempfile.TemporaryDirectory() as scratch:
        deck = Path(scratch) / "deck.cir"
        deck.write_text(translate_netlist(path, stop=stop).text)
        seconds, cpu, done = timed(["ngspice", "-b", "-r", str(Path(scratch) / "out.raw"), str(deck)],
                                   timeout)
    output = done.stdout + done.stderr
    return None if done.returncode or "too small" in output.lower() else (seconds, cpu)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fraction", type=float, default=1.0, help="run this fraction of each stop")
    parser.add_argument("--only", nargs="*", help="netlists to run (default: all)")
    parser.add_argument("--timeout", type=float, default=1800.0)
    parser.add_argument("--method", default="exact", help="ours with this .options method (default exact)")
    parser.add_argument("--no-ngspice", action="store_true", help="ours only")
    parser.add_argument("--repeat", type=int, default=3, help="runs of each side, interleaved (medians)")
    args = parser.parse_args()
    print(f"{'':<26} {'':>6} {'wall s':^24} {'CPU s':^24}")
    print(f"{'netlist':<26} {'stop':>6} {'ours':>7} {'ngspice':>8} {'ratio':>7} {'ours':>7} {'ngspice':>8} "
          f"{'ratio':>7} {'segments':>8} {'events':>7} {'run µs/segment':>14}")
    for name, stop, signal in CASES:
        path = ROOT / name
        name = path.name
        if args.only and name not in args.only:
            continue
        stop *= args.fraction
        mine, others, runs = [], [], []
        for _ in range(max(1, args.repeat)):
            seconds, cpu, result = ours(path, stop, signal, args.timeout, args.method)
            theirs = (1.0, 1.0) if args.no_ngspice else ngspice(path, stop, args.timeout)
            if "failed" in result or theirs is None:
                break
            mine.append((seconds, cpu))
            others.append(theirs)
            runs.append(result["run"])
        if "failed" in result or theirs is None:
            why = result.get("failed", "ngspice failed")
            print(f"{name:<26} {stop:>6.3g} failed: {why}")
            continue
        seconds, cpu = (statistics.median(values) for values in zip(*mine))
        theirs = tuple(statistics.median(values) for values in zip(*others))
        result["run"] = statistics.median(runs)
        print(f"{name:<26} {stop:>6.3g} {seconds:>7.2f} {theirs[0]:>8.2f} {theirs[0] / seconds:>7.2f} "
              f"{cpu:>7.2f} {theirs[1]:>8.2f} {theirs[1] / cpu:>7.2f} {result['segments']:>8} "
              f"{result['events']:>7} {1e6 * result['run'] / result['segments']:>14.0f}")


if __name__ == "__main__":
    main()
