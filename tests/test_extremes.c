/* test_extremes.c - numerical extremes through the public API (issue #18): near-mirror panes and
 * grazing incidence in the glass model; opaque, empty and many identical layers in a stack against
 * closed forms; values from subnormal to 1e30 and beyond, and facing near-perfect mirrors, which
 * must give a finite result or a clean error; single against double precision on a reference
 * stack; the reciprocity metric.
 *
 * Conventions (bsdfstack.h): a component holds BSDF values (1/sr), column = incident patch; the
 * directional value of a specular (diagonal) component at patch j is Lambda_j M(j, j).  Every
 * stack below has physically valid inputs unless a test says otherwise, so its status is BST_OK;
 * where the inputs are unphysical, a test accepts any status but asks for a finite result or an
 * error with a message, and, for facing mirrors, a non-zero status or a result that conserves
 * energy: that stays true once the library also checks the system's own energy. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static const char *const visible[] = {"Visible"};

static double deg(double d) { return d * M_PI / 180.0; }

static bst_glass *pane(const char *spec)
{
    bst_glass *g = NULL;
    int rc = bst_glass_parse(ctx, spec, getenv("BSDFSTACK_GLASS_DIR"), &g);
    ck_assert_msg(rc == BST_OK, "%s: %s", spec, bst_ctx_message(ctx));
    return g;
}

static bst_basis *klems(const char *which)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, which, &b), BST_OK);
    return b;
}

static bst_basis *sc(int k)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, k, &b), BST_OK);
    return b;
}

/* A diagonal matrix whose directional values Lambda_j M(j, j) are v[j]. */
static bst_mat *specular(const bst_basis *b, const double *v)
{
    size_t n = bst_basis_size(b);
    const double *lam = bst_basis_lambda(b);
    double *d = malloc(n * sizeof *d);
    for (size_t j = 0; j < n; j++)
        d[j] = v[j] / lam[j];
    bst_mat *m;
    ck_assert_int_eq(bst_mat_new_diag(ctx, n, d, &m), BST_OK);
    free(d);
    return m;
}

/* A dense double matrix holding the column-major values a (NULL: zeros). */
static bst_mat *dense(const bst_basis *b, const double *a)
{
    size_t n = bst_basis_size(b);
    bst_mat *m;
    ck_assert_int_eq(bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &m), BST_OK);
    if (a)
        memcpy(bst_mat_dense_data(m), a, n * n * sizeof *a);
    return m;
}

/* A component of hemispherical value v at every incident patch: Lambertian (dense, v / pi
 * everywhere) when diffuse, else specular. */
static bst_mat *uniform(const bst_basis *b, double v, int diffuse)
{
    size_t n = bst_basis_size(b), len = diffuse ? n * n : n;
    double *a = malloc(len * sizeof *a);
    for (size_t k = 0; k < len; k++)
        a[k] = diffuse ? v / M_PI : v;
    bst_mat *m = diffuse ? dense(b, a) : specular(b, a);
    free(a);
    return m;
}

/* A one-channel layer of the four given components (NULL: absent). */
static bst_layer *layer4(const bst_basis *b, bst_mat *tf, bst_mat *rf, bst_mat *tb, bst_mat *rb)
{
    bst_layer *l;
    ck_assert_int_eq(bst_layer_new(ctx, b, 1, visible, &l), BST_OK);
    bst_mat *m[BST_NCOMP] = {tf, rf, tb, rb};
    for (int c = 0; c < BST_NCOMP; c++)
        if (m[c])
            ck_assert_int_eq(bst_layer_set(ctx, l, 0, (bst_comp)c, m[c]), BST_OK);
    return l;
}

/* The Visible channel of pane spec as a layer (at_centre: values at the patch centres). */
static bst_layer *glass_layer(const char *spec, const bst_basis *b, int at_centre)
{
    bst_glass *g = pane(spec);
    bst_layer *l;
    ck_assert_int_eq(bst_glass_layer(ctx, g, b, 1, visible, at_centre, &l), BST_OK);
    bst_glass_free(g);
    return l;
}

/* A seeded random dense layer whose incident columns have T + R = 1 - absorb on both sides. */
static bst_layer *random_layer(const bst_basis *b, double absorb, uint64_t seed)
{
    size_t n = bst_basis_size(b);
    const double *lam = bst_basis_lambda(b);
    tu_rng rng;
    tu_rng_seed(&rng, seed);
    double *a = malloc(4 * n * n * sizeof *a);
    for (size_t k = 0; k < 4 * n * n; k++)
        a[k] = tu_rng_uniform(&rng);
    for (int side = 0; side < 2; side++)
        for (size_t j = 0; j < n; j++) {
            double *t = a + (size_t)(2 * side) * n * n + j * n, *r = t + n * n;
            double st = 0, sr = 0, share = 0.3 + 0.6 * tu_rng_uniform(&rng);
            for (size_t i = 0; i < n; i++)
                st += lam[i] * t[i], sr += lam[i] * r[i];
            for (size_t i = 0; i < n; i++)
                t[i] *= (1.0 - absorb) * share / st, r[i] *= (1.0 - absorb) * (1.0 - share) / sr;
        }
    bst_layer *l = layer4(b, dense(b, a), dense(b, a + n * n), dense(b, a + 2 * n * n),
                          dense(b, a + 3 * n * n));
    free(a);
    return l;
}

static int combine(size_t n, bst_layer *const *l, const bst_stack_opts *o, bst_layer **out)
{
    return bst_stack_combine(ctx, n, (const bst_layer *const *)l, o, out);
}

/* Every element of every component of every channel of l is finite (absent: nothing to check).
 * One assertion per matrix: Check records every assertion passed, which costs a system call. */
static void assert_finite(const bst_layer *l, const char *what)
{
    size_t n = bst_basis_size(bst_layer_basis(l));
    double *a = malloc(n * n * sizeof *a);
    for (size_t ch = 0; ch < bst_layer_nchannels(l); ch++)
        for (int c = 0; c < BST_NCOMP; c++) {
            const bst_mat *m = bst_layer_get(l, ch, (bst_comp)c);
            if (!m)
                continue;
            ck_assert_int_eq(bst_mat_to_dense_array(ctx, m, a), BST_OK);
            size_t k = 0;
            while (k < n * n && isfinite(a[k]))
                k++;
            ck_assert_msg(k == n * n, "%s: %s(%zu, %zu) = %g", what, bst_comp_name((bst_comp)c),
                          k % n, k / n, k < n * n ? a[k] : 0.0);
        }
    free(a);
}

/* Largest |a - b| over the elements of component c, relative to the largest |b|. */
static double rel_diff(const bst_layer *a, const bst_layer *b, bst_comp c)
{
    const bst_mat *x = bst_layer_get(a, 0, c), *y = bst_layer_get(b, 0, c);
    size_t n = bst_basis_size(bst_layer_basis(a));
    double d = 0.0, s = 0.0;
    for (size_t j = 0; j < n; j++)
        for (size_t i = 0; i < n; i++) {
            double u = x ? bst_mat_get(x, i, j) : 0.0, v = y ? bst_mat_get(y, i, j) : 0.0;
            d = fmax(d, fabs(u - v)), s = fmax(s, fabs(v));
            if (isnan(u - v))
                return INFINITY;
        }
    return s > 0.0 ? d / s : d;
}

/* Directional value of the diagonal component c of l at patch j. */
static double dir_value(const bst_layer *l, bst_comp c, size_t j)
{
    return bst_mat_get(bst_layer_get(l, 0, c), j, j) * bst_basis_lambda(bst_layer_basis(l))[j];
}

/* ------------------------------------------------------------------ near-mirror panes */

/* A pane given by T0 and R0 = 1 - T0 - A close to a mirror: the model inverts them to an index
 * n (up to 1e10) and an internal transmittance tau0 with 1 - tau0 ~ T0, which cancellation once
 * lost (T at 10 degrees wrong by up to 100 %, or 0).  Just off normal incidence (1e-9 rad, where
 * the model evaluates its formulas instead of returning T0, R0) T reproduces T0 to 1e-9 relative
 * and 1 - R reproduces T0 + A to 1e-9 relative where a double near 1 can hold that: to 2 units in
 * the last place of R otherwise (1 - R0 = 1e-10 has only 6 digits).  T off normal stays close to
 * T0, and T + R <= 1. */
static const double mirror_t0[] = {1e-2, 1e-4, 1e-6, 1e-8, 1e-10};
static const double mirror_a[] = {0.0, 1e-6, 1e-3};

START_TEST(test_near_mirror)
{
    double t0 = mirror_t0[_i / 3], a = mirror_a[_i % 3], r0 = 1.0 - t0 - a;
    char spec[128];
    snprintf(spec, sizeof spec, "t0=%.17g,r0=%.17g", t0, r0);
    bst_glass *g = pane(spec);
    for (size_t ch = 0; ch < bst_glass_nchannels(g); ch++) {
        double tf, tb, rf, rb;
        ck_assert_int_eq(bst_glass_optics(g, ch, 1e-9, &tf, &tb, &rf, &rb), BST_OK);
        tu_assert_close(tf, t0, 1e-9, 0.0);
        tu_assert_close(tb, t0, 1e-9, 0.0);
        double rtol = fmax(1e-9 * (1.0 - r0), 2.0 * DBL_EPSILON);
        ck_assert_msg(fabs(rf - r0) <= rtol && fabs(rb - r0) <= rtol, "%s: R %.17g %.17g vs %.17g",
                      spec, rf, rb, r0);
        double t_norm = tf;
        static const double angles[] = {10.0, 45.0};
        static const double lo[] = {0.9, 0.5}, hi[] = {1.1, 2.0};
        for (int k = 0; k < 2; k++) {
            ck_assert_int_eq(bst_glass_optics(g, ch, deg(angles[k]), &tf, &tb, &rf, &rb), BST_OK);
            ck_assert_msg(isfinite(tf) && tf > 0.0 && isfinite(rf), "%s at %g deg: T %g, R %g",
                          spec, angles[k], tf, rf);
            ck_assert_msg(tf / t_norm >= lo[k] && tf / t_norm <= hi[k],
                          "%s: T(%g deg) / T(0) = %g", spec, angles[k], tf / t_norm);
            ck_assert_double_eq(tf, tb); /* one T0, R0 for both sides */
            ck_assert_double_le(tf + rf, 1.0);
        }
    }
    /* its layer (patch averages over a Klems basis) is finite, with directional values in [0, 1]
     * and the polar patch (0..9 degrees) close to T0 */
    bst_basis *b = klems("quarter");
    bst_layer *l;
    ck_assert_int_eq(bst_glass_layer(ctx, g, b, 1, visible, 0, &l), BST_OK);
    assert_finite(l, spec);
    for (size_t j = 0; j < bst_basis_size(b); j++)
        for (int c = 0; c < BST_NCOMP; c++) {
            double v = dir_value(l, (bst_comp)c, j);
            ck_assert_msg(v >= 0.0 && v <= 1.0, "%s: %s patch %zu: %g", spec,
                          bst_comp_name((bst_comp)c), j, v);
        }
    tu_assert_close(dir_value(l, BST_TF, 0), t0, 0.02, 0.0);
    bst_layer_free(l);
    bst_basis_free(b);
    bst_glass_free(g);
}
END_TEST

/* A non-absorbing pane (T0 + R0 = 1 exactly: T0 = 2^-m) against its closed form, computed here
 * from T0 alone: rho0 = (1 - T0) / (1 + T0), n = (1 + sqrt rho0)^2 / (1 - rho0), and per
 * polarisation T = c / (2 - c) with c = 1 - r = 4 a b / (a + b)^2 the interface's transmittance.
 * T0 from 2^-7 to 2^-33 (1e-2 .. 1e-10), up to 89.99 degrees: 1e-12 relative. */
START_TEST(test_lossless_mirror_closed_form)
{
    for (int m = 7; m <= 33; m += 2) {
        double t0 = ldexp(1.0, -m), r0 = 1.0 - t0;
        char spec[128];
        snprintf(spec, sizeof spec, "t0=%.17g,r0=%.17g", t0, r0);
        bst_glass *g = pane(spec);
        double rho = (1.0 - t0) / (1.0 + t0), sr = sqrt(rho);
        double n = (1.0 + sr) * (1.0 + sr) / (2.0 * t0 / (1.0 + t0));
        static const double angles[] = {1e-6, 10.0, 45.0, 80.0, 89.99};
        for (int k = 0; k < 5; k++) {
            double th = deg(angles[k]), ci = cos(th), st = sin(th) / n, ct = sqrt(1.0 - st * st);
            double a[2] = {ci, n * ci}, b[2] = {n * ct, ct}, want = 0.0;
            for (int x = 0; x < 2; x++) {
                double c = 4.0 * (a[x] / (a[x] + b[x])) * (b[x] / (a[x] + b[x]));
                want += 0.5 * c / (2.0 - c);
            }
            double t, r;
            ck_assert_int_eq(bst_glass_optics(g, 0, th, &t, NULL, &r, NULL), BST_OK);
            tu_assert_close(t, want, 1e-12, 0.0);
            tu_assert_close(1.0 - r, want, 1e-12, 2.0 * DBL_EPSILON / 1e-12);
        }
        bst_glass_free(g);
    }
}
END_TEST

/* ------------------------------------------------------------------ grazing incidence */

/* Panes evaluated up to the last double below 90 degrees: T and R finite in [0, 1] with
 * T + R <= 1; T falls and R rises monotonically towards 90 degrees (for ordinary glass; a
 * near-mirror has its Brewster angle within 1e-4 degrees of 90) and T -> 0, R -> 1. */
START_TEST(test_grazing)
{
    static const char *const specs[] = {"clear-6mm", "nfrc-103", "lowiron-6mm", "t0=0.1,r0=0.05",
                                        "t0=0.9,r0=0.08", "t0=1e-6,r0=0.999", "t0=0,r0=0.3"};
    const double last = nextafter(M_PI / 2, 0.0);
    const double th[] = {deg(80), deg(85), deg(89), deg(89.9), deg(89.99), deg(89.9999), last};
    const size_t nth = sizeof th / sizeof th[0];
    for (size_t s = 0; s < sizeof specs / sizeof specs[0]; s++) {
        bst_glass *g = pane(specs[s]);
        int ordinary = strstr(specs[s], "0.999") == NULL;
        for (size_t ch = 0; ch < bst_glass_nchannels(g); ch++) {
            double tp = INFINITY, rp = -INFINITY;
            for (size_t k = 0; k < nth; k++) {
                double v[4];
                ck_assert_int_eq(bst_glass_optics(g, ch, th[k], v, v + 1, v + 2, v + 3), BST_OK);
                for (int c = 0; c < 4; c++)
                    ck_assert_msg(isfinite(v[c]) && v[c] >= 0.0 && v[c] <= 1.0,
                                  "%s at %.17g rad: %g", specs[s], th[k], v[c]);
                ck_assert_double_le(v[0] + v[2], 1.0);
                ck_assert_double_le(v[1] + v[3], 1.0);
                if (ordinary) {
                    ck_assert_msg(v[0] <= tp && v[2] >= rp, "%s: not monotone at %.17g rad",
                                  specs[s], th[k]);
                    tp = v[0], rp = v[2];
                }
                if (k == nth - 1) /* cos = 6e-17 */
                    ck_assert_msg(v[0] < 1e-9 && v[1] < 1e-9 && v[2] > 1.0 - 1e-9 &&
                                  v[3] > 1.0 - 1e-9, "%s at the last angle: T %g, R %g",
                                  specs[s], v[0], v[2]);
            }
        }
        bst_glass_free(g);
    }
}
END_TEST

/* ------------------------------------------------------------------ opaque layers */

/* An opaque layer (no transmission on either side) in a stack: the system's T is exactly 0 and
 * its R on a side is that of the layers up to the opaque one: the opaque layer's own R where it
 * faces outwards, and the two-layer closed form R1 + T1^2 rho / (1 - R1b rho) behind a pane for a
 * specular mirror of reflectance rho.  Variants: transmissions absent, stored as zero matrices,
 * or as dense zeros; a specular or a diffuse (dense, Lambertian) reflector. */
START_TEST(test_opaque)
{
    int trans = _i % 3, diffuse = _i / 3;
    bst_basis *b = klems("quarter");
    size_t n = bst_basis_size(b);
    double rho = 0.8;
    bst_mat *t[2] = {NULL, NULL}, *r[2];
    for (int s = 0; s < 2; s++) {
        if (trans == 1)
            ck_assert_int_eq(bst_mat_new_zero(ctx, n, n, &t[s]), BST_OK);
        else if (trans == 2)
            t[s] = dense(b, NULL);
        r[s] = uniform(b, rho, diffuse);
    }
    bst_layer *op = layer4(b, t[0], r[0], t[1], r[1]);
    bst_layer *gl = glass_layer("clear-6mm", b, 0);
    bst_layer *stacks[3][3] = {{op, gl}, {gl, op}, {gl, op, gl}};
    size_t len[3] = {2, 2, 3};
    bst_layer *sys[3];
    for (int s = 0; s < 3; s++) {
        ck_assert_int_eq(combine(len[s], stacks[s], NULL, &sys[s]), BST_OK);
        assert_finite(sys[s], "opaque stack");
        for (int c = BST_TF; c <= BST_TB; c += 2) {
            const bst_mat *m = bst_layer_get(sys[s], 0, (bst_comp)c);
            ck_assert_double_eq(bst_mat_max_abs(m), 0.0);
        }
    }
    double eps = 8 * (double)n * DBL_EPSILON;
    ck_assert_double_le(rel_diff(sys[0], op, BST_RF), eps); /* the opaque layer outside */
    ck_assert_double_le(rel_diff(sys[1], op, BST_RB), eps);
    /* the layers behind the opaque one change nothing */
    ck_assert_double_le(rel_diff(sys[2], sys[1], BST_RF), eps);
    ck_assert_double_le(rel_diff(sys[2], sys[0], BST_RB), eps);
    if (!diffuse)
        for (size_t j = 0; j < n; j++) {
            double t1 = dir_value(gl, BST_TF, j), r1 = dir_value(gl, BST_RF, j);
            double r1b = dir_value(gl, BST_RB, j), d = 1.0 - r1b * rho;
            tu_assert_close(dir_value(sys[1], BST_RF, j), r1 + t1 * t1 * rho / d, eps, 0.0);
            tu_assert_close(dir_value(sys[2], BST_RB, j), r1b + t1 * t1 * rho / (1.0 - r1 * rho),
                            eps, 0.0);
        }
    for (int s = 0; s < 3; s++)
        bst_layer_free(sys[s]);
    bst_layer_free(op), bst_layer_free(gl);
    bst_basis_free(b);
}
END_TEST

/* ------------------------------------------------------------------ empty layers */

/* An empty layer (T = identity in flux, i.e. BSDF delta / Lambda: diag(1 / Lambda); R = 0,
 * stored as zero matrices or absent) anywhere in a stack leaves the system unchanged to a few
 * n eps relative (Lambda_j (1 / Lambda_j) is 1 to rounding).  Stack: pane, random diffusing
 * layer, pane over Shirley-Chiu k = 2 and Klems quarter. */
START_TEST(test_empty_layer)
{
    bst_basis *b = _i ? klems("quarter") : sc(2);
    size_t n = bst_basis_size(b);
    const double *lam = bst_basis_lambda(b);
    double *inv = malloc(n * sizeof *inv);
    for (size_t j = 0; j < n; j++)
        inv[j] = 1.0 / lam[j];
    bst_layer *empty[2];
    for (int v = 0; v < 2; v++) {
        bst_mat *tf, *tb, *rf = NULL, *rb = NULL;
        ck_assert_int_eq(bst_mat_new_diag(ctx, n, inv, &tf), BST_OK);
        ck_assert_int_eq(bst_mat_new_diag(ctx, n, inv, &tb), BST_OK);
        if (v) {
            ck_assert_int_eq(bst_mat_new_zero(ctx, n, n, &rf), BST_OK);
            ck_assert_int_eq(bst_mat_new_zero(ctx, n, n, &rb), BST_OK);
        }
        empty[v] = layer4(b, tf, rf, tb, rb);
    }
    free(inv);
    bst_layer *gl = glass_layer("clear-6mm", b, 0), *dif = random_layer(b, 0.1, 4242);
    bst_layer *base[3] = {gl, dif, gl}, *ref;
    ck_assert_int_eq(combine(3, base, NULL, &ref), BST_OK);
    double eps = 16 * (double)n * DBL_EPSILON, worst = 0.0;
    for (int v = 0; v < 2; v++)
        for (size_t at = 0; at <= 3; at++) {
            bst_layer *l[4], *sys;
            for (size_t k = 0, m = 0; k < 4; k++)
                l[k] = k == at ? empty[v] : base[m++];
            ck_assert_int_eq(combine(4, l, NULL, &sys), BST_OK);
            assert_finite(sys, "with an empty layer");
            for (int c = 0; c < BST_NCOMP; c++) {
                double d = rel_diff(sys, ref, (bst_comp)c);
                ck_assert_msg(d <= eps, "empty layer at %zu: %s differs by %g", at,
                              bst_comp_name((bst_comp)c), d);
                worst = fmax(worst, d);
            }
            bst_layer_free(sys);
        }
    /* empty layers alone, and two around the pane */
    bst_layer *two[2] = {empty[0], empty[1]}, *e2, *ege[3] = {empty[1], gl, empty[0]}, *s3;
    ck_assert_int_eq(combine(2, two, NULL, &e2), BST_OK);
    ck_assert_int_eq(combine(3, ege, NULL, &s3), BST_OK);
    for (int c = 0; c < BST_NCOMP; c++) {
        ck_assert_double_le(rel_diff(e2, empty[1], (bst_comp)c), eps);
        ck_assert_double_le(rel_diff(s3, gl, (bst_comp)c), eps);
    }
    printf("empty layer, %s: largest relative change %.2g (n eps = %.2g)\n", bst_basis_name(b),
           worst, (double)n * DBL_EPSILON);
    bst_layer_free(e2), bst_layer_free(s3);
    bst_layer_free(ref), bst_layer_free(gl), bst_layer_free(dif);
    bst_layer_free(empty[0]), bst_layer_free(empty[1]);
    bst_basis_free(b);
}
END_TEST

/* ------------------------------------------------------------------ N identical panes */

/* N = 2, 5, 10, 20 identical panes (clear 6 mm, values at the Klems patch centres) against the
 * recursion of specular slabs applied to the pane's own T1, R1 at the patch's angle:
 *   T_{n+1} = T_n T1 / (1 - R_n R1),  R_{n+1} = R_n + T_n^2 R1 / (1 - R_n R1)
 * (a symmetric pane: Rf = Rb), at normal incidence (patch 0) and at 50 degrees (patch 69), both on
 * the diagonal path and forced dense.  Error growth: the recursion and the library round
 * differently at each of the N - 1 steps; the largest relative difference measured (T, Rf, Rb,
 * both patches, both paths alike) is 2.0, 3.8, 7.7 and 13.8 eps at N = 2, 5, 10 and 20: linear
 * growth, about 0.7 eps per pane; the bound held is 4 N eps. */
START_TEST(test_n_panes)
{
    bst_basis *b = klems("full");
    bst_glass *g = pane("clear-6mm");
    bst_layer *l = glass_layer("clear-6mm", b, 1);
    static const size_t patches[] = {0, 69};
    static const int counts[] = {2, 5, 10, 20};
    bst_layer *list[20];
    for (int k = 0; k < 20; k++)
        list[k] = l;
    for (int dense_path = 0; dense_path < 2; dense_path++)
        for (int q = 0; q < 4; q++) {
            int N = counts[q];
            bst_stack_opts o;
            bst_stack_opts_init(&o);
            o.force_dense = dense_path;
            bst_layer *sys;
            ck_assert_int_eq(combine((size_t)N, list, &o, &sys), BST_OK);
            double worst = 0.0;
            for (int p = 0; p < 2; p++) {
                size_t j = patches[p];
                double d[3], t1, r1;
                bst_basis_center(b, j, d);
                ck_assert_int_eq(bst_glass_optics(g, 0, acos(d[2]), &t1, NULL, &r1, NULL), BST_OK);
                double t = t1, r = r1;
                for (int k = 1; k < N; k++) {
                    double den = 1.0 - r * r1;
                    r = r + t * t * r1 / den;
                    t = t * t1 / den;
                }
                double got[3] = {dir_value(sys, BST_TF, j), dir_value(sys, BST_RF, j),
                                 dir_value(sys, BST_RB, j)}, want[3] = {t, r, r};
                for (int c = 0; c < 3; c++)
                    worst = fmax(worst, fabs(got[c] - want[c]) / want[c]);
            }
            printf("%2d panes (%s): largest relative difference from the recursion %.2g = "
                   "%.1f eps\n", N, dense_path ? "dense" : "diagonal", worst, worst / DBL_EPSILON);
            ck_assert_double_le(worst, 4.0 * N * DBL_EPSILON);
            bst_layer_free(sys);
        }
    bst_layer_free(l);
    bst_glass_free(g);
    bst_basis_free(b);
}
END_TEST

/* ------------------------------------------------------------------ extreme values */

/* A dense layer scaled so that its values are about `scale` (subnormal to 1e200), with or without
 * its reflections, in stacks with panes and with itself, in double and in single precision, whole
 * and by columns (bst_stack_columns); and a layer with one component all zeros (scale 0).  The
 * library gives a result whose every element is finite, or an error with a message and no result:
 * never NaN or infinity.  (Products of values near 1e200, or near 1e30 in single precision,
 * overflow: an error.) */
static const double extreme_scale[] = {1e-30, 1e30, 1e-300, 1e-310, DBL_TRUE_MIN, 1e200, 0.0};

/* rc of a combination or columns call: an error with a message and no result, or a result. */
static void assert_clean(int rc, const char *what, const void *result)
{
    if (rc < 0) {
        ck_assert_msg(result == NULL, "%s: error %d with a result", what, rc);
        ck_assert_msg(strlen(bst_ctx_message(ctx)) > 0, "%s: error %d without a message", what, rc);
    } else {
        ck_assert_msg(result != NULL, "%s: status %d without a result", what, rc);
    }
}

START_TEST(test_extreme_values)
{
    double scale = extreme_scale[_i / 2];
    int reflect = _i % 2;
    bst_basis *b = klems("quarter");
    size_t n = bst_basis_size(b);
    bst_layer *x = random_layer(b, 0.1, 99);
    bst_layer *w;
    ck_assert_int_eq(bst_layer_new(ctx, b, 1, visible, &w), BST_OK);
    double *a = malloc(n * n * sizeof *a);
    for (int c = 0; c < BST_NCOMP; c++) {
        if (!reflect && (c == BST_RF || c == BST_RB))
            continue;
        ck_assert_int_eq(bst_mat_to_dense_array(ctx, bst_layer_get(x, 0, (bst_comp)c), a), BST_OK);
        for (size_t k = 0; k < n * n; k++)
            a[k] = scale == 0.0 ? (c == BST_TF ? 0.0 : a[k]) : a[k] * scale;
        ck_assert_int_eq(bst_layer_set(ctx, w, 0, (bst_comp)c, dense(b, a)), BST_OK);
    }
    free(a);
    bst_layer *gl = glass_layer("clear-6mm", b, 0);
    bst_layer *stacks[4][3] = {{gl, w, gl}, {w, w}, {w, gl}, {w, w, w}};
    size_t len[4] = {3, 2, 2, 3}, cols[3] = {0, 7, 40};
    for (int s = 0; s < 4; s++)
        for (int v = 0; v < 3; v++) {
            char what[96];
            static const char *const path[3] = {"double", "float", "dense"};
            snprintf(what, sizeof what, "scale %g, %s reflections, stack %d, %s", scale,
                     reflect ? "with" : "without", s, path[v]);
            bst_stack_opts o;
            bst_stack_opts_init(&o);
            o.precision = v == 1 ? BST_FLOAT : BST_DOUBLE;
            o.force_dense = v == 2;
            bst_layer *sys = (bst_layer *)1;
            bst_ctx_clear(ctx);
            int rc = combine(len[s], stacks[s], &o, &sys);
            assert_clean(rc, what, sys);
            if (rc >= 0) {
                assert_finite(sys, what);
                bst_layer_free(sys);
            }
            if (v)
                continue;
            bst_mat *tf = (bst_mat *)1, *rf = (bst_mat *)1;
            bst_columns_opts co;
            bst_columns_opts_init(&co);
            bst_ctx_clear(ctx);
            rc = bst_stack_columns(ctx, len[s], (const bst_layer *const *)stacks[s], NULL, 3, cols,
                                   &co, &tf, &rf);
            assert_clean(rc, what, tf);
            if (rc < 0) {
                ck_assert_ptr_null(rf);
            } else {
                ck_assert_msg(bst_mat_all_finite(tf) && bst_mat_all_finite(rf),
                              "%s, columns: not finite (status %d)", what, rc);
                bst_mat_free(tf), bst_mat_free(rf);
            }
        }
    bst_layer_free(gl), bst_layer_free(w), bst_layer_free(x);
    bst_basis_free(b);
}
END_TEST

/* Non-finite values in an input are an error that names the layer, not a result. */
START_TEST(test_non_finite_input)
{
    bst_basis *b = klems("quarter");
    size_t n = bst_basis_size(b);
    const double bad[] = {NAN, INFINITY, -INFINITY};
    for (int k = 0; k < 3; k++) {
        double *a = calloc(n * n, sizeof *a);
        a[n + 2] = bad[k];
        bst_layer *w = layer4(b, dense(b, a), NULL, NULL, NULL);
        bst_layer *gl = glass_layer("clear-6mm", b, 0);
        bst_layer *l[2] = {gl, w}, *sys = (bst_layer *)1;
        ck_assert_int_lt(combine(2, l, NULL, &sys), 0);
        ck_assert_ptr_null(sys);
        ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "layer 2"));
        bst_layer_free(w), bst_layer_free(gl);
        free(a);
    }
    bst_basis_free(b);
}
END_TEST

/* ------------------------------------------------------------------ facing mirrors */

/* Two identical layers of reflectance R = 0.99 .. 1 facing each other, with T = (1 - R) / 2
 * (T = 1e-3 for R = 1: T + R > 1), specular or diffuse.  The inter-reflection I - L Rb1 L Rf2 is
 * near-singular; the result must be finite, and either the status is non-zero (a warning or an
 * error with a message) or the system conserves energy: T + R <= 1 + 1e-6 for every incident
 * patch on both sides, hemispherically (Lambda weights). */
static const double mirror_r[] = {0.99, 0.9999, 0.999999, 1.0};

static void facing(const bst_basis *b, double r, double t, int diffuse, const bst_stack_opts *o,
                   int *status)
{
    size_t n = bst_basis_size(b);
    bst_mat *m[BST_NCOMP];
    for (int c = 0; c < BST_NCOMP; c++) {
        m[c] = uniform(b, (c == BST_TF || c == BST_TB) ? t : r, diffuse);
    }
    bst_layer *l = layer4(b, m[0], m[1], m[2], m[3]), *pair[2] = {l, l}, *sys = (bst_layer *)1;
    bst_ctx_clear(ctx);
    int rc = combine(2, pair, o, &sys);
    *status = rc;
    if (rc < 0) {
        ck_assert_ptr_null(sys);
        ck_assert_msg(strlen(bst_ctx_message(ctx)) > 0, "R %g: error without a message", r);
    } else {
        char what[64];
        snprintf(what, sizeof what, "mirrors R %.17g, T %g, %s", r, t,
                 diffuse ? "diffuse" : "specular");
        assert_finite(sys, what);
        if (rc == BST_OK) {
            double *ht = malloc(2 * n * sizeof *ht), *hr = ht + n;
            for (int side = 0; side < 2; side++) {
                bst_comp ct = side ? BST_TB : BST_TF, cr = side ? BST_RB : BST_RF;
                ck_assert_int_eq(bst_layer_hemispherical(ctx, sys, 0, ct, ht), BST_OK);
                ck_assert_int_eq(bst_layer_hemispherical(ctx, sys, 0, cr, hr), BST_OK);
                for (size_t j = 0; j < n; j++)
                    ck_assert_msg(ht[j] + hr[j] <= 1.0 + 1e-6, "%s: status 0 but T + R = %.9g at "
                                  "patch %zu", what, ht[j] + hr[j], j);
            }
            free(ht);
        }
        bst_layer_free(sys);
    }
    bst_layer_free(l);
}

START_TEST(test_facing_mirrors)
{
    bst_basis *b = _i ? klems("quarter") : sc(2);
    for (int diffuse = 0; diffuse < 2; diffuse++)
        for (int k = 0; k < 4; k++) {
            double r = mirror_r[k], t = r < 1.0 ? 0.5 * (1.0 - r) : 1e-3;
            int rc;
            facing(b, r, t, diffuse, NULL, &rc);
            if (r == 1.0) /* singular or ill-conditioned, and T + R > 1 */
                ck_assert_msg(rc != BST_OK, "R = 1, T = 1e-3 (%s) passed silently",
                              diffuse ? "diffuse" : "specular");
        }
    /* T + R = 1.000999 is within the default input tolerance (1 %) and the system then reflects
     * and transmits 1.5 times the incident flux; with the tolerance at 1e-6 it is flagged */
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    o.energy_tol = 1e-6;
    for (int diffuse = 0; diffuse < 2; diffuse++) {
        int rc;
        facing(b, 0.999999, 1e-3, diffuse, &o, &rc);
        ck_assert_int_ne(rc, BST_OK);
    }
    bst_basis_free(b);
}
END_TEST

/* ------------------------------------------------------------------ single against double */

/* Pane + the reference rank-3 diffuser + pane at k = 5 (1024 patches, dense) in single and in
 * double precision: the directional-hemispherical T and R of every incident patch, both sides,
 * agree to 1e-5 relative (measured: 5.8e-7), and every column's global accordance GA is above
 * 100 - 1e-6 % (measured: 100 - 2.3e-10).  At k = 6 the same stack differs by 7.2e-7 relative in
 * hemispherical values and 5.8e-6 of the largest value element by element (Tf, Tb), least GA
 * 100 - 2.7e-10; at k = 7 (bench/bench_precision 7, bench/README.md) by 8.0e-6 of the largest
 * value element by element, RMS 1.3e-7 of it, least GA 100 - 5.3e-10. */
START_TEST(test_single_double)
{
    bst_basis *b = sc(5);
    size_t n = bst_basis_size(b);
    bst_bsdf *f;
    int rc = bst_bsdf_read(ctx, tu_ref("L_diffuser_t3k5.xml"), NULL, &f);
    ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    bst_layer *d, *gl = glass_layer("clear-6mm", b, 0), *sys[2];
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, f, b, &d), BST_OK);
    bst_bsdf_free(f);
    bst_layer *l[3] = {gl, d, gl};
    for (int p = 0; p < 2; p++) {
        bst_stack_opts o;
        bst_stack_opts_init(&o);
        o.precision = p ? BST_FLOAT : BST_DOUBLE;
        ck_assert_int_eq(combine(3, l, &o, &sys[p]), BST_OK);
        assert_finite(sys[p], p ? "single" : "double");
    }
    double *h = malloc(2 * n * sizeof *h), worst = 0.0, ga_min = 100.0;
    for (int c = 0; c < BST_NCOMP; c++) {
        ck_assert_int_eq(bst_layer_hemispherical(ctx, sys[0], 0, (bst_comp)c, h), BST_OK);
        ck_assert_int_eq(bst_layer_hemispherical(ctx, sys[1], 0, (bst_comp)c, h + n), BST_OK);
        for (size_t j = 0; j < n; j++)
            worst = fmax(worst, fabs(h[n + j] - h[j]) / h[j]);
        ck_assert_int_eq(bst_metrics_accordance_all(ctx, sys[0], sys[1], 0, (bst_comp)c, h, NULL),
                         BST_OK);
        for (size_t j = 0; j < n; j++)
            ga_min = fmin(ga_min, h[j]);
    }
    printf("k = 5, pane + diffuser + pane, single vs double: hemispherical values differ by %.2g "
           "relative at most; least GA 100 - %.2g\n", worst, 100.0 - ga_min);
    ck_assert_double_le(worst, 1e-5);
    ck_assert_double_ge(ga_min, 100.0 - 1e-6);
    free(h);
    bst_layer_free(sys[0]), bst_layer_free(sys[1]), bst_layer_free(d), bst_layer_free(gl);
    bst_basis_free(b);
}
END_TEST

/* ------------------------------------------------------------------ reciprocity */

/* bst_metrics_reciprocity: Tf(o, i) = Tb(a(i), a(o)).  Analytic panes are reciprocal by
 * construction (1e-15); a reference Klems file's two ray-traced transmissions differ by their
 * Monte Carlo noise; a constructed layer scores what was put in. */
START_TEST(test_reciprocity)
{
    double err;
    size_t i, o;
    for (int k = 0; k < 2; k++) {
        bst_basis *b = k ? klems("full") : sc(3);
        bst_layer *gl = glass_layer("clear-6mm", b, 0);
        ck_assert_int_eq(bst_metrics_reciprocity(ctx, gl, 0, &err, NULL, NULL), BST_OK);
        ck_assert_double_le(err, 1e-15);
        bst_layer_free(gl);
        /* WCE's model gives each side of a pane its own n and tau0: with R0 different on the two
         * sides, Tf and Tb part at oblique incidence and the pane is not reciprocal */
        gl = glass_layer("t0=0.8,r0=0.1,r0b=0.05", b, 0);
        ck_assert_int_eq(bst_metrics_reciprocity(ctx, gl, 0, &err, NULL, NULL), BST_OK);
        printf("reciprocity of t0=0.8,r0=0.1,r0b=0.05 (%s): %.3g\n", bst_basis_name(b), err);
        bst_layer_free(gl);
        bst_basis_free(b);
    }
    bst_bsdf *f;
    bst_layer *rl;
    int rc = bst_bsdf_read(ctx, tu_ref("L_blind0_t4k5_klems.xml"), NULL, &f);
    ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    ck_assert(bst_bsdf_stored(f, 0, BST_TF) && bst_bsdf_stored(f, 0, BST_TB));
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, f, NULL, &rl), BST_OK);
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, rl, 0, &err, &i, &o), BST_OK);
    printf("reciprocity of L_blind0_t4k5_klems.xml: %.3g at incident %zu, outgoing %zu\n", err, i,
           o);
    ck_assert(err > 1e-3 && err < 0.1);
    bst_layer_free(rl);
    bst_bsdf_free(f);

    /* a random Tf with its exact reciprocal as Tb: 0; one element of Tb moved by delta: delta
     * over the largest value, at that element's (i, o) of Tf */
    bst_basis *b = sc(2);
    size_t n = bst_basis_size(b);
    tu_rng rng;
    tu_rng_seed(&rng, 2718);
    double *tf = malloc(2 * n * n * sizeof *tf), *tb = tf + n * n, top = 0.0;
    for (size_t k = 0; k < n * n; k++)
        tf[k] = 0.1 + tu_rng_uniform(&rng), top = fmax(top, tf[k]);
    for (size_t ii = 0; ii < n; ii++)
        for (size_t oo = 0; oo < n; oo++)
            tb[bst_basis_antipode(b, ii) + n * bst_basis_antipode(b, oo)] = tf[oo + n * ii];
    bst_layer *l = layer4(b, dense(b, tf), NULL, dense(b, tb), NULL);
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, l, 0, &err, NULL, NULL), BST_OK);
    ck_assert_double_eq(err, 0.0);
    size_t i0 = 5, o0 = 11;
    double delta = 1e-3;
    tb[bst_basis_antipode(b, i0) + n * bst_basis_antipode(b, o0)] += delta;
    ck_assert_int_eq(bst_layer_set(ctx, l, 0, BST_TB, dense(b, tb)), BST_OK);
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, l, 0, &err, &i, &o), BST_OK);
    tu_assert_close(err, delta / top, 1e-12, 0.0);
    ck_assert_uint_eq(i, i0);
    ck_assert_uint_eq(o, o0);
    /* Tb = Tf: a transposition short of reciprocity, the largest |Tf(o,i) - Tf(a(i),a(o))| */
    double want = 0.0;
    for (size_t ii = 0; ii < n; ii++)
        for (size_t oo = 0; oo < n; oo++)
            want = fmax(want, fabs(tf[oo + n * ii] -
                                   tf[bst_basis_antipode(b, ii) + n * bst_basis_antipode(b, oo)]));
    ck_assert_int_eq(bst_layer_set(ctx, l, 0, BST_TB, dense(b, tf)), BST_OK);
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, l, 0, &err, NULL, NULL), BST_OK);
    tu_assert_close(err, want / top, 1e-12, 0.0);
    /* an absent Tb counts as zero */
    bst_mat_free(bst_layer_take(l, 0, BST_TB));
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, l, 0, &err, NULL, NULL), BST_OK);
    ck_assert_double_eq(err, 1.0);
    /* errors: NULL, channel out of range, a value that is not finite */
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, NULL, 0, &err, NULL, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, l, 0, NULL, NULL, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_metrics_reciprocity(NULL, l, 0, &err, NULL, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, l, 1, &err, NULL, NULL), BST_EINVAL);
    tf[7] = NAN;
    ck_assert_int_eq(bst_layer_set(ctx, l, 0, BST_TF, dense(b, tf)), BST_OK);
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, l, 0, &err, NULL, NULL), BST_EINVAL);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "not finite"));
    free(tf);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* The dense pairs' tiled check against the element-wise definition, written out here: several
 * tiles (k = 4: 256 patches, tiles of 64; Klems full: 145, a partial tile), both precisions, and
 * three equal worst pairs where the tiles meet them out of order, (i, o) = (2, 5) before (1, 100),
 * and (n - 2, 3) in the last run of columns three threads take: the one reported is the first of
 * the element-wise loop (i, then o), on one thread and on three. */
START_TEST(test_reciprocity_tiled)
{
    for (int kb = 0; kb < 2; kb++)
        for (int fl = 0; fl < 2; fl++) {
            bst_basis *b = kb ? klems("full") : sc(4);
            size_t n = bst_basis_size(b), i, o;
            tu_rng rng;
            tu_rng_seed(&rng, 31 + (unsigned)(2 * kb + fl));
            double *tf = malloc(2 * n * n * sizeof *tf), *tb = tf + n * n, top = 0.0, err;
            for (size_t q = 0; q < n * n; q++) { /* values single precision holds exactly */
                tf[q] = (double)(float)(0.1 + tu_rng_uniform(&rng));
                tb[q] = (double)(float)(0.1 + tu_rng_uniform(&rng) * 1e-3);
            }
            for (size_t ii = 0; ii < n; ii++) /* Tb near the reciprocal of Tf */
                for (size_t oo = 0; oo < n; oo++) {
                    size_t q = bst_basis_antipode(b, ii) + n * bst_basis_antipode(b, oo);
                    tb[q] = (double)(float)(tf[oo + n * ii] + tb[q]);
                }
            size_t pi[3] = {2, 1, n - 2}, po[3] = {5, 100, 3};
            for (int t = 0; t < 3; t++) { /* the same, larger difference at three pairs */
                tf[po[t] + n * pi[t]] = 0.75;
                tb[bst_basis_antipode(b, pi[t]) + n * bst_basis_antipode(b, po[t])] = 1.25;
            }
            double want = 0.0;
            size_t wi = 0, wo = 0;
            for (size_t ii = 0; ii < n; ii++)
                for (size_t oo = 0; oo < n; oo++) {
                    double d = fabs(tf[oo + n * ii] -
                                    tb[bst_basis_antipode(b, ii) + n * bst_basis_antipode(b, oo)]);
                    if (d > want)
                        want = d, wi = ii, wo = oo;
                }
            for (size_t q = 0; q < 2 * n * n; q++)
                top = fmax(top, tf[q]);
            bst_precision prec = fl ? BST_FLOAT : BST_DOUBLE;
            bst_mat *m[2];
            for (int t = 0; t < 2; t++) {
                const double *src = t ? tb : tf;
                ck_assert_int_eq(bst_mat_new_dense(ctx, n, n, prec, &m[t]), BST_OK);
                for (size_t q = 0; q < n * n; q++) {
                    if (fl)
                        ((float *)bst_mat_dense_data(m[t]))[q] = (float)src[q];
                    else
                        ((double *)bst_mat_dense_data(m[t]))[q] = src[q];
                }
            }
            bst_layer *l = layer4(b, m[0], NULL, m[1], NULL);
            ck_assert_uint_eq(wi, 1);
            ck_assert_uint_eq(wo, 100);
            for (int th = 1; th <= 3; th += 2) { /* one thread; three, the last tie in the last */
                ck_assert_int_eq(bst_ctx_set_threads(ctx, th), BST_OK);
                ck_assert_int_eq(bst_metrics_reciprocity(ctx, l, 0, &err, &i, &o), BST_OK);
                ck_assert_uint_eq(i, wi);
                ck_assert_uint_eq(o, wo);
                tu_assert_close(err, want / top, 1e-15, 0.0);
            }
            /* an infinity in Tb, far from the first tile */
            if (fl)
                ((float *)bst_mat_dense_data(m[1]))[n * n - 3] = INFINITY;
            else
                ((double *)bst_mat_dense_data(m[1]))[n * n - 3] = INFINITY;
            for (int th = 1; th <= 3; th += 2) {
                ck_assert_int_eq(bst_ctx_set_threads(ctx, th), BST_OK);
                ck_assert_int_eq(bst_metrics_reciprocity(ctx, l, 0, &err, &i, &o), BST_EINVAL);
                ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "not finite"));
            }
            bst_layer_free(l);
            free(tf);
            bst_basis_free(b);
        }
}
END_TEST

static Suite *extremes_suite(void)
{
    Suite *s = suite_create("extremes");
    TCase *tc = tcase_create("glass");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_add_loop_test(tc, test_near_mirror, 0, 15);
    tcase_add_test(tc, test_lossless_mirror_closed_form);
    tcase_add_test(tc, test_grazing);
    suite_add_tcase(s, tc);
    tc = tcase_create("stack");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 60);
    tcase_add_loop_test(tc, test_opaque, 0, 6);
    tcase_add_loop_test(tc, test_empty_layer, 0, 2);
    tcase_add_test(tc, test_n_panes);
    tcase_add_loop_test(tc, test_extreme_values, 0,
                        2 * (int)(sizeof extreme_scale / sizeof extreme_scale[0]));
    tcase_add_test(tc, test_non_finite_input);
    tcase_add_loop_test(tc, test_facing_mirrors, 0, 2);
    suite_add_tcase(s, tc);
    tc = tcase_create("precision");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, test_single_double);
    suite_add_tcase(s, tc);
    tc = tcase_create("reciprocity");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_add_test(tc, test_reciprocity);
    tcase_add_test(tc, test_reciprocity_tiled);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(extremes_suite());
}
