"""Switching instants of circuit-controlled switches, located inside the step.

A switch whose control ``c = control·y`` is a circuit quantity (not a source's time
function) changes state when ``c`` crosses its threshold (``VT + |VH|`` closing,
``VT − |VH|`` opening). When the state at the end of a step, ``y_{k+1}``, shows such a
crossing, the step is split at the crossing: for the step's switch states held fixed,
the state after a partial step of length ``τ`` from ``y_k``, ``y(τ)``, solves the step
system of length ``τ`` (``(E − τΘA) y = E y_k + …``, one MLCP), so ``g(τ) = c(y(τ)) −
threshold`` is a smooth function of ``τ`` in each diode mode. Its root in ``(0, h]`` is
found by regula falsi with the Anderson–Björck modification (:func:`regula_falsi`:
superlinear, and the bracket never stalls); the partial step is taken, the switch changes state, and the
rest of the step is taken with the new state (an implicit Euler step: the algebraic
unknowns jump at the switching, see :mod:`circuitnsds.engine.integrate`). If the rest
of the step shows a further crossing (another switch, or the same one going back), the
rest is split again.

A control that recrosses at once (a switch whose own state moves its control back across
a threshold without hysteresis: *chattering*) would split the step for ever: a partial
step shorter than :data:`MIN_FRACTION` of the step counts as none, and more than
:data:`MAX_EVENTS_PER_STEP` events in one step stop the simulation with an error naming
the switch (:func:`chattering_error`).

This module knows nothing about circuits: it takes the function ``g`` and the names.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Iterable
from itertools import repeat
from typing import NamedTuple

from circuitnsds.errors import SimulationError

MAX_EVENTS_PER_STEP = 20
"""Most switchings located in one time step before the control is declared chattering."""
MIN_FRACTION = 1e-6
"""Shortest partial step, as a fraction of the step: a crossing closer than this to the
start of the (rest of the) step switches there, without a partial step (a source that
jumps at a grid point moves a control across at once; shorter steps only make the step
system ill-conditioned, ``E/τ`` against ``A``)."""
TIME_TOLERANCE = 1e-9
"""The located instant is within this fraction of the step of the root of ``g``."""
MAX_ITERATIONS = 60
"""Regula falsi iterations at most (each one solve of the step system)."""


class SwitchEvent(NamedTuple):
    """One switching: ``time`` [s], the switch's name, its new ``state`` (closed = true)."""

    time: float
    element: str
    state: bool


event_time = operator.attrgetter("time")
"""An event's ``time`` [s]: the key of a list of events in time order (``bisect``'s, ``sort``'s)."""


def switch_events(times: Iterable[float], elements: Iterable[str], states: Iterable[bool]
                  ) -> list[SwitchEvent]:
    """The events of three parallel sequences (times [s], element names, new states), made by
    ``tuple.__new__`` without a Python frame per event: 0.27 µs each where ``SwitchEvent(...)``
    took 0.6 µs (its ``__new__`` is Python); the open-loop buck's 60,000 events a run cost
    36 ms that way, 16 ms this way."""
    return list(map(tuple.__new__, repeat(SwitchEvent), zip(times, elements, states)))


def regula_falsi(g: Callable[[float], float], a: float, b: float, ga: float, gb: float,
                 xtol: float) -> float:
    """A root of ``g`` in ``[a, b]`` where ``ga = g(a)`` and ``gb = g(b)`` have opposite signs
    (or ``gb == 0``): regula falsi with the Anderson–Björck modification of the Illinois
    rule (when the same end of the bracket is kept twice, its value is scaled down, by
    ``1 − g(x)/g(previous x)`` or by 1/2), which keeps the bracket shrinking from both
    sides (superlinear, about order 1.7) instead of stalling on a convex ``g``. Stops when
    the bracket is shorter than ``xtol`` or ``g`` is exactly 0. Returns the end of the
    bracket on ``b``'s side (where the sign of ``g`` is ``gb``'s), so that the crossing has
    happened at the returned instant."""
    if gb == 0.0:
        return b
    # keep (x_new, g_new) as the last iterate; the retained end is (a, ga) or (b, gb)
    side = 0
    for _ in range(MAX_ITERATIONS):
        if b - a <= xtol:
            break
        x = b - gb * (b - a) / (gb - ga)
        if not a < x < b:  # rounding: bisect
            x = 0.5 * (a + b)
        gx = g(x)
        if gx == 0.0:
            return x
        if (gx > 0) == (gb > 0):  # x replaces b; a is retained
            scale = 1.0 - gx / gb
            b, gb = x, gx
            if side == 1:
                ga *= scale if scale > 0 else 0.5
            side = 1
        else:  # x replaces a; b is retained
            scale = 1.0 - gx / ga
            a, ga = x, gx
            if side == -1:
                gb *= scale if scale > 0 else 0.5
            side = -1
    return b


def chattering_error(name: str, t0: float, t1: float, events: list[SwitchEvent]) -> SimulationError:
    """The error for a step ``[t0, t1]`` in which ``events`` (as many as
    :data:`MAX_EVENTS_PER_STEP`) were located and ``name`` is about to switch again: one switch
    toggling back and forth chatters; switchings of several switches (a ring oscillator, a
    fast converter) mean the circuit switches faster than the step resolves."""
    count = len(events)
    names = {event.element for event in events}
    own = sum(event.element == name for event in events)
    if len(names) > 1 and own <= count // 2:
        shown = ", ".join(sorted(names)[:5]) + (", ..." if len(names) > 5 else "")
        return SimulationError(
            f"{count} switchings of {len(names)} switches ({shown}) within the step from "
            f"t = {t0:.9g} s to {t1:.9g} s: the circuit switches faster than the step resolves",
            where=f"t = {t0:.9g} s", time=float(t0),
            hint=f"shorten the time step (--step, or .tran TSTEP) well below {t1 - t0:.3g} s, "
                 "to a fraction of the fastest switching interval")
    return SimulationError(
        f"switch {name} chatters: its control crosses its threshold again right after each "
        f"switching ({count} switchings within the step from t = {t0:.9g} s to {t1:.9g} s)",
        where=f"t = {t0:.9g} s", time=float(t0), devices=(name,),
        cause=SimulationError.SWITCH_CHATTERS,
        hint=f"the state of {name} moves its own control back across the threshold; give its "
        "model a hysteresis band wider than that jump (VH, IH), or add a delay (an RC) in the "
        "control path")
