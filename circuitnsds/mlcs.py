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
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from circuitnsds.stimuli import Stimulus


@dataclass
class MLCS:
    """Matrices and names of a circuit's complementarity system (see module docstring)."""

    E: sp.csr_matrix
    A: sp.csr_matrix
    B: sp.csr_matrix
    C: sp.csr_matrix
    D: sp.csr_matrix
    e: np.ndarray
    S: sp.csr_matrix
    stimuli: list[Stimulus]
    unknowns: list[str]
    pairs: list[str]
    pair_devices: list[str]
    output_names: list[str]
    Y_out: sp.csr_matrix
    L_out: sp.csr_matrix
    nodes: list[str] = field(default_factory=list)

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
        return np.asarray(abs(self.E).sum(axis=1)).ravel() > 0

    def source(self, t: float) -> np.ndarray:
        """``s(t)`` [A on node rows, V on source rows]."""
        if not self.stimuli:
            return np.zeros(self.n)
        return self.S @ np.array([stimulus.value(t) for stimulus in self.stimuli])

    def breakpoints(self, stop: float) -> np.ndarray:
        """Sorted instants in ``(0, stop)`` where a source's slope jumps."""
        points: set[float] = set()
        for stimulus in self.stimuli:
            points.update(stimulus.breakpoints(stop))
        return np.array(sorted(points))

    def outputs(self, y: np.ndarray, current: np.ndarray) -> np.ndarray:
        """Output signals for states ``y`` and pair currents ``current`` (rows = time points)."""
        return y @ self.Y_out.T + current @ self.L_out.T

    def save(self, path: str | Path) -> None:
        """Write every matrix and name to a ``.npz`` file (dense arrays, readable with numpy)."""
        arrays = {name: getattr(self, name).toarray() for name in ("E", "A", "B", "C", "D", "S")}
        np.savez(
            path,
            **arrays,
            e=self.e,
            unknowns=np.array(self.unknowns),
            pairs=np.array(self.pairs),
        )

    def __str__(self) -> str:
        lines = [
            f"MLCS: n = {self.n} unknowns, m = {self.m} complementarity pairs, "
            f"{len(self.stimuli)} sources",
            "  E y' = A y + B λ + s(t);  w = C y + D λ + e;  0 <= w ⊥ λ >= 0",
            f"  unknowns: {', '.join(self.unknowns)}",
            f"  pairs:    {', '.join(self.pairs) if self.pairs else '(none)'}",
            f"  differential rows: {int(self.differential_rows.sum())} of {self.n}",
        ]
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
        self.pairs: list[str] = []
        self.pair_devices: list[str] = []
        self.e: list[float] = []
        self.stimuli: list[Stimulus] = []
        self._triplets: dict[str, list[tuple[int, int, float]]] = {
            key: [] for key in ("E", "A", "B", "C", "D", "S")
        }
        self._outputs: list[tuple[str, list[tuple[int, float]], list[tuple[int, float]]]] = []

    def node(self, name: str) -> int:
        """Row/column of a node's voltage (``-1`` for ground)."""
        return self._node_index.get(name, self.GROUND)

    def branch(self, name: str) -> int:
        """Allocate a branch-current unknown named ``name`` (e.g. ``i(l1)``)."""
        self.unknowns.append(name)
        return len(self.unknowns) - 1

    def pair(self, name: str, device: str, offset: float) -> int:
        """Allocate a complementarity pair with constant term ``e = offset`` [V]."""
        self.pairs.append(name)
        self.pair_devices.append(device)
        self.e.append(offset)
        return len(self.pairs) - 1

    def stimulus(self, function: Stimulus) -> int:
        """Register a source time function; returns its column in ``S``."""
        self.stimuli.append(function)
        return len(self.stimuli) - 1

    def add(self, matrix: str, row: int, col: int, value: float) -> None:
        """Add ``value`` at ``(row, col)`` of ``matrix`` (one of E A B C D S); ground is skipped."""
        if row == self.GROUND or col == self.GROUND or value == 0.0:
            return
        self._triplets[matrix].append((row, col, value))

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

        def assemble(key: str) -> sp.csr_matrix:
            entries = self._triplets[key]
            rows = [r for r, _, _ in entries]
            cols = [c for _, c, _ in entries]
            vals = [v for _, _, v in entries]
            return sp.csr_matrix((vals, (rows, cols)), shape=shapes[key], dtype=float)

        node_outputs = [(u, [(i, 1.0)], []) for i, u in enumerate(self.unknowns[: len(self.nodes)])]
        outputs = node_outputs + self._outputs
        y_out = sp.lil_matrix((len(outputs), n))
        l_out = sp.lil_matrix((len(outputs), m))
        for row, (_, y_terms, pair_terms) in enumerate(outputs):
            for col, coefficient in y_terms:
                y_out[row, col] += coefficient
            for col, coefficient in pair_terms:
                l_out[row, col] += coefficient
        return MLCS(
            E=assemble("E"), A=assemble("A"), B=assemble("B"), C=assemble("C"),
            D=assemble("D"), e=np.array(self.e, dtype=float), S=assemble("S"),
            stimuli=list(self.stimuli), unknowns=list(self.unknowns), pairs=list(self.pairs),
            pair_devices=list(self.pair_devices),
            output_names=[name for name, _, _ in outputs],
            Y_out=y_out.tocsr(), L_out=l_out.tocsr(), nodes=list(self.nodes),
        )
