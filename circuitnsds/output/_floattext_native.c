/* The CSV formatter of circuitnsds/output/floattext.py in C: rows of float64 values as the
 * text Python's repr writes (the shortest decimal that reads back to the same double), with
 * commas between values and a newline after each row.
 *
 * The same method and the same integer arithmetic as floattext.py's _csv_block (the Schubfach
 * method, R. Giulietti, "The Schubfach way to render doubles", 2020; see floattext.py's
 * docstring for the derivation), written from that Python code: every step below has its
 * counterpart there, and the tests check both against repr. The tables (126-bit
 * approximations g of 10^-k, and k and the shift h for each binary exponent) are computed
 * by floattext.tables() in Python and passed in: they exist in one place only.
 *
 * Plain C99 with gcc/clang's unsigned __int128 for the 64 x 64 -> 128-bit products; no
 * Python API: circuitnsds.native loads the library with ctypes, which releases the GIL for
 * the call. Built by setup.py, which defines CIRCUITNSDS_SOURCE_DIGEST (the digest of this
 * file: a library built from another version of it is refused).
 */

#include <stdint.h>

#include "native.h"

__extension__ typedef unsigned __int128 u128; /* gcc and clang */

#define M52 ((UINT64_C(1) << 52) - 1)
#define M63 ((UINT64_C(1) << 63) - 1)
#define EXPONENT_BITS UINT64_C(0x7FF0000000000000)

typedef struct {
    const uint64_t *g_high, *g_low; /* the 63-bit halves of g, for e = -k in e_min.. */
    const int64_t *ks, *hs;         /* k and h for q in q_min.., symmetric interval */
    const int64_t *ka, *ha;         /* the same for the asymmetric interval (c = 2^52) */
    int64_t e_min, q_min;
} Tables;

/* floor(g * cp / 2^127) for g = g_high * 2^63 + g_low, its last bit set when the fraction is
 * nonzero (the sticky bit): floattext._round_odd. */
static inline uint64_t round_odd(uint64_t g_high, uint64_t g_low, uint64_t cp) {
    uint64_t x1 = (uint64_t)(((u128)g_low * cp) >> 64);
    u128 y = (u128)g_high * cp;
    uint64_t y0 = (uint64_t)y, y1 = (uint64_t)(y >> 64);
    uint64_t z = (y0 >> 1) + x1;
    uint64_t vbp = y1 + (z >> 63);
    return vbp | (((z & M63) + M63) >> 63);
}

/* f * 10^e, the shortest nearest decimal of the finite positive double whose IEEE bits (sign
 * cleared) are bits: floattext._shortest. */
static inline uint64_t shortest(uint64_t bits, const Tables *t, int64_t *e) {
    int64_t biased = (int64_t)(bits >> 52);
    uint64_t fraction = bits & M52;
    uint64_t c;
    int64_t q;
    int symmetric;
    if (biased == 0) {
        c = fraction;
        q = t->q_min;
        symmetric = 1;
    } else {
        c = fraction | (UINT64_C(1) << 52);
        q = biased - 1075;
        symmetric = fraction != 0 || biased == 1;
    }
    uint64_t out = c & 1;
    uint64_t cb = c << 2;
    uint64_t cbr = cb + 2;
    uint64_t cbl;
    int64_t k, h;
    if (symmetric) {
        cbl = cb - 2;
        k = t->ks[q - t->q_min];
        h = t->hs[q - t->q_min];
    } else {
        cbl = cb - 1;
        k = t->ka[q - t->q_min];
        h = t->ha[q - t->q_min];
    }
    int64_t index = -k - t->e_min;
    uint64_t g1 = t->g_high[index], g0 = t->g_low[index];
    uint64_t vb = round_odd(g1, g0, cb << h);
    uint64_t vbl = round_odd(g1, g0, cbl << h);
    uint64_t vbr = round_odd(g1, g0, cbr << h);
    uint64_t s = vb >> 2;
    uint64_t sp10 = (s / 10) * 10;
    uint64_t tp10 = sp10 + 10;
    int upin = vbl + out <= (sp10 << 2);
    int wpin = (tp10 << 2) + out <= vbr;
    *e = k;
    if (upin != wpin)
        return upin ? sp10 : tp10;
    uint64_t u = s + 1;
    int uin = vbl + out <= (s << 2);
    int win = (u << 2) + out <= vbr;
    if (uin != win)
        return uin ? s : u;
    uint64_t middle = (s + u) << 1; /* 4 (s + 1/2) */
    if (vb < middle || (vb == middle && (s & 1) == 0))
        return s;
    return u;
}

/* repr of the double whose IEEE bits are bits, written from p; returns the end:
 * floattext._put_text. */
static inline uint8_t *put_text(uint64_t bits, uint8_t *p, const Tables *t) {
    int negative = (bits >> 63) != 0;
    uint64_t magnitude = bits & M63;
    if (magnitude >= EXPONENT_BITS) {
        if (magnitude > EXPONENT_BITS) { /* nan (repr drops its sign) */
            p[0] = 'n', p[1] = 'a', p[2] = 'n';
            return p + 3;
        }
        if (negative)
            *p++ = '-';
        p[0] = 'i', p[1] = 'n', p[2] = 'f';
        return p + 3;
    }
    if (negative)
        *p++ = '-';
    if (magnitude == 0) {
        p[0] = '0', p[1] = '.', p[2] = '0';
        return p + 3;
    }
    int64_t e;
    uint64_t f = shortest(magnitude, t, &e);
    while (f % 100000000 == 0) { /* trailing zeros dropped, eight at a time, then one */
        f /= 100000000;
        e += 8;
    }
    while (f % 10 == 0) {
        f /= 10;
        e += 1;
    }
    uint8_t digits[20]; /* last digit first */
    int n = 0;
    while (f >= 100) { /* two per division */
        unsigned pair = (unsigned)(f % 100);
        f /= 100;
        digits[n] = (uint8_t)('0' + pair % 10);
        digits[n + 1] = (uint8_t)('0' + pair / 10);
        n += 2;
    }
    unsigned last = (unsigned)f;
    if (last >= 10) {
        digits[n] = (uint8_t)('0' + last % 10);
        digits[n + 1] = (uint8_t)('0' + last / 10);
        n += 2;
    } else {
        digits[n++] = (uint8_t)('0' + last);
    }
    int64_t point = n + e; /* value = 0.d1..dn x 10^point */
    if (-4 < point && point <= 16) {
        if (point <= 0) {
            *p++ = '0';
            *p++ = '.';
            for (int64_t j = 0; j < -point; j++)
                *p++ = '0';
            for (int j = n - 1; j >= 0; j--)
                *p++ = digits[j];
        } else if (point >= n) {
            for (int j = n - 1; j >= 0; j--)
                *p++ = digits[j];
            for (int64_t j = 0; j < point - n; j++)
                *p++ = '0';
            *p++ = '.';
            *p++ = '0';
        } else {
            for (int j = n - 1; j > n - 1 - point; j--)
                *p++ = digits[j];
            *p++ = '.';
            for (int j = (int)(n - 1 - point); j >= 0; j--)
                *p++ = digits[j];
        }
        return p;
    }
    *p++ = digits[n - 1];
    if (n > 1) {
        *p++ = '.';
        for (int j = n - 2; j >= 0; j--)
            *p++ = digits[j];
    }
    int64_t exponent = point - 1;
    *p++ = 'e';
    *p++ = exponent < 0 ? '-' : '+';
    if (exponent < 0)
        exponent = -exponent;
    if (exponent >= 100)
        *p++ = (uint8_t)('0' + exponent / 100);
    p[0] = (uint8_t)('0' + (exponent / 10) % 10);
    p[1] = (uint8_t)('0' + exponent % 10);
    return p + 2;
}

/* floattext._csv_block: the rows x columns values whose IEEE bits are bits (row after row)
 * as CSV lines (',' between values, '\n' after each row) into buffer, which must hold
 * rows * columns * (MAX_CHARS + 1) bytes (MAX_CHARS = 24); returns the bytes written. The
 * tables are floattext.tables() and its E_MIN, Q_MIN. */
EXPORT int64_t circuitnsds_csv_block(const uint64_t *bits, int64_t rows, int64_t columns,
                                     uint8_t *buffer, const uint64_t *g_high,
                                     const uint64_t *g_low, const int64_t *ks, const int64_t *hs,
                                     const int64_t *ka, const int64_t *ha, int64_t e_min,
                                     int64_t q_min) {
    const Tables t = {g_high, g_low, ks, hs, ka, ha, e_min, q_min};
    uint8_t *p = buffer;
    for (int64_t i = 0; i < rows; i++) {
        for (int64_t j = 0; j < columns; j++) {
            p = put_text(bits[i * columns + j], p, &t);
            *p++ = j < columns - 1 ? ',' : '\n';
        }
    }
    return (int64_t)(p - buffer);
}
