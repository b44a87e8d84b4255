/* ttree_write.c - emitting RADIANCE tensor trees from a full component tensor, exactly or reduced
 * by a variation criterion (conventions and orders in ttree_write.h).
 *
 * Three passes over the tensor, all streaming:
 * 1. build: every node above the cells (the finest 2^D blocks, their parents, ... the root) gets a
 *    variation measure m, kept as one float per node; m = 0 exactly when the node's region is
 *    constant, and m never decreases from a node to its parent, so "m <= threshold" selects whole
 *    subtrees and a node is merged only if everything below it would be.
 * 2. threshold: the pct-th percentile of m over the finest blocks (selection on a copy).
 * 3. emit: depth first; a node with m <= threshold becomes a one-value leaf (its average) where
 *    the bound on directional-hemispherical values allows it (bsti_reduce, ttree_bound.c), a
 *    finest block above it a 2^D-value leaf, anything else a branch.  The error each leaf makes,
 *    against the value a reader will store, is summed on the way.
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

#include "ttree_tw.h"
#include "write_bound.h"

/* ------------------------------------------------------------------ pass 3: emit */

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

/* value_text through the memo (mm may be NULL). */
static inline int put_value(const struct tw *w, struct memo *mm, double v, char *p, float *back)
{
    float f = (float)v;
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    if (!mm || bits == 0 || !isfinite(f))
        return value_text(w, v, p, back);
    if (mm->pass) {
        mm->pass--;
        return value_text(w, v, p, back);
    }
    if (++mm->probes == MEMO_PROBE) {
        if (mm->hits < MEMO_PROBE / MEMO_RARE)
            mm->pass = MEMO_PASS;
        mm->probes = mm->hits = 0;
    }
    size_t h = (size_t)((bits * UINT32_C(2654435761)) >> (32 - MEMO_BITS));
    if (mm->key[h] == bits) {
        mm->hits++;
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
                    if (acct) { /* the sums in locals for the row (same order, same bits): through
                                   a, each addition was a load and a store */
                        double *rp = a->rerr ? &a->rerr[(c[2] + x2 - a->o0) * a->hside + c[3] - a->o1]
                                             : NULL; /* (rank 4 only) */
                        double sum_abs = a->sum_abs, sum_err = a->sum_err, max_error = a->max_error;
                        double h = *hp;
                        for (size_t x = 0; x < s; x++) {
                            double v = pd ? pd[x] : (double)pf[x], e = v - back;
                            sum_abs += fabs(v);
                            sum_err += fabs(e);
                            if (fabs(e) > max_error)
                                max_error = fabs(e);
                            h += e;
                            if (rp)
                                rp[x] += e;
                        }
                        a->sum_abs = sum_abs, a->sum_err = sum_err, a->max_error = max_error;
                        *hp = h;
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
                    if (acct) {
                        account(w, a, i0, cc[1], v, back);
                        if (a->rerr)
                            a->rerr[(cc[2] - a->o0) * a->hside + cc[3] - a->o1] += v - back;
                    } else
                        sum += clamp0(v);
                    n++;
                }
        }
    }
    if (live)
        *live = n;
    return sum;
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
    if (bsti_tw_within_bound(w, kept ? NULL : a, a->ws, l, c, sum)) {
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
            live = bsti_tw_live_cells(w, l, c);
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
            for (size_t x = 0; a->rerr && x < s; x++) /* every outgoing cell: ni incident cells */
                for (size_t y = 0; y < s; y++)
                    a->rerr[(c[2] + x - a->o0) * a->hside + c[3] + y - a->o1] += e * (double)ni;
        }
    } else if (!constant && w->up && l >= w->split && w->up[node_index(w, l, c) - w->off[w->split]].hemi) {
        const struct up_acct *u = &w->up[node_index(w, l, c) - w->off[w->split]];
        size_t s = (size_t)1 << l;
        a->sum_abs += u->sum_abs;
        a->sum_err += u->sum_err;
        a->max_error = fmax(a->max_error, u->max_error);
        for (size_t x = 0; x < s && (w->D == 4 || c[0] + x < w->half); x++)
            for (size_t y = 0; y < (w->D == 4 ? s : 1); y++)
                *hemi_at(w, a, c[0] + x, c[1] + y) += u->hemi[x * (w->D == 4 ? s : 1) + y];
        for (size_t x = 0; u->rerr && a->rerr && x < s; x++)
            for (size_t y = 0; y < s; y++)
                a->rerr[(c[2] + x - a->o0) * a->hside + c[3] + y - a->o1] += u->rerr[x * s + y];
    } else if (!constant || first != 0.0) { /* (constant zero regions, the bulk, make no error) */
        region_pass(w, a, l, c, 1, back, NULL);
    }
}

/* A rank-4 block's 16 values as leaf_block writes them, at p; returns the end of the text.  The
 * sums the values add to (the error sums, the four incident cells' errors and the four outgoing
 * cells' changes) are held in locals for the block: the same additions in the same order as one
 * value at a time through a, without a round trip through memory for each. */
static char *leaf_block4(const struct tw *w, struct eacc *a, const size_t *c, const double *vals,
                         char *p)
{
    double sum_abs = a->sum_abs, sum_err = a->sum_err, max_error = a->max_error;
    double *hp[4], h[4], *ep[4] = {NULL, NULL, NULL, NULL}, e[4] = {0, 0, 0, 0};
    double *rp[4] = {NULL, NULL, NULL, NULL}, re[4] = {0, 0, 0, 0};
    double lam = M_PI / (double)(w->G * w->G);
    for (int q = 0; q < 4; q++) { /* incident cells (dimension 0 first), outgoing cells alike */
        hp[q] = hemi_at(w, a, c[0] + (size_t)(q >> 1), c[1] + (size_t)(q & 1));
        h[q] = *hp[q];
        if (a->erow) {
            ep[q] = &a->erow[(c[2] + (size_t)(q >> 1) - a->o0) * a->hside + c[3] + (size_t)(q & 1) - a->o1];
            e[q] = *ep[q];
        }
        if (a->rerr) {
            rp[q] = &a->rerr[(c[2] + (size_t)(q >> 1) - a->o0) * a->hside + c[3] + (size_t)(q & 1) - a->o1];
            re[q] = *rp[q];
        }
    }
    for (int j = 0; j < 16; j++) { /* dimension 0 slowest: j's top two bits, the incident cell */
        float back;
        double v = vals[j];
        *p++ = ' ';
        p += put_value(w, a->memo, clamp0(v), p, &back);
        if (v == (double)back) { /* read back exactly (a float source): an error of +0 adds nothing */
            sum_abs += v;
            continue;
        }
        double err = v - back;
        sum_abs += fabs(v);
        sum_err += fabs(err);
        if (fabs(err) > max_error)
            max_error = fabs(err);
        h[j >> 2] += err;
        if (ep[0]) /* the bound's rows: the rounding's change */
            e[j & 3] += lam * ((double)back - clamp0(v));
        re[j & 3] += err; /* (kept only with rp) */
    }
    a->sum_abs = sum_abs, a->sum_err = sum_err, a->max_error = max_error;
    for (int q = 0; q < 4; q++) {
        *hp[q] = h[q];
        if (ep[q])
            *ep[q] = e[q];
        if (rp[q])
            *rp[q] = re[q];
    }
    return p;
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
    if (D == 4)
        p = leaf_block4(w, a, c, vals, p);
    for (int j = 0; D == 3 && j < nk; j++) { /* rank 3: j's top bit is the incident cell */
        float back;
        double v = vals[j];
        *p++ = ' ';
        p += put_value(w, a->memo, clamp0(v), p, &back);
        size_t i0 = c[0] + (size_t)(j >> 2);
        if (i0 >= w->half) /* the dead half: no data */
            continue;
        if (v == (double)back) /* read back exactly (a float source): an error of +0 adds nothing */
            a->sum_abs += v;
        else
            account(w, a, i0, c[1], v, back);
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
        size_t cc[4];
        child_corner(w, l, c, j, cc);
        __builtin_prefetch(&w->m[node_index(w, l - 1, cc)]);
    }
#endif
    for (int j = 0; j < (1 << w->D); j++) {
        size_t cc[4];
        child_corner(w, l, c, j, cc);
        if (l == 3) { /* level-2 children, this one and the next: all their cells unless one
                         constant leaf */
            size_t cn[4];
            if (j == 0)
                prefetch_node2(w, cc, w->m[node_index(w, 2, cc)] != 0.0f);
            if (j + 1 < (1 << w->D)) {
                child_corner(w, l, c, j + 1, cn);
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
/* The bound checks collect makes of nodes of levels >= split (each a pass over the node's cells:
 * about half of a dense k = 7 component's writing, on the calling thread alone), made first on
 * nthreads threads, a level at a time from the root down the nodes collect will reach: a node's
 * check (bsti_tw_within_bound without a task's sums) reads the tensor and writes only the node's
 * kept sum or its negated measure, so collect then finds every answer kept, and the bytes are
 * those of one thread. */
struct pre_node {
    size_t c[4];
    int on_path;
};

struct pre_part {
    const struct tw *w;
    const struct pre_node *nodes;
    const size_t *check;        /* indices into nodes of the candidates to check */
    size_t i0, i1;              /* check[i0 .. i1 - 1] */
    int l;
    double *ws;                 /* bsti_tw_sums_room(w, l) values of room */
    double *room;               /* rec values for each checked node's up_acct, by check index */
    size_t rec;
};

static void *pre_run(void *arg)
{
    const struct pre_part *p = arg;
    const struct tw *w = p->w;
    for (size_t i = p->i0; i < p->i1; i++) {
        const struct pre_node *nd = &p->nodes[p->check[i]];
        size_t q = node_index(w, p->l, nd->c);
        double sum, *kept = &w->vsum[q - w->off[w->split]];
        if (!bsti_tw_within_bound(w, NULL, p->ws, p->l, nd->c, &sum)) {
            w->m[q] = -w->m[q];
            continue;
        }
        *kept = sum;
        /* the errors of the leaf leaf_merged will write: its value's text as it makes it */
        struct up_acct *u = &w->up[q - w->off[w->split]];
        size_t s = (size_t)1 << p->l, live = bsti_tw_live_cells(w, p->l, nd->c);
        char text[40];
        float back;
        value_text(w, live ? sum / (double)live : 0.0, text, &back);
        struct eacc acc;
        memset(&acc, 0, sizeof acc);
        acc.hemi = p->room + i * p->rec;
        acc.rerr = w->rows ? acc.hemi + (w->D == 4 ? s * s : s) : NULL;
        memset(acc.hemi, 0, ((w->D == 4 ? s * s : s) + (w->rows ? s * s : 0)) * sizeof *acc.hemi);
        acc.h0 = nd->c[0], acc.h1 = nd->c[1], acc.hside = s;
        acc.o0 = nd->c[w->D - 2], acc.o1 = nd->c[w->D - 1];
        region_pass(w, &acc, p->l, nd->c, 1, back, NULL);
        u->sum_abs = acc.sum_abs, u->sum_err = acc.sum_err, u->max_error = acc.max_error;
        u->hemi = acc.hemi, u->rerr = acc.rerr;
    }
    return NULL;
}

/* The values of an up_acct's sums for a node of level l. */
static size_t up_rec(const struct tw *w, int l)
{
    size_t s = (size_t)1 << l;
    return (w->D == 4 ? s * s : s) + (w->rows ? s * s : 0);
}

/* BST_OK or BST_ENOMEM (the checks left to collect, the errors to emit).  The up_acct sums of
 * each level's checked nodes in bufs[k - l] (freed by the caller).  Made on one thread too, so
 * that the error sums are added in one order whatever the threads. */
static int precheck(const struct tw *w, int nthreads, double **bufs)
{
    if (!w->split || !w->col_budget || !w->up)
        return BST_OK;
    size_t most = w->off[w->split + 1] - w->off[w->split], room = bsti_tw_sums_room(w, w->k);
    struct pre_node *cur = bsti_alloc_array(w->ctx, most, sizeof *cur);
    struct pre_node *next = bsti_alloc_array(w->ctx, most, sizeof *next);
    size_t *check = bsti_alloc_array(w->ctx, most, sizeof *check);
    double *ws = bsti_alloc_array(w->ctx, (size_t)nthreads * room, sizeof *ws);
    int rc = cur && next && check && ws ? BST_OK : BST_ENOMEM;
    size_t ncur = 1;
    if (rc == BST_OK)
        cur[0] = (struct pre_node){{0, 0, 0, 0}, 1};
    for (int l = w->k; rc == BST_OK && l >= w->split && ncur; l--) {
        size_t nc = 0, rec = up_rec(w, l);
        for (size_t i = 0; i < ncur; i++) {
            size_t q = node_index(w, l, cur[i].c);
            if (candidate(w, w->m[q], cur[i].on_path) && w->m[q] != 0.0f &&
                isnan(w->vsum[q - w->off[w->split]]))
                check[nc++] = i;
        }
        if (nc && !(bufs[w->k - l] = bsti_alloc_array(w->ctx, nc * rec, sizeof **bufs))) {
            rc = BST_ENOMEM;
            break;
        }
        size_t np = nc < (size_t)nthreads ? nc : (size_t)nthreads;
        struct pre_part part[BST_THREADS_MAX];
        for (size_t t = 0; t < np; t++)
            part[t] = (struct pre_part){w, cur, check, nc * t / np, nc * (t + 1) / np, l,
                                        ws + t * room, bufs[w->k - l], rec};
        if (np)
            bsti_run_parts(part, sizeof *part, np, pre_run);
        if (l == w->split)
            break;
        size_t nn = 0;
        for (size_t i = 0; i < ncur; i++) {
            if (candidate(w, w->m[node_index(w, l, cur[i].c)], cur[i].on_path))
                continue; /* merged: collect does not go below it */
            for (int j = 0; j < (1 << w->D); j++) {
                struct pre_node *ch = &next[nn++];
                child_corner(w, l, cur[i].c, j, ch->c);
                ch->on_path = cur[i].on_path && j == 0;
            }
        }
        struct pre_node *x = cur;
        cur = next, next = x, ncur = nn;
    }
    bsti_free(w->ctx, cur), bsti_free(w->ctx, next), bsti_free(w->ctx, check), bsti_free(w->ctx, ws);
    return rc;
}

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
        size_t cc[4];
        child_corner(w, l, c, j, cc);
        collect(w, r, l - 1, cc, depth + 1, on_path && j == 0);
    }
}

static void run_task(struct run *r, size_t t)
{
    const struct tw *w = r->w;
    struct slot *s = &r->slot[t % r->window];
    const struct task *tk = &r->task[t];
    double *hemi = s->acc.hemi, *ws = s->acc.ws, *erow = s->acc.erow, *pyr = s->acc.pyr;
    double *rerr = s->acc.rerr;
    size_t hside = s->acc.hside;
    struct memo *mm = s->acc.memo;
    memset(&s->acc, 0, sizeof s->acc);
    s->acc.out = &s->text;
    s->acc.memo = mm;
    s->acc.ws = ws;
    s->acc.erow = erow;
    s->acc.rerr = rerr;
    s->acc.hemi = hemi;
    s->acc.pyr = pyr; /* (pyr_ready 0: built at the task's first check) */
    s->acc.hside = hside;
    s->acc.h0 = tk->c[0], s->acc.h1 = tk->c[1];
    s->acc.o0 = tk->c[w->D - 2], s->acc.o1 = tk->c[w->D - 1];
    memset(hemi, 0, (w->D == 4 ? hside * hside : hside) * sizeof *hemi);
    if (erow)
        memset(erow, 0, hside * hside * sizeof *erow);
    if (rerr)
        memset(rerr, 0, hside * hside * sizeof *rerr);
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
    for (size_t x = 0; b->rerr && x < b->hside; x++) /* (a->rerr: the whole tree's, origin 0) */
        for (size_t y = 0; y < b->hside; y++)
            a->rerr[(b->o0 + x) * a->hside + b->o1 + y] += b->rerr[x * b->hside + y];
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
    double *upbuf[BST_K_MAX + 1] = {NULL};
    if (precheck(w, nthreads, upbuf) != BST_OK) {
        for (int i = 0; i <= BST_K_MAX; i++)
            bsti_free(w->ctx, upbuf[i]);
        return BST_ENOMEM;
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
    double *rerr = w->rows ? bsti_alloc_array(w->ctx, r.window * hs * hs, sizeof *rerr) : NULL;
    struct memo *memo = bsti_calloc(w->ctx, r.window + 1, sizeof *memo);
    size_t room = w->col_budget ? bsti_tw_sums_room(w, w->split) : 0, nr = w->row_budget ? hs * hs : 0;
    double *ws = room ? bsti_alloc_array(w->ctx, r.window * (room + nr), sizeof *ws) : NULL;
    size_t npyr = bsti_tw_pyramid_room(w);
    double *pyr = npyr ? bsti_alloc_array(w->ctx, r.window * npyr, sizeof *pyr) : NULL;
    int rc = r.task && r.slot && hemi && memo && (!room || ws) && (!npyr || pyr) &&
             (!w->rows || rerr) ? BST_OK : BST_ENOMEM;
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
            r.slot[i].acc.rerr = rerr ? rerr + i * hs * hs : NULL;
            r.slot[i].acc.pyr = pyr ? pyr + i * npyr : NULL;
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
    bsti_free(w->ctx, rerr);
    bsti_free(w->ctx, memo);
    bsti_free(w->ctx, ws);
    bsti_free(w->ctx, pyr);
    for (int i = 0; i <= BST_K_MAX; i++)
        bsti_free(w->ctx, upbuf[i]);
    top->memo = NULL;
    return rc;
}

/* ------------------------------------------------------------------ driver */

/* w->thresh: the pct-th percentile of the measures of the nblocks finest blocks (of those touching
 * a fine incident cell, with variable resolution). */
static int threshold(struct tw *w, double pct, size_t nblocks)
{
    float *tmp = bsti_alloc_array(w->ctx, nblocks, sizeof *tmp);
    size_t nsel = 0;
    if (!tmp)
        return BST_ENOMEM;
    if (w->D == 4 && w->t->fine_in) { /* only the blocks touching fine incident cells */
        size_t S = w->G / 2;
        const unsigned char *f = w->t->fine_in;
        for (size_t q = 0; q < nblocks; q++) {
            size_t bx = q / (S * S * S), by = (q / (S * S)) % S;
            if (f[2 * bx * w->G + 2 * by] | f[2 * bx * w->G + 2 * by + 1] |
                f[(2 * bx + 1) * w->G + 2 * by] | f[(2 * bx + 1) * w->G + 2 * by + 1])
                tmp[nsel++] = w->m[w->off[1] + q];
        }
    } else {
        memcpy(tmp, w->m + w->off[1], nblocks * sizeof *tmp);
        nsel = nblocks;
    }
    size_t rank = (size_t)floor(pct / 100.0 * (double)nsel);
    if (rank > 0)
        w->thresh = bsti_tw_select_kth(tmp, nsel, rank - 1);
    bsti_free(w->ctx, tmp);
    return BST_OK;
}

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
    w.plain = r->plain_checks;
    w.rows = w.D == 4 && r->measure_rows;
    w.text_eps = 1.25 * bsti_bounds_rho(w.digits);
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
    double *rerr = w.rows ? bsti_calloc(ctx, w.G * w.G, sizeof *rerr) : NULL;
    w.m = bsti_calloc(ctx, nodes, sizeof *w.m);
    w.lmean = nsplit ? bsti_alloc_array(ctx, nsplit, sizeof *w.lmean) : NULL;
    size_t nkept = w.col_budget && w.split ? nodes - w.off[w.split] : 0;
    w.vsum = nkept ? bsti_alloc_array(ctx, nkept, sizeof *w.vsum) : NULL;
    w.up = nkept ? bsti_calloc(ctx, nkept, sizeof *w.up) : NULL;
    w.task_share = w.split ? (double)((size_t)1 << 2 * w.split) / (double)(w.G * w.G) : 1.0;
    size_t nr = w.row_budget && !w.split ? w.G * w.G : 0; /* one level: the top is the task */
    double *ws = w.col_budget ? bsti_alloc_array(ctx, bsti_tw_sums_room(&w, w.k) + nr, sizeof *ws) : NULL;
    if (!w.m || !hemi || (nsplit && !w.lmean) || (nkept && (!w.vsum || !w.up)) ||
        (w.col_budget && !ws) || (w.rows && !rerr)) {
        bsti_free(ctx, w.m), bsti_free(ctx, hemi), bsti_free(ctx, w.lmean), bsti_free(ctx, rerr);
        bsti_free(ctx, w.vsum), bsti_free(ctx, w.up), bsti_free(ctx, ws);
        return BST_ENOMEM;
    }
    for (size_t q = 0; q < nkept; q++)
        w.vsum[q] = NAN;
    struct bacc b;
    bsti_tw_build_all(&w, nthreads, &b);
    st->negatives = (int)b.negatives;
    int rc = BST_OK;
    if (b.bad)
        rc = bsti_error(ctx, BST_EINVAL, "tensor tree: value %g is not finite in single precision",
                        b.badval);
    if (rc == BST_OK && r->pct >= 0.0)
        rc = threshold(&w, r->pct, nblocks);
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
        top.rerr = rerr;
        top.ws = ws;
        top.erow = nr ? ws + bsti_tw_sums_room(&w, w.k) : NULL;
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
        worst = 0.0;
        for (size_t o = 0; rerr && o < w.G * w.G; o++)
            worst = fmax(worst, fabs(rerr[o]));
        st->row_error = worst * M_PI / (double)(w.G * w.G); /* incident cell: the same */
        bsti_progress(ctx, 1.0, "writing a tensor tree");
    }
    bsti_free(ctx, w.m);
    bsti_free(ctx, w.lmean);
    bsti_free(ctx, w.vsum);
    bsti_free(ctx, w.up);
    bsti_free(ctx, ws);
    bsti_free(ctx, hemi);
    bsti_free(ctx, rerr);
    return rc;
}
