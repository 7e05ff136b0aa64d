"""What a plain run imports, in two checkouts (issue 19: import only the families a netlist uses).

Runs ``circuitnsds run`` of the flyback with Coss (``θ = 0.5``, ``v(out)`` to a CSV) as a
fresh process with each checkout first on ``PYTHONPATH``, interleaved (one of each, then
again, ``--repeats`` times: this shared machine's speed drifts within minutes), and prints

1. the median wall time of the whole process for each checkout;
2. from ``-X importtime`` of the same runs, the median self/cumulative µs of the modules
   made lazy (``-``: not imported) and of everything under ``circuitnsds``.

Usage: ``python benchmarks/lazy_imports.py --before /path/to/old/checkout [--repeats 7]``
(``--after`` defaults to this checkout). Each checkout needs its C libraries built
(``python setup.py build_ext --inplace``). The processes run without
``PYTHONDONTWRITEBYTECODE``, as after an install.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FLYBACK = ROOT / "benchmarks" / "netlists" / "flyback_coss.cir"
WATCHED = ["circuitnsds.circuit.elements.behavioural", "circuitnsds.circuit.elements.mosfet",
           "circuitnsds.frontend.cards.behavioural", "circuitnsds.frontend.cards.mosfets",
           "circuitnsds.frontend.cards.xspice", "circuitnsds.frontend.cards.xspice_digital",
           "circuitnsds.frontend.cards.xspice_ports", "circuitnsds.netlist.behavioural",
           "circuitnsds.engine.sparse_loop", "circuitnsds.checks.wellposed",
           "circuitnsds.frontend.cards.model_kinds", "circuitnsds.lazy"]


def run(checkout: Path, output: Path) -> tuple[float, dict[str, tuple[int, int]]]:
    """Wall seconds of one run and ``module -> (self µs, cumulative µs)`` of its imports."""
    env = dict(os.environ, PYTHONPATH=str(checkout))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    command = [sys.executable, "-X", "importtime", "-m", "circuitnsds", "run", str(FLYBACK),
               "--signals", "v(out)", "--theta", "0.5", "-o", str(output), "-q"]
    started = time.perf_counter()
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=True,
                          cwd=output.parent)  # (not a checkout: -m puts the cwd first on the path)
    wall = time.perf_counter() - started
    times = {}
    for line in done.stderr.splitlines():
        if line.startswith("import time:") and "|" in line and "self [us]" not in line:
            own, total, name = line.removeprefix("import time:").split("|")
            times[name.strip()] = (int(own), int(total))
    return wall, times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, required=True)
    parser.add_argument("--after", type=Path, default=ROOT)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    checkouts = {"before": args.before.resolve(), "after": args.after.resolve()}
    walls = {key: [] for key in checkouts}
    imports = {key: [] for key in checkouts}
    with tempfile.TemporaryDirectory() as scratch:
        for _ in range(args.repeats):
            for key, checkout in checkouts.items():
                wall, times = run(checkout, Path(scratch) / f"{key}.csv")
                walls[key].append(wall)
                imports[key].append(times)
    print(f"flyback with Coss, θ = 0.5, medians of {args.repeats} interleaved runs\n")
    print("| | before | after |\n|---|---|---|")
    print(f"| whole process [s] | {statistics.median(walls['before']):.3f} | "
          f"{statistics.median(walls['after']):.3f} |")
    package = {key: statistics.median(sum(own for name, (own, _) in times.items()
                                          if name.startswith("circuitnsds"))
                                      for times in runs) for key, runs in imports.items()}
    print(f"| circuitnsds modules, sum of self [ms] | {package['before'] / 1000:.1f} | "
          f"{package['after'] / 1000:.1f} |")
    print("\nself / cumulative µs (-: not imported)\n\n| module | before | after |\n|---|---|---|")
    for module in WATCHED:
        cells = []
        for key in checkouts:
            found = [times[module] for times in imports[key] if module in times]
            cells.append(f"{statistics.median(f[0] for f in found):.0f} / "
                         f"{statistics.median(f[1] for f in found):.0f}" if found else "-")
        print(f"| {module} | {cells[0]} | {cells[1]} |")


if __name__ == "__main__":
    main()
