"""A trajectory together with each step's affine map on the state (DESIGN.md §2, "Periodic
steady state").

:func:`run_with_maps` integrates an MLCS over a grid with full complementarity
(:func:`circuitnsds.engine.integrate.integrate`), then rebuilds, for the mode each
step took (active set, switch states, step size), that mode's step map
(:meth:`circuitnsds.engine.integrate._Stepping._build_mode`, the same map the
compiled loop applies). With implicit Euler (θ = 1) a step depends on the unknowns
``y_k`` only through the charges and fluxes ``E y_k``, so restricted to the *state*
``x = y[state]`` (the unknowns of the non-zero columns of ``E``: node voltages at
capacitors, inductor currents) it is affine:

    x_{k+1} = M_k x_k + b_k,      b_k = (Q1 f_{k+1} + Q0 f_k + c)[state]

and every other unknown follows from the state as ``y_{k+1} = Y_k x_k + g_k``
(:meth:`StepMaps.full_map`). Over the whole grid the composition is
``x_N = Φ x_0 + c`` with ``Φ = M_{N-1} ⋯ M_0`` (:meth:`StepMaps.composition`): the
exact Jacobian of the grid's end state with respect to the start state, for the
mode sequence this run visited.

Where ``E`` couples two nodes (a floating capacitor), both node voltages are state
unknowns while only their difference is stored; ``Φ`` then has an eigenvalue 0 in
the direction the step does not see, which is harmless.

With θ < 1 the step also carries ``(1-θ)·A y_k`` on the differential rows, which
involves algebraic unknowns: the map on the state alone does not exist, and
:func:`run_with_maps` refuses θ ≠ 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from circuitnsds.engine.dense_loop import ModeMap
from circuitnsds.engine.integrate import Trajectory, _Stepping, integrate
from circuitnsds.errors import SimulationError
from circuitnsds.system.mlcs import MLCS


def state_unknowns(mlcs: MLCS) -> np.ndarray:
    """Indices of the state unknowns: the columns of ``E`` holding a non-zero entry."""
    E = mlcs.E.tocsc()
    E.eliminate_zeros()
    return np.flatnonzero(np.diff(E.indptr) > 0).astype(np.int64)


@dataclass
class StepMaps:
    """A trajectory, its mode sequence and the step maps of that sequence.

    Attributes:
        trajectory: the run (:class:`~circuitnsds.engine.integrate.Trajectory`).
        state: indices of the state unknowns in ``y`` (see :func:`state_unknowns`).
        modes: the distinct modes' step maps (:class:`~circuitnsds.engine.dense_loop.ModeMap`:
            ``[y_{k+1}; λ_α] = P y_k + Q1 f_{k+1} + Q0 f_k + c``, ``λ_α`` the active pairs'
            currents [A]).
        mode_of_step: index in ``modes`` of each step's mode, shape ``(N - 1,)``.
        keys: each step's mode as bytes (step size class, switch states, active set):
            two runs visited the same mode sequence when their ``keys`` are equal.
        sources: every source's value at every grid point, shape ``(N, k)``.
    """

    trajectory: Trajectory
    state: np.ndarray
    modes: list[ModeMap]
    mode_of_step: np.ndarray
    keys: list[bytes]
    sources: np.ndarray

    @property
    def steps(self) -> int:
        return int(self.mode_of_step.size)

    def full_map(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(Y, g)`` with ``[y_{k+1}; λ_α] = Y x_k + g`` (every unknown after step ``k``
        and the active pairs' currents [A], from the state before it)."""
        mode = self.modes[self.mode_of_step[k]]
        g = mode.Q1 @ self.sources[k + 1] + mode.Q0 @ self.sources[k] + mode.c
        return mode.P[:, self.state], g

    def step(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(M_k, b_k)``: ``x_{k+1} = M_k x_k + b_k`` on the state."""
        Y, g = self.full_map(k)
        return Y[self.state], g[self.state]

    def input_map(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(Q1, Q0)`` restricted to the state rows: how ``x_{k+1}`` moves with the sources'
        values at ``t_{k+1}`` and ``t_k`` (columns in ``MLCS.stimuli`` order)."""
        mode = self.modes[self.mode_of_step[k]]
        return mode.Q1[self.state], mode.Q0[self.state]

    def composition(self, first: int = 0, last: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(Φ, c)`` with ``x_last = Φ x_first + c`` for the steps ``first .. last - 1``
        (default: the whole grid, ``Φ`` the monodromy matrix when the grid is one period)."""
        last = self.steps if last is None else last
        size = self.state.size
        phi, c = np.eye(size), np.zeros(size)
        for k in range(first, last):
            M, b = self.step(k)
            phi, c = M @ phi, M @ c + b
        return phi, c

    def map_error(self) -> float:
        """Largest difference between the run's states and the maps' prediction from each
        step's start, relative to the state's largest magnitude (rounding: ~1e-12)."""
        x = self.trajectory.y[:, self.state]
        worst = 0.0
        for k in range(self.steps):
            M, b = self.step(k)
            worst = max(worst, float(np.abs(M @ x[k] + b - x[k + 1]).max(initial=0.0)))
        return worst / max(float(np.abs(x).max(initial=0.0)), 1e-300)


class StepMapper:
    """Runs on one grid again and again (a shooting method), keeping the step solvers,
    the mode loop's table and the step maps of the modes seen between runs."""

    def __init__(self, mlcs: MLCS, grid: np.ndarray, *, theta: float = 1.0, tol: float = 1e-9,
                 stepping: str = "compiled"):
        if theta != 1.0:
            raise ValueError(f"step maps on the state need implicit Euler (theta = 1), got {theta}")
        self.mlcs, self.grid, self.tol, self.stepping = mlcs, np.asarray(grid, dtype=float), tol, stepping
        self.state = state_unknowns(mlcs)
        self.cache: dict = {}
        self.maps: dict[bytes, ModeMap] = {}

    def run(self, y0: np.ndarray, charge0: np.ndarray | None = None, active0: np.ndarray | None = None,
            switches0: np.ndarray | None = None) -> StepMaps:
        """Integrate from ``y0`` (arguments as for :func:`~circuitnsds.engine.integrate.integrate`)
        and return the run with its step maps."""
        trajectory = integrate(self.mlcs, self.grid, y0, charge0, None, active0, switches0,
                               tol=self.tol, stepping=self.stepping, cache=self.cache)
        stepping = self.cache["last"]
        classes = stepping.base_class  # θ = 1: a restart step has the map of its size's class
        index: dict[bytes, int] = {}
        modes: list[ModeMap] = []
        keys: list[bytes] = []
        of_step = np.empty(trajectory.time.size - 1, dtype=np.int64)
        for k in range(of_step.size):
            states, active = trajectory.switches[k + 1], trajectory.active[k + 1]
            key = np.int64(classes[k]).tobytes() + states.tobytes() + active.tobytes()
            keys.append(key)
            found = index.get(key)
            if found is None:
                mode = self.maps.get(key)
                if mode is None:
                    # the class integrate used (a θ = 1 restart step has its size's map): the
                    # map built for the mode table is then reused, not built twice
                    mode = self.maps[key] = self._build(stepping, k, int(stepping.step_class[k]),
                                                        states, active)
                found = index[key] = len(modes)
                modes.append(mode)
            of_step[k] = found
        return StepMaps(trajectory, self.state, modes, of_step, keys, stepping.sources)

    def _build(self, stepping: _Stepping, k: int, cls: int, states: np.ndarray,
               active: np.ndarray) -> ModeMap:
        mode = stepping._build_mode(k, cls, states, active)
        if mode is None:
            t0, t1 = self.grid[k], self.grid[k + 1]
            raise SimulationError(
                f"the step from t = {t0:.6g} s to {t1:.6g} s has a singular step matrix in the "
                "mode it took, so it has no step map", where=f"t = {t1:.6g} s", time=float(t1),
                cause=SimulationError.STEP_MAP_SINGULAR)
        return mode


def run_with_maps(
    mlcs: MLCS,
    grid: np.ndarray,
    y0: np.ndarray,
    charge0: np.ndarray | None = None,
    active0: np.ndarray | None = None,
    switches0: np.ndarray | None = None,
    *,
    theta: float = 1.0,
    tol: float = 1e-9,
    stepping: str = "compiled",
) -> StepMaps:
    """Integrate ``mlcs`` over ``grid`` from ``y0`` (arguments as for
    :func:`~circuitnsds.engine.integrate.integrate`) and return the run with its step maps
    (one run; :class:`StepMapper` keeps what it built for the next).

    Raises:
        ValueError: ``theta`` is not 1 (see module docstring).
        SimulationError: from the integration, or a visited mode whose step matrix is
            singular (no map: it names the step).
    """
    return StepMapper(mlcs, grid, theta=theta, tol=tol, stepping=stepping).run(
        y0, charge0, active0, switches0)
