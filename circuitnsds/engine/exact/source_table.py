"""Every source's piece on every interval between corners, computed once for a run.

The exosystem of DESIGN.md ("Event-driven exact integration", step 2) has one *structure*
for the whole run: the terms ``τ^p e^{ντ}`` any source can have (a constant and a ramp for
DC, PULSE and PWL; ``e^{±jωτ}`` damped for each SIN; a decay for each EXP time constant),
a source's coefficient being 0 on an interval where it lacks that term (a SIN before its
delay is a constant). So each mode needs one solution map
(:class:`~.solution_map.SolutionMap`), and the coefficients of every source on every
interval between two corners (the union of the sources' corners) are sampled at once,
vectorised, before the run: the piece from any instant ``t0`` of an interval is that
interval's, shifted (:func:`shift`).

An affine piece is read at the interval's inner thirds (as :mod:`.sources` does: exact to
round-off, the corners' own values never used), a SIN and an EXP from their closed forms.
"""

from __future__ import annotations

import math

import numpy as np

from circuitnsds.engine.exact.exppoly import ExpPoly
from circuitnsds.system.stimuli import Dc, Exp, Pulse, Pwl, Sin, Stimulus


class SourceTable:
    """``corners`` [s] (``0``, every source corner before ``stop``, ``stop``); on interval
    ``k`` (``corners[k]`` to ``corners[k + 1]``) the sources are
    ``Re Σ_j coefficients[k, j] τ^powers[j] e^{exponents[j] τ}``, ``τ = t - corners[k]``."""

    def __init__(self, stimuli: list[Stimulus], stop: float):
        inner = sorted({c for s in stimuli for c in s.breakpoints(stop) if 0 < c < stop})
        self.corners = np.array([0.0, *inner, stop]) if stop > 0 else np.array([0.0, 0.0])
        keys: dict[tuple[int, complex], int] = {(0, 0j): 0, (1, 0j): 1}
        for s in stimuli:
            for nu in _exponents(s):
                keys.setdefault((0, nu), len(keys))
        self.powers = np.array([k[0] for k in keys], np.int64)
        self.exponents = np.array([k[1] for k in keys], complex)
        # the term a ramp's shift feeds: τ^1 e^{ντ} -> τ^0 e^{ντ}
        self.partner = np.array([keys.get((0, nu), -1) if p == 1 else -1
                                 for p, nu in keys], np.int64)
        starts, ends = self.corners[:-1], self.corners[1:]
        self.coefficients = np.zeros((starts.size, len(keys), len(stimuli)), complex)
        for column, s in enumerate(stimuli):
            _fill(s, starts, ends, keys, self.coefficients[:, :, column])
        self.used = np.any(self.coefficients != 0, axis=0)
        """``(terms, sources)``: the coefficients nonzero on some piece (the others are 0 on
        every piece: a mode's map needs no closed form for them). A piece from inside an
        interval is the interval's shifted (:func:`shift`): a ramp's term feeds its partner
        (``τ e^{ντ}`` into ``e^{ντ}``), which is then used even where every interval's own
        is 0 (a PWL from 0 V: without it the ramp restarted from 0 at each event)."""
        for j in np.flatnonzero(self.partner >= 0):
            self.used[self.partner[j]] |= self.used[j]

    def interval(self, t0: float) -> int:
        """The interval whose piece holds just after ``t0`` (its end is the first corner
        after ``t0``, as :meth:`.sources.SourcePieces.next_corner` finds it)."""
        threshold = t0 * (1 + 1e-15) + 1e-300
        return int(min(np.searchsorted(self.corners, threshold, side="right") - 1, self.corners.size - 2))

    def piece(self, k: int, t0: float) -> ExpPoly:
        """The sources from ``t0`` (in interval ``k``) as an ExpPoly in ``τ = t - t0``."""
        return ExpPoly(shift(self.coefficients[k], self.powers, self.exponents, self.partner,
                             t0 - self.corners[k]), self.powers, self.exponents)


def shift(coefficients: np.ndarray, powers: np.ndarray, exponents: np.ndarray, partner: np.ndarray,
          delta: float) -> np.ndarray:
    """The coefficients of ``f(δ + τ)`` from those of ``f(τ)`` (terms of power 0 or 1):
    ``(δ + τ) e^{ν(δ+τ)} = e^{νδ} (δ + τ) e^{ντ}``."""
    out = coefficients * np.exp(exponents * delta)[:, None]
    for j in np.flatnonzero(powers == 1):
        out[partner[j]] += delta * out[j]
    return out


def _exponents(s: Stimulus) -> list[complex]:
    if isinstance(s, Sin) and s.amplitude != 0:
        nu = complex(-s.damping, 2 * math.pi * s.frequency)
        return [nu, nu.conjugate()]
    if isinstance(s, Exp):
        return [complex(-1 / s.rise_tau), complex(-1 / s.fall_tau)]
    return []


def _fill(s: Stimulus, starts: np.ndarray, ends: np.ndarray, keys: dict, out: np.ndarray) -> None:
    """Source ``s``'s coefficients on every interval into ``out`` ``(intervals, terms)``."""
    width = ends - starts
    middle = starts + width / 2
    if isinstance(s, (Dc, Pulse, Pwl)):
        a, b = starts + width / 3, starts + 2 * width / 3
        va, vb = _sampled(s, a), _sampled(s, b)
        with np.errstate(invalid="ignore", divide="ignore"):
            slope = np.where(b > a, (vb - va) / np.where(b > a, b - a, 1.0), 0.0)
        out[:, keys[(0, 0j)]] = va - slope * (a - starts)
        out[:, keys[(1, 0j)]] = slope
    elif isinstance(s, Sin):
        finish = s.delay + s.cycles / abs(s.frequency) if s.cycles else math.inf
        running = (middle > s.delay) & (middle < finish) & (s.amplitude != 0)
        out[:, keys[(0, 0j)]] = np.where(running, s.offset, s.sample(middle))
        if s.amplitude != 0:
            nu = complex(-s.damping, 2 * math.pi * s.frequency)
            c = s.amplitude / 2j * np.exp(1j * math.radians(s.phase_deg) + nu * (starts - s.delay))
            out[:, keys[(0, nu)]] += np.where(running, c, 0)
            out[:, keys[(0, nu.conjugate())]] += np.where(running, np.conj(c), 0)
    elif isinstance(s, Exp):
        span = s.pulsed - s.initial
        rising, falling = middle >= s.rise_delay, middle >= s.fall_delay
        out[:, keys[(0, 0j)]] = s.initial + span * rising - span * falling
        out[:, keys[(0, complex(-1 / s.rise_tau))]] += np.where(
            rising, -span * np.exp(-(starts - s.rise_delay) / s.rise_tau), 0)
        out[:, keys[(0, complex(-1 / s.fall_tau))]] += np.where(
            falling, span * np.exp(-(starts - s.fall_delay) / s.fall_tau), 0)
    else:
        raise TypeError(f"no exact piece for {type(s).__name__}")


def _sampled(s: Stimulus, t: np.ndarray) -> np.ndarray:
    """``s`` at the inner points ``t`` (never a corner), vectorised."""
    if isinstance(s, Pwl):
        return np.interp(t, np.array(s.times), np.array(s.values))
    if isinstance(s, Dc):
        return np.full(t.shape, s.value(0.0))
    return s.sample(t)
