"""``.meas tran`` and ``.four`` lines -> plain specifications (ngspice's syntax).

The forms read, and what they mean, are in :mod:`circuitnsds.output.meas`, which executes
the specifications on the waveforms (it reads their attributes only: the two layers do not
import each other).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial

import numpy as np

from circuitnsds.errors import NetlistError, SourceLocation
from circuitnsds.values import parse_value

WINDOW_KINDS = {"avg", "rms", "min", "max", "pp", "integ", "integral", "min_at", "max_at"}
POINT_KINDS = {"when", "find", "deriv", "derivative", "trig"}
LAST = -1
"""``RISE=LAST`` (and FALL, CROSS): the last crossing (any negative count means it)."""


@dataclass(frozen=True)
class Crossing:
    """Where a WHEN/TRIG/TARG condition holds: ``signal`` crosses ``level`` (a number, or
    another signal's name) for the ``count``-th time in ``direction`` (``rise``, ``fall``
    or ``cross``; ``count`` :data:`LAST` for the last), ignoring times before ``delay``
    and outside ``[start, stop]``; or, with ``at``, simply the instant ``at`` [s]."""

    signal: str | None = None
    level: float | str | None = None
    direction: str = "cross"
    count: int = 0
    delay: float = 0.0
    start: float | None = None
    stop: float | None = None
    at: float | None = None


@dataclass(frozen=True)
class MeasureSpec:
    """One ``.meas tran`` statement, parsed.

    Attributes:
        name: the result's name (lower case).
        kind: ``avg``, ``rms``, ``min``, ``max``, ``pp``, ``integ``, ``min_at``, ``max_at``,
            ``when``, ``find``, ``deriv``, ``trig`` or ``param``.
        signal: OUT of window and FIND/DERIV measurements.
        start, stop, delay: FROM, TO, TD [s].
        when: the WHEN (or AT) condition; trig/targ: those of TRIG ... TARG.
        text: the statement; location: its file:line.
        formula: of ``param``: the value from the earlier measurements' values by name.
        derived: the ``par('expr')`` signals it names (ngspice's expression of the run's
            vectors), each computed from the run's signals: ``derived[token](fetch)`` with
            ``fetch(name)`` a signal's values returns the expression's values on the grid.
    """

    name: str
    kind: str
    signal: str | None = None
    start: float | None = None
    stop: float | None = None
    delay: float = 0.0
    when: Crossing | None = None
    trig: Crossing | None = None
    targ: Crossing | None = None
    text: str = ""
    location: SourceLocation | None = None
    formula: Callable[[Mapping[str, float]], float] | None = None
    derived: Mapping[str, Callable[[Callable[[str], np.ndarray]], np.ndarray]] | None = None


def _param(name: str, text: str, location: SourceLocation | None, fail) -> MeasureSpec:
    """``.meas tran NAME PARAM='expr'``: an expression of the measurements before it (by
    name), evaluated after them, as in ngspice."""
    from circuitnsds.netlist.expressions import ExpressionError, evaluate, parse, strip_delimiters

    match = re.search(r"\bparam\s*=\s*(.+)$", text, re.IGNORECASE | re.DOTALL)
    if match is None:
        raise fail("PARAM needs =expression, e.g. PARAM='vmax - vmin'")
    expression = match[1].strip()
    expression = strip_delimiters(expression) or expression
    try:
        parse(expression.lower())
    except ExpressionError as exc:
        raise fail(f"PARAM: {exc}") from None
    return MeasureSpec(name, "param", text=text, location=location,
                       formula=partial(evaluate, expression.lower()))


_SIGNAL = r"[a-z]+\([^()]*\)"
_PAR = r"par\(\s*'[^']*'\s*\)"
_TOKEN = re.compile(rf"{_PAR}|{_SIGNAL}|'[^']*'|\{{[^}}]*\}}|[^\s=]+|=", re.IGNORECASE)
_PROBE = re.compile(r"\b([vi])\s*\(\s*([^\s(),]+)\s*(?:,\s*([^\s(),]+)\s*)?\)")


def _expression_signal(token: str, fail) -> Callable[[Callable[[str], np.ndarray]], np.ndarray]:
    """``par('expr')`` in a signal's place: ngspice's expression of the run's vectors
    (``v(a)*i(r1)``, ``v(a,b)/2``, functions and parameters as in ``.param``), evaluated at
    every point of the run's grid. Returns the function of a signal fetcher that computes it."""
    from circuitnsds.netlist.expressions import ExpressionError, evaluate, parse

    quoted = re.fullmatch(r"par\(\s*'([^']*)'\s*\)", token)
    if quoted is None:
        raise fail(f"{token}: the expression of par() goes in single quotes: par('v(a)*i(r1)')")
    expression = quoted[1].lower()
    probes: list[str] = []

    def placeholder(match: re.Match) -> str:
        kind, first, second = match.groups()
        name = f"{kind}({first},{second})" if second else f"{kind}({first})"
        if name not in probes:
            probes.append(name)
        return f"cnsds_probe_{probes.index(name)}"

    text = _PROBE.sub(placeholder, expression)
    try:
        _check_names(parse(text), expression)
    except ExpressionError as exc:
        raise fail(f"{token}: {exc}") from None

    def values(fetch: Callable[[str], np.ndarray]) -> np.ndarray:
        columns = [np.asarray(fetch(name), dtype=float) for name in probes]
        size = len(columns[0]) if columns else len(fetch("time"))
        result = np.empty(size)
        for k in range(size):
            names = {f"cnsds_probe_{j}": float(column[k]) for j, column in enumerate(columns)}
            try:
                result[k] = evaluate(text, names)
            except ExpressionError:  # a division by zero at one point: no value there
                result[k] = np.nan
        return result

    return values


def _check_names(node: tuple, text: str) -> None:
    """Raise for a name or function ``node`` does not define at any point of the run: an
    undefined parameter, an unknown function or a wrong argument count would otherwise fail
    at every point alike and leave the measurement NaN (a division by zero fails at a point)."""
    from circuitnsds.netlist.expressions import (
        CONDITIONAL_FUNCTIONS,
        CONSTANTS,
        FUNCTIONS,
        ExpressionError,
        UndefinedNameError,
        excerpt,
    )

    kind = node[0]
    if kind == "name" and not node[1].startswith("cnsds_probe_") and node[1] not in CONSTANTS:
        raise UndefinedNameError(node[1], text)
    if kind == "call":
        name, arguments = node[1], node[2]
        least, most = (3, 3) if name in CONDITIONAL_FUNCTIONS else FUNCTIONS.get(
            name, (None, None, None))[1:3]
        if least is None:
            raise ExpressionError(f"unknown function {name}() in {excerpt(text)}; known: "
                                  + ", ".join(sorted({*FUNCTIONS, *CONDITIONAL_FUNCTIONS})))
        if len(arguments) < least or (most is not None and len(arguments) > most):
            raise ExpressionError(f"{name}() takes {least if least == most else f'{least} or more'}"
                                  f" argument(s), got {len(arguments)} in {excerpt(text)}")
    children = {"neg": node[1:], "not": node[1:], "if": node[1:], "call": node[2] if
                kind == "call" else (),
                "chain": (node[1], *(inner for _, inner in node[2])) if kind == "chain" else ()}
    for child in children.get(kind, ()):
        _check_names(child, text)


def _with_expression_signals(spec: MeasureSpec, fail) -> MeasureSpec:
    """``spec`` with ``derived`` set for each ``par('expr')`` it names (as OUT, in WHEN, TRIG
    or TARG)."""
    from dataclasses import replace

    names = [spec.signal] + [part for crossing in (spec.when, spec.trig, spec.targ) if crossing
                             for part in (crossing.signal, crossing.level)]
    tokens = [name for name in names if isinstance(name, str) and name.startswith("par(")]
    if not tokens:
        return spec
    return replace(spec, derived={token: _expression_signal(token, fail) for token in tokens})


def parse_meas(text: str, location: SourceLocation | None = None) -> MeasureSpec | None:
    """Parse a ``.meas``/``.measure`` line; ``None`` (with nothing to do) for analyses other
    than ``tran``, which the caller reports. A signal may be ``par('expr')``, an expression of
    the run's signals (ngspice's).

    Raises:
        NetlistError: a syntax circuitnsds does not read (with what to write instead).
    """
    spec = _parse_meas(text, location)
    if spec is None:
        return None
    first = text.split(None, 1)[0].lower() if text.strip() else ".meas"
    return _with_expression_signals(spec, partial(_failure, first, text, location))


def _failure(first: str, text: str, location: SourceLocation | None, message: str) -> NetlistError:
    return NetlistError(f"{first}: {message}", where=location, text=text, hint=MEAS_FORMS)


MEAS_FORMS = ("write .meas tran NAME AVG|RMS|MIN|MAX|PP|INTEG OUT [FROM=t TO=t], .meas tran NAME "
              "WHEN OUT=VAL [RISE=n], .meas tran NAME FIND OUT AT=t, or .meas tran NAME TRIG ... "
              "TARG ...")
"""The forms a ``.meas`` line takes, for the hint of a refused one."""


def _parse_meas(text: str, location: SourceLocation | None) -> MeasureSpec | None:
    """:func:`parse_meas` but for the ``par('expr')`` signals."""
    tokens = [token.lower().replace(" ", "") if token.startswith(("v(", "i(", "V(", "I("))
              else token.lower() for token in _TOKEN.findall(text)]

    fail = partial(_failure, tokens[0] if tokens else ".meas", text, location)

    if len(tokens) < 4:
        raise fail("too few fields")
    analysis, name, kind = tokens[1], tokens[2], tokens[3]
    if analysis != "tran":
        return None
    rest = tokens[4:]
    if kind == "param" or kind.startswith("param"):
        return _param(name, text, location, fail)
    if kind in {"integral"}:
        kind = "integ"
    if kind == "derivative":
        kind = "deriv"
    if kind in WINDOW_KINDS:
        if not rest or rest[1:2] == ["="]:  # AVG from=... : the signal is missing
            raise fail(f"{kind.upper()} needs a signal, e.g. v(out)")
        signal, options = rest[0], _options(rest[1:], fail)
        _only(options, {"from", "to", "td"}, kind, fail)
        return MeasureSpec(name, kind, signal=signal, start=options.get("from"),
                           stop=options.get("to"), delay=options.get("td", 0.0), text=text,
                           location=location)
    if kind == "when":
        return MeasureSpec(name, "when", when=_condition(rest, fail), text=text, location=location)
    if kind in {"find", "deriv"}:
        if not rest:
            raise fail(f"{kind.upper()} needs a signal")
        signal, rest = rest[0], rest[1:]
        if rest[:1] == ["when"]:
            return MeasureSpec(name, kind, signal=signal, when=_condition(rest[1:], fail), text=text,
                               location=location)
        options = _options(rest, fail)
        if "at" not in options:
            raise fail(f"{kind.upper()} needs AT=t or WHEN ...")
        return MeasureSpec(name, kind, signal=signal, when=Crossing(at=options["at"]), text=text,
                           location=location)
    if kind == "trig":
        if "targ" not in rest:
            raise fail("TRIG needs a TARG part")
        split = rest.index("targ")
        return MeasureSpec(name, "trig", trig=_trigger(rest[:split], fail),
                           targ=_trigger(rest[split + 1:], fail), text=text, location=location)
    raise fail(f"{kind.upper()} measurements are not supported")


def _options(tokens: list[str], fail) -> dict[str, float]:
    """``key = value`` pairs; RISE/FALL/CROSS=LAST become :data:`LAST`."""
    options: dict[str, float] = {}
    k = 0
    while k < len(tokens):
        if k + 2 >= len(tokens) or tokens[k + 1] != "=":
            raise fail(f"expected key=value, found {' '.join(tokens[k:k + 3])!r}")
        key, text = tokens[k], tokens[k + 2]
        if key in {"rise", "fall", "cross"} and text == "last":
            options[key] = LAST
        else:
            try:
                options[key] = parse_value(text)
            except ValueError:
                raise fail(f"{key}={text}: not a number") from None
        k += 3
    return options


def _only(options: dict, allowed: set[str], kind: str, fail) -> None:
    extra = sorted(set(options) - allowed)
    if extra:
        raise fail(f"{kind.upper()} does not take {', '.join(extra)}")


def _edge(options: dict) -> tuple[str, int]:
    given = [key for key in ("rise", "fall", "cross") if key in options]
    if len(given) > 1:
        raise ValueError("give one of RISE, FALL and CROSS")
    if not given:
        return "cross", 0
    return given[0], int(options[given[0]])


def _condition(tokens: list[str], fail) -> Crossing:
    """``OUT=VAL [RISE=n ...] [TD=t] [FROM=t] [TO=t]`` (VAL a number or a signal)."""
    if len(tokens) < 3 or tokens[1] != "=":
        raise fail("WHEN needs OUT=VAL, e.g. WHEN v(out)=2.5")
    signal, level_text = tokens[0], tokens[2]
    try:
        level: float | str = parse_value(level_text)
    except ValueError:
        level = level_text
        if re.search(r"[*/+]|(?<!^)-", level) and not level.startswith("par("):
            level = f"par('{level}')"  # an expression of signals (ngspice's script meas reads it)
    options = _options(tokens[3:], fail)
    _only(options, {"rise", "fall", "cross", "td", "from", "to"}, "when", fail)
    try:
        direction, count = _edge(options)
    except ValueError as exc:
        raise fail(str(exc)) from None
    return Crossing(signal, level, direction, count, options.get("td", 0.0), options.get("from"),
                    options.get("to"))


def _trigger(tokens: list[str], fail) -> Crossing:
    """``OUT VAL=v [TD=t] [RISE|FALL|CROSS=n]`` or ``AT=t``."""
    if tokens[:1] == ["at"]:
        options = _options(tokens, fail)
        return Crossing(at=options["at"])
    if not tokens:
        raise fail("TRIG/TARG needs a signal and VAL=")
    options = _options(tokens[1:], fail)
    _only(options, {"val", "td", "rise", "fall", "cross"}, "trig/targ", fail)
    if "val" not in options:
        raise fail("TRIG/TARG needs VAL=")
    try:
        direction, count = _edge(options)
    except ValueError as exc:
        raise fail(str(exc)) from None
    return Crossing(tokens[0], options["val"], direction, count, options.get("td", 0.0))


@dataclass(frozen=True)
class FourierSpec:
    """``.four FREQ OUT ...``: the fundamental [Hz] and the outputs."""

    frequency: float
    signals: tuple[str, ...]
    location: SourceLocation | None = None


def parse_four(text: str, location: SourceLocation | None = None) -> FourierSpec:
    """Parse ``.four FREQ OUT1 [OUT2 ...]``."""
    tokens = _TOKEN.findall(text)
    try:
        frequency = parse_value(tokens[1])
    except (IndexError, ValueError):
        raise NetlistError(".four needs the fundamental frequency", where=location, text=text,
                           hint="write .four 50 v(out)") from None
    signals = tuple(token.lower().replace(" ", "") for token in tokens[2:])
    if not signals or frequency <= 0:
        raise NetlistError(".four needs a positive frequency and at least one output",
                           where=location, text=text, hint="write .four 50 v(out)")
    return FourierSpec(frequency, signals, location)
