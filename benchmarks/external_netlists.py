"""Netlists by other people (netlists/external, netlists/vendor): circuitnsds against ngspice.

Prints one row per netlist: the largest error over the signals (compare's `error`: RMS relative
to the RMS value for DC-like signals, to the range otherwise), and both run times. Diode
netlists with Shockley models run a study in N (ideal limit); the others at their own models.

Then the issue-32 batch (netlists/external/SOURCES.md), each run as written: whether ngspice
runs it, whether circuitnsds does, the worst error over the signals (compare's ``error``, as
above; negligible signals left out), or the error we give.

    python benchmarks/external_netlists.py [--batch32 | --batch32b [netlist ...]]

(``--batch32b``: the further batch of issue 32.)
"""

from __future__ import annotations

import re
import subprocess
import sys
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


BATCH_32 = [  # issue 32: (netlist, compare's arguments: the main signal where one is), as written
    ("external/kicad_pe/buck/buck.net", {"window": (20e-3, 30e-3), "signals": ["v(/c)"]}),
    ("external/kicad_pe/BuckBoo/BuckBoo.net", {"window": (20e-3, 30e-3), "signals": ["v(/r_in)"]}),
    ("external/kicad_pe/rectifier/rectifier.net", {"signals": ["v(/a)"]}),
    ("external/kicad_pe/Rectifier_3P/Rectifier_3P.net", {"signals": ["v(net_l2_)"]}),
    ("external/kicad_pe/HWB/HWB.net", {}),
    ("external/kicad_pe/buckclose/buckclose.net", {}),
    ("external/kicad_pe/PushPull_Conv/PushPull_Conv.net", {}),
    ("external/kicad_pe/FlyBavk/FlyBavk.net", {}),
    ("external/ng_cutout1.cir", {"signals": ["v(2)"]}),
    ("external/ng_resume-1.cir", {"signals": ["v(2)"]}),
    ("external/ng_xspice_c2.cir", {}),
    ("external/ng_ddt-test3.cir", {}),
    ("external/ng_transformers1.cir", {}),
    ("external/ng_simple-meas-tran.sp", {}),
    ("external/ng_memristor.sp", {}),
    ("external/ng_integrate1.cir", {}),
    ("external/xy_bug45_diode_bridge.cir", {"signals": ["v(4)"]}),
    ("external/xy_cmc_diode_clipper.cir", {"signals": ["v(4)"]}),
    ("external/xy_diode_clipper_2par.net", {"signals": ["v(4)"]}),
    ("external/xy_bug767a.cir", {"signals": ["v(20)"]}),
    ("external/xy_bug1017.cir", {"signals": ["v(2a)"]}),
    ("external/xy_bug775son_core.cir", {}),
]


BATCH_32B = [  # issue 32, the further batch (netlists/external/SOURCES.md), as written
    ("external/ng_vdmos_dcdc.sp", {"stop": 1e-3, "signals": ["v(out)", "i(l1)"]}),
    ("external/ng_ddt-test1.cir", {"signals": ["v(2)"]}),
    ("external/ng_ddt-test2.cir", {}),
    ("external/ng_meas_expression.cir", {}),
    ("external/ng_pwm-sin.cir", {}),
    ("external/ng_v-i-sources-am-ffm.cir", {}),
    ("external/ng_schmitt.cir", {}),
    ("external/ng_inv_vdmos.sp", {"signals": ["v(3)"]}),
    ("external/xy_gswitch.cir", {}),
    ("external/xy_iswitch_hyst1.cir", {}),
    ("external/xy_vswitch_hyst1.cir", {}),
    ("external/xy_vswitch_a1.cir", {"signals": ["v(1)"]}),
    ("external/xy_ind_path_to_ground.cir", {}),
    ("external/xy_path_to_ground_core.cir", {}),
    ("external/xy_power_b_trap.cir", {}),
    ("external/xy_vdmos_irf130.cir", {}),
    ("external/xy_4049osc.cir", {}),
]


def ngspice_runs(path: Path) -> str:
    """``yes`` (ngspice 39 wrote data rows and reported no failure) or ngspice's first error
    line, from ``ngspice -b`` on the file as written, in its own folder."""
    try:
        done = subprocess.run(["ngspice", "-b", path.name], cwd=path.parent, capture_output=True,
                              text=True, errors="replace", timeout=600)
    except subprocess.TimeoutExpired:
        return "no: over 600 s"
    text = done.stdout + done.stderr
    bad = [line.strip() for line in text.splitlines()
           if re.search(r"error|fatal|too small|interrupted", line, re.IGNORECASE)
           and "PrinterOnly" not in line and "unknown option" not in line]
    if "No. of Data Rows" in text and not any(re.search(r"interrupted|too small|fatal", line, re.I)
                                              for line in bad):
        return "yes"
    return f"no: {' / '.join(bad[:2])[:70] or 'no analysis run'}"


def batch32(names: list[str], batch: list = BATCH_32) -> None:
    """The issue-32 table of ``batch``; ``names``: only these rows (each in a fresh process
    keeps one ngspice library that a run corrupted from spoiling the next rows)."""
    print(f"{'netlist':<50}{'ngspice runs?':<28}{'we run?':<9}{'worst error (signal) or our error'}",
          flush=True)
    for name, arguments in batch:
        if names and name not in names:
            continue
        path = ROOT / name
        ngspice = ngspice_runs(path)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                comparison = compare(path, **arguments)
        except Exception as exc:  # our refusal (or compare's), printed as the user sees it
            message = str(exc).splitlines()[0].replace(str(ROOT) + "/", "")
            print(f"{name:<50}{ngspice:<28}{'no':<9}{message[:170]}", flush=True)
            continue
        run = comparison.run
        worst = run.worst("error")
        result = (f"{100 * worst.error:.3g}% ({worst.signal})" if worst and run.ok
                  else f"ngspice {run.ngspice.status}: {run.ngspice.message[:80]}")
        print(f"{name:<50}{ngspice:<28}{'yes':<9}{result}", flush=True)


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
    if sys.argv[1:2] == ["--batch32"]:
        batch32(sys.argv[2:])
    elif sys.argv[1:2] == ["--batch32b"]:
        batch32(sys.argv[2:], BATCH_32B)
    else:
        main()
