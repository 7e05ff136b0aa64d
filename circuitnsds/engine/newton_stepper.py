"""The Newton stepper: the θ-method for an MLCS with smooth nonlinear relations, each step a
mixed nonlinear complementarity problem solved by Newton–Josephy
(:mod:`circuitnsds.engine.newton_step`), the step length chosen by the local truncation
error (DESIGN.md, "Smooth nonlinear elements beside the ideal ones"; issue 33).

* **Steps onto the grid.** Every grid point is the end of a step: inside a grid interval
  the stepper takes steps of its own length (no interpolation), the last one ending on the
  point. The point's ``tails`` entry holds the start and length of that last step, so that
  a capacitor's current there is that of the step into it.
* **Step length.** A step whose Newton iteration fails is retried at an eighth of its
  length (SPICE's rule), down to :data:`MIN_STEP_FRACTION` of the grid's span. A step that
  converges is judged by its local truncation error, estimated from the second divided
  difference of the states (the unknowns ``E`` or a relation's charge carries) over the
  last two steps: ``|LTE| ≈ h²/(h + h_prev)·|Δy/h − Δy_prev/h_prev|``, compared with
  ``TRTOL·(RELTOL·|y| + atol)`` (ngspice's ``trtol`` 7, ``reltol`` 1e-3). Too large: the
  step is retried shorter; else the next one is longer (by ``(1/error)^½``, at most twice).
  No estimate is made across a switching, a change of active set or a source's corner
  (the scheme is first order there, and the estimate would only shrink the step for
  nothing); steps are not shortened below :data:`MIN_LTE_FRACTION` of the grid interval
  by the estimate.
* **θ.** As the θ stepper: θ on the rows that carry a time derivative, implicit Euler
  for the first step, after a switching, an active-set change and a source's corner.
* **Switches** take their state as in the θ stepper: a source-driven one from its control
  in the middle of the step, a circuit-controlled one from its control at the start; when
  a step's end shows a circuit-controlled control across its threshold, the step is retried
  ending at the crossing (secant on the control) until the crossing is within
  :data:`EVENT_TOLERANCE` of the grid interval of the step's end, and the switch changes
  state there (an event of the trajectory).

All matrices are dense: circuits with smooth devices are small (a Newton iteration
assembles and solves one ``n + m`` system).
"""

from __future__ import annotations

import math
import time as wallclock
from collections.abc import Callable

import numpy as np

from circuitnsds.engine.events import SwitchEvent
from circuitnsds.engine.integrate import Trajectory, source_values, trajectory_bytes
from circuitnsds.engine.newton_step import NewtonFailure, SmoothParts, newton_solve, update_tolerance
from circuitnsds.engine.step_system import check_theta
from circuitnsds.engine.stepper import StartState, Stepper
from circuitnsds.errors import SimulationError
from circuitnsds.system.mlcs import MLCS

TRTOL = 7.0
"""ngspice's ``trtol``: how many times the tolerance a step's truncation error may be."""
LTE_RELTOL = 1e-3
"""ngspice's ``reltol`` for the truncation error test."""
MIN_STEP_FRACTION = 1e-12
"""Shortest step, as a fraction of the grid's span, before a failed Newton stops the run."""
MIN_LTE_FRACTION = 1e-3
"""The truncation error estimate does not shorten a step below this fraction of its grid
interval (a switching circuit's fast edges would otherwise stall it)."""
EVENT_TOLERANCE = 1e-6
"""A switching is located to within this fraction of the grid interval it falls in."""
GROWTH = 2.0
"""A step is at most this many times the last one."""


class NewtonStepper(Stepper):
    """Newton–Josephy steps of variable length onto the grid (see the module docstring).

    Args:
        mlcs: the system (with or without smooth relations).
        theta: θ in [0.5, 1].
        tol: residual tolerance of each linear MLCP.
        loop: accepted for the θ stepper's settings; not used.
        lte: choose the step length by the truncation error (the default); ``False``: each
            grid interval is one step, cut only where Newton fails or a switching falls, so
            that the state at the grid's end is a smooth function of the state at its start
            (the periodic steady state's finite differences of the period map,
            :mod:`circuitnsds.analyses.pss_smooth`; an adaptive step's accept/reject choices
            made them noise at the 1e-5 level).
    """

    name = "newton"

    def __init__(self, mlcs: MLCS, *, theta: float = 1.0, tol: float = 1e-9, loop: str = "auto",
                 lte: bool = True):
        super().__init__(mlcs)
        self.lte = lte
        self.theta, self.tol = check_theta(theta), float(tol)
        self.parts = SmoothParts(mlcs)
        self.E = mlcs.E.toarray()
        self.S = mlcs.S.toarray()
        self.blocks = (mlcs.B.toarray(), mlcs.C.toarray(), mlcs.D.toarray(), np.asarray(mlcs.e, float))
        self.differential = mlcs.differential_rows.copy()
        states = np.abs(self.E).sum(axis=0) > 0
        for relation, inputs in zip(self.parts.relations, self.parts.inputs):
            rows = np.asarray(relation.rows, dtype=int)
            if relation.charges:
                self.differential[rows[rows >= 0]] = True
                states[inputs[inputs >= 0]] = True
        self.states = np.flatnonzero(states)
        self.atol = update_tolerance(mlcs)
        self._matrices: dict[tuple[bool, ...], np.ndarray] = {}
        self._modes: dict = {}  # each active set's pair blocks (newton_step._mode_solution)
        self.breaks = np.zeros(0)
        self.span = 1.0
        self.memory: dict = {}
        self._grid, self._grid_sources = np.zeros(0), np.zeros((0, len(mlcs.stimuli)))
        self.stats = dict.fromkeys(("steps", "newton_iterations", "rejected_newton", "rejected_lte",
                                    "mlcp_fallbacks", "events", "newton_seconds"), 0)

    @classmethod
    def unsuited(cls, mlcs: MLCS) -> str | None:
        return None

    def begin(self, grid: np.ndarray, *, parts: bool) -> None:
        self.span = float(grid[-1] - grid[0]) or 1.0
        self.breaks = self.mlcs.breakpoints(float(grid[-1])) if self.mlcs.stimuli else np.zeros(0)
        self.memory = {}

    def trajectory_bytes(self, points: int) -> int:
        return trajectory_bytes(self.mlcs, points)

    def _system(self, states: tuple[bool, ...]) -> np.ndarray:
        if states not in self._matrices:
            self._matrices[states] = self.mlcs.system_matrix(states).toarray()
        return self._matrices[states]

    def _switch_states(self, on: np.ndarray, y: np.ndarray, t: float, h: float) -> np.ndarray:
        """Each switch's state for a step from ``t`` of length ``h`` (module docstring)."""
        states = on.copy()
        for j, switch in enumerate(self.mlcs.switches):
            if switch.control_stimulus is not None:
                column, sign = switch.control_stimulus
                control = sign * self.mlcs.stimuli[column].value(t + 0.5 * h)
            else:
                control = switch.control_value(y)
            states[j] = switch.next_state(bool(on[j]), control)
        return states

    def _crossing(self, states: np.ndarray, y0: np.ndarray, y1: np.ndarray) -> tuple[int, float] | None:
        """The circuit-controlled switch whose control crosses its threshold first in a step
        from ``y0`` to ``y1`` and where (the secant's fraction of the step), or ``None``."""
        first = None
        for j, switch in enumerate(self.mlcs.switches):
            if switch.control_stimulus is not None:
                continue
            c1 = switch.control_value(y1)
            if switch.next_state(bool(states[j]), c1) == bool(states[j]):
                continue
            c0 = switch.control_value(y0)
            level = switch.off_threshold if states[j] else switch.on_threshold
            fraction = (level - c0) / (c1 - c0) if c1 != c0 else 1.0
            fraction = min(max(fraction, 0.0), 1.0)
            if first is None or fraction < first[1]:
                first = (j, fraction)
        return first

    def _step(self, y: np.ndarray, charge: np.ndarray, t: float, h: float, theta: float,
              states: np.ndarray, guess: np.ndarray | None):
        """One step from ``(y, charge)`` at ``t`` of length ``h``: the Newton result."""
        A = self._system(tuple(bool(s) for s in states))
        weights = np.where(self.differential, theta, 1.0)
        f_next = self._sources(t + h)
        carry = charge / h
        if self.parts.charges:
            totals = self.parts.totals(y, t)
            if totals is None:
                raise NewtonFailure("a smooth relation cannot be evaluated at the step's start", 0)
            carry = carry + totals[1] / h
        if theta != 1.0:
            f_now = self._sources(t)
            explicit = A @ y + self.S @ f_now
            totals = self.parts.totals(y, t)
            if totals is None:
                raise NewtonFailure("a smooth relation cannot be evaluated at the step's start", 0)
            explicit = explicit - totals[0]
            carry = carry + (1.0 - weights) * explicit
        base = self.E / h - weights[:, None] * A
        rhs = carry + weights * (self.S @ f_next)
        started = wallclock.perf_counter()
        try:
            return newton_solve(self.parts, base, rhs, weights, h, t + h, y, guess, self.blocks,
                                self.atol, self.tol, self._modes)
        finally:
            self.stats["newton_seconds"] += wallclock.perf_counter() - started

    def measure_step(self, y: np.ndarray, t: float, h: float, repeat: int = 5
                     ) -> tuple[float, int, float]:
        """The first step from the state ``y`` at ``t`` [s] as a run takes it (of length ``h``,
        else an eighth of it, as often as its Newton needs, at most four times), taken
        ``repeat`` times: ``(its length [s], its Newton iterations, the best time per
        iteration [s])`` (what ``info`` reports as the cost of a step).

        Raises:
            NewtonFailure: the step does not converge even at ``h/8⁴``.
        """
        on = np.array([switch.initially_on for switch in self.mlcs.switches], dtype=bool)
        for attempt in range(5):
            self._grid = np.array([t, t + h])
            self._grid_sources = source_values(self.mlcs, self._grid)
            states = self._switch_states(on, y, t, h)
            try:
                result = self._step(y, self.E @ y, t, h, 1.0, states, None)
                break
            except NewtonFailure:
                if attempt == 4:
                    raise
                h /= 8.0
        best = math.inf
        for _ in range(repeat):
            started = wallclock.perf_counter()
            result = self._step(y, self.E @ y, t, h, 1.0, states, None)
            best = min(best, (wallclock.perf_counter() - started) / result.iterations)
        return h, result.iterations, best

    def _sources(self, t: float) -> np.ndarray:
        """Every source's value at ``t`` [s]: the part's grid values at a grid point (sampled
        once per part), else each source's own value."""
        at = np.searchsorted(self._grid, t)
        if at < self._grid.size and self._grid[at] == t:
            return self._grid_sources[at]
        values = np.array([stimulus.value(t) for stimulus in self.mlcs.stimuli], dtype=float)
        if not np.isfinite(values).all():
            source_values(self.mlcs, np.array([t]))  # (raises the error naming the source)
        return values

    def _lte_error(self, y_new: np.ndarray, y: np.ndarray, h: float, previous) -> float:
        """The truncation error of a step over its tolerance (≤ 1 accepted), from the last step
        ``previous = (y_prev, h_prev)``."""
        y_prev, h_prev = previous
        s = self.states
        if not s.size:
            return 0.0
        slope_change = (y_new[s] - y[s]) / h - (y[s] - y_prev[s]) / h_prev
        lte = h * h / (h + h_prev) * np.abs(slope_change)
        allowed = TRTOL * (LTE_RELTOL * np.maximum(np.abs(y_new[s]), np.abs(y[s])) + self.atol[s])
        return float(np.max(lte / allowed))

    def advance(self, grid: np.ndarray, start: StartState, *, continued: bool,
                progress: Callable[[float, float], None] | None = None) -> Trajectory:
        mlcs, N = self.mlcs, grid.size
        n, m, k = mlcs.n, mlcs.m, len(mlcs.switches)
        clock = wallclock.perf_counter()
        self.stats = dict.fromkeys(self.stats, 0)  # each part's own counts (recorders sum them)
        self._grid, self._grid_sources = grid, source_values(mlcs, grid)
        Y = np.zeros((N, n))
        current, impulse = np.zeros((N, m)), np.zeros((N, m))
        active_rows = np.zeros((N, m), dtype=bool)
        switch_rows = np.zeros((N, k), dtype=bool)
        residual = np.zeros(N)
        events: list[SwitchEvent] = []
        tails: dict[int, tuple[np.ndarray, float]] = {}
        y = np.array(start.y, dtype=float)
        charge = self.E @ y if start.charge is None else np.array(start.charge, dtype=float)
        on = (np.array([s.initially_on for s in mlcs.switches], dtype=bool)
              if start.switches is None else np.array(start.switches, dtype=bool))
        active = None if start.active is None else np.array(start.active, dtype=bool)
        Y[0] = y
        if start.current is not None:
            current[0] = start.current
        if active is not None:
            active_rows[0] = active
        switch_rows[0] = on
        memory = self.memory if continued else {}
        h_try = memory.get("h_try", grid[1] - grid[0] if N > 1 else 0.0)
        previous = memory.get("previous")  # (y, h) of the last step, for the LTE estimate
        restart = memory.get("restart", True) if continued else True
        failure_at = None
        try:
            for i in range(1, N):
                t_end = grid[i]
                interval = t_end - grid[i - 1]
                t = grid[i - 1]
                substeps = 0
                last_start, last_h = y, interval
                step_impulse = np.zeros(m)
                corner = bool(np.any(np.abs(self.breaks - t) <= 1e-12 * max(abs(t), self.span)))
                restart = restart or corner
                if not self.lte:
                    h_try = interval
                while t < t_end:
                    remaining = t_end - t
                    h = min(h_try, remaining)
                    if remaining - h < 1e-3 * h:  # no sliver before the grid point
                        h = remaining
                    states = self._switch_states(on, y, t, h)
                    switched = not np.array_equal(states, on)
                    theta = 1.0 if (restart or switched) else self.theta
                    failure_at = (t, t + h, states)
                    try:
                        result = self._step(y, charge, t, h, theta, states, active)
                    except NewtonFailure as exc:
                        self.stats["rejected_newton"] += 1
                        self.stats["newton_iterations"] += exc.iterations
                        h_try = h / 8.0
                        if h_try < MIN_STEP_FRACTION * self.span:
                            raise SimulationError(
                                f"the Newton iteration of the smooth elements does not converge "
                                f"at t = {t + h:.6g} s, even at a step of {h:.3g} s ({exc.reason})",
                                where=f"t = {t + h:.6g} s", time=t + h, step_interval=(t, t + h),
                                switch_states=states.copy(), cause=SimulationError.STEP_UNSOLVED
                            ) from None
                        continue
                    self.stats["newton_iterations"] += result.iterations
                    self.stats["mlcp_fallbacks"] += result.fallbacks
                    y_new = result.y
                    if not np.isfinite(y_new).all():
                        raise SimulationError("the state is not finite", time=t + h,
                                              cause=SimulationError.STATE_NOT_FINITE)
                    crossing = self._crossing(states, y, y_new)
                    if crossing is not None and crossing[1] * h > EVENT_TOLERANCE * interval:
                        if crossing[1] < 1.0 - 1e-3:  # end the step at the crossing
                            h_try = max(crossing[1] * h * (1.0 + 1e-4), MIN_STEP_FRACTION * self.span)
                            continue
                    changed = active is None or not np.array_equal(result.active, active)
                    if self.lte and previous is not None and not (restart or switched or changed):
                        error = self._lte_error(y_new, y, h, previous)
                        if error > 1.0 and h > MIN_LTE_FRACTION * interval:
                            self.stats["rejected_lte"] += 1
                            h_try = max(h * max(0.25, 0.9 / math.sqrt(error)),
                                        MIN_LTE_FRACTION * interval)
                            continue
                        h_next = h * (GROWTH if error == 0 else min(GROWTH, max(1.0, 0.9 / math.sqrt(error))))
                    else:
                        h_next = h
                    # accepted
                    self.stats["steps"] += 1
                    substeps += 1
                    for j in np.flatnonzero(states != on):
                        events.append(SwitchEvent(float(t), mlcs.switches[j].name, bool(states[j])))
                    self.stats["events"] += int(np.count_nonzero(states != on))
                    on = states
                    last_start, last_h = y, h
                    previous = (y, h)
                    step_impulse += h * result.z
                    y, active = y_new, result.active
                    charge = self.E @ y
                    t = t_end if h == remaining else t + h
                    restart = False
                    if crossing is not None:  # the control crossed at the step's end
                        j = crossing[0]
                        switch = mlcs.switches[j]
                        nxt = on.copy()
                        nxt[j] = switch.next_state(bool(on[j]), switch.control_value(y))
                        if nxt[j] != on[j]:
                            events.append(SwitchEvent(float(t), switch.name, bool(nxt[j])))
                            self.stats["events"] += 1
                            on = nxt
                            restart = True
                    h_try = h_next
                Y[i] = y
                current[i] = result.z if substeps else current[i - 1]
                impulse[i] = step_impulse
                active_rows[i] = active if active is not None else False
                switch_rows[i] = on
                if substeps > 1:
                    tails[i] = (last_start.copy(), last_h)
                if progress is not None and i % 1000 == 0:
                    progress(float(t_end), float(grid[-1]))
                failure_at = None
        except (SimulationError, KeyboardInterrupt) as exc:
            last = i if "i" in locals() else 1
            exc.trajectory = Trajectory(grid[:last].copy(), Y[:last], current[:last], impulse[:last],
                                        residual[:last], active_rows[:last], switch_rows[:last],
                                        self._stats(clock), events, tails)
            raise
        self.memory = {"h_try": h_try, "previous": previous, "restart": restart}
        return Trajectory(grid.copy(), Y, current, impulse, residual, active_rows, switch_rows,
                          self._stats(clock), events, tails)

    def _stats(self, clock: float) -> dict[str, float]:
        stats = {key: (float(value) if key.endswith("seconds") else int(value))
                 for key, value in self.stats.items()}
        stats["seconds"] = wallclock.perf_counter() - clock
        return stats
