"""θ-method time stepping of an MLCS with one MLCP per step (DESIGN.md §2).

For the step ``t_k -> t_{k+1}`` of length ``h``, with ``Θ = diag(θ on rows with
a time derivative, 1 on algebraic rows)``, the unknowns ``y_{k+1}`` and the
impulses ``μ = h·λ`` [C] solve

    (E - hΘA) y_{k+1} - B μ = E y_k + h(I-Θ)(A y_k + s_k) + hΘ s_{k+1}
    w = C y_{k+1} + (D/h) μ + e,        0 <= w ⊥ μ >= 0

Impulses rather than currents keep a Dirac current (a capacitor charged from
a voltage source through an ideal diode) finite: it shows as one step whose
``μ`` does not shrink with ``h``. The first step is always implicit Euler
(θ = 1), because the initial state need not satisfy the algebraic rows.

This module knows nothing about netlists: it takes an :class:`MLCS`, a grid
and a starting point.
"""

from __future__ import annotations

import time as wallclock
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from circuitnsds.errors import SimulationError
from circuitnsds.mlcs import MLCS
from circuitnsds.solvers import LCPError, MLCPSolver

SOLVER_CACHE_SIZE = 32
"""How many step sizes keep their MLCP solver (and its factorisations) alive."""


@dataclass
class Trajectory:
    """Raw result of :func:`integrate` (one row per grid point).

    Attributes:
        time: grid [s], shape ``(N,)``.
        y: MNA unknowns, shape ``(N, n)``.
        current: pair currents ``μ/h`` [A], shape ``(N, m)`` (row 0: initial).
        impulse: pair impulses ``μ`` [C] of the step ending at each point (row 0: 0).
        residual: scaled complementarity residual of each step (row 0: 0).
        active: active set of each step, shape ``(N, m)``.
        stats: counters (steps, factorisations, cache hits, Lemke fallbacks, seconds).
    """

    time: np.ndarray
    y: np.ndarray
    current: np.ndarray
    impulse: np.ndarray
    residual: np.ndarray
    active: np.ndarray
    stats: dict[str, float] = field(default_factory=dict)


def integrate(
    mlcs: MLCS,
    grid: np.ndarray,
    y0: np.ndarray,
    charge0: np.ndarray | None = None,
    current0: np.ndarray | None = None,
    active0: np.ndarray | None = None,
    *,
    theta: float = 1.0,
    tol: float = 1e-9,
    progress: Callable[[float, float], None] | None = None,
) -> Trajectory:
    """Integrate ``mlcs`` over ``grid`` from ``y0``.

    Args:
        mlcs: the system.
        grid: increasing time points [s], ``grid[0]`` is the initial time.
        y0: unknowns at ``grid[0]``.
        charge0: ``E y0`` to use instead (initial conditions that ``y0`` cannot express).
        current0: pair currents at ``grid[0]`` [A] (reported only).
        active0: guessed active set for the first step.
        theta: θ in [0.5, 1].
        tol: complementarity tolerance handed to the solver.
        progress: ``callback(t, t_end)``, called about twice a second (so never
            for runs shorter than half a second), and once at the end if it was called.

    Raises:
        SimulationError: a step has no solution (names the time and devices).
    """
    if not 0.5 <= theta <= 1.0:
        raise ValueError(f"theta must lie in [0.5, 1], got {theta}")
    grid = np.asarray(grid, dtype=float)
    count, n, m = grid.size, mlcs.n, mlcs.m
    y = np.empty((count, n))
    impulse = np.zeros((count, m))
    current = np.zeros((count, m))
    residual = np.zeros(count)
    active = np.zeros((count, m), dtype=bool)
    y[0] = y0
    if current0 is not None:
        current[0] = current0
    if active0 is not None:
        active[0] = active0
    guess = active0

    differential = mlcs.differential_rows
    E, A = mlcs.E.tocsr(), mlcs.A.tocsr()
    solvers: OrderedDict[tuple[float, float], _StepSolver] = OrderedDict()
    retired: list[_StepSolver] = []  # evicted solvers, kept only for their counters
    started = wallclock.perf_counter()
    last_report = started
    reported = False
    charge = charge0 if charge0 is not None else E @ y[0]
    source_now = mlcs.source(grid[0])
    stats = {"steps": count - 1, "factorisations": 0, "cache_hits": 0, "fallbacks": 0}

    step_solver, solver_key = None, None
    for k in range(count - 1):
        h = grid[k + 1] - grid[k]
        step_theta = 1.0 if k == 0 else theta
        if (h, step_theta) != solver_key:  # most steps repeat the previous size
            solver_key = (h, step_theta)
            step_solver = _solver_for(solvers, mlcs, E, A, differential, h, step_theta, tol,
                                      retired)
        weights = step_solver.weights
        source_next = mlcs.source(grid[k + 1])
        rhs = charge + h * weights * source_next
        if step_theta != 1.0:
            rhs += h * (1.0 - weights) * (A @ y[k] + source_now)
        try:
            result = step_solver.solver.solve(-rhs, mlcs.e, guess=guess)
        except LCPError as exc:
            raise _step_failure(mlcs, grid[k], grid[k + 1], exc) from None
        y[k + 1] = result.u  # finite: the solver raises rather than return NaN or inf
        impulse[k + 1] = result.z
        current[k + 1] = result.z / h
        residual[k + 1] = result.residual
        active[k + 1] = guess = np.asarray(result.active, dtype=bool)
        charge = E @ y[k + 1]
        source_now = source_next
        if progress is not None and wallclock.perf_counter() - last_report > 0.5:
            last_report = wallclock.perf_counter()
            reported = True
            progress(grid[k + 1], grid[-1])

    for step_solver in list(solvers.values()) + retired:
        for key in ("factorisations", "cache_hits", "fallbacks"):
            stats[key] += step_solver.solver.stats.get(key, 0)
    stats["seconds"] = wallclock.perf_counter() - started
    if progress is not None and reported:
        progress(grid[-1], grid[-1])
    return Trajectory(grid, y, current, impulse, residual, active, stats)


@dataclass
class _StepSolver:
    """The MLCP solver of one step size and the diagonal of its Θ."""

    solver: MLCPSolver
    weights: np.ndarray


def _solver_for(cache, mlcs: MLCS, E, A, differential: np.ndarray, h: float, theta: float,
                tol: float, retired: list) -> _StepSolver:
    """The MLCP solver of a step of size ``h`` (cached per rounded ``h`` and θ).

    Solvers evicted from the cache go to ``retired``, which keeps their counters.
    """
    key = (float(f"{h:.12g}"), theta)
    if key in cache:
        cache.move_to_end(key)
        return cache[key]
    weights = np.where(differential, theta, 1.0)
    K = (E - h * sp.diags(weights) @ A).tocsc()
    solver = MLCPSolver(K, -mlcs.B, mlcs.C, mlcs.D / h, tol=tol)
    cache[key] = _StepSolver(solver, weights)
    if len(cache) > SOLVER_CACHE_SIZE:
        retired.append(cache.popitem(last=False)[1])
    return cache[key]


def _step_failure(mlcs: MLCS, t0: float, t1: float, exc: LCPError) -> SimulationError:
    devices = sorted(set(mlcs.pair_devices))
    return SimulationError(
        f"the time step from t = {t0:.6g} s to {t1:.6g} s has no solution with ideal devices "
        f"({type(exc).__name__}: {exc})",
        where=f"t = {t1:.6g} s",
        hint=f"devices involved: {', '.join(devices)}; look for a diode (or Zener) that no "
        "current can pass in either state, e.g. in series with a current source or an "
        "inductor forced against it",
    )
