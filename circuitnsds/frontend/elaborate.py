"""Netlist statements -> :class:`~circuitnsds.circuit.circuit.Circuit` (elements, models, analysis).

This is where each statement gets its meaning (the readers of each kind of
line live in :mod:`circuitnsds.frontend.cards`). Anything the engine does not support is
an error naming ``file:line`` (when it changes the circuit) or a warning (when
it only concerns other analyses or output): never silence.

The netlist is expected flat (subcircuits expanded, parameters substituted);
element names may be hierarchical (``x1.d3`` is a diode).
"""

from __future__ import annotations

import re

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import Element, MutualInductance
from circuitnsds.circuit.elements.diode import DEFAULT_OFF_RESISTANCE
from circuitnsds.element_letters import ELEMENT_LETTERS, SUPPORTED_LETTERS, element_letter
from circuitnsds.errors import NetlistError, SourceLocation
from circuitnsds.frontend.cards import commands, devices, parasitics
from circuitnsds.frontend.cards.by_letter import CardContext, reader_for
from circuitnsds.frontend.cards.model_kinds import DIGITAL_PARTS
from circuitnsds.frontend.cards.models import DiodeReading, read_model
from circuitnsds.frontend.cards.reader import StatementReader, warn_at
from circuitnsds.frontend.dc_paths import add_gmin_paths
from circuitnsds.graphs import connected_components
from circuitnsds.lazy import is_loaded_instance
from circuitnsds.netlist import Netlist, Statement


def elaborate(netlist: Netlist, options: dict[str, float | str] | None = None) -> Circuit:
    """Build the :class:`Circuit` described by a flat ``netlist``.

    Order: ``.options`` first (``gmin`` sets model defaults; ``options`` override them), then every
    ``.model`` (a model may follow the elements using it), then elements and
    commands in netlist order, and couplings (``K``) last.

    Raises:
        NetlistError: for malformed or unsupported statements (with file:line).
    """
    circuit = Circuit(title=netlist.title, file=netlist.file, included=list(netlist.included))
    for block in netlist.control_blocks:
        if block.commands:
            skipped = ", ".join(f"{word} (line {line})" for word, line in zip(block.commands, block.lines))
            taken = (f"; its {', '.join(dict.fromkeys(block.taken))} read as dot commands"
                     if block.taken else "")
            warn_at(block.location, f".control script: {skipped} not executed (circuitnsds runs "
                    f"the analyses, .meas and .save of a script, no other command){taken}")
    statements = netlist.statements
    for statement in statements:
        if statement.keyword in commands.OPTION_KEYWORDS:
            circuit.options.update(commands.read_options(StatementReader(statement)))
    circuit.options.update(options or {})
    off_resistance = 1.0 / circuit.options.get("gmin", 1.0 / DEFAULT_OFF_RESISTANCE)
    diodes = DiodeReading(ideal=circuit.options.get("diode") == "ideal",
                          limit=circuit.options.get("diode") == "limit",
                          fit_current=None if circuit.options.get("pwlfit") == "auto"
                          else circuit.options.get("pwlfit"))
    element_tokens = {token for s in statements if not s.is_command for token in s.tokens[1:]}
    model_texts: dict[str, tuple[str, ...]] = {}
    for statement in statements:
        if statement.keyword == ".model":
            reader = StatementReader(statement)
            try:
                name, model = read_model(reader, off_resistance, diodes)
            except NetlistError as error:
                used = len(statement.tokens) < 2 or statement.tokens[1] in element_tokens
                if used or statement.location.file == netlist.file:
                    raise
                warn_at(statement.location, f"unused .model {statement.tokens[1]} of an included "
                        f"library left out ({error.message}); ngspice reads a model only when an "
                        "element uses it")
                continue
            if name in circuit.models:
                if model_texts[name] == statement.tokens[2:]:  # the same text: no ambiguity
                    warn_at(statement.location, f".model {name} is defined again with the same "
                            f"parameters (first at {circuit.model_locations[name]}): the first is used")
                    continue
                raise reader.error(f".model {name} is defined twice, with different parameters",
                                   hint=f"the first is at {circuit.model_locations[name]}")
            model_texts[name] = statement.tokens[2:]
            circuit.models[name] = model
            circuit.model_locations[name] = statement.location
    voltage_sources = {s.keyword for s in statements
                       if not s.is_command and element_letter(s.keyword) == "v"}
    couplings: list[Statement] = []
    context = CardContext(circuit.models, voltage_sources, circuit.options, off_resistance)
    script_lines = {(block.location.file, line) for block in netlist.control_blocks
                    for line in block.taken_lines}
    for statement in statements:
        if statement.keyword == ".model" or statement.keyword in commands.OPTION_KEYWORDS:
            continue
        if statement.is_command and statement.keyword in {".meas", ".measure"} and (
                (statement.location.file, statement.location.line) in script_lines):
            _script_measurement(circuit, statement)
        elif statement.is_command:
            commands.command(circuit, statement)
        elif element_letter(statement.keyword) == "k":
            couplings.append(statement)
        else:
            made = _element(statement, context)
            for element in made if isinstance(made, list) else [made]:  # A, M lines: several
                circuit.add(element, statement.location)
    _couple(circuit, couplings)
    _check_unused_models(circuit)
    if any(getattr(model, "kind", None) in DIGITAL_PARTS for model in circuit.models.values()):
        # (digital parts are the elements of such models: without one there is nothing to check)
        from circuitnsds.frontend.cards import xspice_digital

        xspice_digital.check_digital_nodes(circuit.elements, circuit.models)
    _check_initial_conditions(circuit)
    add_gmin_paths(circuit)
    if not netlist.ended:
        last = netlist.statements[-1].location.line if netlist.statements else 1
        warn_at(SourceLocation(netlist.file, last),
                "the netlist has no .end line; read to the end of the file")
    title_word = netlist.title.split(None, 1)[0].lower() if netlist.title.strip() else ""
    if title_word in TITLE_LIKE_COMMANDS:
        warn_at(SourceLocation(netlist.file, 1), "the first line is the title and is not read, as in "
                f"SPICE: {netlist.title!r}; put a title line above it")
    return circuit


def _script_measurement(circuit: Circuit, statement: Statement) -> None:
    """A ``meas`` of a ``.control`` script, read as ``.meas``; one that names the script's own
    vectors (``VAL=onevec-0.5`` after ``let onevec = 1``), which circuitnsds does not execute,
    is left out with a warning instead of stopping the run."""
    before = len(circuit.measurements)
    try:
        commands.command(circuit, statement)
    except NetlistError as error:
        warn_at(statement.location, f"the .control script's meas is not run: {error.message} (a "
                "script's let vectors are not executed); write it as a .meas line of numbers and "
                "signals to run it")
        return
    measured = {spec.name for spec in circuit.measurements[:before]}
    for spec in circuit.measurements[before:]:
        levels = [getattr(c, "level", None) for c in (spec.when, spec.trig, spec.targ) if c]
        vectors = [level for level in levels if isinstance(level, str)
                   and re.fullmatch(r"[a-z_]\w*", level) and level not in measured]
        if vectors:
            del circuit.measurements[before:]
            warn_at(statement.location, f"the .control script's meas is not run: it compares with "
                    f"{', '.join(repr(v) for v in vectors)}, a vector of the script (its let "
                    "commands are not executed); write the level as a number or a signal to run it")
            return


TITLE_LIKE_COMMANDS = frozenset({
    ".tran", ".include", ".inc", ".lib", ".model", ".param", ".subckt", ".options", ".option",
    ".ic", ".save", ".meas", ".measure", ".four", ".pss", ".ac", ".step", ".func", ".global"})
"""Commands that, on the first line, are the netlist's title and not read (a warning says so);
``.title`` and any other first line are titles without a word."""


def _element(statement: Statement, context: CardContext) -> Element | list[Element]:
    """The element(s) of one element line, by the card reader of its letter
    (:data:`~circuitnsds.frontend.cards.by_letter.CARD_READERS`)."""
    letter = element_letter(statement.keyword)
    reader = StatementReader(statement)
    if len(letter) != 1:  # a name such as "fig." ends with the hierarchy separator
        raise reader.error(f"{statement.keyword}: not an element name",
                           hint=f"element names start with their type letter: {SUPPORTED_LETTERS}")
    if parasitics.has_parasitics(statement, letter):
        made = [_element(part, context) for part in parasitics.split_parasitics(statement, letter)]
        return [element for part in made for element in (part if isinstance(part, list) else [part])]
    if letter in "rclvi" and statement.tokens[3:4] and statement.tokens[3].startswith("{"):
        from circuitnsds.frontend.cards.time_values import time_valued_element  # only then

        return time_valued_element(reader, letter)
    card = reader_for(letter, statement.tokens)
    if card is not None:
        return card.read(reader, letter, context)
    if letter == "x":
        raise reader.error(f"{statement.keyword}: subcircuit instance reached the elaborator "
                           "unexpanded", hint="read netlists with circuitnsds.read_netlist")
    if letter in ELEMENT_LETTERS:
        raise reader.error(
            f"{statement.keyword}: {ELEMENT_LETTERS[letter].what} ('{letter.upper()}' lines) "
            "are not supported by the ideal engine",
            hint=f"circuitnsds reads {SUPPORTED_LETTERS}; model a transistor used as a switch "
            "with an S switch driven by its gate signal, or a MOSFET (M line)",
        )
    raise reader.error(f"{statement.keyword}: unknown element type '{letter.upper()}'",
                       hint=f"element names start with their type letter: {SUPPORTED_LETTERS}")


def _couple(circuit: Circuit, statements: list[Statement]) -> None:
    """Add the ``K`` couplings, then check that each coupled group's inductance matrix
    is positive semidefinite (else the magnetic energy could be negative). A zero
    eigenvalue is perfect coupling (``|k| = 1``, an ideal transformer with its magnetising
    inductance), which ngspice accepts too."""
    inductors = {e.name: e for e in circuit.elements if e.topology == "inductor"}
    couplings: list[MutualInductance] = []
    for statement in statements:
        for coupling in devices.mutual_inductance(StatementReader(statement), inductors):
            for other in couplings:
                if set(other.inductors) == set(coupling.inductors):
                    raise NetlistError(f"{coupling.name}: {' and '.join(coupling.inductors)} are "
                                       f"already coupled by {other.name}", where=statement.location)
            couplings.append(coupling)
            circuit.add(coupling, statement.location)
    if not couplings:
        return
    import numpy as np

    for group in connected_components((), (c.inductors for c in couplings)):
        members = [inductors[name] for name in sorted(group)]
        related = [c for c in couplings if c.inductors[0] in group]
        matrix = devices.inductance_matrix(members, related)
        smallest = float(np.linalg.eigvalsh(matrix / np.max(np.abs(matrix))).min())
        if smallest < -1e-12:
            where = related[-1].location
            raise NetlistError(
                f"the inductance matrix of {', '.join(sorted(group))} (coupled by "
                f"{', '.join(c.name for c in related)}) is not positive semidefinite",
                where=where,
                hint="the couplings contradict each other (e.g. k12 = k23 = 1 with k13 = -1): the "
                "magnetic energy would be negative for some currents; check their values and signs",
            )


def _check_unused_models(circuit: Circuit) -> None:
    used = {element.model_name for element in circuit.elements}
    for name, model in circuit.models.items():
        if name not in used:
            kind = model if isinstance(model, str) else model.kind if is_loaded_instance(
                model, "circuitnsds.frontend.cards.xspice", "XspiceModel"
            ) or is_loaded_instance(model, "circuitnsds.circuit.elements.smooth.bjt", "BjtModel"
            ) or is_loaded_instance(model, "circuitnsds.circuit.elements.smooth.jfet", "JfetModel"
            ) else type(model).__name__.removesuffix("Model")
            warn_at(circuit.model_locations[name], f".model {name} ({kind.upper()}) is not used")


def _check_initial_conditions(circuit: Circuit) -> None:
    for node, (_, location) in circuit.initial_voltages.items():
        if node != "0" and node not in circuit.nodes:
            raise NetlistError(f".ic names node {node!r}, which no element connects",
                               where=location, hint=f"nodes are: {', '.join(circuit.nodes)}")

