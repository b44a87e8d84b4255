/* metrics.c - comparisons of BSDFs: global and local accordance (Grobe 2017) of the light
 * scattered for one incident patch.  Hemispherical integrals are in layer.c/stack.c
 * (bst_layer_hemispherical). */
#include <config.h>

#include <math.h>
#include <string.h>

#include "ctx.h"
#include "layer.h"

int bst_accordance(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch, bst_comp c,
                   size_t incident, double *ga, double *la)
{
    if (!ctx || !a || !b || !ga)
        return ctx ? bsti_error(ctx, BST_EINVAL, "accordance: NULL argument") : BST_EINVAL;
    if (!bst_basis_equal(a->basis, b->basis))
        return bsti_error(ctx, BST_EBASIS, "accordance: the two BSDFs are in different bases");
    size_t n = bst_basis_size(a->basis);
    if (ch >= a->nchannels || ch >= b->nchannels || (unsigned)c >= BST_NCOMP || incident >= n)
        return bsti_error(ctx, BST_EINVAL, "accordance: channel, component or incident patch out of range");
    const bst_mat *ma = bst_layer_get(a, ch, c), *mb = bst_layer_get(b, ch, c);
    const double *lam = bst_basis_lambda(a->basis);
    double diff = 0.0, sum = 0.0;
    for (size_t i = 0; i < n; i++) {
        double x = ma ? bst_mat_get(ma, i, incident) : 0.0;
        double y = mb ? bst_mat_get(mb, i, incident) : 0.0;
        if (!isfinite(x) || !isfinite(y))
            return bsti_error(ctx, BST_EINVAL, "accordance: non-finite value at outgoing patch %zu", i);
        diff += lam[i] * fabs(x - y);
        sum += lam[i] * (fabs(x) + fabs(y));
        if (la)
            la[i] = (x == 0.0 && y == 0.0) ? 100.0 : 100.0 * (1.0 - fabs(x - y) / (fabs(x) + fabs(y)));
    }
    *ga = sum > 0.0 ? 100.0 * (1.0 - diff / sum) : 100.0;
    return BST_OK;
}
