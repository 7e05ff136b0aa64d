"""The principal pivot transform of an MLCP at a start basis, and the choice of that basis.

The MLCP in the solvers' sign convention, with the bordered matrix
``K = [[A, C], [D, B]]`` (``n`` free unknowns ``u``, ``m`` pairs)::

    A u + C z + a = 0,   w = D u + B z + b,   0 <= z ⊥ w >= 0

Eliminating ``u`` gives ``LCP(M, q)`` with ``M = B - D A⁻¹ C``, which loses most of its
digits when ``A`` is nearly singular (a node reached only through blocked devices).
Exchanging the roles of ``z_i`` and ``w_i`` for the pairs of a set ``α0`` (a *principal
pivot transform*) gives ``LCP(M̂, q̂)`` in ``ẑ`` = (``z_i`` for ``i ∉ α0``, ``w_i`` for
``i ∈ α0``), computed from the well-conditioned ``K_α0 = K[u, α0; u, α0]`` instead. It keeps P-matrices
P and positive semidefinite matrices positive semidefinite. :func:`completion_mask`
picks an ``α0`` that completes the rank of ``A``.

Used by the MLCP solver (Lemke from a start basis, :mod:`circuitnsds.solvers.mlcp`) and
by the well-posedness report (:mod:`circuitnsds.checks.wellposed`).
"""

from __future__ import annotations

import numpy as np

from .linalg import LU

__all__ = ["PivotTransform", "completion_mask", "pivoted_qr_order"]


def _block(K, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``K[rows][:, columns]`` as a dense array, for a dense or a scipy.sparse ``K`` (a large
    problem is never made dense whole; these blocks are ``(n + p) × m`` at most)."""
    if isinstance(K, np.ndarray):
        return K[np.ix_(rows, columns)]
    return K[rows][:, columns].toarray()


class PivotTransform:
    """Principal pivot transform of the MLCP with bordered matrix ``K`` at ``mask`` (``α0``).

    With ``(u, z_α0, w_ᾱ0)`` basic and ``ẑ`` nonbasic, ``ŵ`` = (``w_i`` for ``i ∉ α0``,
    ``z_i`` for ``i ∈ α0``) ``= M̂ ẑ + q̂``.

    Attributes:
        M: ``M̂`` ``(m, m)``; G: the basic values per unit of ``ẑ``; W: ``K[ᾱ0 rows, basic]``.
        mask, sel0, aidx, bidx: ``α0`` as a mask, the basic rows of ``K``, ``α0`` and its
            complement as indices; lu: the LU of ``K_α0``.
    """

    __slots__ = ("mask", "sel0", "lu", "G", "W", "aidx", "bidx", "M", "n", "m")

    def __init__(self, K: np.ndarray, n: int, mask: np.ndarray, lu: LU) -> None:
        m = K.shape[0] - n
        aidx = np.flatnonzero(mask)
        bidx = np.flatnonzero(~mask)
        p = aidx.size
        sel0 = np.concatenate([np.arange(n), n + aidx])
        R = np.zeros((n + p, m))
        R[:, bidx] = -_block(K, sel0, n + bidx)
        R[n + np.arange(p), aidx] = 1.0
        G = lu.solve(R) if n + p else np.zeros((0, m))
        W = _block(K, n + bidx, sel0)
        M = np.empty((m, m))
        M[aidx] = G[n:]
        M[bidx] = W @ G
        M[np.ix_(bidx, bidx)] += _block(K, n + bidx, n + bidx)
        self.mask, self.sel0, self.lu, self.G, self.W = mask, sel0, lu, G, W
        self.aidx, self.bidx, self.M, self.n, self.m = aidx, bidx, M, n, m

    def rhs(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(q̂, r0)`` for ``c = [a; b]`` (``r0`` = basic values at ``ẑ = 0``)."""
        r0 = self.lu.solve(-c[self.sel0]) if self.sel0.size else np.zeros(0)
        qhat = np.empty(self.m)
        qhat[self.aidx] = r0[self.n:]
        qhat[self.bidx] = self.W @ r0 + c[self.n + self.bidx]
        return qhat, r0

    def recover(self, zhat: np.ndarray, r0: np.ndarray) -> np.ndarray:
        """``x = [u; z]`` from a point ``ẑ`` of the transformed LCP."""
        x = np.zeros(self.n + self.m)
        x[self.sel0] = r0 + self.G @ zhat
        x[self.n + self.bidx] = zhat[self.bidx]
        return x


def pivoted_qr_order(P: np.ndarray, steps: int | None = None) -> np.ndarray:
    """The column order of a Householder QR of ``P`` with column pivoting (Businger & Golub;
    LAPACK ``geqp3``'s choice): at each step the remaining column of largest norm in the
    rows not yet reduced comes next (ties: the first in the current order, as LAPACK's
    ``idamax``). Norms are recomputed at each step (``geqp3`` downdates them: the same
    order up to rounding). ``steps`` (default all) limits the pivoting; the columns after
    them stay in their current order. ``P`` is not modified."""
    R = np.array(P, dtype=float)
    rows, columns = R.shape
    order = np.arange(columns)
    steps = min(rows, columns) if steps is None else min(steps, rows, columns)
    for j in range(steps):
        norms = np.sqrt(np.einsum("ij,ij->j", R[j:, j:], R[j:, j:]))
        p = j + int(np.argmax(norms))
        if p != j:
            R[:, [j, p]] = R[:, [p, j]]
            order[[j, p]] = order[[p, j]]
        x = R[j:, j]
        alpha = float(norms[p - j])
        if alpha == 0.0 or j + 1 == rows:  # nothing left to reduce
            continue
        v = x.copy()
        v[0] += alpha if x[0] >= 0.0 else -alpha  # the sign that avoids cancellation
        v /= np.sqrt(v @ v)
        R[j:, j:] -= 2.0 * np.outer(v, v @ R[j:, j:])
    return order


def completion_mask(K: np.ndarray, n: int, good: float = 1e-8) -> np.ndarray | None:
    """Pairs whose activation completes the rank of a (nearly) singular ``A = K[:n, :n]``.

    The ``k`` singular values of ``A`` at or below ``good`` times the largest span its
    numerical null spaces ``U2`` (left) and ``V2`` (right); rank-revealing QR (column
    pivoting, :func:`pivoted_qr_order`) on ``[U2ᵀ C; (D V2)ᵀ]`` picks the ``k`` pairs whose
    columns and rows best fill them. ``None`` when more than ``m`` directions are missing,
    when the blocks are not finite or the SVD fails.
    """
    m = K.shape[0] - n
    A, C, D = K[:n, :n], K[:n, n:], K[n:, :n]
    if not np.isfinite(A).all():
        return None
    try:
        U, s, Vt = np.linalg.svd(A)
    except np.linalg.LinAlgError:
        return None
    smax = float(s[0]) if s.size else 0.0
    k = int(np.sum(s <= good * smax)) if smax > 0 else n
    k = max(k, 1)
    if k > m:
        return None
    P = np.vstack([U[:, n - k:].T @ C, (D @ Vt[n - k:].T).T])
    if not np.isfinite(P).all():
        return None
    mask = np.zeros(m, dtype=bool)
    mask[pivoted_qr_order(P, k)[:k]] = True
    return mask
