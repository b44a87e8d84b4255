/* overlap.c - the exact overlap of Shirley-Chiu cells with Klems patches (bsti_overlap,
 * resample.h), and the two moves it serves: a Klems matrix onto the grid (M = W K W^T) and a grid
 * matrix onto Klems patches.  Both use the one table, so light is neither lost nor made where a
 * patch boundary cuts a cell.  Conventions: resample.h, basis.h. */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "basis.h"
#include "ctx.h"
#include "resample.h"

/* Exact overlap of Shirley-Chiu cells and Klems patches.  The concentric map preserves area and
 * sends a circle sin(theta) = r to the square ring max(|a|, |b|) = r and, inside each of its four
 * wedges, an azimuth to a ray through the centre ((a, b) = 2 (sx, sy) - 1; in wedge w, turned by
 * -w 90 degrees into (u, v): u = r, v = r (phi - w pi/2) / (pi/4)).  So the part of a Klems patch
 * inside a wedge is the trapezoid r0 <= u <= r1, t0 u <= v <= t1 u, and its overlap with a cell
 * (an axis-parallel square) is a convex polygon clip. */
struct kpiece {
    size_t patch;
    int wedge;
    double r0, r1, t0, t1;
};

/* Clip the polygon (x[i], y[i]), n vertices, by alpha x + beta y + gamma >= 0. */
static int clip(double *x, double *y, int n, double alpha, double beta, double gamma)
{
    double ox[16], oy[16];
    int m = 0;
    for (int i = 0; i < n; i++) {
        int j = (i + 1) % n;
        double di = alpha * x[i] + beta * y[i] + gamma, dj = alpha * x[j] + beta * y[j] + gamma;
        if (di >= 0)
            ox[m] = x[i], oy[m++] = y[i];
        if ((di >= 0) != (dj >= 0) && m < 16) {
            double t = di / (di - dj);
            ox[m] = x[i] + t * (x[j] - x[i]), oy[m++] = y[i] + t * (y[j] - y[i]);
        }
    }
    memcpy(x, ox, (size_t)m * sizeof *x);
    memcpy(y, oy, (size_t)m * sizeof *y);
    return m;
}

/* Area (in (a, b) units) of cell [a0, a1] x [b0, b1] inside piece pc. */
static double piece_overlap(const struct kpiece *pc, double a0, double a1, double b0, double b1)
{
    double ca[4] = {a0, a1, a1, a0}, cb[4] = {b0, b0, b1, b1}, x[16], y[16];
    for (int i = 0; i < 4; i++) {
        double a = ca[i], b = cb[i];
        switch (pc->wedge) { /* turn by -w 90 degrees */
        case 0: x[i] = a, y[i] = b; break;
        case 1: x[i] = b, y[i] = -a; break;
        case 2: x[i] = -a, y[i] = -b; break;
        default: x[i] = -b, y[i] = a; break;
        }
    }
    int n = 4;
    double umin = fmin(fmin(x[0], x[1]), fmin(x[2], x[3])), umax = fmax(fmax(x[0], x[1]), fmax(x[2], x[3]));
    if (umax <= pc->r0 || umin >= pc->r1)
        return 0.0;
    n = clip(x, y, n, 1, 0, -pc->r0);
    if (n)
        n = clip(x, y, n, -1, 0, pc->r1);
    if (n)
        n = clip(x, y, n, -pc->t0, 1, 0);
    if (n)
        n = clip(x, y, n, pc->t1, -1, 0);
    double area = 0.0;
    for (int i = 0; i < n; i++) {
        int j = (i + 1) % n;
        area += x[i] * y[j] - x[j] * y[i];
    }
    return fabs(area) / 2;
}


/* The trapezoids of every patch of kb: at most 4 per patch (a patch spanning all azimuths). */
static size_t klems_pieces(const bst_basis *kb, struct kpiece *pc)
{
    size_t np = 0;
    for (size_t band = 0; band < kb->nbands; band++) {
        int n = kb->nphi[band];
        double r0 = sin(kb->theta[band] * M_PI / 180), r1 = sin(kb->theta[band + 1] * M_PI / 180);
        for (int j = 0; j < n; j++) {
            double lo = 2 * M_PI * (j - 0.5) / n, hi = 2 * M_PI * (j + 0.5) / n;
            if (n == 1)
                lo = -M_PI / 4, hi = 7 * M_PI / 4;
            for (int w = 0; w < 4; w++)
                for (int shift = -1; shift <= 1; shift++) {
                    double wl = w * M_PI / 2 - M_PI / 4 + shift * 2 * M_PI, wh = wl + M_PI / 2;
                    double a = fmax(lo, wl), b = fmin(hi, wh);
                    if (b - a <= 1e-12)
                        continue;
                    double c = wl + M_PI / 4; /* wedge centre */
                    pc[np++] = (struct kpiece){kb->first[band] + (size_t)j, w, r0, r1,
                                               (a - c) / (M_PI / 4), (b - c) / (M_PI / 4)};
                }
        }
    }
    return np;
}


void bsti_overlap_free(bsti_overlap *ov)
{
    if (!ov)
        return;
    bsti_free(ov->ctx, ov->first), bsti_free(ov->ctx, ov->patch), bsti_free(ov->ctx, ov->w);
    bsti_free(ov->ctx, ov->area), bsti_free(ov->ctx, ov);
}

int bsti_overlap_new(bst_ctx *ctx, int k, const bst_basis *kb, bsti_overlap **out)
{
    *out = NULL;
    if (k < BST_K_MIN || k > BST_K_MAX || !kb || kb->kind != BST_BASIS_KLEMS)
        return bsti_error(ctx, BST_EINVAL, "overlap: needs a Shirley-Chiu order %d..%d and a Klems basis",
                          BST_K_MIN, BST_K_MAX);
    size_t G = (size_t)1 << k, n = G * G, nk = kb->n, maxp = 0;
    for (size_t band = 0; band < kb->nbands; band++)
        maxp += 4 * (size_t)kb->nphi[band];
    bsti_overlap *ov = bsti_calloc(ctx, 1, sizeof *ov);
    struct kpiece *pc = bsti_alloc_array(ctx, maxp, sizeof *pc);
    size_t cap = 2 * n + nk;
    if (ov) {
        ov->ctx = ctx, ov->k = k, ov->n = n, ov->nk = nk;
        ov->first = bsti_alloc_array(ctx, n + 1, sizeof *ov->first);
        ov->patch = bsti_alloc_array(ctx, cap, sizeof *ov->patch);
        ov->w = bsti_alloc_array(ctx, cap, sizeof *ov->w);
        ov->area = bsti_calloc(ctx, nk, sizeof *ov->area);
    }
    if (!ov || !pc || !ov->first || !ov->patch || !ov->w || !ov->area) {
        bsti_free(ctx, pc), bsti_overlap_free(ov);
        return BST_ENOMEM;
    }
    size_t npc = klems_pieces(kb, pc), ne = 0;
    double side = 2.0 / (double)G, cell = side * side;
    for (size_t c = 0; c < n; c++) {
        ov->first[c] = ne;
        double a0 = side * (double)(c / G) - 1, b0 = side * (double)(c % G) - 1;
        for (size_t q = 0; q < npc; q++) {
            double f = piece_overlap(&pc[q], a0, a0 + side, b0, b0 + side) / cell;
            if (f <= 1e-14)
                continue;
            size_t e = ov->first[c];
            while (e < ne && ov->patch[e] != pc[q].patch)
                e++;
            if (e == ne) {
                if (ne == cap) {
                    size_t *np2 = bsti_alloc_array(ctx, 2 * cap, sizeof *np2);
                    double *nw = bsti_alloc_array(ctx, 2 * cap, sizeof *nw);
                    if (!np2 || !nw) {
                        bsti_free(ctx, np2), bsti_free(ctx, nw), bsti_free(ctx, pc), bsti_overlap_free(ov);
                        return BST_ENOMEM;
                    }
                    memcpy(np2, ov->patch, ne * sizeof *np2), memcpy(nw, ov->w, ne * sizeof *nw);
                    bsti_free(ctx, ov->patch), bsti_free(ctx, ov->w);
                    ov->patch = np2, ov->w = nw, cap *= 2;
                }
                ov->patch[ne] = pc[q].patch, ov->w[ne++] = 0.0;
            }
            ov->w[e] += f;
        }
        for (size_t e = ov->first[c]; e < ne; e++)
            ov->area[ov->patch[e]] += ov->w[e];
    }
    ov->first[n] = ne;
    bsti_free(ctx, pc);
    for (size_t p = 0; p < nk; p++)
        if (ov->area[p] == 0.0) {
            bsti_overlap_free(ov);
            return bsti_error(ctx, BST_EBASIS, "Klems patch %zu overlaps no cell of the Shirley-Chiu "
                              "grid of order %d", p, k);
        }
    *out = ov;
    return BST_OK;
}

int bsti_klems_to_sc(bst_ctx *ctx, const bsti_overlap *ov, const double *km, double *m)
{
    size_t n = ov->n, nk = ov->nk;
    const size_t *first = ov->first, *patch = ov->patch;
    const double *w = ov->w;
    double *kw = bsti_alloc_array(ctx, nk, sizeof *kw);
    if (!kw)
        return BST_ENOMEM;
    for (size_t i = 0; i < n; i++) {
        for (size_t q = 0; q < nk; q++) { /* column i of K W^T */
            double s = 0.0;
            for (size_t e = first[i]; e < first[i + 1]; e++)
                s += w[e] * km[q + nk * patch[e]];
            kw[q] = s;
        }
        double *col = m + n * i;
        for (size_t o = 0; o < n; o++) {
            double s = 0.0;
            for (size_t e = first[o]; e < first[o + 1]; e++)
                s += w[e] * kw[patch[e]];
            col[o] = s;
        }
        if (n >= 4096 && (i + 1) % 256 == 0)
            bsti_progress(ctx, (double)(i + 1) / (double)n, "resampling a Klems matrix");
    }
    bsti_free(ctx, kw);
    return BST_OK;
}

int bsti_sc_to_klems(bst_ctx *ctx, const bsti_overlap *ov, const double *m, const bst_basis *kb, double *out)
{
    size_t n = ov->n, nk = ov->nk;
    const size_t *first = ov->first, *patch = ov->patch;
    const double *w = ov->w, *lk = bst_basis_lambda(kb), lsc = M_PI / (double)n;
    double *row = bsti_alloc_array(ctx, nk, sizeof *row);
    if (!row)
        return BST_ENOMEM;
    memset(out, 0, nk * nk * sizeof *out);
    for (size_t i = 0; i < n; i++) {
        memset(row, 0, nk * sizeof *row); /* flux of incident cell i into each outgoing patch */
        const double *col = m + n * i;
        for (size_t o = 0; o < n; o++)
            if (col[o] != 0.0)
                for (size_t e = first[o]; e < first[o + 1]; e++)
                    row[patch[e]] += col[o] * w[e];
        for (size_t e = first[i]; e < first[i + 1]; e++) {
            double wi = w[e] / ov->area[patch[e]];
            double *dst = out + nk * patch[e];
            for (size_t q = 0; q < nk; q++)
                dst[q] += row[q] * wi * lsc / lk[q];
        }
        if (n >= 4096 && (i + 1) % 256 == 0)
            bsti_progress(ctx, (double)(i + 1) / (double)n, "averaging onto Klems patches");
    }
    bsti_free(ctx, row);
    return BST_OK;
}
