/* ttree_bound.c - the tensor-tree writer's bound on directional-hemispherical values (bsti_reduce
 * says what it promises and how the budgets are shared): a candidate node's column and row sums,
 * and whether its one value keeps them within budget.  Conventions: ttree_tw.h, ttree_write.h. */
#include <config.h>

#include <math.h>
#include <string.h>

#include "ttree_tw.h"

size_t bsti_tw_live_cells(const struct tw *w, int l, const size_t *c)
{
    size_t s = (size_t)1 << l, in = s * s;
    if (w->D == 3)
        in = c[0] >= w->half ? 0 : w->half - c[0] < s ? w->half - c[0] : s;
    return in * s * s;
}

size_t bsti_tw_sums_room(const struct tw *w, int l)
{
    size_t s = (size_t)1 << l;
    return w->D == 4 ? 2 * s * s : s;
}

/* The sums of the node of level l at corner c over its cells that hold data, negatives read as 0:
 * cs[x] over the outgoing cells of its incident index x (rank 4: x = x0 s + x1, rank 3: x = x0),
 * and with rs, rs[y] over its incident indices for its outgoing cell y (x2 s + x3).  Returns the
 * sum of them all; *nin the incident indices that hold data. */
static double bound_sums(const struct tw *w, int l, const size_t *c, double *cs, double *rs,
                         size_t *nin)
{
    size_t s = (size_t)1 << l, ni = w->D == 4 ? s * s : s, od = (size_t)w->D - 2, x;
    double total = 0.0;
    if (rs)
        memset(rs, 0, s * s * sizeof *rs);
    for (x = 0; x < ni; x++) {
        size_t i0 = c[0] + (w->D == 4 ? x / s : x);
        if (w->D == 3 && i0 >= w->half)
            break;
        size_t ibase = i0 * w->stride[0] + (w->D == 4 ? (c[1] + x % s) * w->stride[1] : 0);
        double col = 0.0;
        for (size_t a = 0; a < s; a++) { /* the outgoing cells, runs of the last dimension */
            size_t base = ibase + (c[od] + a) * w->stride[od] + c[od + 1];
            double *r = rs ? rs + a * s : NULL;
            for (size_t b = 0; b < s; b++) {
                double v = clamp0(w->d ? w->d[base + b] : w->f ? (double)w->f[base + b]
                                                                : w->t->get(w->t->opaque, base + b));
                col += v;
                if (r)
                    r[b] += v;
            }
        }
        cs[x] = col;
        total += col;
    }
    *nin = x;
    return total;
}

int bsti_tw_within_bound(const struct tw *w, struct eacc *a, double *ws, int l, const size_t *c,
                         double *sum)
{
    size_t s = (size_t)1 << l, per = s * s, nin, G2 = w->G * w->G, ts = a ? a->hside : 0;
    double *cs = ws, *rs = w->row_budget ? ws + per : NULL;
    double total = bound_sums(w, l, c, cs, rs, &nin);
    *sum = total;
    if (!nin)
        return 1;
    char text[40];
    float back;
    value_text(w, total / (double)(nin * per), text, &back); /* as leaf_merged writes it */
    double v = back, lam = M_PI / (double)G2;
    double col_share = a ? w->task_share : (double)per / (double)G2;
    double row_share = a ? w->task_share : (double)nin / (double)G2;
    for (size_t x = 0; x < nin; x++) { /* per outgoing cells of an incident index */
        size_t i0 = c[0] + (w->D == 4 ? x / s : x), i1 = w->D == 4 ? c[1] + x % s : 0;
        double change = lam * ((double)per * v - cs[x]); /* new - old */
        if (a)
            change -= lam * *hemi_at(w, a, i0, i1); /* (hemi sums old - new) */
        if (!(fabs(change) <= w->col_budget[w->D == 4 ? i0 * w->G + i1 : i0] * col_share))
            return 0;
    }
    for (size_t y = 0; rs && y < per; y++) { /* (rank 4: nin incident cells, every one live) */
        size_t o0 = c[2] + y / s, o1 = c[3] + y % s;
        double change = lam * ((double)nin * v - rs[y]);
        if (a)
            change += a->erow[(o0 - a->o0) * ts + o1 - a->o1];
        if (!(fabs(change) <= w->row_budget[o0 * w->G + o1] * row_share))
            return 0;
    }
    for (size_t y = 0; a && rs && y < per; y++)
        a->erow[(c[2] + y / s - a->o0) * ts + c[3] + y % s - a->o1] += lam * ((double)nin * v - rs[y]);
    return 1;
}
