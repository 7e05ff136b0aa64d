"""What the check of the circuit's own time scales against the step costs a run
(:class:`circuitnsds.analyses.fast_modes.FastModeWatch`, issue 36 item 8): each case's
transient with the check and with it replaced by an observer that does nothing, median of
``--repeat`` runs.

Usage: ``python benchmarks/fast_mode_check.py [--repeat 5]``
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from pathlib import Path

import circuitnsds
import circuitnsds.analyses.transient as transient


class _Idle:
    """An observer that watches nothing and notes nothing."""

    def __init__(self, *args, **kwargs):
        pass

    def observe(self, mlcs, trajectory, first: int) -> None:
        pass

    def report(self) -> None:
        pass


ROOT = Path(__file__).resolve().parent.parent
CASES = [("buck_converter.cir", ROOT / "netlists" / "buck_converter.cir", {}),
         ("flyback_coss.cir, 0.5 ms", ROOT / "benchmarks" / "netlists" / "flyback_coss.cir",
          {"stop": 0.5e-3}),
         ("bridge_rectifier.cir", ROOT / "netlists" / "bridge_rectifier.cir", {})]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    checked = transient.FastModeWatch
    print(f"{'case':28} {'with [ms]':>10} {'without [ms]':>13}")
    for label, path, options in CASES:
        circuit = circuitnsds.read_netlist(path)
        circuit.transient(**options)  # (compiled code loaded, caches warm)
        times: dict[str, list[float]] = {"with": [], "without": []}
        for _ in range(args.repeat):  # interleaved: the machine's drift hits both alike
            for key, check in (("with", checked), ("without", _Idle)):
                transient.FastModeWatch = check
                started = time.perf_counter()
                circuit.transient(**options)
                times[key].append(time.perf_counter() - started)
        transient.FastModeWatch = checked
        print(f"{label:28} {statistics.median(times['with']) * 1e3:>10.1f} "
              f"{statistics.median(times['without']) * 1e3:>13.1f}")


if __name__ == "__main__":
    main()
