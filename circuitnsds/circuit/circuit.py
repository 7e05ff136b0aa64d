"""A circuit: elements, nodes, models, initial conditions; the user's entry point to simulation.

The analysis lines read with it (``.tran``, ``.pss``, ``.ac``) are plain specs
(:mod:`circuitnsds.specs`) in :attr:`Circuit.analyses`; the circuit does not use them
itself: each analysis takes the circuit and its spec.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from circuitnsds.circuit.elements import Element
from circuitnsds.errors import CircuitError, NetlistError, SourceLocation
from circuitnsds.specs import AcSpec, AnalysisSpec, PssSpec, SourceDefaults, TransientSpec, TranSpec
from circuitnsds.system.mlcs import MLCS, MLCSBuilder

__all__ = ["AcSpec", "Circuit", "PssSpec", "TranSpec", "TransientSpec"]  # the specs: old import path

NO_TRAN = SourceDefaults(1.0, 1.0)
"""Source defaults without a ``.tran`` line: a 1 s time scale."""


@dataclass
class Circuit:
    """Elements and settings read from a netlist (or built in Python).

    Attributes:
        title: the netlist's first line.
        elements: in netlist order.
        nodes: node names in order of first appearance, ground (``0``) excluded.
        models: model name -> :class:`~circuitnsds.circuit.elements.DiodeModel` (or the type
            letter of a model the engine does not use).
        analyses: the netlist's analysis lines as specs, by command without the dot:
            ``"tran"`` (:class:`~circuitnsds.specs.TransientSpec`), ``"pss"``
            (:class:`~circuitnsds.specs.PssSpec`), ``"ac"`` (:class:`~circuitnsds.specs.AcSpec`);
            data for the analyses, which take them as their defaults.
        initial_voltages: ``.ic`` node voltages [V] with their netlist locations.
        file: the netlist file name.
        included: the files its ``.include``/``.lib`` lines read (resolved paths).
        options: ``.options`` the engine uses (``theta``, ``gmin``, ``pwlfit``, ``diode``).
        measurements: the ``.meas tran`` statements (:class:`circuitnsds.output.meas.MeasureSpec`).
        fourier: the ``.four`` statements (:class:`circuitnsds.output.meas.FourierSpec`).
        saved_signals: signals named by ``.save`` (what the command line writes by default).
        strict: make every warning about the netlist or the circuit an error when the
            circuit is stamped or simulated (``read_netlist(..., strict=True)`` sets it).
        reported: the circuit warnings already given (each is given once).
    """

    title: str = ""
    elements: list[Element] = field(default_factory=list)
    nodes: list[str] = field(default_factory=list)
    models: dict[str, object] = field(default_factory=dict)
    model_locations: dict[str, SourceLocation] = field(default_factory=dict)
    analyses: dict[str, AnalysisSpec] = field(default_factory=dict)
    initial_voltages: dict[str, tuple[float, SourceLocation | None]] = field(default_factory=dict)
    file: str = "<text>"
    included: list[str] = field(default_factory=list)
    options: dict[str, float | str] = field(default_factory=dict)
    saved_signals: list[str] = field(default_factory=list)
    measurements: list = field(default_factory=list)
    fourier: list = field(default_factory=list)
    save_location: SourceLocation | None = None
    strict: bool = False
    reported: set[str] = field(default_factory=set, repr=False, compare=False)

    def _index(self, rebuild: bool = False) -> tuple[dict[str, int], set[str]]:
        """Positions of the elements by name and the set of nodes, kept in step with
        :attr:`elements` and :attr:`nodes` (rebuilt when those lists changed length, or on
        request): reading a netlist of ``N`` elements costs O(N), not O(N²)."""
        index = self.__dict__.get("_by_name")
        node_set = self.__dict__.get("_node_set")
        if (rebuild or index is None or len(index) != len(self.elements)
                or len(node_set) != len(self.nodes)):
            index = {}
            for position, element in enumerate(self.elements):
                index.setdefault(element.name, position)
            node_set = set(self.nodes)
            self.__dict__["_by_name"], self.__dict__["_node_set"] = index, node_set
        return index, node_set

    def _find(self, name: str) -> Element | None:
        """The element called ``name`` (lower case), or ``None``; an element replaced in
        :attr:`elements` directly is found too (the index is checked, rebuilt if stale)."""
        for rebuild in (False, True):
            position = self._index(rebuild)[0].get(name)
            if position is None:
                return None
            if position < len(self.elements) and self.elements[position].name == name:
                return self.elements[position]
        return None

    def add(self, element: Element, location: SourceLocation | None = None) -> None:
        """Append an element; its nodes join the node list."""
        existing = self._find(element.name)
        if existing is not None:
            first = f" (first at {existing.location})" if existing.location else ""
            raise NetlistError(f"element {element.name} is defined twice{first}",
                               where=location or element.name,
                               hint="element names must be unique")
        index, node_set = self._index()
        index[element.name] = len(self.elements)
        self.elements.append(element)
        for node in element.nodes:
            if node != "0" and node not in node_set:
                self.nodes.append(node)
                node_set.add(node)

    @property
    def tran(self) -> TransientSpec | None:
        """Deprecated (one release): ``analyses.get("tran")``."""
        return self._deprecated("tran", "tran")

    @property
    def pss_spec(self) -> PssSpec | None:
        """Deprecated (one release): ``analyses.get("pss")``."""
        return self._deprecated("pss_spec", "pss")

    @property
    def ac_spec(self) -> AcSpec | None:
        """Deprecated (one release): ``analyses.get("ac")``."""
        return self._deprecated("ac_spec", "ac")

    def _deprecated(self, attribute: str, key: str) -> AnalysisSpec | None:
        import warnings

        warnings.warn(f"Circuit.{attribute} is deprecated: use circuit.analyses.get({key!r})",
                      DeprecationWarning, stacklevel=3)
        return self.analyses.get(key)

    def element(self, name: str) -> Element:
        """The element called ``name`` (case-insensitive)."""
        element = self._find(name.lower())
        if element is None:
            raise KeyError(name)
        return element

    def mlcs(self, defaults: SourceDefaults | None = None) -> MLCS:
        """Stamp every element into the circuit's MLCS.

        ``defaults``: the TSTEP and TSTOP [s] of the analysis being run, which fill in the
        source fields that ngspice ties to the analysis (``PULSE`` rise time = TSTEP, ``SIN``
        frequency = 1/TSTOP, ...): every analysis passes its own (a transient:
        ``spec.source_defaults``). Without them, the netlist's ``.tran`` line's, as ngspice
        has them when it runs the netlist, else 1 s (for inspecting the equations; a source's
        value at t = 0, all the operating point reads, depends on none of them).

        Raises:
            CircuitError: the circuit fails a check of :mod:`circuitnsds.checks.topology` or
                :mod:`circuitnsds.checks.rules` (warnings of the latter are errors when ``strict``).
        """
        from circuitnsds.checks.rules import check_circuit, check_source_timing, check_stamps
        from circuitnsds.checks.topology import check_connected, check_current_cutsets, check_source_loops

        if not self.elements:
            raise CircuitError("the circuit has no elements", where=self.file)
        with self._strictness():
            check_circuit(self)
        check_connected(self.elements, self.nodes)
        check_source_loops(self.elements)
        check_current_cutsets(self.elements, self.nodes)
        if defaults is None:
            tran = self.analyses.get("tran")
            defaults = tran.source_defaults if tran is not None else NO_TRAN
        elif not isinstance(defaults, SourceDefaults):
            raise TypeError(
                f"Circuit.mlcs takes the analysis's SourceDefaults, not {defaults!r}: "
                "write circuit.mlcs(SourceDefaults(step=TSTEP, stop=TSTOP)) "
                "(the mlcs(step, stop) form was removed)"
            )
        resolved = self.resolved_elements(defaults)
        check_source_timing(resolved, defaults.stop)
        builder = MLCSBuilder(self.nodes)
        with np.errstate(all="ignore"):
            for element in resolved:
                element.stamp(builder)
            mlcs = builder.build()
        check_stamps(resolved, mlcs)
        return mlcs

    def _strictness(self):
        """A context in which warnings are errors when the circuit is ``strict``."""
        from contextlib import nullcontext

        from circuitnsds.errors import strict_warnings

        return strict_warnings() if self.strict else nullcontext()

    def well_posedness(self, step: float | None = None, *, states=None, theta: float = 1.0):
        """Is each time step's complementarity problem uniquely solvable (see
        :mod:`circuitnsds.checks.wellposed`)? Returns a list of
        :class:`~circuitnsds.checks.wellposed.WellPosedness`, one per switch configuration examined.

        Args:
            step: the time step [s] (default: the ``.tran`` TSTEP, else 1 s).
            states: switch states to examine, a sequence of tuples of booleans (closed =
                true) in the order of the switches; default: every combination for up to
                4 switches, else the initial states, all open and all closed.
            theta: θ of the θ-method (the LCP of a step depends on it through ``K``).
        """
        from circuitnsds.checks.wellposed import analyse_circuit

        return analyse_circuit(self, step, states=states, theta=theta)

    def resolved_elements(self, defaults: SourceDefaults) -> list[Element]:
        """The elements, each source function's analysis-dependent defaults (``defaults``:
        the analysis's step and stop) filled in: what the initial-condition checks of a
        time-domain analysis read."""
        resolved = []
        for element in self.elements:
            function = getattr(element, "function", None)
            if function is not None:
                element = replace(element, function=function.resolve(*defaults))
            resolved.append(element)
        return resolved

    def transient(
        self,
        step: float | None = None,
        stop: float | None = None,
        *,
        start: float | None = None,
        max_step: float | None = None,
        theta: float | None = None,
        uic: bool | None = None,
        tol: float = 1e-9,
        progress: Callable[[float, float], None] | None = None,
        stepping: str = "auto",
        method: str | None = None,
        signals: Sequence[str] | None = None,
        sink=None,
    ):
        """Run a transient analysis with ideal devices; returns :class:`~circuitnsds.Waveforms`.

        Args:
            step: time step [s] (default: the ``.tran`` TSTEP). Every source
                breakpoint is also a grid point.
            stop: end time [s] (default: ``.tran`` TSTOP).
            start: first time written to the waveforms [s] (default ``.tran`` TSTART or 0).
            max_step: upper bound on the step [s] (default ``.tran`` TMAX).
            theta: θ of the θ-method, in [0.5, 1]; 1 is implicit Euler (default:
                ``.options theta``, else 1). The first step, and with θ < 1 the step
                after a switch changes state or a source's corner, is implicit Euler.
            uic: start from initial conditions instead of the operating point
                (default: ``.tran``'s UIC flag).
            tol: complementarity tolerance of every step (scaled residual).
            progress: ``callback(t, stop)`` called now and then during the run.
            stepping: how the steps whose mode (conducting devices, switch states, step
                size) is already known are taken: ``"auto"`` (default) by the mode loops,
                run in Python until the steps left are worth loading the loops compiled
                with numba (a short run never imports numba), ``"compiled"`` by the
                compiled loops from the start, ``"numpy"`` by the same loops run in
                Python, ``"mlcp"`` not at all: every step is solved as a complementarity
                problem. All compute the same scheme (results agree to rounding); the
                last three are for checking and timing the paths.
            method: the integration method (a stepper registered in
                :data:`circuitnsds.engine.stepper.STEPPERS`: ``"theta"``, the θ-method, or
                ``"exact"``, the event-driven exact integrator; ``"auto"``: exact where the
                circuit qualifies; default: ``.options method``, else ``"auto"``).
            signals: keep only these signals (e.g. ``["v(out)"]``; default: every signal,
                computed when first read). The run then goes in segments whose other
                unknowns are dropped as it goes: memory is bounded by what is kept (a
                million steps of one signal: 16 MB with the time), however large the
                circuit. No impulses are kept.
            sink: with ``signals``, where their rows go as the run proceeds instead of being
                kept, e.g. a :class:`~circuitnsds.output.csvfile.CsvStream` (a CSV file
                written segment by segment; memory bounded by one segment); the waveforms
                returned then hold no rows.

        Raises:
            CircuitError: the circuit or the analysis settings are ill-posed.
            SimulationError: a step has no solution or a value became non-finite; its
                ``partial`` attribute holds the waveforms up to the last good step.
        """
        from circuitnsds.analyses.transient import run_transient, transient_spec

        spec = transient_spec(self, step=step, stop=stop, start=start, max_step=max_step,
                              theta=theta, uic=uic)
        with self._strictness():
            return run_transient(self, spec, tol=tol, progress=progress, stepping=stepping,
                                 method=method, signals=signals, sink=sink)

    def pss(
        self,
        period: float | None = None,
        *,
        step: float | None = None,
        periods_warmup: int = 0,
        tol: float | None = None,
        max_iterations: int | None = None,
        uic: bool | None = None,
    ):
        """Periodic steady state by shooting with the exact monodromy matrix (docs/pss.md);
        returns a :class:`~circuitnsds.analyses.pss.PSSResult` (one settled period as
        ``result.waveforms``, Floquet multipliers, residual).

        Args:
            period: ``T`` [s] (default: ``.pss`` GFREQ's inverse, else the least common
                period of the PULSE and SIN sources).
            step: time step [s] (default: ``T / .pss PSSPOINTS``, else ``.tran`` TSTEP, else
                ``T / 1000``); the grid of one period also holds every source breakpoint.
            periods_warmup: periods of plain transient before the shooting (default: ``.pss``
                TSTAB's worth, else 0).
            tol: relative periodicity tolerance (default ``.pss`` STEADYCOEFF, else 1e-9; on
                the exact period map at most 1e-12, where its Newton converges quadratically).
            max_iterations: Newton steps before a fallback of transient periods (default
                ``.pss`` SCITER, else 10; on the exact period map, else 30, and when they do
                not settle it, ``method=auto`` falls back to the θ shooting, with a note).
            uic: start from initial conditions, not the operating point.

        Raises:
            CircuitError: no period can be found, θ ≠ 1 is asked for, bad settings.
            SimulationError: a step fails, ``I − Φ`` is singular, or Newton does not settle
                (the message says which and what to try).
        """
        from circuitnsds.analyses.pss import run_pss

        with self._strictness():
            return run_pss(self, self.analyses.get("pss"), period=period, step=step,
                           periods_warmup=periods_warmup, tol=tol,
                           max_iterations=max_iterations, uic=uic)

    def ac(self, input: str | None = None, outputs=None, frequencies=None, *, around: str = "auto",
           pss=None):
        """Small-signal transfer functions from the value of source ``input`` to ``outputs``
        (signal names as in :meth:`transient`; default: every signal) at ``frequencies`` [Hz]
        (default: the ``.ac`` line's); returns an :class:`~circuitnsds.analyses.ac.ACResult`.
        Without ``input``, every source with an ``AC`` magnitude drives the circuit at once
        (SPICE's ``.ac``) and the result is each output's phasor.

        ``around``: ``"op"`` linearises at the operating point (every source constant:
        SPICE's ``.ac`` with ideal devices), ``"pss"`` around the periodic steady state (a
        switching circuit; ``pss``: a :meth:`pss` result to reuse), ``"auto"`` chooses
        ``"pss"`` when a source varies in time.
        """
        from circuitnsds.analyses.ac import run_ac

        with self._strictness():
            return run_ac(self, self.analyses.get("ac"), input, outputs, frequencies, around=around,
                          pss=pss)

    def operating_point(self) -> dict[str, float]:
        """DC operating point with ideal devices: every output signal's value [V or A]."""
        from circuitnsds.analyses.operating_point import operating_point

        mlcs = self.mlcs()
        state = operating_point(self, mlcs)
        values = mlcs.outputs(state.y[None, :], state.current[None, :])[0]
        return dict(zip(mlcs.output_names, values.tolist()))
