"""The event loop of the exact integrator, compiled, over the modes already known.

Each segment: the sources' piece from the interval table (:mod:`.source_table`), the
mode's event functions from its cached map (:mod:`.solution_map`), the mode that holds
(violated pairs flipped, violated switches once no pair is, as :func:`.run.choose_mode` does), the first event
(:mod:`.first_event`), the output rows before it and the state at it. Everything a segment
needs is in arrays indexed by mode; the loop returns to Python (:func:`.run.run_exact`)
only when a flip leads to a mode it has no map for, when the flipping cycles (the
enumeration is Python's), when its event buffer is full or when it stops advancing.

The arrays and their shapes (``M`` modes, ``T`` terms, ``n`` unknowns, ``m`` pairs,
``w`` switches, ``c = m + w`` event functions, ``r`` states, ``I`` inputs of a map):
``bits (M, c)`` each mode's active pairs and closed switches; ``z_map (M, T·(n+m), I)``,
``table_map (M, T·c, I)``, ``powers (M, T)``, ``exponents (M, T)``, ``terms (M,)``:
:class:`~.solution_map.SolutionMap` with ``z = [y; λ]`` over every pair (0 for an
inactive one); ``rows_p (M, c, r)``, ``rows_q (M, c, n)``, ``rows_y (M, c, n)``,
``rows_c (M, c)``: the magnitudes that make an event function's round-off
(:meth:`.run.ExactSystem.event_functions`).

Besides the rows (``y``, the pairs' multipliers) it writes what the stepper reports of each
row (:class:`.run.ExactRun`): the mode of the segment the row ends, each pair's charge over
the interval ending at the row (the closed-form integral, :mod:`.charge`'s formulas), and
the unknowns at the start of the last segment inside a row's interval (its ``tails``).
Every row is computed from the exponentials at its own time, nothing carried from the
row before (but the previous row's ``e^{νa}`` for the charge, a value of the same formula):
a run in parts, whose parts start at any row, is then the run in one part, bit for bit.
A term with a real exponent (most of a converter's) is summed in real arithmetic; the charge
of a term with ``p = 0`` is ``e^{νa} expm1(νw)/ν`` (:func:`_charge`).

The same loop is C (``_exact_native.c``), which :func:`.run.run_exact` calls when it was
built; this one runs compiled by numba without the library (``CIRCUITNSDS_NATIVE=0``). The
two give the same numbers bit for bit on the bundled netlists (``tests/test_exact_native.py``;
the C loop also skips the inputs a term's map multiplies by 0, which changes no sum). Edit
the two together.
"""

from __future__ import annotations

import numpy as np

from circuitnsds.engine.exact.first_event import crossed_within_tolerance, first_event
from circuitnsds.jit import jit

FINISHED, NEW_MODE, EVENTS_FULL, STALLED = 0, 1, 2, 3
"""What :func:`exact_loop` returns."""
MAX_MODE_CHANGES = 64
CHATTERING = 1e-8
"""(:data:`.run.CHATTERING`)"""
RELATIVE_TOL = 1e-12
TIME_ULPS = 4.0
SUM_ULPS = 8.0
FAST_SIGNIFICANT = 1e-6
""":data:`.run.FAST_SIGNIFICANT` (a state's part along a fast mode that counts at a mode choice)."""
"""As :data:`.run.SUM_ULPS` (the round-off of the unknowns summed at an instant)."""
EPSILON = float(np.finfo(float).eps)
SERIES_TERMS = 24
"""As :data:`.charge.SERIES_TERMS`."""
COUNTERS = 9
"""``counters``: interval, mode, mode already chosen at this instant (1) or not, next output
row, events written, segments, stalled segments, events at this instant reported already
(1), tails written."""


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
               rows_y, rows_c, gap_rows, x, y_size, forcing, instant, table, tolerances):
    """The mode's event functions (``table``) and their round-off (``tolerances``), as
    :meth:`.run.ExactSystem.event_functions` has them."""
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
            scale += rows_p[mode, k, i] * abs(x[i])
        for i in range(forcing.shape[0]):
            scale += rows_q[mode, k, i] * forcing[i]
        summed = 0.0
        for i in range(y_size.shape[0]):
            summed += rows_y[mode, k, i] * y_size[i]
        slope = 0.0
        terms_size = 0.0
        for j in range(count):
            slope += (slope_weights[mode, j] * table[j, k]).real
            terms_size += abs(table[j, k])
        gap = 0.0
        for i in range(x.shape[0]):
            gap += gap_rows[mode, k, i] * x[i]
        tolerances[k] = (RELATIVE_TOL * scale + SUM_ULPS * EPSILON * summed
                         + abs(slope) * TIME_ULPS * _ulp(instant) + SUM_ULPS * EPSILON * terms_size
                         + 1e-300) + abs(gap)


def _fast_offset(fast_rows, mode, c, x):
    """What the state's part along the mode's fast modes adds to function ``c`` at the start,
    where it counts, else 0: :func:`.run.fast_offsets`."""
    total = 0.0
    size = 0.0
    for i in range(x.shape[0]):
        a = fast_rows[mode, c, i]
        total += a * x[i]
        size += abs(a) * abs(x[i])
    return total if abs(total) > FAST_SIGNIFICANT * size else 0.0


def _violated(table, powers, exponents, count, k, tolerance, offset):
    """Whether function ``k`` (with ``offset`` added: :func:`_fast_offset`) is negative at 0,
    or zero and decreasing (to the second derivative) by more than its round-off:
    :func:`.run._violations`."""
    value = 0.0
    for j in range(count):
        if powers[j] == 0:
            value += table[j, k].real
    value += offset
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
        return not (d2 > RELATIVE_TOL * size2 and value - d1 * d1 / (2.0 * d2) >= -tolerance)
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


def _grown(nu_re, nu_im, tau):
    """``e^{ν τ}`` as ``(real part, imaginary part)``: 1 for ``ν = 0`` (constants and ramps),
    one real exponential for a real ``ν`` (most modes), ``e^{Re ν τ}`` times the cosine and
    sine of ``Im ν τ`` otherwise (the C loop's arithmetic, op for op; a pure function of ``ν``
    and ``τ``: a run in parts computes every row as the run in one part)."""
    if nu_im == 0.0:
        if nu_re == 0.0:
            return 1.0, 0.0
        return np.exp(nu_re * tau), 0.0
    size = np.exp(nu_re * tau)
    return size * np.cos(nu_im * tau), size * np.sin(nu_im * tau)


def _size(re, im):
    """``|re + i im|``: ``|re|`` when ``im = 0`` (most terms), else ``hypot``."""
    if im == 0.0:
        return abs(re)
    return np.hypot(re, im)


def _moments(nu, p, w, out):
    """``J_q(w) = ∫_0^w s^q e^{νs} ds`` for ``q = 0..p`` into ``out`` (:mod:`.charge`; only for
    the terms with ``p >= 1``, resonances and ramps: :func:`_integral` has ``p = 0``'s)."""
    nw = nu * w
    if nu == 0:
        for q in range(p + 1):
            out[q] = w ** (q + 1) / (q + 1)
    elif abs(nw) < 1.0:
        for q in range(p + 1):
            series = 0j
            term = 1.0 + 0j
            for k in range(SERIES_TERMS):
                series += term / (q + k + 1)
                term = term * nw / (k + 1)
                if k % 4 == 3 and abs(term) <= 1e-17:
                    break
            out[q] = series * w ** (q + 1)
    else:
        grown = np.exp(nw)
        out[0] = (grown - 1.0) / nu
        for q in range(1, p + 1):
            out[q] = (w ** q * grown - q * out[q - 1]) / nu


def _integral(nu_re, nu_im, p, a, w, at_re, at_im, j, kept_w, moments):
    """``∫_a^{a+w} τ^p e^{ντ} dτ`` [s] for a term with ``p >= 1`` (resonances and ramps) as
    ``(real part, imaginary part)``, with ``e^{νa} = at_re + i at_im``: ``e^{νa} Σ_q C(p, q)
    a^{p−q} J_q(w)`` (:mod:`.charge`), the ``J_q`` (:func:`_moments`) kept in ``moments[j]``
    while ``kept_w[j, 0]`` is ``w``. (``p = 0``, most terms, is :func:`_charge`'s.)"""
    if kept_w[j, 0] != w:
        _moments(complex(nu_re, nu_im), p, w, moments[j])
        kept_w[j, 0] = w
    weight_re = 0.0
    weight_im = 0.0
    binomial = 1.0
    for q in range(p + 1):
        factor = binomial * a ** (p - q)
        weight_re += factor * moments[j, q].real
        weight_im += factor * moments[j, q].imag
        binomial = binomial * (p - q) / (q + 1)
    return weight_re * at_re - weight_im * at_im, weight_re * at_im + weight_im * at_re


def _charge(z_re, z_im, n, pairs, pair_count, powers, nu_re, nu_im, count, a, b, at_re, at_im, kept_w,
            kept_re, kept_im, next_slot, moments, integral_re, integral_im, out):
    """``out[i] += ∫_a^b λ_i dτ`` for each active pair ``i = pairs[:pair_count]`` of the
    segment's ``z`` (its real and imaginary parts ``z_re``, ``z_im``); ``e^{ν_j a} = at_re[j] +
    i at_im[j]``. A term with ``p = 0`` integrates to ``e^{νa} expm1(νw)/ν`` (``w = b − a``;
    ``w`` for ``ν = 0``; a real ``ν``, most terms, in real arithmetic; a complex one with
    ``expm1(x + iy) = (expm1(x) cos y − 2 sin²(y/2)) + i e^x sin y``), ``expm1(νw)/ν`` kept for
    the last two widths in ``kept_re[j, slot], kept_im[j, slot]`` (``kept_w[j, slot]`` the
    width, ``next_slot[j]`` the one to replace: a uniform grid's rows differ in width by an ulp
    or two, two values most often; a pure function of ``ν`` and ``w``, so the run in parts is
    the run in one part); ``p >= 1``: :func:`_integral`. ``integral_re``, ``integral_im``:
    scratch (terms)."""
    if pair_count == 0:
        return
    w = b - a
    for j in range(count):
        nr = nu_re[j]
        ni = nu_im[j]
        if powers[j] != 0:
            integral_re[j], integral_im[j] = _integral(nr, ni, powers[j], a, w, at_re[j], at_im[j], j, kept_w,
                                                       moments)
            continue
        if ni == 0.0 and nr == 0.0:
            integral_re[j] = w
            integral_im[j] = 0.0
            continue
        # (written here, not in a function: a numba call per term and row passing arrays
        # cost more than the rows' arithmetic)
        slot = 0 if kept_w[j, 0] == w else 1 if kept_w[j, 1] == w else -1
        if slot < 0:
            slot = next_slot[j]
            next_slot[j] = 1 - slot
            if ni == 0.0:
                kept_re[j, slot] = np.expm1(nr * w) / nr
                kept_im[j, slot] = 0.0
            else:
                x = nr * w
                y = ni * w
                half = np.sin(0.5 * y)
                e_re = np.expm1(x) * np.cos(y) - 2.0 * half * half
                e_im = np.exp(x) * np.sin(y)
                size = nr * nr + ni * ni
                kept_re[j, slot] = (e_re * nr + e_im * ni) / size
                kept_im[j, slot] = (e_im * nr - e_re * ni) / size
            kept_w[j, slot] = w
        q_re = kept_re[j, slot]
        q_im = kept_im[j, slot]
        if ni == 0.0:
            integral_re[j] = at_re[j] * q_re
            integral_im[j] = 0.0
        else:
            integral_re[j] = at_re[j] * q_re - at_im[j] * q_im
            integral_im[j] = at_re[j] * q_im + at_im[j] * q_re
    for k in range(pair_count):
        i = pairs[k]
        total = 0.0
        for j in range(count):
            if nu_im[j] == 0.0:
                total += z_re[j, n + i] * integral_re[j]
            else:
                total += z_re[j, n + i] * integral_re[j] - z_im[j, n + i] * integral_im[j]
        out[i] += total


def _exact_loop(clock, counters, x, y_size, sources_now, widened,
                corners, source_coefficients, source_exponents, source_powers, partner, s_matrix,
                bits, known, z_map, table_map, powers, exponents, terms, slope_weights,
                rows_p, rows_q, rows_y, rows_c, fast_rows, gap_rows, v1t,
                times, y_out, l_out, charges, row_active, row_closed,
                event_times, event_index, event_on, tail_row, tail_dt, tail_y):
    """Run from ``clock[0]`` [s] until the row ``times[-1]`` is written (the sources' table
    ends at ``corners[-1]``, at or after it); ``counters``: :data:`COUNTERS`; ``widened``:
    tolerances the first segment's functions take at least, when Python chose its mode
    (:data:`.run.LEAKAGE_EXCESS`), zeroed once used. Returns a status (:data:`FINISHED` ...);
    the state (``clock``, ``counters``, ``x``, ``y_size``) is where it stopped: at the
    start of the segment it could not compute or, finished, of the one holding the last row
    (with the mode before the choice there)."""
    n = y_out.shape[1]
    m = l_out.shape[1]
    rows_total = times.shape[0]
    columns = bits.shape[1]
    stop = corners[corners.shape[0] - 1]
    terms_max = powers.shape[1]
    top_power = 0
    for i in range(powers.shape[0]):
        for j in range(terms_max):
            top_power = max(top_power, powers[i, j])
    table = np.zeros((terms_max, columns), np.complex128)
    tolerances = np.zeros(columns)
    zeros_in = x.shape[0]
    inputs = np.zeros(z_map.shape[2], np.complex128)
    forcing = np.zeros(n)
    wanted = np.zeros(columns, np.bool_)
    seen = np.zeros(MAX_MODE_CHANGES, np.int64)
    nu_re = np.zeros(terms_max)
    nu_im = np.zeros(terms_max)
    growth_re = np.zeros(terms_max)
    growth_im = np.zeros(terms_max)
    at_re = np.zeros(terms_max)
    at_im = np.zeros(terms_max)
    integral_re = np.zeros(terms_max)
    integral_im = np.zeros(terms_max)
    kept_w = np.full((terms_max, 2), -1.0)
    kept_re = np.zeros((terms_max, 2))
    kept_im = np.zeros((terms_max, 2))
    next_slot = np.zeros(terms_max, np.int64)
    moments = np.zeros((terms_max, top_power + 1), np.complex128)
    pairs = np.zeros(m, np.int64)
    values = np.zeros(n + m)
    z_re = np.zeros((terms_max, n + m))
    z_im = np.zeros((terms_max, n + m))
    y_end = np.zeros(n)
    size_end = np.zeros(n)
    t = clock[0]
    k, mode, chosen, row, events, segments, stalled, quiet, tails = (
        counters[0], counters[1], counters[2], counters[3], counters[4], counters[5], counters[6],
        counters[7], counters[8])
    status = FINISHED
    while t < stop or (t == stop and row < rows_total):
        if events + columns > event_times.shape[0] or tails + 1 > tail_row.shape[0]:
            status = EVENTS_FULL
            break
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
        from_python = chosen == 1
        changes = 0
        while True:
            _functions(mode, inputs, table_map, terms, columns, exponents, slope_weights, rows_p, rows_q,
                       rows_y, rows_c, gap_rows, x, y_size, forcing, t, table, tolerances)
            if chosen == 1:
                break
            any_bad = False
            pair_bad = False
            for c in range(columns):
                bad = _violated(table, powers[mode], exponents[mode], terms[mode], c, tolerances[c],
                                _fast_offset(fast_rows, mode, c, x))
                wanted[c] = bits[mode, c] != bad
                any_bad = any_bad or bad
                pair_bad = pair_bad or (bad and c < m)
            if not any_bad:
                break
            if pair_bad:  # (the switches flip once the pairs hold: run.choose_mode)
                for c in range(m, columns):
                    wanted[c] = bits[mode, c]
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
        if from_python:
            for c in range(columns):
                tolerances[c] = max(tolerances[c], widened[c])
                widened[c] = 0.0
        chosen = 0
        quiet_here = quiet
        if quiet == 0:
            for c in range(columns):
                if bits[mode, c] != bits[previous, c]:
                    event_times[events] = t
                    event_index[events] = c
                    event_on[events] = bits[mode, c]
                    events += 1
        quiet = 0
        count = terms[mode]
        horizon = end - t
        tau, ended_by = first_event(table[:count], powers[mode, :count], exponents[mode, :count], tolerances,
                                    horizon, 1e-13)
        if ended_by == -2:  # (the search gave up: first_event.MAX_VISITS)
            status = STALLED
            break
        tau, ended_by = crossed_within_tolerance(table[:count], powers[mode, :count], exponents[mode, :count],
                                                 tolerances, tau, ended_by, horizon, 1e-13)
        segments += 1
        stop_at = t + tau
        pair_count = 0
        for i in range(m):
            if bits[mode, i]:
                pairs[pair_count] = i
                pair_count += 1
        for j in range(count):
            nu_re[j] = exponents[mode, j].real
            nu_im[j] = exponents[mode, j].imag
            kept_w[j, 0] = -1.0  # (what _integral keeps is this mode's terms')
            kept_w[j, 1] = -1.0
            next_slot[j] = 0
        # z = [y; λ] per term (real and imaginary parts); the pairs' columns only when a row
        # or a row's charge needs them (most of an inverter's segments hold no row)
        size = n + m if row < rows_total and (times[row] <= stop_at or (tau > 0 and pair_count > 0)) else n
        real_inputs = True
        for q in range(inputs.shape[0]):
            real_inputs = real_inputs and inputs[q].imag == 0.0
        for j in range(count):
            for i in range(size):
                total_re = 0.0
                total_im = 0.0
                line = j * (n + m) + i
                if real_inputs:
                    for q in range(inputs.shape[0]):
                        total_re += z_map[mode, line, q].real * inputs[q].real
                        total_im += z_map[mode, line, q].imag * inputs[q].real
                else:
                    for q in range(inputs.shape[0]):
                        value = z_map[mode, line, q] * inputs[q]
                        total_re += value.real
                        total_im += value.imag
                z_re[j, i] = total_re
                z_im[j, i] = total_im
        first_row = True
        while row < rows_total and times[row] <= stop_at:
            local = times[row] - t
            begin = max(times[row - 1] - t, 0.0)
            for j in range(count):
                if not first_row:
                    at_re[j] = growth_re[j]
                    at_im[j] = growth_im[j]
                elif begin > 0.0:
                    at_re[j], at_im[j] = _grown(nu_re[j], nu_im[j], begin)
                else:
                    at_re[j] = 1.0
                    at_im[j] = 0.0
                growth_re[j], growth_im[j] = _grown(nu_re[j], nu_im[j], local)
            for i in range(n + m):
                values[i] = 0.0
            for j in range(count):
                p = powers[mode, j]
                w_re = growth_re[j]
                w_im = growth_im[j]
                if p:
                    power = local ** p
                    w_re *= power
                    w_im *= power
                if nu_im[j] == 0.0:
                    for i in range(n + m):
                        values[i] += z_re[j, i] * w_re
                else:
                    for i in range(n + m):
                        values[i] += z_re[j, i] * w_re - z_im[j, i] * w_im
            for i in range(n):
                y_out[row, i] = values[i]
            for i in range(m):
                l_out[row, i] = values[n + i]
            for c in range(m):
                row_active[row, c] = bits[mode, c]
            for c in range(columns - m):
                row_closed[row, c] = bits[mode, m + c]
            _charge(z_re, z_im, n, pairs, pair_count, powers[mode], nu_re, nu_im, count, begin, local,
                    at_re, at_im, kept_w, kept_re, kept_im, next_slot, moments, integral_re, integral_im,
                    charges[row])
            if first_row and times[row - 1] < t:  # the row's interval holds this segment's start
                tail_row[tails] = row
                tail_dt[tails] = local
                for i in range(n):
                    value = 0.0
                    for j in range(count):
                        if powers[mode, j] == 0:
                            value += z_re[j, i]
                    tail_y[tails, i] = value
                tails += 1
            first_row = False
            row += 1
        if row < rows_total and tau > 0:  # the next row's interval holds this segment's end
            begin = max(times[row - 1] - t, 0.0)
            if tau > begin and pair_count > 0:
                for j in range(count):
                    at_re[j], at_im[j] = _grown(nu_re[j], nu_im[j], begin)
                _charge(z_re, z_im, n, pairs, pair_count, powers[mode], nu_re, nu_im, count, begin, tau,
                        at_re, at_im, kept_w, kept_re, kept_im, next_slot, moments, integral_re,
                        integral_im, charges[row])
        if row >= rows_total:  # (the state stays at this segment's start, to resume from)
            mode = previous
            quiet = quiet_here
            break
        for i in range(n):
            y_end[i] = 0.0
            size_end[i] = 0.0
        for j in range(count):
            w_re, w_im = _grown(nu_re[j], nu_im[j], tau)
            p = powers[mode, j]
            if p:
                power = tau ** p
                w_re *= power
                w_im *= power
            magnitude = _size(w_re, w_im)
            for i in range(n):
                y_end[i] += z_re[j, i] * w_re - z_im[j, i] * w_im
                size_end[i] += _size(z_re[j, i], z_im[j, i]) * magnitude
        for i in range(x.shape[0]):
            total = 0.0
            for q in range(n):
                total += v1t[i, q] * y_end[q]
            x[i] = total
        for i in range(n):
            y_size[i] = size_end[i]
        new_t = stop_at if tau < horizon else end
        # (segments shorter than CHATTERING of the run, a chattering pair's among them, count
        # as not advancing: run.CHATTERING)
        stalled = stalled + 1 if new_t - t < CHATTERING * stop else 0
        t = new_t
        if stalled > MAX_MODE_CHANGES:
            status = STALLED
            break
    clock[0] = t
    counters[0], counters[1], counters[2], counters[3] = k, mode, chosen, row
    counters[4], counters[5], counters[6], counters[7], counters[8] = events, segments, stalled, quiet, tails
    return status


_shifted = jit(_shifted)
_ulp = jit(_ulp)
_functions = jit(_functions)
_fast_offset = jit(_fast_offset)
_violated = jit(_violated)
_find = jit(_find)
_grown = jit(_grown)
_size = jit(_size)
_moments = jit(_moments)
_integral = jit(_integral)
_charge = jit(_charge)
exact_loop = jit(_exact_loop)
"""Compiled :func:`_exact_loop` (the Python function without numba)."""
