/* test_ctx.c - the context: messages, status texts, allocator hooks and their failure paths. */
#include <config.h>

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "ctx.h"
#include "testutil.h"

START_TEST(test_messages)
{
    bst_ctx *ctx = bst_ctx_new();
    ck_assert_ptr_nonnull(ctx);
    ck_assert_str_eq(bst_ctx_message(ctx), "");
    ck_assert_int_eq(bst_ctx_status(ctx), BST_OK);
    int rc = bsti_error(ctx, BST_EFORMAT, "file %s: element <%s> is wrong", "a.xml", "Foo");
    ck_assert_int_eq(rc, BST_EFORMAT);
    ck_assert_int_eq(bst_ctx_status(ctx), BST_EFORMAT);
    ck_assert_str_eq(bst_ctx_message(ctx), "file a.xml: element <Foo> is wrong");
    bsti_error_prefix(ctx, "layer %d", 2);
    ck_assert_str_eq(bst_ctx_message(ctx), "layer 2: file a.xml: element <Foo> is wrong");
    bst_ctx_clear(ctx);
    ck_assert_str_eq(bst_ctx_message(ctx), "");
    bst_ctx_free(ctx);
    bst_ctx_free(NULL);
}
END_TEST

/* A message longer than the context holds (a path of thousands of characters) loses its middle,
 * never its end, where the reason is; a prefix added to a long message does the same. */
START_TEST(test_long_messages)
{
    bst_ctx *ctx = bst_ctx_new();
    char path[4000];
    for (size_t i = 0; i < sizeof path - 1; i++)
        path[i] = (char)('a' + i % 26);
    path[sizeof path - 1] = '\0';
    for (size_t len = BSTI_MSG_MAX - 40; len < sizeof path; len += 997) {
        path[len] = '\0';
        bsti_error(ctx, BST_EIO, "%s: cannot open: No such file or directory", path);
        const char *m = bst_ctx_message(ctx);
        size_t n = strlen(m);
        ck_assert_uint_lt(n, BSTI_MSG_MAX);
        ck_assert_uint_gt(n, 100);
        ck_assert_str_eq(m + n - 38, "cannot open: No such file or directory"); /* the reason kept */
        ck_assert_int_eq(strncmp(m, path, 100), 0); /* the path's start kept */
        ck_assert_int_eq(strstr(m, "...") != NULL, len + 40 >= BSTI_MSG_MAX);
        bsti_error_prefix(ctx, "layer 2 (%s)", path);
        m = bst_ctx_message(ctx);
        n = strlen(m);
        ck_assert_uint_lt(n, BSTI_MSG_MAX);
        ck_assert_str_eq(m + n - 38, "cannot open: No such file or directory");
        ck_assert_int_eq(strncmp(m, "layer 2 (", 9), 0);
        path[len] = (char)('a' + len % 26);
    }
    bst_ctx_free(ctx);
}
END_TEST

START_TEST(test_strerror)
{
    int codes[] = {BST_OK, BST_EINVAL, BST_ENOMEM, BST_ESIZE, BST_EIO, BST_EFORMAT, BST_EBASIS,
                   BST_ESINGULAR, BST_ENOTFOUND, BST_EINTERNAL, BST_ENOTIMPL, BST_WILLCOND,
                   BST_WENERGY, BST_WDATA};
    for (size_t i = 0; i < sizeof codes / sizeof codes[0]; i++)
        for (size_t j = 0; j < i; j++)
            ck_assert_str_ne(bst_strerror(codes[i]), bst_strerror(codes[j]));
    ck_assert_str_eq(bst_strerror(-1000), "unknown error");
    ck_assert_str_eq(bst_strerror(1000), "unknown warning");
}
END_TEST

START_TEST(test_allocator)
{
    bst_ctx *ctx = bst_ctx_new();
    tu_alloc a = {.fail_at = 2};
    ck_assert_int_eq(bst_ctx_set_allocator(ctx, tu_alloc_malloc, NULL, &a), BST_EINVAL);
    ck_assert_int_eq(bst_ctx_set_allocator(ctx, tu_alloc_malloc, tu_alloc_free, &a), BST_OK);
    void *p = bsti_malloc(ctx, 10);
    ck_assert_ptr_nonnull(p);
    ck_assert_ptr_null(bsti_malloc(ctx, 10));
    ck_assert_int_eq(bst_ctx_status(ctx), BST_ENOMEM);
    ck_assert_ptr_null(bsti_calloc(ctx, SIZE_MAX / 2, 4)); /* overflow is caught, not wrapped */
    ck_assert_int_eq(bst_ctx_status(ctx), BST_ENOMEM);
    bsti_free(ctx, p);
    ck_assert_int_eq(a.live, 0);
    bst_ctx_free(ctx);
}
END_TEST

START_TEST(test_size_mul)
{
    size_t out;
    ck_assert_int_eq(bsti_size_mul(16384, 16384, &out), 0);
    ck_assert_uint_eq(out, 268435456u);
    ck_assert_int_eq(bsti_size_mul(SIZE_MAX / 2 + 1, 2, &out), -1);
}
END_TEST

/* The VmFlags of the mapping that holds address a (/proc/self/smaps), or "" where none is read. */
static void vm_flags(uintptr_t a, char *flags, size_t room)
{
    flags[0] = '\0';
    FILE *f = fopen("/proc/self/smaps", "r");
    if (!f)
        return;
    char line[512];
    int in = 0;
    while (fgets(line, sizeof line, f)) {
        unsigned long lo, hi;
        if (sscanf(line, "%lx-%lx ", &lo, &hi) == 2 && strchr(line, '-') < strchr(line, ' '))
            in = a >= lo && a < hi;
        else if (in && !strncmp(line, "VmFlags:", 8)) {
            size_t len = strlen(line + 8) < room ? strlen(line + 8) : room - 1;
            memcpy(flags, line + 8, len);
            flags[len] = '\0';
            break;
        }
    }
    fclose(f);
}

/* Where the kernel offers transparent huge pages, a large block of the system's allocator asks
 * for them (its mapping is marked hg), by bsti_malloc and by bsti_calloc; its bytes are usable and
 * calloc's are zero. */
START_TEST(test_huge_pages)
{
    bst_ctx *ctx = bst_ctx_new();
    size_t n = (size_t)32 << 20;
    unsigned char *p = bsti_malloc(ctx, n), *q = bsti_calloc(ctx, n, 1);
    ck_assert_ptr_nonnull(p);
    ck_assert_ptr_nonnull(q);
    memset(p, 7, n);
    ck_assert_uint_eq(p[n - 1], 7);
    ck_assert_uint_eq(q[n / 2], 0);
    ck_assert_uint_eq(q[n - 1], 0);
#if defined(HAVE_MADVISE) && defined(__linux__)
    if (access("/sys/kernel/mm/transparent_hugepage/enabled", F_OK) == 0) {
        const unsigned char *blocks[2] = {p, q};
        for (int b = 0; b < 2; b++) {
            uintptr_t mid = ((uintptr_t)blocks[b] + n / 2) & ~(uintptr_t)((2u << 20) - 1);
            char flags[256];
            vm_flags(mid, flags, sizeof flags);
            ck_assert_msg(strstr(flags, " hg"), "block %d's mapping is not marked for huge pages: "
                          "VmFlags '%s'", b, flags);
        }
    } else
        fprintf(stderr, "test_huge_pages: this kernel has no transparent huge pages; the blocks' "
                "bytes checked only\n");
#endif
    bsti_free(ctx, p);
    bsti_free(ctx, q);
    bst_ctx_free(ctx);
}
END_TEST

/* Between bsti_keep_begin and bsti_keep_end a large freed block is handed to the next request of
 * its size (calloc's cleared), at most BSTI_KEEP_SLOTS are kept, a request of another size
 * releases them, and they nest; outside, and with a custom allocator, nothing is kept. */
START_TEST(test_keep_blocks)
{
    bst_ctx *ctx = bst_ctx_new();
    size_t n = BSTI_KEEP_MIN;
    unsigned char *p = bsti_malloc(ctx, n);
    ck_assert_ptr_nonnull(p);
    bsti_free(ctx, p);
    ck_assert_int_eq(ctx->nkept, 0); /* not between begin and end */
#ifdef HAVE_MALLOC_USABLE_SIZE
    bsti_keep_begin(ctx);
    bsti_keep_begin(ctx);
    p = bsti_malloc(ctx, n);
    ck_assert_ptr_nonnull(p);
    memset(p, 0xab, n);
    bsti_free(ctx, p);
    ck_assert_int_eq(ctx->nkept, 1);
    unsigned char *q = bsti_malloc(ctx, n);
    ck_assert_ptr_eq(q, p);
    ck_assert_int_eq(ctx->nkept, 0);
    bsti_free(ctx, q);
    q = bsti_calloc(ctx, n, 1);
    ck_assert_ptr_eq(q, p);
    ck_assert_uint_eq(q[0], 0);
    ck_assert_uint_eq(q[n / 2], 0);
    ck_assert_uint_eq(q[n - 1], 0);
    bsti_free(ctx, q);
    unsigned char *b[BSTI_KEEP_SLOTS + 1];
    for (int i = 0; i <= BSTI_KEEP_SLOTS; i++)
        ck_assert_ptr_nonnull(b[i] = bsti_malloc(ctx, n + (size_t)i * 4096));
    for (int i = 0; i <= BSTI_KEEP_SLOTS; i++)
        bsti_free(ctx, b[i]);
    ck_assert_int_eq(ctx->nkept, BSTI_KEEP_SLOTS);
    q = bsti_malloc(ctx, 2 * n); /* no kept block of its size: they are released */
    ck_assert_ptr_nonnull(q);
    ck_assert_int_eq(ctx->nkept, 0);
    bsti_free(ctx, q);
    ck_assert_int_eq(ctx->nkept, 1);
    bsti_keep_end(ctx);
    ck_assert_int_eq(ctx->nkept, 1); /* nested: the outer pair still open */
    bsti_keep_end(ctx);
    ck_assert_int_eq(ctx->nkept, 0);
#endif
    bst_ctx_free(ctx);
    /* a custom allocator's blocks are its own */
    ctx = bst_ctx_new();
    tu_alloc a = {.fail_at = 0};
    ck_assert_int_eq(bst_ctx_set_allocator(ctx, tu_alloc_malloc, tu_alloc_free, &a), BST_OK);
    bsti_keep_begin(ctx);
    p = bsti_malloc(ctx, n);
    ck_assert_ptr_nonnull(p);
    bsti_free(ctx, p);
    ck_assert_int_eq(ctx->nkept, 0);
    ck_assert_int_eq(a.live, 0);
    bsti_keep_end(ctx);
    bst_ctx_free(ctx);
}
END_TEST

static Suite *ctx_suite(void)
{
    Suite *s = suite_create("ctx");
    TCase *tc = tcase_create("core");
    tcase_add_test(tc, test_messages);
    tcase_add_test(tc, test_long_messages);
    tcase_add_test(tc, test_strerror);
    tcase_add_test(tc, test_allocator);
    tcase_add_test(tc, test_size_mul);
    tcase_add_test(tc, test_huge_pages);
    tcase_add_test(tc, test_keep_blocks);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(ctx_suite());
}
