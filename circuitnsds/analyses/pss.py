"""Periodic steady state by shooting with the exact monodromy matrix (docs/pss.md).

On a grid over one period ``T`` (the same in every period, with the sources'
breakpoints), each implicit Euler step in a fixed mode is affine on the state
``x`` (capacitor node voltages, inductor currents), so one period from ``x_0`` is
``P(x_0) = Φ x_0 + c`` for the mode sequence it visits, with ``Φ = M_{N-1} ⋯ M_0``
(:mod:`circuitnsds.engine.step_maps`). Newton on ``P(x) − x = 0`` solves
``(I − Φ) x_0 = c`` and runs the period again from the new ``x_0`` with full
complementarity; when the run visits the same mode sequence, ``x_0`` is the periodic
solution of the discrete system (to rounding) and the residual says so. A changed
sequence (a diode that now turns off earlier, DCM) gives a new ``Φ`` and one more
step. When Newton does not settle within ``max_iterations``, or returns to a mode sequence
it visited without halving the residual (it cycles between pieces of the piecewise affine
map), some periods of plain transient are run from the best state seen and Newton starts
again (:data:`FALLBACK_ROUNDS` times, the transient doubling each time).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from circuitnsds.analyses.advice import advise
from circuitnsds.analyses.memory import refuse_beyond_memory
from circuitnsds.analyses.mosfet_refits import at_supply, refit_mosfets_to
from circuitnsds.analyses.operating_point import operating_point, uic_state
from circuitnsds.analyses.recorders import TrajectoryRecorder
from circuitnsds.analyses.refits import fitted_diodes, refit_diodes, refits_allowed, report_fits
from circuitnsds.analyses.signals import trajectory_waveforms
from circuitnsds.checks.rules import check_initial_conditions
from circuitnsds.checks.time_scales import exact_monodromy
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements.diode_notes import waveform_diode_peaks
from circuitnsds.engine.driver import drive
from circuitnsds.engine.integrate import Trajectory, trajectory_bytes
from circuitnsds.engine.newton_stepper import NewtonStepper
from circuitnsds.engine.step_maps import StepMapper, StepMaps
from circuitnsds.engine.stepper import AUTO, DEFAULT_STEPPER, StartState, stepper_class
from circuitnsds.engine.theta_stepper import ThetaStepper
from circuitnsds.engine.timegrid import time_grid
from circuitnsds.errors import CircuitError, CircuitWarning, RunNote, SimulationError
from circuitnsds.output.waveforms import Waveforms
from circuitnsds.specs import PssSpec, SourceDefaults
from circuitnsds.system.mlcs import MLCS
from circuitnsds.system.stimuli import Am, Dc, Pulse, Pwl, Sawtooth, Sffm, Sin

if TYPE_CHECKING:
    from circuitnsds.engine.exact.small_signal import ExactPeriod
from circuitnsds.units import format_si

DEFAULT_POINTS = 1000
"""Steps per period when neither ``step``, ``.pss PSSPOINTS`` nor ``.tran`` TSTEP says."""
DEFAULT_TOL = 1e-9
"""Relative periodicity tolerance (see :func:`run_pss`)."""
DEFAULT_ITERATIONS = 10
"""Newton iterations per round before the transient fallback."""
FALLBACK_ROUNDS = 3
"""Rounds of (transient periods, Newton) after the first Newton round fails."""
FALLBACK_PERIODS = 10
"""Transient periods of the first fallback (doubled at each round)."""
SINGULAR = 1e-10
"""A Floquet multiplier closer than this to 1 makes ``I − Φ`` singular."""
ILL_CONDITIONED = 1e12
"""Condition number of ``I − Φ`` above which the Newton step is refused."""
RESONANCE_GAP = 0.05
"""A mode whose exact multiplier over the period lies this close to 1 amplifies what the
sources put into it 20 times or more (resonance): there the step's numerical damping, not the
circuit, may set the response. Further from 1 the step's errors in what goes in and in what
stays cancel (an undamped LC driven at 1 kHz, its own 5 kHz damped 2x too much per period by
the steps: the same 1.0411 V at 1 µs and 0.1 µs as the closed form)."""
STEP_DAMPING_RATIO = 2.0
"""A period's implicit-Euler multiplier this many times further from 1 than the exact one is
warned about (the response along that mode is then set by the step)."""
NO_PERIODIC_RATIO = 10.0
"""... and this many times further is an error (the answer is off by more than that)."""
PERIOD_MATCH = 1e-9
"""Relative tolerance when testing that source periods divide the common period."""
RESONANCE_HINT = ("the sources drive an undamped or nearly undamped mode at its resonance (a "
                  "harmonic of the period): add the damping the real circuit has (an inductor's or "
                  "capacitor's series resistance), or run a transient to see the growth")
UNDAMPED_HINT = ("look for a capacitor in a cut-set with only sources, capacitors or blocked "
                 "diodes (its charge never changes), an inductor in a loop of sources only, or an "
                 "undamped LC; add a resistance (a bleeder across the capacitor, a series "
                 "resistance in the inductor)")
"""What to look for when a state is not damped over a period."""
MOST_PERIODS = 10_000
"""Largest ratio common period / longest source period searched for."""


@dataclass
class PSSResult:
    """One settled period of a circuit with periodic sources.

    Attributes:
        waveforms: the period ``[t0, t0 + period]`` with the transient's signal names.
        period: ``T`` [s].
        t0: the period's first instant [s] (where every source has become periodic).
        state_names: the state unknowns (``v(node)``, ``i(l1)``, ...).
        state: their values at ``t0`` (= at ``t0 + T``) [V or A].
        iterations: Newton steps taken (solves of ``(I − Φ) x = c``).
        residual: ``‖P(x_0) − x_0‖∞`` of the settled period [V or A].
        relative_residual: the same, each component divided by its scale (see
            :func:`run_pss`); at most ``tol`` when returned.
        monodromy: ``Φ`` (state × state), the exact Jacobian of the period map.
        multipliers: eigenvalues of ``Φ`` (Floquet multipliers), largest modulus first:
            all ``|λ| < 1`` for a stable periodic solution; ``-ln|λ| / T`` is a decay rate [1/s].
        transient_periods: periods of plain transient run (warm-up and fallbacks).
        history: ``‖P(x) − x‖∞`` relative, at each run of the period.
        maps: the settled period's :class:`~circuitnsds.engine.step_maps.StepMaps`
            (trajectory, mode sequence, step maps): the start of a small-signal analysis.
        mlcs: the system those maps belong to.
    """

    waveforms: Waveforms
    period: float
    t0: float
    state_names: list[str]
    state: np.ndarray
    iterations: int
    residual: float
    relative_residual: float
    monodromy: np.ndarray
    multipliers: np.ndarray
    transient_periods: int = 0
    history: list[float] = field(default_factory=list)
    maps: StepMaps | None = field(default=None, repr=False)
    mlcs: MLCS | None = field(default=None, repr=False)
    means: dict[str, float] | None = None
    """On the exact map (``.options method=exact``): each unknown's mean over the period, the
    closed-form integral (``maps`` is then ``None``)."""
    periods_run: int = 0
    """Periods of the stepper run by the shooting itself (warm-up and fallbacks not counted)
    when it is the finite-difference one (smooth nonlinear elements), else 0."""
    shooting: str = ""
    """How the period map and its Jacobian were found when not by the affine step maps."""
    exact: ExactPeriod | None = field(default=None, repr=False)
    """On the exact map: the orbit's period as segments (what ``ac`` around it needs)."""

    @property
    def decay_rate(self) -> float:
        """Slowest decay of a disturbance [1/s]: ``-ln(max |λ|) / T`` (``inf`` when Φ = 0)."""
        largest = float(np.abs(self.multipliers).max(initial=0.0))
        return math.inf if largest == 0.0 else -math.log(largest) / self.period

    def summary(self) -> str:
        if not self.state_names:
            return (f"periodic steady state: T = {self.period:.6g} s from t0 = {self.t0:.6g} s; the "
                    "circuit has no state (no capacitor or inductor), so every period is the same")
        largest = float(np.abs(self.multipliers).max(initial=0.0))
        exact = "" if self.means is None else " on the exact period map"
        if self.shooting:
            exact = f" by {self.shooting} ({self.periods_run} periods run)"
        return (f"periodic steady state{exact}: T = {self.period:.6g} s from t0 = {self.t0:.6g} s, "
                f"{self.iterations} Newton step(s), residual {self.relative_residual:.1e} "
                f"(relative), largest Floquet multiplier |λ| = {largest:.6g}")


def source_period(circuit: Circuit) -> tuple[float, float]:
    """The least common period of the circuit's periodic sources and the instant from which
    every source is periodic (the largest delay) [s].

    Raises:
        CircuitError: a time-varying source is not periodic (PWL, EXP, a damped SIN, a PULSE
            without period), no source is periodic, or their periods have no common multiple.
    """
    periods, start = _source_periods(circuit)
    if not periods:
        raise CircuitError("the circuit has no periodic source, so it has no period", where=circuit.file,
                           hint="give the period (pss(period=...), --period, or .pss GFREQ); a circuit "
                           "that oscillates by itself is not supported")
    longest, owner = max(periods)
    for multiple in range(1, MOST_PERIODS + 1):
        candidate = multiple * longest
        if all(_divides(p, candidate) for p, _ in periods):
            return candidate, start
    listed = ", ".join(f"{name}: {p:.6g} s" for p, name in periods)
    raise CircuitError(f"the sources' periods have no common multiple up to {MOST_PERIODS} × "
                       f"{longest:.6g} s ({listed})", where=owner,
                       hint="give the period yourself (pss(period=...), --period), or make the periods "
                       "commensurate")


def _divides(period: float, candidate: float) -> bool:
    """Whether ``candidate`` [s] is a whole multiple of ``period`` [s] (within PERIOD_MATCH)."""
    return abs(candidate / period - round(candidate / period)) <= PERIOD_MATCH * candidate / period


def check_given_period(circuit: Circuit, period: float) -> None:
    """Refuse a period given to pss (``.pss GFREQ``, ``--period``) that some source does not
    repeat with: the shooting would close an orbit of a forcing that is not periodic there.

    Raises:
        CircuitError: a time-varying source is not periodic, or ``period`` [s] is not a whole
            multiple of a source's period (naming it).
    """
    periods, _ = _source_periods(circuit)
    for source_period_, name in periods:
        if not _divides(source_period_, period):
            raise CircuitError(f"source {name} repeats every {source_period_:.6g} s, and the period "
                               f"given to pss, {period:.6g} s, is not a whole multiple of it: the "
                               "circuit has no steady state of that period",
                               where=name, hint="give a period that every source repeats with "
                               "(.pss GFREQ, --period), or leave it out to have it found")


def _source_periods(circuit: Circuit) -> tuple[list[tuple[float, str]], float]:
    """Each time-varying source's period [s] with its name, and the largest delay [s].

    Raises:
        CircuitError: a time-varying source is not periodic.
    """
    periods: list[tuple[float, str]] = []
    start = 0.0
    for element in circuit.elements:
        function = getattr(element, "function", None)
        if function is None or isinstance(function, Dc):
            continue
        name = element.name.upper()
        if isinstance(function, Pulse) and function.period:
            periods.append((function.period, name))
            start = max(start, function.delay)
        elif isinstance(function, Sin) and function.frequency and not function.damping:
            periods.append((1.0 / abs(function.frequency), name))  # sin(-ωt) as ngspice
            start = max(start, function.delay)
        elif isinstance(function, Pwl) and len(set(function.values)) == 1:
            continue  # a constant written as PWL
        else:
            why = {Pulse: "a PULSE without PER is a single pulse",
                   Sin: "a SIN needs FREQ and no damping THETA to be periodic",
                   Pwl: "a PWL holds its last value (repeating PWL is not supported)",
                   Am: "AM sources are not supported by pss (an AM is its carrier and two "
                       "side bands: SIN sources in series)",
                   Sffm: "SFFM sources are not supported by pss",
                   Sawtooth: "it is the phase of an XSPICE d_pwm, which pss does not support yet"}.get(
                       type(function), "it makes one transition")
            raise CircuitError(f"source {name} ({function}) is not periodic: {why}", where=name,
                               hint="a periodic steady state needs periodic sources (PULSE with PER, "
                               "SIN with FREQ) and constants")
    return periods, start


def run_pss(circuit: Circuit, spec: PssSpec | None, **settings) -> PSSResult:
    """The periodic steady state of ``circuit`` described by ``spec`` (a ``.pss`` line, or
    ``None``), the keyword arguments ``settings`` of :func:`_run_pss` winning over it; see
    :meth:`Circuit.pss`. Diodes fitted to SPICE models are fitted where the periodic steady
    state works, as in a transient (:func:`~circuitnsds.analyses.transient.run_transient`):
    a settled period whose peak currents leave a fit's range is found again, once, with the
    models refitted to them; what still leaves it is a warning naming the diode. MOSFETs take
    their output capacitance over the circuit's supply, then their on-resistance and output
    capacitance at the gate drive and blocking voltage of the settled period, found again once
    when those move them (:mod:`~circuitnsds.analyses.mosfet_refits`), as a transient does."""
    circuit = at_supply(circuit)
    result = _run_pss(circuit, spec, **settings)
    refitted = circuit
    if fitted_diodes(circuit) and refits_allowed(circuit):
        refitted = refit_diodes(circuit, waveform_diode_peaks(fitted_diodes(circuit), result.waveforms))
    refitted = refit_mosfets_to(refitted, result.waveforms)
    if refitted is not circuit:
        circuit = refitted
        result = _run_pss(circuit, spec, **settings)
    if fitted_diodes(circuit):
        report_fits(circuit, waveform_diode_peaks(fitted_diodes(circuit), result.waveforms))
    return result


def _run_pss(circuit: Circuit, spec: PssSpec | None, *, period: float | None = None,
             step: float | None = None, periods_warmup: int = 0, tol: float | None = None,
             max_iterations: int | None = None, theta: float | None = None,
             uic: bool | None = None) -> PSSResult:
    """The periodic steady state of ``circuit`` described by ``spec``, its fits as they are. The
    sources' time defaults (``PULSE`` TR = TSTEP, ...) are the netlist's ``.tran`` line's
    when it has one (the transient's waveforms), else this analysis' step and time span.

    Convergence: for each state unknown ``i`` with scale ``s_i`` (its largest magnitude over
    the period, at least ``1e-9`` of the largest scale of its unit), ``|P(x_0)_i − x_{0,i}|
    <= tol · s_i``.
    """
    why = ("with theta < 1 a step depends on the algebraic unknowns too, so the period map is not "
           "a map of the state alone")
    if theta is not None and theta != 1.0:
        raise CircuitError(f"the periodic steady state uses implicit Euler (theta = 1), not theta = "
                           f"{theta:g}", where=circuit.file,
                           hint=f"{why}; compare it with a transient at theta = 1")
    if circuit.options.get("theta", 1.0) != 1.0:
        warnings.warn(CircuitWarning(
            f"{circuit.file}: .options theta={circuit.options['theta']:g} applies to the transient; "
            f"the periodic steady state uses implicit Euler (theta = 1): {why}"), stacklevel=3)
    found_period, t0 = None, None
    if period is None and spec is None:
        try:
            found_period, t0 = source_period(circuit)
        except CircuitError as exc:
            free = _circuit_controlled_switches(circuit)
            if free and "no periodic source" in exc.message:
                raise CircuitError(
                    f"the circuit has no periodic source; switch(es) {', '.join(free)} are controlled "
                    "by the circuit: if they switch by themselves (a hysteretic controller, a relaxation "
                    "oscillator), the period is the circuit's own, and autonomous switching is not "
                    "supported", where=free[0],
                    hint="drive the switching from a source (a PULSE or a ramp into a comparator "
                    "whose control is that source), or run a transient") from None
            raise
    if period is None:
        period = 1.0 / spec.frequency if spec is not None else found_period
    if found_period is None and 0 < period < math.inf:
        check_given_period(circuit, period)
    if t0 is None:
        t0 = _periodic_from(circuit)
    if not period > 0:
        raise CircuitError(f"the period must be positive, got {period:g} s", where=circuit.file)
    tran = circuit.analyses.get("tran")
    if step is None:
        if spec is not None and spec.points:
            step = period / spec.points
        elif tran is not None:
            step = min(tran.step, tran.max_step) if tran.max_step else tran.step
        else:
            step = period / DEFAULT_POINTS
    if not 0 < step <= period:
        raise CircuitError(f"the step ({step:g} s) must lie in (0, period = {period:g} s]",
                           where=circuit.file)
    tol = tol if tol is not None else (spec.tol if spec is not None and spec.tol else DEFAULT_TOL)
    if max_iterations is None and spec is not None and spec.iterations:
        max_iterations = spec.iterations
    asked_iterations = max_iterations  # (None: each map's own; the exact map's are 30 in all)
    if max_iterations is None:  # 0 is a choice: no Newton step, transient periods only
        max_iterations = DEFAULT_ITERATIONS
    for name, option, value, least in (("tol", "--tol", tol, None),
                                       ("max_iterations", "--max-iterations", max_iterations, 0),
                                       ("periods_warmup", "--warmup", periods_warmup, 0)):
        if not (value > 0 and math.isfinite(value) if least is None else value >= least):
            raise CircuitError(f"{name} = {value:g} must be "
                               f"{'positive' if least is None else f'{least} or more'}",
                               where=circuit.file, hint=f"{option} on the command line; see "
                               "docs/pss.md for its meaning")
    if spec is not None and spec.stabilisation and periods_warmup == 0:
        periods_warmup = math.ceil(spec.stabilisation / period - 1e-9)
    uic = uic if uic is not None else ((spec.uic if spec is not None else False)
                                       or (tran.uic if tran is not None else False))
    # the sources' analysis-dependent defaults (PULSE TR = TSTEP, ...): the transient's when the
    # netlist has one (the same waveforms), else this analysis' step and time span
    defaults = (tran.source_defaults if tran is not None
                else SourceDefaults(step, t0 + (periods_warmup + 1) * period))
    mlcs = circuit.mlcs(defaults)
    start_time = t0 + periods_warmup * period
    try:  # both grids before any work: a period or warm-up of too many steps is an error
        grid = _period_grid(mlcs, step, t0, period)
        whole = _whole_grid(mlcs, step, start_time) if start_time > 0 else None
    except ValueError as exc:
        raise CircuitError(str(exc), where=circuit.file,
                           hint="check the period, the step and the warm-up periods (--period, "
                           "--step, --warmup)") from None
    _check_memory(circuit, mlcs, grid, whole)

    check_initial_conditions(circuit, circuit.resolved_elements(defaults), uic)
    initial = uic_state(circuit, mlcs) if uic else operating_point(circuit, mlcs)
    y, charge, active, switches = initial.y, initial.charge, initial.active, initial.switches
    try:
        if start_time > 0:  # into the periodic regime (and the warm-up periods)
            run = _plain_transient(mlcs, whole, StartState(y, charge, None, active, switches))
            # copies: the warm-up's trajectory is freed before the period maps are built
            y, active, switches = run.y[-1].copy(), run.active[-1].copy(), run.switches[-1].copy()
            charge = None
            del run
        if mlcs.smooth:  # no affine step maps: finite-difference shooting on the Newton stepper
            from circuitnsds.analyses.pss_smooth import SmoothShooter

            if charge is not None:  # (initial conditions y cannot express: one period from them)
                run = _plain_transient(mlcs, grid, StartState(y, charge, None, active, switches))
                y, active, switches = run.y[-1].copy(), run.active[-1].copy(), run.switches[-1].copy()
            result = SmoothShooter(circuit, mlcs, grid, period, tol).solve(y, active, switches,
                                                                             max_iterations)
        elif (period_map := _period_map(circuit, mlcs)) != "theta":
            from circuitnsds.analyses.pss_exact import NoSteadyState, exact_pss

            start_y = y
            if charge is not None:  # (initial conditions y cannot express: one step of θ first)
                start_y = _plain_transient(mlcs, grid[:2], StartState(y, charge, None, active, switches)).y[0]
            try:
                result = exact_pss(circuit, mlcs, grid, period, start_y, active, switches, tol,
                                   asked_iterations)
            except SimulationError as exc:
                if period_map == "exact" or isinstance(exc, NoSteadyState):
                    raise
                warnings.warn(RunNote(
                    f"{circuit.file}: method=auto: the periodic steady state on the exact period map "
                    f"failed ({exc.message}); it is the θ shooting's instead"), stacklevel=2)
                result = _Shooter(circuit, mlcs, grid, period, tol).solve(y, charge, active, switches,
                                                                          max_iterations)
        else:
            shooter = _Shooter(circuit, mlcs, grid, period, tol)
            result = shooter.solve(y, charge, active, switches, max_iterations)
    except SimulationError as exc:
        advise(exc)
        raise
    result.transient_periods += periods_warmup
    return result


def _period_map(circuit: Circuit, mlcs: MLCS) -> str:
    """The period map the shooting takes, by ``.options method`` (or, without it, the
    default, :data:`~circuitnsds.engine.stepper.DEFAULT_STEPPER`): ``"exact"`` for
    ``method=exact`` (the exact integrator's map; an error if it cannot run the circuit),
    ``"auto"`` for ``method=auto`` where the exact integrator can run the circuit (its map,
    the θ shooting with its transient fallbacks where Newton on it fails), ``"theta"``
    otherwise (the θ-method's step maps).

    Raises:
        CircuitError: ``method=exact`` on a circuit the exact integrator cannot run.
    """
    name = str(circuit.options.get("method", DEFAULT_STEPPER)).strip().lower()
    reason = stepper_class("exact").unsuited(mlcs) if name in ("exact", AUTO) else "not asked"
    if name == "exact" and reason is not None:
        raise CircuitError(f"the integration method 'exact' cannot run this circuit: {reason}",
                           where=circuit.file, hint=".options method=theta")
    return name if reason is None else "theta"


def _plain_transient(mlcs: MLCS, grid: np.ndarray, start: StartState) -> Trajectory:
    """A plain transient over ``grid`` from ``start``: the θ stepper at θ = 1 (implicit Euler,
    whose period maps the shooting uses), or the Newton stepper at θ = 1 through smooth
    nonlinear elements, driven in one part, every point kept."""
    recorder = TrajectoryRecorder()
    drive(NewtonStepper(mlcs, lte=False) if mlcs.smooth else ThetaStepper(mlcs), grid, start, recorder)
    return recorder.trajectory


def _circuit_controlled_switches(circuit: Circuit) -> list[str]:
    """Names of the switches whose control is not a source's time function."""
    try:
        mlcs = circuit.mlcs()
    except CircuitError:
        return []
    return [switch.name.upper() for switch in mlcs.switches if switch.control_stimulus is None]


def _periodic_from(circuit: Circuit) -> float:
    """The largest delay of a PULSE or SIN source [s] (0 without)."""
    delays = [getattr(element.function, "delay", 0.0) for element in circuit.elements
              if isinstance(getattr(element, "function", None), (Pulse, Sin))]
    return max(delays, default=0.0)


def _period_grid(mlcs: MLCS, step: float, t0: float, period: float) -> np.ndarray:
    """The grid of one period ``[t0, t0 + T]``: regular steps from ``t0`` plus every breakpoint."""
    points = mlcs.breakpoints(t0 + period)
    local = points[(points > t0) & (points < t0 + period)] - t0
    return t0 + time_grid(step, period, local)


def _whole_grid(mlcs: MLCS, step: float, stop: float) -> np.ndarray:
    return time_grid(step, stop, mlcs.breakpoints(stop))


PERIOD_MAP_BYTES = 4
"""The period map's memory per step, in multiples of a run's per point
(:func:`~circuitnsds.engine.integrate.trajectory_bytes`): the run through the period, each
step's map and mode key, and the composition. Measured 2.5-3.2 (tracemalloc and resident
memory, 1e5-4e5 steps per period, an RLC and the buck converter, 2026-11-23), with a margin."""


def _check_memory(circuit: Circuit, mlcs: MLCS, grid: np.ndarray, whole: np.ndarray | None) -> None:
    """Refuse, before starting, a periodic steady state whose period maps (or warm-up run,
    freed before them) cannot fit in memory."""

    needed = max(PERIOD_MAP_BYTES * trajectory_bytes(mlcs, grid.size),
                 trajectory_bytes(mlcs, whole.size) if whole is not None else 0)
    warm_up = f", warm-up {whole.size - 1:,} steps" if whole is not None else ""
    refuse_beyond_memory(
        needed, "the periodic steady state",
        f"{grid.size - 1:,} steps per period{warm_up}, {mlcs.n} unknowns and {mlcs.m} pairs", circuit,
        hint=f"a longer step (--step; now {format_si(float(np.diff(grid).max()), 's')}), fewer "
        "warm-up periods (--warmup), or a smaller circuit")


class _Shooter:
    """Newton on the period map with the exact monodromy matrix, with transient fallbacks."""

    def __init__(self, circuit: Circuit, mlcs: MLCS, grid: np.ndarray, period: float, tol: float):
        self.circuit, self.mlcs, self.grid, self.period, self.tol = circuit, mlcs, grid, period, tol
        self.iterations = 0
        self.history: list[float] = []
        self.transient_periods = 0
        self.mapper = StepMapper(mlcs, grid, tol=1e-9)

    def solve(self, y, charge, active, switches, max_iterations: int) -> PSSResult:
        best: tuple[float, np.ndarray, np.ndarray | None, np.ndarray, np.ndarray] | None = None
        failure = ""
        for round_ in range(FALLBACK_ROUNDS + 1):
            if round_ > 0:
                periods = FALLBACK_PERIODS * 2 ** (round_ - 1)
                y, charge, active, switches = self._transient(best, periods)
            seen: dict[int, float] = {}  # mode sequence -> residual when it was visited
            for attempt in range(max_iterations + 1):
                maps = self.mapper.run(y, charge, active, switches)
                run = maps.trajectory
                x0, x1 = run.y[0, maps.state], run.y[-1, maps.state]
                relative = self._relative(run.y[:, maps.state], x1 - x0)
                self.history.append(relative)
                if best is None or relative < best[0]:
                    best = (relative, run.y[0].copy(), charge, run.active[0].copy(), run.switches[0].copy())
                phi, c = maps.composition()
                if relative <= self.tol:
                    return self._result(maps, phi, float(np.abs(x1 - x0).max(initial=0.0)), relative)
                if attempt == max_iterations:
                    failure = (f"Newton did not settle in {max_iterations} steps (relative residual "
                               f"{relative:.2g}, the mode sequence kept changing)")
                    break
                sequence = hash(b"".join(maps.keys))
                if sequence in seen and relative >= 0.5 * seen[sequence]:
                    # back to a mode sequence without progress: Newton cycles between pieces of
                    # the piecewise affine period map; transient periods break the cycle
                    failure = f"Newton cycled between mode sequences (relative residual {relative:.2g})"
                    break
                seen[sequence] = relative
                x_new = self._newton(maps, phi, c)
                self.iterations += 1
                y = run.y[-1].copy()  # the algebraic unknowns do not enter an implicit Euler step
                y[maps.state] = x_new
                charge, active, switches = None, run.active[-1], run.switches[-1]
        free = [switch.name.upper() for switch in self.mlcs.switches if switch.control_stimulus is None]
        hint = ("try a smaller step (--step), more warm-up periods (periods_warmup, .pss TSTAB), "
                "or check the period")
        if free:
            hint = (f"switch(es) {', '.join(free)} are controlled by the circuit: their instants "
                    "are located and the period map's Jacobian follows them, but only for the "
                    "sequence of modes and switchings a run visits; far from the periodic state "
                    "Newton can jump between sequences (a switching that appears or vanishes, a "
                    "limiter that saturates);\n  more warm-up periods (periods_warmup, .pss TSTAB) "
                    "bring the transient closer, and a tolerance above the best residual "
                    f"(tol={2 * best[0]:.2g}, --tol) accepts the best period found;\n  if they "
                    "switch by themselves (a hysteretic controller), the period is not the sources' "
                    "and that is not supported")
        raise SimulationError(f"the periodic steady state was not found: {failure}; best relative "
                              f"residual {best[0]:.2g} after {self.transient_periods} transient periods",
                              where=self.circuit.file, hint=hint)

    def _relative(self, states: np.ndarray, change: np.ndarray) -> float:
        scale = np.abs(states).max(axis=0)
        floor = 1e-9 * max(float(scale.max(initial=0.0)), 1e-30)
        return float(np.abs(change / np.maximum(scale, floor)).max(initial=0.0))

    def _newton(self, maps: StepMaps, phi: np.ndarray, c: np.ndarray) -> np.ndarray:
        """Solve ``(I − Φ) x = c``, or say in words why not."""
        size = phi.shape[0]
        matrix = np.eye(size) - phi
        multipliers, vectors = np.linalg.eig(phi)
        closest = int(np.argmin(np.abs(1.0 - multipliers))) if size else 0
        condition = np.linalg.cond(matrix) if size else 1.0
        if size and (abs(1.0 - multipliers[closest]) < SINGULAR or not condition < ILL_CONDITIONED):
            raise SimulationError(
                f"I − Φ is singular (Floquet multiplier {multipliers[closest]:.12g}, condition "
                f"{condition:.3g}): the state along {self._along(maps, vectors[:, closest])} is not "
                "damped over a period, so no Newton step can settle it", where=self.circuit.file,
                hint=UNDAMPED_HINT)
        return np.linalg.solve(matrix, c)

    def _along(self, maps: StepMaps, vector: np.ndarray) -> str:
        """The state unknowns that make up most of an eigenvector of ``Φ``."""
        size = np.abs(vector)
        return ", ".join(self.mlcs.unknowns[maps.state[j]] for j in np.argsort(size)[::-1][:3]
                         if size[j] > 0.1 * size.max())

    def _transient(self, best, periods: int):
        """Run ``periods`` periods of plain transient from the best state seen."""
        _, y, charge, active, switches = best
        grid = np.concatenate([self.grid[:-1] + j * self.period for j in range(periods)]
                              + [[self.grid[-1] + (periods - 1) * self.period]])
        refuse_beyond_memory(
            trajectory_bytes(self.mlcs, grid.size)
            + PERIOD_MAP_BYTES * trajectory_bytes(self.mlcs, self.grid.size),
            f"a fallback of {periods} transient periods", f"{grid.size - 1:,} steps, beside the "
            "period maps", self.circuit, hint="a longer step (--step), or more warm-up periods "
            "(--warmup) so that Newton needs no fallback")
        run = _plain_transient(self.mlcs, grid, StartState(y, charge, None, active, switches))
        self.transient_periods += periods
        # back to the first period's instants (the sources are periodic); copies, so that the
        # run's trajectory is freed
        return run.y[-1].copy(), None, run.active[-1].copy(), run.switches[-1].copy()

    def _check_step_damping(self, maps: StepMaps, phi: np.ndarray) -> None:
        """Refuse (or warn about) a periodic solution that the step's numerical damping sets
        rather than the circuit: along a mode, the response is ``1/(1 − multiplier)`` times what
        the sources put in, so where the period's implicit-Euler multiplier ``phi`` lies much
        further from 1 than the exact one (:func:`exact_monodromy`: each stretch of a mode
        integrated exactly; an undamped LC driven at its resonance: exactly 1), the amplitude
        found scales as 1/h. Only modes near resonance (:data:`RESONANCE_GAP`)."""
        if not phi.size:
            return
        exact = exact_monodromy(maps)
        if exact is None:
            return
        exact_values, exact_vectors = np.linalg.eig(exact)
        closest = int(np.argmin(np.abs(1.0 - exact_values)))
        gap = float(abs(1.0 - exact_values[closest]))
        if gap > RESONANCE_GAP:
            return
        values, vectors = np.linalg.eig(phi)
        along = exact_vectors[:, closest] / np.linalg.norm(exact_vectors[:, closest])
        match = int(np.argmax(np.abs(vectors.conj().T @ along)
                              / np.maximum(np.linalg.norm(vectors, axis=0), 1e-300)))
        stepped = float(abs(1.0 - values[match]))
        if stepped < SINGULAR or stepped <= STEP_DAMPING_RATIO * gap:
            return
        names = self._along(maps, exact_vectors[:, closest])
        what = (f"along {names} the circuit forgets |1 − μ| = {gap:.2g} of its state per period "
                f"(μ: its exact Floquet multiplier), the implicit-Euler steps {stepped:.2g}: the "
                "amplitude found there is set by the step's numerical damping, not by the circuit")
        if stepped > NO_PERIODIC_RATIO * gap:
            raise SimulationError(
                f"no periodic steady state to show: {what} (it scales as 1/h; the circuit's own "
                f"response grows without bound, or to {stepped / max(gap, 1e-300):.2g} times the "
                "one found)", where=self.circuit.file, hint=RESONANCE_HINT)

        warnings.warn(CircuitWarning(
            f"{self.circuit.file}: {what} ({stepped / gap:.2g} times the circuit's); a smaller "
            "step (--step) brings it closer"), stacklevel=6)

    def _result(self, maps: StepMaps, phi: np.ndarray, residual: float, relative: float) -> PSSResult:
        self._check_step_damping(maps, phi)
        run = maps.trajectory
        multipliers = np.linalg.eigvals(phi) if phi.size else np.zeros(0)
        multipliers = multipliers[np.argsort(-np.abs(multipliers), kind="stable")]
        if multipliers.size:
            phi_values, vectors = np.linalg.eig(phi)
            closest = int(np.argmin(np.abs(1.0 - phi_values)))
            if abs(1.0 - phi_values[closest]) < SINGULAR:
                warnings.warn(CircuitWarning(
                    f"{self.circuit.file}: the periodic solution is not unique: the state along "
                    f"{self._along(maps, vectors[:, closest])} is not damped (Floquet multiplier 1), "
                    f"so every value of it repeats and the one shown is the initial state's; "
                    f"{UNDAMPED_HINT}"), stacklevel=5)
            elif np.abs(multipliers).max() > 1.0:
                warnings.warn(CircuitWarning(
                    f"{self.circuit.file}: the periodic solution found is not stable (largest Floquet "
                    f"multiplier |λ| = {np.abs(multipliers).max():.6g} > 1): a transient would not "
                    "settle to it"), stacklevel=5)
        # the first point holds the state given, not the algebraic unknowns at t0: take them from
        # the period's end, which is the same instant of the periodic solution
        run.y[0] = run.y[-1]
        run.current[0] = run.current[-1]
        waves = trajectory_waveforms(self.circuit, self.mlcs, run, run.time[0], run.time[-1], periodic=True)
        waves.stats.update(analysis="pss", iterations=self.iterations)
        names = [self.mlcs.unknowns[j] for j in maps.state]
        return PSSResult(waveforms=waves, period=self.period, t0=float(run.time[0]), state_names=names,
                         state=run.y[0, maps.state].copy(), iterations=self.iterations,
                         residual=residual, relative_residual=relative, monodromy=phi,
                         multipliers=multipliers, transient_periods=self.transient_periods,
                         history=list(self.history), maps=maps, mlcs=self.mlcs)
