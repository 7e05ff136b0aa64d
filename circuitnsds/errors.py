"""Exceptions raised for bad input and failed simulations.

Every error a user can provoke derives from :class:`CircuitnsdsError`. Its
message says *what* went wrong, *where* (``file:line`` for netlist problems, an
element name for circuit problems, a time for simulation problems) and *what to
do*. The command line prints the message and exits with status 1; it never
prints a traceback for these.
"""

from __future__ import annotations

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
        return text


class NetlistError(CircuitnsdsError):
    """The netlist text cannot be read or uses something circuitnsds does not support."""


class CircuitError(CircuitnsdsError):
    """The circuit is read but ill-posed: floating nodes, source loops, missing models."""


class SimulationError(CircuitnsdsError):
    """A time step (or the operating point) has no solution or the solver failed."""


class NetlistWarning(UserWarning):
    """Something in the netlist is accepted but not used (it is reported, never silent)."""
