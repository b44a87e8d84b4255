/* test_glass.c - analytic glass against Windows-CalcEngine's uncoated-glass model and closed forms;
 * its diagonal layer; multi-pane stacks against the multi-pane formulas. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static bst_glass *parse(const char *spec)
{
    bst_glass *g;
    int rc = bst_glass_parse(ctx, spec, getenv("BSDFSTACK_GLASS_DIR"), &g);
    ck_assert_msg(rc == BST_OK, "%s: %s", spec, bst_ctx_message(ctx));
    return g;
}

/* WCE's CAngularPropertiesUncoated, tabulated (tolerance 1e-6 as WCE's own test). */
START_TEST(test_wce_mono)
{
    FILE *fp = fopen(tu_ref("wce/glass/glass_mono_fresnel_wce.tsv"), "r");
    ck_assert_ptr_nonnull(fp);
    char line[512];
    int rows = 0;
    while (fgets(line, sizeof line, fp)) {
        double t0, r0, a, tw, rw;
        if (line[0] == '#' || sscanf(line, "%lf %lf %lf %lf %lf", &t0, &r0, &a, &tw, &rw) != 5)
            continue;
        char spec[128];
        snprintf(spec, sizeof spec, "t0=%.17g,r0=%.17g", t0, r0);
        bst_glass *g = parse(spec);
        double t, rf, rb;
        ck_assert_int_eq(bst_glass_optics(g, 0, a * M_PI / 180, &t, NULL, &rf, &rb), BST_OK);
        ck_assert_msg(fabs(t - tw) <= 1e-6 && fabs(rf - rw) <= 1e-6 && rf == rb,
                      "T0 %g R0 %g at %g deg: T %.9f R %.9f vs WCE %.9f %.9f", t0, r0, a, t, rf, tw, rw);
        bst_glass_free(g);
        rows++;
    }
    fclose(fp);
    ck_assert_int_ge(rows, 50);
}
END_TEST

/* Closed forms: a non-absorbing pane of index n has R(0) = 2 rho / (1 + rho) with the interface's
 * rho = ((n-1)/(n+1))^2 and T + R = 1 at every angle; an absorbing one T + R < 1; 90 deg gives
 * T = 0, R = 1; 89.99 deg is finite. */
START_TEST(test_closed_forms)
{
    double n = 1.52, rho = pow((n - 1) / (n + 1), 2), tmax = (1 - rho) / (1 + rho);
    char spec[128];
    snprintf(spec, sizeof spec, "d=6mm,n=%g,tn=%.17g", n, tmax);
    bst_glass *g = parse(spec), *a = parse("d=6mm,n=1.52,tn=0.80");
    for (double deg = 0; deg <= 90.0; deg += 0.5) {
        double t, rf, rb, ta, ra, rba;
        double th = (deg == 90.0 ? 89.99 : deg) * M_PI / 180;
        ck_assert_int_eq(bst_glass_optics(g, 0, th, &t, NULL, &rf, &rb), BST_OK);
        ck_assert_int_eq(bst_glass_optics(a, 1, th, &ta, NULL, &ra, &rba), BST_OK);
        ck_assert(isfinite(t) && isfinite(rf) && isfinite(ta) && isfinite(ra));
        tu_assert_close(t + rf, 1.0, 1e-9, 1.0);
        ck_assert_double_eq(rf, rb);
        ck_assert(ta + ra < 1.0 && ta >= 0 && ra > 0);
        if (deg == 0) {
            tu_assert_close(rf, 2 * rho / (1 + rho), 1e-12, 0.0);
            tu_assert_close(ta, 0.80, 1e-12, 0.0);
        }
    }
    double t, rf, rb;
    ck_assert_int_eq(bst_glass_optics(a, 0, M_PI / 2, &t, NULL, &rf, &rb), BST_OK);
    ck_assert_double_eq(t, 0.0);
    ck_assert_double_eq(rf, 1.0);
    bst_glass_free(g), bst_glass_free(a);
}
END_TEST

/* NFRC 102/103 from their spectral data against WCE's angular results, solar and visible, every
 * angle and side: 1e-6 (the same per-wavelength model and the same integration). */
START_TEST(test_nfrc_band_model)
{
    FILE *fp = fopen(tu_ref("wce/glass/glass_angular_averaged_wce.tsv"), "r");
    ck_assert_ptr_nonnull(fp);
    bst_glass *g102 = parse("nfrc-102"), *g103 = parse("nfrc-103");
    char line[512], pane[32], band[32];
    double worst = 0;
    int rows = 0;
    while (fgets(line, sizeof line, fp)) {
        double a, tf, tb, rf, rb;
        if (line[0] == '#' || sscanf(line, "%31s %31s %lf %lf %lf %lf %lf", pane, band, &a, &tf, &tb, &rf, &rb) != 7)
            continue;
        bst_glass *g = strcmp(pane, "NFRC_102") == 0 ? g102 : g103;
        size_t ch = strcmp(band, "visible") == 0 ? 0 : 1;
        ck_assert_str_eq(bst_glass_channel(g, ch), ch ? "Solar" : "Visible");
        double t, t2, f, b;
        ck_assert_int_eq(bst_glass_optics(g, ch, a * M_PI / 180, &t, &t2, &f, &b), BST_OK);
        double d = fmax(fmax(fabs(t - tf), fabs(t2 - tb)), fmax(fabs(f - rf), fabs(b - rb)));
        ck_assert_msg(d <= 1e-6, "%s %s %g deg: T %.5f Rf %.5f Rb %.5f vs WCE %.5f %.5f %.5f", pane, band, a, t, f, b, tf, rf, rb);
        worst = fmax(worst, d);
        rows++;
    }
    fclose(fp);
    ck_assert_int_gt(rows, 300);
    printf("NFRC 102/103 vs WCE: largest difference %.2e over %d rows\n", worst, rows);
    bst_glass_free(g102), bst_glass_free(g103);
}
END_TEST


/* WCE's Klems full-basis glass layer: diagonal M(i,i) = P(theta_c(i)) / Lambda_i with the patch
 * centre's angle (bst_glass_layer with at_centre = 1), every patch, both panes and bands: 1e-6
 * relative. */
START_TEST(test_wce_klems_diagonal)
{
    FILE *fp = fopen(tu_ref("wce/glass/glass_klems_full_diag_wce.tsv"), "r");
    ck_assert_ptr_nonnull(fp);
    bst_glass *g[2] = {parse("nfrc-102"), parse("nfrc-103")};
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &b), BST_OK);
    bst_layer *l[2];
    for (int p = 0; p < 2; p++)
        ck_assert_int_eq(bst_glass_layer(ctx, g[p], b, 0, NULL, 1, &l[p]), BST_OK);
    char line[512], pane[32], band[32];
    int rows = 0;
    while (fgets(line, sizeof line, fp)) {
        int idx;
        double tc, pc, lam, want[4];
        if (line[0] == '#' || sscanf(line, "%31s %31s %d %lf %lf %lf %lf %lf %lf %lf", pane, band, &idx,
                                     &tc, &pc, &lam, &want[0], &want[1], &want[2], &want[3]) != 10)
            continue;
        const bst_layer *ll = l[strcmp(pane, "NFRC_102") == 0 ? 0 : 1];
        int ch = bst_layer_find_channel(ll, strcmp(band, "solar") == 0 ? "Solar" : "Visible");
        ck_assert_int_ge(ch, 0);
        static const bst_comp comps[4] = {BST_TF, BST_TB, BST_RF, BST_RB};
        for (int c = 0; c < 4; c++) {
            double got = bst_mat_get(bst_layer_get(ll, (size_t)ch, comps[c]), (size_t)idx - 1, (size_t)idx - 1);
            ck_assert_msg(fabs(got - want[c]) <= 1e-6 * want[c], "%s %s patch %d %s: %.9g vs WCE %.9g",
                          pane, band, idx, bst_comp_name(comps[c]), got, want[c]);
        }
        rows++;
    }
    fclose(fp);
    ck_assert_int_eq(rows, 4 * 145);
    for (int p = 0; p < 2; p++)
        bst_layer_free(l[p]), bst_glass_free(g[p]);
    bst_basis_free(b);
}
END_TEST

/* The layer: four diagonals (O(N) even at k = 7), patch value x Lambda = the patch-averaged T. */
START_TEST(test_layer)
{
    bst_glass *g = parse("clear-6mm");
    for (int k = 3; k <= 7; k += 4) {
        bst_basis *b;
        bst_layer *l;
        ck_assert_int_eq(bst_basis_new_sc(ctx, k, &b), BST_OK);
        ck_assert_int_eq(bst_glass_layer(ctx, g, b, 0, NULL, 0, &l), BST_OK);
        size_t n = bst_basis_size(b);
        ck_assert_uint_eq(bst_layer_nchannels(l), 2);
        for (int c = 0; c < BST_NCOMP; c++) {
            ck_assert_int_eq(bst_mat_structure(bst_layer_get(l, 0, (bst_comp)c)), BST_DIAG);
            ck_assert_uint_eq(bst_mat_nnz(bst_layer_get(l, 0, (bst_comp)c)), n);
        }
        double *h = malloc(n * sizeof *h);
        ck_assert_int_eq(bst_layer_hemispherical(ctx, l, 0, BST_TF, h), BST_OK);
        double t, rf, rb;
        bst_glass_optics(g, 0, 0.0, &t, NULL, &rf, &rb);
        /* the central patches hold T at near-normal incidence */
        ck_assert_double_lt(fabs(h[n / 2 + (size_t)(1 << k) / 2] - t), k == 3 ? 1e-3 : 2e-5);
        for (size_t j = 0; j < n; j++)
            ck_assert(h[j] >= 0 && h[j] <= t + 1e-12);
        free(h);
        bst_layer_free(l);
        bst_basis_free(b);
    }
    bst_glass_free(g);
}
END_TEST

/* Two and three analytic panes combined by the matrix formalism equal the multi-pane closed forms
 * at every patch, with the patch values as the per-pane T and R (1e-12 relative). */
START_TEST(test_panes_by_stack)
{
    bst_glass *g[3] = {parse("clear-6mm"), parse("lowiron-6mm"), parse("t0=0.7,r0=0.08,r0b=0.12")};
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &b), BST_OK);
    bst_layer *l[3], *sys;
    const char *vis[] = {"Visible"};
    for (int p = 0; p < 3; p++)
        ck_assert_int_eq(bst_glass_layer(ctx, g[p], b, 1, vis, 1, &l[p]), BST_OK);
    ck_assert_int_eq(bst_stack_combine(ctx, 3, (const bst_layer *const *)l, NULL, &sys), BST_OK);
    const double *lam = bst_basis_lambda(b);
    for (size_t j = 0; j < bst_basis_size(b); j++) {
        double t[3], tb[3], rf[3], rb[3];
        for (int p = 0; p < 3; p++) {
            t[p] = bst_mat_get(bst_layer_get(l[p], 0, BST_TF), j, j) * lam[j];
            tb[p] = bst_mat_get(bst_layer_get(l[p], 0, BST_TB), j, j) * lam[j];
            rf[p] = bst_mat_get(bst_layer_get(l[p], 0, BST_RF), j, j) * lam[j];
            rb[p] = bst_mat_get(bst_layer_get(l[p], 0, BST_RB), j, j) * lam[j];
        }
        /* T = tf1 tf2 / d, Tb = tb1 tb2 / d, Rf = rf1 + tf1 tb1 rf2 / d, Rb = rb2 + tf2 tb2 rb1 / d */
        double d = 1 - rb[0] * rf[1], t12 = t[0] * t[1] / d, tb12 = tb[0] * tb[1] / d;
        double rf12 = rf[0] + t[0] * tb[0] * rf[1] / d, rb12 = rb[1] + t[1] * tb[1] * rb[0] / d;
        double e = 1 - rb12 * rf[2];
        tu_assert_close(bst_mat_get(bst_layer_get(sys, 0, BST_TF), j, j) * lam[j], t12 * t[2] / e, 1e-12, 0);
        tu_assert_close(bst_mat_get(bst_layer_get(sys, 0, BST_TB), j, j) * lam[j], tb12 * tb[2] / e, 1e-12, 0);
        tu_assert_close(bst_mat_get(bst_layer_get(sys, 0, BST_RF), j, j) * lam[j], rf12 + t12 * tb12 * rf[2] / e, 1e-12, 0);
        tu_assert_close(bst_mat_get(bst_layer_get(sys, 0, BST_RB), j, j) * lam[j], rb[2] + t[2] * tb[2] * rb12 / e, 1e-12, 0);
    }
    for (int p = 0; p < 3; p++)
        bst_layer_free(l[p]), bst_glass_free(g[p]);
    bst_layer_free(sys);
    bst_basis_free(b);
}
END_TEST

START_TEST(test_bad_specs)
{
    static const struct { const char *spec, *expect; } bad[] = {
        {"no-such-pane", "no such pane"},
        {"d=6mm,n=1.52", "needs tn"},
        {"d=6mm,n=nan,tn=0.8", "n=nan"},
        {"d=-1mm,n=1.5,tn=0.8", "d=-1mm"},
        {"d=6mm,n=1.52,tn=0.95", "exceeds"},
        {"t0=0.9,r0=0.2", "exceeds 1"},
        {"d=6mm,colour=blue", "unknown glass parameter"},
        {"d=6mm,n", "not key=value"},
        {"../etc/passwd", "cannot open"},
        {"bad name!", "letters, digits"},
        {"", "empty"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        bst_glass *g = (bst_glass *)1;
        int rc = bst_glass_parse(ctx, bad[i].spec, getenv("BSDFSTACK_GLASS_DIR"), &g);
        ck_assert_msg(rc < 0, "'%s' accepted", bad[i].spec);
        ck_assert_ptr_null(g);
        ck_assert_msg(strstr(bst_ctx_message(ctx), bad[i].expect), "'%s': %s", bad[i].spec, bst_ctx_message(ctx));
    }
}
END_TEST

static Suite *glass_suite(void)
{
    Suite *s = suite_create("glass");
    TCase *tc = tcase_create("glass");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 60);
    tcase_add_test(tc, test_wce_mono);
    tcase_add_test(tc, test_closed_forms);
    tcase_add_test(tc, test_nfrc_band_model);
    tcase_add_test(tc, test_wce_klems_diagonal);
    tcase_add_test(tc, test_layer);
    tcase_add_test(tc, test_panes_by_stack);
    tcase_add_test(tc, test_bad_specs);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(glass_suite());
}
