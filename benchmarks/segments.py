"""How many steps a segment of a streamed run should have (``SINK_SEGMENT_STEPS`` of
:mod:`circuitnsds.analyses.transient`): ``run -o out.csv --signals v(out)`` in one process,
each segment size in turn, repeated, the median and minimum of each printed.

A smaller segment lets the CSV writer format a segment while the next is computed, so that
only the last segment's formatting is waited for, and touches less fresh memory; a larger one
pays the per-segment work (switch schedule, source values, bookkeeping) fewer times.

Usage: ``python benchmarks/segments.py [--repeat 12]`` (the flyback at θ = 0.5 and the 1M-step
buck of benchmarks/netlists/).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import circuitnsds.analyses.recorders as recorders
from circuitnsds.cli.main import main as cli

NETLISTS = Path(__file__).parent / "netlists"
CASES = [("flyback θ=0.5", NETLISTS / "flyback_coss.cir", ["--theta", "0.5"]),
         ("buck 100 ms", NETLISTS / "buck_100ms.cir", [])]
SIZES = [2**18, 2**17, 98304, 2**16, 2**15]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=12)
    args = parser.parse_args()
    kept = recorders.SINK_SEGMENT_STEPS
    print(f"{'case':16} {'steps/segment':>13} {'median [ms]':>12} {'min [ms]':>9}")
    with tempfile.TemporaryDirectory() as scratch:
        for label, netlist, extra in CASES:
            command = ["run", str(netlist), "--signals", "v(out)", "-o", str(Path(scratch) / "out.csv"),
                       "-q", *extra]
            cli(command)  # (the compiled code loaded, the files cached)
            times: dict[int, list[float]] = {size: [] for size in SIZES}
            for _ in range(args.repeat):  # interleaved: the machine's drift hits every size alike
                for size in SIZES:
                    recorders.SINK_SEGMENT_STEPS = size
                    started = time.perf_counter()
                    cli(command)
                    times[size].append(time.perf_counter() - started)
            for size in SIZES:
                mark = "  (now)" if size == kept else ""
                print(f"{label:16} {size:13d} {statistics.median(times[size]) * 1e3:12.0f} "
                      f"{min(times[size]) * 1e3:9.0f}{mark}")
    recorders.SINK_SEGMENT_STEPS = kept


if __name__ == "__main__":
    main()
