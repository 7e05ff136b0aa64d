"""Design sweep: output ripple of the bundled bridge rectifier against the reservoir capacitor.

Run from the repository root::

    python examples/ripple_vs_capacitance.py [--out ripple_vs_capacitance.png] [--fast]

The netlist's reservoir capacitor is the parameter ``C``: one :func:`circuitnsds.sweep`
runs the transient for each value (ideal piecewise-linear diodes; on local worker
processes, or in this process with ``--workers 0``) and measures the mean output voltage
and the peak-to-peak ripple over the last two mains periods. The textbook estimate
``ΔV ≈ V_out / (R_load · 2 f · C)`` is printed and drawn beside it.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import circuitnsds

NETLIST = Path(__file__).resolve().parent.parent / "netlists" / "bridge_rectifier.cir"
MAINS_HZ, LOAD_OHM = 50.0, 1e3


def ripple_table(capacitances: list[float], fast: bool = False, workers: int | None = 0
                 ) -> list[tuple[float, float, float, float]]:
    """``(C [F], mean V_out [V], ripple [V p-p], textbook estimate [V])`` for each C.

    ``fast``: 50 µs steps over 3 mains periods instead of 20 µs over 10. ``workers``: as
    :func:`circuitnsds.sweep` takes it (0: in this process; ``None``: one per core).
    """
    step, stop = (50e-6, 3 / MAINS_HZ) if fast else (20e-6, 10 / MAINS_HZ)
    window = f"{stop - 2 / MAINS_HZ!r}, {stop!r}"
    expressions = [f"mean(v(out), {window})", f"ripple(v(out), {window})"]
    table = circuitnsds.sweep(NETLIST, {"C": capacitances}, measure=expressions, step=step, stop=stop,
                              workers=workers)
    failed = table[table["status"] != "ok"]
    if not failed.empty:
        raise RuntimeError(f"C = {failed['C'].iloc[0]:g} F failed: {failed['error'].iloc[0]}")
    return [(c, mean, ripple, mean / (LOAD_OHM * 2 * MAINS_HZ * c))
            for c, mean, ripple in zip(table["C"], table[expressions[0]], table[expressions[1]])]


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
    parser.add_argument("--workers", type=int, default=None,
                        help="worker processes (default: one per core; 0: this process only)")
    args = parser.parse_args(argv)
    capacitances = [100e-6, 470e-6, 1000e-6] if args.fast else [47e-6, 100e-6, 220e-6, 470e-6,
                                                                 1000e-6]
    workers = args.workers if args.workers is not None else (0 if args.fast else None)
    rows = ripple_table(capacitances, args.fast, workers)
    print(f"{'C [uF]':>8} {'mean [V]':>9} {'ripple [V]':>11} {'estimate [V]':>13}")
    for capacitance, mean, ripple, estimate in rows:
        print(f"{capacitance * 1e6:8.0f} {mean:9.2f} {ripple:11.2f} {estimate:13.2f}")
    figure(rows, args.out)
    print(f"wrote {args.out}")
    return rows


if __name__ == "__main__":
    main()
