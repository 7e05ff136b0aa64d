"""The choice between the Python and the compiled mode loop (circuitnsds/engine/loop_choice.py):
by a cost model of the steps left against loading numba, from counts only (never the clock),
so that the same run makes the same choice however busy the machine is."""

from __future__ import annotations

import time

import pytest

from circuitnsds.engine import loop_choice
from circuitnsds.engine.loop_choice import FIRST_CHUNK, LoopChoice


@pytest.fixture
def fresh_process(monkeypatch, tmp_path):
    """numba installed and the loop cached for this source, but not loaded in the process."""
    marker = tmp_path / "ready"
    marker.touch()
    monkeypatch.setattr(loop_choice.dense_loop, "compiled_loaded", lambda: False)
    monkeypatch.setattr(loop_choice, "numba_available", lambda: True)
    monkeypatch.setattr(loop_choice, "ready_marker", lambda: marker)
    monkeypatch.setattr(loop_choice, "start_warmup", lambda: pytest.fail("nothing to compile"))


def run(choice: LoopChoice, steps: int, searches_per_step: float) -> tuple[int | None, list[int]]:
    """Drive ``choice`` as the integrator does over a run of ``steps`` mapped steps; returns the
    step at which it went compiled (None: never) and the Python chunks it asked for."""
    done, chunks = 0, []
    while done < steps:
        if choice.compiled(done, steps - done):
            return done, chunks
        chunk = min(choice.python_chunk(), steps - done)
        chunks.append(chunk)
        choice.record(False, chunk, round(chunk * searches_per_step))
        done += chunk
    return None, chunks


def test_short_cheap_run_stays_in_python(fresh_process):
    # the bundled bridge rectifier: 5,000 steps of a 5-unknown circuit, no searches
    assert run(LoopChoice(None, unknowns=5), 5_000, 0.0)[0] is None


def test_long_run_goes_compiled_at_once(fresh_process):
    # the million-step buck converter: sure to pay before any Python step
    assert run(LoopChoice(None, unknowns=8), 1_040_000, 0.0)[0] == 0


def test_expensive_python_steps_go_compiled(fresh_process):
    # 20,000 steps of the RF multiplier: few steps, but a mode search every fifth step
    # (~75 µs per Python step); after the first chunk the steps left are worth the load
    assert run(LoopChoice(None, unknowns=16), 20_000, 0.2)[0] == FIRST_CHUNK
    # the same steps without searches: not worth it
    assert run(LoopChoice(None, unknowns=16), 20_000, 0.0)[0] is None
    # a peak-current XSPICE buck: 5 watched switches over 40 unknowns, 30,300 steps
    assert run(LoopChoice(None, unknowns=40, watched=5), 30_300, 0.0)[0] == 0


def test_choice_ignores_the_clock(fresh_process, monkeypatch):
    """The same counts give the same decisions and chunks whatever the time measured."""
    quiet = run(LoopChoice(None, unknowns=16), 20_000, 0.01)
    clock = iter(range(0, 10**9, 10**6))
    monkeypatch.setattr(time, "perf_counter", lambda: float(next(clock)))  # a very slow machine
    monkeypatch.setattr(time, "process_time", lambda: float(next(clock)))
    assert run(LoopChoice(None, unknowns=16), 20_000, 0.01) == quiet


def test_saving_is_the_modelled_python_cost():
    choice = LoopChoice(None, unknowns=10, watched=2)
    step = loop_choice.python_step_us(10, 2)
    assert step == pytest.approx(loop_choice.STEP_US + 20 * loop_choice.SWITCH_TERM_US)
    assert choice.saving(0, 1000) == pytest.approx(1000 * (step - loop_choice.COMPILED_STEP_US))
    choice.record(False, 800, 80)  # 800 mapped of 1,000 steps done, a search every 10th
    expected = 0.8 * 10_000 * (step - loop_choice.COMPILED_STEP_US + 0.1 * loop_choice.SEARCH_US)
    assert choice.saving(1000, 10_000) == pytest.approx(expected)
    choice.record(True, 5_000, 500)  # compiled calls do not count
    assert choice.saving(1000, 10_000) == pytest.approx(expected)


def test_forced_modes(fresh_process):
    assert LoopChoice(True).compiled(0, 1)
    assert not LoopChoice(False).compiled(0, 10**9)
