"""circuitnsds: transient simulation of circuits with ideal diodes, Zeners and switches.

Each device is a complementarity pair; modified nodal analysis gives a mixed
linear complementarity system, integrated by the θ-method with one MLCP per
step. See ``docs/`` for the netlist dialect and the mathematics.

Typical use::

    import circuitnsds
    circuit = circuitnsds.read_netlist("netlists/bridge_rectifier.cir")
    waves = circuit.transient()          # .tran from the netlist
    waves["v(out)"]
"""

from __future__ import annotations

from pathlib import Path

from circuitnsds import _blas  # noqa: F401  (first: before numpy is imported)
from circuitnsds.circuit.circuit import Circuit, TranSpec
from circuitnsds.compare import compare  # the function; the subpackage stays importable by name
from circuitnsds.errors import (
    CircuitError,
    CircuitnsdsError,
    CircuitWarning,
    NetlistError,
    NetlistWarning,
    SimulationError,
)
from circuitnsds.output import measure
from circuitnsds.output.waveforms import Waveforms
from circuitnsds.system.mlcs import MLCS

__version__ = "0.1.0"


def read_netlist(source: str | Path, *, strict: bool = False,
                 options: dict[str, float | str] | None = None) -> Circuit:
    """Read a netlist file (a path) or netlist text (a string with a newline) into a Circuit.

    Includes, parameters and subcircuits are expanded first (``.include`` paths in text
    are relative to the current directory).

    Args:
        source: a path, or netlist text.
        strict: every warning (an ignored construct here, a suspicious circuit later when
            the circuit is stamped or simulated) is an error instead (``Circuit.strict``).
        options: ``.options`` values that override the netlist's, e.g. ``{"diode": "ideal"}``.

    Raises:
        NetlistError: malformed or unsupported input, with file:line (under ``strict``
            also for what would be a :class:`NetlistWarning`).
    """
    from contextlib import nullcontext

    from circuitnsds.errors import strict_warnings
    from circuitnsds.frontend.elaborate import elaborate
    from circuitnsds.netlist import load_netlist, load_netlist_text

    with strict_warnings() if strict else nullcontext():
        if isinstance(source, Path) or "\n" not in source:
            circuit = elaborate(load_netlist(source), options)
        else:
            circuit = elaborate(load_netlist_text(source), options)
    circuit.strict = strict
    return circuit


__all__ = [
    "MLCS", "Circuit", "CircuitError", "CircuitWarning", "CircuitnsdsError", "NetlistError",
    "NetlistWarning",
    "SimulationError", "TranSpec", "Waveforms", "compare", "measure", "read_netlist",
]
