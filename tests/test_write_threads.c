/* test_write_threads.c - the tensor-tree writer on threads (bst_ctx_set_threads): the text is the
 * same bytes and the reported errors the same numbers with 1, 2, 3 and 8 threads, for rank 4 and
 * rank 3, double, float and function access, lossless and reduced, a variable-resolution style
 * tensor (fine incident cells) and whole XML files (rank 4 and rank 3); the lossless text equals
 * an independent emitter's (a plain recursive scan written here) and its errors are those
 * recomputed cell by cell; allocation failures end in BST_ENOMEM without leaks. */
#include <config.h>

#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bsdfstack.h"
#include "ctx.h"
#include "numtext.h"
#include "sink.h"
#include "testutil.h"
#include "ttree.h"
#include "ttree_write.h"

static const int thread_counts[] = {1, 2, 3, 8};
#define NCOUNTS (sizeof thread_counts / sizeof thread_counts[0])

/* The tree text of t written with `threads` threads (the caller frees it). */
static char *tree_text_bounded(const bsti_tensor *t, double pct, const double *col,
                               const double *row, int threads, bsti_tree_stats *st)
{
    bst_ctx *ctx = bst_ctx_new();
    ck_assert_int_eq(bst_ctx_set_threads(ctx, threads), BST_OK);
    tu_membuf m = {0};
    bsti_sink *s = malloc(sizeof *s);
    bsti_sink_init(s, tu_mem_write, &m);
    bsti_reduce r = {pct, BST_REDUCE_FLOOR, 0, col, row, 0, row != NULL};
    int rc = bsti_ttree_write(ctx, t, &r, s, st);
    ck_assert_msg(rc == BST_OK, "tree write: %s", bst_ctx_message(ctx));
    ck_assert_int_eq(bsti_sink_flush(s), 0);
    ck_assert_uint_eq(st->bytes, m.n);
    free(s);
    bst_ctx_free(ctx);
    return m.p;
}

static char *tree_text(const bsti_tensor *t, double pct, int threads, bsti_tree_stats *st)
{
    return tree_text_bounded(t, pct, NULL, NULL, threads, st);
}

/* ------------------------------------------------------------------ an independent emitter */

struct ref {
    const double *t;
    int D;
    size_t G, half;
    tu_membuf out;
    int force;
    size_t values, leaves;
    double sa, se, me, *hemi;
};

static double ref_cell(const struct ref *r, const size_t *c)
{
    size_t G = r->G;
    if (r->D == 4)
        return r->t[((c[0] * G + c[1]) * G + c[2]) * G + c[3]];
    return c[0] >= r->half ? 0.0 : r->t[(c[0] * G + c[1]) * G + c[2]];
}

static double clamp0(double v) { return v < 0 ? 0 : v; }

/* Is the node of level l at corner c constant (after clamping)?  *v its value. */
static int ref_constant(const struct ref *r, int l, const size_t *c, double *v)
{
    size_t s = (size_t)1 << l, n = (size_t)1 << (r->D * l);
    for (size_t q = 0; q < n; q++) {
        size_t cc[4] = {0, 0, 0, 0}, x = q;
        for (int i = 0; i < r->D; i++, x /= s)
            cc[i] = c[i] + x % s;
        double u = clamp0(ref_cell(r, cc));
        if (q == 0)
            *v = u;
        else if (u != *v)
            return 0;
    }
    return 1;
}

static void ref_put(struct ref *r, const char *text)
{
    tu_mem_write(text, strlen(text), &r->out);
}

static void ref_value(struct ref *r, double v)
{
    char buf[32];
    float back;
    bsti_format_float(clamp0(v), 0, buf, &back);
    ref_put(r, buf);
}

static void ref_emit(struct ref *r, int l, const size_t *c, int depth, int on_path)
{
    char ind[32];
    double v;
    memset(ind, ' ', (size_t)depth);
    ind[depth] = '\0';
    ref_put(r, ind);
    if (ref_constant(r, l, c, &v) && !(r->force && on_path)) {
        ref_put(r, "{ ");
        ref_value(r, v);
        ref_put(r, " }\n");
        r->leaves++, r->values++;
        return;
    }
    if (l == 1) {
        ref_put(r, "{");
        for (int j = 0; j < (1 << r->D); j++) {
            size_t cc[4] = {0, 0, 0, 0};
            for (int i = 0; i < r->D; i++)
                cc[i] = c[i] + (size_t)((j >> (r->D - 1 - i)) & 1); /* dimension 0 slowest */
            ref_put(r, " ");
            ref_value(r, ref_cell(r, cc));
        }
        ref_put(r, " }\n");
        r->leaves++, r->values += (size_t)1 << r->D;
        return;
    }
    ref_put(r, "{\n");
    for (int j = 0; j < (1 << r->D); j++) {
        size_t cc[4] = {0, 0, 0, 0};
        for (int i = 0; i < r->D; i++)
            cc[i] = c[i] + ((size_t)((j >> i) & 1) << (l - 1)); /* dimension 0 lowest bit */
        ref_emit(r, l - 1, cc, depth + 1, on_path && j == 0);
    }
    ref_put(r, ind);
    ref_put(r, "}\n");
}

/* The lossless tree of t (rank D, order k) and its errors, cell by cell: a lossless tree writes
 * every cell as the float nearest its value (negative ones as 0). */
static void ref_tree(struct ref *r, const double *t, int D, int k)
{
    memset(r, 0, sizeof *r);
    r->t = t, r->D = D, r->G = (size_t)1 << k, r->half = r->G / 2;
    size_t nblocks = (size_t)1 << (D * (k - 1)), S = r->G / 2;
    r->force = 1;
    for (size_t b = 0; b < nblocks && r->force; b++) {
        size_t c[4] = {0, 0, 0, 0}, x = b;
        for (int i = D - 1; i >= 0; i--, x /= S)
            c[i] = 2 * (x % S);
        double v;
        r->force = ref_constant(r, 1, c, &v);
    }
    size_t zero[4] = {0, 0, 0, 0}, n = (size_t)1 << (D * k), nin = D == 4 ? r->G * r->G : r->half;
    ref_emit(r, k, zero, 0, 1);
    r->hemi = calloc(nin, sizeof *r->hemi);
    for (size_t q = 0; q < n; q++) {
        size_t c0 = D == 4 ? q >> (3 * k) : q >> (2 * k), c1 = (q >> (2 * k)) & (r->G - 1);
        if (D == 3 && c0 >= r->half)
            continue;
        double v = t[q], e = v - (double)(float)clamp0(v);
        r->sa += fabs(v), r->se += fabs(e), r->me = fmax(r->me, fabs(e));
        r->hemi[D == 4 ? c0 * r->G + c1 : c0] += e;
    }
    double worst = 0;
    for (size_t i = 0; i < nin; i++)
        worst = fmax(worst, fabs(r->hemi[i]));
    r->hemi[0] = worst * M_PI / (double)(r->G * r->G);
}

/* ------------------------------------------------------------------ tensors */

/* Zero, constant (non-zero) and noisy regions, a few negative cells among the noise; rank 3 holds
 * (G/2) G G values. */
static void fill(tu_rng *r, int rank, int k, double *t, size_t n)
{
    size_t G = (size_t)1 << k;
    double c = 0.5 + tu_rng_uniform(r);
    for (size_t q = 0; q < n; q++) {
        size_t c0 = rank == 4 ? q / (G * G * G) : q / (G * G), c1 = rank == 4 ? q / (G * G) % G : q / G % G;
        double u = tu_rng_uniform(r);
        if (c0 < G / 8 || (c0 < G / 4 && c1 < G / 2))
            t[q] = 0.0;                 /* large zero regions */
        else if (c0 < G / 4)
            t[q] = c;                   /* a large constant region */
        else if (c0 < 3 * G / 8 && (q / 16) % 3 == 0)
            t[q] = 2 * c;               /* constant runs */
        else
            t[q] = u < 0.1 ? 0.0 : u < 0.12 ? -1e-3 * u : exp(6 * u - 3); /* noise, 4 decades */
    }
}

static double get_double(const void *opaque, size_t index)
{
    return ((const double *)opaque)[index];
}

static double get_float(const void *opaque, size_t index)
{
    return (double)((const float *)opaque)[index];
}

static void assert_same_stats(const bsti_tree_stats *a, const bsti_tree_stats *b)
{
    ck_assert_uint_eq(a->values, b->values);
    ck_assert_uint_eq(a->leaves, b->leaves);
    ck_assert_uint_eq(a->blocks_kept, b->blocks_kept);
    ck_assert_uint_eq(a->blocks, b->blocks);
    ck_assert(a->bytes == b->bytes);
    ck_assert_int_eq(a->negatives, b->negatives);
    ck_assert(a->threshold == b->threshold);
    ck_assert(a->l1_error == b->l1_error);
    ck_assert(a->max_error == b->max_error);
    ck_assert(a->hemi_error == b->hemi_error);
}

/* Every access (double, float, function), lossless and two percentiles: the same text and
 * numbers with every thread count; lossless, the independent emitter's text and errors; direct
 * access (whose finest blocks are measured four at a time in vectors, ttree_measure.c) the text
 * and numbers of a function's (one block at a time) over the same doubles or floats. */
START_TEST(test_tree_threads)
{
    tu_rng r;
    tu_rng_seed(&r, 41 + (uint64_t)_i);
    int rank = _i < 6 ? 4 : 3, k = rank == 4 ? _i % 6 : 1 + _i % 6;
    if (rank == 4 && k == 0)
        k = 5;
    size_t G = (size_t)1 << k, n = rank == 4 ? G * G * G * G : G * G * G / 2;
    double *t = malloc(n * sizeof *t);
    float *f = malloc(n * sizeof *f);
    ck_assert(t && f);
    fill(&r, rank, k, t, n);
    for (size_t q = 0; q < n; q++)
        f[q] = (float)t[q];
    bsti_tensor access[4] = {{rank, k, t, NULL, NULL, NULL, 0, NULL},
                             {rank, k, NULL, f, NULL, NULL, 0, NULL},
                             {rank, k, NULL, NULL, get_double, t, 0, NULL},
                             {rank, k, NULL, NULL, get_float, f, 0, NULL}};
    static const double pcts[] = {-1, 50, 90};
    struct ref ref;
    ref_tree(&ref, t, rank, k);
    for (int a = 0; a < 3; a++)
        for (int p = 0; p < 3; p++) {
            bsti_tree_stats s1, sn;
            char *one = tree_text(&access[a], pcts[p], 1, &s1);
            if (pcts[p] < 0) {
                ck_assert_msg(strcmp(one, ref.out.p) == 0, "rank %d k %d access %d: text differs "
                              "from the independent emitter's", rank, k, a);
                ck_assert_uint_eq(s1.values, ref.values);
                ck_assert_uint_eq(s1.leaves, ref.leaves);
                if (a != 1) { /* (float access: the values are the floats, no error) */
                    tu_assert_close(s1.l1_error, ref.se / ref.sa, 1e-9, 1e-15);
                    ck_assert(s1.max_error == ref.me);
                    tu_assert_close(s1.hemi_error, ref.hemi[0], 1e-9, 1e-15);
                }
                if (n >= 4096)
                    ck_assert_int_gt(s1.negatives, 0);
            }
            if (a < 2 && rank == 4 && k >= 4) { /* the same values through a function (tasks of
                                                     16^4 cells: the blocks streamed) */
                char *through = tree_text(&access[a + 2], pcts[p], 1, &sn);
                ck_assert_msg(strcmp(one, through) == 0, "rank %d k %d access %d pct %g: text "
                              "differs from a function's", rank, k, a, pcts[p]);
                assert_same_stats(&s1, &sn);
                free(through);
            }
            for (size_t c = 1; c < NCOUNTS; c++) {
                char *many = tree_text(&access[a], pcts[p], thread_counts[c], &sn);
                ck_assert_msg(strcmp(one, many) == 0, "rank %d k %d access %d pct %g: %d threads "
                              "write other text", rank, k, a, pcts[p], thread_counts[c]);
                assert_same_stats(&s1, &sn);
                free(many);
            }
            free(one);
        }
    free(ref.out.p), free(ref.hemi);
    free(t), free(f);
}
END_TEST

/* A smooth tensor (every node's measure from its children's means as much as from their own
 * measures): direct access, its finest blocks measured four at a time, writes the text of a
 * function's, doubles and floats, reduced at two percentiles. */
START_TEST(test_smooth_direct)
{
    int k = 4; /* (tasks of 16^4 cells: the blocks streamed) */
    size_t G = (size_t)1 << k, n = G * G * G * G;
    double *t = malloc(n * sizeof *t);
    float *f = malloc(n * sizeof *f);
    ck_assert(t && f);
    for (size_t q = 0; q < n; q++) {
        double x[4];
        for (int i = 0; i < 4; i++)
            x[i] = (double)((q >> (k * (3 - i))) & (G - 1)) / (double)G;
        t[q] = exp(2.0 * sin(3.0 * x[0] + x[1]) * cos(2.0 * x[2] - x[3]) + 4.0 * x[3] * x[3]);
        f[q] = (float)t[q];
    }
    bsti_tensor access[4] = {{4, k, t, NULL, NULL, NULL, 0, NULL},
                             {4, k, NULL, NULL, get_double, t, 0, NULL},
                             {4, k, NULL, f, NULL, NULL, 0, NULL},
                             {4, k, NULL, NULL, get_float, f, 0, NULL}};
    static const double pcts[] = {50, 90};
    for (int a = 0; a < 4; a += 2)
        for (int p = 0; p < 2; p++) {
            bsti_tree_stats s1, s2;
            char *direct = tree_text(&access[a], pcts[p], 2, &s1);
            char *through = tree_text(&access[a + 1], pcts[p], 2, &s2);
            ck_assert_msg(strcmp(direct, through) == 0, "k %d access %d pct %g: direct access "
                          "writes other text than a function", k, a, pcts[p]);
            assert_same_stats(&s1, &s2);
            ck_assert_uint_gt(s1.values, 0);
            free(direct), free(through);
        }
    free(t), free(f);
}
END_TEST

/* A value that is not finite in single precision (a double above FLT_MAX, an infinity, a NaN)
 * among the vectors' blocks: the error names the value of the least finest block holding one,
 * through direct access as through a function, doubles and floats. */
START_TEST(test_bad_values)
{
    tu_rng r;
    tu_rng_seed(&r, 77);
    int k = 4;
    size_t G = (size_t)1 << k, n = G * G * G * G;
    double *t = malloc(n * sizeof *t);
    float *f = malloc(n * sizeof *f);
    ck_assert(t && f);
    fill(&r, 4, k, t, n);
    size_t late = n - 3 * G - 5, early = n / 2 + 2 * G + 7; /* finest blocks in index order */
    t[late] = NAN;
    t[early] = _i ? INFINITY : 1e39;
    for (size_t q = 0; q < n; q++)
        f[q] = (float)t[q];
    bsti_tensor access[4] = {{4, k, t, NULL, NULL, NULL, 0, NULL},
                             {4, k, NULL, NULL, get_double, t, 0, NULL},
                             {4, k, NULL, f, NULL, NULL, 0, NULL},
                             {4, k, NULL, NULL, get_float, f, 0, NULL}};
    for (int a = 0; a < 4; a++) {
        bst_ctx *ctx = bst_ctx_new();
        tu_membuf m = {0};
        bsti_sink *s = malloc(sizeof *s);
        bsti_sink_init(s, tu_mem_write, &m);
        bsti_reduce red = {90, BST_REDUCE_FLOOR, 0, NULL, NULL, 0, 0};
        bsti_tree_stats st;
        ck_assert_int_eq(bsti_ttree_write(ctx, &access[a], &red, s, &st), BST_EINVAL);
        const char *want = a < 2 && !_i ? "value 1e+39 is" : "value inf is";
        ck_assert_msg(strstr(bst_ctx_message(ctx), want), "access %d: %s", a,
                      bst_ctx_message(ctx));
        free(s), free(m.p);
        bst_ctx_free(ctx);
    }
    free(t), free(f);
}
END_TEST

/* Budgets (columns, and rows too): the checks of nodes above the threads' subtrees, made on all
 * threads before the text (ttree_write.c, precheck), give one thread's text.  A smooth tensor whose
 * large nodes are candidates, some within their budgets and some not (budgets generous for the first
 * half of the incident cells, tiny for the rest), beside noise.  _i: rows, k. */
START_TEST(test_bound_threads)
{
    int rows = _i & 1, k = 5 + (_i >> 1);
    size_t G = (size_t)1 << k, n = G * G * G * G;
    tu_rng r;
    tu_rng_seed(&r, 77 + (uint64_t)_i);
    double *t = malloc(n * sizeof *t), *col = malloc(G * G * sizeof *col);
    double *row = malloc(G * G * sizeof *row);
    for (size_t q = 0; q < n; q++) {
        size_t c0 = q / (G * G * G), c2 = q / G % G;
        double u = tu_rng_uniform(&r);
        t[q] = c0 < 3 * G / 4 ? 1.0 + 1e-4 * (double)((q ^ (q >> 7)) % 13) + 0.01 * (double)c2 / (double)G
                              : exp(6 * u - 3);
    }
    for (size_t i = 0; i < G * G; i++)
        col[i] = row[i] = i < G * G / 2 ? 1e-2 : 1e-9;
    bsti_tensor access = {4, k, t, NULL, NULL, NULL, 0, NULL};
    bsti_tree_stats s1, sn;
    char *one = tree_text_bounded(&access, 90, col, rows ? row : NULL, 1, &s1);
    for (size_t c = 1; c < NCOUNTS; c++) {
        char *many = tree_text_bounded(&access, 90, col, rows ? row : NULL, thread_counts[c], &sn);
        ck_assert_msg(strcmp(one, many) == 0, "k %d rows %d: %d threads write other text", k, rows,
                      thread_counts[c]);
        assert_same_stats(&s1, &sn);
        free(many);
    }
    ck_assert_uint_lt(s1.leaves, n / 16); /* large nodes merged */
    /* the error statistics against the tree read back (the leaves above the threads' subtrees
       have theirs summed apart: precheck) */
    bst_ctx *ctx = bst_ctx_new();
    bsti_tparse *p;
    bsti_ttree *tree;
    ck_assert_int_eq(bsti_tparse_new(ctx, 4, &p), BST_OK);
    ck_assert_int_eq(bsti_tparse_feed(p, one, strlen(one)), BST_OK);
    ck_assert_int_eq(bsti_tparse_finish(p, &tree), BST_OK);
    double *back = malloc(n * sizeof *back), *re = calloc(G * G, sizeof *re);
    double sa = 0, se = 0, me = 0, worst = 0, rworst = 0;
    ck_assert_int_eq(bsti_ttree_expand4(tree, k, back), BST_OK);
    for (size_t i = 0; i < G * G; i++) {
        double h = 0;
        for (size_t o = 0; o < G * G; o++) {
            double v = t[i * G * G + o], e = v - back[i * G * G + o];
            sa += fabs(v), se += fabs(e), me = fmax(me, fabs(e)), h += e, re[o] += e;
        }
        worst = fmax(worst, fabs(h));
    }
    for (size_t o = 0; o < G * G; o++)
        rworst = fmax(rworst, fabs(re[o]));
    tu_assert_close(s1.l1_error, se / sa, 1e-9, 1e-15);
    ck_assert(s1.max_error == me);
    tu_assert_close(s1.hemi_error, worst * M_PI / (double)(G * G), 1e-9, 1e-15);
    if (rows)
        tu_assert_close(s1.row_error, rworst * M_PI / (double)(G * G), 1e-9, 1e-15);
    bsti_ttree_free(tree), bst_ctx_free(ctx), free(back), free(re);
    free(one), free(t), free(col), free(row);
}
END_TEST

/* A variable-resolution tree (function access, the percentile over the blocks touching the fine
 * incident cells) and a diagonal one: the same with every thread count. */
START_TEST(test_fine_in_and_diagonal)
{
    tu_rng r;
    tu_rng_seed(&r, 7);
    const int k = 5;
    const size_t G = 32, N = G * G, n = N * N;
    double *t = malloc(n * sizeof *t), *dg = calloc(n, sizeof *dg);
    unsigned char *in = calloc(N, 1);
    ck_assert(t && dg && in);
    fill(&r, 4, k, t, n);
    for (size_t i = 0; i < N; i++) {
        in[i] = tu_rng_uniform(&r) < 0.1;
        double u = tu_rng_uniform(&r);
        dg[i * N + i] = u < 0.3 ? 0.0 : u < 0.5 ? 3.5 : 100 * u;
    }
    bsti_tensor fine = {4, k, NULL, NULL, get_double, t, 0, in};
    bsti_tensor diag = {4, k, dg, NULL, NULL, NULL, 1, NULL};
    for (int p = 0; p < 2; p++)
        for (int which = 0; which < 2; which++) {
            bsti_tree_stats s1, sn;
            const bsti_tensor *x = which ? &diag : &fine;
            char *one = tree_text(x, p ? 90 : -1, 1, &s1);
            for (size_t c = 1; c < NCOUNTS; c++) {
                char *many = tree_text(x, p ? 90 : -1, thread_counts[c], &sn);
                ck_assert_str_eq(one, many);
                assert_same_stats(&s1, &sn);
                free(many);
            }
            free(one);
        }
    free(t), free(dg), free(in);
}
END_TEST

/* Whole files: a blind (TensorTree4) and a diffuser (TensorTree3, forced) at k = 4, reduced and not, the
 * same bytes with every thread count. */
START_TEST(test_xml_threads)
{
    static const char *const layers[] = {"L_blind0_t4k5.xml", "L_diffuser_t3k5.xml"};
    bst_ctx *ctx = bst_ctx_new();
    bst_basis *b = NULL;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &b), BST_OK);
    bst_layer *l = tu_layer(ctx, layers[_i], b);
    for (int p = 0; p < 2; p++) {
        bst_bsdf_write_opts o;
        bst_bsdf_write_opts_init(&o);
        o.date = "2000-01-01T00:00:00Z";
        o.reduce_pct = p ? BST_REDUCE_PCT : -1.0;
        o.rank = _i ? BST_RANK_3 : BST_RANK_4;
        tu_membuf one = {0};
        ck_assert_int_eq(bst_ctx_set_threads(ctx, 1), BST_OK);
        ck_assert_msg(bst_bsdf_write_fn(ctx, l, tu_mem_write, &one, &o) >= 0, "%s", bst_ctx_message(ctx));
        ck_assert_ptr_nonnull(strstr(one.p, _i ? "TensorTree3" : "TensorTree4"));
        for (size_t c = 1; c < NCOUNTS; c++) {
            tu_membuf many = {0};
            ck_assert_int_eq(bst_ctx_set_threads(ctx, thread_counts[c]), BST_OK);
            ck_assert_int_eq(bst_ctx_threads(ctx), thread_counts[c]);
            ck_assert(bst_bsdf_write_fn(ctx, l, tu_mem_write, &many, &o) >= 0);
            ck_assert_uint_eq(one.n, many.n);
            ck_assert_msg(memcmp(one.p, many.p, one.n) == 0, "%s: %d threads write other bytes",
                          layers[_i], thread_counts[c]);
            free(many.p);
        }
        free(one.p);
    }
    bst_layer_free(l);
    bst_basis_free(b);
    bst_ctx_free(ctx);
}
END_TEST

/* The setting: negative counts refused; a custom allocator keeps the work on one thread; the
 * workers never exceed the parts or BST_THREADS_MAX. */
START_TEST(test_setting)
{
    bst_ctx *ctx = bst_ctx_new();
    ck_assert_int_eq(bst_ctx_threads(ctx), 0);
    ck_assert_int_eq(bst_ctx_set_threads(ctx, -1), BST_EINVAL);
    ck_assert_int_eq(bst_ctx_set_threads(NULL, 2), BST_EINVAL);
    ck_assert_int_eq(bst_ctx_set_threads(ctx, 100), BST_OK);
    ck_assert_int_eq(bsti_ctx_workers(ctx, 1000), BST_THREADS_MAX);
    ck_assert_int_eq(bsti_ctx_workers(ctx, 3), 3);
    ck_assert_int_eq(bsti_ctx_workers(ctx, 1), 1);
    ck_assert_int_eq(bst_ctx_set_threads(ctx, 1), BST_OK);
    ck_assert_int_eq(bsti_ctx_workers(ctx, 1000), 1);
    ck_assert_int_eq(bst_ctx_set_threads(ctx, 0), BST_OK);
    ck_assert_int_ge(bsti_ctx_workers(ctx, 1000), 1);
    tu_alloc a = {0};
    ck_assert_int_eq(bst_ctx_set_threads(ctx, 4), BST_OK);
    ck_assert_int_eq(bst_ctx_set_allocator(ctx, tu_alloc_malloc, tu_alloc_free, &a), BST_OK);
    ck_assert_int_eq(bsti_ctx_workers(ctx, 1000), 1);
    bst_ctx_free(ctx);
}
END_TEST

/* Every allocation of a tree write failing in turn: BST_ENOMEM, nothing left allocated; then the
 * text of the unhindered write. */
START_TEST(test_alloc_failure)
{
    tu_rng r;
    tu_rng_seed(&r, 3);
    const int k = 4;
    const size_t n = 65536;
    double *t = malloc(n * sizeof *t);
    fill(&r, 4, k, t, n);
    bsti_tensor x = {4, k, t, NULL, NULL, NULL, 0, NULL};
    bsti_tree_stats st;
    char *want = tree_text(&x, 90, 1, &st);
    for (long fail = 1;; fail++) {
        tu_alloc a = {fail, 0, 0};
        bst_ctx *ctx = bst_ctx_new();
        ck_assert_int_eq(bst_ctx_set_allocator(ctx, tu_alloc_malloc, tu_alloc_free, &a), BST_OK);
        tu_membuf m = {0};
        bsti_sink s;
        bsti_sink_init(&s, tu_mem_write, &m);
        bsti_reduce red = {90, BST_REDUCE_FLOOR, 0, NULL, NULL, 0, 0};
        int rc = bsti_ttree_write(ctx, &x, &red, &s, &st);
        ck_assert_int_eq(a.live, 0);
        if (a.count < fail) { /* no allocation failed: done */
            ck_assert_int_eq(rc, BST_OK);
            bsti_sink_flush(&s);
            ck_assert_str_eq(m.p, want);
            free(m.p);
            bst_ctx_free(ctx);
            break;
        }
        ck_assert_int_eq(rc, BST_ENOMEM);
        ck_assert_int_eq(bst_ctx_status(ctx), BST_ENOMEM);
        free(m.p);
        bst_ctx_free(ctx);
    }
    free(want), free(t);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("write_threads");
    TCase *tc = tcase_create("core");
    tcase_set_timeout(tc, 120);
    tcase_add_loop_test(tc, test_bound_threads, 0, 4);
    tcase_add_loop_test(tc, test_bad_values, 0, 2);
    tcase_add_test(tc, test_smooth_direct);
    tcase_add_loop_test(tc, test_tree_threads, 0, 12);
    tcase_add_test(tc, test_fine_in_and_diagonal);
    tcase_add_loop_test(tc, test_xml_threads, 0, 2);
    tcase_add_test(tc, test_setting);
    tcase_add_test(tc, test_alloc_failure);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(suite());
}
