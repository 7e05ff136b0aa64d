"""Linear algebra shared by the solvers and the engine: LU factorisations with a
condition estimate (dense and sparse), and the tolerances that go with them.

* :func:`factorise` — dense LU (LAPACK ``getrf``) with the reciprocal 1-norm condition
  estimate of ``gecon``; :class:`LU` solves with ``getrs`` directly (no argument
  checking), which is what makes the cache-hit path of the mode-reuse solver cheap.
* :func:`factorise_sparse` — SuperLU for large bordered matrices, with the same
  interface (:class:`SparseLU`) and a condition estimate of the same meaning.
* :data:`RCOND_MIN` (singularity), :data:`SIGN_TOL` (sign test of a guessed mode),
  :data:`SPARSE_MIN` (where the sparse LU takes over).

Sparse LU: A circuit's bordered matrix ``K_α`` has a few non-zeros per row. Beyond
:data:`SPARSE_MIN` unknowns a dense LU costs O(N³) (0.14 s at N = 2000, the
1000-section diode ladder) where SuperLU takes milliseconds. The reciprocal
condition number is estimated as LAPACK's ``gecon`` does, from the 1-norm of
``K`` and an estimate of the 1-norm of ``K⁻¹`` (Hager's method, a few solves), so
:attr:`SparseLU.ok` means what :attr:`LU.ok` means.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg import lapack

__all__ = ["LU", "SparseLU", "factorise", "factorise_sparse", "RCOND_MIN", "SIGN_TOL", "SPARSE_MIN"]

RCOND_MIN = 1e-15
"""Below this reciprocal condition number (1-norm estimate) a matrix is treated as singular."""
SIGN_TOL = 1e-7
"""Largest relative sign violation accepted from a guessed mode: a complementarity value
counts as ``>= 0`` when it is negative by less than ``SIGN_TOL`` times the sum of the
magnitudes of the terms that make it up (rounding noise of a pair at zero on both sides).
Used by the MLCP solver's test of a guessed mode and by the engine's mode loops."""

_getrs = lapack.dgetrs
_gecon = lapack.dgecon


class LU:
    """LU factors of a square matrix with its reciprocal condition estimate.

    ``solve(b)`` calls LAPACK ``getrs`` directly (no argument checking), which is
    what makes the cache-hit path of the mode-reuse solver cheap.
    """

    __slots__ = ("lu", "piv", "rcond", "size")

    def __init__(self, lu: np.ndarray, piv: np.ndarray, rcond: float) -> None:
        self.lu = lu
        self.piv = piv
        self.rcond = rcond
        self.size = lu.shape[0]

    @property
    def ok(self) -> bool:
        """True when the matrix is not numerically singular."""
        return self.rcond >= RCOND_MIN

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``K x = b`` (``b`` 1-D or 2-D)."""
        if self.size == 0:
            return np.zeros_like(b, dtype=float)
        x, _ = _getrs(self.lu, self.piv, b)
        return x


def factorise(K: np.ndarray) -> LU:
    """LU-factorise a dense square ``K``; ``rcond`` is 0 when a pivot is exactly zero."""
    size = K.shape[0]
    if size == 0:
        return LU(np.zeros((0, 0)), np.zeros(0, dtype=np.int32), 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lu, piv = sla.lu_factor(K, check_finite=False)
    if not np.all(np.isfinite(lu)):
        return LU(lu, piv, 0.0)
    diag = np.abs(np.diag(lu))
    if diag.min() == 0.0:
        return LU(lu, piv, 0.0)
    anorm = float(np.abs(K).sum(axis=0).max())
    rcond, info = _gecon(lu, anorm, norm="1")
    if info != 0 or not np.isfinite(rcond):
        rcond = 0.0
    return LU(lu, piv, float(rcond))

SPARSE_MIN = 300
"""Bordered systems with at least this many unknowns are factorised sparse (when ``K`` is)."""


class SparseLU:
    """SuperLU factors of a square sparse matrix with its reciprocal condition estimate."""

    __slots__ = ("factors", "rcond", "size")

    def __init__(self, factors: spla.SuperLU | None, rcond: float, size: int) -> None:
        self.factors = factors
        self.rcond = rcond
        self.size = size

    @property
    def ok(self) -> bool:
        """True when the matrix is not numerically singular."""
        return self.rcond >= RCOND_MIN

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``K x = b`` (``b`` 1-D or 2-D)."""
        return self.factors.solve(np.asarray(b, dtype=float))


def factorise_sparse(K: sp.spmatrix | sp.sparray) -> SparseLU:
    """Factorise ``K``; ``rcond`` is 0 when it is exactly singular or not finite."""
    K = sp.csc_matrix(K)
    size = K.shape[0]
    if not np.isfinite(K.data).all():
        return SparseLU(None, 0.0, size)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            factors = spla.splu(K, permc_spec="MMD_AT_PLUS_A")
    except RuntimeError:  # exactly singular
        return SparseLU(None, 0.0, size)
    inverse = spla.LinearOperator((size, size), matvec=factors.solve,
                                  rmatvec=lambda b: factors.solve(b, trans="T"), dtype=float)
    with np.errstate(all="ignore"):  # t = 1 (Hager's method): deterministic, no random columns
        inverse_norm = spla.onenormest(inverse, t=1)
    anorm = float(abs(K).sum(axis=0).max())
    rcond = 1.0 / (anorm * inverse_norm) if anorm > 0 and np.isfinite(inverse_norm) else 0.0
    return SparseLU(factors, rcond, size)
