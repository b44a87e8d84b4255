/* lowrank.h - factored matrices (issue #31, first step): M = D + U K V^T over N patches, the form
 * in which a layer keeps the resolution of its information.
 *
 *   D            diagonal (n values) or absent: clear panes, the unobstructed light
 *   U            [diag(a_1) S, ..., diag(a_p) S]   (N x p r)
 *   V            [diag(b_1) S, ..., diag(b_q) S]   (N x q r)
 *   K            dense (p r) x (q r), column-major; block (i, j) pairs a_i with b_j
 *   S            an N x r map shared by every matrix of a stack: the 0/1 prolongation P from a
 *                coarse Shirley-Chiu order (one parent a row: a depth-d tree read at k > d is
 *                exactly P M_d P^T), or the overlap table W of tree cells with Klems patches
 *                (a Klems layer is W K W^T)
 *
 * Products, sums and diagonal scalings stay in the family: the scaling vectors of the terms are
 * collected in the two lists, a vector already there (equal to 1e-14 of its largest value) shares
 * its block, so that a pane + coarse shade + pane stack keeps p = q = 1.  The inter-reflection
 * (I - M)^-1 is again of the family by the Woodbury identity,
 *   (E - U K V^T)^-1 = E^-1 + E^-1 U (I - K V^T E^-1 U)^-1 K V^T E^-1,   E = I - D,
 * whose dense work has the size p r of the coarse information, not N; V^T E^-1 U has blocks
 * S^T diag(b_j a_i / e) S: diagonal for P (block sums), sparse and small for W.
 * mat_lowrank.c and solve.c wire it into the structured-matrix dispatch; tests/test_lowrank.c
 * checks every operation against the dense one. */
#ifndef BST_LOWRANK_H
#define BST_LOWRANK_H

#include <stddef.h>

#include "bsdfstack.h"

/* The map S: row x's entries are col[start[x] .. start[x + 1] - 1] with weights w.  Counted
 * references: every matrix over it holds one (the maker's is given back by bsti_lr_map_free), the
 * last frees it through the context that made it.  Two maps of the same tag and orders are one
 * (prolongations "P" from d to k; Klems overlaps of basis tag on order k); an untagged map is
 * only itself. */
typedef struct {
    size_t N, r;
    size_t *start, *col;
    double *w;
    int k, d;         /* a prolongation from order d to k; d = -1 for another map */
    int single;       /* every row has one entry of weight 1 (a prolongation): S^T diag(c) S is
                         the diagonal of block sums */
    char tag[32];     /* "P", a Klems basis's name, or "" (untagged) */
    long refs;        /* changed atomically (matrices of one stack live in several threads) */
    bst_ctx *ctx;
} bsti_lr_map;

/* A sparse K's values by column (r + 1 starts, then rows ascending, values not zero). */
typedef struct {
    size_t nnz;
    size_t *start, *row;
    double *val;
} bsti_lr_csc;

typedef struct {
    const bsti_lr_map *S; /* one reference held */
    size_t N, r, p, q;
    double *d;            /* N values, or NULL: no diagonal part */
    double *a, *b;        /* p and q vectors of N values (a[i * N + x]) */
    double *k;            /* (p r) x (q r), column-major; or NULL where ks alone holds K: an
                             operand made of a sparse matrix for one product, sum or solve
                             (bsti_mat_lr_operand), which only bsti_lr_mul, bsti_lr_add,
                             bsti_lr_fact_solve and bsti_lr_free take */
    bsti_lr_csc *ks;      /* K's values that are not zero, where K is known sparse (p = q = 1: a
                             pane's tree, mat_lowrank.c's sparse_lr), for products through them
                             (no pass over K to find them); NULL: not known.  One block, freed
                             with F; a change of K in F's own storage drops it */
} bsti_lr;

/* A K block at most this share of whose values are not zero is multiplied as a sparse one (a clear
 * pane's tree at a coarse order: a diagonal, a mirror, a few values more), and an operand's K so
 * sparse is held by column alone (bsti_mat_lr_operand). */
#define BSTI_LR_SPARSE_SHARE (1.0 / 64.0)

/* An N x r map with nnz entries, rows filled by the caller (start[0] = 0, start[N] = nnz). */
int bsti_lr_map_new(bst_ctx *ctx, size_t N, size_t r, size_t nnz, bsti_lr_map **out);
/* The prolongation from Shirley-Chiu order d to order k >= d (basis.h's index x 2^k + y): row x
 * holds 1 at the coarse cell that contains fine cell x. */
int bsti_lr_map_prolong(bst_ctx *ctx, int k, int d, bsti_lr_map **out);
/* Give back the maker's reference (NULL-safe). */
void bsti_lr_map_free(bst_ctx *ctx, bsti_lr_map *S);
/* A map taken by one more holder (given back by bsti_lr_map_free). */
bsti_lr_map *bsti_lr_map_hold(bsti_lr_map *S);
/* Whether F and G lie over one map (the same object or the same prolongation). */
int bsti_lr_same_map(const bsti_lr *f, const bsti_lr *g);
/* A copy of F. */
int bsti_lr_copy(bst_ctx *ctx, const bsti_lr *f, bsti_lr **out);
/* F^T (the lists swapped, K transposed). */
int bsti_lr_transpose(bst_ctx *ctx, const bsti_lr *f, bsti_lr **out);
/* F := F^T in F's own storage where K is square (as many left as right scalings): 0; else -1 and
 * F as it was. */
int bsti_lr_transpose_take(bsti_lr *f);
/* y = F x (trans 0) or F^T x (trans 1), N values each; work: (p + q) r values. */
void bsti_lr_apply(const bsti_lr *f, int trans, const double *x, double *y, double *work);
/* F'[x, y] = F[perm[x], perm[y]] for a permutation of the patches that maps the cells of each
 * coarse cell onto those of one coarse cell (a mirror of the grid, for a prolongation; maps of
 * one entry a row only): BST_ENOTFOUND, with no message, when it does not. */
int bsti_lr_permute(bst_ctx *ctx, const bsti_lr *f, const size_t *perm, bsti_lr **out);
/* An untagged map whose row x is row perm[x] of S (a maker's reference in *out), and F over it:
 * F'[x, y] = F[perm[x], perm[y]] for any map (S2 made from F's map by bsti_lr_map_permuted with
 * the same perm; one S2 for the components of one layer keeps them over one map). */
int bsti_lr_map_permuted(bst_ctx *ctx, const bsti_lr_map *S, const size_t *perm, bsti_lr_map **out);
int bsti_lr_permute_over(bst_ctx *ctx, const bsti_lr *f, const size_t *perm, const bsti_lr_map *S2,
                         bsti_lr **out);
/* Element (i, j). */
double bsti_lr_get(const bsti_lr *f, size_t i, size_t j);
/* Column y of F (out[x] = F[x, y], N values), each value the same bits as bsti_lr_get gives (the
 * same operations in the same order: lowrank.c), at O(N p q) a column, for readers of many (the
 * writer, the checks): the map's rows laid out (bsti_lr_rows_new) for passes that do not branch
 * on a row's entries (a Klems overlap table: one entry for most cells, two to four for those on a
 * patch's edge), with room for one column's sums.  One layout per thread. */
typedef struct {
    bst_ctx *ctx;
    double *fw;           /* N: the weight of each row's first entry (0: none) */
    size_t *fc;           /* N: its column (0: none) */
    size_t *multi;        /* the rows of more than one entry */
    size_t nmulti;
    double *s, *c;        /* N and r values of room */
} bsti_lr_rows;
int bsti_lr_rows_new(bst_ctx *ctx, const bsti_lr *f, bsti_lr_rows **out);
void bsti_lr_rows_free(bsti_lr_rows *t);
void bsti_lr_col_fast(const bsti_lr *f, bsti_lr_rows *t, size_t y, double *out);
/* Every stored value finite. */
int bsti_lr_finite(const bsti_lr *f);
/* Values stored: the diagonal, the scaling vectors and K. */
size_t bsti_lr_stored(const bsti_lr *f);

/* diag(d) + diag(a) S K S^T diag(b): d, a, b may be NULL (none, ones, ones); K r x r, copied. */
int bsti_lr_new(bst_ctx *ctx, const bsti_lr_map *S, const double *d, const double *a,
                const double *K, const double *b, bsti_lr **out);
void bsti_lr_free(bst_ctx *ctx, bsti_lr *m);

/* *out = F G.  Its K blocks are multiplied by GEMM unless one is sparse (at most 1/64 of its
 * values not zero: a clear pane's tree at a coarse order, a diagonal or a mirror and a few values
 * more), then through that one's values (the same sums, in another order). */
int bsti_lr_mul(bst_ctx *ctx, const bsti_lr *f, const bsti_lr *g, bsti_lr **out);
/* *out = alpha F + beta G. */
int bsti_lr_add(bst_ctx *ctx, double alpha, const bsti_lr *f, double beta, const bsti_lr *g,
                bsti_lr **out);
/* *out = diag(dr) F diag(dc) (either NULL: identity). */
int bsti_lr_scale(bst_ctx *ctx, const double *dr, const bsti_lr *f, const double *dc, bsti_lr **out);
/* F := diag(dr) F diag(dc) in F's own storage (K untouched); bsti_lr_scale is a copy and this. */
void bsti_lr_scale_take(const double *dr, bsti_lr *f, const double *dc);
/* The solves with I - F (lowrank_solve.c).  A factorization holds E^-1 = (I - D)^-1 and the LU
 * factors of the capacitance C = I - K H, H = V^T E^-1 U ((p r) x (p r)), of F (side 0) or of F^T
 * (side 1: I - K^T U^T E^-1 V), each made at its first use.  A solve with a factored right-hand
 * side B whose left scalings are among F's (those of the side's matrix: F's a for side 0, its b
 * for side 1) needs no inverse: (I - F)^-1 U = E^-1 U C^-1 (the push-through identity) gives
 *   (I - F)^-1 B = E^-1 D_B + E^-1 U C^-1 [K V^T E^-1 D_B + K_B' V_B^T],
 * K_B' = K_B with its block rows moved to those of F's equal scalings: one LU (2/3 (p r)^3) and a
 * solve with the columns of the bracket, where forming (I - F)^-1 and multiplying it by B costs a
 * solve with q r columns and then a GEMM.  Any other B goes through the inverse, formed from the
 * same LU.  The stack's B (L Tf1, L Rb1 L Tb2, Tf2 for a right solve) share A's scalings, so each
 * inter-reflection of a pane + factored layer step costs one LU, one solve and one GEMM.  *rcond
 * (may be NULL): the reciprocal 1-norm condition of I - F, 1 / (|I - F|_1 |(I - F)^-1|_1), each
 * norm estimated as LAPACK's dgecon does (dlacn2) with products through the factors (a vector
 * through the LU: O(N + (p r)^2)).  BST_ESINGULAR when I - D or the capacitance is singular. */
typedef struct {
    bsti_lr *m[2];      /* F (side 0) and F^T (side 1), the one not asked yet NULL */
    double *einv;       /* N values: 1 / (1 - d) */
    double *lu[2];      /* side s's capacitance's LU factors ((p r)^2 values of m[s]), or NULL */
    void *ipiv[2];      /* their pivots (lapack_int: lapacke.h is kept out of this header) */
} bsti_lr_fact;
/* I - F factored on side `trans` (0: for (I - F)^-1 B, 1: for (I - F)^-T B, as a right solve
 * B (I - F)^-1 = ((I - F)^-T B^T)^T needs); F is copied. */
int bsti_lr_factor(bst_ctx *ctx, const bsti_lr *f, int trans, bsti_lr_fact **out, double *rcond);
/* The same of an F the caller gives up: the factorization holds F itself (transposed in its own
 * storage for side 1 where K is square), not a copy; F is freed on failure. */
int bsti_lr_factor_take(bst_ctx *ctx, bsti_lr *f, int trans, bsti_lr_fact **out, double *rcond);
/* *out = (I - F)^-1 B (trans 0) or (I - F)^-T B (trans 1), B over F's map. */
int bsti_lr_fact_solve(bst_ctx *ctx, bsti_lr_fact *fa, int trans, const bsti_lr *b, bsti_lr **out);
/* *out = (I - F)^-1 (trans 0) or (I - F)^-T (trans 1), factored: E^-1 + E^-1 U C^-1 K V^T E^-1. */
int bsti_lr_fact_inverse(bst_ctx *ctx, bsti_lr_fact *fa, int trans, bsti_lr **out);
void bsti_lr_fact_free(bst_ctx *ctx, bsti_lr_fact *fa);
/* *out = (I - F)^-1 by the Woodbury identity (a factorization's inverse), *rcond as above. */
int bsti_lr_inverse(bst_ctx *ctx, const bsti_lr *f, bsti_lr **out, double *rcond);

/* Shared by lowrank.c and lowrank_solve.c (not for other modules). */
/* A matrix over S with room for p and q scalings and a diagonal when with_d; K as kmode says: zero,
 * filled (its values left for the caller to write, every one of them: no clearing pass), or none
 * (k NULL: the caller sets ks). */
enum { BSTI_LR_K_ZERO, BSTI_LR_K_FILLED, BSTI_LR_K_NONE };
int bsti_lr_alloc(bst_ctx *ctx, const bsti_lr_map *S, size_t p, size_t q, int with_d, int kmode,
                  bsti_lr **out);
/* dst's r x r block (bi, bj) += s * F's block (i, j) (first: := 0 + s * F's block, the block's
 * values not read), from K or, where F holds K by column alone, from its values (the same sums:
 * the zeros add nothing). */
void bsti_lr_block_put(double *dst, size_t ldd, size_t bi, size_t bj, const bsti_lr *f, size_t i,
                       size_t j, double s, int first);
/* The index of v (N values) among the n vectors of list (equal to 1e-14 of v's largest value), n
 * when it is not there; bsti_lr_find_or_add appends it then. */
size_t bsti_lr_find(const double *list, size_t n, const double *v, size_t N);
size_t bsti_lr_find_or_add(double *list, size_t *n, const double *v, size_t N);
/* dst's r x r block (bi, bj) += s * src's block (i, j), column-major, leading dimensions ldd, lds. */
void bsti_lr_add_block(double *dst, size_t ldd, size_t bi, size_t bj, const double *src, size_t lds,
                       size_t i, size_t j, size_t r, double s);
/* The gram S^T diag(c) S: added into G's block at (row0, col0) (leading dimension ld), or, for a
 * map of one entry a row, its diagonal's r values into g (bsti_lr_gram_diag). */
void bsti_lr_gram_add(const bsti_lr_map *S, const double *c, double *G, size_t ld, size_t row0,
                      size_t col0);
void bsti_lr_gram_diag(const bsti_lr_map *S, const double *c, double *g);
/* T := beta T + alpha K G, K m x (nq r), G (nq r) x (np r) of diagonal r x r blocks (block (j, i)'s
 * diagonal at g + (j np + i) r), beta 0 or 1. */
void bsti_lr_mul_diag_blocks(const double *K, size_t m, size_t nq, size_t np, size_t r,
                             const double *g, double alpha, int beta, double *T);
/* F's N x N values into out (column-major, leading dimension N). */
void bsti_lr_to_dense(const bsti_lr *f, double *out);

#endif
