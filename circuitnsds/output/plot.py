"""Figures of waveforms: one panel per kind of quantity, engineering units.

Voltages (``v(...)``) come first, currents (``i(...)``) next, any other signal in a panel
of its own kind; the signals of one unit are spread over panels of similar scale (a signal
20 times smaller than the largest of its panel gets the next one). Each panel's axis is scaled to an SI prefix
(``current [mA]``), the time axis to s, ms, µs or ns, and every trace is named in
the panel's legend. :func:`plot_waveforms` writes a file (PNG, drawn with Pillow by
:mod:`circuitnsds.output.raster_figure`, or PDF/SVG ... by the extension, drawn with
matplotlib) without a screen; :func:`show_waveforms` opens a window and says
clearly when there is no display to open it on.
"""

from __future__ import annotations

import io
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from circuitnsds.errors import CircuitnsdsError
from circuitnsds.output.files import atomic_path
from circuitnsds.output.waveforms import Waveforms
from circuitnsds.units import engineering_scale, time_unit

MAX_DEFAULT_SIGNALS = 8
"""Default plots show at most this many node voltages and this many device currents."""

KINDS = (("v(", "voltage", "V"), ("i(", "current", "A"), ("tj(", "junction temperature", "°C"))
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


KEPT_CURRENTS = frozenset("ldswm")
"""Element letters whose currents a default plot always shows: inductors, diodes, switches and
MOSFETs (an LLC's current panel had lost i(lr) and its diodes' currents to the cap of 8)."""

SCALE_RATIO = 20.0
"""A signal whose peak is below this fraction of the largest in its panel gets a panel of its
own scale (a 0..1 V control signal drawn flat under a 400 V bus was unreadable)."""
MAX_PANELS_PER_UNIT = 3
"""Signals of one unit are spread over at most this many panels of different scales."""


def _letter(name: str) -> str:
    """The element letter of a current ``i(x1.lr)`` (its last name part's first letter)."""
    return name[2:-1].rsplit(".", 1)[-1][:1]


def default_signals(waves: Waveforms) -> list[str]:
    """Up to 8 node voltages; the currents of every inductor, diode, switch and MOSFET, and of
    other devices but resistors up to 8 currents in all; up to 8 junction temperatures
    ``tj(...)`` (devices with datasheets, docs/losses.md); in the order of ``waves``."""
    voltages = [n for n in waves.names if n.startswith("v(")][:MAX_DEFAULT_SIGNALS]
    currents = [n for n in waves.names if n.startswith("i(") and _letter(n) != "r"]
    kept = {n for n in currents if _letter(n) in KEPT_CURRENTS}
    room = max(MAX_DEFAULT_SIGNALS - len(kept), 0)
    kept |= set([n for n in currents if n not in kept][:room])
    junctions = [n for n in waves.names if n.startswith("tj(")]
    return voltages + [n for n in currents if n in kept] + junctions[:MAX_DEFAULT_SIGNALS]


def _by_scale(group: list[str], peaks: dict[str, float]) -> list[list[str]]:
    """``group`` split into panels of similar scale (see :data:`SCALE_RATIO`), the largest
    scale first, each in the order of ``group``; signals that are zero throughout go with the
    smallest scale."""
    order = sorted(group, key=lambda n: -peaks.get(n, 0.0))
    panels: list[list[str]] = []
    leader = 0.0
    for name in order:
        peak = peaks.get(name, 0.0)
        if panels and (peak >= leader / SCALE_RATIO or len(panels) == MAX_PANELS_PER_UNIT
                       or peak == 0.0):
            panels[-1].append(name)
        else:
            panels.append([name])
            leader = peak
    return [[n for n in group if n in panel] for panel in panels]


def _panels(names: Sequence[str], peaks: dict[str, float] | None = None
            ) -> list[tuple[str, str, list[str]]]:
    """``(quantity, unit, names)`` for each panel: voltages first, then currents, then the
    rest; with ``peaks`` (signal -> largest magnitude), each unit split by scale (:func:`_by_scale`)."""
    panels = []
    for prefix, quantity, unit in KINDS:
        group = [n for n in names if n.startswith(prefix)]
        for part in (_by_scale(group, peaks) if peaks is not None and group else [group] if group
                     else []):
            panels.append((quantity, unit, part))
    rest = [n for n in names if not any(n.startswith(prefix) for prefix, _, _ in KINDS)]
    if rest:
        panels.append(("value", "", rest))
    return panels


def _peaks(waves: Waveforms, names: Sequence[str]) -> dict[str, float]:
    return {n: _finite_peak(waves[n]) for n in names if n in waves}


@dataclass(frozen=True)
class Panel:
    """One panel of a waveform figure: its axis label and its traces, already scaled to
    the label's unit (``("i(d1)", values in mA)``)."""

    ylabel: str
    traces: list[tuple[str, np.ndarray]]


@dataclass(frozen=True)
class FigureData:
    """What a waveform figure shows, in the units of its labels: the time axis (scaled, with
    its label), the panels top to bottom, the title and the switchings to mark
    (``(time, closed)``, time scaled like the axis). Drawn by :func:`draw` (matplotlib) and
    :func:`circuitnsds.output.raster_figure.png_bytes` (PNG with Pillow)."""

    title: str
    time: np.ndarray
    xlabel: str
    panels: list[Panel]
    events: list[tuple[float, bool]] = field(default_factory=list)


def _finite_peak(values: np.ndarray) -> float:
    """Largest magnitude among the finite ``values`` (0 if none): NaN and inf do not set the scale."""
    magnitudes = np.abs(np.asarray(values, dtype=float))
    magnitudes = magnitudes[np.isfinite(magnitudes)]
    return float(magnitudes.max()) if magnitudes.size else 0.0


def figure_data(waves: Waveforms, names: Sequence[str] | None = None,
                events: bool = False) -> FigureData:
    """The panels of ``waves`` (see the module docstring) with their units chosen: time in
    s, ms, µs ... and each panel in the SI prefix of its largest finite value; with
    ``events``, the switchings of ``waves.events``.

    Raises:
        KeyError: a name that is not a signal of ``waves``.
        PlotError: no signal to plot.
    """
    names = default_signals(waves) if names is None else [n.strip().lower() for n in names]
    names = [n for n in names if n != "time"]
    missing = [n for n in names if n not in waves]
    if missing:
        raise KeyError(f"no signal {', '.join(missing)}; available: {', '.join(waves.names)}")
    groups = _panels(names, _peaks(waves, names))
    if not groups:
        raise PlotError("nothing to plot: no signals", where="plot")
    time = np.asarray(waves.time, dtype=float)
    span = float(time[-1] - time[0]) if time.size > 1 else 0.0
    t_factor, t_unit = time_unit(max(span, abs(float(time[-1])) if time.size else 0.0))
    panels = []
    for quantity, unit, group in groups:
        peak = max(_finite_peak(waves[n]) for n in group)
        factor, prefix = engineering_scale(peak) if unit and unit != "°C" else (1.0, "")
        panels.append(Panel(f"{quantity} [{prefix}{unit}]" if unit else quantity,
                            [(n, np.asarray(waves[n], dtype=float) * factor) for n in group]))
    marks = [(time_of * t_factor, bool(closed)) for time_of, _, closed in waves.events] if events else []
    return FigureData(waves.title or "circuitnsds transient", time * t_factor, f"time [{t_unit}]",
                      panels, marks)


def draw(figure, waves: Waveforms, names: Sequence[str] | None = None, events: bool = False) -> None:
    """Draw the panels of ``waves`` into a matplotlib ``figure`` (see the module docstring);
    with ``events``, each switching of ``waves.events`` as a thin vertical line on every
    panel (solid: closing, dotted: opening)."""
    data = figure_data(waves, names, events)
    axes = figure.subplots(len(data.panels), 1, sharex=True, squeeze=False)[:, 0]
    for axis, panel in zip(axes, data.panels):
        for name, values in panel.traces:
            axis.plot(data.time, values, label=name, linewidth=1.0)
        for time_of, closed in data.events:
            axis.axvline(time_of, color="0.5", linewidth=0.4, linestyle="-" if closed else ":")
        axis.set_ylabel(panel.ylabel)
        axis.grid(True, alpha=0.3)
        axis.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize="small",
                    frameon=False)
    axes[-1].set_xlabel(data.xlabel)
    if data.time.size:
        axes[-1].set_xlim(data.time[0], data.time[-1])
    axes[0].set_title(data.title, fontsize="medium")


def _size(panels: int) -> tuple[float, float]:
    return 10.0, 1.2 + 2.6 * max(panels, 1)


def plot_waveforms(waves: Waveforms, path: str | Path, names: Sequence[str] | None = None,
                   dpi: int = 120, events: bool = False) -> None:
    """Write a figure of ``waves`` to ``path`` (format from the extension, PNG usually),
    through a temporary file and a rename. A PNG is drawn with Pillow
    (:mod:`circuitnsds.output.raster_figure`, no matplotlib: ~0.1 s in all); other formats
    (PDF, SVG, ...) with matplotlib.

    Args:
        waves: the results.
        path: file to write.
        names: signals to draw; default: :func:`default_signals`.
        dpi: resolution of raster formats.
        events: mark each switching (``waves.events``) with a thin vertical line.

    Raises:
        PlotError: the extension names no figure format, or nothing to plot.
        KeyError: a name that is not a signal of ``waves``.
    """
    file_format = plot_format(path)
    chosen = default_signals(waves) if names is None else list(names)
    lowered = [n.strip().lower() for n in chosen]
    size = _size(len(_panels(lowered, _peaks(waves, lowered))))
    if file_format == "png":
        from circuitnsds.output.raster_figure import png_bytes

        content = png_bytes(figure_data(waves, chosen, events), size, dpi)
        with atomic_path(path) as temporary, open(temporary, "wb") as handle:
            handle.write(content)
        return
    from matplotlib.figure import Figure  # no pyplot: no backend, no screen needed

    figure = Figure(figsize=size, layout="constrained")
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
    lowered = [n.strip().lower() for n in chosen]
    figure = plt.figure(figsize=_size(len(_panels(lowered, _peaks(waves, lowered)))),
                        layout="constrained")
    draw(figure, waves, chosen, events)
    plt.show()
