"""Refusing, before it starts, a run whose results cannot fit in memory."""

from __future__ import annotations

import os

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.errors import CircuitError

MEMORY_SHARE = 0.8
"""A run may plan to use at most this share of the memory available when it starts."""


def available_memory() -> int | None:
    """Memory the system can give this process now [bytes] (Linux's ``MemAvailable``, else the
    free physical pages), or ``None`` when unknown."""
    try:
        with open("/proc/meminfo") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def refuse_beyond_memory(needed: int, what: str, sizes: str, circuit: Circuit, hint: str) -> None:
    """Raise :class:`CircuitError` when ``what`` would need more than :data:`MEMORY_SHARE`
    of the memory available: ``needed`` [bytes], estimated from ``sizes`` (words for the
    message). Nothing when the memory available is unknown."""
    available = available_memory()
    if available is None or needed <= MEMORY_SHARE * available:
        return
    raise CircuitError(f"{what} would take {needed / 2**30:.3g} GiB ({sizes}), more than the "
                       f"{available / 2**30:.3g} GiB of memory available", where=circuit.file, hint=hint)
