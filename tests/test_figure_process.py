"""``run --plot`` draws the figure in a child process started before the run (matplotlib's
import overlaps the simulation); the figure is the one drawn in-process, and any failure of
the child falls back to drawing in-process with the usual messages."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from circuitnsds.output import figure_process
from tests.conftest import NETLISTS

ROOT = Path(__file__).resolve().parents[1]
PROBE = """
import sys
from circuitnsds.cli.main import main
status = main(sys.argv[1:])
print("matplotlib imported here:", "matplotlib" in sys.modules)
sys.exit(status)
"""

two_cores = pytest.mark.skipif(figure_process._cores() < 2, reason="the child is used only with two cores")


def _run(*arguments, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-c", PROBE, *map(str, arguments)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


@two_cores
def test_child_draws_the_figure(tmp_path):
    done = _run("run", NETLISTS / "zener_regulator.cir", "-o", tmp_path / "z.csv", "--plot",
                tmp_path / "z.png", "-q", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "matplotlib imported here: False" in done.stdout  # the child drew it
    assert (tmp_path / "z.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "z.csv").stat().st_size > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["z.csv", "z.png"]  # no temporary left
    # the same figure as drawn in-process from the same results (read back from the CSV)
    import numpy as np

    from circuitnsds.output.plot import plot_waveforms
    from circuitnsds.output.waveforms import Waveforms

    data = np.genfromtxt(tmp_path / "z.csv", delimiter=",", names=True, deletechars="")
    header = (tmp_path / "z.csv").read_text().splitlines()[0].split(",")
    title = NETLISTS.joinpath("zener_regulator.cir").read_text().splitlines()[0]
    waves = Waveforms(data[header[0]], {name: data[name] for name in header[1:]}, title=title)
    plot_waveforms(waves, tmp_path / "here.png")
    assert (tmp_path / "here.png").read_bytes() == (tmp_path / "z.png").read_bytes()


def test_failed_child_falls_back_to_the_usual_error(tmp_path):
    """The figure's folder does not exist: the child fails, this process draws it and reports
    the write error as it always did (exit 1, no traceback), after writing the CSV."""
    done = _run("run", NETLISTS / "zener_regulator.cir", "-o", tmp_path / "z.csv", "--plot",
                tmp_path / "missing" / "z.png", "-q", cwd=tmp_path)
    assert done.returncode == 1
    assert "cannot write" in done.stderr and "Traceback" not in done.stderr
    assert (tmp_path / "z.csv").stat().st_size > 0


def test_unused_child_ends(tmp_path):
    with figure_process.FigureProcess() as child:
        process = child._child
    assert process is None or process.poll() is not None
