"""The mixed linear complementarity system (MLCS) of a circuit, as plain data.

Modified nodal analysis turns a circuit with ideal devices into

    E y' = A y + B λ + s(t)
    w    = C y + D λ + e,            0 <= w ⊥ λ >= 0

* ``y`` (length ``n``): node voltages [V] (every node but ground), then branch
  currents [A] of inductors and voltage sources (``unknowns`` names them:
  ``v(out)``, ``i(l1)``, ``i(v1)``).
* ``λ`` (length ``m``): one current [A] per complementarity pair (``pairs``
  names them: ``d1``; a Zener has ``dz1.forward`` and ``dz1.reverse``).
* Row ``r`` of the first equation is Kirchhoff's current law at node ``r``
  (sum of currents *into* the node, capacitor currents on the left) or the
  branch equation of an inductor (``L i' = v+ - v-``) or voltage source
  (``0 = v+ - v- - V(t)``).
* ``s(t) = S @ [f_1(t), ..., f_k(t)]``: the independent sources' time
  functions ``stimuli`` and their incidence ``S``.
* ``w`` is the device's distance from its constraint [V]: for a diode
  ``Ron·i + Vfwd - v``; ``λ`` is the device current [A].

Outputs (``output_names``) are linear in ``y`` and ``λ``:
``outputs = Y_out @ y + L_out @ λ``.

Ideal switches (``switches``) are not complementarity pairs: each owns one
row of ``A`` whose entries depend on its state, open or closed (an exogenous
mode set by its control, see :class:`SwitchRelation`). ``A`` holds every
switch's *open* row; :meth:`MLCS.system_matrix` gives ``A`` for any states.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from circuitnsds.arrays import sorted_unique
from circuitnsds.errors import CircuitError
from circuitnsds.system.smooth import SmoothRelation
from circuitnsds.system.stimuli import Stimulus, breakpoint_bound, threshold_crossings
from circuitnsds.system.triplets import Triplets

Row = tuple[tuple[int, float], ...]
"""Sparse row: ``((column, value), ...)``."""


@dataclass(frozen=True)
class SwitchRelation:
    """One ideal switch as the MLCS sees it.

    Attributes:
        name: element name (``s1``).
        row: index of the switch's branch equation, which is also the index of
            its current unknown ``i(name)`` (flowing from ``n+`` to ``n-`` through it).
        open_row, closed_row: the entries of ``A[row]`` in each state
            (``0 = Goff·(v+ - v-) - i`` open, ``0 = v+ - v- - Ron·i`` closed).
        control: the control quantity as a row over ``y`` (``v(nc+) - v(nc-)`` [V]
            for ``S``, the current of the controlling source [A] for ``W``).
        control_stimulus: ``(column of S, sign)`` when the control is exactly a
            source's time function (a voltage source across the control nodes);
            such switches change state exactly when the source crosses a threshold.
        on_threshold: the switch closes when the control exceeds it (``VT + |VH|``).
        off_threshold: the switch opens when the control falls below it (``VT - |VH|``).
        initially_on: the ``ON`` flag of the instance (state before the operating point).
        crossing: the level whose crossings by a source-driven control are put on the time
            grid when it differs from both thresholds (``VT`` of a switch without hysteresis,
            whose thresholds sit a round-off margin above it); ``None`` otherwise.
    """

    name: str
    row: int
    open_row: Row
    closed_row: Row
    control: Row
    control_stimulus: tuple[int, float] | None
    on_threshold: float
    off_threshold: float
    initially_on: bool = False
    crossing: float | None = None

    def next_state(self, on: bool, control: float) -> bool:
        """State after seeing ``control``: hysteresis keeps ``on`` between the thresholds."""
        if control > self.on_threshold:
            return True
        if control < self.off_threshold:
            return False
        return on

    def control_value(self, y: np.ndarray) -> float:
        """The control quantity for MNA unknowns ``y``."""
        return float(sum(value * y[column] for column, value in self.control))


MAX_BREAKPOINTS = 50_000_000
"""Refuse more source breakpoints than this (each is a grid point; the time grid's own
limit, :data:`circuitnsds.engine.timegrid.MAX_POINTS`, is the same)."""


@dataclass
class MLCS:
    """Matrices and names of a circuit's complementarity system (see module docstring)."""

    E: Triplets
    A: Triplets
    B: Triplets
    C: Triplets
    D: Triplets
    e: np.ndarray
    S: Triplets
    stimuli: list[Stimulus]
    unknowns: list[str]
    pairs: list[str]
    pair_devices: list[str]
    output_names: list[str]
    Y_out: Triplets
    L_out: Triplets
    nodes: list[str] = field(default_factory=list)
    switches: list[SwitchRelation] = field(default_factory=list)
    pair_signs: np.ndarray | None = None
    """``(m,)``: +1 when the pair's current flows in its device's positive direction (a
    diode's forward pair), -1 when against it (a Zener's reverse pair); the device's
    current or impulse is the signed sum over its pairs. Default: all +1."""
    stimulus_owners: list[str] = field(default_factory=list)
    """The element (source) name of each column of ``S`` ("" when unnamed)."""
    smooth: list[SmoothRelation] = field(default_factory=list)
    """Smooth nonlinear relations (:mod:`circuitnsds.system.smooth`); empty for a circuit of
    ideal devices, which the affine steppers integrate."""

    def __post_init__(self) -> None:
        if self.pair_signs is None:
            self.pair_signs = np.ones(len(self.pairs))
        self.pair_signs = np.asarray(self.pair_signs, dtype=float)

    def stimulus_column(self, owner: str) -> int:
        """The column of ``S`` (and of ``stimuli``) of the source called ``owner`` (any case)."""
        try:
            return self.stimulus_owners.index(owner.lower())
        except ValueError:
            raise KeyError(owner) from None

    @property
    def n(self) -> int:
        """Number of MNA unknowns."""
        return self.A.shape[0]

    @property
    def m(self) -> int:
        """Number of complementarity pairs."""
        return self.D.shape[0]

    @property
    def differential_rows(self) -> np.ndarray:
        """Boolean mask of the rows of ``E y' = ...`` that carry a time derivative."""
        return np.bincount(self.E.rows, weights=np.abs(self.E.values), minlength=self.n) > 0

    def source(self, t: float) -> np.ndarray:
        """``s(t)`` [A on node rows, V on source rows]."""
        if not self.stimuli:
            return np.zeros(self.n)
        return self.S @ np.array([stimulus.value(t) for stimulus in self.stimuli])

    def breakpoint_bound(self, stop: float) -> float:
        """At most how many instants :meth:`breakpoints` gives, found without listing them."""
        bound = sum(breakpoint_bound(stimulus, stop) for stimulus in self.stimuli)
        for switch in self.switches:  # a linear piece crosses a level at most once
            if switch.control_stimulus is not None:
                levels = 1 if switch.crossing is not None else 2
                bound += levels * breakpoint_bound(self.stimuli[switch.control_stimulus[0]], stop)
        return bound

    def breakpoints(self, stop: float) -> np.ndarray:
        """Sorted instants in ``(0, stop)`` where a source's slope jumps or a source-driven
        switch changes state (so that both fall on the time grid).

        Raises:
            CircuitError: more than :data:`MAX_BREAKPOINTS` of them (counted first: listing
                them would fill the memory).
        """
        bound = self.breakpoint_bound(stop)
        if bound > MAX_BREAKPOINTS:
            counts = [breakpoint_bound(stimulus, stop) for stimulus in self.stimuli]
            busiest = (self.stimulus_owners[int(np.argmax(counts))]
                       if counts and len(self.stimulus_owners) == len(counts) else "")
            raise CircuitError(f"the sources have up to {bound:.3g} breakpoints (corners) before "
                               f"{stop:.4g} s (limit {MAX_BREAKPOINTS:.0e})"
                               + (f", most of them {busiest}'s" if busiest else ""),
                               where=busiest or None, hint="check the units of the source's period "
                               "and of TSTOP (a 10 µs PULSE over 100 s has 4e7 corners)")
        points = [np.asarray(stimulus.breakpoints(stop), dtype=float) for stimulus in self.stimuli]
        for switch in self.switches:
            if switch.control_stimulus is not None:
                column, sign = switch.control_stimulus
                levels = ({switch.crossing} if switch.crossing is not None
                          else {switch.on_threshold, switch.off_threshold})
                for level in levels:
                    points.append(np.asarray(threshold_crossings(self.stimuli[column], sign * level,
                                                                 stop), dtype=float))
        return sorted_unique(np.concatenate([np.zeros(0), *points]))  # sorted, each instant once

    def system_matrix(self, closed: tuple[bool, ...] = ()) -> Triplets:
        """``A`` with switch ``j`` closed where ``closed[j]`` is true (open elsewhere): the
        entries of each closed switch's ``open_row`` give way to its ``closed_row``."""
        if not any(closed):
            return self.A
        A = self.A
        replaced = np.zeros(A.nnz, dtype=bool)
        stamps = []
        for switch, on in zip(self.switches, closed):
            if on:
                columns = [column for column, _ in switch.open_row + switch.closed_row]
                replaced |= (A.rows == switch.row) & np.isin(A.cols, columns)
                stamps += [(switch.row, column, value) for column, value in switch.closed_row]
        kept = ~replaced
        stamps += list(zip(A.rows[kept].tolist(), A.cols[kept].tolist(), A.values[kept].tolist()))
        return Triplets.from_stamps(stamps, A.shape)

    def outputs(self, y: np.ndarray, current: np.ndarray) -> np.ndarray:
        """Output signals for states ``y`` and pair currents ``current`` (rows = time points)."""
        return (self.Y_out @ np.asarray(y).T + self.L_out @ np.asarray(current).T).T

    def save(self, path: str | Path) -> None:
        """Write every matrix and name to a ``.npz`` file (dense arrays, readable with numpy)
        named exactly ``path`` (numpy's own ``savez`` would append ``.npz`` to another name)."""
        arrays = {name: getattr(self, name).toarray() for name in ("E", "A", "B", "C", "D", "S")}
        with open(path, "wb") as file:
            np.savez(file, **arrays, e=self.e, unknowns=np.array(self.unknowns),
                     pairs=np.array(self.pairs))

    def __str__(self) -> str:
        lines = [
            f"MLCS: n = {self.n} unknowns, m = {self.m} complementarity pairs, "
            f"{len(self.stimuli)} sources",
            "  E y' = A y + B λ + s(t);  w = C y + D λ + e;  0 <= w ⊥ λ >= 0",
            f"  unknowns: {', '.join(self.unknowns)}",
            f"  pairs:    {', '.join(self.pairs) if self.pairs else '(none)'}",
            f"  differential rows: {int(self.differential_rows.sum())} of {self.n}",
        ]
        if self.switches:
            lines.append(f"  switches: {', '.join(s.name for s in self.switches)}")
        return "\n".join(lines)


class MLCSBuilder:
    """Collects the stamps of the elements, then freezes them into an :class:`MLCS`.

    Node indices are fixed when the builder is created; branch currents and
    complementarity pairs are allocated on demand by the elements that need them.
    Index ``-1`` is ground: stamps on it are dropped.
    """

    GROUND = -1

    def __init__(self, nodes: list[str]):
        self.nodes = list(nodes)
        self._node_index = {name: k for k, name in enumerate(self.nodes)}
        self.unknowns = [f"v({name})" for name in self.nodes]
        self._branch_index: dict[str, int] = {}
        self.pairs: list[str] = []
        self.pair_devices: list[str] = []
        self.pair_signs: list[float] = []
        self.e: list[float] = []
        self.stimuli: list[Stimulus] = []
        self.stimulus_owners: list[str] = []
        self._triplets: dict[str, list[tuple[int, int, float]]] = {
            key: [] for key in ("E", "A", "B", "C", "D", "S")
        }
        self._outputs: list[tuple[str, list[tuple[int, float]], list[tuple[int, float]]]] = []
        self._switches: list[tuple[dict, tuple[int, int] | None]] = []
        self._source_columns: dict[tuple[int, int], int] = {}
        self._smooth: list[SmoothRelation] = []

    def node(self, name: str) -> int:
        """Row/column of a node's voltage (``-1`` for ground)."""
        return self._node_index.get(name, self.GROUND)

    def branch(self, name: str) -> int:
        """The branch-current unknown named ``name`` (e.g. ``i(l1)``), allocated on first use.

        An element that refers to another's current (``F``, ``H``, ``K``, ``W``)
        gets the same index as the element that owns it, whichever is stamped first.
        """
        if name in self._branch_index:
            return self._branch_index[name]
        self.unknowns.append(name)
        self._branch_index[name] = len(self.unknowns) - 1
        return self._branch_index[name]

    def voltage_source_stimulus(self, plus: int, minus: int, column: int) -> None:
        """Record that a voltage source imposes stimulus ``column`` between two nodes."""
        self._source_columns.setdefault((plus, minus), column)

    def switch(self, relation: dict, control_nodes: tuple[int, int] | None = None) -> None:
        """Register a switch: the fields of :class:`SwitchRelation`; without ``control_stimulus``
        it is found at :meth:`build` from ``control_nodes`` if a voltage source sits across them
        (an element switched by its own time function gives the stimulus's column itself)."""
        self._switches.append((relation, control_nodes))

    def smooth(self, relation: SmoothRelation) -> None:
        """Add a smooth nonlinear relation (:mod:`circuitnsds.system.smooth`)."""
        self._smooth.append(relation)

    def pair(self, name: str, device: str, offset: float, sign: float = 1.0) -> int:
        """Allocate a complementarity pair of ``device`` with constant term ``e = offset`` [V];
        ``sign`` -1 when its current flows against the device's positive direction."""
        self.pairs.append(name)
        self.pair_devices.append(device)
        self.pair_signs.append(float(sign))
        self.e.append(offset)
        return len(self.pairs) - 1

    def stimulus(self, function: Stimulus, owner: str = "") -> int:
        """Register a source time function (of the element ``owner``); returns its column in ``S``."""
        self.stimuli.append(function)
        self.stimulus_owners.append(owner.lower())
        return len(self.stimuli) - 1

    def add(self, matrix: str, row: int, col: int, value: float) -> None:
        """Add ``value`` at ``(row, col)`` of ``matrix`` (one of E A B C D S); ground is skipped."""
        if row == self.GROUND or col == self.GROUND or value == 0.0:
            return
        self._triplets[matrix].append((row, col, value))

    def stamped_values(self) -> list[float]:
        """Every value stamped so far, in all matrices and in ``e`` (to check that they are finite)."""
        return [value for triplets in self._triplets.values() for _, _, value in triplets] + self.e

    def add_conductance(self, matrix: str, a: int, b: int, value: float) -> None:
        """Stamp the two-terminal pattern ``+value`` on the diagonal, ``-value`` off it.

        With ``matrix="E"`` and a capacitance this is a capacitor; with
        ``matrix="A"`` and ``-G`` it is a conductance.
        """
        self.add(matrix, a, a, value)
        self.add(matrix, b, b, value)
        self.add(matrix, a, b, -value)
        self.add(matrix, b, a, -value)

    def output(self, name: str, y_terms: list[tuple[int, float]],
               pair_terms: list[tuple[int, float]] = ()) -> None:
        """Declare an output signal ``sum(c*y[k]) + sum(c*λ[j])``."""
        self._outputs.append((name, [t for t in y_terms if t[0] != self.GROUND], list(pair_terms)))

    def build(self) -> MLCS:
        n, m, k = len(self.unknowns), len(self.pairs), len(self.stimuli)
        shapes = {"E": (n, n), "A": (n, n), "B": (n, m), "C": (m, n), "D": (m, m), "S": (n, k)}

        def assemble(key: str) -> Triplets:
            return Triplets.from_stamps(self._triplets[key], shapes[key])

        node_outputs = [(u, [(i, 1.0)], []) for i, u in enumerate(self.unknowns[: len(self.nodes)])]
        outputs = node_outputs + self._outputs
        y_out = [(row, col, c) for row, (_, y_terms, _) in enumerate(outputs) for col, c in y_terms]
        l_out = [(row, col, c) for row, (_, _, pair_terms) in enumerate(outputs) for col, c in pair_terms]
        switches = []
        for relation, control_nodes in self._switches:
            relation = dict(relation)
            stimulus = relation.pop("control_stimulus", None)
            if stimulus is None and control_nodes is not None:
                plus, minus = control_nodes
                if (plus, minus) in self._source_columns:
                    stimulus = (self._source_columns[plus, minus], 1.0)
                elif (minus, plus) in self._source_columns:
                    stimulus = (self._source_columns[minus, plus], -1.0)
            switches.append(SwitchRelation(**relation, control_stimulus=stimulus))
        return MLCS(
            E=assemble("E"), A=assemble("A"), B=assemble("B"), C=assemble("C"),
            D=assemble("D"), e=np.array(self.e, dtype=float), S=assemble("S"),
            stimuli=list(self.stimuli), unknowns=list(self.unknowns), pairs=list(self.pairs),
            pair_devices=list(self.pair_devices), pair_signs=np.array(self.pair_signs, dtype=float),
            output_names=[name for name, _, _ in outputs],
            Y_out=Triplets.from_stamps(y_out, (len(outputs), n)),
            L_out=Triplets.from_stamps(l_out, (len(outputs), m)), nodes=list(self.nodes),
            switches=switches, stimulus_owners=list(self.stimulus_owners),
            smooth=list(self._smooth),
        )
