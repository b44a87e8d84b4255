/* glass_coated.c - the angular model WINDOW uses for coated glass, laminates and films, and the rule
 * that picks a pane's model from its material type.
 *
 * WINDOW does not model a coated pane's layers: it scales the pane's own normal-incidence values by
 * the angular behaviour of one of two measured reference glazings, a clear and a bronze one, each
 * fitted by a quartic in c = cos(theta) (LBNL Windows-CalcEngine, CAngularPropertiesCoated; the
 * facts below were read there, the code is bsdfstack's own).  Per side, per wavelength or band,
 * from T0 and R0 at normal incidence:
 *   reference  = clear if T0 > 0.645 (BST_GLASS_COATED_CLEAR_T0), else bronze
 *   tau(c)     = sum_i a_i c^i,  rho_t(c) = sum_i b_i c^i        (the reference's quartics)
 *   T(theta)   = T0 tau(c)
 *   R(theta)   = R0 (1 - rho) + rho,  rho = rho_t(c) - tau(c)  (R0 plus the share rho of 1 - R0)
 * each clipped to [0, 1], and where T + R > 1 the larger gives way (as the uncoated model does).
 * At theta = 0 the measured T0 and R0 are used as they are, as WINDOW's angular spectral sample
 * does; the quartics themselves do not pass through 1 there: tau(1) = 1.0023 and
 * rho_t(1) - tau(1) = -0.0013 for the clear glass, 1.01175 and -0.00675 for the bronze one, so T
 * just off the normal is 0.23 % (clear) or 1.2 % (bronze) above T0, as in WINDOW.  At 90 degrees
 * tau = a_0 < 0 clips T to 0; rho = b_0 - a_0 is 1.0005 for the clear glass (R clips to 1) and
 * 0.999 for the bronze one (R = 0.999 + 0.001 R0, not 1).  The model ignores thickness and
 * wavelength, and treats each side alone: a spectral pane applies it at every wavelength, so one
 * pane may use both references where its T0 crosses 0.645.
 *
 * Which model (WCE's coatingType): Monolithic and Interlayer are uncoated, every other type
 * (Coated, Film, Applied Film, Laminate, Electrochromic, Thermochromic) coated. */
#include <config.h>

#include <ctype.h>
#include <math.h>
#include <string.h>
#include <strings.h>

#include "ctx.h"
#include "glass.h"

/* The reference glazings' quartics in c = cos(theta), lowest power first: [0] clear, [1] bronze. */
static const double coated_tau[2][5] = {
    {-0.0015, 3.355, -3.84, 1.46, 0.0288},
    {-0.002, 2.813, -2.341, -0.05725, 0.599},
};
static const double coated_rho[2][5] = {
    {0.999, -0.563, 2.043, -2.532, 1.054},
    {0.997, -1.868, 6.513, -7.862, 3.225},
};

static double quartic(const double a[5], double c)
{
    return (((a[4] * c + a[3]) * c + a[2]) * c + a[1]) * c + a[0];
}

void bsti_glass_coated_poly(int bronze, double c, double *tau, double *rho)
{
    *tau = quartic(coated_tau[bronze != 0], c);
    *rho = quartic(coated_rho[bronze != 0], c);
}

static double clip01(double x)
{
    return x < 0.0 ? 0.0 : x > 1.0 ? 1.0 : x;
}

void bsti_glass_coated_optics(double t0, double r0, double c, double *t, double *r)
{
    double tau, rho_t;
    bsti_glass_coated_poly(!(t0 > BST_GLASS_COATED_CLEAR_T0), c, &tau, &rho_t);
    double rho = rho_t - tau;
    double tt = clip01(t0 * tau), rr = clip01(r0 * (1.0 - rho) + rho);
    if (tt + rr > 1.0) { /* the larger gives way */
        if (tt > rr)
            tt = 1.0 - rr;
        else
            rr = 1.0 - tt;
    }
    *t = tt, *r = rr;
}

/* ------------------------------------------------------------------ the model of a pane */

static const struct {
    const char *type; /* compared with blanks, '-' and '_' removed, case ignored */
    bst_glass_model model;
} type_models[] = {
    {"Monolithic", BST_GLASS_UNCOATED},  {"Interlayer", BST_GLASS_UNCOATED},
    {"Coated", BST_GLASS_COATED},        {"Film", BST_GLASS_COATED},
    {"AppliedFilm", BST_GLASS_COATED},   {"Laminate", BST_GLASS_COATED},
    {"Electrochromic", BST_GLASS_COATED}, {"Thermochromic", BST_GLASS_COATED},
};

int bst_glass_model_for_type(const char *type, bst_glass_model *model)
{
    char key[64];
    size_t n = 0;
    for (const char *p = type; p && *p; p++) {
        if (isspace((unsigned char)*p) || *p == '-' || *p == '_')
            continue;
        if (n + 1 >= sizeof key)
            return BST_ENOTFOUND;
        key[n++] = *p;
    }
    key[n] = '\0';
    for (size_t i = 0; n && i < sizeof type_models / sizeof type_models[0]; i++)
        if (strcasecmp(key, type_models[i].type) == 0) {
            if (model)
                *model = type_models[i].model;
            return BST_OK;
        }
    return BST_ENOTFOUND;
}

const char *bst_glass_model_name(bst_glass_model model)
{
    return model == BST_GLASS_COATED ? "coated" : "uncoated";
}

int bsti_glass_side_model(struct bsti_glass_side *s, double t0, double r0, bst_glass_model m)
{
    if (bsti_glass_side_init(s, t0, r0) < 0)
        return -1;
    s->coated = m == BST_GLASS_COATED;
    return 0;
}

bst_glass_model bst_glass_get_model(const bst_glass *g)
{
    return g ? g->model : BST_GLASS_UNCOATED;
}

int bsti_glass_apply_model(bst_glass *g, bst_glass_model model, const char *from)
{
    g->model = model;
    for (size_t c = 0; c < g->nch; c++)
        for (size_t k = 0; k < g->ch[c].nk; k++)
            g->ch[c].front[k].coated = g->ch[c].back[k].coated = model == BST_GLASS_COATED;
    g->meta.model_from = from; /* a literal */
    return BST_OK;
}

int bst_glass_set_model(bst_ctx *ctx, bst_glass *g, bst_glass_model model)
{
    if (!ctx || !g)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass: NULL argument") : BST_EINVAL;
    if (model != BST_GLASS_UNCOATED && model != BST_GLASS_COATED)
        return bsti_error(ctx, BST_EINVAL, "%s: model %d is neither uncoated nor coated", g->where,
                          (int)model);
    return bsti_glass_apply_model(g, model, "set");
}
