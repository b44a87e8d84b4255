/* bsdf_eval.c - a read BSDF file (xml.c) evaluated at a pair of directions as libBSDF does:
 * Klems matrices by the patches the directions fall in, tensor trees at the directions' points of
 * the Shirley-Chiu square (rank 3: the exit vector rotated so that the light travels towards +x,
 * ../shared/reference/CONVENTIONS.md 5.2), a transmission the file omits by reciprocity. */
#include <config.h>

#include <math.h>

#include "basis.h"
#include "bsdf.h"
#include "ctx.h"
#include "ttree.h"

/* Stored component c at (in, out), no reciprocity. */
static double eval_stored(const bst_bsdf *b, size_t ch, int c, const double in[3], const double out[3])
{
    if (b->mat[ch][c]) {
        size_t n = bst_basis_size(b->klems);
        double prop[3] = {-in[0], -in[1], -in[2]};
        return b->mat[ch][c][bst_basis_patch(b->klems, out) + n * bst_basis_patch(b->klems, prop)];
    }
    const bsti_ttree *t = b->tree[ch][c];
    double p[4];
    if (t->dim == 4) {
        bsti_sc_disk_to_square(-in[0], -in[1], &p[0], &p[1]);
        bsti_sc_disk_to_square(out[0], out[1], &p[2], &p[3]);
    } else {
        /* rank 3: sin(theta_in) on the lower half of p0; the exit vector rotated so that the
         * incident light travels towards +x (CONVENTIONS.md 5.2) */
        p[0] = 0.5 - 1e-6 - 0.5 * sqrt(in[0] * in[0] + in[1] * in[1]);
        double phi = atan2(-in[1], -in[0]), c0 = cos(phi), s0 = sin(phi);
        bsti_sc_disk_to_square(out[0] * c0 + out[1] * s0, -out[0] * s0 + out[1] * c0, &p[1], &p[2]);
    }
    return bsti_ttree_eval(t, p);
}

static double eval_comp(const bst_bsdf *b, size_t ch, int c, const double in[3], const double out[3])
{
    if (bsti_bsdf_stored(b, ch, c))
        return eval_stored(b, ch, c, in, out);
    int other = bsti_bsdf_reciprocal(c);
    if (other >= 0 && bsti_bsdf_stored(b, ch, other))
        return eval_stored(b, ch, other, out, in); /* reciprocity: f(in, out) = f(out, in) */
    return 0.0;
}

/* u = x / |x|, scaled by its largest component first, so that no square overflows (1e200) or
 * underflows (a subnormal component); 0 when x is not finite or is zero. */
static int unit(const double x[3], double u[3])
{
    double m = fmax(fabs(x[0]), fmax(fabs(x[1]), fabs(x[2])));
    if (!(m > 0 && isfinite(m)) || !isfinite(x[0] + x[1] + x[2]))
        return 0;
    double l = 0;
    for (int i = 0; i < 3; i++) {
        u[i] = x[i] / m;
        l += u[i] * u[i]; /* 1..3 */
    }
    l = sqrt(l);
    for (int i = 0; i < 3; i++)
        u[i] /= l;
    return 1;
}

int bst_bsdf_eval(bst_ctx *ctx, const bst_bsdf *b, size_t ch, const double in_raw[3],
                  const double out_raw[3], double *value)
{
    if (!ctx || !b || !in_raw || !out_raw || !value)
        return ctx ? bsti_error(ctx, BST_EINVAL, "eval: NULL argument") : BST_EINVAL;
    if (ch >= b->nch)
        return bsti_error(ctx, BST_EINVAL, "eval: channel %zu of %zu", ch, b->nch);
    double in[3], out[3];
    if (!unit(in_raw, in) || !unit(out_raw, out))
        return bsti_error(ctx, BST_EINVAL, "eval: direction vectors must be finite and non-zero");
    if (in[2] == 0.0 || out[2] == 0.0)
        return bsti_error(ctx, BST_EINVAL, "eval: a direction lies in the surface plane (z = 0)");
    int c = in[2] < 0 ? (out[2] > 0 ? BST_TF : BST_RF) : (out[2] < 0 ? BST_TB : BST_RB);
    *value = eval_comp(b, ch, c, in, out);
    return BST_OK;
}
