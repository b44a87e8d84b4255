/* metrics.c - comparisons of BSDFs: global, flux and local accordance of the light scattered for
 * one incident patch (see bst_accordance in bsdfstack.h).  Hemispherical integrals are in
 * layer.c/stack.c (bst_layer_hemispherical). */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "layer.h"

/* Mean cos(theta) of each patch over its projected solid angle (4 x 4 stratified points): the
 * DSF of patch i is its BSDF value times this. */
static void patch_cosines(const bst_basis *b, size_t n, double *mu)
{
    enum { S = 4 };
    for (size_t i = 0; i < n; i++) {
        double sum = 0.0, d[3];
        for (int u = 0; u < S; u++)
            for (int v = 0; v < S; v++) {
                bst_basis_sample(b, i, (u + 0.5) / S, (v + 0.5) / S, d);
                sum += fabs(d[2]);
            }
        mu[i] = sum / (S * S);
    }
}

int bst_accordance(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch, bst_comp c,
                   size_t incident, double *ga, double *fa, double *la)
{
    if (!ctx || !a || !b || (!ga && !fa && !la))
        return ctx ? bsti_error(ctx, BST_EINVAL, "accordance: NULL argument") : BST_EINVAL;
    if (!bst_basis_equal(a->basis, b->basis))
        return bsti_error(ctx, BST_EBASIS, "accordance: the two BSDFs are in different bases");
    size_t n = bst_basis_size(a->basis);
    if (ch >= a->nchannels || ch >= b->nchannels || (unsigned)c >= BST_NCOMP || incident >= n)
        return bsti_error(ctx, BST_EINVAL, "accordance: channel, component or incident patch out of range");
    double *mu = malloc(n * sizeof *mu);
    if (!mu)
        return bsti_error(ctx, BST_ENOMEM, "accordance: out of memory");
    patch_cosines(a->basis, n, mu);
    const bst_mat *ma = bst_layer_get(a, ch, c), *mb = bst_layer_get(b, ch, c);
    const double *lam = bst_basis_lambda(a->basis);
    double diff = 0.0, sum = 0.0, ab = 0.0, aa = 0.0, bb = 0.0;
    for (size_t i = 0; i < n; i++) {
        double x = ma ? bst_mat_get(ma, i, incident) : 0.0;
        double y = mb ? bst_mat_get(mb, i, incident) : 0.0;
        if (!isfinite(x) || !isfinite(y)) {
            free(mu);
            return bsti_error(ctx, BST_EINVAL, "accordance: non-finite value at outgoing patch %zu", i);
        }
        x = fabs(x), y = fabs(y);
        /* DSF products integrated over solid angle: BSDF * BSDF * cos^2 * (L / cos) */
        double w = lam[i] * mu[i];
        ab += w * x * y, aa += w * x * x, bb += w * y * y;
        diff += lam[i] * fabs(x - y), sum += lam[i] * (x + y);
        if (la)
            la[i] = (x == 0.0 && y == 0.0) ? 100.0 : 100.0 * (1.0 - fabs(x - y) / (x + y));
    }
    free(mu);
    if (ga)
        *ga = aa == 0.0 && bb == 0.0 ? 100.0 : aa == 0.0 || bb == 0.0 ? 0.0 : fmin(100.0, 100.0 * ab / sqrt(aa * bb));
    if (fa)
        *fa = sum > 0.0 ? 100.0 * (1.0 - diff / sum) : 100.0;
    return BST_OK;
}
