"""One step (or the DC point) of an MLCS with smooth relations: a mixed *nonlinear*
complementarity problem, solved by Newton–Josephy (DESIGN.md, "Smooth nonlinear elements
beside the ideal ones").

With the smooth relations ``F(y, t) = Σ_r P_r f_r(x_r, t)`` and charges
``Q(y) = Σ_r P_r q_r(x_r)`` (:mod:`circuitnsds.system.smooth`), the θ-step of
:mod:`circuitnsds.engine.step_system` (rows divided by ``h``, pair unknowns the currents
``λ``) becomes

    G(y, λ) = (E y + Q(y))/h − Θ(A y + S f_{k+1} − F(y, t_{k+1})) − c_k − B λ = 0
    c_k     = (E y_k + Q(y_k))/h + (I − Θ)(A y_k + S f_k − F(y_k, t_k))
    w = C y + D λ + e,     0 ≤ w ⊥ λ ≥ 0

Newton–Josephy linearises ``F`` and ``Q`` at the iterate (each relation at its own point
``x̂_r``, which junction limiting may hold back from the iterate's ``x_r``, as SPICE's
``pnjlim`` does) and solves the *linear* MLCP that results with the project's solver
(:class:`~circuitnsds.solvers.MLCPSolver`, warm-started from the last active set):

    K y − B λ = r,    K = (E + J_Q)/h − Θ(A − J_F),
    r = c_k − (Q̂ − J_Q x̂)/h + Θ(S f_{k+1} − (F̂ − J_F x̂))

An iterate where a relation cannot be evaluated (an overflowing ``exp``) is damped: the
update is halved until it can. The iteration stops when the update is below
``reltol·|y| + atol`` (SPICE's test: ``atol`` 1 µV on node voltages, 1 nA on currents), the
active set repeats, and each relation's value at the new iterate agrees with its
linearisation to ``reltol`` (SPICE's device convergence test); each iterate already holds
the complementarity of its linear MLCP exactly, so what is left at convergence is this
linearisation error. The DC point is the same problem without the ``1/h`` terms and with
``Θ = I`` (:func:`newton_solve` with ``h = inf``).

This module knows nothing about circuits: it takes an :class:`MLCS` and arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from circuitnsds.solvers import LCPError, MLCPSolver
from circuitnsds.system.mlcs import MLCS

RELTOL = 1e-4
"""Relative tolerance of the update and of the relations' linearisation error."""
VOLTAGE_ATOL = 1e-6
"""Absolute tolerance of the update on node voltages [V] (SPICE's ``vntol``)."""
CURRENT_ATOL = 1e-9
"""Absolute tolerance of the update on currents and other unknowns [A]."""
RELATION_ATOL = 1e-9
"""Absolute tolerance of a relation's linearisation error [A, or V on a branch row]."""
MAX_ITERATIONS = 50
"""Newton iterations at most before the step is called unconverged."""
MAX_DAMPING = 30
"""Halvings of an update at most while a relation cannot be evaluated there."""


class NewtonFailure(Exception):
    """A step's Newton iteration did not converge (the caller shortens the step, or tries
    another continuation at DC).

    Attributes:
        reason: in words; iterations: how many were made.
    """

    def __init__(self, reason: str, iterations: int):
        super().__init__(reason)
        self.reason = reason
        self.iterations = iterations


@dataclass
class Linearisation:
    """The smooth relations' sum at one point, over the whole ``y``.

    Attributes:
        F, JF: ``F̂ − J_F x̂`` scattered on the rows, and ``J_F`` over ``y`` (``(n,)``, ``(n, n)``).
        Q, JQ: the same for the charges.
        values: each relation's ``f`` at its point (for the convergence test).
        points: each relation's point ``x̂``.
    """

    F: np.ndarray
    JF: np.ndarray
    Q: np.ndarray
    JQ: np.ndarray
    values: list[np.ndarray] = field(default_factory=list)
    points: list[np.ndarray] = field(default_factory=list)
    derivatives: list[np.ndarray] = field(default_factory=list)


class SmoothParts:
    """The smooth relations of an MLCS, gathered for assembly into dense matrices of
    ``size`` rows and columns (default ``mlcs.n``; more when unknowns are appended after
    the MLCS's own, as the DC point's held nodes are)."""

    def __init__(self, mlcs: MLCS, size: int | None = None):
        self.n = mlcs.n if size is None else int(size)
        self.relations = list(mlcs.smooth)
        self.inputs = [np.asarray(r.inputs, dtype=int) for r in self.relations]
        self.rows = [np.asarray(r.rows, dtype=int) for r in self.relations]
        self.charges = any(r.charges for r in self.relations)
        # where each relation's values and derivatives go (ground rows and columns dropped)
        self._scatter = []
        for rows, columns in zip(self.rows, self.inputs):
            keep_rows, keep_columns = np.flatnonzero(rows >= 0), np.flatnonzero(columns >= 0)
            r, c = rows[keep_rows], columns[keep_columns]
            flat = (r[:, None] * self.n + c[None, :]).ravel()
            whole = keep_rows.size == rows.size and keep_columns.size == columns.size
            unique = np.unique(flat).size == flat.size and np.unique(r).size == r.size
            self._scatter.append((keep_rows, keep_columns, r, flat, whole, unique))

    def read(self, k: int, y: np.ndarray) -> np.ndarray:
        index = self.inputs[k]
        return np.where(index >= 0, y[np.maximum(index, 0)], 0.0) if index.size else np.zeros(0)

    def evaluate(self, y: np.ndarray, t: float, previous: Linearisation | None = None
                 ) -> Linearisation | None:
        """The relations linearised at ``y`` (each at its limited point when it limits and
        ``previous`` holds its last point); ``None`` when a value is not finite."""
        n = self.n
        F, JF = np.zeros(n), np.zeros((n, n))
        Q, JQ = np.zeros(n), np.zeros((n, n))
        values, points, derivatives = [], [], []
        for k, relation in enumerate(self.relations):
            x = self.read(k, y)
            if relation.limit is not None and previous is not None:
                x = np.asarray(relation.limit(x, previous.points[k]), dtype=float)
            try:
                f, df, q, dq = relation.evaluate(x, t)
            except OverflowError:  # math.exp of a huge iterate: not finite, damped as such
                return None
            f, df = np.asarray(f, dtype=float), np.asarray(df, dtype=float)
            if not (np.isfinite(f).all() and np.isfinite(df).all()):
                return None
            keep_rows, keep_columns, r, flat, whole, unique = self._scatter[k]
            constant = f - df @ x
            block = df if whole else df[np.ix_(keep_rows, keep_columns)]
            if unique:
                F[r] += constant if whole else constant[keep_rows]
                JF.flat[flat] += block.ravel()
            else:
                np.add.at(F, r, constant[keep_rows])
                np.add.at(JF.ravel(), flat, block.ravel())
            if relation.charges:
                q, dq = np.asarray(q, dtype=float), np.asarray(dq, dtype=float)
                if not (np.isfinite(q).all() and np.isfinite(dq).all()):
                    return None
                np.add.at(Q, r, (q - dq @ x)[keep_rows])
                np.add.at(JQ.ravel(), flat, dq[np.ix_(keep_rows, keep_columns)].ravel())
            values.append(f)
            points.append(x)
            derivatives.append(df)
        return Linearisation(F, JF, Q, JQ, values, points, derivatives)

    def totals(self, y: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray] | None:
        """``F(y, t)`` and ``Q(y)`` themselves (not linearised); ``None`` when not finite."""
        lin = self.evaluate(y, t)
        if lin is None:
            return None
        return lin.F + lin.JF @ y, lin.Q + lin.JQ @ y

    def agrees(self, lin: Linearisation, y: np.ndarray, t: float) -> bool:
        """Whether each relation's value at ``y`` agrees with ``lin`` (its linearisation at
        the previous iterate) within the tolerances (SPICE's device convergence test)."""
        for k, relation in enumerate(self.relations):
            x = self.read(k, y)
            f = np.asarray(relation.evaluate(x, t)[0], dtype=float)
            predicted = lin.values[k] + lin.derivatives[k] @ (x - lin.points[k])
            scale = np.maximum(np.abs(f), np.abs(predicted))
            if not (np.abs(f - predicted) <= RELTOL * scale + RELATION_ATOL).all():
                return False
        return True


@dataclass
class NewtonResult:
    """A converged step: unknowns ``y``, pair currents ``z`` [A], the active set, the
    iterations made and the linear MLCPs solved by a fallback (not by mode reuse)."""

    y: np.ndarray
    z: np.ndarray
    active: np.ndarray
    iterations: int
    fallbacks: int


SIGN_TOLERANCE = 1e-10
"""Relative tolerance of the signs a guessed active set must give (``λ ≥ 0`` on the active
pairs, ``w ≥ 0`` on the others) for :func:`_mode_solution` to accept it."""


@dataclass
class ModeSolution:
    """What :func:`_mode_solution` gives: the fields of an MLCP result a Newton step reads."""

    u: np.ndarray
    z: np.ndarray
    active: np.ndarray


MODE_CACHE = 64
"""How many active sets keep their bordered matrix's pair blocks (:func:`_mode_solution`)."""


def _mode_solution(K: np.ndarray, r: np.ndarray, blocks, active: np.ndarray,
                   cache: dict | None = None) -> ModeSolution | None:
    """The linear MLCP's solution when the active set ``active`` is right (one dense solve of
    its bordered system ``[[K, −B_α], [C_α, D_αα]]``), else ``None`` (the full solver
    decides): the warm start of every Newton iteration. ``cache`` keeps each active set's
    pair blocks (they do not change from one iteration or step to the next, ``K`` does)."""
    B, C, D, e = blocks
    n = K.shape[0]
    active = np.asarray(active, dtype=bool)
    key = active.tobytes()
    entry = cache.get(key) if cache is not None else None
    if entry is None:
        act, inactive = np.flatnonzero(active), np.flatnonzero(~active)
        template = np.zeros((n + act.size, n + act.size))
        template[:n, n:] = -B[:, act]
        template[n:, :n] = C[act]
        template[n:, n:] = D[np.ix_(act, act)]
        entry = (act, template, -e[act], C[inactive], D[np.ix_(inactive, act)], e[inactive])
        if cache is not None:
            if len(cache) >= MODE_CACHE:
                cache.pop(next(iter(cache)))
            cache[key] = entry
    act, template, pair_rhs, C_in, D_in, e_in = entry
    matrix = template.copy()
    matrix[:n, :n] = K
    rhs = np.concatenate([r, pair_rhs]) if act.size else r
    try:
        solution = np.linalg.solve(matrix, rhs)
    except np.linalg.LinAlgError:
        return None
    if not np.isfinite(solution).all():
        return None
    y, z = solution[:n], np.zeros(e.size)
    z[act] = solution[n:]
    if e.size:
        scale = SIGN_TOLERANCE * (1.0 + float(np.abs(solution).max()))
        if (solution[n:] < -scale).any() or (C_in @ y + D_in @ solution[n:] + e_in < -scale).any():
            return None
    return ModeSolution(y, z, active.copy())


def update_tolerance(mlcs: MLCS) -> np.ndarray:
    """``atol`` of each unknown: :data:`VOLTAGE_ATOL` on node voltages, else
    :data:`CURRENT_ATOL`."""
    atol = np.full(mlcs.n, CURRENT_ATOL)
    atol[[k for k, name in enumerate(mlcs.unknowns) if name.startswith("v(")]] = VOLTAGE_ATOL
    return atol


def newton_solve(parts: SmoothParts, base: np.ndarray, rhs: np.ndarray, weights: np.ndarray,
                 h: float, t: float, y0: np.ndarray, guess: np.ndarray | None,
                 blocks: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], atol: np.ndarray,
                 tol: float = 1e-9, cache: dict | None = None) -> NewtonResult:
    """Solve ``G(y, λ) = 0`` with complementarity (module docstring) from ``y0``.

    Args:
        parts: the smooth relations.
        base: ``E/h − ΘA`` (dense, ``(n, n)``; ``−A`` at DC).
        rhs: ``c_k + ΘS f_{k+1}`` (at DC: ``S f``), the part of ``r`` without the relations.
        weights: the diagonal of ``Θ``.
        h: the step [s] (``inf`` at DC: no charges).
        t: the time the relations are evaluated at [s] (``t_{k+1}``).
        y0: the first iterate; guess: the active set to try first (``None``: none).
        blocks: ``(B, C, D, e)`` of the pairs (dense).
        atol: the update's absolute tolerance per unknown.
        tol: the linear MLCP's residual tolerance.
        cache: kept between calls: each active set's pair blocks.

    Raises:
        NewtonFailure: no convergence in :data:`MAX_ITERATIONS`, a linear MLCP without a
            solution, or a relation that cannot be evaluated however damped.
    """
    B, C, D, e = blocks
    m = e.size
    dynamic = math.isfinite(h) and parts.charges
    y = np.array(y0, dtype=float)
    lin = parts.evaluate(y, t)
    if lin is None:
        raise NewtonFailure("a smooth relation cannot be evaluated at the first iterate", 0)
    active = np.zeros(m, dtype=bool) if guess is None else np.asarray(guess, dtype=bool).copy()
    previous_active = None
    fallbacks = 0
    for iteration in range(1, MAX_ITERATIONS + 1):
        K = base + weights[:, None] * lin.JF
        r = rhs - weights * lin.F
        if dynamic:
            K = K + lin.JQ / h
            r = r - lin.Q / h
        result = _mode_solution(K, r, blocks, active, cache)
        if result is None:
            try:
                solver = MLCPSolver(K, -B, C, D, tol=tol, cache_size=2)
                result = solver.solve(-r, e, active if m else None)
            except (LCPError, np.linalg.LinAlgError, ValueError) as exc:
                raise NewtonFailure(f"the linearised step has no solution ({exc})", iteration) from None
            fallbacks += 1
        step = np.asarray(result.u, dtype=float) - y
        y_new = y + step
        new_lin = parts.evaluate(y_new, t, lin)
        damping = 0
        while new_lin is None and damping < MAX_DAMPING:  # an exp() overflowed: back off
            step *= 0.5
            y_new = y + step
            new_lin = parts.evaluate(y_new, t, lin)
            damping += 1
        if new_lin is None:
            raise NewtonFailure("a smooth relation cannot be evaluated however the update is "
                                "damped", iteration)
        small = bool((np.abs(step) <= RELTOL * np.maximum(np.abs(y_new), np.abs(y)) + atol).all())
        active = np.asarray(result.active, dtype=bool)
        settled = previous_active is not None and np.array_equal(active, previous_active)
        if small and damping == 0 and (settled or m == 0) and parts.agrees(lin, y_new, t):
            return NewtonResult(y_new, np.asarray(result.z, dtype=float), active, iteration, fallbacks)
        previous_active = active
        y, lin = y_new, new_lin
    raise NewtonFailure(f"no convergence in {MAX_ITERATIONS} iterations", MAX_ITERATIONS)


def linearised(mlcs: MLCS, y: np.ndarray, t: float = 0.0) -> MLCS:
    """``mlcs`` with its smooth relations replaced by their linearisation at ``y`` (time
    ``t`` [s]): ``A − J_F`` and ``E + J_Q``, no smooth relations left (the constant terms
    ``F̂ − J_F x̂`` are dropped: what a small-signal analysis around ``y`` needs).

    Raises:
        ValueError: a relation cannot be evaluated at ``y``.
    """
    from dataclasses import replace

    from circuitnsds.system.triplets import Triplets

    lin = SmoothParts(mlcs).evaluate(np.asarray(y, dtype=float)[: mlcs.n], t)
    if lin is None:
        raise ValueError("a smooth relation cannot be evaluated at the point")

    def plus(matrix: Triplets, dense: np.ndarray, sign: float) -> Triplets:
        rows, cols = np.nonzero(dense)
        stamps = list(zip(matrix.rows.tolist(), matrix.cols.tolist(), matrix.values.tolist()))
        stamps += list(zip(rows.tolist(), cols.tolist(), (sign * dense[rows, cols]).tolist()))
        return Triplets.from_stamps(stamps, matrix.shape)

    return replace(mlcs, A=plus(mlcs.A, lin.JF, -1.0), E=plus(mlcs.E, lin.JQ, 1.0), smooth=[])
