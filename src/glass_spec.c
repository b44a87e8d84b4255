/* glass_spec.c - what "glass:SPEC" names: a catalogue pane, a spectral data file or an inline pane,
 * and which angular model the pane follows.
 *
 * Specs (bsdfstack.h, bsdfstack-glass(5)): NAME is the catalogue file NAME.glass in the catalogue
 * directory; FILE (a '/' or a .tsv ending, or a file that exists where the catalogue has no such
 * pane) a spectral data file in any of its formats (glass_band.c, glass_optics.c, glass_json.c)
 * averaged over Visible and Solar; "key=value,..." an inline pane applied to Visible and Solar
 * alike.  Any of them may carry ",model=uncoated|coated", which overrides the model the file's or
 * catalogue's material type gives (settle_model).  Inline keys: d (thickness, a
 * length: 6mm, 0.006m, 0.6cm, 0.25in, bare = mm), n (index), tn (normal-incidence T of a slab
 * of index n), k (extinction coefficient, 1/m: tau0 = exp(-k d)), t0, r0 (= r0f), r0b
 * (normal-incidence T and R).  Everything ends as normal-incidence T0 and R0 per side, the input
 * of the slab model (glass.c); a catalogue file lists such channels and at most one spectral data
 * file (glass_band.c).
 * Every message names where the problem is: the spec, or the catalogue file and line. */
#include <config.h>

#include <ctype.h>
#ifdef HAVE_DLADDR
#include <dlfcn.h>
#endif
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "ctx.h"
#include "numtext.h"
#include "glass.h"

/* Refractive index assumed by inline specs that give none (soda-lime float glass). */
#define GLASS_DEFAULT_N 1.52

/* ------------------------------------------------------------------ the catalogue */

/* The installed catalogue (BST_GLASS_DIR, under the configured prefix), or the source tree's
 * layers/glass when the code running is the build tree's own, not installed: this library (or a
 * program linking it statically) lies in the build directory or its .libs.  So the programs and the
 * Python package find the catalogue from a fresh build without an environment variable, and an
 * installed copy never looks into a build tree. */
const char *bst_glass_catalogue_dir(void)
{
#if defined(HAVE_DLADDR) && defined(BST_BUILD_DIR) && defined(BST_SOURCE_GLASS_DIR)
    Dl_info info;
    char self[PATH_MAX], build[PATH_MAX];
    if (dladdr((void *)bst_glass_catalogue_dir, &info) && info.dli_fname &&
        realpath(info.dli_fname, self) && realpath(BST_BUILD_DIR, build)) {
        char *slash = strrchr(self, '/');
        if (slash) {
            *slash = '\0';
            size_t n = strlen(build), m = strlen(self);
            int in_build = strcmp(self, build) == 0 ||
                           (m == n + 6 && strncmp(self, build, n) == 0 && strcmp(self + n, "/.libs") == 0);
            if (in_build && access(BST_SOURCE_GLASS_DIR, R_OK | X_OK) == 0)
                return BST_SOURCE_GLASS_DIR;
        }
    }
#endif
    return BST_GLASS_DIR;
}

/* ------------------------------------------------------------------ inline specs */


/* "6mm", "0.006m", "0.6cm", "0.25in" or a bare number of millimetres -> metres. */
static int parse_length(const char *v, double *m)
{
    static const char *const suffix[] = {"", "mm", "m", "cm", "in", NULL};
    static const double factor[] = {1e-3, 1e-3, 1.0, 1e-2, 0.0254};
    return bsti_parse_scaled(v, suffix, factor, m);
}

/* An extinction coefficient: "25", "25/m", "0.25/cm", "0.025/mm" -> 1/m. */
static int parse_extinction(const char *v, double *k)
{
    static const char *const suffix[] = {"", "/m", "/cm", "/mm", NULL};
    static const double factor[] = {1.0, 1.0, 1e2, 1e3};
    return bsti_parse_scaled(v, suffix, factor, k);
}

static int parse_number(const char *v, double *x)
{
    char *end;
    errno = 0;
    *x = strtod(v, &end);
    return (end == v || *end || !isfinite(*x) || errno) ? -1 : 0;
}

/* Parse "key=value,key=value" into the two sides of one band channel. */
static int parse_params(bst_ctx *ctx, const char *where, const char *text,
                        struct bsti_glass_side *f, struct bsti_glass_side *b)
{
    enum { D, N, TN, K, T0, R0, R0B, NKEYS };
    static const char *const keys[NKEYS] = {"d", "n", "tn", "k", "t0", "r0", "r0b"};
    double v[NKEYS];
    for (int i = 0; i < NKEYS; i++)
        v[i] = NAN;
    char buf[512];
    if (strlen(text) >= sizeof buf)
        return bsti_error(ctx, BST_EINVAL, "%s: pane description too long", where);
    strcpy(buf, text);
    char *save = NULL;
    for (char *kv = strtok_r(buf, ",", &save); kv; kv = strtok_r(NULL, ",", &save)) {
        while (isspace((unsigned char)*kv))
            kv++;
        char *eq = strchr(kv, '=');
        if (!eq)
            return bsti_error(ctx, BST_EINVAL, "%s: '%s' is not key=value (keys: d, n, tn, k, t0, "
                              "r0, r0b)", where, kv);
        *eq = '\0';
        const char *key = kv, *val = eq + 1;
        int i = 0;
        while (i < NKEYS && strcmp(key, keys[i]) != 0)
            i++;
        if (i == NKEYS && strcmp(key, "r0f") == 0)
            i = R0;
        if (i == NKEYS)
            return bsti_error(ctx, BST_EINVAL, "%s: unknown glass parameter '%s' (keys: d, n, tn, "
                              "k, t0, r0, r0b)", where, key);
        if (!isnan(v[i]))
            return bsti_error(ctx, BST_EINVAL, "%s: %s given twice", where, keys[i]);
        double x = NAN;
        int bad;
        switch (i) {
        case D: bad = parse_length(val, &x) || !(x >= 0.0 && x < 1.0); break;
        case N: bad = parse_number(val, &x) || !(x > 1.0 && x < 5.0); break;
        case K: bad = parse_extinction(val, &x) || !(x >= 0.0); break;
        case R0:
        case R0B: bad = parse_number(val, &x) || !(x >= 0.0 && x < 1.0); break;
        default: bad = parse_number(val, &x) || !(x >= 0.0 && x <= 1.0); break; /* tn, t0 */
        }
        if (bad)
            return bsti_error(ctx, BST_EINVAL, "%s: %s=%s is not a valid value (d: a length in "
                              "[0, 1 m) such as 6mm; n: in (1, 5); tn, t0: in [0, 1]; k: >= 0 per "
                              "metre such as 25/m; r0, r0b: in [0, 1), as a slab reflecting all "
                              "would need an infinite index)", where, key, val);
        v[i] = x;
    }
    double t0 = v[T0], r0f = v[R0], r0b = v[R0B];
    int slab = !isnan(v[TN]) || !isnan(v[K]);
    if (slab) { /* a slab of index n: absorption from tn, or from k and d */
        if (!isnan(t0) || !isnan(r0f) || !isnan(r0b))
            return bsti_error(ctx, BST_EINVAL, "%s: give n with tn or k, or t0 and r0, not both",
                              where);
        if (!isnan(v[TN]) && !isnan(v[K]))
            return bsti_error(ctx, BST_EINVAL, "%s: give either tn or k (with d)", where);
        if (!isnan(v[K]) && isnan(v[D]))
            return bsti_error(ctx, BST_EINVAL, "%s: k needs the thickness d", where);
        double n = isnan(v[N]) ? GLASS_DEFAULT_N : v[N];
        double rho = (n - 1) / (n + 1);
        rho *= rho;
        double tau;
        if (!isnan(v[K])) {
            tau = exp(-v[K] * v[D]);
            t0 = tau * (1 - rho) * (1 - rho) / ((1 - tau * rho) * (1 + tau * rho));
        } else {
            double tn = v[TN], tmax = (1 - rho) / (1 + rho);
            if (tn > tmax)
                return bsti_error(ctx, BST_EINVAL, "%s: tn=%g exceeds %.4f, the transmittance of "
                                  "a non-absorbing pane of index %g", where, tn, tmax, n);
            /* tau from tn = tau (1 - rho)^2 / (1 - tau^2 rho^2): the positive root of
             * tn rho^2 tau^2 + (1 - rho)^2 tau - tn = 0, written without cancellation */
            double p = (1 - rho) * (1 - rho);
            tau = tn == 0.0 ? 0.0 : 2.0 * tn / (p + sqrt(p * p + 4.0 * tn * tn * rho * rho));
            t0 = tn;
        }
        r0f = r0b = rho * (1 + tau * t0);
    } else if (!isnan(v[N])) { /* d alone is descriptive, as with tn */
        if (isnan(t0) || isnan(r0f))
            return bsti_error(ctx, BST_EINVAL, "%s: a pane of index n needs tn or k (with d)",
                              where);
        return bsti_error(ctx, BST_EINVAL, "%s: t0 and r0 fix the refractive index: give no n "
                          "with them", where);
    }
    if (isnan(t0) || isnan(r0f))
        return bsti_error(ctx, BST_EINVAL, "%s: a pane needs tn (with n), k (with d and n), or t0 "
                          "and r0", where);
    if (isnan(r0b))
        r0b = r0f;
    if (t0 + r0f > 1.0 || t0 + r0b > 1.0)
        return bsti_error(ctx, BST_EINVAL, "%s: T0 + R0 = %g exceeds 1", where, t0 + fmax(r0f, r0b));
    if (bsti_glass_side_init(f, t0, r0f) || bsti_glass_side_init(b, t0, r0b))
        return bsti_error(ctx, BST_EINVAL, "%s: no uncoated pane has T0 = %g and R0 = %g", where,
                          t0, r0f);
    return BST_OK;
}

static int add_inline(bst_ctx *ctx, bst_glass *g, const char *where, const char *name,
                      const char *params)
{
    if (g->nch >= BSTI_GLASS_MAX_CH)
        return bsti_error(ctx, BST_EINVAL, "%s: more than %d channels", where, BSTI_GLASS_MAX_CH);
    int rc = bsti_glass_channel_new(ctx, g, where, name, 1);
    if (rc >= 0) {
        struct bsti_glass_channel *c = &g->ch[g->nch];
        c->w[0] = 1.0;
        rc = parse_params(ctx, where, params, &c->front[0], &c->back[0]);
    }
    return bsti_glass_channel_commit(ctx, g, rc);
}

/* A spectral data file and the bands to average it over (space-separated names; "" = the
 * caller's bands, deflt, or, without them (NULL), Visible and Solar). */
static int add_spectral(bst_ctx *ctx, bst_glass *g, const char *where, const char *path,
                        const char *dir, char *names, const char *deflt)
{
    if (g->data.n)
        return bsti_error(ctx, BST_EINVAL, "%s: a second spectral data file", where);
    int rc = bsti_glass_load_spectral(ctx, g, path, dir);
    char def[64];
    snprintf(def, sizeof def, "%s", deflt ? deflt : "Visible Solar");
    char *save = NULL;
    for (char *b = strtok_r(*names ? names : def, " \t", &save); b && rc >= 0;
         b = strtok_r(NULL, " \t", &save)) {
        const struct bsti_glass_band *band = bsti_glass_find_band(b);
        rc = band ? bsti_glass_add_band(ctx, g, path, band)
                  : bsti_error(ctx, BST_EINVAL,
                               "%s: unknown spectral band '%s' (" BSTI_GLASS_BAND_LIST ")", where,
                               b);
    }
    return rc;
}

/* "uncoated" or "coated" -> *m; -1 for anything else. */
static int parse_model(const char *v, bst_glass_model *m)
{
    if (strcmp(v, "uncoated") == 0)
        *m = BST_GLASS_UNCOATED;
    else if (strcmp(v, "coated") == 0)
        *m = BST_GLASS_COATED;
    else
        return -1;
    return 0;
}

/* A catalogue file (bsdfstack-glass(5)): '#' comments; "description TEXT"; "spectral FILE
 * [BAND...]" (FILE relative to the catalogue directory); "type TYPE"; "model MODEL" (*model, -1
 * when the file gives none); "CHANNEL key=value,...". */
static int read_catalogue(bst_ctx *ctx, bst_glass *g, const char *path, const char *name,
                          const char *dir, const char *bands, int *model)
{
    int rc = BST_OK;
    FILE *fp = fopen(path, "r");
    if (!fp)
        return bsti_error(ctx, BST_ENOTFOUND, "glass:%s: no such pane in the catalogue (%s), no "
                          "such file, and not a key=value description; list the catalogue with "
                          "'bsdfstack glass --list'", name, dir);
    char line[1024];
    int lineno = 0, got;
    while (rc >= 0 && (got = bsti_glass_read_line(fp, line, sizeof line)) != 0) {
        lineno++;
        if (got < 0) {
            rc = bsti_glass_line_error(ctx, path, lineno, got, sizeof line);
            break;
        }
        char *s = line;
        while (isspace((unsigned char)*s))
            s++;
        size_t n = strlen(s);
        while (n && isspace((unsigned char)s[n - 1]))
            s[--n] = '\0';
        if (!*s || *s == '#')
            continue;
        char *sp = s;
        while (*sp && !isspace((unsigned char)*sp))
            sp++;
        char *rest = sp;
        while (isspace((unsigned char)*rest))
            rest++;
        *sp = '\0';
        char where[1300];
        snprintf(where, sizeof where, "%s: line %d", path, lineno);
        if (strcmp(s, "description") == 0) {
            bsti_free(ctx, g->description);
            if (!(g->description = bsti_strdup(ctx, rest)))
                rc = BST_ENOMEM;
        } else if (!*rest) {
            rc = bsti_error(ctx, BST_EINVAL, "%s: '%s' without parameters", where, s);
        } else if (strcmp(s, "type") == 0) {
            rc = bsti_glass_meta_set(g, &g->meta.type, rest);
        } else if (strcmp(s, "model") == 0) {
            bst_glass_model m = BST_GLASS_UNCOATED;
            if (parse_model(rest, &m) < 0)
                rc = bsti_error(ctx, BST_EINVAL, "%s: model '%s' (uncoated or coated)", where, rest);
            *model = (int)m;
        } else if (strcmp(s, "spectral") == 0) {
            char *names = rest;
            while (*names && !isspace((unsigned char)*names))
                names++;
            if (*names)
                *names++ = '\0';
            char data[1200];
            if ((size_t)snprintf(data, sizeof data, "%s%s%s", rest[0] == '/' ? "" : dir,
                                 rest[0] == '/' ? "" : "/", rest) >= sizeof data)
                rc = bsti_error(ctx, BST_EINVAL, "%s: the data file's path is longer than %zu "
                                "characters", where, sizeof data - 1);
            else
                rc = add_spectral(ctx, g, where, data, dir, names, bands);
        } else {
            rc = add_inline(ctx, g, where, s, rest);
        }
    }
    fclose(fp);
    if (rc >= 0 && g->nch == 0)
        rc = bsti_error(ctx, BST_EFORMAT, "%s: no channel defined", path);
    /* the catalogue is the source, whatever data file it names */
    if (rc >= 0)
        rc = bsti_glass_meta_set(g, &g->meta.source, "catalogue");
    if (rc >= 0)
        rc = bsti_glass_meta_set(g, &g->meta.path, path);
    return rc;
}

/* Take the items "KEY=VALUE" (prefix "KEY=") out of a spec's comma-separated list, in place:
 * *count of them, the first one's value in v (vsize bytes; *vlen its whole length). */
static void take_items(char *spec, const char *prefix, char *v, size_t vsize, int *count,
                       size_t *vlen)
{
    char *out = spec, *item = spec;
    size_t pl = strlen(prefix);
    *count = 0;
    while (item) {
        char *comma = strchr(item, ',');
        size_t len = comma ? (size_t)(comma - item) : strlen(item);
        if (len >= pl && strncmp(item, prefix, pl) == 0) {
            if ((*count)++ == 0) {
                *vlen = len - pl;
                snprintf(v, vsize, "%.*s", (int)(*vlen < vsize - 1 ? *vlen : vsize - 1), item + pl);
            }
        } else {
            if (out != spec)
                *out++ = ',';
            memmove(out, item, len);
            out += len;
        }
        item = comma ? comma + 1 : NULL;
    }
    *out = '\0';
}

/* Take "model=MODEL" out of a spec's list (in place): *model stays -1 when there is none. */
static int take_model(bst_ctx *ctx, const char *where, char *spec, int *model)
{
    char v[16];
    size_t vl = 0;
    int n;
    bst_glass_model m;
    take_items(spec, "model=", v, sizeof v, &n, &vl);
    if (n > 1)
        return bsti_error(ctx, BST_EINVAL, "%s: model given twice", where);
    if (n == 1 && (vl >= sizeof v - 1 || parse_model(v, &m) < 0))
        return bsti_error(ctx, BST_EINVAL, "%s: model=%s (uncoated or coated)", where, v);
    if (n == 1)
        *model = (int)m;
    return BST_OK;
}

/* Take "rows=all" or "rows=N" (N >= 2) out of a spec's list (in place) into *rows
 * (bst_glass_set_layer_rows' bound, 0 = all); it stays as it was when there is none. */
static int take_rows(bst_ctx *ctx, const char *where, char *spec, size_t *rows)
{
    char v[24], *end = NULL;
    size_t vl = 0;
    int n;
    take_items(spec, "rows=", v, sizeof v, &n, &vl);
    if (n > 1)
        return bsti_error(ctx, BST_EINVAL, "%s: rows given twice", where);
    if (n == 0)
        return BST_OK;
    unsigned long long r = strcmp(v, "all") == 0 ? 0 : strtoull(v, &end, 10);
    if (vl >= sizeof v - 1 || (end && (end == v || *end || !isdigit((unsigned char)*v) || r < 2 ||
                                       r > (unsigned long long)SIZE_MAX)))
        return bsti_error(ctx, BST_EINVAL, "%s: rows=%s (all, or a count of at least 2)", where, v);
    *rows = (size_t)r;
    return BST_OK;
}

/* The pane's model, once everything is read: model= in the spec, else the catalogue's model line,
 * else the type its file or catalogue names (as WINDOW chooses), else uncoated. */
static int settle_model(bst_ctx *ctx, bst_glass *g, int spec_model, int cat_model)
{
    bst_glass_model m = BST_GLASS_UNCOATED;
    if (spec_model >= 0)
        return bsti_glass_apply_model(g, (bst_glass_model)spec_model, "spec");
    if (cat_model >= 0)
        return bsti_glass_apply_model(g, (bst_glass_model)cat_model, "catalogue");
    if (!*g->meta.type)
        return bsti_glass_apply_model(g, m, "default");
    if (bst_glass_model_for_type(g->meta.type, &m) < 0)
        return bsti_error(ctx, BST_EFORMAT, "%s: material type '%s' is none of Monolithic, "
                          "Interlayer (uncoated), Coated, Film, Applied Film, Laminate, "
                          "Electrochromic, Thermochromic (coated): give model=uncoated or "
                          "model=coated", g->where, g->meta.type);
    return bsti_glass_apply_model(g, m, "type");
}

/* Whether a spec that is not key=value names a data file rather than a catalogue pane: a path
 * (a '/', a .tsv ending), a name with characters no catalogue name has, or a file that exists
 * where no catalogue pane of that name does. */
static int names_file(const char *spec, const char *dir)
{
    size_t sl = strlen(spec);
    if (strchr(spec, '/') || (sl > 4 && strcmp(spec + sl - 4, ".tsv") == 0))
        return 1;
    for (const char *c = spec; *c; c++)
        if (!(isalnum((unsigned char)*c) || *c == '-' || *c == '_' || *c == '.'))
            return access(spec, R_OK) == 0;
    char path[1200];
    if ((size_t)snprintf(path, sizeof path, "%s/%s.glass", dir, spec) >= sizeof path)
        return 0;
    return access(path, F_OK) != 0 && access(spec, R_OK) == 0;
}

/* bst_glass_parse, with the bands a spectral data file named without any is averaged over
 * (space-separated, NULL: Visible and Solar). */
static int parse(bst_ctx *ctx, const char *spec, const char *catalogue_dir, const char *bands,
                 bst_glass **out)
{
    if (!ctx || !spec || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass: NULL argument") : BST_EINVAL;
    *out = NULL;
    bst_glass *g = bsti_glass_new(ctx);
    if (!g)
        return BST_ENOMEM;
    int rc = BST_OK, spec_model = -1, cat_model = -1;
    char where[600], *body = NULL;
    snprintf(where, sizeof where, "glass:%s", spec);
    if (!(g->where = bsti_strdup(ctx, where)) || !(body = bsti_strdup(ctx, spec)))
        rc = BST_ENOMEM;
    if (rc >= 0)
        rc = take_model(ctx, where, body, &spec_model);
    if (rc >= 0)
        rc = take_rows(ctx, where, body, &g->layer_rows);
    if (rc >= 0 && !*body)
        rc = bsti_error(ctx, BST_EINVAL, "glass: empty specification (glass:NAME, glass:PATH "
                        "or glass:d=6mm,n=1.52,tn=0.89)");
    const char *dir = catalogue_dir ? catalogue_dir : bst_glass_catalogue_dir();
    /* key=value,... starts with a key; else a data file or a catalogue NAME */
    size_t kl = 0;
    while (rc >= 0 && isalnum((unsigned char)body[kl]))
        kl++;
    int is_inline = rc >= 0 && kl > 0 && body[kl] == '=' && isalpha((unsigned char)body[0]);
    if (rc < 0) {
        /* nothing more */
    } else if (is_inline) {
        rc = add_inline(ctx, g, where, "Visible", body);
        if (rc >= 0)
            rc = add_inline(ctx, g, where, "Solar", body);
        if (rc >= 0 && (!(g->description = bsti_strdup(ctx, body)) ||
                        bsti_glass_meta_set(g, &g->meta.source, "inline") < 0))
            rc = BST_ENOMEM;
    } else if (names_file(body, dir)) {
        char none[1] = "", desc[800];
        rc = add_spectral(ctx, g, where, body, dir, none, bands);
        /* the product's name where the file gives one */
        snprintf(desc, sizeof desc, "%s%s%s%s", g->meta.product_name,
                 *g->meta.product_name ? " (" : "", body, *g->meta.product_name ? ")" : "");
        if (rc >= 0 && !(g->description = bsti_strdup(ctx, desc)))
            rc = BST_ENOMEM;
    } else {
        for (const char *c = body; *c && rc >= 0; c++)
            if (!(isalnum((unsigned char)*c) || *c == '-' || *c == '_' || *c == '.'))
                rc = bsti_error(ctx, BST_EINVAL, "%s: a catalogue name has letters, digits, '-', "
                                "'_' and '.' only", where);
        if (rc >= 0) {
            char path[1200];
            if ((size_t)snprintf(path, sizeof path, "%s/%s.glass", dir, body) >= sizeof path)
                rc = bsti_error(ctx, BST_EINVAL, "%s: the catalogue file's path is longer than %zu "
                                "characters", where, sizeof path - 1);
            else
                rc = read_catalogue(ctx, g, path, body, dir, bands, &cat_model);
        }
        if (rc >= 0 && !g->description && !(g->description = bsti_strdup(ctx, body)))
            rc = BST_ENOMEM;
    }
    if (rc >= 0)
        rc = settle_model(ctx, g, spec_model, cat_model);
    bsti_free(ctx, body);
    if (rc < 0) {
        bst_glass_free(g);
        return rc;
    }
    *out = g;
    return BST_OK;
}

int bst_glass_parse(bst_ctx *ctx, const char *spec, const char *catalogue_dir, bst_glass **out)
{
    return parse(ctx, spec, catalogue_dir, NULL, out);
}

int bst_glass_parse_bands(bst_ctx *ctx, const char *spec, const char *catalogue_dir,
                          size_t nchannels, const char *const *channels, bst_glass **out)
{
    if (nchannels && !channels)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass: NULL argument") : BST_EINVAL;
    char bands[64] = "";
    const struct bsti_glass_band *seen[BSTI_GLASS_MAX_CH];
    size_t ns = 0;
    for (size_t c = 0; c < nchannels; c++) {
        const struct bsti_glass_band *b = bsti_glass_find_band(channels[c]);
        size_t k = 0;
        while (k < ns && seen[k] != b)
            k++;
        if (!b || k < ns || ns == BSTI_GLASS_MAX_CH || strlen(bands) + strlen(channels[c]) + 2 > sizeof bands)
            continue;
        seen[ns++] = b;
        snprintf(bands + strlen(bands), sizeof bands - strlen(bands), "%s%s", *bands ? " " : "",
                 channels[c]);
    }
    return parse(ctx, spec, catalogue_dir, *bands ? bands : NULL, out);
}
