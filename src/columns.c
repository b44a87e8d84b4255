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

/* The iteration's state: the layers as seen from the incident side, the gaps' light D_g, U_g
 * (g = 1..G, G = n - 1) and their values of the previous sweep. */
struct sweep {
    bst_ctx *ctx;
    const bst_layer *const *layers;
    const int *ch;     /* each layer's index of the channel */
    size_t n, G, N, ncols;
    int back;          /* the stack seen from the back */
    const double *lam;
    bst_mat **D, **U;  /* D[g - 1], U[g - 1] */
    double *old, *buf; /* 2 G N ncols values of the last sweep; N ncols of workspace */
};

/* Component c of layer i (1..n) as the light meets it: back incidence runs over the stack seen
 * from the back, layers in reverse order with front and back components exchanged (patch indices
 * need no change: they follow the propagation direction's x and y, which the other side's view
 * shares). */
static const bst_mat *comp(const struct sweep *w, size_t i, bst_comp c)
{
    static const bst_comp swapped[BST_NCOMP] = {[BST_TF] = BST_TB, [BST_RF] = BST_RB,
                                                [BST_TB] = BST_TF, [BST_RB] = BST_RF};
    size_t l = w->back ? w->n - i : i - 1;
    return bst_layer_get(w->layers[l], (size_t)w->ch[l], w->back ? swapped[c] : c);
}

/* One Gauss-Seidel sweep, inwards then outwards (src: layer 1's Tf columns); the flux of the
 * change is added to *change. */
static int sweep_once(struct sweep *w, const bst_mat *src, double *change)
{
    bst_ctx *ctx = w->ctx;
    size_t G = w->G, Nm = w->N * w->ncols;
    int rc = BST_OK;
    for (size_t g = 1; rc >= 0 && g <= G; g++) { /* inwards: D_g */
        bst_mat *a = NULL, *b = NULL;
        if (g == 1)
            rc = src ? bst_mat_convert(ctx, src, bst_mat_structure(src), BST_DOUBLE, &a) : BST_OK;
        else
            rc = apply(ctx, comp(w, g, BST_TF), w->lam, w->D[g - 2], &a);
        if (rc >= 0)
            rc = apply(ctx, comp(w, g, BST_RB), w->lam, w->U[g - 1], &b);
        rc = update(ctx, rc, a, b, &w->D[g - 1], w->old + (g - 1) * Nm, w->lam, w->N, w->ncols,
                    w->buf, change);
    }
    for (size_t g = G; rc >= 0 && g >= 1; g--) { /* outwards: U_g */
        bst_mat *a = NULL, *b = NULL;
        rc = apply(ctx, comp(w, g + 1, BST_RF), w->lam, w->D[g - 1], &a);
        if (rc >= 0 && g < G)
            rc = apply(ctx, comp(w, g + 1, BST_TB), w->lam, w->U[g], &b);
        rc = update(ctx, rc, a, b, &w->U[g - 1], w->old + (G + g - 1) * Nm, w->lam, w->N,
                    w->ncols, w->buf, change);
    }
    return rc;
}

/* The system's columns from the converged gaps: Tf = Tf_n L D_{n-1}, Rf = Rf_1[:, cols] + Tb_1 L
 * U_1; absent ones as zero matrices. */
static int system_columns(struct sweep *w, const bst_mat *src, const size_t *cols, bst_mat **tf,
                          bst_mat **rf)
{
    bst_ctx *ctx = w->ctx;
    bst_mat *r1 = NULL;
    int rc;
    if (w->G == 0)
        rc = src ? bst_mat_convert(ctx, src, bst_mat_structure(src), BST_DOUBLE, tf) : BST_OK;
    else
        rc = apply(ctx, comp(w, w->n, BST_TF), w->lam, w->D[w->G - 1], tf);
    if (rc >= 0 && comp(w, 1, BST_RF))
        rc = bst_mat_select_cols(ctx, comp(w, 1, BST_RF), w->ncols, cols, &r1);
    if (rc >= 0) {
        bst_mat *b = NULL;
        if (w->G > 0)
            rc = apply(ctx, comp(w, 1, BST_TB), w->lam, w->U[0], &b);
        if (rc >= 0) {
            rc = add_into(ctx, r1, b, rf);
            r1 = NULL;
        }
    }
    bst_mat_free(r1);
    for (size_t q = 0; rc >= 0 && q < 2; q++) { /* absent results are zero matrices */
        bst_mat **m = q ? rf : tf;
        if (!*m)
            rc = bst_mat_new_zero(ctx, w->N, w->ncols, m);
    }
    if (rc >= 0 && (!bsti_mat_finite(ctx, *tf) || !bsti_mat_finite(ctx, *rf))) /* products overflow */
        rc = bsti_error(ctx, BST_EINVAL, "columns: the result overflows double: input values too "
                        "large");
    return rc;
}

/* The layers' channel indices into ch, checking bases, channels and the incident patches. */
static int check_stack(bst_ctx *ctx, size_t n, const bst_layer *const *layers, const char *channel,
                       size_t ncols, const size_t *cols, int *ch)
{
    const bst_basis *basis = bst_layer_basis(layers[0]);
    size_t N = bst_basis_size(basis);
    for (size_t i = 0; i < n; i++) {
        if (!layers[i] || !bst_basis_equal(bst_layer_basis(layers[i]), basis))
            return bsti_error(ctx, BST_EBASIS, "columns: layer %zu is missing or in another basis", i + 1);
        if ((ch[i] = bst_layer_find_channel(layers[i], channel)) < 0)
            return bsti_error(ctx, BST_ENOTFOUND, "columns: layer %zu has no channel %s", i + 1, channel);
    }
    for (size_t j = 0; j < ncols; j++)
        if (cols[j] >= N)
            return bsti_error(ctx, BST_EINVAL, "columns: incident patch %zu of %zu", cols[j], N);
    return BST_OK;
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
    size_t N = bst_basis_size(bst_layer_basis(layers[0])), G = n - 1;
    if (!channel)
        channel = bst_layer_channel(layers[0], 0);
    int *ch = bsti_alloc_array(ctx, n, sizeof *ch);
    if (!ch)
        return BST_ENOMEM; /* the allocator has said so in ctx */
    int rc = check_stack(ctx, n, layers, channel, ncols, cols, ch);
    struct sweep w = {ctx, layers, ch, n, G, N, ncols, opts->back != 0,
                      bst_basis_lambda(bst_layer_basis(layers[0])), NULL, NULL, NULL, NULL};
    w.D = rc >= 0 ? bsti_calloc(ctx, 2 * G + 1, sizeof *w.D) : NULL;
    w.U = w.D ? w.D + G : NULL;
    w.buf = w.D ? bsti_alloc_array(ctx, N * ncols, sizeof *w.buf) : NULL;
    w.old = w.buf ? bsti_alloc_array(ctx, 2 * G * N * ncols + 1, sizeof *w.old) : NULL;
    if (rc >= 0 && !w.old)
        rc = BST_ENOMEM;
    bst_mat *src = NULL;
    if (rc >= 0 && comp(&w, 1, BST_TF))
        rc = bst_mat_select_cols(ctx, comp(&w, 1, BST_TF), ncols, cols, &src);
    /* a float layer makes float products, whose rounding a sweep cannot get below: stop there */
    double tol = opts->tol;
    for (size_t i = 1; rc >= 0 && i <= n; i++)
        for (int c = 0; c < BST_NCOMP; c++)
            if (comp(&w, i, (bst_comp)c) && bst_mat_precision(comp(&w, i, (bst_comp)c)) == BST_FLOAT)
                tol = fmax(tol, BST_COLUMNS_TOL_FLOAT);
    double in = 0.0, change = INFINITY;
    if (rc >= 0)
        rc = flux(ctx, src, NULL, w.lam, N, ncols, w.buf, &in);
    if (rc >= 0)
        memset(w.old, 0, 2 * G * N * ncols * sizeof *w.old);
    int it = 0;
    while (rc >= 0 && G > 0 && it < opts->max_iter && !(change <= tol * in)) {
        change = 0.0;
        rc = sweep_once(&w, src, &change);
        it++;
        if (rc >= 0 && !isfinite(change))
            rc = bsti_error(ctx, BST_EINVAL, "columns: the iteration produced a non-finite value");
    }
    opts->iterations = it;
    opts->residual = G == 0 || in == 0.0 ? 0.0 : change / in;
    if (rc >= 0)
        rc = system_columns(&w, src, cols, tf, rf);
    for (size_t g = 0; w.D && g < 2 * G; g++)
        bst_mat_free(w.D[g]);
    bsti_free(ctx, w.D), bsti_free(ctx, w.buf), bsti_free(ctx, w.old), bsti_free(ctx, ch);
    bst_mat_free(src);
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
