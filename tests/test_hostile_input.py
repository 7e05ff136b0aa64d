"""Hostile or absurd input gets a clear error, never "internal error" (issue 20, items 6-8)."""

import os

import pytest

from circuitnsds.cli.main import main
from circuitnsds.errors import NetlistError
from circuitnsds.netlist.expressions import MAX_DEPTH, ExpressionError, evaluate
from tests.conftest import NETLISTS, circuit_from


def _run(tmp_path, capsys, text, *args):
    netlist = tmp_path / "hostile.cir"
    netlist.write_text(text)
    status = main(["run", str(netlist), "-o", str(tmp_path / "out.csv"), "-q", *args])
    err = capsys.readouterr().err
    assert "internal error" not in err
    return status, err


# --- item 7: deep nesting --------------------------------------------------------------------

def test_parentheses_nested_to_the_limit_evaluate_and_deeper_is_an_error():
    assert evaluate("(" * MAX_DEPTH + "2" + ")" * MAX_DEPTH) == 2.0
    assert evaluate("sqrt(" * 50 + "16" + ")" * 50) == pytest.approx(1.0 + 16 ** (2.0 ** -50) - 1.0)
    with pytest.raises(ExpressionError, match="nested more than 100 levels"):
        evaluate("(" * 300 + "1" + ")" * 300)


def test_any_number_of_unary_signs():
    assert evaluate("-" * 20000 + "1") == 1.0
    assert evaluate("-" * 20001 + "1") == -1.0
    assert evaluate("2^" + "-" * 5001 + "1") == 0.5


def test_deep_parentheses_in_a_netlist_are_a_netlist_error(tmp_path, capsys):
    text = "deep\n.param p=" + "(" * 300 + "1" + ")" * 300 + "\nR1 a 0 {p}\nV1 a 0 1\n.tran 1u 10u\n.end\n"
    status, err = _run(tmp_path, capsys, text)
    assert status == 1 and "hostile.cir:2" in err and "nested more than 100 levels" in err
    assert len(err) < 1000                           # the 601-character line is not echoed whole


def test_long_chains_of_parameters():
    forward = "\n".join([".param p0=1"] + [f".param p{i}={{p{i - 1}+1}}" for i in range(1, 3000)])
    circuit = circuit_from(forward + "\nR1 a 0 {p2999}\nV1 a 0 1")
    assert circuit.elements[0].resistance == 3000.0     # defined in order: evaluated in order
    backward = "\n".join(f".param p{i}={{p{i - 1}+1}}" for i in range(300, 0, -1)) + "\n.param p0=1"
    with pytest.raises(NetlistError, match="chain of more than 50 parameters"):
        circuit_from(backward + "\nR1 a 0 {p300}\nV1 a 0 1")


# --- item 7: figures ---------------------------------------------------------------------------

def test_unknown_figure_format_is_refused_before_simulating(tmp_path, capsys):
    status, err = _run(tmp_path, capsys, (NETLISTS / "diode_clamp.cir").read_text(),
                       "--plot", str(tmp_path / "x.xyz"))
    assert status == 1 and "'.xyz' is not a figure format" in err and ".png" in err
    assert not (tmp_path / "out.csv").exists()       # refused before the run, not after


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="/dev/full is Linux's full device")
def test_a_figure_that_cannot_be_written_is_an_error(tmp_path, capsys):
    status, err = _run(tmp_path, capsys, (NETLISTS / "diode_clamp.cir").read_text(),
                       "--plot", "/dev/full")
    assert status == 1 and "No space left on device" in err
