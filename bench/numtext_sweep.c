/* numtext_sweep.c - the shortest double text (bsti_format_double) against its reference search
 * (bsti_format_double_search: printf's "%.*g" and strtod) on as many values as asked, and both
 * formatters' speed.  Not part of make check (tests/test_numtext.c runs the same comparison at a
 * size that takes seconds).
 *
 *   make bench/numtext_sweep && bench/numtext_sweep [N [SEED]]
 *   bench/numtext_sweep --floats [THREADS]
 *
 * --floats: every float from 2^-68 to 2^25 (the positive ones; the sign is one character), the
 * float writer's shortest-digits way against the fixed-point replay of the search that doubles
 * take, which the rest of this program and the tests check against the search itself: 1.56e9
 * values, about a minute a thread here.
 *
 * N values of each family (default 10^6): random bit patterns (every exponent, both signs),
 * log-uniform values in the BSDF range 1e-8..1e4, and decimals of 1..17 significant digits in
 * that range with both neighbours (3 N); then every power of two and of ten in double range with
 * their neighbours, and exact printf ties i 2^-k.  Prints the values compared and the texts that
 * differ (none expected); then ns per value of the new path, the search, and the float writer's
 * fast path and its search (bsti_format_float, bsti_format_float_search) on 10^6 BSDF-range
 * values, the best of 5 passes in thread CPU time. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "numtext.h"

static uint64_t rng = 88172645463325252ull;
static long compared, differ;

static uint64_t next(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return rng;
}

static double uniform(void) { return (double)(next() >> 11) * 0x1p-53; }

static void check(double v)
{
    char got[32], want[32];
    double back;
    if (!isfinite(v) || v == 0.0)
        return;
    bsti_format_double(v, 0, got, &back);
    bsti_format_double_search(v, want);
    compared++;
    if (strcmp(got, want) != 0 && differ++ < 20)
        printf("DIFFERENT %a: %s, reference %s\n", v, got, want);
}

static void check3(double v)
{
    check(v), check(nextafter(v, 0.0)), check(nextafter(v, INFINITY));
}

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t); /* CPU time: the machine may be shared */
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

enum { NEW_DOUBLE, SEARCH_DOUBLE, FAST_FLOAT, SEARCH_FLOAT };

/* ns per value, the best of 5 passes over vals[0..n-1] */
static double time_it(int which, const double *vals, size_t n)
{
    char buf[32];
    double best = INFINITY, back;
    float fback;
    volatile int sink = 0;
    for (int pass = 0; pass < 5; pass++) {
        double t0 = now();
        for (size_t i = 0; i < n; i++)
            switch (which) {
            case NEW_DOUBLE: sink += bsti_format_double(vals[i], 0, buf, &back); break;
            case SEARCH_DOUBLE: sink += bsti_format_double_search(vals[i], buf); break;
            case FAST_FLOAT: sink += bsti_format_float(vals[i], 0, buf, &fback); break;
            default: sink += bsti_format_float_search((float)vals[i], buf); break;
            }
        best = fmin(best, (now() - t0) / (double)n * 1e9);
    }
    (void)sink;
    return best;
}

/* Every float from 2^-68 to 2^25 (the writer's shortest-digits way) against the fixed-point
 * replay of the search (bsti_format_float_general), bits lo..hi-1 of the positive floats. */
struct span {
    uint32_t lo, hi;
    long compared, differ;
};

static void *float_span(void *arg)
{
    struct span *sp = arg;
    char got[32], want[32];
    float back;
    for (uint32_t bits = sp->lo; bits < sp->hi; bits++) {
        float f;
        memcpy(&f, &bits, sizeof f);
        int nw = bsti_format_float_general(f, want);
        if (!nw)
            nw = bsti_format_float_search(f, want);
        bsti_format_float(f, 0, got, &back);
        sp->compared++;
        if (strcmp(got, want) != 0 && sp->differ++ < 20)
            printf("DIFFERENT %a: %s, reference %s\n", (double)f, got, want);
    }
    return NULL;
}

static int all_floats(int nthreads)
{
    uint32_t lo = (uint32_t)59 << 23, hi = (uint32_t)152 << 23; /* biased exponents 59..151 */
    struct span sp[16];
    pthread_t th[16];
    if (nthreads < 1 || nthreads > 16)
        nthreads = 2;
    for (int t = 0; t < nthreads; t++) {
        sp[t].lo = lo + (uint32_t)((uint64_t)(hi - lo) * (uint64_t)t / (uint64_t)nthreads);
        sp[t].hi = lo + (uint32_t)((uint64_t)(hi - lo) * (uint64_t)(t + 1) / (uint64_t)nthreads);
        sp[t].compared = sp[t].differ = 0;
        if (pthread_create(&th[t], NULL, float_span, &sp[t]) != 0)
            return 2;
    }
    for (int t = 0; t < nthreads; t++) {
        pthread_join(th[t], NULL);
        compared += sp[t].compared, differ += sp[t].differ;
    }
    printf("%ld floats compared (2^-68 to 2^25), %ld different\n", compared, differ);
    return differ != 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "--floats") == 0)
        return all_floats(argc > 2 ? atoi(argv[2]) : 2);
    long n = argc > 1 ? atol(argv[1]) : 1000000;
    if (argc > 2)
        rng = strtoull(argv[2], NULL, 10) | 1;
    for (long i = 0; i < n; i++) {
        uint64_t bits = next();
        double v;
        memcpy(&v, &bits, sizeof v);
        check(v);
    }
    for (long i = 0; i < n; i++)
        check(pow(10.0, -8.0 + 12.0 * uniform()));
    for (long i = 0; i < n; i++) {
        char text[40];
        int d = 1 + (int)(next() % 17);
        snprintf(text, sizeof text, "%.*e", d - 1, pow(10.0, -8.0 + 12.0 * uniform()));
        check3(strtod(text, NULL));
    }
    for (int e = -1074; e <= 1023; e++)
        check3(ldexp(1.0, e));
    for (int k = -323; k <= 308; k++) {
        char text[16];
        snprintf(text, sizeof text, "1e%d", k);
        check3(strtod(text, NULL));
    }
    check3(DBL_MAX), check3(DBL_MIN), check3(0x1p-1074);
    for (int i = 1; i < 100000; i++)
        check((double)i), check(i / 8.0), check(i / 1024.0), check(ldexp(i, -30));
    printf("%ld values compared, %ld different\n", compared, differ);
    fflush(stdout);

    size_t m = 1000000;
    double *vals = malloc(m * sizeof *vals);
    if (!vals)
        return 2;
    for (size_t i = 0; i < m; i++)
        vals[i] = pow(10.0, -8.0 + 12.0 * uniform());
    printf("ns/value (BSDF range, best of 5): double %.1f, its search %.1f; float %.1f, its search %.1f\n",
           time_it(NEW_DOUBLE, vals, m), time_it(SEARCH_DOUBLE, vals, m / 10),
           time_it(FAST_FLOAT, vals, m), time_it(SEARCH_FLOAT, vals, m / 10));
    free(vals);
    return differ != 0;
}
