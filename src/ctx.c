/* ctx.c - the context object: last status and message, allocator hooks, progress callback, and the
 * CHOLMOD common block shared by the sparse kernels of one context. */
#include <config.h>

#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#ifdef HAVE_SYS_MMAN_H
#include <sys/mman.h>
#endif
#ifdef HAVE_MALLOC_H
#include <malloc.h>
#endif

#include <cholmod.h>

#include "ctx.h"

/* Where Linux's transparent huge pages are offered on request (its "madvise" mode), a large
 * block of the system's allocator asks for them on the 2 MiB-aligned part of its own bytes. The
 * factored algebra makes and drops dozens of blocks of 128 MiB in one k = 7 combination: each
 * fresh 4 KiB page is a fault, where a huge page is one fault for 512 of them (bench/README.md,
 * "Huge pages and fewer fresh blocks in the factored algebra"). A hint: its failure changes
 * nothing. */
enum { HUGE_PAGE = 2u << 20, HUGE_MIN = 4u << 20 };

static void *advise_huge(void *p, size_t size)
{
#if defined(HAVE_MADVISE) && defined(MADV_HUGEPAGE)
    if (p && size >= HUGE_MIN) {
        uintptr_t a = ((uintptr_t)p + HUGE_PAGE - 1) & ~(uintptr_t)(HUGE_PAGE - 1);
        uintptr_t e = ((uintptr_t)p + size) & ~(uintptr_t)(HUGE_PAGE - 1);
        if (e > a)
            (void)madvise((void *)a, e - a, MADV_HUGEPAGE);
    }
#else
    (void)size;
#endif
    return p;
}

static void *system_malloc(size_t size, void *opaque)
{
    (void)opaque;
    return advise_huge(malloc(size), size);
}

static void system_free(void *p, void *opaque)
{
    (void)opaque;
    free(p);
}

const char *bst_strerror(int status)
{
    switch (status) {
    case BST_OK: return "success";
    case BST_EINVAL: return "invalid argument";
    case BST_ENOMEM: return "out of memory";
    case BST_ESIZE: return "sizes do not match";
    case BST_EIO: return "input/output error";
    case BST_EFORMAT: return "malformed input";
    case BST_EBASIS: return "unknown or incompatible basis";
    case BST_ESINGULAR: return "singular matrix";
    case BST_ENOTFOUND: return "not found";
    case BST_EINTERNAL: return "internal error in a numerical library";
    case BST_ENOTIMPL: return "not implemented yet";
    case BST_WILLCOND: return "ill-conditioned solve";
    case BST_WENERGY: return "energy imbalance";
    case BST_WDATA: return "input data completed or repaired";
    case BST_WACCURACY: return "the file written moves hemispherical values beyond the tolerance";
    default: return status < 0 ? "unknown error" : "unknown warning";
    }
}

static void keep_release(bst_ctx *ctx);

bst_ctx *bst_ctx_new(void)
{
    bst_ctx *ctx = calloc(1, sizeof *ctx);
    if (!ctx)
        return NULL;
    ctx->malloc_fn = system_malloc;
    ctx->free_fn = system_free;
    if (pthread_mutex_init(&ctx->keep_lock, NULL) != 0) {
        free(ctx);
        return NULL;
    }
    return ctx;
}

void bst_ctx_free(bst_ctx *ctx)
{
    if (!ctx)
        return;
    if (ctx->cholmod) {
        cholmod_l_finish(ctx->cholmod);
        free(ctx->cholmod);
    }
    keep_release(ctx);
    pthread_mutex_destroy(&ctx->keep_lock);
    free(ctx);
}

int bst_ctx_set_allocator(bst_ctx *ctx, bst_malloc_fn m, bst_free_fn f, void *opaque)
{
    if (!ctx)
        return BST_EINVAL;
    if (!m != !f)
        return bsti_error(ctx, BST_EINVAL, "allocator: give both malloc and free hooks, or neither");
    ctx->malloc_fn = m ? m : system_malloc;
    ctx->free_fn = f ? f : system_free;
    ctx->alloc_opaque = m ? opaque : NULL;
    return BST_OK;
}

const char *bst_ctx_message(const bst_ctx *ctx)
{
    return ctx ? ctx->msg : "no context";
}

int bst_ctx_status(const bst_ctx *ctx)
{
    return ctx ? ctx->status : BST_EINVAL;
}

void bst_ctx_clear(bst_ctx *ctx)
{
    if (!ctx)
        return;
    ctx->status = BST_OK;
    ctx->msg[0] = '\0';
}

void bst_ctx_set_progress(bst_ctx *ctx, bst_progress_fn fn, void *opaque)
{
    if (!ctx)
        return;
    ctx->progress_fn = fn;
    ctx->progress_opaque = opaque;
}

int bst_ctx_set_threads(bst_ctx *ctx, int n)
{
    if (!ctx)
        return BST_EINVAL;
    if (n < 0)
        return bsti_error(ctx, BST_EINVAL, "threads: %d (must be >= 0, 0 = one per CPU)", n);
    ctx->threads = n;
    return BST_OK;
}

int bst_ctx_threads(const bst_ctx *ctx)
{
    return ctx ? ctx->threads : 0;
}

int bsti_ctx_workers(const bst_ctx *ctx, size_t jobs)
{
    if (!ctx || ctx->malloc_fn != system_malloc)
        return 1;
    return bsti_ctx_workers_no_alloc(ctx, jobs);
}

void bsti_run_parts(void *parts, size_t size, size_t n, void *(*fn)(void *))
{
    pthread_t th[BSTI_RUN_PARTS_MAX];
    int started[BSTI_RUN_PARTS_MAX] = {0};
    char *p = parts;
    for (size_t t = 1; t < n && t < BSTI_RUN_PARTS_MAX; t++)
        started[t] = pthread_create(&th[t], NULL, fn, p + t * size) == 0;
    if (n)
        fn(p);
    for (size_t t = 1; t < n; t++) {
        if (t < BSTI_RUN_PARTS_MAX && started[t])
            pthread_join(th[t], NULL);
        else
            fn(p + t * size);
    }
}

int bsti_ctx_workers_no_alloc(const bst_ctx *ctx, size_t jobs)
{
    if (!ctx || jobs < 2)
        return 1;
    long n = ctx->threads;
    if (n == 0)
        n = sysconf(_SC_NPROCESSORS_ONLN);
    if (n > BST_THREADS_MAX)
        n = BST_THREADS_MAX;
    if ((size_t)n > jobs)
        n = (long)jobs;
    return n > 1 ? (int)n : 1;
}

/* Messages put the reason last ("PATH: line N: what is wrong"), so one longer than ctx->msg
 * (a path of a thousand characters) loses its middle, not its end: the first third and the rest
 * from the end, joined by "...".  Texts beyond this many bytes lose what follows as well. */
#define MSG_FORMAT_MAX (16 * BSTI_MSG_MAX)

static void put_message(bst_ctx *ctx, const char *text, size_t len)
{
    size_t room = sizeof ctx->msg - 1;
    if (len <= room) {
        memcpy(ctx->msg, text, len);
        ctx->msg[len] = '\0';
        return;
    }
    size_t head = room / 3, tail = room - head - 3;
    memcpy(ctx->msg, text, head);
    memcpy(ctx->msg + head, "...", 3);
    memcpy(ctx->msg + head + 3, text + len - tail, tail);
    ctx->msg[room] = '\0';
}

int bsti_error(bst_ctx *ctx, int status, const char *fmt, ...)
{
    if (!ctx)
        return status;
    char text[MSG_FORMAT_MAX];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    put_message(ctx, text, n < 0 ? 0 : (size_t)n < sizeof text ? (size_t)n : sizeof text - 1);
    ctx->status = status;
    return status;
}

void bsti_error_prefix(bst_ctx *ctx, const char *fmt, ...)
{
    if (!ctx)
        return;
    char text[MSG_FORMAT_MAX];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(text, sizeof text - BSTI_MSG_MAX - 2, fmt, ap);
    va_end(ap);
    size_t len = n < 0 ? 0 : (size_t)n < sizeof text - BSTI_MSG_MAX - 2 ? (size_t)n : sizeof text - BSTI_MSG_MAX - 3;
    len += (size_t)snprintf(text + len, sizeof text - len, ": %s", ctx->msg);
    put_message(ctx, text, len); /* the end of the old message, its reason, stays */
}

int bsti_size_mul(size_t a, size_t b, size_t *out)
{
    if (a != 0 && b > SIZE_MAX / a)
        return -1;
    *out = a * b;
    return 0;
}

/* ------------------------------------------------------------------ large blocks kept */

/* The kept blocks freed (the lock held, or the context going). */
static void keep_release(bst_ctx *ctx)
{
    for (int i = 0; i < ctx->nkept; i++)
        free(ctx->kept[i]);
    ctx->nkept = 0;
}

void bsti_keep_begin(bst_ctx *ctx)
{
    pthread_mutex_lock(&ctx->keep_lock);
    ctx->keep_depth++;
    pthread_mutex_unlock(&ctx->keep_lock);
}

void bsti_keep_end(bst_ctx *ctx)
{
    pthread_mutex_lock(&ctx->keep_lock);
    if (ctx->keep_depth > 0 && --ctx->keep_depth == 0)
        keep_release(ctx);
    pthread_mutex_unlock(&ctx->keep_lock);
}

/* A kept block of size to size + size / 8 bytes, or NULL (then none is kept any more). */
static void *keep_take(bst_ctx *ctx, size_t size)
{
#ifdef HAVE_MALLOC_USABLE_SIZE
    if (size < BSTI_KEEP_MIN || ctx->malloc_fn != system_malloc)
        return NULL;
    void *p = NULL;
    pthread_mutex_lock(&ctx->keep_lock);
    for (int i = 0; i < ctx->nkept && !p; i++)
        if (ctx->kept_size[i] >= size && ctx->kept_size[i] - size <= size / 8) {
            p = ctx->kept[i];
            ctx->kept[i] = ctx->kept[--ctx->nkept];
            ctx->kept_size[i] = ctx->kept_size[ctx->nkept];
        }
    if (!p)
        keep_release(ctx);
    pthread_mutex_unlock(&ctx->keep_lock);
    return p;
#else
    (void)ctx, (void)size;
    return NULL;
#endif
}

/* Whether p (of the system's allocator) is kept instead of freed. */
static int keep_put(bst_ctx *ctx, void *p)
{
#ifdef HAVE_MALLOC_USABLE_SIZE
    if (ctx->free_fn != system_free)
        return 0;
    size_t size = malloc_usable_size(p);
    if (size < BSTI_KEEP_MIN)
        return 0;
    int kept = 0;
    pthread_mutex_lock(&ctx->keep_lock);
    if (ctx->keep_depth > 0 && ctx->nkept < BSTI_KEEP_SLOTS) {
        ctx->kept[ctx->nkept] = p, ctx->kept_size[ctx->nkept++] = size;
        kept = 1;
    }
    pthread_mutex_unlock(&ctx->keep_lock);
    return kept;
#else
    (void)ctx, (void)p;
    return 0;
#endif
}

/* ------------------------------------------------------------------ allocation */

void *bsti_malloc(bst_ctx *ctx, size_t size)
{
    void *p = keep_take(ctx, size);
    if (p)
        return p;
    p = ctx->malloc_fn(size ? size : 1, ctx->alloc_opaque);
    if (!p)
        bsti_error(ctx, BST_ENOMEM, "out of memory (allocating %zu bytes)", size);
    return p;
}

/* n * size into *total: 0, or -1 with the overflow recorded. */
static int array_bytes(bst_ctx *ctx, size_t n, size_t size, size_t *total)
{
    if (!bsti_size_mul(n, size, total))
        return 0;
    bsti_error(ctx, BST_ENOMEM, "out of memory (%zu x %zu bytes overflows)", n, size);
    return -1;
}

void *bsti_alloc_array(bst_ctx *ctx, size_t n, size_t size)
{
    size_t total;
    return array_bytes(ctx, n, size, &total) ? NULL : bsti_malloc(ctx, total);
}

void *bsti_calloc(bst_ctx *ctx, size_t n, size_t size)
{
    size_t total;
    if (array_bytes(ctx, n, size, &total))
        return NULL;
    if (ctx->malloc_fn != system_malloc) {
        void *p = bsti_malloc(ctx, total);
        if (p)
            memset(p, 0, total);
        return p;
    }
    /* the system's calloc: a fresh mapping (a large block) is zero already and is not written
     * here, so its pages are faulted in by their first real use, and those never used (a sparse
     * factor's zeros) never are; a kept block is cleared */
    void *p = keep_take(ctx, total);
    if (p)
        return memset(p, 0, total);
    p = advise_huge(calloc(total ? total : 1, 1), total);
    if (!p)
        bsti_error(ctx, BST_ENOMEM, "out of memory (allocating %zu bytes)", total);
    return p;
}

void bsti_free(bst_ctx *ctx, void *p)
{
    if (p && !keep_put(ctx, p))
        ctx->free_fn(p, ctx->alloc_opaque);
}

char *bsti_strdup(bst_ctx *ctx, const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = bsti_malloc(ctx, n);
    if (d)
        memcpy(d, s, n);
    return d;
}

void bsti_progress(bst_ctx *ctx, double fraction, const char *label)
{
    if (ctx && ctx->progress_fn)
        ctx->progress_fn(fraction, label, ctx->progress_opaque);
}

struct cholmod_common_struct *bsti_cholmod(bst_ctx *ctx)
{
    if (ctx->cholmod)
        return ctx->cholmod;
    cholmod_common *cc = malloc(sizeof *cc);
    if (!cc || !cholmod_l_start(cc)) {
        free(cc);
        bsti_error(ctx, BST_ENOMEM, "out of memory (starting CHOLMOD)");
        return NULL;
    }
    cc->print = 0; /* the library never prints */
    cc->error_handler = NULL;
    ctx->cholmod = cc;
    return cc;
}

const char *bst_version(void)
{
    return PACKAGE_VERSION;
}
