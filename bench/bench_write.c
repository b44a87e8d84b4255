/* bench_write - the BSDF XML writer's speed alone: a file is read once onto its own basis, then
 * written R times into a counting sink (no file, no disk) with 1 and with 2 threads in turn
 * (bst_ctx_set_threads), each write timed by the wall clock and by the process's CPU clock.
 * Prints one line per write and the medians: seconds, CPU-s, MB and MB/s of text.
 *
 * Usage: bench_write FILE [--runs R] [--no-reduce] [--float] [--threads LIST] [--reduce-tol T]
 *                    [--digits N]
 *   --float: the layer in single precision (the writer's float access); LIST: comma-separated
 *   thread counts, default 1,2; T: the reduction's tolerance (none: the percentile alone); N:
 *   significant digits (0: exact).  Only the public API is used, so the same source also measures
 *   an older libbsdfstack (without bst_ctx_set_threads: one line per run, "threads -"; without
 *   BST_REDUCE_TOL in its header: no --reduce-tol or --digits). */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bsdfstack.h"

#if defined(__GNUC__)
#pragma weak bst_ctx_set_threads
#endif

static int count(const char *buf, size_t len, void *opaque)
{
    (void)buf;
    *(size_t *)opaque += len;
    return 0;
}

static double clock_s(clockid_t id)
{
    struct timespec t;
    clock_gettime(id, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv)
{
    const char *path = NULL, *list = "1,2";
    int runs = 3, no_reduce = 0, single = 0, digits = -2;
    double tol = NAN;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--runs") == 0 && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (strcmp(argv[i], "--no-reduce") == 0)
            no_reduce = 1;
        else if (strcmp(argv[i], "--float") == 0)
            single = 1;
        else if (strcmp(argv[i], "--threads") == 0 && i + 1 < argc)
            list = argv[++i];
        else if (strcmp(argv[i], "--reduce-tol") == 0 && i + 1 < argc)
            tol = strcmp(argv[i + 1], "none") == 0 ? INFINITY : atof(argv[i + 1]), i++;
        else if (strcmp(argv[i], "--digits") == 0 && i + 1 < argc)
            digits = atoi(argv[++i]);
        else if (argv[i][0] != '-' && !path)
            path = argv[i];
        else {
            fprintf(stderr, "usage: bench_write FILE [--runs R] [--no-reduce] [--float] "
                            "[--threads LIST] [--reduce-tol T] [--digits N]\n");
            return 2;
        }
    }
    if (!path || runs < 1) {
        fprintf(stderr, "bench_write: give a BSDF XML file (and --runs R >= 1)\n");
        return 2;
    }
    int counts[8], ncounts = 0;
    for (const char *p = list; *p && ncounts < 8;) {
        counts[ncounts++] = atoi(p);
        p = strchr(p, ',');
        if (!p)
            break;
        p++;
    }
    if (!bst_ctx_set_threads)
        ncounts = 1;
    bst_ctx *ctx = bst_ctx_new();
    bst_bsdf *b = NULL;
    bst_basis *basis = NULL;
    bst_layer *l = NULL;
    bst_bsdf_read_opts ro;
    memset(&ro, 0, sizeof ro);
    ro.precision = single ? BST_FLOAT : BST_DOUBLE;
    int rc = bst_bsdf_read(ctx, path, &ro, &b);
    if (rc >= 0)
        rc = bst_bsdf_kind(b) == BST_FILE_KLEMS ? bst_basis_new_klems(ctx, "full", &basis)
                                                : bst_basis_new_sc(ctx, bst_bsdf_order(b), &basis);
    if (rc >= 0)
        rc = bst_bsdf_to_layer(ctx, b, basis, &l);
    if (rc < 0) {
        fprintf(stderr, "bench_write: %s: %s\n", path, bst_ctx_message(ctx));
        return 1;
    }
    bst_bsdf_write_opts o;
    bst_bsdf_write_opts_init(&o);
    o.date = "2000-01-01T00:00:00Z";
    o.reduce_pct = no_reduce ? -1.0 : BST_REDUCE_PCT;
    o.rank3_source = b;
#ifdef BST_REDUCE_TOL
    if (!isnan(tol))
        o.reduce_tol = tol;
    if (digits > -2)
        o.digits = digits;
#else
    if (!isnan(tol) || digits > -2) {
        fprintf(stderr, "bench_write: this libbsdfstack has no reduce_tol or automatic digits\n");
        return 2;
    }
#endif
    double *wall = calloc((size_t)runs * (size_t)ncounts, sizeof *wall);
    double *cpu = calloc((size_t)runs * (size_t)ncounts, sizeof *cpu);
    size_t bytes = 0;
    for (int r = 0; r < runs; r++)
        for (int c = 0; c < ncounts; c++) {
            if (bst_ctx_set_threads)
                bst_ctx_set_threads(ctx, counts[c]);
            size_t n = 0;
            double w0 = clock_s(CLOCK_MONOTONIC), c0 = clock_s(CLOCK_PROCESS_CPUTIME_ID);
            rc = bst_bsdf_write_fn(ctx, l, count, &n, &o);
            double w1 = clock_s(CLOCK_MONOTONIC), c1 = clock_s(CLOCK_PROCESS_CPUTIME_ID);
            if (rc < 0) {
                fprintf(stderr, "bench_write: %s\n", bst_ctx_message(ctx));
                return 1;
            }
            bytes = n;
            wall[c * runs + r] = w1 - w0, cpu[c * runs + r] = c1 - c0;
            printf("run %d threads %s%d: %.3f s, %.3f CPU-s, %.1f MB, %.0f MB/s\n", r + 1,
                   bst_ctx_set_threads ? "" : "- ", bst_ctx_set_threads ? counts[c] : 0, w1 - w0,
                   c1 - c0, n / 1e6, n / 1e6 / (w1 - w0));
        }
    for (int c = 0; c < ncounts; c++) {
        qsort(wall + c * runs, (size_t)runs, sizeof *wall, cmp_double);
        qsort(cpu + c * runs, (size_t)runs, sizeof *cpu, cmp_double);
        double mw = wall[c * runs + runs / 2], mc = cpu[c * runs + runs / 2];
        printf("median threads %d: %.3f s, %.3f CPU-s, %.1f MB, %.0f MB/s, %.0f MB per CPU-s\n",
               bst_ctx_set_threads ? counts[c] : 0, mw, mc, bytes / 1e6, bytes / 1e6 / mw,
               bytes / 1e6 / mc);
    }
    free(wall), free(cpu);
    bst_layer_free(l);
    bst_basis_free(basis);
    bst_bsdf_free(b);
    bst_ctx_free(ctx);
    return 0;
}
