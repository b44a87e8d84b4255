/* mat_add.c - sums of structured matrices, C = alpha A + beta B, by a kernel per pair of
 * structures.
 *
 * Dispatch.  A sum looks up its kernel in a table indexed by the operand structures (ZERO,
 * DIAG, SPARSE, DENSE).  Order of the lookup:
 *   1. normalize: the sum commutes, so A and B (with alpha and beta) are swapped to put the
 *      denser structure first (ZERO < DIAG < SPARSE < DENSE); only the table's entries on and
 *      below its diagonal are reached;
 *   2. ZERO + ZERO is ZERO; A + ZERO is alpha A in A's structure (ZERO is the identity);
 *   3. DIAG + DIAG stays DIAG, element by element;
 *   4. SPARSE + DIAG and SPARSE + SPARSE: cholmod_l_add, a DIAG operand copied to sparse;
 *   5. DENSE + anything: a dense copy of alpha A, then beta B added by B's structure.
 * An empty entry falls back to the generic sum (both operands converted to dense, added element
 * by element: bsti_mat_add_generic), which the tests compare the kernels with.  Precision and
 * workspace follow mat.c's conventions: a dense float operand makes a dense result float, and
 * each kernel's temporary memory is stated at the kernel. */
#include <config.h>

#include <math.h>

#include "ctx.h"
#include "mat.h"

typedef int (*add_kernel)(bst_ctx *ctx, double alpha, const bst_mat *a, double beta,
                          const bst_mat *b, bst_mat **out);

static int add_zero(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                    bst_mat **out)
{
    (void)alpha, (void)beta, (void)b;
    return bst_mat_new_zero(ctx, a->rows, a->cols, out);
}

/* alpha A, B being ZERO.  Workspace: none beyond the result. */
static int add_scaled(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                      bst_mat **out)
{
    (void)beta, (void)b;
    bst_mat *c = NULL;
    int rc;
    switch (a->s) {
    case BST_DIAG:
        if ((rc = bst_mat_new_diag(ctx, a->rows, a->diag, &c)) < 0)
            return rc;
        for (size_t i = 0; i < a->rows; i++)
            c->diag[i] *= alpha;
        break;
    case BST_SPARSE: {
        if ((rc = bsti_mat_to_sparse(ctx, a, &c)) < 0)
            return rc;
        double *x = c->sp->x;
        size_t nz = (size_t)((SuiteSparse_long *)c->sp->p)[c->cols];
        for (size_t k = 0; k < nz; k++)
            x[k] *= alpha;
        if ((rc = bsti_mat_drop(ctx, c->sp, 0.0)) < 0) { /* alpha = 0 leaves no entry */
            bst_mat_free(c);
            return rc;
        }
        break;
    }
    case BST_DENSE: {
        if ((rc = bsti_mat_to_dense(ctx, a, a->prec, &c)) < 0)
            return rc;
        size_t n = a->rows * a->cols;
        if (c->prec == BST_DOUBLE)
            for (size_t k = 0; k < n; k++)
                ((double *)c->dense)[k] *= alpha;
        else
            for (size_t k = 0; k < n; k++)
                ((float *)c->dense)[k] = (float)(((float *)c->dense)[k] * alpha);
        break;
    }
    case BST_ZERO:
        return bst_mat_new_zero(ctx, a->rows, a->cols, out);
    default: /* FACTORED has its own kernel (add_table) */
        return bsti_mat_add_generic(ctx, alpha, a, 0.0, a, out);
    }
    *out = c;
    return BST_OK;
}

static int add_diag_diag(bst_ctx *ctx, double alpha, const bst_mat *a, double beta,
                         const bst_mat *b, bst_mat **out)
{
    bst_mat *c;
    int rc = bst_mat_new_diag(ctx, a->rows, a->diag, &c);
    if (rc < 0)
        return rc;
    for (size_t i = 0; i < a->rows; i++)
        c->diag[i] = alpha * a->diag[i] + beta * b->diag[i];
    *out = c;
    return BST_OK;
}

/* A SPARSE, B DIAG or SPARSE.  Workspace: a sparse copy of a DIAG B. */
static int add_sparse(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                      bst_mat **out)
{
    cholmod_common *cc = bsti_cholmod(ctx);
    if (!cc)
        return BST_ENOMEM;
    bst_mat *sb = NULL;
    int rc = b->s == BST_SPARSE ? BST_OK : bsti_mat_to_sparse(ctx, b, &sb);
    if (rc >= 0) {
        double al[2] = {alpha, 0}, be[2] = {beta, 0};
        cholmod_sparse *c = cholmod_l_add(a->sp, sb ? sb->sp : b->sp, al, be, 1, 1, cc);
        if (!c)
            rc = bsti_mat_cholmod_failed(ctx, "add");
        else if ((rc = bsti_mat_drop(ctx, c, 0.0)) < 0)
            cholmod_l_free_sparse(&c, cc);
        else
            rc = bsti_mat_from_cholmod(ctx, c, out);
    }
    bst_mat_free(sb);
    return rc;
}

/* c[k] += v, in c's precision. */
static inline void dense_add_at(bst_mat *c, size_t k, double v)
{
    if (c->prec == BST_DOUBLE)
        ((double *)c->dense)[k] += v;
    else
        ((float *)c->dense)[k] += (float)v;
}

/* C += beta B, C dense (its precision), B any structure but FACTORED. */
static void dense_add_matrix(bst_mat *c, double beta, const bst_mat *b)
{
    size_t r = c->rows;
    switch (b->s) {
    case BST_ZERO:
        break;
    case BST_DIAG:
        for (size_t i = 0; i < r; i++)
            dense_add_at(c, i * r + i, beta * b->diag[i]);
        break;
    case BST_SPARSE: {
        const SuiteSparse_long *p = b->sp->p, *ri = b->sp->i;
        const double *x = b->sp->x;
        for (size_t j = 0; j < b->cols; j++)
            for (SuiteSparse_long q = p[j]; q < p[j + 1]; q++)
                dense_add_at(c, j * r + (size_t)ri[q], beta * x[q]);
        break;
    }
    case BST_DENSE:
        for (size_t j = 0; j < b->cols; j++)
            for (size_t i = 0; i < r; i++)
                dense_add_at(c, j * r + i, beta * bsti_dense_get(b, i, j));
        break;
    default: /* FACTORED never comes second (the table's normalization) */
        for (size_t j = 0; j < b->cols; j++)
            for (size_t i = 0; i < r; i++)
                dense_add_at(c, j * r + i, beta * bst_mat_get(b, i, j));
        break;
    }
}

/* The precision of a dense sum: float when A or a dense B is float. */
static bst_precision dense_sum_precision(const bst_mat *a, const bst_mat *b)
{
    return (a->prec == BST_FLOAT || (b->s == BST_DENSE && b->prec == BST_FLOAT)) ? BST_FLOAT
                                                                                 : BST_DOUBLE;
}

/* A DENSE, B any structure.  Workspace: the result only (A is copied into it). */
static int add_dense(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                     bst_mat **out)
{
    bst_precision prec = dense_sum_precision(a, b);
    bst_mat *c;
    int rc = bsti_mat_to_dense(ctx, a, prec, &c);
    if (rc < 0)
        return rc;
    size_t n = a->rows * a->cols;
    if (alpha != 1.0 && prec == BST_DOUBLE)
        for (size_t k = 0; k < n; k++)
            ((double *)c->dense)[k] *= alpha;
    else if (alpha != 1.0)
        for (size_t k = 0; k < n; k++)
            ((float *)c->dense)[k] = (float)(((float *)c->dense)[k] * alpha);
    dense_add_matrix(c, beta, b);
    *out = c;
    return BST_OK;
}

int bsti_mat_add_take(bst_ctx *ctx, bst_mat *a, const bst_mat *b, bst_mat **out)
{
    *out = NULL;
    if (!ctx || !a || !b) {
        bst_mat_free(a);
        return ctx ? bsti_error(ctx, BST_EINVAL, "sum: NULL matrix") : BST_EINVAL;
    }
    /* a PLUS_LR B: bst_mat_add forms A + its base as below, then adds U W^T into that (the base's
       sum is dense, so bsti_plus_settle makes it plain): the same steps in A's storage */
    const bst_mat *bb = b->s == BST_PLUS_LR ? b->plus->base : b;
    if (a->s != BST_DENSE || bb->s == BST_FACTORED || bb->s == BST_PLUS_LR || a->rows != b->rows ||
        a->cols != b->cols || dense_sum_precision(a, bb) != a->prec) { /* no storage to take */
        int rc = bst_mat_add(ctx, 1.0, a, 1.0, b, out);
        bst_mat_free(a);
        return rc;
    }
    dense_add_matrix(a, 1.0, bb);
    int rc = b->s == BST_PLUS_LR ? bsti_plus_lowrank_into(ctx, a, b) : BST_OK;
    if (rc < 0) {
        bst_mat_free(a);
        return rc;
    }
    *out = a;
    return BST_OK;
}

/* add_table[structure of A][structure of B], A the denser after normalization (step 1);
 * FACTORED counts as the densest: with ZERO, DIAG or FACTORED it stays factored (mat_lowrank.c),
 * with a SPARSE that is P K P^T over its prolongation too, with any other SPARSE or DENSE the sum
 * is dense (NULL: the generic path). */
static const add_kernel add_table[5][5] = {
    /*                ZERO              DIAG              SPARSE      DENSE      FACTORED */
    /* ZERO     */ {add_zero,         NULL,             NULL,       NULL,      NULL},
    /* DIAG     */ {add_scaled,       add_diag_diag,    NULL,       NULL,      NULL},
    /* SPARSE   */ {add_scaled,       add_sparse,       add_sparse, NULL,      NULL},
    /* DENSE    */ {add_scaled,       add_dense,        add_dense,  add_dense, NULL},
    /* FACTORED */ {bsti_add_lowrank, bsti_add_lowrank, bsti_add_lowrank, NULL, bsti_add_lowrank},
};

int bsti_mat_add_generic(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                         bst_mat **out)
{
    bst_mat *da = NULL, *db = NULL;
    int rc = bsti_mat_dense_pair(ctx, a, b, &da, &db);
    if (rc >= 0)
        rc = add_dense(ctx, alpha, da, beta, db, out);
    bst_mat_free(da);
    bst_mat_free(db);
    return rc;
}

int bst_mat_add(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                bst_mat **out)
{
    int rc = bsti_mat_check_out(ctx, out);
    if (rc < 0)
        return rc;
    if (!a || !b)
        return bsti_error(ctx, BST_EINVAL, "sum: NULL matrix");
    if (a->rows != b->rows || a->cols != b->cols)
        return bsti_error(ctx, BST_ESIZE, "sum: %zu x %zu plus %zu x %zu", a->rows, a->cols,
                          b->rows, b->cols);
    if (!isfinite(alpha) || !isfinite(beta))
        return bsti_error(ctx, BST_EINVAL, "sum: non-finite coefficient");
    if (a->s == BST_PLUS_LR || b->s == BST_PLUS_LR) /* the bases' sum, the thin parts joined */
        return bsti_add_plus(ctx, alpha, a, beta, b, out);
    if (a->s < b->s) { /* 1. the denser operand first */
        const bst_mat *t = a;
        a = b, b = t;
        double s = alpha;
        alpha = beta, beta = s;
    }
    add_kernel k = add_table[a->s][b->s];
    return k ? k(ctx, alpha, a, beta, b, out) : bsti_mat_add_generic(ctx, alpha, a, beta, b, out);
}
