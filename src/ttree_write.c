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
 * children's measures and of the same ratio over the children's means.  Without reduction (pct
 * < 0, threshold 0) only m = 0 counts, and every other node gets FLT_MIN.  Dividing by the root of
 * the mean makes Monte Carlo noise (variance proportional to the mean) count about the same
 * everywhere, so the percentile culls noise and keeps structure.
 *
 * Threads (bst_ctx_set_threads): passes 1 and 3 split into the subtrees of one level, the "tasks"
 * (the largest level below the root whose nodes hold at most TASK_CELLS cells).  Build runs the
 * tasks in any order (each writes only its own nodes' measures) and then the levels above them.
 * Emit walks the levels above the tasks on the calling thread; each task's text goes to a buffer
 * of its own (at most WINDOW texts per thread in flight, each at most about 17 bytes a cell) and
 * the caller passes them to the sink in tree order, so the bytes are those of one thread.  The
 * error sums are kept per task and added in tree order, with any number of threads alike. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "mat.h"
#include "ttree_write.h"

/* Progress is reported about this many times per tree. */
#define PROGRESS_STEPS 256
/* A task: a subtree of at most this many cells (rank 4: 16^4, rank 3: 8^5 cells). */
#define TASK_CELLS 65536
/* Block rows stream_blocks asks for ahead of the one it reads (8 rows of cells each). */
#define STREAM_AHEAD 16
/* Task texts in flight per thread. */
#define WINDOW 2
/* The most bytes one leaf line takes: indent, braces, 16 values of <= 15 characters, each after a
 * space, and the terminator bsti_format_float writes. */
#define LEAF_ROOM (BST_K_MAX + 8 + 16 * 16 + 16)

struct tw {                        /* read-only while threads run (but for the marks of the
                                      bound, made by the calling thread: see collect) */
    bst_ctx *ctx;
    const bsti_tensor *t;
    const double *d;               /* t->d, t->f: direct access, else t->get */
    const float *f;
    int D, k;
    size_t G, half;                /* rank 3: cells of dimension 0 that hold data (G/2) */
    size_t stride[4];              /* index step of each dimension in the tensor */
    size_t boff[16], loff[16];     /* index offset of member j of a finest block: dimension i at
                                      bit i of j (build), dimension 0 slowest (leaf text) */
    float *m;                      /* variation measure of every node of levels 1..k */
    size_t off[BST_K_MAX + 2];     /* first node of level l in m (level l: side 2^l cells) */
    double thresh;
    int force;                     /* expand the path of child 0 down to the finest blocks */
    int digits;
    double floor;
    int lossless;                  /* no reduction: only whether m is 0 matters, not its size */
    int split;                     /* level of the tasks (0: none, the tree is one task) */
    double *lmean;                 /* the mean of every node of level split */
    int top;                       /* build: the nodes of level split are done (lmean, m) */
    const double *col_budget, *row_budget; /* the bound (bsti_reduce); col_budget NULL: none */
    double task_share;             /* a task's share of each column (or row): 4^split / G^2 */
    double *vsum;                  /* nodes of levels >= split (index - off[split]): the sum of a
                                      candidate that passed the bound, NaN before it is checked */
};

/* ------------------------------------------------------------------ tensor access */

/* Raw value of cell c (rank 3: 0 in the unused upper half of dimension 0). */
static inline double cell(const struct tw *w, const size_t *c)
{
    size_t idx;
    if (w->D == 3 && c[0] >= w->half)
        return 0.0;
    idx = c[0] * w->stride[0] + c[1] * w->stride[1] + c[2] * w->stride[2];
    if (w->D == 4)
        idx += c[3];
    return w->d ? w->d[idx] : w->f ? (double)w->f[idx] : w->t->get(w->t->opaque, idx);
}

/* The 2^D values of the finest block at corner c, member j at index offset off[j] (w->boff or
 * w->loff; leaf says which, for a rank-3 block in the dead half). */
static inline void block_values(const struct tw *w, const size_t *c, const size_t *off, int leaf,
                                double *v)
{
    int D = w->D, nk = 1 << D;
    if (D == 3 && c[0] + 1 >= w->half) { /* k = 1, or the dead half: cell by cell */
        for (int j = 0; j < nk; j++) {
            size_t cc[4];
            for (int i = 0; i < D; i++)
                cc[i] = c[i] + (size_t)((j >> (leaf ? D - 1 - i : i)) & 1);
            v[j] = cell(w, cc);
        }
        return;
    }
    size_t base = c[0] * w->stride[0] + c[1] * w->stride[1] + c[2] * w->stride[2];
    if (D == 4)
        base += c[3];
    if (w->f) {
        const float *p = w->f + base;
        for (int j = 0; j < nk; j++)
            v[j] = (double)p[off[j]];
    } else if (w->d) {
        const double *p = w->d + base;
        for (int j = 0; j < nk; j++)
            v[j] = p[off[j]];
    } else {
        for (int j = 0; j < nk; j++)
            v[j] = w->t->get(w->t->opaque, base + off[j]);
    }
}

/* Ask for the cells of the level-2 node at corner c (4^D cells in 4^(D-1) runs of 4) ahead of
 * use: the walk visits them in tree order, which no hardware prefetcher follows.  all = 0: only
 * its first cell. */
static inline void prefetch_node2(const struct tw *w, const size_t *c, int all)
{
#if defined(__GNUC__)
    if (!w->d && !w->f)
        return;
    if (w->D == 3 && c[0] + 3 >= w->half)
        return;
    size_t base = c[0] * w->stride[0] + c[1] * w->stride[1] + c[2] * w->stride[2];
    if (w->D == 4)
        base += c[3];
    size_t n1 = all ? 4 : 1, n3 = all && w->D == 4 ? 4 : 1, s1 = w->stride[1];
    size_t s2 = w->D == 4 ? w->stride[2] : 0, sz = w->d ? sizeof(double) : sizeof(float);
    const char *p = w->d ? (const char *)w->d : (const char *)w->f;
    for (size_t x0 = 0; x0 < n1; x0++)
        for (size_t x1 = 0; x1 < n1; x1++)
            for (size_t x2 = 0; x2 < n3; x2++)
                __builtin_prefetch(p + (base + x0 * w->stride[0] + x1 * s1 + x2 * s2) * sz);
#else
    (void)w, (void)c, (void)all;
#endif
}

/* Ask for every cell of the node of level l at corner c, in index order (whole runs of dimension
 * D - 1): a task's region (at most TASK_CELLS cells, 512 KiB of doubles) then sits in the cache
 * while the walk in tree order reads it. */
static void prefetch_region(const struct tw *w, int l, const size_t *c)
{
#if defined(__GNUC__)
    if (!w->d && !w->f)
        return;
    size_t s = (size_t)1 << l, sz = w->d ? sizeof(double) : sizeof(float), line = 64 / sz;
    size_t e1 = w->D == 4 ? s : 1;
    const char *p = w->d ? (const char *)w->d : (const char *)w->f;
    for (size_t x0 = 0; x0 < s; x0++) {
        if (w->D == 3 && c[0] + x0 >= w->half)
            break;
        for (size_t x1 = 0; x1 < s; x1++)
            for (size_t x2 = 0; x2 < e1; x2++) {
                size_t base = (c[0] + x0) * w->stride[0] + (c[1] + x1) * w->stride[1] +
                              (c[2] + x2) * w->stride[2];
                size_t first = w->D == 4 ? base + c[3] : base, run = s;
                for (size_t q = 0; q < run; q += line)
                    __builtin_prefetch(p + (first + q) * sz);
                __builtin_prefetch(p + (first + run - 1) * sz);
            }
    }
#else
    (void)w, (void)l, (void)c;
#endif
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

/* What one thread's share of build found. */
struct bacc {
    size_t negatives;
    int bad;                       /* a value that is not finite in single precision */
    double badval;
    size_t badnode;                /* the finest block holding it (the least such is reported) */
};

/* Measure (*m_out) and mean of the finest block at corner c from its 2^D values (w->boff order,
 * changed in place: negatives and bad values read 0). */
static double block_measure(const struct tw *w, struct bacc *b, const size_t *c, double *vals,
                            float *m_out)
{
    int nk = 1 << w->D;
    double lo = INFINITY, hi = -INFINITY, sum = 0.0, mean;
    float m;
    for (int j = 0; j < nk; j++) {
        double v = vals[j];
        if (!isfinite(v) || v > FLT_MAX) {
            size_t q = node_index(w, 1, c);
            if (!b->bad || q < b->badnode)
                b->badval = v, b->badnode = q;
            b->bad = 1;
            v = 0.0;
        }
        if (v < 0.0) {
            b->negatives++;
            v = 0.0;
        }
        vals[j] = v;
        lo = v < lo ? v : lo, hi = v > hi ? v : hi, sum += v; /* (no NaN left) */
    }
    if (lo == hi) {
        mean = lo;
        m = 0.0f;
    } else if (w->lossless) {
        mean = sum / nk;
        m = FLT_MIN;
    } else {
        mean = sum / nk;
        double ss = 0.0;
        for (int j = 0; j < nk; j++)
            ss += (vals[j] - mean) * (vals[j] - mean);
        m = measure(sqrt(ss / nk), mean, w->floor);
    }
    w->m[node_index(w, 1, c)] = m;
    *m_out = m;
    return mean;
}

/* A task's finest blocks measured ahead of the walk (stream_blocks): their means, the block at
 * offset (q_0, .., q_{D-1}) (in blocks from corner c) at index sum q_i side^(D-1-i). */
struct pre1 {
    size_t c[4], side;
    double *mean;
};

/* Ask for block row u of a rank-4 task (stream_blocks): its 8 rows of 2h cells. */
static inline void prefetch_row3(const struct tw *w, const struct pre1 *pre, size_t u)
{
#if defined(__GNUC__)
    size_t h = pre->side, n[3] = {u / (h * h), (u / h) % h, u % h};
    size_t sz = w->d ? sizeof(double) : sizeof(float);
    const char *p = w->d ? (const char *)w->d : (const char *)w->f;
    for (int r = 0; r < 8; r++) {
        size_t first = pre->c[3];
        for (int i = 0; i < 3; i++)
            first += (pre->c[i] + 2 * n[i] + (size_t)((r >> i) & 1)) * w->stride[i];
        for (size_t x = 0; x < 2 * h * sz; x += 64)
            __builtin_prefetch(p + first * sz + x);
    }
#else
    (void)w, (void)pre, (void)u;
#endif
}

/* The finest blocks of a rank-4 task at pre->c in index order (dimension 3 fastest), measured
 * into w->m and pre->mean: the 8 rows of cells of one (x0, x1, x2) block row are read along
 * dimension 3 while the rows STREAM_AHEAD block rows on are asked for, so the reads follow the
 * memory instead of the tree (whose order left the walk waiting on each block: most of build's
 * time). */
static void stream_blocks(const struct tw *w, struct bacc *b, const struct pre1 *pre)
{
    size_t h = pre->side, nt = h * h * h, q = 0;
    for (size_t t = 0; t < STREAM_AHEAD && t < nt; t++)
        prefetch_row3(w, pre, t);
    for (size_t t = 0; t < nt; t++) {
        size_t a[3] = {t / (h * h), (t / h) % h, t % h}, row[8];
        for (int r = 0; r < 8; r++) {
            row[r] = pre->c[3];
            for (int i = 0; i < 3; i++)
                row[r] += (pre->c[i] + 2 * a[i] + (size_t)((r >> i) & 1)) * w->stride[i];
        }
        if (t + STREAM_AHEAD < nt)
            prefetch_row3(w, pre, t + STREAM_AHEAD);
        for (size_t a3 = 0; a3 < h; a3++, q++) {
            double vals[16]; /* w->boff order: bit i of j is dimension i */
            size_t c[4] = {pre->c[0] + 2 * a[0], pre->c[1] + 2 * a[1], pre->c[2] + 2 * a[2],
                           pre->c[3] + 2 * a3};
            if (w->f)
                for (int j = 0; j < 16; j++)
                    vals[j] = (double)w->f[row[j & 7] + 2 * a3 + (size_t)(j >> 3)];
            else
                for (int j = 0; j < 16; j++)
                    vals[j] = w->d[row[j & 7] + 2 * a3 + (size_t)(j >> 3)];
            float mm;
            pre->mean[q] = block_measure(w, b, c, vals, &mm);
        }
    }
}

/* Measure of the node of level l at corner c (in cells); returns its mean (exact when constant). */
static double build(const struct tw *w, struct bacc *b, const struct pre1 *pre, int l, const size_t *c,
                    float *m_out)
{
    int D = w->D, nk = 1 << D;
    double vals[16], mean = 0.0;
    float m;
    if (D == 4 && w->t->diagonal && (c[0] != c[2] || c[1] != c[3])) {
        /* an aligned block off the diagonal: zero, its measures left at 0 (calloc) */
        *m_out = 0.0f;
        return 0.0;
    }
    if (w->top && l == w->split) { /* done by a task */
        size_t q = node_index(w, l, c);
        *m_out = w->m[q];
        return w->lmean[q - w->off[l]];
    }
    if (l == 1 && pre) { /* measured by stream_blocks */
        size_t h = pre->side, q = 0;
        for (int i = 0; i < D; i++)
            q = q * h + ((c[i] - pre->c[i]) >> 1);
        *m_out = w->m[node_index(w, 1, c)];
        return pre->mean[q];
    }
    if (l == 1) {
        block_values(w, c, w->boff, 0, vals);
        return block_measure(w, b, c, vals, m_out);
    } else {
        float ms[16], mmax = 0.0f;
        int constant = 1;
        size_t cn[4] = {0, 0, 0, 0};
        for (int j = 0; j < nk; j++) {
            size_t cc[4] = {0, 0, 0, 0};
            for (int i = 0; i < D; i++)
                cc[i] = c[i] + ((size_t)((j >> i) & 1) << (l - 1));
            if (l == 3) { /* the level-2 children: this one's cells at first, then the next's */
                if (j == 0)
                    prefetch_node2(w, cc, 1);
                if (j + 1 < nk) {
                    for (int i = 0; i < D; i++)
                        cn[i] = c[i] + ((size_t)(((j + 1) >> i) & 1) << (l - 1));
                    prefetch_node2(w, cn, 1);
                }
            }
            vals[j] = build(w, b, pre, l - 1, cc, &ms[j]);
            mmax = ms[j] > mmax ? ms[j] : mmax;
            constant &= ms[j] == 0.0f && vals[j] == vals[0];
            mean += vals[j];
        }
        if (constant) {
            mean = vals[0];
            m = 0.0f;
        } else if (w->lossless) {
            mean /= nk;
            m = FLT_MIN;
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

/* Corner of node q (row major, as node_index) of level l. */
static void node_corner(const struct tw *w, int l, size_t q, size_t *c)
{
    size_t S = w->G >> l;
    for (int i = w->D - 1; i >= 0; i--) {
        c[i] = (q % S) << l;
        q /= S;
    }
}

struct build_job {
    const struct tw *w;
    atomic_size_t next;
    size_t n;                      /* nodes of level split */
};

struct build_worker {
    struct build_job *job;
    struct bacc b;
    pthread_t thread;
    int started;
};

static void *build_tasks(void *arg)
{
    struct build_worker *bw = arg;
    struct build_job *job = bw->job;
    const struct tw *w = job->w;
    double mean[TASK_CELLS / 16];
    int streamed = w->D == 4 && (w->d || w->f); /* (then never diagonal: that is t->get) */
    for (size_t q; (q = atomic_fetch_add(&job->next, 1)) < job->n;) {
        size_t c[4] = {0, 0, 0, 0};
        float mm;
        node_corner(w, w->split, q, c);
        struct pre1 pre = {{c[0], c[1], c[2], c[3]}, (size_t)1 << (w->split - 1), mean};
        if (streamed)
            stream_blocks(w, &bw->b, &pre);
        else if (!(w->D == 4 && w->t->diagonal && (c[0] != c[2] || c[1] != c[3])))
            prefetch_region(w, w->split, c);
        w->lmean[q] = build(w, &bw->b, streamed ? &pre : NULL, w->split, c, &mm);
    }
    return NULL;
}

/* Pass 1 on nthreads threads; *b gets what they found. */
static void build_all(struct tw *w, int nthreads, struct bacc *b)
{
    size_t zero[4] = {0, 0, 0, 0};
    float mroot;
    memset(b, 0, sizeof *b);
    if (w->split) {
        struct build_worker bw[BST_THREADS_MAX];
        struct build_job job;
        job.w = w;
        job.n = w->off[w->split + 1] - w->off[w->split];
        atomic_init(&job.next, 0);
        w->top = 0;
        for (int t = 0; t < nthreads; t++) {
            memset(&bw[t].b, 0, sizeof bw[t].b);
            bw[t].job = &job;
            bw[t].started = t > 0 && pthread_create(&bw[t].thread, NULL, build_tasks, &bw[t]) == 0;
        }
        build_tasks(&bw[0]); /* a thread that could not start leaves its share to the others */
        for (int t = 0; t < nthreads; t++) {
            if (bw[t].started)
                pthread_join(bw[t].thread, NULL);
            b->negatives += bw[t].b.negatives;
            if (bw[t].b.bad && (!b->bad || bw[t].b.badnode < b->badnode))
                b->bad = 1, b->badval = bw[t].b.badval, b->badnode = bw[t].b.badnode;
        }
        w->top = 1;
    }
    build(w, b, NULL, w->k, zero, &mroot);
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

/* A growing text buffer (the context's allocator, no error recorded: threads share the ctx). */
struct tbuf {
    const bst_ctx *ctx;
    char *p;
    size_t n, cap;
    int fail;                      /* an allocation failed: the text is incomplete */
};

/* Room for need more bytes at p + n, or NULL (fail set). */
static char *tb_room(struct tbuf *b, size_t need)
{
    if (b->fail)
        return NULL;
    if (b->cap - b->n < need) {
        size_t cap = b->cap ? 2 * b->cap : 65536;
        while (cap - b->n < need)
            cap *= 2;
        char *p = b->ctx->malloc_fn(cap, b->ctx->alloc_opaque);
        if (!p) {
            b->fail = 1;
            return NULL;
        }
        if (b->n)
            memcpy(p, b->p, b->n);
        if (b->p)
            b->ctx->free_fn(b->p, b->ctx->alloc_opaque);
        b->p = p;
        b->cap = cap;
    }
    return b->p + b->n;
}

static void tb_free(struct tbuf *b)
{
    if (b->p)
        b->ctx->free_fn(b->p, b->ctx->alloc_opaque);
    b->p = NULL;
    b->n = b->cap = 0;
}

/* The texts of recent values: a value's text is a function of its float alone (value_text), and
 * measured data repeat values (RADIANCE's blind at k = 6: a third of 5.3 million non-zero values
 * found in a table of this size). */
#define MEMO_BITS 12
struct memo {
    uint32_t key[1 << MEMO_BITS];  /* the float's bits; 0 (+0, never stored) = empty */
    unsigned char len[1 << MEMO_BITS];
    float back[1 << MEMO_BITS];    /* what a reader stores of the text */
    char text[1 << MEMO_BITS][16];
};

/* The emitting side of one task (or of the levels above them): its text and its error sums. */
struct eacc {
    struct tbuf *out;
    struct memo *memo;             /* NULL: every value formatted */
    size_t values, leaves, blocks_kept, cells;
    double sum_abs, sum_err, max_error;
    double *hemi;                  /* per incident cell of the region: sum of the errors */
    double *ws;                    /* the bound's sums over a candidate (sums_room doubles) */
    double *erow;                  /* the bound's rows: change of each outgoing cell's
                                      directional-hemispherical sum so far (task side ^ 2) */
    size_t o0, o1;                 /* the region's first outgoing cell */
    size_t h0, h1, hside;          /* the region's first incident cell and side (rank 3: h0) */
};

static inline double *hemi_at(const struct tw *w, struct eacc *a, size_t i0, size_t i1)
{
    return w->D == 4 ? &a->hemi[(i0 - a->h0) * a->hside + (i1 - a->h1)] : &a->hemi[i0 - a->h0];
}

/* The text of v >= 0 at p (16 bytes of room): the shortest that reads back as its float, or with a
 * digits setting that float's w->digits significant digits; *back what a reader stores. */
static inline int value_text(const struct tw *w, double v, char *p, float *back)
{
    return bsti_format_float(w->digits ? (double)(float)v : v, w->digits, p, back);
}

/* value_text through the memo (mm may be NULL). */
static inline int put_value(const struct tw *w, struct memo *mm, double v, char *p, float *back)
{
    float f = (float)v;
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    if (!mm || bits == 0 || !isfinite(f))
        return value_text(w, v, p, back);
    size_t h = (size_t)((bits * UINT32_C(2654435761)) >> (32 - MEMO_BITS));
    if (mm->key[h] == bits) {
        *back = mm->back[h];
        memcpy(p, mm->text[h], 16);
        return mm->len[h];
    }
    int n = value_text(w, v, p, back);
    if (n < 16) {
        mm->key[h] = bits;
        mm->len[h] = (unsigned char)n;
        mm->back[h] = *back;
        memcpy(mm->text[h], p, 16);
    }
    return n;
}

/* Indent and a short piece of text (a branch's brace line). */
static void put_line(struct eacc *a, int depth, const char *text, size_t len)
{
    char *p = tb_room(a->out, (size_t)depth + len);
    if (!p)
        return;
    memset(p, ' ', (size_t)depth);
    memcpy(p + depth, text, len);
    a->out->n += (size_t)depth + len;
}

/* Error bookkeeping for one cell of incident cell (i0, i1): v its value, back what the file gives. */
static inline void account(const struct tw *w, struct eacc *a, size_t i0, size_t i1, double v,
                           double back)
{
    double e = v - back;
    a->sum_abs += fabs(v);
    a->sum_err += fabs(e);
    if (fabs(e) > a->max_error)
        a->max_error = fabs(e);
    *hemi_at(w, a, i0, i1) += e;
}

/* The cells of the node of level l at corner c in index order (dimension D - 1 fastest), those
 * that hold data: their sum (account = 0) or their error against back (account = 1).  With direct
 * access, row by row of the last dimension (s contiguous cells) into the incident cell's error
 * sum found once a row: the same additions in the same order as cell by cell. */
static double region_pass(const struct tw *w, struct eacc *a, int l, const size_t *c, int acct,
                          double back, size_t *live)
{
    size_t s = (size_t)1 << l, n = 0;
    double sum = 0.0;
    size_t e1 = w->D == 4 ? s : 1;
    for (size_t x0 = 0; x0 < s; x0++) {
        size_t i0 = c[0] + x0;
        if (w->D == 3 && i0 >= w->half)
            break;
        for (size_t x1 = 0; x1 < s; x1++) {
            if (w->d || w->f) {
                double *hp = acct ? hemi_at(w, a, i0, c[1] + x1) : NULL;
                for (size_t x2 = 0; x2 < e1; x2++) { /* rows: dimension 2 (rank 4) */
                    size_t base = i0 * w->stride[0] + (c[1] + x1) * w->stride[1] +
                                  (w->D == 4 ? (c[2] + x2) * w->stride[2] + c[3] : c[2]);
                    const double *pd = w->d ? w->d + base : NULL;
                    const float *pf = w->f ? w->f + base : NULL;
                    if (acct) {
                        for (size_t x = 0; x < s; x++) {
                            double v = pd ? pd[x] : (double)pf[x], e = v - back;
                            a->sum_abs += fabs(v);
                            a->sum_err += fabs(e);
                            if (fabs(e) > a->max_error)
                                a->max_error = fabs(e);
                            *hp += e;
                        }
                    } else {
                        for (size_t x = 0; x < s; x++)
                            sum += clamp0(pd ? pd[x] : (double)pf[x]);
                    }
                    n += s;
                }
                continue;
            }
            for (size_t x2 = 0; x2 < s; x2++)
                for (size_t x3 = 0; x3 < e1; x3++) {
                    size_t cc[4] = {i0, c[1] + x1, c[2] + x2, c[3] + x3};
                    double v = cell(w, cc);
                    if (acct)
                        account(w, a, i0, cc[1], v, back);
                    else
                        sum += clamp0(v);
                    n++;
                }
        }
    }
    if (live)
        *live = n;
    return sum;
}

/* ------------------------------------------------------------------ the bound */

/* Cells of the node of level l at corner c that hold data (rank 3: not in the dead half). */
static size_t live_cells(const struct tw *w, int l, const size_t *c)
{
    size_t s = (size_t)1 << l, in = s * s;
    if (w->D == 3)
        in = c[0] >= w->half ? 0 : w->half - c[0] < s ? w->half - c[0] : s;
    return in * s * s;
}

/* Doubles of the bound's sums over a node of level l: one a column (incident index), and one a
 * row (outgoing cell) when rows are bounded (rank 4 only). */
static size_t sums_room(const struct tw *w, int l)
{
    size_t s = (size_t)1 << l;
    return w->D == 4 ? 2 * s * s : s;
}

/* The sums of the node of level l at corner c over its cells that hold data, negatives read as 0:
 * cs[x] over the outgoing cells of its incident index x (rank 4: x = x0 s + x1, rank 3: x = x0),
 * and with rs, rs[y] over its incident indices for its outgoing cell y (x2 s + x3).  Returns the
 * sum of them all; *nin the incident indices that hold data. */
static double bound_sums(const struct tw *w, int l, const size_t *c, double *cs, double *rs,
                         size_t *nin)
{
    size_t s = (size_t)1 << l, ni = w->D == 4 ? s * s : s, od = (size_t)w->D - 2, x;
    double total = 0.0;
    if (rs)
        memset(rs, 0, s * s * sizeof *rs);
    for (x = 0; x < ni; x++) {
        size_t i0 = c[0] + (w->D == 4 ? x / s : x);
        if (w->D == 3 && i0 >= w->half)
            break;
        size_t ibase = i0 * w->stride[0] + (w->D == 4 ? (c[1] + x % s) * w->stride[1] : 0);
        double col = 0.0;
        for (size_t a = 0; a < s; a++) { /* the outgoing cells, runs of the last dimension */
            size_t base = ibase + (c[od] + a) * w->stride[od] + c[od + 1];
            double *r = rs ? rs + a * s : NULL;
            for (size_t b = 0; b < s; b++) {
                double v = clamp0(w->d ? w->d[base + b] : w->f ? (double)w->f[base + b]
                                                                : w->t->get(w->t->opaque, base + b));
                col += v;
                if (r)
                    r[b] += v;
            }
        }
        cs[x] = col;
        total += col;
    }
    *nin = x;
    return total;
}

/* Does the one value of the node of level l at corner c keep every sum the bound watches within
 * its budget (bsti_reduce)?  Inside a task (a: its sums; a->hemi the errors so far of its incident
 * indices, a->erow the changes so far of its rows) the changes add to those of the task; above the
 * tasks (a NULL) the node's own changes are held to its share.  ws: sums_room(l) doubles; *sum:
 * the sum of the node's cells.  A node that passes in a task has its rows' changes added to
 * a->erow (its columns' reach a->hemi as leaf_merged writes it). */
static int within_bound(const struct tw *w, struct eacc *a, double *ws, int l, const size_t *c,
                        double *sum)
{
    size_t s = (size_t)1 << l, per = s * s, nin, G2 = w->G * w->G, ts = a ? a->hside : 0;
    double *cs = ws, *rs = w->row_budget ? ws + per : NULL;
    double total = bound_sums(w, l, c, cs, rs, &nin);
    *sum = total;
    if (!nin)
        return 1;
    char text[40];
    float back;
    value_text(w, total / (double)(nin * per), text, &back); /* as leaf_merged writes it */
    double v = back, lam = M_PI / (double)G2;
    double col_share = a ? w->task_share : (double)per / (double)G2;
    double row_share = a ? w->task_share : (double)nin / (double)G2;
    for (size_t x = 0; x < nin; x++) { /* per outgoing cells of an incident index */
        size_t i0 = c[0] + (w->D == 4 ? x / s : x), i1 = w->D == 4 ? c[1] + x % s : 0;
        double change = lam * ((double)per * v - cs[x]); /* new - old */
        if (a)
            change -= lam * *hemi_at(w, a, i0, i1); /* (hemi sums old - new) */
        if (!(fabs(change) <= w->col_budget[w->D == 4 ? i0 * w->G + i1 : i0] * col_share))
            return 0;
    }
    for (size_t y = 0; rs && y < per; y++) { /* (rank 4: nin incident cells, every one live) */
        size_t o0 = c[2] + y / s, o1 = c[3] + y % s;
        double change = lam * ((double)nin * v - rs[y]);
        if (a)
            change += a->erow[(o0 - a->o0) * ts + o1 - a->o1];
        if (!(fabs(change) <= w->row_budget[o0 * w->G + o1] * row_share))
            return 0;
    }
    for (size_t y = 0; a && rs && y < per; y++)
        a->erow[(c[2] + y / s - a->o0) * ts + c[3] + y % s - a->o1] += lam * ((double)nin * v - rs[y]);
    return 1;
}

/* A node whose measure is at most the threshold, off the forced path. */
static inline int candidate(const struct tw *w, float m, int on_path)
{
    return m >= 0.0f && m <= w->thresh && !(w->force && on_path);
}

/* Is the node of level l at corner c written as one value?  A candidate is, unless the bound
 * forbids it.  Nodes of levels >= split (when there are tasks) are checked once, by the calling
 * thread in collect, before any worker starts: a failed one's measure is negated, a passed one's
 * sum kept in vsum.  The others are checked by the one thread that emits their task (a).  *sum:
 * the node's sum when the check found it, else NaN. */
static int merged(const struct tw *w, struct eacc *a, int l, const size_t *c, int on_path, double *sum)
{
    size_t q = node_index(w, l, c);
    float m = w->m[q];
    *sum = NAN;
    if (!candidate(w, m, on_path))
        return 0;
    if (!w->col_budget || m == 0.0f) /* (a constant region changes no sum) */
        return 1;
    double *kept = w->split && l >= w->split ? &w->vsum[q - w->off[w->split]] : NULL;
    if (kept && !isnan(*kept)) {
        *sum = *kept;
        return 1;
    }
    if (within_bound(w, kept ? NULL : a, a->ws, l, c, sum)) {
        if (kept)
            *kept = *sum;
        return 1;
    }
    if (kept)
        w->m[q] = -m;
    return 0;
}

/* The one-value leaf of the node of level l at corner c; sum: the sum of its cells, or NaN. */
static void leaf_merged(const struct tw *w, struct eacc *a, int l, const size_t *c, int constant,
                        int depth, double sum)
{
    size_t n = (size_t)1 << (w->D * l), live = 0;
    double v, first = cell(w, c);
    if (constant) {
        v = clamp0(first);
    } else { /* average over the cells that hold data (rank 3: never straddles the dead half) */
        if (isnan(sum))
            sum = region_pass(w, a, l, c, 0, 0.0, &live);
        else
            live = live_cells(w, l, c);
        v = live ? sum / (double)live : 0.0;
    }
    char *p = tb_room(a->out, (size_t)depth + 24);
    if (!p)
        return;
    float back;
    memset(p, ' ', (size_t)depth);
    p += depth;
    *p++ = '{', *p++ = ' ';
    p += put_value(w, a->memo, v, p, &back);
    *p++ = ' ', *p++ = '}', *p++ = '\n';
    a->out->n = (size_t)(p - a->out->p);
    a->leaves++;
    a->values++;
    a->cells += n;
    if (constant && first > 0.0) {
        /* every cell is first (a negative one would read as 0): the same error everywhere */
        size_t s = (size_t)1 << l, ni = 0, per = s * s; /* incident cells, cells of each */
        double e = first - back;
        if (w->D == 4) {
            ni = s * s;
        } else {
            for (size_t x = 0; x < s && c[0] + x < w->half; x++)
                ni++;
        }
        a->sum_abs += first * (double)(ni * per);
        a->sum_err += fabs(e) * (double)(ni * per);
        if (fabs(e) > a->max_error && ni)
            a->max_error = fabs(e);
        if (e != 0.0) {
            for (size_t x = 0; x < (w->D == 4 ? s : ni); x++)
                for (size_t y = 0; y < (w->D == 4 ? s : 1); y++)
                    *hemi_at(w, a, c[0] + x, c[1] + y) += e * (double)per;
        }
    } else if (!constant || first != 0.0) { /* (constant zero regions, the bulk, make no error) */
        region_pass(w, a, l, c, 1, back, NULL);
    }
}

static void leaf_block(const struct tw *w, struct eacc *a, const size_t *c, int depth)
{
    int D = w->D, nk = 1 << D;
    double vals[16];
    block_values(w, c, w->loff, 1, vals);
    char *p = tb_room(a->out, LEAF_ROOM);
    if (!p)
        return;
    memset(p, ' ', (size_t)depth);
    p += depth;
    *p++ = '{';
    for (int j = 0; j < nk; j++) {
        float back;
        double v = vals[j];
        *p++ = ' ';
        p += put_value(w, a->memo, clamp0(v), p, &back);
        /* dimension 0 slowest: j's top bits are the incident cell */
        size_t i0 = c[0] + (size_t)(j >> (D - 1)), i1 = c[1] + (size_t)((j >> 2) & 1);
        if (v == (double)back) /* read back exactly (a float source): an error of +0 adds nothing */
            a->sum_abs += D == 4 || i0 < w->half ? v : 0.0;
        else if (D == 4 || i0 < w->half)
            account(w, a, i0, i1, v, back);
        if (a->erow && v != (double)back) /* the bound's rows (rank 4): the rounding's change */
            a->erow[(c[2] + (size_t)((j >> 1) & 1) - a->o0) * a->hside + c[3] + (size_t)(j & 1) - a->o1] +=
                M_PI / (double)(w->G * w->G) * ((double)back - clamp0(v));
    }
    *p++ = ' ', *p++ = '}', *p++ = '\n';
    a->out->n = (size_t)(p - a->out->p);
    a->leaves++;
    a->values += (size_t)nk;
    a->blocks_kept++;
    a->cells += (size_t)nk;
}

struct run;
static void consume(struct run *r, int depth);

/* The text of the node of level l at corner c; with r (the levels above the tasks), a node of
 * level split is the next task's text. */
static void emit(const struct tw *w, struct eacc *a, struct run *r, int l, const size_t *c,
                 int depth, int on_path)
{
    if (a->out->fail)
        return;
    double sum;
    if (merged(w, a, l, c, on_path, &sum)) {
        leaf_merged(w, a, l, c, w->m[node_index(w, l, c)] == 0.0f, depth, sum);
        return;
    }
    if (r && l == w->split) {
        consume(r, depth);
        return;
    }
    if (l == 1) {
        leaf_block(w, a, c, depth);
        return;
    }
    put_line(a, depth, "{\n", 2);
#if defined(__GNUC__)
    /* the children's measures, read first thing by each: scattered over the level's row-major
     * array (children j and j + 8 share a line: dimension 3 is the array's fastest), so asked for
     * together */
    for (int j = 0; j < (1 << w->D); j++) {
        size_t cc[4] = {0, 0, 0, 0};
        for (int i = 0; i < w->D; i++)
            cc[i] = c[i] + ((size_t)((j >> i) & 1) << (l - 1));
        __builtin_prefetch(&w->m[node_index(w, l - 1, cc)]);
    }
#endif
    for (int j = 0; j < (1 << w->D); j++) {
        size_t cc[4] = {0, 0, 0, 0};
        for (int i = 0; i < w->D; i++)
            cc[i] = c[i] + ((size_t)((j >> i) & 1) << (l - 1)); /* dimension 0 lowest bit */
        if (l == 3) { /* level-2 children, this one and the next: all their cells unless one
                         constant leaf */
            size_t cn[4] = {0, 0, 0, 0};
            if (j == 0)
                prefetch_node2(w, cc, w->m[node_index(w, 2, cc)] != 0.0f);
            if (j + 1 < (1 << w->D)) {
                for (int i = 0; i < w->D; i++)
                    cn[i] = c[i] + ((size_t)(((j + 1) >> i) & 1) << (l - 1));
                prefetch_node2(w, cn, w->m[node_index(w, 2, cn)] != 0.0f);
            }
        }
        emit(w, a, r, l - 1, cc, depth + 1, on_path && j == 0);
    }
    put_line(a, depth, "}\n", 2);
}

/* ------------------------------------------------------------------ pass 3 on threads */

struct task {
    size_t c[4];
    int depth, on_path;
};

struct slot {
    struct tbuf text;
    struct eacc acc;
    int done;
};

struct run {
    const struct tw *w;
    struct task *task;
    size_t ntasks, next, consumed, window;
    struct slot *slot;
    int stop;
    pthread_mutex_t lock;
    pthread_cond_t cond;
    struct eacc *top;              /* the levels above the tasks, the whole tree's sums */
    bsti_sink *out;
    size_t done, total, next_report;
    int nomem;
};

/* The nodes of level split the emitter reaches, in tree order. */
static void collect(const struct tw *w, struct run *r, int l, const size_t *c, int depth, int on_path)
{
    double sum;
    if (merged(w, r->top, l, c, on_path, &sum))
        return;
    if (l == w->split) {
        if (r->task) {
            struct task *t = &r->task[r->ntasks];
            memcpy(t->c, c, sizeof t->c);
            t->depth = depth, t->on_path = on_path;
        }
        r->ntasks++;
        return;
    }
    for (int j = 0; j < (1 << w->D); j++) {
        size_t cc[4] = {0, 0, 0, 0};
        for (int i = 0; i < w->D; i++)
            cc[i] = c[i] + ((size_t)((j >> i) & 1) << (l - 1));
        collect(w, r, l - 1, cc, depth + 1, on_path && j == 0);
    }
}

static void run_task(struct run *r, size_t t)
{
    const struct tw *w = r->w;
    struct slot *s = &r->slot[t % r->window];
    const struct task *tk = &r->task[t];
    double *hemi = s->acc.hemi, *ws = s->acc.ws, *erow = s->acc.erow;
    size_t hside = s->acc.hside;
    struct memo *mm = s->acc.memo;
    memset(&s->acc, 0, sizeof s->acc);
    s->acc.out = &s->text;
    s->acc.memo = mm;
    s->acc.ws = ws;
    s->acc.erow = erow;
    s->acc.hemi = hemi;
    s->acc.hside = hside;
    s->acc.h0 = tk->c[0], s->acc.h1 = tk->c[1];
    s->acc.o0 = tk->c[w->D - 2], s->acc.o1 = tk->c[w->D - 1];
    memset(hemi, 0, (w->D == 4 ? hside * hside : hside) * sizeof *hemi);
    if (erow)
        memset(erow, 0, hside * hside * sizeof *erow);
    s->text.n = 0;
    prefetch_region(w, w->split, tk->c);
    emit(w, &s->acc, NULL, w->split, tk->c, tk->depth, tk->on_path);
}

static void *emit_worker(void *arg)
{
    struct run *r = arg;
    pthread_mutex_lock(&r->lock);
    for (;;) {
        while (!r->stop && r->next < r->ntasks && r->next >= r->consumed + r->window)
            pthread_cond_wait(&r->cond, &r->lock);
        if (r->stop || r->next >= r->ntasks)
            break;
        size_t t = r->next++;
        pthread_mutex_unlock(&r->lock);
        run_task(r, t);
        pthread_mutex_lock(&r->lock);
        r->slot[t % r->window].done = 1;
        pthread_cond_broadcast(&r->cond);
    }
    pthread_mutex_unlock(&r->lock);
    return NULL;
}

static void progress(struct run *r, size_t cells)
{
    r->done += cells;
    if (r->done >= r->next_report) {
        bsti_progress(r->w->ctx, (double)r->done / (double)r->total, "writing a tensor tree");
        r->next_report += r->total / PROGRESS_STEPS + 1;
    }
}

/* The next task's text (made here when no thread has it) to the sink, its sums to the tree's. */
static void consume(struct run *r, int depth)
{
    const struct tw *w = r->w;
    size_t t = r->consumed;
    struct slot *s = &r->slot[t % r->window];
    (void)depth; /* the task's own (collect gave it) */
    pthread_mutex_lock(&r->lock);
    while (!s->done) {
        if (r->next < r->ntasks && r->next < r->consumed + r->window) {
            size_t u = r->next++;
            pthread_mutex_unlock(&r->lock);
            run_task(r, u);
            pthread_mutex_lock(&r->lock);
            r->slot[u % r->window].done = 1;
            pthread_cond_broadcast(&r->cond);
        } else {
            pthread_cond_wait(&r->cond, &r->lock);
        }
    }
    pthread_mutex_unlock(&r->lock);
    struct eacc *a = r->top, *b = &s->acc;
    if (s->text.fail) {
        r->nomem = 1;
        a->out->fail = 1; /* stops the walk above */
    } else {
        bsti_sink_put(r->out, a->out->p, a->out->n); /* the levels above, so far */
        a->out->n = 0;
        bsti_sink_put(r->out, s->text.p, s->text.n);
        if (bsti_sink_failed(r->out))
            a->out->fail = 1;
    }
    a->values += b->values, a->leaves += b->leaves, a->blocks_kept += b->blocks_kept;
    a->sum_abs += b->sum_abs, a->sum_err += b->sum_err;
    a->max_error = fmax(a->max_error, b->max_error);
    for (size_t x = 0; x < b->hside && (w->D == 4 || b->h0 + x < w->half); x++)
        for (size_t y = 0; y < (w->D == 4 ? b->hside : 1); y++)
            *hemi_at(w, a, b->h0 + x, b->h1 + y) += b->hemi[x * (w->D == 4 ? b->hside : 1) + y];
    progress(r, b->cells);
    pthread_mutex_lock(&r->lock);
    s->done = 0;
    r->consumed++;
    pthread_cond_broadcast(&r->cond);
    pthread_mutex_unlock(&r->lock);
}

/* Pass 3 on nthreads threads into out; top->hemi covers the whole tree.  BST_ENOMEM or BST_OK
 * (a failed sink is seen by the caller). */
static int emit_all(const struct tw *w, int nthreads, struct eacc *top, bsti_sink *out)
{
    size_t zero[4] = {0, 0, 0, 0};
    struct run r;
    memset(&r, 0, sizeof r);
    r.w = w;
    r.top = top;
    r.out = out;
    for (int i = 0; i < w->D; i++)
        r.total = i ? r.total * w->G : w->G;
    if (!w->split) { /* a tree of one level: no tasks (and few values: no memo) */
        emit(w, top, NULL, w->k, zero, 0, 1);
        if (top->out->fail)
            return BST_ENOMEM;
        bsti_sink_put(out, top->out->p, top->out->n);
        return BST_OK;
    }
    collect(w, &r, w->k, zero, 0, 1);
    size_t ntasks = r.ntasks;
    r.window = (size_t)nthreads * WINDOW;
    if (r.window > ntasks)
        r.window = ntasks ? ntasks : 1;
    size_t hs = (size_t)1 << w->split, nh = w->D == 4 ? hs * hs : hs;
    r.task = bsti_alloc_array(w->ctx, ntasks + 1, sizeof *r.task);
    r.slot = bsti_calloc(w->ctx, r.window, sizeof *r.slot);
    double *hemi = bsti_alloc_array(w->ctx, r.window * nh, sizeof *hemi);
    struct memo *memo = bsti_calloc(w->ctx, r.window + 1, sizeof *memo);
    size_t room = w->col_budget ? sums_room(w, w->split) : 0, nr = w->row_budget ? hs * hs : 0;
    double *ws = room ? bsti_alloc_array(w->ctx, r.window * (room + nr), sizeof *ws) : NULL;
    int rc = r.task && r.slot && hemi && memo && (!room || ws) ? BST_OK : BST_ENOMEM;
    if (rc == BST_OK) {
        r.ntasks = 0;
        collect(w, &r, w->k, zero, 0, 1);
        for (size_t i = 0; i < r.window; i++) {
            r.slot[i].text.ctx = w->ctx;
            r.slot[i].acc.hemi = hemi + i * nh;
            r.slot[i].acc.hside = hs;
            r.slot[i].acc.memo = memo ? memo + i : NULL;
            r.slot[i].acc.ws = ws ? ws + i * (room + nr) : NULL;
            r.slot[i].acc.erow = nr ? ws + i * (room + nr) + room : NULL;
        }
        top->memo = memo ? memo + r.window : NULL;
        pthread_mutex_init(&r.lock, NULL);
        pthread_cond_init(&r.cond, NULL);
        pthread_t th[BST_THREADS_MAX];
        int started[BST_THREADS_MAX] = {0};
        if ((size_t)nthreads > ntasks)
            nthreads = (int)ntasks;
        for (int t = 1; t < nthreads; t++)
            started[t] = pthread_create(&th[t], NULL, emit_worker, &r) == 0;
        emit(w, top, &r, w->k, zero, 0, 1);
        pthread_mutex_lock(&r.lock);
        r.stop = 1;
        pthread_cond_broadcast(&r.cond);
        pthread_mutex_unlock(&r.lock);
        for (int t = 1; t < nthreads; t++)
            if (started[t])
                pthread_join(th[t], NULL);
        pthread_cond_destroy(&r.cond);
        pthread_mutex_destroy(&r.lock);
        if (r.nomem || top->out->fail)
            rc = bsti_sink_failed(out) ? BST_OK : BST_ENOMEM;
        else
            bsti_sink_put(out, top->out->p, top->out->n);
        for (size_t i = 0; i < r.window; i++)
            tb_free(&r.slot[i].text);
    }
    bsti_free(w->ctx, r.task);
    bsti_free(w->ctx, r.slot);
    bsti_free(w->ctx, hemi);
    bsti_free(w->ctx, memo);
    bsti_free(w->ctx, ws);
    top->memo = NULL;
    return rc;
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
    if (r->row_budget && (t->rank != 4 || !r->col_budget))
        return bsti_error(ctx, BST_EINVAL, "tensor tree: row budgets need a rank-4 tree and column "
                          "budgets");
    struct tw w;
    memset(&w, 0, sizeof w);
    w.ctx = ctx;
    w.t = t;
    w.d = t->d;
    w.f = t->d ? NULL : t->f;
    w.D = t->rank;
    w.k = t->k;
    w.G = (size_t)1 << t->k;
    w.half = w.G / 2;
    w.digits = r->digits;
    w.floor = r->floor;
    w.lossless = r->pct < 0.0;
    w.col_budget = w.lossless ? NULL : r->col_budget; /* (lossless: nothing to bound) */
    w.row_budget = w.col_budget ? r->row_budget : NULL;
    for (int i = w.D - 1; i >= 0; i--)
        w.stride[i] = i == w.D - 1 ? 1 : w.stride[i + 1] * w.G;
    for (int j = 0; j < (1 << w.D); j++)
        for (int i = 0; i < w.D; i++) {
            w.boff[j] += (size_t)((j >> i) & 1) * w.stride[i];
            w.loff[j] += (size_t)((j >> (w.D - 1 - i)) & 1) * w.stride[i];
        }
    size_t nodes = 0;
    for (int l = 1; l <= w.k + 1; l++) {
        w.off[l] = nodes;
        size_t S = w.G >> l, c = 1;
        for (int i = 0; i < w.D && l <= w.k; i++)
            c *= S;
        nodes += l <= w.k ? c : 0;
    }
    for (int l = w.k - 1; l >= 1 && !w.split; l--)
        if ((size_t)1 << (w.D * l) <= TASK_CELLS)
            w.split = l;
    size_t nblocks = (w.k >= 2 ? w.off[2] : nodes) - w.off[1]; /* the finest 2^D blocks */
    size_t nin = w.D == 4 ? w.G * w.G : w.half;
    size_t nsplit = w.split ? w.off[w.split + 1] - w.off[w.split] : 0;
    int nthreads = bsti_ctx_workers(ctx, nsplit);
    double *hemi = bsti_calloc(ctx, nin, sizeof *hemi);
    w.m = bsti_calloc(ctx, nodes, sizeof *w.m);
    w.lmean = nsplit ? bsti_alloc_array(ctx, nsplit, sizeof *w.lmean) : NULL;
    size_t nkept = w.col_budget && w.split ? nodes - w.off[w.split] : 0;
    w.vsum = nkept ? bsti_alloc_array(ctx, nkept, sizeof *w.vsum) : NULL;
    w.task_share = w.split ? (double)((size_t)1 << 2 * w.split) / (double)(w.G * w.G) : 1.0;
    size_t nr = w.row_budget && !w.split ? w.G * w.G : 0; /* one level: the top is the task */
    double *ws = w.col_budget ? bsti_alloc_array(ctx, sums_room(&w, w.k) + nr, sizeof *ws) : NULL;
    if (!w.m || !hemi || (nsplit && !w.lmean) || (nkept && !w.vsum) || (w.col_budget && !ws)) {
        bsti_free(ctx, w.m), bsti_free(ctx, hemi), bsti_free(ctx, w.lmean);
        bsti_free(ctx, w.vsum), bsti_free(ctx, ws);
        return BST_ENOMEM;
    }
    for (size_t q = 0; q < nkept; q++)
        w.vsum[q] = NAN;
    struct bacc b;
    build_all(&w, nthreads, &b);
    st->negatives = (int)b.negatives;
    int rc = BST_OK;
    if (b.bad)
        rc = bsti_error(ctx, BST_EINVAL, "tensor tree: value %g is not finite in single precision",
                        b.badval);
    /* threshold: the pct-th percentile of the finest blocks' measures (lossless: 0) */
    if (rc == BST_OK && r->pct >= 0.0) {
        float *tmp = bsti_alloc_array(ctx, nblocks, sizeof *tmp);
        size_t nsel = 0;
        if (!tmp) {
            rc = BST_ENOMEM;
        } else if (w.D == 4 && t->fine_in) { /* only the blocks touching fine incident cells */
            size_t S = w.G / 2;
            for (size_t q = 0; q < nblocks; q++) {
                size_t bx = q / (S * S * S), by = (q / (S * S)) % S;
                const unsigned char *f = t->fine_in;
                if (f[2 * bx * w.G + 2 * by] | f[2 * bx * w.G + 2 * by + 1] |
                    f[(2 * bx + 1) * w.G + 2 * by] | f[(2 * bx + 1) * w.G + 2 * by + 1])
                    tmp[nsel++] = w.m[w.off[1] + q];
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
        for (size_t q = 0; q < nblocks && w.force; q++)
            if (w.m[w.off[1] + q] > w.thresh)
                w.force = 0;
        struct tbuf text = {ctx, NULL, 0, 0, 0};
        struct eacc top;
        memset(&top, 0, sizeof top);
        top.out = &text;
        top.hemi = hemi;
        top.ws = ws;
        top.erow = nr ? ws + sums_room(&w, w.k) : NULL;
        if (top.erow)
            memset(top.erow, 0, nr * sizeof *top.erow);
        top.hside = w.G;
        uint64_t before = out->total;
        rc = emit_all(&w, nthreads, &top, out);
        tb_free(&text);
        st->bytes = out->total - before;
        if (rc == BST_ENOMEM)
            rc = bsti_error(ctx, BST_ENOMEM, "tensor tree: out of memory for the text");
        else if (bsti_sink_failed(out))
            rc = bsti_error(ctx, BST_EIO, "tensor tree: write failed");
        st->values = top.values;
        st->leaves = top.leaves;
        st->blocks_kept = top.blocks_kept;
        st->max_error = top.max_error;
        st->l1_error = top.sum_abs > 0.0 ? top.sum_err / top.sum_abs : 0.0;
        double worst = 0.0;
        for (size_t i = 0; i < nin; i++)
            worst = fmax(worst, fabs(hemi[i]));
        st->hemi_error = worst * M_PI / (double)(w.G * w.G); /* outgoing cell: pi / G^2 sr */
        bsti_progress(ctx, 1.0, "writing a tensor tree");
    }
    bsti_free(ctx, w.m);
    bsti_free(ctx, w.lmean);
    bsti_free(ctx, w.vsum);
    bsti_free(ctx, ws);
    bsti_free(ctx, hemi);
    return rc;
}
