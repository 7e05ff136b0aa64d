"""Flattening: ``.param`` and ``.subckt``/``X`` -> a flat :class:`Netlist` for elaboration.

:func:`flatten` takes the statements of a netlist whose includes are already expanded
(:mod:`circuitnsds.netlist.includes`) and returns statements that
:func:`circuitnsds.frontend.elaborate.elaborate` reads as they are:

* every ``{expr}`` / ``'expr'`` token of an element, ``.model``, ``.tran`` or ``.ic``
  line is replaced by its value (``repr(float)``), evaluated in the scope where the
  line is written (:mod:`circuitnsds.netlist.params`);
* every ``X`` line is replaced by the lines of its subcircuit, renamed as ngspice
  does: element ``d1`` of instance ``x1`` becomes ``x1.d1``, internal node ``mid``
  becomes ``x1.mid``, ports become the instance's nodes, ground (``0``, ``gnd``) and
  ``.global`` nodes stay as they are, and instances nest (``x1.x2.d1``); a port named
  ``gnd`` or ``0`` is ground inside, and the instance's node there is not connected to it
  (ngspice 39 reads it so; a warning names that node);
* a ``.model`` written inside a subcircuit is local to each instance (``x1.dmod``,
  and the lines of that instance refer to it so); top-level models are global;
* the controlling source of ``F``/``H``/``W`` lines and the inductors of ``K`` lines
  are renamed like elements when the subcircuit defines them (else they name a
  top-level element and are kept).

Each flat statement keeps the ``location`` where it is written (inside the subcircuit
definition) and its ``text`` ends with ``[in x1.x2]``, so messages are precise.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, replace

from circuitnsds.element_letters import element_letter, letter_of
from circuitnsds.errors import NetlistError, NetlistWarning
from circuitnsds.netlist.conditionals import resolve_conditionals
from circuitnsds.netlist.expressions import ExpressionError, Random
from circuitnsds.netlist.params import (
    AssignmentSyntaxError,
    Definition,
    Scope,
    func_definition,
    param_definitions,
    parse_assignments,
    split_parameters,
)
from circuitnsds.netlist.parser import Netlist, Statement, tokenize

GROUND_NAMES = frozenset({"0", "gnd"})
_PUNCTUATION = frozenset({"(", ")", "="})

SUBSTITUTED_COMMANDS = frozenset({".model", ".tran", ".ic"})
"""Commands whose ``{expr}`` tokens are evaluated (others are passed on as written)."""

# B sources and the expression forms of E/G/F/H hold run-time expressions (v(), i(), time):
# they are passed on unevaluated, and the elaborator says they are not supported.
_BEHAVIOURAL_KEYWORDS = frozenset({"value", "vol", "cur", "table", "laplace", "freq", "poly"})


_TIME_VALUED = frozenset("rclvi")  # (netlist.behavioural.TIME_VALUED_LETTERS, not imported here)


def _behavioural(statement: Statement) -> bool:
    letter = element_letter(statement.keyword)
    if letter in _TIME_VALUED:
        if not any("time" in token or (token[:1] in "{'" and "(" in token)
                   for token in statement.tokens[3:]):
            return False
        from circuitnsds.netlist.behavioural import is_time_valued  # only for such lines

        return is_time_valued(letter, statement.tokens)
    return letter == "b" or (letter in {"e", "f", "g", "h"}
                             and not _BEHAVIOURAL_KEYWORDS.isdisjoint(statement.tokens))


def _behavioural_tokens(statement: Statement, context: _Context) -> tuple[str, ...] | None:
    """A behavioural line's tokens with its expression's parameters substituted and its
    nodes and elements renamed (:func:`circuitnsds.netlist.behavioural.flat_tokens`)."""
    from circuitnsds.netlist.behavioural import flat_tokens  # only for a netlist with such lines

    letter = element_letter(statement.keyword)
    try:
        if letter in _TIME_VALUED:
            from circuitnsds.netlist.behavioural import time_valued_tokens

            return time_valued_tokens(statement.text, node=context.node, lookup=context.scope.lookup)
        return flat_tokens(letter, statement.text, node=context.node, element=context.element,
                           lookup=context.scope.lookup, function=context.scope.function)
    except ExpressionError as exc:
        where = f" (in instance {context.path})" if context.path else ""
        raise NetlistError(f"{statement.keyword}: {exc}{where}", where=statement.location,
                           hint=f"in: {statement.text}") from None


def _rename_code_model(tokens: list[str], context: _Context) -> None:
    """An XSPICE ``A`` line: every port node renamed (``%v``/``%vd`` markers, brackets and
    parentheses kept), the model (last token) renamed when local."""
    tokens[0] = context.prefixed(tokens[0])
    for index in range(1, len(tokens) - 1):
        token = tokens[index]
        core = token.strip("[]").lstrip("~")  # ~node: an inverted digital port
        if core and not core.startswith("%") and core not in _PUNCTUATION and core != "null":
            start = token.index(core)
            tokens[index] = token[:start] + context.node(core) + token[start + len(core):]
    if len(tokens) > 1:
        tokens[-1] = context.model(tokens[-1])


MAX_DEPTH = 100
"""Deepest subcircuit nesting accepted (a guard; recursion is detected before)."""

MAX_STATEMENTS = 250_000
"""Most statements the expansion of subcircuits may produce: each instance copies its
subcircuit, so 30 levels of two instances each would make 2^30 elements from a few lines
(250,000 elements take about a minute to read and check, 250 MB)."""


@dataclass(eq=False)
class SubcircuitDefinition:
    """One ``.subckt NAME ports... [params: a=1 ...]`` ... ``.ends`` block.

    Attributes:
        name: the subcircuit name (lower case).
        ports: its port nodes, in order.
        defaults: ``(name, expression)`` of its parameters, in order.
        statement: the ``.subckt`` line.
        parent: the definition it is written in, ``None`` at the top level.
        body: its statements, nested definitions excluded.
        children: definitions written inside it (visible only inside it).
        models: names of the models it defines (local to each instance).
        elements: names of the elements it defines.
        params: its ``.param`` definitions.
        functions: its ``.func`` lines.
    """

    name: str
    ports: tuple[str, ...]
    defaults: list[tuple[str, str]]
    statement: Statement
    parent: SubcircuitDefinition | None = None
    body: list[Statement] = field(default_factory=list)
    children: dict[str, SubcircuitDefinition] = field(default_factory=dict)
    models: set[str] = field(default_factory=set)
    elements: set[str] = field(default_factory=set)
    params: list[Definition] = field(default_factory=list)
    functions: list[Statement] = field(default_factory=list)


@dataclass
class _Structure:
    """A netlist split into its top-level body, definitions and global nodes."""

    body: list[Statement] = field(default_factory=list)
    definitions: dict[str, SubcircuitDefinition] = field(default_factory=dict)
    global_nodes: set[str] = field(default_factory=set)
    params: list[Definition] = field(default_factory=list)
    functions: list[Statement] = field(default_factory=list)


def _structure(statements: list[Statement]) -> _Structure:
    structure = _Structure()
    stack: list[SubcircuitDefinition] = []
    for statement in statements:
        keyword = statement.keyword
        if keyword == ".subckt":
            definition = _header(statement, stack[-1] if stack else None)
            siblings = stack[-1].children if stack else structure.definitions
            if definition.name in siblings:
                raise NetlistError(f"subcircuit {definition.name!r} is defined twice (first at "
                                   f"{siblings[definition.name].statement.location})",
                                   where=statement.location, hint="rename one of them")
            siblings[definition.name] = definition
            stack.append(definition)
        elif keyword == ".ends":
            if not stack:
                raise NetlistError(".ends without a .subckt", where=statement.location,
                                   hint="every .ends closes a .subckt NAME ... line")
            if len(statement.tokens) > 1 and statement.tokens[1] != stack[-1].name:
                raise NetlistError(f".ends {statement.tokens[1]} closes .subckt {stack[-1].name} "
                                   f"({stack[-1].statement.location})", where=statement.location,
                                   hint=f"write .ends {stack[-1].name} (or just .ends)")
            stack.pop()
        elif keyword == ".global":
            structure.global_nodes.update(t for t in statement.tokens[1:] if t not in GROUND_NAMES)
        elif stack:
            definition = stack[-1]
            definition.body.append(statement)
            if keyword == ".param":
                definition.params.extend(param_definitions(statement))
            elif keyword == ".func":
                definition.functions.append(statement)
            elif keyword == ".model" and len(statement.tokens) > 1:
                definition.models.add(statement.tokens[1])
            elif not statement.is_command:
                definition.elements.add(keyword)
        else:
            structure.body.append(statement)
            if keyword == ".param":
                structure.params.extend(param_definitions(statement))
            elif keyword == ".func":
                structure.functions.append(statement)
    if stack:
        raise NetlistError(f".subckt {stack[-1].name} has no .ends", where=stack[-1].statement.location,
                           hint=f"close the definition with .ends {stack[-1].name}")
    return structure


def _header(statement: Statement, parent: SubcircuitDefinition | None) -> SubcircuitDefinition:
    """Read ``.subckt NAME ports... [params:] [a=1 b={expr} ...]``."""
    positional, assignments = split_parameters(statement.text)
    words = tokenize(positional, strict=False)
    hint = "write .subckt NAME node1 node2 ... [params: name=value ...]"
    if len(words) < 2:
        raise NetlistError(".subckt has no name", where=statement.location, hint=hint)
    name, ports = words[1], words[2:]
    for port in ports:
        if port in _PUNCTUATION:
            raise NetlistError(f".subckt {name}: {port!r} cannot be a port", where=statement.location,
                               hint=hint)
        if ports.count(port) > 1:
            raise NetlistError(f".subckt {name}: port {port!r} is listed twice", where=statement.location)
    try:
        defaults = parse_assignments(assignments)
    except AssignmentSyntaxError as exc:
        raise NetlistError(f".subckt {name}: {exc}", where=statement.location, hint=hint) from None
    names = [n for n, _ in defaults]
    for parameter in names:
        if names.count(parameter) > 1:
            raise NetlistError(f".subckt {name}: parameter {parameter!r} is given twice",
                               where=statement.location)
    return SubcircuitDefinition(name, tuple(ports), defaults, statement, parent)


@dataclass
class _Context:
    """Where a statement is expanded: the instance path, its scope and its port map."""

    definition: SubcircuitDefinition | None
    path: str
    scope: Scope
    ports: dict[str, str]
    global_nodes: frozenset[str]
    parent: _Context | None = None

    def prefixed(self, name: str) -> str:
        """``name`` as seen from the top level (``x1.x2.name``)."""
        return f"{self.path}.{name}" if self.path else name

    def node(self, node: str) -> str:
        if self.definition is None or node in GROUND_NAMES:
            return node
        if node in self.ports:
            return self.ports[node]
        if node in self.global_nodes:
            return node
        return self.prefixed(node)

    def model(self, name: str) -> str:
        """The flat name of a model used here: local models are per instance, others global."""
        definition = self.definition
        while definition is not None:
            if name in definition.models:
                context: _Context | None = self
                while context is not None and context.definition is not definition:
                    context = context.parent
                return context.prefixed(name) if context is not None else name
            definition = definition.parent
        return name

    def is_local_model(self, name: str) -> bool:
        return self.model(name) != name

    def element(self, name: str) -> str:
        """The flat name of an element named by another (F/H/W control, K inductors)."""
        if self.definition is not None and name in self.definition.elements:
            return self.prefixed(name)
        return name

    def chain(self) -> Iterator[_Context]:
        context: _Context | None = self
        while context is not None:
            yield context
            context = context.parent


class _Flattener:
    def __init__(self, structure: _Structure, overrides: dict[str, float]):
        self.structure = structure
        self.replaced = overrides
        self.statements: list[Statement] = []
        self._sizes: dict[int, int] = {}

    def size(self, definition: SubcircuitDefinition, depth: int = 0) -> int:
        """How many statements one instance of ``definition`` expands to (its subcircuit
        instances counted through; an unknown or recursive one counts 0, and so do levels
        below :data:`MAX_DEPTH`: the expansion reports them, and a chain of 1000 levels
        must not exhaust Python's stack here first)."""
        key = id(definition)
        if key in self._sizes:
            return self._sizes[key]
        if depth > MAX_DEPTH:
            return 0
        self._sizes[key] = 0  # a recursive definition (refused by instance()) ends here
        total = 0
        for statement in definition.body:
            if statement.keyword == ".param":
                continue
            if not statement.is_command and element_letter(statement.keyword) == "x":
                words = tokenize(split_parameters(statement.text)[0], strict=False)
                child = self.find_from(words[-1], definition) if len(words) >= 2 else None
                total += self.size(child, depth + 1) if child is not None else 0
            else:
                total += 1
        self._sizes[key] = total
        return total

    def expand(self, body: list[Statement], context: _Context) -> None:
        for statement in body:
            keyword = statement.keyword
            if keyword in (".param", ".func"):
                continue
            elif not statement.is_command and element_letter(keyword) == "x":
                self.instance(statement, context)
            else:
                self.statements.append(self.flat_statement(statement, context))

    def flat_statement(self, statement: Statement, context: _Context) -> Statement:
        keyword = statement.keyword
        behavioural = _behavioural(statement)
        flat = _behavioural_tokens(statement, context) if behavioural else None
        if flat is not None:
            text = statement.text if context.definition is None else \
                f"{statement.text}   [in {context.path}]"
            return Statement((context.prefixed(flat[0]), *flat[1:]), statement.location, text)
        if not statement.is_command and element_letter(keyword) in {"s", "w"} and any(
                token.startswith("control") for token in statement.tokens[3:]):
            raise NetlistError(
                f"{keyword}: Xyce's generic switch (CONTROL={{expression}}) is not supported (ngspice "
                "refuses it too)", where=statement.location,
                hint=f"write a voltage-controlled switch, {keyword.upper()} n+ n- ctl 0 MODEL with "
                ".model MODEL SW(VT=0.5), and drive node ctl with the control: Bctl ctl 0 "
                "V={expression of v() and i()}, or a V source (PULSE, PWL) for a function of time")
        if (statement.is_command and keyword not in SUBSTITUTED_COMMANDS) or behavioural:
            tokens = list(statement.tokens)
        else:
            tokens = list(context.scope.substitute(statement))
        if context.definition is None:
            text = statement.text
            if keyword in (".meas", ".measure"):
                text = meas_with_parameters(text, context.scope.lookup)
            return Statement(tuple(tokens), statement.location, text)
        if keyword == ".model" and len(tokens) > 1:
            tokens[1] = context.model(tokens[1])
        elif keyword == ".ic":
            for index in range(len(tokens) - 3):
                if tokens[index] == "v" and tokens[index + 1] == "(" and tokens[index + 3] == ")":
                    tokens[index + 2] = context.node(tokens[index + 2])
        elif not statement.is_command:
            self.rename_element(tokens, context, behavioural)
        return Statement(tuple(tokens), statement.location, f"{statement.text}   [in {context.path}]")

    @staticmethod
    def rename_element(tokens: list[str], context: _Context, behavioural: bool = False) -> None:
        """Rename an element line's name, nodes, local models and named elements in place."""
        if element_letter(tokens[0]) == "a":
            _rename_code_model(tokens, context)
            return
        layout = letter_of(tokens[0])
        nodes, controls = layout.node_indexes(tokens), layout.controls
        if behavioural:  # only the output nodes are known (the elaborator refuses the rest)
            nodes, controls = tuple(range(1, min(3, len(tokens)))), ()
        tokens[0] = context.prefixed(tokens[0])
        for index in nodes:
            if tokens[index] not in _PUNCTUATION:
                tokens[index] = context.node(tokens[index])
        for index in controls:
            if index < len(tokens):
                tokens[index] = context.element(tokens[index])
        for index in range(1 + max(nodes, default=0), len(tokens)):
            beside_equals = "=" in (tokens[index - 1], tokens[index + 1] if index + 1 < len(tokens) else "")
            if index not in controls and not beside_equals and context.is_local_model(tokens[index]):
                tokens[index] = context.model(tokens[index])

    def find(self, name: str, context: _Context) -> SubcircuitDefinition | None:
        return self.find_from(name, context.definition)

    def find_from(self, name: str, definition: SubcircuitDefinition | None) -> SubcircuitDefinition | None:
        """The subcircuit ``name`` as seen from inside ``definition`` (``None``: the top level)."""
        while definition is not None:
            if name in definition.children:
                return definition.children[name]
            definition = definition.parent
        return self.structure.definitions.get(name)

    def visible(self, context: _Context) -> list[str]:
        names = set(self.structure.definitions)
        definition = context.definition
        while definition is not None:
            names.update(definition.children)
            definition = definition.parent
        return sorted(names)

    def instance(self, statement: Statement, context: _Context) -> None:
        """Expand ``Xname nodes... SUBCKT [name=value ...]`` in ``context``."""
        name = statement.keyword
        positional, assignments = split_parameters(statement.text)
        words = tokenize(positional, strict=False)
        hint = "write Xname node1 node2 ... SUBCKTNAME [name=value ...]"
        if len(words) < 2:
            raise NetlistError(f"{name}: missing subcircuit name", where=statement.location, hint=hint)
        nodes, subcircuit = words[1:-1], words[-1]
        definition = self.find(subcircuit, context)
        if definition is None:
            known = ", ".join(self.visible(context)) or "none"
            raise NetlistError(f"{name}: subcircuit {subcircuit!r} is not defined", where=statement.location,
                               hint=f"defined here: {known}; add its .subckt ... .ends block or the "
                               ".include/.lib line that provides it")
        callers = [c for c in context.chain() if c.definition is not None]
        if any(c.definition is definition for c in callers):
            path = " -> ".join(f"{c.path} ({c.definition.name})" for c in reversed(callers))
            raise NetlistError(f"{name}: subcircuit {subcircuit!r} instantiates itself "
                               f"({path} -> {context.prefixed(name)} ({subcircuit}))",
                               where=statement.location, hint="a subcircuit cannot contain itself")
        if len(callers) >= MAX_DEPTH:
            raise NetlistError(f"{name}: subcircuits nested deeper than {MAX_DEPTH} levels",
                               where=statement.location)
        if len(nodes) != len(definition.ports):
            raise NetlistError(
                f"{name}: subcircuit {subcircuit} has {len(definition.ports)} ports "
                f"({' '.join(definition.ports) or 'none'}), the instance gives {len(nodes)} nodes "
                f"({' '.join(nodes) or 'none'})", where=statement.location,
                hint=f".subckt {subcircuit} is at {definition.statement.location}; {hint}")
        size = self.size(definition)
        if len(self.statements) + size > MAX_STATEMENTS:
            raise NetlistError(
                f"{name}: expanding subcircuit {subcircuit!r} would make {size:,} more statements "
                f"({len(self.statements):,} already), beyond the limit of {MAX_STATEMENTS:,}",
                where=statement.location,
                hint="each instance copies every element of its subcircuit, so nested instances "
                "multiply: check the nesting (a subcircuit instantiating two of the level below, "
                "30 levels deep, is 2^30 elements)")
        path = context.prefixed(name)
        scope = Scope(parent=context.scope, label=path)
        for parameter, value in self.overrides(statement, assignments, definition, context).items():
            scope.set_value(parameter, value)
        location, text = definition.statement.location, definition.statement.text
        for parameter, expression in definition.defaults:
            if parameter not in scope.values:
                scope.define(Definition(parameter, expression, location, text))
        for statement_ in definition.functions:
            scope.define_function(func_definition(statement_), statement_.location)
        for param in definition.params:
            if param.name in self.replaced:
                scope.set_value(param.name, self.replaced[param.name])
            else:
                scope.define(param)
        scope.evaluate_all()
        ports = {port: context.node(node) for port, node in zip(definition.ports, nodes)}
        for port, node in zip(definition.ports, nodes):
            if port in GROUND_NAMES and context.node(node) not in GROUND_NAMES:
                warnings.warn(f"{statement.location}: {name}: port {port!r} of .subckt {subcircuit} is "
                              f"ground inside it (ground is global, as in ngspice): node {node!r} is not "
                              f"connected to it; name the port otherwise to pass {node!r} in",
                              NetlistWarning, stacklevel=2)
        inner = _Context(definition, path, scope, ports, context.global_nodes, parent=context)
        self.expand(definition.body, inner)

    @staticmethod
    def overrides(statement: Statement, assignments: str, definition: SubcircuitDefinition,
                  context: _Context) -> dict[str, float]:
        """Instance parameter values, evaluated in the caller's scope."""
        name = statement.keyword
        try:
            pairs = parse_assignments(assignments)
        except AssignmentSyntaxError as exc:
            raise NetlistError(f"{name}: {exc}", where=statement.location,
                               hint="instance parameters are written name=value after the "
                               "subcircuit name") from None
        declared = [n for n, _ in definition.defaults]
        values: dict[str, float] = {}
        for parameter, expression in pairs:
            if parameter not in declared:
                listed = ", ".join(declared) or "none"
                raise NetlistError(f"{name}: subcircuit {definition.name} has no parameter {parameter!r} "
                                   f"(its parameters: {listed})", where=statement.location,
                                   hint=f"declare it: .subckt {definition.name} ... "
                                   f"params: {parameter}=DEFAULT")
            if parameter in values:
                raise NetlistError(f"{name}: parameter {parameter!r} is given twice",
                                   where=statement.location)
            values[parameter] = context.scope.evaluate(expression, statement,
                                                       f"{name}: parameter {parameter}")
        return values


_MEAS_EXPRESSION = re.compile(r"(\bpar(?:am)?\s*(?:=\s*|\(\s*))('[^']*'|\{[^}]*\})", re.IGNORECASE)
_NAME = re.compile(r"\b[vi]\s*\([^()]*\)|(?<![\w.])([a-z_]\w*)\b(?!\s*\()", re.IGNORECASE)
"""A probe (kept as written) or a name that is not a function's."""


def meas_with_parameters(text: str, lookup: Callable[[str], float | None]) -> str:
    """A ``.meas`` line with the ``.param`` names inside its ``PARAM='expr'`` and ``par('expr')``
    expressions replaced by their values, as ngspice's numparam does when it reads the line
    (``.param fval=5`` then ``.meas tran yadd param='fval + 7'`` is 12); names that are not
    parameters (earlier measurements, functions, ``v(...)``) are left to the measurement."""
    def values(match: re.Match) -> str:
        def value(name: re.Match) -> str:
            if name[1] is None:  # v(...), i(...): a signal, its node names are not parameters
                return name[0]
            try:
                found = lookup(name[1].lower())
            except NetlistError:
                found = None
            return repr(found) if found is not None else name[0]

        return match[1] + _NAME.sub(value, match[2])

    return _MEAS_EXPRESSION.sub(values, text)


def flatten(netlist: Netlist, params: Mapping[str, float] | None = None,
            random: Random | None = None) -> Netlist:
    """Evaluate parameters and expand subcircuits (includes must be expanded already).

    Args:
        netlist: the statements, includes expanded.
        params: parameter values replacing the ``.param`` definitions of the same name
            (names lower case), at the top level and in subcircuit bodies; a name no
            ``.param`` defines becomes a top-level parameter (as LTspice's ``.step param``).
            A subcircuit's ``params:`` defaults are its interface and are not replaced:
            give them ``{expressions}`` of top-level parameters to sweep them.
        random: the generator of the Monte Carlo functions (``agauss`` ...); without one,
            a netlist using them is an error.

    ``.if``/``.elseif``/``.else``/``.endif`` blocks are resolved first
    (:mod:`circuitnsds.netlist.conditionals`).

    Returns:
        a new :class:`Netlist` with the same title, file and ``ended`` flag, whose
        statements contain no ``.param``, ``.subckt``, ``.ends``, ``.global`` or ``X``
        line and no ``{expr}`` token in element, ``.model``, ``.tran`` and ``.ic`` lines.

    Raises:
        NetlistError: with file:line, for malformed definitions, undefined or cyclic
            parameters, unknown or recursive subcircuits, port-count mismatches.
    """
    overrides = {name.lower(): float(value) for name, value in (params or {}).items()}
    structure = _structure(resolve_conditionals(netlist.statements, overrides, random))
    scope = Scope(random=random)
    for statement in structure.functions:
        scope.define_function(func_definition(statement), statement.location)
    for definition in structure.params:
        if definition.name not in overrides:
            scope.define(definition)
    for name, value in overrides.items():
        scope.set_value(name, value)
    scope.evaluate_all()
    flattener = _Flattener(structure, overrides)
    top = _Context(None, "", scope, {}, frozenset(structure.global_nodes))
    flattener.expand(structure.body, top)
    return replace(netlist, statements=flattener.statements)
