/* test_resample.c - Klems <-> Shirley-Chiu resampling (resample.c) keeps light.
 *
 * - The overlap table against closed forms (a cell's fractions add to 1; a patch's cells add to its
 *   projected solid angle pi (sin^2 theta_1 - sin^2 theta_0) / n_phi) and against an independent
 *   count of sample points, for the full, half and quarter bases at every order.
 * - A uniform (Lambertian) Klems file stays uniform at every order and basis: T = pi f at every
 *   incident cell, every value f.
 * - The reference Klems layers: every incident cell's directional-hemispherical T and R equal the
 *   overlap-weighted mean of the Klems patches' (1e-9), and back on the Klems basis the file's
 *   bi-hemispherical totals come back to 1e-9.  Per patch the totals cannot all come back: a cell
 *   that straddles a patch boundary holds the mean of both patches' values (the first property), and
 *   the patch's average over its cells mixes that mean in again, so a patch's total comes back as a
 *   convex combination of its own and its neighbours', with weight s_p = sum_i w_ip^2 / A_p on its
 *   own.  That is asserted: |H'_p - H_p| <= (1 - s_p) max |H_p' - H_p| over the neighbours p'.
 * - A stack: pane + Klems diffuser + pane on the tree basis against the same stack in the Klems
 *   basis and with the diffuser's own tensor tree (see test_stack_klems_shade for the bound). */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "basis.h"
#include "bsdf.h"
#include "resample.h"
#include "testutil.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static const char *const klems_bases[] = {"full", "half", "quarter"};
static const char *const klems_refs[] = {"L_glass_t4k5_klems.xml", "L_blind0_t4k5_klems.xml",
                                         "L_blind45_t4k5_klems.xml", "L_diffuser_t3k5_klems.xml",
                                         "L_blind0_t4k6_klems.xml"};

static bst_bsdf *read_ok(const char *path)
{
    bst_bsdf *b;
    int rc = bst_bsdf_read(ctx, path, NULL, &b);
    ck_assert_msg(rc >= 0, "%s", bst_ctx_message(ctx));
    return b;
}

/* ------------------------------------------------------------------ the overlap table */

/* Closed forms at every order and basis; an independent count of S x S points per cell, mapped
 * to directions by the concentric map and looked up with bst_basis_patch, at k = 1..4 (a point
 * count misses a fraction by at most the cell's boundary length over S). */
START_TEST(test_overlap_table)
{
    const int S = 128;
    for (int q = 0; q < 3; q++) {
        bst_basis *kb;
        ck_assert_int_eq(bst_basis_new_klems(ctx, klems_bases[q], &kb), BST_OK);
        size_t nk = bst_basis_size(kb);
        const double *lk = bst_basis_lambda(kb);
        double *count = malloc(nk * sizeof *count);
        for (int k = BST_K_MIN; k <= BST_K_MAX; k++) {
            bsti_overlap *ov;
            ck_assert_int_eq(bsti_overlap_new(ctx, k, kb, &ov), BST_OK);
            size_t n = ov->n, G = (size_t)1 << k;
            ck_assert_uint_eq(n, G * G);
            ck_assert_uint_eq(ov->nk, nk);
            for (size_t c = 0; c < n; c++) {
                double s = 0;
                for (size_t e = ov->first[c]; e < ov->first[c + 1]; e++) {
                    ck_assert(ov->w[e] > 0 && ov->w[e] <= 1 + 1e-12);
                    s += ov->w[e];
                }
                tu_assert_close(s, 1.0, 1e-12, 1.0);
            }
            for (size_t p = 0; p < nk; p++) {
                double band_lo = 0, band_hi = 0;
                int nphi = 0;
                for (size_t b = 0; b < kb->nbands; b++)
                    if (p >= kb->first[b] && p < kb->first[b + 1])
                        band_lo = kb->theta[b], band_hi = kb->theta[b + 1], nphi = kb->nphi[b];
                double s0 = sin(band_lo * M_PI / 180), s1 = sin(band_hi * M_PI / 180);
                double closed = M_PI * (s1 * s1 - s0 * s0) / nphi;
                tu_assert_close(ov->area[p] * M_PI / (double)n, closed, 1e-11, closed);
                tu_assert_close(lk[p], closed, 1e-11, closed);
            }
            for (size_t c = 0; k <= 4 && c < n; c++) {
                memset(count, 0, nk * sizeof *count);
                for (int u = 0; u < S; u++)
                    for (int v = 0; v < S; v++) {
                        double d[3];
                        bsti_sc_square_to_disk(((double)(c / G) + (u + 0.5) / S) / (double)G,
                                               ((double)(c % G) + (v + 0.5) / S) / (double)G, &d[0], &d[1]);
                        d[2] = sqrt(fmax(0.0, 1 - d[0] * d[0] - d[1] * d[1]));
                        count[bst_basis_patch(kb, d)] += 1.0 / (S * S);
                    }
                for (size_t e = ov->first[c]; e < ov->first[c + 1]; e++) {
                    ck_assert_msg(fabs(ov->w[e] - count[ov->patch[e]]) <= 4.0 / S,
                                  "%s k %d cell %zu patch %zu: %.5f vs %.5f", klems_bases[q], k, c,
                                  ov->patch[e], ov->w[e], count[ov->patch[e]]);
                    count[ov->patch[e]] = 0;
                }
                for (size_t p = 0; p < nk; p++) /* no patch the table leaves out */
                    ck_assert_msg(count[p] <= 4.0 / S, "%s k %d cell %zu misses patch %zu (%.4f)",
                                  klems_bases[q], k, c, p, count[p]);
            }
            bsti_overlap_free(ov);
        }
        free(count);
        bst_basis_free(kb);
    }
    bsti_overlap *ov;
    bst_basis *sc;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &sc), BST_OK);
    ck_assert_int_eq(bsti_overlap_new(ctx, 3, sc, &ov), BST_EINVAL);
    ck_assert_ptr_null(ov);
    bst_basis_free(sc);
}
END_TEST

/* ------------------------------------------------------------------ uniform BSDFs */

/* A Klems file with every component uniform (Tf = Rb = ft, Rf = Tb = fr), written by the writer
 * (its values are exact in binary and decimal). */
static void write_uniform_klems(const char *which, double ft, double fr, char *path, size_t size)
{
    bst_basis *kb;
    bst_layer *l;
    const char *ch = "Visible";
    ck_assert_int_eq(bst_basis_new_klems(ctx, which, &kb), BST_OK);
    size_t nk = bst_basis_size(kb);
    ck_assert_int_eq(bst_layer_new(ctx, kb, 1, &ch, &l), BST_OK);
    for (int c = 0; c < BST_NCOMP; c++) {
        bst_mat *m;
        ck_assert_int_eq(bst_mat_new_dense(ctx, nk, nk, BST_DOUBLE, &m), BST_OK);
        double *d = bst_mat_dense_data(m);
        for (size_t q = 0; q < nk * nk; q++)
            d[q] = c == BST_TF || c == BST_RB ? ft : fr;
        ck_assert_int_eq(bst_layer_set(ctx, l, 0, (bst_comp)c, m), BST_OK);
    }
    snprintf(path, size, "/tmp/bst_uniform_%s_XXXXXX", which);
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    close(fd);
    ck_assert_int_eq(bst_bsdf_write_path(ctx, l, path, NULL), BST_OK);
    bst_layer_free(l);
    bst_basis_free(kb);
}

/* Every order 1..7 and every Klems basis: every value of the resampled Tf and Rf is the file's
 * (so every incident cell keeps T = pi f); order 7 goes through the internal entry point
 * (one 2 GiB work matrix, no layer), the others through bst_bsdf_to_layer. */
START_TEST(test_uniform_klems)
{
    const double ft = 0.125, fr = 0.0625;
    for (int q = 0; q < 3; q++) {
        char path[64];
        write_uniform_klems(klems_bases[q], ft, fr, path, sizeof path);
        bst_bsdf *b = read_ok(path);
        unlink(path);
        for (int k = BST_K_MIN; k <= BST_K_MAX; k++) {
            bst_basis *sc;
            ck_assert_int_eq(bst_basis_new_sc(ctx, k, &sc), BST_OK);
            size_t n = bst_basis_size(sc);
            if (k < BST_K_MAX) {
                bst_layer *l;
                ck_assert_int_eq(bst_bsdf_to_layer(ctx, b, sc, &l), BST_OK);
                for (int c = 0; c < BST_NCOMP; c++) {
                    double *h = malloc(n * sizeof *h), f = c == BST_TF || c == BST_RB ? ft : fr;
                    const bst_mat *m = bst_layer_get(l, 0, (bst_comp)c);
                    for (size_t i = 0; i < n; i += 7)
                        for (size_t o = 0; o < n; o++)
                            tu_assert_close(bst_mat_get(m, o, i), f, 1e-13, f);
                    ck_assert_int_eq(bst_layer_hemispherical(ctx, l, 0, (bst_comp)c, h), BST_OK);
                    for (size_t i = 0; i < n; i++)
                        tu_assert_close(h[i], M_PI * f, 1e-12, 1.0);
                    free(h);
                }
                bst_layer_free(l);
            } else {
                double *work = malloc(n * n * sizeof *work);
                ck_assert_ptr_nonnull(work);
                int recip;
                ck_assert_int_eq(bsti_resample_component(ctx, b, 0, BST_TF, sc, work, &recip), BST_OK);
                ck_assert_int_eq(recip, 0);
                double worst = 0;
                for (size_t i = 0; i < n; i++) {
                    double h = 0;
                    for (size_t o = 0; o < n; o++) {
                        worst = fmax(worst, fabs(work[o + n * i] - ft));
                        h += work[o + n * i] * M_PI / (double)n;
                    }
                    tu_assert_close(h, M_PI * ft, 1e-12, 1.0);
                }
                ck_assert_double_le(worst, 1e-12 * ft);
                free(work);
            }
            bst_basis_free(sc);
        }
        bst_bsdf_free(b);
    }
}
END_TEST

/* ------------------------------------------------------------------ the reference Klems layers */

/* The Klems patches that share a cell with p (mark[p'] = 1), and s_p. */
static double neighbours(const bsti_overlap *ov, size_t p, char *mark)
{
    double s = 0;
    memset(mark, 0, ov->nk);
    for (size_t c = 0; c < ov->n; c++) {
        double wp = 0;
        for (size_t e = ov->first[c]; e < ov->first[c + 1]; e++)
            if (ov->patch[e] == p)
                wp = ov->w[e];
        if (wp == 0)
            continue;
        s += wp * wp;
        for (size_t e = ov->first[c]; e < ov->first[c + 1]; e++)
            mark[ov->patch[e]] = 1;
    }
    return s / ov->area[p];
}

/* One file, one order: the incident cells' totals against the overlap-weighted Klems totals, and
 * the way back to Klems.  worst[0]: the largest per-patch change of a hemispherical total on the
 * way back, worst[1]: the matrices' change, sum Lambda Lambda |K' - K| / sum Lambda Lambda K. */
static void check_klems_file(const char *name, int k, int ncomp, double worst[2])
{
    bst_bsdf *b = read_ok(tu_ref(name));
    const bst_basis *kb = bst_bsdf_klems_basis(b);
    ck_assert_ptr_nonnull(kb);
    bst_basis *sc;
    bst_layer *lk;
    bsti_overlap *ov;
    ck_assert_int_eq(bst_basis_new_sc(ctx, k, &sc), BST_OK);
    ck_assert_int_eq(bst_bsdf_to_layer(ctx, b, NULL, &lk), BST_OK);
    ck_assert_int_eq(bsti_overlap_new(ctx, k, kb, &ov), BST_OK);
    size_t n = bst_basis_size(sc), nk = bst_basis_size(kb);
    const double *lk_ = bst_basis_lambda(kb), lsc = M_PI / (double)n;
    double *work = malloc(n * n * sizeof *work), *back = malloc(nk * nk * sizeof *back);
    double *hk = malloc(nk * sizeof *hk);
    char *mark = malloc(nk);
    ck_assert_ptr_nonnull(work);
    for (int c = 0; c < ncomp; c++) {
        int recip;
        ck_assert_int_eq(bst_layer_hemispherical(ctx, lk, 0, (bst_comp)c, hk), BST_OK);
        ck_assert_int_eq(bsti_resample_component(ctx, b, 0, c, sc, work, &recip), BST_OK);
        for (size_t i = 0; i < n; i++) {
            /* a component from reciprocity is read as the caller reads it */
            size_t col = recip ? bst_basis_antipode(sc, i) : i;
            double h = 0, want = 0;
            for (size_t o = 0; o < n; o++)
                h += (recip ? work[col + n * bst_basis_antipode(sc, o)] : work[o + n * col]) * lsc;
            for (size_t e = ov->first[i]; e < ov->first[i + 1]; e++)
                want += ov->w[e] * hk[ov->patch[e]];
            ck_assert_msg(fabs(h - want) <= 1e-9, "%s %s k %d cell %zu: %.12f vs %.12f", name,
                          bst_comp_name((bst_comp)c), k, i, h, want);
        }
        if (recip)
            continue; /* the way back is the same as for the stored transmission */
        ck_assert_int_eq(bsti_sc_to_klems(ctx, ov, work, kb, back), BST_OK);
        const double *km = b->mat[0][c];
        double tot = 0, tot_back = 0, diff = 0, sum = 0;
        for (size_t p = 0; p < nk; p++) {
            double h = 0;
            for (size_t q = 0; q < nk; q++) {
                h += back[q + nk * p] * lk_[q];
                diff += lk_[q] * lk_[p] * fabs(back[q + nk * p] - km[q + nk * p]);
                sum += lk_[q] * lk_[p] * km[q + nk * p];
            }
            tot += lk_[p] * hk[p], tot_back += lk_[p] * h;
            double s = neighbours(ov, p, mark), spread = 0;
            for (size_t q = 0; q < nk; q++)
                if (mark[q])
                    spread = fmax(spread, fabs(hk[q] - hk[p]));
            ck_assert_msg(fabs(h - hk[p]) <= (1 - s) * spread + 1e-12,
                          "%s %s k %d patch %zu: %.9f back from %.9f (s %.4f, spread %.5f)", name,
                          bst_comp_name((bst_comp)c), k, p, h, hk[p], s, spread);
            worst[0] = fmax(worst[0], fabs(h - hk[p]));
        }
        tu_assert_close(tot_back, tot, 1e-9, 1.0);
        if (sum > 0)
            worst[1] = fmax(worst[1], diff / sum);
    }
    free(work), free(back), free(hk), free(mark);
    bsti_overlap_free(ov);
    bst_layer_free(lk);
    bst_basis_free(sc);
    bst_bsdf_free(b);
}

/* Prints, per order, each file's largest change of a patch's hemispherical total and its
 * matrices' change on the way back (the figures in bsdfstack-convert(1)). */
START_TEST(test_klems_references)
{
    for (int k = BST_K_MIN; k <= 6; k++) {
        printf("Klems -> Shirley-Chiu k = %d -> Klems, largest hemispherical change / matrix change:", k);
        for (size_t f = 0; f < sizeof klems_refs / sizeof *klems_refs; f++) {
            double worst[2] = {0, 0};
            check_klems_file(klems_refs[f], k, BST_NCOMP, worst);
            printf("  %.*s %.4f / %.1f %%", (int)(strlen(klems_refs[f]) - 10), klems_refs[f] + 2, worst[0],
                   100 * worst[1]);
        }
        printf("\n");
    }
}
END_TEST

/* Order 7 (N = 16384: 2 GiB of work per component): the diffuser's transmission. */
START_TEST(test_klems_reference_k7)
{
    double worst[2] = {0, 0};
    check_klems_file("L_diffuser_t3k5_klems.xml", 7, 1, worst);
    printf("Klems -> Shirley-Chiu k = 7 -> Klems (diffuser Tf): a patch's hemispherical total moves "
           "by up to %.5f, the matrix by %.2f %% of its flux\n", worst[0], 100 * worst[1]);
}
END_TEST


/* ------------------------------------------------------------------ a stack with a Klems shade */

/* Layer over basis: glass spec (catalogue) or a reference file; without_r: reflections zeroed. */
static bst_layer *stack_layer(const char *what, const bst_basis *basis, int without_r)
{
    bst_layer *l;
    const char *ch = "Visible";
    if (strncmp(what, "glass:", 6) == 0) {
        ck_assert_int_eq(bst_glass_layer_from_spec(ctx, what + 6, getenv("BSDFSTACK_GLASS_DIR"), basis,
                                                   1, &ch, &l), BST_OK);
    } else {
        bst_bsdf *b = read_ok(tu_ref(what));
        ck_assert_int_eq(bst_bsdf_to_layer(ctx, b, basis, &l), BST_OK);
        bst_bsdf_free(b);
    }
    for (int c = 0; without_r && c < BST_NCOMP; c++)
        if (c == BST_RF || c == BST_RB) {
            bst_mat *z;
            size_t n = bst_basis_size(basis);
            ck_assert_int_eq(bst_mat_new_zero(ctx, n, n, &z), BST_OK);
            ck_assert_int_eq(bst_layer_set(ctx, l, 0, (bst_comp)c, z), BST_OK);
        }
    return l;
}

/* Hemispherical Tf of pane + shade + pane over basis, for every incident patch of kb (a tree
 * basis's cells averaged onto kb's patches by the overlaps). */
static void stack_tf(const char *shade, const bst_basis *basis, const bst_basis *kb, int without_r,
                     double *tf)
{
    bst_layer *ls[3], *sys;
    ls[0] = stack_layer("glass:clear-6mm", basis, without_r);
    ls[1] = stack_layer(shade, basis, without_r);
    ls[2] = stack_layer("glass:clear-6mm", basis, without_r);
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    o.comps = BST_COMP_BIT(BST_TF);
    ck_assert_int_ge(bst_stack_combine(ctx, 3, (const bst_layer *const *)ls, &o, &sys), 0);
    size_t n = bst_basis_size(basis), nk = bst_basis_size(kb);
    double *h = malloc(n * sizeof *h);
    ck_assert_int_eq(bst_layer_hemispherical(ctx, sys, 0, BST_TF, h), BST_OK);
    if (bst_basis_kind_of(basis) == BST_BASIS_KLEMS) {
        memcpy(tf, h, nk * sizeof *tf);
    } else {
        bsti_overlap *ov;
        ck_assert_int_eq(bsti_overlap_new(ctx, bst_basis_order(basis), kb, &ov), BST_OK);
        memset(tf, 0, nk * sizeof *tf);
        for (size_t i = 0; i < n; i++)
            for (size_t e = ov->first[i]; e < ov->first[i + 1]; e++)
                tf[ov->patch[e]] += ov->w[e] * h[i] / ov->area[ov->patch[e]];
        bsti_overlap_free(ov);
    }
    free(h);
    for (int j = 0; j < 3; j++)
        bst_layer_free(ls[j]);
    bst_layer_free(sys);
}

/* Directional-hemispherical values of component c of a file over basis, per patch. */
static void file_hemi(const char *name, const bst_basis *basis, bst_comp c, double *h)
{
    bst_layer *l = stack_layer(name, basis, 0);
    ck_assert_int_eq(bst_layer_hemispherical(ctx, l, 0, c, h), BST_OK);
    bst_layer_free(l);
}

/* glass:clear-6mm + L_diffuser_t3k5_klems + glass:clear-6mm, hemispherical Tf per incident Klems
 * patch p (tree results averaged onto the patches by the overlaps):
 * 1. The first pass (every reflection set to zero) on the tree basis is exactly what the overlaps
 *    give from the Klems matrix K and the panes' cell values t1, t2:
 *      T1(i) = t1(i) sum_p' w_ip' sum_q K(q, p') sum_o w_oq t2(o) pi/N   (1e-9).
 * 2. The basis change.  The Klems combination resolves the panes by patches, the tree basis by
 *    cells, and that alone moves the first pass (d1 = T1_tree - T1_klems, pinned by 1); the
 *    inter-reflected light (T - T1) is further moved by the panes' reflectance as cells resolve it
 *    (eps_R: the lambda-weighted relative difference of cell and patch reflectance over the patches
 *    the cells meet) and by the light that cells carry across patch boundaries (mu: the share of
 *    the hemisphere's projected solid angle in cell parts outside their cell's main patch,
 *    sum_i w_ip (1 - w_ip) / N).  Asserted: |d - d1 T_klems / T1_klems| <= (eps_R + mu) (T - T1)
 *    in the Klems combination's terms, where d = T_tree - T_klems.  (At k = 5: eps_R 0.175, mu 0.305;
 *    the left side reaches 0.13 of the inter-reflected light in the 75-90 degree band, 0.001 of it
 *    at normal incidence.)
 * 3. The diffuser's own tree (L_diffuser_t3k5.xml, of which the Klems file is bsdf2klems's patch
 *    average) in the same stack: the Klems shade is that tree seen through the Klems basis, so the
 *    two stacks may differ by what 2 allows for the basis change. */
START_TEST(test_stack_klems_shade)
{
    bst_basis *kb, *sc;
    bsti_overlap *ov;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "full", &kb), BST_OK);
    ck_assert_int_eq(bst_basis_new_sc(ctx, 5, &sc), BST_OK);
    ck_assert_int_eq(bsti_overlap_new(ctx, 5, kb, &ov), BST_OK);
    size_t n = bst_basis_size(sc), nk = bst_basis_size(kb);
    const double lsc = M_PI / (double)n;
    static double tk[145], tk1[145], ts[145], ts1[145], tt[145], gtk[145], grk[145], t2q[145], kt2[145];
    const char *shade = "L_diffuser_t3k5_klems.xml";
    stack_tf(shade, kb, kb, 0, tk);
    stack_tf(shade, kb, kb, 1, tk1);
    stack_tf(shade, sc, kb, 0, ts);
    stack_tf(shade, sc, kb, 1, ts1);
    stack_tf("L_diffuser_t3k5.xml", sc, kb, 0, tt);
    double *gt = malloc(n * sizeof *gt), *gr = malloc(n * sizeof *gr), *t1 = calloc(nk, sizeof *t1);
    file_hemi("glass:clear-6mm", sc, BST_TF, gt), file_hemi("glass:clear-6mm", sc, BST_RF, gr);
    file_hemi("glass:clear-6mm", kb, BST_TF, gtk), file_hemi("glass:clear-6mm", kb, BST_RF, grk);

    /* 1: the first pass from the overlaps (the pane is symmetric: t1 = t2 = gt) */
    bst_layer *dl = stack_layer(shade, kb, 0);
    const bst_mat *K = bst_layer_get(dl, 0, BST_TF);
    for (size_t o = 0; o < n; o++)
        for (size_t e = ov->first[o]; e < ov->first[o + 1]; e++)
            t2q[ov->patch[e]] += ov->w[e] * gt[o] * lsc;
    for (size_t p = 0; p < nk; p++) {
        kt2[p] = 0;
        for (size_t q = 0; q < nk; q++)
            kt2[p] += bst_mat_get(K, q, p) * t2q[q];
    }
    for (size_t i = 0; i < n; i++) {
        double v = 0;
        for (size_t e = ov->first[i]; e < ov->first[i + 1]; e++)
            v += ov->w[e] * kt2[ov->patch[e]];
        for (size_t e = ov->first[i]; e < ov->first[i + 1]; e++)
            t1[ov->patch[e]] += ov->w[e] * gt[i] * v / ov->area[ov->patch[e]];
    }
    for (size_t p = 0; p < nk; p++)
        ck_assert_msg(fabs(ts1[p] - t1[p]) <= 1e-9, "first pass, patch %zu: %.12f vs %.12f", p, ts1[p], t1[p]);

    /* 2 and 3 */
    double er = 0, erd = 0, mu = 0;
    for (size_t i = 0; i < n; i++)
        for (size_t e = ov->first[i]; e < ov->first[i + 1]; e++) {
            size_t q = ov->patch[e];
            er += ov->w[e] * fabs(gr[i] - grk[q]), erd += ov->w[e] * grk[q];
            mu += ov->w[e] * (1 - ov->w[e]) / (double)n;
        }
    double eps = er / erd + mu, worst = 0, worst_tree = 0;
    for (size_t p = 0; p < nk; p++) {
        double d = ts[p] - tk[p], d1 = ts1[p] - tk1[p], multi = tk[p] - tk1[p];
        double lhs = fabs(d - d1 * tk[p] / tk1[p]), lhs_tree = fabs(ts[p] - tt[p]);
        ck_assert_msg(multi > 0 && lhs <= eps * multi, "patch %zu: tree %.5f, Klems %.5f (first pass "
                      "%.5f, %.5f): %.5f > %.3f x %.5f", p, ts[p], tk[p], ts1[p], tk1[p], lhs, eps, multi);
        ck_assert_msg(lhs_tree <= fabs(d1) * tk[p] / tk1[p] + eps * multi, "patch %zu: Klems shade %.5f, "
                      "tree shade %.5f", p, ts[p], tt[p]);
        worst = fmax(worst, lhs / multi), worst_tree = fmax(worst_tree, fabs(ts[p] / tt[p] - 1));
    }
    printf("pane + Klems diffuser + pane at k = 5: normal incidence T %.5f (Klems basis %.5f, the "
           "diffuser's tree %.5f); basis change moves at most %.3f of the inter-reflected light "
           "(allowed %.3f); the tree shade's stack differs by up to %.2f %%\n", ts[0], tk[0], tt[0],
           worst, eps, 100 * worst_tree);
    free(gt), free(gr), free(t1);
    bst_layer_free(dl);
    bsti_overlap_free(ov);
    bst_basis_free(kb), bst_basis_free(sc);
}
END_TEST

/* Allocation failure anywhere in a resampling (overlap table, work matrices, plans) returns
 * BST_ENOMEM with nothing leaked, and the first run that is not starved succeeds: a Klems file onto
 * a tree and onto another Klems basis, a tree onto a Klems basis. */
START_TEST(test_allocation_failure)
{
    static const struct {
        const char *file;
        int k;              /* 0: Klems */
        const char *klems;
    } cases[] = {{"L_diffuser_t3k5_klems.xml", 3, NULL}, {"L_blind0_t4k5_klems.xml", 0, "half"},
                 {"L_glass_t4k5.xml", 0, "quarter"}};
    for (size_t q = 0; q < sizeof cases / sizeof *cases; q++) {
        bst_bsdf *b = read_ok(tu_ref(cases[q].file));
        bst_basis *target;
        if (cases[q].k)
            ck_assert_int_eq(bst_basis_new_sc(ctx, cases[q].k, &target), BST_OK);
        else
            ck_assert_int_eq(bst_basis_new_klems(ctx, cases[q].klems, &target), BST_OK);
        int ok = 0;
        long n;
        for (n = 1; n < 10000 && !ok; n++) {
            tu_alloc a = {n, 0, 0};
            bst_ctx *c = bst_ctx_new();
            ck_assert_int_eq(bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &a), BST_OK);
            bst_layer *l = (bst_layer *)1;
            int rc = bst_bsdf_to_layer(c, b, target, &l);
            if (rc == BST_OK) {
                ok = 1;
                bst_layer_free(l);
            } else {
                ck_assert_int_eq(rc, BST_ENOMEM);
                ck_assert_ptr_null(l);
            }
            ck_assert_msg(a.live == 0, "%s, allocation %ld failing: %ld blocks leaked", cases[q].file, n,
                          a.live);
            bst_ctx_free(c);
        }
        ck_assert_msg(ok, "%s never converted", cases[q].file);
        bst_basis_free(target);
        bst_bsdf_free(b);
    }
}
END_TEST

static Suite *suite(void)
{
    const struct {
        const char *name;
        const TTest *test;
    } cases[] = {{"overlap", test_overlap_table}, {"uniform", test_uniform_klems},
                 {"references", test_klems_references}, {"k7", test_klems_reference_k7},
                 {"stack", test_stack_klems_shade}, {"allocation", test_allocation_failure}};
    Suite *s = suite_create("resample");
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        TCase *tc = tcase_create(cases[i].name);
        tcase_add_checked_fixture(tc, setup, teardown);
        tcase_set_timeout(tc, 600);
        tcase_add_test(tc, cases[i].test);
        suite_add_tcase(s, tc);
    }
    return s;
}

int main(void) { return tu_run(suite()); }
