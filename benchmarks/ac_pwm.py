"""Issue 16 benchmark: control-to-output of a PWM buck (a comparator switch S1, closed while
the control source Vc is above a 0..1 V ramp, fs = 100 kHz; L = 47 uH, C = 220 uF, R = 0.5 Ω,
D = 0.398) around its periodic steady state, against

* the averaged model ``GAIN·Vin/(1 + sL/R + s²LC)``, ``GAIN = (rise + fall)/T`` (the duty
  cycle per volt of control: the ramp's rise and fall both cross Vc);
* brute-force sine-injection transients: Vc + 4 mV·sin(ωt) from the periodic steady state,
  1.2 ms to settle (the LC's start-up decays with 2L/R = 0.19 ms), then the DFT of v(out)
  over 0.5 ms (whole periods of the sine and of the switching), weighted like the AC.

Also the PSS's Newton history and the time of a 100-frequency sweep against the injection
transients it replaces. Usage: ``python benchmarks/ac_pwm.py [STEP]`` (default 0.2 µs).
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import circuitnsds  # noqa: E402
from circuitnsds.engine.integrate import integrate  # noqa: E402
from circuitnsds.engine.timegrid import time_grid  # noqa: E402

PERIOD, RISE, WIDTH, FALL = 10e-6, 9.9e-6, 50e-9, 50e-9
VIN, VC, L, C, R = 12.0, 0.4, 47e-6, 220e-6, 0.5
GAIN = (RISE + FALL) / PERIOD
STEP = float(sys.argv[1]) if len(sys.argv) > 1 else 0.2e-6
FREQUENCIES = np.array([2e3, 4e3, 10e3, 20e3, 46e3])  # whole periods in WINDOW
AMPLITUDE, SETTLE, WINDOW = 4e-3, 1.2e-3, 0.5e-3


def netlist(control: str) -> str:
    return f"""open-loop PWM buck
Vin in 0 DC {VIN}
Vc ctrl 0 {control}
Vramp ramp 0 PULSE(0 1 0 {RISE} {FALL} {WIDTH} {PERIOD})
S1 in sw ctrl ramp swmod
D1 0 sw dfree
L1 sw out {L}
C1 out 0 {C}
Rload out 0 {R}
.model swmod SW(VT=0 VH=0 RON=1m ROFF=1e9)
.model dfree D(Ron=1m)
.tran {STEP} 1m
.end
"""


def read(text: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return circuitnsds.read_netlist(text)


def injection(settled, frequency: float) -> tuple[complex, float]:
    circuit = read(netlist(f"SIN({VC} {AMPLITUDE} {frequency})"))
    mlcs = circuit.mlcs(circuitnsds.SourceDefaults(STEP, SETTLE + WINDOW))
    grid = time_grid(STEP, SETTLE + WINDOW, mlcs.breakpoints(SETTLE + WINDOW))
    start = settled.maps.trajectory
    began = time.perf_counter()
    run = integrate(mlcs, grid, start.y[0], None, None, start.active[0], start.switches[0])
    seconds = time.perf_counter() - began
    out = run.y[:, mlcs.unknowns.index("v(out)")]
    inside = np.flatnonzero(grid > SETTLE + 1e-12)
    weights = (grid[inside] - grid[inside - 1]) / WINDOW
    coefficient = np.sum(weights * out[inside] * np.exp(-2j * np.pi * frequency * grid[inside]))
    return 2 * coefficient / (-1j * AMPLITUDE), seconds


def main() -> None:
    circuit = read(netlist(f"DC {VC}"))
    began = time.perf_counter()
    settled = circuit.pss(step=STEP)
    pss_seconds = time.perf_counter() - began
    print(f"PSS: {settled.iterations} Newton step(s), relative residuals "
          + ", ".join(f"{r:.1e}" for r in settled.history) + f"; {pss_seconds:.3f} s")
    ac = circuit.ac("vc", "v(out)", FREQUENCIES, pss=settled).transfer["v(out)"]
    s = 2j * np.pi * FREQUENCIES
    averaged = VIN * GAIN / (1 + s * L / R + s * s * L * C)
    print("| f [Hz] | abs(H) (AC) | phase (AC) [deg] | AC − averaged [dB] | [deg] "
          "| AC − injection [dB] | [deg] |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    times = []
    for f, h, a in zip(FREQUENCIES, ac, averaged):
        theirs, seconds = injection(settled, f)
        times.append(seconds)
        print(f"| {f:g} | {abs(h):.5g} | {np.degrees(np.angle(h)):.2f} | {20 * np.log10(abs(h / a)):+.4f} "
              f"| {np.degrees(np.angle(h / a)):+.3f} | {20 * np.log10(abs(h / theirs)):+.4f} "
              f"| {np.degrees(np.angle(h / theirs)):+.3f} |")
    began = time.perf_counter()
    circuit.ac("vc", "v(out)", np.logspace(2, np.log10(50e3), 100), pss=settled)
    sweep = time.perf_counter() - began
    print(f"100-frequency sweep: {sweep:.3f} s after the PSS ({pss_seconds:.3f} s); 100 injection "
          f"transients ({(SETTLE + WINDOW) * 1e3:.2g} ms simulated each): {100 * np.mean(times):.1f} s "
          f"({np.mean(times):.3f} s each)")


if __name__ == "__main__":
    main()
