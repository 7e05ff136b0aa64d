"""MOSFETs used as switches: ``.model NAME VDMOS(...)`` / ``NMOS`` / ``PMOS`` and ``M`` lines.

A MOSFET becomes (see :mod:`circuitnsds.circuit.elements.mosfet`):

* an ideal drain–source switch controlled by ``v(g, s)`` against ``Vto``;
* its on-resistance ``Ron = Rd + Rs + Rch`` where ``Rch`` is the channel's small-``Vds``
  resistance at the gate drive ``|Vgs| = .options mosdrive`` (default
  :data:`DEFAULT_GATE_DRIVE`), from the same equations ngspice uses:
  VDMOS ``Rch = (1 + θ·Vgs) / (Kp·mtriode·Vov)`` with the overdrive ``Vov = Vgs − Vto``
  smoothed by ``ksubthres`` as ngspice smooths it; level 1–3 ``Rch = 1/(β·(Vgs − Vto))``,
  ``β = Kp·W/(L − 2·LD)`` (``L``, ``W`` from the instance, else from the model as PSpice
  allows, else ngspice's 100 µm). LTspice's ``Ron`` (a datasheet annotation that neither
  LTspice nor ngspice simulates) is not used;
* its off-resistance: VDMOS ``Rds`` when given, else the circuit's ``1/gmin``;
* an ideal body diode (VDMOS: source → drain for n-channel, in series with ``Rb``, with
  ``BV`` as a Zener breakdown when given; level 1–3: the bulk–drain and bulk–source
  junctions; none when ``IS = 0``) fitted to its Shockley curve as diode models are
  (:func:`circuitnsds.circuit.elements.diode.fitted_model`, refitted where the circuit works);
* level 1–3: ``VTO`` and ``KP`` derived from the process as ngspice derives them when the
  model leaves them out (:mod:`~circuitnsds.frontend.cards.mos_parameters`);
* linear capacitances when the model gives them, the gate–drain one split into its two
  grounded halves, each at the value it has when its node moves: ngspice's Cgd(Vgd) is
  Cgdmax while the channel conducts (``Vgd > 0``) and falls toward Cgdmin as the drain
  rises above the gate. The gate moves (crossing ``Vto``) while the channel conducts, the
  drain while it blocks, so the input capacitance is ``Ciss = Cgs + Cgdmax`` (gate–source)
  and the output capacitance ``Coss = Cjo + Cgdmin`` (drain–source; ``Cjo`` is the body
  junction's zero-bias capacitance, its largest); level 1–3: ``CGSO·W + CGDO·W`` and
  ``CGDO·W``, ``CBD``, ``CBS``. A capacitance between gate and drain would feed the drain's jump at
  each switching back into the gate (the Miller effect): a real device then sits in its
  linear region while the gate charges (the Miller plateau), which an ideal switch does
  not have, so the switch would chatter. ``Rg`` is in series with the gate when a gate
  capacitance is present (without one it carries no current and is left out).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from circuitnsds.circuit.elements import (
    Capacitor,
    Diode,
    DiodeModel,
    Element,
    Resistor,
    SwitchModel,
)
from circuitnsds.circuit.elements.diode import fitted_model
from circuitnsds.circuit.elements.diode_fit import ShockleyDiode
from circuitnsds.circuit.elements.mosfet import Mosfet
from circuitnsds.errors import SourceLocation
from circuitnsds.frontend.cards.mos_parameters import threshold, transconductance
from circuitnsds.frontend.cards.reader import StatementReader, node_name

DEFAULT_GATE_DRIVE = 10.0
"""``|Vgs|`` [V] at which the on-resistance is computed: the usual datasheet ``Rds(on)``
condition of standard-level power MOSFETs (``.options mosdrive`` changes it)."""
TEXT_PARAMETERS = {"mfg", "type"}
"""Parameters whose value is text (the manufacturer, in vendor libraries)."""
FLAGS = {"nchan", "pchan", "vdmosn", "vdmosp"}

VDMOS_USED = {"vto", "vth0", "kp", "theta", "mtriode", "ksubthres", "subshift", "rd", "rs", "rg",
              "rds", "rb", "is", "n", "bv", "cjo", "cgdmax", "cgdmin", "cgs", "smooth"}
VDMOS_IGNORED = {
    # smooth-model details that do not change a switch's states or its on-resistance
    "phi", "lambda", "tnom", "kf", "af", "rq", "vq", "tcvth", "vtotc", "mu", "bex", "texp0",
    "texp1", "trd1", "trd2", "trg1", "trg2", "trs1", "trs2", "trb1", "trb2", "tksubthres1",
    "tksubthres2", "ibv", "nbv", "tt", "eg", "xti", "vj", "m", "fc", "a", "rthjc",
    "rthca", "cthj", "vgs_max", "vgd_max", "vds_max", "vgsr_max", "vgdr_max", "pd_max", "id_max",
    "idr_max", "te_max", "rth_ext", "derating",
    # LTspice datasheet annotations (not simulated by LTspice or ngspice)
    "ron", "qg", "vds", "subthres", "vdmos",
}
LEVEL1_USED = {"level", "vto", "vt0", "kp", "u0", "uo", "tox", "ld", "rd", "rs", "is", "cbd", "cbs",
               "cgso", "cgdo", "l", "w", "nsub", "phi", "gamma", "tpg", "nss", "xj", "delta", "wd",
               "tnom", "smooth"}
LEVEL1_IGNORED = {
    "lambda", "pb", "cgbo", "rsh", "cj", "mj", "cjsw", "mjsw", "js", "fc",
    "kf", "af", "uexp", "ucrit", "vmax", "neff", "nfs", "eta",
    "theta", "kappa", "xqc", "nlev", "gdsnoi", "ron", "qg", "vds", "mfg",
}
DEFAULT_LENGTH = 100e-6
"""ngspice's default channel length and width ``DEFL``/``DEFW`` [m]."""

@dataclass(frozen=True)
class MosfetModel:
    """A ``.model NAME VDMOS|NMOS|PMOS(...)`` card as written.

    Attributes:
        name: model name.
        kind: ``vdmos``, ``nmos`` or ``pmos``.
        polarity: ``+1`` n-channel, ``-1`` p-channel (``pchan`` for VDMOS).
        params: the numeric parameters given (lower-case names, SI units).
        text: the text parameters given (``mfg``).
        location: where the card was written.
    """

    name: str
    kind: str
    polarity: int = 1
    params: dict[str, float] = field(default_factory=dict)
    text: dict[str, str] = field(default_factory=dict)
    location: SourceLocation | None = None

    def get(self, key: str, default: float) -> float:
        return self.params.get(key, default)

    @property
    def threshold(self) -> float:
        """``Vto`` [V] (negative for an enhancement p-channel device) of a default-size
        channel: as written, else derived as ngspice does (:meth:`threshold_of`)."""
        return self.threshold_of({"l": DEFAULT_LENGTH, "w": DEFAULT_LENGTH})[0]

    def threshold_of(self, instance: dict[str, float]) -> tuple[float, str]:
        """``(Vto [V], how it was found)`` for the channel ``instance["l"]`` × ``["w"]``
        [m]: VDMOS ``VTO`` (ngspice's default 3 V); level 1–3 as ngspice derives it
        (:mod:`~circuitnsds.frontend.cards.mos_parameters`: from ``NSUB``, ``TOX``, ...)."""
        if self.kind == "vdmos":
            return self.params.get("vto", self.params.get("vth0", 3.0 * self.polarity)), "VTO"
        return threshold(self.params, self.polarity, instance["l"], instance["w"])


def read_mos_model(name: str, kind: str, reader: StatementReader) -> MosfetModel:
    """The parameters of a MOSFET ``.model`` (after the type word and its parenthesis)."""
    polarity = -1 if kind == "pmos" else 1
    params: dict[str, float] = {}
    text: dict[str, str] = {}
    while not reader.done():
        key = reader.next("parameter")
        if reader.peek() != "=":
            if kind == "vdmos" and key in FLAGS:
                polarity = -1 if key in {"pchan", "vdmosp"} else 1
                continue
            raise reader.error(f".model {name}: expected '{key}=value', found {key!r} alone",
                               hint="VDMOS models take the flags nchan/pchan and name=value pairs")
        reader.position += 1
        value = reader.next(f"value of {key}")
        if key in params or key in text:
            raise reader.error(f".model {name}: parameter {key!r} is given twice")
        if key == "thermal":
            from circuitnsds.frontend.cards.models import thermal_path

            text[key] = thermal_path(reader, value)
        elif key in TEXT_PARAMETERS:
            text[key] = value
        else:
            params[key] = reader.number(key, value)
    used, ignored = (VDMOS_USED, VDMOS_IGNORED) if kind == "vdmos" else (LEVEL1_USED, LEVEL1_IGNORED)
    unknown = sorted(k for k in params if k not in used | ignored)
    if unknown:
        reader.warn(f".model {name} {kind.upper()}: unknown parameter(s) {', '.join(unknown)} ignored")
    if kind != "vdmos":
        level = int(params.get("level", 1))
        if level not in (1, 2, 3):
            raise reader.error(f".model {name}: MOSFET level {level} is not supported",
                               hint="circuitnsds reads VDMOS and level 1-3 MOSFETs as switches "
                               "(threshold VTO, on-resistance from KP)")
        if level != 1:
            reader.warn(f".model {name}: level {level} read with the level-1 on-resistance "
                        "(KP, W, L); its threshold is ngspice's at Vbs = 0 (level 3: with the "
                        "short- and narrow-channel effects, without ETA's drain feedback)")
    return MosfetModel(name, kind, polarity, params, text, reader.location)


def mosfet(reader: StatementReader, models: dict[str, object], options: dict[str, float],
           off_resistance: float) -> list[Element]:
    """``M name d g s [b] MODEL [m=..] [l=..] [w=..]``: the switch and its companion elements.

    ``options`` are the circuit's ``.options`` (``mosdrive``); ``off_resistance`` [Ω] the
    default off-resistance (``1/gmin``).
    """
    name = reader.name
    positional: list[str] = []
    while not reader.done() and reader.peek(1) != "=":
        token = reader.next("node or model")
        if token != "off":
            positional.append(token)
        else:
            reader.warn(f"{name}: 'off' ignored (the ideal operating point needs no hint)")
    if len(positional) not in (4, 5):
        raise reader.error(f"{name}: expected drain, gate, source, [bulk,] and a model name, "
                           f"got {len(positional)} word(s)",
                           hint="write Mname d g s MODEL (VDMOS) or Mname d g s b MODEL")
    *node_tokens, model_name = positional
    drain, gate, source = (node_name(t) for t in node_tokens[:3])
    bulk = node_name(node_tokens[3]) if len(node_tokens) == 4 else source
    model = models.get(model_name)
    if not isinstance(model, MosfetModel):
        what = "is not defined" if model is None else "is not a MOSFET (VDMOS, NMOS, PMOS) model"
        raise reader.error(f"{name}: model {model_name!r} {what}",
                           hint=f"add a line such as: .model {model_name} VDMOS(Vto=3 Kp=20 Rd=10m)")
    if model.kind == "vdmos" and len(node_tokens) == 4:
        raise reader.error(f"{name}: a VDMOS has three terminals (d g s); the thermal nodes "
                           "of ngspice's self-heating model are not supported")
    instance = {"m": 1.0, "l": model.get("l", DEFAULT_LENGTH), "w": model.get("w", DEFAULT_LENGTH)}
    for key, text in reader.keyword_values():
        number = reader.number(key, text)
        if key in instance and (key == "m" or model.kind != "vdmos"):
            instance[key] = number
        elif key in {"ad", "as", "pd", "ps", "nrd", "nrs", "temp", "dtemp", "ic", "icvds",
                     "icvgs"}:
            reader.warn(f"{name}: {key}= ignored by the ideal MOSFET")
        else:
            raise reader.error(f"{name}: instance parameter {key!r} is not supported",
                               hint="M lines take m= (and l=, w= for level-1 models)")
    if min(instance.values()) <= 0:
        raise reader.error(f"{name}: m, l and w must be positive")
    drive = options.get("mosdrive", DEFAULT_GATE_DRIVE)
    try:
        vto, vto_rule = model.threshold_of(instance)
    except ValueError as exc:
        raise reader.error(f"{name}: model {model.name}: {exc}",
                           hint="check NSUB's unit (cm^-3) or give VTO") from None
    channel, rule = _channel_resistance(model, instance, drive, reader, vto)
    series = model.get("rd", 0.0) + model.get("rs", 0.0)
    count = instance["m"]
    on_resistance = (series + channel) / count
    rule = (f"Rd + Rs + Rch = {model.get('rd', 0.0):g} + {model.get('rs', 0.0):g} + {channel:.4g} Ω"
            + (f", / m={count:g}" if count != 1 else "") + f"; {rule}; Vto={vto:.4g} V: {vto_rule}")
    off = model.get("rds", off_resistance) if model.kind == "vdmos" else off_resistance
    switch_model = SwitchModel(model.name, threshold=model.polarity * vto,
                               on_resistance=on_resistance, off_resistance=off / count,
                               location=model.location, thermal=model.text.get("thermal"))
    location = reader.location
    parts: list[Element] = []
    inner_gate = gate
    gate_caps = _gate_capacitances(model, instance)
    if gate_caps and model.kind == "vdmos" and model.get("rg", 0.0) > 0:
        inner_gate = f"{name}.gate"
        parts.append(Resistor(f"{name}.rg", (gate, inner_gate), location,
                              resistance=model.get("rg", 0.0) / count))
    miller = gate_caps.get("cgd", 0.0)
    if gate_caps:
        parts.append(Capacitor(f"{name}.ciss", (inner_gate, source), location,
                               capacitance=(gate_caps.get("cgs", 0.0) + miller) * count))
    parts += _body_diodes(model, name, drain, source, bulk, count, off_resistance, location)
    if model.kind == "vdmos":  # the drain moves while the channel blocks: Cgd is at Cgdmin
        output = model.params.get("cgdmin", 0.0) + model.params.get("cjo", 0.0)
    else:
        output = miller
    if output > 0:
        parts.append(Capacitor(f"{name}.coss", (drain, source), location,
                               capacitance=output * count))
    switch = Mosfet(name, (drain, source, inner_gate), location, model=switch_model,
                    polarity=model.polarity, device=model.kind, on_resistance_rule=rule,
                    gate_drive=drive, parts=tuple(p.name for p in parts))
    return [switch, *parts]


def _channel_resistance(model: MosfetModel, instance: dict[str, float], drive: float,
                        reader: StatementReader, vto: float) -> tuple[float, str]:
    """``(Rch [Ω], the rule in words)`` at ``|Vgs| = drive`` for the threshold ``vto`` [V]."""
    overdrive = drive - model.polarity * vto
    if overdrive <= 0:
        raise reader.error(f"{reader.name}: the gate drive |Vgs| = {drive:g} V does not reach "
                           f"the threshold of model {model.name} (Vto = {vto:.4g} V)",
                           hint="set the drive at which Ron is computed: .options mosdrive=VALUE")
    if model.kind == "vdmos":
        kp = model.get("kp", 25.0 + 10.0 * model.polarity)
        slope = model.get("ksubthres", 0.1)
        shift = model.get("subshift", 0.0)
        argument = (overdrive - shift) / slope
        smoothed = slope * (argument if argument > 30 else math.log1p(math.exp(argument)))
        theta, triode = model.get("theta", 0.0), model.get("mtriode", 1.0)
        resistance = (1.0 + theta * drive) / (kp * triode * smoothed)
        return resistance, (f"Rch = (1 + θ·Vgs)/(Kp·mtriode·(Vgs − Vto)) at |Vgs| = {drive:g} V "
                            f"(Kp={kp:g}, Vto={vto:g})")
    kp, _ = transconductance(model.params)
    length = instance["l"] - 2.0 * model.get("ld", 0.0)
    if length <= 0:
        raise reader.error(f"{reader.name}: the effective channel length L - 2·LD is not positive")
    beta = kp * instance["w"] / length
    return 1.0 / (beta * overdrive), (f"Rch = 1/(Kp·W/(L−2·LD)·(Vgs − Vto)) at |Vgs| = {drive:g} V "
                                      f"(Kp={kp:g}, W/L={instance['w'] / length:g}, "
                                      f"Vto={vto:.4g})")


def _gate_capacitances(model: MosfetModel, instance: dict[str, float]) -> dict[str, float]:
    if model.kind == "vdmos":
        return {key: model.params[source] for key, source in (("cgs", "cgs"), ("cgd", "cgdmax"))
                if model.params.get(source, 0.0) > 0}
    return {key: model.params[source] * instance["w"]
            for key, source in (("cgs", "cgso"), ("cgd", "cgdo")) if model.params.get(source, 0.0) > 0}


def _body_diodes(model: MosfetModel, name: str, drain: str, source: str, bulk: str, count: float,
                 off_resistance: float, location: SourceLocation | None) -> list[Element]:
    """VDMOS: the body diode; level 1–3: the bulk junctions and ``CBD``/``CBS``."""
    saturation = model.get("is", 1e-14)
    if saturation <= 0:  # IS=0: the model has no junction diode
        return []
    emission = model.get("n", 1.0) if model.kind == "vdmos" else 1.0
    resistance = model.get("rb", 0.0) if model.kind == "vdmos" else 0.0
    breakdown = abs(model.params["bv"]) if model.kind == "vdmos" and model.params.get("bv") else None
    diode_model = fitted_model(DiodeModel(f"{model.name}.body", off_resistance=off_resistance,
                                          breakdown_voltage=breakdown,
                                          breakdown_resistance=resistance if breakdown else 0.0,
                                          location=model.location),
                               ShockleyDiode(saturation, emission, resistance))
    parts: list[Element] = []

    def junction(suffix: str, other: str) -> None:
        nodes = (bulk if model.kind != "vdmos" else source, other)
        if model.polarity < 0:
            nodes = nodes[::-1]
        parts.append(Diode(f"{name}.{suffix}", nodes, location, model=diode_model, area=count))

    if model.kind == "vdmos":
        junction("dbody", drain)  # its capacitance Cjo is part of m1.coss
        return parts
    junction("dbd", drain)
    if bulk != source:
        junction("dbs", source)
    for suffix, other in (("cbd", drain), ("cbs", source)):
        if model.params.get(suffix, 0.0) > 0 and (bulk != other):
            parts.append(Capacitor(f"{name}.{suffix}", (bulk, other), location,
                                   capacitance=model.params[suffix] * count))
    return parts
