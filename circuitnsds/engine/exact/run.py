"""The event loop of the exact integrator (DESIGN.md "Event-driven exact integration").

From a consistent state, repeat: take the sources' current piece; solve the mode's state
equations in closed form over it (:class:`~.mode.ModeDynamics`); find the first event
(:func:`~.roots.first_root` over every pair's and switch's event function, and the piece's
end); write the output rows that fall before it; at the event choose the next mode
(:func:`choose_mode`) and go on. Nothing is approximated between events: the error is the
round-off of the closed forms and of the located instants.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from circuitnsds.engine.exact.exppoly import ExpPoly
from circuitnsds.engine.exact.first_event import first_event
from circuitnsds.engine.exact.loop import FINISHED, NEW_MODE, STALLED, exact_loop
from circuitnsds.engine.exact.mode import ModeDynamics, StateCoordinates
from circuitnsds.engine.exact.mode_tables import ModeTables
from circuitnsds.engine.exact.solution_map import SolutionMap
from circuitnsds.engine.exact.source_table import SourceTable
from circuitnsds.jit import AVAILABLE
from circuitnsds.system.mlcs import MLCS

MAX_MODE_CHANGES = 64
"""Mode changes at one instant at most before the run stops as chattering."""

TIME_ULPS = 4.0
"""Ulps of the absolute time within which an instant is known (see
:meth:`ExactSystem.event_functions`)."""

RELATIVE_TOL = 1e-12
"""Relative round-off of an event function: it counts as negative below ``-tol`` (see
:meth:`ExactSystem.event_functions`)."""


class Chattering(Exception):
    """No consistent mode was found at an instant (a sliding mode or a latch that does not settle)."""


@dataclass
class ExactEvent:
    time: float
    name: str
    kind: str
    """``"on"``/``"off"`` for a pair (conducting/blocking), ``"close"``/``"open"`` for a switch."""


@dataclass
class ExactRun:
    """Output of :func:`run_exact`: rows on ``times``."""

    times: np.ndarray
    y: np.ndarray
    currents: np.ndarray
    events: list[ExactEvent] = field(default_factory=list)
    segments: int = 0


@dataclass
class EventFunctions:
    """A mode's event functions on one segment: ``table`` holds one per column (the same
    terms for all), ``g >= 0`` while the mode holds; ``tolerances`` their round-off."""

    table: ExpPoly
    tolerances: np.ndarray
    labels: list[tuple[str, int]]
    """``("pair", j)`` or ``("switch", k)`` per column."""

    def function(self, k: int) -> ExpPoly:
        """Column ``k`` as a scalar ExpPoly, its zero terms dropped."""
        column = self.table.coefficients[:, k]
        keep = column != 0
        return ExpPoly(column[keep, None], self.table.powers[keep], self.table.exponents[keep])


class ExactSystem:
    """An MLCS prepared for exact integration: dense blocks, state coordinates, mode cache."""

    def __init__(self, mlcs: MLCS):
        self.mlcs = mlcs
        self.E = mlcs.E.toarray()
        self.B, self.C, self.D = mlcs.B.toarray(), mlcs.C.toarray(), mlcs.D.toarray()
        self.S = mlcs.S.toarray() if mlcs.stimuli else np.zeros((mlcs.n, 0))
        self.e = np.asarray(mlcs.e, dtype=float)
        self.coordinates = StateCoordinates.of(self.E)
        self.n, self.m = mlcs.n, mlcs.m
        self._system_matrices: dict[tuple[bool, ...], np.ndarray] = {}
        self._modes: dict[tuple, ModeDynamics] = {}
        self._rows: dict[int, tuple] = {}
        self._maps: dict[tuple, SolutionMap] = {}
        self.sources_used: np.ndarray | None = None
        """``(terms, sources)``: the source coefficients a run's pieces can have nonzero
        (:attr:`.source_table.SourceTable.used`, set by the run); ``None``: all."""
        self.controls = [self._row(s.control) for s in mlcs.switches]

    def _row(self, row) -> np.ndarray:
        vector = np.zeros(self.n)
        for column, value in row:
            vector[column] += value
        return vector

    def mode(self, active: np.ndarray, closed: tuple[bool, ...]) -> ModeDynamics:
        key = (tuple(bool(a) for a in active), closed)
        if key not in self._modes:
            if closed not in self._system_matrices:
                self._system_matrices[closed] = self.mlcs.system_matrix(closed).toarray()
            self._modes[key] = ModeDynamics(self.coordinates, self._system_matrices[closed], self.B,
                                            self.C, self.D, self.e, self.S, active)
        return self._modes[key]

    def event_functions(self, mode: ModeDynamics, closed: tuple[bool, ...], x: np.ndarray,
                        sources: ExpPoly, x_size: np.ndarray,
                        instant: float = 0.0) -> tuple[ExpPoly, EventFunctions]:
        """The mode's solution ``z(τ)`` from ``x`` (:meth:`ModeDynamics.solution`) and the
        event function ``g`` with its round-off ``tol`` of every pair and switch: ``g >= 0``
        while the mode holds (a conducting pair's current, a blocking pair's ``w``, a switch
        control's distance from the threshold it would cross); ``tol`` is the round-off of
        ``g`` propagated from ``x`` and the sources (:data:`RELATIVE_TOL` times the magnitudes
        that make up ``g(0)``);
        ``x_size`` [state units]: the magnitudes that were summed to compute ``x``, whose
        round-off ``x`` carries (a located instant's state comes from a sum of large terms).

        ``instant`` [s]: the absolute time of ``τ = 0``. It is a double, so the instant itself
        is known only to :data:`TIME_ULPS` ulps of it: ``tol`` also holds ``|g'(0)|`` times that
        (a function crossing zero closer to ``τ = 0`` than the time can resolve is zero *at*
        the instant; without this term the crossing is found at a ``τ`` with
        ``instant + τ == instant`` and the loop never advances)."""
        rows, constants, rows_P, rows_Q = self.event_rows(mode, closed)
        linear = self.solution_map(mode, rows, constants, sources.powers, sources.exponents, sources.size)
        inputs = linear.inputs(x, sources.coefficients)
        z = linear.solution(inputs)
        table = linear.table(inputs)
        phi0 = mode.forcing_size(sources)
        scale = rows_P @ np.maximum(np.abs(x), x_size) + rows_Q @ phi0 + np.abs(constants)
        slopes = np.abs((linear.slope_weights @ table).real)
        tolerances = RELATIVE_TOL * scale + slopes * TIME_ULPS * math.ulp(max(abs(instant), 1e-300)) + 1e-300
        # terms that vanish in every column are left out (a bound multiplies their size by
        # their growth, and 0·∞ is not a number)
        keep = np.any(table != 0, axis=1)
        labels = [("pair", k) for k in range(self.m)] + [("switch", k) for k in range(len(closed))]
        return z, EventFunctions(ExpPoly(table[keep], linear.powers[keep], linear.exponents[keep]),
                                 tolerances, labels)

    def solution_map(self, mode: ModeDynamics, rows: np.ndarray, constants: np.ndarray,
                     powers: np.ndarray, exponents: np.ndarray, columns: int) -> SolutionMap:
        """The mode's :class:`~.solution_map.SolutionMap` for sources of the structure
        ``(powers, exponents)`` over ``columns`` sources (cached)."""
        used = self.sources_used if self.sources_used is not None and self.sources_used.shape == (
            powers.size, columns) else None
        key = (id(mode), powers.tobytes(), exponents.tobytes(), None if used is None else used.tobytes())
        linear = self._maps.get(key)
        if linear is None:
            linear = SolutionMap(mode, powers, exponents, columns, rows, constants, used)
            self._maps[key] = linear
        return linear

    def built_modes(self) -> list[tuple[tuple[bool, ...], tuple[bool, ...]]]:
        """``(active, closed)`` of every mode built so far."""
        return list(self._modes)

    def event_rows(self, mode: ModeDynamics, closed: tuple[bool, ...]):
        """``(rows, constants, |rows P|, |rows Q|)``: ``g = rows · z + constants`` for every
        pair and switch of the mode (:meth:`event_functions`), cached with the mode."""
        cached = self._rows.get(id(mode))
        if cached is not None:
            return cached
        n = self.n
        act = mode.active_index
        rows = np.zeros((self.m + len(closed), n + act.size))
        constants = np.zeros(self.m + len(closed))
        signs = np.ones(self.m + len(closed))
        for position, j in enumerate(act):
            rows[j, n + position] = 1.0
        inactive = np.flatnonzero(~mode.active)
        rows[inactive, :n] = self.C[inactive]
        rows[np.ix_(inactive, n + np.arange(act.size))] = self.D[np.ix_(inactive, act)]
        constants[inactive] = self.e[inactive]
        for index, (switch, control) in enumerate(zip(self.mlcs.switches, self.controls)):
            r = self.m + index
            rows[r, :n] = control
            if closed[index]:
                constants[r] = -switch.off_threshold
            else:
                signs[r], constants[r] = -1.0, switch.on_threshold
        rows *= signs[:, None]
        cached = (rows, constants, np.abs(rows @ mode.P), np.abs(rows @ mode.Q))
        self._rows[id(mode)] = cached
        return cached


def _tolerance(g: ExpPoly) -> float:
    """Round-off of a derivative of an event function: its terms' magnitudes at 0."""
    return RELATIVE_TOL * float(np.sum(np.abs(g.coefficients))) + 1e-300


def _violations(functions: EventFunctions) -> list[tuple[str, int]]:
    """The event functions that are negative at ``τ = 0``, or zero and decreasing (to the
    second derivative): the mode cannot hold just after the instant."""
    bad = []
    values = functions.table(0.0)
    for k, ((kind, index), value, tol) in enumerate(zip(functions.labels, values, functions.tolerances)):
        if value < -tol:
            bad.append((kind, index))
            continue
        if value <= tol:
            d1 = functions.function(k).derivative()
            slope = float(d1(0.0)[0])
            if slope < -_tolerance(d1):
                bad.append((kind, index))
            elif abs(slope) <= _tolerance(d1):
                d2 = d1.derivative()
                if float(d2(0.0)[0]) < -_tolerance(d2):
                    bad.append((kind, index))
    return bad


def choose_mode(system: ExactSystem, active: np.ndarray, closed: tuple[bool, ...], x: np.ndarray,
                sources: ExpPoly, x_size: np.ndarray, instant: float):
    """A mode that holds just after the instant, starting from ``active``/``closed``: each
    violated pair or switch is flipped, repeatedly; when that cycles, the pairs involved are
    enumerated. Returns ``(active, closed, z, functions)``: the mode, its solution from ``x``
    and its event functions (:meth:`ExactSystem.event_functions`)."""
    active = active.copy()
    closed = tuple(closed)
    seen = set()
    for _ in range(MAX_MODE_CHANGES):
        key = (tuple(active), closed)
        if key in seen:
            break
        seen.add(key)
        z, functions = system.event_functions(system.mode(active, closed), closed, x, sources,
                                              x_size, instant)
        bad = _violations(functions)
        if not bad:
            return active, closed, z, functions
        states = list(closed)
        for kind, index in bad:
            if kind == "pair":
                active[index] = not active[index]
            else:
                states[index] = not states[index]
        closed = tuple(states)
    # the flipping cycled: enumerate the pairs it moved
    candidates = sorted({j for key in seen for j in range(system.m) if key[0][j] != active[j]})
    for flips in itertools.product((False, True), repeat=len(candidates)):
        trial = active.copy()
        for j, flip in zip(candidates, flips):
            trial[j] ^= flip
        z, functions = system.event_functions(system.mode(trial, closed), closed, x, sources,
                                              x_size, instant)
        if not _violations(functions):
            return trial, closed, z, functions
    raise Chattering("no mode holds after this instant")


def run_exact(mlcs: MLCS, times: np.ndarray, y0: np.ndarray, active0: np.ndarray,
              closed0: tuple[bool, ...]) -> ExactRun:
    """Integrate exactly from ``y0`` at ``times[0] = 0`` to ``times[-1]``, writing a row at each
    of ``times``: in the compiled loop (:mod:`.loop`) over the modes met so far, Python
    choosing the mode only where the loop meets one it does not know; the same loop in
    Python (:func:`run_python`) without numba."""
    if not AVAILABLE:
        return run_python(mlcs, times, y0, active0, closed0)
    system = ExactSystem(mlcs)
    stop = float(times[-1])
    sources = SourceTable(mlcs.stimuli, stop)
    system.sources_used = sources.used
    tables = ModeTables(system, sources)
    n, m = system.n, system.m
    Y = np.zeros((len(times), n))
    L = np.zeros((len(times), m))
    Y[0] = y0
    clock = np.zeros(1)
    counters = np.zeros(7, np.int64)
    counters[1] = tables.add(np.asarray(active0, bool), tuple(closed0))
    counters[3] = 1
    x = system.coordinates.V1.T @ y0
    x_size = np.abs(system.coordinates.V1.T) @ np.abs(y0)
    sources_now = np.zeros(sources.coefficients.shape[1:], complex)
    S = system.S
    v1t = np.ascontiguousarray(system.coordinates.V1.T)
    capacity = 1024
    event_times = np.zeros(capacity)
    event_index, event_on = np.zeros(capacity, np.int64), np.zeros(capacity, bool)
    times = np.asarray(times, dtype=float)
    while True:
        status = exact_loop(clock, counters, x, x_size, sources_now, sources.corners, sources.coefficients,
                            sources.exponents, sources.powers, sources.partner, S, tables.bits, tables.known,
                            tables.z_map, tables.table_map, tables.powers, tables.exponents, tables.terms,
                            tables.slope_weights, tables.rows_p, tables.rows_q, tables.rows_c, v1t,
                            np.abs(v1t), times, Y, L, event_times, event_index, event_on)
        if status == FINISHED:
            break
        if status == STALLED:
            raise Chattering(f"the exact integrator does not advance from t = {clock[0]!r} s")
        if counters[4] + tables.columns > capacity:  # (also what EVENTS_FULL asks)
            capacity *= 2
            event_times, event_index, event_on = (np.resize(a, capacity) for a in (event_times, event_index,
                                                                                   event_on))
        if status == NEW_MODE:
            t = float(clock[0])
            active, closed = tables.mode_of(int(counters[1]))
            piece = ExpPoly(sources_now.copy(), sources.powers, sources.exponents)
            new_active, new_closed, _, _ = choose_mode(system, active, closed, x, piece, x_size, t)
            before = np.concatenate([active, closed])
            after = np.concatenate([new_active, new_closed])
            for c in np.flatnonzero(before != after):
                event_times[counters[4]], event_index[counters[4]], event_on[counters[4]] = t, c, after[c]
                counters[4] += 1
            tables.add_all_built()
            counters[1] = tables.add(new_active, new_closed)
            counters[2] = 1
    # (name, kind) of each event function going on and off: pairs, then switches
    names = list(mlcs.pairs) + [switch.name for switch in mlcs.switches]
    kinds = [("off", "on")] * mlcs.m + [("open", "close")] * len(mlcs.switches)
    count = int(counters[4])
    events = [ExactEvent(t, names[c], kinds[c][on]) for t, c, on in
              zip(event_times[:count].tolist(), event_index[:count].tolist(), event_on[:count].tolist())]
    return ExactRun(times, Y, L, events, int(counters[5]))


def run_python(mlcs: MLCS, times: np.ndarray, y0: np.ndarray, active0: np.ndarray,
               closed0: tuple[bool, ...]) -> ExactRun:
    """:func:`run_exact` in Python (every segment through :func:`choose_mode`): what runs
    without numba, and the reference of the compiled loop."""
    system = ExactSystem(mlcs)
    stop = float(times[-1])
    sources = SourceTable(mlcs.stimuli, stop)
    system.sources_used = sources.used
    n, m = system.n, system.m
    Y = np.zeros((len(times), n))
    L = np.zeros((len(times), m))
    Y[0] = y0
    row = 1
    t = 0.0
    active = np.asarray(active0, dtype=bool).copy()
    closed = tuple(closed0)
    x = system.coordinates.V1.T @ y0
    x_size = np.abs(system.coordinates.V1.T) @ np.abs(y0)
    events: list[ExactEvent] = []
    segments = 0
    stalled = 0
    while t < stop:
        k = sources.interval(t)
        end = float(sources.corners[k + 1])
        piece = sources.piece(k, t)
        new_active, new_closed, z, functions = choose_mode(system, active, closed, x, piece, x_size, t)
        for j in np.flatnonzero(new_active != active):
            events.append(ExactEvent(t, mlcs.pairs[j], "on" if new_active[j] else "off"))
        for k in (k for k in range(len(closed)) if new_closed[k] != closed[k]):
            events.append(ExactEvent(t, mlcs.switches[k].name, "close" if new_closed[k] else "open"))
        active, closed = new_active, new_closed
        mode = system.mode(active, closed)
        horizon = end - t
        # every function at once, compiled (:mod:`.first_event`)
        table = functions.table
        tau, _ = first_event(np.ascontiguousarray(table.coefficients), table.powers.astype(np.int64),
                             table.exponents, functions.tolerances, horizon, 1e-13)
        segments += 1
        stop_at = t + tau
        last = row
        while last < len(times) and times[last] <= stop_at:
            last += 1
        if last > row:
            local = times[row:last] - t
            weights = local[:, None] ** z.powers[None, :] * np.exp(local[:, None] * z.exponents[None, :])
            values = (weights @ z.coefficients).real
            Y[row:last] = values[:, :n]
            L[row:last][:, mode.active_index] = values[:, n:]
            row = last
        x = mode.state(z(tau)[:n])
        x_size = np.abs(mode.V1t) @ z.magnitudes(tau)[:n]
        new_t = stop_at if tau < horizon else end
        # segments that do not advance the time (an event at the instant itself) are
        # legitimate a few at a time; more is a loop that would never end
        stalled = stalled + 1 if new_t <= t else 0
        if stalled > MAX_MODE_CHANGES:
            raise Chattering(f"the exact integrator does not advance from t = {t!r} s")
        t = new_t
    return ExactRun(np.asarray(times, dtype=float), Y, L, events, segments)
