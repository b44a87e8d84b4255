/* glass.c - analytic clear glass: the angular transmittance and reflectance of an uncoated pane, from
 * its normal-incidence values, by Windows-CalcEngine's model for uncoated glass
 * (../shared/reference/wce/README.md, "How WCE gets the angular properties of uncoated (clear)
 * glass"); spectral panes averaged per channel as WCE averages them; the pane as a diagonal layer.
 *
 * The model, per side and per wavelength (or band), from T0 and R0 at normal incidence:
 *   rho0 = smaller root of (2 - R0) rho^2 - (T0^2 - R0^2 + 2 R0 + 1) rho + R0 = 0  (one interface)
 *   n    = (1 + sqrt(rho0)) / (1 - sqrt(rho0))             (inverse of Fresnel at normal incidence)
 *   tau0 = (R0 - rho0) / (T0 rho0)                          (single-pass internal transmittance)
 *   at theta: sin(theta) = n sin(theta'), tau = tau0^(1 / cos(theta'))  (path length 1/cos(theta'))
 *   r_s = ((cos(theta) - n cos(theta')) / (cos(theta) + n cos(theta')))^2,
 *   r_p = ((n cos(theta) - cos(theta')) / (n cos(theta) + cos(theta')))^2,
 *   T_x = tau (1 - r_x)^2 / (1 - tau^2 r_x^2),  R_x = r_x (1 + tau T_x),  T, R = means over s, p.
 * This is the incoherent slab with two identical interfaces and bulk absorption.  Thickness and
 * wavelength enter only through T0 and R0 (an inline pane given by its extinction coefficient K and
 * thickness d has tau0 = exp(-K d)).  Special cases as WCE: theta = 0 gives the measured values,
 * T0 = 0 a bare interface with rho0 = R0 (T = 0), rho0 = 0 or T0 = 1 no angular dependence,
 * theta = 90 deg T = 0 and R = 1; where rounding makes T + R > 1 the larger gives way.
 *
 * Spectral panes (normal-incidence Tf, Tb, Rf, Rb against wavelength in micrometres) apply the
 * model at every wavelength of a grid (the data linearly interpolated to it) and only then average:
 *   channel value = sum_k int_[l_k, l_k+1] P S D / sum_k int_[l_k, l_k+1] S D   (trapezoid rule),
 * over the intervals inside the band's range (1e-6 um slack; an interval straddling the upper end
 * is dropped).  Solar: S = ASTM E891-87 Table 1, D = 1, 0.3..2.5 um, on the data's own wavelengths.
 * Visible (= CIE-Y): S = CIE D65, D = V(lambda), on the 5 nm photopic grid 0.38..0.78 um.  CIE-X,
 * CIE-Z: S = D65 and D = the CIE 1931 x-bar, z-bar by the multi-lobe Gaussian fit of Wyman, Sloan and
 * Shirley (JCGT 2(2), 2013), on the photopic grid; each channel is normalised by its own sum of S D,
 * so a grey pane has X = Y = Z (equal-energy white, as RADIANCE's colour).  The folded weights make
 * a channel a weighted sum of the model over wavelength nodes.
 *
 * A layer's components are diagonal in every basis (index convention of bsdfstack.h: the
 * transmitted and the mirror-reflected beam keep the incident patch's index). */
#include <config.h>

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "basis.h"
#include "ctx.h"
#include "glass.h"

/* Channels a pane may have (five spectral bands plus a few catalogue bands). */
#define MAX_CH 8
/* Refractive index assumed by inline specs that give none (soda-lime float glass). */
#define GLASS_DEFAULT_N 1.52
/* Slack on the band limits when an integration interval counts (WCE's choice, um). */
#define BAND_SLACK 1e-6
/* Spectral data: a row's T + R may exceed 1 by this much (rounding in published tables). */
#define DATA_SUM_TOL 1e-6
/* Plausible wavelengths in micrometres (a table in nanometres fails with a clear message). */
#define WL_MIN_UM 0.1
#define WL_MAX_UM 100.0

/* ------------------------------------------------------------------ the slab model */

/* One side of a pane at one wavelength or band: the measured values and the derived slab. */
struct side {
    double t0, r0;  /* normal-incidence transmittance and reflectance */
    double rho0;    /* reflectance of one interface at normal incidence */
    double n;       /* refractive index */
    double tau0;    /* single-pass internal transmittance at normal incidence */
};

/* Steps 1-3 of the model; -1 when no slab has these values. */
static int side_init(struct side *s, double t0, double r0)
{
    if (!(t0 >= 0.0 && r0 >= 0.0 && r0 < 1.0 && t0 <= 1.0))
        return -1;
    s->t0 = t0, s->r0 = r0;
    /* smaller root of a rho^2 - b rho + c (b > 0), in the form without cancellation */
    double a = 2.0 - r0, b = t0 * t0 - r0 * r0 + 2.0 * r0 + 1.0, c = r0;
    double disc = b * b - 4.0 * a * c;
    if (disc < 0.0)
        return -1;
    s->rho0 = c > 0.0 ? 2.0 * c / (b + sqrt(disc)) : 0.0;
    if (t0 == 0.0) /* opaque: a bare interface of reflectance R0 */
        s->rho0 = r0;
    double sr = sqrt(s->rho0);
    s->n = (1.0 + sr) / (1.0 - sr);
    if (t0 == 0.0 || s->rho0 == 0.0 || r0 == s->rho0)
        s->tau0 = 0.0;
    else /* above 1 only through rounding of a non-absorbing pane */
        s->tau0 = fmin(1.0, (r0 - s->rho0) / (t0 * s->rho0));
    return 0;
}

/* T and R of one side at theta (radians, 0..pi/2). */
static void side_optics(const struct side *s, double theta, double *t, double *r)
{
    if (theta <= 0.0) {
        *t = s->t0, *r = s->r0;
        return;
    }
    double ci = cos(theta);
    if (theta >= M_PI / 2 || ci <= 0.0) {
        *t = 0.0, *r = 1.0;
        return;
    }
    if (s->t0 > 0.0 && (s->rho0 == 0.0 || s->t0 == 1.0)) { /* no angular dependence */
        *t = s->t0, *r = s->r0;
        return;
    }
    double n = s->n, st = sin(theta) / n, ct = sqrt((1.0 - st) * (1.0 + st));
    double tau = s->tau0 > 0.0 ? pow(s->tau0, 1.0 / ct) : 0.0;
    /* Fresnel r = ((a - b) / (a + b))^2 with (a, b) = (cos i, n cos t) for s, (n cos i, cos t) for p.
     * Its complement 1 - r = 4 a b / (a + b)^2 and 1 - tau r = (1 - tau) + tau (1 - r) are formed
     * without cancellation: towards 90 degrees r -> 1 and the textbook form 1 - tau^2 r^2 of a
     * non-absorbing pane would lose every digit (0 / 0 at the last representable angle). */
    const double a[2] = {ci, n * ci}, b[2] = {n * ct, ct};
    double tt = 0.0, rr = 0.0;
    for (int x = 0; x < 2; x++) {
        double sum = a[x] + b[x], q = (a[x] - b[x]) / sum;
        double rx = q * q, cx = 4.0 * a[x] * b[x] / (sum * sum);
        double tx = 0.0, rrx = rx;
        if (tau > 0.0 && cx > 0.0) {
            tx = tau * cx * cx / (((1.0 - tau) + tau * cx) * (1.0 + tau * rx));
            rrx = rx * (1.0 + tau * tx);
        }
        tt += 0.5 * tx, rr += 0.5 * rrx;
    }
    if (tt + rr > 1.0) { /* rounding: the larger gives way (WCE step 7) */
        if (tt > rr)
            tt = 1.0 - rr;
        else
            rr = 1.0 - tt;
    }
    *t = tt, *r = rr;
}

/* ------------------------------------------------------------------ objects */

/* Measured normal-incidence spectrum of a pane (wavelength in um). */
struct data {
    size_t n;
    double *wl, *tf, *tb, *rf, *rb;
};

/* A source or detector table, or an integration grid (x only). */
struct table {
    size_t n;
    double *x, *y;
};

/* A channel is a weighted sum over nodes: property(theta) = sum_k w_k model(T0_k, R0_k, theta);
 * a band channel has one node of weight 1, a spectral channel the trapezoid rule folded into w.
 * A spectral channel also keeps the integration grid that stacks combining per wavelength use
 * (bst_glass_channel_weights): wavelengths grid[], source x detector sd[], range lo..hi. */
struct channel {
    char *name;
    size_t nk;
    double *w;
    struct side *front, *back;
    size_t ng;
    double *grid, *sd;
    double lo, hi;
};

struct bst_glass {
    bst_ctx *ctx;
    size_t nch;
    struct channel ch[MAX_CH];
    char *description;
    char *where;                           /* "glass:SPEC", for messages */
    struct data data;                      /* spectral panes only (data.n > 0) */
    struct table solar, d65, v, photopic;  /* spectra of the bands, spectral panes only */
};

static void table_free(bst_ctx *ctx, struct table *t)
{
    bsti_free(ctx, t->x), bsti_free(ctx, t->y);
    t->x = t->y = NULL, t->n = 0;
}

static void channel_clear(bst_ctx *ctx, struct channel *c)
{
    bsti_free(ctx, c->name), bsti_free(ctx, c->w), bsti_free(ctx, c->front);
    bsti_free(ctx, c->back), bsti_free(ctx, c->grid), bsti_free(ctx, c->sd);
    memset(c, 0, sizeof *c);
}

void bst_glass_free(bst_glass *g)
{
    if (!g)
        return;
    bst_ctx *ctx = g->ctx;
    for (size_t i = 0; i < MAX_CH; i++)
        channel_clear(ctx, &g->ch[i]);
    bsti_free(ctx, g->description), bsti_free(ctx, g->where);
    bsti_free(ctx, g->data.wl), bsti_free(ctx, g->data.tf), bsti_free(ctx, g->data.tb);
    bsti_free(ctx, g->data.rf), bsti_free(ctx, g->data.rb);
    table_free(ctx, &g->solar), table_free(ctx, &g->d65), table_free(ctx, &g->v);
    table_free(ctx, &g->photopic);
    bsti_free(ctx, g);
}

size_t bst_glass_nchannels(const bst_glass *g) { return g ? g->nch : 0; }

const char *bst_glass_channel(const bst_glass *g, size_t ch)
{
    return g && ch < g->nch ? g->ch[ch].name : NULL;
}

int bst_glass_find_channel(const bst_glass *g, const char *name)
{
    for (size_t i = 0; g && name && i < g->nch; i++)
        if (strcasecmp(g->ch[i].name, name) == 0)
            return (int)i;
    return -1;
}

const char *bst_glass_description(const bst_glass *g)
{
    return g && g->description ? g->description : "";
}

int bst_glass_optics(const bst_glass *g, size_t ch, double theta, double *tf, double *tb,
                     double *rf, double *rb)
{
    if (!g || ch >= g->nch || !(theta >= 0.0 && theta <= M_PI / 2 + 1e-12))
        return BST_EINVAL;
    const struct channel *c = &g->ch[ch];
    double st = 0, stb = 0, sf = 0, sb = 0;
    for (size_t k = 0; k < c->nk; k++) {
        double t1, r1, t2, r2;
        side_optics(&c->front[k], theta, &t1, &r1);
        side_optics(&c->back[k], theta, &t2, &r2);
        st += c->w[k] * t1, sf += c->w[k] * r1, stb += c->w[k] * t2, sb += c->w[k] * r2;
    }
    /* the weights sum to 1 up to rounding: keep T + R <= 1 as every node does */
    if (st + sf > 1.0)
        sf = 1.0 - st;
    if (stb + sb > 1.0)
        sb = 1.0 - stb;
    if (tf)
        *tf = st;
    if (tb)
        *tb = stb;
    if (rf)
        *rf = sf;
    if (rb)
        *rb = sb;
    return BST_OK;
}

/* ------------------------------------------------------------------ tables and spectra */

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

/* Numeric rows of a whitespace-separated table with at least ncol columns (more are ignored).
 * Blank lines and '#' lines are skipped, and so is the first other line when it does not start
 * with a number (column names).  Column 0 is a wavelength in um and must increase; unit = 1
 * requires columns 1.. in [0, 1] (transmittances and reflectances), else >= 0. */
static int read_table(bst_ctx *ctx, const char *path, int ncol, int unit, double **cols, size_t *n)
{
    for (int c = 0; c < ncol; c++)
        cols[c] = NULL;
    *n = 0;
    FILE *fp = fopen(path, "r");
    if (!fp)
        return bsti_error(ctx, BST_EIO, "%s: cannot open: %s", path, strerror(errno));
    size_t cap = 0;
    char line[4096];
    int lineno = 0, rc = BST_OK, header = 0;
    while (rc >= 0 && fgets(line, sizeof line, fp)) {
        lineno++;
        char *p = line, *end;
        while (isspace((unsigned char)*p))
            p++;
        if (!*p || *p == '#')
            continue;
        errno = 0;
        (void)strtod(p, &end);
        if (end == p && *n == 0 && !header) {
            header = 1;
            continue;
        }
        if (*n == cap) {
            size_t nc = cap ? 2 * cap : 128;
            for (int c = 0; c < ncol; c++) {
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
            if (rc < 0)
                break;
            cap = nc;
        }
        for (int c = 0; c < ncol && rc >= 0; c++) {
            errno = 0;
            double v = strtod(p, &end);
            if (end == p || !isfinite(v) || errno || v < 0 || (unit && c > 0 && v > 1.0))
                rc = bsti_error(ctx, BST_EFORMAT, "%s: line %d: column %d is %s", path, lineno,
                                c + 1, end == p ? "missing or not a number"
                                      : unit ? "not a value in [0, 1]" : "not a finite value >= 0");
            else if (c == 0 && (v < WL_MIN_UM || v > WL_MAX_UM))
                rc = bsti_error(ctx, BST_EFORMAT, "%s: line %d: wavelength %g is not in %g..%g um "
                                "(wavelengths are in micrometres)", path, lineno, v, WL_MIN_UM, WL_MAX_UM);
            else
                cols[c][*n] = v;
            p = end;
        }
        if (rc >= 0 && *n > 0 && cols[0][*n] <= cols[0][*n - 1])
            rc = bsti_error(ctx, BST_EFORMAT, "%s: line %d: wavelengths must increase", path, lineno);
        if (rc >= 0)
            ++*n;
    }
    if (rc >= 0 && ferror(fp))
        rc = bsti_error(ctx, BST_EIO, "%s: read error", path);
    fclose(fp);
    if (rc >= 0 && *n < 2)
        rc = bsti_error(ctx, BST_EFORMAT, "%s: fewer than two data rows", path);
    if (rc < 0) {
        for (int c = 0; c < ncol; c++) {
            bsti_free(ctx, cols[c]);
            cols[c] = NULL;
        }
        *n = 0;
    }
    return rc;
}

static int read_spectrum(bst_ctx *ctx, const char *dir, const char *file, int ncol, struct table *t)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    double *cols[2];
    int rc = read_table(ctx, path, ncol, 0, cols, &t->n);
    if (rc >= 0)
        t->x = cols[0], t->y = ncol > 1 ? cols[1] : NULL;
    return rc;
}

/* The pane's measured data (wavelength, Tf, Tb, Rf, Rb) and the spectra of the bands, which live in
 * the catalogue directory. */
static int load_spectral(bst_ctx *ctx, bst_glass *g, const char *path, const char *dir)
{
    double *cols[5];
    int rc = read_table(ctx, path, 5, 1, cols, &g->data.n);
    if (rc < 0)
        return rc;
    struct data *d = &g->data;
    d->wl = cols[0], d->tf = cols[1], d->tb = cols[2], d->rf = cols[3], d->rb = cols[4];
    for (size_t k = 0; k < d->n; k++) {
        struct side s;
        if (d->tf[k] + d->rf[k] > 1.0 + DATA_SUM_TOL || d->tb[k] + d->rb[k] > 1.0 + DATA_SUM_TOL)
            return bsti_error(ctx, BST_EFORMAT, "%s: at %g um T + R exceeds 1 (Tf %g Rf %g, Tb %g "
                              "Rb %g)", path, d->wl[k], d->tf[k], d->rf[k], d->tb[k], d->rb[k]);
        if (side_init(&s, d->tf[k], d->rf[k]) || side_init(&s, d->tb[k], d->rb[k]))
            return bsti_error(ctx, BST_EFORMAT, "%s: at %g um no uncoated pane has these T and R",
                              path, d->wl[k]);
    }
    if ((rc = read_spectrum(ctx, dir, "solar_ASTM_E891_87_Table1.tsv", 2, &g->solar)) < 0 ||
        (rc = read_spectrum(ctx, dir, "photopic_source_D65.tsv", 2, &g->d65)) < 0 ||
        (rc = read_spectrum(ctx, dir, "photopic_detector_V.tsv", 2, &g->v)) < 0 ||
        (rc = read_spectrum(ctx, dir, "photopic_wavelength_set.tsv", 1, &g->photopic)) < 0)
        return rc;
    return BST_OK;
}

/* CIE 1931 colour-matching functions x-bar and z-bar at lambda (um): the multi-lobe piecewise
 * Gaussian fit of Wyman, Sloan and Shirley (2013), each lobe (weight, centre nm, sigma below and
 * above the centre).  (Its y-bar differs from the tabulated V by up to 0.007 of the peak on the
 * 5 nm photopic grid; CIE-Y uses the table.) */
static double lobe(double nm, double w, double mu, double s_lo, double s_hi)
{
    double t = (nm - mu) / (nm < mu ? s_lo : s_hi);
    return w * exp(-0.5 * t * t);
}

static double cie_xbar(double um)
{
    double nm = 1000.0 * um;
    return lobe(nm, 1.056, 599.8, 37.9, 31.0) + lobe(nm, 0.362, 442.0, 16.0, 26.7) +
           lobe(nm, -0.065, 501.1, 20.4, 26.2);
}

static double cie_zbar(double um)
{
    double nm = 1000.0 * um;
    return lobe(nm, 1.217, 437.0, 11.8, 36.0) + lobe(nm, 0.681, 459.0, 26.0, 13.8);
}

/* The spectral bands a spectral pane can be averaged over. */
enum detector { DET_ONE, DET_V, DET_X, DET_Z };
static const struct band {
    const char *name;
    int solar;           /* 1: ASTM E891 source on the data's own grid; 0: D65 on the photopic grid */
    enum detector det;
    double lo, hi;       /* um */
} bands[] = {
    {"Visible", 0, DET_V, 0.38, 0.78}, {"Solar", 1, DET_ONE, 0.3, 2.5},
    {"CIE-X", 0, DET_X, 0.38, 0.78},   {"CIE-Y", 0, DET_V, 0.38, 0.78},
    {"CIE-Z", 0, DET_Z, 0.38, 0.78},
};
#define NBANDS (sizeof bands / sizeof bands[0])
#define BAND_LIST "Visible, Solar, CIE-X, CIE-Y, CIE-Z"

static const struct band *find_band(const char *name)
{
    for (size_t i = 0; i < NBANDS; i++)
        if (strcasecmp(bands[i].name, name) == 0)
            return &bands[i];
    return NULL;
}

/* Source x detector of a band at wavelength um. */
static double band_sd(const bst_glass *g, const struct band *b, double um)
{
    if (b->solar)
        return interp(g->solar.x, g->solar.y, g->solar.n, um);
    double s = interp(g->d65.x, g->d65.y, g->d65.n, um);
    switch (b->det) {
    case DET_V: return s * interp(g->v.x, g->v.y, g->v.n, um);
    case DET_X: return s * cie_xbar(um);
    case DET_Z: return s * cie_zbar(um);
    default: return s;
    }
}

/* Trapezoid weights of P on grid x[0..m-1] with S D values sd[], normalised, intervals restricted
 * to [lo, hi] as WCE restricts them; w[] is zeroed first.  -1 when the band has no weight. */
static int trapezoid(const double *x, const double *sd, size_t m, double lo, double hi, double *w)
{
    double sum = 0.0;
    for (size_t k = 0; k < m; k++)
        w[k] = 0.0;
    for (size_t k = 0; k + 1 < m; k++)
        if (x[k] >= lo - BAND_SLACK && x[k + 1] <= hi + BAND_SLACK) {
            double h = 0.5 * (x[k + 1] - x[k]);
            w[k] += h * sd[k], w[k + 1] += h * sd[k + 1];
            sum += h * (sd[k] + sd[k + 1]);
        }
    if (!(sum > 0.0))
        return -1;
    for (size_t k = 0; k < m; k++)
        w[k] /= sum;
    return 0;
}

/* Normal-incidence data of the pane at um, interpolated linearly (constant outside). */
static void data_at(const struct data *d, double um, double *tf, double *tb, double *rf, double *rb)
{
    *tf = interp(d->wl, d->tf, d->n, um), *tb = interp(d->wl, d->tb, d->n, um);
    *rf = interp(d->wl, d->rf, d->n, um), *rb = interp(d->wl, d->rb, d->n, um);
}

static int new_channel(bst_ctx *ctx, bst_glass *g, const char *where, const char *name, size_t nk)
{
    if (g->nch >= MAX_CH)
        return bsti_error(ctx, BST_EINVAL, "%s: more than %d channels", where, MAX_CH);
    if (bst_glass_find_channel(g, name) >= 0)
        return bsti_error(ctx, BST_EINVAL, "%s: channel %s given twice", where, name);
    struct channel *c = &g->ch[g->nch];
    c->nk = nk;
    if (!(c->name = bsti_strdup(ctx, name)) || !(c->w = bsti_calloc(ctx, nk, sizeof *c->w)) ||
        !(c->front = bsti_calloc(ctx, nk, sizeof *c->front)) ||
        !(c->back = bsti_calloc(ctx, nk, sizeof *c->back)))
        return BST_ENOMEM; /* the partial channel is freed with g */
    return BST_OK;
}

/* Fills channel g->nch with a spectral band of a spectral pane (add_band commits or clears it). */
static int fill_band(bst_ctx *ctx, bst_glass *g, const char *where, const struct band *b)
{
    const struct data *d = &g->data;
    /* the single pane's own grid (WCE's single-layer averages) and the integration grid of
     * per-wavelength stacks (WCE's multi-layer averages) */
    const double *own = b->solar ? d->wl : g->photopic.x;
    size_t m = b->solar ? d->n : g->photopic.n;
    const double *ig = b->solar ? g->solar.x : g->photopic.x;
    size_t mg = b->solar ? g->solar.n : g->photopic.n;
    if (d->wl[0] > b->hi || d->wl[d->n - 1] < b->lo)
        return bsti_error(ctx, BST_EFORMAT, "%s: the data (%g..%g um) cover none of %s's range "
                          "%g..%g um", where, d->wl[0], d->wl[d->n - 1], b->name, b->lo, b->hi);
    int rc = new_channel(ctx, g, where, b->name, m);
    if (rc < 0)
        return rc;
    struct channel *c = &g->ch[g->nch];
    double *sd = bsti_alloc_array(ctx, m > mg ? m : mg, sizeof *sd);
    if (!sd || !(c->grid = bsti_alloc_array(ctx, mg, sizeof *c->grid)) ||
        !(c->sd = bsti_alloc_array(ctx, mg, sizeof *c->sd))) {
        bsti_free(ctx, sd);
        return BST_ENOMEM;
    }
    for (size_t k = 0; k < m; k++)
        sd[k] = band_sd(g, b, own[k]);
    rc = trapezoid(own, sd, m, b->lo, b->hi, c->w);
    bsti_free(ctx, sd);
    if (rc < 0)
        return bsti_error(ctx, BST_EFORMAT, "%s: no interval of the data's wavelengths lies in "
                          "%s's range %g..%g um", where, b->name, b->lo, b->hi);
    for (size_t k = 0; k < m; k++) {
        double tf, tb, rf, rb;
        data_at(d, own[k], &tf, &tb, &rf, &rb);
        if (side_init(&c->front[k], tf, rf) || side_init(&c->back[k], tb, rb))
            return bsti_error(ctx, BST_EFORMAT, "%s: at %g um no uncoated pane has T0 = %g and "
                              "R0 = %g", where, own[k], tf, rf);
    }
    c->ng = mg, c->lo = b->lo, c->hi = b->hi;
    for (size_t k = 0; k < mg; k++)
        c->grid[k] = ig[k], c->sd[k] = band_sd(g, b, ig[k]);
    return BST_OK;
}

/* A new channel is complete or absent: a failure clears the half-built one. */
static int commit(bst_ctx *ctx, bst_glass *g, int rc)
{
    if (rc < 0)
        channel_clear(ctx, &g->ch[g->nch]);
    else
        g->nch++;
    return rc;
}

static int add_band(bst_ctx *ctx, bst_glass *g, const char *where, const struct band *b)
{
    if (g->nch >= MAX_CH) /* checked here too: commit() indexes g->ch[g->nch] */
        return bsti_error(ctx, BST_EINVAL, "%s: more than %d channels", where, MAX_CH);
    return commit(ctx, g, fill_band(ctx, g, where, b));
}

int bst_glass_add_channel(bst_ctx *ctx, bst_glass *g, const char *name)
{
    if (!ctx || !g || !name)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass: NULL argument") : BST_EINVAL;
    if (bst_glass_find_channel(g, name) >= 0)
        return BST_OK;
    const struct band *b = find_band(name);
    if (!b)
        return bsti_error(ctx, BST_ENOTFOUND, "%s: no channel %s (spectral bands: " BAND_LIST ")",
                          g->where, name);
    if (!g->data.n)
        return bsti_error(ctx, BST_ENOTFOUND, "%s: no channel %s (only a pane with spectral data "
                          "can be averaged over a new band)", g->where, name);
    return add_band(ctx, g, g->where, b);
}

/* ------------------------------------------------------------------ spectral access */

size_t bst_glass_nwavelengths(const bst_glass *g) { return g ? g->data.n : 0; }

double bst_glass_wavelength(const bst_glass *g, size_t i)
{
    return g && i < g->data.n ? g->data.wl[i] : NAN;
}

int bst_glass_optics_spectral(const bst_glass *g, double lambda, double theta, double *tf,
                              double *tb, double *rf, double *rb)
{
    if (!g || !g->data.n || !isfinite(lambda) || !(theta >= 0.0 && theta <= M_PI / 2 + 1e-12))
        return BST_EINVAL;
    double t0f, t0b, r0f, r0b, t, r;
    struct side f, b;
    data_at(&g->data, lambda, &t0f, &t0b, &r0f, &r0b);
    if (side_init(&f, t0f, r0f) || side_init(&b, t0b, r0b))
        return BST_EINVAL;
    side_optics(&f, theta, &t, &r);
    if (tf)
        *tf = t;
    if (rf)
        *rf = r;
    side_optics(&b, theta, &t, &r);
    if (tb)
        *tb = t;
    if (rb)
        *rb = r;
    return BST_OK;
}

int bst_glass_slab(const bst_glass *g, size_t ch, double lambda, int back, double *n, double *tau0)
{
    if (!g || ch >= g->nch)
        return BST_EINVAL;
    struct side s;
    if (g->data.n) {
        double tf, tb, rf, rb;
        if (!isfinite(lambda))
            return BST_EINVAL;
        data_at(&g->data, lambda, &tf, &tb, &rf, &rb);
        if (side_init(&s, back ? tb : tf, back ? rb : rf))
            return BST_EINVAL;
    } else {
        if (g->ch[ch].nk != 1)
            return BST_EINVAL;
        s = back ? g->ch[ch].back[0] : g->ch[ch].front[0];
    }
    if (n)
        *n = s.n;
    if (tau0)
        *tau0 = s.tau0;
    return BST_OK;
}

const double *bst_glass_channel_grid(const bst_glass *g, size_t ch, size_t *n)
{
    if (n)
        *n = 0;
    if (!g || ch >= g->nch || !g->ch[ch].ng)
        return NULL;
    if (n)
        *n = g->ch[ch].ng;
    return g->ch[ch].grid;
}

int bst_glass_channel_weights(bst_ctx *ctx, const bst_glass *g, size_t ch, size_t n,
                              const double *wl, double *w)
{
    if (!ctx || !g || !wl || !w || !n)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass channel weights: NULL or empty argument")
                   : BST_EINVAL;
    if (ch >= g->nch || !g->ch[ch].ng)
        return bsti_error(ctx, BST_EINVAL, "%s: channel %zu is not a spectral band", g->where, ch);
    for (size_t k = 0; k < n; k++)
        if (!isfinite(wl[k]) || (k && wl[k] <= wl[k - 1]))
            return bsti_error(ctx, BST_EINVAL, "glass channel weights: wavelength %zu (%g um) is "
                              "not finite or does not increase", k, wl[k]);
    const struct channel *c = &g->ch[ch];
    double *cw = bsti_alloc_array(ctx, c->ng, sizeof *cw);
    if (!cw)
        return BST_ENOMEM;
    if (trapezoid(c->grid, c->sd, c->ng, c->lo, c->hi, cw) < 0) {
        bsti_free(ctx, cw);
        return bsti_error(ctx, BST_EINTERNAL, "glass: channel %s has no weight", c->name);
    }
    /* P on the integration grid is P on wl[] interpolated linearly (constant outside): each grid
     * node's weight goes to the one or two wavelengths that it lies between */
    for (size_t k = 0; k < n; k++)
        w[k] = 0.0;
    size_t lo = 0;
    for (size_t j = 0; j < c->ng; j++) {
        double x = c->grid[j];
        if (cw[j] == 0.0)
            continue;
        if (x <= wl[0] || n == 1) {
            w[0] += cw[j];
        } else if (x >= wl[n - 1]) {
            w[n - 1] += cw[j];
        } else {
            while (wl[lo + 1] < x) /* grid increases: lo only moves forward */
                lo++;
            double f = (x - wl[lo]) / (wl[lo + 1] - wl[lo]);
            w[lo] += (1 - f) * cw[j], w[lo + 1] += f * cw[j];
        }
    }
    bsti_free(ctx, cw);
    return BST_OK;
}

/* ------------------------------------------------------------------ inline specs */

/* A number followed by one of the unit suffixes (NULL-terminated; "" = no suffix), scaled by the
 * suffix's factor. */
static int parse_scaled(const char *v, const char *const *suffix, const double *factor, double *out)
{
    char *end;
    errno = 0;
    double x = strtod(v, &end);
    if (end == v || !isfinite(x) || errno)
        return -1;
    for (int i = 0; suffix[i]; i++)
        if (strcmp(end, suffix[i]) == 0) {
            *out = x * factor[i];
            return 0;
        }
    return -1;
}

/* "6mm", "0.006m", "0.6cm", "0.25in" or a bare number of millimetres -> metres. */
static int parse_length(const char *v, double *m)
{
    static const char *const suffix[] = {"", "mm", "m", "cm", "in", NULL};
    static const double factor[] = {1e-3, 1e-3, 1.0, 1e-2, 0.0254};
    return parse_scaled(v, suffix, factor, m);
}

/* An extinction coefficient: "25", "25/m", "0.25/cm", "0.025/mm" -> 1/m. */
static int parse_extinction(const char *v, double *k)
{
    static const char *const suffix[] = {"", "/m", "/cm", "/mm", NULL};
    static const double factor[] = {1.0, 1.0, 1e2, 1e3};
    return parse_scaled(v, suffix, factor, k);
}

static int parse_number(const char *v, double *x)
{
    char *end;
    errno = 0;
    *x = strtod(v, &end);
    return (end == v || *end || !isfinite(*x) || errno) ? -1 : 0;
}

/* Parse "key=value,key=value" into the two sides of one band channel. */
static int parse_params(bst_ctx *ctx, const char *where, const char *text, struct side *f,
                        struct side *b)
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
            return bsti_error(ctx, BST_EINVAL, "%s: %s=%s is not a valid value (d: a length below "
                              "1 m such as 6mm; n: 1..5; tn, t0: 0..1; k: >= 0 per metre such as "
                              "25/m; r0, r0b: 0..1)", where, key, val);
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
    if (side_init(f, t0, r0f) || side_init(b, t0, r0b))
        return bsti_error(ctx, BST_EINVAL, "%s: no uncoated pane has T0 = %g and R0 = %g", where,
                          t0, r0f);
    return BST_OK;
}

static int add_inline(bst_ctx *ctx, bst_glass *g, const char *where, const char *name,
                      const char *params)
{
    if (g->nch >= MAX_CH)
        return bsti_error(ctx, BST_EINVAL, "%s: more than %d channels", where, MAX_CH);
    int rc = new_channel(ctx, g, where, name, 1);
    if (rc >= 0) {
        struct channel *c = &g->ch[g->nch];
        c->w[0] = 1.0;
        rc = parse_params(ctx, where, params, &c->front[0], &c->back[0]);
    }
    return commit(ctx, g, rc);
}

/* A spectral data file and the bands to average it over (space-separated names; "" = Visible
 * and Solar). */
static int add_spectral(bst_ctx *ctx, bst_glass *g, const char *where, const char *path,
                        const char *dir, char *names)
{
    if (g->data.n)
        return bsti_error(ctx, BST_EINVAL, "%s: a second spectral data file", where);
    int rc = load_spectral(ctx, g, path, dir);
    char def[] = "Visible Solar";
    char *save = NULL;
    for (char *b = strtok_r(*names ? names : def, " \t", &save); b && rc >= 0;
         b = strtok_r(NULL, " \t", &save)) {
        const struct band *band = find_band(b);
        rc = band ? add_band(ctx, g, path, band)
                  : bsti_error(ctx, BST_EINVAL, "%s: unknown spectral band '%s' (" BAND_LIST ")",
                               where, b);
    }
    return rc;
}

/* A catalogue file (bsdfstack-glass(5)): '#' comments; "description TEXT"; "spectral FILE
 * [BAND...]" (FILE relative to the catalogue directory); "CHANNEL key=value,...". */
static int read_catalogue(bst_ctx *ctx, bst_glass *g, const char *path, const char *name,
                          const char *dir)
{
    FILE *fp = fopen(path, "r");
    if (!fp)
        return bsti_error(ctx, BST_ENOTFOUND, "glass:%s: no such pane in the catalogue (%s) and "
                          "not a key=value description; list the catalogue with "
                          "'bsdfstack glass --list'", name, dir);
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
        char where[1300];
        snprintf(where, sizeof where, "%s: line %d", path, lineno);
        if (strcmp(s, "description") == 0) {
            bsti_free(ctx, g->description);
            if (!(g->description = bsti_strdup(ctx, rest)))
                rc = BST_ENOMEM;
        } else if (!*rest) {
            rc = bsti_error(ctx, BST_EINVAL, "%s: '%s' without parameters", where, s);
        } else if (strcmp(s, "spectral") == 0) {
            char *names = rest;
            while (*names && !isspace((unsigned char)*names))
                names++;
            if (*names)
                *names++ = '\0';
            char data[1200];
            snprintf(data, sizeof data, "%s%s%s", rest[0] == '/' ? "" : dir,
                     rest[0] == '/' ? "" : "/", rest);
            rc = add_spectral(ctx, g, where, data, dir, names);
        } else {
            rc = add_inline(ctx, g, where, s, rest);
        }
    }
    fclose(fp);
    if (rc >= 0 && g->nch == 0)
        rc = bsti_error(ctx, BST_EFORMAT, "%s: no channel defined", path);
    return rc;
}

int bst_glass_parse(bst_ctx *ctx, const char *spec, const char *catalogue_dir, bst_glass **out)
{
    if (!ctx || !spec || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass: NULL argument") : BST_EINVAL;
    *out = NULL;
    if (!*spec)
        return bsti_error(ctx, BST_EINVAL, "glass: empty specification (glass:NAME, glass:PATH "
                          "or glass:d=6mm,n=1.52,tn=0.89)");
    bst_glass *g = bsti_calloc(ctx, 1, sizeof *g);
    if (!g)
        return BST_ENOMEM;
    g->ctx = ctx;
    int rc;
    char where[600];
    snprintf(where, sizeof where, "glass:%s", spec);
    if (!(g->where = bsti_strdup(ctx, where))) {
        bst_glass_free(g);
        return BST_ENOMEM;
    }
    size_t sl = strlen(spec);
    const char *dir = catalogue_dir ? catalogue_dir : BST_GLASS_DIR;
    /* key=value,... starts with a key; PATH (a '/' or a .tsv ending); else a catalogue NAME */
    size_t kl = 0;
    while (isalnum((unsigned char)spec[kl]))
        kl++;
    int is_inline = kl > 0 && spec[kl] == '=' && isalpha((unsigned char)spec[0]);
    if (!is_inline && (strchr(spec, '/') || (sl > 4 && strcmp(spec + sl - 4, ".tsv") == 0))) {
        char none[1] = "";
        rc = add_spectral(ctx, g, where, spec, dir, none);
        if (rc >= 0 && !(g->description = bsti_strdup(ctx, spec)))
            rc = BST_ENOMEM;
    } else if (is_inline) {
        rc = add_inline(ctx, g, where, "Visible", spec);
        if (rc >= 0)
            rc = add_inline(ctx, g, where, "Solar", spec);
        if (rc >= 0 && !(g->description = bsti_strdup(ctx, spec)))
            rc = BST_ENOMEM;
    } else {
        rc = BST_OK;
        for (const char *c = spec; *c && rc >= 0; c++)
            if (!(isalnum((unsigned char)*c) || *c == '-' || *c == '_' || *c == '.'))
                rc = bsti_error(ctx, BST_EINVAL, "%s: a catalogue name has letters, digits, '-', "
                                "'_' and '.' only", where);
        if (rc >= 0) {
            char path[1200];
            snprintf(path, sizeof path, "%s/%s.glass", dir, spec);
            rc = read_catalogue(ctx, g, path, spec, dir);
        }
        if (rc >= 0 && !g->description && !(g->description = bsti_strdup(ctx, spec)))
            rc = BST_ENOMEM;
    }
    if (rc < 0) {
        bst_glass_free(g);
        return rc;
    }
    *out = g;
    return BST_OK;
}

/* ------------------------------------------------------------------ layer */

/* Tf, Tb, Rf, Rb of channel ch, or at wavelength lambda (um) when lambda > 0, at theta. */
static void optics_at(const bst_glass *g, size_t ch, double lambda, double theta, double p[4])
{
    if (lambda > 0)
        bst_glass_optics_spectral(g, lambda, theta, &p[0], &p[1], &p[2], &p[3]);
    else
        bst_glass_optics(g, ch, theta, &p[0], &p[1], &p[2], &p[3]);
}

static double *table_at(bst_ctx *ctx, const bst_glass *g, size_t ch, double lambda)
{
    double *t = bsti_alloc_array(ctx, 4 * (size_t)(BST_GLASS_TABLE_STEPS + 1), sizeof *t);
    for (size_t a = 0; t && a <= BST_GLASS_TABLE_STEPS; a++)
        optics_at(g, ch, lambda, (double)a / BST_GLASS_TABLE_STEPS * (M_PI / 2), &t[4 * a]);
    return t;
}

double *bsti_glass_table(bst_ctx *ctx, const bst_glass *g, size_t ch)
{
    return table_at(ctx, g, ch, 0.0);
}

void bsti_glass_table_optics(const double *tab, double theta, double v[4])
{
    double x = fmin(fmax(theta / (M_PI / 2), 0.0), 1.0) * BST_GLASS_TABLE_STEPS;
    size_t a = (size_t)x;
    if (a >= BST_GLASS_TABLE_STEPS)
        a = BST_GLASS_TABLE_STEPS - 1;
    double f = x - (double)a;
    for (int i = 0; i < 4; i++)
        v[i] = (1 - f) * tab[4 * a + i] + f * tab[4 * a + 4 + i];
}

/* Incidence angle of a unit direction, accurate near the normal too. */
static double dir_theta(const double d[3])
{
    return atan2(hypot(d[0], d[1]), fabs(d[2]));
}

/* Gauss-Legendre nodes and weights of order m on [0, 1] (Newton's method on P_m from Tricomi's
 * estimates; weights sum to 1). */
static void gauss_legendre(int m, double *x, double *w)
{
    for (int i = 0; i < m; i++) {
        double z = cos(M_PI * (i + 0.75) / (m + 0.5)), dp = 1.0;
        for (int it = 0; it < 100; it++) {
            double p0 = 1.0, p1 = z;
            for (int k = 2; k <= m; k++) {
                double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
                p0 = p1, p1 = p2;
            }
            dp = m * (z * p1 - p0) / (z * z - 1.0);
            double dz = p1 / dp;
            z -= dz;
            if (fabs(dz) < 1e-15)
                break;
        }
        x[i] = 0.5 * (1.0 - z);
        w[i] = 1.0 / ((1.0 - z * z) * dp * dp);
    }
}

/* The rule for a patch average over bst_basis_sample's (u, v) square: points u[], v[] with weights
 * w[] (4 m^2 of each, weights sum to 1).
 * An isotropic pane's property depends on the radius r = sin(theta) alone, and is a smooth function
 * of cos(theta) = sqrt(1 - r^2): at the rim it has a square-root singularity.  Both bases' sample
 * maps are linear in u and v, with the rim on a cell edge; Shirley-Chiu's concentric map has
 * r = max(|a|, |b|) in square coordinates, with a kink along the cell diagonals of the cells that lie
 * on the square's diagonals.  So the square is split by both its diagonals into four triangles
 * (centre, corner, next corner), every kink and singular edge becomes a triangle edge, and each
 * triangle, collapsed onto [0, 1]^2 by p = c + s (p1 + t (p2 - p1) - c) (Jacobian s / 2), gets an
 * m x m Gauss-Legendre rule after the substitution s = q^2 (3 - 2 q) (likewise t), which turns
 * sqrt(1 - s) into the smooth (1 - q) sqrt(1 + 2 q).  A plain midpoint rule errs by up to 1e-2 in
 * rim patches; this one by < 1e-7 (bench/bench_glass). */
static int patch_rule(bst_ctx *ctx, int m, double **u, double **v, double **w)
{
    size_t np = 4 * (size_t)m * (size_t)m;
    double *x = bsti_alloc_array(ctx, (size_t)m, sizeof *x), *gw = bsti_alloc_array(ctx, (size_t)m, sizeof *gw);
    *u = bsti_alloc_array(ctx, np, sizeof **u);
    *v = bsti_alloc_array(ctx, np, sizeof **v);
    *w = bsti_alloc_array(ctx, np, sizeof **w);
    if (!x || !gw || !*u || !*v || !*w) {
        bsti_free(ctx, x), bsti_free(ctx, gw);
        bsti_free(ctx, *u), bsti_free(ctx, *v), bsti_free(ctx, *w);
        *u = *v = *w = NULL;
        return -1;
    }
    gauss_legendre(m, x, gw);
    for (int i = 0; i < m; i++) { /* the substitution q -> q^2 (3 - 2 q) */
        double q = x[i];
        x[i] = q * q * (3.0 - 2.0 * q);
        gw[i] *= 6.0 * q * (1.0 - q);
    }
    static const double corner[5][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}};
    size_t k = 0;
    for (int tri = 0; tri < 4; tri++) {
        const double *p1 = corner[tri], *p2 = corner[tri + 1];
        for (int i = 0; i < m; i++)
            for (int j = 0; j < m; j++, k++) {
                double sv = x[i], tv = x[j];
                (*u)[k] = 0.5 + sv * (p1[0] + tv * (p2[0] - p1[0]) - 0.5);
                (*v)[k] = 0.5 + sv * (p1[1] + tv * (p2[1] - p1[1]) - 0.5);
                (*w)[k] = 0.5 * sv * gw[i] * gw[j];
            }
    }
    bsti_free(ctx, x), bsti_free(ctx, gw);
    return 0;
}

struct bsti_glass_rule {
    size_t n, np;  /* patches, points per patch */
    double *theta; /* theta[j * np + q]: incidence angle of point q of patch j */
    double *w;     /* its weight (sum 1 per patch) */
    size_t *rep;   /* rep[j] <= j: a patch with the same incidence angles and Lambda as j */
};

void bsti_glass_rule_free(bst_ctx *ctx, bsti_glass_rule *r)
{
    if (r)
        bsti_free(ctx, r->theta), bsti_free(ctx, r->w), bsti_free(ctx, r->rep), bsti_free(ctx, r);
}

/* A pane is isotropic, so a patch's average depends only on the incidence angles of its points.
 * Shirley-Chiu: the concentric map commutes with the 8 symmetries of the square (quarter turns,
 * mirrors), and the patch rule's points are symmetric too, so the patches of one orbit share their
 * angles; the orbit's least index stands for it (8x fewer evaluations).  Klems: a patch's angles
 * depend only on its band, whose first patch stands for it. */
static void patch_representatives(const bst_basis *b, size_t *rep)
{
    size_t n = bst_basis_size(b);
    if (b->kind == BST_BASIS_SHIRLEY_CHIU) {
        size_t G = b->g;
        for (size_t j = 0; j < n; j++) {
            size_t x = j / G, y = j % G, best = j;
            size_t xs[2] = {x, G - 1 - x}, ys[2] = {y, G - 1 - y};
            for (int a = 0; a < 2; a++)
                for (int c = 0; c < 2; c++) {
                    size_t p = xs[a] * G + ys[c], q = ys[c] * G + xs[a];
                    best = p < best ? p : best;
                    best = q < best ? q : best;
                }
            rep[j] = best;
        }
    } else {
        for (size_t band = 0; band < b->nbands; band++) {
            size_t end = band + 1 < b->nbands ? b->first[band + 1] : n;
            for (size_t j = b->first[band]; j < end; j++)
                rep[j] = b->first[band];
        }
    }
}

int bsti_glass_rule_new(bst_ctx *ctx, const bst_basis *basis, int at_centre, int samples,
                        bsti_glass_rule **out)
{
    *out = NULL;
    if (!at_centre && samples < 1)
        return bsti_error(ctx, BST_EINVAL, "glass layer: %d samples per patch", samples);
    size_t n = bst_basis_size(basis), np = at_centre ? 1 : 4 * (size_t)samples * (size_t)samples;
    bsti_glass_rule *r = bsti_calloc(ctx, 1, sizeof *r);
    double *qu = NULL, *qv = NULL, *qw = NULL;
    if (!r || !(r->theta = bsti_alloc_array(ctx, n * np, sizeof *r->theta)) ||
        !(r->w = bsti_alloc_array(ctx, n * np, sizeof *r->w)) ||
        !(r->rep = bsti_alloc_array(ctx, n, sizeof *r->rep)) ||
        (!at_centre && patch_rule(ctx, samples, &qu, &qv, &qw) < 0)) {
        bsti_glass_rule_free(ctx, r);
        return BST_ENOMEM;
    }
    r->n = n, r->np = np;
    patch_representatives(basis, r->rep);
    for (size_t j = 0; j < n; j++)
        for (size_t q = 0; q < np; q++) {
            double d[3];
            if (at_centre)
                bst_basis_center(basis, j, d);
            else
                bst_basis_sample(basis, j, qu[q], qv[q], d);
            r->theta[j * np + q] = dir_theta(d);
            r->w[j * np + q] = at_centre ? 1.0 : qw[q];
        }
    bsti_free(ctx, qu), bsti_free(ctx, qv), bsti_free(ctx, qw);
    *out = r;
    return BST_OK;
}

/* The layer over basis of the channels idx[0..nc-1] (names[]), or of the one wavelength lambda
 * (um) when lambda > 0 (one channel, names[0]), averaged with rule r over each patch.  A patch
 * average evaluates hundreds of directions per patch: through the angular table unless exact
 * (a rule of patch centres is always exact). */
static int build_layer(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis,
                       const bsti_glass_rule *r, size_t nc, const size_t *idx,
                       const char *const *names, double lambda, int exact, bst_layer **out)
{
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
        double *tab = NULL;
        if (r->np > 1 && !exact && !(tab = table_at(ctx, g, idx[c], lambda))) {
            rc = BST_ENOMEM;
            break;
        }
        for (size_t j = 0; j < n; j++) {
            if (r->rep[j] != j) { /* the same angles (and Lambda) as an earlier patch */
                for (int k = 0; k < 4; k++)
                    v[(size_t)k * n + j] = v[(size_t)k * n + r->rep[j]];
                continue;
            }
            double sum[4] = {0, 0, 0, 0}, p[4];
            for (size_t q = j * r->np; q < (j + 1) * r->np; q++) {
                if (tab)
                    bsti_glass_table_optics(tab, r->theta[q], p);
                else
                    optics_at(g, idx[c], lambda, r->theta[q], p);
                for (int i = 0; i < 4; i++)
                    sum[i] += r->w[q] * p[i];
            }
            double w = 1.0 / lam[j];
            /* p[] order Tf, Tb, Rf, Rb; v blocks in bst_comp order Tf, Rf, Tb, Rb */
            v[j] = sum[0] * w, v[n + j] = sum[2] * w, v[2 * n + j] = sum[1] * w;
            v[3 * n + j] = sum[3] * w;
        }
        bsti_free(ctx, tab);
        for (int k = 0; k < BST_NCOMP && rc >= 0; k++) {
            bst_mat *m;
            rc = bst_mat_new_diag(ctx, n, v + (size_t)k * n, &m);
            if (rc >= 0)
                rc = bst_layer_set(ctx, l, c, (bst_comp)k, m);
        }
        bsti_progress(ctx, (double)(c + 1) / (double)nc, "glass layer");
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

int bsti_glass_layer(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, size_t nchannels,
                     const char *const *channels, int at_centre, int samples, int exact,
                     bst_layer **out)
{
    if (!ctx || !g || !basis || !out || (nchannels && !channels))
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass layer: NULL argument") : BST_EINVAL;
    *out = NULL;
    if (!at_centre && samples < 1)
        return bsti_error(ctx, BST_EINVAL, "glass layer: %d samples per patch", samples);
    size_t idx[MAX_CH], nc = nchannels ? nchannels : g->nch;
    const char *names[MAX_CH];
    if (nc > MAX_CH)
        return bsti_error(ctx, BST_EINVAL, "glass layer: more than %d channels", MAX_CH);
    for (size_t c = 0; c < nc; c++) {
        int k = nchannels ? bst_glass_find_channel(g, channels[c]) : (int)c;
        if (k < 0)
            return bsti_error(ctx, BST_ENOTFOUND, "%s: no channel %s", g->where, channels[c]);
        idx[c] = (size_t)k;
        names[c] = g->ch[k].name;
    }
    bsti_glass_rule *r;
    int rc = bsti_glass_rule_new(ctx, basis, at_centre, samples, &r);
    if (rc < 0)
        return rc;
    rc = build_layer(ctx, g, basis, r, nc, idx, names, 0.0, exact, out);
    bsti_glass_rule_free(ctx, r);
    return rc;
}

int bsti_glass_layer_at(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis,
                        const bsti_glass_rule *rule, double lambda_um, bst_layer **out)
{
    if (!ctx || !g || !basis || !rule || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass layer: NULL argument") : BST_EINVAL;
    *out = NULL;
    if (!g->data.n)
        return bsti_error(ctx, BST_EINVAL, "%s: no spectral data, so no layer per wavelength", g->where);
    if (!(lambda_um > 0) || !isfinite(lambda_um))
        return bsti_error(ctx, BST_EINVAL, "%s: wavelength %g um is not positive", g->where, lambda_um);
    if (rule->n != bst_basis_size(basis))
        return bsti_error(ctx, BST_EINVAL, "glass layer: the patch rule is for another basis");
    static const size_t zero = 0;
    static const char *const name[] = {"Spectral"};
    return build_layer(ctx, g, basis, rule, 1, &zero, name, lambda_um, 0, out);
}

int bst_glass_layer_at(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, double lambda_um,
                       int at_centre, bst_layer **out)
{
    if (!ctx || !basis || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass layer: NULL argument") : BST_EINVAL;
    bsti_glass_rule *r;
    int rc = bsti_glass_rule_new(ctx, basis, at_centre, BST_GLASS_SAMPLES, &r);
    if (rc < 0)
        return rc;
    rc = bsti_glass_layer_at(ctx, g, basis, r, lambda_um, out);
    bsti_glass_rule_free(ctx, r);
    return rc;
}

int bst_glass_layer(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, size_t nchannels,
                    const char *const *channels, int at_centre, bst_layer **out)
{
    return bsti_glass_layer(ctx, g, basis, nchannels, channels, at_centre, BST_GLASS_SAMPLES, 0, out);
}

int bst_glass_layer_from_spec(bst_ctx *ctx, const char *spec, const char *catalogue_dir,
                              const bst_basis *basis, size_t nchannels,
                              const char *const *channels, bst_layer **out)
{
    if (out)
        *out = NULL;
    bst_glass *g;
    int rc = bst_glass_parse(ctx, spec, catalogue_dir, &g);
    if (rc < 0)
        return rc;
    /* a spectral pane is averaged over any further band the caller asks for (CIE-X, ...) */
    for (size_t c = 0; c < nchannels && rc >= 0 && channels; c++)
        if (bst_glass_find_channel(g, channels[c]) < 0 && bst_glass_nwavelengths(g) &&
            find_band(channels[c]))
            rc = bst_glass_add_channel(ctx, g, channels[c]);
    if (rc >= 0)
        rc = bst_glass_layer(ctx, g, basis, nchannels, channels, 0, out);
    bst_glass_free(g);
    return rc;
}
