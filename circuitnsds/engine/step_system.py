"""The θ-method step system of an MLCS, built in one place.

For the step ``t_k -> t_{k+1}`` of length ``h`` with switch states ``states``,
``Θ = diag(θ on rows with a time derivative, 1 on algebraic rows)`` and
``A = A(states)``, the rows divided by ``h`` (node rows in amperes; the pair
unknowns are the currents ``λ = μ/h`` [A]) read

    K y_{k+1} - B λ = r,        K = E/h - ΘA,
    r = E y_k / h + ΘS f_{k+1} + (I - Θ)(A y_k + S f_k)
    w = C y_{k+1} + D λ + e,    0 <= w ⊥ λ >= 0

(Acary & Brogliato, *Numerical Methods for Nonsmooth Dynamical Systems*, the
θ-method for linear complementarity systems). This is what the integrator
solves as an MLCP (:mod:`circuitnsds.engine.integrate`), what the mode maps
factorise (:func:`mode_blocks`: the bordered matrix of an active set and the
right-hand side as a linear function of ``y_k``, ``f_{k+1}``, ``f_k``), and what
the well-posedness report examines (:mod:`circuitnsds.checks.wellposed`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from circuitnsds.system.mlcs import MLCS
from circuitnsds.theta import THETA_RANGE, theta_in_range

if TYPE_CHECKING:
    import scipy.sparse as sp

__all__ = ["StepSystem", "DenseParts", "ModeBlocks", "step_system", "mode_blocks", "check_theta"]

def check_theta(theta: float) -> float:
    """``theta`` as a float if :func:`theta_in_range`, else :class:`ValueError`."""
    theta = float(theta)
    if not theta_in_range(theta):
        raise ValueError(f"theta must lie in [{THETA_RANGE[0]:g}, {THETA_RANGE[1]:g}], got {theta:g}")
    return theta


@dataclass(frozen=True)
class StepSystem:
    """The step system of one step size ``h`` [s], θ and switch state (module docstring).

    Attributes:
        h: step [s]; theta: θ of the step (1 for implicit Euler).
        weights: the diagonal of ``Θ``, shape ``(n,)``.
        A: ``A(states)`` (CSR); K: ``E/h - ΘA`` (CSC; may hold inf when ``E/h`` overflows,
            see :attr:`finite`).
        E, S: the MLCS's ``E`` and ``S`` (CSR); B (CSC), C, D (CSR) and e: its pair blocks.
        The matrices are numpy arrays instead when the system was built ``dense`` (a small
        circuit: no scipy is imported for it).

    The right-hand side's parts (:attr:`carry`, :attr:`source_next`, :attr:`source_now`) are
    computed on first use and kept: every mode of the step shares them.
    """

    h: float
    theta: float
    weights: np.ndarray
    A: sp.csr_matrix
    K: sp.csc_matrix
    E: sp.csr_matrix
    S: sp.csr_matrix
    B: sp.csc_matrix
    C: sp.csr_matrix
    D: sp.csr_matrix
    e: np.ndarray

    @property
    def is_dense(self) -> bool:
        """Whether the matrices are numpy arrays (see :func:`step_system`)."""
        return isinstance(self.K, np.ndarray)

    @property
    def finite(self) -> bool:
        """Whether ``K`` is finite (capacitance/h or inductance/h may overflow)."""
        return bool(np.isfinite(self.K if self.is_dense else self.K.data).all())

    def rhs(self, charge: np.ndarray, y: np.ndarray, f_now: np.ndarray, f_next: np.ndarray) -> np.ndarray:
        """``r`` of the module docstring with ``charge = E y_k`` (given separately: initial
        conditions that ``y_k`` cannot express); units of the rows divided by ``h``."""
        r = charge / self.h + self.weights * (self.S @ f_next)
        if self.theta != 1.0:
            r += (1.0 - self.weights) * (self.A @ y + self.S @ f_now)
        return r

    @cached_property
    def carry(self) -> sp.csr_matrix | np.ndarray:
        """``E/h + (I - Θ)A``: the part of ``r`` multiplying ``y_k``."""
        if self.is_dense:
            return self.dense.carry
        import scipy.sparse as sp

        return (self.E / self.h + sp.diags(1.0 - self.weights) @ self.A).tocsr()

    @cached_property
    def source_next(self) -> sp.csr_matrix | np.ndarray:
        """``ΘS``: the part of ``r`` multiplying ``f_{k+1}``."""
        if self.is_dense:
            return self.dense.source_next
        import scipy.sparse as sp

        return (sp.diags(self.weights) @ self.S).tocsr()

    @cached_property
    def source_now(self) -> sp.csr_matrix | np.ndarray:
        """``(I - Θ)S``: the part of ``r`` multiplying ``f_k``."""
        if self.is_dense:
            return self.dense.source_now
        import scipy.sparse as sp

        return (sp.diags(1.0 - self.weights) @ self.S).tocsr()

    @cached_property
    def dense(self) -> DenseParts:
        """``K``, ``B``, ``C``, ``D`` and the right-hand side's parts as numpy arrays, for
        the dense mode maps of a small system (computed on first use and kept)."""
        implicit = (1.0 - self.weights)[:, None]
        S, E, A = (_array(self.S), _array(self.E), _array(self.A))
        with np.errstate(all="ignore"):
            # E * (1/h), not E / h: what scipy computes for the sparse E/h (same rounding)
            carry = E * (1.0 / self.h) + implicit * A
        return DenseParts(_array(self.K), _array(self.B), _array(self.C), _array(self.D),
                          carry, self.weights[:, None] * S, implicit * S)


def _array(matrix: sp.spmatrix | np.ndarray) -> np.ndarray:
    """``matrix`` as a numpy array (itself if it is one)."""
    return matrix if isinstance(matrix, np.ndarray) else matrix.toarray()


class DenseParts(NamedTuple):
    """A :class:`StepSystem`'s matrices as numpy arrays (same names and meaning there)."""

    K: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    carry: np.ndarray
    source_next: np.ndarray
    source_now: np.ndarray


def step_system(mlcs: MLCS, h: float, states: tuple[bool, ...] | np.ndarray = (),
                theta: float = 1.0, dense: bool = False) -> StepSystem:
    """The :class:`StepSystem` of ``mlcs`` for a step ``h`` [s], switch ``states`` (closed =
    true, one per ``mlcs.switches``) and ``theta``; with numpy arrays if ``dense`` (a small
    circuit), else scipy.sparse matrices."""
    weights = np.where(mlcs.differential_rows, theta, 1.0)
    A = mlcs.system_matrix(tuple(bool(s) for s in states))
    if dense:
        E, A = mlcs.E.toarray(), A.toarray()
        with np.errstate(all="ignore"):
            # E * (1/h): what scipy computes for the sparse E/h (same rounding either way)
            K = E * (1.0 / h) - weights[:, None] * A
        return StepSystem(float(h), float(theta), weights, A, K, E, mlcs.S.toarray(), mlcs.B.toarray(),
                          mlcs.C.toarray(), mlcs.D.toarray(), mlcs.e)
    import scipy.sparse as sp

    E = mlcs.E.tocsr()
    with np.errstate(all="ignore"):
        K = (E / h - sp.diags(weights) @ A.tocsr()).tocsc()
    return StepSystem(float(h), float(theta), weights, A.tocsr(), K, E, mlcs.S.tocsr(), mlcs.B.tocsc(),
                      mlcs.C.tocsr(), mlcs.D.tocsr(), mlcs.e)


@dataclass(frozen=True)
class ModeBlocks:
    """The step of one mode (active set ``α``) as a linear system, sparse (CSC ``bordered``,
    CSR others) or, from ``mode_blocks(..., dense=True)``, numpy arrays.

    ``bordered · [y_{k+1}; λ_α] = [carry·y_k + S_next·f_{k+1} + S_now·f_k; rhs_pairs]``
    with ``bordered = [[K, -B_α], [C_α, D_αα]]``; the inactive pairs' ``w = W·x + e_w``,
    the active pairs' (zero by construction) ``W_active·x + e_active``.
    """

    bordered: sp.csc_matrix | np.ndarray
    carry: sp.csr_matrix | np.ndarray
    S_next: sp.csr_matrix | np.ndarray
    S_now: sp.csr_matrix | np.ndarray
    rhs_pairs: np.ndarray
    W: sp.csr_matrix | np.ndarray
    e_w: np.ndarray
    active: np.ndarray
    inactive: np.ndarray
    W_active: sp.csr_matrix | np.ndarray | None = None
    e_active: np.ndarray | None = None


def mode_blocks(system: StepSystem, active: np.ndarray, dense: bool = False) -> ModeBlocks:
    """The :class:`ModeBlocks` of the mode with active pairs ``active`` (a boolean mask);
    numpy arrays if ``dense`` (sliced from :attr:`StepSystem.dense`: for a small system,
    several times faster than slicing and assembling sparse matrices), else sparse."""
    act = np.flatnonzero(active)
    inact = np.flatnonzero(~np.asarray(active, dtype=bool))
    e = system.e
    if dense:
        K, B, C, D, carry, source_next, source_now = system.dense
        n = K.shape[0]
        D_act = D[:, act]
        # (assembled in place: np.block's checks cost more than the copies at these sizes)
        bordered = np.empty((n + act.size, n + act.size))
        bordered[:n, :n] = K
        bordered[:n, n:] = -B[:, act]
        bordered[n:, :n] = C[act]
        bordered[n:, n:] = D_act[act]
        W = np.hstack([C[inact], D_act[inact]])
        W_active = np.hstack([C[act], D_act[act]])
    else:
        import scipy.sparse as sp

        B, C, D = system.B, system.C, system.D
        carry, source_next, source_now = system.carry, system.source_next, system.source_now
        bordered = sp.bmat([[system.K, -B[:, act]], [C[act], D[act][:, act]]], format="csc")
        W = sp.hstack([C[inact], D[inact][:, act]]).tocsr()
        W_active = sp.hstack([C[act], D[act][:, act]]).tocsr()
    return ModeBlocks(
        bordered=bordered, carry=carry, S_next=source_next, S_now=source_now, rhs_pairs=-e[act], W=W,
        e_w=e[inact].copy(), active=act.astype(np.int64), inactive=inact.astype(np.int64),
        W_active=W_active, e_active=e[act].copy())
