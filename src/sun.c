/* sun.c - the sun's position as RADIANCE's gensky and gendaylit compute it, and its direction as
 * light reaching a vertical window (conventions in bsdfstack.h, "sun positions").
 *
 * The formulas are RADIANCE's (src/gen/sun.c, 1987), written out here from their mathematics:
 *   day of year jd = days before the month (no leap years) + day
 *   solar time  st = hour + 0.170 sin(4 pi (jd - 80) / 373) - 0.129 sin(2 pi (jd - 8) / 355)
 *                    + 12 (meridian - longitude) / pi          (angles in radians, west positive)
 *   declination  d = 0.4093 sin(2 pi (jd - 81) / 368)
 *   altitude     a = asin(sin(lat) sin(d) - cos(lat) cos(d) cos(pi st / 12))
 *   azimuth      z = -atan2(cos(d) sin(pi st / 12), -cos(lat) sin(d) - sin(lat) cos(d) cos(pi st / 12))
 * so that the numbers match what gensky prints (a few hundredths of a degree from an ephemeris).
 * RADIANCE's sky frame: +X east, +Y north, +Z up; the direction towards the sun is
 * (-sin z cos a, -cos z cos a, sin a) with z from south towards west.
 *
 * A vertical window facing azimuth A (its outward normal points to the sky at azimuth A, horizon)
 * has BSDF axes (bsdfstack.h): Z into the room = -(outward normal) = (sin A, cos A, 0), Y up
 * = (0, 0, 1), X = Y x Z = (-cos A, sin A, 0) (to the right seen from the room; west for a south
 * window).  The incident vector `in` (towards the sun) has coordinates (s.X, s.Y, s.Z); light
 * from the exterior has in_z < 0, and its propagation direction -in has theta = acos(-in_z),
 * phi = atan2(-in_y, -in_x). */
#include <config.h>

#include <math.h>

#include "bsdfstack.h"

#define DEG (M_PI / 180.0)

int bst_sun_day(int month, int day)
{
    static const short before[12] = {0, 31, 59, 90, 120, 151, 181, 212, 243, 273, 304, 334};
    if (month < 1 || month > 12)
        return 0;
    return before[month - 1] + day;
}

double bst_sun_solar_time(const bst_sun_site *site, int jd, double hour)
{
    return hour + 0.170 * sin(4.0 * M_PI / 373.0 * (jd - 80)) -
           0.129 * sin(2.0 * M_PI / 355.0 * (jd - 8)) +
           12.0 * (site->meridian - site->longitude) * DEG / M_PI;
}

double bst_sun_declination(int jd)
{
    return 0.4093 * sin(2.0 * M_PI / 368.0 * (jd - 81)) / DEG;
}

void bst_sun_position(const bst_sun_site *site, int jd, double st, double *altitude,
                      double *azimuth)
{
    double lat = site->latitude * DEG, d = bst_sun_declination(jd) * DEG, h = st * M_PI / 12.0;
    double a = asin(sin(lat) * sin(d) - cos(lat) * cos(d) * cos(h));
    double z = -atan2(cos(d) * sin(h), -cos(lat) * sin(d) - sin(lat) * cos(d) * cos(h));
    if (altitude)
        *altitude = a / DEG;
    if (azimuth)
        *azimuth = z / DEG;
}

int bst_sun_incident(double altitude, double azimuth, double window_azimuth, double *theta,
                     double *phi)
{
    double a = altitude * DEG, z = azimuth * DEG, w = window_azimuth * DEG;
    double s[3] = {-sin(z) * cos(a), -cos(z) * cos(a), sin(a)}; /* towards the sun, E N Up */
    double in_x = -cos(w) * s[0] + sin(w) * s[1];
    double in_y = s[2];
    double in_z = sin(w) * s[0] + cos(w) * s[1];
    double t = acos(fmax(-1.0, fmin(1.0, -in_z))) / DEG, p = atan2(-in_y, -in_x) / DEG;
    *theta = t;
    *phi = p < 0.0 ? p + 360.0 : p;
    return altitude > 0.0 && in_z < 0.0 && t < 90.0;
}

long bst_sun_path(const bst_sun_site *site, double window_azimuth, double step_min, size_t max,
                  double (*dirs)[2])
{
    if (!site || !(fabs(site->latitude) <= 90.0) || !(fabs(site->longitude) <= 360.0) ||
        !(fabs(site->meridian) <= 360.0) || !(step_min >= 1.0 && step_min <= 1440.0) ||
        !isfinite(window_azimuth))
        return BST_EINVAL;
    long n = 0;
    long steps = (long)floor(1440.0 / step_min + 1e-9);
    for (int jd = 1; jd <= 365; jd++)
        for (long q = 0; q < steps; q++) {
            double hour = (double)q * step_min / 60.0, alt, azi, t, p;
            if (hour >= 24.0)
                break;
            bst_sun_position(site, jd, bst_sun_solar_time(site, jd, hour), &alt, &azi);
            if (!bst_sun_incident(alt, azi, window_azimuth, &t, &p))
                continue;
            if (dirs && (size_t)n < max)
                dirs[n][0] = t, dirs[n][1] = p;
            n++;
        }
    return n;
}
