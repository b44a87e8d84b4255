/* test_xml.c - the BSDF XML reader against RADIANCE: the worked examples of CONVENTIONS.md 12, every
 * reference query table (libBSDF's own values), the directional-hemispherical tables, energy
 * conservation of resampling, and malformed files. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <malloc.h>
#include <unistd.h>

#include <libxml/xmlmemory.h>

#include "resample.h"
#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

/* libBSDF perturbs each returned value by up to 2e-4 (trees) / 3e-4 (Klems) relative on purpose
 * (CONVENTIONS.md 6.2, 7); the tables print 7 significant digits. */
#define QUERY_RTOL 3.5e-4

static bst_bsdf *read_ok(const char *path)
{
    bst_bsdf *b;
    int rc = bst_bsdf_read(ctx, path, NULL, &b);
    ck_assert_msg(rc >= 0, "%s: %s", path, bst_ctx_message(ctx));
    return b;
}

/* Compare every row of a query table; returns the largest relative deviation. */
static double check_query_table(const char *xml, const char *table)
{
    bst_bsdf *b = read_ok(xml);
    FILE *fp = fopen(table, "r");
    ck_assert_msg(fp != NULL, "cannot open %s", table);
    char line[512];
    size_t rows = 0;
    double worst = 0;
    while (fgets(line, sizeof line, fp)) {
        char comp[8], kind[64];
        double in[3], out[3], ref, got;
        if (line[0] == '#' || sscanf(line, "%7s %63s %lf %lf %lf %lf %lf %lf %lf", comp, kind, &in[0],
                                     &in[1], &in[2], &out[0], &out[1], &out[2], &ref) != 9)
            continue;
        ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, in, out, &got), BST_OK);
        /* the same directions at 2^1000 times the length (exact): their squares overflow, the
         * value must not change */
        double bin[3], bout[3], big;
        for (int i = 0; i < 3; i++)
            bin[i] = ldexp(in[i], 1000), bout[i] = ldexp(out[i], 1000);
        ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, bin, bout, &big), BST_OK);
        ck_assert_double_eq(big, got);
        double dev = fabs(got - ref) / fmax(fabs(ref), 1e-6);
        ck_assert_msg(dev <= QUERY_RTOL, "%s row %zu (%s %s): %g vs libBSDF %g", xml, rows + 1,
                      comp, kind, got, ref);
        worst = fmax(worst, dev);
        rows++;
    }
    fclose(fp);
    ck_assert_uint_eq(rows, 1200);
    bst_bsdf_free(b);
    return worst;
}

static const char *const tables[] = {"L_glass_t4k5", "L_blind0_t4k5", "L_blind45_t4k5",
                                     "L_diffuser_t3k5", "L_glass_t4k6", "L_glass_t4k5_klems",
                                     "L_blind0_t4k5_klems", "L_blind45_t4k5_klems",
                                     "L_diffuser_t3k5_klems", "L_blind0_t4k6_klems"};

START_TEST(test_query_tables)
{
    char xml[64], tsv[64], xp[4096];
    snprintf(xml, sizeof xml, "%s.xml", tables[_i]);
    snprintf(tsv, sizeof tsv, "%s.query.tsv", tables[_i]);
    snprintf(xp, sizeof xp, "%s", tu_ref(xml));
    double worst = check_query_table(xp, tu_ref(tsv));
    printf("%s: 1200 rows, largest deviation from libBSDF %.2e\n", tables[_i], worst);
}
END_TEST

/* The k = 6 blind ships compressed: unpack it to a temporary file, read it (time and memory
 * printed), compare with its query table. */
START_TEST(test_query_k6_blind)
{
    char tmp[64];
    tu_unxz_ref("L_blind0_t4k6.xml.xz", tmp, sizeof tmp);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    double worst = check_query_table(tmp, tu_ref("L_blind0_t4k6.query.tsv"));
    clock_gettime(CLOCK_MONOTONIC, &t1);
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("L_blind0_t4k6 (109 MB): read and 1200 queries in %.1f s, peak RSS %.0f MiB, largest "
           "deviation %.2e\n", (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec),
           ru.ru_maxrss / 1024.0, worst);
    unlink(tmp);
}
END_TEST

/* CONVENTIONS.md 12: hand-made trees and a Klems matrix, bsdfquery's values. */
START_TEST(test_worked_examples)
{
    static const struct { const char *file; double in[3], out[3], want; } ex[] = {
        {"examples/k1_4d_TF.xml", {-0.3, -0.4, -0.866}, {0.5, 0.2, 0.843}, 16.00167},
        {"examples/k1_4d_TF.xml", {-0.3, -0.4, -0.866}, {0.5, -0.2, 0.843}, 15.00077},
        {"examples/k1_4d_TF.xml", {-0.3, 0.4, -0.866}, {0.5, 0.2, 0.843}, 12.00049},
        {"examples/k1_4d_TF.xml", {0.3, 0.4, -0.866}, {-0.5, -0.2, 0.843}, 0.9999304},
        {"examples/k1_4d_RF.xml", {0.5, -0.2, -0.843}, {-0.3, -0.4, -0.866}, 4.999968},
        {"examples/k1_4d_RF.xml", {-0.3, -0.4, -0.866}, {0.5, -0.2, -0.843}, 15.00077},
        {"examples/k2_4d_TF.xml", {-0.3, -0.4, -0.866}, {0.5, 0.2, 0.8426}, 1607.076},
        {"examples/k2_4d_TF.xml", {0.1, -0.6, -0.7937}, {-0.2, 0.7, 0.6856}, 1116.062},
        {"examples/k2_4d_TF.xml", {0.7, 0.1, -0.7071}, {0.05, -0.3, 0.9526}, 506.0493},
        {"examples/k2_4d_TF.xml", {-0.8, 0.5, -0.3317}, {0.6, 0.55, 0.5809}, 1412.002},
        {"examples/k2_3d_TF.xml", {-0.3420, 0, -0.9397}, {0.4162, 0.0734, 0.9063}, 705.0149},
        {"examples/k2_3d_TF.xml", {-0.3420, 0, -0.9397}, {-0.6330, 0.1116, 0.7660}, 504.9788},
        {"examples/k2_3d_TF.xml", {0, -0.8660, -0.5}, {-0.0734, 0.4162, 0.9063}, 701.0189},
        {"examples/k2_3d_TF.xml", {0, -0.8660, -0.5}, {-0.0734, -0.4162, 0.9063}, 503.0262},
        {"examples/k2_3d_TF.xml", {0.1632, 0.0594, -0.9848}, {0.8138, 0.4698, 0.3420}, 106.0008},
        {"examples/klems_TF.xml", {0, -0.173648, -0.984808}, {-0.130885, -0.315985, 0.939693}, 10.00255},
    };
    for (size_t i = 0; i < sizeof ex / sizeof ex[0]; i++) {
        bst_bsdf *b = read_ok(tu_ref(ex[i].file));
        double v;
        ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, ex[i].in, ex[i].out, &v), BST_OK);
        ck_assert_msg(fabs(v - ex[i].want) <= QUERY_RTOL * ex[i].want, "%s example %zu: %g vs %g",
                      ex[i].file, i, v, ex[i].want);
        /* the same directions at 2^-1040 times their length: subnormal components (about 32
         * significant bits, well inside these points' cells), whose squares underflow to 0 */
        double tin[3], tout[3], tiny;
        for (int k = 0; k < 3; k++)
            tin[k] = ldexp(ex[i].in[k], -1040), tout[k] = ldexp(ex[i].out[k], -1040);
        ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, tin, tout, &tiny), BST_OK);
        ck_assert_double_eq(tiny, v);
        bst_bsdf_free(b);
    }
    /* a zero or non-finite direction is refused */
    bst_bsdf *b = read_ok(tu_ref(ex[0].file));
    double v, zero[3] = {0, 0, 0}, inf[3] = {INFINITY, 0, -1}, nan3[3] = {NAN, 0, -1};
    ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, zero, ex[0].out, &v), BST_EINVAL);
    ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, ex[0].in, inf, &v), BST_EINVAL);
    ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, nan3, ex[0].out, &v), BST_EINVAL);
    bst_bsdf_free(b);
}
END_TEST

/* Directional-hemispherical T and R by libBSDF over a 64 x 64 grid of outgoing cell centres. */
START_TEST(test_hemi_tables)
{
    static const char *const names[] = {"L_glass_t4k5", "L_blind0_t4k5", "L_blind45_t4k5",
                                        "L_diffuser_t3k5", "S1_t4k5"};
    char xml[64], tsv[64];
    snprintf(xml, sizeof xml, "%s.xml", names[_i]);
    snprintf(tsv, sizeof tsv, "%s.hemi.tsv", names[_i]);
    bst_bsdf *b = read_ok(tu_ref(xml));
    bst_basis *g;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 6, &g), BST_OK);
    FILE *fp = fopen(tu_ref(tsv), "r");
    ck_assert_ptr_nonnull(fp);
    char line[512];
    int rows = 0;
    while (fgets(line, sizeof line, fp)) {
        double th, ph, t_ref, r_ref;
        char side[32];
        if (line[0] == '#' || sscanf(line, "%31s %*s %lf %lf %lf %lf", side, &th, &ph, &t_ref, &r_ref) != 5)
            continue;
        int front = strncmp(side, "front", 5) == 0;
        double d = M_PI / 180;
        /* propagation direction of the incident beam; in points back to the source */
        double prop[3] = {sin(th * d) * cos(ph * d), sin(th * d) * sin(ph * d), (front ? 1 : -1) * cos(th * d)};
        /* theta 30 at phi 0 puts the incident square coordinate exactly on a cell boundary
         * (sx = 0.75): the table was made from vectors printed with 12 decimals, which decides
         * the side; do the same */
        double in[3], t = 0, r = 0;
        for (int q = 0; q < 3; q++)
            in[q] = round(-prop[q] * 1e12) / 1e12;
        for (size_t o = 0; o < 4096; o++) {
            double c[3], out[3], v;
            bst_basis_center(g, o, c);
            out[0] = c[0], out[1] = c[1], out[2] = (front ? 1 : -1) * c[2];
            ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, in, out, &v), BST_OK);
            t += v * M_PI / 4096;
            out[2] = -out[2];
            ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, in, out, &v), BST_OK);
            r += v * M_PI / 4096;
        }
        ck_assert_msg(fabs(t - t_ref) <= 2e-4 * t_ref + 6e-5, "%s %s %g %g: T %.5f vs %.4f", names[_i], side, th, ph, t, t_ref);
        ck_assert_msg(fabs(r - r_ref) <= 2e-4 * r_ref + 6e-5, "%s %s %g %g: R %.5f vs %.4f", names[_i], side, th, ph, r, r_ref);
        rows++;
    }
    fclose(fp);
    ck_assert_int_eq(rows, 26);
    bst_basis_free(g);
    bst_bsdf_free(b);
}
END_TEST

/* Resampling a k = 5 tree: to k = 4 and 3 every coarse incident patch's hemispherical T and R is
 * the mean of its fine patches' (energy kept to 1e-9); to k = 6 every value is replicated. */
START_TEST(test_resampling_conserves)
{
    bst_bsdf *b = read_ok(tu_ref("L_blind45_t4k5.xml"));
    bst_layer *l5, *lc;
    bst_basis *b5;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b5), BST_OK);
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, b, b5, &l5), BST_OK);
    double h5[1024], hc[1024];
    for (int k = 4; k >= 3; k--) {
        bst_basis *bc;
        ck_assert_int_eq(bst_basis_new_sc(ctx, k, &bc), BST_OK);
        ck_assert_int_eq(bst_bsdf_to_layer(ctx, b, bc, &lc), BST_OK);
        size_t g = (size_t)1 << k, f = (size_t)1 << (5 - k);
        for (int c = 0; c < BST_NCOMP; c++) {
            ck_assert_int_eq(bst_layer_hemispherical(ctx, l5, 0, (bst_comp)c, h5), BST_OK);
            ck_assert_int_eq(bst_layer_hemispherical(ctx, lc, 0, (bst_comp)c, hc), BST_OK);
            for (size_t I = 0; I < g * g; I++) {
                size_t ix = I / g, iy = I % g;
                double mean = 0;
                for (size_t a = 0; a < f; a++)
                    for (size_t e = 0; e < f; e++)
                        mean += h5[(ix * f + a) * 32 + iy * f + e];
                mean /= (double)(f * f);
                tu_assert_close(hc[I], mean, 1e-9, 1e-12);
            }
        }
        bst_layer_free(lc);
        bst_basis_free(bc);
    }
    { /* up: k = 6 replicates the k = 5 cells */
        bst_basis *b6;
        bst_layer *l6;
        ck_assert_int_eq(bst_basis_new_sc(ctx, 6, &b6), BST_OK);
        ck_assert_int_eq(bst_bsdf_to_layer(ctx, b, b6, &l6), BST_OK);
        const bst_mat *m5 = bst_layer_get(l5, 0, BST_TB), *m6 = bst_layer_get(l6, 0, BST_TB);
        tu_rng r;
        tu_rng_seed(&r, 17);
        for (int s = 0; s < 20000; s++) {
            size_t i = (size_t)(tu_rng_uniform(&r) * 4096), o = (size_t)(tu_rng_uniform(&r) * 4096);
            size_t i5 = (i / 64 / 2) * 32 + (i % 64) / 2, o5 = (o / 64 / 2) * 32 + (o % 64) / 2;
            ck_assert_double_eq(bst_mat_get(m6, o, i), bst_mat_get(m5, o5, i5));
        }
        /* and down again: the mean of the 4 x 4 fine cells of every k = 5 cell pair is that cell */
        for (int s = 0; s < 2000; s++) {
            size_t i5 = (size_t)(tu_rng_uniform(&r) * 1024), o5 = (size_t)(tu_rng_uniform(&r) * 1024);
            double mean = 0;
            for (int q = 0; q < 16; q++) {
                size_t i = (i5 / 32 * 2 + (q >> 3 & 1)) * 64 + i5 % 32 * 2 + (q >> 2 & 1);
                size_t o = (o5 / 32 * 2 + (q >> 1 & 1)) * 64 + o5 % 32 * 2 + (q & 1);
                mean += bst_mat_get(m6, o, i) / 16;
            }
            tu_assert_close(mean, bst_mat_get(m5, o5, i5), 1e-15, 1e-300);
        }
        bst_layer_free(l6);
        bst_basis_free(b6);
    }
    bst_layer_free(l5);
    bst_basis_free(b5);
    bst_bsdf_free(b);
}
END_TEST

/* Mean of a rank-3 file's component c over S x S points of incident cell i and T x T points of
 * outgoing cell o of a Shirley-Chiu grid, point by point through bst_bsdf_eval; jitter > 0 moves
 * every point at random inside its stratum (then no point falls on a cell boundary). */
static double cell_mean(const bst_bsdf *b, const bst_basis *sc, int c, size_t i, size_t o, int S,
                        int T, double jitter, tu_rng *r)
{
    double zin = (c == BST_TF || c == BST_RF) ? -1 : 1, zout = (c == BST_TF || c == BST_RB) ? 1 : -1;
    double sum = 0;
    for (int si = 0; si < S * S; si++) {
        double d[3];
        bst_basis_sample(sc, i, (si / S + 0.5 + jitter * (tu_rng_uniform(r) - 0.5)) / S,
                         (si % S + 0.5 + jitter * (tu_rng_uniform(r) - 0.5)) / S, d);
        double in[3] = {-d[0], -d[1], zin * d[2]}; /* towards the source */
        for (int so = 0; so < T * T; so++) {
            double e[3], v;
            bst_basis_sample(sc, o, (so / T + 0.5 + jitter * (tu_rng_uniform(r) - 0.5)) / T,
                             (so % T + 0.5 + jitter * (tu_rng_uniform(r) - 0.5)) / T, e);
            double out[3] = {e[0], e[1], zout * e[2]};
            ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, in, out, &v), BST_OK);
            sum += v;
        }
    }
    return sum / (S * S * T * T);
}

/* A rank-3 tree on a Shirley-Chiu grid of order k (bst_bsdf_to_layer) is the mean over 2 x 2
 * points of each incident cell and 3 x 3 of each outgoing cell (2^(5-k) times as many per side
 * below the tree's depth 5), a point on a cell boundary taking the mean of the cells there.  Checked against
 * the cell mean estimated independently, point by point through bst_bsdf_eval (the lookup that
 * matches libBSDF's query tables), on twice as many points per side, each jittered in its
 * stratum: per column, accordance and the hemispherical value.  Beside it, the plain 2 x 2 x 3 x 3
 * points looked up one-sided (as a lookup does on a boundary) are reported: the scheme before. */
START_TEST(test_rank3_expansion)
{
    int k = _i;
    bst_bsdf *b = read_ok(tu_ref("L_diffuser_t3k5.xml"));
    bst_basis *sc;
    bst_layer *l;
    ck_assert_int_eq(bst_basis_new_sc(ctx, k, &sc), BST_OK);
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, b, sc, &l), BST_OK);
    size_t n = bst_basis_size(sc), G = (size_t)1 << k;
    double *ref = malloc(n * sizeof *ref), *pt = malloc(n * sizeof *pt);
    double worst_ga = 100, worst_h = 0, pt_ga = 100;
    ck_assert_ptr_nonnull(ref);
    ck_assert_ptr_nonnull(pt);
    tu_rng r;
    tu_rng_seed(&r, 3 + (uint64_t)k);
    for (int c = 0; c < BST_NCOMP; c++) {
        const bst_mat *m = bst_layer_get(l, 0, (bst_comp)c);
        for (int rep = 0; rep < (k < 5 ? 1 : 2); rep++) {
            size_t i = (size_t)(tu_rng_uniform(&r) * (double)n);
            double diff = 0, tot = 0, dh = 0, pdiff = 0, ptot = 0;
            for (size_t o = 0; o < n; o++) {
                ref[o] = cell_mean(b, sc, c, i, o, 4 << (5 - k), 6 << (5 - k), 1.0, &r);
                pt[o] = cell_mean(b, sc, c, i, o, 2, 3, 0.0, &r);
                double x = bst_mat_get(m, o, i);
                diff += fabs(x - ref[o]), tot += x + ref[o], dh += (x - ref[o]) * M_PI / (double)n;
                pdiff += fabs(pt[o] - ref[o]), ptot += pt[o] + ref[o];
            }
            worst_ga = fmin(worst_ga, 100 * (1 - diff / tot)), worst_h = fmax(worst_h, fabs(dh));
            pt_ga = fmin(pt_ga, 100 * (1 - pdiff / ptot));
        }
    }
    printf("rank-3 expansion at k = %d (%zu x %zu cells) against jittered points: least "
           "column accordance %.3f (one-sided lookup %.3f), hemispherical within %.1e\n", k, G, G,
           worst_ga, pt_ga, worst_h);
    ck_assert_double_ge(worst_ga, 99.0);
    ck_assert_double_le(worst_h, 2e-3);
    free(ref), free(pt);
    bst_layer_free(l);
    bst_basis_free(sc);
    bst_bsdf_free(b);
}
END_TEST

/* A rank-3 tree read at an order below its depth is the block average of the tree read at its
 * depth: a depth-6 tree (the rank-3 form of a specular Tf, a peak one fine cell wide, written by
 * the library without reduction) read at k = 5 equals, in every cell pair, the mean of the
 * 2 x 2 incident x 2 x 2 exit cells of order 6 inside it (basis.h: cell (ix, iy) of order 5 holds
 * (2 ix + a, 2 iy + b) of order 6), to 1e-12 relative in every cell pair.  Sampling the coarse
 * cells instead misses the peak (the scheme before: 84 % off).  The expansion shares its columns
 * among the context's threads: one thread gives the same bits as two. */
START_TEST(test_rank3_block_average)
{
    bst_basis *b6, *b5;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 6, &b6), BST_OK);
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b5), BST_OK);
    const size_t N6 = 4096, N5 = 1024;
    double *diag = malloc(N6 * sizeof *diag);
    ck_assert_ptr_nonnull(diag);
    for (size_t i = 0; i < N6; i++) {
        double d[3];
        bst_basis_center(b6, i, d);
        diag[i] = 0.9 * d[2] * (double)N6 / M_PI; /* T = 0.9 cos(theta) */
    }
    static const char *const chan[] = {"Visible"};
    bst_layer *l;
    bst_mat *tf;
    ck_assert_int_eq(bst_layer_new(ctx, b6, 1, chan, &l), BST_OK);
    ck_assert_int_eq(bst_mat_new_diag(ctx, N6, diag, &tf), BST_OK);
    ck_assert_int_eq(bst_layer_set(ctx, l, 0, BST_TF, tf), BST_OK);
    free(diag);
    bst_bsdf_write_opts o;
    bst_bsdf_write_opts_init(&o);
    o.rank = BST_RANK_3, o.reduce_pct = -1, o.iso_refine = 0;
    char path[] = "/tmp/bst_t3k6_XXXXXX";
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    close(fd);
    ck_assert_msg(bst_bsdf_write_path(ctx, l, path, &o) >= 0, "%s", bst_ctx_message(ctx));
    bst_layer_free(l);
    bst_bsdf *b = read_ok(path);
    unlink(path);
    ck_assert_int_eq(bst_bsdf_kind(b), BST_FILE_TT3);
    ck_assert_int_eq(bst_bsdf_depth(b), 6);
    double *m6 = malloc(N6 * N6 * sizeof *m6), *m5 = malloc(N5 * N5 * sizeof *m5);
    ck_assert_ptr_nonnull(m6);
    ck_assert_ptr_nonnull(m5);
    int recip;
    bst_ctx_set_threads(ctx, 2); /* the expansion's columns shared by two threads */
    ck_assert_int_eq(bsti_resample_component(ctx, b, 0, BST_TF, b6, m6, &recip), BST_OK);
    ck_assert_int_eq(recip, 0);
    ck_assert_int_eq(bsti_resample_component(ctx, b, 0, BST_TF, b5, m5, &recip), BST_OK);
    ck_assert_int_eq(recip, 0);
    /* the same bits on one thread */
    double *one = malloc(N5 * N5 * sizeof *one);
    ck_assert_ptr_nonnull(one);
    bst_ctx_set_threads(ctx, 1);
    ck_assert_int_eq(bsti_resample_component(ctx, b, 0, BST_TF, b5, one, &recip), BST_OK);
    bst_ctx_set_threads(ctx, 0);
    ck_assert_msg(memcmp(one, m5, N5 * N5 * sizeof *one) == 0,
                  "a rank-3 tree expanded on one thread differs from two threads' expansion");
    free(one);
    double worst = 0;
    size_t bad = 0;
    for (size_t I = 0; I < N5; I++)
        for (size_t O = 0; O < N5; O++) {
            double mean = 0;
            for (int q = 0; q < 16; q++) {
                size_t i = (I / 32 * 2 + (q >> 3 & 1)) * 64 + I % 32 * 2 + (q >> 2 & 1);
                size_t e = (O / 32 * 2 + (q >> 1 & 1)) * 64 + O % 32 * 2 + (q & 1);
                mean += m6[e + N6 * i] / 16;
            }
            double got = m5[O + N5 * I];
            bad += !tu_close(got, mean, 1e-12, 0.0);
            if (got != mean)
                worst = fmax(worst, fabs(got - mean) / fmax(fabs(got), fabs(mean)));
        }
    printf("rank-3 tree of depth 6 at k = 5 against the block average at k = 6: largest relative "
           "difference %.1e, %zu cell pairs beyond 1e-12\n", worst, bad);
    ck_assert_msg(bad == 0, "%zu cell pairs beyond 1e-12, largest relative difference %.2g", bad, worst);
    free(m6), free(m5);
    bst_bsdf_free(b);
    bst_basis_free(b6), bst_basis_free(b5);
}
END_TEST

/* Shirley-Chiu -> Klems keeps the hemispherical totals: every Klems patch's directional-
 * hemispherical T and R is the average over the patch's directions of the tree's (the resampling
 * weights cells by their exact overlap with the patch; checked here independently on 256 x 256
 * points per patch, uniform in projected solid angle, to 5e-4), also for the Tf that a Tb-only
 * tree yields by reciprocity. */
START_TEST(test_klems_resampling_energy)
{
    bst_bsdf *b = read_ok(tu_ref("L_blind45_t4k5.xml"));
    bst_basis *kb;
    bst_layer *lk, *l5;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &kb), BST_OK);
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, b, kb, &lk), BST_OK);
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, b, NULL, &l5), BST_OK);
    const bst_basis *b5 = bst_layer_basis(l5);
    static double hk[4][145], h5[4][1024], mean[4][145];
    for (int c = 0; c < BST_NCOMP; c++) {
        ck_assert_int_eq(bst_layer_hemispherical(ctx, lk, 0, (bst_comp)c, hk[c]), BST_OK);
        ck_assert_int_eq(bst_layer_hemispherical(ctx, l5, 0, (bst_comp)c, h5[c]), BST_OK);
    }
    const int S = 256;
    for (size_t p = 0; p < 145; p++) {
        for (int u = 0; u < S; u++)
            for (int v = 0; v < S; v++) {
                double d[3];
                bst_basis_sample(kb, p, (u + 0.5) / S, (v + 0.5) / S, d);
                size_t j = bst_basis_patch(b5, d);
                for (int c = 0; c < BST_NCOMP; c++)
                    mean[c][p] += h5[c][j] / (S * S);
            }
        for (int c = 0; c < BST_NCOMP; c++)
            ck_assert_msg(fabs(hk[c][p] - mean[c][p]) <= 5e-4, "%s patch %zu: %.6f vs %.6f",
                          bst_comp_name((bst_comp)c), p, hk[c][p], mean[c][p]);
    }
    bst_layer_free(lk), bst_layer_free(l5);
    bst_basis_free(kb);
    bst_bsdf_free(b);
}
END_TEST

/* ------------------------------------------------------------------ malformed files */

static const char *write_tmp(const char *text, size_t len)
{
    static char path[64];
    snprintf(path, sizeof path, "/tmp/bst_bad_XXXXXX");
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    ck_assert_int_eq(write(fd, text, len), (ssize_t)len);
    close(fd);
    return path;
}

#define HEAD "<?xml version=\"1.0\"?>\n<WindowElement xmlns=\"http://windows.lbl.gov\"><Optical><Layer>" \
             "<DataDefinition><IncidentDataStructure>%s</IncidentDataStructure></DataDefinition>" \
             "<WavelengthData><Wavelength unit=\"Integral\">Visible</Wavelength><WavelengthDataBlock>" \
             "<WavelengthDataDirection>%s</WavelengthDataDirection><AngleBasis>%s</AngleBasis>" \
             "<ScatteringData>%s</ScatteringData></WavelengthDataBlock></WavelengthData></Layer></Optical></WindowElement>\n"

/* Layers read in single precision: dense components are the double ones rounded to float (the
 * diffuser, at k = 4 and in Klems half, with Tf completed by reciprocity for the blind's Klems
 * read), diagonal and sparse ones are unchanged (double). */
START_TEST(test_to_layer_single)
{
    static const char *const files[] = {"L_diffuser_t3k5.xml", "L_glass_t4k5.xml", "L_blind0_t4k5.xml"};
    bst_basis *bases[2];
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &bases[0]), BST_OK);
    ck_assert_int_eq(bst_basis_new_klems(ctx, "half", &bases[1]), BST_OK);
    int dense_seen = 0;
    for (size_t f = 0; f < 3; f++) {
        bst_bsdf *b, *bf;
        bst_bsdf_read_opts single = {.precision = BST_FLOAT};
        ck_assert_int_ge(bst_bsdf_read(ctx, tu_ref(files[f]), NULL, &b), 0);
        ck_assert_int_ge(bst_bsdf_read(ctx, tu_ref(files[f]), &single, &bf), 0);
        for (int q = 0; q < 2; q++) {
            bst_layer *ld, *ls;
            ck_assert_int_eq(bst_bsdf_to_layer(ctx, b, bases[q], &ld), BST_OK);
            ck_assert_int_eq(bst_bsdf_to_layer(ctx, bf, bases[q], &ls), BST_OK);
            size_t n = bst_basis_size(bases[q]);
            for (int c = 0; c < BST_NCOMP; c++) {
                const bst_mat *md = bst_layer_get(ld, 0, (bst_comp)c), *ms = bst_layer_get(ls, 0, (bst_comp)c);
                ck_assert_int_eq(bst_mat_structure(md), bst_mat_structure(ms));
                int dense = bst_mat_structure(md) == BST_DENSE;
                dense_seen += dense;
                ck_assert_int_eq(bst_mat_precision(ms), dense ? BST_FLOAT : BST_DOUBLE);
                for (size_t j = 0; j < n; j++)
                    for (size_t i = 0; i < n; i++) {
                        double x = bst_mat_get(md, i, j);
                        ck_assert(bst_mat_get(ms, i, j) == (dense ? (double)(float)x : x));
                    }
            }
            bst_layer_free(ld), bst_layer_free(ls);
        }
        bst_bsdf_free(b), bst_bsdf_free(bf);
    }
    ck_assert_int_ge(dense_seen, 8);
    bst_bsdf *b;
    bst_bsdf_read_opts bad = {.precision = (bst_precision)7};
    ck_assert_int_eq(bst_bsdf_read(ctx, tu_ref(files[0]), &bad, &b), BST_EINVAL);
    bst_basis_free(bases[0]), bst_basis_free(bases[1]);
}
END_TEST

START_TEST(test_bad_files)
{
    static const struct { const char *structure, *dir, *basis, *data, *expect; } bad[] = {
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "{ 1 2 3 }", "not a power"},
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "{ 1 2 x 4 }", "'x' is not a number"},
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "{ 1 2 1.2.3 4 }", "'1.2.3' is not a number"},
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "{ 1 2 3 4e+ }", "'4e+' is not a number"},
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "{ 1 --2 3 4 }", "'--2' is not a number"},
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "{ 1 nan 3 4 }", "not finite"},
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "{ { 1 } { 2 } }", "2 children"},
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "{ { 1 }", "unclosed"},
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "{ 1 } }", "without a matching"},
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "", "no tree data"},
        {"TensorTree4", "Transmission Sideways", "LBNL/Shirley-Chiu", "{ 1 }", "WavelengthDataDirection"},
        {"TensorTree4", "Transmission Front", "LBNL/Klems Full", "{ 1 }", "AngleBasis"},
        {"TensorTree5", "Transmission Front", "LBNL/Shirley-Chiu", "{ 1 }", "IncidentDataStructure"},
        {"Columns", "Transmission Front", "LBNL/Klems Full", "1 2 3", "without a Klems"},
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "{ 1e99 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 }", "exceeds the single-precision range"},
        {"TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu", "{ 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 3.5e38 }", "exceeds the single-precision range"},
    };
    char buf[4096];
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        int n = snprintf(buf, sizeof buf, HEAD, bad[i].structure, bad[i].dir, bad[i].basis, bad[i].data);
        const char *p = write_tmp(buf, (size_t)n);
        bst_bsdf *b = (bst_bsdf *)1;
        int rc = bst_bsdf_read(ctx, p, NULL, &b);
        ck_assert_msg(rc < 0, "case %zu accepted", i);
        ck_assert_ptr_null(b);
        const char *msg = bst_ctx_message(ctx);
        ck_assert_msg(strstr(msg, p) && strstr(msg, bad[i].expect), "case %zu: '%s' lacks '%s'", i, msg, bad[i].expect);
        ck_assert_ptr_null(strchr(msg, '\n'));
        unlink(p);
    }
    /* truncated copies of a real file, and an empty file */
    FILE *fp = fopen(tu_ref("L_glass_t4k5.xml"), "rb");
    ck_assert_ptr_nonnull(fp);
    static char big[300000];
    size_t len = fread(big, 1, sizeof big, fp);
    fclose(fp);
    size_t cuts[] = {0, 100, 3000, len / 2, len - 20};
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; i++) {
        const char *p = write_tmp(big, cuts[i]);
        bst_bsdf *b;
        ck_assert_int_lt(bst_bsdf_read(ctx, p, NULL, &b), 0);
        ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), p));
        unlink(p);
    }
    bst_bsdf *b;
    /* negative values are read as 0, as libBSDF does (a k = 1 leaf, value 8 negative) */
    int len0 = snprintf(buf, sizeof buf, HEAD, "TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu",
                        "{ 1 2 3 4 5 6 7 -8 9 10 11 12 13 14 15 16 }");
    const char *pn = write_tmp(buf, (size_t)len0);
    ck_assert_int_ge(bst_bsdf_read(ctx, pn, NULL, &b), 0);
    double v, in0[3] = {0.3, -0.4, -0.866}, out0[3] = {0.5, 0.2, 0.843}; /* bits 0111: value 8 */
    ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, in0, out0, &v), BST_OK);
    ck_assert_double_eq(v, 0.0);
    bst_bsdf_free(b);
    unlink(pn);
    ck_assert_int_eq(bst_bsdf_read(ctx, "/nonexistent/x.xml", NULL, &b), BST_EIO);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "/nonexistent/x.xml"));
    /* Klems value count that does not fit the basis */
    fp = fopen(tu_ref("L_glass_t4k5_klems.xml"), "rb");
    static char kl[1000000];
    len = fread(kl, 1, sizeof kl, fp);
    fclose(fp);
    char *sd = strstr(kl, "<ScatteringData>");
    ck_assert_ptr_nonnull(sd);
    sd += strlen("<ScatteringData>");
    char *first_num = sd + strspn(sd, " \n\t\r");
    size_t skip = strcspn(first_num, " \n\t\r,");
    memmove(first_num, first_num + skip, len - (size_t)(first_num + skip - kl));
    len -= skip;
    const char *p = write_tmp(kl, len);
    ck_assert_int_eq(bst_bsdf_read(ctx, p, NULL, &b), BST_EFORMAT);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "21024 values"));
    unlink(p);
}
END_TEST

/* A file holds one kind of scattering data: a Klems block and a tree block, or trees of both
 * ranks, in one file are refused with one line naming the file, whichever comes first and
 * whichever channel is asked for (a mixed bst_bsdf crashed every caller: a NULL matrix or a NULL
 * overlap table); Columns and Rows mix, and an <IncidentDataStructure> that no data follows does
 * not change the kind of the blocks read. */
#define MIX_HEAD "<?xml version=\"1.0\"?>\n<WindowElement xmlns=\"http://windows.lbl.gov\"><Optical><Layer>" \
    "<DataDefinition><AngleBasis><AngleBasisName>Tiny</AngleBasisName>"                               \
    "<AngleBasisBlock><nPhis>1</nPhis><ThetaBounds><LowerTheta>0</LowerTheta><UpperTheta>45"           \
    "</UpperTheta></ThetaBounds></AngleBasisBlock><AngleBasisBlock><nPhis>3</nPhis><ThetaBounds>"      \
    "<LowerTheta>45</LowerTheta><UpperTheta>90</UpperTheta></ThetaBounds></AngleBasisBlock>"           \
    "</AngleBasis></DataDefinition>"
#define MIX_BLOCK "<WavelengthData><Wavelength unit=\"Integral\">%s</Wavelength><WavelengthDataBlock>"    \
    "<IncidentDataStructure>%s</IncidentDataStructure><WavelengthDataDirection>%s"                     \
    "</WavelengthDataDirection><AngleBasis>%s</AngleBasis><ScatteringData>%s</ScatteringData>"        \
    "</WavelengthDataBlock></WavelengthData>"
#define MIX_TAIL "%s</Layer></Optical></WindowElement>\n"

/* A bad value's message names its own line: libxml2 hands <ScatteringData>'s text over in chunks
 * of some hundred lines, and the line it counts is the chunk's end (session 53's review found
 * line 550 for a value on line 200).  The first number on line L of a real file (a Klems matrix,
 * a tensor tree) made 'bogus'. */
START_TEST(test_error_lines)
{
    static const struct { const char *file; int line; } at[] = {
        {"L_glass_t4k5_klems.xml", 111}, {"L_glass_t4k5_klems.xml", 200},
        {"L_glass_t4k5_klems.xml", 5000}, {"L_glass_t4k5_klems.xml", 21279},
        {"L_blind0_t4k5.xml", 40}, {"L_blind0_t4k5.xml", 3000}, {"L_blind0_t4k5.xml", 46000},
    };
    for (size_t k = 0; k < sizeof at / sizeof at[0]; k++) {
        FILE *fp = fopen(tu_ref(at[k].file), "rb");
        ck_assert_ptr_nonnull(fp);
        fseek(fp, 0, SEEK_END);
        size_t len = (size_t)ftell(fp);
        rewind(fp);
        char *text = malloc(len + 8);
        ck_assert_uint_eq(fread(text, 1, len, fp), len);
        fclose(fp);
        char *c = text;
        for (int l = 1; l < at[k].line; l++)
            c = strchr(c, '\n') + 1;
        char *line = c;
        c += strcspn(c, "0123456789");
        size_t n = strspn(c, "0123456789.e+-");
        ck_assert_uint_gt(n, 0);
        ck_assert_ptr_null(memchr(line, '\n', (size_t)(c - line))); /* still on line L */
        memmove(c + 5, c + n, len - (size_t)(c + n - text));
        memcpy(c, "bogus", 5);
        len = len - n + 5;
        const char *p = write_tmp(text, len);
        bst_bsdf *b;
        int rc = bst_bsdf_read(ctx, p, NULL, &b);
        ck_assert_msg(rc == BST_EFORMAT, "%s line %d: read %d", at[k].file, at[k].line, rc);
        char want[64];
        snprintf(want, sizeof want, ": line %d: ", at[k].line);
        ck_assert_msg(strstr(bst_ctx_message(ctx), want) && strstr(bst_ctx_message(ctx), "bogus"),
                      "%s line %d: '%s'", at[k].file, at[k].line, bst_ctx_message(ctx));
        unlink(p);
        free(text);
    }
}
END_TEST

START_TEST(test_mixed_kinds)
{
    static const char klems16[] = "0.1 0.1 0.1 0.1 0.1 0.1 0.1 0.1 0.1 0.1 0.1 0.1 0.1 0.1 0.1 0.1";
    static const char tt4[] = "{ 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 }", tt3[] = "{ 1 2 3 4 5 6 7 8 }";
    static const struct {
        const char *s1, *b1, *d1, *s2, *b2, *d2, *tail, *expect; /* expect NULL: read, kind below */
        bst_file_kind kind;
    } mix[] = {
        {"Columns", "Tiny", klems16, "TensorTree4", "LBNL/Shirley-Chiu", tt4, "",
         "a TensorTree4 block after Columns blocks", 0},
        {"TensorTree4", "LBNL/Shirley-Chiu", tt4, "Rows", "Tiny", klems16, "",
         "a Rows block after TensorTree4 blocks", 0},
        {"TensorTree3", "LBNL/Shirley-Chiu", tt3, "TensorTree4", "LBNL/Shirley-Chiu", tt4, "",
         "a TensorTree4 block after TensorTree3 blocks", 0},
        {"Columns", "Tiny", klems16, "Rows", "Tiny", klems16, "", NULL, BST_FILE_KLEMS},
        {"Columns", "Tiny", klems16, "Columns", "Tiny", klems16,
         "<DataDefinition><IncidentDataStructure>TensorTree3</IncidentDataStructure></DataDefinition>",
         NULL, BST_FILE_KLEMS},
        {"TensorTree3", "LBNL/Shirley-Chiu", tt3, "TensorTree3", "LBNL/Shirley-Chiu", tt3,
         "<DataDefinition><IncidentDataStructure>Columns</IncidentDataStructure></DataDefinition>",
         NULL, BST_FILE_TT3},
    };
    static const char *const only_first[] = {"Visible"};
    const bst_bsdf_read_opts first = {.channels = only_first, .nchannels = 1};
    char buf[4096];
    for (size_t i = 0; i < sizeof mix / sizeof mix[0]; i++) {
        int n = snprintf(buf, sizeof buf, MIX_HEAD MIX_BLOCK MIX_BLOCK MIX_TAIL, "Visible", mix[i].s1,
                         "Transmission Front", mix[i].b1, mix[i].d1, "Solar", mix[i].s2,
                         "Transmission Back", mix[i].b2, mix[i].d2, mix[i].tail);
        ck_assert_int_lt(n, (int)sizeof buf);
        const char *p = write_tmp(buf, (size_t)n);
        for (int opt = 0; opt < 2; opt++) {
            bst_bsdf *b = (bst_bsdf *)1;
            int rc = bst_bsdf_read(ctx, p, opt ? &first : NULL, &b);
            const char *msg = bst_ctx_message(ctx);
            if (mix[i].expect) {
                ck_assert_msg(rc == BST_EFORMAT, "case %zu/%d: status %d (%s)", i, opt, rc, msg);
                ck_assert_ptr_null(b);
                ck_assert_msg(strstr(msg, p) && strstr(msg, mix[i].expect), "case %zu: '%s' lacks '%s'",
                              i, msg, mix[i].expect);
                ck_assert_ptr_null(strchr(msg, '\n'));
                continue;
            }
            ck_assert_msg(rc >= 0, "case %zu/%d: %s", i, opt, msg);
            ck_assert_int_eq(bst_bsdf_kind(b), mix[i].kind);
            double v = -1, in[3] = {0.1, 0.2, -0.9}, out[3] = {0.3, -0.1, 0.8};
            for (size_t ch = 0; ch < bst_bsdf_nchannels(b); ch++) {
                ck_assert_int_eq(bst_bsdf_eval(ctx, b, ch, in, out, &v), BST_OK);
                ck_assert(v > 0);
            }
            bst_bsdf_free(b);
        }
        unlink(p);
    }
}
END_TEST

/* What a file is, said as it is (each read "malformed XML: Document is empty", "the file is
 * empty" or an encoder error before): a directory, UTF-32 text with or without a byte-order mark,
 * a /proc file (size 0, yet text: malformed, not empty), an empty file. */
START_TEST(test_what_a_file_is)
{
    char dir[] = "/tmp/bst_dir_XXXXXX";
    ck_assert_ptr_nonnull(mkdtemp(dir));
    bst_bsdf *b = (bst_bsdf *)1;
    ck_assert_int_eq(bst_bsdf_read(ctx, dir, NULL, &b), BST_EIO);
    ck_assert_ptr_null(b);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "a directory, not a BSDF XML file"));
    rmdir(dir);
    /* "<?xml" in UTF-32: big-endian with a mark, little-endian with one, both without */
    static const unsigned char u32[4][12] = {
        {0, 0, 0xFE, 0xFF, 0, 0, 0, '<', 0, 0, 0, '?'}, {0xFF, 0xFE, 0, 0, '<', 0, 0, 0, '?', 0, 0, 0},
        {0, 0, 0, '<', 0, 0, 0, '?', 0, 0, 0, 'x'}, {'<', 0, 0, 0, '?', 0, 0, 0, 'x', 0, 0, 0}};
    for (int i = 0; i < 4; i++) {
        const char *p = write_tmp((const char *)u32[i], sizeof u32[i]);
        ck_assert_int_eq(bst_bsdf_read(ctx, p, NULL, &b), BST_EFORMAT);
        ck_assert_msg(strstr(bst_ctx_message(ctx), "UTF-32 text"), "case %d: %s", i, bst_ctx_message(ctx));
        unlink(p);
    }
    ck_assert_int_lt(bst_bsdf_read(ctx, "/proc/self/status", NULL, &b), 0);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "malformed XML"));
    ck_assert_ptr_null(strstr(bst_ctx_message(ctx), "empty"));
    const char *p = write_tmp("", 0);
    ck_assert_int_eq(bst_bsdf_read(ctx, p, NULL, &b), BST_EFORMAT);
    ck_assert_str_eq(strstr(bst_ctx_message(ctx), ": the file is empty"), ": the file is empty");
    unlink(p);
}
END_TEST

/* A largest-allocation guard: refuses any block over `limit` bytes and records the largest asked. */
typedef struct { size_t limit, largest; } cap_alloc;
static void *cap_malloc(size_t n, void *opaque)
{
    cap_alloc *a = opaque;
    if (n > a->largest)
        a->largest = n;
    return n > a->limit ? NULL : malloc(n);
}
static void cap_free(void *p, void *opaque)
{
    (void)opaque;
    free(p);
}

/* A short Klems file that declares a huge basis (one band of 100000 patches: 10^10 values) but
 * holds three values costs what its text holds: it is refused for its value count, and no block
 * near the basis's n * n doubles (80 GB) is ever asked for (#18). */
START_TEST(test_klems_huge_basis)
{
    static const char text[] =
        "<?xml version=\"1.0\"?>\n<WindowElement xmlns=\"http://windows.lbl.gov\"><Optical><Layer>"
        "<DataDefinition><IncidentDataStructure>Columns</IncidentDataStructure><AngleBasis>"
        "<AngleBasisName>Huge</AngleBasisName><AngleBasisBlock><Theta>45</Theta><nPhis>100000</nPhis>"
        "<ThetaBounds><LowerTheta>0</LowerTheta><UpperTheta>90</UpperTheta></ThetaBounds>"
        "</AngleBasisBlock></AngleBasis></DataDefinition>"
        "<WavelengthData><Wavelength unit=\"Integral\">Visible</Wavelength><WavelengthDataBlock>"
        "<WavelengthDataDirection>Transmission Front</WavelengthDataDirection>"
        "<ColumnAngleBasis>Huge</ColumnAngleBasis><RowAngleBasis>Huge</RowAngleBasis>"
        "<ScatteringData>0.1 0.2 0.3</ScatteringData></WavelengthDataBlock></WavelengthData>"
        "</Layer></Optical></WindowElement>\n";
    const char *p = write_tmp(text, sizeof text - 1);
    bst_ctx *c = bst_ctx_new();
    cap_alloc a = {64u << 20, 0};
    ck_assert_int_eq(bst_ctx_set_allocator(c, cap_malloc, cap_free, &a), BST_OK);
    bst_bsdf *b = (bst_bsdf *)1;
    ck_assert_int_eq(bst_bsdf_read(c, p, NULL, &b), BST_EFORMAT);
    ck_assert_ptr_null(b);
    const char *msg = bst_ctx_message(c);
    ck_assert_msg(strstr(msg, p) && strstr(msg, "holds 3 values") && strstr(msg, "10000000000"),
                  "message: %s", msg);
    ck_assert_msg(a.largest <= 1u << 20, "a block of %zu bytes was asked for", a.largest);
    bst_ctx_free(c);
    unlink(p);
}
END_TEST

/* A tree where every cell of depth d - 1 (d >= 2) averages to v, the finest cells at depth d:
 * the first child descends, the others are leaves of value v, and the deepest branch holds
 * leaves alternating 0.5 v and 1.5 v. */
static void deep_tree(char *s, size_t size, int dim, int d, double v)
{
    size_t n = strlen(s);
    snprintf(s + n, size - n, "{ ");
    for (int c = 0; c < (1 << dim); c++) {
        n = strlen(s);
        if (d == 1)
            snprintf(s + n, size - n, "%g ", v * (c % 2 ? 1.5 : 0.5));
        else if (c == 0)
            deep_tree(s, size, dim, d - 1, v);
        else
            snprintf(s + n, size - n, "{ %g } ", v);
    }
    n = strlen(s);
    snprintf(s + n, size - n, "} ");
}

/* What the reader reads other than the file states is a warning (BST_WDATA) saying so: a tree
 * of depth 8 read at k = 7, negative values read as 0 (Klems and trees); depth 9 is refused. */
START_TEST(test_read_notes)
{
    static char tree[16384], buf[20000];
    for (int dim = 3; dim <= 4; dim++) {
        for (int d = 7; d <= 9; d++) {
            tree[0] = '\0';
            deep_tree(tree, sizeof tree, dim, d, 0.25);
            snprintf(buf, sizeof buf, HEAD, dim == 3 ? "TensorTree3" : "TensorTree4",
                     "Transmission Front", "LBNL/Shirley-Chiu", tree);
            const char *p = write_tmp(buf, strlen(buf));
            bst_bsdf *b = NULL;
            int rc = bst_bsdf_read(ctx, p, NULL, &b);
            if (d == 9) {
                ck_assert_int_eq(rc, BST_EFORMAT);
                ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "depth 9"));
            } else {
                ck_assert_int_eq(rc, BST_WDATA); /* Rf, Rb as zero at least */
                ck_assert_int_eq(bst_bsdf_order(b), 7);
                ck_assert_int_eq(bst_bsdf_depth(b), d);
                ck_assert_msg((d == 8) == (strstr(bst_ctx_message(ctx), "depth 8, read at k = 7") != NULL),
                              "%s", bst_ctx_message(ctx));
                /* a lookup at the finest cells is the tree's own */
                double v, in[3] = {-0.01, -0.02, -0.9997}, out[3] = {0.01, 0.02, 0.9997};
                ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, in, out, &v), BST_OK);
                ck_assert(v == 0.125 || v == 0.375 || v == 0.25);
                bst_bsdf_free(b);
            }
            unlink(p);
        }
    }
    /* negatives */
    snprintf(buf, sizeof buf, HEAD, "TensorTree4", "Transmission Front", "LBNL/Shirley-Chiu",
             "{ 1 2 3 -4 5 6 7 -8 9 10 11 12 13 14 15 16 }");
    const char *p = write_tmp(buf, strlen(buf));
    bst_bsdf *b;
    ck_assert_int_eq(bst_bsdf_read(ctx, p, NULL, &b), BST_WDATA);
    ck_assert_uint_eq(bst_bsdf_negatives(b), 2);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "2 negative values read as 0"));
    bst_bsdf_free(b);
    unlink(p);
    FILE *fp = fopen(tu_ref("L_glass_t4k5_klems.xml"), "rb");
    static char kl[1000000];
    size_t len = fread(kl, 1, sizeof kl - 8, fp);
    fclose(fp);
    kl[len] = '\0';
    char *sd = strstr(kl, "<ScatteringData>") + strlen("<ScatteringData>");
    sd += strspn(sd, " \n\t\r");
    size_t tok = strcspn(sd, " \n\t\r,");
    memmove(sd + 4, sd + tok, len + 1 - (size_t)(sd + tok - kl));
    len = len + 4 - tok;
    memcpy(sd, "-0.5", 4);
    p = write_tmp(kl, len);
    ck_assert_int_eq(bst_bsdf_read(ctx, p, NULL, &b), BST_WDATA);
    ck_assert_uint_eq(bst_bsdf_negatives(b), 1);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "1 negative value read as 0"));
    bst_bsdf_free(b);
    unlink(p);
    /* a non-finite Klems value is named by its place and text */
    memcpy(sd, " nan", 4);
    p = write_tmp(kl, len);
    ck_assert_int_eq(bst_bsdf_read(ctx, p, NULL, &b), BST_EFORMAT);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "value no. 1, 'nan', is not finite"));
    unlink(p);
    /* so is one past the trees' single-precision bound (it failed later, at the writer, naming the
     * output), and one just inside it is read */
    memcpy(sd, "1e39", 4);
    p = write_tmp(kl, len);
    ck_assert_int_eq(bst_bsdf_read(ctx, p, NULL, &b), BST_EFORMAT);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), p));
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "value no. 1, '1e39', exceeds the single-precision range"));
    unlink(p);
    memcpy(sd, "3e38", 4);
    p = write_tmp(kl, len);
    ck_assert_int_ge(bst_bsdf_read(ctx, p, NULL, &b), 0);
    bst_bsdf_free(b);
    unlink(p);
    /* two layers in one file */
    char *lay = strstr(kl, "<Layer>"), *end = strstr(kl, "</Layer>") + strlen("</Layer>");
    size_t ll = (size_t)(end - lay);
    char *two = malloc(len + ll);
    memcpy(two, kl, (size_t)(end - kl));
    memcpy(two + (end - kl), lay, ll);
    memcpy(two + (end - kl) + ll, end, len - (size_t)(end - kl));
    memcpy(two + (sd - kl), "0.50", 4);
    p = write_tmp(two, len + ll);
    free(two);
    ck_assert_int_eq(bst_bsdf_read(ctx, p, NULL, &b), BST_EFORMAT);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "a second <Layer>"));
    unlink(p);
}
END_TEST

/* ------------------------------------------------------------------ hostile XML */

/* libxml2's allocations, counted (malloc_usable_size, so that blocks allocated before the
 * counting began may be freed through it). */
static long xml_bytes;
static void *count_malloc(size_t n)
{
    void *p = malloc(n);
    if (p)
        xml_bytes += (long)malloc_usable_size(p);
    return p;
}
static void count_free(void *p)
{
    if (p)
        xml_bytes -= (long)malloc_usable_size(p);
    free(p);
}
static void *count_realloc(void *p, size_t n)
{
    long old = p ? (long)malloc_usable_size(p) : 0;
    void *q = realloc(p, n);
    if (q)
        xml_bytes += (long)malloc_usable_size(q) - old;
    return q;
}
static char *count_strdup(const char *s)
{
    char *d = count_malloc(strlen(s) + 1);
    if (d)
        strcpy(d, s);
    return d;
}

/* A reference file with `insert` placed before its first `before` (a temporary file). */
static const char *with_insert(const char *ref, const char *before, const char *insert)
{
    FILE *fp = fopen(tu_ref(ref), "rb");
    ck_assert_ptr_nonnull(fp);
    ck_assert_int_eq(fseek(fp, 0, SEEK_END), 0);
    size_t len = (size_t)ftell(fp);
    rewind(fp);
    size_t ni = strlen(insert);
    char *text = malloc(len + 1), *out = malloc(len + ni);
    ck_assert(text && out);
    ck_assert_uint_eq(fread(text, 1, len, fp), len);
    fclose(fp);
    text[len] = '\0';
    char *at = strstr(text, before);
    ck_assert_ptr_nonnull(at);
    size_t head = (size_t)(at - text);
    memcpy(out, text, head);
    memcpy(out + head, insert, ni);
    memcpy(out + head + ni, at, len - head);
    const char *p = write_tmp(out, len + ni);
    free(text);
    free(out);
    return p;
}

/* An internal DTD subset is read without leaking what libxml2 builds to hold it (12 kB a file
 * before), and entities it declares are not expanded (the billion laughs: an error at once). */
START_TEST(test_internal_dtd)
{
    ck_assert_int_eq(xmlMemSetup(count_free, count_malloc, count_realloc, count_strdup), 0);
    static const char dtd[] = "<!DOCTYPE WindowElement [\n<!ENTITY a \"aaaaaaaaaa\">\n"
                              "<!ENTITY b \"&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;\">\n]>\n";
    const char *p = with_insert("L_glass_t4k5_klems.xml", "<WindowElement", dtd);
    bst_bsdf *b = read_ok(p); /* the first read also sets up libxml2's globals */
    bst_bsdf_free(b);
    long before = xml_bytes;
    for (int i = 0; i < 3; i++)
        bst_bsdf_free(read_ok(p));
    ck_assert_msg(xml_bytes <= before, "libxml2 holds %ld more bytes after 3 reads", xml_bytes - before);
    unlink(p);

    char lol[2048] = "<?xml version=\"1.0\"?>\n<!DOCTYPE WindowElement [\n<!ENTITY l0 \"lol\">\n";
    for (int k = 1; k < 10; k++) {
        size_t n = strlen(lol);
        n += (size_t)snprintf(lol + n, sizeof lol - n, "<!ENTITY l%d \"", k);
        for (int j = 0; j < 10; j++)
            n += (size_t)snprintf(lol + n, sizeof lol - n, "&l%d;", k - 1);
        snprintf(lol + n, sizeof lol - n, "\">\n");
    }
    size_t n = strlen(lol);
    snprintf(lol + n, sizeof lol - n, "]>\n<WindowElement xmlns=\"http://windows.lbl.gov\"><Optical>"
             "<Layer><Material><Name>&l9;</Name></Material></Layer></Optical></WindowElement>\n");
    p = write_tmp(lol, strlen(lol));
    b = (bst_bsdf *)1;
    ck_assert_int_eq(bst_bsdf_read(ctx, p, NULL, &b), BST_EFORMAT);
    ck_assert_ptr_null(b);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "Entity 'l9' not defined"));
    unlink(p);
}
END_TEST

/* Long comments, processing instructions, CDATA sections and attribute values are read in
 * linear time (libxml2's push parser took over 300 s on a 200 MB comment; the tcase's timeout
 * is the bound), and an empty file says so. */
START_TEST(test_long_markup)
{
    static const char *const kinds[][2] = {{"<!--", "-->"}, {"<?pi ", "?>"},
                                           {"<Geometry><![CDATA[", "]]></Geometry>"},
                                           {"<Geometry a=\"", "\"/>"}};
    size_t big = (size_t)64 << 20;
    char *ins = malloc(big + 64);
    ck_assert_ptr_nonnull(ins);
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
        size_t a = strlen(kinds[k][0]), z = strlen(kinds[k][1]);
        memcpy(ins, kinds[k][0], a);
        memset(ins + a, 'x', big);
        memcpy(ins + a + big, kinds[k][1], z + 1);
        const char *p = with_insert("L_diffuser_t3k5_klems.xml", "<Optical>", ins);
        bst_bsdf_free(read_ok(p));
        unlink(p);
    }
    free(ins);
    const char *p = write_tmp("", 0);
    bst_bsdf *b;
    ck_assert_int_eq(bst_bsdf_read(ctx, p, NULL, &b), BST_EFORMAT);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "the file is empty"));
    unlink(p);
}
END_TEST

static Suite *xml_suite(void)
{
    Suite *s = suite_create("xml");
    TCase *tc = tcase_create("reader");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 300);
    tcase_add_test(tc, test_worked_examples);
    tcase_add_loop_test(tc, test_query_tables, 0, sizeof tables / sizeof tables[0]);
    tcase_add_test(tc, test_query_k6_blind);
    tcase_add_loop_test(tc, test_hemi_tables, 0, 5);
    tcase_add_test(tc, test_resampling_conserves);
    tcase_add_loop_test(tc, test_rank3_expansion, 4, 6);
    tcase_add_test(tc, test_rank3_block_average);
    tcase_add_test(tc, test_klems_resampling_energy);
    tcase_add_test(tc, test_to_layer_single);
    tcase_add_test(tc, test_bad_files);
    tcase_add_test(tc, test_error_lines);
    tcase_add_test(tc, test_mixed_kinds);
    tcase_add_test(tc, test_what_a_file_is);
    tcase_add_test(tc, test_klems_huge_basis);
    tcase_add_test(tc, test_internal_dtd);
    tcase_add_test(tc, test_read_notes);
    suite_add_tcase(s, tc);
    tc = tcase_create("long markup");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 60);
    tcase_add_test(tc, test_long_markup);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(xml_suite());
}
