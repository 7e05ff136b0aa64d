"""``circuitnsds info``: elements by kind, nodes, MLCS size, breakpoints, checks."""

import numpy as np

from circuitnsds.cli.main import main
from tests.conftest import NETLISTS


def run_info(tmp_path, capsys, netlist_text=None, path=None, extra=()):
    if netlist_text is not None:
        path = tmp_path / "c.cir"
        path.write_text(netlist_text)
    status = main(["info", str(path), *extra])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_bridge_rectifier(tmp_path, capsys):
    status, out, _ = run_info(tmp_path, capsys, path=NETLISTS / "bridge_rectifier.cir")
    assert status == 0
    assert "nodes:     4 + ground 0: line, acn, acp, out" in out
    assert "  diodes (4): d1, d2, d3, d4" in out
    assert "  resistors (2): rsrc, rload" in out
    assert "  d1 acp out: model drect: piecewise-linear diode, Vfwd=0.8 V, Ron=0.02 Ω" in out
    # one capacitor: one differential row; 4 node voltages + 1 source current in all
    assert "MLCS:      5 unknowns = 1 states (differential rows) + 4 algebraic; " \
           "4 complementarity pairs" in out
    assert out.count("  pass  ") == 5 and "FAIL" not in out
    assert "breakpoints: 0 in (0, 100 ms)" in out


def test_zener_pairs_and_pulse_breakpoints(tmp_path, capsys):
    status, out, _ = run_info(tmp_path, capsys, "pulsed zener\n"
                              "V1 in 0 PULSE(0 10 1m 1u 1u 2m 5m)\nR1 in out 100\n"
                              "DZ1 0 out z\nL1 out x 1m\nR2 x 0 10\n.model z D(BV=5.1)\n"
                              ".tran 1u 30m\n.end\n")
    assert status == 0
    assert "  Zener diodes (1): dz1" in out
    assert "2 complementarity pairs" in out and "pairs:    dz1.forward, dz1.reverse" in out
    assert "= 1 states (differential rows)" in out
    # 6 periods of 5 ms, 4 corners each, inside (0, 30 ms)
    assert "breakpoints: 24 in (0, 30 ms): 1 ms, 1.001 ms, 3.001 ms, 3.002 ms, 6 ms," in out
    assert "... (24 in all)" in out


def test_failed_check_is_reported_and_exits_1(tmp_path, capsys):
    status, out, err = run_info(tmp_path, capsys, "t\nI1 0 a 1m\nC1 a 0 1u\nR1 b 0 1\n"
                                "V1 b 0 1\n.tran 1u 1m\n.end\n")
    assert status == 1
    assert "  FAIL  DC operating point: every node has a DC path to ground: node(s) a" in out
    assert "MLCS:" in out  # still described: only the operating point is undefined
    assert "fails the checks" in err and "Traceback" not in err
    status, out, _ = run_info(tmp_path, capsys, "t\nI1 0 a 1m\nC1 a 0 1u\nR1 b 0 1\n"
                              "V1 b 0 1\n.tran 1u 1m uic\n.end\n")
    assert status == 0 and "  skip  DC operating point" in out
    status, out, _ = run_info(tmp_path, capsys, "t\nV1 a 0 1\nV2 a 0 2\nR1 a 0 1\n.tran 1u 1m\n.end\n")
    assert status == 1 and "  FAIL  no loop of voltage sources only" in out
    assert "MLCS:      not built" in out


def test_matrices(tmp_path, capsys):
    npz = tmp_path / "m.npz"
    status, out, _ = run_info(tmp_path, capsys, path=NETLISTS / "half_wave_rectifier.cir",
                              extra=["--matrices", str(npz)])
    assert status == 0 and f"matrices saved to {npz}" in out
    assert np.load(npz)["E"].shape == (3, 3)  # v(in), v(out), i(v1)


def test_matrices_go_to_the_file_named_or_fail(tmp_path, capsys):
    # numpy's savez appends ".npz" to a name without it: --matrices m.txt wrote m.txt.npz and
    # --matrices DIR/ wrote DIR.npz next to the folder, each while printing "saved to" the name
    # given; the file is now written under the name given, a folder is an error
    named = tmp_path / "m.txt"
    status, out, _ = run_info(tmp_path, capsys, path=NETLISTS / "half_wave_rectifier.cir",
                              extra=["--matrices", str(named)])
    assert status == 0 and f"matrices saved to {named}" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.txt"]
    assert np.load(named)["E"].shape == (3, 3)
    folder = tmp_path / "out"
    folder.mkdir()
    status, out, err = run_info(tmp_path, capsys, path=NETLISTS / "half_wave_rectifier.cir",
                                extra=["--matrices", f"{folder}/"])
    assert status == 1
    assert f"error: {folder}: cannot write {folder}: Is a directory" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.txt", "out"]
