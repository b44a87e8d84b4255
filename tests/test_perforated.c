/* test_perforated.c - perforated screens and woven fabrics from their geometry (bst_perforated,
 * bst_woven, issue #32) against closed forms.  Screens: a sheet of zero thickness passes its open area at every angle; a thick one with
 * circular holes the lens of the hole's two ends (checked at normal incidence, pi a^2 / (x y), and
 * at an angle against a direct evaluation); lossless sheets conserve energy; the layer is
 * reciprocal; bad specs name their key.  Fabrics: the openness (1 - d / s)^2 at the normal and
 * the product of the two thread sets' shadows off it; energy and reciprocity. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static bst_layer *screen(const char *spec, const bst_basis *b)
{
    bst_perforated p;
    ck_assert_msg(bst_perforated_parse(ctx, spec, &p) == BST_OK, "%s: %s", spec, bst_ctx_message(ctx));
    bst_layer *l = NULL;
    ck_assert_msg(bst_perforated_layer(ctx, &p, b, 0, NULL, &l) == BST_OK, "%s: %s", spec,
                  bst_ctx_message(ctx));
    return l;
}

static double *hemi(const bst_layer *l, bst_comp c)
{
    size_t n = bst_basis_size(bst_layer_basis(l));
    double *h = malloc(n * sizeof *h);
    ck_assert_ptr_nonnull(h);
    ck_assert_int_eq(bst_layer_hemispherical(ctx, l, 0, c, h), BST_OK);
    return h;
}

/* Zero thickness: the open area at every patch, direct (diagonal) light only. */
START_TEST(test_open_area)
{
    static const char *const specs[] = {"x=5mm,y=4mm,radius=1.5mm,thickness=0",
                                        "x=5mm,y=4mm,hole-x=2mm,hole-y=3mm"};
    const double area[] = {M_PI * 1.5 * 1.5 / 20, 6.0 / 20};
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &b), BST_OK);
    bst_layer *l = screen(specs[_i], b);
    double *tf = hemi(l, BST_TF), *tb = hemi(l, BST_TB), *rf = hemi(l, BST_RF);
    for (size_t i = 0; i < bst_basis_size(b); i++) {
        ck_assert_msg(fabs(tf[i] - area[_i]) < 1e-14 && fabs(tb[i] - area[_i]) < 1e-14,
                      "%s patch %zu: T %.15g, open area %.15g", specs[_i], i, tf[i], area[_i]);
        ck_assert(rf[i] == 0.0);
    }
    ck_assert_int_eq(bst_mat_structure(bst_layer_get(l, 0, BST_TF)), BST_DIAG);
    free(tf), free(tb), free(rf);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* Thick circular holes: at the normal the open area, away from it the lens of two circles of
 * radius a whose centres lie d tan(theta) apart; black beyond tan(theta) = 2 a / d. */
START_TEST(test_thick_holes)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b), BST_OK);
    bst_perforated p;
    ck_assert_int_eq(bst_perforated_parse(ctx, "x=4mm,y=4mm,radius=1mm,thickness=1mm,samples=1", &p),
                     BST_OK);
    bst_layer *l = NULL;
    ck_assert_int_eq(bst_perforated_layer(ctx, &p, b, 0, NULL, &l), BST_OK);
    double *tf = hemi(l, BST_TF);
    /* with one direction a patch (the Halton set's first point, (1/2, 1/3)) the value is exact:
     * the mean of that direction's share in the patch and in its antipode */
    for (size_t i = 0; i < bst_basis_size(b); i++) {
        double lens[2];
        for (int k = 0; k < 2; k++) {
            double d[3];
            bst_basis_sample(b, k ? bst_basis_antipode(b, i) : i, 0.5, 1.0 / 3, d);
            double dd = 1.0 * hypot(d[0], d[1]) / d[2], a = 1.0; /* mm */
            lens[k] = dd >= 2 * a ? 0 : 2 * a * a * acos(dd / (2 * a)) - dd / 2 * sqrt(4 * a * a - dd * dd);
        }
        double want = (lens[0] + lens[1]) / 2 / 16;
        ck_assert_msg(fabs(tf[i] - want) < 1e-13, "patch %zu: %.15g vs lens %.15g", i, tf[i], want);
    }
    free(tf);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* Lossless sheets (r + t = 1): T + R = 1 for every patch and side; reciprocity. */
START_TEST(test_energy_reciprocity)
{
    static const char *const specs[] = {"x=5mm,y=5mm,radius=2mm,thickness=2mm,rf=0.6,rb=0.3,t=0.4",
                                        "x=5mm,y=3mm,hole-x=2mm,hole-y=1mm,thickness=1mm,r=0.2,t=0.8"};
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &b), BST_OK);
    bst_layer *l = screen(specs[_i], b);
    double *tf = hemi(l, BST_TF), *rf = hemi(l, BST_RF), *tb = hemi(l, BST_TB), *rb = hemi(l, BST_RB);
    double worst = 0;
    for (size_t i = 0; i < bst_basis_size(b); i++) {
        /* rb = 0.3 < 1 - t for the first: the back loses 0.3 of what meets the sheet */
        worst = fmax(worst, fabs(tf[i] + rf[i] - 1));
        if (_i)
            worst = fmax(worst, fabs(tb[i] + rb[i] - 1));
    }
    printf("%s: |T + R - 1| at most %.3g\n", specs[_i], worst);
    ck_assert_msg(worst < 1e-12, "%s: energy off by %g", specs[_i], worst);
    double err;
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, l, 0, &err, NULL, NULL), BST_OK);
    ck_assert_msg(err < 1e-12, "%s: reciprocity %g", specs[_i], err);
    free(tf), free(rf), free(tb), free(rb);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

START_TEST(test_bad_specs)
{
    static const char *const bad[][2] = {
        {"x=0,y=5mm,radius=1mm", "x"},
        {"x=5mm,y=-1mm,radius=1mm", "y"},
        {"x=5mm,radius=1mm", "y"},
        {"x=5mm,y=5mm,radius=3mm", "radius"},
        {"x=5mm,y=5mm", "radius"},
        {"x=5mm,y=5mm,hole-x=6mm,hole-y=1mm", "hole-x"},
        {"x=5mm,y=5mm,radius=1mm,r=1.2", "r"},
        {"x=5mm,y=5mm,radius=1mm,rf=0.6,t=0.5", "rf"},
        {"x=5mm,y=5mm,radius=1mm,thickness=-1mm", "thickness"},
        {"x=5mm,y=5mm,radius=1mm,holes=7", "holes"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        bst_perforated p;
        ck_assert_msg(bst_perforated_parse(ctx, bad[k][0], &p) < 0, "%s accepted", bad[k][0]);
        ck_assert_msg(strstr(bst_ctx_message(ctx), bad[k][1]) != NULL, "%s: '%s' does not name %s",
                      bad[k][0], bst_ctx_message(ctx), bad[k][1]);
    }
}
END_TEST

/* Woven: with one direction a patch (the Halton point (1/2, 1/3)) the patch's value is the closed
 * form's mean over that direction in the patch and in its antipode; lossless threads conserve
 * energy, the layer is reciprocal; bad specs name their key. */
static double woven_open(const double d[3], double ratio)
{
    double cx = d[2] / hypot(d[0], d[2]), cy = d[2] / hypot(d[1], d[2]);
    return fmax(0.0, 1 - ratio / cx) * fmax(0.0, 1 - ratio / cy);
}

START_TEST(test_woven)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &b), BST_OK);
    bst_woven w;
    ck_assert_int_eq(bst_woven_parse(ctx, "diameter=0.5mm,spacing=2mm,samples=1", &w), BST_OK);
    bst_layer *l = NULL;
    ck_assert_int_eq(bst_woven_layer(ctx, &w, b, 0, NULL, &l), BST_OK);
    double *tf = hemi(l, BST_TF);
    for (size_t i = 0; i < bst_basis_size(b); i++) {
        double d0[3], d1[3];
        bst_basis_sample(b, i, 0.5, 1.0 / 3, d0);
        bst_basis_sample(b, bst_basis_antipode(b, i), 0.5, 1.0 / 3, d1);
        double want = (woven_open(d0, 0.25) + woven_open(d1, 0.25)) / 2;
        ck_assert_msg(fabs(tf[i] - want) < 1e-14, "patch %zu: %.15g vs %.15g", i, tf[i], want);
    }
    double n[3] = {0, 0, 1};
    ck_assert(fabs(woven_open(n, 0.25) - 0.5625) < 1e-15); /* (1 - d/s)^2 */
    free(tf);
    bst_layer_free(l);
    bst_layer *ll = NULL;
    ck_assert_int_eq(bst_woven_parse(ctx, "diameter=0.3mm,spacing=1mm,r=0.7,t=0.3", &w), BST_OK);
    ck_assert_int_eq(bst_woven_layer(ctx, &w, b, 0, NULL, &ll), BST_OK);
    double *t2 = hemi(ll, BST_TF), *r2 = hemi(ll, BST_RF), worst = 0, err;
    for (size_t i = 0; i < bst_basis_size(b); i++)
        worst = fmax(worst, fabs(t2[i] + r2[i] - 1));
    ck_assert_msg(worst < 1e-12, "lossless fabric: %g", worst);
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, ll, 0, &err, NULL, NULL), BST_OK);
    ck_assert_msg(err < 1e-12, "reciprocity %g", err);
    free(t2), free(r2);
    bst_layer_free(ll);
    static const char *const bad[][2] = {{"diameter=3mm,spacing=2mm", "diameter"},
                                         {"diameter=1mm,spacing=0", "spacing"},
                                         {"diameter=1mm,spacing=2mm,r=0.8,t=0.3", "r + t"},
                                         {"diameter=1mm,spacing=2mm,colour=3", "colour"}};
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        ck_assert_msg(bst_woven_parse(ctx, bad[k][0], &w) < 0, "%s accepted", bad[k][0]);
        ck_assert_msg(strstr(bst_ctx_message(ctx), bad[k][1]) != NULL, "%s: '%s'", bad[k][0],
                      bst_ctx_message(ctx));
    }
    bst_basis_free(b);
}
END_TEST

static Suite *perforated_suite(void)
{
    Suite *s = suite_create("perforated");
    TCase *tc = tcase_create("perforated");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 300);
    tcase_add_loop_test(tc, test_open_area, 0, 2);
    tcase_add_test(tc, test_thick_holes);
    tcase_add_loop_test(tc, test_energy_reciprocity, 0, 2);
    tcase_add_test(tc, test_bad_specs);
    tcase_add_test(tc, test_woven);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(perforated_suite());
}
