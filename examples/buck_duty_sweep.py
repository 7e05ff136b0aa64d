"""Buck converter: output voltage, output ripple and efficiency against the duty cycle.

Run from the repository root::

    python examples/buck_duty_sweep.py [--out buck_duty_sweep.png] [--fast]

A 12 V, 100 kHz buck converter (ideal switch with 50 mΩ on-resistance, freewheeling
diode with a 0.7 V drop, 100 µH inductor with 50 mΩ winding resistance, 100 µF
output capacitor, 5 Ω load) is simulated for each duty cycle D in its periodic
steady state, found by shooting (see :func:`periodic_state`); a few periods then give:

* the mean output voltage, against the lossless ``D·Vin``;
* the peak-to-peak output ripple, against the textbook ``(1-D)·(Vout+Vfwd) / (8·L·C·f²)``
  (the inductor sees ``-(Vout+Vfwd)`` while the diode conducts);
* the efficiency ``P(Rload) / P(V1)`` with period-averaged powers, against the
  conduction-loss estimate ``(1-D)·Vfwd·I + I²·(D·Ron + (1-D)·Rd + Rw)``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from circuitnsds.frontend.build import CircuitBuilder
from circuitnsds.output import measure

VIN, FSW, L, C, RLOAD = 12.0, 100e3, 100e-6, 100e-6, 5.0
RON_SWITCH, VFWD, RON_DIODE, R_WINDING = 50e-3, 0.7, 20e-3, 50e-3
PERIOD = 1.0 / FSW

# The converter with its duty cycle, initial state and time grid as parameters: read once,
# then built for each run (circuitnsds.frontend.build.CircuitBuilder), no text edited.
NETLIST = f"""Buck converter, duty cycle D
.param duty=0.5 v0=0 i0=0 tstep=50n tstop={PERIOD!r}
V1 in 0 DC {VIN!r}
Vgate gate 0 PULSE(0 1 0 0 0 {{duty*{PERIOD!r}}} {PERIOD!r})
S1 in sw gate 0 power_switch
D1 0 sw freewheel
L1 sw lx {L!r} ic={{i0}}
RL lx out {R_WINDING!r}
C1 out 0 {C!r} ic={{v0}}
Rload out 0 {RLOAD!r}
.model power_switch SW(VT=0.5 VH=0.1 RON={RON_SWITCH!r} ROFF=1e9)
.model freewheel D(Vfwd={VFWD!r} Ron={RON_DIODE!r})
.tran {{tstep}} {{tstop}} uic
.end
"""
BUILDER = CircuitBuilder.load(NETLIST)


def buck(duty: float, voltage: float, current: float, stop: float, step: float):
    """The converter as a Circuit, starting from ``v(out) = voltage`` and ``i(l1) = current``."""
    return BUILDER.build({"duty": duty, "v0": voltage, "i0": current, "tstop": stop, "tstep": step})


def run(duty: float, state: np.ndarray, periods: int, step: float):
    """Simulate ``periods`` switching periods from ``state = (v(out), i(l1))``."""
    circuit = buck(duty, state[0], state[1], periods * PERIOD, step)
    return circuit, circuit.transient()


def periodic_state(duty: float, step: float) -> np.ndarray:
    """``(v(out), i(l1))`` at the start of a period in the periodic steady state, by shooting.

    Over one period the converter maps its state affinely (``x(T) = Φ·x(0) + g``) as long
    as the switching sequence does not change (continuous conduction), so the
    fixed point ``x = Φ·x + g`` follows from three one-period runs; a further chord
    step absorbs what is left. Much faster than waiting ~100 periods for the LC filter's
    transient to die out, and exact, not nearly settled.
    """
    def after_one_period(x: np.ndarray) -> np.ndarray:
        waves = run(duty, x, 1, step)[1]
        return np.array([waves["v(out)"][-1], waves["i(l1)"][-1]])

    # start from the lossy averaged estimate: D·Vin = Vout + (1-D)·Vfwd + I·(D·Ron + (1-D)·Rd + Rw)
    resistance = duty * RON_SWITCH + (1 - duty) * RON_DIODE + R_WINDING
    voltage = (duty * VIN - (1 - duty) * VFWD) / (1 + resistance / RLOAD)
    x = np.array([voltage, voltage / RLOAD])
    residual = after_one_period(x) - x
    jacobian = np.empty((2, 2))  # of x(T) - x(0): Φ - I, by finite differences
    for k, delta in enumerate((1e-3, 1e-3)):
        shifted = x.copy()
        shifted[k] += delta
        jacobian[:, k] = (after_one_period(shifted) - shifted - residual) / delta
    for _ in range(5):  # chord iterations; one suffices when the map is exactly affine
        x = x - np.linalg.solve(jacobian, residual)
        residual = after_one_period(x) - x
        if np.all(np.abs(residual) < 1e-7 * np.maximum(np.abs(x), 1.0)):
            break
    return x


def operating_point(duty: float, fast: bool = False) -> dict[str, float]:
    """Steady-state figures of the converter at one duty cycle (volts, watts, fraction)."""
    step = PERIOD / (50 if fast else 200)
    periods = 3 if fast else 10
    circuit, waves = run(duty, periodic_state(duty, step), periods, step)
    p_out = measure.power(waves, circuit.element("rload"), period=PERIOD)
    p_in = -measure.power(waves, circuit.element("v1"), period=PERIOD)  # delivered by V1
    vout = measure.mean(waves, "v(out)", period=PERIOD)
    return {
        "duty": duty,
        "vout": vout,
        "ripple": measure.ripple(waves, "v(out)"),
        "ripple_estimate": (1 - duty) * (vout + VFWD) / (8 * L * C * FSW ** 2),
        "p_out": p_out,
        "p_in": p_in,
        "efficiency": p_out / p_in,
        "efficiency_estimate": p_out / (p_out + conduction_loss(duty, vout / RLOAD)),
    }


def conduction_loss(duty: float, current: float) -> float:
    """Average conduction loss [W] at load current ``current`` [A], ripple neglected."""
    resistance = duty * RON_SWITCH + (1 - duty) * RON_DIODE + R_WINDING
    return (1 - duty) * VFWD * current + resistance * current ** 2


def sweep(duties: list[float], fast: bool = False) -> list[dict[str, float]]:
    """:func:`operating_point` for each duty cycle."""
    return [operating_point(duty, fast) for duty in duties]


def figure(rows: list[dict[str, float]], path: str | Path) -> None:
    """Vout, ripple and efficiency against D in three panels, written to ``path``."""
    from matplotlib.figure import Figure

    duty = [100 * r["duty"] for r in rows]
    fig = Figure(figsize=(7, 8), layout="constrained")
    top, middle, bottom = fig.subplots(3, 1, sharex=True)
    top.plot(duty, [r["vout"] for r in rows], "o-", label="circuitnsds")
    top.plot(duty, [r["duty"] * VIN for r in rows], "--", label="D·Vin (lossless)")
    top.set_ylabel("mean output [V]")
    middle.plot(duty, [1e3 * r["ripple"] for r in rows], "o-", label="circuitnsds")
    middle.plot(duty, [1e3 * r["ripple_estimate"] for r in rows], "--",
                label="(1-D)·(Vout+Vfwd)/(8LCf²)")
    middle.set_ylabel("output ripple [mV p-p]")
    bottom.plot(duty, [100 * r["efficiency"] for r in rows], "o-", label="P(Rload) / P(V1)")
    bottom.plot(duty, [100 * r["efficiency_estimate"] for r in rows], "--",
                label="conduction-loss estimate")
    bottom.set_ylabel("efficiency [%]")
    bottom.set_xlabel("duty cycle D [%]")
    for axis in (top, middle, bottom):
        axis.grid(True, alpha=0.3)
        axis.legend(fontsize="small")
    top.set_title(f"Buck {VIN:g} V, {FSW / 1e3:g} kHz, L = {L * 1e6:g} µH, C = {C * 1e6:g} µF, "
                  f"R = {RLOAD:g} Ω", fontsize="medium")
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> list[dict[str, float]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("buck_duty_sweep.png"),
                        help="figure to write (default: buck_duty_sweep.png)")
    parser.add_argument("--fast", action="store_true", help="three duty cycles, coarse steps")
    args = parser.parse_args(argv)
    duties = [0.25, 0.5, 0.75] if args.fast else [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]
    rows = sweep(duties, args.fast)
    print(f"{'D':>5} {'Vout [V]':>9} {'D·Vin':>7} {'ripple [mV]':>12} {'estimate':>9} "
          f"{'Pout [W]':>9} {'efficiency':>11} {'estimate':>9}")
    for r in rows:
        print(f"{r['duty']:5.2f} {r['vout']:9.3f} {r['duty'] * VIN:7.2f} {1e3 * r['ripple']:12.2f} "
              f"{1e3 * r['ripple_estimate']:9.2f} {r['p_out']:9.3f} {100 * r['efficiency']:10.1f}% "
              f"{100 * r['efficiency_estimate']:8.1f}%")
    figure(rows, args.out)
    print(f"wrote {args.out}")
    return rows


if __name__ == "__main__":
    main()
