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

bst_basis *tu_wce_basis(bst_ctx *ctx, const char *file)
{
    char path[128], line[512];
    snprintf(path, sizeof path, "wce/basis/%s", file);
    FILE *fp = fopen(tu_ref(path), "r");
    ck_assert_msg(fp != NULL, "cannot open reference file %s", tu_ref(path));
    double bounds[32], lam[256];
    int nphi[32] = {0}, nb = 0, ring, idx;
    size_t np = 0;
    while (fgets(line, sizeof line, fp)) {
        double tlo, thi, plo, phi, tc, pc, l;
        if (line[0] == '#' || sscanf(line, "%d %d %lf %lf %lf %lf %lf %lf %lf", &idx, &ring, &tlo,
                                     &thi, &plo, &phi, &tc, &pc, &l) != 9)
            continue;
        if (ring > nb) {
            ck_assert_int_eq(ring, nb + 1);
            bounds[nb] = tlo, bounds[nb + 1] = thi;
            nb = ring;
        }
        nphi[ring - 1]++;
        lam[np++] = l;
    }
    fclose(fp);
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems_bands(ctx, file, (size_t)nb, bounds, nphi, &b), BST_OK);
    ck_assert_uint_eq(bst_basis_size(b), np);
    for (size_t i = 0; i < np; i++)
        tu_assert_close(bst_basis_lambda(b)[i], lam[i], 1e-9, 0);
    return b;
}

/* The layer of a shade spec of kind "venetian", "woven" or "perforated" over b, in c. */
static int shade_layer(bst_ctx *c, const char *kind, const char *spec, const bst_basis *b,
                       bst_layer **l)
{
    if (strcmp(kind, "woven") == 0) {
        bst_woven w;
        ck_assert_int_eq(bst_woven_parse(c, spec, &w), BST_OK);
        return bst_woven_layer(c, &w, b, 0, NULL, l);
    }
    if (strcmp(kind, "perforated") == 0) {
        bst_perforated p;
        ck_assert_int_eq(bst_perforated_parse(c, spec, &p), BST_OK);
        return bst_perforated_layer(c, &p, b, 0, NULL, l);
    }
    bst_venetian v;
    ck_assert_int_eq(bst_venetian_parse(c, spec, &v), BST_OK);
    return bst_venetian_layer(c, &v, b, 0, NULL, l);
}

long tu_shade_alloc_failures(const char *kind, const char *spec, const char *klems)
{
    bst_ctx *c = bst_ctx_new();
    tu_alloc a = {0};
    ck_assert_int_eq(bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &a), BST_OK);
    bst_basis *b;
    ck_assert_int_eq(klems ? bst_basis_new_klems(c, klems, &b) : bst_basis_new_sc(c, 2, &b), BST_OK);
    long base = a.live, k;
    for (k = 1;; k++) {
        a.fail_at = a.count + k;
        bst_layer *l = NULL;
        int rc = shade_layer(c, kind, spec, b, &l);
        if (rc == BST_OK) {
            bst_layer_free(l);
            break;
        }
        ck_assert_int_eq(rc, BST_ENOMEM);
        ck_assert_ptr_null(l);
        ck_assert_int_eq(a.live, base);
        ck_assert_int_lt(k, 1000);
    }
    ck_assert_int_gt(k, 1);
    ck_assert_int_eq(a.live, base);
    a.fail_at = 0;
    bst_basis_free(b);
    bst_ctx_free(c);
    return k - 1;
}

long tu_venetian_alloc_failures(const char *spec)
{
    return tu_shade_alloc_failures("venetian", spec, NULL);
}

int tu_run(Suite *s)
{
    SRunner *sr = srunner_create(s);
    srunner_run_all(sr, CK_NORMAL);
    int failed = srunner_ntests_failed(sr);
    srunner_free(sr);
    return failed == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
