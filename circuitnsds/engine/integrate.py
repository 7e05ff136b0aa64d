"""θ-method time stepping of an MLCS with one MLCP per step (docs/method.md).

For the step ``t_k -> t_{k+1}`` of length ``h``, with ``Θ = diag(θ on rows with
a time derivative, 1 on algebraic rows)`` and ``A`` for the step's switch states,
the unknowns ``y_{k+1}`` and the impulses ``μ = h·λ`` [C] solve

    (E - hΘA) y_{k+1} - B μ = E y_k + h(I-Θ)(A y_k + s_k) + hΘ s_{k+1}
    w = C y_{k+1} + (D/h) μ + e,        0 <= w ⊥ μ >= 0

Impulses rather than currents keep a Dirac current (a capacitor charged from
a voltage source through an ideal diode) finite: it shows as one step whose
``μ`` does not shrink with ``h``. The first step is always implicit Euler
(θ = 1), because the initial state need not satisfy the algebraic rows; with
θ < 1 so is the step after a switch changes state or a source's corner
(see :class:`GridStepping`).
Numerically the rows are divided by ``h`` and the solver's pair unknowns are
the currents ``λ = μ/h``: the same solution, but the solver's normwise test
then weighs currents (not tiny charges) against voltages.

Switch states for a step are decided before it is solved:

* a switch whose control is a source's time function (a voltage source across
  its control nodes) takes the state its control has in the *middle* of the
  step; the threshold crossings of piecewise-linear sources are grid points
  (:meth:`MLCS.breakpoints`), so it switches exactly at the crossing;
* any other switch takes the state its control had at the start of the step; when
  the step's end shows its control across a threshold, the step is taken again, split
  at the located crossing (:mod:`circuitnsds.engine.events`, :meth:`GridStepping.split_step`).

Steps whose mode (active pairs, switch states, step class) is already known run
through :mod:`circuitnsds.engine.dense_loop` (one affine map per step, checked for
complementarity, the modes kept in a table; a step that leaves its mode continues
there in another stored mode when that is certainly its solution); a step that leaves
its mode otherwise is solved as a full MLCP, which decides the next mode.

This module knows nothing about netlists: it takes an :class:`MLCS`, a grid
and a starting point.
"""

from __future__ import annotations

import time as wallclock
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from itertools import repeat
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from circuitnsds.arrays import sorted_unique
from circuitnsds.engine.dense_loop import (
    STOP_LEFT_MODE,
    FreeSwitches,
    ModeMap,
    ModeTable,
    dense_mode_map,
    run_table,
)
from circuitnsds.engine.events import (
    MAX_EVENTS_PER_STEP,
    MIN_FRACTION,
    TIME_TOLERANCE,
    SwitchEvent,
    chattering_error,
    regula_falsi,
    switch_events,
)
from circuitnsds.engine.loop_choice import LoopChoice
from circuitnsds.engine.step_system import StepSystem, check_theta, mode_blocks, step_system
from circuitnsds.errors import SimulationError
from circuitnsds.solvers import LCPError, LCPNoSolution, MLCPSolver
from circuitnsds.solvers.linalg import SIGN_TOL
from circuitnsds.system.mlcs import MLCS
from circuitnsds.system.stimuli import Dc

if TYPE_CHECKING:
    from circuitnsds.engine.sparse_loop import CompiledSparseMap

SOLVER_CACHE_SIZE = 32
"""How many (step size, switch states) keep their MLCP solver (and its factorisations)."""
MODE_CACHE_SIZE = 256
"""How many modes keep their step map."""
DENSE_MAP_LIMIT = 64
"""Largest ``n + m`` (unknowns + pairs) whose modes get dense step maps in the mode table;
larger circuits keep a sparse LU per mode, stepped by :mod:`circuitnsds.engine.sparse_loop`.
Measured on the diode-RC ladder (``benchmarks/performance.py``), µs per mapped step,
dense / sparse: N = 10 sections 0.79 / 0.90, 30: 1.21 / 0.99, 50: 2.46 / 1.46,
100: 10.3 / 2.95. The dense table also changes modes without leaving the compiled
loop, which is what converters (small ``n``, many switchings) need."""
# With θ < 1, how many implicit-Euler steps follow a switching into a mode whose θ-step has
# an eigenvalue below -RINGING_FACTOR (GridStepping.rings). One is not enough there: it leaves
# the fast mode (Ron·C, τ << h) a residue 1/(1 + h/τ) of its jump, which the θ = ½ step then
# carries with factor -(1 - h/2τ)/(1 + h/2τ) ≈ -1 for ever (a gate RC closing a 10 mΩ switch
# onto 3 nF at h = 1 ns rang ±30 A about 1.2 A). Four leave 1/(1 + h/τ)⁴ (i(s1) then swings
# 0.004 % of 1.2 A there; three left 0.12 %, and a PWM-driven switch closing the same way
# 2 %). Other switchings keep one: each extra implicit-Euler step costs accuracy on the slow
# modes (benchmarks/restart_steps.py; docs/method.md).
RESTART_STEPS = 4
RINGING_FACTOR = 0.5
RINGING_CHECK_LIMIT = 400  # unknowns + pairs: a dense eigenvalue problem per mode met
STEPPINGS = ("auto", "compiled", "numpy", "mlcp")
"""The stepping strategies of :func:`integrate` (its ``stepping`` argument)."""
ENUMERATED_PAIRS = 4
"""Up to this many pairs, a partial step of event location tries every active set as a
dense solve before calling the MLCP solver (16 solves of a small system cost less than
building one solver)."""
CHUNK = 100_000
"""Longest run of mapped steps between progress reports."""


def trajectory_bytes(mlcs: MLCS, points: int) -> int:
    """Memory [bytes] :func:`integrate` allocates for ``points`` grid points: the unknowns,
    pair currents, impulses, active sets, switch states and source values of every point
    (what :class:`Trajectory` keeps, plus the per-point work arrays)."""
    per_point = (8 * mlcs.n + 17 * mlcs.m + len(mlcs.switches) + 8 * len(mlcs.stimuli)
                 + 8 * 4)  # time, residual, mode index, step class
    return int(points) * per_point


@dataclass
class Trajectory:
    """Raw result of :func:`integrate` (one row per grid point).

    Attributes:
        time: grid [s], shape ``(N,)``.
        y: MNA unknowns, shape ``(N, n)``.
        current: pair currents ``μ/h`` [A], shape ``(N, m)`` (row 0: initial); for a step
            split at a switching, the current of its last part (the one at that point).
        impulse: pair impulses ``μ`` [C] of the step ending at each point (row 0: 0), summed
            over the parts of a split step.
        residual: scaled complementarity residual of each step solved as an MLCP;
            0 for a step taken by the mode map (its signs are checked, see
            :mod:`circuitnsds.engine.dense_loop`).
        active: active set of each step, shape ``(N, m)``.
        switches: state (closed = true) of each switch during the step ending at
            each point, shape ``(N, number of switches)`` (row 0: the initial state).
            After a step split at a located switching, the state at its end.
        stats: counters (steps, mapped_steps and the mapped_seconds spent in them,
            mlcp_steps, modes built, factorisations, cache hits, fallbacks (MLCP steps whose
            guess was wrong), pivoting_solves and lemke_fallbacks among them, events,
            event_solves (partial steps solved to locate them), seconds).
        events: every switching, in time order: located instants of circuit-controlled
            switches, grid points of source-controlled ones.
        tails: for each point ending a split step, the unknowns at the start of its last
            part and that part's length [s] (what the point's capacitor currents are
            taken over: the point holds that part's state).
        exact_rows: ``(N,)`` bool, or ``None`` (none): the points that are a closed form at
            their instant (the exact stepper's), whose capacitor currents are ``C dv/dt``
            there (:func:`circuitnsds.engine.exact.rates.state_rates`), not ΔQ/Δt of the
            step into them.
    """

    time: np.ndarray
    y: np.ndarray
    current: np.ndarray
    impulse: np.ndarray
    residual: np.ndarray
    active: np.ndarray
    switches: np.ndarray
    stats: dict[str, float] = field(default_factory=dict)
    events: list[SwitchEvent] = field(default_factory=list)
    tails: dict[int, tuple[np.ndarray, float]] = field(default_factory=dict)
    exact_rows: np.ndarray | None = None


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
    stepping: str = "auto",
    cache: dict | None = None,
    continued: bool = False,
    segments: Segments | None = None,
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
        stepping: how steps whose mode is known are taken (one of :data:`STEPPINGS`):
            ``"auto"`` (the default) by the mode loops, in Python until the steps left
            are worth loading the compiled loop (:mod:`circuitnsds.engine.loop_choice`;
            the sparse loop of large circuits always compiled; with the C loop built at
            install, compiled from the start), ``"compiled"`` by the compiled loops from
            the start (the table loop in C when it was built at install, else by numba,
            bit for bit the same; the same loops in Python when neither is there),
            ``"numpy"`` by the same loops in Python, ``"mlcp"`` by no loop: every step
            is solved as an MLCP. One scheme all four: the results agree to
            rounding.
        continued: ``grid[0]`` is not the start of the analysis but a point of a run
            continued from there (``y0`` etc. its state): the first step is a θ-step
            like the others, not the implicit-Euler restart of an initial state.
        cache: a dict the caller keeps between runs on the same grid (a shooting method
            runs one period again and again): the step solvers and mode maps built for
            this grid are kept in it and reused (``stats`` then count since it was made);
            ``cache["last"]`` is the stepping state of the last run.
        segments: a :class:`Segments` of the whole grid when ``grid`` is one of its parts,
            integrated in order (``continued`` for all but the first): the step solvers,
            mode maps and table built by the earlier parts are reused, and a continued
            part's first step is taken by the mode loop like any other (one run's arithmetic).
            The per-step arrays are reused too: the returned trajectory's arrays (but
            ``time``) are overwritten by the next part; copy what must outlive it.

    Raises:
        SimulationError: a source value or the state is not finite, or a step has no
            solution (names the time and devices); its ``trajectory`` field then holds the
            points computed before it, ``step_interval`` and ``switch_states`` the failing step.
    """
    theta = check_theta(theta)
    if stepping not in STEPPINGS:
        raise ValueError(f"stepping must be one of {', '.join(STEPPINGS)}, got {stepping!r}")
    mapped = stepping != "mlcp"
    stepping_name = stepping
    grid = np.asarray(grid, dtype=float)
    count, n, m = grid.size, mlcs.n, mlcs.m
    switches = mlcs.switches
    kept = None if segments is None else segments.buffers  # the per-step arrays of the parts
    y = _work(kept, "y", (count, n), float, zero=False)
    current = _work(kept, "current", (count, m), float)
    residual = _work(kept, "residual", (count,), float)
    active = _work(kept, "active", (count, m), bool)
    states = _work(kept, "states", (count, len(switches)), bool)
    y[0] = y0
    if active0 is not None:
        active[0] = active0
    states[0] = (switches0 if switches0 is not None
                 else [switch.initially_on for switch in switches])

    loop = {"auto": None, "compiled": True}.get(stepping_name, False)
    if segments is not None and _segmentable(mlcs):
        stepping, choice = segments.enter(mlcs, grid, theta, tol, states[0], continued, loop)
        offset, total = segments.offset, segments.total
    else:
        stepping = _stepping_for(cache, mlcs, grid, theta, tol, states[0], continued)
        choice = LoopChoice(loop, unknowns=n, watched=stepping.free.size)
        offset, total = 0, count - 1
    started = wallclock.perf_counter()
    clock = {"last": started, "reported": False}

    def _report() -> None:
        if progress is not None and wallclock.perf_counter() - clock["last"] > 0.5:
            clock["last"], clock["reported"] = wallclock.perf_counter(), True
            progress(grid[k], grid[-1])

    charge = charge0 if charge0 is not None else mlcs.E @ y[0]
    guess = active0
    # the active set last seen with each switch state (kept across the parts of a run)
    last_active: dict[bytes, np.ndarray] = {} if segments is None else segments.last_active
    stats = {"steps": count - 1, "mapped_steps": 0, "mlcp_steps": 0, "modes": 0}
    used = _work(kept, "used", (count,), np.int64)  # the table mode of each mapped step
    left_mode_at = -1  # a step the mode loop found leaving its mode (the MLCP takes it)

    events: list[SwitchEvent] = []
    split_impulses: dict[int, np.ndarray] = {}  # the charge of each step split at a switching
    tails: dict[int, tuple[np.ndarray, float]] = {}  # (y, length) of each split step's last part
    restart = False  # a switching located at the end of the previous step

    def so_far(last: int) -> list[SwitchEvent]:
        """The switchings up to grid point ``last`` (for a run that stops there)."""
        return sorted([e for e in events if e.time <= grid[last]]
                      + stepping.scheduled_events(states[:last + 1]))

    def split(k: int) -> None:
        """A circuit-controlled switch's control crossed its threshold during step k - 1:
        take that step again, split at the crossing(s)."""
        nonlocal guess, restart, charge, events
        previous = charge0 if k == 1 and charge0 is not None else mlcs.E @ y[k - 1]
        try:
            parts = stepping.split_step(k - 1, states[k - 1], states[k], previous, y[k - 1],
                                        active[k])
        except SimulationError as exc:
            raise _stopped(exc, k - 1, grid, y, current, residual, active, states, stats,
                           so_far(k - 1)) from None
        # the state and pair currents at t_k are those of the last part (so that every
        # sample obeys the device laws); the step's charge is the sum over its parts
        y[k], current[k], residual[k] = parts.result.u, parts.result.z, parts.result.residual
        split_impulses[k] = parts.impulse
        tails[k] = (np.array(parts.parts[-1].y_start), parts.parts[-1].length)
        active[k] = guess = np.asarray(parts.result.active, dtype=bool)
        states[k] = parts.states
        events += parts.events
        stepping.splits[k - 1] = parts.parts
        # a switching inside the step: its rest was implicit Euler, but perhaps too short to
        # damp a fast mode (restart_longer)
        restart = parts.at_end or (bool(parts.events) and stepping.rings(k, states[k], guess))
        last_active[states[k].tobytes()] = guess
        charge = mlcs.E @ y[k]

    stepping.splits = {}
    k = 0
    try:
        while k < count - 1:
            if k > 0 and stepping.crossings(states[k], y[k]):
                split(k)
            states[k + 1] = stepping.switch_states(k, states[k], y[k])
            changed = (k > 0 or continued) and (restart or bool((states[k + 1] != states[k]).any()))
            restart = False
            if changed:
                stepping.restart_longer(k, states[k + 1], last_active.get(states[k + 1].tobytes(), guess))
                # a switch changed: the pairs most likely take the mode they had the last
                # time the switches were in this state (the other phase of a converter)
                guess = last_active.get(states[k + 1].tobytes(), guess)
            cls = stepping.restart_class(k) if changed else int(stepping.step_class[k])
            if (k > 0 or continued) and guess is not None and k != left_mode_at and mapped:
                use = (choice.compiled(offset + k, total - offset - k) if stepping.dense
                       else choice.mode is not False)
                last_step = min(count - 1, k + (CHUNK if use else choice.python_chunk()))
                done, reason, guess = stepping.run_mapped(k, last_step, cls, states[k + 1],
                                                          guess, y, current, active, used, use)
                choice.record(use, done - k, stepping.searches)
                # step `done` left the mode the loop continued with (same class and switch state
                # as the step before): the MLCP solves it. After a change the loop tried the mode
                # stored for the new state; the guess (the set last seen with it) may differ.
                left_mode_at = done if (reason == STOP_LEFT_MODE and done > k
                                        and stepping.continues(done)) else -1
                if done > k:
                    finite = np.isfinite(y[k + 1:done + 1])
                    if not finite.all():  # (flat: one fast pass; the rows only to name the step)
                        bad = k + 1 + int(np.argmin(finite.all(axis=1)))
                        raise _stopped(_non_finite(mlcs, grid, y, bad), bad - 1, grid, y, current,
                                       residual, active, states, stats, so_far(bad - 1))
                    states[k + 1:done + 1] = states[k + 1]  # the state-controlled switches held
                    if stepping.scheduled.size:
                        states[k + 1:done + 1, stepping.scheduled] = stepping.schedule[k:done]
                    last_active[states[done].tobytes()] = guess
                    stats["mapped_steps"] += done - k
                    k, charge = done, None
                    _report()
                    continue  # the next step decides its states and mode afresh
            if charge is None:
                charge = mlcs.E @ y[k]
            try:
                result = stepping.solve_step(k, cls, states[k + 1], charge, y[k], guess)
            except SimulationError as exc:  # keep what was computed: the caller writes it
                raise _stopped(exc, k, grid, y, current, residual, active, states, stats,
                               so_far(k)) from None
            y[k + 1] = result.u  # finite: the solver raises rather than return NaN or inf
            current[k + 1] = result.z
            residual[k + 1] = result.residual
            active[k + 1] = guess = np.asarray(result.active, dtype=bool)
            last_active[states[k + 1].tobytes()] = guess
            stats["mlcp_steps"] += 1
            charge = mlcs.E @ y[k + 1]
            k += 1
            _report()

        if count > 1 and stepping.crossings(states[-1], y[-1]):
            split(count - 1)  # a crossing in the last step is located too (a period's end)
    except KeyboardInterrupt as exc:  # Ctrl-C: keep the points computed so far (grid points
        # 0 .. k are complete whatever the loop was doing), as for a failed step
        _stopped(exc, k, grid, y, current, residual, active, states, stats, so_far(k))
        raise
    impulse = _work(kept, "impulse", (count, m), float, zero=False)
    impulse[0] = 0.0
    np.multiply(current[1:], np.diff(grid)[:, None], out=impulse[1:])
    for row, charge_of_step in split_impulses.items():
        impulse[row] = charge_of_step
    if current0 is not None:
        current[0] = current0
    stats.update(stepping.counters(), mapped_seconds=stepping.mapped_seconds)
    events = sorted(events + stepping.scheduled_events(states))
    stats.update(events=len(events), event_solves=stepping.event_solves)
    stats["seconds"] = wallclock.perf_counter() - started
    if segments is not None:
        segments.offset += count - 1
    if progress is not None and clock["reported"]:
        progress(grid[-1], grid[-1])
    return Trajectory(grid, y, current, impulse, residual, active, states, stats, events, tails)


class _DenseMode(NamedTuple):
    """Dense pieces of one mode's bordered step system (:meth:`GridStepping.dense_pieces`):
    the top-left block is ``E/τ − ΘA``, filled in for each partial step length ``τ``."""

    E: np.ndarray
    A: np.ndarray
    WA: np.ndarray
    weights: np.ndarray
    S: np.ndarray
    e: np.ndarray
    bordered: np.ndarray
    pair_rhs: np.ndarray
    act: np.ndarray
    inact: np.ndarray
    C_in: np.ndarray
    D_in: np.ndarray
    absC_in: np.ndarray
    absD_in: np.ndarray


class _Solved(NamedTuple):
    """A partial step solved in a known mode (the fields of an MLCP result the loop reads)."""

    u: np.ndarray
    z: np.ndarray
    active: np.ndarray
    residual: float


class SplitPart(NamedTuple):
    """One part of a step split at located switchings (θ = 1 parts; read by
    :mod:`circuitnsds.engine.step_maps` for the saltation term).

    Attributes:
        start: offset of the part's start from the step's start [s].
        length: the part's length [s] (it ends at ``start + length``).
        states: switch states during the part.
        y_start: the unknowns at the part's start (``E y_start`` is what it carries in).
        u, z: its solution (unknowns at its end, pair currents [A]); ``active`` its active set.
        theta: the part's θ (1 unless it is the first part of a θ < 1 step).
        row: the free switch (row of ``GridStepping.free``) whose control crosses its threshold
            at the part's end, or -1 when the part ends at the step's end (a fixed instant).
    """

    start: float
    length: float
    states: np.ndarray
    y_start: np.ndarray
    u: np.ndarray
    z: np.ndarray
    active: np.ndarray
    theta: float
    row: int


@dataclass
class _Split:
    """A step taken again in parts at located switchings (:meth:`GridStepping.split_step`).

    Attributes:
        result: the MLCP result of the last part (state and active set at the step's end).
        impulse: pair charges of the whole step, summed over its parts [C].
        states: switch states at the end of the step.
        events: the switchings located in the step.
        at_end: the last switching happened at the very end of the step (the next step
            is the first in the new state).
        parts: the parts the step was taken in (:class:`SplitPart`).
    """

    result: object
    impulse: np.ndarray
    states: np.ndarray
    events: list[SwitchEvent]
    at_end: bool
    parts: list[SplitPart]


def _stepping_for(cache: dict | None, mlcs: MLCS, grid: np.ndarray, theta: float, tol: float,
                  initial_states: np.ndarray, continued: bool = False) -> GridStepping:
    """The :class:`GridStepping` of this grid and start, from ``cache`` when it holds one."""
    if cache is None:
        return GridStepping(mlcs, grid, theta, tol, initial_states, continued)
    key = (id(mlcs), theta, tol, initial_states.tobytes(), grid.tobytes(), continued)
    if key not in cache:
        cache[key] = GridStepping(mlcs, grid, theta, tol, initial_states, continued)
    cache["last"] = cache[key]  # what the caller reads the step maps from
    return cache[key]


class Segments:
    """What the segments of one run keep between them (:func:`integrate`'s ``segments``).

    A run integrated part by part (:func:`circuitnsds.engine.driver.drive` with the θ stepper,
    :class:`~circuitnsds.engine.theta_stepper.ThetaStepper`: each part a slice of ``grid``, in
    order, each ``continued`` from the last state of the one before) builds its step solvers,
    their factorisations, the mode maps and the mode table once, not once per part: the step
    classes are numbered from the whole grid's step sizes, so that a class (and the table's
    keys) mean the same in every part. The loop choice
    (:class:`~circuitnsds.engine.loop_choice.LoopChoice`) counts the whole run's steps. The
    parts of a run must share ``mlcs``, ``theta``, ``tol`` and ``stepping``.
    """

    def __init__(self, grid: np.ndarray):
        steps = np.diff(np.asarray(grid, dtype=float))
        self.sizes, self.classes = _sizes_and_classes(steps)  # (classes: of every step)
        self.total = steps.size  # steps of the whole run
        self.grid = grid
        self.corners: np.ndarray | None = None  # with θ < 1: the whole grid's corner steps
        self.offset = 0  # steps of the parts done
        self.stepping: GridStepping | None = None
        self.choice: LoopChoice | None = None
        self.last_active: dict[bytes, np.ndarray] = {}  # active set last seen per switch state
        self.buffers: dict[str, np.ndarray] = {}  # per-step arrays, reused by the next part

    def enter(self, mlcs: MLCS, grid: np.ndarray, theta: float, tol: float,
              initial_states: np.ndarray, continued: bool, loop: bool | None
              ) -> tuple[GridStepping, LoopChoice]:
        """The stepping state and loop choice for the next part, ``grid``."""
        classes = self.classes[self.offset:self.offset + grid.size - 1]
        corners = None
        if theta != 1.0:  # found once for the whole grid (each part's search began at t = 0)
            if self.corners is None:
                self.corners = _corner_steps(mlcs, self.grid)
            end = self.offset + grid.size - 1
            corners = self.corners[(self.corners >= self.offset) & (self.corners < end)] - self.offset
        if self.stepping is None or self.stepping.mlcs is not mlcs:
            self.stepping = GridStepping(mlcs, grid, theta, tol, initial_states, continued, self.sizes,
                                      classes, self.buffers, corners)
            self.choice = LoopChoice(loop, unknowns=mlcs.n, watched=self.stepping.free.size)
        else:
            self.stepping.target(grid, initial_states, continued, classes, self.buffers, corners)
        return self.stepping, self.choice


@dataclass
class _StepSolver:
    """The MLCP solver of one step size and switch state, with its step system."""

    solver: MLCPSolver
    system: StepSystem


class GridStepping:
    """Everything the θ-method's time loop needs that depends on the grid, cached per step
    class and mode (the stepping state of :func:`integrate`; :mod:`circuitnsds.engine.step_maps`
    reads its mode maps, :meth:`build_mode` and :meth:`dense_pieces`, and its split steps).

    Steps are grouped in *classes*: equal step sizes (to 1e-9 relative; grid rounding is
    ~1e-16·t) share one, and a *restart* step of each size has a class of its own. A
    restart step is implicit Euler whatever θ is: the first step, and with θ < 1 the step
    after a switch changes state, whose ``y_k`` holds the algebraic unknowns of the old
    switch state (the θ-method's explicit part would carry them into the new one, an
    O(h) error at every switching instant), and the step after a source's corner
    (:func:`_corner_steps`).
    """

    def __init__(self, mlcs: MLCS, grid: np.ndarray, theta: float, tol: float,
                 initial_states: np.ndarray, continued: bool = False,
                 sizes: tuple[float, np.ndarray] | None = None, classes: np.ndarray | None = None,
                 buffers: dict | None = None, corners: np.ndarray | None = None):
        self.mlcs, self.theta, self.tol = mlcs, theta, tol
        self.differential = mlcs.differential_rows
        if sizes is None or classes is None:  # (else the whole grid's sizes, this grid's classes)
            sizes, classes = _sizes_and_classes(np.diff(grid))
        self.step_sizes = sizes
        self.sizes = self.step_sizes[1].size
        self.target(grid, initial_states, continued, classes, buffers, corners)
        free = [j for j, s in enumerate(mlcs.switches) if s.control_stimulus is None]
        self.free = np.array(free, dtype=np.int64)
        controls = np.zeros((len(free), mlcs.n))
        for row, j in enumerate(free):
            for column, value in mlcs.switches[j].control:
                controls[row, column] += value
        self.free_controls = controls
        self.free_on = np.array([mlcs.switches[j].on_threshold for j in free])
        self.free_off = np.array([mlcs.switches[j].off_threshold for j in free])
        self._no_free = FreeSwitches(controls, self.free_on, self.free_off, np.zeros(0, dtype=bool))
        self._free_ids: dict[bytes, int] = {}
        self._ringing: dict[tuple, bool] = {}  # see rings()
        self.solvers: OrderedDict[tuple, _StepSolver] = OrderedDict()
        self.retired: list[_StepSolver] = []
        self.dense = mlcs.n + mlcs.m <= DENSE_MAP_LIMIT
        self.table = (ModeTable(mlcs.n, mlcs.m, len(mlcs.stimuli), most=MODE_CACHE_SIZE)
                      if self.dense else None)
        self.unmappable: set[tuple] = set()
        self.modes: dict[tuple, CompiledSparseMap | None] = {}
        self.dense_maps: dict[tuple, ModeMap | None] = {}
        self.built = 0
        self.mapped_seconds = 0.0
        self.event_solves = 0
        self.searches = 0  # mode changes found by searching the table in the last run_mapped
        self._dense_cache: dict[tuple, _DenseMode] = {}
        self.splits: dict[int, list[SplitPart]] = {}  # the last run's split steps
        self._counted = self.counters(absolute=True)  # the solvers' counters before this grid
        self._restart_scheduled_longer()

    def target(self, grid: np.ndarray, initial_states: np.ndarray, continued: bool,
               classes: np.ndarray, buffers: dict | None = None,
               corners: np.ndarray | None = None) -> None:
        """Aim at ``grid`` (a part of the grid whose step sizes :attr:`step_sizes` numbers, or
        the whole of it; ``classes``: the class of each of its steps, by those sizes): the
        sources' values (into the array ``"sources"`` of ``buffers``, the parts' per-step
        arrays, when given), step classes and switch schedule of its steps.
        The step solvers, maps and mode table, keyed by class and switch states, stay:
        a run continued in segments builds each of them once (see :class:`Segments`).
        ``corners``: with θ < 1, the steps of ``grid`` that start at a source's corner, when
        known (:class:`Segments` finds them once for the whole grid); else found here."""
        mlcs, theta = self.mlcs, self.theta
        self.grid = grid
        self.sources = source_values(mlcs, grid, None if buffers is None else _work(
            buffers, "sources", (grid.size, len(mlcs.stimuli)), float, zero=False))
        self.base_class = classes
        self.scheduled, self.schedule, self.sched_state = _switch_schedule(
            mlcs, grid, self.sources, initial_states)
        # a restart step's class is its size's plus the number of sizes
        self.step_class = classes.astype(np.int64)  # (a copy: classes may be the whole grid's)
        # a continued run's first step restarts only if a scheduled switch changes there (or,
        # with θ < 1, a source's slope jumps there: as in one run)
        restart = np.zeros(self.step_class.size, dtype=bool)
        if theta != 1.0:
            restart[1 + np.flatnonzero(self.sched_state[1:] != self.sched_state[:-1])] = True
            restart[_corner_steps(mlcs, grid) if corners is None else corners] = True
            restart[0] &= continued
        restart[0] |= not continued or (theta != 1.0 and self.scheduled.size > 0 and bool(
            (self.schedule[0] != initial_states[self.scheduled]).any()))
        self.step_class[restart] += self.sizes
        self._restarts = np.flatnonzero(restart)  # (see _restart_scheduled_longer)
        if not continued or not hasattr(self, "_start_states"):  # (parts: as one run began)
            self._start_states = np.asarray(initial_states, dtype=bool).copy()
        # the longer restarts that a switching near the previous part's end asks of this one's
        # first steps (restart_longer), so that the parts take the steps of one run
        carried, self._carry = (getattr(self, "_carry", 0) if continued else 0), 0
        self.step_class[:carried] = classes[:carried] + self.sizes
        if hasattr(self, "_ringing"):  # (a new part; the first is done at the end of __init__)
            self._restart_scheduled_longer()
        if hasattr(self, "_counted"):  # a new part: the counters start again
            self._counted = self.counters(absolute=True)
            self.built = 0
            self.mapped_seconds = 0.0
            self.event_solves = 0

    def restart_class(self, k: int) -> int:
        """Class of step ``k`` when a switch changed state at ``t_k``."""
        return int(self.base_class[k]) + (self.sizes if self.theta != 1.0 else 0)

    def rings(self, k: int, states: np.ndarray, active: np.ndarray | None) -> bool:
        """Whether the θ-step of step ``k``'s size in the mode (switch ``states``, pairs
        ``active``) has an eigenvalue with real part below ``-RINGING_FACTOR``: a mode so
        fast for the step (Ron·C, τ < h/3 at θ = ½) that the θ-method carries what is left
        of its jump on alternating in sign. Circuits of up to ``RINGING_CHECK_LIMIT`` unknowns
        (others: ``False``); every stepping path asks the same, so all take the same steps."""
        if self.theta == 1.0 or self.mlcs.n + self.mlcs.m > RINGING_CHECK_LIMIT or active is None:
            return False
        cls = int(self.base_class[k])
        key = (cls, states.tobytes(), np.asarray(active, dtype=bool).tobytes())
        if key not in self._ringing:
            mode = self.build_mode(k, cls, states, np.asarray(active, dtype=bool))
            n = self.mlcs.n
            self._ringing[key] = mode is not None and bool(
                (np.linalg.eigvals(mode.P[:n, :n]).real < -RINGING_FACTOR).any())
        return self._ringing[key]

    def _restart_scheduled_longer(self) -> None:
        """:meth:`restart_longer` for the restarts known before the run (the first step, the
        switchings of source-controlled switches, the sources' corners), which the mode loop
        takes without coming back here: the scheduled state of each is examined once, with
        the other switches as the run (not the part) began and no pair conducting (a switch closing
        onto a capacitor, or a source's jump across Ron·C, rings whatever the diodes do).
        A PWL source dropping 1 V across 1 Ω into 1 µF at h = 10 µs left i(r1) alternating
        -91, +61, -40 mA after its corner."""
        marks = self._restarts
        if self.theta == 1.0 or not marks.size:
            return
        none = np.zeros(self.mlcs.m, dtype=bool)
        ringing = []
        for state in np.unique(self.sched_state[marks]):
            k = int(marks[np.argmax(self.sched_state[marks] == state)])
            states = self._start_states.copy()
            if self.scheduled.size:
                states[self.scheduled] = self.schedule[k]
            if self.rings(k, states, none):
                ringing.append(state)
        marks = marks[np.isin(self.sched_state[marks], ringing)]
        for later in range(1, RESTART_STEPS):
            after = marks[marks + later < self.step_class.size] + later
            self.step_class[after] = self.base_class[after] + self.sizes
        if marks.size:
            self._carry = max(self._carry, int(marks[-1]) + RESTART_STEPS - self.step_class.size)

    def restart_longer(self, k: int, states: np.ndarray, active: np.ndarray | None) -> None:
        """After a switching at ``t_k`` into a mode that :meth:`rings`, make the
        ``RESTART_STEPS - 1`` steps after step ``k`` restarts (implicit Euler) too."""
        if self.rings(k, states, active):
            after = slice(k + 1, min(k + RESTART_STEPS, self.step_class.size))
            self.step_class[after] = self.base_class[after] + self.sizes
            # (steps beyond this part's end: the next part's first, see target)
            self._carry = max(self._carry, k + RESTART_STEPS - self.step_class.size)

    def theta_of(self, cls: int) -> float:
        return 1.0 if cls >= self.sizes else self.theta

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

    def crossings(self, states: np.ndarray, y: np.ndarray) -> list[int]:
        """Rows (in :attr:`free`) of the circuit-controlled switches whose control at ``y``
        calls for a change from ``states``."""
        if not self.free.size:
            return []
        values = self.free_controls @ y
        on = states[self.free]
        return [row for row in range(self.free.size)
                if (values[row] < self.free_off[row] if on[row] else values[row] > self.free_on[row])]

    def source_at(self, t: float) -> np.ndarray:
        """Every source's value at ``t`` [s] (a partial step ends between grid points)."""
        return np.array([stimulus.value(t) for stimulus in self.mlcs.stimuli], dtype=float)

    def partial_step(self, k: int, start: float, length: float, theta: float, states: np.ndarray,
                     charge: np.ndarray, y: np.ndarray, guess: np.ndarray | None,
                     other: np.ndarray | None = None):
        """The MLCP step of ``length`` [s] from ``grid[k] + start`` with ``states`` held: first
        the mode ``guess`` (then ``other``) as one dense bordered solve (small circuits),
        checked for complementarity; the MLCP solver when both fail."""
        t0 = self.grid[k] + start
        self.event_solves += 1
        f0, f1 = self.source_at(t0), self.source_at(t0 + length)
        if self.dense:
            for mode in self._candidate_modes(guess, other):
                solved = self._mode_solve(length, theta, states, charge, y, f0, f1, mode)
                if solved is not None:
                    return solved
        system = step_system(self.mlcs, length, states, theta, dense=self.dense)
        solver = MLCPSolver(system.K, -system.B, system.C, system.D, tol=self.tol)
        rhs = system.rhs(charge, y, f0, f1)
        if not np.isfinite(rhs).all():  # an overflow (a huge .ic), not an MLCP to solve
            raise SimulationError(
                f"the state overflows in the part of a step from t = {t0:.6g} s to {t0 + length:.6g} s "
                f"(largest |value| {np.abs(y).max():.3g})", where=f"t = {t0 + length:.6g} s",
                time=float(t0 + length), cause=SimulationError.STATE_NOT_FINITE)
        try:
            return solver.solve(-rhs, self.mlcs.e, guess=guess)
        except LCPError as exc:
            raise _step_failure(self.mlcs, t0, t0 + length, exc, guess, states) from None

    def _candidate_modes(self, guess: np.ndarray | None, other: np.ndarray | None):
        """Active sets to try as dense solves: ``guess``, ``other``, then, with at most
        :data:`ENUMERATED_PAIRS` pairs, every other one (the first that passes the sign test
        is the step's solution when it is unique, as for a P-matrix)."""
        tried: set[bytes] = set()
        for mode in (guess, other):
            if mode is not None and mode.tobytes() not in tried:
                tried.add(mode.tobytes())
                yield mode
        m = self.mlcs.m
        if m <= ENUMERATED_PAIRS:
            for bits in range(2**m):
                mode = np.array([(bits >> j) & 1 for j in range(m)], dtype=bool)
                if mode.tobytes() not in tried:
                    yield mode

    def _mode_solve(self, length: float, theta: float, states: np.ndarray, charge: np.ndarray,
                    y: np.ndarray, f0: np.ndarray, f1: np.ndarray, active: np.ndarray
                    ) -> _Solved | None:
        """The step of the mode ``active`` as one dense solve of its bordered system
        (:func:`circuitnsds.engine.step_system.mode_blocks`, densely); ``None`` when the
        matrix is singular or a sign is wrong (beyond :data:`SIGN_TOL` of the terms)."""
        mode = self.dense_pieces(states, active, theta)
        n = mode.E.shape[0]
        rhs = charge / length + mode.weights * (mode.S @ f1)
        if theta != 1.0:
            rhs += (1.0 - mode.weights) * (mode.A @ y + mode.S @ f0)
        matrix = mode.bordered.copy()
        matrix[:n, :n] = mode.E / length - mode.WA
        try:
            x = np.linalg.solve(matrix, np.concatenate([rhs, mode.pair_rhs]))
        except np.linalg.LinAlgError:
            return None
        if not np.isfinite(x).all():
            return None
        u, z = x[:n], np.zeros(mode.e.size)
        z[mode.act] = x[n:]
        if (z[mode.act] < -SIGN_TOL * (np.abs(z).max(initial=0.0) + 1e-300)).any():
            return None
        if mode.inact.size:
            w = mode.C_in @ u + mode.D_in @ z + mode.e[mode.inact]
            terms = mode.absC_in @ np.abs(u) + mode.absD_in @ np.abs(z) + np.abs(mode.e[mode.inact])
            if (w < -SIGN_TOL * terms).any():
                return None
        z[mode.act] = np.maximum(z[mode.act], 0.0)
        return _Solved(u, z, np.asarray(active, dtype=bool).copy(), 0.0)

    def dense_pieces(self, states: np.ndarray, active: np.ndarray, theta: float) -> _DenseMode:
        """The dense pieces of a mode's bordered step system (cached; small circuits only)."""
        key = (states.tobytes(), np.asarray(active, dtype=bool).tobytes(), theta)
        mode = self._dense_cache.get(key)
        if mode is None:
            mlcs = self.mlcs
            E = mlcs.E.toarray()
            A = mlcs.system_matrix(tuple(bool(s) for s in states)).toarray()
            B, C, D = mlcs.B.toarray(), mlcs.C.toarray(), mlcs.D.toarray()
            act = np.flatnonzero(active)
            inact = np.flatnonzero(~np.asarray(active, dtype=bool))
            n = E.shape[0]
            weights = np.where(self.differential, theta, 1.0)
            bordered = np.zeros((n + act.size, n + act.size))
            bordered[:n, n:] = -B[:, act]
            bordered[n:, :n] = C[act]
            bordered[n:, n:] = D[np.ix_(act, act)]
            mode = _DenseMode(E, A, weights[:, None] * A, weights, mlcs.S.toarray(), mlcs.e,
                              bordered, -mlcs.e[act], act, inact, C[inact], D[inact],
                              np.abs(C[inact]), np.abs(D[inact]))
            self._dense_cache[key] = mode
        return mode

    def split_step(self, k: int, before: np.ndarray, states: np.ndarray, charge: np.ndarray,
                   y: np.ndarray, guess: np.ndarray | None) -> _Split:
        """Step ``k`` again, split where circuit-controlled switches change state
        (:mod:`circuitnsds.engine.events`). ``before``: the states of step ``k - 1`` (for
        the step's θ), ``states``: those of step ``k``, ``charge``: ``E y_k``."""
        h = self.grid[k + 1] - self.grid[k]
        restart = k == 0 or bool((before != states).any()) or self.step_class[k] >= self.sizes
        theta = 1.0 if restart else self.theta
        states = states.copy()
        start, impulse, events, parts = 0.0, np.zeros(self.mlcs.m), [], []
        while True:
            rest = h - start
            end = self.partial_step(k, start, rest, theta, states, charge, y, guess)
            rows = self.crossings(states, end.u)
            if not rows:
                impulse += end.z * rest
                parts.append(SplitPart(start, rest, states.copy(), y, end.u, end.z,
                                       np.asarray(end.active, dtype=bool), theta, -1))
                return _Split(end, impulse, states, events, False, parts)
            if len(events) >= MAX_EVENTS_PER_STEP:
                name = self.mlcs.switches[self.free[rows[0]]].name
                raise chattering_error(name, self.grid[k], self.grid[k + 1], events)
            first, row = min(self._crossing_time(k, start, rest, theta, states, charge, y, guess,
                                                 end, r) for r in rows)
            j = int(self.free[row])
            if first >= rest - MIN_FRACTION * h:  # at the end of the step
                impulse += end.z * rest
                parts.append(SplitPart(start, rest, states.copy(), y, end.u, end.z,
                                       np.asarray(end.active, dtype=bool), theta, -1))
                states[j] = not states[j]
                events.append(SwitchEvent(float(self.grid[k + 1]), self.mlcs.switches[j].name,
                                          bool(states[j])))
                return _Split(end, impulse, states, events, True, parts)
            if first > MIN_FRACTION * h:
                part = self.partial_step(k, start, first, theta, states, charge, y, guess,
                                         end.active)
                parts.append(SplitPart(start, first, states.copy(), y, part.u, part.z,
                                       np.asarray(part.active, dtype=bool), theta, row))
                impulse += part.z * first
                y, guess = part.u, np.asarray(part.active, dtype=bool)
                charge = self.mlcs.E @ y
                start += first
            states[j] = not states[j]
            events.append(SwitchEvent(float(self.grid[k] + start), self.mlcs.switches[j].name,
                                      bool(states[j])))
            theta = 1.0  # the rest starts in a new switch state: implicit Euler (a restart)

    def _crossing_time(self, k, start, rest, theta, states, charge, y, guess, end, row
                       ) -> tuple[float, int]:
        """``(τ, row)``: when in ``[0, rest]`` the control of free switch ``row`` crosses the
        threshold it is heading for, the others held in ``states``."""
        j = int(self.free[row])
        closing = not states[j]
        threshold = self.free_on[row] if closing else self.free_off[row]
        control = self.free_controls[row]
        g1 = float(control @ end.u) - threshold

        def g(tau: float) -> float:
            return float(control @ self.partial_step(k, start, tau, theta, states, charge, y,
                                                     guess, end.active).u) - threshold

        def crossed(value: float) -> bool:
            return value > 0 if closing else value < 0

        h = self.grid[k + 1] - self.grid[k]
        shortest = MIN_FRACTION * h
        if crossed(float(control @ y) - threshold) or shortest >= rest:
            return 0.0, row  # already across at the start (the control jumped)
        g0 = g(shortest)
        if crossed(g0):  # across within the shortest partial step: at the start
            return 0.0, row
        return regula_falsi(g, shortest, rest, g0, g1, TIME_TOLERANCE * h), row

    def scheduled_events(self, states: np.ndarray) -> list[SwitchEvent]:
        """The switchings of source-controlled switches: at the grid point where the state
        of a step differs from the step before's (the threshold crossing is that grid point)."""
        events = []
        for j in self.scheduled:
            changes = np.flatnonzero(states[2:, j] != states[1:-1, j]) + 1
            # (built from lists by map: a converter switches ~10^4 times a run)
            events += switch_events(self.grid[changes].tolist(), repeat(self.mlcs.switches[j].name),
                                    states[changes + 1, j].tolist())
        return events

    def free_switch_arrays(self, states: np.ndarray) -> FreeSwitches:
        """Controls, thresholds and current states of the switches the loop must watch."""
        if not self.free.size:
            return self._no_free
        return FreeSwitches(self.free_controls, self.free_on, self.free_off, states[self.free])

    def free_id(self, states: np.ndarray) -> int:
        """A small integer naming the states of the state-controlled switches."""
        return self._free_ids.setdefault(states[self.free].tobytes(), len(self._free_ids))

    def _step_solver(self, k: int, cls: int, states: np.ndarray) -> _StepSolver:
        key = (cls, states.tobytes())
        if key in self.solvers:
            self.solvers.move_to_end(key)
            return self.solvers[key]
        h = self.grid[k + 1] - self.grid[k]
        # rows divided by h: node rows in amperes, the pair unknowns are currents μ/h
        # (same solution; the solver's normwise test then weighs currents, not charges,
        # against the voltages, and a wrong-signed current of microamperes is caught)
        system = step_system(self.mlcs, h, states, self.theta_of(cls), dense=self.dense)
        if not system.finite:
            raise SimulationError(
                f"the step from t = {self.grid[k]:.6g} s (h = {h:.3g} s) gives equations that are "
                "not finite (capacitance/h or inductance/h overflows)", where=f"t = {self.grid[k]:.6g} s",
                time=float(self.grid[k]), cause=SimulationError.STEP_NOT_FINITE)
        solver = MLCPSolver(system.K, -system.B, system.C, system.D, tol=self.tol)
        self.solvers[key] = _StepSolver(solver, system)
        if len(self.solvers) > SOLVER_CACHE_SIZE:
            self.retired.append(self.solvers.popitem(last=False)[1])
        return self.solvers[key]

    def solve_step(self, k: int, cls: int, states: np.ndarray, charge: np.ndarray, y: np.ndarray,
                   guess: np.ndarray | None):
        """Solve step ``k`` (of class ``cls``) as an MLCP (see module docstring)."""
        step = self._step_solver(k, cls, states)
        rhs = step.system.rhs(charge, y, self.sources[k], self.sources[k + 1])
        if not np.isfinite(rhs).all():
            t1 = self.grid[k + 1]
            raise SimulationError(
                f"the state overflows in the step from t = {self.grid[k]:.6g} s to {t1:.6g} s "
                f"(largest |value| {np.abs(y).max():.3g})", where=f"t = {t1:.6g} s", time=float(t1),
                cause=SimulationError.STATE_NOT_FINITE)
        try:
            return step.solver.solve(-rhs, self.mlcs.e, guess=guess)
        except LCPError as exc:
            raise _step_failure(self.mlcs, self.grid[k], self.grid[k + 1], exc, guess,
                                states) from None

    def run_mapped(self, k: int, k_end: int, cls: int, states: np.ndarray, guess: np.ndarray,
                   y: np.ndarray, current: np.ndarray, active: np.ndarray, used: np.ndarray,
                   compiled: bool) -> tuple[int, int | None, np.ndarray]:
        """Take steps ``k, k+1, ...`` (up to ``k_end``) with step maps, starting in the mode of
        class ``cls``, switch ``states`` and active set ``guess``: the mode table (dense) or
        one sparse mode. Writes ``y``, ``current`` and ``active`` of the steps done.

        Returns ``(done, reason, guess)``: the first step not done, the loop's ``STOP_*``
        code (``None`` when the mode has no map) and the active set of the last step done.
        """
        self.searches = 0
        if self.dense:
            mode = self.dense_mode(k, cls, states, guess)
        else:
            mode = self.sparse_mode(k, cls, states, guess)
        if mode is None:
            return k, None, guess
        entered = wallclock.perf_counter()  # mapped_seconds: stepping, not building maps
        free = self.free_switch_arrays(states)
        if self.dense:
            done, reason, last = run_table(self.table, mode, cls, k, k_end, y, current, self.sources,
                                           self.step_class, self.sched_state, self.free_id(states),
                                           free, used, use_compiled=compiled)
            # (take, not fancy indexing: rows of a few bytes copied 8x faster)
            np.take(self.table.mask, used[k + 1:done + 1], axis=0, out=active[k + 1:done + 1])
            self.searches = self._searches(mode, used[k + 1:done + 1]) if done > k else 0
            if done > k:
                guess = self.table.mask[last].copy()
        else:
            # a restart step found at run time (a state-controlled switch changed) is one
            # step of its own: the steps after it are of the ordinary class
            from circuitnsds.engine.sparse_loop import run_compiled_sparse  # large circuits only

            last_step = k + 1 if cls != self.step_class[k] else k_end
            done, reason = run_compiled_sparse(mode, k, last_step, y, current, self.sources,
                                               self.step_class, self.sched_state, *free,
                                               use_compiled=compiled)
            active[k + 1:done + 1] = guess
        self.mapped_seconds += wallclock.perf_counter() - entered
        return done, reason, guess

    def _searches(self, mode: int, modes: np.ndarray) -> int:
        """How many of the steps taken in table ``modes`` (``mode`` before them) changed to a
        mode of the same class and switch states: mode changes the loop found by searching
        the table (the others follow a change of step size or scheduled switch states)."""
        if modes.size == 0:
            return 0
        changed = np.flatnonzero(modes[1:] != modes[:-1])  # (few: compared only where it changed)
        after, before = modes[changed + 1], modes[changed]
        if modes[0] != mode:
            after, before = np.append(after, modes[0]), np.append(before, mode)
        table = self.table
        same = ((table.mode_class[before] == table.mode_class[after])
                & (table.mode_sched[before] == table.mode_sched[after]))
        return int(np.count_nonzero(same))

    def continues(self, k: int) -> bool:
        """Whether step ``k`` has the class and scheduled switch states of step ``k - 1``."""
        return bool(self.step_class[k] == self.step_class[k - 1]
                    and self.sched_state[k] == self.sched_state[k - 1])

    def dense_mode(self, k: int, cls: int, states: np.ndarray, guess: np.ndarray) -> int | None:
        """Index in :attr:`table` of the mode (class, switch states, active set ``guess``) of
        step ``k``, built if new; ``None`` when its step matrix is singular."""
        key = (cls, int(self.sched_state[k]), self.free_id(states), guess.tobytes())
        found = self.table.find(key)
        if found is not None or key in self.unmappable:
            return found
        mode = self.build_mode(k, cls, states, guess)
        self.built += 1
        if mode is None:
            self.unmappable.add(key)
            return None
        unique = self._step_solver(k, cls, states).solver.unique_solutions()
        return self.table.add(key, mode, unique=unique)

    def sparse_mode(self, k: int, cls: int, states: np.ndarray, guess: np.ndarray
                    ) -> CompiledSparseMap | None:
        """The factorised step map of the mode of step ``k`` (large circuits)."""
        key = (cls, states.tobytes(), guess.tobytes())
        mode = self.modes.get(key, False)
        if mode is False:
            if len(self.modes) >= MODE_CACHE_SIZE:
                self.modes.clear()  # a circuit visiting this many modes gains little from maps
            mode = self.modes[key] = self._build_sparse_mode(k, cls, states, guess)
            self.built += 1
        return mode

    def build_mode(self, k: int, cls: int, states: np.ndarray, guess: np.ndarray) -> ModeMap | None:
        """The dense step map of a mode (``None``: its bordered matrix is singular), kept for
        the mode table and the step maps of :mod:`circuitnsds.engine.step_maps` alike."""
        key = (cls, states.tobytes(), guess.tobytes())
        if key not in self.dense_maps:
            if len(self.dense_maps) >= MODE_CACHE_SIZE:
                self.dense_maps.clear()
            blocks = mode_blocks(self._step_solver(k, cls, states).system, guess, dense=True)
            self.dense_maps[key] = dense_mode_map(blocks, self.mlcs.n)
        return self.dense_maps[key]

    def _build_sparse_mode(self, k: int, cls: int, states: np.ndarray, guess: np.ndarray
                           ) -> CompiledSparseMap | None:
        """The factorised step map of a mode, as the compiled loop's arrays (``None``: singular)."""
        from circuitnsds.engine.sparse_loop import sparse_mode_map  # large circuits only

        blocks = mode_blocks(self._step_solver(k, cls, states).system, guess)
        return sparse_mode_map(blocks, self.mlcs.n)

    def counters(self, absolute: bool = False) -> dict[str, int]:
        """The solvers' counters and the modes built, since the last :meth:`target`
        (``absolute``: since this object was made; ``modes`` always since the last target)."""
        totals = dict.fromkeys(("factorisations", "cache_hits", "fallbacks", "pivoting_solves",
                                "lemke_fallbacks"), 0)
        for step in list(self.solvers.values()) + self.retired:
            for key in totals:
                totals[key] += step.solver.stats.get(key, 0)
        if not absolute and hasattr(self, "_counted"):
            totals = {key: value - self._counted[key] for key, value in totals.items()}
        totals["modes"] = self.built
        return totals


def _sizes_and_classes(steps: np.ndarray) -> tuple[tuple[float, np.ndarray], np.ndarray]:
    """``((quantum, sizes), classes)``: the distinct step sizes of ``steps`` as integers of the
    quantum 1e-9 of the largest step (equal to that precision: one size), sorted, and the class
    of each step: the rank of its size (int8 when there are fewer than 128 sizes). Most steps
    have one size (the most frequent in a sample of 64): only the others are sorted."""
    quantum = 1e-9 * steps.max()
    rounded = np.divide(steps, quantum)
    np.round(rounded, out=rounded)  # (in place: one array of the grid's size, not two)
    sample = rounded[::max(1, rounded.size // 64)].tolist()
    common = max(set(sample), key=sample.count)  # (not the middle step: that of a flyback's
    # 300,600 is one of the 1,200 its gate's threshold crossings split)
    table = sorted_unique(np.append(rounded[rounded != common], common))
    return (quantum, table), _ranks(table, rounded)


def _ranks(table: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``np.searchsorted(table, values)`` (how many entries of the sorted ``table`` are below
    each value; no NaN), as int8 for a table of fewer than 128 entries, else int64: for a
    short table one comparison per entry, 5-10x faster than numpy's binary search for each
    value."""
    if table.size > 4:
        ranks = np.searchsorted(table, values)
        return ranks.astype(np.int8) if table.size < 128 else ranks.astype(np.int64)
    ranks = np.zeros(values.size, dtype=np.int8)
    for entry in table.tolist():
        ranks += values > entry
    return ranks


def source_values(mlcs: MLCS, grid: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Every source's value at every grid point, shape ``(N, number of sources)`` (written
    into ``out`` when given)."""
    values = np.empty((grid.size, len(mlcs.stimuli))) if out is None else out
    with np.errstate(all="ignore"):
        for column, stimulus in enumerate(mlcs.stimuli):
            # (a constant written as it is: no array of it made first)
            values[:, column] = stimulus.level if type(stimulus) is Dc else stimulus.sample(grid)
        finite = np.isfinite(values.sum())  # (one pass: a NaN or an infinity makes the sum so)
    if not finite and not np.isfinite(values).all():  # (else a finite sum that overflowed)
        row, column = np.argwhere(~np.isfinite(values))[0]
        rows = mlcs.S.rows[mlcs.S.cols == column]
        owners = tuple(mlcs.unknowns[r] for r in rows)
        raise SimulationError(
            f"a source function is {values[row, column]} at t = {grid[row]:.6g} s "
            f"({', '.join(owners) or 'a source'}: {mlcs.stimuli[column]})", where=f"t = {grid[row]:.6g} s",
            time=float(grid[row]), unknowns=owners, cause=SimulationError.SOURCE_NOT_FINITE)
    return values


def _corner_steps(mlcs: MLCS, grid: np.ndarray) -> np.ndarray:
    """Indices of the steps of ``grid`` that start where a source's slope jumps (a breakpoint
    of :meth:`MLCS.breakpoints`: a PULSE or PWL corner, a SIN's delay).

    With θ < 1 such a step is a restart (implicit Euler), as ngspice takes a first-order step
    after a breakpoint: the θ-method's explicit part would carry the slope before the corner
    into the step after it, and the algebraic currents it sets (that of a capacitor across a
    source) would alternate about their value for ever, the trapezoidal rule not damping."""
    if grid.size < 2:
        return np.zeros(0, dtype=np.int64)
    points = np.asarray(mlcs.breakpoints(grid[-1]), dtype=float)
    tolerance = 1e-9 * float(np.diff(grid).max())  # (breakpoints are grid points, merged to 1e-9·h)
    points = points[(points >= grid[0] - tolerance) & (points < grid[-1] - tolerance)]
    if not points.size:
        return np.zeros(0, dtype=np.int64)
    index = np.clip(np.searchsorted(grid, points), 1, grid.size - 1)
    nearest = np.where(np.abs(grid[index - 1] - points) <= np.abs(grid[index] - points), index - 1, index)
    found = nearest[np.abs(grid[nearest] - points) <= tolerance]
    return found[found < grid.size - 1]


def _switch_schedule(mlcs: MLCS, grid: np.ndarray, sources: np.ndarray,
                     initial: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """States of the source-controlled switches for every step, from their control at the
    step's midpoint (with hysteresis, starting from ``initial``).

    Returns ``(switch indices, states (steps, count), state id per step)``: steps with
    the same scheduled states have the same id, and only they.
    """
    scheduled = [j for j, s in enumerate(mlcs.switches) if s.control_stimulus is not None]
    steps = grid.size - 1
    states = np.zeros((steps, len(scheduled)), dtype=bool)
    if not scheduled:
        return np.zeros(0, dtype=np.int64), states, np.zeros(steps, dtype=np.int64)
    middles = np.add(grid[:-1], grid[1:])
    middles *= 0.5  # (0.5·(a + b), in place: one array)
    for column, j in enumerate(scheduled):
        switch = mlcs.switches[j]
        stimulus, sign = switch.control_stimulus
        control = mlcs.stimuli[stimulus].sample(middles)
        if sign != 1:  # (a product by 1 is the same number)
            control = sign * control
        on = control > switch.on_threshold
        off = control < switch.off_threshold
        if (on | off).all():  # no step inside the hysteresis band (e.g. VH = 0): no memory
            states[:, column] = on
            continue
        decided = np.where(on, 1, np.where(off, 0, -1))
        last = np.maximum.accumulate(np.where(decided >= 0, np.arange(steps), -1))
        states[:, column] = np.where(last >= 0, decided[np.maximum(last, 0)] == 1, initial[j])
    if len(scheduled) == 1:
        ids = states[:, 0].astype(np.int64)
    elif len(scheduled) < 63:  # the states as the bits of one integer
        ids = np.zeros(steps, dtype=np.int64)
        for column in range(len(scheduled)):
            ids |= states[:, column].astype(np.int64) << column
    else:
        ids = np.unique(states, axis=0, return_inverse=True)[1].reshape(-1).astype(np.int64)
    return np.array(scheduled, dtype=np.int64), states, ids


def _work(buffers: dict | None, name: str, shape: tuple, dtype, zero: bool = True) -> np.ndarray:
    """A per-step array of ``shape`` (zeros if ``zero``): new, or, with ``buffers`` (the
    parts of one run, :class:`Segments`), the first rows of the array ``name`` an earlier part
    used, so that a long run does not map and zero fresh memory for every part (page faults:
    ~0.1 s per part of a 1,000-section ladder)."""
    if buffers is None:
        return np.zeros(shape, dtype) if zero else np.empty(shape, dtype)
    kept = buffers.get(name)
    if kept is None or kept.shape[0] < shape[0] or kept.shape[1:] != shape[1:] or kept.dtype != dtype:
        kept = buffers[name] = np.empty(shape, dtype)
    array = kept[:shape[0]]
    if zero:
        array.fill(0)
    return array


def _segmentable(mlcs: MLCS) -> bool:
    """Whether the parts of a grid can share one stepping state: the ids of the scheduled
    switches' states are their bits (:func:`_switch_schedule`), the same in every part."""
    return sum(s.control_stimulus is not None for s in mlcs.switches) < 63


def _step_failure(mlcs: MLCS, t0: float, t1: float, exc: LCPError,
                  guess: np.ndarray | None = None, states: np.ndarray | None = None) -> SimulationError:
    """The error of a step whose MLCP has no (verified) solution.

    Carries the time, the devices of the active set tried first (those conducting in the
    previous step), the solver's best residual, the step's ``step_interval`` and
    ``switch_states``: what the caller needs to diagnose the step and to advise
    (:mod:`circuitnsds.checks.wellposed`, :mod:`circuitnsds.analyses.transient`).
    """
    conducting = [] if guess is None else [mlcs.pair_devices[j] for j in np.flatnonzero(guess)]
    conducting = list(dict.fromkeys(conducting))
    closed = [] if states is None else [s.name for s, on in zip(mlcs.switches, states) if on]
    residual = exc.residual
    verdict = "has no solution" if isinstance(exc, LCPNoSolution) else "could not be solved"
    details = [f"conducting before it: {', '.join(conducting) or 'none'}"]
    if mlcs.switches:
        details.append(f"closed switches: {', '.join(closed) or 'none'}")
    if residual is not None and np.isfinite(residual):
        details.append(f"best residual {residual:.2g}")
    return SimulationError(
        f"the time step from t = {t0:.6g} s to {t1:.6g} s {verdict} with ideal devices "
        f"({'; '.join(details)})",
        where=f"t = {t1:.6g} s", time=float(t1), devices=tuple(conducting), residual=residual,
        step_interval=(float(t0), float(t1)), cause=SimulationError.STEP_UNSOLVED,
        switch_states=None if states is None else np.array(states, dtype=bool))


def _non_finite(mlcs: MLCS, grid: np.ndarray, y: np.ndarray, k: int) -> SimulationError:
    """The error for the first grid point ``k`` whose state holds NaN or an infinity."""
    bad = np.flatnonzero(~np.isfinite(y[k]))
    names = ", ".join(f"{mlcs.unknowns[j]} = {y[k, j]}" for j in bad[:4])
    return SimulationError(
        f"the state is not finite at t = {grid[k]:.6g} s ({names}{', ...' if bad.size > 4 else ''})",
        where=f"t = {grid[k]:.6g} s", time=float(grid[k]), cause=SimulationError.STATE_NOT_FINITE)


def _stopped(error: BaseException, k: int, grid: np.ndarray, y: np.ndarray, current: np.ndarray,
             residual: np.ndarray, active: np.ndarray, states: np.ndarray,
             stats: dict, events: list[SwitchEvent]) -> BaseException:
    """``error`` (a :class:`SimulationError`, or the ``KeyboardInterrupt`` of a Ctrl-C) with
    its ``trajectory`` field set to the trajectory up to grid point ``k`` (the last good one)
    and its switchings ``events``, so that the caller can still write them."""
    end = k + 1
    impulse = np.zeros((end, current.shape[1]))
    impulse[1:] = current[1:end] * np.diff(grid[:end])[:, None]
    error.trajectory = Trajectory(grid[:end].copy(), y[:end].copy(), current[:end].copy(), impulse,
                                  residual[:end].copy(), active[:end].copy(), states[:end].copy(),
                                  dict(stats, steps=k), list(events))
    return error
