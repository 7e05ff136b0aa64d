"""``.model NAME TYPE(param=value ...)`` cards: diodes (``D``), switches (``SW``, ``CSW``)
and resistors (``R``/``RES``). Other model types are recorded so that a use can be
reported precisely."""

from __future__ import annotations

from dataclasses import dataclass, replace

from circuitnsds.circuit.elements import DiodeModel, SwitchModel
from circuitnsds.circuit.elements.diode import DEFAULT_OFF_RESISTANCE, fitted_model
from circuitnsds.circuit.elements.diode_fit import MAX_BRANCHES, ShockleyDiode
from circuitnsds.frontend.cards.model_kinds import CODE_MODELS, MOS_KINDS, POWER_KINDS, SMOOTH_KINDS
from circuitnsds.frontend.cards.reader import StatementReader

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
# Resistor model parameters that only matter away from the nominal temperature or for noise.
RESISTOR_TEMPERATURE_PARAMETERS = {"tc1", "tc2", "tce", "tnom", "kf", "af", "lf", "wf", "ef",
                                   "bv_max", "noisy"}
DEFAULT_RESISTOR_WIDTH = 10e-6
"""ngspice's ``DEFW`` [m]."""
DEFAULT_RESISTOR_LENGTH = 10e-6
"""ngspice's ``DEFL`` [m]."""

MODEL_KINDS = {"d": "diode", "sw": "voltage-controlled switch", "csw": "current-controlled switch",
               "vswitch": "voltage-controlled switch", "iswitch": "current-controlled switch",
               "r": "resistor", "res": "resistor", **MOS_KINDS, **POWER_KINDS,
               **SMOOTH_KINDS}


@dataclass(frozen=True)
class ResistorModel:
    """``.model NAME R(...)``: what determines a model-named resistor's resistance.

    Attributes:
        resistance: ``R``/``RES`` [Ω], used when the instance gives no value.
        sheet_resistance: ``RSH`` [Ω/square].
        default_width: ``DEFW`` or ``W`` [m]; default_length: ``DEFL`` or ``L`` [m].
        narrow: ``NARROW`` [m], ``short``: ``SHORT`` [m] (geometry corrections).
    """

    name: str
    resistance: float | None = None
    sheet_resistance: float | None = None
    default_width: float = DEFAULT_RESISTOR_WIDTH
    default_length: float = DEFAULT_RESISTOR_LENGTH
    narrow: float = 0.0
    short: float = 0.0
    location: object | None = None


TEXT_PARAMETERS = {"mfg", "type"}
"""Parameters whose value is text in vendor libraries (``mfg=OnSemi type=Schottky``):
kept as documentation, never evaluated."""
LTSPICE_DIODE_PARAMETERS = {"ron", "roff", "vfwd", "vrev", "rrev", "epsilon", "revepsilon",
                            "ilimit", "revilimit"}
"""Any of these makes a ``D`` model LTspice's piecewise-linear diode (the rule of ngspice's
``ltspice_compat`` in ``inpcom.c``, which then runs it as its ``sidiode`` code model)."""
SHOCKLEY_STATIC_PARAMETERS = {"is", "js", "n", "rs", "ibv", "nbv", "ikf", "ik", "ikr", "isr", "nr"}
"""Parameters of the static Shockley curve: one of them makes the model fitted."""
LTSPICE_DEFAULT_ON_RESISTANCE = 1.0
"""``Ron`` [Ω] of an LTspice PWL diode that gives none (LTspice's help; ngspice's
``sidiode`` code model, ``ifspec.ifs``)."""


@dataclass(frozen=True)
class DiodeReading:
    """How ``.model ... D`` cards are read (from ``.options``).

    Attributes:
        ideal: ``.options diode=ideal``: Shockley parameters are ignored (the textbook
            ideal diode, or ideal Zener with ``BV``).
        limit: ``.options diode=limit``: a SPICE model is read as its limit N -> 0 (and
            NBV -> 0): ``Vfwd = 0``, ``Ron = RS``, breakdown at ``BV`` with ``Rrev = RS``
            (compare's study in N converges to it).
        fit_current: ``.options pwlfit=`` [A]: the top of the Shockley fit range for every
            model: its range is the 5 decades below it and no run refits it (else the range
            is where the circuit works, see :mod:`~circuitnsds.circuit.elements.diode_fit`).
    """

    ideal: bool = False
    limit: bool = False
    fit_current: float | None = None


def read_model(reader: StatementReader, off_resistance: float = DEFAULT_OFF_RESISTANCE,
               diodes: DiodeReading = DiodeReading()) -> tuple[str, object]:
    """Read a ``.model`` card; returns ``(name, model)``.

    ``model`` is a :class:`DiodeModel`, :class:`SwitchModel`, :class:`ResistorModel` or
    :class:`~circuitnsds.frontend.cards.mosfets.MosfetModel`,
    or the type name (a string) for a type the engine does not use.
    ``off_resistance`` [Ω] is the default off-resistance of diodes and switches
    (``1/GMIN``, from ``.options gmin``); ``diodes`` says how diode models are read.
    """
    name = reader.next("model name")
    kind = reader.next("model type")
    if kind == "ako" or kind.startswith("ako:"):
        raise reader.error(f".model {name} {kind}: LTspice's 'ako:' (a kind of) alias is not "
                           "supported", hint="copy the parameters of the model it names into a "
                           f".model {name} D(...) line")
    if reader.peek() == "(":
        reader.position += 1
        if reader.tokens[-1] != ")":
            raise reader.error(f".model {name}: expected ')' at the end of the line",
                               hint=f"write .model NAME {kind.upper()}(param=value ...) with every "
                               "parameter inside the parentheses")
        reader.tokens = reader.tokens[:-1]
    if "smooth" in reader.tokens[:-2]:  # the same flag on any model card: 0 or 1, nothing else
        from circuitnsds.frontend.cards.smooth_devices import smooth_flag

        at = reader.tokens.index("smooth")
        if reader.tokens[at + 1] == "=":
            smooth_flag(reader, reader.tokens[at + 2])
    if kind in CODE_MODELS:  # the families' modules imported only for a netlist that uses them
        from circuitnsds.frontend.cards.xspice import read_xspice_model

        return name, read_xspice_model(reader, name, kind)
    if kind in MOS_KINDS:
        from circuitnsds.frontend.cards.mosfets import read_mos_model

        return name, read_mos_model(name, kind, reader)
    if kind in SMOOTH_KINDS:
        from circuitnsds.frontend.cards.smooth_devices import read_smooth_model

        return name, read_smooth_model(name, kind, reader)
    if kind in POWER_KINDS:
        from circuitnsds.frontend.cards.power_devices import read_power_model

        return name, read_power_model(name, kind, reader)
    if kind not in MODEL_KINDS:
        return name, kind
    params: dict[str, float] = {}
    thermal = None
    for key, text in reader.keyword_values():
        if key in params or (key == "thermal" and thermal is not None):
            raise reader.error(f".model {name}: parameter {key!r} is given twice")
        if key == "thermal":
            if kind not in {"d", "sw", "csw"}:
                raise reader.error(f".model {name} {kind.upper()}: thermal= names a device's "
                                   "datasheet losses", hint="D, SW, CSW, IGBT, VDMOS, NMOS and "
                                   "PMOS models take thermal=\"file.xml\"")
            thermal = thermal_path(reader, text)
            continue
        if key in TEXT_PARAMETERS:
            continue
        params[key] = reader.number(key, text)
    if kind == "d" and params.get("smooth"):  # ngspice's Shockley diode as a smooth device
        from circuitnsds.frontend.cards.smooth_devices import shockley_diode_model

        return name, shockley_diode_model(name, params, reader)
    if kind == "d":
        return name, replace(_diode_model(name, params, reader, off_resistance, diodes),
                             thermal=thermal)
    if kind in PSPICE_SWITCHES:
        kind, params = _pspice_switch(name, kind, params, reader)
    if kind in {"sw", "csw"}:
        return name, replace(_switch_model(name, kind, params, reader, off_resistance),
                             thermal=thermal)
    return name, _resistor_model(name, params, reader)


def thermal_path(reader: StatementReader, token: str) -> str:
    """The file named by ``thermal="path.xml"`` (the PLECS thermal description of the device's
    losses and junction-to-case network), as written (the tokens are lower-case), relative to
    the file holding the card; it must exist."""
    from pathlib import Path

    start = reader.statement.text.lower().find(token)
    written = reader.statement.text[start:start + len(token)] if start >= 0 else token
    if written[:1] in "\"'" and written[-1:] == written[:1] and len(written) >= 2:
        written = written[1:-1]
    path = Path(written)
    home = reader.location.file
    if not path.is_absolute() and not home.startswith("<"):
        path = Path(home).parent / path
    if not path.is_file():
        raise reader.error(f"{reader.name}: thermal={written!r}: no such file ({path})",
                           hint="thermal= names a PLECS thermal description (.xml), relative to "
                           "the netlist")
    return str(path)


def _diode_model(name: str, params: dict[str, float], reader: StatementReader,
                 off_resistance: float, diodes: DiodeReading = DiodeReading()) -> DiodeModel:
    """An LTspice PWL model (``Ron``/``Vfwd``/...: LTspice's defaults ``Ron = 1 Ω``,
    ``Rrev = Ron``), a Shockley model fitted to a PWL one, or the ideal diode."""
    model = DiodeModel(name, off_resistance=off_resistance, location=reader.location)
    fields = {"vfwd": "forward_drop", "ron": "on_resistance", "roff": "off_resistance",
              "rrev": "breakdown_resistance"}
    ltspice = LTSPICE_DIODE_PARAMETERS & params.keys()
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
            reader.warn(f".model {name}: {key} ignored: the ideal engine does not "
                        f"model {UNMODELLED_PARAMETERS[key]}")
        elif key not in SHOCKLEY_PARAMETERS:
            reader.warn(f".model {name}: unknown diode parameter {key!r} ignored")
    if "rrev" in params and model.breakdown_voltage is None:
        reader.warn(f".model {name}: Rrev ignored: it needs a breakdown voltage (BV or Vrev)")
    if ltspice:
        on = params.get("ron", LTSPICE_DEFAULT_ON_RESISTANCE)
        model = replace(model, on_resistance=on,
                        breakdown_resistance=params.get("rrev", on) or on)
        ignored = sorted(SHOCKLEY_STATIC_PARAMETERS & params.keys())
        return replace(model, origin="LTspice PWL (defaults Ron=1 Ω, Rrev=Ron)"
                       + (f"; Shockley {', '.join(ignored)} ignored" if ignored else ""))
    shockley = SHOCKLEY_STATIC_PARAMETERS & params.keys()
    if not shockley:
        return model
    if diodes.ideal:
        return replace(model, origin="ideal (.options diode=ideal; Shockley "
                       f"{', '.join(sorted(shockley))} ignored)")
    if diodes.limit:
        series = params.get("rs", 0.0)
        return replace(model, on_resistance=series,
                       breakdown_resistance=series if model.breakdown_voltage else 0.0,
                       origin=f"the N -> 0 limit of the SPICE model (.options diode=limit): Vfwd=0, "
                       f"Ron=RS={series:g} Ω" + (", Rrev=RS" if model.breakdown_voltage else ""))
    return _fitted(model, params, reader, diodes.fit_current)


def _fitted(model: DiodeModel, params: dict[str, float], reader: StatementReader,
            fit_current: float | None) -> DiodeModel:
    """The PWL diode fitted to the Shockley curve of ``params`` (see ``diode_fit``)."""
    for key in ("is", "js", "n", "ibv", "nbv", "nr", "vj", "pb"):
        if key in params and params[key] <= 0:
            raise reader.error(f".model {model.name}: {key}={params[key]:g} must be positive")
    for key in ("rs", "ikf", "ik", "ikr", "isr"):  # 0: none (ngspice's default)
        if params.get(key, 0.0) < 0:
            raise reader.error(f".model {model.name}: {key}={params[key]:g} must not be negative")
    diode = ShockleyDiode(
        saturation_current=params.get("is", params.get("js", 1e-14)),
        emission=params.get("n", 1.0), series_resistance=params.get("rs", 0.0),
        breakdown_voltage=model.breakdown_voltage, breakdown_current=params.get("ibv", 1e-3),
        breakdown_emission=params.get("nbv", params.get("n", 1.0)),  # ngspice: NBV defaults to N
        average_current=params.get("iave"),
        knee_current=params.get("ikf", params.get("ik")) or None,
        reverse_knee_current=params.get("ikr") or None,
        recombination_current=params.get("isr") or None,
        recombination_emission=params.get("nr", 2.0),
        junction_potential=params.get("vj", params.get("pb", 1.0)),
        grading=params.get("m", params.get("mj", 0.5)))
    # the breakdown: one branch until a run shows breakdown current (then refitted), unless
    # pwlfit fixes the fits (no refit)
    fitted = fitted_model(model, diode, fit_current, fit_current,
                          breakdown_branches=MAX_BRANCHES if fit_current else 1)
    dynamic = [key.upper() for key in ("cjo", "cj0", "cj", "tt") if key in params]
    if dynamic:  # DESIGN: outside the ideal model, said in info
        fitted = replace(fitted, origin=fitted.origin + f"; {', '.join(dynamic)} ignored (junction "
                         "capacitance and transit time are outside the ideal model)")
    return fitted


PSPICE_SWITCHES = {
    "vswitch": ("sw", "v", {"von": 1.0, "voff": 0.0}),
    "iswitch": ("csw", "i", {"ion": 1e-3, "ioff": 0.0}),
}
"""PSpice's switch models -> (the SW/CSW kind, the control's letter, PSpice's defaults of ON/OFF)."""


def _pspice_switch(name: str, kind: str, params: dict[str, float],
                   reader: StatementReader) -> tuple[str, dict[str, float]]:
    """A PSpice ``VSWITCH(RON ROFF VON VOFF)`` (``ISWITCH``: ``ION IOFF``) as the ideal switch
    at the middle of its transition, ``VT = (VON + VOFF)/2``, ``VH = 0``: PSpice's resistance
    moves smoothly (log-linearly) from ``ROFF`` at ``VOFF`` to ``RON`` at ``VON``, which the
    ideal switch does at one threshold. PSpice's ``ROFF`` default 1 MΩ is kept."""
    sw_kind, letter, defaults = PSPICE_SWITCHES[kind]
    on = params.pop(f"{letter}on", defaults[f"{letter}on"])
    off = params.pop(f"{letter}off", defaults[f"{letter}off"])
    xyce = [key for key in (f"{letter}hon", f"{letter}hoff") if key in params]
    if xyce:
        raise reader.error(f".model {name} {kind.upper()}: {', '.join(k.upper() for k in xyce)} (Xyce's "
                           "hysteresis of its switch) is not supported (ngspice refuses it too)",
                           hint=f"write a {sw_kind.upper()} model with the threshold "
                           f"{letter.upper()}T and the hysteresis half-width {letter.upper()}H, e.g. "
                           f".model {name} {sw_kind.upper()}({letter.upper()}T=0.5 "
                           f"{letter.upper()}H=0.05 RON=1 ROFF=100)")
    for key in (f"{letter}t", f"{letter}h"):
        if key in params:
            raise reader.error(f".model {name} {kind.upper()}: {key.upper()} is not a PSpice {kind.upper()} "
                               f"parameter", hint=f"write {letter.upper()}ON and {letter.upper()}OFF, or "
                               f"a {sw_kind.upper()} model with {letter.upper()}T and {letter.upper()}H")
    if on == off:
        raise reader.error(f".model {name} {kind.upper()}: {letter.upper()}ON = {letter.upper()}OFF "
                           f"= {on:g}: no transition", hint=f"give {letter.upper()}ON and "
                           f"{letter.upper()}OFF different values")
    if on < off:  # closed below the threshold: ngspice's SW cannot say so
        raise reader.error(f".model {name} {kind.upper()}: {letter.upper()}ON < {letter.upper()}OFF "
                           "(a switch closed by a low control) is not supported",
                           hint="swap the control's nodes (S n+ n- nc- nc+) and the values")
    threshold = (on + off) / 2
    reader.warn(f".model {name} {kind.upper()} (PSpice; ngspice 39 does not read it) is read as the "
                f"ideal switch {sw_kind.upper()}({letter.upper()}T={threshold:g} {letter.upper()}H=0): "
                f"PSpice's smooth change of resistance between {letter.upper()}OFF={off:g} and "
                f"{letter.upper()}ON={on:g} becomes one step at their middle")
    return sw_kind, {**params, f"{letter}t": threshold, "roff": params.get("roff", 1e6)}


LTSPICE_SWITCH_PARAMETERS = {
    "lser": "Lser: series inductance", "vser": "Vser: series voltage drop when on",
    "ilimit": "Ilimit: current limit when on", "level": "Level: smooth transition",
    "oneway": "Oneway: diode-like conduction", "epsilon": "Epsilon: smooth transition width",
}
"""Switch-model parameters of LTspice that ngspice 39 ignores with a warning; so does circuitnsds."""


def _switch_model(name: str, kind: str, params: dict[str, float], reader: StatementReader,
                  off_resistance: float) -> SwitchModel:
    current = kind == "csw"
    threshold_key, hysteresis_key = ("it", "ih") if current else ("vt", "vh")
    known = {threshold_key, hysteresis_key, "ron", "roff"}
    for key in params:
        if key not in known and key not in LTSPICE_SWITCH_PARAMETERS:
            raise reader.error(f".model {name} {kind.upper()}: unknown parameter {key!r}",
                               hint=f"{kind.upper()} models take {', '.join(sorted(known))}")
    ignored = [key for key in params if key in LTSPICE_SWITCH_PARAMETERS]
    if ignored:
        reader.warn(f".model {name} {kind.upper()}: {', '.join(ignored)} ignored (LTspice's "
                    + "; ".join(LTSPICE_SWITCH_PARAMETERS[key] for key in ignored) + "; ngspice "
                    "ignores them too): the ideal switch has only RON, ROFF and its threshold; "
                    "write a series L, V or D beside the switch for what they stand for")
    on_resistance = params.get("ron", 1.0)
    off = params.get("roff", off_resistance)
    if on_resistance < 0:
        raise reader.error(f".model {name}: RON={on_resistance:g} must not be negative")
    if off <= 0:
        raise reader.error(f".model {name}: ROFF={off:g} must be positive")
    if params.get(hysteresis_key, 0.0) < 0:
        reader.warn(f".model {name}: negative {hysteresis_key.upper()} taken as its magnitude "
                    "(a hysteresis band of half-width |VH| around VT)")
    return SwitchModel(name, current_controlled=current, threshold=params.get(threshold_key, 0.0),
                       hysteresis=params.get(hysteresis_key, 0.0), on_resistance=on_resistance,
                       off_resistance=off, location=reader.location)


def _resistor_model(name: str, params: dict[str, float], reader: StatementReader) -> ResistorModel:
    model = ResistorModel(name, location=reader.location)
    fields = {"r": "resistance", "res": "resistance", "rsh": "sheet_resistance",
              "defw": "default_width", "w": "default_width", "defl": "default_length",
              "l": "default_length", "narrow": "narrow", "short": "short"}
    for key, value in params.items():
        if key in fields:
            model = replace(model, **{fields[key]: value})
        elif key not in RESISTOR_TEMPERATURE_PARAMETERS:
            reader.warn(f".model {name}: unknown resistor parameter {key!r} ignored")
    return model
