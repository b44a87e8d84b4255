/* stack.h - internal entry points of the stack module: the combination (stack.c), its energy
 * checks (stack_energy.c) and the absorptance that rides on it (absorptance.c). */
#ifndef BST_STACK_H
#define BST_STACK_H
#include "bsdfstack.h"
#include "mat.h"

/* What the combination keeps of its partial stacks for the absorptance: of channel `name`, copies
 * of the Tf and Rb of layers 0..k-1 in tf[k] and rb[k], k = 2..n-1 (a zero component as a zero
 * matrix), and, where fin is not NULL, step k's factorizations of its inter-reflections I - A1
 * (inwards, fin[k]) and I - A2 (outwards, fout[k]). */
struct bsti_prefix {
    const char *name;
    bst_mat **tf, **rb;
    bsti_factor **fin, **fout;
};

/* bst_stack_combine; with `take` (the same layers, writable) each input component is taken from
 * its layer when the combination reaches it and freed at its last use (bst_stack_combine_consume);
 * with `keep`, what it names is kept there as it is formed. */
int bsti_stack_combine_keep(bst_ctx *ctx, size_t n, const bst_layer *const *layers, bst_layer **take,
                            const bst_stack_opts *opts, bst_layer **out, struct bsti_prefix *keep);

/* bst_stack_combine and bst_stack_absorptance of channel ch (abs_front and abs_back as there, either
 * may be NULL) in one pass: the absorptance reads the partial stacks the combination forms.  The
 * return is the highest warning or an error. */
int bsti_stack_combine_absorptance(bst_ctx *ctx, size_t n, const bst_layer *const *layers,
                                   size_t ch, const bst_stack_opts *opts, bst_layer **out,
                                   double *abs_front, double *abs_back);

/* Energy: an input layer's T + R above 1 + tol on some incident patch of either side
 * (BST_WENERGY with the message, the first side found; BST_EINVAL for values that are not
 * finite; li is its place in the stack, for the message), and the system's T + R above 1 + tol
 * or a hemispherical value below -tol (the first found; none when warned says a warning of this
 * kind was given already). */
int bsti_energy_check_layer(bst_ctx *ctx, const bst_layer *l, size_t li, size_t ch, double tol);
int bsti_energy_check_result(bst_ctx *ctx, const bst_layer *res, size_t ch, double tol,
                             int warned);
#endif
