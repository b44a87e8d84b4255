/* test_mirror.c - the mirror split of dense solves (mirror.h, solve.c): the kernels (which
 * matrices have the symmetry, the split and join as exact inverses), the solves of mirror-
 * symmetric I - A against the same solves unsplit and against plain dense residuals, both sides,
 * a sparse A made dense as its halves at once,
 * both precisions, every kind of right-hand side, both mirrors (y's through the turned square), a
 * kept factorization, a singular half; products with an inverse kept in halves (mirror_mul.c)
 * against the whole's; and
 * the stacks: a venetian blind's layer commutes with its mirror (a physical symmetry: its model
 * sampled a patch and its image at unrelated points until session 53), and a pane + blind + pane
 * split gives what the unsplit baseline (--dense) gives, Z's products by the halves (stack.c's
 * solve2_z) among them. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "mat.h"
#include "mirror.h"
#include "testmat.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

/* S of side g: (ix, iy) -> (g - 1 - ix, iy), index ix g + iy; the y mirror (ix, g - 1 - iy). */
static size_t mir(size_t g, size_t p) { return (g - 1 - p / g) * g + p % g; }
static size_t mir_y(size_t g, size_t p) { return p / g * g + g - 1 - p % g; }

/* A random n x n (n = g^2) column-major matrix commuting with S (axis 0) or the y mirror (axis 1):
 * (M + S M S) / 2, scaled to |M|_1 = norm. */
static double *symmetric_about(size_t g, int axis, double norm, tu_rng *r)
{
    size_t (*im)(size_t, size_t) = axis ? mir_y : mir;
    size_t n = g * g;
    double *m = malloc(n * n * sizeof *m), *s = malloc(n * n * sizeof *s);
    for (size_t i = 0; i < n * n; i++)
        m[i] = tu_rng_uniform(r) - 0.5;
    for (size_t q = 0; q < n; q++)
        for (size_t p = 0; p < n; p++)
            s[q * n + p] = 0.5 * (m[q * n + p] + m[im(g, q) * n + im(g, p)]);
    double big = 0.0;
    for (size_t q = 0; q < n; q++) {
        double c = 0.0;
        for (size_t p = 0; p < n; p++)
            c += fabs(s[q * n + p]);
        big = fmax(big, c);
    }
    for (size_t i = 0; i < n * n; i++)
        s[i] *= norm / big;
    free(m);
    return s;
}
static double *symmetric(size_t g, double norm, tu_rng *r) { return symmetric_about(g, 0, norm, r); }

static bst_mat *dense_of(const double *v, size_t rows, size_t cols, bst_precision prec)
{
    bst_mat *m;
    ck_assert_int_eq(bst_mat_new_dense(ctx, rows, cols, prec, &m), BST_OK);
    for (size_t i = 0; i < rows * cols; i++)
        if (prec == BST_DOUBLE)
            ((double *)bst_mat_dense_data(m))[i] = v[i];
        else
            ((float *)bst_mat_dense_data(m))[i] = (float)v[i];
    return m;
}

START_TEST(test_side)
{
    ck_assert_uint_eq(bsti_mirror_side(256), 16);
    ck_assert_uint_eq(bsti_mirror_side(1024), 32);
    ck_assert_uint_eq(bsti_mirror_side(16384), 128);
    ck_assert_uint_eq(bsti_mirror_side(64), 0);  /* below BSTI_MIRROR_MIN_N */
    ck_assert_uint_eq(bsti_mirror_side(145), 0); /* Klems */
    ck_assert_uint_eq(bsti_mirror_side(512), 0); /* not a square */
    ck_assert_uint_eq(bsti_mirror_side(400), 0); /* a square of a side that is not 2^k */
}
END_TEST

/* holds: the symmetric matrix yes, one value off by more than the tolerance no, by less yes;
 * the split and the join undo each other; the rows' too. */
START_TEST(test_kernels)
{
    tu_rng r;
    tu_rng_seed(&r, 53);
    size_t g = 16, n = g * g;
    double *a = symmetric(g, 0.9, &r), *b = malloc(n * n * sizeof *b);
    float *af = malloc(n * n * sizeof *af);
    double big = tm_maxabs(a, n * n);
    ck_assert(bsti_mirror_holds(a, BST_DOUBLE, n, g, 0));
    memcpy(b, a, n * n * sizeof *b);
    b[7 * n + 200] += 1e-10 * big;
    ck_assert(!bsti_mirror_holds(b, BST_DOUBLE, n, g, 0));
    b[7 * n + 200] = a[7 * n + 200] + 1e-13 * big;
    ck_assert(bsti_mirror_holds(b, BST_DOUBLE, n, g, 0));
    b[7 * n + 200] = NAN;
    ck_assert(!bsti_mirror_holds(b, BST_DOUBLE, n, g, 0));
    for (size_t i = 0; i < n * n; i++)
        af[i] = (float)a[i];
    ck_assert(bsti_mirror_holds(af, BST_FLOAT, n, g, 0));
    af[3] += (float)(1e-4 * big);
    ck_assert(!bsti_mirror_holds(af, BST_FLOAT, n, g, 0));
    /* the y mirror: held about its own axis, not S's; turned over the diagonal (its own inverse),
       S's */
    double *ay = symmetric_about(g, 1, 0.9, &r);
    ck_assert(bsti_mirror_holds(ay, BST_DOUBLE, n, g, 1));
    ck_assert(!bsti_mirror_holds(ay, BST_DOUBLE, n, g, 0));
    memcpy(b, ay, n * n * sizeof *b);
    bsti_mirror_turn(b, BST_DOUBLE, n, g, n, 1);
    ck_assert(bsti_mirror_holds(b, BST_DOUBLE, n, g, 0));
    ck_assert_double_eq(b[(3 * g + 5) * n + 7 * g + 2], ay[(5 * g + 3) * n + 2 * g + 7]);
    bsti_mirror_turn(b, BST_DOUBLE, n, g, n, 1);
    ck_assert(memcmp(b, ay, n * n * sizeof *b) == 0);
    free(ay);
    /* a matrix commuting with the other mirror (y) only */
    for (size_t q = 0; q < n; q++)
        for (size_t p = 0; p < n; p++) {
            size_t py = p / g * g + g - 1 - p % g, qy = q / g * g + g - 1 - q % g;
            b[q * n + p] = a[q * n + p] + a[qy * n + py] + (double)(p % 5) * (double)(q % 3);
        }
    ck_assert(!bsti_mirror_holds(b, BST_DOUBLE, n, g, 0));

    memcpy(b, a, n * n * sizeof *b);
    bsti_mirror_matrix(b, BST_DOUBLE, n, g, 1);
    /* P = A + B, M = A - B of the pair ordering */
    tu_assert_close(b[5 * n + 9], a[5 * n + 9] + a[mir(g, 5) * n + 9], 1e-15, big);
    tu_assert_close(b[mir(g, 5) * n + mir(g, 9)], a[5 * n + 9] - a[mir(g, 5) * n + 9], 1e-15, big);
    bsti_mirror_matrix(b, BST_DOUBLE, n, g, 0);
    ck_assert_double_le(tm_maxdiff(a, b, n * n), 4 * DBL_EPSILON * big);

    double *x = malloc(3 * n * sizeof *x), *y = malloc(3 * n * sizeof *y);
    for (size_t i = 0; i < 3 * n; i++)
        x[i] = tu_rng_uniform(&r);
    memcpy(y, x, 3 * n * sizeof *y);
    bsti_mirror_rows(y, BST_DOUBLE, n, g, 3, 1);
    tu_assert_close(y[n + 17], x[n + 17] + x[n + mir(g, 17)], 1e-15, 1.0);
    tu_assert_close(y[n + mir(g, 17)], x[n + 17] - x[n + mir(g, 17)], 1e-15, 1.0);
    bsti_mirror_rows(y, BST_DOUBLE, n, g, 3, 0);
    ck_assert_double_le(tm_maxdiff(x, y, 3 * n), 4 * DBL_EPSILON);
    free(a), free(b), free(af), free(x), free(y);
}
END_TEST

/* A right-hand side of kind k (0 dense, 1 sparse, 2 diagonal, 3 thin dense), n rows. */
static bst_mat *rhs(int k, size_t n, bst_precision prec, tu_rng *r)
{
    if (k == 1)
        return tm_random(ctx, TM_SPARSE, n, n, 1.0, r);
    if (k == 2)
        return tm_random(ctx, TM_DIAG, n, n, 1.0, r);
    size_t c = k == 3 ? 5 : n;
    double *v = malloc(n * c * sizeof *v);
    for (size_t i = 0; i < n * c; i++)
        v[i] = tu_rng_uniform(r) - 0.5;
    bst_mat *m = dense_of(v, n, c, prec);
    free(v);
    return m;
}

/* A split solve x[0] against the unsplit x[1] of the same I - A (A's values av, n x n) and B:
 * their condition estimates within a factor 6 (the halves' bound within a factor 2 of the whole
 * inverse's norm, mirror.h, and gecon's within 3), the solutions to 1e-13 (double) or 2e-5
 * (single) of the largest, and the residual (I - A) X - B (left) or Y (I - A) - B (right). */
static void check_split_solve(int right, bst_precision prec, size_t n, const double *av,
                              const bst_mat *b, bst_mat *const *x, const double *rcond)
{
    ck_assert_double_ge(rcond[0], rcond[1] / 6);
    ck_assert_double_le(rcond[0], rcond[1] * 6);
    size_t rows = bst_mat_rows(x[0]), cols = bst_mat_cols(x[0]);
    double *x0 = tm_dense(ctx, x[0]), *x1 = tm_dense(ctx, x[1]), *bv = tm_dense(ctx, b);
    double scale = tm_maxabs(x1, rows * cols), tol = prec == BST_DOUBLE ? 1e-13 : 2e-5;
    ck_assert_msg(tm_maxdiff(x0, x1, rows * cols) <= tol * scale, "split %g from unsplit",
                  tm_maxdiff(x0, x1, rows * cols) / scale);
    double *e = malloc(n * n * sizeof *e), *res = malloc(rows * cols * sizeof *res);
    for (size_t i = 0; i < n * n; i++)
        e[i] = (i % (n + 1) == 0) - av[i];
    if (right)
        tm_gemm(rows, n, n, x0, e, res);
    else
        tm_gemm(n, n, cols, e, x0, res);
    ck_assert_double_le(tm_maxdiff(res, bv, rows * cols), tol * scale);
    free(x0), free(x1), free(bv), free(e), free(res);
}

/* _i: side (right), precision, kind of B, mirror (x, y).  The split solve against the unsplit one and against
 * the residual of plain dense arithmetic. */
START_TEST(test_solves)
{
    int right = _i & 1, k = (_i >> 2) & 3, axis = _i >> 4;
    bst_precision prec = _i & 2 ? BST_FLOAT : BST_DOUBLE;
    tu_rng r;
    tu_rng_seed(&r, 100 + (uint64_t)_i);
    size_t g = 16, n = g * g;
    double *av = symmetric_about(g, axis, 0.9, &r);
    bst_mat *a = dense_of(av, n, n, BST_DOUBLE), *b = rhs(k, n, prec, &r);
    if (right && k == 3) { /* a thin right-hand side of a right solve: 5 x n */
        bst_mat *bt;
        ck_assert_int_eq(bst_mat_transpose(ctx, b, &bt), BST_OK);
        bst_mat_free(b);
        b = bt;
    }
    bst_mat *x[2];
    double rcond[2], splits[2];
    for (int no = 0; no < 2; no++) {
        ctx->no_mirror = no;
        double s0 = ctx->mirror_splits;
        bst_mat *acopy;
        ck_assert_int_eq(bst_mat_convert(ctx, a, BST_DENSE, prec, &acopy), BST_OK);
        int rc = bsti_solve_take(ctx, right, acopy, b, NULL, 0.0, prec, &x[no], &rcond[no], NULL);
        ck_assert_msg(rc == BST_OK, "%s", bst_ctx_message(ctx));
        splits[no] = ctx->mirror_splits - s0;
    }
    ck_assert_double_eq(splits[0], 1.0);
    ck_assert_double_eq(splits[1], 0.0);
    check_split_solve(right, prec, n, av, b, x, rcond);
    free(av);
    bst_mat_free(x[0]), bst_mat_free(x[1]), bst_mat_free(a), bst_mat_free(b);
}
END_TEST

/* A sparse A whose LU would fill (factor_sparse's BSTI_USE_DENSE): I - A made dense as its halves
 * straight from the sparse values (bsti_mirror_split_sparse), _i: side (right), precision, mirror
 * (x, y), and whether one value is moved off the symmetry (then solved whole).  Against the
 * unsplit solve of the same A made dense, and the residual of plain dense arithmetic. */
START_TEST(test_sparse_split)
{
    int right = _i & 1, axis = (_i >> 2) & 1, off = _i >> 3;
    bst_precision prec = _i & 2 ? BST_FLOAT : BST_DOUBLE;
    tu_rng r;
    tu_rng_seed(&r, 300 + (uint64_t)_i);
    size_t g = 16, n = g * g;
    double *av = symmetric_about(g, axis, 0.9, &r);
    for (size_t i = 0; i < n * n; i++) /* about 40 % of the values kept: images alike */
        if (fabs(av[i]) < 0.3 * 0.9 / (0.25 * (double)n))
            av[i] = 0.0;
    size_t (*im)(size_t, size_t) = axis ? mir_y : mir;
    av[7 * n + 7] = av[im(g, 7) * n + im(g, 7)] = 0.0; /* a diagonal value missing */
    av[3 * n + 7] = av[im(g, 3) * n + im(g, 7)] = 0.0;
    if (off)
        av[5 * n + 9] += 1e-3;
    bst_mat *a = dense_of(av, n, n, BST_DOUBLE), *b = rhs(0, n, prec, &r), *x[2];
    double rcond[2], splits[2];
    for (int no = 0; no < 2; no++) {
        ctx->no_mirror = no;
        double s0 = ctx->mirror_splits;
        bst_mat *acopy;
        ck_assert_int_eq(bst_mat_convert(ctx, a, no ? BST_DENSE : BST_SPARSE,
                                         no ? prec : BST_DOUBLE, &acopy), BST_OK);
        int rc = bsti_solve_take(ctx, right, acopy, b, NULL, 0.0, prec, &x[no], &rcond[no], NULL);
        ck_assert_msg(rc == BST_OK, "%s", bst_ctx_message(ctx));
        splits[no] = ctx->mirror_splits - s0;
    }
    ck_assert_double_eq(splits[0], off ? 0.0 : 1.0);
    ck_assert_double_eq(splits[1], 0.0);
    check_split_solve(right, prec, n, av, b, x, rcond);
    free(av);
    bst_mat_free(x[0]), bst_mat_free(x[1]), bst_mat_free(a), bst_mat_free(b);
}
END_TEST

/* bsti_mirror_split_sparse's clearing on threads: into storage full of other values (1e30 and
 * -7), one thread and three write the same halves to the bit and leave the other quarters as they
 * were; _i: precision, mirror (x, y). */
START_TEST(test_split_threads)
{
    bst_precision prec = _i & 1 ? BST_FLOAT : BST_DOUBLE;
    int axis = _i >> 1;
    tu_rng r;
    tu_rng_seed(&r, 900 + (uint64_t)_i);
    size_t g = 16, n = g * g, h = n / 2, es = prec == BST_DOUBLE ? sizeof(double) : sizeof(float);
    double *av = symmetric_about(g, axis, 0.9, &r);
    for (size_t i = 0; i < n * n; i++)
        if (fabs(av[i]) < 0.3 * 0.9 / (0.25 * (double)n))
            av[i] = 0.0;
    bst_mat *a = dense_of(av, n, n, BST_DOUBLE), *as;
    ck_assert_int_eq(bst_mat_convert(ctx, a, BST_SPARSE, BST_DOUBLE, &as), BST_OK);
    char *lu[2];
    const double fill[2] = {1e30, -7.0};
    int turned[2];
    for (int t = 0; t < 2; t++) {
        lu[t] = malloc(n * n * es);
        for (size_t q = 0; q < n * n; q++) {
            if (prec == BST_DOUBLE)
                ((double *)lu[t])[q] = fill[t];
            else
                ((float *)lu[t])[q] = (float)fill[t];
        }
        ck_assert_int_eq(bst_ctx_set_threads(ctx, t ? 3 : 1), BST_OK);
        ck_assert_int_eq(bsti_mirror_split_sparse(ctx, as->sp, prec, g, lu[t],
                                                  &turned[t]), BST_OK);
    }
    ck_assert_int_eq(turned[0], axis);
    ck_assert_int_eq(turned[1], axis);
    for (size_t j = 0; j < n; j++)
        for (size_t i = 0; i < n; i++) {
            size_t q = (j * n + i) * es;
            int half = (i < h) == (j < h); /* top-left or bottom-right */
            if (half) {
                ck_assert_msg(memcmp(lu[0] + q, lu[1] + q, es) == 0, "(%zu, %zu) differs", i, j);
            } else {
                double v0 = prec == BST_DOUBLE ? ((double *)lu[0])[q / es] : ((float *)lu[0])[q / es];
                double v1 = prec == BST_DOUBLE ? ((double *)lu[1])[q / es] : ((float *)lu[1])[q / es];
                ck_assert(v0 == (double)(prec == BST_DOUBLE ? fill[0] : (float)fill[0]));
                ck_assert(v1 == fill[1]);
            }
        }
    free(lu[0]), free(lu[1]), free(av);
    bst_mat_free(a), bst_mat_free(as);
}
END_TEST

/* Products with an inverse kept in halves (mirror_mul.c), _i: side (right), precision, kind of B
 * (0 sparse, 1 diagonal, 2 thin dense), mirror (x, y): against X B (or B X) of the whole X in
 * plain dense arithmetic; a sparse B one value off its symmetry is left to the whole
 * (BSTI_MIRROR_ASYM, nothing made). */
START_TEST(test_halves_product)
{
    int right = _i & 1, k = (_i >> 2) % 3, axis = _i / 12;
    bst_precision prec = _i & 2 ? BST_FLOAT : BST_DOUBLE;
    size_t (*im)(size_t, size_t) = axis ? mir_y : mir;
    tu_rng r;
    tu_rng_seed(&r, 300 + (uint64_t)_i);
    size_t g = 16, n = g * g, m = 5;
    double *xv = symmetric_about(g, axis, 3.0, &r);
    bst_mat *inv = dense_of(xv, n, n, prec), *b;
    void *iv = bst_mat_dense_data(inv);
    if (axis)
        bsti_mirror_turn(iv, prec, n, g, n, 1);
    bsti_mirror_matrix(iv, prec, n, g, 1);
    size_t br = n, bc = n;
    double *bv;
    if (k == 0) { /* sparse: a symmetric matrix, a fifth of its pairs of values kept */
        bv = symmetric_about(g, axis, 1.0, &r);
        for (size_t q = 0; q < n; q++)
            for (size_t p = 0; p < n; p++) {
                size_t cp = p < im(g, p) ? p : im(g, p), cq = p < im(g, p) ? q : im(g, q);
                if ((cp * 7919 + cq * 104729) % 5)
                    bv[q * n + p] = 0.0;
            }
        bst_mat *d = dense_of(bv, n, n, BST_DOUBLE);
        ck_assert_int_eq(bst_mat_convert(ctx, d, BST_SPARSE, BST_DOUBLE, &b), BST_OK);
        bst_mat_free(d);
    } else if (k == 1) {
        double *dg = malloc(n * sizeof *dg);
        for (size_t p = 0; p < n; p++)
            dg[p] = 0.1 + (double)(p < im(g, p) ? p : im(g, p)) / (double)n;
        ck_assert_int_eq(bst_mat_new_diag(ctx, n, dg, &b), BST_OK);
        bv = calloc(n * n, sizeof *bv);
        for (size_t p = 0; p < n; p++)
            bv[p * n + p] = dg[p];
        free(dg);
    } else {
        br = right ? m : n, bc = right ? n : m;
        bv = malloc(n * m * sizeof *bv);
        for (size_t i = 0; i < n * m; i++)
            bv[i] = tu_rng_uniform(&r) - 0.5;
        b = dense_of(bv, br, bc, BST_DOUBLE);
    }
    bst_mat *out = NULL;
    int rc = bsti_mirror_mul(ctx, iv, prec, n, g, axis, right, b, &out);
    ck_assert_msg(rc == BST_OK, "%d %s", rc, bst_ctx_message(ctx));
    size_t rows = right ? br : n, cols = right ? n : bc;
    ck_assert_uint_eq(bst_mat_rows(out), rows);
    ck_assert_uint_eq(bst_mat_cols(out), cols);
    double *want = malloc(rows * cols * sizeof *want), *got = tm_dense(ctx, out);
    if (prec == BST_FLOAT) /* X as it was stored */
        for (size_t i = 0; i < n * n; i++)
            xv[i] = (float)xv[i];
    if (right)
        tm_gemm(br, n, n, bv, xv, want);
    else
        tm_gemm(n, n, bc, xv, bv, want);
    double big = tm_maxabs(want, rows * cols), tol = prec == BST_DOUBLE ? 1e-13 : 1e-5;
    ck_assert_msg(tm_maxdiff(got, want, rows * cols) <= tol * big, "%g of %g",
                  tm_maxdiff(got, want, rows * cols), big);
    bst_mat_free(out), free(got);
    if (k == 0) { /* one value moved off its image */
        size_t p = 3, q = 0;
        while (bv[q * n + p] == 0.0)
            q++;
        bv[q * n + p] *= 1.0 + 1e-4;
        bst_mat *d = dense_of(bv, n, n, BST_DOUBLE), *bs;
        ck_assert_int_eq(bst_mat_convert(ctx, d, BST_SPARSE, BST_DOUBLE, &bs), BST_OK);
        out = NULL;
        ck_assert_int_eq(bsti_mirror_mul(ctx, iv, prec, n, g, axis, right, bs, &out),
                         BSTI_MIRROR_ASYM);
        ck_assert_ptr_null(out);
        bst_mat_free(d), bst_mat_free(bs);
    }
    free(want), free(bv), free(xv);
    bst_mat_free(b), bst_mat_free(inv);
}
END_TEST

/* A sparse n x n matrix commuting with the mirror of the axis: one pair of values in about 16
 * kept of a symmetric one (values for dense_of). */
static double *sparse_symmetric(size_t g, int axis, double norm, tu_rng *r)
{
    size_t (*im)(size_t, size_t) = axis ? mir_y : mir, n = g * g;
    double *v = symmetric_about(g, axis, norm, r);
    for (size_t q = 0; q < n; q++)
        for (size_t p = 0; p < n; p++) {
            size_t cp = p < im(g, p) ? p : im(g, p), cq = p < im(g, p) ? q : im(g, q);
            if ((cp * 7919 + cq * 104729) % 16)
                v[q * n + p] = 0.0;
        }
    return v;
}

static bst_mat *sparse_of_values(const double *v, size_t n)
{
    bst_mat *d = dense_of(v, n, n, BST_DOUBLE), *s;
    ck_assert_int_eq(bst_mat_convert(ctx, d, BST_SPARSE, BST_DOUBLE, &s), BST_OK);
    bst_mat_free(d);
    return s;
}

/* Whether a sparse matrix commutes with the mirror, read on 1 and 3 threads (runs of columns):
 * the tolerance is of the largest value anywhere (a pair 1000 times the rest's, in other columns
 * than the one changed), a change just inside it holds and one just outside does not, as does a
 * NaN. */
START_TEST(test_holds_threads)
{
    tu_rng r;
    tu_rng_seed(&r, 950);
    size_t g = 32, n = g * g, c0 = 5, p0 = 0;
    double *v = sparse_symmetric(g, 0, 1.0, &r), big = 1000.0 * tm_maxabs(v, n * n);
    size_t pb = 3, qb = 16 * g + 5; /* (its image 15 g + 5: both in the middle run) */
    v[qb * n + pb] = v[mir(g, qb) * n + mir(g, pb)] = big;
    while (v[c0 * n + p0] == 0.0)
        p0++;
    double orig = v[c0 * n + p0];
    const double change[4] = {0.0, 0.5e-12 * big, 2e-12 * big, NAN};
    for (int k = 0; k < 4; k++) {
        v[c0 * n + p0] = orig + change[k];
        bst_mat *m = sparse_of_values(v, n);
        for (int t = 0; t < 2; t++) {
            ck_assert_int_eq(bst_ctx_set_threads(ctx, t ? 3 : 1), BST_OK);
            ck_assert_msg(bsti_mirror_commutes(ctx, m, BST_DOUBLE, n, g, 0) == (k < 2),
                          "change %d, %d threads", k, t ? 3 : 1);
        }
        bst_mat_free(m);
    }
    free(v);
}
END_TEST

/* Two left solves with Z's products (bsti_solve_take_left2_z, stack.c's from_inward and
 * from_outward): a split inverse forms Z X1 and Z X2 by its halves before X1 and X2 are made
 * whole, the same as Z times the unsplit solves' X1 and X2 (1e-13 of the largest in double, 2e-5
 * single), and X1, X2 as theirs; a Z without the symmetry (one value moved) is left to the caller
 * (both products NULL, X1 and X2 still split solves).  _i: precision, mirror (x, y), Z off. */
START_TEST(test_z_products)
{
    bst_precision prec = _i & 1 ? BST_FLOAT : BST_DOUBLE;
    int axis = (_i >> 1) & 1, off = _i >> 2;
    tu_rng r;
    tu_rng_seed(&r, 500 + (uint64_t)_i);
    size_t g = 16, n = g * g;
    double *av = symmetric_about(g, axis, 0.9, &r), *b1v = sparse_symmetric(g, axis, 1.0, &r),
           *b2v = sparse_symmetric(g, axis, 0.5, &r), *zv = sparse_symmetric(g, axis, 2.0, &r);
    if (off) {
        size_t q = 0;
        while (zv[q * n + 3] == 0.0)
            q++;
        zv[q * n + 3] *= 1.0 + 1e-4;
    }
    bst_mat *b1 = sparse_of_values(b1v, n), *b2 = sparse_of_values(b2v, n),
            *z = sparse_of_values(zv, n), *x[2][2], *zx[2];
    for (int no = 0; no < 2; no++) {
        ctx->no_mirror = no;
        bst_mat *acopy = dense_of(av, n, n, prec);
        double rcond, s0 = ctx->mirror_splits, z0 = ctx->mirror_z_products;
        int rc = no ? bsti_solve_take_left2(ctx, acopy, b1, NULL, b2, NULL, 0.0, prec, &x[no][0],
                                            &x[no][1], &rcond, NULL)
                    : bsti_solve_take_left2_z(ctx, acopy, b1, NULL, b2, NULL, z, 0.0, prec,
                                              &x[no][0], &x[no][1], &zx[0], &zx[1], &rcond, NULL);
        ck_assert_msg(rc == BST_OK, "%s", bst_ctx_message(ctx));
        ck_assert_double_eq(ctx->mirror_splits - s0, !no);
        ck_assert_double_eq(ctx->mirror_z_products - z0, no || off ? 0.0 : 2.0);
    }
    double tol = prec == BST_DOUBLE ? 1e-13 : 2e-5;
    for (int q = 0; q < 2; q++) {
        double *got = tm_dense(ctx, x[0][q]), *want = tm_dense(ctx, x[1][q]);
        double big = tm_maxabs(want, n * n);
        ck_assert_double_le(tm_maxdiff(got, want, n * n), tol * big);
        if (off) {
            ck_assert_ptr_null(zx[q]);
        } else {
            double *zw = malloc(n * n * sizeof *zw), *zg = tm_dense(ctx, zx[q]);
            tm_gemm(n, n, n, zv, want, zw);
            big = tm_maxabs(zw, n * n);
            ck_assert_msg(tm_maxdiff(zg, zw, n * n) <= tol * big, "Z X%d: %g of %g", q + 1,
                          tm_maxdiff(zg, zw, n * n), big);
            free(zw), free(zg);
        }
        free(got), free(want);
        bst_mat_free(x[0][q]), bst_mat_free(x[1][q]), bst_mat_free(zx[q]);
    }
    free(av), free(b1v), free(b2v), free(zv);
    bst_mat_free(b1), bst_mat_free(b2), bst_mat_free(z);
}
END_TEST

/* A matrix without the symmetry is not split; a kept split factorization serves the later right
 * solves (the absorptance's). */
START_TEST(test_kept_and_plain)
{
    tu_rng r;
    tu_rng_seed(&r, 7);
    size_t g = 16, n = g * g;
    double *av = symmetric(g, 0.9, &r);
    av[3 * n + 4] += 1e-6;
    bst_mat *a = dense_of(av, n, n, BST_DOUBLE), *b = rhs(0, n, BST_DOUBLE, &r), *x, *y[2];
    double rcond, s0 = ctx->mirror_splits;
    ck_assert_int_eq(bst_solve_left(ctx, a, b, 0.0, &x, &rcond), BST_OK);
    ck_assert_double_eq(ctx->mirror_splits, s0);
    bst_mat_free(x), bst_mat_free(a);
    av[3 * n + 4] -= 1e-6;
    a = dense_of(av, n, n, BST_DOUBLE);
    for (int no = 0; no < 2; no++) {
        bsti_factor *f;
        bst_mat *acopy, *x0;
        ctx->no_mirror = no;
        ck_assert_int_eq(bst_mat_convert(ctx, a, BST_DENSE, BST_DOUBLE, &acopy), BST_OK);
        ck_assert_int_eq(bsti_solve_take(ctx, 0, acopy, b, NULL, 0.0, BST_DOUBLE, &x0, &rcond, &f),
                         BST_OK);
        ck_assert_ptr_nonnull(f);
        ck_assert_int_eq(bsti_factor_solve_right(ctx, f, b, &y[no]), BST_OK);
        bsti_factor_free(f);
        bst_mat_free(x0);
    }
    ck_assert_double_eq(ctx->mirror_splits, s0 + 1);
    double *y0 = tm_dense(ctx, y[0]), *y1 = tm_dense(ctx, y[1]);
    ck_assert_double_le(tm_maxdiff(y0, y1, n * n), 1e-13 * tm_maxabs(y1, n * n));
    free(y0), free(y1), free(av);
    bst_mat_free(y[0]), bst_mat_free(y[1]), bst_mat_free(a), bst_mat_free(b);
}
END_TEST

/* I - A singular in one half only (A = (I - S) / 2: I - A = (I + S) / 2 is zero on x_p - x_Sp):
 * singular, as unsplit. */
START_TEST(test_singular_half)
{
    size_t g = 16, n = g * g;
    double *av = calloc(n * n, sizeof *av);
    for (size_t p = 0; p < n; p++) {
        av[p * n + p] += 0.5;
        av[mir(g, p) * n + p] -= 0.5;
    }
    bst_mat *a = dense_of(av, n, n, BST_DOUBLE), *b, *x = NULL;
    tu_rng r;
    tu_rng_seed(&r, 1);
    b = rhs(0, n, BST_DOUBLE, &r);
    double rcond = 1.0, s0 = ctx->mirror_splits;
    ck_assert_int_eq(bst_solve_left(ctx, a, b, 0.0, &x, &rcond), BST_ESINGULAR);
    ck_assert_ptr_null(x);
    ck_assert_double_eq(rcond, 0.0);
    ck_assert_double_eq(ctx->mirror_splits, s0 + 1);
    free(av);
    bst_mat_free(a), bst_mat_free(b);
}
END_TEST

/* The venetian blinds' layers commute with their mirror: a horizontal one with x -> -x, a
 * vertical one with y -> -y (to rounding), each and every component, mirror, diffuse and curved
 * slats. */
START_TEST(test_venetian_symmetry)
{
    static const char *const specs[] = {
        "width=16mm,spacing=14.5mm,tilt=45,rs=0.765,r=0.085,roughness=0.02",
        "width=16mm,spacing=14.5mm,tilt=30,r=0.5,t=0.1",
        "width=16mm,spacing=14.5mm,tilt=30,rs=0.8,roughness=0.1,curvature=30mm",
        "width=16mm,spacing=14.5mm,tilt=-20,rs=0.765,r=0.085,roughness=0.02,vertical"};
    const char *ch = "Visible";
    bst_basis *basis;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &basis), BST_OK);
    size_t g = 16, n = g * g;
    double *d = malloc(n * n * sizeof *d);
    for (size_t s = 0; s < sizeof specs / sizeof specs[0]; s++) {
        bst_venetian v;
        bst_layer *l;
        ck_assert_int_eq(bst_venetian_parse(ctx, specs[s], &v), BST_OK);
        ck_assert_msg(bst_venetian_layer(ctx, &v, basis, 1, &ch, &l) == BST_OK, "%s",
                      bst_ctx_message(ctx));
        for (int c = 0; c < BST_NCOMP; c++) {
            ck_assert_int_eq(bst_mat_to_dense_array(ctx, bst_layer_get(l, 0, c), d), BST_OK);
            double big = tm_maxabs(d, n * n), dev = 0.0, other = 0.0;
            for (size_t q = 0; q < n; q++)
                for (size_t p = 0; p < n; p++) {
                    size_t px = mir(g, p), qx = mir(g, q);
                    size_t py = p / g * g + g - 1 - p % g, qy = q / g * g + g - 1 - q % g;
                    double ex = fabs(d[q * n + p] - d[qx * n + px]);
                    double ey = fabs(d[q * n + p] - d[qy * n + py]);
                    dev = fmax(dev, v.vertical ? ey : ex);
                    other = fmax(other, v.vertical ? ex : ey);
                }
            ck_assert_msg(dev <= 1e-13 * big, "%s component %d: %g of %g off its mirror image",
                          specs[s], c, dev, big);
            ck_assert_double_gt(other, 1e-3 * big); /* the other mirror is no symmetry */
        }
        bst_layer_free(l);
    }
    free(d);
    bst_basis_free(basis);
}
END_TEST

static int saw_mirror;
static void on_step(const bst_stack_step *s, void *opaque)
{
    (void)opaque;
    saw_mirror |= s->mirror;
}

/* A pane on each side of a mirror and diffuse blind at k = 4 (or a mirror blind at k = 5),
 * horizontal (x mirror) or vertical (y mirror, the solve turned first): the second step's dense
 * solve split (-v's flag; the mirror blind's Z products by the halves, solve2_z), the system's
 * every value as the unsplit --dense baseline's to 1e-11 of the largest, double; 2e-5 single. */
START_TEST(test_stack)
{
    /* _i < 4: diffuse slats (a low-rank part), each precision and orientation; 4, 5: mirror slats
       alone (sparse), double horizontal and single vertical */
    int matte = _i < 4, vertical = matte ? _i & 2 : _i == 5;
    bst_precision prec = (matte ? _i & 1 : _i == 5) ? BST_FLOAT : BST_DOUBLE;
    char spec[160];
    snprintf(spec, sizeof spec, "width=16mm,spacing=14.5mm,tilt=45,rs=0.765,%sroughness=0.02%s",
             matte ? "r=0.085," : "", vertical ? ",vertical" : "");
    const char *ch = "Visible";
    bst_basis *basis;
    /* k = 5 for the mirror slats and the first diffuse case: from there the inverse pays
       (solve.c), which Z's products by the halves need (a low-rank part's: the Woodbury solve
       takes Z's sparse base to them, solve_plus) */
    int halves_z = !matte || _i == 0;
    ck_assert_int_eq(bst_basis_new_sc(ctx, halves_z ? 5 : 4, &basis), BST_OK);
    size_t n = bst_basis_size(basis);
    bst_venetian v;
    bst_layer *blind, *pane, *sys[2];
    ck_assert_int_eq(bst_venetian_parse(ctx, spec, &v), BST_OK);
    ck_assert_int_eq(bst_venetian_layer(ctx, &v, basis, 1, &ch, &blind), BST_OK);
    ck_assert_int_eq(bst_layer_new(ctx, basis, 1, &ch, &pane), BST_OK);
    double *t = malloc(n * sizeof *t), *rf = malloc(n * sizeof *rf);
    const double *lam = bst_basis_lambda(basis);
    for (size_t i = 0; i < n; i++) { /* a pane: diagonal T and R, as BSDF values (over Lambda) */
        double dir[3];
        bst_basis_center(basis, i, dir);
        t[i] = 0.85 * dir[2] / lam[i];
        rf[i] = (0.08 + 0.5 * pow(1 - dir[2], 5)) / lam[i];
    }
    for (int c = 0; c < BST_NCOMP; c++) {
        bst_mat *m;
        ck_assert_int_eq(bst_mat_new_diag(ctx, n, c == BST_TF || c == BST_TB ? t : rf, &m), BST_OK);
        ck_assert_int_eq(bst_layer_set(ctx, pane, 0, c, m), BST_OK);
    }
    const bst_layer *stack[3] = {pane, blind, pane};
    for (int dense = 0; dense < 2; dense++) {
        bst_stack_opts o;
        bst_stack_opts_init(&o);
        o.force_dense = dense;
        o.precision = prec;
        o.on_step = on_step;
        saw_mirror = 0;
        double z0 = ctx->mirror_z_products;
        int rc = bst_stack_combine(ctx, 3, stack, &o, &sys[dense]);
        ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
        ck_assert_int_eq(saw_mirror, !dense);
        ck_assert_double_eq(ctx->mirror_z_products - z0, dense || !halves_z ? 0.0 : 2.0);
    }
    double *d0 = malloc(n * n * sizeof *d0), *d1 = malloc(n * n * sizeof *d1);
    for (int c = 0; c < BST_NCOMP; c++) {
        ck_assert_int_eq(bst_mat_to_dense_array(ctx, bst_layer_get(sys[0], 0, c), d0), BST_OK);
        ck_assert_int_eq(bst_mat_to_dense_array(ctx, bst_layer_get(sys[1], 0, c), d1), BST_OK);
        double big = tm_maxabs(d1, n * n), tol = prec == BST_DOUBLE ? 1e-11 : 2e-5;
        ck_assert_msg(tm_maxdiff(d0, d1, n * n) <= tol * big, "component %d: %g of %g", c,
                      tm_maxdiff(d0, d1, n * n), big);
    }
    free(d0), free(d1), free(t), free(rf);
    bst_layer_free(sys[0]), bst_layer_free(sys[1]), bst_layer_free(blind), bst_layer_free(pane);
    bst_basis_free(basis);
}
END_TEST

static Suite *mirror_suite(void)
{
    Suite *s = suite_create("mirror");
    TCase *tc = tcase_create("core");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, test_side);
    tcase_add_test(tc, test_kernels);
    tcase_add_loop_test(tc, test_solves, 0, 32);
    tcase_add_loop_test(tc, test_sparse_split, 0, 16);
    tcase_add_loop_test(tc, test_split_threads, 0, 4);
    tcase_add_loop_test(tc, test_halves_product, 0, 24);
    tcase_add_test(tc, test_holds_threads);
    tcase_add_loop_test(tc, test_z_products, 0, 8);
    tcase_add_test(tc, test_kept_and_plain);
    tcase_add_test(tc, test_singular_half);
    tcase_add_test(tc, test_venetian_symmetry);
    tcase_add_loop_test(tc, test_stack, 0, 6);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return tu_run(mirror_suite()); }
