/* venetian_spec.c - what "venetian:SPEC" names: a blind's geometry and slat surfaces as
 * key=value pairs (bsdfstack.h: bst_venetian; bsdfstack-glass(5)).
 *
 * Keys: width, spacing, curvature (lengths as glass: takes them: 16mm, 0.016m, 1.6cm, 0.63in,
 * bare = mm), tilt (degrees), segments, samples (counts), vertical (a flag, or vertical=0|1),
 * r (both faces' diffuse reflectance), r-up, r-down, t, rs, roughness (numbers; the first five
 * also as VISIBLE/SOLAR: the second for a channel named Solar, the first for any other), rule
 * (average | centre: WINDOW's model, venetian_wce.c) and distribution (directional | uniform).  Every message
 * names the key it is about, so that a script's user finds the mistake in a long spec. */
#include <config.h>

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "numtext.h"
#include "venetian.h"

#define VN_MAX_SEGMENTS 1000 /* strips per face: the radiosity matrix is (2 segments)^2 */
#define VN_MAX_SAMPLES 64    /* directions per patch side: samples^2 per patch */

void bst_venetian_init(bst_venetian *v)
{
    if (!v)
        return;
    memset(v, 0, sizeof *v);
    v->width = v->spacing = NAN;
    v->solar[0] = v->solar[1] = v->solar[2] = v->solar[3] = NAN;
    v->segments = BST_VENETIAN_SEGMENTS;
}

int bsti_shade_spec(bst_ctx *ctx, const char *what, const char *spec, const char *const *keys,
                    int nkeys, bsti_shade_set set, void *opaque, int *seen)
{
    char buf[512];
    if (strlen(spec) >= sizeof buf)
        return bsti_error(ctx, BST_EINVAL, "%s: description too long", what);
    strcpy(buf, spec);
    memset(seen, 0, (size_t)nkeys * sizeof *seen);
    char *save = NULL;
    for (char *kv = strtok_r(buf, ",", &save); kv; kv = strtok_r(NULL, ",", &save)) {
        while (isspace((unsigned char)*kv))
            kv++;
        char *eq = strchr(kv, '=');
        if (eq)
            *eq = '\0';
        int k = 0;
        while (k < nkeys && strcmp(kv, keys[k]) != 0)
            k++;
        if (k == nkeys) {
            char list[256] = "";
            for (int i = 0; i < nkeys; i++)
                snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", i ? ", " : "", keys[i]);
            return bsti_error(ctx, BST_EINVAL, "%s: unknown key '%s' (keys: %s)", what, kv, list);
        }
        if (seen[k])
            return bsti_error(ctx, BST_EINVAL, "%s: %s given twice", what, keys[k]);
        int rc = set(ctx, k, eq ? eq + 1 : NULL, seen, opaque);
        if (rc < 0)
            return rc;
        seen[k] = 1;
    }
    return BST_OK;
}


int bsti_shade_parse_length(const char *v, double *m)
{
    static const char *const suffix[] = {"", "mm", "m", "cm", "in", NULL};
    static const double factor[] = {1e-3, 1e-3, 1.0, 1e-2, 0.0254};
    return bsti_parse_scaled(v, suffix, factor, m);
}

int bsti_shade_parse_number(const char *v, double *x)
{
    static const char *const suffix[] = {"", NULL};
    static const double factor[] = {1.0};
    return bsti_parse_scaled(v, suffix, factor, x);
}

int bsti_shade_parse_bands(const char *v, double *vis, double *sol)
{
    const char *slash = strchr(v, '/');
    char first[64];
    *sol = NAN;
    if (!slash)
        return bsti_shade_parse_number(v, vis);
    size_t n = (size_t)(slash - v);
    if (n >= sizeof first)
        return -1;
    memcpy(first, v, n);
    first[n] = '\0';
    return bsti_shade_parse_number(first, vis) || bsti_shade_parse_number(slash + 1, sol) ? -1 : 0;
}

static int parse_count(const char *v, int lo, int hi, int *n)
{
    char *end;
    errno = 0;
    long x = strtol(v, &end, 10);
    if (end == v || *end || errno || x < lo || x > hi)
        return -1;
    *n = (int)x;
    return 0;
}

enum { K_WIDTH, K_SPACING, K_TILT, K_CURV, K_SEG, K_SAMPLES, K_VERT, K_R, K_RUP, K_RDOWN, K_T,
       K_RS, K_ROUGH, K_RULE, K_DIST, NKEYS };
static const char *const key_name[NKEYS] = {"width", "spacing", "tilt", "curvature", "segments",
                                            "samples", "vertical", "r", "r-up", "r-down", "t",
                                            "rs", "roughness", "rule", "distribution"};

/* The words of rule= and distribution=, by value (bsdfstack.h: BST_VENETIAN_AVERAGE, ...). */
static int parse_word(const char *val, const char *const *words, int nwords, int *x)
{
    for (int k = 0; k < nwords; k++)
        if (strcmp(val, words[k]) == 0) {
            *x = k;
            return 0;
        }
    return -1;
}

/* One key=value (val NULL: a bare key) into v. */
static int set_key(bst_ctx *ctx, int k, const char *val, bst_venetian *v)
{
    double x = NAN;
    int bad = 0;
    if (k == K_VERT) {
        if (!val)
            v->vertical = 1;
        else
            bad = parse_count(val, 0, 1, &v->vertical);
    } else if (!val) {
        return bsti_error(ctx, BST_EINVAL, "venetian: %s needs a value (%s=...)", key_name[k],
                          key_name[k]);
    } else if (k == K_RULE || k == K_DIST) {
        static const char *const rules[] = {"average", "centre"}, *const dists[] = {"directional", "uniform"};
        if (k == K_RULE && strcmp(val, "center") == 0)
            val = "centre";
        if (parse_word(val, k == K_RULE ? rules : dists, 2, k == K_RULE ? &v->rule : &v->distribution))
            return bsti_error(ctx, BST_EINVAL, "venetian: %s: '%s' is not %s", key_name[k], val,
                              k == K_RULE ? "average or centre" : "directional or uniform");
    } else if (k == K_SEG) {
        bad = parse_count(val, 1, VN_MAX_SEGMENTS, &v->segments);
    } else if (k == K_SAMPLES) {
        bad = parse_count(val, 0, VN_MAX_SAMPLES, &v->samples);
    } else if (k == K_WIDTH || k == K_SPACING || k == K_CURV) {
        bad = bsti_shade_parse_length(val, &x);
    } else if (k >= K_R && k <= K_RS && strchr(val, '/')) { /* VISIBLE/SOLAR */
        char two[64];
        double y = NAN;
        snprintf(two, sizeof two, "%s", val);
        char *slash = strchr(two, '/');
        *slash = '\0';
        bad = bsti_shade_parse_number(two, &x) || bsti_shade_parse_number(slash + 1, &y);
        if (!bad) {
            if (k == K_R || k == K_RUP)
                v->solar[0] = y;
            if (k == K_R || k == K_RDOWN)
                v->solar[1] = y;
            if (k == K_T)
                v->solar[2] = y;
            if (k == K_RS)
                v->solar[3] = y;
        }
    } else {
        bad = bsti_shade_parse_number(val, &x);
        /* one value for every channel: a Solar value given before (a record's, under
         * bst_venetian_update) no longer applies */
        if (!bad && (k == K_R || k == K_RUP))
            v->solar[0] = NAN;
        if (!bad && (k == K_R || k == K_RDOWN))
            v->solar[1] = NAN;
        if (!bad && k == K_T)
            v->solar[2] = NAN;
        if (!bad && k == K_RS)
            v->solar[3] = NAN;
    }
    if (bad)
        return bsti_error(ctx, BST_EINVAL, "venetian: %s: '%s' is not %s", key_name[k], val,
                          k == K_SEG ? "a count of 1 to 1000" : k == K_SAMPLES ? "a count of 0 (automatic) to 64"
                          : k == K_VERT ? "0 or 1" : k <= K_CURV && k != K_TILT
                          ? "a length (16mm, 0.016m, 1.6cm, 0.63in)"
                          : k >= K_R && k <= K_RS ? "a number or VISIBLE/SOLAR" : "a number");
    switch (k) {
    case K_WIDTH: v->width = x; break;
    case K_SPACING: v->spacing = x; break;
    case K_TILT: v->tilt = x; break;
    case K_CURV: v->curvature = x; break;
    case K_R: v->r_up = v->r_down = x; break;
    case K_RUP: v->r_up = x; break;
    case K_RDOWN: v->r_down = x; break;
    case K_T: v->t = x; break;
    case K_RS: v->rs = x; break;
    case K_ROUGH: v->roughness = x; break;
    default: break;
    }
    return BST_OK;
}

/* One item of a venetian spec (bsti_shade_set): r and r-up/r-down overlap, each face named
 * once. */
static int venetian_item(bst_ctx *ctx, int k, const char *val, const int *seen, void *opaque)
{
    if ((k == K_R && (seen[K_RUP] || seen[K_RDOWN])) || ((k == K_RUP || k == K_RDOWN) && seen[K_R]))
        return bsti_error(ctx, BST_EINVAL, "venetian: %s given twice", key_name[k]);
    return set_key(ctx, k, val, opaque);
}

int bst_venetian_parse(bst_ctx *ctx, const char *spec, bst_venetian *v)
{
    if (!ctx || !spec || !v)
        return ctx ? bsti_error(ctx, BST_EINVAL, "venetian: NULL argument") : BST_EINVAL;
    bst_venetian_init(v);
    int seen[NKEYS];
    int rc = bsti_shade_spec(ctx, "venetian", spec, key_name, NKEYS, venetian_item, v, seen);
    if (rc < 0)
        return rc;
    if (!seen[K_WIDTH] || !seen[K_SPACING])
        return bsti_error(ctx, BST_EINVAL, "venetian: %s missing (width and spacing are needed)",
                          seen[K_WIDTH] ? "spacing" : "width");
    if (seen[K_DIST] && v->rule != BST_VENETIAN_CENTRE)
        return bsti_error(ctx, BST_EINVAL, "venetian: distribution needs rule=centre (WINDOW's model)");
    if (v->rule == BST_VENETIAN_CENTRE && !seen[K_SEG]) /* WINDOW's default */
        v->segments = BST_VENETIAN_WCE_SEGMENTS;
    return bst_venetian_check(ctx, v);
}

int bst_venetian_update(bst_ctx *ctx, const char *spec, bst_venetian *v)
{
    if (!ctx || !spec || !v)
        return ctx ? bsti_error(ctx, BST_EINVAL, "venetian: NULL argument") : BST_EINVAL;
    int seen[NKEYS];
    int rc = bsti_shade_spec(ctx, "venetian", spec, key_name, NKEYS, venetian_item, v, seen);
    return rc < 0 ? rc : bst_venetian_check(ctx, v);
}

/* A reflectance or transmittance key's value must lie in [0, 1]. */
static int check_unit(bst_ctx *ctx, const char *key, const char *sfx, double x)
{
    if (!(x >= 0.0 && x <= 1.0))
        return bsti_error(ctx, BST_EINVAL, "venetian: %s%s = %g is not between 0 and 1", key, sfx, x);
    return BST_OK;
}

int bsti_vn_solar(const bst_venetian *v, bst_venetian *vs)
{
    *vs = *v;
    double *sv[4] = {&vs->r_up, &vs->r_down, &vs->t, &vs->rs};
    int differ = 0;
    for (int k = 0; k < 4; k++)
        if (!isnan(v->solar[k]) && v->solar[k] != *sv[k])
            *sv[k] = v->solar[k], differ = 1;
    return differ;
}

int bst_venetian_check(bst_ctx *ctx, const bst_venetian *v)
{
    if (!ctx || !v)
        return ctx ? bsti_error(ctx, BST_EINVAL, "venetian: NULL argument") : BST_EINVAL;
    if (!(v->width > 0.0) || !isfinite(v->width))
        return bsti_error(ctx, BST_EINVAL, "venetian: width = %g m is not positive", v->width);
    if (v->precision != BST_DOUBLE && v->precision != BST_FLOAT)
        return bsti_error(ctx, BST_EINVAL, "venetian: precision = %d is not BST_DOUBLE or BST_FLOAT",
                          (int)v->precision);
    if (!(v->spacing > 0.0) || !isfinite(v->spacing))
        return bsti_error(ctx, BST_EINVAL, "venetian: spacing = %g m is not positive", v->spacing);
    if (!(fabs(v->tilt) <= 90.0))
        return bsti_error(ctx, BST_EINVAL, "venetian: tilt = %g is not between -90 and 90 degrees",
                          v->tilt);
    if (!(v->curvature == 0.0 || v->curvature >= v->width / 2))
        return bsti_error(ctx, BST_EINVAL, "venetian: curvature = %g m is neither 0 (flat) nor at "
                          "least half the width (%g m)", v->curvature, v->width / 2);
    if (v->segments < 1 || v->segments > VN_MAX_SEGMENTS)
        return bsti_error(ctx, BST_EINVAL, "venetian: segments = %d is not 1 to %d", v->segments,
                          VN_MAX_SEGMENTS);
    if (v->samples < 0 || v->samples > VN_MAX_SAMPLES)
        return bsti_error(ctx, BST_EINVAL, "venetian: samples = %d is not 0 (automatic) to %d", v->samples,
                          VN_MAX_SAMPLES);
    for (int band = 0; band < 2; band++) { /* the values, then the Solar channel's */
        double x[4] = {v->r_up, v->r_down, v->t, v->rs};
        for (int k = 0; band && k < 4; k++)
            if (!isnan(v->solar[k]))
                x[k] = v->solar[k];
        int rc;
        const char *sfx = band ? " (Solar)" : "";
        if ((rc = check_unit(ctx, "r-up", sfx, x[0])) < 0 || (rc = check_unit(ctx, "r-down", sfx, x[1])) < 0 ||
            (rc = check_unit(ctx, "t", sfx, x[2])) < 0 || (rc = check_unit(ctx, "rs", sfx, x[3])) < 0)
            return rc;
        double up = x[0] + x[2] + x[3], down = x[1] + x[2] + x[3];
        if (up > 1.0 + 1e-12 || down > 1.0 + 1e-12)
            return bsti_error(ctx, BST_EINVAL, "venetian: %s + t + rs%s = %g is above 1",
                              up >= down ? "r-up" : "r-down", sfx, fmax(up, down));
    }
    if (!(v->roughness >= 0.0) || !isfinite(v->roughness))
        return bsti_error(ctx, BST_EINVAL, "venetian: roughness = %g is not a slope >= 0",
                          v->roughness);
    int rc = bsti_vn_wce_check(ctx, v);
    if (rc < 0)
        return rc;
    return BST_OK;
}
