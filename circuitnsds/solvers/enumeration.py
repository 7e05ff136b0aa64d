"""Exhaustive enumeration of active sets — an exact oracle for small problems.

For every active set ``α`` (``2**m`` of them) the linear system with ``w_α = 0``
and ``z_ᾱ = 0`` is solved and the answer kept if its scaled residual is
``<= tol``. Active sets whose bordered matrix is numerically singular are
revisited at the end with a linear-programming feasibility problem
(``scipy.optimize.linprog``/HiGHS) over the face ``{z_α >= 0, w_α = 0,
w_ᾱ >= 0}``, so that solutions which are not isolated (singular PSD ``M``) are
also found. The solution set of an (M)LCP is the union of these faces, so the
search is complete up to the LP's feasibility tolerance.

Sizes above :data:`MAX_ENUM` raise ``ValueError`` unless ``force=True``.
"""

from __future__ import annotations

import hashlib

import numpy as np

from .linalg import factorise
from .residual import kappa_of, mlcp_residual
from .result import LCPNoSolution, LCPResult, LCPSolverFailure

__all__ = ["MAX_ENUM", "enumerate_mlcp", "enumerate_lcp"]

#: Largest number of complementarity pairs enumerated without ``force=True``.
MAX_ENUM = 12
#: At most this many face LPs (three scipy ``linprog`` calls each, ~5 ms apiece mostly in
#: scipy's checks) per enumeration: past it the enumeration stops with
#: ``LCPSolverFailure(reason="budget")`` rather than let one step cost seconds.
MAX_FACE_LPS = 16
#: At most this much factorisation work per enumeration [flops, ``size³`` per active set]:
#: 1024 sets of a 2000-unknown system would take minutes; past it the enumeration stops
#: as above. (~2 s on one core.)
MAX_ENUM_FLOPS = 2e10


def _face_lp(K: np.ndarray, n: int, c: np.ndarray, mask: np.ndarray,
             objective: np.ndarray | None = None, box: np.ndarray | None = None) -> np.ndarray | None:
    """A point of the face of ``mask`` found by an LP, or ``None``; with ``objective``
    (weights of ``[u; z_α]``) the point minimising it, ``u`` kept within ``box``
    (``(n, 2)`` bounds) if given."""
    from scipy.optimize import linprog  # imported on first use: it costs ~0.5 s

    m = mask.shape[0]
    idx = np.flatnonzero(mask)
    inact = np.flatnonzero(~mask)
    sel = np.concatenate([np.arange(n), n + idx])
    nv = sel.size
    if nv == 0:
        return np.zeros(n + m) if np.all(c[n:] >= 0) else None
    A_eq = K[np.ix_(sel, sel)]
    b_eq = -c[sel]
    A_ub = -K[np.ix_(n + inact, sel)] if inact.size else None
    b_ub = c[n + inact] if inact.size else None
    bounds = ([(None, None)] * n if box is None else [tuple(b) for b in box]) + [(0.0, None)] * idx.size
    try:
        out = linprog(
            np.zeros(nv) if objective is None else objective,
            A_ub=A_ub,
            b_ub=b_ub,
            A_eq=A_eq,
            b_eq=b_eq,
            bounds=bounds,
            method="highs",
            options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10},
        )
    except ValueError:
        return None
    if out.status != 0 or out.x is None:
        return None
    x = np.zeros(n + m)
    x[sel] = out.x
    return x


def _equilibrated_solve(A: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """``A⁻¹ b`` through ``A`` scaled to unit rows, then unit columns, or ``None`` when even
    that is singular. A face that only scaling makes look singular (a 1e9 Ω off-switch
    beside a 1 kH inductor at a 0.1 µs step: rcond 5e-21 unscaled, 0.2 scaled) has this one
    point, found without the feasibility LP; whether its free unknowns are determined (a
    1e-15 Ω resistor: its current is not, in doubles) is still asked of the LPs, once per
    face (:func:`_free_unknowns_varying`)."""
    rows = np.abs(A).max(axis=1)
    if not (rows > 0).all():
        return None
    scaled = A / rows[:, None]
    columns = np.abs(scaled).max(axis=0)
    if not (columns > 0).all():
        return None
    lu = factorise(scaled / columns[None, :])
    if not lu.ok:
        return None
    return lu.solve(b / rows) / columns


_VERDICTS: dict[bytes, np.ndarray] = {}
VERDICTS_KEPT = 256
"""Faces whose :func:`_varying_free_unknowns` verdict is kept (by matrix and active set):
a transient meets the same singular face step after step, with new right-hand sides."""


def _free_unknowns_varying(K: np.ndarray, n: int, c: np.ndarray, mask: np.ndarray,
                           x: np.ndarray) -> np.ndarray:
    """:func:`_varying_free_unknowns`, its two LPs run once per matrix and active set (which
    free unknowns a face leaves undetermined is a property of its equations)."""
    key = hashlib.blake2b(np.ascontiguousarray(K).tobytes() + mask.tobytes() + n.to_bytes(8, "little"),
                          digest_size=16).digest()
    varying = _VERDICTS.get(key)
    if varying is None:
        varying = _varying_free_unknowns(K, n, c, mask, x)
        if len(_VERDICTS) >= VERDICTS_KEPT:
            _VERDICTS.clear()
        _VERDICTS[key] = varying
    return varying


def _varying_free_unknowns(K: np.ndarray, n: int, c: np.ndarray, mask: np.ndarray,
                           x: np.ndarray) -> np.ndarray:
    """Indices of the free unknowns ``u`` that are not the same at every point of the
    (singular) face of ``mask``: the extremes of a random combination of ``u`` over the face
    are compared, ``u`` boxed around ``x`` (all of ``u`` when an LP fails).

    Pair unknowns may legitimately vary over a face (two ideal diodes in parallel split a
    current arbitrarily); a free unknown that varies is a node voltage or current that
    nothing in the circuit determines, and the LP's point would be an arbitrary answer.
    """
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    weights = np.zeros(n + int(mask.sum()))
    weights[:n] = np.random.default_rng(0).uniform(0.5, 1.5, n)
    size = 1.0 + np.abs(x[:n]).max()
    box = np.column_stack([x[:n] - 1e3 * size, x[:n] + 1e3 * size])  # bounded, around x
    low = _face_lp(K, n, c, mask, weights, box)
    high = _face_lp(K, n, c, mask, -weights, box)
    if low is None or high is None:  # the LP failed: nothing can be said of the face
        return np.arange(n)
    spread = np.abs(low[:n] - high[:n])
    return np.flatnonzero(spread > 1e-6 * size)


def enumerate_mlcp(
    K: np.ndarray,
    n: int,
    c: np.ndarray,
    *,
    tol: float = 1e-9,
    force: bool = False,
    use_lp: bool = True,
) -> tuple[np.ndarray, np.ndarray, int, float] | None:
    """Search all active sets of the MLCP ``(K, c)`` with ``n`` free unknowns.

    Args:
        K: dense ``[[A, C], [D, B]]``.
        n: number of free unknowns.
        c: ``[a; b]``.
        tol: accepted scaled residual.
        force: allow more than :data:`MAX_ENUM` pairs.
        use_lp: revisit singular active sets with an LP.

    Returns:
        ``(x, active, tried, residual)`` for the first solution found (``x = [u; z]``),
        or ``None`` when no active set gives a solution.

    Raises:
        ValueError: more than :data:`MAX_ENUM` pairs and ``force`` is false.
        LCPSolverFailure: (``reason="undetermined"``) solutions exist only on singular
            faces along which free unknowns vary: the answer would be arbitrary.
    """
    m = K.shape[0] - n
    if m > MAX_ENUM and not force:
        raise ValueError(f"enumeration of {m} pairs ({2**m} active sets) needs force=True")
    kappa = kappa_of(K)
    bits = np.arange(m)
    singular: list[tuple[np.ndarray, np.ndarray | None]] = []
    tried, work = 0, 0.0
    for code in range(2**m):
        mask = ((code >> bits) & 1).astype(bool)
        tried += 1
        sel = np.concatenate([np.arange(n), n + np.flatnonzero(mask)])
        work += float(sel.size) ** 3
        if work > MAX_ENUM_FLOPS and not force:
            _out_of_budget(n, m, tried, f"{MAX_ENUM_FLOPS:.0e} flops of factorisations")
        x = np.zeros(n + m)
        if sel.size:
            lu = factorise(K[np.ix_(sel, sel)])
            if not lu.ok:
                singular.append((mask, _equilibrated_solve(K[np.ix_(sel, sel)], -c[sel])))
                continue
            x[sel] = lu.solve(-c[sel])
        res, _ = mlcp_residual(K, n, c, x, kappa)
        if res <= tol:
            return x, mask, tried, res
    undetermined: list[np.ndarray] = []
    searched = 0  # faces that needed linear programs
    for mask, scaled in singular:
        if not use_lp:
            break
        sel = np.concatenate([np.arange(n), n + np.flatnonzero(mask)])
        x = np.zeros(n + m)
        if scaled is not None:  # singular only in its scaling: one point, or no solution here
            if not np.isfinite(scaled).all():
                continue
            x[sel] = scaled
        else:
            if searched >= MAX_FACE_LPS and not force:
                _out_of_budget(n, m, tried, f"{MAX_FACE_LPS} singular faces searched by LP")
            searched += 1
            tried += 1
            x = _face_lp(K, n, c, mask)
            if x is None:
                continue
        res, _ = mlcp_residual(K, n, c, x, kappa)
        if res <= tol:
            varying = _free_unknowns_varying(K, n, c, mask, x)
            if not varying.size:
                return x, mask, tried, res
            undetermined.append(varying)
    if undetermined:
        raise LCPSolverFailure(
            "the equations are singular: the solutions leave some unknowns undetermined "
            "(any value would do), so none is returned",
            method="enum", size={"n": n, "m": m}, pivots=tried, residual=float("inf"),
            reason="undetermined", undetermined=undetermined[0])
    return None


def _out_of_budget(n: int, m: int, tried: int, spent: str) -> None:
    raise LCPSolverFailure(
        f"the enumeration of the {2**m} active sets stopped at its budget ({spent}; {tried} "
        "tries): no verified solution so far, and more would cost seconds per step",
        method="enum", size={"n": n, "m": m}, pivots=tried, residual=float("inf"), reason="budget")


def enumerate_lcp(
    M: np.ndarray, q: np.ndarray, *, tol: float = 1e-9, force: bool = False
) -> LCPResult:
    """Solve ``LCP(M, q)`` by enumeration (``n <= MAX_ENUM`` unless ``force``).

    Raises:
        LCPNoSolution: no active set gives a solution (with ``confirmed_by_enumeration=True``).
        ValueError: too large and not forced.
    """
    M = np.asarray(M, dtype=float)
    q = np.asarray(q, dtype=float).reshape(-1)
    found = enumerate_mlcp(M, 0, q, tol=tol, force=force)
    if found is None:
        raise LCPNoSolution(
            "no active set solves the LCP (exhaustive enumeration)",
            method="enum",
            size={"n": q.shape[0]},
            pivots=2 ** q.shape[0],
            residual=float("inf"),
            confirmed_by_enumeration=True,
        )
    z, mask, tried, res = found
    return LCPResult(z=z, w=M @ z + q, active=mask, method="enum", iterations=tried, residual=res)
