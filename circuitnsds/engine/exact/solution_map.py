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

import functools
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


ONE_BY_ONE = 64
"""Modes times inputs up to which :func:`_affine_pieces` goes one term at a time: there
numpy's fixed cost per call exceeds the Python steps it saves (the three-phase inverter's
3 states and 9 inputs: 0.11 ms one by one, 0.2 ms at once; the RF multiplier's 12 and 17:
0.8 ms one by one, 0.55 ms at once)."""


def _affine_pieces(mode: ModeDynamics, powers: np.ndarray, exponents: np.ndarray, sources: int,
                   used: np.ndarray, horizon: float = 0.0) -> tuple[np.ndarray, list]:
    """``(K, keys)`` in closed form for sources of powers 0 and 1 (every piece the run's
    table makes), the same terms as :func:`~.exppoly.response`: for a modal forcing
    ``c τ^p e^{μτ}`` of mode ``k`` (``δ = μ - λ_k``), ``p = 0`` gives ``c/δ (e^{μτ} - e^{λτ})``,
    ``p = 1`` gives ``c (τ/δ - 1/δ²) e^{μτ} + c/δ² e^{λτ}``, and one near resonance
    (:data:`NEAR_RESONANCE`) the series of :func:`_near_terms` (at ``δ = 0``
    ``c τ^{p+1}/(p+1) e^{μτ}``).

    Each contribution is a column of ``z_from_modal`` (or of ``z_from_sources``) times a
    scalar, added into ``K[term, :, input]``. They are made a whole input's modes at once
    (numpy over the modes, the scalars the same operations as one by one) and summed by
    one :func:`numpy.add.at`, which adds in the order given: the order in which the terms
    were added one by one (an input's direct part, then its modes in order), so ``K`` is the
    same to the bit. (One Python step per mode and input made three quarters of the map's
    cost of the RF multiplier's maps.) An input with a mode near resonance takes the
    one-by-one path (:func:`_near_terms`); so does a mode of few states and inputs
    (:data:`ONE_BY_ONE`)."""
    r = mode.V1t.shape[0]
    if mode.eigenvalues.size * (r + int(np.count_nonzero(used)) + 1) <= ONE_BY_ONE:
        return _affine_pieces_one_by_one(mode, powers, exponents, sources, used, horizon)
    size = mode.P.shape[0]
    terms_in = len(powers)
    inputs = r + terms_in * sources + 1
    keys: dict[tuple[int, complex], int] = {(0, 0j): 0}
    lam = mode.eigenvalues.astype(complex)
    z_modal = mode.z_from_modal
    fast = mode.fast
    slow = np.flatnonzero(~fast) if lam.size else np.zeros(0, np.int64)
    # blocks in the order they are added: term indices, input indices, vectors (N, size)
    at_term: list[np.ndarray] = []
    at_input: list[np.ndarray] = []
    at_vector: list[np.ndarray] = []
    lam_key = np.zeros(lam.size, np.int64)
    for k in slow:                     # the state: x0 = e_i starts mode k at W⁻¹[k, i]
        lam_key[k] = keys.setdefault((0, lam[k]), len(keys))  # (fast ones: gone at once, mode.FAST_DECAY)
    if slow.size and r:
        at_term.append(np.repeat(lam_key[slow], r))
        at_input.append(np.tile(np.arange(r), slow.size))
        at_vector.append((z_modal.T[slow][:, None, :] * mode.W_inv[slow][:, :, None]).reshape(-1, size))

    def one(key, vector, column):
        at_term.append(np.array([keys.setdefault(key, len(keys))]))
        at_input.append(np.array([column]))
        at_vector.append(vector[None, :])

    p_of, mu_of, q_of, column_of, mu_size = _forced_inputs(
        np.asarray(powers, np.int64).tobytes(), np.asarray(exponents, complex).tobytes(), sources,
        np.asarray(used, np.bool_).tobytes(), r)
    modal = np.concatenate([mode.modal_from_sources[:, q_of], mode.modal_constant[:, None]], axis=1).T
    direct = np.concatenate([mode.z_from_sources[:, q_of], mode.z_constant[:, None]], axis=1).T
    delta = mu_of[:, None] - lam[None, :]                        # (inputs forced, modes)
    size_delta = np.abs(delta)
    live = modal != 0
    near = live & ((size_delta <= 1e-12 * np.maximum(mu_size[:, None], np.abs(lam)[None, :]) + 1e-300)
                   | ((0.0 < size_delta * horizon) & (size_delta * horizon < NEAR_RESONANCE)))
    one_by_one = near.any(axis=1)
    direct_key = np.zeros(p_of.size, np.int64)
    zero_key = np.zeros(p_of.size, np.int64)
    ramps = live.any(axis=1) & (p_of == 1)
    for j, (p, mu, column) in enumerate(zip(p_of.tolist(), mu_of.tolist(), column_of.tolist())):
        direct_key[j] = keys.setdefault((p, mu), len(keys))   # (the terms' order: as one by one)
        if one_by_one[j]:              # (its direct part first, as one by one)
            one((p, mu), direct[j], column)
            for k in np.flatnonzero(live[j]):
                _one_mode(one, mode, lam, k, modal[j, k], mu, p, horizon, column)
        elif ramps[j]:
            zero_key[j] = keys.setdefault((0, mu), len(keys))
    at_term.append(direct_key[~one_by_one])
    at_input.append(column_of[~one_by_one])
    at_vector.append(direct[~one_by_one])
    live &= ~one_by_one[:, None]
    j, k = np.nonzero(live)            # (by input, then by mode: the order one by one)
    if j.size:
        c, d = modal[j, k], delta[j, k]
        vectors = z_modal.T[k]
        ramp = p_of[j] == 1
        kept = ~fast[k]
        squared = d**2
        at_term += [direct_key[j], np.where(ramp, zero_key[j], lam_key[k]), lam_key[k[ramp & kept]]]
        at_input += [column_of[j], column_of[j], column_of[j[ramp & kept]]]
        # p = 0: c/δ on e^{μτ}, -c/δ on e^{λτ} (slow modes); p = 1: c/δ on τ e^{μτ}, -c/δ² on
        # e^{μτ}, c/δ² on e^{λτ} (slow modes)
        second = np.where(ramp, -c / squared, -c / d)
        keep_second = ramp | kept
        at_term[-2] = at_term[-2][keep_second]
        at_input[-2] = at_input[-2][keep_second]
        at_vector += [vectors * (c / d)[:, None], (vectors * second[:, None])[keep_second],
                      vectors[ramp & kept] * (c / squared)[ramp & kept, None]]
    K = np.zeros((len(keys), size, inputs), complex)
    np.add.at(K, (np.concatenate(at_term), slice(None), np.concatenate(at_input)), np.concatenate(at_vector))
    return K, list(keys)


@functools.lru_cache(maxsize=64)
def _forced_inputs(powers: bytes, exponents: bytes, sources: int, used: bytes, r: int
                   ) -> tuple[np.ndarray, ...]:
    """``(p, μ, source, input, |μ|)`` of each input a map's forcing comes through, in order: each
    source's coefficient of each term that is used (``used``: the flags of
    :class:`SolutionMap`), then the constant 1 (source ``sources``). The same for every mode
    of a run (cached: arguments as bytes)."""
    powers_, exponents_ = np.frombuffer(powers, np.int64), np.frombuffer(exponents, complex)
    used_ = np.frombuffer(used, np.bool_)
    forced = [(t, q) for t in range(powers_.size) for q in range(sources) if used_[t * sources + q]]
    p_of = np.array([int(powers_[t]) for t, _ in forced] + [0], np.int64)
    mu_of = np.array([complex(exponents_[t]) for t, _ in forced] + [0j], complex)
    q_of = np.array([q for _, q in forced], np.int64)
    column_of = np.array([r + t * sources + q for t, q in forced] + [r + powers_.size * sources], np.int64)
    return p_of, mu_of, q_of, column_of, np.abs(mu_of)


def _one_mode(one, mode: ModeDynamics, lam: np.ndarray, k: int, c: complex, mu: complex, p: int,
              horizon: float, column: int) -> None:
    """The terms of mode ``k`` forced by ``c τ^p e^{μτ}`` one by one (:func:`_affine_pieces`)."""
    z_modal = mode.z_from_modal
    delta = mu - lam[k]
    if (abs(delta) <= 1e-12 * max(abs(mu), abs(lam[k])) + 1e-300
            or 0.0 < abs(delta) * horizon < NEAR_RESONANCE):
        for power, weight in _near_terms(delta, p, horizon):
            one((power, mu), z_modal[:, k] * (c * weight), column)
    elif p == 0:
        one((0, mu), z_modal[:, k] * (c / delta), column)
        if not mode.fast[k]:
            one((0, lam[k]), z_modal[:, k] * (-c / delta), column)
    else:
        one((1, mu), z_modal[:, k] * (c / delta), column)
        one((0, mu), z_modal[:, k] * (-c / delta**2), column)
        if not mode.fast[k]:
            one((0, lam[k]), z_modal[:, k] * (c / delta**2), column)


def _affine_pieces_one_by_one(mode: ModeDynamics, powers: np.ndarray, exponents: np.ndarray, sources: int,
                   used: np.ndarray, horizon: float = 0.0) -> tuple[np.ndarray, list]:
    """:func:`_affine_pieces` one term at a time (what a mode of few states and inputs takes)."""
    r = mode.V1t.shape[0]
    size = mode.P.shape[0]
    terms_in = len(powers)
    inputs = r + terms_in * sources + 1
    keys: dict[tuple[int, complex], int] = {(0, 0j): 0}
    # the terms' indices, inputs and vectors in the order added (summed by one add.at, which
    # adds in that order)
    at_term: list[int] = []
    at_input: list[int] = []
    vectors: list[np.ndarray] = []

    def add(key, vector, column):
        at_term.append(keys.setdefault(key, len(keys)))
        at_input.append(column)
        vectors.append(vector)

    lam = mode.eigenvalues.astype(complex)
    z_modal = mode.z_from_modal
    fast = mode.fast
    for k in range(lam.size):          # the state: x0 = e_i starts mode k at W⁻¹[k, i]
        if fast[k]:                    # (gone a femtosecond after the start: mode.FAST_DECAY)
            continue
        term = keys.setdefault((0, lam[k]), len(keys))
        at_term += [term] * r
        at_input += range(r)
        vectors += list(z_modal[:, k][None, :] * mode.W_inv[k, :, None])
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
    if vectors:
        np.add.at(K, (np.array(at_term), slice(None), np.array(at_input)), np.array(vectors))
    return K, list(keys)
