"""Node names written in two cases (``/C`` and ``/c``): one node, said so.

SPICE reads names without case, so ``/C`` and ``/c`` are one node in circuitnsds as in ngspice.
A schematic export (KiCad's) can hold two nets that differ only in case; joined, they make a
different circuit from the one drawn (a controller's output wired onto the output capacitor),
which both simulators then run without a word. This module finds them and warns.
"""

from __future__ import annotations

import warnings

from circuitnsds.element_letters import letter_of
from circuitnsds.errors import NetlistWarning, SourceLocation
from circuitnsds.netlist.parser import Statement


def _node_indexes(statement: Statement) -> tuple[int, ...]:
    """Indexes of the node words of an element line: an ``X`` line's words before its
    parameters, less the subcircuit's name; other letters from their table."""
    if statement.keyword[:1] != "x":
        return letter_of(statement.keyword).node_indexes(statement.tokens)
    words = []
    for index, token in enumerate(statement.tokens[1:], start=1):
        if token in {"params:", "="} or "=" in token or (
                index + 1 < len(statement.tokens) and statement.tokens[index + 1] == "="):
            break
        words.append(index)
    return tuple(words[:-1])


def warn_node_spellings(statements: list[Statement]) -> None:
    """Warn once per node written in more than one case among the netlist's top-level element
    lines (inside a ``.subckt`` the names are the subcircuit's own), naming each spelling and
    where it first appears."""
    spellings: dict[str, dict[str, SourceLocation]] = {}
    depth = 0
    for statement in statements:
        if statement.keyword == ".subckt":
            depth += 1
        elif statement.keyword == ".ends":
            depth = max(depth - 1, 0)
        if depth or statement.is_command:
            continue
        words = statement.text.split()
        for index in _node_indexes(statement):
            if index < len(words) and words[index].lower() == statement.tokens[index]:
                spellings.setdefault(statement.tokens[index], {}).setdefault(
                    words[index], statement.location)
    for node, written in spellings.items():
        if len(written) > 1:
            where = ", ".join(f"{word!r} at {location}" for word, location in written.items())
            warnings.warn(f"{next(iter(written.values()))}: node {node!r} is written in "
                          f"{len(written)} ways ({where}): node names are read without case, as "
                          "ngspice reads them, so these are one node; rename one if two nets "
                          "were meant", NetlistWarning, stacklevel=2)
