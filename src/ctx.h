/* ctx.h - internal side of bst_ctx: status messages, the allocator, progress, the CHOLMOD common.
 *
 * Internal (non-exported) functions of the library carry the prefix bsti_; only bst_ names are
 * exported from the shared library. */
#ifndef BST_CTX_H
#define BST_CTX_H

#include <pthread.h>
#include <stdarg.h>
#include <stddef.h>
#include "bsdfstack.h"

#define BSTI_MSG_MAX 1024

struct cholmod_common_struct;

/* How many freed large blocks a context keeps at most (bsti_keep_begin). */
#define BSTI_KEEP_SLOTS 4
/* How many sparse patterns whose LU was found too filled a context remembers (solve.c). */
#define BSTI_REFUSED_SLOTS 8

struct bst_ctx {
    int status;
    char msg[BSTI_MSG_MAX];
    bst_malloc_fn malloc_fn;
    bst_free_fn free_fn;
    void *alloc_opaque;
    bst_progress_fn progress_fn;
    void *progress_opaque;
    struct cholmod_common_struct *cholmod; /* started on first use, see bsti_cholmod */
    int threads;            /* bst_ctx_set_threads: 0 = one per CPU */
    double flops;           /* bsti_flops_add's count */
    int no_mirror;          /* 1: no mirror split of dense solves (mirror.h; the stack's --dense) */
    int poison_raw;         /* 1: bsti_mat_new_dense_raw fills with NaN (tests: every value written) */
    double mirror_splits;   /* dense factorizations split by mirror symmetry so far */
    double mirror_z_products; /* products Z X formed by such a split's halves (solve.c) */
    /* signatures of sparse A whose LU UMFPACK's analysis found too filled (solve.c,
       factor_sparse), the newest at refused_next - 1, and how often one was met again */
    unsigned long long refused[BSTI_REFUSED_SLOTS];
    int refused_next;
    double refusals_remembered;
    /* large freed blocks kept for reuse while keep_depth > 0 (bsti_keep_begin) */
    pthread_mutex_t keep_lock;
    int keep_depth, nkept;
    void *kept[BSTI_KEEP_SLOTS];
    size_t kept_size[BSTI_KEEP_SLOTS];
};

/* Record status and a printf-style message in ctx and return status (so: return bsti_error(...)). */
int bsti_error(bst_ctx *ctx, int status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
/* Prefix the current message with "prefix: " (to add where an error happened). */
void bsti_error_prefix(bst_ctx *ctx, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Allocation through the context's allocator.  On failure they record BST_ENOMEM in ctx and
 * return NULL.  bsti_calloc and bsti_alloc_array check n * size for overflow. */
void *bsti_malloc(bst_ctx *ctx, size_t size);
void *bsti_calloc(bst_ctx *ctx, size_t n, size_t size);
void *bsti_alloc_array(bst_ctx *ctx, size_t n, size_t size);
void bsti_free(bst_ctx *ctx, void *p);
char *bsti_strdup(bst_ctx *ctx, const char *s);
/* Between bsti_keep_begin and its bsti_keep_end (they nest), blocks of the system's allocator of
 * BSTI_KEEP_MIN bytes or more that are freed are kept (BSTI_KEEP_SLOTS) and handed to the next request of
 * about their size instead of fresh ones: a fresh block's pages are each faulted in and cleared by
 * the kernel at their first touch, and a k = 7 factored combination makes and drops dozens of
 * 128 MiB blocks.  A request that finds no kept block of its size releases them all first, so
 * the memory held never exceeds what the blocks took while they were in use; bsti_keep_end
 * releases them.  Without malloc_usable_size (or with a custom allocator) nothing is kept. */
#define BSTI_KEEP_MIN ((size_t)64 << 20)
void bsti_keep_begin(bst_ctx *ctx);
void bsti_keep_end(bst_ctx *ctx);
/* a * b without overflow: 0 and *out set, or -1 on overflow. */
int bsti_size_mul(size_t a, size_t b, size_t *out);

/* How many threads (the caller's included) may share a job of at most `jobs` independent parts:
 * bst_ctx_set_threads's setting (0: the online CPUs), at most BST_THREADS_MAX and jobs, 1 with a
 * custom allocator (its hooks need not be thread-safe). */
int bsti_ctx_workers(const bst_ctx *ctx, size_t jobs);
/* The same for threads that allocate nothing (their memory made by the caller): the allocator
 * does not matter. */
int bsti_ctx_workers_no_alloc(const bst_ctx *ctx, size_t jobs);
/* fn on each of n parts (parts: an array of n items of `size` bytes each): parts 1.. on threads of
 * their own (up to BSTI_RUN_PARTS_MAX), part 0 on the caller's, then a part whose thread could
 * not start on the caller's too; returns once all are done. */
#define BSTI_RUN_PARTS_MAX 64
void bsti_run_parts(void *parts, size_t size, size_t n, void *(*fn)(void *));

/* Report progress of a long operation (no-op without a callback). */
void bsti_progress(bst_ctx *ctx, double fraction, const char *label);

/* The context's CHOLMOD common (started on first call, finished by bst_ctx_free); NULL with
 * BST_ENOMEM recorded if it cannot be started. */
struct cholmod_common_struct *bsti_cholmod(bst_ctx *ctx);

/* Count floating-point operations asked of the dense kernels in ctx->flops (bst_stack_step's
 * flops): GEMM 2 m n k; LU (getrf) 2/3 n^3 - 1/2 n^2 + 5/6 n and the triangular solves (getrs)
 * (2 n^2 - n) per right-hand side, LAPACK Working Note 41's counts; a sparse by dense product
 * 2 nnz per column of the dense factor.  Not counted: O(n^2) element-wise work (scalings by Lambda
 * or a pane, sums, copies), the condition estimate (gecon, O(n^2)), sparse factorizations and
 * sparse by sparse products.  Per context, as a context is one thread's at a time (the spectral
 * workers each have their own), so that concurrent stacks count only their own. */
static inline void bsti_flops_add(bst_ctx *ctx, double flops) { ctx->flops += flops; }

#endif
