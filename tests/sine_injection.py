"""The brute-force reference of small-signal AC: a transient with a small sine injected,
started from the periodic steady state, and the fundamental of its response by a DFT over
whole periods of the sine and of the switching."""

from __future__ import annotations

import numpy as np

from circuitnsds.engine.integrate import integrate
from circuitnsds.engine.timegrid import time_grid
from circuitnsds.specs import SourceDefaults


def injected_response(injected, start, step: float, frequency: float, amplitude: float,
                      settle: float, window: float, signal: str = "v(out)") -> complex:
    """``signal``'s complex amplitude at ``frequency`` per unit of the injected ``a·sin(ωt)``.

    Args:
        injected: the circuit with the sine added to the input.
        start: the settled period's trajectory (its first point is where the run starts).
        step: the integration step [s].
        frequency: of the injected sine [Hz]; ``window`` must hold whole periods of it.
        amplitude: of the injected sine (its unit is the input's).
        settle: time [s] left for the injection's start-up to decay.
        window: length [s] of the DFT after ``settle``.
    """
    mlcs = injected.mlcs(SourceDefaults(step, settle + window))
    grid = time_grid(step, settle + window, mlcs.breakpoints(settle + window))
    run = integrate(mlcs, grid, start.y[0], None, None, start.active[0], start.switches[0])
    out = run.y[:, mlcs.unknowns.index(signal)]
    inside = np.flatnonzero(grid > settle + 1e-12)
    weights = (grid[inside] - grid[inside - 1]) / window
    coefficient = np.sum(weights * out[inside] * np.exp(-2j * np.pi * frequency * grid[inside]))
    return 2 * coefficient / (-1j * amplitude)  # a·sin(ωt) = Re(−j a e^{jωt})
