"""The state's rate of change at the rows of an exact run: what a capacitor's current is there.

A row of the exact integrator is the closed form at its instant (:mod:`.stepper`), so a
capacitor's current there is ``C dv/dt`` at that instant, not the charge it took over the
interval before the row divided by the interval's width (ΔQ/Δt, the θ-method's current of a
step: KCL holds for it on θ's rows, whose other currents are the step's too, and fails on
exact rows, whose other currents are instantaneous: a switched RC off by 0.045 A where the
currents are 0.034 A).

With the mode of the row fixed (its switch states; the pairs enter through their currents
``λ``), the MLCS gives ``E y' = A y + B λ + s(t)`` at the instant. ``E = U1 Σ1 V1ᵀ``
(:class:`.mode.StateCoordinates`) determines the rate of the state ``x = V1ᵀ y`` only,

    x' = Σ1⁻¹ U1ᵀ (A y + B λ + s(t)),

and returns ``V1 x'``: the rate of each unknown's part in the row space of ``E``. A
capacitor's voltage ``aᵀ y`` (``a`` its incidence) lies in that space (``E`` holds
``C a aᵀ``), so ``C aᵀ V1 x'`` is its current, exactly the closed form's derivative to
round-off. At a row on an event it is the rate of the segment ending there (the row's
``λ`` and switch states are that segment's), the left derivative; a state jump is not a
rate (the exact loop has none; its hand-offs to θ report theirs as impulses).

Each row is computed by the same operations in the same order whatever the number of rows
(entry by entry, no matrix product whose summation order depends on the shapes).
"""

from __future__ import annotations

import numpy as np

from circuitnsds.engine.exact.mode import StateCoordinates
from circuitnsds.system.mlcs import MLCS


def state_rates(mlcs: MLCS, time: np.ndarray, y: np.ndarray, current: np.ndarray,
                switches: np.ndarray) -> np.ndarray:
    """``V1 V1ᵀ y'`` [unit of each unknown per second] at each row (module docstring).

    Args:
        mlcs: the system.
        time: the rows' instants [s], shape ``(N,)``.
        y: the unknowns at each row, ``(N, n)``; current: the pairs' currents ``λ`` [A],
            ``(N, m)``; switches: the switch states (closed = true), ``(N, switches)``.
    """
    time = np.asarray(time, dtype=float)
    rows, n = y.shape
    rates = np.zeros((rows, n))
    if rows == 0:
        return rates
    coordinates = StateCoordinates.of(mlcs.E.toarray())
    if coordinates.rank == 0:
        return rates
    # x' = Σ1⁻¹ U1ᵀ (A y + B λ + S f(t)): ``to_x`` maps the right-hand side to x'
    to_x = coordinates.U1.T / coordinates.sigma[:, None]
    B = mlcs.B.toarray()
    S = mlcs.S.toarray() if mlcs.stimuli else np.zeros((n, 0))
    values = (np.column_stack([stimulus.sample(time) for stimulus in mlcs.stimuli])
              if mlcs.stimuli else np.zeros((rows, 0)))
    fixed = _weighted(current, to_x @ B) + _weighted(values, to_x @ S)
    states = np.asarray(switches, dtype=bool).reshape(rows, -1)
    kinds, which = np.unique(states, axis=0, return_inverse=True)
    which = which.reshape(-1)
    x_rate = np.empty((rows, coordinates.rank))
    for k, closed in enumerate(kinds):
        here = which == k
        A = mlcs.system_matrix(tuple(bool(s) for s in closed)).toarray()
        x_rate[here] = _weighted(y[here], to_x @ A) + fixed[here]
    return _weighted(x_rate, coordinates.V1)


def _weighted(inputs: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """``inputs @ matrixᵀ`` row by row, summed column after column of ``matrix`` (its zero
    columns skipped): each row's arithmetic is the same whatever the number of rows."""
    out = np.zeros((inputs.shape[0], matrix.shape[0]))
    for j in np.flatnonzero(np.any(matrix != 0, axis=0)):
        out += inputs[:, j, None] * matrix[None, :, j]
    return out
