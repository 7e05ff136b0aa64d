"""Design sweep: output ripple of the bundled bridge rectifier against the reservoir capacitor.

Run from the repository root::

    python examples/ripple_vs_capacitance.py [--out ripple_vs_capacitance.png] [--fast]

For each capacitance the netlist's C1 is replaced, the transient is run with
ideal piecewise-linear diodes, and the last two mains periods give the mean
output voltage and the peak-to-peak ripple (``circuitnsds.output.measure``). The
textbook estimate ``ΔV ≈ V_out / (R_load · 2 f · C)`` is printed and drawn beside it.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import circuitnsds
from circuitnsds.output import measure

NETLIST = Path(__file__).resolve().parent.parent / "netlists" / "bridge_rectifier.cir"
MAINS_HZ, LOAD_OHM = 50.0, 1e3


def ripple_table(capacitances: list[float], fast: bool = False
                 ) -> list[tuple[float, float, float, float]]:
    """``(C [F], mean V_out [V], ripple [V p-p], textbook estimate [V])`` for each C.

    ``fast``: 50 µs steps over 3 mains periods instead of 20 µs over 10.
    """
    circuit = circuitnsds.read_netlist(NETLIST)
    step, stop = (50e-6, 3 / MAINS_HZ) if fast else (20e-6, 10 / MAINS_HZ)
    window = (stop - 2 / MAINS_HZ, stop)
    rows = []
    for capacitance in capacitances:
        position = circuit.elements.index(circuit.element("c1"))
        circuit.elements[position] = replace(circuit.element("c1"), capacitance=capacitance)
        waves = circuit.transient(step=step, stop=stop)
        mean = measure.mean(waves, "v(out)", *window)
        rows.append((capacitance, mean, measure.ripple(waves, "v(out)", *window),
                     mean / (LOAD_OHM * 2 * MAINS_HZ * capacitance)))
    return rows


def figure(rows: list[tuple[float, float, float, float]], path: str | Path) -> None:
    """Ripple against C on log-log axes, simulation and estimate."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.5, 4.5), layout="constrained")
    axis = fig.subplots()
    c = [r[0] * 1e6 for r in rows]
    axis.loglog(c, [r[2] for r in rows], "o-", label="circuitnsds (ideal PWL diodes)")
    axis.loglog(c, [r[3] for r in rows], "--", label="V / (R·2f·C)")
    axis.set_xlabel("reservoir capacitance C [µF]")
    axis.set_ylabel("output ripple [V p-p]")
    axis.set_title("Bridge rectifier, 230 V 50 Hz, 1 kΩ load", fontsize="medium")
    axis.grid(True, which="both", alpha=0.3)
    axis.legend(fontsize="small")
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> list[tuple[float, float, float, float]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", "--plot", type=Path, default=Path("ripple_vs_capacitance.png"),
                        help="figure to write (default: ripple_vs_capacitance.png)")
    parser.add_argument("--fast", action="store_true", help="three capacitors, short coarse runs")
    args = parser.parse_args(argv)
    capacitances = [100e-6, 470e-6, 1000e-6] if args.fast else [47e-6, 100e-6, 220e-6, 470e-6,
                                                                 1000e-6]
    rows = ripple_table(capacitances, args.fast)
    print(f"{'C [uF]':>8} {'mean [V]':>9} {'ripple [V]':>11} {'estimate [V]':>13}")
    for capacitance, mean, ripple, estimate in rows:
        print(f"{capacitance * 1e6:8.0f} {mean:9.2f} {ripple:11.2f} {estimate:13.2f}")
    figure(rows, args.out)
    print(f"wrote {args.out}")
    return rows


if __name__ == "__main__":
    main()
