"""Exceptions raised for bad input and failed simulations.

Every error a user can provoke derives from :class:`CircuitnsdsError`. Its
message says *what* went wrong, *where* (``file:line`` for netlist problems, an
element name for circuit problems, a time for simulation problems) and *what to
do*. The command line prints the message and exits with status 1; it never
prints a traceback for these.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass


@dataclass(frozen=True)
class SourceLocation:
    """A place in a netlist: file name (or ``<text>``) and 1-based line number."""

    file: str
    line: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}"


class CircuitnsdsError(Exception):
    """Base class of every user-facing error.

    Args:
        message: what went wrong.
        where: the netlist location, element name or time it concerns.
        hint: what the user can do about it.
    """

    def __init__(self, message: str, *, where: object | None = None, hint: str | None = None):
        self.message = message
        self.where = where
        self.hint = hint
        super().__init__(self.__str__())

    def __str__(self) -> str:
        text = f"{self.where}: {self.message}" if self.where is not None else self.message
        if self.hint:
            text += f"\n  hint: {self.hint}"
        return _clip_lines(text)


TEXT_SHOWN = 100
"""Longest excerpt of the offending netlist text shown in a message (characters)."""


class NetlistError(CircuitnsdsError):
    """The netlist text cannot be read or uses something circuitnsds does not support.

    Args:
        message, where, hint: as for :class:`CircuitnsdsError`; ``where`` is usually a
            :class:`SourceLocation` (file and line).
        column: 1-based column of the offending text in the statement, when known.
        text: the offending statement (or token) as written, when known; shown as a
            second line ``in: ...`` unless the hint already quotes it.

    The first line of the message stays ``file:line: message``.
    """

    def __init__(self, message: str, *, where: object | None = None, hint: str | None = None,
                 column: int | None = None, text: str | None = None):
        self.column = column
        self.text = text
        super().__init__(message, where=where, hint=hint)

    @property
    def file(self) -> str | None:
        """The netlist file (``<text>`` for a string), or ``None`` when unknown."""
        if isinstance(self.where, SourceLocation):
            return self.where.file
        return str(self.where) if self.where is not None else None

    @property
    def line(self) -> int | None:
        """1-based line of the statement, or ``None`` when the error concerns a whole file."""
        return self.where.line if isinstance(self.where, SourceLocation) else None

    def __str__(self) -> str:
        text = f"{self.where}: {self.message}" if self.where is not None else self.message
        excerpt = _excerpt(self.text, self.column) if self.text else None
        said = self.message + (self.hint or "")
        quoted = excerpt is not None and (excerpt in said or self.text.strip() in said)
        if self.hint:
            text += f"\n  hint: {self.hint}"
            if excerpt and not quoted:
                text += f"; in: {excerpt}"
        elif excerpt and not quoted:
            text += f"\n  in: {excerpt}"
        return _clip_lines(text)


LINE_SHOWN = 400
"""Longest line of an error message (characters); longer ones (a netlist line of a megabyte
quoted whole) are cut in the middle."""


def for_terminal(text: str) -> str:
    """``text`` (an error or warning message) escaped and clipped as every error message is."""
    return _clip_lines(text)


def _clip_lines(text: str) -> str:
    """``text`` made safe and short for a terminal: control characters (a netlist's escape
    sequences) written as escapes, and every line longer than :data:`LINE_SHOWN` shortened by
    :func:`_clip_line`."""
    return "\n".join(_clip_line(_printable(line)) for line in text.split("\n"))


def _printable(line: str) -> str:
    """``line`` with every non-printable character (ESC, CR, ...) as its Python escape."""
    if line.isprintable():
        return line
    return "".join(c if c.isprintable() or c == "\t" else repr(c)[1:-1] for c in line)


def _clip_line(line: str) -> str:
    """``line`` cut to about :data:`LINE_SHOWN` characters, clause by clause.

    The clauses (separated by ``"; "``) keep their order, their beginning and their end;
    the longest ones (a quoted netlist line, a list of thousands of devices) are cut in
    the middle first, so that a short clause that says what to do is never dropped.
    """
    if len(line) <= LINE_SHOWN:
        return line
    parts = line.split("; ")
    budget = LINE_SHOWN - 2 * (len(parts) - 1)
    lengths = sorted(len(part) for part in parts)
    cap, used = lengths[-1], 0
    for k, length in enumerate(lengths):  # the largest cap with sum(min(len, cap)) <= budget
        rest = len(lengths) - k
        if used + length * rest > budget:
            cap = max((budget - used) // rest, 60)
            break
        used += length
    clipped = []
    for part in parts:
        if len(part) > cap:
            head = max(cap - 50, 20)
            tail = 20
            part = f"{part[:head]} ...[{len(part) - head - tail} characters]... {part[-tail:]}"
        clipped.append(part)
    return "; ".join(clipped)


def _excerpt(text: str, column: int | None) -> str:
    """``text`` on one line, cut to :data:`TEXT_SHOWN` characters around ``column``."""
    flat = " ".join(text.split())
    if len(flat) <= TEXT_SHOWN:
        return flat
    start = 0 if column is None else max(0, min(column - 1 - TEXT_SHOWN // 2, len(flat) - TEXT_SHOWN))
    cut = flat[start:start + TEXT_SHOWN]
    return ("..." if start > 0 else "") + cut + ("..." if start + TEXT_SHOWN < len(flat) else "")


class CircuitError(CircuitnsdsError):
    """The circuit is read but ill-posed: floating nodes, source loops, missing models."""


class SimulationError(CircuitnsdsError):
    """A time step (or the operating point) has no solution, the solver failed, or a value
    became NaN or infinite.

    Args (each also an attribute of the same name):
        message, where, hint: as for :class:`CircuitnsdsError`.
        time: the instant [s] at which the run stopped (end of the failing step).
        devices: the devices in the active set guessed for the failing step (the
            conducting diodes), or the devices concerned.
        residual: the best scaled complementarity residual the solver reached.
        unknowns: names of the MNA unknowns concerned (``v(node)``, ``i(branch)``), e.g.
            the rows a non-finite source drives; the analysis words them for the reader.
        step_interval: ``(t0, t1)`` [s] of a step whose complementarity problem has no
            (verified) solution, else ``None``.
        switch_states: the switch states (closed = true, one per ``MLCS.switches``) of
            that step, else ``None``.
        trajectory: the engine's :class:`~circuitnsds.engine.integrate.Trajectory` up to
            the last good grid point, when the failure happened while integrating.
        partial: the :class:`~circuitnsds.Waveforms` made of ``trajectory`` (set by the
            transient analysis), else ``None``.
        cause: what kind of failure the engine met, one of the ``STEP_*``/``STATE_*``/
            ``SOURCE_*`` names below (``None``: not said); the analysis words its advice
            from it, the engine knowing no circuit.
    """

    STEP_NOT_FINITE = "step not finite"
    """A step's matrix ``E/h - ΘA`` holds inf (capacitance/h or inductance/h overflows)."""
    STEP_UNSOLVED = "step unsolved"
    """A step's complementarity problem has no (verified) solution (see ``step_interval``)."""
    STATE_NOT_FINITE = "state not finite"
    """The state overflowed or became NaN while integrating."""
    SOURCE_NOT_FINITE = "source not finite"
    """A source function's value is NaN or infinite (the sources concerned: ``unknowns``)."""
    STEP_MAP_SINGULAR = "step map singular"
    SWITCH_CHATTERS = "switch chatters"
    """One switch's state moves its own control back across its threshold (``devices``: it)."""
    """The mode a step took has a singular step matrix, so the step has no affine map."""

    def __init__(self, message: str, *, where: object | None = None, hint: str | None = None,
                 time: float | None = None, devices: tuple[str, ...] = (),
                 residual: float | None = None, unknowns: tuple[str, ...] = (),
                 step_interval: tuple[float, float] | None = None, switch_states=None,
                 trajectory=None, partial=None, cause: str | None = None):
        self.time = time
        self.devices = tuple(devices)
        self.residual = residual
        self.unknowns = tuple(unknowns)
        self.step_interval = step_interval
        self.switch_states = switch_states
        self.trajectory = trajectory
        self.partial = partial
        self.cause = cause
        super().__init__(message, where=where, hint=hint)


class NetlistWarning(UserWarning):
    """Something in the netlist is accepted but not used (it is reported, never silent)."""


class RunNote(UserWarning):
    """Something the run chose for the user (a refined integration step): reported, and not
    an error under ``--strict``."""


class CircuitWarning(NetlistWarning):
    """The circuit is legal but probably not what was meant: a dangling node, a loop of
    voltage sources and capacitors with inconsistent initial conditions, a switch that
    shorts a voltage source when it closes. ``--strict`` makes these errors."""


STRICT_HINT = "this is a warning, made an error by strict mode (--strict); fix it or drop --strict"


@contextmanager
def strict_warnings() -> Iterator[None]:
    """Inside the block every :class:`NetlistWarning` (and :class:`CircuitWarning`) is raised
    as a :class:`NetlistError` (or :class:`CircuitError`) carrying the warning's text.

    Example::

        with strict_warnings():
            circuit = circuitnsds.read_netlist("in.cir")
            circuit.transient()
    """
    with warnings.catch_warnings():
        warnings.simplefilter("error", NetlistWarning)
        try:
            yield
        except NetlistWarning as warning:
            raise as_error(warning) from None


def as_error(warning: Warning) -> CircuitnsdsError:
    """The error that a (netlist or circuit) warning becomes in strict mode."""
    cls = CircuitError if isinstance(warning, CircuitWarning) else NetlistError
    return cls(str(warning), hint=STRICT_HINT)
