/* test_basis.c - the Shirley-Chiu and Klems bases against RADIANCE's documented mapping examples
 * (CONVENTIONS.md 4, README "what the vectors mean", 12.4) and WCE's Klems basis tables. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "basis.h"
#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

START_TEST(test_concentric_examples)
{
    static const double ex[][4] = {{0.5, 0, 0.75, 0.5}, {0, 0.5, 0.5, 0.75},
                                   {0.3, 0.4, 0.704833, 0.75}, {0.5, 0.5, 0.853553, 0.853553},
                                   {0.5364, 0.0946, 0.7723, 0.5605}};
    for (size_t i = 0; i < sizeof ex / sizeof ex[0]; i++) {
        double sx, sy, x, y;
        bsti_sc_disk_to_square(ex[i][0], ex[i][1], &sx, &sy);
        tu_assert_close(sx, ex[i][2], 2e-4, 1.0);
        tu_assert_close(sy, ex[i][3], 2e-4, 1.0);
        bsti_sc_square_to_disk(sx, sy, &x, &y);
        tu_assert_close(x, ex[i][0], 1e-12, 1.0);
        tu_assert_close(y, ex[i][1], 1e-12, 1.0);
    }
    /* mirroring x -> -x maps sx -> 1 - sx */
    double a, b, c, d;
    bsti_sc_disk_to_square(0.31, -0.52, &a, &b);
    bsti_sc_disk_to_square(-0.31, -0.52, &c, &d);
    tu_assert_close(c, 1 - a, 1e-14, 1.0);
    tu_assert_close(d, b, 1e-14, 1.0);
}
END_TEST

/* Polar form of the concentric map: the same square points as the Cartesian form for any angle
 * (also beyond one turn); the cells holding a point, with the 2 or 4 that meet on a boundary. */
START_TEST(test_polar_cells)
{
    tu_rng r;
    tu_rng_seed(&r, 5);
    for (int i = 0; i < 10000; i++) {
        double rho = tu_rng_uniform(&r), phi = 4 * M_PI * (tu_rng_uniform(&r) - 0.5), a, b, c, d;
        bsti_sc_polar_to_square(rho, phi, &a, &b);
        bsti_sc_disk_to_square(rho * cos(phi), rho * sin(phi), &c, &d);
        tu_assert_close(a, c, 1e-12, 1.0);
        tu_assert_close(b, d, 1e-12, 1.0);
    }
    size_t cells[4];
    /* (0.3, 0.4) lies in cell (5, 6) of 8 (square point 0.7048, 0.75: on the line y = 6/8) */
    ck_assert_int_eq(bsti_sc_polar_cells(0.5, atan2(0.4, 0.3), 8, cells), 2);
    ck_assert_uint_eq(cells[0], 5 * 8 + 6);
    ck_assert_uint_eq(cells[1], 5 * 8 + 5);
    /* straight along +x at radius 0.5: square (0.75, 0.5), the corner of four cells of 8 */
    ck_assert_int_eq(bsti_sc_polar_cells(0.5, 0.0, 8, cells), 4);
    size_t want[4] = {6 * 8 + 4, 6 * 8 + 3, 5 * 8 + 4, 5 * 8 + 3};
    for (int j = 0; j < 4; j++)
        ck_assert_uint_eq(cells[j], want[j]);
    /* rounding: one ulp off the boundary still counts as on it; a cell interior is one cell */
    ck_assert_int_eq(bsti_sc_polar_cells(0.5, 1e-17, 8, cells), 4);
    ck_assert_int_eq(bsti_sc_polar_cells(0.3, 0.1, 8, cells), 1);
    ck_assert_int_eq(bsti_sc_polar_cells(1.0, 0.1, 8, cells), 1); /* the rim: no cell beyond */
    ck_assert_uint_eq(cells[0], 7 * 8 + 4);
}
END_TEST

START_TEST(test_sc_patches)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b), BST_OK);
    ck_assert_uint_eq(bst_basis_size(b), 1024);
    ck_assert_int_eq(bst_basis_order(b), 5);
    /* README: propagation (0.5364, 0.0946, 0.8387) lies in cell (24, 17) of 32 */
    double p[3] = {0.5364, 0.0946, 0.8387};
    ck_assert_uint_eq(bst_basis_patch(b, p), 24 * 32 + 17);
    p[1] += 0.01; /* shifted by +0.01 in y: cell (24, 18) */
    ck_assert_uint_eq(bst_basis_patch(b, p), 24 * 32 + 18);
    double sum = 0;
    tu_rng r;
    tu_rng_seed(&r, 1);
    for (size_t i = 0; i < bst_basis_size(b); i++) {
        sum += bst_basis_lambda(b)[i];
        double c[3];
        bst_basis_center(b, i, c);
        tu_assert_close(c[0] * c[0] + c[1] * c[1] + c[2] * c[2], 1.0, 1e-14, 1.0);
        ck_assert_uint_eq(bst_basis_patch(b, c), i);
        bst_basis_sample(b, i, tu_rng_uniform(&r), tu_rng_uniform(&r), c);
        ck_assert_uint_eq(bst_basis_patch(b, c), i);
        size_t a = bst_basis_antipode(b, i);
        ck_assert_uint_eq(bst_basis_antipode(b, a), i);
        bst_basis_center(b, i, c);
        c[0] = -c[0], c[1] = -c[1];
        ck_assert_uint_eq(bst_basis_patch(b, c), a);
    }
    tu_assert_close(sum, M_PI, 1e-13, 1.0);
    bst_basis_free(b);
    ck_assert_int_eq(bst_basis_new_sc(ctx, 0, &b), BST_EINVAL);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "k = 0"));
    ck_assert_int_eq(bst_basis_new_sc(ctx, 8, &b), BST_EINVAL);
}
END_TEST

/* The projected solid angles against WCE's basis tables (lambda column). */
START_TEST(test_klems_against_wce)
{
    static const char *const which[] = {"full", "half", "quarter"};
    static const size_t count[] = {145, 77, 41};
    char name[64];
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, which[_i], &b), BST_OK);
    ck_assert_uint_eq(bst_basis_size(b), count[_i]);
    snprintf(name, sizeof name, "wce/basis/basis_klems_%s.tsv", which[_i]);
    FILE *fp = fopen(tu_ref(name), "r");
    ck_assert_msg(fp != NULL, "cannot open %s", tu_ref(name));
    char line[512];
    size_t rows = 0;
    while (fgets(line, sizeof line, fp)) {
        int idx, ring;
        double tlo, thi, plo, phi, tc, pc, lam;
        if (sscanf(line, "%d %d %lf %lf %lf %lf %lf %lf %lf", &idx, &ring, &tlo, &thi, &plo, &phi,
                   &tc, &pc, &lam) != 9)
            continue;
        size_t i = (size_t)idx - 1;
        tu_assert_close(bst_basis_lambda(b)[i], lam, 1e-10, 0.0);
        /* the patch centre WCE uses lies in this patch, and the basis finds it there */
        double d[3] = {sin(tc * M_PI / 180) * cos(pc * M_PI / 180),
                       sin(tc * M_PI / 180) * sin(pc * M_PI / 180), cos(tc * M_PI / 180)};
        ck_assert_uint_eq(bst_basis_patch(b, d), i);
        double c[3];
        bst_basis_center(b, i, c);
        tu_assert_close(c[0], d[0], 1e-12, 1.0);
        tu_assert_close(c[1], d[1], 1e-12, 1.0);
        rows++;
    }
    fclose(fp);
    ck_assert_uint_eq(rows, count[_i]);
    tu_rng r;
    tu_rng_seed(&r, 2);
    double sum = 0;
    for (size_t i = 0; i < bst_basis_size(b); i++) {
        double c[3];
        sum += bst_basis_lambda(b)[i];
        bst_basis_sample(b, i, tu_rng_uniform(&r), tu_rng_uniform(&r), c);
        ck_assert_uint_eq(bst_basis_patch(b, c), i);
        size_t a = bst_basis_antipode(b, i);
        bst_basis_center(b, i, c);
        c[0] = -c[0], c[1] = -c[1];
        ck_assert_uint_eq(bst_basis_patch(b, c), a);
    }
    tu_assert_close(sum, M_PI, 1e-13, 1.0);
    bst_basis_free(b);
}
END_TEST

START_TEST(test_klems_example)
{
    /* CONVENTIONS 12.4 (0-based): propagation theta 10, phi 90 is patch 3 (band 1, j = 2); exit
     * theta 20, phi 247.5 is patch 20 (band 2, j = 11) */
    bst_basis *b, *c;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &b), BST_OK);
    double in[3] = {0, -0.173648, -0.984808}, prop[3] = {-in[0], -in[1], -in[2]};
    double out[3] = {-0.130885, -0.315985, 0.939693};
    ck_assert_uint_eq(bst_basis_patch(b, prop), 3);
    ck_assert_uint_eq(bst_basis_patch(b, out), 20);
    ck_assert_int_eq(bst_basis_copy(ctx, b, &c), BST_OK);
    ck_assert(bst_basis_equal(b, c));
    bst_basis_free(c);
    ck_assert_int_eq(bst_basis_new_klems(ctx, "half", &c), BST_OK);
    ck_assert(!bst_basis_equal(b, c));
    bst_basis_free(c);
    ck_assert_int_eq(bst_basis_new_klems(ctx, "eighth", &c), BST_EBASIS);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "eighth"));
    double bad_t[] = {0, 50, 40, 90};
    int bad_n[] = {1, 8, 8};
    ck_assert_int_eq(bst_basis_new_klems_bands(ctx, "x", 3, bad_t, bad_n, &c), BST_EBASIS);
    bst_basis_free(b);
}
END_TEST

/* A direction whose x or y is not finite has no patch: bst_basis_patch gives the basis's size (it
 * computed (size_t)NaN, undefined, 2^63 on x86-64), which a function taking a patch refuses;
 * directions beyond the unit disk still give a patch of the basis. */
START_TEST(test_patch_not_finite)
{
    bst_basis *bases[2];
    ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &bases[0]), BST_OK);
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &bases[1]), BST_OK);
    const double bad[] = {NAN, INFINITY, -INFINITY};
    for (int k = 0; k < 2; k++) {
        const bst_basis *b = bases[k];
        size_t n = bst_basis_size(b);
        for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
            double dx[3] = {bad[i], 0.1, 0.9}, dy[3] = {0.1, bad[i], 0.9}, dz[3] = {0.1, 0.2, bad[i]};
            ck_assert_uint_eq(bst_basis_patch(b, dx), n);
            ck_assert_uint_eq(bst_basis_patch(b, dy), n);
            ck_assert_uint_lt(bst_basis_patch(b, dz), n); /* z is not used */
        }
        double far[3] = {3.0, -4.0, 0.0};
        ck_assert_uint_lt(bst_basis_patch(b, far), n);
        double nan_dir[3] = {NAN, 0, 1};
        bst_layer *l;
        const char *names[] = {"Visible"};
        ck_assert_int_eq(bst_layer_new(ctx, b, 1, names, &l), BST_OK);
        double ga;
        ck_assert_int_eq(bst_metrics_accordance(ctx, l, l, 0, BST_TF, bst_basis_patch(b, nan_dir), &ga,
                                                NULL, NULL), BST_EINVAL);
        bst_layer_free(l);
    }
    bst_basis_free(bases[0]), bst_basis_free(bases[1]);
}
END_TEST

static Suite *basis_suite(void)
{
    Suite *s = suite_create("basis");
    TCase *tc = tcase_create("basis");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_add_test(tc, test_concentric_examples);
    tcase_add_test(tc, test_polar_cells);
    tcase_add_test(tc, test_sc_patches);
    tcase_add_loop_test(tc, test_klems_against_wce, 0, 3);
    tcase_add_test(tc, test_klems_example);
    tcase_add_test(tc, test_patch_not_finite);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(basis_suite());
}
