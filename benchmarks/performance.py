"""Issue 8 benchmark: circuitnsds against ngspice on switching circuits; prints one table, writes JSON.

For each case:

* circuitnsds: whole-process wall time of ``python -m circuitnsds run NETLIST -r out.raw
  --signals v(out)`` (start-up, netlist, simulation and writing the waveform included), the
  in-process stepping time, steps, µs per step, and the share of steps taken by the mode
  loop (the mode did not change, no MLCP solved);
* ngspice: whole-process wall time of ``ngspice -b`` on the same netlist (Shockley diodes)
  with a ``.control`` block that runs and writes ``v(out)`` with ``wrdata``; whether it finished;
* accuracy of both: the largest difference of ``v(out)`` from a circuitnsds run with a 10×
  smaller step (the ideal reference) over a window, normalised by the reference's range;
  for case 1 also ngspice against its own fine-step reference (TMAX = TSTEP/10).

The issue 8 table measures the θ-method (``.options method=theta``; the default is ``auto``).
Case 1 runs with implicit Euler (θ = 1) and with ``--theta 0.5`` (the
trapezoidal rule, second order here because every switching instant is a grid point), and
once more at θ = 0.5 with circuitnsds at 0.08 µs (ngspice stays at 0.1 µs): the step at
which its error against its own reference is no larger than ngspice's. A
"start-up" row times both simulators on the same netlist over 10 steps: the fixed cost of
a whole process (for circuitnsds the interpreter, numpy/scipy/networkx/numba imports and
numba's first call), which bounds the whole-process ratio however fast the stepping is.

Usage: ``python benchmarks/performance.py [--quick] [--json out.json]``. ``--quick``
shortens every run (a smoke test; the figures in the issue note come from the full run).
ngspice is optional: without it the ngspice columns say so.

The issue 19 table (``--part issue19``, also run first by default): every case of that
issue, as a user runs it, whole processes, the median of ``--repeats`` runs each (ours, numba's
and ngspice's interleaved, one of each per repeat):

* buck 24 -> 12 V, 100 ms at 0.1 µs, ``run -o out.csv --signals v(out)``;
* the bundled bridge rectifier (5,000 steps), ``run -o bridge.csv --plot bridge.png``,
  warm (compiled code cached) and as the first run after an install (an empty cache
  folder, ``CIRCUITNSDS_CACHE_DIR``);
* ``import circuitnsds`` and reading the bridge's netlist, and the floor every whole-process
  figure contains, ``python -c "import numpy"``, measured alongside;
* flyback 48 -> 12 V with RCD clamp, 100 pF Coss and coupled inductors, 3 ms at 10 ns,
  θ = 0.5 and θ = 1;
* boost in discontinuous conduction, 60 ms at 0.05 µs (1.2M steps);
* 4-stage full-wave RF voltage multiplier, 16 diodes;
* the CSV writers on 1M rows × 2 columns (compiled and Python), against ``numpy.savetxt``
  and pandas (``benchmarks/csv_writers.py`` has the whole-process side);

ngspice runs the same netlists in batch mode (``wrdata v(out)``). Each whole-process case
also runs with ``CIRCUITNSDS_NATIVE=0`` (column ``numba[s]``): the mode-table loop compiled by
numba instead of the C loop built at install (``circuitnsds/engine/_dense_native.c``; the two
give the same numbers bit for bit), what an install without a C compiler gets.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import circuitnsds
from circuitnsds.output.rawfile import read_raw

HERE = Path(__file__).parent
NETLISTS = HERE / "netlists"


def user_environment(env: dict | None = None) -> dict:
    """``env`` (default this process's) as an installed package runs: without
    ``PYTHONDONTWRITEBYTECODE``, which would make every process compile the package's source
    again (~0.15 s; an install writes the ``.pyc`` files)."""
    run_env = dict(os.environ if env is None else env)
    run_env.pop("PYTHONDONTWRITEBYTECODE", None)
    return run_env


def run_process(command: list[str], cwd: Path) -> tuple[float, subprocess.CompletedProcess]:
    started = time.perf_counter()
    done = subprocess.run(command, cwd=cwd, capture_output=True, text=True, check=False,
                          env=user_environment())
    return time.perf_counter() - started, done


def with_tran(text: str, tran: str, control: str | None = None) -> str:
    """Replace the ``.tran`` line and, for ngspice, add a ``.control`` block before ``.end``."""
    text = re.sub(r"(?im)^\.tran.*$", tran, text)
    if control:
        text = re.sub(r"(?im)^\.end\s*$", control + "\n.end", text)
    return text


def ours_process(netlist_text: str, workdir: Path, name: str, theta: float = 1.0) -> dict:
    """Whole-process run of the command line, then read back what it wrote."""
    path = workdir / f"{name}.cir"
    path.write_text(netlist_text)
    raw = workdir / f"{name}.raw"
    seconds, done = run_process([sys.executable, "-m", "circuitnsds", "run", str(path), "-r", str(raw),
                                 "--signals", "v(out)", "--theta", str(theta), "-q"], workdir)
    if done.returncode != 0:
        return {"wall_s": seconds, "ok": False, "error": done.stderr.strip()[-300:]}
    data = read_raw(raw)
    return {"wall_s": seconds, "ok": True, "time": data.time, "v": data["v(out)"]}


def ours_in_process(netlist_text: str, step: float | None = None, stop: float | None = None,
                    theta: float = 1.0) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuitnsds.read_netlist(netlist_text)
        started = time.perf_counter()
        waves = circuit.transient(step=step, stop=stop, theta=theta)
        wall = time.perf_counter() - started
    stats = waves.stats
    # (a run of the default's exact integrator has rows, segments and events, no mapped steps:
    # those columns are NaN for it)
    mapped = stats.get("mapped_steps", float("nan"))
    return {"wall_s": wall, "stepping_s": stats["seconds"], "steps": stats["steps"],
            "us_per_step": 1e6 * stats["seconds"] / stats["steps"],
            "us_per_mapped_step": 1e6 * stats.get("mapped_seconds", float("nan")) / max(mapped, 1),
            "mapped_share": mapped / stats["steps"], "mlcp_steps": stats.get("mlcp_steps", float("nan")),
            "pairs": stats["pairs"], "unknowns": stats["unknowns"],
            "time": waves.time, "v": waves.signals.get("v(out)")}


def ngspice_process(netlist_text: str, tran: str, workdir: Path, name: str) -> dict:
    if shutil.which("ngspice") is None:
        return {"ok": False, "error": "ngspice not installed", "wall_s": float("nan")}
    out = workdir / f"{name}.ng.txt"
    control = f".control\nrun\nwrdata {out} v(out)\n.endc"
    path = workdir / f"{name}.ng.cir"
    path.write_text(with_tran(netlist_text, tran, control))
    seconds, done = run_process(["ngspice", "-b", str(path)], workdir)
    log = done.stdout + done.stderr
    failure = re.search(r"(?i)(timestep too small[^\n]*|singular matrix[^\n]*|no convergence[^\n]*)", log)
    if not out.exists() or out.stat().st_size == 0:
        return {"ok": False, "wall_s": seconds, "error": failure.group(1) if failure else log.strip()[-200:]}
    data = np.loadtxt(out)
    return {"ok": failure is None, "wall_s": seconds, "error": failure.group(1) if failure else "",
            "time": data[:, 0], "v": data[:, 1], "stopped_at": float(data[-1, 0])}


def error_against(reference: dict, run: dict, window: tuple[float, float]) -> float:
    """max |v - v_ref| / range(v_ref) on the reference grid inside ``window``."""
    if not run.get("time") is not None or len(run.get("time", [])) == 0:
        return float("nan")
    t = reference["time"]
    keep = (t >= window[0]) & (t <= min(window[1], run["time"][-1]))
    v_ref = reference["v"][keep]
    v = np.interp(t[keep], run["time"], run["v"])
    span = float(np.ptp(v_ref)) or 1.0
    return float(np.max(np.abs(v - v_ref)) / span)


def case(label: str, netlist: Path, step: float, stop: float, window: float, workdir: Path,
         own_reference: bool = False, theta: float = 1.0, our_step: float | None = None) -> dict:
    """One row: both simulators on ``netlist`` at ``step`` (circuitnsds at ``our_step`` when
    given, to compare at equal accuracy), errors over ``[0, window]``. Ours runs the θ-method
    (``.options method=theta``: these rows measure θ; the default, ``auto``, would take the
    exact integrator, whose error against its own finer grid is round-off)."""
    text = netlist.read_text()
    theta_text = re.sub(r"(?im)^\.end\s*$", ".options method=theta\n.end", text)
    tran = f".tran {step!r} {stop!r}"
    mine = our_step or step
    our_tran = f".tran {mine!r} {stop!r}"
    name = re.sub(r"\W+", "_", label)  # file names for ngspice: no spaces
    ours = ours_process(with_tran(theta_text, our_tran), workdir, name, theta)
    inproc = ours_in_process(with_tran(theta_text, our_tran), theta=theta)
    reference = ours_in_process(with_tran(theta_text, f".tran {mine / 10!r} {window!r}"), theta=theta)
    ngspice = ngspice_process(text, tran, workdir, name)
    row = {
        "case": label, "steps": inproc["steps"], "pairs": inproc["pairs"], "unknowns": inproc["unknowns"],
        "ours_process_s": ours["wall_s"], "ours_stepping_s": inproc["stepping_s"],
        "us_per_step": inproc["us_per_step"], "mapped_share": inproc["mapped_share"],
        "us_per_mapped_step": inproc["us_per_mapped_step"],
        "ours_error": error_against(reference, inproc, (0.0, window)),
        "ngspice_process_s": ngspice["wall_s"], "ngspice_ok": ngspice["ok"],
        "ngspice_note": ngspice.get("error", ""), "ngspice_stopped_at": ngspice.get("stopped_at"),
        "ngspice_error_vs_ideal": error_against(reference, ngspice, (0.0, window)),
    }
    row["ratio"] = row["ngspice_process_s"] / row["ours_process_s"] if ours["ok"] else float("nan")
    if own_reference:
        ng_fine = ngspice_process(text, f".tran {step!r} {window!r} 0 {step / 10!r}", workdir,
                                  name + "_fine")
        ours_short = ours_in_process(with_tran(theta_text, f".tran {mine!r} {window!r}"), theta=theta)
        row["ngspice_error_vs_own_fine"] = error_against(ng_fine, ngspice, (0.0, window)) \
            if ng_fine["ok"] else float("nan")
        row["ours_error_vs_own_fine"] = error_against(reference, ours_short, (0.0, window))
    return row


def start_up(netlist: Path, workdir: Path) -> dict:
    """Fixed cost of a whole process: the buck netlist over 10 steps (interpreter, imports,
    numba's first call / ngspice's start-up, netlist, operating point, writing)."""
    text = with_tran(netlist.read_text(), ".tran 0.1u 1u")
    ours = ours_process(text, workdir, "startup")
    ngspice = ngspice_process(text, ".tran 0.1u 1u", workdir, "startup")
    return {"case": "start-up (10 steps)", "steps": 10, "pairs": 1, "ours_process_s": ours["wall_s"],
            "ngspice_process_s": ngspice["wall_s"], "ngspice_ok": ngspice["ok"],
            "ngspice_note": ngspice.get("error", ""),
            "ratio": ngspice["wall_s"] / ours["wall_s"]}


def ladder_netlist(sections: int, stop: float) -> str:
    """N diode-RC sections in cascade from a source of 10 V with a 1 V, 1 kHz ripple. The diodes
    conduct most of the time (the mode holds for tens of steps) and block together while the
    source falls faster than the capacitors discharge (two mode changes per period)."""
    lines = [f"Ladder of {sections} diode-RC sections", "V1 n0 0 SIN(10 1 1k)"]
    for k in range(1, sections + 1):
        lines += [f"D{k} n{k - 1} n{k} dl", f"R{k} n{k} 0 {1e3 * sections!r}", f"C{k} n{k} 0 1u"]
    lines += ["Rout out 0 1meg", f"Rlink n{sections} out 1", ".model dl D(Ron=1)",
              f".tran 10u {stop!r}", ".options method=theta", ".end"]  # (θ's mapped steps measured)
    return "\n".join(lines) + "\n"


ISSUE19_CASES = [
    # label, netlist, extra arguments of `run`, .tran override for a quick run
    ("buck 100 ms, CSV of v(out)", NETLISTS / "buck_100ms.cir", ["--signals", "v(out)"]),
    ("bridge, CSV + PNG (warm)", HERE.parent / "netlists" / "bridge_rectifier.cir", ["--plot", "{png}"]),
    ("flyback Coss θ=0.5", NETLISTS / "flyback_coss.cir", ["--signals", "v(out)", "--theta", "0.5"]),
    ("flyback Coss θ=1", NETLISTS / "flyback_coss.cir", ["--signals", "v(out)", "--theta", "1"]),
    ("boost DCM 60 ms", NETLISTS / "boost_dcm_60ms.cir", ["--signals", "v(out)"]),
    ("RF multiplier 16 pairs", NETLISTS / "rf_multiplier.cir", ["--signals", "v(out)"]),
]


NUMBA_LOOP = {**os.environ, "CIRCUITNSDS_NATIVE": "0"}
"""The environment of a run whose mode-table loop is numba's, not the C loop's (circuitnsds.native)."""


def _median_process(command: list[str], cwd: Path, repeats: int, env: dict | None = None,
                    fresh: Path | None = None) -> tuple[float, subprocess.CompletedProcess]:
    """Median wall time of ``repeats`` runs (a new empty cache folder under ``fresh`` for each
    run when given: the first run after an install)."""
    times, cpu, done = [], [], None
    for index in range(repeats):
        run_env = user_environment(env)
        if fresh is not None:
            run_env["CIRCUITNSDS_CACHE_DIR"] = str(fresh / f"cache{index}")
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        done = subprocess.run(command, cwd=cwd, capture_output=True, text=True, check=False, env=run_env)
        times.append(time.perf_counter() - started)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    done.cpu_s = float(np.median(cpu))  # user + system CPU seconds (children: a background warm-up too)
    return float(np.median(times)), done


def _median_run(runs: list[tuple[float, subprocess.CompletedProcess]]
                ) -> tuple[float, subprocess.CompletedProcess]:
    """The median wall time of single runs of :func:`_median_process`, and the result of the
    first that failed (else the last) with the median CPU time of all of them."""
    done = next((d for _, d in runs if d.returncode != 0), runs[-1][1])
    done.cpu_s = float(np.median([d.cpu_s for _, d in runs]))
    return float(np.median([t for t, _ in runs])), done


def _quick_tran(text: str, factor: float) -> str:
    """The netlist with its .tran stop time multiplied by ``factor`` (a smoke test)."""
    found = re.search(r"(?im)^\.tran\s+(\S+)\s+(\S+)", text)
    step, stop = found.group(1), circuitnsds.values.parse_value(found.group(2))
    return with_tran(text, f".tran {step} {stop * factor!r}")


def issue19(workdir: Path, repeats: int, scale: float, only: str | None = None) -> list[dict]:
    """The rows of the issue 19 table (see the module docstring); ``only``: the cases whose
    label contains it (and no CSV rows)."""
    rows = []
    for label, netlist, extra in ISSUE19_CASES:
        if only is not None and only.lower() not in label.lower():
            continue
        text = netlist.read_text() if scale == 1.0 else _quick_tran(netlist.read_text(), scale)
        name = re.sub(r"\W+", "_", label)
        path = workdir / f"{name}.cir"
        path.write_text(text)
        arguments = [a.replace("{png}", str(workdir / f"{name}.png")) for a in extra]
        command = [sys.executable, "-m", "circuitnsds", "run", str(path), "-o", str(workdir / f"{name}.csv"),
                   "-q", *arguments]
        # interleaved (ours, numba's, ngspice, ours, ...): the machine's speed drifts by tens of
        # per cent over minutes on shared cores, and a ratio should compare runs made together
        tran = re.search(r"(?im)^\.tran.*$", text).group(0)
        runs: dict[str, list] = {"ours": [], "numba": [], "ngspice": []}
        for _ in range(repeats):
            runs["ours"].append(_median_process(command, workdir, 1))
            runs["numba"].append(_median_process(command, workdir, 1, env=NUMBA_LOOP))
            runs["ngspice"].append(ngspice_process(text, tran, workdir, name))
        ours, done = _median_run(runs["ours"])
        numba, numba_done = _median_run(runs["numba"])
        ng = runs["ngspice"]
        theta = float(arguments[arguments.index("--theta") + 1]) if "--theta" in arguments else 1.0
        inproc = ours_in_process(text, theta=theta)
        rows.append({"case": label, "steps": inproc["steps"], "pairs": inproc["pairs"],
                     "ours_process_s": ours if done.returncode == 0 else float("nan"),
                     "ours_cpu_s": done.cpu_s,
                     "numba_process_s": numba if numba_done.returncode == 0 else float("nan"),
                     "numba_cpu_s": numba_done.cpu_s,
                     "ours_note": "" if done.returncode == 0 else done.stderr.strip()[-120:],
                     "us_per_step": inproc["us_per_step"], "mapped_share": inproc["mapped_share"],
                     "ngspice_process_s": float(np.median([r["wall_s"] for r in ng])),
                     "ngspice_ok": all(r["ok"] for r in ng), "ngspice_note": ng[0].get("error", "")})
        if label.startswith("bridge"):  # the same command as the first run after an install
            first, done = _median_process(command, workdir, repeats, fresh=workdir / "fresh")
            rows.append({"case": "bridge, first run after install", "steps": inproc["steps"],
                         "pairs": inproc["pairs"], "ours_process_s": first})
            code = f"import circuitnsds; circuitnsds.read_netlist({str(netlist)!r})"
            # with the machine's floor measured alongside: the interpreter and numpy alone, which
            # every figure above contains and which drifts the most (0.09–0.30 s on 2026-11-23)
            reading, floor = [], []
            for _ in range(repeats):
                reading.append(_median_process([sys.executable, "-c", code], workdir, 1)[0])
                floor.append(_median_process([sys.executable, "-c", "import numpy"], workdir, 1)[0])
            rows.append({"case": "import + read netlist", "steps": 0, "pairs": inproc["pairs"],
                         "ours_process_s": float(np.median(reading))})
            rows.append({"case": "floor: python -c 'import numpy'", "steps": 0, "pairs": 0,
                         "ours_process_s": float(np.median(floor))})
    if only is None:
        rows.extend(csv_rows(workdir, 1_000_000 if scale == 1.0 else 100_000))
    for row in rows:
        ok = row.get("ngspice_ok", True) and row.get("ngspice_process_s") == row.get("ngspice_process_s")
        row["ratio"] = (row["ngspice_process_s"] / row["ours_process_s"]
                        if ok and "ngspice_process_s" in row else float("nan"))
    return rows


def csv_rows(workdir: Path, rows: int) -> list[dict]:
    """Seconds to write ``rows`` × 2 columns (time, a signal) as CSV: the writers of
    ``csv_writers.py`` (ours: the C and the numba kernels, compiled as chosen, in Python,
    ``Waveforms.to_csv``'s choice; numpy.savetxt with 10 and 17 digits, pandas), medians of 3."""
    from csv_writers import in_process  # this script's sibling (run as a script)

    return [{"case": f"CSV {label}, {rows // 1000}k rows", "steps": rows, "pairs": 0,
             "ours_process_s": seconds, "ours_note": f"{rate:.0f} MB/s"}
            for label, seconds, rate in in_process(rows, 3, workdir)]


def print_issue19(rows: list[dict]) -> None:
    def f(value, spec):
        return format(value, spec) if isinstance(value, (int, float)) and value == value else "-"

    print(f"{'case':<36}{'steps':>9}{'pairs':>6}{'ours[s]':>9}{'cpu[s]':>8}{'numba[s]':>9}{'cpu[s]':>8}"
          f"{'us/step':>9}{'mapped':>8}"
          f"{'ngspice[s]':>11}{'ng/ours':>8}  note")
    for r in rows:
        note = r.get("ours_note", "")
        if "ngspice_ok" in r and not r["ngspice_ok"]:
            note = (note + " ngspice: " + (r.get("ngspice_note") or "failed")[:40]).strip()
        share = r.get("mapped_share")
        print(f"{r['case']:<36}{r['steps']:>9}{r['pairs']:>6}{f(r.get('ours_process_s'), '9.2f'):>9}"
              f"{f(r.get('ours_cpu_s'), '8.2f'):>8}{f(r.get('numba_process_s'), '9.2f'):>9}"
              f"{f(r.get('numba_cpu_s'), '8.2f'):>8}{f(r.get('us_per_step'), '9.2f'):>9}"
              f"{(f(100 * share, '7.1f') + '%') if share is not None else '-':>8}"
              f"{f(r.get('ngspice_process_s'), '11.2f'):>11}{f(r.get('ratio'), '8.2f'):>8}  {note}")
    print("ours[s], ngspice[s]: whole processes (median of the repeats); cpu[s]: their user + system "
          "CPU time (median); numba[s]: ours with CIRCUITNSDS_NATIVE=0 (the mode-table loop compiled by "
          "numba, not the C loop built at install); us/step: in-process stepping "
          "time per step; mapped: share of steps taken by the compiled mode loop.")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short runs (smoke test)")
    parser.add_argument("--json", type=Path, default=HERE / "results" / "performance.json")
    parser.add_argument("--part", choices=["all", "issue19", "issue8"], default="all")
    parser.add_argument("--repeats", type=int, default=3, help="runs per case of the issue 19 table")
    parser.add_argument("--case", help="issue 19 table: only the cases whose label contains this")
    args = parser.parse_args(argv)
    scale = 0.05 if args.quick else 1.0
    rows = []
    if args.part in ("all", "issue19"):
        with tempfile.TemporaryDirectory() as tmp:
            table = issue19(Path(tmp), args.repeats, scale, args.case)
        print_issue19(table)
        print()
        rows.extend(table)
        if args.part == "issue19":
            return _save(args, rows)
    earlier: list[dict] = []  # the issue 8 table
    # numba's first calls (loading the compiled loops, ~0.3 s each) are start-up, not stepping:
    # warm the dense mode table (the buck) and the sparse loop (a 40-section ladder)
    ours_in_process(with_tran((NETLISTS / "buck_100ms.cir").read_text(), ".tran 0.1u 20u"))
    ours_in_process(ladder_netlist(40, 1e-3))
    with tempfile.TemporaryDirectory() as tmp:
        workdir = Path(tmp)
        for theta in (1.0, 0.5):
            earlier.append(case(f"1 buck θ={theta:g}", NETLISTS / "buck_100ms.cir", 0.1e-6, 100e-3 * scale,
                             5e-3 * scale, workdir, own_reference=True, theta=theta))
        # the step at which θ = 0.5 matches ngspice's error against its own reference (h² scaling)
        earlier.append(case("1 buck θ=0.5 h=0.08u", NETLISTS / "buck_100ms.cir", 0.1e-6, 100e-3 * scale,
                         5e-3 * scale, workdir, own_reference=True, theta=0.5, our_step=0.08e-6))
        earlier.append(start_up(NETLISTS / "buck_100ms.cir", workdir))
        earlier.append(case("2 bridge 470 uF", NETLISTS / "bridge_200ms.cir", 20e-6, 200e-3 * scale,
                         200e-3 * scale, workdir))
        earlier.append(case("3 CW x5", NETLISTS / "cw5_1s.cir", 20e-6, 1.0 * scale, 0.2 * scale, workdir))
        zener = (HERE.parent / "netlists" / "book_zener_rlc.cir").read_text()
        for step in (5e-3, 5e-5):
            inproc = ours_in_process(zener, step=step, stop=5.0)
            earlier.append({"case": f"5 Zener RLC h={step:g}", "steps": inproc["steps"],
                         "pairs": inproc["pairs"], "unknowns": inproc["unknowns"],
                         "ours_stepping_s": inproc["stepping_s"], "us_per_step": inproc["us_per_step"],
                         "us_per_mapped_step": inproc["us_per_mapped_step"],
                         "mapped_share": inproc["mapped_share"]})
        for sections in (10, 100, 1000):
            inproc = ours_in_process(ladder_netlist(sections, 5e-3 * max(scale, 0.1)))
            earlier.append({"case": f"4 ladder N={sections}", "steps": inproc["steps"],
                         "pairs": inproc["pairs"], "unknowns": inproc["unknowns"],
                         "ours_stepping_s": inproc["stepping_s"], "us_per_step": inproc["us_per_step"],
                         "us_per_mapped_step": inproc["us_per_mapped_step"],
                         "mapped_share": inproc["mapped_share"]})
    print_table(earlier)
    rows.extend(earlier)
    return _save(args, rows)


def _save(args: argparse.Namespace, rows: list[dict]) -> int:
    args.json.parent.mkdir(parents=True, exist_ok=True)
    meta = {"python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count(),
            "quick": args.quick, "ngspice": ngspice_version(), "load": os.getloadavg()}
    args.json.write_text(json.dumps({"meta": meta, "rows": rows}, indent=2, default=float))
    print(f"\nJSON: {args.json}")
    return 0


def ngspice_version() -> str:
    if shutil.which("ngspice") is None:
        return "not installed"
    done = subprocess.run(["ngspice", "-v"], capture_output=True, text=True, check=False)
    found = re.search(r"ngspice-(\S+)", done.stdout)
    return found.group(1) if found else done.stdout.strip()[:40]


def print_table(rows: list[dict]) -> None:
    def f(value, spec):
        return format(value, spec) if isinstance(value, (int, float)) and value == value else "-"

    print(f"{'case':<22}{'steps':>9}{'pairs':>6}{'us/step':>9}{'us/map':>8}{'mapped':>8}{'step[s]':>8}"
          f"{'ours[s]':>9}"
          f"{'ngspice[s]':>11}{'ratio':>7}  {'err ours':>9}{'err ng':>9}  ngspice")
    for r in rows:
        note = ("ok" if r.get("ngspice_ok") else (r.get("ngspice_note") or "")[:40]) \
            if "ngspice_ok" in r else ""
        if r.get("ngspice_stopped_at") and not r.get("ngspice_ok"):
            note += f" (stopped at {r['ngspice_stopped_at']:.4g} s)"
        print(f"{r['case']:<22}{r['steps']:>9}{r['pairs']:>6}{f(r.get('us_per_step'), '9.2f'):>9}"
              f"{f(r.get('us_per_mapped_step'), '8.2f'):>8}"
              f"{f(100 * r.get('mapped_share', float('nan')), '7.1f'):>7}%"
              f"{f(r.get('ours_stepping_s'), '8.3f'):>8}{f(r.get('ours_process_s'), '9.2f'):>9}"
              f"{f(r.get('ngspice_process_s'), '11.2f'):>11}{f(r.get('ratio'), '7.1f'):>7}  "
              f"{f(r.get('ours_error'), '9.1e'):>9}{f(r.get('ngspice_error_vs_ideal'), '9.1e'):>9}  {note}")
    for r in rows:
        if "ngspice_error_vs_own_fine" in r:
            print(f"\ncase {r['case']}: against each one's own fine-step reference (TSTEP/10): "
                  f"circuitnsds {r['ours_error_vs_own_fine']:.2e}, "
                  f"ngspice {r['ngspice_error_vs_own_fine']:.2e}")
    print("ours[s], ngspice[s]: whole processes from the command line, writing v(out) to a file. "
          "step[s]: in-process stepping time (the integrator alone); us/step: that / steps; "
          "us/map: the same for the steps taken by the mode loop (mode unchanged), mapped: their "
          "share. err: max |v(out) - ideal reference| / range over the case's window.")


if __name__ == "__main__":
    sys.exit(main())
