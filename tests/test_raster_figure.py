"""The PNG figure drawn with Pillow: traces where the data says, round ticks, extremes kept by
the column reduction, non-finite values skipped, and the command writing it without
importing matplotlib."""

import io
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from circuitnsds.output import raster_figure
from circuitnsds.output.plot import PlotError, _size, plot_waveforms
from circuitnsds.output.raster_figure import (
    encode_png,
    min_max_decimate,
    nice_ticks,
    points_to_draw,
    tick_labels,
)
from circuitnsds.output.waveforms import Waveforms
from tests.conftest import NETLISTS

ROOT = Path(__file__).resolve().parents[1]
BLUE, ORANGE = (0x1F, 0x77, 0xB4), (0xFF, 0x7F, 0x0E)  # matplotlib's first two colours


@pytest.fixture(params=["C", "Pillow"])
def painter(request, monkeypatch):
    """The figure's lines painted by the C library (built at install) and by the Pillow
    fallback an install without a compiler uses: every figure test runs with both."""
    if request.param == "Pillow":
        monkeypatch.setattr(raster_figure, "_native_painter", lambda: None)
    else:
        assert raster_figure._native_painter() is not None, "the C painter is not built"
    return request.param


def _image(tmp_path, waves, names=None, events=False) -> np.ndarray:
    path = tmp_path / "f.png"
    plot_waveforms(waves, path, names, events=events)
    with Image.open(path) as image:
        assert image.format == "PNG"
        return np.asarray(image.convert("RGB")).astype(int)


def _longest_runs(mask: np.ndarray) -> np.ndarray:
    """Length of the longest run of ``True`` along each column of ``mask``."""
    runs = np.zeros(mask.shape, dtype=int)
    runs[0] = mask[0]
    for row in range(1, mask.shape[0]):
        runs[row] = (runs[row - 1] + 1) * mask[row]
    return runs.max(axis=0)


def _frame(pixels: np.ndarray, panel: int = 0) -> tuple[int, int, int, int]:
    """Left, top, right, bottom pixel of the ``panel``-th axes frame, found as the long
    unbroken black lines of the image (not from the drawing code's layout)."""
    black = pixels.sum(axis=2) < 60
    columns = np.flatnonzero(_longest_runs(black) > 100)
    rows_all = np.flatnonzero(_longest_runs(black.T) > 0.5 * pixels.shape[1])
    left, right = columns.min(), columns.max()
    rows = [r for r in rows_all if r - 1 not in rows_all]  # the first row of each thick line
    return left, rows[2 * panel], right, rows[2 * panel + 1]


def _near(pixels, colour, row, column, tolerance=2) -> bool:
    window = pixels[row - tolerance:row + tolerance + 1, column]
    return bool(np.any(np.abs(window - np.array(colour)).sum(axis=1) < 60))


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 40), st.integers(1, 40), st.integers(0, 2**32 - 1), st.sampled_from([72, 96, 120, 300]),
       st.sampled_from(["RGB", "L", "RGBA"]))
def test_encoded_png_decodes_to_the_same_pixels_and_dpi(width, height, seed, dpi, mode):
    """Our PNG writer against Pillow's decoder: every pixel back, the dpi recorded (within
    the rounding of pixels per metre), any image mode written as RGB."""
    channels = {"RGB": 3, "L": 1, "RGBA": 4}[mode]
    pixels = np.random.default_rng(seed).integers(0, 256, (height, width, channels), dtype=np.uint8)
    image = Image.fromarray(pixels[:, :, 0] if mode == "L" else pixels, mode)
    with Image.open(io.BytesIO(encode_png(image, dpi))) as decoded:
        decoded.load()  # checks every chunk's CRC and the zlib stream
        assert decoded.format == "PNG" and decoded.mode == "RGB" and decoded.size == (width, height)
        assert np.array_equal(np.asarray(decoded), np.asarray(image.convert("RGB")))
        assert decoded.info["dpi"] == pytest.approx((dpi, dpi), abs=0.5 * 0.0254)  # whole px per metre


def test_size_is_matplotlibs_at_120_dpi(tmp_path, painter):
    time = np.linspace(0, 1e-3, 11)
    one = Waveforms(time, {"v(a)": time})
    assert _image(tmp_path, one).shape[:2] == (round(_size(1)[1] * 120), 1200)
    two = Waveforms(time, {"v(a)": time, "i(b)": time})
    assert _image(tmp_path, two).shape[:2] == (768, 1200)  # 10 x 6.4 inches


def test_traces_are_where_the_axis_limits_put_them(tmp_path, painter):
    """A constant 1 V and a ramp 0 -> 2 V over 0..1 s: the y axis spans the data with 5 %
    margins (-0.1 .. 2.1 V, as matplotlib autoscales), the x axis the run."""
    time = np.linspace(0.0, 1.0, 201)
    pixels = _image(tmp_path, Waveforms(time, {"v(one)": np.ones_like(time), "v(ramp)": 2 * time}))
    left, top, right, bottom = _frame(pixels)
    row_of = lambda volts: round(top + (2.1 - volts) / 2.2 * (bottom - top))  # noqa: E731
    for fraction in (0.1, 0.3, 0.7, 0.9):  # (the ramp is drawn over the constant at 0.5)
        column = round(left + fraction * (right - left))
        assert _near(pixels, BLUE, row_of(1.0), column)
        assert not _near(pixels, BLUE, row_of(1.0) - 6, column)
        assert _near(pixels, ORANGE, row_of(2 * fraction), column)


def test_non_finite_values_break_the_line_and_do_not_set_the_limits(tmp_path, painter):
    time = np.linspace(0.0, 1.0, 301)
    values = np.ones_like(time)
    values[100:200] = np.nan  # a gap over the middle third
    values[50] = np.inf
    values[250] = -np.inf
    pixels = _image(tmp_path, Waveforms(time, {"v(a)": values, "v(b)": 2 * time}))
    left, top, right, bottom = _frame(pixels)
    row = round(top + (2.1 - 1.0) / 2.2 * (bottom - top))  # limits from the finite values only
    column = lambda fraction: round(left + fraction * (right - left))  # noqa: E731
    assert _near(pixels, BLUE, row, column(0.1)) and _near(pixels, BLUE, row, column(0.9))
    for fraction in (0.4, 0.5, 0.6):
        assert not np.any(np.abs(pixels[top + 2:bottom - 1, column(fraction)]
                                 - np.array(BLUE)).sum(axis=1) < 60)


def test_samples_between_non_finite_values_are_dots(tmp_path, painter):
    """A trace whose every other sample is NaN (no two finite samples side by side): each
    finite sample is still drawn, as a dot where it lies, and nothing joins them."""
    time = np.linspace(0.0, 1.0, 11)
    values = 2 * time
    values[1::2] = np.nan  # finite at t = 0, 0.2, ..., 1
    pixels = _image(tmp_path, Waveforms(time, {"v(a)": values}))
    left, top, right, bottom = _frame(pixels)
    row_of = lambda volts: round(top + (2.1 - volts) / 2.2 * (bottom - top))  # noqa: E731
    column = lambda fraction: round(left + fraction * (right - left))  # noqa: E731
    tint = pixels[..., 2] - pixels[..., 0]  # blue over white, antialiased: blue above red
    for fraction in (0.2, 0.4, 0.6, 0.8):
        row, col = row_of(2 * fraction), column(fraction)
        assert tint[row - 2:row + 3, col - 2:col + 3].max() > 40, fraction
    for fraction in (0.3, 0.5, 0.7):  # between two dots: no line
        assert not np.any(np.abs(pixels[top + 2:bottom - 1, column(fraction)]
                                 - np.array(BLUE)).sum(axis=1) < 60)


def test_switching_marks(tmp_path, painter):
    time = np.linspace(0.0, 1.0, 101)
    waves = Waveforms(time, {"v(a)": time}, events=[(0.5, "s1", True)])
    pixels = _image(tmp_path, waves, events=True)
    left, top, right, bottom = _frame(pixels)
    column = round(left + 0.5 * (right - left))
    middle = pixels[top + 5:bottom - 5, column - 1:column + 2]
    grey = np.all(np.abs(middle - middle.mean(axis=2, keepdims=True)) < 8, axis=2) & (middle[..., 0] < 215)
    assert grey.any(axis=1).mean() > 0.8  # a grey vertical line through the panel
    assert not np.array_equal(pixels, _image(tmp_path, waves))


@pytest.mark.parametrize("signals", [
    {"v(a)": np.array([1.0])},                                   # one sample
    {"v(a)": np.full(50, 3.3)},                                  # constant
    {"v(a)": np.zeros(50)},                                      # constant zero
    {"v(a)": np.full(50, np.nan)},                               # nothing finite
    {f"v(n{k})": np.sin(np.arange(50) / (k + 1)) for k in range(40)},  # many traces
])
def test_degenerate_signals_give_a_figure(tmp_path, signals, painter):
    size = next(iter(signals.values())).size
    time = -1e-3 + np.arange(size) * 1e-6  # negative times
    pixels = _image(tmp_path, Waveforms(time, signals))
    assert pixels.shape[:2] == (round(_size(1)[1] * 120), 1200)
    assert pixels[:, -1].sum() == 255 * 3 * pixels.shape[0]  # nothing drawn over the edge


STEP_MANTISSAS = (1.0, 2.0, 2.5, 5.0)


def _mantissa(step: float) -> float:
    return step / 10.0 ** math.floor(math.log10(step) + 1e-9)


@settings(max_examples=300, deadline=None)
@given(low=st.floats(-1e6, 1e6), width=st.floats(1e-6, 1e6), bins=st.integers(6, 9))
def test_ticks_are_round_and_cover_the_range(low, width, bins):
    high = low + width
    if not high - low > 1e-9 * max(abs(low), abs(high)):
        return
    ticks, step = nice_ticks(low, high, bins)
    assert any(abs(_mantissa(step) - m) < 1e-6 for m in STEP_MANTISSAS)
    assert 3 <= ticks.size <= bins + 1
    tolerance = 1e-9 * max(abs(low), abs(high), step)
    assert ticks[0] >= low - tolerance and ticks[-1] <= high + tolerance
    assert ticks[0] - step < low + tolerance and ticks[-1] + step > high - tolerance  # all of them
    assert step >= (high - low) / bins * (1 - 1e-9)  # at most `bins` intervals
    labels = tick_labels(ticks, step)
    assert len(set(labels)) == len(labels)  # distinct labels
    for label, value in zip(labels, ticks):
        assert float(label.replace("\u2212", "-")) == pytest.approx(value, abs=step * 1e-6)


@settings(max_examples=200, deadline=None)
@given(low=st.floats(-1e4, 1e4), width=st.floats(1e-3, 1e4), bins=st.integers(6, 9))
def test_tick_steps_are_matplotlibs(low, width, bins):
    from matplotlib.ticker import MaxNLocator

    high = low + width
    if abs(low) > 1e3 * width:  # matplotlib then ticks an offset from a large value
        return
    expected = MaxNLocator(nbins=bins, steps=[1, 2, 2.5, 5, 10]).tick_values(low, high)
    _, step = nice_ticks(low, high, bins)
    assert step == pytest.approx(expected[1] - expected[0], rel=1e-9)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=400), st.integers(1, 50))
def test_decimation_keeps_every_extreme(values, per_column):
    y = np.array(values)
    x = np.arange(y.size, dtype=float) / per_column
    columns = np.floor(x).astype(np.int64)
    dx, dy = min_max_decimate(x, y, columns)
    assert dy.size <= max(4 * (columns[-1] + 1), y.size)
    assert (dx[0], dy[0], dx[-1], dy[-1]) == (x[0], y[0], x[-1], y[-1])
    for column in np.unique(columns):
        inside = columns == column
        kept = np.floor(dx).astype(np.int64) == column
        assert dy[kept].min() == y[inside].min() and dy[kept].max() == y[inside].max()
    assert np.all(np.diff(dx) >= 0)


def test_a_spike_in_a_long_signal_is_drawn(tmp_path, painter):
    """A million samples, one of them a spike to 5 V over a 1 V sine: the spike reaches the
    row of 5 V (the top of the data, 5 % under the frame)."""
    time = np.linspace(0.0, 1.0, 1_000_001)
    values = np.sin(2 * np.pi * 5 * time)
    values[400_000] = 5.0
    pixels = _image(tmp_path, Waveforms(time, {"v(a)": values}))
    left, top, right, bottom = _frame(pixels)
    row = round(top + 0.05 / 1.1 * (bottom - top))
    column = round(left + 0.4 * (right - left))
    assert any(_near(pixels, BLUE, row, c) for c in range(column - 1, column + 2))


def _run(*arguments, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "circuitnsds", *map(str, arguments)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


def test_command_writes_the_png_without_matplotlib(tmp_path):
    code = ("import sys; from circuitnsds.cli.main import main; "
            f"status = main(['run', {str(NETLISTS / 'zener_regulator.cir')!r}, '-o', 'z.csv', "
            "'--plot', 'z.png', '-q']); print(status, 'matplotlib' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=120)
    assert done.stdout.split() == ["0", "False"], done.stderr
    with Image.open(tmp_path / "z.png") as image:
        assert image.size == (1200, 768)
    # the figure of the results written to the CSV, drawn in this process
    data = np.genfromtxt(tmp_path / "z.csv", delimiter=",", names=True, deletechars="")
    header = (tmp_path / "z.csv").read_text().splitlines()[0].split(",")
    title = NETLISTS.joinpath("zener_regulator.cir").read_text().splitlines()[0]
    waves = Waveforms(data[header[0]], {name: data[name] for name in header[1:]}, title=title)
    plot_waveforms(waves, tmp_path / "here.png")
    assert (tmp_path / "here.png").read_bytes() == (tmp_path / "z.png").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["here.png", "z.csv", "z.png"]


def test_unwritable_figure_is_the_usual_error(tmp_path):
    done = _run("run", NETLISTS / "zener_regulator.cir", "-o", tmp_path / "z.csv", "--plot",
                tmp_path / "missing" / "z.png", "-q", cwd=tmp_path)
    assert done.returncode == 1
    assert "cannot write" in done.stderr and "Traceback" not in done.stderr
    # refused before the run (issue 37): no CSV beside a missing figure, no result computed and lost
    assert "does not exist" in done.stderr and not (tmp_path / "z.csv").exists()


def _distance_to_polyline(px: np.ndarray, py: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Distance of each point (px, py) to the nearest segment of the polyline (x, y)."""
    x0, y0, dx, dy = x[:-1], y[:-1], np.diff(x), np.diff(y)
    length = dx * dx + dy * dy
    t = np.clip(((px[:, None] - x0) * dx + (py[:, None] - y0) * dy) / np.where(length > 0, length, 1), 0, 1)
    return np.hypot(px[:, None] - (x0 + t * dx), py[:, None] - (y0 + t * dy)).min(axis=1)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 3), st.integers(-3, 3), st.integers(1, 6)), min_size=1, max_size=12),
       st.integers(0, 2**32 - 1))
def test_points_dropped_from_a_line_lie_on_what_is_drawn(pieces, seed):
    """Straight pieces (slope, run length), with repeated points, turns back and tiny noise:
    every point left out is within the tolerance of the line drawn through the points
    kept, the ends are kept, and a turn back (a point beyond the straight stretch) is kept."""
    rng = np.random.default_rng(seed)
    x, y = [0.0], [0.0]
    for kind, slope, count in pieces:
        for _ in range(count):
            step = (0.0, 0.0) if kind == 0 else (1.0, float(slope)) if kind < 3 else (-1.0, 0.5 * slope)
            x.append(x[-1] + step[0])
            y.append(y[-1] + step[1] + rng.uniform(-1e-5, 1e-5))
    x, y = np.array(x), np.array(y)
    kept = points_to_draw(x, y)
    assert kept[0] and kept[-1]
    if x.size > 1:
        assert _distance_to_polyline(x, y, x[kept], y[kept]).max() <= 1e-3 + 1e-12


def test_a_gentle_curve_keeps_its_points():
    """A circle's arc sampled so finely that every point is within the tolerance of its two
    neighbours' chord: the line must still follow the arc (the run is checked against the
    chord between the points kept around it)."""
    angle = np.linspace(0.0, 0.5, 2001)
    x, y = 100.0 * np.cos(angle), 100.0 * np.sin(angle)
    kept = points_to_draw(x, y)
    assert _distance_to_polyline(x, y, x[kept], y[kept]).max() <= 1e-3
    flat = np.linspace(0.0, 50.0, 501)
    assert points_to_draw(flat, 0.0 * flat).sum() == 2  # a straight line: its ends


def test_more_colours_than_a_palette_holds(painter):
    """300 strokes of 300 colours (the C canvas indexes 255 besides the background): each
    one still painted in its own colour, a vertical line filling exactly one pixel column."""
    s = raster_figure.SUPERSAMPLE
    colours = [(k % 256, (7 * k) % 256, 255 - k % 200) for k in range(300)]
    strokes = [raster_figure.Stroke(np.array([s * k + s / 2] * 2), np.array([0.0, 4.0 * s]), s, colour)
               for k, colour in enumerate(colours)]
    pixels = np.asarray(raster_figure._paint(strokes, 300, 4))
    assert np.array_equal(pixels, np.broadcast_to(np.array(colours, dtype=np.uint8), (4, 300, 3)))


def test_a_non_finite_point_and_its_neighbours_stay_in_a_straight_line():
    x = np.arange(9.0)
    y = np.array([0, 0, 0, 0, np.nan, 0, 0, 0, 0], dtype=float)
    kept = points_to_draw(x, y)
    assert kept.tolist() == [True, False, False, True, True, True, False, False, True]


def test_a_legend_that_leaves_no_room_is_a_clear_error(tmp_path):
    """140 traces in one panel: their legend's columns would take the figure's width."""
    time = np.linspace(0.0, 1.0, 20)
    signals = {f"v(n{k})": (k + 100) * time for k in range(140)}  # (one scale: one panel)
    with pytest.raises(PlotError, match="too many signals for one figure: 140 in a panel"):
        plot_waveforms(Waveforms(time, signals), tmp_path / "f.png", list(signals))
    assert not (tmp_path / "f.png").exists()
