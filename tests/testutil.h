/* testutil.h - helpers shared by the Check suites: NaN-aware relative comparisons, a seeded random
 * generator, the reference-data directory, and an allocator that fails on demand. */
#ifndef BST_TESTUTIL_H
#define BST_TESTUTIL_H

#include <check.h>
#include <stddef.h>
#include <stdint.h>
#include "bsdfstack.h"

/* |a - b| <= rtol * max(|a|, |b|, scale): relative, with an absolute floor rtol * scale for
 * values near zero.  NaN never compares equal. */
int tu_close(double a, double b, double rtol, double scale);
#define tu_assert_close(a, b, rtol, scale)                                                        \
    do {                                                                                         \
        double tu_a_ = (a), tu_b_ = (b);                                                         \
        ck_assert_msg(tu_close(tu_a_, tu_b_, (rtol), (scale)),                                   \
                      "%s = %.17g vs %s = %.17g (rtol %g, scale %g)", #a, tu_a_, #b, tu_b_,      \
                      (double)(rtol), (double)(scale));                                          \
    } while (0)

/* Deterministic generator (xorshift64*): same sequence on every machine for a given seed. */
typedef struct { uint64_t s; } tu_rng;
void tu_rng_seed(tu_rng *r, uint64_t seed);
double tu_rng_uniform(tu_rng *r); /* [0, 1) */

/* Path of a file in the reference folder ($BST_REFDIR); the returned buffer is static. */
const char *tu_ref(const char *name);
/* Decompress the xz-compressed reference file `name` into a new temporary file whose path is
 * written to path (size >= 32); the caller unlinks it.  Fails the test if xz fails. */
void tu_unxz_ref(const char *name, char *path, size_t size);
/* Path of a file in the source tree ($BST_SRCDIR, default "."); static buffer. */
const char *tu_src(const char *name);
/* A layer over basis b (channel Visible for panes): "glass:SPEC" from the catalogue
 * ($BSDFSTACK_GLASS_DIR), else a reference file (tu_ref) resampled to b.  Fails the test on error. */
bst_layer *tu_layer(bst_ctx *ctx, const char *what, const bst_basis *b);

/* A basis from one of WCE's patch tables (wce/basis/FILE in the reference folder), each patch's
 * Lambda checked against the table's. */
bst_basis *tu_wce_basis(bst_ctx *ctx, const char *file);

/* An allocator for bst_ctx_set_allocator that fails the n-th allocation (n >= 1; 0 = never),
 * and counts live blocks so that leaks show. */
typedef struct {
    long fail_at;  /* the allocation number that fails (1-based), 0 = none */
    long count;    /* allocations attempted so far */
    long live;     /* blocks allocated and not yet freed */
} tu_alloc;
void *tu_alloc_malloc(size_t size, void *opaque);
void tu_alloc_free(void *p, void *opaque);

/* Every allocation of bst_venetian_layer of the venetian spec over Shirley-Chiu k = 2 fails in
 * turn: BST_ENOMEM, no layer, nothing leaked each time, then the layer is made.  Returns how many
 * allocations were failed (at least one). */
long tu_venetian_alloc_failures(const char *spec);
/* The same for a shade of kind "venetian", "woven" or "perforated" (its spec), over the Klems
 * basis named klems or, NULL, Shirley-Chiu k = 2. */
long tu_shade_alloc_failures(const char *kind, const char *spec, const char *klems);

/* Output collected in memory, NUL-terminated (p, n; the caller frees p): tu_mem_write is a
 * bst_bsdf_write_sink that fails once more than `limit` bytes were offered (0 = never) and counts
 * its calls. */
typedef struct {
    char *p;
    size_t n, cap, limit;
    int calls;
} tu_membuf;
int tu_mem_write(const char *buf, size_t len, void *opaque);

/* Run a Check suite; returns the process exit status. */
int tu_run(Suite *s);

#endif
