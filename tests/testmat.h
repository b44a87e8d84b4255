/* testmat.h - random structured matrices and dense reference arithmetic for the algebra tests. */
#ifndef BST_TESTMAT_H
#define BST_TESTMAT_H

#include "testutil.h"

/* Kinds of test operand: the four structures, dense in both precisions. */
enum { TM_ZERO, TM_DIAG, TM_SPARSE, TM_DENSE, TM_FLOAT, TM_NKINDS };
extern const char *const tm_kind_name[TM_NKINDS];

/* A random rows x cols matrix of the kind (DIAG needs rows == cols), values uniform in
 * [-scale, scale), sparse with about 5% fill plus the diagonal. */
bst_mat *tm_random(bst_ctx *ctx, int kind, size_t rows, size_t cols, double scale, tu_rng *r);
/* Column-major double copy (caller frees). */
double *tm_dense(bst_ctx *ctx, const bst_mat *m);
/* max |a - b| over n values, NaN-aware (NaN gives infinity). */
double tm_maxdiff(const double *a, const double *b, size_t n);
double tm_maxabs(const double *a, size_t n);
/* C = A B with plain loops (m x k times k x n). */
void tm_gemm(size_t m, size_t k, size_t n, const double *a, const double *b, double *c);
/* Machine epsilon of a matrix's precision. */
double tm_eps(const bst_mat *m);

#endif
