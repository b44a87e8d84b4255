/* fuzz_ttree.c - libFuzzer target: the tensor-tree text parser (ttree.c, internal API in ttree.h)
 * alone, without the XML around it, then lookups and, for shallow rank-4 trees, the expansion onto
 * a grid.
 *
 * Input: a first byte '3' for a rank-3 tree (any other byte: rank 4), then the ScatteringData text
 * ("4{ 1 2 ... }").  The text is fed in chunks whose sizes cycle through FEED_SIZES, so that tokens
 * straddle chunk boundaries as they do when libxml2 hands the reader its text piecewise. */
#include <config.h>

#include <math.h>

#include "fuzz.h"
#include "ttree.h"

/* Grids are expanded for trees of at most this depth (4^(4k) doubles: 512 kB at k = 4). */
#define FUZZ_EXPAND_MAX_DEPTH 4

static const size_t FEED_SIZES[] = {1, 7, 64, 2, 4096, 13};

static void exercise(const bsti_ttree *t)
{
    fuzz_require(t->nnodes >= 1, "a root node");
    fuzz_require(t->depth >= 0, "a depth");
    /* a lattice of points, the corners and points just below 1/2 and 1 included */
    static const double coord[] = {0.0, 0.2, 0.4999999, 0.5, 0.77, 0.9999999, 1.0};
    const size_t nc = sizeof coord / sizeof coord[0];
    size_t npoints = nc * nc * nc * (t->dim == 4 ? nc : 1);
    for (size_t i = 0; i < npoints; i++) {
        double p[4] = {coord[i % nc], coord[(i / nc) % nc], coord[(i / nc / nc) % nc],
                       coord[(i / nc / nc / nc) % nc]};
        double v = bsti_ttree_eval(t, p);
        fuzz_require(isfinite(v) && v >= 0.0, "a finite non-negative tree value");
    }
    if (t->dim == 4 && t->depth <= FUZZ_EXPAND_MAX_DEPTH) {
        for (int k = 0; k <= t->depth + 1 && k <= FUZZ_EXPAND_MAX_DEPTH; k++) {
            size_t g = (size_t)1 << k, n = g * g * g * g;
            double *m = malloc(n * sizeof *m);
            fuzz_require(m, "memory for the grid");
            fuzz_require(bsti_ttree_expand4(t, k, m) == BST_OK, "an expansion");
            for (size_t j = 0; j < n; j++)
                fuzz_require(isfinite(m[j]) && m[j] >= 0.0, "finite non-negative grid values");
            free(m);
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || size > FUZZ_MAX_INPUT)
        return 0;
    int dim = data[0] == '3' ? 3 : 4;
    const char *text = (const char *)data + 1;
    size_t len = size - 1;
    bst_ctx *ctx = bst_ctx_new();
    fuzz_require(ctx, "a context");
    bsti_tparse *p = NULL;
    int st = bsti_tparse_new(ctx, dim, &p);
    fuzz_require(st == BST_OK && p, "a parser");
    size_t at = 0;
    for (size_t i = 0; st >= 0 && at < len; i++) {
        size_t n = FEED_SIZES[i % (sizeof FEED_SIZES / sizeof FEED_SIZES[0])];
        if (n > len - at)
            n = len - at;
        st = bsti_tparse_feed(p, text + at, n);
        at += n;
    }
    bsti_ttree *t = NULL;
    if (st >= 0) {
        st = bsti_tparse_finish(p, &t); /* frees the parser */
        p = NULL;
    }
    if (st < 0) {
        fuzz_require_error(ctx, st);
        fuzz_require(!t, "no tree on failure");
    } else {
        fuzz_require(t, "a tree");
        exercise(t);
    }
    bsti_tparse_free(p);
    bsti_ttree_free(t);
    bst_ctx_free(ctx);
    return 0;
}
