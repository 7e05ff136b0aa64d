"""What an analysis tells the reader about an engine error: the hint of each error cause
(:data:`ADVICE`, :func:`advise`), the unknowns named as the reader knows them
(:func:`word_unknowns`) and the diagnosis of a failed step (:func:`diagnose`).

The engine raises :class:`~circuitnsds.errors.SimulationError` with structured fields
(``cause``, ``unknowns``, ``step_interval``, ``switch_states``, ``trajectory``) and words no
advice; every analysis that runs the engine (transient, pss, ac) turns them into words here.
"""

from __future__ import annotations

import numpy as np

from circuitnsds.checks.rules import ill_conditioning
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.errors import CircuitError, SimulationError

UNSTABLE = ("the circuit is unstable (a negative resistance, or controlled sources with a loop gain "
            "above 1)")
"""What a state that overflows says about the circuit."""

ADVICE = {
    SimulationError.STEP_NOT_FINITE: "check the step (--step, .tran TSTEP) and the capacitor and inductor "
                                     "values",
    SimulationError.STATE_NOT_FINITE: f"{UNSTABLE} or a value overflowed; the waveforms before that instant "
                                      "are kept",
    SimulationError.SOURCE_NOT_FINITE: "check the source's parameters (a zero time constant or period, an "
                                       "overflow)",
    SimulationError.STEP_MAP_SINGULAR: "a node is left floating in that mode (every diode at it blocks): add "
                                       "a resistor to ground, or a diode off-resistance (Roff)",
}
"""The hint of an engine error by its ``cause`` (a failed step's comes from :func:`diagnose`)."""


def advise(error: SimulationError) -> None:
    """Give an engine error the hint of its ``cause`` (:data:`ADVICE`) unless it has one: what
    every analysis that runs the engine does with its errors."""
    error.hint = error.hint or ADVICE.get(error.cause)


HUGE = 1e100
"""A state beyond this magnitude [V or A] before a failed step means the circuit blew up."""


def _reader_name(unknown: str) -> str:
    """``v(a)`` -> ``node a``, ``i(v1)`` -> ``source v1``: an MNA unknown as the reader knows it."""
    return unknown.replace("v(", "node ").replace("i(", "source ").rstrip(")")


def word_unknowns(error: SimulationError) -> None:
    """Name the unknowns an engine error refers to (``error.unknowns``) as the reader knows them."""
    for unknown in error.unknowns:
        error.message = error.message.replace(unknown, _reader_name(unknown))


ANALYSE_LIMIT = 3000
"""Largest number of unknowns and pairs whose failed step is analysed (the well-posedness
analysis works on dense matrices)."""


def diagnose(error: SimulationError, circuit: Circuit, mlcs, grid: np.ndarray, theta: float) -> None:
    """Give a failed step's error (``error.step_interval`` set) its hint: an ill-conditioned
    element's values, a state that blew up before the step, or the well-posedness analysis
    of that step's LCP (``theta``: the run's θ; the first step of ``grid`` is implicit Euler)."""
    from circuitnsds.checks.wellposed import analyse, forced_currents

    interval = error.step_interval
    if interval is None:
        return
    error.hint = (f"devices: {', '.join(dict.fromkeys(mlcs.pair_devices))}; look for a diode (or "
                  "Zener) that no current can pass in either state, e.g. in series with a current source")
    t0, t1 = interval
    ill = ill_conditioning(circuit.elements, t1 - t0)
    if ill is not None:  # the values, not the devices' states, are the trouble
        error.hint = ill
        return
    trajectory = error.trajectory
    if trajectory is not None and np.abs(trajectory.y[-1]).max(initial=0.0) > HUGE:
        error.hint = (f"the state reached {np.abs(trajectory.y[-1]).max():.3g} before this step: {UNSTABLE}; "
                      "the waveforms before that instant are kept")
        return
    states = error.switch_states
    if mlcs.n + mlcs.m > ANALYSE_LIMIT:  # the analysis is dense: keep the devices' hint
        return
    try:
        analysis = analyse(mlcs, t1 - t0, None if states is None else tuple(states),
                           1.0 if t0 == grid[0] else theta)
    except CircuitError:  # the step's matrices are not finite: keep the hint as it is
        return
    analysis.forced = forced_currents(circuit, analysis.switch_states)
    if analysis.verdict in {"P", "none"} and not analysis.forced:
        error.hint = ("this step's LCP has a P-matrix (or no pairs), so it has exactly one solution: "
                      "the solver failed numerically; try another step size (--step) and please "
                      "report it")
    else:
        error.hint = f"this step's LCP: {analysis.summary()}"
