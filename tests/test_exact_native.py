"""The exact integrator's event loop in C (``circuitnsds/engine/exact/_exact_native.c``, built
at install), against the numba loop (:mod:`circuitnsds.engine.exact.loop`) and the Python loop
(:func:`circuitnsds.engine.exact.run.run_python`).

Checked here:

* the library is built from this very source and loaded (a missing library fails here, it is
  not skipped: CI installs with a C compiler);
* whole runs of bundled netlists (buck, DCM boost, bridge, three-phase inverter, voltage-mode
  buck; the flyback through the stepper, which hands its start to the θ-method): the C loop's
  rows, multipliers, charges, tails, events, segments and state are the numba loop's **bit for
  bit** (the same operations in the same order on this platform's libm; measured equal on all
  of them), and the Python loop's to round-off: 1e-12 of each signal's range where no event
  instant depends on a high-gain amplifier, 2e-7 for the voltage-mode buck (as
  ``test_exact_segments.test_the_compiled_loop_runs_the_python_loop`` explains);
* a run in parts (the stepper's parts of 37 rows) is the run in one part bit for bit in C, for
  the inverter (complex sources, a hundred modes met one by one: the loop returns NEW_MODE to
  Python, and EVENTS_FULL past 4096 events) and the voltage-mode buck;
* the loop stops as STALLED when the first-event search gives up, and the C search is the
  certified first root: never after a crossing that dense sampling sees (Hypothesis), equal to
  the numba search;
* a run on the C loop never imports numba.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import circuitnsds
from circuitnsds.analyses.operating_point import operating_point, uic_state
from circuitnsds.analyses.recorders import TrajectoryRecorder
from circuitnsds.engine.driver import drive
from circuitnsds.engine.exact import loop, run
from circuitnsds.engine.exact.first_event import UNRESOLVED, first_event, native_first_event
from circuitnsds.engine.exact.stepper import ExactStepper
from circuitnsds.engine.timegrid import time_grid
from tests.conftest import assert_native_library_current
from tests.test_exact_segments import drawn_term, two_columns

ROOT = Path(__file__).parents[1]
NETLISTS = ROOT / "netlists"
BENCH = ROOT / "benchmarks" / "netlists"


def test_library_built_from_this_source_and_loaded() -> None:
    assert_native_library_current("engine/exact/_exact_native")
    assert run.native_loop() is not None


class _Spy:
    """Counts the C loop's calls and keeps their statuses."""

    def __init__(self, monkeypatch):
        self.statuses: list[int] = []
        call = run._native_call

        def spied(*arguments):
            status = call(*arguments)
            self.statuses.append(status)
            return status

        monkeypatch.setattr(run, "_native_call", spied)


def _prepared(path: Path, stop: float | None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        circuit = circuitnsds.read_netlist(path)
        tran = circuit.analyses["tran"]
        mlcs = circuit.mlcs()
        state = uic_state(circuit, mlcs) if tran.uic else operating_point(circuit, mlcs)
    stop = tran.stop if stop is None else stop
    times = np.arange(round(stop / tran.step) + 1) * tran.step
    active = np.zeros(mlcs.m, bool) if state.active is None else np.asarray(state.active, bool)
    return (mlcs, times, state.y, active, tuple(state.switches)), tran.step


def _assert_same_run(a: run.ExactRun, b: run.ExactRun) -> None:
    """Every array and count of two runs equal, bit for bit."""
    for name in ("y", "currents", "charges", "active", "closed"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.events == b.events
    assert (a.segments, a.rows) == (b.segments, b.rows)
    assert a.tails.keys() == b.tails.keys()
    for row, (y, dt) in a.tails.items():
        np.testing.assert_array_equal(y, b.tails[row][0])
        assert dt == b.tails[row][1]
    assert a.state.t == b.state.t and a.state.closed == b.state.closed
    np.testing.assert_array_equal(a.state.x, b.state.x)
    np.testing.assert_array_equal(a.state.y_size, b.state.y_size)
    np.testing.assert_array_equal(a.state.active, b.state.active)


@pytest.mark.parametrize("path, stop, python_tolerance", [
    (NETLISTS / "buck_converter.cir", 0.2e-3, 1e-12),
    (BENCH / "boost_dcm.cir", 0.2e-3, 1e-12),
    (NETLISTS / "bridge_rectifier.cir", None, 1e-12),
    (BENCH / "inverter_three_phase.cir", 4e-3, 1e-12),
    (NETLISTS / "buck_voltage_mode.cir", 40e-6, 2e-7),
])
def test_the_c_loop_is_the_numba_loop_and_the_python_loop(monkeypatch, path, stop, python_tolerance):
    arguments, step = _prepared(path, stop)
    spy = _Spy(monkeypatch)
    native = run.run_exact(*arguments)
    assert spy.statuses and spy.statuses[-1] == loop.FINISHED  # (the C loop ran)
    with monkeypatch.context() as numba_only:
        numba_only.setattr(run, "native_loop", lambda: None)
        compiled = run.run_exact(*arguments)
    _assert_same_run(native, compiled)
    python = run.run_python(*arguments)
    assert native.segments == python.segments
    assert [(e.element, e.state) for e in native.events] == [(e.element, e.state) for e in python.events]
    scale = np.abs(python.y).max(axis=0) + 1e-12
    assert np.max(np.abs(native.y - python.y) / scale) < python_tolerance
    largest = np.abs(python.currents).max(initial=0)
    assert np.all(np.abs(native.currents - python.currents) <= python_tolerance * largest)
    assert np.all(np.abs(native.charges - python.charges) <= python_tolerance * largest * step)
    np.testing.assert_array_equal(native.active, python.active)
    np.testing.assert_array_equal(native.closed, python.closed)


def test_tables_that_grow_give_the_c_loop_the_same_lists(monkeypatch):
    # the inverter's modes joining tables sized for 2 (doubled as they come, each mode's list
    # of nonzero entries carried over: ModeTables._allocate) against tables sized for them all:
    # the C loop's runs are the same bit for bit
    from circuitnsds.engine.exact import mode_tables

    arguments, _ = _prepared(BENCH / "inverter_three_phase.cir", 4e-3)
    roomy = run.run_exact(*arguments)
    monkeypatch.setattr(mode_tables, "INITIAL_BYTES", 1)
    monkeypatch.setattr(mode_tables, "INITIAL_CAPACITY", 2)
    spy = _Spy(monkeypatch)
    grown = run.run_exact(*arguments)
    assert spy.statuses and spy.statuses[-1] == loop.FINISHED  # (the C loop ran)
    _assert_same_run(roomy, grown)


CHATTERING_TANK = """A 2 GHz sine through a tank clamped by a diode: an event every few hundred ps
V1 in 0 SIN(0 1 2G)
L1 in a 1n
C1 a 0 1p
D1 0 a dd
R1 a 0 1k
.model dd D(Ron=1m)
.tran 1u 10m
.end
"""


def test_the_three_loops_stop_a_chattering_diode_alike(monkeypatch, tmp_path):
    # a diode clamping a tank driven at 2 GHz turns on and off every few hundred ps, for ever:
    # in a run of 10 ms that is below the floor (run.CHATTERING: 1e-8 of the run, 100 ps
    # here) more than 64 times in a row within a fraction of a microsecond, and the C, numba
    # and Python loops stop at the same instant (the C and numba ones with the same rows, bit
    # for bit). (The XSPICE voltage-mode buck's diode did this at start-up, falsely: the
    # modal sum at its rest state was off its algebraic values, docs/method.md.)
    netlist = tmp_path / "tank.cir"
    netlist.write_text(CHATTERING_TANK)
    arguments, _ = _prepared(netlist, 20e-6)
    stopped = {}
    for which in ("c", "numba", "python"):
        with monkeypatch.context() as patched:
            if which == "numba":
                patched.setattr(run, "native_loop", lambda: None)
            runner = run.run_python if which == "python" else run.run_exact
            with pytest.raises(run.Chattering, match=r"more than 64 segments in a row shorter than "
                               r"1e-08 of the run") as raised:
                runner(*arguments, stop=1e-2)  # (the whole run's end: its floor)
        stopped[which] = raised.value
    c, numba, python = stopped["c"], stopped["numba"], stopped["python"]
    assert 0.0 < c.time < 1e-6 and c.time == numba.time
    _assert_same_run(c.run, numba.run)
    assert python.time == pytest.approx(c.time, rel=1e-12) and python.run.rows == c.run.rows


def test_the_loops_limits_are_the_same_in_c_numba_and_python():
    source = (Path(run.__file__).parent / "_exact_native.c").read_text()
    defined = dict(re.findall(r"^#define (MAX_MODE_CHANGES|CHATTERING) (\S+)$", source, re.MULTILINE))
    assert float(defined["CHATTERING"]) == run.CHATTERING == loop.CHATTERING
    assert int(defined["MAX_MODE_CHANGES"]) == run.MAX_MODE_CHANGES == loop.MAX_MODE_CHANGES


def test_the_flyback_through_the_stepper_is_the_numba_loops_bit_for_bit(monkeypatch):
    # the flyback's start is a mode without state equations (the θ-method takes it, then the
    # exact loop goes on): the hand-off's state is the loop's start
    flyback = circuitnsds.read_netlist(BENCH / "flyback_rcd.cir")
    spy = _Spy(monkeypatch)
    native = flyback.transient(method="exact", stop=30e-6)
    assert loop.FINISHED in spy.statuses
    monkeypatch.setattr(run, "native_loop", lambda: None)
    compiled = flyback.transient(method="exact", stop=30e-6)
    for name in ("v(clamp)", "v(out)", "i(lp)", "i(ls)"):
        np.testing.assert_array_equal(native[name], compiled[name])
    assert native.events == compiled.events


class _Concatenated:
    """A recorder joining the parts' new rows."""

    def __init__(self):
        self.arrays: dict[str, np.ndarray] = {}
        self.events: list = []

    def record(self, trajectory, first):
        for name in ("y", "current", "impulse", "active", "switches"):
            rows = getattr(trajectory, name)[first:].copy()
            self.arrays[name] = rows if name not in self.arrays else np.concatenate([self.arrays[name], rows])
        self.events += [e for e in trajectory.events if e not in self.events]


@pytest.mark.parametrize("path, step, stop", [(BENCH / "inverter_three_phase.cir", 10e-6, 60e-3),
                                              (NETLISTS / "buck_voltage_mode.cir", 40e-9, 60e-6)])
def test_a_run_in_parts_is_the_run_in_one_part_bit_for_bit_in_c(monkeypatch, path, step, stop):
    circuit = circuitnsds.read_netlist(path)
    mlcs = circuit.mlcs()
    start = operating_point(circuit, mlcs)
    grid = time_grid(step, stop, mlcs.breakpoints(stop))
    spy = _Spy(monkeypatch)
    whole = TrajectoryRecorder()
    drive(ExactStepper(mlcs), grid, start, whole)
    assert loop.NEW_MODE in spy.statuses
    if "inverter" in path.name:  # (more than the 4096 events the first buffers hold)
        assert loop.EVENTS_FULL in spy.statuses and len(whole.trajectory.events) > 4096
    parts = _Concatenated()
    drive(ExactStepper(mlcs), grid, start, parts, part_steps=37)
    one = whole.trajectory
    for name in ("y", "current", "impulse", "active", "switches"):
        np.testing.assert_array_equal(parts.arrays[name], getattr(one, name), err_msg=name)
    assert parts.events == one.events


def _zero_function_loop_arguments() -> tuple[dict[str, np.ndarray], tuple[int, ...]]:
    """The arguments of a loop over one mode of one switch (one unknown, no pair) whose event
    function is 0.3 cos(ωτ) written twice with opposite signs: zero everywhere, its bound over
    any interval -1.2 (the fast terms by their magnitude), so the search never clears an
    interval and gives up."""
    omega = 2 * np.pi * 5e3
    terms, inputs = 4, 3  # inputs [x; s; 1]: one state, one source signal of one term, the 1
    table_map = np.zeros((1, terms, inputs), complex)
    table_map[0, :, 2] = [0.3, 0.3, -0.3, -0.3]
    arrays = {
        "clock": np.zeros(1), "counters": np.array([0, 0, 0, 1, 0, 0, 0, 0, 0], np.int64),
        "x": np.zeros(1), "y_size": np.zeros(1), "sources_now": np.zeros((1, 1), complex),
        "widened": np.zeros(1), "corners": np.array([0.0, 1e-3]),
        "source_coefficients": np.zeros((1, 1, 1), complex), "source_exponents": np.zeros(1, complex),
        "source_powers": np.zeros(1, np.int64), "partner": np.array([-1]), "s_matrix": np.zeros((1, 1)),
        "bits": np.ones((1, 1), bool), "z_map": np.zeros((1, terms, inputs), complex),
        "table_map": table_map, "powers": np.zeros((1, terms), np.int64),
        "exponents": np.array([[1j * omega, -1j * omega, 1j * omega, -1j * omega]]),
        "terms": np.array([terms]), "slope_weights": np.zeros((1, terms), complex),
        "rows_p": np.zeros((1, 1, 1)), "rows_q": np.zeros((1, 1, 1)), "rows_y": np.zeros((1, 1, 1)),
        "rows_c": np.zeros((1, 1)), "fast_rows": np.zeros((1, 1, 1)), "gap_rows": np.zeros((1, 1, 1)),
        "v1t": np.ones((1, 1)),
        "times": np.array([0.0, 1e-3]),
        "y_out": np.zeros((2, 1)), "l_out": np.zeros((2, 0)), "charges": np.zeros((2, 0)),
        "row_active": np.zeros((2, 0), bool), "row_closed": np.zeros((2, 1), bool),
        "event_times": np.zeros(8), "event_index": np.zeros(8, np.int64), "event_on": np.zeros(8, bool),
        "tail_row": np.zeros(8, np.int64), "tail_dt": np.zeros(8), "tail_y": np.zeros((8, 1)),
    }
    # every entry listed (the event table's lines, rows_q's, rows_y's, the z map's: zeros add ±0)
    widths = [inputs] * terms + [1, 1] + [inputs] * terms
    arrays["first"] = np.concatenate([[0], np.cumsum(widths)]).astype(np.int64)
    arrays["entries"] = np.concatenate([np.arange(width) for width in widths]).astype(np.int32)
    sizes = (1, 0, 1, 1, 1, 1, 2, 1, terms, inputs, 2, 8, 8)
    return arrays, sizes


def test_the_loop_stops_as_stalled_when_the_search_gives_up():
    arrays, sizes = _zero_function_loop_arguments()
    status = run._native_call(run.native_loop(), arrays, sizes)
    assert status == loop.STALLED
    assert arrays["clock"][0] == 0.0 and arrays["counters"][3] == 1  # (nothing made up, no row)
    again, _ = _zero_function_loop_arguments()  # the numba loop on the same arguments
    numba_arguments = [again[name] for name in run.NATIVE_ARRAYS if name not in run.NATIVE_ONLY]
    numba_arguments.insert(run.NATIVE_ARRAYS.index("bits") + 1, 1)  # (known modes)
    status = loop.exact_loop(*numba_arguments)
    assert status == loop.STALLED
    np.testing.assert_array_equal(again["counters"], arrays["counters"])
    # the search alone, as first_event.py's test has it for numba
    tau, column = native_first_event(arrays["table_map"][0, :, 2:], np.zeros(4, np.int64),
                                     arrays["exponents"][0], np.array([1e-12]), 2e-3)
    assert (tau, column) == (0.0, -2) and UNRESOLVED < 0




@settings(max_examples=80, deadline=None)
@given(st.lists(drawn_term, min_size=1, max_size=5), st.floats(-2.0, 2.0), st.floats(1e-5, 2e-3))
def test_the_c_search_is_the_first_root_dense_sampling_cannot_beat(terms, offset, horizon):
    # two columns sharing their terms, as a segment's event functions do; the C search's
    # instant: no column is below -tol (beyond its round-off) at any of 19,999 instants inside
    # (0, τ) (a column negative at 0 ends the segment at once: τ = 0), and, when a column ends
    # the segment after 0, that column is at its zero there (to the bound's band); the numba
    # search finds the same instant
    g = two_columns(terms, offset)
    tolerances = np.array([1e-12, 1e-12])
    found = native_first_event(g.coefficients, g.powers, g.exponents, tolerances, horizon)
    assert found is not None
    tau, column = found
    assert 0.0 <= tau <= horizon and column in (-1, 0, 1)
    growth = np.exp(max(0.0, g.exponents.real.max()) * horizon)
    band = 1e-10 * np.abs(g.coefficients).sum(axis=0) * growth + tolerances  # (the sums' round-off)
    samples = np.linspace(0.0, tau, 20_001)[1:-1] if tau > 0 else np.zeros(0)
    values = np.array([g(s).real for s in samples]).reshape(-1, 2)
    assert np.all(values >= -tolerances - band), "a crossing before the instant found"
    if column < 0:
        assert tau == horizon
    elif tau > 0:
        assert abs(g(tau)[column].real) <= tolerances[column] + band[column]
    powers = g.powers.astype(np.int64)
    reference, ended = first_event(g.coefficients, powers, g.exponents, tolerances, horizon, 1e-13)
    if ended != -2:
        reference, ended = loop.crossed_within_tolerance(g.coefficients, powers, g.exponents, tolerances,
                                                         reference, ended, horizon, 1e-13)
    assert (tau, column) == (reference, ended)


PROBE = """
import sys
from circuitnsds.cli.main import main
from circuitnsds.engine.exact import run
calls = []
call = run._native_call
run._native_call = lambda *a: calls.append(1) or call(*a)
code = main([{args}])
print(code, len(calls), "numba" in sys.modules)
"""


def test_a_run_on_the_c_loop_imports_no_numba(tmp_path: Path) -> None:
    deck = tmp_path / "buck.cir"
    text = (NETLISTS / "buck_voltage_mode.cir").read_text()
    deck.write_text(text.replace(".end", ".options method=exact\n.end"))
    args = ["run", str(deck), "--stop", "1e-3", "-o", str(tmp_path / "out.csv"), "-q", "--signals", "v(out)"]
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", PROBE.format(args=", ".join(repr(a) for a in args))],
                          capture_output=True, text=True, cwd=tmp_path, env=environment, timeout=120)
    assert done.returncode == 0, done.stderr
    code, calls, numba = done.stdout.split()[-3:]
    assert code == "0" and int(calls) > 0 and numba == "False"


def test_an_exact_pss_with_the_c_library_imports_no_numba(tmp_path: Path) -> None:
    # the period map's Python loop (run_python, for the saltation matrices) searches with the C
    # library's search: loading numba for it was 0.75 s of the boost's 1.2 s pss
    args = ["pss", str(NETLISTS / "boost_converter.cir"), "-o", str(tmp_path / "p.csv"), "-q"]
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", PROBE.format(args=", ".join(repr(a) for a in args))],
                          capture_output=True, text=True, cwd=tmp_path, env=environment, timeout=120)
    assert done.returncode == 0, done.stderr
    code, _, numba = done.stdout.split()[-3:]
    assert code == "0" and numba == "False"
