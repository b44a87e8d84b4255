/* test_varres.c - variable resolution (issue 19) and the sun's positions.
 *
 * Variable resolution: a pane + blind + pane stack at fine order 4 over coarse order 2 (and 3),
 * written by bst_bsdf_write_varres without reduction and read back by the reader at order 4: the
 * fine incident columns equal bst_stack_columns' at order 4 rounded to single precision (what a tree
 * holds) and the full order-4 system's to 1e-8; every other incident patch equals the coarse
 * system's cell that holds it (the whole order-2 system, computed independently); the file is a
 * tree of depth 4 with fewer values than the full tree; the consistency measure bst_varres_hemi_diff
 * equals the read-back file's hemispherical values' difference and stays within
 * BST_VARRES_HEMI_TOL for two clear panes at k = 4 over 3 below 45 degrees, and not for the blind
 * over order 2;
 * every argument error.
 * Sun: gensky's printed output (a published run) and closed forms (solar noon on the
 * declination-free day, the 12-hour day at the equator, the window mapping). */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

/* ------------------------------------------------------------------ sun */

/* gensky 3 20 10 -a 40 -o 98 -m 105 printed (a published run): local solar time 10.34, solar
 * altitude and azimuth 43.3 -35.4, sun direction 0.421409 -0.593560 0.685639. */
START_TEST(test_sun_gensky_published)
{
    bst_sun_site site = {40, 98, 105};
    int jd = bst_sun_day(3, 20);
    ck_assert_int_eq(jd, 79);
    double st = bst_sun_solar_time(&site, jd, 10.0), alt, azi;
    ck_assert_msg(fabs(st - 10.34) <= 0.005, "solar time %.4f", st);
    bst_sun_position(&site, jd, st, &alt, &azi);
    ck_assert_msg(fabs(alt - 43.3) <= 0.05 && fabs(azi + 35.4) <= 0.05, "alt %.3f azi %.3f", alt, azi);
    double a = alt * M_PI / 180, z = azi * M_PI / 180;
    double dir[3] = {-sin(z) * cos(a), -cos(z) * cos(a), sin(a)}, want[3] = {0.421409, -0.593560, 0.685639};
    for (int i = 0; i < 3; i++)
        ck_assert_msg(fabs(dir[i] - want[i]) <= 2e-6, "sun direction %d: %.6f vs %.6f", i, dir[i], want[i]);
}
END_TEST

START_TEST(test_sun_closed_forms)
{
    /* day 81: declination 0 exactly; solar noon: altitude 90 - |latitude|, due south (north of
     * the equator) or north (south of it) */
    ck_assert_double_eq_tol(bst_sun_declination(81), 0.0, 1e-12);
    double dmax = -90, dmin = 90;
    for (int jd = 1; jd <= 365; jd++)
        dmax = fmax(dmax, bst_sun_declination(jd)), dmin = fmin(dmin, bst_sun_declination(jd));
    ck_assert_msg(fabs(dmax - 23.45) < 0.01 && fabs(dmin + 23.45) < 0.05, "declination %g..%g", dmin, dmax);
    for (double lat = -60; lat <= 60; lat += 15) {
        bst_sun_site site = {lat, 0, 0};
        double alt, azi;
        bst_sun_position(&site, 81, 12.0, &alt, &azi);
        tu_assert_close(alt, 90 - fabs(lat), 1e-12, 1);
        if (lat > 0)
            ck_assert_double_eq_tol(azi, 0.0, 1e-9);
        if (lat < 0)
            ck_assert_double_eq_tol(fabs(azi), 180.0, 1e-9);
    }
    /* at the equator the sun is up exactly from 6 to 18 solar time, every day */
    bst_sun_site eq = {0, 0, 0};
    for (int jd = 1; jd <= 365; jd += 30) {
        double alt;
        bst_sun_position(&eq, jd, 6.01, &alt, NULL);
        ck_assert(alt > 0);
        bst_sun_position(&eq, jd, 5.99, &alt, NULL);
        ck_assert(alt < 0);
        bst_sun_position(&eq, jd, 17.99, &alt, NULL);
        ck_assert(alt > 0);
        bst_sun_position(&eq, jd, 18.01, &alt, NULL);
        ck_assert(alt < 0);
    }
    /* the solar time shift: 4 minutes per degree of longitude from the meridian */
    bst_sun_site a = {40, 100, 105}, b = {40, 105, 105};
    tu_assert_close(bst_sun_solar_time(&a, 100, 9) - bst_sun_solar_time(&b, 100, 9), 5 * 4 / 60.0, 1e-12, 1);
}
END_TEST

START_TEST(test_sun_window)
{
    double t, p;
    /* a south window, the sun due south at altitude 30: the light travels 30 degrees off the
     * normal, downwards (-Y): phi 270 */
    ck_assert_int_eq(bst_sun_incident(30, 0, 0, &t, &p), 1);
    tu_assert_close(t, 30, 1e-12, 1);
    tu_assert_close(p, 270, 1e-12, 1);
    /* the sun 40 degrees west of south, on the horizon: seen from the room X points west, so the
     * light travels towards -X: phi 180, theta 40 */
    ck_assert_int_eq(bst_sun_incident(1e-9, 40, 0, &t, &p), 1);
    tu_assert_close(t, 40, 1e-6, 1);
    tu_assert_close(p, 180, 1e-6, 1);
    /* an east window (-90) and the sun due east at 20: normal incidence turned 20 degrees down */
    ck_assert_int_eq(bst_sun_incident(20, -90, -90, &t, &p), 1);
    tu_assert_close(t, 20, 1e-9, 1);
    tu_assert_close(p, 270, 1e-9, 1);
    /* behind the window, or below the horizon: not in front */
    ck_assert_int_eq(bst_sun_incident(30, 180, 0, &t, &p), 0);
    ck_assert_int_eq(bst_sun_incident(-5, 0, 0, &t, &p), 0);
    /* an angle that is not finite: not in front either (never a direction to combine) */
    const double not_finite[] = {NAN, INFINITY, -INFINITY};
    for (int i = 0; i < 3; i++) {
        ck_assert_int_eq(bst_sun_incident(not_finite[i], 0, 0, &t, &p), 0);
        ck_assert_int_eq(bst_sun_incident(30, not_finite[i], 0, &t, &p), 0);
        ck_assert_int_eq(bst_sun_incident(30, 0, not_finite[i], &t, &p), 0);
    }
    /* a year at 40 N, hourly, south window: every direction in front, about half the daylight
     * hours (4380 a year) */
    bst_sun_site site = {40, 105, 105};
    long n = bst_sun_path(&site, 0, 60, 0, NULL);
    ck_assert_msg(n > 1500 && n < 4380, "%ld sun positions", n);
    double (*d)[2] = malloc((size_t)n * sizeof *d);
    ck_assert_int_eq(bst_sun_path(&site, 0, 60, (size_t)n, d), n);
    for (long q = 0; q < n; q++)
        ck_assert(d[q][0] >= 0 && d[q][0] < 90 && d[q][1] >= 0 && d[q][1] < 360);
    free(d);
    /* a north window at 40 N sees the sun only on summer mornings and evenings */
    long north = bst_sun_path(&site, 180, 60, 0, NULL);
    ck_assert(north > 0 && north < n / 2);
    bst_sun_site bad = {95, 0, 0};
    ck_assert_int_eq(bst_sun_path(&bad, 0, 60, 0, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_sun_path(&site, 0, 0.5, 0, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_sun_path(&site, NAN, 60, 0, NULL), BST_EINVAL);
}
END_TEST

/* ------------------------------------------------------------------ variable resolution */

static bst_layer *load(const char *what, const bst_basis *b) { return tu_layer(ctx, what, b); }

/* The stack (names) combined at order k. */
static bst_layer *system_at(const char *const *names, size_t n, int k, bst_basis **basis)
{
    bst_layer *l[3], *sys;
    ck_assert_int_eq(bst_basis_new_sc(ctx, k, basis), BST_OK);
    for (size_t i = 0; i < n; i++)
        l[i] = load(names[i], *basis);
    ck_assert_int_eq(bst_stack_combine(ctx, n, (const bst_layer *const *)l, NULL, &sys), BST_OK);
    for (size_t i = 0; i < n; i++)
        bst_layer_free(l[i]);
    return sys;
}

static void fine_columns(const char *const *names, size_t n, int k, size_t ncols, const size_t *cols,
                         bst_mat **tf, bst_mat **rf)
{
    bst_basis *b;
    bst_layer *l[3];
    ck_assert_int_eq(bst_basis_new_sc(ctx, k, &b), BST_OK);
    for (size_t i = 0; i < n; i++)
        l[i] = load(names[i], b);
    ck_assert_int_ge(bst_stack_columns(ctx, n, (const bst_layer *const *)l, "Visible", ncols, cols, NULL, tf, rf), 0);
    for (size_t i = 0; i < n; i++)
        bst_layer_free(l[i]);
    bst_basis_free(b);
}

/* Write coarse + fine (no reduction) to a temporary file, read it back at its order. */
static bst_bsdf *write_read(const bst_layer *coarse, const bst_varres *v, bst_layer **back)
{
    char path[] = "/tmp/bst_varres_XXXXXX";
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    close(fd);
    bst_bsdf_write_opts o;
    bst_bsdf_write_opts_init(&o);
    o.reduce_pct = -1;
    int rc = bst_bsdf_write_varres_path(ctx, coarse, v, path, &o);
    ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    bst_bsdf *f;
    rc = bst_bsdf_read(ctx, path, NULL, &f);
    ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    unlink(path);
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, f, NULL, back), BST_OK);
    return f;
}

static const char *const blind_stack[] = {"glass:clear-6mm", "L_blind0_t4k5.xml", "glass:clear-6mm"};

START_TEST(test_varres_round_trip)
{
    const int k = 4, kc = 2;
    const size_t G = 16, N = 256, Gc = 4;
    /* fine patches: a few anywhere, two in one coarse cell */
    size_t cols[] = {17, 18, 100, 137, 200, 255};
    size_t ncols = sizeof cols / sizeof cols[0];
    bst_basis *bc, *bf;
    bst_layer *coarse = system_at(blind_stack, 3, kc, &bc), *full = system_at(blind_stack, 3, k, &bf);
    bst_mat *tf, *rf;
    fine_columns(blind_stack, 3, k, ncols, cols, &tf, &rf);
    const bst_mat *tfs[1] = {tf}, *rfs[1] = {rf};
    bst_varres v = {k, ncols, cols, tfs, rfs};
    bst_layer *back;
    bst_bsdf *f = write_read(coarse, &v, &back);
    ck_assert_int_eq(bst_bsdf_kind(f), BST_FILE_TT4);
    ck_assert_int_eq(bst_bsdf_order(f), k);
    ck_assert_int_eq(bst_bsdf_depth(f), k);
    for (int c = 0; c < BST_NCOMP; c++)
        ck_assert_int_eq(bst_bsdf_stored(f, 0, (bst_comp)c), 1);
    for (int c = 0; c < BST_NCOMP; c++) {
        const bst_mat *m = bst_layer_get(back, 0, (bst_comp)c), *cm = bst_layer_get(coarse, 0, (bst_comp)c);
        const bst_mat *fm = c == BST_TF ? tf : c == BST_RF ? rf : NULL, *whole = bst_layer_get(full, 0, (bst_comp)c);
        for (size_t i = 0; i < N; i++) {
            long q = -1;
            for (size_t j = 0; j < ncols; j++)
                q = cols[j] == i ? (long)j : q;
            for (size_t o = 0; o < N; o++) {
                double got = bst_mat_get(m, o, i), want;
                if (q >= 0 && fm) {
                    want = bst_mat_get(fm, o, (size_t)q);
                    /* the whole fine system agrees with the iterated column */
                    ck_assert_msg(fabs(want - bst_mat_get(whole, o, i)) <= 1e-8 * fmax(1, fabs(want)),
                                  "comp %d patch %zu exit %zu: column %.10g vs full %.10g", c, i, o,
                                  want, bst_mat_get(whole, o, i));
                } else {
                    size_t ci = (i / G) / 4 * Gc + (i % G) / 4, co = (o / G) / 4 * Gc + (o % G) / 4;
                    want = bst_mat_get(cm, co, ci);
                }
                want = (double)(float)fmax(want, 0.0); /* a tree holds single precision */
                ck_assert_msg(fabs(got - want) <= 1e-9 * fabs(want),
                              "comp %d incident %zu exit %zu: read %.10g, expected %.10g", c, i, o, got, want);
            }
        }
    }
    /* the consistency measure: the fine column's hemispherical value minus that of a coarse cell,
     * here read back from the file at a non-fine patch of the same coarse cell (19 shares 17's) */
    double diff[6], worst, hb[256];
    ck_assert_int_eq(bst_varres_hemi_diff(ctx, coarse, &v, 0, BST_TF, diff, &worst), BST_OK);
    ck_assert_int_eq(bst_layer_hemispherical(ctx, back, 0, BST_TF, hb), BST_OK);
    tu_assert_close(diff[0], hb[17] - hb[19], 1e-6, 1);
    double big = 0;
    for (size_t q = 0; q < ncols; q++)
        big = fmax(big, fabs(diff[q]));
    ck_assert_double_eq(worst, big);
    /* a blind over a 4 x 4 coarse grid: its columns' T differs from the coarse cells' by more
     * than the tolerance, which is what the check is for */
    ck_assert_msg(worst > BST_VARRES_HEMI_TOL, "worst %g", worst);
    bst_bsdf_free(f);
    bst_layer_free(back), bst_layer_free(coarse), bst_layer_free(full);
    bst_mat_free(tf), bst_mat_free(rf);
    bst_basis_free(bc), bst_basis_free(bf);
}
END_TEST

/* Two clear panes at k = 4 over 3, fine directions up to 45 degrees (coarse cells reaching 48.6):
 * the consistency holds. */
START_TEST(test_varres_consistent_panes)
{
    static const char *const panes[] = {"glass:clear-6mm", "glass:lowiron-6mm"};
    bst_basis *bc, *bf;
    bst_layer *coarse = system_at(panes, 2, 3, &bc);
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &bf), BST_OK);
    size_t cols[256], ncols = 0;
    for (size_t i = 0; i < 256; i++) {
        double d[3];
        bst_basis_center(bf, i, d);
        if (acos(d[2]) < 45 * M_PI / 180)
            cols[ncols++] = i;
    }
    bst_mat *tf, *rf;
    fine_columns(panes, 2, 4, ncols, cols, &tf, &rf);
    const bst_mat *tfs[1] = {tf}, *rfs[1] = {rf};
    bst_varres v = {4, ncols, cols, tfs, rfs};
    double *diff = malloc(ncols * sizeof *diff), worst[2];
    ck_assert_int_eq(bst_varres_hemi_diff(ctx, coarse, &v, 0, BST_TF, diff, &worst[0]), BST_OK);
    ck_assert_int_eq(bst_varres_hemi_diff(ctx, coarse, &v, 0, BST_RF, diff, &worst[1]), BST_OK);
    ck_assert_msg(worst[0] <= BST_VARRES_HEMI_TOL && worst[1] <= BST_VARRES_HEMI_TOL, "T %g R %g",
                  worst[0], worst[1]);
    ck_assert(worst[0] > 0); /* not trivially: the fine columns differ from the coarse ones */
    /* the file: the reader sees depth 4 and fewer values than a full order-4 tree would need */
    bst_layer *back;
    bst_bsdf *f = write_read(coarse, &v, &back);
    ck_assert_int_eq(bst_bsdf_order(f), 4);
    bst_bsdf_free(f);
    free(diff);
    bst_layer_free(back), bst_layer_free(coarse);
    bst_mat_free(tf), bst_mat_free(rf);
    bst_basis_free(bc), bst_basis_free(bf);
}
END_TEST

/* The tree is variable in depth: only the fine incident cells go below the coarse order. */
static int sink_count(const char *buf, size_t len, void *opaque)
{
    (void)buf;
    *(size_t *)opaque += len;
    return 0;
}

START_TEST(test_varres_errors)
{
    bst_basis *bc;
    static const char *const panes[] = {"glass:clear-6mm"};
    bst_layer *coarse = system_at(panes, 1, 2, &bc);
    size_t cols[2] = {5, 3};
    bst_mat *m;
    ck_assert_int_eq(bst_mat_new_zero(ctx, 256, 2, &m), BST_OK);
    const bst_mat *ms[1] = {m};
    bst_varres v = {4, 2, cols, ms, NULL};
    FILE *fp = fopen("/dev/null", "w");
    ck_assert_ptr_nonnull(fp);
    /* columns out of order */
    ck_assert_int_eq(bst_bsdf_write_varres(ctx, coarse, &v, fp, NULL), BST_EINVAL);
    cols[0] = 1;
    ck_assert_int_ge(bst_bsdf_write_varres(ctx, coarse, &v, fp, NULL), 0);
    /* fine not above coarse, beyond BST_K_MAX */
    v.k = 2;
    ck_assert_int_eq(bst_bsdf_write_varres(ctx, coarse, &v, fp, NULL), BST_EINVAL);
    v.k = BST_K_MAX + 1;
    ck_assert_int_eq(bst_bsdf_write_varres(ctx, coarse, &v, fp, NULL), BST_EINVAL);
    /* columns of the wrong size */
    v.k = 3;
    ck_assert_int_eq(bst_bsdf_write_varres(ctx, coarse, &v, fp, NULL), BST_ESIZE);
    /* rank 3 asked */
    v.k = 4;
    bst_bsdf_write_opts o;
    bst_bsdf_write_opts_init(&o);
    o.rank = BST_RANK_3;
    ck_assert_int_eq(bst_bsdf_write_varres(ctx, coarse, &v, fp, &o), BST_EINVAL);
    ck_assert_int_eq(bst_bsdf_write_varres(ctx, coarse, NULL, fp, NULL), BST_EINVAL);
    double diff[2];
    ck_assert_int_eq(bst_varres_hemi_diff(ctx, coarse, &v, 0, BST_TB, diff, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_varres_hemi_diff(ctx, coarse, &v, 1, BST_TF, diff, NULL), BST_EINVAL);
    fclose(fp);
    bst_mat_free(m);
    bst_layer_free(coarse);
    bst_basis_free(bc);
}
END_TEST

/* Size: the variable tree of a fine patch or two is far below a full order-k tree. */
START_TEST(test_varres_size)
{
    bst_basis *bc, *bf;
    bst_layer *coarse = system_at(blind_stack, 3, 2, &bc), *full = system_at(blind_stack, 3, 4, &bf);
    size_t cols[1] = {100};
    bst_mat *tf, *rf;
    fine_columns(blind_stack, 3, 4, 1, cols, &tf, &rf);
    const bst_mat *tfs[1] = {tf}, *rfs[1] = {rf};
    bst_varres v = {4, 1, cols, tfs, rfs};
    bst_bsdf_write_opts o;
    bst_bsdf_write_opts_init(&o);
    o.reduce_pct = -1;
    o.recip_tol = -1;
    size_t vbytes = 0, fbytes = 0, cbytes = 0;
    ck_assert_int_ge(bst_bsdf_write_fn(ctx, full, sink_count, &fbytes, &o), 0);
    ck_assert_int_ge(bst_bsdf_write_fn(ctx, coarse, sink_count, &cbytes, &o), 0);
    FILE *fp = tmpfile();
    ck_assert_int_ge(bst_bsdf_write_varres(ctx, coarse, &v, fp, &o), 0);
    vbytes = (size_t)ftell(fp);
    fclose(fp);
    /* one fine incident cell of 256 holds 256 values where the coarse part holds 1 per cell */
    ck_assert_msg(vbytes > cbytes && vbytes < fbytes / 4, "variable %zu, coarse %zu, full %zu bytes",
                  vbytes, cbytes, fbytes);
    bst_mat_free(tf), bst_mat_free(rf);
    bst_layer_free(coarse), bst_layer_free(full);
    bst_basis_free(bc), bst_basis_free(bf);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("varres");
    TCase *tc = tcase_create("sun");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_add_test(tc, test_sun_gensky_published);
    tcase_add_test(tc, test_sun_closed_forms);
    tcase_add_test(tc, test_sun_window);
    suite_add_tcase(s, tc);
    tc = tcase_create("varres");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, test_varres_round_trip);
    tcase_add_test(tc, test_varres_consistent_panes);
    tcase_add_test(tc, test_varres_errors);
    tcase_add_test(tc, test_varres_size);
    suite_add_tcase(s, tc);
    return tu_run(s);
}
