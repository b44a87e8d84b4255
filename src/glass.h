/* glass.h - internal side of the analytic glass module, shared by its files:
 *   glass.c        the slab model (Fresnel, a slab with bulk absorption), the pane object and its
 *                  evaluation at an angle, per channel or per wavelength;
 *   glass_coated.c WINDOW's angular model of coated glass, and which model a material type takes;
 *   glass_optics.c Optics / IGDB text files of a pane's spectral data;
 *   glass_json.c   IGSDB JSON records: a glazing product's data, a shading product (bst_shade);
 *   glass_json2.c  IGSDB v2 glazing records (glass_json.c tells v1 from v2);
 *   glass_band.c   spectral panes: their data tables, the band spectra and the CIE fits, band
 *                  channels and their wavelength weights;
 *   glass_spec.c   specifications ("glass:NAME|PATH|key=value") and catalogue files;
 *   glass_layer.c  the pane as a diagonal layer: patch quadrature over a basis;
 *   spectral.c     stacks of spectral panes combined per wavelength (bst_stack_combine_spectral).
 * Tests and benchmarks use the layer builder below with its numerical parameters exposed, to
 * compare the fast path with exact evaluation and to measure what patch averaging changes.
 *
 * Conventions: angles in radians, wavelengths in micrometres, thickness in metres.  A layer's patch
 * value is P / Lambda (1/sr) with P the pane's directional T or R, either at the patch centre or
 * averaged over the patch uniformly in projected solid angle (bst_basis_sample). */
#ifndef BST_GLASS_H
#define BST_GLASS_H

#include "bsdfstack.h"

/* ------------------------------------------------------------------ the pane (glass.c) */

/* Channels a pane may have (five spectral bands plus a few catalogue bands). */
#define BSTI_GLASS_MAX_CH 8

/* One side of a pane at one wavelength or band: the measured values and the derived slab. */
struct bsti_glass_side {
    double t0, r0;  /* normal-incidence transmittance and reflectance */
    double rho0;    /* reflectance of one interface at normal incidence */
    double n;       /* refractive index */
    double tau0;    /* single-pass internal transmittance at normal incidence */
    double ltau0;   /* log(tau0) from 1 - tau0 (-inf when tau0 = 0): keeps a near-mirror's
                       1 - tau^(1 / cos t) exact through expm1 */
    int coated;     /* 1: WINDOW's coated correlations from t0, r0 (glass_coated.c), not the slab */
};

/* Measured normal-incidence spectrum of a pane (wavelength in um). */
struct bsti_glass_data {
    size_t n;
    double *wl, *tf, *tb, *rf, *rb;
};

/* A source or detector spectrum, or an integration grid (x only). */
struct bsti_glass_spectrum {
    size_t n;
    double *x, *y;
};

/* A channel is a weighted sum over nodes: property(theta) = sum_k w_k model(T0_k, R0_k, theta);
 * a band channel has one node of weight 1, a spectral channel the trapezoid rule folded into w.
 * A spectral channel also keeps the integration grid that stacks combining per wavelength use
 * (bst_glass_channel_weights): wavelengths grid[], source x detector sd[], range lo..hi. */
struct bsti_glass_channel {
    char *name;
    size_t nk;
    double *w;
    struct bsti_glass_side *front, *back;
    size_t ng;
    double *grid, *sd;
    double lo, hi;
};

struct bst_glass {
    bst_ctx *ctx;
    size_t nch;
    struct bsti_glass_channel ch[BSTI_GLASS_MAX_CH];
    char *description;
    char *where;                       /* "glass:SPEC", for messages */
    bst_glass_model model;             /* of every side of every channel (bst_glass_set_model) */
    bst_glass_meta meta;               /* its strings owned here (bsti_glass_meta_set) */
    struct bsti_glass_data data;       /* spectral panes only (data.n > 0) */
    struct bsti_glass_spectrum solar, d65, v, photopic; /* spectra of the bands, spectral panes */
    size_t layer_rows;                 /* bst_glass_set_layer_rows (0: all) */
};

/* The slab of one side from its normal-incidence T0 and R0 (steps 1-3 of the model in glass.c);
 * -1 when no slab has these values.  The side is uncoated; bsti_glass_side_model makes it follow
 * the model given (a coated side keeps its slab values, which only bst_glass_slab would show). */
int bsti_glass_side_init(struct bsti_glass_side *s, double t0, double r0);
int bsti_glass_side_model(struct bsti_glass_side *s, double t0, double r0, bst_glass_model m);
/* A new pane with empty metadata (NULL when out of memory). */
bst_glass *bsti_glass_new(bst_ctx *ctx);
/* Set one of the pane's metadata strings (g->meta.FIELD, not model_from) to a copy of text
 * (NULL = ""), freeing the old. */
int bsti_glass_meta_set(bst_glass *g, const char **field, const char *text);
/* Tf, Tb, Rf, Rb of channel c at theta into v: the nodes' weighted sums, rows of weight 0 passed
 * over, T + R <= 1 kept (bst_glass_optics). */
void bsti_glass_channel_optics(const struct bsti_glass_channel *c, double theta, double v[4]);
/* T and R of one side at theta (radians, 0..pi/2). */
void bsti_glass_side_optics(const struct bsti_glass_side *s, double theta, double *t, double *r);
/* y(xq) by linear interpolation in increasing x[0..n-1], constant outside the range. */
double bsti_glass_interp(const double *x, const double *y, size_t n, double xq);
/* Normal-incidence data of the pane at um, interpolated linearly (constant outside). */
void bsti_glass_data_at(const struct bsti_glass_data *d, double um, double *tf, double *tb,
                        double *rf, double *rb);
/* A new channel is built in place at g->ch[g->nch] and is then complete or absent:
 * bsti_glass_channel_new allocates its name, weights and nk sides (zeroed), and
 * bsti_glass_channel_commit(rc) keeps it (rc >= 0) or clears it; it returns rc. */
int bsti_glass_channel_new(bst_ctx *ctx, bst_glass *g, const char *where, const char *name,
                           size_t nk);
int bsti_glass_channel_commit(bst_ctx *ctx, bst_glass *g, int rc);

/* ------------------------------------------------------------------ coated glass (glass_coated.c) */

/* T and R at cos(theta) = c (0..1) of a coated side with normal-incidence t0, r0 (the reference
 * glass by BST_GLASS_COATED_CLEAR_T0), without the
 * special case theta = 0 (which gives t0, r0: bsti_glass_side_optics). */
void bsti_glass_coated_optics(double t0, double r0, double c, double *t, double *r);
/* The polynomials' values at c: the transmittance ratio T / T0 and the reflectance one, before
 * T and R are formed and clipped; bronze = 1 for the bronze glass's (for the tests). */
void bsti_glass_coated_poly(int bronze, double c, double *tau, double *rho);
/* Give every side of g (and the channels added later) the model; from: g->meta.model_from, one of
 * the literals listed there (kept, not copied). */
int bsti_glass_apply_model(bst_glass *g, bst_glass_model model, const char *from);

/* ------------------------------------------------------------------ spectral bands (glass_band.c) */

/* fgets for the line-based glass files (catalogues, data tables): 1 with the next line in buf, 0 at
 * the end of the file, -1 when the line does not fit (len - 1 characters and its newline), which
 * callers report rather than read its tail as a line of its own, -2 when it holds a NUL byte (the
 * string would end there, and the rest of the line go unread). */
int bsti_glass_read_line(FILE *fp, char *buf, size_t len);
/* The error for line lineno of path that bsti_glass_read_line refused (got < 0) in a buffer of len. */
int bsti_glass_line_error(bst_ctx *ctx, const char *path, int lineno, int got, size_t len);

#define BSTI_GLASS_BAND_LIST "Visible, Solar, CIE-X, CIE-Y, CIE-Z"
struct bsti_glass_band;
/* The band of that name (case-insensitive), NULL if none. */
const struct bsti_glass_band *bsti_glass_find_band(const char *name);
/* Read a pane's spectral data file into g->data, in whichever of its formats it is (bsdfstack's
 * table: wavelength, Tf, Tb, Rf, Rb; an Optics / IGDB text file; an IGSDB JSON record), and the
 * band spectra from the catalogue directory dir.  g->meta says what was read. */
int bsti_glass_load_spectral(bst_ctx *ctx, bst_glass *g, const char *path, const char *dir);
/* One row of spectral data as every file format must give it: a wavelength in um that is plausible
 * (a file in nanometres read as micrometres is not) and above prev_um, and v = {Tf, Tb, Rf, Rb}
 * each in [0, 1] with T + R <= 1 per side (to rounding) and R < 1.  where names the row. */
int bsti_glass_row_check(bst_ctx *ctx, const char *where, double prev_um, double um,
                         const double v[4]);
/* Room for need rows in d's five columns, whose capacity is *cap (d->n rows kept). */
int bsti_glass_data_reserve(bst_ctx *ctx, struct bsti_glass_data *d, size_t *cap, size_t need);

/* ------------------------------------------------------------------ files (glass_optics.c, _json.c) */

/* What the file readers take as plausible, to refuse a value in the wrong unit rather than keep
 * it: a pane's thickness up to BSTI_GLASS_MAX_THICKNESS_MM (mm; metres read as mm pass, but
 * micrometres do not), a conductivity up to BSTI_GLASS_MAX_CONDUCTIVITY W/(m K) (above any metal),
 * a shade's lengths up to BSTI_SHADE_MAX_LENGTH_MM (mm), its slats cut into at most
 * BSTI_SHADE_MAX_SEGMENTS segments. */
#define BSTI_GLASS_MAX_THICKNESS_MM 1000.0
#define BSTI_GLASS_MAX_CONDUCTIVITY 1e4
#define BSTI_SHADE_MAX_LENGTH_MM 1e4
#define BSTI_SHADE_MAX_SEGMENTS 1000

/* Which format a pane's data file is, from its first characters: an IGSDB record starts with '{'
 * (or '[') and then '"' or a line break, an Optics file with '{' and a field name on that line,
 * anything else is bsdfstack's table.  An error when it cannot be opened. */
enum bsti_glass_format { BSTI_GLASS_TABLE, BSTI_GLASS_OPTICS, BSTI_GLASS_IGSDB };
int bsti_glass_sniff(bst_ctx *ctx, const char *path, enum bsti_glass_format *fmt);
/* An Optics / IGDB text file into g->data and g->meta (type, product, thickness, ...). */
int bsti_glass_read_optics(bst_ctx *ctx, bst_glass *g, const char *path);
/* An IGSDB JSON record: a glazing product into g->data and g->meta; a shading product is read and
 * validated as bst_shade_read_igsdb does and refused with BST_ENOTIMPL. */
int bsti_glass_read_igsdb(bst_ctx *ctx, bst_glass *g, const char *path);
/* An IGSDB v2 glazing record (root, a jansson json_t *) into g->data and g->meta (glass_json2.c);
 * path names the file in messages. */
struct json_t;
int bsti_glass_read_glazing_v2(bst_ctx *ctx, const char *path, bst_glass *g, struct json_t *root);
/* Data d's normal-incidence Tf, Tb, Rf, Rb (v) averaged over the band named (Visible, Solar,
 * CIE-X, CIE-Y, CIE-Z) with the weights a spectral pane's channel of that band gives its data, the
 * band spectra read from the catalogue directory dir (a shade's material, bst_shade_model_of);
 * where: for messages. */
int bsti_glass_band_average(bst_ctx *ctx, const struct bsti_glass_data *d, const char *dir,
                            const char *band, const char *where, double v[4]);
/* Add band b as a channel of spectral pane g (where: for messages); complete or absent.  Data that
 * do not reach both ends of the band (to 1e-6 um) are refused, here and in
 * bsti_glass_band_average, with one line: where, the range the data cover and the band's. */
int bsti_glass_add_band(bst_ctx *ctx, bst_glass *g, const char *where,
                        const struct bsti_glass_band *b);

/* ------------------------------------------------------------------ layers (glass_layer.c) */

/* Patch averages (bst_glass_layer with at_centre = 0) integrate over bst_basis_sample's (u, v)
 * square with Gauss-Legendre points after a substitution that removes the rim's square-root
 * singularity (glass_layer.c, patch_rule): Shirley-Chiu's square split into four triangles, each
 * with BST_GLASS_SAMPLES^2 points (4 x 8^2 = 256 directions per patch); Klems, whose patches' incidence
 * angle depends on u alone, 4 BST_GLASS_SAMPLES points in u (32 per patch).  Against 4x more points
 * per dimension the patch values (Lambda x value, i.e. T or R) differ by at most 7.6e-6 at k = 1,
 * 2.5e-6 at k = 2..7 and 4.8e-11 in Klems full; the diffuse-diffuse sum over patches matches the
 * continuous pane's 2 int P sin cos dtheta to 7.6e-6 (k = 1), 6.3e-7 (k = 3), 2.8e-8 (k = 7) and
 * 3.2e-12 (Klems full) (clear 6 mm and NFRC 103, Visible: bench/bench_glass; test_glass checks the
 * k = 3 and 7 sums). */
#define BST_GLASS_SAMPLES 8

/* Angular table used by patch averages when they need more distinct directions than it has angles
 * (256 directions per patch, and a spectral channel sums the model over about a hundred
 * wavelengths per direction; Shirley-Chiu k >= 4, not Klems full's 288): Tf, Tb, Rf, Rb at BST_GLASS_TABLE_STEPS + 1
 * equidistant angles 0..90 degrees, linear in between.  Pointwise it deviates from exact evaluation
 * by < 2e-6 up to 89.9 degrees and < 2e-5 in the last 0.01 degree; in a layer's patch values
 * (Lambda x value) by at most BST_GLASS_TABLE_ERR (catalogue panes, Klems full and Shirley-Chiu k = 3
 * and 5 when it was used everywhere: 2.3e-8; k = 5 checked by tests/test_glass.c). */
#define BST_GLASS_TABLE_STEPS 9000
#define BST_GLASS_TABLE_ERR 5e-8

/* bst_glass_layer with its parameters: samples = Gauss points per triangle and dimension (>= 1;
 * ignored when at_centre), exact = 1 to evaluate every direction exactly instead of through the
 * table. */
int bsti_glass_layer(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, size_t nchannels,
                     const char *const *channels, int at_centre, int samples, int exact,
                     bst_layer **out);

/* The angular table of channel ch (4 * (BST_GLASS_TABLE_STEPS + 1) values: Tf, Tb, Rf, Rb at each
 * angle), freed with bsti_free; NULL when out of memory.  bsti_glass_table_optics interpolates it at
 * theta into v = {Tf, Tb, Rf, Rb}. */
double *bsti_glass_table(bst_ctx *ctx, const bst_glass *g, size_t ch);
void bsti_glass_table_optics(const double *tab, double theta, double v[4]);

/* The directions a layer's patch values average (bst_glass_layer): per patch, the incidence
 * angles and weights of its points (at_centre: the centre alone), computed once per basis so that
 * a stack evaluated at hundreds of wavelengths pays for the geometry once. */
typedef struct bsti_glass_rule bsti_glass_rule;
int bsti_glass_rule_new(bst_ctx *ctx, const bst_basis *basis, int at_centre, int samples,
                        bsti_glass_rule **out);
void bsti_glass_rule_free(bst_ctx *ctx, bsti_glass_rule *r);
/* bst_glass_layer_at with a precomputed rule for basis. */
int bsti_glass_layer_at(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis,
                        const bsti_glass_rule *rule, double lambda_um, bst_layer **out);
/* The same from normal-incidence data d = {Tf, Tb, Rf, Rb} instead of a wavelength (spectral.c
 * evaluates a group of wavelengths at its weighted mean data); g names the layer and messages. */
int bsti_glass_layer_data(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis,
                          const bsti_glass_rule *rule, const double d[4], bst_layer **out);

#endif
