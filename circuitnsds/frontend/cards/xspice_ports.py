"""The port list of an XSPICE ``A`` line, in ngspice's syntax.

Analog (voltage) ports: a node, ``%v(node)``, ``%vd(node+ node-)`` (a differential
voltage). Digital ports: a node, ``%d node``, ``%d(node)``, ``~node`` (the inverted state)
and ``NULL`` (an unconnected optional port). Vector ports: ``[port port ...]``, optionally
preceded by the type (``%d [a b]``). Digital nodes carry 0/1 V in circuitnsds (see
:mod:`circuitnsds.frontend.cards.xspice_digital`).
"""

from __future__ import annotations

from typing import NamedTuple

from circuitnsds.circuit.elements.behavioural import Affine
from circuitnsds.frontend.cards.reader import StatementReader, node_name

Port = tuple[str, str]
"""A voltage port: ``(plus, minus)`` nodes (``minus`` is ``0`` for a single-ended port)."""

HINT = ("write A1 in out MODEL; ports: node, %v(node), %vd(n+ n-), digital ~node, %d(node), NULL, "
        "[vector]")


class DigitalPort(NamedTuple):
    """A digital port: its node and whether it is connected inverted (``~node``)."""

    node: str
    inverted: bool = False

    def level(self) -> Affine:
        """The port's logic value as an affine value of its node voltage (0 or 1 [V])."""
        if self.inverted:
            return Affine(voltages=((self.node, -1.0),), constant=1.0)
        return Affine(voltages=((self.node, 1.0),))


def split_brackets(tokens: list[str]) -> list[str]:
    """Tokens with ``[`` and ``]`` as tokens of their own (the parser keeps them in words)."""
    out: list[str] = []
    for token in tokens:
        while token.startswith("["):
            out.append("[")
            token = token[1:]
        closing = len(token) - len(token.rstrip("]"))
        if token[:len(token) - closing]:
            out.append(token[:len(token) - closing])
        out.extend("]" * closing)
    return out


class Ports:
    """Reads the port list of an ``A`` line (``tokens``: after the name, model excluded)."""

    def __init__(self, reader: StatementReader, tokens: list[str]):
        self.reader = reader
        self.tokens = tokens
        self.position = 0

    @property
    def done(self) -> bool:
        return self.position >= len(self.tokens)

    def port(self) -> Port:
        """An analog voltage port."""
        token = self.take("a port")
        if token.startswith("%"):
            kind = token[1:]
            if kind not in {"v", "vd"}:
                raise self.reader.error(f"{self.reader.name}: port type %{kind} is not supported here",
                                        hint="this port is a voltage: node, %v(node) or "
                                        "%vd(node+ node-)")
            if self.take("'('") != "(":
                raise self.reader.error(f"{self.reader.name}: expected '(' after %{kind}")
            nodes = [self._node(self.take("a node"))]
            if kind == "vd":
                nodes.append(self._node(self.take("a node")))
            if self.take("')'") != ")":
                raise self.reader.error(f"{self.reader.name}: expected ')' after the nodes of %{kind}")
            return (nodes[0], nodes[1] if kind == "vd" else "0")
        return (self._node(token), "0")

    def vector(self) -> list[Port]:
        """An analog vector port (a single port is a vector of one)."""
        if self.tokens[self.position:self.position + 1] != ["["]:
            return [self.port()]
        self.position += 1
        ports = []
        while self.tokens[self.position:self.position + 1] != ["]"]:
            ports.append(self.port())
        self.position += 1
        return ports

    def digital(self, what: str, optional: bool = False) -> DigitalPort | None:
        """A scalar digital port (``None`` for ``NULL``, where ``optional``)."""
        token = self.take(f"the {what} port")
        if token == "%d":
            token = self.take(f"the {what} port")
            if token == "(":
                token = self.take(f"the {what} node")
                if self.take("')'") != ")":
                    raise self.reader.error(f"{self.reader.name}: expected ')' after %d({token}")
        elif token.startswith("%"):
            raise self.reader.error(f"{self.reader.name}: port type {token} is not supported for "
                                    f"the digital port {what}", hint="digital ports are node, ~node, "
                                    "%d node or %d(node)")
        if token == "[":
            raise self.reader.error(f"{self.reader.name}: the {what} port is a single digital node, "
                                    "not a vector [...]", hint=HINT)
        inverted = token.startswith("~")
        node = token[1:] if inverted else token
        if node == "null":
            if not optional or inverted:
                raise self.reader.error(f"{self.reader.name}: the {what} port cannot be NULL",
                                        hint="connect it to a digital node")
            return None
        return DigitalPort(self._node(node, digital=True), inverted)

    def digital_vector(self, what: str) -> list[DigitalPort]:
        """A digital vector port ``[a ~b ...]`` (``%d [a b]`` too)."""
        if self.tokens[self.position:self.position + 1] == ["%d"] and \
                self.tokens[self.position + 1:self.position + 2] == ["["]:
            self.position += 1
        if self.take(f"the {what} vector '['") != "[":
            raise self.reader.error(f"{self.reader.name}: the {what} port is a vector: write "
                                    f"[node node ...]", hint=HINT)
        ports = []
        while self.tokens[self.position:self.position + 1] != ["]"]:
            ports.append(self.digital(what))
        self.position += 1
        return ports

    def take(self, what: str) -> str:
        if self.position >= len(self.tokens):
            raise self.reader.error(f"{self.reader.name}: missing {what}", hint=HINT)
        self.position += 1
        return self.tokens[self.position - 1]

    def _node(self, token: str, digital: bool = False) -> str:
        if token in {"(", ")", "[", "]", "="} or token.startswith(("%", "~")) or \
                (token == "null" and not digital):
            raise self.reader.error(f"{self.reader.name}: unexpected {token!r} in the port list",
                                    hint=HINT)
        node = node_name(token)
        if digital and node == "0":
            raise self.reader.error(f"{self.reader.name}: a digital port cannot be ground (node "
                                    f"{token!r})", hint="drive a digital node with a part (e.g. "
                                    "an adc_bridge of a DC source)")
        return node


def difference(port: Port, scale: float) -> Affine:
    """``scale·(v(plus) − v(minus))``."""
    terms = tuple((n, s * scale) for n, s in ((port[0], 1.0), (port[1], -1.0)) if n != "0")
    return Affine(voltages=terms)


def affine_sum(*values: Affine, constant: float = 0.0) -> Affine:
    """The sum of node-voltage affine values (their constants dropped) plus ``constant``."""
    terms: dict[str, float] = {}
    for value in values:
        for node, c in value.voltages:
            terms[node] = terms.get(node, 0.0) + c
    return Affine(voltages=tuple((n, c) for n, c in terms.items() if c != 0.0), constant=constant)
