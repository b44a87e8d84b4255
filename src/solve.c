/* solve.c - X = (I - A)^-1 B and Y = B (I - A)^-1, the inter-reflection solves of the stack.
 *
 * (I - A) is factored once by the structure of A and the factorization serves every column of B:
 *   ZERO   - the identity: X = B;
 *   DIAG   - elementwise: X = diag(1 / (1 - a_i)) B, keeping B's structure;
 *   SPARSE - UMFPACK LU of the sparse I - A (umfpack_dl_*), one solve per column of B (no
 *            iterative refinement; the columns shared out among the context's threads): a dense
 *            column by UMFPACK's solve, a sparse one through the factors by CXSparse's
 *            cs_dl_spsolve, which visits only what the column reaches (struct reach);
 *   DENSE  - LAPACK getrf, then getrs on all columns at once, or getri and products with B where B
 *            is sparse with few values (inverse_pays); a mirror-symmetric I - A in two halves
 *            (mirror.h), its inverse's products too (mirror_mul.c) (single precision when A or B is a
 *            dense float matrix, or when the caller asks for single-precision dense work:
 *            bsti_solve_take's prec, the stack's --precision, which also holds for a sparse A
 *            too filled for UMFPACK);
 *   FACTORED - the LU of the Woodbury capacitance (lowrank_solve.c: the dense work has the coarse
 *            information's size); a B factored over A's map (or diagonal, or a sparse P K P^T)
 *            whose left scalings are A's is solved through it, any other multiplied by the
 *            inverse formed from it (mat_lowrank.c).  A right solve factors A^T's capacitance:
 *            the side a solve needs is factored at its first use.
 * The right solve works on transposes: Y^T = (I - A)^-T B^T, with the transposed solve of the same
 * factorization (UMFPACK_At, getrs 'T').
 *
 * Condition: rcond = 1 / (max(1, |I - A|_1) |(I - A)^-1|_1).  |(I - A)^-1|_1 is exact for DIAG, from
 * LAPACK gecon for DENSE, and from Hager's estimator (a few extra solves with the same
 * factorization) for SPARSE.  The scale max(1, |I - A|_1) measures I - A against the identity, so
that rcond also falls when A approaches a multiple of I (two facing mirrors), where forming I - A
cancels digits although I - A itself is well scaled.
 *
 * Workspace: DENSE: a copy of I - A (N^2) and the result, none of them when the caller gives up a
 * dense A and B in the factor's precision (bsti_solve_take: I - A and its LU factors overwrite A,
 * the solution B, a right solve's through B's transpose, formed in place); SPARSE: I - A in CHOLMOD form, UMFPACK's
 * factors, two vectors of N, and the result (accumulated densely, N x ncols, then compacted when B
 * was sparse or diagonal). */
#include <config.h>

#include <math.h>
#include <stdint.h>
#include <string.h>

#include <cblas.h>
#include <lapacke.h>
#include <cs.h>
#include <umfpack.h>

#include "blas_threads.h"
#include "ctx.h"
#include "mat.h"
#include "mirror.h"

/* Factorizations up to this many rows run on one OpenBLAS thread (see dense_factor). */
#define BSTI_LU_SERIAL_MAX 512

/* Lowest warning threshold of a single-precision solve: sqrt(FLT_EPSILON). */
#define BSTI_RCOND_WARN_FLOAT 3.5e-4

/* A sparse A whose LU factors (UMFPACK's estimate after the symbolic analysis) would hold more than
 * this fraction of n^2 values is solved by the dense path instead: column-by-column sparse
 * triangular solves on nearly dense factors are many times slower than LAPACK's blocked ones
 * (measured at n = 4096: a blind layer's step took 60 s sparse against 17 s dense). */
#define BSTI_SPARSE_LU_MAX_FILL 0.2

/* UMFPACK's iterative refinement steps in a sparse solve.  None: I - A, A the product of two
 * reflections or transmissions of norm below 1, is diagonally dominant by columns, so its LU with
 * UMFPACK's diagonal preference is backward stable, and refinement (a residual through A and one
 * more solve a column at each step) only costs: bench/README.md, "Sparse solves". */
#define BSTI_UMF_IRSTEP 0
/* Workspace doubles per row of one sparse solve (umfpack_dl_wsolve: n, 5 n with refinement). */
#define BSTI_UMF_W (BSTI_UMF_IRSTEP > 0 ? 5 : 1)

/* Iterations of Hager's 1-norm estimator (each costs two solves). */
#define HAGER_MAX_ITER 5

/* factor_new's answer for a sparse A whose LU would be nearly dense (not a status of the API). */
#define BSTI_USE_DENSE 100

struct factor {
    bst_ctx *ctx;
    bst_structure s;
    size_t n;
    double anorm;           /* |I - A|_1 */
    double *d;              /* DIAG: 1 - a_i */
    cholmod_sparse *m;      /* SPARSE: I - A */
    void *numeric;          /* SPARSE: UMFPACK numeric factorization */
    bst_precision prec;     /* DENSE */
    void *lu;               /* DENSE: LU factors (double or float) */
    bst_mat *lu_mat;        /* DENSE: the matrix A whose storage holds lu, when it was taken */
    lapack_int *ipiv;
    size_t mirror_g;        /* DENSE: lu holds the mirror split's halves (mirror.h) of this side,
                               0: the whole matrix */
    int mirror_turned;      /* DENSE: and was turned first (bsti_mirror_turn: the y mirror's) */
    double *w1, *w2;        /* SPARSE: vectors of n */
    double control[UMFPACK_CONTROL]; /* SPARSE: UMFPACK's settings for the solves */
    SuiteSparse_long *wi;   /* SPARSE: the caller's thread's solve workspace (sparse_wsolve) */
    double *w;
    bsti_lr_fact *lf;       /* FACTORED: the capacitance's LU (lowrank_solve.c) */
    struct reach *reach;    /* SPARSE: the factors for solves with a sparse column, or NULL */
    int reach_tried;        /* SPARSE: reach_new was called */
};

/* A sparse factorization's factors, P R (I - A) Q = L U (UMFPACK's, R the row scaling), as
 * CXSparse matrices for triangular solves that visit only what a sparse right-hand side reaches
 * (Gilbert and Peierls; cs_dl_spsolve): UMFPACK's own solve sweeps all of L and U for every
 * column, which dominated a mirror blind's step (bench/README.md, "Sparse solves").  For side t
 * (0: M x = b, 1: M^T x = b) the solve is first[t] (lower, its diagonal first in each column)
 * then second[t] (upper, diagonal last): L then U, or U^T then L^T; b's row i goes to position
 * in_pos[t][i] scaled by in_scale[t][i] (NULL: 1), and position k of the solution to row
 * out_pos[t][k] scaled by out_scale[t][k] (NULL: 1). */
struct reach {
    cs_dl *first[2], *second[2];
    SuiteSparse_long *in_pos[2], *out_pos[2];
    double *in_scale[2], *out_scale[2];
    cs_dl *lt, *l, *u, *ut;        /* L^T (UMFPACK's rows of L), L, U, U^T */
    SuiteSparse_long *pinv, *qinv, *p, *q;
    double *r, *rp;                /* r[i]: row i's scale; rp[k] = r[p[k]] */
};

static void reach_free(bst_ctx *ctx, struct reach *h)
{
    if (!h)
        return;
    cs_dl_spfree(h->lt), cs_dl_spfree(h->l), cs_dl_spfree(h->u), cs_dl_spfree(h->ut);
    bsti_free(ctx, h->pinv), bsti_free(ctx, h->qinv), bsti_free(ctx, h->p), bsti_free(ctx, h->q);
    bsti_free(ctx, h->r), bsti_free(ctx, h->rp);
    bsti_free(ctx, h);
}

static void factor_free(struct factor *f)
{
    reach_free(f->ctx, f->reach);
    bst_ctx *ctx = f->ctx;
    bsti_free(ctx, f->d);
    if (f->m)
        cholmod_l_free_sparse(&f->m, bsti_cholmod(ctx));
    if (f->numeric)
        umfpack_dl_free_numeric(&f->numeric);
    if (f->lu_mat)
        bst_mat_free(f->lu_mat);
    else
        bsti_free(ctx, f->lu);
    bsti_free(ctx, f->ipiv);
    bsti_free(ctx, f->w1);
    bsti_free(ctx, f->w2);
    bsti_free(ctx, f->wi);
    bsti_free(ctx, f->w);
    bsti_lr_fact_free(ctx, f->lf);
    memset(f, 0, sizeof *f);
}

static int umfpack_failed(bst_ctx *ctx, const char *what, int status)
{
    if (status == UMFPACK_ERROR_out_of_memory)
        return bsti_error(ctx, BST_ENOMEM, "out of memory (UMFPACK %s)", what);
    if (status == UMFPACK_WARNING_singular_matrix)
        return bsti_error(ctx, BST_ESINGULAR, "I - A is singular (UMFPACK %s)", what);
    return bsti_error(ctx, BST_EINTERNAL, "UMFPACK %s failed (status %d)", what, status);
}

/* f's factors as a reach (f->reach), or f->reach NULL where a column of L or U lacks its diagonal
 * where a triangular solve looks for it (UMFPACK's solve serves then). */
static int reach_new(struct factor *f)
{
    bst_ctx *ctx = f->ctx;
    SuiteSparse_long lnz, unz, nr, nc, nzud, n = (SuiteSparse_long)f->n, recip;
    int st = (int)umfpack_dl_get_lunz(&lnz, &unz, &nr, &nc, &nzud, f->numeric);
    if (st != UMFPACK_OK)
        return umfpack_failed(ctx, "get_lunz", st);
    struct reach *h = bsti_calloc(ctx, 1, sizeof *h);
    if (!h)
        return BST_ENOMEM;
    h->lt = cs_dl_spalloc(n, n, lnz, 1, 0);
    h->u = cs_dl_spalloc(n, n, unz, 1, 0);
    h->pinv = bsti_alloc_array(ctx, (size_t)n, sizeof *h->pinv);
    h->qinv = bsti_alloc_array(ctx, (size_t)n, sizeof *h->qinv);
    h->p = bsti_alloc_array(ctx, (size_t)n, sizeof *h->p);
    h->q = bsti_alloc_array(ctx, (size_t)n, sizeof *h->q);
    h->r = bsti_alloc_array(ctx, (size_t)n, sizeof *h->r);
    h->rp = bsti_alloc_array(ctx, (size_t)n, sizeof *h->rp);
    int rc = h->lt && h->u && h->pinv && h->qinv && h->p && h->q && h->r && h->rp ? BST_OK : BST_ENOMEM;
    if (rc >= 0) {
        st = (int)umfpack_dl_get_numeric(h->lt->p, h->lt->i, h->lt->x, h->u->p, h->u->i, h->u->x,
                                         h->p, h->q, NULL, &recip, h->r, f->numeric);
        if (st != UMFPACK_OK)
            rc = umfpack_failed(ctx, "get_numeric", st);
    }
    if (rc >= 0 && (!(h->l = cs_dl_transpose(h->lt, 1)) || !(h->ut = cs_dl_transpose(h->u, 1))))
        rc = bsti_error(ctx, BST_ENOMEM, "out of memory (transposing a sparse factorization)");
    int usable = rc >= 0;
    for (SuiteSparse_long j = 0; usable && j < n; j++) /* each diagonal where cs_dl_spsolve reads it */
        usable = h->l->p[j + 1] > h->l->p[j] && h->l->i[h->l->p[j]] == j &&
                 h->u->p[j + 1] > h->u->p[j] && h->u->i[h->u->p[j + 1] - 1] == j &&
                 h->ut->p[j + 1] > h->ut->p[j] && h->ut->i[h->ut->p[j]] == j &&
                 h->lt->p[j + 1] > h->lt->p[j] && h->lt->i[h->lt->p[j + 1] - 1] == j;
    if (!usable) {
        reach_free(ctx, h);
        return rc;
    }
    for (SuiteSparse_long i = 0; i < n; i++) {
        h->r[i] = recip ? h->r[i] : 1.0 / h->r[i]; /* now a factor of row i */
        h->pinv[h->p[i]] = i, h->qinv[h->q[i]] = i;
    }
    for (SuiteSparse_long k = 0; k < n; k++)
        h->rp[k] = h->r[h->p[k]];
    /* M x = b: L U (Q^T x) = P R b; M^T x = b: U^T L^T (P R^-1 x) = Q^T b */
    h->first[0] = h->l, h->second[0] = h->u;
    h->in_pos[0] = h->pinv, h->in_scale[0] = h->r, h->out_pos[0] = h->q, h->out_scale[0] = NULL;
    h->first[1] = h->ut, h->second[1] = h->lt;
    h->in_pos[1] = h->qinv, h->in_scale[1] = NULL, h->out_pos[1] = h->p, h->out_scale[1] = h->rp;
    f->reach = h;
    return BST_OK;
}

/* Per thread: the two triangles' column starts (cs_dl_spsolve marks visited columns in them, so
 * each thread has its own copies), the reach stacks and values of both solves, and the scattered
 * right-hand side, 8 n + 2 values in all (reach_room). */
struct reach_work {
    cs_dl g[2];
    SuiteSparse_long *xi, *bi;
    double *x, *bx;
};
static size_t reach_room(size_t n) { return 8 * n + 2; }

/* The work of a thread in room (reach_room(n) values of 8 bytes) for side trans. */
static void reach_work_init(const struct reach *h, int trans, size_t n, void *room, struct reach_work *w)
{
    SuiteSparse_long *l = room;
    w->g[0] = *h->first[trans], w->g[1] = *h->second[trans];
    w->g[0].p = l, w->g[1].p = l + n + 1;
    memcpy(w->g[0].p, h->first[trans]->p, (n + 1) * sizeof *l);
    memcpy(w->g[1].p, h->second[trans]->p, (n + 1) * sizeof *l);
    w->xi = l + 2 * n + 2;          /* 2 n */
    w->bi = w->xi + 2 * n;          /* n */
    w->x = (double *)(w->bi + n);   /* 2 n: both solves' values */
    w->bx = w->x + 2 * n;           /* n */
}

/* x (n values, all written) = M^-1 b or M^-T b for the sparse column b (nb entries at rows bi with
 * values bv), through the reach. */
static void reach_solve(const struct reach *h, int trans, struct reach_work *w, size_t n,
                        const SuiteSparse_long *bi, const double *bv, size_t nb, double *x)
{
    const SuiteSparse_long *ip = h->in_pos[trans], *op = h->out_pos[trans];
    const double *is = h->in_scale[trans], *os = h->out_scale[trans];
    for (size_t e = 0; e < nb; e++)
        w->bi[e] = ip[bi[e]], w->bx[e] = is ? is[bi[e]] * bv[e] : bv[e];
    SuiteSparse_long bp[2] = {0, (SuiteSparse_long)nb};
    cs_dl b = {(SuiteSparse_long)nb, (SuiteSparse_long)n, 1, bp, w->bi, w->bx, -1};
    double *y = w->x, *z = w->x + n;
    SuiteSparse_long *xi = w->xi, top = cs_dl_spsolve(&w->g[0], &b, 0, xi, y, NULL, 1);
    /* the first solve's pattern and values, packed, are the second's right-hand side */
    size_t m = 0;
    for (SuiteSparse_long q = top; q < (SuiteSparse_long)n; q++)
        w->bi[m] = xi[q], w->bx[m++] = y[xi[q]];
    bp[1] = (SuiteSparse_long)m, b.nzmax = (SuiteSparse_long)m;
    top = cs_dl_spsolve(&w->g[1], &b, 0, xi, z, NULL, 0);
    memset(x, 0, n * sizeof *x);
    for (SuiteSparse_long q = top; q < (SuiteSparse_long)n; q++) {
        SuiteSparse_long k = xi[q];
        x[op[k]] = os ? os[k] * z[k] : z[k];
    }
}

/* x = M^-1 b (trans 0) or M^-T b (trans 1) with the sparse factorization, through the workspace
 * wi (n) and w (n doubles, or 5 n with iterative refinement): UMFPACK's status.  The factorization
 * is only read, so that threads with workspaces of their own may solve at once. */
static int sparse_wsolve(const struct factor *f, int trans, double *x, const double *b,
                         SuiteSparse_long *wi, double *w)
{
    return (int)umfpack_dl_wsolve(trans ? UMFPACK_At : UMFPACK_A, f->m->p, f->m->i, f->m->x, x, b,
                                  f->numeric, f->control, NULL, wi, w);
}

/* Solve in place with the sparse factorization: x := M^-1 x (trans 0) or M^-T x (trans 1). */
static int sparse_apply(struct factor *f, int trans, double *x)
{
    memcpy(f->w1, x, f->n * sizeof *x);
    int st = sparse_wsolve(f, trans, x, f->w1, f->wi, f->w);
    if (st < 0)
        return umfpack_failed(f->ctx, "solve", st);
    return BST_OK;
}

/* |M^-1|_1 by Hager's method (Higham 1988, with the alternating-sign safeguard). */
static int hager_inverse_norm(struct factor *f, double *est)
{
    size_t n = f->n;
    double *x = f->w2;
    double *y = bsti_alloc_array(f->ctx, n, sizeof *y);
    if (!y)
        return BST_ENOMEM;
    int rc = BST_OK;
    double e = 0.0;
    for (size_t i = 0; i < n; i++)
        x[i] = 1.0 / (double)n;
    for (int it = 0; it < HAGER_MAX_ITER; it++) {
        memcpy(y, x, n * sizeof *y);
        if ((rc = sparse_apply(f, 0, y)) < 0)
            break;
        double en = 0.0;
        for (size_t i = 0; i < n; i++)
            en += fabs(y[i]);
        if (it > 0 && en <= e)
            break;
        e = en;
        for (size_t i = 0; i < n; i++)
            y[i] = y[i] >= 0.0 ? 1.0 : -1.0;
        if ((rc = sparse_apply(f, 1, y)) < 0)
            break;
        size_t jmax = 0;
        double zx = 0.0;
        for (size_t i = 0; i < n; i++) {
            zx += y[i] * x[i];
            if (fabs(y[i]) > fabs(y[jmax]))
                jmax = i;
        }
        if (it > 0 && fabs(y[jmax]) <= zx)
            break;
        memset(x, 0, n * sizeof *x);
        x[jmax] = 1.0;
    }
    if (rc == BST_OK && n > 1) { /* safeguard vector: alternating signs of growing size */
        for (size_t i = 0; i < n; i++)
            y[i] = (i % 2 ? -1.0 : 1.0) * (1.0 + (double)i / (double)(n - 1));
        if ((rc = sparse_apply(f, 0, y)) == BST_OK) {
            double t = 0.0;
            for (size_t i = 0; i < n; i++)
                t += fabs(y[i]);
            e = fmax(e, 2.0 * t / (3.0 * (double)n));
        }
    }
    bsti_free(f->ctx, y);
    *est = e;
    return rc;
}

/* I - A of each structure factored into f (factor_new says how; the context, structure, order and
 * *rcond = 1 set before). */
static int factor_zero(bst_ctx *ctx, const bst_mat *a, bst_precision prec, struct factor *f,
                       double *rcond, bst_mat **take)
{
    (void)ctx, (void)a, (void)prec, (void)rcond, (void)take;
    f->anorm = 1.0;
    return BST_OK;
}

static int factor_diag(bst_ctx *ctx, const bst_mat *a, bst_precision prec, struct factor *f,
                       double *rcond, bst_mat **take)
{
    (void)prec, (void)take;
    size_t n = a->rows;
    if (!(f->d = bsti_alloc_array(ctx, n, sizeof *f->d)))
        return BST_ENOMEM;
    double dmin = INFINITY, dmax = 0.0;
    for (size_t i = 0; i < n; i++) {
        f->d[i] = 1.0 - a->diag[i];
        dmin = fmin(dmin, fabs(f->d[i]));
        dmax = fmax(dmax, fabs(f->d[i]));
    }
    f->anorm = dmax;
    if (n == 0)
        return BST_OK;
    *rcond = dmin / fmax(1.0, dmax);
    if (!(dmin > 0.0) || !isfinite(dmax))
        return bsti_error(ctx, BST_ESINGULAR, "I - A is singular (diagonal element %s)",
                          isfinite(dmax) ? "1 - a = 0" : "not finite");
    return BST_OK;
}

/* A signature of a packed sparse matrix's pattern (its size, column starts and row indices), 0
 * for one not packed. */
static unsigned long long pattern_signature(const cholmod_sparse *s)
{
    if (!s->packed)
        return 0;
    const SuiteSparse_long *p = s->p, *ri = s->i;
    size_t n = s->ncol, nz = (size_t)p[n];
    uint64_t h = 0x9e3779b97f4a7c15u ^ ((uint64_t)s->nrow << 32) ^ (uint64_t)n;
    for (size_t j = 0; j <= n; j++)
        h = (h ^ (uint64_t)p[j]) * 0x100000001b3u;
    for (size_t q = 0; q < nz; q++)
        h = (h ^ (uint64_t)ri[q]) * 0x100000001b3u;
    h ^= h >> 29;
    return (unsigned long long)(h ? h : 1);
}

static int refused_before(const bst_ctx *ctx, unsigned long long sig)
{
    for (int q = 0; sig && q < BSTI_REFUSED_SLOTS; q++)
        if (ctx->refused[q] == sig)
            return 1;
    return 0;
}

static int factor_sparse(bst_ctx *ctx, const bst_mat *a, bst_precision prec, struct factor *f,
                         double *rcond, bst_mat **take)
{
    (void)prec, (void)take;
    size_t n = a->rows;
    /* The LU's fill is the pattern's: an A whose pattern's analysis was refused before (the
       same step of another channel: the layers' patterns are the channels') goes dense without
       analysing it again (about 1.2 s at k = 7).  A signature met by another pattern by chance
       only sends that A to the dense path, which solves it too. */
    unsigned long long sig = pattern_signature(a->sp);
    if (refused_before(ctx, sig)) {
        ctx->refusals_remembered++;
        return BSTI_USE_DENSE;
    }
    cholmod_common *cc = bsti_cholmod(ctx);
    if (!cc)
        return BST_ENOMEM;
    cholmod_sparse *id = cholmod_l_speye(n, n, CHOLMOD_REAL, cc);
    double one[2] = {1, 0}, minus[2] = {-1, 0};
    f->m = id ? cholmod_l_add(id, a->sp, one, minus, 1, 1, cc) : NULL;
    cholmod_l_free_sparse(&id, cc);
    if (!f->m)
        return bsti_error(ctx, BST_ENOMEM, "out of memory (forming I - A)");
    SuiteSparse_long *p = f->m->p, *ri = f->m->i;
    double *x = f->m->x;
    for (size_t j = 0; j < n; j++) {
        double s = 0.0;
        for (SuiteSparse_long q = p[j]; q < p[j + 1]; q++)
            s += fabs(x[q]);
        f->anorm = isfinite(s) ? fmax(f->anorm, s) : s;
        if (!isfinite(s))
            break;
    }
    if (!isfinite(f->anorm))
        return bsti_error(ctx, BST_ESINGULAR, "I - A has non-finite elements");
    void *symbolic = NULL;
    double info[UMFPACK_INFO];
    int st = umfpack_dl_symbolic((SuiteSparse_long)n, (SuiteSparse_long)n, p, ri, x, &symbolic,
                                 NULL, info);
    if (st < 0)
        return umfpack_failed(ctx, "symbolic", st);
    if (info[UMFPACK_LNZ_ESTIMATE] + info[UMFPACK_UNZ_ESTIMATE] >
        BSTI_SPARSE_LU_MAX_FILL * (double)n * (double)n) {
        umfpack_dl_free_symbolic(&symbolic);
        if (sig) {
            ctx->refused[ctx->refused_next] = sig;
            ctx->refused_next = (ctx->refused_next + 1) % BSTI_REFUSED_SLOTS;
        }
        return BSTI_USE_DENSE;
    }
    st = umfpack_dl_numeric(p, ri, x, symbolic, &f->numeric, NULL, NULL);
    umfpack_dl_free_symbolic(&symbolic);
    if (st != UMFPACK_OK)
        return umfpack_failed(ctx, "numeric", st);
    umfpack_dl_defaults(f->control);
    f->control[UMFPACK_IRSTEP] = BSTI_UMF_IRSTEP;
    f->w1 = bsti_alloc_array(ctx, n, sizeof *f->w1);
    f->w2 = bsti_alloc_array(ctx, n, sizeof *f->w2);
    f->wi = bsti_alloc_array(ctx, n, sizeof *f->wi);
    f->w = bsti_alloc_array(ctx, BSTI_UMF_W * n, sizeof *f->w);
    if (!f->w1 || !f->w2 || !f->wi || !f->w)
        return BST_ENOMEM;
    double inv;
    int rc = hager_inverse_norm(f, &inv);
    if (rc < 0)
        return rc;
    *rcond = (inv > 0.0 && isfinite(inv)) ? 1.0 / (fmax(1.0, f->anorm) * inv) : 0.0;
    if (*rcond == 0.0)
        return bsti_error(ctx, BST_ESINGULAR, "I - A is singular to working precision");
    return BST_OK;
}

/* The first (half 0) or the second half's block of a mirror-split dense factorization (mirror.h):
 * the top-left quarter, or the bottom-right one. */
static void *block(const struct factor *f, int half)
{
    size_t h = f->n / 2, off = half ? h * f->n + h : 0;
    return f->prec == BST_DOUBLE ? (void *)((double *)f->lu + off) : (void *)((float *)f->lu + off);
}

/* LU (getrf) and condition estimate (gecon against scale) of the n x n block a (leading dimension
 * lda) in precision prec. */
static int lu_block(bst_ctx *ctx, bst_precision prec, size_t n, size_t lda, void *a,
                    lapack_int *ipiv, double scale, double *rcond)
{
    lapack_int N = (lapack_int)n, LDA = (lapack_int)lda, info;
    /* OpenBLAS's threaded getrf spends small factorizations in thread hand-offs (N = 145: 60%
     * of a Klems spectral stack's run in dgetrf_parallel): below BSTI_LU_SERIAL_MAX rows, one
     * thread.  (OpenBLAS's thread count is process-wide: set back at once.) */
    int threads = openblas_get_num_threads();
    if (n <= BSTI_LU_SERIAL_MAX && threads > 1)
        openblas_set_num_threads(1);
    double dn = (double)n;
    bsti_flops_add(ctx, 2.0 / 3.0 * dn * dn * dn - 0.5 * dn * dn + 5.0 / 6.0 * dn);
    if (prec == BST_DOUBLE) {
        info = LAPACKE_dgetrf_work(LAPACK_COL_MAJOR, N, N, a, LDA, ipiv);
        if (info == 0)
            info = LAPACKE_dgecon(LAPACK_COL_MAJOR, '1', N, a, LDA, scale, rcond);
    } else {
        float rc32 = 0.0f;
        info = LAPACKE_sgetrf_work(LAPACK_COL_MAJOR, N, N, a, LDA, ipiv);
        if (info == 0)
            info = LAPACKE_sgecon(LAPACK_COL_MAJOR, '1', N, a, LDA, (float)scale, &rc32);
        *rcond = rc32;
    }
    if (n <= BSTI_LU_SERIAL_MAX && threads > 1)
        openblas_set_num_threads(threads);
    if (info > 0 || *rcond == 0.0) {
        *rcond = 0.0;
        return bsti_error(ctx, BST_ESINGULAR, "I - A is singular (zero pivot %d)", (int)info);
    }
    if (info < 0)
        return bsti_error(ctx, BST_EINTERNAL, "LAPACK getrf/gecon: argument %d", (int)-info);
    return BST_OK;
}

static int lu_dense(bst_ctx *ctx, struct factor *f, double *rcond);

static int factor_dense(bst_ctx *ctx, const bst_mat *a, bst_precision prec, struct factor *f,
                        double *rcond, bst_mat **take)
{
    size_t n = a->rows;
    f->prec = prec;
    size_t es = prec == BST_DOUBLE ? sizeof(double) : sizeof(float);
    if (!(f->ipiv = bsti_alloc_array(ctx, n ? n : 1, sizeof *f->ipiv)))
        return BST_ENOMEM;
    if (*take == a && a->prec == prec) { /* each element is read before it is overwritten */
        f->lu_mat = *take;
        f->lu = f->lu_mat->dense;
        *take = NULL;
    } else if (!(f->lu = bsti_alloc_array(ctx, n * n, es))) {
        return BST_ENOMEM;
    }
    for (size_t j = 0; j < n; j++) {
        double s = 0.0;
        for (size_t i = 0; i < n; i++) {
            double v = (i == j ? 1.0 : 0.0) - bsti_dense_get(a, i, j);
            s += fabs(v); /* a NaN or infinity makes s non-finite */
            if (prec == BST_DOUBLE)
                ((double *)f->lu)[j * n + i] = v;
            else
                ((float *)f->lu)[j * n + i] = (float)v;
        }
        f->anorm = isfinite(s) ? fmax(f->anorm, s) : s;
        if (!isfinite(s))
            break;
    }
    if (!isfinite(f->anorm))
        return bsti_error(ctx, BST_ESINGULAR, "I - A has non-finite elements");
    if (n == 0)
        return BST_OK;
    size_t g = ctx->no_mirror ? 0 : bsti_mirror_side(n);
    if (g && (bsti_mirror_holds(f->lu, prec, n, g, 0) ||
              (f->mirror_turned = bsti_mirror_holds(f->lu, prec, n, g, 1)))) {
        f->mirror_g = g;
        ctx->mirror_splits++;
        if (f->mirror_turned)
            bsti_mirror_turn(f->lu, prec, n, g, n, 1);
        bsti_mirror_matrix(f->lu, prec, n, g, 1);
    }
    return lu_dense(ctx, f, rcond);
}

/* A sparse A whose LU would be nearly dense (factor_sparse's BSTI_USE_DENSE) and that commutes with
 * the mirror: I - A made dense as its split's halves straight from A's values (mirror_mul.c), where
 * a dense copy of A, I - A formed from it, its symmetry read and its halves made were four passes
 * over N^2 values (about 3 s at k = 7), and the quarters off the halves were never needed; then
 * the halves' LU.  BSTI_USE_DENSE when that does not apply (no mirror split, no symmetry, a value
 * not finite: the dense path then tells). */
static int factor_split_sparse(bst_ctx *ctx, const bst_mat *a, bst_precision prec,
                               struct factor *f, double *rcond)
{
    size_t n = a->rows, g = ctx->no_mirror ? 0 : bsti_mirror_side(n);
    memset(f, 0, sizeof *f);
    f->ctx = ctx, f->s = BST_DENSE, f->n = n, f->prec = prec;
    *rcond = 1.0;
    if (!g || a->s != BST_SPARSE)
        return BSTI_USE_DENSE;
    const SuiteSparse_long *p = a->sp->p, *ri = a->sp->i;
    const double *x = a->sp->x;
    for (size_t j = 0; j < n; j++) { /* |I - A|_1 */
        double s = 1.0;
        for (SuiteSparse_long q = p[j]; q < p[j + 1]; q++)
            s += (size_t)ri[q] == j ? fabs(1.0 - x[q]) - 1.0 : fabs(x[q]);
        if (!isfinite(s))
            return BSTI_USE_DENSE;
        f->anorm = fmax(f->anorm, s);
    }
    size_t es = prec == BST_DOUBLE ? sizeof(double) : sizeof(float);
    if (!(f->ipiv = bsti_alloc_array(ctx, n, sizeof *f->ipiv)) ||
        !(f->lu = bsti_alloc_array(ctx, n * n, es)))
        return BST_ENOMEM;
    if (bsti_mirror_split_sparse(ctx, a->sp, prec, g, f->lu, &f->mirror_turned) != BST_OK)
        return BSTI_USE_DENSE;
    f->mirror_g = g;
    ctx->mirror_splits++;
    return lu_dense(ctx, f, rcond);
}

/* The LU of a dense factor's I - A in f->lu, whole or as its split's two halves, and *rcond. */
static int lu_dense(bst_ctx *ctx, struct factor *f, double *rcond)
{
    bst_precision prec = f->prec;
    size_t n = f->n;
    double scale = fmax(1.0, f->anorm);
    if (!f->mirror_g)
        return lu_block(ctx, prec, n, n, f->lu, f->ipiv, scale, rcond);
    /* the halves: rcond from the larger of their inverses' norms, a bound within a factor 2 of
       the whole inverse's (mirror.h) */
    size_t h = n / 2;
    double rc2;
    int rc = lu_block(ctx, prec, h, n, f->lu, f->ipiv, scale, rcond);
    if (rc >= 0 && (rc = lu_block(ctx, prec, h, n, block(f, 1), f->ipiv + h, scale, &rc2)) >= 0)
        *rcond = fmin(*rcond, rc2);
    if (rc < 0)
        *rcond = 0.0;
    return rc;
}

/* I - A factored by its capacitance (lowrank_solve.c), on the side of a left (right 0) or right
 * solve; *rcond its estimate.  With *take = a (A given up) the factorization takes A's factors
 * instead of a copy (a K of (p r)^2 values: 128 MiB for a k = 6 tree read at k = 7), and A is
 * left an empty shell for the caller to free. */
static int factor_lowrank(bst_ctx *ctx, const bst_mat *a, int right, struct factor *f,
                          double *rcond, bst_mat **take)
{
    f->anorm = 1.0;
    if (*take != a)
        return bsti_lr_factor(ctx, a->lr, right, &f->lf, rcond);
    bsti_lr *lr = (*take)->lr;
    (*take)->lr = NULL;
    return bsti_lr_factor_take(ctx, lr, right, &f->lf, rcond);
}

/* X = (I - A)^-1 B (trans 0) or (I - A)^-T B for a FACTORED A: through the capacitance when B is
 * factored over A's map (or a diagonal, or a sparse P K P^T there), else B times the inverse. */
static int lowrank_solve(struct factor *f, int trans, const bst_mat *b, bst_mat **out)
{
    bst_ctx *ctx = f->ctx;
    const bsti_lr *fl = f->lf->m[0] ? f->lf->m[0] : f->lf->m[1];
    bsti_lr *lb = NULL, *x, *inv;
    const bsti_lr *bl = b->s == BST_FACTORED ? b->lr : NULL;
    int rc = BST_OK;
    if (!bl && (rc = bsti_mat_lr_operand(ctx, b, fl->S, &lb)) < 0 && rc != BST_ENOTFOUND)
        return rc;
    if (lb)
        bl = lb;
    if (bl && bsti_lr_same_map(fl, bl)) {
        rc = bsti_lr_fact_solve(ctx, f->lf, trans, bl, &x);
        bsti_lr_free(ctx, lb);
        if (rc >= 0 && (rc = bsti_mat_from_lr(ctx, x, out)) >= 0 &&
            (rc = bsti_mat_lr_settle(ctx, out)) < 0) {
            bst_mat_free(*out);
            *out = NULL;
        }
        return rc;
    }
    bsti_lr_free(ctx, lb);
    bst_mat *z;
    if ((rc = bsti_lr_fact_inverse(ctx, f->lf, trans, &inv)) < 0 ||
        (rc = bsti_mat_from_lr(ctx, inv, &z)) < 0)
        return rc;
    rc = bst_mat_mul(ctx, z, b, 0.0, out);
    bst_mat_free(z);
    return rc;
}

/* Factor I - A; *rcond as documented at the top.  With *take = a (A given up by the caller) a
 * dense A in the factor's precision is overwritten by I - A and then its LU factors, and the factor
 * owns it (*take = NULL): no second N x N buffer. */
static int factor_new(bst_ctx *ctx, const bst_mat *a, bst_precision prec, int right,
                      struct factor *f, double *rcond, bst_mat **take)
{
    typedef int (*factor_fn)(bst_ctx *, const bst_mat *, bst_precision, struct factor *, double *,
                             bst_mat **);
    static const factor_fn by_structure[] = {
        [BST_ZERO] = factor_zero, [BST_DIAG] = factor_diag, [BST_SPARSE] = factor_sparse,
        [BST_DENSE] = factor_dense};
    memset(f, 0, sizeof *f);
    f->ctx = ctx;
    f->s = a->s;
    f->n = a->rows;
    *rcond = 1.0;
    if (a->s == BST_FACTORED)
        return factor_lowrank(ctx, a, right, f, rcond, take);
    if ((unsigned)a->s >= sizeof by_structure / sizeof by_structure[0] || !by_structure[a->s])
        return bsti_error(ctx, BST_EINVAL, "solve: unknown structure");
    return by_structure[a->s](ctx, a, prec, f, rcond, take);
}

/* x (n x nrhs, leading dimension n) := M^-1 x or M^-T x with the LU factors lu of an n x n block
 * (leading dimension lda). */
static int getrs_block(struct factor *f, int trans, size_t n, size_t lda, void *lu,
                       lapack_int *ipiv, size_t nrhs, size_t ldx, void *x)
{
    lapack_int N = (lapack_int)n, NR = (lapack_int)nrhs, info;
    char t = trans ? 'T' : 'N';
    bsti_flops_add(f->ctx, (2.0 * (double)n - 1.0) * (double)n * (double)nrhs);
    int saved = bsti_blas_serial_begin(n);
    if (f->prec == BST_DOUBLE)
        info = LAPACKE_dgetrs_work(LAPACK_COL_MAJOR, t, N, NR, lu, (lapack_int)lda, ipiv, x,
                                   (lapack_int)ldx);
    else
        info = LAPACKE_sgetrs_work(LAPACK_COL_MAJOR, t, N, NR, lu, (lapack_int)lda, ipiv, x,
                                   (lapack_int)ldx);
    bsti_blas_serial_end(saved);
    if (info != 0)
        return bsti_error(f->ctx, BST_EINTERNAL, "LAPACK getrs: argument %d", (int)-info);
    return BST_OK;
}

/* x := M^-1 x or M^-T x with the dense factorization; x is dense in the factor's precision.  A
 * mirror-split factorization solves x's pair sums and differences with its halves (mirror.h). */
static int dense_solve_in_place(struct factor *f, int trans, bst_mat *x)
{
    size_t n = f->n, g = f->mirror_g, h = n / 2;
    if (!n || !x->cols)
        return BST_OK;
    if (!g)
        return getrs_block(f, trans, n, n, f->lu, f->ipiv, x->cols, n, x->dense);
    if (f->mirror_turned)
        bsti_mirror_turn(x->dense, f->prec, n, g, x->cols, 0);
    bsti_mirror_rows(x->dense, f->prec, n, g, x->cols, 1);
    size_t es = f->prec == BST_DOUBLE ? sizeof(double) : sizeof(float);
    int rc = getrs_block(f, trans, h, n, f->lu, f->ipiv, x->cols, n, x->dense);
    if (rc >= 0)
        rc = getrs_block(f, trans, h, n, block(f, 1), f->ipiv + h, x->cols, n,
                         (char *)x->dense + h * es);
    bsti_mirror_rows(x->dense, f->prec, n, g, x->cols, 0);
    if (f->mirror_turned)
        bsti_mirror_turn(x->dense, f->prec, n, g, x->cols, 0);
    return rc;
}

/* A sparse factorization's solves with columns j0 .. j1 - 1 of b into those of the dense x (n rows),
 * through a right-hand side bcol (n, zero on entry and on return) and the workspace wi, w. */
struct sparse_cols {
    const struct factor *f;
    int trans;
    const bst_mat *b;
    double *x;             /* column j's solution at x + (j - xj0) n */
    size_t xj0;
    size_t j0, j1;
    double *bcol;
    SuiteSparse_long *wi;
    double *w;
    void *reach_room;      /* reach_room(n) values: solve through f->reach (B not dense) */
    int status;            /* UMFPACK's first failure, or 0 */
};

/* Sparse solves shared out among threads from this many result values (N x columns) on. */
#define SPARSE_SOLVE_PAR_MIN ((double)(1 << 20))
/* Columns a thread solves at a time where the result is gathered sparse (solve_to_sparse). */
#define SPARSE_SOLVE_CHUNK 64

/* Column j of b into col (n values, zero where b's column has nothing: only b's entries are
 * written), or (put 0) those entries back to zero. */
static void put_column(const bst_mat *b, size_t j, double *col, int put)
{
    switch (b->s) {
    case BST_DIAG: col[j] = put ? b->diag[j] : 0.0; break;
    case BST_SPARSE: {
        const SuiteSparse_long *p = b->sp->p, *ri = b->sp->i;
        const double *bx = b->sp->x;
        for (SuiteSparse_long q = p[j]; q < p[j + 1]; q++)
            col[ri[q]] = put ? bx[q] : 0.0;
        break;
    }
    case BST_DENSE:
        for (size_t i = 0; i < b->rows; i++)
            col[i] = put ? bsti_dense_get(b, i, j) : 0.0;
        break;
    default: break;
    }
}

static void *sparse_cols_run(void *arg)
{
    struct sparse_cols *t = arg;
    const bst_mat *b = t->b;
    size_t n = t->f->n;
    if (t->reach_room) { /* each column from what it reaches */
        struct reach_work w;
        reach_work_init(t->f->reach, t->trans, n, t->reach_room, &w);
        for (size_t j = t->j0; j < t->j1; j++) {
            double *x = t->x + (j - t->xj0) * n;
            if (b->s == BST_SPARSE) {
                const SuiteSparse_long *p = b->sp->p;
                reach_solve(t->f->reach, t->trans, &w, n, (const SuiteSparse_long *)b->sp->i + p[j],
                            (const double *)b->sp->x + p[j], (size_t)(p[j + 1] - p[j]), x);
            } else {
                SuiteSparse_long row = (SuiteSparse_long)j;
                reach_solve(t->f->reach, t->trans, &w, n, &row, &b->diag[j], 1, x);
            }
        }
        return NULL;
    }
    memset(t->bcol, 0, n * sizeof *t->bcol);
    for (size_t j = t->j0; j < t->j1 && t->status >= 0; j++) {
        put_column(b, j, t->bcol, 1);
        int st = sparse_wsolve(t->f, t->trans, t->x + (j - t->xj0) * n, t->bcol, t->wi, t->w);
        if (st < 0)
            t->status = st;
        put_column(b, j, t->bcol, 0); /* bcol back to zeros */
    }
    return NULL;
}

/* The values of x (n x nc, column-major) that are not zero appended to the columns from j0 on of
 * cp (starts), ri (rows) and v, grown as needed (*cap values); *diag_only cleared by one off the
 * diagonal. */
static int gather_nonzeros(bst_ctx *ctx, const double *x, size_t n, size_t nc, size_t j0,
                           SuiteSparse_long *cp, SuiteSparse_long **ri, double **v, size_t *cap,
                           int *diag_only)
{
    size_t nz = (size_t)cp[j0];
    for (size_t jj = 0; jj < nc; jj++) {
        const double *col = x + jj * n;
        for (size_t i = 0; i < n; i++) {
            if (col[i] == 0.0)
                continue;
            if (nz == *cap) { /* doubled: the copies cost O(nnz) in all */
                size_t c2 = 2 * *cap;
                SuiteSparse_long *r2 = bsti_alloc_array(ctx, c2, sizeof *r2);
                double *v2 = r2 ? bsti_alloc_array(ctx, c2, sizeof *v2) : NULL;
                if (!v2) {
                    bsti_free(ctx, r2);
                    return BST_ENOMEM;
                }
                memcpy(r2, *ri, nz * sizeof *r2), memcpy(v2, *v, nz * sizeof *v2);
                bsti_free(ctx, *ri), bsti_free(ctx, *v);
                *ri = r2, *v = v2, *cap = c2;
            }
            (*ri)[nz] = (SuiteSparse_long)i, (*v)[nz++] = col[i];
            if (i != j0 + jj)
                *diag_only = 0;
        }
        cp[j0 + jj + 1] = (SuiteSparse_long)nz;
    }
    return BST_OK;
}

/* X = M^-1 B (or M^-T B) for a sparse or diagonal B through the threads' parts (their workspaces
 * set), SPARSE_SOLVE_CHUNK columns a thread at a time into a buffer whose values that are not
 * zero are gathered by column: *out as bst_mat_compact makes it of the dense X (zero, diagonal,
 * sparse up to BST_SPARSE_MAX_FILL, else dense), the same values, without its n x columns of
 * doubles (a mirror blind's step at k = 7: 2 GiB for 10.5 million values). */
static int solve_to_sparse(struct factor *f, const bst_mat *b, struct sparse_cols *part, size_t nw,
                           bst_mat **out)
{
    bst_ctx *ctx = f->ctx;
    size_t n = f->n, cols = b->cols, chunk = nw * SPARSE_SOLVE_CHUNK, cap = 4 * (n > cols ? n : cols);
    if (chunk > cols)
        chunk = cols;
    double *buf = bsti_alloc_array(ctx, n * chunk, sizeof *buf), *v = bsti_alloc_array(ctx, cap, sizeof *v);
    SuiteSparse_long *cp = bsti_alloc_array(ctx, cols + 1, sizeof *cp);
    SuiteSparse_long *ri = bsti_alloc_array(ctx, cap, sizeof *ri);
    int rc = buf && v && cp && ri ? BST_OK : BST_ENOMEM, diag_only = n == cols;
    if (rc >= 0)
        cp[0] = 0;
    for (size_t j0 = 0; j0 < cols && rc >= 0; j0 += chunk) {
        size_t nc = cols - j0 < chunk ? cols - j0 : chunk;
        for (size_t t = 0; t < nw; t++)
            part[t].x = buf, part[t].xj0 = j0, part[t].j0 = j0 + nc * t / nw,
            part[t].j1 = j0 + nc * (t + 1) / nw;
        bsti_run_parts(part, sizeof *part, nw, sparse_cols_run);
        for (size_t t = 0; t < nw && rc >= 0; t++)
            if (part[t].status < 0)
                rc = umfpack_failed(ctx, "solve", part[t].status);
        if (rc >= 0)
            rc = gather_nonzeros(ctx, buf, n, nc, j0, cp, &ri, &v, &cap, &diag_only);
    }
    bsti_free(ctx, buf);
    size_t nz = rc >= 0 ? (size_t)cp[cols] : 0;
    cholmod_common *cc = rc >= 0 ? bsti_cholmod(ctx) : NULL;
    cholmod_sparse *sp = cc ? cholmod_l_allocate_sparse(n, cols, nz, 1, 1, 0, CHOLMOD_REAL, cc) : NULL;
    bst_mat *m = NULL;
    if (rc < 0) {
        /* reported */
    } else if (!sp) {
        rc = cc ? bsti_mat_cholmod_failed(ctx, "allocate_sparse") : BST_ENOMEM;
    } else {
        memcpy(sp->p, cp, (cols + 1) * sizeof *cp);
        memcpy(sp->i, ri, nz * sizeof *ri);
        memcpy(sp->x, v, nz * sizeof *v);
        rc = bsti_mat_from_cholmod(ctx, sp, &m);
    }
    bsti_free(ctx, v), bsti_free(ctx, ri), bsti_free(ctx, cp);
    /* what bst_mat_compact would change (nothing, or only the diagonal, or too many values) it
     * makes; the common sparse result is kept as gathered */
    if (rc >= 0 && (nz == 0 || diag_only || (double)nz > BST_SPARSE_MAX_FILL * (double)n * (double)cols)) {
        rc = bst_mat_compact(ctx, m, BST_SPARSE_MAX_FILL, out);
        bst_mat_free(m);
    } else if (rc >= 0) {
        *out = m;
    }
    return rc;
}

/* X = M^-1 B (trans 0) or M^-T B (trans 1) for the factored M = I - A. */
static int factor_solve(struct factor *f, int trans, const bst_mat *b, bst_mat **out)
{
    bst_ctx *ctx = f->ctx;
    size_t n = f->n;
    int rc = BST_OK;
    if (b->s == BST_ZERO || f->s == BST_ZERO)
        return bst_mat_convert(ctx, b, b->s, b->prec, out);
    if (f->s == BST_DIAG) {
        double *inv = bsti_alloc_array(ctx, n, sizeof *inv);
        if (!inv)
            return BST_ENOMEM;
        for (size_t i = 0; i < n; i++)
            inv[i] = 1.0 / f->d[i]; /* transposing a diagonal changes nothing */
        rc = bst_mat_scale(ctx, inv, b, NULL, out);
        bsti_free(ctx, inv);
        return rc;
    }
    if (f->s == BST_FACTORED)
        return lowrank_solve(f, trans, b, out);
    if (f->s == BST_DENSE) {
        bst_mat *x;
        if ((rc = bst_mat_convert(ctx, b, BST_DENSE, f->prec, &x)) < 0)
            return rc;
        if ((rc = dense_solve_in_place(f, trans, x)) < 0) {
            bst_mat_free(x);
            return rc;
        }
        *out = x;
        return BST_OK;
    }
    /* SPARSE factorization: column by column, the columns shared out among the context's threads
     * where there are many (each column solved alone: the same bits on any number of threads);
     * a dense B's into a dense double result, a sparse or diagonal one's gathered sparse */
    size_t cols = b->cols;
    struct sparse_cols part[BST_THREADS_MAX];
    size_t nw = (double)n * (double)cols >= SPARSE_SOLVE_PAR_MIN
                    ? (size_t)bsti_ctx_workers_no_alloc(ctx, cols) : 1;
    /* workspace: a right-hand side, wi and w for each thread but the caller's (f's own) */
    double *ws = nw > 1 ? bsti_alloc_array(ctx, (nw - 1) * (1 + BSTI_UMF_W) * n, sizeof *ws) : NULL;
    SuiteSparse_long *wis = nw > 1 ? bsti_alloc_array(ctx, (nw - 1) * n, sizeof *wis) : NULL;
    if (nw > 1 && (!ws || !wis)) {
        bsti_free(ctx, ws), bsti_free(ctx, wis);
        ws = NULL, wis = NULL, nw = 1;
    }
    for (size_t t = 0; t < nw; t++) {
        part[t] = (struct sparse_cols){f, trans, b, NULL, 0, 0, 0, f->w1, f->wi, f->w, NULL, 0};
        if (t > 0) {
            double *wt = ws + (t - 1) * (1 + BSTI_UMF_W) * n;
            part[t].bcol = wt, part[t].w = wt + n, part[t].wi = wis + (t - 1) * n;
        }
    }
    bst_mat *x = NULL;
    double *room = NULL;
    if (b->s != BST_DENSE && !f->reach_tried) {
        f->reach_tried = 1;
        rc = reach_new(f);
    }
    if (rc >= 0 && b->s != BST_DENSE && f->reach) {
        if ((room = bsti_alloc_array(ctx, nw * reach_room(n), sizeof *room)) == NULL)
            rc = BST_ENOMEM;
        for (size_t t = 0; room && t < nw; t++)
            part[t].reach_room = room + t * reach_room(n);
    }
    if (rc < 0) {
        /* reported */
    } else if (b->s != BST_DENSE) {
        rc = solve_to_sparse(f, b, part, nw, &x);
    } else if ((rc = bst_mat_new_dense(ctx, n, cols, BST_DOUBLE, &x)) >= 0) {
        for (size_t t = 0; t < nw; t++)
            part[t].x = x->dense, part[t].j0 = cols * t / nw, part[t].j1 = cols * (t + 1) / nw;
        bsti_run_parts(part, sizeof *part, nw, sparse_cols_run);
        for (size_t t = 0; t < nw && rc >= 0; t++)
            if (part[t].status < 0)
                rc = umfpack_failed(ctx, "solve", part[t].status);
        if (rc >= 0 && b->prec == BST_FLOAT) {
            bst_mat *c;
            rc = bst_mat_convert(ctx, x, BST_DENSE, BST_FLOAT, &c);
            if (rc >= 0) {
                bst_mat_free(x);
                x = c;
            }
        }
    }
    bsti_free(ctx, ws), bsti_free(ctx, wis), bsti_free(ctx, room);
    if (rc < 0) {
        bst_mat_free(x);
        return rc;
    }
    *out = x;
    return BST_OK;
}

/* The operands' shapes and the threshold, at the public entry. */
static int check_operands(bst_ctx *ctx, int right, const bst_mat *a, size_t nb,
                          const bst_mat *const *b, double rcond_warn)
{
    if (!a)
        return bsti_error(ctx, BST_EINVAL, "solve: NULL matrix");
    for (size_t q = 0; q < nb; q++)
        if (!b[q])
            return bsti_error(ctx, BST_EINVAL, "solve: NULL matrix");
    if (a->rows != a->cols)
        return bsti_error(ctx, BST_ESIZE, "solve: A is %zu x %zu, not square", a->rows, a->cols);
    for (size_t q = 0; q < nb; q++)
        if ((right ? b[q]->cols : b[q]->rows) != a->rows)
            return bsti_error(ctx, BST_ESIZE, "solve: A is %zu x %zu, B is %zu x %zu", a->rows,
                              a->cols, b[q]->rows, b[q]->cols);
    if (!(rcond_warn >= 0.0))
        return bsti_error(ctx, BST_EINVAL, "solve: warning threshold %g is not >= 0", rcond_warn);
    return BST_OK;
}

/* One right-hand side b (bq: the same, owned and consumable, or NULL) through the factorization f
 * into *out; last: f is not needed after this one (freed here as soon as it is dead). */
static int solve_one(bst_ctx *ctx, struct factor *f, int right, const bst_mat *b, bst_mat *bq,
                     int last, bst_mat **out)
{
    int rc;
    int in_place = bq && f->s == BST_DENSE && bq->s == BST_DENSE && bq->prec == f->prec &&
                   (!right || bq->rows == bq->cols);
    if (in_place) {
        *out = bq;
        if (right)
            bsti_mat_transpose_in_place(bq);
        rc = dense_solve_in_place(f, right, bq);
        if (right && last)
            factor_free(f);
        if (right)
            bsti_mat_transpose_in_place(bq);
        return rc;
    }
    if (!right) {
        rc = factor_solve(f, 0, b, out);
        bst_mat_free(bq);
        return rc;
    }
    /* Y^T = (I - A)^-T B^T; each workspace freed as soon as it is dead, B^T solved in place when
     * it is dense in the factor's precision */
    bst_mat *bt = NULL, *xt = NULL;
    rc = bq ? bsti_mat_transpose_take(ctx, bq, &bt) : bst_mat_transpose(ctx, b, &bt);
    if (rc >= 0 && f->s == BST_DENSE && bt->s == BST_DENSE && bt->prec == f->prec) {
        rc = dense_solve_in_place(f, 1, bt);
        xt = bt;
        bt = NULL;
    } else if (rc >= 0) {
        rc = factor_solve(f, 1, bt, &xt);
    }
    bst_mat_free(bt);
    if (last)
        factor_free(f);
    if (rc >= 0)
        return bsti_mat_transpose_take(ctx, xt, out);
    bst_mat_free(xt);
    return rc;
}

/* Sparse right-hand sides of a dense factorization: the inverse formed from the LU factors in their
 * own storage (getri, 4/3 N^3 flops) and multiplied by each B (a dense-sparse product, 2 nnz N
 * flops, mat_mul.c) costs less than getrs on B made dense (2 N^2 flops a column) when B's values
 * are few: the second step of a mirror blind between panes at k = 7 has two right-hand sides of
 * 3 and 10.5 million values, 17.6 TFLOP by getrs and 5.9 + 0.44 by the inverse.  A product's flop
 * takes INV_SPMM_COST times a getrs flop's time (measured at N = 4096 in single precision, B of 5 %
 * random values, two threads: getrs 183 GFLOP/s, getri 140-148, the product 26-34).  Not with a
 * kept factorization (its later solves need the LU factors). */
#define INV_SPMM_COST 6.0

static int inverse_pays(const struct factor *f, size_t nb, const bst_mat *const *b)
{
    if (f->s != BST_DENSE || f->n == 0)
        return 0;
    double n = (double)f->n, getrs = 0.0, spmm = 0.0;
    for (size_t q = 0; q < nb; q++) {
        size_t thin = b[q]->rows < b[q]->cols ? b[q]->rows : b[q]->cols;
        if (b[q]->s == BST_DENSE && thin < f->n / 16) {
            /* a thin one (a PLUS_LR operand's factors: solve_plus): GEMM by the inverse costs
               about what getrs does */
            getrs += 2.0 * n * n * (double)thin;
            spmm += 2.0 * n * n * (double)thin;
            continue;
        }
        if (b[q]->s != BST_SPARSE && b[q]->s != BST_DIAG)
            return 0;
        getrs += 2.0 * n * n * (double)b[q]->cols;
        spmm += INV_SPMM_COST * 2.0 * (double)bst_mat_nnz(b[q]) * n;
    }
    if (f->mirror_g) /* two halves: the inverse a quarter, the triangular solves and the
                        products half (mirror_mul.c) */
        return 1.0 / 3.0 * n * n * n + 0.5 * spmm < 0.5 * getrs;
    return 4.0 / 3.0 * n * n * n + spmm < getrs;
}

/* The LU factors of the n x n block lu (leading dimension lda) become its inverse (getri, after
 * its workspace query). */
/* getri's own algorithm with wider blocks, for n >= GETRI_OWN_MIN: inv(U) by trtri, then
 * X L = inv(U) solved for X = A^-1 a block of GETRI_NB columns at a time from the right (each
 * block's GEMM with all the columns right of it, then a triangular solve with L's diagonal block),
 * and the columns interchanged back.  LAPACK's getri takes blocks of 64 (ILAENV), whose thin GEMMs
 * ran at 123 GFLOP/s on a k = 7 half (n = 8192 at leading dimension 16384, single precision, this
 * machine's two cores), against 183-190 here with blocks of 512 to 1024 (bench/README.md).
 * work: n x GETRI_NB values. */
#define GETRI_OWN_MIN 2048
#define GETRI_NB 512
#define GETRI_KERNEL(T, P)                                                                        \
    static lapack_int getri_own_##P(size_t n, size_t lda, T *a, const lapack_int *ipiv, T *work) \
    {                                                                                              \
        lapack_int info = LAPACKE_##P##trtri(LAPACK_COL_MAJOR, 'U', 'N', (lapack_int)n, a,         \
                                             (lapack_int)lda);                                     \
        if (info != 0)                                                                             \
            return info;                                                                           \
        for (size_t j = (n - 1) / GETRI_NB * GETRI_NB;; j -= GETRI_NB) {                           \
            size_t jb = n - j < GETRI_NB ? n - j : GETRI_NB;                                       \
            for (size_t c = j; c < j + jb; c++) /* L's block column, zeroed in a */                \
                for (size_t i = c + 1; i < n; i++) {                                               \
                    work[(c - j) * n + i] = a[c * lda + i];                                        \
                    a[c * lda + i] = 0;                                                            \
                }                                                                                  \
            if (j + jb < n)                                                                        \
                cblas_##P##gemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)n, (int)jb,        \
                                (int)(n - j - jb), -1, a + (j + jb) * lda, (int)lda,               \
                                work + j + jb, (int)n, 1, a + j * lda, (int)lda);                  \
            cblas_##P##trsm(CblasColMajor, CblasRight, CblasLower, CblasNoTrans, CblasUnit,        \
                            (int)n, (int)jb, 1, work + j, (int)n, a + j * lda, (int)lda);          \
            if (j == 0)                                                                            \
                break;                                                                             \
        }                                                                                          \
        for (size_t j = n - 1; j-- > 0;) {                                                         \
            size_t jp = (size_t)ipiv[j] - 1;                                                       \
            if (jp != j)                                                                           \
                cblas_##P##swap((int)n, a + j * lda, 1, a + jp * lda, 1);                          \
        }                                                                                          \
        return 0;                                                                                  \
    }
GETRI_KERNEL(double, d)
GETRI_KERNEL(float, s)

static int getri_block(bst_ctx *ctx, bst_precision prec, size_t n, size_t lda, void *lu,
                       lapack_int *ipiv)
{
    lapack_int N = (lapack_int)n, LDA = (lapack_int)lda, lw = 0, info = 0;
    int dbl = prec == BST_DOUBLE, own = n >= GETRI_OWN_MIN;
    double qd = 0.0;
    float qf = 0.0f;
    if (own)
        lw = (lapack_int)(n * GETRI_NB);
    else
        info = dbl ? LAPACKE_dgetri_work(LAPACK_COL_MAJOR, N, lu, LDA, ipiv, &qd, -1)
                   : LAPACKE_sgetri_work(LAPACK_COL_MAJOR, N, lu, LDA, ipiv, &qf, -1);
    if (info == 0 && !own)
        lw = dbl ? (lapack_int)qd : (lapack_int)qf;
    void *w = info == 0 ? bsti_alloc_array(ctx, lw > 0 ? (size_t)lw : 1, dbl ? sizeof(double)
                                                                             : sizeof(float))
                        : NULL;
    if (info == 0 && !w)
        return BST_ENOMEM;
    if (info == 0) {
        double dn = (double)n;
        bsti_flops_add(ctx, 4.0 / 3.0 * dn * dn * dn - dn * dn + 5.0 / 3.0 * dn); /* LAWN 41 */
        int saved = bsti_blas_serial_begin(n);
        if (own)
            info = dbl ? getri_own_d(n, lda, lu, ipiv, w) : getri_own_s(n, lda, lu, ipiv, w);
        else
            info = dbl ? LAPACKE_dgetri_work(LAPACK_COL_MAJOR, N, lu, LDA, ipiv, w, lw)
                       : LAPACKE_sgetri_work(LAPACK_COL_MAJOR, N, lu, LDA, ipiv, w, lw);
        bsti_blas_serial_end(saved);
    }
    bsti_free(ctx, w);
    if (info != 0)
        return bsti_error(ctx, info > 0 ? BST_ESINGULAR : BST_EINTERNAL, "LAPACK getri: %s %d",
                          info > 0 ? "singular at" : "argument", (int)(info > 0 ? info : -info));
    return BST_OK;
}

/* The LU factors become the inverse (I - A)^-1 in their storage; a mirror-split factorization's
 * halves are inverted and stay split (join_inverse makes them the whole). */
static int dense_invert(bst_ctx *ctx, struct factor *f)
{
    size_t n = f->n, h = n / 2;
    if (!f->mirror_g)
        return getri_block(ctx, f->prec, n, n, f->lu, f->ipiv);
    int rc = getri_block(ctx, f->prec, h, n, f->lu, f->ipiv);
    if (rc >= 0)
        rc = getri_block(ctx, f->prec, h, n, block(f, 1), f->ipiv + h);
    return rc;
}

static void join_inverse(struct factor *f)
{
    if (!f->mirror_g)
        return;
    bsti_mirror_matrix(f->lu, f->prec, f->n, f->mirror_g, 0);
    if (f->mirror_turned)
        bsti_mirror_turn(f->lu, f->prec, f->n, f->mirror_g, f->n, 1);
    f->mirror_g = 0, f->mirror_turned = 0;
}

/* The storage of a dense factorization's LU factors (or inverse) handed out as an n x n dense
 * matrix (its values as they are), the factorization left without it. */
static int factor_give_lu(bst_ctx *ctx, struct factor *f, bst_mat **out)
{
    int rc = BST_OK;
    if (f->lu_mat) {
        *out = f->lu_mat;
    } else if ((rc = bsti_mat_alloc(ctx, BST_DENSE, f->prec, f->n, f->n, out)) >= 0) {
        (*out)->dense = f->lu;
    } else {
        return rc;
    }
    f->lu_mat = NULL, f->lu = NULL;
    return BST_OK;
}

/* Whether a left solve's products and Z's with the first nz of them all go by the inverse's
 * halves: a split inverse, Z and b[0..nz-1] sparse or diagonal and commuting with its mirror
 * (mirror.h), the others thin dense ones (a Woodbury solve's).  Z is read first: where it lacks
 * the symmetry, the b[q] are read once, by bsti_mirror_mul. */
static int halves_serve_z(bst_ctx *ctx, const struct factor *f, int right, size_t nb, size_t nz,
                          const bst_mat *const *b, const bst_mat *z)
{
    if (!f->mirror_g || right)
        return 0;
    for (size_t q = nz; q < nb; q++) /* the others: thin, as bsti_mirror_mul takes them */
        if (b[q]->s != BST_DENSE || b[q]->rows != f->n)
            return 0;
    for (size_t q = 0; q <= nz; q++)
        if (!bsti_mirror_commutes(ctx, q ? b[q - 1] : z, f->prec, f->n, f->mirror_g,
                                  f->mirror_turned))
            return 0;
    return 1;
}

/* out[q] = (I - A)^-1 b[q] and, for q < nz, zout[q] = Z out[q] by the halves (halves_serve_z): those
 * out[q] left split while Z multiplies them, half the flops of Z times the whole (mirror_mul.c),
 * then made whole; the others (thin: a Woodbury solve's, solve_plus) as bsti_mirror_mul makes
 * them.  Z's first product goes into the inverse's storage, read for the last time by then: a
 * block whose pages were touched, where a new one costs their first touch (bench/README.md). */
static int split_products_z(bst_ctx *ctx, struct factor *f, size_t nb, size_t nz,
                            const bst_mat *const *b, bst_mat **own_b, const bst_mat *z,
                            bst_mat **out, bst_mat **zout)
{
    size_t n = f->n, g = f->mirror_g;
    int turn = f->mirror_turned, rc = BST_OK;
    bst_precision prec = f->prec;
    for (size_t q = 0; q < nb && rc >= 0; q++) {
        rc = q < nz ? bsti_mirror_mul_split(ctx, f->lu, prec, n, g, turn, 0, b[q], NULL, 0, &out[q])
                    : bsti_mirror_mul(ctx, f->lu, prec, n, g, turn, 0, b[q], &out[q]);
        if (rc == BSTI_MIRROR_ASYM) /* (halves_serve_z checked the shapes) */
            rc = bsti_error(ctx, BST_EINTERNAL, "solve: a thin right-hand side the halves refuse");
        if (own_b) {
            bst_mat_free(own_b[q]);
            own_b[q] = NULL;
        }
    }
    bst_mat *spare = NULL;
    if (rc >= 0)
        rc = factor_give_lu(ctx, f, &spare);
    for (size_t q = 0; q < nz && rc >= 0; q++) {
        rc = bsti_mirror_mul_split(ctx, out[q]->dense, prec, n, g, turn, 1, z, spare, 1,
                                   &zout[q]);
        spare = NULL; /* taken */
        ctx->mirror_z_products += rc >= 0;
        bsti_mirror_join(out[q]->dense, prec, n, g, turn);
    }
    bst_mat_free(spare);
    return rc;
}

/* out[q] = (I - A)^-1 b[q] or b[q] (I - A)^-1 by the inverse, the owned right-hand sides freed as
 * read: by its halves while each b[q] has the mirror symmetry or is thin (mirror_mul.c, half the
 * product's flops), else by the whole.  z (NULL: none): zout[q] = Z out[q] too for q < nz, where
 * the halves serve it (split_products_z), else zout left NULL for the caller's product. */
static int solve_by_inverse(bst_ctx *ctx, struct factor *f, int right, size_t nb,
                            const bst_mat *const *b, bst_mat **own_b, const bst_mat *z, size_t nz,
                            bst_mat **out, bst_mat **zout)
{
    int rc = dense_invert(ctx, f);
    if (rc >= 0 && z && halves_serve_z(ctx, f, right, nb, nz, b, z))
        return split_products_z(ctx, f, nb, nz, b, own_b, z, out, zout);
    for (size_t q = 0; q < nb && rc >= 0; q++) {
        rc = BSTI_MIRROR_ASYM;
        if (f->mirror_g)
            rc = bsti_mirror_mul(ctx, f->lu, f->prec, f->n, f->mirror_g, f->mirror_turned, right,
                                 b[q], &out[q]);
        if (rc == BSTI_MIRROR_ASYM) {
            join_inverse(f);
            bst_mat inv = {.ctx = ctx, .s = BST_DENSE, .prec = f->prec, .rows = f->n,
                           .cols = f->n, .dense = f->lu};
            rc = right ? bst_mat_mul(ctx, b[q], &inv, 0.0, &out[q])
                       : bst_mat_mul(ctx, &inv, b[q], 0.0, &out[q]);
        }
        if (own_b) {
            bst_mat_free(own_b[q]);
            own_b[q] = NULL;
        }
    }
    return rc;
}

/* The results' last check: each finite, else BST_ESINGULAR naming rcond; on an error (rc or this
 * one) every result freed.  rc or the error. */
static int results_checked(bst_ctx *ctx, int rc, size_t nb, bst_mat **out, double rcond)
{
    for (size_t q = 0; q < nb && rc >= 0; q++)
        if (!bsti_mat_finite(ctx, out[q]))
            rc = bsti_error(ctx, BST_ESINGULAR, "solve: the result is not finite (I - A is "
                            "singular to working precision, rcond %.3g)", rcond);
    for (size_t q = 0; q < nb && rc < 0; q++) {
        bst_mat_free(out[q]);
        out[q] = NULL;
    }
    return rc;
}

static int solve_checked(bst_ctx *ctx, int right, const bst_mat *a, bst_mat **own_a, size_t nb,
                         const bst_mat *const *b, bst_mat **own_b, double rcond_warn,
                         bst_precision dense_prec, bst_mat **out, double *rcond_out,
                         bsti_factor **keep, const bst_mat *z, size_t nz, bst_mat **zout)
{
    if (keep)
        *keep = NULL;
    if (!ctx)
        return BST_EINVAL;
    if (rcond_out)
        *rcond_out = 0.0;
    int rc = check_operands(ctx, right, a, nb, b, rcond_warn);
    if (rc < 0)
        return rc;
    int b_float = 0;
    for (size_t q = 0; q < nb; q++)
        b_float |= b[q]->s == BST_DENSE && b[q]->prec == BST_FLOAT;
    bst_precision prec = dense_prec == BST_FLOAT || (a->s == BST_DENSE && a->prec == BST_FLOAT) ||
                                 b_float ? BST_FLOAT : BST_DOUBLE;
    struct factor f;
    double rcond;
    bst_mat *adense = NULL;
    rc = factor_new(ctx, a, prec, right, &f, &rcond, own_a);
    if (rc == BSTI_USE_DENSE) {
        factor_free(&f);
        rc = factor_split_sparse(ctx, a, prec, &f, &rcond);
    }
    if (rc == BSTI_USE_DENSE) { /* workspace: a dense copy of A in the factor's precision, which
                                   becomes I - A and its factors */
        factor_free(&f);
        rc = bst_mat_convert(ctx, a, BST_DENSE, prec, &adense);
        if (rc >= 0)
            rc = factor_new(ctx, adense, prec, right, &f, &rcond, &adense);
        bst_mat_free(adense);
    }
    int f_dense = f.s == BST_DENSE;
    if (*own_a) {
        bst_mat_free(*own_a);
        *own_a = NULL;
    }
    a = NULL;
    if (rcond_out)
        *rcond_out = rcond;
    if (rc >= 0 && !keep && inverse_pays(&f, nb, b))
        rc = solve_by_inverse(ctx, &f, right, nb, b, own_b, z, nz, out, zout);
    else
        for (size_t q = 0; q < nb && rc >= 0; q++) {
            bst_mat *bq = own_b ? own_b[q] : NULL;
            if (own_b)
                own_b[q] = NULL;
            rc = solve_one(ctx, &f, right, b[q], bq, q + 1 == nb && !keep, &out[q]);
        }
    if (rc >= 0 && keep && f.s != BST_ZERO && (*keep = bsti_alloc_array(ctx, 1, sizeof **keep)))
        **keep = f; /* handed to the caller (bsti_factor_free) */
    else
        factor_free(&f);
    rcond = fmin(rcond, 1.0); /* rounding in the estimate may exceed the bound 1 */
    if (rcond_out)
        *rcond_out = rcond;
    if ((rc = results_checked(ctx, rc, nb, out, rcond)) < 0) {
        for (size_t q = 0; zout && q < nz; q++) {
            bst_mat_free(zout[q]);
            zout[q] = NULL;
        }
        return rc;
    }
    /* Single precision keeps about 7 digits: warn from sqrt(eps_float) on, whatever was asked. */
    if (prec == BST_FLOAT && f_dense)
        rcond_warn = fmax(rcond_warn, BSTI_RCOND_WARN_FLOAT);
    if (rcond < rcond_warn)
        return bsti_error(ctx, BST_WILLCOND, "solve: I - A is ill-conditioned (rcond %.3g < %.3g)",
                          rcond, rcond_warn);
    return BST_OK;
}

/* *out = Z X for Z = Z0 + Uz Wz^T (mz = 0: Z0) and X = X0 + U W^T (n x m thin factors), given
 * zx0 = Z0 X0 (taken): zx0 + [Z0 U | Uz] [W | X0^T Wz + W (U^T Wz)]^T, settled (mat.h). */
static int z_times_plus(bst_ctx *ctx, const bst_mat *z0, size_t mz, const double *uz,
                        const double *wz, const bst_mat *x0, size_t m, const double *u,
                        const double *w, bst_mat *zx0, bst_mat **out)
{
    size_t n = x0->rows, mm = m + mz;
    double *nu = bsti_alloc_array(ctx, n * mm + 1, sizeof *nu);
    double *nw = bsti_alloc_array(ctx, n * mm + 1, sizeof *nw);
    double *core = bsti_alloc_array(ctx, m * mz + 1, sizeof *core);
    int rc = nu && nw && core ? BST_OK : BST_ENOMEM;
    if (rc >= 0 && m) {
        rc = bsti_mul_thin(ctx, z0, u, m, nu); /* Z0 U */
        memcpy(nw, w, n * m * sizeof *nw);
    }
    if (rc >= 0 && mz) {
        memcpy(nu + n * m, uz, n * mz * sizeof *nu);
        rc = bsti_mul_thin_t(ctx, x0, wz, mz, nw + n * m); /* X0^T Wz */
        if (rc >= 0 && m) { /* + W (U^T Wz) */
            cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)m, (int)mz, (int)n, 1.0, u,
                        (int)n, wz, (int)n, 0.0, core, (int)m);
            cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)n, (int)mz, (int)m, 1.0, w,
                        (int)n, core, (int)m, 1.0, nw + n * m, (int)n);
        }
    }
    bsti_free(ctx, core);
    *out = NULL;
    return bsti_plus_settled(ctx, rc, zx0, mm, nu, nw, out);
}

/* PLUS_LR operands (mat.h), A = A0 + Ua Wa^T and B = B0 + Ub Wb^T (a plain one with m = 0), by
 * the Woodbury identity with E = I - A0 factored once (solve_checked) for the bases and the thin
 * parts together, C = I - Wa^T E^-1 Ua (ma x ma) the capacitance:
 *   left:  X = X0 + [Zb | Z] [Wb | H^T]^T,  X0 = E^-1 B0, Zb = E^-1 Ub, Z = E^-1 Ua,
 *          H = C^-1 (Wa^T X0 + (Wa^T Zb) Wb^T);
 *   right: Y = Y0 + [Ub | Y0 Ua + Ub (Rb Ua)] [Rb^T | (C^-1 Rw)^T]^T,  Y0 = B0 E^-1,
 *          Rb = Wb^T E^-1, Rw = Wa^T E^-1 (and C = I - Rw Ua).
 * The thin right-hand sides ride with the bases' (columns [Ua | Ub..] of a left solve, rows
 * [Wa^T; Wb^T..] of a right one).  *own_a and own_b[q] (NULL, or the matrix itself) are taken: a
 * taken PLUS_LR's base is given to the bases' solve (a dense one becomes its own factors).
 * *rcond: the lesser of E's estimate and C's (LAPACK gecon).
 * z (left, NULL: none; Z = Z0 + Uz Wz^T or a plain Z0, sparse or diagonal): zout[q] = Z X where
 * the bases' solve makes Z0 X0 by the halves (split_products_z), with
 *   Z X = Z0 X0 + [Z0 U' | Uz] [W' | X0^T Wz + W' (U'^T Wz)]^T  for X = X0 + U' W'^T,
 * else zout[q] is left NULL for the caller's product. */
static int solve_plus(bst_ctx *ctx, int right, const bst_mat *a, bst_mat **own_a, size_t nb,
                      const bst_mat *const *b, bst_mat **own_b, double rcond_warn,
                      bst_precision dense_prec, bst_mat **out, double *rcond_out,
                      const bst_mat *z, bst_mat **zout)
{
    enum { NB_MAX = 2 };
    const bst_mat *a0, *b0[NB_MAX + 1];
    const double *ua, *wa, *ub[NB_MAX], *wb[NB_MAX];
    size_t n = a->rows, ma, mb[NB_MAX], off[NB_MAX], mt;
    if (nb > NB_MAX)
        return bsti_error(ctx, BST_EINTERNAL, "solve: %zu right-hand sides", nb);
    bsti_plus_parts(a, &a0, &ma, &ua, &wa);
    mt = ma;
    const bst_mat *z0 = NULL;
    const double *uz = NULL, *wz = NULL;
    size_t mz = 0;
    bst_mat *zx0[NB_MAX] = {NULL, NULL};
    if (z && zout && !right)
        bsti_plus_parts(z, &z0, &mz, &uz, &wz);
    if (z0 && z0->s != BST_SPARSE && z0->s != BST_DIAG)
        z0 = NULL;
    bst_mat *own0 = NULL, *own_b0[NB_MAX + 1] = {NULL, NULL, NULL}, *x[NB_MAX + 1] = {NULL, NULL, NULL};
    /* taken operands pass on to the bases' solve: a PLUS_LR one's base (its factors are read
       below, the shell freed by the caller), a plain one itself */
    if (*own_a == a && a->s == BST_PLUS_LR)
        own0 = a->plus->base, a->plus->base = NULL;
    else if (*own_a == a)
        own0 = *own_a, *own_a = NULL;
    for (size_t q = 0; q < nb; q++) {
        bsti_plus_parts(b[q], &b0[q], &mb[q], &ub[q], &wb[q]);
        off[q] = mt, mt += mb[q];
        if (own_b && own_b[q] == b[q] && b[q]->s == BST_PLUS_LR)
            own_b0[q] = b[q]->plus->base, b[q]->plus->base = NULL;
        else if (own_b && own_b[q] == b[q])
            own_b0[q] = own_b[q], own_b[q] = NULL;
    }
    bst_mat *thin = NULL, *none = NULL;
    double *t = NULL, *c = bsti_alloc_array(ctx, ma * ma + 1, sizeof *c);
    lapack_int *piv = bsti_alloc_array(ctx, ma + 1, sizeof *piv);
    int rc = c && piv ? BST_OK : BST_ENOMEM, warn = 0;
    if (rc >= 0 && mt && (rc = bst_mat_new_dense(ctx, right ? mt : n, right ? n : mt, BST_DOUBLE,
                                                  &thin)) >= 0) {
        double *v = thin->dense;
        for (size_t q = 0; q <= nb; q++) { /* q = nb: A's own */
            size_t m = q < nb ? mb[q] : ma, o = q < nb ? off[q] : 0;
            const double *f = q < nb ? (right ? wb[q] : ub[q]) : (right ? wa : ua);
            for (size_t k = 0; k < m; k++)
                for (size_t i = 0; i < n; i++) {
                    if (right)
                        v[i * mt + o + k] = f[k * n + i];
                    else
                        v[(o + k) * n + i] = f[k * n + i];
                }
        }
        b0[nb] = thin, own_b0[nb] = thin;
    }
    double rcond = 1.0, rc_c = 1.0;
    if (rc >= 0) { /* the bases and the thin parts, one factorization of E */
        rc = solve_checked(ctx, right, a0, own0 ? &own0 : &none, nb + (mt > 0), b0,
                           own_b0, rcond_warn, dense_prec, x, &rcond, NULL, z0, nb,
                           z0 ? zx0 : NULL);
        thin = NULL; /* taken */
        if (rc > 0)
            warn = rc, rc = BST_OK;
    }
    bst_mat_free(own0);
    for (size_t q = 0; q <= nb; q++)
        bst_mat_free(own_b0[q]);
    if (rc >= 0 && mt) { /* the thin solutions as doubles: n x mt (left), mt x n (right) */
        if (!(t = bsti_alloc_array(ctx, n * mt, sizeof *t)))
            rc = BST_ENOMEM;
        else
            rc = bst_mat_to_dense_array(ctx, x[nb], t);
    }
    if (rc >= 0 && ma) { /* C = I - Wa^T E^-1 Ua, its LU and condition */
        if (right)
            cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)ma, (int)ma, (int)n, -1.0,
                        t, (int)mt, ua, (int)n, 0.0, c, (int)ma);
        else
            cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)ma, (int)ma, (int)n, -1.0, wa,
                        (int)n, t, (int)n, 0.0, c, (int)ma);
        for (size_t k = 0; k < ma; k++)
            c[k * ma + k] += 1.0;
        double cn = LAPACKE_dlange(LAPACK_COL_MAJOR, '1', (lapack_int)ma, (lapack_int)ma, c, (lapack_int)ma);
        lapack_int info = LAPACKE_dgetrf(LAPACK_COL_MAJOR, (lapack_int)ma, (lapack_int)ma, c,
                                         (lapack_int)ma, piv);
        if (info == 0)
            info = LAPACKE_dgecon(LAPACK_COL_MAJOR, '1', (lapack_int)ma, c, (lapack_int)ma, cn, &rc_c);
        if (info > 0 || !(rc_c > 0.0))
            rc = bsti_error(ctx, BST_ESINGULAR, "solve: I - A is singular (its low-rank part's "
                            "capacitance)");
        else if (info < 0)
            rc = bsti_error(ctx, BST_EINTERNAL, "solve: LAPACK getrf/gecon %d", (int)info);
    }
    for (size_t q = 0; q < nb && rc >= 0; q++) {
        size_t m = mb[q] + ma;
        double *u = bsti_alloc_array(ctx, n * m + 1, sizeof *u), *w = bsti_alloc_array(ctx, n * m + 1, sizeof *w);
        double *g = bsti_alloc_array(ctx, 2 * n * ma + ma * mb[q] + 1, sizeof *g), *gt = g + n * ma,
               *core = gt + n * ma;
        rc = u && w && g ? BST_OK : BST_ENOMEM;
        const double *tb = t ? (right ? t + off[q] : t + off[q] * n) : NULL;
        if (rc >= 0 && !right) {
            /* U' = [Zb | Z], W' = [Wb | H^T], H^T = (X0^T Wa + Wb (Zb^T Wa)) C^-T */
            if (mb[q]) { /* (a plain B: none) */
                memcpy(u, tb, n * mb[q] * sizeof *u);
                memcpy(w, wb[q], n * mb[q] * sizeof *w);
            }
            if (ma) {
                memcpy(u + n * mb[q], t, n * ma * sizeof *u);
                rc = bsti_mul_thin_t(ctx, x[q], wa, ma, gt); /* G^T = X0^T Wa (n x ma) */
                for (size_t k = 0; rc >= 0 && k < ma; k++)
                    for (size_t i = 0; i < n; i++)
                        g[i * ma + k] = gt[k * n + i];
                if (rc >= 0 && mb[q]) { /* G += (Wa^T Zb) Wb^T */
                    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, (int)ma, (int)mb[q], (int)n,
                                1.0, wa, (int)n, tb, (int)n, 0.0, core, (int)ma);
                    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, (int)ma, (int)n, (int)mb[q],
                                1.0, core, (int)ma, wb[q], (int)n, 1.0, g, (int)ma);
                }
                if (rc >= 0 && LAPACKE_dgetrs(LAPACK_COL_MAJOR, 'N', (lapack_int)ma, (lapack_int)n,
                                              c, (lapack_int)ma, piv, g, (lapack_int)ma) != 0)
                    rc = bsti_error(ctx, BST_EINTERNAL, "solve: LAPACK getrs");
                for (size_t k = 0; rc >= 0 && k < ma; k++) /* W'[:, mb + k] = H[k, :]^T */
                    for (size_t i = 0; i < n; i++)
                        w[(mb[q] + k) * n + i] = g[i * ma + k];
            }
        } else if (rc >= 0) {
            /* U' = [Ub | Y0 Ua + Ub (Rb Ua)], W' = [Rb^T | (C^-1 Rw)^T] */
            if (mb[q])
                memcpy(u, ub[q], n * mb[q] * sizeof *u);
            for (size_t k = 0; k < mb[q]; k++)
                for (size_t i = 0; i < n; i++)
                    w[k * n + i] = tb[i * mt + k];
            if (ma) {
                rc = bsti_mul_thin(ctx, x[q], ua, ma, u + n * mb[q]); /* Y0 Ua (n x ma) */
                if (rc >= 0 && mb[q]) {
                    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)mb[q], (int)ma, (int)n,
                                1.0, tb, (int)mt, ua, (int)n, 0.0, core, (int)mb[q]);
                    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)n, (int)ma, (int)mb[q],
                                1.0, ub[q], (int)n, core, (int)mb[q], 1.0, u + n * mb[q], (int)n);
                }
                for (size_t k = 0; rc >= 0 && k < ma; k++) /* Rw's rows */
                    for (size_t i = 0; i < n; i++)
                        g[i * ma + k] = t[i * mt + k];
                if (rc >= 0 && LAPACKE_dgetrs(LAPACK_COL_MAJOR, 'N', (lapack_int)ma, (lapack_int)n,
                                              c, (lapack_int)ma, piv, g, (lapack_int)ma) != 0)
                    rc = bsti_error(ctx, BST_EINTERNAL, "solve: LAPACK getrs");
                for (size_t k = 0; rc >= 0 && k < ma; k++)
                    for (size_t i = 0; i < n; i++)
                        w[(mb[q] + k) * n + i] = g[i * ma + k];
            }
        }
        bsti_free(ctx, g);
        if (rc >= 0 && zx0[q]) { /* Z X, while X0 is at hand */
            rc = z_times_plus(ctx, z0, mz, uz, wz, x[q], m, u, w, zx0[q], &zout[q]);
            zx0[q] = NULL; /* taken */
        }
        bst_mat *r = x[q];
        x[q] = NULL;
        if (rc < 0) /* (bsti_mat_plus_new takes r, u and w, also on failure) */
            bst_mat_free(r), bsti_free(ctx, u), bsti_free(ctx, w);
        else if ((rc = bsti_mat_plus_new(ctx, r, m, u, w, &out[q])) >= 0)
            rc = bsti_plus_settle(ctx, &out[q]);
    }
    for (size_t q = 0; q <= nb; q++)
        bst_mat_free(x[q]);
    for (size_t q = 0; q < nb; q++)
        bst_mat_free(zx0[q]);
    bsti_free(ctx, t), bsti_free(ctx, c), bsti_free(ctx, piv);
    rcond = fmin(rcond, rc_c);
    if (rcond_out)
        *rcond_out = rcond;
    if ((rc = results_checked(ctx, rc, nb, out, rcond)) < 0) {
        for (size_t q = 0; zout && q < nb; q++) {
            bst_mat_free(zout[q]);
            zout[q] = NULL;
        }
        return rc;
    }
    if (rc_c < rcond_warn)
        return bsti_error(ctx, BST_WILLCOND, "solve: I - A is ill-conditioned (rcond %.3g < %.3g, "
                          "its low-rank part)", rc_c, rcond_warn);
    return warn;
}

/* The solve with nb right-hand sides b[0..nb-1] (one factorization for all: out[q] = (I - A)^-1
 * b[q], or b[q] (I - A)^-1); *own_a (NULL or a itself) is taken: a dense A becomes its own
 * factorization (factor_new), any other is freed as soon as I - A is factored, so that A, its
 * factorization and the results are never all held at once.  own_b (NULL, or per right-hand side
 * NULL or b[q] itself) are taken likewise: a dense b[q] in the factor's precision is solved in its
 * own storage and becomes out[q] (square, through its transpose, for a right solve), any other is
 * freed once it has been read.  Every matrix taken is gone, or is a result, on return, whatever
 * the status. */
static int solve_owning(bst_ctx *ctx, int right, const bst_mat *a, bst_mat **own_a, size_t nb,
                        const bst_mat *const *b, bst_mat **own_b, double rcond_warn,
                        bst_precision dense_prec, bst_mat **out, double *rcond_out,
                        bsti_factor **keep, const bst_mat *z, bst_mat **zout)
{
    for (size_t q = 0; q < nb; q++)
        out[q] = NULL;
    for (size_t q = 0; zout && q < nb; q++)
        zout[q] = NULL;
    int plus = a && a->s == BST_PLUS_LR, rc;
    for (size_t q = 0; q < nb; q++)
        plus |= b[q] && b[q]->s == BST_PLUS_LR;
    if (keep)
        *keep = NULL;
    if (plus && (rc = check_operands(ctx, right, a, nb, b, rcond_warn)) >= 0) /* not kept */
        rc = solve_plus(ctx, right, a, own_a, nb, b, own_b, rcond_warn, dense_prec, out, rcond_out,
                        z, zout);
    else if (!plus)
        rc = solve_checked(ctx, right, a, own_a, nb, b, own_b, rcond_warn, dense_prec, out,
                           rcond_out, keep, z, nb, zout);
    bst_mat_free(*own_a); /* when an error came before the factorization */
    *own_a = NULL;
    for (size_t q = 0; own_b && q < nb; q++) { /* when an error came before it was read */
        bst_mat_free(own_b[q]);
        own_b[q] = NULL;
    }
    return rc;
}

int bst_solve_left(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double rcond_warn,
                   bst_mat **x, double *rcond)
{
    bst_mat *none = NULL;
    if (!ctx)
        return BST_EINVAL;
    if (!x)
        return bsti_error(ctx, BST_EINVAL, "solve: NULL result pointer");
    return solve_owning(ctx, 0, a, &none, 1, &b, NULL, rcond_warn, BST_DOUBLE, x, rcond, NULL,
                        NULL, NULL);
}

int bst_solve_right(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double rcond_warn,
                    bst_mat **y, double *rcond)
{
    bst_mat *none = NULL;
    if (!ctx)
        return BST_EINVAL;
    if (!y)
        return bsti_error(ctx, BST_EINVAL, "solve: NULL result pointer");
    return solve_owning(ctx, 1, a, &none, 1, &b, NULL, rcond_warn, BST_DOUBLE, y, rcond, NULL,
                        NULL, NULL);
}

int bsti_solve_take(bst_ctx *ctx, int right, bst_mat *a, const bst_mat *b, bst_mat *b_own,
                    double rcond_warn, bst_precision prec, bst_mat **out, double *rcond,
                    bsti_factor **keep)
{
    bst_mat *own = a, *own_b[1] = {b_own};
    if (keep)
        *keep = NULL;
    if (!ctx || !out) {
        bst_mat_free(a);
        bst_mat_free(b_own);
        return ctx ? bsti_error(ctx, BST_EINVAL, "solve: NULL result pointer") : BST_EINVAL;
    }
    return solve_owning(ctx, right, a, &own, 1, &b, own_b, rcond_warn, prec, out, rcond, keep,
                        NULL, NULL);
}

int bsti_solve_take_left2(bst_ctx *ctx, bst_mat *a, const bst_mat *b1, bst_mat *b1_own,
                          const bst_mat *b2, bst_mat *b2_own, double rcond_warn,
                          bst_precision prec, bst_mat **x1, bst_mat **x2, double *rcond,
                          bsti_factor **keep)
{
    return bsti_solve_take_left2_z(ctx, a, b1, b1_own, b2, b2_own, NULL, rcond_warn, prec, x1, x2,
                                   NULL, NULL, rcond, keep);
}

int bsti_solve_take_left2_z(bst_ctx *ctx, bst_mat *a, const bst_mat *b1, bst_mat *b1_own,
                            const bst_mat *b2, bst_mat *b2_own, const bst_mat *z,
                            double rcond_warn, bst_precision prec, bst_mat **x1, bst_mat **x2,
                            bst_mat **zx1, bst_mat **zx2, double *rcond, bsti_factor **keep)
{
    bst_mat *own = a, *x[2] = {NULL, NULL}, *own_b[2] = {b1_own, b2_own}, *zx[2] = {NULL, NULL};
    const bst_mat *b[2] = {b1, b2};
    if (keep)
        *keep = NULL;
    if (!ctx || !x1 || !x2 || (z && (!zx1 || !zx2))) {
        bst_mat_free(a);
        bst_mat_free(b1_own);
        bst_mat_free(b2_own);
        return ctx ? bsti_error(ctx, BST_EINVAL, "solve: NULL result pointer") : BST_EINVAL;
    }
    int rc = solve_owning(ctx, 0, a, &own, 2, b, own_b, rcond_warn, prec, x, rcond, keep, z,
                          z ? zx : NULL);
    *x1 = x[0];
    *x2 = x[1];
    if (z)
        *zx1 = zx[0], *zx2 = zx[1];
    return rc;
}

int bsti_factor_solve_right(bst_ctx *ctx, bsti_factor *f, const bst_mat *b, bst_mat **y)
{
    bst_mat *bt = NULL, *xt = NULL;
    *y = NULL;
    if (b->cols != f->n)
        return bsti_error(ctx, BST_ESIZE, "solve: factor of %zu, B is %zu x %zu", f->n, b->rows,
                          b->cols);
    int rc = bst_mat_transpose(ctx, b, &bt);
    if (rc >= 0)
        rc = factor_solve(f, 1, bt, &xt);
    if (rc >= 0)
        rc = bst_mat_transpose(ctx, xt, y);
    bst_mat_free(bt), bst_mat_free(xt);
    return rc;
}

void bsti_factor_free(bsti_factor *f)
{
    if (!f)
        return;
    bst_ctx *ctx = f->ctx;
    factor_free(f);
    bsti_free(ctx, f);
}
