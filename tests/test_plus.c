/* test_plus.c - PLUS_LR matrices (mat.h, mat_plus.c: base + U W^T), every operation against its
 * dense value formed here with plain loops from the base's values and the factors: reading
 * (elements, columns, column sums, conversions), products and sums with every structure, the
 * recompression to the numerical rank, and the Woodbury solves, left and right, with plain and
 * PLUS_LR right-hand sides, against the dense solve of the same values. */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "mat.h"
#include "testmat.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

#define N 160 /* large enough that a rank of 6 stays PLUS_LR (BSTI_PLUS_DENSE_SHARE) */

/* An operand: base of kind (testmat.h) + U W^T of rank m (0: the plain base), values scaled by
 * scale; *ref its dense values (N x N, column-major, malloc'd). */
static bst_mat *operand(int kind, size_t m, double scale, tu_rng *r, double **ref)
{
    bst_mat *base = tm_random(ctx, kind, N, N, scale, r);
    double *d = tm_dense(ctx, base);
    if (m == 0) {
        *ref = d;
        return base;
    }
    double *u = bsti_alloc_array(ctx, N * m, sizeof *u), *w = bsti_alloc_array(ctx, N * m, sizeof *w);
    for (size_t k = 0; k < N * m; k++)
        u[k] = scale * (2.0 * tu_rng_uniform(r) - 1.0), w[k] = 2.0 * tu_rng_uniform(r) - 1.0;
    for (size_t j = 0; j < N; j++)
        for (size_t i = 0; i < N; i++)
            for (size_t k = 0; k < m; k++)
                d[j * N + i] += u[k * N + i] * w[k * N + j];
    bst_mat *p;
    ck_assert_int_eq(bsti_mat_plus_new(ctx, base, m, u, w, &p), BST_OK);
    ck_assert_int_eq(bst_mat_structure(p), BST_PLUS_LR);
    *ref = d;
    return p;
}

/* max |values of x - ref| / max |ref| */
static double rel_err(const bst_mat *x, const double *ref, size_t rows, size_t cols)
{
    ck_assert_uint_eq(bst_mat_rows(x), rows);
    ck_assert_uint_eq(bst_mat_cols(x), cols);
    double *v = tm_dense(ctx, x), s = tm_maxabs(ref, rows * cols);
    double e = tm_maxdiff(v, ref, rows * cols);
    free(v);
    return s > 0 ? e / s : e;
}

static double tol_of(const bst_mat *a, const bst_mat *b)
{
    int f = (bst_mat_structure(a) == BST_DENSE && bst_mat_precision(a) == BST_FLOAT) ||
            (bst_mat_structure(b) == BST_DENSE && bst_mat_precision(b) == BST_FLOAT) ||
            (bst_mat_structure(a) == BST_PLUS_LR && bst_mat_precision(a) == BST_FLOAT) ||
            (bst_mat_structure(b) == BST_PLUS_LR && bst_mat_precision(b) == BST_FLOAT);
    return f ? 2e-5 : 1e-12;
}

/* Reading one: elements, every column, selected columns, column sums, dense copies, transpose,
 * scaling, the largest value. */
START_TEST(test_values)
{
    tu_rng r;
    tu_rng_seed(&r, 11 + (uint64_t)_i);
    double *ref;
    bst_mat *a = operand(_i % TM_NKINDS, 4, 1.0, &r, &ref);
    double tol = tol_of(a, a);
    for (size_t j = 0; j < N; j += 7)
        for (size_t i = 0; i < N; i += 3)
            ck_assert(fabs(bst_mat_get(a, i, j) - ref[j * N + i]) <= tol * 8);
    ck_assert_double_le(rel_err(a, ref, N, N), tol);
    bst_mat *d, *t, *s, *c;
    ck_assert_int_eq(bst_mat_convert(ctx, a, BST_DENSE, BST_DOUBLE, &d), BST_OK);
    ck_assert_double_le(rel_err(d, ref, N, N), tol);
    ck_assert_int_eq(bst_mat_convert(ctx, a, BST_SPARSE, BST_DOUBLE, &c), BST_OK);
    ck_assert_double_le(rel_err(c, ref, N, N), tol);
    bst_mat_free(c);
    ck_assert_int_eq(bst_mat_convert(ctx, a, BST_DENSE, BST_FLOAT, &c), BST_OK);
    ck_assert_double_le(rel_err(c, ref, N, N), 1e-6);
    bst_mat_free(c);
    ck_assert_int_eq(bst_mat_convert(ctx, a, BST_PLUS_LR, BST_DOUBLE, &c), BST_OK);
    ck_assert_int_eq(bst_mat_structure(c), BST_PLUS_LR);
    ck_assert_double_le(rel_err(c, ref, N, N), tol);
    bst_mat_free(c);
    ck_assert_int_eq(bst_mat_convert(ctx, a, BST_DIAG, BST_DOUBLE, &c), BST_EINVAL);
    /* transpose, copied and in place */
    double *rt = malloc(N * N * sizeof *rt);
    for (size_t j = 0; j < N; j++)
        for (size_t i = 0; i < N; i++)
            rt[i * N + j] = ref[j * N + i];
    ck_assert_int_eq(bst_mat_transpose(ctx, a, &t), BST_OK);
    ck_assert_double_le(rel_err(t, rt, N, N), tol);
    bst_mat *t2;
    ck_assert_int_eq(bsti_mat_transpose_take(ctx, t, &t2), BST_OK);
    ck_assert_double_le(rel_err(t2, ref, N, N), tol);
    bst_mat_free(t2);
    /* diag(dr) A diag(dc) */
    double dr[N], dc[N], w[N], sums[N];
    for (size_t i = 0; i < N; i++)
        dr[i] = 0.5 + tu_rng_uniform(&r), dc[i] = 0.5 + tu_rng_uniform(&r), w[i] = tu_rng_uniform(&r);
    ck_assert_int_eq(bst_mat_scale(ctx, dr, a, dc, &s), BST_OK);
    for (size_t j = 0; j < N; j++)
        for (size_t i = 0; i < N; i++)
            rt[j * N + i] = dr[i] * ref[j * N + i] * dc[j];
    ck_assert_double_le(rel_err(s, rt, N, N), tol * 4);
    bst_mat_free(s);
    /* column sums weighted by w */
    ck_assert_int_eq(bst_mat_col_weighted_sum(ctx, a, w, sums), BST_OK);
    double big = 0;
    for (size_t j = 0; j < N; j++) {
        double e = 0;
        for (size_t i = 0; i < N; i++)
            e += w[i] * ref[j * N + i];
        big = fmax(big, fabs(e));
        ck_assert_msg(fabs(sums[j] - e) <= tol * 4 * N, "column %zu: %g vs %g", j, sums[j], e);
    }
    ck_assert(big > 0);
    /* selected columns, repeated and out of order */
    size_t cols[4] = {N - 1, 0, 77, 77};
    ck_assert_int_eq(bst_mat_select_cols(ctx, a, 4, cols, &c), BST_OK);
    for (size_t k = 0; k < 4; k++)
        memcpy(rt + k * N, ref + cols[k] * N, N * sizeof *rt);
    ck_assert_double_le(rel_err(c, rt, N, 4), tol);
    bst_mat_free(c);
    /* the column reader (bsti_cols: the writer's sums and reciprocity), in blocks by GEMM, and
       a selection of columns; and its visits, a column at a time */
    bsti_cols *rd;
    double *got = malloc(N * N * sizeof *got);
    ck_assert_int_eq(bsti_cols_new(ctx, a, N, &rd), BST_OK);
    bsti_cols_get(rd, NULL, 0, N, got);
    ck_assert_double_le(tm_maxdiff(got, ref, N * N), tol * tm_maxabs(ref, N * N));
    bsti_cols_get(rd, cols, 0, 4, got);
    for (size_t k = 0; k < 4; k++)
        ck_assert_double_le(tm_maxdiff(got + k * N, ref + cols[k] * N, N), tol * tm_maxabs(ref, N * N));
    bsti_cols_free(rd);
    free(got);
    /* the largest |value|, its count of stored values, finiteness */
    ck_assert(fabs(bst_mat_max_abs(a) - tm_maxabs(ref, N * N)) <= tol * tm_maxabs(ref, N * N));
    ck_assert(bst_mat_all_finite(a));
    ck_assert_uint_eq(bsti_mat_rank(a), 4);
    free(rt), free(ref);
    bst_mat_free(d), bst_mat_free(a);
}
END_TEST

/* Products and sums of a PLUS_LR operand with every kind on either side (and of two), against
 * the dense values. */
START_TEST(test_mul_add)
{
    tu_rng r;
    tu_rng_seed(&r, 101 + (uint64_t)_i);
    int ka = _i % TM_NKINDS, kb = (_i / TM_NKINDS) % TM_NKINDS;
    size_t ma = 3, mb = (_i / (TM_NKINDS * TM_NKINDS)) ? 2 : 0; /* b plain or PLUS_LR */
    for (int side = 0; side < 2; side++) {
        double *ra, *rb;
        bst_mat *a = operand(ka, ma, 1.0, &r, &ra), *b = operand(kb, mb, 1.0, &r, &rb);
        const bst_mat *x = side ? b : a, *y = side ? a : b;
        const double *rx = side ? rb : ra, *ry = side ? ra : rb;
        double tol = tol_of(a, b);
        double *p = malloc(N * N * sizeof *p);
        tm_gemm(N, N, N, rx, ry, p);
        bst_mat *c;
        ck_assert_int_eq(bst_mat_mul(ctx, x, y, 0.0, &c), BST_OK);
        ck_assert_msg(rel_err(c, p, N, N) <= tol * N, "%s %s product: %g", tm_kind_name[ka],
                      tm_kind_name[kb], rel_err(c, p, N, N));
        if (ka != TM_ZERO && kb != TM_ZERO) /* the factors' rank at most, recompressed */
            ck_assert_uint_le(bsti_mat_rank(c), ma + mb);
        bst_mat_free(c);
        for (size_t k = 0; k < N * N; k++)
            p[k] = 0.5 * rx[k] - 2.0 * ry[k];
        ck_assert_int_eq(bst_mat_add(ctx, 0.5, x, -2.0, y, &c), BST_OK);
        ck_assert_msg(rel_err(c, p, N, N) <= tol * 4, "%s %s sum: %g", tm_kind_name[ka],
                      tm_kind_name[kb], rel_err(c, p, N, N));
        bst_mat_free(c);
        /* a sum taking its first term: a dense one (in the sum's precision) is the result, with
           the bits of the plain sum, also where the other term is PLUS_LR (its base added, then
           its low-rank part) */
        bst_mat *xc, *plain;
        ck_assert_int_eq(bst_mat_convert(ctx, x, bst_mat_structure(x), bst_mat_precision(x), &xc), BST_OK);
        for (size_t k = 0; k < N * N; k++)
            p[k] = rx[k] + ry[k];
        ck_assert_int_eq(bst_mat_add(ctx, 1.0, x, 1.0, y, &plain), BST_OK);
        const bst_mat *yb = bst_mat_structure(y) == BST_PLUS_LR ? y->plus->base : y;
        int in_place = bst_mat_structure(xc) == BST_DENSE && bst_mat_structure(yb) != BST_FACTORED &&
                       (bst_mat_precision(xc) == BST_FLOAT ||
                        !(bst_mat_structure(yb) == BST_DENSE && bst_mat_precision(yb) == BST_FLOAT));
        const bst_mat *before = xc;
        ck_assert_int_eq(bsti_mat_add_take(ctx, xc, y, &c), BST_OK);
        ck_assert_double_le(rel_err(c, p, N, N), tol * 4);
        if (in_place) {
            ck_assert_msg(c == before, "%s + %s: the dense term's storage not taken",
                          tm_kind_name[side ? kb : ka], tm_kind_name[side ? ka : kb]);
            ck_assert_int_eq(bst_mat_structure(plain), BST_DENSE);
            ck_assert_int_eq(bst_mat_precision(plain), bst_mat_precision(c));
            size_t es = bst_mat_precision(c) == BST_FLOAT ? sizeof(float) : sizeof(double);
            ck_assert_msg(memcmp(bst_mat_dense_data(c), bst_mat_dense_data(plain), N * N * es) == 0,
                          "%s + %s taken: not the bits of the plain sum",
                          tm_kind_name[side ? kb : ka], tm_kind_name[side ? ka : kb]);
        }
        bst_mat_free(plain);
        bst_mat_free(c);
        free(p), free(ra), free(rb);
        bst_mat_free(a), bst_mat_free(b);
    }
}
END_TEST

/* The rank is the numerical one after each operation: A + A keeps A's, A - A is the base's
 * difference alone (plain), a product by a diagonal keeps it; a rank too large for the form is
 * dense. */
START_TEST(test_rank)
{
    tu_rng r;
    tu_rng_seed(&r, 7);
    double *ra;
    bst_mat *a = operand(TM_SPARSE, 5, 1.0, &r, &ra), *c;
    ck_assert_int_eq(bst_mat_add(ctx, 1.0, a, 1.0, a, &c), BST_OK);
    ck_assert_int_eq(bst_mat_structure(c), BST_PLUS_LR);
    ck_assert_uint_eq(bsti_mat_rank(c), 5);
    bst_mat_free(c);
    ck_assert_int_eq(bst_mat_add(ctx, 1.0, a, -1.0, a, &c), BST_OK);
    ck_assert_int_eq(bst_mat_structure(c), BST_SPARSE);
    bst_mat_free(c);
    double *ra2;
    bst_mat *d = operand(TM_DIAG, 0, 1.0, &r, &ra2);
    ck_assert_int_eq(bst_mat_mul(ctx, d, a, 0.0, &c), BST_OK);
    ck_assert_uint_eq(bsti_mat_rank(c), 5);
    bst_mat_free(c);
    double *rw;
    bst_mat *wide = operand(TM_SPARSE, 20, 1.0, &r, &rw), *s; /* 25 (2 N) >= N^2 / 4: dense */
    ck_assert_int_eq(bst_mat_add(ctx, 1.0, a, 1.0, wide, &s), BST_OK);
    ck_assert_int_eq(bst_mat_structure(s), BST_DENSE);
    for (size_t k = 0; k < N * N; k++)
        rw[k] += ra[k];
    ck_assert_double_le(rel_err(s, rw, N, N), 1e-12);
    bst_mat_free(s), bst_mat_free(wide), bst_mat_free(d), bst_mat_free(a);
    free(ra), free(ra2), free(rw);
}
END_TEST

/* (I - A)^-1 B and B (I - A)^-1 for A = base + U W^T (spectral radius below 1) and B plain or
 * PLUS_LR, against the dense solve of the same values (test_solve checks that one against closed
 * forms); two right-hand sides with one factorization, taken operands, and a factorization asked
 * to be kept (not kept: NULL). */
START_TEST(test_solve)
{
    tu_rng r;
    tu_rng_seed(&r, 301 + (uint64_t)_i);
    int ka = _i % 4 + 1; /* DIAG, SPARSE, DENSE, FLOAT bases */
    int right = (_i / 4) % 2, kb = (_i / 8) % 2 ? TM_DENSE : TM_SPARSE;
    double *ra, *rb, *rc2;
    bst_mat *a = operand(ka, 4, 0.5 / N, &r, &ra);
    bst_mat *b = operand(kb, 3, 1.0, &r, &rb), *b2 = operand(TM_SPARSE, 0, 1.0, &r, &rc2);
    bst_mat *ad, *bd, *b2d, *x, *xd, *x2, *x2d;
    ck_assert_int_eq(bst_mat_new_dense(ctx, N, N, BST_DOUBLE, &ad), BST_OK);
    ck_assert_int_eq(bst_mat_new_dense(ctx, N, N, BST_DOUBLE, &bd), BST_OK);
    ck_assert_int_eq(bst_mat_new_dense(ctx, N, N, BST_DOUBLE, &b2d), BST_OK);
    memcpy(bst_mat_dense_data(ad), ra, N * N * sizeof(double));
    memcpy(bst_mat_dense_data(bd), rb, N * N * sizeof(double));
    memcpy(bst_mat_dense_data(b2d), rc2, N * N * sizeof(double));
    double tol = ka == TM_FLOAT ? 1e-5 : 1e-11, rcond = 0;
    int (*solve)(bst_ctx *, const bst_mat *, const bst_mat *, double, bst_mat **, double *) =
        right ? bst_solve_right : bst_solve_left;
    ck_assert_int_eq(solve(ctx, a, b, 0.0, &x, &rcond), BST_OK);
    ck_assert(rcond > 0 && rcond <= 1);
    ck_assert_int_eq(solve(ctx, ad, bd, 0.0, &xd, NULL), BST_OK);
    double *rx = tm_dense(ctx, xd);
    ck_assert_msg(rel_err(x, rx, N, N) <= tol, "%s %s: %g", tm_kind_name[ka], right ? "right" : "left",
                  rel_err(x, rx, N, N));
    /* and its residual, formed here: (I - A) X - B, or X (I - A) - B */
    double *xv = tm_dense(ctx, x), *ax = malloc(N * N * sizeof *ax);
    if (right)
        tm_gemm(N, N, N, xv, ra, ax);
    else
        tm_gemm(N, N, N, ra, xv, ax);
    double res = 0, big = tm_maxabs(rb, N * N);
    for (size_t k = 0; k < N * N; k++)
        res = fmax(res, fabs(xv[k] - ax[k] - rb[k]));
    ck_assert_msg(res <= tol * big, "%s %s residual: %g", tm_kind_name[ka], right ? "right" : "left",
                  res / big);
    free(xv), free(ax);
    /* sparse bases keep the form; a dense one takes the low-rank part into its values
       (bsti_plus_settle) */
    if (ka == TM_DIAG && kb == TM_SPARSE) /* (a random sparse E^-1 fills) */
        ck_assert_int_eq(bst_mat_structure(x), BST_PLUS_LR);
    if (bst_mat_structure(x) == BST_PLUS_LR)
        ck_assert_int_ne(bst_mat_structure(x->plus->base), BST_DENSE);
    ck_assert_uint_le(bsti_mat_rank(x), 7);
    bst_mat_free(x);
    /* a plain A, a PLUS_LR B */
    ck_assert_int_eq(solve(ctx, bst_mat_structure(a) == BST_PLUS_LR ? a->plus->base : a, b, 0.0, &x,
                           NULL), BST_OK);
    bst_mat *a0d, *x0d;
    ck_assert_int_eq(bst_mat_convert(ctx, a->plus->base, BST_DENSE, BST_DOUBLE, &a0d), BST_OK);
    ck_assert_int_eq(solve(ctx, a0d, bd, 0.0, &x0d, NULL), BST_OK);
    double *r0 = tm_dense(ctx, x0d);
    ck_assert_double_le(rel_err(x, r0, N, N), tol);
    bst_mat_free(x);
    /* the same with both taken (a plain A passes on to the bases' solve) */
    bst_mat *a0c, *bc0;
    ck_assert_int_eq(bst_mat_convert(ctx, a->plus->base, a->plus->base->s, a->plus->base->prec, &a0c),
                     BST_OK);
    ck_assert_int_eq(bsti_plus_copy(ctx, b, &bc0), BST_OK);
    ck_assert_int_eq(bsti_solve_take(ctx, right, a0c, bc0, bc0, 0.0, BST_DOUBLE, &x, NULL, NULL),
                     BST_OK);
    ck_assert_double_le(rel_err(x, r0, N, N), tol);
    bst_mat_free(x), bst_mat_free(a0d), bst_mat_free(x0d);
    free(r0);
    if (!right) { /* two right-hand sides, both taken, A taken, a kept factorization asked */
        bst_mat *ac, *bc, *b2c;
        bsti_factor *keep = (bsti_factor *)&keep;
        ck_assert_int_eq(bsti_plus_copy(ctx, a, &ac), BST_OK);
        ck_assert_int_eq(bsti_plus_copy(ctx, b, &bc), BST_OK);
        ck_assert_int_eq(bst_mat_convert(ctx, b2, BST_SPARSE, BST_DOUBLE, &b2c), BST_OK);
        ck_assert_int_eq(bsti_solve_take_left2(ctx, ac, bc, bc, b2c, b2c, 0.0, BST_DOUBLE, &x, &x2,
                                               &rcond, &keep), BST_OK);
        ck_assert_ptr_null(keep);
        ck_assert_int_eq(bst_solve_left(ctx, ad, b2d, 0.0, &x2d, NULL), BST_OK);
        double *r2 = tm_dense(ctx, x2d);
        ck_assert_double_le(rel_err(x, rx, N, N), tol);
        ck_assert_double_le(rel_err(x2, r2, N, N), tol);
        free(r2);
        bst_mat_free(x), bst_mat_free(x2), bst_mat_free(x2d);
    } else { /* taken, right */
        bst_mat *ac, *bc;
        ck_assert_int_eq(bsti_plus_copy(ctx, a, &ac), BST_OK);
        ck_assert_int_eq(bsti_plus_copy(ctx, b, &bc), BST_OK);
        ck_assert_int_eq(bsti_solve_take(ctx, 1, ac, bc, bc, 0.0, BST_DOUBLE, &x, &rcond, NULL), BST_OK);
        ck_assert_double_le(rel_err(x, rx, N, N), tol);
        bst_mat_free(x);
    }
    free(ra), free(rb), free(rc2), free(rx);
    bst_mat_free(a), bst_mat_free(b), bst_mat_free(b2);
    bst_mat_free(ad), bst_mat_free(bd), bst_mat_free(b2d), bst_mat_free(xd);
}
END_TEST

/* I - A singular through its low-rank part alone (A = U W^T with W^T U = I on a direction):
 * an error naming the capacitance, no result. */
START_TEST(test_singular)
{
    double *u = bsti_alloc_array(ctx, N, sizeof *u), *w = bsti_alloc_array(ctx, N, sizeof *w);
    for (size_t i = 0; i < N; i++)
        u[i] = 1.0, w[i] = i == 0 ? 1.0 : 0.0; /* A e_0 ... A = u e_0^T: (I - A) e_0 = 0 */
    bst_mat *z, *a, *b, *x = NULL;
    ck_assert_int_eq(bst_mat_new_zero(ctx, N, N, &z), BST_OK);
    ck_assert_int_eq(bsti_mat_plus_new(ctx, z, 1, u, w, &a), BST_OK);
    double one[N];
    for (size_t i = 0; i < N; i++)
        one[i] = 1.0;
    ck_assert_int_eq(bst_mat_new_diag(ctx, N, one, &b), BST_OK);
    ck_assert_int_eq(bst_solve_left(ctx, a, b, 0.0, &x, NULL), BST_ESINGULAR);
    ck_assert_ptr_null(x);
    ck_assert(strstr(bst_ctx_message(ctx), "low-rank") != NULL);
    bst_mat_free(a), bst_mat_free(b);
}
END_TEST

/* Every allocation of each operation failed in turn (a diagonal base: all of its memory through
 * the context's allocator): BST_ENOMEM, no result, nothing leaked; then it succeeds. */
START_TEST(test_nomem)
{
    bst_ctx *c = bst_ctx_new(), *save = ctx;
    tu_alloc al = {0};
    ck_assert_int_eq(bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &al), BST_OK);
    ctx = c;
    tu_rng r;
    tu_rng_seed(&r, 5);
    double *ra, *rb, *rd, dr[N];
    bst_mat *a = operand(TM_DIAG, 3, 0.5 / N, &r, &ra), *b = operand(TM_DIAG, 2, 1.0, &r, &rb);
    bst_mat *d = operand(TM_DIAG, 0, 1.0, &r, &rd);
    for (size_t i = 0; i < N; i++)
        dr[i] = 0.5 + tu_rng_uniform(&r);
    for (int op = 0; op < 9; op++) {
        long base = al.live;
        for (long k = 1;; k++) {
            al.fail_at = al.count + k;
            bst_mat *m = (bst_mat *)1, *m2 = (bst_mat *)1, *ac = NULL, *bc = NULL;
            int rc = op == 0   ? bst_mat_mul(c, a, b, 0.0, &m)
                     : op == 1 ? bst_mat_mul(c, d, a, 0.0, &m)
                     : op == 2 ? bst_mat_add(c, 1.0, a, 2.0, b, &m)
                     : op == 3 ? bst_mat_scale(c, dr, a, dr, &m)
                     : op == 4 ? bst_mat_transpose(c, a, &m)
                     : op == 5 ? bst_mat_convert(c, a, BST_DENSE, BST_FLOAT, &m)
                     : op == 6 ? bst_solve_left(c, a, b, 0.0, &m, NULL)
                     : op == 7 ? bst_solve_right(c, a, b, 0.0, &m, NULL)
                               : BST_OK;
            if (op == 8) { /* taken operands, two right-hand sides */
                rc = bsti_plus_copy(c, a, &ac);
                if (rc >= 0 && (rc = bsti_plus_copy(c, b, &bc)) < 0)
                    bst_mat_free(ac);
                if (rc >= 0)
                    rc = bsti_solve_take_left2(c, ac, bc, bc, d, NULL, 0.0, BST_DOUBLE, &m, &m2,
                                               NULL, NULL);
                else
                    m = m2 = NULL;
            }
            al.fail_at = 0;
            if (rc == BST_OK) {
                bst_mat_free(m);
                if (op == 8)
                    bst_mat_free(m2);
                break;
            }
            ck_assert_int_eq(rc, BST_ENOMEM);
            ck_assert_ptr_null(m);
            ck_assert_int_eq(al.live, base);
            ck_assert_int_lt(k, 400);
        }
    }
    bst_mat_free(a), bst_mat_free(b), bst_mat_free(d);
    free(ra), free(rb), free(rd);
    ctx = save;
    bst_ctx_free(c);
}
END_TEST

static Suite *plus_suite(void)
{
    Suite *s = suite_create("plus");
    TCase *tc = tcase_create("plus");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_loop_test(tc, test_values, 0, TM_NKINDS);
    tcase_add_loop_test(tc, test_mul_add, 0, 2 * TM_NKINDS * TM_NKINDS);
    tcase_add_test(tc, test_rank);
    tcase_add_loop_test(tc, test_solve, 0, 16);
    tcase_add_test(tc, test_singular);
    tcase_add_test(tc, test_nomem);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return tu_run(plus_suite()); }
