/* numtext.c - numbers as the writer prints them: the shortest text that reads back as the same
 * float (or double), in printf's %g style.
 *
 * The reference is a search over printf's correctly rounded "%.*g" for the fewest significant
 * digits that strtof (strtod) reads back unchanged: bsti_format_float_search and
 * bsti_format_double_search.  The writers' hot path finds the same text without printf or strtod:
 * the value v = m 2^e, scaled by a 128-bit power of ten to 17 digits before the point, is held in
 * fixed point (exact or within 2^-65 of a unit), and for a number P of digits the test the search
 * makes ("does printf's P-digit rounding read back as v?") is decided exactly: the rounding is
 * half-way-to-even in X / 10^(17-P), and strtod reads the result back as v when it lies within
 * half a gap of v (a tie going to the even significand).  The search's own steps are replayed,
 * so the digits are its digits even where its test is not monotone (powers of two); a decision
 * too close to call in fixed point goes to the search itself (see "shortest text" below).  This
 * is the idea of Ryu and Schubfach (the shortest correctly rounded digits from one wide product
 * with a precomputed power of ten), arranged to reproduce printf's digits and the search's
 * choice of P rather than the shortest digit string: about 70 ns a value against 1.5 us (double)
 * and 0.8 us (float) for the search (bench/numtext_sweep).  Floats, the writers' values, mostly
 * go a shorter way to the same text (Ryu's digit removal, "floats: the shortest digits" below):
 * about 36 ns.  A fixed number of digits up to 9 (a reduced tree's five) goes first a shorter way
 * still, in double arithmetic (format_digits_quick), which also gives the value a reader stores
 * without reading the text back; the rare value it cannot be sure of goes the fixed-point way.
 *
 * Reading goes the other way with Clinger's fast path (bsti_parse_double): a decimal whose digits
 * fit an exact double (below 2^53) and whose power of ten is exact (|p| <= 22) is one correctly
 * rounded product or quotient of exact operands, which is strtod's answer; the readers' numbers
 * ("1.684e+02") nearly all are.  Anything else, including text strtod would read other than a
 * plain decimal (inf, nan, hexadecimal), is strtod's. */
#include <config.h>

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "numtext.h"

/* Powers of ten as doubles (exact to 1e22, correctly rounded above): Clinger's fast path. */
static const double pow10_pos[] = {
    1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14,
    1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22, 1e23, 1e24, 1e25, 1e26, 1e27, 1e28, 1e29,
    1e30, 1e31, 1e32, 1e33, 1e34, 1e35, 1e36, 1e37, 1e38, 1e39, 1e40, 1e41, 1e42, 1e43, 1e44,
    1e45, 1e46, 1e47, 1e48, 1e49, 1e50, 1e51, 1e52, 1e53, 1e54, 1e55, 1e56, 1e57, 1e58, 1e59,
    1e60};

/* The text printf's "%.*g" with precision prec gives for r * 10^lead / 10^(ndigits(r) - 1), r's
 * leading digit at decimal exponent lead, trailing zeros dropped as %g drops them. */
static const char pairs[201] = "00010203040506070809101112131415161718192021222324252627282930313233"
    "343536373839404142434445464748495051525354555657585960616263646566676869707172737475767778798081"
    "828384858687888990919293949596979899";

static int g_text(uint64_t r, int lead, int prec, int negative, char *buf)
{
    char dig[24];
    int m = 0;
    while (r >= 100) { /* two digits a step: half the chain of dependent divisions */
        uint64_t q = r / 100, d = r - 100 * q;
        dig[m++] = pairs[2 * d + 1];
        dig[m++] = pairs[2 * d];
        r = q;
    }
    if (r >= 10) {
        dig[m++] = pairs[2 * r + 1];
        dig[m++] = pairs[2 * r];
    } else if (r) {
        dig[m++] = (char)('0' + r);
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

#if defined(__GNUC__) && defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define HAVE_SWAR_DIGITS 1
/* The 8 decimal digits of n < 10^8 as byte values 0..9, the most significant at the lowest
 * address (the word stored little-endian): n's halves of four digits in two 32-bit lanes, each
 * split into two of two digits and each of those into two digits, every lane at once, by
 * multiplications with reciprocals that are exact in the lanes' ranges (x / 100 = x 10486 >> 20
 * for x < 10^4, x / 10 = x 103 >> 10 for x < 100) and masks that keep a lane's quotient from its
 * neighbour's low bits.  tests/test_numtext.c checks it against division for every n < 10^8. */
static inline uint64_t digits8(uint32_t n)
{
    uint64_t v = (uint64_t)(n / 10000) | (uint64_t)(n % 10000) << 32;
    uint64_t hundreds = v * 10486 >> 20 & (UINT64_C(0x7f) << 32 | 0x7f);
    uint64_t pairs2 = (v - 100 * hundreds) << 16 | hundreds; /* 16-bit lanes of two digits */
    uint64_t tens = pairs2 * 103 >> 10 & UINT64_C(0x000f000f000f000f);
    return tens | (pairs2 - 10 * tens) << 8;
}

/* g_text for r of exactly p <= 7 digits, not negative, printed without an exponent (-4 <= lead <
 * p): the digits as one word, the last non-zero one found from the word's non-zero bytes, and the
 * text stored 8 bytes at a time (16 bytes of room in buf). */
static int g_text_plain(uint32_t r, int lead, int p, char *buf)
{
    uint64_t d = digits8(r) >> 8 * (8 - p); /* the p digits from byte 0, zero bytes above */
    uint64_t nonzero = (d + UINT64_C(0x7f7f7f7f7f7f7f7f)) & UINT64_C(0x8080808080808080);
    int n = (63 - __builtin_clzll(nonzero)) / 8 + 1; /* the digits %g keeps (r != 0) */
    uint64_t text = d | UINT64_C(0x3030303030303030);
    int len;
    if (lead < 0) { /* 0.000ddd: the digits after "0." and -lead - 1 zeros */
        memcpy(buf, "0.000000", 8);
        memcpy(buf + 1 - lead, &text, 8);
        len = 1 - lead + n;
    } else {
        memcpy(buf, &text, 8);
        len = lead + 1;
        if (n > lead + 1) { /* ddd.ddd */
            uint64_t frac = text >> 8 * (lead + 1);
            buf[lead + 1] = '.';
            memcpy(buf + lead + 2, &frac, 8);
            len = n + 1;
        }
    }
    buf[len] = '\0';
    return len;
}
#endif

int bsti_numtext_digits8(uint32_t n, unsigned char d[8])
{
#ifdef HAVE_SWAR_DIGITS
    uint64_t x = digits8(n);
    memcpy(d, &x, 8);
    return 1;
#else
    (void)n, (void)d;
    return 0;
#endif
}

/* printf's "%.*g" text of v != 0 with 1 <= p <= 9 significant digits, and in *back the double
 * strtod reads of it; 0 where double arithmetic cannot be sure (then the exact path decides).
 * A reduced tree's values take this way, about three times faster than the fixed-point one and
 * without reading the text back.  x = v 10^s, with 10^s exact (|s| <= 22), is one correctly
 * rounded product or quotient, within half an ulp of X = v 10^s; X < 10^9 < 2^30 puts it within
 * 2^-24 of X, so rounding x to an integer rounds X alike unless x's fraction lies within 2^-22 of
 * a half (exact ties, printf's half-way-to-even, among them): those go the exact way.  The text's
 * value r 10^-s is again one correctly rounded operation of exact operands (Clinger's fast path),
 * which is strtod's answer. */
static int format_digits_quick(double v, int p, char *buf, double *back)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    int bexp = (int)(bits >> 52 & 0x7ff), negative = (int)(bits >> 63);
    if (bexp == 0 || bexp == 0x7ff) /* zero, subnormal, inf, nan */
        return 0;
    /* log10's floor, or one or two less (the loop below goes up; two passes, then the slow way):
     * floor(e log10 2) or one less, in integers, by a factor a little below log10 2 for e >= 0
     * (78913 / 2^18) and a little above it below 0 (315653 / 2^20) */
    int e2 = bexp - 1023;
    int lead = e2 >= 0 ? (e2 * 78913) >> 18 : -((-e2 * 315653 + 1048575) >> 20);
    double a = fabs(v);
    for (int pass = 0; pass < 2; pass++) {
        int s = p - 1 - lead;
        if (s < -22 || s > 22)
            return 0;
        double x = s >= 0 ? a * pow10_pos[s] : a / pow10_pos[-s];
        if (x >= pow10_pos[p]) { /* the floor was one less */
            lead++;
            continue;
        }
        /* floor (0 < x < 10^9: the signed conversions, one instruction each way), f exact */
        int64_t whole = (int64_t)x;
        double f = x - (double)whole;
        if (fabs(f - 0.5) <= 0x1p-22)
            return 0;
        int64_t r = whole + (f > 0.5);
        double val = s >= 0 ? (double)r / pow10_pos[s] : (double)r * pow10_pos[-s];
        *back = negative ? -val : val;
        if ((double)r >= pow10_pos[p]) { /* 9.99996 -> 10.000: one digit up */
            lead++;
            r /= 10;
        }
#ifdef HAVE_SWAR_DIGITS
        if (p <= 7 && !negative && lead >= -4 && lead < p)
            return g_text_plain((uint32_t)r, lead, p, buf);
#endif
        return g_text((uint64_t)r, lead, p, negative, buf);
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

/* ------------------------------------------------------------------ shortest text
 *
 * v = m 2^e exactly (m < 2^53, or < 2^24 for a float).  X = v 10^s with s chosen so that X has
 * 17 digits before the point (10^16 <= X < 10^17) is held in fixed point with FRAC fraction
 * bits, from one product of m with a 128-bit 10^s (numtext_pow10.h), as are the half-gaps to v's
 * neighbours.  The P-digit text printf prints is round-half-even(X / 10^(17-P)); strtod reads it
 * back as v when it lies within half a gap of v, a tie going to the even significand.  With
 * these exact tests the search over P is replayed step by step where it must be (powers of two,
 * whose lower gap is half the upper: there the test is not monotone in P), and elsewhere the
 * least passing P is found trying the likeliest first; so the digits are the search's.  A
 * decision nearer than DMARGIN units to its threshold where the values are not exact (the table
 * entry is rounded or a shift dropped bits) is left to the search itself: about 1 in 10^4 random
 * bit patterns, all of them at or above 10^17 where 10^s (s < 0) is inexact and v is an integer
 * (ties there look exact); none in 2e6 values of the BSDF range, none for floats.
 * tests/test_numtext.c compares with the search.
 * Floats go the same way with at most 9 digits (tests/test_write.c compares them with their
 * search; all 334525322 floats from 1e-8 to 1e4 were compared once by hand with the earlier
 * double-arithmetic path: no difference).
 * Without unsigned __int128 (not gcc or clang on a 64-bit target) the searches do it all. */
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

/* x / 10^k for k = 17 - p, p = 1..17: a constant divisor in each case, which the compiler turns
 * into a multiplication (a 64-bit division by a variable takes several times as long, and this
 * is the formatter's inner step). */
static inline uint64_t div_p10(uint64_t x, int k)
{
    switch (k) {
    case 0: return x;
    case 1: return x / 10ull;
    case 2: return x / 100ull;
    case 3: return x / 1000ull;
    case 4: return x / 10000ull;
    case 5: return x / 100000ull;
    case 6: return x / 1000000ull;
    case 7: return x / 10000000ull;
    case 8: return x / 100000000ull;
    case 9: return x / 1000000000ull;
    case 10: return x / 10000000000ull;
    case 11: return x / 100000000000ull;
    case 12: return x / 1000000000000ull;
    case 13: return x / 10000000000000ull;
    case 14: return x / 100000000000000ull;
    case 15: return x / 1000000000000000ull;
    default: return x / 10000000000000000ull; /* 16 (p = 1) */
    }
}

/* The P-digit rounding of X, r (10^(P-1) <= r <= 10^P), and whether strtod reads r 10^(17-P-s)
 * back as v: 1 or 0, or -1 when that is not certain here. */
static int dfixed_digits(const struct dfixed *d, int p, uint64_t *r)
{
    uint64_t D = p10u[17 - p], xi = (uint64_t)(d->x >> FRAC), q = div_p10(xi, 17 - p);
    u128 rem = (u128)(xi - q * D) << FRAC | (d->x & (((u128)1 << FRAC) - 1));
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

/* The search's text for m 2^e != 0 with at most maxp digits (17: double, 9: float; the type's
 * significand m, asym where the gap below is half the gap above): the length written, or 0 where
 * the answer is not certain here. */
static int format_fixed(uint64_t m, int e, int asym, int maxp, int negative, char *buf)
{
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
    int lo = 1, hi = maxp, ok;
    uint64_t r, rhi = 0;
    if (!asym) {
        /* With equal gaps on both sides the test is monotone in P (the P+1-digit rounding is never
         * farther from v than the P-digit one), so the search's answer is the least P that passes,
         * found in any order: most values need maxp or maxp - 1 digits, so those are tried first. */
        if ((ok = dfixed_digits(&d, maxp - 1, &rhi)) < 0)
            return 0;
        if (!ok)
            lo = maxp;
        else if ((ok = dfixed_digits(&d, maxp - 2, &r)) < 0)
            return 0;
        else if (!ok)
            lo = hi = maxp - 1;
        else
            hi = maxp - 2, rhi = r;
    }
    while (lo < hi) { /* the search's steps */
        int mid = (lo + hi) / 2;
        if ((ok = dfixed_digits(&d, mid, &r)) < 0)
            return 0;
        if (ok)
            hi = mid, rhi = r;
        else
            lo = mid + 1;
    }
    if (lo == maxp && dfixed_digits(&d, maxp, &rhi) < 0)
        return 0;
    r = rhi;
    if (r >= p10u[lo]) /* 9.96 -> 10: one digit up */
        lead++;
    return g_text(r, lead, lo, negative, buf);
}

/* A finite v != 0 as format_double_search prints it, or 0. */
static int format_double_fast(double v, char *buf)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    int bexp = (int)(bits >> 52 & 0x7ff), negative = (int)(bits >> 63);
    uint64_t frac = bits & ((1ull << 52) - 1);
    if (bexp == 0x7ff || (bexp == 0 && frac == 0))
        return 0;
    if (bexp == 0) /* subnormal */
        return format_fixed(frac, -1074, 0, 17, negative, buf);
    return format_fixed(frac | 1ull << 52, bexp - 1075, frac == 0 && bexp > 1, 17, negative, buf);
}

/* A finite v != 0 with p significant digits (1 <= p <= 17), as printf's "%.*g" prints it: the
 * P-digit rounding of X (half-way to even, decided exactly as the search's are), or 0 where it is
 * too close to call here (then printf does it).  A fixed number of digits (a reduced tree's) costs
 * what the shortest text does instead of a printf. */
static int format_digits_fast(double v, int p, char *buf)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    int bexp = (int)(bits >> 52 & 0x7ff), negative = (int)(bits >> 63);
    uint64_t m = bits & ((1ull << 52) - 1);
    int e = -1074;
    if (bexp == 0x7ff || (bexp == 0 && m == 0))
        return 0;
    if (bexp)
        m |= 1ull << 52, e = bexp - 1075;
    int e2 = e + 63 - __builtin_clzll(m), lead = (int)floor(e2 * 0.30102999566398120);
    struct dfixed d;
    if (!dfixed_scale(m, e, 16 - lead, 0, &d))
        return 0;
    if ((uint64_t)(d.x >> FRAC) >= p10u[17]) {
        lead++;
        if (!dfixed_scale(m, e, 16 - lead, 0, &d))
            return 0;
    }
    if ((uint64_t)(d.x >> FRAC) < p10u[16])
        return 0;
    uint64_t D = p10u[17 - p], xi = (uint64_t)(d.x >> FRAC), r = div_p10(xi, 17 - p);
    u128 rem = (u128)(xi - r * D) << FRAC | (d.x & (((u128)1 << FRAC) - 1));
    int c = dfixed_cmp(rem, (u128)D << (FRAC - 1), d.exact);
    if (c == -2)
        return 0;
    r += c > 0 || (c == 0 && (r & 1));
    if (r >= p10u[p]) /* 9.9996 -> 10.000: one digit up */
        lead++;
    return g_text(r, lead, p, negative, buf);
}

/* ------------------------------------------------------------------ floats: the shortest digits
 *
 * The writers' values are floats, and for them a shorter way finds the same text.  Where the gaps
 * on both sides of v are equal (all but the powers of two), the search's test is monotone in P and
 * the least P that passes is the length of the shortest decimal inside v's rounding interval (if
 * any P-digit number lies inside, so does the nearest one, printf's: the interval is symmetric);
 * and printf's P digits are that shortest decimal nearest v.  That is what Ryu's digit removal
 * finds (Adams 2018, section 3): v and its interval's ends on a decimal grid finer than the gap,
 * exactly, then one digit off all three while a coarser grid point still lies inside, the digits
 * removed from v remembered for the rounding.  Here the grid values come exact from one 128-bit
 * product: v = 4m 2^-s (s > 0), the ends 4m -/+ 2, times 10^d; floors by a shift, exactness from
 * the bits shifted out.  10^d 2^-s lies in [10, 100), so the interval spans at least 40 grid
 * steps (a digit is always removed, and v's remainder is seen) and 4m 10^d < 2^128 for d <= 30:
 * normal floats from 2^-68 to 2^25 (about 3e-21 to 3e7), where every BSDF value lies; the others
 * and the powers of two take format_fixed's way.  Compared with it on every float in that range
 * by hand (bench/numtext_sweep --floats), with the search in tests/test_write.c and
 * tests/test_numtext.c. */
#define P19 10000000000000000000ull
static const u128 p10w[31] = {1ull, 10ull, 100ull, 1000ull, 10000ull, 100000ull, 1000000ull,
    10000000ull, 100000000ull, 1000000000ull, 10000000000ull, 100000000000ull, 1000000000000ull,
    10000000000000ull, 100000000000000ull, 1000000000000000ull, 10000000000000000ull,
    100000000000000000ull, 1000000000000000000ull, P19, (u128)P19 * 10u, (u128)P19 * 100u,
    (u128)P19 * 1000u, (u128)P19 * 10000u, (u128)P19 * 100000u, (u128)P19 * 1000000u,
    (u128)P19 * 10000000u, (u128)P19 * 100000000u, (u128)P19 * 1000000000u,
    (u128)P19 * 10000000000ull, (u128)P19 * 100000000000ull};

/* g_text for r 10^e, r of at most 9 digits, the last not 0 (printf's "%.*g" with precision the
 * number of digits of r): the digits written once, right to left, two a step, then moved into
 * place. */
static int float_text(uint32_t r, int e, int negative, char *buf)
{
    char dig[10], *end = dig + 10, *q = end;
    while (r >= 100) {
        uint32_t t = r / 100, p = r - 100 * t;
        q -= 2;
        memcpy(q, pairs + 2 * p, 2);
        r = t;
    }
    if (r >= 10) {
        q -= 2;
        memcpy(q, pairs + 2 * r, 2);
    } else {
        *--q = (char)('0' + r);
    }
    int nd = (int)(end - q), lead = e + nd - 1;
    char *s = buf;
    if (negative)
        *s++ = '-';
    if (lead < -4 || lead >= nd) { /* d.ddde+XX */
        *s++ = q[0];
        if (nd > 1) {
            *s++ = '.';
            memcpy(s, q + 1, (size_t)nd - 1);
            s += nd - 1;
        }
        int x = lead < 0 ? -lead : lead;
        *s++ = 'e';
        *s++ = lead < 0 ? '-' : '+';
        if (x >= 100)
            *s++ = (char)('0' + x / 100), x %= 100;
        memcpy(s, pairs + 2 * x, 2);
        s += 2;
    } else if (lead >= 0) { /* ddd.ddd (nd > lead) */
        memcpy(s, q, (size_t)lead + 1);
        s += lead + 1;
        if (nd > lead + 1) {
            *s++ = '.';
            memcpy(s, q + lead + 1, (size_t)(nd - lead - 1));
            s += nd - lead - 1;
        }
    } else { /* 0.000ddd */
        *s++ = '0';
        *s++ = '.';
        for (int k = -1; k > lead; k--)
            *s++ = '0';
        memcpy(s, q, (size_t)nd);
        s += nd;
    }
    *s = '\0';
    return (int)(s - buf);
}

/* m 2^e, 2^23 < m < 2^24, s = 2 - e in 1..93: the search's text, its length. */
static int format_float_short(uint32_t m, int e, int negative, char *buf)
{
    int s = 2 - e, d = ((s * 78913) >> 18) + 2; /* floor(s log10 2) + 2 */
    u128 t = p10w[d], x = (u128)(4u * m) * t, h = 2 * t, mask = ((u128)1 << s) - 1;
    u128 lo = x - h, hi = x + h;                /* 10^d times v, its ends; units 2^-s */
    uint64_t vr = (uint64_t)(x >> s), vp = (uint64_t)(hi >> s), vm = (uint64_t)(lo >> s);
    int even = !(m & 1);                        /* strtod: an end reads as v when m is even */
    int vr_tz = (x & mask) == 0, vm_tz = even && (lo & mask) == 0, last = 0, removed = 0;
    if (!even && (hi & mask) == 0)
        vp--;                                   /* the upper end itself reads as the neighbour */
    while (vp / 100 > vm / 100) {               /* two digits a step while that is inside */
        vm_tz &= vm % 100 == 0;
        vr_tz &= last == 0 && vr % 10 == 0;
        last = (int)(vr / 10 % 10);
        vr /= 100, vp /= 100, vm /= 100, removed += 2;
    }
    while (vp / 10 > vm / 10) {                 /* a coarser grid point still inside */
        vm_tz &= vm % 10 == 0;
        vr_tz &= last == 0;
        last = (int)(vr % 10);
        vr /= 10, vp /= 10, vm /= 10, removed++;
    }
    if (vm_tz) /* the lower end is inside and on the grid: shorter texts may end there */
        while (vm % 10 == 0) {
            vr_tz &= last == 0;
            last = (int)(vr % 10);
            vr /= 10, vp /= 10, vm /= 10, removed++;
        }
    if (vr_tz && last == 5 && !(vr & 1))
        last = 4;                               /* an exact half: printf rounds to even */
    uint32_t r = (uint32_t)(vr + ((vr == vm && !vm_tz) || last >= 5)); /* at most 9 digits */
    while (r % 10 == 0)
        r /= 10, removed++;
    return float_text(r, removed - d, negative, buf);
}

/* A finite f != 0 as bsti_format_float_search prints it, or 0. */
static int format_float_fixed(float f, char *buf)
{
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    int bexp = (int)(bits >> 23 & 0xff), negative = (int)(bits >> 31);
    uint32_t frac = bits & ((1u << 23) - 1);
    if (bexp == 0xff || (bexp == 0 && frac == 0))
        return 0;
    if (bexp == 0)
        return format_fixed(frac, -149, 0, 9, negative, buf);
    if (frac && bexp >= 59 && bexp <= 151)
        return format_float_short(frac | 1u << 23, bexp - 150, negative, buf);
    return format_fixed(frac | 1u << 23, bexp - 150, frac == 0 && bexp > 1, 9, negative, buf);
}

int bsti_format_float_general(float f, char *buf)
{
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    int bexp = (int)(bits >> 23 & 0xff), negative = (int)(bits >> 31);
    uint32_t frac = bits & ((1u << 23) - 1);
    if (bexp == 0xff || bexp == 0)
        return 0;
    return format_fixed(frac | 1u << 23, bexp - 150, frac == 0 && bexp > 1, 9, negative, buf);
}
#else
int bsti_format_float_general(float f, char *buf)
{
    (void)f, (void)buf;
    return 0;
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

int bsti_format_float(double v, int digits, char *buf, float *back)
{
    if (v == 0.0) {
        buf[0] = '0', buf[1] = '\0';
        *back = 0.0f;
        return 1;
    }
    if (digits > 0) { /* what a reader stores: the text read as a double, then the float of it */
        double x;
        int n = format_digits_quick(v, digits > 9 ? 9 : digits, buf, &x);
        if (n) {
            *back = (float)x;
            return n;
        }
#ifdef HAVE_DFIXED
        n = format_digits_fast(v, digits > 9 ? 9 : digits, buf);
#endif
        if (!n)
            n = snprintf(buf, 32, "%.*g", digits > 9 ? 9 : digits, v);
        *back = bsti_parse_double(buf, (size_t)n, &x) ? (float)x : strtof(buf, NULL);
        return n;
    }
    float f = (float)v;
    *back = f;
#ifdef HAVE_DFIXED
    int n = format_float_fixed(f, buf);
    if (n)
        return n;
#endif
    return bsti_format_float_search(f, buf);
}

int bsti_format_double(double v, int digits, char *buf, double *back)
{
    if (v == 0.0) {
        buf[0] = '0', buf[1] = '\0';
        *back = 0.0;
        return 1;
    }
    if (digits > 0) {
        int n = digits <= 9 ? format_digits_quick(v, digits, buf, back) : 0;
        if (n)
            return n;
#ifdef HAVE_DFIXED
        n = format_digits_fast(v, digits > 17 ? 17 : digits, buf);
#endif
        if (!n)
            n = snprintf(buf, 32, "%.*g", digits > 17 ? 17 : digits, v);
        if (!bsti_parse_double(buf, (size_t)n, back))
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

int bsti_parse_scaled(const char *v, const char *const *suffix, const double *factor, double *out)
{
    char *end;
    errno = 0;
    double x = strtod(v, &end);
    if (end == v || !isfinite(x) || errno)
        return -1;
    for (int i = 0; suffix[i]; i++)
        if (strcmp(end, suffix[i]) == 0) {
            *out = x * factor[i];
            return 0;
        }
    return -1;
}
