"""XSPICE digital parts in ngspice's syntax: ``d_inverter``, ``d_and``, ``d_or``,
``d_srlatch``, ``d_dff``, ``adc_bridge`` and ``dac_bridge``.

A digital node is an ordinary node whose voltage is exactly 0 or 1 [V], held by the ideal
voltage output (a :class:`~circuitnsds.circuit.elements.behavioural.BehaviouralSource`)
of the part that drives it; inputs draw no current. Every state of a part is a
:class:`~circuitnsds.circuit.elements.behavioural.Select` on the engine's switch
machinery, ``x = 1 if control > 0 else 0`` with ``control`` affine in the inputs, the
part's own states and ``min``/``max`` auxiliaries of them (exact complementarity pairs):
a state changes only at an event located by the engine (the step is split at the
crossing), and every change is a switching in ``waves.events`` named after the part
(``a1``; a flip-flop's master ``a1.master``). Port order and parameter names are ngspice's
(``src/xspice/icm/digital/*/ifspec.ifs``). What differs from ngspice:

* **no delays**: ngspice delays every output change by ``rise_delay``/``fall_delay`` (and
  ``clk_delay``, ``set_delay``, ... ; at least 1 ps, 1 ns by default) and ramps a
  ``dac_bridge`` output over ``t_rise``/``t_fall``; here a change propagates at the
  instant of its cause. Delay and load parameters given on a ``.model`` card are reported
  as ignored (a warning naming them). Hence a ``d_dff`` takes the data it had just before
  the active clock edge: a data change at the very instant of the edge is not taken (what a
  shift register of these parts needs), where ngspice, delaying data and clock alike, takes
  the new data when both change together from outside;
* **no UNKNOWN state**: where ngspice's output would be UNKNOWN, ours is a definite 0/1:
  an ``adc_bridge`` input between ``in_low`` and ``in_high`` keeps the output's state (a
  hysteresis band: it goes to 1 when it reaches ``max(in_low, in_high)`` and to 0 when it
  reaches ``min(in_low, in_high)``, both edges inclusive as in ngspice; ngspice outputs
  UNKNOWN inside when ``in_low < in_high``; when ``in_low > in_high`` its development
  sources (commit 0f0f80f, November 2024) hold, a Schmitt trigger, and its releases 39 to
  45 switch at ``in_low`` both ways); ``d_srlatch`` with
  ``s = r = 1`` and both latches with ``set = reset = 1`` are reset (reset dominant).

The state functions (``x`` a state, inputs 0/1, ``min`` of 0/1 values is their ``and``):

* ``d_inverter``: ``x = [½ − in > 0]``; ``d_and``: ``[Σ in − (n − ½) > 0]``;
  ``d_or``: ``[Σ in − ½ > 0]``;
* ``d_srlatch``: ``q = [min(en, s) − 2·min(en, r) + q + 3·set − 5·reset − ½ > 0]``;
* ``d_dff`` (master–slave, rising edge): master ``m = [max(min(d, 1 − clk), min(clk, m)) +
  2·set − 3·reset − ½ > 0]``, slave ``q = [max(min(m, clk), min(1 − clk, q)) + 2·set −
  3·reset − ½ > 0]``: the master follows ``data`` while the clock is low and holds while
  it is high; the slave copies the master while the clock is high;
* ``adc_bridge``: ``x = [in − (in_low + in_high)/2 > 0]`` with a band of half-width
  ``|in_high − in_low|/2``; ``dac_bridge``: ``out = out_low + (out_high − out_low)·in``
  (no state).

Every control is at least ½ away from its threshold whatever the 0/1 inputs, so no state
sits on its threshold.
"""

from __future__ import annotations

from typing import NamedTuple

from circuitnsds.circuit.elements.behavioural import Affine, BehaviouralSource, MinMax, Select
from circuitnsds.circuit.elements.switch import AT_THRESHOLD
from circuitnsds.errors import NetlistError
from circuitnsds.frontend.cards.model_kinds import DIGITAL_PARTS
from circuitnsds.frontend.cards.reader import StatementReader
from circuitnsds.frontend.cards.xspice_ports import HINT, DigitalPort, Ports, difference

DELAYS = frozenset({"rise_delay", "fall_delay", "sr_delay", "enable_delay", "set_delay",
                    "reset_delay", "clk_delay", "t_rise", "t_fall"})
LOADS = frozenset({"input_load", "sr_load", "enable_load", "set_load", "reset_load", "data_load",
                   "clk_load"})

ANALOG_INPUT = frozenset({"adc_bridge", "d_pwm"})
"""The digital parts whose inputs are analog (their output alone is a digital node)."""

ZERO = Affine()
ONE = Affine(constant=1.0)


def check_digital_model(reader: StatementReader, name: str, kind: str, params: dict) -> None:
    """Warn about the parameters of a digital ``.model`` card that are not honoured, and
    refuse values that have no meaning here."""
    delays = sorted(key for key in params if key in DELAYS)
    if delays:
        reader.warn(f".model {name} {kind}: {', '.join(delays)} ignored: digital parts switch "
                    "without delay in circuitnsds (ngspice delays by them)")
    loads = sorted(key for key in params if key in LOADS)
    if loads:
        reader.warn(f".model {name} {kind}: {', '.join(loads)} ignored (in ngspice loads only "
                    "lengthen the delays)")
    if "out_undef" in params:
        reader.warn(f".model {name} {kind}: out_undef ignored: digital nodes have no UNKNOWN "
                    "state in circuitnsds")
    if "ic" in params and params["ic"] not in (0.0, 1.0):
        raise reader.error(f".model {name} {kind}: ic={params['ic']:g} is not 0 or 1",
                           hint="the initial state of a latch is 0 or 1 (no UNKNOWN state)")
    if kind == "d_pwm":
        from circuitnsds.frontend.cards.xspice_pwm import check_pwm_model

        check_pwm_model(reader, name, params)
    if kind == "adc_bridge":
        low = params.get("in_low", DIGITAL_PARTS[kind]["in_low"])
        high = params.get("in_high", DIGITAL_PARTS[kind]["in_high"])
        if low < high:
            reader.warn(f".model {name} adc_bridge: between in_low={low:g} and in_high={high:g} "
                        "the output keeps its state here; ngspice's is UNKNOWN there (a "
                        "dac_bridge then gives out_undef): write in_low = in_high for a plain "
                        "threshold")
        elif low > high:
            reader.warn(f".model {name} adc_bridge: in_low={low:g} > in_high={high:g} is a Schmitt "
                        "trigger here (as in ngspice's development sources since November 2024); "
                        f"released ngspice (39 to 45) switches at in_low={low:g} both ways")


def _combine(*terms: tuple[float, Affine], constant: float = 0.0) -> Affine:
    """``Σ c·value + constant`` of affine values (node voltages, auxiliaries, constants)."""
    voltages: dict[str, float] = {}
    auxiliaries: dict[int, float] = {}
    for c, value in terms:
        for node, a in value.voltages:
            voltages[node] = voltages.get(node, 0.0) + c * a
        for k, a in value.auxiliaries:
            auxiliaries[k] = auxiliaries.get(k, 0.0) + c * a
        constant += c * value.constant
    return Affine(voltages=tuple((n, a) for n, a in voltages.items() if a != 0.0),
                  auxiliaries=tuple((k, a) for k, a in auxiliaries.items() if a != 0.0),
                  constant=constant)


def _state(k: int, inverted: bool = False) -> Affine:
    """Auxiliary ``k`` (a 0/1 state), or ``1 − x_k``."""
    return Affine(auxiliaries=((k, -1.0 if inverted else 1.0),), constant=1.0 if inverted else 0.0)


def _not(value: Affine) -> Affine:
    return _combine((-1.0, value), constant=1.0)


class _Output(NamedTuple):
    """One ideal voltage output of a part: ``v(plus) − v(minus) = value``."""

    suffix: str
    plus: str
    minus: str
    value: Affine


def _output(port: DigitalPort | None, state: Affine, suffix: str = "") -> list[_Output]:
    if port is None:
        return []
    return [_Output(suffix, port.node, "0", _not(state) if port.inverted else state)]


def digital_part(reader: StatementReader, model, tokens: list[str]) -> list[BehaviouralSource]:
    """An ``A`` line whose model is one of :data:`DIGITAL_PARTS` (``tokens``: its ports).

    One behavioural voltage source per output, to ground (or across a ``%vd`` port of a
    ``dac_bridge``): the first (``out``, or ``Nout`` when ``out`` is NULL) carries the
    part's states and is named as the part; ``Nout`` is ``1 − v(out)``, named
    ``<part>.nout``; the bits of a vector bridge are ``<part>.0``, ``<part>.1``, ...
    """
    ports = Ports(reader, tokens)
    build = {"d_inverter": _gate, "d_and": _gate, "d_or": _gate, "d_srlatch": _srlatch,
             "d_dff": _dff, "adc_bridge": _adc, "dac_bridge": _dac}[model.kind]
    parts = build(reader, model, ports)
    if not ports.done:
        raise reader.error(f"{reader.name}: unexpected {ports.tokens[ports.position]!r} after the "
                           f"ports of {model.kind}", hint=HINT)
    if not parts:
        raise reader.error(f"{reader.name}: every output of {model.kind} is NULL",
                           hint="connect out or Nout to a node")
    sources = []
    for output, auxiliaries, inputs in parts:
        name = reader.name + output.suffix
        first = (output.plus, output.minus)
        controls = tuple(n for n in dict.fromkeys(inputs) if n not in first and n != "0")
        sources.append(BehaviouralSource(
            name, (*first, *controls), reader.location, output="v", value=output.value,
            auxiliaries=tuple(auxiliaries), expression=f"{model.kind} {model.name}",
            model=model.name))
    return sources


def _latch_outputs(out: DigitalPort | None, nout: DigitalPort | None, auxiliaries: list,
                   inputs: list[str]):
    """The ``out``/``Nout`` sources of a latch whose state is auxiliary 0 of ``auxiliaries``."""
    if out is None:
        return [(_output(nout, _state(0, inverted=True))[0], auxiliaries, inputs)] if nout else []
    parts = [(_output(out, _state(0))[0], auxiliaries, inputs)]
    if nout is not None:
        complement = _not(out.level())
        parts.append((_output(nout, complement, ".nout")[0], [], [out.node]))
    return parts


def _gate(reader, model, ports: Ports):
    if model.kind == "d_inverter":
        inputs = [ports.digital("in")]
    else:
        inputs = ports.digital_vector("in")
        if len(inputs) < 2:
            raise reader.error(f"{reader.name}: {model.kind} needs at least two inputs, "
                               f"not {len(inputs)}", hint="write [in1 in2 ...]")
    out = ports.digital("out")
    total = _combine(*((1.0, port.level()) for port in inputs))
    threshold = {"d_inverter": 0.5, "d_and": len(inputs) - 0.5, "d_or": 0.5}[model.kind]
    sign = -1.0 if model.kind == "d_inverter" else 1.0
    control = _combine((sign, total), constant=-sign * threshold)
    select = Select(control, ONE, ZERO, name=reader.name)
    return [(_output(out, _state(0))[0], [select], [p.node for p in inputs])]


def _async(set_port: DigitalPort | None, reset_port: DigitalPort | None,
           set_weight: float, reset_weight: float) -> list[tuple[float, Affine]]:
    terms = []
    if set_port is not None:
        terms.append((set_weight, set_port.level()))
    if reset_port is not None:
        terms.append((-reset_weight, reset_port.level()))
    return terms


def _srlatch(reader, model, ports: Ports):
    s, r, enable = (ports.digital(what) for what in ("s", "r", "enable"))
    set_port, reset_port = ports.digital("set", True), ports.digital("reset", True)
    out, nout = ports.digital("out", True), ports.digital("Nout", True)
    # x0 = q, x1 = min(enable, s), x2 = min(enable, r)
    control = _combine((1.0, _state(1)), (-2.0, _state(2)), (1.0, _state(0)),
                       *_async(set_port, reset_port, 3.0, 5.0), constant=-0.5)
    auxiliaries = [
        Select(control, ONE, ZERO, name=reader.name, initially_on=model.get("ic") == 1.0),
        MinMax("min", enable.level(), s.level()),
        MinMax("min", enable.level(), r.level()),
    ]
    inputs = [p.node for p in (s, r, enable, set_port, reset_port) if p is not None]
    return _latch_outputs(out, nout, auxiliaries, inputs)


def _dff(reader, model, ports: Ports):
    data, clk = ports.digital("data"), ports.digital("clk")
    set_port, reset_port = ports.digital("set", True), ports.digital("reset", True)
    out, nout = ports.digital("out", True), ports.digital("Nout", True)
    forced = _async(set_port, reset_port, 2.0, 3.0)
    initial = model.get("ic") == 1.0
    low = _not(clk.level())
    # x0 = q (slave), x1 = m (master); x2..x4 the master's multiplexer, x5..x7 the slave's
    auxiliaries = [
        Select(_combine((1.0, _state(7)), *forced, constant=-0.5), ONE, ZERO, name=reader.name,
               initially_on=initial),
        Select(_combine((1.0, _state(4)), *forced, constant=-0.5), ONE, ZERO,
               name=f"{reader.name}.master", initially_on=initial),
        MinMax("min", data.level(), low),
        MinMax("min", clk.level(), _state(1)),
        MinMax("max", _state(2), _state(3)),
        MinMax("min", _state(1), clk.level()),
        MinMax("min", low, _state(0)),
        MinMax("max", _state(5), _state(6)),
    ]
    inputs = [p.node for p in (data, clk, set_port, reset_port) if p is not None]
    return _latch_outputs(out, nout, auxiliaries, inputs)


def _expect_vector(reader, ports: Ports, what: str) -> None:
    if ports.tokens[ports.position:ports.position + 1] != ["["]:
        raise reader.error(f"{reader.name}: the {what} port of a bridge is a vector: write "
                           "[node ...] (ngspice requires the brackets)", hint=HINT)


def adc_thresholds(in_low: float, in_high: float) -> tuple[float, float]:
    """``(on, off)`` [V]: an ``adc_bridge`` output goes to 1 when its input exceeds ``on`` and
    to 0 when it falls below ``off`` (a :class:`Select` switches strictly beyond its thresholds).

    ngspice 39 (``src/xspice/icm/digital/adc_bridge/cfunc.mod``) tests ``in <= in_low`` (0)
    first, then ``in >= in_high`` (1): both edges of the band are *inclusive*, so an input that
    reaches exactly ``in_high`` (a 0/1 V pulse with ``in_high = 1``) switches to 1. The
    thresholds therefore sit a round-off margin (:data:`AT_THRESHOLD` of the level, as for a
    switch exactly at ``VT``) inside the band; with ``in_low = in_high = t`` both are
    ``t + margin``, so an input exactly at ``t`` gives 0, as ngspice 39's order of tests does.
    """
    low, high = sorted((in_low, in_high))
    on = high - AT_THRESHOLD * max(1.0, abs(high))
    off = low + AT_THRESHOLD * max(1.0, abs(low))
    if on <= off:
        on = off = max(on, off)
    return on, off


def _adc(reader, model, ports: Ports):
    _expect_vector(reader, ports, "in")
    inputs = ports.vector()
    outs = ports.digital_vector("out")
    if len(inputs) != len(outs):
        raise reader.error(f"{reader.name}: adc_bridge has {len(inputs)} input(s) and "
                           f"{len(outs)} output(s)", hint="give one digital output per input")
    on, off = adc_thresholds(model.get("in_low"), model.get("in_high"))
    parts = []
    for k, (port, out) in enumerate(zip(inputs, outs)):
        suffix = "" if len(inputs) == 1 else f".{k}"
        control = _combine((1.0, difference(port, 1.0)), constant=-(on + off) / 2)
        select = Select(control, ONE, ZERO, name=reader.name + suffix, hysteresis=(on - off) / 2)
        parts.append((_output(out, _state(0), suffix)[0], [select], list(port)))
    return parts


def _dac(reader, model, ports: Ports):
    inputs = ports.digital_vector("in")
    _expect_vector(reader, ports, "out")
    outs = ports.vector()
    if len(inputs) != len(outs):
        raise reader.error(f"{reader.name}: dac_bridge has {len(inputs)} input(s) and "
                           f"{len(outs)} output(s)", hint="give one analog output per input")
    low, high = model.get("out_low"), model.get("out_high")
    return [(_Output("" if len(inputs) == 1 else f".{k}", plus, minus,
                     _combine((high - low, port.level()), constant=low)), [], [port.node])
            for k, (port, (plus, minus)) in enumerate(zip(inputs, outs))]


def check_digital_nodes(elements, models: dict[str, object]) -> None:
    """Digital and analog nodes stay apart, as the parts' threshold functions need 0/1 V
    inputs: every digital input must be a node that a digital output drives (a gate, a
    latch or an ``adc_bridge``), and a digital node may touch no analog element (nor the
    analog side of a bridge). ngspice 39 would insert a bridge there by itself
    (``src/xspice/evt/evtcheck_nodes.c``: an ``adc_bridge`` at ``vcc/2``, a ``dac_bridge``
    of ``0``/``vcc``, ``vcc`` = 3.3 V unless ``.param vcc``), where circuitnsds would read or
    give the digital node's 0/1 V: both are refused, naming the bridge to write."""
    def kind(element) -> str | None:
        model = models.get(getattr(element, "model", None) or "")
        return getattr(model, "kind", None) if isinstance(element, BehaviouralSource) else None

    digital = [(element, kind(element)) for element in elements if kind(element) in DIGITAL_PARTS]
    driven = {element.nodes[0]: element for element, k in digital if k != "dac_bridge"}
    for element, k in digital:
        if k in ANALOG_INPUT:
            continue
        for node in element.nodes[2:]:
            if node not in driven:
                raise NetlistError(
                    f"{element.name}: node {node!r} is a digital input of this {k} but no digital "
                    "output drives it", where=element.location,
                    hint="convert the analog voltage with an adc_bridge (.model M adc_bridge("
                    "in_low=1.65 in_high=1.65) is the one ngspice 39 inserts by itself for "
                    "vcc = 3.3 V)")
    digital_ports = {id(element): set(element.nodes[:1] if k in ANALOG_INPUT else
                                      element.nodes[2:] if k == "dac_bridge" else element.nodes)
                     for element, k in digital}
    for element in elements:
        ports = digital_ports.get(id(element), set())
        for node in element.nodes:
            if node in driven and node not in ports:
                driver = driven[node]
                raise NetlistError(
                    f"{element.name}: node {node!r} is a digital node (the output of "
                    f"{driver.name}) but {element.name} connects to it as an analog element",
                    where=element.location,
                    hint="read the node through a dac_bridge into an analog node (ngspice 39 "
                    "inserts one by itself, .model M dac_bridge(out_low=0 out_high=3.3) for "
                    "vcc = 3.3 V, where circuitnsds would give the digital 0/1 V)")
