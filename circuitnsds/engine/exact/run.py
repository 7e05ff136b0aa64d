"""The event loop of the exact integrator (DESIGN.md "Event-driven exact integration").

From a consistent state, repeat: take the sources' current piece; solve the mode's state
equations in closed form over it (:class:`~.mode.ModeDynamics`); find the first event
(:func:`~.first_event.first_event` over every pair's and switch's event function, and the
piece's end); write the output rows that fall before it; at the event choose the next mode
(:func:`choose_mode`) and go on. Nothing is approximated between events: the error is the
round-off of the closed forms and of the located instants.

:func:`run_exact` runs that loop compiled (:mod:`.loop`; in C, ``_exact_native.c``, when it
was built, else by numba) over the modes met so far, Python choosing the mode only where the
loop meets one it does not know (and enumerating when the flipping cycles); :func:`run_python`
is the same loop in Python: what runs without either, when a run records its segments (the
period map's derivative needs them as objects), and the reference a test holds the compiled
loop to.
"""

from __future__ import annotations

import ctypes
import functools
import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from circuitnsds import native
from circuitnsds.engine.events import SwitchEvent, switch_events
from circuitnsds.engine.exact.charge import interval_integrals
from circuitnsds.engine.exact.exppoly import ExpPoly
from circuitnsds.engine.exact.first_event import crossed_within_tolerance, first_event, native_first_event
from circuitnsds.engine.exact.loop import COUNTERS, FINISHED, NEW_MODE, STALLED, exact_loop
from circuitnsds.engine.exact.mode import ModeDynamics, NotIndexOne, StateCoordinates
from circuitnsds.engine.exact.mode_tables import ModeTables
from circuitnsds.engine.exact.solution_map import SolutionMap
from circuitnsds.engine.exact.source_table import SourceTable
from circuitnsds.jit import AVAILABLE
from circuitnsds.system.mlcs import MLCS

MAX_MODE_CHANGES = 64
"""Mode changes at one instant at most before the run stops as chattering; also the segments
in a row shorter than :data:`CHATTERING` of the run."""
CHATTERING = 1e-8
"""A segment shorter than this fraction of the run's end time counts as not advancing (the
compiled loops' ``stalled``): more than :data:`MAX_MODE_CHANGES` in a row are a chattering
pair, handed to θ (:class:`Chattering`): a diode clamping a tank driven at 2 GHz turns on and
off every few hundred ps for ever (``tests/test_exact_native.py``), where the θ-method slides
through it. (The XSPICE voltage-mode buck's diode did so at start-up, 4.1 million events in
77 s, falsely: ``mode.ModeDynamics.vector_gap``.) The fraction is of the run, not of the rows' spacing:
the rows do not set the exact integrator's accuracy, and a long run of sparse rows is a use
of it; a real ringing 64 times in a row shorter than 1e-8 of the run (a 5 MHz ring over a run
of 10 s) is handed to θ too, and said."""

TIME_ULPS = 4.0
"""Ulps of the absolute time within which an instant is known (see
:meth:`ExactSystem.event_functions`)."""

EPSILON = float(np.finfo(float).eps)

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


ENUMERATED_PAIRS = 8
"""Pairs :func:`choose_mode` adds to those its flipping moved, when that cycles, only while
the enumeration stays within this many (2⁸ = 256 modes at most)."""

NEAR_ZERO = 10.0
"""Tolerances from zero within which a pair's falling function in the mode being left counts
as switching at the instant, give or take its round-off (:func:`_near_crossing`)."""

LEAKAGE_EXCESS = 1e3
"""When flipping cycles and no mode holds, the mode whose violated functions are negative by
less than this many tolerances (and none of them leaving by its slope) is taken, their
tolerances widened to their values: a pair turned on while its inductor still carries the
leakage of its blocking ``Roff`` (a flyback's secondary diode at the primary switch's
opening: −9.7 pA against a tolerance of 5.5 pA) starts at that current, not at 0."""


def _stalled(t: float) -> str:
    """What a loop that stopped advancing at ``t`` [s] says (:data:`CHATTERING`)."""
    return (f"the exact integrator does not advance from t = {t!r} s (more than {MAX_MODE_CHANGES} "
            f"segments in a row shorter than {CHATTERING:g} of the run)")


class Chattering(Exception):
    """No consistent mode was found at an instant (a sliding mode or a latch that does not settle)."""


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


class TailTable(Mapping):
    """An exact run's ``tails`` (:class:`ExactRun`), ``{row: (unknowns, seconds)}``, made from
    the loop's arrays when first read: the stepper does not read them (its rows' capacitor
    currents are the instant's, :mod:`circuitnsds.analyses.signals`), and a dictionary of one
    entry per event was 60,000 tuples in the 100 ms buck."""

    def __init__(self, rows: np.ndarray, seconds: np.ndarray, unknowns: np.ndarray):
        self._arrays: tuple | None = (rows, seconds, unknowns)
        self._table: dict[int, tuple[np.ndarray, float]] = {}

    def _made(self) -> dict[int, tuple[np.ndarray, float]]:
        if self._arrays is not None:
            rows, seconds, unknowns = self._arrays
            unknowns = unknowns.copy()  # (one copy; each entry a view of its row)
            self._table = dict(zip(rows.tolist(), zip(unknowns, seconds.tolist())))
            self._arrays = None
        return self._table

    def __getitem__(self, row: int) -> tuple[np.ndarray, float]:
        return self._made()[row]

    def __iter__(self):
        return iter(self._made())

    def __len__(self) -> int:
        return len(self._made())


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
    events: list[SwitchEvent] = field(default_factory=list)
    segments: int = 0
    active: np.ndarray | None = None
    closed: np.ndarray | None = None
    charges: np.ndarray | None = None
    tails: Mapping[int, tuple[np.ndarray, float]] = field(default_factory=dict)
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
    offsets: np.ndarray | None = None
    """What the state's part along the mode's fast modes adds to each function at the start
    (left out of ``table``: :func:`fast_offsets`), or ``None`` (nothing)."""

    def at_start(self) -> np.ndarray:
        """Each function's value just after the instant: ``table(0)`` and :attr:`offsets`."""
        values = self.table(0.0)
        return values if self.offsets is None else values + self.offsets

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
        self._refused: dict[tuple, str] = {}
        """The modes without state equations met, with why (:meth:`mode`)."""
        self._rows: dict[int, tuple] = {}
        self._fast_rows: dict[int, np.ndarray] = {}
        self._gap_rows: dict[int, np.ndarray] = {}
        self._maps: dict[tuple, SolutionMap] = {}
        self._quick_maps: dict[tuple, tuple] = {}
        self._labels: dict[int, tuple] = {}
        self._tables: dict[float, tuple[SourceTable, ModeTables]] = {}
        self.sources_used: np.ndarray | None = None
        """``(terms, sources)``: the source coefficients a run's pieces can have nonzero
        (:attr:`.source_table.SourceTable.used`, set by the run); ``None``: all."""
        self.controls = [self._row(s.control) for s in mlcs.switches]
        self.horizon = 0.0
        """[s] The longest piece of the sources' table in use (set by :meth:`tables`): the
        longest segment a solution map serves (:data:`.solution_map.NEAR_RESONANCE`)."""

    def _row(self, row) -> np.ndarray:
        vector = np.zeros(self.n)
        for column, value in row:
            vector[column] += value
        return vector

    def mode(self, active: np.ndarray, closed: tuple[bool, ...]) -> ModeDynamics:
        """The mode's reduced equations (built once). Raises :class:`NotIndexOne` for a mode
        without them, found once too: the Cockcroft–Walton multiplier's 213 hand-offs each
        enumerated its 64 modes, building 13,817 that failed again (1.05 s of a 1.6 s run)."""
        key = (tuple(np.asarray(active, bool).tolist()), closed)
        found = self._modes.get(key)
        if found is not None:
            return found
        refused = self._refused.get(key)
        if refused is not None:
            raise NotIndexOne(refused)
        if closed not in self._system_matrices:
            self._system_matrices[closed] = self.mlcs.system_matrix(closed).toarray()
        try:
            found = ModeDynamics(self.coordinates, self._system_matrices[closed], self.B, self.C,
                                 self.D, self.e, self.S, active)
        except NotIndexOne as exc:
            self._refused[key] = str(exc)
            raise
        self._modes[key] = found
        return found

    def event_functions(self, mode: ModeDynamics, closed: tuple[bool, ...], x: np.ndarray,
                        sources: ExpPoly, y_size: np.ndarray,
                        instant: float = 0.0, solution: bool = True) -> tuple[ExpPoly | None, EventFunctions]:
        """The mode's solution ``z(τ)`` from ``x`` (:meth:`ModeDynamics.solution`) and the
        event function ``g`` with its round-off ``tol`` of every pair and switch: ``g >= 0``
        while the mode holds (a conducting pair's current, a blocking pair's ``w``, a switch
        control's distance from the threshold it would cross); ``tol`` is the round-off of
        ``g`` propagated from ``x`` and the sources (:data:`RELATIVE_TOL` times the magnitudes
        that make up ``g(0)``);
        ``y_size`` [units of ``y``]: the magnitudes that were summed to compute each unknown
        from which ``x`` was taken, whose round-off ``x`` carries (a located instant's state
        comes from a sum of large terms; :data:`SUM_ULPS`).

        ``solution``: false leaves ``z`` out (``None``): the compiled loop's mode choice
        needs the functions only.

        ``instant`` [s]: the absolute time of ``τ = 0``. It is a double, so the instant itself
        is known only to :data:`TIME_ULPS` ulps of it: ``tol`` also holds ``|g'(0)|`` times that
        (a function crossing zero closer to ``τ = 0`` than the time can resolve is zero *at*
        the instant; without this term the crossing is found at a ``τ`` with
        ``instant + τ == instant`` and the loop never advances)."""
        rows, constants, rows_P, rows_Q, rows_Y = self._event_rows(mode, closed)
        linear = self.solution_map(mode, rows, constants, sources.powers, sources.exponents, sources.size)
        inputs = linear.inputs(x, sources.coefficients)
        z = linear.solution(inputs) if solution else None
        table = linear.table(inputs)
        phi0 = mode.forcing_size(sources)
        scale = rows_P @ np.abs(x) + rows_Q @ phi0 + np.abs(constants)
        slopes = np.abs((linear.slope_weights @ table).real)
        summed = SUM_ULPS * EPSILON * (rows_Y @ y_size)
        resolution = slopes * TIME_ULPS * math.ulp(max(abs(instant), 1e-300))
        # g(0) is the sum of the table's terms at τ = 0, which may be far larger than g: a mode
        # of the voltage-mode buck's limited amplifier (gain 1e4) at its start gives its switch's
        # control 0 V as terms of 4e7 V whose sum came out at -1.8e-9 V, and the mode was
        # refused on that sign (changed by one ulp of an eigenvector)
        terms = SUM_ULPS * EPSILON * np.add.reduce(np.abs(table), axis=0)
        tolerances = RELATIVE_TOL * scale + summed + resolution + terms + 1e-300
        if mode.vector_gap is not None:  # (the modal sum's gap to P x at τ = 0: mode.vector_gap)
            tolerances = tolerances + np.abs(self.gap_rows(mode, closed) @ x)
        # terms that vanish in every column are left out (a bound multiplies their size by
        # their growth, and 0·∞ is not a number)
        keep = (table != 0).any(axis=1)
        labels = self._labels.get(len(closed))
        if labels is None:
            labels = self._labels[len(closed)] = tuple(
                [("pair", k) for k in range(self.m)] + [("switch", k) for k in range(len(closed))])
        if keep.all():  # (the same arrays: nothing to leave out)
            table_poly = ExpPoly(table, linear.powers, linear.exponents)
        else:
            table_poly = ExpPoly(table[keep], linear.powers[keep], linear.exponents[keep])
        offsets = fast_offsets(self.fast_rows(mode, closed), x) if mode.fast_P is not None else None
        return z, EventFunctions(table_poly, tolerances, list(labels), offsets)

    def fast_rows(self, mode: ModeDynamics, closed: tuple[bool, ...]) -> np.ndarray:
        """``(columns, r)``: each event function's change per unit of the state along the
        mode's fast modes, at the start (:func:`fast_offsets`), for a mode that has them
        (``mode.fast_P``: the callers ask only then)."""
        return self._per_state(self._fast_rows, mode, closed, mode.fast_P)

    def gap_rows(self, mode: ModeDynamics, closed: tuple[bool, ...]) -> np.ndarray:
        """``(columns, r)``: each event function's share of the gap between the mode's modal
        sum at ``τ = 0`` and its algebraic values, per unit of the state
        (``rows · mode.vector_gap``; the callers ask only for a mode that has one). Its value
        at ``x``, ``|gap_rows @ x|``, joins the function's round-off: the gap itself, not a
        bound of it by magnitudes (the XSPICE buck's eigenvectors, whose ``W⁻¹`` has entries
        that cancel on its states, made ``|gap_rows| |x|`` 0.85 V per unit of the state)."""
        return self._per_state(self._gap_rows, mode, closed, mode.vector_gap)

    def _per_state(self, cache: dict[int, np.ndarray], mode: ModeDynamics, closed: tuple[bool, ...],
                   matrix: np.ndarray) -> np.ndarray:
        """The mode's event rows times ``matrix`` (``(n + k, r)``), kept in ``cache`` by mode."""
        cached = cache.get(id(mode))
        if cached is None:
            cached = cache[id(mode)] = self._event_rows(mode, closed)[0] @ matrix
        return cached

    def solution_map(self, mode: ModeDynamics, rows: np.ndarray, constants: np.ndarray,
                     powers: np.ndarray, exponents: np.ndarray, columns: int) -> SolutionMap:
        """The mode's :class:`~.solution_map.SolutionMap` for sources of the structure
        ``(powers, exponents)`` over ``columns`` sources (cached)."""
        # (first by the arrays' identities, which the run's own pieces share: its source table's;
        # the entry holds them, so their ids are not reused while it is there)
        quick = (id(mode), id(powers), id(exponents), id(self.sources_used), columns, self.horizon)
        known = self._quick_maps.get(quick)
        if (known is not None and known[0] is powers and known[1] is exponents
                and known[2] is self.sources_used):
            return known[3]
        used = self.sources_used if self.sources_used is not None and self.sources_used.shape == (
            powers.size, columns) else None
        key = (id(mode), powers.tobytes(), exponents.tobytes(), None if used is None else used.tobytes(),
               self.horizon)
        linear = self._maps.get(key)
        if linear is None:
            linear = SolutionMap(mode, powers, exponents, columns, rows, constants, used, self.horizon)
            self._maps[key] = linear
        self._quick_maps[quick] = (powers, exponents, self.sources_used, linear)
        return linear

    def built_modes(self) -> list[tuple[tuple[bool, ...], tuple[bool, ...]]]:
        """``(active, closed)`` of every mode built so far."""
        return list(self._modes)

    def tables(self, stop: float) -> tuple[SourceTable, ModeTables]:
        """The sources' table of a run ending at ``stop`` [s] and the compiled loop's table of
        the modes met (kept with the system: the parts of one run share them)."""
        if stop not in self._tables:
            sources = SourceTable(self.mlcs.stimuli, stop)
            self._use(sources)  # (before the tables: they build the maps of the modes met)
            self._tables[stop] = (sources, ModeTables(self, sources))
        sources, tables = self._tables[stop]
        self._use(sources)
        return sources, tables

    def _use(self, sources: SourceTable) -> None:
        """Solution maps from now on are for ``sources``' pieces (:attr:`sources_used`,
        :attr:`horizon`)."""
        self.sources_used = sources.used
        self.horizon = float(np.max(np.diff(sources.corners), initial=0.0))

    def event_row_data(self, mode: ModeDynamics, closed: tuple[bool, ...]) -> tuple:
        """``(rows, constants, |rows P|, |rows Q|, |rows P V1ᵀ|)`` of :meth:`event_functions`
        (what :mod:`.mode_tables` packs for the compiled loop)."""
        return self._event_rows(mode, closed)

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
        rows[act, n + np.arange(act.size)] = 1.0
        inactive = (~mode.active).nonzero()[0]
        rows[inactive, :n] = self.C[inactive]
        rows[inactive, n:] = self.D[inactive][:, act]
        constants[inactive] = self.e[inactive]
        for index, (switch, control) in enumerate(zip(self.mlcs.switches, self.controls)):
            r = self.m + index
            rows[r, :n] = control
            if closed[index]:
                constants[r] = -switch.off_threshold
            else:
                signs[r], constants[r] = -1.0, switch.on_threshold
        rows *= signs[:, None]
        # (the state's round-off through what of P persists: mode.FAST_DECAY)
        cached = (rows, constants, np.abs(rows @ mode.P_persistent), np.abs(rows @ mode.Q),
                  np.abs(rows @ mode.P_persistent @ mode.V1t))
        self._rows[id(mode)] = cached
        return cached


FAST_SIGNIFICANT = 1e-6
"""A state's part along a mode faster than :data:`.mode.FAST_DECAY` counts at a mode choice
where it moves an event function by more than this fraction of the magnitudes that make up
that move (:func:`fast_offsets`): round-off moves it by 1e-16 of them; an inductor's current
that an opening switch cuts, with no diode conducting yet to take it, by all of them."""


def fast_offsets(fast_rows: np.ndarray, x: np.ndarray) -> np.ndarray:
    """What the state ``x``'s part along the mode's fast modes adds to each event function at
    the start (``fast_rows`` of :meth:`ExactSystem.fast_rows`), where it counts
    (:data:`FAST_SIGNIFICANT`), else 0. A segment's solution leaves those modes out (gone
    in a femtosecond, :data:`.mode.FAST_DECAY`), but not what they do at the instant: the
    buck whose switch's model has RON alone opened with 1.02 A in its inductor and its
    freewheeling diode blocking, the inductor's current went into the open switch's 1e-9 S
    (a mode of −1.06e16 /s) and vanished from the solution, and the diode never turned on
    (v(out) 0.38 V instead of 4.8 V). The compiled loops compute the same
    (``loop._fast_offset``)."""
    offsets = fast_rows @ x
    return np.where(np.abs(offsets) > FAST_SIGNIFICANT * (np.abs(fast_rows) @ np.abs(x)), offsets, 0.0)


def _violations(functions: EventFunctions) -> list[tuple[str, int]]:
    """The event functions that are negative at ``τ = 0``, or zero and decreasing (to the
    second derivative): the mode cannot hold just after the instant. A zero function whose
    slope is negative but whose curvature turns it back up within its own round-off (the
    parabola's dip ``g − g'²/(2g'')`` above ``−tol``) is not violated: a winding's diode
    turning on while the open-circuit voltage still rises (a flyback's output diode with a
    leakage inductance) has a current starting at −117 A/s that turns up at 1.2e16 A/s², a
    dip of 0.5 pA against a round-off of 1.3 pA over 19 fs; flipping it back and forth
    found no mode. (The loop's certified search catches any deeper dip as an event.)"""
    bad = []
    table = functions.table
    values = functions.at_start()
    for k, ((kind, index), value, tol) in enumerate(zip(functions.labels, values, functions.tolerances)):
        if value < -tol:
            bad.append((kind, index))
            continue
        if value <= tol:
            d1 = _column_derivative(table, k)
            slope, slope_tol = _at_zero(*d1)
            if slope > slope_tol:
                continue
            curvature, curvature_tol = _at_zero(*_derivative(*d1))
            if slope < -slope_tol:  # (decreasing: unless the curvature turns it back within tol)
                if not (curvature > curvature_tol and value - slope * slope / (2.0 * curvature) >= -tol):
                    bad.append((kind, index))
            elif curvature < -curvature_tol:
                bad.append((kind, index))
    return bad


def _column_derivative(table: ExpPoly, k: int) -> tuple:
    """:func:`_derivative` of column ``k`` of ``table``, its zero terms left out."""
    column = table.coefficients[:, k]
    keep = column != 0
    return _derivative(column[keep, None], table.powers[keep], table.exponents[keep])


def _derivative(coefficients: np.ndarray, powers: np.ndarray, exponents: np.ndarray) -> tuple:
    """:meth:`.ExpPoly.derivative` on the arrays ``(coefficients (terms, 1), powers,
    exponents)`` (the same operations, without the objects: :func:`_violations` takes
    one or two per event)."""
    lowered = powers > 0
    return (np.concatenate([coefficients * exponents[:, None],
                            coefficients[lowered] * powers[lowered, None]]),
            np.concatenate([powers, powers[lowered] - 1]), np.concatenate([exponents, exponents[lowered]]))


def _at_zero(coefficients: np.ndarray, powers: np.ndarray, exponents: np.ndarray) -> tuple[float, float]:
    """The scalar function's value at ``τ = 0`` (as :meth:`.ExpPoly.__call__`) and its
    round-off: :data:`RELATIVE_TOL` of its terms' magnitudes there."""
    weights = 0.0 ** powers * np.exp(exponents * 0.0)
    return (float((weights @ coefficients).real[0]),
            RELATIVE_TOL * float(np.sum(np.abs(coefficients))) + 1e-300)


def choose_mode(system: ExactSystem, active: np.ndarray, closed: tuple[bool, ...], x: np.ndarray,
                sources: ExpPoly, y_size: np.ndarray, instant: float, solution: bool = True):
    """A mode that holds just after the instant, starting from ``active``/``closed``: each
    violated pair is flipped, and each violated switch once no pair is, repeatedly; when that
    cycles, the pairs involved are enumerated, with those the starting mode switches within a
    few round-offs of the instant (:func:`_near_crossing`; at most :data:`ENUMERATED_PAIRS`
    pairs). Returns ``(active, closed, z, functions)``: the mode, its solution from ``x``
    (``None`` unless ``solution``: the compiled loop's choice does not need it) and its event
    functions (:meth:`ExactSystem.event_functions`)."""
    active = active.copy()
    closed = tuple(closed)
    seen = set()
    singular: NotIndexOne | None = None
    left: EventFunctions | None = None  # (the functions of the mode being left)
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
        z, functions = system.event_functions(mode, closed, x, sources, y_size, instant, solution)
        bad = _violations(functions)
        if not bad:
            return active, closed, z, functions
        if left is None:
            left = functions
        # the pairs first, the switches once they hold: a switch's control read through pairs
        # in their modes of before the instant is stale (a d_dff's slave read min(low, q) as
        # low = 1 at the falling clock edge and took the master's place: the states' other
        # fixpoint, q = 1 with m = 0, since d = not q at the same instant)
        pairs_bad = any(kind == "pair" for kind, _ in bad)
        states = list(closed)
        for kind, index in bad:
            if kind == "pair":
                active[index] = not active[index]
            elif not pairs_bad:
                states[index] = not states[index]
        closed = tuple(states)
    # the flipping cycled (or met a mode that is not index 1): enumerate the pairs it moved
    candidates = sorted({j for key in seen for j in range(system.m) if key[0][j] != active[j]})
    crossing = _near_crossing(left) if left is not None else set()
    if crossing and len(set(candidates) | crossing) <= ENUMERATED_PAIRS:
        # (and the pairs the mode left switches within a few round-offs of the instant)
        candidates = sorted(set(candidates) | crossing)
    if singular is not None:  # (and the pairs the singular mode would have flipped too)
        if system.m <= ENUMERATED_PAIRS:
            candidates = list(range(system.m))
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
        z, functions = system.event_functions(mode, closed, x, sources, y_size, instant, solution)
        bad = _violations(functions)
        if not bad:
            return trial, closed, z, functions
        excess = _excess(functions, bad)
        if excess <= nearest_excess:
            nearest, nearest_excess = (trial, z, functions, bad), excess
    if nearest is not None:  # below a blocking pair's leakage: the mode holds (see LEAKAGE_EXCESS)
        trial, z, functions, bad = nearest
        values = functions.at_start()
        for k, label in enumerate(functions.labels):
            if label in bad:
                functions.tolerances[k] = max(functions.tolerances[k], 2.0 * abs(values[k]))
        return trial, closed, z, functions
    if singular is not None:
        raise singular
    raise Chattering("no mode holds after this instant")


def _near_crossing(functions: EventFunctions) -> set[int]:
    """The pairs whose function, in the mode being left at an instant, is falling within
    :data:`NEAR_ZERO` tolerances of zero (by more than its slope's round-off): pairs that mode
    switches within a few round-offs of the instant, which :func:`choose_mode` enumerates
    with those its flipping moved. The transformer-fed bridge's blocking mode
    (``netlists/transformer_rectifier.cir``) computes its diodes' voltages to ±2e-6 and ±5e-6 V
    only (its floating secondary's −1.8e17 /s leakage part): at the start-up ringing's
    turn-offs one diode of a pair was at zero, the other 4 tolerances above it and falling
    at 2,577 V/s, so the flipping moved one alone, found no mode, and θ took 16 steps; with
    both enumerated, the pair's mode is found."""
    values = functions.at_start()
    near = set()
    for k, ((kind, index), value, tol) in enumerate(zip(functions.labels, values, functions.tolerances)):
        if kind == "pair" and abs(value) <= NEAR_ZERO * tol:
            slope, slope_tol = _at_zero(*_column_derivative(functions.table, k))
            if slope < -slope_tol:
                near.add(index)
    return near


def _excess(functions: EventFunctions, bad: list[tuple[str, int]]) -> float:
    """How far below its tolerance the worst violated function of a mode is (its value over
    its tolerance); infinite if one is violated by its slope (it leaves the mode at once)."""
    values = functions.at_start()
    worst = 0.0
    for k, label in enumerate(functions.labels):
        if label in bad:
            if values[k] >= -functions.tolerances[k]:
                return math.inf
            worst = max(worst, -values[k] / functions.tolerances[k])
    return worst


# The C loop (_exact_native.c): the order of its arguments' entries (its A_*, S_* enums)
NATIVE_ARRAYS = ("clock", "counters", "x", "y_size", "sources_now", "widened", "corners",
                 "source_coefficients", "source_exponents", "source_powers", "partner", "s_matrix", "bits",
                 "z_map", "table_map", "powers", "exponents", "terms", "slope_weights", "rows_p", "rows_q",
                 "rows_y", "rows_c", "fast_rows", "gap_rows", "v1t", "times", "y_out", "l_out", "charges",
                 "row_active", "row_closed", "event_times", "event_index", "event_on", "tail_row", "tail_dt",
                 "tail_y", "first", "entries")
"""The arrays whose addresses the C loop takes, in its order (each C-contiguous, of the dtype
:data:`_NATIVE_DTYPES` gives, float64 otherwise): the numba loop's arguments, then
:data:`NATIVE_ONLY`."""
NATIVE_ONLY = ("first", "entries")
"""The arrays only the C loop takes: each mode's nonzero entries (:meth:`.ModeTables._list`;
the numba loop sums over the dense maps)."""
NATIVE_SIZES = ("n", "m", "columns", "states", "source_terms", "signals", "corners", "known", "terms_max",
                "inputs", "rows", "event_capacity", "tail_capacity")
"""The integers the C loop takes, in its order."""
_NATIVE_DTYPES = {"counters": np.int64, "sources_now": np.complex128, "source_coefficients": np.complex128,
                  "source_exponents": np.complex128, "source_powers": np.int64, "partner": np.int64,
                  "bits": np.bool_, "z_map": np.complex128, "table_map": np.complex128, "powers": np.int64,
                  "exponents": np.complex128, "terms": np.int64, "slope_weights": np.complex128,
                  "row_active": np.bool_, "row_closed": np.bool_, "event_index": np.int64,
                  "event_on": np.bool_, "tail_row": np.int64, "first": np.int64, "entries": np.int32}
_WRITTEN = frozenset({"clock", "counters", "x", "y_size", "sources_now", "widened", "y_out", "l_out",
                      "charges", "row_active", "row_closed", "event_times", "event_index", "event_on",
                      "tail_row", "tail_dt", "tail_y"})
OUT_OF_MEMORY = 4
"""What the C loop returns when it could not allocate its scratch (nothing done)."""


@functools.cache
def native_loop():
    """The C loop's function (``int64 circuitnsds_exact_loop(void **arrays, int64 *sizes)``), or
    ``None``: not built, or disabled (:mod:`circuitnsds.native`)."""
    return native.function("engine/exact/_exact_native", "circuitnsds_exact_loop",
                           [ctypes.c_void_p, ctypes.c_void_p], ctypes.c_int64)


def _native_call(function, arrays: dict[str, np.ndarray], sizes: tuple[int, ...]) -> int:
    """One call of the C loop on ``arrays`` (named as :data:`NATIVE_ARRAYS`): each checked for
    its dtype and contiguity (a read-only one laid out otherwise is converted; one the loop
    writes must be as it needs: ``run_exact`` makes them so)."""
    addresses = np.zeros(len(NATIVE_ARRAYS), dtype=np.uintp)
    keep = []
    for i, name in enumerate(NATIVE_ARRAYS):
        array = arrays[name]
        dtype = _NATIVE_DTYPES.get(name, np.float64)
        if array.dtype != dtype or not array.flags.c_contiguous or not array.flags.aligned:
            if name in _WRITTEN:
                raise ValueError(f"the exact C loop's array {name} is not a C-contiguous {np.dtype(dtype)}")
            array = np.ascontiguousarray(array, dtype=dtype)
            keep.append(array)
        addresses[i] = array.ctypes.data
    size_array = np.array(sizes, dtype=np.int64)
    status = int(function(addresses.ctypes.data, size_array.ctypes.data))
    if status == OUT_OF_MEMORY:
        raise MemoryError("the exact integrator's C loop could not allocate its scratch")
    return status


def run_exact(mlcs: MLCS, times: np.ndarray, y0: np.ndarray, active0: np.ndarray,
              closed0: tuple[bool, ...], *, resume: LoopState | None = None,
              system: ExactSystem | None = None, stop: float | None = None,
              record: list[Segment] | None = None,
              out: tuple[np.ndarray, ...] | None = None) -> ExactRun:
    """Integrate exactly from ``y0`` at ``times[0]`` (0 unless resumed) to ``times[-1]``,
    writing a row at each of ``times``: in the compiled loop (:mod:`.loop`: the C library's
    when built, :func:`native_loop`, else numba's) over the modes met so far, Python choosing
    the mode only where the loop meets one it does not know;
    in Python (:func:`run_python`, the same arithmetic to round-off) without either or when
    ``record`` asks for the segments.

    ``resume``: the loop state to go on from (``y0`` is then row 0 only, and ``times[0]`` is
    at or after ``resume.t``); ``system``: the prepared system to reuse (its modes and
    tables cached); ``stop`` [s]: the end of the whole run when this is a part of it (the
    sources' pieces end at their corners or there, as in the whole run); ``record``: a list
    that gets each segment computed (:class:`Segment`: what the period map's derivative
    needs); ``out``: the arrays ``(y, currents, charges, active, closed)`` to write the rows
    into (C-contiguous, ``len(times)`` rows or more: the stepper's own, which saves a copy
    of every row; the Python path ignores it).

    Raises:
        Chattering, NotIndexOne: with ``run`` (the rows written before) and ``time`` set.
    """
    function = native_loop()
    if (function is None and not AVAILABLE) or record is not None:
        return run_python(mlcs, times, y0, active0, closed0, resume=resume, system=system, stop=stop,
                          record=record)
    system = ExactSystem(mlcs) if system is None else system
    times = np.asarray(times, dtype=float)
    sources, tables = system.tables(float(times[-1]) if stop is None else stop)
    n, m, w = system.n, system.m, len(closed0)
    count = len(times)
    if out is None:
        Y, L, charges = np.zeros((count, n)), np.zeros((count, m)), np.zeros((count, m))
        row_active, row_closed = np.zeros((count, m), bool), np.zeros((count, w), bool)
    else:  # (the caller's rows, C-contiguous, at least count of them: written in place)
        Y, L, charges, row_active, row_closed = (array[:count] for array in out)
        charges[1:] = 0.0  # (summed into)
    Y[0] = y0
    row_active[0], row_closed[0] = active0, closed0
    if resume is None:
        resume = LoopState(0.0, system.coordinates.V1.T @ y0, np.abs(y0),
                           np.asarray(active0, dtype=bool), tuple(closed0))
    clock = np.array([resume.t])
    x = np.array(resume.x, dtype=float)
    y_size = np.array(resume.y_size, dtype=float)
    counters = np.zeros(COUNTERS, np.int64)
    counters[0] = sources.interval(resume.t)
    counters[3] = 1
    counters[7] = int(resume.announced)
    widened = np.zeros(tables.columns)
    sources_now = np.zeros(sources.coefficients.shape[1:], complex)
    v1t = np.ascontiguousarray(system.coordinates.V1.T)
    # events and tails of a part (doubled when full; np.zeros leaves untouched pages unallocated)
    capacity = max(4096, len(times) // 16)
    event_times = np.zeros(capacity)
    event_index, event_on = np.zeros(capacity, np.int64), np.zeros(capacity, bool)
    tail_row, tail_dt, tail_y = np.zeros(capacity, np.int64), np.zeros(capacity), np.zeros((capacity, n))

    def state() -> LoopState:
        active, closed = tables.mode_of(int(counters[1]))
        return LoopState(float(clock[0]), x.copy(), y_size.copy(), active, closed, bool(counters[7]))

    def result() -> ExactRun:
        names = np.array(list(mlcs.pairs) + [switch.name for switch in mlcs.switches], dtype=object)
        used = int(counters[4])
        events = switch_events(event_times[:used].tolist(), names[event_index[:used]].tolist(),
                               event_on[:used].tolist())
        written = int(counters[8])
        tails = TailTable(tail_row[:written], tail_dt[:written], tail_y[:written])
        return ExactRun(times, Y, L, events, int(counters[5]), row_active, row_closed, charges, tails,
                        state(), int(counters[3]))

    def choose(active: np.ndarray, closed: tuple[bool, ...]) -> None:
        """The mode at ``clock[0]`` chosen in Python from ``(active, closed)``, its events
        reported, the loop told to take it."""
        t = float(clock[0])
        piece = ExpPoly(sources.piece(int(counters[0]), t).coefficients, sources.powers, sources.exponents)
        new_active, new_closed, _, functions = choose_mode(system, active, closed, x, piece, y_size, t,
                                                           solution=False)
        if not counters[7]:
            before = np.concatenate([active, closed])
            after = np.concatenate([new_active, new_closed])
            for c in np.flatnonzero(before != after):
                event_times[counters[4]], event_index[counters[4]] = t, c
                event_on[counters[4]] = after[c]
                counters[4] += 1
        tables.add_all_built()
        counters[1] = tables.add(new_active, new_closed)
        counters[2] = 1
        counters[7] = 1  # (reported: the loop does not report them again)
        # Python's tolerances, widened where it took a mode below a leakage (LEAKAGE_EXCESS),
        # are the least the loop's take for this segment
        widened[:] = functions.tolerances

    try:
        try:
            counters[1] = tables.add(np.asarray(resume.active, bool), tuple(resume.closed))
        except NotIndexOne:  # (a mode without state equations to start from: Python leaves it)
            choose(np.asarray(resume.active, bool), tuple(resume.closed))
        while True:
            if function is not None:
                status = _native_call(function, {
                    "clock": clock, "counters": counters, "x": x, "y_size": y_size,
                    "sources_now": sources_now, "widened": widened, "corners": sources.corners,
                    "source_coefficients": sources.coefficients, "source_exponents": sources.exponents,
                    "source_powers": sources.powers, "partner": sources.partner, "s_matrix": system.S,
                    "bits": tables.bits, "z_map": tables.z_map, "table_map": tables.table_map,
                    "powers": tables.powers, "exponents": tables.exponents, "terms": tables.terms,
                    "slope_weights": tables.slope_weights, "rows_p": tables.rows_p, "rows_q": tables.rows_q,
                    "rows_y": tables.rows_y, "rows_c": tables.rows_c, "fast_rows": tables.fast_rows,
                    "gap_rows": tables.gap_rows,
                    "v1t": v1t, "times": times, "y_out": Y,
                    "l_out": L, "charges": charges, "row_active": row_active, "row_closed": row_closed,
                    "event_times": event_times, "event_index": event_index, "event_on": event_on,
                    "tail_row": tail_row, "tail_dt": tail_dt, "tail_y": tail_y, "first": tables.first,
                    "entries": tables.entries},
                    (n, m, tables.columns, x.size, sources.coefficients.shape[1],
                     sources.coefficients.shape[2], sources.corners.size, tables.known,
                     tables.powers.shape[1], tables.inputs, count, capacity, capacity))
            else:
                status = exact_loop(clock, counters, x, y_size, sources_now, widened, sources.corners,
                                    sources.coefficients, sources.exponents, sources.powers, sources.partner,
                                    system.S, tables.bits, tables.known, tables.z_map, tables.table_map,
                                    tables.powers, tables.exponents, tables.terms, tables.slope_weights,
                                    tables.rows_p, tables.rows_q, tables.rows_y, tables.rows_c,
                                    tables.fast_rows, tables.gap_rows, v1t, times, Y, L, charges, row_active,
                                    row_closed, event_times, event_index, event_on, tail_row, tail_dt, tail_y)
            if status == FINISHED:
                break
            if status == STALLED:
                raise Chattering(_stalled(float(clock[0])))
            if counters[4] + tables.columns > capacity or counters[8] + 1 > capacity:  # (EVENTS_FULL)
                capacity *= 2
                event_times, event_index, event_on, tail_row, tail_dt = (
                    np.resize(a, capacity) for a in (event_times, event_index, event_on, tail_row, tail_dt))
                tail_y = np.resize(tail_y, (capacity, n))
            if status == NEW_MODE:
                choose(*tables.mode_of(int(counters[1])))
    except (Chattering, NotIndexOne) as exc:
        exc.time = float(clock[0])
        exc.run = result()
        raise
    return result()


def run_python(mlcs: MLCS, times: np.ndarray, y0: np.ndarray, active0: np.ndarray,
               closed0: tuple[bool, ...], *, resume: LoopState | None = None,
               system: ExactSystem | None = None, stop: float | None = None,
               record: list[Segment] | None = None) -> ExactRun:
    """:func:`run_exact` in Python (every segment through :func:`choose_mode`): what runs
    without numba or with ``record``, and the reference of the compiled loop."""
    system = ExactSystem(mlcs) if system is None else system
    last_time = float(times[-1])
    sources_table, _ = system.tables(last_time if stop is None else stop)
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
    events: list[SwitchEvent] = []
    segments = 0
    stalled = 0
    state = resume
    try:
        while t < last_time or (t == last_time and row < len(times)):
            state = LoopState(t, x, y_size, active, closed, quiet)
            k = sources_table.interval(t)
            end = float(sources_table.corners[k + 1])
            sources = sources_table.piece(k, t)
            new_active, new_closed, z, functions = choose_mode(system, active, closed, x, sources,
                                                               y_size, t)
            if not quiet:
                for j in np.flatnonzero(new_active != active):
                    events.append(SwitchEvent(t, mlcs.pairs[j], bool(new_active[j])))
                for k in (k for k in range(len(closed)) if new_closed[k] != closed[k]):
                    events.append(SwitchEvent(t, mlcs.switches[k].name, bool(new_closed[k])))
            quiet = False
            active, closed = new_active, new_closed
            mode = system.mode(active, closed)
            horizon = end - t
            # every function at once, compiled (:mod:`.first_event`), then a crossing inside
            # the tolerance (:func:`.first_event.crossed_within_tolerance`): the C library's
            # search where it is built (the same bits as numba's, without loading numba: 0.75 s
            # of an exact pss's 1.2 s), else numba's
            table = functions.table
            coefficients = np.ascontiguousarray(table.coefficients)
            powers = table.powers.astype(np.int64)
            found = native_first_event(coefficients, powers, table.exponents, functions.tolerances, horizon)
            if found is None:
                tau, column = first_event(coefficients, powers, table.exponents, functions.tolerances,
                                          horizon, 1e-13)
                tau, column = crossed_within_tolerance(coefficients, powers, table.exponents,
                                                       functions.tolerances, tau, column, horizon, 1e-13)
            else:
                tau, column = found
            ended_by = None if column < 0 else int(column)
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
            # segments that do not advance the time (an event at the instant itself), or hardly
            # (CHATTERING), are legitimate a few at a time; more is a loop that would never end,
            # or a chattering pair's
            stalled = stalled + 1 if new_t - t < CHATTERING * float(sources_table.corners[-1]) else 0
            if stalled > MAX_MODE_CHANGES:
                raise Chattering(_stalled(t))
            t = new_t
    except (Chattering, NotIndexOne) as exc:
        exc.time = t
        exc.run = ExactRun(np.asarray(times, dtype=float), Y, L, events, segments, row_active,
                           row_closed, charges, tails, state, row)
        raise
    return ExactRun(np.asarray(times, dtype=float), Y, L, events, segments, row_active, row_closed,
                    charges, tails, state, row)
