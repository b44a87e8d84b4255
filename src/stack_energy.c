/* stack_energy.c - the combination's energy checks: an input layer whose T + R exceeds 1 on some
 * incident patch (a measured or ray-traced layer's noise, or a broken file), and a system whose
 * inter-reflections created energy or made a hemispherical value negative (layers that reflect
 * nearly everything multiply their excess at every inter-reflection).  Both are warnings
 * (BST_WENERGY; errors with --strict, which the caller decides), not-finite values an error. */
#include <config.h>

#include <math.h>

#include "basis.h"
#include "ctx.h"
#include "layer.h"
#include "stack.h"

/* Angles of a patch centre, for messages. */
static double patch_theta_deg(const bst_basis *b, size_t patch)
{
    double d[3];
    bst_basis_center(b, patch, d);
    return acos(fmin(1.0, fabs(d[2]))) * 180.0 / M_PI;
}

static const bst_comp sides[2][2] = {{BST_TF, BST_RF}, {BST_TB, BST_RB}};

int bsti_energy_check_layer(bst_ctx *ctx, const bst_layer *l, size_t li, size_t ch, double tol)
{
    size_t n = bst_basis_size(l->basis);
    double *t = bsti_alloc_array(ctx, 2 * n, sizeof *t);
    if (!t)
        return BST_ENOMEM;
    double *r = t + n;
    int rc = BST_OK;
    for (int side = 0; side < 2 && rc == BST_OK; side++) {
        if ((rc = bst_layer_hemispherical(ctx, l, ch, sides[side][0], t)) < 0 ||
            (rc = bst_layer_hemispherical(ctx, l, ch, sides[side][1], r)) < 0)
            break;
        size_t worst = 0;
        double wv = -1.0;
        for (size_t j = 0; j < n && isfinite(wv); j++) /* a NaN compares false: test it first */
            if (!isfinite(t[j] + r[j]) || t[j] + r[j] > wv)
                wv = t[j] + r[j], worst = j;
        if (!isfinite(wv))
            rc = bsti_error(ctx, BST_EINVAL, "layer %zu (%s), channel %s: non-finite values",
                            li + 1, bst_layer_name(l), l->channels[ch]);
        else if (wv > 1.0 + tol)
            rc = bsti_error(ctx, BST_WENERGY,
                            "layer %zu (%s), channel %s: %s T + R = %.4g > 1 at incident patch %zu "
                            "(theta %.1f deg)", li + 1, bst_layer_name(l), l->channels[ch],
                            side ? "back" : "front", wv, worst, patch_theta_deg(l->basis, worst));
    }
    bsti_free(ctx, t);
    return rc;
}

int bsti_energy_check_result(bst_ctx *ctx, const bst_layer *res, size_t ch, double tol,
                             int warned)
{
    size_t n = bst_basis_size(res->basis);
    double *h = bsti_alloc_array(ctx, 2 * n, sizeof *h);
    if (!h)
        return BST_ENOMEM;
    double *sum = h + n;
    int rc = BST_OK;
    const char *channel = res->channels[ch];
    for (int side = 0; side < 2 && rc == BST_OK; side++) {
        int formed = 0;
        for (size_t j = 0; j < n; j++)
            sum[j] = 0.0;
        for (int k = 0; k < 2 && rc == BST_OK; k++) {
            bst_comp c = sides[side][k];
            if (!bst_layer_get(res, ch, c))
                continue;
            if ((rc = bst_layer_hemispherical(ctx, res, ch, c, h)) < 0)
                break;
            formed++;
            size_t worst = 0;
            for (size_t j = 0; j < n; j++) {
                sum[j] += h[j];
                if (h[j] < h[worst])
                    worst = j;
            }
            if (h[worst] < -tol && !warned)
                rc = bsti_error(ctx, BST_WENERGY, "stack: the system's hemispherical %s, channel "
                                "%s, is %.4g < 0 at incident patch %zu (theta %.1f deg): the inter-"
                                "reflection of layers with T + R > 1", bst_comp_name(c), channel,
                                h[worst], worst, patch_theta_deg(res->basis, worst));
        }
        if (rc != BST_OK || formed == 0)
            break;
        size_t worst = 0;
        for (size_t j = 0; j < n; j++)
            if (sum[j] > sum[worst])
                worst = j;
        if (sum[worst] > 1.0 + tol && !warned)
            rc = bsti_error(ctx, BST_WENERGY, "stack: the system's %s, channel %s, is %.4g > 1 at "
                            "incident patch %zu (theta %.1f deg): the layers' inter-reflection "
                            "creates energy", formed == 2 ? (side ? "back T + R" : "front T + R")
                            : bst_comp_name(bst_layer_get(res, ch, sides[side][0]) ? sides[side][0]
                                                                                     : sides[side][1]),
                            channel, sum[worst], worst, patch_theta_deg(res->basis, worst));
    }
    bsti_free(ctx, h);
    return rc;
}
