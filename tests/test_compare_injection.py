"""``compare`` hands ngspice only what circuitnsds read as circuit (issue 37).

ngspice runs ``*#`` comment lines as commands, reads a deck titled ``*ng_script`` as a
script, runs ``.control`` blocks and, when it starts, a ``.spiceinit`` of the current
folder. Each test plants one such form, in the netlist or in a file it includes, whose
command would create a marker file; it checks that the marker is not created and that
the comparison still runs. The translation tests need no ngspice; the others are
marked ``ngspice`` (they fail, not skip, without it: see test_compare_ngspice.py).
"""

import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.compare import compare, translate_netlist
from circuitnsds.compare.translate import CIRCUIT_COMMANDS
from circuitnsds.errors import NetlistError

RC = """V1 in 0 SIN(0 1 1k)
R1 in out 1k
C1 out 0 1u
.tran 10u 2m
"""

#: comment-line command forms; {marker} is the file a successful injection creates
COMMENT_COMMANDS = [
    "*# shell touch {marker}",
    "*#SHELL touch {marker}",
    "*#shell touch {marker}",
    "*#\tshell touch {marker}",
    "  *# shell touch {marker}",
    "*# echo hi > {marker}",
    "*# tran 10u 1m\n*# wrdata {marker} v(in)",
    "*#TRAN 10u 1m\n*#write {marker} v(in)",
]

SCRIPT_TITLES = ["*ng_script", "*NG_SCRIPT", " *ng_script", "*ng_script_with_params", "*Ng_Script x"]


def _compare(netlist: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the .control blocks are reported as warnings
        return compare(netlist, signals=["v(out)"])


def _assert_clean_run(comparison, marker: Path) -> None:
    assert not marker.exists(), f"ngspice ran an injected command: {marker} was created"
    assert comparison.runs[0].ngspice.ok, comparison.runs[0].ngspice.message
    assert comparison.runs[0].metrics["v(out)"].nrms < 0.05


def _deck_lines(translation_text: str) -> list[str]:
    return translation_text.splitlines()


# --- the translation (no ngspice needed) ------------------------------------------------------


@pytest.mark.parametrize("form", COMMENT_COMMANDS)
def test_comment_commands_never_reach_the_deck(form, tmp_path):
    text = "t\n" + form.format(marker=tmp_path / "m") + "\n" + RC + ".end\n"
    lines = _deck_lines(translate_netlist(text).text)
    assert all("#" not in line and "*" not in line for line in lines), lines


def test_every_deck_line_is_a_title_element_or_circuit_command(tmp_path):
    (tmp_path / "lib.inc").write_text("*# shell touch x\n.control\nshell touch y\n.endc\n"
                                      "R9 out 0 1meg\n.lib sect\nR8 out 0 1meg\n.endl\n.title *ng_script\n")
    top = tmp_path / "top.cir"
    top.write_text("*ng_script\n.include lib.inc\n* plain comment\nR7 out 0\n*# shell touch z\n+ 1meg\n"
                   + RC + ".print tran v(out)\n.end\n")
    lines = _deck_lines(translate_netlist(top).text)
    assert lines[0] == "circuitnsds compare: *ng_script"
    for line in lines[1:]:
        keyword = line.split()[0].lower()
        assert keyword in CIRCUIT_COMMANDS | {".save", ".end"} or keyword[0].isalpha(), line
    assert "R7 out 0 1meg" in lines  # a continuation across a comment line is one statement
    assert not any("shell" in line or "include" in line or "title" in line for line in lines)


def test_title_line_breaks_cannot_start_a_new_line():
    translation = translate_netlist("t\r" + RC + ".end\n")  # \r alone ends the title line
    assert translation.text.splitlines()[0] == "circuitnsds compare: t"


# --- ngspice runs the translated deck ----------------------------------------------------------


@pytest.mark.ngspice
@pytest.mark.parametrize("form", COMMENT_COMMANDS)
def test_comment_command_in_the_netlist_does_not_run(form, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    marker = tmp_path / "marker"
    netlist = tmp_path / "rc.cir"
    netlist.write_text("rc\n" + form.format(marker=marker) + "\n" + RC + ".end\n")
    _assert_clean_run(_compare(netlist), marker)


@pytest.mark.ngspice
@pytest.mark.parametrize("include", [".include models.inc", ".inc 'models.inc'", ".lib models.inc"])
def test_comment_command_in_an_included_file_does_not_run(include, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    marker = tmp_path / "marker"
    (tmp_path / "models.inc").write_text(f"*# shell touch {marker}\nR9 out 0 1meg\n")
    netlist = tmp_path / "rc.cir"
    netlist.write_text(f"rc\n{include}\n" + RC + ".end\n")
    _assert_clean_run(_compare(netlist), marker)


@pytest.mark.ngspice
def test_comment_command_in_a_library_section_does_not_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    marker = tmp_path / "marker"
    (tmp_path / "parts.lib").write_text(f".lib load\n*#shell touch {marker}\nR9 out 0 1meg\n.endl\n"
                                        f".lib other\n*# shell touch {marker}2\n.endl\n")
    netlist = tmp_path / "rc.cir"
    netlist.write_text("rc\n.lib parts.lib load\n" + RC + ".end\n")
    _assert_clean_run(_compare(netlist), marker)
    assert not Path(f"{marker}2").exists()


@pytest.mark.ngspice
def test_control_block_in_an_included_file_does_not_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    marker = tmp_path / "marker"
    (tmp_path / "models.inc").write_text(f"R9 out 0 1meg\n.CONTROL\nshell touch {marker}\n"
                                         f"wrdata {marker}2 v(in)\n.endc\n")
    netlist = tmp_path / "rc.cir"
    netlist.write_text("rc\n.include models.inc\n.control\nrun\n.endc\n" + RC + ".end\n")
    _assert_clean_run(_compare(netlist), marker)
    assert not Path(f"{marker}2").exists()


@pytest.mark.ngspice
@pytest.mark.parametrize("title", SCRIPT_TITLES)
def test_script_title_does_not_make_the_deck_a_script(title, tmp_path, monkeypatch):
    # `shell touch MARK g 0 swmod` is a switch to circuitnsds, a shell command in a script
    monkeypatch.chdir(tmp_path)
    netlist = tmp_path / "sw.cir"
    netlist.write_text(f"{title}\nV1 in 0 SIN(0 1 1k)\nVg g 0 PULSE(0 2 0 1u 1u 0.5m 1m)\n"
                       "shell touch MARK g 0 swmod\nR1 in touch 1k\nR2 MARK 0 1k\nR3 in out 1k\n"
                       "C1 out 0 1u\n.model swmod SW(VT=1 RON=1 ROFF=1e6)\n.tran 10u 2m\n.end\n")
    _assert_clean_run(_compare(netlist), tmp_path / "MARK")


@pytest.mark.ngspice
def test_project_spiceinit_does_not_run(tmp_path):
    # a fresh process: ngspice reads .spiceinit when it starts, once per process
    marker = tmp_path / "marker"
    (tmp_path / ".spiceinit").write_text(f"* a downloaded project's init\nshell touch {marker}\n")
    (tmp_path / "rc.cir").write_text("rc\n" + RC + ".end\n")
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    result = subprocess.run([sys.executable, "-m", "circuitnsds", "compare", "rc.cir", "--signals", "v(out)"],
                            cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "v(out)" in result.stdout
    assert not marker.exists(), "ngspice ran the .spiceinit of the current folder"


def test_circuit_commands_and_elements_are_kept_in_order():
    text = ("t\n.param C=470u\n.func f(x) {2*x}\n.global vdd\nR1 in out {f(1k)}\nC1 out 0 {C}\n"
            ".ic v(out)=1\n.options gmin=1e-12\n.subckt s a b\nR2 a b 1\n.ends\n" + RC + ".end\n")
    lines = _deck_lines(translate_netlist(text).text)
    assert lines[1:11] == [".param C=470u", ".func f(x) {2*x}", ".global vdd", "R1 in out {f(1k)}",
                           "C1 out 0 {C}", ".ic v(out)=1", ".options gmin=1e-12", ".subckt s a b",
                           "R2 a b 1", ".ends"]


def test_options_and_saves_cannot_open_a_control_block():
    options = "method=gear\n.control\nshell touch x\n.endc"
    translation = translate_netlist("t\n" + RC + ".end\n", options=options, saves=["@r1[i]\n.control"])
    lines = _deck_lines(translation.text)
    assert not any(line.split()[0].lower() in {".control", "shell", ".endc"} for line in lines), lines


FRAGMENTS = ["*# shell touch x", "*#SHELL touch x", "*#\twrite x v(in)", "  *# echo hi > x", ".control",
             ".CONTROL", ".endc", "shell touch x", "*ng_script", ".title *ng_script", "R9 in out 1k",
             "+ 2k", "* comment", ".print tran v(out)", "C9 out 0 1n", "  .Control", ".exec", ""]


@settings(max_examples=300, deadline=None)
@given(st.lists(st.sampled_from(FRAGMENTS), max_size=12), st.sampled_from(["t", "*ng_script", " *NG_SCRIPT"]))
def test_no_arrangement_of_script_lines_reaches_the_deck(lines, title):
    text = "\n".join([title, *lines, RC, ".end"]) + "\n"
    try:
        deck = _deck_lines(translate_netlist(text).text)
    except NetlistError:  # e.g. a .control without .endc: refused, nothing runs
        return
    assert deck[0].startswith("circuitnsds compare: ")  # never a script title
    for line in deck[1:]:  # an element (`shell touch x` is a switch in a circuit deck) or a circuit command
        keyword = line.split()[0].lower()
        assert keyword in CIRCUIT_COMMANDS | {".save", ".end"} or keyword[0].isalpha(), line
