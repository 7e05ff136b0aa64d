"""Time per step of the C mode-table loop (``circuitnsds/engine/_dense_native.c``): this
checkout's library against the same file at another git revision, on the same arguments.

Run from the repository root, after ``python setup.py build_ext --inplace``::

    python benchmarks/loop_step.py [--before 21261dd] [--repeat 5]

``--before`` names the revision whose ``_dense_native.c`` is compiled here (into a temporary
directory, with setup.py's flags) as the reference; the default, 21261dd, is the last one
that summed one row at a time. Two tables, medians of ``--repeat``
interleaved runs (before, after, before, after, ...):

* **one unchanged mode**: a synthetic table with one mode of ``n`` unknowns (n = 5, 10, 20,
  40), 2 pairs (one active, one inactive: both sign checks run), 2 sources and a watched
  switch, stepped 50,000 times in one call: µs per unchanged-mode step.
* **whole runs**: the time spent inside the C loop's calls of a whole transient (the
  flyback with Coss at θ = 0.5, the 100 ms buck, the RF multiplier, the bundled XSPICE
  peak-current buck with its 5 watched switches), and the µs per step that makes. The
  waveforms of the two libraries are checked equal bit for bit.
"""

from __future__ import annotations

import argparse
import ctypes
import shutil
import statistics
import subprocess
import sys
import sysconfig
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import circuitnsds
from circuitnsds import native
from circuitnsds.engine import dense_loop
from circuitnsds.engine.dense_loop import FreeSwitches, ModeMap, ModeTable

ROOT = Path(__file__).resolve().parent.parent
SOURCE = "circuitnsds/engine/_dense_native.c"
NETLISTS = ROOT / "benchmarks" / "netlists"
RUNS = (("flyback Coss θ=0.5, 3 ms", NETLISTS / "flyback_coss.cir", {"theta": 0.5}),
        ("buck 100 ms", NETLISTS / "buck_100ms.cir", {}),
        ("RF multiplier, 16 pairs", NETLISTS / "rf_multiplier.cir", {}),
        ("XSPICE peak-current buck", ROOT / "netlists" / "buck_peak_current_xspice.cir", {}))


def build_before(revision: str, scratch: Path):
    """The loop function of ``revision``'s C source, compiled with setup.py's flags."""
    source = scratch / "_dense_native.c"
    source.write_bytes(subprocess.run(["git", "show", f"{revision}:{SOURCE}"], cwd=ROOT, check=True,
                                      capture_output=True).stdout)
    shutil.copy(native.HEADER, scratch / "native.h")
    compiler = (sysconfig.get_config_var("CC") or "cc").split()[0]
    flags = ["-O2", "-ffp-contract=off", "-fno-fast-math"]  # setup.py's
    library = scratch / "_dense_native_before.so"
    subprocess.run([compiler, *flags, "-shared", "-fPIC", f"-I{scratch}",
                    '-DCIRCUITNSDS_SOURCE_DIGEST="before"', str(source), "-o", str(library)], check=True)
    function = ctypes.CDLL(str(library)).circuitnsds_table_loop
    function.argtypes, function.restype = [ctypes.c_void_p] * 4, None
    return function


def one_mode_table(n: int, m: int = 2, kstim: int = 2) -> ModeTable:
    """One mode: pair 0 active (its current positive), pair 1 inactive (its ``w`` positive);
    ``P`` contracting so that the run stays bounded."""
    rng = np.random.default_rng(n)
    rows = n + 1
    c = rng.normal(0, 1, rows)
    c[n:] = 5.0
    e_w = np.array([5.0, 0.0])
    table = ModeTable(n, m, kstim)
    table.add((0, 0, 0, b"one"), ModeMap(
        P=rng.normal(0, 0.3 / n, (rows, n)), Q1=rng.normal(0, 0.1, (rows, kstim)),
        Q0=rng.normal(0, 0.1, (rows, kstim)), c=c, W=rng.normal(0, 0.1 / rows, (m, rows)), e_w=e_w,
        resistance=np.array([1.0]), active=np.array([0], dtype=np.int64)), unique=True)
    return table


def time_one_mode(function, n: int, steps: int) -> float:
    """Seconds for ``steps`` steps of the one-mode table in one call of ``function``."""
    table = one_mode_table(n)
    rng = np.random.default_rng(1)
    y = np.zeros((steps + 1, n))
    z = np.zeros((steps + 1, 2))
    F = rng.normal(0, 1, (steps + 1, 2))
    free = FreeSwitches(rng.normal(0, 1, (1, n)), np.array([1e9]), np.array([-1e9]), np.array([True]))
    used = np.zeros(steps + 1, dtype=np.int64)
    zeros = np.zeros(steps, dtype=np.int64)
    for array in (y, z, used):
        array.fill(0)  # the pages are touched before the clock starts
    start = time.perf_counter()
    done = dense_loop._run_native(function, table, 0, 0, 0, steps, y, z, F, zeros, zeros, 0, free, used)
    elapsed = time.perf_counter() - start
    assert done == (steps, dense_loop.STOP_END, 0), done
    return elapsed


def time_run(function, path: Path, options: dict) -> tuple[float, int, dict]:
    """(seconds inside the C loop's calls, steps, waveforms) of a whole transient."""
    spent = [0.0]

    def timed(*pointers):
        start = time.perf_counter()
        function(*pointers)
        spent[0] += time.perf_counter() - start

    saved = dense_loop._native_function
    dense_loop._native_function = lambda: timed
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            waves = circuitnsds.read_netlist(path).transient(stepping="compiled", method="theta", **options)
    finally:
        dense_loop._native_function = saved
    return spent[0], int(waves.stats["steps"]), {name: waves[name] for name in waves.names}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", default="21261dd", help="git revision of the reference C source")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--steps", type=int, default=50_000, help="steps of the one-mode runs")
    args = parser.parse_args(argv)
    after = dense_loop._native_function()
    if after is None:
        print("the C loop of this checkout is not built: python setup.py build_ext --inplace")
        return 1
    with tempfile.TemporaryDirectory() as scratch:
        before = build_before(args.before, Path(scratch))
        functions = {"before": before, "after": after}
        print(f"C loop, {args.before} ('before') against this checkout ('after'); "
              f"median of {args.repeat}, interleaved\n")
        print(f"one unchanged mode, {args.steps:,} steps in one call, 2 pairs, 2 sources, 1 watched switch")
        print(f"{'n':>4} {'before [µs/step]':>17} {'after [µs/step]':>16} {'ratio':>6}")
        for n in (5, 10, 20, 40):
            times: dict[str, list[float]] = {"before": [], "after": []}
            for _ in range(args.repeat):
                for name, function in functions.items():
                    times[name].append(time_one_mode(function, n, args.steps))
            b, a = (statistics.median(times[name]) / args.steps * 1e6 for name in ("before", "after"))
            print(f"{n:4d} {b:17.3f} {a:16.3f} {b / a:6.2f}")
        print("\nwhole runs: time inside the C loop's calls")
        print(f"{'run':26} {'steps':>9} {'before [ms]':>12} {'after [ms]':>11} {'before µs/step':>15} "
              f"{'after µs/step':>14} {'ratio':>6}")
        for label, path, options in RUNS:
            times = {"before": [], "after": []}
            waves = {}
            for _ in range(args.repeat):
                for name, function in functions.items():
                    spent, steps, waves[name] = time_run(function, path, options)
                    times[name].append(spent)
            for signal, values in waves["before"].items():
                if not np.array_equal(values, waves["after"][signal]):
                    print(f"  {label}: {signal} differs between the two libraries", file=sys.stderr)
                    return 1
            b, a = (statistics.median(times[name]) for name in ("before", "after"))
            print(f"{label:26} {steps:9,d} {b * 1e3:12.1f} {a * 1e3:11.1f} {b / steps * 1e6:15.3f} "
                  f"{a / steps * 1e6:14.3f} {b / a:6.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
