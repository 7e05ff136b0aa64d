"""A catalogue of named mistakes and the exact message the command line prints for each.

Every entry runs ``circuitnsds run bad.cir`` in a temporary directory and compares the
whole of stderr: one or two lines, exit status 1, no traceback. These are the messages
users see; change them here on purpose, never by accident.
"""

import pytest

from circuitnsds.cli.main import main

ERROR = "circuitnsds: error: "

CATALOGUE = {
    "missing .model": (
        b"t\nD1 a 0 dmod\nR1 a 0 1k\n.tran 1u 1m\n.end\n",
        "bad.cir:2: d1: diode model 'dmod' is not defined\n"
        "  hint: add a line such as: .model dmod D()  (an ideal diode) or .model dmod "
        "D(Vfwd=0.7 Ron=10m); in: D1 a 0 dmod",
    ),
    "unknown model type": (
        b"t\nD1 a 0 dmod\nR1 a 0 1k\n.model dmod xyz(a=1)\n.tran 1u 1m\n.end\n",
        "bad.cir:2: d1: model 'dmod' is an unknown-type (XYZ) model, not a diode (D) model\n"
        "  hint: a diode needs a diode model: .model dmod D(...); in: D1 a 0 dmod",
    ),
    "unknown element letter": (
        b"t\n9R1 a 0 1k\nV1 a 0 1\n.tran 1u 1m\n.end\n",
        "bad.cir:2: 9r1: unknown element type '9'\n"
        "  hint: element names start with their type letter: R, C, L, K, V, I, E, F, G, H, B, D, S, "
        "W, M, A, J, Q, Z and X (subcircuit instances); in: 9R1 a 0 1k",
    ),
    "unsupported element letter": (
        b"t\nR1 a 0 1k\nT1 a 0 b 0 z0=50 td=1n\n.tran 1u 1m\n.end\n",
        "bad.cir:3: t1: transmission lines ('T' lines) are not supported by the ideal engine\n"
        "  hint: circuitnsds reads R, C, L, K, V, I, E, F, G, H, B, D, S, W, M, A, J, Q, Z and X "
        "(subcircuit instances); model a transistor used as a switch with an S switch driven by "
        "its gate signal, or a MOSFET (M line); in: T1 a 0 b 0 z0=50 td=1n",
    ),
    ".tran missing": (
        b"t\nR1 a 0 1k\nV1 a 0 1\n.end\n",
        "bad.cir: no .tran line and no step/stop given\n"
        "  hint: add '.tran TSTEP TSTOP' to the netlist (e.g. .tran 1u 10m), or give --step and "
        "--stop (step= and stop= in Python)",
    ),
    ".tran TSTEP < 0": (
        b"t\nR1 a 0 1k\nV1 a 0 1\n.tran -1u 1m\n.end\n",
        "bad.cir:4: .tran TSTEP = -1 \xb5s must be positive\n"
        "  hint: .tran TSTEP TSTOP [TSTART [TMAX]] [UIC], e.g. .tran 1u 10m; in: .tran -1u 1m",
    ),
    ".ic on an unknown node": (
        b"t\nR1 a 0 1k\nV1 a 0 1\n.ic v(zz)=1\n.tran 1u 1m\n.end\n",
        "bad.cir:4: .ic names node 'zz', which no element connects\n"
        "  hint: nodes are: a",
    ),
    "a number too large": (
        b"t\nR1 a 0 1e999\nV1 a 0 1\n.tran 1u 1m\n.end\n",
        "bad.cir:2: r1: resistance '1e999' is too large (beyond 1.8e308)\n"
        "  hint: numbers look like 10, 4.7k, 10uF, 1e-3; in: R1 a 0 1e999",
    ),
    "NaN literal": (
        b"t\nR1 a 0 nan\nV1 a 0 1\n.tran 1u 1m\n.end\n",
        "bad.cir:2: r1: resistance 'nan' is not a number\n"
        "  hint: numbers look like 10, 4.7k, 10uF, 1e-3; in: R1 a 0 nan",
    ),
    "division by zero in an expression": (
        b"t\nR1 a 0 {1/0}\nV1 a 0 1\n.tran 1u 1m\n.end\n",
        "bad.cir:2: r1: division by zero in '1/0'\n"
        "  hint: in: R1 a 0 {1/0}",
    ),
    "empty file": (
        b"",
        "bad.cir: the netlist is empty\n"
        "  hint: the first line of a netlist is its title, then elements and .tran",
    ),
    "binary file": (
        b"\x7fELF\x02\x01\x01\x00\x00\x00",
        "bad.cir: the netlist 'bad.cir' is a binary file, not netlist text\n"
        "  hint: a netlist is plain text; check that the right file is named",
    ),
    # The three below come from circuitnsds/netlist/ (parser and includes).
    "include cycle": (
        b"t\n.include b.inc\n.end\n",
        "a.inc:1: .include: b.inc includes itself (bad.cir -> b.inc -> a.inc -> b.inc)\n"
        "  hint: remove the include that closes the cycle",
    ),
    "non-UTF-8 file": (
        b"t\nR1 a 0 1k \xe9\n.end\n",
        "bad.cir: the netlist 'bad.cir' is not UTF-8 text (byte 0xe9 on its line 2)\n"
        "  hint: convert it, e.g. iconv -f latin1 -t utf-8 bad.cir > bad-utf8.cir",
    ),
}


@pytest.mark.parametrize("mistake", list(CATALOGUE))
def test_named_mistake_prints_exactly(mistake, tmp_path, monkeypatch, capsys):
    content, expected = CATALOGUE[mistake]
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.cir").write_bytes(content)
    (tmp_path / "b.inc").write_text(".include a.inc\n")
    (tmp_path / "a.inc").write_text(".include b.inc\nR1 a 0 1\n")
    status = main(["run", "bad.cir", "-o", "out.csv", "-q"])
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if not line.startswith("circuitnsds: warning:")]
    assert status == 1
    assert "\n".join(errors) == ERROR + expected
    assert not (tmp_path / "out.csv").exists()


def test_file_not_found(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "nothere.cir", "-q"]) == 1
    assert capsys.readouterr().err == (
        ERROR + "nothere.cir: cannot read the netlist 'nothere.cir': no such file\n"
        "  hint: check the name and its case; relative paths start from the directory of the "
        "file that names them\n")


def test_included_file_not_found(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.cir").write_text("t\nR1 a 0 1k\n.include nothere.lib\n.tran 1u 1m\n.end\n")
    assert main(["run", "bad.cir", "-q"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(ERROR + "bad.cir:3: .include: file 'nothere.lib' not found")
    assert len(err.splitlines()) == 2
