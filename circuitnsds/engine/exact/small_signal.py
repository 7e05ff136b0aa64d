"""Small-signal response around the exact periodic orbit (``ac`` after a ``pss`` on the exact
map): closed form on every segment, saltation at every located event, no time step.

The orbit's period is a sequence of segments (:class:`~.run.Segment`), each in one mode with
``x' = F x + H φ``, ``z = P x + Q φ``, ``φ = [S f(t); e_a]`` (:class:`~.mode.ModeDynamics`).
A perturbation ``δu(t) = e^{jω(t − t0)}`` of the sources along ``b`` (the phasor of every
source column) moves the state by ``δx`` with, on a segment from ``t_k`` of length ``τ``
(``F = W Λ W⁻¹``, ``ξ = W⁻¹ δx``, ``γ = W⁻¹ H_S b`` with ``H_S`` the columns of ``H`` that
``S f`` enters, ``a_k = e^{jω(t_k − t0)}``):

    ξ_i(s) = e^{λ_i s} ξ_i(0) + γ_i a_k s e^{jωs} φ₁((λ_i − jω) s),   φ₁(w) = (e^w − 1)/w,

and at an event ending the segment (a diode's current or voltage, a switch's control reaching
its threshold) the instant moves by ``δt = −(∇g·δx⁻ + ∂g/∂u δu)/ġ⁻``, so

    δx⁺ = δx⁻ + (f⁺ − f⁻) (∇g·δx⁻ + ∂g/∂u δu(t_e)) / ġ⁻

(the saltation of :mod:`.periodic` plus the input's own push on the event function, which is
the control-to-output path of a PWM comparator). The steady response is ``δx(t) = e^{jω(t −
t0)} p(t)``, ``p`` periodic: ``(e^{jωT} I − Φ) δx(t0) = Γ(ω)``, ``Γ`` the forced response
over one period from ``δx(t0) = 0``. An output ``o = c·z`` answers with its Fourier
coefficient at ω over the period,

    H_o = (1/T) Σ_k ∫_0^{τ_k} c·δz(t_k + s) e^{−jω(t_k + s − t0)} ds,
    ∫_0^τ ξ_i(s) e^{−jω(t_k + s − t0)} ds = ā_k ξ_i(0) τ φ₁(w_i) + γ_i τ² φ₂(w_i),

``w_i = (λ_i − jω) τ``, ``φ₂(w) = (e^w − 1 − w)/w²``, with ``δz = P δx + Q_S b δu`` (each
evaluated by its series near ``w = 0``: a mode in resonance with ω is no special case).

This is the response of the switched circuit itself, not of its implicit Euler discretisation
(the θ-based ``ac`` of :mod:`circuitnsds.engine.small_signal`): no ``s_d = (1 − e^{−jωh})/h``
warping, and a DCM diode's turn-off instant moves continuously with the perturbation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from circuitnsds.engine.exact.run import ExactSystem, Segment

if TYPE_CHECKING:
    from circuitnsds.engine.integrate import Trajectory

SERIES_BELOW = 0.5
"""``|w|`` under which ``φ₁``, ``φ₂`` are summed as series (above, the closed forms lose at most
a few ulps to cancellation)."""
SERIES_TERMS = 22
"""Terms of those series (``0.5^22/22! < 1e-27``)."""


@dataclass
class ExactPeriod:
    """One period of the exact orbit: the system, its segments in order from ``t0`` (the last
    one cut at ``t0 + period``: ``taus``), the monodromy ``Φ`` in the state coordinates ``x``,
    and the orbit's rows on the period's grid (a :class:`~circuitnsds.engine.integrate.Trajectory`)."""

    system: ExactSystem
    segments: list[Segment]
    taus: np.ndarray
    t0: float
    period: float
    monodromy: np.ndarray
    rows: Trajectory | None = None


def phi1(w: np.ndarray) -> np.ndarray:
    """``(e^w − 1)/w`` (1 at 0), elementwise, complex."""
    w = np.asarray(w, dtype=complex)
    out = np.empty_like(w)
    small = np.abs(w) < SERIES_BELOW
    big = ~small
    out[big] = np.expm1(w[big]) / w[big]
    out[small] = _series(w[small], 1)
    return out


def phi2(w: np.ndarray) -> np.ndarray:
    """``(e^w − 1 − w)/w²`` (1/2 at 0), elementwise, complex."""
    w = np.asarray(w, dtype=complex)
    out = np.empty_like(w)
    small = np.abs(w) < SERIES_BELOW
    big = ~small
    out[big] = (np.expm1(w[big]) - w[big]) / w[big] ** 2
    out[small] = _series(w[small], 2)
    return out


def _series(w: np.ndarray, order: int) -> np.ndarray:
    """``Σ_k w^k / (k + order)!``."""
    total = np.zeros_like(w)
    term = np.full_like(w, 1.0 / math.factorial(order))
    for k in range(SERIES_TERMS):
        total += term
        term = term * w / (k + order + 1)
    return total


def periodic_response(period: ExactPeriod, inputs: np.ndarray, frequencies: np.ndarray,
                      outputs: np.ndarray, output_pairs: np.ndarray) -> np.ndarray:
    """Each output's Fourier coefficient at each frequency [Hz] per unit of the sources' phasors
    ``inputs`` (one per source column), shape ``(frequencies, outputs)``; ``outputs``
    ``(outputs, n)`` and ``output_pairs`` ``(outputs, m)``: the outputs as ``Y_out y + L_out λ``
    (dense). Module docstring for the mathematics."""
    system = period.system
    n = system.n
    omegas = 2 * np.pi * np.asarray(frequencies, dtype=float)
    pieces = [_SegmentPieces(system, segment, float(tau), inputs, outputs, output_pairs, n)
              for segment, tau in zip(period.segments, period.taus)]
    for piece, after in zip(pieces, period.segments[1:]):
        if piece.ends_by_event:
            piece.terms = piece.saltation_terms(after)
    result = np.zeros((omegas.size, outputs.shape[0]), dtype=complex)
    r = period.monodromy.shape[0]
    for f, omega in enumerate(omegas):
        forced, _ = _sweep(pieces, period.t0, omega, np.zeros(r, complex), outputs.shape[0])
        start = np.linalg.solve(np.exp(1j * omega * period.period) * np.eye(r) - period.monodromy, forced)
        _, integral = _sweep(pieces, period.t0, omega, start, outputs.shape[0])
        result[f] = integral / period.period
    return result


class _SegmentPieces:
    """What the response needs of one segment, independent of ω."""

    def __init__(self, system: ExactSystem, segment: Segment, tau: float, inputs: np.ndarray,
                 outputs: np.ndarray, output_pairs: np.ndarray, n: int):
        mode = segment.mode
        self.t, self.tau = segment.t, tau
        self.eigenvalues = mode.eigenvalues.astype(complex)
        forcing = system.S @ inputs                          # δ(S f) per unit δu [MNA rows]
        G = mode.H[:, :n] @ forcing                          # δx' per unit δu
        self.gamma = mode.W_inv @ G if self.eigenvalues.size else np.zeros(0, complex)
        self.W = mode.W
        self.W_inv = mode.W_inv
        act = mode.active_index
        rows_out = np.hstack([outputs, output_pairs[:, act]])  # c·z for z = [y; λ_a]
        self.out_modal = rows_out @ mode.P @ mode.W if self.eigenvalues.size else np.zeros(
            (outputs.shape[0], 0))
        self.out_direct = rows_out @ (mode.Q[:, :n] @ forcing)
        # an event ends it inside the period (its instant moves with the perturbation)
        self.ends_by_event = segment.ended_by is not None and tau >= segment.tau
        self.terms: tuple | None = None
        self.segment, self.forcing, self.system, self.n = segment, forcing, system, n

    def saltation_terms(self, after: Segment) -> tuple[np.ndarray, np.ndarray, complex, float]:
        """``(f⁺ − f⁻, ∇g, ∂g/∂u, ġ⁻)`` at the event ending this segment."""
        segment, n, mode = self.segment, self.n, self.segment.mode
        V1t = self.system.coordinates.V1.T
        rows = self.system.event_rows(mode, segment.closed)[segment.ended_by]
        gradient = rows @ mode.P
        by_input = complex(rows @ (mode.Q[:, :n] @ self.forcing))
        f_minus = V1t @ segment.z.derivative()(segment.tau)[:n]
        f_plus = V1t @ after.z.derivative()(0.0)[:n]
        rate = float(segment.functions.table.derivative()(segment.tau)[segment.ended_by])
        return f_plus - f_minus, gradient, by_input, rate


def _sweep(pieces: list[_SegmentPieces], t0: float, omega: float, start: np.ndarray,
           count: int) -> tuple[np.ndarray, np.ndarray]:
    """``(δx(t0 + T), ∫ δo e^{−jω(t − t0)} dt)`` over the period from ``δx(t0) = start``."""
    dx = start.astype(complex)
    integral = np.zeros(count, complex)
    for piece in pieces:
        a = np.exp(1j * omega * (piece.t - t0))
        tau = piece.tau
        if piece.eigenvalues.size:
            lam = piece.eigenvalues
            xi = piece.W_inv @ dx
            grow = np.exp(lam * tau)
            w = (lam - 1j * omega) * tau
            integral += piece.out_modal @ (np.conj(a) * xi * tau * phi1(w) + piece.gamma * tau**2 * phi2(w))
            # the forced part a γ (e^{jωτ} − e^{λτ})/(jω − λ) = a γ τ e^{jωτ} φ₁(w): no e^{−λτ}
            # (a blocking diode's fast mode, λ ≈ −1e18 /s, would overflow it)
            xi_end = grow * xi + piece.gamma * a * tau * np.exp(1j * omega * tau) * phi1(w)
            dx = piece.W @ xi_end
        integral += piece.out_direct * tau
        if piece.terms is not None:
            jump, gradient, by_input, rate = piece.terms
            if rate != 0.0:
                dx = dx + jump * ((gradient @ dx + by_input * a * np.exp(1j * omega * tau)) / rate)
    return dx, integral
