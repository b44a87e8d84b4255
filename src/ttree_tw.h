/* ttree_tw.h - the tensor-tree writer's state, private to its files: ttree_write.c (the driver,
 * the text and the threads that write it; the passes are described there), ttree_measure.c
 * (pass 1: the variation measures, and the percentile's selection) and ttree_bound.c (the bound
 * on directional-hemispherical values, bsti_reduce).  Orders and conventions: ttree_write.h. */
#ifndef BST_TTREE_TW_H
#define BST_TTREE_TW_H

#include <stddef.h>
#include <stdint.h>

#include "ctx.h"
#include "numtext.h"
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
    int plain;                     /* bsti_reduce's plain_checks */
    double text_eps;               /* |what a reader stores - v| <= v text_eps for a value's text
                                      (bsti_bounds_rho, with a quarter to spare) */
    double *vsum;                  /* nodes of levels >= split (index - off[split]): the sum of a
                                      candidate that passed the bound, NaN before it is checked */
    int rows;                      /* rank 4, bsti_reduce's measure_rows: eacc's rerr kept */
    struct up_acct *up;            /* nodes of levels >= split (as vsum) that passed the bound:
                                      the errors their one-value leaf makes (ttree_write.c,
                                      precheck), or NULL */
};

/* The error sums of a node's one-value leaf (eacc's, over the node's cells alone): hemi per
 * incident index of the node, rerr per outgoing cell (w->rows); hemi NULL: not made. */
struct up_acct {
    double sum_abs, sum_err, max_error;
    double *hemi, *rerr;
};

/* ------------------------------------------------------------------ tensor access */

/* How the tensor's values are held: 0 doubles (w->d), 1 floats (w->f), 2 through its reader. */
static inline int tw_kind(const struct tw *w) { return w->d ? 0 : w->f ? 1 : 2; }

/* Value at index k of a tensor held as kind says (inlined with kind known, no test per value). */
static inline __attribute__((always_inline)) double cell_at(const struct tw *w, int kind, size_t k)
{
    return kind == 0 ? w->d[k] : kind == 1 ? (double)w->f[k] : w->t->get(w->t->opaque, k);
}

/* Raw value of cell c (rank 3: 0 in the unused upper half of dimension 0). */
static inline double cell(const struct tw *w, const size_t *c)
{
    size_t idx;
    if (w->D == 3 && c[0] >= w->half)
        return 0.0;
    idx = c[0] * w->stride[0] + c[1] * w->stride[1] + c[2] * w->stride[2];
    if (w->D == 4)
        idx += c[3];
    return cell_at(w, tw_kind(w), idx);
}

/* The 2^D values of the finest block at corner c, member j at index offset off[j] (w->boff or
 * w->loff; leaf says which, for a rank-3 block in the dead half). */
static inline void block_values(const struct tw *w, const size_t *c, const size_t *off, int leaf,
                                double *v)
{
    int D = w->D, nk = 1 << D;
    if (D == 3 && c[0] + 1 >= w->half) { /* k = 1, or the dead half: cell by cell */
        for (int j = 0; j < nk; j++) {
            size_t cc[4] = {0, 0, 0, 0};
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
static inline void prefetch_region(const struct tw *w, int l, const size_t *c)
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

/* The corner cc of child j of the node of level l at corner c (bit i of j: the upper half along
 * dimension i); dimensions from D on are 0. */
static inline void child_corner(const struct tw *w, int l, const size_t *c, int j, size_t *cc)
{
    for (int i = 0; i < 4; i++)
        cc[i] = i < w->D ? c[i] + ((size_t)((j >> i) & 1) << (l - 1)) : 0;
}

static inline size_t node_index(const struct tw *w, int l, const size_t *c)
{
    size_t S = w->G >> l, idx = 0;
    for (int i = 0; i < w->D; i++)
        idx = idx * S + (c[i] >> l);
    return w->off[l] + idx;
}

/* What one thread's share of build found. */
struct bacc {
    size_t negatives;
    int bad;                       /* a value that is not finite in single precision */
    double badval;
    size_t badnode;                /* the finest block holding it (the least such is reported) */
};
/* Pass 1 on nthreads threads (the measures of every node into w->m, the means of the tasks' nodes
 * into w->lmean); *b gets what they found.  ttree_measure.c. */
void bsti_tw_build_all(struct tw *w, int nthreads, struct bacc *b);
/* The k-th smallest (0-based) of a[0..n-1], reordering a.  ttree_measure.c. */
float bsti_tw_select_kth(float *a, size_t n, size_t k);

/* ------------------------------------------------------------------ pass 3: the text */

/* A growing text buffer (the context's allocator, no error recorded: threads share the ctx). */
struct tbuf {
    const bst_ctx *ctx;
    char *p;
    size_t n, cap;
    int fail;                      /* an allocation failed: the text is incomplete */
};

/* The texts of recent values: a value's text is a function of its float alone (value_text), and
 * measured data repeat values (RADIANCE's blind at k = 6: a third of 5.3 million non-zero values
 * found in a table of this size). */
#define MEMO_BITS 12
/* Where values rarely repeat (a computed shade: fewer than 1 in MEMO_RARE of MEMO_PROBE
 * lookups found), the memo is passed by for the next MEMO_PASS values: a miss costs its lookup
 * and the copy into the table of text just written byte by byte. */
#define MEMO_PROBE 1024
#define MEMO_RARE 16
#define MEMO_PASS (15 * MEMO_PROBE)
struct memo {
    uint32_t key[1 << MEMO_BITS];  /* the float's bits; 0 (+0, never stored) = empty */
    unsigned char len[1 << MEMO_BITS];
    float back[1 << MEMO_BITS];    /* what a reader stores of the text */
    char text[1 << MEMO_BITS][16];
    uint32_t probes, hits;         /* lookups since the last decision, and those found */
    uint32_t pass;                 /* values still to pass by */
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
    double *rerr;                  /* w->rows: per outgoing cell of the region (origin o0, o1, side
                                      hside), the sum of the errors, as hemi; else NULL */
    size_t o0, o1;                 /* the region's first outgoing cell */
    size_t h0, h1, hside;          /* the region's first incident cell and side (rank 3: h0) */
    double *pyr;                   /* a task's sums by level (bsti_tw_pyramid_room), or NULL */
    int pyr_ready;                 /* pyr holds this task's sums */
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

/* ------------------------------------------------------------------ the bound (ttree_bound.c) */

/* Cells of the node of level l at corner c that hold data (rank 3: not in the dead half). */
size_t bsti_tw_live_cells(const struct tw *w, int l, const size_t *c);
/* Doubles of the bound's sums over a node of level l: one a column (incident index), and one a
 * row (outgoing cell) when rows are bounded (rank 4 only). */
size_t bsti_tw_sums_room(const struct tw *w, int l);
/* Doubles of a task's sums by level (a rank-4 tree with direct access and a bound; else 0):
 * for each level l of 1..split, the sums of each incident cell over the outgoing cells of each
 * node of level l and, with row budgets, of each outgoing cell over the incident cells of each
 * such node.  A candidate's check then reads its sums instead of its cells (the refusals cascade
 * down the levels, and each level's rescan of the task was most of the bound's time). */
size_t bsti_tw_pyramid_room(const struct tw *w);
/* Does the one value of the node of level l at corner c keep every sum the bound watches within
 * its budget (bsti_reduce)?  Inside a task (a: its sums; a->hemi the errors so far of its incident
 * indices, a->erow the changes so far of its rows) the changes add to those of the task; above the
 * tasks (a NULL) the node's own changes are held to its share.  ws: bsti_tw_sums_room(l) doubles;
 * *sum: the sum of the node's cells.  A node that passes in a task has its rows' changes added to
 * a->erow (its columns' reach a->hemi as leaf_merged writes it). */
int bsti_tw_within_bound(const struct tw *w, struct eacc *a, double *ws, int l, const size_t *c,
                         double *sum);

#endif
