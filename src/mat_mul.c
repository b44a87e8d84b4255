/* mat_mul.c - products of structured matrices, C = A B, by a kernel per pair of structures.
 *
 * Dispatch.  A product looks up its kernel in a table indexed by the operand structures (ZERO,
 * DIAG, SPARSE, DENSE).  Order of the lookup:
 *   1. a ZERO operand gives a ZERO result (no work);
 *   2. a DIAG operand is a row (left) or column (right) scaling of the other operand, whose
 *      structure the result keeps;
 *   3. SPARSE * SPARSE: cholmod_l_ssmult, then the drop tolerance;
 *   4. SPARSE * DENSE and DENSE * SPARSE: the sparse operand's lines times row-major panels of
 *      the dense one, on the context's threads, O(nnz N);
 *   5. DENSE * DENSE: GEMM (OpenBLAS), in single precision when either operand is float;
 *   6. FACTORED (D + U K V^T) with FACTORED over one map, DENSE or SPARSE (made dense): mat_lowrank.c,
 *      without the factored operand's N x N values; over two maps: the generic path;
 *   7. PLUS_LR (base + U W^T) with anything: the bases' product and thin products (mat_plus.c).
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

/* Sparse * dense and dense * sparse by panels of the dense operand, shared out among the context's
 * threads.  A panel is SPMM_PANEL columns of B (sparse A times B) or rows of A (A times sparse B),
 * copied row-major: K x SPMM_PANEL, zero-padded, K the inner dimension.  Each line of the sparse
 * operand (a row of A, by CHOLMOD's transpose of it; a column of B as stored) sums its non-zeros'
 * products with rows of the panel into SPMM_PANEL contiguous accumulators, which go to a row
 * (columns j0.., strided) or column (rows i0.., contiguous) of C.  A product a column at a time,
 * one multiply-add per non-zero of A (or one axpy of a column of A per non-zero of B, read from
 * memory each time), took 30 s for a mirror blind's sparse transmission times a dense k = 7
 * matrix; here each non-zero drives a contiguous run the compiler vectorizes, over a panel that
 * stays in cache.  C(i, j) is summed over the inner index ascending in the dense operand's
 * precision: the same bits as the loop over the non-zeros, on any number of threads.
 * Workspace: A's transpose (nnz, sparse * dense), and a panel a thread. */
#define SPMM_PANEL 64

/* On x86-64 with GCC's function multi-versioning, the panel kernels are also compiled for AVX2,
 * chosen at load time where the CPU has it: the accumulators of a line then fit in the vector
 * registers (8 of 16 in float), where baseline SSE2 code spills them.  No FMA: each multiply-add
 * is still rounded twice, so both versions give the same bits. */
#if defined(__x86_64__) && defined(__has_attribute)
#if __has_attribute(target_clones)
#define SPMM_CLONES __attribute__((target_clones("avx2", "default")))
#endif
#endif
#ifndef SPMM_CLONES
#define SPMM_CLONES
#endif

struct spmm_part {
    const SuiteSparse_long *p, *i;  /* the sparse operand's lines: line l's inner indices
                                       i[p[l] .. p[l + 1] - 1], values v */
    const double *v;
    const void *dd;                 /* the dense operand D, leading dimension ldd, K x span
                                       (D S: span rows, K columns; S D: K rows, span columns) */
    void *cd;                       /* C, leading dimension ldc */
    size_t ldd, ldc, K, span, lines;
    int dense_left;                 /* C = D S (panels of D's rows), else C = S D (of columns) */
    size_t p0, p1;                  /* the panels [p0, p1) */
    void *panel;                    /* K x SPMM_PANEL, row-major, D's precision */
};

/* A line's accumulators are SPMM_ACCS vectors of 32 bytes (GCC's vector extension), named one by
 * one so that the compiler keeps them in registers: as an array they lived on the stack, each
 * multiply-add a load and a store of its accumulator (about 22 cycles a non-zero).  A line's
 * SPMM_PANEL values are taken in groups of SPMM_ACCS vectors (one group of 64 floats, two of 32
 * doubles), each group a pass over the line's non-zeros, and the panel row of the non-zero
 * SPMM_AHEAD places on is prefetched.  Each value is summed as before: the same bits. */
#define SPMM_ACCS 8
#define SPMM_AHEAD 8
/* Lines a block (S D: their results staged, then written a column of C at a time) and the inner
 * indices a tile of the panel's transposing copy (S D). */
#define SPMM_TILE 64
typedef float spmm_vfloat __attribute__((vector_size(32)));
typedef double spmm_vdouble __attribute__((vector_size(32)));
/* The same, for the panel's unaligned loads (its rows are read as vectors: may_alias). */
typedef float spmm_ufloat __attribute__((vector_size(32), aligned(4), may_alias));
typedef double spmm_udouble __attribute__((vector_size(32), aligned(8), may_alias));
/* The u-th vector of a panel row's group. */
#define SPMM_LOAD(U, row, u) (*(const U *)((row) + (u) * L))

/* The panel's K x w values of D (its columns or rows o .. o + w - 1), row-major, zero-padded to
 * SPMM_PANEL; then each line's sums into C: D S's a run of C's column, S D's staged for a block
 * of lines and written by columns.  One plain kernel a precision. */
#define SPMM_PANEL_KERNEL(T, SUF)                                                                \
    SPMM_CLONES static void spmm_panel_##SUF(const struct spmm_part *t, size_t o, size_t w)      \
    {                                                                                            \
        typedef spmm_v##SUF V;                                                                   \
        typedef spmm_u##SUF U;                                                                   \
        enum { L = sizeof(V) / sizeof(T), G = SPMM_ACCS * L };                                   \
        const T *dd = t->dd;                                                                     \
        T *panel = t->panel, *cd = t->cd, stage[SPMM_TILE * SPMM_PANEL];                         \
        size_t K = t->K, R = t->ldd, M = t->ldc;                                                 \
        if (t->dense_left)                                                                       \
            for (size_t k = 0; k < K; k++) {                                                     \
                memcpy(panel + k * SPMM_PANEL, dd + k * R + o, w * sizeof(T));                   \
                for (size_t j = w; j < SPMM_PANEL; j++)                                          \
                    panel[k * SPMM_PANEL + j] = 0;                                               \
            }                                                                                    \
        else                                                                                     \
            for (size_t k0 = 0; k0 < K; k0 += SPMM_TILE) {                                       \
                size_t k1 = K - k0 < SPMM_TILE ? K : k0 + SPMM_TILE;                             \
                for (size_t j = 0; j < SPMM_PANEL; j++)                                          \
                    for (size_t k = k0; k < k1; k++)                                             \
                        panel[k * SPMM_PANEL + j] = j < w ? dd[(o + j) * R + k] : (T)0;          \
            }                                                                                    \
        for (size_t l0 = 0; l0 < t->lines; l0 += SPMM_TILE) {                                   \
            size_t l1 = t->lines - l0 < SPMM_TILE ? t->lines : l0 + SPMM_TILE;                   \
            for (size_t l = l0; l < l1; l++)                                                     \
                for (size_t g = 0; g < w; g += G) {                                              \
                    V c0 = {0}, c1 = {0}, c2 = {0}, c3 = {0}, c4 = {0}, c5 = {0}, c6 = {0},      \
                      c7 = {0};                                                                  \
                    for (SuiteSparse_long q = t->p[l]; q < t->p[l + 1]; q++) {                   \
                        V a = (V){0} + (T)t->v[q];                                               \
                        const T *row = panel + (size_t)t->i[q] * SPMM_PANEL + g;                 \
                        if (q + SPMM_AHEAD < t->p[l + 1]) {                                      \
                            const char *next = (const char *)(panel + g +                        \
                                (size_t)t->i[q + SPMM_AHEAD] * SPMM_PANEL);                      \
                            for (size_t b = 0; b < G * sizeof(T); b += 64)                       \
                                __builtin_prefetch(next + b);                                    \
                        }                                                                        \
                        c0 += a * SPMM_LOAD(U, row, 0);                                          \
                        c1 += a * SPMM_LOAD(U, row, 1);                                          \
                        c2 += a * SPMM_LOAD(U, row, 2);                                          \
                        c3 += a * SPMM_LOAD(U, row, 3);                                          \
                        c4 += a * SPMM_LOAD(U, row, 4);                                          \
                        c5 += a * SPMM_LOAD(U, row, 5);                                          \
                        c6 += a * SPMM_LOAD(U, row, 6);                                          \
                        c7 += a * SPMM_LOAD(U, row, 7);                                          \
                    }                                                                            \
                    V acc[SPMM_ACCS] = {c0, c1, c2, c3, c4, c5, c6, c7};                         \
                    size_t n = w - g < G ? w - g : G;                                            \
                    memcpy(t->dense_left ? cd + l * M + o + g : stage + (l - l0) * SPMM_PANEL + g, \
                           acc, n * sizeof(T));                                                  \
                }                                                                                \
            if (!t->dense_left)                                                                  \
                for (size_t j = 0; j < w; j++)                                                   \
                    for (size_t l = l0; l < l1; l++)                                             \
                        cd[(o + j) * M + l] = stage[(l - l0) * SPMM_PANEL + j];                  \
        }                                                                                        \
    }
SPMM_PANEL_KERNEL(float, float)
SPMM_PANEL_KERNEL(double, double)

struct spmm_run_arg {
    struct spmm_part part;
    int single;
};

static void *spmm_run(void *arg)
{
    const struct spmm_run_arg *r = arg;
    const struct spmm_part *t = &r->part;
    for (size_t p = t->p0; p < t->p1; p++) {
        size_t o = p * SPMM_PANEL, w = t->span - o < SPMM_PANEL ? t->span - o : SPMM_PANEL;
        if (r->single)
            spmm_panel_float(t, o, w);
        else
            spmm_panel_double(t, o, w);
    }
    return NULL;
}

int bsti_spmm(bst_ctx *ctx, const cholmod_sparse *s, bst_precision prec, const void *d, size_t ldd,
              size_t d_rows, size_t d_cols, int dense_left, void *c, size_t ldc)
{
    size_t span = dense_left ? d_rows : d_cols, K = dense_left ? d_cols : d_rows;
    size_t panels = K ? (span + SPMM_PANEL - 1) / SPMM_PANEL : 0; /* no inner values: C stays 0 */
    size_t nw = panels ? (size_t)bsti_ctx_workers_no_alloc(ctx, panels) : 0;
    size_t es = prec == BST_FLOAT ? sizeof(float) : sizeof(double);
    char *work = nw ? bsti_alloc_array(ctx, nw * K * SPMM_PANEL, es) : NULL;
    if (nw && !work)
        return BST_ENOMEM;
    bsti_flops_add(ctx, 2.0 * (double)(s->ncol ? ((const SuiteSparse_long *)s->p)[s->ncol] : 0) *
                            (double)span);
    struct spmm_run_arg part[BST_THREADS_MAX];
    for (size_t t = 0; t < nw; t++)
        part[t] = (struct spmm_run_arg){{s->p, s->i, s->x, d, c, ldd, ldc, K, span, s->ncol,
                                         dense_left, panels * t / nw, panels * (t + 1) / nw,
                                         work + t * K * SPMM_PANEL * es}, prec == BST_FLOAT};
    bsti_run_parts(part, sizeof *part, nw, spmm_run);
    bsti_free(ctx, work);
    return BST_OK;
}

static int mul_sparse_dense(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out)
{
    (void)drop;
    bst_mat *c; /* every value written by bsti_spmm where the inner dimension is not 0 */
    int rc = a->cols ? bsti_mat_new_dense_raw(ctx, a->rows, b->cols, b->prec, &c)
                     : bst_mat_new_dense(ctx, a->rows, b->cols, b->prec, &c);
    if (rc < 0)
        return rc;
    cholmod_common *cc = bsti_cholmod(ctx);
    cholmod_sparse *at = cc ? cholmod_l_transpose(a->sp, 1, cc) : NULL;
    rc = !cc ? BST_ENOMEM : !at ? bsti_mat_cholmod_failed(ctx, "transpose")
                          : bsti_spmm(ctx, at, b->prec, b->dense, b->rows, b->rows, b->cols, 0,
                                      c->dense, c->rows);
    cholmod_l_free_sparse(&at, cc);
    if (rc < 0) {
        bst_mat_free(c);
        return rc;
    }
    *out = c;
    return BST_OK;
}

static int mul_dense_sparse(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out)
{
    (void)drop;
    bst_mat *c; /* (as mul_sparse_dense) */
    int rc = a->cols ? bsti_mat_new_dense_raw(ctx, a->rows, b->cols, a->prec, &c)
                     : bst_mat_new_dense(ctx, a->rows, b->cols, a->prec, &c);
    if (rc < 0)
        return rc;
    if ((rc = bsti_spmm(ctx, b->sp, a->prec, a->dense, a->rows, a->rows, a->cols, 1, c->dense,
                        c->rows)) < 0) {
        bst_mat_free(c);
        return rc;
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
    if (a->s == BST_PLUS_LR || b->s == BST_PLUS_LR) /* 7. mat_plus.c */
        return a->s == BST_ZERO || b->s == BST_ZERO ? mul_zero(ctx, a, b, drop_tol, out)
                                                    : bsti_mul_plus(ctx, a, b, drop_tol, out);
    return mul_table[a->s][b->s](ctx, a, b, drop_tol, out);
}
