"""What ``circuitnsds info`` prints: a circuit's elements, nodes, MLCS size, breakpoints, checks.

:func:`circuit_report` returns the text and whether every check needed for a
transient passed; it builds the MLCS only when they did (it cannot exist otherwise).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.errors import CircuitError
from circuitnsds.units import format_si

BREAKPOINTS_SHOWN = 8
"""How many source breakpoints the report lists before it only counts them."""
NAMES_SHOWN = 100
"""How many names (nodes, elements, unknowns, pairs) a line lists before it only counts them."""
DENSE_UNKNOWNS = 2500
"""Above this many unknowns plus pairs the step's well-posedness (dense matrices: P-matrix
and PSD tests, O(size³) time and 8·size² bytes) is skipped with a note: a 10,000-section RC
ladder took 209 s and 3.2 GB, a 2^17-instance subcircuit tree asked for 128 GiB. (A
2,000-section ladder: 2.3 s.) ``circuitnsds run`` checks every step it solves."""


def _listed(names) -> str:
    """``names`` joined, at most :data:`NAMES_SHOWN` of them, then the count."""
    names = list(names)
    shown = ", ".join(names[:NAMES_SHOWN])
    return shown + (f", ... ({len(names)} in all)" if len(names) > NAMES_SHOWN else "")

_KINDS = {
    "Resistor": "resistors", "Capacitor": "capacitors", "Inductor": "inductors",
    "MutualInductance": "coupled inductors", "VoltageSource": "voltage sources",
    "CurrentSource": "current sources", "Diode": "diodes", "Switch": "switches",
    "Mosfet": "MOSFETs (switches)", "Igbt": "IGBTs", "Thyristor": "thyristors (SCR)",
    "VoltageControlledVoltageSource": "controlled sources (E)",
    "CurrentControlledCurrentSource": "controlled sources (F)",
    "VoltageControlledCurrentSource": "controlled sources (G)",
    "CurrentControlledVoltageSource": "controlled sources (H)",
    "BehaviouralSource": "behavioural sources and XSPICE code models (B, E/G VALUE/TABLE, A)",
    "Integrator": "integrators (A int)",
}


def element_kind(element) -> str:
    """Plural kind of an element for the report (``diodes``, ``Zener diodes``, ``resistors``)."""
    name = type(element).__name__
    if name == "Diode" and getattr(getattr(element, "model", None), "kind", "") == "zener":
        return "Zener diodes"
    return _KINDS.get(name, name)


def _model_detail(element) -> str | None:
    """One line on how the engine reads a device's model (diodes, Zeners, switches)."""
    model = getattr(element, "model", None)
    if model is None:
        return None
    if hasattr(model, "forward_drop") and getattr(model, "forward_fit", None) is not None:
        return (f"model {model.name}: {model.kind} diode of parallel branches, Roff="
                f"{model.off_resistance:g} Ω; read as {model.origin}")
    if hasattr(model, "forward_drop"):
        detail = (f"{model.kind} diode, Vfwd={model.forward_drop:g} V, Ron={model.on_resistance:g} Ω, "
                  f"Roff={model.off_resistance:g} Ω")
        if model.kind == "zener":
            detail += f", BV={model.breakdown_voltage:g} V, Rrev={model.breakdown_resistance:g} Ω"
        return f"model {model.name}: {detail}; read as {model.origin}"
    if hasattr(model, "threshold"):
        unit = "A" if model.current_controlled else "V"
        if type(element).__name__ == "Thyristor":
            control = f"i({element.name}.gate) + i({element.name}) (gate plus anode current)"
        elif getattr(element, "control", None):
            control = f"current of {element.control}"
        else:
            control = "v({}) - v({})".format(*element.control_nodes())
        if model.hysteresis == 0:
            where = f"closed above {model.threshold:g} {unit}, open at or below it (ngspice)"
        else:
            where = (f"closes above {model.threshold + abs(model.hysteresis):g} {unit}, opens below "
                     f"{model.threshold - abs(model.hysteresis):g} {unit}")
        detail = (f"model {model.name}: ideal switch on {control}, {where}, "
                  f"Ron={model.on_resistance:.4g} Ω, Roff={model.off_resistance:g} Ω")
        if hasattr(element, "polarity"):
            channel = "n" if element.polarity > 0 else "p"
            detail = (f"{channel}-channel {element.device.upper()} (drain {element.nodes[0]}, "
                      f"source {element.nodes[1]}, gate {element.gate}) as a {detail}; "
                      f"Ron = {element.on_resistance_rule}"
                      + (f"; {element.output_rule} (a run re-evaluates Ron and Coss where the "
                         "circuit works)" if element.output_rule else "")
                      + (f"; with {', '.join(element.parts)}" if element.parts else ""))
        kind = type(element).__name__
        if kind == "Igbt":
            detail = (f"IGBT (collector {element.nodes[0]}, gate {element.gate}, emitter "
                      f"{element.nodes[3]}): {detail}, in series with the on-state diode "
                      f"{element.name}.on" + (" and the antiparallel diode "
                      f"{element.name}.dfree" if len(element.parts) > 1 else "")
                      + "; the turn-off tail current is not modelled")
        elif kind == "Thyristor":
            detail = (f"thyristor (anode {element.nodes[0]}, gate {element.gate}, cathode "
                      f"{element.cathode}): {detail} (fires above IGT, holds down to IH), in series with the "
                      f"on-state diode {element.name}.on; gate junction {element.name}.gk")
        return detail
    return None


def smooth_lines(circuit: Circuit, mlcs) -> list[str]:
    """Which elements are smooth nonlinear relations (the Newton stepper integrates the
    circuit then) and which ideal; nothing for a circuit of ideal devices only."""
    if not mlcs.smooth:
        return []
    names = {relation.name for relation in mlcs.smooth}
    ideal = [e.name for e in circuit.elements
             if e.name not in names and (e.junction is not None or getattr(e, "auxiliaries", ()))]
    lines = [f"  smooth:   {_listed(sorted(names))}: smooth nonlinear element(s), linearised at "
             "every Newton iteration; the transient is integrated by the Newton stepper "
             "(method=newton: each step a nonlinear complementarity problem, its length by "
             "truncation error; the run summary gives iterations per step and time per iteration)"]
    if ideal:
        lines.append(f"  ideal:    {_listed(ideal)}: complementarity pairs and switches, exact in "
                     "every Newton iteration (no smoothing)")
    lines.append(f"  cost:     {_newton_cost(circuit, mlcs)}")
    return lines


def _newton_cost(circuit: Circuit, mlcs) -> str:
    """The measured cost of one Newton step from the operating point (words)."""
    from circuitnsds.analyses.operating_point import operating_point, uic_state
    from circuitnsds.engine.newton_step import NewtonFailure
    from circuitnsds.engine.newton_stepper import NewtonStepper
    from circuitnsds.errors import CircuitnsdsError

    tran = circuit.analyses.get("tran")
    if tran is None:
        return "not measured (no .tran: no step to take)"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            state = uic_state(circuit, mlcs) if tran.uic else operating_point(circuit, mlcs)
            step, iterations, seconds = NewtonStepper(mlcs).measure_step(state.y, 0.0, tran.step)
    except (CircuitnsdsError, NewtonFailure, ValueError, ArithmeticError) as exc:
        return f"not measured (the first step from the starting point failed: {exc})"
    return (f"the first step ({format_si(step, 's')}) from the starting point took "
            f"{iterations} Newton iteration(s), {1e6 * seconds:.0f} µs each (each a linearisation "
            f"and a dense solve of {mlcs.n + mlcs.m} unknowns and pairs); a circuit of ideal devices "
            "takes about a microsecond per step in its compiled mode loops")


def run_checks(circuit: Circuit) -> list[tuple[str, str | None, bool]]:
    """The circuit checks: ``(what, failure message or None, needed for the transient)``.

    The operating-point checks are not needed when the transient starts from initial
    conditions (UIC).
    """
    from circuitnsds.checks import topology

    checks: list[tuple[str, Callable[[], None], bool]] = [
        ("every node has a path to ground",
         lambda: topology.check_connected(circuit.elements, circuit.nodes), True),
        ("no loop of voltage sources only",
         lambda: topology.check_source_loops(circuit.elements), True),
        ("no node fed only by current sources",
         lambda: topology.check_current_cutsets(circuit.elements, circuit.nodes), True),
    ]
    tran = circuit.analyses.get("tran")
    uic = bool(tran and tran.uic)
    checks += [
        ("DC operating point: no loop of voltage sources and inductors",
         lambda: topology.check_source_loops(circuit.elements, operating_point=True), not uic),
        ("DC operating point: every node has a DC path to ground",
         lambda: topology.check_current_cutsets(circuit.elements, circuit.nodes, operating_point=True,
                                                held=list(circuit.initial_voltages)), not uic),
    ]
    results = []
    for what, check, needed in checks:
        try:
            check()
            results.append((what, None, needed))
        except CircuitError as exc:
            results.append((what, exc.message, needed))
    return results


def _method_line(circuit: Circuit, mlcs) -> str:
    """Which stepper a run would use (``.options method``, else the default: the Newton stepper
    for smooth relations, as the run takes it) and why."""
    from circuitnsds.engine.stepper import DEFAULT_STEPPER, SMOOTH_STEPPER, choose_stepper, default_note

    name = circuit.options.get("method", SMOOTH_STEPPER if mlcs.smooth else DEFAULT_STEPPER)
    try:
        chosen, why = choose_stepper(name, mlcs)
    except ValueError as exc:
        return str(exc)
    reason = chosen.unsuited(mlcs)
    if reason is not None:
        return f"{chosen.name}, which cannot run this circuit: {reason}"
    words = {"theta": "the θ-method", "exact": "exact, event-driven (.tran TSTEP sets the rows "
             "reported, not the accuracy)"}.get(chosen.name, chosen.name)
    if "method" not in circuit.options:
        why = ("taken by itself for the smooth nonlinear elements" if mlcs.smooth
               else default_note(mlcs))
    return words + (f" ({why})" if why else "")


def circuit_report(circuit: Circuit) -> tuple[str, bool]:
    """The text of ``circuitnsds info`` and whether the circuit passed the checks a transient needs.

    The MLCS is built (and described) whenever the structural checks pass, even if
    the operating point is undefined.
    """
    from circuitnsds.analyses.mosfet_refits import at_supply

    circuit = at_supply(circuit)  # MOSFETs' output capacitances as a run starts them
    lines = [f"title:     {circuit.title}", f"file:      {circuit.file}"]
    lines.append(f"nodes:     {len(circuit.nodes)} + ground 0: {_listed(circuit.nodes)}")
    kinds: dict[str, list] = {}
    for element in circuit.elements:
        kinds.setdefault(element_kind(element), []).append(element)
    lines.append(f"elements:  {len(circuit.elements)}")
    for kind, elements in kinds.items():
        lines.append(f"  {kind} ({len(elements)}): {_listed(e.name for e in elements)}")
    details = [(e, _model_detail(e)) for e in circuit.elements]
    details = [(e, d if not getattr(getattr(e, "model", None), "thermal", None) else
                f"{d}; datasheet losses and junction temperature from {e.model.thermal} "
                "(docs/losses.md)") for e, d in details]
    details = [(e, d) for e, d in details if d]
    if details:
        lines.append("devices:")
        lines += [f"  {e.name} {' '.join(e.nodes)}: {d}" for e, d in details[:NAMES_SHOWN]]
        if len(details) > NAMES_SHOWN:
            lines.append(f"  ... ({len(details)} in all)")
    t = circuit.analyses.get("tran")
    if t:
        lines.append(f"tran:      step {format_si(t.step, 's')}, stop {format_si(t.stop, 's')}"
                     + (f", start {format_si(t.start, 's')}" if t.start else "")
                     + (f", max step {format_si(t.max_step, 's')}" if t.max_step else "")
                     + (", UIC" if t.uic else ""))
    else:
        lines.append("tran:      none (give step and stop to run)")

    checks = run_checks(circuit)
    ok = all(failure is None for _, failure, needed in checks if needed)
    structural = all(failure is None for _, failure, _ in checks[:3])
    lines.append("checks:")
    for what, failure, needed in checks:
        if failure is None:
            lines.append(f"  pass  {what}")
        else:
            lines.append(f"  {'FAIL' if needed else 'skip'}  {what}: {failure}"
                         + ("" if needed else " (not needed: the transient starts from UIC)"))
    if not structural:
        lines.append("MLCS:      not built: the circuit fails the checks above")
        return "\n".join(lines), False

    mlcs = circuit.mlcs()
    states = int(mlcs.differential_rows.sum())
    switches = getattr(mlcs, "switches", [])
    lines.append(f"MLCS:      {mlcs.n} unknowns = {states} states (differential rows) + "
                 f"{mlcs.n - states} algebraic; {mlcs.m} complementarity pairs"
                 + (f"; {len(switches)} switches (exogenous modes)" if switches else "")
                 + f"; {len(mlcs.stimuli)} source function(s)")
    lines.append(f"  unknowns: {_listed(mlcs.unknowns)}")
    lines += smooth_lines(circuit, mlcs)
    lines.append(f"  pairs:    {_listed(mlcs.pairs) if mlcs.pairs else '(none)'}")
    lines.append(f"method:    {_method_line(circuit, mlcs)}")
    stop = t.stop if t else None
    if stop is not None:
        try:
            points = mlcs.breakpoints(stop)
        except CircuitError as exc:  # too many to list: the run refuses them the same way
            lines.append(f"breakpoints: not listed: {exc.message}")
        else:
            shown = ", ".join(format_si(float(p), "s", 6) for p in points[:BREAKPOINTS_SHOWN])
            more = f", ... ({len(points)} in all)" if len(points) > BREAKPOINTS_SHOWN else ""
            lines.append(f"breakpoints: {len(points)} in (0, {format_si(stop, 's')})"
                         + (f": {shown}{more}" if len(points) else ""))
    size = mlcs.n + mlcs.m
    if size > DENSE_UNKNOWNS:
        lines.append(f"well-posedness of each step's LCP: not analysed: {size} unknowns and pairs, "
                     f"above {DENSE_UNKNOWNS} (the dense analysis would take {8 * size**2 / 2**30:.3g} "
                     "GiB and O(size³) time); `circuitnsds run` checks each step it solves")
        return "\n".join(lines), ok
    from circuitnsds.checks.wellposed import report_lines

    lines += report_lines(circuit)
    return "\n".join(lines), ok
