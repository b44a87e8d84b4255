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

#define image bsti_mirror_image
#define first bsti_mirror_first
#define turned bsti_mirror_turned

#define MIRROR_KERNELS(T, SUF)                                                                   \
    static int holds_##SUF(const T *a, size_t n, size_t g, int axis, double tol)                  \
    {                                                                                             \
        /* one pass: each value is read once, as one of a pair (the largest |value| and the      \
           largest difference gathered together, compared at the end) */                          \
        double big = 0.0, diff = 0.0;                                                             \
        for (size_t q = 0; q < n; q++) {                                                          \
            if (!first(g, q, axis))                                                               \
                continue;                                                                         \
            const T *cq = a + q * n, *csq = a + image(g, q, axis) * n;                            \
            for (size_t p = 0; p < n; p++) {                                                      \
                if (!first(g, p, axis))                                                           \
                    continue;                                                                     \
                size_t sp = image(g, p, axis);                                                    \
                double u = (double)cq[p], v = (double)csq[sp], w = (double)csq[p],                \
                       x = (double)cq[sp];                                                        \
                double m = fmax(fmax(fabs(u), fabs(v)), fmax(fabs(w), fabs(x)));                  \
                double d = fmax(fabs(u - v), fabs(w - x));                                        \
                if (!(fabs(u) + fabs(v) + fabs(w) + fabs(x) <= DBL_MAX)) /* NaN or infinite (fmax   \
                    drops NaN): no comparison means anything */                                   \
                    return 0;                                                                     \
                big = m > big ? m : big;                                                          \
                diff = d > diff ? d : diff;                                                       \
            }                                                                                     \
        }                                                                                         \
        return diff <= tol * big;                                                                 \
    }                                                                                             \
    static void turn_##SUF(T *a, size_t n, size_t g, size_t ncols, int cols)                      \
    {                                                                                             \
        for (size_t j = 0; j < ncols; j++) { /* rows p <-> Q p in every column */                 \
            T *c = a + j * n;                                                                     \
            for (size_t p = 0; p < n; p++) {                                                      \
                size_t qp = turned(g, p);                                                         \
                if (qp > p) {                                                                     \
                    T x = c[p];                                                                   \
                    c[p] = c[qp], c[qp] = x;                                                      \
                }                                                                                 \
            }                                                                                     \
        }                                                                                         \
        for (size_t j = 0; cols && j < n; j++) { /* columns j <-> Q j */                          \
            size_t qj = turned(g, j);                                                             \
            if (qj > j)                                                                           \
                for (size_t i = 0; i < n; i++) {                                                  \
                    T x = a[j * n + i];                                                           \
                    a[j * n + i] = a[qj * n + i], a[qj * n + i] = x;                              \
                }                                                                                 \
        }                                                                                         \
    }                                                                                             \
    static void matrix_##SUF(T *a, size_t n, size_t g, int split)                                 \
    {                                                                                             \
        size_t h = n / 2;                                                                         \
        for (size_t q = 0; q < h; q++) {                                                          \
            T *cq = a + q * n, *csq = a + image(g, q, 0) * n;                                      \
            for (size_t p = 0; p < h; p++) {                                                      \
                size_t sp = image(g, p, 0);                                                        \
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
                size_t sp = image(g, p, 0);                                                        \
                double u = (double)c[p], v = (double)c[sp];                                       \
                c[p] = (T)(k * (u + v));                                                          \
                c[sp] = (T)(k * (u - v));                                                         \
            }                                                                                     \
        }                                                                                         \
    }

MIRROR_KERNELS(double, d)
MIRROR_KERNELS(float, f)

int bsti_mirror_holds(const void *a, bst_precision prec, size_t n, size_t g, int axis)
{
    return prec == BST_DOUBLE ? holds_d(a, n, g, axis, BSTI_MIRROR_TOL)
                              : holds_f(a, n, g, axis, BSTI_MIRROR_TOL_FLOAT);
}

void bsti_mirror_turn(void *a, bst_precision prec, size_t n, size_t g, size_t ncols, int cols)
{
    if (prec == BST_DOUBLE)
        turn_d(a, n, g, ncols, cols);
    else
        turn_f(a, n, g, ncols, cols);
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
