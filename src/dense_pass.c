/* dense_pass.c - passes that read every value of a dense matrix once: whether all are finite, and
 * column sums (weighted by rows, or of the positive values).  At k = 7 a component is 268 million
 * values, and a combination reads each result several times before and while it is written (the
 * solve's check, the energy check, the writer's validation and budgets); on one thread, each sum a
 * chain of dependent additions, those passes took about 5 s a channel.  Here runs of columns are
 * shared among the context's threads, and each run's columns are summed eight at a time (eight
 * independent chains).  Every column is still summed alone, in row order: the same bits whatever
 * the threads. */
#include <config.h>

#include <stdint.h>
#include <string.h>

#include "ctx.h"
#include "mat.h"

/* Columns a part takes at least (a pass over fewer is not worth a thread). */
#define PASS_MIN_COLS 64

struct pass {
    const bst_mat *m;
    size_t j0, j1;
    const double *w; /* row weights, NULL: 1 */
    int pos;         /* sums of max(value, 0) (a NaN read as 0) */
    double *out;     /* column sums, or NULL: the finiteness pass */
    int finite;
};

/* The column sums of columns j0 .. j1 - 1 of x (nr rows, column-major), eight columns a sweep.
 * Inlined with pos and the presence of w known, so that neither is tested in the loop. */
#define COL_SUMS(NAME, T)                                                                        \
    static inline __attribute__((always_inline)) void NAME(const T *x, size_t nr,                \
                                                           const double *w, int pos, size_t j0,  \
                                                           size_t j1, double *out)               \
    {                                                                                            \
        size_t j = j0;                                                                           \
        for (; j + 8 <= j1; j += 8) {                                                            \
            const T *c = x + j * nr;                                                             \
            double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0, s4 = 0.0, s5 = 0.0, s6 = 0.0,         \
                   s7 = 0.0;                                                                     \
            for (size_t i = 0; i < nr; i++) {                                                    \
                double wi = w ? w[i] : 1.0;                                                      \
                s0 += wi * VAL(c[i]);                                                            \
                s1 += wi * VAL(c[nr + i]);                                                       \
                s2 += wi * VAL(c[2 * nr + i]);                                                   \
                s3 += wi * VAL(c[3 * nr + i]);                                                   \
                s4 += wi * VAL(c[4 * nr + i]);                                                   \
                s5 += wi * VAL(c[5 * nr + i]);                                                   \
                s6 += wi * VAL(c[6 * nr + i]);                                                   \
                s7 += wi * VAL(c[7 * nr + i]);                                                   \
            }                                                                                    \
            out[j] = s0, out[j + 1] = s1, out[j + 2] = s2, out[j + 3] = s3;                      \
            out[j + 4] = s4, out[j + 5] = s5, out[j + 6] = s6, out[j + 7] = s7;                  \
        }                                                                                        \
        for (; j < j1; j++) {                                                                    \
            const T *c = x + j * nr;                                                             \
            double s = 0.0;                                                                      \
            for (size_t i = 0; i < nr; i++)                                                      \
                s += (w ? w[i] : 1.0) * VAL(c[i]);                                               \
            out[j] = s;                                                                          \
        }                                                                                        \
    }
/* 1.0 * v is v: an unweighted sum adds the values themselves, as a plain loop does. */
#define VAL(e) (pos ? ((double)(e) > 0.0 ? (double)(e) : 0.0) : (double)(e))
COL_SUMS(sums_f, float)
COL_SUMS(sums_d, double)
#undef VAL

/* The kernel with w's presence and pos as constants. */
#define SUMS_ANY(K, X, P)                                                                        \
    ((P)->w ? ((P)->pos ? K(X, (P)->m->rows, (P)->w, 1, (P)->j0, (P)->j1, (P)->out)               \
                        : K(X, (P)->m->rows, (P)->w, 0, (P)->j0, (P)->j1, (P)->out))              \
            : ((P)->pos ? K(X, (P)->m->rows, NULL, 1, (P)->j0, (P)->j1, (P)->out)                 \
                        : K(X, (P)->m->rows, NULL, 0, (P)->j0, (P)->j1, (P)->out)))

static void part_sums(const struct pass *p)
{
    if (p->m->prec == BST_DOUBLE)
        SUMS_ANY(sums_d, (const double *)p->m->dense, p);
    else
        SUMS_ANY(sums_f, (const float *)p->m->dense, p);
}

/* Whether n values at x are finite, by their exponent bits (all ones: Inf or NaN), in blocks
 * whose test the compiler makes a vector OR; U the unsigned integer of T's size. */
#define FINITE(NAME, T, U, EXP)                                                                  \
    static int NAME(const T *x, size_t n)                                                        \
    {                                                                                            \
        const U e = EXP;                                                                         \
        size_t k = 0;                                                                            \
        for (; k + 1024 <= n; k += 1024) {                                                       \
            U bad = 0;                                                                           \
            for (size_t q = 0; q < 1024; q++) {                                                  \
                U u;                                                                             \
                memcpy(&u, x + k + q, sizeof u);                                                 \
                bad |= (u & e) == e;                                                             \
            }                                                                                    \
            if (bad)                                                                             \
                return 0;                                                                        \
        }                                                                                        \
        for (; k < n; k++) {                                                                     \
            U u;                                                                                 \
            memcpy(&u, x + k, sizeof u);                                                         \
            if ((u & e) == e)                                                                    \
                return 0;                                                                        \
        }                                                                                        \
        return 1;                                                                                \
    }
FINITE(finite_f, float, uint32_t, 0x7f800000u)
FINITE(finite_d, double, uint64_t, 0x7ff0000000000000u)

static void *run_part(void *opaque)
{
    struct pass *p = opaque;
    const bst_mat *m = p->m;
    if (p->out) {
        part_sums(p);
    } else {
        size_t from = p->j0 * m->rows, n = (p->j1 - p->j0) * m->rows;
        p->finite = m->prec == BST_DOUBLE ? finite_d((const double *)m->dense + from, n)
                                          : finite_f((const float *)m->dense + from, n);
    }
    return NULL;
}

/* Runs of columns (multiples of eight but the last) over the threads ctx allows (ctx NULL: one). */
static void run(bst_ctx *ctx, struct pass *tmpl)
{
    size_t n = tmpl->m->cols;
    size_t t = ctx ? (size_t)bsti_ctx_workers_no_alloc(ctx, n / PASS_MIN_COLS) : 1;
    struct pass part[BST_THREADS_MAX];
    size_t per = (n + t - 1) / t;
    per = (per + 7) / 8 * 8;
    size_t np = 0;
    for (size_t j = 0; j < n && np < BST_THREADS_MAX; j += per, np++) {
        part[np] = *tmpl;
        part[np].j0 = j;
        part[np].j1 = j + per < n ? j + per : n;
        part[np].finite = 1;
    }
    bsti_run_parts(part, sizeof *part, np, run_part);
    tmpl->finite = 1;
    for (size_t q = 0; q < np; q++)
        tmpl->finite = tmpl->finite && part[q].finite;
}

int bsti_dense_finite(bst_ctx *ctx, const bst_mat *m)
{
    struct pass p = {.m = m};
    run(ctx, &p);
    return p.finite;
}

void bsti_dense_col_sums(bst_ctx *ctx, const bst_mat *m, const double *w, int pos, double *out)
{
    struct pass p = {.m = m, .w = w, .pos = pos, .out = out};
    run(ctx, &p);
}
