"""The figure's C painter (circuitnsds/output/_raster_native.c) against the geometry it
promises: a segment of a line of width 2r paints exactly the subpixels whose centres lie
within r of it across and between its ends, a lone point a disc, NaN breaks a line, later
lines cover earlier ones, and the reduction averages each block's palette colours (checked
against numpy)."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from circuitnsds.output import raster_figure
from tests.conftest import assert_native_library_current

WIDTH, HEIGHT = 40, 30
EDGE = 1e-7  # centres this close to the shape's edge may go either way


@pytest.fixture(scope="module")
def painter():
    assert_native_library_current(raster_figure.NATIVE)
    functions = raster_figure._native_painter()
    assert functions is not None
    return functions


def _paint(painter, x, y, half_width, colour=1, canvas=None):
    polyline, _ = painter
    canvas = np.zeros((HEIGHT, WIDTH), dtype=np.uint8) if canvas is None else canvas
    x, y = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(y, dtype=float)
    polyline(canvas.ctypes.data, WIDTH, HEIGHT, x.ctypes.data, y.ctypes.data, x.size, half_width, colour)
    return canvas


def _centres():
    return np.meshgrid(np.arange(WIDTH) + 0.5, np.arange(HEIGHT) + 0.5)


coordinate = st.floats(-10.0, 50.0, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(coordinate, coordinate, coordinate, coordinate, st.floats(0.3, 6.0))
@example(0.0, 0.0, 0.0, 1.371977031727096e-209, 1.0)  # its length squared underflows to 0
def test_a_segment_paints_the_centres_inside_its_rectangle(painter, x0, y0, x1, y1, r):
    length = np.hypot(x1 - x0, y1 - y0)
    canvas = _paint(painter, [x0, x1], [y0, y1], r)
    cx, cy = _centres()
    if length == 0.0:  # two copies of one point: a dot (test_a_run_of_one_point_is_a_disc...)
        distance = np.hypot(cx - x0, cy - y0)
        assert canvas[distance < r - EDGE].all() and not canvas[distance > r + EDGE].any()
        return
    across = ((x1 - x0) * (cy - y0) - (y1 - y0) * (cx - x0)) / length
    along = ((x1 - x0) * (cx - x0) + (y1 - y0) * (cy - y0)) / length
    inside = (np.abs(across) < r - EDGE) & (along > EDGE) & (along < length - EDGE)
    outside = (np.abs(across) > r + EDGE) | (along < -EDGE) | (along > length + EDGE)
    assert canvas[inside].all()
    assert not canvas[outside].any()


@settings(max_examples=200, deadline=None)
@given(coordinate, coordinate, st.floats(0.3, 8.0))
def test_a_lone_point_is_a_disc(painter, x, y, r):
    canvas = _paint(painter, [x], [y], r)
    cx, cy = _centres()
    distance = np.hypot(cx - x, cy - y)
    assert canvas[distance < r - EDGE].all()
    assert not canvas[distance > r + EDGE].any()


@settings(max_examples=100, deadline=None)
@given(st.floats(0.0, 29.0), st.integers(1, 7))
def test_a_horizontal_line_of_whole_width_paints_that_many_rows(painter, y, width):
    """Wherever it lies: the centres on its edge count on one side only."""
    canvas = _paint(painter, [5.0, 35.0], [y, y], width / 2)
    painted_rows = np.flatnonzero(canvas[:, 20])
    expected = np.arange(np.ceil(y - width / 2 - 0.5), np.ceil(y + width / 2 - 0.5))
    expected = expected[(expected >= 0) & (expected < HEIGHT)]
    assert np.array_equal(painted_rows, expected)


def test_nan_breaks_the_line_and_later_lines_cover_earlier_ones(painter):
    canvas = _paint(painter, [2.0, 10.0, np.nan, 30.0, 38.0], [5.0, 5.0, np.nan, 5.0, 5.0], 1.0)
    assert canvas[5, 3:10].all() and canvas[5, 31:38].all()
    assert not canvas[5, 11:30].any()  # no segment from (10, 5) to (30, 5)
    _paint(painter, [20.0, 20.0], [0.0, 30.0], 2.0, colour=2, canvas=canvas)
    assert canvas[5, 18:22].tolist() == [2, 2, 2, 2] and canvas[5, 6] == 1


@settings(max_examples=150, deadline=None)
@given(st.integers(1, 4), st.integers(1, 30), st.integers(1, 6), st.integers(0, 2**32 - 1),
       st.sampled_from([1.0, 0.1, 0.01, 0.0]))
def test_the_reduction_averages_each_block_of_palette_colours(painter, factor, columns, rows, seed, density):
    """Dense and sparse canvases: runs of eight background blocks take a short cut."""
    _, reduce = painter
    rng = np.random.default_rng(seed)
    shape = (rows * factor, columns * factor)
    canvas = (rng.integers(0, 5, shape) * (rng.random(shape) < density)).astype(np.uint8)
    palette = np.zeros((256, 3), dtype=np.uint8)
    palette[:5] = rng.integers(0, 256, (5, 3))
    out = np.empty((rows, columns, 3), dtype=np.uint8)
    reduce(canvas.ctypes.data, columns * factor, rows * factor, factor, palette.ctypes.data, out.ctypes.data)
    sums = palette[canvas].astype(np.int64).reshape(rows, factor, columns, factor, 3).sum(axis=(1, 3))
    area = factor * factor
    assert np.array_equal(out, (2 * sums + area) // (2 * area))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=2, max_size=12),
       st.floats(0.0, 1e6))
def test_any_coordinates_are_safe(painter, values, r):
    """Huge, infinite and NaN coordinates and widths: no write outside the canvas (a guard
    band around it stays untouched), no crash."""
    polyline, _ = painter
    half = len(values) // 2
    x = np.ascontiguousarray(values[:half], dtype=float)
    y = np.ascontiguousarray(values[half:2 * half], dtype=float)
    guard = 4096
    block = np.full(HEIGHT * WIDTH + 2 * guard, 7, dtype=np.uint8)
    canvas = block[guard:guard + HEIGHT * WIDTH]
    canvas[:] = 0
    polyline(canvas.ctypes.data, WIDTH, HEIGHT, x.ctypes.data, y.ctypes.data, x.size, r, 1)
    assert (block[:guard] == 7).all() and (block[guard + HEIGHT * WIDTH:] == 7).all()
    assert set(np.unique(canvas).tolist()) <= {0, 1}


@settings(max_examples=100, deadline=None)
@given(coordinate, coordinate, st.floats(0.3, 6.0), st.integers(1, 3),
       st.sampled_from(["alone", "between NaNs", "after a line", "before a line"]))
def test_a_run_of_one_point_is_a_disc_wherever_it_is(painter, x, y, r, copies, where):
    """A finite point with non-finite neighbours (a trace sampled where its neighbours are
    NaN), repeated or not, is a dot: the run has no segment to paint."""
    run_x, run_y = [x] * copies, [y] * copies
    line_x, line_y = [-30.0, -20.0], [-30.0, -30.0]  # a line far outside the canvas
    layouts = {"alone": (run_x, run_y),
               "between NaNs": ([np.nan, *run_x, np.inf], [np.nan, *run_y, 0.0]),
               "after a line": ([*line_x, np.nan, *run_x], [*line_y, np.nan, *run_y]),
               "before a line": ([*run_x, np.nan, *line_x], [*run_y, -np.inf, *line_y])}
    canvas = _paint(painter, *layouts[where], r)
    cx, cy = _centres()
    distance = np.hypot(cx - x, cy - y)
    assert canvas[distance < r - EDGE].all()
    assert not canvas[distance > r + EDGE].any()
