/* layer.c - a layer (or combined stack): per spectral channel the four components Tf, Rf, Tb, Rb,
 * each an N x N bst_mat over the layer's basis (column = incident patch, row = outgoing patch,
 * BSDF in 1/sr; index convention in bsdfstack.h).  A component may be absent (NULL): absent is not
 * the same as zero, a reader decides what an absent component means.  Directional-hemispherical
 * values weight a column's rows by the outgoing patches' Lambda. */
#include <config.h>

#include <string.h>
#include <strings.h>

#include "basis.h"
#include "ctx.h"
#include "layer.h"
#include "mat.h"

static const char *const comp_names[BST_NCOMP] = {"Tf", "Rf", "Tb", "Rb"};

const char *bst_comp_name(bst_comp c)
{
    return (unsigned)c < BST_NCOMP ? comp_names[c] : "?";
}

int bst_comp_parse(const char *name)
{
    if (!name)
        return -1;
    for (int c = 0; c < BST_NCOMP; c++)
        if (strcasecmp(name, comp_names[c]) == 0)
            return c;
    return -1;
}

int bst_layer_new(bst_ctx *ctx, const bst_basis *basis, size_t nchannels,
                  const char *const *channels, bst_layer **out)
{
    if (!ctx || !out)
        return BST_EINVAL;
    *out = NULL;
    if (!basis || nchannels == 0 || !channels)
        return bsti_error(ctx, BST_EINVAL, "layer: a basis and at least one channel are required");
    for (size_t c = 0; c < nchannels; c++) {
        if (!channels[c] || !*channels[c])
            return bsti_error(ctx, BST_EINVAL, "layer: channel %zu has no name", c);
        for (size_t d = 0; d < c; d++)
            if (strcasecmp(channels[c], channels[d]) == 0)
                return bsti_error(ctx, BST_EINVAL, "layer: channel '%s' given twice", channels[c]);
    }
    bst_layer *l = bsti_calloc(ctx, 1, sizeof *l);
    if (!l)
        return BST_ENOMEM;
    l->ctx = ctx;
    l->nchannels = nchannels;
    l->channels = bsti_calloc(ctx, nchannels, sizeof *l->channels);
    l->comp = bsti_calloc(ctx, nchannels * BST_NCOMP, sizeof *l->comp);
    int rc = (l->channels && l->comp) ? BST_OK : BST_ENOMEM;
    for (size_t c = 0; rc == BST_OK && c < nchannels; c++)
        if (!(l->channels[c] = bsti_strdup(ctx, channels[c])))
            rc = BST_ENOMEM;
    if (rc == BST_OK)
        rc = bst_basis_copy(ctx, basis, &l->basis);
    if (rc < 0) {
        if (!l->channels) /* nothing else to free beyond the struct's own arrays */
            l->nchannels = 0;
        bst_layer_free(l);
        return rc;
    }
    *out = l;
    return BST_OK;
}

void bst_layer_free(bst_layer *l)
{
    if (!l)
        return;
    bst_ctx *ctx = l->ctx;
    if (l->comp)
        for (size_t i = 0; i < l->nchannels * BST_NCOMP; i++)
            bst_mat_free(l->comp[i]);
    if (l->channels)
        for (size_t c = 0; c < l->nchannels; c++)
            bsti_free(ctx, l->channels[c]);
    bsti_free(ctx, l->comp);
    bsti_free(ctx, l->channels);
    bsti_free(ctx, l->name);
    bst_basis_free(l->basis);
    bsti_free(ctx, l);
}

const bst_basis *bst_layer_basis(const bst_layer *l)
{
    return l ? l->basis : NULL;
}

size_t bst_layer_nchannels(const bst_layer *l)
{
    return l ? l->nchannels : 0;
}

const char *bst_layer_channel(const bst_layer *l, size_t channel)
{
    return (l && channel < l->nchannels) ? l->channels[channel] : NULL;
}

int bst_layer_find_channel(const bst_layer *l, const char *name)
{
    if (!l || !name)
        return -1;
    for (size_t c = 0; c < l->nchannels; c++)
        if (strcasecmp(l->channels[c], name) == 0)
            return (int)c;
    return -1;
}

const bst_mat *bst_layer_get(const bst_layer *l, size_t channel, bst_comp c)
{
    if (!l || channel >= l->nchannels || (unsigned)c >= BST_NCOMP)
        return NULL;
    return l->comp[channel * BST_NCOMP + c];
}

int bst_layer_set(bst_ctx *ctx, bst_layer *l, size_t channel, bst_comp c, bst_mat *m)
{
    if (!ctx || !l || !m) {
        bst_mat_free(m);
        return ctx ? bsti_error(ctx, BST_EINVAL, "layer: NULL layer or matrix") : BST_EINVAL;
    }
    if (channel >= l->nchannels || (unsigned)c >= BST_NCOMP) {
        bst_mat_free(m);
        return bsti_error(ctx, BST_EINVAL, "layer: channel %zu or component %d out of range",
                          channel, (int)c);
    }
    size_t n = bst_basis_size(l->basis);
    if (bst_mat_rows(m) != n || bst_mat_cols(m) != n) {
        int rc = bsti_error(ctx, BST_ESIZE, "layer: %s of channel '%s' is %zu x %zu, basis needs %zu x %zu",
                            bst_comp_name(c), l->channels[channel], bst_mat_rows(m),
                            bst_mat_cols(m), n, n);
        bst_mat_free(m);
        return rc;
    }
    bst_mat **slot = &l->comp[channel * BST_NCOMP + c];
    bst_mat_free(*slot);
    *slot = m;
    return BST_OK;
}

bst_mat *bst_layer_take(bst_layer *l, size_t channel, bst_comp c)
{
    if (!l || channel >= l->nchannels || (unsigned)c >= BST_NCOMP)
        return NULL;
    bst_mat **slot = &l->comp[channel * BST_NCOMP + c];
    bst_mat *m = *slot;
    *slot = NULL;
    return m;
}

int bst_layer_set_name(bst_ctx *ctx, bst_layer *l, const char *name)
{
    if (!ctx || !l || !name)
        return ctx ? bsti_error(ctx, BST_EINVAL, "layer: NULL name") : BST_EINVAL;
    char *d = bsti_strdup(ctx, name);
    if (!d)
        return BST_ENOMEM;
    bsti_free(ctx, l->name);
    l->name = d;
    return BST_OK;
}

const char *bst_layer_name(const bst_layer *l)
{
    return (l && l->name) ? l->name : "";
}

/* The mirror x -> -x of every patch, as a symmetric permutation matrix P (P = P^T = P^-1). */
static int mirror_x_permutation(bst_ctx *ctx, const bst_basis *b, bst_mat **out)
{
    size_t n = bst_basis_size(b);
    size_t *row = bsti_alloc_array(ctx, 2 * n, sizeof *row);
    double *one = bsti_alloc_array(ctx, n, sizeof *one);
    int rc = (row && one) ? BST_OK : BST_ENOMEM;
    if (rc == BST_OK) {
        size_t *col = row + n;
        for (size_t j = 0; j < n; j++) {
            row[j] = bsti_basis_mirror_x(b, j);
            col[j] = j;
            one[j] = 1.0;
        }
        rc = bst_mat_new_sparse(ctx, n, n, n, row, col, one, out);
    }
    bsti_free(ctx, row);
    bsti_free(ctx, one);
    return rc;
}

/* The mirrored maps of one flip: an untagged map (a venetian blind's strips) mirrored once for
 * every component over it, so that they stay over one map. */
struct mirrored {
    const bsti_lr_map *from;
    bsti_lr_map *to;
};

/* P M P for a FACTORED M and the mirror P, in M's factors: over M's own map where the mirror maps
 * its lines onto lines (bsti_lr_permute: prolongations), over the mirrored map for an untagged
 * one (bsti_lr_permute_over, *mm keeping it for the next component); BST_ENOTFOUND otherwise. */
static int mirror_factored(bst_ctx *ctx, const bst_basis *b, const bst_mat *m, struct mirrored *mm,
                           bst_mat **out)
{
    size_t n = bst_basis_size(b);
    size_t *perm = bsti_alloc_array(ctx, n, sizeof *perm);
    if (!perm)
        return BST_ENOMEM;
    for (size_t j = 0; j < n; j++)
        perm[j] = bsti_basis_mirror_x(b, j);
    bsti_lr *lr;
    int rc = bsti_lr_permute(ctx, m->lr, perm, &lr);
    if (rc == BST_ENOTFOUND && !m->lr->S->tag[0]) {
        rc = BST_OK;
        if (mm->from != m->lr->S) {
            bsti_lr_map_free(ctx, mm->to);
            mm->to = NULL, mm->from = m->lr->S;
            rc = bsti_lr_map_permuted(ctx, m->lr->S, perm, &mm->to);
        }
        if (rc >= 0)
            rc = bsti_lr_permute_over(ctx, m->lr, perm, mm->to, &lr);
    }
    bsti_free(ctx, perm);
    return rc < 0 ? rc : bsti_mat_from_lr(ctx, lr, out);
}

int bst_layer_flip(bst_ctx *ctx, const bst_layer *l, bst_layer **out)
{
    if (!ctx || !l || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "flip: NULL argument") : BST_EINVAL;
    *out = NULL;
    bst_mat *p = NULL;
    bst_layer *f = NULL;
    struct mirrored mm = {NULL, NULL};
    int rc = mirror_x_permutation(ctx, l->basis, &p);
    if (rc >= 0)
        rc = bst_layer_new(ctx, l->basis, l->nchannels, (const char *const *)l->channels, &f);
    if (rc >= 0 && l->name)
        rc = bst_layer_set_name(ctx, f, l->name);
    /* Seen from the other side, front becomes back: Tf' = P Tb P, Rf' = P Rb P, and so on. */
    static const bst_comp other[BST_NCOMP] = {BST_TB, BST_RB, BST_TF, BST_RF};
    for (size_t ch = 0; rc >= 0 && ch < l->nchannels; ch++)
        for (int c = 0; rc >= 0 && c < BST_NCOMP; c++) {
            const bst_mat *m = bst_layer_get(l, ch, other[c]);
            if (!m)
                continue;
            bst_mat *pm = NULL, *pmp = NULL, *res = NULL;
            if (bst_mat_structure(m) == BST_FACTORED) { /* permuted in its factors */
                rc = mirror_factored(ctx, l->basis, m, &mm, &res);
                if (rc != BST_ENOTFOUND) {
                    if (rc >= 0)
                        rc = bst_layer_set(ctx, f, ch, (bst_comp)c, res);
                    continue;
                }
                rc = BST_OK; /* a map the mirror does not keep: through the values, dense */
            }
            rc = bst_mat_mul(ctx, p, m, 0.0, &pm);
            if (rc >= 0)
                rc = bst_mat_mul(ctx, pm, p, 0.0, &pmp);
            bst_mat_free(pm);
            /* keep the input's structure: a permuted diagonal is diagonal again */
            if (rc >= 0 && bst_mat_structure(pmp) != bst_mat_structure(m) &&
                bst_mat_structure(m) != BST_FACTORED) {
                rc = bst_mat_convert(ctx, pmp, bst_mat_structure(m), bst_mat_precision(m), &res);
                bst_mat_free(pmp);
            } else {
                res = pmp;
            }
            if (rc >= 0)
                rc = bst_layer_set(ctx, f, ch, (bst_comp)c, res);
        }
    bst_mat_free(p);
    bsti_lr_map_free(ctx, mm.to);
    if (rc < 0) {
        bst_layer_free(f);
        return rc;
    }
    *out = f;
    return BST_OK;
}

int bst_layer_hemispherical(bst_ctx *ctx, const bst_layer *l, size_t ch, bst_comp c, double *out)
{
    if (!ctx || !l || !out || ch >= l->nchannels || (unsigned)c >= BST_NCOMP)
        return ctx ? bsti_error(ctx, BST_EINVAL, "hemispherical: invalid argument") : BST_EINVAL;
    size_t n = bst_basis_size(l->basis);
    const bst_mat *m = bst_layer_get(l, ch, c);
    if (!m) {
        memset(out, 0, n * sizeof *out);
        return BST_OK;
    }
    return bst_mat_col_weighted_sum(ctx, m, bst_basis_lambda(l->basis), out);
}
