"""Design sweep: output ripple of the bundled bridge rectifier against the reservoir capacitor.

Run from the repository root::

    python examples/ripple_vs_capacitance.py [--plot ripple.png]

For each capacitance the netlist's C1 is replaced, the transient is run with
ideal piecewise-linear diodes, and the last two mains periods give the mean
output voltage and the peak-to-peak ripple. The textbook estimate
``ΔV ≈ V_out / (R_load · 2 f · C)`` is printed beside it.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

import circuitnsds

NETLIST = Path(__file__).resolve().parent.parent / "netlists" / "bridge_rectifier.cir"
MAINS_HZ, LOAD_OHM = 50.0, 1e3


def ripple_table(capacitances: list[float]) -> list[tuple[float, float, float, float]]:
    """``(C [F], mean V_out [V], ripple [V p-p], textbook estimate [V])`` for each C."""
    circuit = circuitnsds.read_netlist(NETLIST)
    rows = []
    for capacitance in capacitances:
        position = circuit.elements.index(circuit.element("c1"))
        circuit.elements[position] = replace(circuit.element("c1"), capacitance=capacitance)
        waves = circuit.transient(step=20e-6, stop=0.2)
        tail = waves.time >= 0.2 - 2 / MAINS_HZ
        v_out = waves["v(out)"][tail]
        mean = float(v_out.mean())
        rows.append((capacitance, mean, float(np.ptp(v_out)),
                     mean / (LOAD_OHM * 2 * MAINS_HZ * capacitance)))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot", type=Path, help="write ripple against C to this PNG")
    args = parser.parse_args()
    rows = ripple_table([47e-6, 100e-6, 220e-6, 470e-6, 1000e-6])
    print(f"{'C [uF]':>8} {'mean [V]':>9} {'ripple [V]':>11} {'estimate [V]':>13}")
    for capacitance, mean, ripple, estimate in rows:
        print(f"{capacitance * 1e6:8.0f} {mean:9.2f} {ripple:11.2f} {estimate:13.2f}")
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        c = [r[0] * 1e6 for r in rows]
        plt.loglog(c, [r[2] for r in rows], "o-", label="circuitnsds")
        plt.loglog(c, [r[3] for r in rows], "--", label="V/(R·2f·C)")
        plt.xlabel("C [µF]")
        plt.ylabel("ripple [V p-p]")
        plt.legend()
        plt.savefig(args.plot, dpi=110)


if __name__ == "__main__":
    main()
