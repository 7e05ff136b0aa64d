"""The cheap paths of a run (issue 19: the Python work around the compiled loop) give the
numbers of the reference computations they replace, bit for bit."""

from __future__ import annotations

import io

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import circuitnsds
import circuitnsds.analyses.transient as transient
from circuitnsds.analyses.signals import trajectory_waveforms
from circuitnsds.circuit.elements.diode_notes import diode_peaks, waveform_diode_peaks
from circuitnsds.engine.integrate import _ranks, _sizes_and_classes, integrate
from circuitnsds.engine.timegrid import MERGE_FRACTION, time_grid
from circuitnsds.output.csvfile import write_rows
from circuitnsds.solvers import MLCPSolver
from circuitnsds.system.output_rows import signal_terms
from circuitnsds.system.stimuli import Pulse
from tests.test_stimuli_sample import pulses

ZENER_CLIPPER = """Shockley diode and Zener fitted as PWL devices, driven both ways
V1 in 0 SIN(0 20 1k)
R1 in a 100
D1 a b dfit
D2 0 b dzen
R2 b 0 1k
.model dfit D(IS=1e-14 N=1.5 RS=0.1)
.model dzen D(IS=1e-14 N=1 BV=5.1 IBV=1m)
.tran 1u 2m
.end
"""


@given(table=st.lists(st.floats(0.0, 2e9, allow_nan=False), min_size=1, max_size=8, unique=True),
       values=st.lists(st.floats(0.0, 2e9, allow_nan=False), max_size=40))
def test_ranks_are_numpys_searchsorted(table, values):
    """Comparisons with a short table (and numpy's binary search with a longer one, its ranks
    as int64 from 128 entries on) rank every value as ``np.searchsorted`` does, values in the
    table or not."""
    table = np.sort(np.array(table))
    values = np.array(values, dtype=float)
    ranks = _ranks(table, values)
    assert ranks.dtype == np.int8  # (fewer than 128 entries)
    np.testing.assert_array_equal(ranks, np.searchsorted(table, values))
    long = np.arange(200.0)
    np.testing.assert_array_equal(_ranks(long, values), np.searchsorted(long, values))


def test_step_sizes_do_not_take_a_rare_middle_step_for_the_common_one():
    """The flyback's grid: 1,200 half steps at its gate's threshold crossings among 300,600,
    the middle one of them a half step. Sizes and classes are still those of the definition."""
    steps = np.full(3001, 1e-8)
    steps[np.arange(5, 3001, 100)] = 5e-9
    steps[1500] = 5e-9
    (quantum, sizes), classes = _sizes_and_classes(steps)
    rounded = np.round(steps / quantum)
    np.testing.assert_array_equal(sizes, np.unique(rounded))
    np.testing.assert_array_equal(classes, np.unique(rounded, return_inverse=True)[1].reshape(-1))


def test_diode_peaks_are_those_of_the_waveforms():
    """A run's fitted-diode forward and breakdown peaks as the diode's run-time observer
    computes them are those read from its waveforms (the reference,
    :func:`waveform_diode_peaks`), for a diode and a Zener whose currents are those of their
    branches' pairs (each plus its off-conductance's)."""
    circuit = circuitnsds.read_netlist(ZENER_CLIPPER)
    spec = transient.transient_spec(circuit)
    mlcs = circuit.mlcs(spec.source_defaults)
    grid = np.linspace(0.0, spec.stop, 2001)
    state = transient.operating_point(circuit, mlcs, 1e-9)
    trajectory = integrate(mlcs, grid, state.y, state.charge, state.current, state.active,
                           state.switches)
    diodes = [e for e in circuit.elements if e.name in ("d1", "d2")]
    reference = waveform_diode_peaks(diodes, trajectory_waveforms(circuit, mlcs, trajectory,
                                                                  0.0, spec.stop))
    assert reference["d1"][0] > 0 and min(reference["d2"]) > 0  # both conduct, both ways
    pairs = {name: [source for source, _, _ in signal_terms(
        mlcs, mlcs.output_names.index(f"i({name})"))].count(1) for name in ("d1", "d2")}
    models = {name: circuit.element(name).model for name in ("d1", "d2")}
    assert pairs == {name: len(model.forward_branches) + len(model.breakdown_branches)
                     for name, model in models.items()}
    peaks = diode_peaks(diodes, mlcs, trajectory, {})
    assert peaks == reference


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 4), m=st.integers(1, 5))
def test_settled_answer_reuses_lemkes_evaluation_with_the_same_result(seed, n, m):
    """An MLCP answered by Lemke is settled (sign test of its mode) from the evaluation of its
    mode that Lemke's answer was checked with: the result, its method and the solver's
    counters are those of evaluating the mode again (the reference)."""
    rng = np.random.default_rng(seed)
    A = np.diag(rng.uniform(1.0, 3.0, n)) + 0.1 * rng.standard_normal((n, n))
    C = rng.standard_normal((n, m))
    R = rng.standard_normal((m, m))
    B = R @ R.T + rng.uniform(0.0, 1e-3) * np.eye(m)
    problems = [(rng.standard_normal(n), rng.standard_normal(m), rng.random(m) < 0.5)
                for _ in range(6)]

    def answers():
        solver = MLCPSolver(A, C, -C.T, B)
        found = [solver.solve(a, b, guess=guess) for a, b, guess in problems]
        return [(r.u, r.z, r.active, r.method, r.residual) for r in found], solver.stats

    settled, reused = MLCPSolver._settled, []

    def counted(self, result, c, evaluated=None):
        reused.append(evaluated is not None)
        return settled(self, result, c, evaluated)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(MLCPSolver, "_settled", counted)
        fast, fast_stats = answers()
        patch.setattr(MLCPSolver, "_settled",
                      lambda self, result, c, evaluated=None: settled(self, result, c))
        reference, reference_stats = answers()
    assert all(reused)  # (each Lemke answer here is its mode's evaluation: none computed again)
    assert fast_stats == reference_stats
    for (u, z, active, method, res), (u0, z0, active0, method0, res0) in zip(fast, reference):
        assert np.array_equal(u, u0) and np.array_equal(z, z0) and np.array_equal(active, active0)
        assert (method, res) == (method0, res0)


@settings(max_examples=150, deadline=None)
@given(pulse=pulses(), points=st.integers(64, 3000), start=st.floats(0.0, 1e-3),
       middles=st.booleans())
@example(pulse=Pulse(initial=0.0, pulsed=0.0, delay=8.8e-4, rise=0.0, fall=0.0, width=1e-4, period=1e-4,
                     count=None),
         points=64, start=0.0, middles=True)  # 63 midpoints: too few for the grid path
def test_pulse_sampled_on_a_grid_is_sampled_instant_by_instant(pulse, points, start, middles):
    """A PULSE sampled on an increasing grid with many points to a period (the flat stretches
    found by bisection, :meth:`Pulse._flat_runs`) gives, bit for bit, what the corner-by-corner
    formula gives at each instant (the reference), corners and their neighbours included; so
    do the grid's midpoints (the switch schedule's instants)."""
    step = pulse.period / 40
    grid = start + step * np.arange(points)
    corners = np.array(pulse.breakpoints(grid[-1] + pulse.period))
    corners = corners[(corners > grid[0]) & (corners < grid[-1])]
    grid = np.sort(np.concatenate([grid, corners, np.nextafter(corners, np.inf)]))
    times = 0.5 * (grid[:-1] + grid[1:]) if middles else grid
    sampled = pulse.sample(times)
    np.testing.assert_array_equal(sampled, pulse._sample_corners(times))
    regular = min(pulse.rise, pulse.width, pulse.fall) >= 0 and \
        pulse.rise + pulse.width + pulse.fall <= pulse.period and times.size >= 64  # (63 midpoints of 64)
    assert (pulse._flat_runs(times) is not None) == regular  # (the grid path was taken)
    shuffled = np.random.default_rng(points).permutation(times)
    assert pulse._flat_runs(shuffled) is None  # (not increasing: each instant's phase)
    np.testing.assert_array_equal(pulse.sample(shuffled), pulse._sample_corners(shuffled))


@settings(max_examples=200, deadline=None)
@given(step=st.floats(1e-9, 1.0), count=st.integers(1, 200),
       near=st.lists(st.tuples(st.integers(0, 200), st.floats(-3e-9, 3e-9)), max_size=12),
       points=st.lists(st.floats(-0.1, 1.1), max_size=12))
def test_time_grid_is_its_definition(step, count, near, points):
    """The grid (breakpoints put in the place of the regular points they are close to, the
    others merged in) is its definition computed point by point: the regular points ``k·step``
    not within ``MERGE_FRACTION·step`` of a breakpoint (the first and last kept), and the
    breakpoints inside ``(0, stop)`` (those within that of each other counted once)."""
    stop = count * step
    breakpoints = [stop * p for p in points] + [(k + d) * step for k, d in near if k <= count]
    grid = time_grid(step, stop, breakpoints)
    tolerance = MERGE_FRACTION * step
    inside = sorted(b for b in set(breakpoints) if tolerance < b < stop - tolerance)
    merged = [b for i, b in enumerate(inside) if i == 0 or b - inside[i - 1] > tolerance]
    regular = np.arange(count + 1, dtype=float) * step
    regular[-1] = stop
    kept = [t for k, t in enumerate(regular)
            if k in (0, count) or not any(abs(t - b) <= tolerance for b in merged)]
    np.testing.assert_array_equal(grid, np.array(sorted(kept + merged)))


def test_rows_written_with_reused_buffers_are_the_same_bytes():
    """Chunks of rows written with the buffers of earlier (larger and smaller) chunks reused,
    to a binary stream (the text buffer handed over as it is) and to a text stream, are the
    bytes of each chunk written with fresh buffers (the reference)."""
    rng = np.random.default_rng(7)
    scratch: dict = {}
    for rows in (70_000, 5, 65_536, 3, 65_537):
        time = np.cumsum(rng.random(rows))
        columns = [rng.standard_normal(rows) * 10.0 ** rng.integers(-20, 20, rows),
                   np.where(rng.random(rows) < 0.01, np.inf, rng.random(rows))]
        for stream, fresh in ((io.BytesIO(), io.BytesIO()), (io.StringIO(), io.StringIO())):
            write_rows(stream, time, columns, compiled=True, scratch=scratch)
            write_rows(fresh, time, columns, compiled=True)
            assert stream.getvalue() == fresh.getvalue()
