/* mat.h - internal side of the structured matrix (bst_mat).
 *
 * A matrix carries its structure, precision and size, and the context that created it (whose
 * allocator owns dense and diagonal storage and whose CHOLMOD common owns sparse storage).
 * Structures: ZERO (no storage), DIAG (n doubles), SPARSE (cholmod_sparse, double, packed,
 * sorted, SuiteSparse_long indices), DENSE (column-major, leading dimension = rows, double or
 * float), FACTORED (a bsti_lr, lowrank.h: D + U K V^T, double; operations that have no factored
 * kernel expand it to dense, bsti_mat_expanded). */
#ifndef BST_MAT_H
#define BST_MAT_H

#include <cholmod.h>
#include "bsdfstack.h"
#include "lowrank.h"

struct bst_mat {
    bst_ctx *ctx;
    bst_structure s;
    bst_precision prec; /* meaningful for DENSE; DIAG and SPARSE are double */
    size_t rows, cols;
    double *diag;       /* DIAG */
    cholmod_sparse *sp; /* SPARSE */
    void *dense;        /* DENSE: double* or float* */
    bsti_lr *lr;        /* FACTORED */
    struct bsti_plus *plus; /* PLUS_LR */
};

/* A PLUS_LR matrix (mat_plus.c): base + U W^T, base ZERO, DIAG, SPARSE or DENSE of the matrix's
 * shape (its precision is the matrix's), U rows x m and W cols x m column-major doubles, m >= 1.
 * Products, sums, scalings, transposes and the inter-reflection solves keep the form: the base
 * through the structured kernels, the low-rank part by thin products (N m values), recompressed
 * after each operation to its numerical rank (bsti_plus_settle); the solves by the Woodbury
 * identity with the base's factorization, (E - U W^T)^-1 = E^-1 + E^-1 U (I - W^T E^-1 U)^-1 W^T
 * E^-1, E = I - base.  A blind's strips keep the rank at 2 x segments through a stack, where the
 * dense form would make every step a GEMM-bound one (issue #32). */
struct bsti_plus {
    bst_mat *base;
    size_t m;
    double *u, *w;
};

/* Wrap a factored matrix (ownership passes to the matrix, also on failure). */
int bsti_mat_from_lr(bst_ctx *ctx, bsti_lr *lr, bst_mat **out);
/* The factored form of m (FACTORED: a copy; DIAG or ZERO over map S: its diagonal alone; SPARSE
 * over a prolongation S: P K P^T when it is exactly that, a sparse tree of depth below k) into
 * *lr, or BST_ENOTFOUND for another structure or sparse matrix. */
int bsti_mat_lr_of(bst_ctx *ctx, const bst_mat *m, const bsti_lr_map *S, bsti_lr **lr);
/* The same as an operand of one bsti_lr_mul, bsti_lr_add or bsti_lr_fact_solve: a sparse m's K,
 * where it is sparse, held by column alone (lowrank.h), not as r^2 values (128 MiB for a pane's
 * k = 6 tree read at k = 7, cleared and filled with a few thousand values at each use). */
int bsti_mat_lr_operand(bst_ctx *ctx, const bst_mat *m, const bsti_lr_map *S, bsti_lr **lr);
/* A FACTORED matrix whose low-rank part is as large as the matrix itself (BSTI_LR_DENSE_SHARE of
 * N) becomes dense: the structure by cost (a product of two such costs about as much as GEMM on
 * the dense ones and holds more); any other is kept.  *m is replaced, the old freed. */
#define BSTI_LR_DENSE_SHARE 0.5
int bsti_mat_lr_settle(bst_ctx *ctx, bst_mat **m);
/* A FACTORED m's N x N values into out (column-major), bsti_cols's columns (over a wide map by
 * GEMM; any other through the factors with the bits bsti_lr_get gives, on threads): the tree
 * writer streams them instead of evaluating the factors at every visit of every value, into one
 * buffer for all its components (at k = 7, 2 GiB: allocated and first touched once, not once a
 * component).  BST_ENOMEM when the reader's memory is not there. */
int bsti_mat_lr_values(bst_ctx *ctx, const bst_mat *m, double *out);
/* Whether m is FACTORED over a wide map: an untagged one, made of a layer's own lines (a
 * venetian blind's strips: venetian_layer.c; a sheet's spread: perforated.c), not a prolongation
 * (tagged "P", one entry a row) nor a Klems overlap table.  Through the factors each value costs
 * p q times the square of a row's entries (64 for a blind, 5 for a sheet), so that the element-
 * and line-wise readers (writer, bounds, checks) would take minutes at k = 6 (a sheet's stack at
 * k = 5: 17 s of 18); they read such a matrix's columns by GEMM instead (p r multiply-adds a
 * value, r <= 8 x segments), a block at a time (bsti_cols). */
int bsti_mat_lr_wide(const bst_mat *m);
/* The coarser order whose values a FACTORED m holds, or 0: m is P K' P^T, P the prolongation
 * from order kc < k (lowrank.h; a stack of trees of order kc combined at k), with no diagonal part
 * and every scaling the same over the order-k patches of each order-kc patch.  Every order-k
 * patch's values are then those of the order-kc patch holding it, and the tree writer writes the
 * order-kc tree: the same function, read at k as P K' P^T again (a tree of depth below k). */
int bsti_mat_lr_coarse(const bst_mat *m);
/* Such an m's order-kc values K', 4^kc x 4^kc column-major into out, each the bits bsti_lr_get
 * gives at the order-k patches inside (the same operations in the same order). */
void bsti_mat_lr_coarse_values(const bst_mat *m, double *out);
/* One of them: at order-kc patches (ci, cj); column cj of them (4^kc values, the same bits). */
double bsti_mat_lr_coarse_at(const bst_mat *m, size_t ci, size_t cj);
void bsti_mat_lr_coarse_col(const bst_mat *m, size_t cj, double *out);
/* The order-kc patch holding order-k patch x. */
size_t bsti_mat_lr_coarse_cell(const bst_mat *m, size_t x);
/* Such an m's column sums col[x] and row sums row[x] (row may be NULL) at every order-k patch x,
 * negatives read as 0 (as a tree reader stores them): its coarse sums times the order-k patches
 * an order-kc patch holds (the fine sums to rounding).  BST_ENOMEM, or BST_OK. */
int bsti_mat_lr_coarse_sums(bst_ctx *ctx, const bst_mat *m, double *col, double *row);
/* Values given per order-k patch (a writer's budgets) per order-kc patch: the least over the
 * order-k patches inside each, 4^kc into out. */
void bsti_mat_lr_coarse_least(const double *fine, int k, int kc, double *out);
/* A FACTORED m as a dense matrix of precision prec, D + (A K) B^T by GEMM (double) over the rows
 * and columns of K that are not zero (the values equal bsti_lr_get's to rounding, not to the
 * bit): bsti_cols's columns, all of them. */
int bsti_mat_lr_expand(bst_ctx *ctx, const bst_mat *m, bst_precision prec, bst_mat **out);
/* The columns of an N x N matrix a block at a time, for the readers of a stack's result (the
 * writer, the bounds, the reciprocity and rotation checks, the metrics, the spectral sums), which
 * then hold a block of columns instead of an expanded copy of each component.  Each value as
 * bsti_mat_at reads it, except for a FACTORED matrix over a wide map (bsti_mat_lr_wide), whose
 * columns are formed by GEMM from A K and B (held once, N (R + C) values at most): blocks of
 * bsti_cols_block columns from column 0 are bsti_mat_lr_expand's columns bit for bit (it reads
 * them so; the writer, the bounds and the metrics too), other columns to rounding (GEMM's kernels
 * depend on the shape).  A FACTORED matrix over another map (a prolongation, a Klems overlap
 * table) is read column by column through the factors (bsti_lr_col_fast: bsti_lr_get's bits, a
 * few ns a value), the columns shared out among bsti_ctx_workers_no_alloc threads (the reader's
 * workers), each with its own layout of the map's rows.  m NULL or ZERO: zeros.
 * bsti_cols_get: columns cols[0..n-1] (cols NULL: j0..j0 + n - 1) into out (N x n, column-major),
 * at most bsti_cols_block columns (BSTI_COLS_BYTES of them) a GEMM. */
#define BSTI_COLS_BYTES ((size_t)32 << 20)
typedef struct bsti_cols bsti_cols;
int bsti_cols_new(bst_ctx *ctx, const bst_mat *m, size_t N, bsti_cols **out);
size_t bsti_cols_block(const bsti_cols *c);
void bsti_cols_get(bsti_cols *c, const size_t *cols, size_t j0, size_t n, double *out);
void bsti_cols_free(bsti_cols *c);
/* Units of `per` columns (unit u: cols[u per .. u per + per - 1], cols NULL: u per + 0.., n units)
 * handed to visit(opaque, chunk, u, buf, buf2), buf the unit's columns (N x per, column-major),
 * each as bsti_cols_get gives it, and buf2 as many of c2's (a reader of as many rows; cols2 NULL:
 * the same indices), NULL without c2.  The units form `chunks` runs of consecutive units (chunk
 * q: units [n q / chunks, n (q + 1) / chunks)), and each run's units are visited in order, one at
 * a time, the runs shared out among the readers' workers (bsti_ctx_workers_no_alloc): a result
 * kept per chunk is the same whatever the number of threads.  visit may run on several threads at
 * once, for different chunks; a non-zero return stops the visits (those under way finish).
 * BST_ENOMEM (nothing visited) when the buffers are not there. */
typedef int (*bsti_cols_visit_fn)(void *opaque, size_t chunk, size_t u, const double *buf,
                                  const double *buf2);
int bsti_cols_visit(bsti_cols *c, const size_t *cols, bsti_cols *c2, const size_t *cols2, size_t n,
                    size_t per, size_t chunks, bsti_cols_visit_fn visit, void *opaque);
/* The rank of a FACTORED matrix's low-rank part (p r by q r: the larger), a PLUS_LR one's m, 0 for
 * any other. */
size_t bsti_mat_rank(const bst_mat *m);

/* base + U W^T as a PLUS_LR matrix, taking base, u and w (bsti_alloc'd; also on failure); m = 0:
 * base itself.  Not recompressed (bsti_plus_settle). */
int bsti_mat_plus_new(bst_ctx *ctx, bst_mat *base, size_t m, double *u, double *w, bst_mat **out);
/* *m made plain where its base is dense (U W^T added into the base's values: they are held
 * anyway, and a dense step costs the same either way), else recompressed to its numerical rank
 * (singular values of U W^T above BSTI_PLUS_TOL |U|_F |W|_F) and made plain where the rank left
 * is 0 or where the thin part is as large as the dense form (m (rows + cols) >=
 * BSTI_PLUS_DENSE_SHARE rows cols).  *m replaced, the old freed. */
#define BSTI_PLUS_TOL 1e-13
#define BSTI_PLUS_DENSE_SHARE 0.25
int bsti_plus_settle(bst_ctx *ctx, bst_mat **m);
/* base + U W^T from its parts (bsti_mat_plus_new), settled, into *out; every part taken, also
 * when rc (a status from forming them) is an error, which is then returned. */
int bsti_plus_settled(bst_ctx *ctx, int rc, bst_mat *base, size_t m, double *u, double *w,
                      bst_mat **out);
/* Whether a low-rank part of rank m is held apart from a rows x cols base (its thin factors below
 * BSTI_PLUS_DENSE_SHARE of the dense form): the test of bsti_plus_settle, of the venetian layer
 * and of its plan (shade.c), which must agree. */
static inline int bsti_plus_fits(size_t rows, size_t cols, size_t m)
{
    return (double)m * (double)(rows + cols) < BSTI_PLUS_DENSE_SHARE * (double)rows * (double)cols;
}
/* Thin products through the structured ones (a dense float A gives float rounding): out
 * (a->rows x m) = A X for X a->cols x m, and out (a->cols x m) = A^T X for X a->rows x m (GEMM on
 * a dense double A, else (X^T A)^T), all column-major doubles. */
int bsti_mul_thin(bst_ctx *ctx, const bst_mat *a, const double *x, size_t m, double *out);
int bsti_mul_thin_t(bst_ctx *ctx, const bst_mat *a, const double *x, size_t m, double *out);
/* C = D S (dense_left 1) or S D (0) by the panel kernel of mat_mul.c, on the context's threads:
 * s the sparse operand by lines (S's columns for D S, its rows, as a transpose, for S D), values
 * double; D dense in precision prec, d_rows x d_cols with leading dimension ldd; C in prec,
 * leading dimension ldc, every value of its d_rows x s->ncol (D S) or s->ncol x d_cols (S D)
 * written.  Blocks of larger matrices, such as a mirror split's halves (mirror_mul.c), are
 * operands as they lie.  Workspace: a K x 64 panel a thread (K the inner dimension). */
int bsti_spmm(bst_ctx *ctx, const cholmod_sparse *s, bst_precision prec, const void *d, size_t ldd,
              size_t d_rows, size_t d_cols, int dense_left, void *c, size_t ldc);
/* The PLUS_LR kernels (mat_plus.c): a product or sum where either operand is PLUS_LR. */
int bsti_mul_plus(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out);
int bsti_add_plus(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                  bst_mat **out);
/* A PLUS_LR m dense in precision prec (base converted, then U W^T added a block of columns at a
 * time through doubles). */
int bsti_plus_to_dense(bst_ctx *ctx, const bst_mat *m, bst_precision prec, bst_mat **out);
/* d += U W^T of a PLUS_LR m, for a dense d of m's shape (as bsti_plus_to_dense adds it). */
int bsti_plus_lowrank_into(bst_ctx *ctx, bst_mat *d, const bst_mat *m);
/* Element (i, j), column y into out (N doubles), and a copy, transpose, scaling of a PLUS_LR m. */
double bsti_plus_get(const bst_mat *m, size_t i, size_t j);
int bsti_plus_copy(bst_ctx *ctx, const bst_mat *m, bst_mat **out);
int bsti_plus_transpose(bst_ctx *ctx, const bst_mat *m, bst_mat **out);
int bsti_plus_scale(bst_ctx *ctx, const double *dr, const bst_mat *m, const double *dc,
                    bst_mat **out);
/* The parts of any matrix as base + U W^T (a plain one: itself, m = 0). */
static inline void bsti_plus_parts(const bst_mat *a, const bst_mat **base, size_t *m,
                                   const double **u, const double **w)
{
    if (a->s == BST_PLUS_LR) {
        *base = a->plus->base, *m = a->plus->m, *u = a->plus->u, *w = a->plus->w;
    } else {
        *base = a, *m = 0, *u = *w = NULL;
    }
}

/* An empty matrix object of the given shape (no storage yet). */
int bsti_mat_alloc(bst_ctx *ctx, bst_structure s, bst_precision prec, size_t rows, size_t cols,
                   bst_mat **out);
/* Wrap a cholmod_sparse (ownership passes to the matrix, also on failure). */
int bsti_mat_from_cholmod(bst_ctx *ctx, cholmod_sparse *sp, bst_mat **out);
/* Value of a dense matrix element as double. */
static inline double bsti_dense_get(const bst_mat *m, size_t i, size_t j)
{
    return m->prec == BST_DOUBLE ? ((const double *)m->dense)[j * m->rows + i]
                                 : (double)((const float *)m->dense)[j * m->rows + i];
}

/* bst_mat_all_finite with a dense matrix read on the threads ctx allows (NULL: one). */
int bsti_mat_finite(bst_ctx *ctx, const bst_mat *m);
/* dense_pass.c: whether every value of a dense m is finite, and its column sums out[j] (m->cols)
 * of w[i] v(i, j) (w NULL: 1), v the value or, with pos, max(value, 0) (a NaN read as 0); on the
 * threads ctx allows (NULL: one), each column summed in row order (the bits of a plain loop). */
int bsti_dense_finite(bst_ctx *ctx, const bst_mat *m);
void bsti_dense_col_sums(bst_ctx *ctx, const bst_mat *m, const double *w, int pos, double *out);

/* Element (i, j) of any matrix as double; NULL or ZERO reads 0 (sparse: a binary search). */
static inline double bsti_mat_at(const bst_mat *m, size_t i, size_t j)
{
    if (!m || m->s == BST_ZERO)
        return 0.0;
    if (m->s == BST_DENSE)
        return bsti_dense_get(m, i, j);
    return bst_mat_get(m, i, j);
}

/* Shared by mat.c, mat_mul.c and mat_add.c (unchecked: the public entries validate first). */
/* *out = NULL, or BST_EINVAL (with a message when ctx is there) for a NULL ctx or out. */
int bsti_mat_check_out(bst_ctx *ctx, bst_mat **out);
/* The error of a failed CHOLMOD call `what`: BST_ENOMEM when CHOLMOD ran out of memory. */
int bsti_mat_cholmod_failed(bst_ctx *ctx, const char *what);
/* Remove entries |x| <= drop * max|x| from a sparse result (drop = 0: exact zeros only). */
int bsti_mat_drop(bst_ctx *ctx, cholmod_sparse *sp, double drop);
/* Sparse copy of any matrix (the zeros of a DIAG or DENSE one left out). */
int bsti_mat_to_sparse(bst_ctx *ctx, const bst_mat *m, bst_mat **out);
/* A dense matrix whose values are not set, for a kernel that writes every one: a block reused
 * (ctx.h, bsti_keep_begin) is not cleared first, on one thread, and a fresh one has its pages
 * faulted in by the kernel's threads.  With ctx->poison_raw set (tests) every value is NaN. */
int bsti_mat_new_dense_raw(bst_ctx *ctx, size_t rows, size_t cols, bst_precision prec, bst_mat **out);
/* Dense copy of any matrix in precision prec. */
int bsti_mat_to_dense(bst_ctx *ctx, const bst_mat *m, bst_precision prec, bst_mat **out);
/* Dense copies of both operands of a generic product or sum, float when either is dense float;
 * on failure *da and *db are NULL or to be freed by the caller. */
int bsti_mat_dense_pair(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, bst_mat **da,
                        bst_mat **db);
/* C = diag(dr) A diag(dc) (either NULL = identity), in A's structure. */
int bsti_mat_scale(bst_ctx *ctx, const double *dr, const bst_mat *a, const double *dc,
                   bst_mat **out);
/* A + B taking A: a dense A in the sum's precision (float when A or a dense B is float; for a
 * PLUS_LR B, a dense B's base) receives B in its own storage and is returned as *out (the same
 * values as bst_mat_add: a PLUS_LR B's base, then its low-rank part), any other A is freed after
 * bst_mat_add.  A is gone or is the result on return, whatever the status. */
int bsti_mat_add_take(bst_ctx *ctx, bst_mat *a, const bst_mat *b, bst_mat **out);
/* The same of a matrix the caller gives up: a DENSE or DIAG a is scaled in its own storage and
 * becomes *out (the same values bsti_mat_scale gives); any other is scaled into a new matrix and
 * freed, also on failure. */
int bsti_mat_scale_take(bst_ctx *ctx, const double *dr, bst_mat *a, const double *dc,
                        bst_mat **out);

/* bst_solve_left (right = 0) or bst_solve_right (right = 1) taking A, and B when b_own is B
 * (NULL: B is borrowed).  A dense A in the factor's precision is overwritten by its own LU
 * factors, any other A freed as soon as I - A is factored, so that A, its factorization and the
 * result are never all held at once; a taken dense B in the factor's precision is solved in its
 * own storage and returned as *out (a right solve's through its transpose, in place), any other
 * freed once read.  Taken matrices are freed on every error path.
 * keep (may be NULL): on success the factorization of I - A is handed out there (NULL when A is
 * zero or it could not be kept), to be used with bsti_factor_solve_right and freed with
 * bsti_factor_free (the absorptance reuses the combination's, stack.c).
 * prec: the precision of dense work (the stack's): BST_FLOAT factors a dense I - A in single
 * precision, also that of a sparse A whose LU would fill (which bst_solve_left does in double
 * unless A or B is dense float). */
typedef struct factor bsti_factor;
int bsti_solve_take(bst_ctx *ctx, int right, bst_mat *a, const bst_mat *b, bst_mat *b_own,
                    double rcond_warn, bst_precision prec, bst_mat **out, double *rcond,
                    bsti_factor **keep);
/* The same as two left solves with one factorization: x1 = (I - A)^-1 b1, x2 = (I - A)^-1 b2. */
int bsti_solve_take_left2(bst_ctx *ctx, bst_mat *a, const bst_mat *b1, bst_mat *b1_own,
                          const bst_mat *b2, bst_mat *b2_own, double rcond_warn,
                          bst_precision prec, bst_mat **x1, bst_mat **x2, double *rcond,
                          bsti_factor **keep);
/* The same, and zx1 = Z x1, zx2 = Z x2 (Z borrowed; NULL: neither) where a mirror-split inverse's
 * halves form them before x1 and x2 are made whole (half the flops of Z times each, mirror.h);
 * else *zx1 and *zx2 are NULL and the products are the caller's to form. */
int bsti_solve_take_left2_z(bst_ctx *ctx, bst_mat *a, const bst_mat *b1, bst_mat *b1_own,
                            const bst_mat *b2, bst_mat *b2_own, const bst_mat *z,
                            double rcond_warn, bst_precision prec, bst_mat **x1, bst_mat **x2,
                            bst_mat **zx1, bst_mat **zx2, double *rcond, bsti_factor **keep);
/* Y = B (I - A)^-1 with a kept factorization (no condition estimate); NULL-safe free. */
int bsti_factor_solve_right(bst_ctx *ctx, bsti_factor *f, const bst_mat *b, bst_mat **y);
void bsti_factor_free(bsti_factor *f);

/* Transposes (bst_mat_transpose, and this one) go tile by tile, BSTI_TRANSPOSE_TILE square, so that
 * a tile and the one it lands in stay in the L1 cache. */
#define BSTI_TRANSPOSE_TILE 32
/* m := m^T for a square DENSE m, in its own storage (the values of a transposed copy). */
void bsti_mat_transpose_in_place(bst_mat *m);
/* The same for an n x n column-major array of doubles or floats (a factored matrix's K). */
void bsti_transpose_square(void *values, size_t n, bst_precision prec);
/* *out = m^T, m consumed: in m's own storage where it can be (a square DENSE m, a FACTORED one with
 * a square K), else a transposed copy and m freed (also on failure). */
int bsti_mat_transpose_take(bst_ctx *ctx, bst_mat *m, bst_mat **out);

/* The FACTORED kernels (mat_lowrank.c): F G, F B and A F with B, A dense, alpha F + beta G. */
int bsti_mul_lowrank(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out);
int bsti_mul_lowrank_dense(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop,
                           bst_mat **out);
int bsti_mul_dense_lowrank(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop,
                           bst_mat **out);
int bsti_mul_lowrank_sparse(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop,
                            bst_mat **out);
int bsti_add_lowrank(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                     bst_mat **out);

/* The generic product: both operands converted to dense, then GEMM (the tests' baseline). */
int bsti_mat_mul_generic(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, bst_mat **out);
/* The generic sum: both operands converted to dense, then added elementwise (the tests' baseline). */
int bsti_mat_add_generic(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                         bst_mat **out);
#endif
