"""Issue 16 benchmark: small-signal AC around the periodic steady state against brute-force
sine-injection transients, on the CCM buck (``netlists/buck_converter.cir``, fs = 100 kHz).

For line-to-output (a sine of amplitude 10 mV added to Vin) and output impedance (a sine of
10 mA injected into the output by a current source), at five frequencies up to fs/2:

* the AC analysis (``circuit.ac(..., pss=...)``), one call for all frequencies;
* a transient of the same netlist with the sine added, started from the periodic steady
  state (so only the injection's own start-up must decay: 8 ms, 800 switching periods, at
  the output filter's ``|λ| = 0.99`` per period), the fundamental extracted by a DFT over
  the next 1 ms (whole periods of the sine and of the switching), weighted like the AC
  analysis (right-end samples, step lengths).

Then the time of a 100-frequency AC sweep against the injection transients it replaces
(their measured mean time × 100). Usage: ``python benchmarks/ac.py``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import circuitnsds  # noqa: E402
from circuitnsds.engine.integrate import integrate  # noqa: E402
from circuitnsds.engine.timegrid import time_grid  # noqa: E402

FREQUENCIES = np.array([1e3, 3e3, 10e3, 25e3, 45e3])
SETTLE, WINDOW = 8e-3, 1e-3
BASE = (ROOT / "netlists" / "buck_converter.cir").read_text().replace(
    "Rload out 0 5", "Rload out 0 5\nIinj 0 out DC 0")
CASES = {  # input source: (its line in BASE, its line with the sine, amplitude)
    "vin": ("Vin in 0 DC 24", "Vin in 0 SIN(24 {a} {f})", 10e-3),
    "iinj": ("Iinj 0 out DC 0", "Iinj 0 out SIN(0 {a} {f})", 10e-3),
}


def injected(settled, source: str, frequency: float) -> tuple[complex, float]:
    """The transfer function to v(out) at ``frequency`` measured by a sine-injection transient."""
    line, sine, amplitude = CASES[source]
    circuit = circuitnsds.read_netlist(BASE.replace(line, sine.format(a=amplitude, f=frequency)))
    stop = SETTLE + WINDOW
    step = circuit.analyses["tran"].step
    mlcs = circuit.mlcs(circuitnsds.SourceDefaults(step, stop))
    grid = time_grid(step, stop, mlcs.breakpoints(stop))
    start = settled.maps.trajectory
    started = time.perf_counter()
    run = integrate(mlcs, grid, start.y[0], None, None, start.active[0], start.switches[0])
    seconds = time.perf_counter() - started
    out = run.y[:, mlcs.unknowns.index("v(out)")]
    inside = np.flatnonzero(grid > SETTLE + 1e-12)  # right ends of the window's steps
    weights = (grid[inside] - grid[inside - 1]) / WINDOW
    coefficient = np.sum(weights * out[inside] * np.exp(-2j * np.pi * frequency * grid[inside]))
    # a·sin(ωt) = Re(−j a e^{jωt}); the response's coefficient at +ω is H·(−j a)/2
    return 2 * coefficient / (-1j * amplitude), seconds


def main() -> None:
    buck = circuitnsds.read_netlist(BASE)
    settled = buck.pss()
    rows, seconds = [], []
    for source, label in (("vin", "line-to-output v(out)/v(in)"), ("iinj", "output impedance [ohm]")):
        analysed = buck.ac(source, "v(out)", FREQUENCIES, pss=settled).transfer["v(out)"]
        for frequency, ours in zip(FREQUENCIES, analysed):
            theirs, elapsed = injected(settled, source, frequency)
            seconds.append(elapsed)
            ratio = ours / theirs
            rows.append((label, frequency, abs(ours), np.degrees(np.angle(ours)),
                         20 * np.log10(abs(ratio)), np.degrees(np.angle(ratio))))
    print("| transfer | f [Hz] | abs(H) (AC) | phase (AC) [deg] | AC − injection [dB] "
          "| AC − injection [deg] |")
    print("|---|---:|---:|---:|---:|---:|")
    for label, frequency, magnitude, phase, db, degrees in rows:
        print(f"| {label} | {frequency:.0f} | {magnitude:.5g} | {phase:.2f} | {db:+.4f} | {degrees:+.3f} |")
    sweep = np.logspace(2, np.log10(50e3), 100)
    buck.ac("vin", "v(out)", sweep[:2], pss=settled)  # warm
    started = time.perf_counter()
    buck.ac("vin", "v(out)", sweep, pss=settled)
    ac_seconds = time.perf_counter() - started
    started = time.perf_counter()
    buck.pss()
    pss_seconds = time.perf_counter() - started
    per_injection = float(np.mean(seconds))
    print()
    print("| 100-frequency sweep | wall time [s] |")
    print("|---|---:|")
    print(f"| periodic steady state (once) | {pss_seconds:.3f} |")
    print(f"| AC around it, 100 frequencies | {ac_seconds:.3f} |")
    print(f"| sine-injection transients from the PSS, 9 ms each, x 100 (mean {per_injection:.3f} s "
          f"each) | {100 * per_injection:.1f} |")


if __name__ == "__main__":
    main()
