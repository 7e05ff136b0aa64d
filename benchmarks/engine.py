"""Wall time of whole transients: circuitnsds (ideal devices) vs ngspice (Shockley), same netlist.

Run from the repository root::

    python benchmarks/engine.py [--repeat 3]

For every netlist in ``netlists/`` it prints the number of steps, circuitnsds's
median wall time for ``Circuit.transient()`` (parsing excluded), its cost per step,
and ngspice's median wall time for ``ngspice -b -r out.raw`` on the same file (process start
and parsing included, measured once without a circuit and shown separately so it
can be subtracted). ngspice is optional: without it that column says so. A failed
ngspice run (e.g. "Timestep too small") is reported, not hidden.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import tempfile
import time
import warnings
from pathlib import Path

import circuitnsds

NETLISTS = Path(__file__).resolve().parent.parent / "netlists"


def time_circuitnsds(path: Path, repeat: int) -> tuple[int, float]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuitnsds.read_netlist(path)
        times, steps = [], 0
        for _ in range(repeat):
            start = time.perf_counter()
            waves = circuit.transient()
            times.append(time.perf_counter() - start)
            steps = int(waves.stats["steps"])
    return steps, statistics.median(times)


def time_ngspice(path: Path, repeat: int) -> tuple[float | None, str]:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        with tempfile.TemporaryDirectory() as scratch:
            # -r makes batch mode run the analyses and write every vector (as our CSV does)
            result = subprocess.run(["ngspice", "-b", "-r", f"{scratch}/out.raw", str(path)],
                                    capture_output=True, text=True, timeout=600)
        times.append(time.perf_counter() - start)
        output = result.stdout + result.stderr
        if "too small" in output.lower() or "error" in output.lower() and result.returncode:
            reason = next((line.strip() for line in output.splitlines()
                           if "too small" in line.lower() or "error" in line.lower()), "failed")
            return None, reason[:60]
    return statistics.median(times), ""


def ngspice_startup(repeat: int) -> float:
    with tempfile.NamedTemporaryFile("w", suffix=".cir", delete=False) as handle:
        handle.write("empty\nR1 a 0 1\nV1 a 0 1\n.op\n.end\n")
    return time_ngspice(Path(handle.name), repeat)[0] or 0.0


def main() -> None:
    parser = argparse.ArgumentParser(description="circuitnsds vs ngspice wall time")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    has_ngspice = shutil.which("ngspice") is not None
    if has_ngspice:
        startup = ngspice_startup(args.repeat)
        print(f"ngspice -b start-up and .op of a 1-resistor circuit: {startup * 1e3:.0f} ms "
              "(included in the ngspice column)")
    else:
        print("ngspice not found (apt-get install ngspice): only circuitnsds is timed")
    print(f"{'netlist':24} {'steps':>6} {'ours [ms]':>10} {'us/step':>8} {'ngspice [ms]':>13}")
    for path in sorted(NETLISTS.glob("*.cir")):
        steps, ours = time_circuitnsds(path, args.repeat)
        if has_ngspice:
            theirs, failure = time_ngspice(path, args.repeat)
            spice = f"{theirs * 1e3:13.0f}" if theirs is not None else f"  FAILED: {failure}"
        else:
            spice = f"{'-':>13}"
        print(f"{path.stem:24} {steps:6d} {ours * 1e3:10.1f} {ours / steps * 1e6:8.1f} {spice}")


if __name__ == "__main__":
    main()
