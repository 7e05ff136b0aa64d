"""Dot commands: ``.tran``, ``.pss``, ``.ac``, ``.ic``, ``.options``, ``.save``, ``.title``; warnings for
commands that concern other analyses or output, errors for unsupported ones."""

from __future__ import annotations

import re

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.frontend.cards.reader import StatementReader, node_name
from circuitnsds.netlist import Statement
from circuitnsds.specs import AcSpec, PssSpec, TransientSpec
from circuitnsds.theta import THETA_HINT, theta_in_range
from circuitnsds.units import format_si

IGNORED_COMMANDS = {
    ".print": "every signal is written; choose columns with --signals or .save",
    ".plot": "every signal is written; choose columns with --signals or .save",
    ".probe": "every signal is written; choose columns with --signals or .save",
    ".op": "only .tran is run (its operating point is computed unless UIC)",
    ".dc": "only .tran is supported",
    ".noise": "only .tran is supported", ".tf": "only .tran is supported",
    ".sens": "only .tran is supported", ".pz": "only .tran is supported",
    ".disto": "only .tran is supported",
    ".temp": "the ideal devices have no temperature dependence and the smooth ones run at 27 °C",
    ".width": "output formatting does not apply",
    ".backanno": "LTspice's schematic back-annotation; ngspice's LTspice mode removes it too",
    ".nodeset": "the ideal operating point needs no hints",
    ".csparam": "it hands a parameter to the .control script, which circuitnsds does not run "
                "but for its analyses and measurements; .param values reach the circuit",
}


USED_OPTIONS = {"theta": "θ of the θ-method, in [0.5, 1] (1 = implicit Euler)",
                "method": "the integration method, a stepper of circuitnsds.engine.stepper.STEPPERS "
                          "('theta', 'exact', 'newton') or 'auto' (newton for smooth elements, "
                          "else exact where the circuit qualifies); "
                          "ngspice's 'trap' and 'gear' are ignored",
                "gmin": "default off-conductance [S] of diodes and switches (Roff = 1/gmin)",
                "mosdrive": "gate drive |Vgs| [V] at which a MOSFET's on-resistance is computed "
                            "(default: the drive the circuit applies, found by a first run)",
                "mosfet": "'switch' to keep every MOSFET read as an ideal switch, also where a run "
                          "shows it is none ('auto', the default: made the smooth device then)",
                "pwlfit": "top of the current range [A] over which Shockley diode models are "
                "fitted by parallel PWL branches (5 decades below it), or 'auto' (the default): "
                "where a run's currents are",
                "diode": "'ideal' to read SPICE diode models as ideal diodes, 'limit' as their "
                         "N -> 0 limit (Vfwd = 0, Ron = RS, breakdown at BV with Rrev = RS)",
                "seed": "seed of the Monte Carlo functions (agauss, mc, ...; a positive integer)",
                "tcase": "case temperature [°C] of the devices with thermal= data (default 25)",
                "tamb": "ambient temperature [°C] of the heatsink (with rthsa)",
                "rthsa": "thermal resistance [K/W] of the heatsink shared by the devices with "
                "thermal= data, to ambient",
                "cthsa": "thermal capacitance [J/K] of the heatsink (with rthsa; default 0)"}
TEXT_OPTIONS = {"diode": {"ideal", "fit", "limit"}, "mosfet": {"switch", "auto"}}
NGSPICE_METHODS = {"trap", "trapezoidal", "gear"}
"""ngspice's ``.options method`` values: ignored with the other options circuitnsds does not use
(its θ-method is ``.options theta``)."""
OPTION_KEYWORDS = {".options", ".option", ".opt"}


def read_options(reader: StatementReader) -> dict[str, float | str]:
    """``.options name[=value] ...``: the options the engine uses, checked; one warning
    naming all the others."""
    used: dict[str, float | str] = {}
    ignored: list[str] = []
    while not reader.done():
        key = reader.next("option")
        text = None
        if reader.peek() == "=":
            reader.position += 1
            text = reader.next(f"value of {key}")
        if key not in USED_OPTIONS:
            ignored.append(key if text is None else f"{key}={text}")
            continue
        if text is None:
            raise reader.error(f".options {key} needs a value", hint=f"{key}: {USED_OPTIONS[key]}")
        if key == "pwlfit" and text == "auto":
            used[key] = text
            continue
        if key == "method":
            method = text.lower()
            if method in NGSPICE_METHODS:  # ngspice's integration methods: not circuitnsds's
                ignored.append(f"{key}={text}")
            else:  # (checked against the steppers by the analysis that runs one)
                used[key] = method
            continue
        if key in TEXT_OPTIONS:
            if text not in TEXT_OPTIONS[key]:
                raise reader.error(f".options {key}={text} is not understood",
                                   hint=f"{key} takes {' or '.join(sorted(TEXT_OPTIONS[key]))}")
            used[key] = text
            continue
        value = reader.number(key, text)
        if key == "theta" and not theta_in_range(value):
            raise reader.error(f".options theta={value:g} must lie in [0.5, 1]", hint=THETA_HINT)
        if key in {"gmin", "mosdrive", "pwlfit", "rthsa"} and value <= 0:
            raise reader.error(f".options {key}={value:g} must be positive")
        if key == "cthsa" and value < 0:
            raise reader.error(f".options cthsa={value:g} must not be negative")
        if key == "seed" and (value != int(value) or value < 0):
            raise reader.error(f".options seed={value:g} must be a non-negative integer")
        used[key] = value
    if ("tamb" in used or "cthsa" in used) and "rthsa" not in used:
        raise reader.error(".options tamb/cthsa describe a heatsink, and rthsa is not given",
                           hint="give the heatsink's rthsa=K/W (and tamb=°C, cthsa=J/K), or "
                           "tcase=°C for a case at a fixed temperature")
    if "tcase" in used and "rthsa" in used:
        raise reader.error(".options tcase and a heatsink (rthsa) both fix the case temperature",
                           hint="give tcase=°C for a fixed case, or rthsa/cthsa/tamb for a heatsink")
    if ignored:
        reader.warn(f".options {' '.join(ignored)} ignored (circuitnsds uses only "
                    f"{', '.join(USED_OPTIONS)})")
    return used


def command(circuit: Circuit, statement: Statement) -> None:
    """Apply a dot command (other than ``.model`` and ``.options``) to ``circuit``."""
    keyword = statement.keyword
    reader = StatementReader(statement)
    if keyword == ".tran":
        tran = _tran(reader)
        first = circuit.analyses.setdefault("tran", tran)
        if first is not tran:  # ngspice runs the first .tran and warns
            reader.warn(f"second .tran line ignored: the first one (at {first.location}) runs, "
                        "as in ngspice")
    elif keyword == ".pss":
        if "pss" in circuit.analyses:
            raise reader.error("more than one .pss line", hint="keep one .pss GFREQ ... line")
        circuit.analyses["pss"] = _pss(reader)
    elif keyword == ".ac":
        if "ac" in circuit.analyses:
            raise reader.error("more than one .ac line", hint="keep one .ac DEC|OCT|LIN N FSTART FSTOP")
        circuit.analyses["ac"] = _ac(reader)
    elif keyword == ".ic":
        _initial_conditions(circuit, reader)
    elif keyword == ".save":
        _save(circuit, statement)
    elif keyword in {".meas", ".measure"}:
        from circuitnsds.frontend.cards.meas import parse_meas

        spec = parse_meas(statement.text, statement.location)
        if spec is None:
            reader.warn(f"{keyword} ignored (only .meas tran is run): {statement.text}")
        else:
            circuit.measurements.append(spec)
    elif keyword == ".four":
        from circuitnsds.frontend.cards.meas import parse_four

        circuit.fourier.append(parse_four(statement.text, statement.location))
    elif keyword == ".title":
        circuit.title = statement.text.split(None, 1)[1] if " " in statement.text else ""
    elif keyword in IGNORED_COMMANDS:
        reader.warn(f"{keyword} ignored ({IGNORED_COMMANDS[keyword]}): {statement.text}")
    else:
        raise reader.error(f"unknown command {keyword}",
                           hint="supported: .tran, .pss, .ac, .ic, .model, .options, .param, .subckt, "
                           ".include, .lib, .save, .end")


_SIGNAL = re.compile(r"[a-z]+\s*\([^)]*\)|[^\s,]+", re.IGNORECASE)


def _save(circuit: Circuit, statement: Statement) -> None:
    """``.save v(out) i(l1) ...`` selects the signals written by the command line."""
    text = statement.text.split(None, 1)[1] if " " in statement.text.strip() else ""
    names = [re.sub(r"\s+", "", name).lower() for name in _SIGNAL.findall(text)]
    names = [name for name in names if name not in {"all", "allv", "alli", "v(*)", "i(*)"}]  # (PSpice's *)
    for name in names:
        if name.startswith("@"):
            StatementReader(statement).warn(f".save {name} ignored: device parameters (@...) "
                                            "are not outputs of circuitnsds")
        elif name not in circuit.saved_signals:
            circuit.saved_signals.append(name)
    circuit.save_location = statement.location


DEFAULT_STEPS = 1000
"""``.tran 0 TSTOP`` and ``.tran TSTOP`` (LTspice) integrate with ``TSTOP/DEFAULT_STEPS``."""


def _tran(reader: StatementReader) -> TransientSpec:
    numbers: list[float] = []
    uic = False
    while not reader.done():
        token = reader.peek()
        if token == "uic":
            uic = True
            reader.position += 1
        elif token == "noop":  # Xyce's "no operating point": UIC's meaning
            reader.warn(".tran NOOP (Xyce's: no operating point) read as UIC; ngspice refuses it, "
                        "write UIC for both")
            uic = True
            reader.position += 1
        else:
            numbers.append(reader.value(".tran time"))
    if not 1 <= len(numbers) <= 4:
        raise reader.error(".tran takes TSTEP TSTOP [TSTART [TMAX]] [UIC] (or LTspice's .tran TSTOP), "
                           "got no number")
    if len(numbers) == 1:  # LTspice: .tran TSTOP
        numbers = [0.0, numbers[0]]
    step, stop = numbers[0], numbers[1]
    if step == 0 and stop > 0:  # LTspice: .tran 0 TSTOP (the simulator chooses its step)
        step = stop / DEFAULT_STEPS
        reader.warn(f".tran without TSTEP (LTspice form): step TSTOP/{DEFAULT_STEPS} = "
                    f"{format_si(step, 's')} (refined further where a source needs it)")
    start = numbers[2] if len(numbers) > 2 else 0.0
    max_step = numbers[3] if len(numbers) > 3 else None
    for what, value in (("TSTEP", step), ("TSTOP", stop)):
        if value <= 0:
            raise reader.error(f".tran {what} = {format_si(value, 's')} must be positive",
                               hint=".tran TSTEP TSTOP [TSTART [TMAX]] [UIC], e.g. .tran 1u 10m")
    if not 0 <= start < stop:
        raise reader.error(f".tran TSTART={start:g} must lie in [0, TSTOP)")
    if max_step is not None and max_step <= 0:
        raise reader.error(".tran TMAX must be positive")
    return TransientSpec(step=step, stop=stop, start=start, max_step=max_step, uic=uic,
                    location=reader.location)


def _ac(reader: StatementReader) -> AcSpec:
    """``.ac DEC|OCT|LIN N FSTART FSTOP``."""
    usage = ".ac DEC|OCT|LIN N FSTART FSTOP, e.g. .ac dec 20 10 1meg"
    sweep = reader.next(".ac sweep type") if not reader.done() else ""
    if sweep not in ("dec", "oct", "lin"):
        raise reader.error(f".ac sweep type must be DEC, OCT or LIN, got {sweep.upper() or 'nothing'}",
                           hint=usage)
    numbers = []
    while not reader.done() and len(numbers) < 3:
        numbers.append(reader.value(".ac field"))
    if len(numbers) != 3 or not reader.done():
        raise reader.error(".ac takes a sweep type and three numbers", hint=usage)
    points, start, stop = numbers
    if points < 1 or points != int(points):
        raise reader.error(f".ac N = {points:g} must be a positive integer", hint=usage)
    if not 0 < start <= stop:
        raise reader.error(f".ac needs 0 < FSTART <= FSTOP, got {start:g} and {stop:g}", hint=usage)
    return AcSpec(sweep=sweep, points=int(points), start=start, stop=stop, location=reader.location)


PSS_FIELDS = ("GFREQ", "TSTAB", "OSCNOB", "PSSPOINTS", "HARMS", "SCITER", "STEADYCOEFF")
"""The fields of ngspice's ``.pss`` line, in order."""


def _pss(reader: StatementReader) -> PssSpec:
    """``.pss GFREQ [TSTAB [OSCNOB [PSSPOINTS [HARMS [SCITER [STEADYCOEFF]]]]]] [UIC]``.

    GFREQ is the period's inverse (ngspice: a guess for an oscillator; here the exact
    frequency of the sources), TSTAB a transient run before shooting, PSSPOINTS the
    steps per period, SCITER the Newton iterations, STEADYCOEFF the tolerance. OSCNOB
    (the oscillation node of an autonomous circuit) and HARMS (harmonics printed) are
    read and ignored with a warning when given.
    """
    usage = ".pss GFREQ [TSTAB [OSCNOB [PSSPOINTS [HARMS [SCITER [STEADYCOEFF]]]]]] [UIC]"
    fields: list[str | float] = []
    uic = False
    while not reader.done():
        if reader.peek() == "uic":
            uic = True
            reader.position += 1
        elif len(fields) == 2:
            fields.append(node_name(reader.next("OSCNOB node")))
        elif len(fields) < len(PSS_FIELDS):
            fields.append(reader.value(f".pss {PSS_FIELDS[len(fields)]}"))
        else:
            raise reader.error(f".pss takes at most {len(PSS_FIELDS)} fields", hint=usage)
    if not fields:
        raise reader.error(".pss needs GFREQ, the fundamental frequency [Hz]", hint=usage)
    frequency = float(fields[0])
    if not frequency > 0:
        raise reader.error(f".pss GFREQ = {frequency:g} Hz must be positive", hint=usage)
    stabilisation = float(fields[1]) if len(fields) > 1 else 0.0
    if stabilisation < 0:
        raise reader.error(f".pss TSTAB = {stabilisation:g} s must not be negative", hint=usage)
    if len(fields) > 2 and fields[2] != "0":
        reader.warn(f".pss OSCNOB {fields[2]} ignored: the period is set by the sources (an "
                    "autonomous oscillator's period is not searched for)")
    counts = {}
    for index, name in ((3, "PSSPOINTS"), (5, "SCITER")):
        if len(fields) > index:
            value = float(fields[index])
            if value < 1 or value != int(value):
                raise reader.error(f".pss {name} = {value:g} must be a positive integer", hint=usage)
            counts[name] = int(value)
    if len(fields) > 4:
        reader.warn(".pss HARMS ignored: harmonics are not printed (measure them on the settled "
                    "period, e.g. --measure \"thd(v(out), FREQ)\")")
    tol = float(fields[6]) if len(fields) > 6 else None
    if tol is not None and not tol > 0:
        raise reader.error(f".pss STEADYCOEFF = {tol:g} must be positive", hint=usage)
    return PssSpec(frequency=frequency, stabilisation=stabilisation, points=counts.get("PSSPOINTS"),
                   iterations=counts.get("SCITER"), tol=tol, uic=uic, location=reader.location)


def _initial_conditions(circuit: Circuit, reader: StatementReader) -> None:
    while not reader.done():
        kind = reader.next("v(node)=value")
        if kind != "v" or reader.peek() != "(":
            raise reader.error(f".ic: expected v(node)=value, found {kind!r}",
                               hint=".ic sets node voltages only: .ic v(out)=5 v(in)=0")
        reader.position += 1
        node = node_name(reader.next("node name"))
        if reader.next("')'") != ")" or reader.next("'='") != "=":
            raise reader.error(".ic: expected v(node)=value")
        if node == "0":
            raise reader.error(".ic cannot set the ground node: it is 0 V by definition")
        value = reader.value(f".ic value of v({node})")
        earlier = circuit.initial_voltages.get(node)
        if earlier is not None and earlier[0] != value:
            reader.warn(f".ic v({node}) is given twice, {earlier[0]:g} (at {earlier[1]}) and "
                        f"{value:g}: the last one is used")
        circuit.initial_voltages[node] = (value, reader.location)


