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
        if not len(self.powers):
            return self
        keys = np.stack([self.powers.astype(float), self.exponents.real, self.exponents.imag], axis=1)
        unique, inverse = np.unique(keys, axis=0, return_inverse=True)
        inverse = np.ravel(inverse)
        summed = np.zeros((len(unique), self.size), complex)
        np.add.at(summed, inverse, self.coefficients)
        keep = np.any(summed != 0, axis=1)
        return ExpPoly(summed[keep], unique[keep, 0].astype(int),
                       (unique[keep, 1] + 1j * unique[keep, 2]))

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

    Uses ``∫_0^τ e^{λ(τ-s)} s^p e^{μs} ds``, in closed form for ``p <= 2``: with ``δ = μ - λ``,
    a sum of ``τ^q e^{μτ}`` terms and one ``e^{λτ}`` term; when ``δ = 0`` (resonance: a mode
    with the forcing's own exponent) the integral is ``τ^{p+1} e^{λτ}/(p+1)``.
    """
    n = len(eigenvalues)
    coefficients = [np.diag(start.astype(complex))]
    powers = [np.zeros(n, int)]
    exponents = [eigenvalues.astype(complex)]
    for c, p, mu in zip(forcing.coefficients, forcing.powers, forcing.exponents):
        delta = mu - eigenvalues
        # a mode counts as resonant when δ is round-off of the exponents' size
        resonant = np.abs(delta) <= 1e-12 * np.maximum(np.abs(mu), np.abs(eigenvalues)) + 1e-300
        safe = np.where(resonant, 1.0, delta)
        # ∫0^τ e^{λ(τ-s)} s^p e^{μs} ds = Σ_{q<=p} a_q τ^q e^{μτ} + a_e e^{λτ}  (δ ≠ 0)
        # p = 0: (e^{μτ} - e^{λτ})/δ
        # p = 1: τ e^{μτ}/δ - (e^{μτ} - e^{λτ})/δ²
        # p = 2: τ² e^{μτ}/δ - 2τ e^{μτ}/δ² + 2(e^{μτ} - e^{λτ})/δ³
        if p == 0:
            mu_terms = {0: 1 / safe}
            tail = -1 / safe
        elif p == 1:
            mu_terms = {1: 1 / safe, 0: -1 / safe**2}
            tail = 1 / safe**2
        elif p == 2:
            mu_terms = {2: 1 / safe, 1: -2 / safe**2, 0: 2 / safe**3}
            tail = -2 / safe**3
        else:
            raise ValueError(f"forcing power {p} > 2 is not supported")
        live = ~resonant
        for q, factor in mu_terms.items():
            coefficients.append(np.diag(np.where(live, c * factor, 0)))
            powers.append(np.full(n, q))
            exponents.append(np.full(n, mu))
        coefficients.append(np.diag(np.where(live, c * tail, 0)))
        powers.append(np.zeros(n, int))
        exponents.append(eigenvalues.astype(complex))
        if resonant.any():
            coefficients.append(np.diag(np.where(resonant, c / (p + 1), 0)))
            powers.append(np.full(n, p + 1))
            exponents.append(eigenvalues.astype(complex))
    stacked = np.vstack(coefficients)
    keep = np.any(stacked != 0, axis=1)
    return ExpPoly(stacked[keep], np.concatenate(powers)[keep], np.concatenate(exponents)[keep])
