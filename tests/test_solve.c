/* test_solve.c - X = (I - A)^-1 B and Y = B (I - A)^-1 for every structure of A and B: residuals
 * against plain dense arithmetic, agreement with the dense generic solve, the condition estimate
 * as A approaches a singular I - A, singular cases, errors and injected allocation failures; the
 * solves that take their operands (bsti_solve_take*, the stack's): the same bits as the borrowing
 * ones, a dense right-hand side solved in its own storage, nothing leaked on any path; the blocked
 * inverse of large dense factors against getrs; a pattern whose LU fills remembered. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "mat.h"
#include "testmat.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static const size_t sizes[] = {1, 2, 7, 64, 300};
#define NSIZES (sizeof sizes / sizeof sizes[0])

/* A random A of the kind with |A|_1 <= 0.9 (physical layers: rho1 rho2 < 1). */
static bst_mat *contraction(int kind, size_t n, tu_rng *r)
{
    bst_mat *a = tm_random(ctx, kind, n, n, 1.0, r), *s;
    double *d = tm_dense(ctx, a), norm = 0.0;
    for (size_t j = 0; j < n; j++) {
        double c = 0.0;
        for (size_t i = 0; i < n; i++)
            c += fabs(d[j * n + i]);
        norm = fmax(norm, c);
    }
    free(d);
    if (norm == 0.0)
        return a;
    double *w = malloc(n * sizeof *w);
    for (size_t i = 0; i < n; i++)
        w[i] = 0.9 / norm;
    ck_assert_int_eq(bst_mat_scale(ctx, w, a, NULL, &s), BST_OK);
    free(w);
    bst_mat_free(a);
    return s;
}

/* Case i of a loop test: the kinds of A and B, the size (one of sz[0..nsz-1]), the side. */
static void pick_case(int i, const size_t *sz, size_t nsz, int *ka, int *kb, size_t *n, int *right)
{
    *ka = i % TM_NKINDS, *kb = (i / TM_NKINDS) % TM_NKINDS;
    *n = sz[(size_t)(i / (TM_NKINDS * TM_NKINDS)) % nsz];
    *right = i / (TM_NKINDS * TM_NKINDS * (int)nsz);
}

/* _i enumerates (kind of A, kind of B, size, side). */
START_TEST(test_solve_all_pairs)
{
    int ka, kb, right;
    size_t n;
    pick_case(_i, sizes, NSIZES, &ka, &kb, &n, &right);
    tu_rng r;
    tu_rng_seed(&r, 7000 + (uint64_t)_i);
    size_t m = kb == TM_DIAG ? n : n + 2; /* the other dimension of B */
    bst_mat *a = contraction(ka, n, &r);
    bst_mat *b = right ? tm_random(ctx, kb, m, n, 1.0, &r) : tm_random(ctx, kb, n, m, 1.0, &r);
    bst_mat *x;
    double rcond;
    int rc = right ? bst_solve_right(ctx, a, b, BST_RCOND_WARN, &x, &rcond)
                   : bst_solve_left(ctx, a, b, BST_RCOND_WARN, &x, &rcond);
    ck_assert_msg(rc == BST_OK, "%s A, %s B, n %zu: %s", tm_kind_name[ka], tm_kind_name[kb], n,
                  bst_ctx_message(ctx));
    ck_assert(rcond > 0.05 && rcond <= 1.0);
    ck_assert_msg(rc == BST_OK, "unexpected warning"); /* |A| <= 0.9: rcond >= (1 - 0.9) / 1.9 */
    ck_assert_uint_eq(bst_mat_rows(x), bst_mat_rows(b));
    ck_assert_uint_eq(bst_mat_cols(x), bst_mat_cols(b));
    if (ka == TM_DIAG || ka == TM_ZERO)
        ck_assert_int_eq(bst_mat_structure(x), bst_mat_structure(b));
    if (kb == TM_ZERO)
        ck_assert_int_eq(bst_mat_structure(x), BST_ZERO);
    /* residual with dense double arithmetic: (I - A) X - B, or Y (I - A) - B */
    size_t rows = bst_mat_rows(b), cols = bst_mat_cols(b);
    double *da = tm_dense(ctx, a), *db = tm_dense(ctx, b), *dx = tm_dense(ctx, x);
    double *res = malloc(rows * cols * sizeof *res);
    for (size_t q = 0; q < n * n; q++)
        da[q] = -da[q];
    for (size_t i = 0; i < n; i++)
        da[i * n + i] += 1.0;
    if (right)
        tm_gemm(rows, n, n, dx, da, res);
    else
        tm_gemm(n, n, cols, da, dx, res);
    double eps = fmax(tm_eps(a), tm_eps(b));
    double tol = 50.0 * (double)n * eps * fmax(1.0, tm_maxabs(db, rows * cols)) / fmax(rcond, 1e-300);
    ck_assert_msg(tm_maxdiff(res, db, rows * cols) <= tol, "%s A, %s B, n %zu, %s: residual %g > %g",
                  tm_kind_name[ka], tm_kind_name[kb], n, right ? "right" : "left",
                  tm_maxdiff(res, db, rows * cols), tol);
    /* and the same answer as the generic dense solve */
    bst_mat *ad, *g;
    ck_assert_int_eq(bst_mat_convert(ctx, a, BST_DENSE, BST_DOUBLE, &ad), BST_OK);
    rc = right ? bst_solve_right(ctx, ad, b, 0.0, &g, NULL) : bst_solve_left(ctx, ad, b, 0.0, &g, NULL);
    ck_assert_int_eq(rc, BST_OK);
    double *dg = tm_dense(ctx, g);
    ck_assert_double_le(tm_maxdiff(dx, dg, rows * cols), tol);
    free(da), free(db), free(dx), free(dg), free(res);
    bst_mat_free(a), bst_mat_free(b), bst_mat_free(x), bst_mat_free(ad), bst_mat_free(g);
}
END_TEST

/* A sparse A's solves with many columns (n x columns >= 2^20) are shared out among threads, a
 * sparse or diagonal B's result gathered by column: one thread and two give the same bits, left
 * and right, with a sparse, diagonal and dense B, and the dense solve's answer, in the structure
 * the dense solve's result compacts to.  A is a band of five diagonals (its LU stays in the band;
 * a random sparse A's would fill and go the dense way; its inverse is dense), 2 x 2 blocks on the
 * diagonal (a sparse result) or a diagonal held sparse (a diagonal B's result is diagonal). */
START_TEST(test_sparse_threads)
{
    static const int kinds[3] = {TM_SPARSE, TM_DIAG, TM_DENSE};
    int kb = kinds[_i % 3], right = (_i / 3) % 2, ka = _i / 6;
    size_t n = 1100;
    tu_rng r;
    tu_rng_seed(&r, 9100 + (uint64_t)_i);
    size_t *ri = malloc(5 * n * sizeof *ri), *ci = malloc(5 * n * sizeof *ci), nz = 0;
    double *v = malloc(5 * n * sizeof *v);
    for (size_t j = 0; j < n; j++) {
        size_t lo = ka == 0 ? (j >= 2 ? j - 2 : 0) : ka == 1 ? j - j % 2 : j;
        size_t hi = ka == 0 ? j + 2 : ka == 1 ? j - j % 2 + 1 : j;
        for (size_t i = lo; i <= hi && i < n; i++) /* |A|_1 <= 0.9 */
            ri[nz] = i, ci[nz] = j, v[nz++] = 0.18 * (2.0 * tu_rng_uniform(&r) - 1.0);
    }
    bst_mat *a, *b = tm_random(ctx, kb, n, n, 1.0, &r);
    ck_assert_int_eq(bst_mat_new_sparse(ctx, n, n, nz, ri, ci, v, &a), BST_OK);
    free(ri), free(ci), free(v);
    ck_assert_int_eq(bst_mat_structure(a), BST_SPARSE);
    double *got[2];
    bst_structure st[2];
    for (int t = 0; t < 2; t++) {
        ck_assert_int_eq(bst_ctx_set_threads(ctx, t + 1), BST_OK);
        bst_mat *x;
        int rc = right ? bst_solve_right(ctx, a, b, 0.0, &x, NULL) : bst_solve_left(ctx, a, b, 0.0, &x, NULL);
        ck_assert_msg(rc == BST_OK, "%s", bst_ctx_message(ctx));
        got[t] = tm_dense(ctx, x);
        st[t] = bst_mat_structure(x);
        bst_mat_free(x);
    }
    ck_assert_int_eq(bst_ctx_set_threads(ctx, 0), BST_OK);
    ck_assert_int_eq(st[0], st[1]);
    ck_assert_msg(memcmp(got[0], got[1], n * n * sizeof *got[0]) == 0, "A %d, %s B, %s: 1 and 2 "
                  "threads differ", ka, tm_kind_name[kb], right ? "right" : "left");
    bst_mat *ad, *g, *gc;
    ck_assert_int_eq(bst_mat_convert(ctx, a, BST_DENSE, BST_DOUBLE, &ad), BST_OK);
    int rc = right ? bst_solve_right(ctx, ad, b, 0.0, &g, NULL) : bst_solve_left(ctx, ad, b, 0.0, &g, NULL);
    ck_assert_int_eq(rc, BST_OK);
    ck_assert_int_eq(bst_mat_compact(ctx, g, BST_SPARSE_MAX_FILL, &gc), BST_OK);
    if (kb != TM_DENSE)
        ck_assert_msg(st[0] == bst_mat_structure(gc), "A %d, %s B, %s: structure %d, the dense "
                      "solve's compacts to %d", ka, tm_kind_name[kb], right ? "right" : "left",
                      (int)st[0], (int)bst_mat_structure(gc));
    double *dg = tm_dense(ctx, g), *db = tm_dense(ctx, b);
    double tol = 1e-12 * fmax(1.0, tm_maxabs(db, n * n));
    ck_assert_msg(tm_maxdiff(got[0], dg, n * n) <= tol, "A %d, %s B, %s: %g from the dense solve", ka,
                  tm_kind_name[kb], right ? "right" : "left", tm_maxdiff(got[0], dg, n * n));
    free(got[0]), free(got[1]), free(dg), free(db);
    bst_mat_free(a), bst_mat_free(b), bst_mat_free(ad), bst_mat_free(g), bst_mat_free(gc);
}
END_TEST

/* A = s P, P a cyclic permutation (the diagonal kind uses P = I): as s -> 1 the condition estimate
 * falls monotonically, BST_WILLCOND appears, nothing becomes NaN; s = 1 is singular. */
START_TEST(test_condition)
{
    int kind = _i; /* TM_DIAG, TM_SPARSE, TM_DENSE, TM_FLOAT via _i = 1..4 */
    size_t n = 40;
    const double s[] = {0.5, 0.9, 0.99, 0.9999, 1 - 1e-7, 1 - 1e-10, 1 - 1e-13};
    double last = INFINITY;
    size_t *ri = malloc(n * sizeof *ri), *ci = malloc(n * sizeof *ci);
    double *x = malloc(n * sizeof *x);
    tu_rng r;
    tu_rng_seed(&r, 11);
    bst_mat *b = tm_random(ctx, TM_DENSE, n, 3, 1.0, &r);
    for (size_t k = 0; k <= sizeof s / sizeof s[0]; k++) {
        double sk = k < sizeof s / sizeof s[0] ? s[k] : 1.0;
        if (kind == TM_FLOAT && sk > 1 - 1e-7 && sk < 1.0)
            continue; /* not representable as a float below 1 */
        for (size_t i = 0; i < n; i++)
            ri[i] = kind == TM_DIAG ? i : (i + 1) % n, ci[i] = i, x[i] = sk;
        bst_mat *p, *a;
        ck_assert_int_eq(bst_mat_new_sparse(ctx, n, n, n, ri, ci, x, &p), BST_OK);
        if (kind == TM_SPARSE)
            a = p;
        else {
            ck_assert_int_eq(bst_mat_convert(ctx, p, kind == TM_DIAG ? BST_DIAG : BST_DENSE,
                                             kind == TM_FLOAT ? BST_FLOAT : BST_DOUBLE, &a), BST_OK);
            bst_mat_free(p);
        }
        bst_mat *xs = NULL;
        double rcond;
        int rc = bst_solve_left(ctx, a, b, BST_RCOND_WARN, &xs, &rcond);
        if (sk == 1.0) {
            ck_assert_msg(rc == BST_ESINGULAR, "%s: s = 1 gave %d (%s)", tm_kind_name[kind], rc,
                          bst_ctx_message(ctx));
            ck_assert_ptr_null(xs);
        } else {
            ck_assert_msg(rc == BST_OK || rc == BST_WILLCOND, "%s s=%g: %s", tm_kind_name[kind], sk,
                          bst_ctx_message(ctx));
            ck_assert_msg(rcond <= last * (1 + 1e-6), "%s: rcond %g after %g", tm_kind_name[kind], rcond, last);
            ck_assert(bst_mat_all_finite(xs));
            /* 1 - s sets the scale: rcond within a factor n of it */
            ck_assert_msg(rcond > (1 - sk) / (4.0 * n) && rcond < 4.0 * (1 - sk) + 1e-6,
                          "%s s=%g: rcond %g", tm_kind_name[kind], sk, rcond);
            double warn = kind == TM_FLOAT ? 3.5e-4 : BST_RCOND_WARN;
            ck_assert_int_eq(rc, rcond < warn ? BST_WILLCOND : BST_OK);
            last = rcond;
        }
        bst_mat_free(xs);
        bst_mat_free(a);
    }
    ck_assert_double_lt(last, kind == TM_FLOAT ? 3.5e-4 : BST_RCOND_WARN); /* warning reached */
    free(ri), free(ci), free(x);
    bst_mat_free(b);
}
END_TEST

START_TEST(test_errors)
{
    bst_mat *a, *b, *x = (bst_mat *)1;
    tu_rng r;
    tu_rng_seed(&r, 3);
    a = tm_random(ctx, TM_DENSE, 3, 4, 0.1, &r);
    b = tm_random(ctx, TM_DENSE, 3, 2, 1.0, &r);
    ck_assert_int_eq(bst_solve_left(ctx, a, b, 0, &x, NULL), BST_ESIZE);
    ck_assert_ptr_null(x);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "not square"));
    bst_mat_free(a);
    a = tm_random(ctx, TM_DENSE, 4, 4, 0.1, &r);
    ck_assert_int_eq(bst_solve_left(ctx, a, b, 0, &x, NULL), BST_ESIZE);
    ck_assert_int_eq(bst_solve_right(ctx, a, b, 0, &x, NULL), BST_ESIZE);
    ck_assert_int_eq(bst_solve_left(ctx, NULL, b, 0, &x, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_solve_left(ctx, a, NULL, 0, &x, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_solve_left(ctx, a, a, 0, NULL, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_solve_left(ctx, a, a, NAN, &x, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_solve_left(NULL, a, a, 0, &x, NULL), BST_EINVAL);
    /* NaN in A: reported, never returned */
    double *d = bst_mat_dense_data(a);
    d[5] = NAN;
    ck_assert_int_eq(bst_solve_left(ctx, a, a, 0, &x, NULL), BST_ESINGULAR);
    ck_assert_ptr_null(x);
    bst_mat_free(a), bst_mat_free(b);
}
END_TEST

START_TEST(test_alloc_failure)
{
    int ka = 1 + _i % 4, kb = 1 + _i / 4; /* diag, sparse, dense, float for A and B */
    bst_ctx *c = bst_ctx_new();
    tu_alloc al = {0};
    ck_assert_int_eq(bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &al), BST_OK);
    bst_ctx *save = ctx;
    ctx = c;
    tu_rng r;
    tu_rng_seed(&r, 9);
    bst_mat *a = contraction(ka, 12, &r), *b = tm_random(c, kb, 12, 12, 1.0, &r);
    for (int right = 0; right < 2; right++) {
        long base = al.live;
        for (long k = 1;; k++) {
            al.fail_at = al.count + k;
            bst_mat *x = (bst_mat *)1;
            int rc = right ? bst_solve_right(c, a, b, 0, &x, NULL) : bst_solve_left(c, a, b, 0, &x, NULL);
            if (rc == BST_OK) {
                bst_mat_free(x);
                break;
            }
            ck_assert_int_eq(rc, BST_ENOMEM);
            ck_assert_ptr_null(x);
            ck_assert_int_eq(al.live, base);
            ck_assert_int_lt(k, 60);
        }
    }
    al.fail_at = 0;
    bst_mat_free(a), bst_mat_free(b);
    ck_assert_int_eq(al.live, 0);
    ctx = save;
    bst_ctx_free(c);
}
END_TEST

/* Sizes of the taking solves: below, at and across the in-place transpose's tiles (32 x 32,
 * BSTI_TRANSPOSE_TILE). */
static const size_t take_sizes[] = {1, 7, 64, 150};
#define NTAKE (sizeof take_sizes / sizeof take_sizes[0])

/* Bits of two matrices of one structure and shape equal (dense values, or the dense copies). */
static int same_bits(const bst_mat *x, const bst_mat *y)
{
    if (bst_mat_structure(x) != bst_mat_structure(y) || bst_mat_precision(x) != bst_mat_precision(y) ||
        bst_mat_rows(x) != bst_mat_rows(y) || bst_mat_cols(x) != bst_mat_cols(y))
        return 0;
    double *dx = tm_dense(ctx, x), *dy = tm_dense(ctx, y);
    int same = memcmp(dx, dy, bst_mat_rows(x) * bst_mat_cols(x) * sizeof *dx) == 0;
    free(dx), free(dy);
    return same;
}

/* bsti_solve_take with A and B taken gives the bits of bst_solve_left / bst_solve_right (which
 * copy both), and a dense B in the factor's precision comes back as the result itself.  _i
 * enumerates (kind of A, kind of B, size, side); B is square, as the stack's are. */
START_TEST(test_solve_take)
{
    int ka, kb, right;
    size_t n;
    pick_case(_i, take_sizes, NTAKE, &ka, &kb, &n, &right);
    tu_rng r;
    tu_rng_seed(&r, 8100 + (uint64_t)_i);
    bst_mat *a = contraction(ka, n, &r), *b = tm_random(ctx, kb, n, n, 1.0, &r);
    bst_mat *ref = NULL, *x = NULL, *at, *bt;
    int rc = right ? bst_solve_right(ctx, a, b, BST_RCOND_WARN, &ref, NULL)
                   : bst_solve_left(ctx, a, b, BST_RCOND_WARN, &ref, NULL);
    ck_assert_int_eq(rc, BST_OK);
    ck_assert_int_eq(bst_mat_convert(ctx, a, bst_mat_structure(a), bst_mat_precision(a), &at), BST_OK);
    ck_assert_int_eq(bst_mat_convert(ctx, b, bst_mat_structure(b), bst_mat_precision(b), &bt), BST_OK);
    double rcond;
    rc = bsti_solve_take(ctx, right, at, bt, bt, BST_RCOND_WARN, BST_DOUBLE, &x, &rcond, NULL);
    ck_assert_msg(rc == BST_OK, "%s A, %s B, n %zu: %s", tm_kind_name[ka], tm_kind_name[kb], n,
                  bst_ctx_message(ctx));
    ck_assert_msg(same_bits(x, ref), "%s A, %s B, n %zu, %s: not the borrowing solve's bits",
                  tm_kind_name[ka], tm_kind_name[kb], n, right ? "right" : "left");
    int in_place = (ka == TM_DENSE || ka == TM_FLOAT) && /* and B in the factor's precision */
                   (kb == TM_FLOAT || (ka == TM_DENSE && kb == TM_DENSE));
    if (in_place) /* bt was solved in its own storage (the matrix freed otherwise) */
        ck_assert_ptr_eq(x, bt);
    bst_mat_free(a), bst_mat_free(b), bst_mat_free(ref), bst_mat_free(x);
}
END_TEST

/* A dense I - A of n >= 2048 inverted by solve.c's own blocked getri (blocks of 512 from the right,
 * the last one partial here), for a diagonal right-hand side (the inverse pays): against getrs's
 * solve of the same B made dense.  _i: side, precision; in double A = I + R (R random: I - A pivots
 * in every column), in single a contraction (no warning of condition). */
START_TEST(test_own_getri)
{
    int right = _i & 1;
    bst_precision prec = _i & 2 ? BST_FLOAT : BST_DOUBLE;
    size_t n = 2100;
    tu_rng r;
    tu_rng_seed(&r, 8300 + (uint64_t)_i);
    double *av = malloc(n * n * sizeof *av);
    for (size_t i = 0; i < n * n; i++)
        av[i] = (tu_rng_uniform(&r) - 0.5) * (prec == BST_DOUBLE ? 1.0 : 0.9 / (0.5 * (double)n));
    for (size_t i = 0; prec == BST_DOUBLE && i < n; i++)
        av[i * n + i] += 1.0;
    bst_mat *a, *b = tm_random(ctx, TM_DIAG, n, n, 1.0, &r), *bd, *x[2];
    ck_assert_int_eq(bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &a), BST_OK);
    memcpy(bst_mat_dense_data(a), av, n * n * sizeof *av);
    ck_assert_int_eq(bst_mat_convert(ctx, b, BST_DENSE, BST_DOUBLE, &bd), BST_OK);
    for (int k = 0; k < 2; k++) {
        bst_mat *ak;
        ck_assert_int_eq(bst_mat_convert(ctx, a, BST_DENSE, prec, &ak), BST_OK);
        int rc = bsti_solve_take(ctx, right, ak, k ? bd : b, NULL, 0.0, prec, &x[k], NULL, NULL);
        ck_assert_msg(rc == BST_OK, "%s", bst_ctx_message(ctx));
    }
    double *x0 = tm_dense(ctx, x[0]), *x1 = tm_dense(ctx, x[1]);
    double scale = tm_maxabs(x1, n * n), tol = prec == BST_DOUBLE ? 1e-10 : 1e-5;
    ck_assert_msg(tm_maxdiff(x0, x1, n * n) <= tol * scale, "%s, %s: inverse %g from getrs",
                  right ? "right" : "left", prec == BST_DOUBLE ? "double" : "single",
                  tm_maxdiff(x0, x1, n * n) / scale);
    free(x0), free(x1), free(av);
    bst_mat_free(a), bst_mat_free(b), bst_mat_free(bd), bst_mat_free(x[0]), bst_mat_free(x[1]);
}
END_TEST

/* A sparse A whose LU would fill (random, 5 % of the values: UMFPACK's analysis refuses it) goes
 * dense; the next A of its pattern (other values: the next channel's) goes dense without a second
 * analysis, and its solution is the dense path's to the bit; another pattern is analysed again, and
 * one UMFPACK factors (a diagonal) is not remembered. */
START_TEST(test_refused_pattern)
{
    size_t n = 300;
    tu_rng r;
    tu_rng_seed(&r, 8800);
    bst_mat *a = contraction(TM_SPARSE, n, &r), *b = tm_random(ctx, TM_DENSE, n, 7, 1.0, &r);
    bst_mat *x, *half, *ad, *xd, *d = contraction(TM_DIAG, n, &r);
    int next = ctx->refused_next;
    ck_assert_int_eq(bst_solve_left(ctx, a, b, 0.0, &x, NULL), BST_OK);
    ck_assert_int_eq(ctx->refused_next, (next + 1) % BSTI_REFUSED_SLOTS); /* analysed, refused */
    ck_assert_double_eq(ctx->refusals_remembered, 0.0);
    bst_mat_free(x);
    double *w = malloc(n * sizeof *w);
    for (size_t i = 0; i < n; i++)
        w[i] = 0.25 + 0.5 * tu_rng_uniform(&r);
    ck_assert_int_eq(bst_mat_scale(ctx, w, a, NULL, &half), BST_OK);
    ck_assert_int_eq(bst_solve_left(ctx, half, b, 0.0, &x, NULL), BST_OK);
    ck_assert_double_eq(ctx->refusals_remembered, 1.0);
    ck_assert_int_eq(ctx->refused_next, (next + 1) % BSTI_REFUSED_SLOTS);
    ck_assert_int_eq(bst_mat_convert(ctx, half, BST_DENSE, BST_DOUBLE, &ad), BST_OK);
    ck_assert_int_eq(bst_solve_left(ctx, ad, b, 0.0, &xd, NULL), BST_OK);
    ck_assert_int_eq(bst_mat_structure(x), BST_DENSE);
    ck_assert_int_eq(memcmp(bst_mat_dense_data(x), bst_mat_dense_data(xd), n * 7 * sizeof(double)), 0);
    bst_mat_free(x), bst_mat_free(xd), bst_mat_free(ad);
    /* one value off the diagonal moved to another row of its column (the same count of values
       in every column): analysed again */
    ck_assert_int_eq(bst_mat_convert(ctx, half, BST_DENSE, BST_DOUBLE, &ad), BST_OK);
    double *v = bst_mat_dense_data(ad);
    size_t off = 0, to;
    while (v[off] == 0.0 || off % (n + 1) == 0)
        off++;
    for (to = off - off % n; v[to] != 0.0; to++)
        ;
    ck_assert_uint_eq(to / n, off / n);
    v[to] = v[off], v[off] = 0.0;
    bst_mat *other;
    ck_assert_int_eq(bst_mat_convert(ctx, ad, BST_SPARSE, BST_DOUBLE, &other), BST_OK);
    ck_assert_int_eq(bst_solve_left(ctx, other, b, 0.0, &x, NULL), BST_OK);
    ck_assert_double_eq(ctx->refusals_remembered, 1.0);
    ck_assert_int_eq(ctx->refused_next, (next + 2) % BSTI_REFUSED_SLOTS);
    bst_mat_free(x);
    /* a sparse diagonal: factored by UMFPACK, nothing remembered */
    bst_mat *ds;
    ck_assert_int_eq(bst_mat_convert(ctx, d, BST_SPARSE, BST_DOUBLE, &ds), BST_OK);
    ck_assert_int_eq(bst_solve_left(ctx, ds, b, 0.0, &x, NULL), BST_OK);
    ck_assert_int_eq(ctx->refused_next, (next + 2) % BSTI_REFUSED_SLOTS);
    bst_mat_free(x);
    free(w);
    bst_mat_free(a), bst_mat_free(b), bst_mat_free(half), bst_mat_free(ad), bst_mat_free(other);
    bst_mat_free(d), bst_mat_free(ds);
}
END_TEST

/* bsti_solve_take_left2 with both right-hand sides taken: the bits of two bst_solve_left, but for
 * a sparse or diagonal B1, which alone may take another path. */
START_TEST(test_solve_take_left2)
{
    int ka = _i % TM_NKINDS, kb = _i / TM_NKINDS; /* B1's kind; B2 dense, in float with A or
                                                  * B1 (one factor's precision for both) */
    size_t n = 150;
    tu_rng r;
    tu_rng_seed(&r, 8300 + (uint64_t)_i);
    bst_mat *a = contraction(ka, n, &r), *b1 = tm_random(ctx, kb, n, n, 1.0, &r);
    bst_mat *b2 = tm_random(ctx, ka == TM_FLOAT || kb == TM_FLOAT ? TM_FLOAT : TM_DENSE, n, n, 1.0, &r);
    bst_mat *r1, *r2, *at, *b1t, *b2t, *x1 = NULL, *x2 = NULL;
    ck_assert_int_eq(bst_solve_left(ctx, a, b1, BST_RCOND_WARN, &r1, NULL), BST_OK);
    ck_assert_int_eq(bst_solve_left(ctx, a, b2, BST_RCOND_WARN, &r2, NULL), BST_OK);
    ck_assert_int_eq(bst_mat_convert(ctx, a, bst_mat_structure(a), bst_mat_precision(a), &at), BST_OK);
    ck_assert_int_eq(bst_mat_convert(ctx, b1, bst_mat_structure(b1), bst_mat_precision(b1), &b1t), BST_OK);
    ck_assert_int_eq(bst_mat_convert(ctx, b2, bst_mat_structure(b2), bst_mat_precision(b2), &b2t), BST_OK);
    ck_assert_int_eq(bsti_solve_take_left2(ctx, at, b1t, b1t, b2t, b2t, BST_RCOND_WARN, BST_DOUBLE,
                                           &x1, &x2, NULL, NULL), BST_OK);
    if (kb == TM_SPARSE || kb == TM_DIAG) {
        /* alone, B1 may go through the inverse of a dense factorization (solve.c, inverse_pays),
         * beside the dense B2 through getrs: the same values to rounding */
        double *d1 = tm_dense(ctx, x1), *e1 = tm_dense(ctx, r1);
        double tol = 16.0 * (double)n * fmax(tm_eps(x1), tm_eps(r1)) * fmax(1.0, tm_maxabs(e1, n * n));
        ck_assert_msg(tm_maxdiff(d1, e1, n * n) <= tol, "%s A, %s B1: %g", tm_kind_name[ka],
                      tm_kind_name[kb], tm_maxdiff(d1, e1, n * n));
        ck_assert(same_bits(x2, r2));
        free(d1), free(e1);
    } else {
        ck_assert_msg(same_bits(x1, r1) && same_bits(x2, r2), "%s A, %s B1", tm_kind_name[ka],
                      tm_kind_name[kb]);
    }
    bst_mat_free(a), bst_mat_free(b1), bst_mat_free(b2), bst_mat_free(r1), bst_mat_free(r2);
    bst_mat_free(x1), bst_mat_free(x2);
}
END_TEST

/* Every allocation failure in a taking solve frees what it took (the counting allocator ends at
 * zero live blocks) and returns no result; dense A and B of both precisions, both sides. */
START_TEST(test_take_alloc_failure)
{
    int ka = _i % 2 ? TM_FLOAT : TM_DENSE, kb = (_i / 2) % 2 ? TM_FLOAT : TM_DENSE, right = _i / 4;
    bst_ctx *c = bst_ctx_new();
    tu_alloc al = {0};
    ck_assert_int_eq(bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &al), BST_OK);
    bst_ctx *save = ctx;
    ctx = c;
    tu_rng r;
    tu_rng_seed(&r, 10 + (uint64_t)_i);
    bst_mat *a = contraction(ka, 70, &r), *b = tm_random(c, kb, 70, 70, 1.0, &r);
    long base = al.live;
    for (long k = 1;; k++) {
        bst_mat *at = NULL, *bt = NULL, *x = (bst_mat *)1;
        ck_assert_int_eq(bst_mat_convert(c, a, BST_DENSE, bst_mat_precision(a), &at), BST_OK);
        ck_assert_int_eq(bst_mat_convert(c, b, BST_DENSE, bst_mat_precision(b), &bt), BST_OK);
        al.fail_at = al.count + k;
        int rc = bsti_solve_take(c, right, at, bt, bt, 0, BST_DOUBLE, &x, NULL, NULL);
        al.fail_at = 0;
        if (rc == BST_OK) {
            bst_mat_free(x);
            ck_assert_int_eq(al.live, base);
            break;
        }
        ck_assert_int_eq(rc, BST_ENOMEM);
        ck_assert_ptr_null(x);
        ck_assert_int_eq(al.live, base);
        ck_assert_int_lt(k, 60);
    }
    bst_mat_free(a), bst_mat_free(b);
    ck_assert_int_eq(al.live, 0);
    ctx = save;
    bst_ctx_free(c);
}
END_TEST

static Suite *solve_suite(void)
{
    Suite *s = suite_create("solve");
    TCase *tc = tcase_create("solve");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_loop_test(tc, test_solve_all_pairs, 0, 2 * TM_NKINDS * TM_NKINDS * (int)NSIZES);
    tcase_add_loop_test(tc, test_condition, TM_DIAG, TM_NKINDS);
    tcase_add_test(tc, test_errors);
    tcase_add_loop_test(tc, test_sparse_threads, 0, 18);
    tcase_add_loop_test(tc, test_alloc_failure, 0, 16);
    tcase_add_loop_test(tc, test_solve_take, 0, 2 * TM_NKINDS * TM_NKINDS * (int)NTAKE);
    tcase_add_loop_test(tc, test_solve_take_left2, 0, TM_NKINDS * TM_NKINDS);
    tcase_add_test(tc, test_refused_pattern);
    tcase_add_loop_test(tc, test_own_getri, 0, 4);
    tcase_add_loop_test(tc, test_take_alloc_failure, 0, 8);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(solve_suite());
}
