/* perforated.c - a perforated screen from its geometry (bsdfstack.h: bst_perforated), spec and
 * layer.
 *
 * Keys: x, y (hole pitch along X and Y), thickness, radius (circular holes) or hole-x, hole-y
 * (rectangular), lengths as glass: takes them (bare = mm); r (both faces) or rf, rb; t (each a
 * number or VISIBLE/SOLAR, the second for a channel named Solar); samples; rule (average, or
 * centre: WINDOW's model, sheet_wce.c).
 *
 * A hole passes light travelling along d where its two ends, seen along d, overlap: the exit end
 * is the entrance end moved by thickness (dx, dy) / |dz|, and the share of the sheet's area that
 * is open along d is that overlap over the cell x y (two equal circles: the lens area; two equal
 * rectangles: the product of the overlaps per axis).  Symmetric in d -> -d, so front and back
 * share it.  The diffuse part is rank one (see bst_perforated). */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "ctx.h"
#include "mat.h"
#include "venetian.h"

enum { P_X, P_Y, P_THICK, P_RADIUS, P_HX, P_HY, P_R, P_RF, P_RB, P_T, P_SAMPLES, P_RULE, NPKEYS };
static const char *const pkey[NPKEYS] = {"x", "y", "thickness", "radius", "hole-x", "hole-y", "r",
                                        "rf", "rb", "t", "samples", "rule"};

int bsti_shade_parse_rule(bst_ctx *ctx, const char *what, const char *val, int *rule)
{
    if (strcmp(val, "average") == 0)
        *rule = BST_VENETIAN_AVERAGE;
    else if (strcmp(val, "centre") == 0 || strcmp(val, "center") == 0)
        *rule = BST_VENETIAN_CENTRE;
    else
        return bsti_error(ctx, BST_EINVAL, "%s: rule: '%s' is not average or centre", what, val);
    return BST_OK;
}

void bst_perforated_init(bst_perforated *p)
{
    if (!p)
        return;
    memset(p, 0, sizeof *p);
    p->x = p->y = p->radius = p->hole_x = p->hole_y = NAN;
    p->solar[0] = p->solar[1] = p->solar[2] = NAN;
}

/* One key's value into p: a hole's shape given replaces the other shape (a record's, under
 * bst_perforated_update); r, rf, rb, t as VISIBLE/SOLAR or one value for every channel. */
static int set_pkey(bst_ctx *ctx, int k, const char *val, bst_perforated *p)
{
    double x = NAN, sol = NAN;
    if (k == P_RULE)
        return bsti_shade_parse_rule(ctx, "perforated", val, &p->rule);
    if (k == P_SAMPLES) {
        char *end;
        long n = strtol(val, &end, 10);
        if (end == val || *end || n < 0 || n > 64)
            return bsti_error(ctx, BST_EINVAL, "perforated: samples: '%s' is not a count of 0 "
                              "(automatic) to 64", val);
        p->samples = (int)n;
        return BST_OK;
    }
    int length = k <= P_HY;
    if (length ? bsti_shade_parse_length(val, &x) : bsti_shade_parse_bands(val, &x, &sol))
        return bsti_error(ctx, BST_EINVAL, "perforated: %s: '%s' is not %s", pkey[k], val,
                          length ? "a length (5mm, 0.005m, 0.5cm, 0.2in)" : "a number or VISIBLE/SOLAR");
    double *slot[NPKEYS] = {&p->x, &p->y, &p->thickness, &p->radius, &p->hole_x, &p->hole_y,
                            &p->rf, &p->rf, &p->rb, &p->t, NULL, NULL};
    *slot[k] = x;
    if (k == P_RADIUS)
        p->hole_x = p->hole_y = NAN;
    if (k == P_HX || k == P_HY)
        p->radius = NAN;
    if (k == P_R)
        p->rb = x, p->solar[0] = p->solar[1] = sol;
    if (k == P_RF || k == P_RB || k == P_T)
        p->solar[k - P_RF] = sol;
    return BST_OK;
}

int bsti_sheet_check(bst_ctx *ctx, const char *what, const char *const names[3], const double v[3],
                     const double sol[3])
{
    for (int band = 0; band < 2; band++) { /* the values, then the Solar channel's */
        double x[3] = {v[0], v[1], v[2]};
        const char *sfx = band ? " (Solar)" : "";
        for (int k = 0; band && k < 3; k++)
            if (!isnan(sol[k]))
                x[k] = sol[k];
        for (int k = 0; k < 3; k++)
            if (!(x[k] >= 0 && x[k] <= 1))
                return bsti_error(ctx, BST_EINVAL, "%s: %s%s = %g is not between 0 and 1", what,
                                  names[k], sfx, x[k]);
        if (x[0] + x[2] > 1 + 1e-12 || x[1] + x[2] > 1 + 1e-12)
            return bsti_error(ctx, BST_EINVAL, "%s: %s + t%s = %g is above 1", what,
                              x[0] >= x[1] ? names[0] : names[1], sfx, fmax(x[0], x[1]) + x[2]);
    }
    return BST_OK;
}

/* The checks of a screen; every message names its key (r where the spec gave r, else rf, rb). */
static int check(bst_ctx *ctx, const bst_perforated *p, int named_r)
{
    if (!(p->x > 0) || !isfinite(p->x))
        return bsti_error(ctx, BST_EINVAL, "perforated: x = %g m is not a positive pitch", p->x);
    if (!(p->y > 0) || !isfinite(p->y))
        return bsti_error(ctx, BST_EINVAL, "perforated: y = %g m is not a positive pitch", p->y);
    if (!(p->thickness >= 0) || !isfinite(p->thickness))
        return bsti_error(ctx, BST_EINVAL, "perforated: thickness = %g m is not a length >= 0",
                          p->thickness);
    int circ = !isnan(p->radius), rect = !isnan(p->hole_x) || !isnan(p->hole_y);
    if (!circ && !rect)
        return bsti_error(ctx, BST_EINVAL, "perforated: radius missing (radius for circular holes, "
                          "hole-x and hole-y for rectangular ones)");
    if (circ && !(p->radius > 0 && 2 * p->radius <= fmin(p->x, p->y)))
        return bsti_error(ctx, BST_EINVAL, "perforated: radius = %g m is not positive and at most "
                          "half the smaller pitch", p->radius);
    if (rect && !(p->hole_x > 0 && p->hole_x <= p->x))
        return bsti_error(ctx, BST_EINVAL, "perforated: hole-x = %g m is not in (0, x]", p->hole_x);
    if (rect && !(p->hole_y > 0 && p->hole_y <= p->y))
        return bsti_error(ctx, BST_EINVAL, "perforated: hole-y = %g m is not in (0, y]", p->hole_y);
    const char *names[3] = {named_r ? "r" : "rf", named_r ? "r" : "rb", "t"};
    const double v[3] = {p->rf, p->rb, p->t};
    int rc = bsti_sheet_check(ctx, "perforated", names, v, p->solar);
    return rc < 0 ? rc : bsti_sheet_wce_check(ctx, "perforated", p->rule, p->samples, v, p->solar);
}

/* One item of a perforated spec (bsti_shade_set): every key needs a value; r and rf/rb overlap,
 * and so do radius and hole-x/hole-y within one spec. */
static int perforated_item(bst_ctx *ctx, int k, const char *val, const int *seen, void *opaque)
{
    if (!val)
        return bsti_error(ctx, BST_EINVAL, "perforated: %s needs a value (%s=...)", pkey[k], pkey[k]);
    if ((k == P_R && (seen[P_RF] || seen[P_RB])) || ((k == P_RF || k == P_RB) && seen[P_R]))
        return bsti_error(ctx, BST_EINVAL, "perforated: %s given twice", pkey[k]);
    if ((k == P_RADIUS && (seen[P_HX] || seen[P_HY])) || ((k == P_HX || k == P_HY) && seen[P_RADIUS]))
        return bsti_error(ctx, BST_EINVAL, "perforated: radius and hole-x/hole-y both given "
                          "(radius for circular holes, hole-x and hole-y for rectangular ones)");
    return set_pkey(ctx, k, val, opaque);
}

int bst_perforated_parse(bst_ctx *ctx, const char *spec, bst_perforated *p)
{
    if (!ctx || !spec || !p)
        return ctx ? bsti_error(ctx, BST_EINVAL, "perforated: NULL argument") : BST_EINVAL;
    bst_perforated_init(p);
    int seen[NPKEYS];
    int rc = bsti_shade_spec(ctx, "perforated", spec, pkey, NPKEYS, perforated_item, p, seen);
    if (rc < 0)
        return rc;
    if (!seen[P_X] || !seen[P_Y])
        return bsti_error(ctx, BST_EINVAL, "perforated: %s missing (the hole pitch x and y are "
                          "needed)", seen[P_X] ? "y" : "x");
    return check(ctx, p, seen[P_R]);
}

int bst_perforated_update(bst_ctx *ctx, const char *spec, bst_perforated *p)
{
    if (!ctx || !spec || !p)
        return ctx ? bsti_error(ctx, BST_EINVAL, "perforated: NULL argument") : BST_EINVAL;
    int seen[NPKEYS];
    int rc = bsti_shade_spec(ctx, "perforated", spec, pkey, NPKEYS, perforated_item, p, seen);
    return rc < 0 ? rc : check(ctx, p, seen[P_R]);
}

/* The open share of the screen along unit direction d (either sign of d[2]). */
static double open_share(const bst_perforated *p, const double d[3])
{
    double az = fabs(d[2]);
    if (az < 1e-300)
        return 0.0;
    double sx = p->thickness * d[0] / az, sy = p->thickness * d[1] / az;
    if (isnan(p->radius)) /* rectangles */
        return fmax(0.0, p->hole_x - fabs(sx)) * fmax(0.0, p->hole_y - fabs(sy)) / (p->x * p->y);
    double a = p->radius, dd = hypot(sx, sy);
    if (dd >= 2 * a)
        return 0.0;
    double lens = 2 * a * a * acos(dd / (2 * a)) - dd / 2 * sqrt(4 * a * a - dd * dd);
    return lens / (p->x * p->y);
}

/* The first n points of the Halton sequence in bases 2 and 3 (as the venetian layer's). */
static void halton2(size_t k, double *u, double *v)
{
    double f = 1, r = 0;
    for (size_t i = k + 1; i; i /= 2)
        f /= 2, r += f * (double)(i % 2);
    *u = r;
    f = 1, r = 0;
    for (size_t i = k + 1; i; i /= 3)
        f /= 3, r += f * (double)(i % 3);
    *v = r;
}

/* Component c of channel ch: diag(dg[c]) + o in[c]^T, factored over the channel's map
 * [o | in[TF] | in[RF] | in[TB] | in[RB]] (K pairs column 0 with column 1 + c; none where in[c] is
 * NULL, so that a channel's components are all factored or none: bst_shade_model_plan), or the
 * diagonal alone without a map. */
static int sheet_component(bst_ctx *ctx, size_t n, bsti_lr_map *S, const double *dg,
                           const double *in, int c, bst_mat **out)
{
    if (!S) {
        if (dg)
            return bst_mat_new_diag(ctx, n, dg, out);
        double *z = bsti_calloc(ctx, n, sizeof *z);
        int rc = z ? bst_mat_new_diag(ctx, n, z, out) : BST_ENOMEM;
        bsti_free(ctx, z);
        return rc;
    }
    size_t r = S->r;
    double *K = bsti_calloc(ctx, r * r, sizeof *K);
    if (!K)
        return BST_ENOMEM;
    K[r * (1 + (size_t)c)] = in ? 1.0 : 0.0;
    bsti_lr *lr;
    int rc = bsti_lr_new(ctx, S, dg, NULL, K, NULL, &lr);
    if (rc >= 0)
        rc = bsti_mat_from_lr(ctx, lr, out);
    bsti_free(ctx, K);
    return rc;
}

int bsti_sheet_channel(bst_ctx *ctx, const bst_basis *basis, const double *o,
                       const double *const in[BST_NCOMP], const double *const dg[BST_NCOMP],
                       bst_layer *l, size_t ch)
{
    size_t n = bst_basis_size(basis), nnz = 0, r = 1 + BST_NCOMP;
    const double *col[1 + BST_NCOMP] = {o, in[0], in[1], in[2], in[3]};
    bsti_lr_map *S = NULL;
    int rc = BST_OK, any = in[0] || in[1] || in[2] || in[3];
    for (size_t q = 0; any && q < r; q++)
        for (size_t x = 0; col[q] && x < n; x++)
            nnz += col[q][x] != 0.0;
    if (any && (rc = bsti_lr_map_new(ctx, n, r, nnz, &S)) >= 0) {
        S->k = bst_basis_kind_of(basis) == BST_BASIS_SHIRLEY_CHIU ? bst_basis_order(basis) : -1;
        nnz = 0;
        for (size_t x = 0; x < n; x++) {
            S->start[x] = nnz;
            for (size_t q = 0; q < r; q++)
                if (col[q] && col[q][x] != 0.0)
                    S->col[nnz] = q, S->w[nnz++] = col[q][x];
        }
    }
    for (int c = 0; c < BST_NCOMP && rc >= 0; c++) {
        bst_mat *m = NULL;
        rc = sheet_component(ctx, n, S, dg[c], in[c], c, &m);
        if (rc >= 0)
            rc = bst_layer_set(ctx, l, ch, (bst_comp)c, m);
    }
    bsti_lr_map_free(ctx, S);
    return rc;
}

int bsti_open_layer(bst_ctx *ctx, const bst_basis *basis, double (*share)(const void *, const double *),
                    const void *data, const double v[3], const double sol[3], int samples,
                    size_t nchannels, const char *const *channels, bst_layer **out)
{
    static const char *const dual[] = {"Visible", "Solar"};
    if (!nchannels)
        nchannels = 2, channels = dual;
    size_t n = bst_basis_size(basis), nq = samples ? (size_t)samples : BST_VENETIAN_SAMPLES;
    const double *lam = bst_basis_lambda(basis);
    double *F = bsti_alloc_array(ctx, n, sizeof *F), Fm = 0;
    if (!F)
        return BST_ENOMEM;
    for (size_t i = 0; i < n; i++) { /* the open share averaged over the patch */
        double sum = 0;
        for (size_t k = 0; k < nq * nq; k++) {
            double u, v, d[3];
            halton2(k, &u, &v);
            bst_basis_sample(basis, i, u, v, d);
            sum += share(data, d);
        }
        F[i] = sum / (double)(nq * nq);
    }
    /* a patch and its antipode see the same openings (the share is even in d): one value for
     * both, so that the layer is reciprocal exactly */
    for (size_t i = 0; i < n; i++) {
        size_t a = bst_basis_antipode(basis, i);
        if (a > i && a < n)
            F[i] = F[a] = (F[i] + F[a]) / 2;
    }
    for (size_t i = 0; i < n; i++)
        Fm += lam[i] * F[i] / M_PI;
    /* the diffuse part r (1 - F_i)(1 - F_o) / (pi (1 - Fm)): o = 1 - F, in = r o / (pi (1 - Fm)) */
    double *buf = bsti_alloc_array(ctx, 6 * n, sizeof *buf);
    bst_layer *l = NULL;
    int rc = buf ? bst_layer_new(ctx, basis, nchannels, channels, &l) : BST_ENOMEM;
    double *o = buf, *diag = buf ? buf + n : NULL;
    for (size_t i = 0; buf && i < n; i++)
        o[i] = 1.0 - F[i], diag[i] = F[i] / lam[i];
    for (size_t ch = 0; ch < nchannels && rc >= 0; ch++) {
        double x[3] = {v[0], v[1], v[2]};
        for (int k = 0; k < 3 && strcasecmp(channels[ch], "Solar") == 0; k++)
            if (!isnan(sol[k]))
                x[k] = sol[k];
        const double r[BST_NCOMP] = {[BST_TF] = x[2], [BST_TB] = x[2], [BST_RF] = x[0], [BST_RB] = x[1]};
        const double *in[BST_NCOMP] = {NULL}, *dg[BST_NCOMP] = {NULL};
        for (int c = 0; c < BST_NCOMP; c++) {
            dg[c] = c == BST_TF || c == BST_TB ? diag : NULL;
            if (r[c] <= 0 || 1 - Fm < 1e-15)
                continue;
            double *w = buf + (2 + (size_t)c) * n;
            for (size_t i = 0; i < n; i++)
                w[i] = r[c] * o[i] / (M_PI * (1 - Fm));
            in[c] = w;
        }
        rc = bsti_sheet_channel(ctx, basis, o, in, dg, l, ch);
    }
    bsti_free(ctx, buf);
    bsti_free(ctx, F);
    if (rc < 0) {
        bst_layer_free(l);
        return rc;
    }
    *out = l;
    return BST_OK;
}

static double perforated_share(const void *data, const double *d)
{
    return open_share(data, d);
}

int bst_perforated_layer(bst_ctx *ctx, const bst_perforated *p, const bst_basis *basis,
                         size_t nchannels, const char *const *channels, bst_layer **out)
{
    if (!ctx || !p || !basis || !out || (nchannels && !channels))
        return ctx ? bsti_error(ctx, BST_EINVAL, "perforated layer: NULL argument") : BST_EINVAL;
    *out = NULL;
    const double v[3] = {p->rf, p->rb, p->t};
    int rc = check(ctx, p, 0);
    if (rc >= 0 && p->rule == BST_VENETIAN_CENTRE) /* WINDOW's model: sheet_wce.c */
        rc = bsti_sheet_wce_layer(ctx, basis, p, NULL, v, p->solar, nchannels, channels, out);
    else if (rc >= 0)
        rc = bsti_open_layer(ctx, basis, perforated_share, p, v, p->solar, p->samples, nchannels,
                             channels, out);
    return rc == BST_ENOMEM ? bsti_error(ctx, rc, "perforated layer: out of memory") : rc;
}
