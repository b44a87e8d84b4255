/* metrics.c - comparisons of BSDFs: global and local accordance (Grobe 2017, eq. 6-8) and flux
 * accordance of the light scattered for one incident patch or for each (see
 * bst_metrics_accordance in bsdfstack.h), and how far a layer's two transmissions are from
 * reciprocity (bst_metrics_reciprocity).  Hemispherical integrals are in layer.c
 * (bst_layer_hemispherical). */
#include <config.h>

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "layer.h"
#include "mat.h"
#include "write_bound.h"

/* The arguments both entry points share. */
static int check_args(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch, bst_comp c)
{
    if (!bst_basis_equal(a->basis, b->basis))
        return bsti_error(ctx, BST_EBASIS, "accordance: the two BSDFs are in different bases");
    if (ch >= a->nchannels || ch >= b->nchannels || (unsigned)c >= BST_NCOMP)
        return bsti_error(ctx, BST_EINVAL, "accordance: channel or component out of range");
    return BST_OK;
}

/* Element (o, i) of m, 0 for an absent or zero matrix. */
static double element(const bst_mat *m, size_t o, size_t i)
{
    if (!m || m->s == BST_ZERO)
        return 0.0;
    return m->s == BST_DENSE ? bsti_dense_get(m, o, i) : bst_mat_get(m, o, i);
}

/* Column x of m (out[o] = m(o, x), row 0) or its row x (out[y] = m(x, y), row 1), n values, each as
 * element() reads it (a FACTORED m is read through bsti_cols instead). */
static void line_of(const bst_mat *m, int row, size_t x, size_t n, double *out)
{
    for (size_t y = 0; y < n; y++)
        out[y] = row ? element(m, x, y) : element(m, y, x);
}

/* The lines (columns, or rows when row) of a matrix (NULL: zero), a block at a time: a FACTORED
 * one through bsti_cols (its rows as the columns of its transpose: values to rounding), by GEMM
 * over a wide map; any other one line at a time (line_of). */
struct lines {
    const bst_mat *m;
    bst_mat *t;     /* the transpose whose columns are m's rows */
    bsti_cols *c;   /* NULL: line_of */
    int row;
};

static int lines_open(bst_ctx *ctx, const bst_mat *m, int row, size_t n, struct lines *l)
{
    *l = (struct lines){m, NULL, NULL, row};
    if (!m || (m->s != BST_FACTORED && m->s != BST_PLUS_LR))
        return BST_OK;
    int rc = row ? bst_mat_transpose(ctx, m, &l->t) : BST_OK;
    if (rc >= 0)
        rc = bsti_cols_new(ctx, row ? l->t : m, n, &l->c);
    if (rc < 0)
        bst_mat_free(l->t);
    return rc;
}

/* Lines idx[0..nb-1] (idx NULL: x0..x0 + nb - 1) into out (n x nb). */
static void lines_get(struct lines *l, const size_t *idx, size_t x0, size_t nb, size_t n, double *out)
{
    if (l->c) {
        bsti_cols_get(l->c, idx, x0, nb, out);
        return;
    }
    for (size_t s = 0; s < nb; s++)
        line_of(l->m, l->row, idx ? idx[s] : x0 + s, n, out + s * n);
}

static void lines_close(struct lines *l)
{
    bsti_cols_free(l->c);
    bst_mat_free(l->t);
}

/* Lines a block of x and y holds: BSTI_COLS_BYTES of them (at least one) when either is read
 * through bsti_cols, else one (line by line, as before: no more memory). */
static size_t lines_block(size_t n, const struct lines *x, const struct lines *y)
{
    if (!x->c && !y->c)
        return 1;
    size_t nb = BSTI_COLS_BYTES / (n * sizeof(double) + 1);
    return nb < 1 ? 1 : nb > n ? n : nb;
}

/* GA, FA and LA (each may be NULL) of column j of ma and mb (either may be NULL: zero).  Eq. (6)'s
 * DSF = BSDF cos(theta_i) takes the incident direction's cosine, the same for every term of one
 * column, so it cancels in (7) and (8); the terms of (7) are weighted by the outgoing patches'
 * projected solid angles L_i (all equal in Shirley-Chiu bases, where this is the paper's plain
 * sum).  The paper's DSFs are not negative: a negative value (the round-off of a combination
 * where the light is 0, or one in a TSV of columns) counts as 0, as the readers read one; by its
 * magnitude it would score LA 0 against an exact 0. */
static int column(bst_ctx *ctx, const double *xa, const double *xb, const double *lam, size_t n,
                  size_t j, double *ga, double *fa, double *la)
{
    double diff = 0.0, sum = 0.0, d2 = 0.0, s2 = 0.0;
    for (size_t i = 0; i < n; i++) {
        double x = xa[i], y = xb[i];
        if (!isfinite(x) || !isfinite(y))
            return bsti_error(ctx, BST_EINVAL, "accordance: non-finite value for incident patch %zu, "
                              "outgoing patch %zu", j, i);
        x = fmax(x, 0.0), y = fmax(y, 0.0);
        d2 += lam[i] * (x - y) * (x - y), s2 += lam[i] * (x + y) * (x + y);
        diff += lam[i] * fabs(x - y), sum += lam[i] * (x + y);
        if (la)
            la[i] = (x == 0.0 && y == 0.0) ? 100.0 : 100.0 * (1.0 - fabs(x - y) / (x + y));
    }
    if (ga)
        *ga = s2 > 0.0 ? 100.0 * (1.0 - d2 / s2) : 100.0;
    if (fa)
        *fa = sum > 0.0 ? 100.0 * (1.0 - diff / sum) : 100.0;
    return BST_OK;
}

/* Both matrices' columns j0..j0 + nb - 1 (lines(), below) and their GA, FA and LA (la: one column). */
static int columns(bst_ctx *ctx, struct lines *lx, struct lines *ly, const double *lam, size_t n,
                   size_t j0, size_t nb, double *buf, double *ga, double *fa, double *la)
{
    lines_get(lx, NULL, j0, nb, n, buf);
    lines_get(ly, NULL, j0, nb, n, buf + nb * n);
    int rc = BST_OK;
    for (size_t s = 0; s < nb && rc >= 0; s++)
        rc = column(ctx, buf + s * n, buf + (nb + s) * n, lam, n, j0 + s, ga ? ga + s : NULL,
                    fa ? fa + s : NULL, la);
    return rc;
}

int bst_metrics_accordance(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch,
                           bst_comp c, size_t incident, double *ga, double *fa, double *la)
{
    if (!ctx || !a || !b || (!ga && !fa && !la))
        return ctx ? bsti_error(ctx, BST_EINVAL, "accordance: NULL argument") : BST_EINVAL;
    if (incident >= bst_basis_size(a->basis))
        return bsti_error(ctx, BST_EINVAL, "accordance: incident patch %zu out of range", incident);
    int rc = check_args(ctx, a, b, ch, c);
    if (rc < 0)
        return rc;
    size_t n = bst_basis_size(a->basis);
    struct lines ma, mb;
    double *buf = bsti_alloc_array(ctx, 2 * n, sizeof *buf);
    rc = buf ? lines_open(ctx, bst_layer_get(a, ch, c), 0, n, &ma) : BST_ENOMEM;
    if (rc >= 0 && (rc = lines_open(ctx, bst_layer_get(b, ch, c), 0, n, &mb)) < 0)
        lines_close(&ma);
    if (rc >= 0) {
        rc = columns(ctx, &ma, &mb, bst_basis_lambda(a->basis), n, incident, 1, buf, ga, fa, la);
        lines_close(&ma), lines_close(&mb);
    }
    bsti_free(ctx, buf);
    return rc;
}

int bst_metrics_accordance_all(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch,
                               bst_comp c, double *ga, double *fa)
{
    if (!ctx || !a || !b || (!ga && !fa))
        return ctx ? bsti_error(ctx, BST_EINVAL, "accordance: NULL argument") : BST_EINVAL;
    int rc = check_args(ctx, a, b, ch, c);
    if (rc < 0)
        return rc;
    size_t n = bst_basis_size(a->basis), nb = 1;
    struct lines ma, mb;
    rc = lines_open(ctx, bst_layer_get(a, ch, c), 0, n, &ma);
    if (rc >= 0 && (rc = lines_open(ctx, bst_layer_get(b, ch, c), 0, n, &mb)) < 0)
        lines_close(&ma);
    if (rc >= 0)
        nb = lines_block(n, &ma, &mb);
    double *buf = rc >= 0 ? bsti_alloc_array(ctx, 2 * nb * n, sizeof *buf) : NULL;
    if (rc >= 0 && !buf) {
        lines_close(&ma), lines_close(&mb);
        rc = BST_ENOMEM;
    }
    int open = rc >= 0;
    for (size_t j0 = 0; rc >= 0 && j0 < n; j0 += nb) {
        size_t k = n - j0 < nb ? n - j0 : nb;
        rc = columns(ctx, &ma, &mb, bst_basis_lambda(a->basis), n, j0, k, buf, ga ? ga + j0 : NULL,
                     fa ? fa + j0 : NULL, NULL);
    }
    if (open)
        lines_close(&ma), lines_close(&mb);
    bsti_free(ctx, buf);
    return rc;
}

/* ------------------------------------------------------------------ reciprocity */

/* Side of the square tiles the dense check walks: two tiles (one of each matrix, 64 KiB in double)
 * stay in the cache while the tile of Tb is read across its columns. */
#define RECIP_TILE 64

static inline double dense_at(const bst_mat *m, size_t k)
{
    return m->prec == BST_DOUBLE ? ((const double *)m->dense)[k] : (double)((const float *)m->dense)[k];
}

/* One run of Tf's columns [i0, i1) of the dense check below: its largest difference and its place,
 * its largest |value| and its NaN probe. */
struct recip_part {
    const bst_mat *tf, *tb;
    const size_t *a;
    size_t n, i0, i1, bi, bo;
    double w, s, nan_probe;
};

/* (d, i, o) beats (w, bi, bo): larger, or as large (not 0) and first in the order (i, then o). */
static inline int recip_beats(double d, size_t i, size_t o, double w, size_t bi, size_t bo)
{
    return d > w || (d == w && d > 0.0 && (i < bi || (i == bi && o < bo)));
}

static void *recip_run(void *opaque)
{
    struct recip_part *p = opaque;
    const bst_mat *tf = p->tf, *tb = p->tb;
    const size_t *a = p->a, n = p->n;
    double w = 0.0, s = 0.0, nan_probe = 0.0;
    size_t bi = 0, bo = 0;
    for (size_t i0 = p->i0; i0 < p->i1; i0 += RECIP_TILE)
        for (size_t o0 = 0; o0 < n; o0 += RECIP_TILE) {
            size_t i1 = i0 + RECIP_TILE < p->i1 ? i0 + RECIP_TILE : p->i1;
            size_t o1 = o0 + RECIP_TILE < n ? o0 + RECIP_TILE : n;
            for (size_t i = i0; i < i1; i++) {
                size_t ai = a[i];
                for (size_t o = o0; o < o1; o++) {
                    double x = dense_at(tf, o + n * i), y = dense_at(tb, ai + n * a[o]);
                    double d = fabs(x - y);
                    nan_probe += x * 0.0 + y * 0.0; /* NaN from then on after an Inf or NaN */
                    s = fabs(x) > s ? fabs(x) : s;
                    s = fabs(y) > s ? fabs(y) : s;
                    if (recip_beats(d, i, o, w, bi, bo))
                        w = d, bi = i, bo = o;
                }
            }
        }
    p->w = w, p->s = s, p->nan_probe = nan_probe, p->bi = bi, p->bo = bo;
    return NULL;
}

/* The largest |Tf(o, i) - Tb(a(i), a(o))| of two dense n x n transmissions, a one-to-one (the
 * pairs then cover every value of both), and the largest |value| of either in *scale; the worst
 * pair is the first in the order of the element-wise loop (i, then o), whatever the runs of
 * columns the threads take.  Returns 0 when a value is not finite. */
static int recip_dense(bst_ctx *ctx, const bst_mat *tf, const bst_mat *tb, const size_t *a,
                       size_t n, double *worst, double *scale, size_t *wi, size_t *wo)
{
    struct recip_part part[BST_THREADS_MAX];
    size_t tiles = (n + RECIP_TILE - 1) / RECIP_TILE;
    size_t t = (size_t)bsti_ctx_workers_no_alloc(ctx, tiles), per = (tiles + t - 1) / t, np = 0;
    for (size_t q = 0; q * per < tiles && np < BST_THREADS_MAX; q++, np++) {
        size_t i1 = (q + 1) * per * RECIP_TILE;
        part[np] = (struct recip_part){tf, tb, a, n, q * per * RECIP_TILE, i1 < n ? i1 : n,
                                       0, 0, 0.0, 0.0, 0.0};
    }
    bsti_run_parts(part, sizeof *part, np, recip_run);
    double w = 0.0, s = 0.0, nan_probe = 0.0;
    size_t bi = 0, bo = 0;
    for (size_t q = 0; q < np; q++) {
        if (recip_beats(part[q].w, part[q].bi, part[q].bo, w, bi, bo))
            w = part[q].w, bi = part[q].bi, bo = part[q].bo;
        s = part[q].s > s ? part[q].s : s;
        nan_probe += part[q].nan_probe;
    }
    *worst = w, *scale = s, *wi = bi, *wo = bo;
    return nan_probe == 0.0;
}

/* The pair (Tf's column i, Tb's row a(i)) of the reciprocity check: the largest difference so far
 * of chunk q (with its place) and the largest |value|; a run of columns apart (recip_factored's
 * chunks), or one for all (recip_lines). */
#define RECIP_CHUNKS 32
struct recip {
    const size_t *a;
    size_t n;
    double w[RECIP_CHUNKS], s[RECIP_CHUNKS];
    size_t bi[RECIP_CHUNKS], bo[RECIP_CHUNKS];
    bsti_tsums *sums; /* NULL, or the transmissions' sums made on the way (recip_factored) */
    double *bcol;     /* then Tb's column sums of each chunk, RECIP_CHUNKS x n */
};

static int recip_col(void *opaque, size_t q, size_t i, const double *xc, const double *yr)
{
    struct recip *r = opaque;
    const size_t *a = r->a;
    double w = r->w[q], s = r->s[q];
    for (size_t o = 0; o < r->n; o++) {
        double d = fabs(xc[o] - yr[a[o]]);
        s = fmax(s, fmax(fabs(xc[o]), fabs(yr[a[o]])));
        if (d > w)
            w = d, r->bi[q] = i, r->bo[q] = o;
    }
    r->w[q] = w, r->s[q] = s;
    if (r->sums) { /* Tf's column i, Tb's row a(i) (yr), and Tb's columns' share of that row */
        double *bcol = r->bcol + q * r->n, fc = 0.0, br = 0.0;
        for (size_t o = 0; o < r->n; o++) {
            double x = xc[o] > 0.0 ? xc[o] : 0.0, y = yr[o] > 0.0 ? yr[o] : 0.0;
            fc += x;
            br += y;
            bcol[o] += y;
        }
        r->sums->tf_col[i] = fc;
        r->sums->tb_row[a[i]] = br;
    }
    return 0;
}

/* recip_lines of two transmissions of one coarser order kc (bsti_mat_lr_coarse: every order-k
 * patch's values are those of the order-kc patch holding it) at that order, where the antipode
 * maps the patches of each order-kc patch onto those of one (ac): the same differences and
 * values, 4^(k - kc) times fewer.  The worst pair is the first in the fine loop's order: of equal
 * ones, the least coarse patches', whose corners (first fine patches) precede every fine patch of
 * a later one.  The sums are bsti_mat_lr_coarse_sums's.  BST_ENOTFOUND when the antipode does not
 * map the coarse patches so. */
static int recip_coarse(bst_ctx *ctx, const bst_mat *tf, const bst_mat *tb, const size_t *a,
                        size_t n, int kc, double *worst, double *scale, size_t *wi, size_t *wo,
                        bsti_tsums *sums)
{
    size_t nc = (size_t)1 << (2 * kc);
    size_t *ac = bsti_alloc_array(ctx, nc, sizeof *ac), *corner = bsti_alloc_array(ctx, nc, sizeof *corner);
    double *col = bsti_alloc_array(ctx, nc, sizeof *col);
    int rc = ac && corner && col ? BST_OK : BST_ENOMEM;
    for (size_t J = 0; rc >= 0 && J < nc; J++)
        corner[J] = SIZE_MAX;
    for (size_t x = 0; rc >= 0 && x < n; x++) { /* corners: the first fine patch of each */
        size_t J = bsti_mat_lr_coarse_cell(tf, x);
        if (corner[J] == SIZE_MAX)
            corner[J] = x, ac[J] = bsti_mat_lr_coarse_cell(tf, a[x]);
        else if (ac[J] != bsti_mat_lr_coarse_cell(tf, a[x]))
            rc = BST_ENOTFOUND;
    }
    double w = 0.0, sc = 0.0;
    size_t bi = 0, bo = 0;
    for (size_t J = 0; rc >= 0 && J < nc; J++) {
        bsti_mat_lr_coarse_col(tf, J, col);
        for (size_t I = 0; I < nc; I++) {
            double x = col[I], y = bsti_mat_lr_coarse_at(tb, ac[J], ac[I]), d = fabs(x - y);
            sc = fmax(sc, fmax(fabs(x), fabs(y)));
            if (d > w)
                w = d, bi = J, bo = I;
        }
    }
    if (rc >= 0)
        *worst = w, *scale = sc, *wi = corner[bi], *wo = corner[bo];
    if (rc >= 0 && sums && (rc = bsti_mat_lr_coarse_sums(ctx, tf, sums->tf_col, NULL)) >= 0 &&
        (rc = bsti_mat_lr_coarse_sums(ctx, tb, sums->tb_col, sums->tb_row)) >= 0)
        sums->have = 1;
    bsti_free(ctx, ac), bsti_free(ctx, corner), bsti_free(ctx, col);
    return rc;
}

/* recip_lines of two FACTORED transmissions: Tf's columns i beside Tb's rows a(i) (the columns of
 * its transpose: values to rounding) on the readers' threads (bsti_cols_visit), chunk by chunk,
 * the chunks' results taken in their order (the same result whatever the number of threads, and
 * the first of equal ones, as line by line). */
static int recip_factored(bst_ctx *ctx, const bst_mat *tf, const bst_mat *tb, const size_t *a,
                          size_t n, double *worst, double *scale, size_t *wi, size_t *wo,
                          bsti_tsums *sums)
{
    bst_mat *tt = NULL;
    bsti_cols *cf = NULL, *cb = NULL;
    struct recip r = {a, n, {0}, {0}, {0}, {0}, sums, NULL};
    if (sums && !(r.bcol = bsti_calloc(ctx, RECIP_CHUNKS * n, sizeof *r.bcol)))
        return BST_ENOMEM;
    int rc = bst_mat_transpose(ctx, tb, &tt);
    if (rc >= 0)
        rc = bsti_cols_new(ctx, tf, n, &cf);
    if (rc >= 0)
        rc = bsti_cols_new(ctx, tt, n, &cb);
    if (rc >= 0)
        rc = bsti_cols_visit(cf, NULL, cb, a, n, 1, RECIP_CHUNKS, recip_col, &r);
    double w = 0.0, s = 0.0;
    size_t bi = 0, bo = 0;
    for (size_t q = 0; rc >= 0 && q < RECIP_CHUNKS; q++) {
        s = fmax(s, r.s[q]);
        if (r.w[q] > w)
            w = r.w[q], bi = r.bi[q], bo = r.bo[q];
    }
    for (size_t o = 0; rc >= 0 && sums && o < n; o++) { /* the chunks' column sums in order */
        double c = 0.0;
        for (size_t q = 0; q < RECIP_CHUNKS; q++)
            c += r.bcol[q * n + o];
        sums->tb_col[o] = c;
    }
    if (sums)
        sums->have = rc >= 0;
    bsti_free(ctx, r.bcol);
    bsti_cols_free(cf), bsti_cols_free(cb);
    bst_mat_free(tt);
    *worst = w, *scale = s, *wi = bi, *wo = bo;
    return rc;
}

/* The element-wise loop below for transmissions of which one is FACTORED, a one-to-one: Tf's
 * column i beside Tb's row a(i), the same pairs in the same order, a block of lines at a time
 * (lines()), and *scale the largest |value| of either (every value of both is read once).  Values
 * are finite (checked before). */
static int recip_lines(bst_ctx *ctx, const bst_mat *tf, const bst_mat *tb, const size_t *a,
                       size_t n, double *worst, double *scale, size_t *wi, size_t *wo,
                       bsti_tsums *sums)
{
    int kc = bsti_mat_lr_coarse(tf);
    if (kc > 0 && bsti_mat_lr_coarse(tb) == kc) {
        int rc = recip_coarse(ctx, tf, tb, a, n, kc, worst, scale, wi, wo, sums);
        if (rc != BST_ENOTFOUND)
            return rc;
    }
    if (tf && tb && tf->s == BST_FACTORED && tb->s == BST_FACTORED)
        return recip_factored(ctx, tf, tb, a, n, worst, scale, wi, wo, sums);
    struct lines lf, lb;
    int rc = lines_open(ctx, tf, 0, n, &lf);
    if (rc >= 0 && (rc = lines_open(ctx, tb, 1, n, &lb)) < 0)
        lines_close(&lf);
    if (rc < 0)
        return rc;
    size_t nb = lines_block(n, &lf, &lb);
    double *x = bsti_alloc_array(ctx, 2 * nb * n, sizeof *x), *y = x ? x + nb * n : NULL;
    if (!x) {
        lines_close(&lf), lines_close(&lb);
        return BST_ENOMEM;
    }
    struct recip r = {a, n, {0}, {0}, {0}, {0}, NULL, NULL};
    for (size_t i0 = 0; i0 < n; i0 += nb) {
        size_t k = n - i0 < nb ? n - i0 : nb;
        lines_get(&lf, NULL, i0, k, n, x); /* Tf's columns i, Tb's rows a(i) */
        lines_get(&lb, a + i0, 0, k, n, y);
        for (size_t t = 0; t < k; t++)
            recip_col(&r, 0, i0 + t, x + t * n, y + t * n);
    }
    lines_close(&lf), lines_close(&lb);
    bsti_free(ctx, x);
    *worst = r.w[0], *scale = r.s[0], *wi = r.bi[0], *wo = r.bo[0];
    return BST_OK;
}

/* Reciprocity of the BSDF, f(in, out) = f(out, in), in the index convention of bsdfstack.h:
 * light crossing from the front along propagation direction p and leaving along e has Tf's
 * incident patch P(p) and outgoing patch P(e); the reverse path enters from the back propagating
 * along -e and leaves along -p, Tb's incident patch P(-e) = a(P(e)) and outgoing patch a(P(p)).
 * So Tf(o, i) = Tb(a(i), a(o)).  No Lambda weights enter: both are BSDF values over one basis and
 * a patch and its antipode have the same projected solid angle (the flux form
 * Lambda_o Lambda_i Tf(o, i) = Lambda_a(i) Lambda_a(o) Tb(a(i), a(o)) is the same relation). */
static int reciprocity(bst_ctx *ctx, const bst_layer *l, size_t ch, double *err, size_t *incident,
                       size_t *outgoing, bsti_tsums *sums)
{
    if (!ctx || !l || !err)
        return ctx ? bsti_error(ctx, BST_EINVAL, "reciprocity: NULL argument") : BST_EINVAL;
    *err = NAN;
    if (ch >= l->nchannels)
        return bsti_error(ctx, BST_EINVAL, "reciprocity: channel %zu out of range", ch);
    const bst_mat *tf = bst_layer_get(l, ch, BST_TF), *tb = bst_layer_get(l, ch, BST_TB);
    const bst_basis *b = l->basis;
    size_t n = bst_basis_size(b), wi = 0, wo = 0;
    double worst = 0.0, scale = 0.0;
    if (tf && tb && tf->s == BST_DENSE && tb->s == BST_DENSE) {
        size_t *a = bsti_alloc_array(ctx, n, sizeof *a);
        if (!a)
            return BST_ENOMEM;
        int one_to_one = 1;
        for (size_t p = 0; p < n; p++)
            a[p] = bst_basis_antipode(b, p);
        for (size_t p = 0; p < n && one_to_one; p++)
            one_to_one = a[a[p]] == p;
        int finite = one_to_one && recip_dense(ctx, tf, tb, a, n, &worst, &scale, &wi, &wo);
        bsti_free(ctx, a);
        if (one_to_one) {
            if (!finite)
                return bsti_error(ctx, BST_EINVAL, "reciprocity: channel %s holds a transmission "
                                  "value that is not finite", l->channels[ch]);
            goto done;
        }
    }
    if ((tf && !bsti_mat_finite(ctx, tf)) || (tb && !bsti_mat_finite(ctx, tb)))
        return bsti_error(ctx, BST_EINVAL, "reciprocity: channel %s holds a transmission value "
                          "that is not finite", l->channels[ch]);
    if ((tf && (tf->s == BST_FACTORED || tf->s == BST_PLUS_LR)) ||
        (tb && (tb->s == BST_FACTORED || tb->s == BST_PLUS_LR))) {
        size_t *a = bsti_alloc_array(ctx, n, sizeof *a);
        if (!a)
            return BST_ENOMEM;
        int one_to_one = 1, rc = BST_OK;
        for (size_t p = 0; p < n; p++)
            a[p] = bst_basis_antipode(b, p);
        for (size_t p = 0; p < n && one_to_one; p++)
            one_to_one = a[a[p]] == p;
        if (one_to_one)
            rc = recip_lines(ctx, tf, tb, a, n, &worst, &scale, &wi, &wo, sums);
        bsti_free(ctx, a);
        if (rc < 0)
            return rc;
        if (one_to_one)
            goto done;
    }
    scale = fmax(tf ? bst_mat_max_abs(tf) : 0.0, tb ? bst_mat_max_abs(tb) : 0.0);
    /* Where a is one-to-one (every built-in basis; not a Klems band of odd size > 1), (o, i) off
     * the diagonal pairs with (a(i), a(o)) off the diagonal: diagonal or zero transmissions on
     * both sides need only their diagonals. */
    int diagonal = (!tf || tf->s == BST_ZERO || tf->s == BST_DIAG) &&
                   (!tb || tb->s == BST_ZERO || tb->s == BST_DIAG);
    for (size_t p = 0; p < n && diagonal; p++)
        diagonal = bst_basis_antipode(b, bst_basis_antipode(b, p)) == p;
    for (size_t i = 0; i < n; i++) {
        size_t ai = bst_basis_antipode(b, i), lo = diagonal ? i : 0, hi = diagonal ? i + 1 : n;
        for (size_t o = lo; o < hi; o++) {
            double d = fabs(element(tf, o, i) - element(tb, ai, bst_basis_antipode(b, o)));
            if (d > worst)
                worst = d, wi = i, wo = o;
        }
    }
done:
    *err = scale > 0.0 ? worst / scale : 0.0;
    if (incident)
        *incident = wi;
    if (outgoing)
        *outgoing = wo;
    return BST_OK;
}

int bst_metrics_reciprocity(bst_ctx *ctx, const bst_layer *l, size_t ch, double *err,
                            size_t *incident, size_t *outgoing)
{
    return reciprocity(ctx, l, ch, err, incident, outgoing, NULL);
}

int bsti_reciprocity_sums(bst_ctx *ctx, const bst_layer *l, size_t ch, double *err, bsti_tsums *s)
{
    if (s)
        s->have = 0;
    return reciprocity(ctx, l, ch, err, NULL, NULL, s);
}
