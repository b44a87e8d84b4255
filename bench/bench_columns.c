/* bench_columns.c - one incident direction by iteration against the full system:
 *   bench/bench_columns K [REFDIR [THETA PHI]]
 * Pane + L_diffuser_t3k5 + pane (the bench_stack "diffuser" stack) at order K, double precision.
 * First the columns of the incident patch holding (THETA, PHI) (degrees, default 45, 90; light
 * propagating into the front side) for front incidence (Tf, Rf) by bst_stack_columns, timed, with
 * the peak RSS so far; then the whole system by bst_stack_combine_consume, timed, and the columns
 * compared: the largest difference relative to the column's largest value, and GA (Grobe 2017
 * eq. 7, equal weights: Shirley-Chiu patches) between the two. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "bsdfstack.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static double peak_gib(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss / 1048576.0;
}

static void die(bst_ctx *ctx, const char *what)
{
    fprintf(stderr, "bench_columns: %s: %s\n", what, ctx ? bst_ctx_message(ctx) : "failed");
    exit(1);
}

static void layers(bst_ctx *ctx, const bst_basis *b, const char *ref, bst_layer *l[3])
{
    const char *vis[] = {"Visible"};
    char path[4096];
    snprintf(path, sizeof path, "%s/L_diffuser_t3k5.xml", ref);
    bst_bsdf *f;
    if (bst_glass_layer_from_spec(ctx, "t0=0.8815,r0=0.0786", NULL, b, 1, vis, &l[0]) < 0 ||
        bst_glass_layer_from_spec(ctx, "t0=0.8815,r0=0.0786", NULL, b, 1, vis, &l[2]) < 0)
        die(ctx, "glass");
    if (bst_bsdf_read(ctx, path, NULL, &f) < 0 || bst_bsdf_to_layer(ctx, f, b, &l[1]) < 0)
        die(ctx, path);
    bst_bsdf_free(f);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: bench_columns K [REFDIR [THETA PHI]]\n");
        return 2;
    }
    int k = atoi(argv[1]);
    const char *ref = argc > 2 ? argv[2] : "../shared/reference";
    double theta = argc > 4 ? atof(argv[3]) : 45, phi = argc > 4 ? atof(argv[4]) : 90;
    bst_ctx *ctx = bst_ctx_new();
    bst_basis *b;
    if (!ctx || bst_basis_new_sc(ctx, k, &b) < 0)
        die(ctx, "basis");
    size_t n = bst_basis_size(b);
    /* light propagating along (theta, phi) into the front: -z, as combine --incident takes it */
    double t = theta * M_PI / 180, p = phi * M_PI / 180;
    double dir[3] = {sin(t) * cos(p) + 1e-9, sin(t) * sin(p) + 1e-9, -cos(t)};
    size_t col = bst_basis_patch(b, dir);

    double t0 = now();
    bst_layer *l[3] = {0};
    layers(ctx, b, ref, l);
    double t1 = now(), read_peak = peak_gib();
    bst_columns_opts co;
    bst_columns_opts_init(&co);
    bst_mat *tf, *rf;
    if (bst_stack_columns(ctx, 3, (const bst_layer *const *)l, NULL, 1, &col, &co, &tf, &rf) < 0)
        die(ctx, "columns");
    double t2 = now(), col_peak = peak_gib();
    printf("k = %d (N = %zu), pane + L_diffuser_t3k5 + pane, incident (%g, %g) = patch %zu\n", k, n,
           theta, phi, col);
    printf("reading the layers: %.1f s, peak RSS %.2f GiB\n", t1 - t0, read_peak);
    printf("one column by iteration: %.1f s, %d sweeps, last change %.2g of the incident flux, "
           "peak RSS %.2f GiB\n", t2 - t1, co.iterations, co.residual, col_peak);

    bst_stack_opts o;
    bst_stack_opts_init(&o);
    o.comps = BST_COMP_BIT(BST_TF) | BST_COMP_BIT(BST_RF);
    bst_layer *sys;
    if (bst_stack_combine_consume(ctx, 3, l, &o, &sys) < 0)
        die(ctx, "combine");
    double t3 = now();
    printf("the full system (Tf and Rf): %.1f s, peak RSS %.2f GiB\n", t3 - t2, peak_gib());
    const bst_mat *m[2] = {tf, rf};
    for (int c = 0; c < 2; c++) {
        const bst_mat *full = bst_layer_get(sys, 0, c ? BST_RF : BST_TF);
        double fmax = 0, dmax = 0, num = 0, den = 0;
        for (size_t i = 0; i < n; i++) {
            double x = full ? bst_mat_get(full, i, col) : 0, y = bst_mat_get(m[c], i, 0);
            fmax = fmax > fabs(x) ? fmax : fabs(x);
            dmax = dmax > fabs(x - y) ? dmax : fabs(x - y);
            num += (x - y) * (x - y);
            den += (x + y) * (x + y);
        }
        printf("%s: largest value %.6g 1/sr, largest difference %.3g of it, GA 100 - %.2g\n",
               c ? "Rf" : "Tf", fmax, fmax > 0 ? dmax / fmax : 0,
               den > 0 ? 100 * num / den : 0);
    }
    bst_mat_free(tf);
    bst_mat_free(rf);
    bst_layer_free(sys);
    bst_basis_free(b);
    bst_ctx_free(ctx);
    return 0;
}
