/* xml_write.c - writing a layer as BSDF XML (LBNL WindowElement, the layout wrapBSDF writes:
 * CONVENTIONS.md 2), streamed: only one ScatteringData block is ever being formed, straight into
 * the output.
 *
 * File conventions at this boundary (CONVENTIONS.md 1, 5, 7): our front is the XML "Front"
 * (exterior, -Z), so Tf is "Transmission Front" and so on; our matrices index the incident patch by
 * the propagation direction and the outgoing patch by the exit direction, exactly as RADIANCE's
 * tensor trees and Klems files do, so no index is converted.  A Shirley-Chiu matrix M[o + N i] is
 * already rttree_reduce's full tensor; a Klems "Columns" block lists M row by row (each text row
 * one outgoing patch o, its numbers the incident patches i).
 *
 * Choices: trees are rank 3 when every component passes the isotropy check (ttree_rank3.c), else
 * rank 4; a rank-4 transmission that is the reciprocal of the other side's is left out as genBSDF
 * does, unless reciprocity alone would move its hemispherical values beyond the reduction's
 * tolerance; a reduced tree keeps every incident patch's hemispherical values within budgets
 * (write_bound.h); values keep single precision exactly in trees (what readers store) and double
 * precision exactly in Klems matrices, unless a number of digits is asked for; a reduced tree's
 * values have BST_REDUCE_DIGITS by default. */
#include <config.h>

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

#include "basis.h"
#include "ctx.h"
#include "layer.h"
#include "mat.h"
#include "sink.h"
#include "ttree_write.h"
#include "write_bound.h"

static const char *const block_label[BST_NCOMP] = {
    "Transmission Front", "Reflection Front", "Transmission Back", "Reflection Back"};

void bst_bsdf_write_opts_init(bst_bsdf_write_opts *o)
{
    memset(o, 0, sizeof *o);
    o->rank = BST_RANK_AUTO;
    o->reduce_pct = BST_REDUCE_PCT;
    o->reduce_floor = BST_REDUCE_FLOOR;
    o->reduce_tol = BST_REDUCE_TOL;
    o->digits = BST_DIGITS_AUTO;
    o->iso_fa_min = BST_ISO_FA_MIN;
    o->recip_tol = BST_RECIP_TOL;
    o->iso_refine = BST_ISO_REFINE;
}

struct xw {
    bst_ctx *ctx;
    const bst_layer *l;
    const bst_bsdf_write_opts *o;
    bsti_sink *out;
    size_t nch, n;          /* channels, patches */
    int k;                  /* Shirley-Chiu order (0: Klems) */
    bst_file_kind kind;
    double **t3;            /* rank 3: nch * BST_NCOMP tensors of (G/2) N values */
    double *iso;            /* rank 3: the FA of each */
    double *iso_hemi;       /* rank 3: the largest change of a directional-hemispherical value
                               between each and the component (NaN: not measured) */
    int *omit;              /* nch * BST_NCOMP: 1 = left out (reciprocal) */
    double *hemi;           /* Klems: n values, the hemispherical error per incident patch */
    const bst_varres *v;    /* variable resolution: fine columns over the coarse layer l, w->k
                               the fine order and kc the layer's (bst_bsdf_write_varres) */
    int kc;
    bsti_bounds bounds;     /* a reduced tree's budgets (col NULL: no bound) */
    int digits;             /* o->digits, BST_DIGITS_AUTO resolved */
    double *ring;           /* rank 3: G/2 budgets */
    double worst;           /* the largest change of a directional-hemispherical value measured
                               as written (blocks' hemi_error and recip_error), and where */
    size_t worst_ch;
    int worst_c;
    double *full;           /* a FACTORED component's values, n x n (factored_values) */
    double *coarse;         /* a component of a coarser order (bsti_mat_lr_coarse): its values
                               and budgets at that order (coarse_values), room for ncoarse */
    size_t ncoarse;
    bsti_tsums *tsums;      /* nch: transmissions' sums from the reciprocity check (or NULL) */
};

/* ------------------------------------------------------------------ matrix access */

static double tensor_get(const void *opaque, size_t index)
{
    const bst_mat *m = opaque;
    return bsti_mat_at(m, index % m->rows, index / m->rows);
}

static double zero_get(const void *opaque, size_t index)
{
    (void)opaque, (void)index;
    return 0.0;
}

/* ------------------------------------------------------------------ decisions before writing */

static int validate(struct xw *w)
{
    for (size_t ch = 0; ch < w->nch; ch++)
        for (int c = 0; c < BST_NCOMP; c++) {
            const bst_mat *m = bst_layer_get(w->l, ch, (bst_comp)c);
            if (m && !bsti_mat_finite(w->ctx, m))
                return bsti_error(w->ctx, BST_EINVAL, "writing BSDF XML: %s %s holds a value that "
                                  "is not finite", bst_layer_channel(w->l, ch), bst_comp_name((bst_comp)c));
        }
    return BST_OK;
}

/* The rank-3 tensor of channel ch, component c, taken from a rank-3 file by evaluating it at the
 * centre of every rank-3 cell: incidence in the x-z plane (no rotation), the exit direction at the
 * cell centre of the outgoing square. */
static int t3_from_file(struct xw *w, const bst_bsdf *src, size_t sch, int c, double *t3)
{
    size_t G = (size_t)1 << w->k, N = G * G, half = G / 2;
    double zin = (c == BST_TF || c == BST_RF) ? -1.0 : 1.0;
    double zout = (c == BST_TF || c == BST_RB) ? 1.0 : -1.0;
    for (size_t ix = 0; ix < half; ix++) {
        /* p0 = 0.5 - 1e-6 - r/2 at the cell centre (ix + 1/2) / G */
        double r = 1.0 - 2.0 * (((double)ix + 0.5) / (double)G) - 2e-6;
        double in[3] = {-r, 0.0, zin * sqrt(1.0 - r * r)};
        for (size_t q = 0; q < N; q++) {
            double x, y;
            bsti_sc_square_to_disk(((double)(q / G) + 0.5) / (double)G,
                                   ((double)(q % G) + 0.5) / (double)G, &x, &y);
            double out[3] = {x, y, zout * sqrt(fmax(0.0, 1.0 - x * x - y * y))};
            int rc = bst_bsdf_eval(w->ctx, src, sch, in, out, &t3[ix * N + q]);
            if (rc < 0)
                return rc;
        }
    }
    return BST_OK;
}

/* Can src supply the rank-3 tensors (rank-3 file of our order with every channel)? */
static int source_usable(const struct xw *w, const bst_bsdf *src, size_t *map)
{
    if (!src || bst_bsdf_kind(src) != BST_FILE_TT3 || bst_bsdf_order(src) != w->k)
        return 0;
    for (size_t ch = 0; ch < w->nch; ch++) {
        size_t j = 0;
        while (j < bst_bsdf_nchannels(src) &&
               strcasecmp(bst_bsdf_channel(src, j), bst_layer_channel(w->l, ch)) != 0)
            j++;
        if (j == bst_bsdf_nchannels(src))
            return 0;
        map[ch] = j;
    }
    return 1;
}

static void free_t3(struct xw *w)
{
    if (!w->t3)
        return;
    for (size_t i = 0; i < w->nch * BST_NCOMP; i++)
        bsti_free(w->ctx, w->t3[i]);
    bsti_free(w->ctx, w->t3);
    bsti_free(w->ctx, w->iso);
    bsti_free(w->ctx, w->iso_hemi);
    w->t3 = NULL;
    w->iso = w->iso_hemi = NULL;
}

/* The tolerance on directional-hemispherical values a file keeps where no bound is asked for
 * (reduce_tol INFINITY): the default one. */
static double hemi_tol(const bst_bsdf_write_opts *o)
{
    return isfinite(o->reduce_tol) ? o->reduce_tol : BST_REDUCE_TOL;
}

/* Does a component's rank-3 form keep it (fa, hemi: bsti_tt3_job's fa_min and hemi_max): flux
 * accordance iso_fa_min or more at every incident patch, and every directional-hemispherical value
 * within the tolerance (NaN: not measured to the end, so not kept)? */
static int iso_keeps(const bst_bsdf_write_opts *o, double fa, double hemi)
{
    return fa >= o->iso_fa_min && hemi <= hemi_tol(o);
}

/* Rank-3 tensors of every component; *isotropic = 0 when one fails the check (unless rank 3 is
 * forced, then all are built).  The components are built together (bsti_tt3_build: one set of
 * sample tables serves them all), after the cheap rejections.
 *
 * Why a combination with a glass pane stays rank 4 (pane + diffuser + pane, say): the pane's
 * specular reflection puts most of Rf and Rb in one exit cell (k = 5: 77 % of the column at
 * theta 75.6 degrees), and a rank-3 cell, seen from the grid's incident cells at their different
 * azimuths, straddles grid cells: the expansion spreads the peak (169 1/sr read back as 90), FA 60
 * there and below 90 at every incidence - the file would move that much flux.  Tf and Tb fail
 * too, at grazing incidence only (FA 91 in the corner cells of the outer ring: three quarters of
 * a corner cell lie in the outer half of its ring, half of a side cell, so at grazing incidence,
 * where the pane's transmission falls fast with theta, the cells of one ring differ).  The
 * 90-degree rotation test cannot see either (rotation FA 99.9: a mirror peak turns into itself),
 * so the FA of the rank-3 form decides, as it should. */
/* The rank-3 tensor of a component factored over a wide map (mat.h), built alone from its expanded
 * copy, freed before the next (bsti_tt3_build gives each job the results it gives it among others;
 * a give-up among others only spares the work of a layer that stays rank 4). */
static int t3_wide(struct xw *w, const bst_mat *m, size_t idx, int *isotropic)
{
    const bst_bsdf_write_opts *o = w->o;
    bst_mat *d;
    int rc = bsti_mat_lr_expand(w->ctx, m, BST_DOUBLE, &d);
    if (rc < 0)
        return rc;
    bsti_tt3_job job = {d, w->t3[idx], NAN, NAN};
    rc = bsti_tt3_build(w->ctx, w->k, o->iso_refine, o->rank == BST_RANK_3 ? -INFINITY
                        : o->iso_fa_min - 2.0, o->rank != BST_RANK_3, 0, BSTI_TT3_TABLE_BYTES, 0, 1,
                        &job);
    bst_mat_free(d);
    if (rc >= 0)
        w->iso[idx] = job.fa_min, w->iso_hemi[idx] = job.hemi_max;
    if (rc >= 0 && !iso_keeps(o, job.fa_min, job.hemi_max))
        *isotropic = 0;
    return rc;
}

static int build_t3(struct xw *w, int *isotropic)
{
    const bst_bsdf_write_opts *o = w->o;
    size_t G = (size_t)1 << w->k, N = G * G, total = w->nch * BST_NCOMP, nj = 0;
    *isotropic = 1;
    if (!(w->t3 = bsti_calloc(w->ctx, total, sizeof *w->t3)) ||
        !(w->iso = bsti_alloc_array(w->ctx, total, sizeof *w->iso)) ||
        !(w->iso_hemi = bsti_alloc_array(w->ctx, total, sizeof *w->iso_hemi)))
        return BST_ENOMEM;
    size_t map[64];
    int from_file = w->nch <= 64 && source_usable(w, o->rank3_source, map);
    bsti_tt3_job *jobs = bsti_alloc_array(w->ctx, total, sizeof *jobs);
    size_t *at = bsti_alloc_array(w->ctx, total, sizeof *at);
    int rc = jobs && at ? BST_OK : BST_ENOMEM;
    for (size_t ch = 0; rc >= 0 && ch < w->nch; ch++)
        for (int c = 0; rc >= 0 && c < BST_NCOMP; c++) {
            size_t idx = ch * BST_NCOMP + (size_t)c;
            const bst_mat *m = bst_layer_get(w->l, ch, (bst_comp)c);
            w->iso[idx] = w->iso_hemi[idx] = NAN; /* from the file, or absent: not measured */
            if (!(w->t3[idx] = bsti_alloc_array(w->ctx, N * (G / 2), sizeof **w->t3))) {
                rc = BST_ENOMEM;
            } else if (from_file) {
                rc = t3_from_file(w, o->rank3_source, map[ch], c, w->t3[idx]);
            } else if (m) {
                /* a specular (diagonal) component's rank-3 form spreads its peak over the
                 * azimuths of a cell ring and fails the check (glass panes at k = 3, 5, 7): not
                 * tried, which spares O(N^2) sweeps; cheap rejection next (factor 4 instead of
                 * the triangle inequality's 2) */
                double bar = 100.0 - 4.0 * (100.0 - o->iso_fa_min);
                if (bst_mat_structure(m) == BST_DIAG || bsti_tt3_rotation_fa(m, w->k, bar) < bar) {
                    *isotropic = 0;
                    if (o->rank != BST_RANK_3)
                        goto done;
                }
                if (bsti_mat_lr_wide(m)) {
                    rc = t3_wide(w, m, idx, isotropic);
                    if (rc >= 0 && !*isotropic && o->rank != BST_RANK_3)
                        goto done;
                    continue;
                }
                jobs[nj].m = m, jobs[nj].t3 = w->t3[idx];
                at[nj++] = idx;
            }
        }
    if (rc >= 0 && nj > 0) {
        /* corrections gain less than a point of FA: give up well below the bar, as soon as one
         * ring of one component falls there (the layer is then written as rank 4) */
        double stop = o->rank == BST_RANK_3 ? -INFINITY : o->iso_fa_min - 2.0;
        rc = bsti_tt3_build(w->ctx, w->k, o->iso_refine, stop, o->rank != BST_RANK_3, 0,
                            BSTI_TT3_TABLE_BYTES, 0, nj, jobs);
        for (size_t j = 0; rc >= 0 && j < nj; j++) {
            w->iso[at[j]] = jobs[j].fa_min;
            w->iso_hemi[at[j]] = jobs[j].hemi_max;
            if (!iso_keeps(o, jobs[j].fa_min, jobs[j].hemi_max))
                *isotropic = 0;
        }
    }
done:
    bsti_free(w->ctx, jobs);
    bsti_free(w->ctx, at);
    return rc;
}

/* The budgets of a reduced tree (write_bound.h); a Tf that reciprocity alone would move beyond
 * its budget is written after all.  Rounding every value to w->digits moves a patch's
 * directional-hemispherical value H by up to rho H, which no merge makes up for where that exceeds
 * the patch's budget (the bound's afford): the default digits become as many as the tolerance
 * needs; digits asked for are refused there, naming the fewest that keep it. */
static int bounds(struct xw *w)
{
    size_t G = (size_t)1 << w->k, nomit = w->nch * BST_NCOMP;
    if (w->kind == BST_FILE_TT3 && !(w->ring = bsti_alloc_array(w->ctx, G / 2, sizeof *w->ring)))
        return BST_ENOMEM;
    int *omit = bsti_alloc_array(w->ctx, nomit, sizeof *omit); /* before the bound clears any */
    if (!omit)
        return BST_ENOMEM;
    memcpy(omit, w->omit, nomit * sizeof *omit);
    double rho = bsti_bounds_rho(w->digits);
    int rc = bsti_bounds_write(w->ctx, w->l, w->v, w->o->reduce_tol, rho, w->omit, w->tsums,
                               &w->bounds);
    const bsti_bounds *b = &w->bounds;
    if (rc >= 0 && w->digits > 0 && rho > b->afford) {
        int d = bsti_bounds_digits(b->afford, w->digits + 1);
        if (w->o->digits != BST_DIGITS_AUTO) {
            char fewest[64];
            if (d)
                snprintf(fewest, sizeof fewest, "%d digits or more keep it", d);
            else
                snprintf(fewest, sizeof fewest, "only exact values keep it");
            rc = bsti_error(w->ctx, BST_EINVAL, "writing BSDF XML: values rounded to %d "
                            "significant digit%s could move %s %s's directional-hemispherical "
                            "value at patch %zu (%.4g) by up to %.2g, more than the %.2g the "
                            "tolerance %g leaves it: %s, or a larger tolerance", w->digits,
                            w->digits == 1 ? "" : "s", bst_layer_channel(w->l, b->afford_ch),
                            bst_comp_name((bst_comp)b->afford_c), b->afford_i, b->afford_h,
                            rho * b->afford_h, b->afford_b, w->o->reduce_tol, fewest);
        } else {
            bsti_bounds_free(w->ctx, &w->bounds);
            memcpy(w->omit, omit, nomit * sizeof *omit);
            w->digits = d;
            rc = bsti_bounds_write(w->ctx, w->l, w->v, w->o->reduce_tol, bsti_bounds_rho(d),
                                   w->omit, w->tsums, &w->bounds);
        }
    }
    bsti_free(w->ctx, omit);
    return rc;
}

/* What the file moves beyond the tolerance that the bound does not rule out, as options asked it
 * (bst_bsdf_write_opts' rank and digits): a TensorTree3's rank-3 form (forced: by default a layer
 * is rank 3 only where that keeps the tolerance), and digits asked for where no bound holds them
 * (Klems, no reduction, reduce_tol INFINITY), measured as written.  BST_WACCURACY with the
 * largest change, else BST_OK. */
static int accuracy(struct xw *w)
{
    double tol = hemi_tol(w->o);
    char msg[768] = "";
    size_t len = 0;
    if (w->kind == BST_FILE_TT3 && w->iso_hemi) {
        double worst = 0.0;
        size_t at = 0;
        for (size_t i = 0; i < w->nch * BST_NCOMP; i++)
            if (w->iso_hemi[i] > worst) /* (NaN: copied from a rank-3 file, or absent) */
                worst = w->iso_hemi[i], at = i;
        if (worst > tol)
            len += (size_t)snprintf(msg, sizeof msg, "a TensorTree3 of this layer, which is not "
                                    "isotropic, moves %s %s's directional-hemispherical values by "
                                    "up to %.3g (flux accordance down to %.1f %%), more than the "
                                    "tolerance %g",
                                    bst_layer_channel(w->l, at / BST_NCOMP),
                                    bst_comp_name((bst_comp)(at % BST_NCOMP)), worst, w->iso[at], tol);
    }
    int reduced = w->kind != BST_FILE_KLEMS && w->o->reduce_pct >= 0.0;
    if (w->o->digits > 0 && !w->bounds.col && w->worst > tol && len < sizeof msg)
        len += (size_t)snprintf(msg + len, sizeof msg - len, "%svalues rounded to %d significant "
                                "digit%s%s move %s %s's directional-hemispherical values by up to "
                                "%.3g as written, more than the tolerance %g", len ? "; " : "",
                                w->digits, w->digits == 1 ? "" : "s",
                                reduced ? " (and reduced with no bound)" : "",
                                bst_layer_channel(w->l, w->worst_ch),
                                bst_comp_name((bst_comp)w->worst_c), w->worst, tol);
    return len ? bsti_error(w->ctx, BST_WACCURACY, "writing BSDF XML: %s", msg) : BST_OK;
}

/* ------------------------------------------------------------------ the pieces of the file */

static const char *spectrum(const char *channel, const char **detector)
{
    static const struct { const char *name, *source, *detector; } known[] = {
        {"Visible", "CIE Illuminant D65 1nm.ssp", "ASTM E308 1931 Y.dsp"},
        {"CIE-Y", "CIE Illuminant D65 1nm.ssp", "ASTM E308 1931 Y.dsp"},
        {"CIE-X", "CIE Illuminant D65 1nm.ssp", "ASTM E308 1931 X.dsp"},
        {"CIE-Z", "CIE Illuminant D65 1nm.ssp", "ASTM E308 1931 Z.dsp"},
        {"CIE-u", "CIE Illuminant D65 1nm.ssp", NULL},
        {"CIE-v", "CIE Illuminant D65 1nm.ssp", NULL},
        /* the solar spectrum bsdfstack averages over (glass_band.c); wrapBSDF -s Solar writes D65 */
        {"Solar", "ASTM E891-87 Table 1.ssp", "None"},
    };
    for (size_t i = 0; i < sizeof known / sizeof known[0]; i++)
        if (strcasecmp(channel, known[i].name) == 0) {
            *detector = known[i].detector;
            return known[i].source;
        }
    *detector = NULL;
    return NULL;
}

static int tree_order(const struct xw *w, const bst_mat *m);

static void header(struct xw *w)
{
    const bst_bsdf_write_opts *o = w->o;
    bsti_sink *s = w->out;
    const bst_basis *b = bst_layer_basis(w->l);
    char date[64];
    if (o->date) {
        snprintf(date, sizeof date, "%s", o->date);
    } else {
        time_t now = time(NULL);
        struct tm tm;
        if (now == (time_t)-1 || !gmtime_r(&now, &tm) ||
            !strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", &tm))
            snprintf(date, sizeof date, "unknown date");
    }
    bsti_sink_puts(s, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!--\n  Written by bsdfstack ");
    bsti_sink_xml_comment(s, bst_version(), "");
    bsti_sink_puts(s, " on ");
    bsti_sink_xml_comment(s, date, "");
    bsti_sink_puts(s, "\n");
    if (o->command) {
        bsti_sink_puts(s, "  Command: ");
        bsti_sink_xml_comment(s, o->command, "");
        bsti_sink_puts(s, "\n");
    }
    if (o->description) {
        bsti_sink_puts(s, "  ");
        bsti_sink_xml_comment(s, o->description, "  ");
        bsti_sink_puts(s, "\n");
    }
    size_t nl = o->nlayers;
    const char *self = bst_layer_name(w->l);
    if (nl || self[0]) {
        bsti_sink_puts(s, "  Layers, exterior first:\n");
        for (size_t i = 0; i < (nl ? nl : 1); i++) {
            bsti_sink_printf(s, "    %zu. ", i + 1);
            bsti_sink_xml_comment(s, nl ? (o->layers[i] ? o->layers[i] : "?") : self, "");
            bsti_sink_puts(s, "\n");
        }
    }
    if (w->kind == BST_FILE_KLEMS) {
        bsti_sink_puts(s, "  Basis: ");
        bsti_sink_xml_comment(s, bst_basis_name(b), "");
        bsti_sink_printf(s, " (%zu patches per hemisphere), matrices in Columns order\n", w->n);
    } else {
        size_t G = (size_t)1 << w->k;
        bsti_sink_printf(s, "  Basis: LBNL/Shirley-Chiu, k = %d (%zu x %zu patches per hemisphere), "
                         "TensorTree%d\n", w->k, G, G, w->kind == BST_FILE_TT3 ? 3 : 4);
        if (w->v)
            bsti_sink_printf(s, "  Variable resolution: Tf and Rf at k = %d for %zu front incident "
                             "patches, k = %d elsewhere and for Tb and Rb\n", w->k, w->v->ncols, w->kc);
        if (o->reduce_pct >= 0.0 && w->bounds.col)
            bsti_sink_printf(s, "  Tree reduction: cells below the %g-th percentile of variation "
                             "merged (floor %g) where every incident patch's directional-"
                             "hemispherical T and R stay within %g of the unreduced values\n",
                             o->reduce_pct, o->reduce_floor, o->reduce_tol);
        else if (o->reduce_pct >= 0.0)
            bsti_sink_printf(s, "  Tree reduction: cells below the %g-th percentile of variation "
                             "merged (floor %g), no bound on hemispherical values\n",
                             o->reduce_pct, o->reduce_floor);
        else
            bsti_sink_puts(s, "  Tree reduction: none (only exactly constant regions merged)\n");
        for (size_t ch = 0; ch < w->nch; ch++)
            for (int c = 0; c < BST_NCOMP; c++)
                if (w->omit[ch * BST_NCOMP + (size_t)c] == 1) {
                    bsti_sink_puts(s, "  ");
                    bsti_sink_xml_comment(s, bst_layer_channel(w->l, ch), "");
                    bsti_sink_printf(s, " %s: left out, the reciprocal of %s\n", block_label[c],
                                     block_label[c == BST_TF ? BST_TB : BST_TF]);
                } else if (!w->omit[ch * BST_NCOMP + (size_t)c]) {
                    int kc = tree_order(w, bst_layer_get(w->l, ch, (bst_comp)c));
                    if (kc == w->k)
                        continue;
                    bsti_sink_puts(s, "  ");
                    bsti_sink_xml_comment(s, bst_layer_channel(w->l, ch), "");
                    bsti_sink_printf(s, " %s: a tree of order %d, the order of its values (each "
                                     "order-%d patch's are those of the order-%d patch holding it)\n",
                                     block_label[c], kc, w->k, kc);
                }
    }
    bsti_sink_puts(s, "  Values: BSDF in 1/sr; Front = exterior side (-Z)\n-->\n");
    bsti_sink_puts(s, "<WindowElement xmlns=\"http://windows.lbl.gov\" "
                      "xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
                      "xsi:schemaLocation=\"http://windows.lbl.gov/BSDF-v1.4.xsd\">\n"
                      "<WindowElementType>System</WindowElementType>\n"
                      "<FileType>BSDF</FileType>\n<Optical>\n<Layer>\n\t<Material>\n");
    const char *name = o->name ? o->name : self[0] ? self : "bsdfstack layer";
    bsti_sink_xml_element(s, "\t\t", "Name", name);
    bsti_sink_xml_element(s, "\t\t", "Manufacturer", o->manufacturer ? o->manufacturer : "Unknown");
    bsti_sink_xml_element(s, "\t\t", "DeviceType", o->device_type ? o->device_type : "Other");
    const struct { const char *tag; double v; } dims[] = {
        {"Thickness", o->thickness}, {"Width", o->width}, {"Height", o->height}};
    for (int i = 0; i < 3; i++)
        if (dims[i].v > 0.0 && isfinite(dims[i].v))
            bsti_sink_printf(s, "\t\t<%s unit=\"meter\">%.9g</%s>\n", dims[i].tag, dims[i].v, dims[i].tag);
    bsti_sink_puts(s, "\t</Material>\n\t<DataDefinition>\n");
    if (w->kind == BST_FILE_KLEMS) {
        bsti_sink_puts(s, "\t\t<IncidentDataStructure>Columns</IncidentDataStructure>\n"
                          "\t\t<AngleBasis>\n");
        bsti_sink_xml_element(s, "\t\t\t", "AngleBasisName", bst_basis_name(b));
        for (size_t i = 0; i < b->nbands; i++) {
            double centre = (i == 0 && b->theta[0] == 0.0) ? 0.0 : 0.5 * (b->theta[i] + b->theta[i + 1]);
            bsti_sink_printf(s, "\t\t\t<AngleBasisBlock>\n\t\t\t\t<Theta>%.9g</Theta>\n"
                             "\t\t\t\t<nPhis>%d</nPhis>\n\t\t\t\t<ThetaBounds>\n"
                             "\t\t\t\t\t<LowerTheta>%.9g</LowerTheta>\n"
                             "\t\t\t\t\t<UpperTheta>%.9g</UpperTheta>\n"
                             "\t\t\t\t</ThetaBounds>\n\t\t\t</AngleBasisBlock>\n",
                             centre, b->nphi[i], b->theta[i], b->theta[i + 1]);
        }
        bsti_sink_puts(s, "\t\t</AngleBasis>\n");
    } else {
        bsti_sink_printf(s, "\t\t<IncidentDataStructure>TensorTree%d</IncidentDataStructure>\n",
                         w->kind == BST_FILE_TT3 ? 3 : 4);
    }
    bsti_sink_puts(s, "\t</DataDefinition>\n");
}

static void block_head(struct xw *w, size_t ch, int c)
{
    bsti_sink *s = w->out;
    const char *name = bst_layer_channel(w->l, ch), *det, *src = spectrum(name, &det);
    bsti_sink_puts(s, "\t<WavelengthData>\n\t\t<LayerNumber>System</LayerNumber>\n"
                      "\t\t<Wavelength unit=\"Integral\">");
    bsti_sink_xml_text(s, name);
    bsti_sink_puts(s, "</Wavelength>\n");
    if (src)
        bsti_sink_xml_element(s, "\t\t", "SourceSpectrum", src);
    if (det)
        bsti_sink_xml_element(s, "\t\t", "DetectorSpectrum", det);
    bsti_sink_printf(s, "\t\t<WavelengthDataBlock>\n\t\t\t<WavelengthDataDirection>%s"
                     "</WavelengthDataDirection>\n", block_label[c]);
    if (w->kind == BST_FILE_KLEMS) {
        const char *bn = bst_basis_name(bst_layer_basis(w->l));
        bsti_sink_xml_element(s, "\t\t\t", "ColumnAngleBasis", bn);
        bsti_sink_xml_element(s, "\t\t\t", "RowAngleBasis", bn);
    } else {
        bsti_sink_puts(s, "\t\t\t<AngleBasis>LBNL/Shirley-Chiu</AngleBasis>\n");
    }
    /* wrapBSDF writes BTDF for every block; readers ignore it */
    bsti_sink_puts(s, "\t\t\t<ScatteringDataType>BTDF</ScatteringDataType>\n\t\t\t<ScatteringData>\n");
}

static void block_tail(bsti_sink *s)
{
    bsti_sink_puts(s, "\t\t\t</ScatteringData>\n\t\t</WavelengthDataBlock>\n\t</WavelengthData>\n");
}

/* Klems: text row o = outgoing patch o, its numbers the incident patches. */
static void klems_data(struct xw *w, const bst_mat *m, bst_bsdf_write_block *rep)
{
    const double *lam = bst_basis_lambda(bst_layer_basis(w->l));
    size_t n = w->n;
    double sum_abs = 0.0, sum_err = 0.0, *hemi = w->hemi;
    memset(hemi, 0, n * sizeof *hemi);
    for (size_t o = 0; o < n && !bsti_sink_failed(w->out); o++) {
        for (size_t i = 0; i < n; i++) {
            double v = bsti_mat_at(m, o, i), back;
            char buf[32];
            int len = bsti_format_double(v < 0.0 ? 0.0 : v, w->digits, buf, &back);
            if (i)
                bsti_sink_put(w->out, " ", 1);
            bsti_sink_put(w->out, buf, (size_t)len);
            sum_abs += fabs(v);
            sum_err += fabs(v - back);
            rep->max_error = fmax(rep->max_error, fabs(v - back));
            hemi[i] += lam[o] * (v - back);
        }
        bsti_sink_put(w->out, "\n", 1);
    }
    rep->values = n * n;
    rep->l1_error = sum_abs > 0.0 ? sum_err / sum_abs : 0.0;
    for (size_t i = 0; i < n; i++)
        rep->hemi_error = fmax(rep->hemi_error, fabs(hemi[i]));
}

/* A FACTORED m's values (bsti_mat_lr_values) in w->full, made at the first such component and
 * kept for the next (a fresh 2 GiB at k = 7 a component: allocated and its pages first touched
 * again each time); NULL when that memory is not there. */
static const double *factored_values(struct xw *w, const bst_mat *m)
{
    if (!m || (m->s != BST_FACTORED && m->s != BST_PLUS_LR))
        return NULL;
    if (!w->full && !(w->full = bsti_alloc_array(w->ctx, w->n * w->n, sizeof *w->full)))
        return NULL;
    if (m->s == BST_PLUS_LR) /* its base's values, then U W^T by GEMM */
        return bst_mat_to_dense_array(w->ctx, m, w->full) >= 0 ? w->full : NULL;
    return bsti_mat_lr_values(w->ctx, m, w->full) >= 0 ? w->full : NULL;
}

/* The order-kc values of a component of that coarser order, with room after them for two sets of
 * budgets (4^kc each); NULL: out of memory. */
static double *coarse_values(struct xw *w, const bst_mat *m, int kc)
{
    size_t nc = (size_t)1 << (2 * kc), need = nc * nc + 2 * nc;
    if (w->ncoarse < need) {
        bsti_free(w->ctx, w->coarse);
        w->ncoarse = 0;
        if (!(w->coarse = bsti_alloc_array(w->ctx, need, sizeof *w->coarse)))
            return NULL;
        w->ncoarse = need;
    }
    bsti_mat_lr_coarse_values(m, w->coarse);
    return w->coarse;
}

/* The order at which component m's tree is written: w->k, or the coarser order of its values
 * (bsti_mat_lr_coarse) in a rank-4 file of one order. */
static int tree_order(const struct xw *w, const bst_mat *m)
{
    int kc = w->kind == BST_FILE_TT4 && !w->v ? bsti_mat_lr_coarse(m) : 0;
    return kc > 0 ? kc : w->k;
}

static int write_blocks(struct xw *w)
{
    const bst_bsdf_write_opts *o = w->o;
    for (size_t ch = 0; ch < w->nch; ch++)
        for (int c = 0; c < BST_NCOMP; c++) {
            size_t idx = ch * BST_NCOMP + (size_t)c;
            bst_bsdf_write_block rep;
            memset(&rep, 0, sizeof rep);
            rep.channel = bst_layer_channel(w->l, ch);
            rep.comp = (bst_comp)c;
            rep.kind = w->kind;
            rep.iso_fa = w->kind == BST_FILE_TT3 ? w->iso[idx] : NAN;
            rep.iso_hemi = w->kind == BST_FILE_TT3 ? w->iso_hemi[idx] : NAN;
            rep.recip_error = NAN;
            if (!w->omit[idx]) {
                rep.written = 1;
                const bst_mat *m = bst_layer_get(w->l, ch, (bst_comp)c);
                block_head(w, ch, c);
                uint64_t before = w->out->total;
                if (w->kind == BST_FILE_KLEMS) {
                    klems_data(w, m, &rep);
                } else {
                    bsti_tensor t = {w->kind == BST_FILE_TT3 ? 3 : 4, w->k, NULL, NULL, NULL, NULL, 0, NULL};
                    bsti_varres vr = {0};
                    const bst_mat *const *fine = !w->v ? NULL : c == BST_TF ? w->v->tf
                                                 : c == BST_RF ? w->v->rf : NULL;
                    bst_mat *dense = NULL; /* a wide coarse one under fine columns, expanded */
                    if (w->v && fine && fine[ch]) { /* order k, fine columns over coarse cells */
                        int rc = bsti_mat_lr_wide(m) ? bsti_mat_lr_expand(w->ctx, m, BST_DOUBLE, &dense) : BST_OK;
                        vr = (bsti_varres){w->k, w->kc, dense ? dense : m, fine[ch], w->v->ncols,
                                           w->v->cols, NULL, NULL};
                        if (rc >= 0)
                            rc = bsti_varres_init(w->ctx, &vr);
                        if (rc < 0) {
                            bst_mat_free(dense);
                            bsti_error_prefix(w->ctx, "%s %s", rep.channel, block_label[c]);
                            return rc;
                        }
                        t.get = bsti_varres_get, t.opaque = &vr, t.fine_in = vr.in;
                    } else if (w->kind == BST_FILE_TT3) {
                        t.d = w->t3[idx];
                    } else if ((t.k = tree_order(w, m)) < w->k) {
                        if (!(t.d = coarse_values(w, m, t.k)))
                            return bsti_error(w->ctx, BST_ENOMEM, "writing BSDF XML: %s %s: out "
                                              "of memory for its order-%d values", rep.channel,
                                              block_label[c], t.k);
                    } else if (m && m->s == BST_DENSE && m->prec == BST_DOUBLE)
                        t.d = m->dense;
                    else if ((t.d = factored_values(w, m)) != NULL)
                        ; /* (expanded into the one buffer of every block) */
                    else if (bsti_mat_lr_wide(m))
                        return bsti_error(w->ctx, BST_ENOMEM, "writing BSDF XML: %s %s: out of "
                                          "memory expanding a factored component", rep.channel,
                                          block_label[c]);
                    else if (m && m->s == BST_DENSE)
                        t.f = m->dense;
                    else if (m && m->s != BST_ZERO)
                        t.get = tensor_get, t.opaque = m, t.diagonal = m->s == BST_DIAG;
                    else
                        t.get = zero_get;
                    if (w->v && !t.fine_in)
                        t.k = w->kc; /* coarse only (Tb, Rb): a tree of depth kc */
                    bsti_reduce r = {o->reduce_pct, o->reduce_floor, w->digits, NULL, NULL, 0, 0};
                    /* a Tf left out is read back from Tb's rows: measured too */
                    int recip = c == BST_TB && w->omit[ch * BST_NCOMP + BST_TF] == 1;
                    r.measure_rows = recip;
                    if (w->bounds.col) {
                        r.col_budget = w->bounds.col + idx * w->bounds.n;
                        if (w->kind == BST_FILE_TT3) {
                            /* the rank-3 form has moved each patch by up to iso_hemi already: the
                             * tree gets what is left (measured against the layer, not the form) */
                            double lost = isnan(w->iso_hemi[idx]) ? 0.0 : w->iso_hemi[idx];
                            bsti_bounds_rings(w->k, r.col_budget, w->ring);
                            for (size_t x = 0; x < ((size_t)1 << w->k) / 2; x++)
                                w->ring[x] = fmax(0.0, w->ring[x] - lost);
                            r.col_budget = w->ring;
                        }
                        if (c == BST_TB && w->omit[ch * BST_NCOMP + BST_TF] == 1)
                            r.row_budget = w->bounds.row + ch * w->bounds.n;
                        if (t.k < w->k && !w->v) { /* a coarser order's: its patches' least */
                            size_t nc = (size_t)1 << (2 * t.k);
                            double *cb = w->coarse + nc * nc;
                            bsti_mat_lr_coarse_least(r.col_budget, w->k, t.k, cb);
                            r.col_budget = cb;
                            if (r.row_budget) {
                                bsti_mat_lr_coarse_least(r.row_budget, w->k, t.k, cb + nc);
                                r.row_budget = cb + nc;
                            }
                        }
                    }
                    bsti_tree_stats st;
                    int rc = bsti_ttree_write(w->ctx, &t, &r, w->out, &st);
                    bsti_varres_done(w->ctx, &vr);
                    bst_mat_free(dense);
                    if (rc < 0 && rc != BST_EIO) {
                        bsti_error_prefix(w->ctx, "%s %s", rep.channel, block_label[c]);
                        return rc;
                    }
                    rep.values = st.values;
                    rep.leaves = st.leaves;
                    rep.threshold = st.threshold;
                    rep.l1_error = st.l1_error;
                    rep.max_error = st.max_error;
                    rep.hemi_error = st.hemi_error;
                    if (recip)
                        rep.recip_error = st.row_error;
                }
                if (rep.hemi_error > w->worst)
                    w->worst = rep.hemi_error, w->worst_ch = ch, w->worst_c = c;
                if (rep.recip_error > w->worst) /* (NaN: none) */
                    w->worst = rep.recip_error, w->worst_ch = ch, w->worst_c = BST_TF;
                rep.bytes = w->out->total - before;
                block_tail(w->out);
            }
            if (bsti_sink_failed(w->out))
                return BST_EIO;
            if (o->on_block)
                o->on_block(&rep, o->opaque);
        }
    return BST_OK;
}

/* ------------------------------------------------------------------ entry points */

static int write_kept(bst_ctx *ctx, const bst_layer *l, bsti_sink *s, const bst_bsdf_write_opts *opts,
                      const bst_varres *v);

/* The file.  A component factored over a wide map (mat.h) is read a block of columns at a time by
 * the checks and bounds, and expanded for its own block alone (write_blocks), so that one expanded
 * component is held at a time; the large blocks each component's tree takes (its measures, its
 * text) are handed from one component to the next (bsti_keep_begin): fresh ones cost their pages'
 * faults again. */
static int write_layer(bst_ctx *ctx, const bst_layer *l, bsti_sink *s, const bst_bsdf_write_opts *opts,
                       const bst_varres *v)
{
    if (!ctx)
        return BST_EINVAL;
    bsti_keep_begin(ctx);
    int rc = write_kept(ctx, l, s, opts, v);
    bsti_keep_end(ctx);
    return rc;
}

static int write_kept(bst_ctx *ctx, const bst_layer *l, bsti_sink *s, const bst_bsdf_write_opts *opts,
                      const bst_varres *v)
{
    if (!l)
        return bsti_error(ctx, BST_EINVAL, "writing BSDF XML: NULL layer");
    bst_bsdf_write_opts def;
    if (!opts) {
        bst_bsdf_write_opts_init(&def);
        opts = &def;
    }
    if (opts->reduce_pct >= 100.0 || isnan(opts->reduce_pct) || !(opts->reduce_floor > 0.0) ||
        !(opts->reduce_tol >= 0.0) || opts->digits < BST_DIGITS_AUTO || opts->iso_refine < 0 ||
        isnan(opts->iso_fa_min) ||
        (opts->rank != BST_RANK_AUTO && opts->rank != BST_RANK_3 && opts->rank != BST_RANK_4))
        return bsti_error(ctx, BST_EINVAL, "writing BSDF XML: invalid options (reduce_pct %g must "
                          "be < 100, reduce_floor %g > 0, reduce_tol %g >= 0, digits %d >= -1, "
                          "rank %d 0, 3 or 4)", opts->reduce_pct, opts->reduce_floor,
                          opts->reduce_tol, opts->digits, (int)opts->rank);
    struct xw w;
    memset(&w, 0, sizeof w);
    w.ctx = ctx;
    w.l = l;
    w.o = opts;
    w.out = s;
    w.nch = bst_layer_nchannels(l);
    const bst_basis *b = bst_layer_basis(l);
    w.n = bst_basis_size(b);
    w.k = bst_basis_order(b);
    w.v = v;
    int rc = validate(&w);
    if (rc >= 0 && v) {
        w.kc = w.k;
        if (bst_basis_kind_of(b) != BST_BASIS_SHIRLEY_CHIU || opts->rank == BST_RANK_3 ||
            v->k <= w.kc || v->k > BST_K_MAX || (v->ncols && !v->cols))
            return bsti_error(ctx, BST_EINVAL, "writing variable resolution: the coarse layer must "
                              "be Shirley-Chiu of an order below the fine k = %d (<= %d), rank 4",
                              v->k, BST_K_MAX);
        w.k = v->k;
    }
    if (rc < 0)
        return rc;
    if (!(w.omit = bsti_calloc(ctx, w.nch * BST_NCOMP + 1, sizeof *w.omit)))
        return BST_ENOMEM;
    if (bst_basis_kind_of(b) == BST_BASIS_KLEMS) {
        w.kind = BST_FILE_KLEMS;
        if (!(w.hemi = bsti_alloc_array(ctx, w.n, sizeof *w.hemi)))
            rc = BST_ENOMEM;
    } else {
        w.kind = BST_FILE_TT4;
        if (opts->rank != BST_RANK_4 && !v) {
            int iso;
            rc = build_t3(&w, &iso);
            if (rc >= 0 && (iso || opts->rank == BST_RANK_3))
                w.kind = BST_FILE_TT3;
            else
                free_t3(&w);
        }
        int may_omit = w.kind == BST_FILE_TT4 && opts->recip_tol >= 0.0 && !v;
        /* the check's reading of both transmissions gives the bound their sums (bsti_tsums) */
        if (rc >= 0 && may_omit && !(w.tsums = bsti_calloc(ctx, w.nch, sizeof *w.tsums)))
            rc = BST_ENOMEM;
        for (size_t ch = 0; rc >= 0 && may_omit && ch < w.nch; ch++) {
            double err = INFINITY; /* Tf(o, i) = Tb(a(i), a(o)) within recip_tol max|T|? */
            bsti_tsums *ts = &w.tsums[ch];
            if (!(ts->tf_col = bsti_alloc_array(ctx, 3 * w.n, sizeof *ts->tf_col)))
                rc = BST_ENOMEM;
            else
                ts->tb_col = ts->tf_col + w.n, ts->tb_row = ts->tb_col + w.n;
            if (rc >= 0 && bst_layer_get(l, ch, BST_TB) && bst_layer_get(l, ch, BST_TF))
                rc = bsti_reciprocity_sums(ctx, l, ch, &err, ts);
            if (rc >= 0 && err <= opts->recip_tol)
                w.omit[ch * BST_NCOMP + BST_TF] = 1; /* keep Transmission Back, as genBSDF */
        }
    }
    /* components absent from the layer are left out (readers take a missing reflection as zero,
     * a missing transmission from the other side's by reciprocity) */
    int any = 0;
    for (size_t ch = 0; ch < w.nch; ch++)
        for (int c = 0; c < BST_NCOMP; c++) {
            if (!bst_layer_get(l, ch, (bst_comp)c))
                w.omit[ch * BST_NCOMP + (size_t)c] = 2;
            any |= !w.omit[ch * BST_NCOMP + (size_t)c];
        }
    if (rc >= 0 && !any)
        rc = bsti_error(ctx, BST_EINVAL, "writing BSDF XML: the layer has no component to write");
    w.digits = opts->digits != BST_DIGITS_AUTO ? opts->digits
               : w.kind != BST_FILE_KLEMS && opts->reduce_pct >= 0.0 ? BST_REDUCE_DIGITS : 0;
    if (rc >= 0 && w.kind != BST_FILE_KLEMS && opts->reduce_pct >= 0.0 && isfinite(opts->reduce_tol))
        rc = bounds(&w);
    if (rc >= 0) {
        header(&w);
        rc = write_blocks(&w);
    }
    if (rc >= 0) {
        bsti_sink_puts(s, "</Layer>\n</Optical>\n</WindowElement>\n");
        if (bsti_sink_flush(s) != 0)
            rc = BST_EIO;
    }
    if (rc >= 0)
        rc = accuracy(&w);
    free_t3(&w);
    bsti_bounds_free(ctx, &w.bounds);
    bsti_free(ctx, w.ring);
    bsti_free(ctx, w.full);
    bsti_free(ctx, w.coarse);
    for (size_t ch = 0; w.tsums && ch < w.nch; ch++)
        bsti_free(ctx, w.tsums[ch].tf_col);
    bsti_free(ctx, w.tsums);
    bsti_free(ctx, w.omit);
    bsti_free(ctx, w.hemi);
    if (rc == BST_EIO)
        return bsti_error(ctx, BST_EIO, "writing BSDF XML: write failed%s%s%s", s->err ? " (" : "",
                          s->err ? strerror(s->err) : "", s->err ? ")" : "");
    return rc;
}

int bst_bsdf_write_fn(bst_ctx *ctx, const bst_layer *layer, bst_bsdf_write_sink fn, void *opaque,
                      const bst_bsdf_write_opts *opts)
{
    if (!fn)
        return ctx ? bsti_error(ctx, BST_EINVAL, "writing BSDF XML: NULL output function") : BST_EINVAL;
    bsti_sink *s = ctx ? bsti_malloc(ctx, sizeof *s) : NULL;
    if (!s)
        return ctx ? BST_ENOMEM : BST_EINVAL;
    bsti_sink_init(s, fn, opaque);
    int rc = write_layer(ctx, layer, s, opts, NULL);
    bsti_free(ctx, s);
    return rc;
}

int bst_bsdf_write(bst_ctx *ctx, const bst_layer *layer, FILE *fp, const bst_bsdf_write_opts *opts)
{
    if (!fp)
        return ctx ? bsti_error(ctx, BST_EINVAL, "writing BSDF XML: NULL stream") : BST_EINVAL;
    int rc = bst_bsdf_write_fn(ctx, layer, bsti_sink_file, fp, opts);
    if (rc >= 0 && (fflush(fp) != 0 || ferror(fp)))
        rc = bsti_error(ctx, BST_EIO, "writing BSDF XML: write failed (%s)", strerror(errno));
    return rc;
}

/* Write to path through bst_output (a temporary renamed over a regular file; a device, FIFO or
 * link target written directly): the layer, or with v the variable-resolution file over it. */
static int write_to_path(bst_ctx *ctx, const bst_layer *layer, const bst_varres *v, const char *path,
                         const bst_bsdf_write_opts *opts)
{
    bst_output *o;
    int rc = bst_output_open(ctx, path, &o);
    if (rc < 0)
        return rc;
    rc = v ? bst_bsdf_write_varres(ctx, layer, v, bst_output_file(o), opts)
           : bst_bsdf_write(ctx, layer, bst_output_file(o), opts);
    if (rc < 0) {
        bsti_error_prefix(ctx, "%s", path);
        bst_output_abort(o);
        return rc;
    }
    int wc = bst_output_commit(o);
    return wc < 0 ? wc : rc;
}

int bst_bsdf_write_path(bst_ctx *ctx, const bst_layer *layer, const char *path,
                        const bst_bsdf_write_opts *opts)
{
    return write_to_path(ctx, layer, NULL, path, opts);
}

/* ------------------------------------------------------------------ variable resolution */

int bst_bsdf_write_varres(bst_ctx *ctx, const bst_layer *coarse, const bst_varres *v, FILE *fp,
                          const bst_bsdf_write_opts *opts)
{
    if (!ctx)
        return BST_EINVAL;
    if (!fp || !v)
        return bsti_error(ctx, BST_EINVAL, "writing variable resolution: NULL stream or columns");
    bsti_sink *s = bsti_malloc(ctx, sizeof *s);
    if (!s)
        return BST_ENOMEM;
    bsti_sink_init(s, bsti_sink_file, fp);
    int rc = write_layer(ctx, coarse, s, opts, v);
    bsti_free(ctx, s);
    if (rc >= 0 && (fflush(fp) != 0 || ferror(fp)))
        rc = bsti_error(ctx, BST_EIO, "writing BSDF XML: write failed (%s)", strerror(errno));
    return rc;
}

int bst_bsdf_write_varres_path(bst_ctx *ctx, const bst_layer *coarse, const bst_varres *v,
                               const char *path, const bst_bsdf_write_opts *opts)
{
    if (!v)
        return ctx ? bsti_error(ctx, BST_EINVAL, "writing variable resolution: NULL columns") : BST_EINVAL;
    return write_to_path(ctx, coarse, v, path, opts);
}
