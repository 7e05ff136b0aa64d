"""The DC operating point of an MLCS with smooth relations: Newton–Josephy
(:func:`~circuitnsds.engine.newton_step.newton_solve` without the time derivatives), and
when plain Newton fails, the continuations SPICE uses (ngspice's ``CKTop``): *gmin stepping*
(a conductance from every node to ground, 10 mS first, divided by 10 each time the point
converges, then removed) and then *source stepping* (the independent sources raised from 0
to their value, each point starting from the last; a failed raise is halved).

Capacitors are open and inductors short (``E`` plays no part); the charges of the smooth
relations play none either. Nodes may be held at given voltages (``.ic``): each hold is an
extra unknown (the current that holds it) and an extra row.
"""

from __future__ import annotations

import numpy as np

from circuitnsds.engine.integrate import source_values
from circuitnsds.engine.newton_step import (
    NewtonFailure,
    NewtonResult,
    SmoothParts,
    newton_solve,
    update_tolerance,
)
from circuitnsds.system.mlcs import MLCS

GMIN_START = 1e-2
"""The first conductance [S] of gmin stepping."""
GMIN_END = 1e-12
"""The last conductance [S] before it is removed."""
SOURCE_STEPS = 10
"""Source stepping raises the sources in this many equal parts (halved on a failure)."""
MIN_SOURCE_STEP = 1e-4
"""The smallest raise of source stepping before it gives up."""


def smooth_operating_point(mlcs: MLCS, states: tuple[bool, ...], held: list[tuple[int, float]],
                           tol: float = 1e-9) -> NewtonResult:
    """The DC point (module docstring) with switch ``states`` and nodes ``held`` as
    ``(row, voltage)``; ``y`` of the result has the ``n`` unknowns then one hold current per
    held node. ``iterations`` counts every Newton iteration, continuations included.

    Raises:
        NewtonFailure: plain Newton, gmin stepping and source stepping all failed (the
            reason of the last).
    """
    n, k = mlcs.n, len(held)
    size = n + k
    A = np.zeros((size, size))
    A[:n, :n] = mlcs.system_matrix(states).toarray()
    for j, (row, _) in enumerate(held):
        A[row, n + j] = A[n + j, row] = -1.0  # a current into the node; the row v = value
    sources = np.zeros(size)
    sources[:n] = mlcs.S.toarray() @ source_values(mlcs, np.zeros(1))[0]
    sources[n:] = [value for _, value in held]
    B, C = np.zeros((size, mlcs.m)), np.zeros((mlcs.m, size))
    B[:n], C[:, :n] = mlcs.B.toarray(), mlcs.C.toarray()
    blocks = (B, C, mlcs.D.toarray(), np.asarray(mlcs.e, dtype=float))
    parts = SmoothParts(mlcs, size)
    atol = np.concatenate([update_tolerance(mlcs), np.full(k, 1e-9)])
    weights = np.ones(size)
    nodes = np.array([name.startswith("v(") for name in mlcs.unknowns] + [False] * k)
    total = 0

    def solve(gmin: float, scale: float, y0: np.ndarray, guess) -> NewtonResult:
        nonlocal total
        base = -A + np.diag(np.where(nodes, gmin, 0.0))
        rhs = scale * sources
        try:
            result = newton_solve(parts, base, rhs, weights, np.inf, 0.0, y0, guess, blocks, atol, tol)
        except NewtonFailure as exc:
            total += exc.iterations
            raise
        total += result.iterations
        return result

    def counted(result: NewtonResult) -> NewtonResult:
        result.iterations = total
        return result

    zero = np.zeros(size)
    try:
        return counted(solve(0.0, 1.0, zero, None))
    except NewtonFailure:
        pass
    try:  # gmin stepping
        y, guess, gmin = zero, None, GMIN_START
        while gmin >= GMIN_END:
            result = solve(gmin, 1.0, y, guess)
            y, guess, gmin = result.y, result.active, gmin / 10.0
        return counted(solve(0.0, 1.0, y, guess))
    except NewtonFailure:
        pass
    y, guess, scale, raise_by = zero, None, 0.0, 1.0 / SOURCE_STEPS  # source stepping
    failure = None
    while scale < 1.0:
        target = min(1.0, scale + raise_by)
        try:
            result = solve(0.0, target, y, guess)
        except NewtonFailure as exc:
            failure = exc
            raise_by /= 2.0
            if raise_by < MIN_SOURCE_STEP:
                raise NewtonFailure(f"no DC point: plain Newton, gmin stepping and source stepping "
                                    f"failed (source stepping stopped at {scale:.4g} of the "
                                    f"sources: {failure.reason})", total) from None
            continue
        y, guess, scale = result.y, result.active, target
        raise_by = min(2.0 * raise_by, 1.0 / SOURCE_STEPS)
    return counted(result)
