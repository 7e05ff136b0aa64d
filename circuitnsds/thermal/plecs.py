"""Read a PLECS thermal description (the XML vendors publish: Infineon, Wolfspeed, ROHM, …).

What is read (anything else in the file is an error at its ``file:line``, never skipped
silently, except documentation: ``<Comment>``, ``<Variables>`` without formulas using them)::

    <SemiconductorLibrary xmlns="http://www.plexim.com/xml/semiconductors/" version="1.1">
      <Package class="IGBT" vendor="…" partnumber="…">
        <SemiconductorData type="IGBT">
          <TurnOnLoss>   ComputationMethod, [Formula], CurrentAxis, VoltageAxis,
                         TemperatureAxis, <Energy scale="…"> <Temperature> <Voltage>E(i)…
          <TurnOffLoss>  (the same; for a diode: its reverse-recovery energy)
          <ConductionLoss [gate="on"]>  ComputationMethod, [Formula], CurrentAxis,
                         TemperatureAxis, <VoltageDrop scale="…"> <Temperature>v(i)…
        </SemiconductorData>
        <ThermalModel> <Branch type="Foster"> <RTauElement R="…" Tau="…"/> …
                    or <Branch type="Cauer">  <RCElement R="…" C="…"/> … (junction first)
      </Package>
    </SemiconductorLibrary>

A bare ``<Package>`` root (older files) is read too. Energies are in J and voltages in V
after ``scale`` (vendors write mJ with ``scale="0.001"``); temperatures in °C.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

import numpy as np

from circuitnsds.thermal.networks import CauerNetwork, FosterNetwork
from circuitnsds.thermal.tables import METHODS, ConductionTable, EnergyTable, ThermalDataError

DOCUMENTATION_TAGS = {"Comment", "Variables", "Constants", "CustomTables", "Description"}
"""Elements that document a file or feed PLECS's formulas; read as nothing."""
MAX_BYTES = 16 * 2**20
"""A thermal description larger than this is refused (vendor files are a few 10 kB)."""


@dataclass
class Node:
    """One XML element: tag (namespace removed), attributes, children, text, 1-based line."""

    tag: str
    attributes: dict[str, str]
    line: int
    children: list[Node] = field(default_factory=list)
    text: str = ""

    def find(self, tag: str) -> Node | None:
        found = [child for child in self.children if child.tag == tag]
        return found[0] if found else None

    def all(self, tag: str) -> list[Node]:
        return [child for child in self.children if child.tag == tag]


@dataclass(frozen=True)
class DeviceData:
    """What a thermal description gives for one device.

    Attributes:
        path: the file.
        device_class: ``<Package class=>`` (``IGBT``, ``MOSFET``, ``Diode``, …).
        vendor, part: ``vendor=``, ``partnumber=``.
        turn_on, turn_off: switching energies (``None`` when not given; ``turn_off`` of a
            diode is its reverse recovery).
        conduction: the on-state voltage (``None``: the circuit's device model gives it).
        network: the junction-to-case network (``None`` when not given).
    """

    path: str
    device_class: str
    vendor: str = ""
    part: str = ""
    turn_on: EnergyTable | None = None
    turn_off: EnergyTable | None = None
    conduction: ConductionTable | None = None
    network: FosterNetwork | CauerNetwork | None = None

    @property
    def is_diode(self) -> bool:
        return self.device_class.lower() == "diode"


def _parse_tree(path: Path) -> Node:
    """The file's elements with their lines (expat; DTDs and entities refused)."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ThermalDataError(f"cannot read the thermal description: {exc.strerror}",
                               where=str(path), hint="thermal= names a PLECS XML file, relative "
                               "to the netlist") from None
    if len(data) > MAX_BYTES:
        raise ThermalDataError(f"the thermal description is {len(data)} bytes, more than "
                               f"{MAX_BYTES}", where=str(path))
    parser = expat.ParserCreate(namespace_separator="}")
    stack: list[Node] = []
    root: list[Node] = []

    def start(tag: str, attributes: dict[str, str]) -> None:
        node = Node(tag.rsplit("}", 1)[-1], attributes, parser.CurrentLineNumber)
        (stack[-1].children if stack else root).append(node)
        stack.append(node)

    def end(_tag: str) -> None:
        stack.pop()

    def text(chunk: str) -> None:
        if stack:
            stack[-1].text += chunk

    def refuse(*_args) -> None:
        raise ThermalDataError("a thermal description may not declare a DTD or entities",
                               where=f"{path}:{parser.CurrentLineNumber}")

    parser.StartElementHandler, parser.EndElementHandler = start, end
    parser.CharacterDataHandler = text
    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        raise ThermalDataError(f"not well-formed XML: {expat.errors.messages[exc.code]}",
                               where=f"{path}:{exc.lineno}") from None
    return root[0]


class _Reader:
    """Turns the tree into :class:`DeviceData`, with ``file:line`` errors."""

    def __init__(self, path: Path):
        self.path = path

    def error(self, node: Node, message: str, hint: str | None = None) -> ThermalDataError:
        return ThermalDataError(message, where=f"{self.path}:{node.line}", hint=hint)

    def numbers(self, node: Node | None, parent: Node, tag: str) -> np.ndarray:
        if node is None:
            raise self.error(parent, f"<{parent.tag}> has no <{tag}>")
        words = node.text.replace(",", " ").split()
        try:
            values = np.array([float(word) for word in words])
        except ValueError:
            bad = next(word for word in words if not _is_number(word))
            raise self.error(node, f"<{node.tag}>: {bad!r} is not a number") from None
        if values.size == 0 or not np.isfinite(values).all():
            raise self.error(node, f"<{node.tag}> holds no numbers, or one that is not finite")
        return values

    def axis(self, parent: Node, tag: str) -> np.ndarray:
        node = parent.find(tag)
        values = self.numbers(node, parent, tag)
        if np.any(np.diff(values) <= 0):
            raise self.error(node, f"<{tag}> must increase strictly: {node.text.strip()}")
        return values

    def scale(self, node: Node) -> float:
        text = node.attributes.get("scale", "1")
        if not _is_number(text) or not np.isfinite(float(text)):
            raise self.error(node, f"<{node.tag} scale={text!r}>: not a number")
        return float(text)

    def method(self, node: Node) -> tuple[str, str]:
        method_node = node.find("ComputationMethod")
        text = " ".join(method_node.text.split()).lower() if method_node is not None else "table only"
        if text not in METHODS:
            raise self.error(method_node, f"<ComputationMethod>{method_node.text.strip()}"
                             "</ComputationMethod> is not one PLECS documents",
                             hint="use 'Table only', 'Formula' or 'Table and formula'")
        method = METHODS[text]
        formula_node = node.find("Formula")
        formula = " ".join(formula_node.text.split()) if formula_node is not None else ""
        if method != "table" and not formula:
            raise self.error(node, f"<{node.tag}>: the method {text!r} needs a <Formula>")
        return method, formula

    def check_children(self, node: Node, allowed: set[str]) -> None:
        for child in node.children:
            if child.tag not in allowed:
                raise self.error(child, f"<{child.tag}> inside <{node.tag}> is not understood",
                                 hint=f"<{node.tag}> holds {', '.join(sorted(allowed))}")

    def energy(self, node: Node) -> EnergyTable:
        method, formula = self.method(node)
        where = f"{self.path}:{node.line}"
        if method == "formula" and node.find("Energy") is None:
            empty = np.zeros(1)
            return EnergyTable(empty, empty, empty, np.zeros((1, 1, 1)), method=method, formula=formula,
                               where=where)
        self.check_children(node, {"ComputationMethod", "Formula", "CurrentAxis", "VoltageAxis",
                                   "TemperatureAxis", "Energy"})
        current, voltage = self.axis(node, "CurrentAxis"), self.axis(node, "VoltageAxis")
        temperature = self.axis(node, "TemperatureAxis")
        energy_node = node.find("Energy")
        if energy_node is None:
            raise self.error(node, f"<{node.tag}> has no <Energy>")
        planes = energy_node.all("Temperature")
        if len(planes) != temperature.size:
            raise self.error(energy_node, f"<Energy> has {len(planes)} <Temperature> blocks for "
                             f"{temperature.size} temperatures")
        table = np.zeros((temperature.size, voltage.size, current.size))
        for t, plane in enumerate(planes):
            rows = plane.all("Voltage")
            if len(rows) != voltage.size:
                raise self.error(plane, f"<Temperature> has {len(rows)} <Voltage> rows for "
                                 f"{voltage.size} voltages")
            for v, row in enumerate(rows):
                values = self.numbers(row, plane, "Voltage")
                if values.size != current.size:
                    raise self.error(row, f"<Voltage> has {values.size} values for "
                                     f"{current.size} currents")
                table[t, v] = values
        return EnergyTable(current, voltage, temperature, table * self.scale(energy_node),
                           method=method, formula=formula, where=where)

    def conduction(self, node: Node) -> ConductionTable:
        method, formula = self.method(node)
        where = f"{self.path}:{node.line}"
        if method == "formula" and node.find("VoltageDrop") is None:
            return ConductionTable(np.zeros(1), np.zeros(1), np.zeros((1, 1)), method=method,
                                   formula=formula, where=where)
        self.check_children(node, {"ComputationMethod", "Formula", "CurrentAxis",
                                   "TemperatureAxis", "VoltageDrop"})
        current, temperature = self.axis(node, "CurrentAxis"), self.axis(node, "TemperatureAxis")
        drop_node = node.find("VoltageDrop")
        if drop_node is None:
            raise self.error(node, "<ConductionLoss> has no <VoltageDrop>")
        rows = drop_node.all("Temperature")
        if len(rows) != temperature.size:
            raise self.error(drop_node, f"<VoltageDrop> has {len(rows)} <Temperature> rows for "
                             f"{temperature.size} temperatures")
        table = np.zeros((temperature.size, current.size))
        for t, row in enumerate(rows):
            values = self.numbers(row, drop_node, "Temperature")
            if values.size != current.size:
                raise self.error(row, f"<Temperature> has {values.size} values for "
                                 f"{current.size} currents")
            table[t] = values
        return ConductionTable(current, temperature, table * self.scale(drop_node),
                               method=method, formula=formula, where=where)

    def network(self, node: Node) -> FosterNetwork | CauerNetwork:
        branches = node.all("Branch")
        self.check_children(node, {"Branch"})
        if len(branches) != 1:
            raise self.error(node, f"<ThermalModel> has {len(branches)} <Branch> elements; one "
                             "is read (junction to case)")
        branch = branches[0]
        kind = branch.attributes.get("type", "")
        tags = {"Foster": ("RTauElement", "Tau"), "Cauer": ("RCElement", "C")}
        if kind not in tags:
            raise self.error(branch, f"<Branch type={kind!r}>: the type is Foster or Cauer")
        tag, second = tags[kind]
        self.check_children(branch, {tag})
        stages = branch.all(tag)
        if not stages:
            raise self.error(branch, f"a {kind} <Branch> without <{tag}> stages")
        values = []
        for stage in stages:
            pair = []
            for key in ("R", second):
                text = stage.attributes.get(key)
                if text is None or not _is_number(text) or not 0 < float(text) < np.inf:
                    raise self.error(stage, f"<{tag}> {key}={text!r}: a positive number is "
                                     f"needed", hint=f"write <{tag} R=\"0.1\" {second}=\"…\"/>")
                pair.append(float(text))
            values.append(pair)
        first, other = (tuple(column) for column in zip(*values))
        return FosterNetwork(first, other) if kind == "Foster" else CauerNetwork(first, other)

    def device(self, root: Node) -> DeviceData:
        package = root if root.tag == "Package" else None
        if root.tag == "SemiconductorLibrary":
            packages = root.all("Package")
            if len(packages) != 1:
                raise self.error(root, f"<SemiconductorLibrary> holds {len(packages)} <Package> "
                                 "elements; a device's file has one")
            package = packages[0]
        if package is None:
            raise self.error(root, f"<{root.tag}> is not a PLECS thermal description",
                             hint="the root is <SemiconductorLibrary> or <Package>")
        self.check_children(package, {"SemiconductorData", "ThermalModel"} | DOCUMENTATION_TAGS)
        data = package.all("SemiconductorData")
        if len(data) != 1:
            raise self.error(package, f"<Package> holds {len(data)} <SemiconductorData>; one is read")
        semiconductor = data[0]
        self.check_children(semiconductor, {"TurnOnLoss", "TurnOffLoss", "ConductionLoss"})
        device_class = package.attributes.get("class", semiconductor.attributes.get("type", ""))
        turn_on, turn_off = semiconductor.find("TurnOnLoss"), semiconductor.find("TurnOffLoss")
        conduction = [node for node in semiconductor.all("ConductionLoss")
                      if node.attributes.get("gate", "on").lower() == "on"]
        thermal = package.find("ThermalModel")
        return DeviceData(
            str(self.path), device_class, package.attributes.get("vendor", ""),
            package.attributes.get("partnumber", ""),
            None if turn_on is None else self.energy(turn_on),
            None if turn_off is None else self.energy(turn_off),
            self.conduction(conduction[0]) if conduction else None,
            None if thermal is None else self.network(thermal))


NUMBER = re.compile(r"\s*[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\s*")
"""A number as the XML writes it (no SPICE suffixes: ``1k`` is not one)."""


def _is_number(text: str) -> bool:
    return NUMBER.fullmatch(text) is not None


def read_thermal_description(path: str | Path) -> DeviceData:
    """The loss tables and thermal network of a PLECS thermal description file.

    Raises:
        ThermalDataError: unreadable file, malformed XML, or content outside what the module
            docstring lists (at ``file:line``).
    """
    path = Path(path)
    return _Reader(path).device(_parse_tree(path))
