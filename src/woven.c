/* woven.c - a woven fabric from its geometry (bsdfstack.h: bst_woven), spec and layer.
 *
 * Keys: diameter, spacing (lengths as glass: takes them, bare = mm), r (both faces) or rf, rb
 * (exterior, interior face), t (numbers, or VISIBLE/SOLAR: the second for a channel named Solar),
 * samples, rule (average, or centre: WINDOW's model, sheet_wce.c).
 * Two sets of cylindrical threads, along X and along Y, every `spacing`.  A cylinder of diameter d
 * casts a shadow d / cos(theta_p) wide on the fabric's plane, theta_p the direction's angle from
 * the normal in the plane across the threads, so the open share along unit direction d is
 *   (1 - d / (s cos theta_x))+ (1 - d / (s cos theta_y))+,
 * cos theta_x = |dz| / sqrt(dx^2 + dz^2) (threads along Y) and likewise for y: at the normal the
 * openness (1 - d / s)^2.  The rest is scattered diffusely as by a perforated screen
 * (bsti_open_layer). */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "venetian.h"

enum { W_DIAM, W_SPACING, W_R, W_RF, W_RB, W_T, W_SAMPLES, W_RULE, NWKEYS };
static const char *const wkey[NWKEYS] = {"diameter", "spacing", "r", "rf", "rb", "t", "samples",
                                        "rule"};

void bst_woven_init(bst_woven *w)
{
    if (!w)
        return;
    memset(w, 0, sizeof *w);
    w->diameter = w->spacing = NAN;
    w->solar[0] = w->solar[1] = w->solar[2] = NAN;
}

static int set_wkey(bst_ctx *ctx, int k, const char *val, bst_woven *w)
{
    if (k == W_RULE)
        return bsti_shade_parse_rule(ctx, "woven", val, &w->rule);
    if (k == W_SAMPLES) {
        char *end;
        long n = strtol(val, &end, 10);
        if (end == val || *end || n < 0 || n > 64)
            return bsti_error(ctx, BST_EINVAL, "woven: samples: '%s' is not a count of 0 "
                              "(automatic) to 64", val);
        w->samples = (int)n;
        return BST_OK;
    }
    double x, sol = NAN;
    int length = k <= W_SPACING;
    if (length ? bsti_shade_parse_length(val, &x) : bsti_shade_parse_bands(val, &x, &sol))
        return bsti_error(ctx, BST_EINVAL, "woven: %s: '%s' is not %s", wkey[k], val,
                          length ? "a length (0.5mm, 0.0005m, 0.05cm)" : "a number or VISIBLE/SOLAR");
    double *slot[NWKEYS] = {&w->diameter, &w->spacing, &w->rf, &w->rf, &w->rb, &w->t, NULL, NULL};
    *slot[k] = x;
    if (k == W_R)
        w->rb = x, w->solar[0] = w->solar[1] = sol;
    if (k >= W_RF && k <= W_T)
        w->solar[k - W_RF] = sol;
    return BST_OK;
}

static int check(bst_ctx *ctx, const bst_woven *w, int named_r)
{
    if (!(w->spacing > 0) || !isfinite(w->spacing))
        return bsti_error(ctx, BST_EINVAL, "woven: spacing = %g m is not positive", w->spacing);
    if (!(w->diameter > 0 && w->diameter <= w->spacing))
        return bsti_error(ctx, BST_EINVAL, "woven: diameter = %g m is not positive and at most the "
                          "spacing", w->diameter);
    const char *names[3] = {named_r ? "r" : "rf", named_r ? "r" : "rb", "t"};
    const double v[3] = {w->rf, w->rb, w->t};
    int rc = bsti_sheet_check(ctx, "woven", names, v, w->solar);
    return rc < 0 ? rc : bsti_sheet_wce_check(ctx, "woven", w->rule, w->samples, v, w->solar);
}

/* One item of a woven spec (bsti_shade_set): every key needs a value; r and rf/rb overlap. */
static int woven_item(bst_ctx *ctx, int k, const char *val, const int *seen, void *opaque)
{
    if (!val)
        return bsti_error(ctx, BST_EINVAL, "woven: %s needs a value (%s=...)", wkey[k], wkey[k]);
    if ((k == W_R && (seen[W_RF] || seen[W_RB])) || ((k == W_RF || k == W_RB) && seen[W_R]))
        return bsti_error(ctx, BST_EINVAL, "woven: %s given twice", wkey[k]);
    return set_wkey(ctx, k, val, opaque);
}

int bst_woven_parse(bst_ctx *ctx, const char *spec, bst_woven *w)
{
    if (!ctx || !spec || !w)
        return ctx ? bsti_error(ctx, BST_EINVAL, "woven: NULL argument") : BST_EINVAL;
    bst_woven_init(w);
    int seen[NWKEYS];
    int rc = bsti_shade_spec(ctx, "woven", spec, wkey, NWKEYS, woven_item, w, seen);
    if (rc < 0)
        return rc;
    if (!seen[W_DIAM] || !seen[W_SPACING])
        return bsti_error(ctx, BST_EINVAL, "woven: %s missing (diameter and spacing are needed)",
                          seen[W_DIAM] ? "spacing" : "diameter");
    return check(ctx, w, seen[W_R]);
}

int bst_woven_update(bst_ctx *ctx, const char *spec, bst_woven *w)
{
    if (!ctx || !spec || !w)
        return ctx ? bsti_error(ctx, BST_EINVAL, "woven: NULL argument") : BST_EINVAL;
    int seen[NWKEYS];
    int rc = bsti_shade_spec(ctx, "woven", spec, wkey, NWKEYS, woven_item, w, seen);
    return rc < 0 ? rc : check(ctx, w, seen[W_R]);
}

/* The open share along unit direction d (see the top of the file). */
static double woven_share(const void *data, const double *d)
{
    const bst_woven *w = data;
    double az = fabs(d[2]), ratio = w->diameter / w->spacing;
    if (az < 1e-300)
        return 0.0;
    double cx = az / hypot(d[0], az), cy = az / hypot(d[1], az);
    return fmax(0.0, 1.0 - ratio / cx) * fmax(0.0, 1.0 - ratio / cy);
}

int bst_woven_layer(bst_ctx *ctx, const bst_woven *w, const bst_basis *basis, size_t nchannels,
                    const char *const *channels, bst_layer **out)
{
    if (!ctx || !w || !basis || !out || (nchannels && !channels))
        return ctx ? bsti_error(ctx, BST_EINVAL, "woven layer: NULL argument") : BST_EINVAL;
    *out = NULL;
    const double v[3] = {w->rf, w->rb, w->t};
    int rc = check(ctx, w, 0);
    if (rc >= 0 && w->rule == BST_VENETIAN_CENTRE) /* WINDOW's model: sheet_wce.c */
        rc = bsti_sheet_wce_layer(ctx, basis, NULL, w, v, w->solar, nchannels, channels, out);
    else if (rc >= 0)
        rc = bsti_open_layer(ctx, basis, woven_share, w, v, w->solar, w->samples, nchannels,
                             channels, out);
    return rc == BST_ENOMEM ? bsti_error(ctx, rc, "woven layer: out of memory") : rc;
}
