/* ttree_write.h - the emitting side of RADIANCE tensor trees: a full component tensor becomes the
 * ScatteringData text, exactly or reduced, streamed through a sink; and the rank-3 (isotropic)
 * form of a Shirley-Chiu matrix with its read-back check.
 *
 * Full tensor order (CONVENTIONS.md 6.1, RADIANCE's rttree_reduce input): rank 4, G^4 values
 * (ix, iy, ox, oy) with oy fastest, (ix, iy) the cell of the incident square (p0, p1) and (ox, oy)
 * that of the outgoing square (p2, p3); this is exactly our column-major N x N matrix M[o + N i]
 * (i = ix G + iy, o = ox G + oy).  Rank 3, (G/2) G G values (ix, ox, oy): ix covers only the
 * lower, live half of p0; the upper half is implied zero.
 *
 * Tree text (CONVENTIONS.md 6): a branch lists its 2^D children with dimension 0 as the LEAST
 * significant bit of the child index; a leaf of 2^D values lists them with dimension 0 SLOWEST.
 * The emitter writes branches down to the finest 2^D blocks, one-value leaves for merged regions
 * and 2^D-value leaves for finest blocks kept at full resolution, as rttree_reduce does. */
#ifndef BST_TTREE_WRITE_H
#define BST_TTREE_WRITE_H

#include <stddef.h>
#include "bsdfstack.h"
#include "numtext.h"
#include "sink.h"

/* A full component tensor: one of d, f (arrays in the order above) or get (value at a flat index
 * of that order) is set. */
typedef struct {
    int rank;               /* 3 or 4 */
    int k;                  /* G = 2^k cells per dimension, 1 <= k <= BST_K_MAX */
    const double *d;
    const float *f;
    double (*get)(const void *opaque, size_t index);
    const void *opaque;
    int diagonal;           /* rank 4: only cells with (ix, iy) = (ox, oy) may be non-zero (clear
                               glass); the other blocks are not scanned */
    const unsigned char *fine_in; /* rank 4, may be NULL: G^2 flags, the incident cells (ix G + iy)
                               that hold data of order k (variable resolution); the culling
                               percentile is then taken over the finest blocks touching them */
} bsti_tensor;

/* How a tree is reduced.  A node whose variation measure is at most the pct-th percentile is a
 * candidate for one value; with budgets it becomes one only if the changes it makes to the
 * directional-hemispherical values (pi / G^2 times the sum of an incident index's cells) keep
 * every incident index x within its budget b(x).  The budget of a column is shared out over the
 * parts of its outgoing domain in proportion to their solid angle: the subtrees the writer's
 * threads take (tasks) and the one-value leaves above them.  A leaf above the tasks may change x
 * by b(x) times its share; inside a task the changes are summed as made, with their signs (and
 * with those of every value's rounding to float), and a node merges only while the sum stays
 * within b(x) times the task's share: noise averaged away in one place and another partly cancels,
 * and the budget of the blocks a task keeps whole goes to those it merges.  Whatever the tree,
 * the shares add up to 1, so a whole column changes by at most b(x).  With row budgets the same
 * holds for every outgoing cell's sum over incidence (a transmission whose reciprocal a reader
 * takes for the other side: its rows are that side's columns).  Decisions depend on the task's own
 * cells only: the same tree with any number of threads. */
typedef struct {
    double pct;             /* culling percentile in [0, 100); < 0: lossless */
    double floor;           /* BST_REDUCE_FLOOR */
    int digits;             /* 0: shortest text that reads back as the same float */
    const double *col_budget; /* NULL: no bound; else per incident index, rank 4 G^2 (ix G + iy),
                               rank 3 G/2 (ix), directional-hemispherical units, >= 0 */
    const double *row_budget; /* rank 4, may be NULL: per outgoing cell (ox G + oy) */
    int plain_checks;       /* tests: each candidate's sums found from its cells and tested with
                               its text (no task sums by level, no early refusal); the same tree */
    int measure_rows;       /* rank 4: measure each outgoing cell's change too (stats->row_error:
                               a transmission whose reciprocal a reader takes for the other side) */
} bsti_reduce;

typedef struct {
    size_t values, leaves, blocks_kept, blocks; /* blocks: finest 2^D blocks (kept: written whole) */
    uint64_t bytes;
    int negatives;          /* negative values written as 0 (as every tree reader reads them) */
    double threshold;
    double l1_error, max_error, hemi_error; /* as bst_bsdf_write_block */
    double row_error;       /* with measure_rows: the largest change of an outgoing cell's sum over
                               incidence, times pi / G^2 (its reciprocal's directional-
                               hemispherical change); else 0 */
} bsti_tree_stats;

/* Write the tree of t to out.  Fails with BST_EINVAL (nothing written) when a value is not finite,
 * BST_EIO when the sink fails, BST_ENOMEM.  Memory: one float per tree node above the cells
 * (G^D / (2^D - 1) floats) and, when reducing, a copy of the finest level for the percentile; the
 * text is made per subtree of at most 65536 cells on up to bst_ctx_set_threads threads (t->get
 * must then be safe to call from several threads at once), at most two such texts per thread
 * held at a time (about 1.1 MB each) with, under a rank-4 bound, the task's sums by level (about
 * 350 KB), and passed to out in tree order: the same bytes and statistics with any thread count. */
int bsti_ttree_write(bst_ctx *ctx, const bsti_tensor *t, const bsti_reduce *r, bsti_sink *out,
                     bsti_tree_stats *stats);

/* Variable resolution (bst_bsdf_write_varres): the order-k tensor of a component whose incident
 * cells `cols` (order k, increasing) hold the columns of `fine` (N x ncols, N = 4^k) and every
 * other cell the value of the cell of order kc holding it in `coarse` (4^kc x 4^kc; NULL = 0).
 * Written by bsti_ttree_write with get = bsti_varres_get, opaque = the struct, fine_in = in:
 * regions of coarse cells are constant, so the lossless tree stops there (one-value leaves at depth
 * kc or above) and goes down to k only where an incident cell of `cols` lies. */
typedef struct {
    int k, kc;
    const bst_mat *coarse, *fine;
    size_t ncols;
    const size_t *cols;
    long *slot;             /* N: column of fine incident cell i, or -1 */
    unsigned char *in;      /* N: slot[i] >= 0 */
} bsti_varres;
/* Set up v->slot and v->in (freed by bsti_varres_done); BST_EINVAL when cols are not increasing
 * patches of order k or the matrices' sizes differ. */
int bsti_varres_init(bst_ctx *ctx, bsti_varres *v);
void bsti_varres_done(bst_ctx *ctx, bsti_varres *v);
double bsti_varres_get(const void *opaque, size_t index);


/* Rank 3 (CONVENTIONS.md 5.2).  The rank-3 incident cell ix is the square ring j = G/2 - 1 - ix
 * of the Shirley-Chiu incident grid (sin(theta) in [2j/G, 2(j+1)/G)); the outgoing coordinates
 * are the exit direction rotated so that the incident light travels towards +x.
 * bsti_tt3_from_sc fills t3 ((G/2) G G values) from the N x N Shirley-Chiu matrix m of order k:
 * first the average of m over each ring, over sample points of its incident cells (their
 * azimuths) and of each rank-3 outgoing cell; then `refine` corrections t3 += that same average
 * of the residual (m minus the expansion of t3), which drive the expansion towards m.  The
 * expansion is the one bst_bsdf_to_layer applies to a rank-3 tree: the average over
 * BSTI_TT3_IN_SAMPLES^2 points of each incident cell and BSTI_TT3_OUT_SAMPLES^2 of each outgoing
 * cell.  On return *fa_min is the least flux accordance (percent, bst_metrics_accordance's FA)
 * over the incident patches between m and the expansion of t3, *hemi_max the largest change of a
 * directional-hemispherical value.  Sample points on a cell boundary (exit points turned onto the
 * plane of incidence lie on one) take the mean of the cells there, here and in the reader alike,
 * so the FA measured here is what the file reads back as to within about 0.1 (RADIANCE's
 * diffuser: 99.82-99.83 predicted, 99.73-99.80 read back).  Corrections stop early when *fa_min
 * falls below fa_stop (the matrix is clearly not isotropic; -INFINITY never stops).  The exact
 * 90-degree rotation symmetry of the grid cuts the work to a quarter; memory: see
 * bsti_tt3_build. */
#define BSTI_TT3_IN_SAMPLES 2
#define BSTI_TT3_OUT_SAMPLES 3
#define BSTI_TT3_REFINE 3
int bsti_tt3_from_sc(bst_ctx *ctx, const bst_mat *m, int k, int refine, double fa_stop,
                     double *t3, double *fa_min, double *hemi_max);
/* Several matrices of order k at once (the components of a layer), each one's t3, fa_min and
 * hemi_max as bsti_tt3_from_sc gives them, on `threads` threads (<= 0: one a core, at most
 * BSTI_TT3_THREADS), with at most table_bytes of tables a thread (0: none).
 * How: the rings of the incident grid do not interact (a row of t3 is gathered from, and expanded
 * into, its own ring's cells), so each ring runs all its corrections on one thread, the rings
 * shared out: every sum is formed in the same order whatever the number of threads, and the
 * results are bit for bit the same.  A thread keeps the cells of its ring's sample points in
 * tables (they depend on the grid only: one set serves every matrix and every pass), at most
 * table_bytes (the largest ring needs about 144 G N bytes: 38 MB at k = 6, 300 MB at k = 7), so
 * that the points are located twice per ring instead of 2 refine + 3 times per matrix.  A table
 * keeps at most boundary_max points that lie on cell boundaries (0: as many as its 16-bit entries
 * can name, 65536 - N); a cell with more (the corner cell of each ring at k = 7, a quarter of its
 * points) locates its points on every pass, and the ring's other cells keep their tables.  A ring
 * whose FA falls below fa_stop stops the others at that iterate; the rings that had gone further
 * run again up to it.  With give_up, the first ring of any matrix below fa_stop stops them all
 * (enough to know that a layer is not isotropic: that matrix's FA is below fa_stop): fa_min is
 * then the least FA measured below fa_stop, NaN for the other matrices, and neither t3 nor
 * hemi_max (NaN) means anything.  Memory: 2 N doubles, 1 MB and the tables a thread, (refine + 1) G doubles
 * a matrix; every buffer is taken from ctx by the caller's thread (workers allocate nothing). */
typedef struct {
    const bst_mat *m;       /* in: N x N, N = 4^k */
    double *t3;             /* out: (G/2) N values */
    double fa_min, hemi_max; /* out */
} bsti_tt3_job;
#define BSTI_TT3_THREADS 2
#define BSTI_TT3_TABLE_BYTES ((size_t)256 << 20)
int bsti_tt3_build(bst_ctx *ctx, int k, int refine, double fa_stop, int give_up, int threads,
                   size_t table_bytes, size_t boundary_max, size_t njobs, bsti_tt3_job *jobs);

/* The least FA over the incident patches between m and m turned by 90 degrees about Z (exact on
 * the grid).  A rank-3 form is turned into itself, so by the triangle inequality a matrix whose
 * rank-3 form keeps FA >= g everywhere has a rotation FA of about 2 g - 100 or more: a cheap test
 * that rejects anisotropic layers (blinds: 10 to 50) before the rank-3 form is built.  It stops
 * at the first incident patch it finds whose FA falls below stop and returns that FA (-INFINITY:
 * the least over all); a FACTORED m's patches are taken by orbits of the turn. */
double bsti_tt3_rotation_fa(const bst_mat *m, int k, double stop);

#endif
