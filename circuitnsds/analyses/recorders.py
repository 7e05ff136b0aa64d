"""Recorders: what a run keeps of the parts the driver hands them
(:func:`circuitnsds.engine.driver.drive`).

* :class:`TrajectoryRecorder` keeps everything: the trajectory of a run in one part, from
  which the transient makes its waveforms (capacitor currents, impulses, decimation).
* :class:`SignalRecorder` keeps some signals (and the time and each step's residual), or
  streams them to a sink (a CSV file) part by part: memory bounded by what is kept, or by
  one part.
* :class:`Observed` hands each part to a recorder and to the run-time observers the devices
  declare (:mod:`circuitnsds.circuit.observers`).
"""

from __future__ import annotations

import bisect

import numpy as np

from circuitnsds.analyses.signals import trajectory_waveforms
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.observers import RunObserver
from circuitnsds.engine.driver import Recorder
from circuitnsds.engine.events import event_time
from circuitnsds.engine.integrate import Trajectory
from circuitnsds.errors import CircuitError
from circuitnsds.output.waveforms import Waveforms
from circuitnsds.system.mlcs import MLCS

SEGMENT_BYTES = 256 * 2**20
"""Memory the per-step arrays of one part of a run that keeps only some signals may take
[bytes] (see :func:`segment_steps`)."""
SINK_SEGMENT_STEPS = 2**16
"""Steps per part at most when the rows go to a sink: the sink (a CSV file) formats one
part in a background thread while the next is computed, and only the last one's
formatting is waited for (the 300,600-step flyback, θ = 0.5, in-process, medians of 12
interleaved runs: 167 ms against 225 ms at 2^18 steps; the 1M-step buck the same to the
noise, 344–358 ms; benchmarks/segments.py, docs/performance.md)."""


def segment_steps(mlcs: MLCS) -> int:
    """Steps per part of a run that keeps some signals: :data:`SEGMENT_BYTES` over the bytes
    the integrator stores per step (unknowns, pair currents, impulses, active flags,
    switch states, residual, time, the sources' values)."""
    width = mlcs.n + 4 * mlcs.m + len(mlcs.switches) + len(mlcs.stimuli) + 4
    return max(2, SEGMENT_BYTES // (8 * width))


class TrajectoryRecorder:
    """Keeps the trajectory of a run driven in one part (:attr:`trajectory`; ``None`` before
    the part; after a failure, the points computed before it)."""

    def __init__(self) -> None:
        self.trajectory: Trajectory | None = None

    def record(self, trajectory: Trajectory, first: int) -> None:
        if self.trajectory is not None:
            raise ValueError("a TrajectoryRecorder keeps a run driven in one part")
        self.trajectory = trajectory


class Observed:
    """Hands each part to ``recorder`` and to ``observers`` (each ``observe(mlcs, part, first)``)."""

    def __init__(self, recorder: Recorder, mlcs: MLCS, observers: list[RunObserver]):
        self.recorder, self.mlcs, self.observers = recorder, mlcs, observers

    def record(self, trajectory: Trajectory, first: int) -> None:
        self.recorder.record(trajectory, first)
        for observer in self.observers:
            observer.observe(self.mlcs, trajectory, first)


class SignalRecorder:
    """Keeps the signals ``names`` of a run from ``start`` [s] on (and the time and each step's
    residual), or hands them to ``sink`` part by part; :meth:`result` gives the waveforms.

    ``sink``: an object with ``append(time, columns, residual)`` (and optionally
    ``expect(rows)``), e.g. :class:`~circuitnsds.output.csvfile.CsvStream`; the waveforms
    then hold no rows (their ``stats`` count them: ``rows``). Impulses are not kept.

    Raises:
        CircuitError: a name that is not a signal of ``mlcs``.
    """

    def __init__(self, circuit: Circuit, mlcs: MLCS, grid: np.ndarray, names: list[str],
                 start: float, stop: float, sink=None):
        unknown = [name for name in names if name not in mlcs.output_names]
        if unknown:
            raise CircuitError(f"unknown signal(s) {', '.join(unknown)}", where="signals",
                               hint=f"available: {', '.join(mlcs.output_names)}")
        self.circuit, self.mlcs, self.grid, self.names = circuit, mlcs, grid, names
        self.start, self.stop, self.sink = start, stop, sink
        self.kept: dict[str, list[np.ndarray]] = {name: [] for name in names}
        self.times: list[np.ndarray] = []
        self.residuals: list[np.ndarray] = []
        self.events: list = []
        self.stats: dict[str, float] = {}
        self.threshold = start - 1e-12 * stop  # rows before TSTART are not written
        # the first row's time: events from it on
        self.shown_from = grid[int(np.searchsorted(grid, self.threshold))]
        if sink is not None and hasattr(sink, "expect"):
            sink.expect(grid.size - int(np.searchsorted(grid, self.threshold)))
        self.written = 0

    def part_steps(self) -> int:
        """Steps per part for the driver: :func:`segment_steps`, at most
        :data:`SINK_SEGMENT_STEPS` with a sink."""
        rows = segment_steps(self.mlcs)
        return rows if self.sink is None else min(rows, SINK_SEGMENT_STEPS)

    def record(self, trajectory: Trajectory, first: int) -> None:
        waves = trajectory_waveforms(self.circuit, self.mlcs, trajectory, self.grid[0], self.stop)
        if self.sink is not None:
            first = max(first, int(np.searchsorted(trajectory.time, self.threshold)))
            # (not views of the trajectory's arrays: the next part reuses them while the
            # sink may still be formatting this one's rows in its background thread)
            self.sink.append(trajectory.time[first:], [_detached(waves[name][first:], trajectory)
                                                       for name in self.names],
                             trajectory.residual[first:].copy())
            self.written += trajectory.time.size - min(first, trajectory.time.size)
        else:
            self.times.append(trajectory.time[first:])
            self.residuals.append(trajectory.residual[first:].copy())  # (its array is reused)
            for name in self.names:
                self.kept[name].append(np.array(waves[name][first:]))
        begin = float(trajectory.time[0])
        events, new = self.events, trajectory.events
        after = bisect.bisect_right(new, begin, key=event_time)  # (in time order: 60,000 in a buck)
        for event in new[:after]:  # a boundary's events once
            if not events or event not in events[-8:]:
                events.append(event)
        events.extend(new[after:])
        for key, value in trajectory.stats.items():
            self.stats[key] = self.stats.get(key, 0) + value

    def result(self) -> Waveforms:
        """The waveforms kept so far (after a failure: up to it)."""
        times, kept, residuals = self.times, self.kept, self.residuals
        time = np.concatenate(times) if times else np.zeros(0)
        begin = int(np.searchsorted(time, self.start - 1e-12 * self.stop))
        signals = {name: np.concatenate(kept[name])[begin:] if kept[name] else np.zeros(0)
                   for name in self.names}
        residual = np.concatenate(residuals)[begin:] if residuals else np.zeros(0)
        extra = {} if self.sink is None else {"rows": self.written}
        return Waveforms(time=time[begin:], signals=signals, residual=residual,
                         title=self.circuit.title,
                         stats=dict(self.stats, unknowns=self.mlcs.n, pairs=self.mlcs.m, **extra),
                         events=self.events[bisect.bisect_left(self.events, self.shown_from,
                                                               key=event_time):])


def _detached(values: np.ndarray, trajectory: Trajectory) -> np.ndarray:
    """``values``, copied if it may share memory with the per-step arrays of ``trajectory``
    (a part's, which the next part overwrites); a signal computed from them (most) is
    an array of its own already."""
    shared = any(np.may_share_memory(values, array) for array in
                 (trajectory.y, trajectory.current, trajectory.impulse, trajectory.residual))
    return values.copy() if shared else values
