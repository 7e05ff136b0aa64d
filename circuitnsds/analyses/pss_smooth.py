"""Periodic steady state through smooth nonlinear elements: shooting on the Newton stepper's
period map with a finite-difference monodromy matrix (docs/pss.md).

With smooth relations (a BJT, an ``exp()`` source) a step is no longer affine in the state,
so the period map has no product of step maps. Here the period map ``Φ(x)`` is one period of
the Newton stepper (:mod:`circuitnsds.engine.newton_stepper`) from the state ``x``: the
unknowns whose charge the step carries (``E y``: capacitor node voltages, inductor currents,
and the inputs of the smooth relations' charges), the switch states and active set carried
from the period's end. Newton on ``Φ(x) − x = 0`` takes its Jacobian by forward differences
of ``Φ``, one period per state column, each perturbation :data:`PERTURBATION` times the
state's size; the step is damped (halved while it does not lower the residual). A period
costs ``1 + len(x)`` runs per Newton step.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from circuitnsds.analyses.recorders import TrajectoryRecorder
from circuitnsds.analyses.signals import trajectory_waveforms
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.engine.driver import drive
from circuitnsds.engine.integrate import Trajectory
from circuitnsds.engine.newton_stepper import NewtonStepper
from circuitnsds.engine.stepper import StartState
from circuitnsds.errors import CircuitWarning, SimulationError
from circuitnsds.system.mlcs import MLCS

PERTURBATION = 1e-6
"""A finite-difference column perturbs its state by this fraction of the state's size (its
largest magnitude over the period, at least 1e-9 of the largest of all)."""
HALVINGS = 6
"""A damped Newton step is halved at most this many times while the residual does not fall."""


@dataclass
class _Period:
    """One run of the period map: its trajectory and the state at its start and end."""

    run: Trajectory
    x0: np.ndarray
    x1: np.ndarray


class SmoothShooter:
    """Newton on the Newton stepper's period map, its monodromy by finite differences."""

    def __init__(self, circuit: Circuit, mlcs: MLCS, grid: np.ndarray, period: float, tol: float):
        self.circuit, self.mlcs, self.grid, self.period, self.tol = circuit, mlcs, grid, period, tol
        self.state = NewtonStepper(mlcs).states  # the unknowns a step carries
        self.periods_run = 0
        self.iterations = 0
        self.history: list[float] = []

    def run_period(self, y: np.ndarray, active, switches, x: np.ndarray | None = None) -> _Period:
        """One period of the Newton stepper from ``y`` (its state replaced by ``x``)."""
        y = np.array(y, dtype=float)
        if x is not None:
            y[self.state] = x
        recorder = TrajectoryRecorder()
        drive(NewtonStepper(self.mlcs, lte=False), self.grid,
              StartState(y, None, None, active, switches), recorder)
        self.periods_run += 1
        run = recorder.trajectory
        return _Period(run, run.y[0, self.state].copy(), run.y[-1, self.state].copy())

    def relative(self, period: _Period) -> float:
        """``‖Φ(x) − x‖∞``, each component over its scale (as the affine shooting's)."""
        change = period.x1 - period.x0
        scale = self._scale(period)
        return float(np.abs(change / scale).max(initial=0.0))

    def _scale(self, period: _Period) -> np.ndarray:
        scale = np.abs(period.run.y[:, self.state]).max(axis=0)
        floor = 1e-9 * max(float(scale.max(initial=0.0)), 1e-30)
        return np.maximum(scale, floor)

    def monodromy(self, base: _Period, y: np.ndarray, active, switches) -> np.ndarray:
        """``∂Φ/∂x`` at ``base.x0`` by forward differences, one period per column."""
        size = self.state.size
        phi = np.zeros((size, size))
        scale = self._scale(base)
        for j in range(size):
            delta = PERTURBATION * max(scale[j], abs(base.x0[j]))
            x = base.x0.copy()
            x[j] += delta
            phi[:, j] = (self.run_period(y, active, switches, x).x1 - base.x1) / delta
        return phi

    def solve(self, y: np.ndarray, active, switches, max_iterations: int):
        """The settled period from ``y`` (a state near it), or :class:`SimulationError`."""
        from circuitnsds.analyses.pss import PSSResult

        current = self.run_period(y, active, switches)
        residual = self.relative(current)
        self.history.append(residual)
        phi = np.zeros((self.state.size, self.state.size))
        while residual > self.tol:
            if self.iterations >= max_iterations:
                raise SimulationError(
                    f"the periodic steady state was not found: finite-difference shooting on the "
                    f"Newton stepper did not settle in {max_iterations} steps; best relative "
                    f"residual {min(self.history):.2g} after {self.periods_run} periods run",
                    where=self.circuit.file,
                    hint="try more warm-up periods (periods_warmup, .pss TSTAB), a smaller step "
                    "(--step), or a tolerance above the best residual (--tol)")
            start = current.run.y[0].copy()
            active, switches = current.run.active[-1].copy(), current.run.switches[-1].copy()
            phi = self.monodromy(current, start, active, switches)
            try:
                step = np.linalg.solve(np.eye(self.state.size) - phi, current.x1 - current.x0)
            except np.linalg.LinAlgError:
                raise SimulationError(
                    "I − Φ is singular (a Floquet multiplier 1 in the finite-difference "
                    "monodromy): a state is not damped over a period", where=self.circuit.file,
                    hint="add the damping the real circuit has (a bleeder resistor, a series "
                    "resistance)") from None
            self.iterations += 1
            fraction = 1.0
            for _ in range(HALVINGS + 1):
                trial = self.run_period(start, active, switches, current.x0 + fraction * step)
                trial_residual = self.relative(trial)
                if trial_residual < residual:
                    break
                fraction /= 2.0
            current, residual = trial, trial_residual
            self.history.append(residual)
        if self.iterations == 0 and self.state.size:  # (the multipliers of the orbit found)
            phi = self.monodromy(current, current.run.y[0].copy(), active, switches)
        run = current.run
        run.y[0] = run.y[-1]  # the algebraic unknowns at t0: the period's end, the same instant
        run.current[0] = run.current[-1]
        waves = trajectory_waveforms(self.circuit, self.mlcs, run, run.time[0], run.time[-1],
                                     periodic=True)
        waves.stats.update(analysis="pss", iterations=self.iterations, stepper="newton",
                           shooting="finite-difference monodromy", periods_run=self.periods_run)
        multipliers = np.linalg.eigvals(phi) if phi.size else np.zeros(0)
        multipliers = multipliers[np.argsort(-np.abs(multipliers), kind="stable")]
        if multipliers.size and np.abs(multipliers).max() > 1.0:
            warnings.warn(CircuitWarning(
                f"{self.circuit.file}: the periodic solution found is not stable (largest Floquet "
                f"multiplier |λ| = {np.abs(multipliers).max():.6g} > 1, by finite differences): a "
                "transient would not settle to it"), stacklevel=5)
        return PSSResult(
            waveforms=waves, period=self.period, t0=float(run.time[0]),
            state_names=[self.mlcs.unknowns[j] for j in self.state], state=current.x0.copy(),
            iterations=self.iterations, residual=float(np.abs(current.x1 - current.x0).max(initial=0.0)),
            relative_residual=residual, monodromy=phi, multipliers=multipliers,
            history=list(self.history), mlcs=self.mlcs, periods_run=self.periods_run,
            shooting="the Newton stepper, finite-difference monodromy")
