/* ttree_expand.c - a rank-4 tensor tree onto the Shirley-Chiu grid of order k: the census of its
 * non-zero cells, the dense matrix, or the non-zero cells one by one.  Layout and conventions in
 * ttree.h (bsti_ttree_expand4).
 *
 * The tree partitions the hypercube, so every grid cell lies in exactly one leaf region (a leaf
 * at level <= k: its value replicated) or in exactly one node at depth k (finer cells: their
 * mean).  Hence a dense expansion writes every cell once and needs no clearing, and subtrees
 * write disjoint cells, so that threads may share them out in any order with identical results.
 *
 * Every value is the one a plain accumulation gives (the expansion this file replaced, kept as the
 * definition): a cell starts at +0 and adds, in the tree's order (children 0..15, a leaf's values
 * in storage order), w v for each of its values v, w = 16^-(levels below k), skipping zeros.  So a
 * replicated cell holds (double)v + 0 (a stored -0 reads +0) and a mean is summed in that order.
 *
 * recip: the reciprocal transmission's matrix instead, M'[o + N i] = M[a(i) + N a(o)], a(j) =
 * N - 1 - j (basis.h, bst_basis_antipode): cell (i, o) of the tree is written at row a(i), column
 * a(o), so no second pass turns it over.
 *
 * Memory order: the tree's order jumps between columns of the column-major matrix (a leaf of 16
 * cells touches 4 columns N values apart), which leaves a fill waiting on memory.  So a dense fill
 * goes by slabs of whole columns, each small enough to stay in the cache while it is written
 * (SLAB_BYTES): the slab's columns are the cells of one node at depth s in the two dimensions that
 * give the column, and the walk enters only the children inside the slab above depth s.  The slabs
 * are also what threads share out. */
#include <config.h>

#include <pthread.h>
#include <stdatomic.h>
#include <string.h>
#include <unistd.h>

#include "ctx.h"
#include "ttree.h"

/* Bytes of matrix a slab of columns covers at most (it is written while it stays in L2). */
#define SLAB_BYTES (512 * 1024)
/* The smallest page size of the systems we run on (a guess is enough: see touch). */
#define BSTI_PAGE_BYTES 4096
/* At most this many threads, and no more than the online processors. */
#define EXPAND_MAX_THREADS 8
/* Below this order one thread does it all (a thread costs more than the work). */
#define EXPAND_PAR_MIN_K 4

enum walk_mode { WALK_CENSUS, WALK_FILL, WALK_EMIT };

struct walk {
    const bsti_ttree *t;
    enum walk_mode mode;
    int k, recip;
    size_t G, N;
    /* the slab of columns: destination column cells [x0, x0 + W) x [y0, y0 + W); the walk enters
     * only nodes inside it above depth s, where the column dimensions (0, 1, or 2, 3 when recip)
     * of the tree have coordinates (tx, ty) */
    int s;
    size_t x0, y0, W, tx, ty;
    double *md; /* WALK_FILL: the destination, double or float */
    float *mf;
    bsti_ttree_emit_fn emit; /* WALK_EMIT */
    void *opaque;
    size_t nnz, limit; /* WALK_CENSUS: stops once nnz > limit with an off-diagonal cell */
    int diag_only;
};

/* Whether destination column cell (cx, cy) lies in the slab. */
static inline int in_slab(const struct walk *w, size_t cx, size_t cy)
{
    return cx - w->x0 < w->W && cy - w->y0 < w->W;
}

/* A block of rep^4 cells of value v, lower corner (ix, iy, ox, oy) = (x0, y0, u0, v0). */
static inline void block(struct walk *w, size_t x0, size_t y0, size_t u0, size_t v0, size_t rep,
                         double v)
{
    size_t G = w->G, N = w->N;
    if (w->mode == WALK_CENSUS) {
        if (v != 0.0) {
            w->nnz += rep * rep * rep * rep;
            w->diag_only &= rep == 1 && x0 == u0 && y0 == v0; /* the reciprocal's diagonal too */
        }
        return;
    }
    if (w->recip) { /* column a(o), row a(i): coordinates mirrored, in and out swapped */
        size_t cx = G - rep - u0, cy = G - rep - v0, rx = G - rep - x0, ry = G - rep - y0;
        x0 = cx, y0 = cy, u0 = rx, v0 = ry;
    }
    if (w->mode == WALK_EMIT) {
        if (v != 0.0)
            for (size_t cx = x0; cx < x0 + rep; cx++)
                for (size_t cy = y0; cy < y0 + rep; cy++)
                    for (size_t rx = u0; rx < u0 + rep; rx++)
                        for (size_t ry = v0; ry < v0 + rep; ry++)
                            w->emit(w->opaque, rx * G + ry, cx * G + cy, v);
        return;
    }
    /* the block's columns within the slab: all of them, unless it comes from a leaf above depth s */
    size_t nx = rep, ny = rep;
    if (rep > w->W || !in_slab(w, x0, y0)) {
        if (x0 + rep <= w->x0 || x0 >= w->x0 + w->W || y0 + rep <= w->y0 || y0 >= w->y0 + w->W)
            return;
        size_t xa = x0 > w->x0 ? x0 : w->x0, ya = y0 > w->y0 ? y0 : w->y0;
        nx = (x0 + rep < w->x0 + w->W ? x0 + rep : w->x0 + w->W) - xa;
        ny = (y0 + rep < w->y0 + w->W ? y0 + rep : w->y0 + w->W) - ya;
        x0 = xa, y0 = ya;
    }
    size_t p0 = u0 * G + v0 + N * (x0 * G + y0);
    if (w->md) {
        double *m = w->md + p0;
        if (rep == 1) {
            *m = v;
            return;
        }
        for (size_t cx = 0; cx < nx; cx++, m += N * G)
            for (size_t cy = 0; cy < ny; cy++)
                for (size_t rx = 0; rx < rep; rx++) {
                    double *q = m + N * cy + G * rx;
                    for (size_t j = 0; j < rep; j++)
                        q[j] = v;
                }
    } else {
        float *m = w->mf + p0, f = (float)v;
        if (rep == 1) {
            *m = f;
            return;
        }
        for (size_t cx = 0; cx < nx; cx++, m += N * G)
            for (size_t cy = 0; cy < ny; cy++)
                for (size_t rx = 0; rx < rep; rx++) {
                    float *q = m + N * cy + G * rx;
                    for (size_t j = 0; j < rep; j++)
                        q[j] = f;
                }
    }
}

/* Weight of a value of a leaf whose cells lie `below` levels under k. */
static double weight(int below)
{
    return below > 0 ? 1.0 / (double)((size_t)1 << (4 * below)) : 1.0;
}

/* Add the values of the subtree of node id (at depth d > k or a leaf at depth k) to *s. */
static void accumulate(const bsti_ttree *t, uint32_t id, int d, int k, double *s)
{
    const struct bsti_tnode *n = &t->nodes[id];
    if (!n->leaf) {
        for (uint32_t c = 0; c < 16; c++)
            accumulate(t, t->kids[n->first + c], d + 1, k, s);
        return;
    }
    double w = weight(d + n->level - k);
    const float *val = t->values + n->first;
    size_t cells = (size_t)1 << (4 * n->level);
    for (size_t q = 0; q < cells; q++) {
        double v = w * val[q];
        if (v != 0.0)
            *s += v;
    }
}

/* A leaf at depth d <= k, lower corner c[] in cells of depth d. */
static void leaf(struct walk *w, const struct bsti_tnode *n, int d, const size_t c[4])
{
    size_t g = (size_t)1 << n->level;
    const float *val = w->t->values + n->first;
    int lv = d + n->level;
    if (lv <= w->k) { /* each value replicated over rep^4 cells */
        size_t rep = (size_t)1 << (w->k - lv), q = 0;
        for (size_t a = 0; a < g; a++)
            for (size_t b = 0; b < g; b++)
                for (size_t e = 0; e < g; e++)
                    for (size_t f = 0; f < g; f++, q++)
                        block(w, (c[0] * g + a) * rep, (c[1] * g + b) * rep, (c[2] * g + e) * rep,
                              (c[3] * g + f) * rep, rep, (double)val[q] + 0.0);
        return;
    }
    /* s^4 values a cell, in storage order; tc cells per dimension */
    int shift = lv - w->k;
    size_t s = (size_t)1 << shift, tc = g >> shift, G = w->G;
    double wt = weight(shift);
    for (size_t ta = 0; ta < tc; ta++)
        for (size_t tb = 0; tb < tc; tb++)
            for (size_t te = 0; te < tc; te++)
                for (size_t tf = 0; tf < tc; tf++) {
                    size_t x = c[0] * tc + ta, y = c[1] * tc + tb, u = c[2] * tc + te, v = c[3] * tc + tf;
                    if (w->mode == WALK_FILL && !(w->recip ? in_slab(w, G - 1 - u, G - 1 - v) : in_slab(w, x, y)))
                        continue;
                    double sum = 0.0;
                    for (size_t a = ta * s; a < ta * s + s; a++)
                        for (size_t b = tb * s; b < tb * s + s; b++)
                            for (size_t e = te * s; e < te * s + s; e++)
                                for (size_t f = tf * s; f < tf * s + s; f++) {
                                    double vw = wt * val[((a * g + b) * g + e) * g + f];
                                    if (vw != 0.0)
                                        sum += vw;
                                }
                    block(w, x, y, u, v, 1, sum);
                }
}

/* The subtree of node id at depth d <= k, lower corner c[] in cells of depth d. */
static void walk(struct walk *w, uint32_t id, int d, const size_t c[4])
{
    const bsti_ttree *t = w->t;
    const struct bsti_tnode *n = &t->nodes[id];
    if (w->mode == WALK_CENSUS && w->nnz > w->limit && !w->diag_only)
        return;
    if (n->leaf) {
        leaf(w, n, d, c);
        return;
    }
    if (d == w->k) {
        double s = 0.0;
        accumulate(t, id, d, w->k, &s);
        block(w, c[0], c[1], c[2], c[3], 1, s);
        return;
    }
    /* above the slab's depth only the children inside it: the two column bits fixed */
    unsigned fixed = 0, mask = 0;
    if (d < w->s) {
        int sh = w->s - d - 1, lo = w->recip ? 2 : 0;
        fixed = (unsigned)(((w->tx >> sh) & 1) << lo | ((w->ty >> sh) & 1) << (lo + 1));
        mask = 3u << lo;
    }
    for (unsigned child = 0; child < 16; child++) {
        if ((child & mask) != fixed)
            continue;
        size_t cc[4];
        for (int i = 0; i < 4; i++)
            cc[i] = 2 * c[i] + ((child >> i) & 1);
        walk(w, t->kids[n->first + child], d + 1, cc);
    }
}

/* ------------------------------------------------------------------ slabs shared out */

static struct walk walk_of(const bsti_ttree *t, int k, enum walk_mode mode, int recip)
{
    size_t G = (size_t)1 << k;
    return (struct walk){.t = t, .mode = mode, .k = k, .recip = recip, .G = G, .N = G * G,
                         .W = G, .limit = (size_t)-1, .diag_only = 1};
}

/* w set to slab i of 4^s: column cells of depth s (i >> s, i & (2^s - 1)). */
static void set_slab(struct walk *w, int s, size_t i)
{
    size_t gs = (size_t)1 << s, sx = i >> s, sy = i & (gs - 1);
    w->s = s;
    w->W = w->G >> s;
    w->x0 = sx * w->W, w->y0 = sy * w->W;
    /* the tree's coordinates of those columns: (ix, iy), or the mirrored (ox, oy) when recip */
    w->tx = w->recip ? gs - 1 - sx : sx;
    w->ty = w->recip ? gs - 1 - sy : sy;
}

/* Fresh memory is mapped at the first write to each page: those faults taken in address order
 * before the walk, one write a page, cost less than amid its scattered writes. */
static void touch(const struct walk *w)
{
    size_t es = w->md ? sizeof(double) : sizeof(float), bytes = es * w->N * w->W;
    char *m = w->md ? (char *)w->md : (char *)w->mf;
    for (size_t cx = w->x0; cx < w->x0 + w->W; cx++) {
        volatile char *col = m + es * w->N * (cx * w->G + w->y0); /* W columns in a row */
        for (size_t b = 0; b < bytes; b += BSTI_PAGE_BYTES)
            col[b] = 0;
    }
}

struct team {
    const struct walk *proto;
    int s;
    size_t nslabs;
    atomic_size_t next;
};

struct member {
    struct team *team;
    pthread_t thread;
    int started;
};

static void *work(void *arg)
{
    struct member *m = arg;
    struct team *tm = m->team;
    const size_t c0[4] = {0, 0, 0, 0};
    for (;;) {
        size_t i = atomic_fetch_add(&tm->next, 1);
        if (i >= tm->nslabs)
            break;
        struct walk w = *tm->proto;
        set_slab(&w, tm->s, i);
        touch(&w);
        walk(&w, 0, 0, c0);
    }
    return NULL;
}

int bsti_ttree_threads(int k)
{
    long cpus = sysconf(_SC_NPROCESSORS_ONLN);
    if (k < EXPAND_PAR_MIN_K || cpus < 2)
        return 1;
    return cpus < EXPAND_MAX_THREADS ? (int)cpus : EXPAND_MAX_THREADS;
}

void bsti_ttree_fill4(const bsti_ttree *t, int k, int recip, bst_precision prec, void *m, int threads)
{
    struct walk w = walk_of(t, k, WALK_FILL, recip);
    if (prec == BST_FLOAT)
        w.mf = m;
    else
        w.md = m;
    /* the deepest s <= k whose slabs, 4^(k - s) columns of N values, fit in SLAB_BYTES */
    size_t col = w.N * (prec == BST_FLOAT ? sizeof(float) : sizeof(double));
    int s = 0;
    while (s < k && ((size_t)1 << (2 * (k - s))) * col > SLAB_BYTES)
        s++;
    struct team tm = {.proto = &w, .s = s, .nslabs = (size_t)1 << (2 * s)};
    atomic_init(&tm.next, 0);
    if (threads > EXPAND_MAX_THREADS)
        threads = EXPAND_MAX_THREADS;
    if ((size_t)threads > tm.nslabs)
        threads = (int)tm.nslabs;
    struct member mb[EXPAND_MAX_THREADS];
    for (int i = 0; i < threads; i++)
        mb[i] = (struct member){.team = &tm};
    for (int i = 1; i < threads; i++) /* one that cannot start leaves its share to the others */
        mb[i].started = pthread_create(&mb[i].thread, NULL, work, &mb[i]) == 0;
    work(&mb[0]);
    for (int i = 1; i < threads; i++)
        if (mb[i].started)
            pthread_join(mb[i].thread, NULL);
}

void bsti_ttree_census4(const bsti_ttree *t, int k, size_t limit, size_t *nnz, int *diag_only)
{
    const size_t c0[4] = {0, 0, 0, 0};
    struct walk w = walk_of(t, k, WALK_CENSUS, 0);
    w.limit = limit;
    walk(&w, 0, 0, c0);
    *nnz = w.nnz;
    *diag_only = w.diag_only;
}

void bsti_ttree_emit4(const bsti_ttree *t, int k, int recip, bsti_ttree_emit_fn emit, void *opaque)
{
    const size_t c0[4] = {0, 0, 0, 0};
    struct walk w = walk_of(t, k, WALK_EMIT, recip);
    w.emit = emit;
    w.opaque = opaque;
    walk(&w, 0, 0, c0);
}

int bsti_ttree_expand4(const bsti_ttree *t, int k, double *m)
{
    if (t->dim != 4)
        return bsti_error(t->ctx, BST_EINVAL, "expanding a rank-%d tree as rank 4", t->dim);
    bsti_ttree_fill4(t, k, 0, BST_DOUBLE, m, bsti_ttree_threads(k));
    return BST_OK;
}
