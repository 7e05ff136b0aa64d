"""The mode-table loop in C (``circuitnsds/engine/_dense_native.c``, built at install).

It must be the numba loop's twin bit for bit (same floating-point operations in the same
order; no contraction, no reassociation), so the default ``auto``/``compiled`` runs do not
change by the last bit when it replaces numba. Checked here:

* the library is built from this very source and loaded (CI installs with a C compiler: a
  missing library fails here, it is not skipped);
* random mode tables (random maps, step classes, scheduled and watched switches, stored
  modes flagged unique or not): every written array and the returned ``(k, reason, last)``
  of the C loop equal numba's, and the Python loop's to rounding; also for up to 22 rows
  and 9 inactive pairs (the C loop sums rows in blocks of eight, four, two);
* whole runs, C against numba, bit for bit: the bundled buck, the flyback with Coss at
  θ = 0.5 (mode changes found in the table), the 16-diode RF multiplier, an XSPICE buck
  with watched switches, the bridge; C against the Python loop to rounding;
* :mod:`circuitnsds.native` refuses a library built from another source (warns) and
  ``CIRCUITNSDS_NATIVE=0`` disables it;
* a run with the library never imports numba.
"""

from __future__ import annotations

import copy
import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import circuitnsds
from circuitnsds import native
from circuitnsds.engine import dense_loop
from circuitnsds.engine.dense_loop import FreeSwitches, ModeMap, ModeTable, run_table
from tests.conftest import assert_native_library_current, pinned_copy

ROOT = Path(__file__).parents[1]
NETLISTS = ROOT / "netlists"
BENCH = ROOT / "benchmarks" / "netlists"
BUILD = "python setup.py build_ext --inplace (or pip install -e .) with a C compiler"


def test_library_built_from_this_source_and_loaded() -> None:
    assert_native_library_current("engine/_dense_native")
    assert dense_loop.native_loaded(), f"the C loop is built but not loaded (stale? {BUILD})"


# -- random tables: C, numba and Python loops on the same arguments ---------------------------


def random_table(rng: np.random.Generator, n: int, m: int, kstim: int) -> ModeTable:
    """One to three modes for most combinations of step class 0..1, scheduled state 0..1 and
    free-switch id 0..1 (none for some), with random active sets and maps (contracting
    ``P``, so the runs stay bounded; pair values mostly positive, so that a mode holds for a
    few steps), a few with an infinite resistance, random ``unique`` flags."""
    table = ModeTable(n, m, kstim)
    for key in range(8):
        if rng.random() < 0.15:
            continue  # a class and switch state without modes
        for copy_ in range(rng.integers(1, 4)):
            mask = rng.random(m) < 0.5
            active = np.flatnonzero(mask).astype(np.int64)
            a = active.size
            rows = n + a
            resistance = rng.uniform(0.1, 10.0, a)
            resistance[rng.random(a) < 0.2] = np.inf
            c = rng.normal(0, 1, rows)
            c[n:] += 1.5
            mode = ModeMap(P=rng.normal(0, 0.4 / n, (rows, n)), Q1=rng.normal(0, 0.3, (rows, kstim)),
                           Q0=rng.normal(0, 0.3, (rows, kstim)), c=c, W=rng.normal(0, 0.3, (m, rows)),
                           e_w=rng.normal(1.5, 1, m), resistance=resistance, active=active)
            table.add((key & 1, key >> 1 & 1, key >> 2, mask.tobytes() + bytes([copy_])), mode,
                      unique=bool(rng.random() < 0.7))
    return table


def run_random(table: ModeTable, rng_seed: int, steps: int, n: int, m: int, kstim: int, switches: int,
               how: str) -> tuple:
    """Steps ``0 .. steps`` over a copy of ``table`` (the loop updates its last-use and successor
    arrays), the loop called again after each stop as the integrator does (a step it leaves
    is taken here by a random state, a watched switch that must change flips), arguments
    drawn from ``rng_seed``: everything it returns and writes."""
    rng = np.random.default_rng(rng_seed)
    table = copy.deepcopy(table)
    table.native_arguments = None
    y = np.zeros((steps + 1, n))
    y[0] = rng.normal(0, 1, n)
    z = np.zeros((steps + 1, m))
    F = rng.normal(0, 1, (steps + 1, kstim))
    step_class = rng.integers(0, 2, steps).astype(np.int64)
    sched_state = (rng.random(steps) < 0.1).cumsum().astype(np.int64) % 2
    controls = rng.normal(0, 1, (switches, n))
    on, off = rng.uniform(0, 2, switches), rng.uniform(-2, 0, switches)
    switch_on = rng.random(switches) < 0.5
    used = np.full(steps + 1, -7, dtype=np.int64)
    k, mode, calls = int(rng.integers(0, 3)), int(rng.integers(-1, table.count)), []
    while k < steps:
        free = FreeSwitches(controls, on, off, switch_on.copy())
        free_id = int(switch_on[:1].sum())
        done = run_table(table, mode, int(rng.integers(0, 2)), k, steps, y, z, F, step_class, sched_state,
                         free_id, free, used, use_compiled=how != "python", use_native=how == "c")
        calls.append(done)
        k, reason, mode = done
        if reason == dense_loop.STOP_SWITCH:
            switch_on ^= True
        elif reason in (dense_loop.STOP_LEFT_MODE, dense_loop.STOP_NO_MODE):
            y[k + 1] = rng.normal(0, 1, n)  # the caller's MLCP step
            k, mode = k + 1, int(rng.integers(-1, table.count))
    return calls, y, z, used, table.last_used.copy(), table.successor.copy()


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(n=st.integers(1, 5), m=st.integers(0, 4), kstim=st.integers(0, 2), switches=st.integers(0, 2),
       seed=st.integers(0, 2**32 - 1))
def test_random_tables_c_equals_numba(n: int, m: int, kstim: int, switches: int, seed: int) -> None:
    table = random_table(np.random.default_rng(seed), n, m, kstim)
    c = run_random(table, seed + 1, 60, n, m, kstim, switches, "c")
    numba = run_random(table, seed + 1, 60, n, m, kstim, switches, "numba")
    python = run_random(table, seed + 1, 60, n, m, kstim, switches, "python")
    assert c[0] == numba[0]
    for ours, theirs in zip(c[1:], numba[1:], strict=True):
        np.testing.assert_array_equal(ours, theirs)
    # the Python loop sums the products in another order: the same path, values to rounding
    assert c[0] == python[0]
    np.testing.assert_array_equal(c[3], python[3])
    for ours, theirs in zip(c[1:3], python[1:3], strict=True):
        scale = 1 + np.abs(theirs).max(initial=0.0)
        np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=1e-12 * scale)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(n=st.integers(1, 13), m=st.integers(0, 9), kstim=st.integers(0, 3), switches=st.integers(0, 2),
       seed=st.integers(0, 2**32 - 1))
# (the block boundaries every run covers, whatever hypothesis draws: rows n + active pairs
# around 4, 8, 12, 16 and 22, inactive pairs 0..9)
@example(n=4, m=0, kstim=1, switches=0, seed=1)
@example(n=7, m=1, kstim=2, switches=1, seed=2)
@example(n=8, m=1, kstim=0, switches=0, seed=3)
@example(n=9, m=3, kstim=1, switches=2, seed=4)
@example(n=12, m=5, kstim=3, switches=1, seed=5)
@example(n=13, m=9, kstim=2, switches=0, seed=6)
@example(n=1, m=9, kstim=1, switches=1, seed=7)
@example(n=3, m=2, kstim=0, switches=2, seed=8)
def test_row_blocks_c_equals_numba(n: int, m: int, kstim: int, switches: int, seed: int) -> None:
    """The C loop sums a step's rows eight and four at a time and the inactive pairs' w four and
    two at a time, a count that is no multiple of the block finished by a block ending at the
    last row: counts of rows 1..22 and of inactive pairs 0..9 (the examples pin the block
    boundaries) give numba's numbers bit for bit, and the same modes pass and fail their signs."""
    table = random_table(np.random.default_rng(seed), n, m, kstim)
    c = run_random(table, seed + 1, 40, n, m, kstim, switches, "c")
    numba = run_random(table, seed + 1, 40, n, m, kstim, switches, "numba")
    assert c[0] == numba[0]
    for ours, theirs in zip(c[1:], numba[1:], strict=True):
        np.testing.assert_array_equal(ours, theirs)
    # and bit for bit, not merely equal as numbers (assert_array_equal takes -0.0 for 0.0)
    for ours, theirs in zip(c[1:3], numba[1:3], strict=True):
        assert ours.tobytes() == theirs.tobytes()


def test_layouts_the_loop_cannot_take(monkeypatch) -> None:
    """Read-only arrays laid out otherwise are copied for the C loop, rows apart in memory are
    taken as they are; a written array it cannot take falls back to numba's loop (here a
    recording stand-in running the Python loop, so that no other signature is compiled);
    sizes that do not fit the table are an error, not a read beyond an array."""
    rng = np.random.default_rng(4)  # a table whose modes hold for the whole run
    n, m, kstim, steps = 3, 2, 2, 30
    table = random_table(rng, n, m, kstim)
    y0, F = rng.normal(0, 1, n), rng.normal(0, 1, (steps + 1, kstim))
    step_class = rng.integers(0, 2, steps)
    sched_state = (rng.random(steps) < 0.1).cumsum() % 2
    free = FreeSwitches(rng.normal(0, 1, (1, n)), 9 * np.ones(1), -9 * np.ones(1), np.ones(1, dtype=bool))

    def run(y, z, F, step_class, used, use_native):
        fresh = copy.deepcopy(table)
        fresh.native_arguments = None
        y[0] = y0
        done = run_table(fresh, -1, 0, 0, steps, y, z, F, step_class, sched_state, 0, free, used,
                         use_native=use_native)
        return done, y.copy(), z.copy(), np.array(used), fresh.last_used, fresh.successor

    expected = run(np.zeros((steps + 1, n)), np.zeros((steps + 1, m)), F, step_class,
                   np.zeros(steps + 1, dtype=np.int64), use_native=False)
    assert expected[0][0] == steps
    odd = run(np.zeros((steps + 1, n + 3))[:, 1:n + 1], np.zeros((steps + 1, m)), np.asfortranarray(F),
              step_class.astype(np.int32), np.zeros(steps + 1, dtype=np.int64), use_native=True)
    assert odd[0] == expected[0]
    for ours, theirs in zip(odd[1:], expected[1:], strict=True):
        np.testing.assert_array_equal(ours, theirs)
    numba_calls = []
    monkeypatch.setattr(dense_loop, "_compiled",
                        lambda *a: numba_calls.append(1) or dense_loop._python_loop(*a))
    strided = run(np.zeros((steps + 1, n)), np.zeros((steps + 1, m)), F, step_class,
                  np.zeros(2 * (steps + 1), dtype=np.int64)[::2], use_native=True)
    assert numba_calls == [1] and strided[0] == expected[0]
    np.testing.assert_array_equal(strided[3], expected[3])
    np.testing.assert_allclose(strided[1], expected[1], rtol=1e-12, atol=1e-12)
    with pytest.raises(ValueError, match="beyond them"):
        run_table(table, 0, 0, 0, steps + 5, np.zeros((steps + 1, n)), np.zeros((steps + 1, m)), F,
                  step_class, sched_state, 0, free, np.zeros(steps + 1, dtype=np.int64))


# -- whole runs --------------------------------------------------------------------------------

RUNS = {
    "buck": (NETLISTS / "buck_converter.cir", {}),
    "flyback θ=0.5": (BENCH / "flyback_coss.cir", {"stop": 1e-4, "theta": 0.5}),
    "RF multiplier": (BENCH / "rf_multiplier.cir", {"stop": 2e-7}),
    "XSPICE peak-current buck": (NETLISTS / "buck_peak_current_xspice.cir", {"stop": 2e-5}),
    "bridge": (NETLISTS / "bridge_rectifier.cir", {}),
}


def transient(path: Path, options: dict, stepping: str, monkeypatch, c_loop: bool):
    """The run's waveforms and how many calls of the C loop it made (``c_loop=False``: the
    C loop hidden, numba's runs)."""
    calls = []
    run_native = dense_loop._run_native

    def counted(*args):
        calls.append(1)
        return run_native(*args)

    with monkeypatch.context() as patch:
        patch.setattr(dense_loop, "_run_native", counted)
        if not c_loop:
            patch.setattr(dense_loop, "_native_function", lambda: None)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the netlists' notes (a fitted diode model's range)
            # (θ's mode loop in C, numba and numpy: pinned to θ)
            waves = circuitnsds.read_netlist(path).transient(stepping=stepping, method="theta", **options)
    return waves, len(calls)


@pytest.mark.parametrize("name", list(RUNS))
def test_runs_c_equal_numba_bit_for_bit(name: str, monkeypatch) -> None:
    assert dense_loop.native_loaded(), BUILD
    path, options = RUNS[name]
    ours, c_calls = transient(path, options, "compiled", monkeypatch, c_loop=True)
    theirs, numba_calls = transient(path, options, "compiled", monkeypatch, c_loop=False)
    assert c_calls > 0 and numba_calls == 0
    assert dense_loop._compiled.loaded  # numba's loop ran the second
    assert ours.names == theirs.names
    for signal in ours.names:
        np.testing.assert_array_equal(ours[signal], theirs[signal], err_msg=signal)


@pytest.mark.parametrize("name", ["buck", "flyback θ=0.5", "bridge"])
def test_runs_c_agree_with_python_loop(name: str, monkeypatch) -> None:
    path, options = RUNS[name]
    ours, c_calls = transient(path, options, "compiled", monkeypatch, c_loop=True)
    theirs, _ = transient(path, options, "numpy", monkeypatch, c_loop=True)
    assert c_calls > 0
    for signal in ours.names:
        scale = np.abs(theirs[signal]).max()
        np.testing.assert_allclose(ours[signal], theirs[signal], rtol=0, atol=1e-9 * (1 + scale),
                                   err_msg=signal)


# -- circuitnsds.native: stale libraries and the switch ----------------------------------------


def test_stale_library_refused_and_switch(tmp_path: Path, monkeypatch) -> None:
    stem = native.PACKAGE / "engine" / "_dense_native"
    built = native._built(stem)
    assert built is not None, BUILD
    (tmp_path / "engine").mkdir()
    shutil.copy(built, tmp_path / "engine" / built.name)
    source = tmp_path / "engine" / "_dense_native.c"
    shutil.copy(stem.with_suffix(".c"), source)
    monkeypatch.setattr(native, "PACKAGE", tmp_path)
    monkeypatch.setattr(native, "_LIBRARIES", {})
    assert native.library("engine/_dense_native") is not None  # the copy, from its source
    monkeypatch.setattr(native, "_LIBRARIES", {})
    monkeypatch.setenv(native.DISABLE_ENV, "0")
    assert native.library("engine/_dense_native") is None
    monkeypatch.delenv(native.DISABLE_ENV)
    monkeypatch.setattr(native, "_LIBRARIES", {})
    header = tmp_path / "native.h"  # the header the library was built with (shared by all)
    shutil.copy(native.HEADER, header)
    monkeypatch.setattr(native, "HEADER", header)
    assert native.library("engine/_dense_native") is not None
    monkeypatch.setattr(native, "_LIBRARIES", {})
    header.write_text(header.read_text() + "\n/* edited since the build */\n")
    with pytest.warns(RuntimeWarning, match="built from another version"):
        assert native.library("engine/_dense_native") is None
    shutil.copy(stem.parents[1] / "native.h", header)  # the header as built again
    monkeypatch.setattr(native, "_LIBRARIES", {})
    source.write_text(source.read_text() + "\n/* edited since the build */\n")
    with pytest.warns(RuntimeWarning, match="built from another version"):
        assert native.library("engine/_dense_native") is None


# -- a run with the library imports no numba ---------------------------------------------------

PROBE = """
import sys
from circuitnsds.cli.main import main
from circuitnsds.engine import dense_loop
calls = []
run_native = dense_loop._run_native
dense_loop._run_native = lambda *a: calls.append(1) or run_native(*a)
code = main([{args}])
print(code, len(calls), dense_loop.native_loaded(), "numba" in sys.modules)
"""


def probe(args: list[str], env: dict[str, str], cwd: Path) -> list[str]:
    code = PROBE.format(args=", ".join(repr(a) for a in args))
    environment = {**os.environ, "PYTHONPATH": str(ROOT), **env}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd,
                          env=environment, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()[-4:]


def test_run_with_the_library_imports_no_numba(tmp_path: Path) -> None:
    # the buck: 20,800 steps, long enough that without the library the loop choice loads numba
    # (θ's C loop; the exact integrator's loop is numba's: pinned to θ)
    buck = pinned_copy(NETLISTS / "buck_converter.cir", tmp_path)
    args = ["run", str(buck), "-o", str(tmp_path / "out.csv"), "-q", "--signals", "v(out)"]
    code, calls, loaded, numba = probe(args, {}, tmp_path)
    assert (code, loaded, numba) == ("0", "True", "False") and int(calls) > 0
    code, calls, loaded, _ = probe(args, {native.DISABLE_ENV: "0"}, tmp_path)
    assert (code, calls, loaded) == ("0", "0", "False")


def test_a_netlist_of_ideal_diodes_imports_no_smooth_device_module(tmp_path: Path) -> None:
    # every D line went through the smooth devices' reader, which imports the BJT's and the
    # JFET's modules: 15 ms of every run's start; a D line now reaches it only when its model
    # is a Shockley diode (smooth=1)
    code = ("import sys\nfrom circuitnsds.cli.main import main\n"
            f"status = main(['run', {str(NETLISTS / 'bridge_rectifier.cir')!r}, '-o', 'out.csv', '-q'])\n"
            "print(status, sorted(m for m in sys.modules if '.smooth' in m and 'elements' in m or "
            "m.endswith('smooth_devices')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split(maxsplit=1) == ["0", "[]\n"]
