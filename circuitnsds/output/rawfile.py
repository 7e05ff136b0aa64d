"""SPICE raw files, laid out as ngspice's ``write`` command writes them.

A raw file is a text header followed by the values::

    Title: <netlist title>
    Date: Sat Nov 21 12:47:11  2026
    Plotname: Transient Analysis
    Flags: real
    No. Variables: 3
    No. Points: 201
    Variables:
    <TAB>0<TAB>time<TAB>time
    <TAB>1<TAB>v(out)<TAB>voltage
    <TAB>2<TAB>i(v1)<TAB>current
    Values:                      (ASCII)   or   Binary:   (binary)

ASCII values are point-major: for each point `` <index><TAB><time>`` and then one
``<TAB><value>`` line per other variable, then an empty line (``%.15e``, as ngspice,
so 16 significant digits). Binary values follow ``Binary:\\n`` directly: every point's
variables as 8-byte IEEE doubles, point after point, little-endian (ngspice writes
native doubles; every machine it runs on today is little-endian).

Variable 0 is ``time`` of type ``time``; ``v(...)`` signals are of type ``voltage``
and ``i(...)`` signals of type ``current`` (units V and A; time in s). ngspice's
``load`` reads both forms back, and so do spicelib and LTspice's viewer.
"""

from __future__ import annotations

import time as wallclock
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from circuitnsds.errors import CircuitnsdsError
from circuitnsds.output.files import atomic_path
from circuitnsds.output.waveforms import Waveforms

PLOTNAME = "Transient Analysis"


class RawFileError(CircuitnsdsError):
    """A raw file cannot be read (not a raw file, complex data, truncated values)."""


def variable_type(name: str) -> str:
    """ngspice's type of a vector: ``time``, ``voltage`` (``v(...)``) or ``current`` (``i(...)``)."""
    key = name.strip().lower()
    if key == "time":
        return "time"
    if key.startswith("i(") or key.endswith("#branch"):
        return "current"
    return "voltage"


def write_raw(
    waves: Waveforms,
    path: str | Path,
    names: Iterable[str] | None = None,
    *,
    binary: bool = True,
    title: str | None = None,
    date: str | None = None,
) -> None:
    """Write ``waves`` as an ngspice transient raw file.

    Args:
        waves: the results.
        path: file to write.
        names: signals to write after ``time`` (default: all, in output order).
        binary: ``Binary:`` section of little-endian doubles (default) or ``Values:``
            in ASCII.
        title: the ``Title:`` line (default: the netlist title).
        date: the ``Date:`` line (default: now, in ngspice's format).
    """
    columns = [name.strip().lower() for name in (names if names is not None else waves.names)]
    columns = [name for name in columns if name != "time"]
    data = np.column_stack([waves.time] + [waves[name] for name in columns]).astype("<f8")
    variables = ["time", *columns]
    title = (title if title is not None else waves.title) or "circuitnsds"
    header = [
        f"Title: {' '.join(title.split())}",
        f"Date: {date if date is not None else wallclock.strftime('%a %b %d %H:%M:%S  %Y')}",
        f"Plotname: {PLOTNAME}",
        "Flags: real",
        f"No. Variables: {len(variables)}",
        f"No. Points: {data.shape[0]}",
        "Variables:",
        *(f"\t{k}\t{name}\t{variable_type(name)}" for k, name in enumerate(variables)),
    ]
    with atomic_path(path) as temporary, open(temporary, "wb") as stream:
        stream.write(("\n".join(header) + "\n").encode("ascii", "replace"))
        if binary:
            stream.write(b"Binary:\n")
            stream.write(np.ascontiguousarray(data).tobytes())
        else:
            stream.write(b"Values:\n")
            row = " %d" + "\t%.15e\n" * len(variables) + "\n"
            for k, values in enumerate(data.tolist()):
                stream.write((row % (k, *values)).encode("ascii"))


def read_raw(path: str | Path) -> Waveforms:
    """Read the first plot of a real (not complex) raw file, ASCII or binary.

    Returns:
        :class:`Waveforms` with the scale (variable 0) as ``time`` and the other
        variables as signals under their lower-case names; the title is the
        ``Title:`` line.

    Raises:
        RawFileError: not a raw file, complex values, or fewer values than announced.
    """
    blob = Path(path).read_bytes()
    header: dict[str, str] = {}
    variables: list[str] = []
    position = 0
    while True:
        end = blob.find(b"\n", position)
        if end < 0:
            raise RawFileError("no 'Values:' or 'Binary:' section", where=str(path),
                               hint="is this a SPICE raw file?")
        line = blob[position:end].decode("latin-1").rstrip("\r")
        position = end + 1
        key, _, value = line.partition(":")
        key = key.strip().lower()
        if key == "variables":
            count = _header_int(header, "no. variables", path)
            for _ in range(count):
                end = blob.find(b"\n", position)
                fields = blob[position:end if end >= 0 else None].decode("latin-1").split()
                if len(fields) < 2:
                    raise RawFileError("truncated 'Variables:' list", where=str(path))
                variables.append(fields[1].lower())
                position = end + 1
        elif key in ("values", "binary"):
            break
        elif key:
            header[key] = value.strip()
    if "complex" in header.get("flags", "").lower():
        raise RawFileError("complex data (AC analysis) is not supported", where=str(path),
                           hint="circuitnsds reads transient (real) raw files")
    if not variables:
        raise RawFileError("no variables", where=str(path))
    points = _header_int(header, "no. points", path)
    width = len(variables)
    if key == "binary":
        needed = points * width * 8
        if len(blob) - position < needed:
            raise RawFileError(f"{points} points announced but the file holds fewer",
                               where=str(path), hint="the file is truncated")
        data = np.frombuffer(blob, dtype="<f8", count=points * width, offset=position)
    else:
        tokens = blob[position:].split()
        if len(tokens) < points * (width + 1):
            raise RawFileError(f"{points} points announced but the file holds fewer",
                               where=str(path), hint="the file is truncated")
        table = np.array(tokens[: points * (width + 1)], dtype=object).reshape(points, width + 1)
        try:
            data = table[:, 1:].astype(float)
        except ValueError:
            raise RawFileError("a value is not a number", where=str(path)) from None
    data = np.array(data, dtype=float).reshape(points, width)
    return Waveforms(time=data[:, 0].copy(),
                     signals={name: data[:, k].copy() for k, name in enumerate(variables) if k},
                     title=header.get("title", ""))


def _header_int(header: dict[str, str], key: str, path: str | Path) -> int:
    try:
        return int(header[key])
    except (KeyError, ValueError):
        raise RawFileError(f"missing or bad '{key.title()}:' line", where=str(path),
                           hint="is this a SPICE raw file?") from None
