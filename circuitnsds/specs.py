"""Analysis specifications: what to run, as plain data (no circuit, no behaviour beyond itself).

The front end reads a netlist's analysis lines (``.tran``, ``.pss``, ``.ac``) into these
objects, beside the :class:`~circuitnsds.circuit.circuit.Circuit` (its ``analyses`` mapping);
an analysis in :mod:`circuitnsds.analyses` takes a circuit and its spec. The circuit itself
never reads them: the time scale that fills in a source's omitted fields (ngspice ties
``PULSE`` rise time to TSTEP, ``SIN`` frequency to 1/TSTOP, ...) comes from the analysis
being run, as a :class:`SourceDefaults`, so an analysis without a time axis never invents a
time step. This module is foundation: every layer may hold a spec.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import NamedTuple

import numpy as np

from circuitnsds.errors import SourceLocation


class SourceDefaults(NamedTuple):
    """TSTEP and TSTOP [s] from which a source's omitted fields are filled, as ngspice does
    (``PULSE`` TR = TF = TSTEP and PW = PER = TSTOP, ``SIN`` FREQ = 1/TSTOP, ``EXP`` TAU1 =
    TAU2 = TSTEP: see :mod:`circuitnsds.system.stimuli`)."""

    step: float
    stop: float


@dataclass(frozen=True)
class TransientSpec:
    """A transient analysis: ``.tran TSTEP TSTOP [TSTART [TMAX]] [UIC]`` (times in seconds).

    Attributes:
        step: TSTEP, the time step [s]; every source breakpoint is also a grid point.
        stop: TSTOP, the end time [s].
        start: TSTART, the first time written to the waveforms [s].
        max_step: TMAX, an upper bound on the step [s] (``None``: none).
        uic: start from initial conditions instead of the operating point.
        theta: θ of the θ-method in [0.5, 1] (``None``: ``.options theta``, else 1).
        refine_step: ``step`` may be divided so that the sources are resolved (a ``.tran``
            line's TSTEP: results are still reported every TSTEP); ``False`` for a step
            the caller gave, which is obeyed (with a warning when it is too coarse).
        location: the ``.tran`` line, if the spec was read from one.
    """

    step: float
    stop: float
    start: float = 0.0
    max_step: float | None = None
    uic: bool = False
    theta: float | None = None
    refine_step: bool = True
    location: SourceLocation | None = None

    @property
    def source_defaults(self) -> SourceDefaults:
        """TSTEP and TSTOP for the sources' omitted fields."""
        return SourceDefaults(self.step, self.stop)

    @property
    def grid_step(self) -> float:
        """The step the grid is built with [s]: TSTEP, bounded by TMAX."""
        return min(self.step, self.max_step) if self.max_step else self.step

    def overridden(self, **given: float | bool | None) -> TransientSpec:
        """A copy with the fields given (``None``: keep this spec's); a ``step`` given is
        obeyed, not refined (``refine_step`` becomes false)."""
        known = {f.name for f in fields(self)}
        unknown = sorted(set(given) - known)
        if unknown:
            raise TypeError(f"TransientSpec has no field(s) {', '.join(unknown)}")
        changes = {name: value for name, value in given.items() if value is not None}
        if "step" in changes:
            changes.setdefault("refine_step", False)
        return replace(self, **changes)


TranSpec = TransientSpec
"""The name ``TransientSpec`` had before analysis specs left ``Circuit`` (kept for one release)."""


@dataclass(frozen=True)
class PssSpec:
    """A periodic steady state: ``.pss GFREQ [TSTAB [OSCNOB [PSSPOINTS [HARMS [SCITER
    [STEADYCOEFF]]]]]] [UIC]`` (ngspice's field order; see docs/pss.md for what circuitnsds
    makes of each).

    Attributes:
        frequency: the fundamental frequency [Hz] (the period is its inverse).
        stabilisation: transient time [s] run before the shooting starts.
        points: grid steps per period (``None``: the ``.tran`` step, else 1000).
        iterations: Newton iterations per round (``None``: the analysis' default).
        tol: relative tolerance of the periodicity residual (``None``: default).
        uic: start from initial conditions instead of the operating point.
    """

    frequency: float
    stabilisation: float = 0.0
    points: int | None = None
    iterations: int | None = None
    tol: float | None = None
    uic: bool = False
    location: SourceLocation | None = None


@dataclass(frozen=True)
class AcSpec:
    """A small-signal sweep: ``.ac DEC|OCT|LIN N FSTART FSTOP`` (frequencies in Hz)."""

    sweep: str
    points: int
    start: float
    stop: float
    location: SourceLocation | None = None

    def frequencies(self) -> np.ndarray:
        """The sweep's frequencies [Hz], as ngspice spaces them (DEC/OCT: N per decade/octave
        from FSTART while <= FSTOP; LIN: N points from FSTART to FSTOP)."""
        base = 10.0 if self.sweep == "dec" else 2.0
        count = (self.points if self.sweep == "lin" else
                 int(np.floor(self.points * np.log(self.stop / self.start) / np.log(base) + 1e-9)) + 1)
        if count > MAX_FREQUENCIES:  # each one a complex solve; the results would not fit
            from circuitnsds.errors import CircuitError

            raise CircuitError(f"{count:.3g} frequencies (limit {MAX_FREQUENCIES:.0e}) in "
                               f"{self.sweep} {self.points:g} {self.start:g} {self.stop:g}",
                               where=self.location if self.location is not None else "--points",
                               hint="fewer points per decade (20 is usual) or a "
                               "narrower range")
        if self.sweep == "lin":
            return np.linspace(self.start, self.stop, self.points)
        return self.start * base ** (np.arange(count) / self.points)


MAX_FREQUENCIES = 1_000_000
"""Longest AC sweep [frequencies]: beyond it the results would not fit in memory."""


AnalysisSpec = TransientSpec | PssSpec | AcSpec
"""Any analysis spec; ``Circuit.analyses`` maps ``"tran"``, ``"pss"``, ``"ac"`` to one each."""
