/* test_glass.c - analytic glass against Windows-CalcEngine's reference values (uncoated-glass model,
 * NFRC 102/103 per wavelength and band-averaged, Klems diagonals, two-pane systems combined per
 * wavelength) and against closed forms (Fresnel, the slab with and without absorption, energy
 * balance, grazing incidence); its layers (diagonal, O(N), patch values); bad input and allocation
 * failure.  WCE's tolerance is 1e-6 absolute where this code follows its discretisation. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "basis.h"
#include "ctx.h"
#include "glass.h"
#include "testglass.h"
#include "testutil.h"

/* WCE's own tests compare with 1e-6 absolute; so do these where they follow its discretisation. */
#define WCE_TOL 1e-6
/* Energy balance of a non-absorbing pane: rounding only. */
#define BALANCE_TOL (64 * DBL_EPSILON)

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static const char *dir(void) { return getenv("BSDFSTACK_GLASS_DIR"); }

static bst_glass *parse(const char *spec)
{
    bst_glass *g = NULL;
    int rc = bst_glass_parse(ctx, spec, dir(), &g);
    ck_assert_msg(rc == BST_OK, "%s: %s", spec, bst_ctx_message(ctx));
    return g;
}

static double deg(double d) { return d * M_PI / 180; }

/* Unpolarised Fresnel reflectance of one interface air -> index n at theta (textbook form). */
static void fresnel(double n, double th, double *rs, double *rp)
{
    double ci = cos(th), st = sin(th) / n, ct = sqrt(1 - st * st);
    *rs = pow((ci - n * ct) / (ci + n * ct), 2);
    *rp = pow((n * ci - ct) / (n * ci + ct), 2);
}

/* Incoherent slab of index n, internal transmittance tau0^(1/cos theta'), textbook sums. */
static void slab(double n, double tau0, double th, double *t, double *r)
{
    double rs, rp, st = sin(th) / n, tau = pow(tau0, 1 / sqrt(1 - st * st));
    fresnel(n, th, &rs, &rp);
    *t = *r = 0;
    for (int x = 0; x < 2; x++) {
        double rx = x ? rp : rs, tx = tau * (1 - rx) * (1 - rx) / (1 - tau * tau * rx * rx);
        *t += tx / 2, *r += rx * (1 + tau * tx) / 2;
    }
}

/* ------------------------------------------------------------------ WCE reference values */

/* CAngularPropertiesUncoated: (T0, R0) -> T, R at angle, both sides alike. */
START_TEST(test_wce_mono)
{
    FILE *fp = fopen(tu_ref("wce/glass/glass_mono_fresnel_wce.tsv"), "r");
    ck_assert_ptr_nonnull(fp);
    char line[512];
    int rows = 0;
    double worst = 0;
    while (fgets(line, sizeof line, fp)) {
        double t0, r0, a, tw, rw;
        if (line[0] == '#' || sscanf(line, "%lf %lf %lf %lf %lf", &t0, &r0, &a, &tw, &rw) != 5)
            continue;
        char spec[128];
        snprintf(spec, sizeof spec, "t0=%.17g,r0=%.17g", t0, r0);
        bst_glass *g = parse(spec);
        double t, tb, rf, rb;
        ck_assert_int_eq(bst_glass_optics(g, 0, deg(a), &t, &tb, &rf, &rb), BST_OK);
        double d = fmax(fabs(t - tw), fabs(rf - rw));
        ck_assert_msg(d <= WCE_TOL && rf == rb && t == tb, "T0 %g R0 %g at %g deg: T %.9f R %.9f vs "
                      "WCE %.9f %.9f", t0, r0, a, t, rf, tw, rw);
        worst = fmax(worst, d);
        bst_glass_free(g);
        rows++;
    }
    fclose(fp);
    ck_assert_int_ge(rows, 50);
    printf("glass mono model vs WCE: largest difference %.2e over %d rows\n", worst, rows);
}
END_TEST

/* NFRC 102/103 per wavelength (WCE's CAngularSpectralSample) at every data wavelength and angle. */
START_TEST(test_wce_per_wavelength)
{
    FILE *fp = fopen(tu_ref("wce/glass/glass_angular_spectral_wce.tsv"), "r");
    ck_assert_ptr_nonnull(fp);
    bst_glass *g102 = parse("nfrc-102"), *g103 = parse("nfrc-103");
    ck_assert_uint_eq(bst_glass_nwavelengths(g102), 111);
    tu_assert_close(bst_glass_wavelength(g102, 0), 0.3, 1e-15, 0);
    tu_assert_close(bst_glass_wavelength(g102, 110), 2.5, 1e-15, 0);
    ck_assert(isnan(bst_glass_wavelength(g102, 111)));
    char line[512], pane[32];
    int rows = 0;
    double worst = 0;
    while (fgets(line, sizeof line, fp)) {
        double wl, a, w[4], v[4];
        if (line[0] == '#' || sscanf(line, "%31s %lf %lf %lf %lf %lf %lf", pane, &wl, &a, &w[0],
                                     &w[1], &w[2], &w[3]) != 7)
            continue;
        bst_glass *g = strcmp(pane, "NFRC_102") == 0 ? g102 : g103;
        ck_assert_int_eq(bst_glass_optics_spectral(g, wl, deg(a), &v[0], &v[1], &v[2], &v[3]), BST_OK);
        for (int i = 0; i < 4; i++) {
            ck_assert_msg(fabs(v[i] - w[i]) <= WCE_TOL, "%s %g um %g deg col %d: %.9f vs WCE %.9f",
                          pane, wl, a, i, v[i], w[i]);
            worst = fmax(worst, fabs(v[i] - w[i]));
        }
        rows++;
    }
    fclose(fp);
    ck_assert_int_gt(rows, 4000);
    printf("NFRC 102/103 per wavelength vs WCE: largest difference %.2e over %d rows\n", worst, rows);
    bst_glass_free(g102), bst_glass_free(g103);
}
END_TEST

/* NFRC 102/103 band averages (solar, visible) at every angle and side. */
START_TEST(test_wce_band_averages)
{
    FILE *fp = fopen(tu_ref("wce/glass/glass_angular_averaged_wce.tsv"), "r");
    ck_assert_ptr_nonnull(fp);
    bst_glass *g102 = parse("nfrc-102"), *g103 = parse("nfrc-103");
    char line[512], pane[32], band[32];
    double worst = 0;
    int rows = 0;
    while (fgets(line, sizeof line, fp)) {
        double a, w[6];
        if (line[0] == '#' || sscanf(line, "%31s %31s %lf %lf %lf %lf %lf %lf %lf", pane, band, &a,
                                     &w[0], &w[1], &w[2], &w[3], &w[4], &w[5]) != 9)
            continue;
        bst_glass *g = strcmp(pane, "NFRC_102") == 0 ? g102 : g103;
        int ch = bst_glass_find_channel(g, strcmp(band, "visible") == 0 ? "Visible" : "Solar");
        ck_assert_int_ge(ch, 0);
        double v[6];
        ck_assert_int_eq(bst_glass_optics(g, (size_t)ch, deg(a), &v[0], &v[1], &v[2], &v[3]), BST_OK);
        v[4] = 1 - v[0] - v[2], v[5] = 1 - v[1] - v[3]; /* absorptance front, back */
        for (int i = 0; i < 6; i++) {
            ck_assert_msg(fabs(v[i] - w[i]) <= WCE_TOL, "%s %s %g deg col %d: %.9f vs WCE %.9f",
                          pane, band, a, i, v[i], w[i]);
            worst = fmax(worst, fabs(v[i] - w[i]));
        }
        rows++;
    }
    fclose(fp);
    ck_assert_int_gt(rows, 300);
    printf("NFRC 102/103 band averages vs WCE: largest difference %.2e over %d rows\n", worst, rows);
    bst_glass_free(g102), bst_glass_free(g103);
}
END_TEST

/* WCE's Klems full glass layer: M(i,i) = P(theta_c(i)) / Lambda_i (at_centre = 1). */
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
    const double *lam = bst_basis_lambda(b);
    char line[512], pane[32], band[32];
    int rows = 0;
    double worst = 0, worst_rel = 0;
    while (fgets(line, sizeof line, fp)) {
        int idx;
        double tc, pc, lw, want[4];
        if (line[0] == '#' || sscanf(line, "%31s %31s %d %lf %lf %lf %lf %lf %lf %lf", pane, band,
                                     &idx, &tc, &pc, &lw, &want[0], &want[1], &want[2], &want[3]) != 10)
            continue;
        tu_assert_close(lam[idx - 1], lw, 1e-9, 0);
        const bst_layer *ll = l[strcmp(pane, "NFRC_102") == 0 ? 0 : 1];
        int ch = bst_layer_find_channel(ll, strcmp(band, "solar") == 0 ? "Solar" : "Visible");
        ck_assert_int_ge(ch, 0);
        static const bst_comp comps[4] = {BST_TF, BST_TB, BST_RF, BST_RB};
        for (int c = 0; c < 4; c++) {
            double got = bst_mat_get(bst_layer_get(ll, (size_t)ch, comps[c]), (size_t)idx - 1,
                                     (size_t)idx - 1);
            /* the property P = Lambda M to WCE's 1e-6 */
            ck_assert_msg(fabs(got - want[c]) * lw <= WCE_TOL, "%s %s patch %d %s: %.9g vs WCE %.9g",
                          pane, band, idx, bst_comp_name(comps[c]), got, want[c]);
            worst = fmax(worst, fabs(got - want[c]) * lw);
            worst_rel = fmax(worst_rel, fabs(got - want[c]) / want[c]);
        }
        rows++;
    }
    fclose(fp);
    ck_assert_int_eq(rows, 4 * 145);
    printf("Klems full diagonals vs WCE: largest difference of Lambda M %.2e, relative %.2e\n", worst,
           worst_rel);
    for (int p = 0; p < 2; p++)
        bst_layer_free(l[p]), bst_glass_free(g[p]);
    bst_basis_free(b);
}
END_TEST

/* Two panes (NFRC 102 exterior, NFRC 103 interior) combined per wavelength and then averaged with
 * bst_glass_channel_weights on the wavelengths wl[0..n-1]: q[] = Tf, Rf, Tb, Rb, Abs front layer 1,
 * 2, Abs back layer 1, 2.  one_t: each pane transmits Tf both ways (WCE's specular multi-pane
 * calculation does so; its Klems layers, like bst_glass_layer, keep the back side's own Tb, which
 * the model gives slightly different where Rb != Rf). */
static void two_panes(const bst_glass *g1, const bst_glass *g2, size_t ch, const double *wl, size_t n,
                      double theta, int one_t, double q[8])
{
    double *w = malloc(n * sizeof *w);
    ck_assert_int_eq(bst_glass_channel_weights(ctx, g1, ch, n, wl, w), BST_OK);
    for (int i = 0; i < 8; i++)
        q[i] = 0;
    for (size_t k = 0; k < n; k++) {
        double tf1, tb1, rf1, rb1, tf2, tb2, rf2, rb2;
        ck_assert_int_eq(bst_glass_optics_spectral(g1, wl[k], theta, &tf1, &tb1, &rf1, &rb1), BST_OK);
        ck_assert_int_eq(bst_glass_optics_spectral(g2, wl[k], theta, &tf2, &tb2, &rf2, &rb2), BST_OK);
        if (one_t)
            tb1 = tf1, tb2 = tf2;
        /* at 90 degrees two mirrors face each other (d = 0) and nothing is transmitted */
        double d = 1 - rb1 * rf2, id = d > 0 ? 1 / d : 0, x = tf1 * id, y = tb2 * id;
        double v[8] = {tf1 * tf2 * id, rf1 + tf1 * tb1 * rf2 * id, tb2 * tb1 * id,
                       rb2 + tb2 * tf2 * rb1 * id, (1 - tf1 - rf1) + x * rf2 * (1 - tb1 - rb1),
                       x * (1 - tf2 - rf2), y * (1 - tb1 - rb1),
                       (1 - tb2 - rb2) + y * rb1 * (1 - tf2 - rf2)};
        for (int i = 0; i < 8; i++)
            q[i] += w[k] * v[i];
    }
    free(w);
}

/* Index into two_panes' q[] of a results row (quantity, side, layer), -1 if not one of them.
 * from_back: the row numbers layers from the incidence side for back incidence. */
static int quantity(const char *qn, const char *side, const char *layer, int from_back)
{
    int back = strcmp(side, "back") == 0;
    if (strcmp(qn, "T_dirdir") == 0)
        return back ? 2 : 0;
    if (strcmp(qn, "R_dirdir") == 0)
        return back ? 3 : 1;
    if (strcmp(qn, "Abs") == 0)
        return 4 + 2 * back + ((strcmp(layer, "2") == 0) != (back && from_back));
    return -1;
}

/* WCE's specular double pane (MultiPaneSpecular_102_103_FullSpectrum): solar, per wavelength on the
 * panes' common data grid, every angle, and the hemispherical values by trapezoid on 0..90 deg.
 * For back incidence this case's layer 1 is the interior pane (the one the light meets first): its
 * "Abs back 1" equals the Klems case dg_klems_quarter_102_103's "Abs back 2" (exterior first), to
 * every digit, and the physics (the interior NFRC 103, met first, absorbs more) agrees. */
START_TEST(test_wce_two_panes_solar)
{
    bst_glass *g1 = parse("nfrc-102"), *g2 = parse("nfrc-103");
    size_t n = bst_glass_nwavelengths(g1);
    ck_assert_uint_eq(bst_glass_nwavelengths(g2), n);
    double *wl = malloc(n * sizeof *wl);
    for (size_t k = 0; k < n; k++) {
        wl[k] = bst_glass_wavelength(g1, k);
        ck_assert_double_eq(wl[k], bst_glass_wavelength(g2, k)); /* the union is this grid */
    }
    size_t ch = (size_t)bst_glass_find_channel(g1, "Solar");
    FILE *fp = fopen(tu_ref("wce/cases/dg_specular_102_103_solar_results.tsv"), "r");
    ck_assert_ptr_nonnull(fp);
    char line[512], cs[64], band[16], qn[32], side[16], layer[8], idx[8], ts[16], ps[16];
    double worst = 0, value, hemi[8] = {0}, prev[8] = {0}, prev_th = 0;
    int rows = 0, hrows = 0;
    /* trapezoid of P sin(2 theta) on 0, 10, ..., 90 deg (the results' hemispherical rows) */
    for (int a = 0; a <= 90; a += 10) {
        double q[8], th = deg(a);
        two_panes(g1, g2, ch, wl, n, th, 1, q);
        for (int i = 0; i < 8; i++) {
            double f = q[i] * sin(2 * th);
            if (a)
                hemi[i] += 0.5 * (th - prev_th) * (f + prev[i]);
            prev[i] = f;
        }
        prev_th = th;
    }
    while (fgets(line, sizeof line, fp)) {
        if (line[0] == '#' || sscanf(line, "%63s %15s %31s %15s %7s %7s %15s %15s %lf", cs, band, qn,
                                     side, layer, idx, ts, ps, &value) != 9)
            continue;
        double got;
        if (strstr(qn, "diffdiff")) {
            char base[32];
            snprintf(base, sizeof base, "%.*s_dirdir", (int)(strchr(qn, '_') - qn), qn);
            int i = strcmp(qn, "Abs_diffdiff") == 0 ? quantity("Abs", side, layer, 1)
                                                   : quantity(base, side, layer, 1);
            ck_assert_int_ge(i, 0);
            got = hemi[i];
            hrows++;
        } else {
            int i = quantity(qn, side, layer, 1);
            ck_assert_msg(i >= 0, "unexpected quantity %s", qn);
            double q[8];
            two_panes(g1, g2, ch, wl, n, deg(atof(ts)), 1, q);
            got = q[i];
        }
        ck_assert_msg(fabs(got - value) <= WCE_TOL, "%s %s layer %s at %s deg: %.9f vs WCE %.9f", qn,
                      side, layer, ts, got, value);
        worst = fmax(worst, fabs(got - value));
        rows++;
    }
    fclose(fp);
    ck_assert_int_eq(rows, 168);
    ck_assert_int_eq(hrows, 8);
    printf("two panes 102/103 solar, per wavelength, vs WCE: largest difference %.2e over %d rows\n",
           worst, rows);
    free(wl);
    bst_glass_free(g1), bst_glass_free(g2);
}
END_TEST

/* WCE's Klems quarter double pane 102/103, visible: per wavelength on the photopic grid (WCE's
 * common wavelengths, shorter than the data grid), at every patch centre. */
START_TEST(test_wce_two_panes_visible)
{
    bst_glass *g1 = parse("nfrc-102"), *g2 = parse("nfrc-103");
    size_t ch = (size_t)bst_glass_find_channel(g1, "Visible"), n;
    const double *wl = bst_glass_channel_grid(g1, ch, &n);
    ck_assert_ptr_nonnull(wl);
    ck_assert_uint_eq(n, 81);
    FILE *fp = fopen(tu_ref("wce/cases/dg_klems_quarter_102_103_results.tsv"), "r");
    ck_assert_ptr_nonnull(fp);
    char line[512], cs[64], band[16], qn[32], side[16], layer[8], idx[8], ts[16], ps[16];
    double worst = 0, value;
    int rows = 0;
    while (fgets(line, sizeof line, fp)) {
        if (line[0] == '#' || sscanf(line, "%63s %15s %31s %15s %7s %7s %15s %15s %lf", cs, band, qn,
                                     side, layer, idx, ts, ps, &value) != 9)
            continue;
        int i = quantity(qn, side, layer, 0);
        if (strcmp(band, "visible") != 0 || i < 0 || strcmp(ps, "0") != 0) /* one patch a ring */
            continue;
        double q[8];
        two_panes(g1, g2, ch, wl, n, deg(atof(ts)), 0, q);
        ck_assert_msg(fabs(q[i] - value) <= WCE_TOL, "%s %s layer %s at %s deg: %.9f vs WCE %.9f",
                      qn, side, layer, ts, q[i], value);
        worst = fmax(worst, fabs(q[i] - value));
        rows++;
    }
    fclose(fp);
    ck_assert_int_eq(rows, 8 * 5); /* rings at 0, 18, 36, 54, 76.5 deg */
    printf("two panes 102/103 visible, per wavelength, vs WCE: largest difference %.2e over %d rows\n",
           worst, rows);
    bst_glass_free(g1), bst_glass_free(g2);
}
END_TEST

/* Weights: sum 1, reproduce the channel's own average for the pane's data on its data grid (Solar
 * only: Visible integrates on another grid), constant outside the range, and any grid works. */
START_TEST(test_channel_weights)
{
    bst_glass *g = parse("nfrc-103");
    size_t n = bst_glass_nwavelengths(g), ch = (size_t)bst_glass_find_channel(g, "Solar");
    double *wl = malloc(n * sizeof *wl), *w = malloc(n * sizeof *w), s = 0;
    for (size_t k = 0; k < n; k++)
        wl[k] = bst_glass_wavelength(g, k);
    ck_assert_int_eq(bst_glass_channel_weights(ctx, g, ch, n, wl, w), BST_OK);
    for (size_t k = 0; k < n; k++) {
        ck_assert(w[k] >= 0);
        s += w[k];
    }
    tu_assert_close(s, 1.0, 1e-13, 0);
    /* a single wavelength takes all the weight: a constant property */
    double one = 0.55;
    ck_assert_int_eq(bst_glass_channel_weights(ctx, g, ch, 1, &one, w), BST_OK);
    tu_assert_close(w[0], 1.0, 1e-13, 0);
    /* errors: not increasing, not a band channel */
    double bad[2] = {0.6, 0.5};
    ck_assert_int_eq(bst_glass_channel_weights(ctx, g, ch, 2, bad, w), BST_EINVAL);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "does not increase"));
    bst_glass *c = parse("clear-6mm");
    ck_assert_int_eq(bst_glass_channel_weights(ctx, c, 0, 1, &one, w), BST_EINVAL);
    ck_assert_ptr_null(bst_glass_channel_grid(c, 0, &n));
    ck_assert_uint_eq(n, 0);
    ck_assert_uint_eq(bst_glass_nwavelengths(c), 0);
    ck_assert_int_eq(bst_glass_optics_spectral(c, 0.5, 0, &s, NULL, NULL, NULL), BST_EINVAL);
    free(wl), free(w);
    bst_glass_free(g), bst_glass_free(c);
}
END_TEST

/* ------------------------------------------------------------------ closed forms */

/* One bare interface (T0 = 0, R0 = ((n-1)/(n+1))^2): R(theta) is Fresnel's unpolarised average. */
START_TEST(test_single_interface)
{
    double n = 1.52, rho = pow((n - 1) / (n + 1), 2);
    char spec[128];
    snprintf(spec, sizeof spec, "t0=0,r0=%.17g", rho);
    bst_glass *g = parse(spec);
    for (double a = 0; a < 90; a += 0.25) {
        double t, r, rs, rp;
        ck_assert_int_eq(bst_glass_optics(g, 0, deg(a), &t, NULL, &r, NULL), BST_OK);
        fresnel(n, deg(a), &rs, &rp);
        ck_assert_double_eq(t, 0.0);
        tu_assert_close(r, (rs + rp) / 2, 1e-12, 1e-12);
    }
    double t, r;
    bst_glass_optics(g, 0, 0.0, &t, NULL, &r, NULL);
    tu_assert_close(r, rho, 1e-15, 0);
    double nn, tau;
    ck_assert_int_eq(bst_glass_slab(g, 0, 0.5, 0, &nn, &tau), BST_OK);
    tu_assert_close(nn, n, 1e-12, 0);
    ck_assert_double_eq(tau, 0.0);
    bst_glass_free(g);
}
END_TEST

/* Slabs given by n, k and d: every angle equals the textbook incoherent slab; d enters through
 * tau0 = exp(-k d); no absorption conserves energy to rounding; d -> 0 is the bare two-interface
 * pane; the symmetric pane has Rf = Rb, Tf = Tb; T + R + A = 1 with A >= 0. */
START_TEST(test_slab)
{
    const double n = 1.52, k = 30.0; /* 1/m */
    const double thick[] = {0.0, 1e-12, 0.003, 0.006, 0.012};
    for (size_t i = 0; i < sizeof thick / sizeof thick[0]; i++) {
        char spec[128];
        snprintf(spec, sizeof spec, "d=%.17gm,n=%g,k=%g/m", thick[i], n, k);
        bst_glass *g = parse(spec);
        double nn, tau0;
        ck_assert_int_eq(bst_glass_slab(g, 1, NAN, 1, &nn, &tau0), BST_OK);
        tu_assert_close(nn, n, 1e-12, 0);
        tu_assert_close(tau0, exp(-k * thick[i]), 1e-12, 0);
        for (double a = 0; a <= 90; a += 0.5) {
            double th = deg(a == 90 ? 89.99 : a), t, tb, rf, rb, te, re;
            ck_assert_int_eq(bst_glass_optics(g, 1, th, &t, &tb, &rf, &rb), BST_OK);
            ck_assert_double_eq(rf, rb);
            ck_assert_double_eq(t, tb);
            slab(n, exp(-k * thick[i]), th, &te, &re);
            tu_assert_close(t, te, 1e-11, 1e-12);
            tu_assert_close(rf, re, 1e-11, 1e-12);
            ck_assert(1 - t - rf >= -BALANCE_TOL);
            if (thick[i] == 0.0) /* no absorption: T + R = 1 */
                tu_assert_close(t + rf, 1.0, BALANCE_TOL, 0);
            if (thick[i] < 1e-9) { /* d -> 0: bare two interfaces, T = mean of (1 - r)/(1 + r) */
                double rs, rp;
                fresnel(n, th, &rs, &rp);
                tu_assert_close(t, ((1 - rs) / (1 + rs) + (1 - rp) / (1 + rp)) / 2,
                                thick[i] == 0 ? 1e-12 : 1e-7, 0);
            }
        }
        bst_glass_free(g);
    }
    /* a thicker pane of the same glass transmits less at every angle */
    bst_glass *a = parse("d=3mm,k=30,n=1.52"), *b = parse("d=12mm,k=30,n=1.52");
    for (double th = 0; th < M_PI / 2; th += 0.01) {
        double ta, tb2;
        bst_glass_optics(a, 0, th, &ta, NULL, NULL, NULL);
        bst_glass_optics(b, 0, th, &tb2, NULL, NULL, NULL);
        ck_assert(tb2 < ta);
    }
    bst_glass_free(a), bst_glass_free(b);
}
END_TEST

/* The model is continuous at R0 = 0: R0 = 0 is the limit R0 -> 0+ (n = 1, tau0 = T0), T(theta)
 * = T0^(1/cos theta) and R = 0 (the path through an absorbing pane of index 1), and R0 = 1e-300
 * (at every angle), 1e-12 and 1e-6 (to 80 degrees) approach it as sqrt(R0) (R0 = 0 was
 * angle-independent, R0 = 1e-300 not); T0 = 1 stays angle-independent. */
START_TEST(test_no_reflection_limit)
{
    const double t0s[] = {0.05, 0.5, 0.9, 1.0};
    for (size_t i = 0; i < sizeof t0s / sizeof t0s[0]; i++) {
        char spec[128];
        snprintf(spec, sizeof spec, "t0=%g,r0=0", t0s[i]);
        bst_glass *g0 = parse(spec);
        double nn, tau0;
        ck_assert_int_eq(bst_glass_slab(g0, 0, 0.5, 0, &nn, &tau0), BST_OK);
        ck_assert_double_eq(nn, 1.0);
        tu_assert_close(tau0, t0s[i], 1e-15, 0);
        const double near[] = {1e-300, 1e-12, 1e-6}; /* n - 1 ~ 2 sqrt(R0): T moves as sqrt(R0) */
        for (double a = 0; a < 90; a += 2.5) {
            double t, r;
            ck_assert_int_eq(bst_glass_optics(g0, 0, deg(a), &t, NULL, &r, NULL), BST_OK);
            tu_assert_close(t, pow(t0s[i], 1 / cos(deg(a))), 1e-11, 1e-300); /* the exponent amplifies log(T0)'s rounding */
            ck_assert(r >= 0 && r <= 1e-15); /* 0 up to rounding of cos theta' = cos theta */
            for (size_t j = 0; j < 3 && t0s[i] < 1 && (j == 0 || a <= 80); j++) { /* grazing: more sensitive */
                snprintf(spec, sizeof spec, "t0=%g,r0=%g", t0s[i], near[j]);
                bst_glass *g = parse(spec);
                double tn, rn;
                ck_assert_int_eq(bst_glass_optics(g, 0, deg(a), &tn, NULL, &rn, NULL), BST_OK);
                double gap = fmax(1e-15, 100 * sqrt(near[j]));
                ck_assert_msg(fabs(tn - t) <= gap && rn <= gap,
                              "%s at %g deg: T %.17g vs %.17g at R0 = 0, R %g", spec, a, tn, t, rn);
                bst_glass_free(g);
            }
        }
        bst_glass_free(g0);
    }
}
END_TEST

/* Specs by tn: T(0) = tn, R(0) = rho (1 + tau tn), n recovered; tn at the non-absorbing limit gives
 * R(0) = 2 rho / (1 + rho) and T + R = 1 at every angle. */
START_TEST(test_tn_spec)
{
    double n = 1.52, rho = pow((n - 1) / (n + 1), 2), tmax = (1 - rho) / (1 + rho);
    char spec[128];
    snprintf(spec, sizeof spec, "d=6mm,n=%g,tn=%.17g", n, tmax);
    bst_glass *g = parse(spec), *a = parse("d=6mm,n=1.52,tn=0.80");
    double t, r, nn, tau;
    bst_glass_optics(g, 0, 0, &t, NULL, &r, NULL);
    tu_assert_close(r, 2 * rho / (1 + rho), 1e-12, 0);
    for (double d = 0; d < 90; d += 0.5) {
        bst_glass_optics(g, 0, deg(d), &t, NULL, &r, NULL);
        tu_assert_close(t + r, 1.0, BALANCE_TOL, 0);
    }
    bst_glass_optics(a, 0, 0, &t, NULL, &r, NULL);
    tu_assert_close(t, 0.80, 1e-14, 0);
    ck_assert_int_eq(bst_glass_slab(a, 0, NAN, 0, &nn, &tau), BST_OK);
    tu_assert_close(nn, n, 1e-12, 0);
    tu_assert_close(r, rho * (1 + tau * 0.80), 1e-12, 0);
    tu_assert_close(0.80, tau * pow(1 - rho, 2) / (1 - tau * tau * rho * rho), 1e-12, 0);
    bst_glass_free(g), bst_glass_free(a);
}
END_TEST

/* Grazing incidence: finite, 0 <= T, R <= 1, T + R <= 1, T -> 0 and R -> 1 continuously, for
 * absorbing, non-absorbing and asymmetric panes, up to the last double below pi/2. */
START_TEST(test_grazing)
{
    static const char *specs[] = {"d=0mm,n=1.52,k=0", "t0=0.834,r0=0.0747,r0b=0.11", "nfrc-102",
                                  "lowiron-6mm", "t0=0,r0=0.04", "t0=1,r0=0"};
    for (size_t i = 0; i < sizeof specs / sizeof specs[0]; i++) {
        bst_glass *g = parse(specs[i]);
        for (size_t ch = 0; ch < bst_glass_nchannels(g); ch++) {
            double th = deg(89.0), last_t = 1, v[4];
            for (int step = 0; step < 2000 && th < M_PI / 2; step++) {
                ck_assert_int_eq(bst_glass_optics(g, ch, th, &v[0], &v[1], &v[2], &v[3]), BST_OK);
                for (int q = 0; q < 4; q++)
                    ck_assert_msg(isfinite(v[q]) && v[q] >= 0 && v[q] <= 1, "%s %.17g: %g", specs[i],
                                  th, v[q]);
                ck_assert(v[0] + v[2] <= 1 + BALANCE_TOL && v[1] + v[3] <= 1 + BALANCE_TOL);
                if (strcmp(specs[i], "t0=1,r0=0") != 0) /* T falls towards 90 */
                    ck_assert(v[0] <= last_t + 1e-15);
                last_t = v[0];
                th = M_PI / 2 - (M_PI / 2 - th) * 0.97;
            }
            double last = nextafter(M_PI / 2, 0);
            ck_assert_int_eq(bst_glass_optics(g, ch, last, &v[0], &v[1], &v[2], &v[3]), BST_OK);
            ck_assert(isfinite(v[0]) && isfinite(v[2]));
            if (strcmp(specs[i], "t0=1,r0=0") != 0) {
                ck_assert_double_lt(v[0], 1e-12);
                ck_assert_double_gt(v[2], 1 - 1e-12);
            }
            ck_assert_int_eq(bst_glass_optics(g, ch, M_PI / 2, &v[0], &v[1], &v[2], &v[3]), BST_OK);
            ck_assert(v[0] == 0 && v[1] == 0); /* R: 1 up to the rounding of the weights' sum */
            tu_assert_close(v[2], 1.0, 1e-14, 0);
            tu_assert_close(v[3], 1.0, 1e-14, 0);
        }
        bst_glass_free(g);
    }
}
END_TEST

/* An asymmetric pane (Rf != Rb) keeps its sides apart; bad angles and channels are refused. */
START_TEST(test_asymmetric_and_args)
{
    bst_glass *g = parse("t0=0.7,r0=0.08,r0b=0.12");
    double t, tb, rf, rb;
    ck_assert_int_eq(bst_glass_optics(g, 0, deg(40), &t, &tb, &rf, &rb), BST_OK);
    ck_assert_double_lt(rf, rb);
    ck_assert_int_eq(bst_glass_optics(g, 0, 0, &t, &tb, &rf, &rb), BST_OK);
    tu_assert_close(rf, 0.08, 1e-15, 0);
    tu_assert_close(rb, 0.12, 1e-15, 0);
    ck_assert_int_eq(bst_glass_optics(g, 0, NAN, &t, &tb, &rf, &rb), BST_EINVAL);
    ck_assert_int_eq(bst_glass_optics(g, 0, -0.1, &t, &tb, &rf, &rb), BST_EINVAL);
    ck_assert_int_eq(bst_glass_optics(g, 0, 1.6, &t, &tb, &rf, &rb), BST_EINVAL);
    ck_assert_int_eq(bst_glass_optics(g, 2, 0.1, &t, &tb, &rf, &rb), BST_EINVAL);
    ck_assert_int_eq(bst_glass_optics(NULL, 0, 0.1, &t, &tb, &rf, &rb), BST_EINVAL);
    ck_assert_int_eq(bst_glass_find_channel(g, "solar"), 1);
    ck_assert_int_eq(bst_glass_find_channel(g, "CIE-X"), -1);
    ck_assert_ptr_null(bst_glass_channel(g, 2));
    ck_assert_str_eq(bst_glass_description(g), "t0=0.7,r0=0.08,r0b=0.12");
    /* no spectral data: no new band */
    ck_assert_int_eq(bst_glass_add_channel(ctx, g, "CIE-X"), BST_ENOTFOUND);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "spectral data"));
    bst_glass_free(g);
    bst_glass_free(NULL);
}
END_TEST

/* Colour: a grey (spectrally flat) pane has Visible = CIE-X = CIE-Y = CIE-Z = Solar = its value at
 * every angle; NFRC 102's CIE-Y is its Visible. */
START_TEST(test_cie_bands)
{
    char path[] = "/tmp/bst_glass_greyXXXXXX";
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    FILE *fp = fdopen(fd, "w");
    fprintf(fp, "# grey pane\nwavelength Tf Tb Rf Rb\n");
    for (double wl = 0.3; wl < 2.501; wl += 0.05)
        fprintf(fp, "%.3f 0.8 0.8 0.08 0.08\n", wl);
    fclose(fp);
    bst_glass *g = parse(path), *ref = parse("t0=0.8,r0=0.08");
    static const char *bands[] = {"CIE-X", "CIE-Y", "CIE-Z", "cie-x"};
    for (int i = 0; i < 4; i++)
        ck_assert_int_eq(bst_glass_add_channel(ctx, g, bands[i]), BST_OK);
    ck_assert_uint_eq(bst_glass_nchannels(g), 5);
    ck_assert_int_eq(bst_glass_add_channel(ctx, g, "NIR"), BST_ENOTFOUND);
    for (double a = 0; a < 90; a += 7.5)
        for (size_t ch = 0; ch < 5; ch++) {
            double v[4], w[4];
            bst_glass_optics(g, ch, deg(a), &v[0], &v[1], &v[2], &v[3]);
            bst_glass_optics(ref, 0, deg(a), &w[0], &w[1], &w[2], &w[3]);
            for (int q = 0; q < 4; q++)
                tu_assert_close(v[q], w[q], 1e-13, 1e-13);
        }
    unlink(path);
    bst_glass *n = parse("nfrc-102");
    ck_assert_int_eq(bst_glass_add_channel(ctx, n, "CIE-Y"), BST_OK);
    double y, v;
    bst_glass_optics(n, (size_t)bst_glass_find_channel(n, "CIE-Y"), deg(30), &y, NULL, NULL, NULL);
    bst_glass_optics(n, (size_t)bst_glass_find_channel(n, "Visible"), deg(30), &v, NULL, NULL, NULL);
    ck_assert_double_eq(y, v);
    bst_glass_free(g), bst_glass_free(ref), bst_glass_free(n);
}
END_TEST

/* ------------------------------------------------------------------ layers */

/* A Shirley-Chiu layer at k = 3 and 7: four diagonal components of N values (O(N)); each patch's
 * directional-hemispherical value (Lambda x column sum) is its patch value Lambda M_jj; with
 * at_centre = 1 that is P at the patch centre, with patch averages the sum over patches of Lambda P
 * is the continuous pane's hemispherical 2 int P sin cos dtheta (averages keep integrals). */
START_TEST(test_layer_sc)
{
    bst_glass *g = parse("clear-6mm");
    for (int k = 3; k <= 7; k += 4) {
        bst_basis *b;
        bst_layer *avg, *cen;
        ck_assert_int_eq(bst_basis_new_sc(ctx, k, &b), BST_OK);
        ck_assert_int_eq(bst_glass_layer(ctx, g, b, 0, NULL, 0, &avg), BST_OK);
        ck_assert_int_eq(bst_glass_layer(ctx, g, b, 0, NULL, 1, &cen), BST_OK);
        size_t n = bst_basis_size(b);
        const double *lam = bst_basis_lambda(b);
        ck_assert_uint_eq(bst_layer_nchannels(avg), 2);
        double *h = malloc(n * sizeof *h);
        for (size_t ch = 0; ch < 2; ch++) {
            /* the continuous pane's hemispherical values, Simpson on 20000 intervals */
            double hemi[4] = {0};
            for (int i = 0; i <= 20000; i++) {
                double th = i * (M_PI / 2) / 20000, v[4], s = (i == 0 || i == 20000) ? 1 : (i % 2 ? 4 : 2);
                bst_glass_optics(g, ch, th, &v[0], &v[2], &v[1], &v[3]); /* Tf, Rf, Tb, Rb order */
                for (int q = 0; q < 4; q++)
                    hemi[q] += s * v[q] * sin(2 * th) * (M_PI / 2) / 20000 / 3;
            }
            for (int c = 0; c < BST_NCOMP; c++) {
                const bst_mat *m = bst_layer_get(avg, ch, (bst_comp)c);
                ck_assert_int_eq(bst_mat_structure(m), BST_DIAG);
                ck_assert_uint_eq(bst_mat_nnz(m), n);
                ck_assert_int_eq(bst_mat_structure(bst_layer_get(cen, ch, (bst_comp)c)), BST_DIAG);
                ck_assert_int_eq(bst_layer_hemispherical(ctx, avg, ch, (bst_comp)c, h), BST_OK);
                double dd = 0;
                for (size_t j = 0; j < n; j++) {
                    tu_assert_close(h[j], lam[j] * bst_mat_get(m, j, j), 1e-14, 0);
                    dd += lam[j] * h[j] / M_PI;
                }
                /* every patch value is its average: their sum is the hemispherical integral */
                tu_assert_close(dd, hemi[c], k == 3 ? 2e-6 : 5e-7, 1.0); /* absolute */
                /* and each patch's (the layer evaluates one patch per symmetry orbit and copies
                 * it): a plain S x S midpoint average of the pane over the patch.  In the outer
                 * ring theta = asin(r) is singular at the rim and the midpoint rule converges
                 * slowly: 1e-3 there (a patch of another orbit differs by 1e-2 and more) */
                for (size_t j = 0; k == 3 && j < n; j++) {
                    size_t x = j / 8, y = j % 8;
                    int rim = x == 0 || x == 7 || y == 0 || y == 7, S = rim ? 128 : 64;
                    double mean = 0, d[3], v[4];
                    for (int q = 0; q < S * S; q++) {
                        bst_basis_sample(b, j, (q / S + 0.5) / S, (q % S + 0.5) / S, d);
                        bst_glass_optics(g, ch, acos(d[2]), &v[0], &v[2], &v[1], &v[3]);
                        mean += v[c] / (S * S);
                    }
                    tu_assert_close(lam[j] * bst_mat_get(m, j, j), mean, rim ? 1e-3 : 1e-4, 1e-6);
                }
                ck_assert_int_eq(bst_layer_hemispherical(ctx, cen, ch, (bst_comp)c, h), BST_OK);
                for (size_t j = 0; j < n; j += 97) {
                    double d[3], v[4];
                    bst_basis_center(b, j, d);
                    bst_glass_optics(g, ch, acos(d[2]), &v[0], &v[2], &v[1], &v[3]);
                    tu_assert_close(h[j], v[c], 1e-12, 1e-15);
                }
            }
        }
        free(h);
        bst_layer_free(avg), bst_layer_free(cen);
        bst_basis_free(b);
    }
    bst_glass_free(g);
}
END_TEST

/* Klems full: a patch's incidence angles fill its band's ring, so its average is the band's
 * average over theta, uniform in projected solid angle: int P sin cos dtheta / int sin cos dtheta
 * over the band's limits (Simpson on 20000 intervals here).  The layer's rule is a Gauss rule in
 * the band's u (glass_layer.c); its patch values hold to 1e-10, and their sum over patches is the
 * continuous pane's hemispherical value (a 2-D rule with 256 points a patch erred by 1e-6). */
START_TEST(test_layer_klems)
{
    bst_glass *g = parse("nfrc-103");
    bst_basis *b;
    bst_layer *avg;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &b), BST_OK);
    ck_assert_int_eq(bst_glass_layer(ctx, g, b, 0, NULL, 0, &avg), BST_OK);
    const double *lam = bst_basis_lambda(b);
    for (size_t ch = 0; ch < bst_glass_nchannels(g); ch++)
        for (size_t band = 0; band < b->nbands; band++) {
            double t0 = b->theta[band] * M_PI / 180, t1 = b->theta[band + 1] * M_PI / 180;
            double mean[4] = {0}, norm = 0;
            const int S = 20000;
            for (int i = 0; i <= S; i++) {
                double th = t0 + i * (t1 - t0) / S, v[4], wt = (i == 0 || i == S) ? 1 : (i % 2 ? 4 : 2);
                bst_glass_optics(g, ch, th, &v[0], &v[2], &v[1], &v[3]); /* Tf, Rf, Tb, Rb order */
                for (int q = 0; q < 4; q++)
                    mean[q] += wt * v[q] * sin(th) * cos(th);
                norm += wt * sin(th) * cos(th);
            }
            size_t end = band + 1 < b->nbands ? b->first[band + 1] : bst_basis_size(b);
            for (size_t j = b->first[band]; j < end; j++)
                for (int c = 0; c < BST_NCOMP; c++)
                    tu_assert_close(lam[j] * bst_mat_get(bst_layer_get(avg, ch, (bst_comp)c), j, j),
                                    mean[c] / norm, 1e-10, 1.0); /* absolute */
        }
    bst_layer_free(avg);
    bst_basis_free(b);
    bst_glass_free(g);
}
END_TEST

/* The largest |Lambda (fast - exact)| over the patch values of nfrc-103's Visible layer. */
static double table_error(const bst_glass *g, const bst_basis *b)
{
    const char *vis[] = {"Visible"};
    bst_layer *fast, *exact;
    ck_assert_int_eq(bsti_glass_layer(ctx, g, b, 1, vis, 0, BST_GLASS_SAMPLES, 0, &fast), BST_OK);
    ck_assert_int_eq(bsti_glass_layer(ctx, g, b, 1, vis, 0, BST_GLASS_SAMPLES, 1, &exact), BST_OK);
    const double *lam = bst_basis_lambda(b);
    double worst = 0;
    for (int c = 0; c < BST_NCOMP; c++)
        for (size_t j = 0; j < bst_basis_size(b); j++)
            worst = fmax(worst, lam[j] * fabs(bst_mat_get(bst_layer_get(fast, 0, (bst_comp)c), j, j) -
                                              bst_mat_get(bst_layer_get(exact, 0, (bst_comp)c), j, j)));
    bst_layer_free(fast), bst_layer_free(exact);
    return worst;
}

/* The angular table behind patch averages changes no patch value by more than BST_GLASS_TABLE_ERR
 * (k = 5: 4-fold more distinct directions than table angles, so the table is used); Klems full has
 * fewer (288), is evaluated exactly and equals the exact layer; the table itself stays within 2e-6
 * of exact evaluation up to 89.9 degrees. */
START_TEST(test_layer_table)
{
    bst_glass *g = parse("nfrc-103");
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &b), BST_OK);
    ck_assert_double_eq(table_error(g, b), 0.0);
    bst_basis_free(b);
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b), BST_OK);
    double worst = table_error(g, b);
    ck_assert_double_le(worst, BST_GLASS_TABLE_ERR);
    double *tab = bsti_glass_table(ctx, g, 0), tworst = 0;
    ck_assert_ptr_nonnull(tab);
    for (int i = 0; i <= 7 * 8990; i++) {
        double th = deg(89.9) * i / (7 * 8990.0), v[4], e[4];
        bsti_glass_table_optics(tab, th, v);
        bst_glass_optics(g, 0, th, &e[0], &e[1], &e[2], &e[3]);
        for (int q = 0; q < 4; q++)
            tworst = fmax(tworst, fabs(v[q] - e[q]));
    }
    ck_assert_double_le(tworst, 2e-6);
    printf("glass table: patch values within %.2e, pointwise within %.2e up to 89.9 deg\n", worst,
           tworst);
    bsti_free(ctx, tab);
    bst_basis_free(b);
    bst_glass_free(g);
}
END_TEST

/* Channels are selected and ordered by name; from_spec averages a spectral pane over a requested
 * band it lacks; unknown channels are refused. */
START_TEST(test_layer_channels)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 2, &b), BST_OK);
    const char *want[] = {"Solar", "CIE-Z", "Visible"};
    bst_layer *l;
    ck_assert_int_eq(bst_glass_layer_from_spec(ctx, "nfrc-102", dir(), b, 3, want, &l), BST_OK);
    ck_assert_uint_eq(bst_layer_nchannels(l), 3);
    for (size_t c = 0; c < 3; c++)
        ck_assert_str_eq(bst_layer_channel(l, c), want[c]);
    bst_layer_free(l);
    const char *x[] = {"CIE-X"};
    l = (bst_layer *)1;
    ck_assert_int_eq(bst_glass_layer_from_spec(ctx, "clear-6mm", dir(), b, 1, x, &l), BST_ENOTFOUND);
    ck_assert_ptr_null(l);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "no channel CIE-X"));
    bst_glass *g = parse("clear-6mm");
    ck_assert_int_eq(bsti_glass_layer(ctx, g, b, 0, NULL, 0, 0, 0, &l), BST_EINVAL);
    ck_assert_int_eq(bst_glass_layer(ctx, g, NULL, 0, NULL, 0, &l), BST_EINVAL);
    bst_glass_free(g);
    bst_basis_free(b);
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

/* ------------------------------------------------------------------ bad input */

static void expect_bad(const char *spec, const char *catdir, const char *expect)
{
    bst_glass *g = (bst_glass *)1;
    int rc = bst_glass_parse(ctx, spec, catdir, &g);
    ck_assert_msg(rc < 0, "'%s' accepted", spec);
    ck_assert_ptr_null(g);
    const char *m = bst_ctx_message(ctx);
    ck_assert_msg(strstr(m, expect), "'%s': message '%s' lacks '%s'", spec, m, expect);
    ck_assert_msg(!strchr(m, '\n'), "'%s': message of several lines: %s", spec, m);
}

START_TEST(test_bad_specs)
{
    static const struct { const char *spec, *expect; } bad[] = {
        {"no-such-pane", "no such pane"},
        {"d=6mm,n=1.52", "needs tn or k"},
        {"d=6mm,n=nan,tn=0.8", "n=nan"},
        {"d=6mm,n=inf,tn=0.8", "n=inf"},
        {"d=6mm,n=0.9,tn=0.8", "n=0.9"},
        {"d=6mm,n=6,tn=0.8", "n=6"},
        {"d=-1mm,n=1.5,tn=0.8", "d=-1mm"},
        {"d=2m,n=1.5,tn=0.8", "d=2m"},
        {"d=6furlongs,n=1.5,tn=0.8", "d=6furlongs"},
        {"d=6mm,n=1.52,tn=0.95", "exceeds"},
        {"d=6mm,n=1.52,tn=-0.1", "tn=-0.1"},
        {"d=6mm,n=1.52,tn=1.5", "tn=1.5"},
        {"d=6mm,n=1.52,k=-3", "k=-3"},
        {"d=6mm,n=1.52,k=3/ft", "k=3/ft"},
        {"n=1.52,k=3", "k needs the thickness d"},
        {"d=6mm,n=1.52,k=3,tn=0.8", "either tn or k"},
        {"d=6mm,tn=0.8,t0=0.8,r0=0.08", "not both"},
        {"n=1.5,t0=0.8,r0=0.08", "give no n"},
        {"d=6mm", "a pane needs tn"},
        {"d=6mm,d=4mm,tn=0.8", "d given twice"},
        {"t0=0.9,r0=0.2", "exceeds 1"},
        {"t0=0.8", "needs tn"},
        {"t0=0.8,r0=1", "r0=1"},
        {"t0=0.8x,r0=0.1", "t0=0.8x"},
        {"d=6mm,colour=blue", "unknown glass parameter 'colour'"},
        {"d=6mm,n", "not key=value"},
        {"../no/such/file.tsv", "cannot open"},
        {"bad name!", "letters, digits"},
        {"", "empty"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        expect_bad(bad[i].spec, dir(), bad[i].expect);
    /* a name too long for a path is said so, not cut to another file's name */
    char name[1300];
    memset(name, 'a', sizeof name - 1);
    name[sizeof name - 1] = '\0';
    expect_bad(name, dir(), "path is longer than");
    bst_glass *g;
    ck_assert_int_eq(bst_glass_parse(ctx, NULL, dir(), &g), BST_EINVAL);
    ck_assert_int_eq(bst_glass_parse(NULL, "clear-6mm", dir(), NULL), BST_EINVAL);
}
END_TEST

/* Malformed spectral files and catalogue files: one message naming the file and the line. */
START_TEST(test_bad_files)
{
    static const struct { const char *name, *text, *expect; } files[] = {
        {"nm.tsv", "wl Tf Tb Rf Rb\n300 0.1 0.1 0.05 0.05\n310 0.2 0.2 0.05 0.05\n", "micrometres"},
        {"order.tsv", "0.5 0.8 0.8 0.08 0.08\n0.4 0.8 0.8 0.08 0.08\n", "line 2: wavelengths must increase"},
        {"big.tsv", "0.4 1.2 0.8 0.08 0.08\n0.5 0.8 0.8 0.08 0.08\n", "line 1: column 2 is not a value in [0, 1]"},
        {"sum.tsv", "0.4 0.95 0.95 0.08 0.08\n0.5 0.8 0.8 0.08 0.08\n", "T + R exceeds 1"},
        {"short.tsv", "0.4 0.8 0.8 0.08\n0.5 0.8 0.8 0.08 0.08\n", "line 1: column 5 is missing"},
        {"text.tsv", "header\n0.4 0.8 0.8 0.08 0.08\nfoo 1 2 3 4\n", "line 3: column 1 is missing"},
        {"nan.tsv", "0.4 nan 0.8 0.08 0.08\n0.5 0.8 0.8 0.08 0.08\n", "line 1: column 2"},
        {"one.tsv", "# only one row\n0.4 0.8 0.8 0.08 0.08\n", "fewer than two data rows"},
        {"empty.tsv", "", "fewer than two data rows"},
        {"ir.tsv", "1.0 0.8 0.8 0.08 0.08\n2.0 0.8 0.8 0.08 0.08\n",
         "the data cover 1..2 um; the Visible band needs 0.38..0.78 um"},
        {"badline.glass", "description x\nVisible t0=0.8,r0=0.08\nSolar t0=2,r0=0\n", "line 3: t0=2"},
        {"noparam.glass", "Visible\n", "line 1: 'Visible' without parameters"},
        {"nochannel.glass", "# nothing\ndescription empty\n", "no channel defined"},
        {"band.glass", "spectral grey.tsv Visible UV\n", "unknown spectral band 'UV'"},
        {"two.glass", "spectral grey.tsv\nspectral grey.tsv\n", "a second spectral data file"},
        {"twice.glass", "Visible t0=0.8,r0=0.08\nvisible t0=0.7,r0=0.08\n", "channel visible given twice"},
        {"missing.glass", "spectral nowhere.tsv\n", "cannot open"},
    };
    char tmp[] = "/tmp/bst_glass_dirXXXXXX";
    ck_assert_ptr_nonnull(mkdtemp(tmp));
    char path[512], cmd[1200];
    /* the band spectra next to the files, and a good grey pane for the catalogue files */
    static const char *spectra[] = {"solar_ASTM_E891_87_Table1.tsv", "photopic_source_D65.tsv",
                                    "photopic_detector_V.tsv", "photopic_wavelength_set.tsv"};
    for (int i = 0; i < 4; i++) {
        snprintf(cmd, sizeof cmd, "cp '%s/%s' '%s/'", dir(), spectra[i], tmp);
        ck_assert_int_eq(system(cmd), 0);
    }
    snprintf(path, sizeof path, "%s/grey.tsv", tmp);
    FILE *fp = fopen(path, "w");
    fprintf(fp, "0.3 0.8 0.8 0.08 0.08\n2.5 0.8 0.8 0.08 0.08\n");
    fclose(fp);
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", tmp, files[i].name);
        fp = fopen(path, "w");
        fputs(files[i].text, fp);
        fclose(fp);
        char spec[600];
        size_t l = strlen(files[i].name);
        if (strcmp(files[i].name + l - 6, ".glass") == 0)
            snprintf(spec, sizeof spec, "%.*s", (int)(l - 6), files[i].name);
        else
            snprintf(spec, sizeof spec, "%s", path);
        expect_bad(spec, tmp, files[i].expect);
        if (strstr(files[i].expect, "line"))
            ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), files[i].name));
    }
    /* a line too long for the reader's buffer is an error, not two lines with its tail read as a
     * line of its own; a last line that just fits, without its newline, is read */
    static char text[6000];
    const char *const long_names[] = {"long.glass", "long.tsv", "fits.glass"};
    for (int i = 0; i < 3; i++) {
        if (i == 0)
            snprintf(text, sizeof text, "description %01500d\nVisible t0=0.8,r0=0.08\n", 0);
        else if (i == 1)
            snprintf(text, sizeof text, "# %05000d\n0.4 0.8 0.8 0.08 0.08\n0.5 0.8 0.8 0.08 0.08\n", 0);
        else /* 1023 characters and no newline: the catalogue's whole buffer */
            snprintf(text, sizeof text, "Visible t0=0.8,r0=0.08\ndescription %01011d", 0);
        snprintf(path, sizeof path, "%s/%s", tmp, long_names[i]);
        fp = fopen(path, "w");
        fputs(text, fp);
        fclose(fp);
        if (i == 2) {
            bst_glass *g;
            ck_assert_int_eq(bst_glass_parse(ctx, "fits", tmp, &g), BST_OK);
            ck_assert_uint_eq(strlen(bst_glass_description(g)), 1011);
            bst_glass_free(g);
        } else {
            expect_bad(i == 0 ? "long" : path, tmp,
                       i == 0 ? "line 1 is longer than 1022 characters"
                              : "line 1 is longer than 4094 characters");
        }
    }
    /* a directory is not a readable data file; band spectra missing from the catalogue */
    snprintf(path, sizeof path, "%s/", tmp);
    expect_bad(path, tmp, "");
    snprintf(path, sizeof path, "%s/grey.tsv", tmp);
    expect_bad(path, "/nonexistent-dir", "solar_ASTM_E891_87_Table1.tsv: cannot open");
    /* the good grey pane works from this catalogue */
    bst_glass *g;
    ck_assert_int_eq(bst_glass_parse(ctx, path, tmp, &g), BST_OK);
    bst_glass_free(g);
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmp);
    ck_assert_int_eq(system(cmd), 0);
}
END_TEST

/* Channel ca of a and channel cb of b give the same Tf, Tb, Rf and Rb, bit for bit, every 7.5
 * degrees. */
static void same_optics(const bst_glass *a, size_t ca, const bst_glass *b, size_t cb)
{
    for (double t = 0; t <= 90; t += 7.5) {
        double v[4], w[4];
        bst_glass_optics(a, ca, deg(t), &v[0], &v[1], &v[2], &v[3]);
        bst_glass_optics(b, cb, deg(t), &w[0], &w[1], &w[2], &w[3]);
        for (int q = 0; q < 4; q++)
            ck_assert_double_eq(v[q], w[q]);
    }
}

/* Rows lo..hi um (inclusive) of the shipped NFRC 103 table written to dirname/name; the path. */
static const char *nfrc103_rows(const char *dirname, const char *name, double lo, double hi)
{
    static char path[600];
    char src[600], line[256];
    snprintf(src, sizeof src, "%s/spectral_NFRC_103.tsv", dir());
    snprintf(path, sizeof path, "%s/%s", dirname, name);
    FILE *in = fopen(src, "r"), *out = fopen(path, "w");
    ck_assert_ptr_nonnull(in);
    ck_assert_ptr_nonnull(out);
    while (fgets(line, sizeof line, in)) {
        double wl;
        if (sscanf(line, "%lf", &wl) != 1 || (wl >= lo && wl <= hi))
            fputs(line, out); /* comments, the column names and the rows kept */
    }
    fclose(in);
    fclose(out);
    return path;
}

/* Data that cover only part of a band are refused when averaged over it, with one line naming the
 * file, the data's range and the band's, not averaged over the part they cover (NFRC 103 cut at
 * 0.78 um gave Solar T 0.8425 for 0.7707, cut below 0.6 um Visible T 0.8690 for 0.8836); the ends
 * count to 1e-6 um.  A pane of visible data averaged over the colour bands alone is fine and gives
 * the full data's Visible to the bit; asked for Solar later, it says why not and keeps its
 * channels.  A shade material's rows (bsti_glass_band_average) follow the same rule. */
START_TEST(test_band_coverage)
{
    char tmp[] = "/tmp/bst_glass_coverXXXXXX", cmd[1200], want[1400];
    ck_assert_ptr_nonnull(mkdtemp(tmp));
    static const char *spectra[] = {"solar_ASTM_E891_87_Table1.tsv", "photopic_source_D65.tsv",
                                    "photopic_detector_V.tsv", "photopic_wavelength_set.tsv"};
    for (int i = 0; i < 4; i++) {
        snprintf(cmd, sizeof cmd, "cp '%s/%s' '%s/'", dir(), spectra[i], tmp);
        ck_assert_int_eq(system(cmd), 0);
    }
    const char *p = nfrc103_rows(tmp, "to078.tsv", 0.0, 0.78);
    snprintf(want, sizeof want, "%s: the data cover 0.3..0.78 um; the Solar band needs 0.3..2.5 um",
             p);
    expect_bad(p, tmp, want);
    ck_assert_str_eq(bst_ctx_message(ctx), want);
    p = nfrc103_rows(tmp, "from06.tsv", 0.6, 9.0);
    snprintf(want, sizeof want,
             "%s: the data cover 0.6..2.5 um; the Visible band needs 0.38..0.78 um", p);
    expect_bad(p, tmp, want);
    ck_assert_str_eq(bst_ctx_message(ctx), want);

    /* the visible rows, averaged over the bands they cover */
    nfrc103_rows(tmp, "vis.tsv", 0.38, 0.78);
    snprintf(cmd, sizeof cmd, "%s/vis.glass", tmp);
    FILE *fp = fopen(cmd, "w");
    fputs("spectral vis.tsv Visible CIE-X CIE-Y CIE-Z\n", fp);
    fclose(fp);
    bst_glass *vis, *full = parse("nfrc-103");
    size_t fv = (size_t)bst_glass_find_channel(full, "Visible");
    ck_assert_int_eq(bst_glass_parse(ctx, "vis", tmp, &vis), BST_OK);
    ck_assert_uint_eq(bst_glass_nchannels(vis), 4);
    same_optics(vis, 0, full, fv);
    ck_assert_int_eq(bst_glass_add_channel(ctx, vis, "Solar"), BST_EFORMAT);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx),
                                 "the data cover 0.38..0.78 um; the Solar band needs 0.3..2.5 um"));
    ck_assert_uint_eq(bst_glass_nchannels(vis), 4);
    ck_assert_int_eq(bst_glass_find_channel(vis, "Solar"), -1);
    bst_glass_free(vis);
    /* the same data as a file spec: refused for Visible and Solar (bst_glass_parse), taken by a
       caller that asks for the bands they cover (bst_glass_parse_bands), with NFRC 103's values */
    snprintf(cmd, sizeof cmd, "%s/vis.tsv", tmp);
    ck_assert_int_eq(bst_glass_parse(ctx, cmd, tmp, &vis), BST_EFORMAT);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "the Solar band needs 0.3..2.5 um"));
    static const char *const vis_only[] = {"Visible", "Tvis-extra", "visible", "CIE-X"};
    ck_assert_int_eq(bst_glass_parse_bands(ctx, cmd, tmp, 4, vis_only, &vis), BST_OK);
    ck_assert_uint_eq(bst_glass_nchannels(vis), 2); /* Visible and CIE-X, once each */
    ck_assert_str_eq(bst_glass_channel(vis, 0), "Visible");
    same_optics(vis, 0, full, fv);
    bst_glass_free(vis);
    static const char *const both[] = {"Visible", "Solar"};
    ck_assert_int_eq(bst_glass_parse_bands(ctx, cmd, tmp, 2, both, &vis), BST_EFORMAT);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "the Solar band needs 0.3..2.5 um"));
    bst_glass_free(full);

    /* the ends to 1e-6 um: within it a grey pane is the grey inline pane, past it refused */
    static const struct { double lo, hi; int ok; } ends[] = {
        {0.3 + 5e-7, 2.5 - 5e-7, 1}, {0.3 + 2e-6, 2.5, 0}, {0.3, 2.5 - 2e-6, 0},
    };
    bst_glass *grey = parse("t0=0.8,r0=0.08");
    for (size_t i = 0; i < sizeof ends / sizeof ends[0]; i++) {
        snprintf(cmd, sizeof cmd, "%s/grey%zu.tsv", tmp, i);
        fp = fopen(cmd, "w");
        fprintf(fp, "%.9f 0.8 0.8 0.08 0.08\n1.0 0.8 0.8 0.08 0.08\n%.9f 0.8 0.8 0.08 0.08\n",
                ends[i].lo, ends[i].hi);
        fclose(fp);
        bst_glass *g = NULL;
        int rc = bst_glass_parse(ctx, cmd, tmp, &g);
        if (!ends[i].ok) {
            ck_assert_int_eq(rc, BST_EFORMAT);
            ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "the Solar band needs 0.3..2.5 um"));
            continue;
        }
        ck_assert_msg(rc == BST_OK, "%s: %s", cmd, bst_ctx_message(ctx));
        for (size_t ch = 0; ch < 2; ch++) {
            double v[4], w[4];
            bst_glass_optics(g, ch, deg(40), &v[0], &v[1], &v[2], &v[3]);
            bst_glass_optics(grey, 0, deg(40), &w[0], &w[1], &w[2], &w[3]);
            for (int q = 0; q < 4; q++)
                tu_assert_close(v[q], w[q], 1e-13, 1e-13);
        }
        bst_glass_free(g);
    }
    bst_glass_free(grey);

    /* a shade material's rows: Visible from visible rows, not Solar */
    double wl[] = {0.3, 0.5, 0.78}, t[] = {0.1, 0.1, 0.1}, rf[] = {0.6, 0.6, 0.6},
           rb[] = {0.3, 0.3, 0.3}, v[4];
    const struct bsti_glass_data d = {3, wl, t, t, rf, rb};
    ck_assert_int_eq(bsti_glass_band_average(ctx, &d, dir(), "Visible", "shade.json", v), BST_OK);
    tu_assert_close(v[0], 0.1, 1e-14, 1e-14);
    ck_assert_int_eq(bsti_glass_band_average(ctx, &d, dir(), "Solar", "shade.json", v),
                     BST_EFORMAT);
    ck_assert_str_eq(bst_ctx_message(ctx),
                     "shade.json: the data cover 0.3..0.78 um; the Solar band needs 0.3..2.5 um");

    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmp);
    ck_assert_int_eq(system(cmd), 0);
}
END_TEST

/* Every allocation failure is reported as BST_ENOMEM, leaves no object and leaks nothing: parsing,
 * adding a band, building a layer (patch averages for band panes, centres for the spectral one,
 * whose angular table would make 100 builds slow). */
/* One spec parsed and turned into a layer (tg_alloc_sweep's step); spec is "NAME" or, for the
 * layer at patch centres, "NAME" after a '@'. */
static int pane_layer(bst_ctx *c, void *arg)
{
    const char *spec = arg;
    int centre = *spec == '@';
    bst_glass *g = (bst_glass *)1;
    bst_basis *b = NULL;
    bst_layer *l = (bst_layer *)1;
    int rc = bst_glass_parse(c, spec + centre, dir(), &g);
    if (rc < 0)
        ck_assert_ptr_null(g);
    if (rc >= 0 && bst_glass_nwavelengths(g))
        rc = bst_glass_add_channel(c, g, "CIE-X");
    if (rc >= 0)
        rc = bst_basis_new_sc(c, 2, &b);
    if (rc >= 0) {
        rc = bst_glass_layer(c, g, b, 0, NULL, centre, &l);
        if (rc < 0)
            ck_assert_ptr_null(l);
        else
            bst_layer_free(l);
    }
    bst_basis_free(b);
    if (g != (bst_glass *)1)
        bst_glass_free(g);
    return rc;
}

START_TEST(test_alloc_failure)
{
    static char specs[3][24] = {"@nfrc-102", "clear-6mm", "d=6mm,n=1.5,k=20"};
    for (size_t s = 0; s < 3; s++)
        tg_alloc_sweep(specs[s], 400, pane_layer, specs[s]);
}
END_TEST

static Suite *glass_suite(void)
{
    Suite *s = suite_create("glass");
    TCase *tc = tcase_create("glass");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, test_wce_mono);
    tcase_add_test(tc, test_no_reflection_limit);
    tcase_add_test(tc, test_wce_per_wavelength);
    tcase_add_test(tc, test_wce_band_averages);
    tcase_add_test(tc, test_wce_klems_diagonal);
    tcase_add_test(tc, test_wce_two_panes_solar);
    tcase_add_test(tc, test_wce_two_panes_visible);
    tcase_add_test(tc, test_channel_weights);
    tcase_add_test(tc, test_single_interface);
    tcase_add_test(tc, test_slab);
    tcase_add_test(tc, test_tn_spec);
    tcase_add_test(tc, test_grazing);
    tcase_add_test(tc, test_asymmetric_and_args);
    tcase_add_test(tc, test_cie_bands);
    tcase_add_test(tc, test_layer_sc);
    tcase_add_test(tc, test_layer_klems);
    tcase_add_test(tc, test_layer_table);
    tcase_add_test(tc, test_layer_channels);
    tcase_add_test(tc, test_panes_by_stack);
    tcase_add_test(tc, test_bad_specs);
    tcase_add_test(tc, test_bad_files);
    tcase_add_test(tc, test_band_coverage);
    tcase_add_test(tc, test_alloc_failure);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(glass_suite());
}
