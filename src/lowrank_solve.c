/* lowrank_solve.c - the solves with I - F for a factored F = D + U K V^T (lowrank.h): the
 * capacitance's LU, solves through it without forming (I - F)^-1 where the right-hand side shares
 * F's left scalings, the inverse where it does not, and the condition estimate.
 *
 * Why a right-hand side of F's scalings needs no inverse: with E = I - D, C = I - K H and
 * H = V^T E^-1 U, the Woodbury identity gives (I - F)^-1 U = E^-1 U + E^-1 U C^-1 K H
 * = E^-1 U C^-1 (C + K H) = E^-1 U C^-1.  So for B = D_B + U Pi K_B V_B^T (Pi places B's blocks at
 * those of F's equal scalings)
 *   (I - F)^-1 B = E^-1 D_B + E^-1 U C^-1 K V^T E^-1 D_B + E^-1 U C^-1 Pi K_B V_B^T:
 * one solve with C on the columns [K V^T E^-1 D_B, Pi K_B V_B^T], where the inverse costs a solve
 * on K (q r columns) and its product with B a GEMM besides.  A right solve B (I - F)^-1 is the
 * transpose of (I - F^T)^-1 B^T (solve.c transposes): side 1 factors F^T's capacitance
 * I - K^T U^T E^-1 V = (I - H K)^T, and B's right scalings are then the ones to match. */
#include <config.h>

#include <math.h>
#include <string.h>

#include <cblas.h>
#include <lapacke.h>

#include "ctx.h"
#include "lowrank.h"

static void times(double *v, const double *x, const double *y, size_t N)
{
    for (size_t n = 0; n < N; n++)
        v[n] = x[n] * y[n];
}

/* The capacitance C = I - K H, H = V^T E^-1 U ((q r) x (p r)), into c ((p r) x (p r)). */
static int capacitance(bst_ctx *ctx, const bsti_lr *f, const double *einv, double *v, double *c)
{
    size_t N = f->N, r = f->r, pr = f->p * r, qr = f->q * r;
    int single = f->S->single; /* H of diagonal blocks: K H without a GEMM */
    double *h = bsti_calloc(ctx, (single ? f->q * pr : qr * pr) + 1, sizeof *h);
    if (!h)
        return BST_ENOMEM;
    for (size_t j = 0; j < f->q; j++)
        for (size_t i = 0; i < f->p; i++) {
            times(v, f->b + j * N, f->a + i * N, N);
            times(v, v, einv, N);
            if (single)
                bsti_lr_gram_diag(f->S, v, h + (j * f->p + i) * r);
            else
                bsti_lr_gram_add(f->S, v, h, qr, j * r, i * r);
        }
    for (size_t x = 0; x < pr * pr; x++)
        c[x] = 0.0;
    for (size_t x = 0; x < pr; x++)
        c[x * pr + x] = 1.0;
    if (pr && qr && single) {
        bsti_lr_mul_diag_blocks(f->k, pr, f->q, f->p, r, h, -1.0, 1, c);
    } else if (pr && qr) {
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)pr, (int)pr, (int)qr, -1.0,
                    f->k, (int)pr, h, (int)qr, 1.0, c, (int)pr);
        bsti_flops_add(ctx, 2.0 * (double)pr * (double)pr * (double)qr);
    }
    bsti_free(ctx, h);
    return BST_OK;
}

/* Side s's capacitance made and factored, once (F^T formed from F, or F from F^T, when first
 * needed); BST_ESINGULAR when the LU meets an exactly or numerically singular one. */
static int side_factor(bst_ctx *ctx, bsti_lr_fact *fa, int s)
{
    if (fa->lu[s])
        return BST_OK;
    int rc = fa->m[s] ? BST_OK : bsti_lr_transpose(ctx, fa->m[1 - s], &fa->m[s]);
    if (rc < 0)
        return rc;
    const bsti_lr *f = fa->m[s];
    size_t pr = f->p * f->r;
    double *c = bsti_alloc_array(ctx, pr * pr + 1, sizeof *c);
    double *v = c ? bsti_alloc_array(ctx, f->N, sizeof *v) : NULL;
    lapack_int *ipiv = v ? bsti_alloc_array(ctx, pr + 1, sizeof *ipiv) : NULL;
    rc = ipiv ? capacitance(ctx, f, fa->einv, v, c) : BST_ENOMEM;
    double rc_c = 1.0;
    if (rc >= 0 && pr) {
        lapack_int n = (lapack_int)pr;
        double norm = LAPACKE_dlange(LAPACK_COL_MAJOR, '1', n, n, c, n);
        lapack_int info = LAPACKE_dgetrf(LAPACK_COL_MAJOR, n, n, c, n, ipiv);
        double d = (double)pr; /* LAPACK Working Note 41's count, as solve.c */
        bsti_flops_add(ctx, 2.0 / 3.0 * d * d * d - 0.5 * d * d + 5.0 / 6.0 * d);
        if (info == 0) /* only to see an exactly or numerically singular capacitance */
            info = LAPACKE_dgecon(LAPACK_COL_MAJOR, '1', n, c, n, norm, &rc_c);
        if (info != 0 || !(rc_c > 1e-300))
            rc = bsti_error(ctx, BST_ESINGULAR, "factored solve: the capacitance I - K V^T E^-1 U "
                            "(%zu x %zu) is singular", pr, pr);
    }
    bsti_free(ctx, v);
    if (rc < 0) {
        bsti_free(ctx, c), bsti_free(ctx, ipiv);
        return rc;
    }
    fa->lu[s] = c, fa->ipiv[s] = ipiv;
    return BST_OK;
}

/* X := C^-1 X (trans 0) or C^-T X for side s's factored capacitance, X of ncols columns. */
static void cap_solve(bst_ctx *ctx, const bsti_lr_fact *fa, int s, int trans, double *x,
                      size_t ncols)
{
    size_t pr = fa->m[s]->p * fa->m[s]->r;
    if (!pr || !ncols)
        return;
    lapack_int n = (lapack_int)pr;
    LAPACKE_dgetrs_work(LAPACK_COL_MAJOR, trans ? 'T' : 'N', n, (lapack_int)ncols, fa->lu[s], n,
                        fa->ipiv[s], x, n);
    bsti_flops_add(ctx, (2.0 * (double)pr - 1.0) * (double)pr * (double)ncols);
}

/* y = (I - M)^-1 x (t = 0) or (I - M)^-T x (t = 1) for side s's matrix M through its LU,
 *   (I - M)^-1 x = E^-1 x + E^-1 U C^-1 K V^T E^-1 x,  (I - M)^-T x = E^-1 x + E^-1 V K^T C^-T U^T E^-1 x;
 * w holds 2 max(p, q) r values. */
static void apply_inverse(bst_ctx *ctx, const bsti_lr_fact *fa, int s, int t, const double *x,
                          double *y, double *w)
{
    const bsti_lr *f = fa->m[s];
    const bsti_lr_map *S = f->S;
    const double *e = fa->einv;
    size_t N = f->N, r = f->r, pr = f->p * r, qr = f->q * r, nin = t ? f->p : f->q;
    size_t nout = t ? f->q : f->p;
    const double *in = t ? f->a : f->b, *outv = t ? f->b : f->a;
    double *s1 = w, *s2 = w + (pr > qr ? pr : qr);
    for (size_t x0 = 0; x0 < N; x0++)
        y[x0] = e[x0] * x[x0];
    if (!pr || !qr)
        return;
    memset(s1, 0, nin * r * sizeof *s1);
    for (size_t j = 0; j < nin; j++) /* s1 = V^T E^-1 x or U^T E^-1 x */
        for (size_t x0 = 0; x0 < N; x0++)
            for (size_t q = S->start[x0]; q < S->start[x0 + 1]; q++)
                s1[j * r + S->col[q]] += S->w[q] * in[j * N + x0] * e[x0] * x[x0];
    if (!t) {
        cblas_dgemv(CblasColMajor, CblasNoTrans, (int)pr, (int)qr, 1.0, f->k, (int)pr, s1, 1, 0.0,
                    s2, 1);
        cap_solve(ctx, fa, s, 0, s2, 1);
    } else {
        cap_solve(ctx, fa, s, 1, s1, 1);
        cblas_dgemv(CblasColMajor, CblasTrans, (int)pr, (int)qr, 1.0, f->k, (int)pr, s1, 1, 0.0,
                    s2, 1);
    }
    for (size_t i = 0; i < nout; i++) /* y += E^-1 u_i .* S s2_i */
        for (size_t x0 = 0; x0 < N; x0++)
            for (size_t q = S->start[x0]; q < S->start[x0 + 1]; q++)
                y[x0] += e[x0] * outv[i * N + x0] * S->w[q] * s2[i * r + S->col[q]];
}

/* An estimate of the 1-norm of I - F (inverse 0) or of (I - F)^-1 (inverse 1), by LAPACK's dlacn2
 * (Hager and Higham's estimator, as dgecon uses) with products through side s's factors: F^T's
 * products transposed are F's. */
static int norm1_estimate(bst_ctx *ctx, const bsti_lr_fact *fa, int s, int inverse, double *est)
{
    const bsti_lr *f = fa->m[s];
    size_t N = f->N, pq = f->p > f->q ? f->p : f->q;
    double *v = bsti_alloc_array(ctx, 3 * N + 2 * pq * f->r + 1, sizeof *v);
    lapack_int *isgn = bsti_alloc_array(ctx, N, sizeof *isgn), kase = 0, isave[3] = {0, 0, 0};
    if (!v || !isgn) {
        bsti_free(ctx, v), bsti_free(ctx, isgn);
        return BST_ENOMEM;
    }
    double *x = v + N, *y = x + N, *w = y + N;
    *est = 0.0;
    do {
        LAPACKE_dlacn2((lapack_int)N, v, x, isgn, est, &kase, isave);
        if (!kase)
            break;
        int t = (kase == 2) ^ s;
        if (inverse) {
            apply_inverse(ctx, fa, s, t, x, y, w);
            memcpy(x, y, N * sizeof *x);
        } else {
            bsti_lr_apply(f, t, x, y, w);
            for (size_t i = 0; i < N; i++)
                x[i] -= y[i];
        }
    } while (kase);
    bsti_free(ctx, v), bsti_free(ctx, isgn);
    return BST_OK;
}

void bsti_lr_fact_free(bst_ctx *ctx, bsti_lr_fact *fa)
{
    if (!fa)
        return;
    for (int s = 0; s < 2; s++)
        bsti_lr_free(ctx, fa->m[s]), bsti_free(ctx, fa->lu[s]), bsti_free(ctx, fa->ipiv[s]);
    bsti_free(ctx, fa->einv);
    bsti_free(ctx, fa);
}

/* I - F factored on side s from m, side s's matrix (F, or F^T for side 1), which the factorization
 * takes (freed on failure). */
static int factor_side(bst_ctx *ctx, bsti_lr *m, int s, bsti_lr_fact **out, double *rcond)
{
    size_t N = m->N;
    double emin = INFINITY, emax = 0.0;
    for (size_t x = 0; x < N; x++) {
        double e = fabs(1.0 - (m->d ? m->d[x] : 0.0));
        emin = fmin(emin, e), emax = fmax(emax, e);
    }
    if (!(emin > 0.0) || !isfinite(emax)) {
        bsti_lr_free(ctx, m);
        return bsti_error(ctx, BST_ESINGULAR, "factored solve: I - D is singular");
    }
    bsti_lr_fact *fa = bsti_calloc(ctx, 1, sizeof *fa);
    if (!fa) {
        bsti_lr_free(ctx, m);
        return BST_ENOMEM;
    }
    fa->m[s] = m;
    int rc = (fa->einv = bsti_alloc_array(ctx, N, sizeof *fa->einv)) ? BST_OK : BST_ENOMEM;
    for (size_t x = 0; rc >= 0 && x < N; x++)
        fa->einv[x] = 1.0 / (1.0 - (m->d ? m->d[x] : 0.0)); /* E^-1 (F^T's D is F's) */
    if (rc >= 0)
        rc = side_factor(ctx, fa, s);
    double na = 0.0, ninv = 0.0; /* rcond = 1 / (|I - F|_1 |(I - F)^-1|_1), both estimated */
    if (rc >= 0 && rcond)
        rc = norm1_estimate(ctx, fa, s, 0, &na);
    if (rc >= 0 && rcond)
        rc = norm1_estimate(ctx, fa, s, 1, &ninv);
    if (rc < 0) {
        bsti_lr_fact_free(ctx, fa);
        return rc;
    }
    if (rcond)
        *rcond = na > 0 && ninv > 0 ? fmin(1.0, 1.0 / (na * ninv)) : 0.0;
    *out = fa;
    return BST_OK;
}

int bsti_lr_factor(bst_ctx *ctx, const bsti_lr *f, int trans, bsti_lr_fact **out, double *rcond)
{
    *out = NULL;
    if (rcond)
        *rcond = 0.0;
    bsti_lr *m;
    int rc = trans ? bsti_lr_transpose(ctx, f, &m) : bsti_lr_copy(ctx, f, &m);
    return rc < 0 ? rc : factor_side(ctx, m, !!trans, out, rcond);
}

int bsti_lr_factor_take(bst_ctx *ctx, bsti_lr *f, int trans, bsti_lr_fact **out, double *rcond)
{
    *out = NULL;
    if (rcond)
        *rcond = 0.0;
    if (trans && bsti_lr_transpose_take(f) < 0) { /* K not square: a transposed copy */
        bsti_lr *t;
        int rc = bsti_lr_transpose(ctx, f, &t);
        bsti_lr_free(ctx, f);
        if (rc < 0)
            return rc;
        f = t;
    }
    return factor_side(ctx, f, !!trans, out, rcond);
}

/* The indices of B's left scalings among M's (li[i] = M->p for one that is not there). */
static int all_found(const bsti_lr *m, const bsti_lr *b, size_t *li)
{
    int all = 1;
    for (size_t i = 0; i < b->p; i++) {
        li[i] = bsti_lr_find(m->a, m->p, b->a + i * b->N, b->N);
        all &= li[i] < m->p;
    }
    return all;
}

/* (I - M)^-1 B for side s's M and a B whose left scalings are M's (li: where), as at the top:
 * the right list holds M's b_j E^-1 d_B (when B has a diagonal) and B's b_j, the bracket goes
 * into the result's K and is solved there. */
static int solve_matched(bst_ctx *ctx, bsti_lr_fact *fa, int s, const bsti_lr *b, const size_t *li,
                         bsti_lr **out)
{
    const bsti_lr *f = fa->m[s];
    size_t N = f->N, r = f->r, p = f->p, q = f->q, pr = p * r, qmax = (b->d ? q : 0) + b->q;
    double *list = bsti_alloc_array(ctx, qmax * N + 1, sizeof *list);
    double *v = list ? bsti_alloc_array(ctx, N, sizeof *v) : NULL;
    size_t *rj = v ? bsti_alloc_array(ctx, q + b->q + 1, sizeof *rj) : NULL, qn = 0;
    int rc = rj ? BST_OK : BST_ENOMEM;
    for (size_t j = 0; rc >= 0 && b->d && j < q; j++) {
        times(v, f->b + j * N, fa->einv, N);
        times(v, v, b->d, N);
        rj[j] = bsti_lr_find_or_add(list, &qn, v, N);
    }
    for (size_t j = 0; rc >= 0 && j < b->q; j++)
        rj[q + j] = bsti_lr_find_or_add(list, &qn, b->b + j * N, N);
    /* K's only block (one left and one right vector) is written by its first term, not cleared */
    int one = rc >= 0 && p == 1 && qn == 1 && (b->d ? q : 0) + b->p * b->q > 0, first = one;
    if (rc >= 0)
        rc = bsti_lr_alloc(ctx, f->S, p, qn, b->d != NULL, one ? BSTI_LR_K_FILLED : BSTI_LR_K_ZERO,
                           out);
    if (rc >= 0) {
        bsti_lr *m = *out;
        for (size_t i = 0; b->d && i < p; i++)
            for (size_t j = 0; j < q; j++, first = 0)
                bsti_lr_block_put(m->k, pr, i, rj[j], f, i, j, 1.0, first);
        for (size_t i = 0; i < b->p; i++)
            for (size_t j = 0; j < b->q; j++, first = 0)
                bsti_lr_block_put(m->k, pr, li[i], rj[q + j], b, i, j, 1.0, first);
        cap_solve(ctx, fa, s, 0, m->k, qn * r);
        for (size_t x = 0; m->d && x < N; x++)
            m->d[x] = fa->einv[x] * b->d[x];
        for (size_t i = 0; i < p; i++)
            times(m->a + i * N, f->a + i * N, fa->einv, N);
        memcpy(m->b, list, qn * N * sizeof *list);
    }
    bsti_free(ctx, list), bsti_free(ctx, v), bsti_free(ctx, rj);
    return rc;
}

int bsti_lr_fact_solve(bst_ctx *ctx, bsti_lr_fact *fa, int trans, const bsti_lr *b, bsti_lr **out)
{
    int s = !!trans;
    *out = NULL;
    int rc = side_factor(ctx, fa, s);
    if (rc < 0)
        return rc;
    const bsti_lr *f = fa->m[s];
    if (!bsti_lr_same_map(f, b))
        return bsti_error(ctx, BST_EINVAL, "factored matrices over different maps");
    size_t *li = bsti_alloc_array(ctx, b->p + 1, sizeof *li);
    if (!li)
        return BST_ENOMEM;
    if (all_found(f, b, li)) {
        rc = solve_matched(ctx, fa, s, b, li, out);
    } else { /* the inverse, then its product with B */
        bsti_lr *inv;
        rc = bsti_lr_fact_inverse(ctx, fa, s, &inv);
        if (rc >= 0)
            rc = bsti_lr_mul(ctx, inv, b, out);
        bsti_lr_free(ctx, inv);
    }
    bsti_free(ctx, li);
    if (rc < 0) {
        bsti_lr_free(ctx, *out);
        *out = NULL;
    }
    return rc;
}

int bsti_lr_fact_inverse(bst_ctx *ctx, bsti_lr_fact *fa, int trans, bsti_lr **out)
{
    int s = !!trans;
    const bsti_lr *f = fa->m[s] ? fa->m[s] : fa->m[1 - s];
    double *one = bsti_alloc_array(ctx, f->N, sizeof *one);
    bsti_lr *id = NULL;
    *out = NULL;
    int rc = one ? BST_OK : BST_ENOMEM;
    for (size_t x = 0; rc >= 0 && x < f->N; x++)
        one[x] = 1.0;
    if (rc >= 0)
        rc = bsti_lr_new(ctx, f->S, one, NULL, NULL, NULL, &id);
    if (rc >= 0) /* B = I: no left scalings, every one found */
        rc = bsti_lr_fact_solve(ctx, fa, s, id, out);
    bsti_free(ctx, one);
    bsti_lr_free(ctx, id);
    return rc;
}

int bsti_lr_inverse(bst_ctx *ctx, const bsti_lr *f, bsti_lr **out, double *rcond)
{
    bsti_lr_fact *fa;
    *out = NULL;
    int rc = bsti_lr_factor(ctx, f, 0, &fa, rcond);
    if (rc < 0)
        return rc;
    rc = bsti_lr_fact_inverse(ctx, fa, 0, out);
    bsti_lr_fact_free(ctx, fa);
    return rc;
}
