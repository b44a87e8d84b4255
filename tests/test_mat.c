/* test_mat.c - every specialized product, sum, scaling, transpose and conversion of the algebra
 * against plain dense loops, for every pair of operand structures (dense in double and float) and
 * sizes 1 .. 300; result structures; the sparse-dense products' bits on any thread count; the
 * dense passes' sums and finiteness against plain loops; error paths; injected allocation failures. */
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

/* The structure a product must come back in (DESIGN.md §2: the cheapest that holds it). */
static bst_structure expected_product(int ka, int kb)
{
    if (ka == TM_ZERO || kb == TM_ZERO)
        return BST_ZERO;
    if (ka == TM_DIAG)
        return kb == TM_DIAG ? BST_DIAG : kb == TM_SPARSE ? BST_SPARSE : BST_DENSE;
    if (kb == TM_DIAG)
        return ka == TM_SPARSE ? BST_SPARSE : BST_DENSE;
    if (ka == TM_SPARSE && kb == TM_SPARSE)
        return BST_SPARSE;
    return BST_DENSE;
}

/* _i enumerates (kind of A, kind of B, size). */
START_TEST(test_mul_all_pairs)
{
    int ka = _i % TM_NKINDS, kb = (_i / TM_NKINDS) % TM_NKINDS;
    size_t n = sizes[_i / (TM_NKINDS * TM_NKINDS)];
    tu_rng r;
    tu_rng_seed(&r, 1000 + (uint64_t)_i);
    /* rectangular where the structures allow it */
    size_t m = (ka == TM_DIAG) ? n : n + 3, k = n, p = (kb == TM_DIAG) ? n : n + 1;
    if (ka == TM_DIAG)
        m = k;
    bst_mat *a = tm_random(ctx, ka, m, k, 1.0, &r), *b = tm_random(ctx, kb, k, p, 1.0, &r), *c, *g;
    ck_assert_int_eq(bst_mat_mul(ctx, a, b, 0.0, &c), BST_OK);
    ck_assert_int_eq(bsti_mat_mul_generic(ctx, a, b, &g), BST_OK);
    ck_assert_uint_eq(bst_mat_rows(c), m);
    ck_assert_uint_eq(bst_mat_cols(c), p);
    ck_assert_int_eq(bst_mat_structure(c), expected_product(ka, kb));
    if (ka == TM_FLOAT || kb == TM_FLOAT)
        ck_assert(bst_mat_structure(c) != BST_DENSE || bst_mat_precision(c) == BST_FLOAT);
    double *da = tm_dense(ctx, a), *db = tm_dense(ctx, b), *dc = tm_dense(ctx, c), *dg = tm_dense(ctx, g);
    double *ref = malloc(m * p * sizeof *ref);
    tm_gemm(m, k, p, da, db, ref);
    double eps = fmax(tm_eps(a), tm_eps(b));
    /* |A B - fl(A B)| <= k eps |A| |B| elementwise, |A|,|B| <= 1: bounded by k^2 eps */
    double tol = 4.0 * (double)k * (double)k * eps + 1e-300;
    ck_assert_msg(tm_maxdiff(dc, ref, m * p) <= tol, "%s x %s, n %zu: kernel error %g > %g",
                  tm_kind_name[ka], tm_kind_name[kb], n, tm_maxdiff(dc, ref, m * p), tol);
    ck_assert_msg(tm_maxdiff(dc, dg, m * p) <= tol, "%s x %s, n %zu: kernel vs generic %g",
                  tm_kind_name[ka], tm_kind_name[kb], n, tm_maxdiff(dc, dg, m * p));
    free(da), free(db), free(dc), free(dg), free(ref);
    bst_mat_free(a), bst_mat_free(b), bst_mat_free(c), bst_mat_free(g);
}
END_TEST

START_TEST(test_add_all_pairs)
{
    int ka = _i % TM_NKINDS, kb = (_i / TM_NKINDS) % TM_NKINDS;
    size_t n = sizes[_i / (TM_NKINDS * TM_NKINDS)];
    tu_rng r;
    tu_rng_seed(&r, 2000 + (uint64_t)_i);
    bst_mat *a = tm_random(ctx, ka, n, n, 1.0, &r), *b = tm_random(ctx, kb, n, n, 1.0, &r), *c;
    ck_assert_int_eq(bst_mat_add(ctx, 0.75, a, -2.5, b, &c), BST_OK);
    double *da = tm_dense(ctx, a), *db = tm_dense(ctx, b), *dc = tm_dense(ctx, c);
    for (size_t q = 0; q < n * n; q++)
        da[q] = 0.75 * da[q] - 2.5 * db[q];
    double eps = fmax(tm_eps(a), tm_eps(b));
    ck_assert_double_le(tm_maxdiff(dc, da, n * n), 8.0 * eps);
    /* structure: zero is the identity, diag + diag = diag, sparse-like pairs stay sparse */
    bst_structure want = ka == TM_ZERO && kb == TM_ZERO ? BST_ZERO
                         : (ka == TM_DENSE || ka == TM_FLOAT || kb == TM_DENSE || kb == TM_FLOAT) ? BST_DENSE
                         : ka == TM_ZERO ? bst_mat_structure(b)
                         : kb == TM_ZERO ? bst_mat_structure(a)
                         : (ka == TM_DIAG && kb == TM_DIAG) ? BST_DIAG : BST_SPARSE;
    ck_assert_int_eq(bst_mat_structure(c), want);
    free(da), free(db), free(dc);
    bst_mat_free(a), bst_mat_free(b), bst_mat_free(c);
}
END_TEST

/* The transpose of rectangular dense matrices, double and float, with sides that are and are not
 * multiples of its tiles (32), element by element against the definition. */
START_TEST(test_transpose_rect)
{
    static const size_t dims[][2] = {{1, 40}, {33, 5}, {64, 96}, {70, 129}};
    tu_rng r;
    tu_rng_seed(&r, 4242 + (uint64_t)_i);
    int kind = _i % 2 ? TM_FLOAT : TM_DENSE;
    size_t rows = dims[_i / 2][0], cols = dims[_i / 2][1];
    bst_mat *a = tm_random(ctx, kind, rows, cols, 1.0, &r), *t;
    ck_assert_int_eq(bst_mat_transpose(ctx, a, &t), BST_OK);
    ck_assert_int_eq(bst_mat_structure(t), BST_DENSE);
    ck_assert_int_eq(bst_mat_precision(t), bst_mat_precision(a));
    ck_assert_uint_eq(bst_mat_rows(t), cols);
    ck_assert_uint_eq(bst_mat_cols(t), rows);
    for (size_t j = 0; j < cols; j++)
        for (size_t i = 0; i < rows; i++)
            ck_assert_double_eq(bst_mat_get(t, j, i), bst_mat_get(a, i, j));
    bst_mat_free(a), bst_mat_free(t);
}
END_TEST

/* bsti_mat_add_take (the stack's sum with a term read for the last time): A + B with the bits of
 * bst_mat_add for A of every kind and B of every kind; a dense A in the sum's precision is the
 * result itself. */
START_TEST(test_add_take)
{
    int ka = _i % TM_NKINDS, kb = _i / TM_NKINDS;
    size_t n = 64;
    tu_rng r;
    tu_rng_seed(&r, 2500 + (uint64_t)_i);
    bst_mat *a = tm_random(ctx, ka, n, n, 1.0, &r), *b = tm_random(ctx, kb, n, n, 1.0, &r), *ref, *c;
    ck_assert_int_eq(bst_mat_add(ctx, 1.0, a, 1.0, b, &ref), BST_OK);
    int in_place = ka == TM_FLOAT || (ka == TM_DENSE && kb != TM_FLOAT);
    ck_assert_int_eq(bsti_mat_add_take(ctx, a, b, &c), BST_OK); /* a is c, or gone */
    if (in_place)
        ck_assert_ptr_eq(c, a);
    ck_assert_int_eq(bst_mat_structure(c), bst_mat_structure(ref));
    ck_assert_int_eq(bst_mat_precision(c), bst_mat_precision(ref));
    double *dc = tm_dense(ctx, c), *dr = tm_dense(ctx, ref);
    ck_assert_msg(memcmp(dc, dr, n * n * sizeof *dc) == 0, "%s + %s: not the bits of bst_mat_add",
                  tm_kind_name[ka], tm_kind_name[kb]);
    free(dc), free(dr);
    bst_mat_free(b), bst_mat_free(c), bst_mat_free(ref);
}
END_TEST

/* A product over an empty inner dimension is all zero, in either order of sparse and dense (the
 * panel kernels have no panel to copy). */
START_TEST(test_spmm_empty_inner)
{
    size_t none = 0;
    double one = 1.0;
    ctx->poison_raw = 1; /* a result left unset would read NaN: no inner values, zeros */
    for (int dense_left = 0; dense_left < 2; dense_left++) {
        bst_mat *d, *s, *c;
        ck_assert_int_eq(bst_mat_new_dense(ctx, dense_left ? 3 : 0, dense_left ? 0 : 4, BST_FLOAT, &d),
                         BST_OK);
        ck_assert_int_eq(bst_mat_new_sparse(ctx, dense_left ? 0 : 3, dense_left ? 4 : 0, 0, &none,
                                            &none, &one, &s), BST_OK);
        ck_assert_int_eq(dense_left ? bst_mat_mul(ctx, d, s, 0.0, &c) : bst_mat_mul(ctx, s, d, 0.0, &c),
                         BST_OK);
        ck_assert_uint_eq(bst_mat_rows(c), 3);
        ck_assert_uint_eq(bst_mat_cols(c), 4);
        for (size_t j = 0; j < 4; j++)
            for (size_t i = 0; i < 3; i++)
                ck_assert(bst_mat_get(c, i, j) == 0.0);
        bst_mat_free(d), bst_mat_free(s), bst_mat_free(c);
    }
    ctx->poison_raw = 0;
}
END_TEST

/* Sparse times dense and dense times sparse (mat_mul.c, by panels of the dense operand on the
 * context's threads): each C(i, j) is the sum over the sparse operand's non-zeros, inner index
 * ascending, of their products in the dense operand's precision (the loop written out here), to
 * the bit, on one thread or three, for dense operands of fewer lines than a panel, of several
 * panels and a part, rectangular operands, and a long inner dimension. */
START_TEST(test_spmm_same_bits)
{
    static const size_t dims[][3] = {{150, 130, 7}, {150, 130, 200}, {64, 64, 129},
                                     {150, 2500, 70}};
    int dense_left = _i % 2;
    size_t m = dims[_i / 2][0], k = dims[_i / 2][1], p = dims[_i / 2][2];
    if (dense_left) { /* the dense operand's lines are A's rows: the long side first */
        size_t x = m;
        m = p, p = x;
    }
    tu_rng r;
    tu_rng_seed(&r, 7100 + (uint64_t)_i);
    ctx->poison_raw = 1; /* the result's storage is not cleared first: a value not written is NaN */
    bst_mat *s = dense_left ? tm_random(ctx, TM_SPARSE, k, p, 1.0, &r)
                            : tm_random(ctx, TM_SPARSE, m, k, 1.0, &r);
    double *ds = tm_dense(ctx, s);
    for (int kind = TM_DENSE; kind <= TM_FLOAT; kind++) {
        bst_mat *d = dense_left ? tm_random(ctx, kind, m, k, 1.0, &r)
                                : tm_random(ctx, kind, k, p, 1.0, &r), *c[2];
        double *dd = tm_dense(ctx, d);
        for (int t = 0; t < 2; t++) {
            ck_assert_int_eq(bst_ctx_set_threads(ctx, t ? 3 : 1), BST_OK);
            ck_assert_int_eq(dense_left ? bst_mat_mul(ctx, d, s, 0.0, &c[t])
                                        : bst_mat_mul(ctx, s, d, 0.0, &c[t]), BST_OK);
            ck_assert_int_eq(bst_mat_structure(c[t]), BST_DENSE);
        }
        double *dc = tm_dense(ctx, c[1]);
        for (size_t j = 0; j < p; j++)
            for (size_t i = 0; i < m; i++) {
                double want = 0.0;
                float wantf = 0.0f;
                for (size_t q = 0; q < k; q++) {
                    double sv = dense_left ? ds[j * k + q] : ds[q * m + i];
                    double dv = dense_left ? dd[q * m + i] : dd[j * k + q];
                    if (sv != 0.0)
                        want += sv * dv, wantf += (float)sv * (float)dv;
                }
                double got = dc[j * m + i], w = kind == TM_FLOAT ? (double)wantf : want;
                ck_assert_msg(got == w, "%s, %s: %zu x %zu x %zu: C(%zu, %zu) = %.17g, the loop's "
                              "%.17g", dense_left ? "dense x sparse" : "sparse x dense",
                              tm_kind_name[kind], m, k, p, i, j, got, w);
            }
        size_t bytes = m * p * (kind == TM_FLOAT ? sizeof(float) : sizeof(double));
        ck_assert_msg(memcmp(bst_mat_dense_data(c[0]), bst_mat_dense_data(c[1]), bytes) == 0,
                      "%s B: one thread and three differ", tm_kind_name[kind]);
        free(dd), free(dc);
        bst_mat_free(d), bst_mat_free(c[0]), bst_mat_free(c[1]);
    }
    free(ds);
    bst_mat_free(s);
    ctx->poison_raw = 0;
}
END_TEST

/* The dense passes (dense_pass.c): column sums, weighted or of the positive values, the bits of
 * a plain loop on one thread and on three, for column counts around the eight a sweep takes;
 * finiteness with one Inf or NaN anywhere (the first value, the last, inside a 1024 block and in
 * the tail after the blocks). _i: (precision, shape). */
START_TEST(test_dense_passes)
{
    static const size_t shapes[][2] = {{7, 1}, {300, 7}, {300, 8}, {300, 9}, {65, 300}, {1030, 17}};
    int kind = _i % 2 ? TM_FLOAT : TM_DENSE;
    size_t m = shapes[_i / 2][0], n = shapes[_i / 2][1];
    tu_rng r;
    tu_rng_seed(&r, 9100 + (uint64_t)_i);
    bst_mat *a = tm_random(ctx, kind, m, n, 1.0, &r);
    double *x = tm_dense(ctx, a), *w = malloc(m * sizeof *w), *got = malloc(n * sizeof *got);
    for (size_t i = 0; i < m; i++)
        w[i] = 0.5 + tu_rng_uniform(&r);
    for (int t = 0; t < 2; t++) {
        ck_assert_int_eq(bst_ctx_set_threads(ctx, t ? 3 : 1), BST_OK);
        for (int v = 0; v < 3; v++) { /* weighted, plain, positive values */
            const double *wv = v == 0 ? w : NULL;
            bsti_dense_col_sums(ctx, a, wv, v == 2, got);
            for (size_t j = 0; j < n; j++) {
                double want = 0.0;
                for (size_t i = 0; i < m; i++) {
                    double e = x[j * m + i];
                    want += v == 0 ? w[i] * e : v == 1 ? e : e > 0.0 ? e : 0.0;
                }
                ck_assert_msg(got[j] == want, "%s %zu x %zu, %d threads, sums %d: column %zu %.17g, "
                              "the loop's %.17g", tm_kind_name[kind], m, n, t ? 3 : 1, v, j,
                              got[j], want);
            }
        }
        ck_assert(bsti_dense_finite(ctx, a));
        size_t places[] = {0, m * n - 1, (m * n) / 2, m * n > 1024 ? 1024 + 3 : m * n / 3};
        for (size_t q = 0; q < sizeof places / sizeof *places; q++)
            for (int bad = 0; bad < 2; bad++) {
                double b = bad ? NAN : -INFINITY;
                void *d = bst_mat_dense_data(a);
                double keep = x[places[q]];
                if (kind == TM_FLOAT)
                    ((float *)d)[places[q]] = (float)b;
                else
                    ((double *)d)[places[q]] = b;
                ck_assert_msg(!bsti_dense_finite(ctx, a) && !bst_mat_all_finite(a),
                              "%s %zu x %zu: %g at %zu read as finite", tm_kind_name[kind], m, n,
                              b, places[q]);
                if (kind == TM_FLOAT)
                    ((float *)d)[places[q]] = (float)keep;
                else
                    ((double *)d)[places[q]] = keep;
            }
        ck_assert(bsti_dense_finite(ctx, a) && bst_mat_all_finite(a));
    }
    free(x), free(w), free(got);
    bst_mat_free(a);
}
END_TEST

/* Scaling, transpose, conversions, compaction, column selection and sums for each kind. */
START_TEST(test_unary)
{
    int ka = _i % TM_NKINDS;
    size_t n = sizes[_i / TM_NKINDS];
    tu_rng r;
    tu_rng_seed(&r, 3000 + (uint64_t)_i);
    bst_mat *a = tm_random(ctx, ka, n, n, 1.0, &r), *t;
    double *da = tm_dense(ctx, a), *w = malloc(n * sizeof *w), *v = malloc(n * sizeof *v);
    double *ref = malloc(n * n * sizeof *ref), eps = tm_eps(a);
    for (size_t i = 0; i < n; i++)
        w[i] = 0.5 + tu_rng_uniform(&r), v[i] = 0.5 + tu_rng_uniform(&r);
    /* scale */
    ck_assert_int_eq(bst_mat_scale(ctx, w, a, v, &t), BST_OK);
    ck_assert_int_eq(bst_mat_structure(t), bst_mat_structure(a));
    for (size_t j = 0; j < n; j++)
        for (size_t i = 0; i < n; i++)
            ref[j * n + i] = w[i] * da[j * n + i] * v[j];
    double *dt = tm_dense(ctx, t);
    ck_assert_double_le(tm_maxdiff(dt, ref, n * n), 8.0 * eps);
    /* scaling a copy given up (bsti_mat_scale_take): the same bits, in its own storage when
     * dense or diagonal */
    bst_mat *own, *ts;
    ck_assert_int_eq(bst_mat_convert(ctx, a, bst_mat_structure(a), bst_mat_precision(a), &own), BST_OK);
    ck_assert_int_eq(bsti_mat_scale_take(ctx, w, own, v, &ts), BST_OK);
    ck_assert_int_eq(bst_mat_structure(ts), bst_mat_structure(t));
    ck_assert_int_eq(bst_mat_precision(ts), bst_mat_precision(t));
    if (ka == TM_DENSE || ka == TM_FLOAT || ka == TM_DIAG)
        ck_assert_ptr_eq(ts, own);
    double *dts = tm_dense(ctx, ts);
    ck_assert_int_eq(memcmp(dts, dt, n * n * sizeof *dt), 0);
    free(dts);
    bst_mat_free(ts);
    free(dt);
    bst_mat_free(t);
    /* transpose */
    ck_assert_int_eq(bst_mat_transpose(ctx, a, &t), BST_OK);
    dt = tm_dense(ctx, t);
    for (size_t j = 0; j < n; j++)
        for (size_t i = 0; i < n; i++)
            ck_assert_double_eq(dt[i * n + j], da[j * n + i]);
    free(dt);
    bst_mat_free(t);
    /* conversions to every structure that can hold it, exactly */
    for (int s = BST_ZERO; s <= BST_DENSE; s++) {
        int rc = bst_mat_convert(ctx, a, (bst_structure)s, bst_mat_precision(a), &t);
        int diag_only = 1, all_zero = 1;
        for (size_t j = 0; j < n; j++)
            for (size_t i = 0; i < n; i++)
                if (da[j * n + i] != 0.0) {
                    all_zero = 0;
                    diag_only &= i == j;
                }
        int can = s >= BST_SPARSE || (s == BST_DIAG && diag_only) || all_zero;
        if (!can) {
            ck_assert_int_eq(rc, BST_EINVAL);
            continue;
        }
        ck_assert_int_eq(rc, BST_OK);
        dt = tm_dense(ctx, t);
        ck_assert_double_eq(tm_maxdiff(dt, da, n * n), 0.0);
        free(dt);
        bst_mat_free(t);
    }
    /* compact: the cheapest structure */
    ck_assert_int_eq(bst_mat_compact(ctx, a, BST_SPARSE_MAX_FILL, &t), BST_OK);
    bst_structure want = ka == TM_ZERO ? BST_ZERO : ka == TM_DIAG || n == 1 ? BST_DIAG
                         : ka == TM_SPARSE && n >= 64 ? BST_SPARSE : BST_DENSE;
    if (ka == TM_SPARSE && n < 64)
        want = bst_mat_structure(t); /* fill of a tiny random sparse matrix varies; values below */
    ck_assert_int_eq(bst_mat_structure(t), want);
    dt = tm_dense(ctx, t);
    ck_assert_double_eq(tm_maxdiff(dt, da, n * n), 0.0);
    free(dt);
    bst_mat_free(t);
    /* column sums */
    double *cs = malloc(n * sizeof *cs);
    ck_assert_int_eq(bst_mat_col_weighted_sum(ctx, a, w, cs), BST_OK);
    for (size_t j = 0; j < n; j++) {
        double s = 0.0;
        for (size_t i = 0; i < n; i++)
            s += w[i] * da[j * n + i];
        tu_assert_close(cs[j], s, 4.0 * (double)n * DBL_EPSILON, 1.0);
    }
    free(cs);
    /* column selection, in a new order with a repeat */
    size_t cols[3] = {n - 1, 0, n - 1};
    ck_assert_int_eq(bst_mat_select_cols(ctx, a, 3, cols, &t), BST_OK);
    for (size_t k = 0; k < 3; k++)
        for (size_t i = 0; i < n; i++)
            ck_assert_double_eq(bst_mat_get(t, i, k), da[cols[k] * n + i]);
    bst_mat_free(t);
    ck_assert_double_eq(bst_mat_max_abs(a), tm_maxabs(da, n * n));
    ck_assert(bst_mat_all_finite(a));
    free(da), free(w), free(v), free(ref);
    bst_mat_free(a);
}
END_TEST

START_TEST(test_drop_tol)
{
    /* A sparse product with one tiny entry: dropped with a tolerance, kept without. */
    size_t ri[] = {0, 1, 0}, ci[] = {0, 0, 1};
    double x[] = {1.0, 1e-9, 1.0};
    bst_mat *a, *i2, *c;
    ck_assert_int_eq(bst_mat_new_sparse(ctx, 2, 2, 3, ri, ci, x, &a), BST_OK);
    size_t d[] = {0, 1};
    double one[] = {1, 1};
    ck_assert_int_eq(bst_mat_new_sparse(ctx, 2, 2, 2, d, d, one, &i2), BST_OK);
    ck_assert_int_eq(bst_mat_mul(ctx, a, i2, 0.0, &c), BST_OK);
    ck_assert_uint_eq(bst_mat_nnz(c), 3);
    bst_mat_free(c);
    ck_assert_int_eq(bst_mat_mul(ctx, a, i2, 1e-6, &c), BST_OK);
    ck_assert_uint_eq(bst_mat_nnz(c), 2);
    ck_assert_double_eq(bst_mat_get(c, 1, 0), 0.0);
    bst_mat_free(c);
    ck_assert_int_eq(bst_mat_mul(ctx, a, i2, 1.0, &c), BST_EINVAL);
    ck_assert_int_eq(bst_mat_mul(ctx, a, i2, NAN, &c), BST_EINVAL);
    bst_mat_free(a), bst_mat_free(i2);
}
END_TEST

START_TEST(test_errors)
{
    bst_mat *a, *b, *c = (bst_mat *)1;
    ck_assert_int_eq(bst_mat_new_zero(ctx, 3, 4, &a), BST_OK);
    ck_assert_int_eq(bst_mat_new_zero(ctx, 3, 4, &b), BST_OK);
    ck_assert_int_eq(bst_mat_mul(ctx, a, b, 0.0, &c), BST_ESIZE);
    ck_assert_ptr_null(c);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "3 x 4 times 3 x 4"));
    ck_assert_int_eq(bst_mat_mul(ctx, NULL, b, 0.0, &c), BST_EINVAL);
    ck_assert_int_eq(bst_mat_mul(ctx, a, b, 0.0, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_mat_mul(NULL, a, b, 0.0, &c), BST_EINVAL);
    ck_assert_int_eq(bst_mat_add(ctx, 1, a, 1, NULL, &c), BST_EINVAL);
    bst_mat *d;
    ck_assert_int_eq(bst_mat_new_zero(ctx, 4, 3, &d), BST_OK);
    ck_assert_int_eq(bst_mat_add(ctx, 1, a, 1, d, &c), BST_ESIZE);
    ck_assert_int_eq(bst_mat_add(ctx, INFINITY, a, 1, b, &c), BST_EINVAL);
    ck_assert_int_eq(bst_mat_new_dense(ctx, SIZE_MAX / 2, 4, BST_DOUBLE, &c), BST_ENOMEM);
    ck_assert_int_eq(bst_mat_new_dense(ctx, 2, 2, (bst_precision)7, &c), BST_EINVAL);
    ck_assert_int_eq(bst_mat_new_diag(ctx, 3, NULL, &c), BST_EINVAL);
    size_t ri[] = {5}, ci[] = {0};
    double x[] = {1.0}, nan[] = {NAN};
    ck_assert_int_eq(bst_mat_new_sparse(ctx, 3, 3, 1, ri, ci, x, &c), BST_EINVAL);
    ri[0] = 0;
    ck_assert_int_eq(bst_mat_new_sparse(ctx, 3, 3, 1, ri, ci, nan, &c), BST_EINVAL);
    ck_assert(isnan(bst_mat_get(a, 3, 0)));
    ck_assert(isnan(bst_mat_get(NULL, 0, 0)));
    ck_assert_ptr_null(bst_mat_dense_data(a));
    ck_assert_ptr_null(bst_mat_diag_data(a));
    ck_assert_int_eq(bst_mat_compact(ctx, a, 2.0, &c), BST_EINVAL);
    size_t bad = 9;
    ck_assert_int_eq(bst_mat_select_cols(ctx, a, 1, &bad, &c), BST_EINVAL);
    bst_mat_free(a), bst_mat_free(b), bst_mat_free(d);
    bst_mat_free(NULL);
}
END_TEST

/* Every allocation of an operation may fail: the call reports BST_ENOMEM and leaks nothing. */
typedef int (*op_fn)(bst_ctx *c, bst_mat *a, bst_mat *b, bst_mat **out);
static int op_mul(bst_ctx *c, bst_mat *a, bst_mat *b, bst_mat **o) { return bst_mat_mul(c, a, b, 0, o); }
static int op_add(bst_ctx *c, bst_mat *a, bst_mat *b, bst_mat **o) { return bst_mat_add(c, 1, a, 2, b, o); }
static int op_conv(bst_ctx *c, bst_mat *a, bst_mat *b, bst_mat **o) { (void)b; return bst_mat_convert(c, a, BST_DENSE, BST_FLOAT, o); }
static int op_tr(bst_ctx *c, bst_mat *a, bst_mat *b, bst_mat **o) { (void)b; return bst_mat_transpose(c, a, o); }

START_TEST(test_alloc_failure)
{
    static const op_fn ops[] = {op_mul, op_add, op_conv, op_tr};
    int ka = _i % TM_NKINDS, kb = (_i / TM_NKINDS) % TM_NKINDS;
    bst_ctx *c = bst_ctx_new();
    tu_alloc al = {0};
    ck_assert_int_eq(bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &al), BST_OK);
    tu_rng r;
    tu_rng_seed(&r, 5);
    bst_mat *a = tm_random(c, ka, 9, 9, 1.0, &r), *b = tm_random(c, kb, 9, 9, 1.0, &r);
    for (size_t o = 0; o < sizeof ops / sizeof ops[0]; o++) {
        long base = al.live;
        for (long k = 1;; k++) {
            al.fail_at = al.count + k;
            bst_mat *out = (bst_mat *)1;
            int rc = ops[o](c, a, b, &out);
            if (rc == BST_OK) {
                bst_mat_free(out);
                break;
            }
            ck_assert_int_eq(rc, BST_ENOMEM);
            ck_assert_ptr_null(out);
            ck_assert_str_ne(bst_ctx_message(c), "");
            ck_assert_int_eq(al.live, base);
            ck_assert_int_lt(k, 50);
        }
        ck_assert_int_eq(al.live, base);
    }
    al.fail_at = 0;
    bst_mat_free(a), bst_mat_free(b);
    ck_assert_int_eq(al.live, 0);
    bst_ctx_free(c);
}
END_TEST

static Suite *mat_suite(void)
{
    Suite *s = suite_create("mat");
    TCase *tc = tcase_create("algebra");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    int pairs = TM_NKINDS * TM_NKINDS * (int)NSIZES;
    tcase_add_loop_test(tc, test_mul_all_pairs, 0, pairs);
    tcase_add_loop_test(tc, test_add_all_pairs, 0, pairs);
    tcase_add_loop_test(tc, test_unary, 0, TM_NKINDS * (int)NSIZES);
    tcase_add_loop_test(tc, test_transpose_rect, 0, 8);
    tcase_add_loop_test(tc, test_add_take, 0, TM_NKINDS * TM_NKINDS);
    tcase_add_loop_test(tc, test_spmm_same_bits, 0, 8);
    tcase_add_loop_test(tc, test_dense_passes, 0, 12);
    tcase_add_test(tc, test_spmm_empty_inner);
    tcase_add_test(tc, test_drop_tol);
    tcase_add_test(tc, test_errors);
    tcase_add_loop_test(tc, test_alloc_failure, 0, TM_NKINDS * TM_NKINDS);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(mat_suite());
}
