"""CSV of waveforms: a header row ``time,v(out),...`` then one row per instant.

Every number is written as Python's ``repr`` of the float64: the shortest decimal that
reads back to the same double (full precision, ``inf``/``-inf``/``nan`` as such, which
Python's ``float``, numpy and pandas read). Two writers produce the same bytes:

* the compiled formatter (:mod:`circuitnsds.output.floattext`, numba, ~0.1-0.2 µs per
  number), a block of :data:`BLOCK_ROWS` rows at a time into one byte buffer;
* the Python one, one ``%``-format of a repeated ``%r`` row template over a block's
  values (C loops, ~0.6 µs per number), for small files: loading numba costs ~0.6 s in a
  process that has not loaded it yet (~0.02 s when the stepping loop already has).

:func:`compiled_pays` chooses by the count of numbers (measured thresholds, see
``benchmarks/csv_writers.py``).
"""

from __future__ import annotations

import io
import sys
from collections.abc import Sequence
from typing import BinaryIO, TextIO

import numpy as np

from circuitnsds.output import floattext

BLOCK_ROWS = 65_536
"""Rows formatted at once (bounds the memory of the text in flight: ~3 MB for 2 columns)."""
LOADED_VALUES = 50_000
"""Numbers from which the compiled formatter pays when numba is in use in the process (it
loads in ~0.02 s from the cache, and saves ~0.45 µs per number)."""
COLD_VALUES = 1_500_000
"""Numbers from which it pays when numba must first be imported (~0.65 s in all)."""


def _numba_in_use() -> bool:
    """Whether a compiled stepping loop has been loaded in this process (numba imported and
    its compiler context set up), without importing anything."""
    for name in ("circuitnsds.engine.dense_loop", "circuitnsds.engine.sparse_loop"):
        compiled = getattr(sys.modules.get(name), "_compiled", None)
        if getattr(compiled, "loaded", False):
            return True
    return False


def compiled_pays(values: int) -> bool:
    """Whether to write ``values`` numbers with the compiled formatter: numba installed,
    enough numbers for its load to pay (:data:`LOADED_VALUES` or :data:`COLD_VALUES`), and
    the formatter already loaded or cached for this source (the warm-up's marker,
    :func:`~circuitnsds.engine.jit.ready_marker`; compiling it takes ~4 s, more than the
    Python writer needs for most files, so an uncached formatter is never compiled here)."""
    if floattext.loaded():
        return True
    from circuitnsds.engine.jit import numba_available, ready_marker

    if not numba_available() or values < (LOADED_VALUES if _numba_in_use() else COLD_VALUES):
        return False
    marker = ready_marker()
    return marker is not None and marker.exists()


def write_header(stream: TextIO | BinaryIO, names: Sequence[str]) -> None:
    """Write the header row: ``time`` and the signal names."""
    _emit(stream, ",".join(["time", *names]) + "\n")


def _emit(stream: TextIO | BinaryIO, text: str | bytes) -> None:
    """Write ``text`` to a text or a binary stream (ASCII either way)."""
    if isinstance(stream, io.TextIOBase):
        stream.write(text if isinstance(text, str) else text.decode("ascii"))
    else:
        stream.write(text.encode("utf-8") if isinstance(text, str) else text)


def write_rows(stream: TextIO | BinaryIO, time: np.ndarray, columns: Sequence[np.ndarray], *,
               compiled: bool | None = None) -> None:
    """Write one row per element of ``time`` (all arrays of the same length).

    ``compiled``: the compiled formatter (``True``), the Python one (``False``), or chosen
    by :func:`compiled_pays` (``None``); both write the same bytes."""
    width = 1 + len(columns)
    if compiled is None:
        compiled = compiled_pays(time.size * width)
    kernel = floattext.kernel("csv") if compiled else None
    buffer = np.empty(min(time.size, BLOCK_ROWS) * width * (floattext.MAX_CHARS + 1), dtype=np.uint8) \
        if compiled else None
    row = ",".join(["%r"] * width) + "\n"
    for start in range(0, time.size, BLOCK_ROWS):
        stop = min(start + BLOCK_ROWS, time.size)
        block = np.empty((stop - start, width))
        block[:, 0] = time[start:stop]
        for j, column in enumerate(columns, start=1):
            block[:, j] = column[start:stop]
        if compiled:
            end = kernel(block.view(np.uint64), buffer, *floattext.tables())
            _emit(stream, buffer[:end].tobytes())
        else:
            _emit(stream, (row * (stop - start)) % tuple(block.ravel().tolist()))


def write_csv(stream: TextIO | BinaryIO, time: np.ndarray, names: Sequence[str],
              columns: Sequence[np.ndarray], *, compiled: bool | None = None) -> None:
    """Header and rows (see the module docstring)."""
    write_header(stream, names)
    write_rows(stream, np.asarray(time, dtype=float), [np.asarray(c, dtype=float) for c in columns],
               compiled=compiled)
