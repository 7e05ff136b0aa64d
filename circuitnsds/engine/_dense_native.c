/* The mode-table loop of circuitnsds/engine/dense_loop.py (_table_loop and the scalar
 * helpers it calls) in plain C, for a run that must not wait for numba's load.
 *
 * Built at install by setup.py (flags -O2 -ffp-contract=off -fno-fast-math) and called with
 * ctypes by dense_loop.run_table (circuitnsds/native.py checks that the library was built
 * from this very file). Every floating-point operation is the Python original's, in the
 * same order: no fused multiply-adds, no reassociation, so that the trajectories are the
 * numba loop's bit for bit (tests/test_native_loop.py). Edit the two together. (Only the
 * order in which independent sums are interleaved differs: a step's rows are summed eight
 * or four side by side, each row's own operations in the numba loop's order.)
 *
 * No Python API: the arrays come as addresses (the layout is checked by dense_loop before
 * the call), the loop runs without the interpreter's lock (ctypes releases it).
 */

#include <math.h>
#include <stdint.h>

#include "native.h"

#if defined(_WIN32)
/* setuptools links the library as an extension module and exports this name on Windows;
 * nothing imports it (circuitnsds.native loads the library with ctypes). */
EXPORT void *PyInit__dense_native(void) { return 0; }
#endif

/* The order of the entries of the `arrays` argument (addresses) of circuitnsds_table_loop;
 * dense_loop.NATIVE_ARRAYS names them in the same order. */
enum {
    A_P, A_Q1, A_Q0, A_C, A_W, A_EW, A_RESISTANCE, A_ACTIVE, A_ROWS, A_NW, A_MODE_CLASS,
    A_MODE_SCHED, A_MODE_FREE, A_LAST_USED, A_UNIQUE, A_SUCCESSOR, A_Y, A_Z, A_F, A_STEP_CLASS,
    A_SCHED_STATE, A_USED, A_CONTROLS, A_ON, A_OFF, A_SWITCH_ON, A_X, A_COUNT_ARRAYS
};

/* The order of the entries of the `sizes` argument (int64); dense_loop.NATIVE_SIZES. */
enum {
    S_K0, S_K_END, S_MODE, S_CLASS0, S_FREE_ID, S_COUNT, S_N, S_M, S_KSTIM, S_WIDTH,
    S_SWITCHES, S_Y_ROW, S_Z_ROW, S_F_ROW, S_CONTROLS_ROW, S_STOP_LEFT_MODE, S_STOP_NO_MODE,
    S_STOP_SWITCH, S_STOP_END, S_COUNT_SIZES
};

/* The order of the entries of the `tolerances` argument (double). */
enum { T_SIGN, T_CLEAR, T_COUNT_TOLERANCES };

/* One call's arrays and sizes. Table arrays (padded, C order): P (size, width, n),
 * Q1 and Q0 (size, width, kstim), c (size, width), W (size, m, width), e_w, resistance and
 * active (size, m), the per-mode int64/bool vectors (size). Run arrays: y (steps + 1, n),
 * z (steps + 1, m) and F (steps + 1, kstim) with row strides y_row etc. in elements,
 * step_class and sched_state (steps), used (steps + 1), controls (switches, n) with row
 * stride controls_row, on, off and switch_on (switches), x (width). */
typedef struct {
    const double *P, *Q1, *Q0, *c, *W, *e_w, *resistance;
    const int64_t *active, *rows, *nw, *mode_class, *mode_sched, *mode_free;
    int64_t *last_used;
    const uint8_t *unique;
    int64_t *successor;
    double *y, *z;
    const double *F;
    const int64_t *step_class, *sched_state;
    int64_t *used;
    const double *controls, *on, *off;
    const uint8_t *switch_on;
    double *x;
    int64_t n, m, kstim, width, switches, y_row, z_row, f_row, controls_row;
    double sign_tol, clear_tol;
} Loop;

/* _pair_magnitude_scalar: the sum of the magnitudes of the terms of row r of mode's map at step k. */
static double pair_magnitude(const Loop *L, int64_t mode, int64_t r, int64_t k) {
    const int64_t row = mode * L->width + r;
    const double *P = L->P + row * L->n;
    const double *Q1 = L->Q1 + row * L->kstim;
    const double *Q0 = L->Q0 + row * L->kstim;
    const double *yk = L->y + k * L->y_row;
    const double *F1 = L->F + (k + 1) * L->f_row;
    const double *F0 = L->F + k * L->f_row;
    double magnitude = fabs(L->c[row]);
    for (int64_t j = 0; j < L->n; j++)
        magnitude += fabs(P[j] * yk[j]);
    for (int64_t j = 0; j < L->kstim; j++)
        magnitude += fabs(Q1[j] * F1[j]) + fabs(Q0[j] * F0[j]);
    return magnitude;
}

/* _inactive_w_scalar: w of mode's r-th W row for the step x, and the magnitudes of its terms. */
static double inactive_w(const Loop *L, int64_t mode, int64_t r, int64_t size, double *magnitude) {
    const int64_t row = mode * L->m + r;
    const double *W = L->W + row * L->width;
    double acc = L->e_w[row];
    double mag = fabs(acc);
    for (int64_t j = 0; j < size; j++) {
        const double term = W[j] * L->x[j];
        acc += term;
        mag += fabs(term);
    }
    *magnitude = mag;
    return acc;
}

/* The rows of a step are summed several at a time: one row's sum is a chain of dependent
 * additions (each waits for the previous one's result), and the rows' chains, summed side
 * by side, overlap. Each row's own sum keeps _try_mode_scalar's (_inactive_w_scalar's)
 * operations in their order, so every value is the numba loop's bit for bit. A count of
 * rows that is not a multiple of the block is finished by a block ending at the last row:
 * the rows it computes again get the same bits. The blocks are written out, one function per
 * size: one function with the block size as a constant parameter and loops over an array of
 * accumulators (gcc 12, -O2) kept them in memory and made every step 1.4-1.9 times slower
 * (benchmarks/loop_step.py, 2026-11-23). */

/* Rows r .. r+7 of a mode's map at one step (P, Q1, Q0 and c at row r; y = y_k, F1 = F_{k+1},
 * F0 = F_k): x[i] = c[i] + P[i][0]*y[0] + ... + P[i][n-1]*y[n-1]
 * + (Q1[i][0]*F1[0] + Q0[i][0]*F0[0]) + ..., added left to right. */
static void eight_rows(const double *P, const double *Q1, const double *Q0, const double *c,
                       const double *y, const double *F1, const double *F0, int64_t n, int64_t kstim,
                       double *x) {
    const double *P1 = P + n, *P2 = P1 + n, *P3 = P2 + n, *P4 = P3 + n, *P5 = P4 + n, *P6 = P5 + n,
                 *P7 = P6 + n;
    double a0 = c[0], a1 = c[1], a2 = c[2], a3 = c[3], a4 = c[4], a5 = c[5], a6 = c[6], a7 = c[7];
    for (int64_t j = 0; j < n; j++) {
        const double v = y[j];
        a0 += P[j] * v;
        a1 += P1[j] * v;
        a2 += P2[j] * v;
        a3 += P3[j] * v;
        a4 += P4[j] * v;
        a5 += P5[j] * v;
        a6 += P6[j] * v;
        a7 += P7[j] * v;
    }
    for (int64_t j = 0; j < kstim; j++) {
        const double f1 = F1[j], f0 = F0[j];
        a0 += Q1[j] * f1 + Q0[j] * f0;
        a1 += Q1[kstim + j] * f1 + Q0[kstim + j] * f0;
        a2 += Q1[2 * kstim + j] * f1 + Q0[2 * kstim + j] * f0;
        a3 += Q1[3 * kstim + j] * f1 + Q0[3 * kstim + j] * f0;
        a4 += Q1[4 * kstim + j] * f1 + Q0[4 * kstim + j] * f0;
        a5 += Q1[5 * kstim + j] * f1 + Q0[5 * kstim + j] * f0;
        a6 += Q1[6 * kstim + j] * f1 + Q0[6 * kstim + j] * f0;
        a7 += Q1[7 * kstim + j] * f1 + Q0[7 * kstim + j] * f0;
    }
    x[0] = a0;
    x[1] = a1;
    x[2] = a2;
    x[3] = a3;
    x[4] = a4;
    x[5] = a5;
    x[6] = a6;
    x[7] = a7;
}

/* eight_rows for rows r .. r+3. */
static void four_rows(const double *P, const double *Q1, const double *Q0, const double *c,
                      const double *y, const double *F1, const double *F0, int64_t n, int64_t kstim,
                      double *x) {
    const double *P1 = P + n, *P2 = P1 + n, *P3 = P2 + n;
    double a0 = c[0], a1 = c[1], a2 = c[2], a3 = c[3];
    for (int64_t j = 0; j < n; j++) {
        const double v = y[j];
        a0 += P[j] * v;
        a1 += P1[j] * v;
        a2 += P2[j] * v;
        a3 += P3[j] * v;
    }
    for (int64_t j = 0; j < kstim; j++) {
        const double f1 = F1[j], f0 = F0[j];
        a0 += Q1[j] * f1 + Q0[j] * f0;
        a1 += Q1[kstim + j] * f1 + Q0[kstim + j] * f0;
        a2 += Q1[2 * kstim + j] * f1 + Q0[2 * kstim + j] * f0;
        a3 += Q1[3 * kstim + j] * f1 + Q0[3 * kstim + j] * f0;
    }
    x[0] = a0;
    x[1] = a1;
    x[2] = a2;
    x[3] = a3;
}

/* eight_rows for row r alone. */
static void one_row(const double *P, const double *Q1, const double *Q0, const double *c,
                    const double *y, const double *F1, const double *F0, int64_t n, int64_t kstim,
                    double *x) {
    double acc = c[0];
    for (int64_t j = 0; j < n; j++)
        acc += P[j] * y[j];
    for (int64_t j = 0; j < kstim; j++)
        acc += Q1[j] * F1[j] + Q0[j] * F0[j];
    x[0] = acc;
}

/* The `size` rows of mode's map at step k into x (the step of _try_mode_scalar). */
static void map_rows(const Loop *L, int64_t mode, int64_t k, int64_t size) {
    const int64_t n = L->n, kstim = L->kstim, first = mode * L->width;
    const double *P = L->P + first * n, *Q1 = L->Q1 + first * kstim, *Q0 = L->Q0 + first * kstim;
    const double *c = L->c + first;
    const double *y = L->y + k * L->y_row, *F1 = L->F + (k + 1) * L->f_row, *F0 = L->F + k * L->f_row;
    double *x = L->x;
    if (size < 4) {
        for (int64_t r = 0; r < size; r++)
            one_row(P + r * n, Q1 + r * kstim, Q0 + r * kstim, c + r, y, F1, F0, n, kstim, x + r);
        return;
    }
    int64_t r = 0;
    for (; r + 8 <= size; r += 8)
        eight_rows(P + r * n, Q1 + r * kstim, Q0 + r * kstim, c + r, y, F1, F0, n, kstim, x + r);
    for (; r < size; r += 4) {
        if (r + 4 > size)
            r = size - 4;
        four_rows(P + r * n, Q1 + r * kstim, Q0 + r * kstim, c + r, y, F1, F0, n, kstim, x + r);
    }
}

/* W rows r .. r+3 (W and e_w at row r, rows `width` apart) for the step x (`size` entries):
 * w[i] = e_w[i] + W[i][0]*x[0] + ... and mag[i] = |e_w[i]| + |W[i][0]*x[0]| + ..., added
 * left to right (_inactive_w_scalar). */
static void four_w(const double *W, const double *e_w, const double *x, int64_t width, int64_t size,
                   double *w, double *mag) {
    const double *W1 = W + width, *W2 = W1 + width, *W3 = W2 + width;
    double w0 = e_w[0], w1 = e_w[1], w2 = e_w[2], w3 = e_w[3];
    double m0 = fabs(w0), m1 = fabs(w1), m2 = fabs(w2), m3 = fabs(w3);
    for (int64_t j = 0; j < size; j++) {
        const double v = x[j];
        const double t0 = W[j] * v, t1 = W1[j] * v, t2 = W2[j] * v, t3 = W3[j] * v;
        w0 += t0;
        m0 += fabs(t0);
        w1 += t1;
        m1 += fabs(t1);
        w2 += t2;
        m2 += fabs(t2);
        w3 += t3;
        m3 += fabs(t3);
    }
    w[0] = w0;
    w[1] = w1;
    w[2] = w2;
    w[3] = w3;
    mag[0] = m0;
    mag[1] = m1;
    mag[2] = m2;
    mag[3] = m3;
}

/* four_w for W rows r and r+1. */
static void two_w(const double *W, const double *e_w, const double *x, int64_t width, int64_t size,
                  double *w, double *mag) {
    const double *W1 = W + width;
    double w0 = e_w[0], w1 = e_w[1];
    double m0 = fabs(w0), m1 = fabs(w1);
    for (int64_t j = 0; j < size; j++) {
        const double v = x[j];
        const double t0 = W[j] * v, t1 = W1[j] * v;
        w0 += t0;
        m0 += fabs(t0);
        w1 += t1;
        m1 += fabs(t1);
    }
    w[0] = w0;
    w[1] = w1;
    mag[0] = m0;
    mag[1] = m1;
}

/* Whether the w of every inactive pair of mode (its first nw rows of W) for the step x of
 * `size` rows holds: w >= -sign_tol·magnitude (_try_mode_scalar), or, `strictly`,
 * w > clear_tol·magnitude (_clear_scalar); the rows four or two at a time, checked in order. */
static int inactive_hold(const Loop *L, int64_t mode, int64_t size, int strictly) {
    const int64_t inactive = L->nw[mode], width = L->width;
    const double *W = L->W + mode * L->m * width, *e_w = L->e_w + mode * L->m;
    const int64_t block = inactive >= 4 ? 4 : inactive >= 2 ? 2 : 1;
    double w[4], magnitude[4];
    for (int64_t r = 0; r < inactive; r += block) {
        if (r + block > inactive)
            r = inactive - block;
        if (block == 4)
            four_w(W + r * width, e_w + r, L->x, width, size, w, magnitude);
        else if (block == 2)
            two_w(W + r * width, e_w + r, L->x, width, size, w, magnitude);
        else
            w[0] = inactive_w(L, mode, r, size, magnitude);
        for (int64_t i = 0; i < block; i++)
            if (strictly ? !(w[i] > L->clear_tol * magnitude[i]) : w[i] < -L->sign_tol * magnitude[i])
                return 0;
    }
    return 1;
}

/* _try_mode_scalar: step k with mode into x; whether its complementarity signs hold. */
static int try_mode(const Loop *L, int64_t mode, int64_t k) {
    const int64_t n = L->n, size = L->rows[mode], inactive = L->nw[mode];
    const double *x = L->x;
    map_rows(L, mode, k, size);
    for (int64_t r = n; r < size; r++) {
        if (x[r] < 0.0) {
            if (x[r] < -L->sign_tol * pair_magnitude(L, mode, r, k))
                return 0;
            double scale;
            inactive_w(L, mode, inactive + r - n, size, &scale);
            if (-x[r] * L->resistance[mode * L->m + r - n] > L->sign_tol * scale)
                return 0;
        }
    }
    return inactive_hold(L, mode, size, 0);
}

/* _clear_scalar: whether the step x of mode is strictly complementary. */
static int clear(const Loop *L, int64_t mode, int64_t k) {
    const int64_t size = L->rows[mode];
    for (int64_t r = L->n; r < size; r++)
        if (!(L->x[r] > L->clear_tol * pair_magnitude(L, mode, r, k)))
            return 0;
    return inactive_hold(L, mode, size, 1);
}

/* _find_mode_scalar: the stored mode that solves step k, whose mode `failed` left its signs, or -1. */
static int64_t find_mode(const Loop *L, int64_t failed, int64_t k, int64_t count) {
    if (!L->unique[failed])
        return -1;
    const int64_t first = L->successor[failed];
    for (int64_t attempt = 0; attempt < count + 1; attempt++) {
        const int64_t i = attempt == 0 ? first : attempt - 1;
        if (i < 0 || i == failed || (attempt > 0 && i == first))
            continue;
        if (L->mode_class[i] != L->mode_class[failed] || L->mode_sched[i] != L->mode_sched[failed]
            || L->mode_free[i] != L->mode_free[failed])
            continue;
        if (try_mode(L, i, k) && clear(L, i, k))
            return i;
    }
    return -1;
}

/* _table_loop. `arrays`: the addresses in the order of A_*; `sizes`: the integers of S_*;
 * `tolerances`: SIGN_TOL and CLEAR_TOL. Writes (k, reason, last) to out[0..2]. */
EXPORT void circuitnsds_table_loop(void *const *arrays, const int64_t *sizes, const double *tolerances,
                                   int64_t *out) {
    Loop L;
    L.P = arrays[A_P];
    L.Q1 = arrays[A_Q1];
    L.Q0 = arrays[A_Q0];
    L.c = arrays[A_C];
    L.W = arrays[A_W];
    L.e_w = arrays[A_EW];
    L.resistance = arrays[A_RESISTANCE];
    L.active = arrays[A_ACTIVE];
    L.rows = arrays[A_ROWS];
    L.nw = arrays[A_NW];
    L.mode_class = arrays[A_MODE_CLASS];
    L.mode_sched = arrays[A_MODE_SCHED];
    L.mode_free = arrays[A_MODE_FREE];
    L.last_used = arrays[A_LAST_USED];
    L.unique = arrays[A_UNIQUE];
    L.successor = arrays[A_SUCCESSOR];
    L.y = arrays[A_Y];
    L.z = arrays[A_Z];
    L.F = arrays[A_F];
    L.step_class = arrays[A_STEP_CLASS];
    L.sched_state = arrays[A_SCHED_STATE];
    L.used = arrays[A_USED];
    L.controls = arrays[A_CONTROLS];
    L.on = arrays[A_ON];
    L.off = arrays[A_OFF];
    L.switch_on = arrays[A_SWITCH_ON];
    L.x = arrays[A_X];
    L.n = sizes[S_N];
    L.m = sizes[S_M];
    L.kstim = sizes[S_KSTIM];
    L.width = sizes[S_WIDTH];
    L.switches = sizes[S_SWITCHES];
    L.y_row = sizes[S_Y_ROW];
    L.z_row = sizes[S_Z_ROW];
    L.f_row = sizes[S_F_ROW];
    L.controls_row = sizes[S_CONTROLS_ROW];
    L.sign_tol = tolerances[T_SIGN];
    L.clear_tol = tolerances[T_CLEAR];

    const int64_t k0 = sizes[S_K0], k_end = sizes[S_K_END], class0 = sizes[S_CLASS0];
    const int64_t free_id = sizes[S_FREE_ID], count = sizes[S_COUNT], n = L.n;
    int64_t mode = sizes[S_MODE];
    int64_t last = mode;
    int64_t k = k0;
    int64_t reason = sizes[S_STOP_END];
    while (k < k_end) {
        const int64_t cls = k == k0 ? class0 : L.step_class[k];
        if (mode < 0 || L.mode_class[mode] != cls || L.mode_sched[mode] != L.sched_state[k]) {
            /* the step size or the scheduled switches changed: the mode this step's class and
             * switch states had the last time */
            mode = -1;
            for (int64_t i = 0; i < count; i++)
                if (L.mode_class[i] == cls && L.mode_sched[i] == L.sched_state[k] && L.mode_free[i] == free_id
                    && (mode < 0 || L.last_used[i] > L.last_used[mode]))
                    mode = i;
            if (mode < 0) {
                reason = sizes[S_STOP_NO_MODE];
                break;
            }
        }
        if (!try_mode(&L, mode, k)) {
            const int64_t found = find_mode(&L, mode, k, count);
            if (found < 0) {
                reason = sizes[S_STOP_LEFT_MODE];
                break;
            }
            L.successor[mode] = found;
            mode = found;
        }
        double *next = L.y + (k + 1) * L.y_row;
        for (int64_t j = 0; j < n; j++)
            next[j] = L.x[j];
        for (int64_t r = n; r < L.rows[mode]; r++)
            L.z[(k + 1) * L.z_row + L.active[mode * L.m + r - n]] = L.x[r];
        L.used[k + 1] = mode;
        L.last_used[mode] = k;
        last = mode;
        k += 1;
        int stop = 0;
        for (int64_t s = 0; s < L.switches && !stop; s++) {
            const double *control = L.controls + s * L.controls_row;
            const double *yk = L.y + k * L.y_row;
            double value = 0.0;
            for (int64_t j = 0; j < n; j++)
                value += control[j] * yk[j];
            if (L.switch_on[s])
                stop = value < L.off[s];
            else
                stop = value > L.on[s];
        }
        if (stop) {
            reason = sizes[S_STOP_SWITCH];
            break;
        }
    }
    out[0] = k;
    out[1] = reason;
    out[2] = last;
}
