"""An adversarial trial (issue 36): small circuits whose right answer is known in closed form,
run as a user would, each answer checked; a wrong number is reported whether or not a
warning came with it (the warnings are listed beside it).

Run from the repository root: ``python benchmarks/adversarial_trial.py``. Prints one line per
case: its name, the expected and obtained values, the verdict (``ok``, ``WRONG``, ``warned``:
wrong but warned, or ``refused``: an error, listed with its message; right for a case whose
expected value is ``inf``, which has no answer) and the warnings. The cases below the first
fifteen are what the trial found wrong with exit 0, each fixed on the branch.
"""

from __future__ import annotations

import math
import sys
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

import circuitnsds


def run(body: str, **options):
    return circuitnsds.read_netlist(f"trial\n{body}\n.end\n").transient(**options)


@dataclass
class Case:
    name: str
    compute: Callable[[], float]
    expected: float
    tolerance: float  # relative, or absolute when expected is 0


def rc_theta_half() -> float:
    waves = run("V1 in 0 1\nR1 in a 1k\nC1 a 0 1u\n.tran 10u 5m uic", theta=0.5)
    return float(np.interp(1e-3, waves.time, waves["v(a)"]))


def half_wave_peak() -> float:
    waves = run("V1 in 0 SIN(0 10 50)\nD1 in out dd\nC1 out 0 100u\nR1 out 0 1meg\n"
                ".model dd D()\n.tran 10u 40m")
    return float(waves["v(out)"].max())


def zener_clamp() -> float:
    waves = run("V1 in 0 20\nR1 in out 1k\nDz 0 out dz\n.model dz D(BV=5.1)\n.tran 1u 100u")
    return float(waves["v(out)"][-1])


def uic_series_caps_middle() -> float:
    waves = run("C1 a m 1u ic=3\nC2 m 0 2u ic=1\nR1 a 0 1k\n.tran 1u 10u uic")
    return float(waves["v(a)"][0])


def uic_inductor_into_resistor() -> float:
    waves = run("L1 a 0 1m ic=2\nR1 a 0 10\n.tran 1u 10u uic")
    return float(waves["v(a)"][0])


def current_source_ramp() -> float:
    waves = run("I1 0 a 1m\nC1 a 0 1u\nR1 a 0 1e12\n.tran 1u 1m uic")
    return float(waves["v(a)"][-1])


def damped_sin() -> float:
    waves = run("V1 a 0 SIN(0 1 1k 0.5m 100)\nR1 a 0 1\n.tran 1u 2m")
    t = 1.25e-3
    return float(np.interp(t, waves.time, waves["v(a)"]))


def pss_rc_square() -> float:
    circuit = circuitnsds.read_netlist("sq\nV1 in 0 PULSE(0 1 0 0 0 0.5m 1m)\nR1 in a 1k\n"
                                       "C1 a 0 1u\n.tran 1u 1m\n.end\n")
    result = circuit.pss()
    return float(result.waveforms["v(a)"].max())


def bridge_mean() -> float:
    waves = run("V1 a b SIN(0 10 50)\nR0 b 0 1meg\nD1 a p dd\nD2 b p dd\nD3 n a dd\nD4 n b dd\n"
                "R1 p n 100\n.model dd D(Vfwd=0.7 Ron=1u)\n.tran 10u 40m")
    v = waves["v(p)"] - waves["v(n)"]
    return float(np.mean(v[waves.time >= 20e-3]))


def transformer_ratio() -> float:
    waves = run("V1 p 0 SIN(0 10 1k)\nL1 p 0 1m\nL2 s 0 4m\nK1 L1 L2 1\nR1 s 0 1k\n.tran 1u 3m uic")
    return float(waves["v(s)"][waves.time > 1e-3].max())


def lc_energy_theta_half() -> float:
    waves = run("C1 a 0 1u ic=1\nL1 a 0 1m\n.tran 1u 5m uic", theta=0.5)
    energy = 0.5e-6 * waves["v(a)"] ** 2 + 0.5e-3 * waves["i(l1)"] ** 2
    return float(energy[-1] / energy[1])


def step_longer_than_stop() -> float:
    waves = run("V1 in 0 1\nR1 in a 1k\nC1 a 0 1u\n.tran 1 1m uic")
    return float(waves["v(a)"][-1])


def rl_switch_opening_with_diode() -> float:
    waves = run("V1 in 0 10\nVg g 0 PULSE(0 1 0 0 0 50u 1)\nS1 in a g 0 sw\nL1 a b 1m\n"
                "R1 b 0 10\nD1 0 a dd\n.model sw SW(VT=0.5 RON=1u)\n.model dd D()\n.tran 1u 200u")
    return float(np.interp(150e-6, waves.time, waves["i(l1)"]))


def pulse_only_edge() -> float:
    waves = run("V1 a 0 PULSE(0 1 10u 0 0 20u 1)\nR1 a 0 1\n.tran 1u 100u")
    return float(np.interp(20e-6, waves.time, waves["v(a)"]))


def ic_without_uic_on_capacitor_node() -> float:
    waves = run("V1 in 0 5\nR1 in a 1k\nC1 a 0 1u\n.ic v(a)=2\n.tran 10u 1m")
    return float(waves["v(a)"][0])


def pwl_drop_theta_half() -> float:
    waves = run("V1 in 0 PWL(0 0 1m 1 1m 0 2m 0)\nR1 in a 1\nC1 a 0 1u\n.tran 10u 3m", theta=0.5)
    return float(np.abs(waves["i(r1)"][(waves.time > 1.035e-3) & (waves.time < 2e-3)]).max())


def pwm_closing_theta_half() -> float:
    waves = run("V1 in 0 12\nVg g 0 PULSE(0 5 1u 0 0 5u 10u)\nS1 in sw g 0 sw1\nC1 sw 0 3n\n"
                "R1 sw 0 10\n.model sw1 SW(VT=2.6 RON=10m)\n.tran 1n 3u", theta=0.5)
    current = waves["i(s1)"]
    closed = int(np.argmax(np.abs(current) > 0.5))
    return float(np.abs(current[closed + 5:] - 12 / 10.01).max())


def uic_diode_current_at_start() -> float:
    waves = run("C1 a 0 1u ic=10\nD1 a b dd\nR1 b 0 1k\n.model dd D()\n.tran 1u 10u uic")
    return float(waves["i(d1)"][0])


def negative_frequency_sin() -> float:
    waves = run("V1 a 0 SIN(0 1 -1k)\nR1 a 0 1\n.tran 100u 2m")
    return float(np.interp(0.2e-3, waves.time, waves["v(a)"]))  # (a reported point)


def half_bridge_lc_at_resonance_pss() -> float:
    circuit = circuitnsds.read_netlist(
        "hb\nVin in 0 12\nVg g 0 PULSE(0 1 0 0 0 99.3456u 198.6914u)\nS1 in sw g 0 sw\n"
        "S2 sw 0 0 g swn\nL1 sw a 1m\nC1 a 0 1u\nRb a 0 1e9\n.model sw SW(VT=0.5 RON=1u)\n"
        ".model swn SW(VT=-0.5 RON=1u)\n.tran 1u 2m\n.end\n")
    return float(np.abs(circuit.pss().waveforms["v(a)"]).max())


CASES = [
    Case("RC at θ = ½, v(τ)", rc_theta_half, 1 - math.exp(-1), 2e-4),
    Case("half-wave peak detector", half_wave_peak, 10.0, 1e-3),
    Case("Zener clamp (BV=5.1)", zener_clamp, 5.1, 1e-2),
    Case("UIC series caps: v(a) at t = 0", uic_series_caps_middle, 4.0, 1e-9),
    Case("UIC inductor into 10 Ω: v(a) at t = 0", uic_inductor_into_resistor, -20.0, 1e-9),
    Case("current source charging 1 µF for 1 ms", current_source_ramp, 1.0, 1e-6),
    Case("SIN with delay and damping at 1.25 ms", damped_sin,
         math.sin(2 * math.pi * 1e3 * 0.75e-3) * math.exp(-100 * 0.75e-3), 1e-3),
    Case("PSS of RC under a square wave: peak", pss_rc_square,
         (1 - math.exp(-0.5)) / (1 - math.exp(-1.0)), 2e-3),
    Case("bridge with Vfwd = 0.7: mean output", bridge_mean,
         (2 / math.pi) * 10 - 1.4 * (1 - 2 * math.asin(1.4 / 10) / math.pi)
         - (2 / math.pi) * 10 * (1 - math.cos(math.asin(1.4 / 10))), 5e-3),
    Case("transformer 1:2 at K = 1: peak secondary", transformer_ratio, 20.0, 1e-3),
    Case("LC at θ = ½: energy kept over 5 ms", lc_energy_theta_half, 1.0, 1e-9),
    Case("TSTEP longer than TSTOP: RC at 1 ms", step_longer_than_stop, 1 - math.exp(-1), 2e-2),
    Case("RL freewheeling through a diode at 150 µs", rl_switch_opening_with_diode,
         1.0 * (1 - math.exp(-0.5)) * math.exp(-1.0), 2e-2),
    Case("PULSE edge of zero rise at 20 µs", pulse_only_edge, 1.0, 1e-12),
    Case(".ic without UIC: v(a) at t = 0", ic_without_uic_on_capacitor_node, 2.0, 1e-9),
    Case("PWL drop across 1 Ω·1 µF at θ = ½: |i| after", pwl_drop_theta_half, 0.0, 1e-3),
    Case("PWM switch onto 3 nF at θ = ½: |i - 1.2 A|", pwm_closing_theta_half, 0.0, 3e-3),
    Case("UIC: diode current at t = 0", uic_diode_current_at_start, 0.01, 1e-9),
    Case("SIN of negative frequency at 0.2 ms", negative_frequency_sin,
         -math.sin(2 * math.pi * 0.2), 1e-9),
    # no periodic solution: the right answer is a refusal (a value is wrong, whatever it is)
    Case("PSS: half bridge into LC at resonance", half_bridge_lc_at_resonance_pss, math.inf, 0.0),
]


def main() -> int:
    wrong = 0
    print(f"{'case':44} {'expected':>12} {'got':>12}  verdict")
    for case in CASES:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                got = case.compute()
            except circuitnsds.CircuitnsdsError as exc:
                print(f"{case.name:44} {case.expected:>12.6g} {'-':>12}  refused: {exc}")
                continue
        scale = abs(case.expected) if case.expected else 1.0
        good = abs(got - case.expected) <= case.tolerance * scale
        said = [str(w.message)[:90] for w in caught if issubclass(w.category, UserWarning)]
        verdict = "ok" if good else ("warned" if said else "WRONG")
        wrong += verdict == "WRONG"
        print(f"{case.name:44} {case.expected:>12.6g} {got:>12.6g}  {verdict}"
              + (f"  [{'; '.join(said)}]" if said else ""))
    print(f"{len(CASES)} cases, {wrong} wrong with no word")
    return 1 if wrong else 0


if __name__ == "__main__":
    sys.exit(main())
