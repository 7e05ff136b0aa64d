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

from collections import deque
from collections.abc import Callable, Sequence

from circuitnsds.circuit.elements import Element
from circuitnsds.errors import CircuitError
from circuitnsds.graphs import connected_components

GROUND = "0"


def is_short(element: Element) -> bool:
    """An inductor of 0 H: its branch equation is ``0 = v+ - v-``, a 0 V voltage source."""
    return element.topology == "inductor" and getattr(element, "inductance", 1.0) == 0.0


class LoopFinder:
    """A spanning forest grown one element at a time, telling which element closes a loop.

    ``add(element)`` returns ``None`` when the element joins two parts of the forest (it is
    added), or the loop it closes: ``[(element, +1.0), (e1, s1), ...]`` where ``s`` is +1 when
    the loop, walked from ``element``'s second node back to its first, runs through ``e`` from
    its first node to its second (so ``Σ s·v(e) = 0`` by Kirchhoff's voltage law). An element
    whose two nodes coincide is a loop on its own.
    """

    def __init__(self) -> None:
        self._next: dict[str, list[tuple[str, Element]]] = {}  # node -> (neighbour, element)

    def _path(self, a: str, b: str) -> list[tuple[str, str, Element]] | None:
        """The forest's path from ``a`` to ``b`` as ``(u, v, element)`` edges, or ``None``."""
        if a not in self._next or b not in self._next:
            return None
        came_from: dict[str, tuple[str, Element] | None] = {a: None}
        queue = deque([a])
        while queue and b not in came_from:
            node = queue.popleft()
            for neighbour, element in self._next[node]:
                if neighbour not in came_from:
                    came_from[neighbour] = (node, element)
                    queue.append(neighbour)
        if b not in came_from:
            return None
        path, node = [], b
        while came_from[node] is not None:
            previous, element = came_from[node]
            path.append((previous, node, element))
            node = previous
        return path[::-1]

    def connects(self, a: str, b: str) -> bool:
        """Whether the forest already joins nodes ``a`` and ``b``."""
        return self._path(a, b) is not None

    def add(self, element: Element) -> list[tuple[Element, float]] | None:
        a, b = element.nodes[:2]
        if a == b:
            return [(element, 1.0)]
        path = self._path(b, a)
        if path is None:
            self._next.setdefault(a, []).append((b, element))
            self._next.setdefault(b, []).append((a, element))
            return None
        loop = [(element, 1.0)]
        for u, _, edge in path:
            loop.append((edge, 1.0 if edge.nodes[0] == u else -1.0))
        return loop


def isolated_groups(elements: Sequence[Element], nodes: Sequence[str],
                    ignored: Callable[[Element], bool] = lambda element: False,
                    ) -> list[tuple[set[str], list[Element]]]:
    """Groups of nodes that elements other than the ``ignored`` ones do not join to ground,
    each with the elements that cross from the group to the rest (a cut-set of ignored ones)."""
    edges = [element.nodes[:2] for element in elements
             if not ignored(element) and len(element.nodes) >= 2]
    groups = []
    for group in connected_components([GROUND, *nodes], edges):
        if GROUND in group:
            continue
        crossing = [e for e in elements if len(e.nodes) >= 2
                    and (e.nodes[0] in group) != (e.nodes[1] in group)]
        groups.append((set(group), crossing))
    return groups


def _unreachable(elements: Sequence[Element], nodes: Sequence[str],
                 ignored: set[str] = frozenset()) -> list[str]:
    """Nodes with no path to ground through elements whose ``topology`` is not ``ignored``."""
    groups = isolated_groups(elements, nodes, lambda element: element.topology in ignored)
    return sorted(node for group, _ in groups for node in group)


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
    finder = LoopFinder()
    for element in elements:
        if element.topology not in kinds and not is_short(element):
            continue
        closed = finder.add(element)
        if closed is None:
            continue
        loop = [e for e, _ in reversed(closed)]
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
                          operating_point: bool = False, held: Sequence[str] = ()) -> None:
    """Every node must reach ground through elements that are not current sources.

    At the operating point capacitors are open and do not count as a path, and the nodes
    ``held`` (by ``.ic``: the operating point holds them at their values) count as grounded.
    """
    if operating_point:
        grounded = [_HeldNode(node) for node in held if node != GROUND]
        groups = isolated_groups([*elements, *grounded], nodes,
                                 lambda element: element.topology in {"current", "capacitor"})
        cut = sorted(node for group, _ in groups for node in group)
        if not cut:
            return
        feeding = [e for _, crossing in groups for e in crossing if e.topology == "current"]
        if feeding:
            raise CircuitError(
                f"node(s) {', '.join(cut)} have no DC path to ground and "
                f"{', '.join(e.describe() for e in feeding[:4])} drive(s) a current into them that "
                "only capacitors could carry, so no DC operating point exists (a GMIN to "
                "ground would put them at I/gmin volts)",
                where="circuit",
                hint="add UIC to .tran to start the capacitors from their ic= values (0 V "
                "otherwise), give a node .ic, or add a resistor from the node to ground",
            )
        raise CircuitError(
            f"node(s) {', '.join(cut)} have no DC path to ground (only capacitors or current "
            "sources connect them), so the operating point is undefined",
            where="circuit",
            hint="add a large resistor from that node to ground, or add UIC to .tran "
            "to start from given initial conditions",
        )
    cut = _unreachable(elements, nodes, {"current"})
    if not cut:
        return
    raise CircuitError(
        f"node(s) {', '.join(cut)} connect to the rest of the circuit only through current "
        "sources: Kirchhoff's current law cannot hold there",
        where="circuit",
        hint="add a resistor from that node to ground",
    )


class _HeldNode:
    """A node held by ``.ic`` at the operating point, seen by the graph as an edge to ground."""

    topology = "conductive"

    def __init__(self, node: str) -> None:
        self.nodes = (node, GROUND)
