"""The files a transient's results are written to, one writer per command-line option.

:data:`WRITERS` is the table the ``circuitnsds`` command (``run``, ``pss``) consults: for
each output option, the ``argparse`` attribute that holds its path and the function that
writes it. The CSV table (``-o``) is not in it: it may be streamed during the run
(:class:`~circuitnsds.output.csvfile.CsvStream`) or go to standard output, and the
command handles it.

A writer is called with the path to write (a temporary file, renamed over the
destination with the other outputs of the command: see
:func:`~circuitnsds.output.files.replaced_together`), the signals chosen (``None``: all)
and :class:`WriterSettings`. ``settings.partial``, when set, is the note marking a
partial result: the raw file's and the figure's title already carry it (the caller puts
it in the waveforms' title); a CSV file gets it as a first line ``# note``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from circuitnsds.output.waveforms import Waveforms


@dataclass(frozen=True)
class WriterSettings:
    """What the command line says about the outputs beyond their paths.

    Attributes:
        binary: raw file in binary (``True``) or ASCII (``--ascii``).
        mark_events: the figure marks the switchings (``--mark-events``).
        partial: the note of a partial result (``None`` for a whole run).
    """

    binary: bool = True
    mark_events: bool = False
    partial: str | None = None


def _raw(waves: Waveforms, path: Path, names: Sequence[str] | None, settings: WriterSettings) -> None:
    from circuitnsds.output.rawfile import write_raw

    write_raw(waves, path, names, binary=settings.binary)


def _figure(waves: Waveforms, path: Path, names: Sequence[str] | None, settings: WriterSettings) -> None:
    from circuitnsds.output.plot import plot_waveforms

    plot_waveforms(waves, path, names, events=settings.mark_events)


def _events(waves: Waveforms, path: Path, names: Sequence[str] | None, settings: WriterSettings) -> None:
    waves.events_to_csv(path)
    if settings.partial is not None:
        from circuitnsds.output.csvfile import prepend_line

        prepend_line(path, f"# {settings.partial}\n")


@dataclass(frozen=True)
class Writer:
    """One output option: ``option`` (``-r``), the ``argparse`` attribute of its path
    (``raw``), and ``write(waves, path, names, settings)``."""

    option: str
    attribute: str
    write: Callable[[Waveforms, Path, Sequence[str] | None, WriterSettings], None]


WRITERS = (
    Writer("-r", "raw", _raw),
    Writer("--plot", "plot", _figure),
    Writer("--events", "events", _events),
)
"""The output files of ``run`` and ``pss`` besides the CSV table, in the order written."""
