"""``run --plot`` can draw the figure in a child process started before the run (matplotlib's
import overlaps the simulation); the figure is the one drawn in-process, and any failure of
the child falls back to drawing in-process with the usual messages."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

import circuitnsds
from circuitnsds.output import figure_process
from circuitnsds.output.plot import plot_waveforms
from circuitnsds.output.waveforms import Waveforms
from tests.conftest import NETLISTS

ROOT = Path(__file__).resolve().parents[1]


def _run(*arguments, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "circuitnsds", *map(str, arguments)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


def test_child_draws_the_figure_drawn_in_process(tmp_path):
    waves = circuitnsds.read_netlist(NETLISTS / "zener_regulator.cir").transient()
    with figure_process.FigureProcess(start=True) as child:
        assert child.send(waves, tmp_path / "child.png", None)
        assert child.wait()  # the child wrote it
    plot_waveforms(waves, tmp_path / "here.png")
    assert (tmp_path / "child.png").read_bytes() == (tmp_path / "here.png").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["child.png", "here.png"]  # no temporary


def test_command_writes_the_figure_of_its_results(tmp_path):
    """Whether or not the command used a child (it depends on the machine's load), the PNG
    is the one drawn in-process from the results it wrote (read back from the CSV)."""
    done = _run("run", NETLISTS / "zener_regulator.cir", "-o", tmp_path / "z.csv", "--plot",
                tmp_path / "z.png", "-q", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    data = np.genfromtxt(tmp_path / "z.csv", delimiter=",", names=True, deletechars="")
    header = (tmp_path / "z.csv").read_text().splitlines()[0].split(",")
    title = NETLISTS.joinpath("zener_regulator.cir").read_text().splitlines()[0]
    waves = Waveforms(data[header[0]], {name: data[name] for name in header[1:]}, title=title)
    plot_waveforms(waves, tmp_path / "here.png")
    assert (tmp_path / "here.png").read_bytes() == (tmp_path / "z.png").read_bytes()


def test_failed_child_falls_back_to_the_usual_error(tmp_path):
    """The figure's folder does not exist: the child fails, the caller draws it and reports
    the write error as it always did."""
    waves = circuitnsds.read_netlist(NETLISTS / "zener_regulator.cir").transient()
    with figure_process.FigureProcess(start=True) as child:
        assert child.send(waves, tmp_path / "missing" / "z.png", None)
        assert not child.wait()
    done = _run("run", NETLISTS / "zener_regulator.cir", "-o", tmp_path / "z.csv", "--plot",
                tmp_path / "missing" / "z.png", "-q", cwd=tmp_path)
    assert done.returncode == 1
    assert "cannot write" in done.stderr and "Traceback" not in done.stderr
    assert (tmp_path / "z.csv").stat().st_size > 0


def test_unused_child_ends():
    with figure_process.FigureProcess(start=True) as child:
        process = child._child
    assert process is not None and process.poll() is not None
    assert not figure_process.FigureProcess(start=False).send(None, "x.png", None)


def test_command_with_its_child_forced(tmp_path, monkeypatch):
    """The command's own use of the child, whatever the machine's load (the gate keeps it
    off on a busy machine, and then the test above never sees it): the child takes the
    figure and draws the one the command would draw itself."""
    from circuitnsds.cli.main import main

    monkeypatch.setattr(figure_process, "worth_starting", lambda: True)
    sent = []
    original = figure_process.FigureProcess.send
    monkeypatch.setattr(figure_process.FigureProcess, "send",
                        lambda self, *a, **k: sent.append(original(self, *a, **k)) or sent[-1])
    netlist = NETLISTS / "zener_regulator.cir"
    assert main(["run", str(netlist), "-o", str(tmp_path / "z.csv"), "--plot",
                 str(tmp_path / "z.png"), "-q"]) == 0
    assert sent == [True]  # the child took the figure
    plot_waveforms(circuitnsds.read_netlist(netlist).transient(), tmp_path / "here.png")
    assert (tmp_path / "here.png").read_bytes() == (tmp_path / "z.png").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["here.png", "z.csv", "z.png"]


def test_child_does_not_run_the_users_files(tmp_path, monkeypatch):
    """``python -c`` puts the current folder first on the child's path: a user's own
    ``pickle.py`` (or ``numpy.py``, ``threading.py`` ...) in the folder the command runs
    in must not be executed in place of the module (the command itself, an installed
    script, never looks there)."""
    waves = circuitnsds.read_netlist(NETLISTS / "zener_regulator.cir").transient()
    marker = tmp_path / "ran"
    (tmp_path / "pickle.py").write_text(f"open({str(marker)!r}, 'w').close()\n")
    monkeypatch.chdir(tmp_path)
    with figure_process.FigureProcess(start=True) as child:
        assert child.send(waves, tmp_path / "z.png", None)
        assert child.wait()
    assert not marker.exists()
