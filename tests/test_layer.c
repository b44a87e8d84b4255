/* test_layer.c - layers (components per channel), reversal of a layer, hemispherical totals and
 * the accordance metric. */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static const char *const two[] = {"Visible", "Solar"};

static bst_mat *random_dense(size_t n, tu_rng *r, double fill)
{
    bst_mat *m, *c;
    ck_assert_int_eq(bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &m), BST_OK);
    double *d = bst_mat_dense_data(m);
    for (size_t i = 0; i < n * n; i++)
        d[i] = tu_rng_uniform(r) < fill ? tu_rng_uniform(r) : 0.0;
    ck_assert_int_eq(bst_mat_compact(ctx, m, BST_SPARSE_MAX_FILL, &c), BST_OK);
    bst_mat_free(m);
    return c;
}

START_TEST(test_new_and_set)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 2, &b), BST_OK);
    bst_layer *l = NULL;
    const char *dup[] = {"Visible", "visible"};
    ck_assert_int_eq(bst_layer_new(ctx, b, 2, dup, &l), BST_EINVAL);
    ck_assert_ptr_null(l);
    ck_assert_int_eq(bst_layer_new(ctx, b, 0, two, &l), BST_EINVAL);
    ck_assert_int_eq(bst_layer_new(ctx, b, 2, two, &l), BST_OK);
    ck_assert_int_eq(bst_layer_find_channel(l, "SOLAR"), 1);
    ck_assert_int_eq(bst_layer_find_channel(l, "CIE-X"), -1);
    ck_assert_ptr_null(bst_layer_get(l, 0, BST_TF));
    bst_mat *m;
    ck_assert_int_eq(bst_mat_new_zero(ctx, 3, 3, &m), BST_OK);
    ck_assert_int_eq(bst_layer_set(ctx, l, 0, BST_TF, m), BST_ESIZE); /* freed by set */
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "16 x 16"));
    ck_assert_int_eq(bst_mat_new_zero(ctx, 16, 16, &m), BST_OK);
    ck_assert_int_eq(bst_layer_set(ctx, l, 1, BST_RB, m), BST_OK);
    ck_assert_ptr_eq(bst_layer_get(l, 1, BST_RB), m);
    bst_mat *t = bst_layer_take(l, 1, BST_RB);
    ck_assert_ptr_eq(t, m);
    ck_assert_ptr_null(bst_layer_get(l, 1, BST_RB));
    bst_mat_free(t);
    ck_assert_int_eq(bst_comp_parse("rb"), BST_RB);
    ck_assert_int_eq(bst_comp_parse("Tx"), -1);
    ck_assert_str_eq(bst_comp_name(BST_TB), "Tb");
    bst_layer_free(l);
    bst_layer_free(NULL);
    bst_basis_free(b);
}
END_TEST

START_TEST(test_alloc_failure)
{
    bst_ctx *c = bst_ctx_new();
    tu_alloc a = {0};
    ck_assert_int_eq(bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &a), BST_OK);
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(c, 2, &b), BST_OK);
    long base = a.live;
    for (long k = 1;; k++) {
        a.fail_at = a.count + k;
        bst_layer *l = NULL;
        int rc = bst_layer_new(c, b, 2, two, &l);
        if (rc == BST_OK) {
            bst_layer_free(l);
            break;
        }
        ck_assert_int_eq(rc, BST_ENOMEM);
        ck_assert_ptr_null(l);
        ck_assert_int_eq(a.live, base);
        ck_assert_int_lt(k, 100);
    }
    ck_assert_int_eq(a.live, base);
    a.fail_at = 0;
    bst_basis_free(b);
    bst_ctx_free(c);
}
END_TEST

/* Reversal: Tf' (mirror o, mirror i) = Tb (o, i) with mirror x -> -x, and twice is the identity;
 * in the Klems basis as in Shirley-Chiu. */
START_TEST(test_flip)
{
    bst_basis *b;
    if (_i == 0)
        ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &b), BST_OK);
    else
        ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &b), BST_OK);
    size_t n = bst_basis_size(b);
    tu_rng r;
    tu_rng_seed(&r, 4242);
    bst_layer *l, *f, *ff;
    ck_assert_int_eq(bst_layer_new(ctx, b, 1, two, &l), BST_OK);
    double *d = malloc(n * sizeof *d);
    for (size_t i = 0; i < n; i++)
        d[i] = tu_rng_uniform(&r);
    bst_mat *diag;
    ck_assert_int_eq(bst_mat_new_diag(ctx, n, d, &diag), BST_OK);
    ck_assert_int_eq(bst_layer_set(ctx, l, 0, BST_TF, diag), BST_OK);
    ck_assert_int_eq(bst_layer_set(ctx, l, 0, BST_TB, random_dense(n, &r, 1.0)), BST_OK);
    ck_assert_int_eq(bst_layer_set(ctx, l, 0, BST_RB, random_dense(n, &r, 0.02)), BST_OK);
    ck_assert_int_eq(bst_layer_flip(ctx, l, &f), BST_OK);
    ck_assert_int_eq(bst_layer_flip(ctx, f, &ff), BST_OK);
    /* structures are kept */
    ck_assert_int_eq(bst_mat_structure(bst_layer_get(f, 0, BST_TB)), BST_DIAG);
    ck_assert_int_eq(bst_mat_structure(bst_layer_get(f, 0, BST_TF)), BST_DENSE);
    ck_assert_int_eq(bst_mat_structure(bst_layer_get(f, 0, BST_RF)), BST_SPARSE);
    ck_assert_ptr_null(bst_layer_get(f, 0, BST_RB));
    size_t *mir = malloc(n * sizeof *mir);
    for (size_t j = 0; j < n; j++) {
        double v[3];
        bst_basis_center(b, j, v);
        v[0] = -v[0];
        mir[j] = bst_basis_patch(b, v);
        ck_assert_uint_lt(mir[j], n);
    }
    for (size_t j = 0; j < n; j++)
        ck_assert_uint_eq(mir[mir[j]], j);
    const bst_mat *tb = bst_layer_get(l, 0, BST_TB), *tf2 = bst_layer_get(f, 0, BST_TF);
    const bst_mat *rb = bst_layer_get(l, 0, BST_RB), *rf2 = bst_layer_get(f, 0, BST_RF);
    for (size_t j = 0; j < n; j++)
        for (size_t i = 0; i < n; i++) {
            ck_assert_double_eq(bst_mat_get(tf2, mir[i], mir[j]), bst_mat_get(tb, i, j));
            ck_assert_double_eq(bst_mat_get(rf2, mir[i], mir[j]), bst_mat_get(rb, i, j));
            for (int c = 0; c < BST_NCOMP; c++) {
                const bst_mat *x = bst_layer_get(l, 0, (bst_comp)c), *y = bst_layer_get(ff, 0, (bst_comp)c);
                ck_assert_double_eq(x ? bst_mat_get(x, i, j) : 0.0, y ? bst_mat_get(y, i, j) : 0.0);
            }
        }
    free(mir);
    free(d);
    bst_layer_free(l);
    bst_layer_free(f);
    bst_layer_free(ff);
    bst_basis_free(b);
}
END_TEST

START_TEST(test_hemispherical_and_accordance)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 2, &b), BST_OK);
    size_t n = bst_basis_size(b);
    bst_layer *x, *y;
    ck_assert_int_eq(bst_layer_new(ctx, b, 1, two, &x), BST_OK);
    ck_assert_int_eq(bst_layer_new(ctx, b, 1, two, &y), BST_OK);
    /* Lambertian transmission 0.5/pi: hemispherical T = 0.5 for every incident patch */
    bst_mat *m;
    ck_assert_int_eq(bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &m), BST_OK);
    double *d = bst_mat_dense_data(m);
    for (size_t i = 0; i < n * n; i++)
        d[i] = 0.5 / M_PI;
    ck_assert_int_eq(bst_layer_set(ctx, x, 0, BST_TF, m), BST_OK);
    double h[16];
    ck_assert_int_eq(bst_layer_hemispherical(ctx, x, 0, BST_TF, h), BST_OK);
    for (size_t j = 0; j < n; j++)
        tu_assert_close(h[j], 0.5, 1e-14, 0.0);
    ck_assert_int_eq(bst_layer_hemispherical(ctx, x, 0, BST_RF, h), BST_OK);
    ck_assert_double_eq(h[3], 0.0);
    /* y = twice x on the first half of the outgoing patches, zero elsewhere */
    ck_assert_int_eq(bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &m), BST_OK);
    d = bst_mat_dense_data(m);
    for (size_t j = 0; j < n; j++)
        for (size_t i = 0; i < n; i++)
            d[j * n + i] = i < n / 2 ? 1.0 / M_PI : 0.0;
    ck_assert_int_eq(bst_layer_set(ctx, y, 0, BST_TF, m), BST_OK);
    double ga, fa, la[16];
    ck_assert_int_eq(bst_metrics_accordance(ctx, x, x, 0, BST_TF, 5, &ga, &fa, la), BST_OK);
    ck_assert_double_eq(ga, 100.0);
    ck_assert_double_eq(fa, 100.0);
    ck_assert_int_eq(bst_metrics_accordance(ctx, x, y, 0, BST_TF, 5, &ga, &fa, la), BST_OK);
    /* FA: sum L|a-b| = n L (0.5/pi) = 0.5, sum L(a+b) = 0.5 + 0.5 -> 50 */
    tu_assert_close(fa, 50.0, 1e-12, 0.0);
    /* GA (eq. 7, equal patches: plain sums), by hand: the first half has a = 0.5/pi, b = 1/pi,
     * the second a = 0.5/pi, b = 0, so sum (a-b)^2 = n/2 (0.25 + 0.25) / pi^2 and sum (a+b)^2 =
     * n/2 (2.25 + 0.25) / pi^2: GA = 100 (1 - 0.5 / 2.5) = 80 */
    tu_assert_close(ga, 80.0, 1e-12, 0.0);
    tu_assert_close(la[0], 100.0 * (1.0 - 0.5 / 1.5), 1e-12, 0.0);
    ck_assert_double_eq(la[n - 1], 0.0);
    /* x against 3 x: GA 100 (1 - 1/4) = 75, FA 100 (1 - 2/4) = 50 */
    bst_layer *z;
    ck_assert_int_eq(bst_layer_new(ctx, b, 1, two, &z), BST_OK);
    ck_assert_int_eq(bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &m), BST_OK);
    d = bst_mat_dense_data(m);
    for (size_t i = 0; i < n * n; i++)
        d[i] = 1.5 / M_PI;
    ck_assert_int_eq(bst_layer_set(ctx, z, 0, BST_TF, m), BST_OK);
    ck_assert_int_eq(bst_metrics_accordance(ctx, x, z, 0, BST_TF, 2, &ga, &fa, NULL), BST_OK);
    tu_assert_close(ga, 75.0, 1e-12, 0.0);
    tu_assert_close(fa, 50.0, 1e-12, 0.0);
    /* a copy scaled by 1.1: GA 100 (1 - 0.1^2 / 2.1^2) = 99.7732..., FA 100 (1 - 0.1 / 2.1) */
    for (size_t i = 0; i < n * n; i++)
        d[i] = 1.1 * 0.5 / M_PI;
    ck_assert_int_eq(bst_metrics_accordance(ctx, x, z, 0, BST_TF, 2, &ga, &fa, NULL), BST_OK);
    tu_assert_close(ga, 100.0 * (1.0 - 0.01 / 4.41), 1e-12, 0.0);
    tu_assert_close(fa, 100.0 * (1.0 - 0.1 / 2.1), 1e-12, 0.0);
    /* a peak of 3 on a background of 1 moved by one patch (column 7): (a-b)^2 = 4 twice,
     * (a+b)^2 = 16 twice and 4 in the n - 2 others: GA = 100 (1 - 8 / (32 + 4 (n - 2))) = 85.71...
     * for n = 16; LA 100 (1 - 2/4) = 50 at both peaks, 100 elsewhere */
    bst_mat *pa, *pb;
    ck_assert_int_eq(bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &pa), BST_OK);
    ck_assert_int_eq(bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &pb), BST_OK);
    double *da = bst_mat_dense_data(pa), *db = bst_mat_dense_data(pb);
    for (size_t i = 0; i < n * n; i++)
        da[i] = i % n == 4 ? 3.0 : 1.0, db[i] = i % n == 5 ? 3.0 : 1.0;
    ck_assert_int_eq(bst_layer_set(ctx, y, 0, BST_TB, pa), BST_OK);
    ck_assert_int_eq(bst_layer_set(ctx, z, 0, BST_TB, pb), BST_OK);
    ck_assert_int_eq(bst_metrics_accordance(ctx, y, z, 0, BST_TB, 7, &ga, NULL, la), BST_OK);
    tu_assert_close(ga, 100.0 * (1.0 - 8.0 / (32.0 + 4.0 * (double)(n - 2))), 1e-12, 0.0);
    tu_assert_close(la[4], 50.0, 1e-12, 0.0);
    tu_assert_close(la[5], 50.0, 1e-12, 0.0);
    tu_assert_close(la[6], 100.0, 1e-12, 0.0);
    /* disjoint supports: 0 */
    for (size_t i = 0; i < n; i++)
        da[7 * n + i] = i == 4 ? 3.0 : 0.0, db[7 * n + i] = i == 5 ? 3.0 : 0.0;
    ck_assert_int_eq(bst_metrics_accordance(ctx, y, z, 0, BST_TB, 7, &ga, &fa, NULL), BST_OK);
    ck_assert_double_eq(ga, 0.0);
    ck_assert_double_eq(fa, 0.0);
    /* negatives count as 0: -1e-17 against 0 agrees (LA 100), -2 against 1 is 0 against 1 (LA 0),
     * 1 against 1 agrees: GA = 100 (1 - 1 / (1 + 4)) = 80, FA = 100 (1 - 1 / 3) */
    for (size_t i = 0; i < n; i++)
        da[7 * n + i] = db[7 * n + i] = 0.0;
    da[7 * n] = -1e-17, da[7 * n + 1] = -2.0, db[7 * n + 1] = 1.0, da[7 * n + 2] = db[7 * n + 2] = 1.0;
    ck_assert_int_eq(bst_metrics_accordance(ctx, y, z, 0, BST_TB, 7, &ga, &fa, la), BST_OK);
    ck_assert_double_eq(la[0], 100.0);
    ck_assert_double_eq(la[1], 0.0);
    ck_assert_double_eq(la[2], 100.0);
    tu_assert_close(ga, 80.0, 1e-12, 0.0);
    tu_assert_close(fa, 100.0 * (1.0 - 1.0 / 3.0), 1e-12, 0.0);
    /* one side zero, both zero */
    ck_assert_int_eq(bst_metrics_accordance(ctx, x, z, 0, BST_RF, 5, &ga, &fa, NULL), BST_OK);
    ck_assert_double_eq(ga, 100.0); /* both absent */
    ck_assert_double_eq(fa, 100.0);
    ck_assert_int_eq(bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &m), BST_OK);
    ((double *)bst_mat_dense_data(m))[5 * n + 3] = 1.0;
    ck_assert_int_eq(bst_layer_set(ctx, z, 0, BST_RF, m), BST_OK);
    ck_assert_int_eq(bst_metrics_accordance(ctx, x, z, 0, BST_RF, 5, &ga, &fa, NULL), BST_OK);
    ck_assert_double_eq(ga, 0.0);
    ck_assert_double_eq(fa, 0.0);
    /* Klems patches enter eq. 7 weighted by their projected solid angles L: a = 1 in patches 0
     * and 144, b = 1 in patch 0 only: GA = 100 (1 - L_144 / (4 L_0 + L_144)) */
    {
        bst_basis *kb;
        bst_layer *ka, *kbl;
        ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &kb), BST_OK);
        const double *lk = bst_basis_lambda(kb);
        ck_assert_int_eq(bst_layer_new(ctx, kb, 1, two, &ka), BST_OK);
        ck_assert_int_eq(bst_layer_new(ctx, kb, 1, two, &kbl), BST_OK);
        bst_mat *m1, *m2;
        ck_assert_int_eq(bst_mat_new_dense(ctx, 145, 145, BST_DOUBLE, &m1), BST_OK);
        ck_assert_int_eq(bst_mat_new_dense(ctx, 145, 145, BST_DOUBLE, &m2), BST_OK);
        double *p1 = bst_mat_dense_data(m1), *p2 = bst_mat_dense_data(m2);
        p1[0] = p1[144] = 1.0, p2[0] = 1.0;
        ck_assert_int_eq(bst_layer_set(ctx, ka, 0, BST_TF, m1), BST_OK);
        ck_assert_int_eq(bst_layer_set(ctx, kbl, 0, BST_TF, m2), BST_OK);
        ck_assert_int_eq(bst_metrics_accordance(ctx, ka, kbl, 0, BST_TF, 0, &ga, NULL, NULL), BST_OK);
        tu_assert_close(ga, 100.0 * (1.0 - lk[144] / (4.0 * lk[0] + lk[144])), 1e-12, 0.0);
        ck_assert_double_gt(fabs(lk[144] - lk[0]), 1e-3); /* the weights matter here */
        bst_layer_free(ka), bst_layer_free(kbl), bst_basis_free(kb);
    }
    /* every incident patch at once: the same values */
    double gall[16], fall[16];
    ck_assert_int_eq(bst_metrics_accordance_all(ctx, x, y, 0, BST_TF, gall, fall), BST_OK);
    for (size_t j = 0; j < n; j++) {
        ck_assert_int_eq(bst_metrics_accordance(ctx, x, y, 0, BST_TF, j, &ga, &fa, NULL), BST_OK);
        ck_assert_double_eq(gall[j], ga);
        ck_assert_double_eq(fall[j], fa);
    }
    ck_assert_int_eq(bst_metrics_accordance_all(ctx, x, y, 0, BST_TF, NULL, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_metrics_accordance(ctx, x, y, 0, BST_TF, n, &ga, NULL, NULL), BST_EINVAL);
    ck_assert_int_eq(bst_metrics_accordance(ctx, x, y, 0, BST_TF, 0, NULL, NULL, NULL), BST_EINVAL);
    bst_layer_free(z);
    bst_layer_free(x);
    bst_layer_free(y);
    bst_basis_free(b);
}
END_TEST

static Suite *layer_suite(void)
{
    Suite *s = suite_create("layer");
    TCase *tc = tcase_create("layer");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_add_test(tc, test_new_and_set);
    tcase_add_test(tc, test_alloc_failure);
    tcase_add_loop_test(tc, test_flip, 0, 2);
    tcase_add_test(tc, test_hemispherical_and_accordance);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(layer_suite());
}
