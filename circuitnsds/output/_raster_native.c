/* The waveform figure's lines in C (circuitnsds/output/raster_figure.py): wide polylines
 * drawn into a supersampled canvas of palette indices, then averaged down to RGB.
 *
 * The canvas holds one byte per subpixel, the index of its colour in a palette (0: the
 * background); a line writes its index over whatever was there, so that later lines cover
 * earlier ones, as painting in order does. Subpixel (i, j) covers [i, i + 1) x [j, j + 1)
 * and is painted when its centre (i + 1/2, j + 1/2) lies inside the shape.
 *
 * A segment of a line of width 2r is the rectangle of the points within r of the segment,
 * measured across it, and between its ends (square "butt" ends, no joins: the segments of a
 * polyline overlap at its corners, as Pillow's wide lines do). A non-finite point breaks
 * the polyline into runs of finite points (NaN separates dashes); a run with no segment of
 * positive length (a single point: a sample whose neighbours are NaN) is a disc of radius r.
 *
 * (Subpixel centres on the shape's edge count on its top and left sides only, so that a
 * line 5 subpixels wide paints 5 rows, wherever it lies.)
 *
 * Plain C99, no Python API: circuitnsds.native loads the library with ctypes, which releases
 * the GIL for the call. Built by setup.py, which defines CIRCUITNSDS_SOURCE_DIGEST.
 */

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "native.h"

/* The first and last subpixel whose centre lies in [low, high), clipped to [0, size - 1]. */
static int clip_centres(double low, double high, int64_t size, int64_t *first, int64_t *last) {
    double a = ceil(low - 0.5), b = ceil(high - 0.5) - 1.0;
    if (!(a <= b) || b < 0.0 || a > (double)(size - 1)) return 0;
    *first = a < 0.0 ? 0 : (int64_t)a;
    *last = b > (double)(size - 1) ? size - 1 : (int64_t)b;
    return 1;
}

/* Paint the convex quadrilateral with corners (cx[k], cy[k]), in order around it. */
static void fill_quad(uint8_t *canvas, int64_t width, int64_t height, const double *cx,
                      const double *cy, uint8_t colour) {
    double low = cy[0], high = cy[0];
    for (int k = 1; k < 4; k++) {
        if (cy[k] < low) low = cy[k];
        if (cy[k] > high) high = cy[k];
    }
    int64_t first, last;
    if (!clip_centres(low, high, height, &first, &last)) return;
    for (int64_t row = first; row <= last; row++) {
        double y = (double)row + 0.5, left = INFINITY, right = -INFINITY;
        for (int k = 0; k < 4; k++) { /* where the row's centre line crosses each edge */
            double ax = cx[k], ay = cy[k], bx = cx[(k + 1) & 3], by = cy[(k + 1) & 3];
            if (!((ay <= y && y <= by) || (by <= y && y <= ay))) continue;
            double x0 = ax, x1 = bx;
            if (ay != by) x0 = x1 = ax + (y - ay) / (by - ay) * (bx - ax);
            if (x0 > x1) { double t = x0; x0 = x1; x1 = t; }
            if (x0 < left) left = x0;
            if (x1 > right) right = x1;
        }
        int64_t a, b;
        if (clip_centres(left, right, width, &a, &b))
            memset(canvas + row * width + a, colour, (size_t)(b - a + 1));
    }
}

/* Paint the disc of radius r around (x, y). */
static void fill_disc(uint8_t *canvas, int64_t width, int64_t height, double x, double y,
                      double r, uint8_t colour) {
    int64_t first, last;
    if (!clip_centres(y - r, y + r, height, &first, &last)) return;
    for (int64_t row = first; row <= last; row++) {
        double dy = (double)row + 0.5 - y, half = sqrt(r * r - dy * dy);
        int64_t a, b;
        if (half == half && clip_centres(x - half, x + half, width, &a, &b))
            memset(canvas + row * width + a, colour, (size_t)(b - a + 1));
    }
}

/* Paint the polyline through the n points (x[k], y[k]), subpixel coordinates, with lines
 * of width 2 * half_width in palette index colour: each run of finite points as its
 * segments, or as a disc around its first point when none of them has a length. */
EXPORT void circuitnsds_raster_polyline(uint8_t *canvas, int64_t width, int64_t height,
                                        const double *x, const double *y, int64_t n,
                                        double half_width, uint8_t colour) {
    int64_t k = 0;
    while (k < n) {
        if (!(isfinite(x[k]) && isfinite(y[k]))) {
            k++;
            continue;
        }
        int64_t start = k;
        int segments = 0;
        for (; k + 1 < n && isfinite(x[k + 1]) && isfinite(y[k + 1]); k++) {
            double x0 = x[k], y0 = y[k], x1 = x[k + 1], y1 = y[k + 1];
            double dx = x1 - x0, dy = y1 - y0, length = hypot(dx, dy); /* no underflow to 0 nor overflow */
            if (!(length > 0.0)) continue;
            segments = 1;
            double nx = -dy / length * half_width, ny = dx / length * half_width;
            double cx[4] = {x0 + nx, x1 + nx, x1 - nx, x0 - nx};
            double cy[4] = {y0 + ny, y1 + ny, y1 - ny, y0 - ny};
            fill_quad(canvas, width, height, cx, cy, colour);
        }
        if (!segments) fill_disc(canvas, width, height, x[start], y[start], half_width, colour);
        k++; /* past the run's last point */
    }
}

/* Average each factor x factor block of the canvas (width x height subpixels, both
 * multiples of factor) into one RGB pixel of out (row-major, 3 bytes a pixel), the colours
 * looked up in palette (3 bytes an index), rounded half up. A block of background only
 * (index 0, most of a figure) is its colour without the arithmetic. Inlined with the
 * figure's factor 3 as a constant, so that the compiler can unroll the block's loops. */
/* Whether the factor rows of 8 * factor subpixels from block are all background (read 8
 * bytes at a time). */
static inline int blank(const uint8_t *block, int64_t width, int64_t factor) {
    for (int64_t j = 0; j < factor; j++)
        for (int64_t k = 0; k < factor; k++) {
            uint64_t word;
            memcpy(&word, block + j * width + 8 * k, 8);
            if (word) return 0;
        }
    return 1;
}

static inline void reduce_blocks(const uint8_t *canvas, int64_t width, int64_t height,
                                 int64_t factor, const uint8_t *palette, uint8_t *out) {
    int64_t columns = width / factor, rows = height / factor, area = factor * factor;
    for (int64_t row = 0; row < rows; row++) {
        const uint8_t *block_row = canvas + row * factor * width;
        for (int64_t column = 0; column < columns; column++) {
            const uint8_t *block = block_row + column * factor;
            uint8_t *pixel = out + 3 * (row * columns + column);
            if (column % 8 == 0 && column + 8 <= columns && blank(block, width, factor)) {
                for (int k = 0; k < 8; k++) memcpy(pixel + 3 * k, palette, 3);
                column += 7; /* eight blocks of background at once */
                continue;
            }
            unsigned painted = 0;
            for (int64_t j = 0; j < factor; j++)
                for (int64_t i = 0; i < factor; i++) painted |= block[j * width + i];
            if (!painted) {
                pixel[0] = palette[0];
                pixel[1] = palette[1];
                pixel[2] = palette[2];
                continue;
            }
            int64_t red = 0, green = 0, blue = 0;
            for (int64_t j = 0; j < factor; j++)
                for (int64_t i = 0; i < factor; i++) {
                    const uint8_t *colour = palette + 3 * block[j * width + i];
                    red += colour[0];
                    green += colour[1];
                    blue += colour[2];
                }
            pixel[0] = (uint8_t)((2 * red + area) / (2 * area));
            pixel[1] = (uint8_t)((2 * green + area) / (2 * area));
            pixel[2] = (uint8_t)((2 * blue + area) / (2 * area));
        }
    }
}

EXPORT void circuitnsds_raster_reduce(const uint8_t *canvas, int64_t width, int64_t height,
                                      int64_t factor, const uint8_t *palette, uint8_t *out) {
    if (factor == 3)
        reduce_blocks(canvas, width, height, 3, palette, out);
    else
        reduce_blocks(canvas, width, height, factor, palette, out);
}
