"""Run-time expressions of behavioural sources (``B1 n+ n- V={...}``, ``E1 n+ n- VALUE={...}``).

Unlike a ``.param`` expression, which :mod:`circuitnsds.netlist.expressions` evaluates to a
number while reading the netlist, a behavioural expression depends on the circuit's
unknowns: ``v(node)``, ``v(node1, node2)``, ``i(vsource)`` and ``time``. This module reads
it into a tree (plain tuples), substitutes the parameters it names, renames its nodes and
elements when a subcircuit is flattened, and writes it back as text. What the tree *means*
(affine, a limiter, refused) is decided by :mod:`circuitnsds.frontend.cards.behavioural`.

The grammar, operators and precedence are those of :mod:`circuitnsds.netlist.expressions`
(ngspice's, case-insensitive; its parser reads the text, with ``probes=True``), whose ``atom``
may also be a probe::

    PROBE       := "v(" NODE ["," NODE] ")" | "i(" ELEMENT ")"

A probe's arguments are names as written in the netlist (``v(1)``, ``v(x1.mid)``).
Repeated signs fold as there (``--x`` is ``x``, ``!!!x`` is ``!x``).

Tree nodes: ``("num", value)``, ``("name", name)``, ``("neg", x)``, ``("not", x)``,
``("op", operator, left, right)``, ``("and" | "or", left, right)``, ``("if", c, a, b)``,
``("call", name, (arguments...))``, ``("v", node, reference_or_None)``, ``("i", element)``.
"""

from __future__ import annotations

import re
from collections.abc import Callable

from circuitnsds.netlist import expressions
from circuitnsds.netlist.expressions import CONSTANTS, ExpressionError

Node = tuple
"""An expression tree node (see the module docstring)."""

RESERVED_NAMES = frozenset({"time", "temper", "hertz"})
"""Names a behavioural expression may use that are not parameters (simulator variables)."""

_BINARY = {"&&": "and", "||": "or"}


def parse(text: str) -> Node:
    """The tree of a behavioural expression (lower-cased first): the tree of
    :func:`circuitnsds.netlist.expressions.parse` with its probe leaves, each of its chains
    of left-associative operators written as nested binary ``op``/``and``/``or`` nodes.

    Raises:
        ExpressionError: a syntax error, an unexpected character, a bad number, or nesting
            deeper than :data:`circuitnsds.netlist.expressions.MAX_DEPTH`.
    """
    def binary(item: Node) -> Node:
        kind = item[0]
        if kind in {"num", "name", "v", "i"}:
            return item
        if kind == "call":
            return ("call", item[1], tuple(binary(a) for a in item[2]))
        if kind == "chain":
            tree = binary(item[1])
            for op, operand in item[2]:
                right = binary(operand)
                tree = (_BINARY[op], tree, right) if op in _BINARY else ("op", op, tree, right)
            return tree
        return (kind, *(binary(a) for a in item[1:]))

    # a parameter expression in braces inside the expression (V=i(vs1)*{N}, as ngspice's
    # numparam reads it) is a parenthesised term
    return binary(expressions.parse(text.replace("{", "(").replace("}", ")"), probes=True))


def transform(tree: Node, *, node: Callable[[str], str] = lambda n: n,
              element: Callable[[str], str] = lambda e: e,
              lookup: Callable[[str], float | None] = lambda name: None,
              function: Callable[[str], object | None] = lambda name: None) -> Node:
    """A copy of ``tree`` with probe nodes and elements renamed and parameters replaced by
    their values (``lookup`` returns ``None`` for a name that is not a parameter), and each
    call of a ``.func`` (``function`` returns its :class:`~circuitnsds.netlist.expressions.UserFunction`,
    or ``None``) replaced by its body with the arguments in place of its parameters, as
    ngspice's numparam expands it.

    Raises:
        ExpressionError: a name that is neither a parameter, a constant nor a simulator
            variable (:data:`RESERVED_NAMES`).
    """
    def walk(item: Node, arguments: dict[str, Node] | None = None, depth: int = 0) -> Node:
        kind = item[0]
        if kind == "num":
            return item
        if kind == "name" and arguments and item[1] in arguments:
            return arguments[item[1]]
        if kind == "call" and function(item[1]) is not None:
            user = function(item[1])
            if len(item[2]) != len(user.parameters):
                raise ExpressionError(f"{user.name}() takes {len(user.parameters)} argument(s), "
                                      f"got {len(item[2])}")
            if depth > MAX_INLINE_DEPTH:
                raise ExpressionError(f".func {user.name}() calls itself (or nests too deeply)")
            given = {p: walk(a, arguments, depth) for p, a in zip(user.parameters, item[2])}
            return walk(parse(user.body), given, depth + 1)
        if kind == "v":
            return ("v", node(item[1]), None if item[2] is None else node(item[2]))
        if kind == "i":
            return ("i", element(item[1]))
        if kind == "name":
            name = item[1]
            if name in RESERVED_NAMES:
                return item
            value = lookup(name)
            if value is None:
                value = CONSTANTS.get(name)
            if value is None:
                raise ExpressionError(f"undefined parameter {name!r}")
            return ("num", float(value))
        if kind == "call":
            return ("call", item[1], tuple(walk(a, arguments, depth) for a in item[2]))
        if kind == "op":
            return ("op", item[1], walk(item[2], arguments, depth), walk(item[3], arguments, depth))
        return (kind, *(walk(a, arguments, depth) for a in item[1:]))

    return walk(tree)


MAX_INLINE_DEPTH = 50
"""Deepest nesting of ``.func`` calls expanded inside a behavioural expression."""


def to_text(tree: Node) -> str:
    """The expression written back (fully parenthesised; numbers exact, as ``repr(float)``)."""
    kind = tree[0]
    if kind == "num":
        return repr(float(tree[1]))
    if kind == "name":
        return tree[1]
    if kind == "v":
        return f"v({tree[1]})" if tree[2] is None else f"v({tree[1]},{tree[2]})"
    if kind == "i":
        return f"i({tree[1]})"
    if kind == "neg":
        return f"(-{to_text(tree[1])})"
    if kind == "not":
        return f"(!{to_text(tree[1])})"
    if kind == "op":
        return f"({to_text(tree[2])}{tree[1]}{to_text(tree[3])})"
    if kind in {"and", "or"}:
        return f"({to_text(tree[1])}{'&&' if kind == 'and' else '||'}{to_text(tree[2])})"
    if kind == "if":
        return f"({to_text(tree[1])}?{to_text(tree[2])}:{to_text(tree[3])})"
    return f"{tree[1]}({','.join(to_text(a) for a in tree[2])})"


_HEAD = re.compile(r"\s*(\S+)\s+(\S+)\s+(\S+)\s*(.*)", re.DOTALL)
_ASSIGNMENT = re.compile(r"(v|i|value|vol|cur)\s*=\s*(.*)", re.DOTALL)
_TABLE = re.compile(r"table\s*(\{.*\}|'[^']*'|[^=]+?)\s*=\s*(.*)", re.DOTALL)
_BEHAVIOURAL_KEYS = {"b": ("v", "i"), "e": ("value", "vol"), "g": ("value", "cur")}


def _expression(text: str, statement_text: str) -> str:
    """The expression of ``text`` (``{...}``, ``'...'`` or bare to the end)."""
    from circuitnsds.netlist.parser import closing_position

    text = text.strip()
    if text[:1] in {"{", "'"}:
        end = closing_position(text, 0)
        if end == -1:
            raise ExpressionError(f"{text[0]} is not closed in {statement_text!r}")
        if text[end + 1:].strip():
            raise ExpressionError(f"unexpected {text[end + 1:].split()[0]!r} after the expression "
                                  f"(instance parameters of behavioural sources are not supported: "
                                  f"leave them out, and write a factor into the expression)")
        return text[1:end]
    return text


TIME_VALUED_LETTERS = frozenset("rclvi")
"""Elements whose value may be an expression of ``time`` (``R1 a b {time < 1m ? 1k : 2k}``)."""

_TIME = re.compile(r"\btime\b")
_VALUE_KEY = re.compile(r"(r|c|l|dc|value)\s*=\s*(.*)", re.DOTALL)


_PROBE = re.compile(r"\b[vi]\s*\(")


def is_time_valued(letter: str, tokens: tuple[str, ...]) -> bool:
    """Whether an R, C, L, V or I line's value is an expression of ``time`` (an expression
    token naming it; for R, C, L also the bare form ``R = (time<1m ? 1k : 2k)``), or, for R,
    C, L, an expression token of the circuit's unknowns (``C = 'v(a) < 5 ? c1 : c2'``: a
    nonlinear element, which the front end refuses by name)."""
    if letter not in TIME_VALUED_LETTERS:
        return False
    expressions = [t for t in tokens[3:] if t[:1] in {"{", "'"}]
    values = tokens[3:] if letter in "rcl" else expressions
    return (any(_TIME.search(token) for token in values)
            or (letter in "rcl" and any(_PROBE.search(token) for token in expressions)))


def _closing_parenthesis(text: str) -> int:
    """Index of the ``)`` closing the ``(`` at ``text[0]``, or -1."""
    depth = 0
    for index, char in enumerate(text):
        depth += {"(": 1, ")": -1}.get(char, 0)
        if depth == 0:
            return index
    return -1


def time_valued_tokens(text: str, *, node: Callable[[str], str] = lambda n: n,
                       lookup: Callable[[str], float | None] = lambda name: None) -> tuple[str, ...]:
    """``R|C|L|V|I name n1 n2 [key=]expr`` -> ``(name, n1, n2, "{expr}")``, the expression
    with its parameters replaced by their values and ``time`` kept, the nodes renamed.

    Raises:
        ExpressionError: the value cannot be read, or something follows it.
    """
    from circuitnsds.netlist.parser import closing_position

    head = _HEAD.fullmatch(text.strip())
    if head is None:
        raise ExpressionError(f"expected NAME n1 n2 VALUE in {text!r}")
    name, plus, minus, rest = head.groups()
    rest = rest.lower().strip()
    keyed = _VALUE_KEY.fullmatch(rest)
    if keyed is not None:
        rest = keyed[2].strip()
    if rest.startswith("("):
        end = _closing_parenthesis(rest)
        if end == -1:
            raise ExpressionError(f"'(' is not closed in {text!r}")
        if rest[end + 1:].strip():
            raise ExpressionError(f"unexpected {rest[end + 1:].split()[0]!r} after the value (a "
                                  "time-dependent value takes no other parameter)")
        expression = rest[1:end]
    elif rest[:1] in {"{", "'"} and closing_position(rest, 0) not in {-1, len(rest) - 1}:
        after = rest[closing_position(rest, 0) + 1:].split()[0]
        raise ExpressionError(f"unexpected {after!r} after the value (a time-dependent value "
                              "takes no other parameter)")
    else:
        expression = _expression(rest, text)
    tree = transform(parse(expression), node=node, lookup=lookup)
    return (name.lower(), node(plus.lower()), node(minus.lower()), "{" + to_text(tree) + "}")


def flat_tokens(letter: str, text: str, *, node: Callable[[str], str] = lambda n: n,
                element: Callable[[str], str] = lambda e: e,
                lookup: Callable[[str], float | None] = lambda name: None,
                function: Callable[[str], object | None] = lambda name: None,
                ) -> tuple[str, ...] | None:
    """The tokens the elaborator reads for a behavioural line, its names renamed (``node``,
    ``element``), its parameters replaced by their values (``lookup``) and its ``.func`` calls
    by their bodies (``function``):

    * ``B n+ n- V=expr`` / ``I=expr`` -> ``(name, n+, n-, "v"|"i", "=", "{expr}")``;
    * ``E|G n+ n- VALUE=expr`` (also ``VOL=`` for E, ``CUR=`` for G) ->
      ``(name, n+, n-, "value", "=", "{expr}")``;
    * ``E|G n+ n- TABLE {expr} = (x1, y1) (x2, y2) ...`` ->
      ``(name, n+, n-, "table", "{expr}", "=", x1, y1, x2, y2, ...)``.

    Returns ``None`` for another form (``POLY``, ``LAPLACE``, ...), which the elaborator refuses.

    Raises:
        ExpressionError: the expression or the table cannot be read.
    """
    from circuitnsds.netlist.expressions import evaluate, strip_delimiters

    head = _HEAD.fullmatch(text.strip())
    if head is None:
        return None
    name, plus, minus, rest = head.groups()
    name, rest = name.lower(), rest.lower()
    nodes = (node(plus.lower()), node(minus.lower()))
    assignment = _ASSIGNMENT.fullmatch(rest.strip())
    if assignment is not None and assignment[1] in _BEHAVIOURAL_KEYS.get(letter, ()):
        tree = transform(parse(_expression(assignment[2], text)), node=node, element=element,
                         lookup=lookup, function=function)
        key = assignment[1] if letter == "b" else "value"
        return (name, *nodes, key, "=", "{" + to_text(tree) + "}")
    table = _TABLE.fullmatch(rest.strip()) if letter in "eg" else None
    if table is None:
        return None
    tree = transform(parse(_expression(table[1], text)), node=node, element=element, lookup=lookup,
                     function=function)
    values = []
    for item in re.split(r"[\s(),]+", table[2]):
        if item:
            inner = strip_delimiters(item)
            values.append(repr(evaluate(inner if inner is not None else item, lookup)))
    return (name, *nodes, "table", "{" + to_text(tree) + "}", "=", *values)
