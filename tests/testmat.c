/* testmat.c - see testmat.h. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "testmat.h"

const char *const tm_kind_name[TM_NKINDS] = {"zero", "diag", "sparse", "dense", "float"};

bst_mat *tm_random(bst_ctx *ctx, int kind, size_t rows, size_t cols, double scale, tu_rng *r)
{
    bst_mat *m = NULL;
    switch (kind) {
    case TM_ZERO: ck_assert_int_eq(bst_mat_new_zero(ctx, rows, cols, &m), BST_OK); break;
    case TM_DIAG: {
        double *d = malloc((rows ? rows : 1) * sizeof *d);
        for (size_t i = 0; i < rows; i++)
            d[i] = scale * (2.0 * tu_rng_uniform(r) - 1.0);
        ck_assert_int_eq(bst_mat_new_diag(ctx, rows, d, &m), BST_OK);
        free(d);
        break;
    }
    case TM_SPARSE: {
        size_t cap = rows * cols / 20 + rows + cols + 1, n = 0;
        size_t *ri = malloc(cap * sizeof *ri), *ci = malloc(cap * sizeof *ci);
        double *x = malloc(cap * sizeof *x);
        for (size_t j = 0; j < cols; j++)
            for (size_t i = 0; i < rows; i++)
                if ((i == j || tu_rng_uniform(r) < 0.05) && n < cap) {
                    ri[n] = i, ci[n] = j;
                    x[n++] = scale * (2.0 * tu_rng_uniform(r) - 1.0);
                }
        ck_assert_int_eq(bst_mat_new_sparse(ctx, rows, cols, n, ri, ci, x, &m), BST_OK);
        free(ri), free(ci), free(x);
        break;
    }
    case TM_DENSE:
    case TM_FLOAT: {
        bst_precision p = kind == TM_DENSE ? BST_DOUBLE : BST_FLOAT;
        ck_assert_int_eq(bst_mat_new_dense(ctx, rows, cols, p, &m), BST_OK);
        void *d = bst_mat_dense_data(m);
        for (size_t k = 0; k < rows * cols; k++) {
            double v = scale * (2.0 * tu_rng_uniform(r) - 1.0);
            if (p == BST_DOUBLE)
                ((double *)d)[k] = v;
            else
                ((float *)d)[k] = (float)v;
        }
        break;
    }
    }
    return m;
}

double *tm_dense(bst_ctx *ctx, const bst_mat *m)
{
    size_t n = bst_mat_rows(m) * bst_mat_cols(m);
    double *d = malloc((n ? n : 1) * sizeof *d);
    ck_assert_int_eq(bst_mat_to_dense_array(ctx, m, d), BST_OK);
    return d;
}

double tm_maxdiff(const double *a, const double *b, size_t n)
{
    double m = 0.0;
    for (size_t k = 0; k < n; k++) {
        double d = fabs(a[k] - b[k]);
        if (isnan(d))
            return INFINITY;
        m = fmax(m, d);
    }
    return m;
}

double tm_maxabs(const double *a, size_t n)
{
    double m = 0.0;
    for (size_t k = 0; k < n; k++)
        m = fmax(m, fabs(a[k]));
    return m;
}

void tm_gemm(size_t m, size_t k, size_t n, const double *a, const double *b, double *c)
{
    for (size_t j = 0; j < n; j++)
        for (size_t i = 0; i < m; i++) {
            double s = 0.0;
            for (size_t q = 0; q < k; q++)
                s += a[q * m + i] * b[j * k + q];
            c[j * m + i] = s;
        }
}

double tm_eps(const bst_mat *m)
{
    return (bst_mat_structure(m) == BST_DENSE && bst_mat_precision(m) == BST_FLOAT) ? FLT_EPSILON
                                                                                  : DBL_EPSILON;
}
