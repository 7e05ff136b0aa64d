"""Behavioural sources: ``B n+ n- V={expr}`` / ``I={expr}``, ``E``/``G`` with ``VALUE={expr}``
and ``TABLE {expr} = (x, y) ...``.

The expression (read by :mod:`circuitnsds.netlist.behavioural`) is classified into what the
ideal engine represents exactly (:mod:`circuitnsds.circuit.elements.behavioural`):

* affine in ``v(x)``, ``v(x, y)``, ``i(vsource)``: a linear controlled source (several
  terms allowed);
* ``min``, ``max``, ``abs``, ``uramp`` and ``limit(x, lo, hi) = min(max(x, lo), hi)`` of affine
  values: one complementarity pair per ``min``/``max`` (no smoothing);
* ``TABLE`` of one affine argument: the piecewise-linear interpolation, held at the end
  values outside the table, as a sum of clamped ramps (two pairs per segment);
* a comparison ``a > b`` / ``a < b`` (``>=``, ``<=`` alike; value 1 or 0), ``c ? a : b``,
  ``if(c, a, b)`` and ``u(x)`` (``x > 0``) whose condition compares two such values and whose
  branches are such values: a comparator (:class:`Select`), an ideal switch of the engine whose
  instant is located (it is in ``waves.events`` as ``name.cmpK``).

Any other expression of ``v()``, ``i()``, ``time`` and ``temper`` (a product or quotient of
unknowns, a nonlinear function of one, ``&&``/``||``/``!``, ``==``) is a smooth nonlinear
source (:class:`~circuitnsds.circuit.elements.behavioural_smooth.SmoothBehaviouralSource`,
its derivatives from :mod:`circuitnsds.netlist.smooth_expression`), which the Newton stepper
integrates. Refused, with the term named: an unknown function, a constant that is undefined,
``hertz``, a ``TABLE`` of a nonaffine argument.

``ddt(x)`` of an affine ``x``, added to the value times a constant, is a capacitor-like term
(:attr:`Affine.rates`, stamped in ``E``); ``ddt()`` anywhere else is refused as nonlinear.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from circuitnsds.circuit.elements.behavioural import Affine, BehaviouralSource, MinMax, Select
from circuitnsds.circuit.elements.behavioural_smooth import SmoothBehaviouralSource
from circuitnsds.frontend.cards.reader import StatementReader, node_name
from circuitnsds.netlist.behavioural import Node, parse, to_text
from circuitnsds.netlist.expressions import FUNCTIONS, ExpressionError
from circuitnsds.netlist.smooth_expression import smooth_expression

NONLINEAR = "nonlinear (a smooth nonlinear device: issue 33)"
"""What a smooth nonlinear term is called in refusals (the next issue brings such devices)."""
REPRESENTABLE = ("write the value with what the ideal engine represents: affine combinations "
                 "of v(node), v(node1, node2), i(vsource) and constants, min(), max(), abs(), "
                 "uramp(), limit(x, lo, hi) of them (exact complementarity pairs), comparisons "
                 "a > b, a < b (1 or 0), c ? a : b, if(c, a, b), u(x) whose condition compares "
                 "two of them (a comparator: an event-located switch), TABLE of one affine "
                 "argument, and ddt() of an affine value added to the value (a capacitor-like term)")
SWITCHING = {"u2": "u2()", "sgn": "sgn()", "ternary_fcn": "ternary_fcn()", "floor": "floor()",
             "ceil": "ceil()", "nint": "nint()", "int": "int()"}
"""Functions whose value jumps in ways not written as one comparison: refused."""
SWITCHING_HINT = ("only a single comparison (a > b, a < b, a >= b, a <= b) of two affine values "
                  "is a comparator; write it as c ? a : b, if(c, a, b) or u(x), or combine "
                  "comparators arithmetically")
COMPARISONS = {">": 1.0, ">=": 1.0, "<": -1.0, "<=": -1.0}
"""Comparison operators and the sign of ``left - right`` that is positive when they hold."""


class Unrepresentable(ValueError):
    """A term the ideal engine cannot represent.

    Attributes:
        term: the term as text (fully parenthesised).
        reason: why, in words.
    """

    def __init__(self, term: str, reason: str):
        self.term = term
        self.reason = reason
        super().__init__(f"cannot represent {term}: {reason}")


@dataclass
class Linear:
    """An affine value under construction: ``terms[key]·unknown + constant``;
    keys are ``("v", node)``, ``("i", source)`` or ``("x", k)``."""

    terms: dict[tuple[str, object], float] = field(default_factory=dict)
    constant: float = 0.0

    @property
    def is_constant(self) -> bool:
        return not self.terms

    def scaled(self, factor: float) -> Linear:
        return Linear({k: c * factor for k, c in self.terms.items()}, self.constant * factor)

    def plus(self, other: Linear, sign: float = 1.0) -> Linear:
        terms = dict(self.terms)
        for key, c in other.terms.items():
            terms[key] = terms.get(key, 0.0) + sign * c
        return Linear({k: c for k, c in terms.items() if c != 0.0},
                      self.constant + sign * other.constant)

    @property
    def has_rates(self) -> bool:
        return any(k[0] == "d" for k in self.terms)

    def affine(self) -> Affine:
        return Affine(
            voltages=tuple((k[1], c) for k, c in self.terms.items() if k[0] == "v"),
            currents=tuple((k[1], c) for k, c in self.terms.items() if k[0] == "i"),
            auxiliaries=tuple((k[1], c) for k, c in self.terms.items() if k[0] == "x"),
            constant=self.constant,
            rates=tuple((k[1], c) for k, c in self.terms.items() if k[0] == "d"),
        )


class Classifier:
    """Turns expression trees into :class:`Linear` values, collecting the ``min``/``max``
    auxiliaries they need (in ``auxiliaries``)."""

    def __init__(self, name: str = "") -> None:
        self.auxiliaries: list[MinMax | Select] = []
        self.name = name

    def value(self, tree: Node) -> Linear:
        kind = tree[0]
        if kind == "num":
            return Linear(constant=float(tree[1]))
        if kind == "v":
            value = self.voltage(tree[1])
            return value if tree[2] is None else value.plus(self.voltage(tree[2]), -1.0)
        if kind == "i":
            return Linear({("i", tree[1]): 1.0})
        if kind == "name":
            if tree[1] == "time":
                raise Unrepresentable("time", "time-dependent terms are not mapped: write the time "
                                      "function as an independent source (V with PULSE, SIN, PWL) "
                                      "and use its v()")
            raise Unrepresentable(tree[1], "a simulator variable the ideal engine does not provide")
        if kind == "neg":
            return self.value(tree[1]).scaled(-1.0)
        if kind == "op":
            return self.operation(tree)
        if kind == "call":
            return self.call(tree)
        if kind == "if":
            return self.select(tree[1], tree[2], tree[3])
        if kind in {"and", "or", "not"}:
            raise Unrepresentable(to_text(tree), f"a logical operation: {SWITCHING_HINT}")
        raise Unrepresentable(to_text(tree), "unknown construct")

    @staticmethod
    def voltage(node: str) -> Linear:
        node = node_name(node)
        return Linear() if node == "0" else Linear({("v", node): 1.0})

    def operation(self, tree: Node) -> Linear:
        if tree[1] in COMPARISONS:
            return self.select(tree, ("num", 1.0), ("num", 0.0))
        op, left, right = tree[1], self.value(tree[2]), self.value(tree[3])
        text = to_text(tree)
        if op in {"+", "-"}:
            return left.plus(right, 1.0 if op == "+" else -1.0)
        if op == "*":
            if left.is_constant:
                return right.scaled(left.constant)
            if right.is_constant:
                return left.scaled(right.constant)
            raise Unrepresentable(text, f"a product of two unknowns is {NONLINEAR}")
        if op == "/":
            if not right.is_constant:
                raise Unrepresentable(text, f"division by an unknown is {NONLINEAR}")
            if right.constant == 0:
                raise Unrepresentable(text, "division by zero")
            return left.scaled(1.0 / right.constant)
        if op == "^":
            if left.is_constant and right.is_constant:
                return Linear(constant=self.number(text, math.pow, left.constant, right.constant))
            if right.is_constant and right.constant == 1.0:
                return left
            raise Unrepresentable(text, f"a power of an unknown is {NONLINEAR}")
        raise Unrepresentable(text, f"the comparison {op!r} (equality is not a switching "
                              f"threshold): {SWITCHING_HINT}")

    def condition(self, tree: Node) -> Linear:
        """The affine difference that is positive where comparison ``tree`` holds."""
        if tree[0] != "op" or tree[1] not in COMPARISONS:
            raise Unrepresentable(to_text(tree), f"a condition that is not one comparison: "
                                  f"{SWITCHING_HINT}")
        left, right = self.value(tree[2]), self.value(tree[3])
        return left.plus(right, -1.0).scaled(COMPARISONS[tree[1]])

    def select(self, condition: Node, on: Node, off: Node) -> Linear:
        """``on`` where ``condition`` holds, else ``off``: a new comparator auxiliary, or the
        branch itself when the condition is constant. A condition of ``&&``, ``||`` and ``!``
        of comparisons is a chain of comparators: ``p && q ? a : b`` is ``p ? (q ? a : b) : b``,
        ``p || q ? a : b`` is ``p ? a : (q ? a : b)``, ``!p ? a : b`` is ``p ? b : a``."""
        if condition[0] == "and":
            return self.select(condition[1], ("if", condition[2], on, off), off)
        if condition[0] == "or":
            return self.select(condition[1], on, ("if", condition[2], on, off))
        if condition[0] == "not":
            return self.select(condition[1], off, on)
        difference = self.condition(condition)
        if difference.is_constant:
            return self.value(on if difference.constant > 0 else off)
        chosen, other = self.value(on), self.value(off)
        if difference.has_rates or chosen.has_rates or other.has_rates:
            raise Unrepresentable(to_text(condition), f"a comparison or choice involving ddt() "
                                  f"is {NONLINEAR}; ddt() may only be added to the value, times a "
                                  "constant")
        count = sum(isinstance(a, Select) for a in self.auxiliaries)
        self.auxiliaries.append(Select(difference.affine(), chosen.affine(), other.affine(),
                                       name=f"{self.name}.cmp{count}"))
        return Linear({("x", len(self.auxiliaries) - 1): 1.0})

    def call(self, tree: Node) -> Linear:
        name, text = tree[1], to_text(tree)
        if name in SWITCHING:
            raise Unrepresentable(text, f"{SWITCHING[name]}: {SWITCHING_HINT}")
        if name == "if" and len(tree[2]) == 3:
            return self.select(*tree[2])
        if name == "u" and len(tree[2]) == 1:
            return self.select(("op", ">", tree[2][0], ("num", 0.0)), ("num", 1.0), ("num", 0.0))
        args = [self.value(a) for a in tree[2]]
        if name == "ddt" and len(args) == 1:
            return self.rate(text, args[0])
        if name in {"min", "max"} and len(args) >= 2:
            result = args[0]
            for other in args[1:]:
                result = self.minmax(name, result, other)
            return result
        if name == "limit" and len(args) == 3:
            return self.minmax("min", self.minmax("max", args[0], args[1]), args[2])
        if name == "abs" and len(args) == 1:
            return self.minmax("max", args[0], args[0].scaled(-1.0))
        if name == "uramp" and len(args) == 1:
            return self.minmax("max", args[0], Linear())
        if all(a.is_constant for a in args) and name in FUNCTIONS:
            function, least, most, _ = FUNCTIONS[name]
            if len(args) < least or (most is not None and len(args) > most):
                raise Unrepresentable(text, f"{name}() takes {least} argument(s)")
            return Linear(constant=self.number(text, function, *(a.constant for a in args)))
        if name in FUNCTIONS:
            raise Unrepresentable(text, f"{name}() of an unknown is {NONLINEAR}")
        raise Unrepresentable(text, f"unknown function {name}()")

    @staticmethod
    def rate(text: str, argument: Linear) -> Linear:
        """``ddt(argument)`` of an affine argument of node voltages and source currents: the
        same combination of their time derivatives (the constant drops), exact for the ideal
        engine; of anything else a smooth nonlinear term (issue 33)."""
        if any(key[0] in {"x", "d"} for key in argument.terms):
            raise Unrepresentable(text, "ddt() of a min/max, comparator or ddt() value is "
                                  f"{NONLINEAR}; ddt() of an affine combination of v() and i() "
                                  "is supported")
        return Linear({("d", key): c for key, c in argument.terms.items()})

    def minmax(self, kind: str, a: Linear, b: Linear) -> Linear:
        """``max(a, b)`` or ``min(a, b)``: a constant when both are, else a new auxiliary."""
        for value in (a, b):
            if value.has_rates:
                raise Unrepresentable(f"{kind}(...)", f"a {kind}() of a ddt() term is {NONLINEAR}; "
                                      "ddt() may only be added to the value, times a constant")
        if a.is_constant and b.is_constant:
            return Linear(constant=(max if kind == "max" else min)(a.constant, b.constant))
        self.auxiliaries.append(MinMax(kind, a.affine(), b.affine()))
        return Linear({("x", len(self.auxiliaries) - 1): 1.0})

    @staticmethod
    def number(text: str, function, *args: float) -> float:
        try:
            value = float(function(*args))
        except (ValueError, ZeroDivisionError, OverflowError):
            raise Unrepresentable(text, "undefined for these constant arguments") from None
        if not math.isfinite(value):
            raise Unrepresentable(text, "not a finite number")
        return value

    def table(self, argument: Linear, points: list[tuple[float, float]]) -> Linear:
        """The piecewise-linear interpolation of ``points`` at ``argument``, held at the first
        and last values outside: ``y_1 + Σ_k s_k·(limit(u, x_k, x_k+1) - x_k)``."""
        result = Linear(constant=points[0][1])
        for (x0, y0), (x1, y1) in zip(points, points[1:]):
            if y1 == y0:
                continue
            clamped = self.minmax("min", self.minmax("max", argument, Linear(constant=x0)),
                                  Linear(constant=x1))
            slope = (y1 - y0) / (x1 - x0)
            result = result.plus(clamped.plus(Linear(constant=x0), -1.0).scaled(slope))
        return result


def classify(text: str) -> tuple[Linear, list[MinMax | Select]]:
    """The value of expression ``text`` and the auxiliaries it needs.

    Raises:
        ExpressionError: the text is not an expression.
        Unrepresentable: a term the ideal engine cannot represent.
    """
    classifier = Classifier()
    value = classifier.value(parse(text))
    return value, classifier.auxiliaries


def behavioural_source(reader: StatementReader, letter: str,
                       voltage_sources: set[str]) -> BehaviouralSource:
    """A ``B`` line, or an ``E``/``G`` line with ``VALUE=`` or ``TABLE`` (tokens as
    :func:`circuitnsds.netlist.behavioural.flat_tokens` writes them)."""
    name = reader.name
    nodes = reader.nodes(2)
    key = reader.next("V=, I=, VALUE= or TABLE")
    if key not in {"v", "i", "value", "table"} or (key != "table" and reader.peek() != "="):
        form = "V={expr} or I={expr}" if letter == "b" else "VALUE={expr} or TABLE {expr} = (x, y) ..."
        raise reader.error(f"{name}: expected {form} after the two nodes",
                           hint=f"write {name.upper()} n+ n- {form}")
    classifier = Classifier(name)
    output = key if letter == "b" else ("v" if letter == "e" else "i")
    try:
        if key == "table":
            expression = reader.next("table expression")[1:-1]
            reader.next("=")
            value = _table(reader, classifier, expression)
        else:
            reader.next("=")
            expression = reader.next("expression")[1:-1]
            value = classifier.value(parse(expression))
    except Unrepresentable as exc:
        if key == "table" or not smooth_allowed(exc):
            raise reader.error(f"{name}: cannot represent the term {exc.term} of {expression}: "
                               f"{exc.reason}", hint=REPRESENTABLE) from None
        return _smooth_source(reader, output, nodes, expression, voltage_sources)
    except ExpressionError as exc:
        raise reader.error(f"{name}: {exc}") from None
    controls = _controls(value, classifier.auxiliaries)
    for source in controls[1]:
        if source not in voltage_sources:
            raise reader.error(f"{name}: i({source}): {source!r} is not a voltage source of this "
                               "circuit", hint="i() senses the current of a V source; add a 0 V "
                               "source in series with the branch to sense")
    if "limit(" in expression.replace(" ", ""):
        reader.warn(f"{name}: limit(x, lo, hi) is read as the clamp min(max(x, lo), hi) "
                    "(LTspice's meaning); ngspice's B source does not clamp with it: for a netlist "
                    "that means the same in both, write min(max(x, lo), hi)")
    return BehaviouralSource(name, (*nodes, *controls[0]), reader.location, output=output,
                             value=value.affine(), auxiliaries=tuple(classifier.auxiliaries),
                             expression=expression)


NOT_SMOOTH = ("undefined for these constant arguments", "not a finite number", "division by zero",
              "unknown function", "argument(s)", "unknown construct")
"""Reasons of a refusal that a smooth expression would not lift either (they stay errors)."""


def smooth_allowed(refusal: Unrepresentable) -> bool:
    """Whether an expression the ideal engine refuses becomes a smooth nonlinear source (a
    product, a nonlinear function, ``time``, a logical operation: not a constant that is
    undefined or an unknown name)."""
    if "ddt(" in refusal.term.replace(" ", "") or "ddt()" in refusal.reason:
        return False  # (the smooth relations hold no derivative of an unknown: ddt stays refused)
    return not any(reason in refusal.reason for reason in NOT_SMOOTH)


def _smooth_source(reader: StatementReader, output: str, nodes: list[str], expression: str,
                   voltage_sources: set[str]) -> SmoothBehaviouralSource:
    """The source of a nonlinear ``expression``: a smooth relation the Newton stepper
    linearises (:mod:`circuitnsds.netlist.smooth_expression`)."""
    name = reader.name
    try:
        smooth = smooth_expression(parse(expression), node_name)
    except ExpressionError as exc:
        raise reader.error(f"{name}: {exc} in {expression}", hint="write the value with v(), i(), "
                           "time, numbers and the functions .param expressions know; ddt() only "
                           "of an affine combination of v() and i(), added to the value") from None
    for kind, source in smooth.inputs:
        if kind == "i" and source not in voltage_sources:
            raise reader.error(f"{name}: i({source}): {source!r} is not a voltage source of this "
                               "circuit", hint="i() senses the current of a V source; add a 0 V "
                               "source in series with the branch to sense")
    controls = [node for kind, node in smooth.inputs if kind == "v"]
    if "limit(" in expression.replace(" ", ""):
        reader.warn(f"{name}: limit(x, lo, hi) is read as the clamp min(max(x, lo), hi) "
                    "(LTspice's meaning); ngspice's B source does not clamp with it: for a netlist "
                    "that means the same in both, write min(max(x, lo), hi)")
    return SmoothBehaviouralSource(name, (*nodes, *controls), reader.location, output=output,
                                   expression=expression, inputs=smooth.inputs,
                                   law=smooth.evaluate, uses_time=smooth.uses_time)


def _table(reader: StatementReader, classifier: Classifier, expression: str) -> Linear:
    numbers = [reader.value("table value") for _ in range(len(reader.tokens) - reader.position)]
    if len(numbers) < 2 or len(numbers) % 2:
        raise reader.error(f"{reader.name}: TABLE needs (x, y) pairs, got {len(numbers)} numbers",
                           hint="write TABLE {expr} = (x1, y1) (x2, y2) ...")
    points = list(zip(numbers[0::2], numbers[1::2]))
    if any(b[0] <= a[0] for a, b in zip(points, points[1:])):
        raise reader.error(f"{reader.name}: TABLE x values must increase",
                           hint="list the points in order of increasing input")
    return classifier.table(classifier.value(parse(expression)), points)


def _controls(value: Linear, auxiliaries: list[MinMax | Select]) -> tuple[list[str], list[str]]:
    """Nodes and voltage sources the value reads (in order of first use)."""
    nodes: dict[str, None] = {}
    sources: dict[str, None] = {}
    parts = [value.affine()]
    for aux in auxiliaries:
        parts += [aux.control, aux.on, aux.off] if isinstance(aux, Select) else [aux.a, aux.b]
    for affine in parts:
        nodes.update((n, None) for n, _ in affine.voltages)
        sources.update((s, None) for s, _ in affine.currents)
        nodes.update((name, None) for (kind, name), _ in affine.rates if kind == "v")
        sources.update((name, None) for (kind, name), _ in affine.rates if kind == "i")
    return list(nodes), list(sources)
