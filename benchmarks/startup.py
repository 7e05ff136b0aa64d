"""Where a whole ``circuitnsds`` process spends its time (issue 19: start-up and set-up).

Two tables:

1. **Processes**, as a user runs them: each command as a subprocess, the median of
   ``--repeats`` runs of its wall time and of its CPU time (user + system, this process and
   the children it waited for). CPU time is the figure to compare on a shared machine; wall
   time is what the user waits for (a figure is drawn by a second process, so wall can be
   below CPU). The rows build up: Python alone, each library's import, ``import circuitnsds``,
   reading a netlist, then the bundled bridge rectifier (5,000 steps) and the buck converter
   (1.04M steps) as ``run`` commands.
2. **Set-up of the buck's 1.04M-step run**, in-process, best of ``--repeats``: the time grid,
   the source breakpoints, sampling the sources, the switch schedule, the step classes; then
   numba's import and its loading of the cached loop (a fresh process), against the stepping
   itself (``Waveforms.stats["seconds"]`` of a run that loaded the loop before).

Usage: ``python benchmarks/startup.py [--repeats 5] [--json out.json]``. The processes run
without ``PYTHONDONTWRITEBYTECODE`` (as after an install, which writes the ``.pyc`` files;
with it every process compiles the package's source again, ~0.15 s).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
BRIDGE = ROOT / "netlists" / "bridge_rectifier.cir"
BUCK = HERE / "netlists" / "buck_100ms.cir"


def _environment() -> dict[str, str]:
    """This environment with this checkout's circuitnsds first on the path, as an install
    runs (``.pyc`` files written and used: no ``PYTHONDONTWRITEBYTECODE``)."""
    path = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    env = dict(os.environ, PYTHONPATH=path)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def process(command: list[str], repeats: int, cwd: Path) -> dict:
    """Median wall and CPU seconds of ``command`` (CPU: the process and its waited children)."""
    walls, cpus = [], []
    env = _environment()
    for _ in range(repeats):
        started = time.perf_counter()
        child = subprocess.Popen(command, cwd=cwd, env=env, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE)
        _, status, usage = os.wait4(child.pid, 0)
        walls.append(time.perf_counter() - started)
        cpus.append(usage.ru_utime + usage.ru_stime)
        if status:
            raise RuntimeError(f"{' '.join(command)} failed: {child.stderr.read().decode()[-400:]}")
    return {"wall_s": statistics.median(walls), "cpu_s": statistics.median(cpus)}


def process_rows(repeats: int, workdir: Path) -> list[dict]:
    python = sys.executable
    run = [python, "-m", "circuitnsds", "run"]
    cases = [
        ("python -c pass", [python, "-c", "pass"]),
        ("import numpy", [python, "-c", "import numpy"]),
        ("import scipy.sparse, scipy.linalg", [python, "-c", "import scipy.sparse, scipy.linalg"]),
        ("import numba", [python, "-c", "import numba"]),
        ("import networkx", [python, "-c", "import networkx"]),
        ("import matplotlib.figure (+ Agg)", [python, "-c", "import matplotlib.figure, "
                                              "matplotlib.backends.backend_agg"]),
        ("import PIL (Image, ImageDraw, ImageFont: the PNG figure)",
         [python, "-c", "import PIL.Image, PIL.ImageDraw, PIL.ImageFont"]),
        ("import circuitnsds", [python, "-c", "import circuitnsds"]),
        ("import circuitnsds + read the bridge", [python, "-c", "import circuitnsds; "
                                                  f"circuitnsds.read_netlist({str(BRIDGE)!r})"]),
        ("circuitnsds --help", [python, "-m", "circuitnsds", "--help"]),
        ("bridge: run -o bridge.csv", [*run, str(BRIDGE), "-o", "bridge.csv", "-q"]),
        ("bridge: run -o bridge.csv --plot bridge.png", [*run, str(BRIDGE), "-o", "bridge.csv",
                                                         "--plot", "bridge.png", "-q"]),
        ("buck: run -o out.csv --signals v(out)", [*run, str(BUCK), "-o", "out.csv",
                                                   "--signals", "v(out)", "-q"]),
    ]
    rows = []
    for label, command in cases:
        rows.append({"case": label, **process(command, repeats, workdir)})
        print(f"  {label}: {rows[-1]['wall_s']:.3f} s wall, {rows[-1]['cpu_s']:.3f} s CPU", file=sys.stderr)
    return rows


def _best(function, repeats: int) -> tuple[float, object]:
    times, result = [], None
    for _ in range(repeats):
        started = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - started)
    return min(times), result


NUMBA_LOAD = """
import time
started = time.perf_counter()
import numba  # noqa: F401
imported = time.perf_counter()
from circuitnsds.engine.warmup import warm_dense
warm_dense()  # loads the cached dense loop (the run's signature)
print(imported - started, time.perf_counter() - imported)
"""


def setup_rows(repeats: int) -> list[dict]:
    """The buck's set-up pieces, in-process (see the module docstring)."""
    import circuitnsds
    from circuitnsds.engine import integrate as engine
    from circuitnsds.engine.timegrid import time_grid

    circuit = circuitnsds.read_netlist(BUCK)
    spec = circuit.analyses["tran"]
    step, stop = spec.step, spec.stop
    mlcs = circuit.mlcs(spec.source_defaults)
    rows = []
    seconds, points = _best(lambda: mlcs.breakpoints(stop), repeats)
    rows.append({"case": f"source breakpoints ({points.size:,})", "s": seconds})
    seconds, grid = _best(lambda: time_grid(step, stop, np.append(points, 0.0)), repeats)
    rows.append({"case": f"time grid ({grid.size:,} points)", "s": seconds})
    seconds, sources = _best(lambda: engine._source_values(mlcs, grid), repeats)
    rows.append({"case": "source values (PULSE and DC at every point)", "s": seconds})
    initial = np.zeros(len(mlcs.switches), dtype=bool)
    seconds, _ = _best(lambda: engine._switch_schedule(mlcs, grid, sources, initial), repeats)
    rows.append({"case": "switch schedule (PULSE at every midpoint)", "s": seconds})
    seconds, _ = _best(lambda: engine._sizes_and_classes(np.diff(grid)), repeats)
    rows.append({"case": "step classes", "s": seconds})
    seconds, _ = _best(lambda: engine.GridStepping(mlcs, grid, 1.0, 1e-9, initial), repeats)
    rows.append({"case": "all of the stepping's set-up (GridStepping)", "s": seconds})
    env = _environment()
    loads = [subprocess.run([sys.executable, "-c", NUMBA_LOAD], capture_output=True, text=True,
                            env=env, check=True).stdout.split() for _ in range(repeats)]
    rows.append({"case": "numba import (fresh process)", "s": min(float(a) for a, _ in loads)})
    rows.append({"case": "numba: load the cached loop (first call)", "s": min(float(b) for _, b in loads)})
    circuit.transient(stepping="compiled", signals=["v(out)"])  # loads the loop in this process
    stepping = min(circuit.transient(stepping="compiled", signals=["v(out)"]).stats["seconds"]
                   for _ in range(max(1, repeats // 2)))
    rows.append({"case": f"stepping, compiled ({grid.size - 1:,} steps, in-process)", "s": stepping})
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        processes = process_rows(args.repeats, Path(tmp))
    setup = setup_rows(args.repeats)
    print(f"load average {os.getloadavg()[0]:.1f}, {os.cpu_count()} cores, Python "
          f"{sys.version.split()[0]}; medians of {args.repeats} processes\n")
    print("| command | wall [s] | CPU [s] |\n|---|---|---|")
    for row in processes:
        print(f"| {row['case']} | {row['wall_s']:.3f} | {row['cpu_s']:.3f} |")
    print("\n| buck set-up, in-process (best of repeats) | seconds |\n|---|---|")
    for row in setup:
        print(f"| {row['case']} | {row['s']:.3f} |")
    if args.json:
        args.json.write_text(json.dumps({"processes": processes, "setup": setup}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
