/* spectral.c - stacks of spectral panes combined wavelength by wavelength and averaged afterwards,
 * as Windows-CalcEngine and WINDOW do for multi-layer systems.  Combining band-averaged panes is
 * not the same: the system's T is not linear in the panes' T and R (NFRC 102 / 103 at normal
 * incidence, solar: 0.652314 per wavelength vs 0.645986 from band averages).
 *
 * The average of a system property over a band is linear in the per-wavelength system, so the
 * band's matrices are sum_k w_k M(lambda_k) with bst_glass_channel_weights' w: each wavelength is
 * combined once, added with its weight, and freed.  Wavelengths of zero weight are skipped.
 * A band channel (Visible, Solar, CIE-X, CIE-Y, CIE-Z) missing from panes[0] is added to it; its
 * wavelengths are the union of the panes' measured ones, or the band's integration grid when that
 * is shorter (WCE's rule).  Every matrix is diagonal: O(N) per wavelength. */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "glass.h"
#include "layer.h"

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The union of the panes' measured wavelengths, sorted, duplicates (within 1e-9 um) removed. */
static int union_grid(bst_ctx *ctx, size_t n, bst_glass *const *panes, double **wl, size_t *nwl)
{
    size_t total = 0;
    for (size_t i = 0; i < n; i++)
        total += bst_glass_nwavelengths(panes[i]);
    double *w = bsti_alloc_array(ctx, total, sizeof *w);
    if (!w)
        return BST_ENOMEM;
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        for (size_t k = 0; k < bst_glass_nwavelengths(panes[i]); k++)
            w[m++] = bst_glass_wavelength(panes[i], k);
    qsort(w, m, sizeof *w, cmp_double);
    size_t u = 0;
    for (size_t k = 0; k < m; k++)
        if (u == 0 || w[k] - w[u - 1] > 1e-9)
            w[u++] = w[k];
    *wl = w;
    *nwl = u;
    return BST_OK;
}

/* The wavelengths channel `name` of pane g is combined on, by WCE's rule: the union of the
 * layers' wavelengths (all[0..nall-1]), or the band's own integration grid when that is shorter
 * (Visible: 81 wavelengths instead of a few hundred).  NULL if the channel is not a band. */
static const double *wavelengths(const bst_glass *g, const char *name, const double *all,
                                 size_t nall, size_t *n)
{
    size_t ng;
    const double *grid = bst_glass_channel_grid(g, (size_t)bst_glass_find_channel(g, name), &ng);
    *n = grid && ng < nall ? ng : nall;
    return !grid ? NULL : ng < nall ? grid : all;
}

/* acc[c] += w * m[c] for the requested components (acc[c] == NULL: acc[c] = w * m[c]). */
static int accumulate(bst_ctx *ctx, bst_mat **acc, const bst_layer *sys, unsigned want, double w)
{
    for (int c = 0; c < BST_NCOMP; c++) {
        if (!(want & BST_COMP_BIT(c)))
            continue;
        const bst_mat *m = bst_layer_get(sys, 0, (bst_comp)c);
        bst_mat *sum;
        int rc = acc[c] ? bst_mat_add(ctx, 1.0, acc[c], w, m, &sum) : bst_mat_add(ctx, w, m, 0.0, m, &sum);
        if (rc < 0)
            return rc;
        bst_mat_free(acc[c]);
        acc[c] = sum;
    }
    return BST_OK;
}

int bst_stack_combine_spectral(bst_ctx *ctx, size_t n, bst_glass *const *panes,
                               const bst_basis *basis, size_t nchannels,
                               const char *const *channels, int at_centre,
                               const bst_stack_opts *opts_in, bst_layer **out, double *abs_front,
                               double *abs_back)
{
    if (!ctx || !out)
        return BST_EINVAL;
    *out = NULL;
    if (n == 0 || !panes || !basis || nchannels == 0 || !channels)
        return bsti_error(ctx, BST_EINVAL, "spectral stack: no panes, basis or channels");
    for (size_t i = 0; i < n; i++) {
        if (!panes[i])
            return bsti_error(ctx, BST_EINVAL, "spectral stack: pane %zu is NULL", i + 1);
        if (!bst_glass_nwavelengths(panes[i]))
            return bsti_error(ctx, BST_EINVAL, "spectral stack: layer %zu (%s) has no spectral "
                              "data: combine per channel with bst_stack_combine", i + 1,
                              bst_glass_description(panes[i]));
    }
    bst_stack_opts defaults;
    bst_stack_opts_init(&defaults);
    const bst_stack_opts *opts = opts_in ? opts_in : &defaults;
    unsigned want = opts->comps ? opts->comps & BST_COMP_ALL : BST_COMP_ALL;
    int want_abs = abs_front || abs_back;

    size_t N = bst_basis_size(basis), nwl = 0, nall = 0;
    double *all = NULL, *w = NULL, *af = NULL, *ab = NULL;
    bst_layer **lay = bsti_calloc(ctx, n, sizeof *lay), *res = NULL, *sys = NULL;
    bst_mat *acc[BST_NCOMP] = {NULL};
    bst_progress_fn progress = ctx->progress_fn;
    bsti_glass_rule *rule = NULL;
    int rc = lay ? union_grid(ctx, n, panes, &all, &nall) : BST_ENOMEM;
    if (rc >= 0)
        rc = bsti_glass_rule_new(ctx, basis, at_centre, BST_GLASS_SAMPLES, &rule);
    if (rc >= 0)
        rc = bst_layer_new(ctx, basis, nchannels, channels, &res);
    if (rc >= 0 && want_abs && (!(af = bsti_alloc_array(ctx, 2 * n * N, sizeof *af))))
        rc = BST_ENOMEM;
    ab = af ? af + n * N : NULL;
    size_t total = 0, done = 0;
    int warn = 0;
    for (size_t c = 0; c < nchannels && rc >= 0; c++) {
        if (bst_glass_find_channel(panes[0], channels[c]) < 0)
            rc = bst_glass_add_channel(ctx, panes[0], channels[c]);
        if (rc >= 0 && !wavelengths(panes[0], channels[c], all, nall, &nwl))
            rc = bsti_error(ctx, BST_EINVAL, "spectral stack: channel %s is not a spectral band "
                            "(Visible, Solar, CIE-X, CIE-Y, CIE-Z)", channels[c]);
        total += nwl;
    }
    for (size_t c = 0; c < nchannels && rc >= 0; c++) {
        size_t ch = (size_t)bst_glass_find_channel(panes[0], channels[c]);
        const double *wl = wavelengths(panes[0], channels[c], all, nall, &nwl);
        bsti_free(ctx, w);
        if (!(w = bsti_alloc_array(ctx, nwl, sizeof *w))) {
            rc = BST_ENOMEM;
            break;
        }
        rc = bst_glass_channel_weights(ctx, panes[0], ch, nwl, wl, w);
        double *abs_f = abs_front ? abs_front + c * n * N : NULL;
        double *abs_b = abs_back ? abs_back + c * n * N : NULL;
        for (size_t i = 0; i < n * N; i++) {
            if (abs_f)
                abs_f[i] = 0.0;
            if (abs_b)
                abs_b[i] = 0.0;
        }
        for (size_t k = 0; k < nwl && rc >= 0; k++, done++) {
            if (w[k] == 0.0)
                continue;
            for (size_t i = 0; i < n && rc >= 0; i++) {
                bst_layer_free(lay[i]);
                lay[i] = NULL;
                rc = bsti_glass_layer_at(ctx, panes[i], basis, rule, wl[k], &lay[i]);
            }
            ctx->progress_fn = NULL; /* one report per wavelength, below */
            if (rc >= 0)
                rc = bst_stack_combine(ctx, n, (const bst_layer *const *)lay, opts, &sys);
            if (rc > 0) /* a warning (ill-conditioned, energy): kept, its message is in ctx */
                warn = rc, rc = BST_OK;
            if (rc >= 0 && want_abs)
                rc = bst_stack_absorptance(ctx, n, (const bst_layer *const *)lay, 0, opts, af, ab);
            if (rc > 0)
                warn = rc, rc = BST_OK;
            ctx->progress_fn = progress;
            if (rc >= 0)
                rc = accumulate(ctx, acc, sys, want, w[k]);
            for (size_t i = 0; rc >= 0 && want_abs && i < n * N; i++) {
                if (abs_f)
                    abs_f[i] += w[k] * af[i];
                if (abs_b)
                    abs_b[i] += w[k] * ab[i];
            }
            bst_layer_free(sys);
            sys = NULL;
            bsti_progress(ctx, (double)(done + 1) / (double)total, "combining per wavelength");
        }
        for (int m = 0; m < BST_NCOMP; m++) {
            if (rc >= 0 && acc[m])
                rc = bst_layer_set(ctx, res, c, (bst_comp)m, acc[m]);
            else
                bst_mat_free(acc[m]);
            acc[m] = NULL;
        }
    }
    ctx->progress_fn = progress;
    for (size_t i = 0; lay && i < n; i++)
        bst_layer_free(lay[i]);
    for (int m = 0; m < BST_NCOMP; m++)
        bst_mat_free(acc[m]);
    bsti_free(ctx, lay), bsti_free(ctx, all), bsti_free(ctx, w), bsti_free(ctx, af);
    bsti_glass_rule_free(ctx, rule);
    if (rc < 0) {
        bst_layer_free(res);
        return rc;
    }
    *out = res;
    return warn;
}
