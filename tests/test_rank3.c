/* test_rank3.c - the rank-3 (isotropic) form of a Shirley-Chiu matrix (ttree_rank3.c) against a
 * direct computation of its definition (ttree_write.h): every incident cell of a ring sampled in
 * turn, the matrix read element by element, the corrections applied iteration after iteration
 * to the whole tensor.  The library instead samples one quadrant and sums the four turned
 * columns, runs each ring to the end on its own, keeps sample-to-cell tables and shares the rings
 * among threads; the sums thus differ in order only, so the two agree to rounding, and every
 * thread count and table size must give the very same bits.  Also: the early stop (fa_stop), a
 * zero matrix, wrong sizes and allocation failures. */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "basis.h"
#include "ctx.h"
#include "testutil.h"
#include "ttree_write.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

/* ------------------------------------------------------------------ the definition, directly */

struct ref {
    size_t G, N, half, si, so;
    double *in, *out;
};

static size_t ref_ring(size_t c, size_t G)
{
    long a = labs(2 * (long)(c / G) + 1 - (long)G), b = labs(2 * (long)(c % G) + 1 - (long)G);
    return (size_t)((a > b ? a : b) / 2);
}

/* Grid v at the disk point (r, phi): the mean of the cells that hold it (one unless it lies on
 * a boundary), as the reader takes it. */
static double ref_value(const double *v, double r, double phi, size_t G)
{
    size_t cells[4];
    int n = bsti_sc_polar_cells(r, phi, G, cells);
    double s = 0.0;
    for (int j = 0; j < n; j++)
        s += v[cells[j]];
    return s / n;
}

/* t3 row of every ring += the mean over the ring's cells i, their sample azimuths and the sample
 * points of each rank-3 outgoing cell q (turned by the azimuth into the world frame) of R(., i). */
static void ref_gather(const struct ref *f, const double *R, double *t3)
{
    double *add = calloc(f->half * f->N, sizeof *add);
    for (size_t i = 0; i < f->N; i++) {
        double *row = add + (f->half - 1 - ref_ring(i, f->G)) * f->N;
        for (size_t s = 0; s < f->si; s++) {
            double phi = f->in[2 * (i * f->si + s) + 1];
            for (size_t q = 0; q < f->N; q++)
                for (size_t t = 0; t < f->so; t++) {
                    const double *p = f->out + 2 * (q * f->so + t);
                    row[q] += ref_value(R + f->N * i, p[0], p[1] + phi, f->G);
                }
        }
    }
    for (size_t j = 0; j < f->half; j++)
        for (size_t q = 0; q < f->N; q++) {
            double *x = &t3[(f->half - 1 - j) * f->N + q];
            *x += add[(f->half - 1 - j) * f->N + q] / ((double)(8 * j + 4) * (double)(f->si * f->so));
            if (*x < 0.0)
                *x = 0.0;
        }
    free(add);
}

/* E(o, i): the mean of the row of i's ring over the sample points of i and of o, turned back. */
static void ref_expand(const struct ref *f, const double *t3, double *E)
{
    for (size_t i = 0; i < f->N; i++) {
        const double *row = t3 + (f->half - 1 - ref_ring(i, f->G)) * f->N;
        for (size_t o = 0; o < f->N; o++) {
            double sum = 0.0;
            for (size_t s = 0; s < f->si; s++)
                for (size_t t = 0; t < f->so; t++) {
                    const double *p = f->out + 2 * (o * f->so + t);
                    sum += ref_value(row, p[0], p[1] - f->in[2 * (i * f->si + s) + 1], f->G);
                }
            E[o + f->N * i] = sum / (double)(f->si * f->so);
        }
    }
}

/* FA (%) of every incident cell, least one, and the largest hemispherical change. */
static void ref_measure(const struct ref *f, const double *M, const double *E, double *fa,
                        double *hemi)
{
    *fa = 100.0, *hemi = 0.0;
    for (size_t i = 0; i < f->N; i++) {
        double d = 0.0, s = 0.0, h = 0.0;
        for (size_t o = 0; o < f->N; o++) {
            double a = M[o + f->N * i], b = E[o + f->N * i];
            d += fabs(a - b), s += fabs(a) + fabs(b), h += a - b;
        }
        if (s > 0.0)
            *fa = fmin(*fa, 100.0 * (1.0 - d / s));
        *hemi = fmax(*hemi, fabs(h) * M_PI / (double)f->N);
    }
}

static void ref_build(const bst_mat *m, int k, int refine, double fa_stop, double *t3, double *fa,
                      double *hemi)
{
    struct ref f;
    f.G = (size_t)1 << k, f.N = f.G * f.G, f.half = f.G / 2;
    f.si = BSTI_TT3_IN_SAMPLES * BSTI_TT3_IN_SAMPLES;
    f.so = BSTI_TT3_OUT_SAMPLES * BSTI_TT3_OUT_SAMPLES;
    ck_assert_int_eq(bsti_sc_cell_points(ctx, f.G, BSTI_TT3_IN_SAMPLES, &f.in), BST_OK);
    ck_assert_int_eq(bsti_sc_cell_points(ctx, f.G, BSTI_TT3_OUT_SAMPLES, &f.out), BST_OK);
    double *M = malloc(f.N * f.N * sizeof *M), *E = malloc(f.N * f.N * sizeof *E);
    double *R = malloc(f.N * f.N * sizeof *R);
    ck_assert_int_eq(bst_mat_to_dense_array(ctx, m, M), BST_OK);
    memset(t3, 0, f.half * f.N * sizeof *t3);
    ref_gather(&f, M, t3);
    for (int it = 0;; it++) {
        ref_expand(&f, t3, E);
        ref_measure(&f, M, E, fa, hemi);
        if (it == refine || *fa < fa_stop)
            break;
        for (size_t x = 0; x < f.N * f.N; x++)
            R[x] = M[x] - E[x];
        ref_gather(&f, R, t3);
    }
    free(M), free(E), free(R);
    bsti_free(ctx, f.in);
    bsti_free(ctx, f.out);
}

/* ------------------------------------------------------------------ test matrices */

enum { SMOOTH, NOISE, CENTRE_NOISE };

/* N x N, order k: SMOOTH, a Lambertian part and a lobe about the mirror direction (isotropic
 * but for the grid); NOISE, uniform random values (anisotropic); CENTRE_NOISE, SMOOTH but for
 * noise in the columns of the innermost ring (the ring handled last).  prec and s choose the storage
 * (BST_SPARSE: every third value dropped, read through bst_mat_get). */
static bst_mat *test_matrix(int k, int kind, bst_precision prec, bst_structure s, uint64_t seed)
{
    size_t G = (size_t)1 << k, N = G * G;
    double *x = malloc(N * sizeof *x), *y = malloc(N * sizeof *y), *v = malloc(N * N * sizeof *v);
    for (size_t c = 0; c < N; c++)
        bsti_sc_square_to_disk(((double)(c / G) + 0.5) / (double)G, ((double)(c % G) + 0.5) / (double)G,
                               &x[c], &y[c]);
    tu_rng r;
    tu_rng_seed(&r, seed);
    for (size_t i = 0; i < N; i++)
        for (size_t o = 0; o < N; o++) {
            double dx = x[o] + x[i], dy = y[o] + y[i]; /* exit minus the mirrored incidence */
            int noise = kind == NOISE || (kind == CENTRE_NOISE && ref_ring(i, G) == 0);
            v[o + N * i] = noise ? tu_rng_uniform(&r) : 0.1 + 3.0 * exp(-(dx * dx + dy * dy) / 0.05);
        }
    bst_mat *m = NULL;
    if (s == BST_SPARSE) {
        size_t nnz = 0, *row = malloc(N * N * sizeof *row), *col = malloc(N * N * sizeof *col);
        double *val = malloc(N * N * sizeof *val);
        for (size_t i = 0; i < N; i++)
            for (size_t o = 0; o < N; o++)
                if ((o + 7 * i) % 3 != 0)
                    row[nnz] = o, col[nnz] = i, val[nnz++] = v[o + N * i];
        ck_assert_int_eq(bst_mat_new_sparse(ctx, N, N, nnz, row, col, val, &m), BST_OK);
        ck_assert_int_eq(bst_mat_structure(m), BST_SPARSE);
        free(row), free(col), free(val);
    } else {
        ck_assert_int_eq(bst_mat_new_dense(ctx, N, N, prec, &m), BST_OK);
        void *d = bst_mat_dense_data(m);
        for (size_t e = 0; e < N * N; e++) {
            if (prec == BST_DOUBLE)
                ((double *)d)[e] = v[e];
            else
                ((float *)d)[e] = (float)v[e];
        }
    }
    free(x), free(y), free(v);
    return m;
}

/* ------------------------------------------------------------------ tests */

static int build1(bst_ctx *c, const bst_mat *m, int k, int refine, double stop, int threads,
                  size_t table, size_t boundary, double *t3, double *fa, double *hemi)
{
    bsti_tt3_job jb = {m, t3, -1.0, -1.0};
    int rc = bsti_tt3_build(c, k, refine, stop, 0, threads, table, boundary, 1, &jb);
    *fa = jb.fa_min, *hemi = jb.hemi_max;
    return rc;
}

/* The library against the definition, for each storage of the matrix, orders 2 to 4. */
START_TEST(test_matches_definition)
{
    static const struct { int k, kind; bst_precision prec; bst_structure s; } cases[] = {
        {2, SMOOTH, BST_DOUBLE, BST_DENSE}, {3, SMOOTH, BST_DOUBLE, BST_DENSE},
        {4, SMOOTH, BST_DOUBLE, BST_DENSE}, {3, SMOOTH, BST_FLOAT, BST_DENSE},
        {3, SMOOTH, BST_DOUBLE, BST_SPARSE}, {3, NOISE, BST_DOUBLE, BST_DENSE}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        int k = cases[c].k;
        size_t G = (size_t)1 << k, n = G * G * G / 2;
        bst_mat *m = test_matrix(k, cases[c].kind, cases[c].prec, cases[c].s, 11 + c);
        double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), fa, ha, fb, hb, big = 0.0;
        ck_assert_int_eq(bsti_tt3_from_sc(ctx, m, k, BSTI_TT3_REFINE, -INFINITY, a, &fa, &ha),
                         BST_OK);
        ref_build(m, k, BSTI_TT3_REFINE, -INFINITY, b, &fb, &hb);
        for (size_t x = 0; x < n; x++)
            big = fmax(big, b[x]);
        ck_assert(big > 0.0);
        for (size_t x = 0; x < n; x++)
            tu_assert_close(a[x], b[x], 1e-11, big);
        tu_assert_close(fa, fb, 1e-11, 100.0);
        tu_assert_close(ha, hb, 1e-9, 1.0);
        /* the smooth lobe is nearly isotropic (not with a third of it dropped), the noise is not */
        if (cases[c].kind == SMOOTH && cases[c].s == BST_DENSE && k >= 3)
            ck_assert_msg(fa > 90.0, "case %zu: FA %g", c, fa);
        if (cases[c].kind == NOISE)
            ck_assert_msg(fa < 80.0, "case %zu: FA %g", c, fa);
        free(a), free(b);
        bst_mat_free(m);
    }
}
END_TEST

/* 1, 2 and 3 threads, tables of every size (none, some rings' cells only, all), and tables
 * given up on for their boundary points (a ring's cells with more than 0, 40 or 600 of them; the
 * others keep theirs in the same room): the same bits. */
START_TEST(test_threads_tables_same_bits)
{
    int k = 4;
    size_t G = (size_t)1 << k, n = G * G * G / 2;
    bst_mat *m = test_matrix(k, SMOOTH, BST_FLOAT, BST_DENSE, 5);
    double *base = malloc(n * sizeof *base), *t3 = malloc(n * sizeof *t3), f0, h0, f, h;
    ck_assert_int_eq(build1(ctx, m, k, 4, -INFINITY, 1, 0, 0, base, &f0, &h0), BST_OK);
    static const size_t tables[] = {0, 4096, 60000, BSTI_TT3_TABLE_BYTES};
    static const size_t boundary[] = {0, 1, 40, 600};
    for (int th = 1; th <= 3; th++)
        for (size_t tb = 0; tb < sizeof tables / sizeof tables[0]; tb++)
            for (size_t bd = 0; bd < sizeof boundary / sizeof boundary[0]; bd++) {
                memset(t3, 0xff, n * sizeof *t3);
                ck_assert_int_eq(build1(ctx, m, k, 4, -INFINITY, th, tables[tb], boundary[bd], t3,
                                        &f, &h), BST_OK);
                ck_assert_msg(memcmp(t3, base, n * sizeof *t3) == 0,
                              "threads %d, table %zu, boundary points %zu", th, tables[tb],
                              boundary[bd]);
                ck_assert(f == f0 && h == h0);
            }
    free(base), free(t3);
    bst_mat_free(m);
}
END_TEST

/* A matrix whose FA falls below fa_stop: the iterate measured there is returned, as the
 * definition's loop does, and is the one that many corrections give without a stop. */
START_TEST(test_early_stop)
{
    int k = 3;
    size_t G = (size_t)1 << k, n = G * G * G / 2;
    bst_mat *m = test_matrix(k, NOISE, BST_DOUBLE, BST_DENSE, 3);
    double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), fa, ha, fb, hb, f1, h1;
    double stop = 70.0;
    ck_assert_int_eq(build1(ctx, m, k, 3, stop, 2, BSTI_TT3_TABLE_BYTES, 0, a, &fa, &ha),
                     BST_OK);
    ck_assert(fa < stop);
    ref_build(m, k, 3, stop, b, &fb, &hb);
    tu_assert_close(fa, fb, 1e-11, 100.0);
    for (size_t x = 0; x < n; x++)
        tu_assert_close(a[x], b[x], 1e-11, 1.0);
    /* stopped at the first measurement: no correction applied */
    ck_assert_int_eq(build1(ctx, m, k, 0, -INFINITY, 1, 0, 0, b, &f1, &h1), BST_OK);
    ck_assert(memcmp(a, b, n * sizeof *a) == 0 && f1 == fa && h1 == ha);
    free(a), free(b);
    bst_mat_free(m);
}
END_TEST

/* The innermost ring falls below fa_stop after the outer ones ran every correction: those run
 * again up to the first iterate, with 1 thread and with 2. */
START_TEST(test_early_stop_late_ring)
{
    int k = 3;
    size_t G = (size_t)1 << k, n = G * G * G / 2;
    bst_mat *m = test_matrix(k, CENTRE_NOISE, BST_DOUBLE, BST_DENSE, 9);
    double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), fa, ha, fb, hb;
    double stop = 95.0;
    ref_build(m, k, 3, -INFINITY, b, &fb, &hb);
    ck_assert_msg(fb < stop, "FA %g", fb); /* the ring stays below even when corrected */
    ref_build(m, k, 3, stop, b, &fb, &hb);
    for (int th = 1; th <= 2; th++) {
        ck_assert_int_eq(build1(ctx, m, k, 3, stop, th, BSTI_TT3_TABLE_BYTES, 0, a, &fa, &ha), BST_OK);
        tu_assert_close(fa, fb, 1e-11, 100.0);
        tu_assert_close(ha, hb, 1e-9, 1.0);
        for (size_t x = 0; x < n; x++)
            tu_assert_close(a[x], b[x], 1e-11, 4.0);
    }
    free(a), free(b);
    bst_mat_free(m);
}
END_TEST

/* Several matrices at once (one stopping early, one zero) on 2 threads with tables: each the same
 * bits as alone on 1 thread without tables. */
START_TEST(test_many_same_bits)
{
    int k = 4;
    size_t G = (size_t)1 << k, N = G * G, n = N * G / 2;
    bst_mat *m[4];
    m[0] = test_matrix(k, SMOOTH, BST_DOUBLE, BST_DENSE, 21);
    m[1] = test_matrix(k, NOISE, BST_FLOAT, BST_DENSE, 22);
    ck_assert_int_eq(bst_mat_new_zero(ctx, N, N, &m[2]), BST_OK);
    m[3] = test_matrix(k, CENTRE_NOISE, BST_FLOAT, BST_DENSE, 23);
    bsti_tt3_job jobs[4];
    double stop = 90.0, *one = malloc(n * sizeof *one), f, h;
    for (int j = 0; j < 4; j++) {
        jobs[j].m = m[j];
        jobs[j].t3 = malloc(n * sizeof *jobs[j].t3);
        memset(jobs[j].t3, 0xff, n * sizeof *jobs[j].t3);
    }
    ck_assert_int_eq(bsti_tt3_build(ctx, k, 3, stop, 0, 2, BSTI_TT3_TABLE_BYTES, 0, 4, jobs), BST_OK);
    for (int j = 0; j < 4; j++) {
        ck_assert_int_eq(build1(ctx, m[j], k, 3, stop, 1, 0, 0, one, &f, &h), BST_OK);
        ck_assert_msg(memcmp(one, jobs[j].t3, n * sizeof *one) == 0, "matrix %d", j);
        ck_assert(f == jobs[j].fa_min && h == jobs[j].hemi_max);
        free(jobs[j].t3);
        bst_mat_free(m[j]);
    }
    ck_assert_msg(jobs[0].fa_min > stop && jobs[1].fa_min < stop && jobs[2].fa_min == 100.0 &&
                  jobs[3].fa_min < stop, "FA %g %g %g %g", jobs[0].fa_min, jobs[1].fa_min,
                  jobs[2].fa_min, jobs[3].fa_min);
    free(one);
}
END_TEST

/* give_up: a matrix below fa_stop stops all, its FA below fa_stop; without one below, the same
 * bits as without give_up. */
START_TEST(test_give_up)
{
    int k = 4;
    size_t G = (size_t)1 << k, n = G * G * G / 2;
    bst_mat *a = test_matrix(k, SMOOTH, BST_DOUBLE, BST_DENSE, 31);
    bst_mat *b = test_matrix(k, CENTRE_NOISE, BST_DOUBLE, BST_DENSE, 32);
    double *t0 = malloc(n * sizeof *t0), *t1 = malloc(n * sizeof *t1), *t2 = malloc(n * sizeof *t2);
    double stop = 90.0, f, h;
    for (int th = 1; th <= 2; th++) {
        bsti_tt3_job jobs[2] = {{a, t0, 0.0, 0.0}, {b, t1, 0.0, 0.0}};
        ck_assert_int_eq(bsti_tt3_build(ctx, k, 3, stop, 1, th, BSTI_TT3_TABLE_BYTES, 0, 2, jobs), BST_OK);
        ck_assert_msg(jobs[1].fa_min < stop, "FA %g", jobs[1].fa_min);
        ck_assert(isnan(jobs[0].fa_min)); /* abandoned: never measured below fa_stop */
        bsti_tt3_job one[1] = {{a, t0, 0.0, 0.0}};
        ck_assert_int_eq(bsti_tt3_build(ctx, k, 3, stop, 1, th, BSTI_TT3_TABLE_BYTES, 0, 1, one), BST_OK);
        ck_assert_int_eq(build1(ctx, a, k, 3, stop, 1, 0, 0, t2, &f, &h), BST_OK);
        ck_assert(f > stop && one[0].fa_min == f && one[0].hemi_max == h);
        ck_assert(memcmp(t0, t2, n * sizeof *t0) == 0);
    }
    free(t0), free(t1), free(t2);
    bst_mat_free(a), bst_mat_free(b);
}
END_TEST

/* The rotation test against its definition: min over i of FA(M(., i), M(R ., R i)); with a bar,
 * the same answer to "below it?". */
START_TEST(test_rotation_fa)
{
    for (int k = 2; k <= 4; k++) {
        size_t G = (size_t)1 << k, N = G * G;
        bst_mat *m = test_matrix(k, k == 3 ? SMOOTH : NOISE, BST_FLOAT, BST_DENSE, 40 + (uint64_t)k);
        double *M = malloc(N * N * sizeof *M), want = 100.0;
        ck_assert_int_eq(bst_mat_to_dense_array(ctx, m, M), BST_OK);
        for (size_t i = 0; i < N; i++) {
            double d = 0.0, s = 0.0;
            for (size_t o = 0; o < N; o++) {
                double x = M[o + N * i], y = M[bsti_sc_turn(o, 1, G) + N * bsti_sc_turn(i, 1, G)];
                d += fabs(x - y), s += fabs(x) + fabs(y);
            }
            want = fmin(want, 100.0 * (1.0 - d / s));
        }
        tu_assert_close(bsti_tt3_rotation_fa(m, k, -INFINITY), want, 1e-13, 100.0);
        ck_assert(k == 3 ? want > 99.0 : want < 90.0);
        /* stopping early: the same decision against the bar */
        for (double bar = 80.0; bar <= 100.0; bar += 5.0)
            ck_assert_int_eq(bsti_tt3_rotation_fa(m, k, bar) < bar, want < bar);
        free(M);
        bst_mat_free(m);
    }
}
END_TEST

START_TEST(test_zero_and_errors)
{
    int k = 3;
    size_t G = (size_t)1 << k, N = G * G, n = N * G / 2;
    double *t3 = malloc(n * sizeof *t3), fa = -1.0, h = -1.0;
    bst_mat *z = NULL, *small = NULL;
    ck_assert_int_eq(bst_mat_new_zero(ctx, N, N, &z), BST_OK);
    memset(t3, 0xff, n * sizeof *t3);
    ck_assert_int_eq(bsti_tt3_from_sc(ctx, z, k, 3, -INFINITY, t3, &fa, &h), BST_OK);
    for (size_t x = 0; x < n; x++)
        ck_assert(t3[x] == 0.0);
    ck_assert(fa == 100.0 && h == 0.0);
    ck_assert_int_eq(bst_mat_new_zero(ctx, N / 4, N / 4, &small), BST_OK);
    ck_assert_int_eq(bsti_tt3_from_sc(ctx, small, k, 3, -INFINITY, t3, &fa, &h), BST_ESIZE);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "order 3"));
    ck_assert_int_eq(bsti_tt3_from_sc(ctx, z, 0, 3, -INFINITY, t3, &fa, &h), BST_ESIZE);
    ck_assert_int_eq(bsti_tt3_from_sc(ctx, NULL, k, 3, -INFINITY, t3, &fa, &h), BST_ESIZE);
    bst_mat_free(z), bst_mat_free(small);
    free(t3);
}
END_TEST

/* Every allocation failing in turn: BST_ENOMEM, nothing leaked; then the full result. */
START_TEST(test_alloc_failures)
{
    int k = 3;
    size_t G = (size_t)1 << k, n = G * G * G / 2;
    bst_mat *m = test_matrix(k, SMOOTH, BST_DOUBLE, BST_DENSE, 1);
    double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), f0, h0, f, h;
    ck_assert_int_eq(build1(ctx, m, k, 3, -INFINITY, 2, BSTI_TT3_TABLE_BYTES, 0, a, &f0, &h0),
                     BST_OK);
    long fail;
    for (fail = 1;; fail++) {
        tu_alloc al = {fail, 0, 0};
        bst_ctx *c2 = bst_ctx_new();
        ck_assert_int_eq(bst_ctx_set_allocator(c2, tu_alloc_malloc, tu_alloc_free, &al), BST_OK);
        int rc = build1(c2, m, k, 3, -INFINITY, 2, BSTI_TT3_TABLE_BYTES, 0, b, &f, &h);
        bst_ctx_free(c2);
        ck_assert_int_eq(al.live, 0);
        if (al.count < fail) {
            ck_assert_int_eq(rc, BST_OK);
            break;
        }
        ck_assert_int_eq(rc, BST_ENOMEM);
    }
    ck_assert_int_gt(fail, 8);
    ck_assert(memcmp(a, b, n * sizeof *a) == 0 && f == f0 && h == h0);
    free(a), free(b);
    bst_mat_free(m);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("rank3");
    TCase *tc = tcase_create("rank3");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, test_matches_definition);
    tcase_add_test(tc, test_threads_tables_same_bits);
    tcase_add_test(tc, test_early_stop);
    tcase_add_test(tc, test_early_stop_late_ring);
    tcase_add_test(tc, test_many_same_bits);
    tcase_add_test(tc, test_give_up);
    tcase_add_test(tc, test_rotation_fa);
    tcase_add_test(tc, test_zero_and_errors);
    tcase_add_test(tc, test_alloc_failures);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(suite());
}
