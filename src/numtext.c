/* numtext.c - numbers as the writer prints them: the shortest text that reads back as the same
 * float (or double), in printf's %g style.
 *
 * The reference is a search over printf's correctly rounded "%.*g" for the fewest significant
 * digits that strtof reads back unchanged (format_float_search).  The writer's hot path for floats
 * finds the same digits with double arithmetic instead: for d = 1, 2, ... significant digits it
 * takes the d-digit decimal nearest the float and accepts it when it lies inside the float's
 * rounding interval (half-way to each neighbour).  A float and its neighbours are exact in double,
 * and the scaled values carry at most a few double roundings (relative 1e-15), far below the
 * interval's half-width (2^-25 relative); a candidate within 1e-14 of a boundary, or a scaled value
 * within 1e-6 of a rounding tie (printf rounds ties to even), is left to the reference.  So the
 * text is byte for byte the reference's (tests/test_write.c checks millions of floats), at a
 * fraction of its cost: 4 printf and 3 strtof calls per value were a third of a tree's writing.
 *
 * Reading goes the other way with Clinger's fast path (bsti_parse_double): a decimal whose digits
 * fit an exact double (below 2^53) and whose power of ten is exact (|p| <= 22) is one correctly
 * rounded product or quotient of exact operands, which is strtod's answer; the readers' numbers
 * ("1.684e+02") nearly all are.  Anything else, including text strtod would read other than a
 * plain decimal (inf, nan, hexadecimal), is strtod's. */
#include <config.h>

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "numtext.h"

/* Powers of ten as doubles (exact to 1e22, correctly rounded above), enough for floats' range. */
static const double pow10_pos[] = {
    1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14,
    1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22, 1e23, 1e24, 1e25, 1e26, 1e27, 1e28, 1e29,
    1e30, 1e31, 1e32, 1e33, 1e34, 1e35, 1e36, 1e37, 1e38, 1e39, 1e40, 1e41, 1e42, 1e43, 1e44,
    1e45, 1e46, 1e47, 1e48, 1e49, 1e50, 1e51, 1e52, 1e53, 1e54, 1e55, 1e56, 1e57, 1e58, 1e59,
    1e60};
#define POW10_MAX 60

/* x * 10^p for |p| <= POW10_MAX. */
static double scale10(double x, int p)
{
    return p >= 0 ? x * pow10_pos[p] : x / pow10_pos[-p];
}

/* The text printf's "%.*g" with precision prec gives for r * 10^lead / 10^(ndigits(r) - 1), r's
 * leading digit at decimal exponent lead, trailing zeros dropped as %g drops them. */
static int g_text(uint64_t r, int lead, int prec, int negative, char *buf)
{
    char dig[24];
    int m = 0;
    while (r) {
        dig[m++] = (char)('0' + r % 10);
        r /= 10;
    }
    int lo = 0; /* dig[] is least significant first: skip trailing zeros */
    while (lo < m - 1 && dig[lo] == '0')
        lo++;
    char *s = buf;
    if (negative)
        *s++ = '-';
    if (lead < -4 || lead >= prec) { /* scientific: d.ddde+XX */
        *s++ = dig[m - 1];
        if (m - 1 > lo) {
            *s++ = '.';
            for (int i = m - 2; i >= lo; i--)
                *s++ = dig[i];
        }
        int x = lead < 0 ? -lead : lead;
        *s++ = 'e';
        *s++ = lead < 0 ? '-' : '+';
        if (x >= 100)
            *s++ = (char)('0' + x / 100);
        *s++ = (char)('0' + x / 10 % 10);
        *s++ = (char)('0' + x % 10);
    } else if (lead >= 0) { /* ddd.ddd */
        for (int i = m - 1, k = 0; k <= lead; i--, k++)
            *s++ = i >= lo ? dig[i] : '0';
        if (m - 1 - lead > lo) {
            *s++ = '.';
            for (int i = m - 2 - lead; i >= lo; i--)
                *s++ = dig[i];
        }
    } else { /* 0.000ddd */
        *s++ = '0';
        *s++ = '.';
        for (int k = -1; k > lead; k--)
            *s++ = '0';
        for (int i = m - 1; i >= lo; i--)
            *s++ = dig[i];
    }
    *s = '\0';
    return (int)(s - buf);
}

/* The fast path for a finite float f != 0: the length written, or 0 where the answer is not
 * certain in double arithmetic (the caller then asks the reference). */
static int format_float_fast(float f, char *buf)
{
    int negative = f < 0;
    float a = negative ? -f : f;
    double x = a;
    float below = nextafterf(a, 0.0f), above = nextafterf(a, INFINITY);
    double lo = 0.5 * (x + (double)below); /* exact: two floats' sum fits in a double */
    double hi = isinf(above) ? x + (x - lo) : 0.5 * (x + (double)above);
    int e = (int)floor(log10(x)); /* the leading digit's exponent, corrected below */
    if (e + 1 > POW10_MAX || 9 - e > POW10_MAX)
        return 0;
    if (scale10(1.0, e) > x)
        e--;
    else if (scale10(1.0, e + 1) <= x)
        e++;
    double margin = 1e-14 * x;
    for (int d = 1; d <= 9; d++) {
        int p = e - d + 1; /* candidates are r * 10^p with r of d digits */
        if (p > POW10_MAX || -p > POW10_MAX)
            return 0;
        double q = scale10(x, -p), fl = floor(q), frac = q - fl;
        if (fabs(frac - 0.5) < 1e-6)
            return 0; /* near a tie, which printf breaks to even */
        uint64_t r = (uint64_t)fl + (frac > 0.5);
        double c = scale10((double)r, p);
        if (c > lo + margin && c < hi - margin) {
            int lead = e;
            if (r >= (uint64_t)scale10(1.0, d)) /* 9.96 -> 10: one digit up */
                lead++;
            return g_text(r, lead, d, negative, buf);
        }
        if (c > lo - margin && c < hi + margin)
            return 0; /* too near a boundary to tell */
    }
    return 0;
}

int bsti_format_float_search(float f, char *buf)
{
    int lo = 1, hi = 9; /* 9 significant digits always read back as the same float */
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        snprintf(buf, 32, "%.*g", mid, (double)f);
        if (strtof(buf, NULL) == f)
            hi = mid;
        else
            lo = mid + 1;
    }
    return snprintf(buf, 32, "%.*g", lo, (double)f);
}

int bsti_format_float(double v, int digits, char *buf, float *back)
{
    if (v == 0.0) {
        buf[0] = '0', buf[1] = '\0';
        *back = 0.0f;
        return 1;
    }
    if (digits > 0) {
        int n = snprintf(buf, 32, "%.*g", digits > 9 ? 9 : digits, v);
        *back = strtof(buf, NULL);
        return n;
    }
    float f = (float)v;
    *back = f;
    int n = isfinite(f) && f != 0.0f ? format_float_fast(f, buf) : 0;
    return n ? n : bsti_format_float_search(f, buf);
}

/* ------------------------------------------------------------------ shortest double text
 *
 * v = m 2^e exactly (m < 2^53).  X = v 10^s with s chosen so that X has 17 digits before the point
 * (10^16 <= X < 10^17) is held in fixed point with FRAC fraction bits, from one product of m with
 * a 128-bit 10^s (numtext_pow10.h), as are the half-gaps to v's neighbours.  The P-digit text
 * printf prints is round-half-even(X / 10^(17-P)); strtod reads it back as v when it lies within
 * half a gap of v, a tie going to the even significand.  With these exact tests the binary search
 * over P of format_double_search is replayed step by step, so the digits are the reference's even
 * where the search is not monotone (powers of two, whose lower gap is half the upper).  A
 * decision nearer than DMARGIN units to its threshold where the values are not exact (the table
 * entry is rounded or a shift dropped bits) is left to the search itself: about 3 in 10^5 random
 * bit patterns, all of them at or above 10^17 where 10^s (s < 0) is inexact and v is an integer
 * (ties there look exact); none in the BSDF range.  tests/test_numtext.c compares with the search.
 * Without unsigned __int128 (not gcc or clang on a 64-bit target) the search does it all. */
#ifdef __SIZEOF_INT128__
#define HAVE_DFIXED 1
#include "numtext_pow10.h"

typedef unsigned __int128 u128;

#define FRAC 66    /* fraction bits of the fixed-point X: X < 10^18 < 2^60 fits a u128 */
#define DMARGIN 8  /* units of 2^-FRAC: bounds the truncation errors (< 2 units) with room */

static const uint64_t p10u[18] = {1ull, 10ull, 100ull, 1000ull, 10000ull, 100000ull, 1000000ull,
    10000000ull, 100000000ull, 1000000000ull, 10000000000ull, 100000000000ull, 1000000000000ull,
    10000000000000ull, 100000000000000ull, 1000000000000000ull, 10000000000000000ull,
    100000000000000000ull};

/* X = m 2^e 10^s in units of 2^-FRAC, and the half-gaps below (h_lo) and above (h_hi) v. */
struct dfixed {
    u128 x, h_lo, h_hi; /* each rounded down by less than 2 units, or exact */
    int exact;
    uint64_t m;
};

static int dfixed_scale(uint64_t m, int e, int s, int asym, struct dfixed *d)
{
    if (s < BSTI_POW10_SMIN || s > BSTI_POW10_SMAX)
        return 0;
    int i = s - BSTI_POW10_SMIN, sh = -(e + pow10_t[i].b + FRAC);
    if (sh < 1 || sh > 125)
        return 0;
    uint64_t thi = pow10_t[i].hi, tlo = pow10_t[i].lo;
    u128 t = (u128)thi << 64 | tlo;
    u128 a = (u128)m * tlo, c = (u128)m * thi; /* m t = c 2^64 + a: 192 bits p2 p1 p0 */
    uint64_t p0 = (uint64_t)a;
    u128 mid = (a >> 64) + (uint64_t)c;
    uint64_t p1 = (uint64_t)mid, p2 = (uint64_t)(c >> 64) + (uint64_t)(mid >> 64);
    u128 top = (u128)p2 << 64 | p1, lost;
    if (sh >= 64) {
        d->x = top >> (sh - 64);
        lost = (sh > 64 ? top & (((u128)1 << (sh - 64)) - 1) : 0) | p0;
    } else {
        d->x = top << (64 - sh) | p0 >> sh;
        lost = p0 & ((1ull << sh) - 1);
    }
    d->h_hi = t >> (sh + 1); /* 2^(e-1) 10^s */
    d->h_lo = asym ? t >> (sh + 2) : d->h_hi;
    lost |= t & (((u128)1 << (sh + 2)) - 1);
    d->exact = pow10_t[i].exact && lost == 0;
    d->m = m;
    return 1;
}

/* -1 undecided, else whether a > b (cmp > 0) or a < b (cmp < 0), or the tie (0), for a computed
 * a and b that may each lie below their true values by less than 2 units unless exact. */
static int dfixed_cmp(u128 a, u128 b, int exact)
{
    if (a > b + DMARGIN)
        return 1;
    if (a + DMARGIN < b)
        return -1;
    if (!exact)
        return -2;
    return a > b ? 1 : a < b ? -1 : 0;
}

/* The P-digit rounding of X, r (10^(P-1) <= r <= 10^P), and whether strtod reads r 10^(17-P-s)
 * back as v: 1 or 0, or -1 when that is not certain here. */
static int dfixed_digits(const struct dfixed *d, int p, uint64_t *r)
{
    uint64_t D = p10u[17 - p], xi = (uint64_t)(d->x >> FRAC), q = xi / D;
    u128 rem = (u128)(xi % D) << FRAC | (d->x & (((u128)1 << FRAC) - 1));
    int c = dfixed_cmp(rem, (u128)D << (FRAC - 1), d->exact);
    if (c == -2)
        return -1;
    q += c > 0 || (c == 0 && (q & 1)); /* printf: half-way goes to even */
    *r = q;
    u128 cand = (u128)(q * D) << FRAC, dist, lim;
    if (cand >= d->x)
        dist = cand - d->x, lim = d->h_hi;
    else
        dist = d->x - cand, lim = d->h_lo;
    c = dfixed_cmp(dist, lim, d->exact);
    if (c == -2)
        return -1;
    return c < 0 || (c == 0 && !(d->m & 1)); /* strtod: half-way goes to even */
}

/* The fast path for a finite v != 0: the length written, or 0 where the answer is not certain. */
static int format_double_fast(double v, char *buf)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    int bexp = (int)(bits >> 52 & 0x7ff), negative = (int)(bits >> 63);
    uint64_t frac = bits & ((1ull << 52) - 1), m;
    int e;
    if (bexp == 0x7ff || (bexp == 0 && frac == 0))
        return 0;
    if (bexp == 0)
        m = frac, e = -1074;
    else
        m = frac | 1ull << 52, e = bexp - 1075;
    int asym = frac == 0 && bexp > 1; /* a power of two: the gap below is half the gap above */
    int e2 = e + 63 - __builtin_clzll(m); /* 2^e2 <= v < 2^(e2+1) */
    int lead = (int)floor(e2 * 0.30102999566398120); /* log10(v)'s floor, or one less */
    struct dfixed d;
    if (!dfixed_scale(m, e, 16 - lead, asym, &d))
        return 0;
    if ((uint64_t)(d.x >> FRAC) >= p10u[17]) {
        lead++;
        if (!dfixed_scale(m, e, 16 - lead, asym, &d))
            return 0;
    }
    if ((uint64_t)(d.x >> FRAC) < p10u[16])
        return 0;
    int lo = 1, hi = 17; /* format_double_search's steps */
    uint64_t r;
    while (lo < hi) {
        int mid = (lo + hi) / 2, ok = dfixed_digits(&d, mid, &r);
        if (ok < 0)
            return 0;
        if (ok)
            hi = mid;
        else
            lo = mid + 1;
    }
    if (dfixed_digits(&d, lo, &r) < 0)
        return 0;
    if (r >= p10u[lo]) /* 9.96 -> 10: one digit up */
        lead++;
    return g_text(r, lead, lo, negative, buf);
}
#endif /* __SIZEOF_INT128__ */

int bsti_format_double_search(double v, char *buf)
{
    int lo = 1, hi = 17; /* 17 significant digits always read back as the same double */
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        snprintf(buf, 32, "%.*g", mid, v);
        if (strtod(buf, NULL) == v)
            hi = mid;
        else
            lo = mid + 1;
    }
    return snprintf(buf, 32, "%.*g", lo, v);
}

int bsti_format_double(double v, int digits, char *buf, double *back)
{
    if (v == 0.0) {
        buf[0] = '0', buf[1] = '\0';
        *back = 0.0;
        return 1;
    }
    if (digits > 0) {
        int n = snprintf(buf, 32, "%.*g", digits > 17 ? 17 : digits, v);
        *back = strtod(buf, NULL);
        return n;
    }
    *back = v;
#ifdef HAVE_DFIXED
    int n = format_double_fast(v, buf);
    if (n)
        return n;
#endif
    return bsti_format_double_search(v, buf);
}

/* strtod on a terminated copy: the reference, and the path for what the fast one declines. */
static int parse_slow(const char *s, size_t len, double *v)
{
    char buf[64];
    if (len == 0 || len >= sizeof buf)
        return 0;
    memcpy(buf, s, len);
    buf[len] = '\0';
    char *end;
    double x = strtod(buf, &end);
    if (end != buf + len)
        return 0;
    *v = x;
    return 1;
}

int bsti_parse_double(const char *s, size_t len, double *v)
{
    const char *p = s, *end = s + len;
    int negative = 0;
    if (p < end && (*p == '-' || *p == '+'))
        negative = *p++ == '-';
    uint64_t m = 0;
    int digits = 0, scale = 0, seen = 0; /* significant digits kept, power of ten they lack */
    for (; p < end && *p >= '0' && *p <= '9'; p++, seen++) {
        if (m == 0 && *p == '0')
            continue; /* leading zeros */
        if (digits == 19)
            return parse_slow(s, len, v);
        m = 10 * m + (uint64_t)(*p - '0'), digits++;
    }
    if (p < end && *p == '.') {
        for (p++; p < end && *p >= '0' && *p <= '9'; p++, seen++) {
            if (m == 0 && *p == '0') {
                scale--;
                continue;
            }
            if (digits == 19)
                return parse_slow(s, len, v);
            m = 10 * m + (uint64_t)(*p - '0'), digits++, scale--;
        }
    }
    if (seen == 0)
        return parse_slow(s, len, v); /* inf, nan, hexadecimal, or not a number */
    if (p < end && (*p == 'e' || *p == 'E')) {
        p++;
        int eneg = 0, ex = 0, edigits = 0;
        if (p < end && (*p == '-' || *p == '+'))
            eneg = *p++ == '-';
        for (; p < end && *p >= '0' && *p <= '9'; p++, edigits++)
            if (ex < 10000)
                ex = 10 * ex + (*p - '0');
        if (edigits == 0)
            return parse_slow(s, len, v); /* "1e": strtod stops before the e */
        scale += eneg ? -ex : ex;
    }
    if (p != end)
        return parse_slow(s, len, v);
    double x;
    if (m == 0)
        x = 0.0;
    else if (m < ((uint64_t)1 << 53) && scale >= -22 && scale <= 22)
        x = scale >= 0 ? (double)m * pow10_pos[scale] : (double)m / pow10_pos[-scale];
    else
        return parse_slow(s, len, v);
    *v = negative ? -x : x;
    return 1;
}
