"""The first event of a segment, compiled: every event function of the mode at once.

The same certified search as :mod:`.roots` (its module docstring: a lower bound per
interval from a Taylor model of the slow terms and the largest magnitude of the fast ones;
an interval that cannot be cleared is halved, left half first, so the root found is the
first one), written as loops over plain arrays so that numba compiles it
(:func:`circuitnsds.jit.jit`; without numba the same code runs in Python). The root is
refined by the Illinois method (regula falsi that halves the weight of an end kept twice)
to a bracket of a few ulps, the bracket kept at every step, so it stays in the interval
where the search certified the first sign change.

A segment's functions share their terms (the columns of one table); the search runs on the
columns that the bound over the whole segment does not clear, each up to the earliest root
found so far, so a later column costs nothing once an earlier root is known.
"""

from __future__ import annotations

import ctypes
import functools

import numpy as np

from circuitnsds import native
from circuitnsds.jit import jit

MAX_DEPTH = 200
"""Halvings of one interval at most (as :data:`.roots.MAX_DEPTH`)."""
MAX_STACK = 2 * MAX_DEPTH + 2
MAX_VISITS = 200_000
"""Intervals one search visits at most. A function that stays within its tolerance of zero
over a stretch (grazing, sliding) is never cleared by its bound there, and halving it down to
the resolution would visit 2^43 intervals: the search gives up (:data:`UNRESOLVED`) and the
loop stops as stalled, so the run hands the stretch to the θ-method, instead of computing on
without end where Ctrl-C cannot reach (measured: a suite run held 10 minutes there)."""
UNRESOLVED = -2.0
"""What a search that gave up returns (no instant is found: none is made up)."""
"""Intervals pending at most (a halving pushes two, pops one)."""
EPSILON = float(np.finfo(float).eps)


def _value(c, p, nu, tau):
    """``Re Σ c_j τ^p_j e^{ν_j τ}``."""
    total = 0.0
    for j in range(c.shape[0]):
        total += (c[j] * tau ** p[j] * np.exp(nu[j] * tau)).real
    return total


def _lowest(g0, g1, g2, third, width):
    """The least over ``s`` in ``[0, width]`` of the cubic Taylor model ``g0 + g1 s + g2 s²/2 -
    third s³/6``: its ends and its local minimum, the smaller zero of its slope ``g1 + g2 s -
    third s²/2`` (written without cancellation), or the parabola's vertex when ``third = 0``."""
    end = g0 + g1 * width + g2 * width * width / 2 - third * width * width * width / 6
    low = g0 if g0 < end else end
    s = -1.0
    if third > 0.0:
        discriminant = g2 * g2 + 2 * third * g1
        if discriminant > 0.0:
            root = np.sqrt(discriminant)
            s = -2 * g1 / (g2 + root) if g2 > 0.0 else (g2 - root) / third
    elif g2 > 0.0:
        s = -g1 / g2
    if s > 0.0 and s < width:
        inside = g0 + g1 * s + g2 * s * s / 2 - third * s * s * s / 6
        low = low if low < inside else inside
    return low


def _bound(c, p, nu, a, b):
    """A lower bound of ``Re Σ c_j τ^p_j e^{ν_j τ}`` on ``[a, b]`` (:func:`.roots.lower_bounds`):
    the better of the slow terms' second-order Taylor bound (``g'' >= -bend``) and third-order
    one (``g''' >= -third``), less the fast terms' magnitudes."""
    width = b - a
    fast = 0.0
    bend = 0.0
    third = 0.0
    g0 = 0.0
    g1 = 0.0
    g2 = 0.0
    for j in range(c.shape[0]):
        size = abs(c[j])
        if size == 0.0:
            continue
        q = p[j]
        growth = np.exp(max(nu[j].real * a, nu[j].real * b))
        speed = abs(nu[j])
        if speed * width > 1.0:
            fast += size * b ** q * growth
            continue
        bend += size * growth * (speed * speed * b ** q + 2 * q * speed * b ** max(q - 1, 0)
                                 + q * (q - 1) * b ** max(q - 2, 0))
        third += size * growth * (speed * speed * speed * b ** q + 3 * q * speed * speed * b ** max(q - 1, 0)
                                  + 3 * q * (q - 1) * speed * b ** max(q - 2, 0)
                                  + q * (q - 1) * (q - 2) * b ** max(q - 3, 0))
        at_a = np.exp(nu[j] * a)
        power = a ** q
        lowered = q * a ** max(q - 1, 0) if q > 0 else 0.0
        lowered2 = q * (q - 1) * a ** max(q - 2, 0) if q > 1 else 0.0
        g0 += (c[j] * power * at_a).real
        g1 += (c[j] * (lowered + nu[j] * power) * at_a).real
        # d²/dτ² τ^q e^{ντ} = (ν (ν τ^q + 2 q τ^{q-1}) + q (q-1) τ^{q-2}) e^{ντ}
        g2 += (c[j] * (nu[j] * (nu[j] * power + 2 * lowered) + lowered2) * at_a).real
    curved = g0 + g1 * width - bend * width * width / 2
    second = g0 if g0 < curved else curved
    cubic = _lowest(g0, g1, g2, third, width)
    return (second if second > cubic else cubic) - fast


def _refine(c, p, nu, a, b):
    """The root of the function in ``[a, b]`` (``g(a) >= 0 > g(b)``), to a few ulps; ``a``
    when ``g(a) <= 0``, ``b`` when ``g(b) >= 0``."""
    ga = _value(c, p, nu, a)
    gb = _value(c, p, nu, b)
    if ga <= 0.0:
        return a
    if gb >= 0.0:
        return b
    side = 0
    for _ in range(400):
        if b - a <= 4 * EPSILON * max(abs(b), 1e-300):
            break
        m = b - gb * (b - a) / (gb - ga)
        if not (a < m < b):
            m = 0.5 * (a + b)
        gm = _value(c, p, nu, m)
        if gm == 0.0:
            return m
        if gm > 0.0:
            a, ga = m, gm
            if side == 1:
                gb *= 0.5
            side = 1
        else:
            b, gb = m, gm
            if side == -1:
                ga *= 0.5
            side = -1
    return b


def _first_root(c, p, nu, horizon, tol, resolution):
    """:func:`.roots.first_root` of one column: the first ``τ`` in ``(0, horizon]`` where
    the function goes below ``-tol`` (its root), or ``-1.0`` when there is none."""
    # -g' for the bound that certifies a single crossing: d/dτ τ^p e^{ντ} = (ν τ^p + p τ^{p-1}) e^{ντ}
    terms = c.shape[0]
    dc = np.empty(2 * terms, np.complex128)
    dp = np.empty(2 * terms, np.int64)
    dnu = np.empty(2 * terms, np.complex128)
    for j in range(terms):
        dc[j] = -c[j] * nu[j]
        dp[j] = p[j]
        dnu[j] = nu[j]
        dc[terms + j] = -c[j] * p[j]
        dp[terms + j] = max(p[j] - 1, 0)
        dnu[terms + j] = nu[j]
    starts = np.empty(MAX_STACK)
    ends = np.empty(MAX_STACK)
    depths = np.empty(MAX_STACK, np.int64)
    starts[0], ends[0], depths[0] = 0.0, horizon, 0
    top = 1
    visits = 0
    while top > 0:
        visits += 1
        if visits > MAX_VISITS:
            return UNRESOLVED
        top -= 1
        a, b, depth = starts[top], ends[top], depths[top]
        if _bound(c, p, nu, a, b) > -tol:
            continue
        gb = _value(c, p, nu, b)
        if gb < -tol and _bound(dc, dp, dnu, a, b) > 0.0:
            return _refine(c, p, nu, a, b)
        if b - a <= resolution or depth >= MAX_DEPTH:
            if gb < -tol:
                return _refine(c, p, nu, a, b)
            continue
        m = 0.5 * (a + b)
        starts[top], ends[top], depths[top] = m, b, depth + 1
        starts[top + 1], ends[top + 1], depths[top + 1] = a, m, depth + 1
        top += 2
    return -1.0


def _first_event(table, powers, exponents, tolerances, horizon, relative_resolution):
    """``(τ, column)``: the earliest root over the columns of ``table`` in ``(0, horizon]``
    (``(horizon, -1)`` when none; ``(0.0, -2)`` when a search gave up, :data:`MAX_VISITS`):
    each column is cleared by its bound over the whole
    interval or searched up to the earliest root found so far."""
    best = horizon
    column = -1
    resolution = relative_resolution * max(horizon, 1e-300)
    for k in range(table.shape[1]):
        c = np.ascontiguousarray(table[:, k])
        if _bound(c, powers, exponents, 0.0, best) > -tolerances[k]:
            continue
        root = _first_root(c, powers, exponents, best, tolerances[k], resolution)
        if root == UNRESOLVED:
            return 0.0, -2
        if root >= 0.0 and root < best:
            best = root
            column = k
    return best, column


_value = jit(_value)
_lowest = jit(_lowest)
_bound = jit(_bound)
_refine = jit(_refine)
_first_root = jit(_first_root)
first_event = jit(_first_event)
"""Compiled :func:`_first_event` (the Python function without numba)."""


def _crossed_within_tolerance(table, powers, exponents, tolerances, tau, column, horizon,
                              relative_resolution):
    """``(τ, column)``: the segment's end ``tau`` and the column ending it (-1: the piece's
    end), or the first zero before it of a function that starts clearly positive (above its
    tolerance) and ends negative at ``tau`` without going below ``-tol`` (:func:`_first_event`
    lets it pass): its crossing is certain, and taking it at the next corner delays the event
    by ``tol / |g'|`` (a flyback's secondary diode, ``tol`` 0.4 V through its ``Roff``, turned
    on at the gate's corner 5 ns after the primary switch opened)."""
    resolution = relative_resolution * max(horizon, 1e-300)
    for k in range(table.shape[1]):
        c = np.ascontiguousarray(table[:, k])
        if _value(c, powers, exponents, tau) < 0.0 and _value(c, powers, exponents, 0.0) > tolerances[k]:
            root = _first_root(c, powers, exponents, tau, 0.0, resolution)
            if root >= 0.0 and root < tau:
                tau = root
                column = k
    return tau, column


crossed_within_tolerance = jit(_crossed_within_tolerance)
"""Compiled :func:`_crossed_within_tolerance` (the Python function without numba)."""


@functools.cache
def _native_search():
    """The C search's function (``_exact_native.c``'s ``circuitnsds_first_event``), or ``None``."""
    return native.function("engine/exact/_exact_native", "circuitnsds_first_event",
                           [ctypes.c_void_p, ctypes.c_int64, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p,
                            ctypes.c_void_p, ctypes.c_double, ctypes.c_void_p], ctypes.c_double)


def native_first_event(table: np.ndarray, powers: np.ndarray, exponents: np.ndarray, tolerances: np.ndarray,
                       horizon: float) -> tuple[float, int] | None:
    """:func:`_first_event` then :func:`_crossed_within_tolerance` (relative resolution 1e-13, as
    the loop has them) by the C loop's search: ``(τ [s], column)`` (``column`` -1: none before
    ``horizon``; -2: the search gave up), or ``None`` when the C library is not loaded. The C
    loop calls its search itself; this is for tests and comparisons. ``table``: ``(terms,
    columns)`` complex coefficients; ``powers``, ``exponents`` [1/s]: per term."""
    function = _native_search()
    if function is None:
        return None
    table = np.ascontiguousarray(table, dtype=np.complex128)
    powers = np.ascontiguousarray(powers, dtype=np.int64)
    exponents = np.ascontiguousarray(exponents, dtype=np.complex128)
    tolerances = np.ascontiguousarray(tolerances, dtype=np.float64)
    terms, columns = table.shape
    if powers.shape != (terms,) or exponents.shape != (terms,) or tolerances.shape != (columns,):
        raise ValueError("native_first_event: powers and exponents need one entry per term, tolerances "
                         "one per column")
    column = np.zeros(1, np.int64)
    tau = function(table.ctypes.data, terms, columns, powers.ctypes.data, exponents.ctypes.data,
                   tolerances.ctypes.data, float(horizon), column.ctypes.data)
    if column[0] == -3:
        raise MemoryError("the C first-event search could not allocate its scratch")
    return float(tau), int(column[0])
