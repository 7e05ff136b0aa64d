"""The periodic orbit of the exact period map, by Newton with its exact derivative
(DESIGN.md "Event-driven exact integration": the period map of the PSS is then exact too).

One period from the state ``x`` (charges and fluxes, :class:`~.mode.StateCoordinates`) is the
exact run over ``[t0, t0 + T]`` (:func:`~.run.run_exact`). Its derivative is the product over
the run's segments of the segment's flow ``e^{F τ}`` (its mode's eigenbasis) and, at a
segment ended by an event whose instant moves with the state (a diode's current or voltage
reaching 0, a switch's control its threshold), the saltation matrix

    S = I + (f⁺ − f⁻) ∇gᵀ / ġ⁻,

``f⁻``, ``f⁺`` the state's derivative just before and after the instant, ``∇g`` the event
function's gradient in the state (``rows P``), ``ġ⁻ = ∇g · f⁻ + ∂g/∂t`` its whole rate of
change before the instant (a PWM comparator's ramp moves ``g`` without the state)
[#saltation]_. A source's corner has a fixed
instant: ``S = I``; so, in effect, has a diode's natural turn-off (its current reaches 0
smoothly: ``f⁺ = f⁻``). Where the derivative jumps at a moving instant (a peak-current
comparator opening the switch) ``S`` is what makes ``Φ`` the map's derivative: without it
Newton stalls on the bundled peak-current buck. Newton on ``P(x) − x = 0`` solves
``(I − Φ) δ = P(x) − x``; the means are the closed-form integrals over the segments.

.. [#saltation] the saltation matrix of a piecewise-smooth flow (Aizerman & Gantmakher; Leine
   & Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical Systems*, §7.4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from circuitnsds.engine.exact.charge import interval_integrals
from circuitnsds.engine.exact.exppoly import ExpPoly
from circuitnsds.engine.exact.run import ExactSystem, LoopState, Segment, run_exact
from circuitnsds.system.mlcs import MLCS

TOLERANCE = 1e-12
"""Newton stops when ``‖P(x) − x‖`` is below this fraction of ``‖x‖`` (and 1e-15)."""
MAX_ITERATIONS = 30
ROUNDING = 64 * np.finfo(float).eps
"""The least relative tolerance Newton is held to (1.4e-14): the bridge rectifier's residual
stalls at 1.8e-16 of its state, and a pss asked for 1e-16 ran its 30 steps there and fell back
to the θ shooting, a less accurate answer for a tighter tolerance."""
SINGULAR = 1e-10
"""A Floquet multiplier closer than this to 1 makes ``I − Φ`` singular (the θ shooting's)."""
ILL_CONDITIONED = 1e12
"""Condition number of ``I − Φ`` above which the Newton step is refused (the θ shooting's)."""


class UndampedPeriod(ArithmeticError):
    """``I − Φ`` is singular: the state along ``vector`` (state coordinates ``x``) is not
    damped over a period (``multiplier``: Φ's eigenvalue closest to 1; ``condition``:
    ``I − Φ``'s), so no Newton step can settle it."""

    def __init__(self, multiplier: complex, condition: float, vector: np.ndarray):
        super().__init__(f"I − Φ is singular (Floquet multiplier {multiplier:.12g}, condition "
                         f"{condition:.3g})")
        self.multiplier, self.condition, self.vector = multiplier, condition, vector


@dataclass
class ExactOrbit:
    """The periodic orbit: ``x`` at ``t0`` (state coordinates), ``y`` there, the monodromy
    ``Φ`` (its Floquet multipliers), Newton's residual history, each unknown's mean over
    the period (the closed-form integral over the segments), the mode at ``t0``, and the
    period's segments (:func:`period_map`'s, from ``x``: what ``ac`` around it takes) with
    the system whose modes they hold."""

    x: np.ndarray
    y: np.ndarray
    monodromy: np.ndarray
    residuals: list[float]
    means: np.ndarray
    active: np.ndarray
    closed: tuple[bool, ...]
    segments: list[Segment]
    system: ExactSystem


def period_map(system: ExactSystem, t0: float, period: float, x: np.ndarray, active: np.ndarray,
               closed: tuple[bool, ...]):
    """``(x(t0 + T), Φ, means, segments, run)`` for the period from ``x`` at ``t0``."""
    mlcs = system.mlcs
    y0 = system.coordinates.V1 @ x
    start = LoopState(t0, x, np.abs(y0), np.asarray(active, bool), tuple(closed))
    segments: list[Segment] = []
    times = np.array([t0, t0 + period])
    run = run_exact(mlcs, times, y0, active, closed, resume=start, system=system,
                    stop=t0 + period, record=segments)
    # the row at t0 + T is the segment holding it; later segments (the loop's look-ahead) are
    # not this period's
    kept = [s for s in segments if s.t < t0 + period]
    n = system.n
    V1t = system.coordinates.V1.T
    r = V1t.shape[0]
    monodromy = np.eye(r)
    total = np.zeros(n)
    for index, segment in enumerate(kept):
        tau = min(segment.tau, t0 + period - segment.t)
        mode = segment.mode
        if mode.eigenvalues.size:
            flow = (mode.W * np.exp(mode.eigenvalues * tau)) @ mode.W_inv
            monodromy = flow.real @ monodromy
        unknowns = ExpPoly(segment.z.coefficients[:, :n], segment.z.powers, segment.z.exponents)
        total += interval_integrals(unknowns, np.array([0.0]), np.array([tau]))[0]
        if segment.ended_by is None or tau < segment.tau or index + 1 >= len(kept):
            continue
        monodromy = _saltation(system, segment, kept[index + 1], n) @ monodromy
    x_end = V1t @ run.y[-1]
    return x_end, monodromy, total / period, kept, run


def _saltation(system: ExactSystem, before: Segment, after: Segment, n: int) -> np.ndarray:
    """``S = I + (f⁺ − f⁻) ∇gᵀ / ġ⁻`` at the event ending ``before``."""
    V1t = system.coordinates.V1.T
    rows = system.event_rows(before.mode, before.closed)
    gradient = rows[before.ended_by] @ before.mode.P  # ∂g/∂x
    f_minus = V1t @ before.z.derivative()(before.tau)[:n]
    f_plus = V1t @ after.z.derivative()(0.0)[:n]
    # the event function's whole rate, ∇g·f⁻ + ∂g/∂t: a PWM comparator's ramp moves g by
    # itself (∇g·f⁻ alone made the voltage-mode loop's Jacobian wrong and Newton stall)
    rate = float(before.functions.table.derivative()(before.tau)[before.ended_by])
    if rate == 0.0:
        return np.eye(V1t.shape[0])
    return np.eye(V1t.shape[0]) + np.outer(f_plus - f_minus, gradient) / rate


def periodic_orbit(mlcs: MLCS, t0: float, period: float, y0: np.ndarray, active: np.ndarray,
                   closed: tuple[bool, ...], *, warm_periods: int = 0, tolerance: float = TOLERANCE,
                   max_iterations: int = MAX_ITERATIONS, acceptable: float | None = None) -> ExactOrbit:
    """Newton on the exact period map from ``y0`` at ``t0`` (after ``warm_periods`` periods of
    the map itself), at most ``max_iterations`` steps (0: the start must already be periodic),
    until ``‖P(x) − x‖`` is within ``tolerance`` of ``‖x‖`` (at least :data:`ROUNDING`: below
    it the residual is the period map's round-off, and Newton stalls there). When the steps
    run out, an orbit within ``acceptable`` (a looser tolerance the caller was asked for) is
    taken.

    Raises:
        UndampedPeriod: ``I − Φ`` is singular at a Newton step (an inductor across a square
            wave of non-zero mean: its current ramps every period; before, a LinAlgError).
        ArithmeticError: Newton did not converge in ``max_iterations`` steps.
    """
    system = ExactSystem(mlcs)
    x = system.coordinates.V1.T @ y0
    active, closed = np.asarray(active, bool), tuple(closed)
    for _ in range(warm_periods):
        x, _, _, _, run = period_map(system, t0, period, x, active, closed)
        active, closed = run.active[-1], tuple(bool(c) for c in run.closed[-1])
    residuals = []
    tolerance = max(tolerance, ROUNDING)
    for iteration in range(max_iterations + 1):
        x_end, monodromy, means, segments, run = period_map(system, t0, period, x, active, closed)
        residual = float(np.max(np.abs(x_end - x), initial=0.0))  # (no state: 0)
        residuals.append(residual)
        scale = max(float(np.max(np.abs(x), initial=0.0)), 1e-3)
        if residual <= tolerance * scale or (iteration == max_iterations and acceptable is not None
                                             and residual <= acceptable * scale):
            return ExactOrbit(x, system.coordinates.V1 @ x, monodromy, residuals, means, active,
                              closed, segments, system)
        if iteration == max_iterations:
            break
        matrix = np.eye(x.size) - monodromy
        values, vectors = np.linalg.eig(monodromy)
        closest = int(np.argmin(np.abs(1.0 - values)))
        condition = float(np.linalg.cond(matrix))
        if abs(1.0 - values[closest]) < SINGULAR or not condition < ILL_CONDITIONED:
            raise UndampedPeriod(complex(values[closest]), condition, vectors[:, closest])
        x = x + np.linalg.solve(matrix, x_end - x)
        active, closed = run.active[-1], tuple(bool(c) for c in run.closed[-1])
    raise ArithmeticError(f"Newton on the exact period map did not converge in {max_iterations} "
                          f"step(s): residuals {', '.join(f'{r:.3g}' for r in residuals)}")
