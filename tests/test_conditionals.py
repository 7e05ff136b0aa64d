"""ngspice's conditional netlist (.if/.elseif/.else/.endif), issue 32: the branch chosen by the
.param values above it (ngspice's regression test if-elseif.cir), errors naming the line."""

import warnings

import pytest
from hypothesis import given
from hypothesis import strategies as st

import circuitnsds
from circuitnsds.errors import NetlistError

NESTED = """multiple .elseif, nested .if
.param select = {select}
.param select2 = {select2}
V1 1 0 1
.if (select == 1)
    R1 1 0 1
.elseif (select == 2)
    R1 1 0 10
.elseif (select == 3)
    .if (select2 == 1)
        R1 1 0 100
    .elseif (select2 = 2)
        R1 1 0 200
    .elseif (select2 = 3) $ <----- selected
        R1 1 0 300
    .else
        R1 1 0 400
    .endif
.elseif (select == 4)
    R1 1 0 1000
.else
    R1 1 0 10000
.endif
.tran 1u 10u
.end
"""


def resistance(text, **params):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return circuitnsds.read_netlist(text, params=params or None).element("r1").resistance


def expected(select, select2):
    if select == 3:
        return {1: 100, 2: 200, 3: 300}.get(select2, 400)
    return {1: 1, 2: 10, 4: 1000}.get(select, 10000)


def test_ngspices_nested_elseif_regression_chooses_300_ohm():
    # ngspice's tests/regression/misc/if-elseif.cir checks 1/i(v1) = 300; before: ".if is not supported"
    assert resistance(NESTED.format(select=3, select2=3)) == 300


@given(select=st.integers(0, 5), select2=st.integers(0, 4))
def test_every_branch_is_the_one_its_conditions_choose(select, select2):
    assert resistance(NESTED.format(select=select, select2=select2)) == expected(select, select2)


def test_parameters_given_to_the_reader_choose_the_branch():
    assert resistance(NESTED.format(select=1, select2=1), select=3, select2=2) == 200


@pytest.mark.parametrize(("lines", "pattern"), [
    (".if (1)\nR1 1 0 1", r"<text>:3: \.if is never closed by \.endif"),
    ("R1 1 0 1\n.endif", r"<text>:4: \.endif without an \.if above it"),
    (".if (nosuch > 1)\nR1 1 0 1\n.endif", r"<text>:3: \.if: undefined parameter 'nosuch'"),
    # a second .else or an .elseif after .else was dropped silently (the first .else's lines ran)
    (".if (0)\nR1 1 0 1\n.else\nR1 1 0 2\n.else\nR1 1 0 3\n.endif",
     r"<text>:7: \.else after the \.else of its block \(line 5\)"),
    (".if (0)\nR1 1 0 1\n.else\nR1 1 0 2\n.elseif (1)\nR1 1 0 3\n.endif",
     r"<text>:7: \.elseif after the \.else of its block"),
])
def test_malformed_blocks_are_refused_at_their_line(lines, pattern):
    with pytest.raises(NetlistError, match=pattern):
        circuitnsds.read_netlist(f"t\nV1 1 0 1\n{lines}\n.tran 1u 10u\n.end\n")


@pytest.mark.ngspice
def test_the_branch_is_the_one_ngspice_runs():
    from circuitnsds.compare.ngspice import run_ngspice

    for select, select2 in ((3, 3), (3, 9), (4, 1), (7, 1)):
        text = NESTED.format(select=select, select2=select2)
        theirs = run_ngspice(text, ["i(v1)"], 10e-6)
        assert theirs.status == "ok", theirs.message
        current = float(theirs.waveforms["i(v1)"][-1])
        assert -1 / current == pytest.approx(resistance(text), rel=1e-9)
