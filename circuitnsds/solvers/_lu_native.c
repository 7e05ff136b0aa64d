/* Dense LU of circuitnsds/solvers/linalg.py in plain C: factorisation with partial pivoting,
 * solves with the factors, and the reciprocal 1-norm condition estimate, so that the small
 * (dense) circuits need no scipy (whose import alone costs a run ~0.3 s). The second section
 * of the file is the pivoting loop of Lemke's method (circuitnsds/solvers/lemke.py), here
 * because its reinversions factorise with this LU (see there).
 *
 * What LAPACK computes, for one matrix at a time:
 *   circuitnsds_lu_factor  dgetf2 (unblocked getrf): the pivot of column k is the first row
 *                          with the largest |value| at or below the diagonal; an exactly zero
 *                          pivot is skipped (the column is left unscaled) and reported; then
 *                          dgecon's estimate of 1/(|K|_1 |K^-1|_1), or 0 (see there).
 *   circuitnsds_lu_solve   dgetrs, no transpose: the row interchanges, then L and U solves.
 *   circuitnsds_lu_rcond   dgecon (norm "1") on given factors: Hager's method as refined by
 *                          Higham (LAPACK dlacn2), with solves by LU and by its transpose.
 * Differences from LAPACK, all at the rounding level or beyond the range where the estimate
 * matters: the column below a pivot is divided by it (dgetf2 multiplies by its reciprocal);
 * the triangular solves of the estimate are plain (dlatrs scales them against overflow: here
 * an overflowing estimate gives rcond 0, as any estimate below ~1e-300 does).
 *
 * Layout: the matrix and its factors are n x n in C (row) order: L (unit diagonal, not
 * stored) below the diagonal, U on and above it, as LAPACK stores them column-wise. The
 * pivots are LAPACK's, 0-based: row k was interchanged with row ipiv[k] (>= k), for
 * k = 0, 1, ... in turn. Right-hand sides are n x nrhs in C order (one vector: nrhs = 1).
 * The triangular solves take the terms of each entry in the order of the reference BLAS
 * (dtrsv / dtrsm), so that they round as it does.
 *
 * Built at install by setup.py (flags -O2 -ffp-contract=off -fno-fast-math: no fused
 * multiply-adds, no reassociation); loaded with ctypes by linalg.py (circuitnsds/native.py
 * checks that the library was built from this very file). No Python API: the arrays come as
 * addresses, checked by linalg.py before the call.
 */

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "native.h"

#if defined(_WIN32)
/* setuptools links the library as an extension module and exports this name on Windows;
 * nothing imports it (circuitnsds.native loads the library with ctypes). */
EXPORT void *PyInit__lu_native(void) { return 0; }
#endif

/* dlacn2's limit on its main iterations. */
#define ITMAX 5

/* The first index of the largest |x[i]| (BLAS idamax, 0-based). */
static int64_t iamax(int64_t n, const double *x) {
    int64_t best = 0;
    double big = fabs(x[0]);
    for (int64_t i = 1; i < n; i++) {
        if (fabs(x[i]) > big) {
            big = fabs(x[i]);
            best = i;
        }
    }
    return best;
}

/* sum |x[i]|, in index order (BLAS dasum). */
static double asum(int64_t n, const double *x) {
    double sum = 0.0;
    for (int64_t i = 0; i < n; i++)
        sum += fabs(x[i]);
    return sum;
}

/* The 1-norm (largest column sum of magnitudes) of the n x n matrix a; NaN if one is. */
static double one_norm(int64_t n, const double *a, double *column) {
    for (int64_t j = 0; j < n; j++)
        column[j] = 0.0;
    for (int64_t i = 0; i < n; i++)
        for (int64_t j = 0; j < n; j++)
            column[j] += fabs(a[i * n + j]);
    double norm = 0.0;
    for (int64_t j = 0; j < n; j++) {
        if (column[j] > norm || isnan(column[j]))  /* dlange: a NaN column sum wins */
            norm = column[j];
        if (isnan(norm))
            break;
    }
    return norm;
}

/* x := U^-1 L^-1 x (kase 1 of dlacn2: no permutation, which leaves the 1-norm unchanged). */
static void solve_lu(int64_t n, const double *lu, double *x) {
    for (int64_t i = 1; i < n; i++) {  /* L, unit diagonal; terms k = 0 .. i-1 */
        const double *row = lu + i * n;
        double xi = x[i];
        for (int64_t k = 0; k < i; k++)
            xi -= row[k] * x[k];
        x[i] = xi;
    }
    for (int64_t i = n - 1; i >= 0; i--) {  /* U; terms k = n-1 .. i+1, then the division */
        const double *row = lu + i * n;
        double xi = x[i];
        for (int64_t k = n - 1; k > i; k--)
            xi -= row[k] * x[k];
        x[i] = xi / row[i];
    }
}

/* x := L^-T U^-T x (kase 2 of dlacn2). */
static void solve_lu_transposed(int64_t n, const double *lu, double *x) {
    for (int64_t i = 0; i < n; i++) {  /* U^T: x[j] loses terms i = 0 .. j-1, then divided */
        const double *row = lu + i * n;
        const double xi = x[i] / row[i];
        x[i] = xi;
        for (int64_t j = i + 1; j < n; j++)
            x[j] -= row[j] * xi;
    }
    for (int64_t i = n - 1; i > 0; i--) {  /* L^T: x[j] loses terms i = n-1 .. j+1 */
        const double *row = lu + i * n;
        const double xi = x[i];
        for (int64_t j = 0; j < i; j++)
            x[j] -= row[j] * xi;
    }
}

static void apply(int kase, int64_t n, const double *lu, double *x) {
    if (kase == 1)
        solve_lu(n, lu, x);
    else
        solve_lu_transposed(n, lu, x);
}

static void set_signs(int64_t n, double *x, int *sign) {
    for (int64_t i = 0; i < n; i++) {
        x[i] = x[i] >= 0.0 ? 1.0 : -1.0;
        sign[i] = x[i] > 0.0 ? 1 : -1;
    }
}

/* dlacn2's estimate of |(LU)^-1|_1 (a lower bound of it), driven directly rather than by
 * reverse communication; x, v (n) and sign (n) are work space. May be inf or NaN when the
 * solves overflow. */
static double inverse_norm(int64_t n, const double *lu, double *x, double *v, int *sign) {
    for (int64_t i = 0; i < n; i++)
        x[i] = 1.0 / (double)n;
    apply(1, n, lu, x);
    if (n == 1)
        return fabs(x[0]);
    double est = asum(n, x);
    set_signs(n, x, sign);
    apply(2, n, lu, x);
    int64_t j = iamax(n, x);
    int iteration = 2;
    for (;;) {
        for (int64_t i = 0; i < n; i++)
            x[i] = 0.0;
        x[j] = 1.0;
        apply(1, n, lu, x);
        for (int64_t i = 0; i < n; i++)
            v[i] = x[i];
        const double estold = est;
        est = asum(n, v);
        int repeated = 1;
        for (int64_t i = 0; i < n; i++) {
            if ((x[i] >= 0.0 ? 1 : -1) != sign[i]) {
                repeated = 0;
                break;
            }
        }
        if (repeated || est <= estold)  /* converged, or cycling */
            break;
        set_signs(n, x, sign);
        apply(2, n, lu, x);
        const int64_t jlast = j;
        j = iamax(n, x);
        if (x[jlast] != fabs(x[j]) && iteration < ITMAX) {
            iteration++;
            continue;
        }
        break;
    }
    /* the final stage: an alternating-sign vector guards against the bad cases */
    double altsgn = 1.0;
    for (int64_t i = 0; i < n; i++) {
        x[i] = altsgn * (1.0 + (double)i / (double)(n - 1));
        altsgn = -altsgn;
    }
    apply(1, n, lu, x);
    const double temp = 2.0 * (asum(n, x) / (double)(3 * n));
    if (temp > est)
        est = temp;
    return est;
}

/* dgecon's reciprocal 1-norm condition estimate (1/anorm)/|(LU)^-1|_1 of the matrix with
 * factors lu and 1-norm anorm; 0 when anorm is 0 or not finite, when a factor is not finite
 * or a pivot is 0, or when the estimate is not finite. n = 0: 1. */
EXPORT double circuitnsds_lu_rcond(int64_t n, const double *lu, double anorm) {
    if (n == 0)
        return 1.0;
    if (!(anorm > 0.0) || !isfinite(anorm))
        return 0.0;
    for (int64_t i = 0; i < n * n; i++)
        if (!isfinite(lu[i]))
            return 0.0;
    for (int64_t i = 0; i < n; i++)
        if (lu[i * n + i] == 0.0)
            return 0.0;
    double *work = malloc((size_t)(2 * n) * sizeof(double));
    int *sign = malloc((size_t)n * sizeof(int));
    double rcond = 0.0;
    if (work != NULL && sign != NULL) {
        const double ainvnm = inverse_norm(n, lu, work, work + n, sign);
        if (ainvnm > 0.0 && isfinite(ainvnm)) {
            rcond = (1.0 / ainvnm) / anorm;
            if (!isfinite(rcond))
                rcond = 0.0;
        }
    }
    free(work);
    free(sign);
    return rcond;
}

/* y[r] -= a * x[r] for r < count: part of a row of a matrix from another row (never the
 * same; unrolled by four, the same operations, so that the compiler vectorises it). */
static void axpy_row(int64_t count, double a, const double *restrict x, double *restrict y) {
    int64_t r = 0;
    for (; r + 4 <= count; r += 4) {
        y[r] -= a * x[r];
        y[r + 1] -= a * x[r + 1];
        y[r + 2] -= a * x[r + 2];
        y[r + 3] -= a * x[r + 3];
    }
    for (; r < count; r++)
        y[r] -= a * x[r];
}

/* Factorise the n x n matrix a in place (see the top of the file); returns 0, or k + 1 for
 * the first exactly zero pivot U[k][k] (LAPACK's info; the factorisation is completed). */
static int64_t factor(int64_t n, double *a, int32_t *ipiv) {
    int64_t info = 0;
    for (int64_t k = 0; k < n; k++) {
        int64_t p = k;
        double big = fabs(a[k * n + k]);
        for (int64_t i = k + 1; i < n; i++) {
            if (fabs(a[i * n + k]) > big) {
                big = fabs(a[i * n + k]);
                p = i;
            }
        }
        ipiv[k] = (int32_t)p;
        double *rowk = a + k * n;
        const double pivot = a[p * n + k];
        if (pivot != 0.0) {
            if (p != k) {
                double *rowp = a + p * n;
                for (int64_t j = 0; j < n; j++) {
                    const double t = rowk[j];
                    rowk[j] = rowp[j];
                    rowp[j] = t;
                }
            }
            for (int64_t i = k + 1; i < n; i++)
                a[i * n + k] /= pivot;
        } else if (info == 0) {
            info = k + 1;
        }
        for (int64_t i = k + 1; i < n; i++)  /* the rank-one update of the trailing block */
            axpy_row(n - k - 1, a[i * n + k], rowk + k + 1, a + i * n + k + 1);
    }
    return info;
}

/* LU-factorise the n x n matrix a (C order) in place, the pivots in ipiv (n); returns the
 * reciprocal condition estimate of circuitnsds_lu_rcond (0 for an exactly zero pivot, for
 * factors or a 1-norm that are not finite). */
EXPORT double circuitnsds_lu_factor(int64_t n, double *a, int32_t *ipiv) {
    if (n <= 0)
        return 1.0;
    double *column = malloc((size_t)n * sizeof(double));
    if (column == NULL)
        return 0.0;
    const double anorm = one_norm(n, a, column);
    free(column);
    if (factor(n, a, ipiv) != 0)
        return 0.0;
    return circuitnsds_lu_rcond(n, a, anorm);
}

/* Solve K X = B in place in b (n x nrhs, C order) with the factors lu and pivots ipiv of
 * circuitnsds_lu_factor (dgetrs, no transpose). */
EXPORT void circuitnsds_lu_solve(int64_t n, int64_t nrhs, const double *lu, const int32_t *ipiv,
                                 double *b) {
    for (int64_t k = 0; k < n; k++) {  /* the interchanges, in order */
        const int64_t p = ipiv[k];
        if (p != k) {
            double *bk = b + k * nrhs, *bp = b + p * nrhs;
            for (int64_t r = 0; r < nrhs; r++) {
                const double t = bk[r];
                bk[r] = bp[r];
                bp[r] = t;
            }
        }
    }
    if (nrhs == 1) {
        solve_lu(n, lu, b);
        return;
    }
    for (int64_t i = 1; i < n; i++) {  /* L: row i of B loses the terms k = 0 .. i-1 */
        const double *row = lu + i * n;
        for (int64_t k = 0; k < i; k++)
            axpy_row(nrhs, row[k], b + k * nrhs, b + i * nrhs);
    }
    for (int64_t i = n - 1; i >= 0; i--) {  /* U: the terms k = n-1 .. i+1, then the division */
        const double *row = lu + i * n;
        double *bi = b + i * nrhs;
        for (int64_t k = n - 1; k > i; k--)
            axpy_row(nrhs, row[k], b + k * nrhs, bi);
        const double pivot = row[i];
        for (int64_t r = 0; r < nrhs; r++)
            bi[r] /= pivot;
    }
}


/* ==========================================================================================
 * Lemke's complementary pivoting: the loop of circuitnsds/solvers/lemke.py (_pivot_python),
 * statement for statement, so that both take the same pivots and end on the same basis.
 *
 * Why here, and not in a file of its own: every LEMKE_REINVERT_EVERY pivots, and when a basic
 * variable turns negative, the tableau is recomputed from the data for the current basis by
 * factorising the basis columns. The Python loop does that with linalg.factorise, which is
 * the LU above for the orders Lemke runs in C (n <= linalg.NATIVE_MAX); calling the same
 * functions keeps the two loops' arithmetic identical without a second copy of the LU (the
 * libraries are built separately, and one cannot call into another).
 *
 * The tableau t is n x (2n + 2) in C order: columns 0..n-1 the w's (starting as the identity,
 * so that they hold the current basis inverse), n..2n-1 the z's, 2n the artificial z0, 2n + 1
 * the right-hand side; t0 is the initial tableau [I, -M, -d, q] (scaled by lemke.py), kept for
 * the reinversions. Variables are numbered by their column; basis[i] is the variable of row i.
 *
 * The arithmetic follows numpy's for the Python loop: a row is divided by its pivot, then
 * every row i (the pivot row included, with factor 0) loses col[i] times the pivot row, entry
 * by entry; NaN and infinities are treated as numpy's min, max, nan_to_num and maximum treat
 * them. Tolerances come from lemke.py (its constants), in the order of enum lemke_scalar.
 */

enum lemke_status {  /* lemke.py's _SOLVED ... (the same numbers) */
    LEMKE_SOLVED = 0,        /* z0 left the basis */
    LEMKE_RAY = 1,           /* no pivot row for the entering column: a secondary ray */
    LEMKE_PIVOT_LIMIT = 2,
    LEMKE_SINGULAR = 3,      /* a periodic reinversion met a singular basis */
    LEMKE_NEGATIVE = 4,      /* a basic variable stayed negative beyond the tolerance */
    LEMKE_NOT_FINITE = 5,    /* the pivot row is not finite */
    LEMKE_NO_MEMORY = -1     /* nothing done: the caller runs the Python loop */
};

/* The entries of circuitnsds_lemke's scalars: the tolerances of lemke.py, then an output. */
enum lemke_scalar { TIE, PIV_REL, PIV_ABS, NEG_TOL, RCOND_MIN, MIN_BASIC, LEMKE_SCALARS };

/* numpy.nan_to_num(v, nan=inf): NaN -> inf, +-inf -> +-DBL_MAX. */
static double nan_to_inf(double v) {
    if (isnan(v))
        return INFINITY;
    if (isinf(v))
        return v > 0.0 ? DBL_MAX : -DBL_MAX;
    return v;
}

/* _lex_argmin: among the count rows listed in rows (ascending, overwritten), the row of the
 * lexicographic minimum of [rhs, B^-1]_i / div[i], ratios within the tie tolerance counting as
 * equal; prefer (>= 0) is taken as soon as it is among the rows tied on the right-hand side. */
static int64_t lex_argmin(int64_t n, const double *t, int64_t *rows, int64_t count,
                          const double *div, int64_t prefer, double tie, double *vals) {
    const int64_t ncol = 2 * n + 2;
    for (int64_t step = 0; step <= n; step++) {
        const int64_t j = step == 0 ? ncol - 1 : step - 1;
        double best = INFINITY;
        for (int64_t k = 0; k < count; k++) {
            const int64_t i = rows[k];
            const double v = nan_to_inf(t[i * ncol + j] / div[i]);
            vals[k] = v;
            if (v < best)
                best = v;
        }
        const double bound = best + tie * (fabs(best) > 1.0 ? fabs(best) : 1.0);
        int64_t kept = 0, has_prefer = 0;
        for (int64_t k = 0; k < count; k++) {
            if (vals[k] <= bound) {
                rows[kept++] = rows[k];
                has_prefer |= rows[k] == prefer;
            }
        }
        count = kept;
        if (count == 1)
            break;
        if (step == 0 && prefer >= 0 && has_prefer)
            return prefer;
    }
    return rows[0];
}

/* Recompute t from t0 for the current basis (factors in b, n x n, and ipiv); 0 when the basis
 * is numerically singular (rcond below the tolerance: t left alone) or t is not finite. */
static int reinvert(int64_t n, const double *t0, double *t, const int64_t *basis, double *b,
                    int32_t *ipiv, double rcond_min) {
    const int64_t ncol = 2 * n + 2;
    for (int64_t i = 0; i < n; i++)
        for (int64_t k = 0; k < n; k++)
            b[i * n + k] = t0[i * ncol + basis[k]];
    if (!(circuitnsds_lu_factor(n, b, ipiv) >= rcond_min))
        return 0;
    memcpy(t, t0, (size_t)(n * ncol) * sizeof(double));
    circuitnsds_lu_solve(n, ncol, b, ipiv, t);
    for (int64_t row = 0; row < n; row++) {
        for (int64_t i = 0; i < n; i++)
            t[i * ncol + basis[row]] = 0.0;
        t[row * ncol + basis[row]] = 1.0;
    }
    for (int64_t i = 0; i < n * ncol; i++)
        if (!isfinite(t[i]))
            return 0;
    return 1;
}

/* The smallest and largest entry of column j of t (numpy's min and max: NaN if one is). */
static void column_range(int64_t n, const double *t, int64_t j, double *lo, double *hi) {
    const int64_t ncol = 2 * n + 2;
    double low = t[j], high = t[j];
    for (int64_t i = 0; i < n; i++) {
        const double v = t[i * ncol + j];
        if (isnan(v)) {
            low = high = v;
            break;
        }
        if (v < low)
            low = v;
        if (v > high)
            high = v;
    }
    *lo = low;
    *hi = high;
}

/* Run Lemke's pivoting on the tableau t0 (n >= 1 rows, see above; not modified), in t (the
 * same shape; the final tableau on return) and basis (n + 2: the basis, then the pivots done
 * and the entering variable, the ray's column for LEMKE_RAY); scalars (LEMKE_SCALARS) holds
 * the tolerances (enum lemke_scalar) and receives the negative basic value of LEMKE_NEGATIVE.
 * Returns the status (enum lemke_status). */
EXPORT int64_t circuitnsds_lemke(int64_t n, const double *t0, double *t, int64_t *basis,
                                 int64_t max_pivots, int64_t reinvert_every, double *scalars) {
    const int64_t ncol = 2 * n + 2, z0 = 2 * n, rhs = 2 * n + 1;
    const double tie = scalars[TIE], piv_rel = scalars[PIV_REL];
    const double piv_abs = scalars[PIV_ABS], neg_tol = scalars[NEG_TOL];
    const double rcond_min = scalars[RCOND_MIN];
    double *work = malloc((size_t)(n * n + 2 * n) * sizeof(double));
    int64_t *rows = malloc((size_t)n * sizeof(int64_t));
    int32_t *ipiv = malloc((size_t)n * sizeof(int32_t));
    if (work == NULL || rows == NULL || ipiv == NULL) {
        free(work);
        free(rows);
        free(ipiv);
        return LEMKE_NO_MEMORY;
    }
    double *b = work, *vals = work + n * n, *div = work + n * n + n;
    memcpy(t, t0, (size_t)(n * ncol) * sizeof(double));
    for (int64_t i = 0; i < n; i++) {
        basis[i] = i;
        rows[i] = i;
        div[i] = -t[i * ncol + z0];
    }
    /* the first pivot: z0 enters at the row of the (lexicographically) most negative q_i/d_i */
    int64_t r = lex_argmin(n, t, rows, n, div, -1, tie, vals);
    int64_t entering = z0, pivots = 0, status;
    for (;;) {
        const int64_t leaving = basis[r];
        double *prow = t + r * ncol;
        const double piv = prow[entering];
        for (int64_t j = 0; j < ncol; j++)
            prow[j] /= piv;
        for (int64_t i = 0; i < n; i++)
            if (i != r)
                axpy_row(ncol, t[i * ncol + entering], prow, t + i * ncol);
        for (int64_t j = 0; j < ncol; j++)  /* numpy's outer product has a 0 here */
            prow[j] -= 0.0 * prow[j];
        for (int64_t i = 0; i < n; i++)
            t[i * ncol + entering] = 0.0;
        prow[entering] = 1.0;
        basis[r] = entering;
        pivots++;

        if (reinvert_every > 0 && pivots % reinvert_every == 0
            && !reinvert(n, t0, t, basis, b, ipiv, rcond_min)) {
            status = LEMKE_SINGULAR;
            break;
        }
        double lo, hi;
        column_range(n, t, rhs, &lo, &hi);
        double scale = hi > 1.0 ? hi : 1.0;
        if (lo < -neg_tol * scale && reinvert(n, t0, t, basis, b, ipiv, rcond_min)) {
            column_range(n, t, rhs, &lo, &hi);
            scale = hi > 1.0 ? hi : 1.0;
        }
        if (lo < 0.0) {
            if (lo < -neg_tol * scale || !isfinite(lo)) {
                scalars[MIN_BASIC] = lo;
                status = LEMKE_NEGATIVE;
                break;
            }
            for (int64_t i = 0; i < n; i++) {  /* numpy.maximum(rhs, 0): NaN stays, -0 -> 0 */
                const double v = t[i * ncol + rhs];
                if (!isnan(v) && !(v > 0.0))
                    t[i * ncol + rhs] = 0.0;
            }
        }
        int finite = 1;
        for (int64_t j = 0; j < ncol; j++)
            finite &= isfinite(prow[j]) != 0;
        if (!finite) {
            status = LEMKE_NOT_FINITE;
            break;
        }
        if (leaving == z0) {
            status = LEMKE_SOLVED;
            break;
        }
        entering = leaving < n ? leaving + n : leaving - n;
        if (pivots >= max_pivots) {
            status = LEMKE_PIVOT_LIMIT;
            break;
        }
        double big = 0.0;
        for (int64_t i = 0; i < n; i++) {
            const double v = fabs(t[i * ncol + entering]);
            if (isnan(v)) {
                big = v;
                break;
            }
            if (v > big)
                big = v;
        }
        const double thresh = piv_rel * big > piv_abs ? piv_rel * big : piv_abs;
        int64_t count = 0, z0_row = -1;
        for (int64_t i = 0; i < n; i++) {
            div[i] = t[i * ncol + entering];
            if (div[i] > thresh)
                rows[count++] = i;
            if (basis[i] == z0 && z0_row < 0)
                z0_row = i;
        }
        if (count == 0) {
            status = LEMKE_RAY;
            break;
        }
        r = lex_argmin(n, t, rows, count, div, z0_row, tie, vals);
    }
    basis[n] = pivots;
    basis[n + 1] = entering;
    free(work);
    free(rows);
    free(ipiv);
    return status;
}
