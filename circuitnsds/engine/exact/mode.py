"""One mode of an MLCS reduced to its state equations (DESIGN.md "Event-driven exact
integration", step 1).

With the active pairs ``a`` and the switch states fixed, the MLCS is the linear DAE

    E y' = A y + B_a λ_a + S f(t),        0 = C_a y + D_aa λ_a + e_a

in ``z = [y; λ_a]``. The singular value decomposition ``E = U_1 Σ_1 V_1ᵀ`` (rank ``r``)
names the state ``x = V_1ᵀ y`` (``E y = U_1 Σ_1 x``: charges and fluxes, continuous while
no impulse acts, the same coordinates in every mode); the other rows are algebraic and,
for an index-1 mode, give ``z`` from ``x`` and the sources:

    z = P x + Q φ,      x' = F x + H φ,      φ = [S f(t); e_a].

A mode whose algebraic block is singular (a capacitor closed across a source by a
conducting diode: index 2) is :class:`NotIndexOne`; so is one whose ``F`` is not
diagonalisable to a reasonable condition: the θ-method takes those stretches.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from circuitnsds.engine.exact.exppoly import ExpPoly, response
from circuitnsds.solvers.pencil import pencil_eigen

FAST_DECAY = 1e15
"""[1/s] A mode decaying faster than this (``Re λ < −FAST_DECAY``: e^-1000 after a picosecond)
is a parasitic one: a blocked diode's 1e-12 S or an open switch's 1e-9 S against an
inductance (a transformer's leakage behind blocked diodes: −1.8e17 /s). Its homogeneous part
is left out of a segment's solution (it is gone after a femtosecond: at the segment's start it
holds only the round-off of the state along it), and so is its amplification of that
round-off from the event functions' tolerances (:meth:`.run.ExactSystem.event_functions`):
taking it in, the bridge's blocked diodes had a tolerance of 1.4 V and a forward bias of
0.6 V went unseen."""


class NotIndexOne(Exception):
    """The mode cannot be reduced to state equations (index 2 or a defective ``F``)."""


@dataclass(frozen=True)
class StateCoordinates:
    """``x = V1ᵀ y`` from ``E = U Σ Vᵀ`` (shared by every mode of one MLCS)."""

    U1: np.ndarray
    U2: np.ndarray
    V1: np.ndarray
    V2: np.ndarray
    sigma: np.ndarray

    @classmethod
    def of(cls, E: np.ndarray) -> StateCoordinates:
        U, sigma, Vt = np.linalg.svd(E)
        rank = int(np.sum(sigma > sigma[0] * 1e-13)) if sigma.size and sigma[0] > 0 else 0
        return cls(U[:, :rank], U[:, rank:], Vt[:rank].T, Vt[rank:].T, sigma[:rank])

    @property
    def rank(self) -> int:
        return self.sigma.size


def _pencil_eigen(coordinates: StateCoordinates, A_bar: np.ndarray, n: int, k: int):
    """The eigenvalues of ``F``, its eigenvectors (columns, in ``x``) and the same vectors in
    ``z = [y; λ_a]`` (scaled alike), from the QZ decomposition of the pencil
    ``(A_bar, diag(E, 0))`` rather than from ``F`` itself.

    The vectors in ``z`` are the pencil's own, not ``P`` times those in ``x``: ``P`` holds the
    inverse of the algebraic block, so where a small conductance carries a state's current
    (gmin at the Zener RLC's blocked Zener: ``v(n1) = −i(l1)/1e-12``) it multiplies that
    component's round-off by ``1/G``. The slow mode's ``i(l1)`` component, −1e-12 of the
    vector, is known to 2e-5 of itself (the norm's round-off); ``P`` made ``v(n1)`` of that
    mode 1.0000195 times the capacitor's voltage, and the sliding Zener's voltage 2.8e-5 V
    off the capacitor's, where the pencil's vector has ``v(n1)`` = 1 − 1e-13 of it.

    ``F`` holds the inverse of the algebraic block, so a blocking diode's off-conductance
    (1e-12 S) in series with an inductor puts a mode of -1e18 /s in it, and the eigenvalues
    of ``F`` are then known to ``eps·‖F‖`` ≈ 200 /s: a flyback's primary ramped through
    25.6 mΩ instead of its switch's 20 mΩ. The pencil keeps 1e-12 where ``F`` has 1e12, so
    its slow eigenvalues are accurate; its ``r`` finite ones are the eigenvalues of ``F``
    (an index-1 mode), the others infinite (``β = 0``).

    Where the pencil has fewer than ``r`` finite eigenvalues (a mode faster than ``1/ε`` times
    the slow ones: the transformer-fed bridge with every diode blocking, whose leakage through
    the blocked diodes is −1.8e17 /s) it is solved again balanced
    (:func:`~circuitnsds.solvers.pencil.balancing`), which gets the slow ones right (−0.1 and
    −10 /s; unbalanced −0.0996, and ``F``'s own, taken before, +32 /s for the magnetising
    mode: a current growing instead of decaying), and :class:`ModeDynamics` takes the
    missing fast ones from ``F``, whose largest eigenvalues are accurate relative to their size
    (its slow ones are not). Balancing every mode moved well-conditioned ones by ulps, enough
    to change a degenerate start's choice of mode (the voltage-mode buck at 0 V everywhere)."""
    E_bar = np.zeros_like(A_bar)
    E_bar[:n, :n] = (coordinates.U1 * coordinates.sigma) @ coordinates.V1.T
    r = coordinates.rank
    eigenvalues, vectors = _finite_eigen(*pencil_eigen(A_bar, E_bar, balance=False), r)
    if eigenvalues.size < r:
        eigenvalues, vectors = _finite_eigen(*pencil_eigen(A_bar, E_bar), r)
    W = coordinates.V1.T @ vectors[:n]
    with np.errstate(divide="ignore", invalid="ignore"):
        norms = np.linalg.norm(W, axis=0)
        return eigenvalues, W / norms, vectors / norms


def _finite_eigen(alpha: np.ndarray, beta: np.ndarray, vectors: np.ndarray, r: int
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The (at most ``r``) finite eigenvalues ``α/β`` of a pencil, the nearest to finite
    first, and their vectors."""
    ratio = np.abs(beta) / np.maximum(np.abs(alpha), 1e-300)
    order = np.argsort(-ratio, kind="stable")[:r]
    with np.errstate(divide="ignore", invalid="ignore"):
        values = alpha[order] / beta[order]
    finite = np.isfinite(values) & (np.abs(beta[order]) > 0)
    return values[finite], vectors[:, order[finite]]


def _algebraic_solve(N: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``N⁻¹ rhs`` for the algebraic block ``N`` of a mode, or :class:`NotIndexOne` when ``N``
    is singular. Singular is judged on ``N`` equilibrated (rows, then columns, scaled to a
    largest entry of 1): the rank does not change, but the scale of the circuit's values
    does not count against it (an open switch's 1e-9 S beside an amplifier's gain of 1e4 is
    a condition of 1e13 unscaled, 10 scaled)."""
    rows = np.abs(N).max(axis=1)
    rows[rows == 0] = 1.0
    scaled = N / rows[:, None]
    columns = np.abs(scaled).max(axis=0)
    columns[columns == 0] = 1.0
    scaled /= columns[None, :]
    if np.linalg.cond(scaled) > 1e13:
        raise NotIndexOne("the mode's algebraic equations are singular (index 2)")
    return np.linalg.solve(scaled, rhs / rows[:, None]) / columns[:, None]


RESIDUAL_RATIO = 1e3
"""How many times smaller the pencil's residual of its own vector must be than that of
``P W`` for the mode's ``z`` to take the pencil's vector (:func:`_closer`)."""


def _closer(A_bar: np.ndarray, coordinates: StateCoordinates, n: int, eigenvalues: np.ndarray,
            from_state: np.ndarray, from_pencil: np.ndarray) -> np.ndarray:
    """Each mode's vector in ``z``: ``P W`` (``from_state``), but the pencil's own
    (``from_pencil``, :func:`_pencil_eigen`) where ``P W`` leaves a residual of the pencil
    ``(A_bar − ν E_bar) z`` :data:`RESIDUAL_RATIO` times the pencil vector's or more (each
    relative to ``(|A_bar| + |ν| |E_bar|) |z|``, largest over the rows): where a small
    conductance carries a state's current, ``P`` multiplies that component's round-off by
    the conductance's inverse (the Zener RLC's blocked Zener, ``v(n1) = −i(l1)/gmin``: its
    slow mode's ``v(n1)`` 1.0000195 times the capacitor's voltage by ``P W``, a residual of
    1e-5 in the winding's row; 1 − 1e-13 of it by the pencil, residual 1e-17). Elsewhere
    ``P W`` (the two agree to round-off; where the algebraic part is ill-conditioned, as a
    bridge's floating input held by its blocked diodes, both are off alike, and ``P W`` is
    what the event tolerances were measured with). A mode with a part faster than
    :data:`FAST_DECAY` keeps ``P W`` whole: the transformer-fed bridge's blocked secondary
    (−9e16 /s) took pencil vectors 1e-6 off ``P W`` by this test, and its diodes delivered
    1.7 % less charge than its load drew over whole periods."""
    if not eigenvalues.size or from_pencil.shape != from_state.shape or np.any(
            eigenvalues.real < -FAST_DECAY):
        return from_state  # (a mode with a part gone at once: the transformer's, measured with P W)
    E_bar = np.zeros_like(A_bar)
    E_bar[:n, :n] = (coordinates.U1 * coordinates.sigma) @ coordinates.V1.T
    size_A, size_E = np.abs(A_bar), np.abs(E_bar)
    chosen = from_state.copy()
    for j, nu in enumerate(eigenvalues):
        residuals = []
        for z in (from_state[:, j], from_pencil[:, j]):
            scale = (size_A + abs(nu) * size_E) @ np.abs(z)
            residual = np.abs((A_bar - nu * E_bar) @ z)
            residuals.append(float(np.max(residual / np.maximum(scale.max(), 1e-300))))
        if residuals[0] > RESIDUAL_RATIO * residuals[1]:
            chosen[:, j] = from_pencil[:, j]
    return chosen


class ModeDynamics:
    """The reduced equations of one mode (module docstring)."""

    def __init__(self, coordinates: StateCoordinates, A: np.ndarray, B: np.ndarray, C: np.ndarray,
                 D: np.ndarray, e: np.ndarray, S: np.ndarray, active: np.ndarray):
        n, r = A.shape[0], coordinates.rank
        act = np.flatnonzero(active)
        k = act.size
        self.active = np.asarray(active, dtype=bool).copy()
        self.n = n
        # (assembled in place: np.block's bookkeeping was a tenth of a mode's cost)
        A_bar = np.empty((n + k, n + k))
        A_bar[:n, :n], A_bar[:n, n:] = A, B[:, act]
        A_bar[n:, :n], A_bar[n:, n:] = C[act], D[np.ix_(act, act)]
        T1 = np.zeros((n + k, r))
        T1[:n] = coordinates.V1
        T2 = np.zeros((n + k, n - r + k))
        T2[:n, :n - r] = coordinates.V2
        T2[n:, n - r:] = np.eye(k)
        R1 = np.zeros((r, n + k))
        R1[:, :n] = coordinates.U1.T
        R2 = np.zeros((n - r + k, n + k))
        R2[:n - r, :n] = coordinates.U2.T
        R2[n - r:, n:] = np.eye(k)
        N = R2 @ A_bar @ T2
        solve = _algebraic_solve(N, R2) if N.size else np.zeros((0, n + k))
        self.P = T1 - T2 @ solve @ A_bar @ T1
        self.Q = -T2 @ solve
        inv_sigma = 1.0 / coordinates.sigma
        self.F = inv_sigma[:, None] * (R1 @ A_bar @ self.P)
        self.H = inv_sigma[:, None] * (R1 @ (A_bar @ self.Q + np.eye(n + k)))
        if r:
            eigenvalues, W, Z = _pencil_eigen(coordinates, A_bar, n, k)
            keep = (np.isfinite(eigenvalues) & np.all(np.isfinite(W), axis=0)
                    & np.all(np.isfinite(Z), axis=0))
            eigenvalues, W, Z = eigenvalues[keep], W[:, keep], Z[:, keep]
            if eigenvalues.size < r:
                # the pencil has fewer than r finite eigenvalues to working precision (a fast
                # mode's β at round-off): the fastest of F's complete them
                fast, fast_vectors = np.linalg.eig(self.F)
                missing = np.argsort(-np.abs(fast), kind="stable")[:r - eigenvalues.size]
                eigenvalues = np.concatenate([eigenvalues.astype(complex), fast[missing]])
                W = np.hstack([W.astype(complex), fast_vectors[:, missing]])
                Z = np.hstack([Z.astype(complex), self.P @ fast_vectors[:, missing]])
            if np.linalg.cond(W) > 1e10:
                raise NotIndexOne("the mode's state matrix is not diagonalisable")
            self.eigenvalues, self.W, self.W_inv = eigenvalues, W, np.linalg.inv(W)
        else:
            self.eigenvalues = np.zeros(0, complex)
            self.W = self.W_inv = np.zeros((0, 0))
            Z = np.zeros((n + k, 0))
        self.S = S
        self.e_active = e[act]
        self.active_index = act
        self.V1t = coordinates.V1.T
        # the maps of solution() (and of SolutionMap), per mode: sources and e_a into the
        # modal forcing (W⁻¹ H ...) and into z (P W for the modal part, Q ... directly)
        self.modal_from_sources = self.W_inv @ self.H[:, :n] @ S
        self.modal_constant = self.W_inv @ self.H[:, n:] @ self.e_active
        self.z_from_modal = _closer(A_bar, coordinates, n, self.eigenvalues, self.P @ self.W, Z)
        # the modes that are gone a femtosecond after any instant (module docstring of
        # solution_map) and what of P persists after them
        self.fast = self.eigenvalues.real < -FAST_DECAY if self.eigenvalues.size else np.zeros(0, bool)
        slow = ~self.fast
        self.P_persistent = (self.z_from_modal[:, slow] @ self.W_inv[slow]).real if r else self.P
        self.z_from_sources = self.Q[:, :n] @ S
        self.z_constant = self.Q[:, n:] @ self.e_active

    def forcing_size(self, sources: ExpPoly) -> np.ndarray:
        """``Σ_j |φ_j|`` at ``τ = 0`` per component of ``φ = [S f(τ); e_a]``: the magnitudes
        summed to make ``φ(0)``, whose round-off it carries."""
        at_zero = sources.coefficients[sources.powers == 0]
        return np.concatenate([np.abs(at_zero @ self.S.T).sum(axis=0), np.abs(self.e_active)])

    def solution(self, x0: np.ndarray, sources: ExpPoly) -> ExpPoly:
        """``z(τ) = [y(τ); λ_a(τ)]`` from the state ``x0`` at ``τ = 0`` for the sources' piece
        ``f`` (one merged ExpPoly of every source: a term of power 0 and exponent 0 at most)."""
        coefficients, powers, exponents = sources.coefficients, sources.powers, sources.exponents
        plain = np.flatnonzero((powers == 0) & (exponents == 0))
        if not plain.size:
            coefficients = np.vstack([coefficients, np.zeros((1, coefficients.shape[1]))])
            powers, exponents = np.append(powers, 0), np.append(exponents, 0j)
            plain = np.array([len(powers) - 1])
        modal_forcing = coefficients @ self.modal_from_sources.T
        direct = coefficients @ self.z_from_sources.T
        modal_forcing[plain[0]] += self.modal_constant
        direct[plain[0]] += self.z_constant
        if self.eigenvalues.size:
            modal = response(self.eigenvalues, self.W_inv @ x0, ExpPoly(modal_forcing, powers, exponents))
            z = ExpPoly(np.vstack([modal.coefficients @ self.z_from_modal.T, direct]),
                        np.concatenate([modal.powers, powers]),
                        np.concatenate([modal.exponents, exponents]))
        else:
            z = ExpPoly(direct, powers, exponents)
        return z.merged()

    def state(self, y: np.ndarray) -> np.ndarray:
        """``x = V1ᵀ y``."""
        return self.V1t @ y
