"""The θ-method as a stepper (:mod:`circuitnsds.engine.stepper`): one MLCP per grid step,
steps in a known mode taken by the compiled mode loops
(:func:`circuitnsds.engine.integrate.integrate`).

The θ stepper steps on the grid itself (every step ends at a grid point; a step in which a
circuit-controlled switch changes state is split at the located instant, and the point at
its end keeps the last part's state). Its ``loop`` says how the steps whose mode is known
are taken (:data:`~circuitnsds.engine.integrate.STEPPINGS`: ``stepping=`` in the API).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from circuitnsds.engine.integrate import STEPPINGS, Segments, Trajectory, integrate, trajectory_bytes
from circuitnsds.engine.step_system import check_theta
from circuitnsds.engine.stepper import StartState, Stepper
from circuitnsds.system.mlcs import MLCS


class ThetaStepper(Stepper):
    """The θ-method on the grid (θ in [0.5, 1]; the first step, and with θ < 1 the step after
    a switching or a source's corner, implicit Euler). A run in parts shares one stepping
    state (:class:`~circuitnsds.engine.integrate.Segments`): the arithmetic of one run.

    Args:
        mlcs: the system.
        theta: θ in [0.5, 1].
        tol: complementarity tolerance of the step solver.
        loop: one of :data:`~circuitnsds.engine.integrate.STEPPINGS`.

    Raises:
        ValueError: θ out of range or an unknown ``loop``.
    """

    name = "theta"

    def __init__(self, mlcs: MLCS, *, theta: float = 1.0, tol: float = 1e-9, loop: str = "auto"):
        super().__init__(mlcs)
        if loop not in STEPPINGS:
            raise ValueError(f"stepping must be one of {', '.join(STEPPINGS)}, got {loop!r}")
        self.theta, self.tol, self.loop = check_theta(theta), tol, loop
        self.segments: Segments | None = None
        self.whole: np.ndarray | None = None

    @classmethod
    def unsuited(cls, mlcs: MLCS) -> str | None:
        if mlcs.smooth:
            names = ", ".join(relation.name for relation in mlcs.smooth[:6])
            return (f"its mode tables are affine, and {names}"
                    f"{' ...' if len(mlcs.smooth) > 6 else ''} {'is a' if len(mlcs.smooth) == 1 else 'are'} "
                    "smooth nonlinear element(s): method=newton integrates them")
        return None

    def begin(self, grid: np.ndarray, *, parts: bool) -> None:
        self.whole = grid
        self.segments = Segments(grid) if parts else None

    def advance(self, grid: np.ndarray, start: StartState, *, continued: bool,
                progress: Callable[[float, float], None] | None = None) -> Trajectory:
        return integrate(self.mlcs, grid, start.y, start.charge, start.current, start.active,
                         start.switches, theta=self.theta, tol=self.tol, progress=progress,
                         stepping=self.loop, continued=continued, segments=self.segments)

    def trajectory_bytes(self, points: int) -> int:
        return trajectory_bytes(self.mlcs, points)
