/* ttree_write.c - emitting RADIANCE tensor trees from a full component tensor, exactly or reduced
 * by a variation criterion (conventions and orders in ttree_write.h).
 *
 * Three passes over the tensor, all streaming:
 * 1. build: every node above the cells (the finest 2^D blocks, their parents, ... the root) gets a
 *    variation measure m, kept as one float per node; m = 0 exactly when the node's region is
 *    constant, and m never decreases from a node to its parent, so "m <= threshold" selects whole
 *    subtrees and a node is merged only if everything below it would be.
 * 2. threshold: the pct-th percentile of m over the finest blocks (selection on a copy).
 * 3. emit: depth first; a node with m <= threshold becomes a one-value leaf (its average), a finest
 *    block above it a 2^D-value leaf, anything else a branch.  The error each leaf makes, against
 *    the value a reader will store (single precision), is summed on the way.
 * The measure of a finest block is sd / (sqrt(mean) + floor); of a larger node, the largest of its
 * children's measures and of the same ratio over the children's means.  Dividing by the root of
 * the mean makes Monte Carlo noise (variance proportional to the mean) count about the same
 * everywhere, so the percentile culls noise and keeps structure. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "mat.h"
#include "ttree_write.h"

/* Progress is reported about this many times per tree. */
#define PROGRESS_STEPS 256

struct tw {
    bst_ctx *ctx;
    const bsti_tensor *t;
    int D, k;
    size_t G, half;                /* rank 3: cells of dimension 0 that hold data (G/2) */
    float *m;                      /* variation measure of every node of levels 1..k */
    size_t off[BST_K_MAX + 2];     /* first node of level l in m (level l: side 2^l cells) */
    double thresh;
    int force;                     /* expand the path of child 0 down to the finest blocks */
    int digits;
    double floor;
    bsti_sink *out;
    bsti_tree_stats *st;
    double *hemi;                  /* per incident cell: sum over outgoing cells of the error */
    size_t nin;
    double sum_abs, sum_err;
    int bad;                       /* build found a value that is not finite */
    double badval;
    size_t done, total, next_report;
};

/* ------------------------------------------------------------------ tensor access */

/* Raw value of cell c (rank 3: 0 in the unused upper half of dimension 0). */
static inline double cell(const struct tw *w, const size_t *c)
{
    size_t G = w->G, idx;
    if (w->D == 4) {
        idx = ((c[0] * G + c[1]) * G + c[2]) * G + c[3];
    } else {
        if (c[0] >= w->half)
            return 0.0;
        idx = (c[0] * G + c[1]) * G + c[2];
    }
    const bsti_tensor *t = w->t;
    return t->d ? t->d[idx] : t->f ? (double)t->f[idx] : t->get(t->opaque, idx);
}

/* Negative BSDF values (round-off of a combination) are written as 0, as readers read them. */
static inline double clamp0(double v) { return v < 0.0 ? 0.0 : v; }

static inline size_t node_index(const struct tw *w, int l, const size_t *c)
{
    size_t S = w->G >> l, idx = 0;
    for (int i = 0; i < w->D; i++)
        idx = idx * S + (c[i] >> l);
    return w->off[l] + idx;
}

static float measure(double sd, double mean, double floor)
{
    double m = sd / (sqrt(mean) + floor);
    if (!(m >= FLT_MIN))
        return FLT_MIN; /* non-constant: strictly above 0 */
    return m > FLT_MAX ? FLT_MAX : (float)m;
}

/* ------------------------------------------------------------------ pass 1: measures */

/* Measure of the node of level l at corner c (in cells); returns its mean (exact when constant). */
static double build(struct tw *w, int l, const size_t *c, float *m_out)
{
    int D = w->D, nk = 1 << D;
    double vals[16], mean = 0.0;
    float m;
    if (D == 4 && w->t->diagonal && (c[0] != c[2] || c[1] != c[3])) {
        /* an aligned block off the diagonal: zero, its measures left at 0 (calloc) */
        *m_out = 0.0f;
        return 0.0;
    }
    if (l == 1) {
        double lo = INFINITY, hi = -INFINITY, sum = 0.0;
        for (int j = 0; j < nk; j++) {
            size_t cc[4];
            for (int i = 0; i < D; i++)
                cc[i] = c[i] + (size_t)((j >> i) & 1);
            double v = cell(w, cc);
            if (!isfinite(v) || v > FLT_MAX) {
                if (!w->bad)
                    w->badval = v;
                w->bad = 1;
                v = 0.0;
            }
            if (v < 0.0) {
                w->st->negatives++;
                v = 0.0;
            }
            vals[j] = v;
            lo = fmin(lo, v), hi = fmax(hi, v), sum += v;
        }
        if (lo == hi) {
            mean = lo;
            m = 0.0f;
        } else {
            mean = sum / nk;
            double ss = 0.0;
            for (int j = 0; j < nk; j++)
                ss += (vals[j] - mean) * (vals[j] - mean);
            m = measure(sqrt(ss / nk), mean, w->floor);
        }
    } else {
        float ms[16], mmax = 0.0f;
        int constant = 1;
        for (int j = 0; j < nk; j++) {
            size_t cc[4];
            for (int i = 0; i < D; i++)
                cc[i] = c[i] + ((size_t)((j >> i) & 1) << (l - 1));
            vals[j] = build(w, l - 1, cc, &ms[j]);
            mmax = ms[j] > mmax ? ms[j] : mmax;
            constant &= ms[j] == 0.0f && vals[j] == vals[0];
            mean += vals[j];
        }
        if (constant) {
            mean = vals[0];
            m = 0.0f;
        } else {
            mean /= nk;
            double ss = 0.0;
            for (int j = 0; j < nk; j++)
                ss += (vals[j] - mean) * (vals[j] - mean);
            m = measure(sqrt(ss / nk), mean, w->floor);
            m = m > mmax ? m : mmax;
        }
    }
    w->m[node_index(w, l, c)] = m;
    *m_out = m;
    return mean;
}

/* k-th smallest (0-based) of a[0..n-1], reordering a (Wirth's selection with a median-of-3
 * pivot value: the scans stop at elements equal to it, so runs of equal values cost no more). */
static float med3(float a, float b, float c)
{
    if (a < b)
        return b < c ? b : (a < c ? c : a);
    return a < c ? a : (b < c ? c : b);
}

static float select_kth(float *a, size_t n, size_t k)
{
    ptrdiff_t l = 0, r = (ptrdiff_t)n - 1, kk = (ptrdiff_t)k;
    while (l < r) {
        float x = med3(a[l], a[kk], a[r]);
        ptrdiff_t i = l, j = r;
        do {
            while (a[i] < x)
                i++;
            while (x < a[j])
                j--;
            if (i <= j) {
                float t = a[i];
                a[i] = a[j], a[j] = t;
                i++, j--;
            }
        } while (i <= j);
        if (j < kk)
            l = i;
        if (kk < i)
            r = j;
    }
    return a[k];
}

/* ------------------------------------------------------------------ pass 3: emit */

static void indent(struct tw *w, int depth)
{
    static const char spaces[] = "                "; /* depth <= BST_K_MAX + 1 */
    bsti_sink_put(w->out, spaces, (size_t)depth);
}

static void progress(struct tw *w, size_t cells)
{
    w->done += cells;
    if (w->done >= w->next_report) {
        bsti_progress(w->ctx, (double)w->done / (double)w->total, "writing a tensor tree");
        w->next_report += w->total / PROGRESS_STEPS + 1;
    }
}

/* Error bookkeeping for one cell: v its value, back what the file gives. */
static inline void account(struct tw *w, const size_t *c, double v, double back)
{
    double e = v - back;
    w->sum_abs += fabs(v);
    w->sum_err += fabs(e);
    if (fabs(e) > w->st->max_error)
        w->st->max_error = fabs(e);
    w->hemi[w->D == 4 ? c[0] * w->G + c[1] : c[0]] += e;
}

/* Cell number q of the node of level l at corner c. */
static inline void region_cell(const struct tw *w, int l, const size_t *c, size_t q, size_t *cc)
{
    size_t mask = ((size_t)1 << l) - 1;
    for (int i = w->D - 1; i >= 0; i--) {
        cc[i] = c[i] + (q & mask);
        q >>= l;
    }
}

static void leaf_merged(struct tw *w, int l, const size_t *c, int constant, int depth)
{
    size_t n = (size_t)1 << (w->D * l), cc[4];
    double v;
    if (constant) {
        v = clamp0(cell(w, c));
    } else { /* average over the cells that hold data (rank 3: never straddles the dead half) */
        double sum = 0.0;
        size_t live = 0;
        for (size_t q = 0; q < n; q++) {
            region_cell(w, l, c, q, cc);
            if (w->D == 4 || cc[0] < w->half)
                sum += clamp0(cell(w, cc)), live++;
        }
        v = live ? sum / (double)live : 0.0;
    }
    char buf[32];
    float back;
    int len = bsti_format_float(v, w->digits, buf, &back);
    indent(w, depth);
    bsti_sink_put(w->out, "{ ", 2);
    bsti_sink_put(w->out, buf, (size_t)len);
    bsti_sink_put(w->out, " }\n", 3);
    w->st->leaves++;
    w->st->values++;
    if (!constant || cell(w, c) != 0.0) { /* (constant zero regions, the bulk, make no error) */
        for (size_t q = 0; q < n; q++) {
            region_cell(w, l, c, q, cc);
            if (w->D == 4 || cc[0] < w->half)
                account(w, cc, cell(w, cc), back);
        }
    }
    progress(w, n);
}

static void leaf_block(struct tw *w, const size_t *c, int depth)
{
    int D = w->D, nk = 1 << D;
    indent(w, depth);
    bsti_sink_put(w->out, "{", 1);
    for (int j = 0; j < nk; j++) {
        size_t cc[4];
        for (int i = 0; i < D; i++)
            cc[i] = c[i] + (size_t)((j >> (D - 1 - i)) & 1); /* dimension 0 slowest */
        double v = cell(w, cc);
        char buf[32];
        float back;
        int len = bsti_format_float(clamp0(v), w->digits, buf, &back);
        bsti_sink_put(w->out, " ", 1);
        bsti_sink_put(w->out, buf, (size_t)len);
        if (D == 3 ? cc[0] < w->half : 1)
            account(w, cc, v, back);
    }
    bsti_sink_put(w->out, " }\n", 3);
    w->st->leaves++;
    w->st->values += (size_t)nk;
    w->st->blocks_kept++;
    progress(w, (size_t)nk);
}

static void emit(struct tw *w, int l, const size_t *c, int depth, int on_path)
{
    if (bsti_sink_failed(w->out))
        return;
    float m = w->m[node_index(w, l, c)];
    if (m <= w->thresh && !(w->force && on_path)) {
        leaf_merged(w, l, c, m == 0.0f, depth);
        return;
    }
    if (l == 1) {
        leaf_block(w, c, depth);
        return;
    }
    indent(w, depth);
    bsti_sink_put(w->out, "{\n", 2);
    for (int j = 0; j < (1 << w->D); j++) {
        size_t cc[4];
        for (int i = 0; i < w->D; i++)
            cc[i] = c[i] + ((size_t)((j >> i) & 1) << (l - 1)); /* dimension 0 lowest bit */
        emit(w, l - 1, cc, depth + 1, on_path && j == 0);
    }
    indent(w, depth);
    bsti_sink_put(w->out, "}\n", 2);
}

/* ------------------------------------------------------------------ driver */

int bsti_ttree_write(bst_ctx *ctx, const bsti_tensor *t, const bsti_reduce *r, bsti_sink *out,
                     bsti_tree_stats *stats)
{
    bsti_tree_stats dummy;
    bsti_tree_stats *st = stats ? stats : &dummy;
    memset(st, 0, sizeof *st);
    if (!t || !r || !out || (t->rank != 3 && t->rank != 4) || t->k < 1 || t->k > BST_K_MAX ||
        (!t->d && !t->f && !t->get))
        return bsti_error(ctx, BST_EINVAL, "tensor tree: invalid tensor description");
    if (r->pct >= 100.0 || isnan(r->pct) || !(r->floor > 0.0))
        return bsti_error(ctx, BST_EINVAL, "tensor tree: culling percentile %g (must be < 100) or "
                          "floor %g (must be > 0) out of range", r->pct, r->floor);
    struct tw w;
    memset(&w, 0, sizeof w);
    w.ctx = ctx;
    w.t = t;
    w.D = t->rank;
    w.k = t->k;
    w.G = (size_t)1 << t->k;
    w.half = w.G / 2;
    w.digits = r->digits;
    w.floor = r->floor;
    w.out = out;
    w.st = st;
    size_t nodes = 0;
    for (int l = 1; l <= w.k; l++) {
        w.off[l] = nodes;
        size_t S = w.G >> l, c = 1;
        for (int i = 0; i < w.D; i++)
            c *= S;
        nodes += c;
    }
    size_t nblocks = (w.k >= 2 ? w.off[2] : nodes) - w.off[1]; /* the finest 2^D blocks */
    w.nin = w.D == 4 ? w.G * w.G : w.half;
    w.m = bsti_calloc(ctx, nodes, sizeof *w.m);
    w.hemi = bsti_calloc(ctx, w.nin, sizeof *w.hemi);
    if (!w.m || !w.hemi) {
        bsti_free(ctx, w.m), bsti_free(ctx, w.hemi);
        return BST_ENOMEM;
    }
    size_t zero[4] = {0, 0, 0, 0};
    float mroot;
    build(&w, w.k, zero, &mroot);
    int rc = BST_OK;
    if (w.bad)
        rc = bsti_error(ctx, BST_EINVAL, "tensor tree: value %g is not finite in single precision",
                        w.badval);
    /* threshold: the pct-th percentile of the finest blocks' measures (lossless: 0) */
    if (rc == BST_OK && r->pct >= 0.0) {
        float *tmp = bsti_alloc_array(ctx, nblocks, sizeof *tmp);
        size_t nsel = 0;
        if (!tmp) {
            rc = BST_ENOMEM;
        } else if (w.D == 4 && t->fine_in) { /* only the blocks touching fine incident cells */
            size_t S = w.G / 2;
            for (size_t b = 0; b < nblocks; b++) {
                size_t bx = b / (S * S * S), by = (b / (S * S)) % S;
                const unsigned char *f = t->fine_in;
                if (f[2 * bx * w.G + 2 * by] | f[2 * bx * w.G + 2 * by + 1] |
                    f[(2 * bx + 1) * w.G + 2 * by] | f[(2 * bx + 1) * w.G + 2 * by + 1])
                    tmp[nsel++] = w.m[w.off[1] + b];
            }
        } else {
            memcpy(tmp, w.m + w.off[1], nblocks * sizeof *tmp);
            nsel = nblocks;
        }
        size_t rank = (size_t)floor(r->pct / 100.0 * (double)nsel);
        if (tmp && rank > 0)
            w.thresh = select_kth(tmp, nsel, rank - 1);
        bsti_free(ctx, tmp);
    }
    if (rc == BST_OK) {
        st->threshold = w.thresh;
        st->blocks = nblocks;
        w.force = 1;
        for (size_t b = 0; b < nblocks && w.force; b++)
            if (w.m[w.off[1] + b] > w.thresh)
                w.force = 0;
        for (int i = 0; i < w.D; i++)
            w.total = i ? w.total * w.G : w.G;
        uint64_t before = out->total;
        emit(&w, w.k, zero, 0, 1);
        st->bytes = out->total - before;
        if (bsti_sink_failed(out))
            rc = bsti_error(ctx, BST_EIO, "tensor tree: write failed");
        st->l1_error = w.sum_abs > 0.0 ? w.sum_err / w.sum_abs : 0.0;
        double worst = 0.0;
        for (size_t i = 0; i < w.nin; i++)
            worst = fmax(worst, fabs(w.hemi[i]));
        st->hemi_error = worst * M_PI / (double)(w.G * w.G); /* outgoing cell: pi / G^2 sr */
        bsti_progress(ctx, 1.0, "writing a tensor tree");
    }
    bsti_free(ctx, w.m);
    bsti_free(ctx, w.hemi);
    return rc;
}

/* ------------------------------------------------------------------ variable resolution */

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

static inline double mat_at(const bst_mat *m, size_t o, size_t i)
{
    if (!m || m->s == BST_ZERO)
        return 0.0;
    if (m->s == BST_DENSE)
        return bsti_dense_get(m, o, i);
    return bst_mat_get(m, o, i);
}

double bsti_varres_get(const void *opaque, size_t index)
{
    const bsti_varres *v = opaque;
    size_t G = (size_t)1 << v->k, N = G * G, i = index / N, o = index % N;
    if (v->slot[i] >= 0)
        return mat_at(v->fine, o, (size_t)v->slot[i]);
    int s = v->k - v->kc;
    size_t Gc = G >> s;
    size_t ci = ((i / G) >> s) * Gc + ((i % G) >> s), co = ((o / G) >> s) * Gc + ((o % G) >> s);
    return mat_at(v->coarse, co, ci);
}
