/* mat_lowrank.c - the FACTORED structure's kernels of the product and sum tables (mat_mul.c,
 * mat_add.c): the algebra of lowrank.c on bst_mat, and the products with a dense operand that
 * never form the factored one's N x N values.
 *
 *   F G (both FACTORED over one map)  bsti_lr_mul, then settled (a rank past half of N: dense)
 *   F B, B dense                       D B + U (K (V^T B)): O(nnz(S) m (p + q) + p q r^2 m)
 *   A F, A dense                       A D + ((A U) K) V^T: the same cost on A's rows
 *   F B, A F with a sparse operand     one that is P K P^T over F's prolongation (a sparse tree
 *                                      of depth below k) factored with that K, then bsti_lr_mul;
 *                                      any other made dense, then as above
 *   alpha F + beta G, G ZERO, DIAG, such a SPARSE or FACTORED over F's map: bsti_lr_add (the
 *                                      diagonal taken as a factored matrix of no rank)
 * Anything else (factored operands over two maps) goes the generic dense way.  A float dense
 * operand makes a float result, as everywhere in mat.c; the factors are double. */
#include <config.h>

#include <math.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cblas.h>

#include "ctx.h"
#include "mat.h"

/* The result as a matrix, FACTORED unless its rank makes dense cheaper. */
static int settled(bst_ctx *ctx, int rc, bsti_lr *lr, bst_mat **out)
{
    if (rc < 0)
        return rc;
    if ((rc = bsti_mat_from_lr(ctx, lr, out)) < 0)
        return rc;
    if ((rc = bsti_mat_lr_settle(ctx, out)) < 0) {
        bst_mat_free(*out);
        *out = NULL;
    }
    return rc;
}

int bsti_mul_lowrank(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop, bst_mat **out)
{
    (void)drop;
    if (!bsti_lr_same_map(a->lr, b->lr))
        return bsti_mat_mul_generic(ctx, a, b, out);
    bsti_lr *lr;
    int rc = bsti_lr_mul(ctx, a->lr, b->lr, &lr);
    return settled(ctx, rc, lr, out);
}

/* A dense operand in double: itself, or a double copy (*copy, to be freed). */
static int as_double(bst_ctx *ctx, const bst_mat *m, const bst_mat **d, bst_mat **copy)
{
    *copy = NULL;
    *d = m;
    if (m->prec == BST_DOUBLE)
        return BST_OK;
    int rc = bsti_mat_to_dense(ctx, m, BST_DOUBLE, copy);
    *d = *copy;
    return rc;
}

/* The double result c given the precision prec of the dense operand (float: converted). */
static int in_precision(bst_ctx *ctx, bst_mat *c, bst_precision prec, bst_mat **out)
{
    if (prec == BST_DOUBLE) {
        *out = c;
        return BST_OK;
    }
    int rc = bsti_mat_to_dense(ctx, c, BST_FLOAT, out);
    bst_mat_free(c);
    return rc;
}

/* C = F B, F FACTORED (N x N), B dense (N x m). */
int bsti_mul_lowrank_dense(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop,
                           bst_mat **out)
{
    (void)drop;
    const bsti_lr *f = a->lr;
    const bsti_lr_map *S = f->S;
    size_t N = f->N, m = b->cols, r = f->r, pr = f->p * r, qr = f->q * r;
    const bst_mat *bd;
    bst_mat *bcopy, *c = NULL;
    int rc = as_double(ctx, b, &bd, &bcopy);
    double *w = rc >= 0 ? bsti_calloc(ctx, (qr + pr) * m + 1, sizeof *w) : NULL;
    if (rc >= 0 && !w)
        rc = BST_ENOMEM;
    if (rc >= 0)
        rc = bst_mat_new_dense(ctx, N, m, BST_DOUBLE, &c);
    if (rc >= 0) {
        const double *B = bd->dense;
        double *C = c->dense, *vb = w, *t = w + qr * m;
        for (size_t col = 0; col < m; col++) {
            for (size_t x = 0; x < N; x++)
                C[col * N + x] = f->d ? f->d[x] * B[col * N + x] : 0.0;
            for (size_t j = 0; j < f->q; j++) /* V^T B: S^T (b_j .* B) */
                for (size_t x = 0; x < N; x++)
                    for (size_t e = S->start[x]; e < S->start[x + 1]; e++)
                        vb[col * qr + j * r + S->col[e]] += S->w[e] * f->b[j * N + x] * B[col * N + x];
        }
        if (pr && qr && m) {
            cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)pr, (int)m, (int)qr, 1.0,
                        f->k, (int)pr, vb, (int)qr, 0.0, t, (int)pr);
            bsti_flops_add(ctx, 2.0 * (double)pr * (double)qr * (double)m);
        }
        for (size_t col = 0; col < m; col++) /* C += U T */
            for (size_t i = 0; i < f->p; i++)
                for (size_t x = 0; x < N; x++)
                    for (size_t e = S->start[x]; e < S->start[x + 1]; e++)
                        C[col * N + x] += f->a[i * N + x] * S->w[e] * t[col * pr + i * r + S->col[e]];
    }
    bsti_free(ctx, w);
    if (rc >= 0)
        rc = in_precision(ctx, c, b->prec, out);
    else
        bst_mat_free(c);
    bst_mat_free(bcopy);
    return rc;
}

/* C = A F, A dense (n x N), F FACTORED: the transpose of F^T A^T. */
int bsti_mul_dense_lowrank(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop,
                           bst_mat **out)
{
    bst_mat *at = NULL, *ft = NULL, *ct = NULL;
    int rc = bst_mat_transpose(ctx, a, &at);
    if (rc >= 0)
        rc = bst_mat_transpose(ctx, b, &ft);
    if (rc >= 0)
        rc = bsti_mul_lowrank_dense(ctx, ft, at, drop, &ct);
    bst_mat_free(at), bst_mat_free(ft);
    if (rc >= 0)
        rc = bst_mat_transpose(ctx, ct, out);
    bst_mat_free(ct);
    return rc;
}

static int place_order(const void *x, const void *y)
{
    size_t a = *(const size_t *)x, b = *(const size_t *)y;
    return (a > b) - (a < b);
}

/* A SPARSE N x N m that is exactly P K P^T for the prolongation S (each pair of coarse cells holds
 * one value in all its fine pairs, or none: a sparse rank-4 tree of depth d read at k > d, a clear
 * pane's tree file say), as the factored matrix with that K; BST_ENOTFOUND, with no message, for
 * any other.  K is held by column (ks), so that its products need no pass over its r^2 values to
 * find the few that are not zero, and, unless kmode is BSTI_LR_K_NONE and K is sparse
 * (BSTI_LR_SPARSE_SHARE), as an r x r array too.  The values are gathered coarse column by coarse
 * column: a pair is whole when its fine^2 values are all there and equal.  Work: O(nnz + N + r
 * log r), and r^2 for the array. */
static int sparse_lr(bst_ctx *ctx, const bst_mat *m, const bsti_lr_map *S, int kmode, bsti_lr **lr)
{
    *lr = NULL;
    if (!S->single || S->k < 0 || m->rows != S->N || m->cols != S->N)
        return BST_ENOTFOUND;
    size_t N = S->N, r = S->r, fine = N / r, whole = fine * fine;
    const SuiteSparse_long *p = m->sp->p, *ri = m->sp->i;
    const double *x = m->sp->x;
    size_t nnz = (size_t)p[m->cols], pairs = 0;
    /* the fine columns of each coarse column (by = r + 1 starts, then N columns), each coarse
     * row's count and value in the column at hand, the rows met there */
    size_t *by = bsti_calloc(ctx, r + 1 + N + 2 * r, sizeof *by);
    double *val = bsti_alloc_array(ctx, r, sizeof *val);
    bsti_lr_csc *cs = bsti_malloc(ctx, sizeof *cs + (r + 1 + nnz / whole + 1) * sizeof(size_t) +
                                       (nnz / whole + 1) * sizeof(double));
    int rc = by && val && cs ? BST_OK : BST_ENOMEM;
    size_t *fc = by + r + 1, *count = fc + N, *met = count + r;
    if (rc >= 0) {
        cs->start = (size_t *)(cs + 1);
        cs->row = cs->start + r + 1;
        cs->val = (double *)(cs->row + nnz / whole + 1);
        for (size_t j = 0; j < N; j++)
            by[S->col[j] + 1]++;
        for (size_t c = 0; c < r; c++)
            by[c + 1] += by[c];
        for (size_t j = 0, *next = met; j < N; j++) /* met: room to place them */
            fc[by[S->col[j]] + next[S->col[j]]++] = j;
        memset(met, 0, r * sizeof *met);
    }
    for (size_t c = 0; rc >= 0 && c < r; c++) {
        size_t nmet = 0;
        cs->start[c] = pairs;
        for (size_t t = by[c]; t < by[c + 1] && rc >= 0; t++)
            for (SuiteSparse_long q = p[fc[t]]; q < p[fc[t] + 1]; q++) {
                size_t row = S->col[ri[q]];
                if (x[q] == 0.0)
                    continue;
                if (!count[row]++)
                    val[row] = x[q], met[nmet++] = row;
                else if (val[row] != x[q])
                    rc = BST_ENOTFOUND;
            }
        qsort(met, nmet, sizeof *met, place_order);
        for (size_t e = 0; e < nmet; e++) {
            if (count[met[e]] != whole || pairs >= nnz / whole)
                rc = BST_ENOTFOUND;
            else
                cs->row[pairs] = met[e], cs->val[pairs++] = val[met[e]];
            count[met[e]] = 0;
        }
    }
    bsti_lr *f = NULL;
    if (rc >= 0) {
        cs->start[r] = cs->nnz = pairs;
        if (kmode == BSTI_LR_K_NONE && (double)pairs > BSTI_LR_SPARSE_SHARE * (double)r * (double)r)
            kmode = BSTI_LR_K_ZERO;
        rc = bsti_lr_alloc(ctx, S, 1, 1, 0, kmode, &f);
    }
    if (rc >= 0) {
        for (size_t y = 0; y < N; y++)
            f->a[y] = f->b[y] = 1.0;
        for (size_t c = 0; f->k && c < r; c++)
            for (size_t e = cs->start[c]; e < cs->start[c + 1]; e++)
                f->k[c * r + cs->row[e]] = cs->val[e];
        f->ks = cs;
        cs = NULL;
        *lr = f;
    }
    bsti_free(ctx, by), bsti_free(ctx, val), bsti_free(ctx, cs);
    return rc;
}

/* F B and A F with a sparse operand: one that is P K P^T over F's prolongation (sparse_lr) joins F
 * in the family (bsti_lr_mul: the dense work of the coarse order, the result factored); any other
 * (the selected columns of a pane, say) is made dense (n m values: the columns asked, or no more
 * than the generic path would make) and multiplied as above.  The factored one is never
 * expanded. */
int bsti_mul_lowrank_sparse(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop,
                            bst_mat **out)
{
    int left = a->s == BST_FACTORED;
    bsti_lr *ls, *lr;
    int rc = sparse_lr(ctx, left ? b : a, (left ? a : b)->lr->S, BSTI_LR_K_NONE, &ls);
    if (rc >= 0) {
        rc = left ? bsti_lr_mul(ctx, a->lr, ls, &lr) : bsti_lr_mul(ctx, ls, b->lr, &lr);
        bsti_lr_free(ctx, ls);
        return settled(ctx, rc, lr, out);
    }
    if (rc != BST_ENOTFOUND)
        return rc;
    bst_mat *d = NULL;
    rc = bsti_mat_to_dense(ctx, left ? b : a, BST_DOUBLE, &d);
    if (rc >= 0)
        rc = left ? bsti_mul_lowrank_dense(ctx, a, d, drop, out)
                  : bsti_mul_dense_lowrank(ctx, d, b, drop, out);
    bst_mat_free(d);
    return rc;
}

int bsti_add_lowrank(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                     bst_mat **out)
{
    bsti_lr *lb = NULL, *lr = NULL;
    int rc = bsti_mat_lr_operand(ctx, b, a->lr->S, &lb);
    if (rc == BST_ENOTFOUND || (rc >= 0 && !bsti_lr_same_map(a->lr, lb))) {
        bsti_lr_free(ctx, lb);
        return bsti_mat_add_generic(ctx, alpha, a, beta, b, out);
    }
    if (rc >= 0)
        rc = bsti_lr_add(ctx, alpha, a->lr, beta, lb, &lr);
    bsti_lr_free(ctx, lb);
    return settled(ctx, rc, lr, out);
}

/* ------------------------------------------------------------------ the FACTORED object */

int bsti_mat_from_lr(bst_ctx *ctx, bsti_lr *lr, bst_mat **out)
{
    int rc = bsti_mat_alloc(ctx, BST_FACTORED, BST_DOUBLE, lr->N, lr->N, out);
    if (rc < 0) {
        bsti_lr_free(ctx, lr);
        return rc;
    }
    (*out)->lr = lr;
    return BST_OK;
}

static int lr_of(bst_ctx *ctx, const bst_mat *m, const bsti_lr_map *S, int kmode, bsti_lr **lr)
{
    *lr = NULL;
    if (m->s == BST_FACTORED)
        return bsti_lr_copy(ctx, m->lr, lr);
    if (m->s == BST_SPARSE)
        return sparse_lr(ctx, m, S, kmode, lr);
    if ((m->s != BST_DIAG && m->s != BST_ZERO) || m->rows != S->N || m->cols != S->N)
        return BST_ENOTFOUND;
    return bsti_lr_new(ctx, S, m->s == BST_DIAG ? m->diag : NULL, NULL, NULL, NULL, lr);
}

int bsti_mat_lr_of(bst_ctx *ctx, const bst_mat *m, const bsti_lr_map *S, bsti_lr **lr)
{
    return lr_of(ctx, m, S, BSTI_LR_K_ZERO, lr);
}

int bsti_mat_lr_operand(bst_ctx *ctx, const bst_mat *m, const bsti_lr_map *S, bsti_lr **lr)
{
    return lr_of(ctx, m, S, BSTI_LR_K_NONE, lr);
}

size_t bsti_mat_rank(const bst_mat *m)
{
    if (m && m->s == BST_PLUS_LR)
        return m->plus->m;
    if (!m || m->s != BST_FACTORED)
        return 0;
    return m->lr->r * (m->lr->p > m->lr->q ? m->lr->p : m->lr->q);
}

int bsti_mat_lr_settle(bst_ctx *ctx, bst_mat **m)
{
    if ((*m)->s != BST_FACTORED || (double)bsti_mat_rank(*m) < BSTI_LR_DENSE_SHARE * (double)(*m)->rows)
        return BST_OK;
    bst_mat *d;
    int rc = bsti_mat_to_dense(ctx, *m, BST_DOUBLE, &d);
    if (rc < 0)
        return rc;
    bst_mat_free(*m);
    *m = d;
    return BST_OK;
}

int bsti_mat_lr_values(bst_ctx *ctx, const bst_mat *m, double *out)
{
    bsti_cols *c;
    int rc = bsti_cols_new(ctx, m, m->rows, &c);
    if (rc >= 0)
        bsti_cols_get(c, NULL, 0, m->rows, out);
    bsti_cols_free(c);
    return rc;
}

int bsti_mat_lr_wide(const bst_mat *m)
{
    if (!m || m->s != BST_FACTORED)
        return 0;
    const bsti_lr_map *S = m->lr->S;
    return !S->single && !S->tag[0];
}

/* The first order-k patch of the order-kc patch J (basis.h's index x 2^k + y): its lower corner. */
static inline size_t coarse_corner(size_t cj, int k, int kc)
{
    size_t low = ((size_t)1 << kc) - 1;
    int s = k - kc;
    return ((cj >> kc) << (s + k)) + ((cj & low) << s);
}

int bsti_mat_lr_coarse(const bst_mat *m)
{
    if (!m || m->s != BST_FACTORED || !m->lr->k)
        return 0;
    const bsti_lr *f = m->lr;
    const bsti_lr_map *S = f->S;
    if (!S->single || strcmp(S->tag, "P") != 0 || S->d < 1 || S->d >= S->k || S->N != f->N)
        return 0;
    size_t N = f->N, G = (size_t)1 << S->k, low = ~(((size_t)1 << (S->k - S->d)) - 1);
    for (size_t x = 0; f->d && x < N; x++)
        if (f->d[x] != 0.0)
            return 0;
    /* each scaling the same over the patches of each coarse patch: equal to its corner's */
    for (size_t i = 0; i < f->p + f->q; i++) {
        const double *v = i < f->p ? f->a + i * N : f->b + (i - f->p) * N;
        for (size_t x = 0; x < N; x++)
            if (v[x] != v[((x / G) & low) * G + ((x % G) & low)])
                return 0;
    }
    return S->d;
}

double bsti_mat_lr_coarse_at(const bst_mat *m, size_t ci, size_t cj)
{
    const bsti_lr *f = m->lr;
    int k = f->S->k, kc = f->S->d;
    size_t N = f->N, r = f->r, ld = f->p * r;
    size_t x = coarse_corner(ci, k, kc), y = coarse_corner(cj, k, kc);
    /* bsti_lr_get's operations at (x, y) for a map of one entry of weight 1 a row: its c and s
     * are K's value itself (0 + v 1 and 0 + 1 c), and no diagonal */
    double v = 0.0;
    for (size_t i = 0; i < f->p; i++)
        for (size_t j = 0; j < f->q; j++)
            v += f->a[i * N + x] * f->k[(j * r + cj) * ld + i * r + ci] * f->b[j * N + y];
    return v;
}

void bsti_mat_lr_coarse_col(const bst_mat *m, size_t cj, double *out)
{
    const bsti_lr *f = m->lr;
    int k = f->S->k, kc = f->S->d;
    size_t N = f->N, r = f->r, ld = f->p * r, y = coarse_corner(cj, k, kc);
    for (size_t ci = 0; ci < r; ci++)
        out[ci] = 0.0;
    /* bsti_mat_lr_coarse_at's terms in its order, each added to every row in turn */
    for (size_t i = 0; i < f->p; i++)
        for (size_t j = 0; j < f->q; j++) {
            const double *kb = f->k + (j * r + cj) * ld + i * r, *a = f->a + i * N;
            double b = f->b[j * N + y];
            for (size_t ci = 0; ci < r; ci++)
                out[ci] += a[coarse_corner(ci, k, kc)] * kb[ci] * b;
        }
}

void bsti_mat_lr_coarse_values(const bst_mat *m, double *out)
{
    size_t nc = m->lr->r;
    for (size_t cj = 0; cj < nc; cj++)
        bsti_mat_lr_coarse_col(m, cj, out + cj * nc);
}

size_t bsti_mat_lr_coarse_cell(const bst_mat *m, size_t x)
{
    return m->lr->S->col[x];
}

int bsti_mat_lr_coarse_sums(bst_ctx *ctx, const bst_mat *m, double *col, double *row)
{
    size_t n = m->rows, nc = m->lr->r, per = n / nc;
    double *cc = bsti_calloc(ctx, 3 * nc, sizeof *cc), *rc = cc ? cc + nc : NULL;
    double *v = cc ? cc + 2 * nc : NULL;
    if (!cc)
        return BST_ENOMEM;
    for (size_t cj = 0; cj < nc; cj++) {
        bsti_mat_lr_coarse_col(m, cj, v);
        for (size_t ci = 0; ci < nc; ci++) {
            double x = v[ci] > 0.0 ? v[ci] : 0.0;
            cc[cj] += x;
            rc[ci] += x;
        }
    }
    for (size_t x = 0; x < n; x++) {
        size_t c = m->lr->S->col[x];
        col[x] = (double)per * cc[c];
        if (row)
            row[x] = (double)per * rc[c];
    }
    bsti_free(ctx, cc);
    return BST_OK;
}

void bsti_mat_lr_coarse_least(const double *fine, int k, int kc, double *out)
{
    size_t nc = (size_t)1 << (2 * kc), s = (size_t)1 << (k - kc), G = (size_t)1 << k;
    for (size_t cj = 0; cj < nc; cj++) {
        size_t x0 = coarse_corner(cj, k, kc);
        double least = INFINITY;
        for (size_t u = 0; u < s; u++)
            for (size_t v = 0; v < s; v++)
                least = fmin(least, fine[x0 + u * G + v]);
        out[cj] = least;
    }
}

/* The indices of K's lines (rows: cols 0, columns: 1) holding a value not 0, into idx; their count. */
static size_t used_lines(const bsti_lr *f, int cols, size_t *idx)
{
    size_t nr = f->p * f->r, nc = f->q * f->r, n = 0, len = cols ? nc : nr;
    for (size_t a = 0; a < len; a++) {
        size_t b = 0, other = cols ? nr : nc;
        while (b < other && (cols ? f->k[a * nr + b] : f->k[b * nr + a]) == 0.0)
            b++;
        if (b < other)
            idx[n++] = a;
    }
    return n;
}

/* out (N x n, column-major): column t = diag(v_i) S e_c for line idx[t] = i r + c of the list v
 * (nl lines in all); pos: room for nl counts. */
static void lines_dense(const bsti_lr *f, const double *v, const size_t *idx, size_t n, size_t nl,
                        size_t *pos, double *out)
{
    const bsti_lr_map *S = f->S;
    size_t N = f->N, r = f->r;
    memset(out, 0, N * n * sizeof *out);
    memset(pos, 0, nl * sizeof *pos);
    for (size_t t = 0; t < n; t++)
        pos[idx[t]] = t + 1;
    for (size_t x = 0; x < N; x++)
        for (size_t e = S->start[x]; e < S->start[x + 1]; e++)
            for (size_t i = 0; i * r + S->col[e] < nl; i++) {
                size_t t = pos[i * r + S->col[e]];
                if (t)
                    out[(t - 1) * N + x] += v[i * N + x] * S->w[e];
            }
}

/* ------------------------------------------------------------------ columns a block at a time */

struct bsti_cols {
    bst_ctx *ctx;
    const bst_mat *m;     /* NULL: zeros */
    size_t N, block;
    /* a FACTORED m over a wide map: M[:, y] = D e_y + L Rt[:, y] with L N x n and Rt n x N, n the
     * lesser of K's used rows R and columns C: L = A Ks, Rt = B^T (C <= R), or L = A, Rt = Ks B^T */
    int gemm;
    size_t n;
    int rt_t;             /* Rt held as its transpose (B, N x n) */
    double *L, *Rt, *gather;
    bsti_lr_rows **rows;  /* a FACTORED m over another map: its rows for bsti_lr_col_fast, one
                             layout (and room) per worker */
    int workers;
};

/* The factored reader's L and Rt (bsti_cols's comment), from the lines of K that are not zero. */
static int cols_gemm_init(bsti_cols *c)
{
    bst_ctx *ctx = c->ctx;
    const bsti_lr *f = c->m->lr;
    size_t N = f->N, nr = f->p * f->r, nc = f->q * f->r;
    size_t *ri = bsti_alloc_array(ctx, 2 * (nr + nc), sizeof *ri);
    if (!ri)
        return BST_ENOMEM;
    size_t *ci = ri + nr, *pos = ci + nc, R = used_lines(f, 0, ri), C = used_lines(f, 1, ci);
    double *A = bsti_alloc_array(ctx, N * R + 1, sizeof *A);
    double *B = bsti_alloc_array(ctx, N * C + 1, sizeof *B);
    double *Ks = bsti_alloc_array(ctx, R * C + 1, sizeof *Ks);
    c->n = R < C ? R : C;
    c->rt_t = C <= R;
    c->L = c->n && c->rt_t ? bsti_alloc_array(ctx, N * C, sizeof *c->L) : NULL;
    c->Rt = c->n && !c->rt_t ? bsti_alloc_array(ctx, R * N, sizeof *c->Rt) : NULL;
    c->gather = c->n ? bsti_alloc_array(ctx, c->block * c->n, sizeof *c->gather) : NULL;
    int rc = A && B && Ks && (!c->n || (c->gather && (c->rt_t ? c->L : c->Rt))) ? BST_OK : BST_ENOMEM;
    if (rc >= 0 && c->n) {
        lines_dense(f, f->a, ri, R, nr, pos, A);
        lines_dense(f, f->b, ci, C, nc, pos, B);
        for (size_t t = 0; t < C; t++)
            for (size_t s = 0; s < R; s++)
                Ks[t * R + s] = f->k[ci[t] * nr + ri[s]];
        if (c->rt_t) { /* L = A Ks (N x C), Rt = B^T kept as B */
            cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)N, (int)C, (int)R, 1.0, A,
                        (int)N, Ks, (int)R, 0.0, c->L, (int)N);
            c->Rt = B, B = NULL;
        } else { /* L = A, Rt = Ks B^T (R x N) */
            cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, (int)R, (int)N, (int)C, 1.0, Ks,
                        (int)R, B, (int)N, 0.0, c->Rt, (int)R);
            c->L = A, A = NULL;
        }
    }
    bsti_free(ctx, A), bsti_free(ctx, B), bsti_free(ctx, Ks), bsti_free(ctx, ri);
    return rc;
}

/* A FACTORED m over another map: the rows' layout and room of each worker (bsti_ctx_workers). */
static int cols_rows_init(bsti_cols *c)
{
    if (!c->m || c->m->s != BST_FACTORED)
        return BST_OK;
    c->workers = bsti_ctx_workers_no_alloc(c->ctx, c->block);
    if (!(c->rows = bsti_calloc(c->ctx, (size_t)c->workers, sizeof *c->rows)))
        return BST_ENOMEM;
    for (int t = 0; t < c->workers; t++) {
        int rc = bsti_lr_rows_new(c->ctx, c->m->lr, &c->rows[t]);
        if (rc < 0)
            return rc;
    }
    return BST_OK;
}

void bsti_cols_free(bsti_cols *c)
{
    if (!c)
        return;
    bsti_free(c->ctx, c->L), bsti_free(c->ctx, c->Rt), bsti_free(c->ctx, c->gather);
    for (int t = 0; c->rows && t < c->workers; t++)
        bsti_lr_rows_free(c->rows[t]);
    bsti_free(c->ctx, c->rows), bsti_free(c->ctx, c);
}

int bsti_cols_new(bst_ctx *ctx, const bst_mat *m, size_t N, bsti_cols **out)
{
    bsti_cols *c = bsti_calloc(ctx, 1, sizeof *c);
    *out = NULL;
    if (!c)
        return BST_ENOMEM;
    c->ctx = ctx, c->m = m && m->s != BST_ZERO ? m : NULL, c->N = N;
    size_t fit = BSTI_COLS_BYTES / (N * sizeof(double) + 1);
    c->block = fit < 1 ? 1 : fit > N ? N : fit;
    c->gemm = bsti_mat_lr_wide(m);
    int rc = c->gemm ? cols_gemm_init(c) : cols_rows_init(c);
    if (rc >= 0 && c->m && c->m->s == BST_PLUS_LR && /* cols_plus's rows of W */
        !(c->gather = bsti_alloc_array(ctx, c->block * c->m->plus->m + 1, sizeof *c->gather)))
        rc = BST_ENOMEM;
    if (rc < 0) {
        bsti_cols_free(c);
        return rc;
    }
    *out = c;
    return BST_OK;
}

size_t bsti_cols_block(const bsti_cols *c)
{
    return c->block;
}

/* Columns of the factored reader: cols (n of them, NULL: j0..j0 + n - 1), n <= block. */
static void cols_gemm(bsti_cols *c, const size_t *cols, size_t j0, size_t n, double *out)
{
    const bsti_lr *f = c->m->lr;
    size_t N = c->N, k = c->n;
    if (!k) {
        memset(out, 0, N * n * sizeof *out);
    } else if (c->rt_t) { /* out = L B[cols, :]^T */
        const double *b = c->Rt + j0;
        size_t ldb = N;
        if (cols) {
            for (size_t t = 0; t < k; t++)
                for (size_t s = 0; s < n; s++)
                    c->gather[t * n + s] = c->Rt[t * N + cols[s]];
            b = c->gather, ldb = n;
        }
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, (int)N, (int)n, (int)k, 1.0, c->L,
                    (int)N, b, (int)ldb, 0.0, out, (int)N);
    } else { /* out = L Rt[:, cols] */
        const double *b = c->Rt + j0 * k;
        if (cols) {
            for (size_t s = 0; s < n; s++)
                memcpy(c->gather + s * k, c->Rt + cols[s] * k, k * sizeof *c->gather);
            b = c->gather;
        }
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)N, (int)n, (int)k, 1.0, c->L,
                    (int)N, b, (int)k, 0.0, out, (int)N);
    }
    for (size_t s = 0; f->d && s < n; s++) {
        size_t y = cols ? cols[s] : j0 + s;
        out[s * N + y] += f->d[y];
    }
}

/* Column y of any other matrix (not PLUS_LR: cols_plus), each value as bsti_mat_at reads it
 * (FACTORED: bsti_lr_get's bits, through the rows laid out for it). */
static void col_plain(const bst_mat *m, bsti_lr_rows *rows, size_t N, size_t y, double *out)
{
    if (m && m->s == BST_FACTORED) {
        bsti_lr_col_fast(m->lr, rows, y, out);
        return;
    }
    if (m && m->s == BST_DENSE && m->prec == BST_DOUBLE) {
        memcpy(out, (const double *)m->dense + y * N, N * sizeof *out);
        return;
    }
    if (m && m->s == BST_DENSE) {
        for (size_t x = 0; x < N; x++)
            out[x] = ((const float *)m->dense)[y * N + x];
        return;
    }
    memset(out, 0, N * sizeof *out);
    if (m && m->s == BST_DIAG) {
        out[y] = m->diag[y];
    } else if (m && m->s == BST_SPARSE) {
        const SuiteSparse_long *p = m->sp->p, *ri = m->sp->i;
        const double *x = m->sp->x;
        for (SuiteSparse_long q = p[y]; q < p[y + 1]; q++)
            out[ri[q]] = x[q];
    }
}

/* Columns s0..s1 - 1 of a bsti_cols_get call, on worker t (a FACTORED m's rows[t]). */
struct cols_part {
    bsti_cols *c;
    const size_t *cols;
    size_t j0, s0, s1;
    double *out;
    int t;
};

static void *cols_part_run(void *opaque)
{
    struct cols_part *p = opaque;
    bsti_cols *c = p->c;
    for (size_t s = p->s0; s < p->s1; s++)
        col_plain(c->m, c->rows ? c->rows[p->t] : NULL, c->N, p->cols ? p->cols[s] : p->j0 + s,
                  p->out + s * c->N);
    return NULL;
}

/* Columns of any other matrix: a FACTORED one's shared out among the workers (each column the
 * same bits whichever computes it). */
static void cols_plain(bsti_cols *c, const size_t *cols, size_t j0, size_t n, double *out)
{
    struct cols_part part[BST_THREADS_MAX];
    int nw = !c->rows || n < 2 ? 1 : (size_t)c->workers < n ? c->workers : (int)n;
    for (int t = 0; t < nw; t++)
        part[t] = (struct cols_part){c, cols, j0, n * (size_t)t / (size_t)nw,
                                     n * (size_t)(t + 1) / (size_t)nw, out, t};
    bsti_run_parts(part, sizeof *part, (size_t)nw, cols_part_run);
}

/* Columns of a PLUS_LR reader (it has no rows of its own: read on the caller's thread): the
 * base's (a FACTORED base value by value), then U W[cols, :]^T added by one GEMM a block.  A
 * column at a time (m axpys of N from memory, on one thread) took 253 s to write a k = 7 blind
 * of rank 16 alone: its columns are read in each of the writer's passes. */
static void cols_plus(bsti_cols *c, const size_t *cols, size_t j0, size_t n, double *out)
{
    const struct bsti_plus *p = c->m->plus;
    size_t N = c->N, m = p->m;
    for (size_t s = 0; s < n; s++) {
        size_t y = cols ? cols[s] : j0 + s;
        if (p->base->s == BST_FACTORED)
            for (size_t x = 0; x < N; x++)
                out[s * N + x] = bst_mat_get(p->base, x, y);
        else
            col_plain(p->base, NULL, N, y, out + s * N);
        for (size_t k = 0; k < m; k++)
            c->gather[s * m + k] = p->w[k * N + y];
    }
    if (m && n)
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)N, (int)n, (int)m, 1.0, p->u,
                    (int)N, c->gather, (int)m, 1.0, out, (int)N);
}

void bsti_cols_get(bsti_cols *c, const size_t *cols, size_t j0, size_t n, double *out)
{
    for (size_t s0 = 0; s0 < n; s0 += c->block) {
        size_t nb = n - s0 < c->block ? n - s0 : c->block;
        double *o = out + s0 * c->N;
        if (c->gemm) {
            cols_gemm(c, cols ? cols + s0 : NULL, j0 + s0, nb, o);
            continue;
        }
        if (c->m && c->m->s == BST_PLUS_LR) {
            cols_plus(c, cols ? cols + s0 : NULL, j0 + s0, nb, o);
            continue;
        }
        cols_plain(c, cols ? cols + s0 : NULL, j0 + s0, nb, o);
    }
}

struct visit {
    bsti_cols *c[2];
    const size_t *cols[2];
    size_t n, per, chunks;
    bsti_cols_visit_fn fn;
    void *opaque;
    atomic_size_t next;  /* the next chunk to take */
    atomic_int stop;
};

struct visitor {
    struct visit *v;
    int t;
    double *buf[2];      /* per x N values for each reader */
};

static void *visit_run(void *arg)
{
    struct visitor *me = arg;
    struct visit *v = me->v;
    size_t N = v->c[0]->N;
    for (;;) {
        size_t q = atomic_fetch_add(&v->next, 1);
        if (q >= v->chunks || atomic_load(&v->stop))
            return NULL;
        size_t u0 = v->n * q / v->chunks, u1 = v->n * (q + 1) / v->chunks;
        for (size_t u = u0; u < u1 && !atomic_load(&v->stop); u++) {
            for (int r = 0; r < 2 && v->c[r]; r++) {
                const size_t *cols = v->cols[r];
                for (size_t s = 0; s < v->per; s++) {
                    size_t j = u * v->per + s;
                    col_plain(v->c[r]->m, v->c[r]->rows[me->t], N, cols ? cols[j] : j,
                              me->buf[r] + s * N);
                }
            }
            if (v->fn(v->opaque, q, u, me->buf[0], me->buf[1]))
                atomic_store(&v->stop, 1);
        }
    }
}

/* bsti_cols_visit where a reader has no workers of its own (a GEMM, a dense or sparse matrix): in
 * rounds, each of up to nw chunks in flight gets its next units' columns, read by this thread
 * (GEMM has its own threads), and then they are visited, a chunk on each thread.  A chunk's units
 * are visited in order, one at a time, whichever thread takes them in a round. */
struct bpart {
    struct visit *v;
    size_t q, u, k;      /* chunk q: units u .. u + k - 1 this round */
    const double *buf[2]; /* their columns from each reader */
};

static void *bpart_run(void *arg)
{
    struct bpart *b = arg;
    struct visit *v = b->v;
    size_t step = v->per * v->c[0]->N;
    for (size_t t = 0; t < b->k && !atomic_load(&v->stop); t++)
        if (v->fn(v->opaque, b->q, b->u + t, b->buf[0] + t * step, b->buf[1] ? b->buf[1] + t * step : NULL))
            atomic_store(&v->stop, 1);
    return NULL;
}

static int visit_blocks(struct visit *v)
{
    bsti_cols *c = v->c[0];
    size_t per = v->per, nr = v->c[1] ? 2 : 1;
    int nw = bsti_ctx_workers_no_alloc(c->ctx, v->chunks);
    size_t nu = c->block / per ? c->block / per : 1; /* units a round, shared by the chunks */
    size_t sub = nu / (size_t)nw ? nu / (size_t)nw : 1, slot = sub * per * c->N;
    double *buf = bsti_alloc_array(c->ctx, nr * (size_t)nw * slot, sizeof *buf);
    if (!buf)
        return BST_ENOMEM;
    struct bpart part[BST_THREADS_MAX];
    size_t next = 0, at[BST_THREADS_MAX] = {0}, end[BST_THREADS_MAX] = {0}, q[BST_THREADS_MAX] = {0};
    while (!atomic_load(&v->stop)) {
        int live = 0;
        for (int t = 0; t < nw; t++) { /* each slot's chunk: its next units, or the next chunk */
            if (at[t] == end[t] && next < v->chunks) {
                q[t] = next++;
                at[t] = v->n * q[t] / v->chunks, end[t] = v->n * (q[t] + 1) / v->chunks;
            }
            size_t k = end[t] - at[t] < sub ? end[t] - at[t] : sub;
            part[t] = (struct bpart){v, q[t], at[t], k, {NULL, NULL}};
            for (size_t r = 0; r < nr && k; r++) {
                double *b = buf + (r * (size_t)nw + (size_t)t) * slot;
                bsti_cols_get(v->c[r], v->cols[r] ? v->cols[r] + at[t] * per : NULL, at[t] * per,
                              k * per, b);
                part[t].buf[r] = b;
            }
            at[t] += k;
            live += k > 0;
        }
        if (!live)
            break;
        bsti_run_parts(part, sizeof *part, (size_t)nw, bpart_run);
    }
    bsti_free(c->ctx, buf);
    return BST_OK;
}

int bsti_cols_visit(bsti_cols *c, const size_t *cols, bsti_cols *c2, const size_t *cols2, size_t n,
                    size_t per, size_t chunks, bsti_cols_visit_fn visit, void *opaque)
{
    if (!per || !n)
        return BST_OK;
    struct visit v = {{c, c2}, {cols, c2 && !cols2 ? cols : cols2}, n, per, chunks ? chunks : 1,
                      visit, opaque, 0, 0};
    if (!c->rows || (c2 && !c2->rows))
        return visit_blocks(&v);
    size_t nr = c2 ? 2 : 1, slot = per * c->N;
    int nw = c2 && c2->workers < c->workers ? c2->workers : c->workers;
    if ((size_t)nw > v.chunks)
        nw = (int)v.chunks;
    struct visitor me[BST_THREADS_MAX];
    double *buf = bsti_alloc_array(c->ctx, (size_t)nw * nr * slot, sizeof *buf);
    if (!buf)
        return BST_ENOMEM;
    for (int t = 0; t < nw; t++)
        me[t] = (struct visitor){&v, t, {buf + (size_t)t * nr * slot,
                                         c2 ? buf + ((size_t)t * nr + 1) * slot : NULL}};
    bsti_run_parts(me, sizeof *me, (size_t)nw, visit_run); /* (late runs find no chunk left) */
    bsti_free(c->ctx, buf);
    return BST_OK;
}

int bsti_mat_lr_expand(bst_ctx *ctx, const bst_mat *m, bst_precision prec, bst_mat **out)
{
    bsti_cols *c;
    *out = NULL;
    int rc = bsti_cols_new(ctx, m, m->rows, &c);
    if (rc >= 0)
        rc = bst_mat_new_dense(ctx, m->rows, m->rows, BST_DOUBLE, out);
    if (rc >= 0)
        bsti_cols_get(c, NULL, 0, m->rows, bst_mat_dense_data(*out));
    bsti_cols_free(c);
    if (rc >= 0 && prec != BST_DOUBLE) {
        bst_mat *f;
        rc = bst_mat_convert(ctx, *out, BST_DENSE, prec, &f);
        bst_mat_free(*out);
        *out = rc >= 0 ? f : NULL;
    }
    return rc;
}
