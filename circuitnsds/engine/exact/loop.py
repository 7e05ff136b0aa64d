"""The event loop of the exact integrator, compiled, over the modes already known.

Each segment: the sources' piece from the interval table (:mod:`.source_table`), the
mode's event functions from its cached map (:mod:`.solution_map`), the mode that holds
(violated pairs and switches flipped, as :func:`.run.choose_mode` does), the first event
(:mod:`.first_event`), the output rows before it and the state at it. Everything a segment
needs is in arrays indexed by mode; the loop returns to Python (:func:`.run.run_exact`)
only when a flip leads to a mode it has no map for, when the flipping cycles (the
enumeration is Python's), when its event buffer is full or when it stops advancing.

The arrays and their shapes (``M`` modes, ``T`` terms, ``n`` unknowns, ``m`` pairs,
``w`` switches, ``c = m + w`` event functions, ``r`` states, ``I`` inputs of a map):
``bits (M, c)`` each mode's active pairs and closed switches; ``z_map (M, T·(n+m), I)``,
``table_map (M, T·c, I)``, ``powers (M, T)``, ``exponents (M, T)``, ``terms (M,)``:
:class:`~.solution_map.SolutionMap` with ``z = [y; λ]`` over every pair (0 for an
inactive one); ``rows_p (M, c, r)``, ``rows_q (M, c, n)``, ``rows_c (M, c)``: the magnitudes
that make an event function's round-off (:meth:`.run.ExactSystem.event_functions`).
"""

from __future__ import annotations

import numpy as np

from circuitnsds.engine.exact.first_event import first_event
from circuitnsds.jit import jit

FINISHED, NEW_MODE, EVENTS_FULL, STALLED = 0, 1, 2, 3
"""What :func:`exact_loop` returns."""
MAX_MODE_CHANGES = 64
RELATIVE_TOL = 1e-12
TIME_ULPS = 4.0
EPSILON = float(np.finfo(float).eps)
REFRESH_ROWS = 8
"""Output rows computed by the recurrence between two computed from the exponentials
themselves: its round-off grows by an ulp or so per row, and a node behind a gain of 1e4
(the voltage-mode buck's error amplifier) shows it (6e-7 of its range after a whole
segment's 250 rows, 5e-8 with a refresh every 8)."""


def _shifted(coefficients, exponents, partner, delta, out):
    """:func:`.source_table.shift` into ``out``."""
    for j in range(coefficients.shape[0]):
        factor = np.exp(exponents[j] * delta)
        for s in range(coefficients.shape[1]):
            out[j, s] = coefficients[j, s] * factor
    for j in range(coefficients.shape[0]):
        if partner[j] >= 0:
            for s in range(coefficients.shape[1]):
                out[partner[j], s] += delta * out[j, s]


def _ulp(t):
    """An upper bound of one ulp of ``t`` (``math.ulp`` is not compiled)."""
    return EPSILON * max(abs(t), 1e-300)


def _functions(mode, inputs, table_map, terms, columns, exponents, slope_weights, rows_p, rows_q,
               rows_c, x, x_size, forcing, instant, table, tolerances):
    """The mode's event functions (``table``) and their round-off (``tolerances``)."""
    count = terms[mode]
    for j in range(count):
        for k in range(columns):
            total = 0j
            line = j * columns + k
            for i in range(inputs.shape[0]):
                total += table_map[mode, line, i] * inputs[i]
            table[j, k] = total
    for k in range(columns):
        scale = rows_c[mode, k]
        for i in range(x.shape[0]):
            scale += rows_p[mode, k, i] * max(abs(x[i]), x_size[i])
        for i in range(forcing.shape[0]):
            scale += rows_q[mode, k, i] * forcing[i]
        slope = 0.0
        for j in range(count):
            slope += (slope_weights[mode, j] * table[j, k]).real
        tolerances[k] = RELATIVE_TOL * scale + abs(slope) * TIME_ULPS * _ulp(instant) + 1e-300


def _violated(table, powers, exponents, count, k, tolerance):
    """Whether function ``k`` is negative at 0, or zero and decreasing (to the second
    derivative): :func:`.run._violations`."""
    value = 0.0
    for j in range(count):
        if powers[j] == 0:
            value += table[j, k].real
    if value < -tolerance:
        return True
    if value > tolerance:
        return False
    d1 = 0.0
    size1 = 0.0
    d2 = 0.0
    size2 = 0.0
    for j in range(count):
        c = table[j, k]
        nu = exponents[j]
        p = powers[j]
        size1 += abs(c * nu) + (abs(c) * p if p > 0 else 0.0)
        size2 += abs(c * nu * nu) + (2 * abs(c * nu) * p if p > 0 else 0.0) + (
            abs(c) * p * (p - 1) if p > 1 else 0.0)
        if p == 0:
            d1 += (c * nu).real
            d2 += (c * nu * nu).real
        elif p == 1:
            d1 += c.real
            d2 += 2 * (c * nu).real
        elif p == 2:
            d2 += 2 * c.real
    tolerance1 = RELATIVE_TOL * size1 + 1e-300
    if d1 < -tolerance1:
        return True
    if abs(d1) <= tolerance1:
        return d2 < -(RELATIVE_TOL * size2 + 1e-300)
    return False


def _find(bits, known, wanted):
    """The index of the mode ``wanted`` among the first ``known`` rows of ``bits``, or -1."""
    for i in range(known):
        same = True
        for k in range(bits.shape[1]):
            if bits[i, k] != wanted[k]:
                same = False
                break
        if same:
            return i
    return -1


def _exact_loop(clock, counters, x, x_size, sources_now,
                corners, source_coefficients, source_exponents, source_powers, partner, s_matrix,
                bits, known, z_map, table_map, powers, exponents, terms, slope_weights,
                rows_p, rows_q, rows_c, v1t, v1t_abs,
                times, y_out, l_out, event_times, event_index, event_on):
    """Run from ``clock[0]`` [s] to ``corners[-1]``; ``counters``: interval, mode, mode
    already chosen at this instant (1) or not, next output row, events written, segments,
    stalled segments. Returns a status (:data:`FINISHED` ...); the state (``clock``,
    ``counters``, ``x``, ``x_size``, ``sources_now``) is where it stopped."""
    n = y_out.shape[1]
    m = l_out.shape[1]
    columns = bits.shape[1]
    stop = corners[corners.shape[0] - 1]
    terms_max = powers.shape[1]
    table = np.zeros((terms_max, columns), np.complex128)
    tolerances = np.zeros(columns)
    zeros_in = x.shape[0]
    inputs = np.zeros(z_map.shape[2], np.complex128)
    forcing = np.zeros(n)
    wanted = np.zeros(columns, np.bool_)
    seen = np.zeros(MAX_MODE_CHANGES, np.int64)
    weights = np.zeros(terms_max, np.complex128)
    growth = np.zeros(terms_max, np.complex128)
    ratios = np.zeros(terms_max, np.complex128)
    t = clock[0]
    k, mode, chosen, row, events, segments, stalled = (counters[0], counters[1], counters[2], counters[3],
                                                       counters[4], counters[5], counters[6])
    status = FINISHED
    while t < stop:
        threshold = t * (1 + 1e-15) + 1e-300
        while k + 2 < corners.shape[0] and corners[k + 1] <= threshold:
            k += 1
        end = corners[k + 1]
        _shifted(source_coefficients[k], source_exponents, partner, t - corners[k], sources_now)
        # inputs [x; s; 1] and the forcing's size Σ_terms |S f_term| at τ = 0
        for i in range(zeros_in):
            inputs[i] = x[i]
        position = zeros_in
        for j in range(sources_now.shape[0]):
            for s in range(sources_now.shape[1]):
                inputs[position] = sources_now[j, s]
                position += 1
        inputs[position] = 1.0
        forcing[:] = 0.0
        for j in range(sources_now.shape[0]):
            if source_powers[j] == 0:
                for i in range(n):
                    total = 0j
                    for s in range(sources_now.shape[1]):
                        total += s_matrix[i, s] * sources_now[j, s]
                    forcing[i] += abs(total)
        previous = mode
        changes = 0
        while True:
            _functions(mode, inputs, table_map, terms, columns, exponents, slope_weights, rows_p, rows_q,
                       rows_c, x, x_size, forcing, t, table, tolerances)
            if chosen == 1:
                break
            any_bad = False
            for c in range(columns):
                bad = _violated(table, powers[mode], exponents[mode], terms[mode], c, tolerances[c])
                wanted[c] = bits[mode, c] != bad
                any_bad = any_bad or bad
            if not any_bad:
                break
            seen[changes] = mode
            changes += 1
            following = _find(bits, known, wanted)
            cycled = following < 0 or changes >= MAX_MODE_CHANGES
            for i in range(changes):
                if seen[i] == following:
                    cycled = True
            if cycled:
                status = NEW_MODE
                break
            mode = following
        if status != FINISHED:
            mode = previous
            break
        chosen = 0
        if events + columns > event_times.shape[0]:
            status = EVENTS_FULL
            mode = previous
            break
        for c in range(columns):
            if bits[mode, c] != bits[previous, c]:
                event_times[events] = t
                event_index[events] = c
                event_on[events] = bits[mode, c]
                events += 1
        count = terms[mode]
        horizon = end - t
        tau, _ = first_event(table[:count], powers[mode, :count], exponents[mode, :count], tolerances,
                             horizon, 1e-13)
        segments += 1
        stop_at = t + tau
        z = np.zeros((count, n + m), np.complex128)
        for j in range(count):
            for i in range(n + m):
                total = 0j
                line = j * (n + m) + i
                for q in range(inputs.shape[0]):
                    total += z_map[mode, line, q] * inputs[q]
                z[j, i] = total
        # the rows of the grid in the segment: e^{ν τ} at the first and every REFRESH_ROWS,
        # times e^{ν Δ} from row to row in between (one complex product per term; the
        # exponentials of Δ only when it changes by more than the times' own round-off)
        first_row = True
        step = -1.0
        since = 0
        while row < times.shape[0] and times[row] <= stop_at:
            local = times[row] - t
            if first_row or since >= REFRESH_ROWS:
                for j in range(count):
                    growth[j] = np.exp(exponents[mode, j] * local)
                first_row = False
                since = 0
            else:
                since += 1
                delta = times[row] - times[row - 1]
                # a grid's steps differ by round-off of the times, which they carry anyway
                if abs(delta - step) > 4 * _ulp(times[row]):
                    step = delta
                    for j in range(count):
                        ratios[j] = np.exp(exponents[mode, j] * delta)
                for j in range(count):
                    growth[j] *= ratios[j]
            for j in range(count):
                weights[j] = growth[j] * local ** powers[mode, j] if powers[mode, j] else growth[j]
            for i in range(n + m):
                value = 0.0
                for j in range(count):
                    value += z[j, i].real * weights[j].real - z[j, i].imag * weights[j].imag
                if i < n:
                    y_out[row, i] = value
                else:
                    l_out[row, i - n] = value
            row += 1
        y_end = np.zeros(n)
        size_end = np.zeros(n)
        for j in range(count):
            weight = tau ** powers[mode, j] * np.exp(exponents[mode, j] * tau)
            magnitude = abs(weight)
            for i in range(n):
                y_end[i] += (z[j, i] * weight).real
                size_end[i] += abs(z[j, i]) * magnitude
        for i in range(x.shape[0]):
            total = 0.0
            size = 0.0
            for q in range(n):
                total += v1t[i, q] * y_end[q]
                size += v1t_abs[i, q] * size_end[q]
            x[i] = total
            x_size[i] = size
        new_t = stop_at if tau < horizon else end
        stalled = stalled + 1 if new_t <= t else 0
        t = new_t
        if stalled > MAX_MODE_CHANGES:
            status = STALLED
            break
    clock[0] = t
    counters[0], counters[1], counters[2], counters[3] = k, mode, chosen, row
    counters[4], counters[5], counters[6] = events, segments, stalled
    return status


_shifted = jit(_shifted)
_ulp = jit(_ulp)
_functions = jit(_functions)
_violated = jit(_violated)
_find = jit(_find)
exact_loop = jit(_exact_loop)
"""Compiled :func:`_exact_loop` (the Python function without numba)."""
