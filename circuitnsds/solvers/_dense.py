"""Small dense linear-algebra helpers: LU with a condition estimate, fast triangular solves."""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla
from scipy.linalg import lapack

__all__ = ["LU", "factorise", "RCOND_MIN"]

#: Below this reciprocal condition number (1-norm estimate) a matrix is treated as singular.
RCOND_MIN = 1e-15

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
