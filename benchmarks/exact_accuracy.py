"""Accuracy of the exact stepper (``method=exact``) against closed forms and converged
references, next to the θ-method at the same step, with the wall-clock time of each run
(whole runs in this process: the first includes the imports). Prints a table.

    PYTHONPATH=$PWD python benchmarks/exact_accuracy.py

The cases are issue 31's: an RC-triggered switch's closing instant, a DCM-like diode
turn-off instant, the flyback with RCD clamp's clamp voltage at its netlist's step (the
converged value from θ's Richardson extrapolation at 0.25 and 0.125 ns), and the boost's
periodic steady state (mean v(out) against the exact orbit 23.839697 V).
"""

from __future__ import annotations

import math
import time
import warnings
from pathlib import Path

import numpy as np

import circuitnsds

ROOT = Path(__file__).resolve().parent.parent
RC_SWITCH = """rc triggered switch
V1 in 0 10
R1 in c 1k
C1 c 0 1u
S1 out 0 c 0 sw
V2 a 0 5
R2 a out 1k
.model sw SW(VT=5 RON=1 ROFF=1e9)
.tran 10u 2m uic
.end
"""
DISCHARGE = """inductor discharging into 5 V through an ideal diode, 1 kohm across it
L1 0 a 1m IC=2.0003
D1 a out dideal
Vo out 0 5
R1 a 0 1k
.model dideal D
.tran 1u 1m uic
.end
"""
FLYBACK_CLAMP = 33.26877
"""v(clamp) − v(in) at 0.3 ms [V]: θ's Richardson limit at 0.25/0.125 ns (33.2130621, 33.2409165 V)."""
BOOST_ORBIT = 23.839697
"""The boost's exact orbit, mean v(out) [V] (issue 31)."""


def _timed(function):
    began = time.perf_counter()
    value = function()
    return value, time.perf_counter() - began


def _rc(method: str) -> float:
    circuit = circuitnsds.read_netlist(RC_SWITCH)
    threshold = circuit.mlcs().switches[0].on_threshold
    waves = circuit.transient(method=method)
    closes = [e.time for e in waves.events if e.element == "s1" and e.state]
    instant = -1e-3 * math.log(1 - threshold / 10)
    return abs(closes[0] - instant) / instant


def _dcm(method: str) -> float:
    waves = circuitnsds.read_netlist(DISCHARGE).transient(method=method)
    t_off = 1e-3 * (2.0003 - 5 / 1e3) / 5  # (off the 1 µs grid)
    if method == "exact":
        located = [e.time for e in waves.events if e.element == "d1" and not e.state][0]
    else:  # θ: the first point after which the diode's impulse is 0
        impulse = np.asarray(waves.impulse("d1"))
        located = float(waves.time[np.flatnonzero(impulse > 0)[-1]])
    return abs(located - t_off) / t_off


def _flyback(method: str) -> float:
    circuit = circuitnsds.read_netlist(ROOT / "benchmarks" / "netlists" / "flyback_rcd.cir")
    waves = circuit.transient(stop=0.3e-3, method=method, signals=["v(clamp)", "v(in)"])
    clamp = float(waves["v(clamp)"][-1] - waves["v(in)"][-1])
    return abs(clamp - FLYBACK_CLAMP) / FLYBACK_CLAMP


def _boost(method: str) -> float:
    text = (ROOT / "netlists" / "boost_converter.cir").read_text()
    result = circuitnsds.read_netlist(text.replace(".end", f".options method={method}\n.end")).pss()
    mean = result.means["v(out)"] if result.means is not None else float(
        np.mean(np.asarray(result.waveforms["v(out)"])[1:]))
    return abs(mean - BOOST_ORBIT)


CASES = [("RC-triggered switch: closing instant (relative)", _rc),
         ("inductor discharge: diode turn-off instant (relative)", _dcm),
         ("flyback RCD clamp at 0.2 us: v(clamp, in) at 0.3 ms (relative)", _flyback),
         ("boost pss: mean v(out) [V]", _boost)]


def main() -> None:
    warnings.simplefilter("ignore")
    print(f"{'case':<66} {'exact error':>12} {'s':>6} {'theta error':>12} {'s':>6}")
    for label, case in CASES:
        exact, exact_seconds = _timed(lambda case=case: case("exact"))
        theta, theta_seconds = _timed(lambda case=case: case("theta"))
        print(f"{label:<66} {exact:12.2e} {exact_seconds:6.2f} {theta:12.2e} {theta_seconds:6.2f}")


if __name__ == "__main__":
    main()
