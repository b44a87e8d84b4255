/* combine_varres.c - `combine --fine-incident / --sun-path`: one variable-resolution tensor tree
 * (bst_bsdf_write_varres): the whole system at the coarse order kc, and the Tf and Rf columns of the
 * fine patches at order k (bst_stack_columns), checked against their coarse patches.  Both parts
 * are combined alike: per wavelength where the plan says so (the same groups of wavelengths), else
 * by band values per channel. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "combine.h"

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return x < y ? -1 : x > y;
}

/* The fine directions' patches at order k, increasing, without repeats. */
static int fine_patches(const char *sub, bst_ctx *ctx, int k, size_t ndirs, const double (*dirs)[2],
                        size_t **cols, size_t *ncols)
{
    bst_basis *b;
    *cols = NULL;
    if (bst_basis_new_sc(ctx, k, &b) < 0)
        return cli_fail_ctx(sub, NULL, ctx);
    size_t *c = malloc((ndirs + 1) * sizeof *c), m = 0;
    if (!c) {
        bst_basis_free(b);
        return cli_fail(sub, "out of memory");
    }
    for (size_t q = 0; q < ndirs; q++) /* off cell boundaries onto the +x, +y side, as --incident */
        c[q] = cli_incident_patch(b, dirs[q][0], dirs[q][1]);
    qsort(c, ndirs, sizeof *c, cmp_size);
    for (size_t q = 0; q < ndirs; q++)
        if (m == 0 || c[q] != c[m - 1])
            c[m++] = c[q];
    bst_basis_free(b);
    *cols = c, *ncols = m;
    return CLI_OK;
}

/* Each fine column's hemispherical value against its coarse patch's: a warning line per
 * channel and component where one differs by more than BST_VARRES_HEMI_TOL (-v: always). */
static int check_fine(bst_ctx *ctx, const char *sub, const bst_layer *sys, const bst_varres *v,
                      int verbose)
{
    size_t ncols = v->ncols, nch = bst_layer_nchannels(sys);
    double *diff = malloc((ncols + 1) * sizeof *diff);
    if (!diff)
        return cli_fail(sub, "out of memory");
    int rc = CLI_OK;
    for (size_t ch = 0; rc == CLI_OK && ch < nch; ch++)
        for (int c = 0; rc == CLI_OK && c < 2; c++) {
            bst_comp comp = c ? BST_RF : BST_TF;
            double worst;
            if (!(c ? v->rf : v->tf)[ch] || !bst_layer_get(sys, ch, comp))
                continue;
            if (bst_varres_hemi_diff(ctx, sys, v, ch, comp, diff, &worst) < 0) {
                rc = cli_fail_ctx(sub, "consistency", ctx);
                break;
            }
            size_t beyond = 0, qw = 0;
            for (size_t q = 0; q < ncols; q++) {
                beyond += fabs(diff[q]) > BST_VARRES_HEMI_TOL;
                qw = fabs(diff[q]) > fabs(diff[qw]) ? q : qw;
            }
            size_t G = (size_t)1 << v->k, col = v->cols[qw];
            double cx = ((double)(col / G) + 0.5) / (double)G, cy = ((double)(col % G) + 0.5) / (double)G;
            if (beyond || verbose)
                fprintf(stderr, "bsdfstack %s: %s%s %s: fine columns' hemispherical value minus "
                        "their coarse patch's: largest %+.4f (fine patch %zu, square (%.3f, %.3f)); "
                        "%zu of %zu beyond %g\n", sub, beyond ? "warning: " : "",
                        bst_layer_channel(sys, ch), bst_comp_name(comp), diff[qw], col, cx, cy,
                        beyond, ncols, BST_VARRES_HEMI_TOL);
        }
    free(diff);
    return rc;
}

/* The Tf and Rf columns cols of the stack at order k (set), per channel of sys, into tf[ch] and
 * rf[ch] (NULL where --only leaves the component out). */
static int fine_columns(bst_ctx *ctx, const char *sub, const struct combine_req *q,
                        const struct cli_layers *set, int spectral, const bst_layer *sys,
                        size_t ncols, const size_t *cols, bst_mat **tf, bst_mat **rf)
{
    unsigned want = q->args.so.comps ? q->args.so.comps : BST_COMP_ALL;
    for (size_t ch = 0; ch < bst_layer_nchannels(sys); ch++) {
        bst_columns_opts o;
        bst_columns_opts_init(&o);
        const char *name = bst_layer_channel(sys, ch);
        if (spectral) {
            int rc = cli_columns_spectral(ctx, sub, set, &q->args.sp, name, ncols, cols, &o, &tf[ch],
                                          &rf[ch]);
            if (rc != CLI_OK)
                return rc;
        } else {
            int st = bst_stack_columns(ctx, set->n, (const bst_layer *const *)set->layers, name,
                                       ncols, cols, &o, &tf[ch], &rf[ch]);
            if (st < 0)
                return cli_fail_ctx(sub, "fine columns", ctx);
            cli_warn_ctx(sub, NULL, st, ctx);
        }
        if (!(want & BST_COMP_BIT(BST_TF)))
            bst_mat_free(tf[ch]), tf[ch] = NULL;
        if (!(want & BST_COMP_BIT(BST_RF)))
            bst_mat_free(rf[ch]), rf[ch] = NULL;
        if (q->verbose)
            fprintf(stderr, "bsdfstack %s: %s fine columns: %d sweeps, last change %.2e of the "
                    "incident flux\n", sub, name, o.iterations, o.residual);
    }
    return CLI_OK;
}

/* The fine directions: --fine-incident's, --fine-incident-file's and the sun's (--sun-path). */
static int fine_directions(const char *sub, struct combine_req *q)
{
    int rc = CLI_OK;
    if (q->finefile)
        rc = combine_read_directions(sub, q->finefile, &q->fine, &q->nfine, &q->fcap);
    if (rc != CLI_OK || !q->sun)
        return rc;
    long m = bst_sun_path(&q->site, q->azimuth, q->sun_step, 0, NULL);
    if (m <= 0)
        return cli_fail(sub, "--sun-path: the sun never stands in front of a window facing azimuth "
                        "%g at latitude %g", q->azimuth, q->site.latitude);
    double (*d)[2] = realloc(q->fine, (q->nfine + (size_t)m) * sizeof *q->fine);
    if (!d)
        return cli_fail(sub, "out of memory");
    q->fine = d;
    bst_sun_path(&q->site, q->azimuth, q->sun_step, (size_t)m, q->fine + q->nfine);
    q->nfine += (size_t)m;
    if (q->verbose)
        fprintf(stderr, "bsdfstack %s: %ld sun positions of a year in front of the window\n", sub, m);
    return CLI_OK;
}

static int varres_run(bst_ctx *ctx, const char *sub, struct combine_req *q)
{
    int k = q->args.basis.k, kc = q->kc ? q->kc : COMBINE_COARSE_K;
    size_t *cols = NULL, ncols = 0;
    int rc = fine_directions(sub, q);
    if (rc == CLI_OK)
        rc = fine_patches(sub, ctx, k, q->nfine, (const double (*)[2])q->fine, &cols, &ncols);
    if (rc != CLI_OK)
        return rc;
    if (q->verbose)
        fprintf(stderr, "bsdfstack %s: %zu fine directions in %zu patches of order %d over order %d\n",
                sub, q->nfine, ncols, k, kc);
    /* the coarse system at kc */
    struct cli_layers set = {0}, fset = {0};
    struct cli_basis_choice choice = q->args.basis;
    choice.k = kc;
    choice.combining = 1;
    bst_layer *sys = NULL;
    double t0 = combine_now();
    rc = cli_layers_load(&set, ctx, sub, q->nspecs, q->specs, &choice, q->args.channels, 0,
                         q->args.so.precision);
    struct cli_run_opts ro = {.verbose = q->verbose, .consume = 1};
    if (rc == CLI_OK) /* the plan's choice, kept in set: the fine columns go the same way */
        rc = cli_combine_run(ctx, sub, NULL, &set, &q->args, &ro, &sys);
    int spectral = set.spectral;
    if (rc == CLI_OK && q->verbose)
        combine_phase("the coarse system", t0);
    /* the fine columns at k, front incidence, per channel of the coarse system */
    size_t nch = sys ? bst_layer_nchannels(sys) : 0;
    bst_mat **tf = calloc(2 * nch + 1, sizeof *tf), **rf = tf ? tf + nch : NULL;
    if (rc == CLI_OK && !tf)
        rc = cli_fail(sub, "out of memory");
    unsigned want = q->args.so.comps ? q->args.so.comps : BST_COMP_ALL;
    t0 = combine_now();
    if (rc == CLI_OK && (want & (BST_COMP_BIT(BST_TF) | BST_COMP_BIT(BST_RF)))) {
        choice.k = k;
        choice.combining = 0;
        rc = cli_layers_load(&fset, ctx, sub, q->nspecs, q->specs, &choice, q->args.channels, 0,
                             q->args.so.precision);
        if (rc == CLI_OK)
            rc = fine_columns(ctx, sub, q, &fset, spectral, sys, ncols, cols, tf, rf);
        if (rc == CLI_OK && q->verbose)
            combine_phase("the fine columns", t0);
    }
    cli_layers_free(&fset);
    bst_varres v = {k, ncols, cols, (const bst_mat *const *)tf, (const bst_mat *const *)rf};
    if (rc == CLI_OK)
        rc = check_fine(ctx, sub, sys, &v, q->verbose);
    t0 = combine_now();
    if (rc == CLI_OK)
        rc = cli_write_varres(ctx, sub, sys, &v, q->outpath, &q->args.reduce, q->argc, q->argv, &set);
    if (rc == CLI_OK && q->verbose)
        combine_phase("wrote the file", t0);
    for (size_t i = 0; tf && i < 2 * nch; i++)
        bst_mat_free(tf[i]);
    free(tf), free(cols);
    bst_layer_free(sys);
    cli_layers_free(&set);
    return rc;
}

int combine_varres(struct combine_req *q)
{
    const char *sub = "combine";
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    bst_ctx_set_threads(ctx, q->threads);
    int rc = varres_run(ctx, sub, q);
    bst_ctx_free(ctx);
    return rc;
}
