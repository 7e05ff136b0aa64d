"""``run -o out.csv --signals ...`` writes each segment's rows to the file as the run goes
(memory bounded by one segment), atomically: the same bytes as a run kept whole, the
rows done so far on Ctrl-C, the previous file on a failure (issue 19, outputs)."""

from __future__ import annotations

import os

import numpy as np
import pytest

import circuitnsds
import circuitnsds.analyses.recorders as recorders
from circuitnsds.cli.main import main
from circuitnsds.output import csvfile
from circuitnsds.output.csvfile import CsvStream
from circuitnsds.output.rawfile import read_raw
from tests.conftest import NETLISTS, pinned, pinned_copy

BUCK = NETLISTS / "buck_converter.cir"


@pytest.mark.parametrize("compiled", [True, False])  # True: formatted in a background thread
def test_streamed_csv_is_the_file_of_a_run_kept_whole(tmp_path, monkeypatch, compiled):
    monkeypatch.setattr(recorders, "segment_steps", lambda mlcs: 700)
    monkeypatch.setattr(csvfile, "compiled_pays", lambda values: compiled)
    streamed, whole = tmp_path / "streamed.csv", tmp_path / "whole.csv"
    assert main(["run", str(BUCK), "-o", str(streamed), "--signals", "v(out),i(l1)", "--stop", "0.3m",
                 "--theta", "0.5", "-q"]) == 0
    circuit = circuitnsds.read_netlist(BUCK)
    kept = circuit.transient(stop=0.3e-3, theta=0.5, signals=["v(out)", "i(l1)"])
    kept.to_csv(whole)
    assert streamed.read_bytes() == whole.read_bytes()
    assert kept.time.size > 2 * 700  # several segments
    # the analysis hands the rows over and keeps none of them
    stream = CsvStream(tmp_path / "python.csv", ["v(out)", "i(l1)"])
    result = circuit.transient(stop=0.3e-3, theta=0.5, signals=["v(out)", "i(l1)"], sink=stream)
    stream.commit()
    assert result.time.size == 0 and result.stats["rows"] == kept.time.size == stream.rows
    assert (tmp_path / "python.csv").read_bytes() == whole.read_bytes()


def test_streamed_csv_with_tstart_and_a_figure(tmp_path, monkeypatch):
    """Rows before TSTART are not written; the figure gets the kept rows."""
    monkeypatch.setattr(recorders, "segment_steps", lambda mlcs: 700)
    netlist = tmp_path / "buck.cir"
    netlist.write_text(BUCK.read_text().replace(".tran 0.1u 2m", ".tran 0.1u 0.3m 0.1m"))
    csv, raw = tmp_path / "out.csv", tmp_path / "out.raw"
    assert main(["run", str(netlist), "-o", str(csv), "-r", str(raw), "--signals", "v(out)", "-q"]) == 0
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    back = read_raw(raw)
    whole = circuitnsds.read_netlist(netlist).transient()
    np.testing.assert_array_equal(data[:, 0], whole.time)
    assert data[0, 0] == pytest.approx(0.1e-3)
    np.testing.assert_allclose(data[:, 1], whole["v(out)"], atol=1e-9 * np.abs(whole["v(out)"]).max())
    np.testing.assert_array_equal(back["v(out)"], data[:, 1])
    np.testing.assert_array_equal(back.time, data[:, 0])


def test_ctrl_c_in_a_later_segment_keeps_the_rows_done(tmp_path, capsys, monkeypatch):
    from circuitnsds.engine import integrate as engine

    monkeypatch.setattr(recorders, "segment_steps", lambda mlcs: 700)
    monkeypatch.setattr(csvfile, "compiled_pays", lambda values: True)
    calls = {"n": 0}
    original = engine.GridStepping.solve_step

    def interrupt_later(self, k, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 1000:
            raise KeyboardInterrupt
        return original(self, k, *args, **kwargs)

    monkeypatch.setattr(engine.GridStepping, "solve_step", interrupt_later)
    monkeypatch.setattr(engine.GridStepping, "dense_mode", lambda *args: None)  # one MLCP per step
    csv = tmp_path / "out.csv"
    csv.write_text("previous\n")
    (tmp_path / "in").mkdir()  # (θ's step stops it: the netlist pinned to θ, beside)
    netlist = pinned_copy(NETLISTS / "half_wave_rectifier.cir", tmp_path / "in")
    status = main(["run", str(netlist), "-o", str(csv), "--step", "10u",
                   "--stop", "20m", "--signals", "v(out)"])
    err = capsys.readouterr().err
    assert status == 130 and "(when interrupted) to" in err
    assert csv.read_text().startswith("# partial: the run stopped at t = ")  # above the header
    data = np.loadtxt(csv, delimiter=",", skiprows=2)
    assert 700 < data.shape[0] < 2001  # past the first segment, not the whole run
    assert f"up to t = {data[-1, 0]:.6g} s" in err
    np.testing.assert_allclose(data[:, 1], np.maximum(10 * np.sin(2 * np.pi * 50 * data[:, 0]), 0),
                               atol=1e-6)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in", "out.csv"]


def test_a_run_that_fails_before_any_row_leaves_the_previous_file(tmp_path, capsys):
    csv = tmp_path / "out.csv"
    csv.write_text("previous\n")
    assert main(["run", str(BUCK), "-o", str(csv), "--signals", "v(nowhere)", "--stop", "10u"]) == 1
    assert "unknown signal(s) v(nowhere)" in capsys.readouterr().err
    assert csv.read_text() == "previous\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]


@pytest.mark.parametrize("compiled", [True, False])
def test_a_write_error_is_a_clean_error_and_keeps_the_previous_file(tmp_path, capsys, monkeypatch,
                                                                    compiled):
    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(csvfile, "compiled_pays", lambda values: compiled)
    monkeypatch.setattr(csvfile, "write_rows", full)
    csv = tmp_path / "out.csv"
    csv.write_text("previous\n")
    assert main(["run", str(BUCK), "-o", str(csv), "--signals", "v(out)", "--stop", "20u"]) == 1
    err = capsys.readouterr().err
    assert "cannot write" in err and "No space left on device" in err and "Traceback" not in err
    assert csv.read_text() == "previous\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]
    assert not any(name.startswith(".out.csv") for name in os.listdir(tmp_path))


def test_a_stream_that_cannot_start_leaves_nothing(tmp_path, monkeypatch):
    def refused(stream, names):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(csvfile, "write_header", refused)
    path = tmp_path / "out.csv"
    path.write_text("previous\n")
    with pytest.raises(circuitnsds.CircuitnsdsError, match="No space left"):
        CsvStream(path, ["v(out)"])
    assert path.read_text() == "previous\n" and sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]


def test_streamed_run_writes_the_switchings_from_tstart_on(tmp_path, monkeypatch):
    """``--events`` of a streamed run with a TSTART holds the switchings from TSTART on, as
    the run that keeps every signal: the buck's gate switches s1 twice per 10 us period, 20
    times in 0.1..0.2 ms (before, a streamed run also wrote the 20 switchings before TSTART)."""
    monkeypatch.setattr(recorders, "segment_steps", lambda mlcs: 700)
    netlist = tmp_path / "buck.cir"
    netlist.write_text(BUCK.read_text().replace(".tran 0.1u 2m", ".tran 0.1u 0.2m 0.1m"))
    events = tmp_path / "events.csv"
    assert main(["run", str(netlist), "-o", str(tmp_path / "out.csv"), "--signals", "v(out)",
                 "--events", str(events), "-q"]) == 0
    rows = [line.split(",") for line in events.read_text().splitlines()[1:]]
    times = np.array([float(time) for time, _, _ in rows])
    # (s1's switchings; the exact integrator, which auto takes, lists the diode's events too)
    assert times.min() >= 0.1e-3 and sum(element == "s1" for _, element, _ in rows) == 20
    whole = circuitnsds.read_netlist(netlist).transient()
    np.testing.assert_allclose(times, [event.time for event in whole.events], rtol=1e-9)  # as written


@pytest.mark.parametrize("extra", [[], ["--tstop", "0.2m"]])  # streamed / kept (no stream)
def test_ctrl_c_before_tstart_is_no_traceback(tmp_path, capsys, monkeypatch, extra):
    """Interrupted before TSTART, a run that keeps some signals has no row to write; its
    switchings before TSTART are not shown either (before: an IndexError in the partial
    result of a run with switchings, reported as an internal error)."""
    from circuitnsds.engine import integrate as engine

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(recorders, "segment_steps", lambda mlcs: 700)
    calls = {"n": 0}
    original = engine.GridStepping.solve_step

    def interrupt_later(self, k, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 300:  # at 30 us, in the first segment, before TSTART = 0.1 ms
            raise KeyboardInterrupt
        return original(self, k, *args, **kwargs)

    monkeypatch.setattr(engine.GridStepping, "solve_step", interrupt_later)
    monkeypatch.setattr(engine.GridStepping, "dense_mode", lambda *args: None)  # one MLCP per step
    netlist = tmp_path / "buck.cir"
    # (θ's step stops it: pinned to θ)
    netlist.write_text(pinned(BUCK.read_text().replace(".tran 0.1u 2m", ".tran 0.1u 0.2m 0.1m")))
    csv = tmp_path / "out.csv"
    csv.write_text("previous\n")
    status = main(["run", str(netlist), "-o", str(csv), "--signals", "v(out)", *extra])
    err = capsys.readouterr().err
    assert status == 130 and "internal error" not in err and "Traceback" not in err
    assert "no results to write" in err
    assert csv.read_text() == "previous\n"


def test_ctrl_c_while_waiting_for_the_writer_still_commits_every_row(tmp_path, monkeypatch):
    """A Ctrl-C that interrupts the wait for the chunk being formatted (formatting slower than
    stepping) leaves that chunk pending: committing the partial result waits for it, so the
    file holds every row the stream counted (the review of the plain-thread writer found a
    file with only its header)."""
    import threading
    import time as clock

    release = threading.Event()
    real_write = csvfile.write_rows

    def slow_write(*args, **kwargs):
        release.wait(5.0)  # formatting that outlasts the next segment's steps
        clock.sleep(0.05)
        return real_write(*args, **kwargs)

    monkeypatch.setattr(csvfile, "write_rows", slow_write)
    interrupted = []
    real_join = csvfile._Background.join

    def join_once_interrupted(self):
        if not interrupted:  # the first wait is cut short by Ctrl-C, with the chunk in flight
            interrupted.append(True)
            release.set()
            raise KeyboardInterrupt
        real_join(self)

    monkeypatch.setattr(csvfile._Background, "join", join_once_interrupted)
    target = tmp_path / "out.csv"
    stream = CsvStream(target, ["v(out)"], background=True)
    stream.compiled = True
    time = np.linspace(0.0, 1.0, 5)
    stream.append(time, [2 * time])
    with pytest.raises(KeyboardInterrupt):
        stream.append(time + 1.0, [2 * time])
    stream.commit()  # as the CLI does with the rows done so far
    rows = target.read_text().splitlines()
    assert len(rows) == 1 + 5 == 1 + stream.rows
    np.testing.assert_allclose(np.loadtxt(target, delimiter=",", skiprows=1)[:, 1], 2 * time)
