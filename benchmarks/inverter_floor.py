"""How close the three-phase inverter can come to issue 31's 5x ngspice: the whole process's
CPU seconds broken into what no run avoids and what the run itself costs.

One table, each row the median of ``--repeat`` interleaved whole processes (CPU: user +
system of the child; wall beside it):

1. ``python -c pass``: the interpreter alone;
2. ``python -c "import numpy"``: numpy, which every run imports;
3. ``circuitnsds run`` on a three-element RC netlist: the floor of any run (the package's
   imports, parsing, the operating point, a CSV);
4. the inverter over 400 ms with ``.tran 100u``: its 32,000 exact segments, its 116 modes
   and the CSV, with a tenth of the rows;
5. the inverter as benchmarked (``.tran 1u``: 404,000 rows);
6. ngspice on the same inverter (``circuitnsds compare``'s translation), and the CPU budget
   the 5x target leaves: a fifth of it.

Rows 3 to 5 run with ``.options method=exact`` and ``--signals i(lab)``, as
``exact_vs_ngspice.py`` runs them (its ``ours`` and ``ngspice``).

Usage: ``PYTHONPATH=$PWD python benchmarks/inverter_floor.py [--repeat 5]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from exact_vs_ngspice import ROOT, ngspice, ours, timed  # noqa: E402

INVERTER = ROOT / "benchmarks" / "netlists" / "inverter_three_phase.cir"
STOP = 0.4
RC = """RC low-pass: the floor of a run
V1 a 0 DC 1
R1 a b 1k
C1 b 0 1u
.tran 1u 10u
.end
"""


def python(code: str) -> tuple[float, float]:
    """Wall and CPU seconds of ``python -c code`` (bytecode caches as after an install)."""
    environment = {key: value for key, value in os.environ.items() if key != "PYTHONDONTWRITEBYTECODE"}
    seconds, cpu, done = timed([sys.executable, "-c", code], 120.0, env=environment)
    if done.returncode:
        raise SystemExit(f"python -c {code!r} failed: {done.stderr.strip()[-200:]}")
    return seconds, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="interleaved runs of each row (medians)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        rc = Path(scratch) / "rc.cir"
        rc.write_text(RC)
        sparse = Path(scratch) / "inverter_100u.cir"
        sparse.write_text(INVERTER.read_text().replace(".tran 1u 400m uic", ".tran 100u 400m uic"))
        rows = {
            "python alone": lambda: python("pass"),
            "import numpy": lambda: python("import numpy"),
            "run: RC, 10 rows": lambda: ours(rc, 10e-6, "v(b)", 120.0)[:2],
            "run: inverter, .tran 100u": lambda: ours(sparse, STOP, "i(lab)", 600.0)[:2],
            "run: inverter, .tran 1u": lambda: ours(INVERTER, STOP, "i(lab)", 600.0)[:2],
            "ngspice: inverter": lambda: ngspice(INVERTER, STOP, 600.0),
        }
        figures: dict[str, list[tuple[float, float]]] = {name: [] for name in rows}
        for _ in range(max(1, args.repeat)):
            for name, measure in rows.items():
                result = measure()
                if result is None:
                    raise SystemExit(f"{name} failed")
                figures[name].append(result)
    print(f"{'process':<28} {'wall s':>8} {'CPU s':>8}")
    medians = {}
    for name, values in figures.items():
        wall, cpu = (statistics.median(column) for column in zip(*values))
        medians[name] = cpu
        print(f"{name:<28} {wall:>8.3f} {cpu:>8.3f}")
    budget = medians["ngspice: inverter"] / 5
    print(f"{'5x ngspice: CPU budget':<28} {'':>8} {budget:>8.3f}")
    theirs = medians["ngspice: inverter"]
    print(f"ngspice / ours (CPU): .tran 1u {theirs / medians['run: inverter, .tran 1u']:.2f}x, "
          f".tran 100u {theirs / medians['run: inverter, .tran 100u']:.2f}x")


if __name__ == "__main__":
    main()
