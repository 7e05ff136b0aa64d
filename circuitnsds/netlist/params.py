"""Parameters: ``.param`` definitions, their scopes, and ``{expr}`` substitution.

A :class:`Scope` holds the parameters of the top level or of one subcircuit instance
(its ``params:`` defaults, overridden by the instance line, and the ``.param`` lines
in its body). Names are looked up in the scope, then in the scope of the caller, up
to the top level. Definitions are evaluated in the order written; a definition may
use one written later in the same scope (it is evaluated on demand, as ngspice sorts
its ``.param`` lines), and a chain of definitions that comes back to itself is an
error naming the chain.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from circuitnsds.errors import NetlistError, SourceLocation
from circuitnsds.netlist.expressions import (
    ExpressionError,
    Random,
    UndefinedNameError,
    UserFunction,
    evaluate,
    strip_delimiters,
)
from circuitnsds.netlist.parser import Statement, closing_position

_NAME_EQUALS = re.compile(r"[\s,]*([a-z_][a-z0-9_]*)\s*=(?!=)\s*", re.IGNORECASE)
_NEXT_ASSIGNMENT = re.compile(r"[\s,]+[a-z_][a-z0-9_]*\s*=(?!=)", re.IGNORECASE)
_FIRST_ASSIGNMENT = re.compile(r"(?<!\S)(params:|[^\s=(),]+\s*=(?!=))", re.IGNORECASE)


class AssignmentSyntaxError(ValueError):
    """``name=value`` pairs cannot be read (the caller adds file:line)."""


def parse_assignments(text: str) -> list[tuple[str, str]]:
    """Read ``a=1 b={a*2} c='a+b' d = a + 1`` into ``[(name, expression), ...]``.

    A value is a ``{...}`` or ``'...'`` expression, or a bare expression running to the
    next ``name=`` (spaces allowed: ``d = a + 1``). Commas between pairs are allowed.
    Names are lower-cased; expressions are returned without their delimiters.

    Raises:
        AssignmentSyntaxError: for text that is not ``name=value`` pairs.
    """
    pairs: list[tuple[str, str]] = []
    position = 0
    while text[position:].strip(" \t,"):
        match = _NAME_EQUALS.match(text, position)
        if match is None:
            rest = text[position:].strip(" \t,")
            raise AssignmentSyntaxError(f"expected name=value, found {rest!r}")
        name, position = match[1].lower(), match.end()
        if position >= len(text):
            raise AssignmentSyntaxError(f"{name}= has no value")
        if text[position] in "{'":
            end = closing_position(text, position)
            if end == -1:
                raise AssignmentSyntaxError(f"{name}: {text[position]} is not closed")
            expression = text[position + 1:end]
            position = end + 1
            if position < len(text) and not (text[position].isspace() or text[position] == ","):
                raise AssignmentSyntaxError(f"{name}: unexpected {text[position:].split()[0]!r} after "
                                            f"{text[match.end():position]!r}")
        else:
            end = _bare_end(text, position)
            expression, position = text[position:end].strip(" \t,"), end
        if not expression.strip():
            raise AssignmentSyntaxError(f"{name}= has no value")
        pairs.append((name, expression.strip()))
    return pairs


def _bare_end(text: str, start: int) -> int:
    """End of a bare expression: the next ``name=`` outside parentheses, or the end."""
    depth = 0
    for index in range(start, len(text)):
        char = text[index]
        if char == "(":
            depth += 1
        elif char == ")":
            depth -= 1
        elif depth <= 0 and _NEXT_ASSIGNMENT.match(text, index):
            return index
    return len(text)


def split_parameters(text: str) -> tuple[str, str]:
    """Split a ``.subckt`` or ``X`` line into its positional part and its ``name=value`` part.

    The parameters start at ``params:`` or at the first ``name=``; ``params:`` itself is
    dropped. ``"x1 a b sub params: r=1k"`` -> ``("x1 a b sub", "r=1k")``.
    """
    match = _FIRST_ASSIGNMENT.search(text)
    if match is None:
        return text, ""
    if match[1].lower() == "params:":
        return text[:match.start()], text[match.end():]
    return text[:match.start()], text[match.start():]


@dataclass(frozen=True)
class Definition:
    """One parameter definition as written.

    Attributes:
        name: the parameter (lower case).
        expression: its expression, without braces or quotes.
        location: where it is written.
        text: the statement it is written in (for messages).
    """

    name: str
    expression: str
    location: SourceLocation
    text: str


MAX_CHAIN = 50
"""Longest chain of parameters evaluated on demand (each used before its definition): the
evaluation recurses once per link."""


class Scope:
    """The parameters visible at one level of the hierarchy.

    Args:
        parent: the scope names fall back to (the caller's); ``None`` at the top level.
        label: the instance path of a subcircuit scope (``x1.x2``), for messages;
            ``None`` at the top level.
        random: the generator of the Monte Carlo functions (``agauss`` ...); a subcircuit
            scope uses its parent's.
    """

    def __init__(self, parent: Scope | None = None, label: str | None = None,
                 random: Random | None = None):
        self.parent = parent
        self.label = label
        self.random = random if random is not None or parent is None else parent.random
        self.definitions: dict[str, Definition] = {}
        self.values: dict[str, float] = {}
        self.functions: dict[str, tuple[UserFunction, SourceLocation]] = {}
        self._evaluating: list[str] = []

    def define_function(self, function: UserFunction, location: SourceLocation) -> None:
        """Add a ``.func`` definition (visible here and in the subcircuits called from here).

        Raises:
            NetlistError: the function is already defined at this level.
        """
        if function.name in self.functions:
            raise NetlistError(f".func {function.name} is defined twice (first at "
                               f"{self.functions[function.name][1]})", where=location,
                               hint="give each function one definition")
        self.functions[function.name] = (function, location)

    def function(self, name: str) -> UserFunction | None:
        """The ``.func`` named ``name`` here or in an enclosing scope, ``None`` if none."""
        if name in self.functions:
            return self.functions[name][0]
        return self.parent.function(name) if self.parent is not None else None

    def _value(self, expression: str) -> float:
        return evaluate(expression, self.lookup, functions=self.function, random=self.random)

    def define(self, definition: Definition) -> None:
        """Add a definition (evaluated later, on demand or by :meth:`evaluate_all`).

        Raises:
            NetlistError: the name is already defined here.
        """
        name = definition.name
        if name in self.definitions or name in self.values:
            previous = self.definitions.get(name)
            where = f" (first at {previous.location})" if previous else ""
            level = f"in instance {self.label}" if self.label else "at the top level"
            raise NetlistError(f"parameter {name!r} is defined twice {level}{where}",
                               where=definition.location, hint="give each parameter one definition")
        self.definitions[name] = definition

    def set_value(self, name: str, value: float) -> None:
        """Fix a parameter's value (an instance line overriding a subcircuit default)."""
        self.definitions.pop(name, None)
        self.values[name] = value

    def lookup(self, name: str) -> float | None:
        """The value of ``name`` here or in an enclosing scope, ``None`` if undefined.

        Raises:
            NetlistError: the definition (or one it uses) cannot be evaluated, or the
                definitions refer to each other in a cycle.
        """
        if name in self.values:
            return self.values[name]
        if name in self.definitions:
            return self._evaluate(name)
        return self.parent.lookup(name) if self.parent is not None else None

    def _evaluate(self, name: str) -> float:
        definition = self.definitions[name]
        if name in self._evaluating:
            chain = self._evaluating[self._evaluating.index(name):] + [name]
            places = ", ".join(f"{n} at {self.definitions[n].location}" for n in dict.fromkeys(chain))
            raise NetlistError(f"parameters refer to each other in a cycle: {' -> '.join(chain)}",
                               where=definition.location,
                               hint=f"({places}); a parameter cannot depend on itself")
        if len(self._evaluating) >= MAX_CHAIN:
            first = self._evaluating[0]
            raise NetlistError(
                f"parameter {first!r} depends on a chain of more than {MAX_CHAIN} parameters "
                f"defined after it ({first} -> {self._evaluating[1]} -> ... -> {name})",
                where=self.definitions[first].location,
                hint="define parameters before the ones that use them (then each is evaluated "
                "once, in order)")
        self._evaluating.append(name)
        try:
            value = self._value(definition.expression)
        except ExpressionError as exc:
            raise _error(exc, f"parameter {name!r}", definition.location, definition.text,
                         self.label) from None
        except RecursionError:
            raise NetlistError(f"parameter {name!r}: the expression and the parameters it uses are "
                               "nested too deeply to evaluate", where=definition.location,
                               hint="split it into several .param lines") from None
        finally:
            self._evaluating.pop()
        self.definitions.pop(name)
        self.values[name] = value
        return value

    def evaluate_all(self) -> None:
        """Evaluate every definition of this scope, in the order written (to report errors)."""
        for name in list(self.definitions):
            if name in self.definitions:
                self._evaluate(name)

    def evaluate(self, expression: str, statement: Statement, what: str) -> float:
        """The value of an expression written in ``statement``, in this scope.

        Raises:
            NetlistError: with the statement's file:line and the expression.
        """
        try:
            return self._value(expression)
        except ExpressionError as exc:
            raise _error(exc, what, statement.location, statement.text, self.label) from None
        except RecursionError:
            raise NetlistError(f"{what}: the expression and the parameters it uses are nested too "
                               "deeply to evaluate", where=statement.location,
                               hint="split it into several .param lines") from None

    def substitute(self, statement: Statement) -> tuple[str, ...]:
        """The statement's tokens with every ``{expr}`` / ``'expr'`` replaced by its value.

        Values are written with ``repr(float)``, so no precision is lost.
        """
        tokens = list(statement.tokens)
        for index, token in enumerate(tokens):
            bracket = token[:1] if token[:1] == "[" else token[-1:] if token[-1:] == "]" else ""
            core = token.strip("[]") if bracket else token  # an XSPICE vector: [{kp} 1 1]
            expression = strip_delimiters(core)
            if expression is not None:
                value = repr(self.evaluate(expression, statement, tokens[0]))
                tokens[index] = token.replace(core, value) if bracket else value
        return tuple(tokens)


def _error(exc: ExpressionError, what: str, location: SourceLocation, text: str,
           label: str | None) -> NetlistError:
    where = f" (in instance {label})" if label else ""
    if isinstance(exc, UndefinedNameError):
        return NetlistError(f"{what}: {exc}{where}", where=location,
                            hint=f"define it with .param {exc.name}=VALUE, or as a subcircuit "
                            f"parameter (.subckt NAME nodes params: {exc.name}=VALUE); in: {text}")
    return NetlistError(f"{what}: {exc}{where}", where=location, hint=f"in: {text}")


def param_definitions(statement: Statement) -> list[Definition]:
    """The definitions of a ``.param`` statement (from its text as written).

    Raises:
        NetlistError: for a ``.param`` line that is not ``name=value`` pairs.
    """
    parts = statement.text.split(None, 1)
    rest = parts[1] if len(parts) > 1 else ""
    try:
        pairs = parse_assignments(rest)
    except AssignmentSyntaxError as exc:
        raise NetlistError(f".param: {exc}", where=statement.location,
                           hint="write .param name=value name2={expression}; "
                           f"in: {statement.text}") from None
    if not pairs:
        raise NetlistError(".param defines nothing", where=statement.location,
                           hint="write .param name=value")
    return [Definition(name, expression, statement.location, statement.text) for name, expression in pairs]


_FUNC = re.compile(r"\.func\s+([a-z_][a-z0-9_]*)\s*\(([^)]*)\)\s*(?:=\s*)?(.*)", re.IGNORECASE | re.DOTALL)


def func_definition(statement: Statement) -> UserFunction:
    """The function of a ``.func name(a, b) {body}`` statement (ngspice and LTspice syntax;
    the body may also be ``'body'``, bare, or follow an ``=``).

    Raises:
        NetlistError: a line that is not of that form, an argument named twice, or a body
            that is not an expression (its syntax is checked here, its names when called).
    """
    hint = "write .func name(x, y) {expression of x and y}"
    match = _FUNC.fullmatch(statement.text.strip())
    if match is None:
        raise NetlistError("cannot read the .func line", where=statement.location,
                           hint=f"{hint}; in: {statement.text}")
    name, arguments, body = match[1].lower(), match[2], match[3].strip()
    parameters = tuple(a.strip().lower() for a in arguments.split(",") if a.strip())
    for parameter in parameters:
        if not re.fullmatch(r"[a-z_][a-z0-9_]*", parameter):
            raise NetlistError(f".func {name}: {parameter!r} is not an argument name",
                               where=statement.location, hint=hint)
        if parameters.count(parameter) > 1:
            raise NetlistError(f".func {name}: argument {parameter!r} is named twice",
                               where=statement.location, hint=hint)
    inner = strip_delimiters(body)
    body = inner if inner is not None else body
    if not body.strip():
        raise NetlistError(f".func {name} has no body", where=statement.location, hint=hint)
    from circuitnsds.netlist.expressions import parse

    try:
        parse(body)
    except ExpressionError as exc:
        raise NetlistError(f".func {name}: {exc}", where=statement.location,
                           hint=f"in: {statement.text}") from None
    return UserFunction(name, parameters, body)
