/* testglass.c - helpers of the glass file-format suites: see testglass.h. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testglass.h"
#include "testutil.h"

void tg_rows_read(struct tg_rows *r)
{
    FILE *fp = fopen(tu_ref("wce/data/spectral_NFRC_102.tsv"), "r");
    ck_assert_ptr_nonnull(fp);
    char line[512];
    size_t cap = 0;
    r->n = 0, r->v = NULL;
    while (fgets(line, sizeof line, fp)) {
        char t[5][24];
        double x;
        if (line[0] == '#' || sscanf(line, "%23s %23s %23s %23s %23s", t[0], t[1], t[2], t[3], t[4]) != 5 ||
            sscanf(t[0], "%lf", &x) != 1)
            continue;
        if (r->n == cap) {
            cap = cap ? 2 * cap : 128;
            r->v = realloc(r->v, cap * sizeof *r->v);
            ck_assert_ptr_nonnull(r->v);
        }
        memcpy(r->v[r->n++], t, sizeof t);
    }
    fclose(fp);
    ck_assert_uint_eq(r->n, 111);
}

void tg_rows_free(struct tg_rows *r)
{
    free(r->v);
    r->v = NULL, r->n = 0;
}

static char scratch[64];

bst_ctx *tg_ctx;
struct tg_rows tg_nfrc102;

void tg_setup(void)
{
    tg_ctx = bst_ctx_new();
    tg_rows_read(&tg_nfrc102);
    tg_scratch();
}

void tg_teardown(void)
{
    tg_scratch_remove();
    tg_rows_free(&tg_nfrc102);
    bst_ctx_free(tg_ctx);
}

const char *tg_scratch(void)
{
    strcpy(scratch, "/tmp/bst_glass_XXXXXX");
    ck_assert_ptr_nonnull(mkdtemp(scratch));
    return scratch;
}

void tg_scratch_remove(void)
{
    char cmd[128];
    if (!scratch[0])
        return;
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", scratch);
    ck_assert_int_eq(system(cmd), 0);
    scratch[0] = '\0';
}

const char *tg_dir(void) { return scratch; }

FILE *tg_create(const char *name, const char **path)
{
    *path = tg_path(name);
    FILE *fp = fopen(*path, "w");
    ck_assert_msg(fp != NULL, "cannot write %s", *path);
    return fp;
}

const char *tg_path(const char *name)
{
    static char p[256];
    snprintf(p, sizeof p, "%s/%s", scratch, name);
    return p;
}

bst_glass *tg_parse(bst_ctx *ctx, const char *spec)
{
    bst_glass *g = NULL;
    int rc = bst_glass_parse(ctx, spec, getenv("BSDFSTACK_GLASS_DIR"), &g);
    ck_assert_msg(rc == BST_OK, "%s: %s", spec, bst_ctx_message(ctx));
    return g;
}

void tg_same_pane(const bst_glass *a, const bst_glass *b)
{
    size_t n = bst_glass_nwavelengths(a);
    ck_assert_uint_eq(n, bst_glass_nwavelengths(b));
    ck_assert_uint_eq(bst_glass_nchannels(a), bst_glass_nchannels(b));
    for (size_t k = 0; k < n; k++)
        ck_assert(bst_glass_wavelength(a, k) == bst_glass_wavelength(b, k));
    for (int d = 0; d <= 90; d++) {
        double th = d * M_PI / 180, p[4], q[4];
        for (size_t c = 0; c < bst_glass_nchannels(a); c++) {
            ck_assert_str_eq(bst_glass_channel(a, c), bst_glass_channel(b, c));
            ck_assert_int_eq(bst_glass_optics(a, c, th, &p[0], &p[1], &p[2], &p[3]), BST_OK);
            ck_assert_int_eq(bst_glass_optics(b, c, th, &q[0], &q[1], &q[2], &q[3]), BST_OK);
            ck_assert_msg(memcmp(p, q, sizeof p) == 0, "channel %zu at %d deg: %.17g vs %.17g",
                          c, d, p[0], q[0]);
        }
        for (size_t k = 0; k < n; k += 10) {
            double wl = bst_glass_wavelength(a, k);
            ck_assert_int_eq(bst_glass_optics_spectral(a, wl, th, &p[0], &p[1], &p[2], &p[3]), BST_OK);
            ck_assert_int_eq(bst_glass_optics_spectral(b, wl, th, &q[0], &q[1], &q[2], &q[3]), BST_OK);
            ck_assert(memcmp(p, q, sizeof p) == 0);
        }
    }
}

void tg_same_stack(bst_ctx *ctx, bst_glass *a, bst_glass *b)
{
    bst_basis *kq;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "quarter", &kq), BST_OK);
    bst_glass *g103 = tg_parse(ctx, "nfrc-103");
    static const char *const bands[2] = {"Solar", "Visible"};
    size_t N = bst_basis_size(kq);
    bst_layer *r[2];
    double *abs[2];
    for (int i = 0; i < 2; i++) {
        bst_glass *panes[2] = {i ? b : a, g103};
        abs[i] = malloc(2 * 2 * N * sizeof *abs[i]);
        int rc = bst_stack_combine_spectral(ctx, 2, panes, kq, 2, bands, 1, NULL, &r[i], abs[i], NULL);
        ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    }
    for (size_t c = 0; c < 2; c++)
        for (int m = 0; m < BST_NCOMP; m++)
            for (size_t j = 0; j < N; j++)
                ck_assert(bst_mat_get(bst_layer_get(r[0], c, (bst_comp)m), j, j) ==
                          bst_mat_get(bst_layer_get(r[1], c, (bst_comp)m), j, j));
    ck_assert(memcmp(abs[0], abs[1], 2 * 2 * N * sizeof(double)) == 0);
    /* and it is a stack worth comparing: WCE's 0.652314 at normal incidence (solar) */
    tu_assert_close(bst_basis_lambda(kq)[0] * bst_mat_get(bst_layer_get(r[0], 0, BST_TF), 0, 0),
                    0.652314, 1e-6, 1);
    for (int i = 0; i < 2; i++)
        bst_layer_free(r[i]), free(abs[i]);
    bst_glass_free(g103);
    bst_basis_free(kq);
}

void tg_refused(bst_ctx *ctx, const char *spec, const char *expect)
{
    bst_glass *g = (bst_glass *)1;
    int rc = bst_glass_parse(ctx, spec, getenv("BSDFSTACK_GLASS_DIR"), &g);
    ck_assert_msg(rc < 0, "'%s' accepted", spec);
    ck_assert_ptr_null(g);
    const char *m = bst_ctx_message(ctx);
    ck_assert_msg(strstr(m, expect), "'%s': message '%s' lacks '%s'", spec, m, expect);
    ck_assert_msg(!strchr(m, '\n'), "'%s': message of several lines: %s", spec, m);
}

void tg_alloc_sweep(const char *what, long max, int (*step)(bst_ctx *c, void *arg), void *arg)
{
    int ok = 0;
    for (long n = 1; n <= max && !ok; n++) {
        tu_alloc a = {n, 0, 0};
        bst_ctx *c = bst_ctx_new();
        ck_assert_int_eq(bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &a), BST_OK);
        int rc = step(c, arg);
        ck_assert_msg(rc == BST_OK || rc == BST_ENOMEM, "%s, allocation %ld: %d %s", what, n, rc,
                      bst_ctx_message(c));
        ok = rc == BST_OK;
        ck_assert_msg(a.live == 0, "%s: %ld blocks leaked after failing allocation %ld", what,
                      a.live, n);
        bst_ctx_free(c);
    }
    ck_assert_msg(ok, "%s never succeeded", what);
}

Suite *tg_suite(const char *name, void (*setup)(void), void (*teardown)(void), int timeout,
                const TTest *const *tests, size_t n)
{
    Suite *s = suite_create(name);
    TCase *tc = tcase_create(name);
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, timeout);
    for (size_t i = 0; i < n; i++)
        tcase_add_test(tc, tests[i]);
    suite_add_tcase(s, tc);
    return s;
}

int tg_read_pane(bst_ctx *c, void *spec)
{
    bst_glass *g = (bst_glass *)1;
    int rc = bst_glass_parse(c, spec, getenv("BSDFSTACK_GLASS_DIR"), &g);
    if (rc < 0)
        ck_assert_ptr_null(g);
    else
        bst_glass_free(g);
    return rc;
}
