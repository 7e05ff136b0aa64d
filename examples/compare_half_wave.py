"""Convergence study: ngspice's Shockley diode approaches circuitnsds's ideal diode as N → 0.

Run from the repository root (needs ngspice's shared library and PySpice)::

    python examples/compare_half_wave.py [--out docs/compare_convergence.png] [--fast]

The bundled half-wave rectifier (10 V, 50 Hz, 1 kΩ, ideal diode) runs once in
circuitnsds and, through ``circuitnsds.compare``, in ngspice with the emission
coefficient N of its diode forced to each value of a sweep. While the diode
conducts, the smooth model's output is lower by the forward drop
``N·Vt·ln(1 + I/IS)``; at the peak current (10 mA, IS = 1e-14 A) that drop is the
largest error, so the error falls in proportion to N. The script prints the
measured largest error of v(out) beside that estimate, and draws the errors and
both simulators' runtimes against N (``Comparison.plot_convergence``).
"""

from __future__ import annotations

import argparse
import math
import warnings
from pathlib import Path

import circuitnsds

ROOT = Path(__file__).resolve().parent.parent
NETLIST = ROOT / "netlists" / "half_wave_rectifier.cir"
VT = 1.380649e-23 * 300.15 / 1.602176634e-19   # thermal voltage at ngspice's 27 °C [V]
IS = 1e-14                                      # ngspice's default saturation current [A]
PEAK_CURRENT = 10.0 / 1e3                       # 10 V across 1 kΩ [A]


def drop_estimate(n: float) -> float:
    """Forward drop of the Shockley diode at the peak current [V]."""
    return n * VT * math.log1p(PEAK_CURRENT / IS)


def study(n_values: list[float], stop: float | None = None):
    """The comparison and one row per N: status, ngspice time, errors of v(out), estimate."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = circuitnsds.compare(NETLIST, n=n_values, stop=stop, signals=["v(out)"])
    rows = []
    for run in comparison.runs:
        metric = run.metrics.get("v(out)")
        rows.append({
            "n": run.overrides.n,
            "status": run.ngspice.status,
            "ngspice_seconds": run.ngspice.seconds,
            "nrms": metric.nrms if metric else math.nan,
            "nmax": metric.nmax if metric else math.nan,
            "estimate": drop_estimate(run.overrides.n) / metric.scale if metric else math.nan,
        })
    return comparison, rows


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "compare_convergence.png",
                        help="PNG to write (default: docs/compare_convergence.png)")
    parser.add_argument("--fast", action="store_true", help="one mains period, three values of N")
    args = parser.parse_args(argv)
    n_values = [1.0, 0.1, 0.01] if args.fast else [1.0, 0.3, 0.1, 0.03, 0.01, 0.003]
    comparison, rows = study(n_values, stop=20e-3 if args.fast else None)
    print(f"{comparison.ngspice_version}, circuitnsds {comparison.circuitnsds_seconds:.3g} s")
    print(f"{'N':>7} {'ngspice':>8} {'time [s]':>9} {'nRMS v(out)':>12} {'nMAX v(out)':>12} "
          f"{'drop/range':>11}")
    for row in rows:
        print(f"{row['n']:>7g} {row['status']:>8} {row['ngspice_seconds']:>9.3g} "
              f"{100 * row['nrms']:>11.3g}% {100 * row['nmax']:>11.3g}% {100 * row['estimate']:>10.3g}%")
    comparison.plot_convergence(args.out)
    print(f"wrote {args.out}")
    return rows


if __name__ == "__main__":
    main()
