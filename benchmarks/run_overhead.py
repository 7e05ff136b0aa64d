"""The Python work of a run, before and after a change (issue 19: the flyback with Coss at
θ = 0.5 against ngspice, whole process).

For this checkout and another revision (``--before``, checked out and its C libraries built
in a temporary directory), interleaved (before, after, before, after, ...: this shared
machine's speed drifts within minutes), ``--repeats`` times:

* **in process**: one fresh process imports the modules a run uses (the command line, the
  transient, the engine, the CSV writer, the solvers: :data:`RUN_MODULES`) and runs
  ``run NETLIST -o out.csv --signals v(out) --theta θ`` twice (``circuitnsds.cli.main``): the
  first call pays what a run pays once per process (fresh memory, first calls, the few
  modules imported on first use), the second is the run alone; each time is the whole
  command after the imports (reading the netlist, the transient, the CSV put in place),
  with the minor page faults it took (fresh memory: ~2 µs each on this machine);
* **whole process**: ``python -m circuitnsds run ...`` as a user types it, wall time.

Prints the medians (and the CSV files of the two checkouts are compared: the same bytes).

Usage (from the repository root, after ``python setup.py build_ext --inplace``)::

    python benchmarks/run_overhead.py --before 168213f [--repeats 7] [--theta 0.5]
        [--netlist benchmarks/netlists/flyback_coss.cir]

The processes run without ``PYTHONDONTWRITEBYTECODE``, as after an install.
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FLYBACK = ROOT / "benchmarks" / "netlists" / "flyback_coss.cir"
RUN_MODULES = ("circuitnsds.cli.main", "circuitnsds.cli.sweep", "circuitnsds.frontend.build",
               "circuitnsds.analyses.transient", "circuitnsds.engine.integrate",
               "circuitnsds.output.csvfile", "circuitnsds.solvers.mlcp")
"""What a run imports (most of it), imported before the runs are timed."""
IN_PROCESS = """
import importlib, json, resource, sys, time
started = time.perf_counter()
for name in sys.argv.pop(1).split(","):
    importlib.import_module(name)
from circuitnsds.cli.main import main
imported = time.perf_counter()
times, faults = [], []
for _ in range(2):
    begin, before = time.perf_counter(), resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    assert main(sys.argv[1:]) == 0
    times.append(time.perf_counter() - begin)
    faults.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
print(json.dumps({"imports": imported - started, "first": times[0], "second": times[1],
                  "first_faults": faults[0], "second_faults": faults[1]}))
"""


def checkout(revision: str, scratch: Path) -> Path:
    """``revision`` of this repository as files in ``scratch``, its C libraries built."""
    target = scratch / "before"
    target.mkdir()
    archive = subprocess.run(["git", "archive", revision], cwd=ROOT, check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(target)], input=archive, check=True)
    subprocess.run([sys.executable, "setup.py", "build_ext", "--inplace"], cwd=target, check=True,
                   capture_output=True)
    return target


def environment(tree: Path) -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def command(netlist: Path, output: Path, theta: str) -> list[str]:
    return ["run", str(netlist), "-o", str(output), "--signals", "v(out)", "--theta", theta, "-q"]


def in_process(tree: Path, arguments: list[str], scratch: Path) -> dict[str, float]:
    """Seconds of the imports and of the first and second run in one process."""
    done = subprocess.run([sys.executable, "-c", IN_PROCESS, ",".join(RUN_MODULES), *arguments],
                          env=environment(tree),
                          cwd=scratch, check=True, capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def whole_process(tree: Path, arguments: list[str], scratch: Path) -> float:
    """Wall seconds of ``python -m circuitnsds`` with ``arguments``."""
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "circuitnsds", *arguments], env=environment(tree),
                   cwd=scratch, check=True, capture_output=True)
    return time.perf_counter() - started


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", required=True, help="git revision to compare with")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--theta", default="0.5")
    parser.add_argument("--netlist", type=Path, default=FLYBACK)
    args = parser.parse_args(argv)
    netlist = args.netlist.resolve()
    with tempfile.TemporaryDirectory() as name:
        scratch = Path(name)
        trees = {"before": checkout(args.before, scratch), "after": ROOT}
        runs: dict[str, list[dict[str, float]]] = {key: [] for key in trees}
        for _ in range(args.repeats):
            for key, tree in trees.items():
                output = scratch / f"{key}.csv"
                arguments = command(netlist, output, args.theta)
                measured = in_process(tree, arguments, scratch)
                measured["whole"] = whole_process(tree, arguments, scratch)
                runs[key].append(measured)
        same = filecmp.cmp(scratch / "before.csv", scratch / "after.csv", shallow=False)

    def median(key: str, field: str) -> float:
        return statistics.median(run[field] for run in runs[key])

    print(f"{netlist.name}, θ = {args.theta}, `run -o out.csv --signals v(out)`: medians of "
          f"{args.repeats} interleaved processes; before = {args.before}, after = this checkout\n")
    print("| | before | after | after/before |\n|---|---|---|---|")
    for field, label, scale in (("imports", "imports of the run's modules [ms]", 1e3),
                                ("first", "first run in a process [ms]", 1e3),
                                ("second", "second run in the same process [ms]", 1e3),
                                ("whole", "whole process (`python -m circuitnsds run`) [ms]", 1e3),
                                ("first_faults", "first run: minor page faults", 1),
                                ("second_faults", "second run: minor page faults", 1)):
        before, after = median("before", field), median("after", field)
        print(f"| {label} | {before * scale:.0f} | {after * scale:.0f} | "
              f"{after / before if before else float('nan'):.2f} |")
    print(f"\nCSV files of the two checkouts: {'the same bytes' if same else 'DIFFERENT'}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
