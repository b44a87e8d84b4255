/* metrics.c - comparisons of BSDFs: global, flux and local accordance of the light scattered for
 * one incident patch or for each (see bst_accordance in bsdfstack.h).  Hemispherical integrals are
 * in layer.c (bst_layer_hemispherical). */
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

/* The arguments both entry points share; on success *mu holds the patch cosines. */
static int check_args(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch, bst_comp c,
                      double **mu)
{
    if (!bst_basis_equal(a->basis, b->basis))
        return bsti_error(ctx, BST_EBASIS, "accordance: the two BSDFs are in different bases");
    if (ch >= a->nchannels || ch >= b->nchannels || (unsigned)c >= BST_NCOMP)
        return bsti_error(ctx, BST_EINVAL, "accordance: channel or component out of range");
    size_t n = bst_basis_size(a->basis);
    if (!(*mu = malloc(n * sizeof **mu)))
        return bsti_error(ctx, BST_ENOMEM, "accordance: out of memory");
    patch_cosines(a->basis, n, *mu);
    return BST_OK;
}

/* GA, FA and LA (each may be NULL) of column j of ma and mb (either may be NULL: zero). */
static int column(bst_ctx *ctx, const bst_mat *ma, const bst_mat *mb, const double *lam,
                  const double *mu, size_t n, size_t j, double *ga, double *fa, double *la)
{
    double diff = 0.0, sum = 0.0, ab = 0.0, aa = 0.0, bb = 0.0;
    for (size_t i = 0; i < n; i++) {
        double x = ma ? bst_mat_get(ma, i, j) : 0.0;
        double y = mb ? bst_mat_get(mb, i, j) : 0.0;
        if (!isfinite(x) || !isfinite(y))
            return bsti_error(ctx, BST_EINVAL, "accordance: non-finite value for incident patch %zu, "
                              "outgoing patch %zu", j, i);
        x = fabs(x), y = fabs(y);
        /* DSF products integrated over solid angle: BSDF * BSDF * cos^2 * (L / cos) */
        double w = lam[i] * mu[i];
        ab += w * x * y, aa += w * x * x, bb += w * y * y;
        diff += lam[i] * fabs(x - y), sum += lam[i] * (x + y);
        if (la)
            la[i] = (x == 0.0 && y == 0.0) ? 100.0 : 100.0 * (1.0 - fabs(x - y) / (x + y));
    }
    if (ga)
        *ga = aa == 0.0 && bb == 0.0 ? 100.0 : aa == 0.0 || bb == 0.0 ? 0.0 : fmin(100.0, 100.0 * ab / sqrt(aa * bb));
    if (fa)
        *fa = sum > 0.0 ? 100.0 * (1.0 - diff / sum) : 100.0;
    return BST_OK;
}

int bst_accordance(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch, bst_comp c,
                   size_t incident, double *ga, double *fa, double *la)
{
    if (!ctx || !a || !b || (!ga && !fa && !la))
        return ctx ? bsti_error(ctx, BST_EINVAL, "accordance: NULL argument") : BST_EINVAL;
    if (incident >= bst_basis_size(a->basis))
        return bsti_error(ctx, BST_EINVAL, "accordance: incident patch %zu out of range", incident);
    double *mu;
    int rc = check_args(ctx, a, b, ch, c, &mu);
    if (rc < 0)
        return rc;
    rc = column(ctx, bst_layer_get(a, ch, c), bst_layer_get(b, ch, c), bst_basis_lambda(a->basis), mu,
                bst_basis_size(a->basis), incident, ga, fa, la);
    free(mu);
    return rc;
}

int bst_accordance_all(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch, bst_comp c,
                       double *ga, double *fa)
{
    if (!ctx || !a || !b || (!ga && !fa))
        return ctx ? bsti_error(ctx, BST_EINVAL, "accordance: NULL argument") : BST_EINVAL;
    double *mu;
    int rc = check_args(ctx, a, b, ch, c, &mu);
    if (rc < 0)
        return rc;
    size_t n = bst_basis_size(a->basis);
    const bst_mat *ma = bst_layer_get(a, ch, c), *mb = bst_layer_get(b, ch, c);
    for (size_t j = 0; j < n && rc >= 0; j++)
        rc = column(ctx, ma, mb, bst_basis_lambda(a->basis), mu, n, j, ga ? ga + j : NULL,
                    fa ? fa + j : NULL, NULL);
    free(mu);
    return rc;
}
