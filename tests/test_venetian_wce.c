/* test_venetian_wce.c - WINDOW's venetian model (venetian:...,rule=centre; venetian_wce.c) against
 * what Windows-CalcEngine computed and against closed forms:
 * - WCE's case dg_small_102_venetian (../shared/reference/wce: slats 16 mm every 12 mm, tilt 45,
 *   flat, 5 segments, directional, in WCE's "Small" basis): the shade's matrices WCE used at the
 *   visible wavelengths (slats T = 0.2, R = 0.6) and outside them (T and R by WCE's dual-band
 *   rule (solar - f visible) / (1 - f), f = 0.499), every entry of Tf, Tb, Rf, Rb to 1e-4; and
 *   how far the default model (rule=average) lies from them;
 * - black slats: the unobstructed share of each patch's centre direction on the diagonal (the
 *   closed form 1 - w |sin(phi - tilt)| / (s cos phi)), nothing else, in both distributions;
 *   closed at +-90 degrees;
 * - uniform distribution, lossless slats (r + t = 1): T + R = 1 for every incident patch to 1e-12
 *   (it is not reciprocal: each column is one constant);
 * - directional distribution with t = 0: reciprocal (Tf(o, i) = Tb(a(i), a(o)), R(o, i) =
 *   R(a(i), a(o))) to 1e-12;
 * - the spec keys: rule, distribution, WINDOW's 5 segments, and bad values naming their key. */
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

/* WCE's dual-band rule: the value outside the visible range. */
#define WCE_F 0.499
/* The acceptance tolerance of issue #32 on WCE's matrices (1/sr). */
#define WCE_MATRIX_TOL 1e-4


/* WCE's matrix `name` (Tf, Tb, Rf, Rb) of the shade (layer 2) in block `block` of the case's
 * layer matrices, n x n row-major (outgoing, incident), zero where the file lists nothing. */
static double *wce_matrix(const char *name, int block, size_t n)
{
    FILE *fp = fopen(tu_ref("wce/cases/dg_small_102_venetian_solar_layer_matrices.tsv"), "r");
    ck_assert_msg(fp != NULL, "cannot open the case's layer matrices");
    double *m = calloc(n * n, sizeof *m);
    char line[512], cs[64], lname[64], mname[8];
    size_t found = 0;
    while (fgets(line, sizeof line, fp)) {
        int layer, blk, row, col;
        double x;
        if (sscanf(line, "%63s %d %63s %7s %d %d %d %lf", cs, &layer, lname, mname, &blk, &row, &col,
                   &x) != 8 || layer != 2 || blk != block || strcmp(mname, name) != 0)
            continue;
        ck_assert(row >= 1 && (size_t)row <= n && col >= 1 && (size_t)col <= n);
        m[(size_t)(row - 1) * n + (size_t)(col - 1)] = x;
        found++;
    }
    fclose(fp);
    ck_assert_uint_eq(found, n * n);
    return m;
}

static bst_layer *layer_of(const bst_venetian *v, const bst_basis *b)
{
    static const char *const vis[] = {"Visible"};
    bst_layer *l = NULL;
    int rc = bst_venetian_layer(ctx, v, b, 1, vis, &l);
    ck_assert_msg(rc == BST_OK, "%s", bst_ctx_message(ctx));
    return l;
}

static bst_venetian parse(const char *spec)
{
    bst_venetian v;
    ck_assert_msg(bst_venetian_parse(ctx, spec, &v) == BST_OK, "%s: %s", spec, bst_ctx_message(ctx));
    return v;
}

/* The largest |ours - WCE's| of each component against block `block` (slats t, r). */
static void against_wce(const char *spec, int block, double t, double r, double worst[BST_NCOMP])
{
    char full[256];
    snprintf(full, sizeof full, "%s,t=%.17g,r=%.17g", spec, t, r);
    bst_venetian v = parse(full);
    bst_basis *b = tu_wce_basis(ctx, "basis_wce_small.tsv");
    bst_layer *l = layer_of(&v, b);
    size_t n = bst_basis_size(b);
    for (int c = 0; c < BST_NCOMP; c++) {
        double *ref = wce_matrix(bst_comp_name((bst_comp)c), block, n);
        const bst_mat *m = bst_layer_get(l, 0, (bst_comp)c);
        worst[c] = 0;
        for (size_t o = 0; o < n; o++)
            for (size_t i = 0; i < n; i++)
                worst[c] = fmax(worst[c], fabs(bst_mat_get(m, o, i) - ref[o * n + i]));
        free(ref);
    }
    bst_layer_free(l);
    bst_basis_free(b);
}

/* dg_small_102_venetian: block 2 is the visible range (slats T = 0.2, R = 0.6), block 1 (and 3)
 * the rest, the dual-band rule applied to solar T = 0.1, R = 0.7. */
START_TEST(test_wce_case)
{
    const double tv = 0.2, rv = 0.6, ts = 0.1, rs = 0.7;
    const double slat[2][2] = {{(ts - WCE_F * tv) / (1 - WCE_F), (rs - WCE_F * rv) / (1 - WCE_F)},
                               {tv, rv}};
    const char *spec = "width=16mm,spacing=12mm,tilt=45,rule=centre,distribution=directional";
    for (int k = 0; k < 2; k++) {
        double worst[BST_NCOMP], dflt[BST_NCOMP];
        against_wce(spec, k + 1, slat[k][0], slat[k][1], worst);
        against_wce("width=16mm,spacing=12mm,tilt=45", k + 1, slat[k][0], slat[k][1], dflt);
        for (int c = 0; c < BST_NCOMP; c++) {
            printf("block %d %s: centre %.3g default %.3g\n", k + 1, bst_comp_name((bst_comp)c),
                   worst[c], dflt[c]);
            ck_assert_msg(worst[c] <= WCE_MATRIX_TOL, "block %d %s: %g from WCE's", k + 1,
                          bst_comp_name((bst_comp)c), worst[c]);
        }
    }
}
END_TEST

static bst_basis *klems_full(void)
{
    bst_basis *b = NULL;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &b), BST_OK);
    return b;
}

/* The geometric openness of profile angle phi (from the normal, towards +Y). */
static double openness(double phi, double w, double s, double tilt_deg)
{
    return fmax(0.0, 1.0 - w * fabs(sin(phi - tilt_deg * M_PI / 180)) / (s * cos(phi)));
}

/* Black slats, both distributions, horizontal and vertical: each incident patch's centre
 * direction passes its geometric openness onto the diagonal (times 1 / Lambda), from both sides
 * (from the interior against -tilt), and nothing else is transmitted or reflected; at +-90 degrees
 * the overlapping slats (width > spacing) let no light through. */
START_TEST(test_black_openness)
{
    static const char *const specs[] = {"tilt=0", "tilt=30", "tilt=-60,distribution=uniform",
                                        "tilt=45,vertical", "tilt=89,distribution=uniform",
                                        "tilt=90", "tilt=-90,vertical,distribution=uniform"};
    char spec[160];
    snprintf(spec, sizeof spec, "width=16mm,spacing=14.5mm,rule=centre,%s", specs[_i]);
    bst_venetian v = parse(spec);
    bst_basis *b = klems_full();
    bst_layer *l = layer_of(&v, b);
    size_t n = bst_basis_size(b);
    const double *lam = bst_basis_lambda(b);
    double worst = 0;
    for (size_t i = 0; i < n; i++) {
        double d[3];
        bst_basis_center(b, i, d);
        /* from the interior the slats are seen mirrored: -tilt */
        double phi = atan2(v.vertical ? d[0] : d[1], d[2]);
        double of = openness(phi, v.width, v.spacing, v.tilt), ob = openness(phi, v.width, v.spacing, -v.tilt);
        for (int c = 0; c < BST_NCOMP; c++) {
            const bst_mat *m = bst_layer_get(l, 0, (bst_comp)c);
            int t = c == BST_TF || c == BST_TB;
            double o = c == BST_TF ? of : ob;
            for (size_t out = 0; out < n; out++) {
                double want = t && out == i ? o / lam[i] : 0.0, got = bst_mat_get(m, out, i);
                worst = fmax(worst, fabs(got - want) * lam[i]);
                ck_assert_msg(fabs(got - want) * lam[i] < 1e-12, "%s: %s(%zu, %zu) = %.15g, "
                              "openness %.15g", spec, bst_comp_name((bst_comp)c), out, i, got, want);
            }
        }
    }
    printf("%s: black slats, |share - openness| at most %.3g\n", spec, worst);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* Uniform distribution, lossless slats: what enters leaves, T + R = 1 for every incident patch
 * (the exchange's view factors are exact, so only rounding is left). */
START_TEST(test_uniform_lossless)
{
    static const char *const specs[] = {"tilt=30,r=0.6,t=0.4", "tilt=-60,r=1", "tilt=45,r=0.9,t=0.1,vertical,segments=12"};
    char spec[160];
    snprintf(spec, sizeof spec, "width=16mm,spacing=14.5mm,rule=centre,distribution=uniform,%s",
             specs[_i]);
    bst_venetian v = parse(spec);
    bst_basis *b = klems_full();
    bst_layer *l = layer_of(&v, b);
    size_t n = bst_basis_size(b);
    double *h[BST_NCOMP], worst = 0;
    for (int c = 0; c < BST_NCOMP; c++) {
        h[c] = malloc(n * sizeof *h[c]);
        ck_assert_int_eq(bst_layer_hemispherical(ctx, l, 0, (bst_comp)c, h[c]), BST_OK);
    }
    for (size_t i = 0; i < n; i++) {
        double ef = h[BST_TF][i] + h[BST_RF][i] - 1, eb = h[BST_TB][i] + h[BST_RB][i] - 1;
        worst = fmax(worst, fmax(fabs(ef), fabs(eb)));
        ck_assert_msg(fabs(ef) < 1e-12 && fabs(eb) < 1e-12, "%s patch %zu: T + R - 1 = %g, %g",
                      spec, i, ef, eb);
    }
    printf("%s: |T + R - 1| at most %.3g\n", spec, worst);
    for (int c = 0; c < BST_NCOMP; c++)
        free(h[c]);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* Directional distribution: reciprocal, Tf(o, i) = Tb(a(i), a(o)) and R(o, i) = R(a(i), a(o)),
 * where WCE's exchange (I - F^T E)^-1 E is symmetric: E = r I, opaque slats whose two faces
 * reflect alike (with t > 0 or r-up != r-down it is not: WCE's exitance is not the radiosity). */
START_TEST(test_directional_reciprocity)
{
    static const char *const specs[] = {"tilt=30,r=0.7", "tilt=-50,r=0.5,segments=7",
                                        "tilt=20,r=0.8,vertical"};
    char spec[160];
    snprintf(spec, sizeof spec, "width=16mm,spacing=12mm,rule=centre,%s", specs[_i]);
    bst_venetian v = parse(spec);
    bst_basis *b = klems_full();
    bst_layer *l = layer_of(&v, b);
    size_t n = bst_basis_size(b);
    const bst_mat *tf = bst_layer_get(l, 0, BST_TF), *tb = bst_layer_get(l, 0, BST_TB);
    const bst_mat *rf = bst_layer_get(l, 0, BST_RF), *rb = bst_layer_get(l, 0, BST_RB);
    double worst = 0;
    for (size_t o = 0; o < n; o++)
        for (size_t i = 0; i < n; i++) {
            size_t ai = bst_basis_antipode(b, i), ao = bst_basis_antipode(b, o);
            double e[3] = {bst_mat_get(tf, o, i) - bst_mat_get(tb, ai, ao),
                           bst_mat_get(rf, o, i) - bst_mat_get(rf, ai, ao),
                           bst_mat_get(rb, o, i) - bst_mat_get(rb, ai, ao)};
            for (int k = 0; k < 3; k++) {
                worst = fmax(worst, fabs(e[k]));
                ck_assert_msg(fabs(e[k]) < 1e-12, "%s: (%zu, %zu) not reciprocal by %g (%d)", spec,
                              o, i, e[k], k);
            }
        }
    printf("%s: reciprocity error at most %.3g\n", spec, worst);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* The keys: rule=centre brings WINDOW's 5 segments unless segments= is given; bad values and what
 * the model lacks name their key. */
START_TEST(test_spec)
{
    bst_venetian v = parse("width=16mm,spacing=12mm");
    ck_assert(v.rule == BST_VENETIAN_AVERAGE && v.segments == BST_VENETIAN_SEGMENTS);
    v = parse("width=16mm,spacing=12mm,rule=centre");
    ck_assert(v.rule == BST_VENETIAN_CENTRE && v.distribution == BST_VENETIAN_DIRECTIONAL);
    ck_assert_int_eq(v.segments, 5);
    v = parse("width=16mm,spacing=12mm,segments=3,rule=center,distribution=uniform");
    ck_assert(v.rule == BST_VENETIAN_CENTRE && v.distribution == BST_VENETIAN_UNIFORM);
    ck_assert_int_eq(v.segments, 3);
    v = parse("width=16mm,spacing=12mm,rule=average");
    ck_assert(v.rule == BST_VENETIAN_AVERAGE && v.segments == BST_VENETIAN_SEGMENTS);
    static const char *const bad[][2] = {
        {"rule=foo", "rule: 'foo' is not average or centre"},
        {"rule=centre,distribution=foo", "distribution: 'foo' is not directional or uniform"},
        {"distribution=uniform", "distribution"},
        {"rule=average,distribution=directional", "distribution"},
        {"rule", "rule"},
        {"rule=centre,rs=0.5", "rs"},
        {"rule=centre,r=0.5/0.4,rs=0/0.2", "rs"},
        {"rule=centre,curvature=20mm", "curvature"},
        {"rule=centre,samples=4", "samples"},
        {"rule=centre,r=0.2/0.7", "r-up + t outside the visible range"},
        {"rule=centre,rule=centre", "rule"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        char spec[160];
        snprintf(spec, sizeof spec, "width=16mm,spacing=12mm,%s", bad[k][0]);
        int rc = bst_venetian_parse(ctx, spec, &v);
        ck_assert_msg(rc < 0, "%s accepted", spec);
        ck_assert_msg(strstr(bst_ctx_message(ctx), bad[k][1]) != NULL, "%s: '%s' does not say %s",
                      spec, bst_ctx_message(ctx), bad[k][1]);
        ck_assert_msg(strchr(bst_ctx_message(ctx), '\n') == NULL, "%s: more than one line", spec);
    }
    /* a struct filled by hand: the values of rule and distribution are checked too */
    v = parse("width=16mm,spacing=12mm");
    v.rule = 7;
    ck_assert_int_lt(bst_venetian_check(ctx, &v), 0);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "rule"));
    v.rule = BST_VENETIAN_CENTRE, v.distribution = -1;
    ck_assert_int_lt(bst_venetian_check(ctx, &v), 0);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "distribution"));
}
END_TEST

/* Allocation failure at every step of the layer's making: an error, no leak. */
START_TEST(test_alloc_failure)
{
    bst_venetian v = parse("width=16mm,spacing=12mm,tilt=45,r=0.6,t=0.2,rule=centre");
    bst_basis *b = tu_wce_basis(ctx, "basis_wce_small.tsv");
    int failed = 0;
    for (long k = 1; k < 200; k++) {
        tu_alloc a = {k, 0, 0};
        bst_ctx *c = bst_ctx_new();
        bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &a);
        bst_layer *l = NULL;
        int rc = bst_venetian_layer(c, &v, b, 0, NULL, &l);
        bst_layer_free(l);
        bst_ctx_free(c);
        ck_assert_msg(a.live == 0, "allocation %ld failing leaves %ld blocks", k, a.live);
        if (rc == BST_OK)
            break;
        ck_assert_int_eq(rc, BST_ENOMEM);
        failed++;
    }
    ck_assert_int_gt(failed, 3);
    bst_basis_free(b);
}
END_TEST

static Suite *venetian_wce_suite(void)
{
    Suite *s = suite_create("venetian_wce");
    TCase *tc = tcase_create("venetian_wce");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 300);
    tcase_add_test(tc, test_wce_case);
    tcase_add_loop_test(tc, test_black_openness, 0, 7);
    tcase_add_loop_test(tc, test_uniform_lossless, 0, 3);
    tcase_add_loop_test(tc, test_directional_reciprocity, 0, 3);
    tcase_add_test(tc, test_spec);
    tcase_add_test(tc, test_alloc_failure);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(venetian_wce_suite());
}
