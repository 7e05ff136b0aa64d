"""Node names written in two cases are one node, and a warning says so.

Found on a public KiCad export (``netlists/external/kicad_pe/buckclose/buckclose.net``,
SOURCES.md): its controller's output net ``/c`` and the converter's output ``/C`` are one node in
SPICE, so the PID's limiter holds the output capacitor and 9.5 kA circulate through the switch;
ngspice runs it the same way without a word."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.errors import NetlistWarning
from tests.conftest import NETLISTS, circuit_from


def _spelling_warnings(body: str) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        circuit_from(body)
    return [str(w.message) for w in caught if "written in" in str(w.message)]


def test_two_spellings_of_a_node_are_named_with_their_lines():
    found = _spelling_warnings("V1 OUT 0 1\nR1 out 0 1k\nR2 Out 0 2k")
    assert len(found) == 1
    assert "node 'out' is written in 3 ways" in found[0]
    assert "'OUT' at <text>:2" in found[0] and "'out' at <text>:3" in found[0]
    assert "'Out' at <text>:4" in found[0]


def test_one_spelling_and_subcircuit_names_are_not_warned():
    assert _spelling_warnings("V1 OUT 0 1\nR1 OUT 0 1k") == []
    # a subcircuit's own nodes are its own: 'A' inside and 'a' outside are not the same net
    assert _spelling_warnings(".subckt cell p\nR1 p A 1k\nR2 A 0 1k\n.ends\nV1 a 0 1\n"
                              "X1 a cell\nR3 a 0 1k") == []


def test_an_x_line_s_nodes_are_seen_and_its_parameters_are_not():
    found = _spelling_warnings(".subckt cell p q k=1\nR1 p q {k}\n.ends\nV1 Vin 0 1\n"
                               "X1 vin 0 cell k=2\nR2 vin 0 1k")
    assert len(found) == 1 and "'Vin' at <text>:5" in found[0] and "'vin' at <text>:6" in found[0]


def test_the_public_kicad_buck_warns_of_its_joined_nets():
    with pytest.warns(NetlistWarning, match=r"node '/c' is written in 2 ways \('/C' at \S*"
                      r"buckclose.net:7, '/c' at \S*buckclose.net:14\)"):
        import circuitnsds

        circuitnsds.read_netlist(NETLISTS / "external/kicad_pe/buckclose/buckclose.net")


@pytest.mark.ngspice
def test_ngspice_reads_two_spellings_as_one_node():
    from circuitnsds.compare import run_ngspice

    body = "V1 OUT 0 pulse(0 2 0 1u 1u 5u 10u)\nR1 out 0 1k\n.tran 0.1u 10u"
    theirs = run_ngspice(f"t\n{body}\n.end\n", ["i(v1)"], 10e-6)
    assert theirs.ok, theirs.message
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours = circuit_from(body).transient()
    resampled = np.interp(ours.time, theirs.waveforms.time, theirs.waveforms["i(v1)"])
    # one node: the source drives the resistor (-2 mA at the top), in both
    assert np.max(np.abs(ours["i(v1)"] - resampled)) < 1e-9
    assert ours["i(v1)"].min() == pytest.approx(-2e-3, rel=1e-9)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(["n", "N"]), min_size=2, max_size=4).flatmap(
    lambda first: st.tuples(st.just(first), st.lists(st.sampled_from(["x", "X"]), min_size=2,
                                                     max_size=4))))
def test_a_warning_exactly_when_a_node_has_two_spellings(names):
    lines, ground = [], ["V1 a 0 1"]
    for k, (first, second) in enumerate(zip(names[0], names[1])):
        lines.append(f"R{k} a {first}{second} 1k\nRg{k} {first}{second} 0 1k")
    found = _spelling_warnings("\n".join(ground + lines))
    spellings = {f + s for f, s in zip(names[0], names[1])}
    assert (len(found) == 1) == (len(spellings) > 1)
