/* columns.c - a few incident columns of a stack's Tf and Rf without the whole system: the light
 * between the layers is iterated gap by gap (Gauss-Seidel), never forming (I - A)^-1.
 *
 * Layers 1..n, exterior first; gap g lies between layers g and g+1.  For the incident patches
 * `cols` (front incidence, basis.h's index convention), D_g is the BSDF-valued light leaving
 * layer g towards the interior and U_g the light leaving layer g+1 towards the exterior, one column
 * per incident patch; L = Lambda, the patches' projected solid angles:
 *   D_1 = Tf_1[:, cols] + Rb_1 L U_1,         D_g = Tf_g L D_{g-1} + Rb_g L U_g   (g >= 2)
 *   U_g = Rf_{g+1} L D_g + Tb_{g+1} L U_{g+1} (g <= n-2),   U_{n-1} = Rf_n L D_{n-1}
 *   Tf[:, cols] = Tf_n L D_{n-1},             Rf[:, cols] = Rf_1[:, cols] + Tb_1 L U_1.
 * Back incidence (opts->back) runs the same over the stack seen from the back and gives Tb, Rb.
 * For two layers the fixed point is D_1 = (I - Rb_1 L Rf_2 L)^-1 Tf_1, so Tf = Tf_2 L D_1, the
 * stack's formula (stack.c) by the push-through identity.  A sweep costs one product of each
 * component with an N x m block: O(N m) for glass, O(nnz m) sparse, O(N^2 m) dense.  The error
 * after a sweep shrinks by about the largest product of facing reflectances per sweep; the
 * iteration stops when a sweep changes the inter-reflected flux by less than tol of the incident
 * flux. */
#include <config.h>

#include <math.h>
#include <string.h>

#include "ctx.h"
#include "layer.h"
#include "mat.h"

void bst_columns_opts_init(bst_columns_opts *opts)
{
    memset(opts, 0, sizeof *opts);
    opts->tol = BST_COLUMNS_TOL;
    opts->max_iter = BST_COLUMNS_MAX_ITER;
}

/* *x = a + b (either may be NULL: absent); consumes a and b. */
static int add_into(bst_ctx *ctx, bst_mat *a, bst_mat *b, bst_mat **x)
{
    int rc = BST_OK;
    if (!a || !b)
        *x = a ? a : b;
    else
        rc = bst_mat_add(ctx, 1.0, a, 1.0, b, x);
    if (a && b) {
        bst_mat_free(a);
        bst_mat_free(b);
    }
    return rc;
}

/* *x = A L X (NULL when A or X is absent). */
static int apply(bst_ctx *ctx, const bst_mat *a, const double *lam, const bst_mat *x, bst_mat **out)
{
    *out = NULL;
    if (!a || !x || bst_mat_structure(a) == BST_ZERO || bst_mat_structure(x) == BST_ZERO)
        return BST_OK;
    bst_mat *lx;
    int rc = bst_mat_scale(ctx, lam, x, NULL, &lx);
    if (rc < 0)
        return rc;
    rc = bst_mat_mul(ctx, a, lx, 0.0, out);
    bst_mat_free(lx);
    return rc;
}

/* Flux of m's columns (sum_o L_o |m[o, j]|), or of their change against old, added to *sum; buf
 * receives m as a dense array. */
static int flux(bst_ctx *ctx, const bst_mat *m, const double *old, const double *lam, size_t n,
                size_t ncols, double *buf, double *sum)
{
    if (!m)
        memset(buf, 0, n * ncols * sizeof *buf);
    else {
        int rc = bst_mat_to_dense_array(ctx, m, buf);
        if (rc < 0)
            return rc;
    }
    for (size_t q = 0; q < n * ncols; q++)
        *sum += lam[q % n] * fabs(buf[q] - (old ? old[q] : 0.0));
    return BST_OK;
}

/* *slot = a + b (both consumed, also on failure); the flux of the change from prev (N x ncols
 * values, then set to the new ones) is added to *change. */
static int update(bst_ctx *ctx, int rc, bst_mat *a, bst_mat *b, bst_mat **slot, double *prev,
                  const double *lam, size_t n, size_t ncols, double *buf, double *change)
{
    bst_mat_free(*slot);
    *slot = NULL;
    if (rc < 0) {
        bst_mat_free(a), bst_mat_free(b);
        return rc;
    }
    if ((rc = add_into(ctx, a, b, slot)) >= 0 && (rc = flux(ctx, *slot, prev, lam, n, ncols, buf, change)) >= 0)
        memcpy(prev, buf, n * ncols * sizeof *buf);
    return rc;
}

int bst_stack_columns(bst_ctx *ctx, size_t n, const bst_layer *const *layers, const char *channel,
                      size_t ncols, const size_t *cols, bst_columns_opts *opts, bst_mat **tf,
                      bst_mat **rf)
{
    if (!ctx || !layers || !cols || !tf || !rf || n == 0 || ncols == 0)
        return ctx ? bsti_error(ctx, BST_EINVAL, "columns: NULL argument or nothing asked") : BST_EINVAL;
    *tf = *rf = NULL;
    bst_columns_opts defaults;
    if (!opts) {
        bst_columns_opts_init(&defaults);
        opts = &defaults;
    }
    if (!(opts->tol > 0) || opts->max_iter < 1)
        return bsti_error(ctx, BST_EINVAL, "columns: tolerance must be > 0 and max_iter >= 1");
    if (!layers[0])
        return bsti_error(ctx, BST_EINVAL, "columns: layer 1 is missing");
    const bst_basis *basis = bst_layer_basis(layers[0]);
    size_t N = bst_basis_size(basis);
    if (!channel)
        channel = bst_layer_channel(layers[0], 0);
    int *ch = bsti_alloc_array(ctx, n, sizeof *ch);
    if (!ch)
        return BST_ENOMEM; /* the allocator has said so in ctx */
    for (size_t i = 0; i < n; i++) {
        if (!layers[i] || !bst_basis_equal(bst_layer_basis(layers[i]), basis)) {
            bsti_free(ctx, ch);
            return bsti_error(ctx, BST_EBASIS, "columns: layer %zu is missing or in another basis", i + 1);
        }
        if ((ch[i] = bst_layer_find_channel(layers[i], channel)) < 0) {
            bsti_free(ctx, ch);
            return bsti_error(ctx, BST_ENOTFOUND, "columns: layer %zu has no channel %s", i + 1, channel);
        }
    }
    for (size_t j = 0; j < ncols; j++)
        if (cols[j] >= N) {
            bsti_free(ctx, ch);
            return bsti_error(ctx, BST_EINVAL, "columns: incident patch %zu of %zu", cols[j], N);
        }
    const double *lam = bst_basis_lambda(basis);
    /* back incidence: the same iteration over the stack seen from the back, layers in reverse
     * order with front and back components exchanged (patch indices need no change: they follow
     * the propagation direction's x and y, which the other side's view shares) */
    static const bst_comp swapped[BST_NCOMP] = {[BST_TF] = BST_TB, [BST_RF] = BST_RB, [BST_TB] = BST_TF,
                                                [BST_RB] = BST_RF};
    int back = opts->back != 0;
#define LAYER(i) (back ? n - (i) : (i) - 1)
#define COMP(i, c) bst_layer_get(layers[LAYER(i)], (size_t)ch[LAYER(i)], back ? swapped[c] : (bst_comp)(c))
    size_t G = n - 1;
    bst_mat **D = bsti_calloc(ctx, 2 * G + 1, sizeof *D), **U = D + G, *src = NULL, *r1 = NULL;
    double *buf = bsti_alloc_array(ctx, N * ncols, sizeof *buf);
    double *old = bsti_alloc_array(ctx, 2 * G * N * ncols + 1, sizeof *old);
    int rc = D && buf && old ? BST_OK : BST_ENOMEM;
    if (rc >= 0 && COMP(1, BST_TF))
        rc = bst_mat_select_cols(ctx, COMP(1, BST_TF), ncols, cols, &src);
    /* a float layer makes float products, whose rounding a sweep cannot get below: stop there */
    double tol = opts->tol;
    for (size_t i = 1; i <= n; i++)
        for (int c = 0; c < BST_NCOMP; c++)
            if (COMP(i, c) && bst_mat_precision(COMP(i, c)) == BST_FLOAT)
                tol = fmax(tol, BST_COLUMNS_TOL_FLOAT);
    double in = 0.0, change = INFINITY;
    if (rc >= 0)
        rc = flux(ctx, src, NULL, lam, N, ncols, buf, &in);
    if (rc >= 0)
        memset(old, 0, 2 * G * N * ncols * sizeof *old);
    int it = 0;
    while (rc >= 0 && G > 0 && it < opts->max_iter && !(change <= tol * in)) {
        change = 0.0;
        for (size_t g = 1; rc >= 0 && g <= G; g++) { /* inwards: D_g */
            bst_mat *a = NULL, *b = NULL;
            if (g == 1)
                rc = src ? bst_mat_convert(ctx, src, bst_mat_structure(src), BST_DOUBLE, &a) : BST_OK;
            else
                rc = apply(ctx, COMP(g, BST_TF), lam, D[g - 2], &a);
            if (rc >= 0)
                rc = apply(ctx, COMP(g, BST_RB), lam, U[g - 1], &b);
            rc = update(ctx, rc, a, b, &D[g - 1], old + (g - 1) * N * ncols, lam, N, ncols, buf, &change);
        }
        for (size_t g = G; rc >= 0 && g >= 1; g--) { /* outwards: U_g */
            bst_mat *a = NULL, *b = NULL;
            rc = apply(ctx, COMP(g + 1, BST_RF), lam, D[g - 1], &a);
            if (rc >= 0 && g < G)
                rc = apply(ctx, COMP(g + 1, BST_TB), lam, U[g], &b);
            rc = update(ctx, rc, a, b, &U[g - 1], old + (G + g - 1) * N * ncols, lam, N, ncols, buf, &change);
        }
        it++;
        if (!isfinite(change))
            rc = bsti_error(ctx, BST_EINVAL, "columns: the iteration produced a non-finite value");
    }
    opts->iterations = it;
    opts->residual = G == 0 || in == 0.0 ? 0.0 : change / in;
    /* the system's columns */
    if (rc >= 0) {
        if (G == 0)
            rc = src ? bst_mat_convert(ctx, src, bst_mat_structure(src), BST_DOUBLE, tf) : BST_OK;
        else
            rc = apply(ctx, COMP(n, BST_TF), lam, D[G - 1], tf);
    }
    if (rc >= 0 && COMP(1, BST_RF))
        rc = bst_mat_select_cols(ctx, COMP(1, BST_RF), ncols, cols, &r1);
    if (rc >= 0) {
        bst_mat *b = NULL;
        if (G > 0)
            rc = apply(ctx, COMP(1, BST_TB), lam, U[0], &b);
        if (rc >= 0) {
            rc = add_into(ctx, r1, b, rf);
            r1 = NULL;
        }
    }
    for (size_t q = 0; rc >= 0 && q < 2; q++) { /* absent results are zero matrices */
        bst_mat **m = q ? rf : tf;
        if (!*m)
            rc = bst_mat_new_zero(ctx, N, ncols, m);
    }
    if (rc >= 0 && (!bst_mat_all_finite(*tf) || !bst_mat_all_finite(*rf))) /* products overflow */
        rc = bsti_error(ctx, BST_EINVAL, "columns: the result overflows double: input values too "
                        "large");
#undef COMP
#undef LAYER
    for (size_t g = 0; D && g < 2 * G; g++)
        bst_mat_free(D[g]);
    bsti_free(ctx, D), bsti_free(ctx, buf), bsti_free(ctx, old), bsti_free(ctx, ch);
    bst_mat_free(src), bst_mat_free(r1);
    if (rc < 0) {
        bst_mat_free(*tf), bst_mat_free(*rf);
        *tf = *rf = NULL;
        return rc;
    }
    if (G > 0 && !(change <= tol * in))
        return bsti_error(ctx, BST_WILLCOND, "columns: no convergence in %d sweeps (last change "
                          "%.2e of the incident flux, asked %.2e): the facing reflectances are "
                          "close to 1; combine the whole stack instead", it, opts->residual, tol);
    return BST_OK;
}
