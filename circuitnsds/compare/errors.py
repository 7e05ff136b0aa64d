"""Errors of the ngspice comparison (all derive from :class:`circuitnsds.CircuitnsdsError`)."""

from __future__ import annotations

from circuitnsds.errors import CircuitnsdsError

INSTALL_HINT = (
    "install ngspice's shared library and PySpice: "
    "sudo apt-get install ngspice libngspice0-dev && python -m pip install 'circuitnsds[ngspice]' "
    "(the -dev package provides the libngspice.so that PySpice opens; elsewhere set "
    "NGSPICE_LIBRARY_PATH to the library file)"
)


class CompareError(CircuitnsdsError):
    """Bad options of a comparison (signals, window, model overrides)."""


class NgspiceUnavailable(CompareError):
    """PySpice or ngspice's shared library is missing; the hint says how to install them."""
