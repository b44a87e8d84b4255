/* venetian_layer.c - a venetian blind (bst_venetian) as a layer over any basis.
 *
 * Each component is assembled from its parts (venetian.h, venetian_trace.c):
 *   C = S + U_x * diag(s m / (pi w)) * Q_y,
 * S the unobstructed and mirrored light (sparse: for each incident patch, its own patch and the
 * patches its mirror image covers, each entry the flux share landing there over the patch's
 * Lambda), U_x (N x 2m) the view of the slat strips from the outgoing patches of exit side x,
 * Q_y (2m x N) the flux the strips re-emit diffusely for each incident patch of side y: the
 * radiosity solution Q = (I - E G)^-1 E D of the first arrivals D, E the strips' emission (r of
 * the face, t from the face behind), G their exchange.  The second term has rank 2m at most and
 * is kept apart until the end.  Where S is diagonal (diffuse slats without a mirror part: only the
 * unobstructed light, on the diagonal of T) and the rank is small beside N, each component is
 * FACTORED (lowrank.h): diag(S) + W K W^T over one map W = [U_ext | U_int | Q_ext^T | Q_int^T]
 * (N x 8m) shared by the four components, K selecting the blocks, so that the stack keeps such
 * a blind at the size of its strips (issue #31/#32).  Otherwise a component with diffuse slats is
 * PLUS_LR (mat.h: S + U_x^T Q_y as they are, where 2m is small beside N) or dense, one with mirror
 * or black slats sparse.
 * Incident patches are averaged over samples x samples directions uniform in projected solid
 * angle (bst_basis_sample), outgoing patches' views the same way.  Curved slats (g.curved) take
 * the same path except for S and the first arrivals: rays traced per incident direction
 * (incident_curved), since a mirrored ray no longer leaves along d or its mirror image. */
#include <config.h>

#include <limits.h>
#include <math.h>
#include <string.h>
#include <strings.h>

#include <cblas.h>

#include "basis.h"
#include "ctx.h"
#include "mat.h"
#include "mirror.h"
#include "venetian.h"

struct trip {
    size_t *row, *col;
    double *val;
    size_t nnz, cap;
};

/* Profile-angle table of the hits and views: intervals over [-pi/2, pi/2] (0.04 deg each). */
#define VN_TABLE 4096

struct build {
    bst_ctx *ctx;
    const bst_basis *b;
    const bst_venetian *v;
    bsti_vn_geom g;
    size_t n, ne;   /* patches, strips (2 segments) */
    size_t np;      /* quadrature points per patch: samples^2 */
    double *pts;    /* np x 4: (u, v) of bst_basis_sample, and a 2-D Gaussian point for the lobe */
    struct trip tr[BST_NCOMP];
    double *dep[2]; /* ne x n first arrivals, column-major, incident from the exterior / interior */
    double *view[2];/* ne x n: column o = strips seen from outgoing patch o at the exterior /
                     * interior opening */
    double *hit[2], *see[2]; /* tables of bsti_vn_hit and bsti_vn_view rows, light along +Z / -Z */
    bsti_lr_map *W; /* the factored components' map, or NULL: dense */
};

/* One worker's room and results in trace_incident: its columns' entries (tr, appended to the
 * build's in the workers' order, so that any number of threads gives the same matrices) and, for
 * curved slats, 2 n flux sums of one column (reflected, transmitted) with the entries in use in
 * the order first met. */
struct worker {
    struct trip tr[BST_NCOMP];
    double *acc;
    size_t *touched;
};

/* The entries of one incident column, summed over its directions. */
struct column {
    size_t n, cap, i;
    int back;
    size_t *row;
    int *comp;
    double *val;
};

/* The model frame's direction of a layer direction and back (a vertical blind swaps x and y). */
static void to_model(const struct build *B, const double in[3], double out[3])
{
    out[0] = B->v->vertical ? in[1] : in[0];
    out[1] = B->v->vertical ? in[0] : in[1];
    out[2] = in[2];
}

static int trip_add(bst_ctx *ctx, struct trip *t, size_t row, size_t col, double val)
{
    if (t->nnz == t->cap) {
        size_t cap = t->cap ? 2 * t->cap : 1024;
        size_t *r = bsti_alloc_array(ctx, cap, sizeof *r), *c = bsti_alloc_array(ctx, cap, sizeof *c);
        double *v = bsti_alloc_array(ctx, cap, sizeof *v);
        if (!r || !c || !v) {
            bsti_free(ctx, r), bsti_free(ctx, c), bsti_free(ctx, v);
            return BST_ENOMEM;
        }
        if (t->nnz) {
            memcpy(r, t->row, t->nnz * sizeof *r);
            memcpy(c, t->col, t->nnz * sizeof *c);
            memcpy(v, t->val, t->nnz * sizeof *v);
        }
        bsti_free(ctx, t->row), bsti_free(ctx, t->col), bsti_free(ctx, t->val);
        t->row = r, t->col = c, t->val = v, t->cap = cap;
    }
    t->row[t->nnz] = row, t->col[t->nnz] = col, t->val[t->nnz] = val;
    t->nnz++;
    return BST_OK;
}

static void trip_free(bst_ctx *ctx, struct trip *t)
{
    bsti_free(ctx, t->row), bsti_free(ctx, t->col), bsti_free(ctx, t->val);
    memset(t, 0, sizeof *t);
}

/* Flux x of column col leaving along the model direction dir (out of the interior side when
 * interior): into the entry of its patch and component. */
static void col_add(const struct build *B, struct column *col, const double dir[3], int interior,
                    double x)
{
    double d[3];
    to_model(B, dir, d);
    size_t row = bst_basis_patch(B->b, d);
    if (x == 0.0 || row >= B->n)
        return;
    int c = interior ? (col->back ? BST_RB : BST_TF) : (col->back ? BST_TB : BST_RF);
    size_t a = 0;
    while (a < col->n && (col->row[a] != row || col->comp[a] != c))
        a++;
    if (a == col->n) {
        if (col->n == col->cap)
            return; /* cannot happen: cap counts every point of every direction */
        col->row[a] = row, col->comp[a] = c, col->val[a] = 0.0, col->n++;
    }
    col->val[a] += x / bst_basis_lambda(B->b)[row];
}

/* The profile angle phi = atan2(a, |b|) of a model direction, as a position in a table of
 * BSTI_VN_TABLE intervals over [-pi/2, pi/2]: the node below and the weight of the one above. */
static size_t table_pos(const double d[3], double *f)
{
    double x = (atan2(d[1], fabs(d[2])) / M_PI + 0.5) * VN_TABLE;
    x = fmin(fmax(x, 0.0), (double)VN_TABLE);
    size_t k = (size_t)x;
    if (k >= VN_TABLE)
        k = VN_TABLE - 1;
    *f = x - (double)k;
    return k;
}

/* The hit rows (BSTI_VN_DEP + ne values) and the views (ne values) of every node and both sides
 * (side 1: light travelling towards -Z).  A view is the same traced quantity as the first
 * arrivals of the reversed direction (rays entering along -(a, b) through the exit opening, each
 * hit weighted rs^n), over the whole opening where the hits are over its blocked part: the view
 * is taken as that blocked share times the reversed node's arrivals (node VN_TABLE - k of the
 * other side), so that first arrivals and views agree to rounding and a diffuse blind is as
 * reciprocal as its exchange (matte slats, k = 4: 5e-9 of the largest transmission; 9e-7 with
 * views traced over the opening's own positions).  Rough mirror slats trace their arrivals with
 * rough facets and their views without: those keep bsti_vn_view, as do curved slats and a sheet. */
static void node_dir(size_t k, int side, double *a, double *b)
{
    /* the ends are grazing in the profile plane: just inside */
    double phi = fmin(fmax(((double)k / VN_TABLE - 0.5) * M_PI, -M_PI / 2 + 1e-9), M_PI / 2 - 1e-9);
    *a = sin(phi), *b = side ? -cos(phi) : cos(phi);
}

/* Whether the views are traced (bsti_vn_view) rather than taken from the reversed direction's
 * first arrivals (above). */
static int views_traced(const struct build *B)
{
    return B->g.curved || B->g.sheet || (B->g.rs > 0 && B->v->roughness > 0);
}

/* Jobs [q0, q1) of a loop whose jobs are traced alone and write only their own results (the
 * tables' nodes, the outgoing views), on one of the context's threads. */
struct range_part {
    struct build *B;
    size_t q0, q1;
};

/* fn on the jobs 0 .. jobs - 1, shared out in runs among the context's threads. */
static void run_ranges(struct build *B, size_t jobs, void *(*fn)(void *))
{
    struct range_part part[BST_THREADS_MAX];
    size_t nw = (size_t)bsti_ctx_workers_no_alloc(B->ctx, jobs);
    for (size_t t = 0; t < nw; t++)
        part[t] = (struct range_part){B, jobs * t / nw, jobs * (t + 1) / nw};
    bsti_run_parts(part, sizeof *part, nw, fn);
}

/* Table nodes (node k of side s as job s (VN_TABLE + 1) + k). */
static void *nodes_run(void *arg)
{
    const struct range_part *t = arg;
    struct build *B = t->B;
    size_t nh = BSTI_VN_DEP + B->ne, nodes = VN_TABLE + 1;
    int traced = views_traced(B);
    for (size_t q = t->q0; q < t->q1; q++) {
        size_t side = q / nodes, k = q % nodes;
        double a, b;
        node_dir(k, (int)side, &a, &b);
        if (!B->g.curved) /* curved slats trace each incident direction (incident_curved) */
            bsti_vn_hit(&B->g, a, b, B->v->roughness / sqrt(2.0), B->hit[side] + k * nh);
        if (traced)
            bsti_vn_view(&B->g, a, b, B->see[side] + k * B->ne);
    }
    return NULL;
}

/* The tables, their nodes shared out among the context's threads (each node traced alone). */
static int make_tables(struct build *B)
{
    size_t nh = BSTI_VN_DEP + B->ne, nodes = VN_TABLE + 1;
    int traced = views_traced(B);
    for (int side = 0; side < 2; side++) {
        B->hit[side] = bsti_alloc_array(B->ctx, nodes * nh, sizeof(double));
        B->see[side] = bsti_alloc_array(B->ctx, nodes * B->ne, sizeof(double));
        if (!B->hit[side] || !B->see[side])
            return BST_ENOMEM;
    }
    run_ranges(B, 2 * nodes, nodes_run);
    for (int side = 0; side < 2 && !traced; side++)
        for (size_t k = 0; k < nodes; k++) { /* the reversed direction: node VN_TABLE - k, other side */
            double a, b;
            node_dir(VN_TABLE - k, 1 - side, &a, &b);
            double blocked = 1.0 - bsti_vn_open(&B->g, a, b);
            const double *h = B->hit[1 - side] + (VN_TABLE - k) * nh + BSTI_VN_DEP;
            for (size_t e = 0; e < B->ne; e++)
                B->see[side][k * B->ne + e] = blocked * h[e];
        }
    return BST_OK;
}

/* Add x times the linear interpolation of rows k and k + 1 (len values, f the weight of k + 1) of
 * tab to acc. */
static void add_interp(const double *tab, size_t len, size_t k, double f, double x, double *acc)
{
    const double *r0 = tab + k * len, *r1 = r0 + len;
    for (size_t e = 0; e < len; e++)
        acc[e] += x * ((1 - f) * r0[e] + f * r1[e]);
}

/* d reflected by the plane of normal n (unit). */
static void reflect(const double d[3], const double n[3], double r[3])
{
    double dn = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
    for (int k = 0; k < 3; k++)
        r[k] = d[k] - 2 * dn * n[k];
}

/* Flux x leaving along d after `bounces` (mean) mirror bounces, odd or even in number, into the
 * column's accumulator, turned by the slats' roughness: RADIANCE's metal (Ward's lobe) tilts the
 * facet normals by slopes that are Gaussian with variance roughness^2 / 2 in each of two
 * directions.  In the profile plane the turn is drawn from the mean and spread (mom: flux, flux x
 * turn, flux x turn^2) of rays traced with their own rough facets (bsti_vn_hit), which carry the
 * geometry's choice of which turned rays meet another slat; out of the plane, a path of n bounces
 * is taken as one facet tilted along X with n times the variance.  (g1, g2) is the point of the
 * standard Gaussian this direction draws (quadrature point, see struct build).  A direction turned
 * past the horizon counts unturned. */
static void spread(struct build *B, const double d[3], int odd, double bounces, double x,
                   const double g[2], const double mom[3], struct column *col)
{
    const double nA[3] = {0.0, B->g.nA[0], B->g.nA[1]};
    double sigma = B->v->roughness * sqrt(fmax(bounces, 1.0) / 2), flat[3], dir[3];
    if (odd)
        reflect(d, nA, flat);
    else
        memcpy(flat, d, sizeof flat);
    memcpy(dir, flat, sizeof dir);
    if (sigma > 0 && !B->g.sheet && mom[0] > 0) {
        /* in the profile plane: the traced rough rays' mean turn and spread */
        double mu = mom[1] / mom[0], sd = sqrt(fmax(mom[2] / mom[0] - mu * mu, 0.0));
        double turn = mu + sd * g[1], r = hypot(flat[1], flat[2]), psi = atan2(flat[1], flat[2]) + turn;
        double e[3] = {flat[0], r * sin(psi), r * cos(psi)}, once[3];
        /* out of it: a flat bounce and one on a facet tilted along X */
        double s1 = sigma * g[0], len = sqrt(1 + s1 * s1);
        double nf[3] = {s1 / len, nA[1] / len, nA[2] / len};
        reflect(e, nA, once);
        reflect(once, nf, dir);
        if ((dir[2] > 0) != (flat[2] > 0))
            memcpy(dir, flat, sizeof dir);
    }
    col_add(B, col, dir, flat[2] > 0, x);
}

/* The quadrature points (struct build): the first np points of the Halton sequence in bases 2, 3,
 * 5, 7, the last two turned into a standard 2-D Gaussian point (Box-Muller). */
static int make_points(struct build *B)
{
    static const int base[4] = {2, 3, 5, 7};
    B->pts = bsti_alloc_array(B->ctx, 4 * B->np, sizeof *B->pts);
    if (!B->pts)
        return BST_ENOMEM;
    for (size_t k = 0; k < B->np; k++) {
        double h[4];
        for (int dim = 0; dim < 4; dim++) { /* radical inverse of k + 1 */
            double f = 1.0, r = 0.0;
            for (size_t i = k + 1; i > 0; i /= (size_t)base[dim]) {
                f /= base[dim];
                r += f * (double)(i % (size_t)base[dim]);
            }
            h[dim] = r;
        }
        double rad = sqrt(-2.0 * log(1.0 - h[2])); /* h < 1 */
        B->pts[4 * k] = h[0], B->pts[4 * k + 1] = h[1];
        B->pts[4 * k + 2] = rad * cos(2 * M_PI * h[3]), B->pts[4 * k + 3] = rad * sin(2 * M_PI * h[3]);
    }
    return BST_OK;
}

/* Whether patch i's quadrature points are mirrored (u -> 1 - u; a vertical blind's v -> 1 - v)
 * on side `back`: on a Shirley-Chiu basis those of the half of the square beyond the slats'
 * axis, so that the directions averaged for a patch and for its mirror image about the plane
 * through the normal and the slats (mirror.h: x = 0 for a horizontal blind) are each other's
 * images, the layer's matrices commute with that mirror to rounding, and a stack of such layers
 * and panes has its dense solves split in halves (solve.c).  On the back the rule of the
 * point-reflected patch a(i), whose coordinates sample() reflects: the opposite half. */
static int mirrored(const struct build *B, size_t i, int back)
{
    if (bst_basis_order(B->b) == 0)
        return 0;
    return !bsti_mirror_first((size_t)1 << bst_basis_order(B->b), i, B->v->vertical) != (back != 0);
}

/* Patch i's mirror image (mirrored()), the representative of the pair: min(i, image). */
static size_t pair_first(const struct build *B, size_t i)
{
    if (bst_basis_order(B->b) == 0)
        return i;
    size_t m = bsti_mirror_image((size_t)1 << bst_basis_order(B->b), i, B->v->vertical);
    return m < i ? m : i;
}

/* Quadrature point p of patch i as a layer direction: incident from the exterior or leaving
 * through the interior opening (back 0, light along +Z) at the point's (u, v) (mirrored on half
 * the patches: mirrored()); incident from the interior or leaving through the exterior opening
 * (back 1, along -Z) at the point-reflected coordinates (bsti_basis_antipode_uv).  So the
 * directions averaged for patch a(i) on one side are exactly the reverses of those averaged for
 * patch i on the other, and every part that is reciprocal direction by direction (the
 * unobstructed light, the strips' first arrivals against their views) is reciprocal patch by
 * patch: Tf(o, i) = Tb(a(i), a(o)), R(o, i) = R(a(i), a(o)).  With the same (u, v) on both sides,
 * the Halton points (not symmetric in a patch) left the unobstructed light alone 0.2 % of the
 * largest transmission off (k = 4, black slats).  *lobe (may be NULL): the point's Gaussian
 * point for the slats' roughness (spread()), its component along the slats mirrored with the
 * direction. */
static void sample(const struct build *B, size_t i, size_t p, int back, double s[3], double lobe[2])
{
    double u = B->pts[4 * p], v = B->pts[4 * p + 1];
    int m = mirrored(B, i, back);
    if (m && B->v->vertical)
        v = 1.0 - v;
    else if (m)
        u = 1.0 - u;
    if (back)
        bsti_basis_antipode_uv(B->b, i, &u, &v);
    bst_basis_sample(B->b, i, u, v, s);
    if (back)
        s[2] = -s[2];
    if (lobe) {
        lobe[0] = m ? -B->pts[4 * p + 2] : B->pts[4 * p + 2];
        lobe[1] = B->pts[4 * p + 3];
    }
}

/* One incident patch i from side col->back: its column's entries (into the worker's tr) and
 * first arrivals. */
static int incident_patch(struct build *B, struct column *col, double *row, struct trip *tr)
{
    const double wq = 1.0 / (double)B->np;
    const size_t nh = BSTI_VN_DEP + B->ne, i = col->i;
    double *dep = B->dep[col->back] + i * B->ne;
    col->n = 0;
    for (size_t p = 0; p < B->np; p++) {
            double s[3], d[3], f, lobe[2];
            sample(B, i, p, col->back, s, lobe);
            to_model(B, s, d);
            if (fabs(d[2]) < 1e-300) /* grazing: no flux crosses the blind's plane */
                continue;
            double open = bsti_vn_open(&B->g, d[1], d[2]);
            size_t k = table_pos(d, &f);
            memset(row, 0, nh * sizeof *row);
            add_interp(B->hit[col->back], nh, k, f, 1.0, row);
            col_add(B, col, d, !col->back, open * wq);
            double hit = (1.0 - open) * wq;
            if (row[BSTI_VN_EVEN] > 0)
                spread(B, d, 0, row[BSTI_VN_EVEN_N] / row[BSTI_VN_EVEN], hit * row[BSTI_VN_EVEN], lobe, row + BSTI_VN_EVEN_W, col);
            if (row[BSTI_VN_ODD] > 0)
                spread(B, d, 1, row[BSTI_VN_ODD_N] / row[BSTI_VN_ODD], hit * row[BSTI_VN_ODD], lobe, row + BSTI_VN_ODD_W, col);
            for (size_t e = 0; e < B->ne; e++)
                dep[e] += hit * row[BSTI_VN_DEP + e];
        }
    int rc = BST_OK;
    for (size_t a = 0; a < col->n && rc >= 0; a++)
        rc = trip_add(B->ctx, &tr[col->comp[a]], col->row[a], i, col->val[a]);
    return rc;
}

/* Flux x of a column leaving along the model direction dir (out of the interior side when
 * interior) into the worker's acc (incident_curved). */
static void acc_add(const struct build *B, struct worker *w, size_t *nt, const double dir[3],
                    int interior, double x)
{
    double d[3];
    to_model(B, dir, d);
    size_t row = bst_basis_patch(B->b, d), a = 2 * row + (interior != 0);
    if (x == 0.0 || row >= B->n)
        return;
    if (w->acc[a] == 0.0)
        w->touched[(*nt)++] = a;
    w->acc[a] += x / bst_basis_lambda(B->b)[row];
}

/* The Halton sequence's radical inverse of k in base `base`. */
static double radical_inverse(size_t k, size_t base)
{
    double f = 1.0, r = 0.0;
    for (; k > 0; k /= base) {
        f /= (double)base;
        r += f * (double)(k % base);
    }
    return r;
}

/* One incident patch i from side col->back among curved slats: each direction's unobstructed
 * share exactly, the rest as BSTI_VN_CURVED_RAYS rays entering across the shadow of a slat
 * (stratified, offset by a fifth Halton dimension), each followed with its own rough facets to
 * where it leaves; out of the profile plane a path of n bounces is turned as by one facet of its
 * last bounce tilted along X with n times the variance (as spread() does for flat slats). */
static int incident_curved(struct build *B, struct column *col, struct worker *w)
{
    const double wq = 1.0 / (double)B->np, sigma = B->v->roughness / sqrt(2.0);
    const size_t i = col->i, nr = BSTI_VN_CURVED_RAYS;
    double *dep = B->dep[col->back] + i * B->ne;
    size_t nt = 0;
    for (size_t p = 0; p < B->np; p++) {
        double s[3], d[3], y0, z0, span, out[5], lobe[2];
        sample(B, i, p, col->back, s, lobe);
        to_model(B, s, d);
        double r = hypot(d[1], d[2]), u[2] = {d[1] / r, d[2] / r};
        if (fabs(d[2]) < 1e-300)
            continue;
        double open = bsti_vn_open(&B->g, d[1], d[2]), hit = (1.0 - open) * wq / (double)nr;
        acc_add(B, w, &nt, d, !col->back, open * wq);
        if (open >= 1.0 || !bsti_vn_curved_entries(&B->g, u[0], u[1], &y0, &z0, &span))
            continue;
        double off = radical_inverse(p + 1, 11);
        for (size_t k = 0; k < nr; k++) {
            double start[2] = {y0 + span * ((double)k + off) / (double)nr, z0};
            unsigned long seed = ((2 * pair_first(B, i) + (size_t)col->back) * B->np + p) * nr + k;
            long n = bsti_vn_curved_trace(&B->g, start, u, LONG_MIN, 0, hit, dep, sigma, seed, out);
            double e[3] = {d[0], r * out[1], r * out[2]}, dir[3];
            memcpy(dir, e, sizeof dir);
            if (B->v->roughness > 0 && n > 0) {
                double s1 = B->v->roughness * sqrt((double)n / 2) * lobe[0], len = sqrt(1 + s1 * s1);
                double nl[3] = {0.0, out[3], out[4]}, once[3];
                double nf[3] = {s1 / len, out[3] / len, out[4] / len};
                reflect(e, nl, once);
                reflect(once, nf, dir);
                if ((dir[2] > 0) != (e[2] > 0))
                    memcpy(dir, e, sizeof dir);
            }
            acc_add(B, w, &nt, dir, e[2] > 0, out[0]);
        }
    }
    int rc = BST_OK;
    for (size_t k = 0; k < nt; k++) {
        size_t a = w->touched[k], row = a / 2;
        int c = a % 2 ? (col->back ? BST_RB : BST_TF) : (col->back ? BST_TB : BST_RF);
        if (rc >= 0)
            rc = trip_add(B->ctx, &w->tr[c], row, i, w->acc[a]);
        w->acc[a] = 0.0;
    }
    return rc;
}

/* Columns q0..q1 - 1 of trace_incident (side q / n, patch q % n) on one thread. */
struct incident_part {
    struct build *B;
    size_t q0, q1;
    struct worker w;
    int rc;
};

static void *incident_run(void *arg)
{
    struct incident_part *t = arg;
    struct build *B = t->B;
    struct column col = {0};
    double *row = NULL;
    int rc = BST_OK;
    if (B->g.curved) {
        t->w.acc = bsti_calloc(B->ctx, 2 * B->n, sizeof *t->w.acc);
        t->w.touched = bsti_alloc_array(B->ctx, 2 * B->n, sizeof *t->w.touched);
        rc = t->w.acc && t->w.touched ? BST_OK : BST_ENOMEM;
    } else {
        col.cap = 3 * B->np + 1; /* open, even, odd per direction */
        col.row = bsti_alloc_array(B->ctx, col.cap, sizeof *col.row);
        col.comp = bsti_alloc_array(B->ctx, col.cap, sizeof *col.comp);
        col.val = bsti_alloc_array(B->ctx, col.cap, sizeof *col.val);
        row = bsti_alloc_array(B->ctx, BSTI_VN_DEP + B->ne, sizeof *row);
        rc = col.row && col.comp && col.val && row ? BST_OK : BST_ENOMEM;
    }
    for (size_t q = t->q0; q < t->q1 && rc >= 0; q++) {
        col.back = q >= B->n, col.i = q % B->n;
        rc = B->g.curved ? incident_curved(B, &col, &t->w) : incident_patch(B, &col, row, t->w.tr);
    }
    bsti_free(B->ctx, col.row), bsti_free(B->ctx, col.comp), bsti_free(B->ctx, col.val);
    bsti_free(B->ctx, row);
    bsti_free(B->ctx, t->w.acc), bsti_free(B->ctx, t->w.touched);
    t->rc = rc;
    return NULL;
}

/* src's entries appended to dst's (then src freed). */
static int trip_append(bst_ctx *ctx, struct trip *dst, struct trip *src)
{
    int rc = BST_OK;
    if (!dst->nnz) { /* taken whole */
        trip_free(ctx, dst);
        *dst = *src;
        memset(src, 0, sizeof *src);
        return BST_OK;
    }
    if (src->nnz) {
        size_t cap = dst->nnz + src->nnz;
        size_t *r = bsti_alloc_array(ctx, cap, sizeof *r), *c = bsti_alloc_array(ctx, cap, sizeof *c);
        double *v = bsti_alloc_array(ctx, cap, sizeof *v);
        if (r && c && v) {
            memcpy(r, dst->row, dst->nnz * sizeof *r), memcpy(r + dst->nnz, src->row, src->nnz * sizeof *r);
            memcpy(c, dst->col, dst->nnz * sizeof *c), memcpy(c + dst->nnz, src->col, src->nnz * sizeof *c);
            memcpy(v, dst->val, dst->nnz * sizeof *v), memcpy(v + dst->nnz, src->val, src->nnz * sizeof *v);
            bsti_free(ctx, dst->row), bsti_free(ctx, dst->col), bsti_free(ctx, dst->val);
            *dst = (struct trip){r, c, v, cap, cap};
        } else {
            bsti_free(ctx, r), bsti_free(ctx, c), bsti_free(ctx, v);
            rc = BST_ENOMEM;
        }
    }
    trip_free(ctx, src);
    return rc;
}

/* The direct and mirrored parts of every column and the first arrivals, both sides: the 2 n
 * columns shared out among the context's threads in runs, each column traced alone (its own
 * first arrivals, and seeds from its own indices), the runs' entries joined in their order. */
static int trace_incident(struct build *B)
{
    struct incident_part part[BST_THREADS_MAX];
    size_t jobs = 2 * B->n, nw = (size_t)bsti_ctx_workers(B->ctx, jobs);
    for (size_t t = 0; t < nw; t++)
        part[t] = (struct incident_part){.B = B, .q0 = jobs * t / nw, .q1 = jobs * (t + 1) / nw};
    bsti_run_parts(part, sizeof *part, nw, incident_run);
    int rc = BST_OK;
    for (size_t t = 0; t < nw; t++) {
        if (part[t].rc < 0 && rc >= 0)
            rc = part[t].rc;
        for (int c = 0; c < BST_NCOMP; c++) {
            if (rc < 0)
                trip_free(B->ctx, &part[t].w.tr[c]);
            else
                rc = trip_append(B->ctx, &B->tr[c], &part[t].w.tr[c]);
        }
    }
    return rc;
}

/* Outgoing patches of trace_views (exit q / n, patch q % n). */
static void *views_run(void *arg)
{
    const struct range_part *t = arg;
    struct build *B = t->B;
    double wq = 1.0 / (double)B->np;
    for (size_t q = t->q0; q < t->q1; q++) {
        int exit = q >= B->n;
        size_t o = q % B->n;
        for (size_t p = 0; p < B->np; p++) {
            double s[3], d[3], f;
            sample(B, o, p, !exit, s, NULL);
            to_model(B, s, d);
            size_t k = table_pos(d, &f);
            add_interp(B->see[!exit], B->ne, k, f, wq, B->view[exit] + o * B->ne);
        }
    }
    return NULL;
}

/* The strips' views from every outgoing patch of both openings (view[1]: the interior one, whose
 * light travels along +Z: table side 0), the patches shared out among the context's threads. */
static void trace_views(struct build *B)
{
    run_ranges(B, 2 * B->n, views_run);
}

/* x := A^-1 x for the ne x ne matrix a (destroyed) and nrhs columns x (ne x nrhs, column-major),
 * by Gaussian elimination with partial pivoting.  I - E G is diagonally dominant by columns
 * (each strip's emission E <= 1 and G's columns sum to at most 1), so no pivot is small. */
static void small_solve(size_t ne, double *a, double *x, size_t nrhs)
{
    for (size_t k = 0; k < ne; k++) {
        size_t piv = k;
        for (size_t r = k + 1; r < ne; r++)
            if (fabs(a[k * ne + r]) > fabs(a[k * ne + piv]))
                piv = r;
        if (piv != k) {
            for (size_t c = 0; c < ne; c++) {
                double t = a[c * ne + k];
                a[c * ne + k] = a[c * ne + piv], a[c * ne + piv] = t;
            }
            for (size_t c = 0; c < nrhs; c++) {
                double t = x[c * ne + k];
                x[c * ne + k] = x[c * ne + piv], x[c * ne + piv] = t;
            }
        }
        for (size_t r = k + 1; r < ne; r++) {
            double f = a[k * ne + r] / a[k * ne + k];
            if (f == 0.0)
                continue;
            for (size_t c = k; c < ne; c++)
                a[c * ne + r] -= f * a[c * ne + k];
            for (size_t c = 0; c < nrhs; c++)
                x[c * ne + r] -= f * x[c * ne + k];
        }
    }
    for (size_t c = 0; c < nrhs; c++)
        for (size_t k = ne; k-- > 0;) {
            double sum = x[c * ne + k];
            for (size_t j = k + 1; j < ne; j++)
                sum -= a[j * ne + k] * x[c * ne + j];
            x[c * ne + k] = sum / a[k * ne + k];
        }
}

/* dep[side] := the strips' diffuse emission Q = (I - E G)^-1 E D, scaled by s m / (pi w), the
 * radiance per unit emitted flux of a strip as the views count it. */
static int radiosity(struct build *B)
{
    size_t ne = B->ne, m = (size_t)B->g.m;
    double *gm = bsti_alloc_array(B->ctx, ne * ne, sizeof *gm);
    double *a = bsti_alloc_array(B->ctx, ne * ne, sizeof *a);
    double *em = bsti_alloc_array(B->ctx, ne, sizeof *em);
    if (!gm || !a || !em) {
        bsti_free(B->ctx, gm), bsti_free(B->ctx, a), bsti_free(B->ctx, em);
        return BST_ENOMEM;
    }
    if (B->v->r_up > 0 || B->v->r_down > 0 || B->v->t > 0)
        bsti_vn_exchange(&B->g, gm);
    else /* nothing emitted diffusely: the exchange would be multiplied by zero (and between
            lossless mirrors, rs = 1, its series of bounces has no finite sum) */
        memset(gm, 0, ne * ne * sizeof *gm);
    for (size_t e = 0; e < ne; e++)
        em[e] = e < m ? B->v->r_up : B->v->r_down;
    /* E = diag(r) + t P, P the face behind (strip e of one face <-> strip e of the other) */
    for (size_t j = 0; j < ne; j++)
        for (size_t e = 0; e < ne; e++)
            a[j * ne + e] = (e == j) - em[e] * gm[e * ne + j] - B->v->t * gm[((e + m) % ne) * ne + j];
    double scale = B->g.s * (double)m / (M_PI * B->g.len);
    for (int side = 0; side < 2; side++) {
        double *d = B->dep[side];
        for (size_t i = 0; i < B->n; i++) {
            double *col = d + i * ne, tmp[2000];
            for (size_t e = 0; e < ne; e++)
                tmp[e] = em[e] * col[e] + B->v->t * col[(e + m) % ne];
            memcpy(col, tmp, ne * sizeof *col);
        }
        if (side == 0)
            memcpy(gm, a, ne * ne * sizeof *gm); /* a copy for the second side's solve */
        small_solve(ne, side == 0 ? a : gm, d, B->n);
        for (size_t k = 0; k < ne * B->n; k++)
            d[k] *= scale;
    }
    bsti_free(B->ctx, gm), bsti_free(B->ctx, a), bsti_free(B->ctx, em);
    return BST_OK;
}

/* Whether every component's sparse part is on the diagonal. */
static int sparse_diagonal(const struct build *B)
{
    for (int c = 0; c < BST_NCOMP; c++)
        for (size_t k = 0; k < B->tr[c].nnz; k++)
            if (B->tr[c].row[k] != B->tr[c].col[k])
                return 0;
    return 1;
}

/* B->W = [U_ext | U_int | Q_ext^T | Q_int^T], row x the strips' views from patch x and their
 * emissions for light incident on x (zeros left out), when the components can be factored over
 * it: a diagonal sparse part and a rank (4 x 2m) below BSTI_LR_DENSE_SHARE of N. */
static int make_map(struct build *B)
{
    size_t n = B->n, ne = B->ne, nnz = 0;
    if (!sparse_diagonal(B) || (double)(4 * ne) >= BSTI_LR_DENSE_SHARE * (double)n)
        return BST_OK;
    const double *blk[4] = {B->view[0], B->view[1], B->dep[0], B->dep[1]};
    for (int q = 0; q < 4; q++)
        for (size_t k = 0; k < n * ne; k++)
            nnz += blk[q][k] != 0.0;
    int rc = bsti_lr_map_new(B->ctx, n, 4 * ne, nnz, &B->W);
    if (rc < 0)
        return rc;
    bsti_lr_map *W = B->W;
    W->k = bst_basis_order(B->b);
    nnz = 0;
    for (size_t x = 0; x < n; x++) {
        W->start[x] = nnz;
        for (int q = 0; q < 4; q++)
            for (size_t e = 0; e < ne; e++)
                if (blk[q][x * ne + e] != 0.0)
                    W->col[nnz] = q * ne + e, W->w[nnz++] = blk[q][x * ne + e];
    }
    W->start[n] = nnz;
    return BST_OK;
}

/* Component c factored over B->W: its diagonal, and K pairing the views of its exit side (block
 * exit) with the emissions for its incident side (block 2 + in), strip by strip. */
static int component_factored(struct build *B, int c, int in, int exit, bst_mat **out)
{
    struct trip *t = &B->tr[c];
    size_t n = B->n, ne = B->ne, r = 4 * ne;
    double *d = t->nnz ? bsti_alloc_array(B->ctx, n, sizeof *d) : NULL;
    double *K = bsti_alloc_array(B->ctx, r * r, sizeof *K);
    int rc = K && (d || !t->nnz) ? BST_OK : BST_ENOMEM;
    if (rc >= 0) {
        memset(K, 0, r * r * sizeof *K);
        for (size_t e = 0; e < ne; e++)
            K[(size_t)exit * ne + e + r * ((2 + (size_t)in) * ne + e)] = 1.0;
        if (d) {
            memset(d, 0, n * sizeof *d);
            for (size_t k = 0; k < t->nnz; k++)
                d[t->row[k]] += t->val[k];
        }
        bsti_lr *lr;
        rc = bsti_lr_new(B->ctx, B->W, d, NULL, K, NULL, &lr);
        if (rc >= 0)
            rc = bsti_mat_from_lr(B->ctx, lr, out);
    }
    bsti_free(B->ctx, d), bsti_free(B->ctx, K);
    return rc;
}

/* Component c's sparse part alone (zero where it has none). */
static int sparse_part(struct build *B, int c, bst_mat **out)
{
    const struct trip *t = &B->tr[c];
    return t->nnz ? bst_mat_new_sparse(B->ctx, B->n, B->n, t->nnz, t->row, t->col, t->val, out)
                  : bst_mat_new_zero(B->ctx, B->n, B->n, out);
}

/* Component c as PLUS_LR (mat.h): its sparse part plus U W^T, U = the strips' views from the
 * outgoing patches of its exit side (N x 2m), W = their emissions for its incident side: a blind
 * with a mirror part and diffuse slats, N^2 values dense (2 GiB at k = 7), 2 N 2m so. */
static int component_plus(struct build *B, int c, int in, int exit, bst_mat **out)
{
    size_t n = B->n, ne = B->ne;
    bst_mat *base = NULL;
    double *u = bsti_alloc_array(B->ctx, n * ne, sizeof *u), *w = bsti_alloc_array(B->ctx, n * ne, sizeof *w);
    int rc = u && w ? BST_OK : BST_ENOMEM;
    if (rc >= 0)
        rc = sparse_part(B, c, &base);
    if (rc < 0) {
        bsti_free(B->ctx, u), bsti_free(B->ctx, w);
        return rc;
    }
    for (size_t x = 0; x < n; x++) /* view and dep are ne x n, column x a patch's */
        for (size_t e = 0; e < ne; e++) {
            u[e * n + x] = B->view[exit][x * ne + e];
            w[e * n + x] = B->dep[in][x * ne + e];
        }
    return bsti_mat_plus_new(B->ctx, base, ne, u, w, out);
}

/* Columns a dense single-precision component is made in at a time (of doubles: 32 MiB at k = 7). */
#define VN_FLOAT_COLS 256

/* Component c dense in single precision, made in blocks of columns of doubles, each rounded once
 * as the double path's whole matrix is: no N x N doubles (at k = 7, 2 GiB a component). */
static int component_float(struct build *B, int c, int in, int exit, bst_mat **out)
{
    struct trip *t = &B->tr[c];
    size_t n = B->n, nb = n < VN_FLOAT_COLS ? n : VN_FLOAT_COLS;
    double *w = bsti_alloc_array(B->ctx, n * nb, sizeof *w);
    size_t *start = bsti_alloc_array(B->ctx, n + 1, sizeof *start);
    size_t *order = bsti_alloc_array(B->ctx, t->nnz ? t->nnz : 1, sizeof *order);
    int rc = w && start && order ? bst_mat_new_dense(B->ctx, n, n, BST_FLOAT, out) : BST_ENOMEM;
    if (rc >= 0) {
        /* the sparse entries by column (a counting sort: each column's in their own order) */
        memset(start, 0, (n + 1) * sizeof *start);
        for (size_t k = 0; k < t->nnz; k++)
            start[t->col[k] + 1]++;
        for (size_t j = 0; j < n; j++)
            start[j + 1] += start[j];
        for (size_t k = 0; k < t->nnz; k++)
            order[start[t->col[k]]++] = k;
        for (size_t j = n; j > 0; j--)
            start[j] = start[j - 1];
        start[0] = 0;
        float *m = bst_mat_dense_data(*out);
        for (size_t j0 = 0; j0 < n; j0 += nb) {
            size_t nc = n - j0 < nb ? n - j0 : nb;
            cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)n, (int)nc, (int)B->ne, 1.0,
                        B->view[exit], (int)B->ne, B->dep[in] + j0 * B->ne, (int)B->ne, 0.0, w,
                        (int)n);
            for (size_t k = start[j0]; k < start[j0 + nc]; k++)
                w[(t->col[order[k]] - j0) * n + t->row[order[k]]] += t->val[order[k]];
            for (size_t x = 0; x < n * nc; x++)
                m[j0 * n + x] = (float)w[x];
        }
    }
    bsti_free(B->ctx, w), bsti_free(B->ctx, start), bsti_free(B->ctx, order);
    return rc;
}

/* Component c: its sparse part, plus (diffuse slats) U_x^T Q_y: factored over B->W where there is
 * one, else sparse plus low rank where the rank is small beside N, else as a dense matrix (in the
 * blind's precision). */
static int component(struct build *B, int c, int diffuse, bst_mat **out)
{
    struct trip *t = &B->tr[c];
    size_t n = B->n;
    if (!diffuse)
        return sparse_part(B, c, out);
    int in = c == BST_TB || c == BST_RB, exit = c == BST_TF || c == BST_RB;
    if (B->W)
        return component_factored(B, c, in, exit, out);
    if (bsti_plus_fits(n, n, B->ne))
        return component_plus(B, c, in, exit, out);
    if (B->v->precision == BST_FLOAT)
        return component_float(B, c, in, exit, out);
    int rc = bst_mat_new_dense(B->ctx, n, n, BST_DOUBLE, out);
    if (rc < 0)
        return rc;
    double *m = bst_mat_dense_data(*out);
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)n, (int)n, (int)B->ne, 1.0,
                B->view[exit], (int)B->ne, B->dep[in], (int)B->ne, 0.0, m, (int)n);
    for (size_t k = 0; k < t->nnz; k++)
        m[t->col[k] * n + t->row[k]] += t->val[k];
    return BST_OK;
}

static void build_free(struct build *B)
{
    for (int c = 0; c < BST_NCOMP; c++)
        trip_free(B->ctx, &B->tr[c]);
    for (int s = 0; s < 2; s++) {
        bsti_free(B->ctx, B->dep[s]), bsti_free(B->ctx, B->view[s]);
        bsti_free(B->ctx, B->hit[s]), bsti_free(B->ctx, B->see[s]);
    }
    bsti_free(B->ctx, B->pts);
    bsti_lr_map_free(B->ctx, B->W);
}

/* The four components into channels ch[0..nch) of l (the first its own, the others copies). */
static int fill_layer(struct build *B, bst_layer *l, size_t nch, const size_t *ch)
{
    int diffuse = B->v->r_up > 0 || B->v->r_down > 0 || B->v->t > 0, rc = BST_OK;
    if (diffuse)
        rc = make_map(B);
    for (int c = 0; c < BST_NCOMP && rc >= 0; c++) {
        bst_mat *m = NULL;
        rc = component(B, c, diffuse, &m);
        if (rc >= 0 && B->v->precision == BST_FLOAT && bst_mat_structure(m) == BST_DENSE &&
            bst_mat_precision(m) == BST_DOUBLE) {
            bst_mat *f; /* at once: one component's doubles at a time */
            rc = bst_mat_convert(B->ctx, m, BST_DENSE, BST_FLOAT, &f);
            bst_mat_free(m);
            m = rc >= 0 ? f : NULL;
        }
        for (size_t k = 1; k < nch && rc >= 0; k++) {
            bst_mat *copy;
            rc = bst_mat_convert(B->ctx, m, bst_mat_structure(m), bst_mat_precision(m), &copy);
            if (rc >= 0)
                rc = bst_layer_set(B->ctx, l, ch[k], (bst_comp)c, copy);
        }
        if (rc >= 0)
            rc = bst_layer_set(B->ctx, l, ch[0], (bst_comp)c, m);
        else
            bst_mat_free(m);
    }
    return rc;
}

/* The blind of slat values v into channels ch[0..nch) of l. */
static int make_band(bst_ctx *ctx, const bst_venetian *v, const bst_basis *basis, bst_layer *l,
                     size_t nch, const size_t *ch)
{
    struct build B;
    memset(&B, 0, sizeof B);
    B.ctx = ctx, B.b = basis, B.v = v;
    int rc = BST_OK, nq = v->samples, k = bst_basis_order(basis); /* 0 for Klems */
    if (!nq) /* automatic: k = 7 as much work as k = 6 (GA at k = 6 falls to 98.7 with 16) */
        nq = k <= 6 ? BST_VENETIAN_SAMPLES : BST_VENETIAN_SAMPLES >> (k - 6);
    B.np = (size_t)nq * (size_t)nq;
    bsti_vn_geom_init(&B.g, v);
    B.n = bst_basis_size(basis);
    B.ne = 2 * (size_t)v->segments;
    for (int s = 0; s < 2; s++) {
        B.dep[s] = bsti_alloc_array(ctx, B.ne * B.n, sizeof *B.dep[s]);
        B.view[s] = bsti_alloc_array(ctx, B.ne * B.n, sizeof *B.view[s]);
        if (!B.dep[s] || !B.view[s])
            rc = BST_ENOMEM;
        else
            memset(B.dep[s], 0, B.ne * B.n * sizeof(double)), memset(B.view[s], 0, B.ne * B.n * sizeof(double));
    }
    if (rc >= 0)
        rc = make_tables(&B);
    if (rc >= 0)
        rc = make_points(&B);
    if (rc >= 0)
        rc = trace_incident(&B);
    if (rc >= 0) {
        trace_views(&B);
        rc = radiosity(&B);
    }
    if (rc >= 0)
        rc = fill_layer(&B, l, nch, ch);
    build_free(&B);
    return rc;
}

int bst_venetian_layer(bst_ctx *ctx, const bst_venetian *v, const bst_basis *basis,
                       size_t nchannels, const char *const *channels, bst_layer **out)
{
    if (!ctx || !v || !basis || !out || (nchannels && !channels))
        return ctx ? bsti_error(ctx, BST_EINVAL, "venetian layer: NULL argument") : BST_EINVAL;
    *out = NULL;
    int rc = bst_venetian_check(ctx, v);
    if (rc < 0)
        return rc;
    static const char *const dual[] = {"Visible", "Solar"};
    if (!nchannels)
        nchannels = 2, channels = dual;
    /* the Solar channel's own slat values, where the spec gives them */
    bst_venetian vs;
    int differ = bsti_vn_solar(v, &vs);
    size_t *ch = bsti_alloc_array(ctx, nchannels, sizeof *ch), nsol = 0, nvis = 0;
    bst_layer *l = NULL;
    if (!ch)
        return bsti_error(ctx, BST_ENOMEM, "venetian layer: out of memory");
    for (size_t c = 0; c < nchannels; c++) /* Solar channels at the end of ch */
        if (differ && strcasecmp(channels[c], "Solar") == 0)
            ch[nchannels - 1 - nsol++] = c;
        else
            ch[nvis++] = c;
    rc = bst_layer_new(ctx, basis, nchannels, channels, &l);
    if (rc >= 0 && v->rule == BST_VENETIAN_CENTRE) /* WINDOW's model: venetian_wce.c */
        rc = bsti_vn_wce_layer(ctx, v, basis, l, nvis, ch, nsol, ch + nvis), nvis = nsol = 0;
    if (rc >= 0 && nvis)
        rc = make_band(ctx, v, basis, l, nvis, ch);
    if (rc >= 0 && nsol)
        rc = make_band(ctx, &vs, basis, l, nsol, ch + nvis);
    bsti_free(ctx, ch);
    if (rc < 0) {
        bst_layer_free(l);
        return rc == BST_ENOMEM ? bsti_error(ctx, rc, "venetian layer: out of memory") : rc;
    }
    *out = l;
    return BST_OK;
}
