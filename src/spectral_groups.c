/* spectral_groups.c - the wavelengths of a spectral stack in groups, one combination each
 * (spectral_groups.h says how they are formed and why). */
#include <config.h>

#include <math.h>

#include "spectral_groups.h"

/* The group that starts at wavelength k0 (w[k0] > 0) of a channel's grid wl (nwl wavelengths,
 * weights w, the panes' normal-incidence data d[k * nq + q], nq = 4 n): its end (one past its last
 * wavelength), in mean[nq] the data averaged with the weights, in *wsum their sum and in *var the
 * largest over q of sum_k w_k (d_kq - mean_q)^2 (the group's share of the grouping's error, see
 * bsti_spectral_groups).  The group extends while that stays within budget and, when the stack has a
 * dual-band layer (split), the wavelength is on wl[k0]'s side of the visible range's limits;
 * wavelengths of zero weight neither join nor end it; budget < 0: one wavelength.  Budget 0
 * joins only equal data (the weighted update below then changes nothing).  m2 and try are nq
 * values of work space. */
static size_t group(size_t nq, const double *d, int split, const double *wl, const double *w,
                    size_t nwl, size_t k0, double budget, double *mean, double *m2, double *try,
                    double *wsum, double *var)
{
    for (size_t q = 0; q < nq; q++)
        mean[q] = d[k0 * nq + q], m2[q] = 0.0;
    *wsum = w[k0];
    *var = 0.0;
    size_t k = k0 + 1;
    for (; budget >= 0 && k < nwl; k++) {
        if (w[k] == 0.0)
            continue;
        if (split && bsti_inside_visible(wl[k]) != bsti_inside_visible(wl[k0]))
            break;
        /* the weighted mean and sum of squared deviations with wavelength k (West's update) */
        double ws = *wsum + w[k], v = 0.0;
        for (size_t q = 0; q < nq; q++) {
            double delta = d[k * nq + q] - mean[q];
            try[q] = m2[q] + w[k] * delta * (d[k * nq + q] - (mean[q] + w[k] / ws * delta));
            v = fmax(v, try[q]);
        }
        if (v > budget)
            break;
        for (size_t q = 0; q < nq; q++) {
            mean[q] += w[k] / ws * (d[k * nq + q] - mean[q]);
            m2[q] = try[q];
        }
        *wsum = ws;
        *var = v;
    }
    return k;
}

/* A channel's groups for a per-group budget: how many, and in *total the sum of their shares
 * (group's *var).  With jobs, each is written there (ch, first, end, side, weight) with its mean
 * data at means + (job index) nq.  ws: 3 nq values of work space. */
size_t bsti_spectral_groups(size_t nq, const double *d, int split, const double *wl,
                             const double *w, size_t nwl, double budget, size_t ch,
                             struct bsti_group *jobs, double *means, double *ws, double *total)
{
    size_t count = 0;
    *total = 0.0;
    for (size_t k = 0, prev = 0; k < nwl; k++) {
        if (w[k] == 0.0)
            continue;
        double wsum, var, *mean = jobs ? means + count * nq : ws + 2 * nq;
        size_t end = group(nq, d, split, wl, w, nwl, k, budget, mean, ws, ws + nq, &wsum, &var);
        if (jobs)
            jobs[count] = (struct bsti_group){.ch = ch, .first = prev, .end = end,
                                       .inside = bsti_inside_visible(wl[k]), .wsum = wsum, .mean = mean};
        *total += var;
        count++;
        prev = end;
        k = end - 1;
    }
    return count;
}

/* The budget's search (group_budget): bracketed upwards from tol^2 GROUP_BUDGET_LOW by factors of
 * 4, then GROUP_BUDGET_STEPS geometric bisections (a factor 4 to within 1 + 1e-12). */
#define GROUP_BUDGET_LOW 1e-16
#define GROUP_BUDGET_STEPS 40

/* The per-group budget for tolerance tol (> 0): the largest (found by bisection, see above) for
 * which the channel's groups' shares sum to at most tol^2; 0 when none is (only equal data
 * grouped).  The greedy groups' sum need not grow monotonically with the budget: the bisection
 * keeps a budget whose sum was seen within tol^2, which is what the groups are then made with. */
double bsti_spectral_group_budget(size_t nq, const double *d, int split, const double *wl,
                           const double *w, size_t nwl, double tol, double *ws)
{
    double total, lo = 0.0, hi = tol * tol;
    bsti_spectral_groups(nq, d, split, wl, w, nwl, hi, 0, NULL, NULL, ws, &total);
    if (total <= tol * tol)
        return hi;
    for (double b = hi * GROUP_BUDGET_LOW; b < hi; b *= 4.0) { /* lo feasible, hi not */
        bsti_spectral_groups(nq, d, split, wl, w, nwl, b, 0, NULL, NULL, ws, &total);
        if (total > tol * tol) {
            hi = b;
            break;
        }
        lo = b;
    }
    for (int it = 0; it < GROUP_BUDGET_STEPS && lo > 0.0; it++) {
        double b = sqrt(lo * hi);
        bsti_spectral_groups(nq, d, split, wl, w, nwl, b, 0, NULL, NULL, ws, &total);
        if (total <= tol * tol)
            lo = b;
        else
            hi = b;
    }
    return lo;
}
