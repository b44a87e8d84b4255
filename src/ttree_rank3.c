/* ttree_rank3.c - the rank-3 (isotropic) form of a Shirley-Chiu matrix and the check of how well it
 * represents the matrix (conventions in ttree_write.h; CONVENTIONS.md 5.2).
 *
 * A rank-3 tree stores f(sin theta_in, exit direction rotated so that the incident light travels
 * towards +x).  Its incident cell ix is exactly the square ring j = G/2 - 1 - ix of the incident
 * grid (the concentric map sends sin(theta) to the ring's "radius" max(|2 sx - 1|, |2 sy - 1|)).
 * Building it averages, per ring, the matrix over the ring's cells, over sample points of each
 * incident cell (their azimuths) and of each rank-3 outgoing cell; reading it back (the reader,
 * and the check here) averages over sample points of the incident and outgoing cells of the grid.
 *
 * Speed: a rotation by 90 degrees about Z maps grid cells onto grid cells exactly (cell (x, y) ->
 * (G-1-y, x)), and the sample patterns are invariant under it, so only the incident cells of one
 * quadrant are sampled; the other three follow by rotating both indices.  Angles are carried as
 * (radius, azimuth) so that rotating a direction is an addition.  Locating a turned sample point
 * in the grid is most of the cost, and which cell holds it depends on the geometry only: since
 * the rings do not interact, each ring is taken from the first gather to the last measurement in
 * one go, for every matrix of the call, while tables keep the cells of its sample points (2
 * point sets a cell, gather and expansion, instead of 2 refine + 3 evaluations per matrix).  The
 * rings are shared among threads.  None of this changes an operation or its order: the results
 * are those of sweeping the whole quadrant pass after pass, bit for bit (tests/test_rank3.c). */
#include <config.h>

#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <string.h>
#include <unistd.h>

#include "basis.h"
#include "ctx.h"
#include "mat.h"
#include "ttree_write.h"

/* Matrix element M(o, i) whatever the structure. */
struct macc {
    const bst_mat *m;
    const double *d;
    const float *f;
    size_t n;
};

static void macc_init(struct macc *a, const bst_mat *m)
{
    a->m = m;
    a->n = m->rows;
    a->d = NULL;
    a->f = NULL;
    if (m->s == BST_DENSE) {
        if (m->prec == BST_DOUBLE)
            a->d = m->dense;
        else
            a->f = m->dense;
    }
}

static inline double mget(const struct macc *a, size_t o, size_t i)
{
    if (a->d)
        return a->d[o + a->n * i];
    if (a->f)
        return a->f[o + a->n * i];
    return bst_mat_get(a->m, o, i);
}

/* One matrix: its rank-3 tensor, and per ring the FA and hemispherical change of each iterate. */
struct job {
    struct macc a;
    double *t3;         /* the result; each ring's row is its worker's current iterate */
    double *fa, *hemi;  /* (refine + 1) x half: ring j's iterate it at [it half + j] */
    int *last;          /* half: the iterate ring j's row holds, -1: to run (again) */
    int bound;          /* no ring goes past this iterate (lowered when one falls below fa_stop) */
    double below;       /* the least FA measured below fa_stop, else NaN */
};

struct r3 {
    bst_ctx *ctx;
    size_t G, N, half, si, so;
    size_t nb_max;      /* boundary points a table may hold */
    int refine;
    double fa_stop;
    int give_up;        /* a ring below fa_stop stops every matrix (abandoned is then set) */
    int abandoned;
    double *in, *out;   /* (radius, azimuth) of the incident and outgoing sample points */
    uint32_t *turn;     /* N: bsti_sc_turn(c, 1, G) of every cell c */
    struct job *jobs;
    size_t njobs;
    pthread_mutex_t lock;
    size_t next_ring;   /* rings handed out so far, largest first */
    size_t done, total; /* incident cells x matrices finished and to do, for the progress */
    struct r3w *first;  /* the caller's worker */
};

/* A worker's buffers: all allocated by the caller, so that workers never use the context. */
struct r3w {
    struct r3 *w;
    double *s, *row;    /* rotation sum of a column, the ring's row: N values and the values
                           at a table's boundary points (TAB_LIMIT in all) */
    double *e, *next;   /* N values each: expansion, next row */
    uint16_t *tab_base, *tab_end; /* room for the sample-to-cell tables of the ring worked on */
    uint16_t *tab, *tab_top; /* free room: entries go up from tab (NULL: no more room in this
                                ring), boundary lists down from tab_top */
    struct tab *gat, *exp; /* per cell of the ring: its gather and its expansion table */
    pthread_t thread;
    int started;
};

/* A sample-to-cell table lists, for every sample point of a pass in the order the pass visits
 * them, one entry: the grid cell holding the point (a value < N), or N + r when the point lies on
 * a boundary, r counting those points in the table.  Point r's cells (n of them, where they meet)
 * are kept apart, in the boundary list; before a table is read back the value at each such point
 * (the mean of its cells, summed in their order) is put after the N values of the grid, so that
 * every entry is one index: no branch, no wait on the previous entry.  A worker's room holds the
 * entries from its start upwards and the boundary lists from its end downwards.  Entries fit in
 * 16 bits while N + r < 65536: N <= 4^BST_K_MAX = 16384, and a table with more boundary points
 * than that leaves is not kept. */
#define TAB_LIMIT 65536u
_Static_assert(((size_t)1 << (2 * BST_K_MAX)) < TAB_LIMIT, "grid cells must fit in table entries");
#define SO (BSTI_TT3_OUT_SAMPLES * BSTI_TT3_OUT_SAMPLES) /* entries per outgoing cell */

struct tab {
    const uint16_t *cell; /* the entries, NULL: not kept */
    const uint16_t *side; /* end of its boundary lists (read downwards: the cells, then n) */
    size_t nb;            /* boundary points */
};

/* Where a pass takes the cells of its sample points: read back (get), or evaluated and, while
 * put is set, recorded (nb boundary points so far, at most nb_max, their lists down from side,
 * not below low).  full: the worker's room ran out (else a table given up on had more boundary
 * points than its entries can name, and the room stays for the ring's other tables). */
struct cursor {
    const uint16_t *get;
    uint16_t *put, *side, *low;
    size_t N, nb, nb_max;
    int full;
};

/* Value of the grid v (G x G cells) at the direction with disk radius rho and azimuth psi
 * (radians); on a cell boundary the mean of the cells that meet there, as the reader does. */
static inline double polar_value(const double *v, double rho, double psi, size_t G, struct cursor *cu)
{
    size_t cells[4];
    int n = bsti_sc_polar_cells(rho, psi, G, cells);
    if (cu->put) {
        if (n == 1) {
            *cu->put++ = (uint16_t)cells[0];
        } else if (cu->side - cu->low < n + 1) {
            cu->put = NULL, cu->full = 1; /* no room */
        } else if (cu->nb >= cu->nb_max) {
            cu->put = NULL; /* this table is not kept */
        } else {
            *cu->put++ = (uint16_t)(cu->N + cu->nb++);
            cu->side -= n + 1;
            for (int j = 0; j < n; j++)
                cu->side[j] = (uint16_t)cells[j];
            cu->side[n] = (uint16_t)n;
        }
    }
    if (n == 1)
        return v[cells[0]];
    double sum = 0.0;
    for (int j = 0; j < n; j++)
        sum += v[cells[j]];
    return sum / n;
}

/* v[N + r] = the value at table t's boundary point r, from the grid values v[0 .. N). */
static void boundary_values(double *v, size_t N, const struct tab *t)
{
    const uint16_t *p = t->side;
    for (size_t r = 0; r < t->nb; r++) {
        int n = p[-1];
        p -= n + 1;
        double sum = 0.0;
        for (int j = 0; j < n; j++)
            sum += v[p[j]];
        v[N + r] = sum / n;
    }
}

/* acc[q] += the sum, in table order, of v at the SO points of each of n outgoing cells listed
 * from `get` on; returns where the next cells' entries start. */
static const uint16_t *replay(const double *v, const uint16_t *get, double *restrict acc, size_t n)
{
    for (size_t q = 0; q < n; q++, get += SO) {
        double sum = 0.0;
        for (size_t t = 0; t < SO; t++)
            sum += v[get[t]];
        acc[q] += sum;
    }
    return get;
}

/* The c-th (0 <= c <= 2 j) incident cell of ring j in the quadrant cx, cy >= G/2, in the order
 * (cx, cy) of the grid: (half + c, half + j) for c < j, then (half + j, half + c - j). */
static inline size_t ring_cell(size_t j, size_t c, size_t half, size_t G)
{
    return c < j ? (half + c) * G + half + j : (half + j) * G + half + (c - j);
}

static int check_args(bst_ctx *ctx, const bst_mat *m, int k)
{
    if (!m || k < 1 || k > BST_K_MAX || m->rows != ((size_t)1 << (2 * k)) || m->cols != m->rows)
        return bsti_error(ctx, BST_ESIZE, "rank-3 tree: the matrix is not %s of order %d",
                          "a Shirley-Chiu component", k);
    return BST_OK;
}

/* A pass's cursor over table *t of `len` entries: read it back when kept, else build it while
 * there is room. */
static void cursor_open(const struct r3w *x, const struct tab *t, size_t len, struct cursor *cu)
{
    cu->get = t->cell;
    cu->put = NULL;
    cu->N = x->w->N, cu->nb = 0, cu->nb_max = x->w->nb_max;
    cu->full = !t->cell && x->tab && (size_t)(x->tab_top - x->tab) < len;
    if (!t->cell && x->tab && !cu->full) {
        cu->put = x->tab;
        cu->side = x->tab_top;
        cu->low = x->tab + len;
    }
}

static void cursor_close(struct r3w *x, struct tab *t, struct cursor *cu)
{
    if (cu->get)
        return;
    if (cu->put) {
        t->cell = x->tab, t->side = x->tab_top, t->nb = cu->nb;
        x->tab = cu->put, x->tab_top = cu->side;
    } else if (cu->full) {
        x->tab = NULL; /* no room: the ring's other passes evaluate their points */
    }
    /* else too many boundary points (the corner cell of a ring at k = 7: a quarter of its 36 N
     * points, against at most 65536 - N): that cell's passes evaluate theirs, the others keep
     * tables in the same room */
}

/* t3 row of ring j gathers S (x->s: the four rotated columns of incident cell i summed) along
 * the sample points of every rank-3 outgoing cell turned into the world frame. */
static void gather(const struct r3w *x, size_t i, const struct tab *t, double *row, struct cursor *cu)
{
    const struct r3 *w = x->w;
    size_t N = w->N, so = w->so;
    if (cu->get)
        boundary_values(x->s, N, t);
    for (size_t s = 0; s < w->si; s++) {
        double phi = w->in[2 * (i * w->si + s) + 1];
        if (cu->get) {
            cu->get = replay(x->s, cu->get, row, N);
            continue;
        }
        for (size_t q = 0; q < N; q++) {
            double sum = 0.0;
            for (size_t t = 0; t < so; t++) {
                const double *p = w->out + 2 * (q * so + t);
                sum += polar_value(x->s, p[0], p[1] + phi, w->G, cu);
            }
            row[q] += sum;
        }
    }
}

/* Column i of the grid expansion of t3 (its ring's row in x->row), as the reader computes it: the
 * average over the sample points of incident cell i and of each outgoing cell, turned into the
 * rotated frame. */
static void expand(const struct r3w *x, size_t i, const struct tab *t, struct cursor *cu)
{
    const struct r3 *w = x->w;
    size_t N = w->N, so = w->so;
    memset(x->e, 0, N * sizeof *x->e);
    if (cu->get)
        boundary_values(x->row, N, t);
    for (size_t s = 0; s < w->si; s++) {
        double phi = w->in[2 * (i * w->si + s) + 1];
        if (cu->get) {
            cu->get = replay(x->row, cu->get, x->e, N);
            continue;
        }
        for (size_t o = 0; o < N; o++) {
            double sum = 0.0;
            for (size_t t = 0; t < so; t++) {
                const double *p = w->out + 2 * (o * so + t);
                sum += polar_value(x->row, p[0], p[1] - phi, w->G, cu);
            }
            x->e[o] += sum;
        }
    }
    for (size_t o = 0; o < N; o++)
        x->e[o] /= (double)(w->si * w->so);
}

/* Ring j of one matrix from start to end: its row of t3 is the gathered matrix, then up to
 * `refine` times the row plus the gathered residual (matrix - expansion of the row); every
 * iterate it is measured into fa and hemi.  The rings do not interact: a row is gathered from,
 * and expanded into, the incident cells of its own ring only.  A ring whose FA falls below
 * fa_stop stops there and keeps the other rings from going further (a matrix that is not
 * isotropic costs little). */
static void ring_job(struct r3w *x, size_t j, struct job *jb)
{
    struct r3 *w = x->w;
    size_t G = w->G, N = w->N, half = w->half, nc = 2 * j + 1;
    double *cur = jb->t3 + (half - 1 - j) * N, *next = x->next, lam = M_PI / (double)N;
    double wt = 1.0 / ((double)(8 * j + 4) * (double)(w->si * w->so)); /* 8j+4 cells */
    size_t len = w->si * w->so * N; /* entries of a table */
    for (int it = -1;; it++) {
        pthread_mutex_lock(&w->lock);
        int bound = jb->bound, abandoned = w->abandoned;
        pthread_mutex_unlock(&w->lock);
        if (abandoned)
            return;
        int measure = it >= 0, accumulate = it < bound; /* the last iterate is only measured */
        double worst_fa = 100.0, worst_h = 0.0;
        struct cursor cu;
        if (accumulate)
            memset(next, 0, N * sizeof *next);
        if (measure)
            memcpy(x->row, cur, N * sizeof *cur);
        for (size_t c = 0; c < nc; c++) {
            size_t i = ring_cell(j, c, half, G);
            size_t ri[4] = {i, bsti_sc_turn(i, 1, G), bsti_sc_turn(i, 2, G), bsti_sc_turn(i, 3, G)};
            if (measure) {
                cursor_open(x, &x->exp[c], len, &cu);
                expand(x, i, &x->exp[c], &cu);
                cursor_close(x, &x->exp[c], &cu);
            }
            /* S(o) = the four turned columns summed, less the expansion: E(R o, R i) = E(o, i) */
            const struct macc *a = &jb->a;
            const uint32_t *turn = w->turn;
            if (!measure) {
                for (size_t o = 0; o < N; o++) {
                    size_t o1 = turn[o], o2 = turn[o1], o3 = turn[o2];
                    x->s[o] = 0.0 + mget(a, o, ri[0]) + mget(a, o1, ri[1]) + mget(a, o2, ri[2]) +
                              mget(a, o3, ri[3]);
                }
            } else {
                double d0 = 0.0, d1 = 0.0, d2 = 0.0, d3 = 0.0, s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
                double h0 = 0.0, h1 = 0.0, h2 = 0.0, h3 = 0.0;
                for (size_t o = 0; o < N; o++) {
                    size_t o1 = turn[o], o2 = turn[o1], o3 = turn[o2];
                    double v0 = mget(a, o, ri[0]), v1 = mget(a, o1, ri[1]);
                    double v2 = mget(a, o2, ri[2]), v3 = mget(a, o3, ri[3]), y = x->e[o];
                    d0 += fabs(v0 - y), s0 += fabs(v0) + fabs(y), h0 += v0 - y;
                    d1 += fabs(v1 - y), s1 += fabs(v1) + fabs(y), h1 += v1 - y;
                    d2 += fabs(v2 - y), s2 += fabs(v2) + fabs(y), h2 += v2 - y;
                    d3 += fabs(v3 - y), s3 += fabs(v3) + fabs(y), h3 += v3 - y;
                    x->s[o] = 0.0 + v0 + v1 + v2 + v3 - 4.0 * y;
                }
                double diff[4] = {d0, d1, d2, d3}, sum[4] = {s0, s1, s2, s3}, dh[4] = {h0, h1, h2, h3};
                for (int r = 0; r < 4; r++) {
                    worst_fa = fmin(worst_fa, sum[r] > 0.0 ? 100.0 * (1.0 - diff[r] / sum[r]) : 100.0);
                    worst_h = fmax(worst_h, fabs(dh[r]) * lam);
                }
            }
            if (accumulate) {
                cursor_open(x, &x->gat[c], len, &cu);
                gather(x, i, &x->gat[c], next, &cu);
                cursor_close(x, &x->gat[c], &cu);
            }
        }
        if (measure) {
            jb->fa[(size_t)it * half + j] = worst_fa;
            jb->hemi[(size_t)it * half + j] = worst_h;
            if (worst_fa < w->fa_stop) {
                pthread_mutex_lock(&w->lock);
                if (it < jb->bound)
                    jb->bound = it;
                if (!(jb->below <= worst_fa))
                    jb->below = worst_fa;
                w->abandoned |= w->give_up;
                pthread_mutex_unlock(&w->lock);
                accumulate = 0;
            }
        }
        if (!accumulate) {
            jb->last[j] = it;
            return;
        }
        for (size_t q = 0; q < N; q++) {
            cur[q] = next[q] * wt + (measure ? cur[q] : 0.0);
            if (cur[q] < 0.0)
                cur[q] = 0.0; /* a BSDF is not negative */
        }
    }
}

/* Ring j of every matrix that needs it, with the same tables (they depend on the grid only):
 * each cell's sample points are located once and their cells read back by the later passes, the
 * same cells in the same order, so the same sums as evaluating them every time. */
static void ring_run(struct r3w *x, size_t j)
{
    struct r3 *w = x->w;
    x->tab = x->tab_base, x->tab_top = x->tab_end;
    for (size_t c = 0; c < 2 * j + 1; c++)
        x->gat[c].cell = x->exp[c].cell = NULL;
    for (size_t m = 0; m < w->njobs; m++) {
        if (w->jobs[m].last[j] >= 0)
            continue;
        ring_job(x, j, &w->jobs[m]);
        pthread_mutex_lock(&w->lock);
        double f = (double)(w->done += 2 * j + 1) / (double)w->total;
        pthread_mutex_unlock(&w->lock);
        if (x == w->first)
            bsti_progress(w->ctx, f < 1.0 ? f : 1.0, "rank-3 tree");
    }
}

/* A worker takes the rings that are left, largest first; worker 0 (the caller's thread) reports
 * the progress. */
static void *work(void *arg)
{
    struct r3w *x = arg;
    struct r3 *w = x->w;
    for (;;) {
        pthread_mutex_lock(&w->lock);
        size_t n = w->next_ring < w->half && !w->abandoned ? w->next_ring++ : w->half;
        pthread_mutex_unlock(&w->lock);
        if (n == w->half)
            break;
        ring_run(x, w->half - 1 - n);
    }
    return NULL;
}

static void run_rings(struct r3 *w, struct r3w *wk, size_t nw)
{
    w->next_ring = 0;
    /* Where a failing ring gives up on every matrix, the smallest ring goes first, alone: it costs
     * 1/(2 half - 1) of the largest, and a matrix that is not isotropic at every incidence fails
     * there (a pane's specular reflection: Rf of pane + diffuser at k = 7 saved sweeping the
     * outer rings, about 2.5 CPU-s).  The rings do not interact, so the order changes no result;
     * the later pass skips it (its jobs are done). */
    if (w->give_up)
        ring_run(&wk[0], 0);
    for (size_t t = 1; t < nw; t++) /* a thread that cannot start: its share is done by the others */
        wk[t].started = pthread_create(&wk[t].thread, NULL, work, &wk[t]) == 0;
    work(&wk[0]);
    for (size_t t = 1; t < nw; t++)
        if (wk[t].started)
            pthread_join(wk[t].thread, NULL);
}

static size_t worker_count(int threads, size_t half)
{
    size_t n = threads > 0 ? (size_t)threads : 1;
    if (threads <= 0) {
        long cpus = sysconf(_SC_NPROCESSORS_ONLN);
        n = cpus > 1 ? (size_t)cpus : 1;
        if (n > BSTI_TT3_THREADS)
            n = BSTI_TT3_THREADS;
    }
    return n < half ? n : half;
}

int bsti_tt3_from_sc(bst_ctx *ctx, const bst_mat *m, int k, int refine, double fa_stop,
                     double *t3, double *fa_min, double *hemi_max)
{
    bsti_tt3_job jb = {m, t3, 0.0, 0.0};
    int rc = bsti_tt3_build(ctx, k, refine, fa_stop, 0, 0, BSTI_TT3_TABLE_BYTES, 0, 1, &jb);
    *fa_min = jb.fa_min, *hemi_max = jb.hemi_max;
    return rc;
}

/* The iterate a matrix returns: the last, or the first whose FA falls below fa_stop; the rings
 * whose row holds another one run again up to it (last = -1).  Returns how many. */
static size_t settle(struct r3 *w, struct job *jb, bsti_tt3_job *out)
{
    int stop = jb->bound;
    for (int it = 0; it < jb->bound; it++) {
        double f = 100.0;
        for (size_t j = 0; j < w->half; j++)
            f = fmin(f, jb->fa[(size_t)it * w->half + j]);
        if (f < w->fa_stop) {
            stop = it;
            break;
        }
    }
    jb->bound = stop;
    out->fa_min = 100.0, out->hemi_max = 0.0;
    size_t again = 0;
    for (size_t j = 0; j < w->half; j++) {
        out->fa_min = fmin(out->fa_min, jb->fa[(size_t)stop * w->half + j]);
        out->hemi_max = fmax(out->hemi_max, jb->hemi[(size_t)stop * w->half + j]);
        if (jb->last[j] != stop)
            jb->last[j] = -1, again += 2 * j + 1;
    }
    return again;
}

int bsti_tt3_build(bst_ctx *ctx, int k, int refine, double fa_stop, int give_up, int threads,
                   size_t table_bytes, size_t boundary_max, size_t njobs, bsti_tt3_job *jobs)
{
    int rc = BST_OK;
    if (njobs == 0)
        return BST_OK;
    for (size_t m = 0; m < njobs && rc >= 0; m++)
        rc = check_args(ctx, jobs[m].m, k);
    if (rc < 0)
        return rc;
    if (refine < 0)
        refine = 0;
    struct r3 w;
    memset(&w, 0, sizeof w);
    w.ctx = ctx;
    w.G = (size_t)1 << k;
    w.N = w.G * w.G;
    w.half = w.G / 2;
    w.nb_max = TAB_LIMIT - w.N;
    if (boundary_max > 0 && boundary_max < w.nb_max)
        w.nb_max = boundary_max;
    w.si = BSTI_TT3_IN_SAMPLES * BSTI_TT3_IN_SAMPLES;
    w.so = BSTI_TT3_OUT_SAMPLES * BSTI_TT3_OUT_SAMPLES;
    w.refine = refine;
    w.fa_stop = fa_stop;
    w.give_up = give_up;
    w.njobs = njobs;
    size_t nw = worker_count(threads, w.half), nc = 2 * w.half - 1;
    /* the tables of the largest ring, with room for points on boundaries, within the budget */
    size_t want = nc * w.si * w.so * w.N * 2, cap = table_bytes / sizeof(uint16_t);
    want += want / 8 + 64;
    if (want < cap)
        cap = want;
    struct r3w *wk = bsti_calloc(ctx, nw, sizeof *wk);
    if (!wk || !(w.jobs = bsti_calloc(ctx, njobs, sizeof *w.jobs)))
        rc = BST_ENOMEM;
    else if ((rc = bsti_sc_cell_points(ctx, w.G, BSTI_TT3_IN_SAMPLES, &w.in)) >= 0 &&
             (rc = bsti_sc_cell_points(ctx, w.G, BSTI_TT3_OUT_SAMPLES, &w.out)) >= 0 &&
             !(w.turn = bsti_alloc_array(ctx, w.N, sizeof *w.turn)))
        rc = BST_ENOMEM;
    for (size_t c = 0; w.turn && c < w.N; c++)
        w.turn[c] = (uint32_t)bsti_sc_turn(c, 1, w.G);
    for (size_t m = 0; rc >= 0 && m < njobs; m++) {
        struct job *jb = &w.jobs[m];
        macc_init(&jb->a, jobs[m].m);
        jb->t3 = jobs[m].t3;
        jb->bound = refine;
        jb->below = NAN;
        if (!(jb->fa = bsti_alloc_array(ctx, ((size_t)refine + 1) * w.half, sizeof *jb->fa)) ||
            !(jb->hemi = bsti_alloc_array(ctx, ((size_t)refine + 1) * w.half, sizeof *jb->hemi)) ||
            !(jb->last = bsti_alloc_array(ctx, w.half, sizeof *jb->last)))
            rc = BST_ENOMEM;
        for (size_t j = 0; jb->last && j < w.half; j++)
            jb->last[j] = -1;
        if (rc >= 0 && jobs[m].m->s == BST_ZERO) { /* nothing to run */
            memset(jb->t3, 0, w.half * w.N * sizeof *jb->t3);
            for (size_t j = 0; j < w.half; j++)
                jb->last[j] = 0, jb->fa[j] = 100.0, jb->hemi[j] = 0.0;
            jb->bound = 0;
        } else {
            w.total += w.half * w.half;
        }
    }
    for (size_t t = 0; rc >= 0 && t < nw; t++) {
        struct r3w *x = &wk[t];
        x->w = &w;
        if (!(x->s = bsti_alloc_array(ctx, TAB_LIMIT, sizeof *x->s)) ||
            !(x->row = bsti_alloc_array(ctx, TAB_LIMIT, sizeof *x->row)) ||
            !(x->e = bsti_alloc_array(ctx, w.N, sizeof *x->e)) ||
            !(x->next = bsti_alloc_array(ctx, w.N, sizeof *x->next)) ||
            !(x->gat = bsti_calloc(ctx, nc, sizeof *x->gat)) ||
            !(x->exp = bsti_calloc(ctx, nc, sizeof *x->exp)) ||
            (cap && !(x->tab_base = bsti_alloc_array(ctx, cap, sizeof *x->tab_base))))
            rc = BST_ENOMEM;
        else
            x->tab_end = cap ? x->tab_base + cap : NULL;
    }
    if (rc >= 0) {
        w.first = &wk[0];
        pthread_mutex_init(&w.lock, NULL);
        run_rings(&w, wk, nw);
        /* a matrix stopped at an iterate (rare: it is then not isotropic) runs again the rings
         * that went further; they stop there, as the bound says */
        size_t again = 0;
        for (size_t m = 0; m < njobs && !w.abandoned; m++)
            again += settle(&w, &w.jobs[m], &jobs[m]);
        for (size_t m = 0; m < njobs && w.abandoned; m++)
            jobs[m].fa_min = w.jobs[m].below, jobs[m].hemi_max = NAN;
        if (again) {
            w.total += again;
            run_rings(&w, wk, nw);
        }
        pthread_mutex_destroy(&w.lock);
    }
    for (size_t t = 0; wk && t < nw; t++) {
        bsti_free(ctx, wk[t].s), bsti_free(ctx, wk[t].e), bsti_free(ctx, wk[t].next);
        bsti_free(ctx, wk[t].row);
        bsti_free(ctx, wk[t].gat), bsti_free(ctx, wk[t].exp), bsti_free(ctx, wk[t].tab_base);
    }
    for (size_t m = 0; w.jobs && m < njobs; m++) {
        bsti_free(ctx, w.jobs[m].fa), bsti_free(ctx, w.jobs[m].hemi);
        bsti_free(ctx, w.jobs[m].last);
    }
    bsti_free(ctx, wk);
    bsti_free(ctx, w.jobs);
    bsti_free(ctx, w.in);
    bsti_free(ctx, w.out);
    bsti_free(ctx, w.turn);
    return rc;
}

/* bsti_tt3_rotation_fa of a FACTORED m, by orbits of the turn: each cell of one quadrant and its
 * three turned images, their columns read once (bsti_cols_visit: by GEMM over a wide map, where
 * each value through the factors costs a row's entries squared, else with bsti_lr_get's bits on
 * the reader's threads), each column compared with the next of its orbit.  NAN when the memory is
 * not there. */
#define ROT_CHUNKS 64
struct rot {
    int k;
    size_t G, N;
    double stop, worst[ROT_CHUNKS]; /* the least FA of each chunk of orbits */
};

static int rot_orbit(void *opaque, size_t chunk, size_t u, const double *buf, const double *none)
{
    struct rot *r = opaque;
    size_t G = r->G, N = r->N;
    int k = r->k;
    (void)u, (void)none;
    for (int t = 0; t < 4; t++) {
        const double *x = buf + (size_t)t * N, *y = buf + (size_t)((t + 1) % 4) * N;
        double diff = 0.0, sum = 0.0;
        for (size_t o = 0; o < N; o++) {
            size_t ro = ((G - 1 - (o & (G - 1))) << k) | (o >> k); /* bsti_sc_turn(o, 1, G) */
            diff += fabs(x[o] - y[ro]);
            sum += fabs(x[o]) + fabs(y[ro]);
        }
        if (sum > 0.0)
            r->worst[chunk] = fmin(r->worst[chunk], 100.0 * (1.0 - diff / sum));
    }
    return r->worst[chunk] < r->stop;
}

static double rotation_fa_cols(const bst_mat *m, int k, double stop)
{
    size_t G = (size_t)1 << k, N = G * G, h = G / 2, quarter = h * h;
    struct rot r = {k, G, N, stop, {0}};
    bsti_cols *c = NULL;
    size_t *idx = bsti_alloc_array(m->ctx, 4 * quarter, sizeof *idx);
    int rc = idx ? bsti_cols_new(m->ctx, m, N, &c) : BST_ENOMEM;
    for (size_t q = 0; idx && q < quarter; q++) {
        size_t i = (q / h) * G + q % h; /* cell (X, Y), X, Y < G / 2 */
        for (int turn = 0; turn < 4; turn++, i = bsti_sc_turn(i, 1, G))
            idx[4 * q + (size_t)turn] = i;
    }
    for (size_t q = 0; q < ROT_CHUNKS; q++)
        r.worst[q] = 100.0;
    if (rc >= 0)
        rc = bsti_cols_visit(c, idx, NULL, NULL, quarter, 4, ROT_CHUNKS, rot_orbit, &r);
    double worst = 100.0;
    for (size_t q = 0; q < ROT_CHUNKS; q++)
        worst = fmin(worst, r.worst[q]);
    bsti_cols_free(c);
    bsti_free(m->ctx, idx);
    return rc < 0 ? NAN : worst;
}

double bsti_tt3_rotation_fa(const bst_mat *m, int k, double stop)
{
    size_t G = (size_t)1 << k, N = G * G;
    if (!m || m->s == BST_ZERO || m->rows != N)
        return 100.0;
    if ((m->s == BST_FACTORED || m->s == BST_PLUS_LR) && k > 0) {
        double fa = rotation_fa_cols(m, k, stop);
        if (!isnan(fa))
            return fa;
    }
    struct macc a;
    macc_init(&a, m);
    double worst = 100.0;
    for (size_t i = 0; i < N; i++) {
        size_t ri = bsti_sc_turn(i, 1, G);
        double diff = 0.0, sum = 0.0;
        for (size_t o = 0; o < N; o++) {
            size_t ro = ((G - 1 - (o & (G - 1))) << k) | (o >> k); /* bsti_sc_turn(o, 1, G) */
            double x = mget(&a, o, i), y = mget(&a, ro, ri);
            diff += fabs(x - y);
            sum += fabs(x) + fabs(y);
        }
        if (sum > 0.0)
            worst = fmin(worst, 100.0 * (1.0 - diff / sum));
        if (worst < stop)
            break;
    }
    return worst;
}
