"""CSV of waveforms: a header row ``time,v(out),...`` then one row per instant.

Every number is written as Python's ``repr`` of the float64: the shortest decimal that
reads back to the same double (full precision, ``inf``/``-inf``/``nan`` as such, which
Python's ``float``, numpy and pandas read). Two writers produce the same bytes:

* the compiled formatter (:mod:`circuitnsds.output.floattext`), a block of
  :data:`BLOCK_ROWS` rows at a time into one byte buffer: its C kernel (the library built
  at install, ~0.05 µs per number, nothing to load) whenever that library is there, else
  its numba kernel (~0.07-0.15 µs per number, but loading numba costs ~1 s in a process
  that has not loaded it yet, ~0.02 s when the stepping loop already has);
* the Python one, one ``%``-format of a repeated ``%r`` row template over a block's
  values (C loops, ~0.6 µs per number): without the C library, for the files too small to
  pay for numba's load.

:func:`compiled_pays` chooses (measured thresholds, see ``benchmarks/csv_writers.py``).
"""

from __future__ import annotations

import io
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import BinaryIO, TextIO

import numpy as np

from circuitnsds.output import floattext
from circuitnsds.output.files import atomic_path, writing

BLOCK_ROWS = 65_536
"""Rows formatted at once (bounds the memory of the text in flight: ~3 MB for 2 columns)."""
LOADED_VALUES = 50_000
"""Numbers from which the numba formatter pays (without the C one) when numba is in use in the
process (it loads in ~0.02 s from the cache, and saves ~0.45 µs per number)."""
COLD_VALUES = 1_500_000
"""Numbers from which the numba formatter pays (without the C one) when numba must first be
imported (~0.65-1 s in all)."""


def _numba_in_use() -> bool:
    """Whether a compiled stepping loop has been loaded in this process (numba imported and
    its compiler context set up), without importing anything."""
    for name in ("circuitnsds.engine.dense_loop", "circuitnsds.engine.sparse_loop"):
        compiled = getattr(sys.modules.get(name), "_compiled", None)
        if getattr(compiled, "loaded", False):
            return True
    return False


def compiled_pays(values: int) -> bool:
    """Whether to write ``values`` numbers with the compiled formatter: always when its C
    kernel is there (:func:`~circuitnsds.output.floattext.has_native`: no load cost). Else
    the numba kernel when numba is installed, enough numbers for its load to pay
    (:data:`LOADED_VALUES` or :data:`COLD_VALUES`), and that kernel already loaded or cached
    for this source (the warm-up's marker,
    :func:`~circuitnsds.output.floattext.ready_marker`; compiling it takes ~5-10 s, more than
    the Python writer needs for most files, so an uncached formatter is never compiled here:
    the warm-up process compiles it in the background for the next runs)."""
    if floattext.has_native() or floattext.loaded():
        return True
    from circuitnsds import jit

    if not jit.numba_available() or values < (LOADED_VALUES if _numba_in_use() else COLD_VALUES):
        return False
    marker = floattext.ready_marker()
    if marker is None:
        return False
    if not marker.exists():
        if values >= COLD_VALUES:  # worth compiling for the next runs, in the background
            jit.start_warmup("circuitnsds.output.floattext")
        return False
    return True


def write_header(stream: TextIO | BinaryIO, names: Sequence[str]) -> None:
    """Write the header row: ``time`` and the signal names."""
    _emit(stream, ",".join(["time", *names]) + "\n")


def _binary(stream: TextIO | BinaryIO) -> bool:
    """Whether ``stream`` takes bytes: a binary file or buffer (``open(..., "wb")``,
    ``BytesIO``, a ``"b"`` mode); anything else with a ``write`` is taken for a text stream."""
    if isinstance(stream, io.TextIOBase):
        return False
    return isinstance(stream, (io.RawIOBase, io.BufferedIOBase)) or "b" in str(getattr(stream, "mode", ""))


def _emit(stream: TextIO | BinaryIO, text: str | bytes) -> None:
    """Write ``text`` to a text or a binary stream (ASCII either way)."""
    if not _binary(stream):
        stream.write(text if isinstance(text, str) else text.decode("ascii"))
    else:
        stream.write(text.encode("utf-8") if isinstance(text, str) else text)


def write_rows(stream: TextIO | BinaryIO, time: np.ndarray, columns: Sequence[np.ndarray], *,
               compiled: bool | None = None, scratch: dict[str, np.ndarray] | None = None) -> None:
    """Write one row per element of ``time`` (all arrays of the same length).

    ``compiled``: the compiled formatter (``True``: its C kernel if built, else numba's), the
    Python one (``False``), or chosen by :func:`compiled_pays` (``None``); all write the same
    bytes. ``scratch``: a dict the caller keeps between calls (not concurrent ones), in which
    the block and text buffers are kept and reused (a streamed run's segments: no fresh
    memory to fault in for each)."""
    width = 1 + len(columns)
    if compiled is None:
        compiled = compiled_pays(time.size * width)
    kernel = floattext.kernel() if compiled else None
    rows = min(time.size, BLOCK_ROWS)
    buffer = _scratch(scratch, "text", rows * width * (floattext.MAX_CHARS + 1), np.uint8) \
        if compiled else None
    blocks = _scratch(scratch, "block", rows * width, np.float64)
    row = ",".join(["%r"] * width) + "\n"
    binary = _binary(stream)
    for start in range(0, time.size, BLOCK_ROWS):
        stop = min(start + BLOCK_ROWS, time.size)
        block = blocks[:(stop - start) * width].reshape(stop - start, width)
        block[:, 0] = time[start:stop]
        for j, column in enumerate(columns, start=1):
            block[:, j] = column[start:stop]
        if compiled:
            end = kernel(block.view(np.uint64), buffer, *floattext.tables())
            if binary:  # (the buffer's bytes as they are: no copy)
                stream.write(memoryview(buffer)[:end])
            else:
                _emit(stream, buffer[:end].tobytes())
        else:
            _emit(stream, (row * (stop - start)) % tuple(block.ravel().tolist()))


def _scratch(scratch: dict[str, np.ndarray] | None, name: str, size: int, dtype) -> np.ndarray:
    """A 1-D array of at least ``size`` elements of ``dtype``: ``scratch[name]`` if it is one,
    else a new one (kept there when ``scratch`` is given)."""
    array = None if scratch is None else scratch.get(name)
    if array is None or array.size < size or array.dtype != dtype:
        array = np.empty(size, dtype=dtype)
        if scratch is not None:
            scratch[name] = array
    return array


def write_csv(stream: TextIO | BinaryIO, time: np.ndarray, names: Sequence[str],
              columns: Sequence[np.ndarray], *, compiled: bool | None = None) -> None:
    """Header and rows (see the module docstring)."""
    write_header(stream, names)
    write_rows(stream, np.asarray(time, dtype=float), [np.asarray(c, dtype=float) for c in columns],
               compiled=compiled)


class CsvStream:
    """A CSV written as a run goes: the header at once, then each segment's rows as the run
    hands them over (:meth:`append`), so the rows need not be held in memory.

    A file is written through :func:`~circuitnsds.output.files.atomic_path`: only
    :meth:`commit` puts it in place (a run that fails or is interrupted commits the rows it
    completed, as the writers do with a partial result); :meth:`abort` leaves the previous
    file untouched. An open stream (standard output) gets the rows directly.

    With the compiled formatter, each chunk is formatted and written in a background thread
    (the formatter holds no GIL: ctypes releases it for the C kernel, numba's is ``nogil``)
    while the run computes the next segment; at most one chunk
    is in flight. ``keep``: also hold the rows (for the outputs that need whole signals:
    raw file, figure); :meth:`waveforms` returns them.

    Args:
        target: file path, or an open text or binary stream.
        names: the signals' column labels, in the order of the columns given to :meth:`append`.
    """

    def __init__(self, target: str | Path | TextIO | BinaryIO, names: Sequence[str], *,
                 keep: bool = False, background: bool = True):
        from contextlib import ExitStack

        self.target = target
        self.names = list(names)
        self.keep = keep
        self.background = background
        self.rows = 0
        self.last_time = float("nan")
        self.max_residual = 0.0
        self.compiled: bool | None = None
        self.expected = 0
        self._chunks: list[tuple[np.ndarray, list[np.ndarray], np.ndarray | None]] = []
        self._pending: _Background | None = None
        self._scratch: dict[str, np.ndarray] = {}  # the writer's buffers (one chunk at a time)
        self._stack = ExitStack()
        self._temporary: Path | None = None  # the file written, renamed over target by commit
        try:
            with writing(target):
                if hasattr(target, "write"):
                    self._stream = target
                else:
                    temporary = self._stack.enter_context(atomic_path(target))
                    self._stream = self._stack.enter_context(open(temporary, "wb"))
                    self._temporary = temporary
                labels = [f'"{name}"' if "," in name else name for name in self.names]
                write_header(self._stream, labels)
        except BaseException as exc:
            self._stack.__exit__(type(exc), exc, exc.__traceback__)  # no file left behind
            raise

    def expect(self, rows: int) -> None:
        """The rows the run will hand over: the formatter is chosen for the whole file at the
        first :meth:`append` (by then a long run has loaded its compiled loop, and numba with it)."""
        self.expected = rows

    def append(self, time: np.ndarray, columns: Sequence[np.ndarray],
               residual: np.ndarray | None = None) -> None:
        """Write the rows of one segment (arrays of equal length, not modified afterwards)."""
        if time.size == 0:
            return
        self._wait()
        if self.compiled is None:
            self.compiled = compiled_pays(max(self.expected, time.size) * (1 + len(self.names)))
        time = np.asarray(time, dtype=float)
        columns = [np.asarray(column, dtype=float) for column in columns]
        if self.keep:
            self._chunks.append((time, columns, residual))
        if self.compiled and self.background:
            self._pending = _Background(write_rows, self._stream, time, columns, compiled=True,
                                        scratch=self._scratch)
        else:
            with writing(self.target):
                write_rows(self._stream, time, columns, compiled=self.compiled, scratch=self._scratch)
        self.rows += time.size
        self.last_time = float(time[-1])
        if residual is not None and residual.size:
            self.max_residual = max(self.max_residual, float(np.max(residual)))

    def _wait(self) -> None:
        """Let the chunk in flight be written (its write error raised here)."""
        pending = self._pending
        if pending is not None:
            with writing(self.target):
                pending.join()  # (a Ctrl-C here leaves it pending: commit or abort waits again)
                self._pending = None
                pending.raise_failure()

    def commit(self, note: str | None = None) -> None:
        """Finish writing and put the file in place (an open stream is flushed).

        ``note``: a partial result's marker, written as a first line ``# note`` above the
        header (a file only: rows already sent to a stream cannot be preceded).
        """
        try:
            self._wait()
            if note is not None and self._temporary is not None:
                with writing(self.target):
                    self._stream.flush()
                    prepend_line(self._temporary, f"# {note}\n")
        except BaseException:
            self.abort()
            raise
        with writing(self.target):
            if hasattr(self.target, "write"):
                self._stream.flush()
            self._stack.close()

    def abort(self) -> None:
        """Stop writing; the file being written is removed, the previous one kept."""
        pending, self._pending = self._pending, None
        if pending is not None:
            pending.join()  # the run's own failure is what gets reported, not the writer's
        aborted = KeyboardInterrupt()
        self._stack.__exit__(KeyboardInterrupt, aborted, None)

    def waveforms(self, template):
        """The rows kept (``keep``) as :class:`~circuitnsds.output.waveforms.Waveforms`, with
        the title, stats and events of ``template`` (the run's result)."""
        from dataclasses import replace

        def joined(arrays):
            return np.concatenate(arrays) if arrays else np.zeros(0)

        residuals = [r for _, _, r in self._chunks if r is not None]
        return replace(template, time=joined([t for t, _, _ in self._chunks]),
                       signals={name: joined([c[j] for _, c, _ in self._chunks])
                                for j, name in enumerate(self.names)},
                       residual=joined(residuals) if residuals else template.residual)


def prepend_line(path: Path, line: str) -> None:
    """Put ``line`` before the content of file ``path`` (a copy renamed over it; on any
    failure, interruption included, the copy is removed and ``path`` is unchanged)."""
    import shutil

    copy = path.with_name(path.name + ".marked")
    try:
        with open(path, "rb") as source, open(copy, "wb") as target:
            target.write(line.encode("utf-8"))
            shutil.copyfileobj(source, target, 2**22)
        shutil.copymode(path, copy)
        os.replace(copy, path)
    except BaseException:
        try:
            os.unlink(copy)
        except OSError:
            pass
        raise


class _Background:
    """One call of ``function(*args, **kwargs)`` in a thread of its own, started at once
    (a plain thread: ``concurrent.futures`` would import ``logging`` and more, ~5 ms of every
    run's start-up, for one worker). Not a daemon: the interpreter waits for it at exit."""

    def __init__(self, function, *args, **kwargs):
        import threading

        self._failure: BaseException | None = None

        def work() -> None:
            try:
                function(*args, **kwargs)
            except BaseException as exc:  # handed to whoever waits for the result
                self._failure = exc

        self._thread = threading.Thread(target=work, name="csv")
        self._thread.start()

    def join(self) -> None:
        """Wait for the call to end."""
        self._thread.join()

    def raise_failure(self) -> None:
        """Raise what the call raised, if anything (after :meth:`join`)."""
        if self._failure is not None:
            raise self._failure
