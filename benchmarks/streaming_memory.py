"""Peak memory of long runs that write one signal (issue 19: memory bounded by what is saved).

Runs, as whole processes, ``circuitnsds run NETLIST -o out.csv --signals v(out)`` on

* the 1,000-section diode-RC ladder of ``benchmarks/performance.py`` (``ladder_netlist``)
  with a DC source (the diodes keep their mode: the compiled sparse loop all along),
  10 µs steps, ``--steps`` steps (default 500,000; the issue's case is 5,000,000: about
  six minutes of CPU);
* the bundled 100 ms buck converter (1.04M steps);

and prints the peak resident memory of each process (``getrusage`` of the child: the
maximum RSS), its CPU time and wall time, and the CSV's rows and size. ``--tree`` runs
another checkout's package (e.g. ``/work/main``) for a before/after comparison.

Usage: ``python benchmarks/streaming_memory.py [--steps 500000] [--tree PATH]``.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from performance import ladder_netlist  # noqa: E402


def measure(tree: Path, netlist: Path, workdir: Path) -> dict:
    """Run one whole process; its peak RSS [MB], CPU and wall time [s], rows and bytes written."""
    output = workdir / "out.csv"
    code = ("import sys, resource, subprocess; "
            "done = subprocess.run(sys.argv[1:]); "
            "usage = resource.getrusage(resource.RUSAGE_CHILDREN); "
            "print(usage.ru_maxrss, usage.ru_utime, usage.ru_stime); sys.exit(done.returncode)")
    command = [sys.executable, "-c", code, sys.executable, "-m", "circuitnsds", "run", str(netlist),
               "-o", str(output), "--signals", "v(out)", "-q"]
    started = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(tree)))
    wall = time.perf_counter() - started
    if done.returncode != 0:
        return {"error": done.stderr.strip()[-200:]}
    peak_kb, user, system = done.stdout.split()[-3:]
    with open(output, "rb") as handle:
        rows = sum(chunk.count(b"\n") for chunk in iter(lambda: handle.read(1 << 24), b"")) - 1
    return {"peak_mb": int(peak_kb) / 1024, "cpu_s": float(user) + float(system), "wall_s": wall,
            "rows": rows, "mb": output.stat().st_size / 1e6}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=500_000)
    parser.add_argument("--tree", type=Path, default=HERE.parent, help="checkout whose package runs")
    args = parser.parse_args()
    assert resource.RUSAGE_CHILDREN  # POSIX only
    with tempfile.TemporaryDirectory() as name:
        workdir = Path(name)
        ladder = workdir / "ladder.cir"
        ladder.write_text(ladder_netlist(1000, args.steps * 10e-6).replace("SIN(10 1 1k)", "DC 10"))
        cases = [(f"ladder 1,000 sections, DC, {args.steps:,} steps", ladder),
                 ("buck 100 ms (1.04M steps)", HERE / "netlists" / "buck_100ms.cir")]
        print(f"package: {args.tree}; load average {os.getloadavg()[0]:.1f}\n")
        print("| run | peak RSS [MB] | CPU [s] | wall [s] | rows | CSV [MB] |\n|---|---|---|---|---|---|")
        for label, netlist in cases:
            result = measure(args.tree, netlist, workdir)
            if "error" in result:
                print(f"| {label} | failed: {result['error']} | | | | |")
                continue
            print(f"| {label} | {result['peak_mb']:.0f} | {result['cpu_s']:.1f} | {result['wall_s']:.1f} "
                  f"| {result['rows']:,} | {result['mb']:.1f} |")


if __name__ == "__main__":
    main()
