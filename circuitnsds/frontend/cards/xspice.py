"""XSPICE analog blocks in ngspice's syntax: ``A name in out MODEL`` with
``.model MODEL gain|summer|limit|int(...)``.

Ports: a node (``in``), ``%v(in)``, ``%vd(in+ in-)`` (a differential voltage), and for
``summer`` a vector ``[in1 %vd(a b) ...]``. Inputs draw no current; an output is an ideal
voltage source (to ground, or between the two nodes of ``%vd``). Parameters and defaults
are those of ngspice's code models (``src/xspice/icm/analog/*/ifspec.ifs``):

* ``gain``: ``out = gain·(in + in_offset) + out_offset`` (defaults 1, 0, 0);
* ``summer``: ``out = out_gain·Σ in_gain[k]·(in[k] + in_offset[k]) + out_offset``;
* ``limit``: ``out = clamp(gain·(in + in_offset), out_lower_limit, out_upper_limit)``: the
  ideal clamp, two complementarity pairs; ngspice rounds the corners over ``limit_range``
  (1 µV by default), which the ideal clamp replaces (a warning when it is given);
* ``int``: ``d out/dt = gain·(in + in_offset)``, ``out(0) = out_ic`` under UIC (an MNA
  state row); ``out_lower_limit``/``out_upper_limit`` stop the state itself at a limit, as
  ngspice's model does, by two complementarity pairs on the state row (limits of magnitude
  1e10 V or more are no limit). Without UIC the operating point takes the integrator at
  equilibrium (its input zero); ngspice holds the output at ``out_ic`` there instead.

The digital parts ``d_inverter``, ``d_and``, ``d_or``, ``d_srlatch``, ``d_dff``,
``adc_bridge`` and ``dac_bridge`` are read by :mod:`circuitnsds.frontend.cards.xspice_digital`,
``d_pwm`` by :mod:`circuitnsds.frontend.cards.xspice_pwm`.
``hyst`` (ngspice's two legs without their rounded corners: a comparator with a band and a
clamped line) and ``d_dt`` (``gain·ddt(in) + out_offset`` on an internal node, clamped to its
limits) are read here too. Other code models (``d_nand``, ``d_jkff``, ``s_xfer``,
``lcouple``, ...) are refused with a message naming the model.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from circuitnsds.circuit.elements.behavioural import (
    Affine,
    BehaviouralSource,
    Integrator,
    MinMax,
    Select,
)
from circuitnsds.errors import SourceLocation
from circuitnsds.frontend.cards.model_kinds import CODE_MODELS, DIGITAL_PARTS
from circuitnsds.frontend.cards.reader import StatementReader
from circuitnsds.frontend.cards.xspice_digital import check_digital_model, digital_part
from circuitnsds.frontend.cards.xspice_ports import (
    HINT,
    Port,
    Ports,
    affine_sum,
    difference,
    split_brackets,
)
from circuitnsds.values import parse_value

VECTOR_PARAMETERS = {"summer": frozenset({"in_offset", "in_gain"}),
                     "d_pwm": frozenset({"cntl_array", "dc_array"})}
"""The parameters written as vectors ``[v1 v2 ...]`` (one value per input); every other
parameter of :data:`CODE_MODELS` is a single value (ngspice refuses either written as the
other: "Array parameter expected", "Bad real value")."""

REFUSED_MODELS = {
    "d_nand", "d_nor", "d_xor", "d_xnor", "d_buffer",
    "d_jkff", "d_tff", "d_srff", "d_dlatch", "d_open_c", "d_open_e", "d_pullup",
    "d_pulldown", "d_fsm", "d_state", "d_ram", "d_source", "d_osc", "d_tristate",
    "d_lut", "d_genlut", "d_to_real", "real_to_v", "slew",
    "s_xfer", "mult", "divide", "cmeter", "lmeter", "climit", "pwl", "ilimit", "aswitch",
    "zener", "file_source", "sine", "square", "triangle", "oneshot", "core", "multi_input_pwl",
    "table2d", "table3d", "filesource", "pswitch", "sidiode", "delay", "astate", "seegen",
}
"""XSPICE code models recognised as such in ``.model`` cards (so that their use is refused
with the model's name rather than reported as an unknown model type)."""


@dataclass(frozen=True)
class XspiceModel:
    """``.model NAME KIND(...)`` of a supported code model (:data:`CODE_MODELS`): ``params``
    holds what the card gives (numbers, tuples for vectors, booleans)."""

    name: str
    kind: str
    params: dict = field(default_factory=dict)
    location: SourceLocation | None = None

    def get(self, key: str):
        return self.params.get(key, CODE_MODELS[self.kind][key])


def read_xspice_model(reader: StatementReader, name: str, kind: str) -> XspiceModel:
    """The parameters of a code model's ``.model`` card (reader after the ``(``)."""
    tokens = split_brackets(list(reader.tokens[reader.position:]))
    known = CODE_MODELS[kind]
    params: dict = {}
    position = 0
    while position < len(tokens):
        key = tokens[position]
        if position + 2 > len(tokens) or tokens[position + 1] != "=":
            raise reader.error(f".model {name}: expected '{key}=value'")
        position += 2
        if position < len(tokens) and tokens[position] == "[":
            end = tokens.index("]", position) if "]" in tokens[position:] else -1
            if end == -1:
                raise reader.error(f".model {name}: '[' of {key} is not closed")
            text = tokens[position + 1:end]
            position = end + 1
            value: object = tuple(_number(reader, name, key, t) for t in text)
        else:
            text = tokens[position] if position < len(tokens) else ""
            position += 1
            value = (text in {"true", "1"}) if key == "fraction" else _number(reader, name, key, text)
        if key not in known:
            raise reader.error(f".model {name} {kind}: unknown parameter {key!r}",
                               hint=f"{kind} takes {', '.join(known)}")
        if key in params:
            raise reader.error(f".model {name}: parameter {key!r} is given twice")
        vector = key in VECTOR_PARAMETERS.get(kind, ())
        if vector and not isinstance(value, tuple):
            raise reader.error(f".model {name} {kind}: {key} is a vector, one value per input",
                               hint=f"write {key}=[v1 v2 ...] (brackets even for one input)")
        if isinstance(value, tuple) and not vector:
            raise reader.error(f".model {name} {kind}: {key} is a single value, not a vector",
                               hint=f"write {key}=value")
        params[key] = value
    if kind in DIGITAL_PARTS:
        check_digital_model(reader, name, kind, params)
    return XspiceModel(name, kind, params, reader.location)


def _number(reader: StatementReader, name: str, key: str, text: str) -> float:
    try:
        return parse_value(text)
    except ValueError:
        raise reader.error(f".model {name}: {key}={text!r} is not a number") from None


def analog_block(reader: StatementReader, models: dict[str, object]):
    """An ``A`` line whose model is one of :data:`CODE_MODELS`."""
    name = reader.name
    tokens = split_brackets(list(reader.tokens[1:]))
    if len(tokens) < 3:
        raise reader.error(f"{name}: expected A{name[1:]} in out MODEL",
                           hint="write A1 in out MODEL with .model MODEL gain(...)")
    if tokens.count("[") != tokens.count("]"):
        raise reader.error(f"{name}: unbalanced brackets in the port list: every '[' needs its ']'",
                           hint=HINT)
    model_name = tokens[-1]
    model = reader.model(models, model_name, "model",
                         f"add .model {model_name} KIND(...), KIND one of {', '.join(CODE_MODELS)}")
    if not isinstance(model, XspiceModel):
        kind = model if isinstance(model, str) else type(model).__name__
        if kind == "core":
            raise reader.error(f"{name}: code model core ({model_name!r}, XSPICE's magnetic core) "
                               "is not supported: its B(H) curve is a smooth nonlinear element "
                               "(issue 33)",
                               hint="for a linear core write a resistor of its reluctance, "
                               "length/(µ·area) [A·turn/Wb], between the magnetic nodes of the "
                               "lcouple windings (read here)")
        analog = {"s_xfer": "the analog transfer-function"}
        what = analog.get(str(kind)) or ("an XSPICE digital or mixed-signal"
                                         if str(kind).startswith(("d_", "adc", "dac")) else f"the {kind!s}")
        raise reader.error(f"{name}: code model {kind!s} ({what} model {model_name!r}) is not "
                           "supported by the ideal engine",
                           hint="write the block with the A models circuitnsds reads ("
                           + ", ".join(CODE_MODELS) + ") or a B source of its function")
    if model.kind == "lcouple":
        return _winding(reader, model, tokens[:-1])
    if model.kind == "d_pwm":
        from circuitnsds.frontend.cards.xspice_pwm import pwm_oscillator

        return pwm_oscillator(reader, model, tokens[:-1])
    if model.kind in DIGITAL_PARTS:
        return digital_part(reader, model, tokens[:-1])
    ports = Ports(reader, tokens[:-1])
    inputs = ports.vector()
    output = ports.port()
    if ports.position != len(ports.tokens):
        raise reader.error(f"{name}: unexpected {ports.tokens[ports.position]!r} after the ports",
                           hint="write A1 in out MODEL")
    if model.kind != "summer" and len(inputs) != 1:
        raise reader.error(f"{name}: {model.kind} takes one input, not a vector")
    controls = tuple(dict.fromkeys(n for port in inputs for n in port if n != "0"))
    outputs = output
    if model.kind == "d_dt":
        return _differentiator(reader, model, inputs[0], outputs, controls)
    value, auxiliaries = _block_value(reader, model, inputs)
    if model.kind == "int":
        low, high = (_finite_limit(model.get(key)) for key in ("out_lower_limit", "out_upper_limit"))
        if low is not None and high is not None and low >= high:
            raise reader.error(f"{name}: out_lower_limit={low:g} is not below "
                               f"out_upper_limit={high:g} in {model.name!r}")
        if "limit_range" in model.params:
            reader.warn(f"{name}: limit_range of {model.name!r} ignored: the ideal limits of the "
                        "integrator have sharp corners")
        return Integrator(name, (*outputs, *controls), reader.location, input=value,
                          initial_output=model.get("out_ic"), lower=low, upper=high,
                          model=model.name)
    return BehaviouralSource(name, (*outputs, *controls), reader.location, output="v", value=value,
                             auxiliaries=auxiliaries, expression=f"{model.kind} {model.name}",
                             model=model.name)


NO_LIMIT = 1e10
"""An integrator limit of this magnitude or more [V] is no limit (ngspice's examples write
±1e12 because its int model requires both limits)."""


def _finite_limit(value: float | None) -> float | None:
    return None if value is None or abs(value) >= NO_LIMIT else value


def _block_value(reader: StatementReader, model: XspiceModel,
                 inputs: list[Port]) -> tuple[Affine, tuple[MinMax | Select, ...]]:
    kind = model.kind
    if kind == "summer":
        count = len(inputs)
        offsets = model.get("in_offset") or (0.0,) * count
        gains = model.get("in_gain") or (1.0,) * count
        for key, values in (("in_offset", offsets), ("in_gain", gains)):
            if len(values) != count:
                raise reader.error(f"{reader.name}: {key} of {model.name!r} has {len(values)} "
                                   f"values for {count} inputs")
        out_gain = model.get("out_gain")
        terms = [difference(port, out_gain * g) for port, g in zip(inputs, gains)]
        constant = out_gain * sum(g * o for g, o in zip(gains, offsets)) + model.get("out_offset")
        return affine_sum(*terms, constant=constant), ()
    if kind == "hyst":
        return _hysteresis(reader, model, inputs[0])
    gain = model.get("gain")
    value = affine_sum(difference(inputs[0], gain), constant=gain * model.get("in_offset"))
    if kind == "gain":
        return affine_sum(value, constant=value.constant + model.get("out_offset")), ()
    if kind == "int":
        return value, ()
    low, high = model.get("out_lower_limit"), model.get("out_upper_limit")
    if low is None or high is None:
        raise reader.error(f"{reader.name}: the limit model {model.name!r} needs out_lower_limit "
                           "and out_upper_limit")
    if low > high:
        raise reader.error(f"{reader.name}: out_lower_limit={low:g} exceeds out_upper_limit={high:g} "
                           f"in {model.name!r}")
    if "limit_range" in model.params or "fraction" in model.params:
        reader.warn(f"{reader.name}: limit_range/fraction of {model.name!r} ignored: the ideal clamp "
                    "has sharp corners (ngspice rounds them over limit_range)")
    # out = min(max(value, low), high): auxiliary 0 is the max, auxiliary 1 the min
    floor = MinMax("max", value, Affine(constant=low))
    ceiling = MinMax("min", Affine(auxiliaries=((0, 1.0),)), Affine(constant=high))
    return Affine(auxiliaries=((1, 1.0),)), (floor, ceiling)


def _differentiator(reader: StatementReader, model: XspiceModel, port: Port,
                    outputs: tuple[str, str], controls: tuple[str, ...]) -> list[BehaviouralSource]:
    """``d_dt``: ``out = clamp(gain·d(in)/dt + out_offset, out_lower_limit, out_upper_limit)``
    [V]. The derivative is a ``ddt()`` term (capacitor-like, differentiated by the integrator as
    a capacitor's charge is; ngspice takes a backward difference over its own step) held by an
    ideal source on the internal node ``<block>.ddt``; the output clamps that node's voltage
    with two complementarity pairs (ngspice rounds the corners over ``limit_range``). ngspice
    requires both limits; a block without them here is the bare derivative."""
    gain = model.get("gain")
    rates = tuple((("v", node), sign * gain) for node, sign in ((port[0], 1.0), (port[1], -1.0))
                  if node != "0")
    derivative = Affine(rates=rates, constant=model.get("out_offset"))
    low, high = model.get("out_lower_limit"), model.get("out_upper_limit")
    common = dict(output="v", expression=f"d_dt {model.name}", model=model.name)
    if low is None and high is None:
        return [BehaviouralSource(reader.name, (*outputs, *controls), reader.location,
                                  value=derivative, **common)]
    if low is not None and high is not None and low > high:
        raise reader.error(f"{reader.name}: out_lower_limit={low:g} exceeds out_upper_limit="
                           f"{high:g} in {model.name!r}")
    if "limit_range" in model.params:
        reader.warn(f"{reader.name}: limit_range of {model.name!r} ignored: the ideal clamp has "
                    "sharp corners (ngspice rounds them over limit_range)")
    inner = f"{reader.name}.ddt"
    clamps: list[MinMax] = []
    value = Affine(voltages=((inner, 1.0),))
    if low is not None:
        clamps.append(MinMax("max", value, Affine(constant=low)))
        value = Affine(auxiliaries=((0, 1.0),))
    if high is not None:
        clamps.append(MinMax("min", value, Affine(constant=high)))
        value = Affine(auxiliaries=((len(clamps) - 1, 1.0),))
    return [BehaviouralSource(inner, (inner, "0", *controls), reader.location, value=derivative,
                              **common),
            BehaviouralSource(reader.name, (*outputs, inner), reader.location, value=value,
                              auxiliaries=tuple(clamps), **common)]


def _hysteresis(reader: StatementReader, model: XspiceModel,
                port: Port) -> tuple[Affine, tuple[Select | MinMax, ...]]:
    """``hyst``: ngspice's two legs without their smoothed corners. On the rising leg ``out`` goes
    linearly from ``out_lower_limit`` at ``in_low + hyst`` to ``out_upper_limit`` at
    ``in_high + hyst``, on the falling leg the same line shifted by ``-2·hyst``; the leg changes
    to falling when ``in`` exceeds ``in_high + hyst`` and back when it falls below
    ``in_low - hyst``: a comparator with hysteresis (auxiliary 0, 1 on the falling leg), whose
    changes are located events, and the clamp of the line (auxiliaries 1 and 2)."""
    low, high, width = model.get("in_low"), model.get("in_high"), model.get("hyst")
    out_low, out_high = model.get("out_lower_limit"), model.get("out_upper_limit")
    if not high > low:
        raise reader.error(f"{reader.name}: in_high={high:g} of the hyst model {model.name!r} must "
                           f"exceed in_low={low:g}", hint="ngspice's slope (out_upper_limit - "
                           "out_lower_limit)/(in_high - in_low) needs in_high > in_low")
    if width < 0:
        raise reader.error(f"{reader.name}: hyst={width:g} of {model.name!r} must not be negative")
    if "input_domain" in model.params or "fraction" in model.params:
        reader.warn(f"{reader.name}: input_domain/fraction of {model.name!r} ignored: the ideal "
                    "hysteresis has sharp corners (ngspice rounds them over input_domain)")
    slope = (out_high - out_low) / (high - low)
    control = affine_sum(difference(port, 1.0), constant=-(low + high) / 2)
    leg = Select(control, Affine(constant=1.0), Affine(), name=reader.name,
                 hysteresis=(high - low) / 2 + width)
    line = Affine(voltages=difference(port, slope).voltages, auxiliaries=((0, 2 * width * slope),),
                  constant=out_low - slope * (low + width))
    floor = MinMax("max", line, Affine(constant=min(out_low, out_high)))
    ceiling = MinMax("min", Affine(auxiliaries=((1, 1.0),)), Affine(constant=max(out_low, out_high)))
    return Affine(auxiliaries=((2, 1.0),)), (leg, floor, ceiling)


def _pair(reader: StatementReader, tokens: list[str], position: int) -> tuple[tuple[str, str], int]:
    """A differential port ``(n+ n-)`` or ``%hd(n+ n-)`` at ``position``: its nodes and the
    position after it."""
    if tokens[position:position + 1] == ["%hd"]:
        position += 1
    if tokens[position:position + 1] != ["("] or tokens[position + 3:position + 4] != [")"]:
        raise reader.error(f"{reader.name}: lcouple's ports are differential: write "
                           "A1 (l+ l-) (mmf+ mmf-) MODEL", hint=HINT)
    return (tokens[position + 1], tokens[position + 2]), position + 4


def _winding(reader: StatementReader, model: XspiceModel, tokens: list[str]) -> list[BehaviouralSource]:
    """``lcouple``: a winding of ``N = num_turns`` turns on an XSPICE magnetic circuit, whose
    nodes carry the magnetomotive force [A·turn] as a voltage and the flux [Wb] as a current
    (a resistor there is a reluctance [1/H]). Two ideal sources: on the magnetic port
    ``mmf+ − mmf- = N·i`` (``i`` the winding's current, into ``l+`` through the winding),
    driving the flux ``Φ`` out of ``mmf+`` into the magnetic circuit (``Φ = −i(<block>.mmf)``,
    SPICE's source-current sign); on the electric port ``v(l+) − v(l-) = N·dΦ/dt`` (a
    ``ddt()`` term of that current), so that a winding's inductance is positive, as in
    ngspice. With linear reluctances the windings are coupled inductors (``L = N²/R`` for one
    winding on a reluctance ``R``), exact for the ideal engine."""
    (plus, minus), position = _pair(reader, tokens, 0)
    (mmf_plus, mmf_minus), position = _pair(reader, tokens, position)
    if position != len(tokens):
        raise reader.error(f"{reader.name}: unexpected {tokens[position]!r} after lcouple's ports",
                           hint=HINT)
    turns = model.get("num_turns")
    magnetic = f"{reader.name}.mmf"
    common = dict(output="v", expression=f"lcouple {model.name}", model=model.name)
    return [
        BehaviouralSource(reader.name, (plus, minus), reader.location,
                          value=Affine(rates=((("i", magnetic), -turns),)), **common),
        BehaviouralSource(magnetic, (mmf_plus, mmf_minus), reader.location,
                          value=Affine(currents=((reader.name, turns),)), **common),
    ]
