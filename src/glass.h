/* glass.h - internal side of the analytic glass module (glass.c): the layer builder with its
 * numerical parameters exposed, so that tests and benchmarks can compare its fast path with exact
 * evaluation and measure what patch averaging changes.
 *
 * Conventions: angles in radians, wavelengths in micrometres, thickness in metres.  A layer's patch
 * value is P / Lambda (1/sr) with P the pane's directional T or R, either at the patch centre or
 * averaged over the patch uniformly in projected solid angle (bst_basis_sample). */
#ifndef BST_GLASS_H
#define BST_GLASS_H

#include "bsdfstack.h"

/* Patch averages (bst_glass_layer with at_centre = 0) integrate over bst_basis_sample's (u, v)
 * square split into four triangles, each with BST_GLASS_SAMPLES^2 Gauss-Legendre points after a
 * substitution that removes the rim's square-root singularity (glass.c, patch_rule): 4 x 8^2 = 256
 * directions per patch.  Against 4 x 32^2 points the patch values (Lambda x value, i.e. T or R)
 * differ by at most 7.6e-6 at k = 1, 2.5e-6 at k = 2..7 and 1e-6 in Klems full; the diffuse-diffuse
 * sum over patches matches the continuous pane's 2 int P sin cos dtheta to 7.6e-6 (k = 1), 6.3e-7
 * (k = 3) and 2.8e-8 (k = 7) (clear 6 mm and NFRC 103, Visible: bench/bench_glass; test_glass
 * checks the k = 3 and 7 sums). */
#define BST_GLASS_SAMPLES 8

/* Angular table used by patch averages (256 directions per patch, and a spectral channel sums the
 * model over about a hundred wavelengths per direction): Tf, Tb, Rf, Rb at BST_GLASS_TABLE_STEPS + 1
 * equidistant angles 0..90 degrees, linear in between.  Pointwise it deviates from exact evaluation
 * by < 2e-6 up to 89.9 degrees and < 2e-5 in the last 0.01 degree; in a layer's patch values
 * (Lambda x value) by at most BST_GLASS_TABLE_ERR (catalogue panes, Klems full and Shirley-Chiu k = 3
 * and 5: 2.3e-8; checked by tests/test_glass.c). */
#define BST_GLASS_TABLE_STEPS 9000
#define BST_GLASS_TABLE_ERR 5e-8

/* bst_glass_layer with its parameters: samples = Gauss points per triangle and dimension (>= 1;
 * ignored when at_centre), exact = 1 to evaluate every direction exactly instead of through the
 * table. */
int bsti_glass_layer(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, size_t nchannels,
                     const char *const *channels, int at_centre, int samples, int exact,
                     bst_layer **out);

/* The angular table of channel ch (4 * (BST_GLASS_TABLE_STEPS + 1) values: Tf, Tb, Rf, Rb at each
 * angle), freed with bsti_free; NULL when out of memory.  bsti_glass_table_optics interpolates it at
 * theta into v = {Tf, Tb, Rf, Rb}. */
double *bsti_glass_table(bst_ctx *ctx, const bst_glass *g, size_t ch);
void bsti_glass_table_optics(const double *tab, double theta, double v[4]);

/* The directions a layer's patch values average (bst_glass_layer): per patch, the incidence
 * angles and weights of its points (at_centre: the centre alone), computed once per basis so that
 * a stack evaluated at hundreds of wavelengths pays for the geometry once. */
typedef struct bsti_glass_rule bsti_glass_rule;
int bsti_glass_rule_new(bst_ctx *ctx, const bst_basis *basis, int at_centre, int samples,
                        bsti_glass_rule **out);
void bsti_glass_rule_free(bst_ctx *ctx, bsti_glass_rule *r);
/* bst_glass_layer_at with a precomputed rule for basis. */
int bsti_glass_layer_at(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis,
                        const bsti_glass_rule *rule, double lambda_um, bst_layer **out);

#endif
