/* sheet_wce.c - WINDOW's models of perforated screens and woven fabrics (rule=centre;
 * bsdfstack.h below bst_perforated and bst_woven), written from the description of
 * Windows-CalcEngine v1.0.75 (its circular, rectangular and woven cell descriptions, its uniform
 * diffuse cell and BSDF layer), so that users can match WINDOW's numbers.
 *
 * WCE takes each patch at its centre direction (theta, phi) alone and builds, per side,
 *   T(o, i) = F_i delta_oi / Lambda_i + D_T(i) / pi,   R(o, i) = D_R(i) / pi,
 * F_i the cell's direct-direct transmittance at the centre, D_T = (1 - F_i) t and D_R = (1 - F_i) r
 * for a screen (r the reflectance of the side the light meets); a woven cell moves its empirical
 * scattering through the threads S from D_R to D_T, S computed with the reflectance of the other
 * side.  A ring of one patch has its centre at azimuth 180 in WCE and 0 here
 * (bst_basis_center): every share below is even in the direction's x and y, so they agree.
 * Dual-band values: the Solar channel weighs the layers of the visible values and of the values
 * outside the visible range f : 1 - f (bsti_sheet_wce_layer). */
#include <config.h>

#include <math.h>
#include <string.h>
#include <strings.h>

#include "ctx.h"
#include "venetian.h"

/* theta (from the normal) and phi of a unit direction of either hemisphere. */
static void angles(const double d[3], double *theta, double *phi)
{
    *theta = acos(fmin(1.0, fabs(d[2])));
    *phi = atan2(d[1], d[0]);
}

double bsti_perforated_wce_open(const bst_perforated *p, const double d[3])
{
    double th, ph;
    angles(d, &th, &ph);
    if (isnan(p->radius)) { /* rectangles: per axis, (hole - thickness |tan|)+ / pitch */
        double tx = fabs(cos(ph) * tan(th)), ty = fabs(sin(ph) * tan(th));
        double ox = p->thickness > 0 ? p->hole_x - p->thickness * tx : p->hole_x;
        double oy = p->thickness > 0 ? p->hole_y - p->thickness * ty : p->hole_y;
        return fmax(0.0, ox / p->x) * fmax(0.0, oy / p->y);
    }
    /* circles: WCE's visible hole, half the circle at full size and half shrunk by the
     * thickness' shadow, over the visible cell (both projected: cos theta cancels) */
    double a = p->radius;
    if (p->thickness > 0 && th > atan(2.0 * a / p->thickness))
        return 0.0;
    double hole = M_PI / 2 * a * a * cos(th) +
                  M_PI / 2 * (a * a * cos(th) - a * p->thickness * sin(th));
    return hole / (p->x * p->y * cos(th));
}

/* WCE's altitude (from the XZ plane) and azimuth (in it) of a direction, radians. */
static void alt_az(const double d[3], double *alt, double *az)
{
    double th, ph;
    angles(d, &th, &ph);
    *alt = asin(sin(th) * -sin(ph));
    *az = 0.0;
    if (fabs(th) - fabs(*alt) > 1e-8)
        *az = acos(fmin(1.0, cos(th) / cos(*alt)));
}

double bsti_woven_wce_open(const bst_woven *w, const double d[3])
{
    double g = w->diameter / w->spacing, cut = acos(g), alt, az;
    alt_az(d, &alt, &az);
    double b = fabs(atan(tan(alt) / cos(alt)));
    double tx = az < cut ? 1.0 - g / cos(az) : 0.0, ty = b < cut ? 1.0 - g / cos(b) : 0.0;
    return tx * ty;
}

double bsti_woven_wce_scatter(const bst_woven *w, const double d[3], double r)
{
    double g = w->diameter / w->spacing;
    if (r <= 0.0 || g >= 1.0)
        return 0.0;
    double alt, az;
    alt_az(d, &alt, &az);
    alt *= 180.0 / M_PI, az *= 180.0 / M_PI;
    double smax = 0.0229 * g + 0.2971 * r - 0.03624 * g * g + 0.04763 * r * r - 0.44416 * g * r;
    double dmax = 89.7 - 10.0 * g / 0.16, delta = sqrt(alt * alt + az * az);
    double peak = 1.0 / (0.2 * r * (1.0 - g)), base = 0.2 * r * smax * (1.0 - g), e, s = 0.0;
    if (delta > dmax) {
        e = -pow(fabs(delta - dmax), 2.5) / 600.0;
        s = -base * fmax(0.0, (delta - dmax) / (90.0 - dmax));
    } else {
        e = -pow(fabs(delta - dmax), 2.0) / 600.0;
    }
    s += base * (1.0 + (peak - 1.0) * exp(e));
    return fmax(0.0, s);
}

/* WINDOW's value of a visible one outside the visible range (the dual-band rule), given the
 * solar one (NaN: as visible). */
static double outside(double vis, double sol)
{
    if (isnan(sol))
        return vis;
    return fmax(0.0, (sol - BST_DUAL_BAND_F * vis) / (1.0 - BST_DUAL_BAND_F));
}

/* The scattered parts of patch i at values x (rf, rb, t), added with weight wt into
 * dd[0..3][i] (D_T front, D_R front, D_T back, D_R back). */
static void scattered(const bst_woven *w, const double *d, double F, const double x[3], double wt,
                      double *const dd[4], size_t i)
{
    double sf = w ? bsti_woven_wce_scatter(w, d, x[1]) : 0.0; /* front: the back's r */
    double sb = w ? bsti_woven_wce_scatter(w, d, x[0]) : 0.0;
    dd[0][i] += wt * ((1.0 - F) * x[2] + sf);
    dd[1][i] += wt * ((1.0 - F) * x[0] - sf);
    dd[2][i] += wt * ((1.0 - F) * x[2] + sb);
    dd[3][i] += wt * ((1.0 - F) * x[1] - sb);
}

/* One channel's four components from F and the scattered parts dd into l's channel ch: each
 * D(i) / pi spread uniformly, factored (bsti_sheet_channel) with o = 1 / pi. */
static int put_channel(bst_ctx *ctx, const bst_basis *basis, const double *F, double *const dd[4],
                       double *work, bst_layer *l, size_t ch)
{
    size_t n = bst_basis_size(basis);
    const double *lam = bst_basis_lambda(basis);
    double *o = work, *diag = work + n;
    for (size_t i = 0; i < n; i++)
        o[i] = 1.0 / M_PI, diag[i] = F[i] / lam[i];
    static const bst_comp comp[4] = {BST_TF, BST_RF, BST_TB, BST_RB};
    const double *in[BST_NCOMP] = {NULL}; /* (a channel that scatters nothing: diagonal) */
    for (int k = 0; k < 4; k++)
        for (size_t i = 0; i < n && !in[comp[k]]; i++)
            if (dd[k][i] != 0.0)
                in[comp[k]] = dd[k];
    const double *dg[BST_NCOMP] = {[BST_TF] = diag, [BST_TB] = diag};
    return bsti_sheet_channel(ctx, basis, o, in, dg, l, ch);
}

int bsti_sheet_wce_layer(bst_ctx *ctx, const bst_basis *basis, const bst_perforated *p,
                         const bst_woven *w, const double v[3], const double sol[3],
                         size_t nchannels, const char *const *channels, bst_layer **out)
{
    static const char *const dual[] = {"Visible", "Solar"};
    if (!nchannels)
        nchannels = 2, channels = dual;
    size_t n = bst_basis_size(basis);
    double *buf = bsti_alloc_array(ctx, 8 * n, sizeof *buf), *dirs = NULL;
    if (buf)
        dirs = bsti_alloc_array(ctx, 3 * n, sizeof *dirs);
    if (!dirs) {
        bsti_free(ctx, buf);
        return BST_ENOMEM;
    }
    double *F = buf, *const dd[4] = {buf + 2 * n, buf + 3 * n, buf + 4 * n, buf + 5 * n};
    for (size_t i = 0; i < n; i++) {
        bst_basis_center(basis, i, dirs + 3 * i);
        F[i] = p ? bsti_perforated_wce_open(p, dirs + 3 * i) : bsti_woven_wce_open(w, dirs + 3 * i);
    }
    int dual_band = !isnan(sol[0]) || !isnan(sol[1]) || !isnan(sol[2]);
    const double o[3] = {outside(v[0], sol[0]), outside(v[1], sol[1]), outside(v[2], sol[2])};
    bst_layer *l = NULL;
    int rc = bst_layer_new(ctx, basis, nchannels, channels, &l);
    for (size_t ch = 0; ch < nchannels && rc >= 0; ch++) {
        int solar = dual_band && strcasecmp(channels[ch], "Solar") == 0;
        memset(buf + 2 * n, 0, 4 * n * sizeof *buf);
        for (size_t i = 0; i < n; i++) {
            const double *d = dirs + 3 * i;
            scattered(w, d, F[i], v, solar ? BST_DUAL_BAND_F : 1.0, dd, i);
            if (solar)
                scattered(w, d, F[i], o, 1.0 - BST_DUAL_BAND_F, dd, i);
        }
        rc = put_channel(ctx, basis, F, dd, buf + 6 * n, l, ch);
    }
    bsti_free(ctx, buf);
    bsti_free(ctx, dirs);
    if (rc < 0) {
        bst_layer_free(l);
        return rc;
    }
    *out = l;
    return BST_OK;
}

int bsti_sheet_wce_check(bst_ctx *ctx, const char *what, int rule, int samples, const double v[3],
                         const double sol[3])
{
    if (rule != BST_VENETIAN_AVERAGE && rule != BST_VENETIAN_CENTRE)
        return bsti_error(ctx, BST_EINVAL, "%s: rule = %d is not average (%d) or centre (%d)", what,
                          rule, BST_VENETIAN_AVERAGE, BST_VENETIAN_CENTRE);
    if (rule != BST_VENETIAN_CENTRE)
        return BST_OK;
    if (samples != 0)
        return bsti_error(ctx, BST_EINVAL, "%s: samples = %d: rule=centre takes one direction "
                          "per patch (leave samples out)", what, samples);
    double o[3];
    for (int k = 0; k < 3; k++)
        o[k] = outside(v[k], sol[k]);
    if (o[0] + o[2] > 1.0 + 1e-12 || o[1] + o[2] > 1.0 + 1e-12) {
        int k = o[0] + o[2] > 1.0 + 1e-12 ? 0 : 1;
        return bsti_error(ctx, BST_EINVAL, "%s: %s + t outside the visible range = %g is above 1 "
                          "(rule=centre takes (solar - %g visible) / %g there, as WINDOW)", what,
                          k ? "rb" : "rf", o[k] + o[2], BST_DUAL_BAND_F, 1.0 - BST_DUAL_BAND_F);
    }
    return BST_OK;
}
