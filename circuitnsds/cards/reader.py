"""Token-level reading of one statement, with ``file:line`` errors and warnings."""

from __future__ import annotations

import warnings
from collections.abc import Iterator

from circuitnsds.errors import NetlistError, NetlistWarning, SourceLocation
from circuitnsds.netlist import Statement
from circuitnsds.values import parse_value

GROUND_NAMES = {"0", "gnd"}


def warn_at(location: SourceLocation, message: str) -> None:
    """Emit a :class:`NetlistWarning` prefixed with ``file:line``."""
    warnings.warn(f"{location}: {message}", NetlistWarning, stacklevel=3)


def node_name(token: str) -> str:
    """Node name as used in the circuit: ``gnd`` is ground ``0``."""
    return "0" if token in GROUND_NAMES else token


def element_letter(name: str) -> str:
    """Type letter of an element name; a flattened name ``x1.d3`` is a ``d``."""
    return name.rsplit(".", 1)[-1][:1]


class StatementReader:
    """Walks the tokens of one statement, turning mistakes into file:line errors."""

    def __init__(self, statement: Statement, start: int = 1):
        self.statement = statement
        self.tokens = statement.tokens
        self.position = start

    @property
    def name(self) -> str:
        """The element name or dot command the statement starts with."""
        return self.tokens[0]

    @property
    def location(self) -> SourceLocation:
        return self.statement.location

    def error(self, message: str, hint: str | None = None) -> NetlistError:
        return NetlistError(message, where=self.location, hint=hint)

    def warn(self, message: str) -> None:
        warn_at(self.location, message)

    def done(self) -> bool:
        return self.position >= len(self.tokens)

    def peek(self, ahead: int = 0) -> str | None:
        """The token ``ahead`` places after the current one, or ``None`` past the end."""
        index = self.position + ahead
        return self.tokens[index] if index < len(self.tokens) else None

    def next(self, what: str) -> str:
        if self.done():
            raise self.error(f"{self.name}: missing {what}", hint=f"in: {self.statement.text}")
        token = self.tokens[self.position]
        self.position += 1
        return token

    def value(self, what: str) -> float:
        token = self.next(what)
        try:
            return parse_value(token)
        except ValueError:
            raise self.error(f"{self.name}: {what} {token!r} is not a number",
                             hint="numbers look like 10, 4.7k, 10uF, 1e-3") from None

    def number(self, key: str, text: str) -> float:
        """The value of parameter ``key`` written as ``text``."""
        try:
            return parse_value(text)
        except ValueError:
            raise self.error(f"{self.name}: {key}={text!r} is not a number") from None

    def nodes(self, count: int) -> tuple[str, ...]:
        return tuple(node_name(self.next(f"node {k + 1} of {count}")) for k in range(count))

    def keyword_values(self) -> Iterator[tuple[str, str]]:
        """Yield ``key = value`` pairs until the end of the statement."""
        while not self.done():
            key = self.next("parameter")
            if self.peek() != "=":
                raise self.error(f"{self.name}: expected '{key}=value', found {key!r} alone",
                                 hint=f"in: {self.statement.text}")
            self.position += 1
            yield key, self.next(f"value of {key}")
