/* ttree.h - RADIANCE tensor trees (rank 3 and 4): built from the ScatteringData text as it streams
 * in, evaluated at a point of the unit hypercube, and expanded onto a regular grid.
 *
 * Syntax facts (CONVENTIONS.md 6): a node is { ... }; a branch has exactly 2^D children, child
 * index sum(b_i << i) with dimension 0 the LEAST significant bit; a leaf holds 2^(D L) values on a
 * regular grid of 2^L cells per dimension with dimension 0 the SLOWEST.  Negative numbers are read
 * as 0 (as libBSDF does).  Lookup: at a branch b_i = [p_i >= 1/2], p_i -> 2 p_i - b_i; at a leaf,
 * cell floor(G p_i). */
#ifndef BST_TTREE_H
#define BST_TTREE_H

#include <stddef.h>
#include <stdint.h>
#include "bsdfstack.h"

struct bsti_tnode {
    uint32_t first; /* branch: index of its first child id in kids[]; leaf: index in values[] */
    uint8_t leaf;
    uint8_t level;  /* leaf: L (grid of 2^L per dimension) */
};

typedef struct bsti_ttree {
    bst_ctx *ctx;
    int dim;                  /* 3 or 4 */
    struct bsti_tnode *nodes; /* nodes[0] is the root */
    size_t nnodes, cap_nodes;
    uint32_t *kids;           /* children of branches, 2^dim consecutive ids per branch */
    size_t nkids, cap_kids;
    float *values;
    size_t nvalues, cap_values;
    int depth;                /* finest cell level: the tree's resolution k */
    int negatives;            /* count of negative numbers read as 0 */
} bsti_ttree;

/* The bound on a value a BSDF file may hold, for both readers (trees and Klems matrices): finite
 * and at most FLT_MAX in magnitude, since tensor trees are held in single precision and every
 * file bsdfstack writes is too (a Klems value past it could only fail later, at the writer, with
 * a message naming the output).  BST_OK when v is within it; else BST_EFORMAT with "WHAT is not
 * finite" or "WHAT exceeds the single-precision range (3.403e+38) in which BSDF values are held"
 * in ctx (what: the value as the file spells it, "value '1e300'"; no file name, the caller
 * prefixes it). */
int bsti_value_check(bst_ctx *ctx, double v, const char *what);

/* Streaming builder: feed text in chunks of any size (tokens may straddle chunks). */
typedef struct bsti_tparse bsti_tparse;
int bsti_tparse_new(bst_ctx *ctx, int dim, bsti_tparse **out);
/* Returns < 0 with a message (no file name; the caller prefixes it) on a syntax error. */
int bsti_tparse_feed(bsti_tparse *p, const char *text, size_t len);
/* After a failed bsti_tparse_feed: the offset in its text of the token or brace that failed (0
 * for a token begun in an earlier chunk), for the caller's line number. */
size_t bsti_tparse_failed_at(const bsti_tparse *p);
/* Completes the tree; the parser is freed whatever the outcome. */
int bsti_tparse_finish(bsti_tparse *p, bsti_ttree **out);
void bsti_tparse_free(bsti_tparse *p);

void bsti_ttree_free(bsti_ttree *t);
/* Share of [0,1)^dim where the tree's value is not zero (the fill of its expansion at any order
 * at least its depth). */
double bsti_ttree_fill(const bsti_ttree *t);
/* Value at p in [0,1)^dim. */
double bsti_ttree_eval(const bsti_ttree *t, const double *p);
/* Rank 4 only: the tree on a grid of 2^k cells per dimension, as the column-major N x N matrix
 * (N = 4^k) M[o + N i] with i = ix 2^k + iy the cell of (p0, p1) and o = ox 2^k + oy that of
 * (p2, p3).  Finer tree cells are averaged, coarser ones replicated.  ttree_expand.c. */
int bsti_ttree_expand4(const bsti_ttree *t, int k, double *m);

/* The same in parts (rank 4 only, unchecked; k >= 1).  recip = 1 gives the matrix of the
 * reciprocal transmission instead, M'[o + N i] = M[a(i) + N a(o)] with a(j) = N - 1 - j.  threads:
 * how many threads may share the work (bsti_ttree_threads: one a processor at k >= 4); the
 * values never depend on it. */
int bsti_ttree_threads(int k);
/* The number of non-zero cells and whether they all lie on the diagonal (o = i); the count stops
 * (a lower bound then) once it passes limit with a cell off the diagonal. */
void bsti_ttree_census4(const bsti_ttree *t, int k, size_t limit, size_t *nnz, int *diag_only);
/* Every cell of m (N x N, double or float by prec) written once: m need not be cleared. */
void bsti_ttree_fill4(const bsti_ttree *t, int k, int recip, bst_precision prec, void *m, int threads);
/* emit(opaque, row, column, value) for each non-zero cell, one thread, in no particular order. */
typedef void (*bsti_ttree_emit_fn)(void *opaque, size_t row, size_t col, double v);
void bsti_ttree_emit4(const bsti_ttree *t, int k, int recip, bsti_ttree_emit_fn emit, void *opaque);

#endif
