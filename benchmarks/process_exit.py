"""How long a ``circuitnsds`` process takes to exit once its command is done (issue 19).

The bundled bridge's ``run -o bridge.csv --plot bridge.png`` runs in a fresh process that
prints the clock when the command returns; the clock is read again here when the process
has ended. The difference is the interpreter's exit: atexit handlers, joining threads,
clearing modules and collecting what is left. Three ways, interleaved, ``--repeats`` times:

* ``main()``: the command alone;
* ``program()``: the command as the console script runs it, then ``gc.freeze()``;
* ``import numpy`` alone, the floor every process with numpy pays.

Usage: ``python benchmarks/process_exit.py [--repeats 15]``. Prints the median and minimum
milliseconds of each.
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

BRIDGE = Path(__file__).resolve().parents[1] / "netlists" / "bridge_rectifier.cir"

DRIVER = """
import sys, time
from circuitnsds.cli.main import main, program
sys.argv = ["circuitnsds", "run", {netlist!r}, "-o", "bridge.csv", "--plot", "bridge.png", "-q"]
status = {call}
print(repr(time.time()), file=sys.stderr)
"""

FLOOR = "import sys, time, numpy; print(repr(time.time()), file=sys.stderr)"


def exit_time(code: str, folder: str) -> float:
    """Seconds from the clock the process printed last to its end."""
    environment = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    done = subprocess.run([sys.executable, "-c", code], cwd=folder, capture_output=True, text=True,
                          check=True, env=environment)
    ended = time.time()
    return ended - float(done.stderr.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()
    ways = {"main() (the command alone)": DRIVER.format(netlist=str(BRIDGE), call="main(sys.argv[1:])"),
            "program() (then gc.freeze())": DRIVER.format(netlist=str(BRIDGE), call="program()"),
            "python -c 'import numpy'": FLOOR}
    times: dict[str, list[float]] = {name: [] for name in ways}
    with tempfile.TemporaryDirectory() as folder:
        for code in ways.values():  # the .pyc files written, the files cached
            exit_time(code, folder)
        for _ in range(args.repeats):  # interleaved: the machine's drift hits every way alike
            for name, code in ways.items():
                times[name].append(exit_time(code, folder))
    print(f"exit of the bridge's run -o bridge.csv --plot bridge.png ({args.repeats} runs each)\n")
    print(f"{'process':32} {'median [ms]':>11} {'min [ms]':>9}")
    for name, values in times.items():
        print(f"{name:32} {statistics.median(values) * 1e3:11.1f} {min(values) * 1e3:9.1f}")


if __name__ == "__main__":
    main()
