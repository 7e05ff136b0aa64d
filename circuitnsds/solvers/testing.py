"""Generators of test problems for the LCP solvers (used by the tests and benchmarks).

All functions take a ``numpy.random.Generator`` so that problems are reproducible.
"""

from __future__ import annotations

import numpy as np

__all__ = ["p_matrix", "psd_matrix", "lcp_with_solution", "monotone_mlcp"]


def p_matrix(n: int, rng: np.random.Generator, kind: str = "pd") -> np.ndarray:
    """A random P-matrix (every principal minor > 0), so ``LCP(M, q)`` has one solution.

    Args:
        n: size.
        rng: random generator.
        kind: ``"pd"`` — positive definite, non-symmetric ``G Gᵀ + S + 0.1 I`` (``S`` skew);
            ``"diagdom"`` — strictly row diagonally dominant with positive diagonal;
            ``"triangular"`` — lower triangular with positive diagonal (a P-matrix
            that is not positive definite in general).
    """
    if kind == "pd":
        G = rng.standard_normal((n, n))
        S = rng.standard_normal((n, n))
        return G @ G.T / n + (S - S.T) / np.sqrt(n) + 0.1 * np.eye(n)
    if kind == "diagdom":
        M = rng.standard_normal((n, n))
        np.fill_diagonal(M, 0.0)
        diag = np.abs(M).sum(axis=1) * (1.0 + rng.uniform(0.05, 1.0, n)) + rng.uniform(0.1, 1.0, n)
        return M + np.diag(diag)
    if kind == "triangular":
        # off-diagonal scale 2/sqrt(n): usually not positive definite, yet well conditioned
        M = np.tril(rng.standard_normal((n, n)) * (2.0 / np.sqrt(n)), k=-1)
        return M + np.diag(rng.uniform(0.5, 2.0, n))
    raise ValueError(f"unknown kind {kind!r}")


def psd_matrix(n: int, rng: np.random.Generator, rank: int | None = None) -> np.ndarray:
    """A positive semidefinite (possibly singular, non-symmetric) ``G Gᵀ + S``, ``S`` skew.

    Args:
        n: size.
        rng: random generator.
        rank: rank of ``G Gᵀ`` (default ``n``); smaller gives a singular symmetric part.
    """
    r = n if rank is None else rank
    G = rng.standard_normal((n, r))
    S = rng.standard_normal((n, n))
    return G @ G.T / max(r, 1) + (S - S.T) / np.sqrt(n)


def lcp_with_solution(
    M: np.ndarray, rng: np.random.Generator, frac_active: float = 0.5, degenerate: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A right-hand side ``q`` for which a known ``(z*, active)`` solves ``LCP(M, q)``.

    Args:
        M: the matrix.
        rng: random generator.
        frac_active: probability that a pair is active (``z* > 0``).
        degenerate: probability that a pair has ``z*_i = w*_i = 0``.

    Returns:
        ``(q, z_star, active)``.
    """
    n = M.shape[0]
    active = rng.random(n) < frac_active
    z = np.where(active, rng.uniform(0.1, 2.0, n), 0.0)
    w = np.where(active, 0.0, rng.uniform(0.1, 2.0, n))
    deg = rng.random(n) < degenerate
    z[deg] = 0.0
    w[deg] = 0.0
    q = w - M @ z
    return q, z, active


def monotone_mlcp(
    n: int, m: int, rng: np.random.Generator, singular_a: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A random monotone MLCP shaped like a passive circuit, with a known solution.

    ``K = [[A, C], [-Cᵀ, B]]`` with ``A`` symmetric positive semidefinite
    (singular when ``singular_a``) and ``B`` positive semidefinite, so
    ``K + Kᵀ >= 0``. The equation rows are then multiplied by random signs and
    scales (an equivalent problem, as the sign choices of nodal analysis give),
    so ``A`` itself is indefinite.

    Returns:
        ``(A, C, D, B, a, b)``.
    """
    L = rng.standard_normal((n, max(n - 1, 0) if singular_a else n))
    A = L @ L.T + (0.0 if singular_a else 0.1) * np.eye(n)
    G = rng.standard_normal((m, m))
    S = rng.standard_normal((m, m))
    B = G @ G.T / m + (S - S.T) / 2
    C = rng.standard_normal((n, m))
    D = -C.T
    act = rng.random(m) < 0.5
    z = np.where(act, rng.uniform(0.1, 2, m), 0.0)
    w = np.where(act, 0.0, rng.uniform(0.1, 2, m))
    u = rng.standard_normal(n)
    a = -(A @ u + C @ z)
    b = w - (D @ u + B @ z)
    rows = rng.choice([-1.0, 1.0], n) * np.exp(rng.uniform(-3, 3, n))
    return rows[:, None] * A, rows[:, None] * C, D, B, rows * a, b
