"""The waveform figure as a PNG, drawn with Pillow: the figure of
:func:`circuitnsds.output.plot.draw` without importing matplotlib.

matplotlib's import takes ~0.4-0.9 s and its drawing and PNG ~0.2 s, more than a short run.
Pillow (a dependency of matplotlib, so always installed with it) imports in ~0.03 s. This
module lays out the same figure: panels stacked on a shared time axis, each with its unit
label, round ticks (:func:`nice_ticks`, steps 1, 2, 2.5 and 5 × 10^k as matplotlib's
default locator chooses them), a light grid, the legend at its right naming each trace
beside a stroke of its colour (matplotlib's default colour cycle), the title on top and the
optional switching marks (solid: closing, dotted: opening). Sizes are matplotlib's defaults
in points (10 pt text, 1 pt lines, 3.5 pt ticks), converted at the figure's dpi.

The lines inside each panel (grid, traces, switching marks) are painted at
:data:`SUPERSAMPLE` times the resolution and averaged down (antialiased lines): by the C
library ``_raster_native.c`` built at install (a canvas of palette indices, each segment
the rectangle of the points within half the line's width of it), else by Pillow's wide
lines; the two differ by rounding at the lines' edges. Text is FreeType's own
antialiasing, in DejaVu Sans (the font matplotlib ships and uses by default; Pillow's
default font if it is absent). A long signal is reduced to the
first, lowest, highest and last value in every drawn pixel column (:func:`min_max_decimate`),
which draws the same pixels: spikes and ringing are kept. Non-finite values (NaN, ±inf)
break the line, as in matplotlib, and do not set the axis limits.
"""

from __future__ import annotations

import ctypes
import math
import struct
import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from PIL import Image, ImageColor, ImageDraw, ImageFont

from circuitnsds.output.plot import FigureData, PlotError

COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
           "#7f7f7f", "#bcbd22", "#17becf")
"""matplotlib's default colour cycle ("tab10"), restarted in every panel."""

STEPS = (1.0, 2.0, 2.5, 5.0, 10.0)
"""Tick steps per decade (matplotlib's ``AutoLocator``)."""

SUPERSAMPLE = 3
"""Traces are drawn at this many times the resolution, then averaged down to it."""

GRID = (231, 231, 231)  # matplotlib's grid colour #b0b0b0 at alpha 0.3 over white
FRAME = (0, 0, 0)
TEXT = (0, 0, 0)
EVENT = (128, 128, 128)  # matplotlib's "0.5"

# sizes in points (1/72 inch), matplotlib's defaults
FONT_PT = 10.0          # tick labels, axis labels, title ("medium")
LEGEND_PT = 10.0 * 0.833  # "small"
LINE_PT = 1.0
FRAME_PT = 0.8
EVENT_PT = 0.4
TICK_PT = 3.5           # tick length and the gap from tick to label
EDGE_PT = 3.0           # constrained layout's padding at the figure's edge and between panels
LABEL_PAD_PT = 4.0      # axis label to tick labels
TITLE_PAD_PT = 6.0
MINUS = "\u2212"         # matplotlib writes negative ticks with a minus sign, not a hyphen


@lru_cache(maxsize=8)
def _font(size_px: float) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    """DejaVu Sans at ``size_px`` pixels per em, from matplotlib's folder (found without
    importing matplotlib); Pillow's default font if it is not there."""
    import importlib.util
    import os

    spec = importlib.util.find_spec("matplotlib")
    for folder in (spec.submodule_search_locations or []) if spec else []:
        path = os.path.join(folder, "mpl-data", "fonts", "ttf", "DejaVuSans.ttf")
        if os.path.exists(path):
            return ImageFont.truetype(path, size_px)
    return ImageFont.load_default(size_px)


def _has_minus(font) -> bool:
    """Whether ``font`` draws U+2212 (DejaVu does; a fallback font may show a box)."""
    return isinstance(font, ImageFont.FreeTypeFont) and "DejaVu" in (font.getname()[0] or "")


# ---------------------------------------------------------------------------- ticks


def nice_ticks(low: float, high: float, bins: int = 9) -> tuple[np.ndarray, float]:
    """Round ticks within ``[low, high]`` and their step: the smallest step of
    :data:`STEPS` × 10^k that makes at most ``bins`` intervals of the range, as matplotlib's
    ``MaxNLocator(nbins=bins, steps=[1, 2, 2.5, 5, 10])`` does. With ``bins`` from 6 to 9
    there are 3 to ``bins + 1`` ticks (consecutive steps differ by at most 2×).

    Returns:
        ``(ticks, step)``: the multiples of ``step`` in ``[low, high]`` (computed as
        integer × step, so ``0`` is exactly 0), ascending.
    """
    if not (math.isfinite(low) and math.isfinite(high)) or high <= low:
        raise ValueError(f"no ticks for the range [{low}, {high}]")
    raw = (high - low) / bins
    scale = 10.0 ** math.floor(math.log10(raw))
    tolerance = 1e-10 * max(abs(low), abs(high))  # ticks on an end are kept despite rounding
    for mantissa in STEPS + tuple(10 * s for s in STEPS[1:]):
        step = mantissa * scale
        if step < raw:  # strictly, as matplotlib: 1.0..1.02 in 8 bins (raw 0.0025000000000000022) steps 0.005
            continue
        first = math.ceil((low - tolerance) / step)
        last = math.floor((high + tolerance) / step)
        if last - first + 1 >= 2:
            break
    return np.arange(first, last + 1) * step, step


def tick_labels(ticks: np.ndarray, step: float, minus: str = MINUS) -> list[str]:
    """Tick labels with the decimals the step needs (``0, 20, 40``; ``0.00, 0.25``;
    ``1.5, 2.0``; ``3.3000025``), negative values with ``minus``; labels that would need
    more than 9 digits in scientific notation (``1.00000020e+09``, ``2.0e-10``)."""
    biggest = float(np.max(np.abs(ticks))) if ticks.size else 0.0
    decimals = next(d for d in range(0, 400) if abs(round(step, d) - step) <= 1e-9 * step)
    if decimals + len(f"{biggest:.0f}") <= 9:  # up to 9 digits: fixed notation
        texts = [f"{0.0 if abs(value) < step / 2 else value:.{decimals}f}" for value in ticks]
    else:  # the digits from the largest value's down to the step's, in scientific notation
        digits = max(1, math.floor(math.log10(max(biggest, step))) - math.floor(math.log10(step)) + 2)
        texts = [f"{value:.{digits - 1}e}" if abs(value) >= step / 2 else "0" for value in ticks]
    return [text.replace("-", minus) for text in texts]


def _limits(values: Sequence[np.ndarray], margin: float) -> tuple[float, float]:
    """Axis limits of the finite ``values`` with ``margin`` of their range added on each side
    (matplotlib's autoscaling: 5 % on y); a single value gets ±5 % of itself (±0.05 at 0)
    first, and no finite value at all gives (-1, 1)."""
    lows, highs = [], []
    for array in values:
        finite = array[np.isfinite(array)]
        if finite.size:
            lows.append(float(finite.min()))
            highs.append(float(finite.max()))
    if not lows:
        return -1.0, 1.0
    low, high = min(lows), max(highs)
    if high - low <= 1e-12 * max(abs(low), abs(high)):
        delta = 0.05 * abs(low) if low != 0 else 0.05
        low, high = low - delta, high + delta
    pad = margin * (high - low)
    return low - pad, high + pad


# ---------------------------------------------------------------------------- lines


def min_max_decimate(x: np.ndarray, y: np.ndarray, columns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(x, y)`` reduced to the first, lowest, highest and last point of each run of equal
    ``columns`` (the pixel column of each point; ascending), in that order: drawn as a
    connected line it covers the same pixels as all of the points, so every extreme
    (spike, ring) stays. Inputs must be finite."""
    if x.size <= 4:
        return x, y
    starts = np.flatnonzero(np.diff(columns)) + 1
    starts = np.concatenate(([0], starts))
    ends = np.concatenate((starts[1:], [x.size])) - 1
    lows = np.minimum.reduceat(y, starts)
    highs = np.maximum.reduceat(y, starts)
    xs = np.empty((starts.size, 4))
    ys = np.empty((starts.size, 4))
    xs[:, 0], ys[:, 0] = x[starts], y[starts]
    xs[:, 1], ys[:, 1] = x[starts], lows
    xs[:, 2], ys[:, 2] = x[ends], highs
    xs[:, 3], ys[:, 3] = x[ends], y[ends]
    return xs.ravel(), ys.ravel()


def _finite_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` of each run of ``True`` in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate(([False], mask, [False])).astype(np.int8)))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))


def _polyline(px: np.ndarray, py: np.ndarray, decimate: bool) -> tuple[np.ndarray, np.ndarray]:
    """The points to draw of one trace in pixels: each run of finite points reduced per
    pixel column when ``decimate``, the runs separated by a NaN, without the interior points
    of straight stretches (a point beside a NaN always stays)."""
    finite = np.isfinite(px) & np.isfinite(py)
    if decimate:
        xs, ys = [], []
        for start, stop in [(0, px.size)] if finite.all() else _finite_runs(finite):
            x, y = px[start:stop], py[start:stop]
            if x.size > 8:
                x, y = min_max_decimate(x, y, np.floor(x).astype(np.int64))
            xs += [x, [np.nan]]
            ys += [y, [np.nan]]
        if not xs:
            return px[:0], py[:0]
        px, py = np.concatenate(xs[:-1]), np.concatenate(ys[:-1])
    elif not finite.all():
        px, py = np.where(finite, px, np.nan), np.where(finite, py, np.nan)
    kept = points_to_draw(px, py)
    return px[kept], py[kept]


STRAIGHT_TOLERANCE = 1e-3
"""Pixels: a point this close to the straight segment between the points kept around it is
not drawn (:func:`points_to_draw`)."""


def points_to_draw(x: np.ndarray, y: np.ndarray, tolerance: float = STRAIGHT_TOLERANCE) -> np.ndarray:
    """Which points of the polyline ``(x, y)`` (pixels) to draw: not the interior points of
    its straight stretches. A point goes when it lies, within ``tolerance``, on the segment
    joining the nearest points kept before and after it: the line drawn covers the same
    pixels with fewer segments (an ideal diode's current is a straight zero for half of the
    bridge's period, and a wide line costs ~0.2 µs per segment in C, ~0.6 µs with Pillow). A
    point at a turn back (a spike along the line's own direction) is kept: it lies beyond the
    segment. Non-finite points, which break the line, and their neighbours are kept."""
    n = x.size
    kept = np.ones(n, dtype=bool)
    if n < 3:
        return kept
    kept[1:-1] = ~_on_segment(x[1:-1], y[1:-1], x[:-2], y[:-2], x[2:], y[2:], tolerance)
    dropped = ~kept
    if not dropped.any():
        return kept
    # each run of dropped points against the chord between the kept points around it: small
    # deviations from one neighbour to the next could add up along a gentle curve
    index = np.arange(n)
    left = np.maximum.accumulate(np.where(dropped, 0, index))
    right = np.minimum.accumulate(np.where(dropped, n - 1, index)[::-1])[::-1]
    runs = np.flatnonzero(dropped)
    before, after = left[runs], right[runs]
    off = ~_on_segment(x[runs], y[runs], x[before], y[before], x[after], y[after], tolerance)
    if off.any():  # a run that bends keeps all of its points
        bent = np.zeros(n, dtype=bool)
        bent[before[off]] = True
        kept[runs[bent[before]]] = True
    return kept


def _on_segment(x, y, x0, y0, x1, y1, tolerance: float) -> np.ndarray:
    """Whether each point ``(x, y)`` lies within ``tolerance`` of the segment from
    ``(x0, y0)`` to ``(x1, y1)`` (arrays of one length), between its ends."""
    chord_x, chord_y = x1 - x0, y1 - y0
    offset_x, offset_y = x - x0, y - y0
    length_squared = chord_x * chord_x + chord_y * chord_y
    along = chord_x * offset_x + chord_y * offset_y
    cross = chord_x * offset_y - chord_y * offset_x
    return ((cross * cross <= tolerance * tolerance * length_squared)
            & (along >= 0.0) & (along <= length_squared) & (length_squared > 0.0))


# ---------------------------------------------------------------------------- layout


@dataclass
class _Box:
    """An axes rectangle in pixels: the frame's lines are on columns ``left``, ``right``
    and rows ``top``, ``bottom``."""

    left: int
    top: int
    right: int
    bottom: int


def _text_size(font, text: str) -> tuple[int, int]:
    left, top, right, bottom = font.getbbox(text)
    return right - left, bottom - top


def _line_height(font) -> int:
    if isinstance(font, ImageFont.FreeTypeFont):
        ascent, descent = font.getmetrics()
        return ascent + descent
    return _text_size(font, "Ag")[1]


def _draw_text(draw: ImageDraw.ImageDraw, xy: tuple[float, float], text: str, font, anchor: str) -> None:
    draw.text((round(xy[0]), round(xy[1])), text, fill=TEXT, font=font, anchor=anchor)


def _vertical_text(image: Image.Image, centre: tuple[float, float], text: str, font) -> None:
    """``text`` turned a quarter left (reading upwards), centred on ``centre``."""
    width, _ = _text_size(font, text)
    height = _line_height(font)
    label = Image.new("L", (width + 4, height + 4), 0)
    ImageDraw.Draw(label).text(((width + 4) / 2, (height + 4) / 2), text, fill=255, font=font,
                               anchor="mm")
    label = label.rotate(90, expand=True)
    corner = (round(centre[0] - label.width / 2), round(centre[1] - label.height / 2))
    image.paste(TEXT, (*corner, corner[0] + label.width, corner[1] + label.height), label)


def png_bytes(data: FigureData, size: tuple[float, float], dpi: float = 120) -> bytes:
    """The PNG of ``data`` at ``size`` inches (width, height) and ``dpi`` dots per inch."""
    return encode_png(render(data, size, dpi), dpi)


def render(data: FigureData, size: tuple[float, float], dpi: float = 120) -> Image.Image:
    """The figure of ``data`` as an RGB image of ``size`` inches at ``dpi``."""
    pt = dpi / 72.0  # pixels per point
    width, height = round(size[0] * dpi), round(size[1] * dpi)
    image = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(image)
    font = _font(FONT_PT * pt)
    legend_font = _font(LEGEND_PT * pt)
    minus = MINUS if _has_minus(font) else "-"
    text_height = _line_height(font)
    edge, tick, pad = EDGE_PT * pt, TICK_PT * pt, TICK_PT * pt

    # y limits and ticks per panel first: the left margin is the widest tick label's
    y_limits = [_limits([v for _, v in panel.traces], 0.05) for panel in data.panels]
    top = edge + text_height + TITLE_PAD_PT * pt
    bottom_margin = edge + text_height + LABEL_PAD_PT * pt + text_height + pad + tick
    gap = tick + 2 * edge  # between panels: the upper one's ticks and paddings
    count = len(data.panels)
    panel_height = (height - top - bottom_margin - gap * (count - 1)) / count
    y_bins = int(np.clip(panel_height / (2 * FONT_PT * pt), 3, 9))
    y_ticks = []
    for low, high in y_limits:
        ticks, step = nice_ticks(low, high, y_bins)
        y_ticks.append((ticks, tick_labels(ticks, step, minus)))
    widest = max((_text_size(font, t)[0] for _, labels in y_ticks for t in labels), default=0)
    left = edge + text_height + LABEL_PAD_PT * pt + widest + pad + tick

    # the legends: one column per panel unless its entries are taller than the panel
    em = LEGEND_PT * pt
    row = max(_line_height(legend_font), 0.7 * em) + 0.5 * em
    rows = max(1, int((panel_height + gap) // row))
    legend_widths = []
    for panel in data.panels:
        columns = math.ceil(len(panel.traces) / rows)
        names = [name for name, _ in panel.traces]
        column_widths = [max(_text_size(legend_font, n)[0] for n in names[c * rows:(c + 1) * rows])
                         for c in range(columns)]
        legend_widths.append(sum(0.4 * em + 2.0 * em + 0.8 * em + w for w in column_widths)
                             + 2.0 * em * (columns - 1) + 0.4 * em)
    axes_width = (width - left - max(legend_widths) - edge) / 1.01
    if axes_width < 0.1 * width:  # the legends would leave the traces no room
        crowded = max(len(panel.traces) for panel in data.panels)
        raise PlotError(f"too many signals for one figure: {crowded} in a panel, whose legend "
                        "leaves the traces less than a tenth of the figure's width",
                        hint="choose fewer with --signals (or write a CSV and plot it yourself)")
    x_left, x_right = int(round(left)), int(round(left + axes_width))

    # the time axis: as many round ticks as fit without their labels touching
    x_low, x_high = ((float(data.time[0]), float(data.time[-1])) if data.time.size else (0.0, 1.0))
    if not (math.isfinite(x_low) and math.isfinite(x_high)) or x_high <= x_low:
        x_low, x_high = _limits([np.array([x_low, x_high])], 0.0)
    for x_bins in range(int(np.clip(axes_width / (3 * FONT_PT * pt), 1, 9)), 0, -1):
        x_ticks, x_step = nice_ticks(x_low, x_high, x_bins)
        x_labels = tick_labels(x_ticks, x_step, minus)
        label_width = max(_text_size(font, t)[0] for t in x_labels)
        spacing = (x_right - x_left) * x_step / (x_high - x_low)
        if label_width + FONT_PT * pt <= spacing:
            break

    boxes = []
    for index in range(count):
        box_top = top + index * (panel_height + gap)
        boxes.append(_Box(x_left, int(round(box_top)), x_right, int(round(box_top + panel_height))))

    def x_pixel(value, box):  # data -> pixel coordinate (pixel i spans [i, i + 1))
        return box.left + 0.5 + (value - x_low) / (x_high - x_low) * (box.right - box.left)

    def y_pixel(value, box, limits):
        low, high = limits
        return box.top + 0.5 + (high - value) / (high - low) * (box.bottom - box.top)

    for box, panel, limits, (ticks, labels) in zip(boxes, data.panels, y_limits, y_ticks):
        strokes = _panel_strokes(box, panel, data, limits, ticks, x_ticks, x_pixel, y_pixel, pt)
        image.paste(_paint(strokes, box.right - box.left + 1, box.bottom - box.top + 1), (box.left, box.top))
        # the frame, ticks and labels, crisp at the final resolution
        frame = max(1, round(FRAME_PT * pt))
        draw.rectangle((box.left, box.top, box.right, box.bottom), outline=FRAME, width=frame)
        for value, label in zip(ticks, labels):
            y = round(y_pixel(value, box, limits) - 0.5)
            draw.line((box.left - tick, y, box.left, y), fill=FRAME, width=frame)
            _draw_text(draw, (box.left - tick - pad, y), label, font, "rm")
        for value in x_ticks:
            x = round(x_pixel(value, box) - 0.5)
            draw.line((x, box.bottom, x, box.bottom + tick), fill=FRAME, width=frame)
        _vertical_text(image, (edge + text_height / 2, (box.top + box.bottom) / 2), panel.ylabel, font)
        _draw_legend(draw, box, panel, legend_font, rows, pt)
    last = boxes[-1]
    for value, label in zip(x_ticks, x_labels):
        x = round(x_pixel(value, last) - 0.5)
        _draw_text(draw, (x, last.bottom + tick + pad), label, font, "mt")
    _draw_text(draw, ((last.left + last.right) / 2, height - edge), data.xlabel, font, "md")
    first = boxes[0]
    _draw_text(draw, ((first.left + first.right) / 2, first.top - TITLE_PAD_PT * pt), data.title,
               font, "md")
    return image


class Stroke(NamedTuple):
    """A line to paint inside a panel: through the points ``(x[k], y[k])`` in supersampled
    pixels from the panel's top left corner (subpixel k spans [k, k + 1)), ``width``
    subpixels wide, in ``colour``. A non-finite point breaks it; a run of a single point
    (or of copies of one point) is a dot as wide as the line."""

    x: np.ndarray
    y: np.ndarray
    width: float
    colour: tuple[int, int, int] | str  # RGB, or a colour name Pillow knows ("#1f77b4")


def _panel_strokes(box, panel, data, limits, y_ticks, x_ticks, x_pixel, y_pixel, pt) -> list[Stroke]:
    """Grid, traces and switching marks of one panel, in painting order, at
    :data:`SUPERSAMPLE` times the resolution."""
    s = SUPERSAMPLE
    width, height = box.right - box.left + 1, box.bottom - box.top + 1

    def sx(pixels):  # final pixel coordinate -> supersampled coordinate
        return (pixels - box.left) * s

    def sy(pixels):
        return (pixels - box.top) * s

    grid = max(1, round(FRAME_PT * pt * s))
    rows = sy(y_pixel(np.asarray(y_ticks, dtype=float), box, limits))
    columns = sx(x_pixel(np.asarray(x_ticks, dtype=float), box))
    strokes = [_segments(np.zeros_like(rows), rows, np.full_like(rows, width * s), rows, grid, GRID),
               _segments(columns, np.zeros_like(columns), columns, np.full_like(columns, height * s),
                         grid, GRID)]
    line = max(1, round(LINE_PT * pt * s))
    time = sx(x_pixel(data.time, box)) if data.time.size else data.time
    monotonic = time.size < 2 or bool(np.all(np.diff(time) >= 0))
    decimate = monotonic and time.size > 2 * width * s
    for index, (_, values) in enumerate(panel.traces):
        strokes.append(Stroke(*_polyline(time, sy(y_pixel(values, box, limits)), decimate), line,
                              COLOURS[index % len(COLOURS)]))
    if data.events:
        strokes.extend(_event_strokes(data, box, x_pixel, sx, height * s, pt))
    return strokes


def _segments(x0, y0, x1, y1, width: float, colour) -> Stroke:
    """Separate segments from ``(x0, y0)`` to ``(x1, y1)`` (arrays) as one stroke: each
    pair of points followed by a NaN break."""
    x = np.column_stack((x0, x1, np.full_like(x0, np.nan))).ravel()
    y = np.column_stack((y0, y1, np.full_like(y0, np.nan))).ravel()
    return Stroke(x, y, width, colour)


def _event_strokes(data, box, x_pixel, sx, height, pt) -> list[Stroke]:
    """The switching marks: a thin line per supersampled column holding one (solid for a
    closing, dotted for an opening; a closing wins a shared column)."""
    times = np.array([t for t, _ in data.events], dtype=float)
    closed = np.array([c for _, c in data.events], dtype=bool)
    columns = np.round(sx(x_pixel(times, box)))
    width = max(1, round(EVENT_PT * pt * SUPERSAMPLE))
    solid = np.unique(columns[closed])
    dotted = np.setdiff1d(np.unique(columns[~closed]), solid)
    dash = max(1, round(1.5 * pt * SUPERSAMPLE))
    starts = np.arange(0, height, 2 * dash, dtype=float)
    dot_x = np.repeat(dotted, starts.size)
    dot_y = np.tile(starts, dotted.size)
    return [_segments(solid, np.zeros_like(solid), solid, np.full_like(solid, height), width, EVENT),
            _segments(dot_x, dot_y, dot_x, dot_y + dash, width, EVENT)]


def _paint(strokes: list[Stroke], width: int, height: int) -> Image.Image:
    """The ``width`` × ``height`` pixel image of ``strokes`` on white: painted at
    :data:`SUPERSAMPLE` times the resolution, in order, then averaged down (antialiasing).
    In C (``_raster_native.c``) when it is built, else with Pillow's wide lines."""
    s = SUPERSAMPLE
    palette = {(255, 255, 255): 0}  # RGB -> index in the canvas (0: the background)
    indices = [palette.setdefault(ImageColor.getrgb(stroke.colour) if isinstance(stroke.colour, str)
                                  else stroke.colour, len(palette)) for stroke in strokes]
    paint = _native_painter()
    if paint is None or len(palette) > 256:  # (more colours than a byte indexes: Pillow)
        return _paint_pillow(strokes, width * s, height * s).reduce(s)
    polyline, reduce = paint
    canvas = np.zeros((height * s, width * s), dtype=np.uint8)
    for stroke, colour in zip(strokes, indices):
        x = np.ascontiguousarray(stroke.x, dtype=np.float64)
        y = np.ascontiguousarray(stroke.y, dtype=np.float64)
        if x.size:
            polyline(canvas.ctypes.data, width * s, height * s, x.ctypes.data, y.ctypes.data, x.size,
                     stroke.width / 2, colour)
    colours = np.zeros((256, 3), dtype=np.uint8)
    colours[list(palette.values())] = list(palette)
    pixels = np.empty((height, width, 3), dtype=np.uint8)
    reduce(canvas.ctypes.data, width * s, height * s, s, colours.ctypes.data, pixels.ctypes.data)
    return Image.fromarray(pixels, "RGB")


def _paint_pillow(strokes: list[Stroke], width: int, height: int) -> Image.Image:
    """``strokes`` painted with Pillow's wide lines on a ``width`` × ``height`` white image
    (Pillow puts pixel k's centre at k: the points move by half a subpixel to get there)."""
    layer = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(layer)
    for stroke in strokes:
        finite = np.isfinite(stroke.x) & np.isfinite(stroke.y)
        for start, stop in _finite_runs(finite):
            x, y = stroke.x[start:stop] - 0.5, stroke.y[start:stop] - 0.5
            if (x == x[0]).all() and (y == y[0]).all():  # a lone point: a dot of the line's width
                r = stroke.width / 2
                draw.ellipse((x[0] - r, y[0] - r, x[0] + r, y[0] + r), fill=stroke.colour)
            else:
                draw.line(np.column_stack((x, y)).ravel().tolist(), fill=stroke.colour,
                          width=round(stroke.width))
    return layer


@lru_cache(maxsize=1)
def _native_painter():
    """The C painter's two functions (polyline, reduce), or ``None`` when the library is
    not built."""
    from circuitnsds import native

    pointer, size = ctypes.c_void_p, ctypes.c_int64
    polyline = native.function(NATIVE, "circuitnsds_raster_polyline",
                               [pointer, size, size, pointer, pointer, size, ctypes.c_double, ctypes.c_uint8],
                               None)
    reduce = native.function(NATIVE, "circuitnsds_raster_reduce",
                             [pointer, size, size, size, pointer, pointer], None)
    return None if polyline is None or reduce is None else (polyline, reduce)


NATIVE = "output/_raster_native"
"""The C painter's library (:func:`circuitnsds.native.library`), built from ``_raster_native.c``."""


def _draw_legend(draw, box, panel, font, rows, pt) -> None:
    """Each trace's name beside a stroke of its colour, right of the panel, centred on it."""
    em = LEGEND_PT * pt
    row = max(_line_height(font), 0.7 * em) + 0.5 * em
    names = [name for name, _ in panel.traces]
    shown_rows = min(rows, len(names))
    first_y = (box.top + box.bottom) / 2 - (shown_rows - 1) * row / 2
    x = box.right + 0.01 * (box.right - box.left) + 0.4 * em
    line = max(1, round(LINE_PT * pt))
    for column in range(math.ceil(len(names) / rows)):
        chunk = names[column * rows:(column + 1) * rows]
        for place, name in enumerate(chunk):
            index = column * rows + place
            y = first_y + place * row
            draw.line((round(x), round(y), round(x + 2.0 * em), round(y)),
                      fill=COLOURS[index % len(COLOURS)], width=line)
            _draw_text(draw, (x + 2.8 * em, y), name, font, "lm")
        x += 2.8 * em + max(_text_size(font, n)[0] for n in chunk) + 2.0 * em


def encode_png(image: Image.Image, dpi: float = 120) -> bytes:
    """``image`` (RGB) as PNG bytes, with its dpi recorded (a ``pHYs`` chunk, as matplotlib
    records it). Written here rather than by Pillow's ``save``: every row with filter type 0
    (none) and zlib at level 3. Pillow tries the five PNG filters on each row and imports its
    five default format plugins on the first save; on the bridge's 1200 × 768 figure its
    ``save`` took 22 ms (39 ms the first time in a process) for 83 kB, this 7 ms for 79 kB
    (``benchmarks/png_encoding.py``)."""
    if image.mode != "RGB":
        image = image.convert("RGB")
    width, height = image.size
    rows = np.empty((height, 1 + 3 * width), dtype=np.uint8)
    rows[:, 0] = 0  # each row's filter type: none
    rows[:, 1:] = np.frombuffer(image.tobytes(), dtype=np.uint8).reshape(height, 3 * width)
    per_metre = round(dpi / 0.0254)
    return b"".join((
        PNG_SIGNATURE,
        _chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)),  # 8-bit RGB
        _chunk(b"pHYs", struct.pack(">IIB", per_metre, per_metre, 1)),  # unit 1: the metre
        _chunk(b"IDAT", zlib.compress(rows.tobytes(), 3)),
        _chunk(b"IEND", b""),
    ))


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _chunk(kind: bytes, payload: bytes) -> bytes:
    """One PNG chunk: length, type, payload, CRC-32 of type and payload."""
    return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(kind + payload))
