/* testutil.c - see testutil.h. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "testutil.h"

int tu_close(double a, double b, double rtol, double scale)
{
    if (isnan(a) || isnan(b))
        return 0;
    if (isinf(a) || isinf(b))
        return a == b;
    double m = fmax(fmax(fabs(a), fabs(b)), scale);
    return fabs(a - b) <= rtol * m;
}

void tu_rng_seed(tu_rng *r, uint64_t seed)
{
    r->s = seed ? seed : 0x9E3779B97F4A7C15ull;
}

double tu_rng_uniform(tu_rng *r)
{
    r->s ^= r->s >> 12;
    r->s ^= r->s << 25;
    r->s ^= r->s >> 27;
    uint64_t x = r->s * 0x2545F4914F6CDD1Dull;
    return (double)(x >> 11) * 0x1.0p-53;
}

const char *tu_ref(const char *name)
{
    static char buf[4096];
    const char *dir = getenv("BST_REFDIR");
    if (!dir || !*dir)
        dir = "../shared/reference";
    snprintf(buf, sizeof buf, "%s/%s", dir, name);
    return buf;
}

bst_layer *tu_layer(bst_ctx *ctx, const char *what, const bst_basis *b)
{
    bst_layer *l;
    const char *ch = "Visible";
    if (strncmp(what, "glass:", 6) == 0) {
        ck_assert_int_eq(bst_glass_layer_from_spec(ctx, what + 6, getenv("BSDFSTACK_GLASS_DIR"), b, 1,
                                                   &ch, &l), BST_OK);
        return l;
    }
    bst_bsdf *f;
    int rc = bst_bsdf_read(ctx, tu_ref(what), NULL, &f);
    ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, f, b, &l), BST_OK);
    bst_bsdf_free(f);
    return l;
}

void tu_unxz_ref(const char *name, char *path, size_t size)
{
    snprintf(path, size, "/tmp/bst_unxz_XXXXXX");
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    close(fd);
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "xz -dc '%s' > '%s'", tu_ref(name), path);
    ck_assert_msg(system(cmd) == 0, "cannot decompress %s", tu_ref(name));
}

const char *tu_src(const char *name)
{
    static char buf[4096];
    const char *dir = getenv("BST_SRCDIR");
    if (!dir || !*dir)
        dir = ".";
    snprintf(buf, sizeof buf, "%s/%s", dir, name);
    return buf;
}


int tu_mem_write(const char *buf, size_t len, void *opaque)
{
    tu_membuf *m = opaque;
    m->calls++;
    if (m->limit && m->n + len > m->limit)
        return -1;
    if (m->n + len + 1 > m->cap) {
        m->cap = (m->n + len + 1) * 2;
        m->p = realloc(m->p, m->cap);
        ck_assert_ptr_nonnull(m->p);
    }
    memcpy(m->p + m->n, buf, len);
    m->n += len;
    m->p[m->n] = '\0';
    return 0;
}

/* Each block carries its size in front so tu_alloc_free can keep the live count. */
void *tu_alloc_malloc(size_t size, void *opaque)
{
    tu_alloc *a = opaque;
    a->count++;
    if (a->fail_at && a->count == a->fail_at)
        return NULL;
    void *p = malloc(size);
    if (p)
        a->live++;
    return p;
}

void tu_alloc_free(void *p, void *opaque)
{
    tu_alloc *a = opaque;
    if (p) {
        a->live--;
        free(p);
    }
}

int tu_run(Suite *s)
{
    SRunner *sr = srunner_create(s);
    srunner_run_all(sr, CK_NORMAL);
    int failed = srunner_ntests_failed(sr);
    srunner_free(sr);
    return failed == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
