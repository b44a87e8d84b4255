/* mirror_mul.c - products with a mirror-split inverse, its halves kept (mirror.h).
 *
 * The inverse (I - A)^-1 of a mirror-symmetric stack, formed in halves (P^-1 and M^-1 in the
 * matrix's own storage, solve.c), multiplies sparse right-hand sides that have the symmetry too
 * (the second step of pane + blind + pane: the first pair's transmission and back reflection),
 * and the thin factors of a low-rank part, which need not.  A product of two matrices that commute
 * with S splits like each of them, (X B)_P = X_P B_P and (X B)_M = X_M B_M, so that a product
 * with the halves costs half the product with the whole inverse (two of n / 2 x n / 2 by a half
 * of B's values each), and the result is joined as the inverse would have been (its P in the
 * top-left quarter, its M in the bottom-right, in S's order).  B's halves come from its columns
 * of the first half, B_P(p, q) = B(p, q) + B(S p, q) and B_M(p, q) = B(p, q) - B(S p, q), after
 * every value was checked against its mirror image to the solve's tolerance (mirror.h): a B
 * without the symmetry is left to the whole inverse (BSTI_MIRROR_ASYM).  Thin operands (n x m or
 * m x n) are split by rows (or columns), multiplied by the halves (GEMM) and joined.
 * A y-mirror stack's inverse was turned over the diagonal (bsti_mirror_turn, Q): B is read as
 * Q B Q and the result turned back. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <string.h>

#include <cblas.h>

#include "ctx.h"
#include "mat.h"
#include "mirror.h"

/* B(row, col) of a sorted, packed CHOLMOD matrix (0 where none is stored). */
static double value_at(const cholmod_sparse *b, size_t row, size_t col)
{
    const SuiteSparse_long *p = b->p, *i = b->i;
    const double *x = b->x;
    SuiteSparse_long lo = p[col], hi = p[col + 1] - 1, r = (SuiteSparse_long)row;
    while (lo <= hi) {
        SuiteSparse_long mid = lo + (hi - lo) / 2;
        if (i[mid] == r)
            return x[mid];
        if (i[mid] < r)
            lo = mid + 1;
        else
            hi = mid - 1;
    }
    return 0.0;
}

/* Whether every value of b agrees with its mirror image (the axis's) to tol of the largest: the
 * largest, then the comparisons, each over runs of columns on the threads ctx allows (NULL: one);
 * the answer does not depend on their number. */
#define HOLDS_MIN_COLS 256
struct holds_part {
    const cholmod_sparse *b;
    size_t g, j0, j1;
    int axis;
    double t;   /* the comparisons' tolerance, or NaN: find the largest value */
    double big; /* the run's largest magnitude (+Inf for a value that is not finite) */
    int ok;     /* every value of the run agrees with its image */
};

static void *holds_run(void *opaque)
{
    struct holds_part *h = opaque;
    const SuiteSparse_long *p = h->b->p, *i = h->b->i;
    const double *x = h->b->x;
    if (isnan(h->t)) {
        double big = 0.0;
        for (SuiteSparse_long q = p[h->j0]; q < p[h->j1]; q++) {
            double v = fabs(x[q]);
            big = !(v <= DBL_MAX) ? INFINITY : v > big ? v : big;
        }
        h->big = big;
        return NULL;
    }
    h->ok = 1;
    for (size_t j = h->j0; j < h->j1 && h->ok; j++) {
        size_t sj = bsti_mirror_image(h->g, j, h->axis);
        for (SuiteSparse_long q = p[j]; q < p[j + 1]; q++)
            if (fabs(x[q] - value_at(h->b, bsti_mirror_image(h->g, (size_t)i[q], h->axis), sj)) >
                h->t) {
                h->ok = 0;
                break;
            }
    }
    return NULL;
}

static int sparse_holds(bst_ctx *ctx, const cholmod_sparse *b, size_t g, int axis, double tol)
{
    size_t n = b->ncol, nt = ctx ? (size_t)bsti_ctx_workers_no_alloc(ctx, n / HOLDS_MIN_COLS) : 1;
    struct holds_part part[BST_THREADS_MAX];
    if (nt < 1)
        nt = 1;
    for (size_t k = 0; k < nt; k++)
        part[k] = (struct holds_part){b, g, n * k / nt, n * (k + 1) / nt, axis, NAN, 0.0, 0};
    bsti_run_parts(part, sizeof *part, nt, holds_run);
    double big = 0.0;
    for (size_t k = 0; k < nt; k++)
        big = part[k].big > big ? part[k].big : big;
    if (!(big <= DBL_MAX))
        return 0;
    for (size_t k = 0; k < nt; k++)
        part[k].t = tol * big;
    bsti_run_parts(part, sizeof *part, nt, holds_run);
    int ok = 1;
    for (size_t k = 0; k < nt; k++)
        ok &= part[k].ok;
    return ok;
}

/* Where value (row, column j) of a matrix that commutes with the mirror goes in its split: for a
 * column whose image (Q j when turned, else j) lies in the first half, 1 or -1 (the sign it takes
 * in M) with its place in P, (*pr, *pc), both in the first half, and in M, (*mr, *mc) = (S *pr,
 * S *pc), both in the second; 0 for any other column (its values are its image's). */
static int split_place(size_t g, int turn, size_t j, size_t row, size_t *pr, size_t *pc, size_t *mr,
                       size_t *mc)
{
    size_t h = g * g / 2, col = turn ? bsti_mirror_turned(g, j) : j;
    if (col >= h)
        return 0;
    int sign = 1;
    row = turn ? bsti_mirror_turned(g, row) : row;
    if (row >= h)
        row = bsti_mirror_image(g, row, 0), sign = -1;
    *pr = row, *pc = col;
    *mr = bsti_mirror_image(g, row, 0), *mc = bsti_mirror_image(g, col, 0);
    return sign;
}

/* B's halves P and M (n/2 x n/2, in the split's orders: P by pair p, M by S p - n/2) from its
 * columns j whose image Q j (turned) or j lies in the first half; by_rows: their transposes (a
 * right product's lines are B's rows). */
static int sparse_halves(bst_ctx *ctx, const cholmod_sparse *b, size_t g, int turn, int by_rows,
                         cholmod_sparse **hp, cholmod_sparse **hm)
{
    cholmod_common *cc = bsti_cholmod(ctx);
    if (!cc)
        return BST_ENOMEM;
    const SuiteSparse_long *p = b->p, *i = b->i;
    const double *x = b->x;
    size_t n = b->ncol, h = n / 2, nz = 0;
    for (size_t j = 0; j < n; j++)
        if ((turn ? bsti_mirror_turned(g, j) : j) < h)
            nz += (size_t)(p[j + 1] - p[j]);
    cholmod_triplet *tp = cholmod_l_allocate_triplet(h, h, nz, 0, CHOLMOD_REAL, cc);
    cholmod_triplet *tm = cholmod_l_allocate_triplet(h, h, nz, 0, CHOLMOD_REAL, cc);
    if (!tp || !tm) {
        cholmod_l_free_triplet(&tp, cc), cholmod_l_free_triplet(&tm, cc);
        return bsti_mat_cholmod_failed(ctx, "allocate_triplet");
    }
    SuiteSparse_long *pi = tp->i, *pj = tp->j, *mi = tm->i, *mj = tm->j;
    double *px = tp->x, *mx = tm->x;
    size_t k = 0;
    for (size_t j = 0; j < n; j++)
        for (SuiteSparse_long q = p[j]; q < p[j + 1]; q++) {
            size_t row, col, mrow, mcol;
            int sign = split_place(g, turn, j, (size_t)i[q], &row, &col, &mrow, &mcol);
            if (!sign) /* a column of the second half: its values are its image's */
                break;
            mrow -= h, mcol -= h;
            pi[k] = (SuiteSparse_long)(by_rows ? col : row);
            pj[k] = (SuiteSparse_long)(by_rows ? row : col);
            mi[k] = (SuiteSparse_long)(by_rows ? mcol : mrow);
            mj[k] = (SuiteSparse_long)(by_rows ? mrow : mcol);
            px[k] = x[q], mx[k] = sign * x[q];
            k++;
        }
    tp->nnz = tm->nnz = k;
    *hp = cholmod_l_triplet_to_sparse(tp, k, cc);
    *hm = *hp ? cholmod_l_triplet_to_sparse(tm, k, cc) : NULL;
    cholmod_l_free_triplet(&tp, cc), cholmod_l_free_triplet(&tm, cc);
    if (!*hp || !*hm) {
        cholmod_l_free_sparse(hp, cc), cholmod_l_free_sparse(hm, cc);
        return bsti_mat_cholmod_failed(ctx, "triplet_to_sparse");
    }
    return BST_OK;
}

/* The two quarters the halves take (top-left, bottom-right) cleared, runs of their columns on the
 * threads ctx allows: the first touch of a fresh block's pages (half of a 1 GiB I - A at k = 7)
 * is most of the split's time, and faults on two threads go faster than on one. */
#define ZERO_MIN_COLS 32
struct zero_part {
    char *lu;
    size_t n, es, j0, j1;
};

static void *zero_run(void *opaque)
{
    const struct zero_part *z = opaque;
    size_t n = z->n, h = n / 2, es = z->es;
    for (size_t j = z->j0; j < z->j1; j++) {
        memset(z->lu + j * n * es, 0, h * es);
        memset(z->lu + ((h + j) * n + h) * es, 0, h * es);
    }
    return NULL;
}

static void zero_quarters(bst_ctx *ctx, void *lu, size_t n, size_t es)
{
    size_t h = n / 2, t = ctx ? (size_t)bsti_ctx_workers_no_alloc(ctx, h / ZERO_MIN_COLS) : 1;
    struct zero_part part[BST_THREADS_MAX];
    for (size_t q = 0; q < t; q++)
        part[q] = (struct zero_part){lu, n, es, h * q / t, h * (q + 1) / t};
    bsti_run_parts(part, sizeof *part, t, zero_run);
}

#define SPLIT_KERNEL(T, SUF)                                                                     \
    static void split_sparse_##SUF(const cholmod_sparse *a, size_t g, int turn, T *lu)            \
    {                                                                                             \
        const SuiteSparse_long *p = a->p, *i = a->i;                                              \
        const double *x = a->x;                                                                   \
        size_t n = a->ncol;                                                                       \
        for (size_t j = 0; j < n; j++)                                                            \
            for (SuiteSparse_long q = p[j]; q < p[j + 1]; q++) {                                  \
                size_t row, col, mrow, mcol;                                                      \
                int sign = split_place(g, turn, j, (size_t)i[q], &row, &col, &mrow, &mcol);       \
                if (!sign) /* a column of the second half: its values are its image's */          \
                    break;                                                                        \
                lu[col * n + row] -= (T)x[q];                                                     \
                lu[mcol * n + mrow] -= (T)(sign * x[q]);                                          \
            }                                                                                     \
        for (size_t j = 0; j < n; j++)                                                            \
            lu[j * n + j] += (T)1;                                                                \
    }
SPLIT_KERNEL(double, d)
SPLIT_KERNEL(float, f)

int bsti_mirror_split_sparse(bst_ctx *ctx, const cholmod_sparse *a, bst_precision prec, size_t g,
                             void *lu, int *turned)
{
    size_t n = a->ncol;
    double tol = prec == BST_DOUBLE ? BSTI_MIRROR_TOL : BSTI_MIRROR_TOL_FLOAT;
    if (a->nrow != n || n != g * g || !a->packed || !a->sorted)
        return BSTI_MIRROR_ASYM;
    int turn = 0;
    if (!sparse_holds(ctx, a, g, 0, tol) && !(turn = sparse_holds(ctx, a, g, 1, tol)))
        return BSTI_MIRROR_ASYM;
    zero_quarters(ctx, lu, n, prec == BST_DOUBLE ? sizeof(double) : sizeof(float));
    if (prec == BST_DOUBLE)
        split_sparse_d(a, g, turn, lu);
    else
        split_sparse_f(a, g, turn, lu);
    *turned = turn;
    return BST_OK;
}

/* The first (0) or second half's block of an n x n split matrix a: its top-left or bottom-right
 * quarter. */
static void *quarter(void *a, bst_precision prec, size_t n, int half)
{
    size_t off = half ? (n / 2) * n + n / 2 : 0;
    return prec == BST_DOUBLE ? (void *)((double *)a + off) : (void *)((float *)a + off);
}

/* B's values as a CHOLMOD matrix in *sb: B's own (SPARSE), or a sparse copy in *tmp (DIAG).
 * BST_OK, BSTI_MIRROR_ASYM for another structure, or an error. */
static int sparse_of(bst_ctx *ctx, const bst_mat *b, bst_mat **tmp, const cholmod_sparse **sb)
{
    *tmp = NULL, *sb = NULL;
    if (b->s == BST_SPARSE)
        *sb = b->sp;
    else if (b->s != BST_DIAG)
        return BSTI_MIRROR_ASYM;
    else {
        int rc = bst_mat_convert(ctx, b, BST_SPARSE, BST_DOUBLE, tmp);
        if (rc < 0)
            return rc;
        *sb = (*tmp)->sp;
    }
    return BST_OK;
}

static int commutes(bst_ctx *ctx, const cholmod_sparse *b, bst_precision prec, size_t n, size_t g,
                    int turn)
{
    double tol = prec == BST_DOUBLE ? BSTI_MIRROR_TOL : BSTI_MIRROR_TOL_FLOAT;
    return b->nrow == n && b->ncol == n && b->packed && b->sorted &&
           sparse_holds(ctx, b, g, turn, tol);
}

int bsti_mirror_commutes(bst_ctx *ctx, const bst_mat *b, bst_precision prec, size_t n, size_t g,
                         int turn)
{
    bst_mat *tmp;
    const cholmod_sparse *sb;
    int holds = sparse_of(ctx, b, &tmp, &sb) == BST_OK && commutes(ctx, sb, prec, n, g, turn);
    bst_mat_free(tmp);
    return holds;
}

void bsti_mirror_join(void *a, bst_precision prec, size_t n, size_t g, int turn)
{
    bsti_mirror_matrix(a, prec, n, g, 0);
    if (turn)
        bsti_mirror_turn(a, prec, n, g, n, 1);
}

/* X B (right 0) or B X by the halves, B sparse and commuting with the mirror (checked by the
 * caller), into into's storage (NULL: a new matrix; else n x n dense in prec, taken: the result
 * or freed), joined when join is set. */
static int mul_sparse(bst_ctx *ctx, void *x, bst_precision prec, size_t n, size_t g, int turn,
                      int right, const cholmod_sparse *b, bst_mat *into, int join, bst_mat **out)
{
    cholmod_sparse *hp = NULL, *hm = NULL;
    bst_mat *c = into;
    int rc = sparse_halves(ctx, b, g, turn, right, &hp, &hm);
    if (rc >= 0 && !c)
        rc = bst_mat_new_dense(ctx, n, n, prec, &c);
    for (int half = 0; half < 2 && rc >= 0; half++)
        rc = bsti_spmm(ctx, half ? hm : hp, prec, quarter(x, prec, n, half), n, n / 2, n / 2,
                       !right, quarter(c->dense, prec, n, half), n);
    cholmod_common *cc = bsti_cholmod(ctx);
    cholmod_l_free_sparse(&hp, cc), cholmod_l_free_sparse(&hm, cc);
    if (rc < 0) {
        bst_mat_free(c);
        return rc;
    }
    if (join)
        bsti_mirror_join(c->dense, prec, n, g, turn);
    *out = c;
    return BST_OK;
}

int bsti_mirror_mul_split(bst_ctx *ctx, void *x, bst_precision prec, size_t n, size_t g, int turn,
                          int right, const bst_mat *b, bst_mat *into, int join, bst_mat **out)
{
    bst_mat *tmp;
    const cholmod_sparse *sb;
    int rc = sparse_of(ctx, b, &tmp, &sb);
    if (rc == BST_OK)
        rc = mul_sparse(ctx, x, prec, n, g, turn, right, sb, into, join, out);
    else
        bst_mat_free(into);
    bst_mat_free(tmp);
    return rc;
}

/* A thin operand: n x m (left) or m x n (right, through its transpose). */
static int mul_thin(bst_ctx *ctx, void *inv, bst_precision prec, size_t n, size_t g, int turn,
                    int right, const bst_mat *b, bst_mat **out)
{
    size_t m = right ? b->rows : b->cols, h = n / 2, es = prec == BST_DOUBLE ? sizeof(double)
                                                                              : sizeof(float);
    char *t = bsti_alloc_array(ctx, n * m + 1, es), *r = bsti_alloc_array(ctx, n * m + 1, es);
    if (!t || !r) {
        bsti_free(ctx, t), bsti_free(ctx, r);
        return BST_ENOMEM;
    }
    for (size_t k = 0; k < m; k++) /* t (n x m) = B, or B^T, in prec */
        for (size_t i = 0; i < n; i++) {
            size_t at = right ? i * b->rows + k : k * n + i;
            double v = b->prec == BST_DOUBLE ? ((const double *)b->dense)[at]
                                             : (double)((const float *)b->dense)[at];
            if (prec == BST_DOUBLE)
                ((double *)t)[k * n + i] = v;
            else
                ((float *)t)[k * n + i] = (float)v;
        }
    if (turn)
        bsti_mirror_turn(t, prec, n, g, m, 0);
    bsti_mirror_rows(t, prec, n, g, m, 1);
    CBLAS_TRANSPOSE tr = right ? CblasTrans : CblasNoTrans;
    for (int half = 0; half < 2; half++) {
        size_t off = half ? h : 0;
        if (prec == BST_DOUBLE)
            cblas_dgemm(CblasColMajor, tr, CblasNoTrans, (int)h, (int)m, (int)h, 1.0,
                        quarter(inv, prec, n, half), (int)n, (double *)t + off, (int)n, 0.0,
                        (double *)r + off, (int)n);
        else
            cblas_sgemm(CblasColMajor, tr, CblasNoTrans, (int)h, (int)m, (int)h, 1.0f,
                        quarter(inv, prec, n, half), (int)n, (float *)t + off, (int)n, 0.0f,
                        (float *)r + off, (int)n);
    }
    bsti_flops_add(ctx, 4.0 * (double)h * (double)h * (double)m);
    bsti_free(ctx, t);
    bsti_mirror_rows(r, prec, n, g, m, 0);
    if (turn)
        bsti_mirror_turn(r, prec, n, g, m, 0);
    bst_mat *c;
    int rc = bst_mat_new_dense(ctx, right ? m : n, right ? n : m, prec, &c);
    if (rc >= 0) {
        if (!right)
            memcpy(c->dense, r, n * m * es);
        else
            for (size_t k = 0; k < m; k++) /* C = R^T */
                for (size_t i = 0; i < n; i++) {
                    if (prec == BST_DOUBLE)
                        ((double *)c->dense)[i * m + k] = ((double *)r)[k * n + i];
                    else
                        ((float *)c->dense)[i * m + k] = ((float *)r)[k * n + i];
                }
        *out = c;
    }
    bsti_free(ctx, r);
    return rc;
}

int bsti_mirror_mul(bst_ctx *ctx, void *inv, bst_precision prec, size_t n, size_t g, int turn,
                    int right, const bst_mat *b, bst_mat **out)
{
    if (b->rows != n && b->cols != n)
        return BSTI_MIRROR_ASYM;
    if (b->s == BST_SPARSE || b->s == BST_DIAG) {
        if (!bsti_mirror_commutes(ctx, b, prec, n, g, turn))
            return BSTI_MIRROR_ASYM;
        return bsti_mirror_mul_split(ctx, inv, prec, n, g, turn, right, b, NULL, 1, out);
    }
    if (b->s == BST_DENSE && (right ? b->cols : b->rows) == n)
        return mul_thin(ctx, inv, prec, n, g, turn, right, b, out);
    return BSTI_MIRROR_ASYM;
}
