"""The command line: outputs, options, and clean errors (no tracebacks)."""

import subprocess
import sys

import numpy as np
import pytest

from circuitnsds.cli.main import main
from tests.conftest import NETLISTS


def test_run_writes_csv_and_png(tmp_path, capsys):
    csv, png = tmp_path / "out.csv", tmp_path / "out.png"
    status = main(["run", str(NETLISTS / "half_wave_rectifier.cir"), "-o", str(csv),
                   "--plot", str(png), "--signals", "v(out), i(d1)", "--step", "100u",
                   "--stop", "20m"])
    assert status == 0
    header = csv.read_text().splitlines()[0]
    assert header == "time,v(out),i(d1)"
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert data.shape == (201, 3)
    assert data[-1, 0] == pytest.approx(20e-3)
    np.testing.assert_allclose(data[:, 1], np.maximum(10 * np.sin(2 * np.pi * 50 * data[:, 0]), 0),
                               atol=1e-6)
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert "wrote" in capsys.readouterr().err


def test_signals_given_twice_are_both_written(tmp_path):
    # --signals v(out) --signals i(d1) wrote i(d1) alone (argparse kept the last)
    csv = tmp_path / "out.csv"
    assert main(["run", str(NETLISTS / "half_wave_rectifier.cir"), "-o", str(csv), "--signals", "v(out)",
                 "--signals", "i(d1)", "--step", "1m", "--stop", "20m"]) == 0
    assert csv.read_text().splitlines()[0] == "time,v(out),i(d1)"


def test_default_output_name_and_theta(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(NETLISTS / "diode_clamp.cir"), "--theta", "0.5", "-q"]) == 0
    assert (tmp_path / "diode_clamp.csv").exists()


@pytest.mark.parametrize(
    ("netlist", "args", "message"),
    [
        ("t\nR1 a 0 1k\nT1 a 0 b 0 z0=50 td=1n\n.end\n", [], "bad.cir:3: t1: transmission lines"),
        ("t\nD1 a 0 nomodel\nR1 a 0 1\n.tran 1u 1m\n.end\n", [], "bad.cir:2: d1: diode model"),
        ("t\nR1 a 0 1k\n.end\n", [], "no .tran line"),
        ("t\nR1 a 0 1k\n.tran 1u 1m\n.end\n", ["--signals", "v(zz)"], "unknown signal(s) v(zz)"),
        ("t\nR1 a 0 1k\n.tran 1u 1m\n.end\n", ["--theta", "0.2"], "theta = 0.2 is outside"),
        ("t\nV1 a 0 1\nV2 a 0 2\n.tran 1u 1m\n.end\n", [], "form a loop of voltage sources"),
        # options that only qualify another output: before, exit 0 with the option dropped
        ("t\nR1 a 0 1k\n.tran 1u 1m\n.end\n", ["--ascii"],
         "--ascii: --ascii is the format of the raw file, and no -r is given"),
        ("t\nR1 a 0 1k\n.tran 1u 1m\n.end\n", ["--signals", " , "],  # was a CSV of time alone
         "--signals: --signals ' , ' names no signal"),
        ("t\nR1 a 0 1k\n.tran 1u 1m\n.end\n", ["--mark-events"],
         "--mark-events: --mark-events draws on the figure, and neither --plot nor --show is given"),
    ],
)
def test_bad_input_exits_1_with_a_located_message(tmp_path, capsys, netlist, args, message):
    path = tmp_path / "bad.cir"
    path.write_text(netlist)
    status = main(["run", str(path), "-o", str(tmp_path / "x.csv"), *args])
    err = capsys.readouterr().err
    assert status == 1
    assert message in err
    assert "Traceback" not in err


def test_missing_file_and_bad_step(tmp_path):
    result = subprocess.run([sys.executable, "-m", "circuitnsds", "run", str(tmp_path / "no.cir")],
                            capture_output=True, text=True)
    assert result.returncode == 1
    assert "cannot read the netlist" in result.stderr and "Traceback" not in result.stderr
    result = subprocess.run([sys.executable, "-m", "circuitnsds", "run",
                             str(NETLISTS / "diode_clamp.cir"), "--step", "abc"],
                            capture_output=True, text=True)
    assert result.returncode == 2 and "is not a time" in result.stderr


def test_info_prints_sizes_and_saves_matrices(tmp_path, capsys):
    npz = tmp_path / "m.npz"
    assert main(["info", str(NETLISTS / "book_zener_rlc.cir"), "--matrices", str(npz)]) == 0
    out = capsys.readouterr().out
    assert "4 unknowns = 2 states (differential rows) + 2 algebraic; 2 complementarity pairs" in out
    assert "dz1.forward, dz1.reverse" in out
    assert "zener diode" in out
    assert np.load(npz)["A"].shape == (4, 4)


def test_warnings_are_printed(tmp_path, capsys):
    path = tmp_path / "w.cir"
    path.write_text("t\nR1 a 0 1k\nV1 a 0 1\n.options reltol=1e-4\n.tran 1u 5u\n.end\n")
    assert main(["run", str(path), "-o", str(tmp_path / "w.csv"), "-q"]) == 0
    assert "warning: " in capsys.readouterr().err
