/* mat.c - the structured-matrix algebra: construction, conversion and scaling; transposes, column
 * sums, exports and checks are in mat_ops.c, products and sums (each with its dispatch table) in
 * mat_mul.c and mat_add.c, the FACTORED structure's kernels in mat_lowrank.c.
 *
 * Precision: sparse and diagonal storage are double.  A dense float operand makes a dense result
 * float (single precision is the user's choice for a whole stack); otherwise results are double.
 *
 * Workspace: each kernel's temporary memory is stated at the kernel.  No kernel copies an operand
 * except where noted (mixed precision GEMM converts the double operand to float). */
#include <config.h>

#include <math.h>
#include <string.h>

#include <cblas.h>

#include "ctx.h"
#include "mat.h"

/* ------------------------------------------------------------------ objects */

int bsti_mat_alloc(bst_ctx *ctx, bst_structure s, bst_precision prec, size_t rows, size_t cols,
                   bst_mat **out)
{
    bst_mat *m = bsti_calloc(ctx, 1, sizeof *m);
    if (!m)
        return BST_ENOMEM;
    m->ctx = ctx;
    m->s = s;
    m->prec = s == BST_DENSE ? prec : BST_DOUBLE;
    m->rows = rows;
    m->cols = cols;
    *out = m;
    return BST_OK;
}

void bst_mat_free(bst_mat *m)
{
    if (!m)
        return;
    bst_ctx *ctx = m->ctx;
    if (m->sp) {
        cholmod_common *cc = bsti_cholmod(ctx);
        if (cc)
            cholmod_l_free_sparse(&m->sp, cc);
    }
    bsti_free(ctx, m->diag);
    bsti_free(ctx, m->dense);
    bsti_lr_free(ctx, m->lr);
    if (m->plus) {
        bst_mat_free(m->plus->base);
        bsti_free(ctx, m->plus->u), bsti_free(ctx, m->plus->w), bsti_free(ctx, m->plus);
    }
    bsti_free(ctx, m);
}

int bsti_mat_check_out(bst_ctx *ctx, bst_mat **out)
{
    if (!ctx)
        return BST_EINVAL;
    if (!out)
        return bsti_error(ctx, BST_EINVAL, "matrix: NULL result pointer");
    *out = NULL;
    return BST_OK;
}

int bst_mat_new_zero(bst_ctx *ctx, size_t rows, size_t cols, bst_mat **out)
{
    int rc = bsti_mat_check_out(ctx, out);
    return rc < 0 ? rc : bsti_mat_alloc(ctx, BST_ZERO, BST_DOUBLE, rows, cols, out);
}

int bst_mat_new_diag(bst_ctx *ctx, size_t n, const double *diag, bst_mat **out)
{
    int rc = bsti_mat_check_out(ctx, out);
    if (rc < 0)
        return rc;
    if (!diag)
        return bsti_error(ctx, BST_EINVAL, "matrix: NULL diagonal");
    bst_mat *m;
    if ((rc = bsti_mat_alloc(ctx, BST_DIAG, BST_DOUBLE, n, n, &m)) < 0)
        return rc;
    if (!(m->diag = bsti_alloc_array(ctx, n, sizeof *m->diag))) {
        bst_mat_free(m);
        return BST_ENOMEM;
    }
    memcpy(m->diag, diag, n * sizeof *diag);
    *out = m;
    return BST_OK;
}

/* bst_mat_new_dense, its values zero (zeroed) or left as they are (raw). */
static int new_dense(bst_ctx *ctx, size_t rows, size_t cols, bst_precision prec, int zeroed,
                     bst_mat **out)
{
    int rc = bsti_mat_check_out(ctx, out);
    if (rc < 0)
        return rc;
    if (prec != BST_DOUBLE && prec != BST_FLOAT)
        return bsti_error(ctx, BST_EINVAL, "matrix: unknown precision %d", (int)prec);
    size_t n;
    if (bsti_size_mul(rows, cols, &n))
        return bsti_error(ctx, BST_ENOMEM, "matrix: %zu x %zu is too large", rows, cols);
    bst_mat *m;
    if ((rc = bsti_mat_alloc(ctx, BST_DENSE, prec, rows, cols, &m)) < 0)
        return rc;
    size_t es = prec == BST_DOUBLE ? sizeof(double) : sizeof(float);
    if (!(m->dense = zeroed ? bsti_calloc(ctx, n, es) : bsti_alloc_array(ctx, n, es))) {
        bst_mat_free(m);
        return BST_ENOMEM;
    }
    if (!zeroed && ctx->poison_raw) /* the tests' check that every value is written */
        for (size_t k = 0; k < n; k++) {
            if (prec == BST_DOUBLE)
                ((double *)m->dense)[k] = NAN;
            else
                ((float *)m->dense)[k] = NAN;
        }
    *out = m;
    return BST_OK;
}

int bst_mat_new_dense(bst_ctx *ctx, size_t rows, size_t cols, bst_precision prec, bst_mat **out)
{
    return new_dense(ctx, rows, cols, prec, 1, out);
}

int bsti_mat_new_dense_raw(bst_ctx *ctx, size_t rows, size_t cols, bst_precision prec, bst_mat **out)
{
    return new_dense(ctx, rows, cols, prec, 0, out);
}

int bsti_mat_from_cholmod(bst_ctx *ctx, cholmod_sparse *sp, bst_mat **out)
{
    bst_mat *m;
    int rc = bsti_mat_alloc(ctx, BST_SPARSE, BST_DOUBLE, sp->nrow, sp->ncol, &m);
    if (rc < 0) {
        cholmod_l_free_sparse(&sp, bsti_cholmod(ctx));
        return rc;
    }
    m->sp = sp;
    *out = m;
    return BST_OK;
}

int bsti_mat_cholmod_failed(bst_ctx *ctx, const char *what)
{
    cholmod_common *cc = bsti_cholmod(ctx);
    if (cc && cc->status == CHOLMOD_OUT_OF_MEMORY)
        return bsti_error(ctx, BST_ENOMEM, "out of memory (CHOLMOD %s)", what);
    return bsti_error(ctx, BST_EINTERNAL, "CHOLMOD %s failed (status %d)", what, cc ? cc->status : 0);
}

/* Remove entries |x| <= drop * max|x| from a sparse result (drop = 0: exact zeros only). */
int bsti_mat_drop(bst_ctx *ctx, cholmod_sparse *sp, double drop)
{
    cholmod_common *cc = bsti_cholmod(ctx);
    double tol = 0.0;
    if (drop > 0.0) {
        const double *x = sp->x;
        size_t nz = (size_t)((SuiteSparse_long *)sp->p)[sp->ncol];
        for (size_t k = 0; k < nz; k++)
            tol = fmax(tol, fabs(x[k]));
        tol *= drop;
    }
    return cholmod_l_drop(tol, sp, cc) ? BST_OK : bsti_mat_cholmod_failed(ctx, "drop");
}

int bst_mat_new_sparse(bst_ctx *ctx, size_t rows, size_t cols, size_t nnz, const size_t *row,
                       const size_t *col, const double *val, bst_mat **out)
{
    int rc = bsti_mat_check_out(ctx, out);
    if (rc < 0)
        return rc;
    if (nnz && (!row || !col || !val))
        return bsti_error(ctx, BST_EINVAL, "matrix: NULL triplet arrays");
    for (size_t k = 0; k < nnz; k++) {
        if (row[k] >= rows || col[k] >= cols)
            return bsti_error(ctx, BST_EINVAL, "matrix: triplet %zu (%zu, %zu) outside %zu x %zu",
                              k, row[k], col[k], rows, cols);
        if (!isfinite(val[k]))
            return bsti_error(ctx, BST_EINVAL, "matrix: triplet %zu has a non-finite value", k);
    }
    cholmod_common *cc = bsti_cholmod(ctx);
    if (!cc)
        return BST_ENOMEM;
    cholmod_triplet *t = cholmod_l_allocate_triplet(rows, cols, nnz, 0, CHOLMOD_REAL, cc);
    if (!t)
        return bsti_mat_cholmod_failed(ctx, "allocate_triplet");
    SuiteSparse_long *ti = t->i, *tj = t->j;
    double *tx = t->x;
    for (size_t k = 0; k < nnz; k++) {
        ti[k] = (SuiteSparse_long)row[k];
        tj[k] = (SuiteSparse_long)col[k];
        tx[k] = val[k];
    }
    t->nnz = nnz;
    cholmod_sparse *sp = cholmod_l_triplet_to_sparse(t, nnz, cc); /* sums duplicates, sorted */
    cholmod_l_free_triplet(&t, cc);
    if (!sp)
        return bsti_mat_cholmod_failed(ctx, "triplet_to_sparse");
    if (!cholmod_l_drop(0.0, sp, cc)) {
        cholmod_l_free_sparse(&sp, cc);
        return bsti_mat_cholmod_failed(ctx, "drop");
    }
    return bsti_mat_from_cholmod(ctx, sp, out);
}

bst_structure bst_mat_structure(const bst_mat *m) { return m ? m->s : BST_ZERO; }
bst_precision bst_mat_precision(const bst_mat *m) { return m ? m->prec : BST_DOUBLE; }
size_t bst_mat_rows(const bst_mat *m) { return m ? m->rows : 0; }
size_t bst_mat_cols(const bst_mat *m) { return m ? m->cols : 0; }

size_t bst_mat_nnz(const bst_mat *m)
{
    if (!m)
        return 0;
    switch (m->s) {
    case BST_DIAG: return m->rows;
    case BST_SPARSE: return (size_t)((SuiteSparse_long *)m->sp->p)[m->cols];
    case BST_DENSE: return m->rows * m->cols;
    case BST_FACTORED: return bsti_lr_stored(m->lr);
    case BST_PLUS_LR: return bst_mat_nnz(m->plus->base) + (m->rows + m->cols) * m->plus->m;
    default: return 0;
    }
}

double bst_mat_get(const bst_mat *m, size_t i, size_t j)
{
    if (!m || i >= m->rows || j >= m->cols)
        return NAN;
    switch (m->s) {
    case BST_DIAG: return i == j ? m->diag[i] : 0.0;
    case BST_DENSE: return bsti_dense_get(m, i, j);
    case BST_SPARSE: {
        const SuiteSparse_long *p = m->sp->p, *ri = m->sp->i;
        const double *x = m->sp->x;
        SuiteSparse_long lo = p[j], hi = p[j + 1];
        while (lo < hi) { /* row indices are sorted */
            SuiteSparse_long mid = lo + (hi - lo) / 2;
            if ((size_t)ri[mid] == i)
                return x[mid];
            if ((size_t)ri[mid] < i)
                lo = mid + 1;
            else
                hi = mid;
        }
        return 0.0;
    }
    case BST_FACTORED: return bsti_lr_get(m->lr, i, j);
    case BST_PLUS_LR: return bsti_plus_get(m, i, j);
    default: return 0.0;
    }
}

void *bst_mat_dense_data(bst_mat *m) { return (m && m->s == BST_DENSE) ? m->dense : NULL; }
double *bst_mat_diag_data(bst_mat *m) { return (m && m->s == BST_DIAG) ? m->diag : NULL; }

/* ------------------------------------------------------------------ conversion */

/* Dense copy of any matrix in precision prec.  Workspace: the result only. */
int bsti_mat_to_dense(bst_ctx *ctx, const bst_mat *m, bst_precision prec, bst_mat **out)
{
    if (bsti_mat_lr_wide(m)) /* by GEMM: through the factors each value costs a row's entries^2 */
        return bsti_mat_lr_expand(ctx, m, prec, out);
    if (m->s == BST_PLUS_LR)
        return bsti_plus_to_dense(ctx, m, prec, out);
    bst_mat *d;
    int rc = bst_mat_new_dense(ctx, m->rows, m->cols, prec, &d);
    if (rc < 0)
        return rc;
    size_t r = m->rows;
    double *dd = prec == BST_DOUBLE ? d->dense : NULL;
    float *df = prec == BST_FLOAT ? d->dense : NULL;
#define PUT(i, j, v) (dd ? (void)(dd[(j) * r + (i)] = (v)) : (void)(df[(j) * r + (i)] = (float)(v)))
    switch (m->s) {
    case BST_ZERO:
    case BST_PLUS_LR: /* above */
        break;
    case BST_DIAG:
        for (size_t i = 0; i < r; i++)
            PUT(i, i, m->diag[i]);
        break;
    case BST_SPARSE: {
        const SuiteSparse_long *p = m->sp->p, *ri = m->sp->i;
        const double *x = m->sp->x;
        for (size_t j = 0; j < m->cols; j++)
            for (SuiteSparse_long k = p[j]; k < p[j + 1]; k++)
                PUT((size_t)ri[k], j, x[k]);
        break;
    }
    case BST_FACTORED:
        if (dd) {
            bsti_lr_to_dense(m->lr, dd);
        } else { /* through a double copy, column by column (no N x N double array) */
            double *x = bsti_calloc(ctx, 2 * r + (m->lr->p + m->lr->q) * m->lr->r + 1, sizeof *x);
            if (!x) {
                bst_mat_free(d);
                return BST_ENOMEM;
            }
            for (size_t j = 0; j < m->cols; j++) {
                x[j] = 1.0;
                bsti_lr_apply(m->lr, 0, x, x + r, x + 2 * r);
                x[j] = 0.0;
                for (size_t i = 0; i < r; i++)
                    df[j * r + i] = (float)x[r + i];
            }
            bsti_free(ctx, x);
        }
        break;
    case BST_DENSE:
        if (m->prec == prec)
            memcpy(d->dense, m->dense, r * m->cols * (prec == BST_DOUBLE ? sizeof(double) : sizeof(float)));
        else
            for (size_t k = 0; k < r * m->cols; k++) {
                if (dd)
                    dd[k] = ((const float *)m->dense)[k];
                else
                    df[k] = (float)((const double *)m->dense)[k];
            }
        break;
    }
#undef PUT
    *out = d;
    return BST_OK;
}

int bsti_mat_to_sparse(bst_ctx *ctx, const bst_mat *m, bst_mat **out)
{
    cholmod_common *cc = bsti_cholmod(ctx);
    if (!cc)
        return BST_ENOMEM;
    if (m->s == BST_SPARSE) {
        cholmod_sparse *c = cholmod_l_copy_sparse(m->sp, cc);
        return c ? bsti_mat_from_cholmod(ctx, c, out) : bsti_mat_cholmod_failed(ctx, "copy_sparse");
    }
    if (m->s == BST_FACTORED || m->s == BST_PLUS_LR) { /* its values through a dense copy */
        bst_mat *d;
        int rc = bsti_mat_to_dense(ctx, m, BST_DOUBLE, &d);
        if (rc >= 0)
            rc = bsti_mat_to_sparse(ctx, d, out);
        bst_mat_free(d);
        return rc;
    }
    size_t nnz = 0;
    if (m->s == BST_DIAG)
        for (size_t i = 0; i < m->rows; i++)
            nnz += m->diag[i] != 0.0;
    else if (m->s == BST_DENSE)
        for (size_t j = 0; j < m->cols; j++)
            for (size_t i = 0; i < m->rows; i++)
                nnz += bsti_dense_get(m, i, j) != 0.0;
    cholmod_sparse *sp = cholmod_l_allocate_sparse(m->rows, m->cols, nnz, 1, 1, 0, CHOLMOD_REAL, cc);
    if (!sp)
        return bsti_mat_cholmod_failed(ctx, "allocate_sparse");
    SuiteSparse_long *p = sp->p, *ri = sp->i;
    double *x = sp->x;
    size_t k = 0;
    for (size_t j = 0; j < m->cols; j++) {
        p[j] = (SuiteSparse_long)k;
        if (m->s == BST_DIAG) {
            if (j < m->rows && m->diag[j] != 0.0)
                ri[k] = (SuiteSparse_long)j, x[k++] = m->diag[j];
        } else if (m->s == BST_DENSE) {
            for (size_t i = 0; i < m->rows; i++) {
                double v = bsti_dense_get(m, i, j);
                if (v != 0.0)
                    ri[k] = (SuiteSparse_long)i, x[k++] = v;
            }
        }
    }
    p[m->cols] = (SuiteSparse_long)k;
    return bsti_mat_from_cholmod(ctx, sp, out);
}

int bsti_mat_dense_pair(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, bst_mat **da,
                        bst_mat **db)
{
    bst_precision prec = ((a->s == BST_DENSE && a->prec == BST_FLOAT) ||
                          (b->s == BST_DENSE && b->prec == BST_FLOAT)) ? BST_FLOAT : BST_DOUBLE;
    *da = *db = NULL;
    int rc = bsti_mat_to_dense(ctx, a, prec, da);
    return rc < 0 ? rc : bsti_mat_to_dense(ctx, b, prec, db);
}

/* Count of non-zeros and whether every non-zero lies on the diagonal. */
static void census(const bst_mat *m, size_t *nnz, int *diag_only)
{
    *nnz = 0;
    *diag_only = m->rows == m->cols;
    switch (m->s) {
    case BST_ZERO: break;
    case BST_DIAG:
        for (size_t i = 0; i < m->rows; i++)
            *nnz += m->diag[i] != 0.0;
        break;
    case BST_SPARSE: {
        const SuiteSparse_long *p = m->sp->p, *ri = m->sp->i;
        const double *x = m->sp->x;
        for (size_t j = 0; j < m->cols; j++)
            for (SuiteSparse_long k = p[j]; k < p[j + 1]; k++)
                if (x[k] != 0.0) {
                    ++*nnz;
                    if ((size_t)ri[k] != j)
                        *diag_only = 0;
                }
        break;
    }
    case BST_DENSE:
        for (size_t j = 0; j < m->cols; j++)
            for (size_t i = 0; i < m->rows; i++)
                if (bsti_dense_get(m, i, j) != 0.0) {
                    ++*nnz;
                    if (i != j)
                        *diag_only = 0;
                }
        break;
    default: /* FACTORED is converted through its values before (bst_mat_convert) */
        *nnz = m->rows * m->cols, *diag_only = 0;
        break;
    }
}

int bst_mat_convert(bst_ctx *ctx, const bst_mat *m, bst_structure s, bst_precision prec,
                    bst_mat **out)
{
    int rc = bsti_mat_check_out(ctx, out);
    if (rc < 0)
        return rc;
    if (!m)
        return bsti_error(ctx, BST_EINVAL, "convert: NULL matrix");
    if (m->s == BST_FACTORED && s == BST_FACTORED) {
        bsti_lr *lr;
        return (rc = bsti_lr_copy(ctx, m->lr, &lr)) < 0 ? rc : bsti_mat_from_lr(ctx, lr, out);
    }
    if (s == BST_FACTORED)
        return bsti_error(ctx, BST_EINVAL, "convert: a factored form is made from a layer's coarse "
                          "information, not from values");
    if (m->s == BST_PLUS_LR && s == BST_PLUS_LR)
        return bsti_plus_copy(ctx, m, out);
    if (s == BST_PLUS_LR)
        return bsti_error(ctx, BST_EINVAL, "convert: a sparse plus low-rank form is made from a "
                          "layer's parts, not from values");
    if ((m->s == BST_FACTORED || m->s == BST_PLUS_LR) && s != BST_DENSE) { /* through its values */
        bst_mat *d;
        rc = bsti_mat_to_dense(ctx, m, BST_DOUBLE, &d);
        if (rc >= 0)
            rc = bst_mat_convert(ctx, d, s, prec, out);
        bst_mat_free(d);
        return rc;
    }
    size_t nnz;
    int diag_only;
    switch (s) {
    case BST_ZERO:
        census(m, &nnz, &diag_only);
        if (nnz)
            return bsti_error(ctx, BST_EINVAL, "convert: the matrix has %zu non-zeros, it is not zero", nnz);
        return bst_mat_new_zero(ctx, m->rows, m->cols, out);
    case BST_DIAG: {
        census(m, &nnz, &diag_only);
        if (!diag_only)
            return bsti_error(ctx, BST_EINVAL, "convert: the matrix has off-diagonal non-zeros");
        bst_mat *d;
        if ((rc = bsti_mat_alloc(ctx, BST_DIAG, BST_DOUBLE, m->rows, m->cols, &d)) < 0)
            return rc;
        if (!(d->diag = bsti_alloc_array(ctx, m->rows, sizeof(double)))) {
            bst_mat_free(d);
            return BST_ENOMEM;
        }
        for (size_t i = 0; i < m->rows; i++)
            d->diag[i] = bst_mat_get(m, i, i);
        *out = d;
        return BST_OK;
    }
    case BST_SPARSE: return bsti_mat_to_sparse(ctx, m, out);
    case BST_DENSE: return bsti_mat_to_dense(ctx, m, prec, out);
    default: break;
    }
    return bsti_error(ctx, BST_EINVAL, "convert: unknown structure %d", (int)s);
}

int bst_mat_compact(bst_ctx *ctx, const bst_mat *m, double sparse_max_fill, bst_mat **out)
{
    int rc = bsti_mat_check_out(ctx, out);
    if (rc < 0)
        return rc;
    if (!m)
        return bsti_error(ctx, BST_EINVAL, "compact: NULL matrix");
    if (!(sparse_max_fill >= 0.0 && sparse_max_fill <= 1.0))
        return bsti_error(ctx, BST_EINVAL, "compact: fill fraction %g is not in [0, 1]", sparse_max_fill);
    if (m->s == BST_FACTORED || m->s == BST_PLUS_LR) /* already the structure of its information */
        return bst_mat_convert(ctx, m, m->s, m->prec, out);
    size_t nnz;
    int diag_only;
    census(m, &nnz, &diag_only);
    if (nnz == 0)
        return bst_mat_new_zero(ctx, m->rows, m->cols, out);
    if (diag_only)
        return bst_mat_convert(ctx, m, BST_DIAG, BST_DOUBLE, out);
    if ((double)nnz <= sparse_max_fill * (double)m->rows * (double)m->cols)
        return bsti_mat_to_sparse(ctx, m, out);
    return bsti_mat_to_dense(ctx, m, m->s == BST_DENSE ? m->prec : BST_DOUBLE, out);
}

/* ------------------------------------------------------------------ scaling */

/* C = diag(dr) A diag(dc), same structure as A.  Workspace: the result only. */
/* c := diag(dr) c diag(dc) in c's own storage (either NULL = identity); the one loop that both
 * bsti_mat_scale and bsti_mat_scale_take run, so that scaling a copy and scaling in place give
 * the same bits. */
static void scale_values(bst_mat *c, const double *dr, const double *dc)
{
    switch (c->s) {
    case BST_DIAG:
        for (size_t i = 0; i < c->rows; i++)
            c->diag[i] *= (dr ? dr[i] : 1.0) * (dc ? dc[i] : 1.0);
        break;
    case BST_SPARSE: {
        const SuiteSparse_long *p = c->sp->p, *ri = c->sp->i;
        double *x = c->sp->x;
        for (size_t j = 0; j < c->cols; j++)
            for (SuiteSparse_long k = p[j]; k < p[j + 1]; k++)
                x[k] *= (dr ? dr[ri[k]] : 1.0) * (dc ? dc[j] : 1.0);
        break;
    }
    case BST_DENSE: {
        size_t r = c->rows;
        for (size_t j = 0; j < c->cols; j++) {
            double s = dc ? dc[j] : 1.0;
            if (c->prec == BST_DOUBLE) {
                double *col = (double *)c->dense + j * r;
                for (size_t i = 0; i < r; i++)
                    col[i] *= (dr ? dr[i] : 1.0) * s;
            } else {
                float *col = (float *)c->dense + j * r;
                for (size_t i = 0; i < r; i++)
                    col[i] = (float)(col[i] * (dr ? dr[i] : 1.0) * s);
            }
        }
        break;
    }
    default: break;
    }
}

int bsti_mat_scale(bst_ctx *ctx, const double *dr, const bst_mat *a, const double *dc, bst_mat **out)
{
    bst_mat *c;
    int rc;
    switch (a->s) {
    case BST_ZERO: return bst_mat_new_zero(ctx, a->rows, a->cols, out);
    case BST_DIAG: rc = bst_mat_new_diag(ctx, a->rows, a->diag, &c); break;
    case BST_SPARSE: rc = bsti_mat_to_sparse(ctx, a, &c); break;
    case BST_DENSE: rc = bsti_mat_to_dense(ctx, a, a->prec, &c); break;
    case BST_FACTORED: {
        bsti_lr *lr;
        return (rc = bsti_lr_scale(ctx, dr, a->lr, dc, &lr)) < 0 ? rc : bsti_mat_from_lr(ctx, lr, out);
    }
    case BST_PLUS_LR: return bsti_plus_scale(ctx, dr, a, dc, out);
    default: return bsti_error(ctx, BST_EINVAL, "scale: unknown structure");
    }
    if (rc < 0)
        return rc;
    scale_values(c, dr, dc);
    *out = c;
    return BST_OK;
}

int bsti_mat_scale_take(bst_ctx *ctx, const double *dr, bst_mat *a, const double *dc, bst_mat **out)
{
    if (a->s == BST_FACTORED) { /* its diagonal and scalings; K as it is */
        bsti_lr_scale_take(dr, a->lr, dc);
        *out = a;
        return BST_OK;
    }
    if (a->s == BST_DIAG || a->s == BST_DENSE) {
        scale_values(a, dr, dc);
        *out = a;
        return BST_OK;
    }
    int rc = bsti_mat_scale(ctx, dr, a, dc, out);
    bst_mat_free(a);
    return rc;
}

int bst_mat_scale(bst_ctx *ctx, const double *d_rows, const bst_mat *a, const double *d_cols,
                  bst_mat **out)
{
    int rc = bsti_mat_check_out(ctx, out);
    if (rc < 0)
        return rc;
    if (!a)
        return bsti_error(ctx, BST_EINVAL, "scale: NULL matrix");
    return bsti_mat_scale(ctx, d_rows, a, d_cols, out);
}
