"""Glue for a transient analysis: circuit -> MLCS, grid, initial state, integration, waveforms."""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from circuitnsds.analyses.operating_point import operating_point, uic_state
from circuitnsds.checks.diode_loops import warn_free_diode_loops
from circuitnsds.checks.rules import check_initial_conditions, ill_conditioning
from circuitnsds.checks.source_notes import note_zero_pulse_widths
from circuitnsds.checks.time_scales import fast_modes, visited_modes
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import Capacitor, CurrentSource, Diode
from circuitnsds.engine.integrate import STEPPINGS, Segments, integrate, trajectory_bytes
from circuitnsds.engine.timegrid import time_grid
from circuitnsds.errors import CircuitError, CircuitWarning, RunNote, SimulationError
from circuitnsds.lazy import is_loaded_instance
from circuitnsds.output.waveforms import LazySignals, Waveforms
from circuitnsds.specs import TransientSpec
from circuitnsds.system.stimuli import POINTS_PER_PERIOD, resolving_step
from circuitnsds.theta import theta_in_range, theta_text
from circuitnsds.units import format_si


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
    keyword arguments of :func:`_run_transient`). With ``.options pwlfit=auto`` a first run
    measures the peak forward (and breakdown) current of every fitted diode model, the models
    are refitted over ``[peak/10, peak]`` and the transient is run again (:func:`_refitted`).

    ``sink`` (with ``signals``): an object with ``append(time, columns, residual)`` (and
    optionally ``expect(rows)``), e.g. :class:`~circuitnsds.output.csvfile.CsvStream`,
    that gets the rows of ``signals`` (in that order) segment by segment as the run goes;
    the waveforms returned then hold no rows (their ``stats`` count them: ``rows``)."""
    if sink is not None and signals is None:
        raise ValueError("a sink needs the signals it is to get")
    if circuit.options.get("pwlfit") != "auto":
        return _run_transient(circuit, spec, signals=signals, sink=sink, **settings)
    first = _run_transient(circuit, spec, note_fits=False, **settings)  # every signal: the diodes' currents
    refitted = _refitted(circuit, first)
    if refitted is not circuit:
        return _run_transient(refitted, spec, signals=signals, sink=sink, **settings)
    return first if signals is None else _drained(first.select(signals), sink)


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


def _fitted_peaks(circuit: Circuit, waves: Waveforms,
                  peaks: dict[str, tuple[float, float]] | None = None) -> dict[str, tuple[float, float]]:
    """Model name -> the largest forward and reverse current [A] per unit area that ``waves``
    shows through the instances of each Shockley-fitted diode model (the models whose
    instances' currents ``waves`` does not hold are left out), taken together with ``peaks``
    (those of earlier segments of the same run), which is updated and returned."""
    from circuitnsds.circuit.elements import Diode

    peaks = {} if peaks is None else peaks
    for element in circuit.elements:
        if isinstance(element, Diode) and element.model.shockley is not None:
            try:
                current = np.asarray(waves[f"i({element.name})"]) / element.area
            except KeyError:  # a run that kept only some signals
                continue
            forward, reverse = peaks.get(element.model.name, (0.0, 0.0))
            peaks[element.model.name] = (max(forward, float(current.max(initial=0.0))),
                                         max(reverse, float(-current.min(initial=0.0))))
    return peaks


def _diode_peaks(circuit: Circuit, mlcs, trajectory,
                 peaks: dict[str, tuple[float, float]]) -> dict[str, tuple[float, float]]:
    """Model name -> the largest forward and reverse current [A] per unit area through the
    instances of each Shockley-fitted diode model over every row of ``trajectory`` (what
    :func:`_fitted_peaks` gives from the waveforms, the same numbers), taken together with
    ``peaks`` (of earlier segments of the same run), which is updated and returned. Each
    current is computed only at the rows where its largest value (or, for the reverse peak,
    its largest negated value) can be (:func:`_largest_rows`)."""
    from circuitnsds.circuit.elements import Diode

    rows = {name: j for j, name in enumerate(mlcs.output_names)}
    bounds: dict[int, float] = {}  # the largest |value| of y (0) and of the currents (1)
    for element in circuit.elements:
        if isinstance(element, Diode) and element.model.shockley is not None:
            row = rows.get(f"i({element.name})")
            if row is None:
                continue
            largest = []
            for sign in (1.0, -1.0):  # forward, reverse
                terms = [(source, column, sign * weight)
                         for source, column, weight in _signal_terms(mlcs, row)]
                where = _largest_rows(terms, trajectory, bounds)
                states, currents = trajectory.y, trajectory.current
                if where is not None:
                    states, currents = states[where], currents[where]
                current = _output_values(terms, states, currents) / element.area
                largest.append(float(current.max(initial=0.0)))
            forward, reverse = peaks.get(element.model.name, (0.0, 0.0))
            peaks[element.model.name] = (max(forward, largest[0]), max(reverse, largest[1]))
    return peaks


def _signal_terms(mlcs, row: int) -> list[tuple[int, int, float]]:
    """``(source, column, weight)`` of each term of output ``row`` (``mlcs.output_names``), in
    stamped order: ``source`` 0 for the unknowns ``y``, 1 for the pair currents."""
    return [(source, column, weight)
            for source, matrix in enumerate((mlcs.Y_out, mlcs.L_out))
            for column, weight in zip(*matrix.row(row))]


def _output_values(terms: list[tuple[int, int, float]], states: np.ndarray,
                   currents: np.ndarray) -> np.ndarray:
    """The output of ``terms`` (:func:`_signal_terms`) at each row of ``states`` (unknowns) and
    ``currents`` (pair currents): the sum of its weighted columns, in stamped order."""
    if len(terms) == 1:  # most signals: one scaled column, no zeros array to fault in
        source, column, weight = terms[0]
        values = weight * (states, currents)[source][:, column]
        values += 0.0  # (a zero is +0.0, as the sum below makes it)
        return values
    values = np.zeros(states.shape[0])
    for source, column, weight in terms:
        values += weight * (states, currents)[source][:, column]
    return values


def _largest_rows(terms: list[tuple[int, int, float]], trajectory,
                  bounds: dict[int, float]) -> np.ndarray | None:
    """Rows of ``trajectory`` among which :func:`_output_values` of ``terms`` takes its largest
    value (ties included), or ``None`` (every row) when they are not few.

    The term of largest magnitude (a diode's pair current; the others are its off-conductance
    times node voltages, ~1e-10 A) is computed; every other term is bounded by the largest
    ``|y|`` or ``|current|`` times its weight (``bounds`` keeps those, per trajectory), their
    sum ``B``. A row whose main term is more than ``2(B + δ)`` below the main term's largest
    value (``δ``: the rounding of the products and of the sum, a few ulps of ``B`` plus that
    largest value for each term) is below the row holding it whatever its other terms are:
    it cannot hold the maximum. The margin taken is 2.5(B + δ)."""
    def bound(source: int) -> float:
        if source not in bounds:
            array = (trajectory.y, trajectory.current)[source]
            bounds[source] = max(float(array.max(initial=0.0)), -float(array.min(initial=0.0)))
        return bounds[source]

    sizes = [abs(float(weight)) * bound(source) for source, _, weight in terms]
    main = int(np.argmax(sizes))
    source, column, weight = terms[main]
    others = sum(sizes) - sizes[main]
    values = weight * (trajectory.y, trajectory.current)[source][:, column]
    if values.size == 0 or not np.isfinite(others):
        return None
    high = float(values.max())
    rounding = 4 * len(terms) * np.finfo(float).eps * (abs(high) + sizes[main] + others)
    where = np.flatnonzero(values >= high - 2.5 * (others + rounding))
    return where if where.size <= values.size // 4 else None


FIT_DROP_TOLERANCE = 0.02
"""Forward-drop error [V] of a fitted line (against its Shockley curve) at a diode's peak
current beyond which the run notes that the fit range misses the circuit's currents."""


def _note_fits_outside_their_range(circuit: Circuit, peaks: dict[str, tuple[float, float]]) -> None:
    """A :class:`RunNote` for each Shockley-fitted diode model whose instances' peak forward or
    reverse (breakdown) current (``peaks``: :func:`_diode_peaks`) lies outside the range its
    forward or breakdown line was fitted over, where the line misses the curve by more than
    :data:`FIT_DROP_TOLERANCE` (the answer is then the line's, not the model's)."""
    from circuitnsds.circuit.elements import Diode

    models = {e.model.name: e.model for e in circuit.elements
              if isinstance(e, Diode) and e.model.fit_range is not None}
    for name, (forward, reverse) in peaks.items():
        model = models.get(name)
        if model is None:
            continue
        branches = [("", forward, model.fit_range, model.forward_drop, model.on_resistance,
                     model.shockley.forward_voltage)]
        if model.breakdown_fit_range is not None and model.breakdown_voltage is not None:
            branches.append((" breakdown", reverse, model.breakdown_fit_range,
                             model.breakdown_voltage, model.breakdown_resistance,
                             model.shockley.breakdown_drop))
        for branch, peak, (low, high), drop, slope, curve in branches:
            if peak <= 1e-12:
                continue
            error = abs(drop + slope * peak - float(curve(peak)))
            if (peak < low or peak > high) and error > FIT_DROP_TOLERANCE:
                what = f".model {name}'s breakdown line was" if branch else f".model {name} was"
                way = " in breakdown" if branch else ""
                miss = f"{error:.3g} V" if error >= 1 else f"{error * 1e3:.3g} mV"
                fix = (f"set .options pwlfit={peak:.3g} (pwlfit=auto refits once, to the peaks of "
                       "a first run, and they moved)" if circuit.options.get("pwlfit") == "auto"
                       else f"set .options pwlfit={peak:.3g} (or pwlfit=auto)")
                warnings.warn(RunNote(
                    f"{circuit.file}: {what} fitted over {low:.3g}..{high:.3g} A but its diodes "
                    f"carry up to {peak:.3g} A{way}, where the fitted line misses the model's "
                    f"curve by {miss}: {fix} to fit it where the circuit works"), stacklevel=4)


MOSFET = "circuitnsds.circuit.elements.mosfet"
"""The module of :class:`~circuitnsds.circuit.elements.mosfet.Mosfet`, not imported by runs
without MOSFETs (:func:`~circuitnsds.lazy.is_loaded_instance`)."""
WEAK_DRIVE_SHARE = 0.5
"""Share of a MOSFET's conducting time spent with a weak gate drive (an overdrive ``|Vgs| - Vto``
below half of the one its on-resistance was computed at) beyond which the run notes it."""


def _mosfet_drives(circuit: Circuit, mlcs, trajectory,
                   drives: dict[str, list[float]]) -> dict[str, list[float]]:
    """MOSFET name -> ``[conducting time, time of it with a weak gate drive, smallest |Vgs|]``
    ([s], [s], [V]) over the steps of ``trajectory``, added to ``drives`` (of earlier segments of
    the same run), which is updated and returned. A step counts with the state it ran in and the
    gate drive at its end; "weak": an overdrive below half of ``gate_drive - Vto``."""
    mosfets = {e.name: e for e in circuit.elements if is_loaded_instance(e, MOSFET, "Mosfet")}
    if not mosfets or trajectory.time.size < 2:
        return drives
    lengths = np.diff(trajectory.time)
    for j, switch in enumerate(mlcs.switches):
        element = mosfets.get(switch.name)
        if element is None:
            continue
        closed = np.asarray(trajectory.switches[1:, j], dtype=bool)
        if not closed.any():
            continue
        control = sum(value * trajectory.y[1:, column] for column, value in switch.control)
        threshold = element.model.threshold
        weak = closed & (control < threshold + 0.5 * (element.gate_drive - threshold))
        total = drives.setdefault(switch.name, [0.0, 0.0, math.inf])
        total[0] += float(lengths[closed].sum())
        total[1] += float(lengths[weak].sum())
        total[2] = min(total[2], float(np.min(control[closed])))
    return drives


def _note_weak_gate_drives(circuit: Circuit, drives: dict[str, list[float]]) -> None:
    """A :class:`RunNote` for each MOSFET that spends more than :data:`WEAK_DRIVE_SHARE` of its
    conducting time with a weak gate drive (``drives``: :func:`_mosfet_drives`): read as a switch
    whose Ron was computed at ``gate_drive``, it is then not what the circuit does."""
    for element in circuit.elements:
        if element.name not in drives or not is_loaded_instance(element, MOSFET, "Mosfet"):
            continue
        conducting, weak, lowest = drives[element.name]
        if conducting > 0 and weak > WEAK_DRIVE_SHARE * conducting:
            threshold = element.model.threshold
            warnings.warn(RunNote(
                f"{circuit.file}: {element.describe()} spends {100 * weak / conducting:.0f} % of "
                f"its conducting time at a weak gate drive (|Vgs| down to {lowest:.3g} V, "
                f"threshold {threshold:g} V), while its Ron is computed at |Vgs| = "
                f"{element.gate_drive:g} V: there its channel resistance is several times Ron and "
                "the MOSFET is not a switch; set .options mosdrive to the gate drive it works "
                "at, or drive its gate to that level"), stacklevel=4)


def _refitted(circuit: Circuit, waves: Waveforms) -> Circuit:
    """A copy of ``circuit`` whose fitted diode models are refitted to the peak currents
    ``waves`` shows through their instances (a model that never conducts keeps its fit)."""
    from dataclasses import replace as copy

    from circuitnsds.circuit.elements import Diode
    from circuitnsds.circuit.elements.diode import fitted_model

    peaks = _fitted_peaks(circuit, waves)
    if not peaks:
        return circuit
    models = {}
    for name, (forward, reverse) in peaks.items():
        model = next(e.model for e in circuit.elements if isinstance(e, Diode) and e.model.name == name)
        refit = fitted_model(model, model.shockley, forward if forward > 1e-9 else None,
                             reverse if reverse > 1e-9 else None)
        models[name] = copy(refit, origin=refit.origin + " (pwlfit=auto: the peak current of a "
                            "first run)")
        warnings.warn(RunNote(f"{circuit.file}: .model {name}: refitted to the peak currents of a "
                              f"first run: {models[name].origin}"), stacklevel=3)
    elements = [copy(e, model=models[e.model.name]) if isinstance(e, Diode) and e.model.name in models
                else e for e in circuit.elements]
    refitted = copy(circuit, elements=elements, models={**circuit.models, **models})
    return refitted


def _run_transient(
    circuit: Circuit,
    spec: TransientSpec,
    *,
    tol: float = 1e-9,
    progress: Callable[[float, float], None] | None = None,
    stepping: str = "auto",
    signals: Sequence[str] | None = None,
    sink=None,
    note_fits: bool = True,
) -> Waveforms:
    """The transient ``spec`` of ``circuit``; ``note_fits``: note fitted diode models whose
    currents leave their fit range (:func:`_note_fits_outside_their_range`), from every step's
    currents, also when only some signals are kept."""
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
            factor = math.ceil(h / needed[0] - 1e-9)
            report_step, h = h, h / factor
    breakpoints = np.append(mlcs.breakpoints(stop), start)  # output begins exactly at TSTART
    try:
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
            f"integrated with a step of {h:.4g} s (TSTEP/{factor}), reported every TSTEP"),
            stacklevel=2)
    check_initial_conditions(circuit, circuit._resolved(spec.source_defaults), uic)
    _check_memory(circuit, mlcs, grid, signals if report_step is None else None)
    _check_blocked_currents(circuit, grid)
    warn_free_diode_loops(circuit)
    note_zero_pulse_widths(circuit, stop)
    state = uic_state(circuit, mlcs) if uic else operating_point(circuit, mlcs, tol)
    if signals is not None and report_step is None:  # (decimated runs keep every signal)
        return _kept_signals(circuit, mlcs, grid, state, [name.strip().lower() for name in signals],
                             start, stop, sink=sink, note_fits=note_fits, theta=theta, tol=tol,
                             progress=progress, stepping=stepping)
    try:
        trajectory = integrate(mlcs, grid, state.y, state.charge, state.current, state.active,
                               state.switches, theta=theta, tol=tol, progress=progress,
                               stepping=stepping)
    except SimulationError as exc:
        _word(exc)
        advise(exc)
        _diagnose(exc, circuit, mlcs, grid, theta)
        if exc.trajectory is not None:
            exc.partial = _partial(_waveforms(circuit, mlcs, exc.trajectory, start, stop), signals, sink)
        raise
    except KeyboardInterrupt as exc:  # the waveforms so far, for the caller to write
        if getattr(exc, "trajectory", None) is not None:
            exc.partial = _partial(_waveforms(circuit, mlcs, exc.trajectory, start, stop), signals, sink)
        raise
    fluxes = _cut_inductors(mlcs, trajectory)  # on every step, before any decimation
    full_trajectory = trajectory
    flows = None
    if report_step is not None:
        full_time = trajectory.time
        every_step = _waveforms(circuit, mlcs, trajectory, full_time[0], stop)
        capacitors = [name for name in every_step.names if name not in mlcs.output_names]
        trajectory, kept = _decimated(trajectory, report_step, breakpoints)
        # a capacitor's current at a reported point is that of the step into it, as every
        # other signal is its value there (not ΔQ/Δt between reported points: KCL would fail)
        flows = {name: np.asarray(every_step[name])[kept] for name in capacitors}
        fluxes = {name: _onto(flux, full_time, trajectory.time) for name, flux in fluxes.items()}
    waves = _waveforms(circuit, mlcs, trajectory, start, stop, flows=flows)
    first = trajectory.time.size - waves.time.size
    waves.flux_impulses = {name: flux[first:] for name, flux in fluxes.items()}
    if note_fits:
        _note_fits_outside_their_range(circuit, _fitted_peaks(circuit, waves))
        _note_weak_gate_drives(circuit, _mosfet_drives(circuit, mlcs, full_trajectory, {}))
    if full_trajectory.time.size > 1:  # (the grid's longest step: TSTEP, or TSTOP if shorter)
        warn_fast_modes(circuit, mlcs, full_trajectory, float(np.diff(full_trajectory.time).max()),
                        theta, jumps=uic or breakpoints.size > 1)  # (breakpoints: + TSTART)
    return waves if signals is None else _drained(waves.select(signals), sink)


MAX_FAST_MODE_WARNINGS = 3


def warn_fast_modes(circuit: Circuit, mlcs, trajectory, h: float, theta: float,
                    jumps: bool = True) -> None:
    """Warn about each mode of the circuit's own dynamics (in the modes the run visited) that
    the step ``h`` [s] does not follow (:mod:`circuitnsds.checks.time_scales`), naming the
    elements that hold it and the step that would: only the sources were checked before."""
    modes = visited_modes(trajectory.switches, trajectory.active)
    # (``jumps``: the sources' corners or a UIC start; a change of mode is one too)
    for mode in fast_modes(mlcs, h, modes, jumps or len(modes) > 1)[:MAX_FAST_MODE_WARNINGS]:
        names = ", ".join(_holders(circuit, mode.unknowns)) or ", ".join(mode.unknowns)
        advice = (f"ngspice's own step control would follow it. Use a step of "
                  f"{format_si(mode.needed_step, 's')} or less (--step, or TSTEP of .tran)")
        if mode.rings:  # a wrong peak, frequency and decay: a warning (an error under --strict)
            warnings.warn(CircuitWarning(
                f"{circuit.file}: the mode of {names} rings at {format_si(mode.frequency, 'Hz')} "
                f"(period {format_si(1 / mode.frequency, 's')}, damping ratio {mode.damping:.2g}) "
                f"but the step is {format_si(h, 's')}, {1 / (mode.frequency * h):.2g} steps per "
                "period: " + ("implicit Euler damps that ringing away" if theta == 1.0 else
                              "the θ-method misses or aliases that ringing") + f"; {advice}"),
                stacklevel=3)
        else:  # a transient of a few steps shaped wrongly: a note
            warnings.warn(RunNote(
                f"{circuit.file}: the mode of {names} settles with a time constant of "
                f"{format_si(mode.time_constant, 's')} but the step is {format_si(h, 's')}: its "
                "transients (and the switching instants that depend on them) are followed only "
                f"roughly; {advice}"), stacklevel=3)


def _holders(circuit: Circuit, unknowns: tuple[str, ...]) -> list[str]:
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


def _cut_inductors(mlcs, trajectory) -> dict[str, np.ndarray]:
    """Inductor name -> flux [V·s] of its Dirac voltage per step (``L·Δi`` at each step that
    cuts its current, 0 elsewhere), with a warning for each such inductor.

    A cut: an opening switch or a blocking device with no other path takes the current
    (above 5 % of its maximum) below 0.1 % in one step; the ideal inductor then has a Dirac
    voltage, and the voltage shown at that step (L·ΔI/h, or I·Roff) depends on the step and
    on Roff, not on the circuit. A current that falls to zero smoothly (a diode's natural
    turn-off) does not count: the cut step must change the current more than ten times as
    much as the step before it."""
    inductances = mlcs.E.diagonal()
    differential = mlcs.differential_rows
    y = trajectory.y
    fluxes: dict[str, np.ndarray] = {}
    if y.shape[0] < 3:
        return fluxes
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


MEMORY_SHARE = 0.8
"""A run may plan to use at most this share of the memory available when it starts."""


def available_memory() -> int | None:
    """Memory the system can give this process now [bytes] (Linux's ``MemAvailable``, else the
    free physical pages), or ``None`` when unknown."""
    try:
        with open("/proc/meminfo") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _check_memory(circuit: Circuit, mlcs, grid: np.ndarray, signals: Sequence[str] | None = None) -> None:
    """Refuse, before starting, a run whose results cannot fit in memory (a 1,000-node ladder
    over 5e6 steps needs 37 GiB): the estimate of the arrays every grid point fills, against
    :data:`MEMORY_SHARE` of the memory available. A run keeping only ``signals`` needs
    those, the time and the residual per point, and its segments (:func:`_kept_signals`)."""
    from circuitnsds.units import format_si

    if signals is None:
        needed = trajectory_bytes(mlcs, grid.size)
    else:
        needed = 8 * grid.size * (len(signals) + 2) + 2 * SEGMENT_BYTES
    refuse_beyond_memory(
        needed, "the results", f"{grid.size:,} time points × {mlcs.n} unknowns and {mlcs.m} pairs",
        circuit, hint=f"a longer step (now {format_si(float(np.diff(grid).max()), 's')}), a shorter "
        ".tran, a smaller circuit, or fewer signals kept (--signals v(out))")


def refuse_beyond_memory(needed: int, what: str, sizes: str, circuit: Circuit, hint: str) -> None:
    """Raise :class:`CircuitError` when ``what`` would need more than :data:`MEMORY_SHARE`
    of the memory available: ``needed`` [bytes], estimated from ``sizes`` (words for the
    message). Nothing when the memory available is unknown."""
    available = available_memory()
    if available is None or needed <= MEMORY_SHARE * available:
        return
    raise CircuitError(f"{what} would take {needed / 2**30:.3g} GiB ({sizes}), more than the "
                       f"{available / 2**30:.3g} GiB of memory available", where=circuit.file, hint=hint)


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
"""The hint of an engine error by its ``cause`` (a failed step's comes from :func:`_diagnose`)."""


def advise(error: SimulationError) -> None:
    """Give an engine error the hint of its ``cause`` (:data:`ADVICE`) unless it has one: what
    every analysis that runs the engine does with its errors."""
    error.hint = error.hint or ADVICE.get(error.cause)


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
                   tails={}), index


HUGE = 1e100
"""A state beyond this magnitude [V or A] before a failed step means the circuit blew up."""


def _reader_name(unknown: str) -> str:
    """``v(a)`` -> ``node a``, ``i(v1)`` -> ``source v1``: an MNA unknown as the reader knows it."""
    return unknown.replace("v(", "node ").replace("i(", "source ").rstrip(")")


def _word(error: SimulationError) -> None:
    """Name the unknowns an engine error refers to (``error.unknowns``) as the reader knows them."""
    for unknown in error.unknowns:
        error.message = error.message.replace(unknown, _reader_name(unknown))


ANALYSE_LIMIT = 3000
"""Largest number of unknowns and pairs whose failed step is analysed (the well-posedness
analysis works on dense matrices)."""


def _diagnose(error: SimulationError, circuit: Circuit, mlcs, grid: np.ndarray, theta: float) -> None:
    """The hint of a failed step: the well-posedness analysis of that step's LCP."""
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


def _waveforms(circuit: Circuit, mlcs, trajectory, start: float, stop: float, *,
               periodic: bool = False, flows: dict[str, np.ndarray] | None = None) -> Waveforms:
    """Output signals of ``trajectory`` from ``start`` on (each computed when first read).

    ``periodic``: the trajectory is one period of a periodic solution (its first and last
    points are the same instant), so the step into the first point is the last one.
    ``flows``: the capacitor currents [A] at each point of ``trajectory`` when it is a
    decimated run (the step before a point is not in it); else ΔQ/Δt of its steps."""
    first = int(np.searchsorted(trajectory.time, start - 1e-12 * stop))
    y, current = trajectory.y[first:], trajectory.current[first:]
    rows = {name: j for j, name in enumerate(mlcs.output_names)}
    time = trajectory.time[first:]
    # capacitor currents ΔQ/Δt of each step (charge-consistent: their integral is the charge
    # the capacitor took), from n1 through the capacitor to n2; at the first point the step
    # before it (0 at the start of a run; the period's last step for a periodic one)
    before = max(first - 1, 0)
    capacitors = {f"i({e.name})": e for e in circuit.elements if isinstance(e, Capacitor)
                  and f"i({e.name})" not in rows}

    def voltage(node: str) -> np.ndarray:
        # (_row, not signal: closures calling each other would be a reference cycle that
        # keeps the trajectory alive until the garbage collector runs, a segment's worth of
        # memory each time in a run that keeps only some signals)
        return np.zeros(time.size) if node == "0" else _row(f"v({node})", y, current)

    def signal(name: str) -> np.ndarray:
        if name in capacitors and flows is not None:
            return flows[name][first:]
        if name in capacitors:
            element = capacitors[name]
            charge = element.capacitance * (voltage(element.nodes[0]) - voltage(element.nodes[1]))
            flow = np.zeros(time.size)
            flow[1:] = np.diff(charge) / np.diff(time)
            tails = trajectory.tails
            # a point ending a split step holds the state of its last part: the current of
            # that part there (KCL holds with the other currents, which are that part's too)
            for point, (y_start, length) in tails.items():
                if point >= first:
                    flow[point - first] = (charge[point - first] - charge_at(
                        element, y_start[None, :], trajectory.current[point:point + 1])) / length
            if periodic and time.size > 1:
                flow[0] = flow[-1]
            elif first > 0 and first not in tails:
                step = time[0] - trajectory.time[before]
                flow[0] = (charge[0] - charge_at(element, trajectory.y[before:first],
                                                 trajectory.current[before:first])) / step
            return flow
        return _row(name, y, current)

    def charge_at(element: Capacitor, states: np.ndarray, currents: np.ndarray) -> float:
        """The capacitor's charge [C] (n1 over n2) at one point: ``states``/``currents`` one row."""
        v = [0.0 if n == "0" else float(_row(f"v({n})", states, currents)[0]) for n in element.nodes[:2]]
        return element.capacitance * (v[0] - v[1])

    def _row(name: str, states: np.ndarray, currents: np.ndarray) -> np.ndarray:
        """Signal ``name``: the sum, in stamped order, of its rows' weighted unknowns."""
        return _output_values(_signal_terms(mlcs, rows[name]), states, currents)

    # each device's impulse (the signed sum of its pairs'), computed when first read: a run
    # that keeps some signals reads none (0.09 s per segment of the 1,000-pair ladder)
    pairs_of: dict[str, list[tuple[int, float]]] = {}
    for j, (device, sign) in enumerate(zip(mlcs.pair_devices, mlcs.pair_signs)):
        pairs_of.setdefault(device, []).append((j, sign))
    impulse = trajectory.impulse[first:]

    def impulse_of(device: str) -> np.ndarray:
        total = 0.0
        for j, sign in pairs_of[device]:
            total = total + sign * impulse[:, j]
        return total

    stats = dict(trajectory.stats, unknowns=mlcs.n, pairs=mlcs.m)
    return Waveforms(time=time, signals=LazySignals([*mlcs.output_names, *capacitors], signal),
                     impulses=LazySignals(pairs_of, impulse_of), residual=trajectory.residual[first:],
                     title=circuit.title,
                     stats=stats, events=[event for event in trajectory.events
                                          if event.time >= trajectory.time[first]])


SEGMENT_BYTES = 256 * 2**20
"""Memory the per-step arrays of one segment of a run that keeps only some signals may take
[bytes] (see :func:`_kept_signals`)."""


SINK_SEGMENT_STEPS = 2**16
"""Steps per segment at most when the rows go to a sink: the sink (a CSV file) formats one
segment in a background thread while the next is computed, and only the last one's
formatting is waited for (the 300,600-step flyback, θ = 0.5, in-process, medians of 12
interleaved runs: 167 ms against 225 ms at 2^18 steps; the 1M-step buck the same to the
noise, 344–358 ms; benchmarks/segments.py, docs/performance.md)."""


def segment_steps(mlcs) -> int:
    """Steps per segment of :func:`_kept_signals`: :data:`SEGMENT_BYTES` over the bytes
    the integrator stores per step (unknowns, pair currents, impulses, active flags,
    switch states, residual, time, the sources' values)."""
    width = mlcs.n + 4 * mlcs.m + len(mlcs.switches) + len(mlcs.stimuli) + 4
    return max(2, SEGMENT_BYTES // (8 * width))


def _detached(values: np.ndarray, trajectory) -> np.ndarray:
    """``values``, copied if it may share memory with the per-step arrays of ``trajectory``
    (a segment's, which the next segment overwrites); a signal computed from them (most) is
    an array of its own already."""
    shared = any(np.may_share_memory(values, array) for array in
                 (trajectory.y, trajectory.current, trajectory.impulse, trajectory.residual))
    return values.copy() if shared else values


def _kept_signals(circuit: Circuit, mlcs, grid: np.ndarray, state, names: list[str], start: float,
                  stop: float, sink=None, note_fits: bool = True, **options) -> Waveforms:
    """A transient that keeps only the signals ``names`` (and the time and each step's residual):
    memory bounded by what is kept, not by the circuit's size times the steps.

    The grid is integrated in segments of at most :data:`SEGMENT_BYTES` of per-step arrays;
    each segment starts from the state the previous one ended with (``continued``: no
    restart step), its chosen signals are kept and the rest is dropped. The segments share
    one stepping state (:class:`~circuitnsds.engine.integrate.Segments`: step solvers, mode
    maps and table built once, the loop choice counting the whole run), and a segment's
    first step is taken by the mode loop as in one run: the arithmetic is that of one run.
    Impulses are not kept.

    With a ``sink`` (see :func:`run_transient`) each segment's rows from ``start`` on go to
    it as soon as the segment is done and are not kept: memory is bounded by one segment.
    """
    unknown = [name for name in names if name not in mlcs.output_names]
    if unknown:
        raise CircuitError(f"unknown signal(s) {', '.join(unknown)}", where="signals",
                           hint=f"available: {', '.join(mlcs.output_names)}")
    rows = segment_steps(mlcs) if sink is None else min(segment_steps(mlcs), SINK_SEGMENT_STEPS)
    kept: dict[str, list[np.ndarray]] = {name: [] for name in names}
    times: list[np.ndarray] = []
    residuals: list[np.ndarray] = []
    events: list = []
    stats: dict[str, float] = {}
    peaks: dict[str, tuple[float, float]] = {}  # forward, reverse: fitted diodes, every segment
    drives: dict[str, list[float]] = {}  # MOSFETs' conducting and weak-drive time, every segment
    progress = options.pop("progress")
    total = grid[-1]
    report = None if progress is None else (lambda t, _end: progress(t, total))

    threshold = start - 1e-12 * stop  # rows before TSTART are not written
    shown_from = grid[int(np.searchsorted(grid, threshold))]  # the first row's time: events from it on
    if sink is not None and hasattr(sink, "expect"):
        sink.expect(grid.size - int(np.searchsorted(grid, threshold)))
    written = [0]

    def keep(trajectory, first: int) -> None:
        waves = _waveforms(circuit, mlcs, trajectory, grid[0], stop)
        _diode_peaks(circuit, mlcs, trajectory, peaks)
        _mosfet_drives(circuit, mlcs, trajectory, drives)
        if sink is not None:
            first = max(first, int(np.searchsorted(trajectory.time, threshold)))
            # (not views of the trajectory's arrays: the next segment reuses them while the
            # sink may still be formatting this one's rows in its background thread)
            sink.append(trajectory.time[first:], [_detached(waves[name][first:], trajectory)
                                                  for name in names],
                        trajectory.residual[first:].copy())
            written[0] += trajectory.time.size - min(first, trajectory.time.size)
        else:
            times.append(trajectory.time[first:])
            residuals.append(trajectory.residual[first:].copy())  # (its array is reused)
            for name in names:
                kept[name].append(np.array(waves[name][first:]))
        begin = float(trajectory.time[0])
        events.extend(event for event in trajectory.events  # a boundary's events once
                      if not events or event.time > begin or event not in events[-8:])
        for key, value in trajectory.stats.items():
            stats[key] = stats.get(key, 0) + value

    def result() -> Waveforms:
        time = np.concatenate(times) if times else np.zeros(0)
        begin = int(np.searchsorted(time, start - 1e-12 * stop))
        signals = {name: np.concatenate(kept[name])[begin:] if kept[name] else np.zeros(0)
                   for name in names}
        residual = np.concatenate(residuals)[begin:] if residuals else np.zeros(0)
        extra = {} if sink is None else {"rows": written[0]}
        return Waveforms(time=time[begin:], signals=signals, residual=residual, title=circuit.title,
                         stats=dict(stats, unknowns=mlcs.n, pairs=mlcs.m, **extra),
                         events=[event for event in events if event.time >= shown_from])

    y, charge, current, active, switches = state.y, state.charge, state.current, state.active, \
        state.switches
    first = 0
    segments = Segments(grid)
    while first < grid.size - 1:
        last = min(first + rows, grid.size - 1)
        try:
            trajectory = integrate(mlcs, grid[first:last + 1], y, charge, current, active, switches,
                                   progress=report, continued=first > 0, segments=segments,
                                   **options)
        except (SimulationError, KeyboardInterrupt) as exc:
            if isinstance(exc, SimulationError):
                _word(exc)
                _diagnose(exc, circuit, mlcs, grid, options["theta"])
            if getattr(exc, "trajectory", None) is not None and exc.trajectory.time.size:
                keep(exc.trajectory, 0 if first == 0 else 1)
            exc.partial = result()
            raise
        keep(trajectory, 0 if first == 0 else 1)
        # the last state, copied: views would keep the segment's arrays alive during the next
        y, current = trajectory.y[-1].copy(), trajectory.current[-1].copy()
        active, switches, charge = trajectory.active[-1].copy(), trajectory.switches[-1].copy(), None
        del trajectory  # freed before the next segment's arrays are allocated
        first = last
    if note_fits:
        _note_fits_outside_their_range(circuit, peaks)
        _note_weak_gate_drives(circuit, drives)
    return result()
