/* ttree_varres.c - the order-k tensor of a variable-resolution tree (bsti_varres, ttree_write.h):
 * fine columns at their incident cells, every other cell the value of the coarse cell holding it,
 * read by bsti_ttree_write through bsti_varres_get. */
#include <config.h>

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
