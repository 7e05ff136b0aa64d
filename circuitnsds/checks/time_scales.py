"""The circuit's own time scales in the modes a run visited, against its step.

The sources' fastest features are checked before a run (``resolving_step``); the circuit's
own dynamics are not known until its modes are (switch states and conducting pairs). For a
mode, the implicit-Euler step map ``y_{k+1} = P y_k + ...`` of step ``h`` has the eigenvalue
``μ = 1 / (1 - h λ)`` for each eigenvalue ``λ`` [1/s] of the mode's continuous dynamics
(``E y' = A y`` with the mode's constraints), and 0 for the algebraic unknowns; so
``λ = (1 - 1/μ) / h``.

A step is too long for a mode when the mode

* rings (damping ratio ``ζ = -Re λ / |λ|`` below :data:`LIGHT_DAMPING`) with fewer than
  :data:`STEPS_PER_RING` steps per period: implicit Euler damps the ringing away, the
  trapezoidal rule aliases it (a series RLC at 159 kHz stepped at 100 µs peaked at 10.0 V,
  ngspice 18.44 V);
* or decays with a time constant ``τ`` between ``h / SLOW_STIFF`` and ``h``: neither
  followed (that needs ``h < τ``) nor so fast that only its end matters (a switch's Ron with
  a capacitor, ``τ`` of picoseconds at a nanosecond step). The hysteretic buck's ``L/R =
  50 µs`` at a 100 µs step switched every 47 µs instead of 38.1 µs.

This module returns what it found as data; the analysis words the warning.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from circuitnsds.engine.dense_loop import dense_mode_map
from circuitnsds.engine.step_system import mode_blocks, step_system
from circuitnsds.system.mlcs import MLCS

STEPS_PER_RING = 4
"""Fewer steps than this per period of a lightly damped mode lose its ringing."""
LIGHT_DAMPING = 0.5
"""A mode whose damping ratio is below this rings (its step response overshoots by 16 %)."""
SLOW_STIFF = 10.0
"""A decaying mode with ``h/τ`` in ``[1, SLOW_STIFF)`` is neither followed nor negligible."""
MAX_MODES = 16
"""At most this many of the modes a run visited (the most visited first) are examined."""
MAX_UNKNOWNS = 400
"""Circuits with more unknowns and pairs are not examined (a dense eigenproblem per mode)."""


@dataclass(frozen=True)
class FastMode:
    """A mode of the circuit's dynamics the step does not follow.

    Attributes:
        eigenvalue: ``λ`` [1/s] (for a ringing mode, the one with positive imaginary part).
        unknowns: the state unknowns (``v(node)``, ``i(inductor)``) that hold most of its
            energy, largest first.
        step: the step [s] it was found at.
    """

    eigenvalue: complex
    unknowns: tuple[str, ...]
    step: float

    @property
    def rings(self) -> bool:
        return abs(self.eigenvalue.imag) > 0.0

    @property
    def frequency(self) -> float:
        """[Hz] of a ringing mode."""
        return abs(self.eigenvalue.imag) / (2 * np.pi)

    @property
    def time_constant(self) -> float:
        """``τ = -1/Re λ`` [s]."""
        return -1.0 / self.eigenvalue.real if self.eigenvalue.real < 0 else float("inf")

    @property
    def damping(self) -> float:
        return -self.eigenvalue.real / abs(self.eigenvalue)

    @property
    def needed_step(self) -> float:
        """[s] A step that follows the mode: 20 per period of a ringing one, τ/2 otherwise."""
        return 1.0 / (20 * self.frequency) if self.rings else self.time_constant / 2


def mode_spectrum(mlcs: MLCS, h: float, states: np.ndarray, active: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray] | None:
    """``(λ, vectors)``: the eigenvalues [1/s] of the mode (switch ``states``, ``active``
    pairs) and their eigenvectors over the MNA unknowns (columns), from its implicit-Euler
    step map at ``h``; ``None`` when the mode's step matrix is singular."""
    system = step_system(mlcs, h, tuple(bool(s) for s in states), 1.0, dense=True)
    mode = dense_mode_map(mode_blocks(system, np.asarray(active, dtype=bool), dense=True), mlcs.n)
    if mode is None:
        return None
    n = mlcs.n
    multipliers, vectors = np.linalg.eig(mode.P[:n, :n])
    dynamic = np.abs(multipliers) > 1e-12  # (algebraic unknowns: 0)
    multipliers, vectors = multipliers[dynamic], vectors[:, dynamic]
    return (1.0 - 1.0 / multipliers) / h, vectors


class ModeTally:
    """The distinct ``(switch states, active set)`` rows of a run seen part by part, with how
    often each was visited (each part sampled at most every ``len // SAMPLE_ROWS`` rows: the
    modes that hold the run)."""

    SAMPLE_ROWS = 20_000

    def __init__(self) -> None:
        self.counts: dict[bytes, int] = {}
        self.rows: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def add(self, switches: np.ndarray, active: np.ndarray) -> None:
        """Count the rows of one part (the initial state left out by the caller)."""
        switches, active = np.asarray(switches, dtype=bool), np.asarray(active, dtype=bool)
        if switches.shape[0] == 0:
            return
        every = max(1, switches.shape[0] // self.SAMPLE_ROWS)  # (sampled before they are joined)
        switches, active = switches[::every], active[::every]
        rows = np.hstack([switches, active])
        # each row as one value, for a 1-D unique (np.unique(axis=0) took 0.15 s on 20,000
        # rows): its packed bytes
        packed = np.ascontiguousarray(np.packbits(rows, axis=1)) if rows.shape[1] else \
            np.zeros((rows.shape[0], 1), dtype=np.uint8)
        keys = packed.view(np.dtype((np.void, packed.shape[1]))).ravel()
        _, first, counts = np.unique(keys, return_index=True, return_counts=True)
        split = switches.shape[1]
        for k, count in sorted(zip(first.tolist(), counts.tolist(), strict=True)):
            key = keys[k].tobytes()
            if key not in self.rows:
                self.rows[key] = (rows[k, :split], rows[k, split:])
            self.counts[key] = self.counts.get(key, 0) + count

    def modes(self, most: int = MAX_MODES) -> list[tuple[np.ndarray, np.ndarray]]:
        """The modes seen, the most visited first (the first seen first among equals)."""
        order = sorted(self.counts, key=lambda key: -self.counts[key])[:most]
        return [self.rows[key] for key in order]


def visited_modes(switches: np.ndarray, active: np.ndarray, most: int = MAX_MODES
                  ) -> list[tuple[np.ndarray, np.ndarray]]:
    """The distinct ``(switch states, active set)`` rows of a run, the most visited first
    (at most ``most``; the rows after the first, which is the initial state)."""
    tally = ModeTally()
    tally.add(np.asarray(switches)[1:], np.asarray(active)[1:])
    return tally.modes(most)


def fast_modes(mlcs: MLCS, h: float, modes: list[tuple[np.ndarray, np.ndarray]],
               jumps: bool = True) -> list[FastMode]:
    """The modes (of the given ``(switch states, active set)`` list) whose dynamics a step
    ``h`` [s] does not follow (module docstring), one per distinct eigenvalue, the slowest
    first (the ones that matter most to the waveforms). ``jumps``: whether anything in the
    run starts a transient of a decaying mode (a switching, a source's corner, a start away
    from equilibrium); without, such a mode only follows its smooth forcing, which implicit
    Euler does (an inductor fed by a sine current through 1 MΩ, τ = h: 0.005 % off), and
    only ringing modes are returned."""
    if mlcs.n + mlcs.m > MAX_UNKNOWNS or h <= 0:
        return []
    weights = np.abs(mlcs.E.toarray()).sum(axis=1)  # capacitance / inductance of each row
    found: dict[tuple[float, float], FastMode] = {}
    for states, active in modes:
        spectrum = mode_spectrum(mlcs, h, states, active)
        if spectrum is None:
            continue
        values, vectors = spectrum
        for value, vector in zip(values, vectors.T):
            if not np.isfinite(value) or value.imag < 0:
                continue
            magnitude = abs(value)
            ringing = value.imag > 0 and -value.real / magnitude < LIGHT_DAMPING
            if ringing:
                unresolved = h * value.imag > 2 * np.pi / STEPS_PER_RING
            elif not jumps:
                continue
            else:
                unresolved = 1.0 <= h * -value.real < SLOW_STIFF and abs(value.imag) < 1e-9 * magnitude
            if not unresolved:
                continue
            key = (round(float(value.real), -int(np.floor(np.log10(magnitude))) + 3),
                   round(float(abs(value.imag)), -int(np.floor(np.log10(magnitude))) + 3))
            energy = weights * np.abs(vector) ** 2
            order = [j for j in np.argsort(-energy) if energy[j] > 0.05 * energy.max()][:4]
            found.setdefault(key, FastMode(complex(value.real, value.imag if ringing else 0.0),
                                           tuple(mlcs.unknowns[j] for j in order), h))
    return sorted(found.values(), key=lambda mode: abs(mode.eigenvalue))


def exact_monodromy(maps) -> np.ndarray | None:
    """The monodromy matrix of the period that ``maps`` (a
    :class:`~circuitnsds.engine.step_maps.StepMaps` of implicit-Euler steps) took, with each
    stretch of equal steps in one mode integrated exactly instead: a step map ``M = (I − hF)⁻¹``
    on the state gives ``h·F = I − M⁻¹``, and ``n`` such steps become ``e^{n·(I − M⁻¹)}``.
    Steps split at a switching keep their own map (a fraction of a step). ``None`` when a
    stretch's map is singular on the state (a state that a mode holds algebraically)."""
    from scipy.linalg import expm

    size = maps.state.size
    phi = np.eye(size)
    time = maps.trajectory.time
    k, steps = 0, maps.steps
    while k < steps:
        mode = maps.mode_of_step[k]
        end = k + 1
        if mode >= 0:
            length = time[k + 1] - time[k]
            while (end < steps and maps.mode_of_step[end] == mode
                   and abs((time[end + 1] - time[end]) - length) <= 1e-9 * length):
                end += 1
        M = maps.step(k)[0]
        if mode < 0:
            phi = M @ phi
        else:
            try:
                generator = np.eye(size) - np.linalg.inv(M)
            except np.linalg.LinAlgError:
                return None
            if not np.isfinite(generator).all():
                return None
            phi = expm((end - k) * generator) @ phi
        k = end
    return phi if np.isfinite(phi).all() else None
