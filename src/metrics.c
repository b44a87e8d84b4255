/* metrics.c - comparisons of BSDFs: global and local accordance (Grobe 2017, eq. 6-8) and flux
 * accordance of the light scattered for one incident patch or for each (see
 * bst_metrics_accordance in bsdfstack.h).  Hemispherical integrals are in layer.c (bst_layer_hemispherical). */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "layer.h"

/* The arguments both entry points share. */
static int check_args(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch, bst_comp c)
{
    if (!bst_basis_equal(a->basis, b->basis))
        return bsti_error(ctx, BST_EBASIS, "accordance: the two BSDFs are in different bases");
    if (ch >= a->nchannels || ch >= b->nchannels || (unsigned)c >= BST_NCOMP)
        return bsti_error(ctx, BST_EINVAL, "accordance: channel or component out of range");
    return BST_OK;
}

/* GA, FA and LA (each may be NULL) of column j of ma and mb (either may be NULL: zero).  Eq. (6)'s
 * DSF = BSDF cos(theta_i) takes the incident direction's cosine, the same for every term of one
 * column, so it cancels in (7) and (8); the terms of (7) are weighted by the outgoing patches'
 * projected solid angles L_i (all equal in Shirley-Chiu bases, where this is the paper's plain
 * sum). */
static int column(bst_ctx *ctx, const bst_mat *ma, const bst_mat *mb, const double *lam, size_t n,
                  size_t j, double *ga, double *fa, double *la)
{
    double diff = 0.0, sum = 0.0, d2 = 0.0, s2 = 0.0;
    for (size_t i = 0; i < n; i++) {
        double x = ma ? bst_mat_get(ma, i, j) : 0.0;
        double y = mb ? bst_mat_get(mb, i, j) : 0.0;
        if (!isfinite(x) || !isfinite(y))
            return bsti_error(ctx, BST_EINVAL, "accordance: non-finite value for incident patch %zu, "
                              "outgoing patch %zu", j, i);
        x = fabs(x), y = fabs(y);
        d2 += lam[i] * (x - y) * (x - y), s2 += lam[i] * (x + y) * (x + y);
        diff += lam[i] * fabs(x - y), sum += lam[i] * (x + y);
        if (la)
            la[i] = (x == 0.0 && y == 0.0) ? 100.0 : 100.0 * (1.0 - fabs(x - y) / (x + y));
    }
    if (ga)
        *ga = s2 > 0.0 ? 100.0 * (1.0 - d2 / s2) : 100.0;
    if (fa)
        *fa = sum > 0.0 ? 100.0 * (1.0 - diff / sum) : 100.0;
    return BST_OK;
}

int bst_metrics_accordance(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch,
                           bst_comp c, size_t incident, double *ga, double *fa, double *la)
{
    if (!ctx || !a || !b || (!ga && !fa && !la))
        return ctx ? bsti_error(ctx, BST_EINVAL, "accordance: NULL argument") : BST_EINVAL;
    if (incident >= bst_basis_size(a->basis))
        return bsti_error(ctx, BST_EINVAL, "accordance: incident patch %zu out of range", incident);
    int rc = check_args(ctx, a, b, ch, c);
    if (rc < 0)
        return rc;
    return column(ctx, bst_layer_get(a, ch, c), bst_layer_get(b, ch, c), bst_basis_lambda(a->basis),
                  bst_basis_size(a->basis), incident, ga, fa, la);
}

int bst_metrics_accordance_all(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch,
                               bst_comp c, double *ga, double *fa)
{
    if (!ctx || !a || !b || (!ga && !fa))
        return ctx ? bsti_error(ctx, BST_EINVAL, "accordance: NULL argument") : BST_EINVAL;
    int rc = check_args(ctx, a, b, ch, c);
    if (rc < 0)
        return rc;
    size_t n = bst_basis_size(a->basis);
    const bst_mat *ma = bst_layer_get(a, ch, c), *mb = bst_layer_get(b, ch, c);
    for (size_t j = 0; j < n && rc >= 0; j++)
        rc = column(ctx, ma, mb, bst_basis_lambda(a->basis), n, j, ga ? ga + j : NULL,
                    fa ? fa + j : NULL, NULL);
    return rc;
}
