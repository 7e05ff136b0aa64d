"""Netlists by other people (netlists/external, netlists/vendor): circuitnsds against ngspice.

Prints one row per netlist: the largest error over the signals (compare's `error`: RMS relative
to the RMS value for DC-like signals, to the range otherwise), and both run times. Diode
netlists with Shockley models run a study in N (ideal limit); the others at their own models.

    python benchmarks/external_netlists.py
"""

from __future__ import annotations

import warnings
from pathlib import Path

from circuitnsds.compare import compare

ROOT = Path(__file__).resolve().parent.parent / "netlists"
CASES = [
    ("external/ng_switches_manual_p92.cir", None, {}),
    ("external/ng_cntrl_sources.cir", None, {}),
    ("external/ng_rc_pulse.cir", None, {}),
    ("external/ng_if_batchmode_rc.cir", None, {}),
    ("external/xy_rlc_step.cir", None, {}),
    ("external/xy_mutual_inductors.cir", None, {}),
    ("external/xy_cccs_ftest.cir", None, {}),
    ("external/xy_ic_rc.cir", None, {}),
    ("external/spicelib_top_circuit.cir", None, {}),
    ("external/kicad_rectifier.cir", None, {}),
    ("external/ngspice_simple_diode.cir", None, {}),
    ("external/numbered_nodes_rectifier.cir", [1, 0.1, 0.03], {}),
    ("external/xy_diode_pulse.cir", [1, 0.1, 0.03], {}),
    ("external/xy_subckt_diode_m5.cir", [1, 0.1, 0.03], {}),
    ("external/xy_diode_clipper.cir", [1, 0.1, 0.03], {"step": 1e-6, "stop": 1e-3}),
    ("external/buck_sw_ron_only.cir", None, {"window": (0.8e-3, 1e-3)}),
    ("external/buck_csw_ron_only.cir", None, {"window": (0.8e-3, 1e-3)}),
    ("vendor/halfwave_1n4007.cir", None, {"window": (0.1, 0.2)}),
    ("vendor/bridge_1n5819.cir", None, {"window": (0.1, 0.2)}),
    ("vendor/zener_1n4733.cir", None, {}),
]


def main() -> None:
    print(f"{'netlist':<40}{'ngspice':<22}{'error':>10}  {'signal':<14}{'ours [s]':>9}{'ngspice [s]':>12}")
    for name, n, arguments in CASES:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            comparison = compare(ROOT / name, n=n, **arguments)
        for run in comparison.runs:
            worst = run.worst("error")
            label = run.overrides.label() + (" (lta)" if any("lta" in note for note in comparison.notes)
                                             else "")
            error = f"{100 * worst.error:.3g}%" if worst else run.ngspice.status
            print(f"{name:<40}{label:<22}{error:>10}  {worst.signal if worst else '':<14}"
                  f"{comparison.circuitnsds_seconds:>9.3f}{run.ngspice.seconds:>12.3f}")


if __name__ == "__main__":
    main()
