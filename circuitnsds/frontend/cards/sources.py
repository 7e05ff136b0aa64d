"""Independent sources ``V``/``I`` with their time functions, and controlled sources ``E F G H``."""

from __future__ import annotations

import re
from dataclasses import replace

from circuitnsds.circuit.elements.base import Element
from circuitnsds.circuit.elements.sources import CurrentSource, VoltageSource
from circuitnsds.frontend.cards.reader import StatementReader
from circuitnsds.system.stimuli import Am, Dc, Exp, Pulse, Pwl, Sffm, Sin, Stimulus
from circuitnsds.values import is_value, parse_value

BEHAVIOURAL_KEYWORDS = {"value", "poly", "table", "laplace", "freq", "cur", "vol"}


def independent_source(reader: StatementReader, letter: str) -> Element:
    """``V name n+ n- [DC] value [AC ...] [SIN|PULSE|PWL|EXP(...)]`` (and ``I``)."""
    nodes = reader.nodes(2)
    function, ac = _source_function(reader)
    cls = VoltageSource if letter == "v" else CurrentSource
    return cls(reader.name, nodes, reader.location, function=function, ac=ac)


def controlled_source(reader: StatementReader, letter: str, voltage_sources: set[str]) -> Element:
    """``E``/``G`` (4 nodes and a gain) or ``F``/``H`` (2 nodes, a voltage source, a gain).

    ``voltage_sources`` holds the names of the circuit's voltage sources (for ``F``/``H``).
    """
    # (imported here: a netlist without E F G H does not pay for their classes at start-up)
    from circuitnsds.circuit.elements.controlled import (
        CurrentControlledCurrentSource,
        CurrentControlledVoltageSource,
        VoltageControlledCurrentSource,
        VoltageControlledVoltageSource,
    )

    name = reader.name
    if any(token in BEHAVIOURAL_KEYWORDS for token in reader.tokens[1:]):
        raise reader.error(f"{name}: this form of controlled source (POLY, LAPLACE, FREQ, or "
                           "VALUE/TABLE on F and H) is not supported",
                           hint=f"write a linear source: {letter.upper()}name n+ n- "
                           + ("nc+ nc- GAIN" if letter in "eg" else "VNAME GAIN")
                           + ", or an E/G with VALUE={affine expression} or TABLE {expr} = "
                           "(x1, y1) (x2, y2) ..., or a B source")
    if letter in "eg":
        nodes = reader.nodes(4)
        gain = reader.value("gain" if letter == "e" else "transconductance")
        _no_more(reader)
        if letter == "e":
            return VoltageControlledVoltageSource(name, nodes, reader.location, gain=gain)
        return VoltageControlledCurrentSource(name, nodes, reader.location, transconductance=gain)
    nodes = reader.nodes(2)
    control = reader.next("controlling voltage source")
    gain = reader.value("gain" if letter == "f" else "transresistance")
    _no_more(reader)
    if control not in voltage_sources:
        raise reader.error(f"{name}: controlling source {control!r} is not a voltage source "
                           "of this circuit",
                           hint="F and H sense the current of a V source; add a 0 V source in "
                           "series with the branch to sense")
    if letter == "f":
        return CurrentControlledCurrentSource(name, nodes, reader.location, control=control, gain=gain)
    return CurrentControlledVoltageSource(name, nodes, reader.location, control=control,
                                          transresistance=gain)


def _no_more(reader: StatementReader) -> None:
    if not reader.done():
        if reader.peek() == "m" and reader.peek(1) == "=":
            raise reader.error(f"{reader.name}: m= is not supported on controlled sources",
                               hint="scale the gain instead")
        raise reader.error(f"{reader.name}: unexpected {reader.peek()!r}",
                           hint=f"in: {reader.statement.text}")


def _is_number(token: str | None) -> bool:
    return token is not None and is_value(token)


FUNCTION_ARITY = {"sin": (2, 7), "pulse": (2, 8), "exp": (2, 6), "pwl": (2, None), "am": (2, 8),
                  "sffm": (2, 8)}
FUNCTION_ALIASES = {"sine": "sin"}
"""Other spellings of the functions (PSpice's and ngspice's ``SINE(...)``)."""


def _source_function(reader: StatementReader) -> tuple[Stimulus, tuple[float, float] | None]:
    """Parse ``[DC] value [AC mag [phase]] [SIN(...)|PULSE(...)|PWL(...)|EXP(...)]``: the
    time function and the AC ``(magnitude, phase [deg])`` (``None`` without ``AC``)."""
    name = reader.name
    dc: float | None = None
    function: Stimulus | None = None
    ac: tuple[float, float] | None = None
    while not reader.done():
        token = reader.next("source value")
        if token == "dc":
            if dc is not None:
                raise reader.error(f"{name}: the DC value is given twice")
            dc = reader.value("DC value")
        elif token == "ac":
            if ac is not None:
                raise reader.error(f"{name}: AC is given twice")
            magnitude = reader.value("AC magnitude") if _is_number(reader.peek()) else 1.0
            phase = reader.value("AC phase") if _is_number(reader.peek()) else 0.0
            ac = (magnitude, phase)  # the small-signal .ac's stimulus; no effect on a transient
        elif token in FUNCTION_ARITY or token in FUNCTION_ALIASES:
            if function is not None:
                raise reader.error(f"{name}: more than one transient function")
            function = _function(reader, FUNCTION_ALIASES.get(token, token))
        elif token in {"trnoise", "trrandom", "distof1", "distof2"}:
            raise reader.error(f"{name}: {token.upper()} sources are not supported",
                               hint="use DC, SIN, PULSE, PWL, EXP, AM or SFFM")
        elif is_value(token) and dc is None:
            dc = parse_value(token)
        else:
            raise reader.error(f"{name}: unexpected {token!r} in a source specification",
                               hint="write V1 n+ n- [DC] VALUE or V1 n+ n- SIN(VO VA FREQ ...)")
    if function is not None:
        return function, ac
    return Dc(0.0 if dc is None else dc), ac


def _pwl_options(reader: StatementReader, options: dict[str, float]) -> None:
    """Read ``r=R td=TD`` (ngspice's PWL options, inside or after the parentheses) into
    ``options``."""
    while reader.peek() in {"r", "td"} and reader.peek(1) == "=":
        key = reader.next("PWL option")
        reader.position += 1
        options[key] = reader.value(f"PWL {key}")


def _with_pwl_options(reader: StatementReader, pwl: Pwl, options: dict[str, float]) -> Pwl:
    """``pwl`` repeated from time ``r`` and delayed by ``td`` (checked)."""
    repeat = options.get("r")
    if repeat is not None and (repeat not in pwl.times or repeat == pwl.times[-1]):
        raise reader.error(f"{reader.name}: PWL r={repeat:g} must be one of its times before the "
                           f"last ({', '.join(f'{t:g}' for t in pwl.times[:-1])})",
                           hint="r=0 repeats the whole waveform (with a first point at time 0)")
    if options.get("td", 0.0) < 0:
        raise reader.error(f"{reader.name}: PWL td={options['td']:g} must not be negative")
    return replace(pwl, repeat=repeat, delay=options.get("td", 0.0))


def _pwl_file(reader: StatementReader) -> Pwl:
    """``PWL file=NAME`` (LTspice, ngspice): time-value pairs read from a text file
    (whitespace, commas or semicolons between numbers; ``*``/``;``/``#`` comment lines),
    relative to the netlist's folder."""
    from pathlib import Path

    match = re.search(r"""file\s*=\s*(?:"([^"]+)"|'([^']+)'|([^\s()]+))""", reader.statement.text,
                      re.IGNORECASE)
    if match is None:
        raise reader.error(f"{reader.name}: PWL file= needs a file name", hint='PWL file="wave.txt"')
    target = Path(next(group for group in match.groups() if group))
    if not target.is_absolute():
        target = Path(reader.location.file).resolve().parent / target
    try:
        text = target.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise reader.error(f"{reader.name}: cannot read PWL file {target}: {exc.strerror or exc}",
                           hint="the path is relative to the netlist's folder") from None
    numbers: list[float] = []
    for line in text.splitlines():
        line = line.strip()
        if not line or line[0] in "*;#":
            continue
        for token in re.split(r"[\s,;]+", line):
            if token:
                try:
                    numbers.append(parse_value(token))
                except ValueError:
                    raise reader.error(f"{reader.name}: {target.name}: {token!r} is not a number") from None
    while not reader.done() and reader.peek() != ")":  # consume the file= tokens
        reader.position += 1
    if not reader.done():
        reader.position += 1
    if len(numbers) < 2 or len(numbers) % 2:
        raise reader.error(f"{reader.name}: {target.name} must hold time-value pairs, "
                           f"found {len(numbers)} numbers")
    times, values = tuple(numbers[0::2]), tuple(numbers[1::2])
    if any(b < a for a, b in zip(times, times[1:])):
        raise reader.error(f"{reader.name}: {target.name}: PWL times must not decrease")
    return Pwl(times, values)


def _function(reader: StatementReader, kind: str) -> Stimulus:
    name = reader.name
    args: list[float] = []
    if kind == "pwl" and "file" in reader.tokens[reader.position:reader.position + 2]:
        return _pwl_file(reader)
    parenthesised = reader.peek() == "("
    if parenthesised:
        reader.position += 1
    while not reader.done() and reader.peek() != ")":
        if not is_value(reader.peek()):
            if parenthesised:
                if kind == "pwl" and reader.peek() in {"r", "td"} and reader.peek(1) == "=":
                    break  # r= td= inside the parentheses (ngspice reads both places)
                raise reader.error(f"{name}: {kind.upper()} argument {reader.peek()!r} "
                                   "is not a number")
            break
        args.append(reader.value(f"{kind.upper()} argument"))
    options: dict[str, float] = {}
    if kind == "pwl":
        _pwl_options(reader, options)
    if parenthesised:
        if reader.done() or reader.peek() != ")":
            raise reader.error(f"{name}: {kind.upper()}( has no closing parenthesis")
        reader.position += 1
        if kind == "pwl":
            _pwl_options(reader, options)
    low, high = FUNCTION_ARITY[kind]
    if len(args) < low or (high is not None and len(args) > high):
        expected = f"{low} to {high}" if high else f"at least {low}"
        raise reader.error(f"{name}: {kind.upper()} takes {expected} numbers, got {len(args)}")
    if kind == "sin":
        function = Sin(*args[:2], *_defaults(args[2:], [None, 0.0, 0.0, 0.0, None]))
        if function.cycles is not None and function.cycles <= 0:
            raise reader.error(f"{name}: SIN NCYCLES (7th argument) must be positive")
        return function
    if kind == "pulse":
        pulse = Pulse(*args[:2], *_defaults(args[2:], [0.0, None, None, None, None, None]))
        if pulse.count is not None and pulse.count <= 0:
            raise reader.error(f"{name}: PULSE NP (8th argument, the number of pulses) must be "
                               "positive")
        if any(x is not None and x < 0 for x in (pulse.rise, pulse.fall, pulse.width)):
            raise reader.error(f"{name}: PULSE rise, fall and width must not be negative")
        return pulse
    if kind == "exp":
        function = Exp(*args[:2], *_defaults(args[2:], [0.0, None, None, None]))
        if any(x is not None and x < 0 for x in (function.rise_tau, function.fall_tau)):
            raise reader.error(f"{name}: EXP time constants must not be negative")
        return function
    if kind in NGSPICE39_ORDER:
        return _modulated(reader, kind, args)
    if len(args) % 2:
        raise reader.error(f"{name}: PWL needs time-value pairs, got {len(args)} numbers")
    times, values = tuple(args[0::2]), tuple(args[1::2])
    if any(b < a for a, b in zip(times, times[1:])):
        raise reader.error(f"{name}: PWL times must not decrease")
    return _with_pwl_options(reader, Pwl(times, values), options)


NGSPICE39_ORDER = {"am": "AM(VA VO MF FC TD PHASEC PHASES)", "sffm": "SFFM(VO VA FC MDI FS PHASEC PHASES)"}
"""The modulated sources' arguments in ngspice 39's order (later ngspice versions reorder them)."""

LATER_ORDER = {"am": "AM(VO VMO VMA FM FC TD PHASEM PHASEC)",
               "sffm": "SFFM(VO VA FC MDI FM TD PHASEM PHASEC)"}


def _modulated(reader: StatementReader, kind: str, args: list[float]) -> Stimulus:
    """``AM(...)`` or ``SFFM(...)`` read as ngspice 39 reads them (:class:`Am`, :class:`Sffm`).

    ngspice 39 reads seven values; an eighth, which it ignores, is the sign of a line written
    for a later ngspice, whose order differs: the line is read as ngspice 39 reads it, with a
    warning that says so."""
    if len(args) > 7:
        reader.warn(f"{reader.name}: {kind.upper()} with {len(args)} values: read as ngspice 39 does, "
                    f"{NGSPICE39_ORDER[kind]}, ignoring the 8th; ngspice 40 and later read "
                    f"{LATER_ORDER[kind]}, another waveform. Write the 39 order to keep "
                    "this reading, or the waveform as a B source to have the later one")
        args = args[:7]
    if kind == "am":
        return Am(*args[:2], *_defaults(args[2:], [None, 0.0, 0.0, 0.0, 0.0]))
    return Sffm(*args[:2], *_defaults(args[2:], [None, 0.0, None, 0.0, 0.0]))


def _defaults(given: list[float], defaults: list[float | None]) -> list[float | None]:
    return list(given) + defaults[len(given):]


