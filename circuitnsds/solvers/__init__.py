"""Complementarity solvers: LCP and mixed LCP (MLCP) for circuits with ideal diodes.

Sign conventions::

    LCP:   w = M z + q,                          0 <= z ⊥ w >= 0
    MLCP:  A u + C z + a = 0,  w = D u + B z + b, 0 <= z ⊥ w >= 0,  u free

Public API::

    solve_lcp(M, q, *, method="auto", guess=None, tol=1e-9, max_pivots=None) -> LCPResult
    solve_mlcp(A, C, D, B, a, b, *, method="auto", guess=None, tol=1e-9) -> MLCPResult
    MLCPSolver(A, C, D, B, *, cache_size=16, tol=1e-9).solve(a, b, guess=None)

Every returned result satisfies ``result.residual <= tol`` (the scaled residual
of :mod:`circuitnsds.solvers.residual`); otherwise :class:`LCPNoSolution` or
:class:`LCPSolverFailure` is raised. See ``docs/solvers.md``.
"""

from .enumeration import enumerate_lcp, enumerate_mlcp
from .lcp import solve_lcp
from .lemke import lemke
from .mlcp import MLCPSolver, solve_mlcp
from .newton import fb_newton_lcp, fb_newton_mlcp
from .residual import lcp_residual, mlcp_residual
from .result import LCPError, LCPNoSolution, LCPResult, LCPSolverFailure, MLCPResult

__all__ = [
    "solve_lcp",
    "solve_mlcp",
    "MLCPSolver",
    "LCPResult",
    "MLCPResult",
    "LCPError",
    "LCPNoSolution",
    "LCPSolverFailure",
    "lemke",
    "enumerate_lcp",
    "enumerate_mlcp",
    "fb_newton_lcp",
    "fb_newton_mlcp",
    "lcp_residual",
    "mlcp_residual",
]
