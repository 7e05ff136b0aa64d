"""The waveforms of a trajectory: each output signal of the MLCS, the capacitors' currents
(ΔQ/Δt of each step, charge-consistent; ``C dv/dt`` at the rows an exact integrator wrote)
and each device's impulses, computed when first read."""

from __future__ import annotations

import bisect

import numpy as np

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.circuit.elements import Capacitor
from circuitnsds.engine.events import event_time
from circuitnsds.engine.exact.rates import state_rates
from circuitnsds.output.waveforms import LazySignals, Waveforms
from circuitnsds.system.output_rows import output_values, signal_terms


def trajectory_waveforms(circuit: Circuit, mlcs, trajectory, start: float, stop: float, *,
               periodic: bool = False, flows: dict[str, np.ndarray] | None = None) -> Waveforms:
    """Output signals of ``trajectory`` from ``start`` on (each computed when first read).

    ``periodic``: the trajectory is one period of a periodic solution (its first and last
    points are the same instant), so the step into the first point is the last one.
    ``flows``: the capacitor currents [A] at each point of ``trajectory`` when it is a
    decimated run (the step before a point is not in it); else ΔQ/Δt of its steps, but at
    the points that are a closed form at their instant (``trajectory.exact_rows``), whose
    other currents are those at the instant: ``C dv/dt`` there
    (:func:`~circuitnsds.engine.exact.rates.state_rates`)."""
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
    exact = getattr(trajectory, "exact_rows", None)
    exact = exact[first:] if exact is not None and exact[first:].any() else None
    if exact is not None and exact[int(np.argmax(exact)):].all():  # (a run's rows after its first)
        exact = slice(int(np.argmax(exact)), None)  # (views of the rows, not copies)
    exact_row = np.zeros(time.size, bool)
    if exact is not None:
        exact_row[exact] = True
    rates: dict[str, np.ndarray] = {}  # (each capacitor node's rate at the exact rows, when first read)

    def rate(node: str) -> np.ndarray:
        """``dv(node)/dt`` [V/s] at the exact rows."""
        if not rates:  # (every capacitor node's at once: one pass over the rows)
            nodes = sorted({n for element in capacitors.values() for n in element.nodes[:2] if n != "0"})
            terms = {n: signal_terms(mlcs, rows[f"v({n})"]) for n in nodes}
            columns = sorted({column for n in nodes for source, column, _ in terms[n] if source == 0})
            values = state_rates(mlcs, time[exact], y[exact], current[exact],
                                 trajectory.switches[first:][exact], np.array(columns, dtype=int))
            for n in nodes:  # (v(node) is one unknown: its rate is that column's, weighted)
                rates[n] = sum(weight * values[:, columns.index(column)]
                               for source, column, weight in terms[n] if source == 0)
        return rates[node] if node != "0" else 0.0

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
                if point >= first and not exact_row[point - first]:
                    flow[point - first] = (charge[point - first] - charge_at(
                        element, y_start[None, :], trajectory.current[point:point + 1])) / length
            if periodic and time.size > 1:
                flow[0] = flow[-1]
            elif first > 0 and first not in tails:
                step = time[0] - trajectory.time[before]
                flow[0] = (charge[0] - charge_at(element, trajectory.y[before:first],
                                                 trajectory.current[before:first])) / step
            if exact is not None:  # (the instant's current, as the other currents there)
                flow[exact] = element.capacitance * (rate(element.nodes[0]) - rate(element.nodes[1]))
                if periodic and time.size > 1:
                    flow[0] = flow[-1]
            return flow
        return _row(name, y, current)

    def charge_at(element: Capacitor, states: np.ndarray, currents: np.ndarray) -> float:
        """The capacitor's charge [C] (n1 over n2) at one point: ``states``/``currents`` one row."""
        v = [0.0 if n == "0" else float(_row(f"v({n})", states, currents)[0]) for n in element.nodes[:2]]
        return element.capacitance * (v[0] - v[1])

    def _row(name: str, states: np.ndarray, currents: np.ndarray) -> np.ndarray:
        """Signal ``name``: the sum, in stamped order, of its rows' weighted unknowns."""
        return output_values(signal_terms(mlcs, rows[name]), states, currents)

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
                     stats=stats, events=trajectory.events[bisect.bisect_left(
                         trajectory.events, trajectory.time[first], key=event_time):])
