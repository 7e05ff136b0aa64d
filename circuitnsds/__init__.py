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

from circuitnsds.circuit import Circuit, TranSpec
from circuitnsds.errors import (
    CircuitError,
    CircuitnsdsError,
    NetlistError,
    NetlistWarning,
    SimulationError,
)
from circuitnsds.mlcs import MLCS
from circuitnsds.waveforms import Waveforms

__version__ = "0.1.0"


def read_netlist(source: str | Path) -> Circuit:
    """Read a netlist file (a path) or netlist text (a string with a newline) into a Circuit.

    Raises:
        NetlistError: malformed or unsupported input, with file:line.
    """
    from circuitnsds.elaborate import elaborate
    from circuitnsds.netlist import parse_netlist, read_netlist_file

    if isinstance(source, Path) or "\n" not in source:
        return elaborate(read_netlist_file(source))
    return elaborate(parse_netlist(source))


__all__ = [
    "MLCS", "Circuit", "CircuitError", "CircuitnsdsError", "NetlistError", "NetlistWarning",
    "SimulationError", "TranSpec", "Waveforms", "read_netlist",
]
