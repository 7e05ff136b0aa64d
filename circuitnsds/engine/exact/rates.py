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

The maps are composed first (``V1 Σ1⁻¹ U1ᵀ A`` per switch state, restricted to the unknowns
asked for), so a row costs one small matrix product: reading a capacitor's current on the
voltage-mode buck's 502,001 rows takes a few tenths of a second.
"""

from __future__ import annotations

import numpy as np

from circuitnsds.engine.exact.mode import StateCoordinates
from circuitnsds.system.mlcs import MLCS


def state_rates(mlcs: MLCS, time: np.ndarray, y: np.ndarray, current: np.ndarray,
                switches: np.ndarray, columns: np.ndarray | None = None) -> np.ndarray:
    """``V1 V1ᵀ y'`` [unit of each unknown per second] at each row (module docstring), of the
    unknowns ``columns`` (all by default), shape ``(N, len(columns))``.

    Args:
        mlcs: the system.
        time: the rows' instants [s], shape ``(N,)``.
        y: the unknowns at each row, ``(N, n)``; current: the pairs' currents ``λ`` [A],
            ``(N, m)``; switches: the switch states (closed = true), ``(N, switches)``.
        columns: the unknowns wanted (indices).
    """
    time = np.asarray(time, dtype=float)
    rows, n = y.shape
    columns = np.arange(n) if columns is None else np.asarray(columns, dtype=int)
    coordinates = StateCoordinates.of(mlcs.E.toarray())
    if rows == 0 or coordinates.rank == 0:
        return np.zeros((rows, columns.size))
    # V1 x' = V1 Σ1⁻¹ U1ᵀ (A y + B λ + S f(t)), of the columns wanted: ``to_rate``
    to_rate = coordinates.V1[columns] @ (coordinates.U1.T / coordinates.sigma[:, None])
    rates = ((to_rate @ mlcs.B.toarray()) @ np.asarray(current, dtype=float).T).T.copy()
    if mlcs.stimuli:  # (only the sources that reach a differential row: not a V source's own)
        forcing = to_rate @ mlcs.S.toarray()
        for j in np.flatnonzero(np.any(forcing != 0, axis=0)):
            rates += mlcs.stimuli[j].sample(time)[:, None] * forcing[None, :, j]
    states = np.asarray(switches, dtype=bool).reshape(rows, -1)
    # the switch states come in runs between events: the distinct ones among the runs' starts
    starts = np.flatnonzero(np.r_[True, np.any(states[1:] != states[:-1], axis=1)])
    kinds: dict[bytes, int] = {}
    of_run = np.array([kinds.setdefault(states[k].tobytes(), len(kinds)) for k in starts], dtype=np.intp)
    first = [int(starts[np.argmax(of_run == k)]) for k in range(len(kinds))]
    to_y = np.hstack([(to_rate @ mlcs.system_matrix(tuple(bool(s) for s in states[k])).toarray()).T
                      for k in first])  # (every switch state's map side by side: one product)
    # (as (to_yᵀ yᵀ)ᵀ: numpy's y @ to_y with few columns took 10 times longer on 502,000 rows)
    products = (to_y.T @ y.T).T.reshape(rows, len(first), columns.size)
    if len(first) == 1:
        rates += products[:, 0]
    else:
        which = np.repeat(of_run, np.diff(np.r_[starts, rows]))
        rates += np.take_along_axis(products, which[:, None, None], axis=1)[:, 0]
    return rates
