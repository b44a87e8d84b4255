/* venetian_trace.c - light in one channel of a venetian blind, in its profile plane (venetian.h
 * for the frame, the faces and the elements).  Flat slats here; curved ones in venetian_curved.c
 * (bsti_vn_open, _view and _exchange turn to it).
 *
 * Flat slats are parallel mirrors: a ray's X component never changes and each specular bounce
 * flips its profile direction between d and its mirror image dm, so a ray entering along d leaves
 * along d after an even number of bounces (out of the opposite side: it cannot cross the opening it
 * came in by) and along dm after an odd number.  The unobstructed share of the opening is exact
 * (the overlap of the entrance opening's shadow with the exit opening); only the part of the
 * opening that meets a slat is sampled, by BSTI_VN_POSITIONS midpoints, each carrying its exact
 * share, so the shares of every entering ray add up to 1 whatever the sampling.  Rough slats
 * break the parity rule (a facet's slope may add or save a bounce): their rays are followed with
 * their own facets from the same positions, BSTI_VN_ROUGH_RAYS each. */
#include <config.h>

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "venetian.h"

void bsti_vn_geom_init(bsti_vn_geom *g, const bst_venetian *v)
{
    double b = v->tilt * (M_PI / 180.0);
    memset(g, 0, sizeof *g);
    g->w = v->width;
    g->s = v->spacing;
    g->sb = sin(b);
    g->cb = cos(b);
    g->sheet = fabs(fabs(v->tilt) - 90.0) < 1e-9;
    if (g->sheet) /* exactly in the plane z = 0 */
        g->sb = v->tilt > 0 ? 1.0 : -1.0, g->cb = 0.0;
    g->ze = -g->w * g->cb;
    g->nA[0] = g->cb;
    g->nA[1] = -g->sb;
    g->rs = v->rs;
    g->m = v->segments;
    g->len = g->w;
    if (v->curvature > 0)
        bsti_vn_curved_init(g, v->curvature);
}

/* A uniform number in (0, 1) from a 64-bit key (splitmix64's finaliser): reproducible, and the
 * numbers of different keys independent for our purpose. */
static double hash_uniform(uint64_t x)
{
    x += 0x9e3779b97f4a7c15u;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9u;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebu;
    x ^= x >> 31;
    return ((double)(x >> 11) + 0.5) / 9007199254740992.0;
}

/* The slope of a rough facet (in the profile plane, standard Gaussian) met at bounce j by ray
 * `seed`: Box-Muller on two hashed numbers, the same for the same ray and bounce on every run. */
double bsti_vn_facet_slope(unsigned long seed, long j)
{
    uint64_t key = ((uint64_t)seed << 24) ^ (uint64_t)j;
    double u1 = hash_uniform(2 * key), u2 = hash_uniform(2 * key + 1);
    return sqrt(-2.0 * log(u1)) * cos(2 * M_PI * u2);
}

/* Follow a profile ray from (y, z) along (a, b) with flux wgt until it leaves the channel: every
 * arrival on an element adds the flux then carried to dep[element].  sigma > 0: each bounce's
 * facet is tilted in the profile plane by slope sigma facet_slope(seed, bounce) (a tilt that
 * would send the ray into the slat is not taken; the first bounce's slope is sigma first).
 * Returns the number of bounces; *left is the flux that leaves, *ea, *eb its direction. */
static long trace2(const bsti_vn_geom *g, double y, double z, double a, double b, double wgt,
                   double *dep, double *left, double sigma, unsigned long seed, double first,
                   double *ea, double *eb)
{
    const double H = g->s * g->cb, min = wgt * BSTI_VN_MIN_FLUX; /* face B's distance from A */
    long n = 0;
    for (;;) {
        double h = y * g->nA[0] + (z - g->ze) * g->nA[1], dh = a * g->nA[0] + b * g->nA[1];
        double lw = INFINITY, lo = INFINITY;
        int face = -1;
        if (dh < 0)
            lw = fmax(-h / dh, 0.0), face = 0;
        else if (dh > 0)
            lw = fmax((H - h) / dh, 0.0), face = 1;
        if (b > 0)
            lo = fmax(-z / b, 0.0);
        else if (b < 0)
            lo = fmax((g->ze - z) / b, 0.0);
        if (lo <= lw || face < 0 || n >= BSTI_VN_MAX_BOUNCES || wgt <= min) {
            *left = wgt <= min ? 0.0 : wgt;
            *ea = a, *eb = b;
            return n;
        }
        y += a * lw;
        z += b * lw;
        /* position along the struck slat from its exterior edge */
        double t = (y - (face ? g->s : 0.0)) * g->sb + (z - g->ze) * g->cb;
        long m = (long)floor(t / g->w * g->m);
        m = m < 0 ? 0 : m >= g->m ? g->m - 1 : m;
        dep[face * g->m + m] += wgt;
        wgt *= g->rs;
        double na = g->nA[0], nb = g->nA[1];
        if (sigma > 0) {
            double sl = sigma * (n ? bsti_vn_facet_slope(seed, n) : first), len = sqrt(1 + sl * sl);
            double ta = (na + sl * g->sb) / len, tb = (nb + sl * g->cb) / len, dt = a * ta + b * tb;
            double ra = a - 2 * dt * ta, rb = b - 2 * dt * tb;
            if ((ra * na + rb * nb > 0) == (face == 0)) /* away from the struck face */
                na = ta, nb = tb, dh = dt;
        }
        a -= 2 * dh * na;
        b -= 2 * dh * nb;
        n++;
    }
}

/* The face of a sheet (|tilt| = 90) that light travelling along b meets: face A looks to the
 * exterior at tilt +90 (nA = (0, -1)), to the interior at -90. */
static int sheet_face(const bsti_vn_geom *g, double b)
{
    return (b > 0) == (g->nA[1] < 0) ? 0 : 1;
}

/* The entrance opening [y0, y0 + s] of light along (a, b) and how far its shadow on the exit
 * plane is shifted past the exit opening (the channel's openings: y in [0, s] at z = ze and
 * y in [w sin b, w sin b + s] at z = 0). */
static double shadow_shift(const bsti_vn_geom *g, double a, double b, double *y0, double *z0)
{
    *y0 = b > 0 ? 0.0 : g->w * g->sb;
    *z0 = b > 0 ? g->ze : 0.0;
    double y1 = b > 0 ? g->w * g->sb : 0.0, dy = a / b * (b > 0 ? -g->ze : g->ze);
    return *y0 + dy - y1;
}

double bsti_vn_open(const bsti_vn_geom *g, double a, double b)
{
    if (g->curved)
        return bsti_vn_curved_open(g, a, b);
    if (g->sheet)
        return 1.0 - fmin(1.0, g->w / g->s);
    double y0, z0, delta = shadow_shift(g, a, b, &y0, &z0);
    return fmax(0.0, g->s - fabs(delta)) / g->s;
}

/* The standard normal quantile of p in (0, 1): Abramowitz and Stegun's 26.2.23 (error below
 * 4.5e-4), then two Newton steps on erfc. */
static double normal_quantile(double p)
{
    double q = p < 0.5 ? p : 1 - p, t = sqrt(-2 * log(q));
    double x = t - (2.515517 + t * (0.802853 + t * 0.010328)) /
                       (1 + t * (1.432788 + t * (0.189269 + t * 0.001308)));
    if (p < 0.5)
        x = -x;
    for (int i = 0; i < 2; i++)
        x -= (0.5 * erfc(-x / M_SQRT2) - p) / (exp(-0.5 * x * x) / sqrt(2 * M_PI));
    return x;
}

/* The first bounce's facet slope (standard Gaussian) of rough ray r at entry position k of
 * bsti_vn_hit: stratified, a Latin square of the positions and the BSTI_VN_ROUGH_RAYS bands of
 * the distribution (ray r takes band r, the positions spread over it in a scrambled order), so
 * that the few rays of a position and the positions together cover the distribution evenly (its
 * first bounce decides most of a rough ray's fate). */
static double first_slope(int k, unsigned long r)
{
    const int np = BSTI_VN_POSITIONS;
    unsigned long stratum = r * (unsigned long)np + ((unsigned long)k * 167u) % (unsigned long)np;
    return normal_quantile((stratum + 0.5) / ((double)np * BSTI_VN_ROUGH_RAYS));
}

void bsti_vn_hit(const bsti_vn_geom *g, double a, double b, double sigma, double *row)
{
    double dh = a * g->nA[0] + b * g->nA[1], psi = atan2(a, b);
    double psi_m = atan2(a - 2 * dh * g->nA[0], b - 2 * dh * g->nA[1]);
    const int np = BSTI_VN_POSITIONS;
    memset(row, 0, (BSTI_VN_DEP + 2 * (size_t)g->m) * sizeof *row);
    if (g->sheet) { /* one mirror bounce */
        row[BSTI_VN_ODD] = row[BSTI_VN_ODD_N] = g->rs;
        for (int m = 0; m < g->m; m++)
            row[BSTI_VN_DEP + sheet_face(g, b) * g->m + m] = 1.0 / g->m;
        return;
    }
    double y0, z0, delta = shadow_shift(g, a, b, &y0, &z0), lo, hi, s = g->s;
    if (delta > 0) /* the shadow overshoots: the upper part of the opening meets slat 1 */
        lo = y0 + fmax(0.0, s - delta), hi = y0 + s;
    else
        lo = y0, hi = y0 + fmin(s, -delta);
    for (int k = 0; k < np; k++) {
        double y = lo + (hi - lo) * (k + 0.5) / np, left, ea, eb;
        if (sigma <= 0) {
            long n = trace2(g, y, z0, a, b, 1.0 / np, row + BSTI_VN_DEP, &left, 0.0, 0, 0.0, &ea,
                            &eb);
            row[n % 2 ? BSTI_VN_ODD : BSTI_VN_EVEN] += left;
            row[n % 2 ? BSTI_VN_ODD_N : BSTI_VN_EVEN_N] += left * (double)n;
        }
        for (unsigned long r = 0; sigma > 0 && r < BSTI_VN_ROUGH_RAYS; r++) {
            /* the same entry with rough facets: where it lands, which way it leaves (the parity
             * of its bounces: a rough ray may bounce once more or less than a flat one, e.g.
             * walk between slats it meets almost normally) and how far its exit turns from d
             * or dm in the plane */
            long n = trace2(g, y, z0, a, b, 1.0 / np / BSTI_VN_ROUGH_RAYS, row + BSTI_VN_DEP,
                            &left, sigma, (unsigned long)k * BSTI_VN_ROUGH_RAYS + r,
                            first_slope(k, r), &ea, &eb);
            row[n % 2 ? BSTI_VN_ODD : BSTI_VN_EVEN] += left;
            row[n % 2 ? BSTI_VN_ODD_N : BSTI_VN_EVEN_N] += left * (double)n;
            double dev = remainder(atan2(ea, eb) - (n % 2 ? psi_m : psi), 2 * M_PI);
            double *mom = row + (n % 2 ? BSTI_VN_ODD_W : BSTI_VN_EVEN_W);
            mom[0] += left, mom[1] += left * dev, mom[2] += left * dev * dev;
        }
    }
}

void bsti_vn_view(const bsti_vn_geom *g, double a, double b, double *view)
{
    const int np = BSTI_VN_POSITIONS;
    if (g->curved) {
        bsti_vn_curved_view(g, a, b, view);
        return;
    }
    memset(view, 0, 2 * (size_t)g->m * sizeof *view);
    if (g->sheet) { /* the face towards the exit side, strips of w / m in an opening of s */
        for (int m = 0; m < g->m; m++)
            view[sheet_face(g, -b) * g->m + m] = g->w / (g->m * g->s);
        return;
    }
    /* traced back into the channel from the opening on the exit side */
    double y0 = b > 0 ? g->w * g->sb : 0.0, z0 = b > 0 ? 0.0 : g->ze, left, ea, eb;
    for (int k = 0; k < np; k++)
        trace2(g, y0 + g->s * (k + 0.5) / np, z0, -a, -b, 1.0 / np, view, &left, 0.0, 0, 0.0, &ea,
               &eb);
}

/* Flat slats' exchange, exactly: between two parallel mirrors a path of k arrivals is a straight
 * line in the unfolded channel, whose images of the slats are parallel lines H apart, the i-th
 * the source's slat (i even) or the other one (i odd), each keeping its extent along the slats
 * (reflection across a line parallel to them keeps that coordinate).  Light from a Lambertian
 * strip of a long slat reaches line k over D = k H with flux D^2 / (2 r^3) per unit lengths of
 * both (r^2 = D^2 + v^2, v the path's run along the slats), and arrives on strip e of line k
 * where it crossed lines 1 .. k - 1 within their slats (else it left by an opening: the channel
 * between two slats is convex).  With u0 the start and v the run, line i is crossed at
 * u0 + v i / k: each line bounds u0 by an interval moving linearly with v, so the admissible
 * length of u0 is piecewise linear in v, with its corners among the crossings of the bounds, and
 * each piece integrates in closed form against D^2 / (2 r^3): antiderivatives v / (2 r) and
 * -D^2 / (2 r).  Of the lines between, only the first two and last two bind (each class has one
 * interval, moving by i / k).  The sampled exchange it replaces (64 positions x 64 angles a
 * strip, midpoints) missed half of what escapes from strips deep in a nearly closed channel,
 * which lossless slats turned into energy gained (1.2 % of T + R at tilt 80, width 30 mm). */
struct bound {
    double lo, hi, slope; /* u0 in [lo - slope v, hi - slope v] */
};

/* Integral over v of the admissible u0 length times D^2 / (2 r^3). */
static double unfolded_flux(const struct bound *b, int nb, double D)
{
    double cand[2 * 6 * 6 + 2];
    int nc = 0;
    for (int i = 0; i < 2 * nb; i++) /* every crossing of two bounds (lower or upper) */
        for (int j = i + 1; j < 2 * nb; j++) {
            double ci = i < nb ? b[i].lo : b[i - nb].hi, si = b[i % nb].slope;
            double cj = j < nb ? b[j].lo : b[j - nb].hi, sj = b[j % nb].slope;
            if (si != sj)
                cand[nc++] = (ci - cj) / (si - sj);
        }
    for (int i = 1; i < nc; i++) /* insertion sort: a few dozen values */
        for (int j = i; j > 0 && cand[j] < cand[j - 1]; j--) {
            double t = cand[j];
            cand[j] = cand[j - 1], cand[j - 1] = t;
        }
    double sum = 0.0, D2 = D * D;
    for (int c = 0; c + 1 < nc; c++) {
        double v[2] = {cand[c], cand[c + 1]}, len[2];
        if (!(v[1] > v[0]))
            continue;
        for (int e = 0; e < 2; e++) {
            double lo = -INFINITY, hi = INFINITY;
            for (int i = 0; i < nb; i++) {
                lo = fmax(lo, b[i].lo - b[i].slope * v[e]);
                hi = fmin(hi, b[i].hi - b[i].slope * v[e]);
            }
            len[e] = hi - lo;
        }
        if (len[0] <= 0 && len[1] <= 0)
            continue;
        if (len[0] < 0 || len[1] < 0) { /* a corner met to rounding: the piece ends at the zero */
            int neg = len[1] < 0;
            v[neg] = v[0] + (v[1] - v[0]) * len[0] / (len[0] - len[1]);
            len[neg] = 0.0;
            if (!(v[1] > v[0]))
                continue;
        }
        double beta = (len[1] - len[0]) / (v[1] - v[0]), alpha = len[0] - beta * v[0];
        double r0 = sqrt(D2 + v[0] * v[0]), r1 = sqrt(D2 + v[1] * v[1]);
        sum += alpha * 0.5 * (v[1] / r1 - v[0] / r0) - beta * 0.5 * D2 * (1.0 / r1 - 1.0 / r0);
    }
    return sum;
}

static void exchange_flat(const bsti_vn_geom *g, double *gm)
{
    const size_t n = 2 * (size_t)g->m;
    const double H = g->s * g->cb, shift = g->s * g->sb, L = g->w / g->m;
    const double ext_lo[2] = {0.0, shift}; /* each slat's extent along the slats */
    for (size_t j = 0; j < n; j++) {
        int fj = j >= (size_t)g->m;
        double u0 = ext_lo[fj] + L * (double)(j % (size_t)g->m), weight = 1.0;
        for (long k = 1; k <= BSTI_VN_MAX_BOUNCES && weight > BSTI_VN_MIN_FLUX; k++) {
            int fe = (fj + (int)(k % 2)) % 2;
            struct bound b[6];
            int nb = 0;
            b[nb++] = (struct bound){u0, u0 + L, 0.0};
            for (long i = 1; i < k; i++) { /* the lines between: the first and last two bind */
                if (i > 2 && i < k - 2)
                    continue;
                double lo = ext_lo[(fj + (int)(i % 2)) % 2], t = (double)i / (double)k;
                b[nb++] = (struct bound){lo, lo + g->w, t};
            }
            double total = 0.0;
            for (int m = 0; m < g->m; m++) {
                double lo = ext_lo[fe] + L * m;
                b[nb] = (struct bound){lo, lo + L, 1.0};
                double f = weight * unfolded_flux(b, nb + 1, (double)k * H) / L;
                gm[((size_t)fe * g->m + m) * n + j] += f;
                total += f;
            }
            if (total <= 0.0) /* nothing reaches line k: nor any further */
                break;
            weight *= g->rs;
        }
    }
}

void bsti_vn_exchange(const bsti_vn_geom *g, double *gm)
{
    const size_t n = 2 * (size_t)g->m;
    if (g->curved) {
        bsti_vn_curved_exchange(g, gm);
        return;
    }
    memset(gm, 0, n * n * sizeof *gm);
    if (g->sheet) /* a plane sees none of itself */
        return;
    exchange_flat(g, gm);
}
