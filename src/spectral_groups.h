/* spectral_groups.h - the wavelengths of a spectral stack in groups (spectral.c's opening says why
 * and how well): a group extends while the panes' data it joins stay within a budget of the
 * grouping's error, and the budget is the largest whose groups' errors sum to at most tol^2. */
#ifndef BST_SPECTRAL_GROUPS_H
#define BST_SPECTRAL_GROUPS_H

#include <stddef.h>
#include "bsdfstack.h"

/* One group of one channel: the wavelengths [first, end) of its grid (first after the previous
 * group, for progress), the side of the visible range, the summed weight, the panes' mean data
 * (4 n). */
struct bsti_group {
    size_t ch, first, end;
    int inside;
    double wsum;
    const double *mean;
};

/* 1 when um lies inside the visible range of a dual-band layer ([BST_DUAL_BAND_LO, _HI]). */
static inline int bsti_inside_visible(double um)
{
    return um >= BST_DUAL_BAND_LO && um <= BST_DUAL_BAND_HI;
}

/* A channel's groups for a per-group budget: how many, and in *total the sum of their shares of
 * the error (see group in spectral_groups.c).  nq = 4 n data a wavelength (d[k * nq + q]: every
 * pane's normal-incidence Tf, Tb, Rf, Rb), wl and w the channel's grid and weights (nwl); split:
 * the stack has a dual-band layer (a group stays on one side of the visible range's limits);
 * budget < 0: one wavelength a group.  With jobs, each group is written there (ch, first, end,
 * side, weight) with its mean data at means + (its index) nq.  ws: 3 nq values of work space. */
size_t bsti_spectral_groups(size_t nq, const double *d, int split, const double *wl,
                            const double *w, size_t nwl, double budget, size_t ch,
                            struct bsti_group *jobs, double *means, double *ws, double *total);

/* The per-group budget for tolerance tol (> 0): the largest (by bisection) for which the channel's
 * groups' shares sum to at most tol^2; 0 when none is (only equal data grouped).  ws as above. */
double bsti_spectral_group_budget(size_t nq, const double *d, int split, const double *wl,
                                  const double *w, size_t nwl, double tol, double *ws);

#endif
