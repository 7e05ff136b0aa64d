"""The time grid of a transient: regular steps plus every source breakpoint."""

from __future__ import annotations

import math

import numpy as np

from circuitnsds.arrays import sorted_unique

MERGE_FRACTION = 1e-9
"""Grid points closer than this fraction of the step to a breakpoint are merged into it."""

MAX_POINTS = 50_000_000
"""Refuse grids longer than this (memory: every point stores every unknown)."""


def check_step_count(step: float, stop: float) -> None:
    """Raise ``ValueError`` for a grid of ``stop / step`` regular steps beyond
    :data:`MAX_POINTS` (before anything of the grid, or of its breakpoints, is built)."""
    if step <= 0 or stop <= 0:
        raise ValueError("step and stop must be positive")
    if stop / step > MAX_POINTS:
        raise ValueError(f"{stop / step:.3g} steps requested (limit {MAX_POINTS:.0e}): "
                         "the step is far too small for the stop time")


def time_grid(step: float, stop: float, breakpoints: np.ndarray | list[float] = ()) -> np.ndarray:
    """Instants ``0 = t_0 < t_1 < ... < t_N = stop`` [s].

    The regular points ``k·step`` are kept, every breakpoint in ``(0, stop)`` is
    added, and a regular point within ``MERGE_FRACTION·step`` of a breakpoint is
    dropped in favour of the breakpoint (so no step is absurdly short by accident).
    """
    check_step_count(step, stop)
    count = max(1, math.ceil(stop / step - 1e-9))
    regular = np.arange(count + 1, dtype=float)  # (k·step computed in place: one array)
    regular *= step
    regular[-1] = stop
    tolerance = MERGE_FRACTION * step
    points = sorted_unique(np.asarray(breakpoints, dtype=float))
    points = points[(points > tolerance) & (points < stop - tolerance)]
    if points.size > 1:  # breakpoints within rounding noise of each other are one
        points = points[np.concatenate([[True], np.diff(points) > tolerance])]
    if not points.size:
        return regular
    # only the regular points next to a breakpoint's index can be within the tolerance:
    # index arithmetic per breakpoint, not a search per regular point (1M points: ~10x)
    nearest = np.rint(points / step).astype(np.int64)
    replaced = np.full(points.size, -1, dtype=np.int64)  # the regular point each one replaces
    for offset in (-1, 0, 1):
        index = np.clip(nearest + offset, 0, count)
        hit = (np.abs(regular[index] - points) <= tolerance) & (index > 0) & (index < count)
        # (a regular point near two breakpoints: the second is inserted beside the first)
        replaced[hit & (replaced < 0)] = index[hit & (replaced < 0)]
    taken = replaced[replaced >= 0]
    if taken.size > 1 and not (np.diff(taken) > 0).all():  # two replace one: the general way
        close = np.zeros(regular.size, dtype=bool)
        close[taken] = True
        regular = regular[~close]
        inserted = points
    else:  # each breakpoint takes the place of its regular point, in place; the others go in
        regular[taken] = points[replaced >= 0]
        inserted = points[replaced < 0]
    # both sorted and no value in common (the close ones are gone): a merge, not a sort
    return np.insert(regular, np.searchsorted(regular, inserted), inserted) if inserted.size else regular
