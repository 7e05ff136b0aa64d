"""Sweeps written in the netlist or on the command line: LTspice's ``.step``, ``--param``,
the Monte Carlo seed, and the grid of points they make.

``.step`` (LTspice syntax; only parameters are stepped)::

    .step param NAME START STOP INCR          linear: START, START+INCR, ... up to STOP
    .step lin param NAME START STOP INCR      the same
    .step dec param NAME START STOP POINTS    POINTS per decade from START up to STOP
    .step oct param NAME START STOP POINTS    POINTS per octave
    .step param NAME list V1 V2 ...           the values listed
    .step param NAME dec START STOP POINTS    (the sweep kind may also follow the name)

as LTspice's help describes it ("STEP — Parameter Sweeps"); ``file=`` lists are refused.

Several ``.step`` lines nest: the points are their outer product, the first line being
the outermost loop (the last line's parameter changes fastest). ``STOP`` is included when
the steps land on it (to 1e-9 of a step). A Monte Carlo run count is a stepped parameter
that nothing uses: ``.step param run 1 200 1`` gives 200 points, each with its own draws.

Random draws: every point has its own generator, ``point_generator(seed, index)``, made
from ``numpy.random.SeedSequence(seed, spawn_key=(index,))``; ``index`` is the point's
position in the grid. The same seed gives the same draws whatever runs the points, in
whatever order. The seed is ``.options seed=N`` (or given explicitly), else
:data:`DEFAULT_SEED` (1, ngspice's default ``rndseed``).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

from circuitnsds.errors import NetlistError, SourceLocation
from circuitnsds.netlist.expressions import ExpressionError, evaluate, strip_delimiters
from circuitnsds.netlist.parser import Netlist, Statement

DEFAULT_SEED = 1
"""The seed without ``.options seed`` (ngspice starts its ``rndseed`` at 1)."""

MAX_POINTS = 1_000_000
"""Largest grid accepted (a guard against a mistyped increment)."""

_NAME = re.compile(r"[a-z_][a-z0-9_]*", re.IGNORECASE)


@dataclass(frozen=True)
class Step:
    """One swept parameter.

    Attributes:
        name: the parameter as written (the table's column); it is looked up in lower case.
        values: its values, in order.
        location: the ``.step`` line, or ``None`` for ``--param`` and the API.
    """

    name: str
    values: tuple[float, ...]
    location: SourceLocation | None = None


class StepSyntaxError(ValueError):
    """A sweep specification cannot be read (the caller adds where)."""


def linear_values(start: float, stop: float, increment: float) -> tuple[float, ...]:
    """``start, start + increment, ...`` up to ``stop`` (included when landed on).

    Raises:
        StepSyntaxError: a zero increment, or one pointing away from ``stop``.
    """
    if increment == 0:
        raise StepSyntaxError("the increment is 0")
    span = stop - start
    if span != 0 and (span > 0) != (increment > 0):
        raise StepSyntaxError(f"the increment {increment:g} goes away from the stop value {stop:g}")
    count = math.floor(span / increment + 1e-9) + 1
    _check_count(count)
    return tuple(stop if k == count - 1 and math.isclose(start + k * increment, stop, rel_tol=1e-9,
                                                          abs_tol=1e-12 * abs(increment))
                 else start + k * increment for k in range(count))


def log_values(start: float, stop: float, points: float, base: float) -> tuple[float, ...]:
    """``points`` values per decade (``base`` 10) or octave (2) from ``start`` up to ``stop``.

    Raises:
        StepSyntaxError: non-positive ends or points, or ends of different signs.
    """
    if start <= 0 or stop <= 0:
        raise StepSyntaxError("a logarithmic sweep needs positive start and stop values")
    if points <= 0:
        raise StepSyntaxError("the number of points per decade or octave must be positive")
    span = math.log(stop / start, base) * points
    count = math.floor(abs(span) + 1e-9) + 1
    _check_count(count)
    sign = 1 if span >= 0 else -1
    values = [start * base ** (sign * k / points) for k in range(count)]
    if math.isclose(values[-1], stop, rel_tol=1e-9):
        values[-1] = stop
    return tuple(values)


def count_values(start: float, stop: float, count: int) -> tuple[float, ...]:
    """``count`` equally spaced values from ``start`` to ``stop``, both included."""
    if count < 1 or count != int(count):
        raise StepSyntaxError(f"the number of values must be a positive integer, not {count:g}")
    count = int(count)
    _check_count(count)
    if count == 1:
        if start != stop:
            raise StepSyntaxError("one value from start to stop: give two values or start = stop")
        return (start,)
    return tuple(stop if k == count - 1 else start + (stop - start) * k / (count - 1) for k in range(count))


def _check_count(count: int) -> None:
    if count > MAX_POINTS:
        raise StepSyntaxError(f"{count} values (more than {MAX_POINTS}): check the increment")


def _number(token: str) -> float:
    expression = strip_delimiters(token)
    try:
        return evaluate(expression if expression is not None else token)
    except ExpressionError as exc:
        raise StepSyntaxError(f"{token!r} is not a number ({exc})") from None


STEP_HINT = ("write .step param NAME START STOP INCR, .step dec|oct param NAME START STOP POINTS, "
             "or .step param NAME list V1 V2 ...")


def read_step(statement: Statement) -> Step:
    """The sweep of one ``.step`` line.

    Raises:
        NetlistError: a form other than ``.step [lin|dec|oct] param ...`` (sources,
            models and temperature are not stepped: write them with a parameter), or bad
            numbers.
    """
    tokens = list(statement.tokens[1:])
    written = statement.text.split()[1:]
    kind = "lin"
    if tokens and tokens[0] in ("lin", "dec", "oct"):
        kind = tokens.pop(0)
        written.pop(0)
    if not tokens or tokens[0] != "param":
        what = tokens[0] if tokens else "nothing"
        raise NetlistError(f".step {what}: only parameters are stepped", where=statement.location,
                           hint=f"{STEP_HINT}; to step a source, model parameter or temperature, "
                           "write it as {NAME} and step NAME")
    if len(tokens) < 2 or not _NAME.fullmatch(tokens[1]):
        raise NetlistError(".step param: missing parameter name", where=statement.location, hint=STEP_HINT)
    name = written[1] if len(written) > 1 and written[1].lower() == tokens[1] else tokens[1]
    arguments = tokens[2:]
    if arguments and arguments[0] in ("lin", "dec", "oct") and kind == "lin":  # .step param X dec ...
        kind = arguments.pop(0)
    if "file" in arguments:
        raise NetlistError(f".step param {name} file=...: values from a file are not read",
                           where=statement.location, hint="write the values with list V1 V2 ...")
    try:
        if arguments and arguments[0] == "list":
            if kind != "lin":
                raise StepSyntaxError(f"{kind} with list")
            if len(arguments) < 2:
                raise StepSyntaxError("list has no values")
            values = tuple(_number(t) for t in arguments[1:])
        elif len(arguments) != 3:
            raise StepSyntaxError(f"expected START STOP {'INCR' if kind == 'lin' else 'POINTS'}, "
                                  f"got {len(arguments)} values")
        else:
            start, stop, third = (_number(t) for t in arguments)
            values = (linear_values(start, stop, third) if kind == "lin"
                      else log_values(start, stop, third, 10.0 if kind == "dec" else 2.0))
    except StepSyntaxError as exc:
        raise NetlistError(f".step param {name}: {exc}", where=statement.location,
                           hint=f"{STEP_HINT}; in: {statement.text}") from None
    return Step(name, values, statement.location)


def split_steps(netlist: Netlist) -> tuple[Netlist, list[Step]]:
    """The netlist without its ``.step`` lines, and the sweeps they describe (in order).

    Raises:
        NetlistError: a malformed ``.step``, or two stepping the same parameter.
    """
    kept: list[Statement] = []
    steps: list[Step] = []
    for statement in netlist.statements:
        if statement.keyword != ".step":
            kept.append(statement)
            continue
        step = read_step(statement)
        for other in steps:
            if other.name.lower() == step.name.lower():
                raise NetlistError(f".step param {step.name}: the parameter is already stepped "
                                   f"at {other.location}", where=statement.location)
        steps.append(step)
    return replace(netlist, statements=kept), steps


def options_seed(statements: Iterable[Statement]) -> int | None:
    """The value of ``.options seed=N``, if a line gives one (checked by the elaborator)."""
    seed = None
    for statement in statements:
        if statement.keyword not in (".options", ".option", ".opt"):
            continue
        tokens = statement.tokens
        for index, token in enumerate(tokens[:-2]):
            if token == "seed" and tokens[index + 1] == "=":
                try:
                    value = float(tokens[index + 2])
                except ValueError:
                    raise NetlistError(f".options seed={tokens[index + 2]} is not an integer",
                                       where=statement.location) from None
                if not (math.isfinite(value) and value >= 0 and value == int(value)):
                    raise NetlistError(f".options seed={tokens[index + 2]} must be a non-negative "
                                       "integer", where=statement.location,
                                       hint="any integer from 0 up; the same seed draws the same numbers")
                seed = int(value)
    return seed


def point_generator(seed: int, index: int):
    """The random generator of point ``index`` of a sweep seeded with ``seed`` (a
    ``numpy.random.Generator``; independent streams for different indexes)."""
    import numpy as np

    if seed < 0 or index < 0:
        raise ValueError("the seed and the point index are non-negative integers")
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(int(seed), spawn_key=(int(index),))))


class LazyGenerator:
    """:func:`point_generator` ``(seed, index)``, created at its first use: most netlists draw
    no random number, and ``numpy.random`` costs 0.01-0.04 s to import."""

    def __init__(self, seed: int, index: int):
        if seed < 0 or index < 0:
            raise ValueError("the seed and the point index are non-negative integers")
        self._arguments = (seed, index)
        self._generator = None

    def __getattr__(self, name: str):
        if name.startswith("_"):  # not set yet (copy, pickle create us without __init__)
            raise AttributeError(name)
        if self._generator is None:
            self._generator = point_generator(*self._arguments)
        return getattr(self._generator, name)


def grid(steps: Sequence[Step]) -> list[dict[str, float]]:
    """The outer product of the sweeps: one ``{name as written: value}`` per point, the first
    sweep outermost."""
    count = math.prod(len(step.values) for step in steps)
    if count > MAX_POINTS:
        raise NetlistError(f"the sweep has {count} points (more than {MAX_POINTS})",
                           hint="check the increments and the number of values")
    names = [step.name for step in steps]
    return [dict(zip(names, values)) for values in itertools.product(*(s.values for s in steps))]


def parse_param_option(text: str) -> Step:
    """Read a ``--param`` value: ``NAME=START:STOP:COUNT`` (COUNT values, both ends
    included), ``NAME=V1,V2,...`` (a list) or ``NAME=V`` (one value). Numbers take SPICE
    suffixes (``1k``, ``10u``).

    Raises:
        StepSyntaxError: for anything else.
    """
    name, equals, spec = text.partition("=")
    name, spec = name.strip(), spec.strip()
    if not equals or not _NAME.fullmatch(name):
        raise StepSyntaxError(f"{text!r}: expected NAME=START:STOP:COUNT or NAME=V1,V2,...")
    if not spec:
        raise StepSyntaxError(f"{text!r}: no values after {name}=")
    if ":" in spec:
        parts = spec.split(":")
        if len(parts) != 3:
            raise StepSyntaxError(f"{text!r}: a range is START:STOP:COUNT")
        start, stop = _number(parts[0].strip()), _number(parts[1].strip())
        count = _number(parts[2].strip())
        return Step(name, count_values(start, stop, count))
    values = tuple(_number(part.strip()) for part in spec.split(","))
    return Step(name, values)


def steps_from_mapping(params: Mapping[str, object]) -> list[Step]:
    """``{"D": [0.2, 0.4], "Rl": 5}`` -> steps (a scalar is one value), in the mapping's order.

    Raises:
        StepSyntaxError: a name that is not a parameter name, an empty list, a non-number.
    """
    steps = []
    for name, values in params.items():
        if not _NAME.fullmatch(str(name)):
            raise StepSyntaxError(f"{name!r} is not a parameter name")
        sequence = [values] if isinstance(values, (int, float, str)) else list(values)  # type: ignore[arg-type]
        if not sequence:
            raise StepSyntaxError(f"{name}: no values")
        converted = []
        for value in sequence:
            try:
                converted.append(_number(value) if isinstance(value, str) else float(value))
            except (TypeError, ValueError):
                raise StepSyntaxError(f"{name}: {value!r} is not a number") from None
        steps.append(Step(str(name), tuple(converted)))
    lowered = [s.name.lower() for s in steps]
    for name in lowered:
        if lowered.count(name) > 1:
            raise StepSyntaxError(f"parameter {name!r} is given twice (names are case-insensitive)")
    return steps
