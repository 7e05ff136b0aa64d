"""A behavioural expression as a differentiable function of the circuit's unknowns.

An expression that is not affine (``v(a)*v(b)``, ``1e-12*(exp(v(x)/0.025)-1)``,
``sqrt(abs(v(c)))``, ``time*v(in)``) is evaluated at run time together with its gradient
(forward-mode differentiation: every node of the tree returns its value and its derivatives
with respect to the inputs), which is what a Newton iteration linearises with.

The inputs are the expression's probes in order of first appearance: ``("v", node)`` for a
node voltage [V] (``v(a, b)`` reads two inputs, ground none) and ``("i", element)`` for a
branch current [A]; ``time`` [s] is an argument of its own. The functions mean what they
mean in ngspice's B source (its parse-tree functions): ``x^y``, ``x**y`` and ``pow(x, y)``
are ``|x|^y``; ``pwr(x, y)`` is ``sign(x)·|x|^y``; ``u(x)`` is the unit step (½ at 0),
``uramp(x)`` ``max(x, 0)``, ``u2(x)`` ``min(max(x, 0), 1)``; comparisons, ``&&``, ``||``,
``!`` and ``c ? a : b`` give 1 or 0 (a nonzero condition is true) with derivative 0; only
the branch chosen is evaluated. ``temper`` is 27 (°C, the default temperature).

Points where a function has no derivative (``abs`` at 0, a comparison's threshold) take
the derivative of one side; an argument out of a function's domain (``sqrt`` of a negative
number, ``log`` of 0) or an overflow makes the value ``nan``, which the caller treats as a
failed evaluation (a Newton iteration then backs off).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from circuitnsds.netlist.behavioural import Node, to_text
from circuitnsds.netlist.expressions import ExpressionError

Key = tuple[str, str]
"""An input: ``("v", node)`` or ``("i", element)``."""
Gradient = np.ndarray | None
"""Derivatives with respect to the inputs (``None``: all zero)."""
Evaluator = Callable[[Sequence[float], float], tuple[float, Gradient]]

TEMPERATURE = 27.0
"""``temper`` [°C]: the nominal temperature (ngspice's default ``.options temp``)."""

_UNARY: dict[str, tuple[Callable[[float], float], Callable[[float, float], float]]] = {
    # name: (function, derivative(x, value))
    "exp": (math.exp, lambda x, v: v),
    "log": (math.log, lambda x, v: 1.0 / x),
    "ln": (math.log, lambda x, v: 1.0 / x),
    "log10": (math.log10, lambda x, v: 1.0 / (x * math.log(10.0))),
    "sqrt": (math.sqrt, lambda x, v: 0.5 / v if v else math.inf),
    "sin": (math.sin, lambda x, v: math.cos(x)),
    "cos": (math.cos, lambda x, v: -math.sin(x)),
    "tan": (math.tan, lambda x, v: 1.0 + v * v),
    "asin": (math.asin, lambda x, v: 1.0 / math.sqrt(1.0 - x * x)),
    "acos": (math.acos, lambda x, v: -1.0 / math.sqrt(1.0 - x * x)),
    "atan": (math.atan, lambda x, v: 1.0 / (1.0 + x * x)),
    "sinh": (math.sinh, lambda x, v: math.cosh(x)),
    "cosh": (math.cosh, lambda x, v: math.sinh(x)),
    "tanh": (math.tanh, lambda x, v: 1.0 - v * v),
    "asinh": (math.asinh, lambda x, v: 1.0 / math.sqrt(x * x + 1.0)),
    "acosh": (math.acosh, lambda x, v: 1.0 / math.sqrt(x * x - 1.0)),
    "atanh": (math.atanh, lambda x, v: 1.0 / (1.0 - x * x)),
    "abs": (abs, lambda x, v: 1.0 if x >= 0 else -1.0),
    "uramp": (lambda x: x if x > 0 else 0.0, lambda x, v: 1.0 if x > 0 else 0.0),
    "u2": (lambda x: min(max(x, 0.0), 1.0), lambda x, v: 1.0 if 0.0 < x < 1.0 else 0.0),
}
"""Differentiable functions of one argument."""
_STEPS: dict[str, Callable[[float], float]] = {
    "u": lambda x: 1.0 if x > 0 else 0.0 if x < 0 else 0.5,
    "sgn": lambda x: 1.0 if x > 0 else -1.0 if x < 0 else 0.0,
    "floor": lambda x: float(math.floor(x)),
    "ceil": lambda x: float(math.ceil(x)),
    "nint": lambda x: float(round(x)),
    "int": lambda x: float(int(x)),
}
"""Piecewise-constant functions of one argument (derivative 0)."""
_COMPARE: dict[str, Callable[[float, float], bool]] = {
    ">": lambda a, b: a > b, "<": lambda a, b: a < b, ">=": lambda a, b: a >= b,
    "<=": lambda a, b: a <= b, "==": lambda a, b: a == b, "!=": lambda a, b: a != b,
}
FUNCTION_NAMES = frozenset({*_UNARY, *_STEPS, "min", "max", "pow", "pwr", "pwrs", "limit", "if",
                            "ternary_fcn", "atan2", "hypot"})
"""The functions a smooth behavioural expression may call."""


def _plus(a: Gradient, b: Gradient, sign: float = 1.0) -> Gradient:
    if b is None:
        return a
    if a is None:
        return b if sign == 1.0 else -b
    return a + b if sign == 1.0 else a - b


def _scaled(a: Gradient, factor: float) -> Gradient:
    return None if a is None else a * factor


@dataclass(frozen=True)
class SmoothExpression:
    """An expression, its inputs and its evaluator.

    Attributes:
        text: the expression as written back (for messages).
        inputs: the probes it reads, in the order of ``x`` (see the module docstring).
        uses_time: whether it reads ``time``.
        evaluator: ``evaluator(x, t)`` → ``(value, gradient)``; ``gradient`` has one entry
            per input, or is ``None`` when the value does not depend on them.
    """

    text: str
    inputs: tuple[Key, ...]
    uses_time: bool
    evaluator: Evaluator

    def evaluate(self, x: Sequence[float], t: float) -> tuple[float, np.ndarray]:
        """Value and gradient (an array, zeros where the value does not depend on an input);
        ``nan`` where the expression is undefined or overflows."""
        try:
            value, gradient = self.evaluator(x, t)
        except (ValueError, ZeroDivisionError, OverflowError):
            return math.nan, np.full(len(self.inputs), math.nan)
        if gradient is None:
            gradient = np.zeros(len(self.inputs))
        return float(value), gradient


def smooth_expression(tree: Node, node_name: Callable[[str], str] = lambda n: n
                      ) -> SmoothExpression:
    """The :class:`SmoothExpression` of ``tree`` (from
    :func:`circuitnsds.netlist.behavioural.parse`, parameters already substituted);
    ``node_name`` canonicalises a node's name (``"0"`` is ground).

    Raises:
        ExpressionError: an unknown function, a wrong number of arguments, a name that is
            not ``time`` or ``temper``.
    """
    inputs: list[Key] = []
    uses_time = False

    def column(key: Key) -> int:
        if key not in inputs:
            inputs.append(key)
        return inputs.index(key)

    def unit(k: int) -> Callable[[], np.ndarray]:
        def make() -> np.ndarray:
            gradient = np.zeros(len(inputs))
            gradient[k] = 1.0
            return gradient
        return make

    def build(item: Node) -> Evaluator:
        nonlocal uses_time
        kind = item[0]
        if kind == "num":
            value = float(item[1])
            return lambda x, t: (value, None)
        if kind == "name":
            if item[1] == "time":
                uses_time = True
                return lambda x, t: (t, None)
            if item[1] == "temper":
                return lambda x, t: (TEMPERATURE, None)
            raise ExpressionError(f"{item[1]!r} is not available in a transient (only time and "
                                  "temper are)")
        if kind == "v":
            return voltage(item[1], item[2])
        if kind == "i":
            return probe(("i", item[1]))
        if kind == "neg":
            inner = build(item[1])

            def negative(x, t):
                value, gradient = inner(x, t)
                return -value, _scaled(gradient, -1.0)
            return negative
        if kind == "not":
            inner = build(item[1])
            return lambda x, t: (0.0 if inner(x, t)[0] else 1.0, None)
        if kind in {"and", "or"}:
            left, right = build(item[1]), build(item[2])
            if kind == "and":
                return lambda x, t: (1.0 if left(x, t)[0] and right(x, t)[0] else 0.0, None)
            return lambda x, t: (1.0 if left(x, t)[0] or right(x, t)[0] else 0.0, None)
        if kind == "if":
            return choice(build(item[1]), build(item[2]), build(item[3]))
        if kind == "op":
            return operation(item[1], build(item[2]), build(item[3]))
        if kind == "call":
            return call(item[1], [build(a) for a in item[2]])
        raise ExpressionError(f"unknown construct in {to_text(item)}")

    def probe(key: Key) -> Evaluator:
        k = column(key)
        gradient = unit(k)
        cache: list[np.ndarray] = []

        def read(x, t):
            if not cache:
                cache.append(gradient())
            return x[k], cache[0]
        return read

    def voltage(plus: str, minus: str | None) -> Evaluator:
        terms = [(probe(("v", node_name(n))), sign) for n, sign in ((plus, 1.0), (minus, -1.0))
                 if n is not None and node_name(n) != "0"]
        if not terms:
            return lambda x, t: (0.0, None)
        if len(terms) == 1 and terms[0][1] == 1.0:
            return terms[0][0]

        def difference(x, t):
            value, gradient = 0.0, None
            for term, sign in terms:
                v, g = term(x, t)
                value += sign * v
                gradient = _plus(gradient, g, sign)
            return value, gradient
        return difference

    def choice(condition: Evaluator, on: Evaluator, off: Evaluator) -> Evaluator:
        return lambda x, t: on(x, t) if condition(x, t)[0] else off(x, t)

    def operation(op: str, left: Evaluator, right: Evaluator) -> Evaluator:
        if op in _COMPARE:
            test = _COMPARE[op]
            return lambda x, t: (1.0 if test(left(x, t)[0], right(x, t)[0]) else 0.0, None)
        if op in {"+", "-"}:
            sign = 1.0 if op == "+" else -1.0

            def add(x, t):
                a, da = left(x, t)
                b, db = right(x, t)
                return a + sign * b, _plus(da, db, sign)
            return add
        if op == "*":
            def times(x, t):
                a, da = left(x, t)
                b, db = right(x, t)
                return a * b, _plus(_scaled(da, b), _scaled(db, a))
            return times
        if op == "/":
            def divide(x, t):
                a, da = left(x, t)
                b, db = right(x, t)
                value = a / b
                return value, _plus(_scaled(da, 1.0 / b), _scaled(db, -value / b))
            return divide
        if op == "^":
            return power(left, right, signed=False)
        raise ExpressionError(f"unknown operator {op!r}")

    def power(base: Evaluator, exponent: Evaluator, signed: bool) -> Evaluator:
        def evaluate(x, t):
            a, da = base(x, t)
            b, db = exponent(x, t)
            magnitude = abs(a)
            value = magnitude ** b
            sign = (1.0 if a >= 0 else -1.0) if signed else 1.0
            gradient = None
            if da is not None:  # d|a|^b/da = b |a|^(b-1) sign(a)
                slope = b * magnitude ** (b - 1.0) if magnitude else (
                    0.0 if b > 1 else 1.0 if b == 1 else math.inf)
                gradient = _scaled(da, slope * (1.0 if a >= 0 else -1.0) * sign)
            if db is not None:
                gradient = _plus(gradient, _scaled(db, value * math.log(magnitude) * sign))
            return sign * value, gradient
        return evaluate

    def call(name: str, args: list[Evaluator]) -> Evaluator:
        def arity(least: int, most: int | None = -1) -> None:
            most = least if most == -1 else most  # (None: no most)
            if len(args) < least or (most is not None and len(args) > most):
                raise ExpressionError(f"{name}() takes {least if least == most else f'{least} or more'} "
                                      f"argument(s), got {len(args)}")
        if name in _UNARY:
            arity(1)
            function, derivative = _UNARY[name]
            (inner,) = args

            def unary(x, t):
                a, da = inner(x, t)
                value = function(a)
                return value, None if da is None else da * derivative(a, value)
            return unary
        if name in _STEPS:
            arity(1)
            step, (inner,) = _STEPS[name], args
            return lambda x, t: (step(inner(x, t)[0]), None)
        if name in {"min", "max"}:
            arity(2, None)
            pick = min if name == "min" else max

            def extreme(x, t):
                values = [a(x, t) for a in args]
                return pick(values, key=lambda pair: pair[0])
            return extreme
        if name == "limit":  # (the affine path's clamp, LTspice's meaning)
            arity(3)
            return call("min", [call("max", args[:2]), args[2]])
        if name in {"pow", "pwr", "pwrs"}:
            arity(2)
            return power(args[0], args[1], signed=name != "pow")
        if name in {"if", "ternary_fcn"}:
            arity(3)
            return choice(*args)
        if name == "atan2":
            arity(2)

            def angle(x, t):
                a, da = args[0](x, t)
                b, db = args[1](x, t)
                r2 = a * a + b * b
                return math.atan2(a, b), _plus(_scaled(da, b / r2), _scaled(db, -a / r2))
            return angle
        if name == "hypot":
            arity(2)

            def length(x, t):
                a, da = args[0](x, t)
                b, db = args[1](x, t)
                r = math.hypot(a, b)
                return r, _plus(_scaled(da, a / r), _scaled(db, b / r))
            return length
        if name == "ddt":  # (read by the ideal engine of an affine argument only)
            raise ExpressionError("ddt() of a nonlinear value: the smooth relations hold no time "
                                  "derivative")
        raise ExpressionError(f"unknown function {name}()")

    evaluator = build(tree)
    return SmoothExpression(to_text(tree), tuple(inputs), uses_time, evaluator)
