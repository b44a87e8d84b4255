/* test_venetian_curved.c - curved venetian slats (bst_venetian with curvature > 0) against closed
 * forms and limits.  The ray-traced reference blinds of ../shared/reference are flat, so no
 * curved blind has a reference nobody here wrote; these are the checks:
 * - the arc bows as documented (crown towards +Y at tilt 0) and black slats pass the geometric
 *   openness of the arc, computed here from the arc's points (its circle through the two edges
 *   and the crown): 1 - (the extent of the slat's shadow across the direction) / spacing;
 * - lossless mirror slats conserve energy (T + R = 1 per incident patch to 1e-12), also crossed
 *   at +-90 deg; overlapping slats at +-90 deg pass no light;
 * - a concave face's exchange with itself against the inscribed-angle closed form, a convex face
 *   sees none of itself, deep arcs' exchange is reciprocal; lossless diffuse slats conserve energy to the radiosity's quadrature,
 *   and the segment count converges;
 * - curvature 1000 x width against the flat slat's layer; reciprocity; allocation failure. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"
#include "basis.h"
#include "venetian.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static bst_layer *blind(const char *spec, const bst_basis *b)
{
    bst_venetian v;
    ck_assert_msg(bst_venetian_parse(ctx, spec, &v) == BST_OK, "%s: %s", spec, bst_ctx_message(ctx));
    bst_layer *l = NULL;
    ck_assert_msg(bst_venetian_layer(ctx, &v, b, 0, NULL, &l) == BST_OK, "%s: %s", spec,
                  bst_ctx_message(ctx));
    return l;
}

static bst_basis *sc(int k)
{
    bst_basis *b = NULL;
    ck_assert_int_eq(bst_basis_new_sc(ctx, k, &b), BST_OK);
    return b;
}

/* All four directional-hemispherical components of channel 0, in the order of bst_comp. */
static double *all_hemi(const bst_layer *l)
{
    size_t n = bst_basis_size(bst_layer_basis(l));
    double *h = malloc(4 * n * sizeof *h);
    ck_assert_ptr_nonnull(h);
    for (int c = 0; c < 4; c++)
        ck_assert_int_eq(bst_layer_hemispherical(ctx, l, 0, (bst_comp)c, h + c * n), BST_OK);
    return h;
}

static double comp_of(const double *h, size_t n, bst_comp c, size_t i) { return h[(size_t)c * n + i]; }

/* The arc of a slat (width w, radius R, tilt in degrees) in the profile plane (y up, z from the
 * exterior to the interior), from the circle through its exterior edge (0, -w cos b), its interior
 * edge (w sin b, 0) and its crown, the chord's midpoint moved by the sagitta R - sqrt(R^2 - w^2/4)
 * towards +Y at tilt 0 (the normal (cos b, -sin b)).  npts points along it into y[], z[]. */
static void arc_points(double w, double R, double tilt, int npts, double *y, double *z)
{
    double b = tilt * M_PI / 180, sag = R - sqrt(R * R - w * w / 4);
    double p[3][2] = {{0, -w * cos(b)}, {w * sin(b), 0}, {0, 0}};
    p[2][0] = (p[0][0] + p[1][0]) / 2 + sag * cos(b);
    p[2][1] = (p[0][1] + p[1][1]) / 2 - sag * sin(b);
    /* circumcentre of the three points */
    double ax = p[0][0], ay = p[0][1], bx = p[1][0], by = p[1][1], cx = p[2][0], cy = p[2][1];
    double dd = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by));
    double ux = ((ax * ax + ay * ay) * (by - cy) + (bx * bx + by * by) * (cy - ay) + (cx * cx + cy * cy) * (ay - by)) / dd;
    double uy = ((ax * ax + ay * ay) * (cx - bx) + (bx * bx + by * by) * (ax - cx) + (cx * cx + cy * cy) * (bx - ax)) / dd;
    double t0 = atan2(ay - uy, ax - ux), t1 = atan2(by - uy, bx - ux), tc = atan2(cy - uy, cx - ux);
    /* from t0 to t1 the way that passes the crown */
    double span = remainder(t1 - t0, 2 * M_PI), via = remainder(tc - t0, 2 * M_PI);
    if ((via > 0) != (span > 0) || fabs(via) > fabs(span))
        span = span > 0 ? span - 2 * M_PI : span + 2 * M_PI;
    double rad = hypot(ax - ux, ay - uy);
    for (int k = 0; k < npts; k++) {
        double t = t0 + span * k / (npts - 1);
        y[k] = ux + rad * cos(t), z[k] = uy + rad * sin(t);
    }
}

/* The open share along profile angle phi (from the normal towards +Y; from the interior when
 * back): 1 - the extent of the arc's points projected along the direction on a plane z = const,
 * over the spacing, clipped at 0. */
static double arc_openness(const double *y, const double *z, int npts, double s, double phi, int back)
{
    double t = back ? -tan(phi) : tan(phi), lo = INFINITY, hi = -INFINITY;
    for (int k = 0; k < npts; k++) {
        double x = y[k] - t * z[k];
        lo = fmin(lo, x), hi = fmax(hi, x);
    }
    return fmax(0.0, 1.0 - (hi - lo) / s);
}

/* The bow (crown +Y at tilt 0: y from 0 to the sagitta) and black slats' geometric openness at
 * 1999 profile angles from both sides (the arc sampled at 200001 points: its extent short by
 * R (dphi)^2 / 8 at most, < 1e-11 here), for a shallow and a deep arc at three tilts; a layer of
 * one direction a patch passes exactly its share and reflects nothing. */
START_TEST(test_openness)
{
    static const struct { double tilt, R; } cases[] = {{0, 0.012}, {30, 0.012}, {-60, 0.012},
                                                       {0, 0.05}, {45, 0.008}, {80, 0.02}};
    const double w = 0.016, s = 0.0145, R = cases[_i].R, tilt = cases[_i].tilt;
    char spec[160];
    snprintf(spec, sizeof spec, "width=16mm,spacing=14.5mm,tilt=%g,curvature=%gmm", tilt, R * 1e3);
    bst_venetian v;
    ck_assert_int_eq(bst_venetian_parse(ctx, spec, &v), BST_OK);
    bsti_vn_geom g;
    bsti_vn_geom_init(&g, &v);
    enum { NPTS = 200001 };
    double *y = malloc(NPTS * sizeof *y), *z = malloc(NPTS * sizeof *z), worst = 0;
    ck_assert(y && z);
    arc_points(w, R, tilt, NPTS, y, z);
    if (tilt == 0) {
        double sag = R - sqrt(R * R - w * w / 4);
        ck_assert_msg(fabs(g.ylo) < 1e-15 && fabs(g.yhi - sag) < 1e-15, "tilt 0: y from %g to %g, "
                      "sagitta %g", g.ylo, g.yhi, sag);
    }
    for (int k = -999; k <= 999; k++) {
        double phi = k * (M_PI / 2) / 1000;
        double of = bsti_vn_open(&g, sin(phi), cos(phi)), ob = bsti_vn_open(&g, sin(phi), -cos(phi));
        worst = fmax(worst, fmax(fabs(of - arc_openness(y, z, NPTS, s, phi, 0)),
                                 fabs(ob - arc_openness(y, z, NPTS, s, phi, 1))));
    }
    printf("%s: |share - openness of the arc| at most %.3g\n", spec, worst);
    fflush(stdout);
    ck_assert_msg(worst < 1e-9, "%s: unobstructed share off by %g", spec, worst);
    bst_basis *b = sc(4);
    v.samples = 1;
    bst_layer *l = NULL;
    ck_assert_int_eq(bst_venetian_layer(ctx, &v, b, 0, NULL, &l), BST_OK);
    size_t n = bst_basis_size(b);
    double *h = all_hemi(l);
    for (size_t i = 0; i < n; i++) { /* the one point: Halton's first, (1/2, 1/3), from the
                                         exterior; its point reflection (1/2, 2/3) from the
                                         interior (venetian_layer.c, sample) */
        double d[3], e[3];
        bst_basis_sample(b, i, 0.5, 1.0 / 3, d);
        bst_basis_sample(b, i, 0.5, 2.0 / 3, e);
        double phi = atan2(d[1], d[2]), phib = atan2(e[1], e[2]);
        double of = arc_openness(y, z, NPTS, s, phi, 0), ob = arc_openness(y, z, NPTS, s, phib, 1);
        ck_assert_msg(fabs(comp_of(h, n, BST_TF, i) - of) < 1e-9 && fabs(comp_of(h, n, BST_TB, i) - ob) < 1e-9,
                      "%s patch %zu: Tf %.12g Tb %.12g, openness %.12g %.12g", spec, i,
                      comp_of(h, n, BST_TF, i), comp_of(h, n, BST_TB, i), of, ob);
        ck_assert(comp_of(h, n, BST_RF, i) == 0.0 && comp_of(h, n, BST_RB, i) == 0.0);
    }
    free(h), free(y), free(z);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* Lossless mirrors: T + R = 1 for every incident patch, both sides, to 1e-12. */
START_TEST(test_lossless_mirror)
{
    static const char *const specs[] = {
        "width=16mm,spacing=14.5mm,tilt=0,rs=1,curvature=12mm",
        "width=16mm,spacing=14.5mm,tilt=45,rs=1,curvature=8mm",
        "width=25mm,spacing=20mm,tilt=-70,rs=1,vertical,curvature=30mm",
        "width=16mm,spacing=14.5mm,tilt=30,rs=1,roughness=0.05,curvature=20mm",
        "width=16mm,spacing=12mm,tilt=90,rs=1,curvature=10mm"}; /* crossing neighbours */
    bst_basis *b = NULL;
    if (_i == 3)
        ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &b), BST_OK);
    else
        b = sc(4);
    bst_layer *l = blind(specs[_i], b);
    size_t n = bst_basis_size(b);
    double *h = all_hemi(l), worst = 0;
    for (size_t i = 0; i < n; i++) {
        double f = comp_of(h, n, BST_TF, i) + comp_of(h, n, BST_RF, i);
        double k = comp_of(h, n, BST_TB, i) + comp_of(h, n, BST_RB, i);
        worst = fmax(worst, fmax(fabs(f - 1), fabs(k - 1)));
        ck_assert_msg(fabs(f - 1) < 1e-12 && fabs(k - 1) < 1e-12, "%s patch %zu: Tf + Rf = %.15g, "
                      "Tb + Rb = %.15g", specs[_i], i, f, k);
    }
    printf("%s: |T + R - 1| at most %.3g\n", specs[_i], worst);
    fflush(stdout);
    free(h);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* Closed at +-90 deg when the slats overlap (w >= s): each arc's shadow holds its chord's, so
 * no direction passes, and the arcs (crossing their neighbours when w > s, touching when w = s)
 * leave no path through: T = 0 exactly from both sides for mirror slats; diffuse slats touching
 * edge to edge to rounding (1e-16 measured).  (Diffuse slats that cross, w > s, let the
 * uniform radiosity of a strip partly hidden behind the crossing leak through: 0.01 measured at
 * w = 16 mm, s = 14.5 mm, R = 40 mm; the man page says so.) */
START_TEST(test_closed)
{
    static const char *const specs[] = {
        "width=16mm,spacing=14.5mm,tilt=90,rs=0.7,curvature=12mm",
        "width=16mm,spacing=16mm,tilt=-90,rs=0.7,curvature=8mm",
        "width=16mm,spacing=16mm,tilt=90,rs=0.5,r=0.3,curvature=40mm,vertical"};
    bst_basis *b = sc(3);
    bst_layer *l = blind(specs[_i], b);
    size_t n = bst_basis_size(b);
    double *h = all_hemi(l);
    double bar = _i == 2 ? 1e-12 : 0.0; /* rounding at the touching edges, diffuse part */
    for (size_t i = 0; i < n; i++)
        ck_assert_msg(comp_of(h, n, BST_TF, i) <= bar && comp_of(h, n, BST_TB, i) <= bar,
                      "%s: patch %zu passes %g / %g", specs[_i], i, comp_of(h, n, BST_TF, i),
                      comp_of(h, n, BST_TB, i));
    free(h);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* The strips' exchange G for black-mirrored (rs = 0) slats bowed 3.06 mm (R 12 mm) at tilt 0, whose
 * neighbour's crown stays below the concave face's chord: from a point of a circle, the share of
 * its 2-D Lambertian emission reaching the arc at central angles g1..g2 (measured from it) is
 * |cos(g1/2) - cos(g2/2)| / 2 (the inscribed angle); averaged here over 2000 points of the
 * emitting strip.  A concave strip sees itself and the other concave strips so, to the exchange's
 * quadrature (64 x 64 rays a strip); a convex strip sees no convex strip. */
START_TEST(test_exchange)
{
    bst_venetian v;
    ck_assert_int_eq(bst_venetian_parse(ctx, "width=16mm,spacing=14.5mm,curvature=12mm,segments=6", &v),
                     BST_OK);
    bsti_vn_geom g;
    bsti_vn_geom_init(&g, &v);
    const int m = 6, n = 2 * m;
    double gm[144], worst = 0, th = 2 * asin(0.016 / (2 * 0.012));
    bsti_vn_exchange(&g, gm);
    for (int j = 0; j < m; j++)
        for (int e = 0; e < m; e++) {
            ck_assert_msg(gm[e * n + j] == 0.0, "convex strip %d sees convex strip %d", j, e);
            double f = 0;
            for (int p = 0; p < 2000; p++) { /* the emitter's arc angle, the receiver's ends */
                double x = th * (j + (p + 0.5) / 2000) / m, g1 = th * e / m - x, g2 = th * (e + 1) / m - x;
                /* central angles from the emitter, both ways round: the part on each side */
                double a = fabs(cos(fmax(g1, 0) / 2) - cos(fmax(g2, 0) / 2));
                double c = fabs(cos(fmax(-g2, 0) / 2) - cos(fmax(-g1, 0) / 2));
                f += (a + c) / 2 / 2000;
            }
            double got = gm[(m + e) * n + m + j];
            worst = fmax(worst, fabs(got - f));
            ck_assert_msg(fabs(got - f) < 2e-3, "concave strip %d to %d: %.5f, closed form %.5f", j,
                          e, got, f);
        }
    printf("concave face's exchange with itself: |G - closed form| at most %.2g\n", worst);
    fflush(stdout);
    /* deep arcs close together (the neighbour and the slat's own bulge hide strips from each
     * other): equal strips see each other equally (reciprocity of the view factors: 5.8e-4
     * measured, the quadrature of strips that nearly touch), and no strip sends out more than it
     * emits */
    ck_assert_int_eq(bst_venetian_parse(ctx, "width=16mm,spacing=9mm,tilt=60,curvature=8.5mm,"
                                        "segments=6", &v), BST_OK);
    bsti_vn_geom_init(&g, &v);
    bsti_vn_exchange(&g, gm);
    double asym = 0;
    for (int j = 0; j < n; j++) {
        double sum = 0;
        for (int e = 0; e < n; e++)
            sum += gm[e * n + j], asym = fmax(asym, fabs(gm[e * n + j] - gm[j * n + e]));
        ck_assert_msg(sum <= 1 + 1e-12, "strip %d sends out %.15g", j, sum);
    }
    printf("deep arcs at tilt 60: |G(e, j) - G(j, e)| at most %.2g\n", asym);
    fflush(stdout);
    ck_assert_msg(asym < 2e-3, "exchange not reciprocal: %g", asym);
}
END_TEST

/* Lossless diffuse slats (r = 1; r + t = 1) conserve energy to the quadrature of the exchange and
 * views (the flat slats' bar, 2e-3; 7.9e-4 measured); the segment count converges (R = 12 mm,
 * tilt 45, r = 0.7, t = 0.1, k = 4, against 32 segments: 0.081 at 2, 0.0051 at 8, 0.0015 at 16;
 * flat slats: 0.0015 at 8 against 64): the bar at 8 is 8e-3. */
START_TEST(test_radiosity)
{
    bst_basis *b = sc(4);
    size_t n = bst_basis_size(b);
    bst_layer *l1 = blind("width=16mm,spacing=14.5mm,tilt=0,r=1,curvature=12mm", b);
    bst_layer *l2 = blind("width=16mm,spacing=14.5mm,tilt=45,r=0.5,t=0.5,curvature=20mm", b);
    double *w = all_hemi(l1), *wt = all_hemi(l2), worst = 0;
    bst_layer_free(l1), bst_layer_free(l2);
    for (size_t i = 0; i < n; i++)
        for (int side = 0; side < 2; side++) {
            bst_comp t = side ? BST_TB : BST_TF, r = side ? BST_RB : BST_RF;
            double tr = comp_of(w, n, t, i) + comp_of(w, n, r, i);
            double trt = comp_of(wt, n, t, i) + comp_of(wt, n, r, i);
            worst = fmax(worst, fmax(fabs(tr - 1), fabs(trt - 1)));
        }
    printf("lossless diffuse curved slats: |T + R - 1| at most %.2g\n", worst);
    fflush(stdout);
    ck_assert_msg(worst < 2e-3, "diffuse curved slats lose or make %g", worst);
    double d[3] = {0};
    static const int segs[] = {2, 8, 16};
    bst_layer *lr = blind("width=16mm,spacing=14.5mm,tilt=45,r=0.7,t=0.1,samples=8,curvature=12mm,"
                          "segments=32", b);
    double *ref = all_hemi(lr);
    bst_layer_free(lr);
    for (int k = 0; k < 3; k++) {
        char spec[160];
        snprintf(spec, sizeof spec, "width=16mm,spacing=14.5mm,tilt=45,r=0.7,t=0.1,samples=8,"
                 "curvature=12mm,segments=%d", segs[k]);
        bst_layer *l = blind(spec, b);
        double *h = all_hemi(l);
        for (size_t i = 0; i < 4 * n; i++)
            d[k] = fmax(d[k], fabs(h[i] - ref[i]));
        free(h);
        bst_layer_free(l);
    }
    printf("curved, against 32 segments: %.2g at 2, %.2g at 8, %.2g at 16\n", d[0], d[1], d[2]);
    fflush(stdout);
    ck_assert_msg(d[1] < 8e-3 && d[2] < d[1] && d[1] < d[0], "8 segments differ from 32 by %g", d[1]);
    free(w), free(wt), free(ref);
    bst_basis_free(b);
}
END_TEST

/* Curvature 1000 x width (sagitta w / 8000) against the flat slat: the two builds share nothing
 * but the openness (the curved one traces 8 rays per direction, each rough one with its own
 * facets; the flat one 256 positions per profile angle and a Gaussian lobe of traced moments):
 * every directional-hemispherical value within 5e-3 (measured 6.4e-4 smooth at tilt 0, 3.4e-3
 * rough at tilt 45), and GA >= 99 for the transmission of every patch within 30 deg of the normal
 * (measured 99.9). */
START_TEST(test_flat_limit)
{
    static const char *const flat[] = {"width=16mm,spacing=14.5mm,tilt=0,rs=0.765,r=0.085",
                                       "width=16mm,spacing=14.5mm,tilt=45,rs=0.765,r=0.085,roughness=0.02"};
    bst_basis *b = sc(4);
    size_t n = bst_basis_size(b);
    char spec[200];
    snprintf(spec, sizeof spec, "%s,curvature=16m", flat[_i]);
    bst_layer *lf = blind(flat[_i], b), *lc = blind(spec, b);
    double *hf = all_hemi(lf), *hc = all_hemi(lc), d = 0, ga_min = 100;
    for (size_t i = 0; i < 4 * n; i++)
        d = fmax(d, fabs(hf[i] - hc[i]));
    for (size_t j = 0; j < n; j++) {
        double dir[3], ga, fa;
        bst_basis_center(b, j, dir);
        if (dir[2] < cos(30 * M_PI / 180))
            continue;
        ck_assert_int_eq(bst_metrics_accordance(ctx, lc, lf, 0, BST_TF, j, &ga, &fa, NULL), BST_OK);
        ga_min = fmin(ga_min, ga);
    }
    printf("%s: curvature 16 m against flat: |dH| at most %.2g, Tf GA (to 30 deg) at least %.3f\n",
           flat[_i], d, ga_min);
    fflush(stdout);
    ck_assert_msg(d < 5e-3, "%s: curvature 16 m differs from flat by %g", flat[_i], d);
    ck_assert_msg(ga_min >= 99, "%s: Tf GA %g", flat[_i], ga_min);
    free(hf), free(hc);
    bst_layer_free(lf), bst_layer_free(lc);
    bst_basis_free(b);
}
END_TEST

/* Reciprocity of the transmissions (k = 4), relative to their largest value, with the flat slats'
 * bar of 0.05 (measured 0.0044, 0.0028 and 0.0087: the rays' sampling). */
START_TEST(test_reciprocity)
{
    static const char *const specs[] = {"width=16mm,spacing=14.5mm,tilt=45,rs=0.765,curvature=12mm",
                                        "width=16mm,spacing=14.5mm,tilt=20,rs=0.5,r-up=0.3,r-down=0.1,t=0.1,curvature=20mm",
                                        "width=16mm,spacing=14.5mm,tilt=0,rs=0.765,r=0.085,roughness=0.02,curvature=12mm"};
    bst_basis *b = sc(4);
    bst_layer *l = blind(specs[_i], b);
    double err;
    size_t i, o;
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, l, 0, &err, &i, &o), BST_OK);
    printf("%s: reciprocity error %.3g (incident %zu, outgoing %zu)\n", specs[_i], err, i, o);
    fflush(stdout);
    ck_assert_msg(err < 0.05, "%s: reciprocity error %g", specs[_i], err);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* Every allocation of a curved layer's making fails in turn: BST_ENOMEM, no layer, nothing
 * leaked. */
START_TEST(test_alloc_failure)
{
    long n = tu_venetian_alloc_failures("width=16mm,spacing=14.5mm,tilt=30,rs=0.7,r=0.1,samples=2,segments=2,curvature=10mm");
    printf("curved venetian layer: %ld allocations failed in turn, none leaked\n", n);
}
END_TEST

static Suite *curved_suite(void)
{
    Suite *s = suite_create("venetian_curved");
    TCase *tc = tcase_create("curved");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 600);
    tcase_add_test(tc, test_alloc_failure);
    tcase_add_loop_test(tc, test_openness, 0, 6);
    tcase_add_loop_test(tc, test_lossless_mirror, 0, 5); /* the fourth in Klems full */
    tcase_add_loop_test(tc, test_closed, 0, 3);
    tcase_add_test(tc, test_exchange);
    tcase_add_test(tc, test_radiosity);
    tcase_add_loop_test(tc, test_flat_limit, 0, 2);
    tcase_add_loop_test(tc, test_reciprocity, 0, 3);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(curved_suite());
}
