"""The periodic steady state on the exact period map (``.options method=exact``, and
``method=auto`` where the exact integrator can run the circuit: there, where Newton on this
map fails, the θ shooting instead): the orbit by Newton with the exact monodromy
(:func:`~circuitnsds.engine.exact.periodic.periodic_orbit`: saltation at every located
event, no quantised instants, no implicit-Euler error), shown on the period's grid by the
exact stepper.

The monodromy and multipliers are given in the state unknowns (:func:`state_unknowns`),
like the θ shooting's; the means of the unknowns over the period are the closed-form
integrals (``PSSResult.means``). There are no step maps: ``ac`` around it takes the orbit's
segments (``PSSResult.exact``, :mod:`circuitnsds.engine.exact.small_signal`).
"""

from __future__ import annotations

import warnings

import numpy as np

from circuitnsds.analyses.recorders import TrajectoryRecorder
from circuitnsds.analyses.signals import trajectory_waveforms
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.engine.driver import drive
from circuitnsds.engine.exact.mode import NotIndexOne, StateCoordinates
from circuitnsds.engine.exact.periodic import (
    MAX_ITERATIONS,
    SINGULAR,
    TOLERANCE,
    UndampedPeriod,
    periodic_orbit,
)
from circuitnsds.engine.exact.run import Chattering
from circuitnsds.engine.exact.small_signal import ExactPeriod
from circuitnsds.engine.exact.stepper import HANDOFF_CAUSES, ExactStepper
from circuitnsds.engine.step_maps import state_unknowns
from circuitnsds.engine.stepper import StartState
from circuitnsds.errors import CircuitWarning, SimulationError
from circuitnsds.system.mlcs import MLCS

MARGINAL = 1e-9
"""A Floquet multiplier this close to the unit circle or beyond it is warned about: the orbit
found is then not one a transient settles to (an undamped LC driven near its resonance has an
exact periodic solution, of 1/|1 − μ| times the drive, which its transient never reaches)."""
SLOWLY = 1e-6
"""A largest Floquet multiplier within this of the unit circle (and beyond :data:`MARGINAL`) is
warned about too: a transient takes over 1e6 periods to settle to the orbit (a tank damped
only by a 1 GΩ bleeder and 1 µΩ switches, switched at its resonance: 2.1 MV after 5e6 periods)."""


def _along(mlcs: MLCS, vector: np.ndarray) -> str:
    """The unknowns that make up most of a vector of state coordinates ``x``."""
    size = np.abs(StateCoordinates.of(mlcs.E.toarray()).V1 @ vector)
    return ", ".join(mlcs.unknowns[j] for j in np.argsort(size)[::-1][:3] if size[j] > 0.1 * size.max())


class NoSteadyState(SimulationError):
    """The exact orbit is not one a transient reaches (:func:`_judge_multipliers`): final,
    ``method=auto`` does not take the θ shooting instead (whose steps' damping would set an
    amplitude)."""


def _judge_multipliers(circuit: Circuit, mlcs: MLCS, monodromy: np.ndarray, period: float) -> None:
    """Warn of an orbit that is not unique, not stable, not attracting or attracting only
    slowly (:data:`MARGINAL`, :data:`SLOWLY`), from the Floquet multipliers of ``monodromy``
    (in the state coordinates ``x``); refuse one with an undamped multiplier (on the unit
    circle) within :data:`~circuitnsds.analyses.pss.RESONANCE_GAP` of 1 (an undamped tank
    driven near its resonance: the orbit is 1/|1 − μ| times what the sources put in along
    it, 2.08 MV for 1 V at 2.4e-7 below f0, and no transient ever reaches it; the θ shooting
    refused it too, its amplitude being its steps' damping). A damped one, however slowly
    (a tank damped by 1 GΩ: 2.1 MV reached over 5e6 periods), is the circuit's own steady
    state: warned, with the time it takes."""
    from circuitnsds.analyses.pss import RESONANCE_GAP, RESONANCE_HINT, UNDAMPED_HINT

    if not monodromy.size:
        return
    values, vectors = np.linalg.eig(monodromy)
    magnitudes = np.abs(values)
    closest = int(np.argmin(np.abs(1.0 - values)))
    if abs(1.0 - values[closest]) < SINGULAR:
        warnings.warn(CircuitWarning(
            f"{circuit.file}: the periodic solution is not unique: the state along "
            f"{_along(mlcs, vectors[:, closest])} is not damped (Floquet multiplier 1), so every "
            f"value of it repeats and the one shown is the initial state's; {UNDAMPED_HINT}"),
            stacklevel=5)
        return
    largest = int(np.argmax(magnitudes))
    top = float(magnitudes[largest])
    resonant = [j for j in np.argsort(np.abs(1.0 - values))
                if abs(magnitudes[j] - 1.0) <= MARGINAL and abs(1.0 - values[j]) < RESONANCE_GAP]
    if resonant and top <= 1.0 + MARGINAL:
        j = int(resonant[0])
        gap = float(abs(1.0 - values[j]))
        raise NoSteadyState(
            f"no periodic steady state to show: along {_along(mlcs, vectors[:, j])} the circuit is "
            f"undamped (Floquet multiplier |μ| = {magnitudes[j]:.9g}) and driven near its resonance "
            f"(|1 − μ| = {gap:.2g}): "
            f"the exact periodic solution, about {1.0 / gap:.2g} times what the sources put in along "
            "it, is not one a transient reaches", where=circuit.file, hint=RESONANCE_HINT)
    if top > 1.0 - MARGINAL:
        what = ("not stable" if top > 1.0 + MARGINAL else
                f"not attracting, the state along {_along(mlcs, vectors[:, largest])} undamped")
        warnings.warn(CircuitWarning(
            f"{circuit.file}: the periodic solution found is {what} (largest Floquet multiplier "
            f"|λ| = {top:.6g}): a transient would not settle to it"), stacklevel=5)
    elif top > 1.0 - SLOWLY:
        lost = 1.0 - top
        warnings.warn(CircuitWarning(
            f"{circuit.file}: the periodic solution found attracts only slowly: the state along "
            f"{_along(mlcs, vectors[:, largest])} comes {lost:.2g} of its distance closer to it per "
            f"period (largest Floquet multiplier |λ| = {top:.9g}), so a transient settles to it "
            f"over about {1.0 / lost:.2g} periods ({period / lost:.3g} s)"), stacklevel=5)


def exact_pss(circuit: Circuit, mlcs: MLCS, grid: np.ndarray, period: float, y: np.ndarray,
              active: np.ndarray | None, switches: np.ndarray | None, tol: float = TOLERANCE,
              max_iterations: int | None = None):
    """The settled period from ``y`` (the state at ``grid[0]``, after any warm-up) on the
    exact map; ``grid``: the period's output points [s]. Returns a
    :class:`~circuitnsds.analyses.pss.PSSResult` with ``maps = None``. ``tol``: the pss's
    relative tolerance, taken where it is below the exact map's own
    (:data:`~circuitnsds.engine.exact.periodic.TOLERANCE`, 1e-12: Newton converges
    quadratically there; not below its round-off,
    :data:`~circuitnsds.engine.exact.periodic.ROUNDING`); ``max_iterations``: the Newton steps
    allowed (``None``: the exact map's own,
    :data:`~circuitnsds.engine.exact.periodic.MAX_ITERATIONS`), after which an orbit within
    ``tol`` is taken (a ``.pss`` line's SCITER of 5 with STEADYCOEFF 5e-3).

    Raises:
        SimulationError: Newton on the exact map did not converge.
    """
    from circuitnsds.analyses.pss import PSSResult

    active = np.zeros(mlcs.m, bool) if active is None else np.asarray(active, bool)
    closed = tuple(bool(s) for s in (switches if switches is not None
                                     else [s.initially_on for s in mlcs.switches]))
    hint = "run the pss with .options method=theta (the θ shooting falls back to transient periods)"
    try:
        orbit = periodic_orbit(mlcs, float(grid[0]), period, y, active, closed,
                               tolerance=min(tol, TOLERANCE), acceptable=tol,
                               max_iterations=MAX_ITERATIONS if max_iterations is None else max_iterations)
    except UndampedPeriod as exc:
        from circuitnsds.analyses.pss import UNDAMPED_HINT

        raise SimulationError(f"{exc}: the state along {_along(mlcs, exc.vector)} is not damped over a "
                              "period, so no Newton step can settle it", where=circuit.file,
                              hint=UNDAMPED_HINT) from None
    except ArithmeticError as exc:
        raise SimulationError(str(exc), where=circuit.file, hint=hint) from None
    except (Chattering, NotIndexOne) as exc:  # (a transient hands such a stretch to θ; a period map cannot)
        raise SimulationError(f"the exact period map stopped at t = {exc.time:.6g} s: "
                              f"{HANDOFF_CAUSES[type(exc)]}", where=circuit.file, hint=hint) from None
    _judge_multipliers(circuit, mlcs, orbit.monodromy, period)  # (before the period's rows)
    t0 = float(grid[0])
    system, segments = orbit.system, orbit.segments  # (the period from the orbit's x: Newton's last map)
    taus = np.array([min(s.tau, t0 + period - s.t) for s in segments])
    recorder = TrajectoryRecorder()
    drive(ExactStepper(mlcs), grid, StartState(orbit.y, None, None, orbit.active,
                                               np.array(orbit.closed, bool)), recorder)
    run = recorder.trajectory
    run.y[0], run.current[0] = run.y[-1], run.current[-1]  # (t0 and t0 + T: one instant)
    if run.exact_rows is not None:
        run.exact_rows[0] = run.exact_rows[-1]
    exact = ExactPeriod(system, segments, taus, t0, period, orbit.monodromy, run)
    waves = trajectory_waveforms(circuit, mlcs, run, run.time[0], run.time[-1], periodic=True)
    waves.stats.update(analysis="pss", iterations=len(orbit.residuals) - 1)
    state = state_unknowns(mlcs)
    to_state = StateCoordinates.of(mlcs.E.toarray()).V1[state]  # x -> the state unknowns
    monodromy = to_state @ orbit.monodromy @ np.linalg.pinv(to_state)
    multipliers = np.linalg.eigvals(monodromy) if monodromy.size else np.zeros(0)
    multipliers = multipliers[np.argsort(-np.abs(multipliers), kind="stable")]
    scale = max(float(np.max(np.abs(orbit.x), initial=0.0)), 1e-300)
    result = PSSResult(waveforms=waves, period=period, t0=float(grid[0]),
                       state_names=[mlcs.unknowns[j] for j in state], state=orbit.y[state].copy(),
                       iterations=len(orbit.residuals) - 1, residual=orbit.residuals[-1],
                       relative_residual=orbit.residuals[-1] / scale, monodromy=monodromy,
                       multipliers=multipliers, history=[r / scale for r in orbit.residuals],
                       maps=None, mlcs=mlcs, means=dict(zip(mlcs.unknowns, orbit.means.tolist())),
                       exact=exact)
    return result
