/* bench_glass.c - what the choices behind a glass layer change (figures quoted in glass.h and
 * bsdfstack-glass(5)):
 *   1. patch centre vs patch average: for Shirley-Chiu k = 1..7 and Klems full, the largest
 *      difference of a patch's directional T and R between the two, at which angle, and the
 *      diffuse-diffuse (hemispherical) T and R of each against the continuous pane's
 *      2 int P(theta) sin(theta) cos(theta) dtheta (Gauss-Legendre, exact to rounding);
 *   2. the patch rule: M points per triangle and dimension against 4 BST_GLASS_SAMPLES;
 *   3. layer size in memory (stored values x 8 bytes).
 * Usage: bench_glass [PANE [CATALOGUE_DIR [KMAX [M]]]]
 * (default clear-6mm, $BSDFSTACK_GLASS_DIR, 7, BST_GLASS_SAMPLES points per triangle and dimension)
 * Angles in degrees in the output; P = T (Tf) or R (Rf) of the first channel of the pane. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "glass.h"

/* 2 int_0^pi/2 P(theta) sin cos dtheta by composite Gauss-Legendre (5 points on 2000 intervals). */
static double hemispherical(const bst_glass *g, int refl)
{
    static const double x[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                                0.9061798459386640};
    static const double w[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                                0.4786286704993665, 0.2369268850561891};
    const int m = 2000;
    double h = (M_PI / 2) / m, sum = 0;
    for (int i = 0; i < m; i++)
        for (int q = 0; q < 5; q++) {
            double th = (i + 0.5) * h + 0.5 * h * x[q], t, r;
            bst_glass_optics(g, 0, th, &t, NULL, &r, NULL);
            sum += w[q] * 0.5 * h * (refl ? r : t) * sin(th) * cos(th);
        }
    return 2 * sum;
}

/* diffuse-diffuse value sum_j Lambda_j P_j / pi of a layer component (P_j = Lambda_j M_jj). */
static double diffdiff(const bst_layer *l, bst_comp c)
{
    const bst_basis *b = bst_layer_basis(l);
    const double *lam = bst_basis_lambda(b);
    const bst_mat *m = bst_layer_get(l, 0, c);
    double s = 0;
    for (size_t j = 0; j < bst_basis_size(b); j++)
        s += lam[j] * lam[j] * bst_mat_get(m, j, j);
    return s / M_PI;
}

static int samples = BST_GLASS_SAMPLES;

static void compare(bst_ctx *ctx, const bst_glass *g, bst_basis *b, const char *name, int fine)
{
    bst_layer *cen, *avg, *ref = NULL;
    if (bsti_glass_layer(ctx, g, b, 0, NULL, 1, 1, 1, &cen) < 0 ||
        bsti_glass_layer(ctx, g, b, 0, NULL, 0, samples, 0, &avg) < 0 ||
        (fine && bsti_glass_layer(ctx, g, b, 0, NULL, 0, 4 * BST_GLASS_SAMPLES, 0, &ref) < 0)) {
        fprintf(stderr, "bench_glass: %s\n", bst_ctx_message(ctx));
        exit(1);
    }
    const double *lam = bst_basis_lambda(b);
    size_t n = bst_basis_size(b);
    double dt = 0, dr = 0, tht = 0, thr = 0, st = 0, sr = 0;
    for (size_t j = 0; j < n; j++) {
        double d[3];
        bst_basis_center(b, j, d);
        double th = atan2(hypot(d[0], d[1]), d[2]) * 180 / M_PI;
        double t = fabs(bst_mat_get(bst_layer_get(cen, 0, BST_TF), j, j) -
                        bst_mat_get(bst_layer_get(avg, 0, BST_TF), j, j)) * lam[j];
        double r = fabs(bst_mat_get(bst_layer_get(cen, 0, BST_RF), j, j) -
                        bst_mat_get(bst_layer_get(avg, 0, BST_RF), j, j)) * lam[j];
        if (t > dt)
            dt = t, tht = th;
        if (r > dr)
            dr = r, thr = th;
        if (ref) {
            st = fmax(st, fabs(bst_mat_get(bst_layer_get(ref, 0, BST_TF), j, j) -
                               bst_mat_get(bst_layer_get(avg, 0, BST_TF), j, j)) * lam[j]);
            sr = fmax(sr, fabs(bst_mat_get(bst_layer_get(ref, 0, BST_RF), j, j) -
                               bst_mat_get(bst_layer_get(avg, 0, BST_RF), j, j)) * lam[j]);
        }
    }
    double ht = hemispherical(g, 0), hr = hemispherical(g, 1);
    printf("%s\t%zu\t%.2e\t%.2f\t%.2e\t%.2f\t%+.2e\t%+.2e\t%+.2e\t%+.2e\t%zu\n", name, n, dt,
           tht, dr, thr, diffdiff(cen, BST_TF) - ht, diffdiff(avg, BST_TF) - ht,
           diffdiff(cen, BST_RF) - hr, diffdiff(avg, BST_RF) - hr, 4 * n * sizeof(double));
    if (ref)
        printf("#   %s: m = %d vs %d: max |dT| %.2e, max |dR| %.2e\n", name, samples, 4 * BST_GLASS_SAMPLES, st, sr);
    bst_layer_free(cen), bst_layer_free(avg), bst_layer_free(ref);
}

int main(int argc, char **argv)
{
    const char *pane = argc > 1 ? argv[1] : "clear-6mm";
    const char *dir = argc > 2 ? argv[2] : getenv("BSDFSTACK_GLASS_DIR");
    int kmax = argc > 3 ? atoi(argv[3]) : 7;
    if (argc > 4)
        samples = atoi(argv[4]);
    bst_ctx *ctx = bst_ctx_new();
    bst_glass *g;
    if (!ctx || bst_glass_parse(ctx, pane, dir, &g) < 0) {
        fprintf(stderr, "bench_glass: %s\n", ctx ? bst_ctx_message(ctx) : "out of memory");
        return 1;
    }
    printf("# pane %s, channel %s; continuous pane: T_hem %.6f R_hem %.6f\n", pane,
           bst_glass_channel(g, 0), hemispherical(g, 0), hemispherical(g, 1));
    printf("basis\tN\tmax_dT_centre_vs_avg\tat_theta\tmax_dR\tat_theta\tTdd_centre-hem\t"
           "Tdd_avg-hem\tRdd_centre-hem\tRdd_avg-hem\tbytes_per_channel\n");
    bst_basis *b;
    if (bst_basis_new_klems(ctx, "full", &b) >= 0) {
        compare(ctx, g, b, "klems-full", 1);
        bst_basis_free(b);
    }
    for (int k = 1; k <= kmax; k++) {
        char name[16];
        snprintf(name, sizeof name, "sc-k%d", k);
        if (bst_basis_new_sc(ctx, k, &b) < 0)
            return 1;
        compare(ctx, g, b, name, 1);
        bst_basis_free(b);
    }
    bst_glass_free(g);
    bst_ctx_free(ctx);
    return 0;
}
