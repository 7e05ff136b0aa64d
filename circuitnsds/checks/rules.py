"""Element-level checks and warnings about a circuit, run before it is stamped.

:mod:`circuitnsds.checks.topology` refuses circuits without a unique solution (floating
nodes, loops of voltage sources, cutsets of current sources). This module adds
what concerns single elements and what is legal but suspicious:

Errors (:class:`~circuitnsds.errors.CircuitError`), mostly for circuits built in Python
(the netlist reader refuses the same mistakes with file:line):

* a non-finite value (NaN or infinity) in any element or model;
* a resistance that is not positive, a negative capacitance or inductance;
* two elements with one name;
* a ``K`` coupling naming an element that is not an inductor of the circuit;
* an ``F``/``H`` source or ``W`` switch controlled by an element that has no
  current unknown (not a voltage source, inductor, ``E``/``H`` source or switch);
* (:func:`check_stamps`) stamped equations that are not finite (``R = 1e-320``: 1/R overflows);
* (:func:`check_source_timing`) a ``PULSE`` whose corners alone would need more time
  steps than a run may have.

Warnings (:class:`~circuitnsds.errors.CircuitWarning`; ``--strict`` makes them errors):

* a 0 F capacitor (an open circuit) or a 0 H inductor (a short: it counts as a 0 V
  voltage source in the loop check);
* an element whose two terminals are the same node;
* a dangling node: it appears at one terminal only, so no current flows through
  that element;
* a loop of voltage sources and switches with ``RON = 0``: when the switches close,
  the loop's currents are undefined and the step has no unique solution;
* a group of nodes reached only through current sources and switches: while the
  switches are open, the source current can flow only through their ``ROFF``;
* diodes with ``Ron = 0`` in parallel in the same direction (or Zener breakdown branches
  with ``Rrev = 0``): how they share a current is not determined;
* at start-up under UIC (:func:`check_initial_conditions`): a loop of voltage sources and
  capacitors whose initial voltages do not add up to zero, or a cutset of current
  sources and inductors whose initial currents do not; the state then jumps at ``t = 0``
  (a Dirac current or voltage), which the ideal engine computes but which is
  rarely what was meant.

Each warning is given once per :class:`~circuitnsds.circuit.circuit.Circuit`, however
often the circuit is stamped.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import fields, is_dataclass

import numpy as np

from circuitnsds.checks.topology import GROUND, LoopFinder, is_short, isolated_groups
from circuitnsds.circuit.elements import Element
from circuitnsds.errors import CircuitError, CircuitWarning

MISMATCH = 1e-6
"""Relative tolerance of the start-up loop (KVL) and cutset (KCL) sums."""


def check_circuit(circuit) -> None:
    """Run every element-level check and structural warning on ``circuit``.

    Raises:
        CircuitError: for the errors listed in the module docstring.

    Warns:
        CircuitWarning: for the warnings (each once per circuit).
    """
    elements = circuit.elements
    _check_names(elements)
    for element in elements:
        _check_values(element)
    _check_references(elements)
    for message in _element_warnings(elements):
        _warn(circuit, message)
    for message in _dangling_nodes(elements, circuit.nodes):
        _warn(circuit, message)
    for message in _switch_loops(elements):
        _warn(circuit, message)
    for message in _switch_cutsets(elements, circuit.nodes):
        _warn(circuit, message)
    for message in _parallel_ideal_diodes(elements):
        _warn(circuit, message)


def _parallel_ideal_diodes(elements: Sequence[Element]) -> Iterable[str]:
    """Diodes without on-resistance side by side, in the same direction: while they conduct
    nothing decides how they share the current (the step's solution is not unique; the
    solver returns one split, arbitrary). Same for the breakdown branches of Zeners."""
    branches: dict[tuple[str, str, float], list[Element]] = {}
    for element in elements:
        if element.junction != "diode" or element.nodes[0] == element.nodes[1]:
            continue
        model = element.model
        anode, cathode = element.nodes[:2]
        if model.on_resistance == 0:
            branches.setdefault((anode, cathode, model.forward_drop), []).append(element)
        if model.kind == "zener" and model.breakdown_resistance == 0:
            branches.setdefault((cathode, anode, model.breakdown_voltage), []).append(element)
    for (a, b, _), group in branches.items():
        if len(group) > 1:
            names = ", ".join(e.name for e in group)
            yield (f"{_where(group[1])}{names} are ideal (Ron = 0) and in parallel from {a} to {b}: "
                   "while they conduct, how they share the current is not determined (the results "
                   "show one arbitrary split; their sum is right); give the model Ron > 0 to share "
                   "it by resistance, or keep one diode")


SPREAD = 1e16
"""Conductances (resistors, ``C/h``, ``h/L``, device ``1/Ron`` and ``1/Roff``) spread over
more than this factor make a circuit's equations too ill-conditioned for double precision
(16 digits in all): the smaller ones are rounding noise beside the larger."""


def conductance_scales(elements: Sequence[Element], step: float) -> list[tuple[Element, str, float]]:
    """``(element, what, siemens)`` for every element with a conductance-like stamp: what the
    step's equations hold for it (``1/R``, ``C/h``, ``h/L``, ``1/Ron``, ``1/Roff``) [S]."""
    return [(element, what, siemens) for element in elements
            for what, siemens in element.conductances(step)]


def ill_conditioning(elements: Sequence[Element], step: float) -> str | None:
    """A sentence naming the values that make the equations ill-conditioned (conductances
    spread over more than :data:`SPREAD`), or ``None``: the elements within a decade of the
    largest conductance, and of the smallest unless that is an ``Roff`` (expected to be tiny:
    the default 1e12 Ω)."""
    with np.errstate(all="ignore"):
        scales = [(e, what, g) for e, what, g in conductance_scales(elements, step)
                  if np.isfinite(g) and g > 0]
    if len(scales) < 2:
        return None
    logs = np.log10([g for _, _, g in scales])
    high, low = float(logs.max()), float(logs.min())
    if high - low <= math.log10(SPREAD):
        return None
    named = [f"{e.name} ({what})" for (e, what, _), log in zip(scales, logs)
             if log >= high - 1 or (log <= low + 1 and not what.startswith("Roff"))]
    at = "" if math.isinf(step) else f" at h = {step:.3g} s"
    return (f"{', '.join(dict.fromkeys(named[:6]))}: the circuit's conductances{at} span "
            f"1e{high - low:.0f} (from 1e{low:.0f} to 1e{high:.0f} S), more than double "
            "precision resolves; change those values")


def check_initial_conditions(circuit, elements: Sequence[Element], uic: bool) -> None:
    """Start-up warnings: under UIC, loops of voltage sources and capacitors whose initial
    voltages do not sum to zero, and cutsets of current sources and inductors whose
    initial currents do not (the state jumps at ``t = 0``).

    Args:
        circuit: the circuit (for its ``.ic`` node voltages and its warning record).
        elements: the circuit's elements with their source functions resolved
            (:meth:`Circuit.resolved_elements`), so that ``function.value(0)`` is defined.
        uic: whether the transient starts from initial conditions. Without UIC the
            operating point satisfies every loop and cutset and nothing is checked.
    """
    if not uic:
        return
    for message in _inconsistent_loops(circuit, elements):
        _warn(circuit, message)
    for message in _inconsistent_cutsets(circuit, elements):
        _warn(circuit, message)


def check_source_timing(elements: Sequence[Element], stop: float) -> None:
    """Refuse source functions whose corners alone would need more grid points than a run may
    have (a ``PULSE`` period of femtoseconds over milliseconds, a value of 1e-320): the time
    grid steps onto every corner.

    Args:
        elements: with their source functions resolved (:meth:`Circuit.resolved_elements`).
        stop: end of the run [s].

    Raises:
        CircuitError: naming the source and its period.
    """
    from circuitnsds.engine.timegrid import MAX_POINTS
    from circuitnsds.system.stimuli import Pulse

    for element in elements:
        function = getattr(element, "function", None)
        if isinstance(function, Pulse) and function.period and function.period > 0:
            with np.errstate(all="ignore"):
                periods = np.float64(stop - function.delay) / np.float64(function.period)
            if not (np.isfinite(periods) and periods * 4 <= MAX_POINTS):
                raise CircuitError(
                    f"{element.name}: PULSE period {function.period:g} s"
                    + (f" (delay {function.delay:g} s)" if function.delay else "")
                    + (f" repeats {periods:.3g} times before {stop:g} s: its corners alone need more "
                       f"than {MAX_POINTS:.0e} time steps" if np.isfinite(periods) else
                       f": the number of periods before {stop:g} s overflows"),
                    where=element.location or element.name,
                    hint="check the units of PER (PULSE(V1 V2 TD TR TF PW PER)) and of TSTOP")


def check_stamps(elements: Sequence[Element], mlcs) -> None:
    """The stamped matrices must be finite: a value such as ``R = 1e-320`` is a finite number
    whose conductance is not. Names the first element whose own stamp overflows.

    Raises:
        CircuitError: naming the element (or the whole circuit if no single element is to blame).
    """
    from circuitnsds.system.mlcs import MLCSBuilder

    matrices = (mlcs.E, mlcs.A, mlcs.B, mlcs.C, mlcs.D, mlcs.S)
    if all(np.isfinite(m.values).all() for m in matrices) and np.isfinite(mlcs.e).all():
        return
    nodes = list(mlcs.nodes)
    for element in elements:
        builder = MLCSBuilder(nodes)
        with np.errstate(all="ignore"):
            try:
                element.stamp(builder)
            except (ZeroDivisionError, OverflowError):
                pass
        if not np.isfinite(builder.stamped_values()).all():
            raise CircuitError(f"{element.name}: its equations hold numbers that are not finite "
                               "(a value too small or too large: e.g. 1/R overflows)",
                               where=element.location or element.name,
                               hint="check the element's value and units")
    raise CircuitError("the circuit's equations hold numbers that are not finite",
                       hint="check for values near 1e-308 or 1e308")


def _warn(circuit, message: str) -> None:
    reported = getattr(circuit, "reported", None)
    if reported is not None and message in reported:
        return
    warnings.warn(message, CircuitWarning, stacklevel=4)
    if reported is not None:  # not when the warning was raised as an error (strict)
        reported.add(message)


def _where(element: Element) -> str:
    return f"{element.location}: " if element.location else ""


# ---------------------------------------------------------------- errors


def _check_names(elements: Sequence[Element]) -> None:
    seen: dict[str, Element] = {}
    for element in elements:
        if element.name in seen:
            first = seen[element.name]
            raise CircuitError(f"element {element.name} is defined twice"
                               + (f" (first at {first.location})" if first.location else ""),
                               where=element.location or element.name,
                               hint="element names must be unique")
        seen[element.name] = element


def _numbers(value: object, prefix: str) -> Iterable[tuple[str, float]]:
    """Every float inside ``value`` (dataclass fields, tuples), with a dotted name."""
    if isinstance(value, bool) or value is None:
        return
    if isinstance(value, (int, float)):
        yield prefix, float(value)
    elif isinstance(value, (tuple, list)):
        for k, item in enumerate(value):
            yield from _numbers(item, f"{prefix}[{k}]")
    elif is_dataclass(value) and not isinstance(value, type):
        for item in fields(value):
            if item.name != "location":
                yield from _numbers(getattr(value, item.name), f"{prefix}.{item.name}" if prefix
                                    else item.name)


def _check_values(element: Element) -> None:
    for name, value in _numbers(element, ""):
        if not math.isfinite(value):
            raise CircuitError(f"{element.name}: {name} is {value} (not a finite number)",
                               where=element.location or element.name,
                               hint="check the value or the expression that computes it")
    errors = element.value_errors()  # the most basic first
    if errors:
        message, hint = errors[0]
        raise CircuitError(f"{element.name}: {message}", where=element.location or element.name,
                           hint=hint)


def _check_references(elements: Sequence[Element]) -> None:
    by_name = {element.name: element for element in elements}
    for element in elements:
        for name in element.inductors if element.topology == "coupling" else ():
            if name not in by_name or by_name[name].topology != "inductor":
                raise CircuitError(f"{element.name}: {name!r} is not an inductor of this circuit",
                                   where=element.location or element.name,
                                   hint="K couples two L elements by name: K1 L1 L2 0.99")
        control = getattr(element, "control", None)
        if isinstance(control, str) and control:
            owner = by_name.get(control)
            if owner is None or not owner.owns_branch_current:
                what = "does not exist" if owner is None else "has no current unknown"
                raise CircuitError(
                    f"{element.name}: controlling source {control!r} {what}",
                    where=element.location or element.name,
                    hint="F, H and W sense the current of a V source; add a 0 V source in "
                    "series with the branch to sense")


# ---------------------------------------------------------------- warnings


def _element_warnings(elements: Sequence[Element]) -> Iterable[str]:
    for element in elements:
        for sentence in element.value_warnings():
            yield f"{_where(element)}{element.name}: {sentence}"
        if (len(element.nodes) >= 2 and element.nodes[0] == element.nodes[1]
                and element.topology != "voltage"):
            parts = getattr(element, "parts", ())  # a MOSFET's junctions and capacitors remain
            if parts:  # (vendor subcircuits wire one with drain = source for its Cgd, body diode)
                yield (f"{_where(element)}{element.name}: drain and source are both node "
                       f"{element.nodes[0]}: its channel is shorted and carries no current; its "
                       f"{', '.join(parts)} remain")
            else:
                yield (f"{_where(element)}{element.name}: both terminals are node "
                       f"{element.nodes[0]}: the element is shorted and has no effect")


def _dangling_nodes(elements: Sequence[Element], nodes: Sequence[str]) -> Iterable[str]:
    count: dict[str, list[Element]] = {}
    for element in elements:
        for node in element.nodes:
            count.setdefault(node, []).append(element)
    for node in nodes:
        users = count.get(node, [])
        if len(users) == 1:
            element = users[0]
            yield (f"{_where(element)}node {node} is connected only to {element.name}: a dangling "
                   f"terminal, no current flows through {element.name} (a typo in a node name?)")


def _closes(switch: Element) -> bool:
    return switch.model.on_resistance == 0.0


def _switch_loops(elements: Sequence[Element]) -> Iterable[str]:
    """Loops of voltage sources (0 H inductors) and at least one ``RON = 0`` switch."""
    finder = LoopFinder()
    for element in elements:
        if element.topology == "voltage" or is_short(element):
            finder.add(element)
    for element in elements:
        if element.junction != "switch" or not _closes(element) or len(set(element.nodes[:2])) == 1:
            continue
        closed = finder.add(element)
        if closed is None:
            continue
        loop = [e for e, _ in reversed(closed)]
        switches = [e.name for e in loop if e.junction == "switch"]
        yield (f"{_where(element)}{', '.join(e.name for e in loop)} form a loop of voltage "
               f"sources and switches with RON=0: while {' and '.join(switches)} "
               f"{'is' if len(switches) == 1 else 'are'} closed the loop's currents are "
               "undefined and the time step has no solution (give the switch model RON > 0)")


def _switch_cutsets(elements: Sequence[Element], nodes: Sequence[str]) -> Iterable[str]:
    """Node groups joined to the rest only through current sources, inductors and switches,
    with at least one current source and one switch among them."""
    for group, crossing in _cutsets(elements, nodes, {"current", "inductor", "switch"}):
        sources = [e.name for e in crossing if e.topology == "current"]
        switches = [e.name for e in crossing if e.junction == "switch"]
        if not sources or not switches or any(e.topology == "inductor" for e in crossing):
            continue
        ohms = min(e.model.off_resistance for e in crossing if e.junction == "switch")
        yield (f"node(s) {', '.join(sorted(group))} connect to the rest of the circuit only through "
               f"{', '.join(e.name for e in crossing)}: while {', '.join(switches)} "
               f"{'is' if len(switches) == 1 else 'are'} open, the current of {', '.join(sources)} "
               f"can flow only through ROFF (>= {ohms:g} Ω), giving enormous voltages")


def _cutsets(elements: Sequence[Element], nodes: Sequence[str],
             kinds: set[str]) -> list[tuple[set[str], list[Element]]]:
    """Groups of nodes (without ground) that only elements of ``kinds`` join to the rest,
    with those elements; ``kinds`` holds topologies and ``switch`` for switches."""
    return isolated_groups(elements, nodes, lambda element: (
        "switch" if element.junction == "switch" else element.topology) in kinds)


# ---------------------------------------------------------------- start-up (UIC)


def _initial_voltage(circuit, element: Element) -> float | None:
    """Voltage ``v(nodes[0]) - v(nodes[1])`` [V] of a source or capacitor at ``t = 0`` under
    UIC, as the integration starts from it; ``None`` when it cannot be known beforehand."""
    if element.topology == "voltage":
        function = getattr(element, "function", None)
        return None if function is None else float(function.value(0.0))
    if is_short(element):
        return 0.0
    if element.topology == "capacitor":
        if element.initial_voltage is not None:
            return element.initial_voltage
        values = circuit.initial_voltages
        node_voltage = [0.0 if n == GROUND else values.get(n, (0.0, None))[0] for n in element.nodes]
        return node_voltage[0] - node_voltage[1]
    return None


def _inconsistent_loops(circuit, elements: Sequence[Element]) -> Iterable[str]:
    """Loops of voltage sources and capacitors (one per capacitor closing a loop) whose
    initial voltages do not sum to zero."""
    finder = LoopFinder()
    members = [e for e in elements if e.topology == "voltage" or is_short(e)]
    members += [e for e in elements if e.topology == "capacitor" and e.capacitance > 0]
    for element in members:
        if element.nodes[0] == element.nodes[1]:
            continue
        loop = finder.add(element)
        if loop is None:
            continue
        terms = [(e, _initial_voltage(circuit, e)) for e, _ in loop]
        if any(value is None for _, value in terms):
            continue
        total = sum(sign * value for (_, sign), (_, value) in zip(loop, terms))
        scale = max(1.0, *(abs(value) for _, value in terms))
        if abs(total) > MISMATCH * scale:
            names = ", ".join(e.name for e, _ in loop)
            kinds = ("capacitors" if all(e.topology == "capacitor" for e, _ in loop)
                     else "voltage sources and capacitors")
            yield (f"{_where(element)}{names} form a loop of {kinds} whose "
                   f"initial voltages (UIC) do not add up (they miss by {abs(total):.4g} V): the "
                   "capacitor voltages jump at t = 0 through a Dirac current (set the capacitors' "
                   "ic= to match the sources, or start from the operating point without UIC)")


def _inconsistent_cutsets(circuit, elements: Sequence[Element]) -> Iterable[str]:
    """Cutsets of current sources and inductors whose initial currents do not sum to zero."""
    for group, crossing in _cutsets(elements, circuit.nodes, {"current", "inductor"}):
        if not any(e.topology == "inductor" for e in crossing):
            continue
        total, scale = 0.0, 1.0
        for element in crossing:
            if element.topology == "inductor":
                value = element.initial_current or 0.0
            else:
                function = getattr(element, "function", None)
                if function is None:  # a controlled source: its current is not known yet
                    break
                value = float(function.value(0.0))
            scale = max(scale, abs(value))
            total += value if element.nodes[0] in group else -value
        else:
            if abs(total) > MISMATCH * scale:
                yield (f"node(s) {', '.join(sorted(group))} connect to the rest of the circuit only "
                       f"through {', '.join(e.name for e in crossing)}, whose initial currents (UIC) "
                       f"do not add up (they miss by {abs(total):.4g} A): the inductor currents jump "
                       "at t = 0 through a Dirac voltage (set the inductors' ic= to match, or start "
                       "from the operating point without UIC)")
