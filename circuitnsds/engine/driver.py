"""The driver: advances a stepper over a grid, part by part, and hands each part to a recorder.

What to keep of a run is the recorder's business, not the stepper's (as diffrax keeps
``saveat`` apart from the solver): one recorder keeps the whole trajectory, another keeps
some signals and streams them to a file; both see the same parts. A run in parts (memory
bounded by a part, :func:`drive`'s ``part_steps``) has the arithmetic of one run: the
stepper keeps its state between parts (:mod:`circuitnsds.engine.stepper`).

A recorder is any object with ``record(trajectory, first)``: ``trajectory`` is a part (its
arrays are overwritten by the next part: copy what must outlive the call), ``first`` the
first row that is new (0 for the first part; 1 for the others, whose row 0 is the previous
part's last point).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

import numpy as np

from circuitnsds.engine.stepper import StartState, Stepper

if TYPE_CHECKING:
    from circuitnsds.engine.integrate import Trajectory


class Recorder(Protocol):
    """What the driver hands each part to."""

    def record(self, trajectory: Trajectory, first: int) -> None:
        """Take the rows ``first:`` of ``trajectory`` (a part of the run)."""


def drive(stepper: Stepper, grid: np.ndarray, start: StartState, recorder: Recorder, *,
          part_steps: int | None = None,
          progress: Callable[[float, float], None] | None = None) -> None:
    """Advance ``stepper`` over ``grid`` [s] from ``start`` (the state at ``grid[0]``), handing
    every part to ``recorder``.

    Args:
        part_steps: at most this many steps per part (``None``: the whole grid as one part).
        progress: ``callback(t, t_end)`` [s], ``t_end`` the grid's last point.

    Raises:
        SimulationError: from the stepper, after the points computed before the failure were
            recorded (its ``trajectory`` field, the failing part's good points).
        KeyboardInterrupt: likewise, for a Ctrl-C.
    """
    stepper.begin(grid, parts=part_steps is not None)
    steps = grid.size - 1 if part_steps is None else part_steps
    total = grid[-1]
    report = None if progress is None else (lambda t, _end: progress(t, total))
    first, state = 0, start
    while first < grid.size - 1:
        last = min(first + steps, grid.size - 1)
        try:
            trajectory = stepper.advance(grid[first:last + 1], state, continued=first > 0,
                                         progress=report)
        except BaseException as exc:  # (a SimulationError, a Ctrl-C): keep the good points
            partial = getattr(exc, "trajectory", None)
            if partial is not None and partial.time.size:
                recorder.record(partial, 0 if first == 0 else 1)
            raise
        recorder.record(trajectory, 0 if first == 0 else 1)
        state = StartState.at_end(trajectory)
        del trajectory  # freed before the next part's arrays are allocated
        first = last
