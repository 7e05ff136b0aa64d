"""Duty sweep of the buck converter: serial (in this process) against local Dask workers.

Run from the repository root::

    python benchmarks/sweep.py [--points 40] [--workers 2] [--stop 10m]

Prints one table: the wall time of the 40-point sweep of ``netlists/sweeps/buck_param.cir``
(D from 0.1 to 0.9, measured: mean output and ripple over the last millisecond) run
serially (``workers=0``, no Dask) and on a LocalCluster of N one-thread worker processes
started and closed by the sweep, the ratio of the two, and what the parallel run costs
beyond the work itself. Figures are what this machine gives at the time (other programs
share its cores), so run it twice. A short transient first warms this process (imports,
compiled loops loaded), so that neither run pays that; forked workers (Linux) inherit it.

Columns:

* ``wall [s]``: wall time of ``circuitnsds.sweep`` (cluster start and stop included).
* ``points [s]``: sum of the points' own run times (build + transient + measurements).
* ``first [s]``: the first point of a process (imports and the compiled loop's cache load).
* ``median point [ms]``, ``median CPU [ms]``: wall and CPU time of a point where it ran
  (CPU below wall: the point waited for a core).
* ``overhead/point [ms]``: ``(workers · wall − points) / N``: what each point costs
  beyond its own work (cluster start-up, scheduling, transfers, idle workers), in
  worker-time.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

import circuitnsds
from circuitnsds.values import parse_value

NETLIST = Path(__file__).resolve().parent.parent / "netlists" / "sweeps" / "buck_param.cir"


def run(points: int, workers: int, stop: float):
    duties = np.linspace(0.1, 0.9, points).tolist()
    window = f"{stop - 1e-3!r}, {stop!r}"
    started = time.perf_counter()
    table = circuitnsds.sweep(NETLIST, {"D": duties}, workers=workers, stop=stop,
                              measure=[f"mean(v(out), {window})", f"ripple(v(out), {window})"])
    wall = time.perf_counter() - started
    assert (table["status"] == "ok").all(), table[table["status"] != "ok"]
    return table, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=40)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--stop", default="10m", help="simulated time per point (default 10m)")
    args = parser.parse_args()
    stop = parse_value(args.stop)
    circuitnsds.read_netlist(NETLIST).transient(stop=20e-6)  # both runs start warm: imports, loops loaded
    serial, serial_wall = run(args.points, 0, stop)
    parallel, parallel_wall = run(args.points, args.workers, stop)
    same = serial.drop(columns="warnings").equals(parallel.drop(columns="warnings"))
    print(f"{args.points}-point duty sweep of {NETLIST.name}, {stop * 1e3:g} ms simulated per point "
          f"(step 0.1 us); tables equal bit for bit: {same}")
    print(f"{'run':<22} {'wall [s]':>9} {'points [s]':>11} {'first [s]':>10} {'median point [ms]':>18} "
          f"{'median CPU [ms]':>16} {'overhead/point [ms]':>20}")
    for name, table, wall, workers in (("serial (workers=0)", serial, serial_wall, 1),
                                       (f"{args.workers} local workers", parallel, parallel_wall,
                                        args.workers)):
        seconds = np.array(table.attrs["point_seconds"])
        cpu = np.array(table.attrs["point_cpu_seconds"])
        overhead = (workers * wall - seconds.sum()) / len(seconds)
        print(f"{name:<22} {wall:9.2f} {seconds.sum():11.2f} {seconds[0]:10.2f} "
              f"{1e3 * np.median(seconds):18.1f} {1e3 * np.median(cpu):16.1f} {1e3 * overhead:20.1f}")
    print(f"ratio parallel/serial: {parallel_wall / serial_wall:.2f}")
    print(f"load average (1, 5, 15 min) at the end: {', '.join(f'{v:.1f}' for v in os.getloadavg())} "
          f"on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
