"""IGBTs and thyristors: ``.model NAME IGBT(...)`` / ``SCR(...)`` and ``Z`` lines.

No SPICE has a thyristor primitive, and ngspice and LTspice have no IGBT (their libraries
use subcircuits); PSpice reads ``Zname collector gate emitter MODEL`` with an ``NIGBT``
model of the device physics. circuitnsds reads the ``Z`` line in PSpice's terminal order,
for both devices, and takes the model type to say which:

* ``.model NAME IGBT(VT= VCESAT= [RON=] [VH=] [ROFF=] [VFD= RFD=] [thermal=])``:
  the gate threshold ``VT`` [V] on ``v(g, e)`` (with ``S`` switch rules and hysteresis
  ``VH``), the on-state ``v(c, e) = VCESAT + RON·i_c`` (``VCESAT`` is the intercept of the
  datasheet's output line, ``RON`` [Ω] its slope), and, when ``VFD`` or ``RFD`` is given, an
  antiparallel (co-pack) diode with ``Vfwd = VFD``, ``Ron = RFD`` from the emitter to the
  collector. The turn-off tail current is not modelled (``info`` says so at each IGBT).
* ``.model NAME SCR(IGT= [IH=] [VON=] [RON=] [VGT=] [RG=] [ROFF=])``: fires when the gate
  current exceeds ``IGT`` [A], holds while the anode current stays above ``IH`` [A],
  conducts with ``v(a, k) = VON + RON·i_a``; its gate is a junction to the cathode with
  ``Vfwd = VGT``, ``Ron = RG``.

ngspice's MESFETs (``Z`` with an ``NMF``/``PMF`` model) are refused by name.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from circuitnsds.circuit.elements import Diode, DiodeModel, Element, SwitchModel
from circuitnsds.circuit.elements.power import Igbt, Thyristor
from circuitnsds.errors import SourceLocation
from circuitnsds.frontend.cards.reader import StatementReader

PARAMETERS = {
    "igbt": {"vt": None, "vcesat": None, "ron": 0.0, "vh": 0.0, "roff": None, "vfd": None,
             "rfd": None},
    "scr": {"igt": None, "ih": 1e-9, "von": 0.0, "ron": 0.0, "vgt": 0.7, "rg": 0.0,
            "roff": None},
}
"""Each model type's parameters -> default (``None``: required, or absent by default)."""
REQUIRED = {"igbt": ("vt", "vcesat"), "scr": ("igt",)}
"""Parameters without which the device means nothing."""
EXAMPLES = {"igbt": "IGBT(VT=5 VCESAT=1.2 RON=20m)", "scr": "SCR(IGT=10m VON=1 RON=10m)"}
DEFAULT_HOLDING_CURRENT = PARAMETERS["scr"]["ih"]
"""``IH`` [A] when none is given: a current that counts as zero. The series diode takes the
anode current to exactly zero at turn-off, so any positive ``IH`` below the device's real
holding current turns it off at the same instant; 1 nA stays above the 1e-12 S leakage of a
blocking thyristor up to 1 kV."""


@dataclass(frozen=True)
class PowerDeviceModel:
    """A ``.model NAME IGBT|SCR(...)`` card as written.

    Attributes:
        name: model name.
        kind: ``igbt`` or ``scr``.
        params: the numeric parameters given (lower-case names, SI units).
        thermal: the PLECS thermal description (``thermal="file.xml"``), IGBT only.
        location: where the card was written.
    """

    name: str
    kind: str
    params: dict[str, float] = field(default_factory=dict)
    thermal: str | None = None
    location: SourceLocation | None = None

    def get(self, key: str) -> float | None:
        return self.params.get(key, PARAMETERS[self.kind][key])


def read_power_model(name: str, kind: str, reader: StatementReader) -> PowerDeviceModel:
    """The parameters of an ``IGBT`` or ``SCR`` ``.model`` (after its parenthesis)."""
    known = PARAMETERS[kind]
    params: dict[str, float] = {}
    thermal = None
    for key, text in reader.keyword_values():
        if key in params or (key == "thermal" and thermal is not None):
            raise reader.error(f".model {name}: parameter {key!r} is given twice")
        if key == "thermal" and kind == "igbt":
            from circuitnsds.frontend.cards.models import thermal_path

            thermal = thermal_path(reader, text)
            continue
        if key not in known:
            raise reader.error(f".model {name} {kind.upper()}: unknown parameter {key!r}",
                               hint=f"{kind.upper()} models take {', '.join(sorted(known))}"
                               + (" and thermal=" if kind == "igbt" else ""))
        params[key] = reader.number(key, text)
    missing = [key.upper() for key in REQUIRED[kind] if key not in params]
    if missing:
        raise reader.error(f".model {name} {kind.upper()}: {' and '.join(missing)} "
                           f"{'is' if len(missing) == 1 else 'are'} required",
                           hint=f"for example: .model {name} {EXAMPLES[kind]}")
    for key, value in params.items():
        if value < 0 and key != "vt" or (key == "roff" and value == 0):
            raise reader.error(f".model {name}: {key.upper()}={value:g} must be "
                               + ("positive" if key == "roff" else "non-negative"))
    if kind == "scr" and (params["igt"] <= 0 or params.get("ih", DEFAULT_HOLDING_CURRENT)
                          >= params["igt"]):
        raise reader.error(f".model {name}: the gate trigger current IGT must be positive and "
                           "above the holding current IH", hint="IH defaults to 1 nA (a current "
                           "that counts as zero); datasheets give IH of a few mA")
    return PowerDeviceModel(name, kind, params, thermal, reader.location)


def power_device(reader: StatementReader, models: dict[str, object],
                 off_resistance: float) -> list[Element]:
    """``Z name c g e MODEL`` (IGBT) or ``Z name a g k MODEL`` (SCR): the switch and its parts.

    ``off_resistance`` [Ω] is the circuit's default off-resistance (``1/gmin``).
    """
    name = reader.name
    nodes = reader.nodes(3)
    model_name = reader.next("model name")
    model = reader.model(models, model_name, "IGBT or SCR model",
                         f"add a line such as: .model {model_name} {EXAMPLES['igbt']}")
    if not isinstance(model, PowerDeviceModel):
        raise reader.error(f"{name}: model {model_name!r} is not an IGBT or SCR model: "
                           "circuitnsds reads Z lines as IGBTs and thyristors (ngspice's "
                           "MESFETs are not supported)",
                           hint=f"for example: .model {model_name} {EXAMPLES['igbt']}")
    if not reader.done():
        raise reader.error(f"{name}: unexpected {reader.peek()!r} after the model name",
                           hint="write Zname c g e MODEL (IGBT) or Zname a g k MODEL (SCR)")
    main, gate, return_node = nodes
    inner = f"{name}.inner"
    off = model.get("roff") or off_resistance
    location = reader.location
    conduction = DiodeModel(f"{model.name}.on", forward_drop=model.get("vcesat" if model.kind == "igbt"
                                                                         else "von"),
                            on_resistance=model.get("ron"), off_resistance=off,
                            origin="the on-state line V0 + r·i of the model", location=model.location)
    parts: list[Element] = [Diode(f"{name}.on", (inner, return_node), location, model=conduction)]
    if model.kind == "igbt":
        if model.get("vfd") is not None or model.get("rfd") is not None:
            free = DiodeModel(f"{model.name}.free", forward_drop=model.get("vfd") or 0.0,
                              on_resistance=model.get("rfd") or 0.0, off_resistance=off,
                              origin="the antiparallel diode of the model (VFD, RFD)",
                              location=model.location)
            parts.append(Diode(f"{name}.dfree", (return_node, main), location, model=free))
        switch_model = SwitchModel(model.name, threshold=model.get("vt"), hysteresis=model.get("vh"),
                                   on_resistance=0.0, off_resistance=off, location=model.location,
                                   thermal=model.thermal)
        device = Igbt(name, (main, inner, gate, return_node), location, model=switch_model,
                      parts=tuple(p.name for p in parts))
        return [device, *parts]
    junction = f"{name}.gk"
    gate_model = DiodeModel(f"{model.name}.gate", forward_drop=model.get("vgt"),
                            on_resistance=model.get("rg"), off_resistance=off,
                            origin="the gate junction of the model (VGT, RG)", location=model.location)
    parts.append(Diode(f"{name}.gk", (junction, return_node), location, model=gate_model))
    fire, hold = model.get("igt"), model.get("ih")
    switch_model = SwitchModel(model.name, current_controlled=True, threshold=(fire + hold) / 2,
                               hysteresis=(fire - hold) / 2, on_resistance=0.0, off_resistance=off,
                               location=model.location)
    device = Thyristor(name, (main, inner, gate, junction), location, model=switch_model,
                       parts=tuple(p.name for p in parts), cathode=return_node)
    return [device, *parts]
