/* write_bound.c - the budgets of a reduced tensor tree (write_bound.h says what they promise and
 * how they are shared out). */
#include <config.h>

#include <float.h>
#include <math.h>
#include <string.h>

#include "basis.h"
#include "ctx.h"
#include "layer.h"
#include "mat.h"
#include "write_bound.h"

/* A FACTORED m's column sums and row sums (sums() below) a column at a time on bsti_cols's threads
 * (bsti_cols_visit); the row sums of each of SUM_CHUNKS runs of columns apart, added in their order
 * (the same sums whatever the number of threads). */
#define SUM_CHUNKS 16
struct fsums {
    size_t nr;
    double *col, *row; /* row: SUM_CHUNKS x nr partial sums, or NULL */
};

static int fsums_col(void *opaque, size_t chunk, size_t i, const double *v, const double *none)
{
    (void)none;
    struct fsums *f = opaque;
    double *row = f->row ? f->row + chunk * f->nr : NULL, s = 0.0;
    for (size_t o = 0; o < f->nr; o++) {
        double x = v[o] > 0.0 ? v[o] : 0.0;
        s += x;
        if (row)
            row[o] += x;
    }
    f->col[i] = s;
    return 0;
}

static int factored_sums(bst_ctx *ctx, const bst_mat *m, size_t nr, size_t n, double *col,
                         double *row)
{
    bsti_cols *c = NULL;
    struct fsums f = {nr, col, row ? bsti_calloc(ctx, SUM_CHUNKS * nr, sizeof *f.row) : NULL};
    int rc = row && !f.row ? BST_ENOMEM : bsti_cols_new(ctx, m, nr, &c);
    if (rc >= 0)
        rc = bsti_cols_visit(c, NULL, NULL, NULL, n, 1, SUM_CHUNKS, fsums_col, &f);
    for (size_t q = 0; rc >= 0 && row && q < SUM_CHUNKS; q++)
        for (size_t o = 0; o < nr; o++)
            row[o] += f.row[q * nr + o];
    bsti_cols_free(c);
    bsti_free(ctx, f.row);
    return rc;
}

/* col[i] = sum over o of m(o, i), row[o] = sum over i (row may be NULL), negatives read as 0, as
 * a tree reader stores them; m (NULL: zeros) has nr rows and n columns. */
static int sums(bst_ctx *ctx, const bst_mat *m, size_t nr, size_t n, double *col, double *row)
{
    memset(col, 0, n * sizeof *col);
    if (row)
        memset(row, 0, nr * sizeof *row);
    if (!m || m->s == BST_ZERO)
        return BST_OK;
    if (m->s == BST_DIAG) {
        for (size_t i = 0; i < n && i < nr; i++) {
            col[i] = fmax(m->diag[i], 0.0);
            if (row)
                row[i] = col[i];
        }
    } else if (m->s == BST_FACTORED && nr == n && bsti_mat_lr_coarse(m) > 0) {
        return bsti_mat_lr_coarse_sums(ctx, m, col, row);
    } else if (m->s == BST_FACTORED || m->s == BST_PLUS_LR) {
        return factored_sums(ctx, m, nr, n, col, row);
    } else if (m->s == BST_SPARSE) {
        const SuiteSparse_long *p = m->sp->p, *ri = m->sp->i;
        const double *x = m->sp->x;
        for (size_t i = 0; i < n; i++)
            for (SuiteSparse_long q = p[i]; q < p[i + 1]; q++) {
                double v = fmax(x[q], 0.0);
                col[i] += v;
                if (row)
                    row[ri[q]] += v;
            }
    } else { /* dense (nr = m->rows): the columns on the context's threads, then the rows */
        bsti_dense_col_sums(ctx, m, NULL, 1, col);
        for (size_t i = 0; row && i < n; i++)
            for (size_t o = 0; o < nr; o++) {
                double v = bsti_dense_get(m, o, i);
                row[o] += v > 0.0 ? v : 0.0;
            }
    }
    return BST_OK;
}

double bsti_bounds_rho(int digits)
{
    /* (with digits, the value's float is rounded: both roundings) */
    return digits > 0 ? 0.5 * pow(10.0, 1 - digits) + FLT_EPSILON : FLT_EPSILON / 2;
}

int bsti_bounds_digits(double afford, int from)
{
    for (int d = from < 1 ? 1 : from; d <= 9; d++)
        if (bsti_bounds_rho(d) <= afford)
            return d;
    return 0;
}

/* Budget b before rounding at patch i of channel ch's component c, whose own value is h. */
static void afford(bsti_bounds *B, size_t ch, int c, size_t i, double h, double b)
{
    if (h > 0.0 && b / h < B->afford) {
        B->afford = b / h;
        B->afford_ch = ch, B->afford_c = c, B->afford_i = i;
        B->afford_h = h, B->afford_b = b;
    }
}

/* One side of channel ch: t and r the directional-hemispherical values of its transmission ct and
 * reflection cr (NULL: absent), n patches; their budgets into bt and br (those of an absent one
 * are left). */
static void side(bsti_bounds *B, size_t ch, int ct, int cr, size_t n, const double *t,
                 const double *r, double tol, double rho, double *bt, double *br)
{
    double smax = 0.0, m = (t ? 1.0 : 0.0) + (r ? 1.0 : 0.0);
    if (m == 0.0)
        return;
    for (size_t i = 0; i < n; i++)
        smax = fmax(smax, (t ? t[i] : 0.0) + (r ? r[i] : 0.0));
    for (size_t i = 0; i < n; i++) {
        double slack = smax - (t ? t[i] : 0.0) - (r ? r[i] : 0.0);
        double b = fmin(tol, (tol + slack) / m);
        if (t) {
            bt[i] = fmax(0.0, b - rho * t[i]);
            afford(B, ch, ct, i, t[i], b);
        }
        if (r) {
            br[i] = fmax(0.0, b - rho * r[i]);
            afford(B, ch, cr, i, r[i], b);
        }
    }
}

static int bounds_alloc(bst_ctx *ctx, size_t nch, size_t n, bsti_bounds *b)
{
    b->nch = nch;
    b->n = n;
    b->afford = INFINITY;
    b->col = bsti_calloc(ctx, nch * BST_NCOMP * n, sizeof *b->col);
    b->row = bsti_calloc(ctx, nch * n, sizeof *b->row);
    if (b->col && b->row)
        return BST_OK;
    bsti_bounds_free(ctx, b);
    return BST_ENOMEM;
}

void bsti_bounds_free(bst_ctx *ctx, bsti_bounds *b)
{
    bsti_free(ctx, b->col);
    bsti_free(ctx, b->row);
    b->col = b->row = NULL;
}

int bsti_bounds_layer(bst_ctx *ctx, const bst_layer *l, double tol, double rho, int *omit_tf,
                      const bsti_tsums *pre, bsti_bounds *b)
{
    size_t nch = bst_layer_nchannels(l), n = bst_basis_size(bst_layer_basis(l));
    double lam = M_PI / (double)n; /* Shirley-Chiu: every patch pi / N */
    memset(b, 0, sizeof *b);
    int rc = bounds_alloc(ctx, nch, n, b);
    double *h = rc >= 0 ? bsti_alloc_array(ctx, (BST_NCOMP + 1) * n, sizeof *h) : NULL;
    if (rc >= 0 && !h)
        rc = BST_ENOMEM;
    for (size_t ch = 0; rc >= 0 && ch < nch; ch++) {
        const double *hc[BST_NCOMP];
        double *tb_rows = h + BST_NCOMP * n;
        const bsti_tsums *p = pre && pre[ch].have ? &pre[ch] : NULL;
        for (int c = 0; c < BST_NCOMP; c++) {
            const bst_mat *m = bst_layer_get(l, ch, (bst_comp)c);
            if (p && c == BST_TF) {
                memcpy(h + c * n, p->tf_col, n * sizeof *h);
            } else if (p && c == BST_TB) {
                memcpy(h + c * n, p->tb_col, n * sizeof *h);
                memcpy(tb_rows, p->tb_row, n * sizeof *h);
            } else if (rc >= 0) {
                rc = sums(ctx, m, n, n, h + c * n, c == BST_TB && omit_tf[ch] ? tb_rows : NULL);
            }
            for (size_t i = 0; i < n; i++)
                h[c * n + i] *= lam;
            hc[c] = m ? h + c * n : NULL;
        }
        if (rc < 0)
            break;
        double *col = b->col + ch * BST_NCOMP * n, *row = b->row + ch * n;
        side(b, ch, BST_TF, BST_RF, n, hc[BST_TF], hc[BST_RF], tol, rho, col + BST_TF * n,
             col + BST_RF * n);
        side(b, ch, BST_TB, BST_RB, n, hc[BST_TB], hc[BST_RB], tol, rho, col + BST_TB * n,
             col + BST_RB * n);
        if (!omit_tf[ch] || !hc[BST_TF] || !hc[BST_TB])
            continue;
        for (size_t i = 0; i < n && omit_tf[ch]; i++) {
            size_t a = bst_basis_antipode(bst_layer_basis(l), i);
            /* (Tf's budget already holds back the rounding of its own values, here Tb's row) */
            double left = col[BST_TF * n + i] - fabs(hc[BST_TF][i] - lam * tb_rows[a]);
            if (left < 0.0)
                omit_tf[ch] = 0; /* reciprocity alone moves Tf too far: Tf is written */
            row[a] = left;
        }
    }
    bsti_free(ctx, h);
    if (rc < 0)
        bsti_bounds_free(ctx, b);
    return rc;
}

/* Directional-hemispherical values of a front component's columns at order k (N patches) into
 * out: the fine column where there is one, the coarse patch's (hc, order kc) elsewhere. */
static int varres_front(bst_ctx *ctx, const bst_varres *v, const bst_mat *fine, int kc,
                        const double *hc, double *out, double *colsum)
{
    size_t G = (size_t)1 << v->k, N = G * G, Gc = (size_t)1 << kc;
    int sh = v->k - kc;
    for (size_t i = 0; i < N; i++)
        out[i] = hc[((i / G) >> sh) * Gc + ((i % G) >> sh)];
    if (!fine || fine->rows != N || fine->cols != v->ncols)
        return BST_OK; /* (bsti_varres_init refuses it later) */
    int rc = sums(ctx, fine, N, v->ncols, colsum, NULL);
    for (size_t q = 0; rc >= 0 && q < v->ncols; q++)
        if (v->cols[q] < N)
            out[v->cols[q]] = colsum[q] * M_PI / (double)N;
    return rc;
}

int bsti_bounds_varres(bst_ctx *ctx, const bst_layer *coarse, const bst_varres *v, double tol,
                       double rho, bsti_bounds *b)
{
    size_t nch = bst_layer_nchannels(coarse), Nc = bst_basis_size(bst_layer_basis(coarse));
    int kc = bst_basis_order(bst_layer_basis(coarse));
    size_t N = (size_t)1 << (2 * v->k);
    double lam = M_PI / (double)Nc;
    memset(b, 0, sizeof *b);
    int rc = bounds_alloc(ctx, nch, N, b);
    double *h = rc >= 0 ? bsti_alloc_array(ctx, BST_NCOMP * Nc + 2 * N + v->ncols + 1, sizeof *h) : NULL;
    if (rc >= 0 && !h)
        rc = BST_ENOMEM;
    for (size_t ch = 0; rc >= 0 && ch < nch; ch++) {
        const double *hc[BST_NCOMP];
        for (int c = 0; c < BST_NCOMP; c++) {
            const bst_mat *m = bst_layer_get(coarse, ch, (bst_comp)c);
            if (rc >= 0)
                rc = sums(ctx, m, Nc, Nc, h + c * Nc, NULL);
            for (size_t i = 0; i < Nc; i++)
                h[c * Nc + i] *= lam;
            hc[c] = m ? h + c * Nc : NULL;
        }
        double *col = b->col + ch * BST_NCOMP * N, *ft = h + BST_NCOMP * Nc, *fr = ft + N;
        double *colsum = fr + N;
        if (rc >= 0 && hc[BST_TF])
            rc = varres_front(ctx, v, v->tf ? v->tf[ch] : NULL, kc, hc[BST_TF], ft, colsum);
        if (rc >= 0 && hc[BST_RF])
            rc = varres_front(ctx, v, v->rf ? v->rf[ch] : NULL, kc, hc[BST_RF], fr, colsum);
        if (rc < 0)
            break;
        side(b, ch, BST_TF, BST_RF, N, hc[BST_TF] ? ft : NULL, hc[BST_RF] ? fr : NULL, tol, rho,
             col + BST_TF * N, col + BST_RF * N);
        side(b, ch, BST_TB, BST_RB, Nc, hc[BST_TB], hc[BST_RB], tol, rho, col + BST_TB * N,
             col + BST_RB * N);
        /* a front component with no fine columns is written at order kc: the least of each
         * coarse patch's fine budgets */
        for (int c = BST_TF; c <= BST_RF; c++) {
            const bst_mat *const *fine = c == BST_TF ? v->tf : v->rf;
            if (fine && fine[ch])
                continue;
            double *bc = col + c * N, *pool = ft;
            size_t G = (size_t)1 << v->k, Gc = (size_t)1 << kc;
            int sh = v->k - kc;
            for (size_t q = 0; q < Nc; q++)
                pool[q] = INFINITY;
            for (size_t i = 0; i < N; i++) {
                size_t q = ((i / G) >> sh) * Gc + ((i % G) >> sh);
                pool[q] = fmin(pool[q], bc[i]);
            }
            memcpy(bc, pool, Nc * sizeof *bc);
        }
    }
    bsti_free(ctx, h);
    if (rc < 0)
        bsti_bounds_free(ctx, b);
    return rc;
}

void bsti_bounds_rings(int k, const double *col, double *ring)
{
    size_t G = (size_t)1 << k;
    for (size_t x = 0; x < G / 2; x++)
        ring[x] = INFINITY;
    for (size_t ix = 0; ix < G; ix++)
        for (size_t iy = 0; iy < G; iy++) {
            size_t dx = 2 * ix + 1 > G ? 2 * ix + 1 - G : G - 2 * ix - 1;
            size_t dy = 2 * iy + 1 > G ? 2 * iy + 1 - G : G - 2 * iy - 1;
            size_t j = ((dx > dy ? dx : dy) - 1) / 2, x = G / 2 - 1 - j;
            ring[x] = fmin(ring[x], col[ix * G + iy]);
        }
}

int bsti_bounds_write(bst_ctx *ctx, const bst_layer *l, const bst_varres *v, double tol,
                      double rho, int *omit, const bsti_tsums *pre, bsti_bounds *b)
{
    if (v)
        return bsti_bounds_varres(ctx, l, v, tol, rho, b);
    size_t nch = bst_layer_nchannels(l);
    int *omit_tf = bsti_alloc_array(ctx, nch + 1, sizeof *omit_tf);
    if (!omit_tf)
        return BST_ENOMEM;
    for (size_t ch = 0; ch < nch; ch++)
        omit_tf[ch] = omit[ch * BST_NCOMP + BST_TF] == 1;
    int rc = bsti_bounds_layer(ctx, l, tol, rho, omit_tf, pre, b);
    for (size_t ch = 0; rc >= 0 && ch < nch; ch++)
        if (omit[ch * BST_NCOMP + BST_TF] == 1 && !omit_tf[ch])
            omit[ch * BST_NCOMP + BST_TF] = 0;
    bsti_free(ctx, omit_tf);
    return rc;
}
