/* test_glass_coated.c - WINDOW's angular model of coated glass (glass_coated.c) and how a pane
 * gets its model.
 *  - closed forms of the correlations: the measured values at normal incidence, the quartics'
 *    sums just off it, their values at cos(theta) = 1/2, 90 degrees (clear: T = 0, R = 1; bronze:
 *    T = 0, R = 0.999 + 0.001 R0), the clear/bronze switch at T0 = 0.645, T + R <= 1;
 *  - Windows-CalcEngine's coated results: its CAngularPropertiesCoated for two (T0, R0) pairs
 *    (../shared/reference/wce/glass/glass_mono_coated_wce.tsv) and for NFRC 1042's (the values its
 *    test AngularPropertiesCoated.unit.cpp, Test2, asserts, WCE commit bdbfd84e), and NFRC 1042
 *    as a coated spectral pane (tests/data/nfrc_1042_wce.tsv): the solar band at 70 degrees
 *    (SampleNFRC_1042_Angular.unit.cpp) and flipped in front of NFRC 103, per wavelength
 *    (MultiPaneSpecular_1042_103_FirstLayerFlipped.unit.cpp), to WCE's tolerance 1e-6;
 *  - the model from the spec (model=), the catalogue and the type; the uncoated model unchanged
 *    to the bit after a round trip through the coated one. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "glass.h"
#include "testglass.h"
#include "testutil.h"

/* WCE's own tests compare with 1e-6 absolute. */
#define WCE_TOL 1e-6
/* The reference table prints 12 significant digits; the polynomials are evaluated in another
 * order (Horner here, powers in WCE): a few units in the last place of 1. */
#define TABLE_TOL 1e-11
/* Closed forms: rounding of a quartic (a few units of DBL_EPSILON). */
#define CLOSED_TOL (16 * DBL_EPSILON)

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static bst_glass *parse(const char *spec) { return tg_parse(ctx, spec); }

static double deg(double d) { return d * M_PI / 180; }

/* A coated side of (t0, r0). */
static struct bsti_glass_side coated(double t0, double r0)
{
    struct bsti_glass_side s;
    ck_assert_int_eq(bsti_glass_side_model(&s, t0, r0, BST_GLASS_COATED), 0);
    return s;
}

/* ------------------------------------------------------------------ closed forms */

/* Sums of the published coefficients (WCE CoatingCoefficients): tau(1), rho_t(1) and the values
 * at c = 1/2, clear [0] and bronze [1]. */
static const double tau_1[2] = {1.0023, 1.01175}, rho_1[2] = {1.001, 1.005};
static const double tau_half[2] = {0.9003, 0.84953125}, rho_half[2] = {0.977625, 0.9100625};

START_TEST(test_quartics)
{
    for (int b = 0; b < 2; b++) {
        double tau, rho;
        bsti_glass_coated_poly(b, 1.0, &tau, &rho);
        tu_assert_close(tau, tau_1[b], CLOSED_TOL, 1);
        tu_assert_close(rho, rho_1[b], CLOSED_TOL, 1);
        bsti_glass_coated_poly(b, 0.5, &tau, &rho);
        tu_assert_close(tau, tau_half[b], CLOSED_TOL, 1);
        tu_assert_close(rho, rho_half[b], CLOSED_TOL, 1);
    }
}
END_TEST

/* Normal incidence gives the data (the model's special case at theta = 0, as WINDOW); just off it
 * the quartics' sums: T = T0 tau(1), R = R0 + (rho_t(1) - tau(1)) (1 - R0). */
START_TEST(test_normal_incidence)
{
    static const double pane[2][2] = {{0.8, 0.07}, {0.4, 0.3}}; /* clear, bronze */
    for (int b = 0; b < 2; b++) {
        double t0 = pane[b][0], r0 = pane[b][1], t, r;
        struct bsti_glass_side s = coated(t0, r0);
        bsti_glass_side_optics(&s, 0.0, &t, &r);
        ck_assert(t == t0 && r == r0);
        bsti_glass_side_optics(&s, 1e-7, &t, &r); /* cos = 1 - 5e-15 */
        tu_assert_close(t, t0 * tau_1[b], 1e-13, 1);
        tu_assert_close(r, r0 + (rho_1[b] - tau_1[b]) * (1 - r0), 1e-13, 1);
    }
    /* a pane at normal incidence through the public call: each side's own data */
    bst_glass *g = parse("t0=0.8,r0=0.07,r0b=0.05,model=coated");
    double tf, tb, rf, rb;
    ck_assert_int_eq(bst_glass_optics(g, 0, 0.0, &tf, &tb, &rf, &rb), BST_OK);
    ck_assert(tf == 0.8 && tb == 0.8 && rf == 0.07 && rb == 0.05);
    ck_assert_int_eq(bst_glass_optics(g, 0, deg(60), &tf, &tb, &rf, &rb), BST_OK);
    double rho = rho_half[0] - tau_half[0];
    tu_assert_close(tf, 0.8 * tau_half[0], 1e-14, 1);
    tu_assert_close(rf, 0.07 + rho * (1 - 0.07), 1e-14, 1);
    tu_assert_close(rb, 0.05 + rho * (1 - 0.05), 1e-14, 1);
    bst_glass_free(g);
}
END_TEST

/* 90 degrees: tau(0) = a_0 < 0 clips T to 0; R = R0 + (b_0 - a_0)(1 - R0), which the clear
 * glass's 1.0005 clips to 1 and the bronze glass's 0.999 leaves at 0.999 + 0.001 R0. */
START_TEST(test_grazing)
{
    for (double r0 = 0.0; r0 < 0.95; r0 += 0.1) {
        double t, r;
        struct bsti_glass_side c = coated(0.9 - r0 * 0.2, r0), b = coated(0.3, r0 * 0.7);
        bsti_glass_side_optics(&c, M_PI / 2, &t, &r);
        ck_assert(t == 0.0 && r == 1.0);
        bsti_glass_side_optics(&b, M_PI / 2, &t, &r);
        ck_assert(t == 0.0);
        tu_assert_close(r, 0.999 + 0.001 * (r0 * 0.7), CLOSED_TOL, 1);
    }
}
END_TEST

/* The switch: T0 > 0.645 takes the clear glass's quartics, T0 = 0.645 the bronze one's. */
START_TEST(test_switch)
{
    double t, r, at = BST_GLASS_COATED_CLEAR_T0;
    ck_assert(at == 0.645);
    bsti_glass_coated_optics(at, 0.1, 0.5, &t, &r);
    tu_assert_close(t, at * tau_half[1], CLOSED_TOL, 1);
    double above = nextafter(at, 1.0);
    bsti_glass_coated_optics(above, 0.1, 0.5, &t, &r);
    tu_assert_close(t, above * tau_half[0], CLOSED_TOL, 1);
    tu_assert_close(r, 0.1 + (rho_half[0] - tau_half[0]) * 0.9, CLOSED_TOL, 1);
}
END_TEST

/* T and R stay in [0, 1] with T + R <= 1 for any pane and angle (seeded), including those whose
 * clipping the model needs: T0 = 1 (tau(1) > 1), R0 = 0 (rho < 0 near the normal). */
START_TEST(test_bounds)
{
    tu_rng rng;
    tu_rng_seed(&rng, 33);
    for (int i = 0; i < 2000; i++) {
        double t0 = tu_rng_uniform(&rng), r0 = (1 - t0) * tu_rng_uniform(&rng);
        if (i == 0)
            t0 = 1, r0 = 0;
        if (i == 1)
            t0 = 0.5, r0 = 0;
        for (int a = 0; a <= 900; a += 7) {
            double t, r;
            bsti_glass_coated_optics(t0, r0, cos(deg(a / 10.0)), &t, &r);
            ck_assert_msg(t >= 0 && r >= 0 && t <= 1 && r <= 1 && t + r <= 1 + DBL_EPSILON,
                          "T0 %g R0 %g at %g deg: T %g R %g", t0, r0, a / 10.0, t, r);
        }
    }
    double t, r;
    bsti_glass_coated_optics(1.0, 0.0, 1.0, &t, &r);
    ck_assert(t == 1.0 && r == 0.0);
}
END_TEST

/* ------------------------------------------------------------------ Windows-CalcEngine */

/* CAngularPropertiesCoated at 0..90 degrees for (0.722, 0.066) and (0.5, 0.3): the correlation
 * itself at every angle (WCE's class has no case for theta = 0; its angular spectral sample
 * uses the measured data there, and so does a side). */
START_TEST(test_wce_table)
{
    FILE *fp = fopen(tu_ref("wce/glass/glass_mono_coated_wce.tsv"), "r");
    ck_assert_ptr_nonnull(fp);
    char line[256];
    int rows = 0;
    while (fgets(line, sizeof line, fp)) {
        double t0, r0, a, tw, rw, t, r;
        if (line[0] == '#' || sscanf(line, "%lf %lf %lf %lf %lf", &t0, &r0, &a, &tw, &rw) != 5)
            continue;
        bsti_glass_coated_optics(t0, r0, a == 90 ? 0.0 : cos(deg(a)), &t, &r);
        ck_assert_msg(fabs(t - tw) <= TABLE_TOL && fabs(r - rw) <= TABLE_TOL,
                      "T0 %g R0 %g at %g deg: %.12g %.12g vs WCE %.12g %.12g", t0, r0, a, t, r, tw, rw);
        struct bsti_glass_side s = coated(t0, r0);
        bsti_glass_side_optics(&s, deg(a), &t, &r);
        if (a == 0)
            ck_assert(t == t0 && r == r0);
        else
            ck_assert(fabs(t - tw) <= TABLE_TOL && fabs(r - rw) <= TABLE_TOL);
        rows++;
    }
    fclose(fp);
    ck_assert_int_eq(rows, 20);
}
END_TEST

/* WCE AngularPropertiesCoated.unit.cpp, Test2 ("NFRC Sample ID=1042"): T0 = 0.4517085,
 * R0 = 0.3592343 (bronze), theta = 0, 10, ..., 80 degrees. */
START_TEST(test_wce_1042_values)
{
    static const double want[9][2] = {
        {0.457016074875, 0.354909131525},           {0.45468722065434630, 0.35394347494903849},
        {0.44888678437700730, 0.35282710650693727}, {0.44183053629536256, 0.35502207112203277},
        {0.43348892234243364, 0.36223764779145762}, {0.41826848334431255, 0.37451467264543725},
        {0.38374048664062504, 0.39802064877812487}, {0.31265626242160510, 0.46009099882567134},
        {0.18796828616155317, 0.62493075431787948},
    };
    for (int i = 0; i < 9; i++) {
        double t, r;
        bsti_glass_coated_optics(0.4517085, 0.3592343, cos(deg(10.0 * i)), &t, &r);
        tu_assert_close(t, want[i][0], 1e-13, 1);
        tu_assert_close(r, want[i][1], 1e-13, 1);
    }
}
END_TEST

/* NFRC 1042 (WCE's test data) as a coated spectral pane. */
static bst_glass *pane_1042(void)
{
    char spec[1200];
    snprintf(spec, sizeof spec, "%s,model=coated", tu_src("tests/data/nfrc_1042_wce.tsv"));
    bst_glass *g = parse(spec);
    ck_assert_uint_eq(bst_glass_nwavelengths(g), 496);
    ck_assert_int_eq(bst_glass_get_model(g), BST_GLASS_COATED);
    return g;
}

/* SampleNFRC_1042_Angular.unit.cpp: solar band, 70 degrees, T, Rf, Rb and the front
 * absorptance (the pane's own data grid, as WCE's single sample). */
START_TEST(test_wce_1042_angular)
{
    bst_glass *g = pane_1042();
    double tf, tb, rf, rb;
    ck_assert_int_eq(bst_glass_optics(g, (size_t)bst_glass_find_channel(g, "Solar"), deg(70), &tf,
                                      &tb, &rf, &rb), BST_OK);
    tu_assert_close(tf, 0.327258, WCE_TOL, 1);
    tu_assert_close(rf, 0.471995, WCE_TOL, 1);
    tu_assert_close(rb, 0.504595, WCE_TOL, 1);
    tu_assert_close(1 - tf - rf, 0.200746, WCE_TOL, 1);
    printf("NFRC 1042 coated, solar at 70 deg: T %.7f Rf %.7f Rb %.7f (WCE 0.327258 0.471995 "
           "0.504595)\n", tf, rf, rb);
    bst_glass_free(g);
}
END_TEST

/* Two panes per wavelength on wl[0..n-1] (WCE's specular multi-pane: one T per pane), pane 1
 * flipped: q = T, Rf, Rb, A1, A2 for front incidence at theta. */
static void two_panes(const bst_glass *g1, const bst_glass *g2, const double *w, const double *wl,
                      size_t n, double theta, double q[5])
{
    for (int i = 0; i < 5; i++)
        q[i] = 0;
    for (size_t k = 0; k < n; k++) {
        double t1, rf1, rb1, t2, rf2, rb2;
        /* flipped: the exterior side is the pane's back */
        ck_assert_int_eq(bst_glass_optics_spectral(g1, wl[k], theta, NULL, &t1, &rb1, &rf1), BST_OK);
        ck_assert_int_eq(bst_glass_optics_spectral(g2, wl[k], theta, &t2, NULL, &rf2, &rb2), BST_OK);
        /* at 90 degrees two mirrors may face each other (d = 0), and nothing is transmitted */
        double d = 1 - rb1 * rf2, id = d > 0 ? 1 / d : 0, x = t1 * id;
        double v[5] = {t1 * t2 * id, rf1 + t1 * t1 * rf2 * id, rb2 + t2 * t2 * rb1 * id,
                       (1 - t1 - rf1) + x * rf2 * (1 - t1 - rb1), x * (1 - t2 - rf2)};
        for (int i = 0; i < 5; i++)
            q[i] += w[k] * v[i];
    }
}

/* MultiPaneSpecular_1042_103_FirstLayerFlipped.unit.cpp: NFRC 1042 (coated, flipped) in front of
 * NFRC 103 (uncoated), solar, on the ASTM E891 wavelengths (the test's common wavelengths),
 * at 0 and 40 degrees, and the hemispherical values. */
START_TEST(test_wce_1042_103_flipped)
{
    bst_glass *g1 = pane_1042(), *g2 = parse("nfrc-103");
    size_t ch = (size_t)bst_glass_find_channel(g1, "Solar"), n;
    const double *wl = bst_glass_channel_grid(g1, ch, &n);
    double *w = malloc(n * sizeof *w);
    ck_assert_int_eq(bst_glass_channel_weights(ctx, g1, ch, n, wl, w), BST_OK);
    static const double want[2][5] = {
        {0.372156603, 0.416866895, 0.28025058, 0.156340087, 0.0546364145},  /* 0 deg */
        {0.354493439, 0.422138447, 0.278729862, 0.165818546, 0.0575495679}, /* 40 deg */
    };
    double worst = 0;
    for (int a = 0; a < 2; a++) {
        double q[5];
        two_panes(g1, g2, w, wl, n, deg(40.0 * a), q);
        for (int i = 0; i < 5; i++) {
            ck_assert_msg(fabs(q[i] - want[a][i]) <= WCE_TOL, "%d deg, quantity %d: %.9f vs WCE "
                          "%.9f", 40 * a, i, q[i], want[a][i]);
            worst = fmax(worst, fabs(q[i] - want[a][i]));
        }
    }
    /* hemispherical (diffuse-diffuse) T, Rf, Rb: 2 int P sin cos dtheta by WCE's trapezoid on
     * 0, 10, ..., 90 degrees */
    static const double hemi_want[3] = {0.314154958, 0.455358423, 0.318327267};
    double hemi[3] = {0, 0, 0}, prev[3] = {0, 0, 0};
    for (int a = 0; a <= 90; a += 10) {
        double q[5], th = deg(a);
        two_panes(g1, g2, w, wl, n, th, q);
        for (int i = 0; i < 3; i++) {
            double f = q[i] * sin(2 * th);
            if (a)
                hemi[i] += 0.5 * deg(10) * (f + prev[i]);
            prev[i] = f;
        }
    }
    for (int i = 0; i < 3; i++) {
        ck_assert_msg(fabs(hemi[i] - hemi_want[i]) <= WCE_TOL, "hemispherical %d: %.9f vs WCE %.9f",
                      i, hemi[i], hemi_want[i]);
        worst = fmax(worst, fabs(hemi[i] - hemi_want[i]));
    }
    printf("NFRC 1042 (coated, flipped) / 103 vs WCE: largest difference %.2e\n", worst);
    free(w);
    bst_glass_free(g1), bst_glass_free(g2);
}
END_TEST

/* ------------------------------------------------------------------ which model */

/* Material types and the model WINDOW gives them (-1: a type it does not know). */
static const struct {
    const char *type;
    int model;
} types[] = {{"Monolithic", 0},     {"interlayer", 0}, {"Coated", 1}, {"Applied Film", 1},
             {"applied-film", 1},   {"LAMINATE", 1},   {"Film", 1},   {"electrochromic", 1},
             {"Thermochromic", 1},  {"Tinted", -1},    {"", -1},      {"  ", -1}};

START_TEST(test_model_choice)
{
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++) {
        bst_glass_model m = (bst_glass_model)7;
        int rc = bst_glass_model_for_type(types[i].type, &m);
        ck_assert_msg(types[i].model < 0 ? rc == BST_ENOTFOUND : rc == BST_OK && (int)m == types[i].model,
                      "type '%s'", types[i].type);
    }
    static const struct {
        const char *spec, *from;
        bst_glass_model model;
    } specs[] = {
        {"t0=0.8,r0=0.07", "default", BST_GLASS_UNCOATED},
        {"t0=0.8,r0=0.07,model=coated", "spec", BST_GLASS_COATED},
        {"model=coated,t0=0.8,r0=0.07", "spec", BST_GLASS_COATED},
        {"nfrc-102", "default", BST_GLASS_UNCOATED},
        {"nfrc-102,model=coated", "spec", BST_GLASS_COATED},
    };
    double t[5];
    for (size_t i = 0; i < 5; i++) {
        bst_glass *g = parse(specs[i].spec);
        ck_assert_int_eq(bst_glass_get_model(g), specs[i].model);
        ck_assert_str_eq(bst_glass_metadata(g)->model_from, specs[i].from);
        ck_assert_int_eq(bst_glass_optics(g, 0, deg(50), &t[i], NULL, NULL, NULL), BST_OK);
        bst_glass_free(g);
    }
    ck_assert(t[1] == t[2] && t[0] != t[1] && t[3] != t[4]);
    /* the coated pane's T at 50 degrees is the clear quartic's */
    double tc, rc_;
    bsti_glass_coated_optics(0.8, 0.07, cos(deg(50)), &tc, &rc_);
    ck_assert(t[1] == tc);
    static const char *const bad[] = {"t0=0.8,r0=0.07,model=wavy", "model=coated",
                                      "nfrc-102,model=coated,model=uncoated", "nfrc-102,model="};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        bst_glass *g = (bst_glass *)1;
        ck_assert_int_lt(bst_glass_parse(ctx, bad[i], NULL, &g), 0);
        ck_assert_ptr_null(g);
        ck_assert_msg(strstr(bst_ctx_message(ctx), "model") || strstr(bst_ctx_message(ctx), "empty"),
                      "%s: %s", bad[i], bst_ctx_message(ctx));
    }
}
END_TEST

/* The uncoated model is the same to the bit after the pane went coated and back, per channel
 * and per wavelength; a coated pane is no slab (bst_glass_slab). */
START_TEST(test_uncoated_unchanged)
{
    bst_glass *g = parse("nfrc-102"), *h = parse("nfrc-102");
    ck_assert_int_eq(bst_glass_set_model(ctx, h, BST_GLASS_COATED), BST_OK);
    ck_assert_int_eq(bst_glass_slab(h, 0, 0.5, 0, NULL, NULL), BST_EINVAL);
    ck_assert_str_eq(bst_glass_metadata(h)->model_from, "set");
    double a[4], b[4];
    ck_assert_int_eq(bst_glass_optics(g, 1, deg(45), &a[0], &a[1], &a[2], &a[3]), BST_OK);
    ck_assert_int_eq(bst_glass_optics(h, 1, deg(45), &b[0], &b[1], &b[2], &b[3]), BST_OK);
    ck_assert(a[0] != b[0]);
    ck_assert_int_eq(bst_glass_set_model(ctx, h, BST_GLASS_UNCOATED), BST_OK);
    ck_assert_int_eq(bst_glass_set_model(ctx, h, (bst_glass_model)2), BST_EINVAL);
    for (size_t c = 0; c < bst_glass_nchannels(g); c++)
        for (int d = 0; d <= 90; d += 3) {
            ck_assert_int_eq(bst_glass_optics(g, c, deg(d), &a[0], &a[1], &a[2], &a[3]), BST_OK);
            ck_assert_int_eq(bst_glass_optics(h, c, deg(d), &b[0], &b[1], &b[2], &b[3]), BST_OK);
            ck_assert(memcmp(a, b, sizeof a) == 0);
            ck_assert_int_eq(bst_glass_optics_spectral(g, 0.55, deg(d), &a[0], &a[1], &a[2], &a[3]),
                             BST_OK);
            ck_assert_int_eq(bst_glass_optics_spectral(h, 0.55, deg(d), &b[0], &b[1], &b[2], &b[3]),
                             BST_OK);
            ck_assert(memcmp(a, b, sizeof a) == 0);
        }
    bst_glass_free(g), bst_glass_free(h);
}
END_TEST

/* A coated pane's layer: the patch values are the model's (Klems full at patch centres: the
 * polar patch the data, the others the correlations at their centres). */
START_TEST(test_coated_layer)
{
    bst_glass *g = parse("t0=0.5,r0=0.3,r0b=0.2,model=coated");
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &b), BST_OK);
    bst_layer *l;
    ck_assert_int_eq(bst_glass_layer(ctx, g, b, 0, NULL, 1, &l), BST_OK);
    const double *lam = bst_basis_lambda(b);
    for (size_t j = 0; j < bst_basis_size(b); j += 7) {
        double d[3], t, r, rb;
        bst_basis_center(b, j, d);
        ck_assert_int_eq(bst_glass_optics(g, 0, acos(fmin(d[2], 1.0)), &t, NULL, &r, &rb), BST_OK);
        tu_assert_close(lam[j] * bst_mat_get(bst_layer_get(l, 0, BST_TF), j, j), t, 1e-14, 1);
        tu_assert_close(lam[j] * bst_mat_get(bst_layer_get(l, 0, BST_RF), j, j), r, 1e-14, 1);
        tu_assert_close(lam[j] * bst_mat_get(bst_layer_get(l, 0, BST_RB), j, j), rb, 1e-14, 1);
        if (j == 0)
            ck_assert(fabs(lam[0] * bst_mat_get(bst_layer_get(l, 0, BST_TF), 0, 0) - 0.5) < 1e-15);
    }
    bst_layer_free(l);
    bst_basis_free(b);
    bst_glass_free(g);
}
END_TEST

int main(void)
{
    const TTest *const tests[] = {test_quartics, test_normal_incidence, test_grazing, test_switch,
                                  test_bounds, test_wce_table, test_wce_1042_values,
                                  test_wce_1042_angular, test_wce_1042_103_flipped,
                                  test_model_choice, test_uncoated_unchanged, test_coated_layer};
    return tu_run(tg_suite("glass_coated", setup, teardown, 60, tests,
                           sizeof tests / sizeof tests[0]));
}
