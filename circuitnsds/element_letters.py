"""What the first letter of an element line says: the kind of element, which words after its
name are nodes, which name another element, and whether circuitnsds reads it.

Plain data at the foundation, so that :mod:`circuitnsds.netlist.subcircuits` (renaming an
instance's nodes and elements) and :mod:`circuitnsds.frontend` (choosing the card reader,
:data:`circuitnsds.frontend.cards.by_letter.CARD_READERS`) read one table. A new device adds
its letter here, its class in :mod:`circuitnsds.circuit.elements` and its reader in
``frontend/cards``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from circuitnsds.values import parse_value


def mosfet_node_indexes(tokens: Sequence[str]) -> tuple[int, ...]:
    """Indexes of the nodes of an ``M`` line (``tokens[0]`` is the name): 3 (``d g s MODEL``) or
    4 (``d g s b MODEL``), the first words before the first ``key=value``, the ``off`` flag
    aside wherever it stands (as the card reader reads the line)."""
    words = _positional(tokens)
    return tuple(words[:4 if len(words) >= 5 else 3])


def _positional(tokens: Sequence[str]) -> list[int]:
    """Indexes of the words of an element line before its first ``key=value``, the ``off``
    flag aside (the name, at 0, excluded)."""
    words = []
    for index in range(1, len(tokens)):
        if tokens[index] == "=" or (index + 1 < len(tokens) and tokens[index + 1] == "="):
            break
        if tokens[index] != "off":
            words.append(index)
    return words


def _is_number(token: str) -> bool:
    try:
        parse_value(token)
    except ValueError:
        return False
    return True


def bjt_node_indexes(tokens: Sequence[str]) -> tuple[int, ...]:
    """Indexes of the nodes of a ``Q`` line: ``c b e MODEL [area]`` or ``c b e s MODEL
    [area]``. ngspice asks whether the fourth word is a model; without the models, the fifth
    word decides: a model name (not a number) after four nodes, else the area after three."""
    words = _positional(tokens)
    four = len(words) >= 5 and not _is_number(tokens[words[4]])
    return tuple(words[:4 if four else 3])


@dataclass(frozen=True)
class ElementLetter:
    """One element letter.

    Attributes:
        what: the elements it writes, plural, for messages (``"resistors"``).
        nodes: how many words after the name are nodes, or the function giving their indexes
            in the line's tokens (the name is 0).
        controls: indexes of the tokens (the name is 0) that name another element (the
            sensing source of ``F``/``H``/``W``, the inductors of ``K``).
        supported: whether circuitnsds reads it (else a line with it is refused by name).
    """

    what: str
    nodes: int | Callable[[Sequence[str]], tuple[int, ...]] = 2
    controls: tuple[int, ...] = ()
    supported: bool = True

    def node_indexes(self, tokens: Sequence[str]) -> tuple[int, ...]:
        """Indexes of the nodes in the line ``tokens`` (its name first, at 0)."""
        if isinstance(self.nodes, int):
            return tuple(range(1, min(1 + self.nodes, len(tokens))))
        return self.nodes(tokens)


ELEMENT_LETTERS: dict[str, ElementLetter] = {
    "r": ElementLetter("resistors"),
    "c": ElementLetter("capacitors"),
    "l": ElementLetter("inductors"),
    "k": ElementLetter("inductor couplings", 0, (1, 2)),
    "v": ElementLetter("voltage sources"),
    "i": ElementLetter("current sources"),
    "e": ElementLetter("voltage-controlled voltage sources", 4),
    "f": ElementLetter("current-controlled current sources", 2, (3,)),
    "g": ElementLetter("voltage-controlled current sources", 4),
    "h": ElementLetter("current-controlled voltage sources", 2, (3,)),
    "b": ElementLetter("behavioural sources"),
    "d": ElementLetter("diodes"),
    "s": ElementLetter("voltage-controlled switches", 4),
    "w": ElementLetter("current-controlled switches", 2, (3,)),
    "m": ElementLetter("MOSFETs", mosfet_node_indexes),
    # XSPICE ports are marked and bracketed: netlist/subcircuits renames them by their own rule
    "a": ElementLetter("XSPICE code models", 0),
    "x": ElementLetter("subcircuit instances", 0),
    "j": ElementLetter("JFETs", 3),
    "o": ElementLetter("lossy transmission lines", 0, supported=False),
    "p": ElementLetter("coupled transmission lines", 0, supported=False),
    "q": ElementLetter("bipolar transistors", bjt_node_indexes),
    "t": ElementLetter("transmission lines", 0, supported=False),
    "u": ElementLetter("RC lines", 0, supported=False),
    "y": ElementLetter("transmission lines", 0, supported=False),
    "z": ElementLetter("IGBTs and thyristors (PSpice's Z line)", 3),
    "n": ElementLetter("OSDI devices", 0, supported=False),
}
"""Every element letter SPICE knows, lower case -> what it is (``supported=False``: refused)."""

NOT_AN_ELEMENT = ElementLetter("unknown elements", 0, supported=False)
"""What a letter outside :data:`ELEMENT_LETTERS` is: no nodes renamed, refused."""

SMOOTH_NONLINEAR = frozenset("jq")
"""Letters of the smooth nonlinear devices (BJTs, JFETs: their equations are ngspice's,
:mod:`circuitnsds.circuit.elements.smooth`); an ``M`` line is smooth or an ideal switch by its
model's rule."""

SUPPORTED_LETTERS = (", ".join(letter.upper() for letter, kind in ELEMENT_LETTERS.items()
                               if kind.supported and letter != "x") + " and X (subcircuit instances)")
"""The letters circuitnsds reads, for messages."""


def element_letter(name: str) -> str:
    """The type letter of an element: the first letter of its last dotted component
    (``x1.d3`` is a diode, so a flat netlist flattens to itself)."""
    return name.rsplit(".", 1)[-1][:1]


def letter_of(name: str) -> ElementLetter:
    """The :class:`ElementLetter` of the element called ``name``."""
    return ELEMENT_LETTERS.get(element_letter(name).lower(), NOT_AN_ELEMENT)
