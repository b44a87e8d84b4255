/* venetian_wce.c - WINDOW's venetian blind model (rule=centre; bsdfstack.h above bst_venetian),
 * written from the description of Windows-CalcEngine v1.0.75 (its venetian cell, slat segments,
 * enclosure view factors and BSDF layer), so that users can match WINDOW's numbers.
 *
 * One channel between two slats in the blind's profile plane, in the frame of the side the light
 * enters: x across the blind away from that side, y up (the model frame's Y, venetian.h).  The
 * lower slat runs from (0, 0) to (X, h), X = w cos b, h = w sin b, the upper one is it moved up by
 * the spacing s; light entering from the interior sees the blind mirrored, tilt -b.  Elements:
 * 0..m-1 the lower slat's strips (its upper face: r_up), m..2m-1 the upper slat's (its lower face:
 * r_down), each numbered from the near edge; 2m the near opening (x = 0), 2m+1 the far one
 * (x = X).  By periodicity strip k's other face is strip k +- m: what a strip transmits leaves
 * from there.  Fluxes are per unit flux entering the near opening.
 *
 * The channel is a parallelogram, so convex: a ray entering through one opening meets exactly one
 * other element, and the shares of the opening that meet each element are the projections of the
 * elements along the ray onto it (exact); the view factors are Hottel's crossed strings (exact).
 * The flux arriving on the elements, a, solves a = b + F^T E a (b the first arrivals, F(i, j) the
 * share of i's diffuse emission reaching j, E the strips' reflectance and transmittance):
 *   uniform:     the far opening's arrivals less the unobstructed share are T, the near one's R,
 *                each spread by 1/pi over every outgoing patch;
 *   directional: the strips' exitance x = (I - F^T E)^-1 E b (WCE solves the arrivals' system
 *                for it; the radiosity J = (I - E F^T)^-1 E b is the same only for E = r I),
 *                seen from each outgoing patch's centre: its radiance sum_k x_k v_k s / (pi w / m),
 *                v_k the share of the exit opening that looks onto strip k along the outgoing
 *                direction.
 * Every patch is taken at its centre direction (bst_basis_center; a ring of one patch at azimuth
 * 180 degrees, where WCE puts its centre: the same for a horizontal blind, the mirror image for a
 * vertical one); the unobstructed share of the incident centre goes on the diagonal over Lambda.
 * Dual-band slats: the Solar channel weighs the layers of the visible and of the outside values
 * f : 1 - f (bsti_vn_wce_layer). */
#include <config.h>

#include <math.h>
#include <string.h>

#include <lapacke.h>

#include "ctx.h"
#include "venetian.h"

/* |tilt| is held below this, as WCE holds it (its channel stays a parallelogram). */
#define WCE_TILT_MAX 89.99999
/* A direction this close to the blind's plane crosses none of it (no centre lies there). */
#define WCE_GRAZING 1e-12

struct wce_cell {
    int m;            /* strips per slat */
    size_t ne;        /* elements: 2 m + 2 */
    double s, X, h;   /* spacing, the channel's depth and rise */
    double len;       /* a strip's length */
    double *seg;      /* ne x 4: x0, y0, x1, y1 of each element */
    double *a;        /* ne x ne column-major: I - F^T E, then its LU factors */
    lapack_int *ipiv;
};

/* The emission of element k per unit flux arriving on element j (E(k, j) above). */
static double emission(const bst_venetian *v, int m, size_t k, size_t j)
{
    size_t n = 2 * (size_t)m;
    if (j >= n || k >= n)
        return 0.0;
    if (k == j)
        return j < (size_t)m ? v->r_up : v->r_down;
    return (k + (size_t)m) % n == j ? v->t : 0.0;
}

static double dist(double x0, double y0, double x1, double y1)
{
    return hypot(x1 - x0, y1 - y0);
}

/* F(i -> j) by crossed strings: (crossed - uncrossed) / (2 L_i); in a convex channel the larger
 * pair of strings is the crossed one.  Strips of one slat see none of each other. */
static double view_factor(const struct wce_cell *c, size_t i, size_t j)
{
    size_t n = 2 * (size_t)c->m;
    if (i == j || (i < n && j < n && (i < (size_t)c->m) == (j < (size_t)c->m)))
        return 0.0;
    const double *p = c->seg + 4 * i, *q = c->seg + 4 * j;
    double s1 = dist(p[0], p[1], q[2], q[3]) + dist(p[2], p[3], q[0], q[1]);
    double s2 = dist(p[0], p[1], q[0], q[1]) + dist(p[2], p[3], q[2], q[3]);
    return fabs(s1 - s2) / (2.0 * dist(p[0], p[1], p[2], p[3]));
}

static void cell_free(bst_ctx *ctx, struct wce_cell *c)
{
    bsti_free(ctx, c->seg), bsti_free(ctx, c->a), bsti_free(ctx, c->ipiv);
    memset(c, 0, sizeof *c);
}

/* The channel of tilt b (degrees) and I - F^T E factored. */
static int cell_init(bst_ctx *ctx, struct wce_cell *c, const bst_venetian *v, double tilt)
{
    double b = fmax(-WCE_TILT_MAX, fmin(WCE_TILT_MAX, tilt)) * (M_PI / 180.0);
    memset(c, 0, sizeof *c);
    c->m = v->segments;
    c->ne = 2 * (size_t)c->m + 2;
    c->s = v->spacing;
    c->X = v->width * cos(b);
    c->h = v->width * sin(b);
    c->len = v->width / c->m;
    size_t ne = c->ne, n = ne - 2;
    c->seg = bsti_alloc_array(ctx, 4 * ne, sizeof *c->seg);
    c->a = bsti_alloc_array(ctx, ne * ne, sizeof *c->a);
    c->ipiv = bsti_alloc_array(ctx, ne, sizeof *c->ipiv);
    if (!c->seg || !c->a || !c->ipiv) {
        cell_free(ctx, c);
        return BST_ENOMEM;
    }
    for (size_t k = 0; k < n; k++) {
        double f0 = (double)(k % (size_t)c->m) / c->m, f1 = (double)(k % (size_t)c->m + 1) / c->m;
        double up = k < (size_t)c->m ? 0.0 : c->s;
        double *p = c->seg + 4 * k;
        p[0] = f0 * c->X, p[1] = f0 * c->h + up, p[2] = f1 * c->X, p[3] = f1 * c->h + up;
    }
    double *near = c->seg + 4 * n, *far = near + 4;
    near[0] = 0.0, near[1] = 0.0, near[2] = 0.0, near[3] = c->s;
    far[0] = c->X, far[1] = c->h, far[2] = c->X, far[3] = c->h + c->s;
    /* A(j, i) = delta_ji - sum_k F(k -> j) E(k, i), E(k, i) non-zero for k = i and its other face */
    for (size_t i = 0; i < ne; i++)
        for (size_t j = 0; j < ne; j++) {
            double x = (i == j) ? 1.0 : 0.0;
            if (i < n) {
                size_t p = (i + (size_t)c->m) % n;
                x -= view_factor(c, i, j) * emission(v, c->m, i, i) +
                     view_factor(c, p, j) * emission(v, c->m, p, i);
            }
            c->a[i * ne + j] = x;
        }
    lapack_int info = LAPACKE_dgetrf_work(LAPACK_COL_MAJOR, (lapack_int)ne, (lapack_int)ne, c->a,
                                          (lapack_int)ne, c->ipiv);
    if (info != 0) { /* cannot happen: F^T E has column sums below 1 unless r + t = 1 everywhere,
                      * and the openings absorb */
        cell_free(ctx, c);
        return bsti_error(ctx, BST_ESINGULAR, "venetian: rule=centre: the slats' exchange is singular");
    }
    return BST_OK;
}

/* share[k]: the part of opening `far` (0: near, 1: far) whose rays along (ux, uy) (into the
 * channel) meet element k first; the opening itself gets 0.  The shares add up to 1. */
static void shares(const struct wce_cell *c, int far, double ux, double uy, double *share)
{
    size_t n = c->ne - 2, self = n + (size_t)far;
    double x0 = far ? c->X : 0.0, y0 = far ? c->h : 0.0, slope = uy / ux;
    for (size_t k = 0; k < c->ne; k++) {
        const double *p = c->seg + 4 * k;
        double ya = p[1] - (p[0] - x0) * slope, yb = p[3] - (p[2] - x0) * slope;
        double lo = fmax(fmin(ya, yb), y0), hi = fmin(fmax(ya, yb), y0 + c->s);
        share[k] = k == self ? 0.0 : fmax(0.0, hi - lo) / c->s;
    }
}

/* The model frame's (across, up) of a layer direction: |z| and Y (a vertical blind's X). */
static void profile(const bst_venetian *v, const double d[3], double *across, double *up)
{
    *across = fabs(d[2]);
    *up = v->vertical ? d[0] : d[1];
}

struct wce_build {
    bst_ctx *ctx;
    const bst_venetian *v;
    const bst_basis *b;
    size_t n;
    double *cen;    /* n x 3: the patches' centres */
    double *rhs;    /* ne x n: first arrivals, then what the solve makes of them */
    double *view;   /* ne x n: the strips seen from each outgoing patch */
    double *tdd;    /* n: unobstructed share of each incident centre */
};

/* The strips' views from the outgoing centres leaving by opening `far` of cell c. */
static void views(struct wce_build *B, const struct wce_cell *c, int far)
{
    for (size_t o = 0; o < B->n; o++) {
        double across, up;
        profile(B->v, B->cen + 3 * o, &across, &up);
        double *vw = B->view + o * c->ne;
        if (across < WCE_GRAZING) {
            memset(vw, 0, c->ne * sizeof *vw);
            continue;
        }
        /* back along the light: from the far opening towards -x, from the near one towards +x */
        shares(c, far, far ? -across : across, -up, vw);
    }
}

/* Component (T: far 1, R: far 0) of the side whose cell is c, from B->rhs solved, into m. */
static void assemble(struct wce_build *B, const struct wce_cell *c, int far, double *m)
{
    size_t n = B->n, ne = c->ne, ns = ne - 2;
    const double *lam = bst_basis_lambda(B->b);
    if (B->v->distribution == BST_VENETIAN_UNIFORM) {
        for (size_t i = 0; i < n; i++) {
            double out = B->rhs[i * ne + ns + (size_t)far] - (far ? B->tdd[i] : 0.0);
            for (size_t o = 0; o < n; o++)
                m[i * n + o] = out / M_PI;
        }
    } else {
        views(B, c, far);
        double scale = c->s / (M_PI * c->len);
        for (size_t i = 0; i < n; i++)
            for (size_t o = 0; o < n; o++) {
                double L = 0.0;
                for (size_t k = 0; k < ns; k++)
                    L += B->rhs[i * ne + k] * B->view[o * ne + k];
                m[i * n + o] = L * scale;
            }
    }
    if (far)
        for (size_t i = 0; i < n; i++)
            m[i * n + i] += B->tdd[i] / lam[i];
}

/* The first arrivals of every incident centre in cell c (directional: the strips' first
 * emission E b), solved with the cell's factors. */
static int arrivals(struct wce_build *B, const struct wce_cell *c)
{
    size_t ne = c->ne, ns = ne - 2;
    double *first = bsti_alloc_array(B->ctx, ne, sizeof *first);
    if (!first)
        return BST_ENOMEM;
    for (size_t i = 0; i < B->n; i++) {
        double across, up, *r = B->rhs + i * ne;
        profile(B->v, B->cen + 3 * i, &across, &up);
        if (across < WCE_GRAZING) {
            memset(r, 0, ne * sizeof *r);
            B->tdd[i] = 0.0;
            continue;
        }
        shares(c, 0, across, up, first);
        B->tdd[i] = first[ns + 1];
        if (B->v->distribution == BST_VENETIAN_UNIFORM) {
            memcpy(r, first, ne * sizeof *r);
            continue;
        }
        for (size_t k = 0; k < ne; k++)
            r[k] = k < ns ? emission(B->v, c->m, k, k) * first[k] +
                                B->v->t * first[(k + (size_t)c->m) % ns] : 0.0;
    }
    bsti_free(B->ctx, first);
    lapack_int info = LAPACKE_dgetrs_work(LAPACK_COL_MAJOR, 'N', (lapack_int)ne, (lapack_int)B->n,
                                          c->a, (lapack_int)ne, c->ipiv, B->rhs, (lapack_int)ne);
    return info == 0 ? BST_OK : bsti_error(B->ctx, BST_EINVAL, "venetian: rule=centre: solve failed");
}

/* One side (0: light from the exterior, Tf and Rf; 1: from the interior, Tb and Rb) into mt, mr. */
static int side_components(struct wce_build *B, int back, double *mt, double *mr)
{
    struct wce_cell c;
    int rc = cell_init(B->ctx, &c, B->v, back ? -B->v->tilt : B->v->tilt);
    if (rc < 0)
        return rc;
    rc = arrivals(B, &c);
    if (rc >= 0) {
        assemble(B, &c, 1, mt);
        assemble(B, &c, 0, mr);
    }
    cell_free(B->ctx, &c);
    return rc;
}

/* The four dense components of v over B->b; mats[c] in bst_comp order. */
static int components(struct wce_build *B, bst_mat **mats)
{
    int rc = BST_OK;
    for (int k = 0; k < BST_NCOMP && rc >= 0; k++)
        rc = bst_mat_new_dense(B->ctx, B->n, B->n, BST_DOUBLE, &mats[k]);
    for (int back = 0; back < 2 && rc >= 0; back++)
        rc = side_components(B, back, bst_mat_dense_data(mats[back ? BST_TB : BST_TF]),
                             bst_mat_dense_data(mats[back ? BST_RB : BST_RF]));
    return rc;
}

/* The four dense components of the blind v over basis into mats (bst_comp order). */
static int model(bst_ctx *ctx, const bst_venetian *v, const bst_basis *basis, bst_mat **mats)
{
    struct wce_build B;
    memset(&B, 0, sizeof B);
    B.ctx = ctx, B.v = v, B.b = basis, B.n = bst_basis_size(basis);
    size_t ne = 2 * (size_t)v->segments + 2;
    B.cen = bsti_alloc_array(ctx, 3 * B.n, sizeof *B.cen);
    B.rhs = bsti_alloc_array(ctx, ne * B.n, sizeof *B.rhs);
    B.view = bsti_alloc_array(ctx, ne * B.n, sizeof *B.view);
    B.tdd = bsti_alloc_array(ctx, B.n, sizeof *B.tdd);
    int rc = B.cen && B.rhs && B.view && B.tdd ? BST_OK : BST_ENOMEM;
    for (size_t i = 0; i < B.n && rc >= 0; i++) {
        double *c = B.cen + 3 * i;
        bst_basis_center(basis, i, c);
        if (bst_basis_antipode(basis, i) == i) /* a ring of one patch: WCE's centre is at 180 deg */
            c[0] = -c[0], c[1] = -c[1];
    }
    if (rc >= 0)
        rc = components(&B, mats);
    bsti_free(ctx, B.cen), bsti_free(ctx, B.rhs), bsti_free(ctx, B.view), bsti_free(ctx, B.tdd);
    return rc;
}

/* WCE's dual-band rule: the slat value outside the visible range, from the visible and the
 * solar one (NaN: as visible). */
static double outside(double vis, double sol)
{
    if (isnan(sol))
        return vis;
    return fmax(0.0, (sol - BST_DUAL_BAND_F * vis) / (1.0 - BST_DUAL_BAND_F));
}

/* mats[k] into channels ch[0..nch) of l in precision prec (copies but for the last, which the
 * layer takes when prec is double; a float copy for each channel otherwise). */
static int put(bst_ctx *ctx, bst_layer *l, size_t nch, const size_t *ch, bst_mat **mats,
               bst_precision prec)
{
    int rc = BST_OK;
    for (int k = 0; k < BST_NCOMP && rc >= 0; k++) {
        for (size_t j = 0; j < nch && rc >= 0; j++) {
            bst_mat *m = mats[k];
            if (j + 1 < nch || prec != BST_DOUBLE)
                rc = bst_mat_convert(ctx, mats[k], BST_DENSE, prec, &m);
            else
                mats[k] = NULL; /* the layer's now, also on failure */
            if (rc >= 0)
                rc = bst_layer_set(ctx, l, ch[j], (bst_comp)k, m);
        }
        if (prec != BST_DOUBLE) /* its doubles, as soon as they are copied */
            bst_mat_free(mats[k]), mats[k] = NULL;
    }
    return rc;
}

int bsti_vn_wce_layer(bst_ctx *ctx, const bst_venetian *v, const bst_basis *basis, bst_layer *l,
                      size_t nvis, const size_t *vis, size_t nsol, const size_t *sol)
{
    bst_mat *mv[BST_NCOMP] = {NULL}, *mo[BST_NCOMP] = {NULL};
    int rc = model(ctx, v, basis, mv);
    if (rc >= 0 && nsol) {
        /* WCE takes the visible values inside 0.38-0.78 um and the rule's outside: its solar
         * band then weighs the two layers f : 1 - f, as the stack's dual-band rule splits them */
        bst_venetian vo = *v;
        vo.r_up = outside(v->r_up, v->solar[0]);
        vo.r_down = outside(v->r_down, v->solar[1]);
        vo.t = outside(v->t, v->solar[2]);
        rc = model(ctx, &vo, basis, mo);
        for (int k = 0; k < BST_NCOMP && rc >= 0; k++) {
            double *a = bst_mat_dense_data(mo[k]);
            const double *b = bst_mat_dense_data(mv[k]);
            size_t nn = bst_basis_size(basis) * bst_basis_size(basis);
            for (size_t q = 0; q < nn; q++)
                a[q] = BST_DUAL_BAND_F * b[q] + (1.0 - BST_DUAL_BAND_F) * a[q];
        }
        if (rc >= 0)
            rc = put(ctx, l, nsol, sol, mo, v->precision);
    }
    if (rc >= 0)
        rc = put(ctx, l, nvis, vis, mv, v->precision);
    for (int k = 0; k < BST_NCOMP; k++)
        bst_mat_free(mv[k]), bst_mat_free(mo[k]);
    return rc;
}

int bsti_vn_wce_check(bst_ctx *ctx, const bst_venetian *v)
{
    if (v->rule != BST_VENETIAN_AVERAGE && v->rule != BST_VENETIAN_CENTRE)
        return bsti_error(ctx, BST_EINVAL, "venetian: rule = %d is not average (%d) or centre (%d)",
                          v->rule, BST_VENETIAN_AVERAGE, BST_VENETIAN_CENTRE);
    if (v->distribution != BST_VENETIAN_DIRECTIONAL && v->distribution != BST_VENETIAN_UNIFORM)
        return bsti_error(ctx, BST_EINVAL, "venetian: distribution = %d is not directional (%d) or "
                          "uniform (%d)", v->distribution, BST_VENETIAN_DIRECTIONAL, BST_VENETIAN_UNIFORM);
    if (v->rule != BST_VENETIAN_CENTRE) {
        if (v->distribution != BST_VENETIAN_DIRECTIONAL)
            return bsti_error(ctx, BST_EINVAL, "venetian: distribution=uniform needs rule=centre "
                              "(WINDOW's model)");
        return BST_OK;
    }
    double rs = isnan(v->solar[3]) ? v->rs : fmax(v->rs, v->solar[3]);
    if (rs > 0.0)
        return bsti_error(ctx, BST_EINVAL, "venetian: rs = %g: rule=centre (WINDOW's model) has "
                          "diffuse slats only (rs=0)", rs);
    if (v->curvature != 0.0)
        return bsti_error(ctx, BST_ENOTIMPL, "venetian: curvature = %g m: rule=centre models flat "
                          "slats only (curvature=0)", v->curvature);
    static const char *const key[3] = {"r-up", "r-down", "t"};
    const double x[3] = {v->r_up, v->r_down, v->t};
    double o[3];
    for (int k = 0; k < 3; k++)
        o[k] = outside(x[k], v->solar[k]);
    if (o[0] + o[2] > 1.0 + 1e-12 || o[1] + o[2] > 1.0 + 1e-12) {
        int k = o[0] + o[2] > 1.0 + 1e-12 ? 0 : 1;
        return bsti_error(ctx, BST_EINVAL, "venetian: %s + t outside the visible range = %g is "
                          "above 1 (rule=centre takes (solar - %g visible) / %g there, as WINDOW)",
                          key[k], o[k] + o[2], BST_DUAL_BAND_F, 1.0 - BST_DUAL_BAND_F);
    }
    if (v->samples != 0)
        return bsti_error(ctx, BST_EINVAL, "venetian: samples = %d: rule=centre takes one direction "
                          "per patch (leave samples out)", v->samples);
    return BST_OK;
}
