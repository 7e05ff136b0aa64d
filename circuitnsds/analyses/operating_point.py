"""The state a transient starts from: the DC operating point, or UIC initial conditions.

* Operating point (SPICE default): capacitors open, inductors shorted, ideal
  devices as complementarity pairs, sources at ``t = 0``, ``.ic`` nodes held at
  their values. This is one MLCP (Acary & Brogliato, §1.1.7, equilibrium points).
* UIC: capacitor voltages from ``ic=`` (else the difference of the ``.ic``
  node voltages, unset nodes at 0 V), inductor currents from ``ic=`` (else 0).
  An XSPICE integrator's output starts at its ``out_ic``.
  The other unknowns at ``t = 0`` are those these states imply (``_settled_start``).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from circuitnsds.checks.rules import ill_conditioning
from circuitnsds.checks.topology import check_current_cutsets, check_source_loops
from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import Capacitor, Inductor
from circuitnsds.engine import integrate
from circuitnsds.errors import CircuitError, NetlistWarning, RunNote, SimulationError
from circuitnsds.lazy import is_loaded_instance
from circuitnsds.solvers import LCPError, solve_mlcp
from circuitnsds.system.mlcs import MLCS

if TYPE_CHECKING:
    from circuitnsds.circuit.elements import Affine

BEHAVIOURAL = "circuitnsds.circuit.elements.behavioural"
"""Imported with the first behavioural card: without it the circuit has no such element."""


@dataclass
class InitialState:
    """Starting point of the integration.

    Attributes:
        y: MNA unknowns at ``t = 0`` (volts, amperes).
        charge: ``E @ y`` [C on node rows, Wb on inductor rows]: what the
            time stepping carries; differs from ``E @ y`` only under UIC with
            capacitor ``ic=`` values.
        current: pair currents at ``t = 0`` [A].
        active: guessed active set for the first step (``None``: no guess).
        switches: switch states at ``t = 0`` (closed = true), in ``mlcs.switches`` order.
    """

    y: np.ndarray
    charge: np.ndarray
    current: np.ndarray
    active: np.ndarray | None
    switches: np.ndarray | None = None


def operating_point(circuit: Circuit, mlcs: MLCS, tol: float = 1e-9) -> InitialState:
    """Solve the DC operating point with ideal devices (see module docstring).

    Switches start in their ``ON``/``OFF`` state, then follow their control at the
    operating point (with hysteresis) until no state changes. When a set of switches keeps
    toggling (a comparator in a loop: no DC operating point exists), a warning names them
    and the state is UIC's (:func:`uic_state`: the zero state unless ``ic=`` values say
    otherwise), where ngspice would find a point of its smooth comparator by source
    stepping and LTspice and PLECS start from zero.
    """
    _refuse_smooth(circuit, mlcs)
    check_source_loops(circuit.elements, operating_point=True)
    check_current_cutsets(circuit.elements, circuit.nodes, operating_point=True)
    _warn_unused_element_ics(circuit)
    integrate.source_values(mlcs, np.zeros(1))  # a source that is not finite at t = 0, named
    states = np.array([switch.initially_on for switch in mlcs.switches], dtype=bool)
    seen: list[bytes] = []
    while True:
        result = _solve_dc(circuit, mlcs, states, tol)
        y = np.asarray(result.u[:mlcs.n], dtype=float)
        following = np.array([switch.next_state(bool(on), _control_at_zero(mlcs, switch, y))
                              for switch, on in zip(mlcs.switches, states)], dtype=bool)
        if np.array_equal(following, states):
            break
        seen.append(states.tobytes())
        if following.tobytes() in seen:
            names = [s.name for s, a, b in zip(mlcs.switches, states, following) if a != b]
            _warn_toggling(circuit, names)
            return uic_state(circuit, mlcs)
        states = following
    if not np.all(np.isfinite(y)):
        raise SimulationError("the DC operating point is not finite", where="operating point",
                              hint="add UIC to .tran to start from initial conditions")
    _warn_switches_at_threshold(circuit, mlcs, states, y)
    _note_switches_closed_by_the_circuit(mlcs, states, y)
    return InitialState(y=y, charge=mlcs.E @ y, current=np.asarray(result.z, dtype=float),
                        active=np.asarray(result.active, dtype=bool), switches=states)


def _warn_toggling(circuit: Circuit, names: list[str]) -> None:
    """Say that no DC operating point exists because switches ``names`` toggle each other (a
    comparator in a loop: whichever state they take, their control crosses the threshold)
    and that the run starts from the zero state instead, as UIC (and PLECS) start."""
    controls = []
    for name in names:
        element = circuit.element(name)
        nodes = element.control_nodes() if hasattr(element, "control_nodes") else None
        control = getattr(element, "control", None)
        controls.append(f"{name} (control i({control}))" if control else
                        f"{name} (control v({nodes[0]}, {nodes[1]}))" if nodes else name)
    warnings.warn(NetlistWarning(
        f"{circuit.file}: no DC operating point: switch(es) {', '.join(controls)} toggle whichever "
        "state they take (a comparator in a loop); starting from the zero state, as UIC and "
        "PLECS do (ic= values kept, switches in their ON/OFF state); write UIC to say so"),
        stacklevel=3)


def _control_at_zero(mlcs: MLCS, switch, y: np.ndarray) -> float:
    """A switch's control quantity at the operating point [V or A]."""
    if switch.control_stimulus is not None:
        column, sign = switch.control_stimulus
        return sign * mlcs.stimuli[column].value(0.0)
    return switch.control_value(y)


def _solve_dc(circuit: Circuit, mlcs: MLCS, states: np.ndarray, tol: float):
    """One DC MLCP with the given switch states and the ``.ic`` nodes held."""
    n = mlcs.n
    held = [node for node in circuit.initial_voltages if node != "0"]
    rows = [circuit.nodes.index(node) for node in held]
    k = len(held)
    system = mlcs.system_matrix(tuple(bool(on) for on in states))
    source = np.concatenate([mlcs.source(0.0),
                             [-circuit.initial_voltages[node][0] for node in held]])
    if n + k + mlcs.m <= integrate.DENSE_MAP_LIMIT:  # a small circuit: dense blocks, no scipy
        matrix = np.zeros((n + k, n + k))
        matrix[:n, :n] = system.toarray()
        matrix[rows, n + np.arange(k)] = matrix[n + np.arange(k), rows] = 1.0
        coupling = np.zeros((n + k, mlcs.m))
        coupling[:n] = mlcs.B.toarray()
        output = np.zeros((mlcs.m, n + k))
        output[:, :n] = mlcs.C.toarray()
        pairs = mlcs.D.toarray()
    else:
        import scipy.sparse as sp

        incidence = sp.csr_matrix((np.ones(k), (rows, np.arange(k))), shape=(n, k))
        matrix = sp.bmat([[system.tocsr(), incidence], [incidence.T, None]], format="csr")
        coupling = sp.vstack([mlcs.B.tocsr(), sp.csr_matrix((k, mlcs.m))], format="csr")
        output = sp.hstack([mlcs.C.tocsr(), sp.csr_matrix((mlcs.m, k))], format="csr")
        pairs = mlcs.D.tocsr()
    try:
        return solve_mlcp(-matrix, -coupling, output, pairs, -source, mlcs.e, tol=tol)
    except LCPError as exc:
        ill = ill_conditioning(circuit.elements, math.inf)  # DC: capacitors open, inductors short
        if ill is not None:
            raise SimulationError("the DC operating point cannot be computed: " + ill,
                                  where="operating point") from None
        trials = _ic_trials(circuit, mlcs, states, tol) if held else []
        agreeing = {node for node, actual in trials
                    if _agrees(circuit.initial_voltages[node][0], actual)}
        if agreeing:  # held twice (by a source and by .ic), consistently: hold it once
            from dataclasses import replace

            kept = {k: v for k, v in circuit.initial_voltages.items() if k not in agreeing}
            return _solve_dc(replace(circuit, initial_voltages=kept), mlcs, states, tol)
        contradicted = []
        for node, actual in trials:
            value, location = circuit.initial_voltages[node]
            contradicted.append(f"{str(location) + ': ' if location else ''}.ic v({node})={value:g} "
                                f"contradicts the sources, which hold {node} at {actual:.6g} V")
        if contradicted:
            raise SimulationError(
                "the DC operating point has no solution: " + "; ".join(contradicted),
                where="operating point",
                hint="remove or correct those .ic values (a node a source drives cannot start "
                "elsewhere), or add UIC to .tran to start from them anyway") from None
        undetermined = getattr(exc, "evidence", {}).get("undetermined")
        if undetermined is not None:
            names = [mlcs.unknowns[j] for j in undetermined if j < mlcs.n]
            raise SimulationError(
                "the DC operating point is not unique: nothing in the circuit determines "
                f"{', '.join(names[:6]) + (', ...' if len(names) > 6 else '')} (the circuit's "
                "equations are singular)", where="operating point",
                hint="look for a controlled source that only repeats its own control (E1 a 0 a 0 1), "
                "a loop of voltage sources, or a node that nothing holds") from None
        raise SimulationError(
            f"the DC operating point has no solution with ideal devices ({exc})",
            where="operating point",
            hint="check that .ic values do not contradict the sources driving those nodes, "
            "then the diode orientations and source values; or add UIC to .tran",
        ) from None


MAX_IC_TRIALS = 20
"""At most this many ``.ic`` nodes are tried one by one to find the one a source contradicts."""

IC_AGREEMENT = 1e-6
"""An ``.ic`` value within this fraction of ``max(1 V, |value|)`` of the voltage the sources
give its node agrees with them (it only repeats what they hold)."""


def _ic_trials(circuit: Circuit, mlcs: MLCS, states: np.ndarray, tol: float
               ) -> list[tuple[str, float]]:
    """``(node, voltage)`` of each ``.ic`` node whose value alone makes the operating point
    impossible to solve: without that node held, the circuit gives it ``voltage``."""
    from dataclasses import replace

    found = []
    nodes = [node for node in circuit.initial_voltages if node != "0"][:MAX_IC_TRIALS]
    for node in nodes:
        others = {k: v for k, v in circuit.initial_voltages.items() if k != node}
        try:
            result = _solve_dc(replace(circuit, initial_voltages=others), mlcs, states, tol)
        except SimulationError:
            continue
        found.append((node, float(result.u[circuit.nodes.index(node)]) + 0.0))  # (+0.0: no -0)
    return found


def _agrees(value: float, actual: float) -> bool:
    return abs(actual - value) <= IC_AGREEMENT * max(1.0, abs(value))


def _refuse_smooth(circuit: Circuit, mlcs: MLCS) -> None:
    """Refuse smooth nonlinear relations, which the ideal operating point would leave out."""
    from circuitnsds.engine.stepper import smooth_refusal

    reason = smooth_refusal(mlcs)
    if reason is not None:
        raise CircuitError(f"the operating point cannot be computed: {reason}", where=circuit.file)


def uic_state(circuit: Circuit, mlcs: MLCS) -> InitialState:
    """Initial state from ``ic=`` and ``.ic`` values (SPICE's UIC).

    The integration starts from the charges ``E y`` of these initial conditions
    (ngspice's rule): a capacitor with ``ic=`` holds that voltage, any other
    capacitor the difference of its nodes' ``.ic`` values (an unset node counts
    as 0 V); an inductor carries its ``ic=`` current, else 0.

    The unknowns *reported* at ``t = 0`` hold these charges and obey the algebraic rows
    (:func:`_settled_start`); where that point does not exist without an impulse, the
    ``.ic`` values propagated across capacitors with ``ic=`` from known nodes (ground
    first), nodes reached by neither at 0 V.
    """
    _refuse_smooth(circuit, mlcs)
    y = np.zeros(mlcs.n)
    known = {"0"}
    for node, (value, _) in circuit.initial_voltages.items():
        if node != "0":
            y[circuit.nodes.index(node)] = value
            known.add(node)
    charge = mlcs.E @ y  # capacitors at their .ic node differences
    capacitors = [e for e in circuit.elements
                  if isinstance(e, Capacitor) and e.initial_voltage is not None]
    for cap in capacitors:
        a, b = (_index(circuit, node) for node in cap.nodes)
        implied = _voltage(circuit, y, cap.nodes[0]) - _voltage(circuit, y, cap.nodes[1])
        correction = cap.capacitance * (cap.initial_voltage - implied)
        if a >= 0:
            charge[a] += correction
        if b >= 0:
            charge[b] -= correction
    changed = True
    while changed:
        changed = False
        for cap in capacitors:
            a, b = cap.nodes
            if b in known and a not in known:
                y[_index(circuit, a)] = _voltage(circuit, y, b) + cap.initial_voltage
                known.add(a)
                changed = True
            elif a in known and b not in known:
                y[_index(circuit, b)] = _voltage(circuit, y, a) - cap.initial_voltage
                known.add(b)
                changed = True
    for element in circuit.elements:
        if isinstance(element, Inductor) and element.initial_current is not None:
            k = mlcs.unknowns.index(f"i({element.name})")
            y[k] = element.initial_current
            charge[k] = element.inductance * element.initial_current
    for element in circuit.elements:
        if is_loaded_instance(element, BEHAVIOURAL, "Integrator"):  # its state row starts at out_ic
            k = mlcs.unknowns.index(f"i({element.name})")
            charge[k] = element.initial_charge
            plus, minus = element.nodes[:2]
            if minus == "0" and plus != "0" and plus not in known:
                y[_index(circuit, plus)] = element.initial_output
    _consistent_auxiliaries(circuit, mlcs, y)
    switches = np.array([switch.initially_on for switch in mlcs.switches], dtype=bool)
    current = np.zeros(mlcs.m)
    settled = _settled_start(mlcs, charge, switches)
    if settled is not None and _keeps_initial_conditions(circuit, mlcs, y, settled[0]):
        y, current = settled  # (the pairs' currents too: a diode conducting at t = 0 showed 0 A)
    return InitialState(y=y, charge=charge, current=current, active=None, switches=switches)


def _keeps_initial_conditions(circuit: Circuit, mlcs: MLCS, given: np.ndarray,
                              settled: np.ndarray) -> bool:
    """Whether ``settled`` keeps every initial condition that ``given`` (the ``.ic`` values,
    propagated) holds: each capacitor's voltage, each ``.ic`` node's voltage, each inductor's
    current (within :data:`IC_AGREEMENT`). When it does not, the initial conditions contradict
    each other or the circuit (capacitors in parallel at different voltages share their charge
    at once): the first step makes that jump, and the row at ``t = 0`` shows what was given."""
    def voltage(y: np.ndarray, node: str) -> float:
        return _voltage(circuit, y, node)

    pairs = [(cap.initial_voltage if cap.initial_voltage is not None
              else voltage(given, cap.nodes[0]) - voltage(given, cap.nodes[1]),
              voltage(settled, cap.nodes[0]) - voltage(settled, cap.nodes[1]))
             for cap in circuit.elements if isinstance(cap, Capacitor)]
    pairs += [(value, voltage(settled, node))
              for node, (value, _) in circuit.initial_voltages.items() if node != "0"]
    inductors = {f"i({e.name})" for e in circuit.elements if isinstance(e, Inductor)}
    pairs += [(given[k], settled[k]) for k, name in enumerate(mlcs.unknowns) if name in inductors]
    return all(_agrees(float(value), float(actual)) for value, actual in pairs)


CONSISTENT_START_LIMIT = 400
"""Circuits of up to this many unknowns get a consistent UIC start (a dense SVD of ``E``)."""


def _settled_start(mlcs: MLCS, charge: np.ndarray, switches: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray] | None:
    """``(y, pair currents)`` at ``t = 0`` that hold the initial ``charge`` and obey every algebraic
    row and device law there: the limit of an implicit-Euler step as its length goes to 0.
    With ``E = U Σ Vᵀ`` split into its range (``U_r``) and left null space (``U_0``), that is
    ``U_rᵀ E y = U_rᵀ charge`` and ``U_0ᵀ (A y + B λ + s(0)) = 0``, with the pairs'
    complementarity. A capacitor with ``ic=`` in series with its ESR (no other capacitor
    linking it to ground) was reported at 0 V at ``t = 0``, and ``--losses`` booked its energy
    as stored during the run. ``None`` (the propagated ``.ic`` values are then reported, as
    before) for circuits above :data:`CONSISTENT_START_LIMIT` unknowns, and when no such
    point exists without an impulse at ``t = 0`` (the first step then makes the jump)."""
    n = mlcs.n
    if n + mlcs.m > CONSISTENT_START_LIMIT:
        return None
    E = mlcs.E.toarray()
    U, sigma, _ = np.linalg.svd(E)
    rank = int(np.count_nonzero(sigma > sigma.max(initial=0.0) * n * np.finfo(float).eps))
    kept, null = U[:, :rank], U[:, rank:]
    A = mlcs.system_matrix(tuple(bool(on) for on in switches)).toarray()
    B = mlcs.B.toarray()
    matrix = np.vstack([kept.T @ E, null.T @ A])
    coupling = np.vstack([np.zeros((rank, mlcs.m)), null.T @ B])
    source = np.concatenate([-(kept.T @ charge), null.T @ mlcs.source(0.0)])
    try:
        result = solve_mlcp(matrix, coupling, mlcs.C.toarray(), mlcs.D.toarray(), source, mlcs.e)
    except (LCPError, ValueError, ArithmeticError, np.linalg.LinAlgError):
        return None
    settled, currents = np.asarray(result.u, dtype=float), np.asarray(result.z, dtype=float)
    return (settled, currents) if np.isfinite(settled).all() and np.isfinite(currents).all() else None


def _consistent_auxiliaries(circuit: Circuit, mlcs: MLCS, y: np.ndarray) -> None:
    """Set the auxiliary unknowns ``x(name.k)`` of behavioural sources in ``y`` (in place)
    from the other entries of ``y`` and each comparator's initial state: a comparator's
    ``on``/``off`` value, ``min``/``max`` of their arguments.

    The first step decides every comparator's state from its control at ``y``; a latch's
    control contains its own state (through these auxiliaries), so with all of them 0 a
    latch started at 1 (``ic=1`` of ``d_dff``/``d_srlatch``) would drop to 0 at once. The
    auxiliaries are algebraic unknowns (no charge), so nothing else of the start changes.
    """
    index = {name: k for k, name in enumerate(mlcs.unknowns)}

    def value(affine: Affine, columns: list[int]) -> float:
        total = affine.constant
        total += sum(c * y[index[f"v({node})"]] for node, c in affine.voltages if node != "0")
        total += sum(c * y[index[f"i({source})"]] for source, c in affine.currents)
        return total + sum(c * y[columns[k]] for k, c in affine.auxiliaries)

    for element in circuit.elements:
        auxiliaries = getattr(element, "auxiliaries", ())
        if not auxiliaries or not is_loaded_instance(element, BEHAVIOURAL, "BehaviouralSource"):
            continue
        columns = [index[f"x({element.name}.{k})"] for k in range(len(auxiliaries))]
        for _ in range(len(auxiliaries)):  # enough passes for any order of definition
            for auxiliary, column in zip(auxiliaries, columns):
                if is_loaded_instance(auxiliary, BEHAVIOURAL, "MinMax"):
                    pick = max if auxiliary.kind == "max" else min
                    y[column] = pick(value(auxiliary.a, columns), value(auxiliary.b, columns))
                else:  # a comparator, in its initial state
                    y[column] = value(auxiliary.on if auxiliary.initially_on else auxiliary.off,
                                      columns)


def _voltage(circuit: Circuit, y: np.ndarray, node: str) -> float:
    return 0.0 if node == "0" else float(y[circuit.nodes.index(node)])


def _index(circuit: Circuit, node: str) -> int:
    return -1 if node == "0" else circuit.nodes.index(node)


def _warn_switches_at_threshold(circuit: Circuit, mlcs: MLCS, states: np.ndarray,
                                y: np.ndarray) -> None:
    """Warn about each open switch without hysteresis whose control sits exactly at ``VT`` at
    the operating point: circuitnsds starts it open (the control is not above ``VT``), ngspice
    39 closed (its ``swload.c``/``cswload.c`` take ``VH <= 0`` as "negative hysteresis": at
    ``VT`` a switch coming from REALLY_OFF, the operating point's previous state, becomes
    HYST_ON, and stays on until its control rises above ``VT`` and returns)."""
    from circuitnsds.circuit.elements import Switch

    elements = {e.name: e for e in circuit.elements if isinstance(e, Switch)  # S and W, not M
                and not is_loaded_instance(e, "circuitnsds.circuit.elements.mosfet", "Mosfet")}
    for switch, on in zip(mlcs.switches, states):
        element = elements.get(switch.name)
        if on or switch.crossing is None or element is None:
            continue
        control = _control_at_zero(mlcs, switch, y)
        margin = switch.on_threshold - switch.crossing
        if switch.crossing - margin <= control <= switch.on_threshold:
            level, band, unit = (("IT", "IH", "A") if element.model.current_controlled
                                 else ("VT", "VH", "V"))
            warnings.warn(
                f"{element.describe()}: its control starts exactly at its threshold "
                f"({level} = {switch.crossing:g} {unit}, {band} = 0): circuitnsds starts the "
                f"switch open, ngspice 39 starts it closed and keeps it closed until the control "
                f"rises above {level} and comes back; set {level} between the control's levels "
                f"(e.g. {level}=0.5 for a 0/1 {unit} control) or give {band} > 0 to make the start "
                "unambiguous", NetlistWarning, stacklevel=4)


def _note_switches_closed_by_the_circuit(mlcs: MLCS, states: np.ndarray, y: np.ndarray) -> None:
    """Note each switch (or comparator) controlled by the circuit that the operating point
    closed: its control at DC (capacitors open, inductors shorted) is above its threshold, so
    the run starts from the state the circuit would settle in with it closed for ever. A
    12 → 1.2 V buck whose comparator was true at t = 0 started at v(out) = 11 V and
    i(L) = 47 A with no word."""
    for switch, on in zip(mlcs.switches, states):
        if not on or switch.initially_on or switch.control_stimulus is not None:
            continue
        warnings.warn(RunNote(
            f"{switch.name}: the DC operating point starts it closed (its control is "
            f"{_control_at_zero(mlcs, switch, y):.4g} at DC, with capacitors open and inductors "
            f"shorted, above its threshold {switch.on_threshold:.4g}), so the run starts from "
            "the state the circuit reaches with it closed for ever (a converter at its "
            "full-duty output); add UIC to .tran to start from the initial conditions instead, "
            "with every switch in its ON/OFF state"), stacklevel=4)


def _warn_unused_element_ics(circuit: Circuit) -> None:
    for element in circuit.elements:
        value = getattr(element, "initial_voltage", None)
        if value is None:
            value = getattr(element, "initial_current", None)
        if value is not None:
            warnings.warn(
                f"{element.describe()}: ic={value:g} is ignored without UIC (as in SPICE); "
                "the transient starts from the operating point",
                NetlistWarning, stacklevel=4,
            )
