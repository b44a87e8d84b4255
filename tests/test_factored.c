/* test_factored.c - layers held factored (issue #31): a rank-4 tree of depth d read at k > d is
 * P M_d P^T, and stacks of such layers with panes, dense layers and reversed layers combine to
 * what the dense path (force_dense, the old baseline) gives, every component, both precisions
 * (1e-10 relative in double, 1e-5 in single); the steps say they ran factored; absorptance and
 * the iterated columns agree too.  The coarse trees are made here from the reference blinds
 * (read at k = 3 or 4, written as TensorTree4 files of that depth). */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "mat.h"
#include "testutil.h"
#include "write_bound.h"

static bst_ctx *ctx;
static char coarse3[64], coarse4[64]; /* blind0 at depth 3, blind45 at depth 4 */
static char iso3[64];                 /* the diffuser as a TensorTree3 of depth 3 */
static char glass3[64];                /* the clear pane's tree at depth 3: sparse there */
static char glass4[64];                /* and at depth 4 */

/* The reference file read at order k and written as a tree of that depth and rank (every value). */
static void make_tree(const char *ref, int k, bst_tree_rank rank, char *path)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, k, &b), BST_OK);
    bst_layer *l = tu_layer(ctx, ref, b);
    snprintf(path, 64, "/tmp/bst_factored_XXXXXX");
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    close(fd);
    bst_bsdf_write_opts o;
    bst_bsdf_write_opts_init(&o);
    o.rank = rank;
    o.reduce_pct = -1.0;
    o.digits = 0;
    ck_assert_int_eq(bst_bsdf_write_path(ctx, l, path, &o), BST_OK);
    bst_layer_free(l);
    bst_basis_free(b);
}

static void setup(void)
{
    ctx = bst_ctx_new();
    make_tree("L_blind0_t4k5.xml", 3, BST_RANK_4, coarse3);
    make_tree("L_blind45_t4k5.xml", 4, BST_RANK_4, coarse4);
    make_tree("L_diffuser_t3k5.xml", 3, BST_RANK_3, iso3);
    make_tree("L_glass_t4k5.xml", 3, BST_RANK_4, glass3);
    make_tree("L_glass_t4k5.xml", 4, BST_RANK_4, glass4);
}

static void teardown(void)
{
    unlink(coarse3), unlink(coarse4), unlink(iso3), unlink(glass3), unlink(glass4);
    bst_ctx_free(ctx);
}

static bst_layer *file_layer_rule(const char *path, const bst_basis *b, bst_rank3_rule rule)
{
    bst_bsdf *f;
    ck_assert_int_ge(bst_bsdf_read(ctx, path, NULL, &f), 0);
    ck_assert_int_eq(bst_bsdf_set_rank3_rule(ctx, f, rule), BST_OK);
    bst_layer *l;
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, f, b, &l), BST_OK);
    bst_bsdf_free(f);
    return l;
}

static bst_layer *file_layer(const char *path, const bst_basis *b)
{
    return file_layer_rule(path, b, BST_RANK3_EXACT);
}

static int factored_steps, plus_steps;
static size_t max_rank;
static void count_factored(const bst_stack_step *s, void *opaque)
{
    (void)opaque;
    factored_steps += s->structure == BST_FACTORED;
    plus_steps += s->structure == BST_PLUS_LR;
    max_rank = s->rank > max_rank ? s->rank : max_rank;
}

/* max |a - b| / max |b| of two matrices' values. */
static double rel_diff(const bst_mat *a, const bst_mat *b)
{
    size_t n = bst_mat_rows(b) * bst_mat_cols(b);
    double *x = malloc(n * sizeof *x), *y = malloc(n * sizeof *y), d = 0, m = 0;
    ck_assert_int_eq(bst_mat_to_dense_array(ctx, a, x), BST_OK);
    ck_assert_int_eq(bst_mat_to_dense_array(ctx, b, y), BST_OK);
    for (size_t i = 0; i < n; i++)
        d = fmax(d, fabs(x[i] - y[i])), m = fmax(m, fabs(y[i]));
    free(x), free(y);
    return m > 0 ? d / m : d;
}

/* The stacks (exterior first): 'g' a pane, '3' blind0 at depth 3, '4' blind45 at depth 4, 'D' the
 * blind at its own depth 5 (dense at k = 5), 'K' a Klems diffuser, 'I' the diffuser as a rank-3
 * tree of depth 3 at its own order (BST_RANK3_NATIVE), 't' the pane's tree file at depth 3
 * (sparse, P K P^T beside a factored layer), 'T' the same at depth 4 (r = N / 4, as a k = 6 file
 * read at k = 7), 'v' a venetian blind of matte slats (MATTE_BLIND:
 * factored over its strips' map, rank 64; reversed, over the mirrored map); '^' after one:
 * reversed; 'm' the reference blind's geometry (MIXED_BLIND: a mirror part and diffuse slats,
 * PLUS_LR: sparse + rank 16). */
#define MIXED_BLIND "width=16mm,spacing=14.5mm,tilt=45,rs=0.765,r=0.085,roughness=0.02,samples=4"
#define MATTE_BLIND "width=16mm,spacing=14.5mm,tilt=45,r-up=0.7,r-down=0.4,t=0.05,samples=4"
static bst_layer *blind(const bst_basis *b, const char *spec)
{
    bst_venetian v;
    bst_layer *l;
    const char *ch = "Visible";
    ck_assert_int_eq(bst_venetian_parse(ctx, spec, &v), BST_OK);
    ck_assert_int_eq(bst_venetian_layer(ctx, &v, b, 1, &ch, &l), BST_OK);
    return l;
}

/* 'p' a perforated screen (diagonal + rank one over its channel's map), 'w' a woven fabric in
 * WINDOW's model (rule=centre: the uniform spread, rank one a component over a map of five). */
#define SCREEN "x=3mm,y=3mm,radius=1mm,thickness=1mm,r=0.6,t=0.05"
#define FABRIC "diameter=0.5mm,spacing=1.6mm,r=0.6,t=0.1,rule=centre"
static bst_layer *sheet(const char *kind, const bst_basis *b)
{
    const char *ch = "Visible";
    bst_layer *l;
    if (kind[0] == 'p') {
        bst_perforated p;
        ck_assert_int_eq(bst_perforated_parse(ctx, SCREEN, &p), BST_OK);
        ck_assert_int_eq(bst_perforated_layer(ctx, &p, b, 1, &ch, &l), BST_OK);
    } else {
        bst_woven w;
        ck_assert_int_eq(bst_woven_parse(ctx, FABRIC, &w), BST_OK);
        ck_assert_int_eq(bst_woven_layer(ctx, &w, b, 1, &ch, &l), BST_OK);
    }
    for (int c = 0; c < BST_NCOMP; c++) {
        const bst_mat *m = bst_layer_get(l, 0, (bst_comp)c);
        ck_assert_int_eq(bst_mat_structure(m), BST_FACTORED);
        ck_assert_uint_le(bsti_mat_rank(m), 5);
    }
    return l;
}

static const char *const stacks[] = {"g3", "3g", "g3g", "g4^g3", "gDg3", "g3^Kg", "34^", "gI^g",
                                     "t3t", "t4^gt", "gvg", "gv^g", "vgv^", "3vg", "gpg", "gw^g",
                                     "pgw", "pv", "T4^T", "gmg", "gm^g", "mg", "3mg", "gmKg",
                                     "gDm", "mvg"};
#define NSTACKS (sizeof stacks / sizeof stacks[0])

static size_t build(const char *spec, const bst_basis *b, bst_layer **layers)
{
    size_t n = 0;
    for (const char *c = spec; *c; c++) {
        if (*c == '^') {
            bst_layer *f;
            ck_assert_int_eq(bst_layer_flip(ctx, layers[n - 1], &f), BST_OK);
            bst_layer_free(layers[n - 1]);
            layers[n - 1] = f;
            continue;
        }
        layers[n++] = *c == 'g'   ? tu_layer(ctx, "glass:clear-6mm", b)
                      : *c == '3' ? file_layer(coarse3, b)
                      : *c == '4' ? file_layer(coarse4, b)
                      : *c == 't' ? file_layer(glass3, b)
                      : *c == 'T' ? file_layer(glass4, b)
                      : *c == 'D' ? tu_layer(ctx, "L_blind0_t4k5.xml", b)
                      : *c == 'I' ? file_layer_rule(iso3, b, BST_RANK3_NATIVE)
                      : *c == 'v' ? blind(b, MATTE_BLIND)
                      : *c == 'm' ? blind(b, MIXED_BLIND)
                      : *c == 'p' || *c == 'w' ? sheet(c, b)
                                  : tu_layer(ctx, "L_diffuser_t3k5_klems.xml", b);
    }
    return n;
}

START_TEST(test_layers)
{
    /* read at k = 5, depth 3: factored, rank 64, the values of the order-5 expansion */
    bst_basis *b5;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b5), BST_OK);
    bst_layer *l = file_layer(coarse3, b5);
    for (int c = 0; c < BST_NCOMP; c++) {
        const bst_mat *m = bst_layer_get(l, 0, (bst_comp)c);
        ck_assert_int_eq(bst_mat_structure(m), BST_FACTORED);
        ck_assert_uint_eq(bsti_mat_rank(m), 64);
        /* every fine cell holds its coarse cell's value */
        bst_basis *b3;
        ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &b3), BST_OK);
        bst_layer *c3 = file_layer(coarse3, b3);
        const bst_mat *m3 = bst_layer_get(c3, 0, (bst_comp)c);
        for (size_t y = 0; y < 1024; y += 37)
            for (size_t x = 0; x < 1024; x += 5) {
                size_t px = ((x / 32) >> 2) * 8 + ((x % 32) >> 2), py = ((y / 32) >> 2) * 8 + ((y % 32) >> 2);
                ck_assert_double_eq(bst_mat_get(m, x, y), bst_mat_get(m3, px, py));
            }
        bst_layer_free(c3);
        bst_basis_free(b3);
    }
    bst_layer_free(l);
    bst_basis_free(b5);
}
END_TEST

/* A venetian blind of matte slats: factored over its strips' map (4 x 16 lines: the views and
 * emissions of both sides), no mirror part; its values through the factors one by one
 * (bsti_lr_get) and expanded by GEMM (bsti_mat_lr_expand, as the writer and the stack take them)
 * agree, and the layer written and read back is the layer (to the single precision in which a
 * tree at its own order is read). */
START_TEST(test_matte_blind)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b), BST_OK);
    bst_layer *l = blind(b, MATTE_BLIND);
    for (int c = 0; c < BST_NCOMP; c++) {
        const bst_mat *m = bst_layer_get(l, 0, (bst_comp)c);
        ck_assert_int_eq(bst_mat_structure(m), BST_FACTORED);
        ck_assert_uint_eq(bsti_mat_rank(m), 64);
        ck_assert(bsti_mat_lr_wide(m));
        bst_mat *d; /* (rel_diff reads m through the same expansion: compare value by value) */
        ck_assert_int_eq(bsti_mat_lr_expand(ctx, m, BST_DOUBLE, &d), BST_OK);
        double dmax = 0, vmax = 0;
        for (size_t y = 0; y < 1024; y += 7)
            for (size_t x = 0; x < 1024; x += 3) {
                double v = bsti_lr_get(m->lr, x, y);
                dmax = fmax(dmax, fabs(v - bst_mat_get(d, x, y))), vmax = fmax(vmax, fabs(v));
            }
        ck_assert(vmax > 0);
        ck_assert_msg(dmax <= 1e-14 * vmax, "%s: %g", bst_comp_name((bst_comp)c), dmax / vmax);
        /* the readers' blocks of columns: from column 0 a block at a time, the expansion's columns
         * to the bit (the writer and bounds read them so); any columns, to rounding */
        size_t cols[5] = {1023, 0, 517, 3, 517};
        const double *all = bst_mat_dense_data(d);
        double *got = malloc(1024 * 1024 * sizeof *got);
        bsti_cols *rd;
        ck_assert_int_eq(bsti_cols_new(ctx, m, 1024, &rd), BST_OK);
        size_t nb = bsti_cols_block(rd);
        ck_assert_uint_ge(nb, 1);
        for (size_t j0 = 0; j0 < 1024; j0 += nb)
            bsti_cols_get(rd, NULL, j0, 1024 - j0 < nb ? 1024 - j0 : nb, got + j0 * 1024);
        ck_assert(memcmp(got, all, 1024 * 1024 * sizeof *got) == 0);
        bsti_cols_get(rd, cols, 0, 5, got);
        for (size_t t = 0; t < 5; t++)
            for (size_t x = 0; x < 1024; x++)
                ck_assert(fabs(got[t * 1024 + x] - all[cols[t] * 1024 + x]) <= 1e-14 * vmax);
        bsti_cols_free(rd);
        free(got);
        bst_mat_free(d);
    }
    char path[] = "/tmp/bst_matte_XXXXXX";
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    close(fd);
    bst_bsdf_write_opts wo;
    bst_bsdf_write_opts_init(&wo);
    wo.reduce_pct = -1; /* every value */
    wo.digits = 0;        /* as many as reading back exactly needs */
    wo.recip_tol = -1;    /* both transmissions stored (not one from the other) */
    ck_assert_int_eq(bst_bsdf_write_path(ctx, l, path, &wo), BST_OK);
    bst_bsdf *f;
    bst_layer *back;
    ck_assert_int_ge(bst_bsdf_read(ctx, path, NULL, &f), 0);
    unlink(path);
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, f, b, &back), BST_OK);
    bst_bsdf_free(f);
    for (int c = 0; c < BST_NCOMP; c++) {
        double d = rel_diff(bst_layer_get(back, 0, (bst_comp)c), bst_layer_get(l, 0, (bst_comp)c));
        /* (a tree at its own order is read as floats) */
        ck_assert_msg(d < 2e-7, "written %s: %g", bst_comp_name((bst_comp)c), d);
    }
    bst_layer_free(back), bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

START_TEST(test_stacks)
{
    const char *spec = stacks[_i % NSTACKS];
    bst_precision prec = _i < (int)NSTACKS ? BST_DOUBLE : BST_FLOAT;
    double tol = prec == BST_DOUBLE ? 1e-10 : 1e-5;
    bst_basis *b5;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b5), BST_OK);
    bst_layer *layers[8];
    size_t n = build(spec, b5, layers);
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    o.precision = prec;
    o.on_step = count_factored;
    factored_steps = plus_steps = 0;
    max_rank = 0;
    bst_layer *fact, *dense;
    ck_assert_int_ge(bst_stack_combine(ctx, n, (const bst_layer *const *)layers, &o, &fact), 0);
    if (strcmp(spec, "gmg") == 0 || strcmp(spec, "gm^g") == 0) {
        /* the first step at the strips' rank; the second's where its sums stay sparse (in single
           precision they are dense at k = 5, the low-rank part added into them) */
        ck_assert_int_ge(plus_steps, 4);
        ck_assert_uint_eq(max_rank, 16);
    }
    if (strcmp(spec, "g3") == 0 || strcmp(spec, "g3g") == 0 || strcmp(spec, "3g") == 0 ||
        strcmp(spec, "gI^g") == 0 || strcmp(spec, "gvg") == 0 || strcmp(spec, "gv^g") == 0 ||
        strcmp(spec, "gpg") == 0 || strcmp(spec, "gw^g") == 0)
        ck_assert_int_gt(factored_steps, 0);
    if (strcmp(spec, "gvg") == 0 || strcmp(spec, "gv^g") == 0 || strcmp(spec, "gpg") == 0 ||
        strcmp(spec, "gw^g") == 0) /* handed over factored (stack.c) */
        for (int c = 0; c < BST_NCOMP; c++)
            ck_assert(bsti_mat_lr_wide(bst_layer_get(fact, 0, (bst_comp)c)));
    if (spec[0] == 't' || spec[0] == 'T') { /* the sparse tree joins the factored shade (t3t
         * and T4^T: every component of every step, at the map's rank, 64 or 256: a step formed
         * from one factorization sums terms whose scalings differ by the projected solid angle,
         * L Tf1 + L Rb1 X2 say, in one block; at T4^T's r = N / 4 two would make N / 2, dense
         * (bsti_mat_lr_settle); t4^gt: the glass pane's scalings make a rank of N / 2, dense) */
        ck_assert_int_eq(bst_mat_structure(bst_layer_get(layers[0], 0, BST_TF)), BST_SPARSE);
        int all = strcmp(spec, "t4^gt") != 0;
        ck_assert_msg(factored_steps >= (all ? 4 * ((int)n - 1) : 1), "%s: %d components factored",
                      spec, factored_steps);
        if (all)
            ck_assert_uint_eq(max_rank, spec[0] == 't' ? 64 : 256);
    }
    o.force_dense = 1;
    ck_assert_int_ge(bst_stack_combine(ctx, n, (const bst_layer *const *)layers, &o, &dense), 0);
    for (int c = 0; c < BST_NCOMP; c++) {
        double d = rel_diff(bst_layer_get(fact, 0, (bst_comp)c), bst_layer_get(dense, 0, (bst_comp)c));
        ck_assert_msg(d < tol, "%s %s %s: %g", spec, prec == BST_DOUBLE ? "double" : "single",
                      bst_comp_name((bst_comp)c), d);
    }
    /* absorptance (double): the same per layer and incident patch */
    if (prec == BST_DOUBLE) {
        size_t N = 1024;
        double *af = malloc(4 * n * N * sizeof *af), *ad = af + 2 * n * N;
        o.force_dense = 0;
        ck_assert_int_ge(bst_stack_absorptance(ctx, n, (const bst_layer *const *)layers, 0, &o, af,
                                               af + n * N), 0);
        o.force_dense = 1;
        ck_assert_int_ge(bst_stack_absorptance(ctx, n, (const bst_layer *const *)layers, 0, &o, ad,
                                               ad + n * N), 0);
        for (size_t q = 0; q < 2 * n * N; q++)
            ck_assert_msg(fabs(af[q] - ad[q]) < 1e-10, "%s absorptance %zu: %g vs %g", spec, q,
                          af[q], ad[q]);
        free(af);
    }
    bst_layer_free(fact), bst_layer_free(dense);
    for (size_t i = 0; i < n; i++)
        bst_layer_free(layers[i]);
    bst_basis_free(b5);
}
END_TEST

/* The iterated columns (combine --incident) of a factored stack: those of the whole system. */
START_TEST(test_columns)
{
    bst_basis *b5;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b5), BST_OK);
    bst_layer *layers[8];
    size_t n = build("g3g", b5, layers);
    bst_layer *sys;
    ck_assert_int_ge(bst_stack_combine(ctx, n, (const bst_layer *const *)layers, NULL, &sys), 0);
    size_t cols[3] = {5, 300, 777};
    bst_columns_opts co;
    bst_columns_opts_init(&co);
    co.tol = 1e-13;
    bst_mat *tf, *rf, *want;
    ck_assert_int_ge(bst_stack_columns(ctx, n, (const bst_layer *const *)layers, NULL, 3, cols, &co,
                                       &tf, &rf), 0);
    ck_assert_int_eq(bst_mat_select_cols(ctx, bst_layer_get(sys, 0, BST_TF), 3, cols, &want), BST_OK);
    ck_assert_msg(rel_diff(tf, want) < 1e-9, "Tf columns: %g", rel_diff(tf, want));
    bst_mat_free(want);
    ck_assert_int_eq(bst_mat_select_cols(ctx, bst_layer_get(sys, 0, BST_RF), 3, cols, &want), BST_OK);
    ck_assert_msg(rel_diff(rf, want) < 1e-9, "Rf columns: %g", rel_diff(rf, want));
    bst_mat_free(want), bst_mat_free(tf), bst_mat_free(rf);
    bst_layer_free(sys);
    for (size_t i = 0; i < n; i++)
        bst_layer_free(layers[i]);
    bst_basis_free(b5);
}
END_TEST

/* src without its Transmission Back block, written to a temporary file (path: its name). */
static void without_tb(const char *src, char *path, size_t size)
{
    FILE *in = fopen(src, "r");
    ck_assert_ptr_nonnull(in);
    static char text[8 << 20];
    size_t len = fread(text, 1, sizeof text - 1, in);
    fclose(in);
    text[len] = 0;
    char *dir = strstr(text, "<WavelengthDataDirection>Transmission Back");
    ck_assert_ptr_nonnull(dir);
    char *from = dir, *to = strstr(dir, "</WavelengthData>");
    while (from > text && strncmp(from, "<WavelengthData>", 16) != 0)
        from--;
    ck_assert_ptr_nonnull(to);
    to += strlen("</WavelengthData>");
    memmove(from, to, strlen(to) + 1);
    snprintf(path, size, "/tmp/bst_no_tb_XXXXXX");
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    ck_assert_int_eq(write(fd, text, strlen(text)), (ssize_t)strlen(text));
    close(fd);
}

/* BST_RANK3_NATIVE: a rank-3 tree of depth 3 read at k = 5 is factored, rank 64, each fine cell
 * holding the value its order-3 cells have in the exact expansion at order 3; without the rule it
 * is sampled at order 5 (dense).  A file storing only Tf gets Tf's reciprocal as Tb, factored. */
START_TEST(test_rank3_native)
{
    bst_basis *b5, *b3;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b5), BST_OK);
    ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &b3), BST_OK);
    bst_layer *l = file_layer_rule(iso3, b5, BST_RANK3_NATIVE), *c3 = file_layer(iso3, b3);
    bst_layer *exact = file_layer(iso3, b5);
    for (int c = 0; c < BST_NCOMP; c++) {
        const bst_mat *m = bst_layer_get(l, 0, (bst_comp)c), *m3 = bst_layer_get(c3, 0, (bst_comp)c);
        ck_assert_int_eq(bst_mat_structure(m), BST_FACTORED);
        ck_assert_uint_eq(bsti_mat_rank(m), 64);
        ck_assert_int_eq(bst_mat_structure(bst_layer_get(exact, 0, (bst_comp)c)), BST_DENSE);
        for (size_t y = 0; y < 1024; y += 13)
            for (size_t x = 0; x < 1024; x += 7) {
                size_t px = ((x / 32) >> 2) * 8 + ((x % 32) >> 2), py = ((y / 32) >> 2) * 8 + ((y % 32) >> 2);
                ck_assert_double_eq_tol(bst_mat_get(m, x, y), bst_mat_get(m3, px, py),
                                        1e-13 * fabs(bst_mat_get(m3, px, py)));
            }
    }
    bst_layer_free(l), bst_layer_free(c3), bst_layer_free(exact);
    /* the same file without its Transmission Back: Tb(o, i) = Tf(a(i), a(o)) */
    char path[64];
    without_tb(iso3, path, sizeof path);
    l = file_layer_rule(path, b5, BST_RANK3_NATIVE);
    unlink(path);
    const bst_mat *tf = bst_layer_get(l, 0, BST_TF), *tb = bst_layer_get(l, 0, BST_TB);
    ck_assert_int_eq(bst_mat_structure(tb), BST_FACTORED);
    for (size_t i = 0; i < 1024; i += 11)
        for (size_t o = 0; o < 1024; o += 3) {
            double want = bst_mat_get(tf, bst_basis_antipode(b5, i), bst_basis_antipode(b5, o));
            ck_assert_double_eq_tol(bst_mat_get(tb, o, i), want, 1e-13 * fabs(want));
        }
    bst_layer_free(l);
    bst_basis_free(b5), bst_basis_free(b3);
}
END_TEST

/* A Klems file that stores only Tf: its Tb, by reciprocity, is factored too (W K' W^T, K' the
 * Klems reciprocal) and is exactly the grid's reciprocal of Tf, Tb(o, i) = Tf(a(i), a(o)) with a
 * the Shirley-Chiu antipode; the full file's stored Tb is not (measured data are not reciprocal),
 * so reading the Tb block, not reciprocity, would fail this. */
START_TEST(test_klems_reciprocal)
{
    char path[64];
    without_tb(tu_ref("L_diffuser_t3k5_klems.xml"), path, sizeof path);
    bst_basis *b5;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b5), BST_OK);
    bst_bsdf *f;
    ck_assert_int_ge(bst_bsdf_read(ctx, path, NULL, &f), 0);
    unlink(path);
    ck_assert_int_eq(bst_bsdf_stored(f, 0, BST_TB), 0);
    bst_layer *l;
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, f, b5, &l), BST_OK);
    bst_bsdf_free(f);
    const bst_mat *tf = bst_layer_get(l, 0, BST_TF), *tb = bst_layer_get(l, 0, BST_TB);
    ck_assert_int_eq(bst_mat_structure(tb), BST_FACTORED);
    ck_assert_int_eq(bst_mat_structure(tf), BST_FACTORED);
    size_t n = 1024;
    double *x = malloc(2 * n * n * sizeof *x), *y = x + n * n, d = 0, m = 0;
    ck_assert_ptr_nonnull(x);
    ck_assert_int_eq(bst_mat_to_dense_array(ctx, tf, x), BST_OK);
    ck_assert_int_eq(bst_mat_to_dense_array(ctx, tb, y), BST_OK);
    for (size_t i = 0; i < n; i++)
        for (size_t o = 0; o < n; o++) {
            double want = x[bst_basis_antipode(b5, i) + n * bst_basis_antipode(b5, o)];
            d = fmax(d, fabs(y[o + n * i] - want)), m = fmax(m, fabs(want));
        }
    ck_assert_msg(m > 0 && d <= 1e-12 * m, "Tb against Tf's reciprocal: %g of %g", d, m);
    free(x);
    bst_layer_free(l);
    bst_basis_free(b5);
}
END_TEST

/* Text written into a growing buffer. */
struct text {
    char *p;
    size_t n;
};

static int to_text(const char *buf, size_t len, void *opaque)
{
    struct text *t = opaque;
    char *p = realloc(t->p, t->n + len + 1);
    if (!p)
        return -1;
    t->p = p;
    memcpy(t->p + t->n, buf, len);
    t->n += len;
    t->p[t->n] = '\0'; /* (strstr reads it) */
    return 0;
}

/* Layer a written through context ca and layer b through cb with options o: the same bytes, at
 * least `least` of them (what: the message's words); a's text is returned, b's freed. */
static struct text same_file(bst_ctx *ca, const bst_layer *a, bst_ctx *cb, const bst_layer *b,
                             const bst_bsdf_write_opts *o, size_t least, const char *what)
{
    struct text ta = {NULL, 0}, tb = {NULL, 0};
    ck_assert_int_eq(bst_bsdf_write_fn(ca, a, to_text, &ta, o), BST_OK);
    ck_assert_int_eq(bst_bsdf_write_fn(cb, b, to_text, &tb, o), BST_OK);
    ck_assert_uint_gt(ta.n, least);
    ck_assert_uint_eq(ta.n, tb.n);
    ck_assert_msg(memcmp(ta.p, tb.p, ta.n) == 0, "%s: the files differ", what);
    free(tb.p);
    return ta;
}

/* An allocator that refuses every block of at least `refuse` bytes (the writer's expansion). */
static void *refusing_malloc(size_t size, void *opaque)
{
    return size >= *(const size_t *)opaque ? NULL : malloc(size);
}

static void plain_free(void *p, void *opaque)
{
    (void)opaque;
    free(p);
}

/* The reciprocity check of a factored system sys and of its expansion exp (N patches, one
 * channel): the same worst pair and error; the check's sums of the factored transmissions (the
 * writer's bound takes them) are the expanded matrices' sums to rounding, negatives read as 0;
 * none are made from dense ones. */
static void same_reciprocity(const bst_layer *sys, const bst_layer *exp, size_t N)
{
    double ef, ed;
    size_t fi, fo, di, dout;
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, sys, 0, &ef, &fi, &fo), BST_OK);
    ck_assert_int_eq(bst_metrics_reciprocity(ctx, exp, 0, &ed, &di, &dout), BST_OK);
    ck_assert_msg(ef == ed && fi == di && fo == dout && ef > 0, "reciprocity %.17g (%zu, %zu) vs "
                  "%.17g (%zu, %zu)", ef, fi, fo, ed, di, dout);
    double *ts = malloc(3 * N * sizeof *ts), es;
    bsti_tsums sums = {ts, ts + N, ts + 2 * N, 0};
    ck_assert_int_eq(bsti_reciprocity_sums(ctx, exp, 0, &es, &sums), BST_OK);
    ck_assert(es == ed && !sums.have);
    ck_assert_int_eq(bsti_reciprocity_sums(ctx, sys, 0, &es, &sums), BST_OK);
    ck_assert(es == ef && sums.have);
    const bst_mat *tf = bst_layer_get(exp, 0, BST_TF), *tb = bst_layer_get(exp, 0, BST_TB);
    for (size_t j = 0; j < N; j++) {
        double want[3] = {0.0, 0.0, 0.0}; /* Tf's column j, Tb's column j, Tb's row j */
        for (size_t o = 0; o < N; o++) {
            want[0] += fmax(bsti_mat_at(tf, o, j), 0.0);
            want[1] += fmax(bsti_mat_at(tb, o, j), 0.0);
            want[2] += fmax(bsti_mat_at(tb, j, o), 0.0);
        }
        const double got[3] = {sums.tf_col[j], sums.tb_col[j], sums.tb_row[j]};
        for (int t = 0; t < 3; t++)
            ck_assert_msg(fabs(got[t] - want[t]) <= 1e-12 * fmax(1.0, want[t]),
                          "sum %d of line %zu: %.17g vs %.17g", t, j, got[t], want[t]);
    }
    free(ts);
}

/* A factored system's tree: the writer expands a factored component to write it, or reads it
 * value by value through the factors when that memory is refused; the same bytes either way,
 * reduced (budgets, reciprocity: lines through the factors) and not. */
START_TEST(test_write_expanded)
{
    bst_basis *b5;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b5), BST_OK);
    bst_layer *layers[8];
    size_t n = build("g3g", b5, layers);
    bst_layer *sys;
    ck_assert_int_ge(bst_stack_combine(ctx, n, (const bst_layer *const *)layers, NULL, &sys), 0);
    ck_assert_int_eq(bst_mat_structure(bst_layer_get(sys, 0, BST_TB)), BST_FACTORED);
    size_t refuse = 1024 * 1024 * sizeof(double);
    bst_ctx *c2 = bst_ctx_new();
    ck_assert_int_eq(bst_ctx_set_allocator(c2, refusing_malloc, plain_free, &refuse), BST_OK);
    for (int reduce = 0; reduce < 2; reduce++) {
        bst_bsdf_write_opts o;
        bst_bsdf_write_opts_init(&o);
        o.rank = BST_RANK_4;
        o.date = "2026-11-28T00:00:00Z";
        if (!reduce)
            o.reduce_pct = -1.0;
        free(same_file(ctx, sys, c2, sys, &o, 100000,
                       reduce ? "reduced, expanded tree" : "expanded tree").p);
    }
    bst_ctx_free(c2);
    bst_layer_free(sys);
    for (size_t i = 0; i < n; i++)
        bst_layer_free(layers[i]);
    bst_basis_free(b5);
}
END_TEST

/* A stack with a matte venetian blind: its result stays FACTORED over the blind's wide map (no
 * expanded copy of each component is held: the readers take a block of columns at a time), and
 * every reader gives what it gives for the same layer with its components expanded (dense): the
 * file (byte for byte, reduced and not, rank chosen by the rotation test, Tf left out by
 * reciprocity or not), the reciprocity, GA and FA against the --dense system, the largest value,
 * the hemispherical values. */
START_TEST(test_wide_result)
{
    bst_basis *b5;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b5), BST_OK);
    bst_layer *layers[8], *sys, *ref, *exp;
    size_t n = build("gvg", b5, layers), N = 1024;
    bst_stack_opts so;
    bst_stack_opts_init(&so);
    so.precision = _i ? BST_FLOAT : BST_DOUBLE;
    ck_assert_int_ge(bst_stack_combine(ctx, n, (const bst_layer *const *)layers, &so, &sys), 0);
    so.force_dense = 1;
    ck_assert_int_ge(bst_stack_combine(ctx, n, (const bst_layer *const *)layers, &so, &ref), 0);
    const char *ch = bst_layer_channel(sys, 0);
    ck_assert_int_eq(bst_layer_new(ctx, b5, 1, &ch, &exp), BST_OK);
    for (int c = 0; c < BST_NCOMP; c++) {
        const bst_mat *m = bst_layer_get(sys, 0, (bst_comp)c);
        bst_mat *d;
        ck_assert_int_eq(bst_mat_structure(m), BST_FACTORED);
        ck_assert(bsti_mat_lr_wide(m));
        ck_assert_int_eq(bsti_mat_lr_expand(ctx, m, BST_DOUBLE, &d), BST_OK);
        ck_assert_double_eq(bst_mat_max_abs(m), bst_mat_max_abs(d));
        ck_assert_int_eq(bst_layer_set(ctx, exp, 0, (bst_comp)c, d), BST_OK);
        double hf[1024], hd[1024];
        ck_assert_int_eq(bst_layer_hemispherical(ctx, sys, 0, (bst_comp)c, hf), BST_OK);
        ck_assert_int_eq(bst_layer_hemispherical(ctx, exp, 0, (bst_comp)c, hd), BST_OK);
        for (size_t j = 0; j < N; j++)
            ck_assert_msg(fabs(hf[j] - hd[j]) <= 1e-12 * fmax(1.0, fabs(hd[j])), "%s %zu: %g vs %g",
                          bst_comp_name((bst_comp)c), j, hf[j], hd[j]);
        double *g[4];
        for (int t = 0; t < 4; t++)
            g[t] = malloc(N * sizeof *g[t]);
        ck_assert_int_eq(bst_metrics_accordance_all(ctx, sys, ref, 0, (bst_comp)c, g[0], g[1]), BST_OK);
        ck_assert_int_eq(bst_metrics_accordance_all(ctx, exp, ref, 0, (bst_comp)c, g[2], g[3]), BST_OK);
        ck_assert(memcmp(g[0], g[2], N * sizeof *g[0]) == 0 && memcmp(g[1], g[3], N * sizeof *g[1]) == 0);
        for (size_t j = 0; j < N; j++) /* the factored system is the --dense one */
            ck_assert_msg(g[0][j] > 99.99, "%s GA %zu: %g", bst_comp_name((bst_comp)c), j, g[0][j]);
        double la[1024], la2[1024], ga, ga2;
        ck_assert_int_eq(bst_metrics_accordance(ctx, sys, ref, 0, (bst_comp)c, 517, &ga, NULL, la), BST_OK);
        ck_assert_int_eq(bst_metrics_accordance(ctx, exp, ref, 0, (bst_comp)c, 517, &ga2, NULL, la2), BST_OK);
        ck_assert(fabs(ga - ga2) < 1e-9 && fabs(ga - g[0][517]) < 1e-9); /* (a lone column: GEMM's */
        for (size_t i = 0; i < N; i++)                                     /* rounding, mat.h) */
            ck_assert_msg(fabs(la[i] - la2[i]) < 1e-6, "LA %zu: %g vs %g", i, la[i], la2[i]);
        for (int t = 0; t < 4; t++)
            free(g[t]);
    }
    same_reciprocity(sys, exp, N);
    for (int reduce = 0; reduce < 2; reduce++)
        for (int recip = 0; recip < 2; recip++) {
            bst_bsdf_write_opts o;
            bst_bsdf_write_opts_init(&o);
            o.date = "2026-11-28T00:00:00Z";
            if (!reduce)
                o.reduce_pct = -1.0;
            if (!recip)
                o.recip_tol = -1.0;
            char what[32];
            snprintf(what, sizeof what, "reduce %d recip %d", reduce, recip);
            struct text a = same_file(ctx, sys, ctx, exp, &o, 10000, what);
            ck_assert(strstr(a.p, "TensorTree4") != NULL); /* the rotation test: not isotropic */
            if (!recip)
                ck_assert(strstr(a.p, "Transmission Front") != NULL);
            free(a.p);
        }
    /* refused the memory of a block of columns or of the one expanded component, the write fails
     * with a message instead of reading each value through the factors */
    size_t refuse = 4 * 1024 * 1024;
    bst_ctx *c2 = bst_ctx_new();
    ck_assert_int_eq(bst_ctx_set_allocator(c2, refusing_malloc, plain_free, &refuse), BST_OK);
    struct text t = {NULL, 0};
    ck_assert_int_eq(bst_bsdf_write_fn(c2, sys, to_text, &t, NULL), BST_ENOMEM);
    ck_assert(strstr(bst_ctx_message(c2), "out of memory") != NULL);
    free(t.p);
    bst_ctx_free(c2);
    bst_layer_free(sys), bst_layer_free(ref), bst_layer_free(exp);
    for (size_t i = 0; i < n; i++)
        bst_layer_free(layers[i]);
    bst_basis_free(b5);
}
END_TEST

/* A system of trees of order 3 combined at k = 5 (panes and blind, the blind either way round) is
 * of that order (bsti_mat_lr_coarse) in every component.  Read at that order (the reciprocity
 * check, its sums, the writer's budgets) it gives what its expansion gives at order 5: the same
 * worst pair and error, sums and budgets to rounding; and its file holds order-3 trees (the file's
 * order is 3) that read back at k = 5 are the system, value by value unreduced and within the
 * reduced tree's promise (every hemispherical value within 0.002). */
START_TEST(test_coarse_result)
{
    bst_basis *b5;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &b5), BST_OK);
    bst_layer *layers[8], *sys, *exp;
    size_t n = build(_i ? "t3^t" : "t3t", b5, layers), N = 1024;
    ck_assert_int_ge(bst_stack_combine(ctx, n, (const bst_layer *const *)layers, NULL, &sys), 0);
    const char *ch = bst_layer_channel(sys, 0);
    ck_assert_int_eq(bst_layer_new(ctx, b5, 1, &ch, &exp), BST_OK);
    for (int c = 0; c < BST_NCOMP; c++) {
        const bst_mat *m = bst_layer_get(sys, 0, (bst_comp)c);
        bst_mat *d;
        ck_assert_int_eq(bst_mat_structure(m), BST_FACTORED);
        ck_assert_int_eq(bsti_mat_lr_coarse(m), 3);
        ck_assert_int_eq(bsti_mat_to_dense(ctx, m, BST_DOUBLE, &d), BST_OK);
        ck_assert_int_eq(bst_layer_set(ctx, exp, 0, (bst_comp)c, d), BST_OK);
    }
    same_reciprocity(sys, exp, N);
    bsti_bounds bs, bd;
    int omit_s = 0, omit_d = 0;
    ck_assert_int_eq(bsti_bounds_layer(ctx, sys, 0.002, bsti_bounds_rho(5), &omit_s, NULL, &bs), BST_OK);
    ck_assert_int_eq(bsti_bounds_layer(ctx, exp, 0.002, bsti_bounds_rho(5), &omit_d, NULL, &bd), BST_OK);
    for (size_t i = 0; i < BST_NCOMP * N; i++)
        ck_assert_msg(fabs(bs.col[i] - bd.col[i]) <= 1e-14, "budget %zu: %.17g vs %.17g", i,
                      bs.col[i], bd.col[i]);
    bsti_bounds_free(ctx, &bs), bsti_bounds_free(ctx, &bd);
    for (int reduce = 0; reduce < 2; reduce++) {
        char path[64];
        snprintf(path, sizeof path, "/tmp/bst_factored_XXXXXX");
        int fd = mkstemp(path);
        ck_assert_int_ge(fd, 0);
        close(fd);
        bst_bsdf_write_opts o;
        bst_bsdf_write_opts_init(&o);
        if (!reduce)
            o.reduce_pct = -1.0, o.digits = 0;
        ck_assert_int_eq(bst_bsdf_write_path(ctx, sys, path, &o), BST_OK);
        bst_bsdf *f;
        bst_layer *back;
        ck_assert_int_ge(bst_bsdf_read(ctx, path, NULL, &f), 0);
        ck_assert_int_eq(bst_bsdf_order(f), 3);
        ck_assert_int_eq(bst_bsdf_to_layer(ctx, f, b5, &back), BST_OK);
        bst_bsdf_free(f);
        unlink(path);
        for (int c = 0; c < BST_NCOMP; c++) {
            const bst_mat *m = bst_layer_get(exp, 0, (bst_comp)c), *r = bst_layer_get(back, 0, (bst_comp)c);
            if (!reduce) {
                for (size_t y = 0; y < N; y++)
                    for (size_t x = 0; x < N; x++) {
                        double v = fmax(bsti_mat_at(m, x, y), 0.0), got = bst_mat_get(r, x, y);
                        ck_assert_msg(fabs(got - v) <= 1e-6 * v, "%s (%zu, %zu): %.9g vs %.9g",
                                      bst_comp_name((bst_comp)c), x, y, got, v);
                    }
                continue;
            }
            double hs[1024], hb[1024];
            ck_assert_int_eq(bst_layer_hemispherical(ctx, exp, 0, (bst_comp)c, hs), BST_OK);
            ck_assert_int_eq(bst_layer_hemispherical(ctx, back, 0, (bst_comp)c, hb), BST_OK);
            for (size_t j = 0; j < N; j++)
                ck_assert_msg(fabs(hs[j] - hb[j]) <= 0.002 + 1e-9, "%s hemispherical %zu: %g vs %g",
                              bst_comp_name((bst_comp)c), j, hb[j], hs[j]);
        }
        bst_layer_free(back);
    }
    bst_layer_free(sys), bst_layer_free(exp);
    for (size_t i = 0; i < n; i++)
        bst_layer_free(layers[i]);
    bst_basis_free(b5);
}
END_TEST

static double min_rcond;
static void note_rcond(const bst_stack_step *s, void *opaque)
{
    (void)opaque;
    min_rcond = fmin(min_rcond, s->rcond);
    factored_steps += s->structure == BST_FACTORED;
}

/* Near-perfect mirrors (diagonal, reflectance 1 - 1e-9) around a near-white Lambertian layer held
 * factored (P K P^T, K = rho / pi: reflectance 1 - 2e-9, transmittance 1e-9): both gaps'
 * inter-reflections are nearly singular.  The factored path (solves through the capacitance)
 * reports the condition the dense path does (each an estimate: within a factor of 10), gives the
 * same status (the ill-conditioning warning) and the dense path's values within the loss the
 * condition allows. */
START_TEST(test_near_mirrors)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &b), BST_OK);
    size_t N = bst_basis_size(b);
    const double *lam = bst_basis_lambda(b), pi = acos(-1.0);
    const char *vis = "Visible";
    bsti_lr_map *S;
    ck_assert_int_eq(bsti_lr_map_prolong(ctx, 3, 1, &S), BST_OK);
    bst_layer *mirror, *white;
    ck_assert_int_eq(bst_layer_new(ctx, b, 1, &vis, &mirror), BST_OK);
    ck_assert_int_eq(bst_layer_new(ctx, b, 1, &vis, &white), BST_OK);
    double *d = malloc(N * sizeof *d), K[16];
    for (int c = 0; c < BST_NCOMP; c++) {
        int refl = c == BST_RF || c == BST_RB;
        for (size_t x = 0; x < N; x++)
            d[x] = (refl ? 1.0 - 1e-9 : 1e-9) / lam[x];
        bst_mat *m;
        ck_assert_int_eq(bst_mat_new_diag(ctx, N, d, &m), BST_OK);
        ck_assert_int_eq(bst_layer_set(ctx, mirror, 0, (bst_comp)c, m), BST_OK);
        for (int i = 0; i < 16; i++)
            K[i] = (refl ? 1.0 - 2e-9 : 1e-9) / pi;
        bsti_lr *lr;
        ck_assert_int_eq(bsti_lr_new(ctx, S, NULL, NULL, K, NULL, &lr), BST_OK);
        ck_assert_int_eq(bsti_mat_from_lr(ctx, lr, &m), BST_OK);
        ck_assert_int_eq(bst_layer_set(ctx, white, 0, (bst_comp)c, m), BST_OK);
    }
    const bst_layer *layers[3] = {mirror, white, mirror};
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    o.on_step = note_rcond;
    bst_layer *fact, *dense;
    double rc[2];
    int st[2];
    for (int k = 0; k < 2; k++) {
        o.force_dense = k;
        min_rcond = 1.0, factored_steps = 0;
        st[k] = bst_stack_combine(ctx, 3, layers, &o, k ? &dense : &fact);
        rc[k] = min_rcond;
        if (!k)
            ck_assert_int_eq(factored_steps, 8);
    }
    ck_assert_int_eq(st[0], st[1]);
    ck_assert_int_eq(st[0], BST_WILLCOND);
    ck_assert_msg(rc[0] < 1e-6 && rc[0] > 0.1 * rc[1] && rc[0] < 10 * rc[1], "rcond %g, dense %g",
                  rc[0], rc[1]);
    for (int c = 0; c < BST_NCOMP; c++) {
        double dd = rel_diff(bst_layer_get(fact, 0, (bst_comp)c), bst_layer_get(dense, 0, (bst_comp)c));
        ck_assert_msg(dd < 1e-15 / rc[1], "%s: %g (rcond %g)", bst_comp_name((bst_comp)c), dd, rc[1]);
    }
    free(d);
    bsti_lr_map_free(ctx, S);
    bst_layer_free(fact), bst_layer_free(dense), bst_layer_free(mirror), bst_layer_free(white);
    bst_basis_free(b);
}
END_TEST

static Suite *suite(void)
{
    Suite *s = suite_create("factored");
    TCase *tc = tcase_create("stacks");
    tcase_add_unchecked_fixture(tc, setup, teardown); /* the coarse files once */
    tcase_set_timeout(tc, 300);
    tcase_add_test(tc, test_layers);
    tcase_add_test(tc, test_matte_blind);
    tcase_add_loop_test(tc, test_stacks, 0, (int)(2 * NSTACKS));
    tcase_add_test(tc, test_columns);
    tcase_add_test(tc, test_klems_reciprocal);
    tcase_add_test(tc, test_rank3_native);
    tcase_add_test(tc, test_write_expanded);
    tcase_add_loop_test(tc, test_wide_result, 0, 2);
    tcase_add_loop_test(tc, test_coarse_result, 0, 2);
    tcase_add_test(tc, test_near_mirrors);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return tu_run(suite()); }
