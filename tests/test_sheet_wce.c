/* test_sheet_wce.c - WINDOW's models of perforated screens and woven fabrics (rule=centre of
 * perforated: and woven: specs, sheet_wce.c; issue #32) against values nobody here computed:
 *  - 20 scalars that Windows-CalcEngine's own unit tests assert (v1.0.75, the suite that
 *    shared/reference/wce/README.md describes), with each test's inputs typed in as it sets them
 *    and its tolerance: diffuse-diffuse and directional-hemispherical values and matrix entries
 *    of screens and fabrics in WCE's quarter basis (= Klems quarter), a fabric cell's values at
 *    single directions, and WINDOW's systems of NFRC 102 with a dual-band screen (WCE's Small
 *    basis) and fabric (quarter) combined per wavelength;
 *  - closed forms: each patch's diagonal is the open share of its centre direction over Lambda
 *    (WCE's formulas typed in here from its description), every other entry (1 - F_i) r / pi or
 *    t / pi; a sheet of zero thickness passes its open area, is reciprocal and equals the default
 *    model (whose open share is then constant over every patch); lossless sheets conserve energy
 *    (the fabric's scattering through the threads moves light from R to T); a dual-band Solar
 *    channel is WINDOW's f : 1 - f weighing of the layers of the visible values and of the values
 *    outside the visible range;
 *  - bad specs name their key; every allocation failing in turn leaks nothing. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"
#include "venetian.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static const char *const one[] = {"X"};

/* The layer of a perforated: (p) or woven: spec over b, one channel, or two (Visible, Solar)
 * with dual. */
static bst_layer *layer(const char *spec, const bst_basis *b, int dual)
{
    bst_layer *l = NULL;
    int rc;
    if (strncmp(spec, "woven:", 6) == 0) {
        bst_woven w;
        rc = bst_woven_parse(ctx, spec + 6, &w);
        if (rc >= 0)
            rc = bst_woven_layer(ctx, &w, b, dual ? 0 : 1, dual ? NULL : one, &l);
    } else {
        bst_perforated p;
        rc = bst_perforated_parse(ctx, spec + 11, &p);
        if (rc >= 0)
            rc = bst_perforated_layer(ctx, &p, b, dual ? 0 : 1, dual ? NULL : one, &l);
    }
    ck_assert_msg(rc == BST_OK, "%s: %s", spec, bst_ctx_message(ctx));
    return l;
}

/* Component c of channel ch as a dense column-major n x n array (the caller frees it). */
static double *dense(const bst_layer *l, size_t ch, bst_comp c)
{
    size_t n = bst_basis_size(bst_layer_basis(l));
    double *a = malloc(n * n * sizeof *a);
    ck_assert_ptr_nonnull(a);
    ck_assert_int_eq(bst_mat_to_dense_array(ctx, bst_layer_get(l, ch, c), a), BST_OK);
    return a;
}

/* WCE's derived quantities (shared/reference/wce/README.md): diffuse-diffuse
 * sum_oi Lambda_o M(o, i) Lambda_i / pi, directional-hemispherical sum_o Lambda_o M(o, i). */
static double diffdiff(const bst_layer *l, bst_comp c)
{
    const bst_basis *b = bst_layer_basis(l);
    size_t n = bst_basis_size(b);
    const double *lam = bst_basis_lambda(b);
    double *a = dense(l, 0, c), s = 0;
    for (size_t i = 0; i < n; i++)
        for (size_t o = 0; o < n; o++)
            s += lam[o] * a[i * n + o] * lam[i] / M_PI;
    free(a);
    return s;
}

static double dirhem(const bst_layer *l, bst_comp c, size_t i)
{
    const bst_basis *b = bst_layer_basis(l);
    size_t n = bst_basis_size(b);
    double *a = dense(l, 0, c), s = 0;
    for (size_t o = 0; o < n; o++)
        s += bst_basis_lambda(b)[o] * a[i * n + o];
    free(a);
    return s;
}

static double entry(const bst_layer *l, bst_comp c, size_t o, size_t i)
{
    size_t n = bst_basis_size(bst_layer_basis(l));
    double *a = dense(l, 0, c), x = a[i * n + o];
    free(a);
    return x;
}

/* One asserted value: the layer of spec in WCE's quarter basis; quantity 0 diffuse-diffuse of
 * comp, 1 directional-hemispherical of comp at patch i (0-based), 2 the entry (o, i). */
struct assertion {
    const char *spec;
    int quantity;
    bst_comp comp;
    size_t o, i;
    double want, tol;
};

/* Inputs as the WCE tests set them (lengths in their units: only the ratios matter), materials
 * Material::singleBandMaterial(T, T, Rf, Rb). */
#define CIRC1 "perforated:x=22.5,y=38.1,thickness=5,radius=8.35,t=0.2,rf=0.75,rb=0.66,rule=centre"
#define NFRC18000 "perforated:x=1.69,y=1.69,thickness=0.23,radius=0.58,t=0,rf=0.137,rb=0.16,rule=centre"
#define RECT1 "perforated:x=19.05,y=19.05,thickness=0.6,hole-x=3.175,hole-y=6.35,t=0,r=0.7,rule=centre"
#define RECT2 "perforated:x=20,y=25,thickness=7,hole-x=5,hole-y=8,t=0.1,rf=0.5,rb=0.6,rule=centre"
#define WOVEN "woven:diameter=2,spacing=3,t=0,r=0.1,rule=centre"
static const struct assertion wce[] = {
    /* SingleLayerOptics/tst/units/CircularPerforatedShade1.unit.cpp,
     * TestCircularPerforatedShade1.TestSolarProperties (tolerance 1e-6): DiffDiff T and Rb, the
     * diagonal's first entry */
    {CIRC1, 0, BST_TF, 0, 0, 0.320845, 1e-6},
    {CIRC1, 0, BST_RB, 0, 0, 0.560303, 1e-6},
    {CIRC1, 2, BST_TF, 0, 0, 3.370933, 1e-6},
    /* CircularPerforatedShadeNFRC18000.unit.cpp, TestCircularPerforatedShadeNFRC18000
     * .TestSolarProperties (1e-6): DiffDiff T */
    {NFRC18000, 0, BST_TF, 0, 0, 0.257367, 1e-6},
    /* RectangularPerforatedShade1.unit.cpp, TestRectangularPerforatedShade1.TestSolarProperties:
     * DirHem T at (0, 0) (1e-6); T's diagonal at patches 34 and 36 (theta 76.5, phi 0 and 90;
     * 1e-5) */
    {RECT1, 1, BST_TF, 0, 0, 0.055556, 1e-6},
    {RECT1, 2, BST_TF, 33, 33, 0.146104, 1e-5},
    {RECT1, 2, BST_TF, 35, 35, 0.416249, 1e-5},
    /* RectangularPerforatedShade2.unit.cpp, TestRectangularPerforatedShade2.TestSolarProperties
     * (1e-6): DiffDiff T */
    {RECT2, 0, BST_TF, 0, 0, 0.112843786, 1e-6},
    /* WovenShadeUniformMaterial.unit.cpp, TestWovenShadeUniformMaterial.TestSolarProperties
     * (1e-6): DiffDiff T and Rf (the scattering through the threads included) */
    {WOVEN, 0, BST_TF, 0, 0, 0.037033896815761802, 1e-6},
    {WOVEN, 0, BST_RF, 0, 0, 0.096296610318422418, 1e-6},
};

START_TEST(test_wce_assertions)
{
    const struct assertion *a = &wce[_i];
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "quarter", &b), BST_OK);
    bst_layer *l = layer(a->spec, b, 0);
    double got = a->quantity == 0 ? diffdiff(l, a->comp)
               : a->quantity == 1 ? dirhem(l, a->comp, a->i) : entry(l, a->comp, a->o, a->i);
    printf("%s: quantity %d comp %d (%zu, %zu): %.9f, WCE %.9f (|d| %.2g, tolerance %g)\n", a->spec,
           a->quantity, (int)a->comp, a->o, a->i, got, a->want, fabs(got - a->want), a->tol);
    ck_assert_msg(fabs(got - a->want) <= a->tol, "%s: %.9f, WCE asserts %.9f within %g", a->spec,
                  got, a->want, a->tol);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* A fabric cell at single directions, WovenCell1.unit.cpp (diameter 6.35, spacing 19.05,
 * T 0.08, Rf = Rb 0.9; 1e-6): TestWoven4, T_dir_dir at theta 54, phi 270 = 0.100838024 (WCE's
 * Ty: not the angle in the YZ plane); TestWoven3, R_dir_dif at (78, 45) = 0.870608, (1 - F) R
 * less the scattering through the threads.  (WCE's T_dir_dif of these tests with T > 0, e.g.
 * 0.193195 at (54, 270), are its single-band path's (1 - F)^2 T + S; its per-wavelength path,
 * which WINDOW's systems use and this model follows, gives (1 - F) T + S.) */
START_TEST(test_wce_woven_cell)
{
    bst_woven w;
    ck_assert_int_eq(bst_woven_parse(ctx, "diameter=6.35,spacing=19.05,t=0.08,r=0.9,rule=centre", &w),
                     BST_OK);
    static const double dirs[2][2] = {{54, 270}, {78, 45}};
    for (int k = 0; k < 2; k++) {
        double th = dirs[k][0] * M_PI / 180, ph = dirs[k][1] * M_PI / 180;
        double d[3] = {sin(th) * cos(ph), sin(th) * sin(ph), cos(th)};
        double F = bsti_woven_wce_open(&w, d), S = bsti_woven_wce_scatter(&w, d, 0.9);
        double got = k == 0 ? F : (1 - F) * 0.9 - S, want = k == 0 ? 0.100838024 : 0.870608;
        printf("woven cell (%g, %g): %.9f, WCE %.9f\n", dirs[k][0], dirs[k][1], got, want);
        ck_assert_msg(fabs(got - want) <= 1e-6, "(%g, %g): %.9f, WCE %.9f", dirs[k][0], dirs[k][1],
                      got, want);
    }
}
END_TEST

/* NFRC 102 (exterior) and a shade's WINDOW layer (Visible and Solar channels) combined per
 * wavelength as WCE combines them (test_wce.c's pane_shade_case), solar; out[0..5]: front
 * diffuse-diffuse T and R, T and R directional-hemispherical and direct-direct (Lambda_j M(j, j))
 * at patch j. */
static void pane_shade(const char *spec, const bst_basis *b, size_t j, double out[6])
{
    bst_glass *g;
    ck_assert_int_eq(bst_glass_parse(ctx, "nfrc-102", getenv("BSDFSTACK_GLASS_DIR"), &g), BST_OK);
    bst_layer *shade = layer(spec, b, 1), *r;
    bst_spectral_layer l[2] = {{.pane = g}, {.bands = shade}};
    bst_spectral_opts so;
    bst_spectral_opts_init(&so);
    so.at_centre = 1;
    so.tol = 0; /* WCE combines every wavelength */
    int rc = bst_stack_combine_spectral_layers(ctx, 2, l, b, 1, (const char *const[]){"Solar"}, &so,
                                               NULL, &r, NULL, NULL);
    ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    out[0] = diffdiff(r, BST_TF), out[1] = diffdiff(r, BST_RF);
    out[2] = dirhem(r, BST_TF, j), out[3] = dirhem(r, BST_RF, j);
    out[4] = entry(r, BST_TF, j, j) * bst_basis_lambda(b)[j];
    out[5] = entry(r, BST_RF, j, j) * bst_basis_lambda(b)[j];
    bst_layer_free(r), bst_layer_free(shade);
    bst_glass_free(g);
}

/* WINDOW's systems: MultiLayerOptics/tst/units/MultiPaneBSDF_102_PerforatedRectangular.unit.cpp
 * (TestPerforatedRectangular: WCE's Small basis) and MultiPaneBSDF_102_Woven.unit.cpp
 * (TestWovenShade: quarter basis), NFRC 102 (3.048 mm) and a screen or fabric of dual-band
 * material (solar T 0.1, R 0.7; visible T 0.2, R 0.6), solar (ASTM E891, its own wavelengths),
 * tolerance 1e-6: front DiffDiff T and R, and at (0, 0) DirHem T (screen) or R (fabric), at
 * (45, 78) DirDir T (patch 4 of the Small basis, 13 of the quarter: 45 degrees is the lower ring's
 * upper limit, 78 lies in the 30-degree patch of phi 90). */
START_TEST(test_wce_pane_shade)
{
    bst_basis *b = _i ? NULL : tu_wce_basis(ctx, "basis_wce_small.tsv");
    if (_i)
        ck_assert_int_eq(bst_basis_new_klems(ctx, "quarter", &b), BST_OK);
    const char *spec = _i ? "woven:diameter=0.1,spacing=0.3,t=0.2/0.1,r=0.6/0.7,rule=centre"
                          : "perforated:x=19.05,y=19.05,thickness=5,hole-x=5,hole-y=5,t=0.2/0.1,"
                            "r=0.6/0.7,rule=centre";
    static const double want[2][4] = {{0.101574414, 0.574081179, 0.150277087, 0.0320930672},
                                      {0.337833142, 0.4118198, 0.325823919, 0.305055792}};
    double o0[6], o45[6];
    pane_shade(spec, b, 0, o0);
    pane_shade(spec, b, _i ? 12 : 3, o45);
    const double got[4] = {o0[0], o0[1], _i ? o0[3] : o0[2], o45[4]};
    for (int k = 0; k < 4; k++) {
        printf("NFRC 102 + %s: %d: %.9f, WCE %.9f (|d| %.2g)\n", spec, k, got[k], want[_i][k],
               fabs(got[k] - want[_i][k]));
        ck_assert_msg(fabs(got[k] - want[_i][k]) <= 1e-6, "%s: value %d %.9f, WCE %.9f", spec, k,
                      got[k], want[_i][k]);
    }
    bst_basis_free(b);
}
END_TEST

/* WCE's open shares, typed in from its description: circles (pi a^2 - pi a d tan(theta) / 2) /
 * (x y) up to tan(theta) = 2 a / d, rectangles the product of (hole - d |tan|)+ / pitch per axis. */
static double open_circle(double x, double y, double a, double d, const double u[3])
{
    double tn = hypot(u[0], u[1]) / u[2];
    if (d > 0 && tn > 2 * a / d)
        return 0.0;
    return (M_PI * a * a - M_PI * a * d * tn / 2) / (x * y);
}

static double open_rect(double x, double y, double hx, double hy, double d, const double u[3])
{
    return fmax(0.0, hx - d * fabs(u[0] / u[2])) / x * fmax(0.0, hy - d * fabs(u[1] / u[2])) / y;
}

/* Klems full: every column is F_i / Lambda_i on the diagonal (transmissions) plus (1 - F_i) t /
 * pi (or rf, rb / pi for the reflections) everywhere, F_i the open share of patch i's centre. */
START_TEST(test_centre_closed_form)
{
    static const char *const specs[] = {
        "perforated:x=5mm,y=4mm,radius=1.5mm,thickness=1mm,rf=0.6,rb=0.3,t=0.1,rule=centre",
        "perforated:x=5mm,y=4mm,hole-x=2mm,hole-y=3mm,thickness=1.5mm,rf=0.6,rb=0.3,t=0.1,rule=centre"};
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &b), BST_OK);
    bst_layer *l = layer(specs[_i], b, 0);
    size_t n = bst_basis_size(b);
    const double *lam = bst_basis_lambda(b);
    double *m[BST_NCOMP], worst = 0;
    const double scat[BST_NCOMP] = {[BST_TF] = 0.1, [BST_TB] = 0.1, [BST_RF] = 0.6, [BST_RB] = 0.3};
    for (int c = 0; c < BST_NCOMP; c++)
        m[c] = dense(l, 0, (bst_comp)c);
    for (size_t i = 0; i < n; i++) {
        double u[3];
        bst_basis_center(b, i, u);
        double F = _i ? open_rect(5, 4, 2, 3, 1.5, u) : open_circle(5, 4, 1.5, 1, u);
        for (int c = 0; c < BST_NCOMP; c++)
            for (size_t o = 0; o < n; o++) {
                double want = (1 - F) * scat[c] / M_PI;
                if (o == i && (c == BST_TF || c == BST_TB))
                    want += F / lam[i];
                worst = fmax(worst, fabs(m[c][i * n + o] - want) / fmax(1.0, fabs(want)));
            }
    }
    printf("%s: closed form to %.3g\n", specs[_i], worst);
    ck_assert_msg(worst < 1e-13, "%s: off the closed form by %g", specs[_i], worst);
    for (int c = 0; c < BST_NCOMP; c++)
        free(m[c]);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* Fabric: the open share of a centre, (T(i, i) - T(o, i)) Lambda_i for any o != i (the scattered
 * part is one constant a column), is (1 - g)^2 at the normal and (1 - g / cos theta)+ (1 - g) at
 * the centres of azimuth 0, g = diameter / spacing. */
START_TEST(test_woven_closed_form)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &b), BST_OK);
    bst_layer *l = layer("woven:diameter=0.5mm,spacing=1.6mm,r=0.6,t=0.1,rule=centre", b, 0);
    const double *lam = bst_basis_lambda(b), g = 0.5 / 1.6;
    static const size_t first[] = {0, 1, 9, 25, 45, 69, 93, 117, 133}; /* phi = 0 of each ring */
    for (size_t k = 0; k < sizeof first / sizeof first[0]; k++) {
        double u[3];
        bst_basis_center(b, first[k], u);
        ck_assert(fabs(u[1]) < 1e-15);
        double want = fmax(0.0, 1 - g / u[2]) * (1 - g);
        size_t i = first[k], o = i ? 0 : 1;
        double got = (entry(l, BST_TF, i, i) - entry(l, BST_TF, o, i)) * lam[i];
        double gotb = (entry(l, BST_TB, i, i) - entry(l, BST_TB, o, i)) * lam[i];
        ck_assert_msg(fabs(got - want) < 1e-13 && fabs(gotb - want) < 1e-13,
                      "patch %zu: open %.15g, %.15g, want %.15g", first[k], got, gotb, want);
        if (k == 0)
            ck_assert(fabs(want - (1 - g) * (1 - g)) < 1e-15);
    }
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* Lossless sheets (r + t = 1 both faces): T + R = 1 at every patch, both sides, in Klems full
 * and at k = 3; the fabric's scattering only moves light from R to T. */
START_TEST(test_energy)
{
    static const char *const specs[] = {
        "perforated:x=5mm,y=4mm,radius=1.5mm,thickness=1mm,r=0.7,t=0.3,rule=centre",
        "perforated:x=5mm,y=4mm,hole-x=2mm,hole-y=3mm,thickness=1.5mm,r=0.2,t=0.8,rule=centre",
        "woven:diameter=0.5mm,spacing=1.6mm,r=0.7,t=0.3,rule=centre",
        "woven:diameter=1mm,spacing=1.5mm,r=0.95,t=0.05,rule=centre"};
    for (int kb = 0; kb < 2; kb++) {
        bst_basis *b;
        ck_assert_int_eq(kb ? bst_basis_new_sc(ctx, 3, &b) : bst_basis_new_klems(ctx, "full", &b), BST_OK);
        bst_layer *l = layer(specs[_i], b, 0);
        size_t n = bst_basis_size(b);
        double *h[BST_NCOMP], worst = 0;
        for (int c = 0; c < BST_NCOMP; c++) {
            h[c] = malloc(n * sizeof *h[c]);
            ck_assert_int_eq(bst_layer_hemispherical(ctx, l, 0, (bst_comp)c, h[c]), BST_OK);
        }
        for (size_t i = 0; i < n; i++)
            worst = fmax(worst, fmax(fabs(h[BST_TF][i] + h[BST_RF][i] - 1),
                                     fabs(h[BST_TB][i] + h[BST_RB][i] - 1)));
        printf("%s (%s): |T + R - 1| at most %.3g\n", specs[_i], kb ? "k = 3" : "Klems full", worst);
        ck_assert_msg(worst < 1e-12, "%s: energy off by %g", specs[_i], worst);
        for (int c = 0; c < BST_NCOMP; c++)
            free(h[c]);
        bst_layer_free(l);
        bst_basis_free(b);
    }
}
END_TEST

/* Zero thickness: the open area at every patch; the centre rule's layer is the default's (the
 * open share is constant over every patch, and the default's reciprocal spreading is then WCE's
 * uniform one) and reciprocal; a thick sheet's WINDOW layer is not (every column one constant). */
START_TEST(test_zero_thickness)
{
    static const char *const specs[] = {"perforated:x=5mm,y=4mm,radius=1.5mm,rf=0.6,rb=0.3,t=0.1",
                                        "perforated:x=5mm,y=4mm,hole-x=2mm,hole-y=3mm,r=0.5,t=0.2"};
    const double area[] = {M_PI * 1.5 * 1.5 / 20, 6.0 / 20};
    for (int kb = 0; kb < 2; kb++) {
        bst_basis *b;
        ck_assert_int_eq(kb ? bst_basis_new_sc(ctx, 3, &b) : bst_basis_new_klems(ctx, "full", &b), BST_OK);
        char spec[200];
        snprintf(spec, sizeof spec, "%s,rule=centre", specs[_i]);
        bst_layer *lc = layer(spec, b, 0), *la = layer(specs[_i], b, 0);
        size_t n = bst_basis_size(b);
        double worst = 0, err;
        for (int c = 0; c < BST_NCOMP; c++) {
            double *x = dense(lc, 0, (bst_comp)c), *y = dense(la, 0, (bst_comp)c);
            for (size_t q = 0; q < n * n; q++)
                worst = fmax(worst, fabs(x[q] - y[q]) / fmax(1.0, fabs(y[q])));
            if (c == BST_TF)
                for (size_t i = 0; i < n; i++) { /* the diagonal less the column's constant */
                    double F = (x[i * n + i] - x[i * n + (i ? 0 : 1)]) * bst_basis_lambda(b)[i];
                    ck_assert_msg(fabs(F - area[_i]) < 1e-14, "%s patch %zu: open %.15g, area %.15g",
                                  spec, i, F, area[_i]);
                }
            free(x), free(y);
        }
        printf("%s: the two rules differ by %.3g\n", spec, worst);
        ck_assert_msg(worst < 1e-13, "%s: the rules differ by %g", spec, worst);
        ck_assert_int_eq(bst_metrics_reciprocity(ctx, lc, 0, &err, NULL, NULL), BST_OK);
        ck_assert_msg(err < 1e-12, "%s: reciprocity %g", spec, err);
        bst_layer_free(lc), bst_layer_free(la);
        snprintf(spec, sizeof spec, "%s,thickness=1mm,rule=centre", specs[_i]);
        lc = layer(spec, b, 0);
        ck_assert_int_eq(bst_metrics_reciprocity(ctx, lc, 0, &err, NULL, NULL), BST_OK);
        printf("%s: reciprocity error %.3g\n", spec, err);
        ck_assert_msg(err > 1e-5, "%s: reciprocal after all (%g)", spec, err);
        bst_layer_free(lc);
        bst_basis_free(b);
    }
}
END_TEST

/* Dual-band values: the Solar channel is 0.499 x the layer of the visible values + 0.501 x that
 * of (solar - 0.499 visible) / 0.501; the Visible channel the visible values' layer. */
START_TEST(test_dual_band)
{
    static const char *const kinds[] = {"perforated:x=5mm,y=4mm,radius=1.5mm,thickness=1mm",
                                        "woven:diameter=0.5mm,spacing=1.6mm"};
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "quarter", &b), BST_OK);
    char spec[300];
    snprintf(spec, sizeof spec, "%s,rf=0.6/0.7,rb=0.5/0.4,t=0.2/0.1,rule=centre", kinds[_i]);
    bst_layer *l = layer(spec, b, 1);
    const double f = 0.499, rf = (0.7 - f * 0.6) / (1 - f), rb = (0.4 - f * 0.5) / (1 - f),
                 t = (0.1 - f * 0.2) / (1 - f);
    snprintf(spec, sizeof spec, "%s,rf=0.6,rb=0.5,t=0.2,rule=centre", kinds[_i]);
    bst_layer *lv = layer(spec, b, 0);
    snprintf(spec, sizeof spec, "%s,rf=%.17g,rb=%.17g,t=%.17g,rule=centre", kinds[_i], rf, rb, t);
    bst_layer *lo = layer(spec, b, 0);
    size_t n = bst_basis_size(b);
    for (int c = 0; c < BST_NCOMP; c++) {
        double *vis = dense(l, 0, (bst_comp)c), *sol = dense(l, 1, (bst_comp)c);
        double *v = dense(lv, 0, (bst_comp)c), *o = dense(lo, 0, (bst_comp)c), worst = 0;
        for (size_t q = 0; q < n * n; q++)
            worst = fmax(worst, fmax(fabs(vis[q] - v[q]), fabs(sol[q] - (f * v[q] + (1 - f) * o[q]))));
        ck_assert_msg(worst < 1e-13, "%s comp %d: off by %g", kinds[_i], c, worst);
        free(vis), free(sol), free(v), free(o);
    }
    bst_layer_free(l), bst_layer_free(lv), bst_layer_free(lo);
    bst_basis_free(b);
}
END_TEST

START_TEST(test_bad_specs)
{
    static const char *const bad[][2] = {
        {"perforated:x=5mm,y=5mm,radius=1mm,rule=middle", "rule"},
        {"perforated:x=5mm,y=5mm,radius=1mm,rule=centre,samples=4", "samples"},
        {"perforated:x=5mm,y=5mm,radius=1mm,rule=centre,distribution=uniform", "distribution"},
        {"perforated:x=5mm,y=5mm,radius=1mm,r=0.1/0.9,t=0.1/0.1,rule=centre", "outside the visible"},
        {"woven:diameter=1mm,spacing=2mm,rule=", "rule"},
        {"woven:diameter=1mm,spacing=2mm,samples=2,rule=centre", "samples"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        int rc;
        if (strncmp(bad[k][0], "woven:", 6) == 0) {
            bst_woven w;
            rc = bst_woven_parse(ctx, bad[k][0] + 6, &w);
        } else {
            bst_perforated p;
            rc = bst_perforated_parse(ctx, bad[k][0] + 11, &p);
        }
        ck_assert_msg(rc < 0, "%s accepted", bad[k][0]);
        ck_assert_msg(strstr(bst_ctx_message(ctx), bad[k][1]) != NULL, "%s: '%s' does not name %s",
                      bad[k][0], bst_ctx_message(ctx), bad[k][1]);
    }
    /* a struct filled by hand with a rule that is neither */
    bst_perforated p;
    ck_assert_int_eq(bst_perforated_parse(ctx, "x=5mm,y=5mm,radius=1mm", &p), BST_OK);
    p.rule = 7;
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "quarter", &b), BST_OK);
    bst_layer *l = NULL;
    ck_assert_int_eq(bst_perforated_layer(ctx, &p, b, 0, NULL, &l), BST_EINVAL);
    ck_assert_ptr_null(l);
    ck_assert(strstr(bst_ctx_message(ctx), "rule") != NULL);
    bst_basis_free(b);
}
END_TEST

/* Every allocation of the WINDOW layer failing in turn: BST_ENOMEM, no layer, nothing leaked. */
START_TEST(test_alloc_failure)
{
    long n = tu_shade_alloc_failures("woven", "diameter=0.5mm,spacing=1.6mm,r=0.6/0.7,t=0.1,rule=centre",
                                     "quarter");
    ck_assert_int_gt(n, 2);
}
END_TEST

static Suite *sheet_wce_suite(void)
{
    Suite *s = suite_create("sheet_wce");
    TCase *tc = tcase_create("sheet_wce");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 300);
    tcase_add_loop_test(tc, test_wce_assertions, 0, (int)(sizeof wce / sizeof wce[0]));
    tcase_add_test(tc, test_wce_woven_cell);
    tcase_add_loop_test(tc, test_wce_pane_shade, 0, 2);
    tcase_add_loop_test(tc, test_centre_closed_form, 0, 2);
    tcase_add_test(tc, test_woven_closed_form);
    tcase_add_loop_test(tc, test_energy, 0, 4);
    tcase_add_loop_test(tc, test_zero_thickness, 0, 2);
    tcase_add_loop_test(tc, test_dual_band, 0, 2);
    tcase_add_test(tc, test_bad_specs);
    tcase_add_test(tc, test_alloc_failure);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(sheet_wce_suite());
}
