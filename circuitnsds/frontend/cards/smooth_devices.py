"""Smooth semiconductor devices: ``.model NAME NPN|PNP(...)`` with ``Q`` lines (Gummel–Poon,
:mod:`circuitnsds.circuit.elements.smooth.bjt`) and ``.model NAME NJF|PJF(...)`` with ``J``
lines (:mod:`circuitnsds.circuit.elements.smooth.jfet`).

Parameters take ngspice 39's names (and its aliases: ``VA`` for ``VAF``, ``IK`` for ``IKF``,
``PE`` for ``VJE``, ``VT0`` for ``VTO``...), units and defaults; a name ngspice does not know
(PSpice's ``ISR``, ``ALPHA`` of a vendor JFET) is ignored with a warning, as ngspice ignores
it. The devices are simulated at ngspice's nominal
temperature (27 °C): temperature coefficients, noise and safe-operating-area parameters are
read and change nothing there; a parameter whose effect the equations leave out (the
substrate diode ``ISS``, quasi-saturation ``RCO``, ``NKF``, excess phase ``PTF``) is refused
by name rather than dropped, as is a model whose ``TNOM`` is not 27 °C.
"""

from __future__ import annotations

from dataclasses import replace

from circuitnsds.circuit.elements.smooth.bjt import Bjt, BjtModel
from circuitnsds.circuit.elements.smooth.jfet import Jfet, JfetModel
from circuitnsds.circuit.elements.smooth.junctions import NOMINAL_TEMPERATURE
from circuitnsds.frontend.cards.reader import StatementReader, node_name
from circuitnsds.values import parse_value

BJT_PARAMETERS = {
    "is": "is_", "bf": "bf", "br": "br", "nf": "nf", "nr": "nr", "vaf": "vaf", "va": "vaf",
    "var": "var", "vb": "var", "ikf": "ikf", "ik": "ikf", "ikr": "ikr", "ise": "ise", "c2": "ise",
    "ne": "ne", "isc": "isc", "c4": "isc", "nc": "nc", "rb": "rb", "rbm": "rbm", "irb": "irb",
    "rc": "rc", "re": "re", "cje": "cje", "vje": "vje", "pe": "vje", "mje": "mje", "me": "mje",
    "cjc": "cjc", "vjc": "vjc", "pc": "vjc", "mjc": "mjc", "mc": "mjc", "xcjc": "xcjc",
    "tf": "tf", "xtf": "xtf", "vtf": "vtf", "itf": "itf", "tr": "tr", "fc": "fc",
    "cjs": "cjs", "ccs": "cjs", "csub": "cjs",
}
"""``.model NPN|PNP`` parameter (and alias) -> :class:`BjtModel` field."""
BJT_NO_EFFECT = {
    # temperature dependence (none at TEMP = TNOM), noise, safe operating area, documentation
    "xtb", "eg", "xti", "kf", "af", "tlev", "tlevc", "ctc", "cte", "cts", "tvjc", "tvje", "tvjs",
    "vbe_max", "vbc_max", "vce_max", "pd_max", "ic_max", "ib_max", "te_max", "rth0", "level",
    "vjs", "ps", "ns", "vceo", "icrating", "iave", "vpk",
    *(f"t{name}{k}" for name in ("bf", "br", "ikf", "ikr", "irb", "nc", "ne", "nf", "nr", "rb",
                                 "rc", "re", "rm", "vaf", "var", "itf", "tf", "tr", "mje",
                                 "mjc", "mjs", "ns", "is", "ise", "isc", "iss") for k in (1, 2)),
    "trb", "trc", "tre",
}
"""Parameters that change nothing at the nominal temperature, or describe the device only."""
BJT_REFUSED = {
    "iss": "the substrate diode", "mjs": "the grading of the substrate capacitance (a "
    "constant CJS is modelled)", "ms": "the grading of the substrate capacitance (a constant "
    "CJS is modelled)",
    "ptf": "excess phase", "rco": "quasi-saturation", "qco": "quasi-saturation",
    "vo": "quasi-saturation", "gamma": "quasi-saturation", "quasimod": "quasi-saturation",
    "vg": "quasi-saturation", "cn": "quasi-saturation", "d": "quasi-saturation",
    "nkf": "the high-injection exponent", "nk": "the high-injection exponent",
    "ibe": "separate B-E saturation current", "ibc": "separate B-C saturation current",
}
"""Parameters whose effect the Gummel–Poon equations here leave out (refused when nonzero)."""



JFET_PARAMETERS = {"vto": "vto", "vt0": "vto", "beta": "beta", "lambda": "lam", "rd": "rd",
                   "rs": "rs", "cgs": "cgs", "cgd": "cgd", "pb": "pb", "is": "is_", "fc": "fc",
                   "b": "b"}
"""``.model NJF|PJF`` parameter (and alias) -> :class:`JfetModel` field."""
JFET_NO_EFFECT = {"tcv", "vtotc", "bex", "betatce", "xti", "eg", "kf", "af", "nlev", "gdsnoi",
                  "level", "mfg", "type"}
"""JFET parameters that change nothing at the nominal temperature (or in a simulation)."""


def read_smooth_model(name: str, kind: str, reader: StatementReader) -> BjtModel | JfetModel:
    """The parameters of a ``.model NAME NPN|PNP|NJF|PJF(...)`` card (after its type word)."""
    params: dict[str, float] = {}
    for key, text in reader.keyword_values():
        if key in params:
            raise reader.error(f".model {name}: parameter {key!r} is given twice")
        if key in {"mfg", "type"}:  # text in vendor libraries: documentation
            continue
        params[key] = reader.number(key, text)
    if kind in {"njf", "pjf"}:
        return jfet_model(name, kind, params, reader)
    return bjt_model(name, kind, params, reader)


def _nominal_temperature(name: str, params: dict[str, float], reader: StatementReader) -> None:
    """Refuse a ``TNOM`` other than 27 °C: the parameters would be scaled to 27 °C."""
    for key in ("tnom", "tref"):
        value = params.get(key)
        if value is not None and abs(value + 273.15 - NOMINAL_TEMPERATURE) > 1e-9:
            raise reader.error(f".model {name}: TNOM={value:g} °C: the smooth devices run at "
                               "27 °C and do not scale their parameters to another TNOM",
                               hint="give the parameters at 27 °C and leave TNOM out")


def _ignored(name: str, kind: str, keys: list[str], reader: StatementReader) -> None:
    if keys:
        reader.warn(f".model {name} {kind.upper()}: {', '.join(keys)} ignored: not a parameter "
                    "of ngspice 39's model, which ignores it too")


def jfet_model(name: str, kind: str, params: dict[str, float], reader: StatementReader) -> JfetModel:
    """A :class:`JfetModel` from the parameters of its card (lower-case names, SI units)."""
    _nominal_temperature(name, params, reader)
    fields: dict[str, float] = {}
    for key, value in params.items():
        if key in JFET_PARAMETERS:
            if JFET_PARAMETERS[key] in fields:
                raise reader.error(f".model {name}: {key.upper()} gives VTO a second time")
            fields[JFET_PARAMETERS[key]] = value
    _ignored(name, kind, [key for key in params if key not in JFET_PARAMETERS
                          and key not in JFET_NO_EFFECT | {"tnom", "tref"}], reader)
    if params.get("level", 1) != 1:
        raise reader.error(f".model {name}: JFET level {params['level']:g} is not supported",
                           hint="circuitnsds has ngspice's level 1")
    model = JfetModel(name, 1 if kind == "njf" else -1, location=reader.location, **fields)
    problems = [f"{key.upper()} must not be negative" for key in
                ("beta", "rd", "rs", "cgs", "cgd", "is_") if getattr(model, key) < 0]
    if model.pb <= 0:
        problems.append("PB must be positive")
    if model.pb == model.vto:
        problems.append("PB must differ from VTO (B's profile divides by PB - VTO)")
    if not 0 <= model.fc < 1:
        problems.append("FC must lie in [0, 1)")
    if problems:
        raise reader.error(f".model {name}: {'; '.join(p.replace('IS_', 'IS') for p in problems)}")
    if model.fc > 0.95:
        reader.warn(f".model {name}: FC={model.fc:g} limited to 0.95, as ngspice limits it")
    return model


def bjt_model(name: str, kind: str, params: dict[str, float], reader: StatementReader) -> BjtModel:
    """A :class:`BjtModel` from the parameters of its card (lower-case names, SI units)."""
    _nominal_temperature(name, params, reader)
    fields: dict[str, float] = {}
    unknown: list[str] = []
    lateral = kind == "pnp"
    for key, value in params.items():
        if key in BJT_PARAMETERS:
            if BJT_PARAMETERS[key] in fields:
                raise reader.error(f".model {name}: {key.upper()} gives "
                                   f"{BJT_PARAMETERS[key].rstrip('_').upper()} a second time")
            fields[BJT_PARAMETERS[key]] = value
        elif key == "subs":
            lateral = value < 0
        elif key in BJT_REFUSED:
            if value:
                raise reader.error(f".model {name}: {key.upper()}={value:g} ({BJT_REFUSED[key]}) "
                                   "is not modelled", hint=f"leave {key.upper()} out (or 0) to "
                                   "run without it")
        elif key not in BJT_NO_EFFECT | {"tnom", "tref"}:
            unknown.append(key)
    _ignored(name, kind, unknown, reader)
    if params.get("level", 1) != 1:
        raise reader.error(f".model {name}: BJT level {params['level']:g} is not supported",
                           hint="circuitnsds has ngspice's level 1 (Gummel-Poon)")
    model = BjtModel(name, 1 if kind == "npn" else -1, lateral=lateral, location=reader.location,
                     **fields)
    problems = [f"{key.upper()} must be positive" for key in ("bf", "br", "nf", "nr", "ne", "nc")
                if getattr(model, key) <= 0]
    problems += [f"{key.upper()} must not be negative" for key in
                 ("is_", "ise", "isc", "ikf", "ikr", "rb", "irb", "rc", "re", "cje", "cjc",
                  "tf", "tr", "itf", "xtf", "cjs") if getattr(model, key) < 0]
    if model.rbm is not None and not 0 <= model.rbm <= model.rb:
        problems.append("RBM must lie between 0 and RB")
    if not 0 <= model.xcjc <= 1:
        problems.append("XCJC must lie in [0, 1]")
    if not 0 <= model.fc < 1:
        problems.append("FC must lie in [0, 1)")
    if model.is_ == 0:
        problems.append("IS must be positive")
    if problems:
        raise reader.error(f".model {name}: {'; '.join(p.replace('IS_', 'IS') for p in problems)}")
    return replace(model, fc=min(model.fc, 0.9999))


def bjt_node_count(words: list[str], models: dict[str, object]) -> int:
    """How many of an instance line's positional ``words`` (after the name) are nodes: 3 when
    the fourth names a model (as ngspice's parser decides) or is the last word, else 4
    (``c b e s MODEL``)."""
    return 3 if len(words) <= 4 or isinstance(models.get(words[3]), BjtModel) else 4


def bjt(reader: StatementReader, models: dict[str, object], off_resistance: float) -> Bjt:
    """``Q name c b e [s] MODEL [area] [off] [m=..]``: a Gummel–Poon transistor. ``off_resistance``
    [Ω] is ``1/GMIN``, the conductance ngspice puts across each junction."""
    words = _positional_words(reader)
    count = bjt_node_count(words, models)
    if len(words) < count + 1:
        raise reader.error(f"{reader.name}: expected collector, base, emitter, [substrate,] and a "
                           f"model name, got {len(words)} word(s)", hint="write Qname c b e MODEL")
    nodes = tuple(node_name(token) for token in words[:count]) + (("0",) if count == 3 else ())
    model = _model(reader, models, words[count], BjtModel, "a bipolar (NPN, PNP)",
                   "NPN(IS=1e-14 BF=100)")
    multiplier = _instance_multiplier(reader, words[count + 1:], "Q")
    return Bjt(reader.name, nodes, reader.location, model=model, multiplier=multiplier,
               gmin=1.0 / off_resistance)


def jfet(reader: StatementReader, models: dict[str, object], off_resistance: float) -> Jfet:
    """``J name d g s MODEL [area] [off] [m=..]``: a level-1 JFET. ``off_resistance`` [Ω] is
    ``1/GMIN``, the conductance ngspice puts across each gate junction."""
    words = _positional_words(reader)
    if len(words) < 4:
        raise reader.error(f"{reader.name}: expected drain, gate, source and a model name, got "
                           f"{len(words)} word(s)", hint="write Jname d g s MODEL")
    nodes = tuple(node_name(token) for token in words[:3])
    model = _model(reader, models, words[3], JfetModel, "a JFET (NJF, PJF)",
                   "NJF(VTO=-2 BETA=1m)")
    multiplier = _instance_multiplier(reader, words[4:], "J")
    return Jfet(reader.name, nodes, reader.location, model=model, multiplier=multiplier,
                gmin=1.0 / off_resistance)


def _positional_words(reader: StatementReader) -> list[str]:
    """The words of an instance line before its ``key=value`` parameters, ``off`` aside (a hint
    for ngspice's first Newton iterate: the solution it converges to is the same)."""
    words: list[str] = []
    while not reader.done() and reader.peek(1) != "=":
        token = reader.next("node or model")
        if token != "off":
            words.append(token)
    return words


def _model(reader: StatementReader, models: dict[str, object], model_name: str, kind: type,
           what: str, example: str):
    model = models.get(model_name)
    if not isinstance(model, kind):
        problem = "is not defined" if model is None else f"is not {what} model"
        raise reader.error(f"{reader.name}: model {model_name!r} {problem}",
                           hint=f"add a line such as: .model {model_name} {example}")
    return model


def _instance_multiplier(reader: StatementReader, extra: list[str], letter: str) -> float:
    """The instance's ``m=`` after its model (and its optional area, which must be 1)."""
    name = reader.name
    instance = {"m": 1.0, "area": 1.0}
    if extra:
        if len(extra) > 1:
            raise reader.error(f"{name}: unexpected {' '.join(extra[1:])!r} after the area")
        instance["area"] = parse_value(extra[0]) if _is_number(extra[0]) else -1.0
    for key, text in reader.keyword_values():
        if key in instance:
            instance[key] = reader.number(key, text)
        elif key == "ic":
            raise reader.error(f"{name}: IC= (initial junction voltages for UIC) is not supported",
                               hint="set the node voltages with .ic instead")
        elif key in {"temp", "dtemp"}:
            raise reader.error(f"{name}: {key}= is not supported: the smooth devices run at 27 °C",
                               hint=f"remove {key}=, or give the model the parameters it has at "
                               "that temperature")
        else:
            raise reader.error(f"{name}: instance parameter {key!r} is not supported",
                               hint=f"{letter} lines take m=")
    if instance["area"] != 1.0:
        raise reader.error(f"{name}: area {extra[0] if extra else instance['area']} is not "
                           "supported (only 1)", hint="scale the model's currents, resistances "
                           "and capacitances in a model of its own, or use m= for parallel devices")
    if instance["m"] <= 0:
        raise reader.error(f"{name}: m={instance['m']:g} must be positive")
    return instance["m"]


def _is_number(token: str) -> bool:
    try:
        parse_value(token)
    except ValueError:
        return False
    return True


SMOOTH_FLAG = "smooth"
"""``smooth=1`` on an ``M`` line or on its ``.model`` makes the MOSFET the smooth device of
ngspice's equations instead of the ideal switch (``smooth=0`` on the line keeps the switch
for a model that says ``smooth=1``)."""
MOS1_REFUSED = {
    "js": "the junction current density (needs AD, AS)", "cj": "the bottom junction "
    "capacitance per area (needs AD, AS)", "cjsw": "the sidewall junction capacitance (needs "
    "PD, PS)", "rsh": "the sheet resistance (needs NRD, NRS)",
}
"""Level-1 parameters whose geometry the smooth device does not take (refused when nonzero)."""


def smooth_flag(reader, text: str) -> bool:
    """The value of ``smooth=`` written as ``text``: 1 for the smooth device, 0 for the ideal
    one; any other value is an error (``smooth=2`` read as 1 and ``smooth=0.5`` as 1 too)."""
    value = reader.number(SMOOTH_FLAG, text)
    if value not in (0, 1):
        raise reader.error(f"{reader.name}: smooth={text} must be 0 or 1",
                           hint="write smooth=1 for the smooth device of ngspice's equations, "
                           "smooth=0 (or nothing) for the ideal one")
    return value == 1


def mosfet(reader: StatementReader, models: dict[str, object], options: dict[str, float],
           off_resistance: float):
    """An ``M`` line: the smooth device when its line or its model says ``smooth=1``
    (:data:`SMOOTH_FLAG`), else the ideal switch of
    :func:`circuitnsds.frontend.cards.mosfets.mosfet`."""
    from circuitnsds.frontend.cards.mosfets import MosfetModel
    from circuitnsds.frontend.cards.mosfets import mosfet as ideal_mosfet

    tokens = list(reader.tokens)
    flag = None
    if SMOOTH_FLAG in tokens:
        at = tokens.index(SMOOTH_FLAG)
        if tokens[at + 1:at + 2] == ["="] and len(tokens) > at + 2:
            flag = smooth_flag(reader, tokens[at + 2])
            reader.tokens = tuple(tokens[:at] + tokens[at + 3:])
    words = [token for token in reader.tokens[1:reader.tokens.index("=") - 1
                                              if "=" in reader.tokens else None] if token != "off"]
    model = models.get(words[-1]) if words else None
    if flag is None:
        flag = isinstance(model, MosfetModel) and bool(model.params.get(SMOOTH_FLAG, 0))
    if not flag:
        return ideal_mosfet(reader, models, options, off_resistance)
    return smooth_mosfet(reader, models, off_resistance)


def smooth_mosfet(reader: StatementReader, models: dict[str, object], off_resistance: float):
    """``M name d g s [b] MODEL [m=..] [l=..] [w=..]`` as ngspice's level-1 smooth device."""
    from circuitnsds.circuit.elements.smooth.mos1 import Mos1, Mos1Model
    from circuitnsds.frontend.cards.mos_parameters import transconductance
    from circuitnsds.frontend.cards.mosfets import DEFAULT_LENGTH, MosfetModel

    name = reader.name
    words = _positional_words(reader)
    if len(words) not in (4, 5):
        raise reader.error(f"{name}: expected drain, gate, source, [bulk,] and a model name, "
                           f"got {len(words)} word(s)", hint="write Mname d g s b MODEL")
    *node_tokens, model_name = words
    nodes = tuple(node_name(token) for token in node_tokens)
    nodes = nodes if len(nodes) == 4 else nodes + (nodes[2],)
    model = _model(reader, models, model_name, MosfetModel, "a MOSFET (NMOS, PMOS)",
                   "NMOS(VTO=1 KP=50u)")
    if model.kind == "vdmos":
        return smooth_vdmos(reader, model, node_tokens, off_resistance)
    if int(model.params.get("level", 1)) != 1:
        raise reader.error(f"{name}: a level {model.params['level']:g} MOSFET as a smooth device "
                           "is not supported yet (level 1 and VDMOS are)",
                           hint="leave smooth=1 out to read it as a switch")
    instance = {"m": 1.0, "l": model.get("l", DEFAULT_LENGTH), "w": model.get("w", DEFAULT_LENGTH)}
    for key, text in reader.keyword_values():
        if key not in instance:
            raise reader.error(f"{name}: instance parameter {key!r} is not supported by the "
                               "smooth MOSFET", hint="it takes m=, l= and w=")
        instance[key] = reader.number(key, text)
    if min(instance.values()) <= 0:
        raise reader.error(f"{name}: m, l and w must be positive")
    params = model.params
    for key, what in MOS1_REFUSED.items():
        if params.get(key):
            raise reader.error(f"{name}: model {model.name}: {key.upper()} ({what}) is not "
                               "supported by the smooth MOSFET",
                               hint=f"remove {key.upper()} from the model, or run the device as "
                               "the ideal switch (smooth=0)")
    if "nsub" in params and not {"gamma", "phi"} <= params.keys():
        raise reader.error(f"{name}: model {model.name}: GAMMA and PHI derived from NSUB are "
                           "not supported by the smooth MOSFET", hint="give GAMMA and PHI")
    if "tox" in params:
        reader.warn(f"{name}: model {model.name} gives TOX: its Meyer gate capacitances are left "
                    "out of the smooth device (ngspice's are not a charge of the voltages)")
    try:
        vto = model.threshold_of(instance)[0]
    except ValueError as exc:
        raise reader.error(f"{name}: model {model.name}: {exc}") from None
    length = instance["l"] - 2.0 * params.get("ld", 0.0)
    if length <= 0:
        raise reader.error(f"{name}: L - 2·LD = {length:g} m must be positive")
    device = Mos1Model(
        model.name, model.polarity, vto=model.polarity * vto,
        beta=transconductance(params)[0] * instance["w"] / length,
        gamma=params.get("gamma", 0.0), phi=params.get("phi", 0.6),
        lam=params.get("lambda", 0.0), rd=params.get("rd", 0.0), rs=params.get("rs", 0.0),
        is_=params.get("is", 1e-14), cbd=params.get("cbd", 0.0), cbs=params.get("cbs", 0.0),
        mj=params.get("mj", 0.5), pb=params.get("pb", 0.8), fc=params.get("fc", 0.5),
        cgs=params.get("cgso", 0.0) * instance["w"], cgd=params.get("cgdo", 0.0) * instance["w"],
        cgb=params.get("cgbo", 0.0) * length, location=model.location)
    if device.phi <= 0:
        raise reader.error(f"{name}: model {model.name}: PHI must be positive")
    return Mos1(name, nodes, reader.location, model=device, multiplier=instance["m"],
                gmin=1.0 / off_resistance)


DIODE_PARAMETERS = {"is": "is_", "js": "is_", "n": "n", "rs": "rs", "bv": "bv", "vb": "bv",
                    "ibv": "ibv", "ib": "ibv", "nbv": "nbv", "ikf": "ikf", "ik": "ikf",
                    "ikr": "ikr", "cjo": "cjo", "cj0": "cjo", "cj": "cjo", "vj": "vj", "pb": "vj",
                    "m": "m", "mj": "m", "fc": "fc", "tt": "tt"}
"""``.model D(... smooth=1)`` parameter (and alias) -> :class:`ShockleyDiodeModel` field."""
DIODE_NO_EFFECT = {"smooth", "level", "eg", "xti", "kf", "af", "tlev", "tlevc", "cta", "ctp",
                   "tcv", "tpb", "tphp", "trs", "trs1", "trs2", "tm1", "tm2", "ttt1", "ttt2",
                   "tnom", "tref", "bv_max", "fv_max", "te_max", "pd_max", "rth0", "cth0",
                   "iave", "ipk", "vpk", "diss", "mfg", "type"}
"""Diode parameters that change nothing at the nominal temperature (or in a simulation)."""
DIODE_REFUSED = {"isw": "sidewall current", "jsw": "sidewall current", "ns": "sidewall "
                 "current", "isr": "recombination current", "nr": "recombination current",
                 "jtun": "tunnelling current", "jtunsw": "tunnelling current", "cjsw": "sidewall "
                 "capacitance", "cjp": "sidewall capacitance", "fcs": "sidewall capacitance"}
"""Diode parameters whose effect the smooth diode leaves out (refused when nonzero)."""


def shockley_diode_model(name: str, params: dict[str, float], reader: StatementReader):
    """A ``.model NAME D(... smooth=1)`` card as ngspice's level-1 diode
    (:class:`~circuitnsds.circuit.elements.smooth.diode.ShockleyDiodeModel`)."""
    from circuitnsds.circuit.elements.smooth.diode import ShockleyDiodeModel

    _nominal_temperature(name, params, reader)
    fields: dict[str, float] = {}
    for key, value in params.items():
        if key in DIODE_PARAMETERS:
            if DIODE_PARAMETERS[key] in fields:
                raise reader.error(f".model {name}: {key.upper()} gives "
                                   f"{DIODE_PARAMETERS[key].rstrip('_').upper()} a second time")
            fields[DIODE_PARAMETERS[key]] = value
        elif key in DIODE_REFUSED and value:
            raise reader.error(f".model {name}: {key.upper()}={value:g} ({DIODE_REFUSED[key]}) is "
                               "not modelled by the smooth diode", hint=f"leave {key.upper()} out")
    _ignored(name, "d", [key for key in params if key not in DIODE_PARAMETERS
                         and key not in DIODE_NO_EFFECT and key not in DIODE_REFUSED], reader)
    if params.get("level", 1) != 1:
        raise reader.error(f".model {name}: diode level {params['level']:g} is not supported "
                           "as a smooth device", hint="ngspice's level 1 is")
    model = ShockleyDiodeModel(name, location=reader.location, **fields)
    problems = [f"{key.upper()} must be positive" for key in ("is_", "n", "vj")
                if getattr(model, key) <= 0]
    problems += [f"{key.upper()} must not be negative" for key in
                 ("rs", "ikf", "ikr", "cjo", "tt") if getattr(model, key) < 0]
    if model.bv is not None and (model.bv <= 0 or model.ibv <= 0):
        problems.append("BV and IBV must be positive")
    if not 0 <= model.fc < 1 or not 0 <= model.m < 1:
        problems.append("FC and M must lie in [0, 1)")
    if problems:
        raise reader.error(f".model {name}: {'; '.join(p.replace('IS_', 'IS') for p in problems)}")
    return model


def diode(reader: StatementReader, models: dict[str, object], off_resistance: float):
    """A ``D`` line: ngspice's Shockley diode as a smooth device when its model says
    ``smooth=1``, else the ideal or piecewise-linear diode of
    :func:`circuitnsds.frontend.cards.devices.diode`."""
    from circuitnsds.circuit.elements.smooth.diode import ShockleyDiode, ShockleyDiodeModel
    from circuitnsds.frontend.cards.devices import diode as ideal_diode

    model = models.get(reader.tokens[3]) if len(reader.tokens) > 3 else None
    if not isinstance(model, ShockleyDiodeModel):
        return ideal_diode(reader, models)
    words = _positional_words(reader)
    nodes = tuple(node_name(token) for token in words[:2])
    for key, text in reader.keyword_values():
        if key not in {"m", "area"} or reader.number(key, text) != 1:
            raise reader.error(f"{reader.name}: {key}={text} is not supported by the smooth diode",
                               hint="use a model of its own for another area, or parallel diodes")
    if words[3:]:
        raise reader.error(f"{reader.name}: area {words[3]} is not supported by the smooth diode "
                           "(only 1)", hint="scale IS, RS and CJO in a model of its own")
    return ShockleyDiode(reader.name, nodes, reader.location, model=model,
                         gmin=1.0 / off_resistance)


VDMOS_SMOOTH = {"vto": "vto", "vth0": "vto", "kp": "kp", "lambda": "lam", "theta": "theta",
                "mtriode": "mtriode", "ksubthres": "ksubthres", "subshift": "subshift",
                "rd": "rd", "rs": "rs", "rg": "rg", "rds": "rds", "cgs": "cgs",
                "cgdmin": "cgdmin", "cgdmax": "cgdmax", "a": "a"}
"""VDMOS parameters of the channel and gate -> :class:`VdmosModel` field."""
VDMOS_BODY = {"is": "is_", "n": "n", "rb": "rs", "bv": "bv", "ibv": "ibv", "nbv": "nbv",
              "cjo": "cjo", "vj": "vj", "m": "m", "fc": "fc", "tt": "tt"}
"""VDMOS body-diode parameters -> :class:`ShockleyDiodeModel` field."""


def smooth_vdmos(reader: StatementReader, model, node_tokens: list[str], off_resistance: float):
    """``M name d g s MODEL`` with a VDMOS model as ngspice's smooth VDMOS (no self-heating,
    no quasi-saturation ``RQ``, ``M`` 1)."""
    from circuitnsds.circuit.elements.smooth.diode import ShockleyDiodeModel
    from circuitnsds.circuit.elements.smooth.vdmos import Vdmos, VdmosModel

    name = reader.name
    if len(node_tokens) != 3:
        raise reader.error(f"{name}: a VDMOS has three terminals (d g s); the thermal nodes of "
                           "ngspice's self-heating model are not supported",
                           hint="write the line with its drain, gate and source only")
    for key, text in reader.keyword_values():
        if key != "m" or reader.number(key, text) != 1:
            raise reader.error(f"{name}: {key}={text} is not supported by the smooth VDMOS",
                               hint="give the parallel devices a model of their own")
    params = model.params
    if params.get("rq"):
        raise reader.error(f"{name}: model {model.name}: RQ (quasi-saturation) is not supported "
                           "by the smooth VDMOS", hint="leave RQ out")
    channel = {field: params[key] for key, field in VDMOS_SMOOTH.items() if key in params}
    body = {field: params[key] for key, field in VDMOS_BODY.items() if key in params}
    diode = ShockleyDiodeModel("body", **{"ibv": 1e-10, "nbv": 1.0, "vj": 0.8, **body})
    device = VdmosModel(model.name, model.polarity, diode=diode, location=model.location,
                        **channel)
    if device.ksubthres <= 0 or device.kp < 0 or device.a <= 0:
        raise reader.error(f"{name}: model {model.name}: KSUBTHRES and A must be positive, KP "
                           "not negative")
    return Vdmos(name, tuple(node_name(token) for token in node_tokens), reader.location,
                 model=device, gmin=1.0 / off_resistance)
