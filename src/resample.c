/* resample.c - a BSDF file's components on the basis a stack works in.
 *
 * Tensor trees of rank 4 lie on Shirley-Chiu grids already (ttree.c averages or replicates them
 * onto another order); rank-3 trees are expanded by sampling, at every order on the points of the
 * tree's finest cells (expand3); Klems files and the Klems output basis meet the Shirley-Chiu grid
 * through one table of exact cell/patch overlaps (bsti_overlap, overlap.c), which both directions
 * use, so light is neither lost nor made where a patch boundary cuts a cell.  Conventions:
 * resample.h, basis.h. */
#include <config.h>

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "basis.h"
#include "bsdf.h"
#include "ctx.h"
#include "layer.h"
#include "mat.h"
#include "resample.h"
#include "ttree.h"

/* Sample points per cell when a rank-3 tree is expanded (DESIGN.md 1). */
#define TT3_IN_SAMPLES 2
#define TT3_OUT_SAMPLES 3
/* Order of the Shirley-Chiu grid through which a Klems file goes to another Klems basis (trees go
 * through their own order, which holds them exactly). */
#define KLEMS_VIA_ORDER 6

/* ------------------------------------------------------------------ rank-3 trees */

struct e3 {
    size_t G, n, gd, h0, ni, no, lo;
    const float *grid;        /* h0 slabs of gd x gd: the tree on its finest cells */
    const double *pin, *pol;  /* (radius, azimuth) of the incident and outgoing sample points */
    double *m;
    atomic_size_t next, done; /* quadrant columns handed out, finished */
    bst_ctx *ctx;             /* whose progress the caller's thread reports */
};

/* Column i of the quadrant's incident cells: the sum over its points, in the same order on any
 * thread, so the matrix does not depend on how many share the work. */
static void e3_column(const struct e3 *e, size_t i)
{
    size_t n = e->n, ni = e->ni, no = e->no, gd = e->gd, h0 = e->h0;
    double *col = e->m + n * i;
    memset(col, 0, n * sizeof *col);
    for (size_t si = 0; si < ni; si++) {
        double r = e->pin[2 * (i * ni + si)], phi = e->pin[2 * (i * ni + si) + 1];
        size_t i0 = (size_t)((0.5 - 1e-6 - 0.5 * r) * (double)gd);
        const float *slab = e->grid + (i0 < h0 ? i0 : h0 - 1) * gd * gd;
        for (size_t o = 0; o < n; o++) {
            const double *po = e->pol + 2 * o * no;
            double sum = 0;
            for (size_t s = 0; s < no; s++) {
                size_t cells[4];
                int nc = bsti_sc_polar_cells(po[2 * s], po[2 * s + 1] - phi, gd, cells);
                double v = 0.0;
                for (int j = 0; j < nc; j++)
                    v += slab[cells[j]];
                sum += v / nc;
            }
            col[o] += sum / (double)(no * ni);
        }
    }
}

/* Columns of the quadrant until none is left; `report`: the caller's thread, which reports. */
static void e3_take(struct e3 *e, int report)
{
    size_t side = e->G - e->lo, todo = side * side, q;
    while ((q = atomic_fetch_add(&e->next, 1)) < todo) {
        e3_column(e, (e->lo + q / side) * e->G + e->lo + q % side);
        size_t done = atomic_fetch_add(&e->done, 1) + 1;
        if (report && done % 16 == 0 && done < todo)
            bsti_progress(e->ctx, (double)done / (double)todo, "expanding an isotropic tree");
    }
}

static void *e3_work(void *opaque)
{
    e3_take(opaque, 0);
    return NULL;
}

/* A rank-3 tree on the Shirley-Chiu grid of order k, M[o + N i] as bsti_ttree_expand4 lays it
 * out: the average over TT3_IN_SAMPLES^2 points of incident cell i and TT3_OUT_SAMPLES^2 points of
 * outgoing cell o of the tree at (sin(theta_in) on the lower half of p0, the exit point turned by
 * -phi_in).  A cell coarser than the tree's finest, f = 2^(depth - k) of them per side, takes the
 * points of all its f x f finer cells (bsti_sc_cell_points), so the tree read at k is the block
 * average of the tree read at its depth (tests/test_xml.c): fewer points per cell would miss a
 * peaked distribution's cell mean.  Below its depth a tree thus costs what it costs at its depth.
 * The tree is first laid on a grid of its own finest cells (a lookup there is the tree's lookup),
 * and sample points are kept in polar form, so a turn is a subtraction; a point on a cell
 * boundary takes the mean of the cells there (bsti_sc_polar_cells).  The result is invariant
 * under quarter turns of both cells (the concentric map commutes with them and the sample points
 * of a cell turn into those of the turned cell), so only incident cells of one quadrant are
 * computed and the other three columns are copied.  Those columns are shared among the context's
 * threads (bst_ctx_set_threads); the caller's thread alone reports progress. */
static int expand3(bst_ctx *ctx, const bsti_ttree *t, int k, double *m)
{
    size_t G = (size_t)1 << k, n = G * G;
    size_t gd = (size_t)1 << t->depth, h0 = gd > 1 ? gd / 2 : 1;
    size_t f = t->depth > k ? (size_t)1 << (t->depth - k) : 1; /* tree cells per cell side */
    size_t S = TT3_IN_SAMPLES * f, T = TT3_OUT_SAMPLES * f;
    float *grid = bsti_alloc_array(ctx, h0 * gd * gd, sizeof *grid);
    double *pin = NULL, *pol = NULL;
    if (!grid || bsti_sc_cell_points(ctx, G, S, &pin) < 0 || bsti_sc_cell_points(ctx, G, T, &pol) < 0) {
        bsti_free(ctx, grid), bsti_free(ctx, pin), bsti_free(ctx, pol);
        return BST_ENOMEM;
    }
    for (size_t i0 = 0; i0 < h0; i0++) /* p0 < 1/2 only: sin(theta_in) lies there */
        for (size_t q = 0; q < gd * gd; q++) {
            double p[3] = {(i0 + 0.5) / gd, (q / gd + 0.5) / gd, (q % gd + 0.5) / gd};
            grid[i0 * gd * gd + q] = (float)bsti_ttree_eval(t, p);
        }
    size_t lo = G > 1 ? G / 2 : 0, todo = (G - lo) * (G - lo);
    struct e3 e = {.G = G, .n = n, .gd = gd, .h0 = h0, .ni = S * S, .no = T * T, .lo = lo,
                   .grid = grid, .pin = pin, .pol = pol, .m = m, .ctx = ctx};
    atomic_init(&e.next, 0);
    atomic_init(&e.done, 0);
    /* a column costs ni no N lookups: below 2^22 in all threads are not worth their start */
    int threads = todo * e.ni * e.no * n < ((size_t)1 << 22) ? 1 : bsti_ctx_workers(ctx, todo);
    pthread_t th[BST_THREADS_MAX];
    int started[BST_THREADS_MAX] = {0};
    for (int w = 1; w < threads; w++) /* one that cannot start leaves its share to the others */
        started[w] = pthread_create(&th[w], NULL, e3_work, &e) == 0;
    e3_take(&e, 1);
    for (int w = 1; w < threads; w++)
        if (started[w])
            pthread_join(th[w], NULL);
    if (todo >= 16)
        bsti_progress(ctx, 1.0, "expanding an isotropic tree");
    /* the three other quadrants, by quarter turns of both cells */
    for (size_t ix = lo; G > 1 && ix < G; ix++)
        for (size_t iy = lo; iy < G; iy++) {
            const double *src = m + n * (ix * G + iy);
            for (int turn = 1; turn < 4; turn++) {
                double *dst = m + n * bsti_sc_turn(ix * G + iy, turn, G);
                for (size_t o = 0; o < n; o++)
                    dst[bsti_sc_turn(o, turn, G)] = src[o];
            }
        }
    bsti_free(ctx, grid), bsti_free(ctx, pin), bsti_free(ctx, pol);
    return BST_OK;
}


/* In place on a Shirley-Chiu matrix (antipode(j) = N - 1 - j): M'[o + N i] = M[a(i) + N a(o)], the
 * transmission of the other side by reciprocity.  The map swaps pairs, so it is its own inverse. */
static void antipode_transpose(double *m, size_t n)
{
    for (size_t i = 0; i < n; i++)
        for (size_t o = 0; o < n; o++) {
            size_t p = o + n * i, q = (n - 1 - i) + n * (n - 1 - o);
            if (p < q) {
                double t = m[p];
                m[p] = m[q];
                m[q] = t;
            }
        }
}


/* ------------------------------------------------------------------ one file onto one basis */

/* What moving the components of one file onto one basis needs, made once for all of them. */
struct plan {
    const bst_bsdf *b;
    const bst_basis *target;
    int direct;          /* a Klems file onto its own basis */
    int kfine;           /* Klems target: order of the grid the file goes through, else 0 */
    bsti_overlap *in;    /* a Klems file with the grid it lands on (target's or the fine one) */
    bsti_overlap *out;   /* Klems target: the fine grid with the target's patches */
    double *fine;        /* Klems target: the component on the fine grid */
};

static void plan_free(bst_ctx *ctx, struct plan *p)
{
    bsti_overlap_free(p->in), bsti_overlap_free(p->out), bsti_free(ctx, p->fine);
}

static int plan_make(bst_ctx *ctx, const bst_bsdf *b, const bst_basis *target, struct plan *p)
{
    *p = (struct plan){.b = b, .target = target};
    int klems = b->kind == BST_FILE_KLEMS, rc = BST_OK;
    if (target->kind == BST_BASIS_KLEMS && klems && bst_basis_equal(target, b->klems)) {
        p->direct = 1;
        return BST_OK;
    }
    if (target->kind == BST_BASIS_KLEMS) {
        p->kfine = klems ? KLEMS_VIA_ORDER : b->k > BST_K_MAX ? BST_K_MAX : b->k;
        size_t nf = (size_t)1 << (2 * p->kfine);
        if (!(p->fine = bsti_alloc_array(ctx, nf * nf, sizeof *p->fine)))
            rc = BST_ENOMEM;
        if (rc >= 0)
            rc = bsti_overlap_new(ctx, p->kfine, target, &p->out);
    }
    if (rc >= 0 && klems)
        rc = bsti_overlap_new(ctx, p->kfine ? p->kfine : target->k, b->klems, &p->in);
    if (rc < 0) {
        plan_free(ctx, p);
        *p = (struct plan){0};
    }
    return rc;
}

/* Stored component c on the Shirley-Chiu grid of order k (m: N x N); a rank-4 tree comes as its
 * reciprocal where *recip, which is then cleared. */
static int to_grid(bst_ctx *ctx, const struct plan *p, size_t ch, int c, int k, double *m, int *recip)
{
    const bst_bsdf *b = p->b;
    if (b->mat[ch][c])
        return bsti_klems_to_sc(ctx, p->in, b->mat[ch][c], m);
    if (b->tree[ch][c]->dim == 4) {
        bsti_ttree_fill4(b->tree[ch][c], k, *recip, BST_DOUBLE, m, bsti_ttree_threads(k));
        *recip = 0;
        return BST_OK;
    }
    return expand3(ctx, b->tree[ch][c], k, m);
}

static int plan_component(bst_ctx *ctx, const struct plan *p, size_t ch, int c, double *work, int *recip)
{
    const bst_bsdf *b = p->b;
    size_t n = bst_basis_size(p->target);
    *recip = 0;
    if (!bsti_bsdf_stored(b, ch, c)) {
        int other = bsti_bsdf_reciprocal(c);
        if (other < 0 || !bsti_bsdf_stored(b, ch, other))
            return bsti_error(ctx, BST_EINVAL, "%s: no %s in channel %zu", b->path,
                              bst_comp_name((bst_comp)c), ch);
        c = other, *recip = 1;
    }
    if (p->direct) {
        memcpy(work, b->mat[ch][c], n * n * sizeof *work);
        return BST_OK;
    }
    if (!p->kfine) {
        int keep = 0; /* the caller reads a reciprocal from work */
        return to_grid(ctx, p, ch, c, p->target->k, work, &keep);
    }
    int rc = to_grid(ctx, p, ch, c, p->kfine, p->fine, recip);
    if (rc < 0)
        return rc;
    /* A Klems patch is not a union of cells of the other side's patches: apply reciprocity on the
     * fine grid, where it is exact (a rank-4 tree's expansion did as it wrote), then average
     * (otherwise the hemispherical Tf of a file storing only Tb is not kept). */
    if (*recip)
        antipode_transpose(p->fine, (size_t)1 << (2 * p->kfine));
    *recip = 0;
    return bsti_sc_to_klems(ctx, p->out, p->fine, p->target, work);
}

int bsti_resample_component(bst_ctx *ctx, const bst_bsdf *b, size_t ch, int c,
                            const bst_basis *target, double *work, int *recip)
{
    struct plan p;
    int rc = plan_make(ctx, b, target, &p);
    if (rc < 0)
        return rc;
    rc = plan_component(ctx, &p, ch, c, work, recip);
    plan_free(ctx, &p);
    return rc;
}

/* The component in work (N x N column-major, recip: to be taken as its reciprocal) as a matrix in
 * its cheapest structure; a dense one is filled straight from work in precision prec. */
static int component_from_work(bst_ctx *ctx, const bst_basis *target, const double *work, int recip,
                               bst_precision prec, bst_mat **out)
{
    size_t n = bst_basis_size(target), nnz = 0;
    int diag_only = 1;
    /* the reciprocal maps (o, i) to (a(i), a(o)): diagonal to diagonal, so the census is the same */
    for (size_t q = 0; q < n * n; q++)
        if (work[q] != 0.0) {
            nnz++;
            diag_only &= q % (n + 1) == 0;
        }
    int rc;
    bst_mat *d;
    if (nnz > 0 && !diag_only && (double)nnz > BST_SPARSE_MAX_FILL * (double)n * (double)n) {
        if ((rc = bst_mat_new_dense(ctx, n, n, prec, &d)) < 0)
            return rc;
        double *dd = prec == BST_DOUBLE ? bst_mat_dense_data(d) : NULL;
        float *df = prec == BST_FLOAT ? bst_mat_dense_data(d) : NULL;
        for (size_t i = 0; i < n; i++) {
            size_t ai = recip ? bst_basis_antipode(target, i) : 0;
            for (size_t o = 0; o < n; o++) {
                double v = recip ? work[ai + n * bst_basis_antipode(target, o)] : work[o + n * i];
                if (dd)
                    dd[o + n * i] = v;
                else
                    df[o + n * i] = (float)v;
            }
        }
        *out = d;
        return BST_OK;
    }
    if ((rc = bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &d)) < 0)
        return rc;
    double *dd = bst_mat_dense_data(d);
    if (recip) { /* Tf[o][i] = Tb[a(i)][a(o)], a = antipode */
        for (size_t i = 0; i < n; i++) {
            size_t ai = bst_basis_antipode(target, i);
            for (size_t o = 0; o < n; o++)
                dd[o + n * i] = work[ai + n * bst_basis_antipode(target, o)];
        }
    } else {
        memcpy(dd, work, n * n * sizeof *dd);
    }
    rc = bst_mat_compact(ctx, d, BST_SPARSE_MAX_FILL, out);
    bst_mat_free(d);
    return rc;
}

/* The non-zero cells of a tree's expansion gathered for a sparse or diagonal matrix. */
struct cells {
    size_t *row, *col, n;
    double *val, *diag;
};

static void collect(void *opaque, size_t row, size_t col, double v)
{
    struct cells *c = opaque;
    if (c->diag) {
        c->diag[row] = v;
        return;
    }
    c->row[c->n] = row, c->col[c->n] = col, c->val[c->n++] = v;
}

/* P K P^T on the grid of order k, P the prolongation from order d (lowrank.h), with K (4^d x 4^d)
 * left for the caller to fill in place in *K: no second copy of the coarse matrix is made. */
static int prolonged(bst_ctx *ctx, int k, int d, bsti_lr **lr, double **K)
{
    bsti_lr_map *S = NULL;
    int rc = bsti_lr_map_prolong(ctx, k, d, &S);
    if (rc >= 0)
        rc = bsti_lr_alloc(ctx, S, 1, 1, 0, BSTI_LR_K_ZERO, lr);
    bsti_lr_map_free(ctx, S); /* the matrix holds its own reference */
    if (rc < 0)
        return rc;
    for (size_t x = 0; x < (*lr)->N; x++)
        (*lr)->a[x] = (*lr)->b[x] = 1.0;
    *K = (*lr)->k;
    return BST_OK;
}

/* A rank-4 tree of depth d below the grid's order k whose values fill its own order's matrix
 * M_d (or its reciprocal's): exactly P M_d P^T, P the prolongation from d to k (lowrank.h), held
 * factored at the size of its information (issue #31). */
static int tree_factored(bst_ctx *ctx, const bsti_ttree *t, int k, int recip, int threads,
                         bst_mat **out)
{
    bsti_lr *lr;
    double *K;
    int rc = prolonged(ctx, k, t->depth, &lr, &K);
    if (rc < 0)
        return rc;
    bsti_ttree_fill4(t, t->depth, recip, BST_DOUBLE, K, threads);
    return bsti_mat_from_lr(ctx, lr, out);
}

/* A rank-3 tree of depth d below the grid's order k, as BST_RANK3_NATIVE asks: expanded at its own
 * order (expand3, the same sampling as at any order) and held as P M_d P^T, the reciprocal taken
 * on the order-d grid (the antipode, index reversal, maps an order-d cell's children to its
 * antipode's children, so it commutes with P). */
static int tree3_factored(bst_ctx *ctx, const bsti_ttree *t, int k, int recip, bst_mat **out)
{
    bsti_lr *lr;
    double *K;
    int rc = prolonged(ctx, k, t->depth, &lr, &K);
    if (rc < 0)
        return rc;
    if ((rc = expand3(ctx, t, t->depth, K)) < 0) {
        bsti_lr_free(ctx, lr);
        return rc;
    }
    if (recip)
        antipode_transpose(K, (size_t)1 << (2 * t->depth));
    return bsti_mat_from_lr(ctx, lr, out);
}

/* Whether a rank-4 tree goes factored onto order k: coarser than k, and dense at its own order
 * (a sparse or diagonal tree stays sparse or diagonal at k, which costs less). */
static int tree_is_factored(const bsti_ttree *t, int k)
{
    if (t->depth >= k || t->depth < 1)
        return 0;
    size_t r = (size_t)1 << (2 * t->depth), nnz;
    int diag_only;
    size_t sparse_max = (size_t)(BST_SPARSE_MAX_FILL * (double)r * (double)r);
    bsti_ttree_census4(t, t->depth, sparse_max, &nnz, &diag_only);
    return !diag_only && (double)nnz > BST_SPARSE_MAX_FILL * (double)r * (double)r;
}

/* A rank-4 tree (or its reciprocal) on the Shirley-Chiu grid of order k, straight into the
 * structure component_from_work would choose for its expansion (the census comes from the tree):
 * a dense matrix is filled in place in precision prec, with no N x N work copy between. */
static int tree_component(bst_ctx *ctx, const bsti_ttree *t, int k, int recip, bst_precision prec,
                          int threads, bst_mat **out)
{
    size_t n = (size_t)1 << (2 * k), nnz;
    int diag_only, rc;
    /* past this many non-zeros (one off the diagonal) it is dense: the census may stop there */
    size_t sparse_max = (size_t)(BST_SPARSE_MAX_FILL * (double)n * (double)n);
    bsti_ttree_census4(t, k, sparse_max, &nnz, &diag_only);
    if (nnz == 0)
        return bst_mat_new_zero(ctx, n, n, out);
    if (!diag_only && (double)nnz > BST_SPARSE_MAX_FILL * (double)n * (double)n) {
        bst_mat *d;
        if ((rc = bsti_mat_alloc(ctx, BST_DENSE, prec, n, n, &d)) < 0)
            return rc;
        /* not cleared: the expansion writes every cell */
        if (!(d->dense = bsti_alloc_array(ctx, n * n, prec == BST_DOUBLE ? sizeof(double) : sizeof(float)))) {
            bst_mat_free(d);
            return BST_ENOMEM;
        }
        bsti_ttree_fill4(t, k, recip, prec, d->dense, threads);
        *out = d;
        return BST_OK;
    }
    struct cells c = {0};
    if (diag_only) {
        if (!(c.diag = bsti_calloc(ctx, n, sizeof *c.diag)))
            return BST_ENOMEM;
        bsti_ttree_emit4(t, k, recip, collect, &c);
        rc = bst_mat_new_diag(ctx, n, c.diag, out);
        bsti_free(ctx, c.diag);
        return rc;
    }
    c.row = bsti_alloc_array(ctx, 2 * nnz, sizeof *c.row);
    c.val = bsti_alloc_array(ctx, nnz, sizeof *c.val);
    if (c.row && c.val) {
        c.col = c.row + nnz;
        bsti_ttree_emit4(t, k, recip, collect, &c);
        rc = bst_mat_new_sparse(ctx, n, n, nnz, c.row, c.col, c.val, out);
    } else {
        rc = BST_ENOMEM;
    }
    bsti_free(ctx, c.row);
    bsti_free(ctx, c.val);
    return rc;
}

/* A Klems file's overlaps with the grid of its plan as a map (M = W K W^T, bsti_klems_to_sc), or
 * NULL when the Klems basis is not small beside the grid (its rank past BSTI_LR_DENSE_SHARE of
 * N: dense costs less) or the target is not a Shirley-Chiu grid. */
static int klems_map(bst_ctx *ctx, const struct plan *p, bsti_lr_map **out)
{
    *out = NULL;
    const bsti_overlap *ov = p->in;
    if (!ov || p->kfine || (double)ov->nk >= BSTI_LR_DENSE_SHARE * (double)ov->n)
        return BST_OK;
    int rc = bsti_lr_map_new(ctx, ov->n, ov->nk, ov->first[ov->n], out);
    if (rc < 0)
        return rc;
    bsti_lr_map *S = *out;
    memcpy(S->start, ov->first, (ov->n + 1) * sizeof *S->start);
    memcpy(S->col, ov->patch, ov->first[ov->n] * sizeof *S->col);
    memcpy(S->w, ov->w, ov->first[ov->n] * sizeof *S->w);
    S->k = ov->k;
    snprintf(S->tag, sizeof S->tag, "%s", bst_basis_name(p->b->klems));
    return BST_OK;
}

/* Whether every ring of a Klems basis is its own image under the antipode (phi + 180 degrees):
 * an even count of patches, or one patch spanning the ring.  Then a patch's overlap with a cell is
 * its antipode's with the antipodal cell, W(a(c), p) = W(c, a(p)), and reciprocity can be applied
 * to the Klems matrix before the overlaps instead of on the grid after them. */
static int klems_antipodal(const bst_basis *kb)
{
    for (size_t band = 0; band < kb->nbands; band++)
        if (kb->nphi[band] != 1 && kb->nphi[band] % 2 != 0)
            return 0;
    return 1;
}

/* A stored Klems matrix km over the map S: W K W^T, factored (issue #31).  recip: the transmission
 * that reciprocity gives from km (kb its Klems basis, antipodal): M'(o, i) = M(a(i), a(o)) on the
 * grid is W K' W^T with K'(q, p) = K(a(p), a(q)) on the patches, since W(a(c), p) = W(c, a(p)). */
static int klems_factored(bst_ctx *ctx, const bsti_lr_map *S, const double *km, int recip,
                          const bst_basis *kb, bst_mat **out)
{
    double *kr = NULL;
    if (recip) {
        size_t n = bst_basis_size(kb);
        if (!(kr = bsti_alloc_array(ctx, n * n, sizeof *kr)))
            return BST_ENOMEM;
        for (size_t p = 0; p < n; p++) {
            size_t ap = bst_basis_antipode(kb, p);
            for (size_t q = 0; q < n; q++)
                kr[q + n * p] = km[ap + n * bst_basis_antipode(kb, q)];
        }
    }
    bsti_lr *lr;
    int rc = bsti_lr_new(ctx, S, NULL, NULL, recip ? kr : km, NULL, &lr);
    bsti_free(ctx, kr);
    return rc < 0 ? rc : bsti_mat_from_lr(ctx, lr, out);
}

/* Dense components come out in the precision the file was read for (bst_bsdf_read_opts). */
int bst_bsdf_to_layer(bst_ctx *ctx, const bst_bsdf *b, const bst_basis *target_in, bst_layer **out)
{
    return bsti_bsdf_to_layer(ctx, b, target_in, 0, out);
}

int bsti_bsdf_to_layer(bst_ctx *ctx, const bst_bsdf *b, const bst_basis *target_in, int threads,
                       bst_layer **out)
{
    if (!ctx || !b || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "to_layer: NULL argument") : BST_EINVAL;
    *out = NULL;
    bst_basis *native = NULL;
    int rc = BST_OK;
    if (!target_in) {
        rc = b->kind == BST_FILE_KLEMS ? bst_basis_copy(ctx, b->klems, &native)
                                       : bst_basis_new_sc(ctx, b->k > BST_K_MAX ? BST_K_MAX : b->k, &native);
        if (rc < 0)
            return rc;
    }
    const bst_basis *target = target_in ? target_in : native;
    size_t n = bst_basis_size(target);
    if (threads < 1)
        threads = target->kind == BST_BASIS_SHIRLEY_CHIU ? bsti_ttree_threads(target->k) : 1;
    bst_layer *l = NULL;
    struct plan p = {0};
    double *work = NULL;
    rc = bst_layer_new(ctx, target, b->nch, (const char *const *)b->channels, &l);
    if (rc >= 0)
        rc = bst_layer_set_name(ctx, l, b->path);
    if (rc >= 0)
        rc = plan_make(ctx, b, target, &p);
    bsti_lr_map *kmap = NULL; /* a Klems file on a fine grid: its components factored */
    if (rc >= 0 && b->kind == BST_FILE_KLEMS && !p.direct)
        rc = klems_map(ctx, &p, &kmap);
    for (size_t ch = 0; rc >= 0 && ch < b->nch; ch++)
        for (int c = 0; rc >= 0 && c < BST_NCOMP; c++) {
            bst_mat *m;
            int other = bsti_bsdf_reciprocal(c), recip = 0, from = c;
            if (!bsti_bsdf_stored(b, ch, c) && (other < 0 || !bsti_bsdf_stored(b, ch, other))) {
                if ((rc = bst_mat_new_zero(ctx, n, n, &m)) >= 0)
                    rc = bst_layer_set(ctx, l, ch, (bst_comp)c, m);
                continue;
            }
            if (!bsti_bsdf_stored(b, ch, c))
                from = other, recip = 1;
            const bsti_ttree *t = b->tree[ch][from];
            if (target->kind == BST_BASIS_SHIRLEY_CHIU && t && t->dim == 4 &&
                tree_is_factored(t, target->k)) {
                rc = tree_factored(ctx, t, target->k, recip, threads, &m);
            } else if (target->kind == BST_BASIS_SHIRLEY_CHIU && t && t->dim == 4) {
                rc = tree_component(ctx, t, target->k, recip, b->prec, threads, &m);
            } else if (target->kind == BST_BASIS_SHIRLEY_CHIU && t && t->dim == 3 &&
                       b->rank3 == BST_RANK3_NATIVE && t->depth >= 1 && t->depth < target->k) {
                rc = tree3_factored(ctx, t, target->k, recip, &m);
            } else if (kmap && (!recip || klems_antipodal(b->klems))) {
                rc = klems_factored(ctx, kmap, b->mat[ch][from], recip, b->klems, &m);
            } else {
                /* the N x N work buffer only where a component goes through it */
                if (!work && !(work = bsti_alloc_array(ctx, n * n, sizeof *work))) {
                    rc = BST_ENOMEM;
                    break;
                }
                if ((rc = plan_component(ctx, &p, ch, c, work, &recip)) >= 0)
                    rc = component_from_work(ctx, target, work, recip, b->prec, &m);
            }
            if (rc >= 0)
                rc = bst_layer_set(ctx, l, ch, (bst_comp)c, m);
        }
    plan_free(ctx, &p);
    bsti_lr_map_free(ctx, kmap); /* the matrices hold their own references */
    bsti_free(ctx, work);
    bst_basis_free(native);
    if (rc < 0) {
        bst_layer_free(l);
        return rc;
    }
    *out = l;
    return BST_OK;
}
