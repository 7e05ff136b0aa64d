"""LTspice's parasitics written on an element line: ``V1 in 0 PULSE(...) Rser=1``,
``L1 a b 10u Rser=20m Rpar=1k Cpar=10p``, ``C1 a b 100u Rser=5m Lser=1n``.

Each stands for the element it names, and becomes that element, named after its owner as
a subcircuit's element is (``l1.rser``: a resistor, ``c1.lser``: an inductor), so its
current and the internal node between owner and parasitic (``l1.1``) are reported like
any other. Series parasitics go in series from the first node, in the order ``Rser``,
``Lser``, then the element itself; parallel ones go across the two nodes of the line
(around the element and its series parasitics), as LTspice draws them:

    n+ ── Rser ── Lser ── element ── n-          (V: Rser, Cpar; L: Rser, Rpar, Cpar;
     └──────────── Rpar, Cpar ────────┘            C: Rser, Lser, Rpar, Cpar)

``i(v1)``, ``i(l1)`` stay the currents of the source and the inductor themselves. A value
of 0 means "none", as in LTspice. LTspice's own defaults (an inductor's 1 mΩ ``Rser``)
are not added: only what the line writes. ngspice 39 refuses these parameters.
"""

from __future__ import annotations

from circuitnsds.errors import NetlistError
from circuitnsds.netlist import Statement

PARASITICS = {"v": ("rser", "cpar"), "l": ("rser", "rpar", "cpar"),
              "c": ("rser", "lser", "rpar", "cpar"), "i": ()}
"""The parasitics each element letter takes (LTspice's)."""

_ANY = frozenset({"rser", "rpar", "lser", "cpar"})
_WHAT = {"v": "a voltage source", "i": "a current source", "l": "an inductor", "c": "a capacitor"}

_SERIES = ("rser", "lser")


def has_parasitics(statement: Statement, letter: str) -> bool:
    """Whether a V, I, L or C line writes a parasitic (``Rser=`` ...) as ``key=value``."""
    tokens = statement.tokens
    return letter in PARASITICS and any(tokens[i] in _ANY and tokens[i + 1] == "="
                                        for i in range(3, len(tokens) - 2))


def split_parasitics(statement: Statement, letter: str) -> list[Statement]:
    """The element's own statement (its parasitics removed, its first node moved behind its
    series parasitics), then one statement per nonzero parasitic (see the module docstring).

    Raises:
        NetlistError: a parasitic LTspice does not give this element (``Rpar`` on a V line).
    """
    tokens = list(statement.tokens)
    values: dict[str, str] = {}
    index = 3
    while index < len(tokens) - 2:
        if tokens[index] in _ANY and tokens[index + 1] == "=" and tokens[index] not in PARASITICS[letter]:
            given = ", ".join(k.capitalize() for k in PARASITICS[letter])
            given = f"LTspice gives it {given}" if given else "LTspice gives it none"
            raise NetlistError(f"{statement.keyword}: {tokens[index].capitalize()}= is not a parasitic "
                               f"of {_WHAT[letter]} ({given})", where=statement.location,
                               hint="write the element it stands for on a line of its own (for a "
                               "series one, with a new node between it and the element)")
        if tokens[index] in PARASITICS[letter] and tokens[index + 1] == "=":
            values[tokens[index]] = tokens[index + 2]
            del tokens[index:index + 3]
        else:
            index += 1
    values = {key: value for key, value in values.items() if _nonzero(value)}
    name, plus, minus = tokens[0], tokens[1], tokens[2]
    extra: list[Statement] = []
    node = plus
    for count, key in enumerate(k for k in _SERIES if k in values):
        inner = f"{name}.{count + 1}"
        extra.append(_line(f"{name}.{key}", node, inner, values[key], statement))
        node = inner
    tokens[1] = node
    for key in ("rpar", "cpar"):
        if key in values:
            extra.append(_line(f"{name}.{key}", plus, minus, values[key], statement))
    own = Statement(tuple(tokens), statement.location, statement.text)
    return [own, *extra]


def _nonzero(value: str) -> bool:
    try:
        return float(value) != 0.0
    except ValueError:
        return True  # not a plain number: the element's reader reports it


def _line(name: str, plus: str, minus: str, value: str, owner: Statement) -> Statement:
    """A parasitic's statement, located at its owner's line (whose text it shows)."""
    return Statement((name, plus, minus, value), owner.location,
                     f"{owner.text}   [{name.split('.')[-1]} of {owner.keyword}]")
