/* test_lowrank.c - factored matrices D + U K V^T (lowrank.h) against dense arithmetic: products,
 * sums, scalings and the Woodbury inverse on random operands over the prolongation P and over a
 * Klems-like overlap map; the inverse at the extremes (near-singular, a factor of rank N,
 * singular); and a pane + coarse diffuser + pane stack combined by the matrix formalism in
 * factored form against bst_stack_combine's dense result, component by component, its rank kept. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cblas.h>
#include <lapacke.h>

#include "ctx.h"
#include "lowrank.h"
#include "mat.h"
#include "testmat.h"
#include "testutil.h"

static bst_ctx *ctx;
static tu_rng rng;
static void setup(void)
{
    ctx = bst_ctx_new();
    tu_rng_seed(&rng, 31);
}
static void teardown(void) { bst_ctx_free(ctx); }

/* max |x - y| over max |y|: the relative difference of two N x N arrays. */
static double rel_diff(const double *x, const double *y, size_t n)
{
    double d = 0.0, m = 0.0;
    for (size_t i = 0; i < n; i++)
        d = fmax(d, fabs(x[i] - y[i])), m = fmax(m, fabs(y[i]));
    return m > 0 ? d / m : d;
}

static double *dense_of(const bsti_lr *f)
{
    double *d = malloc(f->N * f->N * sizeof *d);
    bsti_lr_to_dense(f, d);
    return d;
}

static void random_vec(double *v, size_t n, double lo, double hi)
{
    for (size_t i = 0; i < n; i++)
        v[i] = lo + (hi - lo) * tu_rng_uniform(&rng);
}

/* A random factored matrix: a diagonal when with_d, two terms of other scalings when two (so
 * p = q = 2), entries small enough that I - F stays well conditioned. */
static bsti_lr *random_lr(const bsti_lr_map *S, int with_d, int two)
{
    size_t N = S->N, r = S->r;
    double *d = malloc(N * sizeof *d), *a = malloc(N * sizeof *a), *b = malloc(N * sizeof *b);
    double *K = malloc(r * r * sizeof *K);
    random_vec(d, N, 0.0, 0.3), random_vec(a, N, 0.5, 1.0), random_vec(b, N, 0.5, 1.0);
    random_vec(K, r * r, 0.0, 0.25 / (double)N);
    bsti_lr *f;
    ck_assert_int_eq(bsti_lr_new(ctx, S, with_d ? d : NULL, a, K, b, &f), BST_OK);
    if (two) {
        bsti_lr *g, *s;
        random_vec(a, N, 0.5, 1.0), random_vec(b, N, 0.5, 1.0);
        random_vec(K, r * r, 0.0, 0.25 / (double)N);
        ck_assert_int_eq(bsti_lr_new(ctx, S, NULL, a, K, b, &g), BST_OK);
        ck_assert_int_eq(bsti_lr_add(ctx, 1.0, f, 1.0, g, &s), BST_OK);
        ck_assert_uint_eq(s->p, 2);
        ck_assert_uint_eq(s->q, 2);
        bsti_lr_free(ctx, f), bsti_lr_free(ctx, g);
        f = s;
    }
    free(d), free(a), free(b), free(K);
    return f;
}

/* A Klems-like overlap map: each of N rows holds 1 to 3 of r columns with weights summing to 1. */
static bsti_lr_map *overlap_map(size_t N, size_t r)
{
    bsti_lr_map *S;
    ck_assert_int_eq(bsti_lr_map_new(ctx, N, r, 3 * N, &S), BST_OK);
    size_t e = 0;
    for (size_t x = 0; x < N; x++) {
        S->start[x] = e;
        size_t m = 1 + (size_t)(3 * tu_rng_uniform(&rng)), c0 = (x * r) / N;
        double w[3], s = 0;
        for (size_t i = 0; i < m; i++)
            w[i] = 0.2 + tu_rng_uniform(&rng), s += w[i];
        for (size_t i = 0; i < m; i++, e++)
            S->col[e] = (c0 + i) % r, S->w[e] = w[i] / s;
    }
    S->start[N] = e;
    return S;
}

static bsti_lr_map *map_of(int which)
{
    bsti_lr_map *S;
    if (which == 0)
        ck_assert_int_eq(bsti_lr_map_prolong(ctx, 3, 1, &S), BST_OK); /* N 64, r 4 */
    else if (which == 1)
        ck_assert_int_eq(bsti_lr_map_prolong(ctx, 4, 2, &S), BST_OK); /* N 256, r 16 */
    else
        S = overlap_map(100, 9);
    return S;
}

/* (I - M)^-1 of a dense N x N M, in place into inv. */
static void dense_inverse(const double *m, size_t N, double *inv)
{
    double *a = malloc(N * N * sizeof *a);
    lapack_int *ipiv = malloc(N * sizeof *ipiv);
    for (size_t i = 0; i < N * N; i++)
        a[i] = -m[i], inv[i] = 0.0;
    for (size_t i = 0; i < N; i++)
        a[i * N + i] += 1.0, inv[i * N + i] = 1.0;
    ck_assert_int_eq(LAPACKE_dgesv(LAPACK_COL_MAJOR, (lapack_int)N, (lapack_int)N, a, (lapack_int)N,
                                   ipiv, inv, (lapack_int)N), 0);
    free(a), free(ipiv);
}

/* want = (I - M)^-1 B for dense N x N M and B (trans: (I - M)^-T B). */
static void dense_solve(const double *m, const double *b, size_t N, int trans, double *want)
{
    double *inv = malloc(N * N * sizeof *inv);
    dense_inverse(m, N, inv);
    cblas_dgemm(CblasColMajor, trans ? CblasTrans : CblasNoTrans, CblasNoTrans, (int)N, (int)N,
                (int)N, 1.0, inv, (int)N, b, (int)N, 0.0, want, (int)N);
    free(inv);
}

/* bsti_lr_col_fast's columns y = 0, step, 2 step, ... of f against bsti_lr_get, bit for bit. */
static void check_columns(const bsti_lr *f, size_t step)
{
    size_t N = f->N;
    double *line = malloc(N * sizeof *line);
    bsti_lr_rows *rows;
    ck_assert_int_eq(bsti_lr_rows_new(ctx, f, &rows), BST_OK);
    for (size_t y = 0; y < N; y += step) {
        bsti_lr_col_fast(f, rows, y, line);
        for (size_t x = 0; x < N; x++) {
            double v = bsti_lr_get(f, x, y);
            ck_assert_msg(memcmp(&line[x], &v, sizeof v) == 0, "column %zu row %zu", y, x);
        }
    }
    bsti_lr_rows_free(rows);
    free(line);
}

START_TEST(test_algebra)
{
    bsti_lr_map *S = map_of(_i / 4);
    int with_d = _i & 1, two = (_i >> 1) & 1;
    size_t N = S->N;
    bsti_lr *f = random_lr(S, with_d, two), *g = random_lr(S, !with_d, 1), *m;
    double *df = dense_of(f), *dg = dense_of(g), *want = malloc(N * N * sizeof *want), *got;
    /* product */
    ck_assert_int_eq(bsti_lr_mul(ctx, f, g, &m), BST_OK);
    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)N, (int)N, (int)N, 1.0, df, (int)N,
                dg, (int)N, 0.0, want, (int)N);
    got = dense_of(m);
    ck_assert_msg(rel_diff(got, want, N * N) < 1e-13, "product: %g", rel_diff(got, want, N * N));
    free(got), bsti_lr_free(ctx, m);
    /* a prolongation's diagonal grams (S->single) against the general gram and GEMM: the same
     * product and inverse, to the bit with one block (p = q = 1) */
    if (S->single) {
        bsti_lr *m1, *m0, *i1, *i0;
        ck_assert_int_eq(bsti_lr_mul(ctx, f, g, &m1), BST_OK);
        ck_assert_int_eq(bsti_lr_inverse(ctx, f, &i1, NULL), BST_OK);
        S->single = 0;
        ck_assert_int_eq(bsti_lr_mul(ctx, f, g, &m0), BST_OK);
        ck_assert_int_eq(bsti_lr_inverse(ctx, f, &i0, NULL), BST_OK);
        S->single = 1;
        size_t nk = m1->p * m1->r * m1->q * m1->r, ni = i1->p * i1->r * i1->q * i1->r;
        if (!two) { /* (f: one block, so K_F V_F^T U_G sums one product a value) */
            ck_assert_int_eq(memcmp(m1->k, m0->k, nk * sizeof *m1->k), 0);
            ck_assert_int_eq(memcmp(i1->k, i0->k, ni * sizeof *i1->k), 0);
            ck_assert_int_eq(memcmp(i1->d, i0->d, N * sizeof *i1->d), 0);
        }
        ck_assert_msg(rel_diff(m1->k, m0->k, nk) < 1e-14, "single-entry product: %g",
                      rel_diff(m1->k, m0->k, nk));
        ck_assert_msg(rel_diff(i1->k, i0->k, ni) < 1e-13, "single-entry inverse: %g",
                      rel_diff(i1->k, i0->k, ni));
        bsti_lr_free(ctx, m1), bsti_lr_free(ctx, m0), bsti_lr_free(ctx, i1), bsti_lr_free(ctx, i0);
    }
    check_columns(f, 7); /* the bits of the values one by one */
    /* sum */
    ck_assert_int_eq(bsti_lr_add(ctx, 0.5, f, -2.0, g, &m), BST_OK);
    for (size_t i = 0; i < N * N; i++)
        want[i] = 0.5 * df[i] - 2.0 * dg[i];
    got = dense_of(m);
    ck_assert_msg(rel_diff(got, want, N * N) < 1e-14, "sum: %g", rel_diff(got, want, N * N));
    free(got), bsti_lr_free(ctx, m);
    /* scaling */
    double *dr = malloc(N * sizeof *dr), *dc = malloc(N * sizeof *dc);
    random_vec(dr, N, -1.0, 1.0), random_vec(dc, N, 0.1, 2.0);
    ck_assert_int_eq(bsti_lr_scale(ctx, dr, f, dc, &m), BST_OK);
    for (size_t j = 0; j < N; j++)
        for (size_t i = 0; i < N; i++)
            want[j * N + i] = dr[i] * df[j * N + i] * dc[j];
    got = dense_of(m);
    ck_assert_msg(rel_diff(got, want, N * N) < 1e-14, "scaling: %g", rel_diff(got, want, N * N));
    free(got), bsti_lr_free(ctx, m);
    /* inverse */
    double rcond;
    ck_assert_int_eq(bsti_lr_inverse(ctx, f, &m, &rcond), BST_OK);
    ck_assert_msg(rcond > 0.1 && rcond <= 1.0, "rcond %g", rcond);
    dense_inverse(df, N, want);
    got = dense_of(m);
    ck_assert_msg(rel_diff(got, want, N * N) < 1e-13, "inverse: %g", rel_diff(got, want, N * N));
    free(got), bsti_lr_free(ctx, m);
    free(dr), free(dc), free(df), free(dg), free(want);
    bsti_lr_free(ctx, f), bsti_lr_free(ctx, g);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* Near-singular I - F (a near-mirror pair): rcond reported small, the inverse still the dense
 * one within rcond's loss; F = I exactly: singular, refused. */
START_TEST(test_extremes)
{
    bsti_lr_map *S = map_of(1);
    size_t N = S->N, r = S->r;
    /* F = P K P^T with K = c I / 16 (each coarse cell has 16 children): F P = c P, so I - F has
     * the eigenvalue 1 - c */
    double *K = calloc(r * r, sizeof *K), *want = malloc(N * N * sizeof *want);
    for (size_t i = 0; i < r; i++)
        K[i * r + i] = (1.0 - 1e-9) / 16.0;
    bsti_lr *f, *m;
    ck_assert_int_eq(bsti_lr_new(ctx, S, NULL, NULL, K, NULL, &f), BST_OK);
    double rcond;
    ck_assert_int_eq(bsti_lr_inverse(ctx, f, &m, &rcond), BST_OK);
    ck_assert_msg(rcond < 1e-8 && rcond > 1e-11, "rcond %g", rcond);
    double *df = dense_of(f), *got = dense_of(m);
    dense_inverse(df, N, want);
    ck_assert_msg(rel_diff(got, want, N * N) < 1e-6, "near-singular: %g", rel_diff(got, want, N * N));
    free(got), bsti_lr_free(ctx, m);
    /* the solves through the capacitance (B = F: F's scalings, no inverse), either side: the same
     * condition reported, the dense solve within its loss */
    for (int side = 0; side < 2; side++) {
        bsti_lr_fact *fa;
        double rc2, *w2 = malloc(N * N * sizeof *w2);
        ck_assert_int_eq(bsti_lr_factor(ctx, f, side, &fa, &rc2), BST_OK);
        ck_assert_msg(fabs(rc2 - rcond) <= 1e-3 * rcond, "side %d: rcond %g, %g", side, rc2, rcond);
        ck_assert_int_eq(bsti_lr_fact_solve(ctx, fa, side, f, &m), BST_OK);
        dense_solve(df, df, N, side, w2);
        got = dense_of(m);
        ck_assert_msg(rel_diff(got, w2, N * N) < 1e-6, "near-singular solve %d: %g", side,
                      rel_diff(got, w2, N * N));
        free(got), free(w2), bsti_lr_free(ctx, m), bsti_lr_fact_free(ctx, fa);
    }
    free(df), bsti_lr_free(ctx, f);
    /* exactly singular capacitance */
    for (size_t i = 0; i < r; i++)
        K[i * r + i] = 1.0 / 16.0;
    ck_assert_int_eq(bsti_lr_new(ctx, S, NULL, NULL, K, NULL, &f), BST_OK);
    ck_assert_int_eq(bsti_lr_inverse(ctx, f, &m, &rcond), BST_ESINGULAR);
    ck_assert_ptr_null(m);
    bsti_lr_fact *fa = (bsti_lr_fact *)1;
    ck_assert_int_eq(bsti_lr_factor(ctx, f, 1, &fa, &rcond), BST_ESINGULAR);
    ck_assert_ptr_null(fa);
    bsti_lr_free(ctx, f);
    /* I - D singular */
    double *one = malloc(N * sizeof *one);
    for (size_t x = 0; x < N; x++)
        one[x] = x == 5 ? 1.0 : 0.5;
    ck_assert_int_eq(bsti_lr_new(ctx, S, one, NULL, NULL, NULL, &f), BST_OK);
    ck_assert_int_eq(bsti_lr_inverse(ctx, f, &m, &rcond), BST_ESINGULAR);
    bsti_lr_free(ctx, f);
    free(one), free(K), free(want);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* A factor of rank N (the prolongation from an order to itself: S = I): the same answers. */
START_TEST(test_full_rank)
{
    bsti_lr_map *S;
    ck_assert_int_eq(bsti_lr_map_prolong(ctx, 3, 3, &S), BST_OK);
    size_t N = S->N;
    ck_assert_uint_eq(S->r, N);
    bsti_lr *f = random_lr(S, 1, 0), *m;
    double rcond, *df = dense_of(f), *want = malloc(N * N * sizeof *want), *got;
    ck_assert_int_eq(bsti_lr_inverse(ctx, f, &m, &rcond), BST_OK);
    dense_inverse(df, N, want);
    got = dense_of(m);
    ck_assert_msg(rel_diff(got, want, N * N) < 1e-13, "rank N: %g", rel_diff(got, want, N * N));
    free(got), free(df), free(want), bsti_lr_free(ctx, m), bsti_lr_free(ctx, f);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* (I - F)^-1 B and (I - F)^-T B through the capacitance's LU (lowrank_solve.c) against the dense
 * solve, for a B whose left scalings are F's (no inverse formed for (I - F)^-1 B: fewer flops than
 * the inverse and a product), one whose left scalings are F's right ones (the same for
 * (I - F)^-T B, the right solve's transpose), one of other scalings (through the inverse) and a
 * diagonal; each factorization also serves the other side. */
/* A sum of two terms whose scalings are one vector times constants (L F + G with Shirley-Chiu's
 * one projected solid angle, say) keeps one block: the constants go into K.  F + diag(c) F diag(e)
 * with constant c, e: F's p and q, the values of the dense sum (1e-13); with a c that varies, a
 * block more. */
START_TEST(test_add_multiple)
{
    bsti_lr_map *S = map_of(_i);
    size_t N = S->N;
    bsti_lr *f = random_lr(S, 0, _i == 1), *g, *m;
    double *c = malloc(N * sizeof *c), *e = malloc(N * sizeof *e);
    for (int varies = 0; varies < 2; varies++) {
        for (size_t x = 0; x < N; x++)
            c[x] = varies && x == N / 2 ? 0.3 : 0.7, e[x] = 2.5;
        ck_assert_int_eq(bsti_lr_scale(ctx, c, f, e, &g), BST_OK);
        ck_assert_int_eq(bsti_lr_add(ctx, 1.0, f, -0.5, g, &m), BST_OK);
        ck_assert_uint_eq(m->p, f->p * (1 + varies));
        ck_assert_uint_eq(m->q, f->q);
        double *df = dense_of(f), *dg = dense_of(g), *dm = dense_of(m);
        for (size_t x = 0; x < N * N; x++)
            df[x] -= 0.5 * dg[x];
        ck_assert_double_le(rel_diff(dm, df, N * N), 1e-13);
        free(df), free(dg), free(dm);
        bsti_lr_free(ctx, g), bsti_lr_free(ctx, m);
    }
    free(c), free(e);
    bsti_lr_free(ctx, f);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* A factorization that takes F (bsti_lr_factor_take: F itself, side 1 transposed in place where
 * K is square, a transposed copy where it is not) solves as the one of a copy does, to the bit,
 * with the same condition estimate: a square F (p = q = 1) and one of two left scalings (p = 2,
 * q = 1: F + diag(dr) F), both sides. */
START_TEST(test_factor_take)
{
    bsti_lr_map *S = map_of(_i);
    size_t N = S->N;
    double *dr = malloc(N * sizeof *dr);
    random_vec(dr, N, 0.2, 0.6);
    bsti_lr *sq = random_lr(S, 1, 0), *sc, *wide, *b = random_lr(S, 0, 1);
    ck_assert_int_eq(bsti_lr_scale(ctx, dr, sq, NULL, &sc), BST_OK);
    ck_assert_int_eq(bsti_lr_add(ctx, 1.0, sq, 1.0, sc, &wide), BST_OK);
    ck_assert_uint_eq(wide->p, 2);
    ck_assert_uint_eq(wide->q, 1);
    const bsti_lr *fs[2] = {sq, wide};
    for (int w = 0; w < 2; w++)
        for (int side = 0; side < 2; side++) {
            bsti_lr_fact *fa, *ft;
            bsti_lr *given, *x, *y;
            double rc1, rc2;
            ck_assert_int_eq(bsti_lr_factor(ctx, fs[w], side, &fa, &rc1), BST_OK);
            ck_assert_int_eq(bsti_lr_copy(ctx, fs[w], &given), BST_OK);
            ck_assert_int_eq(bsti_lr_factor_take(ctx, given, side, &ft, &rc2), BST_OK);
            ck_assert_double_eq(rc1, rc2);
            ck_assert_int_eq(bsti_lr_fact_solve(ctx, fa, side, b, &x), BST_OK);
            ck_assert_int_eq(bsti_lr_fact_solve(ctx, ft, side, b, &y), BST_OK);
            double *dx = dense_of(x), *dy = dense_of(y);
            ck_assert_int_eq(memcmp(dx, dy, N * N * sizeof *dx), 0);
            free(dx), free(dy);
            bsti_lr_free(ctx, x), bsti_lr_free(ctx, y);
            bsti_lr_fact_free(ctx, fa), bsti_lr_fact_free(ctx, ft);
        }
    bsti_lr_free(ctx, sq), bsti_lr_free(ctx, sc), bsti_lr_free(ctx, wide), bsti_lr_free(ctx, b);
    free(dr);
    bsti_lr_map_free(ctx, S);
}
END_TEST

START_TEST(test_solves)
{
    bsti_lr_map *S = map_of(_i / 4);
    int with_d = _i & 1, two = (_i >> 1) & 1;
    size_t N = S->N;
    bsti_lr *f = random_lr(S, with_d, two), *bs[4];
    double *dr = malloc(N * sizeof *dr), *dc = malloc(N * sizeof *dc);
    random_vec(dr, N, 0.5, 1.5), random_vec(dc, N, 0.5, 1.5);
    ck_assert_int_eq(bsti_lr_scale(ctx, NULL, f, dc, &bs[0]), BST_OK); /* F's a */
    bsti_lr *t1;
    ck_assert_int_eq(bsti_lr_scale(ctx, dr, f, NULL, &t1), BST_OK);
    ck_assert_int_eq(bsti_lr_transpose(ctx, t1, &bs[1]), BST_OK); /* F's b on the left */
    bsti_lr_free(ctx, t1);
    bs[2] = random_lr(S, !with_d, 1);
    ck_assert_int_eq(bsti_lr_new(ctx, S, dr, NULL, NULL, NULL, &bs[3]), BST_OK);
    double *df = dense_of(f), *want = malloc(N * N * sizeof *want);
    for (int side = 0; side < 2; side++) {
        bsti_lr_fact *fa;
        double rcond;
        ck_assert_int_eq(bsti_lr_factor(ctx, f, side, &fa, &rcond), BST_OK);
        ck_assert_msg(rcond > 0.1 && rcond <= 1.0, "rcond %g", rcond);
        for (int t = 0; t < 2; t++) {
            int tt = side ^ t; /* the factored side first, then the other */
            for (int k = 0; k < 4; k++) {
                double *db = dense_of(bs[k]), *got, f0 = ctx->flops;
                bsti_lr *x;
                ck_assert_int_eq(bsti_lr_fact_solve(ctx, fa, tt, bs[k], &x), BST_OK);
                double flops = ctx->flops - f0;
                dense_solve(df, db, N, tt, want);
                got = dense_of(x);
                ck_assert_msg(rel_diff(got, want, N * N) < 1e-12, "side %d, solve %d, B %d: %g",
                              side, tt, k, rel_diff(got, want, N * N));
                if (k == tt && !with_d) { /* matched: cheaper than the inverse and a product */
                    bsti_lr *inv, *y;
                    f0 = ctx->flops;
                    ck_assert_int_eq(bsti_lr_fact_inverse(ctx, fa, tt, &inv), BST_OK);
                    ck_assert_int_eq(bsti_lr_mul(ctx, inv, bs[k], &y), BST_OK);
                    ck_assert_msg(flops < ctx->flops - f0, "%g flops, through the inverse %g",
                                  flops, ctx->flops - f0);
                    bsti_lr_free(ctx, inv), bsti_lr_free(ctx, y);
                }
                free(got), free(db), bsti_lr_free(ctx, x);
            }
        }
        bsti_lr_fact_free(ctx, fa);
    }
    for (int k = 0; k < 4; k++)
        bsti_lr_free(ctx, bs[k]);
    free(df), free(want), free(dr), free(dc);
    bsti_lr_free(ctx, f);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* I - F factored for a right solve, then (I - F)^-T F^T (F^T's left scalings are the side's:
 * solved through the LU) and (I - F)^-1 G (the other side factored at its first use, G through
 * the inverse); the last result in *out. */
static int factor_solves(bst_ctx *c, const bsti_lr *f, const bsti_lr *ft, const bsti_lr *g,
                         bsti_lr **out)
{
    bsti_lr_fact *fa;
    bsti_lr *x = NULL;
    double rcond;
    *out = NULL;
    int rc = bsti_lr_factor(c, f, 1, &fa, &rcond);
    if (rc < 0)
        return rc;
    rc = bsti_lr_fact_solve(c, fa, 1, ft, &x);
    bsti_lr_free(c, x);
    if (rc >= 0)
        rc = bsti_lr_fact_solve(c, fa, 0, g, out);
    bsti_lr_fact_free(c, fa);
    return rc;
}

/* Every allocation of a product, a sum, a scaling, an inverse and a factorization's solves failed
 * in turn: BST_ENOMEM, no result and nothing leaked. */
START_TEST(test_nomem)
{
    bst_ctx *c = bst_ctx_new();
    tu_alloc al = {0};
    ck_assert_int_eq(bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &al), BST_OK);
    bst_ctx *save = ctx;
    ctx = c;
    bsti_lr_map *S = map_of(2);
    bsti_lr *f = random_lr(S, 1, 1), *g = random_lr(S, 0, 0);
    double *dr = malloc(S->N * sizeof *dr);
    random_vec(dr, S->N, 0.5, 1.0);
    bsti_lr *ft;
    ck_assert_int_eq(bsti_lr_transpose(c, f, &ft), BST_OK);
    for (int op = 0; op < 5; op++) {
        long base = al.live;
        for (long k = 1;; k++) {
            al.fail_at = al.count + k;
            bsti_lr *m = (bsti_lr *)1;
            int rc = op == 0   ? bsti_lr_mul(c, f, g, &m)
                     : op == 1 ? bsti_lr_add(c, 1.0, f, 2.0, g, &m)
                     : op == 2 ? bsti_lr_scale(c, dr, f, NULL, &m)
                     : op == 3 ? bsti_lr_inverse(c, f, &m, NULL)
                               : factor_solves(c, f, ft, g, &m);
            al.fail_at = 0;
            if (rc == BST_OK) {
                bsti_lr_free(c, m);
                break;
            }
            ck_assert_int_eq(rc, BST_ENOMEM);
            ck_assert_ptr_null(m);
            ck_assert_int_eq(al.live, base);
            ck_assert_int_lt(k, 120);
        }
    }
    free(dr);
    bsti_lr_free(c, f), bsti_lr_free(c, g), bsti_lr_free(c, ft);
    bsti_lr_map_free(c, S);
    ck_assert_int_eq(al.live, 0);
    ctx = save;
    bst_ctx_free(c);
}
END_TEST

/* rel_diff of two matrices' values. */
static double mat_diff(const bst_mat *x, const bst_mat *y)
{
    double *a = tm_dense(ctx, x), *b = tm_dense(ctx, y);
    double d = rel_diff(a, b, bst_mat_rows(y) * bst_mat_cols(y));
    free(a), free(b);
    return d;
}

/* The FACTORED structure in the dispatch (mat_mul.c, mat_add.c, solve.c): each product with an
 * operand of every other structure, both orders, each sum, and the solves, against the generic
 * dense path (both operands expanded). */
START_TEST(test_dispatch)
{
    int kind = _i; /* TM_ZERO .. TM_FLOAT */
    bsti_lr_map *S = map_of(2);
    size_t N = S->N;
    bst_mat *f, *g, *x, *want;
    ck_assert_int_eq(bsti_mat_from_lr(ctx, random_lr(S, 1, 1), &f), BST_OK);
    tu_rng gr;
    tu_rng_seed(&gr, 7 + (uint64_t)kind);
    g = tm_random(ctx, kind, N, N, 0.002, &gr);
    double tol = kind == TM_FLOAT ? 1e-5 : 1e-13;
    for (int order = 0; order < 2; order++) {
        const bst_mat *a = order ? g : f, *b = order ? f : g;
        ck_assert_int_eq(bst_mat_mul(ctx, a, b, 0.0, &x), BST_OK);
        ck_assert_int_eq(bsti_mat_mul_generic(ctx, a, b, &want), BST_OK);
        ck_assert_msg(mat_diff(x, want) < tol, "product %d, %s", order, tm_kind_name[kind]);
        ck_assert_int_ne(bst_mat_structure(x), kind == TM_ZERO ? BST_DENSE : BST_ZERO);
        bst_mat_free(x), bst_mat_free(want);
    }
    ck_assert_int_eq(bst_mat_add(ctx, 0.5, g, -1.5, f, &x), BST_OK);
    ck_assert_int_eq(bsti_mat_add_generic(ctx, 0.5, g, -1.5, f, &want), BST_OK);
    ck_assert_msg(mat_diff(x, want) < tol, "sum, %s", tm_kind_name[kind]);
    if (kind == TM_ZERO || kind == TM_DIAG) /* stays factored */
        ck_assert_int_eq(bst_mat_structure(x), BST_FACTORED);
    bst_mat_free(x), bst_mat_free(want);
    /* solves: X = (I - F)^-1 G and G (I - F)^-1, residuals against the generic product */
    for (int right = 0; right < 2; right++) {
        double rcond;
        ck_assert_int_ge(right ? bst_solve_right(ctx, f, g, 0, &x, &rcond)
                               : bst_solve_left(ctx, f, g, 0, &x, &rcond), 0);
        bst_mat *fx, *r;
        ck_assert_int_eq(right ? bsti_mat_mul_generic(ctx, x, f, &fx) : bsti_mat_mul_generic(ctx, f, x, &fx), BST_OK);
        ck_assert_int_eq(bsti_mat_add_generic(ctx, 1.0, x, -1.0, fx, &r), BST_OK); /* (I - F) X */
        double *dr = tm_dense(ctx, r), *dg = tm_dense(ctx, g);
        double gmax = tm_maxabs(dg, N * N);
        ck_assert_msg(tm_maxdiff(dr, dg, N * N) <= (kind == TM_FLOAT ? 1e-5 : 1e-12) * (gmax > 0 ? gmax : 1),
                      "solve %d, %s: residual %g", right, tm_kind_name[kind], tm_maxdiff(dr, dg, N * N));
        free(dr), free(dg);
        bst_mat_free(fx), bst_mat_free(r), bst_mat_free(x);
    }
    bst_mat_free(f), bst_mat_free(g);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* ---------------------------------------------------------------- a stack in factored form */

struct comps {
    bsti_lr *m[BST_NCOMP];
};

static bsti_lr *mul3(bsti_lr *a, bsti_lr *b, bsti_lr *c) /* a b c, consuming none */
{
    bsti_lr *ab, *abc;
    ck_assert_int_eq(bsti_lr_mul(ctx, a, b, &ab), BST_OK);
    ck_assert_int_eq(bsti_lr_mul(ctx, ab, c, &abc), BST_OK);
    bsti_lr_free(ctx, ab);
    return abc;
}

/* One step of the formalism (stack.c's formulas), L = Lambda as a scaling:
 *   Tf = Tf2 (I - L Rb1 L Rf2)^-1 L Tf1,  Rb = Rb2 + Tf2 (I - L Rb1 L Rf2)^-1 L Rb1 L Tb2,
 *   Tb = Tb1 (I - L Rf2 L Rb1)^-1 L Tb2,  Rf = Rf1 + Tb1 (I - L Rf2 L Rb1)^-1 L Rf2 L Tf1,
 * with A1 = (L Rb1 L) Rf2 and A2 = (L Rf2 L) Rb1. */
static struct comps step(const struct comps *u, const struct comps *v, const double *lam)
{
    struct comps s;
    bsti_lr *lrb1, *lrf2, *a1, *a2, *x, *y, *ltf1, *ltb2, *t, *t2;
    ck_assert_int_eq(bsti_lr_scale(ctx, lam, u->m[BST_RB], lam, &lrb1), BST_OK);
    ck_assert_int_eq(bsti_lr_scale(ctx, lam, v->m[BST_RF], lam, &lrf2), BST_OK);
    ck_assert_int_eq(bsti_lr_scale(ctx, lam, u->m[BST_TF], NULL, &ltf1), BST_OK);
    ck_assert_int_eq(bsti_lr_scale(ctx, lam, v->m[BST_TB], NULL, &ltb2), BST_OK);
    ck_assert_int_eq(bsti_lr_mul(ctx, lrb1, v->m[BST_RF], &a1), BST_OK);
    ck_assert_int_eq(bsti_lr_mul(ctx, lrf2, u->m[BST_RB], &a2), BST_OK);
    ck_assert_int_eq(bsti_lr_inverse(ctx, a1, &x, NULL), BST_OK);
    ck_assert_int_eq(bsti_lr_inverse(ctx, a2, &y, NULL), BST_OK);
    s.m[BST_TF] = mul3(v->m[BST_TF], x, ltf1);
    t = mul3(v->m[BST_TF], x, lrb1);
    ck_assert_int_eq(bsti_lr_mul(ctx, t, v->m[BST_TB], &t2), BST_OK);
    ck_assert_int_eq(bsti_lr_add(ctx, 1.0, v->m[BST_RB], 1.0, t2, &s.m[BST_RB]), BST_OK);
    bsti_lr_free(ctx, t), bsti_lr_free(ctx, t2);
    s.m[BST_TB] = mul3(u->m[BST_TB], y, ltb2);
    t = mul3(u->m[BST_TB], y, lrf2);
    ck_assert_int_eq(bsti_lr_mul(ctx, t, u->m[BST_TF], &t2), BST_OK);
    ck_assert_int_eq(bsti_lr_add(ctx, 1.0, u->m[BST_RF], 1.0, t2, &s.m[BST_RF]), BST_OK);
    bsti_lr_free(ctx, t), bsti_lr_free(ctx, t2);
    bsti_lr *dead[] = {lrb1, lrf2, a1, a2, x, y, ltf1, ltb2};
    for (size_t i = 0; i < sizeof dead / sizeof dead[0]; i++)
        bsti_lr_free(ctx, dead[i]);
    return s;
}

/* A pane's components as diagonal factored matrices. */
static struct comps pane_lr(const bst_layer *l, const bsti_lr_map *S)
{
    struct comps c;
    double *d = malloc(S->N * sizeof *d);
    for (int k = 0; k < BST_NCOMP; k++) {
        const bst_mat *m = bst_layer_get(l, 0, (bst_comp)k);
        ck_assert_int_eq(bst_mat_structure(m), BST_DIAG);
        for (size_t x = 0; x < S->N; x++)
            d[x] = bst_mat_get(m, x, x);
        ck_assert_int_eq(bsti_lr_new(ctx, S, d, NULL, NULL, NULL, &c.m[k]), BST_OK);
    }
    free(d);
    return c;
}

START_TEST(test_stack)
{
    /* the diffuser's order-3 matrices as the coarse information of an order-4 layer */
    bst_basis *b3, *b4;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &b3), BST_OK);
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &b4), BST_OK);
    bst_layer *coarse = tu_layer(ctx, "L_diffuser_t3k5.xml", b3);
    bst_layer *pane = tu_layer(ctx, "glass:clear-6mm", b4), *shade;
    bsti_lr_map *S;
    ck_assert_int_eq(bsti_lr_map_prolong(ctx, 4, 3, &S), BST_OK);
    size_t N = S->N, r = S->r;
    const char *vis = "Visible";
    ck_assert_int_eq(bst_layer_new(ctx, b4, 1, &vis, &shade), BST_OK);
    struct comps sh;
    double *K = malloc(r * r * sizeof *K);
    for (int k = 0; k < BST_NCOMP; k++) {
        ck_assert_int_eq(bst_mat_to_dense_array(ctx, bst_layer_get(coarse, 0, (bst_comp)k), K), BST_OK);
        ck_assert_int_eq(bsti_lr_new(ctx, S, NULL, NULL, K, NULL, &sh.m[k]), BST_OK);
        bst_mat *m; /* the same layer prolonged to order 4, dense: the library's own path */
        ck_assert_int_eq(bst_mat_new_dense(ctx, N, N, BST_DOUBLE, &m), BST_OK);
        bsti_lr_to_dense(sh.m[k], m->dense);
        ck_assert_int_eq(bst_layer_set(ctx, shade, 0, (bst_comp)k, m), BST_OK);
    }
    const bst_layer *layers[3] = {pane, shade, pane};
    bst_layer *sys;
    ck_assert_int_ge(bst_stack_combine(ctx, 3, layers, NULL, &sys), 0);
    struct comps p = pane_lr(pane, S);
    const double *lam = bst_basis_lambda(b4);
    struct comps s1 = step(&p, &sh, lam), s2 = step(&s1, &p, lam);
    double *want = malloc(N * N * sizeof *want);
    for (int k = 0; k < BST_NCOMP; k++) {
        ck_assert_int_eq(bst_mat_to_dense_array(ctx, bst_layer_get(sys, 0, (bst_comp)k), want), BST_OK);
        double *got = dense_of(s2.m[k]);
        ck_assert_msg(rel_diff(got, want, N * N) < 1e-12, "%s: %g", bst_comp_name((bst_comp)k),
                      rel_diff(got, want, N * N));
        /* the rank stays the coarse order's: one scaling a side */
        ck_assert_msg(s2.m[k]->p <= 1 && s2.m[k]->q <= 1, "%s: p %zu q %zu",
                      bst_comp_name((bst_comp)k), s2.m[k]->p, s2.m[k]->q);
        free(got);
    }
    for (int k = 0; k < BST_NCOMP; k++) {
        bsti_lr_free(ctx, sh.m[k]), bsti_lr_free(ctx, p.m[k]);
        bsti_lr_free(ctx, s1.m[k]), bsti_lr_free(ctx, s2.m[k]);
    }
    free(K), free(want);
    bsti_lr_map_free(ctx, S);
    bst_layer_free(sys), bst_layer_free(shade), bst_layer_free(pane), bst_layer_free(coarse);
    bst_basis_free(b3), bst_basis_free(b4);
}
END_TEST

/* The column readers for many columns: bsti_lr_col_fast gives bsti_lr_get's bits over a
 * prolongation, a Klems-like overlap map and one with empty rows; bsti_cols_visit hands every
 * unit over once, in order within each chunk, with the second reader's columns beside the first's
 * (through the factors, or by GEMM over a wide map), the same per chunk on one thread and on two,
 * and stops when asked. */
struct vsum {
    size_t N, per, visits;
    double *sums;        /* chunks: the sum over its units of (u + 1) times their first value */
    size_t *last;        /* chunks: the last unit + 1 seen (order check) */
    const bsti_lr *f, *g;
    const size_t *perm;
    int bad, stop_at, gemm; /* gemm: over a wide map, the values to rounding */
};

static int vsum_visit(void *opaque, size_t q, size_t u, const double *buf, const double *buf2)
{
    struct vsum *v = opaque;
    __atomic_add_fetch(&v->visits, 1, __ATOMIC_RELAXED);
    if (v->last[q] > u)
        v->bad = 1;
    v->last[q] = u + 1;
    for (size_t s = 0; s < v->per; s++) { /* unit u: columns perm[u per + s] of f, then of g */
        size_t j = v->perm[u * v->per + s], y = j;
        for (size_t x = 0; x < v->N; x += 5) {
            double a = bsti_lr_get(v->f, x, j), b = bsti_lr_get(v->g, x, y);
            double da = buf[s * v->N + x], db = buf2[s * v->N + x];
            if (v->gemm ? !(fabs(a - da) <= 1e-12 * fabs(a) && fabs(b - db) <= 1e-12 * fabs(b))
                        : memcmp(&a, &da, sizeof a) != 0 || memcmp(&b, &db, sizeof b) != 0)
                v->bad = 1;
        }
        v->sums[q] += (double)(u + 1) * buf[s * v->N];
    }
    return v->stop_at >= 0 && u == (size_t)v->stop_at;
}

START_TEST(test_lines_fast)
{
    bsti_lr_map *S = _i < 2 ? map_of(_i == 0 ? 1 : 2) : overlap_map(150, 11);
    if (_i == 2) /* rows 0, 7, 14, ... empty */
        for (size_t x = 0, e = 0; x < S->N; x++) {
            size_t n = x % 7 == 0 ? 0 : S->start[x + 1] - S->start[x], e0 = S->start[x];
            S->start[x] = e;
            for (size_t t = 0; t < n; t++, e++)
                S->col[e] = S->col[e0 + t], S->w[e] = S->w[e0 + t];
            if (x + 1 == S->N)
                S->start[S->N] = e;
        }
    if (_i == 1) /* tagged as Klems overlaps are (case 2: untagged, a wide map, read by GEMM) */
        snprintf(S->tag, sizeof S->tag, "test overlaps");
    size_t N = S->N;
    bsti_lr *f = random_lr(S, 1, 1), *g = random_lr(S, 0, 0), *f2, *g2;
    check_columns(f, 1);
    /* the visits: units of 3 columns, f's and g's at a permutation (cols2 NULL: cols) */
    bst_mat *mf, *mg;
    ck_assert_int_eq(bsti_lr_copy(ctx, f, &f2), BST_OK);
    ck_assert_int_eq(bsti_lr_copy(ctx, g, &g2), BST_OK);
    ck_assert_int_eq(bsti_mat_from_lr(ctx, f2, &mf), BST_OK);
    ck_assert_int_eq(bsti_mat_from_lr(ctx, g2, &mg), BST_OK);
    size_t per = 3, n = N / per, chunks = 7, *perm = malloc(N * sizeof *perm);
    for (size_t j = 0; j < N; j++)
        perm[j] = (j * 37 + 5) % N; /* (37 and N coprime) */
    double sums[2][7];
    for (int threads = 1; threads <= 2; threads++) {
        bsti_cols *cf, *cg;
        size_t last[7] = {0};
        struct vsum v = {N, per, 0, sums[threads - 1], last, f, g, perm, 0, -1, _i == 2};
        memset(v.sums, 0, sizeof sums[0]);
        ck_assert_int_eq(bst_ctx_set_threads(ctx, threads), BST_OK);
        ck_assert_int_eq(bsti_cols_new(ctx, mf, N, &cf), BST_OK);
        ck_assert_int_eq(bsti_cols_new(ctx, mg, N, &cg), BST_OK);
        ck_assert_int_eq(bsti_cols_visit(cf, perm, cg, NULL, n, per, chunks, vsum_visit, &v), BST_OK);
        ck_assert_uint_eq(v.visits, n);
        ck_assert_int_eq(v.bad, 0);
        for (size_t q = 0; q < chunks; q++)
            ck_assert_uint_eq(last[q], n * (q + 1) / chunks);
        /* a stop at unit 2 (chunk 0): no later unit of its chunk; on one thread, nothing more
         * (on two, the other thread's visits before it saw the stop are legitimate) */
        memset(last, 0, sizeof last);
        double scratch[7] = {0};
        v.visits = 0, v.stop_at = 2, v.sums = scratch;
        ck_assert_int_eq(bsti_cols_visit(cf, perm, cg, NULL, n, per, chunks, vsum_visit, &v), BST_OK);
        ck_assert_uint_eq(last[0], 3); /* chunk 0: no unit after the stop */
        if (threads == 1)
            ck_assert_uint_eq(v.visits, 3);
        bsti_cols_free(cf), bsti_cols_free(cg);
    }
    ck_assert_int_eq(memcmp(sums[0], sums[1], sizeof sums[0]), 0);
    free(perm);
    bst_mat_free(mf), bst_mat_free(mg);
    bsti_lr_free(ctx, f), bsti_lr_free(ctx, g);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* Products with a sparse K (a clear pane's tree at a coarse order: a diagonal and a value more),
 * which are formed through K's values instead of GEMM, on either side of a dense one and of each
 * other, against the dense products. */
START_TEST(test_sparse_k)
{
    bsti_lr_map *S; /* a prolongation, a Klems-like overlap map; r past 64 (LR_SPARSE_SHARE) */
    if (_i == 0)
        ck_assert_int_eq(bsti_lr_map_prolong(ctx, 5, 4, &S), BST_OK); /* N 1024, r 256 */
    else
        S = overlap_map(300, 100);
    size_t N = S->N, r = S->r;
    double *K = calloc(r * r, sizeof *K), *a = malloc(N * sizeof *a);
    for (size_t c = 0; c < r; c++)
        K[c * r + (r - 1 - c)] = 0.05 + 0.01 * (double)c / (double)r; /* a mirror */
    K[1] = 0.02;
    random_vec(a, N, 0.5, 1.0);
    bsti_lr *pane, *dense = random_lr(S, 1, _i == 0), *m;
    ck_assert_int_eq(bsti_lr_new(ctx, S, NULL, a, K, NULL, &pane), BST_OK);
    const bsti_lr *ops[3][2] = {{pane, dense}, {dense, pane}, {pane, pane}};
    for (int t = 0; t < 3; t++) {
        double *da = dense_of(ops[t][0]), *db = dense_of(ops[t][1]), *want = malloc(N * N * sizeof *want);
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)N, (int)N, (int)N, 1.0, da,
                    (int)N, db, (int)N, 0.0, want, (int)N);
        double flops = ctx->flops;
        ck_assert_int_eq(bsti_lr_mul(ctx, ops[t][0], ops[t][1], &m), BST_OK);
        if (_i == 0 || t == 2) /* (over the overlap map a dense K times the band of W^T W stays
                                  dense: a GEMM there) */
            ck_assert_msg(ctx->flops == flops, "product %d: GEMM of %g flops", t, ctx->flops - flops);
        double *got = dense_of(m);
        ck_assert_msg(rel_diff(got, want, N * N) < 1e-13, "product %d: %g", t, rel_diff(got, want, N * N));
        free(da), free(db), free(want), free(got), bsti_lr_free(ctx, m);
    }
    bsti_lr_free(ctx, pane), bsti_lr_free(ctx, dense);
    free(K), free(a);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* A sparse operand beside a factored one joins it (sparse_lr, mat_lowrank.c) exactly when it is
 * P K P^T over the factored one's prolongation: every pair of coarse cells holds one value in all
 * its fine pairs, or none.  _i: 0 such a matrix (the product stays FACTORED), 1 one fine pair of a
 * block missing, 2 one fine pair of a block with another value (both made dense).  The product
 * equals the generic one every time. */
START_TEST(test_sparse_join)
{
    bsti_lr_map *S;
    ck_assert_int_eq(bsti_lr_map_prolong(ctx, 4, 2, &S), BST_OK); /* N 256, r 16, 16 fine cells */
    size_t N = S->N, r = S->r, nnz = 0;
    size_t *row = malloc(N * N * sizeof *row), *col = malloc(N * N * sizeof *col);
    double *val = malloc(N * N * sizeof *val);
    for (size_t j = 0; j < N; j++)
        for (size_t i = 0; i < N; i++) {
            size_t ci = S->col[i], cj = S->col[j]; /* their coarse cells */
            if (ci != r - 1 - cj && !(ci == 1 && cj == 0))
                continue; /* a mirror and one value beside it */
            if (_i == 1 && i == S->N - 1 && ci == r - 1 - cj)
                continue;
            val[nnz] = 0.05 + 0.01 * (double)cj / (double)r + (_i == 2 && nnz == 7 ? 1e-9 : 0.0);
            row[nnz] = i, col[nnz++] = j;
        }
    bst_mat *sp, *f, *x, *want;
    ck_assert_int_eq(bst_mat_new_sparse(ctx, N, N, nnz, row, col, val, &sp), BST_OK);
    ck_assert_int_eq(bst_mat_structure(sp), BST_SPARSE);
    ck_assert_int_eq(bsti_mat_from_lr(ctx, random_lr(S, 1, 0), &f), BST_OK);
    for (int order = 0; order < 2; order++) {
        const bst_mat *a = order ? sp : f, *b = order ? f : sp;
        ck_assert_int_eq(bst_mat_mul(ctx, a, b, 0.0, &x), BST_OK);
        ck_assert_int_eq(bsti_mat_mul_generic(ctx, a, b, &want), BST_OK);
        ck_assert_msg(mat_diff(x, want) < 1e-13, "case %d, product %d: %g", _i, order, mat_diff(x, want));
        ck_assert_msg((bst_mat_structure(x) == BST_FACTORED) == (_i == 0), "case %d, product %d: "
                      "structure %d", _i, order, (int)bst_mat_structure(x));
        bst_mat_free(x), bst_mat_free(want);
    }
    bst_mat_free(sp), bst_mat_free(f);
    free(row), free(col), free(val);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* Whether two factored matrices hold the same values, bit for bit: diagonal, scalings and K. */
static int same_lr(const bsti_lr *x, const bsti_lr *y)
{
    size_t N = x->N, nk = x->p * x->r * x->q * x->r;
    if (x->p != y->p || x->q != y->q || !x->d != !y->d || !x->k || !y->k)
        return 0;
    return (!x->d || memcmp(x->d, y->d, N * sizeof *x->d) == 0) &&
           memcmp(x->a, y->a, x->p * N * sizeof *x->a) == 0 &&
           memcmp(x->b, y->b, x->q * N * sizeof *x->b) == 0 && memcmp(x->k, y->k, nk * sizeof *x->k) == 0;
}

/* A sparse P K P^T whose K is sparse (a mirror and one value beside it, over P from order 4 to 5:
 * r = 256, 257 values of 65536) is taken as an operand with K held by column alone
 * (bsti_mat_lr_operand: no r x r array), and each product, sum and solve with it gives the bits
 * the operand with its K as an array (bsti_mat_lr_of) gives, and the dense values.  _i: the factored
 * matrix beside it has one term and a diagonal (the product through K's values), two terms (the
 * operand made an array first), or one term whose left scaling is the operand's (the solve without
 * an inverse). */
START_TEST(test_sparse_operand)
{
    bsti_lr_map *S;
    ck_assert_int_eq(bsti_lr_map_prolong(ctx, 5, 4, &S), BST_OK);
    size_t N = S->N, r = S->r, nnz = 0, fine = N / r;
    size_t *row = malloc((r + 1) * fine * fine * sizeof *row), *col = malloc((r + 1) * fine * fine * sizeof *col);
    double *val = malloc((r + 1) * fine * fine * sizeof *val);
    for (size_t j = 0; j < N; j++)
        for (size_t i = 0; i < N; i++) {
            size_t ci = S->col[i], cj = S->col[j];
            if (ci == r - 1 - cj || (ci == 1 && cj == 0))
                val[nnz] = 0.05 + 0.01 * (double)cj / (double)r, row[nnz] = i, col[nnz++] = j;
        }
    bst_mat *sp;
    ck_assert_int_eq(bst_mat_new_sparse(ctx, N, N, nnz, row, col, val, &sp), BST_OK);
    bsti_lr *op, *arr, *f;
    ck_assert_int_eq(bsti_mat_lr_operand(ctx, sp, S, &op), BST_OK);
    ck_assert_int_eq(bsti_mat_lr_of(ctx, sp, S, &arr), BST_OK);
    ck_assert_ptr_null(op->k);
    ck_assert_ptr_nonnull(arr->k);
    ck_assert_uint_eq(op->ks->nnz, r + 1);
    if (_i == 2) { /* left scaling ones, as the operand's */
        double *K = malloc(r * r * sizeof *K), *d = malloc(N * sizeof *d), *b = malloc(N * sizeof *b);
        random_vec(K, r * r, 0.0, 0.25 / (double)N), random_vec(d, N, 0.0, 0.3), random_vec(b, N, 0.5, 1.0);
        ck_assert_int_eq(bsti_lr_new(ctx, S, d, NULL, K, b, &f), BST_OK);
        free(K), free(d), free(b);
    } else {
        f = random_lr(S, 1, _i == 1);
    }
    double *dsp = dense_of(arr), *df = dense_of(f), *want = malloc(N * N * sizeof *want);
    for (int t = 0; t < 2; t++) { /* F op, op F */
        bsti_lr *x, *y;
        ck_assert_int_eq(bsti_lr_mul(ctx, t ? op : f, t ? f : op, &x), BST_OK);
        ck_assert_int_eq(bsti_lr_mul(ctx, t ? arr : f, t ? f : arr, &y), BST_OK);
        ck_assert_msg(same_lr(x, y), "case %d, product %d: not the same bits", _i, t);
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)N, (int)N, (int)N, 1.0,
                    t ? dsp : df, (int)N, t ? df : dsp, (int)N, 0.0, want, (int)N);
        double *got = dense_of(x);
        ck_assert_msg(rel_diff(got, want, N * N) < 1e-13, "case %d, product %d", _i, t);
        free(got), bsti_lr_free(ctx, x), bsti_lr_free(ctx, y);
        ck_assert_int_eq(bsti_lr_add(ctx, 0.5, t ? op : f, -2.0, t ? f : op, &x), BST_OK);
        ck_assert_int_eq(bsti_lr_add(ctx, 0.5, t ? arr : f, -2.0, t ? f : arr, &y), BST_OK);
        ck_assert_msg(same_lr(x, y), "case %d, sum %d: not the same bits", _i, t);
        for (size_t e = 0; e < N * N; e++)
            want[e] = 0.5 * (t ? dsp : df)[e] - 2.0 * (t ? df : dsp)[e];
        got = dense_of(x);
        ck_assert_msg(rel_diff(got, want, N * N) < 1e-13, "case %d, sum %d", _i, t);
        free(got), bsti_lr_free(ctx, x), bsti_lr_free(ctx, y);
        bsti_lr_fact *fa;
        ck_assert_int_eq(bsti_lr_factor(ctx, f, t, &fa, NULL), BST_OK);
        ck_assert_int_eq(bsti_lr_fact_solve(ctx, fa, t, op, &x), BST_OK);
        ck_assert_int_eq(bsti_lr_fact_solve(ctx, fa, t, arr, &y), BST_OK);
        ck_assert_msg(same_lr(x, y), "case %d, solve %d: not the same bits", _i, t);
        dense_solve(df, dsp, N, t, want);
        got = dense_of(x);
        ck_assert_msg(rel_diff(got, want, N * N) < 1e-12, "case %d, solve %d: %g", _i, t,
                      rel_diff(got, want, N * N));
        free(got), bsti_lr_free(ctx, x), bsti_lr_free(ctx, y);
        bsti_lr_fact_free(ctx, fa);
    }
    free(dsp), free(df), free(want), free(row), free(col), free(val);
    bsti_lr_free(ctx, op), bsti_lr_free(ctx, arr), bsti_lr_free(ctx, f);
    bst_mat_free(sp);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* Products through a sparse K large enough to be shared out among threads by columns (r = 1024:
 * a million values a result) give the same bits on one thread and on two, sparse on the left and
 * on the right. */
START_TEST(test_sparse_threads)
{
    bsti_lr_map *S;
    ck_assert_int_eq(bsti_lr_map_prolong(ctx, 6, 5, &S), BST_OK); /* N 4096, r 1024 */
    size_t r = S->r;
    double *K = calloc(r * r, sizeof *K);
    for (size_t c = 0; c < r; c++)
        K[c * r + (r - 1 - c)] = 0.05 + 0.01 * (double)c / (double)r;
    bsti_lr *pane, *f = random_lr(S, 1, 0), *x[2][2];
    ck_assert_int_eq(bsti_lr_new(ctx, S, NULL, NULL, K, NULL, &pane), BST_OK);
    for (int t = 0; t < 2; t++) {
        ck_assert_int_eq(bst_ctx_set_threads(ctx, t + 1), BST_OK);
        ck_assert_int_eq(bsti_lr_mul(ctx, pane, f, &x[t][0]), BST_OK);
        ck_assert_int_eq(bsti_lr_mul(ctx, f, pane, &x[t][1]), BST_OK);
    }
    for (int o = 0; o < 2; o++) {
        ck_assert_msg(same_lr(x[0][o], x[1][o]), "product %d: other bits on two threads", o);
        bsti_lr_free(ctx, x[0][o]), bsti_lr_free(ctx, x[1][o]);
    }
    bsti_lr_free(ctx, pane), bsti_lr_free(ctx, f);
    free(K);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* Scaling a factored matrix in its own storage (bsti_lr_scale_take, what the stack does at a
 * matrix's last read; bsti_lr_scale is a copy and this) gives diag(dr) F diag(dc) of F's values,
 * with either side's scaling absent. */
START_TEST(test_scale_take)
{
    bsti_lr_map *S = map_of(_i % 3);
    size_t N = S->N;
    double *dr = malloc(N * sizeof *dr), *dc = malloc(N * sizeof *dc);
    random_vec(dr, N, 0.1, 2.0), random_vec(dc, N, 0.1, 2.0);
    const double *r = _i < 3 ? dr : NULL, *c = _i < 6 && _i >= 3 ? NULL : dc;
    bsti_lr *f = random_lr(S, 1, 1);
    double *want = dense_of(f);
    for (size_t y = 0; y < N; y++)
        for (size_t x = 0; x < N; x++)
            want[y * N + x] *= (r ? r[x] : 1.0) * (c ? c[y] : 1.0);
    bsti_lr_scale_take(r, f, c);
    double *got = dense_of(f);
    ck_assert_msg(rel_diff(got, want, N * N) < 1e-14, "case %d: %g", _i, rel_diff(got, want, N * N));
    free(want), free(got), free(dr), free(dc);
    bsti_lr_free(ctx, f);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* Transposing a factored matrix in its own storage (bsti_lr_transpose_take, the right solves' B and
 * X) gives the bits of a transposed copy, across the swap's tiles of 32 (_i 6, 7: K of 64 and
 * 128 square); a K that is not square (one left, two right scalings) is refused and left as it
 * was. */
START_TEST(test_transpose_take)
{
    bsti_lr_map *S;
    if (_i < 6)
        S = map_of(_i % 3);
    else
        ck_assert_int_eq(bsti_lr_map_prolong(ctx, 5, 3, &S), BST_OK); /* N 1024, r 64 */
    size_t N = S->N;
    bsti_lr *f = random_lr(S, _i % 2, _i >= 3 && _i != 6), *copy;
    ck_assert_int_eq(bsti_lr_transpose(ctx, f, &copy), BST_OK);
    ck_assert_int_eq(bsti_lr_transpose_take(f), 0);
    double *want = dense_of(copy), *got = dense_of(f);
    ck_assert_msg(memcmp(want, got, N * N * sizeof *got) == 0, "case %d: other bits", _i);
    free(want), free(got);
    bsti_lr_free(ctx, f), bsti_lr_free(ctx, copy);
    bsti_lr *g; /* p 1, q 2 */
    ck_assert_int_eq(bsti_lr_alloc(ctx, S, 1, 2, 0, BSTI_LR_K_ZERO, &g), BST_OK);
    random_vec(g->a, N, 0.5, 1.0), random_vec(g->b, 2 * N, 0.5, 1.0);
    random_vec(g->k, 2 * S->r * S->r, 0.0, 0.1);
    want = dense_of(g);
    ck_assert_int_eq(bsti_lr_transpose_take(g), -1);
    got = dense_of(g);
    ck_assert_msg(memcmp(want, got, N * N * sizeof *got) == 0, "case %d: a refused one changed", _i);
    free(want), free(got);
    bsti_lr_free(ctx, g);
    bsti_lr_map_free(ctx, S);
}
END_TEST

/* A factored matrix over a prolongation whose values are those of its coarse order
 * (bsti_mat_lr_coarse: no diagonal part, scalings constant over each coarse cell, one or two
 * terms) gives that order, and its coarse values the bits bsti_lr_get gives at every fine cell
 * (bsti_mat_lr_coarse_values); a diagonal part, one scaling changed in one fine cell or an overlap
 * map give 0; the coarse budgets are the least of each cell's fine ones.  _i: map, terms. */
START_TEST(test_coarse)
{
    bsti_lr_map *S = map_of(_i % 3);
    size_t N = S->N, r = S->r;
    int two = _i >= 3, want = _i % 3 == 2 ? 0 : S->d;
    double *a = malloc(N * sizeof *a), *b = malloc(N * sizeof *b), *K = malloc(r * r * sizeof *K);
    double *va = malloc(r * sizeof *va), *vb = malloc(r * sizeof *vb), *d = calloc(N, sizeof *d);
    bsti_lr *f = NULL;
    for (int t = 0; t <= two; t++) {
        random_vec(va, r, 0.5, 1.0), random_vec(vb, r, 0.5, 1.0), random_vec(K, r * r, -0.1, 1.0);
        for (size_t x = 0; x < N; x++) /* constant over each coarse cell (its map's first column) */
            a[x] = va[S->col[S->start[x]]], b[x] = vb[S->col[S->start[x]]];
        bsti_lr *g, *sum;
        ck_assert_int_eq(bsti_lr_new(ctx, S, t == 0 ? d : NULL, a, K, b, &g), BST_OK);
        if (!f) {
            f = g;
            continue;
        }
        ck_assert_int_eq(bsti_lr_add(ctx, 1.0, f, 1.0, g, &sum), BST_OK);
        bsti_lr_free(ctx, f), bsti_lr_free(ctx, g);
        f = sum;
    }
    ck_assert_uint_eq(f->p, two ? 2 : 1);
    bst_mat *m;
    ck_assert_int_eq(bsti_mat_from_lr(ctx, f, &m), BST_OK);
    ck_assert_int_eq(bsti_mat_lr_coarse(m), want);
    if (want) {
        size_t nc = (size_t)1 << (2 * S->d);
        ck_assert_uint_eq(nc, r);
        double *kc = malloc(nc * nc * sizeof *kc);
        bsti_mat_lr_coarse_values(m, kc);
        for (size_t y = 0; y < N; y++)
            for (size_t x = 0; x < N; x++) {
                double got = kc[S->col[y] * nc + S->col[x]], at = bsti_lr_get(f, x, y);
                ck_assert_msg(memcmp(&got, &at, sizeof got) == 0, "(%zu, %zu): %.17g, %.17g", x, y,
                              got, at);
            }
        double *fine = malloc(N * sizeof *fine), *least = malloc(nc * sizeof *least);
        random_vec(fine, N, 0.0, 1.0);
        bsti_mat_lr_coarse_least(fine, S->k, S->d, least);
        for (size_t J = 0; J < nc; J++) {
            double w = INFINITY;
            for (size_t x = 0; x < N; x++)
                if (S->col[x] == J)
                    w = fmin(w, fine[x]);
            ck_assert_double_eq(least[J], w);
        }
        free(kc), free(fine), free(least);
        /* not of the coarse order: one scaling changed in one fine cell, or a diagonal part */
        double keep = f->b[N - 1];
        f->b[N - 1] *= 1.5;
        ck_assert_int_eq(bsti_mat_lr_coarse(m), 0);
        f->b[N - 1] = keep;
        if (f->d) {
            f->d[N / 2] = 1e-300;
            ck_assert_int_eq(bsti_mat_lr_coarse(m), 0);
            f->d[N / 2] = 0.0;
        }
        ck_assert_int_eq(bsti_mat_lr_coarse(m), want);
    }
    bst_mat_free(m);
    free(a), free(b), free(K), free(va), free(vb), free(d);
    bsti_lr_map_free(ctx, S);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("lowrank");
    TCase *tc = tcase_create("factored");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_loop_test(tc, test_algebra, 0, 12);
    tcase_add_loop_test(tc, test_solves, 0, 12);
    tcase_add_loop_test(tc, test_factor_take, 0, 3);
    tcase_add_loop_test(tc, test_add_multiple, 0, 3);
    tcase_add_test(tc, test_extremes);
    tcase_add_test(tc, test_full_rank);
    tcase_add_test(tc, test_nomem);
    tcase_add_loop_test(tc, test_dispatch, TM_ZERO, TM_NKINDS);
    tcase_add_test(tc, test_stack);
    tcase_add_loop_test(tc, test_lines_fast, 0, 3);
    tcase_add_loop_test(tc, test_sparse_k, 0, 2);
    tcase_add_loop_test(tc, test_sparse_join, 0, 3);
    tcase_add_loop_test(tc, test_sparse_operand, 0, 3);
    tcase_add_test(tc, test_sparse_threads);
    tcase_add_loop_test(tc, test_scale_take, 0, 9);
    tcase_add_loop_test(tc, test_transpose_take, 0, 8);
    tcase_add_loop_test(tc, test_coarse, 0, 6);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return tu_run(suite()); }
