"""Outputs never destroy inputs or each other, are written whole or not at all, and
survive Ctrl-C; ``-`` is standard input/output (issue 20, items 4, 5 and 9)."""

from __future__ import annotations

import io
import math
import os

import numpy as np
import pytest

import circuitnsds
from circuitnsds.cli.main import main
from circuitnsds.output import csvfile
from circuitnsds.output.files import atomic_path
from tests.conftest import NETLISTS, pinned, pinned_copy

RC = "rc\nV1 in 0 1\nR1 in out 1k\nC1 out 0 1u\n.tran 10u 1m\n.end\n"


def _refused(capsys, argv: list[str], fragment: str) -> None:
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert fragment in err and "Traceback" not in err


def test_output_over_the_netlist_is_refused(tmp_path, capsys):
    netlist = tmp_path / "hw.cir"
    netlist.write_text(RC)
    _refused(capsys, ["run", str(netlist), "-o", str(netlist)], "would overwrite the netlist input")
    assert netlist.read_text() == RC
    _refused(capsys, ["run", str(netlist), "-r", str(tmp_path / ".." / tmp_path.name / "hw.cir")],
             "would overwrite the netlist input")
    assert netlist.read_text() == RC


def test_default_csv_named_like_the_netlist_is_refused(tmp_path, capsys, monkeypatch):
    netlist = tmp_path / "net.csv"
    netlist.write_text(RC)
    monkeypatch.chdir(tmp_path)
    _refused(capsys, ["run", "net.csv"], "-o net.csv would overwrite the netlist input")
    assert netlist.read_text() == RC


@pytest.mark.parametrize("argv", [
    ["run", "{net}", "--events", "{net}"],
    ["pss", "{net}", "-o", "{net}"],
    ["ac", "{net}", "--fstart", "10", "--fstop", "1k", "-o", "{net}"],
    ["ac", "{net}", "--fstart", "10", "--fstop", "1k", "--plot", "{net}"],
    ["sweep", "{net}", "--param", "R=1k,2k", "--measure", "mean(v(out))", "--workers", "0",
     "-o", "{net}"],
    ["sweep", "{net}", "--param", "R=1k,2k", "--measure", "mean(v(out))", "--workers", "0",
     "--plot", "{net}"],
    ["compare", "{net}", "--json", "{net}"],
    ["info", "{net}", "--matrices", "{net}"],
])
def test_every_command_refuses_to_write_over_the_netlist(tmp_path, capsys, argv):
    netlist = tmp_path / "hw.cir"
    text = ("rc\n.param R=1k\nV1 in 0 PULSE(0 1 0 1u 1u 0.5m 1m) AC 1\nR1 in out {R}\n"
            "C1 out 0 1u\n.tran 10u 1m\n.end\n")
    netlist.write_text(text)
    _refused(capsys, [a.replace("{net}", str(netlist)) for a in argv], "would overwrite the netlist input")
    assert netlist.read_text() == text


@pytest.mark.parametrize("argv", [
    ["ac", "{net}", "--fstart", "10", "--fstop", "1k", "-o", "{dir}/b.csv", "--plot", "{dir}/b.xyz"],
    ["sweep", "{net}", "--param", "R=1k,2k", "--measure", "mean(v(out))", "--workers", "0",
     "-o", "{dir}/t.csv", "--plot", "{dir}/t.xyz"],
])
def test_an_unknown_figure_format_is_refused_before_the_run(tmp_path, capsys, argv):
    # before: ac and sweep found out after the whole run (a sweep of hours), run and pss before
    netlist = tmp_path / "hw.cir"
    netlist.write_text("rc\n.param R=1k\nV1 in 0 DC 1 AC 1\nR1 in out {R}\nC1 out 0 1u\n"
                       ".tran 10u 1m\n.end\n")
    _refused(capsys, [a.replace("{net}", str(netlist)).replace("{dir}", str(tmp_path)) for a in argv],
             "'.xyz' is not a figure format")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hw.cir"]  # nothing ran, nothing written
    assert capsys.readouterr().out == ""


def test_output_over_an_included_file_is_refused(tmp_path, capsys):
    (tmp_path / "parts.inc").write_text("R1 in out 1k\nC1 out 0 1u\n")
    netlist = tmp_path / "top.cir"
    netlist.write_text("top\nV1 in 0 1\n.include parts.inc\n.tran 10u 1m\n.end\n")
    _refused(capsys, ["run", str(netlist), "--plot", str(tmp_path / "parts.inc")],
             "would overwrite the netlist input")
    assert (tmp_path / "parts.inc").read_text().startswith("R1")


def test_two_outputs_in_one_file_are_refused(tmp_path, capsys):
    netlist = tmp_path / "rc.cir"
    netlist.write_text(RC)
    _refused(capsys, ["run", str(netlist), "-o", str(tmp_path / "a.csv"), "-r", str(tmp_path / "a.csv")],
             "-o and -r name the same file")
    assert not (tmp_path / "a.csv").exists()


def test_csv_keeps_full_precision(tmp_path):
    values = np.array([0.1, 1 / 3, -2.5e-300, 1e300, math.pi * 1e-9, 0.0, np.inf, -np.inf])
    waves = circuitnsds.Waveforms(time=np.arange(values.size, dtype=float), signals={"v(x)": values})
    path = tmp_path / "x.csv"
    waves.to_csv(path)
    lines = path.read_text().splitlines()
    assert lines[0] == "time,v(x)"
    read = np.array([float(line.split(",")[1]) for line in lines[1:]])
    np.testing.assert_array_equal(read, values)  # repr round-trips every double exactly


def test_csv_blocks_join_seamlessly(tmp_path, monkeypatch):
    monkeypatch.setattr(csvfile, "BLOCK_ROWS", 7)
    time = np.linspace(0.0, 1.0, 50)
    waves = circuitnsds.Waveforms(time=time, signals={"a": time ** 2, "b": -time})
    waves.to_csv(tmp_path / "x.csv")
    data = np.loadtxt(tmp_path / "x.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(data, np.column_stack([time, time ** 2, -time]))


def test_an_interrupted_write_leaves_the_previous_file(tmp_path, monkeypatch):
    path = tmp_path / "out.csv"
    path.write_text("previous\n")
    os.chmod(path, 0o640)
    calls = []

    def interrupted(stream, time, columns, **options):
        stream.write(b"1,2\n")
        calls.append(1)
        raise KeyboardInterrupt

    monkeypatch.setattr(csvfile, "write_rows", interrupted)
    waves = circuitnsds.Waveforms(time=np.zeros(3), signals={"v(a)": np.zeros(3)})
    with pytest.raises(KeyboardInterrupt):
        waves.to_csv(path)
    assert calls and path.read_text() == "previous\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]  # no temporary left
    monkeypatch.undo()
    waves.to_csv(path)
    assert path.read_text().startswith("time,v(a)\n") and (path.stat().st_mode & 0o777) == 0o640


def test_atomic_path_writes_devices_directly():
    with atomic_path(os.devnull) as target:
        assert str(target) == os.devnull  # never a rename over /dev/null


def test_dash_reads_stdin_and_writes_stdout(capsys, monkeypatch):
    monkeypatch.setattr("sys.stdin", io.StringIO(pinned(RC)))  # (implicit Euler's values: θ)
    assert main(["run", "-", "-q", "--signals", "v(out)", "--uic"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "time,v(out)"
    data = np.array([[float(x) for x in line.split(",")] for line in out[1:]])
    assert data[-1, 0] == pytest.approx(1e-3)
    # implicit Euler on the RC: v_k = 1 - (1 + h/τ)^-k, τ = 1 ms, h = 10 µs
    steps = np.arange(data.shape[0])
    np.testing.assert_allclose(data[:, 1], 1 - 1.01 ** -steps, rtol=1e-9, atol=1e-12)


def test_dash_output_with_a_netlist_file(tmp_path, capsys):
    netlist = tmp_path / "rc.cir"
    netlist.write_text(RC)
    assert main(["run", str(netlist), "-o", "-", "-q", "--measure", "mean(v(out))"]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("time,")  # the CSV alone on stdout; the table on stderr
    assert "mean" in captured.err
    assert not (tmp_path / "rc.csv").exists() and not os.path.exists("-")


@pytest.mark.parametrize("argv", [
    ["run", "{net}", "-o", "{dir}/o.csv", "--plot", "-"],
    ["run", "{net}", "-o", "{dir}/o.csv", "-r", "-"],
    ["run", "{net}", "-o", "{dir}/o.csv", "--events", "-"],
    ["ac", "{net}", "--fstart", "10", "--fstop", "1k", "-o", "{dir}/b.csv", "--plot", "-"],
    ["sweep", "{net}", "--param", "R=1k,2k", "--measure", "mean(v(out))", "--workers", "0",
     "--plot", "-"],
    ["info", "{net}", "--matrices", "-"],
    ["compare", "{net}", "--plot", "-"],
    ["compare", "{net}", "--json", "-"],
])
def test_only_the_csv_goes_to_standard_output(tmp_path, capsys, monkeypatch, argv):
    # before: each of these wrote a file named "-" in the current folder (info: "-.npz")
    monkeypatch.chdir(tmp_path)
    netlist = tmp_path / "hw.cir"
    netlist.write_text("rc\n.param R=1k\nV1 in 0 PULSE(0 1 0 1u 1u 0.5m 1m) AC 1\nR1 in out {R}\n"
                       "C1 out 0 1u\n.tran 10u 1m\n.end\n")
    _refused(capsys, [a.replace("{net}", str(netlist)).replace("{dir}", str(tmp_path)) for a in argv],
             "cannot go to standard output")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hw.cir"]


def test_the_bode_table_to_standard_output(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    netlist = tmp_path / "rc.cir"
    netlist.write_text("rc\nV1 in 0 DC 0 AC 1\nR1 in out 1k\nC1 out 0 1u\n.end\n")
    assert main(["ac", str(netlist), "--fstart", "10", "--fstop", "1k", "--output", "v(out)",
                 "-o", "-", "-q"]) == 0
    rows = capsys.readouterr().out.splitlines()
    assert rows[0].startswith("frequency") and len(rows) == 1 + 41
    f, magnitude = (float(x) for x in rows[-1].split(",")[:2])
    # first-order low pass, corner 1/(2π·1 ms) = 159 Hz
    assert f == pytest.approx(1e3) and magnitude == pytest.approx(
        -10 * math.log10(1 + (2 * math.pi * 1e3 * 1e-3) ** 2), abs=1e-6)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rc.cir"]


def test_standard_input_as_the_netlist(tmp_path, capsys, monkeypatch):
    # before: `ac -` and `sweep -`/`compare -` said "cannot read the netlist '-': no such file"
    # although run, pss and info read standard input
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("sys.stdin", io.StringIO("rc\nV1 in 0 DC 0 AC 1\nR1 in out 1k\nC1 out 0 1u\n"
                                                 ".end\n"))
    assert main(["ac", "-", "--fstart", "10", "--fstop", "1k", "--output", "v(out)", "-q"]) == 0
    rows = capsys.readouterr().out.splitlines()  # the Bode table on stdout, as run's CSV
    assert rows[0] == "frequency,mag(v(out)),phase(v(out))" and len(rows) == 42
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    for argv in (["sweep", "-", "--param", "R=1,2"], ["compare", "-"]):
        _refused(capsys, argv, f"error: -: {argv[0]} reads a netlist file, not standard input")


def test_with_the_csv_on_stdout_every_report_goes_to_stderr(tmp_path, capsys):
    # before: --losses, .meas and .four printed their lines on stdout after the CSV, so that
    # `run NETLIST -o - > out.csv` gave a CSV with a power table and ngspice lines at its end
    netlist = tmp_path / "rc.cir"
    netlist.write_text(RC.replace(".end", ".meas tran vavg AVG v(out)\n.four 1k v(out)\n.end"))
    assert main(["run", str(netlist), "-o", "-", "-q", "--losses", "r1", "--uic"]) == 0
    captured = capsys.readouterr()
    rows = captured.out.splitlines()
    assert rows[0] == "time,v(in),v(out),i(v1),i(r1),i(c1)" and len(rows) == 102
    assert all(len(row.split(",")) == 6 for row in rows)
    assert "power balance" in captured.err and "vavg" in captured.err
    assert "Fourier analysis for v(out)" in captured.err


def test_ctrl_c_writes_the_partial_results_and_exits_130(tmp_path, capsys, monkeypatch):
    from circuitnsds.engine import integrate as engine

    # (the interruption comes from θ's step: pinned to θ)
    netlist = pinned_copy(NETLISTS / "half_wave_rectifier.cir", tmp_path)
    calls = {"n": 0}
    original = engine.GridStepping.solve_step

    def interrupt_later(self, k, *args, **kwargs):
        calls["n"] += 1
        if k == 120:
            raise KeyboardInterrupt
        return original(self, k, *args, **kwargs)

    monkeypatch.setattr(engine.GridStepping, "solve_step", interrupt_later)
    monkeypatch.setattr(engine.GridStepping, "dense_mode", lambda *args: None)  # one MLCP per step
    csv = tmp_path / "out.csv"
    status = main(["run", str(netlist), "-o", str(csv), "--step", "100u", "--stop", "20m",
                   "--signals", "v(out)"])
    err = capsys.readouterr().err
    assert status == 130
    assert "wrote the results up to t = 0.012 s (when interrupted) to" in err
    assert err.rstrip().endswith("circuitnsds: interrupted")
    first = csv.read_text().splitlines()[0]
    assert first == "# partial: the run stopped at t = 0.012 s (when interrupted); the rows end there"
    data = np.loadtxt(csv, delimiter=",", skiprows=2)
    assert data.shape[0] == 121  # t_0 .. t_120: every step done before the interruption
    assert data[-1, 0] == pytest.approx(120 * 100e-6)
    np.testing.assert_allclose(data[:, 1], np.maximum(10 * np.sin(2 * np.pi * 50 * data[:, 0]), 0),
                               atol=1e-6)
