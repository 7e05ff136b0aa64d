"""Properties of the vectorised source functions and of the threshold crossings.

* ``stimulus.sample(times)`` is ``[stimulus.value(t) for t in times]`` for every kind of
  source, random parameters and instants that include the corners themselves (where the
  left-continuous convention decides the value) and their floating-point neighbours.
* ``threshold_crossings(stimulus, level, stop)`` (PULSE and PWL) returns instants where
  the function equals ``level``, strictly inside the linear pieces between breakpoints,
  and one for every piece that crosses ``level`` away from its ends.
"""

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from circuitnsds.system.stimuli import Dc, Exp, Pulse, Pwl, Sin, threshold_crossings

levels = st.floats(-20, 20, allow_nan=False)
durations = st.floats(1e-9, 1e-3, allow_nan=False)
maybe_zero_durations = st.one_of(st.just(0.0), durations)
tsteps = st.floats(1e-9, 1e-5)
tstops = st.floats(1e-4, 1e-2)


@st.composite
def pulses(draw):
    pulse = Pulse(
        draw(levels), draw(levels),
        delay=draw(st.one_of(st.just(0.0), durations)),
        rise=draw(st.one_of(st.none(), maybe_zero_durations)),
        fall=draw(st.one_of(st.none(), maybe_zero_durations)),
        width=draw(st.one_of(st.none(), maybe_zero_durations)),
        period=draw(st.one_of(st.none(), st.just(0.0), st.floats(1e-6, 1e-3))),
    )
    return pulse.resolve(draw(tsteps), draw(tstops))


@st.composite
def pwls(draw):
    count = draw(st.integers(1, 8))
    steps = draw(st.lists(st.one_of(st.just(0.0), durations), min_size=count, max_size=count))
    start = draw(st.one_of(st.just(0.0), durations))
    times = tuple(np.cumsum([start, *steps[1:]]).tolist())  # non-decreasing: vertical steps allowed
    values = tuple(draw(st.lists(levels, min_size=count, max_size=count)))
    return Pwl(times, values)


@st.composite
def sines(draw):
    return Sin(draw(levels), draw(levels), frequency=draw(st.one_of(st.none(), st.floats(1, 1e6))),
               delay=draw(st.one_of(st.just(0.0), durations)),
               damping=draw(st.one_of(st.just(0.0), st.floats(0, 1e4))),
               phase_deg=draw(st.floats(-360, 360))).resolve(draw(tsteps), draw(tstops))


@st.composite
def exps(draw):
    rise_delay = draw(st.one_of(st.just(0.0), durations))
    return Exp(draw(levels), draw(levels), rise_delay=rise_delay,
               rise_tau=draw(st.one_of(st.none(), durations)),
               fall_delay=draw(st.one_of(st.none(), st.just(rise_delay + 1e-4), durations)),
               fall_tau=draw(st.one_of(st.none(), durations))).resolve(draw(tsteps), draw(tstops))


stimuli = st.one_of(pulses(), pwls(), sines(), exps(), levels.map(Dc))


def corner_instants(stimulus, stop: float) -> np.ndarray:
    """Breakpoints as the grid has them, the same instants computed other ways (period
    by period, as a sum of fields) and their floating-point neighbours."""
    points = list(stimulus.breakpoints(stop))
    if isinstance(stimulus, Pulse):
        corners = (0.0, stimulus.rise, stimulus.rise + stimulus.width,
                   stimulus.rise + stimulus.width + stimulus.fall, stimulus.period)
        for n in range(min(50, int(stop / stimulus.period) + 1)):
            start = stimulus.delay + n * stimulus.period
            points.extend(start + corner for corner in corners)
            points.append(stimulus.delay + (n + 1) * stimulus.period)
    elif isinstance(stimulus, Pwl):
        points.extend(stimulus.times)
    elif isinstance(stimulus, Sin):
        points.append(stimulus.delay)
    elif isinstance(stimulus, Exp):
        points.extend([stimulus.rise_delay, stimulus.fall_delay])
    points = np.array([p for p in points if 0 <= p <= stop], dtype=float)
    return np.concatenate([points, np.nextafter(points, np.inf), np.nextafter(points, -np.inf)])


def steepest_slope(stimulus) -> float:
    """Largest |dv/dt| of a smooth or linear stretch [unit/s] (ideal jumps excluded)."""
    if isinstance(stimulus, Pulse):
        ramps = [r for r in (stimulus.rise, stimulus.fall) if r > 0]
        return abs(stimulus.pulsed - stimulus.initial) / min(ramps) if ramps else 0.0
    if isinstance(stimulus, Pwl):
        pairs = zip(zip(stimulus.times, stimulus.values), zip(stimulus.times[1:], stimulus.values[1:]))
        return max([abs(v1 - v0) / (t1 - t0) for (t0, v0), (t1, v1) in pairs if t1 > t0], default=0.0)
    if isinstance(stimulus, Sin):
        return abs(stimulus.amplitude) * (2 * np.pi * stimulus.frequency + stimulus.damping)
    if isinstance(stimulus, Exp):
        return abs(stimulus.pulsed - stimulus.initial) / min(stimulus.rise_tau, stimulus.fall_tau)
    return 0.0


@settings(max_examples=150, deadline=None)
@given(stimuli, st.lists(st.floats(0, 1), max_size=40), st.floats(1e-4, 1e-2))
def test_sample_equals_value_everywhere_including_the_corners(stimulus, fractions, stop):
    assume(not isinstance(stimulus, Pulse) or stop / stimulus.period <= 200)
    times = np.concatenate([np.array(fractions) * stop, corner_instants(stimulus, stop), [0.0, stop]])
    times = np.abs(times)
    sampled = stimulus.sample(times)
    assert sampled.shape == times.shape
    expected = np.array([stimulus.value(float(t)) for t in times])
    scale = max(1.0, float(np.abs(expected).max()))
    # the two evaluate the same formulas with the operations grouped differently
    # ((t - a) - b versus t - (a + b)): they may differ by a few ulps of t times the slope
    # (1e-10 of the swing on a 1 ns edge at t = 1 ms); a corner read on the wrong side
    # would differ by a whole jump or ramp
    tolerance = 1e-12 * scale + 8 * steepest_slope(stimulus) * np.spacing(times)
    mismatch = np.abs(sampled - expected) > tolerance
    assert not mismatch.any(), (
        f"{stimulus}: at t = {times[mismatch][:3].tolist()} sample gives "
        f"{sampled[mismatch][:3].tolist()}, value gives {expected[mismatch][:3].tolist()}")


@settings(max_examples=30, deadline=None)
@given(stimuli)
def test_sample_keeps_the_shape_of_its_input(stimulus):
    grid = np.linspace(0, 1e-3, 12).reshape(3, 4)
    assert stimulus.sample(grid).shape == (3, 4)


def pieces(stimulus, stop: float) -> list[tuple[float, float]]:
    edges = [0.0, *stimulus.breakpoints(stop), stop]
    return list(zip(edges[:-1], edges[1:]))


def check_crossings(stimulus, level: float, stop: float) -> None:
    crossings = threshold_crossings(stimulus, level, stop)
    spans = pieces(stimulus, stop)
    scale = max(1.0, abs(level), *(abs(stimulus.value(a)) for a, _ in spans), abs(stimulus.value(stop)))
    found = {piece: 0 for piece in spans}
    for instant in crossings:
        assert 0 < instant < stop
        inside = [(a, b) for a, b in spans if a < instant < b]
        assert len(inside) == 1, f"{instant} is a breakpoint or outside every piece"
        a, b = inside[0]
        # strictly inside: not within rounding of an end (those instants are grid points already)
        assert min(instant - a, b - instant) >= 0.5e-9 * (b - a)
        # equal to the level up to 1e-9 relative, and up to what the resolution of t allows
        # on a steep ramp (a 1 ns edge at t = 4 ms moves by 1e-9 of its swing per ulp of t)
        end = stimulus.value(b)
        slope = (end - (2 * stimulus.value(0.5 * (a + b)) - end)) / (b - a)
        tolerance = 1e-9 * scale + 4 * abs(slope) * np.spacing(instant)
        assert abs(stimulus.value(instant) - level) <= tolerance, (
            f"{stimulus}: value({instant}) = {stimulus.value(instant)} != {level}")
        found[inside[0]] += 1
    for (a, b), count in found.items():
        assert count <= 1, f"two crossings in the linear piece ({a}, {b})"
        # the function is linear on (a, b]: value(b) is its end, 2 value(mid) - value(b) its start
        end = stimulus.value(b)
        start = 2 * stimulus.value(0.5 * (a + b)) - end
        if start == end:
            continue
        fraction = (level - start) / (end - start)
        if 1e-6 < fraction < 1 - 1e-6:
            assert count == 1, f"{stimulus}: the piece ({a}, {b}) crosses {level} but was not reported"


# levels at least 1e-6 of the swing away from V1 and V2: a crossing closer to a corner than
# value()'s corner snapping (64 ulp of t) is read as the corner; the time grid merges such
# an instant with the corner anyway (points closer than 1e-9·TSTEP are one)
positions = st.floats(1e-6, 1 - 1e-6)


@settings(max_examples=100, deadline=None)
@given(pulses(), positions, st.floats(1e-4, 1e-2))
def test_pulse_threshold_crossings(pulse, position, stop):
    assume(stop / pulse.period <= 200)
    low, high = sorted((pulse.initial, pulse.pulsed))
    check_crossings(pulse, low + position * (high - low), stop)


@settings(max_examples=100, deadline=None)
@given(pwls(), positions, st.floats(1e-4, 1e-2))
def test_pwl_threshold_crossings(pwl, position, stop):
    low, high = min(pwl.values), max(pwl.values)
    check_crossings(pwl, low + position * (high - low), stop)


def test_pulse_crossings_of_the_buck_gate_are_where_the_ramps_reach_the_level():
    # PULSE(0 5 0 10n 10n 4.99u 10u): 2.5 V at 5 ns and 5.005 us in every period
    gate = Pulse(0, 5, 0, 10e-9, 10e-9, 4.99e-6, 10e-6)
    crossings = np.array(threshold_crossings(gate, 2.5, 30e-6))
    expected = np.array([n * 10e-6 + offset for n in range(3) for offset in (5e-9, 5.005e-6)])
    np.testing.assert_allclose(np.sort(crossings), expected, rtol=0, atol=1e-18)


def test_jumps_and_other_functions_give_no_crossings():
    # an ideal edge crosses at its corner, which is a breakpoint already
    assert threshold_crossings(Pulse(0, 5, 1e-6, 0, 0, 1e-6, 4e-6), 2.5, 10e-6) == []
    assert threshold_crossings(Pwl((0, 1e-3, 1e-3), (0, 0, 5)), 2.5, 2e-3) == []
    assert threshold_crossings(Sin(0, 5, 1e3), 2.5, 2e-3) == []
    assert threshold_crossings(Exp(0, 5, 0, 1e-4, 1e-3, 1e-4), 2.5, 2e-3) == []
    assert threshold_crossings(Dc(1), 1, 1) == []


@settings(max_examples=50, deadline=None)
@given(pulses())
def test_pulse_breakpoints_are_sorted_and_inside(pulse):
    stop = 5e-3
    points = pulse.breakpoints(stop)
    assert points == sorted(points)
    assert all(0 < p < stop for p in points)


@st.composite
def long_pulse_runs(draw):
    """A PULSE (zero ramps, ramps longer than the period, a delay, a pulse count) and instants
    over up to 10^6 periods: a coarse grid, every corner of some far periods and their
    floating-point neighbours (the period index of a late instant carries rounding)."""
    period = draw(st.floats(1e-8, 1e-3))
    fraction = st.one_of(st.just(0.0), st.floats(1e-9, 1.5))
    pulse = Pulse(draw(levels), draw(levels),
                  delay=draw(st.one_of(st.just(0.0), st.floats(0, 50))) * period,
                  rise=draw(fraction) * period, fall=draw(fraction) * period,
                  width=draw(fraction) * period, period=period,
                  count=draw(st.one_of(st.none(), st.integers(1, 10**6).map(float)))
                  ).resolve(period / 100, period)
    periods = draw(st.integers(1, 10**6))
    stop = pulse.delay + periods * period
    corners = np.array([0.0, pulse.rise, pulse.rise + pulse.width,
                        pulse.rise + pulse.width + pulse.fall, period])
    far = np.array(draw(st.lists(st.integers(0, periods), min_size=1, max_size=20)))
    times = np.concatenate([np.linspace(0.0, stop, 2001),
                            (pulse.delay + far[:, None] * period + corners[None, :]).ravel()])
    return pulse, np.concatenate([times, np.nextafter(times, np.inf), np.nextafter(times, -np.inf)])


@settings(max_examples=150, deadline=None)
@given(long_pulse_runs())
def test_pulse_flat_parts_shortcut_is_the_corner_by_corner_sampling(run):
    """``Pulse.sample`` settles the instants on a flat part at once (V1 or V2) and sends the
    others through the corner-by-corner evaluation: the two give the same bits everywhere,
    and each instant at V1 or V2 is ``value(t)`` (to an ulp: where two corners are within the
    snapping distance of each other the two snap in a different order, and V1 + (V2 - V1)
    may stand for V2)."""
    pulse, times = run
    times = times[times >= 0]
    fast, full = pulse.sample(times), pulse._sample_corners(times)
    np.testing.assert_array_equal(fast, full)
    flat = (fast == pulse.initial) | (fast == pulse.pulsed)
    picked = times[flat][:: max(1, int(flat.sum()) // 300)]
    ulp = np.spacing(max(abs(pulse.initial), abs(pulse.pulsed), abs(pulse.pulsed - pulse.initial)))
    np.testing.assert_allclose([pulse.value(float(t)) for t in picked], pulse.sample(picked),
                               rtol=0, atol=2 * ulp)


def test_pulse_corners_closer_than_the_snapping_distance_snap_once():
    """A fall that ends 1e-17 s after the period (found by the property test above): late in
    the run the snapping distance exceeds that gap, and ``value`` and ``sample`` must snap an
    instant near the period's end to the same corner (they used to differ by 1e-9 V there:
    ``sample`` snapped twice)."""
    pulse = Pulse(initial=0.0, pulsed=1.0, delay=0.0, rise=0.0, fall=1e-8, width=1e-17, period=1e-8)
    corners = np.array([0.0, 0.0, 1e-17, 1e-8 + 1e-17, 1e-8])
    times = (np.arange(0, 70_370, 7)[:, None] * 1e-8 + corners[None, :]).ravel()
    times = np.concatenate([np.linspace(0.0, 70_369e-8, 2001), times])
    times = np.concatenate([times, np.nextafter(times, 0.0), np.nextafter(times, 1.0)])
    expected = np.array([pulse.value(float(t)) for t in times])
    np.testing.assert_array_equal(pulse.sample(times), expected)
    np.testing.assert_array_equal(pulse._sample_corners(times), expected)
