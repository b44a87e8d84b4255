/* stack.c - combination of a list of layers (exterior first) by the matrix formalism.
 *
 * Two adjacent parts U (exterior, "1") and V (interior, "2") combine, with every inter-reflection
 * in the gap between them, as (L = Lambda, the projected solid angles of the basis):
 *
 *   Tf = Tf2 (I - A1)^-1 L Tf1                 A1 = L Rb1 L Rf2   (light going inwards in the gap)
 *   Rb = Rb2 + Tf2 (I - A1)^-1 L Rb1 L Tb2
 *   Tb = Tb1 (I - A2)^-1 L Tb2                 A2 = L Rf2 L Rb1   (light going outwards)
 *   Rf = Rf1 + Tb1 (I - A2)^-1 L Rf2 L Tf1
 *
 * Derivation of the first: the flux vector g arriving at V is g = L Tf1 e + L Rb1 L Rf2 g, so
 * g = (I - A1)^-1 L Tf1 e and V transmits Tf2 g.  The index convention of bsdfstack.h (a ray keeps
 * its patch across the gap) is what lets these products be plain matrix products.
 *
 * Only what is asked is computed: need() below derives, from the components requested of a partial
 * stack, the components required of its two parts; a stack of n layers is n - 1 steps, and each
 * partial result is freed as soon as the next step has used it.  Within a step, count_uses derives
 * from need() how often each component of the two parts will be read, and every matrix the
 * combination owns is freed at its last read (struct term, use()); a dense one whose last read is
 * a diagonal scaling or a solve holds the result in its own storage (I - A its LU factors, a
 * right-hand side its solution), so that a step with a dense partial system peaks at that system
 * and three N x N matrices (bench/README.md, the memory guard's model).  When both members of a pair
 * (Tf, Rb) or (Rf, Tb) are needed, one factorization serves both through W = T2 (I - A)^-1 (a right
 * solve), or, when T2 is a pane's (diagonal, or a sparse tree: cheap_transmission), through two
 * left solves multiplied by T2 (W's products would be dense); when one is needed, a left solve
 * with its own right-hand side is cheaper.  When all four are needed and a part is a pane, one
 * factorization serves all four (from_outward, from_inward).  The absorptance rides on the
 * combination (absorptance.c: the combination keeps what it needs). */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "basis.h"
#include "ctx.h"
#include "layer.h"
#include "mat.h"
#include "stack.h"

#define BIT(c) BST_COMP_BIT(c)

void bst_stack_opts_init(bst_stack_opts *opts)
{
    memset(opts, 0, sizeof *opts);
    opts->comps = BST_COMP_ALL;
    opts->drop_tol = 0.0;
    opts->rcond_warn = BST_RCOND_WARN;
    opts->energy_tol = BST_ENERGY_TOL;
    opts->precision = BST_DOUBLE;
}

/* Components of the exterior part U (*u) and the interior layer V (*v) that the components `want`
 * of their combination require (see the formulas at the top). */
static void need(unsigned want, unsigned *u, unsigned *v)
{
    *u = *v = 0;
    if (want & BIT(BST_TF)) {
        *u |= BIT(BST_TF) | BIT(BST_RB);
        *v |= BIT(BST_TF) | BIT(BST_RF);
    }
    if (want & BIT(BST_RB)) {
        *u |= BIT(BST_RB);
        *v |= BIT(BST_RB) | BIT(BST_TF) | BIT(BST_RF) | BIT(BST_TB);
    }
    if (want & BIT(BST_TB)) {
        *u |= BIT(BST_TB) | BIT(BST_RB);
        *v |= BIT(BST_TB) | BIT(BST_RF);
    }
    if (want & BIT(BST_RF)) {
        *u |= BIT(BST_RF) | BIT(BST_TB) | BIT(BST_RB) | BIT(BST_TF);
        *v |= BIT(BST_RF);
    }
}

static double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* One channel's four components of a part; NULL = zero.  `own` marks matrices this module
 * allocated (partial results, converted copies) or took from a consumed layer, as opposed to
 * borrowed from an input layer; `uses` counts the reads of each component still to come in the
 * step being formed (count_uses); `tf_lam`: m[BST_TF] holds L Tf, scaled in its own storage at
 * the start of the step (combine_pair). */
struct part {
    const bst_mat *m[BST_NCOMP];
    bst_mat *own[BST_NCOMP];
    int uses[BST_NCOMP];
    int tf_lam;
};

static void part_clear(struct part *p)
{
    for (int c = 0; c < BST_NCOMP; c++) {
        bst_mat_free(p->own[c]);
        p->own[c] = NULL;
        p->m[c] = NULL;
    }
}

struct combiner {
    bst_ctx *ctx;
    const bst_stack_opts *opts;
    const double *lam;
    size_t n;
    int status;   /* the first error (BST_OK until then): the operations below do nothing after it */
    int warning;  /* highest warning status so far */
    double rcond; /* of the step's last inter-reflection solve (1 when none) */
    size_t step;
    const char *channel;
    double flops_mark; /* ctx->flops when the component being formed began */
    double mirror_mark; /* ctx->mirror_splits then */
    struct bsti_prefix *keep; /* the absorptance's: factorizations kept (keep_slot), else NULL */
};

/* A step's two inter-reflections: of the light going inwards in the gap, and outwards. */
enum gap { GAP_INWARD, GAP_OUTWARD };
static bsti_factor **keep_slot(struct combiner *cb, enum gap g);

/* Record a warning (or, in strict mode, turn it into an error). */
static int note_warning(struct combiner *cb, int status)
{
    if (status <= 0)
        return status;
    if (cb->opts->strict) {
        char msg[BSTI_MSG_MAX]; /* the warning is in ctx->msg, which bsti_error overwrites */
        snprintf(msg, sizeof msg, "%s", cb->ctx->msg);
        return bsti_error(cb->ctx, BST_EINVAL, "%s (--strict)", msg);
    }
    if (status > cb->warning)
        cb->warning = status;
    return BST_OK;
}

/* ------------------------------------------------------------------ terms and their lifetimes
 *
 * The operations below read and return terms: a matrix (NULL = zero) and, when this read is its
 * last and the combination owns it, the same matrix in `dies`, which the operation frees once it
 * has read it.  An operation's result is a new term that dies at its one read; keep() reads a term
 * that is read again later, and use() hands out a component of U or V, which dies at the last of
 * the reads count_uses counted.  So every matrix goes at its last use, and the formulas below free
 * nothing themselves.  After an error (cb->status < 0) an operation computes nothing and returns
 * zero, but still frees what dies: a step runs to its end and leaks nothing. */
struct term {
    const bst_mat *m;
    bst_mat *dies;
};

/* Term t for a read after which it is read again. */
static struct term keep(struct term t)
{
    return (struct term){t.m, NULL};
}

/* Component c of part p, for one of the reads that count_uses counted; at the last, an owned
 * matrix dies with the read (a borrowed one is the caller's). */
static struct term use(struct part *p, bst_comp c)
{
    struct term t = {p->m[c], NULL};
    if (--p->uses[c] == 0) {
        t.dies = p->own[c];
        p->own[c] = NULL;
        p->m[c] = NULL;
    }
    return t;
}

#define INWARD (BIT(BST_TF) | BIT(BST_RB))
#define OUTWARD (BIT(BST_TB) | BIT(BST_RF))

/* The reads of each component of U and V that forming `want` makes (inward and outward below):
 * each step reads once every component that need() says it needs, except Rf2, which the outward
 * step reads twice for Rf, in A2 and in L Rf2 L Tf1 (scaling it once for both would copy V's
 * matrix). */
static void count_uses(unsigned want, struct part *u, struct part *v)
{
    unsigned ui, vi, uo, vo;
    need(want & INWARD, &ui, &vi);
    need(want & OUTWARD, &uo, &vo);
    for (int c = 0; c < BST_NCOMP; c++) {
        u->uses[c] = !!(ui & BIT(c)) + !!(uo & BIT(c));
        v->uses[c] = !!(vi & BIT(c)) + !!(vo & BIT(c));
    }
    if (want & BIT(BST_RF))
        v->uses[BST_RF]++;
}

/* The term an operation returns from the library call that formed m: on error the error becomes
 * the combination's status and m goes. */
static struct term result(struct combiner *cb, int rc, bst_mat *m)
{
    if (rc < 0) {
        cb->status = rc;
        bst_mat_free(m);
        m = NULL;
    }
    return (struct term){m, m};
}

static void release(struct term a, struct term b)
{
    bst_mat_free(a.dies);
    bst_mat_free(b.dies);
}

/* A copy of m in its own structure and precision. */
static int copy(struct combiner *cb, const bst_mat *m, bst_mat **out)
{
    return bst_mat_convert(cb->ctx, m, bst_mat_structure(m), bst_mat_precision(m), out);
}

/* diag(dr) a diag(dc): in a's own storage when this read is a's last (the same values). */
static struct term scaled(struct combiner *cb, const double *dr, struct term a, const double *dc)
{
    bst_mat *out = NULL;
    int rc = BST_OK;
    if (cb->status < 0 || !a.m)
        bst_mat_free(a.dies);
    else if (a.dies)
        rc = bsti_mat_scale_take(cb->ctx, dr, a.dies, dc, &out);
    else
        rc = bst_mat_scale(cb->ctx, dr, a.m, dc, &out);
    return result(cb, rc, out);
}

/* L a. */
static struct term lam_times(struct combiner *cb, struct term a)
{
    return scaled(cb, cb->lam, a, NULL);
}

/* L a L (both sides scaled by the projected solid angles). */
static struct term lam_both(struct combiner *cb, struct term a)
{
    return scaled(cb, cb->lam, a, cb->lam);
}

/* a b; a diagonal factor times a dense one read for the last time scales the dense one in its
 * own storage (what the product's kernel computes, mat_mul.c). */
static struct term mul(struct combiner *cb, struct term a, struct term b)
{
    if (cb->status >= 0 && a.m && b.m) {
        if (bst_mat_structure(a.m) == BST_DIAG && b.dies && bst_mat_structure(b.m) == BST_DENSE) {
            const double *d = bst_mat_diag_data((bst_mat *)a.m);
            struct term r = scaled(cb, d, b, NULL);
            bst_mat_free(a.dies);
            return r;
        }
        if (bst_mat_structure(b.m) == BST_DIAG && a.dies && bst_mat_structure(a.m) == BST_DENSE) {
            const double *d = bst_mat_diag_data((bst_mat *)b.m);
            struct term r = scaled(cb, NULL, a, d);
            bst_mat_free(b.dies);
            return r;
        }
    }
    bst_mat *out = NULL;
    int rc = cb->status >= 0 && a.m && b.m
                 ? bst_mat_mul(cb->ctx, a.m, b.m, cb->opts->drop_tol, &out) : BST_OK;
    release(a, b);
    return result(cb, rc, out);
}

/* L (a b): the product scaled by L afterwards, so that no scaled copy of a is formed. */
static struct term lam_mul(struct combiner *cb, struct term a, struct term b)
{
    if (!a.m || !b.m || bst_mat_structure(b.m) != BST_DIAG)
        return lam_times(cb, mul(cb, a, b));
    /* a diagonal factor folds into one scaling: no product held beside its scaled copy */
    struct term r = scaled(cb, cb->lam, a, bst_mat_diag_data((bst_mat *)b.m));
    bst_mat_free(b.dies);
    return r;
}

/* r + s; a new matrix also when one of them is zero; in a dense term's own storage when this read
 * is its last (bsti_mat_add_take: no copy of an N x N result). */
static struct term add(struct combiner *cb, struct term r, struct term s)
{
    bst_mat *out = NULL;
    int rc = BST_OK;
    if (cb->status >= 0 && r.m && s.m && (s.dies || r.dies)) {
        int take_s = s.dies && (!r.dies || bst_mat_structure(s.m) == BST_DENSE);
        struct term own = take_s ? s : r, other = take_s ? r : s; /* a dense one where both die */
        rc = bsti_mat_add_take(cb->ctx, own.dies, other.m, &out);
        bst_mat_free(other.dies);
        return result(cb, rc, out);
    }
    if (cb->status >= 0 && r.m && s.m)
        rc = bst_mat_add(cb->ctx, 1.0, r.m, 1.0, s.m, &out);
    else if (cb->status >= 0 && (r.m || s.m))
        rc = copy(cb, r.m ? r.m : s.m, &out);
    release(r, s);
    return result(cb, rc, out);
}

enum { LEFT = 0, RIGHT = 1 };


/* A solve's status told with the step, channel and which inter-reflection: a singular one is an
 * error so named, an ill-conditioned one a warning (noted for --strict). */
static int solve_status(struct combiner *cb, int rc, const char *what)
{
    if (rc == BST_ESINGULAR)
        bsti_error_prefix(cb->ctx, "layers 1-%zu, channel %s: inter-reflection %s", cb->step + 1,
                          cb->channel, what);
    if (rc == BST_WILLCOND) {
        bsti_error(cb->ctx, BST_WILLCOND,
                   "layers 1-%zu, channel %s: inter-reflection %s is ill-conditioned "
                   "(reciprocal condition %.3g): near-perfect mirrors facing each other",
                   cb->step + 1, cb->channel, what, cb->rcond);
        rc = note_warning(cb, rc);
    }
    return rc;
}

/* (I - A)^-1 B (LEFT) or B (I - A)^-1 (RIGHT).  A is a result of the step: a dense A becomes its
 * own LU factors, any other goes as soon as it is factored; a B read for the last time is solved
 * in its own storage when dense (bsti_solve_take).  cb->rcond receives the condition estimate (1
 * without a solve); what names the inter-reflection in messages; the factorization is handed out
 * in *slot when slot is not NULL (keep_slot). */
static struct term solve(struct combiner *cb, int side, struct term a, struct term b,
                         const char *what, bsti_factor **slot)
{
    bst_mat *out = NULL;
    int rc = BST_OK;
    cb->rcond = 1.0;
    if (cb->status < 0 || !b.m) {
        release(a, b);
    } else if (!a.m) { /* no inter-reflection: B itself */
        if (b.dies)
            out = b.dies;
        else
            rc = copy(cb, b.m, &out);
    } else {
        rc = bsti_solve_take(cb->ctx, side, a.dies, b.m, b.dies, cb->opts->rcond_warn,
                             cb->opts->precision, &out, &cb->rcond, slot);
    }
    rc = solve_status(cb, rc, what);
    return result(cb, rc, out);
}

/* (I - A)^-1 B1 and (I - A)^-1 B2 with one factorization: the first returned, the second in *x2
 * (as solve() for the rest). */
static struct term solve2(struct combiner *cb, struct term a, struct term b1, struct term b2,
                          const char *what, bsti_factor **slot, struct term *x2)
{
    bst_mat *out1 = NULL, *out2 = NULL;
    int rc = BST_OK;
    cb->rcond = 1.0;
    if (cb->status < 0 || !a.m || !b1.m || !b2.m) { /* a zero operand: solve() each, the one
                                                      * that needs no factorization first */
        struct term r1;
        if (!b1.m) {
            r1 = solve(cb, LEFT, keep(a), b1, what, slot);
            *x2 = solve(cb, LEFT, a, b2, what, slot);
        } else {
            *x2 = solve(cb, LEFT, keep(a), b2, what, slot);
            r1 = solve(cb, LEFT, a, b1, what, slot);
        }
        return r1;
    }
    rc = bsti_solve_take_left2(cb->ctx, a.dies, b1.m, b1.dies, b2.m, b2.dies,
                               cb->opts->rcond_warn, cb->opts->precision, &out1, &out2,
                               &cb->rcond, slot);
    rc = solve_status(cb, rc, what);
    *x2 = result(cb, rc, out2);
    return result(cb, rc, out1);
}

/* Whether Z's first factor leaves Z sparse (or diagonal), or sparse plus low rank: then Z is formed
 * before the solve and rides with it (solve2_z; a Woodbury solve's, solve_plus, takes a PLUS_LR
 * Z's base to the halves); a dense Z is formed after it, as it would add an N x N block to the
 * solve's peak. */
static int sparse_factor(const bst_mat *m)
{
    bst_structure st = bst_mat_structure(m);
    if (st == BST_PLUS_LR)
        st = bst_mat_structure(m->plus->base);
    return st == BST_SPARSE || st == BST_DIAG;
}

/* solve2 for from_outward and from_inward, with Z's products: *zx1 = Z X1 and *zx2 = Z X2 (Z
 * read once here), by the halves of a mirror-split inverse where they serve (mat.h), else by
 * plain products after the solve. */
static struct term solve2_z(struct combiner *cb, struct term a, struct term b1, struct term b2,
                            struct term z, const char *what, struct term *x2, struct term *zx1,
                            struct term *zx2)
{
    if (cb->status < 0 || !a.m || !b1.m || !b2.m || !z.m) { /* solve2's zero operands */
        struct term x1 = solve2(cb, a, b1, b2, what, NULL, x2);
        *zx2 = mul(cb, keep(z), keep(*x2));
        *zx1 = mul(cb, z, keep(x1));
        return x1;
    }
    bst_mat *out1 = NULL, *out2 = NULL, *zout1 = NULL, *zout2 = NULL;
    cb->rcond = 1.0;
    int rc = bsti_solve_take_left2_z(cb->ctx, a.dies, b1.m, b1.dies, b2.m, b2.dies, z.m,
                                     cb->opts->rcond_warn, cb->opts->precision, &out1, &out2,
                                     &zout1, &zout2, &cb->rcond, NULL);
    rc = solve_status(cb, rc, what);
    *x2 = result(cb, rc, out2);
    struct term x1 = result(cb, rc, out1);
    *zx2 = zout2 ? result(cb, rc, zout2) : mul(cb, keep(z), keep(*x2));
    *zx1 = zout1 ? result(cb, rc, zout1) : mul(cb, keep(z), keep(x1));
    bst_mat_free(z.dies);
    return x1;
}

/* Component c of S is t: kept, and reported (time since t0, the step's rcond). */
static void form(struct combiner *cb, struct part *s, bst_comp c, double t0, struct term t)
{
    s->own[c] = t.dies;
    double flops = cb->ctx->flops - cb->flops_mark;
    int mirror = cb->ctx->mirror_splits > cb->mirror_mark;
    cb->flops_mark = cb->ctx->flops;
    cb->mirror_mark = cb->ctx->mirror_splits;
    if (!cb->opts->on_step || cb->status < 0)
        return;
    bst_stack_step st = {
        .comp = c,
        .step = cb->step,
        .channel = cb->channel,
        .structure = t.m ? bst_mat_structure(t.m) : BST_ZERO,
        .nnz = t.m ? bst_mat_nnz(t.m) : 0,
        .seconds = now_seconds() - t0,
        .rcond = cb->rcond,
        .flops = flops,
        .rank = bsti_mat_rank(t.m),
        .mirror = mirror,
    };
    cb->opts->on_step(&st, cb->opts->opaque);
}

/* ------------------------------------------------------------------ one step: U and V
 *
 * The scalings by L go on the cheaper factor (U's reflection is the exterior part's, often a
 * diagonal pane), so that V's dense matrices are never copied just to be scaled.  Where a formula
 * nests, the innermost product is formed first and each factor goes as soon as it has been read. */

/* Whether a product with the gap's transmission t costs far less than GEMM: a diagonal (a pane),
 * or a sparse matrix of at most 1/16 of its values (a pane's tree file: its diagonal, a few values
 * more).  Then a pair of components is cheaper from two left solves (4 N^3 flops besides the LU)
 * and two products with t (4 nnz N, at a sparse product's speed, some 8 times slower a flop than
 * GEMM's: below 2 N^3 at that share) than from W = t (I - A)^-1, whose right solve and products
 * with two dense right-hand sides cost 6 N^3. */
#define CHEAP_SHARE (1.0 / 16.0)
static int cheap_transmission(const bst_mat *t)
{
    bst_structure s = bst_mat_structure(t);
    return t && (s == BST_DIAG || (s == BST_SPARSE && (double)bst_mat_nnz(t) <=
                                       CHEAP_SHARE * (double)bst_mat_rows(t) * (double)bst_mat_cols(t)));
}

/* L Tf1, for one of the reads of U's Tf that count_uses counted. */
static struct term lam_tf1(struct combiner *cb, struct part *u)
{
    return u->tf_lam ? use(u, BST_TF) : lam_times(cb, use(u, BST_TF));
}

/* L Rf2 L X1: what V reflects back into the gap of X1's light, for X1 = Rb1 (A2) and X1 = Tf1 (the
 * right-hand side of Rf). */
static struct term reflected_outwards(struct combiner *cb, struct part *v, struct part *u,
                                      bst_comp x1)
{
    return lam_mul(cb, use(v, BST_RF), x1 == BST_TF ? lam_tf1(cb, u) : lam_times(cb, use(u, x1)));
}

/* Light travelling inwards in the gap, A1 = L Rb1 L Rf2 = (L Rb1 L) Rf2:
 *   Tf = Tf2 (I - A1)^-1 L Tf1,   Rb = Rb2 + Tf2 (I - A1)^-1 (L Rb1 L) Tb2.
 * One of them: a left solve with its own right-hand side.  Both: W = Tf2 (I - A1)^-1 serves the
 * two, and Rb goes first, so that its temporaries beside W are gone before Tf exists; but when Tf2
 * is a pane's (cheap_transmission), two left solves with one factorization, each then multiplied
 * by Tf2, save W's dense products (2 N^3 flops each): X1 = (I - A1)^-1 L Tf1,
 * X2 = (I - A1)^-1 (L Rb1 L) Tb2. */
static void inward(struct combiner *cb, struct part *u, struct part *v, unsigned want,
                   struct part *s)
{
    const char *what = "towards the interior";
    bsti_factor **slot = keep_slot(cb, GAP_INWARD);
    double t0 = now_seconds();
    cb->flops_mark = cb->ctx->flops;
    cb->mirror_mark = cb->ctx->mirror_splits;
    struct term llrb1 = lam_both(cb, use(u, BST_RB));
    struct term a1 = mul(cb, want & BIT(BST_RB) ? keep(llrb1) : llrb1, use(v, BST_RF));
    if (want == BIT(BST_TF)) {
        struct term x = solve(cb, LEFT, a1, lam_tf1(cb, u), what, slot);
        form(cb, s, BST_TF, t0, mul(cb, use(v, BST_TF), x));
    } else if (want == BIT(BST_RB)) {
        struct term x = solve(cb, LEFT, a1, mul(cb, llrb1, use(v, BST_TB)), what, slot);
        form(cb, s, BST_RB, t0, add(cb, use(v, BST_RB), mul(cb, use(v, BST_TF), x)));
    } else if (cheap_transmission(v->m[BST_TF])) {
        struct term x2, x1 = solve2(cb, a1, lam_tf1(cb, u),
                                    mul(cb, llrb1, use(v, BST_TB)), what, slot, &x2);
        struct term tf2 = use(v, BST_TF);
        form(cb, s, BST_RB, t0, add(cb, use(v, BST_RB), mul(cb, keep(tf2), x2)));
        t0 = now_seconds();
        form(cb, s, BST_TF, t0, mul(cb, tf2, x1));
    } else {
        struct term w = solve(cb, RIGHT, a1, use(v, BST_TF), what, slot);
        form(cb, s, BST_RB, t0,
             add(cb, use(v, BST_RB), mul(cb, keep(w), mul(cb, llrb1, use(v, BST_TB)))));
        t0 = now_seconds();
        form(cb, s, BST_TF, t0, mul(cb, w, lam_tf1(cb, u)));
    }
}

/* Light travelling outwards in the gap, A2 = L Rf2 L Rb1 = L (Rf2 (L Rb1)):
 *   Tb = Tb1 (I - A2)^-1 L Tb2,   Rf = Rf1 + Tb1 (I - A2)^-1 L Rf2 L Tf1.
 * Both: W = Tb1 (I - A2)^-1 serves the two, or, when Tb1 is a pane's (cheap_transmission), two
 * left solves with one factorization (as inward).  One of them: a left solve with its own right-hand side. */
static void outward(struct combiner *cb, struct part *u, struct part *v, unsigned want,
                    struct part *s)
{
    const char *what = "towards the exterior";
    bsti_factor **slot = keep_slot(cb, GAP_OUTWARD);
    double t0 = now_seconds();
    cb->flops_mark = cb->ctx->flops;
    cb->mirror_mark = cb->ctx->mirror_splits;
    struct term a2 = reflected_outwards(cb, v, u, BST_RB);
    if (want == OUTWARD && cheap_transmission(u->m[BST_TB])) {
        struct term x2, x1 = solve2(cb, a2, lam_times(cb, use(v, BST_TB)),
                                    reflected_outwards(cb, v, u, BST_TF), what, slot, &x2);
        struct term tb1 = use(u, BST_TB);
        form(cb, s, BST_TB, t0, mul(cb, keep(tb1), x1));
        t0 = now_seconds();
        form(cb, s, BST_RF, t0, add(cb, use(u, BST_RF), mul(cb, tb1, x2)));
    } else if (want == OUTWARD) {
        struct term w = solve(cb, RIGHT, a2, use(u, BST_TB), what, slot);
        form(cb, s, BST_TB, t0, mul(cb, keep(w), lam_times(cb, use(v, BST_TB))));
        t0 = now_seconds();
        form(cb, s, BST_RF, t0,
             add(cb, use(u, BST_RF), mul(cb, w, reflected_outwards(cb, v, u, BST_TF))));
    } else if (want == BIT(BST_TB)) {
        struct term x = solve(cb, LEFT, a2, lam_times(cb, use(v, BST_TB)), what, slot);
        form(cb, s, BST_TB, t0, mul(cb, use(u, BST_TB), x));
    } else {
        struct term x = solve(cb, LEFT, a2, reflected_outwards(cb, v, u, BST_TF), what, slot);
        form(cb, s, BST_RF, t0, add(cb, use(u, BST_RF), mul(cb, use(u, BST_TB), x)));
    }
}

/* All four components from one of the gap's two inter-reflections, when one part is a pane (its
 * transmission and reflection cheap_transmission) and the other is not.  With X = L Rb1 and
 * Y = L Rf2, A1 = X Y and A2 = Y X, and the push-through identities
 *   (I - X Y)^-1 X = X (I - Y X)^-1,   (I - X Y)^-1 = I + X (I - Y X)^-1 Y   (and X, Y swapped)
 * turn the formulas of the other inter-reflection into products with this one's two solves, so
 * that the step factors once: one LU (2/3 N^3) fewer than inward and outward each factoring, the
 * solves and products as many (8 N^3 for a dense other part).  Not when the absorptance keeps each
 * inter-reflection's factorization (keep_slot), nor for fewer than four components.
 *
 * The pane's factor that follows a solve's dense result X goes into the other part's matrix
 * before it meets X (Z = Tf2 L Rb1 below: the other part's sparse or dense values scaled, where
 * L Rb1 X would be a scaled copy of X), so that each X is read as it is by the product with Z and
 * then scaled by the pane in its own storage at its last read: no N x N temporary, and two fresh
 * N x N blocks fewer a step.  A sparse Z is formed before the solve and goes with it
 * (solve2_z): a mirror-split inverse's halves multiply Z before X is made whole, half the flops
 * of Z X (a mirror blind's second step at k = 7: two products of 98 GFLOP each).
 *
 * U a pane, from the light going outwards:
 *   X1 = (I - A2)^-1 L Tb2,  X2 = (I - A2)^-1 L Rf2 L Tf1,  Z = Tf2 L Rb1,
 *   Rb = Rb2 + Z X1,  Tf = Tf2 L Tf1 + Z X2,  Tb = Tb1 X1,  Rf = Rf1 + Tb1 X2. */
static void from_outward(struct combiner *cb, struct part *u, struct part *v, struct part *s)
{
    const char *what = "towards the exterior";
    double t0 = now_seconds();
    cb->flops_mark = cb->ctx->flops;
    cb->mirror_mark = cb->ctx->mirror_splits;
    struct term a2 = reflected_outwards(cb, v, u, BST_RB);
    struct term tf2 = use(v, BST_TF), x1, x2;
    if (sparse_factor(tf2.m)) {
        struct term zx1, zx2, z = mul(cb, keep(tf2), lam_times(cb, use(u, BST_RB)));
        x1 = solve2_z(cb, a2, lam_times(cb, use(v, BST_TB)), reflected_outwards(cb, v, u, BST_TF),
                      z, what, &x2, &zx1, &zx2);
        form(cb, s, BST_RB, t0, add(cb, use(v, BST_RB), zx1));
        t0 = now_seconds();
        form(cb, s, BST_TF, t0, add(cb, mul(cb, tf2, lam_tf1(cb, u)), zx2));
    } else {
        x1 = solve2(cb, a2, lam_times(cb, use(v, BST_TB)), reflected_outwards(cb, v, u, BST_TF),
                    what, NULL, &x2);
        struct term z = mul(cb, keep(tf2), lam_times(cb, use(u, BST_RB)));
        form(cb, s, BST_RB, t0, add(cb, use(v, BST_RB), mul(cb, keep(z), keep(x1))));
        t0 = now_seconds();
        form(cb, s, BST_TF, t0, add(cb, mul(cb, tf2, lam_tf1(cb, u)), mul(cb, z, keep(x2))));
    }
    t0 = now_seconds();
    struct term tb1 = use(u, BST_TB);
    form(cb, s, BST_TB, t0, mul(cb, keep(tb1), x1));
    t0 = now_seconds();
    form(cb, s, BST_RF, t0, add(cb, use(u, BST_RF), mul(cb, tb1, x2)));
}

/* V a pane, from the light going inwards:
 *   X1 = (I - A1)^-1 L Tf1,  X2 = (I - A1)^-1 (L Rb1 L) Tb2,  Z = Tb1 L Rf2,
 *   Tb = Tb1 L Tb2 + Z X2,  Rf = Rf1 + Z X1,  Tf = Tf2 X1,  Rb = Rb2 + Tf2 X2. */
static void from_inward(struct combiner *cb, struct part *u, struct part *v, struct part *s)
{
    const char *what = "towards the interior";
    double t0 = now_seconds();
    cb->flops_mark = cb->ctx->flops;
    cb->mirror_mark = cb->ctx->mirror_splits;
    struct term llrb1 = lam_both(cb, use(u, BST_RB));
    struct term a1 = mul(cb, keep(llrb1), use(v, BST_RF));
    struct term tb1 = use(u, BST_TB), x1, x2;
    if (sparse_factor(tb1.m)) {
        struct term zx1, zx2, z = mul(cb, keep(tb1), lam_times(cb, use(v, BST_RF)));
        x1 = solve2_z(cb, a1, lam_tf1(cb, u), mul(cb, llrb1, use(v, BST_TB)), z, what, &x2, &zx1,
                      &zx2);
        form(cb, s, BST_TB, t0, add(cb, mul(cb, tb1, lam_times(cb, use(v, BST_TB))), zx2));
        t0 = now_seconds();
        form(cb, s, BST_RF, t0, add(cb, use(u, BST_RF), zx1));
    } else {
        x1 = solve2(cb, a1, lam_tf1(cb, u), mul(cb, llrb1, use(v, BST_TB)), what, NULL, &x2);
        struct term z = mul(cb, keep(tb1), lam_times(cb, use(v, BST_RF)));
        form(cb, s, BST_TB, t0,
             add(cb, mul(cb, tb1, lam_times(cb, use(v, BST_TB))), mul(cb, keep(z), keep(x2))));
        t0 = now_seconds();
        form(cb, s, BST_RF, t0, add(cb, use(u, BST_RF), mul(cb, z, keep(x1))));
    }
    t0 = now_seconds();
    struct term tf2 = use(v, BST_TF);
    form(cb, s, BST_TF, t0, mul(cb, keep(tf2), x1));
    t0 = now_seconds();
    form(cb, s, BST_RB, t0, add(cb, use(v, BST_RB), mul(cb, tf2, x2)));
}

/* Stored values of two components of a part (zero components hold none). */
static double stored(const struct part *p, bst_comp c1, bst_comp c2)
{
    return (p->m[c1] ? (double)bst_mat_nnz(p->m[c1]) : 0.0) +
           (p->m[c2] ? (double)bst_mat_nnz(p->m[c2]) : 0.0);
}

/* Which of from_outward (1) or from_inward (2) forms `want` of U and V, or neither (0).  When
 * both parts pass for panes (a pane and a sparse mirror blind's partial stack at k = 7, whose
 * inter-reflection may still need the dense LU), one factorization is still the cheaper: the
 * products it adds are with cheap matrices; the one of the sparser part is taken. */
static int one_factorization(struct combiner *cb, const struct part *u, const struct part *v,
                             unsigned want)
{
    if (want != BST_COMP_ALL || (cb->keep && cb->keep->fin))
        return 0;
    int u_pane = cheap_transmission(u->m[BST_TB]) && cheap_transmission(u->m[BST_RB]);
    int v_pane = cheap_transmission(v->m[BST_TF]) && cheap_transmission(v->m[BST_RF]);
    if (u_pane && v_pane)
        return stored(v, BST_TF, BST_RF) <= stored(u, BST_TB, BST_RB) ? 2 : 1;
    return u_pane ? 1 : v_pane ? 2 : 0;
}

/* Combine U (exterior part) and V (interior layer) into S, forming the components `want`: the
 * inward pair, then the outward one, which finds fewer of U's and V's components still held. */
static int combine_pair(struct combiner *cb, struct part *u, struct part *v, unsigned want,
                        struct part *s)
{
    memset(s, 0, sizeof *s);
    int one = one_factorization(cb, u, v, want);
    if (!one) {
        count_uses(want, u, v);
    } else { /* the reads from_outward and from_inward make */
        static const int uses[2][2][BST_NCOMP] = {
            /* U: Tf, Rf, Tb, Rb; V: Tf, Rf, Tb, Rb (bst_comp's order) */
            {{2, 1, 1, 2}, {1, 2, 1, 1}},
            {{1, 1, 1, 1}, {1, 2, 2, 1}}};
        for (int c = 0; c < BST_NCOMP; c++)
            u->uses[c] = uses[one - 1][0][c], v->uses[c] = uses[one - 1][1][c];
    }
    /* Every read of U's Tf is of L Tf1 (the inward right-hand side, the outward L Rf2 L Tf1): an
     * owned one is scaled once, in its own storage, instead of into a copy at each read. */
    u->tf_lam = 0;
    if (cb->status >= 0 && u->uses[BST_TF] > 0 && u->own[BST_TF]) {
        struct term t = scaled(cb, cb->lam, (struct term){u->m[BST_TF], u->own[BST_TF]}, NULL);
        u->m[BST_TF] = t.m;
        u->own[BST_TF] = t.dies;
        u->tf_lam = 1;
    }
    if (one == 1)
        from_outward(cb, u, v, s);
    else if (one == 2)
        from_inward(cb, u, v, s);
    if (!one && (want & INWARD))
        inward(cb, u, v, want & INWARD, s);
    if (!one && (want & OUTWARD))
        outward(cb, u, v, want & OUTWARD, s);
    for (int c = 0; c < BST_NCOMP; c++) {
        s->m[c] = s->own[c];
        if (cb->status >= 0 && (u->uses[c] || v->uses[c]))
            cb->status = bsti_error(cb->ctx, BST_EINTERNAL, "stack: component %s read other "
                                    "than counted", bst_comp_name((bst_comp)c));
    }
    if (cb->status < 0) {
        part_clear(s);
        return cb->status;
    }
    return BST_OK;
}

/* A component of an input layer in the form the combination works on: borrowed as it is (taken
 * from the layer, when `take` is the layer, to be freed at its last use), or a dense copy
 * (force_dense), or a float copy of a dense double matrix (single precision). */
static int prepare(struct combiner *cb, const bst_layer *l, bst_layer *take, size_t ch,
                   struct part *p, bst_comp c)
{
    const bst_mat *m = bst_layer_get(l, ch, c);
    bst_mat *taken = take ? bst_layer_take(take, ch, c) : NULL;
    p->m[c] = m;
    p->own[c] = taken;
    if (!m)
        return BST_OK;
    const bst_stack_opts *o = cb->opts;
    bst_structure s = bst_mat_structure(m);
    int to_dense = o->force_dense && s != BST_DENSE;
    int to_prec = s == BST_DENSE && bst_mat_precision(m) != o->precision;
    if (!to_dense && !to_prec)
        return BST_OK;
    bst_mat *copy = NULL;
    int rc = bst_mat_convert(cb->ctx, m, BST_DENSE, o->precision, &copy);
    bst_mat_free(taken);
    p->own[c] = copy;
    p->m[c] = copy;
    return rc;
}

/* Where the step being formed keeps the factorization of its inter-reflection g for the
 * absorptance: step k's inward one (I - L Rb_U L Rf_k, the gap's front incidence) in fin[k], the
 * outward one (I - L Rf_k L Rb_U) in fout[k]; NULL when nothing is kept. */
static bsti_factor **keep_slot(struct combiner *cb, enum gap g)
{
    if (!cb->keep || !cb->keep->fin)
        return NULL;
    bsti_factor **slot = g == GAP_INWARD ? &cb->keep->fin[cb->step] : &cb->keep->fout[cb->step];
    bsti_factor_free(*slot); /* not expected: one solve a side and step */
    *slot = NULL;
    return slot;
}

/* A copy of m, or a zero N x N matrix for m == NULL (zero). */
static int copy_or_zero(bst_ctx *ctx, const bst_mat *m, size_t N, bst_mat **out)
{
    return m ? bst_mat_convert(ctx, m, bst_mat_structure(m), bst_mat_precision(m), out)
             : bst_mat_new_zero(ctx, N, N, out);
}

/* The layers at the public entry: none NULL, one basis. */
static int check_layers(bst_ctx *ctx, size_t n, const bst_layer *const *layers)
{
    for (size_t i = 0; i < n; i++) {
        if (!layers[i])
            return bsti_error(ctx, BST_EINVAL, "stack: layer %zu is NULL", i + 1);
        if (!bst_basis_equal(layers[i]->basis, layers[0]->basis))
            return bsti_error(ctx, BST_EBASIS,
                              "stack: layer %zu (%s) is in basis %s (%zu patches), layer 1 in %s "
                              "(%zu patches): resample to one basis first", i + 1,
                              bst_layer_name(layers[i]), bst_basis_name(layers[i]->basis),
                              bst_basis_size(layers[i]->basis), bst_basis_name(layers[0]->basis),
                              bst_basis_size(layers[0]->basis));
    }
    return BST_OK;
}

/* Hand the wanted components of the whole stack (acc) to channel ch of res: copies where still
 * borrowed, zero matrices where a component vanished.  A component factored over a wide map stays
 * factored (double): its readers take its columns a block at a time (bsti_cols, mat.h), so that no
 * expanded copy of every component is ever held together (at k = 7 each is 1-2 GiB). */
static int hand_over(struct combiner *cb, struct part *acc, unsigned want, bst_layer *res,
                     size_t ch)
{
    bst_ctx *ctx = cb->ctx;
    size_t N = bst_basis_size(res->basis);
    int rc = BST_OK;
    for (int c = 0; c < BST_NCOMP && rc >= 0; c++) {
        if (!(want & BIT(c)))
            continue;
        bst_mat *m = acc->own[c];
        acc->own[c] = NULL;
        if (!m && acc->m[c])
            rc = bst_mat_convert(ctx, acc->m[c], bst_mat_structure(acc->m[c]),
                                 bst_mat_precision(acc->m[c]), &m);
        else if (!m)
            rc = bst_mat_new_zero(ctx, N, N, &m);
        if (rc >= 0 && !bsti_mat_finite(ctx, m)) { /* finite inputs whose products overflow */
            rc = bsti_error(ctx, BST_EINVAL, "layers 1-%zu, channel %s: %s overflows %s: input "
                            "values too large", cb->n, cb->channel, bst_comp_name((bst_comp)c),
                            bst_mat_precision(m) == BST_FLOAT ? "float" : "double");
            bst_mat_free(m);
        } else if (rc >= 0) {
            rc = bst_layer_set(ctx, res, ch, (bst_comp)c, m);
        }
    }
    return rc;
}

/* The stack in channel ch of res (cb->channel): layer by layer, each step combining the stack so
 * far with the next layer; need_s[k] / need_l[k]: the components needed of the partial stack of
 * layers 0..k and of layer k. */
static int combine_channel(struct combiner *cb, const bst_layer *const *layers, bst_layer **take,
                           const unsigned *need_s, const unsigned *need_l, unsigned want,
                           bst_layer *res, size_t ch, size_t nch)
{
    bst_ctx *ctx = cb->ctx;
    size_t n = cb->n;
    int rc = BST_OK;
    for (size_t i = 0; i < n && rc >= 0; i++)
        rc = note_warning(cb, bsti_energy_check_layer(ctx, layers[i], i,
                          (size_t)bst_layer_find_channel(layers[i], cb->channel), cb->opts->energy_tol));
    struct part acc = {0}, lay = {0}, next;
    size_t ch0 = (size_t)bst_layer_find_channel(layers[0], cb->channel);
    for (int c = 0; c < BST_NCOMP && rc >= 0; c++)
        if (need_l[0] & BIT(c))
            rc = prepare(cb, layers[0], take ? take[0] : NULL, ch0, &acc, (bst_comp)c);
    for (size_t k = 1; k < n && rc >= 0; k++) {
        size_t chk = (size_t)bst_layer_find_channel(layers[k], cb->channel);
        for (int c = 0; c < BST_NCOMP && rc >= 0; c++)
            if (need_l[k] & BIT(c))
                rc = prepare(cb, layers[k], take ? take[k] : NULL, chk, &lay, (bst_comp)c);
        cb->step = k;
        if (rc >= 0 && cb->keep && k >= 2) { /* the stack so far, for the absorptance */
            size_t N = bst_basis_size(res->basis);
            rc = copy_or_zero(ctx, acc.m[BST_TF], N, &cb->keep->tf[k]);
            if (rc >= 0)
                rc = copy_or_zero(ctx, acc.m[BST_RB], N, &cb->keep->rb[k]);
        }
        if (rc >= 0)
            rc = combine_pair(cb, &acc, &lay, need_s[k], &next);
        part_clear(&lay);
        part_clear(&acc);
        if (rc >= 0)
            acc = next;
        bsti_progress(ctx, (double)(ch * (n - 1) + k) / (double)(nch * (n - 1)), "combining");
    }
    if (rc >= 0)
        rc = hand_over(cb, &acc, want, res, ch);
    part_clear(&acc);
    if (rc >= 0)
        rc = note_warning(cb, bsti_energy_check_result(ctx, res, ch, cb->opts->energy_tol,
                                                       cb->warning >= BST_WENERGY));
    return rc;
}

static int combine_layers(bst_ctx *ctx, size_t n, const bst_layer *const *layers, bst_layer **take,
                          const bst_stack_opts *opts_in, bst_layer **out, struct bsti_prefix *keep)
{
    *out = NULL;
    if (n == 0 || !layers)
        return bsti_error(ctx, BST_EINVAL, "stack: no layers");
    bst_stack_opts defaults;
    bst_stack_opts_init(&defaults);
    const bst_stack_opts *opts = opts_in ? opts_in : &defaults;
    unsigned want = opts->comps ? opts->comps & BST_COMP_ALL : BST_COMP_ALL;
    if (!(opts->drop_tol >= 0.0 && opts->drop_tol < 1.0))
        return bsti_error(ctx, BST_EINVAL, "stack: drop tolerance %g is not in [0, 1)", opts->drop_tol);
    int rc = check_layers(ctx, n, layers);
    if (rc < 0)
        return rc;

    const bst_layer *l0 = layers[0];
    const char **names = bsti_calloc(ctx, l0->nchannels, sizeof *names);
    if (!names)
        return BST_ENOMEM;
    size_t nch = bst_plan_channels(n, layers, names); /* in layer 1's order */
    if (nch == 0) {
        bsti_free(ctx, names);
        return bsti_error(ctx, BST_ENOTFOUND, "stack: the layers have no spectral channel in common");
    }

    /* need[k]: components required of the partial stack of layers 0..k; needl[k]: of layer k. */
    unsigned *need_s = bsti_calloc(ctx, 2 * n, sizeof *need_s);
    bst_layer *res = NULL;
    rc = need_s ? bst_layer_new(ctx, l0->basis, nch, names, &res) : BST_ENOMEM;
    if (rc >= 0) {
        unsigned *need_l = need_s + n;
        need_s[n - 1] = want;
        for (size_t k = n - 1; k >= 1; k--)
            need(need_s[k], &need_s[k - 1], &need_l[k]);
        need_l[0] = need_s[0];
        struct combiner cb = {.ctx = ctx, .opts = opts, .lam = bst_basis_lambda(l0->basis), .n = n};
        for (size_t ch = 0; ch < nch && rc >= 0; ch++) {
            cb.channel = names[ch];
            cb.keep = keep && strcmp(names[ch], keep->name) == 0 ? keep : NULL;
            rc = combine_channel(&cb, layers, take, need_s, need_l, want, res, ch, nch);
        }
        if (rc >= 0 && cb.warning > 0)
            rc = cb.warning; /* the message of the last warning is in ctx */
    }
    bsti_free(ctx, need_s);
    bsti_free(ctx, names);
    if (rc < 0) {
        bst_layer_free(res);
        return rc;
    }
    *out = res;
    return rc;
}

int bsti_stack_combine_keep(bst_ctx *ctx, size_t n, const bst_layer *const *layers, bst_layer **take,
                   const bst_stack_opts *opts_in, bst_layer **out, struct bsti_prefix *keep)
{
    if (!ctx || !out)
        return BST_EINVAL;
    bsti_keep_begin(ctx); /* the steps' large blocks reused (ctx.h) */
    int no_mirror = ctx->no_mirror;
    ctx->no_mirror |= opts_in && opts_in->force_dense; /* the baseline splits nothing */
    int rc = combine_layers(ctx, n, layers, take, opts_in, out, keep);
    ctx->no_mirror = no_mirror;
    bsti_keep_end(ctx);
    return rc;
}

int bst_stack_combine(bst_ctx *ctx, size_t n, const bst_layer *const *layers,
                      const bst_stack_opts *opts, bst_layer **out)
{
    return bsti_stack_combine_keep(ctx, n, layers, NULL, opts, out, NULL);
}

int bst_stack_combine_consume(bst_ctx *ctx, size_t n, bst_layer **layers,
                              const bst_stack_opts *opts, bst_layer **out)
{
    if (!ctx || !out || !layers)
        return bsti_stack_combine_keep(ctx, n, (const bst_layer *const *)layers, NULL, opts, out, NULL);
    *out = NULL; /* also when the list below cannot be allocated */
    /* A layer listed twice (one pane object for both panes) is borrowed where it occurs first and
     * taken only at its last occurrence, and freed once. */
    bst_layer **take = bsti_calloc(ctx, n, sizeof *take);
    int rc = BST_ENOMEM;
    if (take) {
        for (size_t i = 0; i < n; i++) {
            size_t j = i + 1;
            while (j < n && layers[j] != layers[i])
                j++;
            take[i] = j == n ? layers[i] : NULL;
        }
        rc = bsti_stack_combine_keep(ctx, n, (const bst_layer *const *)layers, take, opts, out, NULL);
    }
    for (size_t i = 0; i < n; i++) {
        int last = 1;
        for (size_t j = i + 1; j < n && last; j++)
            last = layers[j] != layers[i];
        if (last)
            bst_layer_free(layers[i]);
    }
    for (size_t i = 0; i < n; i++)
        layers[i] = NULL;
    bsti_free(ctx, take);
    return rc;
}
