"""A mode's solution and event functions as one linear map of the segment's data.

On a segment the mode's solution ``z(τ)`` (:meth:`~.mode.ModeDynamics.solution`) is an
exponential polynomial whose terms (powers and exponents) depend only on the mode and on
the *structure* of the sources' piece (its powers and exponents), and whose coefficients
are affine in the state ``x`` at the segment's start and in the piece's coefficients ``s``:

    coefficients(z) = K [x; s; 1].

So is every event function of the mode (``g = rows · z + constants``). :class:`SolutionMap`
holds ``K`` for ``z`` and for the table of event functions, built once per mode and source
structure term by term in closed form (the terms of :func:`~.exppoly.response`, nothing
approximated), so that a segment costs two complex matrix-vector products instead of the
closed form's assembly.
"""

from __future__ import annotations

import math

import numpy as np

from circuitnsds.engine.exact.exppoly import ExpPoly
from circuitnsds.engine.exact.mode import ModeDynamics


class SolutionMap:
    """``z`` and the event functions of ``mode`` for sources of the structure
    ``(powers, exponents)`` over ``sources`` columns (module docstring)."""

    def __init__(self, mode: ModeDynamics, powers: np.ndarray, exponents: np.ndarray, sources: int,
                 rows: np.ndarray, constants: np.ndarray, used: np.ndarray | None = None,
                 horizon: float = 0.0):
        """``used``: ``(terms, sources)``, the source coefficients that can be nonzero (the
        map of the others is left 0); all by default. ``horizon`` [s]: the longest segment
        the map is used for (the sources' longest piece), which decides where a forcing is
        near resonance (:data:`NEAR_RESONANCE`)."""
        r = mode.V1t.shape[0]
        terms_in = len(powers)
        size = mode.P.shape[0]
        inputs = r + terms_in * sources + 1
        used = np.ones(terms_in * sources, bool) if used is None else np.asarray(used, bool).ravel()
        if powers.size and powers.max() > 1:
            raise ValueError(f"source pieces of power {powers.max()}: only constants and ramps have maps")
        K, keys = _affine_pieces(mode, powers, exponents, sources, used, horizon)
        self.powers = np.array([k[0] for k in keys], int)
        self.exponents = np.array([k[1] for k in keys], complex)
        terms = len(keys)
        self.state_size = r
        self.size = size
        self.z_map = K.reshape(terms * size, inputs)
        table = np.matmul(rows, K)                 # (terms, columns, inputs): rows · K per term
        table[0, :, -1] += constants               # the constants join the term τ^0 e^{0τ}
        self.columns = rows.shape[0]
        self.table_map = table.reshape(terms * self.columns, inputs)
        # g'(0) = Re Σ c_j (ν_j [p_j = 0] + [p_j = 1])
        self.slope_weights = np.where(self.powers == 0, self.exponents, 0) + (self.powers == 1)

    def inputs(self, x: np.ndarray, coefficients: np.ndarray) -> np.ndarray:
        """``[x; s; 1]`` for the state ``x`` and the piece's coefficients ``s``."""
        return np.concatenate([x.astype(complex), coefficients.ravel(), [1.0]])

    def solution(self, inputs: np.ndarray) -> ExpPoly:
        """``z(τ)`` (the same function as :meth:`ModeDynamics.solution`)."""
        coefficients = (self.z_map @ inputs).reshape(len(self.powers), self.size)
        return ExpPoly(coefficients, self.powers, self.exponents)

    def table(self, inputs: np.ndarray) -> np.ndarray:
        """The event functions' coefficients, ``(terms, columns)`` (the constants included)."""
        return (self.table_map @ inputs).reshape(len(self.powers), self.columns)


NEAR_RESONANCE = 1e-5
"""A modal forcing ``c τ^p e^{μτ}`` with ``|μ − λ| · horizon`` below this is near resonance:
its response is taken as the series ``c e^{μτ} Σ_j (−δ)^j p!/(p+j+1)! τ^{p+j+1}`` (``δ = μ − λ``,
:func:`_near_terms`), not the closed form, whose terms ``c/δ²`` cancel: a current ramping into
1 µF held by gmin (λ = −1e-6 /s) gave 6e7 V for 1e-3 V. Above it the closed form loses at
most ``ε/(δ·τ)²`` ≈ 1e-6 of that mode's forced response; below, the series is exact to
round-off but adds up to four terms to every row (at 1e-4 the voltage-mode buck's compensator
mode, −2.97 /s under 10 µs ramps, took them: 6 terms became 10, rows 50 % dearer). At 1e-2
the bundled buck's start changed its mode: its event functions' terms, no longer cancelling,
made their tolerances tighter at a start where every diode is at 0 V and 0 A."""
SERIES_FLOOR = 1e-18
"""The near-resonance series stops at the first term below this fraction of the first."""


def _near_terms(delta: complex, p: int, horizon: float) -> list[tuple[int, complex]]:
    """``(power, coefficient)`` of ``∫_0^τ (τ − u)^p e^{−δu} du = Σ_j (−δ)^j p!/(p+j+1)! τ^{p+j+1}``
    (the response of one mode to ``τ^p e^{μτ}`` divided by ``e^{μτ}``), to :data:`SERIES_FLOOR`
    over ``τ <= horizon``."""
    terms = []
    coefficient = complex(math.factorial(p)) / math.factorial(p + 1)
    size = abs(delta) * horizon
    j = 0
    while True:
        terms.append((p + j + 1, coefficient))
        j += 1
        coefficient *= -delta / (p + j + 1)
        if size == 0.0 or size ** j / math.factorial(j) < SERIES_FLOOR or j > 40:
            return terms


def _affine_pieces(mode: ModeDynamics, powers: np.ndarray, exponents: np.ndarray, sources: int,
                   used: np.ndarray, horizon: float = 0.0) -> tuple[np.ndarray, list]:
    """``(K, keys)`` in closed form for sources of powers 0 and 1 (every piece the run's
    table makes), the same terms as :func:`~.exppoly.response`: for a modal forcing
    ``c τ^p e^{μτ}`` of mode ``k`` (``δ = μ - λ_k``), ``p = 0`` gives ``c/δ (e^{μτ} - e^{λτ})``,
    ``p = 1`` gives ``c (τ/δ - 1/δ²) e^{μτ} + c/δ² e^{λτ}``, and one near resonance
    (:data:`NEAR_RESONANCE`) the series of :func:`_near_terms` (at ``δ = 0``
    ``c τ^{p+1}/(p+1) e^{μτ}``)."""
    r = mode.V1t.shape[0]
    size = mode.P.shape[0]
    terms_in = len(powers)
    inputs = r + terms_in * sources + 1
    keys: dict[tuple[int, complex], int] = {(0, 0j): 0}
    columns: list[tuple[tuple[int, complex], np.ndarray, int]] = []   # (key, z vector, input)

    def add(key, vector, column):
        keys.setdefault(key, len(keys))
        columns.append((key, vector, column))

    lam = mode.eigenvalues.astype(complex)
    z_modal = mode.z_from_modal
    fast = mode.fast
    for k in range(lam.size):          # the state: x0 = e_i starts mode k at W⁻¹[k, i]
        if fast[k]:                    # (gone a femtosecond after the start: mode.FAST_DECAY)
            continue
        for i in range(r):
            add((0, lam[k]), z_modal[:, k] * mode.W_inv[k, i], i)
    forcings = [(int(powers[t]), complex(exponents[t]), mode.modal_from_sources,
                 mode.z_from_sources, r + t * sources) for t in range(terms_in)]
    forcings.append((0, 0j, mode.modal_constant[:, None], mode.z_constant[:, None], inputs - 1))
    for p, mu, modal, direct, first in forcings:
        for q in range(modal.shape[1]):
            column = first + q
            if column < inputs - 1 and not used[column - r]:
                continue
            add((p, mu), direct[:, q], column)
            for k in range(lam.size):
                c = modal[k, q]
                if c == 0:
                    continue
                delta = mu - lam[k]
                if (abs(delta) <= 1e-12 * max(abs(mu), abs(lam[k])) + 1e-300
                        or 0.0 < abs(delta) * horizon < NEAR_RESONANCE):
                    for power, weight in _near_terms(delta, p, horizon):
                        add((power, mu), z_modal[:, k] * (c * weight), column)
                elif p == 0:
                    add((0, mu), z_modal[:, k] * (c / delta), column)
                    if not fast[k]:
                        add((0, lam[k]), z_modal[:, k] * (-c / delta), column)
                else:
                    add((1, mu), z_modal[:, k] * (c / delta), column)
                    add((0, mu), z_modal[:, k] * (-c / delta**2), column)
                    if not fast[k]:
                        add((0, lam[k]), z_modal[:, k] * (c / delta**2), column)
    K = np.zeros((len(keys), size, inputs), complex)
    for key, vector, column in columns:
        K[keys[key], :, column] += vector
    return K, list(keys)
