"""How much more memory this process may use, from every limit that applies to it, and the
refusal, before it starts, of a run whose results cannot fit in it.

Three limits, the smallest wins:

* the system's: Linux's ``MemAvailable`` (else the free physical pages);
* the process's address space, ``RLIMIT_AS`` (``ulimit -v``), less what is mapped now
  (``VmSize`` of ``/proc/self/status``): past it every allocation fails, however much
  memory the machine has;
* the control group's (containers, systemd units, batch schedulers): cgroup v2
  ``memory.max`` less ``memory.current``, or cgroup v1 ``memory.limit_in_bytes`` less
  ``memory.usage_in_bytes``, for the process's group and each group above it.

Each reader returns ``None`` when its limit is absent or unreadable.
"""

from __future__ import annotations

import os
import resource
from pathlib import Path

from circuitnsds.circuit.circuit import Circuit
from circuitnsds.errors import CircuitError

CGROUP_ROOT = Path("/sys/fs/cgroup")
"""Where the control groups are mounted (cgroup v2, or v1's ``memory`` controller below it)."""
UNLIMITED_V1 = 2**60
"""cgroup v1 writes "no limit" as a huge number (``9223372036854771712``): above this, none."""


def system_available() -> int | None:
    """``MemAvailable`` [bytes], else the free physical pages, else ``None``."""
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


def address_space_left() -> int | None:
    """``RLIMIT_AS`` less the address space mapped now [bytes] (0 when already above), or
    ``None`` without a limit."""
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY:
        return None
    mapped = 0
    try:
        with open("/proc/self/status") as handle:
            for line in handle:
                if line.startswith("VmSize:"):
                    mapped = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    return max(soft - mapped, 0)


def _read_number(path: Path) -> int | None:
    try:
        text = path.read_text().strip()
    except OSError:
        return None
    if text == "max":
        return None
    try:
        return int(text)
    except ValueError:
        return None


def cgroup_left(root: Path = CGROUP_ROOT, membership: str | None = None) -> int | None:
    """The smallest ``limit - usage`` [bytes] over the process's control group and the
    groups above it, or ``None`` without a memory limit.

    Args:
        root: the cgroup mount point (tests give a folder of their own).
        membership: the text of ``/proc/self/cgroup`` (default: read it).
    """
    if membership is None:
        try:
            membership = Path("/proc/self/cgroup").read_text()
        except OSError:
            return None
    left = None
    for line in membership.splitlines():
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        hierarchy, controllers, group = parts
        if hierarchy == "0" and controllers == "":  # v2: the unified hierarchy
            base, names = root, ("memory.max", "memory.current")
        elif "memory" in controllers.split(","):  # v1: the memory controller's own tree
            base, names = root / "memory", ("memory.limit_in_bytes", "memory.usage_in_bytes")
        else:
            continue
        folder = base / group.strip("/")
        while True:
            limit, usage = _read_number(folder / names[0]), _read_number(folder / names[1])
            if limit is not None and limit < UNLIMITED_V1:
                here = max(limit - (usage or 0), 0)
                left = here if left is None else min(left, here)
            if folder == base or base not in folder.parents:
                break
            folder = folder.parent
    return left


def available_memory() -> int | None:
    """Memory this process may still use [bytes]: the smallest of :func:`system_available`,
    :func:`address_space_left` and :func:`cgroup_left`, or ``None`` when none is known."""
    known = [value for value in (system_available(), address_space_left(), cgroup_left())
             if value is not None]
    return min(known) if known else None


MEMORY_SHARE = 0.8
"""A run may plan to use at most this share of the memory available when it starts."""


def refuse_beyond_memory(needed: int, what: str, sizes: str, circuit: Circuit, hint: str) -> None:
    """Raise :class:`CircuitError` when ``what`` would need more than :data:`MEMORY_SHARE`
    of the memory available: ``needed`` [bytes], estimated from ``sizes`` (words for the
    message). Nothing when the memory available is unknown."""
    available = available_memory()
    if available is None or needed <= MEMORY_SHARE * available:
        return
    raise CircuitError(f"{what} would take {needed / 2**30:.3g} GiB ({sizes}), more than the "
                       f"{available / 2**30:.3g} GiB of memory available (the least of the system's, "
                       "ulimit -v's and the control group's)", where=circuit.file, hint=hint)
