"""A trajectory together with each step's affine map on the state (docs/pss.md).

:meth:`StepMapper.run` integrates an MLCS over a grid with full complementarity
(:func:`circuitnsds.engine.integrate.integrate`), then rebuilds, for the mode each
step took (active set, switch states, step size), that mode's step map
(:meth:`circuitnsds.engine.integrate.GridStepping.build_mode`, the same map the
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

A step split at located switchings of circuit-controlled switches
(:meth:`circuitnsds.engine.integrate.GridStepping.split_step`) is taken in parts: part ``i``
of length ``σ_i = T_i − T_{i−1}`` (``T_0 = t_k``, the last part ends at ``t_{k+1}``) in its
own switch states and active set solves the fixed-mode θ = 1 step system

    K_i(σ_i) [y_i; λ_i] = [E y_{i−1}/σ_i + S f(T_i); −e_α],   K_i(σ) = [[E/σ − A, −B_α], [C_α, D_αα]]

and an inner instant ``T_i`` is where the switch's control ``c·y_i − threshold`` is 0. The
map of the whole step then depends on ``x_k`` also through the instants: its exact
Jacobian (:func:`split_map`) is built part by part, carrying ``J = ∂y_{i−1}/∂(x_k, δf)``
and ``∂T_{i−1}/∂(x_k, δf)``. Differentiating ``K_i s = r`` (``s = [y_i; λ_i]``):

    ∂s/∂T_i     =  K_i⁻¹ [E (y_i − y_{i−1})/σ_i² + S ḟ(T_i); 0]   (= v_i)
    ∂s/∂T_{i−1} = −K_i⁻¹ [E (y_i − y_{i−1})/σ_i²; 0]
    ∂s/∂y_{i−1} =  K_i⁻¹ [E/σ_i; 0],   ∂s/∂f(T_i) = K_i⁻¹ [S; 0]

and, at a located instant, ``c·y_i(T_i) = threshold`` gives
``∂T_i = −c·(∂y_i with T_i held) / (c·v_i)``: the switching-instant sensitivity, whose
product with ``v_i`` is the saltation term (the difference of the two modes' vector
fields at the instant, in the discrete system). ``ḟ`` is the sources' slope, a central
difference of their time functions over 1e-6 of the step (exact on a PULSE's linear
segments). The sources enter each part at its end instant ``T_i``
(:meth:`StepMaps.input_terms`): a sine injected into a source is sampled there, as the
transient does.

With θ < 1 the step also carries ``(1-θ)·A y_k`` on the differential rows, which
involves algebraic unknowns: the map on the state alone does not exist, and
:class:`StepMapper` refuses θ ≠ 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from circuitnsds.engine.dense_loop import ModeMap
from circuitnsds.engine.integrate import GridStepping, SplitPart, Trajectory, integrate
from circuitnsds.errors import SimulationError
from circuitnsds.system.mlcs import MLCS


def state_unknowns(mlcs: MLCS) -> np.ndarray:
    """Indices of the state unknowns: the columns of ``E`` holding a non-zero entry."""
    E = mlcs.E.tocsc()
    E.eliminate_zeros()
    return np.flatnonzero(np.diff(E.indptr) > 0).astype(np.int64)


@dataclass
class SplitMap:
    """The exact linearisation of one step split at located switchings (:func:`split_map`).

    Attributes:
        Y: ``(n + a, state)``, ``∂[y_{k+1}; λ_α]/∂x_k`` including the instants' sensitivity.
        g: ``[y_{k+1}; λ_α] − Y x_k`` at the run's values.
        inputs: ``(T_i, G_i)`` per part: ``G_i = ∂[y_{k+1}; λ_α]/∂f(T_i)``, ``(n + a, sources)``.
        active: the active pairs of the last part (the ``λ_α`` rows).
        instants: ``(T_i, ∂T_i/∂x_k)`` of each located switching in the step.
    """

    Y: np.ndarray
    g: np.ndarray
    inputs: list[tuple[float, np.ndarray]]
    active: np.ndarray
    instants: list[tuple[float, np.ndarray]]


def _source_slope(stepping: GridStepping, t: float, h: float) -> np.ndarray:
    """Every source's time derivative at ``t`` [unit/s]: a central difference over ``1e-6·h``."""
    d = 1e-6 * h
    return (stepping.source_at(t + d) - stepping.source_at(t - d)) / (2 * d)


def split_map(stepping: GridStepping, k: int, parts: list[SplitPart], state: np.ndarray) -> SplitMap:
    """The exact Jacobian of step ``k`` taken in ``parts`` (module docstring), with respect to
    the state at its start and to the sources' values at each part's end.

    Raises:
        SimulationError: a part's step matrix is singular, or a control touches its
            threshold without crossing it (``c·v = 0``: the instant has no derivative).
    """
    mlcs = stepping.mlcs
    n, sources = mlcs.n, len(mlcs.stimuli)
    t_k = float(stepping.grid[k])
    h = float(stepping.grid[k + 1]) - t_k
    size = state.size
    columns = size + len(parts) * sources
    J = np.zeros((n, columns))
    J[state, np.arange(size)] = 1.0  # E y_k depends on the state only
    d_start = np.zeros(columns)
    ends, instants = [], []
    for i, part in enumerate(parts):
        if part.theta != 1.0:
            raise ValueError("split step maps need implicit Euler parts (theta = 1)")
        mode = stepping.dense_pieces(part.states, part.active, 1.0)
        sigma, a = part.length, mode.act.size
        K = mode.bordered.copy()
        K[:n, :n] = mode.E / sigma - mode.A
        moved = mode.E @ (part.u - part.y_start) / sigma**2
        end_time = t_k + part.start + sigma
        rhs = np.zeros((n + a, columns))
        rhs[:n] = mode.E @ J / sigma - np.outer(moved, d_start)
        own = slice(size + i * sources, size + (i + 1) * sources)
        rhs[:n, own] += mode.S
        try:
            d = np.linalg.solve(K, rhs)
            if part.row >= 0:
                slope = np.zeros(n + a)
                slope[:n] = moved + mode.S @ _source_slope(stepping, end_time, h)
                v = np.linalg.solve(K, slope)
        except np.linalg.LinAlgError:
            raise SimulationError(
                f"the part of the step from t = {t_k + part.start:.9g} s to {end_time:.9g} s has a "
                "singular step matrix in the mode it took, so it has no step map",
                where=f"t = {end_time:.9g} s", time=end_time,
                cause=SimulationError.STEP_MAP_SINGULAR) from None
        if part.row >= 0:
            control = stepping.free_controls[part.row]
            rate = float(control @ v[:n])
            if not abs(rate) > 1e-12 * (np.abs(control) @ np.abs(v[:n]) + 1e-300):
                name = mlcs.switches[int(stepping.free[part.row])].name
                raise SimulationError(
                    f"the control of switch {name} touches its threshold at t = {end_time:.9g} s "
                    "without crossing it: the switching instant has no derivative",
                    where=f"t = {end_time:.9g} s", time=end_time)
            d_start = -(control @ d[:n]) / rate
            d += np.outer(v, d_start)
            instants.append((end_time, d_start[:size].copy()))
        else:
            d_start = np.zeros(columns)
        J = d[:n]
        ends.append(end_time)
    last = parts[-1]
    act = stepping.dense_pieces(last.states, last.active, 1.0).act
    Y = d[:, :size]
    inputs = [(end, d[:, size + i * sources:size + (i + 1) * sources]) for i, end in enumerate(ends)]
    values = np.concatenate([last.u, last.z[act]])
    g = values - Y @ parts[0].y_start[state]
    return SplitMap(Y, g, inputs, act, instants)


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
        splits: the steps split at located switchings and their exact maps (their
            ``mode_of_step`` is -1).
    """

    trajectory: Trajectory
    state: np.ndarray
    modes: list[ModeMap]
    mode_of_step: np.ndarray
    keys: list[bytes]
    sources: np.ndarray
    splits: dict[int, SplitMap]

    @property
    def steps(self) -> int:
        return int(self.mode_of_step.size)

    def full_map(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(Y, g)`` with ``[y_{k+1}; λ_α] = Y x_k + g`` (every unknown after step ``k``
        and the active pairs' currents [A], from the state before it; for a split step the
        linearisation at the run, :class:`SplitMap`)."""
        split = self.splits.get(k)
        if split is not None:
            return split.Y, split.g
        mode = self.modes[self.mode_of_step[k]]
        g = mode.Q1 @ self.sources[k + 1] + mode.Q0 @ self.sources[k] + mode.c
        return mode.P[:, self.state], g

    def step(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(M_k, b_k)``: ``x_{k+1} = M_k x_k + b_k`` on the state."""
        Y, g = self.full_map(k)
        return Y[self.state], g[self.state]

    def input_terms(self, k: int) -> list[tuple[float, np.ndarray]]:
        """``(t, G)`` pairs: ``[y_{k+1}; λ_α]`` moves by ``G δf(t)`` with the sources' values
        ``δf`` at the instants ``t`` [s] (columns in ``MLCS.stimuli`` order): ``t_{k+1}`` and
        ``t_k`` (``Q1``, ``Q0``) for a whole step, each part's end for a split one."""
        split = self.splits.get(k)
        if split is not None:
            return split.inputs
        mode = self.modes[self.mode_of_step[k]]
        time = self.trajectory.time
        return [(float(time[k + 1]), mode.Q1), (float(time[k]), mode.Q0)]

    def active_pairs(self, k: int) -> np.ndarray:
        """Indices of the pairs whose currents follow ``y_{k+1}`` in :meth:`full_map`."""
        split = self.splits.get(k)
        return split.active if split is not None else self.modes[self.mode_of_step[k]].active

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
        splits = {k: split_map(stepping, k, parts, self.state)
                  for k, parts in stepping.splits.items()}
        for k in range(of_step.size):
            states, active = trajectory.switches[k + 1], trajectory.active[k + 1]
            key = np.int64(classes[k]).tobytes() + states.tobytes() + active.tobytes()
            if k in splits:  # its parts' modes (the instants move with the state)
                key += b"split" + b"".join(p.states.tobytes() + p.active.tobytes()
                                           for p in stepping.splits[k])
                keys.append(key)
                of_step[k] = -1
                continue
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
        return StepMaps(trajectory, self.state, modes, of_step, keys, stepping.sources, splits)

    def _build(self, stepping: GridStepping, k: int, cls: int, states: np.ndarray,
               active: np.ndarray) -> ModeMap:
        mode = stepping.build_mode(k, cls, states, active)
        if mode is None:
            t0, t1 = self.grid[k], self.grid[k + 1]
            raise SimulationError(
                f"the step from t = {t0:.6g} s to {t1:.6g} s has a singular step matrix in the "
                "mode it took, so it has no step map", where=f"t = {t1:.6g} s", time=float(t1),
                cause=SimulationError.STEP_MAP_SINGULAR)
        return mode
