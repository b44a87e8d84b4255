/* shade.c - an IGSDB shading record (bst_shade, read by glass_json.c) as a layer of the geometric
 * shade models (venetian_*.c, perforated.c, woven.c), and the shade specs of the program's layers.
 *
 * What the record's fields become, as LBNL's WinCalc (the engine of pywincalc and WINDOW's IGSDB
 * import) hands them to Windows-CalcEngine (read for these facts, not copied):
 *  - venetian: slat_width, slat_spacing, slat_curvature (mm), slat_tilt (degrees, passed as it
 *    is: WCE's tilt and bsdfstack's have the same sign, a positive tilt passing light that travels
 *    downward into the room in both; checked on WCE's own Klems matrices), number_segments.  The
 *    material's front values (Rf) belong to the slat face looking up at tilt 0 (WCE's front
 *    diffuse-diffuse Rf of a tilt-45 blind with Rf 0.3, Rb 0.7 is 0.153 and ours with r-up 0.3,
 *    r-down 0.7 0.1525), Rb to the face looking down;
 *  - perforated-screen: spacing_x, spacing_y; a Circular hole's dimension_x is passed as WCE's
 *    radius (WinCalc doubles it for the thermal openness), Rectangular holes are dimension_x by
 *    dimension_y, Square ones dimension_x both ways; the sheet's thickness is the material's;
 *  - woven: thread_diameter, thread_spacing (shade_thickness is thermal only).
 * The material's optics: spectral rows averaged over the bands as a spectral pane's channels
 * average theirs (bsti_glass_band_average), or the dual-band values.  WCE scatters everything a
 * shade's material reflects or transmits diffusely; the venetian model here keeps a dual-band
 * record's specular reflectance as the slats' mirror part rs (override rs=0,r-up=...,r-down=... for
 * WINDOW's all-diffuse slats). */
#include <config.h>

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "ctx.h"
#include "glass.h"
#include "mat.h"
#include "venetian.h"

#define MM 1e-3 /* the record's lengths are millimetres, the models' metres */

int bst_shade_band_values(bst_ctx *ctx, const bst_shade *s, const char *catalogue_dir,
                          bst_shade_band *visible, bst_shade_band *solar)
{
    if (!ctx || !s || !visible || !solar)
        return ctx ? bsti_error(ctx, BST_EINVAL, "shade: NULL argument") : BST_EINVAL;
    if (!s->material.n) { /* the dual-band values, as given */
        *visible = s->material.visible, *solar = s->material.solar;
        return BST_OK;
    }
    const struct bsti_glass_data d = {s->material.n, s->material.wl, s->material.tf,
                                      s->material.tb, s->material.rf, s->material.rb};
    const char *dir = catalogue_dir ? catalogue_dir : bst_glass_catalogue_dir();
    char where[1100];
    snprintf(where, sizeof where, "%s: composition[0].child_product.spectral_data", s->path);
    bst_shade_band *out[2] = {visible, solar};
    static const char *const name[2] = {"Visible", "Solar"};
    for (int b = 0; b < 2; b++) {
        double v[4];
        int rc = bsti_glass_band_average(ctx, &d, dir, name[b], where, v);
        if (rc < 0)
            return rc;
        for (int c = 0; c < 4; c++)
            out[b]->specular[c] = 0.0, out[b]->diffuse[c] = v[c];
    }
    return BST_OK;
}

/* One band's values as the models take them, x = {r-up (Rf), r-down (Rb), t, rs}: whole R and
 * T (specular + diffuse, an absent part 0) for perforated and woven (keep_rs 0); the diffuse R
 * and the specular R apart for blinds (keep_rs 1).  Tb absent: Tf's (and the other way). */
static int band_model(bst_ctx *ctx, const bst_shade *s, const bst_shade_band *b, const char *bn,
                      int keep_rs, double x[4])
{
    static const char *const comp[4] = {"Tf", "Tb", "Rf", "Rb"};
    double tot[4], sp[4];
    for (int c = 0; c < 4; c++) {
        int none = isnan(b->specular[c]) && isnan(b->diffuse[c]);
        sp[c] = isnan(b->specular[c]) ? 0.0 : b->specular[c];
        tot[c] = none ? NAN : sp[c] + (isnan(b->diffuse[c]) ? 0.0 : b->diffuse[c]);
    }
    if (isnan(tot[1]))
        tot[1] = tot[0];
    if (isnan(tot[0]))
        tot[0] = tot[1];
    for (int c = 0; c < 4; c++)
        if (isnan(tot[c]))
            return bsti_error(ctx, BST_EFORMAT, "%s: composition[0].child_product.spectral_data."
                              "dual_band_values: %s_%s_specular and _diffuse both missing", s->path,
                              c < 2 ? "Tf and Tb" : comp[c], bn);
    if (fabs(tot[0] - tot[1]) > BST_SHADE_SIDE_TOL)
        return bsti_error(ctx, BST_ENOTIMPL, "%s: the material's Tf_%s %g and Tb_%s %g differ: the "
                          "shade models transmit the same both ways", s->path, bn, tot[0], bn, tot[1]);
    x[2] = tot[0] == tot[1] ? tot[0] : (tot[0] + tot[1]) / 2;
    x[0] = tot[2], x[1] = tot[3], x[3] = 0.0;
    if (keep_rs) {
        if (fabs(sp[2] - sp[3]) > BST_SHADE_SIDE_TOL)
            return bsti_error(ctx, BST_ENOTIMPL, "%s: the material's Rf_%s_specular %g and "
                              "Rb_%s_specular %g differ: a slat has one specular reflectance (rs) "
                              "for both faces", s->path, bn, sp[2], bn, sp[3]);
        x[3] = sp[2] == sp[3] ? sp[2] : (sp[2] + sp[3]) / 2;
        for (int c = 2; c < 4; c++) /* the diffuse parts as given (0 when absent) */
            x[c - 2] = isnan(b->diffuse[c]) ? 0.0 : b->diffuse[c];
    }
    return BST_OK;
}

/* The record's blind (before overrides). */
static void venetian_of(const bst_shade *s, const double vis[4], const double sol[4], bst_venetian *v)
{
    bst_venetian_init(v);
    v->width = s->geometry.venetian.slat_width * MM;
    v->spacing = s->geometry.venetian.slat_spacing * MM;
    v->curvature = s->geometry.venetian.slat_curvature * MM; /* the venetian model decides */
    v->tilt = s->geometry.venetian.slat_tilt;
    v->segments = s->geometry.venetian.number_segments;
    v->r_up = vis[0], v->r_down = vis[1], v->t = vis[2], v->rs = vis[3];
    for (int k = 0; k < 4; k++)
        if (sol[k] != vis[k])
            v->solar[k] = sol[k];
}

/* The record's screen (thickness NaN when the material has none). */
static void perforated_of(const bst_shade *s, const double vis[4], const double sol[4],
                          bst_perforated *p)
{
    bst_perforated_init(p);
    p->x = s->geometry.perforated.spacing_x * MM;
    p->y = s->geometry.perforated.spacing_y * MM;
    p->thickness = s->material.thickness_mm * MM;
    if (s->geometry.perforated.type == BST_PERFORATION_CIRCULAR)
        p->radius = s->geometry.perforated.dimension_x * MM;
    else
        p->hole_x = s->geometry.perforated.dimension_x * MM,
        p->hole_y = s->geometry.perforated.dimension_y * MM;
    p->rf = vis[0], p->rb = vis[1], p->t = vis[2];
    for (int k = 0; k < 3; k++)
        if (sol[k] != vis[k])
            p->solar[k] = sol[k];
}

static void woven_of(const bst_shade *s, const double vis[4], const double sol[4], bst_woven *w)
{
    bst_woven_init(w);
    w->diameter = s->geometry.woven.thread_diameter * MM;
    w->spacing = s->geometry.woven.thread_spacing * MM;
    w->rf = vis[0], w->rb = vis[1], w->t = vis[2];
    for (int k = 0; k < 3; k++)
        if (sol[k] != vis[k])
            w->solar[k] = sol[k];
}

/* "FILE: KIND from the record: MESSAGE" in place of the model's own line, so that the file shows. */
static int about_record(bst_ctx *ctx, const bst_shade *s, int rc)
{
    char msg[900];
    snprintf(msg, sizeof msg, "%s", bst_ctx_message(ctx));
    return bsti_error(ctx, rc, "%s: %s", s->path, msg);
}

int bst_shade_model_of(bst_ctx *ctx, const bst_shade *s, const char *catalogue_dir,
                       const char *overrides, bst_shade_model *m)
{
    if (!ctx || !s || !m)
        return ctx ? bsti_error(ctx, BST_EINVAL, "shade: NULL argument") : BST_EINVAL;
    memset(m, 0, sizeof *m);
    m->kind = s->kind;
    bst_shade_band bv, bs;
    double vis[4], sol[4];
    int rc, blind = s->kind == BST_SHADE_VENETIAN;
    if ((rc = bst_shade_band_values(ctx, s, catalogue_dir, &bv, &bs)) < 0 ||
        (rc = band_model(ctx, s, &bv, "vis", blind, vis)) < 0 ||
        (rc = band_model(ctx, s, &bs, "sol", blind, sol)) < 0)
        return rc;
    const char *o = overrides ? overrides : "";
    switch (s->kind) {
    case BST_SHADE_VENETIAN:
        venetian_of(s, vis, sol, &m->venetian);
        rc = bst_venetian_update(ctx, o, &m->venetian);
        break;
    case BST_SHADE_PERFORATED:
        perforated_of(s, vis, sol, &m->perforated);
        if (isnan(m->perforated.thickness)) /* only an override can give it */
            m->perforated.thickness = -INFINITY;
        rc = bst_perforated_update(ctx, o, &m->perforated);
        if (rc < 0 && m->perforated.thickness == -INFINITY && strstr(bst_ctx_message(ctx), "thickness"))
            return bsti_error(ctx, BST_EFORMAT, "%s: composition[0].child_product.measured_data."
                              "thickness: missing (a perforated screen's sheet thickness; or give "
                              "thickness= after the file name)", s->path);
        break;
    default:
        woven_of(s, vis, sol, &m->woven);
        rc = bst_woven_update(ctx, o, &m->woven);
        break;
    }
    return rc < 0 ? about_record(ctx, s, rc) : BST_OK;
}

int bst_shade_parse(bst_ctx *ctx, const char *spec, const char *catalogue_dir, bst_shade_model *m)
{
    if (!ctx || !spec || !m)
        return ctx ? bsti_error(ctx, BST_EINVAL, "shade: NULL argument") : BST_EINVAL;
    memset(m, 0, sizeof *m);
    static const char *const prefix[3] = {"venetian:", "woven:", "perforated:"};
    for (int k = 0; k < 3; k++) { /* in bst_shade_kind's order */
        size_t pl = strlen(prefix[k]);
        if (strncmp(spec, prefix[k], pl) != 0)
            continue;
        m->kind = (bst_shade_kind)k;
        return k == BST_SHADE_VENETIAN ? bst_venetian_parse(ctx, spec + pl, &m->venetian)
               : k == BST_SHADE_WOVEN  ? bst_woven_parse(ctx, spec + pl, &m->woven)
                                       : bst_perforated_parse(ctx, spec + pl, &m->perforated);
    }
    if (strncmp(spec, "shade:", 6) != 0)
        return bsti_error(ctx, BST_EINVAL, "'%s' is not a shade (venetian:KEYS, perforated:KEYS, "
                          "woven:KEYS or shade:FILE.json[,KEYS])", spec);
    /* FILE ends at its first comma, unless the whole text names a file */
    const char *body = spec + 6, *comma = strchr(body, ',');
    if (!*body)
        return bsti_error(ctx, BST_EINVAL, "shade: no file named (shade:FILE.json[,KEY=VALUE,...])");
    if (!comma || access(body, F_OK) == 0)
        comma = body + strlen(body);
    char *file = bsti_alloc_array(ctx, (size_t)(comma - body) + 1, 1);
    if (!file)
        return BST_ENOMEM;
    memcpy(file, body, (size_t)(comma - body));
    file[comma - body] = '\0';
    bst_shade *s = NULL;
    int rc = bst_shade_read_igsdb(ctx, file, &s);
    if (rc >= 0)
        rc = bst_shade_model_of(ctx, s, catalogue_dir, *comma ? comma + 1 : "", m);
    bst_shade_free(s);
    bsti_free(ctx, file);
    return rc;
}

int bst_shade_model_layer(bst_ctx *ctx, const bst_shade_model *m, const bst_basis *basis,
                          size_t nchannels, const char *const *channels, bst_layer **out)
{
    if (!ctx || !m)
        return ctx ? bsti_error(ctx, BST_EINVAL, "shade layer: NULL argument") : BST_EINVAL;
    switch (m->kind) {
    case BST_SHADE_VENETIAN: return bst_venetian_layer(ctx, &m->venetian, basis, nchannels, channels, out);
    case BST_SHADE_PERFORATED:
        return bst_perforated_layer(ctx, &m->perforated, basis, nchannels, channels, out);
    case BST_SHADE_WOVEN: return bst_woven_layer(ctx, &m->woven, basis, nchannels, channels, out);
    default: return bsti_error(ctx, BST_EINVAL, "shade layer: kind %d unknown", (int)m->kind);
    }
}

/* What one channel of a venetian blind of slat values v holds (bst_venetian_layer, make_band,
 * make_map, component; venetian_wce.c): 4 dense, 4 factored over the strips' map, or none
 * (sparse; also sparse + low rank, a mirror part and diffuse slats, whose thin factors, 2 N x
 * 2 segments values a component, are small beside the model's base). */
static void venetian_channel(const bst_venetian *v, size_t N, bst_plan_held *h)
{
    int diffuse = v->r_up > 0 || v->r_down > 0 || v->t > 0;
    size_t width = 8 * (size_t)v->segments; /* [U_ext | U_int | Q_ext^T | Q_int^T] */
    if (v->rule == BST_VENETIAN_CENTRE)
        h->dense += BST_NCOMP;
    else if (diffuse && v->rs == 0 && (double)width < BSTI_LR_DENSE_SHARE * (double)N)
        h->factored += BST_NCOMP, h->width = width > h->width ? width : h->width;
    else if (diffuse && bsti_plus_fits(N, N, 2 * (size_t)v->segments)) /* 2 strips a segment */
        h->plus += BST_NCOMP; /* PLUS_LR */
    else if (diffuse)
        h->dense += BST_NCOMP;
    h->precision = v->precision;
}

/* Whether a sheet's channel scatters: any diffuse value above 0 (sol's where not NaN). */
static int sheet_scatters(const double v[3], const double sol[3], int solar)
{
    for (int k = 0; k < 3; k++)
        if ((solar && !isnan(sol[k]) ? sol[k] : v[k]) > 0)
            return 1;
    return 0;
}

int bst_shade_model_plan(bst_ctx *ctx, const bst_shade_model *m, const bst_basis *basis,
                         size_t nchannels, const char *const *channels, bst_plan_held *out)
{
    if (!ctx || !m || !basis || !out || (nchannels && !channels))
        return ctx ? bsti_error(ctx, BST_EINVAL, "shade plan: NULL argument") : BST_EINVAL;
    static const char *const dual[] = {"Visible", "Solar"};
    if (!nchannels)
        nchannels = 2, channels = dual;
    memset(out, 0, sizeof *out);
    out->nchannels = nchannels;
    size_t N = bst_basis_size(basis);
    const bst_venetian *v = &m->venetian;
    bst_venetian vs; /* the Solar channel's slat values, as bst_venetian_layer takes them */
    bsti_vn_solar(v, &vs);
    for (size_t c = 0; c < nchannels; c++) {
        int solar = strcasecmp(channels[c], "Solar") == 0;
        double x[3];
        const double *sol = NULL;
        switch (m->kind) {
        case BST_SHADE_VENETIAN: venetian_channel(solar ? &vs : v, N, out); continue;
        case BST_SHADE_PERFORATED:
            x[0] = m->perforated.rf, x[1] = m->perforated.rb, x[2] = m->perforated.t;
            sol = m->perforated.solar;
            break;
        case BST_SHADE_WOVEN:
            x[0] = m->woven.rf, x[1] = m->woven.rb, x[2] = m->woven.t, sol = m->woven.solar;
            break;
        default: return bsti_error(ctx, BST_EINVAL, "shade plan: kind %d unknown", (int)m->kind);
        }
        if (sheet_scatters(x, sol, solar)) /* the diagonal and rank <= 5 over a wide map */
            out->factored += BST_NCOMP, out->width = 5;
    }
    return BST_OK;
}

int bst_shade_spec_layer(bst_ctx *ctx, const char *spec, const char *catalogue_dir,
                         const bst_basis *basis, size_t nchannels, const char *const *channels,
                         bst_layer **out)
{
    if (out)
        *out = NULL;
    bst_shade_model m;
    int rc = bst_shade_parse(ctx, spec, catalogue_dir, &m);
    return rc < 0 ? rc : bst_shade_model_layer(ctx, &m, basis, nchannels, channels, out);
}

/* ------------------------------------------------------------------ the model as a spec */

struct text {
    char *buf;
    size_t size, len;
};

static void put(struct text *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(t->len < t->size ? t->buf + t->len : NULL,
                      t->len < t->size ? t->size - t->len : 0, fmt, ap);
    va_end(ap);
    if (n > 0)
        t->len += (size_t)n;
}

/* ",KEY=VALUE" of a per-channel value, VALUE/SOLAR where the Solar channel's differs in the
 * digits written (band averages of the same rows may differ in the last bit). */
static void put_band(struct text *t, const char *key, double x, double sol)
{
    char a[32], b[32];
    snprintf(a, sizeof a, "%.10g", x);
    snprintf(b, sizeof b, "%.10g", sol);
    if (isnan(sol) || strcmp(a, b) == 0)
        put(t, ",%s=%s", key, a);
    else
        put(t, ",%s=%s/%s", key, a, b);
}

size_t bst_shade_model_spec(const bst_shade_model *m, char *buf, size_t size)
{
    struct text t = {buf, buf ? size : 0, 0};
    if (t.size)
        buf[0] = '\0';
    if (!m)
        return 0;
    if (m->kind == BST_SHADE_VENETIAN) {
        const bst_venetian *v = &m->venetian;
        put(&t, "venetian:width=%.10gmm,spacing=%.10gmm,tilt=%.10g,curvature=%.10gmm,segments=%d",
            v->width / MM, v->spacing / MM, v->tilt, v->curvature / MM, v->segments);
        put_band(&t, "r-up", v->r_up, v->solar[0]);
        put_band(&t, "r-down", v->r_down, v->solar[1]);
        put_band(&t, "t", v->t, v->solar[2]);
        put_band(&t, "rs", v->rs, v->solar[3]);
        if (v->roughness > 0)
            put(&t, ",roughness=%.10g", v->roughness);
        if (v->vertical)
            put(&t, ",vertical");
        if (v->samples)
            put(&t, ",samples=%d", v->samples);
        if (v->rule == BST_VENETIAN_CENTRE)
            put(&t, ",rule=centre%s",
                v->distribution == BST_VENETIAN_UNIFORM ? ",distribution=uniform" : "");
        return t.len;
    }
    double r[3];
    const double *sol;
    int samples, rule;
    if (m->kind == BST_SHADE_PERFORATED) {
        const bst_perforated *p = &m->perforated;
        put(&t, "perforated:x=%.10gmm,y=%.10gmm,thickness=%.10gmm", p->x / MM, p->y / MM,
            p->thickness / MM);
        if (!isnan(p->radius))
            put(&t, ",radius=%.10gmm", p->radius / MM);
        else
            put(&t, ",hole-x=%.10gmm,hole-y=%.10gmm", p->hole_x / MM, p->hole_y / MM);
        r[0] = p->rf, r[1] = p->rb, r[2] = p->t, sol = p->solar;
        samples = p->samples, rule = p->rule;
    } else {
        const bst_woven *w = &m->woven;
        put(&t, "woven:diameter=%.10gmm,spacing=%.10gmm", w->diameter / MM, w->spacing / MM);
        r[0] = w->rf, r[1] = w->rb, r[2] = w->t, sol = w->solar;
        samples = w->samples, rule = w->rule;
    }
    put_band(&t, "rf", r[0], sol[0]);
    put_band(&t, "rb", r[1], sol[1]);
    put_band(&t, "t", r[2], sol[2]);
    if (samples)
        put(&t, ",samples=%d", samples);
    if (rule == BST_VENETIAN_CENTRE)
        put(&t, ",rule=centre");
    return t.len;
}

int bst_shade_spec_model(bst_ctx *ctx, const char *spec, const char *catalogue_dir, char *buf,
                         size_t size)
{
    bst_shade_model m;
    int rc = bst_shade_parse(ctx, spec, catalogue_dir, &m);
    if (rc < 0)
        return rc;
    if (bst_shade_model_spec(&m, buf, size) >= size)
        return bsti_error(ctx, BST_EINVAL, "shade: the model's spec is longer than %zu characters", size);
    return BST_OK;
}
