"""Glue for a transient analysis: circuit -> MLCS, grid, initial state, integration, waveforms."""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from circuitnsds.analyses import smooth_mosfets
from circuitnsds.analyses.advice import advise, diagnose, word_unknowns
from circuitnsds.analyses.fast_modes import FastModeWatch
from circuitnsds.analyses.memory import refuse_beyond_memory
from circuitnsds.analyses.mosfet_refits import (
    at_supply,
    is_mosfet_observer,
    mosfet_observer,
    mosfets,
    refit_mosfets,
)
from circuitnsds.analyses.operating_point import operating_point, uic_state
from circuitnsds.analyses.recorders import SEGMENT_BYTES, Observed, SignalRecorder, TrajectoryRecorder
from circuitnsds.analyses.refits import fit_observer, refit_diodes, refits_allowed
from circuitnsds.analyses.signals import trajectory_waveforms
from circuitnsds.checks.diode_loops import warn_free_diode_loops
from circuitnsds.checks.rules import check_initial_conditions
from circuitnsds.checks.source_notes import note_zero_pulse_widths
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import CurrentSource, Diode
from circuitnsds.circuit.elements.diode_notes import FitRangeObserver
from circuitnsds.circuit.observers import RunObserver, observers_of
from circuitnsds.engine.driver import drive
from circuitnsds.engine.stepper import DEFAULT_STEPPER, SMOOTH_STEPPER, Stepper, choose_stepper
from circuitnsds.engine.theta_stepper import STEPPINGS
from circuitnsds.engine.timegrid import check_step_count, time_grid
from circuitnsds.errors import CircuitError, CircuitWarning, RunNote, SimulationError
from circuitnsds.output.waveforms import Waveforms
from circuitnsds.specs import TransientSpec
from circuitnsds.system.stimuli import POINTS_PER_PERIOD, resolving_step
from circuitnsds.theta import theta_in_range, theta_text


def transient_spec(circuit: Circuit, **given: float | bool | None) -> TransientSpec:
    """The transient to run: the netlist's ``.tran`` line with the fields ``given`` (not
    ``None``) replacing its own, θ from ``.options theta`` (else 1) when neither says.

    Raises:
        CircuitError: no ``.tran`` line, and no step and stop given.
    """
    tran = circuit.analyses.get("tran")
    if tran is None:
        if given.get("step") is None or given.get("stop") is None:
            raise CircuitError("no .tran line and no step/stop given", where=circuit.file,
                               hint="add '.tran TSTEP TSTOP' to the netlist (e.g. .tran 1u 10m), or "
                               "give --step and --stop (step= and stop= in Python)")
        tran = TransientSpec(step=given["step"], stop=given["stop"])
    spec = tran.overridden(**given)
    if spec.theta is None:
        spec = replace(spec, theta=circuit.options.get("theta", 1.0))
    return spec


def run_transient(circuit: Circuit, spec: TransientSpec, *, signals: Sequence[str] | None = None,
                  sink=None, **settings) -> Waveforms:
    """Run the transient ``spec`` (see :meth:`Circuit.transient`; ``settings``: the other
    keyword arguments of :func:`_run_transient`). Diodes fitted to SPICE models are fitted
    where the circuit works: when a run's peak forward or breakdown current of a fitted model
    (measured by the diodes' observer) leaves the range its branches cover
    (:func:`~circuitnsds.circuit.elements.diode.refit_to`), the model is refitted to those
    peaks and the transient is run again, once (:func:`~circuitnsds.analyses.refits.refit_diodes`;
    not with a ``sink``, which has its rows already: a warning names the diodes then).
    ``.options pwlfit=I`` fixes every fit's range below ``I`` [A] instead. MOSFETs take their
    output capacitance over the circuit's supply, and are re-evaluated at the gate drive and
    the blocking voltage a first run shows, with the same one rerun
    (:mod:`~circuitnsds.analyses.mosfet_refits`). A MOSFET whose switch chatters, or which
    conducts mostly at a weak gate drive in the run returned, is made ngspice's smooth device
    and the run made again, with a note (:mod:`~circuitnsds.analyses.smooth_mosfets`; not
    with a ``sink``: the weak drive is noted then).

    ``sink`` (with ``signals``): an object with ``append(time, columns, residual)`` (and
    optionally ``expect(rows)``), e.g. :class:`~circuitnsds.output.csvfile.CsvStream`,
    that gets the rows of ``signals`` (in that order) segment by segment as the run goes;
    the waveforms returned then hold no rows (their ``stats`` count them: ``rows``)."""
    if sink is not None and signals is None:
        raise ValueError("a sink needs the signals it is to get")
    circuit = at_supply(circuit)
    if sink is not None or not (refits_allowed(circuit) or mosfets(circuit)):
        return _run_transient(circuit, spec, signals=signals, sink=sink, **settings)
    observers = observers_of(circuit)
    try:
        first = _run_transient(circuit, spec, signals=signals, observers=observers, **settings)
    except SimulationError as error:
        smooth = _smooth_chattering(circuit, error)
        if smooth is None:
            raise
        try:
            return run_transient(smooth, spec, signals=signals, **settings)
        except SimulationError as failure:
            smooth_mosfets.failed(circuit, failure, "the switches' error follows")
            raise error from None
    fits, watch = fit_observer(observers), mosfet_observer(observers)
    refitted = refit_diodes(circuit, fits.peaks) if fits is not None and refits_allowed(circuit) else circuit
    if watch is not None:
        refitted = refit_mosfets(refitted, watch.levels)
    if refitted is circuit:
        smooth = _smooth_weak(circuit, watch, spec, signals, settings)
        if smooth is not None:
            return smooth
        _report(observers)
        return first
    # said once: the first run's other notes; the peaks, drives and time scales of the run returned
    _report([observer for observer in observers
             if not (isinstance(observer, FitRangeObserver | FastModeWatch) or is_mosfet_observer(observer))])
    again = [observer for observer in observers_of(refitted)
             if isinstance(observer, FitRangeObserver) or is_mosfet_observer(observer)]
    waves = _run_transient(refitted, spec, signals=signals, observers=again, **settings)
    smooth = _smooth_weak(refitted, mosfet_observer(again), spec, signals, settings)
    if smooth is not None:
        return smooth
    _report(again)
    return waves


def _smooth_weak(circuit: Circuit, watch, spec: TransientSpec, signals, settings: dict) -> Waveforms | None:
    """The run made again with the MOSFETs that ``watch`` (the MOSFETs' observer of a run of
    ``circuit``) saw conducting mostly at a weak gate drive made the smooth device
    (:mod:`~circuitnsds.analyses.smooth_mosfets`), noted; ``None`` when there are none, their
    drive is fixed by ``.options mosdrive``, ``.options mosfet=switch`` keeps them, or the
    smooth run fails (noted: the switches' run is returned then)."""
    if watch is None or not smooth_mosfets.automatic(circuit):
        return None
    from circuitnsds.circuit.elements.mosfet_notes import current_limited_mosfets, weak_drive_mosfets

    free = [element for element in mosfets(circuit) if not element.drive_fixed]
    if len(free) < len(mosfets(circuit)):  # .options mosdrive: the user's switches
        return None
    weak = weak_drive_mosfets(free, watch.drives, smooth_mosfets.SMOOTH_SHARE)
    limited = [name for name in current_limited_mosfets(free, watch.limited, smooth_mosfets.SMOOTH_SHARE)
               if name not in weak]
    every = [element.name for element in mosfets(circuit)]
    smooth, made = smooth_mosfets.as_smooth(circuit, every) if weak or limited else (circuit, [])
    if not made:
        return None
    reasons = []
    if weak:
        reasons.append(f"{', '.join(weak)} spend{'s' if len(weak) == 1 else ''} over "
                       f"{smooth_mosfets.SMOOTH_SHARE:.0%} of the conducting time between threshold "
                       "and half the gate drive: a device in its active region")
    if limited:
        reasons.append(f"{', '.join(limited)} carr{'ies' if len(limited) == 1 else 'y'} over "
                       f"{smooth_mosfets.SMOOTH_SHARE:.0%} of the conducting time more than its "
                       "channel's saturation current at the gate drive applied: a current source, "
                       "not Ron")
    smooth_mosfets.note(circuit, made, f"({'; '.join(reasons)})")
    try:
        return run_transient(smooth, spec, signals=signals, **settings)
    except SimulationError as failure:
        smooth_mosfets.failed(circuit, failure, "the switches' run is returned, with its notes")
        return None


def _smooth_chattering(circuit: Circuit, error: SimulationError) -> Circuit | None:
    """``circuit`` with the MOSFET whose switch ``error`` says chatters made the smooth
    device (:mod:`~circuitnsds.analyses.smooth_mosfets`), noted; ``None`` when the error is
    another, the switch no MOSFET, or ``.options mosfet=switch`` keeps it."""
    if error.cause != SimulationError.SWITCH_CHATTERS or not smooth_mosfets.automatic(circuit):
        return None
    every = [element.name for element in mosfets(circuit)]
    chattering = [name for name in every if name in error.devices]
    smooth, made = smooth_mosfets.as_smooth(circuit, every) if chattering else (circuit, [])
    if not made:
        return None
    smooth_mosfets.note(circuit, made, f"({', '.join(chattering)} chatters as a switch at "
                        f"{error.where}: its state moves its own gate back across the threshold, "
                        "the device sits in its active region)")
    return smooth


def _drained(waves: Waveforms, sink) -> Waveforms:
    """``waves`` handed to ``sink`` whole (a run that was not segmented) and returned without
    rows; ``waves`` itself without a sink."""
    if sink is None:
        return waves
    names = list(waves.names)
    if hasattr(sink, "expect"):
        sink.expect(waves.time.size)
    sink.append(waves.time, [np.asarray(waves[name]) for name in names], waves.residual)
    return replace(waves, time=np.zeros(0), signals={name: np.zeros(0) for name in names},
                   impulses={}, flux_impulses={},
                   residual=None if waves.residual is None else np.zeros(0),
                   stats=dict(waves.stats, rows=waves.time.size))


def _run_transient(
    circuit: Circuit,
    spec: TransientSpec,
    *,
    method: str | None = None,
    tol: float = 1e-9,
    progress: Callable[[float, float], None] | None = None,
    stepping: str = "auto",
    signals: Sequence[str] | None = None,
    sink=None,
    observers: list[RunObserver] | None = None,
) -> Waveforms:
    """The transient ``spec`` of ``circuit``, integrated by the stepper ``method`` (else
    ``.options method``, else θ) and driven over the grid (:func:`~circuitnsds.engine.driver.drive`)
    into a recorder: the whole trajectory, or the ``signals`` kept (streamed to ``sink``) in
    parts. The devices' run-time observers
    (:func:`~circuitnsds.circuit.observers.observers_of`: a fitted diode's peak currents, a
    MOSFET at a weak gate drive) see every step and note after a run that finished;
    ``observers``: those to run instead, whose notes the caller makes (:func:`run_transient`
    reads the diodes' peaks before it says them); the run appends its time-scale watch
    (:class:`~circuitnsds.analyses.fast_modes.FastModeWatch`) to them, or to its own."""
    step, stop, start, uic = spec.step, spec.stop, spec.start, spec.uic
    theta = spec.theta if spec.theta is not None else circuit.options.get("theta", 1.0)
    explicit_step = not spec.refine_step
    for name, value in (("step", step), ("stop", stop), ("max_step", spec.max_step), ("tol", tol)):
        if value is not None and not (value > 0 and math.isfinite(value)):
            raise CircuitError(f"{name} = {value:g} must be positive and finite", where=circuit.file,
                               hint="tol is the scaled complementarity residual of a step (default "
                               "1e-9)" if name == "tol" else "step, stop and max_step are times in "
                               "seconds (--step, --stop on the command line); leave one out for the "
                               "netlist's .tran value")
    if not theta_in_range(theta):
        raise CircuitError(f"theta = {theta_text(theta)} is outside [0.5, 1]", where=circuit.file,
                           hint="theta = 1 is implicit Euler (default), 0.5 the trapezoidal rule")
    if stepping not in STEPPINGS:
        raise CircuitError(f"stepping = {stepping!r} is not one of {', '.join(map(repr, STEPPINGS))}",
                           where=circuit.file, hint="\"auto\" (default), \"compiled\", \"numpy\" (the "
                           "same loops in Python) or \"mlcp\" (one complementarity problem per step)")
    if not 0 <= start < stop:
        raise CircuitError(f"start = {start:g} s must lie in [0, stop)", where=circuit.file)

    mlcs = circuit.mlcs(spec.source_defaults)
    h = spec.grid_step
    report_step = None
    needed = _resolving_step(circuit, step, stop)
    if needed is not None and h > needed[0] * (1 + 1e-9):
        what = (f"{needed[1]} needs a step of at most {needed[0]:.4g} s ({POINTS_PER_PERIOD} points "
                f"per period)")
        if explicit_step:
            warnings.warn(CircuitWarning(
                f"{circuit.file}: the step {h:.4g} s cannot resolve the sources: {what}; the step "
                "given is obeyed (leave out --step to let circuitnsds refine it)"), stacklevel=2)
        else:
            ratio = h / needed[0]  # (inf for .tran 1e308: then the step needed itself)
            factor = math.ceil(ratio - 1e-9) if ratio < 2.0**52 else None
            report_step, h = h, h / factor if factor else needed[0]
    try:
        check_step_count(h, stop)  # before the breakpoints are listed (two 10 µs PULSEs: 2.6 GB)
        breakpoints = np.append(mlcs.breakpoints(stop), start)  # output begins exactly at TSTART
        grid = time_grid(h, stop, breakpoints)
    except ValueError as exc:
        if report_step is not None:  # the step the sources need, not TSTEP, is too small
            raise CircuitError(f"{exc}: {what}", where=circuit.file,
                               hint="check the frequencies of the sources (and their units)") from None
        raise CircuitError(str(exc), where=circuit.file,
                           hint="check the units of TSTEP/TMAX and TSTOP") from None
    if report_step is not None:  # noted once the grid exists (a failed refinement is an error)
        warnings.warn(RunNote(
            f"{circuit.file}: TSTEP {report_step:.4g} s cannot resolve the sources ({what}): "
            f"integrated with a step of {h:.4g} s{f' (TSTEP/{factor})' if factor else ''}, reported "
            "every TSTEP"),
            stacklevel=2)
    check_initial_conditions(circuit, circuit.resolved_elements(spec.source_defaults), uic)
    stepper = _stepper(circuit, mlcs, method, theta=theta, tol=tol, loop=stepping)
    _check_memory(circuit, stepper, grid, signals if report_step is None else None)
    _check_blocked_currents(circuit, grid)
    warn_free_diode_loops(circuit)
    note_zero_pulse_widths(circuit, stop)
    state = uic_state(circuit, mlcs) if uic else operating_point(circuit, mlcs, tol)
    owned = observers is None  # the run's own observers note; given ones are the caller's
    observers = observers_of(circuit) if owned else observers
    # every run's time scales are checked (issue 36 item 8; TSTART is a jump too); a caller's
    # list gets the watch, so that a refitted rerun's caller says it once, of the run returned
    observers.append(FastModeWatch(circuit, mlcs, theta, jumps=uic or breakpoints.size > 1))
    if signals is not None and report_step is None:  # (decimated runs keep every signal)
        kept = SignalRecorder(circuit, mlcs, grid, [name.strip().lower() for name in signals],
                              start, stop, sink)
        try:
            drive(stepper, grid, state, Observed(kept, mlcs, observers),
                  part_steps=kept.part_steps(), progress=progress)
        except (SimulationError, KeyboardInterrupt) as exc:
            if isinstance(exc, SimulationError):
                _explain(exc, circuit, mlcs, grid, theta)
            exc.partial = kept.result()
            raise
        if owned:
            _report(observers)
        result = kept.result()
        _note_method(circuit, stepper, result.stats)
        return result
    recorder = TrajectoryRecorder()
    try:
        drive(stepper, grid, state, Observed(recorder, mlcs, observers), progress=progress)
    except (SimulationError, KeyboardInterrupt) as exc:  # the waveforms so far, for the caller
        if isinstance(exc, SimulationError):
            _explain(exc, circuit, mlcs, grid, theta)
        if recorder.trajectory is not None:
            exc.partial = _partial(trajectory_waveforms(circuit, mlcs, recorder.trajectory, start,
                                                        stop), signals, sink)
        raise
    trajectory = recorder.trajectory
    fluxes = _cut_inductors(mlcs, trajectory)  # on every step, before any decimation
    flows = None
    if report_step is not None:
        full_time = trajectory.time
        every_step = trajectory_waveforms(circuit, mlcs, trajectory, full_time[0], stop)
        capacitors = [name for name in every_step.names if name not in mlcs.output_names]
        trajectory, kept = _decimated(trajectory, report_step, breakpoints)
        # a capacitor's current at a reported point is that of the step into it, as every
        # other signal is its value there (not ΔQ/Δt between reported points: KCL would fail)
        flows = {name: np.asarray(every_step[name])[kept] for name in capacitors}
        fluxes = {name: _onto(flux, full_time, trajectory.time) for name, flux in fluxes.items()}
    waves = trajectory_waveforms(circuit, mlcs, trajectory, start, stop, flows=flows)
    first = trajectory.time.size - waves.time.size
    waves.flux_impulses = {name: flux[first:] for name, flux in fluxes.items()}
    if owned:
        _report(observers)
    _note_method(circuit, stepper, waves.stats)
    return waves if signals is None else _drained(waves.select(signals), sink)


def _stepper(circuit: Circuit, mlcs, method: str | None, **settings) -> Stepper:
    """The stepper named ``method`` (else by ``.options method``, else the default) for ``mlcs``.

    Raises:
        CircuitError: an unknown name, or settings the stepper refuses.
    """
    name = method if method is not None else circuit.options.get("method")
    if name is None and mlcs.smooth:
        name = SMOOTH_STEPPER
        warnings.warn(RunNote(
            f"{circuit.file}: {', '.join(r.name for r in mlcs.smooth[:6])}"
            f"{' ...' if len(mlcs.smooth) > 6 else ''}: smooth nonlinear element(s); the run is "
            f"integrated by the Newton stepper (method={SMOOTH_STEPPER}: Newton–Josephy on each "
            "step, step length by truncation error)"), stacklevel=3)
    by_default = name is None
    name = DEFAULT_STEPPER if name is None else name
    hint = ".options method=NAME in the netlist, method= in Python"
    try:
        chosen, why = choose_stepper(name, mlcs)
    except ValueError as exc:
        raise CircuitError(str(exc), where=circuit.file, hint=hint) from None
    reason = chosen.unsuited(mlcs)
    if reason is not None:
        raise CircuitError(f"the integration method {chosen.name!r} cannot run this circuit: {reason}",
                           where=circuit.file, hint=hint)
    try:
        stepper = chosen(mlcs, **settings)
    except ValueError as exc:  # (settings the stepper refuses)
        raise CircuitError(str(exc), where=circuit.file, hint=hint) from None
    stepper.why = why
    stepper.by_default = by_default
    return stepper


def _note_method(circuit: Circuit, stepper: Stepper, stats: dict) -> None:
    """Say which stepper ran unless it is the θ-method named or by default: the exact
    integrator (whose rows are exact at every ``TSTEP``: the step sets the rows reported, not
    the accuracy; and its hand-offs to θ), or θ chosen by ``auto`` (and why).

    A choice :data:`~circuitnsds.engine.stepper.DEFAULT_STEPPER` made (``auto``) is no note
    (every run of the default would carry one): its words go to ``stats["method"]``, which
    the run summary prints; the exact integrator's hand-offs to θ are still noted."""
    why = getattr(stepper, "why", None)
    if why is not None and getattr(stepper, "by_default", False):
        stats["method"] = why.replace("method=auto", "method=auto (the default)", 1) + (
            "; .tran TSTEP sets the rows reported, not the accuracy" if stepper.name == "exact" else "")
        handoffs = getattr(stepper, "handoffs", [])
        if handoffs:
            first, cause = handoffs[0]
            warnings.warn(RunNote(
                f"{circuit.file}: {len(handoffs)} stretch(es) of the exact integration handed to "
                f"the θ-method, the first at t = {first:.6g} s ({cause})"), stacklevel=3)
        return
    if stepper.name != "exact":
        if why is not None:
            what = "the Newton stepper" if stepper.name == SMOOTH_STEPPER else "the θ-method"
            warnings.warn(RunNote(f"{circuit.file}: integrated by {what} ({why})"), stacklevel=3)
        return
    text = (f"{circuit.file}: integrated by the exact event-driven method"
            f"{f' ({why})' if why else ''}: the state is exact between located events, so .tran "
            "TSTEP sets the rows reported, not the accuracy")
    handoffs = getattr(stepper, "handoffs", [])
    if handoffs:
        first, cause = handoffs[0]
        text += (f"; {len(handoffs)} stretch(es) handed to the θ-method, the first at "
                 f"t = {first:.6g} s ({cause})")
    warnings.warn(RunNote(text), stacklevel=3)


def _explain(error: SimulationError, circuit: Circuit, mlcs, grid: np.ndarray, theta: float) -> None:
    """Word an engine error for the reader: its unknowns by their names, the hint of its cause,
    the diagnosis of a failed step (:mod:`circuitnsds.analyses.advice`)."""
    word_unknowns(error)
    advise(error)
    diagnose(error, circuit, mlcs, grid, theta)


def _report(observers: list) -> None:
    """Let each run-time observer note what the run showed (a run that finished)."""
    for observer in observers:
        observer.report()


def _partial(waves: Waveforms, signals: Sequence[str] | None, sink) -> Waveforms:
    """The partial result of a failed or interrupted run that was not segmented: handed to
    ``sink`` (and returned without rows) when there is one."""
    return waves if sink is None else _drained(waves.select(signals), sink)


def _onto(weights: np.ndarray, time: np.ndarray, reported: np.ndarray) -> np.ndarray:
    """Dirac weights per step of the grid ``time`` summed onto the reported points: a weight
    counts at the first reported point at or after its step's end."""
    out = np.zeros(reported.size)
    where = np.flatnonzero(weights)
    index = np.minimum(np.searchsorted(reported, time[where] - 1e-12 * max(reported[-1], 1e-300)),
                       reported.size - 1)
    np.add.at(out, index, weights[where])
    return out


DRIVE_MARGIN = 20.0
"""How many times the circuit's voltage (the median over a part's rows of each row's largest
node voltage) the mean inductor voltage of a step between two exact rows must exceed for a
fall of its current to zero to count as a cut (:func:`_cut_inductors`): twice a row's
largest voltage is the most an inductor's two nodes put across it, and ten times more leaves
room for peaks between the rows."""


def _cut_inductors(mlcs, trajectory) -> dict[str, np.ndarray]:
    """Inductor name -> flux [V·s] of its Dirac voltage per step (``L·Δi`` at each step that
    cuts its current, 0 elsewhere), with a warning for each such inductor.

    A cut: an opening switch or a blocking device with no other path takes the current
    (above 5 % of its maximum) below 0.1 % in one step; the ideal inductor then has a Dirac
    voltage, and the voltage shown at that step (L·ΔI/h, or I·Roff) depends on the step and
    on Roff, not on the circuit. A current that falls to zero smoothly (a diode's natural
    turn-off) does not count: the cut step must change the current more than ten times as
    much as the step before it.

    Between two rows of the exact integrator (``trajectory.exact_rows``), which are the closed
    form at their instants however far apart, a current that falls to zero between them may
    have fallen smoothly: a freewheeling diode took it and it rang down in a microsecond
    between rows 50 µs apart. Such a step counts as a cut only if no voltage of the run could
    have driven the fall: its mean inductor voltage ``L·|Δi|/Δt`` above :data:`DRIVE_MARGIN`
    times the circuit's voltage, the median over the part's rows of each row's largest node
    voltage (an inductor carries at most twice a row's largest; the margin leaves room for
    peaks between the rows; the median leaves out the cut's own spike, ``I·Roff`` at the
    row of the cut). A real cut at rows 1 µs apart needs 990 V of a 1 V circuit; at rows as
    far apart as a cut current's own decay, it is not told from a smooth fall
    (docs/diagnostics.md)."""
    inductances = mlcs.E.diagonal()
    differential = mlcs.differential_rows
    y = trajectory.y
    fluxes: dict[str, np.ndarray] = {}
    if y.shape[0] < 3:
        return fluxes
    exact = getattr(trajectory, "exact_rows", None)
    if exact is not None and exact.any():
        voltages = [row for row, name in enumerate(mlcs.unknowns) if name.startswith("v(")]
        # (the median over the rows of each row's largest: a cut's own spike, I·Roff at the row
        # of the cut, is one row)
        voltage_scale = float(np.median(np.abs(y[:, voltages]).max(axis=1, initial=0.0)))
    else:
        exact = None
    for row, name in enumerate(mlcs.unknowns):
        if not (name.startswith("i(") and differential[row]):
            continue
        current = y[:, row]
        scale = float(np.abs(current).max())
        if not scale > 0.0:
            continue
        change = np.abs(np.diff(current))
        before = np.concatenate([[np.inf], change[:-1]])
        cut = np.flatnonzero((np.abs(current[:-1]) > 0.05 * scale) & (np.abs(current[1:]) < 1e-3 * scale)
                             & (change > 10.0 * before))
        inductance = float(inductances[row])
        if cut.size and exact is not None:  # (a step between exact rows: a cut only if no voltage drove it)
            smooth = exact[cut] & exact[cut + 1]
            needed = inductance * np.abs(current[cut + 1] - current[cut]) / np.diff(trajectory.time)[cut]
            cut = cut[~smooth | (needed > DRIVE_MARGIN * voltage_scale)]
        columns, values = mlcs.E.row(row)
        if cut.size and (columns != row).any():
            # a coupled winding: its voltage is a Dirac only if its flux linkage Σ M·i jumps;
            # with K = 1 the flux moves to the other winding when this current is cut
            flux_linkage = y[:, columns] @ values
            jump = np.abs(flux_linkage[cut + 1] - flux_linkage[cut])
            cut = cut[jump > 0.1 * inductance * np.abs(current[cut + 1] - current[cut])]
        if not cut.size:
            continue
        weights = np.zeros(current.size)
        weights[cut + 1] = inductance * (current[cut + 1] - current[cut])
        fluxes[name[2:-1]] = weights
        k = int(cut[0])
        flux = inductance * abs(float(current[k]))
        more = f" (and {cut.size - 1} more times)" if cut.size > 1 else ""
        warnings.warn(
            f"the current of {name[2:-1]} ({current[k]:.3g} A) is cut in one step at "
            f"t = {trajectory.time[k + 1]:.6g} s{more}: an ideal inductor then has a Dirac voltage "
            f"of weight L·ΔI = {flux:.3g} V·s; the voltage shown at that step depends on the step "
            "(L·ΔI/h) or on Roff, not on the circuit; give the current a path (a freewheeling "
            "diode, a snubber) if that is not meant (Waveforms.flux_impulse)", CircuitWarning,
            stacklevel=4)
    return fluxes


def _check_memory(circuit: Circuit, stepper: Stepper, grid: np.ndarray,
                  signals: Sequence[str] | None = None) -> None:
    """Refuse, before starting, a run whose results cannot fit in memory (a 1,000-node ladder
    over 5e6 steps needs 37 GiB): the estimate of the arrays every grid point fills, against
    :data:`~circuitnsds.analyses.memory.MEMORY_SHARE` of the memory available. A run keeping
    only ``signals`` needs those, the time and the residual per point, and its parts
    (:class:`SignalRecorder`)."""
    from circuitnsds.units import format_si

    if signals is None:
        needed = stepper.trajectory_bytes(grid.size)
    else:
        needed = 8 * grid.size * (len(signals) + 2) + 2 * SEGMENT_BYTES
    mlcs = stepper.mlcs
    refuse_beyond_memory(
        needed, "the results", f"{grid.size:,} time points × {mlcs.n} unknowns and {mlcs.m} pairs",
        circuit, hint=f"a longer step (now {format_si(float(np.diff(grid).max()), 's')}), a shorter "
        ".tran, a smaller circuit, or fewer signals kept (--signals v(out))")


def _check_blocked_currents(circuit: Circuit, grid: np.ndarray) -> None:
    """Refuse (or, for diodes with an ``Roff`` of their own, warn about) current sources forced
    against blocking diodes (:func:`~circuitnsds.checks.wellposed.blocked_currents`)."""
    elements = circuit.elements  # it finds nothing without both (and costs an import of ~2 ms)
    if not (any(isinstance(e, CurrentSource) for e in elements)
            and any(isinstance(e, Diode) for e in elements)):
        return
    from circuitnsds.checks.wellposed import blocked_currents

    for message, where, fatal in blocked_currents(circuit, grid):
        if fatal:
            raise CircuitError(message, where=where or circuit.file,
                               hint="turn the diode round, give the current another path (a "
                               "resistor), or, if the leakage is meant, give the diode model an Roff")
        warnings.warn(message, CircuitWarning, stacklevel=3)


def _resolving_step(circuit: Circuit, tstep: float, stop: float) -> tuple[float, str] | None:
    """``(largest step that resolves every SIN/PULSE source [s], the source that needs it)``,
    ``None`` when no source constrains the step."""
    best = None
    for element in circuit.elements:
        function = getattr(element, "function", None)
        if function is None:
            continue
        needed = resolving_step(function.resolve(tstep, stop), stop)
        if needed is not None and (best is None or needed < best[0]):
            best = (needed, element.name)
    return best


def _decimated(trajectory, every: float, breakpoints: np.ndarray):
    """The trajectory at the multiples of ``every`` [s] (and at breakpoints, the last point):
    states as computed there, impulses summed over the dropped steps, residuals their maximum;
    and the indices of the kept points in ``trajectory``."""
    time = trajectory.time
    phase = time / every
    keep = np.abs(phase - np.round(phase)) <= 1e-6
    keep |= np.isin(time, breakpoints)
    keep[[0, -1]] = True
    index = np.flatnonzero(keep)
    impulse = np.add.reduceat(trajectory.impulse, np.r_[0, index[:-1] + 1], axis=0) \
        if trajectory.impulse.size else trajectory.impulse[index]
    residual = np.maximum.reduceat(trajectory.residual, np.r_[0, index[:-1] + 1]) \
        if trajectory.residual.size else trajectory.residual[index]
    return replace(trajectory, time=time[index], y=trajectory.y[index],
                   current=trajectory.current[index], impulse=impulse, residual=residual,
                   active=trajectory.active[index], switches=trajectory.switches[index],
                   tails={}, exact_rows=None if trajectory.exact_rows is None
                   else trajectory.exact_rows[index]), index
