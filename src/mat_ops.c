/* mat_ops.c - structured matrices: transposes, column sums, exports, column selection and
 * checks (the objects, conversions and scalings are in mat.c; conventions in mat.h). */
#include <config.h>

#include <math.h>
#include <string.h>

#include <cblas.h>

#include "ctx.h"
#include "mat.h"

int bst_mat_transpose(bst_ctx *ctx, const bst_mat *a, bst_mat **out)
{
    int rc = bsti_mat_check_out(ctx, out);
    if (rc < 0)
        return rc;
    if (!a)
        return bsti_error(ctx, BST_EINVAL, "transpose: NULL matrix");
    switch (a->s) {
    case BST_ZERO: return bst_mat_new_zero(ctx, a->cols, a->rows, out);
    case BST_DIAG: return bst_mat_new_diag(ctx, a->rows, a->diag, out);
    case BST_FACTORED: {
        bsti_lr *lr;
        return (rc = bsti_lr_transpose(ctx, a->lr, &lr)) < 0 ? rc : bsti_mat_from_lr(ctx, lr, out);
    }
    case BST_PLUS_LR: return bsti_plus_transpose(ctx, a, out);
    case BST_SPARSE: {
        cholmod_common *cc = bsti_cholmod(ctx);
        cholmod_sparse *t = cc ? cholmod_l_transpose(a->sp, 1, cc) : NULL;
        return t ? bsti_mat_from_cholmod(ctx, t, out) : bsti_mat_cholmod_failed(ctx, "transpose");
    }
    case BST_DENSE: {
        bst_mat *t;
        if ((rc = bst_mat_new_dense(ctx, a->cols, a->rows, a->prec, &t)) < 0)
            return rc;
        /* tile by tile (BSTI_TRANSPOSE_TILE): element by element, every write of a large matrix's
         * column would touch another cache line and page (2-3x slower at N = 4096, where
         * OpenBLAS's omatcopy is no faster either) */
        const size_t r = a->rows, c = a->cols, B = BSTI_TRANSPOSE_TILE;
        for (size_t j0 = 0; j0 < c; j0 += B)
            for (size_t i0 = 0; i0 < r; i0 += B) {
                size_t j1 = j0 + B < c ? j0 + B : c, i1 = i0 + B < r ? i0 + B : r;
                if (a->prec == BST_DOUBLE) {
                    const double *src = a->dense;
                    double *dst = t->dense;
                    for (size_t j = j0; j < j1; j++)
                        for (size_t i = i0; i < i1; i++)
                            dst[i * c + j] = src[j * r + i];
                } else {
                    const float *src = a->dense;
                    float *dst = t->dense;
                    for (size_t j = j0; j < j1; j++)
                        for (size_t i = i0; i < i1; i++)
                            dst[i * c + j] = src[j * r + i];
                }
            }
        *out = t;
        return BST_OK;
    }
    }
    return bsti_error(ctx, BST_EINVAL, "transpose: unknown structure");
}

void bsti_mat_transpose_in_place(bst_mat *m)
{
    bsti_transpose_square(m->dense, m->rows, m->prec);
}

void bsti_transpose_square(void *values, size_t n, bst_precision prec)
{
    const size_t B = BSTI_TRANSPOSE_TILE;
    for (size_t jb = 0; jb < n; jb += B) {
        size_t je = jb + B < n ? jb + B : n;
        for (size_t ib = jb; ib < n; ib += B) { /* a tile and its mirror, swapped */
            size_t ie = ib + B < n ? ib + B : n;
            for (size_t j = jb; j < je; j++) {
                size_t i0 = ib == jb ? j + 1 : ib; /* a diagonal tile: its lower triangle */
                if (prec == BST_DOUBLE) {
                    double *d = values;
                    for (size_t i = i0; i < ie; i++) {
                        double t = d[j * n + i];
                        d[j * n + i] = d[i * n + j];
                        d[i * n + j] = t;
                    }
                } else {
                    float *d = values;
                    for (size_t i = i0; i < ie; i++) {
                        float t = d[j * n + i];
                        d[j * n + i] = d[i * n + j];
                        d[i * n + j] = t;
                    }
                }
            }
        }
    }
}

int bsti_mat_transpose_take(bst_ctx *ctx, bst_mat *m, bst_mat **out)
{
    if (m->s == BST_PLUS_LR && m->rows == m->cols) { /* its base in place, U and W swapped */
        struct bsti_plus *p = m->plus;
        bst_mat *bt;
        int rc = bsti_mat_transpose_take(ctx, p->base, &bt);
        p->base = rc >= 0 ? bt : NULL;
        double *t = p->u;
        p->u = p->w, p->w = t;
        if (rc < 0) {
            bst_mat_free(m);
            return rc;
        }
        *out = m;
        return BST_OK;
    }
    if ((m->s == BST_DENSE && m->rows == m->cols) ||
        (m->s == BST_FACTORED && bsti_lr_transpose_take(m->lr) == 0)) {
        if (m->s == BST_DENSE)
            bsti_mat_transpose_in_place(m);
        *out = m;
        return BST_OK;
    }
    int rc = bst_mat_transpose(ctx, m, out);
    bst_mat_free(m);
    return rc;
}

int bst_mat_col_weighted_sum(bst_ctx *ctx, const bst_mat *m, const double *w, double *out)
{
    if (!ctx)
        return BST_EINVAL;
    if (!m || !out)
        return bsti_error(ctx, BST_EINVAL, "column sums: NULL argument");
    if (m->s == BST_FACTORED) { /* out = F^T w, through the factors */
        size_t n = m->rows;
        double *x = bsti_alloc_array(ctx, n + (m->lr->p + m->lr->q) * m->lr->r + 1, sizeof *x);
        if (!x)
            return BST_ENOMEM;
        for (size_t i = 0; i < n; i++)
            x[i] = w ? w[i] : 1.0;
        bsti_lr_apply(m->lr, 1, x, out, x + n);
        bsti_free(ctx, x);
        return BST_OK;
    }
    if (m->s == BST_PLUS_LR) { /* out = base^T w + W (U^T w) */
        const struct bsti_plus *p = m->plus;
        double *t = bsti_alloc_array(ctx, p->m, sizeof *t);
        int rc = t ? bst_mat_col_weighted_sum(ctx, p->base, w, out) : BST_ENOMEM;
        for (size_t k = 0; rc >= 0 && k < p->m; k++) {
            t[k] = 0.0;
            for (size_t i = 0; i < m->rows; i++)
                t[k] += (w ? w[i] : 1.0) * p->u[k * m->rows + i];
        }
        for (size_t j = 0; rc >= 0 && j < m->cols; j++)
            for (size_t k = 0; k < p->m; k++)
                out[j] += p->w[k * m->cols + j] * t[k];
        bsti_free(ctx, t);
        return rc;
    }
    if (m->s == BST_DENSE) {
        bsti_dense_col_sums(ctx, m, w, 0, out);
        return BST_OK;
    }
    for (size_t j = 0; j < m->cols; j++) {
        double s = 0.0;
        switch (m->s) {
        case BST_ZERO: break;
        case BST_DIAG: s = j < m->rows ? (w ? w[j] : 1.0) * m->diag[j] : 0.0; break;
        case BST_SPARSE: {
            const SuiteSparse_long *p = m->sp->p, *ri = m->sp->i;
            const double *x = m->sp->x;
            for (SuiteSparse_long q = p[j]; q < p[j + 1]; q++)
                s += (w ? w[ri[q]] : 1.0) * x[q];
            break;
        }
        default: break; /* DENSE, FACTORED: above */
        }
        out[j] = s;
    }
    return BST_OK;
}

int bst_mat_to_dense_array(bst_ctx *ctx, const bst_mat *m, double *out)
{
    if (!ctx)
        return BST_EINVAL;
    if (!m || !out)
        return bsti_error(ctx, BST_EINVAL, "export: NULL argument");
    size_t r = m->rows;
    if (m->s == BST_DENSE && m->prec == BST_DOUBLE) {
        memcpy(out, m->dense, r * m->cols * sizeof(double));
        return BST_OK;
    }
    if (bsti_mat_lr_wide(m)) { /* by GEMM (mat.h), straight into out */
        bsti_cols *c;
        int rc = bsti_cols_new(ctx, m, r, &c);
        if (rc < 0)
            return rc;
        bsti_cols_get(c, NULL, 0, m->cols, out);
        bsti_cols_free(c);
        return BST_OK;
    }
    if (m->s == BST_FACTORED) {
        bsti_lr_to_dense(m->lr, out);
        return BST_OK;
    }
    if (m->s == BST_PLUS_LR) { /* the base's values, then U W^T added */
        const struct bsti_plus *p = m->plus;
        int rc = bst_mat_to_dense_array(ctx, p->base, out);
        if (rc >= 0)
            cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, (int)r, (int)m->cols, (int)p->m,
                        1.0, p->u, (int)r, p->w, (int)m->cols, 1.0, out, (int)r);
        return rc;
    }
    memset(out, 0, r * m->cols * sizeof(double));
    switch (m->s) {
    case BST_DIAG:
        for (size_t i = 0; i < r; i++)
            out[i * r + i] = m->diag[i];
        break;
    case BST_SPARSE: {
        const SuiteSparse_long *p = m->sp->p, *ri = m->sp->i;
        const double *x = m->sp->x;
        for (size_t j = 0; j < m->cols; j++)
            for (SuiteSparse_long q = p[j]; q < p[j + 1]; q++)
                out[j * r + (size_t)ri[q]] = x[q];
        break;
    }
    case BST_DENSE:
        for (size_t k = 0; k < r * m->cols; k++)
            out[k] = ((const float *)m->dense)[k];
        break;
    default: break;
    }
    return BST_OK;
}

int bst_mat_select_cols(bst_ctx *ctx, const bst_mat *m, size_t ncols, const size_t *cols,
                        bst_mat **out)
{
    int rc = bsti_mat_check_out(ctx, out);
    if (rc < 0)
        return rc;
    if (!m || (ncols && !cols))
        return bsti_error(ctx, BST_EINVAL, "select columns: NULL argument");
    for (size_t k = 0; k < ncols; k++)
        if (cols[k] >= m->cols)
            return bsti_error(ctx, BST_EINVAL, "select columns: column %zu of %zu", cols[k], m->cols);
    if (m->s == BST_ZERO)
        return bst_mat_new_zero(ctx, m->rows, ncols, out);
    if (m->s == BST_FACTORED) { /* each column through the factors */
        bst_mat *c;
        size_t n = m->rows;
        double *x = bsti_calloc(ctx, n + (m->lr->p + m->lr->q) * m->lr->r + 1, sizeof *x);
        if (!x)
            return BST_ENOMEM;
        if ((rc = bst_mat_new_dense(ctx, n, ncols, BST_DOUBLE, &c)) >= 0)
            for (size_t k = 0; k < ncols; k++) {
                x[cols[k]] = 1.0;
                bsti_lr_apply(m->lr, 0, x, (double *)c->dense + k * n, x + n);
                x[cols[k]] = 0.0;
            }
        bsti_free(ctx, x);
        if (rc >= 0)
            *out = c;
        return rc;
    }
    if (m->s == BST_PLUS_LR) { /* the base's columns, dense double, plus U W[cols, :]^T */
        const struct bsti_plus *p = m->plus;
        bst_mat *sel = NULL, *c = NULL;
        double *wr = bsti_alloc_array(ctx, ncols * p->m + 1, sizeof *wr);
        rc = wr ? bst_mat_select_cols(ctx, p->base, ncols, cols, &sel) : BST_ENOMEM;
        if (rc >= 0)
            rc = bsti_mat_to_dense(ctx, sel, BST_DOUBLE, &c);
        if (rc >= 0 && ncols) {
            for (size_t t = 0; t < p->m; t++)
                for (size_t k = 0; k < ncols; k++)
                    wr[t * ncols + k] = p->w[t * m->cols + cols[k]];
            cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, (int)m->rows, (int)ncols,
                        (int)p->m, 1.0, p->u, (int)m->rows, wr, (int)ncols, 1.0, c->dense,
                        (int)m->rows);
        }
        bst_mat_free(sel);
        bsti_free(ctx, wr);
        if (rc >= 0)
            *out = c;
        return rc;
    }
    if (m->s == BST_DENSE) {
        bst_mat *c;
        if ((rc = bst_mat_new_dense(ctx, m->rows, ncols, m->prec, &c)) < 0)
            return rc;
        size_t es = m->prec == BST_DOUBLE ? sizeof(double) : sizeof(float);
        for (size_t k = 0; k < ncols; k++)
            memcpy((char *)c->dense + k * m->rows * es, (const char *)m->dense + cols[k] * m->rows * es,
                   m->rows * es);
        *out = c;
        return BST_OK;
    }
    /* DIAG and SPARSE: gather the columns as triplets; a selected diagonal becomes sparse. */
    size_t nnz = 0;
    for (size_t k = 0; k < ncols; k++)
        nnz += m->s == BST_DIAG ? 1
                                : (size_t)(((SuiteSparse_long *)m->sp->p)[cols[k] + 1] -
                                           ((SuiteSparse_long *)m->sp->p)[cols[k]]);
    size_t *ri = bsti_alloc_array(ctx, 2 * nnz + 1, sizeof *ri);
    double *x = bsti_alloc_array(ctx, nnz + 1, sizeof *x);
    if (!ri || !x) {
        bsti_free(ctx, ri);
        bsti_free(ctx, x);
        return BST_ENOMEM;
    }
    size_t *ci = ri + nnz, q = 0;
    for (size_t k = 0; k < ncols; k++) {
        if (m->s == BST_DIAG) {
            ri[q] = cols[k], ci[q] = k, x[q++] = m->diag[cols[k]];
        } else {
            const SuiteSparse_long *p = m->sp->p, *mi = m->sp->i;
            const double *mx = m->sp->x;
            for (SuiteSparse_long t = p[cols[k]]; t < p[cols[k] + 1]; t++)
                ri[q] = (size_t)mi[t], ci[q] = k, x[q++] = mx[t];
        }
    }
    rc = bst_mat_new_sparse(ctx, m->rows, ncols, q, ri, ci, x, out);
    bsti_free(ctx, ri);
    bsti_free(ctx, x);
    return rc;
}

int bst_mat_all_finite(const bst_mat *m)
{
    return bsti_mat_finite(NULL, m);
}

int bsti_mat_finite(bst_ctx *ctx, const bst_mat *m)
{
    if (!m)
        return 0;
    switch (m->s) {
    case BST_DIAG:
        for (size_t i = 0; i < m->rows; i++)
            if (!isfinite(m->diag[i]))
                return 0;
        return 1;
    case BST_SPARSE: {
        const double *x = m->sp->x;
        for (size_t k = 0; k < bst_mat_nnz(m); k++)
            if (!isfinite(x[k]))
                return 0;
        return 1;
    }
    case BST_DENSE: return bsti_dense_finite(ctx, m);
    case BST_FACTORED: return bsti_lr_finite(m->lr);
    case BST_PLUS_LR:
        for (size_t k = 0; k < (m->rows + m->cols) * m->plus->m; k++)
            if (!isfinite(k < m->rows * m->plus->m ? m->plus->u[k]
                                                    : m->plus->w[k - m->rows * m->plus->m]))
                return 0;
        return bsti_mat_finite(ctx, m->plus->base);
    default: return 1;
    }
}

/* A FACTORED m's largest |value|, a block of columns at a time (bsti_cols: over a wide map by
 * GEMM), or value by value when the block's memory is not there. */
static double factored_max_abs(const bst_mat *m)
{
    double v = 0.0;
    size_t n = m->rows;
    bsti_cols *c = NULL;
    double *buf = NULL;
    if (bsti_cols_new(m->ctx, m, n, &c) >= 0 &&
        (buf = bsti_alloc_array(m->ctx, bsti_cols_block(c) * n, sizeof *buf)) != NULL) {
        for (size_t j0 = 0, nb = bsti_cols_block(c); j0 < n; j0 += nb) {
            size_t k = n - j0 < nb ? n - j0 : nb;
            bsti_cols_get(c, NULL, j0, k, buf);
            for (size_t t = 0; t < k * n; t++)
                v = fmax(v, fabs(buf[t]));
        }
    } else {
        for (size_t j = 0; j < n; j++)
            for (size_t i = 0; i < n; i++)
                v = fmax(v, fabs(bst_mat_get(m, i, j)));
    }
    bsti_free(m->ctx, buf);
    bsti_cols_free(c);
    return v;
}

double bst_mat_max_abs(const bst_mat *m)
{
    double v = 0.0;
    if (!m)
        return NAN;
    switch (m->s) {
    case BST_DIAG:
        for (size_t i = 0; i < m->rows; i++)
            v = fmax(v, fabs(m->diag[i]));
        break;
    case BST_SPARSE:
        for (size_t k = 0; k < bst_mat_nnz(m); k++)
            v = fmax(v, fabs(((const double *)m->sp->x)[k]));
        break;
    case BST_DENSE:
        for (size_t k = 0; k < m->rows * m->cols; k++)
            v = fmax(v, fabs(m->prec == BST_DOUBLE ? ((const double *)m->dense)[k]
                                                   : (double)((const float *)m->dense)[k]));
        break;
    case BST_FACTORED:
    case BST_PLUS_LR:
        v = factored_max_abs(m);
        break;
    default: break;
    }
    return v;
}
