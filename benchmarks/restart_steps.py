"""How many implicit-Euler steps should follow a switching with θ < 1
(``RESTART_STEPS`` of :mod:`circuitnsds.engine.integrate`; issue 36, item 1).

Only switchings into a mode whose θ-step has an eigenvalue below -0.5 get the extra
steps (``GridStepping.rings``). One restart step leaves such a stiff mode (a switch's Ron
with a capacitor, τ << h) a residue of its jump that the trapezoidal rule carries on,
alternating in sign, for ever. Each extra step damps that residue by 1/(1 + h/τ) and
costs a little accuracy on the smooth modes.
For 1, 2, 3 and 4 restart steps this prints:

* ``ring``: a gate RC closing S1 (10 mΩ) onto 3 nF || 10 Ω from 12 V at h = 1 ns: the largest
  step-to-step swing of i(s1) over the 4th to 40th step after the closing, in % of its final 1.2 A;
* ``LC energy``: a lossless LC tank (1 mH, 1 µF, 1 V, h = 1 µs) at θ = ½ with a switch
  toggled every 50 µs between it and a 1 GΩ resistor (each switching a restart, nothing
  stiff): stored energy after 2 ms in % of the start's (what θ = ½ exists to keep);
* ``buck period``: the hysteretic buck of ``tests/test_events.py`` at 100 steps per period,
  θ = ½: relative error of the mean period (analytic 38.107 µs);
* ``flyback``: ``benchmarks/netlists/flyback_coss.cir`` at θ = ½ over 0.3 ms: mean v(out)
  over the last 50 µs at its 10 ns step, and the difference from the same at 1 ns.

Usage: ``python benchmarks/restart_steps.py``
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

import circuitnsds
import circuitnsds.engine.integrate as integrate

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from tests.test_events import hysteretic_buck, hysteretic_period  # noqa: E402

RING = """ring
V1 in 0 12
Vg g0 0 PULSE(0 5 1u 0 0 5u 10u)
Rg g0 g 3
Cg g 0 5n
S1 in sw g 0 sw1
C1 sw 0 3n
R1 sw 0 10
.model sw1 SW(VT=2.6 RON=10m)
.tran 1n 3u
"""
TANKS = """tanks
C1 a 0 1u ic=1
L1 a 0 1m
S1 a b ctl 0 sw1
Rb b 0 1e9
Vc ctl 0 PULSE(0 1 50u 0 0 50u 100u)
.model sw1 SW(VT=0.5 RON=1m ROFF=1e12)
.tran 1u 2m uic
"""


def ring() -> float:
    waves = circuitnsds.read_netlist(RING).transient(theta=0.5, method="theta")
    current = waves["i(s1)"]
    closed = int(np.argmax(np.abs(current) > 0.5))
    after = current[closed + 4:closed + 40]
    return float(np.abs(np.diff(after)).max() / 1.2 * 100)


def tank_energy() -> float:
    waves = circuitnsds.read_netlist(TANKS).transient(theta=0.5, method="theta")
    energy = 0.5e-6 * waves["v(a)"] ** 2 + 0.5e-3 * waves["i(l1)"] ** 2
    return float(energy[-1] / energy[0] * 100)


def buck_period() -> float:
    period = hysteretic_period()
    waves = circuitnsds.read_netlist("buck\n" + hysteretic_buck(period / 100, 10 * period)
                                     ).transient(theta=0.5, method="theta")
    closings = [e.time for e in waves.events if e.state]
    return abs(float(np.mean(np.diff(closings[1:]))) / period - 1)


def flyback(step: float) -> float:
    circuit = circuitnsds.read_netlist(ROOT / "benchmarks" / "netlists" / "flyback_coss.cir")
    waves = circuit.transient(step=step, stop=0.3e-3, theta=0.5, signals=["v(out)"], method="theta")
    return float(waves["v(out)"][waves.time > 0.25e-3].mean())


def main() -> None:
    kept = integrate.RESTART_STEPS
    print(f"{'restart steps':>13} {'ring [%]':>9} {'LC energy [%]':>13} {'buck period':>11} "
          f"{'flyback v(out)':>14} {'vs 1 ns':>9}")
    warnings.simplefilter("ignore")
    for steps in (1, 2, 3, 4):
        integrate.RESTART_STEPS = steps
        coarse, fine = flyback(10e-9), flyback(1e-9)
        mark = "  (now)" if steps == kept else ""
        print(f"{steps:>13} {ring():>9.3f} {tank_energy():>13.3f} {buck_period():>11.2e} "
              f"{coarse:>14.4f} {coarse - fine:>9.1e}{mark}")
    integrate.RESTART_STEPS = kept


if __name__ == "__main__":
    main()
