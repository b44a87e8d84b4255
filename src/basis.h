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

#include <math.h>
#include <stddef.h>

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
/* Sample coordinates in patch a(patch) (a = bst_basis_antipode) of the point-reflected direction
 * of bst_basis_sample(b, patch, u, v): (x, y) -> (-x, -y), and, the map being its own inverse,
 * those in patch of a(patch)'s sample (u, v).  Shirley-Chiu (1 - u, 1 - v); Klems the same
 * (u, v), half a turn on in a band of one patch.  A model that samples a patch's
 * reversed directions at these coordinates averages reciprocal quantities over exactly reversed
 * directions (venetian_layer.c). */
void bsti_basis_antipode_uv(const bst_basis *b, size_t patch, double *u, double *v);

/* Shirley-Chiu concentric map of RADIANCE: disk (x, y), x^2 + y^2 <= 1 -> square [0,1)^2, and back. */
void bsti_sc_disk_to_square(double x, double y, double *sx, double *sy);
void bsti_sc_square_to_disk(double sx, double sy, double *x, double *y);
/* The same maps with the disk point in polar form (r, phi): phi may be any angle.  Inline: the
 * expansion of a rank-3 tree calls the first one 10^9 times at k = 7. */
static inline void bsti_sc_polar_to_square(double r, double phi, double *sx, double *sy)
{
    double a, b;
    if (r == 0.0) {
        *sx = *sy = 0.5;
        return;
    }
    while (phi < -M_PI / 4)
        phi += 2 * M_PI;
    while (phi >= 7 * M_PI / 4)
        phi -= 2 * M_PI;
    if (phi < M_PI / 4)
        a = r, b = r * phi / (M_PI / 4);
    else if (phi < 3 * M_PI / 4)
        b = r, a = -r * (phi - M_PI / 2) / (M_PI / 4);
    else if (phi < 5 * M_PI / 4)
        a = -r, b = -r * (phi - M_PI) / (M_PI / 4);
    else
        b = -r, a = r * (phi - 3 * M_PI / 2) / (M_PI / 4);
    *sx = (a + 1) / 2;
    *sy = (b + 1) / 2;
}
void bsti_sc_square_to_polar(double sx, double sy, double *r, double *phi);

/* Cell index (x g + y) of a g x g grid turned r quarter turns about the square's centre (the
 * concentric map turns the disk with it): (x, y) -> (g-1-y, x) per turn. */
static inline size_t bsti_sc_turn(size_t c, int r, size_t g)
{
    for (; r > 0; r--) {
        size_t x = c / g, y = c % g;
        c = (g - 1 - y) * g + x;
    }
    return c;
}

/* (r, phi) on the disk of ns x ns points of every cell of a g x g grid, at (s + 1/2) / ns of the
 * cell per side: pol[2 (c ns^2 + s)] and pol[2 (c ns^2 + s) + 1].  The point patterns are
 * invariant under the square's symmetries, and f ns points per side of a cell are the ns of each
 * of its f x f subcells (of the grid g f).  Allocated with ctx's allocator. */
int bsti_sc_cell_points(bst_ctx *ctx, size_t g, size_t ns, double **pol);

/* One coordinate of a grid of g cells: the cell of f = x g, and in *other the cell across the
 * boundary that f lies on within rounding (else the same cell). */
static inline size_t bsti_cell_pair(double f, size_t g, size_t *other)
{
    const double eps = 1e-9;
    size_t c = f <= 0.0 ? 0 : f >= (double)g ? g - 1 : (size_t)f;
    double frac = f - (double)c;
    if (frac < eps && c > 0)
        *other = c - 1;
    else if (frac > 1.0 - eps && c + 1 < g)
        *other = c, c = c + 1;
    else
        *other = c;
    return c;
}

/* The cells (index x g + y) of a g x g grid of the square that hold the disk point (r, phi): one,
 * or the 2 or 4 that meet where the point lies on a cell boundary (within rounding).  Sample
 * points turned about Z land on boundaries systematically (an exit point turned onto the plane
 * of incidence lies on the middle line), and a rounding error must not pick the side: callers
 * average over the cells returned.  Returns their count. */
static inline int bsti_sc_polar_cells(double r, double phi, size_t g, size_t cells[4])
{
    double sx, sy;
    bsti_sc_polar_to_square(r, phi, &sx, &sy);
    size_t x1, y1, x0 = bsti_cell_pair(sx * (double)g, g, &x1), y0 = bsti_cell_pair(sy * (double)g, g, &y1);
    cells[0] = x0 * g + y0;
    if (x0 == x1 && y0 == y1)
        return 1;
    if (x0 == x1 || y0 == y1) {
        cells[1] = x1 * g + y1;
        return 2;
    }
    cells[1] = x0 * g + y1, cells[2] = x1 * g + y0, cells[3] = x1 * g + y1;
    return 4;
}

#endif
