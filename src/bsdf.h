/* bsdf.h - internal side of bst_bsdf, a BSDF XML file as stored: shared by the reader and
 * evaluator (xml.c) and the resampling onto bases (resample.c).
 *
 * Components are indexed by bst_comp in the file's own sides (XML "Front" is our front, the
 * exterior, -Z: CONVENTIONS.md 1); a component the file leaves out is NULL in both tree and mat. */
#ifndef BST_BSDF_H
#define BST_BSDF_H

#include "bsdfstack.h"
#include "ttree.h"

#define BSTI_BSDF_MAX_CHANNELS 16

struct bst_bsdf {
    bst_ctx *ctx;
    char *path;
    bst_file_kind kind;
    int k;                 /* tensor-tree order read: the depth, at most BST_K_MAX */
    int depth;             /* tensor-tree depth stored */
    size_t negatives;      /* negative values read as 0 */
    bst_precision prec;    /* of the dense components of bst_bsdf_to_layer (read option) */
    bst_rank3_rule rank3;  /* how bst_bsdf_to_layer lays a rank-3 tree on a finer grid */
    bst_basis *klems;      /* Klems files */
    size_t nch;
    char *channels[BSTI_BSDF_MAX_CHANNELS];
    bsti_ttree *tree[BSTI_BSDF_MAX_CHANNELS][BST_NCOMP];
    double *mat[BSTI_BSDF_MAX_CHANNELS][BST_NCOMP]; /* Klems, column-major N x N, M[o + N i] */
};

/* 1 when the file stores component c of channel ch. */
static inline int bsti_bsdf_stored(const bst_bsdf *b, size_t ch, int c)
{
    return b->tree[ch][c] || b->mat[ch][c];
}

/* The transmission that reciprocity gives c from (Tf <-> Tb), -1 for a reflection. */
static inline int bsti_bsdf_reciprocal(int c)
{
    return c == BST_TF ? BST_TB : c == BST_TB ? BST_TF : -1;
}

#endif
