/* ttree_varres.c - the order-k tensor of a variable-resolution tree (bsti_varres, ttree_write.h):
 * fine columns at their incident cells, every other cell the value of the coarse cell holding it,
 * read by bsti_ttree_write through bsti_varres_get; and the consistency of the two parts
 * (bst_varres_hemi_diff). */
#include <config.h>

#include <math.h>

#include "basis.h"
#include "ctx.h"
#include "mat.h"
#include "ttree_write.h"

int bsti_varres_init(bst_ctx *ctx, bsti_varres *v)
{
    v->slot = NULL;
    v->in = NULL;
    if (v->kc < 1 || v->k <= v->kc || v->k > BST_K_MAX)
        return bsti_error(ctx, BST_EINVAL, "variable resolution: orders k = %d over kc = %d (need "
                          "1 <= kc < k <= %d)", v->k, v->kc, BST_K_MAX);
    size_t N = (size_t)1 << (2 * v->k), Nc = (size_t)1 << (2 * v->kc);
    if (v->coarse && (v->coarse->rows != Nc || v->coarse->cols != Nc))
        return bsti_error(ctx, BST_ESIZE, "variable resolution: coarse matrix %zu x %zu, not %zu x %zu",
                          v->coarse->rows, v->coarse->cols, Nc, Nc);
    if (v->fine && (v->fine->rows != N || v->fine->cols != v->ncols))
        return bsti_error(ctx, BST_ESIZE, "variable resolution: fine columns %zu x %zu, not %zu x %zu",
                          v->fine->rows, v->fine->cols, N, v->ncols);
    for (size_t q = 0; q < v->ncols; q++)
        if (v->cols[q] >= N || (q && v->cols[q] <= v->cols[q - 1]))
            return bsti_error(ctx, BST_EINVAL, "variable resolution: fine patch %zu (of %zu) is out "
                              "of order or beyond %zu", v->cols[q], q, N);
    v->slot = bsti_alloc_array(ctx, N, sizeof *v->slot);
    v->in = bsti_calloc(ctx, N, 1);
    if (!v->slot || !v->in) {
        bsti_varres_done(ctx, v);
        return BST_ENOMEM;
    }
    for (size_t i = 0; i < N; i++)
        v->slot[i] = -1;
    for (size_t q = 0; v->fine && q < v->ncols; q++) {
        v->slot[v->cols[q]] = (long)q;
        v->in[v->cols[q]] = 1;
    }
    return BST_OK;
}

void bsti_varres_done(bst_ctx *ctx, bsti_varres *v)
{
    bsti_free(ctx, v->slot);
    bsti_free(ctx, v->in);
    v->slot = NULL;
    v->in = NULL;
}

double bsti_varres_get(const void *opaque, size_t index)
{
    const bsti_varres *v = opaque;
    size_t G = (size_t)1 << v->k, N = G * G, i = index / N, o = index % N;
    if (v->slot[i] >= 0)
        return bsti_mat_at(v->fine, o, (size_t)v->slot[i]);
    int s = v->k - v->kc;
    size_t Gc = G >> s;
    size_t ci = ((i / G) >> s) * Gc + ((i % G) >> s), co = ((o / G) >> s) * Gc + ((o % G) >> s);
    return bsti_mat_at(v->coarse, co, ci);
}

int bst_varres_hemi_diff(bst_ctx *ctx, const bst_layer *coarse, const bst_varres *v, size_t ch,
                         bst_comp c, double *diff, double *worst)
{
    if (!ctx)
        return BST_EINVAL;
    if (!coarse || !v || !diff || (c != BST_TF && c != BST_RF) || ch >= bst_layer_nchannels(coarse))
        return bsti_error(ctx, BST_EINVAL, "variable resolution: NULL argument, channel %zu or "
                          "component %s", ch, bst_comp_name(c));
    const bst_basis *b = bst_layer_basis(coarse);
    int kc = bst_basis_order(b);
    if (bst_basis_kind_of(b) != BST_BASIS_SHIRLEY_CHIU || v->k <= kc || v->k > BST_K_MAX)
        return bsti_error(ctx, BST_EINVAL, "variable resolution: fine order %d over a coarse "
                          "basis of order %d", v->k, kc);
    size_t Nc = bst_basis_size(b), G = (size_t)1 << v->k, N = G * G;
    int sh = v->k - kc;
    const bst_mat *const *fine = c == BST_TF ? v->tf : v->rf;
    const bst_mat *f = fine ? fine[ch] : NULL;
    double *hc = bsti_alloc_array(ctx, Nc, sizeof *hc), *hf = bsti_alloc_array(ctx, v->ncols + 1, sizeof *hf);
    int rc = hc && hf ? BST_OK : BST_ENOMEM;
    if (rc >= 0)
        rc = bst_layer_hemispherical(ctx, coarse, ch, c, hc);
    if (rc >= 0 && f) {
        if (f->rows != N || f->cols != v->ncols)
            rc = bsti_error(ctx, BST_ESIZE, "variable resolution: fine columns %zu x %zu, not %zu x %zu",
                            f->rows, f->cols, N, v->ncols);
        double lam = M_PI / (double)N;
        double *w = rc >= 0 ? bsti_alloc_array(ctx, N, sizeof *w) : NULL;
        if (rc >= 0 && !w)
            rc = BST_ENOMEM;
        for (size_t o = 0; w && o < N; o++)
            w[o] = lam;
        if (rc >= 0)
            rc = bst_mat_col_weighted_sum(ctx, f, w, hf);
        bsti_free(ctx, w);
    }
    double big = 0.0;
    for (size_t q = 0; rc >= 0 && q < v->ncols; q++) {
        size_t i = v->cols[q], Gc = G >> sh;
        size_t ci = ((i / G) >> sh) * Gc + ((i % G) >> sh);
        diff[q] = f ? hf[q] - hc[ci] : 0.0;
        big = fmax(big, fabs(diff[q]));
    }
    if (rc >= 0 && worst)
        *worst = big;
    bsti_free(ctx, hc), bsti_free(ctx, hf);
    return rc;
}
