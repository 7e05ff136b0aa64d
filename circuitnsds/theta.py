"""The θ of the θ-method: its range and the one test of it.

A foundation module (it imports nothing of the package), so that the front end
(``.options theta``), the transient analysis and the engine test θ the same way.
"""

from __future__ import annotations

__all__ = ["THETA_RANGE", "THETA_HINT", "theta_in_range", "theta_text"]

THETA_RANGE = (0.5, 1.0)
"""The θ the θ-method accepts: 1 is implicit Euler, 0.5 the trapezoidal rule (A-stable
for θ >= 0.5)."""
THETA_HINT = "1 is implicit Euler, 0.5 the trapezoidal rule"
"""What to tell a user whose θ is out of range."""


def theta_in_range(theta: float) -> bool:
    """Whether ``theta`` lies in :data:`THETA_RANGE` (callers that know where the value came
    from word their own error)."""
    return THETA_RANGE[0] <= theta <= THETA_RANGE[1]


def theta_text(theta: float) -> str:
    """``theta`` as written in a message: short (``2``, ``0.75``) when that is the number, all
    its digits otherwise (``0.4999999999`` is not ``0.5``, which ``:g`` printed)."""
    short = f"{theta:g}"
    return short if float(short) == theta else repr(float(theta))
