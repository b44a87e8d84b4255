/* woven.c - a woven fabric from its geometry (bsdfstack.h: bst_woven), spec and layer.
 *
 * Keys: diameter, spacing (lengths as glass: takes them, bare = mm), r, t (numbers), samples.
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

enum { W_DIAM, W_SPACING, W_R, W_T, W_SAMPLES, NWKEYS };
static const char *const wkey[NWKEYS] = {"diameter", "spacing", "r", "t", "samples"};

static int set_wkey(bst_ctx *ctx, int k, const char *val, bst_woven *w)
{
    if (k == W_SAMPLES) {
        char *end;
        long n = strtol(val, &end, 10);
        if (end == val || *end || n < 0 || n > 64)
            return bsti_error(ctx, BST_EINVAL, "woven: samples: '%s' is not a count of 0 "
                              "(automatic) to 64", val);
        w->samples = (int)n;
        return BST_OK;
    }
    double x;
    int length = k <= W_SPACING;
    if (length ? bsti_shade_parse_length(val, &x) : bsti_shade_parse_number(val, &x))
        return bsti_error(ctx, BST_EINVAL, "woven: %s: '%s' is not %s", wkey[k], val,
                          length ? "a length (0.5mm, 0.0005m, 0.05cm)" : "a number");
    double *slot[NWKEYS] = {&w->diameter, &w->spacing, &w->r, &w->t, NULL};
    *slot[k] = x;
    return BST_OK;
}

static int check(bst_ctx *ctx, const bst_woven *w)
{
    if (!(w->spacing > 0) || !isfinite(w->spacing))
        return bsti_error(ctx, BST_EINVAL, "woven: spacing = %g m is not positive", w->spacing);
    if (!(w->diameter > 0 && w->diameter <= w->spacing))
        return bsti_error(ctx, BST_EINVAL, "woven: diameter = %g m is not positive and at most the "
                          "spacing", w->diameter);
    if (!(w->r >= 0 && w->r <= 1))
        return bsti_error(ctx, BST_EINVAL, "woven: r = %g is not between 0 and 1", w->r);
    if (!(w->t >= 0 && w->t <= 1))
        return bsti_error(ctx, BST_EINVAL, "woven: t = %g is not between 0 and 1", w->t);
    if (w->r + w->t > 1 + 1e-12)
        return bsti_error(ctx, BST_EINVAL, "woven: r + t = %g is above 1", w->r + w->t);
    return BST_OK;
}

/* One item of a woven spec (bsti_shade_set): every key needs a value. */
static int woven_item(bst_ctx *ctx, int k, const char *val, const int *seen, void *opaque)
{
    (void)seen;
    if (!val)
        return bsti_error(ctx, BST_EINVAL, "woven: %s needs a value (%s=...)", wkey[k], wkey[k]);
    return set_wkey(ctx, k, val, opaque);
}

int bst_woven_parse(bst_ctx *ctx, const char *spec, bst_woven *w)
{
    if (!ctx || !spec || !w)
        return ctx ? bsti_error(ctx, BST_EINVAL, "woven: NULL argument") : BST_EINVAL;
    memset(w, 0, sizeof *w);
    w->diameter = w->spacing = NAN;
    int seen[NWKEYS];
    int rc = bsti_shade_spec(ctx, "woven", spec, wkey, NWKEYS, woven_item, w, seen);
    if (rc < 0)
        return rc;
    if (!seen[W_DIAM] || !seen[W_SPACING])
        return bsti_error(ctx, BST_EINVAL, "woven: %s missing (diameter and spacing are needed)",
                          seen[W_DIAM] ? "spacing" : "diameter");
    return check(ctx, w);
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
    int rc = bsti_open_layer(ctx, basis, woven_share, w, w->r, w->r, w->t, w->samples, nchannels,
                             channels, out);
    return rc == BST_ENOMEM ? bsti_error(ctx, rc, "woven layer: out of memory") : rc;
}
