"""Safe evaluation of netlist expressions (``{1/(2*pi*fc*r)}``, ``'a+b'``), never ``eval``.

A small recursive-descent parser builds a tree (plain tuples) that is then evaluated;
the grammar (case-insensitive)::

    expression  := disjunction ["?" expression ":" expression]    # c ? a : b, right-assoc.
    disjunction := conjunction ("||" conjunction)*
    conjunction := comparison ("&&" comparison)*
    comparison  := sum (("==" | "!=" | "<" | "<=" | ">" | ">=") sum)*
    sum         := product (("+" | "-") product)*
    product     := unary (("*" | "/") unary)*
    unary       := ("+" | "-" | "!") unary | power
    power       := atom (("^" | "**") signed)*     # left-associative, as ngspice-39: 2^3^2 = 64
    signed      := ("+" | "-") signed | atom
    atom        := NUMBER | NAME | NAME "(" expression ("," expression)* ")" | "(" expression ")"
                 | PROBE              # v(node[, node]), i(element): only with parse(..., probes=True)

So unary minus binds looser than the power: ``-2^2`` is ``-4`` and ``2^-1`` is ``0.5``;
``2^3^2`` is ``(2^3)^2 = 64`` as in ngspice-39 (which the same netlist must agree with).
Comparisons and ``!``, ``&&``, ``||`` give 1 or 0; a condition is true when nonzero, and
``c ? a : b``, ``if(c, a, b)`` and ``ternary_fcn(c, a, b)`` evaluate only the branch
chosen (the operator order of ngspice's manual, "Parameters, functions, expressions").
``NUMBER`` is a SPICE number with its scale suffix and units (``4.7k``, ``10u``,
``1e-3``, ``2.2meg``; see :func:`circuitnsds.values.parse_value`). ``NAME`` is a
parameter (``[a-z_][a-z0-9_]*``) or the constant ``pi`` (unless a parameter is so
named). Every intermediate result must be a finite float; anything else raises
:class:`ExpressionError`.
"""

from __future__ import annotations

import functools
import math
import re
import sys
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Protocol

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
"""Deepest nesting of parentheses, function calls and ``?:`` in one expression (the parser
recurses once per level; ngspice's own parser also has a limit)."""

EXCERPT = 60
"""Longest piece of an expression quoted in a message [characters]."""


def excerpt(text: str, limit: int = EXCERPT) -> str:
    """``text`` quoted for a message: its start and end when longer than ``limit`` characters,
    with the number of characters left out, escaped (``repr``: no control characters)."""
    if len(text) <= limit:
        return repr(text)
    half = limit // 2
    return f"{text[:half]!r} ... {text[-half:]!r} ({len(text)} characters)"


def _sigma(sigma: float) -> float:
    if sigma == 0:
        raise ZeroDivisionError("sigma = 0")
    return sigma


def _gauss(random: Random, *args: float) -> float:
    if len(args) == 1:  # LTspice: gauss(x), zero mean and standard deviation x
        return args[0] * random.standard_normal()
    nominal, relative, sigma = args
    return nominal + nominal * relative / _sigma(sigma) * random.standard_normal()


def _limit(random: Random, nominal: float, absolute: float) -> float:
    return nominal + absolute if random.uniform(-1.0, 1.0) > 0 else nominal - absolute


RANDOM_FUNCTIONS: dict[str, tuple[Callable[..., float], int, int | None, str]] = {
    "agauss": (lambda r, nom, avar, sigma: nom + avar / _sigma(sigma) * r.standard_normal(), 3, 3,
               "agauss(nom, avar, sigma): nom plus a Gaussian draw of standard deviation avar/sigma "
               "(ngspice)"),
    "gauss": (_gauss, 1, 3, "gauss(nom, rvar, sigma): nom plus a Gaussian draw of standard deviation "
              "nom·rvar/sigma (ngspice); gauss(x): a Gaussian draw of standard deviation x (LTspice)"),
    "aunif": (lambda r, nom, avar: nom + avar * r.uniform(-1.0, 1.0), 2, 2,
              "aunif(nom, avar): nom plus a uniform draw in [-avar, avar) (ngspice)"),
    "unif": (lambda r, nom, rvar: nom + nom * rvar * r.uniform(-1.0, 1.0), 2, 2,
             "unif(nom, rvar): nom plus a uniform draw in [-nom·rvar, nom·rvar) (ngspice)"),
    "limit": (_limit, 2, 2, "limit(nom, avar): nom + avar or nom - avar, each with probability "
              "1/2 (ngspice)"),
    "mc": (lambda r, nom, tol: nom + nom * tol * r.uniform(-1.0, 1.0), 2, 2,
           "mc(x, tol): a uniform draw between x·(1-tol) and x·(1+tol) (LTspice)"),
    "flat": (lambda r, x: x * r.uniform(-1.0, 1.0), 1, 1,
             "flat(x): a uniform draw in [-x, x) (LTspice)"),
}
"""Monte Carlo functions: name -> (implementation taking the generator first, least and most
arguments, meaning). Every call draws anew; a ``.param`` is evaluated once per circuit, so
every use of a parameter defined by one of them sees the same draw (as in ngspice)."""

CONDITIONAL_FUNCTIONS = {"if": "if(c, a, b): a where c is nonzero, else b (only that branch is "
                         "evaluated)", "ternary_fcn": "ternary_fcn(c, a, b): the same as if(c, a, b) "
                         "(ngspice's name)"}
"""Functions of a condition: only the branch chosen is evaluated."""


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


_TOKENS = r"""
        (?P<number>(?:\d+\.?\d*|\.\d+)(?:e[+-]?\d+)?[a-z%]*)
      | (?P<name>[a-z_][a-z0-9_]*)
      | (?P<op>\*\*|==|!=|<=|>=|&&|\|\||[-+*/^(),<>!?:])
"""
_TOKEN = re.compile(r"\s*(?:" + _TOKENS + ")", re.VERBOSE)
_PROBE_TOKEN = re.compile(
    r"""\s*(?:
        (?P<probe>(?P<kind>[vi])\s*\(\s*(?P<first>[^\s(),]+)\s*(?:,\s*(?P<second>[^\s(),]+)\s*)?\))
      | """ + _TOKENS + ")",
    re.VERBOSE,
)
"""With ``probes``: ``v(node)``, ``v(node1, node2)`` and ``i(element)`` are one token each,
their arguments names as written in a netlist (``v(1)``, ``v(x1.mid)``), tried first."""

Lookup = Callable[[str], "float | None"]


@dataclass(frozen=True)
class UserFunction:
    """A ``.func name(a, b) {body}`` definition.

    Attributes:
        name: the function (lower case).
        parameters: its argument names (lower case), in order.
        body: its expression, without braces or quotes.
    """

    name: str
    parameters: tuple[str, ...]
    body: str


FunctionLookup = Callable[[str], "UserFunction | None"]


class Random(Protocol):
    """The random source of the Monte Carlo functions: a ``numpy.random.Generator``."""

    def standard_normal(self) -> float: ...

    def uniform(self, low: float, high: float) -> float: ...


def _tokens(text: str, probes: bool = False) -> list[tuple]:
    """``(kind, text, position)`` triples, ending with ``("end", "", len(text))``; with
    ``probes``, a probe is ``("probe", (kind, first, second_or_None), position)``."""
    pattern = _PROBE_TOKEN if probes else _TOKEN
    tokens: list[tuple] = []
    position = 0
    while position < len(text):
        if text[position:].isspace():
            break
        match = pattern.match(text, position)
        if match is None or match.end() == position:
            start = position + len(text[position:]) - len(text[position:].lstrip())
            raise ExpressionError(f"unexpected character {text[start]!r} in {excerpt(text)}")
        if probes and match["probe"]:
            tokens.append(("probe", (match["kind"], match["first"], match["second"]),
                           match.start("probe")))
        else:
            kind = match.lastgroup or "op"
            tokens.append((kind, match[kind], match.start(kind)))
        position = match.end()
    tokens.append(("end", "", len(text)))
    return tokens


def _finite(value: float, what: str, text: str) -> float:
    if not math.isfinite(value):
        raise ExpressionError(f"{what} is not a finite number (overflow) in {excerpt(text)}")
    return value


# An expression tree: plain tuples, ("num", value) ("name", name) ("neg", x) ("not", x)
# ("chain", first, ((operator, node), ...)) for a run of left-associative binary operators of
# one precedence level (evaluated in a loop), ("if", condition, then, else),
# ("call", name, (arguments...)); with probes also ("v", node, reference_or_None), ("i", element).
Node = tuple


class _Parser:
    """Builds the expression tree: one method per grammar rule (nothing is evaluated).
    With ``probes``, ``v(...)`` and ``i(...)`` are leaves (a behavioural source's unknowns)."""

    def __init__(self, text: str, probes: bool = False):
        self.text = text
        self.probes = probes
        self.tokens = _tokens(text, probes)
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

    def parse(self) -> Node:
        if self.current[0] == "end":
            raise ExpressionError("empty expression")
        tree = self.expression()
        if self.current[0] != "end":
            raise self.unexpected("expected an operator")
        return tree

    def nested(self, parse: Callable[[], Node]) -> Node:
        """``parse()`` one level deeper in parentheses, calls or ``?:`` (at most :data:`MAX_DEPTH`)."""
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise ExpressionError(f"parentheses, function calls or ?: nested more than {MAX_DEPTH} "
                                  f"levels deep in {excerpt(self.text)}")
        try:
            return parse()
        finally:
            self.depth -= 1

    def chain(self, operand: Callable[[], Node], *ops: str) -> Node:
        """``operand (op operand)*`` as one node ``("chain", first, ((op, node), ...))``,
        evaluated left to right in a loop (a long sum is not a deep tree)."""
        first = operand()
        rest = []
        while (op := self.accept(*ops)) is not None:
            rest.append((op, operand()))
        return ("chain", first, tuple(rest)) if rest else first

    def expression(self) -> Node:
        """``condition ? a : b`` (right-associative, lowest precedence)."""
        condition = self.disjunction()
        if self.accept("?") is None:
            return condition
        then = self.nested(self.expression)
        self.expect(":")
        return ("if", condition, then, self.nested(self.expression))

    def disjunction(self) -> Node:
        return self.chain(self.conjunction, "||")

    def conjunction(self) -> Node:
        return self.chain(self.comparison, "&&")

    def comparison(self) -> Node:
        return self.chain(self.sum, "==", "!=", "<", "<=", ">", ">=")

    def sum(self) -> Node:
        return self.chain(self.product, "+", "-")

    def product(self) -> Node:
        return self.chain(self.unary, "*", "/")

    def unary(self) -> Node:
        """Any number of leading ``+ - !`` (a loop), then a power."""
        prefix = []
        while (op := self.accept("+", "-", "!")) is not None:
            prefix.append(op)
        tree = self.power()
        for op in reversed(prefix):  # --x is x, !!!x is !x: the tree stays shallow
            if op == "-":
                tree = tree[1] if tree[0] == "neg" else ("neg", tree)
            elif op == "!":
                inner = tree[1] if tree[0] == "not" else None
                tree = inner if inner is not None and inner[0] == "not" else ("not", tree)
            if _depth(tree) > MAX_DEPTH:
                raise ExpressionError(f"more than {MAX_DEPTH} alternating unary operators in "
                                      f"{excerpt(self.text)}")
        return tree

    def power(self) -> Node:
        """``atom (^ signed)*``, left-associative, as one chain."""
        first = self.atom()
        rest = []
        while self.accept("^", "**") is not None:
            rest.append(("^", self.signed()))
        return ("chain", first, tuple(rest)) if rest else first

    def signed(self) -> Node:
        """An exponent: an atom with any number of signs (``2^-1``), read in a loop."""
        negative = False
        while (op := self.accept("+", "-")) is not None:
            negative ^= op == "-"
        tree = self.atom()
        return ("neg", tree) if negative else tree

    def atom(self) -> Node:
        kind, token, _ = self.current
        if kind == "probe":
            self.index += 1
            probe, first, second = token
            if probe == "i":
                if second is not None:
                    raise ExpressionError(f"i({first}, {second}): i() takes one element name "
                                          f"in {excerpt(self.text)}")
                return ("i", first)
            return ("v", first, second)
        if kind == "number":
            self.index += 1
            try:
                return ("num", parse_value(token))
            except ValueError:
                raise ExpressionError(f"{token!r} is not a number in {excerpt(self.text)}") from None
        if kind == "name":
            self.index += 1
            if self.accept("("):
                return self.nested(lambda: self.call(token))
            return ("name", token)
        if self.accept("("):
            tree = self.nested(self.expression)
            self.expect(")")
            return tree
        raise self.unexpected("expected a number, a name, v(...), i(...) or '('" if self.probes
                              else "expected a number, a name or '('")

    def call(self, name: str) -> Node:
        arguments = [self.expression()]
        while self.accept(","):
            arguments.append(self.expression())
        self.expect(")")
        return ("call", name, tuple(arguments))


def _depth(tree: Node) -> int:
    """How many ``neg``/``not`` nodes head ``tree``."""
    depth = 0
    while tree[0] in ("neg", "not"):
        depth, tree = depth + 1, tree[1]
    return depth


STACK = 6000
"""Python frames allowed while parsing or evaluating (one level of parentheses takes about 15
frames of the recursive descent; :data:`MAX_DEPTH` levels must fit)."""


@contextmanager
def _stack() -> Iterator[None]:
    """Raise Python's recursion limit to :data:`STACK` for the block (restored after)."""
    previous = sys.getrecursionlimit()
    sys.setrecursionlimit(max(previous, STACK))
    try:
        yield
    finally:
        sys.setrecursionlimit(previous)


def parse(text: str, *, probes: bool = False) -> Node:
    """The expression tree of ``text`` (lower-cased first); cached, as a sweep evaluates the
    same expressions at every point. With ``probes``, ``v(node)``, ``v(node1, node2)`` and
    ``i(element)`` are leaves (:mod:`circuitnsds.netlist.behavioural`); :func:`evaluate`
    never reads them.

    Raises:
        ExpressionError: a syntax error, an unexpected character, a bad number, or nesting
            deeper than :data:`MAX_DEPTH`.
    """
    with _stack():
        return _parse(text, probes)


@functools.lru_cache(maxsize=4096)
def _parse(text: str, probes: bool = False) -> Node:
    """:func:`parse` without the recursion limit raised (cached)."""
    return _Parser(text.lower(), probes).parse()


MAX_CALL_DEPTH = 100
"""Deepest nesting of ``.func`` calls (a ``.func`` calling itself is stopped here)."""


class _Evaluator:
    """Evaluates a tree: names through ``lookup``, ``.func`` calls through ``functions``,
    Monte Carlo functions from ``random``."""

    def __init__(self, text: str, lookup: Lookup, functions: FunctionLookup, random: Random | None,
                 depth: int = 0):
        self.text = text
        self.lookup = lookup
        self.functions = functions
        self.random = random
        self.depth = depth

    def value(self, node: Node) -> float:
        kind = node[0]
        if kind == "num":
            return node[1]
        if kind == "name":
            return self.name(node[1])
        if kind == "neg":
            return -self.value(node[1])
        if kind == "not":
            return float(self.value(node[1]) == 0)
        if kind == "if":  # only the branch taken is evaluated (its errors and random draws)
            return self.value(node[2] if self.value(node[1]) != 0 else node[3])
        if kind == "call":
            return self.call(node[1], node[2])
        return self.chain(node[1], node[2])

    def chain(self, first: Node, rest: tuple) -> float:
        """``first op node op node ...`` left to right; ``&&``/``||`` stop at the first
        operand that decides (its right side is not evaluated)."""
        value = self.value(first)
        for op, node in rest:
            if op == "&&":
                value = float(value != 0 and self.value(node) != 0)
            elif op == "||":
                value = float(value != 0 or self.value(node) != 0)
            else:
                value = self.operation(op, value, self.value(node))
        return value

    def name(self, name: str) -> float:
        if name in FUNCTIONS or name in RANDOM_FUNCTIONS or name in CONDITIONAL_FUNCTIONS:
            raise ExpressionError(f"{name} is a function: write {name}(...) in {excerpt(self.text)}")
        value = self.lookup(name)
        if value is None:
            value = CONSTANTS.get(name)
        if value is None:
            raise UndefinedNameError(name, self.text)
        return value

    def operation(self, op: str, left: float, right: float) -> float:
        text = self.text
        if op == "+":
            return _finite(left + right, "a sum", text)
        if op == "-":
            return _finite(left - right, "a sum", text)
        if op == "*":
            return _finite(left * right, "a product", text)
        if op == "/":
            if right == 0:
                raise ExpressionError(f"division by zero in {excerpt(text)}")
            return _finite(left / right, "a quotient", text)
        if op == "^":
            return _power(left, right, text)
        return float({"==": left == right, "!=": left != right, "<": left < right,
                      "<=": left <= right, ">": left > right, ">=": left >= right}[op])

    def call(self, name: str, arguments: tuple[Node, ...]) -> float:
        if name in CONDITIONAL_FUNCTIONS:
            _count(name, len(arguments), 3, 3, self.text)
            return self.value(arguments[1] if self.value(arguments[0]) != 0 else arguments[2])
        user = self.functions(name)
        if user is not None:
            return self.user_call(user, [self.value(a) for a in arguments])
        if name in RANDOM_FUNCTIONS:
            function, least, most, _ = RANDOM_FUNCTIONS[name]
            args = [self.value(a) for a in arguments]
            _count(name, len(args), least, most, self.text)
            if self.random is None:
                raise ExpressionError(f"{name}() draws a random number, and no random generator "
                                      f"is given in {excerpt(self.text)}")
            return _finite(function(self.random, *args), f"{name}()", self.text)
        if name not in FUNCTIONS:
            known = sorted({*FUNCTIONS, *RANDOM_FUNCTIONS, *CONDITIONAL_FUNCTIONS})
            raise ExpressionError(f"unknown function {name}() in {excerpt(self.text)}; known: "
                                  + ", ".join(known) + " (and .func definitions)")
        function, least, most, _ = FUNCTIONS[name]
        args = [self.value(a) for a in arguments]
        _count(name, len(args), least, most, self.text)
        formatted = ", ".join(f"{a:g}" for a in args)
        try:
            result = float(function(*args))
        except (ValueError, ZeroDivisionError):
            raise ExpressionError(f"{name}({formatted}) is undefined (domain error) "
                                  f"in {excerpt(self.text)}") from None
        except OverflowError:
            raise ExpressionError(f"{name}({formatted}) overflows in {excerpt(self.text)}") from None
        return _finite(result, f"{name}({formatted})", self.text)

    def user_call(self, user: UserFunction, args: list[float]) -> float:
        _count(user.name, len(args), len(user.parameters), len(user.parameters), self.text)
        if self.depth >= MAX_CALL_DEPTH:
            raise ExpressionError(f".func {user.name}() calls itself (nested deeper than "
                                  f"{MAX_CALL_DEPTH}) in {excerpt(self.text)}")
        bound = dict(zip(user.parameters, args))

        def lookup(name: str) -> float | None:
            return bound[name] if name in bound else self.lookup(name)

        inner = _Evaluator(user.body.lower(), lookup, self.functions, self.random, self.depth + 1)
        try:
            return inner.value(parse(user.body))
        except UndefinedNameError:
            raise
        except ExpressionError as exc:
            raise ExpressionError(f"in .func {user.name}({', '.join(user.parameters)}) = "
                                  f"{excerpt(user.body)} called from {excerpt(self.text)}: {exc}") from None


def _count(name: str, given: int, least: int, most: int | None, text: str) -> None:
    if given < least or (most is not None and given > most):
        expected = f"{least}" if least == most else (
            f"at least {least}" if most is None else f"{least} to {most}")
        raise ExpressionError(f"{name}() takes {expected} argument{'s' * (expected != '1')}, "
                              f"got {given} in {excerpt(text)}")


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


def _as_lookup(table):
    """A mapping, a lookup function or ``None`` as a function ``name -> value or None``."""
    if table is None:
        return lambda name: None
    if isinstance(table, Mapping):
        return table.get
    return table


def evaluate(text: str, names: Mapping[str, float] | Lookup | None = None, *,
             functions: Mapping[str, UserFunction] | FunctionLookup | None = None,
             random: Random | None = None) -> float:
    """The value of an expression.

    Args:
        text: the expression without its braces or quotes (``1/(2*pi*fc*r)``).
        names: parameter values, as a mapping or as a function returning a name's value
            or ``None`` when it is undefined (it may compute the value on demand, and raise).
        functions: ``.func`` definitions, as a mapping or a function returning ``None`` for
            a name that is not one (a ``.func`` hides a built-in function of the same name).
        random: the generator of the Monte Carlo functions (:data:`RANDOM_FUNCTIONS`);
            each call draws anew. Without one, those functions are an error.

    Raises:
        ExpressionError: syntax error, undefined name (:class:`UndefinedNameError`),
            division by zero, domain error, or a non-finite result.
    """
    lookup: Lookup = _as_lookup(names)
    function_lookup: FunctionLookup = _as_lookup(functions)
    tree = parse(text)
    try:
        with _stack():
            return _Evaluator(text.lower(), lookup, function_lookup, random).value(tree)
    except RecursionError:  # .func calls inside deep expressions: a limit, not a crash
        raise ExpressionError(f"the evaluation nests too deeply in {excerpt(text)}") from None


def strip_delimiters(token: str) -> str | None:
    """The expression inside a ``{...}`` or ``'...'`` token, or ``None`` for another token."""
    if len(token) >= 2 and ((token[0], token[-1]) in {("{", "}"), ("'", "'")}):
        return token[1:-1]
    return None
