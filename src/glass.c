/* glass.c - analytic clear glass: angular T and R of an uncoated pane from its normal-incidence
 * values, following Windows-CalcEngine's model for uncoated glass (../shared/reference/wce/README.md,
 * "How WCE gets the angular properties of uncoated (clear) glass"), and its diagonal layer.
 *
 * The model per side and channel, from T0 and R0 at normal incidence:
 *   rho0 = smaller root of (2 - R0) rho^2 - (T0^2 - R0^2 + 2 R0 + 1) rho + R0 = 0  (one interface)
 *   n    = (1 + sqrt(rho0)) / (1 - sqrt(rho0))
 *   tau0 = (R0 - rho0) / (T0 rho0)                      (single-pass internal transmittance)
 *   at theta: sin(theta) = n sin(theta'), tau = tau0^(1 / cos(theta'))
 *   r_p = ((n cos(theta) - cos(theta')) / (n cos(theta) + cos(theta')))^2, r_s likewise
 *   T_x = tau (1 - r_x)^2 / (1 - tau^2 r_x^2),  R_x = r_x (1 + tau T_x),  T, R = means over s, p.
 * Thickness and wavelength cancel: only T0, R0 and theta matter.
 *
 * A layer's components are diagonal in every basis (index convention of basis.h: the transmitted
 * and the mirror-reflected beam keep the incident patch). */
#include <config.h>

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "ctx.h"

#define MAX_CH 8
/* Sample points per patch and dimension when averaging over a patch (uniform in projected solid
 * angle): 8 x 8 = 64 incidence directions. */
#define GLASS_SAMPLES 8
/* Refractive index assumed by specs that give none. */
#define GLASS_DEFAULT_N 1.52

struct side { double t0, r0, rho0, n, tau0; };

/* Angles tabulated for building layers of spectral panes (0.05 degree steps, linear between). */
#define GLASS_TABLE 1800

/* A channel is a weighted sum over wavelength nodes (one node of weight 1 for band values):
 * property(theta) = sum_k w_k model(T0_k, R0_k, theta), the trapezoid rule of WCE's spectral
 * averaging folded into the weights. */
struct channel {
    size_t nk;
    double *w;
    struct side *front, *back;
    float *table;  /* spectral channels: T, Rf, Rb at GLASS_TABLE + 1 angles */
};

struct bst_glass {
    bst_ctx *ctx;
    size_t nch;
    char *name[MAX_CH];
    struct channel ch[MAX_CH];
    char *description;
};

/* Derived constants of one side (steps 1-3). */
static int side_init(struct side *s, double t0, double r0)
{
    s->t0 = t0, s->r0 = r0;
    double a = 2.0 - r0, b = -(t0 * t0 - r0 * r0 + 2.0 * r0 + 1.0), c = r0;
    double disc = b * b - 4.0 * a * c;
    if (disc < 0)
        return -1;
    s->rho0 = (-b - sqrt(disc)) / (2.0 * a);
    if (s->rho0 < 0)
        s->rho0 = 0;
    double sr = sqrt(s->rho0);
    s->n = (1.0 + sr) / (1.0 - sr);
    s->tau0 = (t0 == 0.0 || s->rho0 == 0.0 || r0 == s->rho0) ? 0.0 : (r0 - s->rho0) / (t0 * s->rho0);
    if (t0 == 0.0) { /* opaque: bare interface with rho0 = R0 */
        s->rho0 = r0;
        sr = sqrt(r0);
        s->n = (1.0 + sr) / (1.0 - sr);
    }
    return 0;
}

/* T and R of one side at theta (radians). */
static void side_optics(const struct side *s, double theta, double *t, double *r)
{
    if (theta <= 0.0) {
        *t = s->t0, *r = s->r0;
        return;
    }
    double ci = cos(theta);
    if (ci <= 0.0 || theta >= M_PI / 2) {
        *t = 0.0, *r = 1.0;
        return;
    }
    if (s->t0 > 0.0 && (s->rho0 == 0.0 || s->t0 == 1.0)) { /* no angular dependence */
        *t = s->t0, *r = s->r0;
        return;
    }
    double si = sin(theta), st = si / s->n, ct = sqrt(1.0 - st * st), n = s->n;
    double tau = s->tau0 > 0.0 ? pow(s->tau0, 1.0 / ct) : 0.0;
    double rp = (n * ci - ct) / (n * ci + ct), rs = (ci - n * ct) / (ci + n * ct);
    rp *= rp, rs *= rs;
    double tt = 0.0, rr = 0.0;
    const double rx[2] = {rs, rp};
    for (int k = 0; k < 2; k++) {
        double tx = s->t0 == 0.0 ? 0.0 : tau * (1.0 - rx[k]) * (1.0 - rx[k]) / (1.0 - tau * tau * rx[k] * rx[k]);
        double rrx = s->t0 == 0.0 ? rx[k] : rx[k] * (1.0 + tau * tx);
        tt += 0.5 * tx, rr += 0.5 * rrx;
    }
    if (tt + rr > 1.0) { /* rounding: the larger gives way */
        if (tt > rr)
            tt = 1.0 - rr;
        else
            rr = 1.0 - tt;
    }
    *t = tt, *r = rr;
}

void bst_glass_free(bst_glass *g)
{
    if (!g)
        return;
    for (size_t i = 0; i < MAX_CH; i++) {
        bsti_free(g->ctx, g->name[i]);
        bsti_free(g->ctx, g->ch[i].w);
        bsti_free(g->ctx, g->ch[i].front);
        bsti_free(g->ctx, g->ch[i].back);
        bsti_free(g->ctx, g->ch[i].table);
    }
    bsti_free(g->ctx, g->description);
    bsti_free(g->ctx, g);
}

size_t bst_glass_nchannels(const bst_glass *g) { return g->nch; }
const char *bst_glass_channel(const bst_glass *g, size_t ch) { return ch < g->nch ? g->name[ch] : NULL; }
const char *bst_glass_description(const bst_glass *g) { return g->description ? g->description : ""; }

int bst_glass_optics(const bst_glass *g, size_t ch, double theta, double *t, double *tb_out,
                     double *rf, double *rb)
{
    if (!g || ch >= g->nch || !(theta >= 0.0 && theta <= M_PI / 2 + 1e-12))
        return BST_EINVAL;
    const struct channel *c = &g->ch[ch];
    double st = 0, stb = 0, sf = 0, sb = 0;
    for (size_t k = 0; k < c->nk; k++) {
        double tk, fk, tb, bk;
        side_optics(&c->front[k], theta, &tk, &fk);
        side_optics(&c->back[k], theta, &tb, &bk);
        st += c->w[k] * tk, stb += c->w[k] * tb, sf += c->w[k] * fk, sb += c->w[k] * bk;
    }
    *t = st, *rf = sf, *rb = sb;
    if (tb_out)
        *tb_out = stb;
    return BST_OK;
}

/* T, Rf, Rb for building layers: exact for band channels, from the angle table for spectral ones. */
static void fast_optics(const bst_glass *g, size_t ch, double theta, double *t, double *tb,
                        double *rf, double *rb)
{
    const struct channel *c = &g->ch[ch];
    if (!c->table) {
        bst_glass_optics(g, ch, theta, t, tb, rf, rb);
        return;
    }
    double x = fmin(fmax(theta / (M_PI / 2), 0.0), 1.0) * GLASS_TABLE;
    size_t a = (size_t)x;
    if (a >= GLASS_TABLE)
        a = GLASS_TABLE - 1;
    double f = x - (double)a;
    const float *p = c->table + 4 * a;
    *t = (1 - f) * p[0] + f * p[4];
    *tb = (1 - f) * p[1] + f * p[5];
    *rf = (1 - f) * p[2] + f * p[6];
    *rb = (1 - f) * p[3] + f * p[7];
}

/* ------------------------------------------------------------------ specs */

/* "6mm", "0.006m", "0.6cm", "0.25in" or a bare number of millimetres -> metres. */
static int parse_length(const char *v, double *m)
{
    char *end;
    errno = 0;
    double x = strtod(v, &end);
    if (end == v || !isfinite(x) || errno)
        return -1;
    double f = 1e-3;
    if (strcmp(end, "mm") == 0 || *end == '\0')
        f = 1e-3;
    else if (strcmp(end, "m") == 0)
        f = 1.0;
    else if (strcmp(end, "cm") == 0)
        f = 1e-2;
    else if (strcmp(end, "in") == 0)
        f = 0.0254;
    else
        return -1;
    *m = x * f;
    return 0;
}

static int parse_number(const char *v, double *x)
{
    char *end;
    errno = 0;
    *x = strtod(v, &end);
    return (end == v || *end || !isfinite(*x) || errno) ? -1 : 0;
}

/* Parse "key=value,key=value" into the front and back sides of one channel. */
static int parse_params(bst_ctx *ctx, const char *where, const char *text, struct side *f, struct side *b)
{
    double d = NAN, n = NAN, tn = NAN, t0 = NAN, r0f = NAN, r0b = NAN;
    char buf[512];
    if (strlen(text) >= sizeof buf)
        return bsti_error(ctx, BST_EINVAL, "%s: glass description too long", where);
    strcpy(buf, text);
    char *save = NULL;
    for (char *kv = strtok_r(buf, ",", &save); kv; kv = strtok_r(NULL, ",", &save)) {
        while (isspace((unsigned char)*kv))
            kv++;
        char *eq = strchr(kv, '=');
        if (!eq)
            return bsti_error(ctx, BST_EINVAL, "%s: '%s' is not key=value (keys: d, n, tn, t0, r0, "
                              "r0f, r0b)", where, kv);
        *eq = '\0';
        const char *k = kv, *v = eq + 1;
        int bad;
        if (strcmp(k, "d") == 0)
            bad = parse_length(v, &d) || !(d >= 0 && d < 1.0);
        else if (strcmp(k, "n") == 0)
            bad = parse_number(v, &n) || !(n > 1.0 && n < 5.0);
        else if (strcmp(k, "tn") == 0 || strcmp(k, "t0") == 0)
            bad = parse_number(v, strcmp(k, "tn") == 0 ? &tn : &t0) ||
                  !((strcmp(k, "tn") == 0 ? tn : t0) >= 0.0 && (strcmp(k, "tn") == 0 ? tn : t0) <= 1.0);
        else if (strcmp(k, "r0") == 0 || strcmp(k, "r0f") == 0)
            bad = parse_number(v, &r0f) || !(r0f >= 0.0 && r0f < 1.0);
        else if (strcmp(k, "r0b") == 0)
            bad = parse_number(v, &r0b) || !(r0b >= 0.0 && r0b < 1.0);
        else
            return bsti_error(ctx, BST_EINVAL, "%s: unknown glass parameter '%s' (keys: d, n, tn, "
                              "t0, r0, r0f, r0b)", where, k);
        if (bad)
            return bsti_error(ctx, BST_EINVAL, "%s: %s=%s is not a valid value (d: a length below "
                              "1 m such as 6mm; n: 1..5; tn, t0: 0..1; r0: 0..1)", where, k, v);
    }
    if (!isnan(tn)) { /* a slab of index n with normal transmittance tn */
        if (!isnan(t0) || !isnan(r0f))
            return bsti_error(ctx, BST_EINVAL, "%s: give either n and tn, or t0 and r0", where);
        if (isnan(n))
            n = GLASS_DEFAULT_N;
        double rho = (n - 1) / (n + 1);
        rho *= rho;
        double tmax = (1 - rho) / (1 + rho);
        if (tn > tmax)
            return bsti_error(ctx, BST_EINVAL, "%s: tn=%g exceeds %.4f, the transmittance of a "
                              "non-absorbing pane of index %g", where, tn, tmax, n);
        double tau = tn == 0.0 ? 0.0 : (-(1 - rho) * (1 - rho) +
                                        sqrt(pow(1 - rho, 4) + 4 * tn * tn * rho * rho)) / (2 * tn * rho * rho);
        t0 = tn;
        r0f = rho * (1 + tau * tn);
    }
    if (isnan(t0) || isnan(r0f))
        return bsti_error(ctx, BST_EINVAL, "%s: a pane needs tn (with n) or t0 and r0", where);
    if (isnan(r0b))
        r0b = r0f;
    if (t0 + r0f > 1.0 || t0 + r0b > 1.0)
        return bsti_error(ctx, BST_EINVAL, "%s: T0 + R0 = %g exceeds 1", where, t0 + fmax(r0f, r0b));
    if (side_init(f, t0, r0f) || side_init(b, t0, r0b))
        return bsti_error(ctx, BST_EINVAL, "%s: no uncoated pane has T0 = %g and R0 = %g", where, t0, r0f);
    (void)d;
    return BST_OK;
}

static int new_channel(bst_ctx *ctx, bst_glass *g, const char *where, const char *name, size_t nk)
{
    if (g->nch >= MAX_CH)
        return bsti_error(ctx, BST_EINVAL, "%s: more than %d channels", where, MAX_CH);
    for (size_t i = 0; i < g->nch; i++)
        if (strcasecmp(g->name[i], name) == 0)
            return bsti_error(ctx, BST_EINVAL, "%s: channel %s given twice", where, name);
    struct channel *c = &g->ch[g->nch];
    c->nk = nk;
    c->w = bsti_calloc(ctx, nk, sizeof *c->w);
    c->front = bsti_calloc(ctx, nk, sizeof *c->front);
    c->back = bsti_calloc(ctx, nk, sizeof *c->back);
    if (!c->w || !c->front || !c->back)
        return BST_ENOMEM;
    return BST_OK;
}

static int add_channel(bst_ctx *ctx, bst_glass *g, const char *where, const char *name, const char *params)
{
    int rc = new_channel(ctx, g, where, name, 1);
    if (rc < 0)
        return rc;
    g->ch[g->nch].w[0] = 1.0;
    rc = parse_params(ctx, where, params, &g->ch[g->nch].front[0], &g->ch[g->nch].back[0]);
    if (rc < 0)
        return rc;
    if (!(g->name[g->nch] = bsti_strdup(ctx, name)))
        return BST_ENOMEM;
    g->nch++;
    return BST_OK;
}


/* ------------------------------------------------------------------ spectral panes */

/* Spectral averaging as WCE does it (../shared/reference/wce/README.md, "How WCE averages over
 * the spectrum"): trapezoid rule on a grid, intervals inside [lo, hi] (1e-6 slack); Solar on the
 * glass data's own wavelengths with the ASTM E891 Table 1 irradiance, Visible on the 5 nm photopic
 * grid with CIE D65 x V(lambda), the glass data interpolated onto it. */
#define SOLAR_LO 0.3
#define SOLAR_HI 2.5
#define VISIBLE_LO 0.38
#define VISIBLE_HI 0.78

/* Numeric rows of a TSV file with at least ncol columns; '#' lines and a header are skipped. */
static int read_table(bst_ctx *ctx, const char *path, int ncol, double **cols, size_t *n)
{
    FILE *fp = fopen(path, "r");
    if (!fp)
        return bsti_error(ctx, BST_EIO, "%s: cannot open: %s", path, strerror(errno));
    size_t cap = 0;
    *n = 0;
    for (int c = 0; c < ncol; c++)
        cols[c] = NULL;
    char line[1024];
    int lineno = 0, rc = BST_OK;
    while (rc >= 0 && fgets(line, sizeof line, fp)) {
        lineno++;
        char *p = line, *end;
        while (isspace((unsigned char)*p))
            p++;
        if (!*p || *p == '#' || isalpha((unsigned char)*p))
            continue;
        if (*n == cap) {
            size_t nc = cap ? 2 * cap : 256;
            for (int c = 0; c < ncol && rc >= 0; c++) {
                double *q = bsti_alloc_array(ctx, nc, sizeof *q);
                if (!q) {
                    rc = BST_ENOMEM;
                    break;
                }
                if (cols[c])
                    memcpy(q, cols[c], cap * sizeof *q);
                bsti_free(ctx, cols[c]);
                cols[c] = q;
            }
            cap = nc;
            if (rc < 0)
                break;
        }
        for (int c = 0; c < ncol; c++) {
            double v = strtod(p, &end);
            if (end == p || !isfinite(v) || v < 0 || (c > 0 && ncol == 5 && v > 1.0)) {
                rc = bsti_error(ctx, BST_EFORMAT, "%s: line %d: column %d is not a valid value", path, lineno, c + 1);
                break;
            }
            cols[c][*n] = v;
            p = end;
        }
        if (rc >= 0 && *n > 0 && cols[0][*n] <= cols[0][*n - 1])
            rc = bsti_error(ctx, BST_EFORMAT, "%s: line %d: wavelengths must increase", path, lineno);
        if (rc >= 0)
            ++*n;
    }
    fclose(fp);
    if (rc >= 0 && *n < 2)
        rc = bsti_error(ctx, BST_EFORMAT, "%s: fewer than two data rows", path);
    if (rc < 0)
        for (int c = 0; c < ncol; c++) {
            bsti_free(ctx, cols[c]);
            cols[c] = NULL;
        }
    return rc;
}

/* y(xq) by linear interpolation, constant outside the range. */
static double interp(const double *x, const double *y, size_t n, double xq)
{
    if (xq <= x[0])
        return y[0];
    if (xq >= x[n - 1])
        return y[n - 1];
    size_t lo = 0, hi = n - 1;
    while (hi - lo > 1) {
        size_t mid = (lo + hi) / 2;
        if (x[mid] <= xq)
            lo = mid;
        else
            hi = mid;
    }
    double f = (xq - x[lo]) / (x[hi] - x[lo]);
    return (1 - f) * y[lo] + f * y[hi];
}

/* One channel on grid wl[0..m-1] with weights S D at the nodes; data columns d[0..4]. */
static int spectral_channel(bst_ctx *ctx, bst_glass *g, const char *where, const char *name,
                            const double *wl, const double *sd, size_t m, double lo, double hi,
                            double *const *d, size_t nd)
{
    int rc = new_channel(ctx, g, where, name, m);
    if (rc < 0)
        return rc;
    struct channel *c = &g->ch[g->nch];
    double sum = 0;
    for (size_t k = 0; k + 1 < m; k++)
        if (wl[k] >= lo - 1e-6 && wl[k + 1] <= hi + 1e-6) {
            double h = 0.5 * (wl[k + 1] - wl[k]);
            c->w[k] += h * sd[k], c->w[k + 1] += h * sd[k + 1];
            sum += h * (sd[k] + sd[k + 1]);
        }
    if (!(sum > 0))
        return bsti_error(ctx, BST_EFORMAT, "%s: no %s weight in %g..%g um", where, name, lo, hi);
    for (size_t k = 0; k < m; k++) {
        c->w[k] /= sum;
        double tf = interp(d[0], d[1], nd, wl[k]), tb = interp(d[0], d[2], nd, wl[k]);
        double rf = interp(d[0], d[3], nd, wl[k]), rb = interp(d[0], d[4], nd, wl[k]);
        if (side_init(&c->front[k], tf, rf) || side_init(&c->back[k], tb, rb))
            return bsti_error(ctx, BST_EFORMAT, "%s: no uncoated pane has T0 = %g, R0 = %g at %g um",
                              where, tf, rf, wl[k]);
    }
    if (!(g->name[g->nch] = bsti_strdup(ctx, name)))
        return BST_ENOMEM;
    g->nch++;
    if (!(c->table = bsti_alloc_array(ctx, 4 * (GLASS_TABLE + 1), sizeof *c->table)))
        return BST_ENOMEM;
    for (size_t a = 0; a <= GLASS_TABLE; a++) {
        double t, tb, f, b;
        bst_glass_optics(g, g->nch - 1, (double)a / GLASS_TABLE * (M_PI / 2), &t, &tb, &f, &b);
        c->table[4 * a] = (float)t, c->table[4 * a + 1] = (float)tb;
        c->table[4 * a + 2] = (float)f, c->table[4 * a + 3] = (float)b;
    }
    return BST_OK;
}

/* Channels Solar and Visible of a spectral data file (wavelength in um, Tf, Tb, Rf, Rb at normal
 * incidence); the source and detector spectra come from the catalogue directory. */
static int add_spectral(bst_ctx *ctx, bst_glass *g, const char *path, const char *dir)
{
    double *d[5] = {0}, *sol[2] = {0}, *d65[2] = {0}, *v[2] = {0}, *set[1] = {0};
    double *sd = NULL;
    size_t nd, ns, n65, nv, nset;
    char p[1200];
    int rc = read_table(ctx, path, 5, d, &nd);
    if (rc >= 0) {
        snprintf(p, sizeof p, "%s/solar_ASTM_E891_87_Table1.tsv", dir);
        rc = read_table(ctx, p, 2, sol, &ns);
    }
    if (rc >= 0) {
        snprintf(p, sizeof p, "%s/photopic_source_D65.tsv", dir);
        rc = read_table(ctx, p, 2, d65, &n65);
    }
    if (rc >= 0) {
        snprintf(p, sizeof p, "%s/photopic_detector_V.tsv", dir);
        rc = read_table(ctx, p, 2, v, &nv);
    }
    if (rc >= 0) {
        snprintf(p, sizeof p, "%s/photopic_wavelength_set.tsv", dir);
        rc = read_table(ctx, p, 1, set, &nset);
    }
    size_t m = nd > nset ? nd : nset;
    if (rc >= 0 && !(sd = bsti_alloc_array(ctx, m, sizeof *sd)))
        rc = BST_ENOMEM;
    if (rc >= 0) {
        for (size_t k = 0; k < nset; k++)
            sd[k] = interp(d65[0], d65[1], n65, set[0][k]) * interp(v[0], v[1], nv, set[0][k]);
        rc = spectral_channel(ctx, g, path, "Visible", set[0], sd, nset, VISIBLE_LO, VISIBLE_HI, d, nd);
    }
    if (rc >= 0) {
        for (size_t k = 0; k < nd; k++)
            sd[k] = interp(sol[0], sol[1], ns, d[0][k]);
        rc = spectral_channel(ctx, g, path, "Solar", d[0], sd, nd, SOLAR_LO, SOLAR_HI, d, nd);
    }
    for (int c = 0; c < 5; c++)
        bsti_free(ctx, d[c]);
    for (int c = 0; c < 2; c++)
        bsti_free(ctx, sol[c]), bsti_free(ctx, d65[c]), bsti_free(ctx, v[c]);
    bsti_free(ctx, set[0]);
    bsti_free(ctx, sd);
    return rc;
}

/* A catalogue file: '#' comments; "description TEXT"; "spectral FILE" (relative to the catalogue
 * directory); "CHANNEL key=value,...". */
static int read_catalogue(bst_ctx *ctx, bst_glass *g, const char *path, const char *name, const char *dir)
{
    FILE *fp = fopen(path, "r");
    if (!fp)
        return bsti_error(ctx, BST_ENOTFOUND, "glass:%s: no such pane in the catalogue (%s) and "
                          "not a key=value description; list the catalogue with "
                          "'bsdfstack glass --list'", name, path);
    char line[1024];
    int lineno = 0, rc = BST_OK;
    while (rc >= 0 && fgets(line, sizeof line, fp)) {
        lineno++;
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
        char where[1200];
        snprintf(where, sizeof where, "%s: line %d", path, lineno);
        if (strcmp(s, "description") == 0) {
            bsti_free(ctx, g->description);
            if (!(g->description = bsti_strdup(ctx, rest)))
                rc = BST_ENOMEM;
        } else if (!*rest) {
            rc = bsti_error(ctx, BST_EINVAL, "%s: '%s' without parameters", where, s);
        } else if (strcmp(s, "spectral") == 0) {
            char data[1200];
            snprintf(data, sizeof data, "%s/%s", dir, rest);
            rc = add_spectral(ctx, g, data, dir);
        } else {
            rc = add_channel(ctx, g, where, s, rest);
        }
    }
    fclose(fp);
    if (rc >= 0 && g->nch == 0)
        rc = bsti_error(ctx, BST_EINVAL, "%s: no channel defined", path);
    return rc;
}

int bst_glass_parse(bst_ctx *ctx, const char *spec, const char *catalogue_dir, bst_glass **out)
{
    if (!ctx || !spec || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass: NULL argument") : BST_EINVAL;
    *out = NULL;
    if (!*spec)
        return bsti_error(ctx, BST_EINVAL, "glass: empty specification (glass:NAME or glass:d=6mm,n=1.52,tn=0.89)");
    bst_glass *g = bsti_calloc(ctx, 1, sizeof *g);
    if (!g)
        return BST_ENOMEM;
    g->ctx = ctx;
    int rc;
    char where[600];
    snprintf(where, sizeof where, "glass:%s", spec);
    size_t sl = strlen(spec);
    const char *dir = catalogue_dir ? catalogue_dir : BST_GLASS_DIR;
    if (strchr(spec, '/') || (sl > 4 && strcmp(spec + sl - 4, ".tsv") == 0)) {
        rc = add_spectral(ctx, g, spec, dir);
        if (rc >= 0 && !(g->description = bsti_strdup(ctx, spec)))
            rc = BST_ENOMEM;
    } else if (strchr(spec, '=')) {
        rc = add_channel(ctx, g, where, "Visible", spec);
        if (rc >= 0)
            rc = add_channel(ctx, g, where, "Solar", spec);
        if (rc >= 0 && !(g->description = bsti_strdup(ctx, spec)))
            rc = BST_ENOMEM;
    } else {
        for (const char *c = spec; *c; c++)
            if (!(isalnum((unsigned char)*c) || *c == '-' || *c == '_' || *c == '.')) {
                bst_glass_free(g);
                return bsti_error(ctx, BST_EINVAL, "%s: a catalogue name has letters, digits, '-', "
                                  "'_' and '.' only", where);
            }
        char path[1024];
        snprintf(path, sizeof path, "%s/%s.glass", dir, spec);
        rc = read_catalogue(ctx, g, path, spec, dir);
    }
    if (rc < 0) {
        bst_glass_free(g);
        return rc;
    }
    *out = g;
    return BST_OK;
}

/* ------------------------------------------------------------------ layer */

int bst_glass_layer(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, size_t nchannels,
                    const char *const *channels, int at_centre, bst_layer **out)
{
    if (!ctx || !g || !basis || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass layer: NULL argument") : BST_EINVAL;
    *out = NULL;
    size_t idx[MAX_CH], nc = nchannels ? nchannels : g->nch;
    const char *names[MAX_CH];
    if (nc > MAX_CH)
        return bsti_error(ctx, BST_EINVAL, "glass layer: more than %d channels", MAX_CH);
    for (size_t c = 0; c < nc; c++) {
        size_t k = 0;
        if (nchannels) {
            while (k < g->nch && strcasecmp(g->name[k], channels[c]) != 0)
                k++;
            if (k == g->nch)
                return bsti_error(ctx, BST_ENOTFOUND, "glass %s: no channel %s", bst_glass_description(g), channels[c]);
        } else {
            k = c;
        }
        idx[c] = k;
        names[c] = g->name[k];
    }
    bst_layer *l;
    int rc = bst_layer_new(ctx, basis, nc, names, &l);
    if (rc < 0)
        return rc;
    size_t n = bst_basis_size(basis);
    const double *lam = bst_basis_lambda(basis);
    double *v = bsti_alloc_array(ctx, 4 * n, sizeof *v);
    if (!v) {
        bst_layer_free(l);
        return BST_ENOMEM;
    }
    for (size_t c = 0; c < nc && rc >= 0; c++) {
        for (size_t j = 0; j < n; j++) {
            double t = 0, tb = 0, rf = 0, rb = 0;
            int s = at_centre ? 1 : GLASS_SAMPLES;
            for (int a = 0; a < s; a++)
                for (int e = 0; e < s; e++) {
                    double d[3], tt, ttb, f, bb;
                    if (at_centre)
                        bst_basis_center(basis, j, d);
                    else
                        bst_basis_sample(basis, j, (a + 0.5) / s, (e + 0.5) / s, d);
                    fast_optics(g, idx[c], acos(fmin(1.0, fmax(0.0, d[2]))), &tt, &ttb, &f, &bb);
                    t += tt, tb += ttb, rf += f, rb += bb;
                }
            double w = 1.0 / (s * s * lam[j]);
            v[j] = t * w, v[n + j] = rf * w, v[2 * n + j] = tb * w, v[3 * n + j] = rb * w;
        }
        const double *src[BST_NCOMP] = {v, v + n, v + 2 * n, v + 3 * n}; /* Tf, Rf, Tb, Rb */
        for (int k = 0; k < BST_NCOMP && rc >= 0; k++) {
            bst_mat *m;
            rc = bst_mat_new_diag(ctx, n, src[k], &m);
            if (rc >= 0)
                rc = bst_layer_set(ctx, l, c, (bst_comp)k, m);
        }
    }
    bsti_free(ctx, v);
    if (rc >= 0 && g->description)
        rc = bst_layer_set_name(ctx, l, g->description);
    if (rc < 0) {
        bst_layer_free(l);
        return rc;
    }
    *out = l;
    return BST_OK;
}

int bst_glass_layer_from_spec(bst_ctx *ctx, const char *spec, const char *catalogue_dir,
                              const bst_basis *basis, size_t nchannels,
                              const char *const *channels, bst_layer **out)
{
    bst_glass *g;
    int rc = bst_glass_parse(ctx, spec, catalogue_dir, &g);
    if (rc < 0)
        return rc;
    rc = bst_glass_layer(ctx, g, basis, nchannels, channels, 0, out);
    bst_glass_free(g);
    return rc;
}
