/* The event loop of the exact integrator (circuitnsds/engine/exact/loop.py, _exact_loop and
 * the helpers it calls) and its first-event search (first_event.py: _value, _bound, _refine,
 * _first_root, _first_event, _crossed_within_tolerance) in plain C, for a run that must not
 * wait for numba's load and that spends its time in rows and segments.
 *
 * Built at install by setup.py (flags -O2 -ffp-contract=off -fno-fast-math) and called with
 * ctypes by run.run_exact (circuitnsds/native.py checks that the library was built from this
 * very file). The algorithm is the numba loop's, step for step: the same segments, the same
 * certified first root (an interval is cleared only by a lower bound above -tol, else halved,
 * left half first: no early crossing is skipped), the same rows, charges, tails and events.
 * The rows' arithmetic is loop.py's op for op (real arithmetic for real exponents, the p = 0
 * charges by e^{νa} expm1(νw)/ν); complex numbers are explicit (re, im) pairs, products
 * written out as numba has them, so the results agree with the numba loop to round-off (the
 * libm's exp, cos, sin, expm1, hypot, and numba's complex exp, may differ by an ulp), and a
 * run in parts is the run in one part bit for bit (every row a function of quantities that do
 * not depend on where a part started). Edit the two together.
 *
 * No Python API: the arrays come as addresses (run.py checks their dtypes and contiguity and
 * converts before the call), the loop runs without the interpreter's lock (ctypes releases it).
 */

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "native.h"

#if defined(_WIN32)
EXPORT void *PyInit__exact_native(void) { return 0; }
#endif

/* loop.py's constants (FINISHED ...; MAX_MODE_CHANGES, RELATIVE_TOL, TIME_ULPS, SUM_ULPS,
 * SERIES_TERMS) and first_event.py's (MAX_DEPTH, MAX_STACK, MAX_VISITS, UNRESOLVED). */
enum { FINISHED = 0, NEW_MODE = 1, EVENTS_FULL = 2, STALLED = 3, OUT_OF_MEMORY = 4 };
#define MAX_MODE_CHANGES 64
#define CHATTERING 1e-8
#define RELATIVE_TOL 1e-12
#define TIME_ULPS 4.0
#define SUM_ULPS 8.0
#define FAST_SIGNIFICANT 1e-6
#define EPSILON 2.220446049250313e-16
#define SERIES_TERMS 24
#define MAX_DEPTH 200
#define MAX_STACK (2 * MAX_DEPTH + 2)
#define MAX_VISITS 200000
#define UNRESOLVED (-2.0)
#define RESOLUTION 1e-13

typedef struct {
    double re, im;
} cplx;

static inline cplx cmul(cplx a, cplx b) {
    cplx r = {a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re};
    return r;
}

static inline cplx cscale(cplx a, double s) {
    cplx r = {a.re * s, a.im * s};
    return r;
}

/* e^z: exp(Re z) for a real z, else exp(Re z) (cos Im z, sin Im z) (loop._grown's form). */
static inline cplx cexp_(double re, double im) {
    cplx r;
    if (im == 0.0) {
        r.re = exp(re);
        r.im = 0.0;
    } else {
        double size = exp(re);
        r.re = size * cos(im);
        r.im = size * sin(im);
    }
    return r;
}

/* loop._size: |re + i im|. */
static inline double csize(double re, double im) { return im == 0.0 ? fabs(re) : hypot(re, im); }

/* x^p for a small integer p >= 0 by repeated products. */
static inline double ipow(double x, int64_t p) {
    double r = 1.0;
    for (int64_t i = 0; i < p; i++)
        r *= x;
    return r;
}

/* ---------------------------------------------------------------- the first-event search */

/* first_event._value: Re Σ c_j τ^p_j e^{ν_j τ} (e^{0} = 1 and a conjugate's e^{ν̄τ}, the conjugate
 * of its partner's, without exp, cos and sin: the same bits). */
static double value_at(const cplx *c, const int64_t *p, const cplx *nu, int64_t terms, double tau) {
    double total = 0.0;
    cplx grown = {1.0, 0.0};
    for (int64_t j = 0; j < terms; j++) {
        cplx scaled = cscale(c[j], ipow(tau, p[j]));
        if (j > 0 && nu[j].im != 0.0 && nu[j].re == nu[j - 1].re && nu[j].im == -nu[j - 1].im) {
            grown.im = -grown.im; /* (grown is still the partner's) */
        } else if (nu[j].re == 0.0 && nu[j].im == 0.0) {
            grown.re = 1.0;
            grown.im = 0.0;
        } else {
            grown = cexp_(nu[j].re * tau, nu[j].im * tau);
        }
        total += scaled.re * grown.re - scaled.im * grown.im;
    }
    return total;
}

/* Scratch of the search (search_init: one block for a table of up to `terms` terms and
 * `columns` columns): the derivative's terms (2 per term), the column searched, the terms'
 * factors over the interval last prepared, and the interval stack. */
typedef struct {
    void *block;
    cplx *dc, *column, *at_a, *at_t;     /* -c ν, -c p (2 terms per term); e^{ν_j a}; e^{ν_j τ} */
    double *d_sizes, *sizes, *speeds;    /* |dc|; the column's |c_j|; |ν_j| */
    double *table_sizes;                 /* |c_jk| of the table (terms, columns): search_sizes or the loop's functions() */
    double *growth, *at_key, *power_t;   /* e^{max(Re ν a, Re ν b)}; the a of at_a (NaN: none); τ^p_j */
    int64_t *dp;
    uint8_t *conjugate;                  /* ν_j is the conjugate of ν_{j-1} */
    double prepared_a, prepared_b;       /* the interval growth and at_a hold (NaN: none) */
    double starts[MAX_STACK], ends[MAX_STACK], end_values[MAX_STACK]; /* (g(end), NaN: not known) */
    int64_t depths[MAX_STACK];
} Search;

/* The search's scratch for tables of up to `terms` terms and `columns` columns; 0 when it could
 * not be allocated (then search_free is still called). */
static int search_init(Search *s, int64_t terms, int64_t columns) {
    size_t complexes = (size_t)(6 * terms + 1), doubles = (size_t)(8 * terms + terms * columns + 1);
    size_t ints = (size_t)(2 * terms + 1);
    s->block = malloc(sizeof(cplx) * complexes + sizeof(double) * doubles + sizeof(int64_t) * ints
                      + (size_t)terms + 1);
    if (!s->block)
        return 0;
    cplx *c = s->block;
    s->dc = c; c += 2 * terms;
    s->column = c; c += terms;
    s->at_a = c; c += terms;
    s->at_t = c;
    double *d = (double *)((cplx *)s->block + complexes);
    s->d_sizes = d; d += 2 * terms;
    s->sizes = d; d += terms;
    s->speeds = d; d += terms;
    s->growth = d; d += terms;
    s->at_key = d; d += terms;
    s->power_t = d; d += terms;
    s->table_sizes = d;
    s->dp = (int64_t *)((double *)((cplx *)s->block + complexes) + doubles);
    s->conjugate = (uint8_t *)(s->dp + ints);
    return 1;
}

static void search_free(Search *s) { free(s->block); }

/* A segment's terms: their |ν_j| (s->speeds), which is a conjugate of the one before, and no
 * factor prepared yet (every search of the segment takes these exponents). */
static void search_terms(Search *s, const cplx *exponents, int64_t terms) {
    for (int64_t j = 0; j < terms; j++) {
        s->speeds[j] = csize(exponents[j].re, exponents[j].im);
        s->conjugate[j] = j > 0 && exponents[j].im != 0.0 && exponents[j].re == exponents[j - 1].re
                          && exponents[j].im == -exponents[j - 1].im;
        s->at_key[j] = NAN;
    }
    s->prepared_a = NAN;
    s->prepared_b = NAN;
}

/* |c_jk| of a table (terms, columns) into s->table_sizes (the loop has them from functions()). */
static void search_sizes(Search *s, const cplx *table, int64_t terms, int64_t columns) {
    for (int64_t i = 0; i < terms * columns; i++)
        s->table_sizes[i] = csize(table[i].re, table[i].im);
}

/* The terms' factors over [a, b] that every column's bound and the derivative's share, the same
 * values first_event._bound computes term by term: growth_j = e^{max(Re ν_j a, Re ν_j b)} (1 for
 * Re ν_j = 0: e^{±0}) and, for a slow term (|ν_j| (b - a) <= 1), e^{ν_j a}, kept while a stays
 * (a left half starts where its interval did; the columns' bounds over [0, best] all start at
 * 0); a conjugate's e^{ν̄a} is the conjugate of its partner's (exp, cos even, sin odd: the same
 * bits, as the rows have it). */
static void prepare(Search *s, const cplx *nu, int64_t terms, double a, double b) {
    if (a == s->prepared_a && b == s->prepared_b)
        return;
    double width = b - a;
    for (int64_t j = 0; j < terms; j++) {
        s->growth[j] = nu[j].re == 0.0 ? 1.0 : exp(fmax(nu[j].re * a, nu[j].re * b));
        if (s->speeds[j] * width > 1.0 || s->at_key[j] == a)
            continue;
        if (s->conjugate[j] && s->at_key[j - 1] == a) {
            s->at_a[j].re = s->at_a[j - 1].re;
            s->at_a[j].im = -s->at_a[j - 1].im;
        } else if (nu[j].re == 0.0 && nu[j].im == 0.0) {
            s->at_a[j].re = 1.0; /* (cexp_(±0, ±0): e^{±0} = 1) */
            s->at_a[j].im = 0.0;
        } else {
            s->at_a[j] = cexp_(nu[j].re * a, nu[j].im * a);
        }
        s->at_key[j] = a;
    }
    s->prepared_a = a;
    s->prepared_b = b;
}

/* The sums of first_event._bound over terms (c, sizes, p) of exponents ν on the prepared [a, b]:
 * the fast terms' magnitudes, the slow terms' g, g', g'' at a and bounds of |g''| (bend) and
 * |g'''| (third) on [a, b]. */
typedef struct {
    double fast, bend, third, g0, g1, g2;
} Sums;

static void accumulate(Sums *t, const Search *s, const cplx *c, const double *sizes, const int64_t *p,
                       const cplx *nu, int64_t terms, double a, double b) {
    double width = b - a;
    for (int64_t j = 0; j < terms; j++) {
        double size = sizes[j];
        if (size == 0.0)
            continue;
        int64_t q = p[j];
        double growth = s->growth[j];
        double speed = s->speeds[j];
        if (speed * width > 1.0) {
            t->fast += size * ipow(b, q) * growth;
            continue;
        }
        cplx at_a = s->at_a[j];
        if (q == 0) { /* (most terms: the general lines below with their powers 1 and 0) */
            t->bend += size * growth * (speed * speed);
            t->third += size * growth * (speed * speed * speed);
            t->g0 += c[j].re * at_a.re - c[j].im * at_a.im;
            cplx slope = {0.0 + nu[j].re, nu[j].im}; /* (0.0 + : -0 as +0, as the general line has it) */
            cplx d = cmul(c[j], slope);
            t->g1 += d.re * at_a.re - d.im * at_a.im;
            cplx curve = cmul(nu[j], slope);
            curve.re += 0.0;
            cplx d2 = cmul(c[j], curve);
            t->g2 += d2.re * at_a.re - d2.im * at_a.im;
            continue;
        }
        t->bend += size * growth * (speed * speed * ipow(b, q) + 2 * q * speed * ipow(b, q > 1 ? q - 1 : 0)
                                    + q * (q - 1) * ipow(b, q > 2 ? q - 2 : 0));
        t->third += size * growth * (speed * speed * speed * ipow(b, q) + 3 * q * speed * speed * ipow(b, q > 1 ? q - 1 : 0)
                                     + 3 * q * (q - 1) * speed * ipow(b, q > 2 ? q - 2 : 0)
                                     + q * (q - 1) * (q - 2) * ipow(b, q > 3 ? q - 3 : 0));
        double power = ipow(a, q);
        double lowered = q > 0 ? q * ipow(a, q > 1 ? q - 1 : 0) : 0.0;
        double lowered2 = q > 1 ? q * (q - 1) * ipow(a, q > 2 ? q - 2 : 0) : 0.0;
        cplx scaled = cscale(c[j], power);
        t->g0 += scaled.re * at_a.re - scaled.im * at_a.im;
        cplx slope = {lowered + nu[j].re * power, nu[j].im * power};
        cplx d = cmul(c[j], slope);
        t->g1 += d.re * at_a.re - d.im * at_a.im;
        /* d²/dτ² τ^q e^{ντ} = (ν (ν τ^q + 2 q τ^{q-1}) + q (q-1) τ^{q-2}) e^{ντ} */
        cplx inner = {nu[j].re * power + 2 * lowered, nu[j].im * power};
        cplx curve = cmul(nu[j], inner);
        curve.re += lowered2;
        cplx d2 = cmul(c[j], curve);
        t->g2 += d2.re * at_a.re - d2.im * at_a.im;
    }
}

/* first_event._lowest: the least over s in [0, width] of the slow terms' cubic Taylor model
 * g0 + g1 s + g2 s²/2 - third s³/6 (its ends and its local minimum, the smaller zero of its
 * slope g1 + g2 s - third s²/2, or the parabola's vertex when third = 0). */
static inline double lowest(double g0, double g1, double g2, double third, double width) {
    double end = g0 + g1 * width + g2 * width * width / 2 - third * width * width * width / 6;
    double low = g0 < end ? g0 : end;
    double s = -1.0;
    if (third > 0.0) {
        double discriminant = g2 * g2 + 2 * third * g1;
        if (discriminant > 0.0) {
            double root = sqrt(discriminant);
            s = g2 > 0.0 ? -2 * g1 / (g2 + root) : (g2 - root) / third; /* (no cancellation) */
        }
    } else if (g2 > 0.0) {
        s = -g1 / g2;
    }
    if (s > 0.0 && s < width) {
        double inside = g0 + g1 * s + g2 * s * s / 2 - third * s * s * s / 6;
        low = low < inside ? low : inside;
    }
    return low;
}

/* first_event._bound from the sums over [a, b] (b - a = width): the better of the second-order
 * bound (g'' >= -bend) and the third-order one (g''' >= -third), less the fast terms. */
static inline double bound_of(const Sums *t, double width) {
    double curved = t->g0 + t->g1 * width - t->bend * width * width / 2;
    double second = t->g0 < curved ? t->g0 : curved;
    double cubic = lowest(t->g0, t->g1, t->g2, t->third, width);
    return (second > cubic ? second : cubic) - t->fast;
}

/* first_event._bound: a lower bound of Re Σ c_j τ^p_j e^{ν_j τ} on [a, b] (the column's sizes in
 * s->sizes). */
static double bound(Search *s, const cplx *c, const int64_t *p, const cplx *nu, int64_t terms, double a, double b) {
    prepare(s, nu, terms, a, b);
    Sums t = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    accumulate(&t, s, c, s->sizes, p, nu, terms, a, b);
    return bound_of(&t, b - a);
}

/* first_event._bound of -g' (terms -c ν τ^p e^{ντ}, then -c p τ^{p-1} e^{ντ}) on [a, b], over
 * the factors prepared for g's bound on the same interval. */
static double slope_bound(Search *s, const cplx *nu, int64_t terms, double a, double b) {
    prepare(s, nu, terms, a, b);
    Sums t = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    accumulate(&t, s, s->dc, s->d_sizes, s->dp, nu, terms, a, b);
    accumulate(&t, s, s->dc + terms, s->d_sizes + terms, s->dp + terms, nu, terms, a, b);
    return bound_of(&t, b - a);
}

/* first_event._refine: the root in [a, b] (g(a) >= 0 > g(b)) to a few ulps, Illinois (gb: g(b),
 * known to the caller). */
static double refine(const cplx *c, const int64_t *p, const cplx *nu, int64_t terms, double a, double b,
                     double gb) {
    double ga = value_at(c, p, nu, terms, a);
    if (ga <= 0.0)
        return a;
    if (gb >= 0.0)
        return b;
    int side = 0;
    for (int i = 0; i < 400; i++) {
        if (b - a <= 4 * EPSILON * fmax(fabs(b), 1e-300))
            break;
        double m = b - gb * (b - a) / (gb - ga);
        if (!(a < m && m < b))
            m = 0.5 * (a + b);
        double gm = value_at(c, p, nu, terms, m);
        if (gm == 0.0)
            return m;
        if (gm > 0.0) {
            a = m;
            ga = gm;
            if (side == 1)
                gb *= 0.5;
            side = 1;
        } else {
            b = m;
            gb = gm;
            if (side == -1)
                ga *= 0.5;
            side = -1;
        }
    }
    return b;
}

/* first_event._first_root: the first τ in (0, horizon] where the function (the column in
 * s->column, its sizes in s->sizes) goes below -tol, or -1 when none, UNRESOLVED when the
 * search gave up (MAX_VISITS). */
static double first_root(Search *s, const cplx *c, const int64_t *p, const cplx *nu, int64_t terms,
                         double horizon, double tol, double resolution) {
    for (int64_t j = 0; j < terms; j++) {
        cplx minus = {-c[j].re, -c[j].im};
        s->dc[j] = cmul(minus, nu[j]);
        s->dp[j] = p[j];
        s->dc[terms + j] = cscale(minus, (double)p[j]);
        s->dp[terms + j] = p[j] > 1 ? p[j] - 1 : 0;
    }
    for (int64_t j = 0; j < 2 * terms; j++)
        s->d_sizes[j] = csize(s->dc[j].re, s->dc[j].im);
    s->starts[0] = 0.0;
    s->ends[0] = horizon;
    s->end_values[0] = NAN;
    s->depths[0] = 0;
    int64_t top = 1, visits = 0;
    while (top > 0) {
        visits += 1;
        if (visits > MAX_VISITS)
            return UNRESOLVED;
        top -= 1;
        double a = s->starts[top], b = s->ends[top], known = s->end_values[top];
        int64_t depth = s->depths[top];
        if (bound(s, c, p, nu, terms, a, b) > -tol)
            continue;
        /* (a right half ends where its interval did: its g(b) is the one computed there) */
        double gb = isnan(known) ? value_at(c, p, nu, terms, b) : known;
        if (gb < -tol && slope_bound(s, nu, terms, a, b) > 0.0)
            return refine(c, p, nu, terms, a, b, gb);
        if (b - a <= resolution || depth >= MAX_DEPTH) {
            if (gb < -tol)
                return refine(c, p, nu, terms, a, b, gb);
            continue;
        }
        double m = 0.5 * (a + b);
        s->starts[top] = m;
        s->ends[top] = b;
        s->end_values[top] = gb;
        s->depths[top] = depth + 1;
        s->starts[top + 1] = a;
        s->ends[top + 1] = m;
        s->end_values[top + 1] = NAN;
        s->depths[top + 1] = depth + 1;
        top += 2;
    }
    return -1.0;
}

/* Column k of a table (terms, columns) into s->column, its terms' sizes into s->sizes. */
static const cplx *column_of(Search *s, const cplx *table, int64_t terms, int64_t columns, int64_t k) {
    for (int64_t j = 0; j < terms; j++) {
        s->column[j] = table[j * columns + k];
        s->sizes[j] = s->table_sizes[j * columns + k];
    }
    return s->column;
}

/* first_event._first_event: (τ, column) of the earliest root over the columns in (0, horizon];
 * (horizon, -1) when none; (0, -2) when a search gave up. (search_terms and the table's sizes
 * first.) */
static double first_event(Search *s, const cplx *table, int64_t terms, int64_t columns, const int64_t *powers,
                          const cplx *exponents, const double *tolerances, double horizon, int64_t *column) {
    double best = horizon;
    *column = -1;
    double resolution = RESOLUTION * fmax(horizon, 1e-300);
    for (int64_t k = 0; k < columns; k++) {
        const cplx *c = column_of(s, table, terms, columns, k);
        if (bound(s, c, powers, exponents, terms, 0.0, best) > -tolerances[k])
            continue;
        double root = first_root(s, c, powers, exponents, terms, best, tolerances[k], resolution);
        if (root == UNRESOLVED) {
            *column = -2;
            return 0.0;
        }
        if (root >= 0.0 && root < best) {
            best = root;
            *column = k;
        }
    }
    return best;
}

/* e^{ν_j τ} and τ^p_j into s->at_t, s->power_t: value_at's factors, shared by the columns. */
static void factors_at(Search *s, const int64_t *p, const cplx *nu, int64_t terms, double tau) {
    for (int64_t j = 0; j < terms; j++) {
        s->power_t[j] = ipow(tau, p[j]);
        if (s->conjugate[j]) {
            s->at_t[j].re = s->at_t[j - 1].re;
            s->at_t[j].im = -s->at_t[j - 1].im;
        } else {
            s->at_t[j] = cexp_(nu[j].re * tau, nu[j].im * tau);
        }
    }
}

/* value_at of column k of the table from factors_at's factors (the same operations). */
static double column_value(const Search *s, const cplx *table, int64_t terms, int64_t columns, int64_t k) {
    double total = 0.0;
    for (int64_t j = 0; j < terms; j++) {
        cplx scaled = cscale(table[j * columns + k], s->power_t[j]);
        total += scaled.re * s->at_t[j].re - scaled.im * s->at_t[j].im;
    }
    return total;
}

/* first_event._crossed_within_tolerance. (After first_event: its search_terms and sizes.) */
static double crossed_within_tolerance(Search *s, const cplx *table, int64_t terms, int64_t columns,
                                       const int64_t *powers, const cplx *exponents, const double *tolerances,
                                       double tau, int64_t *column, double horizon) {
    double resolution = RESOLUTION * fmax(horizon, 1e-300);
    double at_zero[64];
    int64_t known = columns < 64 ? columns : 0; /* (the values at 0 of the first 64 columns at once) */
    if (known) {
        factors_at(s, powers, exponents, terms, 0.0);
        for (int64_t k = 0; k < known; k++)
            at_zero[k] = column_value(s, table, terms, columns, k);
    }
    factors_at(s, powers, exponents, terms, tau);
    for (int64_t k = 0; k < columns; k++) {
        if (!(column_value(s, table, terms, columns, k) < 0.0))
            continue;
        double start;
        if (k < known) {
            start = at_zero[k];
        } else {
            const cplx *c = column_of(s, table, terms, columns, k);
            start = value_at(c, powers, exponents, terms, 0.0);
        }
        if (start > tolerances[k]) {
            const cplx *c = column_of(s, table, terms, columns, k);
            double root = first_root(s, c, powers, exponents, terms, tau, 0.0, resolution);
            if (root >= 0.0 && root < tau) {
                tau = root;
                *column = k;
                factors_at(s, powers, exponents, terms, tau);
            }
        }
    }
    return tau;
}

/* The search alone (tests: the C search against dense sampling and the numba search). */
EXPORT double circuitnsds_first_event(const cplx *table, int64_t terms, int64_t columns, const int64_t *powers,
                                      const cplx *exponents, const double *tolerances, double horizon,
                                      int64_t *column) {
    Search *s = malloc(sizeof(Search));
    double tau = 0.0;
    *column = -3;
    if (s && search_init(s, terms, columns)) {
        search_terms(s, exponents, terms);
        search_sizes(s, table, terms, columns);
        tau = first_event(s, table, terms, columns, powers, exponents, tolerances, horizon, column);
        if (*column != -2)
            tau = crossed_within_tolerance(s, table, terms, columns, powers, exponents, tolerances, tau,
                                           column, horizon);
    }
    if (s)
        search_free(s);
    free(s);
    return tau;
}

/* ---------------------------------------------------------------- the loop */

/* The order of the entries of the `arrays` argument (addresses); run.NATIVE_ARRAYS names them
 * in the same order, with their dtypes and shapes (all C-contiguous). */
enum {
    A_CLOCK, A_COUNTERS, A_X, A_Y_SIZE, A_SOURCES_NOW, A_WIDENED, A_CORNERS, A_SOURCE_COEFFICIENTS,
    A_SOURCE_EXPONENTS, A_SOURCE_POWERS, A_PARTNER, A_S_MATRIX, A_BITS, A_Z_MAP, A_TABLE_MAP, A_POWERS,
    A_EXPONENTS, A_TERMS, A_SLOPE_WEIGHTS, A_ROWS_P, A_ROWS_Q, A_ROWS_Y, A_ROWS_C, A_FAST_ROWS, A_GAP_ROWS, A_V1T, A_TIMES, A_Y_OUT,
    A_L_OUT, A_CHARGES, A_ROW_ACTIVE, A_ROW_CLOSED, A_EVENT_TIMES, A_EVENT_INDEX, A_EVENT_ON, A_TAIL_ROW,
    A_TAIL_DT, A_TAIL_Y, A_FIRST, A_ENTRIES, A_COUNT_ARRAYS
};

/* The order of the entries of the `sizes` argument (int64); run.NATIVE_SIZES. */
enum {
    S_N, S_M, S_COLUMNS, S_STATES, S_SOURCE_TERMS, S_SIGNALS, S_CORNERS, S_KNOWN, S_TERMS_MAX, S_INPUTS,
    S_ROWS, S_EVENT_CAPACITY, S_TAIL_CAPACITY, S_COUNT_SIZES
};

typedef struct {
    int64_t n, m, columns, r, J, S, corners_count, known, T, I, rows_total, event_capacity, tail_capacity;
    double *clock;
    int64_t *counters;
    double *x, *y_size;
    cplx *sources_now;
    double *widened;
    const double *corners;
    const cplx *source_coefficients, *source_exponents;
    const int64_t *source_powers, *partner;
    const double *s_matrix;
    const uint8_t *bits;
    const cplx *z_map, *table_map;
    const int64_t *powers;
    const cplx *exponents;
    const int64_t *terms;
    const cplx *slope_weights;
    const double *rows_p, *rows_q, *rows_y, *rows_c, *fast_rows, *gap_rows, *v1t, *times;
    double *y_out, *l_out, *charges;
    uint8_t *row_active, *row_closed;
    double *event_times;
    int64_t *event_index;
    uint8_t *event_on;
    int64_t *tail_row;
    double *tail_dt, *tail_y;
    /* each mode's nonzero entries, listed by Python when the mode joins (mode_tables.py): the
     * lines of mode `mode` start at first + mode * lines_per_mode: the event table's lines
     * (T·columns over I inputs), then rows_q's and rows_y's (columns lines over n each), then
     * the z map's (T·(n + m) over I: a few % of its entries are not 0, as a term of a source's
     * exponent reads only that source's inputs and a mode's own exponent only the state), then
     * the end; first[line] .. first[line + 1] index `entries`, the line's nonzero columns */
    const int64_t *first;
    const int32_t *entries;
    /* the nonzero entries of S's rows (s_entries[s_first[i]] ... of row i: the sources that
     * drive unknown i), listed once per call; a zero entry adds ±0 to a sum that is +0 */
    int64_t *s_first, *s_entries;
} Exact;

/* The lines of a mode's lists: the event table's, rows_q's, rows_y's, the z map's, and the end
 * (mode_tables.ModeTables.lines_per_mode). */
static inline int64_t lines_per_mode(const Exact *L) {
    return L->T * L->columns + 2 * L->columns + L->T * (L->n + L->m) + 1;
}

/* loop._shifted: the sources' piece k shifted by delta into L->sources_now. */
static void shifted(const Exact *L, int64_t k, double delta) {
    const cplx *coefficients = L->source_coefficients + k * L->J * L->S;
    for (int64_t j = 0; j < L->J; j++) {
        cplx factor = cexp_(L->source_exponents[j].re * delta, L->source_exponents[j].im * delta);
        for (int64_t s = 0; s < L->S; s++)
            L->sources_now[j * L->S + s] = cmul(coefficients[j * L->S + s], factor);
    }
    for (int64_t j = 0; j < L->J; j++) {
        int64_t q = L->partner[j];
        if (q >= 0)
            for (int64_t s = 0; s < L->S; s++) {
                cplx *to = &L->sources_now[q * L->S + s];
                cplx from = L->sources_now[j * L->S + s];
                to->re += delta * from.re;
                to->im += delta * from.im;
            }
    }
}

static inline double ulp_of(double t) { return EPSILON * fmax(fabs(t), 1e-300); }

/* loop._functions: the mode's event functions (table (T, columns)) and their round-off, over the
 * mode's nonzero map entries and rows (its lists: Exact.first). A zero entry adds ±0 to a sum
 * that is never -0 (it starts at +0, and x + (-x) is +0): summing the nonzero entries alone
 * gives the numba loop's sums bit for bit. */
static void functions(const Exact *L, int64_t mode, const cplx *inputs, const double *x, const double *y_size, const double *forcing, double instant, cplx *table,
                      double *tolerances, double *sizes) {
    int64_t count = L->terms[mode], columns = L->columns, I = L->I;
    const cplx *map = L->table_map + mode * (L->T * columns) * I;
    const int64_t *first = L->first + mode * lines_per_mode(L);
    const int32_t *entries = L->entries;
    for (int64_t j = 0; j < count; j++)
        for (int64_t k = 0; k < columns; k++) {
            const int64_t line_index = j * columns + k;
            const cplx *line = map + line_index * I;
            cplx total = {0.0, 0.0};
            for (int64_t e = first[line_index]; e < first[line_index + 1]; e++) {
                int32_t i = entries[e];
                cplx product = cmul(line[i], inputs[i]);
                total.re += product.re;
                total.im += product.im;
            }
            table[j * columns + k] = total;
        }
    const int64_t *first_q = first + L->T * columns, *first_y = first_q + columns;
    for (int64_t k = 0; k < columns; k++) {
        double scale = L->rows_c[mode * columns + k];
        const double *rp = L->rows_p + (mode * columns + k) * L->r;
        const double *rq = L->rows_q + (mode * columns + k) * L->n;
        const double *ry = L->rows_y + (mode * columns + k) * L->n;
        for (int64_t i = 0; i < L->r; i++)
            scale += rp[i] * fabs(x[i]);
        for (int64_t e = first_q[k]; e < first_q[k + 1]; e++)
            scale += rq[entries[e]] * forcing[entries[e]];
        double summed = 0.0;
        for (int64_t e = first_y[k]; e < first_y[k + 1]; e++)
            summed += ry[entries[e]] * y_size[entries[e]];
        double slope = 0.0, terms_size = 0.0;
        for (int64_t j = 0; j < count; j++) {
            cplx product = cmul(L->slope_weights[mode * L->T + j], table[j * columns + k]);
            slope += product.re;
            sizes[j * columns + k] = csize(table[j * columns + k].re, table[j * columns + k].im);
            terms_size += sizes[j * columns + k];
        }
        const double *rg = L->gap_rows + (mode * columns + k) * L->r;
        double gap = 0.0; /* (the modal sum's gap to P x at tau = 0: run.ExactSystem.gap_rows) */
        for (int64_t i = 0; i < L->r; i++)
            gap += rg[i] * x[i];
        tolerances[k] = (RELATIVE_TOL * scale + SUM_ULPS * EPSILON * summed + fabs(slope) * TIME_ULPS * ulp_of(instant)
                         + SUM_ULPS * EPSILON * terms_size + 1e-300) + fabs(gap);
    }
}

/* loop._fast_offset: what the state's part along the mode's fast modes adds to function c at the
 * start, where it counts (FAST_SIGNIFICANT), else 0. */
static double fast_offset(const Exact *L, int64_t mode, int64_t c, const double *x) {
    const double *row = L->fast_rows + (mode * L->columns + c) * L->r;
    double total = 0.0, size = 0.0;
    for (int64_t i = 0; i < L->r; i++) {
        total += row[i] * x[i];
        size += fabs(row[i]) * fabs(x[i]);
    }
    return fabs(total) > FAST_SIGNIFICANT * size ? total : 0.0;
}

/* loop._violated: function k (with offset added: fast_offset) negative at 0, or zero and decreasing (to the second derivative) by more
 * than its round-off. */
static int violated(const cplx *table, int64_t columns, const int64_t *powers, const cplx *exponents, int64_t count,
                    int64_t k, double tolerance, double offset) {
    double value = 0.0;
    for (int64_t j = 0; j < count; j++)
        if (powers[j] == 0)
            value += table[j * columns + k].re;
    value += offset;
    if (value < -tolerance)
        return 1;
    if (value > tolerance)
        return 0;
    double d1 = 0.0, size1 = 0.0, d2 = 0.0, size2 = 0.0;
    for (int64_t j = 0; j < count; j++) {
        cplx c = table[j * columns + k], nu = exponents[j];
        int64_t p = powers[j];
        cplx cn = cmul(c, nu), cnn = cmul(cn, nu);
        double size_c = csize(c.re, c.im), size_cn = csize(cn.re, cn.im);
        size1 += size_cn + (p > 0 ? size_c * p : 0.0);
        size2 += csize(cnn.re, cnn.im) + (p > 0 ? 2 * size_cn * p : 0.0) + (p > 1 ? size_c * p * (p - 1) : 0.0);
        if (p == 0) {
            d1 += cn.re;
            d2 += cnn.re;
        } else if (p == 1) {
            d1 += c.re;
            d2 += 2 * cn.re;
        } else if (p == 2) {
            d2 += 2 * c.re;
        }
    }
    double tolerance1 = RELATIVE_TOL * size1 + 1e-300;
    if (d1 < -tolerance1)
        return !(d2 > RELATIVE_TOL * size2 && value - d1 * d1 / (2.0 * d2) >= -tolerance);
    if (fabs(d1) <= tolerance1)
        return d2 < -(RELATIVE_TOL * size2 + 1e-300);
    return 0;
}

/* loop._find: the index of mode `wanted` among the known ones, or -1. */
static int64_t find(const Exact *L, const uint8_t *wanted) {
    for (int64_t i = 0; i < L->known; i++) {
        const uint8_t *b = L->bits + i * L->columns;
        int64_t k = 0;
        while (k < L->columns && b[k] == wanted[k])
            k++;
        if (k == L->columns)
            return i;
    }
    return -1;
}

/* loop._grown. */
static inline void grown(double nu_re, double nu_im, double tau, double *re, double *im) {
    if (nu_im == 0.0) {
        *re = nu_re == 0.0 ? 1.0 : exp(nu_re * tau);
        *im = 0.0;
    } else {
        double size = exp(nu_re * tau);
        *re = size * cos(nu_im * tau);
        *im = size * sin(nu_im * tau);
    }
}

/* complex division a / b as numba has it (numba's complex division: Smith's algorithm). */
static cplx cdiv(cplx a, cplx b) {
    double abs_breal = fabs(b.re), abs_bimag = fabs(b.im);
    cplx r;
    if (abs_breal >= abs_bimag) {
        if (abs_breal == 0.0 && abs_bimag == 0.0) {
            r.re = a.re / abs_breal;
            r.im = a.im / abs_breal;
            return r;
        }
        double ratio = b.im / b.re, denom = b.re + b.im * ratio;
        r.re = (a.re + a.im * ratio) / denom;
        r.im = (a.im - a.re * ratio) / denom;
    } else {
        double ratio = b.re / b.im, denom = b.re * ratio + b.im;
        r.re = (a.re * ratio + a.im) / denom;
        r.im = (a.im * ratio - a.re) / denom;
    }
    return r;
}

/* loop._moments: J_q(w) = ∫_0^w s^q e^{νs} ds for q = 0..p into out. */
static void moments_of(cplx nu, int64_t p, double w, cplx *out) {
    cplx nw = cscale(nu, w);
    if (nu.re == 0.0 && nu.im == 0.0) {
        for (int64_t q = 0; q <= p; q++) {
            out[q].re = ipow(w, q + 1) / (double)(q + 1);
            out[q].im = 0.0;
        }
    } else if (csize(nw.re, nw.im) < 1.0) {
        for (int64_t q = 0; q <= p; q++) {
            cplx series = {0.0, 0.0}, term = {1.0, 0.0};
            for (int64_t k = 0; k < SERIES_TERMS; k++) {
                series.re += term.re / (double)(q + k + 1);
                series.im += term.im / (double)(q + k + 1);
                term = cmul(term, nw);
                term.re /= (double)(k + 1);
                term.im /= (double)(k + 1);
                if (k % 4 == 3 && csize(term.re, term.im) <= 1e-17)
                    break;
            }
            out[q] = cscale(series, ipow(w, q + 1));
        }
    } else {
        cplx g = cexp_(nw.re, nw.im);
        cplx less = {g.re - 1.0, g.im};
        out[0] = cdiv(less, nu);
        for (int64_t q = 1; q <= p; q++) {
            cplx top = {ipow(w, q) * g.re - q * out[q - 1].re, ipow(w, q) * g.im - q * out[q - 1].im};
            out[q] = cdiv(top, nu);
        }
    }
}

/* Per-segment scratch of the rows (loop.py's arrays of the same names). */
typedef struct {
    double *nu_re, *nu_im, *growth_re, *growth_im, *at_re, *at_im, *integral_re, *integral_im, *kept_w, *values, *z_re, *z_im, *y_end, *size_end, *forcing, *tolerances, *kept_w2, *kept_re2,
        *kept_im2;
    cplx *moments, *inputs, *table;
    int64_t *pairs, *seen, *next_slot;
    uint8_t *wanted, *conjugate;
    int64_t top_power;
} Rows;

static const double BINOMIALS[5][6] = {
    {1, 0, 0, 0, 0, 0}, {1, 1, 0, 0, 0, 0}, {1, 2, 1, 0, 0, 0}, {1, 3, 3, 1, 0, 0}, {1, 4, 6, 4, 1, 0}};

/* loop._integral: ∫_a^{a+w} τ^p e^{ντ} dτ (re, im) for term j, e^{νa} = at. */
static inline void integral(Rows *R, int64_t j, int64_t p, double a, double w, double *out_re, double *out_im) {
    double nu_re = R->nu_re[j], nu_im = R->nu_im[j], at_re = R->at_re[j], at_im = R->at_im[j];
    if (p == 0) {
        if (nu_im == 0.0 && nu_re == 0.0) {
            *out_re = w;
            *out_im = 0.0;
            return;
        }
        /* expm1(νw)/ν kept for the last two widths (a uniform grid's rows differ in width by
         * an ulp or two from row to row: two values, most often) */
        int64_t slot = R->kept_w2[2 * j] == w ? 0 : R->kept_w2[2 * j + 1] == w ? 1 : -1;
        if (slot < 0) {
            slot = R->next_slot[j];
            R->next_slot[j] = 1 - slot;
            double *kept_re = R->kept_re2 + 2 * j + slot, *kept_im = R->kept_im2 + 2 * j + slot;
            if (nu_im == 0.0) {
                *kept_re = expm1(nu_re * w) / nu_re;
                *kept_im = 0.0;
            } else {
                double x = nu_re * w, y = nu_im * w;
                double half = sin(0.5 * y);
                double e_re = expm1(x) * cos(y) - 2.0 * half * half;
                double e_im = exp(x) * sin(y);
                double size = nu_re * nu_re + nu_im * nu_im;
                *kept_re = (e_re * nu_re + e_im * nu_im) / size;
                *kept_im = (e_im * nu_re - e_re * nu_im) / size;
            }
            R->kept_w2[2 * j + slot] = w;
        }
        double q_re = R->kept_re2[2 * j + slot], q_im = R->kept_im2[2 * j + slot];
        if (nu_im == 0.0) {
            *out_re = at_re * q_re;
            *out_im = 0.0;
        } else {
            *out_re = at_re * q_re - at_im * q_im;
            *out_im = at_re * q_im + at_im * q_re;
        }
        return;
    }
    cplx *moments = R->moments + j * (R->top_power + 1);
    if (R->kept_w[j] != w) {
        cplx nu = {nu_re, nu_im};
        moments_of(nu, p, w, moments);
        R->kept_w[j] = w;
    }
    double weight_re = 0.0, weight_im = 0.0, binomial = 1.0;
    for (int64_t q = 0; q <= p; q++) {
        double factor = binomial * ipow(a, p - q);
        weight_re += factor * moments[q].re;
        weight_im += factor * moments[q].im;
        /* (C(p, q + 1): exact integers either way, the table spares two divisions) */
        binomial = p <= 4 ? BINOMIALS[p][q + 1] : binomial * (double)(p - q) / (double)(q + 1);
    }
    *out_re = weight_re * at_re - weight_im * at_im;
    *out_im = weight_re * at_im + weight_im * at_re;
}

/* loop._charge: out[i] += ∫_a^b λ_i dτ for each active pair. */
static void charge(Rows *R, int64_t n, int64_t width, int64_t pair_count, const int64_t *powers, int64_t count,
                   double a, double b, double *out) {
    if (pair_count == 0)
        return;
    double w = b - a;
    for (int64_t j = 0; j < count; j++)
        integral(R, j, powers[j], a, w, &R->integral_re[j], &R->integral_im[j]);
    for (int64_t k = 0; k < pair_count; k++) {
        int64_t i = R->pairs[k];
        double total = 0.0;
        for (int64_t j = 0; j < count; j++) {
            const double zr = R->z_re[j * width + n + i];
            if (R->nu_im[j] == 0.0)
                total += zr * R->integral_re[j];
            else
                total += zr * R->integral_re[j] - R->z_im[j * width + n + i] * R->integral_im[j];
        }
        out[i] += total;
    }
}

/* values[i] += zr[i] w for i < width (four at a time: each element's sum in the numba loop's
 * order, the four independent). */
static inline void add_real(double *restrict values, const double *restrict zr, double w, int64_t width) {
    int64_t i = 0;
    for (; i + 4 <= width; i += 4) {
        double a = zr[i] * w, b = zr[i + 1] * w, c = zr[i + 2] * w, d = zr[i + 3] * w;
        values[i] += a;
        values[i + 1] += b;
        values[i + 2] += c;
        values[i + 3] += d;
    }
    for (; i < width; i++)
        values[i] += zr[i] * w;
}

/* values[i] += zr[i] w_re - zi[i] w_im for i < width. */
static inline void add_complex(double *restrict values, const double *restrict zr, const double *restrict zi,
                               double w_re, double w_im, int64_t width) {
    int64_t i = 0;
    for (; i + 2 <= width; i += 2) {
        double a = zr[i] * w_re - zi[i] * w_im, b = zr[i + 1] * w_re - zi[i + 1] * w_im;
        values[i] += a;
        values[i + 1] += b;
    }
    for (; i < width; i++)
        values[i] += zr[i] * w_re - zi[i] * w_im;
}

static int64_t run(Exact *L, Rows *R, Search *search) {
    const int64_t n = L->n, m = L->m, width = n + m, columns = L->columns, T = L->T, I = L->I;
    const int64_t rows_total = L->rows_total;
    const double stop = L->corners[L->corners_count - 1];
    double *x = L->x, *y_size = L->y_size;
    int64_t *counters = L->counters;
    double t = L->clock[0];
    int64_t k = counters[0], mode = counters[1], chosen = counters[2], row = counters[3], events = counters[4],
            segments = counters[5], stalled = counters[6], quiet = counters[7], tails = counters[8];
    int64_t status = FINISHED;
    cplx *inputs = R->inputs, *table = R->table;
    double *tolerances = R->tolerances, *forcing = R->forcing;
    while (t < stop || (t == stop && row < rows_total)) {
        if (events + columns > L->event_capacity || tails + 1 > L->tail_capacity) {
            status = EVENTS_FULL;
            break;
        }
        double threshold = t * (1 + 1e-15) + 1e-300;
        while (k + 2 < L->corners_count && L->corners[k + 1] <= threshold)
            k += 1;
        double end = L->corners[k + 1];
        shifted(L, k, t - L->corners[k]);
        /* inputs [x; s; 1] and the forcing's size Σ_terms |S f_term| at τ = 0 */
        for (int64_t i = 0; i < L->r; i++) {
            inputs[i].re = x[i];
            inputs[i].im = 0.0;
        }
        int64_t position = L->r;
        for (int64_t j = 0; j < L->J * L->S; j++)
            inputs[position++] = L->sources_now[j];
        inputs[position].re = 1.0;
        inputs[position].im = 0.0;
        for (int64_t i = 0; i < n; i++)
            forcing[i] = 0.0;
        for (int64_t j = 0; j < L->J; j++)
            if (L->source_powers[j] == 0)
                for (int64_t i = 0; i < n; i++) {
                    if (L->s_first[i] == L->s_first[i + 1])
                        continue; /* (a row of S without a source: its size stays +0, as numba's) */
                    cplx total = {0.0, 0.0};
                    for (int64_t e = L->s_first[i]; e < L->s_first[i + 1]; e++) {
                        int64_t s = L->s_entries[e];
                        cplx v = L->sources_now[j * L->S + s];
                        double a = L->s_matrix[i * L->S + s];
                        /* (numba: a real times a complex, the real as a + 0i) */
                        total.re += a * v.re - 0.0 * v.im;
                        total.im += a * v.im + 0.0 * v.re;
                    }
                    forcing[i] += csize(total.re, total.im);
                }
        int real_inputs = 1;
        for (int64_t q = 0; q < I; q++)
            real_inputs = real_inputs && inputs[q].im == 0.0;
        int64_t previous = mode;
        int from_python = chosen == 1;
        int64_t changes = 0;
        for (;;) {
            functions(L, mode, inputs, x, y_size, forcing, t, table, tolerances, search->table_sizes);
            if (chosen == 1)
                break;
            int any_bad = 0, pair_bad = 0;
            for (int64_t c = 0; c < columns; c++) {
                int bad = violated(table, columns, L->powers + mode * T, L->exponents + mode * T, L->terms[mode], c,
                                   tolerances[c], fast_offset(L, mode, c, x));
                R->wanted[c] = (uint8_t)(L->bits[mode * columns + c] != bad);
                any_bad = any_bad || bad;
                pair_bad = pair_bad || (bad && c < m);
            }
            if (!any_bad)
                break;
            if (pair_bad) /* (the switches flip once the pairs hold: run.choose_mode) */
                for (int64_t c = m; c < columns; c++)
                    R->wanted[c] = L->bits[mode * columns + c];
            R->seen[changes] = mode;
            changes += 1;
            int64_t following = find(L, R->wanted);
            int cycled = following < 0 || changes >= MAX_MODE_CHANGES;
            for (int64_t i = 0; i < changes; i++)
                if (R->seen[i] == following)
                    cycled = 1;
            if (cycled) {
                status = NEW_MODE;
                break;
            }
            mode = following;
        }
        if (status != FINISHED) {
            mode = previous;
            break;
        }
        if (from_python)
            for (int64_t c = 0; c < columns; c++) {
                tolerances[c] = fmax(tolerances[c], L->widened[c]);
                L->widened[c] = 0.0;
            }
        chosen = 0;
        int64_t quiet_here = quiet;
        if (quiet == 0)
            for (int64_t c = 0; c < columns; c++)
                if (L->bits[mode * columns + c] != L->bits[previous * columns + c]) {
                    L->event_times[events] = t;
                    L->event_index[events] = c;
                    L->event_on[events] = L->bits[mode * columns + c];
                    events += 1;
                }
        quiet = 0;
        const int64_t count = L->terms[mode];
        const int64_t *powers = L->powers + mode * T;
        const cplx *exponents = L->exponents + mode * T;
        double horizon = end - t;
        int64_t ended_by;
        search_terms(search, exponents, count); /* (the table's sizes: functions()) */
        double tau = first_event(search, table, count, columns, powers, exponents, tolerances, horizon, &ended_by);
        if (ended_by == -2) {
            status = STALLED;
            break;
        }
        tau = crossed_within_tolerance(search, table, count, columns, powers, exponents, tolerances, tau,
                                       &ended_by, horizon);
        segments += 1;
        double stop_at = t + tau;
        int64_t pair_count = 0;
        for (int64_t i = 0; i < m; i++)
            if (L->bits[mode * columns + i])
                R->pairs[pair_count++] = i;
        for (int64_t j = 0; j < count; j++) {
            R->nu_re[j] = exponents[j].re;
            R->nu_im[j] = exponents[j].im;
            R->conjugate[j] = j > 0 && exponents[j].im != 0.0 && exponents[j].re == exponents[j - 1].re
                              && exponents[j].im == -exponents[j - 1].im;
            R->kept_w[j] = -1.0;
            R->kept_w2[2 * j] = -1.0;
            R->kept_w2[2 * j + 1] = -1.0;
            R->next_slot[j] = 0;
        }
        /* z = [y; λ] per term; the pairs' columns only when a row or a row's charge needs them */
        int64_t size = row < rows_total && (L->times[row] <= stop_at || (tau > 0 && pair_count > 0)) ? width : n;
        const cplx *z_map = L->z_map + mode * (T * width) * I;
        const int64_t *first_z = L->first + mode * lines_per_mode(L) + T * columns + 2 * columns;
        for (int64_t j = 0; j < count; j++)
            for (int64_t i = 0; i < size; i++) {
                const cplx *line = z_map + (j * width + i) * I;
                const int64_t from = first_z[j * width + i], to = first_z[j * width + i + 1];
                double total_re = 0.0, total_im = 0.0; /* (over the line's nonzero entries) */
                if (real_inputs) {
                    for (int64_t e = from; e < to; e++) {
                        int32_t q = L->entries[e];
                        total_re += line[q].re * inputs[q].re;
                        total_im += line[q].im * inputs[q].re;
                    }
                } else {
                    for (int64_t e = from; e < to; e++) {
                        int32_t q = L->entries[e];
                        cplx value = cmul(line[q], inputs[q]);
                        total_re += value.re;
                        total_im += value.im;
                    }
                }
                R->z_re[j * width + i] = total_re;
                R->z_im[j * width + i] = total_im;
            }
        int first_row = 1;
        double *values = R->values;
        while (row < rows_total && L->times[row] <= stop_at) {
            double local = L->times[row] - t;
            double begin = fmax(L->times[row - 1] - t, 0.0);
            /* e^{ν local} for each row from its own time (nothing carried from the row
             * before: a run in parts, whose parts start at any row, is the run in one part) */
            for (int64_t j = 0; j < count; j++) {
                if (!first_row) {
                    R->at_re[j] = R->growth_re[j];
                    R->at_im[j] = R->growth_im[j];
                } else if (begin > 0.0) {
                    grown(R->nu_re[j], R->nu_im[j], begin, &R->at_re[j], &R->at_im[j]);
                } else {
                    R->at_re[j] = 1.0;
                    R->at_im[j] = 0.0;
                }
                if (R->conjugate[j]) { /* e^{ν̄τ} = conj e^{ντ}: exp, cos even, sin odd, bit for bit */
                    R->growth_re[j] = R->growth_re[j - 1];
                    R->growth_im[j] = -R->growth_im[j - 1];
                } else {
                    grown(R->nu_re[j], R->nu_im[j], local, &R->growth_re[j], &R->growth_im[j]);
                }
            }
            for (int64_t i = 0; i < width; i++)
                values[i] = 0.0;
            for (int64_t j = 0; j < count; j++) {
                int64_t p = powers[j];
                double w_re = R->growth_re[j], w_im = R->growth_im[j];
                if (p) {
                    double power = ipow(local, p);
                    w_re *= power;
                    w_im *= power;
                }
                if (R->nu_im[j] == 0.0)
                    add_real(values, R->z_re + j * width, w_re, width);
                else
                    add_complex(values, R->z_re + j * width, R->z_im + j * width, w_re, w_im, width);
            }
            double *y_row = L->y_out + row * n, *l_row = L->l_out + row * m;
            for (int64_t i = 0; i < n; i++)
                y_row[i] = values[i];
            for (int64_t i = 0; i < m; i++)
                l_row[i] = values[n + i];
            const uint8_t *mode_bits = L->bits + mode * columns;
            for (int64_t c = 0; c < m; c++)
                L->row_active[row * m + c] = mode_bits[c];
            for (int64_t c = m; c < columns; c++)
                L->row_closed[row * (columns - m) + c - m] = mode_bits[c];
            charge(R, n, width, pair_count, powers, count, begin, local, L->charges + row * m);
            if (first_row && L->times[row - 1] < t) { /* the row's interval holds this segment's start */
                L->tail_row[tails] = row;
                L->tail_dt[tails] = local;
                for (int64_t i = 0; i < n; i++) {
                    double value = 0.0;
                    for (int64_t j = 0; j < count; j++)
                        if (powers[j] == 0)
                            value += R->z_re[j * width + i];
                    L->tail_y[tails * n + i] = value;
                }
                tails += 1;
            }
            first_row = 0;
            row += 1;
        }
        if (row < rows_total && tau > 0) { /* the next row's interval holds this segment's end */
            double begin = fmax(L->times[row - 1] - t, 0.0);
            if (tau > begin && pair_count > 0) {
                for (int64_t j = 0; j < count; j++)
                    grown(R->nu_re[j], R->nu_im[j], begin, &R->at_re[j], &R->at_im[j]);
                charge(R, n, width, pair_count, powers, count, begin, tau, L->charges + row * m);
            }
        }
        if (row >= rows_total) { /* (the state stays at this segment's start, to resume from) */
            mode = previous;
            quiet = quiet_here;
            break;
        }
        for (int64_t i = 0; i < n; i++) {
            R->y_end[i] = 0.0;
            R->size_end[i] = 0.0;
        }
        for (int64_t j = 0; j < count; j++) {
            double w_re, w_im;
            grown(R->nu_re[j], R->nu_im[j], tau, &w_re, &w_im);
            int64_t p = powers[j];
            if (p) {
                double power = ipow(tau, p);
                w_re *= power;
                w_im *= power;
            }
            double magnitude = csize(w_re, w_im);
            const double *zr = R->z_re + j * width, *zi = R->z_im + j * width;
            for (int64_t i = 0; i < n; i++) {
                R->y_end[i] += zr[i] * w_re - zi[i] * w_im;
                R->size_end[i] += csize(zr[i], zi[i]) * magnitude;
            }
        }
        for (int64_t i = 0; i < L->r; i++) {
            double total = 0.0;
            for (int64_t q = 0; q < n; q++)
                total += L->v1t[i * n + q] * R->y_end[q];
            x[i] = total;
        }
        for (int64_t i = 0; i < n; i++)
            y_size[i] = R->size_end[i];
        double new_t = tau < horizon ? stop_at : end;
        stalled = new_t - t < CHATTERING * stop ? stalled + 1 : 0; /* (loop._exact_loop) */
        t = new_t;
        if (stalled > MAX_MODE_CHANGES) {
            status = STALLED;
            break;
        }
    }
    L->clock[0] = t;
    counters[0] = k;
    counters[1] = mode;
    counters[2] = chosen;
    counters[3] = row;
    counters[4] = events;
    counters[5] = segments;
    counters[6] = stalled;
    counters[7] = quiet;
    counters[8] = tails;
    return status;
}

/* loop._exact_loop: `arrays` the addresses (A_*), `sizes` the integers (S_*); returns the
 * status (FINISHED ...; OUT_OF_MEMORY when its scratch could not be allocated: nothing done). */
EXPORT int64_t circuitnsds_exact_loop(void *const *arrays, const int64_t *sizes) {
    Exact L;
    L.n = sizes[S_N];
    L.m = sizes[S_M];
    L.columns = sizes[S_COLUMNS];
    L.r = sizes[S_STATES];
    L.J = sizes[S_SOURCE_TERMS];
    L.S = sizes[S_SIGNALS];
    L.corners_count = sizes[S_CORNERS];
    L.known = sizes[S_KNOWN];
    L.T = sizes[S_TERMS_MAX];
    L.I = sizes[S_INPUTS];
    L.rows_total = sizes[S_ROWS];
    L.event_capacity = sizes[S_EVENT_CAPACITY];
    L.tail_capacity = sizes[S_TAIL_CAPACITY];
    L.clock = arrays[A_CLOCK];
    L.counters = arrays[A_COUNTERS];
    L.x = arrays[A_X];
    L.y_size = arrays[A_Y_SIZE];
    L.sources_now = arrays[A_SOURCES_NOW];
    L.widened = arrays[A_WIDENED];
    L.corners = arrays[A_CORNERS];
    L.source_coefficients = arrays[A_SOURCE_COEFFICIENTS];
    L.source_exponents = arrays[A_SOURCE_EXPONENTS];
    L.source_powers = arrays[A_SOURCE_POWERS];
    L.partner = arrays[A_PARTNER];
    L.s_matrix = arrays[A_S_MATRIX];
    L.bits = arrays[A_BITS];
    L.z_map = arrays[A_Z_MAP];
    L.table_map = arrays[A_TABLE_MAP];
    L.powers = arrays[A_POWERS];
    L.exponents = arrays[A_EXPONENTS];
    L.terms = arrays[A_TERMS];
    L.slope_weights = arrays[A_SLOPE_WEIGHTS];
    L.rows_p = arrays[A_ROWS_P];
    L.rows_q = arrays[A_ROWS_Q];
    L.rows_y = arrays[A_ROWS_Y];
    L.rows_c = arrays[A_ROWS_C];
    L.fast_rows = arrays[A_FAST_ROWS];
    L.gap_rows = arrays[A_GAP_ROWS];
    L.v1t = arrays[A_V1T];
    L.times = arrays[A_TIMES];
    L.y_out = arrays[A_Y_OUT];
    L.l_out = arrays[A_L_OUT];
    L.charges = arrays[A_CHARGES];
    L.row_active = arrays[A_ROW_ACTIVE];
    L.row_closed = arrays[A_ROW_CLOSED];
    L.event_times = arrays[A_EVENT_TIMES];
    L.event_index = arrays[A_EVENT_INDEX];
    L.event_on = arrays[A_EVENT_ON];
    L.tail_row = arrays[A_TAIL_ROW];
    L.tail_dt = arrays[A_TAIL_DT];
    L.tail_y = arrays[A_TAIL_Y];
    L.s_first = malloc(sizeof(int64_t) * (size_t)(L.n + 1));
    L.s_entries = malloc(sizeof(int64_t) * (size_t)(L.n * L.S + 1));
    if (L.s_first && L.s_entries) {
        int64_t used = 0;
        for (int64_t i = 0; i < L.n; i++) {
            L.s_first[i] = used;
            for (int64_t s = 0; s < L.S; s++)
                if (L.s_matrix[i * L.S + s] != 0.0)
                    L.s_entries[used++] = s;
        }
        L.s_first[L.n] = used;
    }
    L.first = arrays[A_FIRST];
    L.entries = arrays[A_ENTRIES];

    const int64_t T = L.T, width = L.n + L.m;
    int64_t top_power = 0;
    for (int64_t i = 0; i < L.known * T; i++)
        top_power = L.powers[i] > top_power ? L.powers[i] : top_power;
    Rows R;
    R.top_power = top_power;
    size_t doubles = (size_t)(15 * T + width + 2 * T * width + 3 * L.n + L.columns);
    size_t complexes = (size_t)(T * (top_power + 1) + L.I + T * L.columns + 1);
    double *d = calloc(doubles, sizeof(double));
    cplx *c = calloc(complexes, sizeof(cplx));
    int64_t *ints = calloc((size_t)(L.m + MAX_MODE_CHANGES + T + 1), sizeof(int64_t));
    uint8_t *wanted = calloc((size_t)(L.columns + T + 1), 1);
    Search *search = malloc(sizeof(Search));
    int searching = search && search_init(search, T, L.columns);
    int64_t status = OUT_OF_MEMORY;
    if (d && c && ints && wanted && searching && L.s_first && L.s_entries) {
        double *next = d;
        R.nu_re = next; next += T;
        R.nu_im = next; next += T;
        R.growth_re = next; next += T;
        R.growth_im = next; next += T;
        R.at_re = next; next += T;
        R.at_im = next; next += T;
        R.integral_re = next; next += T;
        R.integral_im = next; next += T;
        R.kept_w = next; next += T;
        R.values = next; next += width;
        R.z_re = next; next += T * width;
        R.z_im = next; next += T * width;
        R.y_end = next; next += L.n;
        R.size_end = next; next += L.n;
        R.forcing = next; next += L.n;
        R.tolerances = next; next += L.columns;
        R.kept_w2 = next; next += 2 * T;
        R.kept_re2 = next; next += 2 * T;
        R.kept_im2 = next;
        cplx *cn = c;
        R.moments = cn; cn += T * (top_power + 1);
        R.inputs = cn; cn += L.I;
        R.table = cn;
        R.pairs = ints;
        R.seen = ints + L.m;
        R.next_slot = ints + L.m + MAX_MODE_CHANGES;
        R.wanted = wanted;
        R.conjugate = wanted + L.columns;
        status = run(&L, &R, search);
    }
    free(d);
    free(c);
    free(ints);
    free(wanted);
    if (search)
        search_free(search);
    free(search);
    free(L.s_first);
    free(L.s_entries);
    return status;
}
