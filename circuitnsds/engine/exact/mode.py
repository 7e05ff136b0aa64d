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

import math
from dataclasses import dataclass, field

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
    _blocks: dict = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def of(cls, E: np.ndarray) -> StateCoordinates:
        U, sigma, Vt = np.linalg.svd(E)
        rank = int(np.sum(sigma > sigma[0] * 1e-13)) if sigma.size and sigma[0] > 0 else 0
        return cls(U[:, :rank], U[:, rank:], Vt[:rank].T, Vt[rank:].T, sigma[:rank])

    @property
    def rank(self) -> int:
        return self.sigma.size

    def blocks(self, k: int) -> ModeBlocks:
        """The matrices of a mode with ``k`` active pairs that do not depend on which
        (:class:`ModeBlocks`), made once per ``k``."""
        blocks = self._blocks.get(k)
        if blocks is None:
            blocks = self._blocks[k] = ModeBlocks.of(self, k)
        return blocks


@dataclass(frozen=True)
class ModeBlocks:
    """For modes of ``k`` active pairs (``z = [y; λ_a]``, ``n + k`` unknowns): ``T1``/``T2`` the
    differential/algebraic coordinates of ``z``, ``R1``/``R2`` those of the equations,
    ``E_bar`` the pencil's ``diag(E, 0)``, ``identity`` ``I_{n+k}`` (module docstring)."""

    T1: np.ndarray
    T2: np.ndarray
    R1: np.ndarray
    R2: np.ndarray
    E_bar: np.ndarray
    identity: np.ndarray
    inv_sigma: np.ndarray

    @classmethod
    def of(cls, coordinates: StateCoordinates, k: int) -> ModeBlocks:
        n, r = coordinates.U1.shape[0], coordinates.rank
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
        E_bar = np.zeros((n + k, n + k))
        E_bar[:n, :n] = (coordinates.U1 * coordinates.sigma) @ coordinates.V1.T
        return cls(T1, T2, R1, R2, E_bar, np.eye(n + k), 1.0 / coordinates.sigma)


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
    E_bar = coordinates.blocks(k).E_bar
    r = coordinates.rank
    eigenvalues, vectors = _finite_eigen(*pencil_eigen(A_bar, E_bar, balance=False), r)
    if eigenvalues.size < r:
        eigenvalues, vectors = _finite_eigen(*pencil_eigen(A_bar, E_bar), r)
    W = coordinates.V1.T @ vectors[:n]
    norms = np.sqrt(np.add.reduce((W.conj() * W).real, axis=0))  # (np.linalg.norm's, inlined)
    if norms.all():
        return eigenvalues, W / norms, vectors / norms
    with np.errstate(divide="ignore", invalid="ignore"):
        return eigenvalues, W / norms, vectors / norms


def _finite_eigen(alpha: np.ndarray, beta: np.ndarray, vectors: np.ndarray, r: int
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The (at most ``r``) finite eigenvalues ``α/β`` of a pencil, the nearest to finite
    first, and their vectors."""
    ratio = np.abs(beta) / np.maximum(np.abs(alpha), 1e-300)
    order = (-ratio).argsort(kind="stable")[:r]
    chosen = beta[order]
    if chosen.all():
        values = alpha[order] / chosen
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            values = alpha[order] / chosen
    finite = np.isfinite(values) & (np.abs(chosen) > 0)
    if finite.all():
        return values, vectors[:, order]
    return values[finite], vectors[:, order[finite]]


SINGULAR = 1e13
"""The 2-norm condition of a mode's equilibrated algebraic block above which the mode is
index 2 (:func:`_algebraic_solve`)."""
SURE = 10.0
"""Margin of the cheap bounds of a condition (:func:`_algebraic_solve`, :class:`ModeDynamics`)
below which the singular values are not computed: a bound within a factor ``SURE`` of its
threshold is decided by the singular values as before."""


def _algebraic_solve(N: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``N⁻¹ rhs`` for the algebraic block ``N`` of a mode, or :class:`NotIndexOne` when ``N``
    is singular. Singular is judged on ``N`` equilibrated (rows, then columns, scaled to a
    largest entry of 1): the rank does not change, but the scale of the circuit's values
    does not count against it (an open switch's 1e-9 S beside an amplifier's gain of 1e4 is
    a condition of 1e13 unscaled, 10 scaled).

    ``rhs`` is the mode's ``R2`` (orthonormal rows: ``R2 R2ᵀ = I``), so the solution also gives
    the scaled block's inverse, ``S⁻¹ = X R2ᵀ diag(rows)`` (``X`` the scaled solve), one
    product; its Frobenius condition bounds the 2-norm one from above (``κ₂ <= κ_F``), so a
    mode whose ``κ_F`` is below :data:`SINGULAR` / :data:`SURE` is index 1 without the singular
    values (a third of a mode's cost: the inverter's 116 modes spent 12 ms on them); only
    above it are they computed, and decide as they did. The solve is the same call as
    before: the maps are the same to the bit."""
    rows = np.maximum.reduce(np.abs(N), axis=1)
    rows[rows == 0] = 1.0
    scaled = N / rows[:, None]
    columns = np.maximum.reduce(np.abs(scaled), axis=0)
    columns[columns == 0] = 1.0
    scaled /= columns[None, :]
    try:
        solved = np.linalg.solve(scaled, rhs / rows[:, None])
    except np.linalg.LinAlgError:  # (exactly singular: a condition of infinity)
        raise NotIndexOne("the mode's algebraic equations are singular (index 2)") from None
    inverse = (solved @ rhs.T) * rows[None, :]
    bound = math.sqrt(np.vdot(scaled, scaled)) * math.sqrt(np.vdot(inverse, inverse))
    if not bound <= SINGULAR / SURE and np.linalg.cond(scaled) > SINGULAR:
        raise NotIndexOne("the mode's algebraic equations are singular (index 2)")
    return solved / columns[:, None]


DEFECTIVE = 1e10
"""The condition of a mode's eigenvectors above which ``F`` counts as not diagonalisable."""


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
    what the event tolerances were measured with). A part faster than :data:`FAST_DECAY`
    keeps ``P W``: its homogeneous part is left out of every segment, and what it does at
    once (``fast_P``) and under the sources was measured with ``P W``. The slow parts of a
    mode that has one are chosen by the test like any other: the transformer-fed bridge's
    blocking mode (its floating secondary's leakage, −1.8e17 /s, puts 5e11 V on a diode's
    ``w`` per unit of that part) had ``P W`` for them too, whose round-off along the fast
    part made the diodes' ``w`` 1.5e-5 V off a 50-digit solution from the same state, and
    each conduction start went to θ (10 hand-offs in 100 ms); with the pencil's vectors and
    their gap in the tolerances (``vector_gap``) none does (with :func:`.run._near_crossing`
    for its start-up ringing's turn-offs), and its diodes deliver what its load and capacitor
    draw to 1e-7 over the last 40 ms (1.7e-5 before)."""
    if not eigenvalues.size or from_pencil.shape != from_state.shape:
        return from_state
    E_bar = coordinates.blocks(A_bar.shape[0] - n).E_bar
    both = np.stack([from_state, from_pencil])  # (2, rows, modes): every mode's two vectors at once
    sizes = np.abs(both)
    scales = (np.abs(A_bar) @ sizes + np.abs(eigenvalues) * (np.abs(E_bar) @ sizes)).max(axis=1)
    residuals = np.abs(A_bar @ both - eigenvalues * (E_bar @ both)).max(axis=1) / np.maximum(scales, 1e-300)
    chosen = from_state.copy()
    pencil = (residuals[0] > RESIDUAL_RATIO * residuals[1]) & (eigenvalues.real >= -FAST_DECAY)
    chosen[:, pencil] = from_pencil[:, pencil]
    return chosen


class ModeDynamics:
    """The reduced equations of one mode (module docstring)."""

    def __init__(self, coordinates: StateCoordinates, A: np.ndarray, B: np.ndarray, C: np.ndarray,
                 D: np.ndarray, e: np.ndarray, S: np.ndarray, active: np.ndarray):
        n, r = A.shape[0], coordinates.rank
        self.active = np.array(active, dtype=bool)
        act = self.active.nonzero()[0]
        k = act.size
        self.n = n
        # (assembled in place: np.block's bookkeeping was a tenth of a mode's cost)
        A_bar = np.empty((n + k, n + k))
        A_bar[:n, :n], A_bar[:n, n:] = A, B[:, act]
        A_bar[n:, :n], A_bar[n:, n:] = C[act], D[act][:, act]
        blocks = coordinates.blocks(k)  # (T1, T2, R1, R2: the same for every mode of k pairs)
        T1, T2, R1, R2 = blocks.T1, blocks.T2, blocks.R1, blocks.R2
        N = R2 @ A_bar @ T2
        solve = _algebraic_solve(N, R2) if N.size else np.zeros((0, n + k))
        self.P = T1 - T2 @ solve @ A_bar @ T1
        self.Q = -T2 @ solve
        inv_sigma = blocks.inv_sigma
        self.F = inv_sigma[:, None] * (R1 @ A_bar @ self.P)
        self.H = inv_sigma[:, None] * (R1 @ (A_bar @ self.Q + blocks.identity))
        if r:
            eigenvalues, W, Z = _pencil_eigen(coordinates, A_bar, n, k)
            keep = np.isfinite(eigenvalues) & np.isfinite(W).all(axis=0) & np.isfinite(Z).all(axis=0)
            if not keep.all():
                eigenvalues, W, Z = eigenvalues[keep], W[:, keep], Z[:, keep]
            if eigenvalues.size < r:
                # the pencil has fewer than r finite eigenvalues to working precision (a fast
                # mode's β at round-off): the fastest of F's complete them
                fast, fast_vectors = np.linalg.eig(self.F)
                missing = np.argsort(-np.abs(fast), kind="stable")[:r - eigenvalues.size]
                eigenvalues = np.concatenate([eigenvalues.astype(complex), fast[missing]])
                W = np.hstack([W.astype(complex), fast_vectors[:, missing]])
                Z = np.hstack([Z.astype(complex), self.P @ fast_vectors[:, missing]])
            # κ₂(W) <= κ_F(W) from the inverse needed anyway: the singular values only near
            # the threshold (SURE)
            try:
                W_inv = np.linalg.inv(W)
            except np.linalg.LinAlgError:
                raise NotIndexOne("the mode's state matrix is not diagonalisable") from None
            bound = math.sqrt(np.vdot(W, W).real) * math.sqrt(np.vdot(W_inv, W_inv).real)
            if not bound <= DEFECTIVE / SURE and np.linalg.cond(W) > DEFECTIVE:
                raise NotIndexOne("the mode's state matrix is not diagonalisable")
            self.eigenvalues, self.W, self.W_inv = eigenvalues, W, W_inv
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
        from_state = self.P @ self.W
        self.z_from_modal = _closer(A_bar, coordinates, n, self.eigenvalues, from_state, Z)
        # the modes that are gone a femtosecond after any instant (module docstring of
        # solution_map) and what of P persists after them
        self.fast = self.eigenvalues.real < -FAST_DECAY if self.eigenvalues.size else np.zeros(0, bool)
        if not r:
            self.P_persistent = self.P
        elif self.fast.any():
            slow = ~self.fast
            self.P_persistent = (self.z_from_modal[:, slow] @ self.W_inv[slow]).real
        else:  # (the same product: every mode slow)
            self.P_persistent = (self.z_from_modal @ self.W_inv).real
        # what the state's part along the fast modes puts in z at the start (round-off, but a
        # current an opening switch cuts where nothing else takes it: run.fast_offsets)
        self.fast_P = ((self.z_from_modal[:, self.fast] @ self.W_inv[self.fast]).real
                       if r and self.fast.any() else None)
        self.z_from_sources = self.Q[:, :n] @ S
        self.z_constant = self.Q[:, n:] @ self.e_active
        gap = self.z_from_modal - from_state if r else None
        self.vector_gap = ((gap[:, ~self.fast] @ self.W_inv[~self.fast]).real
                           if gap is not None and gap.any() else None)
        """``(n + k, r)`` or ``None``: where the mode's vectors are the pencil's own
        (:func:`_closer`), how far the solution at ``τ = 0`` from a state ``x``,
        ``Σ_k z_k (W⁻¹ x)_k``, is from the mode's algebraic values ``P x`` (its slow modes: the
        fast ones are left out at once): ``vector_gap @ x``. The two are the same function
        in exact arithmetic; where the pencil's vectors were taken, one of them is off by
        the round-off of a parasitic part (1e-6 of it: at rest through a switch's 1e9 Ω,
        −1e-5 V at a diode blocking at +1e-5 V), which the event functions' round-off then
        holds (:meth:`.run.ExactSystem.event_functions`)."""

    def forcing_size(self, sources: ExpPoly) -> np.ndarray:
        """``Σ_j |φ_j|`` at ``τ = 0`` per component of ``φ = [S f(τ); e_a]``: the magnitudes
        summed to make ``φ(0)``, whose round-off it carries."""
        at_zero = sources.coefficients[sources.powers == 0]
        size = np.empty(self.S.shape[0] + self.e_active.size)
        np.add.reduce(np.abs(at_zero @ self.S.T), axis=0, out=size[:self.S.shape[0]])
        np.abs(self.e_active, out=size[self.S.shape[0]:])
        return size

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
