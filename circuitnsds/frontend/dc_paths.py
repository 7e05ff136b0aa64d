"""Nodes without a DC path to ground get SPICE's GMIN, as ngspice gives them, with a warning.

A node joined to ground only through capacitors (a capacitively coupled stage), or a group of
nodes joined to the rest only through coupled inductors (a transformer's floating secondary),
has no DC operating point of its own: the potential of the group is undetermined. ngspice
resolves it with GMIN (1e-12 S by default, ``.options gmin``) to ground, and its users write
such netlists without thinking about it. The reader does the same, never silently: each such
group gets a :class:`~circuitnsds.circuit.elements.passive.GminLeak` of ``gmin`` siemens from
each of its nodes to ground (as ngspice's GMIN stepping adds to every node, so that a floating
secondary swings symmetrically about ground, as in ngspice), and a warning names the nodes
and the elements (file:line) that isolate them.

How a group is found: elements join their first two nodes, except current sources and
couplings (never a path), and capacitors at the operating point (open there). A node held by
``.ic`` counts as joined to ground at the operating point (the operating point holds it, as
ngspice's ``.ic`` does). Under ``.tran ... UIC`` there is no operating point, so only groups
isolated in the time steps themselves (the floating secondary) need GMIN.

When GMIN would decide the answer rather than resolve an indeterminacy, nothing is added, and
the circuit checks refuse it as before: a current source (or a controlled one) that crosses
into the group injects a current that only GMIN could carry, setting the group at
``I / gmin`` volts (1 mA: a gigavolt), which is no one's operating point. An independent current
source that is 0 at ``t = 0`` injects nothing there, so it does not count. Nor does a group that
no element joins to the rest at all (an island, most often a misspelt node): nothing ties it to
the circuit, and ngspice's own answer for it depends on its operating-point search (an island
``V1 a b 1`` with ``R1 a b 1`` came out at 2 V and 1 V, not ±0.5 V).
"""

from __future__ import annotations

import warnings

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import Element
from circuitnsds.circuit.elements.diode import DEFAULT_OFF_RESISTANCE
from circuitnsds.circuit.elements.passive import GminLeak
from circuitnsds.errors import NetlistWarning
from circuitnsds.frontend.cards.reader import warn_at
from circuitnsds.graphs import connected_components

GROUND = "0"


def add_gmin_paths(circuit: Circuit) -> None:
    """Give every group of ``circuit``'s nodes without a DC path to ground a GMIN conductance
    from each of its nodes to ground, with a warning (see the module docstring); leave alone a
    group that a current source feeds (the circuit checks then refuse it)."""
    tran = circuit.analyses.get("tran")
    uic = bool(tran is not None and getattr(tran, "uic", False))
    never = {"current", "coupling"}
    open_kinds = never if uic else never | {"capacitor"}
    edges = [element.nodes[:2] for element in circuit.elements
             if element.topology not in open_kinds and len(element.nodes) >= 2]
    if not uic:
        edges += [(GROUND, node) for node in circuit.initial_voltages]
    gmin = float(circuit.options.get("gmin", 1.0 / DEFAULT_OFF_RESISTANCE))
    for group in connected_components([GROUND, *circuit.nodes], edges):
        if GROUND in group:
            continue
        crossing = [e for e in circuit.elements if len(e.nodes) >= 2
                    and (e.nodes[0] in group) != (e.nodes[1] in group)]
        isolating = _isolating(circuit, group, crossing)
        if not isolating or any(_injects(element) for element in crossing):
            continue
        nodes = [node for node in circuit.nodes if node in group]
        for node in nodes:
            circuit.add(GminLeak(name=f"gmin({node})", nodes=(node, GROUND), conductance=gmin))
        _warn(circuit, nodes, isolating, gmin, uic)


def _injects(element: Element) -> bool:
    """Whether ``element`` is a current source whose current into a group could be nonzero at
    the operating point (an independent one: its value at ``t = 0``; a controlled one: always,
    since that depends on the solution)."""
    if element.topology != "current":
        return False
    function = getattr(element, "function", None)
    if not element.independent_source or function is None:
        return True
    return function.resolve(1.0, 1.0).value(0.0) != 0.0


def _isolating(circuit: Circuit, group: set[str], crossing: list[Element]) -> list[Element]:
    """The elements that cut ``group`` off: those crossing its boundary, and the couplings of
    its inductors (a transformer's secondary is cut off by its ``K``)."""
    inductors = {e.name for e in circuit.elements
                 if e.topology == "inductor" and set(e.nodes[:2]) <= group}
    couplings = [e for e in circuit.elements if e.topology == "coupling"
                 and inductors & set(getattr(e, "inductors", ()))]
    return crossing + couplings


def _warn(circuit: Circuit, nodes: list[str], isolating: list[Element], gmin: float,
          uic: bool) -> None:
    located = [e for e in isolating if e.location is not None]
    names = ", ".join(e.describe() for e in isolating[:6]) + (", ..." if len(isolating) > 6 else "")
    why = ("connected to the rest only through " + names) if names else "not connected to ground"
    what = "no path to ground in the time steps" if uic else "no DC path to ground"
    message = (f"node(s) {', '.join(nodes)} have {what} ({why}): added gmin = {gmin:.3g} S from "
               f"each to ground, as ngspice's GMIN (.options gmin sets it); write a resistor to "
               "ground to choose the path yourself")
    where = located[0].location if located else None
    if where is not None:
        warn_at(where, message)
    else:
        warnings.warn(f"{circuit.file}: {message}", NetlistWarning, stacklevel=2)
