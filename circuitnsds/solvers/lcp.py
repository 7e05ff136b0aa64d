"""``solve_lcp``: one entry point for ``w = M z + q, 0 <= z ⊥ w >= 0``."""

from __future__ import annotations

from typing import Any

import numpy as np

from ._inputs import as_dense, as_vector, is_sparse
from .enumeration import enumerate_lcp
from .lemke import lemke
from .mlcp import MLCPSolver
from .newton import fb_newton_lcp
from .result import LCPError, LCPResult, MLCPResult

__all__ = ["solve_lcp"]

_METHODS = ("auto", "lemke", "direct", "enum", "newton")


def _as_lcp(res: MLCPResult) -> LCPResult:
    """The LCP's result from that of the MLCP without free unknowns (``res.u`` is empty)."""
    return LCPResult(z=res.z, w=res.w, active=res.active, method=res.method, iterations=res.iterations,
                     residual=res.residual)


def solve_lcp(
    M: Any,
    q: Any,
    *,
    method: str = "auto",
    guess: Any = None,
    tol: float = 1e-9,
    max_pivots: int | None = None,
) -> LCPResult:
    """Solve the LCP ``w = M z + q, 0 <= z ⊥ w >= 0``.

    Args:
        M: ``(n, n)`` dense ndarray or scipy.sparse matrix.
        q: ``(n,)`` vector.
        method:
            ``"auto"`` — mode reuse when ``guess`` is given, else (or when the
            guess is wrong) Lemke; if Lemke fails numerically, enumeration
            (``n <= 10``) then semismooth Newton; a Lemke secondary ray is
            confirmed by enumeration when ``n <= 10``.
            ``"lemke"`` — Lemke only. ``"direct"`` — solve the linear system of
            ``guess`` only (``LCPSolverFailure`` if it is not a solution).
            ``"enum"`` — exhaustive enumeration (``n <= 12``).
            ``"newton"`` — semismooth Newton on Fischer–Burmeister (sparse
            ``M`` stays sparse).
        guess: boolean mask or index array of the pairs expected active
            (``z_i > 0``, ``w_i = 0``).
        tol: largest accepted scaled residual (see
            :func:`circuitnsds.solvers.residual.lcp_residual`).
        max_pivots: Lemke pivot limit (default ``50 * (n + 1)``).

    Returns:
        :class:`LCPResult`; ``result.residual <= tol`` always holds.

    Raises:
        LCPNoSolution: Lemke secondary ray (proof of infeasibility when ``M`` is
            copositive-plus) or enumeration found no solution.
        LCPSolverFailure: pivot/iteration limit, numerical trouble, wrong guess
            for ``"direct"``.
        ValueError: bad shapes, NaN input, unknown method, ``"enum"`` with
            ``n > 12``, ``"direct"`` without guess.
    """
    if method not in _METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {_METHODS}")
    q = as_vector(q, name="q")
    n = q.shape[0]
    if is_sparse(M):
        if M.shape != (n, n):
            raise ValueError(f"M has shape {M.shape}, expected {(n, n)}")
        if method == "newton":
            return fb_newton_lcp(M, q, tol=tol)
    Md = as_dense(M, (n, n), "M")
    if method == "newton":
        return fb_newton_lcp(Md, q, tol=tol)
    if method == "lemke":
        return lemke(Md, q, max_pivots=max_pivots, tol=tol)
    if method == "enum":
        return enumerate_lcp(Md, q, tol=tol)
    empty = np.zeros((0, 0))
    solver = MLCPSolver(
        empty, np.zeros((0, n)), np.zeros((n, 0)), Md, tol=tol, max_pivots=max_pivots, cache_size=1
    )
    try:
        if method == "direct":
            return _as_lcp(solver.solve_direct(np.zeros(0), q, guess))
        return _as_lcp(solver.solve(np.zeros(0), q, guess))
    except LCPError as err:
        err.size = {"n": n}  # the LCP is an MLCP without free unknowns; report its size
        raise
