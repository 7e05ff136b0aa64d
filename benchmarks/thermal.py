"""Issue 35 benchmark: what the datasheet losses and junction temperatures cost on top of a
run, on the SiC buck (``netlists/thermal/sic_buck.cir``: one switch and one diode with
thermal descriptions, 20 kHz).

For a transient of 2, 5 and 20 ms (0.1 µs steps) and for the periodic steady state: the
analysis's time, then the thermal post-processing's (:func:`circuitnsds.thermal.junction.
analyse`: switching energy at every commutation, conduction tables, the networks driven
period by period, the passes of the coupling to Tj), best of three.
Usage: ``python benchmarks/thermal.py``.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import circuitnsds  # noqa: E402
from circuitnsds.thermal.junction import analyse  # noqa: E402

NETLIST = ROOT / "netlists" / "thermal" / "sic_buck.cir"
PERIOD = 50e-6


def best(function, repeats: int = 3) -> tuple[float, object]:
    times, result = [], None
    for _ in range(repeats):
        started = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - started)
    return min(times), result


def main() -> None:
    warnings.simplefilter("ignore")
    circuit = circuitnsds.read_netlist(NETLIST)
    print(f"{'analysis':<18}{'points':>9}{'analysis [s]':>14}{'thermal [s]':>13}{'passes':>8}")
    for stop in (2e-3, 5e-3, 20e-3):
        seconds, waves = best(lambda stop=stop: circuit.transient(0.1e-6, stop))
        thermal, result = best(lambda waves=waves: analyse(circuit, waves, steady=False,
                                                           period=PERIOD))
        print(f"{f'transient {stop * 1e3:g} ms':<18}{waves.time.size:>9}{seconds:>14.3f}"
              f"{thermal:>13.3f}{result.passes:>8}")
    seconds, pss = best(lambda: circuit.pss(PERIOD, step=0.1e-6))
    thermal, result = best(lambda: analyse(circuit, pss.waveforms, steady=True, period=PERIOD))
    print(f"{'pss':<18}{pss.waveforms.time.size:>9}{seconds:>14.3f}{thermal:>13.3f}"
          f"{result.passes:>8}")


if __name__ == "__main__":
    main()
