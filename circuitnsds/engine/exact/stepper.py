"""The exact integrator as a stepper (:mod:`circuitnsds.engine.stepper`): events located to
round-off, the state between them in closed form (:func:`~.run.run_exact`), rows written
at the grid's points.

The grid does not steer the integration: the event loop runs from event to event (and
source corner), and each grid point is the closed form evaluated there. ``.tran TSTEP``
therefore sets the rows reported, not the accuracy. A run in parts keeps the loop's state
(:class:`~.run.LoopState`, the start of the segment holding the part's last point) and
computes that segment again in the next part: the arithmetic of one run.

What a row holds (the contract's :class:`~circuitnsds.engine.integrate.Trajectory`):

* ``y``, ``current``: the closed form at the point (at an event: the segment ending there);
* ``impulse`` [C]: each pair's charge ``∫ λ dt`` over the interval ending at the point, from
  the closed form (:mod:`.charge`), summed over the segments in it;
* ``active``, ``switches``: the mode of the segment the point ends;
* ``residual``: 0 (the signs of every pair are certified between events, as the θ-stepper's
  mapped steps report 0);
* ``tails``: a θ stretch's split steps' (what their capacitor currents are taken over); none
  for the exact loop's points (below);
* ``exact_rows``: the points the exact loop wrote (not a θ stretch's, not the first point
  of a run): their capacitor currents are ``C dv/dt`` at the point
  (:func:`~.rates.state_rates`), as every other current there is the one at that instant;
* ``events``: every event, diodes' (a pair's name; ``state`` true: conducting) as well as
  switches'.

**Hand-off to θ.** Where the loop finds no mode that holds (:class:`~.run.Chattering`: a
comparator without hysteresis sliding on its threshold, a latch that does not settle) or a
mode it cannot reduce to state equations (:class:`~.mode.NotIndexOne`: a capacitor closed
onto a source by a conducting diode, an inductor's current cut, whose jumps are impulses),
the stretch from the last point written goes to the θ-method
(:func:`~circuitnsds.engine.integrate.integrate`, Moreau's impulses included) for
:data:`HANDOFF_STEPS` grid steps, doubled each time the exact loop fails again at once;
then the exact loop starts again from the θ state. ``stats`` counts the hand-offs and
their steps, and the analyses say so.
"""

from __future__ import annotations

import time as wallclock
from collections.abc import Callable

import numpy as np

from circuitnsds.engine.events import SwitchEvent
from circuitnsds.engine.exact.mode import NotIndexOne
from circuitnsds.engine.exact.run import Chattering, ExactRun, ExactSystem, LoopState, run_exact
from circuitnsds.engine.exact.sources import supported
from circuitnsds.engine.integrate import STEPPINGS, Segments, Trajectory, integrate, trajectory_bytes
from circuitnsds.engine.step_system import check_theta
from circuitnsds.engine.stepper import StartState, Stepper
from circuitnsds.errors import SimulationError
from circuitnsds.system.mlcs import MLCS

HANDOFF_STEPS = 16
"""Grid steps the θ-method takes at a hand-off, at first (doubled at each hand-off that follows
one at once)."""
HANDOFF_CAUSES = {
    Chattering: "no mode holds after that instant: a sliding or chattering control, or a "
                "switching whose instant double precision does not resolve (docs/method.md)",
    NotIndexOne: "a mode without state equations (index 2: a capacitor held to a source, an "
                 "inductor's current cut), whose jumps the θ-method's impulses capture",
}
"""Why a stretch went to θ, in words, by the exception the exact loop stopped with."""
MAX_UNKNOWNS = 200
"""Largest ``n + m`` the exact integrator takes: its modes are dense eigen-decompositions."""


class ExactStepper(Stepper):
    """Event-driven exact integration (module docstring); ``theta``, ``tol`` and ``loop`` are
    the θ-method's at a hand-off.

    Raises:
        ValueError: θ out of range or an unknown ``loop``.
    """

    name = "exact"

    def __init__(self, mlcs: MLCS, *, theta: float = 1.0, tol: float = 1e-9, loop: str = "auto"):
        super().__init__(mlcs)
        if loop not in STEPPINGS:
            raise ValueError(f"stepping must be one of {', '.join(STEPPINGS)}, got {loop!r}")
        self.theta, self.tol, self.loop = check_theta(theta), tol, loop
        self.system: ExactSystem | None = None
        self.whole = np.zeros(0)
        self.theta_segments: Segments | None = None
        self.state: LoopState | None = None
        self.theta_until: int | None = None  # the whole grid's index a hand-off runs to
        self.handoff_steps = HANDOFF_STEPS
        self.handoffs: list[tuple[float, str]] = []
        """``(time [s], why)`` of each hand-off to θ in the run so far."""
        self.last_exact = False  # the last point of the part before: the exact loop's

    @classmethod
    def unsuited(cls, mlcs: MLCS) -> str | None:
        if mlcs.smooth:
            names = ", ".join(sorted({relation.name for relation in mlcs.smooth}))
            return f"it has smooth nonlinear elements ({names}), which are not piecewise linear"
        if mlcs.n + mlcs.m > MAX_UNKNOWNS:
            return (f"it has {mlcs.n} unknowns and {mlcs.m} pairs, more than the {MAX_UNKNOWNS} "
                    "the exact integrator's dense modes take")
        blind = [switch.name for switch in mlcs.switches if not switch.control]
        if blind:  # (a resistor stepping in time: its windows' switches follow a PWL alone)
            return (f"its switch(es) {', '.join(blind[:5])}{' ...' if len(blind) > 5 else ''} "
                    "follow a source's time function without a circuit quantity, which its "
                    "event functions do not see")
        if not supported(mlcs.stimuli):  # (AM, SFFM, a sawtooth: no closed-form piece)
            kinds = sorted({type(s).__name__.upper() for s in mlcs.stimuli if not supported([s])})
            owners = [owner or "?" for owner, s in zip(mlcs.stimulus_owners or [""] * len(mlcs.stimuli),
                                                       mlcs.stimuli) if not supported([s])]
            return (f"its source(s) {', '.join(owners[:5])}{' ...' if len(owners) > 5 else ''} "
                    f"({', '.join(kinds)}) have no closed form it integrates (it takes DC, PULSE, "
                    "PWL, SIN and EXP)")
        return None

    def begin(self, grid: np.ndarray, *, parts: bool) -> None:
        self.whole = grid
        self.theta_segments = None  # the hand-offs' stepping state, made at the first hand-off
        self.system = ExactSystem(self.mlcs)
        self.state = None
        self.theta_until = None
        self.handoff_steps = HANDOFF_STEPS
        self.handoffs = []
        self.last_exact = False

    def trajectory_bytes(self, points: int) -> int:
        return trajectory_bytes(self.mlcs, points)

    def advance(self, grid: np.ndarray, start: StartState, *, continued: bool,
                progress: Callable[[float, float], None] | None = None) -> Trajectory:
        began = wallclock.perf_counter()
        mlcs, count = self.mlcs, grid.size
        out = _Rows(mlcs, grid, start)
        out.exact[0] = continued and self.last_exact
        if not continued or self.state is None:
            self.state = self._loop_state(start.y, start.charge, out.active[0], out.switches[0],
                                          float(grid[0]), announced=False)
            self.theta_until = None
        offset = int(np.searchsorted(self.whole, grid[0]))
        row = 0
        while row < count - 1:
            if self.theta_until is not None:
                row = self._theta_stretch(out, row, offset)
                continue
            try:
                run = run_exact(mlcs, grid[row:], out.y[row], out.active[row],
                                tuple(out.switches[row]), resume=self.state, system=self.system,
                                stop=float(self.whole[-1]), out=out.views(row))
            except (Chattering, NotIndexOne) as exc:
                run = exc.run
                out.take(run, row)
                out.check_finite(row + 1, row + run.rows)
                # (the stepper's own record, not the part's: a run in parts doubles alike)
                failed_at_once = run.rows <= 1 and self.handoffs != []
                self.handoff_steps = 2 * self.handoff_steps if failed_at_once else HANDOFF_STEPS
                out.stats["handoffs"] += 1
                self.handoffs.append((float(exc.time), HANDOFF_CAUSES[type(exc)]))
                row += run.rows - 1
                self.theta_until = offset + row + self.handoff_steps
                continue
            out.take(run, row)
            out.check_finite(row + 1, row + run.rows)
            self.state = run.state
            row = count - 1
            if progress is not None:
                progress(float(grid[-1]), float(grid[-1]))
        out.stats["steps"] = count - 1
        out.stats["seconds"] = wallclock.perf_counter() - began
        self.last_exact = bool(out.exact[-1])
        return out.trajectory()

    def _theta_stretch(self, out: _Rows, row: int, offset: int) -> int:
        """The θ-method from ``row`` to the hand-off's end (or the part's); the exact loop
        starts again from its state there. Returns the row reached."""
        last = min(self.theta_until - offset, out.grid.size - 1)
        # (one stepping state for every stretch, placed at the stretch's steps of the whole
        # grid: a stretch cut by a part's end is then the stretch in one call, bit for bit)
        if self.theta_segments is None:  # (as one θ run's over the whole grid: 0.03 s for 1 M points)
            self.theta_segments = Segments(self.whole)
        self.theta_segments.offset = offset + row
        try:
            part = integrate(self.mlcs, out.grid[row:last + 1], out.y[row], None, out.current[row],
                             out.active[row], out.switches[row], theta=self.theta, tol=self.tol,
                             stepping=self.loop, continued=True, segments=self.theta_segments)
        except (SimulationError, KeyboardInterrupt) as exc:  # the part's rows before it, kept
            done = getattr(exc, "trajectory", None)
            if done is not None:
                out.take_theta(done, row)
                exc.trajectory = out.trajectory(row + done.time.size)
            raise
        out.take_theta(part, row)
        if last + offset >= self.theta_until:
            self.theta_until = None
            self.state = self._loop_state(out.y[last], None, out.active[last], out.switches[last],
                                          float(out.grid[last]), announced=False)
        return last

    def _loop_state(self, y: np.ndarray, charge: np.ndarray | None, active: np.ndarray,
                    switches: np.ndarray, t: float, *, announced: bool) -> LoopState:
        """The loop's state at a point from its unknowns (or its charges ``E y``)."""
        coordinates = self.system.coordinates
        if charge is not None:
            x = (coordinates.U1.T @ charge) / coordinates.sigma
            size = np.abs(coordinates.V1) @ np.abs(x)
        else:
            x = coordinates.V1.T @ y
            size = np.abs(y)
        return LoopState(t, x, size, np.asarray(active, dtype=bool).copy(),
                         tuple(bool(s) for s in switches), announced)


class _Rows:
    """The arrays of one part, filled from exact runs and θ stretches."""

    def __init__(self, mlcs: MLCS, grid: np.ndarray, start: StartState):
        count, n, m, k = grid.size, mlcs.n, mlcs.m, len(mlcs.switches)
        self.mlcs, self.grid = mlcs, grid
        self.y = np.zeros((count, n))
        self.current = np.zeros((count, m))
        self.impulse = np.zeros((count, m))
        self.residual = np.zeros(count)
        self.active = np.zeros((count, m), bool)
        self.switches = np.zeros((count, k), bool)
        self.exact = np.zeros(count, bool)
        self.y[0] = start.y
        if start.current is not None:
            self.current[0] = start.current
        if start.active is not None:
            self.active[0] = start.active
        self.switches[0] = (start.switches if start.switches is not None
                            else [s.initially_on for s in mlcs.switches])
        self.events: list[SwitchEvent] = []
        self.in_order = True
        self.tails: dict[int, tuple[np.ndarray, float]] = {}
        self.stats: dict[str, float] = {"exact_segments": 0, "events": 0, "handoffs": 0,
                                        "theta_steps": 0}

    def views(self, row: int) -> tuple[np.ndarray, ...]:
        """The part's arrays from ``row`` on, for :func:`~.run.run_exact` to write into."""
        return self.y[row:], self.current[row:], self.impulse[row:], self.active[row:], self.switches[row:]

    def take(self, run: ExactRun, row: int) -> None:
        """The rows ``1 .. run.rows - 1`` of an exact run started at ``row`` (copied unless the
        run wrote them in place: :meth:`views`)."""
        end = row + run.rows
        if not np.shares_memory(run.y, self.y):
            for name in ("y", "currents", "charges", "active", "closed"):
                source = getattr(run, name)[1:run.rows]
                target = {"currents": self.current, "charges": self.impulse, "closed": self.switches,
                          "y": self.y, "active": self.active}[name]
                target[row + 1:end] = source
        self.exact[row + 1:end] = True  # (their capacitor currents the instant's: no tails)
        self._add_events(run.events)
        self.stats["exact_segments"] += run.segments
        self.stats["events"] += len(run.events)

    def _add_events(self, events: list[SwitchEvent]) -> None:
        """Append a run's or a stretch's events (each in time order), noting whether the part's
        list is still in time order (then :meth:`trajectory` need not sort it: 60,000 events in
        the 100 ms buck)."""
        if events and self.events and events[0].time < self.events[-1].time:
            self.in_order = False
        self.events.extend(events)

    def take_theta(self, part: Trajectory, row: int) -> None:
        """The rows ``1..`` of a θ stretch started at ``row``."""
        end = row + part.time.size
        self.y[row + 1:end] = part.y[1:]
        self.current[row + 1:end] = part.current[1:]
        self.impulse[row + 1:end] = part.impulse[1:]
        self.residual[row + 1:end] = part.residual[1:]
        self.active[row + 1:end] = part.active[1:]
        self.switches[row + 1:end] = part.switches[1:]
        self.exact[row + 1:end] = False
        self.tails.update({row + k: tail for k, tail in part.tails.items() if k > 0})
        self._add_events(part.events)
        self.stats["theta_steps"] += part.time.size - 1
        self.stats["events"] += len(part.events)

    def check_finite(self, first: int, end: int) -> None:
        """Raise at the first of the rows ``first .. end - 1`` whose state is not finite (an
        unstable mode's exponential overflows: NaN or an infinity, never a silent result),
        with the trajectory of the rows before it.

        Raises:
            SimulationError: ``cause`` :attr:`~SimulationError.STATE_NOT_FINITE`.
        """
        if np.isfinite(np.add.reduce(self.y[first:end], axis=None)):
            return  # (one pass: a NaN or an infinity makes the sum so, an overflowing sum is checked)
        bad = ~np.isfinite(self.y[first:end]).all(axis=1)
        if bad.any():
            k = first + int(np.argmax(bad))
            error = _non_finite(self.mlcs, self.grid, self.y, k)
            error.trajectory = self.trajectory(k)
            raise error

    def trajectory(self, end: int | None = None) -> Trajectory:
        """The part's trajectory, or its rows before ``end`` (a failure's)."""
        if not self.in_order:
            self.events.sort(key=lambda event: event.time)
            self.in_order = True
        if end is None:
            return Trajectory(self.grid, self.y, self.current, self.impulse, self.residual,
                              self.active, self.switches, self.stats, self.events, self.tails,
                              self.exact)
        last = float(self.grid[end - 1])
        return Trajectory(self.grid[:end], self.y[:end], self.current[:end], self.impulse[:end],
                          self.residual[:end], self.active[:end], self.switches[:end],
                          dict(self.stats, steps=end - 1),
                          [event for event in self.events if event.time <= last],
                          {k: tail for k, tail in self.tails.items() if k < end}, self.exact[:end])


def _non_finite(mlcs: MLCS, grid: np.ndarray, y: np.ndarray, k: int) -> SimulationError:
    """The error for grid point ``k`` [index into ``grid``, s], whose state holds NaN or an
    infinity, worded as the θ-method's (``integrate._non_finite``)."""
    bad = np.flatnonzero(~np.isfinite(y[k]))
    names = ", ".join(f"{mlcs.unknowns[j]} = {y[k, j]}" for j in bad[:4])
    return SimulationError(
        f"the state is not finite at t = {grid[k]:.6g} s ({names}{', ...' if bad.size > 4 else ''})",
        where=f"t = {grid[k]:.6g} s", time=float(grid[k]), cause=SimulationError.STATE_NOT_FINITE)
