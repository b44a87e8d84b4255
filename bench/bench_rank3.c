/* bench_rank3.c - a rank-3 tree at its own order (BST_RANK3_NATIVE) against the exact expansion:
 *   bench/bench_rank3 K [REFDIR [PRECISION [layer]]]
 * Reads L_diffuser_t3k5.xml (a rank-3 tree of depth 5) onto the Shirley-Chiu grid of order K > 5
 * both ways and prints, for the layer alone and for pane + layer + pane (glass:clear-6mm): the
 * seconds of each way and the peak RSS so far (every native result is made first), and per
 * component GA and FA (bst_metrics_accordance: Grobe 2017 eq. 7 and the flux accordance) at the
 * paper's directions, their least over every incident patch, and the largest |difference| of an
 * incident patch's directional-hemispherical value (`layer`: the layer alone only).
 * PRECISION (double, the default, or single) is that of the dense work of the exact way; at
 * K = 7 in double the exact stack needs about 14 GiB, in single about 7 GiB.  Run from the top of
 * the source tree (the pane from layers/glass) or set BSDFSTACK_GLASS_DIR. */
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

static double peak_mib(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return u.ru_maxrss / 1024.0;
}

static void die(bst_ctx *ctx, const char *what)
{
    fprintf(stderr, "bench_rank3: %s: %s\n", what, ctx ? bst_ctx_message(ctx) : "failed");
    exit(1);
}

/* The diffuser over b laid on by rule, alone (stack 0) or between two panes (stack 1). */
static bst_layer *make(bst_ctx *ctx, const char *path, const bst_basis *b, bst_rank3_rule rule,
                       bst_precision prec, int stack, double *seconds)
{
    double t0 = now();
    bst_bsdf_read_opts ro = {.precision = prec};
    bst_bsdf *f;
    bst_layer *shade, *pane, *out;
    if (bst_bsdf_read(ctx, path, &ro, &f) < 0 || bst_bsdf_set_rank3_rule(ctx, f, rule) < 0 ||
        bst_bsdf_to_layer(ctx, f, b, &shade) < 0)
        die(ctx, path);
    bst_bsdf_free(f);
    if (!stack) {
        *seconds = now() - t0;
        return shade;
    }
    const char *visible = "Visible", *dir = getenv("BSDFSTACK_GLASS_DIR"); /* the diffuser's channel */
    if (bst_glass_layer_from_spec(ctx, "clear-6mm", dir ? dir : "layers/glass", b, 1, &visible, &pane) < 0)
        die(ctx, "glass:clear-6mm");
    const bst_layer *layers[3] = {pane, shade, pane};
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    o.precision = prec;
    if (bst_stack_combine(ctx, 3, layers, &o, &out) < 0)
        die(ctx, "combine");
    bst_layer_free(shade), bst_layer_free(pane);
    *seconds = now() - t0;
    return out;
}

static void report(bst_ctx *ctx, const bst_layer *exact, const bst_layer *native, const bst_basis *b)
{
    static const double dirs[][2] = {{0, 0}, {25, 90}, {45, 90}, {50, 90}, {45, 45}, {65, 90}};
    size_t n = bst_basis_size(b);
    double *ga = malloc(4 * n * sizeof *ga), *fa = ga + n, *he = fa + n, *hn = he + n;
    if (!ga)
        die(NULL, "out of memory");
    for (int c = 0; c < BST_NCOMP; c++) {
        printf("  %s  GA/FA at", bst_comp_name((bst_comp)c));
        for (size_t d = 0; d < sizeof dirs / sizeof dirs[0]; d++) {
            double v[3], g, f;
            /* as `compare --incident` finds the patch (a boundary: the +x, +y side) */
            v[0] = sin(dirs[d][0] * M_PI / 180) * cos(dirs[d][1] * M_PI / 180) + 1e-9;
            v[1] = sin(dirs[d][0] * M_PI / 180) * sin(dirs[d][1] * M_PI / 180) + 1e-9;
            v[2] = cos(dirs[d][0] * M_PI / 180);
            size_t i = bst_basis_patch(b, v);
            if (bst_metrics_accordance(ctx, exact, native, 0, (bst_comp)c, i, &g, &f, NULL) < 0)
                die(ctx, "accordance");
            printf(" (%g,%g) %.2f/%.2f", dirs[d][0], dirs[d][1], g, f);
        }
        if (bst_metrics_accordance_all(ctx, exact, native, 0, (bst_comp)c, ga, fa) < 0 ||
            bst_layer_hemispherical(ctx, exact, 0, (bst_comp)c, he) < 0 ||
            bst_layer_hemispherical(ctx, native, 0, (bst_comp)c, hn) < 0)
            die(ctx, "metrics");
        double gmin = 100, fmin_ = 100, dh = 0;
        for (size_t i = 0; i < n; i++)
            gmin = fmin(gmin, ga[i]), fmin_ = fmin(fmin_, fa[i]), dh = fmax(dh, fabs(he[i] - hn[i]));
        printf("\n      least GA %.2f, least FA %.2f, largest |dhem| %.2e\n", gmin, fmin_, dh);
    }
    free(ga);
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 5) {
        fprintf(stderr, "usage: bench/bench_rank3 K [REFDIR [double|single [layer]]]\n");
        return 2;
    }
    int k = atoi(argv[1]);
    const char *ref = argc > 2 ? argv[2] : "../shared/reference";
    bst_precision prec = argc > 3 && strcmp(argv[3], "single") == 0 ? BST_FLOAT : BST_DOUBLE;
    char path[4096];
    snprintf(path, sizeof path, "%s/L_diffuser_t3k5.xml", ref);
    bst_ctx *ctx = bst_ctx_new();
    bst_basis *b;
    if (!ctx || bst_basis_new_sc(ctx, k, &b) < 0)
        die(ctx, "basis");
    int stacks = argc > 4 && strcmp(argv[4], "layer") == 0 ? 1 : 2;
    /* every native result first, so that their peak RSS is their own (it only grows) */
    bst_layer *native[2] = {NULL, NULL};
    double tn[2], pn[2];
    for (int stack = 0; stack < stacks; stack++) {
        native[stack] = make(ctx, path, b, BST_RANK3_NATIVE, prec, stack, &tn[stack]);
        pn[stack] = peak_mib();
    }
    for (int stack = 0; stack < stacks; stack++) {
        double te;
        bst_layer *exact = make(ctx, path, b, BST_RANK3_EXACT, prec, stack, &te);
        printf("%s, k = %d, %s: native %.2f s (peak RSS so far %.0f MiB), exact %.2f s (peak RSS "
               "so far %.0f MiB)\n", stack ? "pane + L_diffuser_t3k5 + pane" : "L_diffuser_t3k5 alone",
               k, prec == BST_FLOAT ? "single" : "double", tn[stack], pn[stack], te, peak_mib());
        report(ctx, exact, native[stack], b);
        bst_layer_free(exact), bst_layer_free(native[stack]);
    }
    bst_basis_free(b);
    bst_ctx_free(ctx);
    return 0;
}
