"""Integrals of an exponential polynomial over intervals, in closed form: the charge each
pair's current carries between two output rows (the impulses a trajectory reports).

For a term ``τ^p e^{ντ}`` and an interval ``[a, a + w]``, with ``τ = a + s``,

    ∫ τ^p e^{ντ} dτ = e^{νa} Σ_{q<=p} C(p, q) a^{p-q} J_q(w),    J_q(w) = ∫_0^w s^q e^{νs} ds,

and ``J_q`` is summed as its Taylor series ``Σ_k ν^k w^{q+k+1} / (k! (q+k+1))`` where
``|ν w| < 1`` (the closed form ``J_0 = (e^{νw} − 1)/ν`` loses digits there), else by the
recursion ``J_q = (w^q e^{νw} − q J_{q−1}) / ν``.
"""

from __future__ import annotations

import math

import numpy as np

from circuitnsds.engine.exact.exppoly import ExpPoly

SERIES_TERMS = 24
"""Taylor terms of ``J_q`` where ``|ν w| < 1`` (the next one is below 1/24! ≈ 1.6e-24)."""


def _moments(nu: np.ndarray, w: np.ndarray, top: int) -> list[np.ndarray]:
    """``J_q(w)`` for ``q = 0..top``, shape ``(intervals, terms)`` each (``nu`` per term, ``w``
    per interval). ``ν = 0`` (constants and ramps, most terms) is ``w^{q+1}/(q+1)``; the series
    is summed only where ``0 < |ν w| < 1``."""
    nw = w[:, None] * nu[None, :]
    size = np.abs(nw)
    plain = np.broadcast_to(nu[None, :] == 0, nw.shape)
    small = (size < 1.0) & ~plain
    safe_nu = np.where(nu == 0, 1.0, nu)[None, :]
    grown = np.exp(nw)
    where = np.nonzero(small)
    few = nw[where]
    widths = w[where[0]]
    moments: list[np.ndarray] = []
    for q in range(top + 1):
        if q == 0:
            value = np.expm1(nw) / safe_nu
        else:
            value = ((w ** q)[:, None] * grown - q * moments[q - 1]) / safe_nu
        value = np.where(plain, (w ** (q + 1) / (q + 1))[:, None], value)
        if few.size:
            series = np.zeros(few.shape, complex)
            term = np.ones(few.shape, complex)  # (νw)^k / k!
            for k in range(SERIES_TERMS):
                series += term / (q + k + 1)
                term = term * few / (k + 1)
                if k % 4 == 3 and not np.any(np.abs(term) > 1e-17):  # (|νw| small: a few terms)
                    break
            value[where] = series * widths ** (q + 1)
        moments.append(value)
    return moments


def interval_integrals(f: ExpPoly, begins: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """``∫_{begins[i]}^{ends[i]} f(τ) dτ`` for each interval, shape ``(intervals, f.size)``
    (``f`` in the units of its values, times seconds)."""
    begins = np.asarray(begins, dtype=float)
    widths = np.asarray(ends, dtype=float) - begins
    if not f.powers.size or not begins.size:
        return np.zeros((begins.size, f.size))
    top = int(f.powers.max())
    moments = _moments(f.exponents, widths, top)
    weights = np.zeros((begins.size, f.powers.size), complex)
    for p in range(top + 1):
        which = f.powers == p
        if not which.any():
            continue
        total = np.zeros((begins.size, int(which.sum())), complex)
        for q in range(p + 1):
            total += math.comb(p, q) * (begins ** (p - q))[:, None] * moments[q][:, which]
        weights[:, which] = total
    weights *= np.exp(begins[:, None] * f.exponents[None, :])
    # (row by row: a matrix product's summation order depends on the number of rows)
    return np.sum(weights[:, :, None] * f.coefficients[None, :, :], axis=1).real
