/* write_bound.h - what a reduced tensor tree may change: a budget for every incident patch's
 * directional-hemispherical value, per channel and component, taken from the layer written.
 *
 * The promise (bsdfstack-convert(1), "Tree reduction"): read back, every incident patch's
 * directional-hemispherical T and R of every component and channel lies within tol of the
 * layer's, and T + R on a side never exceeds the layer's largest T + R on that side by more than
 * tol.  The tree writer keeps each patch's change within its budget (bsti_reduce); here the
 * budgets are shared out so that both halves of the promise hold:
 * - on a side whose present components (T, R or both: m of them) give S(i) = T(i) + R(i), largest
 *   Smax, each gets b(i) = min(tol, (tol + Smax - S(i)) / m);
 * - each is then lowered by rho H(i), H(i) the component's own value and rho the largest relative
 *   rounding of a value's text (the writer counts the rounding it has made when it merges, but not
 *   that of the values it keeps after its last merge); where rho H(i) exceeds b(i), no merge can
 *   make up for it and the promise fails whatever the tree: the least b(i) / H(i) over every
 *   component and patch (afford) is the coarsest rounding that keeps it, and the writer takes
 *   more digits or refuses (xml_write.c) where rho would exceed it;
 * - a rank-4 Tf left out of the file is read as Tb's reciprocal (CONVENTIONS.md 1,
 *   Tf(o, i) = Tb(a(i), a(o))), so Tf's value at front patch i is Tb's row a(i) summed over
 *   incidence: that row gets Tf's budget less what reciprocity itself changes there, |Tf's column
 *   sum - Tb's row sum|; where that alone exceeds Tf's budget, Tf is written after all.
 * Values are as a reader stores them (negatives 0).  Shirley-Chiu layers only (trees). */
#ifndef BST_WRITE_BOUND_H
#define BST_WRITE_BOUND_H

#include <stddef.h>
#include "bsdfstack.h"

typedef struct {
    size_t nch, n;          /* channels, patches */
    double *col;            /* nch * BST_NCOMP * n: channel ch, component c at (ch BST_NCOMP + c) n */
    double *row;            /* nch * n: Tb's rows where Tf is left out (else unused) */
    /* The largest relative rounding of every value that keeps every budget: the least b(i) / H(i)
     * (budget before rounding over the component's own value; INFINITY where every H is 0), and
     * where it is least: channel, component, patch (of the order its budgets have), H and b. */
    double afford;
    size_t afford_ch, afford_i;
    int afford_c;
    double afford_h, afford_b;
} bsti_bounds;

/* A channel's transmission sums, negatives read as 0 (as a tree reader stores them): Tf's column
 * sums, Tb's column sums and row sums, n each; made by the reciprocity check on its way where
 * both transmissions are FACTORED (have = 1; bsti_reciprocity_sums), which saves the bound an
 * expansion of each. */
typedef struct {
    double *tf_col, *tb_col, *tb_row;
    int have;
} bsti_tsums;

/* bst_metrics_reciprocity's err of channel ch, and with s (room for its three sums of n values)
 * the sums where both transmissions are FACTORED (metrics.c). */
int bsti_reciprocity_sums(bst_ctx *ctx, const bst_layer *l, size_t ch, double *err, bsti_tsums *s);

/* Budgets of every component of layer l (Shirley-Chiu) under tolerance tol >= 0, values written
 * with relative rounding at most rho (bsti_bounds_rho); pre (NULL, or one a channel): sums made
 * already.  omit_tf:
 * per channel, 1 where Tf is to be left out as Tb's reciprocal; set to 0 here where reciprocity
 * alone would break the promise.  Free with bsti_bounds_free. */
int bsti_bounds_layer(bst_ctx *ctx, const bst_layer *l, double tol, double rho, int *omit_tf,
                      const bsti_tsums *pre, bsti_bounds *b);

/* The same for a variable-resolution file (bst_bsdf_write_varres): Tf and Rf at the fine order
 * v->k (the fine columns at their patches, the coarse values elsewhere; b->n = 4^k), Tb and Rb
 * at the coarse layer's order (the first 4^kc values of their slots).  Nothing is left out. */
int bsti_bounds_varres(bst_ctx *ctx, const bst_layer *coarse, const bst_varres *v, double tol,
                       double rho, bsti_bounds *b);

/* The largest relative change of a value written with `digits` significant digits of its float
 * (0: the shortest text of the float). */
double bsti_bounds_rho(int digits);

/* The fewest significant digits d in [from, 9] with bsti_bounds_rho(d) <= afford, or 0 (the
 * shortest text of the float) when there is none. */
int bsti_bounds_digits(double afford, int from);

/* The one a writer takes: bsti_bounds_varres with v, else bsti_bounds_layer with omit's Tf flags
 * (omit: nch BST_NCOMP, channel ch's component c at ch BST_NCOMP + c, 1 where it is left out as
 * the other side's reciprocal; a Tf that must be written after all is set to 0 there). */
int bsti_bounds_write(bst_ctx *ctx, const bst_layer *l, const bst_varres *v, double tol,
                      double rho, int *omit, const bsti_tsums *pre, bsti_bounds *b);

void bsti_bounds_free(bst_ctx *ctx, bsti_bounds *b);

/* Budgets of the G/2 rank-3 incident indices (ix = G/2 - 1 - j for the square ring j of the
 * grid) from col's G^2 (order k): the least over each ring's cells. */
void bsti_bounds_rings(int k, const double *col, double *ring);

#endif
