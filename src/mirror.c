/* mirror.c - the mirror split of a dense inter-reflection solve (mirror.h). */
#include <config.h>

#include <float.h>
#include <math.h>

#include "mirror.h"

size_t bsti_mirror_side(size_t n)
{
    if (n < BSTI_MIRROR_MIN_N)
        return 0;
    size_t g = 2;
    while (g * g < n)
        g *= 2;
    return g * g == n ? g : 0;
}

/* S p for p < n / 2: the cell of column ix = p / g mirrored to column g - 1 - ix. */
static inline size_t partner(size_t g, size_t p)
{
    size_t ix = p / g;
    return p + (g - 1 - 2 * ix) * g;
}

#define MIRROR_KERNELS(T, SUF)                                                                   \
    static int holds_##SUF(const T *a, size_t n, size_t g, double tol)                            \
    {                                                                                             \
        double big = 0.0;                                                                         \
        for (size_t i = 0; i < n * n; i++) {                                                      \
            double v = fabs((double)a[i]);                                                        \
            if (!(v <= DBL_MAX)) /* NaN or infinite: no comparison means anything */              \
                return 0;                                                                         \
            big = v > big ? v : big;                                                              \
        }                                                                                         \
        double t = tol * big;                                                                     \
        size_t h = n / 2;                                                                         \
        for (size_t q = 0; q < h; q++) {                                                          \
            const T *cq = a + q * n, *csq = a + partner(g, q) * n;                                \
            for (size_t p = 0; p < h; p++) {                                                      \
                size_t sp = partner(g, p);                                                        \
                if (fabs((double)cq[p] - (double)csq[sp]) > t ||                                  \
                    fabs((double)csq[p] - (double)cq[sp]) > t)                                    \
                    return 0;                                                                     \
            }                                                                                     \
        }                                                                                         \
        return 1;                                                                                 \
    }                                                                                             \
    static void matrix_##SUF(T *a, size_t n, size_t g, int split)                                 \
    {                                                                                             \
        size_t h = n / 2;                                                                         \
        for (size_t q = 0; q < h; q++) {                                                          \
            T *cq = a + q * n, *csq = a + partner(g, q) * n;                                      \
            for (size_t p = 0; p < h; p++) {                                                      \
                size_t sp = partner(g, p);                                                        \
                if (split) {                                                                      \
                    double s = 0.5 * ((double)cq[p] + (double)csq[sp]);                           \
                    double d = 0.5 * ((double)csq[p] + (double)cq[sp]);                           \
                    cq[p] = (T)(s + d);                                                           \
                    csq[sp] = (T)(s - d);                                                         \
                } else {                                                                          \
                    double s = (double)cq[p], d = (double)csq[sp];                                \
                    cq[p] = csq[sp] = (T)(0.5 * (s + d));                                         \
                    csq[p] = cq[sp] = (T)(0.5 * (s - d));                                         \
                }                                                                                 \
            }                                                                                     \
        }                                                                                         \
    }                                                                                             \
    static void rows_##SUF(T *x, size_t n, size_t g, size_t ncols, int split)                     \
    {                                                                                             \
        size_t h = n / 2;                                                                         \
        double k = split ? 1.0 : 0.5;                                                             \
        for (size_t j = 0; j < ncols; j++) {                                                      \
            T *c = x + j * n;                                                                     \
            for (size_t p = 0; p < h; p++) {                                                      \
                size_t sp = partner(g, p);                                                        \
                double u = (double)c[p], v = (double)c[sp];                                       \
                c[p] = (T)(k * (u + v));                                                          \
                c[sp] = (T)(k * (u - v));                                                         \
            }                                                                                     \
        }                                                                                         \
    }

MIRROR_KERNELS(double, d)
MIRROR_KERNELS(float, f)

int bsti_mirror_holds(const void *a, bst_precision prec, size_t n, size_t g)
{
    return prec == BST_DOUBLE ? holds_d(a, n, g, BSTI_MIRROR_TOL)
                              : holds_f(a, n, g, BSTI_MIRROR_TOL_FLOAT);
}

void bsti_mirror_matrix(void *a, bst_precision prec, size_t n, size_t g, int split)
{
    if (prec == BST_DOUBLE)
        matrix_d(a, n, g, split);
    else
        matrix_f(a, n, g, split);
}

void bsti_mirror_rows(void *x, bst_precision prec, size_t n, size_t g, size_t ncols, int split)
{
    if (prec == BST_DOUBLE)
        rows_d(x, n, g, ncols, split);
    else
        rows_f(x, n, g, ncols, split);
}
