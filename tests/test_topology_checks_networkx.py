"""The circuit graph checks (floating nodes, loops of voltage sources, cut-sets of current
sources, the switch loop/cut-set warnings) on random netlists against a reference written
here with networkx, from the element letters (not the elements' ``topology``): what the
checks did before they stopped using networkx (issue 19)."""

import re
import warnings
from dataclasses import replace

import networkx as nx
from hypothesis import given, settings
from hypothesis import strategies as st

import circuitnsds
from circuitnsds.checks import rules, topology
from circuitnsds.circuit.elements.passive import GminLeak
from circuitnsds.errors import CircuitError

NODES = ["0", "a", "b", "c", "d", "e"]
# letter -> what the element is to the graph checks
VOLTAGE, CURRENT = set("VEH") | {"L0"}, set("IGF")
KINDS = ["R", "C", "L", "L0", "V", "I", "E", "G", "F", "H", "D", "S", "S0"]


def _line(kind: str, index: int, a: str, b: str) -> str:
    name = f"{kind[0]}{index}"
    return {
        "R": f"{name} {a} {b} 1k",
        "C": f"{name} {a} {b} 1u",
        "L": f"{name} {a} {b} 1m",
        "L0": f"{name} {a} {b} 0",
        "V": f"{name} {a} {b} DC 1",
        "I": f"{name} {a} {b} DC 1m",
        "E": f"{name} {a} {b} z 0 2",
        "G": f"{name} {a} {b} z 0 1m",
        "F": f"{name} {a} {b} vsense 2",
        "H": f"{name} {a} {b} vsense 10",
        "D": f"{name} {a} {b} dmod",
        "S": f"{name} {a} {b} z 0 smod",
        "S0": f"{name} {a} {b} z 0 szero",
    }[kind]


ELEMENTS = st.lists(st.tuples(st.sampled_from(KINDS), st.sampled_from(NODES), st.sampled_from(NODES)),
                    min_size=1, max_size=9)


def _circuit(elements):
    lines = ["random graph", "vsense z 0 DC 0", "rsense z 0 1k"]
    lines += [_line(kind, index, a, b) for index, (kind, a, b) in enumerate(elements)]
    lines += [".model dmod D", ".model smod SW(RON=1 ROFF=1MEG VT=0.5)",
              ".model szero SW(RON=0 ROFF=1MEG VT=0.5)", ".tran 1u 10u", ".end"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuitnsds.read_netlist("\n".join(lines) + "\n")
    leaks = sorted(e.nodes[0] for e in circuit.elements if isinstance(e, GminLeak))
    # the checks are of the netlist's own elements: the reader's GMIN leaks set apart
    return replace(circuit, elements=[e for e in circuit.elements if not isinstance(e, GminLeak)]), leaks


def _graph(elements, keep):
    """MultiGraph of the elements ``keep(kind)`` selects (the sense branch z joins ground)."""
    graph = nx.MultiGraph()
    graph.add_nodes_from(NODES + ["z"])
    graph.add_edge("z", "0", name="vsense")
    for index, (kind, a, b) in enumerate(elements):
        if keep(kind):
            graph.add_edge(a, b, name=f"{kind[0]}{index}".lower())
    return graph


def _cut_off(elements, keep):
    """Nodes used by an element that ``keep``'s elements do not join to ground."""
    used = {n for _, a, b in elements for n in (a, b)} | {"z"}
    grounded = nx.node_connected_component(_graph(elements, keep), "0")
    return sorted(used - grounded)


def _first_loop(elements, members):
    """Index of the first element whose addition makes ``members``' elements contain a cycle."""
    graph = nx.MultiGraph()
    for index, (kind, a, b) in enumerate(elements):
        if kind not in members:
            continue
        if a == b or (graph.has_node(a) and graph.has_node(b) and nx.has_path(graph, a, b)):
            return index
        graph.add_edge(a, b)
    return None


def _error(check) -> CircuitError | None:
    try:
        check()
    except CircuitError as error:
        return error
    return None


def _listed_nodes(message: str) -> list[str]:
    return re.search(r"node\(s\) (.*?) (?:have|connect)", message).group(1).split(", ")


def _is_cycle(elements, names):
    """The named elements form one simple cycle (or one element shorted on itself)."""
    by_name = {f"{kind[0]}{index}".lower(): (a, b) for index, (kind, a, b) in enumerate(elements)}
    edges = [by_name[name.lower()] for name in names]
    if len(edges) == 1:
        return edges[0][0] == edges[0][1]
    graph = nx.MultiGraph(edges)
    return nx.is_connected(graph) and all(degree == 2 for _, degree in graph.degree())


def _loop_names(error: CircuitError) -> list[str]:
    """The element names of "x1 (where), y2 (where) form a loop ..."."""
    return [part.split()[0] for part in str(error).split(": ", 1)[1].split(" form a loop")[0].split(", ")]


def _check_floating(circuit, elements):
    expected = _cut_off(elements, lambda kind: True)
    error = _error(lambda: topology.check_connected(circuit.elements, circuit.nodes))
    assert (error is not None) == bool(expected)
    if error is not None:
        assert _listed_nodes(str(error)) == expected


def _check_cutsets(circuit, elements, operating_point):
    blocked = CURRENT | ({"C"} if operating_point else set())
    expected = _cut_off(elements, lambda kind: kind not in blocked)
    error = _error(lambda: topology.check_current_cutsets(circuit.elements, circuit.nodes,
                                                          operating_point=operating_point))
    assert (error is not None) == bool(expected)
    if error is not None:
        assert _listed_nodes(str(error)) == expected


def _check_gmin_leaks(leaks, elements):
    """The reader gives GMIN to each node of every group that capacitors and current sources cut
    off from ground (at the operating point), unless a current source (here I, G or F, all of
    them nonzero) crosses into the group or nothing does (an island)."""
    free = _graph(elements, lambda kind: kind not in CURRENT | {"C"})
    used = {n for _, a, b in elements for n in (a, b)}
    free.add_nodes_from(used)
    expected = []
    for group in nx.connected_components(free):
        crossing = [kind for kind, a, b in elements if (a in group) != (b in group)]
        if "0" not in group and crossing and not CURRENT & set(crossing):
            expected += group & used
    assert leaks == sorted(expected)


def _check_loops(circuit, elements, operating_point):
    members = VOLTAGE | ({"L"} if operating_point else set())
    first = _first_loop(elements, members)
    error = _error(lambda: topology.check_source_loops(circuit.elements, operating_point=operating_point))
    assert (error is not None) == (first is not None)
    if error is not None:
        kind = elements[first][0]
        assert error.where.lower() == f"{kind[0]}{first}".lower()
        assert _is_cycle(elements, _loop_names(error))


def _check_switch_warnings(circuit, elements):
    """A RON = 0 switch closing a loop of voltage sources is warned about, once per such switch;
    a group cut off by current sources, inductors and switches (no inductor, at least one
    current source and one switch crossing) is warned about."""
    loops = list(rules._switch_loops(circuit.elements))
    graph = _graph(elements, lambda kind: kind in VOLTAGE)
    expected_loops = 0
    for kind, a, b in elements:
        if kind != "S0" or a == b:
            continue
        if nx.has_path(graph, a, b):
            expected_loops += 1
        else:
            graph.add_edge(a, b)
    assert len(loops) == expected_loops

    cuts = list(rules._switch_cutsets(circuit.elements, circuit.nodes))
    through = CURRENT | {"L", "L0", "S", "S0"}
    free = _graph(elements, lambda kind: kind not in through)
    expected = []
    for group in nx.connected_components(free):
        used = group & ({n for _, a, b in elements for n in (a, b)} | {"z"})
        if "0" in group or not used:
            continue
        crossing = [kind for kind, a, b in elements if (a in group) != (b in group)]
        if (any(k in CURRENT for k in crossing) and any(k in {"S", "S0"} for k in crossing)
                and not {"L", "L0"} & set(crossing)):
            expected.append(sorted(group))
    found = [sorted(re.search(r"node\(s\) (.*?) connect", m).group(1).split(", ")) for m in cuts]
    assert sorted(found) == sorted(expected)


@settings(max_examples=120, deadline=None)
@given(elements=ELEMENTS)
def test_graph_checks_as_networkx(elements):
    circuit, leaks = _circuit(elements)
    _check_gmin_leaks(leaks, elements)
    _check_floating(circuit, elements)
    for operating_point in (False, True):
        _check_cutsets(circuit, elements, operating_point)
        _check_loops(circuit, elements, operating_point)
    _check_switch_warnings(circuit, elements)
