"""A device's terminals (external and internal nodes) onto the unknowns of the MLCS.

A device's equations are written over its own list of terminals (a BJT's ``c, b, e, s`` and
its internal ``c', b', e'``), some of which are the same unknown (``b' = b`` without base
resistance) or ground. The relation the engine sees reads each distinct non-ground unknown
once and writes each once (ground reads 0 V and its row is dropped, so it is left out), so
that its Jacobian has no repeated columns: :class:`TerminalMap` does the bookkeeping.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class TerminalMap:
    """Terminal ``k`` of a device is the unknown ``unknowns[k]`` of ``y`` (``-1``: ground).

    Attributes:
        unknowns: per terminal, its index in ``y`` or ``-1``.
    """

    unknowns: tuple[int, ...]

    @property
    def inputs(self) -> tuple[int, ...]:
        """The distinct non-ground unknowns, in terminal order: the relation's ``inputs``
        and ``rows``."""
        return tuple(dict.fromkeys(k for k in self.unknowns if k >= 0))

    @property
    def scatter(self) -> np.ndarray:
        """``P`` with ``P[k, j] = 1`` when terminal ``k`` is input ``j``: terminal voltages
        are ``P x``, the rows' values ``Pᵀ f``, the Jacobian ``Pᵀ J P``."""
        position = {unknown: j for j, unknown in enumerate(self.inputs)}
        matrix = np.zeros((len(self.unknowns), len(position)))
        for k, unknown in enumerate(self.unknowns):
            if unknown >= 0:
                matrix[k, position[unknown]] = 1.0
        return matrix


def scattered_evaluator(terminal_values: Callable, device, terminals: TerminalMap) -> Callable:
    """``evaluate(x, t)`` of a device's :class:`~circuitnsds.system.smooth.SmoothRelation`
    over ``terminals.inputs``: ``terminal_values(device, v)`` gives ``(f, ∂f/∂v, q, ∂q/∂v)`` at
    the device's own terminal voltages ``v = scatter @ x`` [V], and they are gathered back onto
    the relation's inputs (a terminal on ground, or two on one node, summed)."""
    scatter = terminals.scatter

    def evaluate(x: np.ndarray, t: float = 0.0):
        f, jacobian, q, q_jacobian = terminal_values(device, scatter @ np.asarray(x, dtype=float))
        return (scatter.T @ f, scatter.T @ jacobian @ scatter, scatter.T @ q,
                scatter.T @ q_jacobian @ scatter)

    return evaluate


def difference_gradient(size: int, plus: int, minus: int, sign: float) -> np.ndarray:
    """The gradient of ``sign·(v[plus] − v[minus])`` over a device's ``size`` terminal
    voltages (a junction's or a branch's voltage, as the equations read it)."""
    gradient = np.zeros(size)
    gradient[plus] += sign
    gradient[minus] -= sign
    return gradient


def add_branches(values: np.ndarray, jacobian: np.ndarray, branches, sign: float = 1.0) -> None:
    """Stamp each branch ``(plus, minus, value, gradient)``: ``sign·value`` (a current [A] or a
    charge [C]) leaves terminal ``plus`` and enters ``minus`` (``values[plus] += sign·value``,
    ``values[minus] −= sign·value``), its gradient over the terminal voltages likewise into
    the rows of ``jacobian``."""
    for plus, minus, value, gradient in branches:
        values[plus] += sign * value
        values[minus] -= sign * value
        jacobian[plus] += sign * gradient
        jacobian[minus] -= sign * gradient


def add_resistors(values: np.ndarray, jacobian: np.ndarray, v: np.ndarray, resistors) -> None:
    """Stamp each linear resistor ``(plus, minus, resistance [Ω])`` whose resistance is not 0
    (0: the terminals are one node, left to the device's own mapping): the current
    ``(v[plus] − v[minus])/R`` from ``plus`` to ``minus`` and its constant gradient."""
    for plus, minus, resistance in resistors:
        if resistance:
            conductance = difference_gradient(values.size, plus, minus, 1.0 / resistance)
            values[plus] += conductance @ v
            values[minus] -= conductance @ v
            jacobian[plus] += conductance
            jacobian[minus] -= conductance
