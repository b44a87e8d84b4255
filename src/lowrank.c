/* lowrank.c - factored matrices D + U K V^T (lowrank.h): their products, sums, scalings and the
 * Woodbury inverse, each exact (to rounding) and with dense work of the coarse size only.
 *
 * Block bookkeeping: K's block (i, j) is r x r at rows i r .. i r + r - 1 and columns
 * j r .. j r + r - 1 of a column-major (p r) x (q r) array.  A result's scaling vectors are
 * collected term by term; a vector already in the list (find_or_add) takes the same block, so the
 * blocks of equal scalings add up instead of growing the rank. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include <cblas.h>
#include <lapacke.h>

#include "ctx.h"
#include "lowrank.h"
#include "mat.h"

/* Two scaling vectors are one when they differ by at most this much of the larger's largest
 * value: products of the same diagonals in another order round differently (a few ulps). */
#define BSTI_LR_SAME_TOL 1e-14

int bsti_lr_map_new(bst_ctx *ctx, size_t N, size_t r, size_t nnz, bsti_lr_map **out)
{
    *out = NULL;
    bsti_lr_map *S = bsti_calloc(ctx, 1, sizeof *S);
    if (!S)
        return BST_ENOMEM;
    S->refs = 1, S->ctx = ctx; /* before any failure: the release below frees what was made */
    S->start = bsti_alloc_array(ctx, N + 1, sizeof *S->start);
    S->col = S->start ? bsti_alloc_array(ctx, nnz ? nnz : 1, sizeof *S->col) : NULL;
    S->w = S->col ? bsti_alloc_array(ctx, nnz ? nnz : 1, sizeof *S->w) : NULL;
    if (!S->w) {
        bsti_lr_map_free(ctx, S);
        return BST_ENOMEM;
    }
    S->N = N, S->r = r, S->k = -1, S->d = -1;
    S->start[0] = 0, S->start[N] = nnz;
    *out = S;
    return BST_OK;
}

int bsti_lr_map_prolong(bst_ctx *ctx, int k, int d, bsti_lr_map **out)
{
    *out = NULL;
    if (d < 0 || d > k || k > BST_K_MAX)
        return bsti_error(ctx, BST_EINVAL, "prolongation from order %d to %d", d, k);
    size_t G = (size_t)1 << k, g = (size_t)1 << d, N = G * G, s = (size_t)(k - d);
    int rc = bsti_lr_map_new(ctx, N, g * g, N, out);
    if (rc < 0)
        return rc;
    bsti_lr_map *S = *out;
    S->k = k, S->d = d, S->single = 1;
    snprintf(S->tag, sizeof S->tag, "P");
    for (size_t x = 0; x < N; x++) {
        S->start[x] = x;
        S->col[x] = ((x / G) >> s) * g + ((x % G) >> s);
        S->w[x] = 1.0;
    }
    return BST_OK;
}

static void map_hold(const bsti_lr_map *S)
{
    __atomic_add_fetch(&((bsti_lr_map *)S)->refs, 1, __ATOMIC_RELAXED);
}

static void map_release(const bsti_lr_map *S)
{
    bsti_lr_map *m = (bsti_lr_map *)S;
    if (!m || __atomic_sub_fetch(&m->refs, 1, __ATOMIC_ACQ_REL) != 0)
        return;
    bsti_free(m->ctx, m->start), bsti_free(m->ctx, m->col), bsti_free(m->ctx, m->w);
    bsti_free(m->ctx, m);
}

void bsti_lr_map_free(bst_ctx *ctx, bsti_lr_map *S)
{
    (void)ctx; /* freed through the context that made it, by the last holder */
    map_release(S);
}

int bsti_lr_same_map(const bsti_lr *f, const bsti_lr *g)
{
    const bsti_lr_map *a = f->S, *b = g->S;
    return a == b || (a->tag[0] && strcmp(a->tag, b->tag) == 0 && a->k == b->k && a->d == b->d &&
                      a->N == b->N && a->r == b->r);
}

bsti_lr_map *bsti_lr_map_hold(bsti_lr_map *S)
{
    map_hold(S);
    return S;
}

void bsti_lr_free(bst_ctx *ctx, bsti_lr *m)
{
    if (!m)
        return;
    bsti_free(ctx, m->d), bsti_free(ctx, m->a), bsti_free(ctx, m->b), bsti_free(ctx, m->k);
    bsti_free(ctx, m->ks);
    map_release(m->S);
    bsti_free(ctx, m);
}

int bsti_lr_alloc(bst_ctx *ctx, const bsti_lr_map *S, size_t p, size_t q, int with_d, int kmode,
                  bsti_lr **out)
{
    size_t N = S->N, r = S->r;
    bsti_lr *m = bsti_calloc(ctx, 1, sizeof *m);
    *out = NULL;
    if (!m)
        return BST_ENOMEM;
    *m = (bsti_lr){.S = S, .N = N, .r = r, .p = p, .q = q};
    map_hold(S);
    int ok = (!with_d || (m->d = bsti_alloc_array(ctx, N, sizeof *m->d))) &&
             (m->a = bsti_alloc_array(ctx, p * N + 1, sizeof *m->a)) &&
             (m->b = bsti_alloc_array(ctx, q * N + 1, sizeof *m->b)) &&
             (kmode == BSTI_LR_K_NONE ||
              (m->k = kmode == BSTI_LR_K_ZERO ? bsti_calloc(ctx, p * r * q * r + 1, sizeof *m->k)
                                              : bsti_alloc_array(ctx, p * r * q * r + 1, sizeof *m->k)));
    if (!ok) {
        bsti_lr_free(ctx, m);
        return BST_ENOMEM;
    }
    *out = m;
    return BST_OK;
}

int bsti_lr_new(bst_ctx *ctx, const bsti_lr_map *S, const double *d, const double *a,
                const double *K, const double *b, bsti_lr **out)
{
    size_t N = S->N, r = S->r, p = K ? 1 : 0;
    int rc = bsti_lr_alloc(ctx, S, p, p, d != NULL, K ? BSTI_LR_K_FILLED : BSTI_LR_K_ZERO, out);
    if (rc < 0)
        return rc;
    bsti_lr *m = *out;
    if (d)
        memcpy(m->d, d, N * sizeof *d);
    for (size_t x = 0; p && x < N; x++)
        m->a[x] = a ? a[x] : 1.0, m->b[x] = b ? b[x] : 1.0;
    if (K)
        memcpy(m->k, K, r * r * sizeof *K);
    return BST_OK;
}

size_t bsti_lr_find(const double *list, size_t n, const double *v, size_t N)
{
    double vmax = 0.0;
    for (size_t x = 0; x < N; x++)
        vmax = fmax(vmax, fabs(v[x]));
    for (size_t i = 0; i < n; i++) {
        const double *u = list + i * N;
        size_t x = 0;
        while (x < N && fabs(u[x] - v[x]) <= BSTI_LR_SAME_TOL * vmax)
            x++;
        if (x == N)
            return i;
    }
    return n;
}

size_t bsti_lr_find_or_add(double *list, size_t *n, const double *v, size_t N)
{
    size_t i = bsti_lr_find(list, *n, v, N);
    if (i == *n)
        memcpy(list + (*n)++ * N, v, N * sizeof *v);
    return i;
}

/* G[row0 .., col0 ..] += S^T diag(c) S, G column-major with leading dimension ld. */
void bsti_lr_gram_add(const bsti_lr_map *S, const double *c, double *G, size_t ld, size_t row0,
                     size_t col0)
{
    for (size_t x = 0; x < S->N; x++)
        for (size_t e2 = S->start[x]; e2 < S->start[x + 1]; e2++)
            for (size_t e1 = S->start[x]; e1 < S->start[x + 1]; e1++)
                G[(col0 + S->col[e2]) * ld + row0 + S->col[e1]] += c[x] * S->w[e1] * S->w[e2];
}

/* The gram S^T diag(c) S of a map of one entry a row is diagonal: its r values into g (the sum
 * over each coarse cell's rows, in the order and with the operations gram_add uses). */
void bsti_lr_gram_diag(const bsti_lr_map *S, const double *c, double *g)
{
    for (size_t x = 0; x < S->r; x++)
        g[x] = 0.0;
    for (size_t x = 0; x < S->N; x++)
        g[S->col[x]] += c[x] * S->w[x] * S->w[x];
}

/* T := beta T + alpha K G for K (m x nq r, column-major) and G (nq r x np r) of diagonal r x r
 * blocks, block (j, i)'s diagonal at g + (j np + i) r; beta is 0 (T overwritten) or 1.  What a
 * GEMM with that G gives (with one block row, nq = 1, the same values: every sum holds one
 * product) at r times fewer operations. */
void bsti_lr_mul_diag_blocks(const double *K, size_t m, size_t nq, size_t np, size_t r,
                            const double *g, double alpha, int beta, double *T)
{
    for (size_t i = 0; i < np; i++)
        for (size_t c = 0; c < r; c++) {
            double *t = T + (i * r + c) * m;
            for (size_t x = 0; x < m; x++) {
                double acc = 0.0;
                for (size_t j = 0; j < nq; j++)
                    acc += K[(j * r + c) * m + x] * g[(j * np + i) * r + c];
                t[x] = beta ? t[x] + alpha * acc : alpha * acc;
            }
        }
}

/* dst's block (bi, bj) += s * src's block (i, j), both r x r blocks of column-major arrays (no
 * I and J: lapacke.h brings complex.h's I). */
void bsti_lr_add_block(double *dst, size_t ldd, size_t bi, size_t bj, const double *src, size_t lds,
                      size_t i, size_t j, size_t r, double s)
{
    for (size_t c = 0; c < r; c++)
        for (size_t q = 0; q < r; q++)
            dst[(bj * r + c) * ldd + bi * r + q] += s * src[(j * r + c) * lds + i * r + q];
}

void bsti_lr_block_put(double *dst, size_t ldd, size_t bi, size_t bj, const bsti_lr *f, size_t i,
                       size_t j, double s, int first)
{
    size_t r = f->r, lds = f->p * r;
    if (f->k && !first) {
        bsti_lr_add_block(dst, ldd, bi, bj, f->k, lds, i, j, r, s);
        return;
    }
    for (size_t c = 0; c < r; c++) {
        double *d = dst + (bj * r + c) * ldd + bi * r;
        if (f->k) { /* 0 + x, not x: a -0 becomes +0, as adding to a cleared block makes it */
            const double *src = f->k + (j * r + c) * lds + i * r;
            for (size_t q = 0; q < r; q++)
                d[q] = 0.0 + s * src[q];
            continue;
        }
        if (first)
            memset(d, 0, r * sizeof *d);
        for (size_t e = f->ks->start[c]; e < f->ks->start[c + 1]; e++)
            d[f->ks->row[e]] += s * f->ks->val[e];
    }
}

/* Values of A (m x n, leading dimension lda) that are not zero, counting stopped past limit. */
static size_t nonzeros(const double *A, size_t m, size_t n, size_t lda, size_t limit)
{
    size_t nz = 0;
    for (size_t j = 0; j < n && nz <= limit; j++)
        for (size_t i = 0; i < m; i++)
            nz += A[j * lda + i] != 0.0;
    return nz;
}

/* C = S diag(g) B for a sparse m x k S given by column (start: k + 1, row, val; g k values or NULL
 * for ones) and a dense k x n B: each column of C the sum, over l in order, of S's column l times
 * g[l] B[l, j]. */
static void sparse_times(size_t m, size_t j0, size_t n, size_t k, const size_t *start,
                         const size_t *row, const double *val, const double *g, const double *B,
                         double *C, size_t ldc)
{
    for (size_t j = j0; j < n; j++) {
        double *c = C + j * ldc;
        memset(c, 0, m * sizeof *c);
        for (size_t l = 0; l < k; l++) {
            double b = B[j * k + l];
            for (size_t e = start[l]; e < start[l + 1]; e++)
                c[row[e]] += (g ? val[e] * g[l] : val[e]) * b;
        }
    }
}

/* C = A diag(g) S for a dense m x k A and a sparse k x n S given by column (start: n + 1, row,
 * val): each column of C the sum, over S's values in order, of A diag(g)'s column times the value. */
static void times_sparse(size_t m, size_t j0, size_t n, const double *A, const double *g,
                         const size_t *start, const size_t *row, const double *val, double *C,
                         size_t ldc)
{
    for (size_t j = j0; j < n; j++) {
        double *c = C + j * ldc;
        memset(c, 0, m * sizeof *c);
        for (size_t e = start[j]; e < start[j + 1]; e++) {
            size_t l = row[e];
            double b = val[e];
            for (size_t i = 0; i < m; i++)
                c[i] += (g ? A[l * m + i] * g[l] : A[l * m + i]) * b;
        }
    }
}

/* Columns j0 .. j1 - 1 of sparse_times (left 1: the sparse one on the left) or times_sparse, a part
 * for bsti_run_parts. */
struct sparse_part {
    int left;
    size_t m, j0, j1, k, ldc;
    const size_t *start, *row;
    const double *val, *g, *A, *B;
    double *C;
};

static void *sparse_part_run(void *arg)
{
    const struct sparse_part *t = arg;
    if (t->left)
        sparse_times(t->m, t->j0, t->j1, t->k, t->start, t->row, t->val, t->g, t->B, t->C, t->ldc);
    else
        times_sparse(t->m, t->j0, t->j1, t->A, t->g, t->start, t->row, t->val, t->C, t->ldc);
    return NULL;
}

/* C = S diag(g) B (s->left) or A diag(g) S over the n columns of C, shared out by columns among the
 * context's threads where C is large (a million values; a pane's K at k = 7 is 16.8 million): each
 * column is its own sums, so the same bits on any number of threads.  These loops are bound by
 * memory, which one core of a 2-core machine does not use up (bench/README.md). */
#define LR_SPARSE_PAR_MIN ((size_t)1 << 20)
static void sparse_product(const bst_ctx *ctx, const struct sparse_part *s, size_t n)
{
    struct sparse_part part[BST_THREADS_MAX];
    size_t nw = s->m * n >= LR_SPARSE_PAR_MIN ? (size_t)bsti_ctx_workers_no_alloc(ctx, n) : 1;
    for (size_t w = 0; w < nw; w++) {
        part[w] = *s;
        part[w].j0 = n * w / nw, part[w].j1 = n * (w + 1) / nw;
    }
    bsti_run_parts(part, sizeof *part, nw, sparse_part_run);
}

/* The values of the m x n M (column-major, leading dimension m) that are not zero, by column, as
 * M's value times g[row] (g NULL: ones), into *start (n + 1, then nz rows) and *val (nz). */
static int by_column(bst_ctx *ctx, const double *M, const double *g, size_t m, size_t n, size_t nz,
                     size_t **start, double **val)
{
    *start = bsti_alloc_array(ctx, n + 1 + nz, sizeof **start);
    *val = bsti_alloc_array(ctx, nz + 1, sizeof **val);
    if (!*start || !*val) {
        bsti_free(ctx, *start), bsti_free(ctx, *val);
        return BST_ENOMEM;
    }
    size_t *row = *start + n + 1;
    for (size_t j = 0, e = 0; j < n; j++) {
        (*start)[j] = e;
        for (size_t i = 0; i < m; i++) {
            double v = g ? M[j * m + i] * g[j] : M[j * m + i];
            if (v != 0.0)
                row[e] = i, (*val)[e++] = v;
        }
        (*start)[j + 1] = e;
    }
    return BST_OK;
}

/* C = A diag(g) B (m x n in C's leading dimension ldc; A m x k, g k values or NULL for ones, B k x
 * n, column-major, their leading dimensions their row counts): GEMM, unless A diag(g) or B is sparse
 * (BSTI_LR_SPARSE_SHARE), then through its values that are not zero (the same sums but for their
 * order), taken from as or bs where given (that matrix's, bsti_lr_csc), else found by a pass over
 * the matrix; A or B NULL: held by as or bs alone (lowrank.h), always taken so.  Each value of
 * A diag(g) is A's times g's, as bsti_lr_mul_diag_blocks makes it: the sparse ways take them as
 * they go, the GEMM from an m x k array of them. */
static int lr_gemm(bst_ctx *ctx, size_t m, size_t n, size_t k, const double *A, const double *g,
                   const bsti_lr_csc *as, const double *B, const bsti_lr_csc *bs, double *C,
                   size_t ldc)
{
    size_t la = (size_t)(BSTI_LR_SPARSE_SHARE * (double)m * (double)k);
    size_t lb = (size_t)(BSTI_LR_SPARSE_SHARE * (double)k * (double)n);
    if (as && (as->nnz <= la || !A) && B) {
        struct sparse_part t = {.left = 1, .m = m, .k = k, .ldc = ldc, .start = as->start,
                                .row = as->row, .val = as->val, .g = g, .B = B, .C = C};
        sparse_product(ctx, &t, n);
        return BST_OK;
    }
    if (bs && (bs->nnz <= lb || !B) && A) {
        struct sparse_part t = {.left = 0, .m = m, .ldc = ldc, .start = bs->start, .row = bs->row,
                                .val = bs->val, .g = g, .A = A, .C = C};
        sparse_product(ctx, &t, n);
        return BST_OK;
    }
    size_t nza = 0;
    for (size_t l = 0; l < k && nza <= la; l++)
        for (size_t i = 0; i < m; i++)
            nza += (g ? A[l * m + i] * g[l] : A[l * m + i]) != 0.0;
    size_t nzb = nza <= la ? 0 : nonzeros(B, k, n, k, lb);
    if (nza <= la || nzb <= lb) { /* the sparse one's values listed by column */
        size_t *start;
        double *val;
        int rc = nza <= la ? by_column(ctx, A, g, m, k, nza, &start, &val)
                           : by_column(ctx, B, NULL, k, n, nzb, &start, &val);
        if (rc < 0)
            return rc;
        struct sparse_part t = {.left = nza <= la, .m = m, .k = k, .ldc = ldc, .start = start,
                                .row = start + (nza <= la ? k : n) + 1, .val = val,
                                .g = nza <= la ? NULL : g, .A = A, .B = B, .C = C};
        sparse_product(ctx, &t, n);
        bsti_free(ctx, start), bsti_free(ctx, val);
    } else {
        double *ag = NULL;
        if (g) {
            if (!(ag = bsti_alloc_array(ctx, m * k, sizeof *ag)))
                return BST_ENOMEM;
            bsti_lr_mul_diag_blocks(A, m, 1, 1, k, g, 1.0, 0, ag);
        }
        cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, (int)m, (int)n, (int)k, 1.0,
                    ag ? ag : A, (int)m, B, (int)k, 0.0, C, (int)ldc);
        bsti_flops_add(ctx, 2.0 * (double)m * (double)n * (double)k);
        bsti_free(ctx, ag);
    }
    return BST_OK;
}

static void times(double *v, const double *x, const double *y, size_t N)
{
    for (size_t n = 0; n < N; n++)
        v[n] = x[n] * y[n];
}

/* Scratch of a product or sum: the result's two lists and where each operand's vectors went. */
struct lists {
    double *left, *right, *v;
    size_t *li_f, *li_g, *rj_f, *rj_g;
};

static int lists_alloc(bst_ctx *ctx, size_t N, size_t pmax, size_t qmax, const bsti_lr *f,
                       const bsti_lr *g, struct lists *l)
{
    memset(l, 0, sizeof *l);
    l->left = bsti_alloc_array(ctx, pmax * N + 1, sizeof *l->left);
    l->right = bsti_alloc_array(ctx, qmax * N + 1, sizeof *l->right);
    l->v = bsti_alloc_array(ctx, N, sizeof *l->v);
    l->li_f = bsti_alloc_array(ctx, f->p + g->p + f->q + g->q + 4, sizeof *l->li_f);
    if (!l->left || !l->right || !l->v || !l->li_f)
        return BST_ENOMEM;
    l->li_g = l->li_f + f->p + 1, l->rj_f = l->li_g + g->p + 1, l->rj_g = l->rj_f + f->q + 1;
    return BST_OK;
}

static void lists_free(bst_ctx *ctx, struct lists *l)
{
    bsti_free(ctx, l->left), bsti_free(ctx, l->right), bsti_free(ctx, l->v), bsti_free(ctx, l->li_f);
}

/* A new matrix holding the lists (pn, qn vectors) and, with_d, a diagonal; K as kmode says. */
static int lr_from_lists(bst_ctx *ctx, const bsti_lr_map *S, const struct lists *l, size_t pn,
                         size_t qn, int with_d, int kmode, bsti_lr **out)
{
    int rc = bsti_lr_alloc(ctx, S, pn, qn, with_d, kmode, out);
    if (rc >= 0) {
        memcpy((*out)->a, l->left, pn * S->N * sizeof *l->left);
        memcpy((*out)->b, l->right, qn * S->N * sizeof *l->right);
    }
    return rc;
}

/* F with K as an array: F itself (*copy NULL), or, where F holds K by column alone, a copy that
 * holds it so (*copy, to be freed). */
static int with_k(bst_ctx *ctx, const bsti_lr *f, bsti_lr **copy)
{
    *copy = NULL;
    if (f->k)
        return BST_OK;
    int rc = bsti_lr_alloc(ctx, f->S, f->p, f->q, f->d != NULL, BSTI_LR_K_FILLED, copy);
    if (rc < 0)
        return rc;
    bsti_lr *m = *copy;
    if (f->d)
        memcpy(m->d, f->d, f->N * sizeof *m->d);
    memcpy(m->a, f->a, f->p * f->N * sizeof *m->a);
    memcpy(m->b, f->b, f->q * f->N * sizeof *m->b);
    bsti_lr_block_put(m->k, f->p * f->r, 0, 0, f, 0, 0, 1.0, 1);
    return BST_OK;
}

static int same_map(bst_ctx *ctx, const bsti_lr *f, const bsti_lr *g)
{
    if (!bsti_lr_same_map(f, g))
        return bsti_error(ctx, BST_EINVAL, "factored matrices over different maps");
    return BST_OK;
}

/* The coupled term of F G, U_F (K_F V_F^T U_G K_G) V_G^T, added to m's K (leading dimension ld)
 * at the blocks the lists give; direct: it is one block, zero so far, and the product is made
 * there (no r x r scratch, no pass adding it). */
static int coupled(bst_ctx *ctx, const bsti_lr *f, const bsti_lr *g, struct lists *l, bsti_lr *m,
                   size_t ld, int direct)
{
    size_t N = f->N, r = f->r;
    size_t fq = f->q * r, gp = g->p * r, fp = f->p * r, gq = g->q * r;
    int single = f->S->single; /* V_F^T U_G of diagonal blocks: no GEMM for K_F V_F^T U_G */
    /* one diagonal block between K_F and K_G: lr_gemm takes it as it goes (no K_F G array where
     * either is sparse, a pane's) */
    int one = single && f->q == 1 && g->p == 1;
    double *gm = single ? bsti_alloc_array(ctx, f->q * gp, sizeof *gm)
                        : bsti_calloc(ctx, fq * gp, sizeof *gm);
    double *t1 = one ? NULL : bsti_alloc_array(ctx, fp * gp, sizeof *t1);
    double *t = direct ? m->k + l->rj_g[0] * r * ld + l->li_f[0] * r
                       : bsti_alloc_array(ctx, fp * gq, sizeof *t);
    int rc = gm && (one || t1) && t ? BST_OK : BST_ENOMEM;
    for (size_t j = 0; rc >= 0 && j < f->q; j++)
        for (size_t i = 0; i < g->p; i++) {
            times(l->v, f->b + j * N, g->a + i * N, N);
            if (single)
                bsti_lr_gram_diag(f->S, l->v, gm + (j * g->p + i) * r);
            else
                bsti_lr_gram_add(f->S, l->v, gm, fq, j * r, i * r);
        }
    if (rc >= 0 && one)
        rc = lr_gemm(ctx, fp, gq, gp, f->k, gm, f->ks, g->k, g->ks, t, direct ? ld : fp);
    else {
        if (rc >= 0 && single)
            bsti_lr_mul_diag_blocks(f->k, fp, f->q, g->p, r, gm, 1.0, 0, t1);
        else if (rc >= 0)
            rc = lr_gemm(ctx, fp, gp, fq, f->k, NULL, f->ks, gm, NULL, t1, fp);
        if (rc >= 0)
            rc = lr_gemm(ctx, fp, gq, gp, t1, NULL, NULL, g->k, g->ks, t, direct ? ld : fp);
    }
    for (size_t i = 0; rc >= 0 && !direct && i < f->p; i++)
        for (size_t j = 0; j < g->q; j++)
            bsti_lr_add_block(m->k, ld, l->li_f[i], l->rj_g[j], t, fp, i, j, r, 1.0);
    bsti_free(ctx, gm), bsti_free(ctx, t1);
    if (!direct)
        bsti_free(ctx, t);
    return rc;
}

/* F G = D_F D_G + D_F U_G K_G V_G^T + U_F K_F V_F^T D_G + U_F (K_F V_F^T U_G K_G) V_G^T.  An operand
 * holding K by column alone (lowrank.h) is taken so where the coupled term is one product through
 * its values (one diagonal block between the two K: coupled's `one`), else as a copy with K. */
static int mul(bst_ctx *ctx, const bsti_lr *f, const bsti_lr *g, bsti_lr **out)
{
    size_t N = f->N, r = f->r;
    struct lists l;
    int rc = lists_alloc(ctx, N, g->p + f->p, g->q + f->q, f, g, &l);
    size_t pn = 0, qn = 0;
    for (size_t i = 0; rc >= 0 && f->d && i < g->p; i++) {
        times(l.v, f->d, g->a + i * N, N);
        l.li_g[i] = bsti_lr_find_or_add(l.left, &pn, l.v, N);
    }
    for (size_t i = 0; rc >= 0 && i < f->p; i++)
        l.li_f[i] = bsti_lr_find_or_add(l.left, &pn, f->a + i * N, N);
    for (size_t j = 0; rc >= 0 && j < g->q; j++)
        l.rj_g[j] = bsti_lr_find_or_add(l.right, &qn, g->b + j * N, N);
    for (size_t j = 0; rc >= 0 && g->d && j < f->q; j++) {
        times(l.v, g->d, f->b + j * N, N);
        l.rj_f[j] = bsti_lr_find_or_add(l.right, &qn, l.v, N);
    }
    /* A coupled term of one block that at most one diagonal term adds to is made first, in its
     * block: the same sums as adding it last (x + y = y + x); where it is K's only block, K is
     * not cleared first. */
    int direct = 0;
    if (rc >= 0 && f->p == 1 && g->q == 1 && g->p) {
        int hits = 0;
        for (size_t i = 0; f->d && i < g->p; i++)
            for (size_t j = 0; j < g->q; j++)
                hits += l.li_g[i] == l.li_f[0] && l.rj_g[j] == l.rj_g[0];
        for (size_t i = 0; g->d && i < f->p; i++)
            for (size_t j = 0; j < f->q; j++)
                hits += l.li_f[i] == l.li_f[0] && l.rj_f[j] == l.rj_g[0];
        direct = hits <= 1;
    }
    if (rc >= 0)
        rc = lr_from_lists(ctx, f->S, &l, pn, qn, f->d && g->d,
                           direct && pn == 1 && qn == 1 ? BSTI_LR_K_FILLED : BSTI_LR_K_ZERO, out);
    if (rc < 0) {
        lists_free(ctx, &l);
        return rc;
    }
    bsti_lr *m = *out;
    size_t ld = pn * r;
    if (direct)
        rc = coupled(ctx, f, g, &l, m, ld, 1);
    if (m->d)
        times(m->d, f->d, g->d, N);
    for (size_t i = 0; f->d && i < g->p; i++)
        for (size_t j = 0; j < g->q; j++)
            bsti_lr_block_put(m->k, ld, l.li_g[i], l.rj_g[j], g, i, j, 1.0, 0);
    for (size_t i = 0; g->d && i < f->p; i++)
        for (size_t j = 0; j < f->q; j++)
            bsti_lr_block_put(m->k, ld, l.li_f[i], l.rj_f[j], f, i, j, 1.0, 0);
    if (rc >= 0 && !direct && f->p && g->p)
        rc = coupled(ctx, f, g, &l, m, ld, 0);
    lists_free(ctx, &l);
    if (rc < 0) {
        bsti_lr_free(ctx, m);
        *out = NULL;
    }
    return rc;
}

int bsti_lr_mul(bst_ctx *ctx, const bsti_lr *f, const bsti_lr *g, bsti_lr **out)
{
    *out = NULL;
    int rc = same_map(ctx, f, g);
    if (rc < 0)
        return rc;
    bsti_lr *fk = NULL, *gk = NULL;
    if ((!f->k || !g->k) && !(f->S->single && f->q == 1 && g->p == 1) &&
        ((rc = with_k(ctx, f, &fk)) < 0 || (rc = with_k(ctx, g, &gk)) < 0)) {
        bsti_lr_free(ctx, fk);
        return rc;
    }
    rc = mul(ctx, fk ? fk : f, gk ? gk : g, out);
    bsti_lr_free(ctx, fk), bsti_lr_free(ctx, gk);
    return rc;
}

/* The index of a vector of the list that v is a multiple of (v = c u to 1e-14 of v's largest
 * value), its factor in *c; when none, v appended (c = 1).  A sum's terms often carry one scaling
 * vector times a constant (Shirley-Chiu's projected solid angle is one value for every patch, so
 * L F's left vector is the projected solid angle times F's): the constant goes into K's block
 * instead of a block of its own, which would double the sum's rank. */
static size_t find_multiple_or_add(double *list, size_t *n, const double *v, size_t N, double *c)
{
    *c = 1.0;
    size_t same = bsti_lr_find(list, *n, v, N); /* the vector itself: K's block as it is */
    if (same < *n)
        return same;
    double vmax = 0.0;
    size_t x0 = N;
    for (size_t x = 0; x < N; x++) {
        vmax = fmax(vmax, fabs(v[x]));
        if (x0 == N && v[x] != 0.0)
            x0 = x;
    }
    for (size_t i = 0; x0 < N && i < *n; i++) {
        const double *u = list + i * N;
        if (u[x0] == 0.0)
            continue;
        double f = v[x0] / u[x0];
        size_t x = 0;
        while (x < N && fabs(f * u[x] - v[x]) <= BSTI_LR_SAME_TOL * vmax)
            x++;
        if (x == N) {
            *c = f;
            return i;
        }
    }
    memcpy(list + *n * N, v, N * sizeof *v);
    return (*n)++;
}

int bsti_lr_add(bst_ctx *ctx, double alpha, const bsti_lr *f, double beta, const bsti_lr *g,
                bsti_lr **out)
{
    *out = NULL;
    int rc = same_map(ctx, f, g);
    if (rc < 0)
        return rc;
    size_t N = f->N, r = f->r;
    struct lists l;
    rc = lists_alloc(ctx, N, f->p + g->p, f->q + g->q, f, g, &l);
    size_t pn = 0, qn = 0;
    /* each vector's factor against the list's: F's and G's left ones, then their right ones */
    double *c = rc >= 0 ? bsti_alloc_array(ctx, f->p + g->p + f->q + g->q + 1, sizeof *c) : NULL;
    if (rc >= 0 && !c)
        rc = BST_ENOMEM;
    double *cl_f = c, *cl_g = c ? c + f->p : NULL, *cr_f = c ? cl_g + g->p : NULL;
    double *cr_g = c ? cr_f + f->q : NULL;
    for (size_t i = 0; rc >= 0 && i < f->p; i++)
        l.li_f[i] = find_multiple_or_add(l.left, &pn, f->a + i * N, N, &cl_f[i]);
    for (size_t i = 0; rc >= 0 && i < g->p; i++)
        l.li_g[i] = find_multiple_or_add(l.left, &pn, g->a + i * N, N, &cl_g[i]);
    for (size_t j = 0; rc >= 0 && j < f->q; j++)
        l.rj_f[j] = find_multiple_or_add(l.right, &qn, f->b + j * N, N, &cr_f[j]);
    for (size_t j = 0; rc >= 0 && j < g->q; j++)
        l.rj_g[j] = find_multiple_or_add(l.right, &qn, g->b + j * N, N, &cr_g[j]);
    /* K's only block is written by its first term, not cleared and added to; where each matrix
     * has one term and F holds K by column alone, G's comes first (the same sums: x + y = y + x) */
    int one = pn == 1 && qn == 1 && f->p * f->q + g->p * g->q > 0;
    int g_first = one && !f->k && f->p * f->q == 1 && g->p * g->q == 1;
    if (rc >= 0)
        rc = lr_from_lists(ctx, f->S, &l, pn, qn, f->d || g->d,
                           one ? BSTI_LR_K_FILLED : BSTI_LR_K_ZERO, out);
    if (rc >= 0) {
        bsti_lr *m = *out;
        int first = one;
        for (size_t x = 0; m->d && x < N; x++)
            m->d[x] = (f->d ? alpha * f->d[x] : 0.0) + (g->d ? beta * g->d[x] : 0.0);
        for (int t = 0; t < 2; t++) {
            const bsti_lr *h = (t == 0) != g_first ? f : g;
            const size_t *li = h == f ? l.li_f : l.li_g, *rj = h == f ? l.rj_f : l.rj_g;
            const double *cl = h == f ? cl_f : cl_g, *cr = h == f ? cr_f : cr_g;
            for (size_t i = 0; i < h->p; i++)
                for (size_t j = 0; j < h->q; j++, first = 0)
                    bsti_lr_block_put(m->k, pn * r, li[i], rj[j], h, i, j,
                                      (h == f ? alpha : beta) * cl[i] * cr[j], first);
        }
    }
    bsti_free(ctx, c);
    lists_free(ctx, &l);
    return rc;
}

void bsti_lr_scale_take(const double *dr, bsti_lr *f, const double *dc)
{
    size_t N = f->N;
    for (size_t x = 0; f->d && x < N; x++)
        f->d[x] = (dr ? dr[x] : 1.0) * f->d[x] * (dc ? dc[x] : 1.0);
    for (size_t i = 0; dr && i < f->p; i++)
        for (size_t x = 0; x < N; x++)
            f->a[i * N + x] = dr[x] * f->a[i * N + x];
    for (size_t j = 0; dc && j < f->q; j++)
        for (size_t x = 0; x < N; x++)
            f->b[j * N + x] = dc[x] * f->b[j * N + x];
}

int bsti_lr_scale(bst_ctx *ctx, const double *dr, const bsti_lr *f, const double *dc, bsti_lr **out)
{
    size_t N = f->N, r = f->r;
    int rc = bsti_lr_alloc(ctx, f->S, f->p, f->q, f->d != NULL, BSTI_LR_K_FILLED, out);
    if (rc < 0)
        return rc;
    bsti_lr *m = *out;
    if (f->d)
        memcpy(m->d, f->d, N * sizeof *m->d);
    memcpy(m->a, f->a, f->p * N * sizeof *m->a);
    memcpy(m->b, f->b, f->q * N * sizeof *m->b);
    memcpy(m->k, f->k, f->p * r * f->q * r * sizeof *m->k);
    bsti_lr_scale_take(dr, m, dc);
    return BST_OK;
}

/* y = F x (trans 0) or F^T x (trans 1) without forming F: the diagonal, then through S^T, K and S
 * for each pair of scalings; w holds (p + q) r values. */
void bsti_lr_apply(const bsti_lr *f, int trans, const double *x, double *y, double *w)
{
    size_t N = f->N, r = f->r, pr = f->p * r, qr = f->q * r;
    const bsti_lr_map *S = f->S;
    size_t nin = trans ? f->p : f->q, nout = trans ? f->q : f->p;
    const double *in = trans ? f->a : f->b, *outv = trans ? f->b : f->a;
    double *s = w, *t = w + (trans ? pr : qr);
    for (size_t x0 = 0; x0 < N; x0++)
        y[x0] = f->d ? f->d[x0] * x[x0] : 0.0;
    memset(s, 0, nin * r * sizeof *s);
    for (size_t j = 0; j < nin; j++) /* s_j = S^T (v_j .* x) */
        for (size_t x0 = 0; x0 < N; x0++)
            for (size_t e = S->start[x0]; e < S->start[x0 + 1]; e++)
                s[j * r + S->col[e]] += S->w[e] * in[j * N + x0] * x[x0];
    if (pr && qr)
        cblas_dgemv(CblasColMajor, trans ? CblasTrans : CblasNoTrans, (int)pr, (int)qr, 1.0, f->k,
                    (int)pr, s, 1, 0.0, t, 1);
    for (size_t i = 0; i < nout; i++) /* y += u_i .* S t_i */
        for (size_t x0 = 0; x0 < N; x0++)
            for (size_t e = S->start[x0]; e < S->start[x0 + 1]; e++)
                y[x0] += outv[i * N + x0] * S->w[e] * t[i * r + S->col[e]];
}

void bsti_lr_to_dense(const bsti_lr *f, double *out)
{
    size_t N = f->N, r = f->r, ld = f->p * r;
    const bsti_lr_map *S = f->S;
    memset(out, 0, N * N * sizeof *out);
    for (size_t x = 0; f->d && x < N; x++)
        out[x * N + x] = f->d[x];
    for (size_t i = 0; i < f->p; i++)
        for (size_t j = 0; j < f->q; j++) {
            const double *a = f->a + i * N, *b = f->b + j * N;
            for (size_t y = 0; y < N; y++)
                for (size_t ey = S->start[y]; ey < S->start[y + 1]; ey++) {
                    double wy = S->w[ey] * b[y];
                    const double *kc = f->k + (j * r + S->col[ey]) * ld + i * r;
                    for (size_t x = 0; x < N; x++)
                        for (size_t ex = S->start[x]; ex < S->start[x + 1]; ex++)
                            out[y * N + x] += a[x] * S->w[ex] * kc[S->col[ex]] * wy;
                }
        }
}

int bsti_lr_copy(bst_ctx *ctx, const bsti_lr *f, bsti_lr **out)
{
    return bsti_lr_scale(ctx, NULL, f, NULL, out);
}

int bsti_lr_transpose_take(bsti_lr *f)
{
    size_t n = f->p * f->r;
    if (f->p != f->q)
        return -1;
    double *t = f->a;
    f->a = f->b, f->b = t;
    bsti_transpose_square(f->k, n, BST_DOUBLE);
    bsti_free(f->S->ctx, f->ks);
    f->ks = NULL;
    return 0;
}

int bsti_lr_transpose(bst_ctx *ctx, const bsti_lr *f, bsti_lr **out)
{
    size_t N = f->N, pr = f->p * f->r, qr = f->q * f->r;
    int rc = bsti_lr_alloc(ctx, f->S, f->q, f->p, f->d != NULL, BSTI_LR_K_FILLED, out);
    if (rc < 0)
        return rc;
    bsti_lr *m = *out;
    if (f->d)
        memcpy(m->d, f->d, N * sizeof *m->d);
    memcpy(m->a, f->b, f->q * N * sizeof *m->a);
    memcpy(m->b, f->a, f->p * N * sizeof *m->b);
    for (size_t j0 = 0; j0 < qr; j0 += 32) /* by tiles that stay in the cache (K: up to 128 MB) */
        for (size_t i0 = 0; i0 < pr; i0 += 32)
            for (size_t j = j0; j < j0 + 32 && j < qr; j++)
                for (size_t i = i0; i < i0 + 32 && i < pr; i++)
                    m->k[i * qr + j] = f->k[j * pr + i];
    return BST_OK;
}

/* Every reader builds the value (x, y) in one order, so that all give the same bits (bsti_lr_get,
 * bsti_lr_col_fast, which mat_lowrank.c's column reader uses): the diagonal or 0 first and
 * then, pair (i, j) by pair, v += a_i[x] s b_j[y], with
 *   c_e = 0 + the sum over y's entries ey, in order, of K_ij[col_e, col_ey] w_ey  (for x's entry e)
 *   s   = 0 + the sum over x's entries e, in order, of w_e c_e.
 * Summed so, a column's c are one vector of r values for all its rows (bsti_lr_col_fast). */
double bsti_lr_get(const bsti_lr *f, size_t x, size_t y)
{
    const bsti_lr_map *S = f->S;
    size_t N = f->N, r = f->r, ld = f->p * r;
    double v = f->d && x == y ? f->d[x] : 0.0;
    for (size_t i = 0; i < f->p; i++)
        for (size_t j = 0; j < f->q; j++) {
            const double *kb = f->k + j * r * ld + i * r;
            double s = 0.0;
            for (size_t ex = S->start[x]; ex < S->start[x + 1]; ex++) {
                double c = 0.0;
                for (size_t ey = S->start[y]; ey < S->start[y + 1]; ey++)
                    c += kb[S->col[ey] * ld + S->col[ex]] * S->w[ey];
                s += S->w[ex] * c;
            }
            v += f->a[i * N + x] * s * f->b[j * N + y];
        }
    return v;
}

int bsti_lr_rows_new(bst_ctx *ctx, const bsti_lr *f, bsti_lr_rows **out)
{
    const bsti_lr_map *S = f->S;
    size_t N = f->N, nm = 0;
    *out = NULL;
    for (size_t x = 0; x < N; x++)
        nm += S->start[x + 1] - S->start[x] > 1;
    bsti_lr_rows *t = bsti_calloc(ctx, 1, sizeof *t);
    if (!t)
        return BST_ENOMEM;
    t->ctx = ctx;
    t->nmulti = nm;
    t->fw = bsti_alloc_array(ctx, N, sizeof *t->fw);
    t->s = bsti_alloc_array(ctx, N, sizeof *t->s);
    t->c = bsti_alloc_array(ctx, f->r, sizeof *t->c);
    t->fc = bsti_alloc_array(ctx, N + nm + 1, sizeof *t->fc);
    if (!t->fw || !t->s || !t->c || !t->fc) {
        bsti_lr_rows_free(t);
        return BST_ENOMEM;
    }
    t->multi = t->fc + N;
    nm = 0;
    for (size_t x = 0; x < N; x++) {
        size_t e = S->start[x], n = S->start[x + 1] - e;
        t->fw[x] = n ? S->w[e] : 0.0;
        t->fc[x] = n ? S->col[e] : 0;
        if (n > 1)
            t->multi[nm++] = x;
    }
    *out = t;
    return BST_OK;
}

void bsti_lr_rows_free(bsti_lr_rows *t)
{
    if (!t)
        return;
    bsti_free(t->ctx, t->fw), bsti_free(t->ctx, t->s), bsti_free(t->ctx, t->c);
    bsti_free(t->ctx, t->fc), bsti_free(t->ctx, t);
}

/* The column in passes that do not branch on a row's entries: every row's first entry (an empty
 * row's weight 0 on c_0: 0 + 0 c_0 = +0, as the empty sum; K's values are finite), then the
 * further entries of the rows that have them, in order, then the scalings. */
void bsti_lr_col_fast(const bsti_lr *f, bsti_lr_rows *t, size_t y, double *out)
{
    const bsti_lr_map *S = f->S;
    size_t N = f->N, r = f->r, ld = f->p * r;
    const double *fw = t->fw;
    const size_t *fc = t->fc;
    double *s = t->s, *c = t->c;
    for (size_t x = 0; x < N; x++)
        out[x] = 0.0;
    if (f->d)
        out[y] = f->d[y];
    for (size_t i = 0; i < f->p; i++)
        for (size_t j = 0; j < f->q; j++) {
            const double *a = f->a + i * N, *kb = f->k + j * r * ld + i * r;
            double by = f->b[j * N + y];
            for (size_t q = 0; q < r; q++)
                c[q] = 0.0;
            for (size_t ey = S->start[y]; ey < S->start[y + 1]; ey++) {
                const double *kc = kb + S->col[ey] * ld;
                double wy = S->w[ey];
                for (size_t q = 0; q < r; q++)
                    c[q] += kc[q] * wy;
            }
            for (size_t x = 0; x < N; x++)
                s[x] = 0.0 + fw[x] * c[fc[x]];
            for (size_t m = 0; m < t->nmulti; m++) {
                size_t x = t->multi[m];
                double v = s[x];
                for (size_t e = S->start[x] + 1; e < S->start[x + 1]; e++)
                    v += S->w[e] * c[S->col[e]];
                s[x] = v;
            }
            for (size_t x = 0; x < N; x++)
                out[x] += a[x] * s[x] * by;
        }
}

static int all_finite(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

int bsti_lr_finite(const bsti_lr *f)
{
    size_t N = f->N;
    return (!f->d || all_finite(f->d, N)) && all_finite(f->a, f->p * N) &&
           all_finite(f->b, f->q * N) && all_finite(f->k, f->p * f->r * f->q * f->r);
}

size_t bsti_lr_stored(const bsti_lr *f)
{
    return (f->d ? f->N : 0) + (f->p + f->q) * f->N + f->p * f->r * f->q * f->r;
}

/* m's diagonal and scaling vectors: F's, entry x from entry perm[x]. */
static void permute_vectors(const bsti_lr *f, const size_t *perm, bsti_lr *m)
{
    size_t N = f->N;
    for (size_t x = 0; x < N; x++) {
        if (m->d)
            m->d[x] = f->d[perm[x]];
        for (size_t i = 0; i < f->p; i++)
            m->a[i * N + x] = f->a[i * N + perm[x]];
        for (size_t j = 0; j < f->q; j++)
            m->b[j * N + x] = f->b[j * N + perm[x]];
    }
}

int bsti_lr_map_permuted(bst_ctx *ctx, const bsti_lr_map *S, const size_t *perm, bsti_lr_map **out)
{
    int rc = bsti_lr_map_new(ctx, S->N, S->r, S->start[S->N], out);
    if (rc < 0)
        return rc;
    bsti_lr_map *m = *out;
    size_t e = 0;
    for (size_t x = 0; x < S->N; x++) {
        m->start[x] = e;
        for (size_t f = S->start[perm[x]]; f < S->start[perm[x] + 1]; f++, e++)
            m->col[e] = S->col[f], m->w[e] = S->w[f];
    }
    m->start[S->N] = e;
    m->k = S->k;
    return BST_OK;
}

int bsti_lr_permute_over(bst_ctx *ctx, const bsti_lr *f, const size_t *perm, const bsti_lr_map *S2,
                         bsti_lr **out)
{
    int rc = bsti_lr_alloc(ctx, S2, f->p, f->q, f->d != NULL, BSTI_LR_K_FILLED, out);
    if (rc < 0)
        return rc;
    permute_vectors(f, perm, *out);
    memcpy((*out)->k, f->k, f->p * f->r * f->q * f->r * sizeof *f->k);
    return BST_OK;
}

int bsti_lr_permute(bst_ctx *ctx, const bsti_lr *f, const size_t *perm, bsti_lr **out)
{
    const bsti_lr_map *S = f->S;
    size_t N = f->N, r = f->r, pr = f->p * r;
    *out = NULL;
    size_t *cp = bsti_alloc_array(ctx, r + 1, sizeof *cp);
    if (!cp)
        return BST_ENOMEM;
    for (size_t c = 0; c < r; c++)
        cp[c] = (size_t)-1;
    int rc = BST_OK;
    for (size_t x = 0; x < N && rc >= 0; x++) { /* cp[c(x)] = c(perm x), the same for every x */
        size_t y = perm[x], ex = S->start[x], ey = S->start[y];
        if (S->start[x + 1] - ex != 1 || S->start[y + 1] - ey != 1 || S->w[ex] != S->w[ey] ||
            (cp[S->col[ex]] != (size_t)-1 && cp[S->col[ex]] != S->col[ey]))
            rc = BST_ENOTFOUND;
        else
            cp[S->col[ex]] = S->col[ey];
    }
    if (rc >= 0)
        rc = bsti_lr_alloc(ctx, S, f->p, f->q, f->d != NULL, BSTI_LR_K_ZERO, out);
    if (rc >= 0) {
        bsti_lr *m = *out;
        permute_vectors(f, perm, m);
        for (size_t j = 0; j < f->q; j++) /* K'_ij[u, v] = K_ij[cp u, cp v] */
            for (size_t v = 0; v < r; v++)
                for (size_t i = 0; i < f->p; i++)
                    for (size_t u = 0; u < r; u++)
                        m->k[(j * r + v) * pr + i * r + u] = f->k[(j * r + cp[v]) * pr + i * r + cp[u]];
    }
    bsti_free(ctx, cp);
    return rc;
}
