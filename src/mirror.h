/* mirror.h - the mirror split of a dense inter-reflection solve.
 *
 * A horizontal venetian blind, a pane, a diffuser: a layer whose geometry is symmetric about the
 * plane x = 0 (through the normal and the slats' direction) has matrices that commute with the
 * permutation S of that mirror, exact at every Shirley-Chiu order: cell (ix, iy), index
 * ix 2^k + iy (basis.h), goes to (2^k - 1 - ix, iy), which pairs each cell p of the first half
 * (ix < 2^(k-1), index below n/2) with a cell S p of the second.  A stack of such layers has them
 * too, and so has each I - A it solves with.  Ordered by pairs, such a matrix is [[A, B], [B, A]],
 * and the sums and differences of paired values split it into two independent halves,
 *   P = A + B (on x_p + x_Sp)   and   M = A - B (on x_p - x_Sp),
 * so that an LU, a solve or an inverse costs two of n/2: a quarter of the flops and a few O(n^2)
 * passes (bench/README.md, "Mirror-symmetric stacks").  The split is held in the matrix's own
 * storage: P in the top-left quarter (rows and columns p < n/2), M's value of pair (p, q) at
 * (S p, S q), the bottom-right quarter in S's order (a reordering of M by one permutation on both
 * sides, which products, LU and solves carry through); a vector's sum of pair p at p and its
 * difference at S p.  The two other quarters are left as they were (not read).
 *
 * Whether a matrix has the symmetry is read from its values, not assumed from its layers: every
 * pair of values S maps onto each other must agree to BSTI_MIRROR_TOL (double) or
 * BSTI_MIRROR_TOL_FLOAT (float) of its largest magnitude.  Those that agree to rounding (a stack
 * computed without the split) are made exactly symmetric (each of P and M from the average of
 * its two readings), a change far below the solve's own rounding.  A matrix symmetric about
 * y = 0 instead (a vertical blind's stack) is first turned over the square's diagonal
 * (bsti_mirror_turn), which makes that symmetry S's. */
#ifndef BST_MIRROR_H
#define BST_MIRROR_H

#include <stddef.h>

#include <cholmod.h>

#include "bsdfstack.h"

#define BSTI_MIRROR_TOL 1e-12
#define BSTI_MIRROR_TOL_FLOAT 1e-6
/* The smallest n split: below it the passes cost more than the halves save. */
#define BSTI_MIRROR_MIN_N 256

/* The image of cell p (index ix g + iy) in the mirror of the axis (0: x -> -x, 1: y -> -y), whether
 * p is the first of its pair (ix, or iy, below g / 2), and Q p, the cell (iy, ix) (the square
 * turned over its diagonal). */
static inline size_t bsti_mirror_image(size_t g, size_t p, int axis)
{
    size_t ix = p / g, iy = p % g;
    return axis ? ix * g + (g - 1 - iy) : (g - 1 - ix) * g + iy;
}
static inline int bsti_mirror_first(size_t g, size_t p, int axis)
{
    return (axis ? p % g : p / g) < g / 2;
}
static inline size_t bsti_mirror_turned(size_t g, size_t p) { return (p % g) * g + p / g; }

/* g (the square's cells a side) when n = g^2 with g a power of two >= 2 and n at least
 * BSTI_MIRROR_MIN_N, else 0. */
size_t bsti_mirror_side(size_t n);
/* Whether the n x n column-major matrix a (double or float by prec, leading dimension n) commutes
 * with the mirror of the axis (0: S, x -> -x; 1: y -> -y, (ix, iy) -> (ix, 2^k - 1 - iy)) of side
 * g (bsti_mirror_side) to the tolerance above. */
int bsti_mirror_holds(const void *a, bst_precision prec, size_t n, size_t g, int axis);
/* The rows (cols 0: of ncols columns) or the rows and the columns (cols 1, ncols = n) of a
 * exchanged by Q, (ix, iy) <-> (iy, ix), its own inverse: Q M Q commutes with S where M commutes
 * with the y mirror (a vertical blind's), so that the split serves both. */
void bsti_mirror_turn(void *a, bst_precision prec, size_t n, size_t g, size_t ncols, int cols);
/* a (as above) made P and M in its own storage (split 1), or P^-1 and M^-1 (or any pair of
 * halves) made the whole matrix again (split 0): each pair of paired values set to
 * (P + M) / 2 and (P - M) / 2. */
void bsti_mirror_matrix(void *a, bst_precision prec, size_t n, size_t g, int split);
/* The rows of x (n x ncols, column-major, leading dimension n) made sums and differences of
 * pairs (split 1), or halves again (split 0: x_p = (s + d) / 2, x_Sp = (s - d) / 2). */
void bsti_mirror_rows(void *x, bst_precision prec, size_t n, size_t g, size_t ncols, int split);

/* bsti_mirror_mul's answer for a right-hand side without the symmetry (not a status of the API):
 * the caller joins the inverse (bsti_mirror_matrix) and multiplies by the whole. */
#define BSTI_MIRROR_ASYM 1
/* *out = X B (right 0) or B X, X the n x n inverse held as its split's inverted halves in inv
 * (precision prec, side g, turned: of Q (I - A) Q), by mirror_mul.c: B sparse or diagonal and
 * commuting with the mirror (read from its values), or thin and dense (n x m, or m x n when
 * right).  BST_OK, BSTI_MIRROR_ASYM (nothing made), or an error. */
int bsti_mirror_mul(bst_ctx *ctx, void *inv, bst_precision prec, size_t n, size_t g, int turn,
                    int right, const bst_mat *b, bst_mat **out);

/* Whether B (sparse or diagonal, n x n) commutes with the mirror of side g (turned: Q B Q with
 * S), to the split's tolerance for prec. */
int bsti_mirror_commutes(bst_ctx *ctx, const bst_mat *b, bst_precision prec, size_t n, size_t g,
                         int turn);
/* *out = X B (right 0) or B X, X any n x n matrix held split in x as bsti_mirror_mul's inverse is
 * (it commutes with the mirror), B sparse or diagonal and bsti_mirror_commutes: the product of
 * the halves, left split like X (join 0: products by its halves may follow) or made whole
 * (join 1).  into: NULL for a new matrix, or an n x n dense one in prec whose storage receives
 * the result (taken: it is *out, or freed on failure; its values need not be cleared).  BST_OK,
 * BSTI_MIRROR_ASYM for another structure, or an error. */
int bsti_mirror_mul_split(bst_ctx *ctx, void *x, bst_precision prec, size_t n, size_t g, int turn,
                          int right, const bst_mat *b, bst_mat *into, int join, bst_mat **out);
/* A split n x n matrix (bsti_mirror_mul_split's, join 0) made whole, turned back when turn. */
void bsti_mirror_join(void *a, bst_precision prec, size_t n, size_t g, int turn);

/* I - A for a sparse A (n = g^2 patches, packed and sorted) that commutes with the mirror of the
 * x axis, or of the y axis (then *turned = 1: Q (I - A) Q's), written split as
 * bsti_mirror_matrix(split 1) would leave the dense I - A: P in lu's top-left quarter, M in its
 * bottom-right one (n x n, precision prec; the other quarters not touched), from A's columns of the
 * first half; those quarters are cleared first on the threads ctx allows (NULL: one).  BST_OK, or
 * BSTI_MIRROR_ASYM (nothing written) when A lacks the symmetry to the split's tolerance. */
int bsti_mirror_split_sparse(bst_ctx *ctx, const cholmod_sparse *a, bst_precision prec, size_t g,
                             void *lu, int *turned);

#endif
