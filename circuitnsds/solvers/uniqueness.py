"""A certificate that an LCP has exactly one solution for every right-hand side.

``LCP(M, q)`` has a unique solution for every ``q`` if and only if ``M`` is a
P-matrix (every principal minor positive; Cottle, Pang & Stone, *The Linear
Complementarity Problem*, Theorem 3.3.7). Checking every minor costs ``2^m``
determinants; a cheap sufficient condition is that the symmetric part of
``S M S`` is positive definite for some positive diagonal ``S`` (then every principal
submatrix of ``S M S`` is positive definite in the same sense, hence has a positive
determinant, and scaling both sides by a positive diagonal multiplies each principal
minor by a positive number). With
``S = diag(M_ii)^(-1/2)`` the symmetric part has a unit diagonal, so its smallest
eigenvalue is a margin in [0, 1].

Used where a solution found by a shortcut must be *the* solution: the engine's mode
loop accepts a mode found in its table for a step whose mode changed only when the
step's LCP is certified so (:mod:`circuitnsds.engine.dense_loop`); otherwise the MLCP
solver decides (it warns or fails on ambiguous problems).
"""

from __future__ import annotations

import numpy as np

__all__ = ["P_MARGIN", "p_matrix_margin", "certified_p_matrix"]

P_MARGIN = 1e-6
"""Smallest eigenvalue of the scaled symmetric part (unit diagonal) accepted as a
certificate; also the largest relative error of ``M`` itself that it tolerates."""


def p_matrix_margin(M: np.ndarray) -> float:
    """Smallest eigenvalue of the symmetric part of ``S M S``, ``S = diag(M_ii)^(-1/2)``
    (``-inf`` when a diagonal entry is not positive or an entry is not finite; ``inf`` for
    an empty ``M``). Positive: ``M`` is a P-matrix."""
    M = np.asarray(M, dtype=float)
    if M.size == 0:
        return float("inf")
    diagonal = np.diagonal(M)
    if not np.isfinite(M).all() or not (diagonal > 0.0).all():
        return float("-inf")
    s = 1.0 / np.sqrt(diagonal)
    scaled = s[:, None] * M * s[None, :]
    return float(np.linalg.eigvalsh(0.5 * (scaled + scaled.T))[0])


def certified_p_matrix(M: np.ndarray, relative_error: float = 0.0) -> bool:
    """Whether ``M`` is certified a P-matrix: :func:`p_matrix_margin` above :data:`P_MARGIN`
    and above ten times what an error of ``relative_error`` times ``M``'s largest entry
    (e.g. ``eps / rcond`` of the factorisation ``M`` came from) can move it by."""
    M = np.asarray(M, dtype=float)
    margin = p_matrix_margin(M)
    if M.size == 0 or margin == float("inf"):
        return True
    if not margin > 0.0:
        return False
    # an absolute error δ on every entry moves the scaled matrix's eigenvalues by at most
    # m·δ / min M_ii (a bound on its spectral norm)
    error = relative_error * float(np.abs(M).max()) * M.shape[0] / float(np.diagonal(M).min())
    return margin > max(P_MARGIN, 10.0 * error)
