"""The stepping loop for runs of steps whose mode does not change (DESIGN.md §2, "mode reuse").

While the active set of the complementarity pairs, the switch states and the
step size stay the same, one θ-method step is an affine map

    x_{k+1} = [y_{k+1}; λ_α] = P y_k + Q1 f_{k+1} + Q0 f_k + c

(``f`` the sources' values, ``λ_α = μ_α/h`` the currents of the active pairs),
valid as long as ``λ_α >= 0`` and the inactive pairs' ``w = W x + e_w >= 0``. A
:class:`ModeMap` holds those matrices; :func:`run_mode` applies the map step
after step and stops at the first step that leaves the mode, which the caller
then solves as a full MLCP.

The loop is compiled with numba when it is installed; otherwise the same
loop runs with numpy matrix products (same arithmetic up to the summation
order of the products, so results agree to rounding, not bit for bit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

try:  # numba is optional: it makes the loop ~20x faster, nothing else depends on it
    from numba import njit
except ImportError:  # pragma: no cover - exercised by the fallback test via NUMBA_DISABLE_JIT
    njit = None

STOP_LEFT_MODE = 0
STOP_SWITCH = 1
STOP_SCHEDULE = 2
STOP_END = 3


@dataclass
class ModeMap:
    """The affine step map of one mode (see module docstring); dense arrays.

    Attributes:
        P: ``(n + a, n)``; Q1, Q0: ``(n + a, k)``; c: ``(n + a,)``.
        W: ``(m - a, n + a)`` and e_w ``(m - a,)``: the inactive pairs' ``w``.
        active: indices of the active pairs (``a`` of them); inactive: the others.
    """

    P: np.ndarray
    Q1: np.ndarray
    Q0: np.ndarray
    c: np.ndarray
    W: np.ndarray
    e_w: np.ndarray
    active: np.ndarray
    inactive: np.ndarray


def _run_mode_loop(k0, k_end, y, z, F, step_class, schedule, P, Q1, Q0, c, W, e_w, active,
                   controls, on_threshold, off_threshold, switch_on):
    """Apply the map from step ``k0`` until the mode is left; returns ``(k, reason)``.

    ``k`` is the index of the first grid point *not* computed (steps ``k0 .. k-1``
    are done: ``y[k0+1 .. k]`` and the active columns of ``z[k0+1 .. k]``, the
    pair currents, are written; the other columns must hold zeros). ``reason``: 0 the
    step ``k`` left the mode (nothing written for it), 1 a state-controlled switch
    must change after step ``k-1``, 2 the step size or a scheduled switch state
    changes at step ``k``, 3 ``k_end`` reached.
    """
    n = y.shape[1]
    rows = P.shape[0]
    kstim = F.shape[1]
    nw = W.shape[0]
    ns = controls.shape[0]
    x = np.empty(rows)
    k = k0
    while k < k_end:
        if k > k0 and (step_class[k] != step_class[k0] or schedule[k] != schedule[k0]):
            return k, STOP_SCHEDULE
        for r in range(rows):
            acc = c[r]
            for j in range(n):
                acc += P[r, j] * y[k, j]
            for j in range(kstim):
                acc += Q1[r, j] * F[k + 1, j] + Q0[r, j] * F[k, j]
            x[r] = acc
        for r in range(n, rows):
            if x[r] < 0.0:
                return k, STOP_LEFT_MODE
        for r in range(nw):
            acc = e_w[r]
            for j in range(rows):
                acc += W[r, j] * x[j]
            if acc < 0.0:
                return k, STOP_LEFT_MODE
        for j in range(n):
            y[k + 1, j] = x[j]
        for r in range(n, rows):
            z[k + 1, active[r - n]] = x[r]
        k += 1
        for s in range(ns):
            value = 0.0
            for j in range(n):
                value += controls[s, j] * y[k, j]
            if switch_on[s]:
                if value < off_threshold[s]:
                    return k, STOP_SWITCH
            elif value > on_threshold[s]:
                return k, STOP_SWITCH
    return k, STOP_END


def _run_python_loop(advance, W, e_w, active, k0, k_end, y, current, step_class, schedule,
                     controls, on_threshold, off_threshold, switch_on):
    """The loop of :func:`_run_mode_loop` in Python, for any way of taking one step:
    ``advance(k)`` returns ``x_{k+1} = [y_{k+1}; λ_α]``."""
    n = y.shape[1]
    k = k0
    while k < k_end:
        if k > k0 and (step_class[k] != step_class[k0] or schedule[k] != schedule[k0]):
            return k, STOP_SCHEDULE
        x = advance(k)
        if (x[n:] < 0.0).any() or (W @ x + e_w < 0.0).any():
            return k, STOP_LEFT_MODE
        y[k + 1] = x[:n]
        current[k + 1, active] = x[n:]
        k += 1
        if controls.shape[0]:
            value = controls @ y[k]
            if (np.where(switch_on, value < off_threshold, value > on_threshold)).any():
                return k, STOP_SWITCH
    return k, STOP_END


_compiled = njit(cache=True, nogil=True)(_run_mode_loop) if njit is not None else None


def compiled() -> bool:
    """Whether the compiled loop is available (numba installed)."""
    return _compiled is not None


def run_mode(mode: ModeMap, k0: int, k_end: int, y: np.ndarray, current: np.ndarray,
             F: np.ndarray, step_class: np.ndarray, schedule: np.ndarray,
             controls: np.ndarray, on_threshold: np.ndarray, off_threshold: np.ndarray,
             switch_on: np.ndarray, use_compiled: bool = True) -> tuple[int, int]:
    """Run the loop (compiled if possible); see :func:`_run_mode_loop`."""
    if use_compiled and _compiled is not None:
        k, reason = _compiled(k0, k_end, y, current, F, step_class, schedule, mode.P, mode.Q1,
                              mode.Q0, mode.c, mode.W, mode.e_w, mode.active, controls,
                              on_threshold, off_threshold, switch_on)
        return int(k), int(reason)

    def advance(k: int) -> np.ndarray:
        return mode.P @ y[k] + mode.Q1 @ F[k + 1] + mode.Q0 @ F[k] + mode.c

    return _run_python_loop(advance, mode.W, mode.e_w, mode.active, k0, k_end, y, current,
                            step_class, schedule, controls, on_threshold, off_threshold, switch_on)


@dataclass
class SparseModeMap:
    """The step map of one mode of a large circuit, kept factorised (sparse LU).

    Each step solves ``bordered · x = [carry·y_k + Sw f_{k+1} + Si f_k; -e_α]``: the
    cost grows with the number of non-zeros, not with the square of the size.
    """

    lu: object
    carry: object
    S_next: object
    S_now: object
    rhs_pairs: np.ndarray
    W: object
    e_w: np.ndarray
    active: np.ndarray
    n: int


def run_sparse_mode(mode: SparseModeMap, k0: int, k_end: int, y: np.ndarray, current: np.ndarray,
                    F: np.ndarray, step_class: np.ndarray, schedule: np.ndarray,
                    controls: np.ndarray, on_threshold: np.ndarray, off_threshold: np.ndarray,
                    switch_on: np.ndarray) -> tuple[int, int]:
    """:func:`run_mode` for a :class:`SparseModeMap` (a Python loop around a sparse solve)."""
    n = mode.n
    rhs = np.empty(n + mode.active.size)
    rhs[n:] = mode.rhs_pairs

    def advance(k: int) -> np.ndarray:
        rhs[:n] = mode.carry @ y[k] + mode.S_next @ F[k + 1] + mode.S_now @ F[k]
        return mode.lu.solve(rhs)

    return _run_python_loop(advance, mode.W, mode.e_w, mode.active, k0, k_end, y, current,
                            step_class, schedule, controls, on_threshold, off_threshold, switch_on)
