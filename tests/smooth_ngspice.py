"""Helpers of the smooth devices' tests: ngspice 39's DC answer for a one-device netlist, and
the terminal currents of a device of ours at the same terminal voltages.

ngspice runs in batch mode (``ngspice -b``) on the netlist with a ``.dc`` sweep, writing the
node voltages and source currents it names to a file with 15 digits (``wrdata``).
"""

from __future__ import annotations

import subprocess
import tempfile
from pathlib import Path

import numpy as np

from tests.conftest import circuit_from

TIGHT = "reltol=1e-10 vntol=1e-14 abstol=1e-18 itl2=500"
"""ngspice's Newton tolerances, tightened so that the internal nodes it solves for carry no
error at the 1e-6 level (its defaults stop at ``reltol=1e-3`` of the node voltages)."""


def ngspice_dc(netlist: str, sweep: str, vectors: list[str],
               options: str = TIGHT) -> dict[str, np.ndarray]:
    """Run ngspice on ``netlist`` (elements and models, no title or ``.end``) with ``.dc sweep``
    and ``.options`` (:data:`TIGHT` tolerances by default); return each of ``vectors``
    (``v(b)``, ``i(vc)``: ngspice's names) over the sweep."""
    with tempfile.TemporaryDirectory(prefix="devices_ngspice_") as folder:
        data = Path(folder) / "dc.txt"
        deck = Path(folder) / "dc.cir"
        deck.write_text(
            f"one device\n{netlist}\n.options {options}\n.dc {sweep}\n.control\n"
            "set wr_singlescale\nset wr_vecnames\noption numdgt=15\nrun\n"
            f"wrdata {data} {' '.join(vectors)}\n.endc\n.end\n")
        run = subprocess.run(["ngspice", "-b", str(deck)], capture_output=True, text=True,
                             timeout=60)
        assert data.exists(), f"ngspice wrote nothing:\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}"
        table = np.loadtxt(data, skiprows=1, ndmin=2)
    return {name: table[:, k + 1] for k, name in enumerate(vectors)}


def relation_of(netlist: str, name: str):
    """The smooth relation of element ``name`` and the unknowns' names of the circuit."""
    mlcs = circuit_from(netlist).mlcs()
    relation = next(r for r in mlcs.smooth if r.name == name)
    return relation, mlcs.unknowns


def terminal_currents(relation, unknowns: list[str], voltages: dict[str, float],
                      tol: float = 1e-13) -> dict[str, float]:
    """Currents [A] into the device at each node of ``voltages`` (``v(c)``: volts), the
    internal nodes (unknowns not in ``voltages``) solved by Newton on Kirchhoff's law there
    with the relation's own Jacobian and limiting (SPICE's), linear series resistances
    included through the terminal rows: returns ``{node: current leaving the node into the device}``."""
    inputs = list(relation.inputs)
    names = [unknowns[k] for k in inputs]
    fixed = np.array([name in voltages for name in names])
    x = np.array([voltages.get(name, 0.0) for name in names])
    free = ~fixed
    for _ in range(200):
        f, jacobian, _, _ = relation.evaluate(x, 0.0)
        if not free.any():
            break
        residual = f[free]
        step = np.linalg.solve(jacobian[np.ix_(free, free)], -residual)
        proposed = x.copy()
        proposed[free] += step
        x = relation.limit(proposed, x) if relation.limit is not None else proposed
        x[fixed] = proposed[fixed]  # limiting may move a terminal: the sources hold them
        if np.max(np.abs(step)) < tol:
            break
    f = relation.evaluate(x, 0.0)[0]
    return {name: float(f[k]) for k, name in enumerate(names) if name in voltages}
