/* test_system.c - the ray-traced ground truth: S1 = pane + specular blind + pane, ray traced as one
 * assembly by RADIANCE (../shared/reference/S1_t4k5.xml), against our combination of its three
 * separately ray-traced layers at k = 5: hemispherical totals, and the accordance (bsdfstack.h) of
 * the transmitted distribution at the paper's directions, incidence from both sides.
 *
 * The accordance bound is the Monte Carlo noise floor of the reference data itself: two
 * independent RADIANCE traces of the same blind (L_blind0 at k = 5, and at k = 6 averaged to k = 5)
 * agree to an accordance of 95.6 - 98.4 at these directions under bst_accordance's definition,
 * so the combination of three noisy layers is required to come within 2 points of that floor at
 * every direction.  (The GA >= 99 refers to Grobe's own GA definition, which this
 * definition does not reproduce; see the closing note.) */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static bst_layer *load(const char *name, const bst_basis *b)
{
    bst_bsdf *f;
    bst_layer *l;
    int rc = bst_bsdf_read(ctx, tu_ref(name), NULL, &f);
    ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, f, b, &l), BST_OK);
    bst_bsdf_free(f);
    return l;
}

static const double dirs[][2] = {{25, 90}, {45, 90}, {50, 90}, {45, 45}, {65, 90}};

/* The incident patch of a propagation direction (theta, phi), nudged off the cell boundaries that
 * phi = 90 (x = 0) lies on, so that both files are read in the same cell. */
static size_t incident_patch(const bst_basis *b, double th, double ph)
{
    double d[3] = {sin(th * M_PI / 180) * cos(ph * M_PI / 180) + 1e-7,
                   sin(th * M_PI / 180) * sin(ph * M_PI / 180) + 1e-7, cos(th * M_PI / 180)};
    return bst_basis_patch(b, d);
}

static double noise_floor[2][5];

static void accordance_table(const bst_layer *sys, const bst_layer *truth, const bst_basis *b,
                             const char *what, double margin)
{
    for (int side = 0; side < 2; side++)
        for (size_t k = 0; k < sizeof dirs / sizeof dirs[0]; k++) {
            size_t j = incident_patch(b, dirs[k][0], dirs[k][1]);
            double ga;
            ck_assert_int_eq(bst_accordance(ctx, sys, truth, 0, side ? BST_TB : BST_TF, j, &ga, NULL), BST_OK);
            printf("S1 %s, %s incidence (theta %g, phi %g): accordance %.2f (noise floor %.2f)\n", what,
                   side ? "back" : "front", dirs[k][0], dirs[k][1], ga, noise_floor[side][k]);
            fflush(stdout);
            ck_assert_msg(ga >= noise_floor[side][k] - margin, "%s %s (%g, %g): accordance %.2f < %.2f - %g",
                          what, side ? "back" : "front", dirs[k][0], dirs[k][1], ga,
                          noise_floor[side][k], margin);
        }
}

/* The two independent traces of the blind, k = 6 unpacked to a temporary file. */
static void measure_noise_floor(const bst_basis *b)
{
    char tmp[64];
    tu_unxz_ref("L_blind0_t4k6.xml.xz", tmp, sizeof tmp);
    bst_bsdf *f;
    bst_layer *b6, *b5 = load("L_blind0_t4k5.xml", b);
    ck_assert_int_ge(bst_bsdf_read(ctx, tmp, NULL, &f), 0);
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, f, b, &b6), BST_OK);
    bst_bsdf_free(f);
    unlink(tmp);
    for (int side = 0; side < 2; side++)
        for (size_t k = 0; k < sizeof dirs / sizeof dirs[0]; k++)
            ck_assert_int_eq(bst_accordance(ctx, b5, b6, 0, side ? BST_TB : BST_TF,
                                            incident_patch(b, dirs[k][0], dirs[k][1]),
                                            &noise_floor[side][k], NULL), BST_OK);
    bst_layer_free(b5), bst_layer_free(b6);
}

START_TEST(test_s1_raytraced)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b), BST_OK);
    measure_noise_floor(b);
    bst_layer *l[3] = {load("L_glass_t4k5.xml", b), load("L_blind0_t4k5.xml", b), load("L_glass_t4k5.xml", b)};
    bst_layer *truth = load("S1_t4k5.xml", b), *sys, *dense;
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    o.comps = BST_COMP_BIT(BST_TF) | BST_COMP_BIT(BST_TB);
    int rc = bst_stack_combine(ctx, 3, (const bst_layer *const *)l, &o, &sys);
    ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    accordance_table(sys, truth, b, "combined layers", 2.0);
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
    accordance_table(sa, truth, b, "analytic panes + blind", 3.0);
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
