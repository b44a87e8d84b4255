/* resample.h - BSDFs moved between bases: the exact overlap of Shirley-Chiu cells with Klems
 * patches, which serves both directions, and the expansion of rank-3 trees.
 *
 * Matrices are column-major N x N, M[o + N i] (column: incident patch i, row: outgoing patch o),
 * BSDF values in 1/sr, with basis.h's index convention on both sides. */
#ifndef BST_RESAMPLE_H
#define BST_RESAMPLE_H

#include "bsdfstack.h"

/* How a Shirley-Chiu grid of order k and a Klems basis overlap.  Cell c meets the patches
 * patch[first[c]] .. patch[first[c+1] - 1], and w[e] is the fraction of the cell's projected
 * solid angle inside patch[e] (the fractions of a cell add to 1).  area[p] is the sum of patch
 * p's fractions, its projected solid angle in cells: Lambda_p = area[p] pi / N.  Exact to
 * rounding: the concentric map preserves area and takes a patch to at most four trapezoids. */
typedef struct {
    bst_ctx *ctx;
    int k;
    size_t n, nk;
    size_t *first;
    size_t *patch;
    double *w;
    double *area;
} bsti_overlap;

int bsti_overlap_new(bst_ctx *ctx, int k, const bst_basis *kb, bsti_overlap **out);
void bsti_overlap_free(bsti_overlap *ov);

/* Klems matrix km (nk x nk) -> Shirley-Chiu m (N x N): each cell pair takes the mean of the
 * piecewise-constant Klems BSDF over both cells, M = W K W^T with W the overlap fractions.  So every
 * incident cell's directional-hemispherical value is the overlap-weighted mean of those of the
 * patches it meets, and a uniform BSDF stays uniform. */
int bsti_klems_to_sc(bst_ctx *ctx, const bsti_overlap *ov, const double *km, double *m);

/* Shirley-Chiu m (N x N) -> Klems out (nk x nk): an incident patch averages its cells weighted by
 * the part of each inside it, an outgoing patch collects the flux of the part of each cell inside
 * it.  So every incident patch keeps the projected-solid-angle mean of its directions'
 * directional-hemispherical values. */
int bsti_sc_to_klems(bst_ctx *ctx, const bsti_overlap *ov, const double *m, const bst_basis *kb,
                     double *out);

/* Component c of channel ch of b on target, N x N into work.  A transmission the file leaves out
 * comes from the other one by reciprocity: applied here for a Klems target (on the fine grid,
 * where it is exact); for a Shirley-Chiu target work gets the stored one and *recip = 1, and
 * the caller reads M[o + N i] as work[a(i) + N a(o)], a = bst_basis_antipode (no second N^2
 * buffer).  An absent component is BST_EINVAL. */
int bsti_resample_component(bst_ctx *ctx, const bst_bsdf *b, size_t ch, int c,
                            const bst_basis *target, double *work, int *recip);

/* bst_bsdf_to_layer with the number of threads that may expand a tensor tree (0: one a processor,
 * bsti_ttree_threads); the layer is the same whatever the number. */
int bsti_bsdf_to_layer(bst_ctx *ctx, const bst_bsdf *b, const bst_basis *target, int threads,
                       bst_layer **out);

#endif
