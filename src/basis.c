/* basis.c - Shirley-Chiu and Klems bases: direction <-> patch, patch centres and samples, Lambda.
 * Conventions in basis.h. */
#include <config.h>

#include <math.h>
#include <string.h>
#include <strings.h>

#include "basis.h"
#include "ctx.h"

#define DEG (M_PI / 180.0)

/* ------------------------------------------------------------------ concentric map */

void bsti_sc_disk_to_square(double x, double y, double *sx, double *sy)
{
    double r = sqrt(x * x + y * y);
    bsti_sc_polar_to_square(r, r == 0.0 ? 0.0 : atan2(y, x), sx, sy);
}

void bsti_sc_square_to_polar(double sx, double sy, double *r, double *phi)
{
    double a = 2 * sx - 1, b = 2 * sy - 1;
    if (a == 0.0 && b == 0.0) {
        *r = *phi = 0.0;
        return;
    }
    if (fabs(a) >= fabs(b)) {
        *r = fabs(a);
        *phi = a > 0 ? (M_PI / 4) * (b / a) : (M_PI / 4) * (4 + b / a);
    } else {
        *r = fabs(b);
        *phi = b > 0 ? (M_PI / 4) * (2 - a / b) : (M_PI / 4) * (6 - a / b);
    }
}

int bsti_sc_cell_points(bst_ctx *ctx, size_t g, size_t ns, double **pol)
{
    size_t n = g * g, per = ns * ns;
    double *p = bsti_alloc_array(ctx, 2 * n * per, sizeof *p);
    *pol = p;
    if (!p)
        return BST_ENOMEM;
    for (size_t c = 0; c < n; c++)
        for (size_t s = 0; s < per; s++)
            bsti_sc_square_to_polar(((double)(c / g) + ((double)(s / ns) + 0.5) / (double)ns) / (double)g,
                                    ((double)(c % g) + ((double)(s % ns) + 0.5) / (double)ns) / (double)g,
                                    &p[2 * (c * per + s)], &p[2 * (c * per + s) + 1]);
    return BST_OK;
}

void bsti_sc_square_to_disk(double sx, double sy, double *x, double *y)
{
    double r, phi;
    bsti_sc_square_to_polar(sx, sy, &r, &phi);
    *x = r * cos(phi);
    *y = r * sin(phi);
}

/* ------------------------------------------------------------------ construction */

static int basis_alloc(bst_ctx *ctx, bst_basis_kind kind, size_t n, const char *name, bst_basis **out)
{
    bst_basis *b = bsti_calloc(ctx, 1, sizeof *b);
    if (!b)
        return BST_ENOMEM;
    b->ctx = ctx;
    b->kind = kind;
    b->n = n;
    b->lambda = bsti_alloc_array(ctx, n, sizeof *b->lambda);
    b->name = bsti_strdup(ctx, name);
    if (!b->lambda || !b->name) {
        bst_basis_free(b);
        return BST_ENOMEM;
    }
    *out = b;
    return BST_OK;
}

int bst_basis_new_sc(bst_ctx *ctx, int k, bst_basis **out)
{
    if (!ctx || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "basis: NULL result pointer") : BST_EINVAL;
    *out = NULL;
    if (k < BST_K_MIN || k > BST_K_MAX)
        return bsti_error(ctx, BST_EINVAL, "basis: Shirley-Chiu order k = %d is out of range %d..%d",
                          k, BST_K_MIN, BST_K_MAX);
    size_t g = (size_t)1 << k;
    bst_basis *b;
    int rc = basis_alloc(ctx, BST_BASIS_SHIRLEY_CHIU, g * g, "LBNL/Shirley-Chiu", &b);
    if (rc < 0)
        return rc;
    b->k = k;
    b->g = g;
    for (size_t i = 0; i < b->n; i++)
        b->lambda[i] = M_PI / (double)b->n;
    *out = b;
    return BST_OK;
}

int bst_basis_new_klems_bands(bst_ctx *ctx, const char *name, size_t nbands,
                              const double *theta_bounds_deg, const int *nphi, bst_basis **out)
{
    if (!ctx || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "basis: NULL result pointer") : BST_EINVAL;
    *out = NULL;
    if (!name || !theta_bounds_deg || !nphi || nbands == 0 || nbands > BSTI_KLEMS_MAX_BANDS)
        return bsti_error(ctx, BST_EBASIS, "basis %s: %zu bands (1..%d required)", name ? name : "?",
                          nbands, BSTI_KLEMS_MAX_BANDS);
    size_t n = 0;
    for (size_t i = 0; i < nbands; i++) {
        double lo = theta_bounds_deg[i], hi = theta_bounds_deg[i + 1];
        if (!(lo >= 0.0 && hi > lo && hi <= 90.0) || (i == 0 && lo != 0.0) ||
            (i == nbands - 1 && hi != 90.0) || nphi[i] < 1 || nphi[i] > 100000)
            return bsti_error(ctx, BST_EBASIS, "basis %s: band %zu (theta %g..%g, %d patches) is "
                              "not a valid band", name, i + 1, lo, hi, nphi[i]);
        n += (size_t)nphi[i];
    }
    bst_basis *b;
    int rc = basis_alloc(ctx, BST_BASIS_KLEMS, n, name, &b);
    if (rc < 0)
        return rc;
    b->nbands = nbands;
    size_t p = 0;
    for (size_t i = 0; i < nbands; i++) {
        b->theta[i] = theta_bounds_deg[i];
        b->nphi[i] = nphi[i];
        b->first[i] = p;
        double c0 = cos(theta_bounds_deg[i] * DEG), c1 = cos(theta_bounds_deg[i + 1] * DEG);
        for (int j = 0; j < nphi[i]; j++)
            b->lambda[p++] = M_PI * (c0 * c0 - c1 * c1) / nphi[i];
    }
    b->theta[nbands] = theta_bounds_deg[nbands];
    b->first[nbands] = p;
    *out = b;
    return BST_OK;
}

int bst_basis_new_klems(bst_ctx *ctx, const char *which, bst_basis **out)
{
    static const double full_t[] = {0, 5, 15, 25, 35, 45, 55, 65, 75, 90};
    static const int full_n[] = {1, 8, 16, 20, 24, 24, 24, 16, 12};
    static const double half_t[] = {0, 6.5, 19.5, 32.5, 45.5, 58.5, 71.5, 90};
    static const int half_n[] = {1, 8, 12, 16, 20, 12, 8};
    static const double quarter_t[] = {0, 9, 27, 45, 63, 90};
    static const int quarter_n[] = {1, 8, 12, 12, 8};
    if (!ctx || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "basis: NULL result pointer") : BST_EINVAL;
    *out = NULL;
    if (which && strcasecmp(which, "full") == 0)
        return bst_basis_new_klems_bands(ctx, "LBNL/Klems Full", 9, full_t, full_n, out);
    if (which && strcasecmp(which, "half") == 0)
        return bst_basis_new_klems_bands(ctx, "LBNL/Klems Half", 7, half_t, half_n, out);
    if (which && strcasecmp(which, "quarter") == 0)
        return bst_basis_new_klems_bands(ctx, "LBNL/Klems Quarter", 5, quarter_t, quarter_n, out);
    return bsti_error(ctx, BST_EBASIS, "basis: unknown Klems basis '%s' (use full, half or quarter)",
                      which ? which : "(null)");
}

int bst_basis_copy(bst_ctx *ctx, const bst_basis *b, bst_basis **out)
{
    if (!ctx || !b || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "basis: NULL argument") : BST_EINVAL;
    if (b->kind == BST_BASIS_SHIRLEY_CHIU)
        return bst_basis_new_sc(ctx, b->k, out);
    return bst_basis_new_klems_bands(ctx, b->name, b->nbands, b->theta, b->nphi, out);
}

void bst_basis_free(bst_basis *b)
{
    if (!b)
        return;
    bsti_free(b->ctx, b->lambda);
    bsti_free(b->ctx, b->name);
    bsti_free(b->ctx, b);
}

/* ------------------------------------------------------------------ queries */

bst_basis_kind bst_basis_kind_of(const bst_basis *b) { return b->kind; }
size_t bst_basis_size(const bst_basis *b) { return b ? b->n : 0; }
int bst_basis_order(const bst_basis *b) { return b->kind == BST_BASIS_SHIRLEY_CHIU ? b->k : 0; }
const char *bst_basis_name(const bst_basis *b) { return b->name; }
const double *bst_basis_lambda(const bst_basis *b) { return b->lambda; }

static size_t sc_cell(size_t g, double s)
{
    double c = floor(s * (double)g);
    if (c < 0.0)
        return 0;
    return c >= (double)g ? g - 1 : (size_t)c;
}

/* Band of a polar angle (degrees); the last band includes 90. */
static size_t klems_band(const bst_basis *b, double theta)
{
    size_t i = 0;
    while (i + 1 < b->nbands && theta >= b->theta[i + 1])
        i++;
    return i;
}

/* Band of a Klems patch. */
static size_t patch_band(const bst_basis *b, size_t patch)
{
    size_t band = 0;
    while (band + 1 < b->nbands && patch >= b->first[band + 1])
        band++;
    return band;
}

size_t bst_basis_patch(const bst_basis *b, const double dir[3])
{
    double x = dir[0], y = dir[1];
    if (!isfinite(x) || !isfinite(y))
        return b->n; /* no patch: every entry taking a patch refuses one past the last */
    if (b->kind == BST_BASIS_SHIRLEY_CHIU) {
        double sx, sy;
        bsti_sc_disk_to_square(x, y, &sx, &sy);
        return sc_cell(b->g, sx) * b->g + sc_cell(b->g, sy);
    }
    double r = fmin(1.0, sqrt(x * x + y * y));
    size_t band = klems_band(b, asin(r) / DEG);
    int n = b->nphi[band];
    double phi = atan2(y, x) / DEG;
    if (phi < 0)
        phi += 360.0;
    long j = (long)floor((phi + 180.0 / n) / (360.0 / n));
    return b->first[band] + (size_t)(((j % n) + n) % n);
}

void bst_basis_sample(const bst_basis *b, size_t patch, double u, double v, double dir[3])
{
    double x, y;
    if (b->kind == BST_BASIS_SHIRLEY_CHIU) {
        size_t ix = patch / b->g, iy = patch % b->g;
        bsti_sc_square_to_disk(((double)ix + u) / (double)b->g, ((double)iy + v) / (double)b->g, &x, &y);
    } else {
        size_t band = patch_band(b, patch);
        int n = b->nphi[band];
        size_t j = patch - b->first[band];
        double s0 = sin(b->theta[band] * DEG), s1 = sin(b->theta[band + 1] * DEG);
        double r = sqrt(s0 * s0 + u * (s1 * s1 - s0 * s0)); /* uniform in projected solid angle */
        double phi = ((double)j - 0.5 + v) * 2.0 * M_PI / n;
        x = r * cos(phi);
        y = r * sin(phi);
    }
    double rr = x * x + y * y;
    dir[0] = x;
    dir[1] = y;
    dir[2] = rr < 1.0 ? sqrt(1.0 - rr) : 0.0;
}

void bst_basis_center(const bst_basis *b, size_t patch, double dir[3])
{
    if (b->kind == BST_BASIS_SHIRLEY_CHIU) {
        bst_basis_sample(b, patch, 0.5, 0.5, dir);
        return;
    }
    /* Klems: the band's mid polar angle (0 for the first band) and the patch's central azimuth,
     * as Klems files and WINDOW define the patch direction. */
    size_t band = patch_band(b, patch);
    double theta = band == 0 && b->theta[0] == 0.0 && b->nphi[0] == 1
                       ? 0.0 : 0.5 * (b->theta[band] + b->theta[band + 1]);
    double phi = (double)(patch - b->first[band]) * 2.0 * M_PI / b->nphi[band];
    dir[0] = sin(theta * DEG) * cos(phi);
    dir[1] = sin(theta * DEG) * sin(phi);
    dir[2] = cos(theta * DEG);
}

size_t bst_basis_antipode(const bst_basis *b, size_t patch)
{
    if (b->kind == BST_BASIS_SHIRLEY_CHIU)
        return b->n - 1 - patch; /* (ix, iy) -> (g-1-ix, g-1-iy) */
    size_t band = patch_band(b, patch);
    int n = b->nphi[band];
    if (n % 2 == 0)
        return b->first[band] + (patch - b->first[band] + (size_t)n / 2) % (size_t)n;
    double d[3];
    bst_basis_center(b, patch, d);
    d[0] = -d[0];
    d[1] = -d[1];
    return bst_basis_patch(b, d);
}

void bsti_basis_antipode_uv(const bst_basis *b, size_t patch, double *u, double *v)
{
    if (b->kind == BST_BASIS_SHIRLEY_CHIU) { /* the concentric map is odd: (1 - s, 1 - t) -> -p */
        *u = 1.0 - *u;
        *v = 1.0 - *v;
        return;
    }
    size_t band = patch_band(b, patch);
    if (b->nphi[band] == 1) /* its own antipode (an odd band of more patches has none exactly) */
        *v = *v < 0.5 ? *v + 0.5 : *v - 0.5;
}

size_t bsti_basis_mirror_x(const bst_basis *b, size_t patch)
{
    double d[3];
    bst_basis_center(b, patch, d);
    d[0] = -d[0];
    return bst_basis_patch(b, d);
}

int bst_basis_equal(const bst_basis *a, const bst_basis *b)
{
    if (!a || !b || a->kind != b->kind || a->n != b->n)
        return 0;
    if (a->kind == BST_BASIS_SHIRLEY_CHIU)
        return a->k == b->k;
    if (a->nbands != b->nbands)
        return 0;
    for (size_t i = 0; i < a->nbands; i++)
        if (a->nphi[i] != b->nphi[i] || fabs(a->theta[i + 1] - b->theta[i + 1]) > 1e-9)
            return 0;
    return 1;
}
