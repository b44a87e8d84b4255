/* bench_mat.c - times of the algebra's kernels at n = 1024, 2048, 4096 (or the sizes given as
 * arguments): diag*dense, sparse(1 %)*dense, dense*dense (GEMM, double and float), and the solves
 * (I - A)^-1 B for diagonal, sparse (1 %) and dense A with a dense B of NRHS columns.  Median of
 * three runs in seconds, GFLOP/s by the nominal operation count, and the process's peak RSS.
 * First, as lines starting with '#', the BLAS it ran on: OpenBLAS's build configuration (its
 * version first) and the number of threads it uses, asked of the library loaded (bench/run puts
 * them in bench/REPORT.md's header).
 * Run: make bench && bench/bench_mat [n ...] */
#include <config.h>

#include <stdio.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <time.h>

#include "bsdfstack.h"

#define RUNS 3
#define NRHS 256

/* OpenBLAS's own answers (its cblas.h declares them; weak here, so that another BLAS links too and
 * the lines say that it was not OpenBLAS) */
extern int openblas_get_num_threads(void) __attribute__((weak));
extern char *openblas_get_config(void) __attribute__((weak));

static void print_blas(void)
{
    if (openblas_get_config && openblas_get_num_threads) {
        printf("# BLAS: %s\n", openblas_get_config());
        printf("# BLAS threads: %d\n", openblas_get_num_threads());
    } else {
        printf("# BLAS: not OpenBLAS (no openblas_get_config in the process)\n");
        printf("# BLAS threads: unknown\n");
    }
}

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static unsigned long long rng = 88172645463325252ull;
static double uniform(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) * 0x1.0p-53;
}

static bst_mat *dense(bst_ctx *ctx, size_t r, size_t c, bst_precision p, double scale)
{
    bst_mat *m;
    if (bst_mat_new_dense(ctx, r, c, p, &m) < 0)
        exit(1);
    void *d = bst_mat_dense_data(m);
    for (size_t k = 0; k < r * c; k++) {
        double v = scale * uniform();
        if (p == BST_DOUBLE)
            ((double *)d)[k] = v;
        else
            ((float *)d)[k] = (float)v;
    }
    return m;
}

static bst_mat *sparse(bst_ctx *ctx, size_t n, double fill, double scale)
{
    size_t nnz = (size_t)(fill * n * n) + n;
    size_t *ri = malloc(nnz * sizeof *ri), *ci = malloc(nnz * sizeof *ci);
    double *x = malloc(nnz * sizeof *x);
    for (size_t k = 0; k < nnz; k++) {
        ri[k] = k < n ? k : (size_t)(uniform() * n);
        ci[k] = k < n ? k : (size_t)(uniform() * n);
        x[k] = scale * uniform();
    }
    bst_mat *m;
    if (bst_mat_new_sparse(ctx, n, n, nnz, ri, ci, x, &m) < 0)
        exit(1);
    free(ri), free(ci), free(x);
    return m;
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void report(const char *what, size_t n, double *t, double flops)
{
    qsort(t, RUNS, sizeof *t, cmp);
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("%-28s %6zu %10.4f %9.2f %10.0f\n", what, n, t[RUNS / 2], flops / t[RUNS / 2] * 1e-9,
           ru.ru_maxrss / 1024.0);
    fflush(stdout);
}

int main(int argc, char **argv)
{
    size_t sizes[8] = {1024, 2048, 4096};
    int ns = 3;
    if (argc > 1) {
        ns = 0;
        for (int i = 1; i < argc && ns < 8; i++)
            sizes[ns++] = (size_t)atol(argv[i]);
    }
    bst_ctx *ctx = bst_ctx_new();
    print_blas();
    printf("%-28s %6s %10s %9s %10s\n", "operation", "n", "median_s", "GFLOP/s", "peakRSS_MiB");
    for (int s = 0; s < ns; s++) {
        size_t n = sizes[s];
        double t[RUNS];
        double *dg = malloc(n * sizeof *dg);
        for (size_t i = 0; i < n; i++)
            dg[i] = 0.9 * uniform();
        bst_mat *d, *sp = sparse(ctx, n, 0.01, 1.0), *b = dense(ctx, n, n, BST_DOUBLE, 1.0);
        bst_mat *bf = dense(ctx, n, n, BST_FLOAT, 1.0), *a = dense(ctx, n, n, BST_DOUBLE, 0.9 / n);
        bst_mat *rhs = dense(ctx, n, NRHS, BST_DOUBLE, 1.0), *spa = sparse(ctx, n, 0.01, 0.9 / (0.01 * n + 1));
        bst_mat_new_diag(ctx, n, dg, &d);
        double nnz = (double)bst_mat_nnz(sp);
        struct { const char *name; const bst_mat *x, *y; double flops; } prods[] = {
            {"diag*dense", d, b, (double)n * n},
            {"sparse(1%)*dense", sp, b, 2.0 * nnz * n},
            {"dense*dense (GEMM double)", b, b, 2.0 * n * n * n},
            {"dense*dense (GEMM float)", bf, bf, 2.0 * n * n * n},
        };
        for (size_t p = 0; p < sizeof prods / sizeof prods[0]; p++) {
            for (int r = 0; r < RUNS; r++) {
                bst_mat *c;
                double t0 = now();
                if (bst_mat_mul(ctx, prods[p].x, prods[p].y, 0.0, &c) < 0) {
                    fprintf(stderr, "%s\n", bst_ctx_message(ctx));
                    return 1;
                }
                t[r] = now() - t0;
                bst_mat_free(c);
            }
            report(prods[p].name, n, t, prods[p].flops);
        }
        struct { const char *name; const bst_mat *a; double flops; } solves[] = {
            {"solve diag A", d, (double)n * NRHS},
            {"solve sparse(1%) A", spa, 0.0},
            {"solve dense A", a, 2.0 / 3.0 * n * n * n + 2.0 * n * n * NRHS},
        };
        for (size_t p = 0; p < sizeof solves / sizeof solves[0]; p++) {
            for (int r = 0; r < RUNS; r++) {
                bst_mat *x;
                double rc, t0 = now();
                if (bst_solve_left(ctx, solves[p].a, rhs, 0.0, &x, &rc) < 0) {
                    fprintf(stderr, "%s\n", bst_ctx_message(ctx));
                    return 1;
                }
                t[r] = now() - t0;
                bst_mat_free(x);
            }
            report(solves[p].name, n, t, solves[p].flops > 0 ? solves[p].flops : 0.0);
        }
        bst_mat_free(d), bst_mat_free(sp), bst_mat_free(b), bst_mat_free(bf), bst_mat_free(a);
        bst_mat_free(rhs), bst_mat_free(spa);
        free(dg);
    }
    printf("(solves: B dense with %d columns; sparse-solve GFLOP/s not given: the LU fill decides)\n", NRHS);
    bst_ctx_free(ctx);
    return 0;
}
