"""Safe evaluation of netlist expressions (``{1/(2*pi*fc*r)}``, ``'a+b'``), never ``eval``.

A small recursive-descent parser over this grammar (case-insensitive)::

    expression := sum
    sum        := product (("+" | "-") product)*
    product    := unary (("*" | "/") unary)*
    unary      := ("+" | "-") unary | power
    power      := atom (("^" | "**") signed)*         # left-associative, as ngspice-39: 2^3^2 = 64
    signed     := ("+" | "-") signed | atom
    atom       := NUMBER | NAME | NAME "(" sum ("," sum)* ")" | "(" sum ")"

So unary minus binds looser than the power: ``-2^2`` is ``-4`` and ``2^-1`` is ``0.5``;
``2^3^2`` is ``(2^3)^2 = 64`` as in ngspice-39 (which the same netlist must agree with).
``NUMBER`` is a SPICE number with its scale suffix and units (``4.7k``, ``10u``,
``1e-3``, ``2.2meg``; see :func:`circuitnsds.values.parse_value`). ``NAME`` is a
parameter (``[a-z_][a-z0-9_]*``) or the constant ``pi`` (unless a parameter is so
named). Every intermediate result must be a finite float; anything else raises
:class:`ExpressionError`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping

from circuitnsds.values import parse_value

CONSTANTS: dict[str, float] = {"pi": math.pi}
"""Built-in constants; a parameter of the same name takes precedence (ngspice-39 has no
built-in ``pi`` in ``.param`` expressions, so portable netlists define it)."""


def _sgn(x: float) -> float:
    return float((x > 0) - (x < 0))


FUNCTIONS: dict[str, tuple[Callable[..., float], int, int | None, str]] = {
    "sqrt": (math.sqrt, 1, 1, "square root (argument >= 0)"),
    "exp": (math.exp, 1, 1, "e to the power x"),
    "log": (math.log, 1, 1, "natural logarithm (argument > 0), as in ngspice"),
    "ln": (math.log, 1, 1, "natural logarithm (argument > 0)"),
    "log10": (math.log10, 1, 1, "decimal logarithm (argument > 0)"),
    "sin": (math.sin, 1, 1, "sine (radians)"),
    "cos": (math.cos, 1, 1, "cosine (radians)"),
    "tan": (math.tan, 1, 1, "tangent (radians)"),
    "asin": (math.asin, 1, 1, "arc sine (radians, argument in [-1, 1])"),
    "acos": (math.acos, 1, 1, "arc cosine (radians, argument in [-1, 1])"),
    "atan": (math.atan, 1, 1, "arc tangent (radians)"),
    "sinh": (math.sinh, 1, 1, "hyperbolic sine"),
    "cosh": (math.cosh, 1, 1, "hyperbolic cosine"),
    "tanh": (math.tanh, 1, 1, "hyperbolic tangent"),
    "abs": (abs, 1, 1, "absolute value"),
    "floor": (lambda x: float(math.floor(x)), 1, 1, "largest integer <= x"),
    "ceil": (lambda x: float(math.ceil(x)), 1, 1, "smallest integer >= x"),
    "sgn": (_sgn, 1, 1, "sign: -1, 0 or 1"),
    "min": (min, 2, None, "smallest of its arguments (two or more)"),
    "max": (max, 2, None, "largest of its arguments (two or more)"),
    "pow": (math.pow, 2, 2, "pow(x, y) = x^y"),
}
"""Function name -> (implementation, least and most arguments, meaning)."""


MAX_DEPTH = 100
"""Deepest nesting of parentheses and function calls in one expression (the parser recurses
once per level; ngspice's own parser also has a limit)."""

EXCERPT = 60
"""Longest piece of an expression quoted in a message [characters]."""


def excerpt(text: str, limit: int = EXCERPT) -> str:
    """``text`` quoted for a message: its start and end when longer than ``limit`` characters,
    with the number of characters left out, escaped (``repr``: no control characters)."""
    if len(text) <= limit:
        return repr(text)
    half = limit // 2
    return f"{text[:half]!r} ... {text[-half:]!r} ({len(text)} characters)"


class ExpressionError(ValueError):
    """An expression cannot be evaluated; the message says why (the caller adds file:line)."""


class UndefinedNameError(ExpressionError):
    """An expression names a parameter that is not defined.

    Attributes:
        name: the undefined name (lower case).
    """

    def __init__(self, name: str, text: str):
        self.name = name
        super().__init__(f"undefined parameter {name!r} in {excerpt(text)}")


_TOKEN = re.compile(
    r"""\s*(?:
        (?P<number>(?:\d+\.?\d*|\.\d+)(?:e[+-]?\d+)?[a-z%]*)
      | (?P<name>[a-z_][a-z0-9_]*)
      | (?P<op>\*\*|[-+*/^(),])
    )""",
    re.VERBOSE,
)

Lookup = Callable[[str], "float | None"]


def _tokens(text: str) -> list[tuple[str, str, int]]:
    """``(kind, text, position)`` triples, ending with ``("end", "", len(text))``."""
    tokens: list[tuple[str, str, int]] = []
    position = 0
    while position < len(text):
        if text[position:].isspace():
            break
        match = _TOKEN.match(text, position)
        if match is None or match.end() == position:
            start = position + len(text[position:]) - len(text[position:].lstrip())
            raise ExpressionError(f"unexpected character {text[start]!r} in {excerpt(text)}")
        kind = match.lastgroup or "op"
        tokens.append((kind, match[kind], match.start(kind)))
        position = match.end()
    tokens.append(("end", "", len(text)))
    return tokens


def _finite(value: float, what: str, text: str) -> float:
    if not math.isfinite(value):
        raise ExpressionError(f"{what} is not a finite number (overflow) in {excerpt(text)}")
    return value


class _Parser:
    """Evaluates while parsing: one method per grammar rule."""

    def __init__(self, text: str, lookup: Lookup):
        self.text = text
        self.lookup = lookup
        self.tokens = _tokens(text)
        self.index = 0
        self.depth = 0

    @property
    def current(self) -> tuple[str, str, int]:
        return self.tokens[self.index]

    def accept(self, *ops: str) -> str | None:
        kind, token, _ = self.current
        if kind == "op" and token in ops:
            self.index += 1
            return token
        return None

    def expect(self, op: str) -> None:
        if self.accept(op) is None:
            raise self.unexpected(f"expected {op!r}")

    def unexpected(self, expectation: str) -> ExpressionError:
        kind, token, position = self.current
        found = "the end" if kind == "end" else repr(token)
        return ExpressionError(f"syntax error: {expectation}, found {found} after "
                               f"{excerpt(self.text[:position].strip())} in {excerpt(self.text)}")

    def parse(self) -> float:
        if self.current[0] == "end":
            raise ExpressionError("empty expression")
        value = self.sum()
        if self.current[0] != "end":
            raise self.unexpected("expected an operator")
        return value

    def sum(self) -> float:
        value = self.product()
        while (op := self.accept("+", "-")) is not None:
            right = self.product()
            value = _finite(value + right if op == "+" else value - right, "a sum", self.text)
        return value

    def product(self) -> float:
        value = self.unary()
        while (op := self.accept("*", "/")) is not None:
            right = self.unary()
            if op == "*":
                value = _finite(value * right, "a product", self.text)
            elif right == 0:
                raise ExpressionError(f"division by zero in {excerpt(self.text)}")
            else:
                value = _finite(value / right, "a quotient", self.text)
        return value

    def signs(self) -> float:
        """The product of the leading ``+``/``-`` signs (a loop: any number of them)."""
        sign = 1.0
        while (op := self.accept("+", "-")) is not None:
            if op == "-":
                sign = -sign
        return sign

    def unary(self) -> float:
        sign = self.signs()
        value = self.power()
        return -value if sign < 0 else value

    def power(self) -> float:
        value = self.atom()
        while self.accept("^", "**") is not None:
            value = _power(value, self.signed(), self.text)
        return value

    def signed(self) -> float:
        """An exponent: an atom with any number of signs (``2^-1``)."""
        sign = self.signs()
        value = self.atom()
        return -value if sign < 0 else value

    def nested(self, parse: Callable[[], float]) -> float:
        """``parse()`` one level deeper in parentheses or function calls (at most :data:`MAX_DEPTH`)."""
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise ExpressionError(f"parentheses or function calls nested more than {MAX_DEPTH} "
                                  f"levels deep in {excerpt(self.text)}")
        try:
            return parse()
        finally:
            self.depth -= 1

    def atom(self) -> float:
        kind, token, _ = self.current
        if kind == "number":
            self.index += 1
            try:
                return parse_value(token)
            except ValueError:
                raise ExpressionError(f"{token!r} is not a number in {excerpt(self.text)}") from None
        if kind == "name":
            self.index += 1
            if self.accept("("):
                return self.nested(lambda: self.call(token))
            if token in FUNCTIONS:
                raise ExpressionError(f"{token} is a function: write {token}(...) in {excerpt(self.text)}")
            value = self.lookup(token)
            if value is None:
                value = CONSTANTS.get(token)
            if value is None:
                raise UndefinedNameError(token, self.text)
            return value
        if self.accept("("):
            value = self.nested(self.sum)
            self.expect(")")
            return value
        raise self.unexpected("expected a number, a name or '('")

    def call(self, name: str) -> float:
        if name not in FUNCTIONS:
            raise ExpressionError(f"unknown function {name}() in {excerpt(self.text)}; known: "
                                  + ", ".join(sorted(FUNCTIONS)))
        function, least, most, _ = FUNCTIONS[name]
        args = [self.sum()]
        while self.accept(","):
            args.append(self.sum())
        self.expect(")")
        if len(args) < least or (most is not None and len(args) > most):
            expected = f"{least}" if least == most else f"at least {least}"
            raise ExpressionError(f"{name}() takes {expected} argument{'s' * (expected != '1')}, "
                                  f"got {len(args)} in {excerpt(self.text)}")
        arguments = ", ".join(f"{a:g}" for a in args)
        try:
            result = float(function(*args))
        except (ValueError, ZeroDivisionError):
            raise ExpressionError(f"{name}({arguments}) is undefined (domain error) "
                                  f"in {excerpt(self.text)}") from None
        except OverflowError:
            raise ExpressionError(f"{name}({arguments}) overflows in {excerpt(self.text)}") from None
        return _finite(result, f"{name}({arguments})", self.text)


def _power(base: float, exponent: float, text: str) -> float:
    if base == 0 and exponent < 0:
        raise ExpressionError(f"division by zero: 0^{exponent:g} in {excerpt(text)}")
    try:
        result = math.pow(base, exponent)
    except ValueError:
        raise ExpressionError(f"{base:g}^{exponent:g} is undefined (a negative base needs an integer "
                              f"exponent) in {excerpt(text)}") from None
    except OverflowError:
        raise ExpressionError(f"{base:g}^{exponent:g} overflows in {excerpt(text)}") from None
    return _finite(result, f"{base:g}^{exponent:g}", text)


def evaluate(text: str, names: Mapping[str, float] | Lookup | None = None) -> float:
    """The value of an expression.

    Args:
        text: the expression without its braces or quotes (``1/(2*pi*fc*r)``).
        names: parameter values, as a mapping or as a function returning a name's value
            or ``None`` when it is undefined (it may compute the value on demand, and raise).

    Raises:
        ExpressionError: syntax error, undefined name (:class:`UndefinedNameError`),
            division by zero, domain error, or a non-finite result.
    """
    if names is None:
        lookup: Lookup = lambda name: None  # noqa: E731
    elif isinstance(names, Mapping):
        lookup = names.get
    else:
        lookup = names
    return _Parser(text.lower(), lookup).parse()


def strip_delimiters(token: str) -> str | None:
    """The expression inside a ``{...}`` or ``'...'`` token, or ``None`` for another token."""
    if len(token) >= 2 and ((token[0], token[-1]) in {("{", "}"), ("'", "'")}):
        return token[1:-1]
    return None
