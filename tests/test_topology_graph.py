"""The checks' graph helpers (a union-find and a spanning forest, no graph library) against
networkx on random multigraphs (hypothesis), and the loops they report obey Kirchhoff's
voltage law."""

import networkx as nx
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.checks.topology import LoopFinder
from circuitnsds.graphs import connected_components

NODES = st.sampled_from(["0", "a", "b", "c", "d", "e", "f", "g"])
EDGES = st.lists(st.tuples(NODES, NODES), max_size=14)


@settings(max_examples=200, deadline=None)
@given(nodes=st.lists(NODES, max_size=5, unique=True), edges=EDGES)
def test_components_as_networkx(nodes, edges):
    graph = nx.MultiGraph()
    graph.add_nodes_from(nodes)
    graph.add_edges_from(edges)
    expected = [set(group) for group in nx.connected_components(graph)]
    assert connected_components(nodes, edges) == expected  # same sets, same order


class _Branch:
    def __init__(self, name, a, b):
        self.name, self.nodes = name, (a, b)


@settings(max_examples=200, deadline=None)
@given(edges=EDGES, potentials=st.lists(st.integers(-50, 50), min_size=8, max_size=8))
def test_loops_close_and_obey_kvl(edges, potentials):
    """Each element that closes a loop in the forest (networkx: its nodes already joined)
    gets a loop whose signed branch voltages sum to zero for any node potentials."""
    v = dict(zip(["0", "a", "b", "c", "d", "e", "f", "g"], potentials))
    finder, forest = LoopFinder(), nx.Graph()
    for index, (a, b) in enumerate(edges):
        branch = _Branch(f"x{index}", a, b)
        closes = a == b or (forest.has_node(a) and forest.has_node(b) and nx.has_path(forest, a, b))
        loop = finder.add(branch)
        assert (loop is not None) == closes
        if loop is None:
            forest.add_edge(a, b)
            continue
        assert loop[0] == (branch, 1.0)
        # the path runs from the new branch's second node b back to its first a: its signed
        # voltages sum to v(b) - v(a), cancelling the new branch's v(a) - v(b)
        total = sum(sign * (v[e.nodes[0]] - v[e.nodes[1]]) for e, sign in loop[1:])
        assert total == v[b] - v[a]
