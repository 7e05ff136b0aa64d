"""Token-level reading of one statement, with ``file:line`` errors and warnings."""

from __future__ import annotations

import warnings
from collections.abc import Iterator, Mapping

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


def token_column(statement: Statement, index: int) -> int | None:
    """1-based column of ``statement.tokens[index]`` in ``statement.text``, or ``None`` when
    the text does not show it (a token produced by parameter substitution)."""
    if not statement.tokens:
        return None
    index = min(index, len(statement.tokens) - 1)
    text = statement.text.lower()
    offset = 0
    for k, token in enumerate(statement.tokens[:index + 1]):
        found = text.find(token, offset)
        if found < 0:
            return None
        if k == index:
            return found + 1
        offset = found + len(token)
    return None


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
        """A :class:`NetlistError` at this statement: file:line, the statement's text and the
        column of the token read last (the offending one, usually)."""
        return NetlistError(message, where=self.location, hint=hint, text=self.statement.text,
                            column=token_column(self.statement, max(0, self.position - 1)))

    def model(self, models: Mapping[str, object], model_name: str, what: str, hint: str) -> object:
        """The ``.model`` called ``model_name`` in ``models``; if there is none, the error
        ``"<element>: <what> '<model_name>' is not defined"`` with ``hint`` (the line to add)."""
        if model_name not in models:
            raise self.error(f"{self.name}: {what} {model_name!r} is not defined", hint=hint)
        return models[model_name]

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
        except ValueError as exc:
            problem = ("is too large (beyond 1.8e308)" if "too large" in str(exc)
                       else "is too small (below 5e-324, it would be 0)" if "too small" in str(exc)
                       else "is not a number")
            raise self.error(f"{self.name}: {what} {token!r} {problem}",
                             hint="numbers look like 10, 4.7k, 10uF, 1e-3") from None

    def number(self, key: str, text: str) -> float:
        """The value of parameter ``key`` written as ``text``."""
        try:
            return parse_value(text)
        except ValueError as exc:
            problem = "is not a number" if "not a number" in str(exc) else str(exc).split(" is ", 1)[-1]
            raise self.error(f"{self.name}: {key}={text!r} is {problem.removeprefix('is ')}") from None

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
