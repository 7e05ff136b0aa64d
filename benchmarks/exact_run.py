"""One whole-process run of the exact integrator on a netlist, for
``benchmarks/exact_vs_ngspice.py`` (until ``.options method=exact`` reaches the command
line, the benchmark times this script): read the netlist, start from its operating point
(or UIC), run :func:`~circuitnsds.engine.exact.run.run_exact` on the ``.tran`` grid up to
``--stop``, and print one JSON line: segments, events, rows and the seconds of the run itself.

Usage: ``PYTHONPATH=$PWD python benchmarks/exact_run.py NETLIST --stop 0.1``
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np

import circuitnsds
from circuitnsds.analyses.operating_point import operating_point, uic_state
from circuitnsds.engine.exact.run import run_exact


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("netlist")
    parser.add_argument("--stop", type=float, help="stop time [s] (default: the .tran stop)")
    args = parser.parse_args()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuitnsds.read_netlist(args.netlist)
        tran = circuit.analyses["tran"]
        mlcs = circuit.mlcs()
        state = uic_state(circuit, mlcs) if tran.uic else operating_point(circuit, mlcs)
    stop = tran.stop if args.stop is None else args.stop
    times = np.arange(round(stop / tran.step) + 1) * tran.step
    active = np.zeros(mlcs.m, bool) if state.active is None else np.asarray(state.active, bool)
    start = time.perf_counter()
    run = run_exact(mlcs, times, state.y, active, tuple(state.switches))
    seconds = time.perf_counter() - start
    print(json.dumps({"segments": run.segments, "events": len(run.events), "rows": len(run.times),
                      "seconds": seconds}))


if __name__ == "__main__":
    main()
