"""SiC buck converter: switching and conduction losses, junction temperatures, from the datasheet.

Run from the repository root::

    python examples/sic_buck_losses.py [--out sic_buck_losses.png] [--fast]

``netlists/thermal/sic_buck.cir``: 600 V -> 300 V, 400 A, 20 kHz; the switch and the
freewheeling diode name thermal descriptions transcribed from the Wolfspeed CAB450M12XM3
datasheet (``netlists/thermal/SOURCES.md``). The periodic steady state gives the loss
table and the thermal steady state (``circuitnsds pss --losses``); beside it, the paper
estimate an engineer makes from the same datasheet figures:

* turn-on ``E_on(Tj)·I_valley/450 A`` and turn-off ``E_off(Tj)·I_peak/450 A`` per period,
  the diode's recovery ``E_rr(Tj)·I_valley/450 A``, at 600 V (the datasheet's figures at
  450 A, 600 V, linear in current as the files assume), times 20 kHz;
* conduction ``D·R_DS(on)(Tj)·(I² + ΔI²/12)``, the inductor's ripple
  ``ΔI = (Vin − Vout)·D/(L·f)``;
* ``Tj = Tcase + R_th(j-c)·P``, solved with the energies and ``R_DS(on)`` at ``Tj`` (the
  diode's ``P`` with its conduction ``(1 − D)·Rd·(I² + ΔI²/12)``, ``Rd`` = 1 mΩ of its model).

The figure is ``tj(s1)`` over the first milliseconds of a transient against
``Tcase + R_th·P·(1 − e^(−t/τ))`` with the steady loss ``P``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import circuitnsds
from circuitnsds.output.measure import losses
from circuitnsds.thermal.junction import analyse, with_junction_temperatures

NETLIST = Path(__file__).resolve().parent.parent / "netlists" / "thermal" / "sic_buck.cir"
VIN, VOUT_NOMINAL, DUTY, FSW, L, RLOAD, TCASE = 600.0, 300.0, 0.5, 20e3, 500e-6, 0.75, 80.0
RTH, TAU, R_DIODE = 0.094, 0.1, 1e-3
DATASHEET = {  # at 600 V, 450 A (netlists/thermal/SOURCES.md): Tj [°C] -> mJ
    "E_on": {25: 25.4, 125: 24.0, 175: 24.4},
    "E_off": {25: 7.51, 125: 8.10, 175: 8.35},
    "E_rr": {25: 0.2, 125: 0.9, 175: 1.1},
}


def at(figure: str, tj: float) -> float:
    """A datasheet energy [J] at 450 A, 600 V, linear in Tj between its figures."""
    points = sorted(DATASHEET[figure].items())
    return 1e-3 * float(np.interp(tj, [t for t, _ in points], [e for _, e in points]))


def r_on(tj: float) -> float:
    """R_DS(on) [Ω]: 2.6 mΩ at 25 °C, 4.7 mΩ at 175 °C, linear between."""
    return float(np.interp(tj, [25.0, 175.0], [2.6e-3, 4.7e-3]))


def paper(vout: float) -> dict[str, float]:
    """The datasheet estimate (module docstring), Tj solved by fixed point."""
    current = vout / RLOAD
    ripple = (VIN - vout) * DUTY / (L * FSW)
    valley, peak = current - ripple / 2, current + ripple / 2
    tj_switch = tj_diode = TCASE
    for _ in range(100):
        parts = {"turn_on": FSW * at("E_on", tj_switch) * valley / 450,
                 "turn_off": FSW * at("E_off", tj_switch) * peak / 450,
                 "conduction": DUTY * r_on(tj_switch) * (current ** 2 + ripple ** 2 / 12),
                 "recovery": FSW * at("E_rr", tj_diode) * valley / 450}
        switch = parts["turn_on"] + parts["turn_off"] + parts["conduction"]
        diode = parts["recovery"] + (1 - DUTY) * R_DIODE * (current ** 2 + ripple ** 2 / 12)
        tj_switch, tj_diode = TCASE + RTH * switch, TCASE + RTH * diode
    return {**parts, "switch": switch, "tj_switch": tj_switch}


def simulate(step: float) -> dict[str, float]:
    """The PSS's loss table and thermal steady state."""
    circuit = circuitnsds.read_netlist(NETLIST)
    result = circuit.pss(1 / FSW, step=step)
    waves = result.waveforms
    thermal = analyse(circuit, waves, steady=True, period=1 / FSW)
    table = losses(waves, circuit, outputs=("rload",), devices=lambda t0, t1: {
        name: device.average(t0, t1) for name, device in thermal.losses.items()})
    s1 = next(row for row in table.rows if row.element == "s1")
    d1 = next(row for row in table.rows if row.element == "d1")
    return {"turn_on": s1.turn_on, "turn_off": s1.turn_off, "conduction": s1.conduction,
            "recovery": d1.recovery, "switch": s1.power,
            "tj_switch": float(thermal.junction["s1"][0]), "efficiency": table.efficiency,
            "vout": float(np.mean(waves["v(out)"]))}


def transient(stop: float, step: float):
    """``(time, tj(s1))`` of a start-up."""
    circuit = circuitnsds.read_netlist(NETLIST)
    waves = circuit.transient(step, stop)
    waves = with_junction_temperatures(waves, analyse(circuit, waves, steady=False,
                                                      period=1 / FSW))
    return waves.time, waves["tj(s1)"]


def figure(time, tj, steady: float, path: str | Path) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 4), layout="constrained")
    axis = fig.subplots()
    axis.plot(1e3 * time, tj, label="tj(s1), circuitnsds")
    axis.plot(1e3 * time, TCASE + (steady - TCASE) * -np.expm1(-time / TAU), "--",
              label="Tcase + Rth·P·(1 − e^(−t/τ)), P of the steady state")
    axis.set_xlabel("time [ms]")
    axis.set_ylabel("junction temperature [°C]")
    axis.grid(True, alpha=0.3)
    axis.legend(fontsize="small")
    axis.set_title("SiC buck 600 V → 300 V, 400 A, 20 kHz (CAB450M12XM3 figures)", fontsize="medium")
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("sic_buck_losses.png"),
                        help="figure to write (default: sic_buck_losses.png)")
    parser.add_argument("--fast", action="store_true", help="coarse steps, a short start-up")
    args = parser.parse_args(argv)
    step = 0.5e-6 if args.fast else 0.1e-6
    simulated = simulate(step)
    estimate = paper(simulated["vout"])
    print(f"{'':<22}{'datasheet estimate':>20}{'circuitnsds':>14}")
    for key, label, unit in (("turn_on", "S1 turn-on", "W"), ("turn_off", "S1 turn-off", "W"),
                             ("conduction", "S1 conduction", "W"), ("recovery", "D1 recovery", "W"),
                             ("switch", "S1 total", "W"), ("tj_switch", "Tj(S1) steady", "°C")):
        print(f"{label:<22}{estimate[key]:>18.4g} {unit:<2}{simulated[key]:>11.4g} {unit}")
    print(f"efficiency {100 * simulated['efficiency']:.3f} % (datasheet losses included)")
    time, tj = transient(5e-3 if args.fast else 20e-3, step)
    figure(time, tj, simulated["tj_switch"], args.out)
    print(f"wrote {args.out}")
    return {"simulated": simulated, "estimate": estimate}


if __name__ == "__main__":
    main()
