"""``~/`` in an include path means the home folder ($HOME) for circuitnsds's reader and for
the deck ``compare`` gives ngspice, as ngspice 39 reads it (``ngspice -b`` with
``.include ~/m.lib`` reads $HOME/m.lib and does not fall back to ./~/m.lib)."""

from pathlib import Path

import pytest

import circuitnsds
from circuitnsds.compare import translate_netlist
from circuitnsds.errors import NetlistError


@pytest.fixture
def home_and_decoy(tmp_path, monkeypatch):
    """$HOME/m.lib holds R2 = 1k; ./~/m.lib (a folder literally named ~) holds R2 = 3k."""
    home, work = tmp_path / "home", tmp_path / "work"
    (work / "~").mkdir(parents=True)
    home.mkdir()
    (home / "m.lib").write_text("R2 a 0 1k\n")
    (work / "~" / "m.lib").write_text("R2 a 0 3k\n")
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.chdir(work)
    netlist = work / "t.cir"
    netlist.write_text("tilde\nV1 a 0 1\n.include ~/m.lib\n.tran 1u 10u\n.end\n")
    return netlist


def test_reader_takes_tilde_as_the_home_folder(home_and_decoy):
    waves = circuitnsds.read_netlist(home_and_decoy).transient()
    assert waves["i(v1)"][-1] == pytest.approx(-1e-3)  # 1 V over $HOME's 1k, not ./~'s 3k


def test_compare_deck_holds_the_same_file(home_and_decoy):
    text = translate_netlist(home_and_decoy).text
    assert "R2 a 0 1k" in text and "3k" not in text


def test_literal_tilde_folder_is_written_with_dot_slash(home_and_decoy):
    home_and_decoy.write_text("tilde\nV1 a 0 1\n.include ./~/m.lib\n.tran 1u 10u\n.end\n")
    assert "R2 a 0 3k" in translate_netlist(home_and_decoy).text


def test_missing_home_file_names_the_home_path(home_and_decoy):
    (Path.home() / "m.lib").unlink()
    with pytest.raises(NetlistError, match="home"):
        circuitnsds.read_netlist(home_and_decoy)
