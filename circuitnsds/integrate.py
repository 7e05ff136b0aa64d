"""θ-method time stepping of an MLCS with one MLCP per step (DESIGN.md §2).

For the step ``t_k -> t_{k+1}`` of length ``h``, with ``Θ = diag(θ on rows with
a time derivative, 1 on algebraic rows)`` and ``A`` for the step's switch states,
the unknowns ``y_{k+1}`` and the impulses ``μ = h·λ`` [C] solve

    (E - hΘA) y_{k+1} - B μ = E y_k + h(I-Θ)(A y_k + s_k) + hΘ s_{k+1}
    w = C y_{k+1} + (D/h) μ + e,        0 <= w ⊥ μ >= 0

Impulses rather than currents keep a Dirac current (a capacitor charged from
a voltage source through an ideal diode) finite: it shows as one step whose
``μ`` does not shrink with ``h``. The first step is always implicit Euler
(θ = 1), because the initial state need not satisfy the algebraic rows.
Numerically the rows are divided by ``h`` and the solver's pair unknowns are
the currents ``λ = μ/h``: the same solution, but the solver's normwise test
then weighs currents (not tiny charges) against voltages.

Switch states for a step are decided before it is solved:

* a switch whose control is a source's time function (a voltage source across
  its control nodes) takes the state its control has in the *middle* of the
  step; the threshold crossings of piecewise-linear sources are grid points
  (:meth:`MLCS.breakpoints`), so it switches exactly at the crossing;
* any other switch takes the state its control had at the *start* of the step
  (at most one step late).

Steps whose mode (active pairs, switch states, step size) is the previous
step's run through :mod:`circuitnsds.kernel` (one affine map per step, checked
for complementarity); a step that leaves the mode is solved as a full MLCP.

This module knows nothing about netlists: it takes an :class:`MLCS`, a grid
and a starting point.
"""

from __future__ import annotations

import time as wallclock
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from scipy.linalg import lapack

from circuitnsds.errors import SimulationError
from circuitnsds.kernel import ModeMap, run_mode
from circuitnsds.mlcs import MLCS
from circuitnsds.solvers import LCPError, MLCPSolver

SOLVER_CACHE_SIZE = 32
"""How many (step size, switch states) keep their MLCP solver (and its factorisations)."""
MODE_CACHE_SIZE = 256
"""How many modes keep their step map."""
DENSE_MAP_LIMIT = 400
"""Largest ``n + active pairs`` for which a mode gets a dense step map (beyond: MLCP every step)."""
CHUNK = 100_000
"""Longest run of mapped steps between progress reports."""


@dataclass
class Trajectory:
    """Raw result of :func:`integrate` (one row per grid point).

    Attributes:
        time: grid [s], shape ``(N,)``.
        y: MNA unknowns, shape ``(N, n)``.
        current: pair currents ``μ/h`` [A], shape ``(N, m)`` (row 0: initial).
        impulse: pair impulses ``μ`` [C] of the step ending at each point (row 0: 0).
        residual: scaled complementarity residual of each step solved as an MLCP;
            0 for a step taken by the mode map, whose signs are checked exactly.
        active: active set of each step, shape ``(N, m)``.
        switches: state (closed = true) of each switch during the step ending at
            each point, shape ``(N, number of switches)`` (row 0: the initial state).
        stats: counters (steps, mapped_steps, mlcp_steps, factorisations, cache hits,
            Lemke fallbacks, seconds).
    """

    time: np.ndarray
    y: np.ndarray
    current: np.ndarray
    impulse: np.ndarray
    residual: np.ndarray
    active: np.ndarray
    switches: np.ndarray
    stats: dict[str, float] = field(default_factory=dict)


def integrate(
    mlcs: MLCS,
    grid: np.ndarray,
    y0: np.ndarray,
    charge0: np.ndarray | None = None,
    current0: np.ndarray | None = None,
    active0: np.ndarray | None = None,
    switches0: np.ndarray | None = None,
    *,
    theta: float = 1.0,
    tol: float = 1e-9,
    progress: Callable[[float, float], None] | None = None,
    compiled: bool = True,
) -> Trajectory:
    """Integrate ``mlcs`` over ``grid`` from ``y0``.

    Args:
        mlcs: the system.
        grid: increasing time points [s], ``grid[0]`` is the initial time.
        y0: unknowns at ``grid[0]``.
        charge0: ``E y0`` to use instead (initial conditions that ``y0`` cannot express).
        current0: pair currents at ``grid[0]`` [A] (reported only).
        active0: guessed active set for the first step.
        switches0: switch states at ``grid[0]`` (default: each switch's ``ON`` flag).
        theta: θ in [0.5, 1].
        tol: complementarity tolerance handed to the solver.
        progress: ``callback(t, t_end)``, called about twice a second (so never
            for runs shorter than half a second), and once at the end if it was called.
        compiled: use the compiled mode loop when numba is installed (``False``:
            the numpy loop, for comparison).

    Raises:
        SimulationError: a step has no solution (names the time and devices).
    """
    if not 0.5 <= theta <= 1.0:
        raise ValueError(f"theta must lie in [0.5, 1], got {theta}")
    grid = np.asarray(grid, dtype=float)
    count, n, m = grid.size, mlcs.n, mlcs.m
    switches = mlcs.switches
    y = np.empty((count, n))
    current = np.zeros((count, m))
    residual = np.zeros(count)
    active = np.zeros((count, m), dtype=bool)
    states = np.zeros((count, len(switches)), dtype=bool)
    y[0] = y0
    if active0 is not None:
        active[0] = active0
    states[0] = (switches0 if switches0 is not None
                 else [switch.initially_on for switch in switches])

    stepping = _Stepping(mlcs, grid, theta, tol, states[0])
    started = wallclock.perf_counter()
    clock = {"last": started, "reported": False}

    def _report() -> None:
        if progress is not None and wallclock.perf_counter() - clock["last"] > 0.5:
            clock["last"], clock["reported"] = wallclock.perf_counter(), True
            progress(grid[k], grid[-1])

    charge = charge0 if charge0 is not None else mlcs.E @ y[0]
    guess = active0
    last_active: dict[bytes, np.ndarray] = {}
    stats = {"steps": count - 1, "mapped_steps": 0, "mlcp_steps": 0, "modes": 0}

    k = 0
    while k < count - 1:
        states[k + 1] = stepping.switch_states(k, states[k], y[k])
        if k > 0 and (states[k + 1] != states[k]).any():
            # a switch changed: the pairs most likely take the mode they had the last
            # time the switches were in this state (the other phase of a converter)
            guess = last_active.get(states[k + 1].tobytes(), guess)
        if k > 0 and guess is not None:
            mode = stepping.mode_map(k, states[k + 1], guess)
            if mode is not None:
                done, reason = run_mode(mode, k, min(count - 1, k + CHUNK), y, current,
                                        stepping.sources, stepping.step_class,
                                        stepping.schedule_code,
                                        *stepping.free_switch_arrays(states[k + 1]),
                                        use_compiled=compiled)
                if done > k:
                    active[k + 1:done + 1] = guess
                    states[k + 1:done + 1] = states[k + 1]
                    last_active[states[k + 1].tobytes()] = guess
                    stats["mapped_steps"] += done - k
                    k, charge = done, None
                    _report()
                    continue  # the next step decides its states and mode afresh
        if charge is None:
            charge = mlcs.E @ y[k]
        result = stepping.solve_step(k, states[k + 1], charge, y[k], guess)
        y[k + 1] = result.u  # finite: the solver raises rather than return NaN or inf
        current[k + 1] = result.z
        residual[k + 1] = result.residual
        active[k + 1] = guess = np.asarray(result.active, dtype=bool)
        last_active[states[k + 1].tobytes()] = guess
        stats["mlcp_steps"] += 1
        charge = mlcs.E @ y[k + 1]
        k += 1
        _report()

    impulse = np.zeros((count, m))
    impulse[1:] = current[1:] * np.diff(grid)[:, None]
    if current0 is not None:
        current[0] = current0
    stats.update(stepping.counters())
    stats["seconds"] = wallclock.perf_counter() - started
    if progress is not None and clock["reported"]:
        progress(grid[-1], grid[-1])
    return Trajectory(grid, y, current, impulse, residual, active, states, stats)


@dataclass
class _StepSolver:
    """The MLCP solver of one step size and switch state, with its Θ diagonal and ``A``."""

    solver: MLCPSolver
    weights: np.ndarray
    A: sp.csr_matrix
    K: sp.csc_matrix


class _Stepping:
    """Everything the time loop needs that depends on the grid, cached per step size and mode."""

    def __init__(self, mlcs: MLCS, grid: np.ndarray, theta: float, tol: float,
                 initial_states: np.ndarray):
        self.mlcs, self.grid, self.theta, self.tol = mlcs, grid, theta, tol
        self.E = mlcs.E.tocsr()
        self.differential = mlcs.differential_rows
        self.sources = _source_values(mlcs, grid)
        steps = np.diff(grid)
        # steps equal to 1e-9 relative share one class (grid rounding is ~1e-16·t)
        quantum = 1e-9 * steps.max()
        self.step_class = np.unique(np.round(steps / quantum),
                                    return_inverse=True)[1].astype(np.int64)
        self.step_class[0] = -1  # the first step is implicit Euler whatever θ is
        self.scheduled, self.schedule, self.schedule_code = _switch_schedule(
            mlcs, grid, self.sources, initial_states)
        free = [j for j, s in enumerate(mlcs.switches) if s.control_stimulus is None]
        self.free = np.array(free, dtype=np.int64)
        controls = np.zeros((len(free), mlcs.n))
        for row, j in enumerate(free):
            for column, value in mlcs.switches[j].control:
                controls[row, column] += value
        self.free_controls = controls
        self.free_on = np.array([mlcs.switches[j].on_threshold for j in free])
        self.free_off = np.array([mlcs.switches[j].off_threshold for j in free])
        self._no_free = (controls, self.free_on, self.free_off, np.zeros(0, dtype=bool))
        self.solvers: OrderedDict[tuple, _StepSolver] = OrderedDict()
        self.retired: list[_StepSolver] = []
        self.modes: dict[tuple, ModeMap | None] = {}
        self.built = 0

    def switch_states(self, k: int, previous: np.ndarray, y: np.ndarray) -> np.ndarray:
        """States of the switches during step ``k``: scheduled ones from their source,
        the others from their control at ``t_k`` (with hysteresis)."""
        if not self.free.size:
            if self.scheduled.size == previous.size:
                return self.schedule[k]  # every switch scheduled (the usual converter)
            if not self.scheduled.size:
                return previous
        states = previous.copy()
        if self.scheduled.size:
            states[self.scheduled] = self.schedule[k]
        for row, j in enumerate(self.free):
            states[j] = self.mlcs.switches[j].next_state(bool(previous[j]),
                                                         float(self.free_controls[row] @ y))
        return states

    def free_switch_arrays(self, states: np.ndarray) -> tuple[np.ndarray, ...]:
        """Controls, thresholds and current states of the switches the loop must watch."""
        if not self.free.size:
            return self._no_free
        return self.free_controls, self.free_on, self.free_off, states[self.free]

    def _key(self, k: int, states: np.ndarray) -> tuple:
        return int(self.step_class[k]), states.tobytes()

    def _step_solver(self, k: int, states: np.ndarray) -> _StepSolver:
        key = self._key(k, states)
        if key in self.solvers:
            self.solvers.move_to_end(key)
            return self.solvers[key]
        h = self.grid[k + 1] - self.grid[k]
        theta = 1.0 if k == 0 else self.theta
        weights = np.where(self.differential, theta, 1.0)
        A = self.mlcs.system_matrix(tuple(bool(s) for s in states))
        # rows divided by h: node rows in amperes, the pair unknowns are currents μ/h
        # (same solution; the solver's normwise test then weighs currents, not charges,
        # against the voltages, and a wrong-signed current of microamperes is caught)
        K = (self.E / h - sp.diags(weights) @ A).tocsc()
        solver = MLCPSolver(K, -self.mlcs.B, self.mlcs.C, self.mlcs.D, tol=self.tol)
        self.solvers[key] = _StepSolver(solver, weights, A.tocsr(), K)
        if len(self.solvers) > SOLVER_CACHE_SIZE:
            self.retired.append(self.solvers.popitem(last=False)[1])
        return self.solvers[key]

    def solve_step(self, k: int, states: np.ndarray, charge: np.ndarray, y: np.ndarray,
                   guess: np.ndarray | None):
        """Solve step ``k`` as an MLCP (see module docstring)."""
        step = self._step_solver(k, states)
        h = self.grid[k + 1] - self.grid[k]
        S = self.mlcs.S
        source_next = S @ self.sources[k + 1]
        rhs = charge / h + step.weights * source_next
        if k > 0 and self.theta != 1.0:
            rhs += (1.0 - step.weights) * (step.A @ y + S @ self.sources[k])
        try:
            return step.solver.solve(-rhs, self.mlcs.e, guess=guess)
        except LCPError as exc:
            raise _step_failure(self.mlcs, self.grid[k], self.grid[k + 1], exc) from None

    def mode_map(self, k: int, states: np.ndarray, guess: np.ndarray) -> ModeMap | None:
        """The step map of the mode (step size of step ``k``, ``states``, active set ``guess``)."""
        key = (self.step_class[k], states.tobytes(), guess.tobytes())
        mode = self.modes.get(key, False)
        if mode is False:
            if len(self.modes) >= MODE_CACHE_SIZE:
                self.modes.clear()  # a circuit visiting this many modes gains little from maps
            mode = self.modes[key] = self._build_mode(k, states, guess)
            self.built += 1
        return mode

    def _build_mode(self, k: int, states: np.ndarray, guess: np.ndarray) -> ModeMap | None:
        mlcs, n = self.mlcs, self.mlcs.n
        act = np.flatnonzero(guess)
        inact = np.flatnonzero(~guess)
        if n + act.size > DENSE_MAP_LIMIT:
            return None
        step = self._step_solver(k, states)
        h = self.grid[k + 1] - self.grid[k]
        B, C, D = (mlcs.B.toarray(), mlcs.C.toarray(), mlcs.D.toarray())
        bordered = np.block([[step.K.toarray(), -B[:, act]], [C[act], D[np.ix_(act, act)]]])
        try:
            lu = la.lu_factor(bordered, check_finite=False)
        except (ValueError, la.LinAlgError):
            return None
        diagonal = np.abs(np.diag(lu[0]))
        if diagonal.min() <= 1e-13 * diagonal.max():
            return None
        implicit = np.zeros(n) if k == 0 else (1.0 - step.weights)
        S = mlcs.S.toarray()
        carry = self.E.toarray() / h + implicit[:, None] * step.A.toarray()
        kstim = S.shape[1]
        right = np.zeros((n + act.size, n + 2 * kstim + 1))
        right[:n, :n] = carry
        right[:n, n:n + kstim] = step.weights[:, None] * S
        right[:n, n + kstim:n + 2 * kstim] = implicit[:, None] * S
        right[n:, -1] = -mlcs.e[act]
        # LAPACK getrs directly: scipy's lu_solve is slow for matrix right-hand sides
        solution, info = lapack.dgetrs(lu[0], lu[1], right)
        if info != 0 or not np.all(np.isfinite(solution)):
            return None
        P, Q1 = solution[:, :n], solution[:, n:n + kstim]
        Q0, c = solution[:, n + kstim:n + 2 * kstim], solution[:, -1]
        W = np.hstack([C[inact], D[np.ix_(inact, act)]])
        return ModeMap(P=np.ascontiguousarray(P), Q1=np.ascontiguousarray(Q1),
                       Q0=np.ascontiguousarray(Q0), c=np.ascontiguousarray(c), W=np.ascontiguousarray(W),
                       e_w=mlcs.e[inact].copy(), active=act.astype(np.int64),
                       inactive=inact.astype(np.int64))

    def counters(self) -> dict[str, int]:
        totals = {"factorisations": 0, "cache_hits": 0, "fallbacks": 0}
        for step in list(self.solvers.values()) + self.retired:
            for key in totals:
                totals[key] += step.solver.stats.get(key, 0)
        totals["modes"] = self.built
        return totals


def _source_values(mlcs: MLCS, grid: np.ndarray) -> np.ndarray:
    """Every source's value at every grid point, shape ``(N, number of sources)``."""
    values = np.zeros((grid.size, len(mlcs.stimuli)))
    for column, stimulus in enumerate(mlcs.stimuli):
        values[:, column] = stimulus.sample(grid)
    return values


def _switch_schedule(mlcs: MLCS, grid: np.ndarray, sources: np.ndarray,
                     initial: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """States of the source-controlled switches for every step, from their control at the
    step's midpoint (with hysteresis, starting from ``initial``).

    Returns ``(switch indices, states (steps, count), one integer code per step)``; the
    code changes exactly where some scheduled state does (the mode loop watches it).
    """
    scheduled = [j for j, s in enumerate(mlcs.switches) if s.control_stimulus is not None]
    steps = grid.size - 1
    states = np.zeros((steps, len(scheduled)), dtype=bool)
    if not scheduled:
        return np.zeros(0, dtype=np.int64), states, np.zeros(steps, dtype=np.int64)
    middles = 0.5 * (grid[:-1] + grid[1:])
    for column, j in enumerate(scheduled):
        switch = mlcs.switches[j]
        stimulus, sign = switch.control_stimulus
        control = sign * mlcs.stimuli[stimulus].sample(middles)
        decided = np.where(control > switch.on_threshold, 1,
                           np.where(control < switch.off_threshold, 0, -1))
        last = np.maximum.accumulate(np.where(decided >= 0, np.arange(steps), -1))
        states[:, column] = np.where(last >= 0, decided[np.maximum(last, 0)] == 1, initial[j])
    changes = np.any(states[1:] != states[:-1], axis=1)
    code = np.concatenate([[0], np.cumsum(changes)]).astype(np.int64)
    return np.array(scheduled, dtype=np.int64), states, code


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
