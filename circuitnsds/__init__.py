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

import importlib
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from circuitnsds import (
    _blas,  # noqa: F401  (first: before numpy is imported)
    compare,  # the subpackage; called, it is compare.api.compare (imported then)
)
from circuitnsds.errors import (
    CircuitError,
    CircuitnsdsError,
    CircuitWarning,
    NetlistError,
    NetlistWarning,
    SimulationError,
)

if TYPE_CHECKING:
    from circuitnsds.circuit.circuit import Circuit  # noqa: F401
    from circuitnsds.output import measure  # noqa: F401
    from circuitnsds.output.waveforms import Waveforms  # noqa: F401
    from circuitnsds.specs import AcSpec, PssSpec, SourceDefaults, TransientSpec, TranSpec  # noqa: F401
    from circuitnsds.system.mlcs import MLCS  # noqa: F401

_LAZY = {"Circuit": "circuitnsds.circuit.circuit", "Waveforms": "circuitnsds.output.waveforms",
         "MLCS": "circuitnsds.system.mlcs", "AcSpec": "circuitnsds.specs", "PssSpec": "circuitnsds.specs",
         "SourceDefaults": "circuitnsds.specs", "TransientSpec": "circuitnsds.specs",
         "TranSpec": "circuitnsds.specs"}
"""Public names imported on first use (PEP 562), so that ``import circuitnsds`` and the
command line's start (``--help``, argument errors, starting the figure's process) do not
wait for numpy and the circuit modules."""


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
    elif name == "measure":
        value = importlib.import_module("circuitnsds.output.measure")
    else:  # a subpackage or module not imported yet (circuitnsds.values, circuitnsds.units, ...)
        try:
            value = importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    globals()[name] = value
    return value


__version__ = "0.1.0"


def read_netlist(source: str | Path, *, params: Mapping[str, float] | None = None,
                 random=None, strict: bool = False,
                 options: dict[str, float | str] | None = None) -> Circuit:
    """Read a netlist file (a path) or netlist text (a string with a newline) into a Circuit.

    Includes, parameters and subcircuits are expanded first (``.include`` paths in text
    are relative to the current directory). To build many circuits from one netlist
    (a sweep), read it once with :class:`circuitnsds.frontend.build.CircuitBuilder`.

    Args:
        source: a path, or netlist text.
        params: parameter values replacing the netlist's ``.param`` definitions
            (``{"D": 0.4}``; names case-insensitive), also those written in subcircuit
            bodies; a name the netlist does not use is warned about. Parameters stepped by
            ``.step`` lines and not given take their first value (with a warning).
        random: a ``numpy.random.Generator`` for the Monte Carlo functions (``agauss``,
            ``mc``, ...); default: point 0 of ``.options seed`` (else seed 1), see
            :func:`circuitnsds.netlist.steps.point_generator`.
        strict: every warning (an ignored construct here, a suspicious circuit later when
            the circuit is stamped or simulated) is an error instead (``Circuit.strict``).
        options: ``.options`` values that override the netlist's, e.g. ``{"diode": "ideal"}``.

    Raises:
        NetlistError: malformed or unsupported input, with file:line (under ``strict``
            also for what would be a :class:`NetlistWarning`).
    """
    from contextlib import nullcontext

    from circuitnsds.errors import strict_warnings
    from circuitnsds.frontend.build import CircuitBuilder

    with strict_warnings() if strict else nullcontext():
        builder = CircuitBuilder.load(source)
    return builder.build(params, random, strict=strict, options=options)


def sweep(netlist, params=None, **options):
    """Run a netlist at many parameter values; see :func:`circuitnsds.sweeps.api.sweep`."""
    from circuitnsds.sweeps.api import sweep as run

    return run(netlist, params, **options)


__all__ = [
    "MLCS", "AcSpec", "Circuit", "CircuitError", "CircuitWarning", "CircuitnsdsError", "NetlistError",
    "NetlistWarning", "PssSpec", "SimulationError", "SourceDefaults", "TransientSpec", "TranSpec",
    "Waveforms", "compare", "measure", "read_netlist", "sweep",
]
