"""Thermal RC networks from a junction to its reference (the case, or the heatsink): the
electrical analogue (power [W] = current, temperature rise [K] = voltage).

* **Foster**: stages ``R_k ∥ C_k`` in series, given as ``R_k`` [K/W] and ``τ_k = R_k·C_k``
  [s]; its step response is ``Z(t) = Σ R_k (1 − e^(−t/τ_k))``. The internal nodes have no
  physical meaning, but the junction's temperature is exact.
* **Cauer**: a ladder from the junction: ``C_1`` from the junction to the reference, ``R_1``
  to the next node, ``C_2`` from it to the reference, …, ``R_n`` to the reference.

:func:`cauer_to_foster` turns a ladder into the Foster network with the same impedance
``Z(s)`` at the junction (the partial fractions of ``Z(s)``), so one integrator serves both.
Driving (:meth:`FosterNetwork.respond`) is exact for a power constant between breakpoints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ThermalNetwork:
    """A thermal RC network by its stages' resistances ``resistance[k]`` [K/W]."""

    resistance: tuple[float, ...]

    @property
    def total(self) -> float:
        """``Σ R_k`` [K/W]: the steady-state rise per watt."""
        return float(sum(self.resistance))


@dataclass(frozen=True)
class FosterNetwork(ThermalNetwork):
    """Stages ``resistance[k]`` [K/W] with time constants ``tau[k]`` [s] (all positive)."""

    tau: tuple[float, ...]

    def step(self, time: np.ndarray) -> np.ndarray:
        """The rise [K] at ``time`` [s] after a 1 W step applied at ``t = 0``."""
        time = np.asarray(time, dtype=float)
        return sum(r * -np.expm1(-time / tau) for r, tau in zip(self.resistance, self.tau))

    def respond(self, breakpoints: np.ndarray, powers: np.ndarray, time: np.ndarray,
                initial: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The junction's rise [K] at each ``time`` for a power ``powers[k]`` [W] constant on
        ``[breakpoints[k], breakpoints[k+1])`` (the last one holding on; zero before the first
        breakpoint), and the stages' rises at the last breakpoint (to continue from).

        Args:
            breakpoints: increasing instants [s], one more than ``powers`` or as many.
            powers: the power of each interval [W].
            time: increasing instants [s] at which the rise is wanted.
            initial: the stages' rises [K] at ``breakpoints[0]`` (default: 0).
        """
        breakpoints = np.asarray(breakpoints, dtype=float)
        powers = np.asarray(powers, dtype=float)
        time = np.asarray(time, dtype=float)
        r = np.asarray(self.resistance, dtype=float)
        tau = np.asarray(self.tau, dtype=float)
        states = np.zeros((breakpoints.size, r.size))
        states[0] = 0.0 if initial is None else initial
        for k in range(1, breakpoints.size):
            decay = np.exp(-(breakpoints[k] - breakpoints[k - 1]) / tau)
            states[k] = states[k - 1] * decay + r * powers[k - 1] * (1.0 - decay)
        index = np.clip(np.searchsorted(breakpoints, time, side="right") - 1, 0, None)
        held = np.minimum(index, powers.size - 1)
        elapsed = np.maximum(time - breakpoints[index], 0.0)[:, None]
        decay = np.exp(-elapsed / tau)
        rise = states[index] * decay + r * powers[held][:, None] * (1.0 - decay)
        before = time < breakpoints[0]
        rise[before] = states[0]
        return rise.sum(axis=1), states[-1]


@dataclass(frozen=True)
class CauerNetwork(ThermalNetwork):
    """A ladder of ``resistance[k]`` [K/W] and ``capacitance[k]`` [J/K], junction first."""

    capacitance: tuple[float, ...]


def cauer_to_foster(network: CauerNetwork) -> FosterNetwork:
    """The Foster network with the same junction impedance as the ladder.

    The ladder's node temperatures ``x`` obey ``C·x' = −G·x + e_1·P`` (``C`` diagonal, ``G``
    the conductance matrix of the ``R_k``), so ``Z(s) = e_1ᵀ (sC + G)⁻¹ e_1``. With
    ``M = C^(−½) G C^(−½) = Q Λ Qᵀ`` (symmetric), ``Z(s) = Σ_k (Q_1k² / C_1) / (s + λ_k)``:
    stage ``k`` has ``τ_k = 1/λ_k`` and ``R_k = τ_k Q_1k² / C_1``.
    """
    r = np.asarray(network.resistance, dtype=float)
    c = np.asarray(network.capacitance, dtype=float)
    n = r.size
    g = 1.0 / r
    conductance = np.zeros((n, n))
    for k in range(n):
        conductance[k, k] += g[k]
        if k + 1 < n:
            conductance[k + 1, k + 1] += g[k]
            conductance[k, k + 1] -= g[k]
            conductance[k + 1, k] -= g[k]
    scale = 1.0 / np.sqrt(c)
    eigenvalues, vectors = np.linalg.eigh(conductance * scale[:, None] * scale[None, :])
    tau = 1.0 / eigenvalues
    resistance = tau * vectors[0] ** 2 / c[0]
    order = np.argsort(tau)
    return FosterNetwork(tuple(float(x) for x in resistance[order]),
                         tuple(float(x) for x in tau[order]))


def as_foster(network: FosterNetwork | CauerNetwork) -> FosterNetwork:
    """``network`` as a Foster network (a Cauer ladder transformed)."""
    return network if isinstance(network, FosterNetwork) else cauer_to_foster(network)
