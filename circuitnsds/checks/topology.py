"""Checks of the circuit graph that say, in words, why a circuit has no unique solution.

* a group of nodes with no element path to ground (their potential is undefined);
* a loop made only of voltage sources (their currents are undefined); at the
  operating point inductors are shorts and count as voltage sources, and a 0 H
  inductor always does;
* a cutset made only of current sources (Kirchhoff's current law cannot hold);
  at the operating point capacitors are open and count with the current sources.

Functions take the element list and return nothing; they raise
:class:`~circuitnsds.errors.CircuitError` naming nodes and elements.
"""

from __future__ import annotations

from collections.abc import Sequence

import networkx as nx

from circuitnsds.circuit.elements import Element
from circuitnsds.errors import CircuitError

GROUND = "0"


def is_short(element: Element) -> bool:
    """An inductor of 0 H: its branch equation is ``0 = v+ - v-``, a 0 V voltage source."""
    return element.topology == "inductor" and getattr(element, "inductance", 1.0) == 0.0


def _unreachable(elements: Sequence[Element], nodes: Sequence[str],
                 ignored: set[str] = frozenset()) -> list[str]:
    """Nodes with no path to ground through elements whose ``topology`` is not ``ignored``."""
    graph = nx.MultiGraph()
    graph.add_nodes_from([GROUND, *nodes])
    for element in elements:
        if element.topology not in ignored and len(element.nodes) >= 2:
            graph.add_edge(*element.nodes[:2])
    reachable = nx.node_connected_component(graph, GROUND)
    return sorted(n for n in nodes if n not in reachable)


def check_connected(elements: Sequence[Element], nodes: Sequence[str]) -> None:
    """Every node must reach ground through some chain of elements."""
    floating = _unreachable(elements, nodes)
    if floating:
        raise CircuitError(
            f"node(s) {', '.join(floating)} have no path to ground (node 0) through any element: "
            "their voltages are undefined",
            where="circuit",
            hint="connect that part of the circuit to node 0 (SPICE requires the same)",
        )


def check_source_loops(elements: Sequence[Element], operating_point: bool = False) -> None:
    """No loop of voltage sources (and, at the operating point, inductors)."""
    kinds = {"voltage", "inductor"} if operating_point else {"voltage"}
    graph = nx.Graph()
    for element in elements:
        if element.topology not in kinds and not is_short(element):
            continue
        a, b = element.nodes[:2]
        if a == b:
            loop = [element]
        elif graph.has_node(a) and graph.has_node(b) and nx.has_path(graph, a, b):
            path = nx.shortest_path(graph, a, b)
            loop = [graph.edges[u, v]["element"] for u, v in zip(path, path[1:])] + [element]
        else:
            graph.add_edge(a, b, element=element)
            continue
        names = ", ".join(e.describe() for e in loop)
        what = "voltage sources and inductors" if operating_point else "voltage sources"
        raise CircuitError(
            f"{names} form a loop of {what} only: the currents in the loop are undefined"
            + (" at the DC operating point (inductors are shorts there)" if operating_point else ""),
            where=loop[-1].name,
            hint="add a series resistance in the loop"
            + (" or start the transient with UIC" if operating_point else ""),
        )


def check_current_cutsets(elements: Sequence[Element], nodes: Sequence[str],
                          operating_point: bool = False) -> None:
    """Every node must reach ground through elements that are not current sources.

    At the operating point capacitors are open and do not count as a path.
    """
    cut = _unreachable(elements, nodes,
                       {"current", "capacitor"} if operating_point else {"current"})
    if not cut:
        return
    if operating_point:
        raise CircuitError(
            f"node(s) {', '.join(cut)} have no DC path to ground (only capacitors or current "
            "sources connect them), so the operating point is undefined",
            where="circuit",
            hint="add a large resistor from that node to ground, or add UIC to .tran "
            "to start from given initial conditions",
        )
    raise CircuitError(
        f"node(s) {', '.join(cut)} connect to the rest of the circuit only through current "
        "sources: Kirchhoff's current law cannot hold there",
        where="circuit",
        hint="add a resistor from that node to ground",
    )
