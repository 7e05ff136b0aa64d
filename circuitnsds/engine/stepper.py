"""The stepper contract: what a way of integrating an MLCS over a time grid provides, and the
registry the analyses choose one from by name.

A *stepper* advances the state of one :class:`~circuitnsds.system.mlcs.MLCS` over the points
of a time grid. The analyses never call a stepper themselves: the driver
(:func:`circuitnsds.engine.driver.drive`) does, and hands what it returns to a recorder. The
rules, in the manner of scipy's ``OdeSolver``:

* **Suitability.** ``StepperClass.unsuited(mlcs)``: ``None`` when the stepper can integrate
  that system, else the reason in words (a stepper exact only for piecewise-linear systems
  refuses a smooth nonlinear element); the analysis refuses the run with that reason.
* **Construction.** ``StepperClass(mlcs, theta=..., tol=..., loop=...)``: the system and the
  run's settings, checked here (a ``ValueError`` naming the bad one). Nothing is integrated yet.
* **The grid belongs to the driver.** Before the first part the driver calls
  :meth:`Stepper.begin` with the *whole* output grid (increasing times [s]; its points are
  where the analysis wants the state: every ``TSTEP``, every breakpoint of the sources, the
  output's ``TSTART``) and says whether it will come in several parts. The stepper may
  prepare anything that depends on the whole grid there (step classes, the sources' corner
  steps, buffers reused by the parts).
* **Parts (segments).** The driver then calls :meth:`Stepper.advance` once per *part*: a
  slice ``grid[i:j + 1]`` of the whole grid, in order, the parts sharing their end points.
  ``start`` is the state at the part's first point (an object with the fields of
  :class:`StartState`); ``continued`` is false for the first part only (its first point is an
  initial state, which need not satisfy the algebraic rows: the stepper restarts there) and
  true for the others (the state the previous part ended with: no restart). The arithmetic
  of a run cut in parts must be that of the same run in one part, bit for bit.
* **Inside a part the stepper owns its steps.** It may step between grid points as it likes
  (fixed steps on the grid, as :class:`~circuitnsds.engine.theta_stepper.ThetaStepper` does;
  steps of its own length, rejected and retried as its error control says; one step per
  switching event, each located exactly), provided it reports the state *at every grid point
  of the part*; what it does between them (rejected steps, internal points) stays inside it.
* **What a part returns** is a :class:`~circuitnsds.engine.integrate.Trajectory`: one row
  per grid point of the part (row 0 the start), the unknowns ``y``, pair currents, impulses
  (the charge of the step into each point, Dirac currents included), the active sets and
  switch states, each step's complementarity residual, the switching ``events`` located in
  the part (time, switch, new state; in time order), the ``tails`` of points whose step was
  split, and ``stats`` (counters; ``steps`` at least). Its arrays may be reused by the next
  part: a recorder copies what it keeps.
* **Events.** A switching the stepper locates inside a step is an event of the trajectory;
  the driver does not look for them and does not change the grid.
* **Failures.** A step with no solution, a state or source that is not finite: raise
  :class:`~circuitnsds.errors.SimulationError` with its structured fields (``cause``,
  ``time``, ``step_interval``, ``switch_states``, ``unknowns``) and ``trajectory`` set to the
  part's points computed before the failure; a ``KeyboardInterrupt`` carries the same
  ``trajectory``. Never a message for the reader (the analyses word the advice,
  :mod:`circuitnsds.analyses.advice`), never a silent result.
* **Progress.** ``progress(t, t_end)`` may be called during a part ([s], the part's end); the
  driver maps it onto the whole grid.

A new stepper is a new module in ``engine/`` with a subclass of :class:`Stepper` and one line
in :data:`STEPPERS`; ``.options method=NAME`` in a netlist or ``method=NAME`` in the API
chooses it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from importlib import import_module
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from circuitnsds.system.mlcs import MLCS

if TYPE_CHECKING:
    from circuitnsds.engine.integrate import Trajectory


def smooth_refusal(mlcs: MLCS) -> str | None:
    """The reason a computation on the linear part of ``mlcs`` alone refuses its smooth
    nonlinear relations (:mod:`circuitnsds.system.smooth`), naming them; ``None`` without."""
    if not mlcs.smooth:
        return None
    names = ", ".join(relation.name for relation in mlcs.smooth[:5])
    more = f" and {len(mlcs.smooth) - 5} more" if len(mlcs.smooth) > 5 else ""
    verb = "is a smooth nonlinear device" if len(mlcs.smooth) == 1 else "are smooth nonlinear devices"
    return (f"{names}{more} {verb}, which only the Newton stepper (method=newton) solves: "
            "this method would leave it out")


@dataclass
class StartState:
    """The state at the first point of a part (what :meth:`Stepper.advance` starts from).

    Attributes:
        y: MNA unknowns (volts, amperes).
        charge: ``E y`` to carry instead, or ``None`` (initial conditions ``y`` cannot express).
        current: pair currents [A] (reported only), or ``None``.
        active: guessed active set of the first step, or ``None``.
        switches: switch states (closed = true), or ``None`` (each switch's initial state).
    """

    y: np.ndarray
    charge: np.ndarray | None = None
    current: np.ndarray | None = None
    active: np.ndarray | None = None
    switches: np.ndarray | None = None

    @classmethod
    def at_end(cls, trajectory: Trajectory) -> StartState:
        """The state a trajectory ended with, copied (views would keep a part's arrays alive
        during the next part, and the next part overwrites them)."""
        return cls(trajectory.y[-1].copy(), None, trajectory.current[-1].copy(),
                   trajectory.active[-1].copy(), trajectory.switches[-1].copy())


class Stepper(ABC):
    """A way of integrating an MLCS over the parts of a grid (see the module's rules).

    Attributes:
        name: the name it is registered under in :data:`STEPPERS`.
        mlcs: the system it integrates.
    """

    name: ClassVar[str]

    def __init__(self, mlcs: MLCS):
        self.mlcs = mlcs

    @classmethod
    def unsuited(cls, mlcs: MLCS) -> str | None:
        """Why this stepper cannot integrate ``mlcs`` (words for the reader), or ``None``. By
        default a stepper of the MLCS's linear part refuses smooth nonlinear relations (it
        would leave them out); a stepper that solves them overrides this."""
        return smooth_refusal(mlcs)

    @abstractmethod
    def begin(self, grid: np.ndarray, *, parts: bool) -> None:
        """Prepare a run over the whole output ``grid`` [s]; ``parts``: it comes in several
        parts (:meth:`advance` is called for each, in order)."""

    @abstractmethod
    def advance(self, grid: np.ndarray, start: StartState, *, continued: bool,
                progress: Callable[[float, float], None] | None = None) -> Trajectory:
        """Integrate the part ``grid`` (a slice of the grid given to :meth:`begin`) from
        ``start``, its first point's state; ``continued``: ``start`` ends the previous part."""

    @abstractmethod
    def trajectory_bytes(self, points: int) -> int:
        """Memory [bytes] a part of ``points`` grid points takes (for the analyses' checks
        before a run)."""


STEPPERS: dict[str, str] = {
    "theta": "circuitnsds.engine.theta_stepper:ThetaStepper",
    "exact": "circuitnsds.engine.exact.stepper:ExactStepper",
    "newton": "circuitnsds.engine.newton_stepper:NewtonStepper",
}
"""The steppers by name: ``"module:Class"``, imported when chosen (one line per stepper)."""
DEFAULT_STEPPER = "auto"
"""The stepper a run uses unless ``.options method`` or ``method=`` names another: ``"auto"``,
the exact integrator where the circuit qualifies (every switching instant located; a flyback's
clamp as written within 2e-6 of its converged value where θ at the netlist's step is 48 %
low), the Newton stepper for smooth elements, θ otherwise. It is slower than θ where it
follows ringing that θ damps away (``benchmarks/method_auto_vs_theta.py``, docs/method.md);
``.options method=theta`` takes θ."""
SMOOTH_STEPPER = "newton"
"""The stepper a run of a system with smooth relations uses unless one is named."""
AUTO = "auto"
"""The method name that chooses: ``newton`` for a system with smooth relations, else ``exact``
where it can integrate the system, else ``theta``."""


def choose_stepper(name: str, mlcs: MLCS) -> tuple[type[Stepper], str | None]:
    """The stepper ``name`` means for ``mlcs`` and, for :data:`AUTO`, why it was chosen (words
    for the reader; ``None`` for a stepper named).

    Raises:
        ValueError: no stepper has that name.
    """
    if str(name).strip().lower() != AUTO:
        return stepper_class(name), None
    if mlcs.smooth:
        return stepper_class(SMOOTH_STEPPER), ("method=auto: the circuit has smooth nonlinear "
                                               "elements (the Newton stepper)")
    exact = stepper_class("exact")
    reason = exact.unsuited(mlcs)
    if reason is None:
        return exact, ("method=auto: the circuit is piecewise linear and its sources have closed "
                       "forms")
    return stepper_class("theta"), f"method=auto: the exact integrator cannot run it: {reason}"


def default_note(mlcs: MLCS) -> str:
    """Why a run without ``.options method`` takes the stepper it takes (words for ``info``):
    with :data:`DEFAULT_STEPPER` ``auto``, the choice and its reason; with a stepper named
    there, what ``auto`` would do for ``mlcs``."""
    if DEFAULT_STEPPER == AUTO:
        _, why = choose_stepper(AUTO, mlcs)
        return str(why).replace("method=auto", "the default, method=auto", 1)
    reason = stepper_class("exact").unsuited(mlcs)
    if reason is not None:
        return f"the default; the exact integrator cannot run it: {reason}"
    return ("the default; .options method=auto would integrate this circuit exactly, its switching "
            "instants located, slower to start")


def stepper_class(name: str) -> type[Stepper]:
    """The stepper registered as ``name`` (case-insensitive).

    Raises:
        ValueError: no stepper has that name (the message lists the known ones).
    """
    key = str(name).strip().lower()
    if key not in STEPPERS:
        raise ValueError(f"unknown integration method {name!r}: the methods are "
                         f"{', '.join(sorted([*STEPPERS, AUTO]))}")
    module, _, attribute = STEPPERS[key].partition(":")
    return getattr(import_module(module), attribute)
