"""Time and peak memory of the inputs of issue 37 that used to cost minutes or gigabytes.

Run from the repository root::

    python benchmarks/resources.py [--quick]

Each case runs ``circuitnsds`` in a fresh process (``/usr/bin/time``-like figures from
``resource.getrusage`` of the child): wall time, peak resident memory, exit status.

* ``pulses``: two 10 µs PULSE sources over ``.tran 20n 100`` (5e9 steps): refused. Before
  the step count was checked first, 2.6 GB of breakpoints were listed (24.8 s).
* ``no-load buck``: the buck with ``L1 sw out 1k`` and no load over 200 µs (2,080 steps,
  every blocked step on a face singular in its scaling). Before: 43.6 s (three LPs a step).
* ``info ladder``: ``circuitnsds info`` on an RC ladder of 10,000 sections (2,000 with
  ``--quick``). Before: 209 s and 3.2 GB for 10,000 (the dense well-posedness analysis).
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

ROOT = Path(__file__).resolve().parent.parent


def _ladder(sections: int) -> str:
    lines = [f"RC ladder of {sections} sections", "V1 n0 0 PULSE(0 1 0 1n 1n 5u 10u)"]
    for k in range(sections):
        lines += [f"R{k} n{k} n{k + 1} 1k", f"C{k} n{k + 1} 0 1n"]
    return "\n".join(lines + [".tran 1u 100u", ".end"]) + "\n"


def cases(quick: bool) -> list[tuple[str, str, list[str]]]:
    """``(name, netlist text, command arguments before the netlist)``."""
    buck = (ROOT / "netlists" / "buck_converter.cir").read_text()
    no_load = (buck.replace("L1 sw out 100u", "L1 sw out 1k").replace("Rload out 0 5\n", "")
               .replace(".tran 0.1u 2m", ".tran 0.1u 200u"))
    pulses = ("two pulses\nV1 a 0 PULSE(0 1 0 1n 1n 5u 10u)\nV2 b 0 PULSE(0 1 0 1n 1n 5u 10u)\n"
              "R1 a b 1k\nR2 b 0 1k\n.tran 20n 100\n.end\n")
    sections = 2_000 if quick else 10_000
    return [("pulses", pulses, ["run"]), ("no-load buck", no_load, ["run"]),
            (f"info ladder {sections}", _ladder(sections), ["info"])]


def measure(text: str, command: list[str], folder: Path) -> tuple[float, float, int]:
    """``(wall seconds, peak resident MiB, exit status)`` of ``circuitnsds COMMAND netlist``."""
    netlist = folder / "case.cir"
    netlist.write_text(text)
    arguments = [sys.executable, "-m", "circuitnsds", *command, str(netlist)]
    if command[0] == "run":
        arguments += ["-o", str(folder / "out.csv"), "-q"]
    started = time.perf_counter()
    process = subprocess.Popen(arguments, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               env={**os.environ, "PYTHONPATH": str(ROOT)})
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - started
    return wall, usage.ru_maxrss / 1024, os.waitstatus_to_exitcode(status)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a 2,000-section ladder")
    args = parser.parse_args(argv)
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    print(f"{'case':<20} {'wall [s]':>9} {'peak [MiB]':>11} {'exit':>5}")
    with tempfile.TemporaryDirectory() as folder:
        for name, text, command in cases(args.quick):
            wall, peak, status = measure(text, command, Path(folder))
            print(f"{name:<20} {wall:>9.2f} {peak:>11.0f} {status:>5}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
