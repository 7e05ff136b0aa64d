"""Each independent source on the piece that starts at ``t0``, as an exponential polynomial
in ``τ = t - t0`` (the exosystem of DESIGN.md: PULSE, PWL and DC are affine between their
corners, SIN a damped rotation after its delay, EXP a decay after each of its delays).

The piece ends at the source's next corner (:meth:`Stimulus.breakpoints`), where the
event loop starts a new piece: a corner is an event known in advance.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from circuitnsds.engine.exact.exppoly import ExpPoly
from circuitnsds.system.stimuli import Dc, Exp, Pulse, Pwl, Sin, Stimulus


class SourcePieces:
    """The pieces of every source of a run ending at ``stop`` [s]."""

    def __init__(self, stimuli: list[Stimulus], stop: float):
        self.stimuli = stimuli
        self.stop = stop
        self.corners = [sorted(set(s.breakpoints(stop))) for s in stimuli]

    def next_corner(self, t0: float) -> float:
        """The first corner of any source after ``t0`` (``stop`` if none)."""
        best = self.stop
        for corners in self.corners:
            k = bisect.bisect_right(corners, t0 * (1 + 1e-15) + 1e-300)
            if k < len(corners):
                best = min(best, corners[k])
        return best

    def piece(self, t0: float, end: float) -> ExpPoly:
        """Every source's value on ``(t0, end]`` (``end`` the next corner), a vector ExpPoly
        with its terms of equal power and exponent merged."""
        parts = [_piece(stimulus, t0, end) for stimulus in self.stimuli]
        k = len(parts)
        total = ExpPoly.zero(k)
        for index, part in enumerate(parts):
            placed = np.zeros((part.coefficients.shape[0], k), complex)
            placed[:, index] = part.coefficients[:, 0]
            total = total + ExpPoly(placed, part.powers, part.exponents)
        return total.merged()


def _affine(stimulus: Stimulus, t0: float, end: float) -> ExpPoly:
    """A piece on which the source is affine: its value just after ``t0`` and its slope,
    read at two interior points (exact up to round-off: the piece is a straight line)."""
    a, b = t0 + (end - t0) / 3, t0 + 2 * (end - t0) / 3
    va, vb = stimulus.value(a), stimulus.value(b)
    slope = (vb - va) / (b - a)
    start = va - slope * (a - t0)
    return ExpPoly(np.array([[start], [slope]], complex), np.array([0, 1]), np.zeros(2, complex))


def _piece(stimulus: Stimulus, t0: float, end: float) -> ExpPoly:
    if isinstance(stimulus, (Dc, Pulse, Pwl)):
        return _affine(stimulus, t0, end)
    if isinstance(stimulus, Sin):
        return _sine(stimulus, t0)
    if isinstance(stimulus, Exp):
        return _exponential(stimulus, t0)
    raise TypeError(f"no exact piece for {type(stimulus).__name__}")


def _sine(s: Sin, t0: float) -> ExpPoly:
    """``VO + VA e^{-θ(t-TD)} sin(2πf(t-TD) + φ)`` after ``TD`` (and before the end of
    ``NCYCLES``); the constant ``VO + VA sin φ`` before, the value at the end after."""
    phase = math.radians(s.phase_deg)
    finish = s.delay + s.cycles / abs(s.frequency) if s.cycles else math.inf  # (a negative FREQ: sin(-ωt))
    if t0 < s.delay - 1e-15 * max(1.0, abs(s.delay)) or t0 >= finish:
        return ExpPoly.constant(np.array([s.value(t0 + 1e-300 if t0 < s.delay else t0)]))
    nu = complex(-s.damping, 2 * math.pi * s.frequency)
    c = s.amplitude / 2j * np.exp(1j * phase + nu * (t0 - s.delay))
    return ExpPoly(np.array([[s.offset], [c], [np.conj(c)]], complex), np.zeros(3, int),
                   np.array([0, nu, np.conj(nu)]))


def _exponential(s: Exp, t0: float) -> ExpPoly:
    """``V1 + (V2-V1)(1 - e^{-(t-TD1)/τ1}) - (V2-V1)(1 - e^{-(t-TD2)/τ2})``, terms from the delays passed."""
    span = s.pulsed - s.initial
    constant = s.initial
    coefficients, exponents = [], []
    if t0 >= s.rise_delay:
        constant += span
        coefficients.append(-span * math.exp(-(t0 - s.rise_delay) / s.rise_tau))
        exponents.append(-1 / s.rise_tau)
    if t0 >= s.fall_delay:
        constant -= span
        coefficients.append(span * math.exp(-(t0 - s.fall_delay) / s.fall_tau))
        exponents.append(-1 / s.fall_tau)
    return ExpPoly(np.array([[constant], *[[c] for c in coefficients]], complex),
                   np.zeros(1 + len(coefficients), int), np.array([0, *exponents], complex))


def supported(stimuli: list[Stimulus]) -> bool:
    """Whether every source has exact pieces here."""
    return all(isinstance(s, (Dc, Pulse, Pwl, Sin, Exp)) for s in stimuli)
