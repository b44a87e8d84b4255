/* test_system.c - the ray-traced ground truth: S1 = pane + specular blind + pane, ray traced as one
 * assembly by RADIANCE (../shared/reference/S1_t4k5.xml), against our combination of its three
 * separately ray-traced layers at k = 5: hemispherical totals, and the accordance of the
 * transmitted distribution at the paper's directions, incidence from both sides (bst_metrics_accordance):
 *   GA, the global accordance of Grobe 2017 (eq. 7): the bar, GA >= 99 at every direction
 *   and side (the combination scores 99.90-99.98);
 *   FA, the flux accordance (100 (1 - sum L |a - b| / sum L (a + b))), the share of the scattered
 *   flux on which the two agree, which every percent of Monte Carlo noise costs about a point.
 *
 * What accordance the data allow.  S1 and the blind are symmetric under x -> -x and y -> -y, so
 * each file's column for a direction and the mirror image of its column for the mirrored
 * direction estimate the same distribution from independent rays: their accordance measures the
 * file's noise.  At these directions S1 scores GA 99.95-99.99 against its mirror images (mean of
 * the two), the blind 99.87-99.99, and the combination inherits the blind's noise.  In FA the same
 * noise costs 1.7-3.7 points (S1 96.3-98.3 against its mirror images): FA is held to
 * 100 - sqrt(e_S1^2 + e_blind^2) - 1.5, with e = (100 - FA_mirror) / sqrt 2 each file's expected
 * deviation from the truth (1.5: the glass layers' noise and the estimate's scatter).  The analytic
 * panes in place of the ray-traced ones give the same figures to 0.03: RADIANCE's glass is the
 * same Fresnel model, and both are k = 5 cell averages. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static bst_layer *load(const char *what, const bst_basis *b) { return tu_layer(ctx, what, b); }

static const double dirs[][2] = {{25, 90}, {45, 90}, {50, 90}, {45, 45}, {65, 90}};

/* The incident patch of a propagation direction (theta, phi), nudged off the cell boundaries that
 * phi = 90 (x = 0) lies on, so that both files are read in the same cell. */
static size_t incident_patch(const bst_basis *b, double th, double ph)
{
    double d[3] = {sin(th * M_PI / 180) * cos(ph * M_PI / 180) + 1e-7,
                   sin(th * M_PI / 180) * sin(ph * M_PI / 180) + 1e-7, cos(th * M_PI / 180)};
    return bst_basis_patch(b, d);
}

/* Global and flux accordance of layer l's component c for incident patch j with its mirror image
 * (x -> -x and/or y -> -y, both for the incident and the exit directions), with
 * bst_metrics_accordance's definitions. */
static void mirror_accordance(const bst_layer *l, const bst_basis *b, bst_comp c, size_t j, int mx,
                              int my, double *ga, double *fa)
{
    const bst_mat *m = bst_layer_get(l, 0, c);
    const double *lam = bst_basis_lambda(b);
    size_t N = bst_basis_size(b);
    double d[3];
    bst_basis_center(b, j, d);
    d[0] = mx ? -d[0] : d[0], d[1] = my ? -d[1] : d[1];
    size_t jm = bst_basis_patch(b, d);
    double diff = 0, sum = 0, d2 = 0, s2 = 0;
    for (size_t i = 0; i < N; i++) {
        bst_basis_center(b, i, d);
        d[0] = mx ? -d[0] : d[0], d[1] = my ? -d[1] : d[1];
        double x = bst_mat_get(m, i, j), y = bst_mat_get(m, bst_basis_patch(b, d), jm);
        diff += lam[i] * fabs(x - y), sum += lam[i] * (x + y);
        d2 += lam[i] * (x - y) * (x - y), s2 += lam[i] * (x + y) * (x + y);
    }
    *fa = 100.0 * (1.0 - diff / sum);
    *ga = 100.0 * (1.0 - d2 / s2);
}

/* Mean of a file's two mirror accordances for column j. */
static void noise(const bst_layer *l, const bst_basis *b, bst_comp c, size_t j, double *ga, double *fa)
{
    double g1, f1, g2, f2;
    mirror_accordance(l, b, c, j, 1, 0, &g1, &f1);
    mirror_accordance(l, b, c, j, 0, 1, &g2, &f2);
    *ga = 0.5 * (g1 + g2), *fa = 0.5 * (f1 + f2);
}

static void accordance_table(const bst_layer *sys, const bst_layer *truth, const bst_layer *blind,
                             const bst_basis *b, const char *what, double ga_min)
{
    for (int side = 0; side < 2; side++)
        for (size_t k = 0; k < sizeof dirs / sizeof dirs[0]; k++) {
            size_t j = incident_patch(b, dirs[k][0], dirs[k][1]);
            bst_comp c = side ? BST_TB : BST_TF;
            double ga, fa, ga_s1, fa_s1, ga_bl, fa_bl;
            noise(truth, b, c, j, &ga_s1, &fa_s1);
            noise(blind, b, c, j, &ga_bl, &fa_bl);
            double e1 = (100.0 - fa_s1) / sqrt(2.0), e2 = (100.0 - fa_bl) / sqrt(2.0);
            double fa_expect = 100.0 - sqrt(e1 * e1 + e2 * e2);
            ck_assert_int_eq(bst_metrics_accordance(ctx, sys, truth, 0, c, j, &ga, &fa, NULL), BST_OK);
            printf("S1 %s, %s incidence (theta %g, phi %g): GA %.3f, FA %.2f; against their mirror "
                   "images: S1 GA %.3f FA %.2f, blind GA %.3f FA %.2f\n", what, side ? "back" : "front",
                   dirs[k][0], dirs[k][1], ga, fa, ga_s1, fa_s1, ga_bl, fa_bl);
            fflush(stdout);
            ck_assert_msg(ga >= ga_min, "%s %s (%g, %g): GA %.3f < %g", what, side ? "back" : "front",
                          dirs[k][0], dirs[k][1], ga, ga_min);
            ck_assert_msg(fa >= fa_expect - 1.5, "%s %s (%g, %g): FA %.2f < %.2f - 1.5", what,
                          side ? "back" : "front", dirs[k][0], dirs[k][1], fa, fa_expect);
        }
}

START_TEST(test_s1_raytraced)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b), BST_OK);
    bst_layer *l[3] = {load("L_glass_t4k5.xml", b), load("L_blind0_t4k5.xml", b), load("L_glass_t4k5.xml", b)};
    bst_layer *truth = load("S1_t4k5.xml", b), *sys, *dense;
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    o.comps = BST_COMP_BIT(BST_TF) | BST_COMP_BIT(BST_TB);
    int rc = bst_stack_combine(ctx, 3, (const bst_layer *const *)l, &o, &sys);
    ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    accordance_table(sys, truth, l[1], b, "combined layers", 99.0);
    /* hemispherical T at every incident patch below the outer ring (theta < 69.6 deg, where the
     * incident cells average steep angular changes: up to 14 % there, a discretisation effect) within
     * 6 % of the ray-traced system (Monte Carlo noise of S1 and of the blind, whose Tf comes by
     * reciprocity from its noisier Tb rows), and within 0.5 % on average */
    double hs[1024], ht[1024];
    for (int c = 0; c < BST_NCOMP; c += 2) {
        ck_assert_int_eq(bst_layer_hemispherical(ctx, sys, 0, (bst_comp)c, hs), BST_OK);
        ck_assert_int_eq(bst_layer_hemispherical(ctx, truth, 0, (bst_comp)c, ht), BST_OK);
        double mean = 0;
        int used = 0;
        for (size_t j = 0; j < 1024; j++) {
            size_t ix = j / 32, iy = j % 32;
            if (ix == 0 || iy == 0 || ix == 31 || iy == 31)
                continue;
            used++;
            ck_assert_msg(fabs(hs[j] - ht[j]) <= 0.06 * ht[j], "%s patch %zu: %.4f vs S1 %.4f",
                          bst_comp_name((bst_comp)c), j, hs[j], ht[j]);
            mean += hs[j] - ht[j];
        }
        mean /= used;
        printf("S1 %s: mean hemispherical difference (combined - ray traced) %+.4f\n", bst_comp_name((bst_comp)c), mean);
        ck_assert_double_lt(fabs(mean), 0.005);
    }
    /* the same stack forced dense gives the same matrices */
    o.force_dense = 1;
    ck_assert_int_ge(bst_stack_combine(ctx, 3, (const bst_layer *const *)l, &o, &dense), 0);
    for (int c = 0; c < BST_NCOMP; c += 2) {
        const bst_mat *x = bst_layer_get(sys, 0, (bst_comp)c), *y = bst_layer_get(dense, 0, (bst_comp)c);
        double scale = bst_mat_max_abs(y), worst = 0;
        for (size_t j = 0; j < 1024; j += 7)
            for (size_t i = 0; i < 1024; i++)
                worst = fmax(worst, fabs(bst_mat_get(x, i, j) - bst_mat_get(y, i, j)));
        ck_assert_msg(worst <= 1e-10 * scale, "typed vs dense: %g (scale %g)", worst, scale);
    }
    /* analytic panes in place of the ray-traced ones (the ray-traced glass is a k = 5 average) */
    bst_layer *g;
    ck_assert_int_eq(bst_glass_layer_from_spec(ctx, "t0=0.8815,r0=0.0786", NULL, b, 1,
                                               (const char *const[]){"Visible"}, &g), BST_OK);
    const bst_layer *la[3] = {g, l[1], g};
    bst_layer *sa;
    o.force_dense = 0;
    ck_assert_int_ge(bst_stack_combine(ctx, 3, la, &o, &sa), 0);
    accordance_table(sa, truth, l[1], b, "analytic panes + blind", 99.0);
    bst_layer_free(sa), bst_layer_free(g);
    for (int k = 0; k < 3; k++)
        bst_layer_free(l[k]);
    bst_layer_free(truth), bst_layer_free(sys), bst_layer_free(dense);
    bst_basis_free(b);
}
END_TEST

static Suite *system_suite(void)
{
    Suite *s = suite_create("system");
    TCase *tc = tcase_create("S1");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 300);
    tcase_add_test(tc, test_s1_raytraced);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(system_suite());
}
