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
 * (radius, azimuth) so that rotating a direction is an addition. */
#include <config.h>

#include <math.h>
#include <string.h>

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

/* Value of the grid v (G x G cells) at the direction with disk radius rho and azimuth psi
 * (radians); on a cell boundary the mean of the cells that meet there, as the reader does. */
static inline double polar_value(const double *v, double rho, double psi, size_t G)
{
    size_t cells[4];
    int n = bsti_sc_polar_cells(rho, psi, G, cells);
    if (n == 1)
        return v[cells[0]];
    double sum = 0.0;
    for (int j = 0; j < n; j++)
        sum += v[cells[j]];
    return sum / n;
}

/* Ring of a grid cell: j = max(|2 cx + 1 - G|, |2 cy + 1 - G|) / 2 (integer). */
static inline size_t ring(size_t c, size_t G)
{
    long cx = (long)(c / G), cy = (long)(c % G), g = (long)G;
    long a = labs(2 * cx + 1 - g), b = labs(2 * cy + 1 - g);
    return (size_t)((a > b ? a : b) / 2);
}

static int check_args(bst_ctx *ctx, const bst_mat *m, int k)
{
    if (!m || k < 1 || k > BST_K_MAX || m->rows != ((size_t)1 << (2 * k)) || m->cols != m->rows)
        return bsti_error(ctx, BST_ESIZE, "rank-3 tree: the matrix is not %s of order %d",
                          "a Shirley-Chiu component", k);
    return BST_OK;
}

struct r3 {
    bst_ctx *ctx;
    struct macc a;
    size_t G, N, half, si, so;
    double *in, *out; /* (radius, azimuth) of the incident and outgoing sample points */
    double *s, *e;    /* N values each: rotation sum of a column, expansion of t3 */
};

/* t3 row of ring j gathers S (the four rotated columns of incident cell i summed) along the
 * sample points of every rank-3 outgoing cell turned into the world frame. */
static void gather(const struct r3 *w, size_t i, double *row)
{
    for (size_t s = 0; s < w->si; s++) {
        double phi = w->in[2 * (i * w->si + s) + 1];
        for (size_t q = 0; q < w->N; q++) {
            double sum = 0.0;
            for (size_t t = 0; t < w->so; t++) {
                const double *p = w->out + 2 * (q * w->so + t);
                sum += polar_value(w->s, p[0], p[1] + phi, w->G);
            }
            row[q] += sum;
        }
    }
}

/* Column i of the grid expansion of t3, as the reader computes it: the average over the sample
 * points of incident cell i and of each outgoing cell, turned into the rotated frame. */
static void expand(const struct r3 *w, size_t i, const double *row)
{
    memset(w->e, 0, w->N * sizeof *w->e);
    for (size_t s = 0; s < w->si; s++) {
        double phi = w->in[2 * (i * w->si + s) + 1];
        for (size_t o = 0; o < w->N; o++) {
            double sum = 0.0;
            for (size_t t = 0; t < w->so; t++) {
                const double *p = w->out + 2 * (o * w->so + t);
                sum += polar_value(row, p[0], p[1] - phi, w->G);
            }
            w->e[o] += sum;
        }
    }
    for (size_t o = 0; o < w->N; o++)
        w->e[o] /= (double)(w->si * w->so);
}

/* One pass over the incident cells of the quadrant cx, cy >= G/2 (one of each 90-degree orbit).
 * With cur == NULL: next = the gathered matrix.  Otherwise next = cur + gathered residual
 * (matrix - expansion of cur), and *fa_min, *hemi_max describe cur. */
static void sweep(struct r3 *w, const double *cur, double *next, double *fa_min, double *hemi_max,
                  const char *label)
{
    size_t G = w->G, N = w->N, half = w->half, done = 0;
    double worst_fa = 100.0, worst_h = 0.0, lam = M_PI / (double)N;
    memset(next, 0, half * N * sizeof *next);
    for (size_t cx = half; cx < G; cx++)
        for (size_t cy = half; cy < G; cy++) {
            size_t i = cx * G + cy, j = ring(i, G);
            size_t ri[4] = {i, bsti_sc_turn(i, 1, G), bsti_sc_turn(i, 2, G), bsti_sc_turn(i, 3, G)};
            if (cur)
                expand(w, i, cur + (half - 1 - j) * N);
            double diff[4] = {0}, sum[4] = {0}, dh[4] = {0};
            for (size_t o = 0; o < N; o++) {
                size_t oo = o;
                w->s[o] = 0.0;
                for (int r = 0; r < 4; r++, oo = bsti_sc_turn(oo, 1, G)) {
                    double x = mget(&w->a, oo, ri[r]);
                    w->s[o] += x;
                    if (cur) { /* E(R o, R i) = E(o, i) */
                        double y = w->e[o];
                        diff[r] += fabs(x - y), sum[r] += fabs(x) + fabs(y), dh[r] += x - y;
                    }
                }
                if (cur)
                    w->s[o] -= 4.0 * w->e[o];
            }
            for (int r = 0; cur && r < 4; r++) {
                worst_fa = fmin(worst_fa, sum[r] > 0.0 ? 100.0 * (1.0 - diff[r] / sum[r]) : 100.0);
                worst_h = fmax(worst_h, fabs(dh[r]) * lam);
            }
            gather(w, i, next + (half - 1 - j) * N);
            if (++done % 16 == 0)
                bsti_progress(w->ctx, (double)done / (double)(half * half), label);
        }
    for (size_t j = 0; j < half; j++) {
        double wt = 1.0 / ((double)(8 * j + 4) * (double)(w->si * w->so)); /* 8j+4 cells */
        double *row = next + (half - 1 - j) * N;
        const double *c = cur ? cur + (half - 1 - j) * N : NULL;
        for (size_t q = 0; q < N; q++) {
            row[q] = row[q] * wt + (c ? c[q] : 0.0);
            if (row[q] < 0.0)
                row[q] = 0.0; /* a BSDF is not negative */
        }
    }
    if (fa_min)
        *fa_min = worst_fa, *hemi_max = worst_h;
}

int bsti_tt3_from_sc(bst_ctx *ctx, const bst_mat *m, int k, int refine, double fa_stop,
                     double *t3, double *fa_min, double *hemi_max)
{
    int rc = check_args(ctx, m, k);
    if (rc < 0)
        return rc;
    struct r3 w;
    memset(&w, 0, sizeof w);
    w.ctx = ctx;
    w.G = (size_t)1 << k;
    w.N = w.G * w.G;
    w.half = w.G / 2;
    w.si = BSTI_TT3_IN_SAMPLES * BSTI_TT3_IN_SAMPLES;
    w.so = BSTI_TT3_OUT_SAMPLES * BSTI_TT3_OUT_SAMPLES;
    macc_init(&w.a, m);
    if (m->s == BST_ZERO) {
        memset(t3, 0, w.half * w.N * sizeof *t3);
        *fa_min = 100.0, *hemi_max = 0.0;
        return BST_OK;
    }
    double *tmp = NULL;
    if ((rc = bsti_sc_cell_points(ctx, w.G, BSTI_TT3_IN_SAMPLES, &w.in)) < 0 ||
        (rc = bsti_sc_cell_points(ctx, w.G, BSTI_TT3_OUT_SAMPLES, &w.out)) < 0 ||
        !(w.s = bsti_alloc_array(ctx, w.N, sizeof *w.s)) ||
        !(w.e = bsti_alloc_array(ctx, w.N, sizeof *w.e)) ||
        !(tmp = bsti_alloc_array(ctx, w.half * w.N, sizeof *tmp))) {
        rc = rc < 0 ? rc : BST_ENOMEM;
    } else {
        /* every sweep measures the current tensor and forms the corrected one; the last
         * correction is not kept, so what is measured is what is returned */
        sweep(&w, NULL, t3, NULL, NULL, "rank-3 tree");
        for (int it = 0; it <= refine; it++) {
            sweep(&w, t3, tmp, fa_min, hemi_max, it ? "rank-3 tree: refining" : "isotropy check");
            if (it == refine || *fa_min < fa_stop)
                break;
            memcpy(t3, tmp, w.half * w.N * sizeof *t3);
        }
    }
    bsti_free(ctx, tmp);
    bsti_free(ctx, w.in);
    bsti_free(ctx, w.out);
    bsti_free(ctx, w.s);
    bsti_free(ctx, w.e);
    return rc;
}

double bsti_tt3_rotation_fa(const bst_mat *m, int k)
{
    size_t G = (size_t)1 << k, N = G * G;
    if (!m || m->s == BST_ZERO || m->rows != N)
        return 100.0;
    struct macc a;
    macc_init(&a, m);
    double worst = 100.0;
    for (size_t i = 0; i < N; i++) {
        size_t ri = bsti_sc_turn(i, 1, G);
        double diff = 0.0, sum = 0.0;
        for (size_t o = 0; o < N; o++) {
            double x = mget(&a, o, i), y = mget(&a, bsti_sc_turn(o, 1, G), ri);
            diff += fabs(x - y);
            sum += fabs(x) + fabs(y);
        }
        if (sum > 0.0)
            worst = fmin(worst, 100.0 * (1.0 - diff / sum));
    }
    return worst;
}
