"""Source time functions against their ngspice definitions, and their breakpoints."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from circuitnsds.engine.integrate import _sizes_and_classes
from circuitnsds.engine.timegrid import MERGE_FRACTION, time_grid
from circuitnsds.system.stimuli import Exp, Pulse, Pwl, Sin


def test_sin_with_delay_damping_and_phase():
    f = Sin(1.0, 2.0, 50.0, 0.01, 3.0, 30.0)
    assert f.value(0.0) == pytest.approx(1 + 2 * math.sin(math.radians(30)))
    t = 0.0137
    expected = 1 + 2 * math.exp(-3 * (t - 0.01)) * math.sin(2 * math.pi * 50 * (t - 0.01)
                                                            + math.radians(30))
    assert f.value(t) == pytest.approx(expected)
    assert f.breakpoints(1.0) == [0.01]
    assert Sin(0, 1).resolve(1e-3, 0.5).frequency == 2.0


def test_pulse_shape_period_and_left_continuity():
    p = Pulse(0.0, 5.0, 1.0, 0.5, 0.25, 2.0, 5.0)
    samples = {0.0: 0, 1.0: 0, 1.25: 2.5, 1.5: 5, 3.5: 5, 3.625: 2.5, 3.75: 0, 6.0: 0,
               6.25: 2.5, 7.0: 5}
    for t, v in samples.items():
        assert p.value(t) == pytest.approx(v), t
    step = Pulse(0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 10.0)
    assert step.value(1.0) == 0.0  # value at the corner is the value before it
    assert step.value(1.0 + 1e-12) == 1.0
    assert step.value(2.0) == 1.0 and step.value(2.0 + 1e-12) == 0.0
    assert p.breakpoints(7.0) == [1.0, 1.5, 3.5, 3.75, 6.0, 6.5]


def test_pulse_corners_stay_left_continuous_over_many_periods():
    """Grid points computed as k*step hit the corners only up to rounding."""
    pulse = Pulse(0.0, 1.0, 0.0, 0.0, 0.0, 0.3e-3, 1e-3)
    for k in range(1, 200):
        for corner in (k * 1e-3, k * 1e-3 + 0.3e-3):
            t = round(corner / 1e-4) * 1e-4  # how a 0.1 ms grid reaches the corner
            assert pulse.value(t) == pulse.value(corner - 1e-9), t


def test_zero_fields_take_ngspice_defaults():
    assert Sin(0, 1, 0.0).resolve(1e-3, 0.5).frequency == 2.0
    resolved = Pulse(0, 1, 0, 0, 0, 0, 0).resolve(1e-3, 0.5)
    assert (resolved.rise, resolved.width, resolved.period) == (0, 0.5, 0.5)
    assert Exp(0, 1, 0, 0, None, 0).resolve(1e-3, 0.5).rise_tau == 1e-3


def test_pwl_and_exp():
    assert Pwl((0.0, 1e-3, 1e-3), (0.0, 0.0, 1.0)).value(1e-3) == 0.0  # vertical last segment
    f = Pwl((0.0, 1.0, 1.0, 3.0), (0.0, 2.0, 4.0, 0.0))
    assert [f.value(t) for t in (-1, 0.5, 1.0, 2.0, 9)] == [0, 1, 2, 2, 0]
    assert f.breakpoints(2.0) == [1.0]
    e = Exp(0.0, 1.0, 1.0, 0.5, 3.0, 0.25)
    assert e.value(0.5) == 0
    assert e.value(2.0) == pytest.approx(1 - math.exp(-2))
    expected = (1 - math.exp(-2.5 / 0.5)) - (1 - math.exp(-0.5 / 0.25))
    assert e.value(3.5) == pytest.approx(expected)


@given(
    step=st.floats(1e-6, 1.0),
    stop_steps=st.floats(1.0, 400.0),
    points=st.lists(st.floats(0.0, 1.0), max_size=20),
)
def test_grid_contains_breakpoints_and_regular_steps(step, stop_steps, points):
    stop = step * stop_steps
    breakpoints = np.array(sorted(p * stop for p in points))
    grid = time_grid(step, stop, breakpoints)
    assert grid[0] == 0 and grid[-1] == stop
    assert np.all(np.diff(grid) > 0)
    assert np.all(np.diff(grid) <= step * (1 + 1e-9))
    assert np.all(np.diff(grid) > MERGE_FRACTION * step)  # no step in rounding noise
    for b in breakpoints[(breakpoints > 0) & (breakpoints < stop)]:
        assert np.min(np.abs(grid - b)) <= MERGE_FRACTION * step


@given(regular=st.floats(1e-9, 1.0), count=st.integers(1, 60),
       others=st.lists(st.tuples(st.integers(0, 59), st.floats(1e-3, 2.0)), max_size=12))
def test_step_classes_number_equal_sizes_in_increasing_order(regular, count, others):
    """The integrator's step classes (fast path: only the irregular steps sorted) against
    the definition: the rank of each step's size rounded to 1e-9 of the largest."""
    steps = np.full(count, regular)
    for index, factor in others:
        if index < count:
            steps[index] = regular * factor
    quantum = 1e-9 * steps.max()
    expected = np.unique(np.round(steps / quantum), return_inverse=True)[1].reshape(-1)
    np.testing.assert_array_equal(_sizes_and_classes(steps)[1], expected)


@given(step=st.floats(1e-7, 1.0), count=st.integers(1, 300),
       near=st.lists(st.tuples(st.integers(0, 300), st.floats(-2e-9, 2e-9)), max_size=15),
       points=st.lists(st.floats(0.0, 1.0), max_size=10))
def test_grid_drops_exactly_the_regular_points_next_to_a_breakpoint(step, count, near, points):
    """Breakpoints at and around regular points (within and just beyond the merge tolerance)
    against the definition: the grid is the regular points ``k·step`` (``stop`` last) with
    those closer than ``MERGE_FRACTION·step`` to a breakpoint in (0, stop) replaced by it."""
    stop = step * count
    breakpoints = np.array([(k + offset) * step for k, offset in near if k <= count]
                           + [p * stop for p in points])
    grid = time_grid(step, stop, breakpoints)
    regular = np.arange(count + 1) * step
    regular[-1] = stop
    tolerance = MERGE_FRACTION * step
    inside = np.unique(breakpoints[(breakpoints > tolerance) & (breakpoints < stop - tolerance)])
    if inside.size > 1:
        inside = inside[np.concatenate([[True], np.diff(inside) > tolerance])]
    dropped = [k for k in range(1, count) if np.any(np.abs(inside - regular[k]) <= tolerance)]
    expected = np.sort(np.concatenate([np.delete(regular, dropped), inside]))
    np.testing.assert_array_equal(grid, expected)


def test_a_sine_beyond_the_doubles_is_reported_not_a_crash(tmp_path, capsys):
    # a SIN delayed by -1e308 s (a fuzzed case from Xyce's ic_rc test): sin() of an infinite
    # phase raised "math domain error" (exit status 2, internal error); value() now gives NaN
    # as sample() does, and the run fails on the non-finite source, naming it
    from circuitnsds.cli.main import main
    from circuitnsds.system.stimuli import Sin

    wave = Sin(0.0, 1.0, 1e5, -1e308, 0.0)
    with np.errstate(all="ignore"):
        assert math.isnan(wave.value(0.0)) and math.isnan(wave.sample(np.array([0.0]))[0])
        assert math.isinf(Sin(0.0, 1.0, 1e3, 0.0, -1e10).value(0.25e-3))  # grows past the doubles
    path = tmp_path / "sin.cir"
    path.write_text("t\nv1 1 0 sin 0 1V 1e5 -1e308 0\nr1 1 2 1k\nc1 2 0 2u\n.tran 1u 1m\n.end\n")
    assert main(["run", str(path), "-q", "-o", str(tmp_path / "o.csv")]) == 1
    err = capsys.readouterr().err
    assert "internal error" not in err and "RuntimeWarning" not in err
    assert "a source function is nan at t = 0 s (i(v1): Sin(" in err
    assert "no results to write (the run stopped before its first step)" in err  # was "(before
    # the failure before the first step)"
