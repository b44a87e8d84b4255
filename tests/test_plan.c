/* test_plan.c - the stack's decisions (plan.c): the basis rule over files of every kind, the
 * warning for a k above every rank-4 tree's order, the spectral plan's every branch with its
 * reason, the common channels and bands, and the memory model against its closed form, over
 * files and over layers made from shade specs (what those will hold, against the layers made). */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static bst_bsdf *read_ref(const char *name)
{
    bst_bsdf *b;
    int rc = bst_bsdf_read(ctx, tu_ref(name), NULL, &b);
    ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    return b;
}

START_TEST(test_basis_rule)
{
    bst_bsdf *tree6 = read_ref("L_glass_t4k6.xml"), *tree5 = read_ref("L_blind0_t4k5.xml");
    bst_bsdf *klems = read_ref("L_blind0_t4k5_klems.xml"), *iso = read_ref("L_diffuser_t3k5.xml");
    bst_plan_basis p;
    /* the finest tree order among the files, whatever else the stack holds */
    const bst_bsdf *a[4] = {NULL, tree5, klems, tree6};
    bst_plan_pick_basis(4, a, NULL, 0, NULL, &p);
    ck_assert_int_eq(p.k, 6);
    ck_assert_int_eq(p.finest, 6);
    ck_assert_ptr_nonnull(strstr(p.why, "finest tree order"));
    ck_assert_str_eq(p.note, "");
    /* else the first Klems file's basis */
    const bst_bsdf *b[3] = {NULL, klems, NULL};
    bst_plan_pick_basis(3, b, NULL, 0, NULL, &p);
    ck_assert_int_eq(p.k, 0);
    ck_assert_int_eq(p.file, 1);
    bst_basis *basis;
    ck_assert_int_eq(bst_plan_make_basis(ctx, &p, 3, b, NULL, &basis), BST_OK);
    ck_assert(bst_basis_equal(basis, bst_bsdf_klems_basis(klems)));
    bst_basis_free(basis);
    /* else a layer given over a basis, else k = 5 */
    bst_basis *half;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "half", &half), BST_OK);
    const bst_basis *given[3] = {NULL, NULL, half};
    bst_plan_pick_basis(3, NULL, given, 0, NULL, &p);
    ck_assert_int_eq(p.given, 2);
    ck_assert_int_eq(bst_plan_make_basis(ctx, &p, 3, NULL, given, &basis), BST_OK);
    ck_assert(bst_basis_equal(basis, half));
    bst_basis_free(basis);
    bst_plan_pick_basis(2, NULL, NULL, 0, NULL, &p);
    ck_assert_int_eq(p.k, 5);
    ck_assert_ptr_nonnull(strstr(p.why, "default"));
    /* asked: as asked; above every rank-4 tree's order, a note (none with a rank-3 tree) */
    const bst_bsdf *r4[2] = {tree5, tree5}, *r3[2] = {tree5, iso};
    bst_plan_pick_basis(2, r4, NULL, 7, NULL, &p);
    ck_assert_int_eq(p.k, 7);
    ck_assert_ptr_nonnull(strstr(p.note, "order 5 or less: -k 7 gives their order-5 system"));
    ck_assert_ptr_nonnull(strstr(p.note, "16 finer patches, written as its order-5 trees (with "
                                         "--dense at order 7, 256 times the values)"));
    bst_plan_pick_basis(2, r3, NULL, 7, NULL, &p);
    ck_assert_str_eq(p.note, "");
    bst_plan_pick_basis(2, r4, NULL, 0, "quarter", &p);
    ck_assert_str_eq(p.klems, "quarter");
    ck_assert_int_eq(bst_plan_make_basis(ctx, &p, 2, r4, NULL, &basis), BST_OK);
    ck_assert_uint_eq(bst_basis_size(basis), 41);
    bst_basis_free(basis);
    /* a pick that names a layer which is not there */
    bst_plan_basis bad = p;
    bad.klems = NULL, bad.k = 0, bad.file = 3, bad.given = -1;
    ck_assert_int_eq(bst_plan_make_basis(ctx, &bad, 2, r4, NULL, &basis), BST_EINVAL);
    ck_assert_ptr_null(basis);
    bst_basis_free(half);
    bst_bsdf_free(tree6), bst_bsdf_free(tree5), bst_bsdf_free(klems), bst_bsdf_free(iso);
}
END_TEST

/* An empty layer over k = 2 with the channels named (the plan reads channels only). */
static bst_layer *layer_with(const char *const *names, size_t n)
{
    bst_basis *b;
    bst_layer *l;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 2, &b), BST_OK);
    ck_assert_int_eq(bst_layer_new(ctx, b, n, names, &l), BST_OK);
    bst_basis_free(b);
    return l;
}

/* bst_plan_spectral on layers: the decision and warning wanted, and both texts in its reason. */
static void expect_plan(size_t n, const bst_plan_layer *l, int per_channel, int want, int want_warn,
                        const char *text1, const char *text2)
{
    char why[1024];
    int spectral = -1, warn = -1;
    ck_assert_int_eq(bst_plan_spectral(ctx, n, l, per_channel, why, sizeof why, &spectral, &warn), BST_OK);
    ck_assert_msg(spectral == want && warn == want_warn, "%d, warn %d: %s", spectral, warn, why);
    ck_assert_msg(strstr(why, text1) && strstr(why, text2), "%s", why);
}

START_TEST(test_spectral_plan)
{
    bst_glass *g;
    ck_assert_int_eq(bst_glass_parse(ctx, "nfrc-102", getenv("BSDFSTACK_GLASS_DIR"), &g), BST_OK);
    static const char *const sv[] = {"Visible", "Solar"}, *v[] = {"Visible"}, *s[] = {"Solar"};
    static const char *const vx[] = {"Visible", "Solar", "Other"};
    bst_layer *pane = layer_with(sv, 2), *dual = layer_with(sv, 2), *vis = layer_with(v, 1);
    bst_layer *sol = layer_with(s, 1), *odd = layer_with(vx, 3);
    /* panes and a dual-band layer: per wavelength, the dual-band layer said so */
    bst_plan_layer two[3] = {{pane, g, 0}, {dual, NULL, 1}, {pane, g, 0}};
    expect_plan(3, two, 0, 1, 0, "layer 2, ", "as WINDOW's dual-band material");
    expect_plan(3, two, 1, 0, 0, "as asked", ""); /* asked per channel */
    /* a file layer with Visible only: no spectral data */
    bst_plan_layer plain[2] = {{pane, g, 0}, {vis, NULL, 1}};
    expect_plan(2, plain, 0, 0, 0, "layer 2, ", "no Solar and Visible channels");
    /* Solar without Visible: per channel, with a warning */
    bst_plan_layer solar[2] = {{pane, g, 0}, {sol, NULL, 1}};
    expect_plan(2, solar, 0, 0, 1, "name Visible in --channels too", "");
    /* no pane at all; a channel that is not a band */
    bst_plan_layer none[1] = {{dual, NULL, 1}};
    expect_plan(1, none, 0, 0, 0, "no layer is a pane", "");
    bst_plan_layer other[2] = {{odd, g, 0}, {odd, g, 0}};
    expect_plan(2, other, 0, 0, 0, "channel Other is not a spectral band", "");
    char why[64];
    int spectral, warn;
    ck_assert_int_eq(bst_plan_spectral(ctx, 0, two, 0, why, sizeof why, &spectral, &warn), BST_EINVAL);
    /* channels in common, in layer 1's order; the bands */
    const bst_layer *ls[3] = {odd, dual, pane};
    const char *names[3];
    ck_assert_uint_eq(bst_plan_channels(3, ls, names), 2);
    ck_assert_str_eq(names[0], "Visible");
    ck_assert_str_eq(names[1], "Solar");
    ck_assert(bst_plan_is_band("cie-x") && bst_plan_is_band("SOLAR") && !bst_plan_is_band("Other"));
    bst_layer_free(pane), bst_layer_free(dual), bst_layer_free(vis), bst_layer_free(sol);
    bst_layer_free(odd);
    bst_glass_free(g);
}
END_TEST

/* The model's closed form (bsdfstack.h, bst_plan_memory) at k = 4 (N^2 = 65536 cells) with the
 * rank-3 diffuser, whose four components fill their domains (dense), and panes. */
START_TEST(test_memory)
{
    bst_bsdf *diff = read_ref("L_diffuser_t3k5.xml");
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &b), BST_OK);
    const bst_bsdf *f[2] = {NULL, diff};
    double cells = 65536.0, base = 64.0 * 1048576.0 + 0.5 * cells;
    size_t nd;
    /* a rank-3 file fills its whole domain: four dense components */
    double need = bst_plan_memory(b, 2, f, 0, BST_DOUBLE, 0, BST_DOUBLE, &nd);
    ck_assert_uint_eq(nd, 4);
    tu_assert_close(need, base + cells * (4 * 8.0 + 8.0), 1e-15, 1);
    need = bst_plan_memory(b, 2, f, 0, BST_FLOAT, 1, BST_FLOAT, &nd);
    tu_assert_close(need, base + cells * (4 * 4.0 + 12.0), 1e-15, 1);
    need = bst_plan_memory(b, 2, f, BST_COMP_BIT(BST_TF), BST_DOUBLE, 1, BST_DOUBLE, &nd);
    ck_assert_uint_eq(nd, 1);
    tu_assert_close(need, base + cells * (8.0 + 24.0), 1e-15, 1);
    /* panes only: the base */
    const bst_bsdf *none[2] = {NULL, NULL};
    tu_assert_close(bst_plan_memory(b, 2, none, 0, BST_DOUBLE, 1, BST_DOUBLE, &nd), base, 1e-15, 1);
    ck_assert_uint_eq(nd, 0);
    bst_basis_free(b);
    bst_bsdf_free(diff);
}
END_TEST

/* The components of l that are dense and factored, all channels together. */
static void count_made(const bst_layer *l, size_t *dense, size_t *factored, size_t *plus)
{
    *dense = *factored = *plus = 0;
    for (size_t ch = 0; ch < bst_layer_nchannels(l); ch++)
        for (int c = 0; c < BST_NCOMP; c++) {
            bst_structure s = bst_mat_structure(bst_layer_get(l, ch, (bst_comp)c));
            *dense += s == BST_DENSE;
            *factored += s == BST_FACTORED;
            *plus += s == BST_PLUS_LR;
        }
}

/* A shade spec's plan at order k with the channels given (NULL: the default two), checked
 * against the layer the model then makes: as many dense and factored components (venetian
 * blinds, perforated screens and woven fabrics alike). */
static bst_plan_held plan_of(const char *spec, int k, size_t nch, const char *const *names)
{
    bst_shade_model m;
    bst_basis *b;
    bst_plan_held h;
    ck_assert_int_eq(bst_basis_new_sc(ctx, k, &b), BST_OK);
    ck_assert_msg(bst_shade_parse(ctx, spec, NULL, &m) >= 0, "%s", bst_ctx_message(ctx));
    ck_assert_int_eq(bst_shade_model_plan(ctx, &m, b, nch, names, &h), BST_OK);
    ck_assert_ptr_null(h.file);
    ck_assert_uint_eq(h.nchannels, nch ? nch : 2);
    {
        bst_layer *l;
        size_t dense, factored, plus;
        ck_assert_int_eq(bst_shade_model_layer(ctx, &m, b, nch, names, &l), BST_OK);
        count_made(l, &dense, &factored, &plus);
        ck_assert_msg(dense == h.dense && factored == h.factored && plus == h.plus, "%s at k = %d: "
                      "made %zu dense %zu factored %zu sparse + low rank, planned %zu, %zu and %zu",
                      spec, k, dense, factored, plus, h.dense, h.factored, h.plus);
        bst_layer_free(l);
    }
    bst_basis_free(b);
    return h;
}

/* What shade layers will hold, by their model's rules (bsdfstack.h, bst_shade_model_plan), and
 * the same as the venetian layers made hold. */
START_TEST(test_shade_plan)
{
    const char *vis[1] = {"Visible"}, *both[2] = {"Solar", "Visible"};
    bst_plan_held h = plan_of("venetian:width=16mm,spacing=14.5mm,rs=0.765,r=0.085", 3, 0, NULL);
    ck_assert(h.dense == 8 && h.factored == 0); /* a mirror part: dense */
    h = plan_of("venetian:width=16mm,spacing=14.5mm,r=0.7", 4, 0, NULL);
    ck_assert(h.dense == 0 && h.factored == 8 && h.width == 64); /* matte: factored, 8 x 8 strips */
    h = plan_of("venetian:width=16mm,spacing=14.5mm,r=0.7", 2, 0, NULL); /* N = 16: 64 >= N / 2 */
    ck_assert(h.dense == 8 && h.factored == 0);
    h = plan_of("venetian:width=16mm,spacing=14.5mm,r=0.7,segments=2", 3, 1, vis);
    ck_assert(h.dense == 0 && h.factored == 4 && h.width == 16); /* N = 64: 16 < N / 2 */
    h = plan_of("venetian:width=16mm,spacing=14.5mm,r=0.7,rs=0/0.3", 4, 2, both);
    ck_assert(h.dense == 0 && h.factored == 4 && h.plus == 4); /* the Solar channel has a mirror
                                                   part: sparse + rank 16 (N = 256: 2 x 16 < N / 4) */
    h = plan_of("venetian:width=16mm,spacing=14.5mm,rs=0.765,r=0.085", 4, 0, NULL);
    ck_assert(h.dense == 0 && h.factored == 0 && h.plus == 8); /* the same in both channels */
    h = plan_of("venetian:width=16mm,spacing=14.5mm,rs=0.9", 3, 0, NULL);
    ck_assert(h.dense == 0 && h.factored == 0); /* mirror slats: sparse */
    h = plan_of("venetian:width=16mm,spacing=14.5mm,r=0.7,rule=centre", 3, 0, NULL);
    ck_assert(h.dense == 8 && h.factored == 0); /* WINDOW's model: dense */
    ck_assert_int_eq(h.precision, BST_DOUBLE);
    h = plan_of("perforated:x=5mm,y=5mm,radius=1mm,r=0.7", 3, 0, NULL);
    ck_assert(h.dense == 0 && h.factored == 8 && h.width == 5);
    h = plan_of("perforated:x=5mm,y=5mm,radius=1mm,r=0/0.2", 3, 1, vis);
    ck_assert(h.dense == 0 && h.factored == 0); /* black in Visible: the open share, diagonal */
    h = plan_of("woven:diameter=0.5mm,spacing=2mm,r=0.7,t=0.1,rule=centre", 3, 0, NULL);
    ck_assert(h.dense == 0 && h.factored == 8);
    bst_shade_model m;
    ck_assert_int_eq(bst_shade_model_plan(ctx, &m, NULL, 0, NULL, &h), BST_EINVAL);
}
END_TEST

/* The model over made layers (bsdfstack.h, bst_plan_memory_held) against its closed form at
 * k = 4 (N = 256): dense made components count as doubles; factored ones their own size and, with
 * no dense component, the writer's one grid of doubles and 64 MiB of column blocks (the results
 * stay factored; the writer expands one component at a time). */
START_TEST(test_memory_held)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &b), BST_OK);
    bst_bsdf *diff = read_ref("L_diffuser_t3k5.xml"); /* one channel, four dense components */
    double N = 256.0, cells = N * N, base = 64.0 * 1048576.0 + 0.5 * cells;
    bst_plan_need need;
    /* a pane, a dual-band specular blind (8 dense), a pane: 8 doubles and 3 of work */
    bst_plan_held sp[3] = {{0}, {.nchannels = 2, .dense = 8}, {0}};
    tu_assert_close(bst_plan_memory_held(b, 3, sp, 0, BST_FLOAT, 1, BST_FLOAT, &need),
                    base + cells * (8 * 8.0 + 3 * 4.0), 1e-15, 1);
    ck_assert(need.dense == 8 && need.expanded == 0);
    tu_assert_close(need.dense_bytes, 64.0 * cells, 1e-15, 1);
    /* the same blind made in floats (bst_venetian's precision, as the program makes it under
     * --precision single): 8 floats */
    sp[1].precision = BST_FLOAT;
    tu_assert_close(bst_plan_memory_held(b, 3, sp, 0, BST_FLOAT, 1, BST_FLOAT, &need),
                    base + cells * (8 * 4.0 + 3 * 4.0), 1e-15, 1);
    tu_assert_close(need.dense_bytes, 32.0 * cells, 1e-15, 1);
    /* and the diffuser read in single precision beside it */
    bst_plan_held sd[2] = {{.file = diff}, {.nchannels = 2, .dense = 8}};
    tu_assert_close(bst_plan_memory_held(b, 2, sd, 0, BST_FLOAT, 1, BST_DOUBLE, &need),
                    base + cells * (4 * 4.0 + 8 * 8.0 + 3 * 8.0), 1e-15, 1);
    ck_assert_uint_eq(need.dense, 12);
    /* a matte blind (8 factored over 64 columns) between panes: its own size, the writer's grid
     * of doubles and the column blocks, in either precision */
    double small = 8 * 8.0 * (N + 64.0 * 64.0) + 2 * 16.0 * N * 64.0, blocks = 64.0 * 1048576.0;
    bst_plan_held mt[3] = {{0}, {.nchannels = 2, .factored = 8, .width = 64}, {0}};
    tu_assert_close(bst_plan_memory_held(b, 3, mt, 0, BST_DOUBLE, 1, BST_DOUBLE, &need),
                    base + small + blocks + 8.0 * cells, 1e-15, 1);
    ck_assert(need.dense == 0 && need.expanded == 1);
    tu_assert_close(need.expanded_bytes, 8.0 * cells, 1e-15, 1);
    tu_assert_close(bst_plan_memory_held(b, 3, mt, 0, BST_DOUBLE, 1, BST_FLOAT, &need),
                    base + small + blocks + 8.0 * cells, 1e-15, 1);
    /* not combined (convert): the same grid */
    tu_assert_close(bst_plan_memory_held(b, 1, mt + 1, 0, BST_FLOAT, 0, BST_FLOAT, &need),
                    base + small + blocks + 8.0 * cells, 1e-15, 1);
    ck_assert_uint_eq(need.expanded, 1);
    /* bst_plan_memory is the same model over files */
    const bst_bsdf *f[2] = {NULL, diff};
    bst_plan_held hf[2] = {{0}, {.file = diff}};
    size_t nd;
    tu_assert_close(bst_plan_memory(b, 2, f, 0, BST_DOUBLE, 1, BST_DOUBLE, &nd),
                    bst_plan_memory_held(b, 2, hf, 0, BST_DOUBLE, 1, BST_DOUBLE, NULL), 1e-15, 1);
    bst_bsdf_free(diff);
    bst_basis_free(b);
}
END_TEST

/* The work model: the partial system takes the widest structure so far. */
START_TEST(test_work)
{
    double N = 256.0, w[3];
    const bst_structure panes[2] = {BST_DIAG, BST_DIAG};
    tu_assert_close(bst_plan_work(2, panes, 256, w), N, 1e-15, 1);
    tu_assert_close(w[0], N, 1e-15, 1);
    /* a dense layer between panes: both steps dense (the partial stays dense) */
    const bst_structure shade[3] = {BST_DIAG, BST_DENSE, BST_DIAG};
    tu_assert_close(bst_plan_work(3, shade, 256, w), 2 * N * N * N, 1e-15, 1);
    tu_assert_close(w[1], N * N * N, 1e-15, 1);
    /* a specular tree first: sparse, then sparse again */
    const bst_structure spec[3] = {BST_SPARSE, BST_DIAG, BST_DIAG};
    tu_assert_close(bst_plan_work(3, spec, 256, NULL), 2 * N * N, 1e-15, 1);
    /* one layer: no step */
    tu_assert_close(bst_plan_work(1, spec, 256, w), 0.0, 0.0, 1);
    /* the costliest stacks first: dense beats sparse beats diagonal at any N > 1 */
    ck_assert(bst_plan_work(3, shade, 145, NULL) > bst_plan_work(3, spec, 145, NULL));
    ck_assert(bst_plan_work(3, spec, 145, NULL) > bst_plan_work(2, panes, 145, NULL));
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("plan");
    TCase *tc = tcase_create("decisions");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, test_basis_rule);
    tcase_add_test(tc, test_spectral_plan);
    tcase_add_test(tc, test_memory);
    tcase_add_test(tc, test_shade_plan);
    tcase_add_test(tc, test_memory_held);
    tcase_add_test(tc, test_work);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return tu_run(suite()); }
