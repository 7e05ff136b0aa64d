"""The element-letter tables: one letter -> its nodes (foundation, read by subcircuit
flattening) and its card reader (frontend); a letter in one is in the other."""

import inspect
import warnings
from dataclasses import fields

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds import read_netlist
from circuitnsds.element_letters import ELEMENT_LETTERS, SUPPORTED_LETTERS, mosfet_node_indexes
from circuitnsds.errors import NetlistError
from circuitnsds.frontend.cards.by_letter import CARD_READERS, CardContext

HANDLED_BY_THE_ELABORATOR = {"k", "x"}  # couplings are read last; instances are expanded before


def test_every_supported_letter_has_a_reader_and_every_reader_a_supported_letter():
    supported = {letter for letter, kind in ELEMENT_LETTERS.items() if kind.supported}
    assert set(CARD_READERS) == supported - HANDLED_BY_THE_ELABORATOR
    for letter in supported:
        assert letter.upper() in SUPPORTED_LETTERS


@pytest.mark.parametrize("letter", sorted(CARD_READERS))
def test_each_reader_takes_the_line_and_the_context_fields_it_names(letter):
    card = CARD_READERS[letter]
    parameters = list(inspect.signature(card.load()).parameters)
    assert parameters[0] == "reader"
    assert set(card.arguments) <= {"letter"} | {f.name for f in fields(CardContext)}
    assert parameters[1:] == list(card.arguments)  # the reader's own names, in its order


@pytest.mark.parametrize(("tokens", "nodes"), [
    (("m1", "d", "g", "s", "nch"), (1, 2, 3)), (("m1", "d", "g", "s", "b", "nch"), (1, 2, 3, 4)),
    (("m1", "d", "g", "s", "nch", "off"), (1, 2, 3)),
    (("m1", "d", "g", "s", "nch", "w", "=", "1"), (1, 2, 3)),
    (("m1", "d", "g", "s", "b", "nch", "l", "=", "1"), (1, 2, 3, 4)),
    (("m1", "d", "off", "g", "s", "nch"), (1, 3, 4)),
])
def test_mosfet_nodes_are_the_words_before_the_parameters(tokens, nodes):
    assert mosfet_node_indexes(tokens) == nodes


def test_nodes_inside_a_subcircuit_are_renamed_by_the_table():
    circuit = read_netlist("t\n.subckt cell a b\nm1 a g b b nch\nvg g b 5\nw1 a x vg sw\nrx x b 1\n"
                           ".model nch nmos(vto=1 kp=1)\n.model sw csw(it=1)\n.ends\n"
                           "v1 in 0 10\nx1 in 0 cell\n.end\n")
    assert circuit.element("x1.m1").nodes[:2] == ("in", "0")
    assert circuit.element("x1.w1").control == "x1.vg"
    assert circuit.element("x1.w1").nodes == ("in", "x1.x")


@pytest.mark.parametrize(("line", "message"), [
    ("t1 a 0 b 0 z0=50 td=1n", r"t1: transmission lines \('T' lines\) are not supported"),
    ("%1 a 0 1", "unknown element type '%'"),
])
def test_a_letter_without_a_reader_is_refused_by_name(line, message):
    with pytest.raises(NetlistError, match=message):
        read_netlist(f"t\nv1 a 0 1\n{line}\n.end\n")


@settings(max_examples=30, deadline=None)
@given(bulk=st.booleans(), off_at=st.one_of(st.none(), st.integers(0, 4)),
       parameters=st.sampled_from(["", " w=10u", " w = 10u l=1u", " m=2"]))
def test_an_m_line_inside_a_subcircuit_renames_its_nodes_and_not_its_model(bulk, off_at, parameters):
    """However an M line is written (3 or 4 nodes, ``off`` among its words, parameters or not),
    flattening renames exactly its nodes: the global model keeps its name (renamed as a node
    it would not be found) and every terminal becomes the instance's own."""
    words = ["nd", "ng", "ns", *(["nb"] if bulk else []), "nch"]
    if off_at is not None:
        words.insert(min(off_at, len(words)), "off")
    netlist = (f"t\n.model nch nmos(vto=1 kp=1)\n.subckt cell p\nm1 {' '.join(words)}{parameters}\n"
               "rd p nd 1\nvg ng ns 5\nrs ns 0 1\n" + ("rb nb 0 1\n" if bulk else "") +
               ".ends\nv1 in 0 10\nx1 in cell\n.end\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = read_netlist(netlist)
    mosfet = circuit.element("x1.m1")
    assert set(mosfet.nodes) == {"x1.nd", "x1.ng", "x1.ns"}
    assert mosfet.model.name == "nch"
