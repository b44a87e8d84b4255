/* test_solve.c - X = (I - A)^-1 B and Y = B (I - A)^-1 for every structure of A and B: residuals
 * against plain dense arithmetic, agreement with the dense generic solve, the condition estimate
 * as A approaches a singular I - A, singular cases, errors and injected allocation failures. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

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

/* _i enumerates (kind of A, kind of B, size, side). */
START_TEST(test_solve_all_pairs)
{
    int ka = _i % TM_NKINDS, kb = (_i / TM_NKINDS) % TM_NKINDS;
    size_t n = sizes[(_i / (TM_NKINDS * TM_NKINDS)) % NSIZES];
    int right = _i / (TM_NKINDS * TM_NKINDS * (int)NSIZES);
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

static Suite *solve_suite(void)
{
    Suite *s = suite_create("solve");
    TCase *tc = tcase_create("solve");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_loop_test(tc, test_solve_all_pairs, 0, 2 * TM_NKINDS * TM_NKINDS * (int)NSIZES);
    tcase_add_loop_test(tc, test_condition, TM_DIAG, TM_NKINDS);
    tcase_add_test(tc, test_errors);
    tcase_add_loop_test(tc, test_alloc_failure, 0, 16);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(solve_suite());
}
