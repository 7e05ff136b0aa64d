"""Ruiz equilibration of a matrix by positive row and column factors.

Complementarity problems allow any positive row scaling ``E`` of the ``w``
equations and any positive column scaling of ``z``: with ``z = F z'`` and
``w' = E w`` the pair products ``z'_i w'_i`` only change by a positive factor,
so ``LCP(E M F, E q)`` has exactly the solutions ``z' = F⁻¹ z``. Lemke's pivot
sequence is also unchanged when its covering vector is scaled to ``E d``
(ratios of a row are scaled by the same factor), so its guarantees carry over,
while the tableau becomes far better conditioned for badly scaled data.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ._inputs import is_sparse

__all__ = ["ruiz"]


def ruiz(K: Any, iters: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """Factors ``(r, c)`` giving every row and column of ``diag(r) K diag(c)`` max-abs ~1.

    Rows or columns that are entirely zero keep the factor 1. Factors are powers
    of two (exact scaling, no rounding).
    """
    nr, nc = K.shape
    r = np.ones(nr)
    c = np.ones(nc)
    if nr == 0 or nc == 0:
        return r, c
    if is_sparse(K):
        import scipy.sparse as sp

        A = abs(sp.csr_matrix(K)).astype(float)
    else:
        A = np.abs(np.asarray(K, dtype=float))
    for _ in range(iters):
        S = (
            A.multiply(r[:, None]).multiply(c[None, :])
            if is_sparse(A)
            else A * r[:, None] * c[None, :]
        )
        if is_sparse(S):
            rmax = np.asarray(S.max(axis=1).todense()).ravel()
            cmax = np.asarray(S.max(axis=0).todense()).ravel()
        else:
            rmax = S.max(axis=1)
            cmax = S.max(axis=0)
        if np.all(np.abs(rmax[rmax > 0] - 1.0) < 0.5) and np.all(
            np.abs(cmax[cmax > 0] - 1.0) < 0.5
        ):
            break
        rf = np.where(rmax > 0, 1.0 / np.sqrt(np.where(rmax > 0, rmax, 1.0)), 1.0)
        cf = np.where(cmax > 0, 1.0 / np.sqrt(np.where(cmax > 0, cmax, 1.0)), 1.0)
        r *= rf
        c *= cf
    # round to powers of two so that scaling is exact in floating point
    r = np.exp2(np.round(np.log2(r)))
    c = np.exp2(np.round(np.log2(c)))
    return r, c
