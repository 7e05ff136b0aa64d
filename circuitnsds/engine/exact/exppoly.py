"""Vector-valued exponential polynomials ``f(τ) = Re Σ_j c_j τ^{p_j} e^{ν_j τ}``.

Every solution of a linear time-invariant system driven by sources that are themselves
exponential polynomials (constants, ramps, damped sines, decays) is one: this is the
closed form the exact integrator evaluates, differentiates and bounds. ``c_j`` are complex
vectors (one per term, rows of :attr:`ExpPoly.coefficients`), ``p_j`` small non-negative
integers, ``ν_j`` complex exponents [1/s]; a real function carries each complex exponent
with its conjugate, so taking the real part loses nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ExpPoly:
    """``Re Σ_j coefficients[j] τ^powers[j] e^{exponents[j] τ}``, a function of ``τ`` [s]
    with values of length :attr:`size`."""

    coefficients: np.ndarray
    """``(terms, size)`` complex."""
    powers: np.ndarray
    """``(terms,)`` int."""
    exponents: np.ndarray
    """``(terms,)`` complex [1/s]."""

    @property
    def size(self) -> int:
        return self.coefficients.shape[1]

    @classmethod
    def zero(cls, size: int) -> ExpPoly:
        return cls(np.zeros((0, size), complex), np.zeros(0, int), np.zeros(0, complex))

    @classmethod
    def constant(cls, value: np.ndarray) -> ExpPoly:
        value = np.atleast_1d(np.asarray(value, dtype=complex))
        return cls(value[None, :], np.zeros(1, int), np.zeros(1, complex))

    def __add__(self, other: ExpPoly) -> ExpPoly:
        return ExpPoly(np.vstack([self.coefficients, other.coefficients]),
                       np.concatenate([self.powers, other.powers]),
                       np.concatenate([self.exponents, other.exponents]))

    def map(self, matrix: np.ndarray) -> ExpPoly:
        """``matrix @ f(τ)``."""
        return ExpPoly(self.coefficients @ np.asarray(matrix).T, self.powers, self.exponents)

    def row(self, vector: np.ndarray) -> ExpPoly:
        """The scalar function ``vector · f(τ)``."""
        return self.map(np.asarray(vector, dtype=float)[None, :])

    def merged(self) -> ExpPoly:
        """The same function with the terms of equal power and exponent summed (and terms that
        sum to zero dropped): cancelling terms would otherwise weaken every bound on ``f``."""
        first: dict[tuple[int, complex], int] = {}
        target = np.empty(len(self.powers), int)
        for j, key in enumerate(zip(self.powers.tolist(), self.exponents.tolist())):
            target[j] = first.setdefault(key, len(first))
        if len(first) == len(self.powers):
            summed, powers, exponents = self.coefficients, self.powers, self.exponents
        else:
            summed = np.zeros((len(first), self.size), complex)
            np.add.at(summed, target, self.coefficients)
            keys = list(first)
            powers = np.array([k[0] for k in keys], int)
            exponents = np.array([k[1] for k in keys], complex)
        keep = np.any(summed != 0, axis=1)
        if keep.all():
            return self if summed is self.coefficients else ExpPoly(summed, powers, exponents)
        return ExpPoly(summed[keep], powers[keep], exponents[keep])

    def __call__(self, tau: float) -> np.ndarray:
        weights = tau ** self.powers * np.exp(self.exponents * tau)
        return (weights @ self.coefficients).real

    def magnitudes(self, tau: float) -> np.ndarray:
        """``Σ_j |c_j| |τ^p_j e^{ν_j τ}|`` per component: the size of what was summed to
        evaluate ``f(τ)``, whose round-off is a few ulps of it."""
        weights = np.abs(tau ** self.powers * np.exp(self.exponents * tau))
        return weights @ np.abs(self.coefficients)

    def derivative(self) -> ExpPoly:
        """``f'(τ)``: ``d/dτ τ^p e^{ντ} = p τ^{p-1} e^{ντ} + ν τ^p e^{ντ}``."""
        lowered = self.powers > 0
        return ExpPoly(
            np.vstack([self.coefficients * self.exponents[:, None],
                       self.coefficients[lowered] * self.powers[lowered, None]]),
            np.concatenate([self.powers, self.powers[lowered] - 1]),
            np.concatenate([self.exponents, self.exponents[lowered]]))

    def shifted(self, start: float) -> ExpPoly:
        """``g(τ) = f(start + τ)`` (binomial expansion of ``(start + τ)^p``)."""
        coefficients, powers, exponents = [], [], []
        scale = np.exp(self.exponents * start)
        for j, p in enumerate(self.powers):
            for q in range(p + 1):
                coefficients.append(self.coefficients[j] * scale[j] * math.comb(p, q) * start ** (p - q))
                powers.append(q)
                exponents.append(self.exponents[j])
        if not coefficients:
            return ExpPoly.zero(self.size)
        return ExpPoly(np.array(coefficients), np.array(powers), np.array(exponents))

    def term_magnitudes(self, tau: float) -> np.ndarray:
        """``|c_j| τ^p_j |e^{ν_j τ}|`` per term (the 2-norm of each term's vector)."""
        return (np.linalg.norm(self.coefficients, axis=1) * tau ** self.powers
                * np.exp(self.exponents.real * tau))


def response(eigenvalues: np.ndarray, start: np.ndarray, forcing: ExpPoly) -> ExpPoly:
    """The solution ``u(τ)`` of the decoupled system ``u_k' = λ_k u_k + b_k(τ)``, ``u(0) = start``,
    for a forcing ``b`` that is an exponential polynomial (in the modal coordinates).

    Uses ``∫_0^τ e^{λ(τ-s)} s^p e^{μs} ds``; with ``δ = μ - λ ≠ 0`` it is
    ``Σ_{q<=p} (-1)^{p-q} p!/q! δ^{-(p-q+1)} τ^q e^{μτ}  -  (-1)^p p! δ^{-(p+1)} e^{λτ}``
    (``p = 0``: ``(e^{μτ} - e^{λτ})/δ``); when ``δ = 0`` (resonance: a mode with the
    forcing's own exponent) it is ``τ^{p+1} e^{λτ}/(p+1)``. The ``e^{λ_k τ}`` parts of every
    forcing term join the free response's term of mode ``k``: one term per mode.
    """
    n = len(eigenvalues)
    eigenvalues = eigenvalues.astype(complex)
    c, p, mu = forcing.coefficients, forcing.powers, forcing.exponents
    if p.size and p.max() > 20:
        raise ValueError(f"forcing power {p.max()} > 20 is not supported")
    delta = mu[:, None] - eigenvalues[None, :]                              # (terms, modes)
    # a mode counts as resonant when δ is round-off of the exponents' size
    resonant = np.abs(delta) <= 1e-12 * np.maximum(np.abs(mu)[:, None], np.abs(eigenvalues)) + 1e-300
    live = np.where(resonant, 0, c)
    inverse = 1 / np.where(resonant, 1.0, delta)
    factorials = np.array([math.factorial(int(k)) for k in range(int(p.max(initial=0)) + 1)], float)
    sign = np.where(p % 2 == 0, 1.0, -1.0)
    tails = (sign * factorials[p])[:, None] * live * inverse ** (p + 1)[:, None]
    free = start.astype(complex) - np.sum(tails, axis=0)
    diagonal = np.zeros((n, n), complex)
    diagonal[np.arange(n), np.arange(n)] = free
    stacked, all_powers, all_exponents = [diagonal], [np.zeros(n, int)], [eigenvalues]
    for q in range(int(p.max(initial=-1)) + 1):
        terms = np.flatnonzero(p >= q)
        pq = p[terms] - q
        factor = np.where(pq % 2 == 0, 1.0, -1.0) * factorials[p[terms]] / factorials[q]
        stacked.append(factor[:, None] * live[terms] * inverse[terms] ** (pq + 1)[:, None])
        all_powers.append(np.full(terms.size, q))
        all_exponents.append(mu[terms])
    for j, k in zip(*np.nonzero(resonant)):
        block = np.zeros((1, n), complex)
        block[0, k] = c[j, k] / (p[j] + 1)
        stacked.append(block)
        all_powers.append(np.array([p[j] + 1]))
        all_exponents.append(eigenvalues[k:k + 1])
    stacked = np.vstack(stacked)
    keep = np.any(stacked != 0, axis=1)
    return ExpPoly(stacked[keep], np.concatenate(all_powers)[keep], np.concatenate(all_exponents)[keep])
