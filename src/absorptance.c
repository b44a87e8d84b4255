/* absorptance.c - per-layer absorptance (bst_stack_absorptance), riding on the combination.
 *
 * The combination forms the partial stacks of layers 0..k-1 (U_k); it keeps their Tf and Rb
 * (struct bsti_prefix) and the absorptance needs nothing else: no interior partial stack, only row
 * vectors carried through the gaps (an adjoint sweep, L = Lambda, alpha_f / alpha_b the layers'
 * side absorptances, columns = incident patches).  In gap k (between U_k and layer k) let h_k be
 * the light arriving at layer k's front and g_k that arriving at U_k's back; layer k absorbs
 * alpha_f(k)^T h_k + alpha_b(k)^T g_{k+1}, and
 *   g_k = L Rf_k h_k + L Tb_k g_{k+1}                     (layer k's front sends back)
 *   h_k = L Tf_U + L Rb_U g_k   (front incidence),   h_k = L Rb_U g_k   (back incidence)
 * (U = U_k; h_0 = I, g_n = 0 for front incidence; h_0 = 0, g_n = I for back incidence).  So
 *   front: h_k = M_k^-1 (L Tf_U + L Rb_U L Tb_k g_{k+1}),   M_k  = I - L Rb_U L Rf_k,
 *   back:  g_k = M'_k^-1 L Tb_k g_{k+1},                    M'_k = I - L Rf_k L Rb_U,
 * the matrices the combination's step k inverts (inward and outward).  A row c^T applied to g_k
 * (front) becomes (c^T L Rf_k) on h_k plus (c^T L Tb_k) on g_{k+1}, and a row d^T on h_k becomes,
 * with y^T = d^T M_k^-1 (one right solve), y^T L Tf_U (absorbed: done) plus y^T L Rb_U L Tb_k on
 * g_{k+1}: so one sweep from the exterior inwards carries every layer's row (n rows, N values
 * each) through every gap, each gap costing one factorization and products of n rows by N x N
 * matrices, O(n N^2); the rows left on g_n are zero.  Back incidence: a row r^T on g_k becomes
 * (r^T M'_k^-1) L Tb_k on g_{k+1}, layer k's alpha_f(k)^T L Rb_U joins on g_k, and the rows
 * reaching g_n = I are the absorptances.  The combination's step k factors M_k and M'_k itself:
 * up to BSTI_ABS_KEEP_MAX_N patches, in double, it hands the factorizations over (keep_slot) and
 * the sweeps cost O(n^2 N^2) in all; otherwise each gap factors both again.  The old scheme (each
 * gap's h from the interior partial stack V_k = layers k..n-1, formed here, and its own
 * factorizations) cost pane / dense shade / pane 7.3 N^3 flops against 2.7 N^3 when factoring
 * again and O(N^2) with the kept factorizations; it also took the back incidence as the front of
 * the flipped stack, all of it once more.  (Klems 1994, part 2; checked against the energy balance
 * T + R + the layers' absorptances = 1 and Windows-CalcEngine's per-layer cases.) */

#include <config.h>

#include <string.h>

#include "basis.h"
#include "ctx.h"
#include "layer.h"
#include "mat.h"
#include "stack.h"

/* Directional absorptance of one side of a layer: 1 - hemispherical (T + R) per incident patch. */
static int side_absorptance(bst_ctx *ctx, const bst_layer *l, size_t ch, int back, double *a)
{
    size_t n = bst_basis_size(l->basis);
    double *t = bsti_alloc_array(ctx, n, sizeof *t);
    if (!t)
        return BST_ENOMEM;
    int rc = bst_layer_hemispherical(ctx, l, ch, back ? BST_TB : BST_TF, t);
    if (rc >= 0)
        rc = bst_layer_hemispherical(ctx, l, ch, back ? BST_RB : BST_RF, a);
    for (size_t j = 0; rc >= 0 && j < n; j++)
        a[j] = 1.0 - t[j] - a[j];
    bsti_free(ctx, t);
    return rc;
}

/* The combination's factorizations of each gap's two matrices are kept for the sweeps (one
 * factorization a gap and side fewer) up to this many patches (k = 5): 2 (n - 1) LU factors of
 * N x N doubles beside the partial stacks' copies; above it, and in single precision, the
 * sweeps factor them again. */
#define BSTI_ABS_KEEP_MAX_N 1024

/* A dense double matrix of nr rows (nr x N, column-major) from arr. */
static int rows_new(bst_ctx *ctx, size_t nr, size_t N, const double *arr, bst_mat **out)
{
    int rc = bst_mat_new_dense(ctx, nr, N, BST_DOUBLE, out);
    if (rc >= 0)
        memcpy(bst_mat_dense_data(*out), arr, nr * N * sizeof *arr);
    return rc;
}

/* out = (rows L) m for nr rows (nr x N column-major arrays; m NULL = zero). */
static int rows_mul(bst_ctx *ctx, const double *lam, size_t nr, size_t N, const double *rows,
                    const bst_mat *m, double *out)
{
    if (!m) {
        memset(out, 0, nr * N * sizeof *out);
        return BST_OK;
    }
    bst_mat *r = NULL, *res = NULL;
    int rc = bst_mat_new_dense(ctx, nr, N, BST_DOUBLE, &r);
    if (rc >= 0) {
        double *d = bst_mat_dense_data(r);
        for (size_t p = 0; p < N; p++)
            for (size_t i = 0; i < nr; i++)
                d[p * nr + i] = rows[p * nr + i] * lam[p];
        rc = bst_mat_mul(ctx, r, m, 0.0, &res);
    }
    if (rc >= 0)
        rc = bst_mat_to_dense_array(ctx, res, out);
    bst_mat_free(r), bst_mat_free(res);
    return rc;
}

/* out = rows (I - L x L y)^-1 for nr rows (x or y NULL: out = rows), with I - L x L y factored
 * here, or in f (the combination's, kept) when not NULL. */
static int rows_solve(bst_ctx *ctx, const double *lam, size_t nr, size_t N, const double *rows,
                      const bst_mat *x, const bst_mat *y, bsti_factor *f, double rcond_warn,
                      double *out)
{
    if (!x || !y) {
        memmove(out, rows, nr * N * sizeof *out);
        return BST_OK;
    }
    bst_mat *lx = NULL, *ly = NULL, *a = NULL, *b = NULL, *sol = NULL;
    double rcond;
    if (f) {
        int rc = rows_new(ctx, nr, N, rows, &b);
        if (rc >= 0)
            rc = bsti_factor_solve_right(ctx, f, b, &sol);
        if (rc >= 0)
            rc = bst_mat_to_dense_array(ctx, sol, out);
        bst_mat_free(b), bst_mat_free(sol);
        return rc;
    }
    int rc = bst_mat_scale(ctx, lam, x, NULL, &lx);
    if (rc >= 0)
        rc = bst_mat_scale(ctx, lam, y, NULL, &ly);
    if (rc >= 0)
        rc = bst_mat_mul(ctx, lx, ly, 0.0, &a);
    bst_mat_free(lx), bst_mat_free(ly);
    if (rc >= 0)
        rc = rows_new(ctx, nr, N, rows, &b);
    if (rc >= 0) {
        rc = bst_solve_right(ctx, a, b, rcond_warn, &sol, &rcond);
        if (rc == BST_WILLCOND)
            rc = BST_OK; /* already reported by the combination */
    }
    if (rc >= 0)
        rc = bst_mat_to_dense_array(ctx, sol, out);
    bst_mat_free(a), bst_mat_free(b), bst_mat_free(sol);
    return rc;
}

/* The gap sweeps above: abs_front and abs_back ([layer][patch], either NULL) from the layers' side
 * absorptances af, ab ([layer][patch]) and U_k's Tf and Rb (tf_u[k], rb_u[k], k = 1..n-1). */
static int absorptance_sweeps(bst_ctx *ctx, size_t n, const bst_layer *const *layers,
                              const char *chname, const bst_mat *const *tf_u,
                              const bst_mat *const *rb_u, bsti_factor *const *fin,
                              bsti_factor *const *fout, const double *af, const double *ab,
                              double rcond_warn, double *abs_front, double *abs_back)
{
    size_t N = bst_basis_size(layers[0]->basis);
    const double *lam = bst_basis_lambda(layers[0]->basis);
    double *c = bsti_calloc(ctx, 4 * n * N, sizeof *c), *d = c ? c + n * N : NULL;
    double *e = c ? d + n * N : NULL, *y = c ? e + n * N : NULL;
    double *row = bsti_alloc_array(ctx, N, sizeof *row), *w = bsti_alloc_array(ctx, N, sizeof *w);
    int rc = c && row && w ? BST_OK : BST_ENOMEM;
    for (size_t p = 0; rc >= 0 && p < N; p++) /* rows on g_1: layer 0's back */
        c[p * n] = ab[p];
    if (rc >= 0 && abs_front) {
        for (size_t i = 0; i < n * N; i++)
            abs_front[i] = i < N ? af[i] : 0.0;
        for (size_t k = 1; rc >= 0 && k < n; k++) {
            size_t ck = (size_t)bst_layer_find_channel(layers[k], chname);
            const bst_mat *rf = bst_layer_get(layers[k], ck, BST_RF);
            const bst_mat *tb = bst_layer_get(layers[k], ck, BST_TB);
            rc = rows_mul(ctx, lam, n, N, c, rf, d); /* rows on h_k */
            if (rc >= 0 && k + 1 < n)
                rc = rows_mul(ctx, lam, n, N, c, tb, e); /* and on g_{k+1} */
            for (size_t p = 0; rc >= 0 && p < N; p++)
                d[p * n + k] = af[k * N + p], e[p * n + k] = ab[k * N + p];
            if (rc >= 0)
                rc = rows_solve(ctx, lam, n, N, d, rb_u[k], rf, fin ? fin[k] : NULL, rcond_warn, y);
            if (rc >= 0)
                rc = rows_mul(ctx, lam, n, N, y, tf_u[k], d); /* absorbed */
            for (size_t p = 0; rc >= 0 && p < N; p++)
                for (size_t i = 0; i <= k; i++)
                    abs_front[i * N + p] += d[p * n + i];
            if (rc >= 0 && k + 1 < n) { /* what goes on to g_{k+1} */
                rc = rows_mul(ctx, lam, n, N, y, rb_u[k], d);
                if (rc >= 0)
                    rc = rows_mul(ctx, lam, n, N, d, tb, c);
                for (size_t i = 0; rc >= 0 && i < n * N; i++)
                    c[i] += e[i];
            }
        }
    }
    if (rc >= 0 && abs_back) {
        memset(c, 0, n * N * sizeof *c);
        for (size_t p = 0; p < N; p++) /* rows on g_1 */
            c[p * n] = ab[p];
        for (size_t k = 1; rc >= 0 && k < n; k++) {
            size_t ck = (size_t)bst_layer_find_channel(layers[k], chname);
            const bst_mat *rf = bst_layer_get(layers[k], ck, BST_RF);
            const bst_mat *tb = bst_layer_get(layers[k], ck, BST_TB);
            for (size_t p = 0; p < N; p++) /* layer k's front: alpha_f(k)^T L Rb_U on g_k */
                w[p] = af[k * N + p] * lam[p];
            rc = rb_u[k] ? bst_mat_col_weighted_sum(ctx, rb_u[k], w, row) : BST_OK;
            for (size_t p = 0; rc >= 0 && p < N; p++)
                c[p * n + k] = rb_u[k] ? row[p] : 0.0;
            if (rc >= 0)
                rc = rows_solve(ctx, lam, n, N, c, rf, rb_u[k], fout ? fout[k] : NULL, rcond_warn,
                                y);
            if (rc >= 0)
                rc = rows_mul(ctx, lam, n, N, y, tb, c); /* on g_{k+1}, with layer k's back */
            for (size_t p = 0; rc >= 0 && p < N; p++)
                c[p * n + k] += ab[k * N + p];
        }
        for (size_t i = 0; rc >= 0 && i < n; i++) /* g_n = I */
            for (size_t p = 0; p < N; p++)
                abs_back[i * N + p] = c[p * n + i];
    }
    bsti_free(ctx, c), bsti_free(ctx, row), bsti_free(ctx, w);
    return rc;
}

/* The combination (all four components) with what the sweeps need kept, then the sweeps: the
 * system in *out and the absorptances of channel ch (its name in layer 0; every layer holds it). */
static int combine_sweep(bst_ctx *ctx, size_t n, const bst_layer *const *layers, size_t ch,
                         const bst_stack_opts *opts, bst_layer **out, double *abs_front,
                         double *abs_back)
{
    const char *chname = layers[0]->channels[ch];
    size_t N = bst_basis_size(layers[0]->basis);
    struct bsti_prefix keep = {.name = chname};
    keep.tf = bsti_calloc(ctx, 2 * n, sizeof *keep.tf);
    keep.rb = keep.tf ? keep.tf + n : NULL;
    if (N <= BSTI_ABS_KEEP_MAX_N && opts->precision == BST_DOUBLE && keep.tf) {
        keep.fin = bsti_calloc(ctx, 2 * n, sizeof *keep.fin); /* none kept: factored again */
        keep.fout = keep.fin ? keep.fin + n : NULL;
    }
    double *alpha = bsti_alloc_array(ctx, 2 * n * N, sizeof *alpha); /* [side][layer][patch] */
    bst_layer *sys = NULL;
    int rc = keep.tf && alpha ? bsti_stack_combine_keep(ctx, n, layers, NULL, opts, &sys, &keep) : BST_ENOMEM;
    int warn = rc > 0 ? rc : BST_OK;
    for (size_t i = 0; rc >= 0 && i < n; i++) {
        size_t c = (size_t)bst_layer_find_channel(layers[i], chname);
        rc = side_absorptance(ctx, layers[i], c, 0, alpha + i * N);
        if (rc >= 0)
            rc = side_absorptance(ctx, layers[i], c, 1, alpha + (n + i) * N);
    }
    if (rc >= 0) { /* U_1 is layer 0 itself */
        size_t c0 = (size_t)bst_layer_find_channel(layers[0], chname);
        const bst_mat **tf = (const bst_mat **)keep.tf, **rb = (const bst_mat **)keep.rb;
        if (n > 1)
            tf[1] = bst_layer_get(layers[0], c0, BST_TF), rb[1] = bst_layer_get(layers[0], c0, BST_RB);
        rc = absorptance_sweeps(ctx, n, layers, chname, tf, rb, keep.fin, keep.fout, alpha,
                                alpha + n * N, opts->rcond_warn, abs_front, abs_back);
        if (n > 1)
            tf[1] = rb[1] = NULL; /* borrowed: not freed below */
    }
    for (size_t k = 0; keep.tf && k < n; k++)
        bst_mat_free(keep.tf[k]), bst_mat_free(keep.rb[k]);
    for (size_t k = 0; keep.fin && k < n; k++)
        bsti_factor_free(keep.fin[k]), bsti_factor_free(keep.fout[k]);
    bsti_free(ctx, keep.tf);
    bsti_free(ctx, keep.fin);
    bsti_free(ctx, alpha);
    if (rc < 0) {
        bst_layer_free(sys);
        return rc;
    }
    *out = sys;
    return warn;
}

/* The checks both entries make: layers, channel ch of layer 0, held by every layer. */
static int check_channel(bst_ctx *ctx, size_t n, const bst_layer *const *layers, size_t ch)
{
    if (n == 0 || !layers || !layers[0])
        return bsti_error(ctx, BST_EINVAL, "absorptance: no layers");
    if (ch >= layers[0]->nchannels)
        return bsti_error(ctx, BST_EINVAL, "absorptance: channel %zu of %zu", ch, layers[0]->nchannels);
    for (size_t i = 1; i < n; i++)
        if (!layers[i] || bst_layer_find_channel(layers[i], layers[0]->channels[ch]) < 0)
            return bsti_error(ctx, layers[i] ? BST_ENOTFOUND : BST_EINVAL,
                              "absorptance: layer %zu has no channel %s", i + 1, layers[0]->channels[ch]);
    return BST_OK;
}

int bst_stack_absorptance(bst_ctx *ctx, size_t n, const bst_layer *const *layers, size_t ch,
                          const bst_stack_opts *opts_in, double *abs_front, double *abs_back)
{
    if (!ctx)
        return BST_EINVAL;
    int rc = check_channel(ctx, n, layers, ch);
    if (rc < 0 || (!abs_front && !abs_back))
        return rc;
    bst_stack_opts o;
    if (opts_in)
        o = *opts_in;
    else
        bst_stack_opts_init(&o);
    o.comps = BST_COMP_ALL; /* the sweeps read the partial stacks' Tf and Rb */
    o.on_step = NULL;
    bst_layer *sys = NULL;
    rc = combine_sweep(ctx, n, layers, ch, &o, &sys, abs_front, abs_back);
    bst_layer_free(sys);
    return rc;
}

int bsti_stack_combine_absorptance(bst_ctx *ctx, size_t n, const bst_layer *const *layers,
                                   size_t ch, const bst_stack_opts *opts_in, bst_layer **out,
                                   double *abs_front, double *abs_back)
{
    if (!ctx || !out)
        return BST_EINVAL;
    *out = NULL;
    bst_stack_opts defaults;
    bst_stack_opts_init(&defaults);
    const bst_stack_opts *opts = opts_in ? opts_in : &defaults;
    unsigned want = opts->comps ? opts->comps & BST_COMP_ALL : BST_COMP_ALL;
    if (!abs_front && !abs_back)
        return bst_stack_combine(ctx, n, layers, opts, out);
    if (n == 0 || !layers || !layers[0] || ch >= layers[0]->nchannels || want != BST_COMP_ALL) {
        /* the checks and messages of the two, or a system of fewer components than the sweeps
         * read: the combination asked for, and the absorptance's own */
        int rc = bst_stack_combine(ctx, n, layers, opts, out), ra = BST_OK;
        if (rc >= 0)
            ra = bst_stack_absorptance(ctx, n, layers, ch, opts, abs_front, abs_back);
        if (ra < 0) {
            bst_layer_free(*out);
            *out = NULL;
            return ra;
        }
        return rc > ra ? rc : ra;
    }
    int rc = check_channel(ctx, n, layers, ch);
    return rc < 0 ? rc : combine_sweep(ctx, n, layers, ch, opts, out, abs_front, abs_back);
}
