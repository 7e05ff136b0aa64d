"""From parameters to a :class:`~circuitnsds.circuit.circuit.Circuit`, without re-reading.

A :class:`CircuitBuilder` reads a netlist once (parse, includes) and keeps its statements;
:meth:`CircuitBuilder.build` then evaluates the parameters (with overrides and a random
generator), flattens the subcircuits and elaborates: what one point of a sweep costs.

:class:`NetlistSource` is what a sweep ships to a worker: the netlist text with its
includes resolved (one statement per line) and where each line was written, so that a
worker needs no file and its messages still name the original file:line.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.errors import NetlistWarning, SourceLocation, strict_warnings
from circuitnsds.frontend.cards.reader import warn_at
from circuitnsds.frontend.elaborate import elaborate
from circuitnsds.netlist.expressions import Random
from circuitnsds.netlist.includes import expand_includes
from circuitnsds.netlist.node_spellings import warn_node_spellings
from circuitnsds.netlist.parser import (
    ControlBlock,
    Netlist,
    Statement,
    parse_netlist,
    read_netlist_file,
)
from circuitnsds.netlist.steps import DEFAULT_SEED, LazyGenerator, Step, options_seed, split_steps
from circuitnsds.netlist.subcircuits import flatten


@dataclass(frozen=True)
class NetlistSource:
    """A netlist as text with its includes resolved, plus where each statement came from.

    Attributes:
        text: title line, then one statement per line (continuations joined), ``.end``.
        file: the netlist's name, for messages.
        locations: ``(file, line)`` of each statement, in order.
        control_blocks: ``(file, line, commands, lines, taken)`` of each ngspice ``.control``
            script (see :class:`~circuitnsds.netlist.parser.ControlBlock`).
    """

    text: str
    file: str
    locations: tuple[tuple[str, int], ...]
    control_blocks: tuple[tuple[str, int, tuple[str, ...], tuple[int, ...], tuple[str, ...]], ...] = ()


class CircuitBuilder:
    """Builds circuits from one netlist for any parameter values.

    Args:
        netlist: the parsed netlist with its includes expanded (``.step`` lines included).

    Attributes:
        steps: the ``.step`` sweeps of the netlist, in order.
        seed: ``.options seed``, or ``None``.
    """

    def __init__(self, netlist: Netlist):
        self.netlist, self.steps = split_steps(netlist)
        warn_node_spellings(self.netlist.statements)
        self.seed = options_seed(self.netlist.statements)
        self._names = _written_names(self.netlist)

    @classmethod
    def load(cls, source: str | Path, directory: str | Path | None = None) -> CircuitBuilder:
        """Read a netlist file (a path) or netlist text (a string with a newline).

        Args:
            directory: where relative include paths start for text (default: current directory).

        Raises:
            NetlistError: malformed content or a missing include (with file:line).
        """
        if isinstance(source, Path) or "\n" not in source:
            netlist = read_netlist_file(source)
            return cls(expand_includes(netlist, None))
        return cls(expand_includes(parse_netlist(source), directory if directory is not None else Path.cwd()))

    @classmethod
    def from_source(cls, source: NetlistSource) -> CircuitBuilder:
        """The builder of a shipped :class:`NetlistSource` (no file is read)."""
        parsed = parse_netlist(source.text, file=source.file)
        if len(parsed.statements) != len(source.locations):
            raise ValueError("the netlist source's text and locations do not match")
        statements = [Statement(s.tokens, SourceLocation(*where), s.text)
                      for s, where in zip(parsed.statements, source.locations)]
        blocks = [ControlBlock(SourceLocation(file, line), list(commands), list(lines), list(taken))
                  for file, line, commands, lines, taken in source.control_blocks]
        return cls(Netlist(parsed.title, statements, source.file, parsed.ended, blocks))

    def source(self) -> NetlistSource:
        """This netlist (``.step`` lines included) as a :class:`NetlistSource`."""
        lines = [self.netlist.title]
        locations = []
        for statement in _with_steps(self):
            lines.append(statement.text)
            locations.append((statement.location.file, statement.location.line))
        if self.netlist.ended:
            lines.append(".end")
        blocks = tuple((b.location.file, b.location.line, tuple(b.commands), tuple(b.lines),
                        tuple(b.taken)) for b in self.netlist.control_blocks)
        return NetlistSource("\n".join(lines) + "\n", self.netlist.file, tuple(locations), blocks)

    @property
    def default_seed(self) -> int:
        """``.options seed``, else :data:`~circuitnsds.netlist.steps.DEFAULT_SEED`."""
        return self.seed if self.seed is not None else DEFAULT_SEED

    def unknown(self, params: Mapping[str, float]) -> list[str]:
        """The names in ``params`` that the netlist neither defines nor uses (typos); stepped
        parameters and ``run`` (a Monte Carlo run count) are never reported."""
        stepped = {step.name.lower() for step in self.steps} | {"run"}
        return [name for name in params if name.lower() not in self._names | stepped]

    def build(self, params: Mapping[str, float] | None = None, random: Random | None = None, *,
              strict: bool = False, options: dict[str, float | str] | None = None) -> Circuit:
        """The circuit for these parameter values.

        Args:
            params: values replacing ``.param`` definitions (see
                :func:`~circuitnsds.netlist.subcircuits.flatten`); names are case-insensitive.
                Stepped parameters not given take their first ``.step`` value, with a warning.
            random: generator of the Monte Carlo functions; default: point 0 of the
                netlist's seed (:func:`~circuitnsds.netlist.steps.point_generator`).
            strict: every warning is an error.
            options: ``.options`` values that override the netlist's (``{"diode": "ideal"}``).

        Raises:
            NetlistError: malformed input (with file:line).
        """
        given = {name.lower(): float(value) for name, value in (params or {}).items()}
        with strict_warnings() if strict else nullcontext():
            for name in self.unknown(given):
                warnings.warn(f"parameter {name!r} is given, and the netlist neither defines nor "
                              "uses it (check its spelling)", NetlistWarning, stacklevel=2)
            missing = [s for s in self.steps if s.name.lower() not in given]
            if missing:
                first = ", ".join(f"{s.name}={s.values[0]:g}" for s in missing)
                warn_at(missing[0].location, f"one circuit from a netlist with .step lines: {first} "
                        "(the first values; run the sweep with circuitnsds.sweep or `circuitnsds "
                        "run`, or give the parameters' values)")
                given.update({s.name.lower(): s.values[0] for s in missing})
            if random is None:
                random = LazyGenerator(self.default_seed, 0)  # numpy.random only if drawn from
            circuit = elaborate(flatten(self.netlist, given, random), options)
        circuit.strict = strict
        return circuit


def _with_steps(builder: CircuitBuilder) -> list[Statement]:
    """The statements with the ``.step`` lines put back where their locations say (a
    ``.step`` is a top-level command: its place among the others does not matter)."""
    return list(builder.netlist.statements) + [_step_statement(step) for step in builder.steps]


def _step_statement(step: Step) -> Statement:
    values = " ".join(repr(v) for v in step.values)
    text = f".step param {step.name} list {values}"
    location = step.location if step.location is not None else SourceLocation("<sweep>", 0)
    return Statement(tuple(text.lower().split()), location, text)


def _written_names(netlist: Netlist) -> set[str]:
    """The names that parameter values can reach (lower case): every word of ``.param`` and
    ``.func`` lines, of the parameter part of ``.subckt`` and ``X`` lines, and inside
    ``{...}``/``'...'`` expressions. A parameter given but absent from them has no effect."""
    import re

    from circuitnsds.netlist.expressions import strip_delimiters
    from circuitnsds.netlist.params import split_parameters

    def words(text: str) -> set[str]:
        return set(re.findall(r"[a-z_][a-z0-9_]*", text.lower()))

    names: set[str] = set()
    for statement in netlist.statements:
        keyword = statement.keyword
        if keyword in (".param", ".func"):
            names |= words(statement.text)
            continue
        if keyword == ".subckt" or keyword.rsplit(".", 1)[-1].startswith("x"):
            names |= words(split_parameters(statement.text)[1])
        for token in statement.tokens:
            inner = strip_delimiters(token)
            if inner is not None:
                names |= words(inner)
    return names
