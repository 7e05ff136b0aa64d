"""Smooth semiconductor devices: ``.model NAME NPN|PNP(...)`` with ``Q`` lines (Gummel–Poon,
:mod:`circuitnsds.circuit.elements.smooth.bjt`).

Parameters take ngspice 39's names (and its aliases: ``VA`` for ``VAF``, ``IK`` for ``IKF``,
``PE`` for ``VJE``...), units and defaults. The devices are simulated at ngspice's nominal
temperature (27 °C): temperature coefficients, noise and safe-operating-area parameters are
read and change nothing there; a parameter whose effect the equations leave out (the
substrate diode ``ISS``, quasi-saturation ``RCO``, ``NKF``, excess phase ``PTF``) is refused
by name rather than dropped, as is a model whose ``TNOM`` is not 27 °C.
"""

from __future__ import annotations

from dataclasses import replace

from circuitnsds.circuit.elements.smooth.bjt import Bjt, BjtModel
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
}
"""``.model NPN|PNP`` parameter (and alias) -> :class:`BjtModel` field."""
BJT_NO_EFFECT = {
    # temperature dependence (none at TEMP = TNOM), noise, safe operating area, documentation
    "xtb", "eg", "xti", "kf", "af", "tlev", "tlevc", "ctc", "cte", "cts", "tvjc", "tvje", "tvjs",
    "vbe_max", "vbc_max", "vce_max", "pd_max", "ic_max", "ib_max", "te_max", "rth0", "level",
    "vjs", "ps", "mjs", "ms", "ns", "vceo", "icrating", "iave", "vpk",
    *(f"t{name}{k}" for name in ("bf", "br", "ikf", "ikr", "irb", "nc", "ne", "nf", "nr", "rb",
                                 "rc", "re", "rm", "vaf", "var", "itf", "tf", "tr", "mje",
                                 "mjc", "mjs", "ns", "is", "ise", "isc", "iss") for k in (1, 2)),
    "trb", "trc", "tre",
}
"""Parameters that change nothing at the nominal temperature, or describe the device only."""
BJT_REFUSED = {
    "iss": "the substrate diode", "cjs": "the substrate capacitance",
    "csub": "the substrate capacitance", "ccs": "the substrate capacitance",
    "ptf": "excess phase", "rco": "quasi-saturation", "qco": "quasi-saturation",
    "vo": "quasi-saturation", "gamma": "quasi-saturation", "quasimod": "quasi-saturation",
    "vg": "quasi-saturation", "cn": "quasi-saturation", "d": "quasi-saturation",
    "nkf": "the high-injection exponent", "nk": "the high-injection exponent",
    "ibe": "separate B-E saturation current", "ibc": "separate B-C saturation current",
}
"""Parameters whose effect the Gummel–Poon equations here leave out (refused when nonzero)."""



def read_smooth_model(name: str, kind: str, reader: StatementReader) -> BjtModel:
    """The parameters of a ``.model NAME NPN|PNP(...)`` card (after its type word)."""
    params: dict[str, float] = {}
    for key, text in reader.keyword_values():
        if key in params:
            raise reader.error(f".model {name}: parameter {key!r} is given twice")
        params[key] = reader.number(key, text)
    return bjt_model(name, kind, params, reader)


def bjt_model(name: str, kind: str, params: dict[str, float], reader: StatementReader) -> BjtModel:
    """A :class:`BjtModel` from the parameters of its card (lower-case names, SI units)."""
    fields: dict[str, float] = {}
    lateral = kind == "pnp"
    for key, value in params.items():
        if key in BJT_PARAMETERS:
            if BJT_PARAMETERS[key] in fields:
                raise reader.error(f".model {name}: {key.upper()} gives "
                                   f"{BJT_PARAMETERS[key].rstrip('_').upper()} a second time")
            fields[BJT_PARAMETERS[key]] = value
        elif key == "subs":
            lateral = value < 0
        elif key in {"tnom", "tref"}:
            if abs(value + 273.15 - NOMINAL_TEMPERATURE) > 1e-9:
                raise reader.error(f".model {name}: TNOM={value:g} °C: the smooth devices run at "
                                   "27 °C and do not scale their parameters to another TNOM",
                                   hint="give the parameters at 27 °C and leave TNOM out")
        elif key in BJT_REFUSED:
            if value:
                raise reader.error(f".model {name}: {key.upper()}={value:g} ({BJT_REFUSED[key]}) "
                                   "is not modelled", hint=f"leave {key.upper()} out (or 0) to "
                                   "run without it")
        elif key not in BJT_NO_EFFECT:
            raise reader.error(f".model {name} {kind.upper()}: unknown parameter {key!r}",
                               hint="see ngspice's manual, BJT level 1 (Gummel-Poon)")
    if params.get("level", 1) != 1:
        raise reader.error(f".model {name}: BJT level {params['level']:g} is not supported",
                           hint="circuitnsds has ngspice's level 1 (Gummel-Poon)")
    model = BjtModel(name, 1 if kind == "npn" else -1, lateral=lateral, location=reader.location,
                     **fields)
    problems = [f"{key.upper()} must be positive" for key in ("bf", "br", "nf", "nr", "ne", "nc")
                if getattr(model, key) <= 0]
    problems += [f"{key.upper()} must not be negative" for key in
                 ("is_", "ise", "isc", "ikf", "ikr", "rb", "irb", "rc", "re", "cje", "cjc",
                  "tf", "tr", "itf", "xtf") if getattr(model, key) < 0]
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
    name = reader.name
    words: list[str] = []
    while not reader.done() and reader.peek(1) != "=":
        token = reader.next("node or model")
        if token != "off":  # a hint for ngspice's first Newton iterate: the solution is the same
            words.append(token)
    count = bjt_node_count(words, models)
    if len(words) < count + 1:
        raise reader.error(f"{name}: expected collector, base, emitter, [substrate,] and a model "
                           f"name, got {len(words)} word(s)", hint="write Qname c b e MODEL")
    nodes = tuple(node_name(token) for token in words[:count]) + (("0",) if count == 3 else ())
    model_name, extra = words[count], words[count + 1:]
    model = models.get(model_name)
    if not isinstance(model, BjtModel):
        what = "is not defined" if model is None else "is not a bipolar (NPN, PNP) model"
        raise reader.error(f"{name}: model {model_name!r} {what}",
                           hint=f"add a line such as: .model {model_name} NPN(IS=1e-14 BF=100)")
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
            raise reader.error(f"{name}: {key}= is not supported: the smooth devices run at 27 °C")
        else:
            raise reader.error(f"{name}: instance parameter {key!r} is not supported",
                               hint="Q lines take m=")
    if instance["area"] != 1.0:
        raise reader.error(f"{name}: area {extra[0] if extra else instance['area']} is not "
                           "supported (only 1)", hint="scale IS, IKF, the resistances and "
                           "capacitances in a model of its own, or use m= for parallel devices")
    if instance["m"] <= 0:
        raise reader.error(f"{name}: m={instance['m']:g} must be positive")
    return Bjt(name, nodes, reader.location, model=model, multiplier=instance["m"],
               gmin=1.0 / off_resistance)


def _is_number(token: str) -> bool:
    try:
        parse_value(token)
    except ValueError:
        return False
    return True
