"""``method=auto`` against ``method=theta`` on the cases of ``benchmarks/performance.py``, whole
processes: the measurement behind the default method (issue 31: the default becomes ``auto``
only if it is not slower than θ there by more than noise).

Each case is the command a user runs (``python -m circuitnsds run NETLIST -o out.csv -q`` and
the case's arguments, as in ``performance.py``'s issue 19 table, and the issue 8 cases with
``--signals v(out)``), on the netlist with ``.options method=theta`` or ``.options
method=auto`` added; the two runs interleaved ``--repeats`` times (the machine's speed drifts
on shared cores), the median wall and CPU seconds of each printed with auto / θ, and which
method auto ran (the run summary's words).

Usage: ``PYTHONPATH=$PWD python benchmarks/method_auto_vs_theta.py [--repeats 3] [--only WORD]``
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

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
CASES = [
    ("buck 100 ms, CSV of v(out)", HERE / "netlists" / "buck_100ms.cir", ["--signals", "v(out)"]),
    ("bridge, CSV + PNG", ROOT / "netlists" / "bridge_rectifier.cir", ["--plot", "{png}"]),
    ("flyback Coss θ=0.5", HERE / "netlists" / "flyback_coss.cir", ["--signals", "v(out)", "--theta", "0.5"]),
    ("flyback Coss θ=1", HERE / "netlists" / "flyback_coss.cir", ["--signals", "v(out)", "--theta", "1"]),
    ("boost DCM 60 ms", HERE / "netlists" / "boost_dcm_60ms.cir", ["--signals", "v(out)"]),
    ("RF multiplier 16 pairs", HERE / "netlists" / "rf_multiplier.cir", ["--signals", "v(out)"]),
    ("bridge 470 uF 200 ms", HERE / "netlists" / "bridge_200ms.cir", ["--signals", "v(out)"]),
    ("CW x5 1 s", HERE / "netlists" / "cw5_1s.cir", ["--signals", "v(out)"]),
]


def with_method(text: str, method: str) -> str:
    """The netlist with ``.options method=...`` before its ``.end``."""
    lines = text.splitlines()
    end = max((k for k, line in enumerate(lines) if line.strip().lower() == ".end"), default=len(lines))
    return "\n".join([*lines[:end], f".options method={method}", *lines[end:]]) + "\n"


def timed(command: list[str], cwd: Path) -> tuple[float, float, subprocess.CompletedProcess]:
    """Wall and CPU (user + system) seconds of a child process."""
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    done = subprocess.run(command, cwd=cwd, capture_output=True, text=True, check=False, env=environment)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, done


def which(stderr: str) -> str:
    """The method a run used, from its summary and notes."""
    if "exact segments" in stderr:
        return "exact"
    return "theta"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--only", help="the cases whose label contains this")
    args = parser.parse_args()
    print(f"{'case':<28} {'θ wall':>7} {'auto wall':>9} {'ratio':>6} {'θ CPU':>7} {'auto CPU':>8} "
          f"{'ratio':>6}  auto ran")
    with tempfile.TemporaryDirectory() as scratch:
        workdir = Path(scratch)
        for label, netlist, extra in CASES:
            if args.only and args.only.lower() not in label.lower():
                continue
            figures: dict[str, list[tuple[float, float]]] = {"theta": [], "auto": []}
            ran, failed = "", ""
            for _ in range(args.repeats):
                for method in ("theta", "auto"):
                    path = workdir / f"{method}.cir"
                    path.write_text(with_method(netlist.read_text(), method))
                    arguments = [a.replace("{png}", str(workdir / "out.png")) for a in extra]
                    wall, cpu, done = timed([sys.executable, "-m", "circuitnsds", "run", str(path), "-o",
                                             str(workdir / "out.csv"), *arguments], workdir)
                    if done.returncode:
                        failed = f"{method} failed: {done.stderr.strip()[-100:]}"
                    figures[method].append((wall, cpu))
                    if method == "auto":
                        ran = which(done.stderr)
            theta, auto = (np.median(np.array(figures[m]), axis=0) for m in ("theta", "auto"))
            print(f"{label:<28} {theta[0]:>7.2f} {auto[0]:>9.2f} {auto[0] / theta[0]:>6.2f} {theta[1]:>7.2f} "
                  f"{auto[1]:>8.2f} {auto[1] / theta[1]:>6.2f}  {failed or ran}")


if __name__ == "__main__":
    main()
