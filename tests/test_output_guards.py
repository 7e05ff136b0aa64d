"""No result is lost to an output that cannot be written, a signal or a full disk (issue 37).

Every output is checked before the run (folder, writability, identity with every input,
standard input's file included); SIGTERM and SIGHUP stop a run as Ctrl-C does, leaving
the partial result marked and no temporary file; the outputs of one command are replaced
together or not at all.
"""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from circuitnsds.cli.main import main
from tests.conftest import NETLISTS, pinned_copy

ROOT = Path(__file__).resolve().parents[1]
RC = "rc\nV1 in 0 1\nR1 in out 1k\nC1 out 0 1u\n.tran 10u 1m\n.end\n"


def _refused(capsys, argv: list[str], *fragments: str) -> str:
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err and "steps in" not in err  # nothing ran
    for fragment in fragments:
        assert fragment in err, err
    return err


@pytest.fixture
def netlist(tmp_path) -> Path:
    path = tmp_path / "rc.cir"
    path.write_text(RC)
    return path


# --- checked before the run -----------------------------------------------------------------------


@pytest.mark.parametrize("option", ["-o", "-r", "--plot", "--events"])
def test_an_output_in_a_missing_folder_is_refused_before_the_run(option, netlist, tmp_path, capsys):
    missing = tmp_path / "missing" / "deeper"
    name = {"-o": "out.csv", "-r": "out.raw", "--plot": "out.png", "--events": "ev.csv"}[option]
    _refused(capsys, ["run", str(netlist), option, str(missing / name)],
             f"{option}: cannot write {missing / name}: the folder {missing} does not exist", "mkdir -p")
    assert not (tmp_path / "missing").exists()


@pytest.mark.parametrize("argv", [
    ["ac", "{netlist}", "--fstart", "10", "--fstop", "1k", "-o", "{out}"],
    ["pss", "{netlist}", "--period", "1m", "-o", "{out}"],
    ["sweep", "{netlist}", "--param", "R=1,2", "-o", "{out}"],
    ["compare", "{netlist}", "--json", "{out}"],
    ["info", "{netlist}", "--matrices", "{out}"],
])
def test_every_command_checks_its_outputs_folder(argv, netlist, tmp_path, capsys):
    out = tmp_path / "nowhere" / "out.csv"
    argv = [word.format(netlist=netlist, out=out) for word in argv]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert f"the folder {out.parent} does not exist" in err and "Traceback" not in err


def test_an_output_under_a_file_or_naming_a_folder_is_refused(netlist, tmp_path, capsys):
    _refused(capsys, ["run", str(netlist), "-o", str(netlist / "out.csv")], "is a file, not a folder")
    _refused(capsys, ["run", str(netlist), "-o", str(tmp_path)], f"cannot write {tmp_path}: Is a directory")


def test_an_unwritable_folder_is_refused(netlist, tmp_path, capsys, monkeypatch):
    locked = tmp_path / "locked"
    locked.mkdir()
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda path, mode, **kw: False if Path(path) == locked
                        else real_access(path, mode, **kw))  # root may write anywhere: pretend
    _refused(capsys, ["run", str(netlist), "-o", str(locked / "out.csv")],
             f"the folder {locked} is not writable")


def test_standard_inputs_file_is_not_overwritten(netlist):
    with open(netlist) as stdin:
        result = subprocess.run([sys.executable, "-m", "circuitnsds", "run", "-", "-o", str(netlist)],
                                stdin=stdin, capture_output=True, text=True, cwd=netlist.parent,
                                env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)
    assert result.returncode == 1
    assert "is the file standard input reads the netlist from" in result.stderr
    assert netlist.read_text() == RC


def test_sweep_waveforms_folder_holding_the_netlist_or_the_table_is_refused(netlist, tmp_path, capsys,
                                                                           monkeypatch):
    monkeypatch.chdir(tmp_path)
    text = RC.replace("R1 in out 1k", "R1 in out {R}").replace("rc\n", "rc\n.param R=1k\n")
    netlist.write_text(text)
    _refused(capsys, ["sweep", "rc.cir", "--param", "R=1k,2k", "--waveforms", "."],
             "--waveforms . holds the netlist input")
    (tmp_path / "waves").mkdir()
    _refused(capsys, ["sweep", "rc.cir", "--param", "R=1k,2k", "--waveforms", "waves", "-o",
                      "waves/point_0000.csv"], "holds the -o output")
    assert netlist.read_text() == text and sorted(p.name for p in (tmp_path / "waves").iterdir()) == []


# --- written together or not at all ---------------------------------------------------------------


def test_a_full_disk_keeps_the_previous_set(netlist, tmp_path, capsys, monkeypatch):
    from circuitnsds.output import plot

    outputs = {"-o": tmp_path / "out.csv", "-r": tmp_path / "out.raw", "--plot": tmp_path / "out.png"}
    for path in outputs.values():
        path.write_text("previous\n")

    def no_space(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(plot, "plot_waveforms", no_space)
    argv = ["run", str(netlist)] + [word for option, path in outputs.items() for word in (option, str(path))]
    assert main(argv) == 1
    assert "No space left on device" in capsys.readouterr().err
    assert all(path.read_text() == "previous\n" for path in outputs.values())  # none replaced
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv", "out.png", "out.raw", "rc.cir"]


def test_ac_table_and_figure_are_replaced_together(netlist, tmp_path, capsys, monkeypatch):
    from circuitnsds.output import bode

    csv, png = tmp_path / "bode.csv", tmp_path / "bode.png"
    csv.write_text("previous\n")
    netlist.write_text(RC.replace("V1 in 0 1", "V1 in 0 DC 1 AC 1"))

    def no_space(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(bode, "plot_bode", no_space)
    argv = ["ac", str(netlist), "--fstart", "10", "--fstop", "1k", "-o", str(csv), "--plot", str(png)]
    assert main(argv) == 1
    assert "No space left on device" in capsys.readouterr().err
    assert csv.read_text() == "previous\n" and not png.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bode.csv", "rc.cir"]


@pytest.mark.parametrize("signals", [None, "v(out)"])  # written after the run, and streamed
def test_a_whole_run_has_no_partial_marker(signals, netlist, tmp_path):
    csv = tmp_path / "out.csv"
    chosen = ["--signals", signals] if signals else []
    assert main(["run", str(netlist), "-o", str(csv), "-q", *chosen]) == 0
    assert csv.read_text().startswith("time,")


# --- SIGTERM, SIGHUP and SIGINT in the middle of a run --------------------------------------------


@pytest.mark.skipif(os.name != "posix", reason="POSIX signals")
@pytest.mark.parametrize(("signum", "status", "words"), [
    (signal.SIGTERM, 143, "interrupted by SIGTERM"),
    (signal.SIGHUP, 129, "interrupted by SIGHUP"),
    (signal.SIGINT, 130, "interrupted"),
])
def test_a_signal_mid_run_writes_a_marked_partial_result_and_no_temporary(signum, status, words, tmp_path):
    csv, raw = tmp_path / "out.csv", tmp_path / "out.raw"
    csv.write_text("previous\n")
    argv = [sys.executable, "-m", "circuitnsds", "run", str(NETLISTS / "buck_converter.cir"), "-o", str(csv),
            "-r", str(raw), "--stop", "1", "--signals", "v(out),i(l1)", "-q"]
    # (the signal's default action restored in the child: a suite run as a background job or
    # under nohup hands its children SIGINT or SIGHUP ignored, which Python then keeps ignored)
    process = subprocess.Popen(argv, cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(ROOT)},
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signum, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and process.poll() is None:
            if any(p.stat().st_size > 10_000 for p in tmp_path.glob(".out.csv.*")):
                break  # rows are being written: the stepping is under way (10 million steps)
            time.sleep(0.02)
        assert process.poll() is None, process.communicate()
        process.send_signal(signum)
        _, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == status, err
    assert err.rstrip().endswith(f"circuitnsds: {words}") and "Traceback" not in err
    assert "wrote the results up to t = " in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv", "out.raw"]  # no temporary
    lines = csv.read_text().splitlines()
    assert lines[0].startswith("# partial: the run stopped at t = ") and f"(when {words})" in lines[0]
    data = np.loadtxt(csv, delimiter=",", skiprows=2)
    assert data.shape[0] > 100 and data[-1, 0] < 1
    assert f"when {words}" in raw.read_bytes()[:600].decode("latin-1")  # the raw file's title


def test_sigterm_outside_the_stepping_stops_cleanly_too(netlist, capsys, monkeypatch):
    from circuitnsds.cli.interrupts import Terminated
    from circuitnsds.frontend import build

    def terminated(*args, **kwargs):
        raise Terminated(signal.SIGTERM)

    monkeypatch.setattr(build.CircuitBuilder, "load", terminated)  # while the netlist is read
    assert main(["run", str(netlist), "-o", str(netlist.with_suffix(".csv"))]) == 143
    assert capsys.readouterr().err.strip() == "circuitnsds: interrupted by SIGTERM"
    assert sorted(p.name for p in netlist.parent.iterdir()) == ["rc.cir"]


def test_a_partial_csv_written_after_the_run_is_marked(tmp_path, capsys, monkeypatch):
    from circuitnsds.cli.interrupts import Terminated
    from circuitnsds.engine import integrate as engine

    original = engine.GridStepping.solve_step

    def terminate_later(self, k, *args, **kwargs):
        if k == 120:
            raise Terminated(signal.SIGHUP)
        return original(self, k, *args, **kwargs)

    monkeypatch.setattr(engine.GridStepping, "solve_step", terminate_later)
    monkeypatch.setattr(engine.GridStepping, "dense_mode", lambda *args: None)  # one MLCP per step
    csv, events = tmp_path / "out.csv", tmp_path / "ev.csv"
    netlist = pinned_copy(NETLISTS / "half_wave_rectifier.cir", tmp_path)  # (θ's step stops it)
    status = main(["run", str(netlist), "-o", str(csv), "--events", str(events),
                   "--step", "100u", "--stop", "20m", "--every", "2"])  # --every: not streamed
    assert status == 129
    note = "# partial: the run stopped at t = 0.012 s (when interrupted by SIGHUP); the rows end there"
    assert csv.read_text().splitlines()[:2] == [note, "time,v(in),v(out),i(v1),i(d1),i(r1)"]
    assert events.read_text().splitlines()[:2] == [note, "time,element,state"]
    data = np.loadtxt(csv, delimiter=",", skiprows=2)
    assert data[-1, 0] == pytest.approx(0.012)


def test_the_writers_table_matches_the_command_line():
    from circuitnsds.cli.main import build_parser
    from circuitnsds.output.writers import WRITERS

    for command in ("run", "pss"):
        for writer in WRITERS:
            args = build_parser().parse_args([command, "x.cir", writer.option, "out.file"])
            assert getattr(args, writer.attribute) == Path("out.file"), (command, writer.option)
