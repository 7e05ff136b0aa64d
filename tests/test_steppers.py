"""The stepper contract (issue 30): steppers chosen by name, one driver handing every part of
a run to a recorder, and the run-time observers the devices declare."""

from __future__ import annotations

import math

import numpy as np
import pytest

import circuitnsds
import circuitnsds.analyses.recorders as recorders
from circuitnsds.circuit.elements.passive import Resistor
from circuitnsds.engine import stepper as steppers
from circuitnsds.engine.driver import drive
from circuitnsds.engine.integrate import Trajectory
from circuitnsds.engine.stepper import StartState, Stepper
from circuitnsds.engine.theta_stepper import ThetaStepper
from circuitnsds.engine.timegrid import time_grid
from tests.conftest import NETLISTS

TAU = 1e-3
RC_STEP = """RC charged by a step at 0.2 ms (tau = 1 ms)
V1 in 0 PULSE(0 1 0.2m 1n 1n 10 20)
R1 in out 1k
C1 out 0 1u
.tran 0.1m 3m
.end
"""


def _refined(grid: np.ndarray) -> np.ndarray:
    """``grid`` with the midpoint of every step inserted."""
    fine = np.empty(2 * grid.size - 1)
    fine[0::2] = grid
    fine[1::2] = 0.5 * (grid[:-1] + grid[1:])
    return fine


class RefinedTheta(Stepper):
    """A stepper of this test's own (a new module plus one registration line): the θ-method
    on a grid twice as fine, reporting the state at the output grid's points only (a stepper
    owns its steps between grid points)."""

    name = "refined"

    def __init__(self, mlcs, *, theta: float = 1.0, tol: float = 1e-9, loop: str = "auto"):
        super().__init__(mlcs)
        self.inner = ThetaStepper(mlcs, theta=theta, tol=tol, loop=loop)

    def begin(self, grid, *, parts):
        self.inner.begin(_refined(grid), parts=parts)

    def advance(self, grid, start, *, continued, progress=None):
        fine = self.inner.advance(_refined(grid), start, continued=continued, progress=progress)
        impulse = fine.impulse[0::2].copy()
        impulse[1:] += fine.impulse[1::2]
        return Trajectory(fine.time[0::2].copy(), fine.y[0::2].copy(), fine.current[0::2].copy(),
                          impulse, np.maximum(fine.residual[0::2], np.r_[0.0, fine.residual[1::2]]),
                          fine.active[0::2].copy(), fine.switches[0::2].copy(),
                          dict(fine.stats, steps=grid.size - 1), list(fine.events), {})

    def trajectory_bytes(self, points):
        return self.inner.trajectory_bytes(2 * points)


@pytest.fixture
def refined_registered(monkeypatch):
    monkeypatch.setitem(steppers.STEPPERS, "refined", "tests.test_steppers:RefinedTheta")


def _charging_error(waves) -> float:
    t = np.asarray(waves.time)
    after = t >= 0.2e-3 + 1e-9
    exact = 1.0 - np.exp(-(t[after] - 0.2e-3 - 1e-9) / TAU)
    return float(np.abs(np.asarray(waves["v(out)"])[after] - exact).max())


def test_a_registered_stepper_is_chosen_by_name_in_the_api_and_the_netlist(refined_registered):
    circuit = circuitnsds.read_netlist(RC_STEP)
    theta = circuit.transient(method="theta")  # (the θ-method's error, pinned: the default may be auto)
    refined = circuit.transient(method="refined")
    np.testing.assert_array_equal(refined.time, theta.time)  # the output grid is the driver's
    # implicit Euler's error is first order: half the step, about half the error
    assert 0.01 < _charging_error(theta) < 0.03  # (h/2τ · max of t/τ·e^(-t/τ): 0.018)
    assert _charging_error(refined) < 0.6 * _charging_error(theta)
    by_option = circuitnsds.read_netlist(RC_STEP.replace(".end", ".options method=refined\n.end"))
    np.testing.assert_array_equal(by_option.transient()["v(out)"], refined["v(out)"])
    assert math.isclose(_charging_error(by_option.transient(method="theta")), _charging_error(theta))


def test_a_new_stepper_cut_in_parts_gives_its_run_in_one_part(refined_registered, monkeypatch):
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    whole = circuit.transient(stop=0.1e-3, method="refined")
    monkeypatch.setattr(recorders, "segment_steps", lambda mlcs: 97)
    kept = circuit.transient(stop=0.1e-3, method="refined", signals=["v(out)", "i(l1)"])
    for name in kept.names:
        np.testing.assert_array_equal(kept[name], whole[name])


def test_an_unknown_method_is_an_error_naming_the_known_ones():
    circuit = circuitnsds.read_netlist(RC_STEP)
    with pytest.raises(circuitnsds.CircuitError, match=r"unknown integration method 'euler': "
                       r"the methods are auto, exact, newton, theta"):
        circuit.transient(method="euler")
    by_option = circuitnsds.read_netlist(RC_STEP.replace(".end", ".options method=euler\n.end"))
    with pytest.raises(circuitnsds.CircuitError, match=r"unknown integration method 'euler'"):
        by_option.transient()


class NoPairs(RefinedTheta):
    """A stepper that integrates only systems without complementarity pairs."""

    name = "nopairs"

    @classmethod
    def unsuited(cls, mlcs):
        return f"it has {mlcs.m} complementarity pairs" if mlcs.m else None


def test_a_stepper_that_cannot_run_the_circuit_says_why(monkeypatch):
    monkeypatch.setitem(steppers.STEPPERS, "nopairs", "tests.test_steppers:NoPairs")
    assert circuitnsds.read_netlist(RC_STEP).transient(method="nopairs").time.size > 10
    buck = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    with pytest.raises(circuitnsds.CircuitError, match=r"the integration method 'nopairs' cannot run "
                       r"this circuit: it has 1 complementarity pairs"):
        buck.transient(stop=1e-5, method="nopairs")


def test_ngspices_methods_are_ignored_with_a_warning():
    plain = circuitnsds.read_netlist(RC_STEP).transient()
    with pytest.warns(Warning, match=r"\.options method=gear ignored"):
        gear = circuitnsds.read_netlist(RC_STEP.replace(".end", ".options method=gear\n.end"))
    np.testing.assert_array_equal(gear.transient()["v(out)"], plain["v(out)"])


class _Parts:
    """A recorder keeping a copy of every part and its first new row."""

    def __init__(self):
        self.firsts: list[int] = []
        self.y: list[np.ndarray] = []
        self.time: list[np.ndarray] = []

    def record(self, trajectory, first):
        self.firsts.append(first)
        self.y.append(trajectory.y[first:].copy())
        self.time.append(trajectory.time[first:].copy())


def test_the_driver_hands_every_part_to_the_recorder_with_one_runs_numbers():
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    spec = circuitnsds.analyses.transient.transient_spec(circuit, stop=0.2e-3, theta=0.5)
    mlcs = circuit.mlcs(spec.source_defaults)
    grid = time_grid(spec.grid_step, spec.stop, mlcs.breakpoints(spec.stop))
    start = StartState(np.zeros(mlcs.n))
    one, parts = _Parts(), _Parts()
    drive(ThetaStepper(mlcs, theta=0.5), grid, start, one)
    drive(ThetaStepper(mlcs, theta=0.5), grid, start, parts, part_steps=300)
    assert one.firsts == [0]
    assert len(parts.firsts) == math.ceil((grid.size - 1) / 300) and parts.firsts[1:] == [1] * (
        len(parts.firsts) - 1)
    np.testing.assert_array_equal(np.concatenate(parts.time), grid)
    np.testing.assert_array_equal(np.concatenate(parts.y), one.y[0])


class _Counting:
    """An observer counting the steps it was shown and how often it reported."""

    made: list[_Counting] = []

    def __init__(self, circuit, elements):
        self.elements, self.steps, self.reports = elements, 0, 0
        _Counting.made.append(self)

    def observe(self, mlcs, trajectory, first):
        self.steps += trajectory.time.size - 1

    def report(self):
        self.reports += 1


@pytest.mark.parametrize("signals", [None, ["v(out)"]])
def test_the_observers_a_device_declares_see_every_step_of_a_run(monkeypatch, signals):
    monkeypatch.setattr(Resistor, "run_observers", (_Counting,))
    monkeypatch.setattr(recorders, "segment_steps", lambda mlcs: 250)
    _Counting.made.clear()
    circuit = circuitnsds.read_netlist(NETLISTS / "buck_converter.cir")
    waves = circuit.transient(stop=0.1e-3, signals=signals)
    [observer] = _Counting.made  # one per run, with every resistor that declared it
    assert sorted(e.name for e in observer.elements) == sorted(
        e.name for e in circuit.elements if isinstance(e, Resistor))
    assert observer.steps == waves.stats["steps"] > 250
    assert observer.reports == 1
