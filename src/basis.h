/* basis.h - directional bases of one hemisphere: RADIANCE's Shirley-Chiu square-to-disk basis of
 * order k and Klems-type band bases.
 *
 * Index convention (the one fact every module relies on): a direction's patch is found from its
 * x and y components only.  An incident patch is the patch of the light's PROPAGATION direction
 * (minus the vector pointing to the source), an outgoing patch that of the exit direction.  A ray
 * leaving layer 1 towards layer 2 therefore has the same index as the same ray arriving at
 * layer 2, and straight-through transmission and mirror reflection lie on the diagonal.  This is
 * the convention of RADIANCE's tensor trees (CONVENTIONS.md 5.1) and of its Klems files (7).
 *
 * Shirley-Chiu: (x, y) -> unit square by the concentric map; cell (ix, iy) of side 2^-k, ix along
 * X, has index ix * 2^k + iy; Lambda = pi / 4^k for every patch (the map preserves area, and
 * projected solid angle is area on the unit disk).
 * Klems: band b covers theta in [t_b, t_b+1) with n_b patches; patch j of a band is centred on
 * azimuth 360 j / n_b degrees and spans +-180 / n_b; Lambda = pi (cos^2 t_b - cos^2 t_b+1) / n_b. */
#ifndef BST_BASIS_H
#define BST_BASIS_H

#include "bsdfstack.h"

#define BSTI_KLEMS_MAX_BANDS 64

struct bst_basis {
    bst_ctx *ctx;
    bst_basis_kind kind;
    int k;            /* Shirley-Chiu order */
    size_t g;         /* Shirley-Chiu cells per square side, 2^k */
    size_t n;         /* patches */
    char *name;
    double *lambda;   /* n projected solid angles */
    size_t nbands;    /* Klems */
    double theta[BSTI_KLEMS_MAX_BANDS + 1]; /* band limits, degrees */
    int nphi[BSTI_KLEMS_MAX_BANDS];
    size_t first[BSTI_KLEMS_MAX_BANDS + 1]; /* index of a band's first patch */
};

/* The patch of the mirror image x -> -x of a patch (reversing a layer about the vertical axis).
 * Patch centres map onto patch centres in both bases (the concentric map and the Klems azimuth
 * grid are symmetric about the Y axis), so the lookup of the mirrored centre is exact. */
size_t bsti_basis_mirror_x(const bst_basis *b, size_t patch);

/* Shirley-Chiu concentric map of RADIANCE: disk (x, y), x^2 + y^2 <= 1 -> square [0,1)^2, and back. */
void bsti_sc_disk_to_square(double x, double y, double *sx, double *sy);
void bsti_sc_square_to_disk(double sx, double sy, double *x, double *y);

#endif
