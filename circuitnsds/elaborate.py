"""Netlist statements -> :class:`~circuitnsds.circuit.Circuit` (elements, models, analysis).

This is where each statement gets its meaning. Anything the engine does not
support is an error naming ``file:line`` (when it changes the circuit) or a
warning (when it only concerns other analyses or output): never silence.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from dataclasses import replace

from circuitnsds.circuit import Circuit, TranSpec
from circuitnsds.elements import (
    Capacitor,
    CurrentSource,
    Diode,
    DiodeModel,
    Element,
    Inductor,
    Resistor,
    VoltageSource,
)
from circuitnsds.errors import NetlistError, NetlistWarning, SourceLocation
from circuitnsds.netlist import Netlist, Statement
from circuitnsds.stimuli import Dc, Exp, Pulse, Pwl, Sin, Stimulus
from circuitnsds.values import is_value, parse_value

GROUND_NAMES = {"0", "gnd"}

UNSUPPORTED_ELEMENTS = {
    "a": "XSPICE code models", "b": "behavioural sources", "e": "voltage-controlled voltage sources",
    "f": "current-controlled current sources", "g": "voltage-controlled current sources",
    "h": "current-controlled voltage sources", "j": "JFETs", "k": "coupled inductors",
    "m": "MOSFETs", "o": "lossy transmission lines", "p": "coupled transmission lines",
    "q": "bipolar transistors", "s": "voltage-controlled switches",
    "t": "transmission lines", "u": "RC lines", "w": "current-controlled switches",
    "x": "subcircuit instances", "y": "transmission lines", "z": "MESFETs",
}

IGNORED_COMMANDS = {
    ".options": "simulator options do not apply to the ideal engine",
    ".option": "simulator options do not apply to the ideal engine",
    ".opt": "simulator options do not apply to the ideal engine",
    ".print": "every signal is written; choose columns with --signals",
    ".plot": "every signal is written; choose columns with --signals",
    ".probe": "every signal is written; choose columns with --signals",
    ".save": "every signal is written; choose columns with --signals",
    ".op": "only .tran is run (its operating point is computed unless UIC)",
    ".ac": "only .tran is supported", ".dc": "only .tran is supported",
    ".noise": "only .tran is supported", ".tf": "only .tran is supported",
    ".sens": "only .tran is supported", ".pz": "only .tran is supported",
    ".disto": "only .tran is supported", ".four": "Fourier analysis is not supported",
    ".meas": ".meas is not supported; compute measurements from the waveforms",
    ".measure": ".meas is not supported; compute measurements from the waveforms",
    ".temp": "the ideal devices have no temperature dependence",
    ".width": "output formatting does not apply", ".nodeset": "the ideal operating point needs no hints",
}

UNSUPPORTED_COMMANDS = {
    ".param", ".func", ".subckt", ".ends", ".include", ".inc", ".lib", ".endl", ".global",
    ".csparam", ".if", ".else", ".elseif", ".endif",
}

# Shockley and datasheet parameters: legitimate in a diode model, not used by the ideal engine.
SHOCKLEY_PARAMETERS = {
    "is", "js", "n", "rs", "cjo", "cj0", "cj", "vj", "pb", "m", "mj", "tt", "fc", "ibv", "ib",
    "nbv", "ikf", "ik", "ikr", "isr", "nr", "jsw", "cjsw", "cjp", "php", "vjsw", "mjsw", "fcs",
    "eg", "xti", "kf", "af", "tnom", "tref", "level", "area", "pj", "trs", "trs1", "trs2", "tm1",
    "tm2", "ttt1", "ttt2", "tlev", "tlevc", "cta", "ctp", "tcv", "tpb", "tphp", "bvj", "gap1",
    "gap2", "mfg", "type", "iave", "ipk", "vpk", "diss", "xp", "rsw", "nbvl", "ibvl",
}
# LTspice idealised-diode parameters that the ideal engine does not model.
UNMODELLED_PARAMETERS = {
    "ilimit": "current limiting", "revilimit": "reverse current limiting",
    "epsilon": "the quadratic smoothing of the knee", "revepsilon": "the quadratic smoothing of the knee",
}


def _warn(location: SourceLocation, message: str) -> None:
    warnings.warn(f"{location}: {message}", NetlistWarning, stacklevel=3)


def _node(token: str) -> str:
    return "0" if token in GROUND_NAMES else token


class _Reader:
    """Walks the tokens of one statement, turning mistakes into file:line errors."""

    def __init__(self, statement: Statement, start: int = 1):
        self.statement = statement
        self.tokens = statement.tokens
        self.position = start

    @property
    def location(self) -> SourceLocation:
        return self.statement.location

    def error(self, message: str, hint: str | None = None) -> NetlistError:
        return NetlistError(message, where=self.location, hint=hint)

    def done(self) -> bool:
        return self.position >= len(self.tokens)

    def peek(self, ahead: int = 0) -> str | None:
        """The token ``ahead`` places after the current one, or ``None`` past the end."""
        index = self.position + ahead
        return self.tokens[index] if index < len(self.tokens) else None

    def next(self, what: str) -> str:
        if self.done():
            raise self.error(f"{self.tokens[0]}: missing {what}", hint=f"in: {self.statement.text}")
        token = self.tokens[self.position]
        self.position += 1
        return token

    def value(self, what: str) -> float:
        token = self.next(what)
        try:
            return parse_value(token)
        except ValueError:
            raise self.error(f"{self.tokens[0]}: {what} {token!r} is not a number",
                             hint="numbers look like 10, 4.7k, 10uF, 1e-3") from None

    def nodes(self, count: int) -> tuple[str, ...]:
        return tuple(_node(self.next(f"node {k + 1} of {count}")) for k in range(count))

    def keyword_values(self) -> Iterator[tuple[str, str]]:
        """Yield ``key = value`` pairs until the end of the statement."""
        while not self.done():
            key = self.next("parameter")
            if self.peek() != "=":
                raise self.error(f"{self.tokens[0]}: expected '{key}=value', found {key!r} alone",
                                 hint=f"in: {self.statement.text}")
            self.position += 1
            yield key, self.next(f"value of {key}")


def elaborate(netlist: Netlist) -> Circuit:
    """Build the :class:`Circuit` described by ``netlist``.

    Models are read first, so a ``.model`` may come after the elements using it.

    Raises:
        NetlistError: for malformed or unsupported statements (with file:line).
    """
    circuit = Circuit(title=netlist.title, file=netlist.file)
    statements = list(_outside_control_blocks(netlist.statements))
    for statement in statements:
        if statement.keyword == ".model":
            _model(circuit, _Reader(statement))
    for statement in statements:
        keyword = statement.keyword
        if keyword == ".model":
            continue
        if statement.is_command:
            _command(circuit, statement)
        elif keyword[0] == "d":
            circuit.add(_diode(statement, _Reader(statement), circuit.models), statement.location)
        else:
            circuit.add(_element(statement), statement.location)
    _check_unused_models(circuit)
    _check_initial_conditions(circuit)
    if not netlist.ended:
        last = netlist.statements[-1].location.line if netlist.statements else 1
        _warn(SourceLocation(netlist.file, last),
              "the netlist has no .end line; read to the end of the file")
    return circuit


def _outside_control_blocks(statements: list[Statement]) -> Iterator[Statement]:
    """Statements outside ``.control ... .endc`` (ngspice scripts are not run; one warning each)."""
    opened: SourceLocation | None = None
    for statement in statements:
        if opened is not None:
            if statement.keyword == ".endc":
                opened = None
            continue
        if statement.keyword == ".control":
            opened = statement.location
            _warn(opened, ".control ... .endc block skipped "
                  "(ngspice scripting is not run by circuitnsds)")
            continue
        yield statement
    if opened is not None:
        raise NetlistError(".control block has no .endc", where=opened)


def _element(statement: Statement) -> Element:
    letter = statement.keyword[0]
    reader = _Reader(statement)
    if letter in "rcl":
        return _passive(letter, reader)
    if letter in "vi":
        nodes = reader.nodes(2)
        function = _source_function(reader)
        cls = VoltageSource if letter == "v" else CurrentSource
        return cls(statement.keyword, nodes, statement.location, function=function)
    if letter in UNSUPPORTED_ELEMENTS:
        raise reader.error(
            f"{statement.keyword}: {UNSUPPORTED_ELEMENTS[letter]} ('{letter.upper()}' lines) "
            "are not supported yet",
            hint="circuitnsds reads R, C, L, V, I and D elements",
        )
    raise reader.error(f"{statement.keyword}: unknown element type '{letter.upper()}'",
                       hint="element names start with their type letter: R, C, L, V, I, D")


def _passive(letter: str, reader: _Reader) -> Element:
    name = reader.tokens[0]
    nodes = reader.nodes(2)
    quantity = {"r": "resistance", "c": "capacitance", "l": "inductance"}[letter]
    value: float | None = None
    if reader.peek() is not None and reader.peek(1) != "=":
        value = reader.value(quantity)
    initial: float | None = None
    multiplier = 1.0
    for key, text in reader.keyword_values():
        number = _number(reader, key, text)
        if key == letter and value is None:
            value = number
        elif key == "ic" and letter in "cl":
            initial = number
        elif key == "m":
            multiplier = number
        elif key in {"tc1", "tc2", "temp", "dtemp", "tc", "noisy", "scale"}:
            _warn(reader.location, f"{name}: {key}= ignored (no temperature or noise modelling)")
        else:
            raise reader.error(f"{name}: parameter {key!r} is not supported",
                               hint=f"write {letter.upper()}name n1 n2 VALUE"
                               + (" [ic=VALUE]" if letter in "cl" else ""))
    if value is None:
        raise reader.error(f"{name}: missing {quantity}", hint=f"in: {reader.statement.text}")
    if multiplier <= 0:
        raise reader.error(f"{name}: m={multiplier:g} must be positive")
    if letter == "r":
        if value <= 0:
            raise reader.error(f"{name}: resistance must be positive, got {value:g}",
                               hint="use a 0 V voltage source for a short circuit")
        return Resistor(name, nodes, reader.location, resistance=value / multiplier)
    if value < 0:
        raise reader.error(f"{name}: {quantity} must not be negative, got {value:g}")
    if letter == "c":
        return Capacitor(name, nodes, reader.location, capacitance=value * multiplier,
                         initial_voltage=initial)
    return Inductor(name, nodes, reader.location, inductance=value / multiplier,
                    initial_current=initial)


def _number(reader: _Reader, key: str, text: str) -> float:
    try:
        return parse_value(text)
    except ValueError:
        raise reader.error(f"{reader.tokens[0]}: {key}={text!r} is not a number") from None


FUNCTION_ARITY = {"sin": (2, 6), "pulse": (2, 7), "exp": (2, 6), "pwl": (2, None)}


def _source_function(reader: _Reader) -> Stimulus:
    """Parse ``[DC] value [AC mag [phase]] [SIN(...)|PULSE(...)|PWL(...)|EXP(...)]``."""
    name = reader.tokens[0]
    dc: float | None = None
    function: Stimulus | None = None
    while not reader.done():
        token = reader.next("source value")
        if token == "dc":
            if dc is not None:
                raise reader.error(f"{name}: the DC value is given twice")
            dc = reader.value("DC value")
        elif token == "ac":
            reader.value("AC magnitude")  # small-signal only: no effect on a transient
            if reader.peek() is not None and is_value(reader.peek()):
                reader.value("AC phase")
        elif token in FUNCTION_ARITY:
            if function is not None:
                raise reader.error(f"{name}: more than one transient function")
            function = _function(reader, token)
        elif token in {"sffm", "am", "trnoise", "trrandom", "distof1", "distof2"}:
            raise reader.error(f"{name}: {token.upper()} sources are not supported",
                               hint="use DC, SIN, PULSE, PWL or EXP")
        elif is_value(token) and dc is None:
            dc = parse_value(token)
        else:
            raise reader.error(f"{name}: unexpected {token!r} in a source specification",
                               hint="write V1 n+ n- [DC] VALUE or V1 n+ n- SIN(VO VA FREQ ...)")
    if function is not None:
        return function
    return Dc(0.0 if dc is None else dc)


def _function(reader: _Reader, kind: str) -> Stimulus:
    name = reader.tokens[0]
    args: list[float] = []
    parenthesised = reader.peek() == "("
    if parenthesised:
        reader.position += 1
    while not reader.done() and reader.peek() != ")":
        if not is_value(reader.peek()):
            if parenthesised:
                raise reader.error(f"{name}: {kind.upper()} argument {reader.peek()!r} "
                                   "is not a number (PWL options r= and td= are not supported)")
            break
        args.append(reader.value(f"{kind.upper()} argument"))
    if parenthesised:
        if reader.done():
            raise reader.error(f"{name}: {kind.upper()}( has no closing parenthesis")
        reader.position += 1
    low, high = FUNCTION_ARITY[kind]
    if len(args) < low or (high is not None and len(args) > high):
        expected = f"{low} to {high}" if high else f"at least {low}"
        raise reader.error(f"{name}: {kind.upper()} takes {expected} numbers, got {len(args)}")
    if kind == "sin":
        return Sin(*args[:2], *_defaults(args[2:], [None, 0.0, 0.0, 0.0]))
    if kind == "pulse":
        pulse = Pulse(*args[:2], *_defaults(args[2:], [0.0, None, None, None, None]))
        if any(x is not None and x < 0 for x in (pulse.rise, pulse.fall, pulse.width)):
            raise reader.error(f"{name}: PULSE rise, fall and width must not be negative")
        return pulse
    if kind == "exp":
        function = Exp(*args[:2], *_defaults(args[2:], [0.0, None, None, None]))
        if any(x is not None and x < 0 for x in (function.rise_tau, function.fall_tau)):
            raise reader.error(f"{name}: EXP time constants must not be negative")
        return function
    if len(args) % 2:
        raise reader.error(f"{name}: PWL needs time-value pairs, got {len(args)} numbers")
    times, values = tuple(args[0::2]), tuple(args[1::2])
    if any(b < a for a, b in zip(times, times[1:])):
        raise reader.error(f"{name}: PWL times must not decrease")
    return Pwl(times, values)


def _defaults(given: list[float], defaults: list[float | None]) -> list[float | None]:
    return list(given) + defaults[len(given):]


def _diode(statement: Statement, reader: _Reader, models: dict[str, DiodeModel]) -> Diode:
    name = statement.keyword
    nodes = reader.nodes(2)
    model_name = reader.next("model name")
    if model_name not in models:
        raise reader.error(f"{name}: diode model {model_name!r} is not defined",
                           hint=f"add a line such as: .model {model_name} D()  "
                           f"(an ideal diode) or .model {model_name} D(Vfwd=0.7 Ron=10m)")
    model = models[model_name]
    if not isinstance(model, DiodeModel):
        raise reader.error(f"{name}: model {model_name!r} is a {model} model, not a diode (D) model")
    area = 1.0
    if reader.peek() is not None and is_value(reader.peek()):
        area = reader.value("area")
    while not reader.done():
        token = reader.next("parameter")
        if token == "off":
            _warn(reader.location, f"{name}: 'off' ignored (the ideal operating point needs no hint)")
            continue
        if reader.peek() != "=":
            raise reader.error(f"{name}: unexpected {token!r}",
                               hint="write Dname anode cathode MODEL [area]")
        reader.position += 1
        number = _number(reader, token, reader.next(f"value of {token}"))
        if token in {"area", "m"}:
            area *= number
        elif token in {"ic", "temp", "dtemp", "pj", "lm", "lp", "wm", "wp"}:
            _warn(reader.location, f"{name}: {token}= ignored by the ideal diode")
        else:
            raise reader.error(f"{name}: instance parameter {token!r} is not supported")
    if area <= 0:
        raise reader.error(f"{name}: area must be positive, got {area:g}")
    return Diode(name, nodes, statement.location, model=model, area=area)


def _command(circuit: Circuit, statement: Statement) -> None:
    keyword = statement.keyword
    reader = _Reader(statement)
    if keyword == ".tran":
        circuit.set_tran(_tran(reader), statement.location)
    elif keyword == ".ic":
        _initial_conditions(circuit, reader)
    elif keyword == ".title":
        circuit.title = statement.text.split(None, 1)[1] if " " in statement.text else ""
    elif keyword in IGNORED_COMMANDS:
        _warn(statement.location, f"{keyword} ignored: {IGNORED_COMMANDS[keyword]}")
    elif keyword in UNSUPPORTED_COMMANDS:
        raise reader.error(f"{keyword} is not supported yet",
                           hint="flatten the netlist (no parameters, subcircuits or includes)")
    else:
        raise reader.error(f"unknown command {keyword}",
                           hint="supported: .tran, .ic, .model, .end")


def _tran(reader: _Reader) -> TranSpec:
    numbers: list[float] = []
    uic = False
    while not reader.done():
        token = reader.peek()
        if token == "uic":
            uic = True
            reader.position += 1
        else:
            numbers.append(reader.value(".tran time"))
    if not 2 <= len(numbers) <= 4:
        raise reader.error(f".tran takes TSTEP TSTOP [TSTART [TMAX]] [UIC], got {len(numbers)} numbers")
    step, stop = numbers[0], numbers[1]
    start = numbers[2] if len(numbers) > 2 else 0.0
    max_step = numbers[3] if len(numbers) > 3 else None
    if step <= 0 or stop <= 0:
        raise reader.error(".tran TSTEP and TSTOP must be positive")
    if not 0 <= start < stop:
        raise reader.error(f".tran TSTART={start:g} must lie in [0, TSTOP)")
    if max_step is not None and max_step <= 0:
        raise reader.error(".tran TMAX must be positive")
    return TranSpec(step=step, stop=stop, start=start, max_step=max_step, uic=uic,
                    location=reader.location)


def _initial_conditions(circuit: Circuit, reader: _Reader) -> None:
    while not reader.done():
        kind = reader.next("v(node)=value")
        if kind != "v" or reader.peek() != "(":
            raise reader.error(f".ic: expected v(node)=value, found {kind!r}",
                               hint=".ic sets node voltages only: .ic v(out)=5 v(in)=0")
        reader.position += 1
        node = _node(reader.next("node name"))
        if reader.next("')'") != ")" or reader.next("'='") != "=":
            raise reader.error(".ic: expected v(node)=value")
        if node == "0":
            raise reader.error(".ic cannot set the ground node: it is 0 V by definition")
        circuit.initial_voltages[node] = (reader.value(f".ic value of v({node})"), reader.location)


def _model(circuit: Circuit, reader: _Reader) -> None:
    name = reader.next("model name")
    kind = reader.next("model type")
    if reader.peek() == "(":
        reader.position += 1
        if reader.tokens[-1] != ")":
            raise reader.error(f".model {name}: expected ')' at the end of the line",
                               hint="write .model NAME D(param=value ...) with every "
                               "parameter inside the parentheses")
        reader.tokens = reader.tokens[:-1]
    if name in circuit.models:
        raise reader.error(f".model {name} is defined twice")
    if kind != "d":
        circuit.models[name] = kind  # kept so that a use can be reported precisely
        circuit.model_locations[name] = reader.location
        return
    circuit.models[name] = _diode_model(name, reader)
    circuit.model_locations[name] = reader.location


def _diode_model(name: str, reader: _Reader) -> DiodeModel:
    model = DiodeModel(name, location=reader.location)
    params: dict[str, float] = {}
    for key, text in reader.keyword_values():
        if key in params:
            raise reader.error(f".model {name}: parameter {key!r} is given twice")
        params[key] = _number(reader, key, text)
    fields = {"vfwd": "forward_drop", "ron": "on_resistance", "roff": "off_resistance",
              "rrev": "breakdown_resistance"}
    for key, value in params.items():
        if key in fields:
            if value < 0 or (key == "roff" and value == 0):
                raise reader.error(f".model {name}: {key}={value:g} must be "
                                   + ("positive" if key == "roff" else "non-negative"))
            model = replace(model, **{fields[key]: value})
        elif key in {"bv", "vrev"}:
            if value <= 0:
                raise reader.error(f".model {name}: {key}={value:g}: the breakdown voltage "
                                   "must be positive")
            if model.breakdown_voltage not in (None, value):
                raise reader.error(f".model {name}: BV and Vrev disagree "
                                   f"({model.breakdown_voltage:g} vs {value:g})",
                                   hint="give the breakdown voltage once")
            model = replace(model, breakdown_voltage=value)
        elif key in UNMODELLED_PARAMETERS:
            _warn(reader.location, f".model {name}: {key} ignored: the ideal engine does not "
                  f"model {UNMODELLED_PARAMETERS[key]}")
        elif key not in SHOCKLEY_PARAMETERS:
            _warn(reader.location, f".model {name}: unknown diode parameter {key!r} ignored")
    if "rrev" in params and model.breakdown_voltage is None:
        _warn(reader.location, f".model {name}: Rrev ignored: it needs a breakdown voltage "
              "(BV or Vrev)")
    return model


def _check_unused_models(circuit: Circuit) -> None:
    used = {element.model.name for element in circuit.elements if isinstance(element, Diode)}
    for name, model in circuit.models.items():
        if name not in used:
            kind = model if isinstance(model, str) else "d"
            _warn(circuit.model_locations[name], f".model {name} ({kind.upper()}) is not used")


def _check_initial_conditions(circuit: Circuit) -> None:
    for node, (_, location) in circuit.initial_voltages.items():
        if node != "0" and node not in circuit.nodes:
            raise NetlistError(f".ic names node {node!r}, which no element connects",
                               where=location, hint=f"nodes are: {', '.join(circuit.nodes)}")
