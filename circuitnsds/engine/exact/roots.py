"""The first instant an event function goes negative, with no earlier crossing missed.

An event function is a real exponential polynomial ``g(τ) = Re Σ c_j τ^p_j e^{ν_j τ}``
(:class:`~circuitnsds.engine.exact.exppoly.ExpPoly`), non-negative while the mode holds
(a conducting diode's current, a blocking diode's distance from its threshold, a switch
control's distance from the threshold it would cross). The search for its first root on
``[0, T]`` is certified: an interval ``[a, b]`` is declared free of roots only when a
*lower bound* of ``g`` over it is above ``-tol``. The bound splits the terms:

* a *slow* term (``|ν|·(b-a) <= 1``) enters a Taylor model at ``a``, the better of
  ``g_s(a) + g_s'(a)(τ-a) - M (τ-a)²/2`` with ``M`` an upper bound of ``|g_s''|`` on ``[a, b]``
  and ``g_s(a) + g_s'(a)(τ-a) + g_s''(a)(τ-a)²/2 - M₃ (τ-a)³/6`` with ``M₃`` one of
  ``|g_s'''|`` (its least on ``[a, b]``: the ends and the cubic's local minimum), which
  clears a convex stretch (a ring's trough) whole where the first halves it until
  ``M (b-a)`` is below the slope (intervals visited per segment: 27.7 -> 19.0 on the DCM
  boost of ``benchmarks/``, 7.3 -> 3.7 on the three-phase inverter);
* a *fast* term (a quickly decaying or oscillating one) enters by its largest magnitude on
  ``[a, b]``, ``|c| b^p e^{max(Re ν a, Re ν b)}``.

An interval that cannot be declared root-free is halved, left half first, so the root
found is the first one. Once ``g'`` is certified negative on an interval where ``g``
changes sign, the single root there is refined by Brent's method to round-off. A function
that touches ``-tol`` without crossing it (grazing) ends in intervals below the time
resolution, where the sign at the right end decides.
"""

from __future__ import annotations

import math

import numpy as np

from circuitnsds.engine.exact.exppoly import ExpPoly

MAX_DEPTH = 200
"""Halvings of one interval at most (far below the resolution of a double)."""


def _lowest(g0: np.ndarray, g1: np.ndarray, g2: np.ndarray, third: np.ndarray, width: float) -> np.ndarray:
    """The least over ``s`` in ``[0, width]`` of each cubic ``g0 + g1 s + g2 s²/2 - third s³/6``:
    its ends and its local minimum (the smaller zero of its slope, written without
    cancellation; the parabola's vertex when ``third = 0``)."""
    low = np.minimum(g0, g0 + g1 * width + g2 * width**2 / 2 - third * width**3 / 6)
    with np.errstate(divide="ignore", invalid="ignore"):
        discriminant = g2 * g2 + 2 * third * g1
        root = np.sqrt(np.maximum(discriminant, 0.0))
        smaller = np.where(g2 > 0.0, -2 * g1 / (g2 + root), (g2 - root) / third)
        cubic = np.where(discriminant > 0.0, smaller, -1.0)
        s = np.where(third > 0.0, cubic, np.where(g2 > 0.0, -g1 / g2, -1.0))
    inside = (s > 0.0) & (s < width)
    s = np.where(inside, s, 0.0)
    return np.where(inside, np.minimum(low, g0 + g1 * s + g2 * s**2 / 2 - third * s**3 / 6), low)


def lower_bounds(g: ExpPoly, a: float, b: float) -> np.ndarray:
    """A lower bound on ``[a, b]`` of each component of ``g`` (module docstring): one call
    bounds every event function of a segment, the columns of one table."""
    width = b - a
    slow = np.abs(g.exponents) * width <= 1.0
    magnitude = np.abs(g.coefficients)
    p = g.powers
    growth = np.exp(np.maximum(g.exponents.real * a, g.exponents.real * b))
    fast_bound = (b ** p[~slow] * growth[~slow]) @ magnitude[~slow]
    ps, nu = p[slow], g.exponents[slow]
    size = np.abs(nu)
    second = growth[slow] * (size**2 * b**ps + 2 * ps * size * b ** np.maximum(ps - 1, 0)
                             + ps * (ps - 1) * b ** np.maximum(ps - 2, 0))
    bend = second @ magnitude[slow]
    third = growth[slow] * (size**3 * b**ps + 3 * ps * size**2 * b ** np.maximum(ps - 1, 0)
                            + 3 * ps * (ps - 1) * size * b ** np.maximum(ps - 2, 0)
                            + ps * (ps - 1) * (ps - 2) * b ** np.maximum(ps - 3, 0))
    bend3 = third @ magnitude[slow]
    # value and derivatives of the slow part at a: d/dτ τ^p e^{ντ} = (p τ^{p-1} + ν τ^p) e^{ντ},
    # d²/dτ² τ^p e^{ντ} = (ν (ν τ^p + 2 p τ^{p-1}) + p (p-1) τ^{p-2}) e^{ντ}
    at_a = np.exp(nu * a)
    power = a ** ps
    lowered = np.where(ps > 0, ps * a ** np.maximum(ps - 1, 0), 0.0)
    lowered2 = np.where(ps > 1, ps * (ps - 1) * a ** np.maximum(ps - 2, 0), 0.0)
    coefficients = g.coefficients[slow]
    g0 = ((power * at_a) @ coefficients).real
    g1 = (((lowered + nu * power) * at_a) @ coefficients).real
    g2 = (((nu * (nu * power + 2 * lowered) + lowered2) * at_a) @ coefficients).real
    second_order = np.minimum(g0, g0 + g1 * width - bend * width**2 / 2)
    return np.maximum(second_order, _lowest(g0, g1, g2, bend3, width)) - fast_bound


def _lower_bound(g: ExpPoly, a: float, b: float) -> float:
    """A lower bound of the scalar ``g`` on ``[a, b]``."""
    return float(lower_bounds(g, a, b)[0])


def first_root(g: ExpPoly, horizon: float, tol: float, resolution: float) -> float | None:
    """The first ``τ`` in ``(0, horizon]`` where ``g`` crosses below ``-tol`` (returned as the
    root of ``g`` itself, to round-off), or ``None`` if ``g >= -tol`` on the whole interval.

    ``resolution`` [s]: intervals shorter than this are not halved further.
    """
    slope = g.derivative()
    stack = [(0.0, horizon, 0)]
    while stack:
        a, b, depth = stack.pop()
        if _lower_bound(g, a, b) > -tol:
            continue
        gb = float(g(b)[0])
        if gb < -tol and _lower_bound(ExpPoly(-slope.coefficients, slope.powers, slope.exponents),
                                      a, b) > 0:
            return _refine(g, a, b)
        if b - a <= resolution or depth >= MAX_DEPTH:
            if gb < -tol:
                return _refine(g, a, b)
            continue
        m = 0.5 * (a + b)
        stack.append((m, b, depth + 1))
        stack.append((a, m, depth + 1))
    return None


def _refine(g: ExpPoly, a: float, b: float) -> float:
    """The root of ``g`` in ``[a, b]`` (``g(a) >= 0 > g(b)`` up to the tolerance); ``a`` if
    ``g(a)`` is already negative."""
    ga, gb = float(g(a)[0]), float(g(b)[0])
    if ga <= 0:
        return a
    from scipy.optimize import brentq

    return float(brentq(lambda t: float(g(t)[0]), a, b, xtol=4 * math.ulp(max(b, 1e-300)),
                        rtol=4 * np.finfo(float).eps, maxiter=200)) if gb < 0 else b
