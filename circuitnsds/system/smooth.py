"""Smooth nonlinear relations of an MLCS: the data a smooth element (a BJT, a JFET, a
nonlinear behavioural source) hands to the engine (DESIGN.md "Smooth nonlinear elements
beside the ideal ones", issue 33).

With smooth relations the first equation of the MLCS (:mod:`circuitnsds.system.mlcs`) reads

    E y' + Σ_r P_r d/dt q_r(x_r) = A y + B λ + s(t) − Σ_r P_r f_r(x_r, t)

for every relation ``r``: ``x_r = y[inputs]`` (an input ``-1`` is ground and reads 0 V),
``P_r`` scatters the relation's values onto ``rows`` (a row ``-1`` is ground: dropped).

* On a node's row (Kirchhoff's current law, currents *into* the node on the right), ``f`` is
  the current [A] that *leaves* the node into the element's terminal and ``q`` the charge
  [C] the element stores at that terminal (its current is ``dq/dt``, leaving the node too).
  A device's terminal currents and charges sum to zero over its terminals.
* On a branch row (``0 = v+ − v− − ...`` of a voltage-defined element), ``f`` is the term
  subtracted (a behavioural voltage source ``V = g(x)`` puts ``f = g(x)`` on its branch row).

The engine needs the values and their derivatives at an iterate; a relation is plain data
with one function, so that the system layer stays free of devices.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

SmoothEvaluation = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""``(f, df/dx, q, dq/dx)``: ``f`` and ``q`` of shape ``(len(rows),)`` [A, C (or V on a
branch row)], their Jacobians ``(len(rows), len(inputs))`` [S, F]."""


@dataclass(frozen=True)
class SmoothRelation:
    """One smooth nonlinear element as the MLCS sees it.

    Attributes:
        name: the element's name (``q1``, ``b3``).
        inputs: indexes into ``y`` of the unknowns it reads (node voltages [V], branch
            currents [A]); ``-1`` is ground (0 V).
        rows: indexes of the rows it adds ``f`` and ``q`` to; ``-1`` is ground (dropped).
        evaluate: ``evaluate(x, t)`` → :data:`SmoothEvaluation` at ``x = y[inputs]`` and time
            ``t`` [s] (devices ignore ``t``; a behavioural source of ``time`` uses it).
        limit: ``limit(x_new, x_old)`` → the Newton iterate to use instead of ``x_new``
            (SPICE's junction-voltage limiting), or ``None`` (no limiting).
        charges: whether ``q`` can be nonzero (a relation without charges skips its
            ``dq/dt`` terms).
    """

    name: str
    inputs: tuple[int, ...]
    rows: tuple[int, ...]
    evaluate: Callable[[np.ndarray, float], SmoothEvaluation]
    limit: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
    charges: bool = False

    def read(self, y: np.ndarray) -> np.ndarray:
        """``x = y[inputs]``, ground read as 0."""
        index = np.asarray(self.inputs, dtype=int)
        return np.where(index >= 0, y[np.maximum(index, 0)], 0.0) if index.size else np.zeros(0)
