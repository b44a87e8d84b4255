/* test_glass_table.c - the angular table of a spectral pane of many rows (glass_layer.c, issue
 * #34 item 10), against the path it replaced.
 *  - The table today: the model's sides with one exponential per evaluation (glass.c), rows of
 *    zero weight (outside the band) passed over, the angles shared among threads.  The reference
 *    here is the path before (kept in this file): every row summed, tau and 1 - tau from exp and
 *    expm1 taken apart.  Every table entry agrees to 1e-12 relative, on a pane of 3000 rows with
 *    transparent, absorbing and opaque (T0 = 0) wavelengths and rows beyond the Solar band.
 *  - One thread and several give the same table and the same layer, to the bit.
 *  - Past BST_GLASS_LAYER_ROWS wavelengths: smooth data are summed in that many groups of adjacent
 *    wavelengths, and the layer's patch values (Lambda x value) stay within 2e-8 of the sum over
 *    every row (bst_glass_set_layer_rows(0), the spec's rows=all); noisy data, where groups would
 *    not agree, are summed row by row, the same layer to the bit; the bound's errors.
 * A layer's patch value is a positive combination of table entries (bsti_glass_table_optics and
 * the patch rule), so its agreement with the reference follows from the table's. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "basis.h"
#include "ctx.h"
#include "glass.h"
#include "testglass.h"
#include "testutil.h"

/* Rows of the made-up pane, and how much the reference may differ (relative). */
#define ROWS 3000
#define TABLE_RTOL 1e-12

/* A spectral pane of ROWS rows over 0.25..3.0 um (the Solar band is 0.3..2.5: some rows weigh 0):
 * T0 from 0 (opaque, in the ultraviolet) through absorbing to 0.9, reflectances that differ by
 * side; values to 8 digits, so that almost no two rows are alike. */
static const char *write_pane(void)
{
    const char *path;
    FILE *fp = tg_create("many.txt", &path);
    for (int i = 0; i < ROWS; i++) {
        double um = 0.25 + 2.75 * i / (ROWS - 1), x = (um - 0.25) / 2.75;
        double t = um < 0.31 ? 0.0 : 0.45 + 0.45 * sin(9.0 * x) * cos(2.0 * x);
        double rf = 0.05 + 0.04 * cos(5.0 * x) * cos(5.0 * x), rb = rf + 0.02 * x;
        if (t < 0.0)
            t = 0.0;
        fprintf(fp, "%.8f %.8f %.8f %.8f %.8f\n", um, t, t, rf, rb);
    }
    fclose(fp);
    return path;
}

/* The side's T and R at theta as the model computed them before (exp and expm1 apart). */
static void ref_side(const struct bsti_glass_side *s, double theta, double *t, double *r)
{
    double ci = cos(theta), si = sin(theta);
    if (theta <= 0.0 || s->coated) {
        bsti_glass_side_optics(s, theta, t, r); /* neither changed: theta = 0 and coated sides */
        return;
    }
    if (theta >= M_PI / 2 || ci <= 0.0) {
        *t = 0.0, *r = 1.0;
        return;
    }
    if (s->t0 == 1.0) {
        *t = s->t0, *r = s->r0;
        return;
    }
    double n = s->n, st = si / n, ct = sqrt((1.0 - st) * (1.0 + st));
    double e = s->ltau0 / ct, tau = exp(e), omt = -expm1(e);
    const double a[2] = {ci, n * ci}, b[2] = {n * ct, ct};
    double tt = 0.0, rr = 0.0;
    for (int x = 0; x < 2; x++) {
        double sum = a[x] + b[x], q = (a[x] - b[x]) / sum;
        double rx = q * q, cx = 4.0 * (a[x] / sum) * (b[x] / sum);
        double tx = 0.0, rrx = rx;
        if (tau > 0.0 && cx > 0.0) {
            tx = tau * cx * cx / ((omt + tau * cx) * (1.0 + tau * rx));
            rrx = rx * (1.0 + tau * tx);
        }
        tt += 0.5 * tx, rr += 0.5 * rrx;
    }
    if (tt + rr > 1.0) {
        if (tt > rr)
            tt = 1.0 - rr;
        else
            rr = 1.0 - tt;
    }
    *t = tt, *r = rr;
}

/* Channel ch at theta as bst_glass_optics computed it before: every row, weight 0 or not. */
static void ref_channel(const bst_glass *g, size_t ch, double theta, double v[4])
{
    const struct bsti_glass_channel *c = &g->ch[ch];
    double s[4] = {0, 0, 0, 0};
    for (size_t k = 0; k < c->nk; k++) {
        double t1, r1, t2, r2;
        ref_side(&c->front[k], theta, &t1, &r1);
        ref_side(&c->back[k], theta, &t2, &r2);
        s[0] += c->w[k] * t1, s[2] += c->w[k] * r1, s[1] += c->w[k] * t2, s[3] += c->w[k] * r2;
    }
    if (s[0] + s[2] > 1.0)
        s[2] = 1.0 - s[0];
    if (s[1] + s[3] > 1.0)
        s[3] = 1.0 - s[1];
    memcpy(v, s, sizeof s);
}

START_TEST(test_table_as_before)
{
    bst_glass *g = tg_parse(tg_ctx, write_pane());
    int solar = bst_glass_find_channel(g, "Solar");
    ck_assert_int_ge(solar, 0);
    const struct bsti_glass_channel *c = &g->ch[solar];
    size_t zero = 0, opaque = 0, absorbing = 0;
    for (size_t k = 0; k < c->nk; k++) {
        zero += c->w[k] == 0.0;
        opaque += c->front[k].t0 == 0.0;
        absorbing += c->front[k].t0 > 0.0 && c->front[k].tau0 < 0.5;
    }
    ck_assert_msg(c->nk == ROWS && zero > 100 && opaque > 10 && absorbing > 100,
                  "the pane lacks a case: %zu rows, %zu of weight 0, %zu opaque, %zu absorbing",
                  c->nk, zero, opaque, absorbing);
    for (size_t ch = 0; ch < bst_glass_nchannels(g); ch++) {
        double *tab = bsti_glass_table(tg_ctx, g, ch), worst = 0;
        ck_assert_ptr_nonnull(tab);
        for (size_t a = 0; a <= BST_GLASS_TABLE_STEPS; a += (ch == (size_t)solar ? 7 : 1)) {
            double v[4];
            ref_channel(g, ch, (double)a / BST_GLASS_TABLE_STEPS * (M_PI / 2), v);
            for (int i = 0; i < 4; i++) {
                double d = fabs(tab[4 * a + (size_t)i] - v[i]);
                double rel = d == 0.0 ? 0.0 : d / fmax(fabs(v[i]), fabs(tab[4 * a + (size_t)i]));
                worst = fmax(worst, rel);
                ck_assert_msg(rel <= TABLE_RTOL, "%s, angle %zu, value %d: %.17g vs %.17g before",
                              bst_glass_channel(g, ch), a, i, tab[4 * a + (size_t)i], v[i]);
            }
        }
        printf("%s: table within %.2g (relative) of the path before\n", bst_glass_channel(g, ch), worst);
        bsti_free(tg_ctx, tab);
    }
    bst_glass_free(g);
}
END_TEST

/* The table and a k = 4 layer (built through the table) on 1 and on 3 threads: the same bits. */
START_TEST(test_threads_same_bits)
{
    bst_glass *g = tg_parse(tg_ctx, write_pane());
    int solar = bst_glass_find_channel(g, "Solar");
    size_t size = 4 * (size_t)(BST_GLASS_TABLE_STEPS + 1) * sizeof(double);
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(tg_ctx, 4, &b), BST_OK);
    double *tab[2];
    bst_layer *l[2];
    for (int i = 0; i < 2; i++) {
        ck_assert_int_eq(bst_ctx_set_threads(tg_ctx, i ? 3 : 1), BST_OK);
        tab[i] = bsti_glass_table(tg_ctx, g, (size_t)solar);
        ck_assert_ptr_nonnull(tab[i]);
        ck_assert_int_eq(bst_glass_layer(tg_ctx, g, b, 0, NULL, 0, &l[i]), BST_OK);
    }
    ck_assert_int_eq(bst_ctx_set_threads(tg_ctx, 0), BST_OK);
    ck_assert(memcmp(tab[0], tab[1], size) == 0);
    size_t n = bst_basis_size(b);
    for (size_t ch = 0; ch < bst_layer_nchannels(l[0]); ch++)
        for (int c = 0; c < BST_NCOMP; c++)
            for (size_t j = 0; j < n; j++) {
                double x = bst_mat_get(bst_layer_get(l[0], ch, (bst_comp)c), j, j);
                double y = bst_mat_get(bst_layer_get(l[1], ch, (bst_comp)c), j, j);
                ck_assert_msg(memcmp(&x, &y, sizeof x) == 0, "channel %zu comp %d patch %zu: %.17g "
                              "on 1 thread, %.17g on 3", ch, c, j, x, y);
            }
    for (int i = 0; i < 2; i++)
        bsti_free(tg_ctx, tab[i]), bst_layer_free(l[i]);
    bst_basis_free(b);
    bst_glass_free(g);
}
END_TEST

/* A pane of rows rows over 0.3..2.5 um: smooth, or with noise of +-0.02 in T and +-0.01 in R
 * (seeded), as a high-resolution measurement may carry. */
static bst_glass *many_rows(const char *name, int rows, int noisy)
{
    const char *path;
    FILE *fp = tg_create(name, &path);
    tu_rng rng;
    tu_rng_seed(&rng, 34);
    for (int i = 0; i < rows; i++) {
        double um = 0.3 + 2.2 * i / (rows - 1), x = (um - 0.3) / 2.2;
        double t = 0.45 + 0.25 * sin(15.4 * x), r = 0.07 + 0.02 * cos(11.0 * x);
        if (noisy)
            t += 0.04 * (tu_rng_uniform(&rng) - 0.5), r += 0.02 * (tu_rng_uniform(&rng) - 0.5);
        fprintf(fp, "%.8f %.6f %.6f %.6f %.6f\n", um, t, t - 0.01, r, r + 0.01);
    }
    fclose(fp);
    return tg_parse(tg_ctx, path);
}

/* The largest |Lambda (a - b)| over the patch values of two layers over b. */
static double layer_gap(const bst_layer *a, const bst_layer *b, const bst_basis *basis)
{
    const double *lam = bst_basis_lambda(basis);
    double worst = 0;
    for (size_t ch = 0; ch < bst_layer_nchannels(a); ch++)
        for (int c = 0; c < BST_NCOMP; c++)
            for (size_t j = 0; j < bst_basis_size(basis); j++)
                worst = fmax(worst, lam[j] * fabs(bst_mat_get(bst_layer_get(a, ch, (bst_comp)c), j, j) -
                                                  bst_mat_get(bst_layer_get(b, ch, (bst_comp)c), j, j)));
    return worst;
}

START_TEST(test_rows_bound)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(tg_ctx, 4, &b), BST_OK);
    for (int noisy = 0; noisy < 2; noisy++) {
        bst_glass *g = many_rows(noisy ? "noisy.txt" : "smooth.txt", 12000, noisy);
        size_t solar = (size_t)bst_glass_find_channel(g, "Solar"), rows;
        size_t nodes = bst_glass_layer_nodes(g, solar, &rows);
        ck_assert_uint_eq(rows, 11999); /* the solar source is 0 at 0.3 um */
        ck_assert_uint_eq(nodes, noisy ? rows : BST_GLASS_LAYER_ROWS);
        bst_layer *grouped, *every;
        ck_assert_int_eq(bst_glass_layer(tg_ctx, g, b, 0, NULL, 0, &grouped), BST_OK);
        ck_assert_int_eq(bst_glass_set_layer_rows(tg_ctx, g, 0), BST_OK);
        ck_assert_uint_eq(bst_glass_layer_nodes(g, solar, NULL), rows);
        ck_assert_int_eq(bst_glass_layer(tg_ctx, g, b, 0, NULL, 0, &every), BST_OK);
        double gap = layer_gap(grouped, every, b);
        printf("%s 12000 rows, k = 4: %zu nodes, patch values within %.3g of every row's\n",
               noisy ? "noisy" : "smooth", nodes, gap);
        if (noisy)
            ck_assert(gap == 0.0);
        else
            ck_assert_msg(gap > 0.0 && gap <= 2e-8, "grouped layer %.3g from every row's", gap);
        bst_layer_free(grouped), bst_layer_free(every);
        bst_glass_free(g);
    }
    bst_basis_free(b);
    /* the bound's values: rows=all in a spec is 0, 1 is refused (a group needs two rows) */
    bst_glass *g = tg_parse(tg_ctx, "clear-6mm,rows=all");
    ck_assert_int_eq(bst_glass_set_layer_rows(tg_ctx, g, 1), BST_EINVAL);
    ck_assert_int_eq(bst_glass_set_layer_rows(tg_ctx, g, 2), BST_OK);
    bst_glass_free(g);
    tg_refused(tg_ctx, "clear-6mm,rows=1", "rows=1 (all, or a count of at least 2)");
    tg_refused(tg_ctx, "clear-6mm,rows=12x", "rows=12x (all, or a count of at least 2)");
    tg_refused(tg_ctx, "clear-6mm,rows=all,rows=9", "rows given twice");
}
END_TEST

int main(void)
{
    const TTest *const tests[] = {test_table_as_before, test_threads_same_bits, test_rows_bound};
    return tu_run(tg_suite("glass_table", tg_setup, tg_teardown, 300, tests,
                           sizeof tests / sizeof tests[0]));
}
