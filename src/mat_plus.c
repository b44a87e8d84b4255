/* mat_plus.c - PLUS_LR matrices, base + U W^T (mat.h): a diagonal, sparse or dense base and a part
 * of small rank m held as two thin dense factors.
 *
 * A venetian blind whose slats have a mirror part and a diffuse one is of this form in each
 * component: the unobstructed and mirrored light sparse, the light the strips scatter of rank
 * 2 x segments (venetian_layer.c).  Held dense, each component costs N^2 values (2 GiB at k = 7)
 * and every step of a stack through it is GEMM-bound; held so, the stack's products and sums cost
 * what the base's do plus thin products of N m values, and the solves are the base's with m more
 * right-hand sides (solve.c, solve_plus).
 *
 * Products: (A + Ua Wa^T)(B + Ub Wb^T) = A B + U' W'^T with
 *   U' = [A Ub + Ua (Wa^T Ub) | Ua],   W' = [Wb | B^T Wa],
 * sums: alpha (A + Ua Wa^T) + beta (B + Ub Wb^T) = (alpha A + beta B) + [alpha Ua | beta Ub] [Wa | Wb]^T.
 * The rank grows by addition and is cut back to the numerical rank of U' W'^T after each operation
 * (bsti_plus_settle: QR of both factors, SVD of the m x m core): the light of a blind's strips
 * stays the strips' through any number of steps. */
#include <config.h>

#include <math.h>
#include <string.h>

#include <cblas.h>
#include <lapacke.h>

#include "ctx.h"
#include "mat.h"

/* Columns a float expansion adds U W^T in at a time (of doubles: 32 MiB at k = 7). */
#define PLUS_FLOAT_COLS 256

static int add_into(bst_ctx *ctx, bst_mat *d, size_t m, const double *u, const double *w);

int bsti_mat_plus_new(bst_ctx *ctx, bst_mat *base, size_t m, double *u, double *w, bst_mat **out)
{
    *out = NULL;
    if (m == 0) {
        bsti_free(ctx, u), bsti_free(ctx, w);
        *out = base;
        return BST_OK;
    }
    struct bsti_plus *p = bsti_calloc(ctx, 1, sizeof *p);
    bst_mat *r = NULL;
    int rc = p ? bsti_mat_alloc(ctx, BST_PLUS_LR, BST_DOUBLE, base->rows, base->cols, &r) : BST_ENOMEM;
    if (rc < 0) {
        bsti_free(ctx, p), bsti_free(ctx, u), bsti_free(ctx, w);
        bst_mat_free(base);
        return rc;
    }
    p->base = base, p->m = m, p->u = u, p->w = w;
    r->plus = p;
    r->prec = base->s == BST_DENSE ? base->prec : BST_DOUBLE; /* (bsti_mat_alloc sets DENSE's alone) */
    *out = r;
    return BST_OK;
}

/* ------------------------------------------------------------------ thin products */

int bsti_mul_thin(bst_ctx *ctx, const bst_mat *a, const double *x, size_t m, double *out)
{
    bst_mat xm = {.ctx = ctx, .s = BST_DENSE, .prec = BST_DOUBLE, .rows = a->cols, .cols = m,
                  .dense = (void *)x};
    bst_mat *y;
    int rc = bst_mat_mul(ctx, a, &xm, 0.0, &y);
    if (rc < 0)
        return rc;
    rc = bst_mat_to_dense_array(ctx, y, out);
    bst_mat_free(y);
    return rc;
}

int bsti_mul_thin_t(bst_ctx *ctx, const bst_mat *a, const double *x, size_t m, double *out)
{
    size_t r = a->rows, c = a->cols;
    if (a->s == BST_DENSE && a->prec == BST_DOUBLE) {
        bsti_flops_add(ctx, 2.0 * (double)r * (double)c * (double)m);
        cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)c, (int)m, (int)r, 1.0, a->dense,
                    (int)r, x, (int)r, 0.0, out, (int)c);
        return BST_OK;
    }
    double *xt = bsti_alloc_array(ctx, r * m + 1, sizeof *xt), *yt = bsti_alloc_array(ctx, c * m + 1, sizeof *yt);
    int rc = xt && yt ? BST_OK : BST_ENOMEM;
    bst_mat *y = NULL;
    if (rc >= 0) {
        for (size_t k = 0; k < m; k++)
            for (size_t i = 0; i < r; i++)
                xt[i * m + k] = x[k * r + i];
        bst_mat xm = {.ctx = ctx, .s = BST_DENSE, .prec = BST_DOUBLE, .rows = m, .cols = r,
                      .dense = xt};
        rc = bst_mat_mul(ctx, &xm, a, 0.0, &y);
    }
    if (rc >= 0)
        rc = bst_mat_to_dense_array(ctx, y, yt);
    if (rc >= 0)
        for (size_t j = 0; j < c; j++)
            for (size_t k = 0; k < m; k++)
                out[k * c + j] = yt[j * m + k];
    bst_mat_free(y);
    bsti_free(ctx, xt), bsti_free(ctx, yt);
    return rc;
}

/* ------------------------------------------------------------------ recompression */

/* U W^T (U r x m, W c x m, both taken) cut to its numerical rank k: U = Qu Ru, W = Qw Rw (QR),
 * Ru Rw^T = X S Y^T (SVD), U' = Qu X_k S_k, W' = Qw Y_k, the singular values above
 * tol |U|_F |W|_F kept.
 * Left as it is where m exceeds r or c. */
static int compress(bst_ctx *ctx, size_t r, size_t c, double tol, size_t *pm, double **pu,
                    double **pw)
{
    size_t m = *pm;
    if (m == 0 || m > r || m > c)
        return BST_OK;
    double *u = *pu, *w = *pw;
    double *room = bsti_alloc_array(ctx, 3 * m * m + 4 * m, sizeof *room);
    if (!room)
        return BST_ENOMEM;
    double *tu = room, *tw = tu + m, *s = tw + m, *sup = s + m, *p = sup + m, *x = p + m * m,
           *yt = x + m * m;
    lapack_int M = (lapack_int)m, info;
    info = LAPACKE_dgeqrf(LAPACK_COL_MAJOR, (lapack_int)r, M, u, (lapack_int)r, tu);
    if (info == 0)
        info = LAPACKE_dgeqrf(LAPACK_COL_MAJOR, (lapack_int)c, M, w, (lapack_int)c, tw);
    if (info == 0) {
        for (size_t j = 0; j < m; j++) /* P = Ru Rw^T, both upper triangular */
            for (size_t i = 0; i < m; i++) {
                double v = 0.0;
                for (size_t k = i > j ? i : j; k < m; k++)
                    v += u[k * r + i] * w[k * c + j];
                p[j * m + i] = v;
            }
        info = LAPACKE_dgesvd(LAPACK_COL_MAJOR, 'A', 'A', M, M, p, M, s, x, M, yt, M, sup);
    }
    bsti_flops_add(ctx, 4.0 * (double)(r + c) * (double)m * (double)m);
    /* the threshold: tol times the bound |U|_F |W|_F of |U W^T|_2, so that what a sum cancels
       (A - A) goes, not only what lies below the largest value left */
    double nu2 = 0.0, nw2 = 0.0;
    for (size_t j = 0; j < m; j++)
        for (size_t i = 0; i <= j; i++)
            nu2 += u[j * r + i] * u[j * r + i], nw2 += w[j * c + i] * w[j * c + i];
    size_t k = 0;
    while (info == 0 && k < m && s[k] > tol * sqrt(nu2 * nw2))
        k++;
    double *nu = NULL, *nw = NULL;
    int rc = info == 0 ? BST_OK : bsti_error(ctx, BST_EINTERNAL, "low-rank part: LAPACK %d", (int)info);
    if (rc >= 0 && k > 0) {
        nu = bsti_calloc(ctx, r * k, sizeof *nu);
        nw = bsti_calloc(ctx, c * k, sizeof *nw);
        rc = nu && nw ? BST_OK : BST_ENOMEM;
    }
    if (rc >= 0 && k > 0) {
        for (size_t t = 0; t < k; t++)
            for (size_t i = 0; i < m; i++) {
                nu[t * r + i] = x[t * m + i] * s[t];
                nw[t * c + i] = yt[i * m + t];
            }
        info = LAPACKE_dormqr(LAPACK_COL_MAJOR, 'L', 'N', (lapack_int)r, (lapack_int)k, M, u,
                              (lapack_int)r, tu, nu, (lapack_int)r);
        if (info == 0)
            info = LAPACKE_dormqr(LAPACK_COL_MAJOR, 'L', 'N', (lapack_int)c, (lapack_int)k, M, w,
                                  (lapack_int)c, tw, nw, (lapack_int)c);
        if (info != 0)
            rc = bsti_error(ctx, BST_EINTERNAL, "low-rank part: LAPACK dormqr %d", (int)info);
    }
    bsti_free(ctx, room);
    if (rc < 0) {
        bsti_free(ctx, nu), bsti_free(ctx, nw);
        return rc;
    }
    bsti_free(ctx, u), bsti_free(ctx, w);
    *pu = nu, *pw = nw, *pm = k;
    return BST_OK;
}

int bsti_plus_settle(bst_ctx *ctx, bst_mat **pm)
{
    bst_mat *m = *pm;
    if (m->s != BST_PLUS_LR)
        return BST_OK;
    struct bsti_plus *p = m->plus;
    int rc;
    if (p->base->s == BST_DENSE) { /* N^2 values held anyway: the sum in them */
        if ((rc = add_into(ctx, p->base, p->m, p->u, p->w)) < 0)
            return rc;
        p->m = 0;
    } else if ((rc = compress(ctx, m->rows, m->cols, BSTI_PLUS_TOL, &p->m, &p->u, &p->w)) < 0) {
        return rc;
    }
    if (p->m == 0) {
        *pm = p->base;
        p->base = NULL;
        bst_mat_free(m);
        return BST_OK;
    }
    if (bsti_plus_fits(m->rows, m->cols, p->m))
        return BST_OK;
    bst_mat *d;
    if ((rc = bsti_plus_to_dense(ctx, m, m->prec, &d)) < 0)
        return rc;
    bst_mat_free(m);
    *pm = d;
    return BST_OK;
}

int bsti_plus_settled(bst_ctx *ctx, int rc, bst_mat *base, size_t m, double *u, double *w,
                      bst_mat **out)
{
    if (rc < 0) {
        bst_mat_free(base);
        bsti_free(ctx, u), bsti_free(ctx, w);
        return rc;
    }
    if ((rc = bsti_mat_plus_new(ctx, base, m, u, w, out)) >= 0 && (rc = bsti_plus_settle(ctx, out)) < 0) {
        bst_mat_free(*out);
        *out = NULL;
    }
    return rc;
}

/* ------------------------------------------------------------------ products and sums */

int bsti_mul_plus(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out)
{
    const bst_mat *ab, *bb;
    size_t ma, mb;
    const double *ua, *wa, *ub, *wb;
    bsti_plus_parts(a, &ab, &ma, &ua, &wa);
    bsti_plus_parts(b, &bb, &mb, &ub, &wb);
    size_t r = a->rows, c = b->cols, n = a->cols, m = ma + mb;
    bst_mat *base = NULL;
    double *u = bsti_alloc_array(ctx, r * m + 1, sizeof *u), *w = bsti_alloc_array(ctx, c * m + 1, sizeof *w);
    double *core = bsti_alloc_array(ctx, ma * mb + 1, sizeof *core);
    int rc = u && w && core ? bst_mat_mul(ctx, ab, bb, drop, &base) : BST_ENOMEM;
    if (rc >= 0 && mb) { /* U'[:, :mb] = A Ub + Ua (Wa^T Ub), W'[:, :mb] = Wb */
        rc = bsti_mul_thin(ctx, ab, ub, mb, u);
        if (rc >= 0 && ma) {
            cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)ma, (int)mb, (int)n, 1.0, wa,
                        (int)n, ub, (int)n, 0.0, core, (int)ma);
            cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)r, (int)mb, (int)ma, 1.0, ua,
                        (int)r, core, (int)ma, 1.0, u, (int)r);
        }
        memcpy(w, wb, c * mb * sizeof *w);
    }
    if (rc >= 0 && ma) { /* U'[:, mb:] = Ua, W'[:, mb:] = B^T Wa */
        memcpy(u + r * mb, ua, r * ma * sizeof *u);
        rc = bsti_mul_thin_t(ctx, bb, wa, ma, w + c * mb);
    }
    bsti_free(ctx, core);
    return bsti_plus_settled(ctx, rc, base, m, u, w, out);
}

int bsti_add_plus(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                  bst_mat **out)
{
    const bst_mat *ab, *bb;
    size_t ma, mb;
    const double *ua, *wa, *ub, *wb;
    bsti_plus_parts(a, &ab, &ma, &ua, &wa);
    bsti_plus_parts(b, &bb, &mb, &ub, &wb);
    size_t r = a->rows, c = a->cols, m = ma + mb;
    bst_mat *base = NULL;
    double *u = bsti_alloc_array(ctx, r * m + 1, sizeof *u), *w = bsti_alloc_array(ctx, c * m + 1, sizeof *w);
    int rc = u && w ? bst_mat_add(ctx, alpha, ab, beta, bb, &base) : BST_ENOMEM;
    if (rc >= 0) {
        for (size_t k = 0; k < r * ma; k++)
            u[k] = alpha * ua[k];
        for (size_t k = 0; k < r * mb; k++)
            u[r * ma + k] = beta * ub[k];
        if (ma)
            memcpy(w, wa, c * ma * sizeof *w);
        if (mb)
            memcpy(w + c * ma, wb, c * mb * sizeof *w);
    }
    return bsti_plus_settled(ctx, rc, base, m, u, w, out);
}

/* ------------------------------------------------------------------ values, copies, transposes */

/* d += U W^T for a dense d of either precision (a float one through doubles, a block of columns at
 * a time, each value rounded once). */
static int add_into(bst_ctx *ctx, bst_mat *d, size_t m, const double *u, const double *w)
{
    size_t r = d->rows, c = d->cols;
    bsti_flops_add(ctx, 2.0 * (double)r * (double)c * (double)m);
    if (d->prec == BST_DOUBLE) {
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, (int)r, (int)c, (int)m, 1.0, u, (int)r,
                    w, (int)c, 1.0, d->dense, (int)r);
        return BST_OK;
    }
    size_t nb = c < PLUS_FLOAT_COLS ? c : PLUS_FLOAT_COLS;
    double *buf = bsti_alloc_array(ctx, r * nb + 1, sizeof *buf);
    if (!buf)
        return BST_ENOMEM;
    float *f = d->dense;
    for (size_t j0 = 0; j0 < c; j0 += nb) {
        size_t k = c - j0 < nb ? c - j0 : nb;
        for (size_t t = 0; t < r * k; t++)
            buf[t] = f[j0 * r + t];
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, (int)r, (int)k, (int)m, 1.0, u, (int)r,
                    w + j0, (int)c, 1.0, buf, (int)r);
        for (size_t t = 0; t < r * k; t++)
            f[j0 * r + t] = (float)buf[t];
    }
    bsti_free(ctx, buf);
    return BST_OK;
}

int bsti_plus_lowrank_into(bst_ctx *ctx, bst_mat *d, const bst_mat *m)
{
    return add_into(ctx, d, m->plus->m, m->plus->u, m->plus->w);
}

int bsti_plus_to_dense(bst_ctx *ctx, const bst_mat *m, bst_precision prec, bst_mat **out)
{
    const struct bsti_plus *p = m->plus;
    bst_mat *d;
    int rc = bst_mat_convert(ctx, p->base, BST_DENSE, prec, &d);
    if (rc >= 0 && (rc = add_into(ctx, d, p->m, p->u, p->w)) < 0)
        bst_mat_free(d);
    if (rc >= 0)
        *out = d;
    return rc;
}

double bsti_plus_get(const bst_mat *m, size_t i, size_t j)
{
    const struct bsti_plus *p = m->plus;
    double v = bst_mat_get(p->base, i, j);
    for (size_t k = 0; k < p->m; k++)
        v += p->u[k * m->rows + i] * p->w[k * m->cols + j];
    return v;
}

static int dup_into(bst_ctx *ctx, const double *x, size_t n, double **out)
{
    *out = bsti_alloc_array(ctx, n + 1, sizeof **out);
    if (!*out)
        return BST_ENOMEM;
    memcpy(*out, x, n * sizeof **out);
    return BST_OK;
}

/* base (made by the caller, status rc) + copies of u (nu values) and w (nw values), rank m; base and
 * the copies freed on failure. */
static int plus_of_copies(bst_ctx *ctx, int rc, bst_mat *base, size_t m, const double *u, size_t nu,
                          const double *w, size_t nw, bst_mat **out)
{
    double *cu = NULL, *cw = NULL;
    if (rc >= 0)
        rc = dup_into(ctx, u, nu, &cu);
    if (rc >= 0)
        rc = dup_into(ctx, w, nw, &cw);
    if (rc < 0) {
        bst_mat_free(base);
        bsti_free(ctx, cu), bsti_free(ctx, cw);
        return rc;
    }
    return bsti_mat_plus_new(ctx, base, m, cu, cw, out);
}

int bsti_plus_copy(bst_ctx *ctx, const bst_mat *m, bst_mat **out)
{
    const struct bsti_plus *p = m->plus;
    bst_mat *base = NULL;
    int rc = bst_mat_convert(ctx, p->base, p->base->s, p->base->prec, &base);
    return plus_of_copies(ctx, rc, base, p->m, p->u, m->rows * p->m, p->w, m->cols * p->m, out);
}

int bsti_plus_transpose(bst_ctx *ctx, const bst_mat *m, bst_mat **out)
{
    const struct bsti_plus *p = m->plus;
    bst_mat *base = NULL;
    int rc = bst_mat_transpose(ctx, p->base, &base);
    return plus_of_copies(ctx, rc, base, p->m, p->w, m->cols * p->m, p->u, m->rows * p->m, out);
}

int bsti_plus_scale(bst_ctx *ctx, const double *dr, const bst_mat *m, const double *dc,
                    bst_mat **out)
{
    const struct bsti_plus *p = m->plus;
    bst_mat *base = NULL;
    int rc = bsti_mat_scale(ctx, dr, p->base, dc, &base);
    if ((rc = plus_of_copies(ctx, rc, base, p->m, p->u, m->rows * p->m, p->w, m->cols * p->m, out)) < 0)
        return rc;
    struct bsti_plus *q = (*out)->plus;
    for (size_t k = 0; dr && k < q->m; k++)
        for (size_t i = 0; i < m->rows; i++)
            q->u[k * m->rows + i] *= dr[i];
    for (size_t k = 0; dc && k < q->m; k++)
        for (size_t j = 0; j < m->cols; j++)
            q->w[k * m->cols + j] *= dc[j];
    return BST_OK;
}
