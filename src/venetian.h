/* venetian.h - internal side of the venetian blind model (bsdfstack.h: bst_venetian).
 *
 * The blind's profile plane is (y, z) of the model's frame (a vertical blind's x and y are
 * exchanged on the way in and out).  One channel between two neighbouring slats stands for all:
 * slat 0 runs from its exterior edge (0, -w cos b) to its interior edge (w sin b, 0), slat 1 is
 * slat 0 moved by the spacing s along y.  Face A is slat 0's face towards slat 1 (the face
 * looking +y at tilt 0: r_up), face B slat 1's face towards slat 0 (r_down); by periodicity a
 * face's other side is the other face at the same place.  Element e = face * segments + m is strip
 * m (from the exterior edge) of a face, of length w / segments.  Every light flux below is per
 * unit flux entering one period of the blind. */
#ifndef BST_VENETIAN_H
#define BST_VENETIAN_H

#include "bsdfstack.h"

/* A ray that has bounced this often between lossless mirrors leaves the channel the way it is
 * heading (only rays almost normal to the slats get here); a ray whose flux has fallen below
 * BSTI_VN_MIN_FLUX of what it entered with is dropped (rs < 1 only). */
#define BSTI_VN_MAX_BOUNCES 100000
#define BSTI_VN_MIN_FLUX 1e-15
/* Entry positions per profile direction over the part of the opening that meets a slat, and per
 * view of the strips from an opening; positions and in-plane angles per strip in their exchange. */
#define BSTI_VN_POSITIONS 256
#define BSTI_VN_EXCHANGE_POSITIONS 64
/* The row of a hit: flux leaving along d (even bounces), the sum of bounces times that flux, the
 * same along the mirror image dm (odd bounces), then the arrivals on the 2 m strips. */
enum { BSTI_VN_EVEN, BSTI_VN_EVEN_N, BSTI_VN_ODD, BSTI_VN_ODD_N, BSTI_VN_EVEN_W, BSTI_VN_EVEN_D,
       BSTI_VN_EVEN_D2, BSTI_VN_ODD_W, BSTI_VN_ODD_D, BSTI_VN_ODD_D2, BSTI_VN_DEP };
/* Rough slats: rays traced per entry position with their own facet slopes (the first bounce's
 * stratified over the positions): they alone make the row, their arrivals, the flux leaving by
 * the parity of their own bounces, and the moments of their exits' turn in the profile plane
 * (BSTI_VN_*_W, _D, _D2: flux, flux x turn, flux x turn^2, by that parity).  A rough ray may
 * bounce more often than a flat one, and leave by the other side: light meeting a slat almost
 * normally walks between the slats (the tilt-45 blind's interior incidence at 45 degrees: T 0.0005
 * of mirror slats with roughness 0.02, none without). */
#define BSTI_VN_ROUGH_RAYS 4
/* Curved slats: rays per incident direction across the part of the opening that meets a slat
 * (each direction of a patch its own, stratified, entry positions). */
#define BSTI_VN_CURVED_RAYS 8
/* Curved slats: emission angles per position in the strips' exchange, and positions per face
 * (BSTI_VN_EXCHANGE_POSITIONS a strip at least): strips of neighbouring arcs may come close,
 * where the exchange converges only as 1 / positions (its reciprocity 0.0085 with 64 a strip,
 * 0.0027 with 256, deep arcs 9 mm apart at tilt 60). */
#define BSTI_VN_CURVED_ANGLES 256
#define BSTI_VN_CURVED_FACE_POSITIONS 2048

typedef struct {
    double w, s;         /* slat width, spacing (m) */
    double sb, cb;       /* sin and cos of the tilt */
    double ze;           /* z of the exterior edges (-w cos b); interior edges at z = 0 */
    double nA[2];        /* face A's normal (y, z), into the channel */
    double rs;           /* specular reflectance */
    int m;               /* strips per face */
    int sheet;           /* |tilt| = 90: the slats lie in one plane (no channel) */
    double len;          /* a face's length along its profile (w flat, R 2h curved) */
    /* curved slats (venetian_curved.c): the arc of radius R about c (slat 0), half-angle h
     * (cth = cos h), and the extent of slat 0 in y and z (zlo..zhi: the slab that holds them) */
    int curved;
    double R, half, cth, c[2], ylo, yhi, zlo, zhi;
} bsti_vn_geom;

/* Flat slats, or curved ones when v->curvature > 0 (bsti_vn_curved_init). */
void bsti_vn_geom_init(bsti_vn_geom *g, const bst_venetian *v);

/* The share of light entering along profile direction (a, b) (b > 0: from the exterior, b < 0:
 * from the interior; b != 0) that passes between the slats without meeting one: exact. */
double bsti_vn_open(const bsti_vn_geom *g, double a, double b);

/* Flat slats only: what becomes of unit flux entering along (a, b) on the part of the opening
 * that meets a slat (whatever that part's size): row[BSTI_VN_EVEN ..] as enumerated above, BSTI_VN_DEP + 2 m values;
 * sigma > 0 (rough slats, the deviation of a facet's slope in the profile plane) adds the moments
 * of BSTI_VN_ROUGH_RAYS rays per entry position traced with their own facets. */
void bsti_vn_hit(const bsti_vn_geom *g, double a, double b, double sigma, double *row);

/* The strips as seen from the opening that light leaving along profile direction (a, b) crosses
 * (b > 0: the interior one): view[e] = the mean over that opening of rs^n for each n-th hit of
 * strip e by a ray traced back along -(a, b). */
void bsti_vn_view(const bsti_vn_geom *g, double a, double b, double *view);

/* g[e * n + j] (n = 2 segments): the flux arriving on element e (at every bounce, weighted
 * rs^bounces) per unit flux emitted diffusely by element j into the channel. */
void bsti_vn_exchange(const bsti_vn_geom *g, double *gm);

/* WINDOW's model (rule=centre, venetian_wce.c): the blind v into channels vis[0..nvis) of l
 * (its slat values) and sol[0..nsol) (Solar: what WCE's dual-band rule makes of v's solar values,
 * bsdfstack.h); and the checks of its keys (rule, distribution, and what the model lacks). */
int bsti_vn_wce_layer(bst_ctx *ctx, const bst_venetian *v, const bst_basis *basis, bst_layer *l,
                      size_t nvis, const size_t *vis, size_t nsol, const size_t *sol);
int bsti_vn_wce_check(bst_ctx *ctx, const bst_venetian *v);

/* The slope of a rough facet (standard Gaussian) met at bounce j by ray `seed`: the same on every
 * run. */
double bsti_vn_facet_slope(unsigned long seed, long j);

/* Curved slats (venetian_curved.c; bsti_vn_open, _view and _exchange turn to these when
 * g->curved).  _init: the arc of radius `radius` over the flat slat set up in g. */
void bsti_vn_curved_init(bsti_vn_geom *g, double radius);
double bsti_vn_curved_open(const bsti_vn_geom *g, double a, double b);
void bsti_vn_curved_view(const bsti_vn_geom *g, double a, double b, double *view);
void bsti_vn_curved_exchange(const bsti_vn_geom *g, double *gm);
/* Where light entering along (a, b) (unit) meets a slat: the positions y0 .. y0 + span on the
 * plane z = z0 that it enters by (span <= s: the shadow of one arc, or a whole period when the
 * shadows overlap).  0 when no light meets a slat. */
int bsti_vn_curved_entries(const bsti_vn_geom *g, double a, double b, double *y0, double *z0,
                           double *span);
/* Follow a profile ray from start along dir (unit) with flux wgt until it leaves the slab of the
 * slats: each arrival on a strip adds the flux then carried to dep[element]; each bounce takes
 * rs.  The ray starts on no slat (jlast = LONG_MIN) or on face flast (0 convex, 1 concave) of
 * slat jlast.  sigma > 0: each bounce's facet is tilted along the arc by sigma
 * bsti_vn_facet_slope(seed, bounce).  out: the flux that leaves, its direction (2) and the
 * normal of its last bounce's facet (2; 0 without a bounce).  Returns the number of bounces. */
long bsti_vn_curved_trace(const bsti_vn_geom *g, const double start[2], const double dir[2],
                          long jlast, int flast, double wgt, double *dep, double sigma,
                          unsigned long seed, double out[5]);

/* The slat values of a channel named Solar: v's, with solar[k] where it is not NaN, into *vs;
 * whether any differs from v's (venetian_spec.c; bst_venetian_layer, bst_shade_model_plan). */
int bsti_vn_solar(const bst_venetian *v, bst_venetian *vs);

/* A layer of a sheet with openings (perforated.c; perforated screens, woven fabrics): share(data,
 * d) the share of the sheet open along unit direction d (even in d), averaged over each patch by
 * samples^2 directions (0: BST_VENETIAN_SAMPLES), on the diagonal of the transmissions; the rest
 * reflected (v[0] = rf, v[1] = rb) and transmitted (v[2] = t) diffusely by the reciprocal rank-one
 * term of bst_perforated; a channel named Solar takes sol[k] where it is not NaN.  nchannels 0:
 * Visible and Solar. */
int bsti_open_layer(bst_ctx *ctx, const bst_basis *basis, double (*share)(const void *, const double *),
                    const void *data, const double v[3], const double sol[3], int samples,
                    size_t nchannels, const char *const *channels, bst_layer **out);
/* Channel ch of l from a sheet's parts: component c = diag(dg[c]) + o in[c]^T (o over the
 * outgoing patches, in[c] over the incident ones, N values each; dg[c] NULL: no diagonal; in[c]
 * NULL: the diagonal alone, zero without one), each factored (lowrank.h) over one map
 * [o | in[TF] | in[RF] | in[TB] | in[RB]] of the channel: the stack keeps a screen or a fabric at
 * rank one instead of N^2 values a component (perforated.c). */
int bsti_sheet_channel(bst_ctx *ctx, const bst_basis *basis, const double *o,
                       const double *const in[BST_NCOMP], const double *const dg[BST_NCOMP],
                       bst_layer *l, size_t ch);
/* WINDOW's models of sheets (sheet_wce.c; rule=centre of bst_perforated and bst_woven): the
 * layer with every patch at its centre (exactly one of p, w given; v and sol as for
 * bsti_open_layer); WCE's open share of a screen and of a fabric along unit direction d, and
 * its fabric's scattering through the threads for the reflectance r of the side not met; the
 * checks of rule=centre (rule, samples 0, the values outside the visible range). */
int bsti_sheet_wce_layer(bst_ctx *ctx, const bst_basis *basis, const bst_perforated *p,
                         const bst_woven *w, const double v[3], const double sol[3],
                         size_t nchannels, const char *const *channels, bst_layer **out);
double bsti_perforated_wce_open(const bst_perforated *p, const double d[3]);
double bsti_woven_wce_open(const bst_woven *w, const double d[3]);
double bsti_woven_wce_scatter(const bst_woven *w, const double d[3], double r);
int bsti_sheet_wce_check(bst_ctx *ctx, const char *what, int rule, int samples, const double v[3],
                         const double sol[3]);
/* The checks of a sheet's diffuse values (perforated screens, woven fabrics: `what`): each of
 * rf, rb, t (named by names[]) in [0, 1], rf + t and rb + t at most 1, the values and the Solar
 * ones (sol[k] where not NaN). */
int bsti_sheet_check(bst_ctx *ctx, const char *what, const char *const names[3], const double v[3],
                     const double sol[3]);

/* Spec values of the shades (venetian_spec.c, perforated.c): "16mm", "0.016m", "1.6cm", "0.63in"
 * or a bare number of millimetres -> metres; a plain number.  0, or -1 when v is not one. */
int bsti_shade_parse_length(const char *v, double *m);
int bsti_shade_parse_number(const char *v, double *x);
/* rule= of perforated and woven specs (perforated.c): average or centre (center) into *rule;
 * else an error naming `what` and the key. */
int bsti_shade_parse_rule(bst_ctx *ctx, const char *what, const char *val, int *rule);
/* A reflectance or transmittance as a spec gives it: a number, or VISIBLE/SOLAR (*sol the second,
 * for a channel named Solar; NaN when there is no '/').  0, or -1 when v is not one. */
int bsti_shade_parse_bands(const char *v, double *vis, double *sol);
/* Each key=value item of a comma-separated shade spec, in order (spaces before a key skipped):
 * `what` names the kind in messages; keys[0..nkeys-1] the key names; set(ctx, k, value, seen,
 * opaque) takes item k, value NULL when the item has no '=' (seen[k]: items of key k before
 * this one, the same key twice refused here, with the key's name).  A key not among keys is
 * refused naming them all; a spec longer than 511 characters is refused.  seen[] (nkeys values)
 * is cleared first and tells the caller which keys came. */
typedef int (*bsti_shade_set)(bst_ctx *ctx, int k, const char *value, const int *seen, void *opaque);
int bsti_shade_spec(bst_ctx *ctx, const char *what, const char *spec, const char *const *keys,
                    int nkeys, bsti_shade_set set, void *opaque, int *seen);

#endif
