/* ttree_measure.c - pass 1 of the tensor-tree writer (ttree_write.c describes the passes): the
 * variation measure of every node above the cells, streamed over the tensor on the writer's
 * threads, and the selection that finds the culling percentile among the finest blocks'. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <string.h>

#include "ttree_tw.h"

static float measure(double sd, double mean, double floor)
{
    double m = sd / (sqrt(mean) + floor);
    if (!(m >= FLT_MIN))
        return FLT_MIN; /* non-constant: strictly above 0 */
    return m > FLT_MAX ? FLT_MAX : (float)m;
}


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

/* On x86-64 with GCC's function multi-versioning, stream_blocks is also compiled for AVX2 (as the
 * sparse products are, mat_mul.c): four blocks' values then fill one vector register.  No FMA:
 * each product and sum is rounded as in block_measure. */
#if defined(__x86_64__) && defined(__has_attribute)
#if __has_attribute(target_clones)
#define MEASURE_CLONES __attribute__((target_clones("avx2", "default")))
#endif
#endif
#ifndef MEASURE_CLONES
#define MEASURE_CLONES
#endif

/* Four blocks side by side, block t in lane t (GCC's vector extension); the unaligned views the
 * tensor's rows are read through. */
#define MEASURE_NB 4
typedef double mv4d __attribute__((vector_size(32)));
typedef long long mv4l __attribute__((vector_size(32)));
typedef float mv8f_u __attribute__((vector_size(32), aligned(4), may_alias));
typedef double mv4d_u __attribute__((vector_size(32), aligned(8), may_alias));

/* a where mask m is set, else b (lane by lane). */
#define MV_PICK(m, a, b) ((mv4d)(((mv4l)(a) & (m)) | ((mv4l)(b) & ~(m))))

/* block_measure for the MEASURE_NB finest blocks of corners c + 2 t e_3 (rank 4, t < MEASURE_NB),
 * whose rows of values start at index row[r] + x (r < 8: member j of block t at row[j & 7] + x +
 * 2 t + (j >> 3)), in the four lanes of vectors: each block's comparisons and sums over its
 * values in their order, as block_measure makes them, so the same bits (negatives counted and
 * read as +0, -0 kept).  Only where every value is finite and at most FLT_MAX: 0, nothing
 * written, when one is not (block_measure alone reports it). */
static inline __attribute__((always_inline)) int blocks_measure(const struct tw *w,
                                                                struct bacc *b,
                                                                const size_t *row, size_t x,
                                                                const size_t *c, double *mean)
{
    mv4d v[16]; /* member j of the four blocks */
    for (int r = 0; r < 8; r++) {
        if (w->f) {
            mv8f_u raw = *(const mv8f_u *)(w->f + row[r] + x);
            v[r] = __builtin_convertvector(__builtin_shufflevector(raw, raw, 0, 2, 4, 6), mv4d);
            v[r + 8] = __builtin_convertvector(__builtin_shufflevector(raw, raw, 1, 3, 5, 7), mv4d);
        } else {
            mv4d_u lo = *(const mv4d_u *)(w->d + row[r] + x), hi = *(const mv4d_u *)(w->d + row[r] + x + 4);
            v[r] = __builtin_shufflevector(lo, hi, 0, 2, 4, 6);
            v[r + 8] = __builtin_shufflevector(lo, hi, 1, 3, 5, 7);
        }
    }
    mv4l ok = {-1, -1, -1, -1}, neg = {0, 0, 0, 0};
    for (int j = 0; j < 16; j++) {
        ok &= (v[j] <= FLT_MAX) & (v[j] >= -DBL_MAX); /* (false for NaN) */
        mv4l n = v[j] < 0.0;
        neg -= n; /* (a set mask is -1) */
        v[j] = (mv4d)((mv4l)v[j] & ~n); /* +0 where negative */
    }
    if (!(ok[0] & ok[1] & ok[2] & ok[3]))
        return 0;
    b->negatives += (size_t)(neg[0] + neg[1] + neg[2] + neg[3]);
    mv4d lo = v[0], hi = v[0], sum = 0.0 + v[0], ss, mu;
    for (int j = 1; j < 16; j++) {
        lo = MV_PICK(v[j] < lo, v[j], lo);
        hi = MV_PICK(v[j] > hi, v[j], hi);
        sum += v[j];
    }
    mu = sum / 16.0;
    ss = 0.0 + (v[0] - mu) * (v[0] - mu);
    for (int j = 1; j < 16; j++)
        ss += (v[j] - mu) * (v[j] - mu);
    for (int t = 0; t < MEASURE_NB; t++) {
        float m;
        mean[t] = mu[t];
        if (lo[t] == hi[t]) {
            mean[t] = lo[t];
            m = 0.0f;
        } else if (w->lossless) {
            m = FLT_MIN;
        } else {
            m = measure(sqrt(ss[t] / 16.0), mu[t], w->floor);
        }
        size_t ct[4] = {c[0], c[1], c[2], c[3] + 2 * (size_t)t};
        w->m[node_index(w, 1, ct)] = m;
    }
    return 1;
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
MEASURE_CLONES static void stream_blocks(const struct tw *w, struct bacc *b, const struct pre1 *pre)
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
            if (a3 % MEASURE_NB == 0 && h - a3 >= MEASURE_NB &&
                blocks_measure(w, b, row, 2 * a3, c, pre->mean + q)) {
                a3 += MEASURE_NB - 1, q += MEASURE_NB - 1;
                continue;
            }
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
        size_t cn[4];
        for (int j = 0; j < nk; j++) {
            size_t cc[4];
            child_corner(w, l, c, j, cc);
            if (l == 3) { /* the level-2 children: this one's cells at first, then the next's */
                if (j == 0)
                    prefetch_node2(w, cc, 1);
                if (j + 1 < nk) {
                    child_corner(w, l, c, j + 1, cn);
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
void bsti_tw_build_all(struct tw *w, int nthreads, struct bacc *b)
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

float bsti_tw_select_kth(float *a, size_t n, size_t k)
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
