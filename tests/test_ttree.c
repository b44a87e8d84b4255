/* test_ttree.c - rank-4 tensor trees: the streaming tokenizer and the expansion onto a grid
 * (ttree.c, ttree_expand.c) against independent computations.
 *
 * - Random trees (seeded: branches, leaves of level 0 to 2 at every depth, zeros, -0, negatives)
 *   parsed from their text fed whole and in chunks of 1, 2, 3, 5 and 64 characters: the same
 *   nodes and values, bit for bit; malformed tokens give the same message whatever the chunking.
 * - The dense expansion at every order against the plain definition written here (a cleared grid,
 *   each value added in the tree's order to every cell under it, weighted by 16^-levels), bit for
 *   bit, in double and float; where the order is at least the tree's depth every cell also equals
 *   the tree's lookup (bsti_ttree_eval) at the cell's centre.
 * - The reciprocal layout (M'[o + N i] = M[a(i) + N a(o)]), 1, 2 and 3 threads: identical bits.
 * - The census (non-zeros, diagonal only, the early stop) and the emitted cells against the dense
 *   expansion; bst_bsdf_to_layer's structure against bst_mat_compact of the same values.
 * - bsti_bsdf_to_layer on reference files with 1 and 2 threads: identical matrices. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf.h"
#include "ctx.h"
#include "mat.h"
#include "resample.h"
#include "testutil.h"
#include "ttree.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

/* ------------------------------------------------------------------ random trees as text */

struct text {
    char *s;
    size_t n, cap;
};

static void put(struct text *t, const char *s)
{
    size_t len = strlen(s);
    if (t->n + len + 1 > t->cap) {
        t->cap = 2 * (t->n + len + 1);
        t->s = realloc(t->s, t->cap);
        ck_assert_ptr_nonnull(t->s);
    }
    memcpy(t->s + t->n, s, len + 1);
    t->n += len;
}

static void value_text(tu_rng *r, char *buf)
{
    double u = tu_rng_uniform(r);
    if (u < 0.25)
        strcpy(buf, "0");
    else if (u < 0.30)
        strcpy(buf, "-0");
    else if (u < 0.35)
        snprintf(buf, 32, "%.3g", -tu_rng_uniform(r)); /* read as 0 */
    else if (u < 0.45)
        snprintf(buf, 32, "%.7e", 1e-30 * tu_rng_uniform(r));
    else
        snprintf(buf, 32, "%.9g", 100 * tu_rng_uniform(r));
}

/* A subtree at depth d of a tree at most D deep; leaves up to level 2, separators varied. */
static void gen(tu_rng *r, struct text *t, int d, int D)
{
    static const char *const seps[] = {" ", "\n", ",", "\t ", "\r\n  "};
    put(t, "{");
    double u = tu_rng_uniform(r);
    if (d < D && (d == 0 || u < 0.55)) {
        for (int c = 0; c < 16; c++) {
            put(t, seps[(int)(5 * tu_rng_uniform(r))]);
            gen(r, t, d + 1, D);
        }
    } else {
        int L = D - d >= 2 && tu_rng_uniform(r) < 0.1 ? 2 : D - d >= 1 && tu_rng_uniform(r) < 0.4 ? 1 : 0;
        for (int i = 0; i < 1 << (4 * L); i++) {
            char buf[32];
            value_text(r, buf);
            put(t, seps[(int)(5 * tu_rng_uniform(r))]);
            put(t, buf);
        }
        put(t, " ");
    }
    put(t, "}");
}

static bsti_ttree *parse(const char *s, size_t len, size_t chunk)
{
    bsti_tparse *p;
    bsti_ttree *t;
    ck_assert_int_eq(bsti_tparse_new(ctx, 4, &p), BST_OK);
    for (size_t i = 0; i < len; i += chunk)
        ck_assert_int_eq(bsti_tparse_feed(p, s + i, len - i < chunk ? len - i : chunk), BST_OK);
    ck_assert_int_eq(bsti_tparse_finish(p, &t), BST_OK);
    return t;
}

static bsti_ttree *random_tree(uint64_t seed, int D, struct text *txt)
{
    tu_rng r;
    tu_rng_seed(&r, seed);
    txt->n = 0;
    put(txt, "");
    gen(&r, txt, 0, D);
    return parse(txt->s, txt->n, txt->n);
}

/* ------------------------------------------------------------------ the definition */

/* Every value of the subtree of id (depth d, corner c) added to each grid cell under it, weighted
 * by 16^-(levels below k): the expansion as first written, cell by cell, on a cleared grid. */
static void plain(const bsti_ttree *t, uint32_t id, int d, const size_t c[4], int k, double *m)
{
    const struct bsti_tnode *n = &t->nodes[id];
    if (!n->leaf) {
        for (int ch = 0; ch < 16; ch++) {
            size_t cc[4];
            for (int i = 0; i < 4; i++)
                cc[i] = 2 * c[i] + (size_t)((ch >> i) & 1);
            plain(t, t->kids[n->first + (uint32_t)ch], d + 1, cc, k, m);
        }
        return;
    }
    size_t G = (size_t)1 << k, N = G * G, g = (size_t)1 << n->level;
    int lv = d + n->level;
    for (size_t q = 0; q < g * g * g * g; q++) {
        size_t a[4] = {q / (g * g * g), q / (g * g) % g, q / g % g, q % g}, lo[4], span;
        if (lv <= k) { /* replicated over 2^(k - lv) cells a side */
            span = (size_t)1 << (k - lv);
            for (int i = 0; i < 4; i++)
                lo[i] = (c[i] * g + a[i]) * span;
        } else {
            span = 1;
            for (int i = 0; i < 4; i++)
                lo[i] = (c[i] * g + a[i]) >> (lv - k);
        }
        double v = t->values[n->first + q] * (lv > k ? ldexp(1.0, -4 * (lv - k)) : 1.0);
        if (v == 0.0)
            continue;
        for (size_t x = lo[0]; x < lo[0] + span; x++)
            for (size_t y = lo[1]; y < lo[1] + span; y++)
                for (size_t u = lo[2]; u < lo[2] + span; u++)
                    for (size_t w = lo[3]; w < lo[3] + span; w++)
                        m[u * G + w + N * (x * G + y)] += v;
    }
}

static double *definition(const bsti_ttree *t, int k)
{
    size_t N = (size_t)1 << (2 * k);
    double *m = calloc(N * N, sizeof *m);
    ck_assert_ptr_nonnull(m);
    const size_t c[4] = {0, 0, 0, 0};
    plain(t, 0, 0, c, k, m);
    return m;
}

/* ------------------------------------------------------------------ tests */

static const char *const bad_tokens[] = {"{ 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 1.2.3 }",
                                         "{ 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 1e999 }",
                                         "{ 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 nan }",
                                         "{ 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 "
                                         "1234567890123456789012345678901234567890123456789012345678901234567 }",
                                         "5 { 1 }", "{ { 1 } 2 }"};

START_TEST(test_chunks)
{
    struct text txt = {0};
    bsti_ttree *whole = random_tree(1000 + (uint64_t)_i, 4, &txt);
    static const size_t chunks[] = {1, 2, 3, 5, 64};
    for (size_t j = 0; j < sizeof chunks / sizeof chunks[0]; j++) {
        bsti_ttree *t = parse(txt.s, txt.n, chunks[j]);
        ck_assert_uint_eq(t->nnodes, whole->nnodes);
        ck_assert_uint_eq(t->nkids, whole->nkids);
        ck_assert_uint_eq(t->nvalues, whole->nvalues);
        ck_assert_int_eq(t->depth, whole->depth);
        ck_assert_int_eq(t->negatives, whole->negatives);
        ck_assert(memcmp(t->nodes, whole->nodes, t->nnodes * sizeof *t->nodes) == 0);
        ck_assert(memcmp(t->kids, whole->kids, t->nkids * sizeof *t->kids) == 0);
        ck_assert(memcmp(t->values, whole->values, t->nvalues * sizeof *t->values) == 0);
        bsti_ttree_free(t);
    }
    ck_assert(whole->negatives > 0); /* the text had negatives, read as 0 */
    bsti_ttree_free(whole);
    free(txt.s);
}
END_TEST

START_TEST(test_bad_tokens)
{
    const char *s = bad_tokens[_i];
    size_t len = strlen(s);
    char first[BSTI_MSG_MAX] = "";
    static const size_t chunks[] = {1000, 1, 2, 7};
    for (size_t j = 0; j < sizeof chunks / sizeof chunks[0]; j++) {
        bsti_tparse *p;
        bsti_ttree *t = NULL;
        ck_assert_int_eq(bsti_tparse_new(ctx, 4, &p), BST_OK);
        int rc = BST_OK;
        for (size_t i = 0; i < len && rc >= 0; i += chunks[j])
            rc = bsti_tparse_feed(p, s + i, len - i < chunks[j] ? len - i : chunks[j]);
        if (rc >= 0)
            rc = bsti_tparse_finish(p, &t);
        else
            bsti_tparse_free(p);
        ck_assert_msg(rc == BST_EFORMAT, "'%s' in chunks of %zu: %d", s, chunks[j], rc);
        ck_assert_ptr_null(t);
        if (j == 0)
            snprintf(first, sizeof first, "%s", bst_ctx_message(ctx));
        else
            ck_assert_str_eq(bst_ctx_message(ctx), first);
    }
    ck_assert(strlen(first) > 0);
}
END_TEST

/* The dense expansion against the definition, every order 1..depth + 1, both precisions. */
START_TEST(test_fill_definition)
{
    struct text txt = {0};
    bsti_ttree *t = random_tree(2000 + (uint64_t)_i, 2 + _i % 3, &txt);
    for (int k = 1; k <= t->depth + 1 && k <= 5; k++) {
        size_t N = (size_t)1 << (2 * k), G = (size_t)1 << k;
        double *ref = definition(t, k), *m = malloc(N * N * sizeof *m);
        float *f = malloc(N * N * sizeof *f);
        ck_assert(m && f);
        memset(m, 0xa5, N * N * sizeof *m); /* every cell must be written */
        memset(f, 0xa5, N * N * sizeof *f);
        bsti_ttree_fill4(t, k, 0, BST_DOUBLE, m, 1);
        bsti_ttree_fill4(t, k, 0, BST_FLOAT, f, 1);
        for (size_t q = 0; q < N * N; q++) {
            ck_assert_msg(memcmp(&m[q], &ref[q], sizeof m[q]) == 0, "k %d cell %zu: %.17g vs %.17g", k,
                          q, m[q], ref[q]);
            float rf = (float)ref[q];
            ck_assert(memcmp(&f[q], &rf, sizeof rf) == 0);
        }
        if (k >= t->depth) /* no averaging: each cell is the tree's value at its centre */
            for (size_t i = 0; i < N; i++)
                for (size_t o = 0; o < N; o++) {
                    double p[4] = {(i / G + 0.5) / G, (i % G + 0.5) / G, (o / G + 0.5) / G, (o % G + 0.5) / G};
                    ck_assert(m[o + N * i] == bsti_ttree_eval(t, p));
                }
        else /* a mean of the finer cells: their sum over the cell, rounded differently */
            for (size_t i = 0; i < N; i++)
                for (size_t o = 0; o < N; o++) {
                    size_t s = (size_t)1 << (t->depth - k), Gd = G * s;
                    double sum = 0;
                    for (size_t a = 0; a < s; a++)
                        for (size_t b = 0; b < s; b++)
                            for (size_t e = 0; e < s; e++)
                                for (size_t h = 0; h < s; h++) {
                                    double p[4] = {((i / G) * s + a + 0.5) / Gd, ((i % G) * s + b + 0.5) / Gd,
                                                   ((o / G) * s + e + 0.5) / Gd, ((o % G) * s + h + 0.5) / Gd};
                                    sum += bsti_ttree_eval(t, p);
                                }
                    tu_assert_close(m[o + N * i], sum / (double)(s * s * s * s), 1e-13, 1e-30);
                }
        free(ref), free(m), free(f);
    }
    bsti_ttree_free(t);
    free(txt.s);
}
END_TEST

/* The reciprocal layout and the threads: the same bits however the work is shared.  Order 5 has
 * 16 slabs of columns; the random trees have leaves above the slabs' depth (clipped to them). */
START_TEST(test_fill_recip_threads)
{
    struct text txt = {0};
    bsti_ttree *t = random_tree(3000 + (uint64_t)_i, 4, &txt);
    for (int k = 3; k <= 5; k++) {
        size_t N = (size_t)1 << (2 * k);
        double *m1 = malloc(N * N * sizeof *m1), *m2 = malloc(N * N * sizeof *m2), *r = malloc(N * N * sizeof *r);
        ck_assert(m1 && m2 && r);
        bsti_ttree_fill4(t, k, 0, BST_DOUBLE, m1, 1);
        for (int th = 2; th <= 3; th++) {
            memset(m2, 0xa5, N * N * sizeof *m2);
            bsti_ttree_fill4(t, k, 0, BST_DOUBLE, m2, th);
            ck_assert(memcmp(m1, m2, N * N * sizeof *m1) == 0);
        }
        for (int th = 1; th <= 2; th++) {
            memset(r, 0xa5, N * N * sizeof *r);
            bsti_ttree_fill4(t, k, 1, BST_DOUBLE, r, th);
            for (size_t i = 0; i < N; i++)
                for (size_t o = 0; o < N; o++)
                    ck_assert(memcmp(&r[o + N * i], &m1[(N - 1 - i) + N * (N - 1 - o)], sizeof *r) == 0);
        }
        free(m1), free(m2), free(r);
    }
    bsti_ttree_free(t);
    free(txt.s);
}
END_TEST

struct emitted {
    const double *m;
    size_t N, count;
    int recip;
};

static void check_cell(void *opaque, size_t row, size_t col, double v)
{
    struct emitted *e = opaque;
    size_t N = e->N;
    double want = e->recip ? e->m[(N - 1 - col) + N * (N - 1 - row)] : e->m[row + N * col];
    ck_assert(v != 0.0 && memcmp(&v, &want, sizeof v) == 0);
    e->count++;
}

START_TEST(test_census_emit)
{
    struct text txt = {0};
    bsti_ttree *t = random_tree(4000 + (uint64_t)_i, 3, &txt);
    for (int k = 1; k <= 4; k++) {
        size_t N = (size_t)1 << (2 * k), nnz = 0, got;
        int diag = 1, got_diag;
        double *m = definition(t, k);
        for (size_t i = 0; i < N; i++)
            for (size_t o = 0; o < N; o++)
                if (m[o + N * i] != 0.0)
                    nnz++, diag &= o == i;
        bsti_ttree_census4(t, k, (size_t)-1, &got, &got_diag);
        ck_assert_uint_eq(got, nnz);
        ck_assert_int_eq(got_diag, diag);
        if (nnz > 1 && !diag) { /* stops early, past the limit */
            bsti_ttree_census4(t, k, nnz / 2, &got, &got_diag);
            ck_assert(got > nnz / 2 && got <= nnz && !got_diag);
        }
        for (int recip = 0; recip < 2; recip++) {
            struct emitted e = {.m = m, .N = N, .recip = recip};
            bsti_ttree_emit4(t, k, recip, check_cell, &e);
            ck_assert_uint_eq(e.count, nnz);
        }
        free(m);
    }
    bsti_ttree_free(t);
    free(txt.s);
}
END_TEST

/* A diagonal tree (specular glass) and an empty one take the diagonal and zero structures. */
START_TEST(test_census_diagonal)
{
    /* k = 1: a branch of 16 one-value leaves, non-zero where (ix, iy) = (ox, oy): children 0, 5,
       10, 15 (bits ix, iy, ox, oy) */
    char s[512] = "{";
    for (int c = 0; c < 16; c++)
        strcat(s, (c & 3) == (c >> 2) ? " { 0.5 }" : " { 0 }");
    strcat(s, " }");
    bsti_ttree *t = parse(s, strlen(s), 3);
    size_t nnz;
    int diag;
    bsti_ttree_census4(t, 1, (size_t)-1, &nnz, &diag);
    ck_assert_uint_eq(nnz, 4);
    ck_assert_int_eq(diag, 1);
    bsti_ttree_census4(t, 2, (size_t)-1, &nnz, &diag); /* replicated: 2 x 2 x 2 x 2 blocks */
    ck_assert_uint_eq(nnz, 64);
    ck_assert_int_eq(diag, 0);
    bsti_ttree_free(t);
    const char *zero = "{ 0 -0 -1 0 0 0 0 0 0 0 0 0 0 0 0 0 }";
    t = parse(zero, strlen(zero), 4);
    bsti_ttree_census4(t, 3, (size_t)-1, &nnz, &diag);
    ck_assert_uint_eq(nnz, 0);
    bsti_ttree_free(t);
}
END_TEST

static const char *const layer_files[] = {"L_blind0_t4k5.xml", "L_glass_t4k5.xml", "L_blind45_t4k5.xml",
                                          "S1_t4k5.xml"};

/* Reference files onto their own grid and a coarser one: 1 and 2 threads give the same matrices,
 * in the structure bst_mat_compact gives their values. */
START_TEST(test_to_layer_threads)
{
    bst_bsdf *b;
    bst_bsdf_read_opts ro = {.precision = _i >= 4 ? BST_FLOAT : BST_DOUBLE};
    ck_assert_int_ge(bst_bsdf_read(ctx, tu_ref(layer_files[_i % 4]), &ro, &b), 0);
    for (int k = 4; k <= 5; k++) {
        bst_basis *sc;
        bst_layer *l1, *l2;
        ck_assert_int_eq(bst_basis_new_sc(ctx, k, &sc), BST_OK);
        ck_assert_int_eq(bsti_bsdf_to_layer(ctx, b, sc, 1, &l1), BST_OK);
        ck_assert_int_eq(bsti_bsdf_to_layer(ctx, b, sc, 2, &l2), BST_OK);
        size_t n = bst_basis_size(sc);
        double *d1 = malloc(n * n * sizeof *d1), *d2 = malloc(n * n * sizeof *d2);
        ck_assert(d1 && d2);
        for (int c = 0; c < BST_NCOMP; c++) {
            const bst_mat *m1 = bst_layer_get(l1, 0, (bst_comp)c), *m2 = bst_layer_get(l2, 0, (bst_comp)c);
            ck_assert_int_eq(bst_mat_structure(m1), bst_mat_structure(m2));
            ck_assert_int_eq(bst_mat_precision(m1), bst_mat_precision(m2));
            ck_assert_int_eq(bst_mat_to_dense_array(ctx, m1, d1), BST_OK);
            ck_assert_int_eq(bst_mat_to_dense_array(ctx, m2, d2), BST_OK);
            ck_assert(memcmp(d1, d2, n * n * sizeof *d1) == 0);
            bst_mat *cm;
            ck_assert_int_eq(bst_mat_compact(ctx, m1, BST_SPARSE_MAX_FILL, &cm), BST_OK);
            ck_assert_int_eq(bst_mat_structure(cm), bst_mat_structure(m1));
            bst_mat_free(cm);
        }
        free(d1), free(d2);
        bst_layer_free(l1), bst_layer_free(l2), bst_basis_free(sc);
    }
    bst_bsdf_free(b);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("ttree");
    TCase *tc = tcase_create("core");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_loop_test(tc, test_chunks, 0, 6);
    tcase_add_loop_test(tc, test_bad_tokens, 0, sizeof bad_tokens / sizeof bad_tokens[0]);
    tcase_add_loop_test(tc, test_fill_definition, 0, 6);
    tcase_add_loop_test(tc, test_fill_recip_threads, 0, 3);
    tcase_add_loop_test(tc, test_census_emit, 0, 6);
    tcase_add_test(tc, test_census_diagonal);
    tcase_add_loop_test(tc, test_to_layer_threads, 0, 8);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return tu_run(suite()); }
