"""Lexical level of netlists: title, comments, continuations, .end, tokens, locations."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.errors import NetlistError
from circuitnsds.netlist import parse_netlist
from circuitnsds.netlist.parser import tokenize


def test_title_comments_continuation_and_end():
    text = """R1 is not an element: this is the title
* a comment
R1 a b 1k ; trailing comment
V1 a 0 SIN(0 1
* comment inside a continuation block

+ 50) $ dollar comment
C1 b 0 1u // slash comment
.end
R9 ignored after end
"""
    netlist = parse_netlist(text, file="x.cir")
    assert netlist.title == "R1 is not an element: this is the title"
    assert netlist.ended
    assert [s.tokens for s in netlist.statements] == [
        ("r1", "a", "b", "1k"),
        ("v1", "a", "0", "sin", "(", "0", "1", "50", ")"),
        ("c1", "b", "0", "1u"),
    ]
    assert [s.location.line for s in netlist.statements] == [3, 4, 8]
    assert str(netlist.statements[1].location) == "x.cir:4"


def test_dollar_needs_whitespace_and_equals_is_a_token():
    assert tokenize("Dz a$b m") == ("dz", "a$b", "m")
    assert tokenize(".model D1 D(Vfwd=0.7, Ron=1m)") == (
        ".model", "d1", "d", "(", "vfwd", "=", "0.7", "ron", "=", "1m", ")")


def test_orphan_continuation_is_an_error_with_location():
    with pytest.raises(NetlistError, match=r"x.cir:2: continuation"):
        parse_netlist("title\n+ 1 2 3\n", file="x.cir")


def test_empty_netlist_is_an_error():
    with pytest.raises(NetlistError, match="empty"):
        parse_netlist("")


names = st.from_regex(r"[a-z][a-z0-9_]{0,6}", fullmatch=True)
tokens = st.lists(st.from_regex(r"[a-z0-9_.]{1,6}", fullmatch=True), min_size=1, max_size=8)


@settings(max_examples=60, deadline=None)
@given(
    statements=st.lists(st.tuples(names, tokens), min_size=1, max_size=6),
    splits=st.lists(st.integers(0, 8), min_size=6, max_size=6),
    upper=st.booleans(),
    comments=st.booleans(),
)
def test_continuations_and_case_do_not_change_statements(statements, splits, upper, comments):
    """However a statement is split over '+' lines, with comments between, it reads the same."""
    lines = ["a title"]
    for (name, words), split in zip(statements, splits):
        words = [name] + words
        cut = min(max(split, 1), len(words))
        first, rest = words[:cut], words[cut:]
        lines.append(" ".join(first))
        if comments:
            lines.append("* a comment line")
        if rest:
            lines.append("+ " + " ".join(rest) + (" ; tail" if comments else ""))
    text = "\n".join(lines)
    if upper:
        text = text.upper()
    netlist = parse_netlist(text)
    expected = [tuple([name] + words) for name, words in statements]
    assert [s.tokens for s in netlist.statements] == expected
