"""The stepping loop for steps whose mode is already known (docs/method.md, "mode reuse").

While the active set of the complementarity pairs, the switch states and the
step size stay the same, one θ-method step is an affine map

    x_{k+1} = [y_{k+1}; λ_α] = P y_k + Q1 f_{k+1} + Q0 f_k + c

(``f`` the sources' values, ``λ_α = μ_α/h`` the currents of the active pairs),
valid as long as ``λ_α >= 0`` and the inactive pairs' ``w = W x + e_w >= 0``:
then ``x`` *is* the step's MLCP solution (the equations hold by construction, up
to the rounding of the products). A sign counts as holding when the value is
``>= 0`` or negative by less than :data:`SIGN_TOL` times the sum of the
magnitudes of the terms that make it up: rounding noise, as for a diode at zero
current on both sides. The MLCP solver accepts a guessed mode by a test of the
same kind (:meth:`circuitnsds.solvers.MLCPSolver._signs_hold`), measured against
the rows of the step matrix instead, so in such degenerate cases the two may
settle a pair on different sides within that tolerance.

A :class:`ModeTable` keeps the maps of every mode seen so far, padded into
arrays indexed by mode. :func:`run_table` applies them step after step. When
the step size class or the state of the source-scheduled switches changes, it
continues with the mode that class and switch state had the last time. When a
step's signs fail, the loop looks for the step's mode among the stored modes of the
same class and switch states (:func:`_find_mode_scalar`), and takes the first whose
signs hold if the step's LCP is certified to have one solution for every state (a
P-matrix, :meth:`circuitnsds.solvers.MLCPSolver.unique_solutions`, stored per mode as
``unique``) and every pair of that mode is off zero by more than :data:`CLEAR_TOL` of
its terms: then it is the step's solution, the one the MLCP solver would find. It
returns to the caller when a step's signs fail and no stored mode is certain (the
caller solves that step as an MLCP, which decides the new mode, and the table grows by
it), when no mode is stored for the step's class and switch state, when a
state-controlled switch must change, or at the end. A converter thus runs its
thousands of periods in one call once both phases' modes are known, and a ringing
circuit its thousands of mode changes once it has seen its modes.

The loop exists three times, one logic: ``stepping="compiled"`` (and ``auto`` once it
pays) runs it compiled, **in C** when the library ``_dense_native`` was built at install
(``_dense_native.c``, loaded with ctypes by :mod:`circuitnsds.native`: nothing to load or
compile at run time, so a run goes compiled from its first step and never imports numba
for it), **else compiled by numba** (:mod:`circuitnsds.jit`: on its first compiled
call, cached per user; ~0.6 s to load in each process). The two give the same numbers bit
for bit (the C source keeps every floating-point operation of the scalar functions here,
in the same order, built without contraction or reassociation; edit them together).
``use_compiled=False`` runs the same loop in Python with a numpy step (same arithmetic up
to the summation order of the products: results agree to rounding, not bit for bit).
"""

from __future__ import annotations

import ctypes
import functools
import weakref
from typing import NamedTuple

import numpy as np

from circuitnsds import native
from circuitnsds.engine.step_system import ModeBlocks
from circuitnsds.jit import AVAILABLE, jit, python_version
from circuitnsds.solvers.linalg import SIGN_TOL, factorise

STOP_LEFT_MODE = 0
"""Step ``k`` leaves its mode: a sign fails (nothing written for it)."""
STOP_NO_MODE = 4
"""No mode is stored for the class and switch state of step ``k`` (nothing written for it)."""
STOP_SWITCH = 1
"""A state-controlled switch must change after step ``k - 1``."""
STOP_END = 3
"""``k_end`` reached."""
STOP_SCHEDULE = 2
"""(Sparse loop only) the step size class or a scheduled switch state changes at step ``k``."""

CLEAR_TOL = 1e-10
"""A mode found in the table for a step whose mode changed (:func:`_find_mode_scalar`) is
taken only when every pair's value (active current, inactive ``w``) is positive by more
than this times the magnitudes of its terms: far above the products' rounding (~1e-15),
and at the tie tolerance of the MLCP solver's Lemke pivoting, so that a pair this clearly
on one side is on that side in the solver's answer too. Below it a pair is at zero on both
sides for all the arithmetic can tell, and the MLCP solver decides."""

TABLE_BYTES = 64 * 2**20
"""Memory the padded arrays of a :class:`ModeTable` may take [bytes]."""


class ModeMap(NamedTuple):
    """The affine step map of one mode (see module docstring); dense arrays.

    Attributes:
        P: ``(n + a, n)``; Q1, Q0: ``(n + a, k)``; c: ``(n + a,)``.
        W: ``(m, n + a)`` and e_w ``(m,)``: ``w = W x + e_w`` of the inactive pairs (the
            first ``m - a`` rows), then of the active ones (``0`` by construction; their
            terms are the scale a negative ``λ_α`` is measured against).
        resistance: ``(a,)``, ``∂w_i/∂λ_i`` of each active pair [Ω]: the shift of ``w_i``
            per ampere removed from the pair (``inf`` when its current is forced).
        active: indices of the active pairs (``a`` of them).

    A :class:`ModeTable` keeps the maps of its modes in the same fields, stacked along a
    first axis (one row per mode) and padded.
    """

    P: np.ndarray
    Q1: np.ndarray
    Q0: np.ndarray
    c: np.ndarray
    W: np.ndarray
    e_w: np.ndarray
    resistance: np.ndarray
    active: np.ndarray


def dense_mode_map(blocks: ModeBlocks, n: int) -> ModeMap | None:
    """The :class:`ModeMap` of a mode's step system (``n`` circuit unknowns; ``blocks`` from
    ``mode_blocks(..., dense=True)``); ``None`` when its bordered matrix is singular by the
    MLCP solver's own test (so both agree) or the map is not finite."""
    lu = factorise(blocks.bordered)
    if not lu.ok:
        return None
    kstim = blocks.S_next.shape[1]
    right = np.zeros((blocks.bordered.shape[0], n + 2 * kstim + 1))
    right[:n, :n] = blocks.carry
    right[:n, n:n + kstim] = blocks.S_next
    right[:n, n + kstim:n + 2 * kstim] = blocks.S_now
    right[n:, -1] = blocks.rhs_pairs
    solution = lu.solve(right)
    if not np.all(np.isfinite(solution)):
        return None
    a = blocks.active.size
    # ∂λ_i/∂w_i of each active pair: the inverse's diagonal at the pair rows (its reciprocal is
    # the resistance the pair sees; see _try_mode_scalar)
    unit = np.zeros((blocks.bordered.shape[0], a))
    unit[n + np.arange(a), np.arange(a)] = 1.0
    gain = np.abs(np.diagonal(lu.solve(unit)[n:]))
    with np.errstate(divide="ignore"):
        resistance = np.where(gain > 0.0, 1.0 / gain, np.inf)
    return ModeMap(P=solution[:, :n], Q1=solution[:, n:n + kstim], Q0=solution[:, n + kstim:n + 2 * kstim],
                   c=solution[:, -1], W=np.vstack([blocks.W, blocks.W_active]),
                   e_w=np.concatenate([blocks.e_w, blocks.e_active]), resistance=resistance,
                   active=blocks.active)


class TableArrays(NamedTuple):
    """The arrays of a :class:`ModeTable` as the loop takes them (one argument; see there):
    the stacked maps and, per mode, its sizes, class and switch states, last use, whether
    its step's LCP is certified to have one solution, and the mode that followed it."""

    maps: ModeMap
    rows: np.ndarray
    nw: np.ndarray
    mode_class: np.ndarray
    mode_sched: np.ndarray
    mode_free: np.ndarray
    last_used: np.ndarray
    unique: np.ndarray
    successor: np.ndarray


class FreeSwitches(NamedTuple):
    """The switches the loop watches (state-controlled ones): ``controls`` ``(s, n)`` dense
    (the control as a combination of the unknowns), thresholds in the control's unit
    (V or A) and the current states (closed = true)."""

    controls: np.ndarray
    on_threshold: np.ndarray
    off_threshold: np.ndarray
    switch_on: np.ndarray


class ModeTable:
    """The dense step maps of the modes seen so far, padded into arrays indexed by mode.

    A mode is identified by its step class (step size, and whether the step is a
    θ = 1 restart), the id of the scheduled switches' states, the id of the other
    switches' states and the active set. Row ``i`` of the arrays holds mode ``i``:
    ``P[i, :rows[i]]`` etc. (``rows = n + a``), ``W[i, :nw[i], :rows[i]]``
    (``nw = m - a``). When full, the table starts afresh.
    """

    def __init__(self, n: int, m: int, kstim: int, budget: int = TABLE_BYTES, most: int = 256):
        self.n, self.m, self.kstim = n, m, kstim
        width = n + m
        per_mode = 8 * (width * n + 2 * width * kstim + width + m * width + 4 * m + 8)
        self.capacity = int(max(1, min(most, budget // per_mode)))
        self.count = 0
        self.index: dict[tuple, int] = {}
        self.native_arguments = None  # the C loop's arguments (dense_loop._run_native)
        self._allocate(min(self.capacity, 4))

    def _allocate(self, size: int) -> None:
        n, m, ks, width = self.n, self.m, self.kstim, self.n + self.m
        fresh = {
            "P": np.zeros((size, width, n)), "Q1": np.zeros((size, width, ks)),
            "Q0": np.zeros((size, width, ks)), "c": np.zeros((size, width)),
            "W": np.zeros((size, m, width)), "e_w": np.zeros((size, m)),
            "resistance": np.zeros((size, m)),
            "active": np.zeros((size, m), dtype=np.int64), "mask": np.zeros((size, m), dtype=bool),
            "rows": np.zeros(size, dtype=np.int64), "nw": np.zeros(size, dtype=np.int64),
            "mode_class": np.zeros(size, dtype=np.int64), "mode_sched": np.zeros(size, dtype=np.int64),
            "mode_free": np.zeros(size, dtype=np.int64), "last_used": np.zeros(size, dtype=np.int64),
            "unique": np.zeros(size, dtype=bool), "successor": np.full(size, -1, dtype=np.int64),
        }
        for name, array in fresh.items():
            old = getattr(self, name, None)
            if old is not None:
                array[:self.count] = old[:self.count]
            setattr(self, name, array)

    def arrays(self) -> TableArrays:
        """The padded arrays, for the loop."""
        maps = ModeMap(*(getattr(self, name) for name in ModeMap._fields))
        return TableArrays(maps, *(getattr(self, name) for name in TableArrays._fields[1:]))

    def find(self, key: tuple) -> int | None:
        """Index of the mode ``key`` (``(class, sched, free, active bytes)``), if stored."""
        return self.index.get(key)

    def add(self, key: tuple, mode: ModeMap, unique: bool = False) -> int:
        """Store ``mode`` under ``key`` = ``(class, sched, free, active bytes)``; returns its index.

        ``unique``: the step's LCP (its class and switch states) is certified to have one
        solution for every state (:meth:`circuitnsds.solvers.MLCPSolver.unique_solutions`),
        so that the loop may look for the next mode among the stored ones."""
        if self.count == self.capacity:
            self.count = 0
            self.index.clear()
        if self.count == self.P.shape[0]:
            self._allocate(min(self.capacity, 2 * self.P.shape[0]))
        i = self.count
        for name, value in zip(ModeMap._fields, mode, strict=True):
            getattr(self, name)[(i, *(slice(0, size) for size in value.shape))] = value
        self.mask[i] = False
        self.mask[i, mode.active] = True
        self.rows[i], self.nw[i] = mode.P.shape[0], self.m - mode.active.size
        self.mode_class[i], self.mode_sched[i], self.mode_free[i] = key[0], key[1], key[2]
        self.last_used[i] = -1
        self.unique[i] = unique
        self.successor[i] = -1
        self.index[key] = i
        self.count += 1
        return i


def _pair_magnitude_scalar(mode, r, k, y, F, P, Q1, Q0, c):
    """The sum of the magnitudes of the terms that make up row ``r`` (a pair current) of
    ``mode``'s step map at step ``k``: the scale against which its sign is judged."""
    magnitude = abs(c[mode, r])
    for j in range(y.shape[1]):
        magnitude += abs(P[mode, r, j] * y[k, j])
    for j in range(F.shape[1]):
        magnitude += abs(Q1[mode, r, j] * F[k + 1, j]) + abs(Q0[mode, r, j] * F[k, j])
    return magnitude


def _inactive_w_scalar(mode, r, size, W, e_w, x):
    """``(w, magnitude)``: the ``w`` of ``mode``'s ``r``-th inactive pair (row ``r`` of ``W``,
    ``e_w``) for the step ``x``, and the sum of the magnitudes of its terms."""
    acc = e_w[mode, r]
    magnitude = abs(acc)
    for j in range(size):
        term = W[mode, r, j] * x[j]
        acc += term
        magnitude += abs(term)
    return acc, magnitude


def _try_mode_scalar(mode, k, y, F, P, Q1, Q0, c, W, e_w, resistance, rows, nw, x):
    """Step ``k`` with mode ``mode`` into ``x``; whether its complementarity signs hold.

    A sign holds when the value is ``>= 0`` or, like the MLCP solver's test of a guessed
    mode, negative by less than ``SIGN_TOL`` times the sum of the magnitudes of the terms
    that make it up (rounding noise of a pair at zero on both sides: a diode carrying
    -3e-12 A out of terms of amperes in a voltage multiplier). A negative current must
    moreover be harmless where it acts: removing it shifts the pair's ``w`` by
    ``|λ_i|·resistance_i``, which must stay within ``SIGN_TOL`` of the magnitude of the
    terms of that ``w`` (as :func:`circuitnsds.solvers.mlcp.negative_current_harmless`):
    -6e-10 A is rounding beside amperes, but 160 V on a node held by 1e-12 S.
    """
    n = y.shape[1]
    size = rows[mode]
    kstim = F.shape[1]
    inactive = nw[mode]
    for r in range(size):
        acc = c[mode, r]
        for j in range(n):
            acc += P[mode, r, j] * y[k, j]
        for j in range(kstim):
            acc += Q1[mode, r, j] * F[k + 1, j] + Q0[mode, r, j] * F[k, j]
        x[r] = acc
    for r in range(n, size):
        if x[r] < 0.0:
            if x[r] < -SIGN_TOL * _pair_magnitude(mode, r, k, y, F, P, Q1, Q0, c):
                return False
            _, scale = _inactive_w(mode, inactive + r - n, size, W, e_w, x)
            if -x[r] * resistance[mode, r - n] > SIGN_TOL * scale:
                return False
    for r in range(inactive):
        w, magnitude = _inactive_w(mode, r, size, W, e_w, x)
        if w < -SIGN_TOL * magnitude:
            return False
    return True


def _try_mode_numpy(mode, k, y, F, P, Q1, Q0, c, W, e_w, resistance, rows, nw, x):
    """:func:`_try_mode_scalar` with numpy products (the loop without numba); the magnitudes
    of the terms are computed only for a value that is negative."""
    n, size, q = y.shape[1], rows[mode], nw[mode]
    x[:size] = P[mode, :size] @ y[k] + Q1[mode, :size] @ F[k + 1] + Q0[mode, :size] @ F[k] + c[mode, :size]
    if (x[n:size] < 0.0).any():
        magnitude = (np.abs(P[mode, n:size]) @ np.abs(y[k]) + np.abs(Q1[mode, n:size]) @ np.abs(F[k + 1])
                     + np.abs(Q0[mode, n:size]) @ np.abs(F[k]) + np.abs(c[mode, n:size]))
        if (x[n:size] < -SIGN_TOL * magnitude).any():
            return False
        a = size - n
        scale = np.abs(W[mode, q:q + a, :size]) @ np.abs(x[:size]) + np.abs(e_w[mode, q:q + a])
        shift = np.where(x[n:size] < 0.0, -x[n:size] * resistance[mode, :a], 0.0)
        if (shift > SIGN_TOL * scale).any():
            return False
    w = W[mode, :q, :size] @ x[:size] + e_w[mode, :q]
    if (w < 0.0).any():
        magnitude = np.abs(W[mode, :q, :size]) @ np.abs(x[:size]) + np.abs(e_w[mode, :q])
        return not (w < -SIGN_TOL * magnitude).any()
    return True


def _clear_scalar(mode, k, y, F, P, Q1, Q0, c, W, e_w, rows, nw, x):
    """Whether the step ``x`` of ``mode`` (from :func:`_try_mode_scalar`) is strictly
    complementary: every active pair's current and every inactive pair's ``w`` is positive by
    more than :data:`CLEAR_TOL` times the magnitudes of its terms. Otherwise a pair sits at
    zero on both sides as far as the arithmetic can tell, another mode may be as good, and
    the MLCP solver must decide (it compares them componentwise)."""
    size = rows[mode]
    for r in range(y.shape[1], size):
        if not x[r] > CLEAR_TOL * _pair_magnitude(mode, r, k, y, F, P, Q1, Q0, c):
            return False
    for r in range(nw[mode]):
        w, magnitude = _inactive_w(mode, r, size, W, e_w, x)
        if not w > CLEAR_TOL * magnitude:
            return False
    return True


def _clear_numpy(mode, k, y, F, P, Q1, Q0, c, W, e_w, rows, nw, x):
    """:func:`_clear_scalar` with numpy products (the loop without numba)."""
    n, size, q = y.shape[1], rows[mode], nw[mode]
    magnitude = (np.abs(P[mode, n:size]) @ np.abs(y[k]) + np.abs(Q1[mode, n:size]) @ np.abs(F[k + 1])
                 + np.abs(Q0[mode, n:size]) @ np.abs(F[k]) + np.abs(c[mode, n:size]))
    if not (x[n:size] > CLEAR_TOL * magnitude).all():
        return False
    w = W[mode, :q, :size] @ x[:size] + e_w[mode, :q]
    magnitude = np.abs(W[mode, :q, :size]) @ np.abs(x[:size]) + np.abs(e_w[mode, :q])
    return bool((w > CLEAR_TOL * magnitude).all())


def _find_mode_scalar(failed, k, y, F, P, Q1, Q0, c, W, e_w, resistance, rows, nw, mode_class,
                      mode_sched, mode_free, unique, successor, count, x):
    """The stored mode that solves step ``k``, whose mode ``failed`` left its signs, or -1.

    Only for a step whose LCP is certified to have exactly one solution (``unique``, a
    P-matrix): then a mode of the same class and switch states that is strictly
    complementary *is* that solution, whichever is tried first. Tried first: the mode that followed ``failed``
    the last time (a ringing circuit repeats its sequence), then every other of its class
    and switch states. The first that passes :func:`_try_mode_scalar` and
    :func:`_clear_scalar` (strictly complementary: the exact solution, whatever was tried
    before it) is returned, with ``x`` holding its step; -1 when none does (a new mode, or
    a pair at zero on both sides: the MLCP solver decides).
    """
    if not unique[failed]:
        return -1
    first = successor[failed]
    for attempt in range(count + 1):
        i = first if attempt == 0 else attempt - 1
        if i < 0 or i == failed or (attempt > 0 and i == first):
            continue
        if (mode_class[i] != mode_class[failed] or mode_sched[i] != mode_sched[failed]
                or mode_free[i] != mode_free[failed]):
            continue
        if (_try_mode(i, k, y, F, P, Q1, Q0, c, W, e_w, resistance, rows, nw, x)
                and _clear(i, k, y, F, P, Q1, Q0, c, W, e_w, rows, nw, x)):
            return i
    return -1


def _table_loop(k0, k_end, mode, class0, y, z, F, step_class, sched_state, free_id, table, count,
                free, used, x):
    """Step from ``k0`` over the modes of ``table`` (the fields of :class:`TableArrays`), watching
    the switches ``free`` (the fields of :class:`FreeSwitches`), with mode ``mode`` first
    (``class0`` the class of step ``k0``), until a step leaves its mode or has none stored,
    a state-controlled switch changes, or ``k_end``.

    Returns ``(k, reason, last)``: steps ``k0 .. k-1`` are done (``y[k0+1 .. k]``, the
    active columns of ``z[k0+1 .. k]``, the pair currents, and ``used[k0+1 .. k]``, the
    mode of each step, are written; ``z``'s other columns must hold zeros), ``reason`` is
    a ``STOP_*`` code, ``last`` the mode of the last step done (``mode`` if none).
    """
    # plain tuples in the order of TableArrays (its maps: of ModeMap) and FreeSwitches (named
    # tuples would be typed by numba's slow path at every call, ~0.1 ms)
    maps, rows, nw, mode_class, mode_sched, mode_free, last_used, unique, successor = table
    P, Q1, Q0, c, W, e_w, resistance, active = maps
    controls, on_threshold, off_threshold, switch_on = free
    n = y.shape[1]
    ns = controls.shape[0]
    last = mode
    k = k0
    while k < k_end:
        cls = class0 if k == k0 else step_class[k]
        if mode < 0 or mode_class[mode] != cls or mode_sched[mode] != sched_state[k]:
            # the step size or the scheduled switches changed: the mode this step's
            # class and switch states had the last time (the other phase of a converter)
            mode = -1
            for i in range(count):
                if (mode_class[i] == cls and mode_sched[i] == sched_state[k] and mode_free[i] == free_id
                        and (mode < 0 or last_used[i] > last_used[mode])):
                    mode = i
            if mode < 0:
                return k, STOP_NO_MODE, last
        if not _try_mode(mode, k, y, F, P, Q1, Q0, c, W, e_w, resistance, rows, nw, x):
            found = _find_mode(mode, k, y, F, P, Q1, Q0, c, W, e_w, resistance, rows, nw, mode_class,
                               mode_sched, mode_free, unique, successor, count, x)
            if found < 0:
                return k, STOP_LEFT_MODE, last  # the caller's MLCP finds the new mode
            successor[mode] = found
            mode = found
        y[k + 1, :] = x[:n]
        for r in range(n, rows[mode]):
            z[k + 1, active[mode, r - n]] = x[r]
        used[k + 1] = mode
        last_used[mode] = k
        last = mode
        k += 1
        for s in range(ns):
            value = 0.0
            for j in range(n):
                value += controls[s, j] * y[k, j]
            if switch_on[s]:
                if value < off_threshold[s]:
                    return k, STOP_SWITCH, last
            elif value > on_threshold[s]:
                return k, STOP_SWITCH, last
    return k, STOP_END, last


_pair_magnitude = jit(_pair_magnitude_scalar)
_inactive_w = jit(_inactive_w_scalar)
_try_mode = jit(_try_mode_scalar)
_clear = jit(_clear_scalar)
_find_mode = jit(_find_mode_scalar)
_compiled = jit(_table_loop)
# the same loop in Python with the numpy step: one copy of the loop's logic, two step kernels
_python_loop = python_version(
    _table_loop, _try_mode=_try_mode_numpy,
    _find_mode=python_version(_find_mode_scalar, _try_mode=_try_mode_numpy, _clear=_clear_numpy))


def _plain(arrays: TableArrays) -> tuple:
    """``arrays`` as nested plain tuples (what :func:`_table_loop` takes)."""
    return (tuple(arrays.maps), *arrays[1:])


# The C loop (_dense_native.c): the order of its arguments' entries (its A_*, S_* enums)
NATIVE_ARRAYS = ("P", "Q1", "Q0", "c", "W", "e_w", "resistance", "active", "rows", "nw", "mode_class",
                 "mode_sched", "mode_free", "last_used", "unique", "successor", "y", "z", "F", "step_class",
                 "sched_state", "used", "controls", "on", "off", "switch_on", "x")
"""The arrays whose addresses the C loop takes, in its order."""
NATIVE_SIZES = ("k0", "k_end", "mode", "class0", "free_id", "count", "n", "m", "kstim", "width", "switches",
                "y_row", "z_row", "F_row", "controls_row", "stop_left_mode", "stop_no_mode", "stop_switch",
                "stop_end")
"""The integers the C loop takes, in its order."""
_TABLE_NATIVE = 16  # the first 16 of NATIVE_ARRAYS are the table's
_WRITTEN = frozenset({"last_used", "successor", "y", "z", "used", "x"})
_DTYPES = {"active": np.int64, "rows": np.int64, "nw": np.int64, "mode_class": np.int64,
           "mode_sched": np.int64, "mode_free": np.int64, "last_used": np.int64, "unique": np.bool_,
           "successor": np.int64, "step_class": np.int64, "sched_state": np.int64, "used": np.int64,
           "switch_on": np.bool_}
@functools.cache
def _native_function():
    """The C loop's function (argument types declared), or ``None``: no library built, or
    disabled (:mod:`circuitnsds.native`)."""
    return native.function("engine/_dense_native", "circuitnsds_table_loop", [ctypes.c_void_p] * 4, None)


def native_loaded() -> bool:
    """Whether the C loop is built and loaded (the compiled loop without numba)."""
    return _native_function() is not None


def _row_stride(array: np.ndarray) -> int | None:
    """The row stride of a 2-D array in elements, or ``None`` if its rows are not contiguous."""
    if array.size == 0:
        return 0  # nothing is read (numpy gives such arrays any strides)
    rows, columns = array.strides
    size = array.itemsize
    if (columns != size and array.shape[1] > 1) or rows % size or rows < 0:
        return None
    return rows // size


def _laid_out(name: str, array: np.ndarray) -> bool:
    """Whether ``array`` can be handed to the C loop as its argument ``name``: the dtype, a
    contiguous row (rows anywhere for the 2-D run arrays), aligned, writeable if written."""
    dtype = _DTYPES.get(name, np.float64)
    if array.dtype != dtype or not array.flags.aligned or (name in _WRITTEN and not array.flags.writeable):
        return False
    if name in ("y", "z", "F", "controls"):
        return array.ndim == 2 and _row_stride(array) is not None
    return array.flags.c_contiguous


class _NativeArguments:
    """The arguments of one table's calls of the C loop: the arrays' addresses (each taken, and
    its layout checked, when a new array comes: most calls of a run pass the same ones) and
    the integers. Kept on the :class:`ModeTable`."""

    def __init__(self, width: int):
        self.addresses = np.zeros(len(NATIVE_ARRAYS), dtype=np.uintp)
        self.refs: list = [None] * len(NATIVE_ARRAYS)
        self.rows = [0] * len(NATIVE_ARRAYS)  # row strides [elements] of the 2-D arrays
        self.copies: list = []  # read-only arrays converted for the call
        self.sizes = np.zeros(len(NATIVE_SIZES), dtype=np.int64)
        self.tolerances = np.array([SIGN_TOL, CLEAR_TOL])
        self.out = np.zeros(3, dtype=np.int64)
        self.x = np.empty(width)
        self.pointers = tuple(a.__array_interface__["data"][0]
                              for a in (self.addresses, self.sizes, self.tolerances, self.out))

    def set(self, arrays: tuple[np.ndarray, ...]) -> bool:
        """Take the addresses of ``arrays`` (in the order of :data:`NATIVE_ARRAYS`); a read-only
        one laid out otherwise is copied as the loop needs it. ``False``: an array the loop
        writes is laid out otherwise (the caller then runs another loop)."""
        for i, array in enumerate(arrays):
            ref = self.refs[i]
            if ref is not None and ref() is array:
                continue
            name = NATIVE_ARRAYS[i]
            if not _laid_out(name, array):
                if name in _WRITTEN:
                    return False
                array = np.array(array, dtype=_DTYPES.get(name, np.float64), order="C")
                self.copies.append(array)
            if array.ndim == 2:
                self.rows[i] = _row_stride(array)
            self.addresses[i] = array.__array_interface__["data"][0]
            self.refs[i] = weakref.ref(array)
        return True


_Y, _Z, _F, _CONTROLS = (NATIVE_ARRAYS.index(name) for name in ("y", "z", "F", "controls"))


def _run_native(function, table: ModeTable, mode: int, class0: int, k0: int, k_end: int,
                y: np.ndarray, current: np.ndarray, F: np.ndarray, step_class: np.ndarray,
                sched_state: np.ndarray, free_id: int, free: FreeSwitches, used: np.ndarray
                ) -> tuple[int, int, int] | None:
    """:func:`_table_loop` by the C loop; ``None`` when an array it writes is not laid out for it."""
    n, m, kstim = table.n, table.m, table.kstim
    controls, on, off, switch_on = free
    switches = len(switch_on)
    # the bounds the loop relies on (it checks none): a caller's error, whichever loop runs
    if (y.ndim != 2 or y.shape[1] != n or current.ndim != 2 or current.shape[1] != m
            or F.ndim != 2 or F.shape[1] != kstim or controls.shape != (switches, n)
            or len(on) != switches or len(off) != switches or not 0 <= k0
            or (k_end > k0 and (min(y.shape[0], current.shape[0], F.shape[0], len(used)) <= k_end
                                or min(len(step_class), len(sched_state)) < k_end))
            or not -1 <= mode < table.count <= table.P.shape[0]):
        raise ValueError(f"run_table: arrays of other sizes than the table's (n {n}, m {m}, {kstim} "
                         f"sources) or steps {k0}..{k_end} beyond them")
    arguments = table.native_arguments
    if arguments is None:
        arguments = table.native_arguments = _NativeArguments(n + m)
    if not arguments.set((table.P, table.Q1, table.Q0, table.c, table.W, table.e_w, table.resistance,
                          table.active, table.rows, table.nw, table.mode_class, table.mode_sched,
                          table.mode_free, table.last_used, table.unique, table.successor, y, current,
                          F, step_class, sched_state, used, controls, on, off, switch_on, arguments.x)):
        return None
    rows = arguments.rows
    arguments.sizes[:] = (k0, k_end, mode, class0, free_id, table.count, n, m, kstim, n + m, switches,
                          rows[_Y], rows[_Z], rows[_F], rows[_CONTROLS], STOP_LEFT_MODE, STOP_NO_MODE,
                          STOP_SWITCH, STOP_END)
    function(*arguments.pointers)
    arguments.copies.clear()
    k, reason, last = arguments.out.tolist()
    return k, reason, last


def compiled_loaded() -> bool:
    """Whether the compiled loop runs in this process without a load to wait for: the C loop
    is built (:func:`native_loaded`), or numba's loop has been loaded (numba imported)."""
    return native_loaded() or (AVAILABLE and _compiled.loaded)


def run_table(table: ModeTable, mode: int, class0: int, k0: int, k_end: int, y: np.ndarray,
              current: np.ndarray, F: np.ndarray, step_class: np.ndarray, sched_state: np.ndarray,
              free_id: int, free: FreeSwitches, used: np.ndarray, use_compiled: bool = True,
              use_native: bool = True) -> tuple[int, int, int]:
    """Run the loop of :func:`_table_loop` over ``table``: with ``use_compiled``, the C loop when
    it is built (and ``use_native``), else numba's when numba is installed; otherwise (or
    without either) the same loop in Python with a numpy step. The C and numba loops give
    the same numbers bit for bit; the Python loop agrees with them to rounding."""
    if use_compiled and use_native:
        function = _native_function()
        if function is not None:
            done = _run_native(function, table, mode, class0, k0, k_end, y, current, F, step_class,
                               sched_state, free_id, free, used)
            if done is not None:
                return done
    loop = _compiled if use_compiled and AVAILABLE else _python_loop
    x = np.empty(table.n + table.m)
    k, reason, last = loop(k0, k_end, mode, class0, y, current, F, step_class, sched_state, free_id,
                           _plain(table.arrays()), table.count, tuple(free), used, x)
    return int(k), int(reason), int(last)
