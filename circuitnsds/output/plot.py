"""Figures of waveforms: one panel per kind of quantity, engineering units.

Voltages (``v(...)``) share the top panel, currents (``i(...)``) the next one, any
other signal a panel of its own kind. Each panel's axis is scaled to an SI prefix
(``current [mA]``), the time axis to s, ms, µs or ns, and every trace is named in
the panel's legend. :func:`plot_waveforms` writes a file (PNG, or PDF/SVG by the
extension) without a screen; :func:`show_waveforms` opens a window and says
clearly when there is no display to open it on.
"""

from __future__ import annotations

import io
import os
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from circuitnsds.errors import CircuitnsdsError
from circuitnsds.output.files import atomic_path
from circuitnsds.output.waveforms import Waveforms
from circuitnsds.units import engineering_scale, time_unit

MAX_DEFAULT_SIGNALS = 8
"""Default plots show at most this many node voltages and this many device currents."""

KINDS = (("v(", "voltage", "V"), ("i(", "current", "A"))
"""Signal-name prefix, quantity and unit of each panel kind, in panel order."""

_NON_INTERACTIVE = {"agg", "cairo", "pdf", "pgf", "ps", "svg", "template"}

FIGURE_FORMATS = frozenset({"eps", "jpeg", "jpg", "pdf", "pgf", "png", "ps", "raw", "rgba", "svg",
                            "svgz", "tif", "tiff", "webp"})
"""The file extensions every matplotlib this package accepts (>= 3.7) writes
(``FigureCanvasBase.get_supported_filetypes()``): known without importing matplotlib
(~0.4 s), so a command checks ``--plot`` before its run at no cost. Another extension
(``.gif`` and ``.avif``, written from matplotlib 3.11 on) is looked up in the installed
matplotlib itself."""


class PlotError(CircuitnsdsError):
    """A figure cannot be written (unknown format) or shown (no display, no interactive
    matplotlib backend)."""


def default_signals(waves: Waveforms) -> list[str]:
    """Up to 8 node voltages and up to 8 currents of devices other than resistors."""
    voltages = [n for n in waves.names if n.startswith("v(")][:MAX_DEFAULT_SIGNALS]
    currents = [n for n in waves.names if n.startswith("i(") and not n.startswith("i(r")]
    return voltages + currents[:MAX_DEFAULT_SIGNALS]


def _panels(names: Sequence[str]) -> list[tuple[str, str, list[str]]]:
    """``(quantity, unit, names)`` for each panel, voltages first, then currents, then the rest."""
    panels = []
    for prefix, quantity, unit in KINDS:
        group = [n for n in names if n.startswith(prefix)]
        if group:
            panels.append((quantity, unit, group))
    rest = [n for n in names if not any(n.startswith(prefix) for prefix, _, _ in KINDS)]
    if rest:
        panels.append(("value", "", rest))
    return panels


def draw(figure, waves: Waveforms, names: Sequence[str] | None = None, events: bool = False) -> None:
    """Draw the panels of ``waves`` into a matplotlib ``figure`` (see the module docstring);
    with ``events``, each switching of ``waves.events`` as a thin vertical line on every
    panel (solid: closing, dotted: opening)."""
    names = default_signals(waves) if names is None else [n.strip().lower() for n in names]
    names = [n for n in names if n != "time"]
    missing = [n for n in names if n not in waves]
    if missing:
        raise KeyError(f"no signal {', '.join(missing)}; available: {', '.join(waves.names)}")
    panels = _panels(names)
    if not panels:
        raise PlotError("nothing to plot: no signals", where="plot")
    time = np.asarray(waves.time)
    span = float(time[-1] - time[0]) if time.size > 1 else 0.0
    t_factor, t_unit = time_unit(max(span, abs(float(time[-1])) if time.size else 0.0))
    axes = figure.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for axis, (quantity, unit, group) in zip(axes, panels):
        peak = max((float(np.max(np.abs(waves[n]))) if waves[n].size else 0.0) for n in group)
        factor, prefix = engineering_scale(peak) if unit else (1.0, "")
        for name in group:
            axis.plot(time * t_factor, waves[name] * factor, label=name, linewidth=1.0)
        if events:
            for time_of, _, closed in waves.events:
                axis.axvline(time_of * t_factor, color="0.5", linewidth=0.4,
                             linestyle="-" if closed else ":")
        axis.set_ylabel(f"{quantity} [{prefix}{unit}]" if unit else quantity)
        axis.grid(True, alpha=0.3)
        axis.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize="small",
                    frameon=False)
    axes[-1].set_xlabel(f"time [{t_unit}]")
    if time.size:
        axes[-1].set_xlim(time[0] * t_factor, time[-1] * t_factor)
    axes[0].set_title(waves.title or "circuitnsds transient", fontsize="medium")


def _size(panels: int) -> tuple[float, float]:
    return 10.0, 1.2 + 2.6 * max(panels, 1)


def plot_waveforms(waves: Waveforms, path: str | Path, names: Sequence[str] | None = None,
                   dpi: int = 120, events: bool = False) -> None:
    """Write a figure of ``waves`` to ``path`` (format from the extension, PNG usually).

    Args:
        waves: the results.
        path: file to write.
        names: signals to draw; default: :func:`default_signals`.
        dpi: resolution of raster formats.
        events: mark each switching (``waves.events``) with a thin vertical line.
    """
    from matplotlib.figure import Figure  # no pyplot: no backend, no screen needed

    file_format = plot_format(path)
    chosen = default_signals(waves) if names is None else list(names)
    figure = Figure(figsize=_size(len(_panels([n.strip().lower() for n in chosen]))),
                    layout="constrained")
    draw(figure, waves, chosen, events)
    save_figure(figure, path, dpi, file_format)


def save_figure(figure, path: str | Path, dpi: int = 120, file_format: str | None = None) -> None:
    """Write a matplotlib ``figure`` to ``path`` (format from the extension) through a
    temporary file and a rename. It is rendered in memory and written here: matplotlib's own
    writers can swallow a failed write (ENOSPC on /dev/full reported success); closing our
    file raises it.

    Raises:
        PlotError: the extension names no format matplotlib writes.
    """
    buffer = io.BytesIO()
    figure.savefig(buffer, format=file_format or plot_format(path), dpi=dpi)
    with atomic_path(path) as temporary, open(temporary, "wb") as handle:
        handle.write(buffer.getvalue())


def plot_format(path: str | Path) -> str:
    """The figure format of ``path``, from its extension.

    Raises:
        PlotError: the extension names no format matplotlib writes (``x.xyz``); a name
            without extension is a PNG.
    """
    suffix = Path(path).suffix.lower().lstrip(".")
    if not suffix:
        return "png"  # as matplotlib does for a name without extension
    if suffix in FIGURE_FORMATS:
        return suffix
    from matplotlib.backend_bases import FigureCanvasBase

    supported = FigureCanvasBase.get_supported_filetypes()
    if suffix not in supported:
        raise PlotError(f"cannot plot to {path}: '.{suffix}' is not a figure format",
                        hint="use one of " + ", ".join(f".{k}" for k in sorted(supported))
                        + " (.png usually)")
    return suffix


def check_display() -> None:
    """Raise :class:`PlotError` unless a window can be opened here."""
    if sys.platform not in ("win32", "darwin") and not (
            os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise PlotError("--show needs a display, and none is available (DISPLAY is not set)",
                        where="plot", hint="write the figure to a file instead: --plot out.png")


def show_waveforms(waves: Waveforms, names: Sequence[str] | None = None,
                   events: bool = False) -> None:
    """Open an interactive window with the figure of ``waves`` (``events``: mark the
    switchings); returns when it is closed.

    Raises:
        PlotError: no display, or matplotlib has no interactive backend.
    """
    check_display()
    import matplotlib.pyplot as plt

    backend = plt.get_backend().lower()
    if backend in _NON_INTERACTIVE:
        raise PlotError(f"matplotlib has no interactive backend here (it uses {backend!r})",
                        where="plot", hint="install one (tkinter: apt install python3-tk; or "
                        "pip install PyQt6), or write a file with --plot out.png")
    chosen = default_signals(waves) if names is None else list(names)
    figure = plt.figure(figsize=_size(len(_panels([n.strip().lower() for n in chosen]))),
                        layout="constrained")
    draw(figure, waves, chosen, events)
    plt.show()
