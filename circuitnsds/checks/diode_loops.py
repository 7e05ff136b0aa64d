"""Loops of ideal diodes around which any current may circulate.

Diodes with neither a forward drop nor an on-resistance that form a directed cycle (each
one's cathode the next one's anode: two anti-parallel diodes, a ring) can all sit at 0 V
together; Kirchhoff's voltage law then holds for every current ``c >= 0`` going round, and the
complementarity conditions too, so the circuit's solution is not unique. The solver returns
one of them (usually ``c = 0``). A forward drop (``Vfwd > 0``: the loop's drops would have to
sum to 0) or a resistance (``Ron > 0``: ``c·ΣRon = 0``) in the loop makes it unique.
"""

from __future__ import annotations

from collections.abc import Iterable

from circuitnsds.circuit.elements import Diode

MOST_LOOPS = 3
"""At most this many loops are returned."""


def free_diode_loops(elements: Iterable) -> list[list[str]]:
    """Directed cycles of diodes with ``Vfwd = 0`` and ``Ron = 0`` (names, in the order the
    current goes round), at most :data:`MOST_LOOPS`, each diode in at most one of them."""
    edges: dict[str, list[tuple[str, str]]] = {}  # anode -> [(cathode, diode name)]
    for element in elements:
        if (isinstance(element, Diode) and element.model.forward_drop == 0.0
                and element.model.on_resistance == 0.0 and element.nodes[0] != element.nodes[1]):
            edges.setdefault(element.nodes[0], []).append((element.nodes[1], element.name))
    loops: list[list[str]] = []
    used: set[str] = set()
    for start in sorted(edges):
        if len(loops) >= MOST_LOOPS:
            break
        loop = _cycle_from(start, edges, used)
        if loop:
            loops.append(loop)
            used.update(loop)
    return loops


def _cycle_from(start: str, edges: dict[str, list[tuple[str, str]]], used: set[str]) -> list[str]:
    """The diodes of a directed cycle through node ``start`` (depth first, iterative), avoiding
    the diodes in ``used``; ``[]`` when there is none."""
    path: list[str] = []  # diode names along the current path
    nodes = [start]
    iterators = [iter(edges.get(start, ()))]
    on_path = {start}
    visited: set[str] = set()
    while iterators:
        step = next(iterators[-1], None)
        if step is None:
            iterators.pop()
            done = nodes.pop()  # every way on from it explored: no cycle back to start
            visited.add(done)
            on_path.discard(done)
            if path:
                path.pop()
            continue
        node, name = step
        if name in used:
            continue
        if node == start:
            return path + [name]
        if node in on_path or node in visited:
            continue
        path.append(name)
        nodes.append(node)
        on_path.add(node)
        iterators.append(iter(edges.get(node, ())))
    return []


def warn_free_diode_loops(circuit) -> None:
    """A :class:`CircuitWarning` (an error under ``--strict``) for each loop of
    :func:`free_diode_loops`, naming its diodes and nodes."""
    import warnings

    from circuitnsds.errors import CircuitWarning

    diodes = {element.name: element for element in circuit.elements if isinstance(element, Diode)}
    for loop in free_diode_loops(circuit.elements):
        nodes = " → ".join([diodes[name].nodes[0] for name in loop] + [diodes[loop[0]].nodes[0]])
        warnings.warn(CircuitWarning(
            f"{circuit.file}: {', '.join(loop)} form a loop of ideal diodes ({nodes}) with no "
            "forward drop and no resistance: any current may circulate round it, so the solution "
            "is not unique and the one shown (usually none circulating) is one choice among "
            "many; give the diode model a forward drop or Ron > 0 (as a real diode has) to make "
            "it unique"), stacklevel=3)
