"""MOSFETs used as switches: ``.model NAME VDMOS(...)`` / ``NMOS`` / ``PMOS`` and ``M`` lines.

A MOSFET becomes (see :mod:`circuitnsds.circuit.elements.mosfet`):

* an ideal drain–source switch controlled by ``v(g, s)`` against ``Vto``;
* its on-resistance ``Ron = Rd + Rs + Rch`` where ``Rch`` is the channel's small-``Vds``
  resistance at the gate drive ``|Vgs|`` (:class:`~circuitnsds.circuit.elements.mosfet_laws.
  ChannelLaw`, ngspice's equations): ``.options mosdrive`` when given, else
  :data:`DEFAULT_GATE_DRIVE` until a first run shows the drive the circuit applies
  (:mod:`circuitnsds.analyses.mosfet_refits`). LTspice's ``Ron`` (a datasheet annotation that
  neither LTspice nor ngspice simulates) is not used;
* its off-resistance: VDMOS ``Rds`` when given, else the circuit's ``1/gmin``;
* an ideal body diode (VDMOS: source → drain for n-channel, in series with ``Rb``, with
  ``BV`` as a Zener breakdown when given; level 1–3: the bulk–drain and bulk–source
  junctions; none when ``IS = 0``) fitted to its Shockley curve as diode models are
  (:func:`circuitnsds.circuit.elements.diode.fitted_model`, refitted where the circuit works);
* level 1–3: ``VTO`` and ``KP`` derived from the process as ngspice derives them when the
  model leaves them out (:mod:`~circuitnsds.frontend.cards.mos_parameters`);
* linear capacitances when the model gives them: the input capacitance
  ``Ciss = Cgs + Cgdmax`` gate–source (ngspice's Cgd(Vgd) is Cgdmax while the channel
  conducts, and the gate crosses ``Vto`` while it does; level 1–3 ``CGSO·W + CGDO·W``) and
  the output capacitance ``{name}.coss`` drain–source, the charge-equivalent of ngspice's
  Coss(v) (body junction and Cgd with the gate at the source;
  :class:`~circuitnsds.circuit.elements.mosfet_laws.OutputCapacitance`) over the voltage the
  drain swings, at zero bias here until the analysis places it. A capacitance between gate
  and drain would feed the drain's jump at each switching back into the gate (the Miller
  effect): a real device then sits in its linear region while the gate charges (the Miller
  plateau), which an ideal switch does not have, so the switch would chatter. ``Rg`` is in
  series with the gate when a gate capacitance is present (without one it carries no
  current and is left out).
"""

from __future__ import annotations

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
from circuitnsds.circuit.elements.mosfet_laws import ChannelLaw, OutputCapacitance
from circuitnsds.errors import SourceLocation
from circuitnsds.frontend.cards.mos_parameters import threshold, transconductance
from circuitnsds.frontend.cards.reader import StatementReader, node_name

DEFAULT_GATE_DRIVE = 10.0
"""``|Vgs|`` [V] at which the on-resistance is computed before a run shows the drive the
circuit applies: the usual datasheet ``Rds(on)`` condition of standard-level power MOSFETs
(``.options mosdrive`` fixes the drive)."""
TEXT_PARAMETERS = {"mfg", "type"}
"""Parameters whose value is text (the manufacturer, in vendor libraries)."""
FLAGS = {"nchan", "pchan", "vdmosn", "vdmosp"}

VDMOS_USED = {"vto", "vth0", "kp", "theta", "mtriode", "ksubthres", "subshift", "rd", "rs", "rg",
              "rds", "rb", "is", "n", "bv", "cjo", "cgdmax", "cgdmin", "cgs", "vj", "m", "a", "smooth"}
VDMOS_IGNORED = {
    # smooth-model details that do not change a switch's states or its on-resistance
    "phi", "lambda", "tnom", "kf", "af", "rq", "vq", "tcvth", "vtotc", "mu", "bex", "texp0",
    "texp1", "trd1", "trd2", "trg1", "trg2", "trs1", "trs2", "trb1", "trb2", "tksubthres1",
    "tksubthres2", "ibv", "nbv", "tt", "eg", "xti", "fc", "rthjc",
    "rthca", "cthj", "vgs_max", "vgd_max", "vds_max", "vgsr_max", "vgdr_max", "pd_max", "id_max",
    "idr_max", "te_max", "rth_ext", "derating",
    # LTspice datasheet annotations (not simulated by LTspice or ngspice)
    "ron", "qg", "vds", "subthres", "vdmos",
}
LEVEL1_USED = {"level", "vto", "vt0", "kp", "u0", "uo", "tox", "ld", "rd", "rs", "is", "cbd", "cbs",
               "cgso", "cgdo", "l", "w", "nsub", "phi", "gamma", "tpg", "nss", "xj", "delta", "wd",
               "tnom", "pb", "mj", "theta", "smooth"}
LEVEL1_IGNORED = {
    "lambda", "cgbo", "rsh", "cj", "cjsw", "mjsw", "js", "fc",
    "kf", "af", "uexp", "ucrit", "vmax", "neff", "nfs", "eta",
    "kappa", "xqc", "nlev", "gdsnoi", "ron", "qg", "vds", "mfg",
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
        [m]: VDMOS ``VTO`` (ngspice 39's default 0 V for either channel: ``.model mx vdmos(kp=2)``
        at Vgs = 2 V, Vds = 5 V draws 4 A there); level 1–3 as ngspice derives it
        (:mod:`~circuitnsds.frontend.cards.mos_parameters`: from ``NSUB``, ``TOX``, ...)."""
        if self.kind == "vdmos":
            return self.params.get("vto", self.params.get("vth0", 0.0)), "VTO"
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
                        "(KP, W, L; level 3 also THETA's mobility reduction); its threshold is "
                        "ngspice's at Vbs = 0 (level 3: with the short- and narrow-channel "
                        "effects, without ETA's drain feedback)")
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
                           "of ngspice's self-heating model are not supported",
                           hint=f"write {name.upper()} drain gate source MODEL, without the thermal "
                           "nodes tj and tc")
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
    drive_origin = ".options mosdrive" if "mosdrive" in options else "the default"
    try:
        vto, vto_rule = model.threshold_of(instance)
    except ValueError as exc:
        raise reader.error(f"{name}: model {model.name}: {exc}",
                           hint="check NSUB's unit (cm^-3) or give VTO") from None
    overdrive = drive - model.polarity * vto
    if overdrive <= 0:
        raise reader.error(f"{name}: the gate drive |Vgs| = {drive:g} V does not reach "
                           f"the threshold of model {model.name} (Vto = {vto:.4g} V)",
                           hint="set the drive at which Ron is computed: .options mosdrive=VALUE")
    channel, equation = _channel_law(model, instance, vto, reader)
    count = instance["m"]
    rule = f"{equation}; Vto={vto:.4g} V: {vto_rule}"
    off = model.get("rds", off_resistance) if model.kind == "vdmos" else off_resistance
    switch_model = SwitchModel(model.name, threshold=model.polarity * vto,
                               on_resistance=channel.resistance(drive), off_resistance=off / count,
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
    output = _output_capacitance(model, instance, bulk == source)
    voltage, voltage_origin = 0.0, "at zero bias until a run or the circuit's supply gives the voltage"
    if output.present:
        parts.append(Capacitor(f"{name}.coss", (drain, source), location,
                               capacitance=output.equivalent(voltage)))
    switch = Mosfet(name, (drain, source, inner_gate), location, model=switch_model,
                    polarity=model.polarity, device=model.kind, channel_rule=rule,
                    gate_drive=drive, drive_origin=drive_origin, channel=channel,
                    output=output if output.present else None, switched_voltage=voltage,
                    voltage_origin=voltage_origin, parts=tuple(p.name for p in parts))
    return [switch, *parts]


def _channel_law(model: MosfetModel, instance: dict[str, float], vto: float,
                 reader: StatementReader) -> tuple[ChannelLaw, str]:
    """The on-resistance as a function of the gate drive and its equation in words, for the
    threshold ``vto`` [V]."""
    resistors = {"drain": model.get("rd", 0.0), "source": model.get("rs", 0.0)}
    threshold = model.polarity * vto
    if model.kind == "vdmos":
        kp = model.get("kp", 25.0 + 10.0 * model.polarity)
        law = ChannelLaw("vdmos", threshold, kp * model.get("mtriode", 1.0),
                         theta=model.get("theta", 0.0), slope=model.get("ksubthres", 0.1),
                         shift=model.get("subshift", 0.0), count=instance["m"], **resistors)
        return law, f"Rch = (1 + θ·Vgs)/(Kp·mtriode·(Vgs − Vto)) (Kp={kp:g}, Vto={vto:g})"
    kp, _ = transconductance(model.params)
    length = instance["l"] - 2.0 * model.get("ld", 0.0)
    if length <= 0:
        raise reader.error(f"{reader.name}: the effective channel length L - 2·LD is not positive")
    beta = kp * instance["w"] / length
    theta = model.get("theta", 0.0) if int(model.get("level", 1)) == 3 else 0.0
    law = ChannelLaw("level", threshold, beta, theta=theta, count=instance["m"], **resistors)
    mobility = "(1 + θ·(Vgs − Vto))" if theta else "1"
    given = f", THETA={theta:g}" if theta else ""
    return law, (f"Rch = {mobility}/(Kp·W/(L−2·LD)·(Vgs − Vto)) (Kp={kp:g}, "
                 f"W/L={instance['w'] / length:g}, Vto={vto:.4g}{given})")


def _output_capacitance(model: MosfetModel, instance: dict[str, float],
                        bulk_at_source: bool) -> OutputCapacitance:
    """The drain–source capacitance law of a blocking device (its charge-equivalent value is
    ``{name}.coss``): VDMOS the body junction (``CJO``, ``VJ``, ``M``) and ``Cgd(Vgd)``
    (``CGDMIN``, ``CGDMAX``, ``A``); level 1–3 ``CGDO·W`` and, with the bulk at the source,
    the bulk–drain junction ``CBD`` (``PB``, ``MJ``)."""
    count = instance["m"]
    if model.kind == "vdmos":
        return OutputCapacitance(junction=model.get("cjo", 0.0), potential=model.get("vj", 0.8),
                                 grading=model.get("m", 0.5), gate_drain_min=model.get("cgdmin", 0.0),
                                 gate_drain_max=model.get("cgdmax", 0.0), slope=model.get("a", 1.0),
                                 count=count)
    overlap = model.get("cgdo", 0.0) * instance["w"]
    junction = model.get("cbd", 0.0) if bulk_at_source else 0.0
    return OutputCapacitance(junction=junction, potential=model.get("pb", 0.8),
                             grading=model.get("mj", 0.5), overlap=overlap, count=count)


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
        if model.params.get(suffix, 0.0) > 0 and bulk not in (other, source):
            parts.append(Capacitor(f"{name}.{suffix}", (bulk, other), location,
                                   capacitance=model.params[suffix] * count))
    return parts
