"""The run-time check of the circuit's own time scales against the step (issue 36, item 8).

:class:`FastModeWatch` is a run-time observer (see :mod:`circuitnsds.circuit.observers`): it
tallies the modes a run visits (switch states and conducting pairs) and its longest step over
every part the driver hands on, and after a run that finished warns about each mode whose
dynamics that step does not follow (:mod:`circuitnsds.checks.time_scales`), naming the
inductors and capacitors that hold it and the step that would. The sources alone are checked
before the run.
"""

from __future__ import annotations

import warnings

import numpy as np

from circuitnsds.checks.time_scales import ModeTally, fast_modes
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import Capacitor
from circuitnsds.errors import CircuitWarning, RunNote
from circuitnsds.units import format_si

MAX_FAST_MODE_WARNINGS = 3
"""At most this many modes are warned about (the slowest first: they matter most)."""


class FastModeWatch:
    """Watches a transient run's modes and steps; ``report`` warns about its fast modes.

    ``theta``: the run's θ (the wording: implicit Euler damps a ringing, θ < 1 aliases it).
    ``jumps``: whether the sources' corners or a UIC start begin transients (a change of mode
    does too: counted from the modes seen).
    """

    def __init__(self, circuit: Circuit, mlcs, theta: float, jumps: bool):
        self.circuit, self.mlcs, self.theta, self.jumps = circuit, mlcs, theta, jumps
        self.tally = ModeTally()
        self.longest = 0.0
        self.exact_tally = ModeTally()
        self.widest = 0.0
        """[s] The widest spacing of rows the exact integrator wrote."""

    def observe(self, mlcs, trajectory, first: int) -> None:
        """Tally the new rows' modes (the initial state left out) and the part's longest step
        (``first`` = 1: row 0 is the previous part's last, the step into row 1 is new). The
        rows the exact integrator wrote (``trajectory.exact_rows``) are tallied apart: it
        follows every mode exactly, whatever the rows' spacing, but rows too far apart do
        not show a ringing (:func:`warn_hidden_ringing`); its hand-offs' θ steps are watched
        as θ's."""
        new = max(first, 1)
        switches, active = trajectory.switches[new:], trajectory.active[new:]
        steps = np.diff(trajectory.time)[new - 1:]
        exact = trajectory.exact_rows
        if exact is not None:
            written = exact[new:]
            if written.all():  # (every row the exact loop's: no copies)
                self.exact_tally.add(switches, active)
                self.widest = max(self.widest, float(steps.max(initial=0.0)))
                return
            if written.any():
                self.exact_tally.add(switches[written], active[written])
                self.widest = max(self.widest, float(steps[written].max()))
            stepped = ~written
            switches, active, steps = switches[stepped], active[stepped], steps[stepped]
        self.tally.add(switches, active)
        if steps.size:
            self.longest = max(self.longest, float(steps.max()))

    def report(self) -> None:
        if self.longest > 0.0:
            warn_fast_modes(self.circuit, self.mlcs, self.tally.modes(), self.longest, self.theta,
                            self.jumps)
        if self.widest > 0.0:
            warn_hidden_ringing(self.circuit, self.mlcs, self.exact_tally.modes(), self.widest)


def warn_fast_modes(circuit: Circuit, mlcs, modes: list[tuple[np.ndarray, np.ndarray]], h: float,
                    theta: float, jumps: bool = True) -> None:
    """Warn about each of ``modes`` (``(switch states, active set)``, the most visited first)
    whose dynamics the step ``h`` [s] does not follow: a ringing mode is a
    :class:`~circuitnsds.errors.CircuitWarning` (an error under --strict), a decaying one a
    :class:`~circuitnsds.errors.RunNote`."""
    # (``jumps``: the sources' corners or a UIC start; a change of mode is one too)
    for mode in fast_modes(mlcs, h, modes, jumps or len(modes) > 1)[:MAX_FAST_MODE_WARNINGS]:
        names = ", ".join(holders(circuit, mode.unknowns)) or ", ".join(mode.unknowns)
        advice = (f"ngspice's own step control would follow it. Use a step of "
                  f"{format_si(mode.needed_step, 's')} or less (--step, or TSTEP of .tran)")
        if mode.rings:  # a wrong peak, frequency and decay: a warning (an error under --strict)
            warnings.warn(CircuitWarning(
                f"{circuit.file}: the mode of {names} rings at {format_si(mode.frequency, 'Hz')} "
                f"(period {format_si(1 / mode.frequency, 's')}, damping ratio {mode.damping:.2g}) "
                f"but the step is {format_si(h, 's')}, {1 / (mode.frequency * h):.2g} steps per "
                "period: " + ("implicit Euler damps that ringing away" if theta == 1.0 else
                              "the θ-method misses or aliases that ringing") + f"; {advice}"),
                stacklevel=2)
        else:  # a transient of a few steps shaped wrongly: a note
            warnings.warn(RunNote(
                f"{circuit.file}: the mode of {names} settles with a time constant of "
                f"{format_si(mode.time_constant, 's')} but the step is {format_si(h, 's')}: its "
                "transients (and the switching instants that depend on them) are followed only "
                f"roughly; {advice}"), stacklevel=2)


def warn_hidden_ringing(circuit: Circuit, mlcs, modes: list[tuple[np.ndarray, np.ndarray]],
                        spacing: float) -> None:
    """Warn about each ringing mode of ``modes`` (as :func:`warn_fast_modes`) whose period the
    exact integrator's rows, ``spacing`` [s] apart, do not resolve. Each row's values are
    exact, but the ringing's peaks fall between rows: a series RLC ringing at 159 kHz read at
    100 µs rows peaks at 10 V in them, at 18.55 V in the circuit (a
    :class:`~circuitnsds.errors.CircuitWarning`: a peak read from the rows is wrong). Only the
    modes the rows fall in are looked at: a ringing mode entered and left between two rows
    (a DCM ring shorter than TSTEP) is not warned about."""
    for mode in fast_modes(mlcs, spacing, modes, jumps=False)[:MAX_FAST_MODE_WARNINGS]:
        names = ", ".join(holders(circuit, mode.unknowns)) or ", ".join(mode.unknowns)
        warnings.warn(CircuitWarning(
            f"{circuit.file}: the mode of {names} rings at {format_si(mode.frequency, 'Hz')} "
            f"(period {format_si(1 / mode.frequency, 's')}, damping ratio {mode.damping:.2g}) "
            f"but the rows are {format_si(spacing, 's')} apart, {1 / (mode.frequency * spacing):.2g} "
            "per period: the exact integrator follows the ringing and each row is exact, but its "
            f"peaks fall between the rows; use a TSTEP of {format_si(mode.needed_step, 's')} or "
            "less (--step, or TSTEP of .tran) to see them"), stacklevel=2)


def holders(circuit: Circuit, unknowns: tuple[str, ...]) -> list[str]:
    """The inductors and capacitors behind state unknowns (``i(l1)`` → l1, ``v(b)`` → the
    capacitors at node b), sorted by name (a ringing mode holds its energy in its inductors
    and capacitors alike: their order by energy is a matter of rounding)."""
    names: list[str] = []
    for unknown in unknowns:
        inner = unknown[2:-1]
        if unknown.startswith("i("):
            found = [inner]
        else:
            found = [e.name for e in circuit.elements
                     if isinstance(e, Capacitor) and inner in e.nodes]
        names += [name for name in found if name not in names]
    return sorted(names)
