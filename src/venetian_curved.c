/* venetian_curved.c - light among curved slats, in the blind's profile plane (venetian.h for the
 * frame; bsdfstack.h, bst_venetian, for the model).
 *
 * A curved slat is the circular arc of radius R whose chord is the flat slat of the same tilt
 * (exterior edge (0, -w cos b), interior edge (w sin b, 0)), bowed towards face A's normal nA: the
 * crown looks +Y at tilt 0 (convex upward, as real blinds and WINDOW's positive slat curvature:
 * Windows-CalcEngine's CVenetianSlat puts a positive radius's arc on the top of its circle and
 * turns it with the tilt).  Its centre lies sqrt(R^2 - w^2/4) behind the chord's midpoint along
 * -nA, and the point at arc angle phi (-h..h, h = asin(w / 2R), from the exterior edge's side) is
 * C + R (cos phi nA + sin phi u), u = (sin b, cos b) the chord's direction.  Face A is the convex
 * face (r_up), face B the concave one (r_down); strip m of a face spans arc angles of equal length
 * (equal arc lengths), from the exterior edge.
 *
 * The slats no longer bound one channel of parallel walls (an arc may bulge past its edges' z and,
 * near +-90 deg, cross its neighbour), so light is followed in the whole periodic array: from a
 * point of the slab zmin <= z <= zmax that holds the slats, to the first arc of slat j (slat 0
 * moved by j s along y) that it meets, until it leaves the slab.  The unobstructed share is exact
 * (a direction passes unless it meets the shadow of one arc: 1 - its extent across the direction
 * over the spacing); only the shadow is sampled.  The strips' exchange and views are traced from
 * the arcs themselves (no chord approximation: a concave face sees itself, the neighbour and the
 * slat's own bulge obstruct as they do). */
#include <config.h>

#include <limits.h>
#include <math.h>
#include <string.h>

#include "venetian.h"

/* The least and greatest of A cos phi + B sin phi over -h <= phi <= h (h <= pi/2). */
static void arc_extent(double A, double B, double h, double *lo, double *hi)
{
    double e0 = A * cos(h) - B * sin(h), e1 = A * cos(h) + B * sin(h), psi = atan2(B, A);
    *lo = fmin(e0, e1), *hi = fmax(e0, e1);
    if (fabs(psi) <= h) /* the maximum R hypot(A, B) at phi = psi */
        *hi = hypot(A, B);
    double pm = psi > 0 ? psi - M_PI : psi + M_PI;
    if (fabs(pm) <= h)
        *lo = -hypot(A, B);
}

void bsti_vn_curved_init(bsti_vn_geom *g, double radius)
{
    double hw = g->w / 2, lo, hi;
    g->curved = 1;
    g->sheet = 0; /* an arc is never a plane */
    g->R = radius;
    g->half = asin(fmin(1.0, hw / radius));
    g->cth = cos(g->half);
    g->len = 2 * radius * g->half;
    double back = sqrt(fmax(radius * radius - hw * hw, 0.0)); /* centre to chord */
    g->c[0] = hw * g->sb - back * g->nA[0];
    g->c[1] = g->ze + hw * g->cb - back * g->nA[1];
    arc_extent(g->nA[0], g->sb, g->half, &lo, &hi); /* y = c_y + R (cos phi nA_y + sin phi u_y) */
    g->ylo = g->c[0] + radius * lo, g->yhi = g->c[0] + radius * hi;
    arc_extent(g->nA[1], g->cb, g->half, &lo, &hi);
    g->zlo = g->c[1] + radius * lo, g->zhi = g->c[1] + radius * hi;
}

/* The shadow of slat 0 cast along (a, b) on the plane z = z0: its least y and its length. */
static double shadow(const bsti_vn_geom *g, double a, double b, double z0, double *start)
{
    double t = a / b, lo, hi;
    arc_extent(g->nA[0] - t * g->nA[1], g->sb - t * g->cb, g->half, &lo, &hi);
    *start = g->c[0] - t * (g->c[1] - z0) + g->R * lo;
    return g->R * (hi - lo);
}

double bsti_vn_curved_open(const bsti_vn_geom *g, double a, double b)
{
    double y0;
    return fmax(0.0, 1.0 - shadow(g, a, b, 0.0, &y0) / g->s);
}

/* The first point where the ray from p along d (unit) meets an arc, searched among the slats
 * whose y extent it crosses before its distance *best (in: where it leaves the slab; INFINITY
 * for d along y): *best, the slat and whether the ray met the arc from inside its circle (the
 * concave face).  The slat it starts on (jlast, from the face flast) is met again only from
 * inside (a concave face may see itself), never at the start.  Returns 0 when it meets none. */
static int first_arc(const bsti_vn_geom *g, const double p[2], const double d[2], long jlast,
                     int flast, double *best, long *jhit, int *inside)
{
    const double s = g->s, tol = 1e-12 * s;
    const long cap = 1000000; /* slats passed along a ray grazing y: it leaves as it heads */
    long dir = d[0] >= 0 ? 1 : -1;
    long j = dir > 0 ? (long)floor((p[0] - g->yhi) / s) - 1 : (long)ceil((p[0] - g->ylo) / s) + 1;
    int found = 0;
    for (long k = 0; k < cap; k++, j += dir) {
        double reach = p[0] + d[0] * *best; /* y where the ray is now known to stop */
        if (dir > 0 ? j * s + g->ylo > fmax(reach, p[0]) + tol
                    : j * s + g->yhi < fmin(reach, p[0]) - tol)
            break;
        if (j == jlast && flast == 0)
            continue; /* off a convex face: away from its own circle */
        double q0 = p[0] - (g->c[0] + (double)j * s), q1 = p[1] - g->c[1];
        double qd = q0 * d[0] + q1 * d[1], c = q0 * q0 + q1 * q1 - g->R * g->R;
        double disc = qd * qd - c;
        if (disc < 0)
            continue;
        double sq = sqrt(disc), r1, r2;
        if (-qd > 0)
            r2 = -qd + sq, r1 = r2 != 0 ? c / r2 : 0;
        else
            r1 = -qd - sq, r2 = r1 != 0 ? c / r1 : 0;
        for (int root = j == jlast ? 1 : 0; root < 2; root++) {
            double lam = root ? r2 : r1;
            if (!(lam > 0) || lam >= *best)
                continue;
            double x0 = q0 + lam * d[0], x1 = q1 + lam * d[1];
            if ((x0 * g->nA[0] + x1 * g->nA[1]) / g->R < g->cth)
                continue; /* on the circle, not on the arc */
            *best = lam, *jhit = j, *inside = x0 * d[0] + x1 * d[1] > 0, found = 1;
            break;
        }
    }
    return found;
}

long bsti_vn_curved_trace(const bsti_vn_geom *g, const double start[2], const double dir[2],
                          long jlast, int flast, double wgt, double *dep, double sigma,
                          unsigned long seed, double out[5])
{
    const double min = wgt * BSTI_VN_MIN_FLUX;
    double p[2] = {start[0], start[1]}, d[2] = {dir[0], dir[1]}, nl[2] = {0.0, 0.0};
    long n = 0;
    for (;;) {
        double best = d[1] > 0 ? fmax((g->zhi - p[1]) / d[1], 0.0)
                    : d[1] < 0 ? fmax((g->zlo - p[1]) / d[1], 0.0) : INFINITY;
        long j = 0;
        int inside = 0;
        if (n >= BSTI_VN_MAX_BOUNCES || wgt <= min
            || !first_arc(g, p, d, jlast, flast, &best, &j, &inside)) {
            out[0] = wgt <= min ? 0.0 : wgt;
            out[1] = d[0], out[2] = d[1], out[3] = nl[0], out[4] = nl[1];
            return n;
        }
        p[0] += d[0] * best, p[1] += d[1] * best;
        /* the radial unit vector there, its arc angle and strip; the normal towards the ray */
        double r0 = (p[0] - (g->c[0] + (double)j * g->s)) / g->R, r1 = (p[1] - g->c[1]) / g->R;
        double phi = asin(fmax(-1.0, fmin(1.0, r0 * g->sb + r1 * g->cb)));
        long m = (long)floor((phi + g->half) / (2 * g->half) * g->m);
        m = m < 0 ? 0 : m >= g->m ? g->m - 1 : m;
        dep[inside * g->m + m] += wgt;
        wgt *= g->rs;
        double na = inside ? -r0 : r0, nb = inside ? -r1 : r1, dh = d[0] * na + d[1] * nb;
        if (sigma > 0) { /* a facet tilted along the arc; not one that sends the ray in */
            double sl = sigma * bsti_vn_facet_slope(seed, n), len = sqrt(1 + sl * sl);
            double ta = (na + sl * nb) / len, tb = (nb - sl * na) / len, dt = d[0] * ta + d[1] * tb;
            if ((d[0] - 2 * dt * ta) * na + (d[1] - 2 * dt * tb) * nb > 0)
                na = ta, nb = tb, dh = dt;
        }
        d[0] -= 2 * dh * na, d[1] -= 2 * dh * nb;
        nl[0] = na, nl[1] = nb;
        jlast = j, flast = inside;
        n++;
    }
}

int bsti_vn_curved_entries(const bsti_vn_geom *g, double a, double b, double *y0, double *z0,
                           double *span)
{
    *z0 = b > 0 ? g->zlo : g->zhi;
    double len = shadow(g, a, b, *z0, y0);
    *span = fmin(len, g->s);
    return *span > 0;
}

void bsti_vn_curved_view(const bsti_vn_geom *g, double a, double b, double *view)
{
    const int np = BSTI_VN_POSITIONS;
    const double d[2] = {-a, -b};
    double out[5];
    memset(view, 0, 2 * (size_t)g->m * sizeof *view);
    for (int k = 0; k < np; k++) { /* back from the plane the light leaves by, over a period */
        double p[2] = {g->s * (k + 0.5) / np, b > 0 ? g->zhi : g->zlo};
        bsti_vn_curved_trace(g, p, d, LONG_MIN, 0, 1.0 / np, view, 0.0, 0, out);
    }
}

void bsti_vn_curved_exchange(const bsti_vn_geom *g, double *gm)
{
    const size_t n = 2 * (size_t)g->m;
    const int na = BSTI_VN_CURVED_ANGLES;
    const int np = g->m * BSTI_VN_EXCHANGE_POSITIONS >= BSTI_VN_CURVED_FACE_POSITIONS
                 ? BSTI_VN_EXCHANGE_POSITIONS : (BSTI_VN_CURVED_FACE_POSITIONS + g->m - 1) / g->m;
    double col[2 * 1000], out[5], wa[BSTI_VN_CURVED_ANGLES], sum = 0;
    /* Lambertian emission in the profile plane, cos(alpha) / 2 d alpha: midpoints uniform in
     * alpha, weighed by cos alpha and normalised (a concave strip sees itself only at grazing
     * angles, which points uniform in sin alpha would leave out) */
    for (int q = 0; q < na; q++)
        sum += wa[q] = cos(M_PI * (-0.5 + (q + 0.5) / na));
    memset(gm, 0, n * n * sizeof *gm);
    for (size_t j = 0; j < n; j++) {
        int face = j >= (size_t)g->m;
        double m = (double)(j % (size_t)g->m);
        memset(col, 0, n * sizeof *col);
        for (int p = 0; p < np; p++) {
            double phi = -g->half + 2 * g->half * (m + (p + 0.5) / np) / g->m;
            double r0 = cos(phi) * g->nA[0] + sin(phi) * g->sb;
            double r1 = cos(phi) * g->nA[1] + sin(phi) * g->cb;
            double x[2] = {g->c[0] + g->R * r0, g->c[1] + g->R * r1};
            double nx = face ? -r0 : r0, ny = face ? -r1 : r1; /* the emitting face's normal */
            for (int q = 0; q < na; q++) {
                double al = M_PI * (-0.5 + (q + 0.5) / na), ca = cos(al), sa = sin(al);
                double d[2] = {ca * nx + sa * ny, ca * ny - sa * nx};
                bsti_vn_curved_trace(g, x, d, 0, face, wa[q] / (sum * np), col, 0.0, 0, out);
            }
        }
        for (size_t e = 0; e < n; e++)
            gm[e * n + j] = col[e];
    }
}
