"""Lemke's complementary pivoting method for ``w = M z + q, 0 <= z ⊥ w >= 0``.

Dense tableau, covering vector ``d > 0`` (default all ones), lexicographic
ratio test (rows of the current basis inverse break ties, which rules out
cycling on degenerate problems; the artificial variable ``z0`` leaves as soon
as it is among the tied rows). Lemke finds a solution of every feasible LCP
whose ``M`` is copositive-plus (positive semidefinite, P-matrices, ...); when
it ends on a secondary ray and ``M`` is copositive-plus the LCP has no
solution.

Before pivoting, ``M`` is equilibrated by positive row and column factors
(Ruiz scaling, see :mod:`circuitnsds.solvers._scaling`; the covering vector is
scaled with the rows so that the pivot sequence is unchanged) and ``M``, ``q``
are normalised to max-abs 1, so the pivot tolerances below are relative. The
tableau is rebuilt from the data for the current basis every
``_REINVERT_EVERY`` pivots and whenever a basic variable turns negative. After
the pivoting ends the active set of the final basis is solved again with a
fresh LU factorisation ("polish"), and the more accurate of the two candidate
answers is returned only if its scaled residual is ``<= tol``.

The pivoting loop runs in C (``circuitnsds_lemke`` in ``_lu_native.c``, beside the dense LU
its reinversions use) when the library is built and ``n <= NATIVE_MAX``, else in Python
(:func:`_pivot_python`, the fallback and the reference). The C loop does numpy's arithmetic
in numpy's order, so both take the same pivots and return the same basis and values bit for
bit (tests/test_lemke_native.py); the scaling before the loop and the answer or evidence
after it are Python's either way.
"""

from __future__ import annotations

import ctypes
import functools
import math

import numpy as np

from circuitnsds import native

from ._scaling import ruiz
from .linalg import LIBRARY as LU_LIBRARY
from .linalg import NATIVE_MAX as NATIVE_LU_MAX
from .linalg import RCOND_MIN, factorise
from .residual import kappa_of, lcp_residual
from .result import LCPNoSolution, LCPResult, LCPSolverFailure

__all__ = ["LemkeTableau", "lemke", "lemke_pivot"]

_TIE = 1e-10  # relative tolerance under which two ratios count as tied
_PIV_REL = 1e-11  # a column entry must exceed this fraction of the column's max-abs ...
_PIV_ABS = 1e-13  # ... and this absolute value (after scaling) to be a pivot candidate
_NEG_TOL = 1e-9  # basic values below -_NEG_TOL * scale signal lost feasibility
_REINVERT_EVERY = 50  # recompute the tableau from the data every this many pivots


def _var_name(j: int, n: int) -> str:
    if j < n:
        return f"w[{j}]"
    if j < 2 * n:
        return f"z[{j - n}]"
    return "z0"


def _near_smallest(vals: np.ndarray) -> np.ndarray:
    """Mask of the entries within the tie tolerance of the smallest of ``vals`` (NaN: 0/0 with
    denormal data, counted as ``inf`` so that it never wins; all-NaN keeps every entry, and
    the caller's residual check rejects whatever pivot follows)."""
    vals = np.nan_to_num(vals, nan=np.inf)
    best = vals.min()
    return vals <= best + _TIE * max(1.0, abs(best))


def _lex_argmin(rows: np.ndarray, div: np.ndarray, T: np.ndarray, n: int, prefer: int) -> int:
    """Row of the lexicographic minimum of ``[rhs, B^-1]_i / div_i`` over ``rows``."""
    dv = div[rows]
    for step, j in enumerate([T.shape[1] - 1, *range(n)]):
        with np.errstate(divide="ignore", invalid="ignore"):
            keep = _near_smallest(T[rows, j] / dv)
        rows, dv = rows[keep], dv[keep]
        if rows.size == 1:
            break
        if step == 0 and prefer >= 0 and np.any(rows == prefer):
            return prefer
    return int(rows[0])


# Outcomes of the pivoting loop (the same numbers as enum lemke_status of _lu_native.c).
_SOLVED, _RAY, _PIVOT_LIMIT, _SINGULAR, _NEGATIVE, _NOT_FINITE = range(6)
_NO_MEMORY = -1

NATIVE_MAX = NATIVE_LU_MAX
"""Largest number of pairs pivoted in C (above it: the Python loop). The C loop reinverts
with the C LU, which :func:`~circuitnsds.solvers.linalg.factorise` uses up to the same order,
so that both loops take the same pivots; ``benchmarks/lemke_native.py`` times the two."""


@functools.cache  # (on the path of every Lemke solve)
def _native_lemke():
    """The C pivoting loop ``circuitnsds_lemke`` of the LU's library with its argument types
    declared, or ``None`` (not built, disabled, or stale: :func:`circuitnsds.native.library`)."""
    doubles, integers, size = ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_int64), ctypes.c_int64
    return native.function(LU_LIBRARY, "circuitnsds_lemke",
                           [size, doubles, doubles, integers, size, size, doubles], ctypes.c_int64)


def native_loaded() -> bool:
    """Whether Lemke's pivoting runs in C (up to :data:`NATIVE_MAX` pairs)."""
    return _native_lemke() is not None


_Outcome = tuple[int, np.ndarray, np.ndarray, int, int, float]
"""What the pivoting loops return (see :func:`_pivot_python`)."""


def _pivot_native(run, T0: np.ndarray, max_pivots: int) -> _Outcome | None:
    """:func:`_pivot_python` by the C loop ``run``; ``None`` if it could not allocate. ``T0``:
    a C-ordered float64 array (from_buffer refuses one not contiguous)."""
    n = T0.shape[0]
    if T0.dtype != np.float64 or T0.shape != (n, 2 * n + 2):
        raise ValueError(f"Lemke tableau: float64 of shape (n, 2n + 2) expected, not {T0.dtype} {T0.shape}")
    T = np.empty_like(T0)
    basis = np.empty(n + 2, dtype=np.int64)  # the basis, the pivots, the entering variable
    scalars = np.array([_TIE, _PIV_REL, _PIV_ABS, _NEG_TOL, RCOND_MIN, 0.0])  # (enum lemke_scalar)
    double, integer = ctypes.c_double, ctypes.c_int64
    limit = math.ceil(max_pivots)  # (the Python loop stops at the first pivot count >= the limit)
    status = run(n, double.from_buffer(T0), double.from_buffer(T), integer.from_buffer(basis), limit,
                 _REINVERT_EVERY, double.from_buffer(scalars))
    if status == _NO_MEMORY:
        return None
    return int(status), T, basis[:n], int(basis[n]), int(basis[n + 1]), float(scalars[-1])


def _pivot_python(T0: np.ndarray, max_pivots: int) -> _Outcome:
    """Lemke's pivoting on the tableau ``T0 = [I, -M, -d, q]`` (``n x (2n + 2)``, scaled;
    not modified), from the basis of the ``w``'s.

    Returns:
        ``(status, T, basis, pivots, entering, min_basic)``: one of ``_SOLVED``, ``_RAY``,
        ``_PIVOT_LIMIT``, ``_SINGULAR``, ``_NEGATIVE``, ``_NOT_FINITE``; the final tableau
        and basis (``basis[i]``: the variable, i.e. column, of row ``i``); the pivots done;
        the entering variable (the ray's column for ``_RAY``); the negative basic value of
        ``_NEGATIVE`` (else 0).
    """
    n = T0.shape[0]
    Z0, RHS = 2 * n, 2 * n + 1
    T = T0.copy()
    basis = np.arange(n)

    def reinvert() -> bool:
        """Recompute the tableau from the original data for the current basis."""
        lu = factorise(T0[:, basis])
        if not lu.ok:
            return False
        T[:] = lu.solve(T0)
        for row, var in enumerate(basis):
            T[:, var] = 0.0
            T[row, var] = 1.0
        return bool(np.all(np.isfinite(T)))

    # First pivot: z0 enters at the row of the (lexicographically) most negative q_i/d_i.
    r = _lex_argmin(np.arange(n), -T[:, Z0], T, n, prefer=-1)
    entering = Z0
    pivots = 0
    while True:
        leaving = int(basis[r])
        piv = T[r, entering]
        T[r] /= piv
        col = T[:, entering].copy()
        col[r] = 0.0
        T -= np.outer(col, T[r])
        T[:, entering] = 0.0
        T[r, entering] = 1.0
        basis[r] = entering
        pivots += 1

        if pivots % _REINVERT_EVERY == 0 and not reinvert():
            return _SINGULAR, T, basis, pivots, entering, 0.0
        rhs = T[:, RHS]
        scale = max(1.0, float(rhs.max()))
        lo = float(rhs.min())
        if lo < -_NEG_TOL * scale and reinvert():
            rhs = T[:, RHS]
            scale = max(1.0, float(rhs.max()))
            lo = float(rhs.min())
        if lo < 0.0:
            if lo < -_NEG_TOL * scale or not np.isfinite(lo):
                return _NEGATIVE, T, basis, pivots, entering, lo
            np.maximum(rhs, 0.0, out=rhs)
        if not np.all(np.isfinite(T[r])):
            return _NOT_FINITE, T, basis, pivots, entering, 0.0
        if leaving == Z0:
            return _SOLVED, T, basis, pivots, entering, 0.0
        entering = leaving + n if leaving < n else leaving - n
        if pivots >= max_pivots:
            return _PIVOT_LIMIT, T, basis, pivots, entering, 0.0
        col = T[:, entering]
        thresh = max(_PIV_ABS, _PIV_REL * float(np.abs(col).max()))
        rows = np.flatnonzero(col > thresh)
        if rows.size == 0:
            return _RAY, T, basis, pivots, entering, 0.0
        z0_pos = np.flatnonzero(basis == Z0)
        r = _lex_argmin(rows, col, T, n, prefer=int(z0_pos[0]) if z0_pos.size else -1)


class LemkeTableau:
    """What Lemke's method needs of ``M`` and the covering vector ``d``, computed once: the Ruiz
    factors and the tableau's columns of ``w``, ``z`` and ``z0``. :meth:`pivot` then solves
    ``LCP(M, q)`` for any ``q`` (the MLCP solver keeps one per start basis, whose ``M̂`` is the
    same at every step while ``q̂`` changes).

    Args:
        M: dense ``(n, n)`` float array (not kept).
        d: covering vector, all entries ``> 0`` (default ones).

    Raises:
        ValueError: ``d`` of another length or not positive.
    """

    __slots__ = ("n", "rs", "cs", "s_m", "s_d", "T0")

    def __init__(self, M: np.ndarray, d: np.ndarray | None = None) -> None:
        n = M.shape[0]
        if d is None:
            d = np.ones(n)
        d = np.asarray(d, dtype=float).reshape(-1)
        if d.shape != (n,) or not np.all(d > 0.0):
            raise ValueError("covering vector d must have n strictly positive entries")
        rs, cs = ruiz(M)
        Ms = rs[:, None] * M * cs[None, :]
        ds = rs * d
        self.n = n
        self.rs, self.cs = rs, cs
        self.s_m = (float(np.abs(Ms).max()) if n else 0.0) or 1.0
        self.s_d = float(ds.max()) if n else 1.0
        T0 = np.zeros((n, 2 * n + 2))  # [I, -M, -d, q] scaled, q filled in by pivot
        T0[:, :n] = np.eye(n)
        T0[:, n : 2 * n] = -Ms / self.s_m
        T0[:, 2 * n] = -(ds / self.s_d)
        self.T0 = T0

    def pivot(self, q: np.ndarray, max_pivots: int | None = None) -> tuple[np.ndarray, np.ndarray, int]:
        """:func:`lemke_pivot` of this ``M`` and ``d`` for ``q`` (``(n,)`` float array)."""
        n = self.n
        size = {"n": n}
        if max_pivots is None:
            max_pivots = 50 * (n + 1)
        if n == 0 or (q >= 0.0).all():
            return np.zeros(n), np.zeros(n, dtype=bool), 0
        rs, cs, s_m, s_d = self.rs, self.cs, self.s_m, self.s_d
        qs = rs * q
        s_q = float(np.abs(qs).max())
        Z0, RHS = 2 * n, 2 * n + 1
        T0 = self.T0.copy()
        T0[:, RHS] = qs / s_q

        run = _native_lemke() if n <= NATIVE_MAX else None
        outcome = _pivot_native(run, T0, max_pivots) if run is not None else None
        if outcome is None:
            outcome = _pivot_python(T0, max_pivots)
        status, T, basis, pivots, entering, min_basic = outcome

        if status == _RAY:
            col = T[:, entering]
            direction = np.zeros(2 * n + 1)
            direction[entering] = 1.0
            direction[basis] -= col
            z0_pos = np.flatnonzero(basis == Z0)
            z0_val = float(T[z0_pos[0], RHS]) * s_q / s_d if z0_pos.size else 0.0
            ray_w = direction[:n] * s_q / rs
            ray_z = cs * direction[n : 2 * n] * (s_q / s_m)
            ray_z0 = direction[Z0] * s_q / s_d
            big = max(float(np.abs(ray_w).max()), float(np.abs(ray_z).max()), abs(ray_z0)) or 1.0
            raise LCPNoSolution(
                "Lemke ended on a secondary ray: no solution if M is copositive-plus",
                method="lemke",
                size=size,
                pivots=pivots,
                residual=float("inf"),
                entering=_var_name(entering, n),
                z0=z0_val,
                ray_z=ray_z / big,
                ray_w=ray_w / big,
                ray_z0=ray_z0 / big,
                confirmed_by_enumeration=False,
            )
        if status != _SOLVED:
            message, reason, evidence = {
                _SINGULAR: ("Lemke basis became singular", "singular basis", {}),
                _NEGATIVE: ("Lemke lost feasibility (numerical trouble: ill-conditioned pivots)",
                            "negative basic variable", {"min_basic": min_basic * s_q}),
                _NOT_FINITE: ("Lemke tableau became non-finite", "non-finite tableau", {}),
                _PIVOT_LIMIT: (f"Lemke reached the pivot limit ({max_pivots})", "pivot limit", {}),
            }[status]
            raise LCPSolverFailure(message, method="lemke", size=size, pivots=pivots, residual=float("inf"),
                                   reason=reason, **evidence)

        zn = np.zeros(n)
        active = np.zeros(n, dtype=bool)
        values = T[:, RHS].tolist()
        for row, var in enumerate(basis.tolist()):  # (a loop: cheaper than numpy's masks at this size)
            if n <= var < 2 * n:
                zn[var - n] = values[row]
                active[var - n] = True
        return cs * zn * (s_q / s_m), active, pivots


def lemke_pivot(
    M: np.ndarray,
    q: np.ndarray,
    *,
    d: np.ndarray | None = None,
    max_pivots: int | None = None,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Run Lemke's pivoting and return the raw tableau answer.

    The pivoting runs in C (:func:`native_loaded`, up to :data:`NATIVE_MAX` pairs), else in
    Python (:func:`_pivot_python`); both take the same pivots. The scaling before and the
    evidence after are Python's either way (:class:`LemkeTableau`, which keeps the scaling
    of ``M`` for further ``q``).

    Args:
        M: dense ``(n, n)`` float array.
        q: ``(n,)`` float array.
        d: covering vector, all entries ``> 0`` (default ones).
        max_pivots: pivot limit (default ``50 * (n + 1)``).

    Returns:
        ``(z, active, pivots)``: ``z`` read from the final tableau (not verified),
        ``active`` the mask of pairs whose ``z`` is basic, the number of pivots.

    Raises:
        LCPNoSolution: secondary ray (evidence: ``ray_z``, ``ray_w``, ``ray_z0``,
            ``entering``, ``z0``).
        LCPSolverFailure: pivot limit or numerical trouble.
    """
    n = q.shape[0]
    if n == 0 or (q >= 0.0).all():
        return np.zeros(n), np.zeros(n, dtype=bool), 0
    return LemkeTableau(M, d).pivot(q, max_pivots)


def solve_active_set(M: np.ndarray, q: np.ndarray, active: np.ndarray) -> np.ndarray | None:
    """``z`` with ``z_ᾱ = 0`` and ``M_αα z_α = -q_α``; ``None`` if ``M_αα`` is singular."""
    n = q.shape[0]
    z = np.zeros(n)
    idx = np.flatnonzero(active)
    if idx.size == 0:
        return z
    lu = factorise(M[np.ix_(idx, idx)])
    if lu.rcond == 0.0:  # an exactly zero pivot, or not finite
        return None
    sol = lu.solve(-q[idx])
    if not np.all(np.isfinite(sol)):
        return None
    z[idx] = sol
    return z


def lemke(
    M: np.ndarray,
    q: np.ndarray,
    *,
    d: np.ndarray | None = None,
    max_pivots: int | None = None,
    tol: float = 1e-9,
) -> LCPResult:
    """Solve ``LCP(M, q)`` by Lemke's method and verify the answer.

    Args:
        M: dense ``(n, n)`` matrix.
        q: ``(n,)`` vector.
        d: covering vector (default ones).
        max_pivots: pivot limit (default ``50 * (n + 1)``).
        tol: largest accepted scaled residual.

    Returns:
        :class:`LCPResult` with ``method="lemke"`` and ``iterations`` = pivots.

    Raises:
        LCPNoSolution: secondary ray.
        LCPSolverFailure: pivot limit, numerical trouble, or residual ``> tol``.
    """
    M = np.asarray(M, dtype=float)
    q = np.asarray(q, dtype=float).reshape(-1)
    n = q.shape[0]
    z_t, active, pivots = lemke_pivot(M, q, d=d, max_pivots=max_pivots)
    kappa = kappa_of(M)
    res_t, w_t = lcp_residual(M, q, z_t, kappa)
    best = (res_t, z_t, w_t)
    if res_t > 1e-14:
        z_p = solve_active_set(M, q, active)
        if z_p is not None:
            res_p, w_p = lcp_residual(M, q, z_p, kappa)
            if res_p < res_t:
                best = (res_p, z_p, w_p)
    res, z, w = best
    if not res <= tol:
        raise LCPSolverFailure(
            "Lemke's answer fails the residual check (numerical trouble)",
            method="lemke",
            size={"n": n},
            pivots=pivots,
            residual=float(res),
            reason="residual above tol",
            tol=tol,
        )
    return LCPResult(
        z=z, w=w, active=active, method="lemke", iterations=pivots, residual=float(res)
    )
