"""Inputs that crashed, hung or filled the memory (issue 37): each a clear error at its
place, or the right result; memory checks that know every limit of the process."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

import circuitnsds
from circuitnsds.analyses import memory
from circuitnsds.cli.main import main
from circuitnsds.errors import CircuitError
from circuitnsds.system.mlcs import MLCS
from circuitnsds.system.stimuli import Pulse
from tests.conftest import NETLISTS

ROOT = Path(__file__).resolve().parent.parent
BUCK = (NETLISTS / "buck_converter.cir").read_text()
W_BUCK = (NETLISTS / "external" / "buck_csw_ron_only.cir").read_text()


def _run(tmp_path, capsys, text: str, *args: str) -> tuple[int, str]:
    netlist = tmp_path / "case.cir"
    netlist.write_text(text)
    status = main(["run", str(netlist), "-o", str(tmp_path / "out.csv"), "-q", *args])
    err = capsys.readouterr().err
    assert "internal error" not in err and "Traceback" not in err, err
    return status, err


@pytest.mark.parametrize("seed", ["-1", "1e999", "2.5"])
def test_a_bad_options_seed_is_an_error_at_its_line(tmp_path, capsys, seed):
    status, err = _run(tmp_path, capsys, BUCK.replace(".tran", f".options seed={seed}\n.tran"))
    assert status == 1 and f"case.cir:15: .options seed={seed} must be a non-negative integer" in err


def test_a_tstep_beyond_the_doubles_integrates_like_any_tstep_longer_than_the_run():
    # TSTEP/TSTOP overflowed the refinement factor (inf); any TSTEP above TSTOP reports the
    # two ends, integrated with the step the PULSE needs (its period / 20 = 0.5 µs)
    huge = circuitnsds.read_netlist(BUCK.replace(".tran 0.1u 2m", ".tran 1e308 10m"))
    plain = circuitnsds.read_netlist(BUCK.replace(".tran 0.1u 2m", ".tran 1 10m"))
    with pytest.warns(Warning, match=r"integrated with a step of 5e-07 s, reported every TSTEP"):
        a = huge.transient()
    with pytest.warns(Warning, match=r"integrated with a step of 5e-07 s \(TSTEP/2000000\)"):
        b = plain.transient()
    assert a.time[-1] == b.time[-1] == 10e-3
    # the same integration, up to the rounding of the step (5e-7 s, or 1 s / 2e6)
    assert a["v(out)"][-1] == pytest.approx(b["v(out)"][-1], rel=1e-12)
    assert a["i(l1)"][-1] == pytest.approx(b["i(l1)"][-1], rel=1e-9)
    assert 11 < a["v(out)"][-1] < 12.5  # the buck near D·24 V


def test_a_huge_initial_condition_is_an_overflow_error_not_a_solver_crash(tmp_path, capsys):
    status, err = _run(tmp_path, capsys, W_BUCK.replace(".tran", ".ic v(out)=1e300\n.tran"))
    assert status == 1 and "the state overflows" in err


def test_the_step_count_is_refused_before_any_breakpoint_is_listed(monkeypatch, tmp_path, capsys):
    # two 10 µs PULSEs over 100 s listed 4e7 corners (2.6 GB) before the 5e7-step refusal
    def listed(self, stop):
        raise AssertionError("the breakpoints were listed")

    monkeypatch.setattr(MLCS, "breakpoints", listed)
    status, err = _run(tmp_path, capsys, "two pulses\nV1 a 0 PULSE(0 1 0 1n 1n 5u 10u)\n"
                       "V2 b 0 PULSE(0 1 0 1n 1n 5u 10u)\nR1 a b 1k\nR2 b 0 1k\n.tran 20n 100\n.end\n")
    assert status == 1 and "5e+09 steps requested (limit 5e+07)" in err


def test_too_many_breakpoints_are_refused_before_they_are_listed(monkeypatch):
    # an explicit step of 10 s over 100 s: few steps, but 1e7 gate periods: 4e7 corners and
    # as many crossings of the switch's threshold
    circuit = circuitnsds.read_netlist(BUCK)

    def listed(self, stop):
        raise AssertionError("the corners were listed")

    monkeypatch.setattr(Pulse, "breakpoints", listed)
    with pytest.raises(CircuitError, match=r"up to 8e\+07 breakpoints .*\(limit 5e\+07\), most of "
                       r"them vgate's"):
        circuit.transient(10.0, 100.0)


def test_a_thousand_nested_subcircuit_levels_are_the_depth_error(tmp_path, capsys):
    lines = ["deep"]
    for level in range(1000):
        inner = f"X1 a b s{level + 1}" if level < 999 else "R1 a b 1"
        lines += [f".subckt s{level} a b", inner, f".ends s{level}"]
    lines += ["X1 1 0 s0", "V1 1 0 1", ".tran 1u 10u", ".end"]
    status, err = _run(tmp_path, capsys, "\n".join(lines) + "\n")
    assert status == 1 and "case.cir:300: x1: subcircuits nested deeper than 100 levels" in err


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are a Unix thing")
def test_an_included_fifo_is_refused_at_once(tmp_path, capsys):
    fifo = tmp_path / "models.lib"
    os.mkfifo(fifo)

    def unblock():  # a reader that waits for a writer is let go after 10 s (and the test fails)
        if not finished.wait(10):
            with open(fifo, "w") as handle:
                handle.write("R9 a 0 1\n")

    finished = threading.Event()
    threading.Thread(target=unblock, daemon=True).start()
    try:
        status, err = _run(tmp_path, capsys, f"fifo\n.include {fifo}\nR1 a 0 1\nV1 a 0 1\n"
                           ".tran 1u 10u\n.end\n")
    finally:
        finished.set()
    assert status == 1 and "case.cir:2: the included file" in err and "is a FIFO (named pipe)" in err


def test_a_memory_error_is_a_clear_error(tmp_path, capsys, monkeypatch):
    from circuitnsds.cli import main as cli

    def exhausted(args):
        raise MemoryError("Unable to allocate 137. MiB for an array with shape (18000001,)")

    monkeypatch.setattr(cli, "_run", exhausted)
    status, err = _run(tmp_path, capsys, BUCK)
    assert status == 1 and "error: out of memory (Unable to allocate 137. MiB" in err


def test_the_memory_check_honours_ulimit_v():
    # a 2 GiB address-space limit: a run whose results need ~2.5 GiB is refused before it
    # starts, whatever the machine has (MemAvailable alone let it run into a MemoryError)
    code = """
import resource, sys
from circuitnsds.analyses import memory
from circuitnsds.errors import CircuitError
import circuitnsds
limit = 2 * 2**30
resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
left = memory.address_space_left()
assert 0 < left < limit and memory.available_memory() <= left, (left, memory.available_memory())
circuit = circuitnsds.read_netlist(sys.argv[1])
try:
    circuit.transient(1e-9, 40e-3)
except CircuitError as exc:
    print(exc)
"""
    text = BUCK.replace(".tran 0.1u 2m", ".tran 1n 40m")
    output = subprocess.run([sys.executable, "-c", code, text], capture_output=True, text=True, timeout=120,
                            env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert output.returncode == 0, output.stderr[-2000:]
    assert "the results would take" in output.stdout and "ulimit -v" in output.stdout, output.stdout


def _group(folder: Path, **files: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name.replace("_", ".", 1)).write_text(text + "\n")


def test_cgroup_v2_limits_of_the_group_and_its_parents(tmp_path):
    _group(tmp_path / "user.slice", memory_max="1000000", memory_current="400000")
    _group(tmp_path / "user.slice" / "job", memory_max="max", memory_current="100000")
    assert memory.cgroup_left(tmp_path, "0::/user.slice/job\n") == 600_000  # the parent's limit
    _group(tmp_path / "user.slice" / "job", memory_max="300000", memory_current="100000")
    assert memory.cgroup_left(tmp_path, "0::/user.slice/job\n") == 200_000  # its own, smaller
    assert memory.cgroup_left(tmp_path, "0::/elsewhere\n") is None  # no limit readable


def test_cgroup_v1_memory_controller(tmp_path):
    root = tmp_path / "memory"
    _group(root / "docker" / "abc", memory_limit_in_bytes="536870912", memory_usage_in_bytes="36870912")
    _group(root / "docker", memory_limit_in_bytes=str(9223372036854771712), memory_usage_in_bytes="1")
    membership = "12:cpu,cpuacct:/docker/abc\n11:memory:/docker/abc\n"
    assert memory.cgroup_left(tmp_path, membership) == 500_000_000
    assert memory.cgroup_left(tmp_path, "11:memory:/docker\n") is None  # "unlimited"


def test_the_smallest_limit_is_the_memory_available(monkeypatch):
    monkeypatch.setattr(memory, "system_available", lambda: 8 * 2**30)
    monkeypatch.setattr(memory, "address_space_left", lambda: None)
    monkeypatch.setattr(memory, "cgroup_left", lambda: 2**30)
    assert memory.available_memory() == 2**30
    monkeypatch.setattr(memory, "cgroup_left", lambda: None)
    assert memory.available_memory() == 8 * 2**30


def test_info_skips_the_dense_analysis_above_its_size_and_lists_names_boundedly(monkeypatch, capsys):
    # a 10,000-section RC ladder took 209 s and 3.2 GB in the dense well-posedness analysis
    from circuitnsds.checks import wellposed
    from circuitnsds.cli import info

    def dense(circuit):
        raise AssertionError("the dense analysis ran")

    monkeypatch.setattr(wellposed, "report_lines", dense)
    monkeypatch.setattr(info, "DENSE_UNKNOWNS", 50)
    sections = 60
    text = "ladder\nV1 n0 0 PULSE(0 1 0 1n 1n 5u 10u)\n" + "".join(
        f"R{k} n{k} n{k + 1} 1k\nC{k} n{k + 1} 0 1n\n" for k in range(sections)) + ".tran 1u 100u\n.end\n"
    report, ok = info.circuit_report(circuitnsds.read_netlist(text))
    assert ok and "well-posedness of each step's LCP: not analysed: 62 unknowns and pairs, above 50" in report
    monkeypatch.setattr(info, "NAMES_SHOWN", 10)
    report, ok = info.circuit_report(circuitnsds.read_netlist(text))
    nodes = next(line for line in report.splitlines() if line.startswith("nodes:"))
    assert nodes == "nodes:     61 + ground 0: " + ", ".join(f"n{k}" for k in range(10)) + ", ... (61 in all)"



def test_a_face_singular_only_by_scaling_costs_no_linear_program_per_step(monkeypatch):
    # a buck without load and with a 1 kH inductor: each blocked step's face has rcond 5e-21
    # unscaled (1e9 Ω off-switch, 1 kH at 0.1 µs) and went through enumeration and three LPs
    # (44 s for 200 µs); scaled to unit rows and columns it is well conditioned
    from circuitnsds.solvers import enumeration

    calls = []
    face_lp = enumeration._face_lp
    monkeypatch.setattr(enumeration, "_face_lp", lambda *args, **kw: calls.append(1) or face_lp(*args, **kw))
    monkeypatch.setattr(enumeration, "_VERDICTS", {})
    text = BUCK.replace("L1 sw out 100u", "L1 sw out 1k").replace("Rload out 0 5\n", "")
    # (the θ-method's step solver and its face LPs: pinned to θ)
    waves = circuitnsds.read_netlist(text.replace(".tran 0.1u 2m", ".tran 0.1u 20u")).transient(
        method="theta")
    # two LPs per distinct face (are its free unknowns determined?), not three per step
    assert 0 < len(calls) <= 8
    calls.clear()
    circuitnsds.read_netlist(text.replace(".tran 0.1u 2m", ".tran 0.1u 60u")).transient(method="theta")
    assert not calls  # the same faces, known
    on = np.asarray(waves["v(gate)"]) > 2.6  # (at 2.5 V exactly the switch is still open)
    # the switch closed: sw at the input; the inductor's current (nA) never reaches the diode's
    assert np.allclose(np.asarray(waves["v(sw)"])[on], 24.0, atol=1e-6)
    assert np.abs(np.asarray(waves["i(l1)"])).max() < 1e-9


def test_the_enumeration_stops_at_its_budget_instead_of_costing_seconds(monkeypatch):
    from circuitnsds.solvers import enumeration
    from circuitnsds.solvers.result import LCPSolverFailure

    # M = 0 with q < 0: no solution, and every active set but the empty one singular
    monkeypatch.setattr(enumeration, "MAX_FACE_LPS", 3)
    with pytest.raises(LCPSolverFailure, match=r"stopped at its budget \(3 singular faces searched by LP"):
        enumeration.enumerate_mlcp(np.zeros((5, 5)), 0, -np.ones(5))
    assert enumeration.enumerate_mlcp(np.zeros((5, 5)), 0, -np.ones(5), force=True) is None
    # factorisation work: 2**8 sets of a 300-unknown system
    rng = np.random.default_rng(1)
    K = np.eye(308) + 0.01 * rng.standard_normal((308, 308))
    monkeypatch.setattr(enumeration, "MAX_ENUM_FLOPS", 1e9)
    with pytest.raises(LCPSolverFailure, match=r"1e\+09 flops of factorisations") as caught:
        enumeration.enumerate_mlcp(K, 300, np.r_[np.zeros(300), -np.ones(8)])
    assert caught.value.reason == "budget"
