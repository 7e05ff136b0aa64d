"""Issue 14 benchmark: periodic steady state by shooting against the transient that settles.

For each circuit (bundled netlists, each on its ``.tran`` step):

* PSS: wall time of ``circuit.pss()`` (operating point, shooting, waveforms; best of 3),
  its Newton steps and largest Floquet multiplier ``|λ|``;
* transient: a long run from the operating point, cut into periods; the first period ``j``
  after which every period agrees with the PSS within ``TOL`` of each signal's range is
  where the transient has settled; the wall time of a fresh transient of ``j + 1``
  periods (best of 2) is the cost of settling by simulation;
* the agreement of the long run's last period with the PSS (largest difference / range),
  and the decay rate per period seen in the transient (slope of log(difference) over the
  periods before it settles) against ``ln |λ|``.

Usage: ``python benchmarks/pss.py [--quick]`` (``--quick``: fewer circuits, a smoke test).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import circuitnsds  # noqa: E402

TOL = 1e-6
"""Agreement that counts as settled: largest difference over the period / the signal's range."""

CASES = [  # (label, netlist in netlists/ or benchmarks/netlists/, longest transient in periods,
    #         replacements in the netlist text)
    ("buck CCM (buck_converter.cir)", "buck_converter.cir", 3000, {}),
    ("boost CCM (boost_converter.cir, Q = 3)", "boost_converter.cir", 3000, {}),
    # the 12 -> 24 V boost of Q = R(1 - D)·sqrt(C/L) = 17: the same with a 34 ohm load
    ("boost CCM, Q = 17 (Rload = 34 ohm)", "boost_converter.cir", 14000,
     {"Rload out 0 6": "Rload out 0 34"}),
    ("boost DCM (boost_dcm.cir)", "boost_dcm.cir", 2000, {}),
    ("flyback + RCD clamp (flyback_rcd.cir)", "flyback_rcd.cir", 1500, {}),
    ("bridge + C filter (bridge_rectifier.cir)", "bridge_rectifier.cir", 200, {}),
]


def best_of(count: int, run):
    times, result = [], None
    for _ in range(count):
        started = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - started)
    return min(times), result


def period_differences(pss, waves) -> np.ndarray:
    """For each whole period of ``waves``: largest |difference| / range over the PSS signals."""
    period, points = pss.period, pss.waveforms.time.size
    names = [name for name in pss.waveforms.names
             if np.ptp(pss.waveforms[name]) > 1e-9 * (1 + np.abs(pss.waveforms[name]).max())]
    count = int(round((waves.time[-1] - waves.time[0]) / period))
    starts = np.searchsorted(waves.time, waves.time[0] + np.arange(count) * period - 1e-9 * period)
    worst = np.zeros(count)
    for name in names:
        ours, span = pss.waveforms[name], np.ptp(pss.waveforms[name])
        theirs = waves[name]
        for j, first in enumerate(starts):
            segment = theirs[first:first + points]
            if segment.size == points:
                worst[j] = max(worst[j], np.abs(segment - ours).max() / span)
            else:
                worst[j] = np.inf
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    cases = CASES[1:2] if args.quick else CASES
    circuitnsds.read_netlist(ROOT / "netlists" / "buck_converter.cir").pss()  # numba compiles
    rows = []
    for label, name, longest, replacements in cases:
        path = ROOT / "netlists" / name
        text = (path if path.exists() else ROOT / "benchmarks" / "netlists" / name).read_text()
        for old, new in replacements.items():
            assert old in text, old
            text = text.replace(old, new)
        circuit = circuitnsds.read_netlist(text)
        step = circuit.analyses["tran"].step
        pss_seconds, pss = best_of(3, lambda circuit=circuit, step=step: circuit.pss(step=step))
        largest = float(np.abs(pss.multipliers).max())
        waves = circuit.transient(step, longest * pss.period)
        worst = period_differences(pss, waves)
        unsettled = np.flatnonzero(worst > TOL)
        settled_at = int(unsettled[-1]) + 1 if unsettled.size else 0
        if settled_at >= worst.size:
            tran_seconds, settled = math.nan, f"> {worst.size}"
        else:
            tran_seconds, _ = best_of(2, lambda c=circuit, s=step, stop=(settled_at + 1) * pss.period:
                                      c.transient(s, stop))
            settled = str(settled_at + 1)
        window = np.flatnonzero((worst > 1e3 * TOL) & (worst < 1e-1))
        seen = (math.exp(np.polyfit(window, np.log(worst[window]), 1)[0])
                if window.size > 3 else math.nan)
        rows.append((label, pss_seconds, pss.iterations, largest, seen, settled, tran_seconds,
                     tran_seconds / pss_seconds, worst[-1]))
    header = ("| circuit | PSS [s] | Newton steps | max abs(λ) | decay per period in the transient | "
              "periods to settle (1e-6) | transient [s] | speed-up | last period vs PSS |")
    print(header)
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for label, seconds, steps, largest, seen, settled, tran, ratio, last in rows:
        print(f"| {label} | {seconds:.3f} | {steps} | {largest:.6f} | {seen:.6f} | {settled} | "
              f"{tran:.3f} | {ratio:.0f}x | {last:.1e} |")


if __name__ == "__main__":
    main()
