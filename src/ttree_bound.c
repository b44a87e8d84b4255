/* ttree_bound.c - the tensor-tree writer's bound on directional-hemispherical values (bsti_reduce
 * says what it promises and how the budgets are shared): a candidate node's column and row sums,
 * and whether its one value keeps them within budget.  Inside a task the sums come from the
 * task's sums by level, made once at its first check (a refused node's children are checked
 * next, and each level's rescan of the cells was most of the bound's time); a candidate clearly
 * off budget is refused before its text is made.  Both give the decisions of the plain checks
 * (bsti_reduce's plain_checks; tests/test_write.c compares them).  Conventions: ttree_tw.h,
 * ttree_write.h. */
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

/* The first cell of incident index x's runs in the node of side s at corner c. */
static inline size_t incident_base(const struct tw *w, const size_t *c, size_t s, size_t x)
{
    return (c[0] + (w->D == 4 ? x / s : x)) * w->stride[0] +
           (w->D == 4 ? (c[1] + x % s) * w->stride[1] : 0);
}

/* bound_sums for one kind of storage (tw_kind; inlined with kind known).  Four incident indices are read
 * side by side: each one's column sum is still a chain of additions in the order of its cells,
 * and each row sum takes its incident indices in turn, so the sums are those of a loop over one
 * index at a time, to the bit; the four chains hide the additions' latency, which bounded the
 * check (a k = 7 component's nodes above the writer's tasks are read once a level). */
static inline __attribute__((always_inline)) double sums_of(const struct tw *w, int kind, int l,
                                                            const size_t *c, double *cs,
                                                            double *rs, size_t *nin)
{
    size_t s = (size_t)1 << l, ni = w->D == 4 ? s * s : s, od = (size_t)w->D - 2, nx = ni;
    if (w->D == 3) /* the incident indices that hold data: a prefix */
        nx = c[0] >= w->half ? 0 : w->half - c[0] < ni ? w->half - c[0] : ni;
    double total = 0.0;
    if (rs)
        memset(rs, 0, s * s * sizeof *rs);
    size_t x = 0;
    for (; x + 4 <= nx; x += 4) {
        size_t b0 = incident_base(w, c, s, x), b1 = incident_base(w, c, s, x + 1);
        size_t b2 = incident_base(w, c, s, x + 2), b3 = incident_base(w, c, s, x + 3);
        double c0 = 0.0, c1 = 0.0, c2 = 0.0, c3 = 0.0;
        for (size_t a = 0; a < s; a++) { /* the outgoing cells, runs of the last dimension */
            size_t off = (c[od] + a) * w->stride[od] + c[od + 1];
            double *r = rs ? rs + a * s : NULL;
            for (size_t b = 0; b < s; b++) {
                double v0 = clamp0(cell_at(w, kind, b0 + off + b));
                double v1 = clamp0(cell_at(w, kind, b1 + off + b));
                double v2 = clamp0(cell_at(w, kind, b2 + off + b));
                double v3 = clamp0(cell_at(w, kind, b3 + off + b));
                c0 += v0, c1 += v1, c2 += v2, c3 += v3;
                if (r) {
                    double t = r[b];
                    t += v0, t += v1, t += v2, t += v3;
                    r[b] = t;
                }
            }
        }
        cs[x] = c0, cs[x + 1] = c1, cs[x + 2] = c2, cs[x + 3] = c3;
        total += c0, total += c1, total += c2, total += c3;
    }
    for (; x < nx; x++) {
        size_t ibase = incident_base(w, c, s, x);
        double col = 0.0;
        for (size_t a = 0; a < s; a++) {
            size_t base = ibase + (c[od] + a) * w->stride[od] + c[od + 1];
            double *r = rs ? rs + a * s : NULL;
            for (size_t b = 0; b < s; b++) {
                double v = clamp0(cell_at(w, kind, base + b));
                col += v;
                if (r)
                    r[b] += v;
            }
        }
        cs[x] = col;
        total += col;
    }
    *nin = nx;
    return total;
}

/* The sums of the node of level l at corner c over its cells that hold data, negatives read as 0:
 * cs[x] over the outgoing cells of its incident index x (rank 4: x = x0 s + x1, rank 3: x = x0),
 * and with rs, rs[y] over its incident indices for its outgoing cell y (x2 s + x3).  Returns the
 * sum of them all; *nin the incident indices that hold data. */
static double bound_sums(const struct tw *w, int l, const size_t *c, double *cs, double *rs,
                         size_t *nin)
{
    int kind = tw_kind(w);
    return kind == 0 ? sums_of(w, 0, l, c, cs, rs, nin)
           : kind == 1 ? sums_of(w, 1, l, c, cs, rs, nin)
                       : sums_of(w, 2, l, c, cs, rs, nin);
}

/* Level l's part of a task's pyramid (l >= 1; side T = 2^split): cs, T^2 (T / 2^l)^2 sums (an
 * incident cell's over each node's outgoing cells, the node's index fastest), and with rows rs,
 * as many (an outgoing cell's over each node's incident cells, the outgoing cell fastest). */
static size_t pyr_level_size(size_t T, int l)
{
    size_t nb = T >> l;
    return T * T * nb * nb;
}

size_t bsti_tw_pyramid_room(const struct tw *w)
{
    if (w->D != 4 || !w->split || !w->col_budget || (!w->d && !w->f) || w->plain)
        return 0;
    size_t T = (size_t)1 << w->split, n = 0;
    if (T > 16)
        return 0;
    for (int l = 1; l <= w->split; l++)
        n += (w->row_budget ? 2 : 1) * pyr_level_size(T, l);
    return n;
}

/* Level l's sums in a's pyramid: *cs and *rs (NULL without rows). */
static void pyr_level(const struct tw *w, const struct eacc *a, int l, double **cs, double **rs)
{
    size_t T = a->hside, per = w->row_budget ? 2 : 1;
    double *p = a->pyr;
    for (int j = 1; j < l; j++)
        p += per * pyr_level_size(T, j);
    *cs = p;
    *rs = w->row_budget ? p + pyr_level_size(T, l) : NULL;
}

/* The task's pyramid from its cells (negatives read as 0), then level by level from the one
 * below: each sum is of four (a node's 2 x 2 children along the summed dimensions). */
static void pyr_build(const struct tw *w, struct eacc *a)
{
    size_t T = a->hside, T2 = T * T, nb = T / 2, nb2 = nb * nb;
    double *cs, *rs;
    pyr_level(w, a, 1, &cs, &rs);
    if (rs)
        memset(rs, 0, nb2 * T2 * sizeof *rs);
    for (size_t i0 = 0; i0 < T; i0++)
        for (size_t i1 = 0; i1 < T; i1++) {
            double *c = cs + (i0 * T + i1) * nb2;
            double *r = rs ? rs + ((i0 >> 1) * nb + (i1 >> 1)) * T2 : NULL;
            memset(c, 0, nb2 * sizeof *c);
            for (size_t o2 = 0; o2 < T; o2++) {
                size_t base = (a->h0 + i0) * w->stride[0] + (a->h1 + i1) * w->stride[1] +
                              (a->o0 + o2) * w->stride[2] + a->o1;
                double v[16], *cr = c + (o2 >> 1) * nb; /* (T <= 16: pyramid_room) */
                if (w->f)
                    for (size_t b = 0; b < T; b++)
                        v[b] = clamp0((double)w->f[base + b]);
                else
                    for (size_t b = 0; b < T; b++)
                        v[b] = clamp0(w->d[base + b]);
                for (size_t b = 0; b < nb; b++)
                    cr[b] += v[2 * b] + v[2 * b + 1];
                if (r)
                    for (size_t b = 0; b < T; b++)
                        r[o2 * T + b] += v[b];
            }
        }
    for (int l = 2; l <= w->split; l++) {
        double *cs1 = cs, *rs1 = rs;
        size_t nbf = nb; /* nodes a side below */
        pyr_level(w, a, l, &cs, &rs);
        nb = T >> l;
        for (size_t i = 0; i < T2; i++)
            for (size_t b2 = 0; b2 < nb; b2++)
                for (size_t b3 = 0; b3 < nb; b3++) {
                    const double *f = cs1 + i * nbf * nbf + 2 * b2 * nbf + 2 * b3;
                    cs[(i * nb + b2) * nb + b3] = (f[0] + f[1]) + (f[nbf] + f[nbf + 1]);
                }
        for (size_t b0 = 0; rs && b0 < nb; b0++)
            for (size_t b1 = 0; b1 < nb; b1++) {
                const double *f00 = rs1 + (2 * b0 * nbf + 2 * b1) * T2, *f01 = f00 + T2;
                const double *f10 = f00 + nbf * T2, *f11 = f10 + T2;
                double *d = rs + (b0 * nb + b1) * T2;
                for (size_t o = 0; o < T2; o++)
                    d[o] = (f00[o] + f01[o]) + (f10[o] + f11[o]);
            }
    }
    a->pyr_ready = 1;
}

/* bound_sums from a's pyramid (the node lies in a's task). */
static double pyr_sums(const struct tw *w, struct eacc *a, int l, const size_t *c, double *cs,
                       double *rs)
{
    if (!a->pyr_ready)
        pyr_build(w, a);
    size_t T = a->hside, s = (size_t)1 << l, nb = T >> l;
    size_t l0 = c[0] - a->h0, l1 = c[1] - a->h1, l2 = c[2] - a->o0, l3 = c[3] - a->o1;
    double *pc, *pr, total = 0.0;
    pyr_level(w, a, l, &pc, &pr);
    const double *col = pc + (l2 >> l) * nb + (l3 >> l);
    for (size_t x0 = 0; x0 < s; x0++)
        for (size_t x1 = 0; x1 < s; x1++) {
            double v = col[((l0 + x0) * T + l1 + x1) * nb * nb];
            cs[x0 * s + x1] = v;
            total += v;
        }
    if (rs) {
        const double *row = pr + ((l0 >> l) * nb + (l1 >> l)) * T * T + l2 * T + l3;
        for (size_t y0 = 0; y0 < s; y0++)
            memcpy(rs + y0 * s, row + y0 * T, s * sizeof *rs);
    }
    return total;
}

/* Would the node's one value v move some sum the bound watches (cs and rs: the node's sums as
 * bsti_tw_within_bound has them) off its budget by more than eps v a cell?  eps = 0: the exact
 * test, v the value a reader stores.  eps = w->text_eps, v the node's mean before its text is
 * made: the stored value lies within eps v of it, so a node found outside by more than that (and
 * 1e-13 of the terms, the arithmetic's own rounding) would fail the exact test too, and is
 * refused without making the text. */
static int outside(const struct tw *w, struct eacc *a, size_t s, const size_t *c, const double *cs,
                   const double *rs, size_t nin, double v, double eps, double col_share,
                   double row_share)
{
    size_t per = s * s, ts = a ? a->hside : 0;
    double lam = M_PI / (double)(w->G * w->G);
    double slack_col = lam * (double)per * v * eps, slack_row = lam * (double)nin * v * eps;
    for (size_t x = 0; x < nin; x++) { /* per outgoing cells of an incident index */
        size_t i0 = c[0] + (w->D == 4 ? x / s : x), i1 = w->D == 4 ? c[1] + x % s : 0;
        double old = a ? lam * *hemi_at(w, a, i0, i1) : 0.0; /* (hemi sums old - new) */
        double change = lam * ((double)per * v - cs[x]) - old; /* new - old */
        double guard = eps > 0.0 ? 1e-13 * (lam * ((double)per * v + cs[x]) + fabs(old)) : 0.0;
        if (!(fabs(change) <= w->col_budget[w->D == 4 ? i0 * w->G + i1 : i0] * col_share + slack_col + guard))
            return 1;
    }
    for (size_t y = 0; rs && y < per; y++) { /* (rank 4: nin incident cells, every one live) */
        size_t o0 = c[2] + y / s, o1 = c[3] + y % s;
        double old = a ? a->erow[(o0 - a->o0) * ts + o1 - a->o1] : 0.0;
        double change = lam * ((double)nin * v - rs[y]) + old;
        double guard = eps > 0.0 ? 1e-13 * (lam * ((double)nin * v + rs[y]) + fabs(old)) : 0.0;
        if (!(fabs(change) <= w->row_budget[o0 * w->G + o1] * row_share + slack_row + guard))
            return 1;
    }
    return 0;
}

int bsti_tw_within_bound(const struct tw *w, struct eacc *a, double *ws, int l, const size_t *c,
                         double *sum)
{
    size_t s = (size_t)1 << l, per = s * s, nin, G2 = w->G * w->G, ts = a ? a->hside : 0;
    double *cs = ws, *rs = w->row_budget ? ws + per : NULL;
    double total;
    if (a && a->pyr) {
        total = pyr_sums(w, a, l, c, cs, rs);
        nin = per;
    } else {
        total = bound_sums(w, l, c, cs, rs, &nin);
    }
    *sum = total;
    if (!nin)
        return 1;
    double lam = M_PI / (double)G2, v0 = total / (double)(nin * per);
    double col_share = a ? w->task_share : (double)per / (double)G2;
    double row_share = a ? w->task_share : (double)nin / (double)G2;
    if (!w->plain && outside(w, a, s, c, cs, rs, nin, v0, w->text_eps, col_share, row_share))
        return 0;
    char text[40];
    float back;
    value_text(w, v0, text, &back); /* as leaf_merged writes it */
    double v = back;
    if (outside(w, a, s, c, cs, rs, nin, v, 0.0, col_share, row_share))
        return 0;
    for (size_t y = 0; a && rs && y < per; y++)
        a->erow[(c[2] + y / s - a->o0) * ts + c[3] + y % s - a->o1] += lam * ((double)nin * v - rs[y]);
    return 1;
}
