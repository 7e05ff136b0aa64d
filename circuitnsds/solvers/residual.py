"""The scaled residual every solver checks before it returns.

For the MLCP ``A u + C z + a = 0, w = D u + B z + b, 0 <= z ⊥ w >= 0`` write
``K = [[A, C], [D, B]]``, ``x = [u; z]``, ``c = [a; b]`` and ``κ = ||K||_∞``
(largest absolute row sum). ``w`` is always *recomputed* as ``D u + B z + b``,
never taken from a solver's internal state. Then::

    residual = max( ||A u + C z + a||_∞ ,  max_i |min(κ z_i, w_i)| )
               / ( ||c||_∞ + κ ||x||_∞ )

``min(κ z_i, w_i)`` is the natural residual of the pair with ``z`` brought to
the units of ``w``: it is ``< 0`` when ``z_i`` or ``w_i`` is negative and ``> 0``
when both are positive (complementarity violated). The denominator is the
normwise backward-error scale, so the residual is invariant when the problem
and its solution are scaled together, and rounding errors of a backward-stable
solve give values near machine epsilon. A result is accepted when
``residual <= tol`` (default ``1e-9``). The LCP is the case ``n = 0``
(``K = M``, ``x = z``, ``c = q``). A non-finite ``x`` gives ``inf``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["mlcp_residual", "lcp_residual", "kappa_of", "evaluate", "componentwise_residual",
           "scaled_column_max"]


def kappa_of(K: np.ndarray) -> float:
    """``||K||_∞`` (max absolute row sum) of a dense or sparse matrix; 1.0 if empty."""
    if K.shape[0] == 0 or K.shape[1] == 0:
        return 1.0
    if isinstance(K, np.ndarray):
        val = float(np.abs(K).sum(axis=1).max())
    else:
        val = float(abs(K).sum(axis=1).max())
    return val if val > 0.0 else 1.0


def evaluate(
    K: np.ndarray, n: int, c: np.ndarray, x: np.ndarray, kappa: float
) -> tuple[float, np.ndarray, float]:
    """Scaled residual, ``w`` and the denominator ``||c||_∞ + κ ||x||_∞`` (the scale ``S``)."""
    r = K @ x
    r = np.asarray(r, dtype=float).reshape(-1) + c
    w = r[n:]
    eq = float(np.abs(r[:n]).max()) if n else 0.0
    comp = float(np.abs(np.minimum(kappa * x[n:], w)).max()) if w.size else 0.0
    xn = float(np.abs(x).max()) if x.size else 0.0
    cn = float(np.abs(c).max()) if c.size else 0.0
    scale = cn + kappa * xn
    num = max(eq, comp)
    if not (np.isfinite(num) and np.isfinite(scale)):
        return float("inf"), w, scale
    if num == 0.0:
        return 0.0, w, scale
    return num / max(scale, np.finfo(float).tiny), w, scale


def mlcp_residual(
    K: np.ndarray,
    n: int,
    c: np.ndarray,
    x: np.ndarray,
    kappa: float | None = None,
) -> tuple[float, np.ndarray]:
    """Scaled residual of ``x = [u; z]`` for the MLCP ``(K, c)`` with ``n`` free unknowns.

    Args:
        K: ``[[A, C], [D, B]]`` (dense or sparse).
        n: number of free unknowns ``u``.
        c: ``[a; b]``.
        x: ``[u; z]``.
        kappa: ``||K||_∞`` if already known.

    Returns:
        ``(residual, w)`` with ``w = D u + B z + b``.
    """
    if kappa is None:
        kappa = kappa_of(K)
    res, w, _ = evaluate(K, n, c, x, kappa)
    return res, w


def componentwise_residual(
    absK: np.ndarray, n: int, c: np.ndarray, x: np.ndarray, r: np.ndarray
) -> float:
    """Componentwise (Oettli–Prager style) residual, used to choose between solutions.

    With ``s = |K| |x| + |c|`` (row scales) and ``r = K x + c``: equation rows give
    ``|r_j| / s_j``; a negative ``z_i`` gives ``|z_i| max_j |K_ji| / s_j`` (the relative
    change of the rows it enters if it were set to 0); a negative ``w_i`` gives
    ``|w_i| / s_{n+i}``; a pair with both positive gives the smaller of the two.
    Values are in ``[0, 1]`` up to rounding. This measure sees effects of tiny
    conductances (``gmin``) that the normwise residual cannot; it is not an
    acceptance test (noise in rows whose every term is ~0 makes it large).
    """
    s = absK @ np.abs(x) + np.abs(c)
    safe = np.where(s > 0.0, s, 1.0)
    eq = float((np.abs(r[:n]) / safe[:n]).max()) if n else 0.0
    z = x[n:]
    w = r[n:]
    if z.size == 0:
        return eq
    colmax = scaled_column_max(absK, n, safe)
    zt = z * colmax
    wt = w / safe[n:]
    comp = float(np.abs(np.minimum(zt, wt)).max())
    return max(eq, comp)


def scaled_column_max(absK: Any, n: int, safe: np.ndarray) -> np.ndarray:
    """``max_j |K_ji| / safe_j`` for each pair column ``i`` (columns ``n:``), for a dense or
    sparse ``|K|``: the relative weight of a pair unknown in the rows it enters."""
    if isinstance(absK, np.ndarray):
        return (absK[:, n:] / safe[:, None]).max(axis=0)
    import scipy.sparse as sp

    scaled = sp.diags(1.0 / safe) @ sp.csc_matrix(absK)[:, n:]
    return np.asarray(scaled.max(axis=0).todense()).ravel()


def lcp_residual(
    M: np.ndarray, q: np.ndarray, z: np.ndarray, kappa: float | None = None
) -> tuple[float, np.ndarray]:
    """Scaled residual of ``z`` for ``LCP(M, q)``; returns ``(residual, w = M z + q)``."""
    return mlcp_residual(M, 0, q, z, kappa)
