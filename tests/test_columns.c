/* test_columns.c - a stack's incident columns by iteration (bst_stack_columns) against the whole
 * system (bst_stack_combine): the reference stacks at k = 5, both sides, to 1e-8 of each column's
 * largest value;
 * a near-perfect mirror pair that cannot converge says so; one layer; bad arguments. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static bst_layer *load(const char *what, const bst_basis *b) { return tu_layer(ctx, what, b); }

/* Column q of x against column cols[q] of the full matrix, relative to the column's largest value. */
static double column_error(const bst_mat *x, const bst_mat *full, size_t n, size_t q, size_t col)
{
    double big = 0, err = 0;
    for (size_t o = 0; o < n; o++)
        big = fmax(big, fabs(bst_mat_get(full, o, col)));
    for (size_t o = 0; o < n; o++)
        err = fmax(err, fabs(bst_mat_get(x, o, q) - bst_mat_get(full, o, col)));
    return big > 0 ? err / big : err;
}

static const char *const stacks[][3] = {
    {"glass:clear-6mm", "L_blind0_t4k5.xml", "glass:clear-6mm"},
    {"L_glass_t4k5.xml", "L_diffuser_t3k5.xml", "L_glass_t4k5.xml"},
    {"glass:clear-6mm", "L_blind45_t4k5.xml", NULL},
    {"glass:clear-6mm", "glass:lowiron-6mm", NULL},
};

START_TEST(test_against_full)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b), BST_OK);
    size_t N = bst_basis_size(b), n = stacks[_i][2] ? 3 : 2;
    bst_layer *l[3];
    for (size_t i = 0; i < n; i++)
        l[i] = load(stacks[_i][i], b);
    bst_layer *sys;
    ck_assert_int_ge(bst_stack_combine(ctx, n, (const bst_layer *const *)l, NULL, &sys), 0);
    size_t cols[] = {0, 31, 100, 333, 511, 528, 700, 1023};
    size_t m = sizeof cols / sizeof *cols;
    for (int back = 0; back < 2; back++) {
        bst_columns_opts o;
        bst_columns_opts_init(&o);
        o.back = back;
        bst_mat *tf, *rf;
        ck_assert_int_eq(bst_stack_columns(ctx, n, (const bst_layer *const *)l, NULL, m, cols, &o, &tf, &rf),
                         BST_OK);
        ck_assert_uint_eq(bst_mat_rows(tf), N);
        ck_assert_uint_eq(bst_mat_cols(tf), m);
        double worst = 0;
        for (size_t q = 0; q < m; q++) {
            worst = fmax(worst, column_error(tf, bst_layer_get(sys, 0, back ? BST_TB : BST_TF), N, q, cols[q]));
            worst = fmax(worst, column_error(rf, bst_layer_get(sys, 0, back ? BST_RB : BST_RF), N, q, cols[q]));
        }
        printf("%s + %s%s%s, %s: %zu columns of T and R in %d sweeps (last change %.1e): within %.1e of "
               "the full system\n", stacks[_i][0], stacks[_i][1], n == 3 ? " + " : "", n == 3 ? stacks[_i][2] : "",
               back ? "back" : "front", m, o.iterations, o.residual, worst);
        ck_assert_double_le(worst, 1e-8);
        ck_assert_double_le(o.residual, BST_COLUMNS_TOL);
        ck_assert_int_ge(o.iterations, 1);
        bst_mat_free(tf), bst_mat_free(rf);
    }
    bst_layer_free(sys);
    for (size_t i = 0; i < n; i++)
        bst_layer_free(l[i]);
    bst_basis_free(b);
}
END_TEST

/* Two facing mirrors of reflectance 1 - 1e-7: the iteration cannot reach 1e-12 in 50 sweeps and
 * returns BST_WILLCOND with a message and finite columns; a single layer is its own columns; bad
 * arguments. */
START_TEST(test_mirrors_and_single)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 2, &b), BST_OK);
    size_t N = bst_basis_size(b);
    const char *ch = "Visible";
    bst_layer *l[2];
    double t[16], r[16];
    for (size_t i = 0; i < N; i++)
        t[i] = 1e-7 / (M_PI / N), r[i] = (1 - 1e-7) / (M_PI / N);
    for (int k = 0; k < 2; k++) {
        ck_assert_int_eq(bst_layer_new(ctx, b, 1, &ch, &l[k]), BST_OK);
        for (int c = 0; c < BST_NCOMP; c++) {
            bst_mat *m;
            ck_assert_int_eq(bst_mat_new_diag(ctx, N, c == BST_TF || c == BST_TB ? t : r, &m), BST_OK);
            ck_assert_int_eq(bst_layer_set(ctx, l[k], 0, (bst_comp)c, m), BST_OK);
        }
    }
    size_t col = 5;
    bst_columns_opts o;
    bst_columns_opts_init(&o);
    o.max_iter = 50;
    bst_mat *tf, *rf;
    ck_assert_int_eq(bst_stack_columns(ctx, 2, (const bst_layer *const *)l, "Visible", 1, &col, &o, &tf, &rf),
                     BST_WILLCOND);
    ck_assert_int_eq(o.iterations, 50);
    ck_assert_double_gt(o.residual, 1e-12);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "no convergence"));
    ck_assert(isfinite(bst_mat_get(tf, col, 0)));
    bst_mat_free(tf), bst_mat_free(rf);
    /* one layer: its own columns */
    ck_assert_int_eq(bst_stack_columns(ctx, 1, (const bst_layer *const *)l, NULL, 1, &col, NULL, &tf, &rf), BST_OK);
    tu_assert_close(bst_mat_get(tf, col, 0), t[col], 1e-15, 0.0);
    tu_assert_close(bst_mat_get(rf, col, 0), r[col], 1e-15, 0.0);
    bst_mat_free(tf), bst_mat_free(rf);
    /* bad arguments */
    size_t bad = N;
    ck_assert_int_eq(bst_stack_columns(ctx, 2, (const bst_layer *const *)l, NULL, 1, &bad, NULL, &tf, &rf), BST_EINVAL);
    ck_assert_int_eq(bst_stack_columns(ctx, 2, (const bst_layer *const *)l, "Solar", 1, &col, NULL, &tf, &rf), BST_ENOTFOUND);
    ck_assert_int_eq(bst_stack_columns(ctx, 2, (const bst_layer *const *)l, NULL, 0, &col, NULL, &tf, &rf), BST_EINVAL);
    o.tol = 0;
    ck_assert_int_eq(bst_stack_columns(ctx, 2, (const bst_layer *const *)l, NULL, 1, &col, &o, &tf, &rf), BST_EINVAL);
    bst_layer_free(l[0]), bst_layer_free(l[1]);
    bst_basis_free(b);
}
END_TEST

/* Single precision: a dense float layer stops the iteration at BST_COLUMNS_TOL_FLOAT, which
 * float products can reach, and the columns agree with the double system to float accuracy. */
START_TEST(test_single_precision)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &b), BST_OK);
    size_t N = bst_basis_size(b);
    bst_layer *l[3], *sys;
    l[0] = load("glass:clear-6mm", b), l[2] = load("glass:clear-6mm", b);
    bst_bsdf *f;
    bst_bsdf_read_opts ro = {.precision = BST_FLOAT};
    ck_assert_int_ge(bst_bsdf_read(ctx, tu_ref("L_diffuser_t3k5.xml"), &ro, &f), 0);
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, f, b, &l[1]), BST_OK);
    bst_bsdf_free(f);
    ck_assert_int_eq(bst_mat_precision(bst_layer_get(l[1], 0, BST_TF)), BST_FLOAT);
    bst_layer *ld = load("L_diffuser_t3k5.xml", b), *ls[3] = {l[0], ld, l[2]};
    ck_assert_int_ge(bst_stack_combine(ctx, 3, (const bst_layer *const *)ls, NULL, &sys), 0);
    size_t cols[] = {0, 77, 200};
    bst_columns_opts o;
    bst_columns_opts_init(&o);
    bst_mat *tf, *rf;
    ck_assert_int_eq(bst_stack_columns(ctx, 3, (const bst_layer *const *)l, NULL, 3, cols, &o, &tf, &rf), BST_OK);
    ck_assert_double_le(o.residual, BST_COLUMNS_TOL_FLOAT);
    ck_assert_int_lt(o.iterations, 100);
    for (size_t q = 0; q < 3; q++)
        ck_assert_double_le(column_error(tf, bst_layer_get(sys, 0, BST_TF), N, q, cols[q]), 1e-5);
    bst_mat_free(tf), bst_mat_free(rf);
    bst_layer_free(sys), bst_layer_free(ld);
    for (int i = 0; i < 3; i++)
        bst_layer_free(l[i]);
    bst_basis_free(b);
}
END_TEST

/* Allocation failure anywhere in an iteration returns BST_ENOMEM, no columns and no leak. */
START_TEST(test_allocation_failure)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &b), BST_OK);
    bst_layer *l[3] = {load("glass:clear-6mm", b), load("L_blind0_t4k5.xml", b), load("L_diffuser_t3k5.xml", b)};
    size_t cols[] = {3, 40};
    int ok = 0;
    for (long n = 1; n < 5000 && !ok; n++) {
        tu_alloc a = {n, 0, 0};
        bst_ctx *c = bst_ctx_new();
        ck_assert_int_eq(bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &a), BST_OK);
        bst_mat *tf = (bst_mat *)1, *rf = (bst_mat *)1;
        bst_columns_opts o;
        bst_columns_opts_init(&o);
        o.back = n % 2;
        int rc = bst_stack_columns(c, 3, (const bst_layer *const *)l, NULL, 2, cols, &o, &tf, &rf);
        if (rc == BST_OK) {
            ok = 1;
            bst_mat_free(tf), bst_mat_free(rf);
        } else {
            ck_assert_int_eq(rc, BST_ENOMEM);
            ck_assert_ptr_null(tf);
            ck_assert_ptr_null(rf);
        }
        ck_assert_msg(a.live == 0, "allocation %ld failing: %ld blocks leaked", n, a.live);
        bst_ctx_free(c);
    }
    ck_assert(ok);
    for (int i = 0; i < 3; i++)
        bst_layer_free(l[i]);
    bst_basis_free(b);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("columns");
    TCase *tc = tcase_create("columns");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 300);
    tcase_add_loop_test(tc, test_against_full, 0, sizeof stacks / sizeof *stacks);
    tcase_add_test(tc, test_mirrors_and_single);
    tcase_add_test(tc, test_single_precision);
    tcase_add_test(tc, test_allocation_failure);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return tu_run(suite()); }
