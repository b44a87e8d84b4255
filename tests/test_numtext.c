/* test_numtext.c - the writers' shortest double (and float) text (numtext.c's fixed-point replay
 * of the search) against the reference itself, bsti_format_double_search (printf's "%.*g" and strtod):
 * byte for byte on random bit patterns over every exponent, on random values in the BSDF range
 * (1e-8 .. 1e4), on decimals of 1 to 17 significant digits and their neighbours, and on
 * boundaries: every power of two (whose lower gap is half the upper: where the search is not
 * monotone) and of ten with their neighbours, subnormals, DBL_MIN, DBL_MAX, and exact printf ties
 * (multiples of 2^-k).  (A failure aborts through ck_abort_msg: ck_assert in the loops would
 * cost a write to Check's pipe per value.)  The sizes here run in a few seconds; bench/numtext_sweep.c runs the same
 * comparison on as many values as asked. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"
#include "numtext.h"

static uint64_t xorshift(uint64_t *x)
{
    *x ^= *x << 13, *x ^= *x >> 7, *x ^= *x << 17;
    return *x;
}

/* v and its two neighbours, both signs: the text equals the search's and reads back as v. */
static long check_around(double v)
{
    long n = 0;
    for (int s = -1; s <= 1; s++) {
        double w = s < 0 ? nextafter(v, 0.0) : s > 0 ? nextafter(v, INFINITY) : v;
        for (int sign = 0; sign < 2; sign++) {
            double u = sign ? -w : w, back = NAN;
            char got[32], want[32];
            if (!isfinite(u) || u == 0.0)
                continue;
            int len = bsti_format_double(u, 0, got, &back);
            bsti_format_double_search(u, want);
            if (strcmp(got, want) != 0 || len != (int)strlen(want) || strtod(got, NULL) != u || back != u)
                ck_abort_msg("%a: %s (%d), reference %s", u, got, len, want);
            n++;
        }
    }
    return n;
}

static long check_one(double v)
{
    char got[32], want[32];
    double back;
    if (!isfinite(v) || v == 0.0)
        return 0;
    bsti_format_double(v, 0, got, &back);
    bsti_format_double_search(v, want);
    if (strcmp(got, want) != 0)
        ck_abort_msg("%a: %s, reference %s", v, got, want);
    return 1;
}

START_TEST(test_double_random_bits)
{
    uint64_t x = 88172645463325252ull;
    long checked = 0;
    for (long i = 0; i < 250000; i++) {
        uint64_t bits = xorshift(&x);
        double v;
        memcpy(&v, &bits, sizeof v);
        checked += check_one(v);
    }
    ck_assert_int_gt(checked, 249000);
}
END_TEST

START_TEST(test_double_bsdf_range)
{
    uint64_t x = 0x9E3779B97F4A7C15ull;
    for (long i = 0; i < 250000; i++) {
        double u = (double)(xorshift(&x) >> 11) * 0x1p-53;
        if (check_one(pow(10.0, -8.0 + 12.0 * u)) != 1)
            ck_abort_msg("%g: not a finite non-zero value", u);
    }
}
END_TEST

/* Decimals of d significant digits (d = 1..17) read as doubles, with their neighbours: the
 * shortest text has d digits or fewer for the value itself and usually 16-17 for a neighbour. */
START_TEST(test_double_short_decimals)
{
    uint64_t x = 12345;
    char text[40];
    for (long i = 0; i < 60000; i++) {
        int d = 1 + (int)(xorshift(&x) % 17);
        double u = (double)(xorshift(&x) >> 11) * 0x1p-53;
        snprintf(text, sizeof text, "%.*e", d - 1, pow(10.0, -8.0 + 12.0 * u));
        if (check_around(strtod(text, NULL)) != 6)
            ck_abort_msg("%s: not 6 values checked", text);
    }
}
END_TEST

START_TEST(test_double_boundaries)
{
    char text[40];
    for (int e = -1074; e <= 1023; e++)
        check_around(ldexp(1.0, e));
    for (int k = -323; k <= 308; k++) {
        snprintf(text, sizeof text, "1e%d", k);
        check_around(strtod(text, NULL));
    }
    static const double fixed[] = {DBL_MAX, DBL_MIN, 0x1p-1074, 0x1.fffffffffffffp-1023,
        0x0.0000000000003p-1022, 1e23, 9007199254740993.0, 0.1, 0.3, 1.0 / 3.0, 2.0 / 3.0,
        5e-324, 1.7976931348623157e308, 2.2250738585072014e-308, 123456789012345678.0,
        0.30000000000000004, 9.999999999999999e22, 1e-8, 1e4, 9.5, 0.125, 0.375, 2.5};
    for (size_t i = 0; i < sizeof fixed / sizeof fixed[0]; i++)
        check_around(fixed[i]);
    /* exact printf ties: i 2^-k has a 5 where the digits are cut */
    for (int i = 1; i < 20000; i++) {
        check_one(i / 8.0);
        check_one(i / 1024.0);
        check_one(ldexp(i, -30));
        check_one((double)i);
    }
}
END_TEST

/* Floats (bsti_format_float: the same fixed-point path with 9 digits at most) against their search
 * in the BSDF range, as decimals of 1..9 digits with their neighbours, and at every power of two;
 * tests/test_write.c adds random bit patterns. */
START_TEST(test_float_vs_search)
{
    uint64_t x = 4711;
    char got[32], want[32], text[40];
    float back;
    for (long i = 0; i < 100000; i++) {
        double u = (double)(xorshift(&x) >> 11) * 0x1p-53;
        int d = 1 + (int)(xorshift(&x) % 9);
        snprintf(text, sizeof text, "%.*e", d - 1, pow(10.0, -8.0 + 12.0 * u));
        float f = strtof(text, NULL);
        float cand[3] = {f, nextafterf(f, 0.0f), nextafterf(f, INFINITY)};
        for (int k = 0; k < 3; k++) {
            bsti_format_float(cand[k], 0, got, &back);
            bsti_format_float_search(cand[k], want);
            if (strcmp(got, want) != 0 || back != cand[k] || strtof(got, NULL) != cand[k])
                ck_abort_msg("%a: %s, reference %s", (double)cand[k], got, want);
        }
    }
    for (int e = -149; e <= 127; e++) {
        float f = ldexpf(1.0f, e);
        bsti_format_float(f, 0, got, &back);
        bsti_format_float_search(f, want);
        if (strcmp(got, want) != 0)
            ck_abort_msg("%a: %s, reference %s", (double)f, got, want);
    }
}
END_TEST

/* Floats from 2^-68 to 2^25 take the shortest-digits way (Ryu's digit removal), the others the
 * fixed-point replay of the search: the two agree on 4 million random floats of that range and
 * on every float of one binade's neighbourhood of the decimals 10^-8..10^4 (all 1.56e9 of the
 * range were compared once by hand, bench/numtext_sweep --floats: no difference); the search
 * itself is the reference above and in tests/test_write.c. */
START_TEST(test_float_short_vs_general)
{
    uint64_t x = 2718281828;
    char got[32], want[32];
    float back;
    long compared = 0;
    for (long i = 0; i < 4000000; i++) {
        uint32_t bits = (uint32_t)((59u + xorshift(&x) % 93u) << 23 | (xorshift(&x) & 0x7fffffu));
        float f;
        memcpy(&f, &bits, sizeof f);
        if (!bsti_format_float_general(f, want))
            bsti_format_float_search(f, want);
        bsti_format_float(f, 0, got, &back);
        if (strcmp(got, want) != 0)
            ck_abort_msg("%a: %s, reference %s", (double)f, got, want);
        compared++;
    }
    for (int k = -8; k <= 4; k++) { /* 2^16 floats on either side of each power of ten */
        float c = (float)pow(10.0, k);
        uint32_t b0;
        memcpy(&b0, &c, sizeof b0);
        for (uint32_t bits = b0 - 65536; bits < b0 + 65536; bits++) {
            float f;
            memcpy(&f, &bits, sizeof f);
            if (!bsti_format_float_general(f, want))
                bsti_format_float_search(f, want);
            bsti_format_float(f, 0, got, &back);
            if (strcmp(got, want) != 0 || back != f)
                ck_abort_msg("%a: %s, reference %s", (double)f, got, want);
            compared++;
        }
    }
    ck_assert_int_eq(compared, 4000000 + 13 * 131072);
}
END_TEST

/* The texts known by heart (printf's layout: exponent form below 1e-4 and at or above 1e(P)). */
START_TEST(test_double_texts)
{
    static const struct { double v; const char *want; } cases[] = {
        {0.1, "0.1"}, {0.25, "0.25"}, {1.0 / 3.0, "0.3333333333333333"}, {1e-5, "1e-05"},
        {1e-4, "0.0001"}, {123456.0, "123456"}, {1e16, "1e+16"}, {1e17, "1e+17"}, {1e23, "1e+23"},
        {-2.5, "-2.5"}, {DBL_MAX, "1.7976931348623157e+308"}, {0x1p-1074, "5e-324"},
        {DBL_MIN, "2.2250738585072014e-308"},
        {0.30000000000000004, "0.30000000000000004"}, {100.0, "1e+02"}, {1e15, "1e+15"},
        {123456789012345.0, "123456789012345"}, {0, "0"}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char got[32];
        double back;
        bsti_format_double(cases[i].v, 0, got, &back);
        ck_assert_msg(strcmp(got, cases[i].want) == 0, "%a: %s, want %s", cases[i].v, got, cases[i].want);
    }
}
END_TEST

/* A fixed number of significant digits (a reduced tree's, a --digits setting): printf's "%.*g"
 * text byte for byte, for doubles (1 to 17 digits) and floats (1 to 9), on random bit patterns, on
 * the BSDF range and on exact printf ties (d.5 at the last digit, which go to even); and what a
 * reader stores of it (strtod, then the float). */
START_TEST(test_fixed_digits)
{
    uint64_t x = 0x9e3779b97f4a7c15ull;
    long compared = 0;
    for (int i = 0; i < 300000; i++) {
        uint64_t bits = xorshift(&x);
        double v;
        if (i % 3 == 0) {
            memcpy(&v, &bits, sizeof v);
            if (!isfinite(v) || v == 0.0)
                continue;
        } else if (i % 3 == 1) {
            v = exp(log(1e-8) + (double)(bits >> 11) * 0x1p-53 * (log(1e4) - log(1e-8)));
        } else { /* ties: r5 10^q, r of 1..8 digits */
            int nd = 1 + (int)(bits % 8), q = (int)((bits >> 8) % 12) - 8;
            double r = (double)((bits >> 20) % (uint64_t)pow(10, nd));
            v = (10.0 * r + 5.0) * pow(10.0, q);
        }
        int d = 1 + (int)((bits >> 40) % 17);
        char got[40], want[40];
        double back;
        bsti_format_double(v, d, got, &back);
        snprintf(want, sizeof want, "%.*g", d, v);
        if (strcmp(got, want) != 0 || back != strtod(want, NULL))
            ck_abort_msg("double %a, %d digits: %s, want %s", v, d, got, want);
        float fb;
        int df = 1 + d % 9;
        bsti_format_float(v, df, got, &fb);
        snprintf(want, sizeof want, "%.*g", df, v);
        if (fabs(v) <= FLT_MAX && (strcmp(got, want) != 0 || fb != (float)strtod(want, NULL)))
            ck_abort_msg("float path %a, %d digits: %s, want %s", v, df, got, want);
        compared++;
    }
    ck_assert_int_gt(compared, 250000);
}
END_TEST

/* The fixed digits' fast path (numtext.c, g_text_plain): the eight digits of every n < 10^8 as
 * division gives them, and printf's text for values printed without an exponent (1e-4 <= v <
 * 10^p) at 1 to 7 digits: decimals with trailing zeros (0.0125, 1.5, 100), values that round up
 * to the next power of ten (9.99996 at 5 digits), each power of ten and its neighbours. */
START_TEST(test_fixed_digits_plain)
{
    unsigned char d[8];
    if (bsti_numtext_digits8(0, d)) {
        for (uint32_t n = 0; n < 100000000; n++) {
            bsti_numtext_digits8(n, d);
            uint32_t m = n;
            for (int i = 7; i >= 0; i--, m /= 10)
                if (d[i] != m % 10)
                    ck_abort_msg("digits of %u: byte %d is %d, want %u", n, i, d[i], m % 10);
        }
    }
    uint64_t x = 0x2545f4914f6cdd1dull;
    long compared = 0;
    for (int i = 0; i < 400000; i++) {
        uint64_t bits = xorshift(&x);
        int p = 1 + (int)(bits % 7), lead = -4 + (int)((bits >> 8) % (uint64_t)(p + 4));
        int nd = 1 + (int)((bits >> 16) % (uint64_t)p);
        double v;
        if (i % 4 == 0) { /* nd digits, the rest zeros */
            double r = (double)(pow(10, nd - 1) + (double)((bits >> 24) % (uint64_t)(9 * pow(10, nd - 1))));
            v = r * pow(10.0, lead - nd + 1);
        } else if (i % 4 == 1) { /* just below the next power of ten */
            v = pow(10.0, lead + 1) * (1.0 - (double)((bits >> 24) % 10 + 1) * pow(10.0, -p - 1));
        } else if (i % 4 == 2) { /* a power of ten, or a neighbour */
            v = pow(10.0, lead);
            v = (bits >> 24) % 3 == 0 ? nextafter(v, 0.0) : (bits >> 24) % 3 == 1 ? v : nextafter(v, 1e300);
        } else {
            v = pow(10.0, lead) * (1.0 + 9.0 * (double)(bits >> 11 & 0xfffff) / 1048576.0);
        }
        char got[40], want[40];
        double back;
        float fb;
        bsti_format_double(v, p, got, &back);
        snprintf(want, sizeof want, "%.*g", p, v);
        if (strcmp(got, want) != 0 || back != strtod(want, NULL))
            ck_abort_msg("double %a, %d digits: %s, want %s", v, p, got, want);
        bsti_format_float(v, p, got, &fb);
        if (strcmp(got, want) != 0 || fb != (float)strtod(want, NULL))
            ck_abort_msg("float path %a, %d digits: %s, want %s", v, p, got, want);
        compared++;
    }
    ck_assert_int_eq(compared, 400000);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("numtext");
    TCase *tc = tcase_create("double text");
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, test_double_texts);
    tcase_add_test(tc, test_double_boundaries);
    tcase_add_test(tc, test_double_random_bits);
    tcase_add_test(tc, test_double_bsdf_range);
    tcase_add_test(tc, test_double_short_decimals);
    tcase_add_test(tc, test_float_vs_search);
    tcase_add_test(tc, test_float_short_vs_general);
    tcase_add_test(tc, test_fixed_digits);
    tcase_add_test(tc, test_fixed_digits_plain);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(suite());
}
