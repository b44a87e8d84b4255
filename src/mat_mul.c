/* mat_mul.c - products of structured matrices, C = A B, by a kernel per pair of structures.
 *
 * Dispatch.  A product looks up its kernel in a table indexed by the operand structures (ZERO,
 * DIAG, SPARSE, DENSE).  Order of the lookup:
 *   1. a ZERO operand gives a ZERO result (no work);
 *   2. a DIAG operand is a row (left) or column (right) scaling of the other operand, whose
 *      structure the result keeps;
 *   3. SPARSE * SPARSE: cholmod_l_ssmult, then the drop tolerance;
 *   4. SPARSE * DENSE: A's rows times panels of B's columns, on the context's threads, O(nnz N);
 *      DENSE * SPARSE: one axpy of a dense column per non-zero of the sparse operand, O(nnz N);
 *   5. DENSE * DENSE: GEMM (OpenBLAS), in single precision when either operand is float;
 *   6. FACTORED (D + U K V^T) with FACTORED over one map, DENSE or SPARSE (made dense): mat_lowrank.c,
 *      without the factored operand's N x N values; over two maps: the generic path.
 * Every pair has a kernel; the generic fallback (both operands converted to dense, GEMM) is what
 * the tests compare each kernel with (bsti_mat_mul_generic).  Precision and workspace follow the
 * conventions of mat.c: a dense float operand makes a dense result float, and each kernel's
 * temporary memory is stated at the kernel. */
#include <config.h>

#include <math.h>
#include <string.h>

#include <cblas.h>

#include "blas_threads.h"
#include "ctx.h"
#include "mat.h"

typedef int (*mul_kernel)(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop,
                          bst_mat **out);

static int mul_zero(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out)
{
    (void)drop;
    return bst_mat_new_zero(ctx, a->rows, b->cols, out);
}

static int mul_diag_left(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out)
{
    (void)drop;
    return bsti_mat_scale(ctx, a->diag, b, NULL, out);
}

static int mul_diag_right(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out)
{
    (void)drop;
    return bsti_mat_scale(ctx, NULL, a, b->diag, out);
}

/* Workspace: CHOLMOD's, O(rows + nnz(C)). */
static int mul_sparse_sparse(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out)
{
    cholmod_common *cc = bsti_cholmod(ctx);
    if (!cc)
        return BST_ENOMEM;
    cholmod_sparse *c = cholmod_l_ssmult(a->sp, b->sp, 0, 1, 1, cc);
    if (!c)
        return bsti_mat_cholmod_failed(ctx, "ssmult");
    int rc = bsti_mat_drop(ctx, c, drop);
    if (rc < 0) {
        cholmod_l_free_sparse(&c, cc);
        return rc;
    }
    return bsti_mat_from_cholmod(ctx, c, out);
}

/* Sparse * dense by panels of SPMM_PANEL columns of B, shared out among the context's threads.
 * A panel of B is copied row-major (K x SPMM_PANEL, zero-padded), and each row i of A (A's rows:
 * CHOLMOD's transpose of it) sums its non-zeros' products a_ik B(k, panel) into SPMM_PANEL
 * contiguous accumulators, which go to row i of C's panel.  The product a column at a time over
 * A's columns scatters one value per multiply-add (3 GFLOP/s on one thread: 30 s for a mirror
 * blind's sparse transmission times a dense k = 7 matrix); here each non-zero drives a contiguous
 * run the compiler vectorizes.  C(i, j) is summed over k ascending in B's precision, as that loop
 * summed it: the same bits, on any number of threads.  Workspace: A's transpose (nnz), and per
 * thread a panel of B and a row of accumulators. */
#define SPMM_PANEL 64

struct spmm_part {
    const SuiteSparse_long *rp, *ci; /* A by rows: row i's columns ci[rp[i] .. rp[i + 1] - 1] */
    const double *v;
    const bst_mat *b;
    bst_mat *c;
    size_t p0, p1;                   /* the panels [p0, p1) */
    void *bp;                        /* K x SPMM_PANEL, row-major, B's precision */
};

static void spmm_panel_float(const struct spmm_part *t, size_t j0, size_t w)
{
    size_t K = t->b->rows, M = t->c->rows;
    const float *bd = (const float *)t->b->dense + j0 * K;
    float *bp = t->bp, *cd = (float *)t->c->dense + j0 * M;
    for (size_t k = 0; k < K; k++)
        for (size_t j = 0; j < SPMM_PANEL; j++)
            bp[k * SPMM_PANEL + j] = j < w ? bd[j * K + k] : 0.0f;
    for (size_t i = 0; i < M; i++) {
        float acc[SPMM_PANEL] = {0};
        for (SuiteSparse_long q = t->rp[i]; q < t->rp[i + 1]; q++) {
            float a = (float)t->v[q];
            const float *row = bp + (size_t)t->ci[q] * SPMM_PANEL;
            for (size_t j = 0; j < SPMM_PANEL; j++)
                acc[j] += a * row[j];
        }
        for (size_t j = 0; j < w; j++)
            cd[j * M + i] = acc[j];
    }
}

static void spmm_panel_double(const struct spmm_part *t, size_t j0, size_t w)
{
    size_t K = t->b->rows, M = t->c->rows;
    const double *bd = (const double *)t->b->dense + j0 * K;
    double *bp = t->bp, *cd = (double *)t->c->dense + j0 * M;
    for (size_t k = 0; k < K; k++)
        for (size_t j = 0; j < SPMM_PANEL; j++)
            bp[k * SPMM_PANEL + j] = j < w ? bd[j * K + k] : 0.0;
    for (size_t i = 0; i < M; i++) {
        double acc[SPMM_PANEL] = {0};
        for (SuiteSparse_long q = t->rp[i]; q < t->rp[i + 1]; q++) {
            double a = t->v[q];
            const double *row = bp + (size_t)t->ci[q] * SPMM_PANEL;
            for (size_t j = 0; j < SPMM_PANEL; j++)
                acc[j] += a * row[j];
        }
        for (size_t j = 0; j < w; j++)
            cd[j * M + i] = acc[j];
    }
}

static void *spmm_run(void *arg)
{
    const struct spmm_part *t = arg;
    size_t cols = t->b->cols;
    for (size_t p = t->p0; p < t->p1; p++) {
        size_t j0 = p * SPMM_PANEL, w = cols - j0 < SPMM_PANEL ? cols - j0 : SPMM_PANEL;
        if (t->b->prec == BST_FLOAT)
            spmm_panel_float(t, j0, w);
        else
            spmm_panel_double(t, j0, w);
    }
    return NULL;
}

static int mul_sparse_dense(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out)
{
    (void)drop;
    bst_mat *c;
    int rc = bst_mat_new_dense(ctx, a->rows, b->cols, b->prec, &c);
    if (rc < 0 || b->cols == 0 || a->rows == 0) {
        *out = rc < 0 ? NULL : c;
        return rc;
    }
    bsti_flops_add(ctx, 2.0 * (double)bst_mat_nnz(a) * (double)b->cols);
    cholmod_common *cc = bsti_cholmod(ctx);
    cholmod_sparse *at = cc ? cholmod_l_transpose(a->sp, 1, cc) : NULL;
    if (!at) {
        bst_mat_free(c);
        return cc ? bsti_mat_cholmod_failed(ctx, "transpose") : BST_ENOMEM;
    }
    size_t panels = (b->cols + SPMM_PANEL - 1) / SPMM_PANEL;
    size_t nw = (size_t)bsti_ctx_workers_no_alloc(ctx, panels);
    size_t es = b->prec == BST_FLOAT ? sizeof(float) : sizeof(double);
    char *work = bsti_alloc_array(ctx, nw * b->rows * SPMM_PANEL, es);
    if (!work) {
        cholmod_l_free_sparse(&at, cc);
        bst_mat_free(c);
        return BST_ENOMEM;
    }
    struct spmm_part part[BST_THREADS_MAX];
    for (size_t t = 0; t < nw; t++)
        part[t] = (struct spmm_part){at->p, at->i, at->x, b, c, panels * t / nw,
                                     panels * (t + 1) / nw, work + t * b->rows * SPMM_PANEL * es};
    bsti_run_parts(part, sizeof *part, nw, spmm_run);
    bsti_free(ctx, work);
    cholmod_l_free_sparse(&at, cc);
    *out = c;
    return BST_OK;
}

/* Dense * sparse: column j of C is the sum over the non-zeros B(k, j) of B(k, j) * A(:, k), one
 * axpy per non-zero, O(nnz * rows).  Workspace: the result only. */
static int mul_dense_sparse(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out)
{
    (void)drop;
    bst_mat *c;
    int rc = bst_mat_new_dense(ctx, a->rows, b->cols, a->prec, &c);
    if (rc < 0)
        return rc;
    const SuiteSparse_long *p = b->sp->p, *ri = b->sp->i;
    const double *x = b->sp->x;
    size_t r = a->rows;
    bsti_flops_add(ctx, 2.0 * (double)bst_mat_nnz(b) * (double)r);
    for (size_t j = 0; j < b->cols; j++)
        for (SuiteSparse_long q = p[j]; q < p[j + 1]; q++) {
            size_t k = (size_t)ri[q];
            if (a->prec == BST_DOUBLE)
                cblas_daxpy((int)r, x[q], (const double *)a->dense + k * r, 1,
                            (double *)c->dense + j * r, 1);
            else
                cblas_saxpy((int)r, (float)x[q], (const float *)a->dense + k * r, 1,
                            (float *)c->dense + j * r, 1);
        }
    *out = c;
    return BST_OK;
}

/* GEMM.  Mixed precision converts the double operand to float (workspace: that copy). */
static int mul_dense_dense(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out)
{
    (void)drop;
    bst_precision prec = (a->prec == BST_FLOAT || b->prec == BST_FLOAT) ? BST_FLOAT : BST_DOUBLE;
    bst_mat *ta = NULL, *tb = NULL, *c = NULL;
    int rc = BST_OK;
    if (a->prec != prec)
        rc = bsti_mat_to_dense(ctx, a, prec, &ta);
    if (rc >= 0 && b->prec != prec)
        rc = bsti_mat_to_dense(ctx, b, prec, &tb);
    if (rc >= 0)
        rc = bst_mat_new_dense(ctx, a->rows, b->cols, prec, &c);
    if (rc >= 0 && a->rows && b->cols && a->cols) {
        const bst_mat *A = ta ? ta : a, *B = tb ? tb : b;
        int m = (int)a->rows, n = (int)b->cols, k = (int)a->cols;
        bsti_flops_add(ctx, 2.0 * m * n * k);
        /* small products on one OpenBLAS thread (blas_threads.h): the same bits on any number of
         * cores, and no worker left spinning after a Klems stack */
        int big = m > n ? (m > k ? m : k) : (n > k ? n : k);
        int saved = bsti_blas_serial_begin((size_t)big);
        if (prec == BST_DOUBLE)
            cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, m, n, k, 1.0, A->dense, m,
                        B->dense, k, 0.0, c->dense, m);
        else
            cblas_sgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, m, n, k, 1.0f, A->dense, m,
                        B->dense, k, 0.0f, c->dense, m);
        bsti_blas_serial_end(saved);
    }
    bst_mat_free(ta);
    bst_mat_free(tb);
    if (rc < 0) {
        bst_mat_free(c);
        return rc;
    }
    *out = c;
    return BST_OK;
}

/* mul_table[structure of A][structure of B] */
static const mul_kernel mul_table[5][5] = {
    /*                ZERO      DIAG            SPARSE             DENSE                   FACTORED */
    /* ZERO     */ {mul_zero, mul_zero,       mul_zero,          mul_zero,               mul_zero},
    /* DIAG     */ {mul_zero, mul_diag_left,  mul_diag_left,     mul_diag_left,          mul_diag_left},
    /* SPARSE   */ {mul_zero, mul_diag_right, mul_sparse_sparse, mul_sparse_dense,       bsti_mul_lowrank_sparse},
    /* DENSE    */ {mul_zero, mul_diag_right, mul_dense_sparse,  mul_dense_dense,        bsti_mul_dense_lowrank},
    /* FACTORED */ {mul_zero, mul_diag_right, bsti_mul_lowrank_sparse, bsti_mul_lowrank_dense, bsti_mul_lowrank},
};

int bsti_mat_mul_generic(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, bst_mat **out)
{
    bst_mat *da = NULL, *db = NULL;
    int rc = bsti_mat_dense_pair(ctx, a, b, &da, &db);
    if (rc >= 0)
        rc = mul_dense_dense(ctx, da, db, 0.0, out);
    bst_mat_free(da);
    bst_mat_free(db);
    return rc;
}

int bst_mat_mul(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop_tol, bst_mat **out)
{
    int rc = bsti_mat_check_out(ctx, out);
    if (rc < 0)
        return rc;
    if (!a || !b)
        return bsti_error(ctx, BST_EINVAL, "product: NULL matrix");
    if (a->cols != b->rows)
        return bsti_error(ctx, BST_ESIZE, "product: %zu x %zu times %zu x %zu", a->rows, a->cols,
                          b->rows, b->cols);
    if (!(drop_tol >= 0.0 && drop_tol < 1.0))
        return bsti_error(ctx, BST_EINVAL, "product: drop tolerance %g is not in [0, 1)", drop_tol);
    return mul_table[a->s][b->s](ctx, a, b, drop_tol, out);
}
