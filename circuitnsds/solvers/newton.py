"""Semismooth Newton method on the Fischer–Burmeister reformulation.

The MLCP ``A u + C z + a = 0, w = D u + B z + b, 0 <= z ⊥ w >= 0`` (the LCP is
the case without ``u``) is written as the nonsmooth equation ``F(x) = 0``,
``x = [u; z]``::

    F(x) = [ A u + C z + a ;  φ(z_i, w_i) for each pair ],
    φ(s, t) = sqrt(s² + t²) - s - t

(``φ(s, t) = 0`` iff ``s >= 0, t >= 0, s t = 0``). Each iteration takes an
element ``J`` of the generalised Jacobian, solves ``J d = -F`` (dense LU, or
``scipy.sparse.linalg.spsolve`` for sparse input), and falls back to a
Levenberg–Marquardt direction ``(JᵀJ + μI) d = -JᵀF`` when ``J`` is singular or
``d`` is not a descent direction. An Armijo backtracking line search on the
merit ``Ψ = ½||F||²`` keeps the iteration globally convergent to stationary
points of ``Ψ``, which are solutions for P0 (e.g. positive semidefinite) LCPs.

The iteration stops when the scaled residual of
:mod:`circuitnsds.solvers.residual` is ``<= tol``. The active set
``{z_i > w_i}`` is then solved exactly once more ("polish") and the better of
the two answers is kept. No convergence raises :class:`LCPSolverFailure`.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from ._inputs import is_sparse
from ._scaling import ruiz
from .linalg import factorise
from .residual import kappa_of, mlcp_residual
from .result import LCPResult, LCPSolverFailure

__all__ = ["fb_newton_mlcp", "fb_newton_lcp"]

_SIGMA = 1e-4  # Armijo constant
_RHO = 1e-10  # descent test: gᵀd <= -_RHO ||d||²
_SQ2 = 1.0 - 1.0 / np.sqrt(2.0)


def _fb(s: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.hypot(s, t) - s - t


def _jacobian_parts(z: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Diagonals ``Da = ∂φ/∂z``, ``Db = ∂φ/∂w`` (a generalised-Jacobian element at kinks)."""
    r = np.hypot(z, w)
    kink = r <= 1e-300
    rs = np.where(kink, 1.0, r)
    da = np.where(kink, -_SQ2, z / rs - 1.0)
    db = np.where(kink, -_SQ2, w / rs - 1.0)
    return da, db


def _solve(J: Any, rhs: np.ndarray, sparse: bool) -> np.ndarray | None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if sparse:
            import scipy.sparse as sp
            import scipy.sparse.linalg as spla

            try:
                d = spla.spsolve(sp.csc_matrix(J), rhs)
            except (RuntimeError, ValueError):
                return None
        else:
            lu = factorise(J)
            if not lu.ok:
                return None
            d = lu.solve(rhs)
    d = np.asarray(d, dtype=float).reshape(-1)
    return d if np.all(np.isfinite(d)) else None


def _polish(K: Any, n: int, c: np.ndarray, active: np.ndarray, sparse: bool) -> np.ndarray | None:
    sel = np.concatenate([np.arange(n), n + np.flatnonzero(active)])
    x = np.zeros(K.shape[0])
    if sel.size == 0:
        return x
    if sparse:
        import scipy.sparse as sp

        sub = sp.csc_matrix(K)[sel][:, sel]
    else:
        sub = K[np.ix_(sel, sel)]
    sol = _solve(sub, -c[sel], sparse)
    if sol is None:
        return None
    x[sel] = sol
    return x


def fb_newton_mlcp(
    K: Any,
    n: int,
    c: np.ndarray,
    *,
    tol: float = 1e-9,
    max_iter: int = 100,
    x0: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, int, float]:
    """Semismooth Newton for the MLCP ``(K, c)`` with ``n`` free unknowns.

    Args:
        K: ``[[A, C], [D, B]]``, dense ndarray or scipy.sparse (then solved with spsolve).
        n: number of free unknowns.
        c: ``[a; b]``.
        tol: accepted scaled residual.
        max_iter: iteration limit.
        x0: starting point (default zeros).

    Returns:
        ``(x, active, iterations, residual)`` with ``x = [u; z]`` and ``active = z > w``
        (or the polished set).

    Raises:
        LCPSolverFailure: no convergence within ``max_iter`` or line search failure.
    """
    sparse = is_sparse(K)
    N = K.shape[0]
    m = N - n
    size = {"n": n, "m": m} if n else {"n": m}
    # Iterate on the equilibrated problem diag(rs) K diag(cs), x = cs * x' (an
    # equivalent MLCP, see _scaling); verify on the original data at the end.
    K_orig, c_orig = K, c
    kappa_orig = kappa_of(K)
    rs, cs = ruiz(K)
    if sparse:
        import scipy.sparse as sp

        K = sp.csr_matrix(sp.diags(rs) @ sp.csr_matrix(K) @ sp.diags(cs))
    else:
        K = rs[:, None] * np.asarray(K, dtype=float) * cs[None, :]
    c = rs * c
    kappa = kappa_of(K)
    x = np.zeros(N) if x0 is None else np.array(x0, dtype=float) / cs

    def evaluate(xv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r = np.asarray(K @ xv, dtype=float).reshape(-1) + c
        F = r.copy()
        F[n:] = _fb(xv[n:], r[n:])
        return F, r

    F, r = evaluate(x)
    psi = 0.5 * float(F @ F)
    best_res = float("inf")
    it = 0
    for it in range(max_iter + 1):
        res, _ = mlcp_residual(K, n, c, x, kappa)
        best_res = min(best_res, res)
        if res <= tol * 1e-3 or psi == 0.0:
            break
        if it == max_iter:
            break
        da, db = _jacobian_parts(x[n:], r[n:])
        if sparse:
            scale = sp.diags(np.concatenate([np.ones(n), db]))
            J = (scale @ K + sp.diags(np.concatenate([np.zeros(n), da]))).tocsc()
        else:
            J = K.copy()
            J[n:] *= db[:, None]
            J[n + np.arange(m), n + np.arange(m)] += da
        g = np.asarray(J.T @ F, dtype=float).reshape(-1)
        d = _solve(J, -F, sparse)
        if d is None or float(g @ d) > -_RHO * float(d @ d):
            mu = min(1.0, np.sqrt(2.0 * psi)) + 1e-12
            JtJ = (
                (J.T @ J + mu * sp.identity(N, format="csc"))
                if sparse
                else J.T @ J + mu * np.eye(N)
            )
            d = _solve(JtJ, -g, sparse)
            if d is None or float(g @ d) >= 0.0:
                d = -g
        slope = float(g @ d)
        t = 1.0
        while True:
            x_new = x + t * d
            F_new, r_new = evaluate(x_new)
            psi_new = 0.5 * float(F_new @ F_new)
            if psi_new <= psi + _SIGMA * t * slope:
                break
            t *= 0.5
            if t < 1e-14:
                if res <= tol:
                    break
                raise LCPSolverFailure(
                    "semismooth Newton: line search failed (stationary point of the merit)",
                    method="newton",
                    size=size,
                    pivots=it,
                    residual=best_res,
                    reason="line search",
                )
        if t < 1e-14:
            break
        x, F, r, psi = x_new, F_new, r_new, psi_new

    _, w = mlcp_residual(K, n, c, x, kappa)
    active = x[n:] > w
    x = x * cs
    res, _ = mlcp_residual(K_orig, n, c_orig, x, kappa_orig)
    xp = _polish(K_orig, n, c_orig, active, sparse)
    if xp is not None:
        res_p, _ = mlcp_residual(K_orig, n, c_orig, xp, kappa_orig)
        if res_p < res:
            x, res = xp, res_p
    if not res <= tol:
        raise LCPSolverFailure(
            f"semismooth Newton did not converge in {max_iter} iterations",
            method="newton",
            size=size,
            pivots=it,
            residual=float(min(res, best_res)),
            reason="iteration limit",
            tol=tol,
        )
    return x, active, it, float(res)


def fb_newton_lcp(M: Any, q: np.ndarray, *, tol: float = 1e-9, max_iter: int = 100) -> LCPResult:
    """Semismooth Newton for ``LCP(M, q)`` (``M`` dense or sparse)."""
    q = np.asarray(q, dtype=float).reshape(-1)
    x, active, it, res = fb_newton_mlcp(M, 0, q, tol=tol, max_iter=max_iter)
    w = np.asarray(M @ x, dtype=float).reshape(-1) + q
    return LCPResult(z=x, w=w, active=active, method="newton", iterations=it, residual=res)
