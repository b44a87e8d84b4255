/* test_glass_table.c - the angular table of a spectral pane of many rows (glass_layer.c, issue
 * #34 item 10), against the path it replaced.
 *  - The table today: the model's sides with one exponential per evaluation (glass.c), rows of
 *    zero weight (outside the band) passed over, the angles shared among threads.  The reference
 *    here is the path before (kept in this file): every row summed, tau and 1 - tau from exp and
 *    expm1 taken apart.  Every table entry agrees to 1e-12 relative, on a pane of 3000 rows with
 *    transparent, absorbing and opaque (T0 = 0) wavelengths and rows beyond the Solar band.
 *  - One thread and several give the same table and the same layer, to the bit.
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

int main(void)
{
    const TTest *const tests[] = {test_table_as_before, test_threads_same_bits};
    return tu_run(tg_suite("glass_table", tg_setup, tg_teardown, 300, tests,
                           sizeof tests / sizeof tests[0]));
}
