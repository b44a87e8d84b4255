/* glass.c - analytic clear glass: the angular transmittance and reflectance of an uncoated pane, from
 * its normal-incidence values, by Windows-CalcEngine's model for uncoated glass
 * (../shared/reference/wce/README.md, "How WCE gets the angular properties of uncoated (clear)
 * glass"), and the pane object that holds one such model per side and channel.  Spectral bands are
 * in glass_band.c, specifications and the catalogue in glass_spec.c, layers in glass_layer.c.
 *
 * The model, per side and per wavelength (or band), from T0 and R0 at normal incidence:
 *   rho0 = smaller root of (2 - R0) rho^2 - (T0^2 - R0^2 + 2 R0 + 1) rho + R0 = 0  (one interface)
 *   n    = (1 + sqrt(rho0)) / (1 - sqrt(rho0))             (inverse of Fresnel at normal incidence)
 *   tau0 = (R0 - rho0) / (T0 rho0)                          (single-pass internal transmittance)
 *   at theta: sin(theta) = n sin(theta'), tau = tau0^(1 / cos(theta'))  (path length 1/cos(theta'))
 *   r_s = ((cos(theta) - n cos(theta')) / (cos(theta) + n cos(theta')))^2,
 *   r_p = ((n cos(theta) - cos(theta')) / (n cos(theta) + cos(theta')))^2,
 *   T_x = tau (1 - r_x)^2 / (1 - tau^2 r_x^2),  R_x = r_x (1 + tau T_x),  T, R = means over s, p.
 * Both steps are evaluated in forms without cancellation (bsti_glass_side_init, _optics), which
 * stay accurate down to near-mirrors (T0 = 1e-10, R0 = 1 - 1e-10) where the textbook ones keep no
 * digit.  This is the incoherent slab with two identical interfaces and bulk absorption.
 * Thickness and wavelength enter only through T0 and R0 (an inline pane given by its extinction
 * coefficient K and thickness d has tau0 = exp(-K d)).  Special cases as WCE: theta = 0 gives the
 * measured values, T0 = 0 a bare interface with rho0 = R0 (T = 0), T0 = 1 no angular dependence,
 * theta = 90 deg T = 0 and R = 1; where rounding makes T + R > 1 the larger gives way.  One case
 * differs from WCE on purpose: WCE takes rho0 = 0 (R0 = 0) as angle-independent, which made the
 * model jump at R0 = 0 (R0 = 1e-300 gave T = T0^(1/cos theta), R0 = 0 gave T0 at every angle);
 * here R0 = 0 is the limit R0 -> 0+, n = 1 and tau0 = T0, continuous (an absorbing pane without
 * reflection still has a path that grows as 1 / cos theta).  No measured glass has R0 = 0.
 *
 * A side marked coated follows WINDOW's correlations for coated glass instead (glass_coated.c),
 * with the same special case at theta = 0; the slab values are still derived, and unused.
 *
 * A channel is a weighted sum of the model over nodes (struct bsti_glass_channel in glass.h): one
 * node for a band given by its normal-incidence values, the wavelengths of a band's grid with their
 * weights for a spectral pane (glass_band.c).  Angles in radians, wavelengths in micrometres. */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "ctx.h"
#include "glass.h"

/* ------------------------------------------------------------------ the slab model */

/* Written in u = 1 - R0 (exact for R0 >= 1/2) and d = T0^2 - u^2 = (T0 - u)(T0 + u), the
 * quadratic has b = 2 + d and 4 a c = 4 (1 - u^2), so its discriminant is the sum of squares
 * S^2 = 4 T0^2 + d^2 and nothing is subtracted:
 *   rho0     = 2 R0 / (2 + d + S)
 *   1 - rho0 = (T0^2 + u (2 - u) + S) / (2 + d + S)          (n = (1 + sqrt rho0)^2 / (1 - rho0))
 *   tau0     = (S + d) / (2 T0) = 2 T0 / (S - d)             (R0 - rho0 = R0 (S + d) / (2 + d + S))
 *   1 - tau0 = -d (1 - d / (S + 2 T0)) / (S - d)             (S - 2 T0 = d^2 / (S + 2 T0))
 * with d <= 0 for every pane that absorbs (T0 + R0 <= 1); d > 0 only through rounding, tau0 = 1.
 * A near-mirror's T at an angle hangs on 1 - tau0 and 1 - rho0, both of the order of T0: the
 * old forms (b^2 - 4 a c, R0 - rho0, 1 - sqrt(rho0)) lost all their digits at T0 = 1e-8. */
int bsti_glass_side_init(struct bsti_glass_side *s, double t0, double r0)
{
    if (!(t0 >= 0.0 && r0 >= 0.0 && r0 < 1.0 && t0 <= 1.0))
        return -1;
    s->t0 = t0, s->r0 = r0, s->coated = 0;
    double u = 1.0 - r0, d = (t0 - u) * (t0 + u), S = hypot(2.0 * t0, d), den = 2.0 + d + S;
    double omr, omt; /* 1 - rho0, 1 - tau0 */
    if (t0 == 0.0) { /* opaque: a bare interface of reflectance R0 */
        s->rho0 = r0, omr = u;
        s->tau0 = 0.0, omt = 1.0;
    } else {
        s->rho0 = 2.0 * r0 / den;
        omr = (t0 * t0 + u * (2.0 - u) + S) / den;
        if (d >= 0.0) /* a non-absorbing pane, or above 1 through rounding */
            s->tau0 = 1.0, omt = 0.0;
        else
            s->tau0 = 2.0 * t0 / (S - d), omt = -d * (1.0 - d / (S + 2.0 * t0)) / (S - d);
    }
    /* R0 = 0 (rho0 = 0) needs no case of its own: the formulas give n = 1 and tau0 = T0, the
     * limit of R0 -> 0+, so T = T0^(1 / cos theta) follows the longer path and R = 0 */
    double sr = sqrt(s->rho0);
    s->n = (1.0 + sr) * (1.0 + sr) / omr;
    if (s->tau0 == 0.0)
        s->ltau0 = -INFINITY;
    else /* whichever of tau0 and 1 - tau0 is the smaller holds the digits */
        s->ltau0 = omt < 0.5 ? log1p(-omt) : log(s->tau0);
    return 0;
}

/* bsti_glass_side_optics with ci = cos(theta) and si = sin(theta) given: a spectral channel sums
 * the model over its wavelengths at one theta, and takes these once (bst_glass_optics). */
static void side_optics_cs(const struct bsti_glass_side *s, double theta, double ci, double si,
                           double *t, double *r)
{
    if (theta <= 0.0) {
        *t = s->t0, *r = s->r0;
        return;
    }
    if (s->coated) {
        bsti_glass_coated_optics(s->t0, s->r0, theta >= M_PI / 2 || ci <= 0.0 ? 0.0 : ci, t, r);
        return;
    }
    if (theta >= M_PI / 2 || ci <= 0.0) {
        *t = 0.0, *r = 1.0;
        return;
    }
    if (s->t0 == 1.0) { /* nothing absorbed or reflected: no angular dependence */
        *t = s->t0, *r = s->r0;
        return;
    }
    double n = s->n, st = si / n, ct = sqrt((1.0 - st) * (1.0 + st));
    /* tau = tau0^(1 / cos t) and 1 - tau from log(tau0): a near-mirror's 1 - tau is ~T0.  One
     * exponential, not two (it was half of a spectral layer's time): below tau = 1/2, exp gives
     * tau and 1 - tau loses nothing; above, expm1 gives 1 - tau and 1 + expm1 loses nothing.
     * Both agree with exp and expm1 taken apart to a few ulp (test_glass_speed). */
    double e = s->ltau0 / ct, tau, omt;
    if (e < -M_LN2) {
        tau = exp(e), omt = 1.0 - tau;
    } else {
        double m = expm1(e);
        tau = 1.0 + m, omt = -m;
    }
    /* Fresnel r = ((a - b) / (a + b))^2, (a, b) = (cos i, n cos t) for s, (n cos i, cos t) for p.
     * Its complement 1 - r = 4 a b / (a + b)^2 and 1 - tau r = (1 - tau) + tau (1 - r) are formed
     * without cancellation: towards 90 degrees r -> 1 and the textbook form 1 - tau^2 r^2 of a
     * non-absorbing pane would lose every digit (0 / 0 at the last representable angle), and so
     * would a near-mirror's (n up to 1e10 and more) at every angle.  The quotients are taken
     * before the product so that (a + b)^2 cannot overflow. */
    const double a[2] = {ci, n * ci}, b[2] = {n * ct, ct};
    double tt = 0.0, rr = 0.0;
    for (int x = 0; x < 2; x++) {
        double sum = a[x] + b[x], q = (a[x] - b[x]) / sum;
        double rx = q * q, cx = 4.0 * (a[x] / sum) * (b[x] / sum);
        double tx = 0.0, rrx = rx;
        if (tau > 0.0 && cx > 0.0) {
            tx = tau * cx * cx / ((omt + tau * cx) * (1.0 + tau * rx));
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

void bsti_glass_side_optics(const struct bsti_glass_side *s, double theta, double *t, double *r)
{
    side_optics_cs(s, theta, cos(theta), sin(theta), t, r);
}

/* ------------------------------------------------------------------ the pane object */

/* What an unset metadata string points to (never freed). */
static const char meta_none[] = "";

bst_glass *bsti_glass_new(bst_ctx *ctx)
{
    bst_glass *g = bsti_calloc(ctx, 1, sizeof *g);
    if (!g)
        return NULL;
    g->ctx = ctx;
    bst_glass_meta *m = &g->meta;
    m->source = m->path = m->type = m->product_name = m->manufacturer = meta_none;
    m->coating_name = m->coated_side = m->wavelength_units = meta_none;
    m->model_from = "default"; /* always one of the literals of bst_glass_meta, never freed */
    m->nfrc_id = -1;
    m->thickness_mm = m->conductivity = m->emissivity_front = m->emissivity_back = NAN;
    m->ir_transmittance = NAN;
    g->layer_rows = BST_GLASS_LAYER_ROWS;
    return g;
}

int bsti_glass_meta_set(bst_glass *g, const char **field, const char *text)
{
    char *copy = bsti_strdup(g->ctx, text ? text : "");
    if (!copy)
        return BST_ENOMEM;
    if (*field && *field != meta_none)
        bsti_free(g->ctx, (char *)*field);
    *field = copy;
    return BST_OK;
}

const bst_glass_meta *bst_glass_metadata(const bst_glass *g)
{
    return g ? &g->meta : NULL;
}

static void spectrum_free(bst_ctx *ctx, struct bsti_glass_spectrum *t)
{
    bsti_free(ctx, t->x), bsti_free(ctx, t->y);
    t->x = t->y = NULL, t->n = 0;
}

static void channel_clear(bst_ctx *ctx, struct bsti_glass_channel *c)
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
    for (size_t i = 0; i < BSTI_GLASS_MAX_CH; i++)
        channel_clear(ctx, &g->ch[i]);
    bsti_free(ctx, g->description), bsti_free(ctx, g->where);
    const char **meta[] = {&g->meta.source,       &g->meta.path,         &g->meta.type,
                           &g->meta.product_name, &g->meta.manufacturer, &g->meta.coating_name,
                           &g->meta.coated_side,  &g->meta.wavelength_units};
    for (size_t i = 0; i < sizeof meta / sizeof meta[0]; i++)
        if (*meta[i] && *meta[i] != meta_none)
            bsti_free(ctx, (char *)*meta[i]);
    bsti_free(ctx, g->data.wl), bsti_free(ctx, g->data.tf), bsti_free(ctx, g->data.tb);
    bsti_free(ctx, g->data.rf), bsti_free(ctx, g->data.rb);
    spectrum_free(ctx, &g->solar), spectrum_free(ctx, &g->d65), spectrum_free(ctx, &g->v);
    spectrum_free(ctx, &g->photopic);
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

void bsti_glass_channel_optics(const struct bsti_glass_channel *c, double theta, double v[4])
{
    double st = 0, stb = 0, sf = 0, sb = 0, ci = cos(theta), si = sin(theta);
    for (size_t k = 0; k < c->nk; k++) {
        double t1, r1, t2, r2;
        if (c->w[k] == 0.0) /* outside the band (a spectral pane's rows beyond 2.5 um): adds 0 */
            continue;
        side_optics_cs(&c->front[k], theta, ci, si, &t1, &r1);
        side_optics_cs(&c->back[k], theta, ci, si, &t2, &r2);
        st += c->w[k] * t1, sf += c->w[k] * r1, stb += c->w[k] * t2, sb += c->w[k] * r2;
    }
    /* the weights sum to 1 up to rounding: keep T + R <= 1 as every node does */
    if (st + sf > 1.0)
        sf = 1.0 - st;
    if (stb + sb > 1.0)
        sb = 1.0 - stb;
    v[0] = st, v[1] = stb, v[2] = sf, v[3] = sb;
}

int bst_glass_optics(const bst_glass *g, size_t ch, double theta, double *tf, double *tb,
                     double *rf, double *rb)
{
    if (!g || ch >= g->nch || !(theta >= 0.0 && theta <= M_PI / 2 + 1e-12))
        return BST_EINVAL;
    double v[4];
    bsti_glass_channel_optics(&g->ch[ch], theta, v);
    if (tf)
        *tf = v[0];
    if (tb)
        *tb = v[1];
    if (rf)
        *rf = v[2];
    if (rb)
        *rb = v[3];
    return BST_OK;
}

int bst_glass_set_layer_rows(bst_ctx *ctx, bst_glass *g, size_t max)
{
    if (!ctx || !g)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass: NULL argument") : BST_EINVAL;
    if (max == 1)
        return bsti_error(ctx, BST_EINVAL, "%s: layer rows 1 (0 = all, else at least 2)", g->where);
    g->layer_rows = max;
    return BST_OK;
}

int bsti_glass_channel_new(bst_ctx *ctx, bst_glass *g, const char *where, const char *name,
                           size_t nk)
{
    if (g->nch >= BSTI_GLASS_MAX_CH)
        return bsti_error(ctx, BST_EINVAL, "%s: more than %d channels", where, BSTI_GLASS_MAX_CH);
    if (bst_glass_find_channel(g, name) >= 0)
        return bsti_error(ctx, BST_EINVAL, "%s: channel %s given twice", where, name);
    struct bsti_glass_channel *c = &g->ch[g->nch];
    c->nk = nk;
    if (!(c->name = bsti_strdup(ctx, name)) || !(c->w = bsti_calloc(ctx, nk, sizeof *c->w)) ||
        !(c->front = bsti_calloc(ctx, nk, sizeof *c->front)) ||
        !(c->back = bsti_calloc(ctx, nk, sizeof *c->back)))
        return BST_ENOMEM; /* the partial channel is freed with g */
    return BST_OK;
}

int bsti_glass_channel_commit(bst_ctx *ctx, bst_glass *g, int rc)
{
    if (rc < 0)
        channel_clear(ctx, &g->ch[g->nch]);
    else
        g->nch++;
    return rc;
}

/* ------------------------------------------------------------------ spectral evaluation */

double bsti_glass_interp(const double *x, const double *y, size_t n, double xq)
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

void bsti_glass_data_at(const struct bsti_glass_data *d, double um, double *tf, double *tb,
                        double *rf, double *rb)
{
    *tf = bsti_glass_interp(d->wl, d->tf, d->n, um);
    *tb = bsti_glass_interp(d->wl, d->tb, d->n, um);
    *rf = bsti_glass_interp(d->wl, d->rf, d->n, um);
    *rb = bsti_glass_interp(d->wl, d->rb, d->n, um);
}

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
    struct bsti_glass_side f, b;
    bsti_glass_data_at(&g->data, lambda, &t0f, &t0b, &r0f, &r0b);
    if (bsti_glass_side_model(&f, t0f, r0f, g->model) ||
        bsti_glass_side_model(&b, t0b, r0b, g->model))
        return BST_EINVAL;
    bsti_glass_side_optics(&f, theta, &t, &r);
    if (tf)
        *tf = t;
    if (rf)
        *rf = r;
    bsti_glass_side_optics(&b, theta, &t, &r);
    if (tb)
        *tb = t;
    if (rb)
        *rb = r;
    return BST_OK;
}

int bst_glass_slab(const bst_glass *g, size_t ch, double lambda, int back, double *n, double *tau0)
{
    if (!g || ch >= g->nch || g->model != BST_GLASS_UNCOATED) /* a coated side is no slab */
        return BST_EINVAL;
    struct bsti_glass_side s;
    if (g->data.n) {
        double tf, tb, rf, rb;
        if (!isfinite(lambda))
            return BST_EINVAL;
        bsti_glass_data_at(&g->data, lambda, &tf, &tb, &rf, &rb);
        if (bsti_glass_side_init(&s, back ? tb : tf, back ? rb : rf))
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
