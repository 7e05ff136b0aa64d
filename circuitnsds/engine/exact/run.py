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

from circuitnsds.engine.exact.charge import interval_integrals
from circuitnsds.engine.exact.exppoly import ExpPoly
from circuitnsds.engine.exact.mode import ModeDynamics, NotIndexOne, StateCoordinates
from circuitnsds.engine.exact.roots import first_root, lower_bounds
from circuitnsds.engine.exact.sources import SourcePieces
from circuitnsds.system.mlcs import MLCS

MAX_MODE_CHANGES = 64
"""Mode changes at one instant at most before the run stops as chattering."""

TIME_ULPS = 4.0
"""Ulps of the absolute time within which an instant is known (see
:meth:`ExactSystem.event_functions`)."""

RELATIVE_TOL = 1e-12
"""Relative round-off of an event function: it counts as negative below ``-tol`` (see
:meth:`ExactSystem.event_functions`)."""

SUM_ULPS = 8.0
"""Ulps of the magnitudes summed to compute each unknown at an instant (``y_size``) that its
round-off is: a slow mode's ramp ``c (e^{λτ} − 1)`` with ``|c|`` a thousand times the value
leaves a few ulps of ``|c|``. The round-off reaches an event function through
``|rows P V1ᵀ|`` (unknown by unknown), not ``|rows P| |V1ᵀ|``: coupled windings mix the
primary's current into every state coordinate, and a blocking secondary diode's ``w`` is
``Roff`` times the secondary's current. Bounded the mixed way with :data:`RELATIVE_TOL`, a
flyback's secondary diode looked at its threshold while 6 V from it, and turned on 5 ns
late (at the gate's next corner) when it was at its threshold."""


LEAKAGE_EXCESS = 1e3
"""When flipping cycles and no mode holds, the mode whose violated functions are negative by
less than this many tolerances (and none of them leaving by its slope) is taken, their
tolerances widened to their values: a pair turned on while its inductor still carries the
leakage of its blocking ``Roff`` (a flyback's secondary diode at the primary switch's
opening: −9.7 pA against a tolerance of 5.5 pA) starts at that current, not at 0."""


class Chattering(Exception):
    """No consistent mode was found at an instant (a sliding mode or a latch that does not settle)."""


@dataclass
class ExactEvent:
    time: float
    name: str
    kind: str
    """``"on"``/``"off"`` for a pair (conducting/blocking), ``"close"``/``"open"`` for a switch."""


@dataclass
class LoopState:
    """Where the event loop stands at the start of a segment, before the mode choice there:
    enough to compute that segment, and all that follow, again bit for bit (a run resumed
    from it, :func:`run_exact`'s ``resume``, is the run that was cut).

    Attributes:
        t: the segment's start [s].
        x: the state ``V1ᵀ y`` there; ``y_size`` the magnitudes summed to compute ``y``.
        active, closed: the mode before the choice at ``t``.
        announced: the events of the choice at ``t`` were reported already.
    """

    t: float
    x: np.ndarray
    y_size: np.ndarray
    active: np.ndarray
    closed: tuple[bool, ...]
    announced: bool = False


@dataclass
class Segment:
    """One segment of the loop: from ``t`` [s] for ``tau`` [s] in ``mode`` (switch states
    ``closed``), the solution ``z(τ)`` and the event functions; ``ended_by``: the column of
    the function whose root ends it, ``None`` when the sources' piece ends it."""

    t: float
    tau: float
    mode: ModeDynamics
    closed: tuple[bool, ...]
    z: ExpPoly
    functions: EventFunctions
    ended_by: int | None


@dataclass
class ExactRun:
    """Output of :func:`run_exact`: rows on ``times``.

    ``active``/``closed``: the mode of the segment each row lies in (a row at an event: the
    segment ending there); ``charges`` [C]: each pair's ``∫ λ dt`` over the interval ending at
    each row (row 0: 0); ``tails``: for a row whose interval holds a segment start, the
    unknowns there and the time from there to the row [s]; ``state``: the loop at the start
    of the segment holding the last row (to resume from); ``rows``: rows written (all but
    in a run stopped by :class:`Chattering` or :class:`NotIndexOne`, which carry it as
    ``run``)."""

    times: np.ndarray
    y: np.ndarray
    currents: np.ndarray
    events: list[ExactEvent] = field(default_factory=list)
    segments: int = 0
    active: np.ndarray | None = None
    closed: np.ndarray | None = None
    charges: np.ndarray | None = None
    tails: dict[int, tuple[np.ndarray, float]] = field(default_factory=dict)
    state: LoopState | None = None
    rows: int = 0


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
                        sources: ExpPoly, y_size: np.ndarray,
                        instant: float = 0.0) -> tuple[ExpPoly, EventFunctions]:
        """The mode's solution ``z(τ)`` from ``x`` (:meth:`ModeDynamics.solution`) and the
        event function ``g`` with its round-off ``tol`` of every pair and switch: ``g >= 0``
        while the mode holds (a conducting pair's current, a blocking pair's ``w``, a switch
        control's distance from the threshold it would cross); ``tol`` is the round-off of
        ``g`` propagated from ``x`` and the sources (:data:`RELATIVE_TOL` times the magnitudes
        that make up ``g(0)``);
        ``y_size`` [units of ``y``]: the magnitudes that were summed to compute each unknown
        from which ``x`` was taken, whose round-off ``x`` carries (a located instant's state
        comes from a sum of large terms; :data:`SUM_ULPS`).

        ``instant`` [s]: the absolute time of ``τ = 0``. It is a double, so the instant itself
        is known only to :data:`TIME_ULPS` ulps of it: ``tol`` also holds ``|g'(0)|`` times that
        (a function crossing zero closer to ``τ = 0`` than the time can resolve is zero *at*
        the instant; without this term the crossing is found at a ``τ`` with
        ``instant + τ == instant`` and the loop never advances)."""
        rows, constants, rows_P, rows_Q, rows_Y = self._event_rows(mode, closed)
        z = mode.solution(x, sources)
        values = z.map(rows)
        phi0 = mode.forcing_size(sources)
        scale = rows_P @ np.abs(x) + rows_Q @ phi0 + np.abs(constants)
        # g'(0) = Re Σ c_j (ν_j [p_j = 0] + [p_j = 1])
        at_zero = np.where(values.powers == 0, values.exponents, 0) + (values.powers == 1)
        slopes = np.abs((at_zero @ values.coefficients).real)
        summed = SUM_ULPS * np.finfo(float).eps * (rows_Y @ y_size)
        resolution = slopes * TIME_ULPS * math.ulp(max(abs(instant), 1e-300))
        tolerances = RELATIVE_TOL * scale + summed + resolution + 1e-300
        # the constants join the term τ^0 e^{0τ} (one is added when the solution has none)
        plain = np.flatnonzero((values.powers == 0) & (values.exponents == 0))
        if plain.size:
            coefficients = values.coefficients.copy()
            coefficients[plain[0]] += constants
            powers, exponents = values.powers, values.exponents
        else:
            coefficients = np.vstack([values.coefficients, constants[None, :].astype(complex)])
            powers = np.append(values.powers, 0)
            exponents = np.append(values.exponents, 0j)
        labels = [("pair", k) for k in range(self.m)] + [("switch", k) for k in range(len(closed))]
        return z, EventFunctions(ExpPoly(coefficients, powers, exponents), tolerances, labels)

    def event_rows(self, mode: ModeDynamics, closed: tuple[bool, ...]) -> np.ndarray:
        """The rows ``r`` with ``g = r · z + constant`` of every pair and switch of the mode,
        in the columns of :meth:`event_functions` (the period map's saltation needs them)."""
        return self._event_rows(mode, closed)[0]

    def _event_rows(self, mode: ModeDynamics, closed: tuple[bool, ...]):
        """``(rows, constants, |rows P|, |rows Q|, |rows P V1ᵀ|)``: ``g = rows · z + constants`` for every
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
        cached = (rows, constants, np.abs(rows @ mode.P), np.abs(rows @ mode.Q),
                  np.abs(rows @ mode.P @ mode.V1t))
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
                sources: ExpPoly, y_size: np.ndarray, instant: float):
    """A mode that holds just after the instant, starting from ``active``/``closed``: each
    violated pair or switch is flipped, repeatedly; when that cycles, the pairs involved are
    enumerated. Returns ``(active, closed, z, functions)``: the mode, its solution from ``x``
    and its event functions (:meth:`ExactSystem.event_functions`)."""
    active = active.copy()
    closed = tuple(closed)
    seen = set()
    singular: NotIndexOne | None = None
    for _ in range(MAX_MODE_CHANGES):
        key = (tuple(active), closed)
        if key in seen:
            break
        seen.add(key)
        try:
            mode = system.mode(active, closed)
        except NotIndexOne as exc:  # (a trial on the way; the enumeration skips it)
            singular = exc
            break
        z, functions = system.event_functions(mode, closed, x, sources, y_size, instant)
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
    # the flipping cycled (or met a mode that is not index 1): enumerate the pairs it moved
    candidates = sorted({j for key in seen for j in range(system.m) if key[0][j] != active[j]})
    if singular is not None:  # (and the pairs the singular mode would have flipped too)
        candidates = sorted(set(candidates) | set(range(system.m))) if system.m <= 8 else candidates
    nearest, nearest_excess = None, LEAKAGE_EXCESS
    for flips in itertools.product((False, True), repeat=len(candidates)):
        trial = active.copy()
        for j, flip in zip(candidates, flips):
            trial[j] ^= flip
        try:
            mode = system.mode(trial, closed)
        except NotIndexOne as exc:
            singular = exc
            continue
        z, functions = system.event_functions(mode, closed, x, sources, y_size, instant)
        bad = _violations(functions)
        if not bad:
            return trial, closed, z, functions
        excess = _excess(functions, bad)
        if excess <= nearest_excess:
            nearest, nearest_excess = (trial, z, functions, bad), excess
    if nearest is not None:  # below a blocking pair's leakage: the mode holds (see LEAKAGE_EXCESS)
        trial, z, functions, bad = nearest
        values = functions.table(0.0)
        for k, label in enumerate(functions.labels):
            if label in bad:
                functions.tolerances[k] = max(functions.tolerances[k], 2.0 * abs(values[k]))
        return trial, closed, z, functions
    if singular is not None:
        raise singular
    raise Chattering("no mode holds after this instant")


def _crossed_within_tolerance(functions: EventFunctions, tau: float, horizon: float,
                              ended_by: int | None) -> tuple[float, int | None]:
    """The segment's end ``tau`` [s] and the column ending it (``ended_by``, ``None``: the
    piece's end), or the first zero before it of a function that starts
    clearly positive (above its tolerance) and ends negative without going below ``-tol``:
    its crossing is certain, and taking it at the next corner instead delays the event by
    ``tol / |g'|`` (a flyback's secondary diode, ``tol`` 0.4 V through ``Roff``, turned on
    at the gate's corner 5 ns after the primary switch opened)."""
    ends = functions.table(tau)
    crossed = np.flatnonzero((ends < 0) & (functions.table(0.0) > functions.tolerances))
    for k in crossed:
        root = first_root(functions.function(k), tau, 0.0, resolution=1e-13 * max(horizon, 1e-300))
        if root is not None and root < tau:
            tau, ended_by = root, int(k)
    return tau, ended_by


def _excess(functions: EventFunctions, bad: list[tuple[str, int]]) -> float:
    """How far below its tolerance the worst violated function of a mode is (its value over
    its tolerance); infinite if one is violated by its slope (it leaves the mode at once)."""
    values = functions.table(0.0)
    worst = 0.0
    for k, label in enumerate(functions.labels):
        if label in bad:
            if values[k] >= -functions.tolerances[k]:
                return math.inf
            worst = max(worst, -values[k] / functions.tolerances[k])
    return worst


def run_exact(mlcs: MLCS, times: np.ndarray, y0: np.ndarray, active0: np.ndarray,
              closed0: tuple[bool, ...], *, resume: LoopState | None = None,
              system: ExactSystem | None = None, stop: float | None = None,
              record: list[Segment] | None = None) -> ExactRun:
    """Integrate exactly from ``y0`` at ``times[0]`` (0 unless resumed) to ``times[-1]``,
    writing a row at each of ``times``.

    ``resume``: the loop state to go on from (``y0`` is then row 0 only, and ``times[0]`` is
    at or after ``resume.t``); ``system``: the prepared system to reuse (its modes cached);
    ``stop`` [s]: the end of the whole run when this is a part of it (the sources' pieces
    end at their corners or there, as in the whole run); ``record``: a list that gets each
    segment computed (:class:`Segment`: what the period map's derivative needs).

    Raises:
        Chattering, NotIndexOne: with ``run`` (the rows written before) and ``time`` set.
    """
    system = ExactSystem(mlcs) if system is None else system
    last_time = float(times[-1])
    pieces = SourcePieces(mlcs.stimuli, last_time if stop is None else stop)
    n, m = system.n, system.m
    Y = np.zeros((len(times), n))
    L = np.zeros((len(times), m))
    charges = np.zeros((len(times), m))
    row_active = np.zeros((len(times), m), bool)
    row_closed = np.zeros((len(times), len(closed0)), bool)
    tails: dict[int, tuple[np.ndarray, float]] = {}
    Y[0] = y0
    row_active[0], row_closed[0] = active0, closed0
    row = 1
    if resume is None:
        resume = LoopState(0.0, system.coordinates.V1.T @ y0, np.abs(y0),
                           np.asarray(active0, dtype=bool), tuple(closed0))
    t, x, y_size = resume.t, resume.x, resume.y_size
    active = np.asarray(resume.active, dtype=bool).copy()
    closed = tuple(resume.closed)
    quiet = resume.announced
    events: list[ExactEvent] = []
    segments = 0
    stalled = 0
    state = resume
    try:
        while t < last_time or (t == last_time and row < len(times)):
            state = LoopState(t, x, y_size, active, closed, quiet)
            end = pieces.next_corner(t)
            sources = pieces.piece(t, end)
            new_active, new_closed, z, functions = choose_mode(system, active, closed, x, sources,
                                                               y_size, t)
            if not quiet:
                for j in np.flatnonzero(new_active != active):
                    events.append(ExactEvent(t, mlcs.pairs[j], "on" if new_active[j] else "off"))
                for k in (k for k in range(len(closed)) if new_closed[k] != closed[k]):
                    events.append(ExactEvent(t, mlcs.switches[k].name,
                                             "close" if new_closed[k] else "open"))
            quiet = False
            active, closed = new_active, new_closed
            mode = system.mode(active, closed)
            horizon = end - t
            tau = horizon
            # every function at once over the whole piece; the search only where that fails (a
            # bound that is not a number, 0·∞ from a term another column does not have, fails)
            cleared = lower_bounds(functions.table, 0.0, horizon) > -functions.tolerances
            doubtful = np.flatnonzero(~cleared)
            ended_by = None
            for k in doubtful:
                root = first_root(functions.function(k), tau, float(functions.tolerances[k]),
                                  resolution=1e-13 * max(horizon, 1e-300))
                if root is not None and root < tau:
                    tau, ended_by = root, int(k)
            tau, ended_by = _crossed_within_tolerance(functions, tau, horizon, ended_by)
            segments += 1
            if record is not None:
                record.append(Segment(t, tau, mode, closed, z, functions, ended_by))
            stop_at = t + tau
            last = row
            while last < len(times) and times[last] <= stop_at:
                last += 1
            currents = ExpPoly(z.coefficients[:, n:], z.powers, z.exponents)
            if last > row:
                local = times[row:last] - t
                weights = local[:, None] ** z.powers[None, :] * np.exp(local[:, None] * z.exponents[None, :])
                # (summed row by row: a matrix product's order of summation depends on how
                # many rows there are, and a run in parts must be the run in one part)
                values = np.sum(weights[:, :, None] * z.coefficients[None, :, :], axis=1).real
                Y[row:last] = values[:, :n]
                L[row:last][:, mode.active_index] = values[:, n:]
                row_active[row:last], row_closed[row:last] = active, closed
                begins = np.maximum(times[row - 1:last - 1] - t, 0.0)
                charges[row:last][:, mode.active_index] += interval_integrals(currents, begins, local)
                if times[row - 1] < t:  # the first row's interval holds this segment's start
                    tails[row] = (z(0.0)[:n], float(local[0]))
                row = last
            if row < len(times) and tau > 0:  # the next row's interval holds this segment's end
                begin = max(float(times[row - 1]) - t, 0.0)
                if tau > begin:
                    charges[row][mode.active_index] += interval_integrals(
                        currents, np.array([begin]), np.array([tau]))[0]
            if row >= len(times):
                break
            x = mode.state(z(tau)[:n])
            y_size = z.magnitudes(tau)[:n]
            new_t = stop_at if tau < horizon else end
            # segments that do not advance the time (an event at the instant itself) are
            # legitimate a few at a time; more is a loop that would never end
            stalled = stalled + 1 if new_t <= t else 0
            if stalled > MAX_MODE_CHANGES:
                raise Chattering(f"the exact integrator does not advance from t = {t!r} s")
            t = new_t
    except (Chattering, NotIndexOne) as exc:
        exc.time = t
        exc.run = ExactRun(np.asarray(times, dtype=float), Y, L, events, segments, row_active,
                           row_closed, charges, tails, state, row)
        raise
    return ExactRun(np.asarray(times, dtype=float), Y, L, events, segments, row_active, row_closed,
                    charges, tails, state, row)
