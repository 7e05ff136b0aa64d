"""Result records and exceptions of the complementarity solvers.

Sign conventions (shared by every solver in this package):

* LCP:   ``w = M z + q``,  ``0 <= z  ⊥  w >= 0``.
* MLCP:  ``A u + C z + a = 0``,  ``w = D u + B z + b``,  ``0 <= z ⊥ w >= 0``, ``u`` free.

A pair ``i`` is *active* when ``z_i`` carries the value and ``w_i == 0``
(a conducting diode); inactive pairs have ``z_i == 0`` and ``w_i >= 0``.
In degenerate solutions ``z_i == w_i == 0`` and either label is correct; the
solvers then report the label of the linear system they actually solved, so
that ``result.active`` passed back as ``guess`` always names a factorisable mode.

``residual`` is the scaled complementarity residual defined in
:mod:`circuitnsds.solvers.residual`; a result is only ever returned when
``residual <= tol``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "LCPResult",
    "MLCPResult",
    "LCPError",
    "LCPNoSolution",
    "LCPSolverFailure",
]


@dataclass(slots=True, kw_only=True)
class LCPResult:
    """Solution of ``w = M z + q, 0 <= z ⊥ w >= 0``.

    Attributes:
        z: the unknowns (float64, shape ``(n,)``).
        w: ``M z + q`` recomputed from ``z`` (float64, shape ``(n,)``).
        active: boolean mask, ``True`` where ``w_i == 0`` is imposed and ``z_i``
            carries the value.
        method: the method(s) actually used, e.g. ``"lemke"``, ``"direct"``,
            ``"direct->lemke"``, ``"lemke->enum"``, ``"direct->pivoting"``.
        iterations: Lemke pivots, Newton iterations, active sets tried by
            enumeration or pivoting trials; 0 for a direct (mode reuse) solve.
        residual: scaled residual (see :func:`circuitnsds.solvers.residual.lcp_residual`).
    """

    z: np.ndarray
    w: np.ndarray
    active: np.ndarray
    method: str
    iterations: int
    residual: float


@dataclass(slots=True, kw_only=True)
class MLCPResult(LCPResult):
    """Solution of ``A u + C z + a = 0, w = D u + B z + b, 0 <= z ⊥ w >= 0``: the fields of
    :class:`LCPResult` over the ``m`` pairs (``w = D u + B z + b`` recomputed from ``u, z``;
    the residual of :func:`circuitnsds.solvers.residual.mlcp_residual`), and

    Attributes:
        u: free unknowns (float64, shape ``(n,)``).
    """

    u: np.ndarray


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.3g}"
    if isinstance(value, np.ndarray):
        with np.printoptions(precision=3, threshold=12, edgeitems=4):
            return np.array2string(value, separator=", ")
    return str(value)


class LCPError(Exception):
    """Base class of the complementarity solvers' errors.

    The arguments are kept as the declared attributes below; the further ``evidence``
    keywords are kept too (in :attr:`evidence` and as attributes of their own name,
    e.g. ``err.reason``), and the scalar ones are listed in ``str(err)``.

    Args:
        message: what happened.
        method: the method that raised.
        size: problem size, e.g. ``{"n": 3, "m": 2}`` or ``{"n": 5}``.
        pivots: pivots / iterations done.
        residual: best scaled residual reached (``inf`` if none, ``None`` if not said).
        **evidence: any further data (ray direction, blocking variable, ...).
    """

    message: str
    method: str | None
    size: dict[str, int]
    pivots: int | None
    residual: float | None
    evidence: dict[str, Any]

    def __init__(
        self,
        message: str,
        *,
        method: str | None = None,
        size: dict[str, int] | None = None,
        pivots: int | None = None,
        residual: float | None = None,
        **evidence: Any,
    ) -> None:
        self.message = message
        self.method = method
        self.size = dict(size or {})
        self.pivots = pivots
        self.residual = residual
        self.evidence: dict[str, Any] = dict(evidence)
        for key, value in evidence.items():
            setattr(self, key, value)
        super().__init__(message)

    def __str__(self) -> str:
        parts = [self.message]
        details: list[str] = []
        if self.method is not None:
            details.append(f"method={self.method}")
        if self.size:
            details.append(", ".join(f"{k}={v}" for k, v in self.size.items()))
        if self.pivots is not None:
            details.append(f"pivots/iterations={self.pivots}")
        if self.residual is not None:
            details.append(f"residual={self.residual:.3g}")
        for key, value in self.evidence.items():
            if isinstance(value, (int, float, str, np.ndarray)) and not isinstance(value, bool):
                if isinstance(value, np.ndarray) and value.size > 12:
                    details.append(f"{key}=<array of {value.size}>")
                else:
                    details.append(f"{key}={_fmt(value)}")
        if details:
            parts.append("(" + "; ".join(details) + ")")
        return " ".join(parts)


class LCPNoSolution(LCPError):
    """The problem has no solution (Lemke ended on a secondary ray).

    For a copositive-plus ``M`` (positive semidefinite included) a secondary ray
    proves that ``{z >= 0, M z + q >= 0}`` is empty. For other matrices it only
    says that Lemke could not find a solution; ``confirmed_by_enumeration`` is
    ``True`` when an exhaustive search also found none.

    Evidence attributes (when known): ``ray_z``, ``ray_w``, ``ray_z0``
    (direction of the unbounded edge, normalised to max-norm 1), ``entering``
    (name of the variable whose column had no positive entry), ``z0`` (value
    of the artificial variable on the ray), ``confirmed_by_enumeration``.
    """


class LCPSolverFailure(LCPError):
    """The solver stopped without a verified solution.

    Causes: pivot or iteration limit, numerical trouble (singular or
    non-finite systems), a result whose residual exceeds ``tol``, or a wrong
    guess given to the ``"direct"`` method. The problem may still have a
    solution. Evidence: ``reason`` and whatever the method could report.
    """
