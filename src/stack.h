/* stack.h - internal entry points of the stack module (stack.c). */
#ifndef BST_STACK_H
#define BST_STACK_H
#include "bsdfstack.h"

/* bst_stack_combine and bst_stack_absorptance of channel ch (abs_front and abs_back as there, either
 * may be NULL) in one pass: the absorptance reads the partial stacks the combination forms.  The
 * results agree with the two calls to rounding; the return is the highest warning or an error. */
int bsti_stack_combine_absorptance(bst_ctx *ctx, size_t n, const bst_layer *const *layers,
                                   size_t ch, const bst_stack_opts *opts, bst_layer **out,
                                   double *abs_front, double *abs_back);
#endif
