"""Zener shunt regulator: output voltage and line regulation against the input voltage.

Run from the repository root::

    python examples/zener_line_regulation.py [--out zener_line_regulation.png] [--fast]

A 5.1 V Zener (dynamic resistance Rz = 7 Ω, as a 1N4733A's datasheet gives) behind a
100 Ω series resistor feeds three loads. The input ramps slowly from 0 to 15 V; the
circuit has no capacitor or inductor, so each instant is a DC operating point and the
ramp traces the regulator's DC transfer curve. For each load:

* the knee, the input at which the Zener starts to conduct, against ``BV·(1 + Rs/RL)``;
* the line regulation ``ΔVout/ΔVin`` between 9 V and 12 V in, against
  ``(1/Rs) / (1/Rs + 1/Rz + 1/RL)``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from circuitnsds.frontend.build import CircuitBuilder
from circuitnsds.output import measure

BV, RZ, RS, VMAX, RAMP = 5.1, 7.0, 100.0, 15.0, 10e-3
LOADS = (250.0, 500.0, 1000.0)
LINE = (9.0, 12.0)
"""Input voltages [V] between which the line regulation is measured."""

# The load and the time step are parameters: the netlist is read once, then built per load.
NETLIST = f"""Zener shunt regulator, load Rl
.param rl=1k tstep=3.3u
V1 in 0 PWL(0 0 {RAMP!r} {VMAX!r})
Rs in out {RS!r}
DZ1 0 out z5v1
Rload out 0 {{rl}}
.model z5v1 D(BV={BV!r} Rrev={RZ!r} Vfwd=0.7)
.tran {{tstep}} {RAMP!r}
.end
"""
BUILDER = CircuitBuilder.load(NETLIST)


def regulator(load: float, fast: bool = False):
    """The regulator with ``load`` [Ω] as a Circuit (input ramp 0 -> 15 V over 10 ms)."""
    return BUILDER.build({"rl": load, "tstep": RAMP / (300 if fast else 3000)})


def characterise(load: float, fast: bool = False) -> dict:
    """Transfer curve, knee [V] and line regulation [V/V] for one load, with the estimates."""
    waves = regulator(load, fast).transient()
    vin, vout = waves["v(in)"], waves["v(out)"]
    conducting = waves["i(dz1)"] < -1e-6  # breakdown current flows cathode -> anode: negative
    knee = float(vin[np.argmax(conducting)]) if conducting.any() else float("nan")
    # the input is a ramp: input voltage v <-> time v/VMAX·RAMP; average over ±0.1 V
    at = [measure.mean(waves, "v(out)", (v - 0.1) / VMAX * RAMP, (v + 0.1) / VMAX * RAMP)
          for v in LINE]
    return {
        "load": load,
        "vin": vin,
        "vout": vout,
        "knee": knee,
        "knee_estimate": BV * (1 + RS / load),
        "regulation": (at[1] - at[0]) / (LINE[1] - LINE[0]),
        "regulation_estimate": (1 / RS) / (1 / RS + 1 / RZ + 1 / load),
        "vout_at_12": at[1],
    }


def figure(rows: list[dict], path: str | Path) -> None:
    """Transfer curves (top) and the local line regulation dVout/dVin (bottom)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 7), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True)
    for row in rows:
        line, = top.plot(row["vin"], row["vout"], label=f"RL = {row['load']:g} Ω")
        top.axvline(row["knee_estimate"], color=line.get_color(), linestyle=":", linewidth=0.8)
        slope = np.gradient(row["vout"], row["vin"])
        bottom.plot(row["vin"], 1e3 * slope, color=line.get_color(), label=f"RL = {row['load']:g} Ω")
        bottom.axhline(1e3 * row["regulation_estimate"], color=line.get_color(), linestyle="--",
                       linewidth=0.8)
    top.plot([0, VMAX], [0, VMAX], color="0.6", linewidth=0.8, label="Vout = Vin")
    top.set_ylim(0, BV * 1.5)
    top.set_ylabel("output [V]")
    top.set_title(f"Zener regulator: BV = {BV:g} V, Rz = {RZ:g} Ω, Rs = {RS:g} Ω "
                  "(dotted: knee BV·(1+Rs/RL))", fontsize="medium")
    bottom.set_yscale("log")
    bottom.set_ylabel("line regulation dVout/dVin [mV/V]")
    bottom.set_xlabel("input [V]")
    bottom.set_title("dashed: (1/Rs)/(1/Rs + 1/Rz + 1/RL)", fontsize="small")
    for axis in (top, bottom):
        axis.grid(True, which="both", alpha=0.3)
        axis.legend(fontsize="small")
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("zener_line_regulation.png"),
                        help="figure to write (default: zener_line_regulation.png)")
    parser.add_argument("--fast", action="store_true", help="coarse input steps")
    args = parser.parse_args(argv)
    rows = [characterise(load, args.fast) for load in LOADS]
    print(f"{'RL [ohm]':>9} {'knee [V]':>9} {'estimate':>9} {'Vout@12V':>9} "
          f"{'regulation [mV/V]':>18} {'estimate':>9}")
    for r in rows:
        print(f"{r['load']:9g} {r['knee']:9.2f} {r['knee_estimate']:9.2f} {r['vout_at_12']:9.3f} "
              f"{1e3 * r['regulation']:18.2f} {1e3 * r['regulation_estimate']:9.2f}")
    figure(rows, args.out)
    print(f"wrote {args.out}")
    return rows


if __name__ == "__main__":
    main()
