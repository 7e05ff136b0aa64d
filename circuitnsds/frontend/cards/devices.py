"""Device lines: ``R C L`` (resistors possibly with a model), ``D``, ``S``/``W`` switches, ``K``."""

from __future__ import annotations

import numpy as np

from circuitnsds.circuit.elements import (
    Capacitor,
    Diode,
    DiodeModel,
    Element,
    Inductor,
    MutualInductance,
    Resistor,
    Switch,
    SwitchModel,
)
from circuitnsds.frontend.cards.models import MODEL_KINDS, ResistorModel
from circuitnsds.frontend.cards.reader import StatementReader
from circuitnsds.lazy import is_loaded_instance
from circuitnsds.values import is_value

IGNORED_PASSIVE_PARAMETERS = {"tc1", "tc2", "tc", "temp", "dtemp", "noisy", "scale", "ac"}


def passive(reader: StatementReader, letter: str, models: dict[str, object]) -> Element:
    """``R|C|L name n1 n2 [VALUE] [key=value ...]``; a resistor may name an ``R`` model
    before or after its value (``R1 a b RMOD 2.5`` or ``R1 a b 2.5 RMOD``)."""
    name = reader.name
    nodes = reader.nodes(2)
    quantity = {"r": "resistance", "c": "capacitance", "l": "inductance"}[letter]
    value: float | None = None
    model: ResistorModel | None = None
    while reader.peek() is not None and reader.peek(1) != "=":
        token = reader.peek()
        if letter == "r" and model is None and token in models:
            model = _resistor_model(reader, models[token])
            reader.position += 1
        elif value is None:
            value = reader.value(quantity)
        else:
            raise reader.error(f"{name}: unexpected {token!r}", hint=f"in: {reader.statement.text}")
    initial: float | None = None
    multiplier = 1.0
    geometry: dict[str, float] = {}
    for key, text in reader.keyword_values():
        number = reader.number(key, text)
        if key == letter and value is None:
            value = number
        elif key == "ic" and letter in "cl":
            initial = number
        elif key == "m":
            multiplier = number
        elif key in {"l", "w"} and model is not None:
            geometry[key] = number
        elif key in IGNORED_PASSIVE_PARAMETERS:
            reader.warn(f"{name}: {key}= ignored (no temperature, noise or small-signal modelling)")
        else:
            raise reader.error(f"{name}: parameter {key!r} is not supported",
                               hint=f"write {letter.upper()}name n1 n2 VALUE"
                               + (" [ic=VALUE]" if letter in "cl" else ""))
    if value is None and model is not None:
        value = _model_resistance(reader, model, geometry)
    if value is None:
        raise reader.error(f"{name}: missing {quantity}", hint=f"in: {reader.statement.text}")
    if multiplier <= 0:
        raise reader.error(f"{name}: m={multiplier:g} must be positive")
    if letter == "r":
        if value <= 0:
            raise reader.error(f"{name}: resistance must be positive, got {value:g}",
                               hint="use a 0 V voltage source for a short circuit")
        return Resistor(name, nodes, reader.location, resistance=value / multiplier,
                        model=model.name if model else None)
    if value < 0:
        raise reader.error(f"{name}: {quantity} must not be negative, got {value:g}")
    if letter == "c":
        return Capacitor(name, nodes, reader.location, capacitance=value * multiplier,
                         initial_voltage=initial)
    return Inductor(name, nodes, reader.location, inductance=value / multiplier,
                    initial_current=initial)


def _resistor_model(reader: StatementReader, model: object) -> ResistorModel:
    if not isinstance(model, ResistorModel):
        raise reader.error(f"{reader.name}: model {reader.peek()!r} is {_kind(model)} model, "
                           "not a resistor (R) model")
    return model


def _model_resistance(reader: StatementReader, model: ResistorModel,
                      geometry: dict[str, float]) -> float:
    """ngspice's rule without an instance value: ``RSH·(L-SHORT)/(W-NARROW)`` when the model
    has a sheet resistance (``L``, ``W`` from the instance, else the model's defaults),
    else the model's ``R``."""
    if model.sheet_resistance:
        width = geometry.get("w", model.default_width) - model.narrow
        length = geometry.get("l", model.default_length) - model.short
        if width <= 0 or length <= 0:
            raise reader.error(f"{reader.name}: the effective length and width must be positive")
        return model.sheet_resistance * length / width
    if model.resistance is not None:
        return model.resistance
    raise reader.error(f"{reader.name}: no resistance: give a value, or R= in .model "
                       f"{model.name}, or RSH there (with L and W)")


def diode_line(reader: StatementReader, models: dict[str, object], off_resistance: float):
    """A ``D`` line: the smooth Shockley diode when its model is one (``smooth=1``:
    :func:`~circuitnsds.frontend.cards.smooth_devices.diode`), else :func:`diode`. The smooth
    devices' reader (and its BJT and JFET modules, 15 ms of every run's start) is imported
    only then: no Shockley model can exist before its module is."""
    model = models.get(reader.tokens[3]) if len(reader.tokens) > 3 else None
    if is_loaded_instance(model, "circuitnsds.circuit.elements.smooth.diode", "ShockleyDiodeModel"):
        from circuitnsds.frontend.cards.smooth_devices import diode as smooth_diode

        return smooth_diode(reader, models, off_resistance)
    return diode(reader, models)


def diode(reader: StatementReader, models: dict[str, object]) -> Diode:
    """``D name anode cathode MODEL [area] [area=..] [m=..] [off] [ic=..]``."""
    name = reader.name
    nodes = reader.nodes(2)
    if reader.done():
        raise reader.error(f"{name}: the diode has no model (ngspice refuses it too)",
                           hint=f"write {name.upper()} {nodes[0]} {nodes[1]} DMOD and define it: "
                           ".model DMOD D() for an ideal diode, D(Vfwd=0.7 Ron=10m) for a "
                           "piecewise-linear one, or D(IS=1e-14 N=1) for ngspice's Shockley diode")
    model_name = reader.next("model name")
    model = reader.model(models, model_name, "diode model", f"add a line such as: .model {model_name} D()  "
                         f"(an ideal diode) or .model {model_name} D(Vfwd=0.7 Ron=10m)")
    if not isinstance(model, DiodeModel):
        raise reader.error(f"{name}: model {model_name!r} is {_kind(model)} model, "
                           "not a diode (D) model",
                           hint=f"a diode needs a diode model: .model {model_name} D(...)")
    area = 1.0
    if reader.peek() is not None and reader.peek(1) != "=" and reader.peek() != "off":
        area = reader.value("area")
    while not reader.done():
        token = reader.next("parameter")
        if token == "off":
            reader.warn(f"{name}: 'off' ignored (the ideal operating point needs no hint)")
            continue
        if reader.peek() != "=":
            raise reader.error(f"{name}: unexpected {token!r}",
                               hint="write Dname anode cathode MODEL [area]")
        reader.position += 1
        number = reader.number(token, reader.next(f"value of {token}"))
        if token in {"area", "m"}:
            area *= number
        elif token in {"ic", "temp", "dtemp", "pj", "lm", "lp", "wm", "wp"}:
            reader.warn(f"{name}: {token}= ignored by the ideal diode")
        else:
            raise reader.error(f"{name}: instance parameter {token!r} is not supported",
                               hint="a diode line takes area= (or m=), and ic=, temp=, dtemp=, pj=, "
                               "lm=, lp=, wm=, wp= (ignored); write Dname anode cathode MODEL [area]")
    if area <= 0:
        raise reader.error(f"{name}: area must be positive, got {area:g}")
    return Diode(name, nodes, reader.location, model=model, area=area)


def switch(reader: StatementReader, letter: str, models: dict[str, object],
           voltage_sources: set[str]) -> Switch:
    """``S name n+ n- nc+ nc- MODEL [ON|OFF]`` or ``W name n+ n- VNAME MODEL [ON|OFF]``."""
    name = reader.name
    control: str | None = None
    if letter == "s":
        nodes = reader.nodes(4)
    else:
        nodes = reader.nodes(2)
        control = reader.next("controlling voltage source")
        if control not in voltage_sources:
            raise reader.error(f"{name}: controlling source {control!r} is not a voltage source "
                               "of this circuit",
                               hint="a W switch senses the current of a V source (0 V is fine)")
    model_name = reader.next("model name")
    wanted = "SW" if letter == "s" else "CSW"
    thresholds = "VT=2.5 VH=0.1" if letter == "s" else "IT=1m IH=0.1m"
    model = reader.model(models, model_name, "switch model",
                         f"add a line such as: .model {model_name} {wanted}({thresholds} RON=10m ROFF=1meg)")
    if not isinstance(model, SwitchModel) or model.current_controlled != (letter == "w"):
        raise reader.error(f"{name}: model {model_name!r} is {_kind(model)} model, "
                           f"a {letter.upper()} switch needs a {wanted} model")
    initially_on = False
    while not reader.done():
        token = reader.next("ON or OFF")
        if token not in {"on", "off"}:
            raise reader.error(f"{name}: unexpected {token!r}",
                               hint="the only flags after the model are ON and OFF (initial state)")
        initially_on = token == "on"
    return Switch(name, nodes, reader.location, model=model, control=control,
                  initially_on=initially_on)


def mutual_inductance(reader: StatementReader, inductors: dict[str, Inductor]) -> list[MutualInductance]:
    """``K name L1 L2 [L3 ...] k``: couples inductors already in the circuit. LTspice's form
    with more than two inductors couples every pair with the same ``k`` (one
    :class:`MutualInductance` per pair, named ``K1_L1_L2``...)."""
    name = reader.name
    fields = reader.tokens[reader.position:]
    if len(fields) < 3:
        raise reader.error(f"{name}: missing inductors or the coupling coefficient k",
                           hint="write Kname L1 L2 k (LTspice: Kname L1 L2 L3 k)")
    if not is_value(fields[-1]) and is_value(fields[-2]) and fields[-1] not in inductors:
        raise reader.error(f"{name}: {fields[-1]!r} after the coupling coefficient is a core model "
                           "(Xyce's nonlinear magnetic core, K ... k MODEL): not supported, the "
                           "coupling here is linear", hint=f"leave the model out for a linear "
                           f"transformer: {name.upper()} {' '.join(f.upper() for f in fields[:-1])}")
    names = tuple(reader.next("inductor") for _ in fields[:-1])
    coupling = reader.value("coupling coefficient")
    for inductor in names:
        if inductor not in inductors:
            raise reader.error(f"{name}: {inductor!r} is not an inductor of this circuit",
                               hint="K couples L elements by name: K1 L1 L2 0.99")
    if len(set(names)) != len(names):
        raise reader.error(f"{name}: an inductor cannot be coupled to itself")
    if not 0 < abs(coupling) <= 1:
        raise reader.error(f"{name}: coupling coefficient k={coupling!r} must satisfy 0 < |k| <= 1")
    pairs = [(a, b) for k, a in enumerate(names) for b in names[k + 1:]]
    return [MutualInductance(name if len(pairs) == 1 else f"{name}_{a}_{b}", (), reader.location,
                             inductors=(a, b), inductances=(inductors[a].inductance,
                                                            inductors[b].inductance),
                             coupling=coupling)
            for a, b in pairs]


def inductance_matrix(inductors: list[Inductor], couplings: list[MutualInductance]) -> np.ndarray:
    """The symmetric inductance matrix [H] of ``inductors`` (in that order) with their couplings."""
    index = {inductor.name: k for k, inductor in enumerate(inductors)}
    matrix = np.diag([inductor.inductance for inductor in inductors])
    for coupling in couplings:
        a, b = (index[name] for name in coupling.inductors)
        matrix[a, b] += coupling.mutual
        matrix[b, a] += coupling.mutual
    return matrix


def _kind(model: object) -> str:
    if isinstance(model, str):
        return f"a {MODEL_KINDS[model]}" if model in MODEL_KINDS else f"an unknown-type ({model.upper()})"
    if is_loaded_instance(model, "circuitnsds.frontend.cards.mosfets", "MosfetModel"):
        return f"a {model.kind.upper()} MOSFET"
    return {DiodeModel: "a diode", ResistorModel: "a resistor"}.get(
        type(model), "a current-controlled switch" if getattr(model, "current_controlled", False)
        else "a voltage-controlled switch")
