/* layer.h - internal side of bst_layer: four components per channel over one basis. */
#ifndef BST_LAYER_H
#define BST_LAYER_H

#include "bsdfstack.h"

struct bst_layer {
    bst_ctx *ctx;
    bst_basis *basis;
    size_t nchannels;
    char **channels;
    bst_mat **comp; /* nchannels * BST_NCOMP, index channel * BST_NCOMP + comp; NULL = absent */
    char *name;
};

#endif
