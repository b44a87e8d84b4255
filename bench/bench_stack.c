/* bench_stack.c - one combination, timed: bench/bench_stack K STACK MODE [REFDIR]
 *   STACK: glass2 (two analytic panes), blind (pane + L_blind0 + pane), diffuser (pane +
 *          L_diffuser + pane)
 *   MODE:  typed (structured algebra), dense (--dense baseline), single (dense work in float)
 * Prints one TSV line: k, stack, mode, seconds reading layers, seconds combining (all four
 * components), peak RSS (MiB), and the system's hemispherical Tf at normal incidence.
 * bench/run-stack runs the grid of configurations (median of three runs each). */
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

static void die(bst_ctx *ctx, const char *what)
{
    fprintf(stderr, "bench_stack: %s: %s\n", what, bst_ctx_message(ctx));
    exit(1);
}

int main(int argc, char **argv)
{
    if (argc < 4) {
        fprintf(stderr, "usage: bench_stack K glass2|blind|diffuser typed|dense|single [REFDIR]\n");
        return 2;
    }
    int k = atoi(argv[1]);
    const char *stack = argv[2], *mode = argv[3];
    const char *ref = argc > 4 ? argv[4] : "../shared/reference";
    bst_ctx *ctx = bst_ctx_new();
    bst_basis *b;
    if (bst_basis_new_sc(ctx, k, &b) < 0)
        die(ctx, "basis");
    const char *vis[] = {"Visible"};
    double t0 = now();
    bst_layer *l[3] = {0};
    if (bst_glass_layer_from_spec(ctx, "t0=0.8815,r0=0.0786", NULL, b, 1, vis, &l[0]) < 0 ||
        bst_glass_layer_from_spec(ctx, "t0=0.8815,r0=0.0786", NULL, b, 1, vis, &l[2]) < 0)
        die(ctx, "glass");
    size_t n = 2;
    if (strcmp(stack, "glass2") != 0) {
        char path[4096];
        if (strcmp(stack, "blind") == 0)
            snprintf(path, sizeof path, "%s/L_blind0_t4k5.xml", ref);
        else
            snprintf(path, sizeof path, "%s/L_diffuser_t3k5.xml", ref);
        bst_bsdf *f;
        if (bst_bsdf_read(ctx, path, NULL, &f) < 0 || bst_bsdf_to_layer(ctx, f, b, &l[1]) < 0)
            die(ctx, path);
        bst_bsdf_free(f);
        n = 3;
    } else {
        l[1] = l[2];
        l[2] = NULL;
    }
    double t1 = now();
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    o.force_dense = strcmp(mode, "typed") != 0;
    o.precision = strcmp(mode, "single") == 0 ? BST_FLOAT : BST_DOUBLE;
    bst_layer *sys;
    /* as `bsdfstack combine` does: each input component freed at its last use */
    if (bst_stack_combine_consume(ctx, n, l, &o, &sys) < 0)
        die(ctx, "combine");
    double t2 = now();
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    size_t N = bst_basis_size(b);
    double *h = malloc(N * sizeof *h), d[3] = {1e-9, 1e-9, 1};
    bst_layer_hemispherical(ctx, sys, 0, BST_TF, h);
    printf("%d\t%s\t%s\t%.3f\t%.3f\t%.0f\t%.6f\n", k, stack, mode, t1 - t0, t2 - t1,
           ru.ru_maxrss / 1024.0, h[bst_basis_patch(b, d)]);
    free(h);
    bst_layer_free(sys);
    for (int i = 0; i < 3; i++)
        bst_layer_free(l[i]);
    bst_basis_free(b);
    bst_ctx_free(ctx);
    return 0;
}
