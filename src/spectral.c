/* spectral.c - stacks with spectral panes combined wavelength by wavelength and averaged afterwards,
 * as Windows-CalcEngine and WINDOW do for multi-layer systems.  Combining band-averaged panes is
 * not the same: the system's T is not linear in the panes' T and R.
 *
 * The average of a system property over a band is linear in the per-wavelength system, so the
 * band's matrices are sum_k w_k M(lambda_k) with bst_glass_channel_weights' w.  Wavelengths of zero
 * weight are skipped.  The rest are combined once per group (cost control), each pane built from
 * its data averaged with the weights over the group, the system added with the group's summed
 * weight (absorptance likewise).  The system is smooth in the panes' data and the mean cancels the
 * first-order term, so a group's error is about its weighted sum of squared deviations from the
 * mean, sum_k w_k (d_k - mean)^2 (d: every pane's normal-incidence Tf, Tb, Rf, Rb; the largest of
 * them), and the band's error about the sum of that over its groups.  So the groups are formed for
 * that sum: walking the grid in order, a group extends while its share stays within a budget b
 * (and, with a dual-band layer, on the same side of the visible range's limits, where the layer is
 * constant), and b is the largest (bisection) for which the shares sum to at most tol^2: tol is
 * the weighted RMS deviation of the panes' data from their group means.  A group is evaluated at
 * its mean data, not at a centroid wavelength.  tol = 0 groups only wavelengths with equal data
 * (the result equals the ungrouped one to rounding), tol < 0 none.  (The rule's history and its
 * measured errors: bench/README.md, "Spectral stacks with a shade"; test_wce.c checks them.)
 *
 * What does not depend on the wavelength is built once, before the groups: the patch rule of the
 * panes (bsti_glass_rule: directions and weights), the dual-band layers (two one-channel layers in
 * their cheapest structures), the groups themselves; per group each pane's two slab sides are set
 * up once, not at each direction (glass_layer.c).  A group costs one combination: the absorptance
 * rides on it (bsti_stack_combine_absorptance, absorptance.c), and the groups run side by side,
 * one worker a core, each with a context of its own (below).
 *
 * A band channel (Visible, Solar, CIE-X, CIE-Y, CIE-Z) missing from the first pane is added to it;
 * its wavelengths are the union of the layers' own ones, or the band's integration grid when that
 * is shorter (WCE's rule).
 *
 * A layer known only by band values (Solar and Visible channels) is WINDOW's dual-band material:
 * its own wavelengths are {0.3, 0.38 -+ 1e-6, 0.78 -+ 1e-6, 2.5} um (WCE's), it is its Visible
 * matrices inside [0.38, 0.78] um and max(0, (Solar - f Visible) / (1 - f)) outside.  Only the
 * panes depend on the wavelength.  A stack of panes only keeps every matrix diagonal: O(N) per
 * wavelength. */
#include <config.h>

#include <float.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cblas.h>

#include "ctx.h"
#include "glass.h"
#include "layer.h"
#include "mat.h"
#include "spectral_groups.h"
#include "stack.h"

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* A dual-band layer's own wavelengths (um): WCE's, the band limits -+ 1e-6 and the solar range. */
#define DUAL_EDGE 1e-6
static const double dual_grid[6] = {0.3, BST_DUAL_BAND_LO - DUAL_EDGE, BST_DUAL_BAND_LO + DUAL_EDGE,
                                    BST_DUAL_BAND_HI - DUAL_EDGE, BST_DUAL_BAND_HI + DUAL_EDGE, 2.5};
/* Wavelengths closer than this (um) are one. */
#define GRID_MERGE 1e-9

void bst_spectral_opts_init(bst_spectral_opts *opts)
{
    if (!opts)
        return;
    opts->at_centre = 0;
    opts->dual_f = BST_DUAL_BAND_F;
    opts->tol = BST_SPECTRAL_TOL;
}

/* The union of the layers' own wavelengths, sorted, duplicates (within GRID_MERGE) removed. */
static int union_grid(bst_ctx *ctx, size_t n, const bst_spectral_layer *layers, double **wl,
                      size_t *nwl)
{
    size_t total = 0;
    for (size_t i = 0; i < n; i++)
        total += layers[i].pane ? bst_glass_nwavelengths(layers[i].pane) : 6;
    double *w = bsti_alloc_array(ctx, total, sizeof *w);
    if (!w)
        return BST_ENOMEM;
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (layers[i].pane)
            for (size_t k = 0; k < bst_glass_nwavelengths(layers[i].pane); k++)
                w[m++] = bst_glass_wavelength(layers[i].pane, k);
        else
            for (size_t k = 0; k < 6; k++)
                w[m++] = dual_grid[k];
    qsort(w, m, sizeof *w, cmp_double);
    size_t u = 0;
    for (size_t k = 0; k < m; k++)
        if (u == 0 || w[k] - w[u - 1] > GRID_MERGE)
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

/* ------------------------------------------------------------------ dual-band layers */

/* A dual-band layer as two one-channel ("Spectral") layers: inside the visible range and outside. */
struct dual {
    bst_layer *vis, *out;
};

/* Component c of the layer outside the visible range from the Solar (s) and Visible (v) matrices
 * (either may be NULL = zero): max(0, (s - f v) / (1 - f)), in the cheapest exact structure. */
static int dual_outside(bst_ctx *ctx, const bst_mat *s, const bst_mat *v, size_t N, double f,
                        bst_mat **out)
{
    bst_mat *d;
    int rc = bst_mat_new_dense(ctx, N, N, BST_DOUBLE, &d);
    if (rc < 0)
        return rc;
    double *x = bst_mat_dense_data(d), *y = NULL;
    if (s)
        rc = bst_mat_to_dense_array(ctx, s, x);
    if (rc >= 0 && v && !(y = bsti_alloc_array(ctx, N * N, sizeof *y)))
        rc = BST_ENOMEM;
    if (rc >= 0 && v)
        rc = bst_mat_to_dense_array(ctx, v, y);
    for (size_t k = 0; rc >= 0 && k < N * N; k++)
        x[k] = fmax(0.0, (x[k] - f * (y ? y[k] : 0.0)) / (1.0 - f));
    bsti_free(ctx, y);
    if (rc >= 0)
        rc = bst_mat_compact(ctx, d, BST_SPARSE_MAX_FILL, out);
    bst_mat_free(d);
    return rc;
}

static void dual_free(struct dual *d)
{
    bst_layer_free(d->vis);
    bst_layer_free(d->out);
    d->vis = d->out = NULL;
}

static int dual_new(bst_ctx *ctx, const bst_layer *l, size_t pos, const bst_basis *basis,
                    double f, struct dual *d)
{
    static const char *const name[] = {"Spectral"};
    int cs = bst_layer_find_channel(l, "Solar"), cv = bst_layer_find_channel(l, "Visible");
    d->vis = d->out = NULL;
    if (cs < 0 || cv < 0)
        return bsti_error(ctx, BST_EINVAL, "spectral stack: layer %zu (%s) has no spectral data "
                          "and lacks a %s channel: a dual-band layer needs Solar and Visible",
                          pos + 1, bst_layer_name(l) ? bst_layer_name(l) : "unnamed",
                          cs < 0 ? "Solar" : "Visible");
    if (!bst_basis_equal(bst_layer_basis(l), basis))
        return bsti_error(ctx, BST_EINVAL, "spectral stack: layer %zu is over another basis",
                          pos + 1);
    size_t N = bst_basis_size(basis);
    int rc = bst_layer_new(ctx, basis, 1, name, &d->vis);
    if (rc >= 0)
        rc = bst_layer_new(ctx, basis, 1, name, &d->out);
    for (int c = 0; c < BST_NCOMP && rc >= 0; c++) {
        const bst_mat *s = bst_layer_get(l, (size_t)cs, (bst_comp)c);
        const bst_mat *v = bst_layer_get(l, (size_t)cv, (bst_comp)c);
        bst_mat *m = NULL;
        if (v && (rc = bst_mat_compact(ctx, v, BST_SPARSE_MAX_FILL, &m)) >= 0)
            rc = bst_layer_set(ctx, d->vis, 0, (bst_comp)c, m);
        if (rc >= 0 && (s || v) && (rc = dual_outside(ctx, s, v, N, f, &m)) >= 0)
            rc = bst_layer_set(ctx, d->out, 0, (bst_comp)c, m);
    }
    if (rc < 0)
        dual_free(d);
    return rc;
}

/* ------------------------------------------------------------------ the combination */

/* *acc += w m for m FACTORED over a wide map (mat.h): into a dense double *acc (made when NULL or
 * not dense double) a block of m's columns at a time (bsti_cols), so that no expanded copy of m is
 * held beside the sum.  Such sums do not stay factored: each group's scaling vectors are its own,
 * and the rank grows with the groups. */
static int add_wide(bst_ctx *ctx, bst_mat **acc, const bst_mat *m, double w)
{
    size_t N = bst_mat_rows(m);
    bst_mat *d = NULL;
    int rc = BST_OK;
    if (!*acc)
        rc = bst_mat_new_dense(ctx, N, N, BST_DOUBLE, &d); /* zeros */
    else if (bst_mat_structure(*acc) != BST_DENSE || bst_mat_precision(*acc) != BST_DOUBLE)
        rc = bst_mat_convert(ctx, *acc, BST_DENSE, BST_DOUBLE, &d);
    if (rc < 0)
        return rc;
    if (d) {
        bst_mat_free(*acc);
        *acc = d;
    }
    bsti_cols *c;
    if ((rc = bsti_cols_new(ctx, m, N, &c)) < 0)
        return rc;
    size_t nb = bsti_cols_block(c);
    double *buf = bsti_alloc_array(ctx, nb * N, sizeof *buf), *sum = bst_mat_dense_data(*acc);
    for (size_t j0 = 0; buf && j0 < N; j0 += nb) {
        size_t k = N - j0 < nb ? N - j0 : nb;
        bsti_cols_get(c, NULL, j0, k, buf);
        for (size_t t = 0; t < k * N; t++)
            sum[j0 * N + t] += w * buf[t];
    }
    rc = buf ? BST_OK : BST_ENOMEM;
    bsti_free(ctx, buf);
    bsti_cols_free(c);
    return rc;
}

/* acc[c] += w * m[c] for the requested components (acc[c] == NULL: acc[c] = w * m[c]).  Dense
 * double sums are added in place (and the first taken from sys, scaled in place): no N x N
 * matrix allocated, filled and freed per group and component. */
static int accumulate(bst_ctx *ctx, bst_mat **acc, bst_layer *sys, unsigned want, double w)
{
    for (int c = 0; c < BST_NCOMP; c++) {
        if (!(want & BST_COMP_BIT(c)))
            continue;
        const bst_mat *m = bst_layer_get(sys, 0, (bst_comp)c);
        int dense = m && bst_mat_structure(m) == BST_DENSE && bst_mat_precision(m) == BST_DOUBLE;
        size_t size = dense ? bst_mat_rows(m) * bst_mat_cols(m) : 0;
        if (dense && !acc[c] && size <= INT_MAX) {
            acc[c] = bst_layer_take(sys, 0, (bst_comp)c);
            cblas_dscal((int)size, w, bst_mat_dense_data(acc[c]), 1);
            continue;
        }
        if (dense && bst_mat_structure(acc[c]) == BST_DENSE &&
            bst_mat_precision(acc[c]) == BST_DOUBLE && size <= INT_MAX) {
            cblas_daxpy((int)size, w, bst_mat_dense_data((bst_mat *)m), 1,
                        bst_mat_dense_data(acc[c]), 1);
            continue;
        }
        if (bsti_mat_lr_wide(m)) { /* groups' maps differ in their scalings: summed dense */
            int rc = add_wide(ctx, &acc[c], m, w);
            if (rc < 0)
                return rc;
            continue;
        }
        bst_mat *sum;
        int rc = acc[c] ? bst_mat_add(ctx, 1.0, acc[c], w, m, &sum) : bst_mat_add(ctx, w, m, 0.0, m, &sum);
        if (rc < 0)
            return rc;
        bst_mat_free(acc[c]);
        acc[c] = sum;
    }
    return BST_OK;
}

/* ------------------------------------------------------------------ groups of wavelengths */

/* Normal-incidence Tf, Tb, Rf, Rb of every pane at um into d[4 * i ..] (other layers: zeros). */
static void panes_at(size_t n, const bst_spectral_layer *layers, double um, double *d)
{
    for (size_t i = 0; i < n; i++)
        if (layers[i].pane)
            bsti_glass_data_at(&layers[i].pane->data, um, &d[4 * i], &d[4 * i + 1],
                               &d[4 * i + 2], &d[4 * i + 3]);
        else
            d[4 * i] = d[4 * i + 1] = d[4 * i + 2] = d[4 * i + 3] = 0.0;
}

/* Validates the layers; *first = the first pane (it gives the bands' weights). */
static int check_layers(bst_ctx *ctx, size_t n, const bst_spectral_layer *layers,
                        const bst_spectral_opts *so, bst_glass **first)
{
    *first = NULL;
    if (!(so->dual_f >= 0.0 && so->dual_f < 1.0))
        return bsti_error(ctx, BST_EINVAL, "spectral stack: dual-band f = %g is not in [0, 1)",
                          so->dual_f);
    if (isnan(so->tol))
        return bsti_error(ctx, BST_EINVAL, "spectral stack: the grouping tolerance is NaN");
    for (size_t i = 0; i < n; i++) {
        const bst_spectral_layer *l = &layers[i];
        if (!l->pane == !l->bands)
            return bsti_error(ctx, BST_EINVAL, "spectral stack: layer %zu needs exactly one of a "
                              "pane and a dual-band layer", i + 1);
        if (l->pane && !bst_glass_nwavelengths(l->pane))
            return bsti_error(ctx, BST_EINVAL, "spectral stack: layer %zu (%s) has no spectral "
                              "data: combine per channel with bst_stack_combine", i + 1,
                              bst_glass_description(l->pane));
        if (l->pane && !*first)
            *first = l->pane;
    }
    if (!*first)
        return bsti_error(ctx, BST_EINVAL, "spectral stack: no layer is a spectral pane: combine "
                          "per channel with bst_stack_combine");
    return BST_OK;
}

/* ------------------------------------------------------------------ workers
 *
 * The groups are independent combinations summed with their weights, so they are shared out
 * among workers, one a core: worker t takes groups t, t + T, t + 2T, ... (T workers; a fixed
 * share, so that a run's sums do not depend on timing), sums its own, and the sums are added in
 * worker order at the end (the result differs from one worker's by rounding only).  Each worker
 * runs its combinations on one OpenBLAS thread (set for the process while the workers run, and
 * set back): at these sizes groups side by side keep the cores busier than one product split
 * between them (Klems full: the split product spent most of its time handing over work).  Worker
 * 0 is the calling thread with the caller's context and reports the progress; the others have
 * their own contexts, since a context is not shared between threads, and the caller's on_step is
 * called under a lock, from whichever worker formed the step.  With a custom allocator (which
 * need not be thread-safe), a single group or a single core, one worker does it all. */

/* Groups run side by side when the basis has at most this many patches (k = 5): each worker
 * holds its own combination's workspace and sums (about 20 N x N doubles: 160 MB at N = 1024);
 * above it one worker runs them in turn and OpenBLAS threads each product. */
#define BSTI_SPECTRAL_PAR_MAX_N 1024
/* At most this many workers (and no more than online processors). */
#define BSTI_SPECTRAL_MAX_WORKERS 16


/* What every worker reads; stop is set by a worker that fails, so that the others end early. */
struct shared {
    size_t n, N, njobs, nworkers, total;
    const bst_spectral_layer *layers;
    const struct dual *dual;
    const bst_basis *basis;
    const bsti_glass_rule *rule;
    const bst_stack_opts *opts;
    unsigned want;
    int want_abs;
    const struct bsti_group *jobs;
    /* columns (bst_stack_columns_spectral_layers): ncols > 0, the system's Tf and Rf (or Tb and
     * Rb) columns cols of each group summed into acc's BST_TF and BST_RF slots */
    size_t ncols;
    const size_t *cols;
    const bst_columns_opts *copts;
    atomic_int stop;
    /* the caller's opts->on_step, called under `lock`: never from two workers at once */
    void (*on_step)(const bst_stack_step *step, void *opaque);
    void *opaque;
    pthread_mutex_t lock;
};

static void locked_step(const bst_stack_step *step, void *opaque)
{
    struct shared *sh = opaque;
    pthread_mutex_lock(&sh->lock);
    sh->on_step(step, sh->opaque);
    pthread_mutex_unlock(&sh->lock);
}

/* A worker's sums (acc: nchannels x BST_NCOMP matrices of its context; abs: per channel, front
 * then back, n N each) and outcome. */
struct worker {
    struct shared *sh;
    size_t index;
    bst_ctx *ctx;
    bst_mat **acc;
    double *abs;
    int rc, warn;
    int iterations;     /* columns: the most sweeps of a group, and the largest last change */
    double residual;
};

/* Columns of one group's stack lay: iterated (bst_stack_columns) and summed with the group's
 * weight into the worker's BST_TF and BST_RF slots of the group's channel. */
static int group_columns(bst_ctx *ctx, const struct shared *sh, const bst_layer **lay,
                         struct worker *wk, const struct bsti_group *j)
{
    bst_columns_opts o = *sh->copts;
    bst_mat *m[2] = {NULL, NULL};
    int rc = bst_stack_columns(ctx, sh->n, lay, NULL, sh->ncols, sh->cols, &o, &m[0], &m[1]);
    if (rc < 0)
        return rc;
    wk->iterations = o.iterations > wk->iterations ? o.iterations : wk->iterations;
    wk->residual = fmax(wk->residual, o.residual);
    static const bst_comp slot[2] = {BST_TF, BST_RF};
    for (int c = 0; c < 2; c++) {
        bst_mat **acc = &wk->acc[j->ch * BST_NCOMP + slot[c]], *sum;
        int st = *acc ? bst_mat_add(ctx, 1.0, *acc, j->wsum, m[c], &sum)
                      : bst_mat_add(ctx, j->wsum, m[c], 0.0, m[c], &sum);
        if (st < 0) {
            rc = st;
            break;
        }
        bst_mat_free(*acc);
        *acc = sum;
    }
    bst_mat_free(m[0]), bst_mat_free(m[1]);
    return rc;
}

static void *work(void *arg)
{
    struct worker *wk = arg;
    const struct shared *sh = wk->sh;
    bst_ctx *ctx = wk->ctx;
    size_t n = sh->n, N = sh->N, done = 0;
    bst_layer **own = bsti_calloc(ctx, n, sizeof *own), *sys = NULL;
    const bst_layer **lay = bsti_calloc(ctx, n, sizeof *lay);
    double *af = sh->want_abs ? bsti_alloc_array(ctx, 2 * n * N, sizeof *af) : NULL;
    int rc = own && lay && (af || !sh->want_abs) ? BST_OK : BST_ENOMEM;
    bst_progress_fn progress = ctx->progress_fn;
    ctx->progress_fn = NULL; /* one report per group, below */
    for (size_t g = wk->index; rc >= 0 && g < sh->njobs; g += sh->nworkers) {
        if (atomic_load(&((struct shared *)sh)->stop))
            break;
        const struct bsti_group *j = &sh->jobs[g];
        for (size_t i = 0; i < n && rc >= 0; i++) {
            bst_layer_free(own[i]);
            own[i] = NULL;
            if (sh->layers[i].pane)
                rc = bsti_glass_layer_data(ctx, sh->layers[i].pane, sh->basis, sh->rule,
                                           &j->mean[4 * i], &own[i]);
            lay[i] = sh->layers[i].pane ? own[i] : j->inside ? sh->dual[i].vis : sh->dual[i].out;
        }
        if (rc >= 0 && sh->ncols)
            rc = group_columns(ctx, sh, lay, wk, j);
        else if (rc >= 0)
            rc = bsti_stack_combine_absorptance(ctx, n, lay, 0, sh->opts, &sys, af,
                                                af ? af + n * N : NULL);
        if (rc > 0) /* a warning (ill-conditioned, energy): kept, its message is in ctx */
            wk->warn = rc > wk->warn ? rc : wk->warn, rc = BST_OK;
        if (rc >= 0 && !sh->ncols)
            rc = accumulate(ctx, wk->acc + j->ch * BST_NCOMP, sys, sh->want, j->wsum);
        double *a = wk->abs + j->ch * 2 * n * N;
        for (size_t i = 0; rc >= 0 && af && i < 2 * n * N; i++)
            a[i] += j->wsum * af[i];
        bst_layer_free(sys);
        sys = NULL;
        done += j->end - j->first;
        if (wk->index == 0 && progress) {
            double f = (double)(done * sh->nworkers) / (double)sh->total;
            ctx->progress_fn = progress;
            bsti_progress(ctx, f < 1.0 ? f : 1.0, "combining per group of wavelengths");
            ctx->progress_fn = NULL;
        }
    }
    ctx->progress_fn = progress;
    if (rc < 0)
        atomic_store(&((struct shared *)sh)->stop, 1);
    for (size_t i = 0; own && i < n; i++)
        bst_layer_free(own[i]);
    bsti_free(ctx, own), bsti_free(ctx, lay), bsti_free(ctx, af);
    wk->rc = rc;
    return NULL;
}

/* How many workers: see above. */
static size_t worker_count(const bst_ctx *ctx, size_t N, size_t njobs)
{
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    bst_ctx *probe = bst_ctx_new(); /* it holds the default allocator */
    int custom = !probe || probe->malloc_fn != ctx->malloc_fn || probe->free_fn != ctx->free_fn;
    bst_ctx_free(probe);
    if (custom || N > BSTI_SPECTRAL_PAR_MAX_N || cpus < 2 || njobs < 2)
        return 1;
    size_t t = (size_t)cpus < njobs ? (size_t)cpus : njobs;
    return t < BSTI_SPECTRAL_MAX_WORKERS ? t : BSTI_SPECTRAL_MAX_WORKERS;
}

/* Run the workers; the first error (in worker order) or the highest warning, its message in ctx. */
static int run_workers(bst_ctx *ctx, struct worker *wk, size_t nw)
{
    int threads = openblas_get_num_threads();
    if (nw > 1 && threads > 1)
        openblas_set_num_threads(1);
    bsti_run_parts(wk, sizeof *wk, nw, work); /* (a thread that cannot start: its share here) */
    if (nw > 1 && threads > 1)
        openblas_set_num_threads(threads);
    int warn = BST_OK;
    for (size_t t = 0; t < nw; t++) {
        if (wk[t].rc < 0) {
            if (t > 0)
                bsti_error(ctx, wk[t].rc, "%s", wk[t].ctx->msg);
            return wk[t].rc;
        }
        if (wk[t].warn > warn) {
            warn = wk[t].warn;
            if (t > 0)
                bsti_error(ctx, warn, "%s", wk[t].ctx->msg);
        }
    }
    return warn;
}

/* ------------------------------------------------------------------ the combination */

/* The groups' sums: sums[c * BST_NCOMP + m] (nchannels x BST_NCOMP, NULL where nothing was
 * asked) of the whole system's components (ncols == 0) or of its columns cols (copts: Tf and Rf
 * slots, or Tb and Rb with copts->back), and the absorptance; the highest warning or an error
 * (then nothing is left in sums). */
/* The groups of wavelengths of every channel (bsti_spectral_groups), each with the panes' mean
 * data: *jobs and *means (4 n values a group), *njobs of them; *total: the channels' wavelengths
 * (room allocated).  all: the union grid of nall wavelengths; split: a dual-band layer. */
static int make_groups(bst_ctx *ctx, bst_glass *ref, size_t n, const bst_spectral_layer *layers,
                       size_t nchannels, const char *const *channels, const double *all,
                       size_t nall, const bst_spectral_opts *so, int split,
                       struct bsti_group **jobs_out, double **means_out, size_t *njobs_out,
                       size_t *total_out)
{
    size_t nwl = 0, total = 0, njobs = 0;
    double *w = NULL, *data = NULL, *means = NULL;
    struct bsti_group *jobs = NULL;
    int rc = BST_OK;
    for (size_t c = 0; c < nchannels && rc >= 0; c++) {
        if (bst_glass_find_channel(ref, channels[c]) < 0)
            rc = bst_glass_add_channel(ctx, ref, channels[c]);
        if (rc >= 0 && !wavelengths(ref, channels[c], all, nall, &nwl))
            rc = bsti_error(ctx, BST_EINVAL, "spectral stack: channel %s is not a spectral band "
                            "(Visible, Solar, CIE-X, CIE-Y, CIE-Z)", channels[c]);
        total += nwl;
    }
    /* the groups of every channel, each pane's mean data with it */
    if (rc >= 0 && (!(jobs = bsti_calloc(ctx, total ? total : 1, sizeof *jobs)) ||
                    !(means = bsti_alloc_array(ctx, (total ? total : 1) * 4 * n, sizeof *means))))
        rc = BST_ENOMEM;
    for (size_t c = 0; c < nchannels && rc >= 0; c++) {
        size_t ch = (size_t)bst_glass_find_channel(ref, channels[c]);
        const double *wl = wavelengths(ref, channels[c], all, nall, &nwl);
        bsti_free(ctx, w);
        if (!(w = bsti_alloc_array(ctx, nwl, sizeof *w))) {
            rc = BST_ENOMEM;
            break;
        }
        rc = bst_glass_channel_weights(ctx, ref, ch, nwl, wl, w);
        bsti_free(ctx, data);
        if (rc >= 0 && !(data = bsti_alloc_array(ctx, (nwl + 3) * 4 * n, sizeof *data)))
            rc = BST_ENOMEM;
        for (size_t k = 0; rc >= 0 && k < nwl; k++)
            panes_at(n, layers, wl[k], data + k * 4 * n);
        if (rc < 0)
            break;
        double *ws = data + nwl * 4 * n, vsum;
        double budget = so->tol > 0 ? bsti_spectral_group_budget(4 * n, data, split, wl, w, nwl, so->tol, ws)
                                    : so->tol;
        njobs += bsti_spectral_groups(4 * n, data, split, wl, w, nwl, budget, c, jobs + njobs,
                                means + njobs * 4 * n, ws, &vsum);
    }
    bsti_free(ctx, w), bsti_free(ctx, data);
    *jobs_out = jobs, *means_out = means, *njobs_out = njobs, *total_out = total;
    return rc;
}

/* The sums of the workers, in worker order, into the caller's context: sums[c * BST_NCOMP + m],
 * and the absorptance when asked. */
static int gather(bst_ctx *ctx, struct worker *wk, size_t nw, size_t nchannels, size_t n, size_t N,
                  int want_abs, bst_mat **sums, double *abs_front, double *abs_back)
{
    int rc = BST_OK;
    for (size_t c = 0; c < nchannels && rc >= 0; c++) {
        for (int m = 0; m < BST_NCOMP && rc >= 0; m++) {
            bst_mat *sum = NULL;
            for (size_t t = 0; t < nw && rc >= 0; t++) {
                bst_mat *x = wk[t].acc[c * BST_NCOMP + m], *s2;
                if (!x)
                    continue;
                rc = sum ? bst_mat_add(ctx, 1.0, sum, 1.0, x, &s2)
                     : t ? bst_mat_add(ctx, 1.0, x, 0.0, x, &s2) : BST_OK;
                if (!sum && !t)
                    s2 = x, wk[t].acc[c * BST_NCOMP + m] = NULL; /* worker 0's is the caller's */
                if (rc >= 0 && sum != s2)
                    bst_mat_free(sum), sum = s2;
            }
            if (rc >= 0)
                sums[c * BST_NCOMP + m] = sum;
            else
                bst_mat_free(sum);
        }
        for (size_t i = 0; rc >= 0 && want_abs && i < n * N; i++) {
            double f = 0.0, b = 0.0;
            for (size_t t = 0; t < nw; t++)
                f += wk[t].abs[c * 2 * n * N + i], b += wk[t].abs[c * 2 * n * N + n * N + i];
            if (abs_front)
                abs_front[c * n * N + i] = f;
            if (abs_back)
                abs_back[c * n * N + i] = b;
        }
    }
    return rc;
}

static int spectral_run(bst_ctx *ctx, size_t n, const bst_spectral_layer *layers,
                        const bst_basis *basis, size_t nchannels, const char *const *channels,
                        const bst_spectral_opts *so, const bst_stack_opts *opts_in, size_t ncols,
                        const size_t *cols, bst_columns_opts *copts, bst_mat **sums,
                        double *abs_front, double *abs_back)
{
    bst_glass *ref;
    int rc = check_layers(ctx, n, layers, so, &ref);
    if (rc < 0)
        return rc;
    bst_stack_opts defaults;
    bst_stack_opts_init(&defaults);
    const bst_stack_opts *opts = opts_in ? opts_in : &defaults;
    unsigned want = opts->comps ? opts->comps & BST_COMP_ALL : BST_COMP_ALL;
    int want_abs = abs_front || abs_back;

    size_t N = bst_basis_size(basis), nall = 0, total = 0, njobs = 0, nw = 0;
    double *all = NULL, *means = NULL;
    struct dual *dual = bsti_calloc(ctx, n, sizeof *dual);
    struct bsti_group *jobs = NULL;
    struct worker *wk = NULL;
    bsti_glass_rule *rule = NULL;
    int split = 0; /* a dual-band layer changes at the visible range's limits */
    rc = dual ? union_grid(ctx, n, layers, &all, &nall) : BST_ENOMEM;
    for (size_t i = 0; i < n && rc >= 0; i++)
        if (layers[i].bands)
            rc = dual_new(ctx, layers[i].bands, i, basis, so->dual_f, &dual[i]), split = 1;
    if (rc >= 0)
        rc = bsti_glass_rule_new(ctx, basis, so->at_centre, BST_GLASS_SAMPLES, &rule);
    if (rc >= 0)
        rc = make_groups(ctx, ref, n, layers, nchannels, channels, all, nall, so, split, &jobs,
                         &means, &njobs, &total);
    /* the workers and their sums */
    struct shared sh = {.n = n, .N = N, .njobs = njobs, .total = total ? total : 1,
                        .layers = layers, .dual = dual, .basis = basis, .rule = rule,
                        .opts = opts, .want = want, .want_abs = want_abs, .jobs = jobs,
                        .ncols = ncols, .cols = cols, .copts = copts,
                        .on_step = opts->on_step, .opaque = opts->opaque};
    bst_stack_opts wopts = *opts;
    if (opts->on_step)
        wopts.on_step = locked_step, wopts.opaque = &sh, sh.opts = &wopts;
    atomic_init(&sh.stop, 0);
    pthread_mutex_init(&sh.lock, NULL);
    if (rc >= 0) {
        sh.nworkers = nw = worker_count(ctx, N, njobs);
        if (!(wk = bsti_calloc(ctx, nw, sizeof *wk)))
            rc = BST_ENOMEM;
    }
    for (size_t t = 0; t < nw && rc >= 0; t++) {
        wk[t].sh = &sh, wk[t].index = t;
        wk[t].ctx = t ? bst_ctx_new() : ctx;
        wk[t].acc = bsti_calloc(ctx, nchannels * BST_NCOMP, sizeof *wk[t].acc);
        wk[t].abs = want_abs ? bsti_calloc(ctx, nchannels * 2 * n * N, sizeof *wk[t].abs) : NULL;
        if (!wk[t].ctx)
            rc = bsti_error(ctx, BST_ENOMEM, "out of memory (a worker's context)");
        else if (!wk[t].acc || (want_abs && !wk[t].abs))
            rc = BST_ENOMEM;
    }
    int warn = rc >= 0 ? run_workers(ctx, wk, nw) : BST_OK;
    if (warn < 0)
        rc = warn, warn = BST_OK;
    if (rc >= 0)
        rc = gather(ctx, wk, nw, nchannels, n, N, want_abs, sums, abs_front, abs_back);
    for (size_t t = 0; copts && wk && t < nw; t++) {
        copts->iterations = wk[t].iterations > copts->iterations ? wk[t].iterations : copts->iterations;
        copts->residual = fmax(copts->residual, wk[t].residual);
    }
    for (size_t t = 0; wk && t < nw; t++) {
        for (size_t q = 0; wk[t].acc && q < nchannels * BST_NCOMP; q++)
            bst_mat_free(wk[t].acc[q]);
        bsti_free(ctx, wk[t].acc), bsti_free(ctx, wk[t].abs);
        if (t)
            bst_ctx_free(wk[t].ctx);
    }
    for (size_t i = 0; dual && i < n; i++)
        dual_free(&dual[i]);
    bsti_free(ctx, dual), bsti_free(ctx, jobs), bsti_free(ctx, means), bsti_free(ctx, wk);
    bsti_free(ctx, all);
    bsti_glass_rule_free(ctx, rule);
    pthread_mutex_destroy(&sh.lock);
    if (rc < 0) {
        for (size_t q = 0; q < nchannels * BST_NCOMP; q++)
            bst_mat_free(sums[q]), sums[q] = NULL;
        return rc;
    }
    return warn;
}

int bst_stack_combine_spectral_layers(bst_ctx *ctx, size_t n, const bst_spectral_layer *layers,
                                      const bst_basis *basis, size_t nchannels,
                                      const char *const *channels, const bst_spectral_opts *sopts,
                                      const bst_stack_opts *opts, bst_layer **out,
                                      double *abs_front, double *abs_back)
{
    if (!ctx || !out)
        return BST_EINVAL;
    *out = NULL;
    if (n == 0 || !layers || !basis || nchannels == 0 || !channels)
        return bsti_error(ctx, BST_EINVAL, "spectral stack: no layers, basis or channels");
    bst_spectral_opts sdefaults;
    bst_spectral_opts_init(&sdefaults);
    bst_layer *res = NULL;
    bst_mat **sums = bsti_calloc(ctx, nchannels * BST_NCOMP, sizeof *sums);
    if (!sums)
        return BST_ENOMEM;
    int rc = bst_layer_new(ctx, basis, nchannels, channels, &res);
    if (rc >= 0)
        rc = spectral_run(ctx, n, layers, basis, nchannels, channels, sopts ? sopts : &sdefaults,
                          opts, 0, NULL, NULL, sums, abs_front, abs_back);
    int warn = rc > 0 ? rc : BST_OK;
    for (size_t q = 0; q < nchannels * BST_NCOMP; q++) {
        int st = rc >= 0 && sums[q] ? bst_layer_set(ctx, res, q / BST_NCOMP, (bst_comp)(q % BST_NCOMP), sums[q])
                                    : BST_OK;
        if (st < 0 || rc < 0)
            bst_mat_free(sums[q]);
        if (st < 0)
            rc = st;
    }
    bsti_free(ctx, sums);
    if (rc < 0) {
        bst_layer_free(res);
        return rc;
    }
    *out = res;
    return warn;
}

int bst_stack_columns_spectral_layers(bst_ctx *ctx, size_t n, const bst_spectral_layer *layers,
                                      const bst_basis *basis, const char *channel,
                                      const bst_spectral_opts *sopts, size_t ncols,
                                      const size_t *cols, bst_columns_opts *copts, bst_mat **tf,
                                      bst_mat **rf)
{
    if (!ctx || !tf || !rf)
        return BST_EINVAL;
    *tf = *rf = NULL;
    if (n == 0 || !layers || !basis || !channel || ncols == 0 || !cols)
        return bsti_error(ctx, BST_EINVAL, "spectral columns: no layers, basis, channel or columns");
    size_t N = bst_basis_size(basis);
    for (size_t q = 0; q < ncols; q++)
        if (cols[q] >= N)
            return bsti_error(ctx, BST_EINVAL, "spectral columns: patch %zu is beyond the basis's %zu",
                              cols[q], N);
    bst_spectral_opts sdefaults;
    bst_spectral_opts_init(&sdefaults);
    bst_columns_opts cdefaults;
    bst_columns_opts_init(&cdefaults);
    bst_columns_opts *co = copts ? copts : &cdefaults;
    co->iterations = 0;
    co->residual = 0.0;
    bst_mat *sums[BST_NCOMP] = {NULL};
    int rc = spectral_run(ctx, n, layers, basis, 1, &channel, sopts ? sopts : &sdefaults, NULL,
                          ncols, cols, co, sums, NULL, NULL);
    if (rc < 0)
        return rc;
    *tf = sums[BST_TF];
    *rf = sums[BST_RF];
    return rc;
}

int bst_stack_combine_spectral(bst_ctx *ctx, size_t n, bst_glass *const *panes,
                               const bst_basis *basis, size_t nchannels,
                               const char *const *channels, int at_centre,
                               const bst_stack_opts *opts, bst_layer **out, double *abs_front,
                               double *abs_back)
{
    if (!ctx || !out)
        return BST_EINVAL;
    *out = NULL;
    if (n == 0 || !panes)
        return bsti_error(ctx, BST_EINVAL, "spectral stack: no panes");
    bst_spectral_layer *l = bsti_calloc(ctx, n, sizeof *l);
    if (!l)
        return BST_ENOMEM;
    for (size_t i = 0; i < n; i++)
        l[i].pane = panes[i];
    bst_spectral_opts so;
    bst_spectral_opts_init(&so);
    so.at_centre = at_centre;
    so.tol = 0; /* panes alone stay diagonal, O(N) a wavelength: no need to group */
    int rc = bst_stack_combine_spectral_layers(ctx, n, l, basis, nchannels, channels, &so, opts,
                                               out, abs_front, abs_back);
    bsti_free(ctx, l);
    return rc;
}
