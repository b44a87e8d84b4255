/* plan.c - the decisions a stack's combination takes, in one place for every client (the program's
 * combine, batch and MPI ranks, Python): which basis when none is asked, which channels, whether
 * spectral panes combine wavelength by wavelength or band values per channel (and why), and how
 * much memory the work needs (bsdfstack.h, "plans").
 *
 * The basis rule: a rank-4 tree is constant on the cells of its order and the combination keeps
 * that (a finer cell's projected solid angle is its parent's quarter, so every product and inverse
 * of replicated matrices is replicated), so the finest order among the files holds all they say;
 * above it the system is that order's, each value repeated.  The combination holds such layers
 * factored at their own order (issue #31) and the writer writes the system's trees at that order
 * (bsti_mat_lr_coarse); with --dense, each order above costs up to 64 times the time and 16 times
 * the values to write.
 *
 * The spectral plan follows WINDOW and Windows-CalcEngine: a stack whose every layer is a pane with
 * spectral data, or WINDOW's dual-band material (a file layer with Solar and Visible channels), is
 * combined wavelength by wavelength and averaged per channel afterwards (spectral.c); anything else
 * combines each channel's band values.
 *
 * The memory model is the one bench/README.md checks against measured peaks. */
#include <config.h>

#include <math.h>

#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "ctx.h"

void bst_plan_pick_basis(size_t n, const bst_bsdf *const *files, const bst_basis *const *given,
                         int k, const char *klems, bst_plan_basis *pick)
{
    memset(pick, 0, sizeof *pick);
    pick->file = -1;
    pick->given = -1;
    int all_rank4 = n > 0;
    long klems_file = -1, given_at = -1;
    for (size_t i = 0; i < n; i++) {
        const bst_bsdf *f = files ? files[i] : NULL;
        all_rank4 &= f && bst_bsdf_kind(f) == BST_FILE_TT4;
        if (!f) {
            if (given && given[i] && given_at < 0)
                given_at = (long)i;
            continue;
        }
        if (bst_bsdf_order(f) > pick->finest)
            pick->finest = bst_bsdf_order(f);
        if (klems_file < 0 && bst_bsdf_kind(f) == BST_FILE_KLEMS)
            klems_file = (long)i;
    }
    if (klems) {
        pick->klems = klems;
        snprintf(pick->why, sizeof pick->why, "the Klems %s basis, as asked", klems);
    } else if (k > 0) {
        pick->k = k;
        snprintf(pick->why, sizeof pick->why, "Shirley-Chiu k = %d, as asked", k);
        if (all_rank4 && k > pick->finest)
            snprintf(pick->note, sizeof pick->note, "every layer is a rank-4 tensor tree of order "
                     "%d or less: -k %d gives their order-%d system, each patch's values repeated "
                     "over its %d finer patches, written as its order-%d trees (with --dense at "
                     "order %d, %.0f times the values); use -k %d, or layers of order %d",
                     pick->finest, k, pick->finest, 1 << (2 * (k - pick->finest)), pick->finest, k,
                     (double)(1ull << (4 * (k - pick->finest))), pick->finest, k);
    } else if (pick->finest) {
        pick->k = pick->finest > BST_K_MAX ? BST_K_MAX : pick->finest;
        snprintf(pick->why, sizeof pick->why, "Shirley-Chiu k = %d, the finest tree order among "
                 "the files", pick->k);
    } else if (klems_file >= 0) {
        pick->file = klems_file;
        snprintf(pick->why, sizeof pick->why, "the Klems basis of layer %ld, the first Klems file",
                 klems_file + 1);
    } else if (given_at >= 0) {
        pick->given = given_at;
        snprintf(pick->why, sizeof pick->why, "the basis of layer %ld, given over it", given_at + 1);
    } else {
        pick->k = 5;
        snprintf(pick->why, sizeof pick->why, "Shirley-Chiu k = 5, the default (no layer is a file)");
    }
}

int bst_plan_make_basis(bst_ctx *ctx, const bst_plan_basis *pick, size_t n,
                        const bst_bsdf *const *files, const bst_basis *const *given, bst_basis **out)
{
    if (!ctx || !pick || !out)
        return BST_EINVAL;
    *out = NULL;
    if (pick->klems)
        return bst_basis_new_klems(ctx, pick->klems, out);
    if (pick->k)
        return bst_basis_new_sc(ctx, pick->k, out);
    if (pick->file >= 0 && (size_t)pick->file < n && files && files[pick->file] &&
        bst_bsdf_klems_basis(files[pick->file]))
        return bst_basis_copy(ctx, bst_bsdf_klems_basis(files[pick->file]), out);
    if (pick->given >= 0 && (size_t)pick->given < n && given && given[pick->given])
        return bst_basis_copy(ctx, given[pick->given], out);
    return bsti_error(ctx, BST_EINVAL, "plan: the basis picked (layer %ld) is not there",
                      pick->file >= 0 ? pick->file + 1 : pick->given + 1);
}

int bst_plan_is_band(const char *name)
{
    static const char *const bands[] = {"Visible", "Solar", "CIE-X", "CIE-Y", "CIE-Z"};
    for (size_t i = 0; name && i < sizeof bands / sizeof bands[0]; i++)
        if (strcasecmp(name, bands[i]) == 0)
            return 1;
    return 0;
}

size_t bst_plan_channels(size_t n, const bst_layer *const *layers, const char **names)
{
    if (n == 0 || !layers || !layers[0])
        return 0;
    size_t m = 0;
    for (size_t c = 0; c < bst_layer_nchannels(layers[0]); c++) {
        const char *name = bst_layer_channel(layers[0], c);
        size_t i = 1;
        while (i < n && layers[i] && bst_layer_find_channel(layers[i], name) >= 0)
            i++;
        if (i == n)
            names[m++] = name;
    }
    return m;
}

/* A layer of a file with Solar and Visible: WINDOW's dual-band material in a spectral stack. */
static int is_dual_band(const bst_plan_layer *l)
{
    return l->from_file && bst_layer_find_channel(l->layer, "Solar") >= 0 &&
           bst_layer_find_channel(l->layer, "Visible") >= 0;
}

static int decide(size_t n, const bst_plan_layer *layers, int per_channel, size_t first_plain,
                  size_t npanes, size_t ndual, size_t nch, const char *const *names, size_t bad,
                  char *why, size_t size, int *warn);

/* What bst_plan_spectral says of a file layer with Solar but no Visible (--channels Solar reads no
 * more): *warn, as a user who asked for Solar alone does not expect it. */
static const char solar_only[] = "has Solar but not Visible, which WINDOW's dual-band rule needs "
                                 "beside it: name Visible in --channels too";

int bst_plan_spectral(bst_ctx *ctx, size_t n, const bst_plan_layer *layers, int per_channel,
                      char *why, size_t size, int *spectral, int *warn)
{
    size_t first_plain = n, ndual = 0, npanes = 0;
    if (warn)
        *warn = 0;
    if (!ctx)
        return BST_EINVAL;
    if (!layers || n == 0 || !layers[0].layer || !why || size == 0 || !spectral)
        return bsti_error(ctx, BST_EINVAL, "plan: no layers, or no room for the answer");
    const bst_layer **ls = bsti_alloc_array(ctx, n, sizeof *ls);
    const char **names = bsti_alloc_array(ctx, bst_layer_nchannels(layers[0].layer) + 1, sizeof *names);
    if (!ls || !names) {
        bsti_free(ctx, ls), bsti_free(ctx, names);
        return BST_ENOMEM;
    }
    for (size_t i = 0; i < n; i++) {
        ls[i] = layers[i].layer;
        if (layers[i].pane)
            npanes++;
        else if (is_dual_band(&layers[i]))
            ndual++;
        else if (first_plain == n)
            first_plain = i;
    }
    size_t nch = bst_plan_channels(n, ls, names), bad = 0;
    while (bad < nch && bst_plan_is_band(names[bad]))
        bad++;
    *spectral = decide(n, layers, per_channel, first_plain, npanes, ndual, nch, names, bad, why,
                       size, warn);
    bsti_free(ctx, ls), bsti_free(ctx, names);
    return BST_OK;
}

/* bst_plan_spectral's decision, with the stack's counts: the first layer that is neither a pane
 * nor dual-band, the panes, the dual-band layers, the common channels and the first that is not
 * a band. */
static int decide(size_t n, const bst_plan_layer *layers, int per_channel, size_t first_plain,
                  size_t npanes, size_t ndual, size_t nch, const char *const *names, size_t bad,
                  char *why, size_t size, int *warn)
{
    const bst_plan_layer *p = first_plain < n ? &layers[first_plain] : NULL;
    const char *pname = p ? bst_layer_name(p->layer) : "";
    if (per_channel) {
        snprintf(why, size, "band values combined per channel (as asked, --per-channel)");
        return 0;
    }
    if (p && npanes && p->from_file && bst_layer_find_channel(p->layer, "Solar") >= 0 &&
        bst_layer_find_channel(p->layer, "Visible") < 0) {
        snprintf(why, size, "band values combined per channel (layer %zu, %s, %s)", first_plain + 1,
                 pname, solar_only);
        if (warn)
            *warn = 1;
        return 0;
    }
    if (p) {
        snprintf(why, size, "band values combined per channel (layer %zu, %s, has no spectral data%s)",
                 first_plain + 1, pname, npanes ? " and no Solar and Visible channels" : "");
        return 0;
    }
    if (!npanes) {
        snprintf(why, size, "band values combined per channel (no layer is a pane with spectral data)");
        return 0;
    }
    if (nch == 0 || bad < nch) {
        snprintf(why, size, "band values combined per channel (channel %s is not a spectral band)",
                 nch ? names[bad] : "(none in common)");
        return 0;
    }
    int len = snprintf(why, size, "combined wavelength by wavelength (union of the panes' measured "
                       "wavelengths%s, or a band's integration grid where shorter), then averaged "
                       "per channel", ndual ? " and the dual-band points 0.3, 0.38 -+ 1e-6, "
                       "0.78 -+ 1e-6, 2.5 um" : "");
    for (size_t i = 0; i < n && len > 0 && (size_t)len < size; i++)
        if (!layers[i].pane)
            len += snprintf(why + len, size - (size_t)len, "; layer %zu, %s, as WINDOW's dual-band "
                            "material (Visible inside 0.38..0.78 um, (Solar - %g Visible) / %g "
                            "outside, clamped at 0)", i + 1, bst_layer_name(layers[i].layer),
                            BST_DUAL_BAND_F, 1.0 - BST_DUAL_BAND_F);
    return 1;
}

/* The sums over the layers the model counts (bst_plan_memory_held). */
struct held_sum {
    size_t dense_files, dense_made, factored;
    double made_dense_bytes; /* per N^2: 8 a double component made, 4 a float one */
    double sparse;   /* bytes of file components that come out sparse (value and index each) */
    double coarse;   /* bytes of coarse matrices held factored, and the largest one */
    double largest;
    double made_small; /* bytes of made layers' factored components (diagonals, K, maps) */
    size_t sparse_made; /* made layers held sparse (a mirror blind, black slats) */
    size_t plus;     /* made components held sparse plus low rank */
    size_t nres;     /* the fewest channels a file or made layer holds (0: none known) */
};

static void fewest(struct held_sum *t, size_t nch)
{
    if (nch && (!t->nres || nch < t->nres))
        t->nres = nch;
}

/* A file layer's components: dense, sparse or (a tree coarser than k) factored. */
static void count_file(const bst_bsdf *f, unsigned comps, int k, double cells, struct held_sum *t)
{
    int d = bst_bsdf_depth(f);
    /* a rank-4 tree coarser than k: its own order's matrix (resample.c, tree_is_factored); so is
     * a rank-3 one laid on the grid at its own order (BST_RANK3_NATIVE) */
    bst_file_kind kind = bst_bsdf_kind(f);
    int at_own = kind == BST_FILE_TT4 ||
                 (kind == BST_FILE_TT3 && bst_bsdf_rank3_rule(f) == BST_RANK3_NATIVE);
    double coarse = at_own && d >= 1 && d < k ? 8.0 * pow(4.0, 2.0 * d) : 0.0;
    fewest(t, bst_bsdf_nchannels(f));
    for (size_t ch = 0; ch < bst_bsdf_nchannels(f); ch++)
        for (int c = 0; c < BST_NCOMP; c++) {
            double x = !comps || (comps & BST_COMP_BIT(c)) ? bst_bsdf_fill(f, ch, (bst_comp)c) : 0;
            if (x > BST_SPARSE_MAX_FILL && coarse > 0)
                t->coarse += coarse, t->largest = fmax(t->largest, coarse);
            else if (x > BST_SPARSE_MAX_FILL)
                t->dense_files++;
            else
                t->sparse += 16.0 * x * cells;
        }
}

/* A made layer held sparse (or sparse plus low rank) where its results stay so: its sparse parts
 * and those of the results formed from it, a quarter of N^2 doubles a channel (beside a pane at
 * k = 7 the reference blind's geometry holds 19 million values a channel in the results, 7 % of
 * N^2; the mirror blind's 0.6 GiB a channel, README.md). */
static void bytes_sparse_made(const struct held_sum *t, double cells, double *base)
{
    if (t->sparse_made)
        *base += (double)(t->nres ? t->nres : 1) * 0.25 * cells * 8.0;
}

/* The model over layers[i], or files[i] where layers is NULL (either may be NULL). */
static double memory_of(const bst_basis *basis, size_t n, const bst_bsdf *const *files,
                        const bst_plan_held *layers, unsigned comps, bst_precision read,
                        int combining, bst_precision work, bst_plan_need *need)
{
    double N = (double)bst_basis_size(basis), cells = N * N;
    int k = bst_basis_kind_of(basis) == BST_BASIS_SHIRLEY_CHIU ? bst_basis_order(basis) : 0;
    struct held_sum t = {0};
    for (size_t i = 0; (layers || files) && i < n; i++) {
        const bst_plan_held none = {.file = files ? files[i] : NULL}, *h = layers ? &layers[i] : &none;
        if (h->file) {
            count_file(h->file, comps, k, cells, &t);
            continue;
        }
        fewest(&t, h->nchannels);
        /* not a pane; a channel sparse plus low rank beside a factored one counts too */
        t.sparse_made += h->nchannels && (h->plus || (!h->dense && !h->factored));
        t.dense_made += h->dense;
        t.made_dense_bytes += (double)h->dense * (h->precision == BST_FLOAT ? 4.0 : 8.0);
        t.factored += h->factored;
        t.plus += h->plus;
        if (h->factored) /* each: its diagonal and K; the map once a channel */
            t.made_small += (double)h->factored * 8.0 * (N + (double)h->width * (double)h->width) +
                            (double)(h->nchannels ? h->nchannels : 1) * 16.0 * N * (double)h->width;
    }
    double rb = read == BST_FLOAT ? 4.0 : 8.0, wb = work == BST_FLOAT ? 4.0 : 8.0;
    bst_plan_need got = {.dense = t.dense_files + t.dense_made,
                         .dense_bytes = cells * ((double)t.dense_files * rb + t.made_dense_bytes)};
    double base = 64.0 * 1048576.0 + 0.5 * cells + t.sparse + t.coarse + t.made_small, bytes;
    if (got.dense) {
        double w = combining ? 3.0 * wb : 0.0;
        bytes = base + got.dense_bytes + cells * (w > 8.0 ? w : 8.0);
    } else if (combining && n >= 3 && t.sparse_made) {
        /* a sparse layer between two others (a mirror blind between panes): its partial stack's
         * inter-reflection with the next layer fills, and the results are dense from that step
         * on (stack.c): four a channel, held until written, and the last channel's step at work
         * beside them (the inverse and the two solutions its results are formed from: one N^2
         * more than the four), and the partial stack's sparse matrices (17 million values at
         * k = 7, 8 % of N^2: a quarter of N^2 doubles counted).  Measured at k = 7 in single,
         * two channels: 9.2 GiB (bench/README.md).  A sparse file (a pane's tree, a ray-traced
         * mirror) is not counted so: its matrices may stay sparse. */
        size_t nch = t.nres ? t.nres : 1;
        got.dense = 4 * nch;
        got.dense_bytes = (double)got.dense * cells * wb;
        bytes = base + got.dense_bytes + cells * wb + 0.25 * cells * 8.0;
    } else if (t.factored || t.plus) {
        bytes_sparse_made(&t, cells, &base);
        /* factored layers over wide maps: a stack hands its results over factored (stack.c,
         * hand_over), their readers take blocks of columns (bsti_cols: up to 32 MiB each, two at
         * a time), and the writer expands one component at a time into one grid of doubles
         * (xml_write.c), combined or not; so it does sparse plus low-rank ones (a pane and a
         * blind of mirror and diffuse slats, or the blind alone) */
        got.expanded = 1;
        got.expanded_bytes = 8.0 * cells;
        bytes = base + got.expanded_bytes + 64.0 * 1048576.0 + (combining ? 3.0 * t.largest : 0.0);
    } else {
        /* a factored combination works on coarse matrices: about three at a time; the tree
         * writer expands one factored component (xml_write.c) */
        bytes_sparse_made(&t, cells, &base);
        bytes = base + (combining ? 3.0 * t.largest : 0.0) + (t.coarse > 0 ? 8.0 * cells : 0.0);
    }
    if (need)
        *need = got;
    return bytes;
}

double bst_plan_memory_held(const bst_basis *basis, size_t n, const bst_plan_held *layers,
                            unsigned comps, bst_precision read, int combining, bst_precision work,
                            bst_plan_need *need)
{
    return memory_of(basis, n, NULL, layers, comps, read, combining, work, need);
}

double bst_plan_memory(const bst_basis *basis, size_t n, const bst_bsdf *const *files,
                       unsigned comps, bst_precision read, int combining, bst_precision work,
                       size_t *ndense)
{
    bst_plan_need need;
    double bytes = memory_of(basis, n, files, NULL, comps, read, combining, work, &need);
    if (ndense)
        *ndense = need.dense;
    return bytes;
}

double bst_plan_work(size_t n, const bst_structure *structure, size_t N, double *work)
{
    if (n == 0 || !structure)
        return 0.0;
    double dn = (double)N, unit[4] = {0.0, dn, dn * dn, dn * dn * dn}, sum = 0.0;
    bst_structure s = structure[0];
    for (size_t i = 1; i < n; i++) {
        if (structure[i] > s)
            s = structure[i];
        double w = s >= BST_ZERO && s <= BST_DENSE ? unit[s] : unit[BST_DENSE];
        if (work)
            work[i - 1] = w;
        sum += w;
    }
    return sum;
}
