/* glass_band.c - spectral panes: their measured data, the band spectra and the averages over bands.
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
 * a channel a weighted sum of the model (glass.c) over wavelength nodes.
 * The data must reach both ends of each band they are averaged over (to the same 1e-6 um): data
 * that cover part of a band are refused, not averaged over that part as if it were the band.  WCE
 * has no such check (it sums the data's own intervals inside the band, and holds the end values
 * constant beyond the data on other grids), and WINDOW's standards files define a band by its ends
 * alone (W5_NFRC_2003.std: Solar 0.3..2.5 um), with no rule for data that stop short of them.
 *
 * Tables (a pane's data, the band spectra in the catalogue directory) are whitespace-separated
 * text with the wavelength in micrometres first; a table in nanometres fails with a clear message.
 * Stacks that combine per wavelength (spectral.c) take each band's own integration grid and
 * weights from here (bst_glass_channel_grid, bst_glass_channel_weights). */
#include <config.h>

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "ctx.h"
#include "glass.h"

/* Slack on the band limits when an integration interval counts (WCE's choice, um), and when data
 * reach a band's end (rounding: an Optics file's nanometres converted, say). */
#define BAND_SLACK 1e-6
/* Spectral data: a row's T + R may exceed 1 by this much (rounding in published tables). */
#define DATA_SUM_TOL 1e-6
/* Plausible wavelengths in micrometres (a table in nanometres fails with a clear message). */
#define WL_MIN_UM 0.1
#define WL_MAX_UM 100.0

/* ------------------------------------------------------------------ tables */

int bsti_glass_read_line(FILE *fp, char *buf, size_t len)
{
    size_t n = 0;
    int c = EOF, nul = 0;
    while (n + 1 < len && (c = getc(fp)) != EOF) {
        nul |= c == '\0';
        buf[n++] = (char)c;
        if (c == '\n')
            break;
    }
    buf[n] = '\0';
    if (n == 0)
        return 0;
    if (n + 1 == len && buf[n - 1] != '\n') {
        int d = getc(fp); /* a full buffer: the line goes on unless the file ends here */
        if (d != EOF) {
            ungetc(d, fp);
            return -1;
        }
    }
    return nul ? -2 : 1;
}

int bsti_glass_line_error(bst_ctx *ctx, const char *path, int lineno, int got, size_t len)
{
    if (got == -1)
        return bsti_error(ctx, BST_EFORMAT, "%s: line %d is longer than %zu characters", path,
                          lineno, len - 2);
    return bsti_error(ctx, BST_EFORMAT, "%s: line %d holds a NUL byte", path, lineno);
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
    int lineno = 0, rc = BST_OK, header = 0, got;
    while (rc >= 0 && (got = bsti_glass_read_line(fp, line, sizeof line)) != 0) {
        lineno++;
        if (got < 0) {
            rc = bsti_glass_line_error(ctx, path, lineno, got, sizeof line);
            break;
        }
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

static int read_spectrum(bst_ctx *ctx, const char *dir, const char *file, int ncol,
                         struct bsti_glass_spectrum *t)
{
    char path[1200];
    if ((size_t)snprintf(path, sizeof path, "%s/%s", dir, file) >= sizeof path)
        return bsti_error(ctx, BST_EINVAL, "%s/%s: path longer than %zu characters", dir, file,
                          sizeof path - 1);
    double *cols[2];
    int rc = read_table(ctx, path, ncol, 0, cols, &t->n);
    if (rc >= 0)
        t->x = cols[0], t->y = ncol > 1 ? cols[1] : NULL;
    return rc;
}

/* bsdfstack's own table of a pane's data: wavelength (um), Tf, Tb, Rf, Rb. */
static int read_pane_table(bst_ctx *ctx, bst_glass *g, const char *path)
{
    double *cols[5];
    int rc = read_table(ctx, path, 5, 1, cols, &g->data.n);
    if (rc < 0)
        return rc;
    struct bsti_glass_data *d = &g->data;
    d->wl = cols[0], d->tf = cols[1], d->tb = cols[2], d->rf = cols[3], d->rb = cols[4];
    for (size_t k = 0; k < d->n; k++) {
        struct bsti_glass_side s;
        if (d->tf[k] + d->rf[k] > 1.0 + DATA_SUM_TOL || d->tb[k] + d->rb[k] > 1.0 + DATA_SUM_TOL)
            return bsti_error(ctx, BST_EFORMAT, "%s: at %g um T + R exceeds 1 (Tf %g Rf %g, Tb %g "
                              "Rb %g)", path, d->wl[k], d->tf[k], d->rf[k], d->tb[k], d->rb[k]);
        if (bsti_glass_side_init(&s, d->tf[k], d->rf[k]) ||
            bsti_glass_side_init(&s, d->tb[k], d->rb[k]))
            return bsti_error(ctx, BST_EFORMAT, "%s: at %g um no uncoated pane has these T and R",
                              path, d->wl[k]);
    }
    if ((rc = bsti_glass_meta_set(g, &g->meta.source, "table")) < 0)
        return rc;
    return bsti_glass_meta_set(g, &g->meta.path, path);
}

int bsti_glass_row_check(bst_ctx *ctx, const char *where, double prev_um, double um,
                         const double v[4])
{
    static const char *const name[4] = {"Tf", "Tb", "Rf", "Rb"};
    if (!(um >= WL_MIN_UM && um <= WL_MAX_UM))
        return bsti_error(ctx, BST_EFORMAT, "%s: wavelength %g um is not in %g..%g um (the file's "
                          "wavelength unit?)", where, um, WL_MIN_UM, WL_MAX_UM);
    if (!(um > prev_um))
        return bsti_error(ctx, BST_EFORMAT, "%s: wavelengths must increase (%g um after %g um)",
                          where, um, prev_um);
    for (int i = 0; i < 4; i++)
        if (!(v[i] >= 0.0 && v[i] <= 1.0))
            return bsti_error(ctx, BST_EFORMAT, "%s: %s = %g is not a value in [0, 1]", where,
                              name[i], v[i]);
    if (v[0] + v[2] > 1.0 + DATA_SUM_TOL || v[1] + v[3] > 1.0 + DATA_SUM_TOL)
        return bsti_error(ctx, BST_EFORMAT, "%s: T + R exceeds 1 (Tf %g Rf %g, Tb %g Rb %g)",
                          where, v[0], v[2], v[1], v[3]);
    if (v[2] >= 1.0 || v[3] >= 1.0)
        return bsti_error(ctx, BST_EFORMAT, "%s: R = 1: a perfect mirror is no pane", where);
    return BST_OK;
}

int bsti_glass_data_reserve(bst_ctx *ctx, struct bsti_glass_data *d, size_t *cap, size_t need)
{
    if (need <= *cap)
        return BST_OK;
    size_t nc = *cap ? *cap : 128;
    while (nc < need)
        nc *= 2;
    double **col[5] = {&d->wl, &d->tf, &d->tb, &d->rf, &d->rb};
    for (int c = 0; c < 5; c++) {
        double *q = bsti_alloc_array(ctx, nc, sizeof *q);
        if (!q)
            return BST_ENOMEM; /* the columns grown so far are d's, freed with it */
        if (*col[c])
            memcpy(q, *col[c], d->n * sizeof *q);
        bsti_free(ctx, *col[c]);
        *col[c] = q;
    }
    *cap = nc;
    return BST_OK;
}

/* The pane's measured data, in whichever format the file is, and the spectra of the bands, which
 * live in the catalogue directory. */
int bsti_glass_load_spectral(bst_ctx *ctx, bst_glass *g, const char *path, const char *dir)
{
    enum bsti_glass_format fmt;
    int rc = bsti_glass_sniff(ctx, path, &fmt);
    if (rc < 0)
        return rc;
    switch (fmt) {
    case BSTI_GLASS_OPTICS: rc = bsti_glass_read_optics(ctx, g, path); break;
    case BSTI_GLASS_IGSDB: rc = bsti_glass_read_igsdb(ctx, g, path); break;
    default: rc = read_pane_table(ctx, g, path); break;
    }
    if (rc < 0)
        return rc;
    if ((rc = read_spectrum(ctx, dir, "solar_ASTM_E891_87_Table1.tsv", 2, &g->solar)) < 0 ||
        (rc = read_spectrum(ctx, dir, "photopic_source_D65.tsv", 2, &g->d65)) < 0 ||
        (rc = read_spectrum(ctx, dir, "photopic_detector_V.tsv", 2, &g->v)) < 0 ||
        (rc = read_spectrum(ctx, dir, "photopic_wavelength_set.tsv", 1, &g->photopic)) < 0)
        return rc;
    return BST_OK;
}

/* ------------------------------------------------------------------ bands */

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
static const struct bsti_glass_band {
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

const struct bsti_glass_band *bsti_glass_find_band(const char *name)
{
    for (size_t i = 0; i < NBANDS; i++)
        if (strcasecmp(bands[i].name, name) == 0)
            return &bands[i];
    return NULL;
}

/* Source x detector of a band at wavelength um. */
static double band_sd(const bst_glass *g, const struct bsti_glass_band *b, double um)
{
    if (b->solar)
        return bsti_glass_interp(g->solar.x, g->solar.y, g->solar.n, um);
    double s = bsti_glass_interp(g->d65.x, g->d65.y, g->d65.n, um);
    switch (b->det) {
    case DET_V: return s * bsti_glass_interp(g->v.x, g->v.y, g->v.n, um);
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

/* The grid a band averages data d on: the data's own wavelengths for Solar (WCE's single-layer
 * averages), the photopic grid for the others. */
static void own_grid(const bst_glass *g, const struct bsti_glass_data *d,
                     const struct bsti_glass_band *b, const double **own, size_t *m)
{
    *own = b->solar ? d->wl : g->photopic.x;
    *m = b->solar ? d->n : g->photopic.n;
}

/* Whether data d reach both ends of band b (to BAND_SLACK); one line naming where, the data's
 * range and the band's when they do not.  A band value from part of the band would pass for the
 * whole band's: beyond the data, P would be their end values held constant (the photopic grid) or
 * left out of the average (Solar, on the data's own wavelengths). */
static int band_covered(bst_ctx *ctx, const struct bsti_glass_data *d, const char *where,
                        const struct bsti_glass_band *b)
{
    if (d->wl[0] > b->lo + BAND_SLACK || d->wl[d->n - 1] < b->hi - BAND_SLACK)
        return bsti_error(ctx, BST_EFORMAT, "%s: the data cover %g..%g um; the %s band needs "
                          "%g..%g um", where, d->wl[0], d->wl[d->n - 1], b->name, b->lo, b->hi);
    return BST_OK;
}

/* The weights w[0..m-1] of band b on that grid (own_grid): the band's average of P is
 * sum_k w[k] P(own[k]), P the data interpolated linearly; one line naming where when the data do
 * not cover the band (band_covered). */
static int own_weights(bst_ctx *ctx, const bst_glass *g, const struct bsti_glass_data *d,
                       const char *where, const struct bsti_glass_band *b, double *w)
{
    const double *own;
    size_t m;
    own_grid(g, d, b, &own, &m);
    int rc = band_covered(ctx, d, where, b);
    if (rc < 0)
        return rc;
    double *sd = bsti_alloc_array(ctx, m, sizeof *sd);
    if (!sd)
        return BST_ENOMEM;
    for (size_t k = 0; k < m; k++)
        sd[k] = band_sd(g, b, own[k]);
    rc = trapezoid(own, sd, m, b->lo, b->hi, w);
    bsti_free(ctx, sd);
    if (rc < 0)
        return bsti_error(ctx, BST_EFORMAT, "%s: no interval of the data's wavelengths lies in "
                          "%s's range %g..%g um", where, b->name, b->lo, b->hi);
    return BST_OK;
}

/* Fills channel g->nch with a spectral band of a spectral pane (bsti_glass_add_band commits or
 * clears it). */
static int fill_band(bst_ctx *ctx, bst_glass *g, const char *where,
                     const struct bsti_glass_band *b)
{
    const struct bsti_glass_data *d = &g->data;
    /* the single pane's own grid (WCE's single-layer averages) and the integration grid of
     * per-wavelength stacks (WCE's multi-layer averages) */
    const double *own;
    size_t m;
    own_grid(g, d, b, &own, &m);
    const double *ig = b->solar ? g->solar.x : g->photopic.x;
    size_t mg = b->solar ? g->solar.n : g->photopic.n;
    int rc = band_covered(ctx, d, where, b); /* before the channel is made */
    if (rc < 0)
        return rc;
    rc = bsti_glass_channel_new(ctx, g, where, b->name, m);
    if (rc < 0)
        return rc;
    struct bsti_glass_channel *c = &g->ch[g->nch];
    if (!(c->grid = bsti_alloc_array(ctx, mg, sizeof *c->grid)) ||
        !(c->sd = bsti_alloc_array(ctx, mg, sizeof *c->sd)))
        return BST_ENOMEM;
    if ((rc = own_weights(ctx, g, d, where, b, c->w)) < 0)
        return rc;
    for (size_t k = 0; k < m; k++) {
        double tf, tb, rf, rb;
        bsti_glass_data_at(d, own[k], &tf, &tb, &rf, &rb);
        if (bsti_glass_side_model(&c->front[k], tf, rf, g->model) ||
            bsti_glass_side_model(&c->back[k], tb, rb, g->model))
            return bsti_error(ctx, BST_EFORMAT, "%s: at %g um no uncoated pane has T0 = %g and "
                              "R0 = %g", where, own[k], tf, rf);
    }
    c->ng = mg, c->lo = b->lo, c->hi = b->hi;
    for (size_t k = 0; k < mg; k++)
        c->grid[k] = ig[k], c->sd[k] = band_sd(g, b, ig[k]);
    return BST_OK;
}

int bsti_glass_band_average(bst_ctx *ctx, const struct bsti_glass_data *d, const char *dir,
                            const char *band, const char *where, double v[4])
{
    const struct bsti_glass_band *b = bsti_glass_find_band(band);
    if (!b || !d->n)
        return bsti_error(ctx, BST_EINVAL, "%s: no spectral band %s, or no data", where, band);
    bst_glass *g = bsti_glass_new(ctx);
    if (!g)
        return BST_ENOMEM;
    int rc;
    if ((rc = read_spectrum(ctx, dir, "solar_ASTM_E891_87_Table1.tsv", 2, &g->solar)) >= 0 &&
        (rc = read_spectrum(ctx, dir, "photopic_source_D65.tsv", 2, &g->d65)) >= 0 &&
        (rc = read_spectrum(ctx, dir, "photopic_detector_V.tsv", 2, &g->v)) >= 0)
        rc = read_spectrum(ctx, dir, "photopic_wavelength_set.tsv", 1, &g->photopic);
    const double *own = NULL;
    size_t m = 0;
    double *w = NULL;
    if (rc >= 0) {
        own_grid(g, d, b, &own, &m);
        rc = (w = bsti_alloc_array(ctx, m, sizeof *w)) ? own_weights(ctx, g, d, where, b, w) : BST_ENOMEM;
    }
    for (int i = 0; i < 4; i++)
        v[i] = 0.0;
    for (size_t k = 0; rc >= 0 && k < m; k++) {
        double x[4];
        bsti_glass_data_at(d, own[k], &x[0], &x[1], &x[2], &x[3]);
        for (int i = 0; i < 4; i++)
            v[i] += w[k] * x[i];
    }
    bsti_free(ctx, w);
    bst_glass_free(g);
    return rc;
}

int bsti_glass_add_band(bst_ctx *ctx, bst_glass *g, const char *where,
                        const struct bsti_glass_band *b)
{
    /* checked here too: bsti_glass_channel_commit indexes g->ch[g->nch] */
    if (g->nch >= BSTI_GLASS_MAX_CH)
        return bsti_error(ctx, BST_EINVAL, "%s: more than %d channels", where, BSTI_GLASS_MAX_CH);
    return bsti_glass_channel_commit(ctx, g, fill_band(ctx, g, where, b));
}

int bst_glass_add_channel(bst_ctx *ctx, bst_glass *g, const char *name)
{
    if (!ctx || !g || !name)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass: NULL argument") : BST_EINVAL;
    if (bst_glass_find_channel(g, name) >= 0)
        return BST_OK;
    const struct bsti_glass_band *b = bsti_glass_find_band(name);
    if (!b)
        return bsti_error(ctx, BST_ENOTFOUND,
                          "%s: no channel %s (spectral bands: " BSTI_GLASS_BAND_LIST ")", g->where,
                          name);
    if (!g->data.n)
        return bsti_error(ctx, BST_ENOTFOUND, "%s: no channel %s (only a pane with spectral data "
                          "can be averaged over a new band)", g->where, name);
    return bsti_glass_add_band(ctx, g, g->where, b);
}

/* ------------------------------------------------------------------ integration grids */

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
    const struct bsti_glass_channel *c = &g->ch[ch];
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

