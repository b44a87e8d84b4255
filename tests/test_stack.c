/* test_stack.c - the combination of layers, checked against physics that no code here printed:
 * closed-form multi-pane formulas for specular layers, conservation of energy for non-absorbing
 * layers, reciprocity, typed kernels against the forced-dense baseline, and "only what is asked"
 * giving the same numbers as the full computation. */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "testutil.h"

static bst_ctx *ctx;

static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

static const char *const visible[] = {"Visible"};

/* A specular layer: diagonal components whose directional values (Lambda * value) are t[j] for
 * transmission and rf[j], rb[j] for reflection. */
static bst_layer *specular_layer(const bst_basis *b, const double *t, const double *rf,
                                 const double *rb)
{
    size_t n = bst_basis_size(b);
    const double *lam = bst_basis_lambda(b);
    bst_layer *l;
    ck_assert_int_eq(bst_layer_new(ctx, b, 1, visible, &l), BST_OK);
    double *d = malloc(n * sizeof *d);
    const double *src[BST_NCOMP] = {t, rf, t, rb};
    for (int c = 0; c < BST_NCOMP; c++) {
        for (size_t j = 0; j < n; j++)
            d[j] = src[c][j] / lam[j];
        bst_mat *m;
        ck_assert_int_eq(bst_mat_new_diag(ctx, n, d, &m), BST_OK);
        ck_assert_int_eq(bst_layer_set(ctx, l, 0, (bst_comp)c, m), BST_OK);
    }
    free(d);
    return l;
}

/* Directional value of a diagonal component at patch j. */
static double dir_value(const bst_layer *l, bst_comp c, size_t j)
{
    return bst_mat_get(bst_layer_get(l, 0, c), j, j) * bst_basis_lambda(bst_layer_basis(l))[j];
}

/* Two and three panes: per patch, the closed forms of the multi-pane formulas
 *   T12 = t1 t2 / (1 - rb1 rf2),  Rf12 = rf1 + t1^2 rf2 / (1 - rb1 rf2),
 *   Rb12 = rb2 + t2^2 rb1 / (1 - rb1 rf2), applied twice for three panes. */
START_TEST(test_panes_closed_form)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &b), BST_OK);
    size_t n = bst_basis_size(b);
    tu_rng rng;
    tu_rng_seed(&rng, 12345);
    double *v = malloc(9 * n * sizeof *v);
    for (size_t i = 0; i < 9 * n; i++)
        v[i] = tu_rng_uniform(&rng);
    /* pane p: t in [0.05, 0.9), rf, rb in [0, 0.1 + 0.8 (1 - t))... kept physical: t + r <= 1 */
    for (int p = 0; p < 3; p++)
        for (size_t j = 0; j < n; j++) {
            double *t = v + (3 * p) * n, *rf = t + n, *rb = rf + n;
            t[j] = 0.05 + 0.85 * t[j];
            rf[j] *= 1.0 - t[j];
            rb[j] *= 1.0 - t[j];
        }
    bst_layer *pane[3];
    for (int p = 0; p < 3; p++)
        pane[p] = specular_layer(b, v + 3 * p * n, v + (3 * p + 1) * n, v + (3 * p + 2) * n);

    bst_layer *sys2, *sys3;
    ck_assert_int_eq(bst_stack_combine(ctx, 2, (const bst_layer *const *)pane, NULL, &sys2), BST_OK);
    ck_assert_int_eq(bst_stack_combine(ctx, 3, (const bst_layer *const *)pane, NULL, &sys3), BST_OK);
    for (int c = 0; c < BST_NCOMP; c++) {
        ck_assert_int_eq(bst_mat_structure(bst_layer_get(sys2, 0, (bst_comp)c)), BST_DIAG);
        ck_assert_int_eq(bst_mat_structure(bst_layer_get(sys3, 0, (bst_comp)c)), BST_DIAG);
    }
    for (size_t j = 0; j < n; j++) {
        double t1 = v[j], rf1 = v[n + j], rb1 = v[2 * n + j];
        double t2 = v[3 * n + j], rf2 = v[4 * n + j], rb2 = v[5 * n + j];
        double t3 = v[6 * n + j], rf3 = v[7 * n + j], rb3 = v[8 * n + j];
        double d = 1.0 - rb1 * rf2;
        double t12 = t1 * t2 / d, rf12 = rf1 + t1 * t1 * rf2 / d, rb12 = rb2 + t2 * t2 * rb1 / d;
        tu_assert_close(dir_value(sys2, BST_TF, j), t12, 1e-12, 0.0);
        tu_assert_close(dir_value(sys2, BST_TB, j), t12, 1e-12, 0.0);
        tu_assert_close(dir_value(sys2, BST_RF, j), rf12, 1e-12, 0.0);
        tu_assert_close(dir_value(sys2, BST_RB, j), rb12, 1e-12, 0.0);
        double e = 1.0 - rb12 * rf3;
        tu_assert_close(dir_value(sys3, BST_TF, j), t12 * t3 / e, 1e-12, 0.0);
        tu_assert_close(dir_value(sys3, BST_RF, j), rf12 + t12 * t12 * rf3 / e, 1e-12, 0.0);
        tu_assert_close(dir_value(sys3, BST_RB, j), rb3 + t3 * t3 * rb12 / e, 1e-12, 0.0);
    }
    for (int p = 0; p < 3; p++)
        bst_layer_free(pane[p]);
    bst_layer_free(sys2);
    bst_layer_free(sys3);
    bst_basis_free(b);
    free(v);
}
END_TEST

/* A random scattering layer over basis b.  Structure per component: 0 diagonal, 1 sparse
 * (a few lobes per column), 2 dense, 3 a diagonal stored sparse (a pane's tree file), 4 sparse
 * with one value in 20 (below stack.c's share for a pane, as a mirror blind's partial stack at
 * k = 7), scattered so that the LU of its inter-reflection with a pane fills.  Without absorption (absorb = 0) every incident patch's
 * hemispherical T + R is exactly 1 on both sides; otherwise 1 - absorb. */
static bst_layer *random_layer(const bst_basis *b, int structure, double absorb, tu_rng *rng)
{
    size_t n = bst_basis_size(b);
    const double *lam = bst_basis_lambda(b);
    bst_layer *l;
    ck_assert_int_eq(bst_layer_new(ctx, b, 1, visible, &l), BST_OK);
    double *a = calloc(4 * n * n, sizeof *a); /* Tf, Rf, Tb, Rb column-major */
    for (int c = 0; c < BST_NCOMP; c++)
        for (size_t j = 0; j < n; j++)
            for (size_t i = 0; i < n; i++) {
                int on = structure == 2 || ((structure == 0 || structure == 3) && i == j) ||
                         (structure == 1 && (i == j || (i * 7 + j * 3) % 11 == 0)) ||
                         (structure == 4 && (i == j || ((i * 73856093u) ^ (j * 19349663u)) % 20 == 0));
                a[(size_t)c * n * n + j * n + i] = on ? tu_rng_uniform(rng) : 0.0;
            }
    /* Scale each incident column pair (T, R of one side) so that T + R = 1 - absorb, with T
     * carrying a random share. */
    for (int side = 0; side < 2; side++)
        for (size_t j = 0; j < n; j++) {
            double *t = a + (size_t)(2 * side) * n * n + j * n, *r = t + n * n;
            double st = 0, sr = 0, share = 0.3 + 0.6 * tu_rng_uniform(rng);
            for (size_t i = 0; i < n; i++)
                st += lam[i] * t[i], sr += lam[i] * r[i];
            for (size_t i = 0; i < n; i++) {
                t[i] *= (1.0 - absorb) * share / st;
                r[i] *= (1.0 - absorb) * (1.0 - share) / sr;
            }
        }
    for (int c = 0; c < BST_NCOMP; c++) {
        bst_mat *m;
        ck_assert_int_eq(bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &m), BST_OK);
        memcpy(bst_mat_dense_data(m), a + (size_t)c * n * n, n * n * sizeof(double));
        bst_mat *t;
        ck_assert_int_eq(bst_mat_compact(ctx, m, BST_SPARSE_MAX_FILL, &t), BST_OK);
        bst_mat_free(m);
        if (structure == 3) { /* a pane's tree file: its diagonal stored sparse */
            ck_assert_int_eq(bst_mat_convert(ctx, t, BST_SPARSE, BST_DOUBLE, &m), BST_OK);
            bst_mat_free(t);
            t = m;
        }
        ck_assert_int_eq(bst_layer_set(ctx, l, 0, (bst_comp)c, t), BST_OK);
    }
    free(a);
    return l;
}

static double max_rel_diff(const bst_mat *a, const bst_mat *b)
{
    size_t n = bst_mat_rows(a);
    double m = 0, scale = 0;
    for (size_t j = 0; j < n; j++)
        for (size_t i = 0; i < n; i++)
            scale = fmax(scale, fabs(bst_mat_get(b, i, j)));
    for (size_t j = 0; j < n; j++)
        for (size_t i = 0; i < n; i++) {
            double d = fabs(bst_mat_get(a, i, j) - bst_mat_get(b, i, j));
            if (isnan(d))
                return INFINITY;
            m = fmax(m, d);
        }
    return scale > 0 ? m / scale : m;
}

/* Non-absorbing layers of every structure: the system conserves energy per incident patch on both
 * sides (T + R = 1 to 1e-9), and the typed result equals the forced-dense one to 1e-10. */
START_TEST(test_energy_and_dense)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 2, &b), BST_OK);
    size_t n = bst_basis_size(b);
    tu_rng rng;
    tu_rng_seed(&rng, 777 + (uint64_t)_i);
    int s[3] = {_i % 4, (_i / 4) % 4, (_i / 16) % 4};
    bst_layer *l[3];
    for (int k = 0; k < 3; k++)
        l[k] = random_layer(b, s[k], 0.0, &rng);
    bst_layer *typed, *dense;
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    ck_assert_int_eq(bst_stack_combine(ctx, 3, (const bst_layer *const *)l, &o, &typed), BST_OK);
    o.force_dense = 1;
    ck_assert_int_eq(bst_stack_combine(ctx, 3, (const bst_layer *const *)l, &o, &dense), BST_OK);
    double *t = malloc(2 * n * sizeof *t), *r = t + n;
    for (int side = 0; side < 2; side++) {
        ck_assert_int_eq(bst_layer_hemispherical(ctx, typed, 0, side ? BST_TB : BST_TF, t), BST_OK);
        ck_assert_int_eq(bst_layer_hemispherical(ctx, typed, 0, side ? BST_RB : BST_RF, r), BST_OK);
        for (size_t j = 0; j < n; j++)
            tu_assert_close(t[j] + r[j], 1.0, 1e-9, 0.0);
    }
    for (int c = 0; c < BST_NCOMP; c++)
        ck_assert_double_le(max_rel_diff(bst_layer_get(typed, 0, (bst_comp)c),
                                         bst_layer_get(dense, 0, (bst_comp)c)), 1e-10);
    free(t);
    for (int k = 0; k < 3; k++)
        bst_layer_free(l[k]);
    bst_layer_free(typed);
    bst_layer_free(dense);
    bst_basis_free(b);
}
END_TEST


/* Absorbing layers of every structure: system T + R + the layers' absorptances = 1 per incident
 * patch on both sides (1e-9), each absorptance within [0, 1]; a single layer's absorptance is its
 * own 1 - T - R. */
START_TEST(test_absorptance_balance)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 2, &b), BST_OK);
    size_t n = bst_basis_size(b);
    tu_rng rng;
    tu_rng_seed(&rng, 31 + (uint64_t)_i);
    bst_layer *l[3] = {random_layer(b, _i % 4, 0.12, &rng), random_layer(b, (_i + 1) % 4, 0.3, &rng),
                       random_layer(b, (_i + 2) % 4, 0.05, &rng)};
    bst_layer *sys;
    ck_assert_int_eq(bst_stack_combine(ctx, 3, (const bst_layer *const *)l, NULL, &sys), BST_OK);
    double *af = malloc(3 * n * sizeof *af), *ab = malloc(3 * n * sizeof *ab), *t = malloc(2 * n * sizeof *t), *r = t + n;
    ck_assert_int_eq(bst_stack_absorptance(ctx, 3, (const bst_layer *const *)l, 0, NULL, af, ab), BST_OK);
    for (int side = 0; side < 2; side++) {
        const double *a = side ? ab : af;
        ck_assert_int_eq(bst_layer_hemispherical(ctx, sys, 0, side ? BST_TB : BST_TF, t), BST_OK);
        ck_assert_int_eq(bst_layer_hemispherical(ctx, sys, 0, side ? BST_RB : BST_RF, r), BST_OK);
        for (size_t j = 0; j < n; j++) {
            double sum = t[j] + r[j];
            for (int i = 0; i < 3; i++) {
                ck_assert(a[i * n + j] >= -1e-12 && a[i * n + j] <= 1.0);
                sum += a[i * n + j];
            }
            tu_assert_close(sum, 1.0, 1e-9, 0.0);
        }
    }
    /* the exterior layer absorbs more than nothing and the first layer's share for a single
     * layer is its own absorptance (0.12) */
    ck_assert_int_eq(bst_stack_absorptance(ctx, 1, (const bst_layer *const *)l, 0, NULL, af, ab), BST_OK);
    for (size_t j = 0; j < n; j++) {
        tu_assert_close(af[j], 0.12, 1e-12, 0.0);
        tu_assert_close(ab[j], 0.12, 1e-12, 0.0);
    }
    free(af), free(ab), free(t);
    for (int k = 0; k < 3; k++)
        bst_layer_free(l[k]);
    bst_layer_free(sys);
    bst_basis_free(b);
}
END_TEST

/* Asking for one component gives the same numbers as asking for all four. */
START_TEST(test_only_requested)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 2, &b), BST_OK);
    tu_rng rng;
    tu_rng_seed(&rng, 99);
    bst_layer *l[3] = {random_layer(b, 0, 0.1, &rng), random_layer(b, 1, 0.2, &rng),
                       random_layer(b, 2, 0.05, &rng)};
    bst_layer *all, *one;
    ck_assert_int_eq(bst_stack_combine(ctx, 3, (const bst_layer *const *)l, NULL, &all), BST_OK);
    for (int c = 0; c < BST_NCOMP; c++) {
        bst_stack_opts o;
        bst_stack_opts_init(&o);
        o.comps = BST_COMP_BIT(c);
        ck_assert_int_eq(bst_stack_combine(ctx, 3, (const bst_layer *const *)l, &o, &one), BST_OK);
        for (int d = 0; d < BST_NCOMP; d++)
            if (d == c)
                ck_assert_double_le(max_rel_diff(bst_layer_get(one, 0, (bst_comp)d),
                                                 bst_layer_get(all, 0, (bst_comp)d)), 1e-13);
            else
                ck_assert_ptr_null(bst_layer_get(one, 0, (bst_comp)d));
        bst_layer_free(one);
    }
    for (int k = 0; k < 3; k++)
        bst_layer_free(l[k]);
    bst_layer_free(all);
    bst_basis_free(b);
}
END_TEST

/* bst_stack_step's flops: two dense layers cost, per the formulas in stack.c, two GEMMs and one
 * factorization with an N-column solve before each of the four components' last products:
 * 8 GEMMs (2 N^3) + 2 LU (2/3 N^3 - 1/2 N^2 + 5/6 N, LAWN 41) + 2 getrs of N columns
 * ((2 N^2 - N) N); two diagonal layers (panes) none at all. */
static void add_flops(const bst_stack_step *s, void *opaque) { *(double *)opaque += s->flops; }

/* The flops the steps of combining l[0], l[1] report; the system freed. */
static double stack_flops(bst_layer *const *l)
{
    double flops = 0.0;
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    o.on_step = add_flops;
    o.opaque = &flops;
    bst_layer *s;
    ck_assert_int_eq(bst_stack_combine(ctx, 2, (const bst_layer *const *)l, &o, &s), BST_OK);
    bst_layer_free(s);
    return flops;
}

/* An N x N LU's flops (LAWN 41). */
static double lu_flops(double n) { return 2.0 / 3.0 * n * n * n - 0.5 * n * n + 5.0 / 6.0 * n; }

START_TEST(test_flops)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 2, &b), BST_OK);
    double n = (double)bst_basis_size(b);
    tu_rng rng;
    tu_rng_seed(&rng, 4242);
    for (int structure = 0; structure <= 2; structure += 2) {
        bst_layer *l[2] = {random_layer(b, structure, 0.1, &rng), random_layer(b, structure, 0.2, &rng)};
        double flops = stack_flops(l);
        double want = structure ? 8 * 2 * n * n * n + 2 * lu_flops(n) + 2 * (2 * n * n - n) * n : 0.0;
        ck_assert_double_le(fabs(flops - want), 1e-9 * want);
        bst_layer_free(l[0]);
        bst_layer_free(l[1]);
    }
    bst_basis_free(b);
}
END_TEST

/* A pane given as a tree (its diagonal stored sparse) and a dense layer, in either order: the step
 * factors one inter-reflection (the light going outwards when the pane is in front, inwards when
 * it is behind) and forms all four components from its two left solves (stack.c,
 * one_factorization).  Dense work: one LU, two getrs of N columns and two GEMMs (the dense layer's
 * transmission times the other inter-reflection's terms); sparse-dense products, 2 N^2 flops
 * each: the inter-reflection, the second right-hand side and the pane's four products (Tb1 or Tf2
 * with X1 and X2, L Rb1 or L Rf2 with X1 and X2).  Each inter-reflection factored, as before: one
 * LU and one getrs more, one GEMM fewer. */
START_TEST(test_flops_pane_tree)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &b), BST_OK);
    double n = (double)bst_basis_size(b);
    tu_rng rng;
    tu_rng_seed(&rng, 4343);
    for (int behind = 0; behind < 2; behind++) {
        bst_layer *pane = random_layer(b, 3, 0.1, &rng), *shade = random_layer(b, 2, 0.2, &rng);
        ck_assert_int_eq(bst_mat_structure(bst_layer_get(pane, 0, BST_TB)), BST_SPARSE);
        bst_layer *l[2] = {behind ? shade : pane, behind ? pane : shade};
        double flops = stack_flops(l);
        double want = lu_flops(n) + 2 * (2 * n * n - n) * n + 2 * 2 * n * n * n + 6 * 2 * n * n;
        ck_assert_msg(fabs(flops - want) <= 1e-9 * want, "pane %s: %.0f flops, want %.0f",
                      behind ? "behind" : "in front", flops, want);
        bst_layer_free(pane);
        bst_layer_free(shade);
    }
    bst_basis_free(b);
}
END_TEST

/* A pane and a thin sparse layer (one value in 20: both pass for panes, cheap_transmission) whose
 * inter-reflection's LU would fill, so that the solve takes the dense path: the step still factors
 * one inter-reflection (the inward one when the pane is behind, the outward one when it is in
 * front: the sparser part's) and forms all four components from two left solves.  Their
 * right-hand sides are sparse, so the LU becomes the inverse (getri) and multiplies them (solve.c,
 * inverse_pays; 2 nnz N flops a product); two products more are with the thin layer's
 * transmission, the others with the pane's diagonal (not counted).  Each inter-reflection
 * factored, as before: two LU and four getrs.  With precision single the dense work is single
 * (the results dense float, within float rounding of double's), though every operand is a double
 * sparse or diagonal matrix. */
START_TEST(test_thin_sparse_pair)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 4, &b), BST_OK);
    double n = (double)bst_basis_size(b);
    tu_rng rng;
    tu_rng_seed(&rng, 4444);
    for (int behind = 0; behind < 2; behind++) {
        bst_layer *pane = random_layer(b, 0, 0.1, &rng), *thin = random_layer(b, 4, 0.2, &rng);
        /* the thin layer's transmission multiplied, and its components in the right-hand sides */
        const bst_mat *t = bst_layer_get(thin, 0, behind ? BST_TB : BST_TF);
        const bst_mat *b1 = bst_layer_get(thin, 0, behind ? BST_TF : BST_TB);
        const bst_mat *b2 = bst_layer_get(thin, 0, behind ? BST_RB : BST_RF);
        ck_assert_int_eq(bst_mat_structure(t), BST_SPARSE);
        ck_assert_double_lt((double)bst_mat_nnz(t), n * n / 16.0);
        bst_layer *l[2] = {behind ? thin : pane, behind ? pane : thin};
        double flops = stack_flops(l);
        double getri = 4.0 / 3.0 * n * n * n - n * n + 5.0 / 3.0 * n;
        double want = lu_flops(n) + getri + 2 * n * (double)(bst_mat_nnz(b1) + bst_mat_nnz(b2)) +
                      2 * 2 * (double)bst_mat_nnz(t) * n;
        ck_assert_msg(fabs(flops - want) <= 1e-9 * want, "pane %s: %.0f flops, want %.0f",
                      behind ? "behind" : "in front", flops, want);
        bst_layer *sd, *sf;
        bst_stack_opts o;
        bst_stack_opts_init(&o);
        ck_assert_int_eq(bst_stack_combine(ctx, 2, (const bst_layer *const *)l, &o, &sd), BST_OK);
        o.precision = BST_FLOAT;
        ck_assert_int_eq(bst_stack_combine(ctx, 2, (const bst_layer *const *)l, &o, &sf), BST_OK);
        for (int c = 0; c < BST_NCOMP; c++) {
            const bst_mat *md = bst_layer_get(sd, 0, (bst_comp)c), *mf = bst_layer_get(sf, 0, (bst_comp)c);
            ck_assert_int_eq(bst_mat_structure(md), BST_DENSE);
            ck_assert_int_eq(bst_mat_precision(md), BST_DOUBLE);
            ck_assert_int_eq(bst_mat_structure(mf), BST_DENSE);
            ck_assert_msg(bst_mat_precision(mf) == BST_FLOAT, "pane %s, %s: not single",
                          behind ? "behind" : "in front", bst_comp_name((bst_comp)c));
            double d = max_rel_diff(mf, md);
            ck_assert_msg(d < 1e-5, "%s: single and double differ by %g", bst_comp_name((bst_comp)c), d);
        }
        bst_layer_free(sd);
        bst_layer_free(sf);
        bst_layer_free(pane);
        bst_layer_free(thin);
    }
    bst_basis_free(b);
}
END_TEST

/* Components freed at their last use give the same numbers: for every structure triple and every
 * subset of requested components, the consuming combination (which takes the inputs and frees
 * each at its last use), the forced-dense one (whose own copies are freed likewise) and the
 * borrowing one agree with the full result; a layer listed twice (one object, both panes) is
 * borrowed first and taken last. */
START_TEST(test_consume)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 2, &b), BST_OK);
    int s[3] = {_i % 4, (_i / 4) % 4, (_i / 16) % 4};
    tu_rng rng;
    bst_layer *l[3], *all;
    tu_rng_seed(&rng, 4242 + (uint64_t)_i);
    for (int k = 0; k < 3; k++)
        l[k] = random_layer(b, s[k], 0.1, &rng);
    ck_assert_int_eq(bst_stack_combine(ctx, 3, (const bst_layer *const *)l, NULL, &all), BST_OK);
    for (unsigned want = 1; want <= BST_COMP_ALL; want++) {
        bst_stack_opts o;
        bst_stack_opts_init(&o);
        o.comps = want;
        bst_layer *fresh[3], *consumed, *dense;
        tu_rng_seed(&rng, 4242 + (uint64_t)_i);
        for (int k = 0; k < 3; k++)
            fresh[k] = random_layer(b, s[k], 0.1, &rng);
        ck_assert_int_eq(bst_stack_combine_consume(ctx, 3, fresh, &o, &consumed), BST_OK);
        for (int k = 0; k < 3; k++)
            ck_assert_ptr_null(fresh[k]);
        o.force_dense = 1;
        ck_assert_int_eq(bst_stack_combine(ctx, 3, (const bst_layer *const *)l, &o, &dense), BST_OK);
        for (int c = 0; c < BST_NCOMP; c++) {
            const bst_mat *mc = bst_layer_get(consumed, 0, (bst_comp)c), *md = bst_layer_get(dense, 0, (bst_comp)c);
            if (!(want & BST_COMP_BIT(c))) {
                ck_assert_ptr_null(mc);
                continue;
            }
            ck_assert_double_le(max_rel_diff(mc, bst_layer_get(all, 0, (bst_comp)c)), 1e-13);
            ck_assert_double_le(max_rel_diff(md, bst_layer_get(all, 0, (bst_comp)c)), 1e-10);
        }
        bst_layer_free(consumed);
        bst_layer_free(dense);
    }
    /* A, B, A with one object for A */
    bst_layer *aba[3] = {l[0], l[1], l[0]}, *ref, *got;
    ck_assert_int_eq(bst_stack_combine(ctx, 3, (const bst_layer *const *)aba, NULL, &ref), BST_OK);
    tu_rng_seed(&rng, 4242 + (uint64_t)_i);
    aba[0] = random_layer(b, s[0], 0.1, &rng);
    aba[1] = random_layer(b, s[1], 0.1, &rng);
    aba[2] = aba[0];
    ck_assert_int_eq(bst_stack_combine_consume(ctx, 3, aba, NULL, &got), BST_OK);
    for (int c = 0; c < BST_NCOMP; c++)
        ck_assert_double_le(max_rel_diff(bst_layer_get(got, 0, (bst_comp)c),
                                         bst_layer_get(ref, 0, (bst_comp)c)), 1e-13);
    bst_layer_free(ref);
    bst_layer_free(got);
    for (int k = 0; k < 3; k++)
        bst_layer_free(l[k]);
    bst_layer_free(all);
    bst_basis_free(b);
}
END_TEST

/* Two facing near-perfect mirrors: the inter-reflection is ill-conditioned; the library warns
 * (or fails with strict) and never returns NaN. */
START_TEST(test_mirrors)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 1, &b), BST_OK);
    size_t n = bst_basis_size(b);
    double t[4], r[4];
    for (size_t j = 0; j < n; j++)
        t[j] = 0.0, r[j] = 1.0 - 1e-12;
    bst_layer *l[2] = {specular_layer(b, t, r, r), specular_layer(b, t, r, r)};
    bst_layer *s;
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    int rc = bst_stack_combine(ctx, 2, (const bst_layer *const *)l, &o, &s);
    ck_assert_int_eq(rc, BST_WILLCOND);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "ill-conditioned"));
    for (int c = 0; c < BST_NCOMP; c++)
        ck_assert(bst_mat_all_finite(bst_layer_get(s, 0, (bst_comp)c)));
    bst_layer_free(s);
    o.strict = 1;
    ck_assert_int_lt(bst_stack_combine(ctx, 2, (const bst_layer *const *)l, &o, &s), 0);
    ck_assert_ptr_null(s);
    /* the error keeps the warning's text */
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "ill-conditioned"));
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "(--strict)"));
    for (int k = 0; k < 2; k++)
        bst_layer_free(l[k]);
    bst_basis_free(b);
}
END_TEST

/* An input with T + R > 1 is reported with its layer, side and patch. */
START_TEST(test_energy_warning)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 1, &b), BST_OK);
    double t[4] = {0.5, 0.5, 0.5, 0.5}, r[4] = {0.1, 0.1, 0.6, 0.1};
    bst_layer *l[2] = {specular_layer(b, t, r, r), specular_layer(b, t, r, r)};
    ck_assert_int_eq(bst_layer_set_name(ctx, l[1], "bad.xml"), BST_OK);
    bst_layer *s;
    ck_assert_int_eq(bst_stack_combine(ctx, 2, (const bst_layer *const *)l, NULL, &s), BST_WENERGY);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "bad.xml"));
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "patch 2"));
    bst_layer_free(s);
    for (int k = 0; k < 2; k++)
        bst_layer_free(l[k]);
    bst_basis_free(b);
}
END_TEST

/* Inputs within the energy tolerance whose inter-reflection creates energy: two facing layers
 * with T + R = 1.0095 (inside BST_ENERGY_TOL) give, by the closed form T = t^2 / (1 - r^2),
 * R = r + t^2 r / (1 - r^2), a system with T + R = 1.1995; with r = 1.002, t = 0.007 the
 * closed form's T is negative.  Each is a warning naming the patch, an error under strict. */
START_TEST(test_result_energy)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 1, &b), BST_OK);
    static const double cases[2][2] = {{0.01, 0.9995}, {0.007, 1.002}};
    static const char *const words[2] = {"front T + R, channel Visible, is 1.2", "Tf, channel Visible, is -0.01"};
    for (int k = 0; k < 2; k++) {
        double t[4], r[4];
        for (size_t j = 0; j < 4; j++)
            t[j] = cases[k][0], r[j] = cases[k][1];
        bst_layer *l[2] = {specular_layer(b, t, r, r), specular_layer(b, t, r, r)};
        bst_layer *s;
        bst_stack_opts o;
        bst_stack_opts_init(&o);
        ck_assert_int_eq(bst_stack_combine(ctx, 2, (const bst_layer *const *)l, &o, &s), BST_WENERGY);
        ck_assert_msg(strstr(bst_ctx_message(ctx), words[k]), "%s", bst_ctx_message(ctx));
        double tt = cases[k][0] * cases[k][0] / (1.0 - cases[k][1] * cases[k][1]);
        tu_assert_close(dir_value(s, BST_TF, 3), tt, 1e-12, 0.0);
        bst_layer_free(s);
        o.strict = 1;
        ck_assert_int_lt(bst_stack_combine(ctx, 2, (const bst_layer *const *)l, &o, &s), 0);
        ck_assert_ptr_null(s);
        ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "(--strict)"));
        /* Only Tf asked: T alone is checked, and is within bounds in the first case. */
        o.strict = 0;
        o.comps = BST_COMP_BIT(BST_TF);
        ck_assert_int_eq(bst_stack_combine(ctx, 2, (const bst_layer *const *)l, &o, &s),
                         k == 0 ? BST_OK : BST_WENERGY);
        bst_layer_free(s);
        for (int i = 0; i < 2; i++)
            bst_layer_free(l[i]);
    }
    bst_basis_free(b);
}
END_TEST

/* An absurd T + R (1e300, from a broken file) is told in a short message: %g, not 300 digits. */
START_TEST(test_energy_warning_huge)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 1, &b), BST_OK);
    double t[4] = {1e300, 0.5, 0.5, 0.5}, r[4] = {0.1, 0.1, 0.1, 0.1};
    bst_layer *l = specular_layer(b, t, r, r), *s = NULL;
    int st = bst_stack_combine(ctx, 1, (const bst_layer *const *)&l, NULL, &s);
    ck_assert_int_eq(st, BST_WENERGY);
    const char *msg = bst_ctx_message(ctx);
    ck_assert_ptr_nonnull(strstr(msg, "e+"));
    ck_assert_uint_lt(strlen(msg), 160);
    bst_layer_free(s);
    bst_layer_free(l);
    bst_basis_free(b);
}
END_TEST

/* Every allocation failure in a combination is reported as BST_ENOMEM, leaves no result and leaks
 * nothing, whether it borrows or consumes the layers, for every requested subset of components:
 * the frees at each component's last use hold on every path. */
START_TEST(test_alloc_failure)
{
    static const int structures[3][3] = {{0, 2, 0}, {2, 1, 2}, {1, 0, 2}};
    const int *s = structures[_i];
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 1, &b), BST_OK);
    tu_rng rng;
    bst_layer *l[3];
    tu_rng_seed(&rng, 77 + (uint64_t)_i);
    for (int k = 0; k < 3; k++)
        l[k] = random_layer(b, s[k], 0.1, &rng);
    for (unsigned want = 1; want <= BST_COMP_ALL; want++)
        for (int consume = 0; consume < 2; consume++) {
            int ok = 0;
            for (long n = 1; n < 1000 && !ok; n++) {
                tu_alloc a = {n, 0, 0};
                bst_ctx *c = bst_ctx_new();
                ck_assert_int_eq(bst_ctx_set_allocator(c, tu_alloc_malloc, tu_alloc_free, &a),
                                 BST_OK);
                bst_stack_opts o;
                bst_stack_opts_init(&o);
                o.comps = want;
                bst_layer *out = (bst_layer *)1;
                int rc;
                if (consume) {
                    bst_layer *fresh[3];
                    tu_rng_seed(&rng, 77 + (uint64_t)_i);
                    for (int k = 0; k < 3; k++)
                        fresh[k] = random_layer(b, s[k], 0.1, &rng);
                    rc = bst_stack_combine_consume(c, 3, fresh, &o, &out);
                } else {
                    rc = bst_stack_combine(c, 3, (const bst_layer *const *)l, &o, &out);
                }
                ck_assert_msg(rc == BST_OK || rc == BST_ENOMEM, "want %u, consume %d, allocation "
                              "%ld: %d %s", want, consume, n, rc, bst_ctx_message(c));
                ok = rc == BST_OK;
                if (ok)
                    bst_layer_free(out);
                else
                    ck_assert_ptr_null(out);
                ck_assert_msg(a.live == 0, "want %u, consume %d: %ld blocks leaked after failing "
                              "allocation %ld", want, consume, a.live, n);
                bst_ctx_free(c);
            }
            ck_assert_msg(ok, "want %u, consume %d never succeeded", want, consume);
        }
    for (int k = 0; k < 3; k++)
        bst_layer_free(l[k]);
    bst_basis_free(b);
}
END_TEST

START_TEST(test_errors)
{
    bst_basis *b1, *b2;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 1, &b1), BST_OK);
    ck_assert_int_eq(bst_basis_new_sc(ctx, 2, &b2), BST_OK);
    double t[16] = {0}, r[16] = {0};
    bst_layer *l[2] = {specular_layer(b1, t, r, r), specular_layer(b2, t, r, r)};
    bst_layer *s = (bst_layer *)1;
    ck_assert_int_eq(bst_stack_combine(ctx, 2, (const bst_layer *const *)l, NULL, &s), BST_EBASIS);
    ck_assert_ptr_null(s);
    ck_assert_ptr_nonnull(strstr(bst_ctx_message(ctx), "resample"));
    ck_assert_int_eq(bst_stack_combine(ctx, 0, (const bst_layer *const *)l, NULL, &s), BST_EINVAL);
    ck_assert_int_eq(bst_stack_combine(NULL, 1, (const bst_layer *const *)l, NULL, &s), BST_EINVAL);
    for (int k = 0; k < 2; k++)
        bst_layer_free(l[k]);
    bst_basis_free(b1);
    bst_basis_free(b2);
}
END_TEST

static Suite *stack_suite(void)
{
    Suite *s = suite_create("stack");
    TCase *tc = tcase_create("combine");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, test_panes_closed_form);
    tcase_add_loop_test(tc, test_energy_and_dense, 0, 64);
    tcase_add_test(tc, test_only_requested);
    tcase_add_test(tc, test_flops);
    tcase_add_test(tc, test_flops_pane_tree);
    tcase_add_test(tc, test_thin_sparse_pair);
    tcase_add_loop_test(tc, test_consume, 0, 64);
    tcase_add_loop_test(tc, test_absorptance_balance, 0, 4);
    tcase_add_test(tc, test_mirrors);
    tcase_add_test(tc, test_energy_warning);
    tcase_add_test(tc, test_result_energy);
    tcase_add_test(tc, test_energy_warning_huge);
    tcase_add_test(tc, test_errors);
    tcase_add_loop_test(tc, test_alloc_failure, 0, 3);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(stack_suite());
}
