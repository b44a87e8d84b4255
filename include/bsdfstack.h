/* bsdfstack.h - the public interface of libbsdfstack.
 *
 * bsdfstack computes the bidirectional scattering distribution function (BSDF) of a window system
 * from the BSDFs of its layers by the matrix (Klems) formalism, in the Klems bases or in RADIANCE's
 * Shirley-Chiu tensor-tree basis at any resolution k = 1..7.
 *
 * Physics contract (every function below relies on it)
 * ------------------------------------------------------
 * - Frame: +Z is the surface normal pointing to the interior (room), -Z to the exterior.  X lies in
 *   the surface plane, Y is "up".  This is RADIANCE's and the BSDF XML files' frame.
 * - Front = exterior side (-Z), back = interior side (+Z), as in the XML labels.  Layers of a stack
 *   are listed exterior first.
 * - Components: Tf (light arrives on the front, leaves through the back), Rf (front -> front),
 *   Tb (back -> front), Rb (back -> back).
 * - A component is a matrix over a directional basis: column = incident patch, row = outgoing patch,
 *   value = BSDF in 1/sr (radiance out per irradiance in; not multiplied by any cosine).
 * - Index convention: the incident patch is that of the light's PROPAGATION direction (the negated
 *   vector pointing to the source), the outgoing patch that of its exit direction; patches are
 *   found from the x, y components of those directions only.  A ray therefore keeps its patch
 *   index across a gap between two layers, and straight-through transmission and mirror
 *   reflection both lie on the diagonal.  (RADIANCE's tensor trees use the same convention.)
 * - Lambda is the diagonal matrix of the patches' projected solid angles (sr): pi/4^k for every
 *   Shirley-Chiu patch, pi*(cos^2 t0 - cos^2 t1)/n for a Klems patch.  Lambda*M*e_i summed over
 *   rows is the directional-hemispherical value of incident patch i.
 *
 * Conventions of the API
 * ----------------------
 * - Every function that can fail returns an int status: 0 = success, < 0 = error, > 0 = warning
 *   (the result is usable, e.g. an ill-conditioned solve).  The message describing the last
 *   error or warning is held by the bst_ctx passed in (bst_ctx_message).
 * - Objects come in _new/_free pairs; every _free accepts NULL.
 * - The library never prints, never exits and holds no global mutable state: one bst_ctx per
 *   thread.
 */
#ifndef BSDFSTACK_H
#define BSDFSTACK_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------- status and context (ctx) */

enum bst_status {
    BST_OK = 0,
    BST_EINVAL = -1,     /* invalid argument (NULL, out of range, NaN) */
    BST_ENOMEM = -2,     /* allocation failed */
    BST_ESIZE = -3,      /* operand sizes do not match */
    BST_EIO = -4,        /* file could not be read or written */
    BST_EFORMAT = -5,    /* malformed input file */
    BST_EBASIS = -6,     /* unknown or incompatible basis */
    BST_ESINGULAR = -7,  /* (I - A) is singular to working precision */
    BST_ENOTFOUND = -8,  /* a named item (layer, component, channel) does not exist */
    BST_EINTERNAL = -9,  /* a library routine (BLAS, LAPACK, SuiteSparse) failed unexpectedly */
    BST_WILLCOND = 1,    /* warning: ill-conditioned solve, see the returned rcond */
    BST_WENERGY = 2,     /* warning: energy imbalance beyond tolerance in an input */
    BST_WDATA = 3        /* warning: input data repaired or completed (e.g. reciprocity used) */
};

/* Short text of a status code ("out of memory", ...); never NULL. */
const char *bst_strerror(int status);

typedef struct bst_ctx bst_ctx;

/* Allocator hooks: malloc-like and free-like, with the opaque pointer given at registration. */
typedef void *(*bst_malloc_fn)(size_t size, void *opaque);
typedef void (*bst_free_fn)(void *ptr, void *opaque);

/* A new context with the system allocator; NULL only if that allocation fails. */
bst_ctx *bst_ctx_new(void);
void bst_ctx_free(bst_ctx *ctx);

/* Replace the allocator used for every library-owned buffer created with this context (used by
 * the tests to inject allocation failures); call it before creating any object.  Every object
 * remembers the context that created it, which must outlive the object.  SuiteSparse's internal
 * storage (sparse matrices, factorizations) uses SuiteSparse's own allocator. */
int bst_ctx_set_allocator(bst_ctx *ctx, bst_malloc_fn m, bst_free_fn f, void *opaque);

/* The message of the last error or warning ("" if none), valid until the next call with ctx. */
const char *bst_ctx_message(const bst_ctx *ctx);
/* The status that produced that message (0 if none). */
int bst_ctx_status(const bst_ctx *ctx);
void bst_ctx_clear(bst_ctx *ctx);

/* Progress reporting for long operations: called with a fraction in [0, 1] and a short label.
 * The library calls it at most a few hundred times per operation; NULL disables it. */
typedef void (*bst_progress_fn)(double fraction, const char *label, void *opaque);
void bst_ctx_set_progress(bst_ctx *ctx, bst_progress_fn fn, void *opaque);

/* ---------------------------------------------------------------- structured matrices (mat) */

typedef enum {
    BST_ZERO = 0,    /* no storage: every element is 0 */
    BST_DIAG = 1,    /* square, only the diagonal is stored: O(N) */
    BST_SPARSE = 2,  /* compressed sparse column (CHOLMOD), always double */
    BST_DENSE = 3    /* column-major, double or float */
} bst_structure;

typedef enum { BST_DOUBLE = 0, BST_FLOAT = 1 } bst_precision;

typedef struct bst_mat bst_mat;

/* Constructors.  Values are copied; the result belongs to the caller (bst_mat_free). */
int bst_mat_new_zero(bst_ctx *ctx, size_t rows, size_t cols, bst_mat **out);
int bst_mat_new_diag(bst_ctx *ctx, size_t n, const double *diag, bst_mat **out);
/* Dense, zero-filled, in the given precision; fill it through bst_mat_dense_data. */
int bst_mat_new_dense(bst_ctx *ctx, size_t rows, size_t cols, bst_precision prec, bst_mat **out);
/* Sparse from triplets (row, col, value); duplicates are summed, zeros dropped. */
int bst_mat_new_sparse(bst_ctx *ctx, size_t rows, size_t cols, size_t nnz,
                       const size_t *row, const size_t *col, const double *val, bst_mat **out);
void bst_mat_free(bst_mat *m);

bst_structure bst_mat_structure(const bst_mat *m);
bst_precision bst_mat_precision(const bst_mat *m);
size_t bst_mat_rows(const bst_mat *m);
size_t bst_mat_cols(const bst_mat *m);
/* Number of stored values (N for diagonal, nnz for sparse, rows*cols for dense, 0 for zero). */
size_t bst_mat_nnz(const bst_mat *m);
/* Element (i, j), whatever the structure (O(1) except sparse: O(log nnz in column)). */
double bst_mat_get(const bst_mat *m, size_t i, size_t j);
/* Pointer to the column-major storage of a dense matrix (double* or float* by precision);
 * NULL for any other structure. */
void *bst_mat_dense_data(bst_mat *m);
/* The diagonal of a diagonal matrix; NULL otherwise. */
double *bst_mat_diag_data(bst_mat *m);

/* A copy converted to the given structure and precision.  Converting to DIAG or ZERO fails with
 * BST_EINVAL when off-diagonal (or any) non-zeros exist.  Sparse is always double. */
int bst_mat_convert(bst_ctx *ctx, const bst_mat *m, bst_structure s, bst_precision prec,
                    bst_mat **out);
/* A copy in the cheapest structure that holds m exactly: zero, diagonal, sparse when the fraction
 * of non-zeros is at most sparse_max_fill (default BST_SPARSE_MAX_FILL), else dense in m's
 * precision (double for a sparse input). */
#define BST_SPARSE_MAX_FILL 0.1
int bst_mat_compact(bst_ctx *ctx, const bst_mat *m, double sparse_max_fill, bst_mat **out);

/* C = A * B.  Sparse results drop entries with |c| <= drop_tol * max|C| (0 = exact). */
int bst_mat_mul(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double drop_tol, bst_mat **out);
/* C = alpha * A + beta * B. */
int bst_mat_add(bst_ctx *ctx, double alpha, const bst_mat *a, double beta, const bst_mat *b,
                bst_mat **out);
/* C = diag(d_rows) * A * diag(d_cols); either vector may be NULL (= identity). Used for Lambda. */
int bst_mat_scale(bst_ctx *ctx, const double *d_rows, const bst_mat *a, const double *d_cols,
                  bst_mat **out);
int bst_mat_transpose(bst_ctx *ctx, const bst_mat *a, bst_mat **out);

/* out[j] = sum_i w[i] * M(i, j) (w NULL = ones): with w = Lambda, the directional-hemispherical
 * value of every incident patch j.  out has cols entries. */
int bst_mat_col_weighted_sum(bst_ctx *ctx, const bst_mat *m, const double *w, double *out);
/* Column-major double copy of any matrix into out (rows * cols entries). */
int bst_mat_to_dense_array(bst_ctx *ctx, const bst_mat *m, double *out);
/* The columns cols[0..ncols-1] of m (e.g. only the incident directions a scene needs); the
 * structure is kept, except that columns of a diagonal matrix come back sparse. */
int bst_mat_select_cols(bst_ctx *ctx, const bst_mat *m, size_t ncols, const size_t *cols,
                        bst_mat **out);
/* 1 when every stored value is finite (0 for NULL). */
int bst_mat_all_finite(const bst_mat *m);
/* Largest magnitude of a stored value (0 for zero matrices, NaN for NULL). */
double bst_mat_max_abs(const bst_mat *m);

/* ---------------------------------------------------------------- solves (solve) */

/* X = (I - A)^-1 * B  (bst_solve_left) and  Y = B * (I - A)^-1  (bst_solve_right).
 * A is square; (I - A) is factored once (elementwise for diagonal A, UMFPACK LU for sparse,
 * LAPACK getrf for dense) and reused for every column of B.
 * *rcond (may be NULL) receives 1 / (max(1, |I - A|_1) * |(I - A)^-1|_1), estimated (exact for
 * diagonal A): the reciprocal condition number of I - A measured against the identity's scale,
 * so that it also falls when A approaches a multiple of I (two facing mirrors), where the
 * cancellation in forming I - A loses digits although I - A is well scaled.  A single-precision
 * (dense float) factorization warns from rcond < 3.5e-4 = sqrt(FLT_EPSILON) at least.
 * Returns BST_WILLCOND
 * (with the result) when rcond < rcond_warn (default BST_RCOND_WARN), BST_ESINGULAR when (I - A)
 * is singular to working precision or the result is not finite. */
#define BST_RCOND_WARN 1e-8
int bst_solve_left(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double rcond_warn,
                   bst_mat **x, double *rcond);
int bst_solve_right(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double rcond_warn,
                    bst_mat **y, double *rcond);

/* ---------------------------------------------------------------- bases (basis) */

/* A directional basis of one hemisphere.  Patches are numbered 0..N-1:
 * - Shirley-Chiu of order k (N = 4^k): the square-to-disk (concentric) map of RADIANCE applied to
 *   the direction's (x, y); square cell (ix, iy) of side 2^-k has index ix * 2^k + iy (ix along
 *   X slowest, "row-wise" as RADIANCE's full tensor order), every patch has Lambda = pi / N.
 * - Klems (full 145, half, quarter, or any band table read from a file): band by band from the
 *   normal outwards; in a band of n patches, patch j is centred on azimuth 360 j / n degrees.
 * A direction's patch depends only on its x, y components (|z| is implied), so the same function
 * serves incident propagation directions and exit directions of either hemisphere. */
typedef struct bst_basis bst_basis;
typedef enum { BST_BASIS_SHIRLEY_CHIU = 0, BST_BASIS_KLEMS = 1 } bst_basis_kind;

#define BST_K_MIN 1
#define BST_K_MAX 7
int bst_basis_new_sc(bst_ctx *ctx, int k, bst_basis **out);
/* which = "full", "half" or "quarter" (built-in LBNL definitions). */
int bst_basis_new_klems(bst_ctx *ctx, const char *which, bst_basis **out);
/* A Klems-type basis from a band table: nbands bands, band b spans theta_bounds_deg[b] ..
 * theta_bounds_deg[b+1] (theta_bounds_deg[0] = 0, last = 90) with nphi[b] patches. */
int bst_basis_new_klems_bands(bst_ctx *ctx, const char *name, size_t nbands,
                              const double *theta_bounds_deg, const int *nphi, bst_basis **out);
int bst_basis_copy(bst_ctx *ctx, const bst_basis *b, bst_basis **out);
void bst_basis_free(bst_basis *b);

bst_basis_kind bst_basis_kind_of(const bst_basis *b);
size_t bst_basis_size(const bst_basis *b);
/* k of a Shirley-Chiu basis, 0 for Klems. */
int bst_basis_order(const bst_basis *b);
/* "LBNL/Shirley-Chiu" or the Klems name ("LBNL/Klems Full", ...). */
const char *bst_basis_name(const bst_basis *b);
/* Projected solid angle of every patch (sr), length bst_basis_size. */
const double *bst_basis_lambda(const bst_basis *b);
/* Patch of a direction (only dir[0], dir[1] are used; |(x, y)| <= 1). */
size_t bst_basis_patch(const bst_basis *b, const double dir[3]);
/* Centre direction of a patch: unit vector with z >= 0. */
void bst_basis_center(const bst_basis *b, size_t patch, double dir[3]);
/* A direction inside a patch: (u, v) in [0,1)^2 maps uniformly in projected solid angle onto the
 * patch ((0.5, 0.5) is near its centre); dir gets a unit vector with z >= 0.  Averages over a
 * patch (resampling, analytic layers) sample it this way. */
void bst_basis_sample(const bst_basis *b, size_t patch, double u, double v, double dir[3]);
/* The patch of the point-reflected direction (x, y) -> (-x, -y); used for reciprocity
 * (f(in, out) = f(out, in) exchanges a propagation direction with an exit direction). */
size_t bst_basis_antipode(const bst_basis *b, size_t patch);
/* 1 when a and b define the same patches. */
int bst_basis_equal(const bst_basis *a, const bst_basis *b);

/* ---------------------------------------------------------------- layers (layer) */

/* A layer (or a combined stack) is four components per spectral channel over one basis. */
typedef enum { BST_TF = 0, BST_RF = 1, BST_TB = 2, BST_RB = 3 } bst_comp;
#define BST_NCOMP 4
/* "Tf", "Rf", "Tb", "Rb". */
const char *bst_comp_name(bst_comp c);
/* BST_TF.. from "Tf" (case-insensitive); -1 if unknown. */
int bst_comp_parse(const char *name);

typedef struct bst_layer bst_layer;

/* A layer over a copy of basis with the named channels (e.g. "Visible", "Solar", "CIE-X") and no
 * component set. */
int bst_layer_new(bst_ctx *ctx, const bst_basis *basis, size_t nchannels,
                  const char *const *channels, bst_layer **out);
void bst_layer_free(bst_layer *l);

const bst_basis *bst_layer_basis(const bst_layer *l);
size_t bst_layer_nchannels(const bst_layer *l);
const char *bst_layer_channel(const bst_layer *l, size_t channel);
/* Index of a channel by name (case-insensitive), -1 if the layer has none of that name. */
int bst_layer_find_channel(const bst_layer *l, const char *name);
/* The component, or NULL when it is absent. */
const bst_mat *bst_layer_get(const bst_layer *l, size_t channel, bst_comp c);
/* Set (or replace) a component: m must be N x N for the layer's basis; the layer takes ownership
 * of m, also on failure. */
int bst_layer_set(bst_ctx *ctx, bst_layer *l, size_t channel, bst_comp c, bst_mat *m);
/* Detach a component (the caller owns it; NULL if absent). */
bst_mat *bst_layer_take(bst_layer *l, size_t channel, bst_comp c);
/* Free-form name and description kept with the layer (e.g. the file it came from). */
int bst_layer_set_name(bst_ctx *ctx, bst_layer *l, const char *name);
const char *bst_layer_name(const bst_layer *l);

/* Reverse a layer (install it with its back side facing the exterior): a rotation by 180 degrees
 * about the vertical Y axis, (x, y, z) -> (-x, y, -z).  Front and back components swap and every
 * patch index is mirrored x -> -x. */
int bst_layer_flip(bst_ctx *ctx, const bst_layer *l, bst_layer **out);

/* Per incident patch j of component c of channel ch: the directional-hemispherical value
 * sum_i Lambda_i * M(i, j) (transmittance or reflectance); out has N entries.  An absent component
 * gives zeros. */
int bst_layer_hemispherical(bst_ctx *ctx, const bst_layer *l, size_t ch, bst_comp c, double *out);

/* ---------------------------------------------------------------- stacks (stack, spectral) */

/* Combination of layers listed exterior first, all over the same basis, by the matrix formalism
 * (two layers 1 = exterior, 2 = interior, Lambda the projected solid angles):
 *   Tf = Tf2 (I - L Rb1 L Rf2)^-1 L Tf1          Rf = Rf1 + Tb1 (I - L Rf2 L Rb1)^-1 L Rf2 L Tf1
 *   Tb = Tb1 (I - L Rf2 L Rb1)^-1 L Tb2          Rb = Rb2 + Tf2 (I - L Rb1 L Rf2)^-1 L Rb1 L Tb2
 * Only the requested components are computed, and of every partial stack only what they need.
 * An absent component of a layer counts as zero. */
#define BST_COMP_BIT(c) (1u << (c))
#define BST_COMP_ALL 0xFu

typedef struct {
    bst_comp comp;          /* component being formed */
    size_t step;            /* 1..n-1: layers 0..step combined */
    const char *channel;
    bst_structure structure;
    size_t nnz;
    double seconds;         /* wall time of the step for this component */
    double rcond;           /* of the inter-reflection solve (1 when none) */
} bst_stack_step;

typedef struct {
    unsigned comps;         /* requested output components, BST_COMP_BIT mask; default all */
    double drop_tol;        /* sparse fill-in drop tolerance (relative), default 0 = exact */
    double rcond_warn;      /* warn below this reciprocal condition number, default BST_RCOND_WARN */
    double energy_tol;      /* warn when an input's T + R exceeds 1 + energy_tol for some
                               incident patch, default BST_ENERGY_TOL */
    int strict;             /* 1: ill-conditioning and energy imbalance are errors, default 0 */
    int force_dense;        /* 1: convert every matrix to dense first (the baseline), default 0 */
    bst_precision precision;/* precision of dense work, default BST_DOUBLE */
    /* Called after each component of each step (for -v); may be NULL. */
    void (*on_step)(const bst_stack_step *step, void *opaque);
    void *opaque;
} bst_stack_opts;
#define BST_ENERGY_TOL 0.01

void bst_stack_opts_init(bst_stack_opts *opts);
/* Combine n >= 1 layers (exterior first) into *out, which has the channels common to all layers
 * (by name, in the first layer's order) and the requested components.  Returns the highest warning
 * (BST_WILLCOND, BST_WENERGY) with its message in ctx, or an error. */
int bst_stack_combine(bst_ctx *ctx, size_t n, const bst_layer *const *layers,
                      const bst_stack_opts *opts, bst_layer **out);
/* The same, consuming the layers: each input component is freed as soon as the combination has
 * used it for the last time, so that the peak holds fewer of them (a pane and a dense layer at
 * k = 7: 12 instead of 20 GiB in double).  On return, success or not, every layers[i] is freed and
 * set to NULL; a layer object listed more than once (one pane for both panes) is freed once. */
int bst_stack_combine_consume(bst_ctx *ctx, size_t n, bst_layer **layers,
                              const bst_stack_opts *opts, bst_layer **out);

/* Per-layer absorptance of a stack (Klems 1994, part 2): for unit flux incident from patch j on
 * the front (exterior) side, abs_front[(i * N) + j] is the fraction absorbed by layer i (exterior
 * first); abs_back likewise for incidence from the back side (either may be NULL).  A layer's
 * directional absorptance is 1 - its hemispherical T - R for the side the light arrives on; the
 * flux arriving on each side of each layer follows from the partial stacks above and below it.
 * For layers that conserve energy, system T + R + sum_i abs_i = 1 per incident patch. */
int bst_stack_absorptance(bst_ctx *ctx, size_t n, const bst_layer *const *layers, size_t ch,
                          const bst_stack_opts *opts, double *abs_front, double *abs_back);

/* A clear pane (analytic glass, below). */
typedef struct bst_glass bst_glass;

/* A stack of spectral panes (exterior first) combined wavelength by wavelength and averaged
 * afterwards, as WINDOW and Windows-CalcEngine do for multi-layer systems (combining band-averaged
 * panes gives another answer: the system is not linear in the panes' T and R).  For each channel
 * (a band: Visible, Solar, CIE-X, CIE-Y, CIE-Z; added to panes[0] when it lacks it) the wavelengths
 * are the union of the panes' measured wavelengths, or the band's integration grid when that is
 * shorter (WCE's rule); each wavelength's system (bst_stack_combine with opts, every matrix
 * diagonal: O(N)) is added with its bst_glass_channel_weights weight and freed.  out has the
 * channels in the order given.  abs_front / abs_back (may be NULL): per-layer absorptance
 * averaged the same way, nchannels * n * N values, [(c * n + i) * N + j] (see
 * bst_stack_absorptance).  Returns the highest warning of any wavelength, or an error. */
int bst_stack_combine_spectral(bst_ctx *ctx, size_t n, bst_glass *const *panes,
                               const bst_basis *basis, size_t nchannels,
                               const char *const *channels, int at_centre,
                               const bst_stack_opts *opts, bst_layer **out, double *abs_front,
                               double *abs_back);

/* ---------------------------------------------------------------- metrics (metrics) */

/* Accordance of two distributions of scattered light for one incident patch: column `incident` of
 * component c of channel ch of layers a and b (same basis), as in Grobe 2017, section 3.4.2.  With
 * DSF = BSDF * cos(theta_i) (eq. 6; theta_i is the incident direction's, common to the column, so
 * it cancels below) and L_i the projected solid angle of outgoing patch i:
 *   GA = 100 * (1 - sum_i L_i (a_i - b_i)^2 / sum_i L_i (a_i + b_i)^2)      (eq. 7)
 *        global accordance (%).  Shirley-Chiu patches have equal L_i, so this is the paper's plain
 *        sum; unequal Klems patches are weighted by L_i.  Squares make it ruled by the peaks: a
 *        copy scaled by 1.1 scores 99.77, disjoint distributions 0.
 *   LA_i = 100 * (1 - |a_i - b_i| / (a_i + b_i))   (eq. 8; local accordance, %; 100 where both are 0)
 *   FA = 100 * (1 - sum_i L_i |a_i - b_i| / sum_i L_i (a_i + b_i))
 *        flux accordance (%, not the paper's): the share of the scattered flux that the two place
 *        alike, counting diffuse light by its flux where GA sees mostly the peak.
 * Identical distributions give 100; GA and FA are 100 when both are zero.  Any of ga, fa, la (N
 * values) may be NULL, not all three. */
int bst_metrics_accordance(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch,
                           bst_comp c, size_t incident, double *ga, double *fa, double *la);
/* GA and FA (either may be NULL) for every incident patch: N values each. */
int bst_metrics_accordance_all(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch,
                               bst_comp c, double *ga, double *fa);

/* ---------------------------------------------------------------- BSDF XML reader (xml, ttree, resample) */

/* A BSDF XML file as stored: Klems matrices or RADIANCE tensor trees (rank 3 or 4), per spectral
 * channel and component.  The reader streams the file (SAX), never holding its text, and keeps
 * tensor trees as trees (4 bytes per stored value). */
typedef struct bst_bsdf bst_bsdf;
typedef enum { BST_FILE_KLEMS = 0, BST_FILE_TT3 = 3, BST_FILE_TT4 = 4 } bst_file_kind;

typedef struct {
    unsigned comps;                /* components to read, BST_COMP_BIT mask; 0 = all */
    size_t nchannels;              /* channels to read (by name); 0 = all */
    const char *const *channels;
    bst_precision precision;       /* of the dense components bst_bsdf_to_layer makes; default
                                      BST_DOUBLE, BST_FLOAT halves their memory */
} bst_bsdf_read_opts;

/* Read a file.  Errors name the file, the element and the line.  Returns BST_WDATA (a warning,
 * the object is usable) when a component had to be completed: a missing transmission is taken
 * from the other side's by reciprocity, a missing reflection is zero. */
int bst_bsdf_read(bst_ctx *ctx, const char *path, const bst_bsdf_read_opts *opts, bst_bsdf **out);
void bst_bsdf_free(bst_bsdf *b);
bst_file_kind bst_bsdf_kind(const bst_bsdf *b);
/* Tensor-tree resolution k (depth of the finest cells), 0 for Klems files. */
int bst_bsdf_order(const bst_bsdf *b);
/* The Klems basis of a Klems file (NULL for trees). */
const bst_basis *bst_bsdf_klems_basis(const bst_bsdf *b);
size_t bst_bsdf_nchannels(const bst_bsdf *b);
const char *bst_bsdf_channel(const bst_bsdf *b, size_t ch);
/* 1 when the file stores the component (0 when it is derived or zero). */
int bst_bsdf_stored(const bst_bsdf *b, size_t ch, bst_comp c);
/* f(in, out) in 1/sr exactly as RADIANCE's libBSDF evaluates the file (without its deliberate
 * perturbation of 2e-4): in points from the surface to the source, out along the scattered
 * light, both unit vectors in the file's frame (+Z = interior); the component follows from the
 * signs of their z (Tf: in_z < 0 < out_z, Tb: out_z < 0 < in_z, Rf: both < 0, Rb: both > 0). */
int bst_bsdf_eval(bst_ctx *ctx, const bst_bsdf *b, size_t ch, const double in[3],
                  const double out[3], double *value);
/* The file's BSDF as a layer over `target` (NULL: the file's own basis, Shirley-Chiu of order
 * bst_bsdf_order for trees).  Tensor trees at their own or a coarser order are averaged exactly
 * (finer orders replicate); rank-3 trees are averaged over 2 x 2 incident x 3 x 3 outgoing points
 * per cell (2^j times as many per side in a cell 2^j times wider than the tree's or order 5's
 * cells; a point on a cell boundary takes the mean of the cells there).  Klems patches and
 * Shirley-Chiu cells meet by their exact overlaps, in both directions and on both sides:
 * Klems -> Shirley-Chiu gives each pair of cells the mean of the Klems BSDF over them, so every
 * incident cell's directional-hemispherical values are the overlap-weighted mean of its patches'
 * (no light lost or made at any order); Shirley-Chiu -> Klems (trees on their own grid, Klems
 * files via order 6) gives every incident patch the mean of its directions' hemispherical values.
 * Where a cell straddles patches, a round trip Klems -> tree -> Klems smooths: see
 * bsdfstack-convert(1).  Each component lands in its cheapest structure, a dense one in the
 * precision it was read for (bst_bsdf_read_opts). */
int bst_bsdf_to_layer(bst_ctx *ctx, const bst_bsdf *b, const bst_basis *target, bst_layer **out);

/* ---------------------------------------------------------------- BSDF XML writer (xml_write) */

/* A layer written as LBNL WindowElement BSDF XML that RADIANCE's libBSDF, WINDOW and EnergyPlus
 * load.  The layer's basis decides the form:
 * - Klems basis: IncidentDataStructure "Columns" with the AngleBasis blocks, every component of
 *   every channel, each text row holding one outgoing patch (WINDOW, EnergyPlus, RADIANCE).
 *   Components absent from the layer are left out (readers take a missing reflection as zero and
 *   a missing transmission from the other side's by reciprocity): write a zero matrix to state a
 *   zero component.
 * - Shirley-Chiu basis of order k: a RADIANCE tensor tree, "TensorTree3" when every component is
 *   isotropic (tested: see iso_fa_min), else "TensorTree4".
 * Nothing is converted at the boundary: our front is the XML "Front" (exterior, -Z) and our
 * matrices index like RADIANCE's trees and Klems files (incident patch of the propagation
 * direction, outgoing patch of the exit direction).  Values are BSDF in 1/sr.
 *
 * Tree reduction (as genBSDF's rttree_reduce -t, own criterion): each node of the tree gets a
 * variation measure m = sd / (sqrt(mean) + reduce_floor), the standard deviation of its cells
 * relative to the square root of their mean (Monte Carlo noise grows like that root); for a node
 * above the finest 2^D blocks m is the largest of its children's and of the same measure taken
 * over the children's means.  The threshold is the reduce_pct-th percentile of m over the finest
 * blocks (for rank 3 the unused half counts, as in rttree_reduce), and every node with m <= the
 * threshold is written as its average (one value); finest blocks above it keep their 2^D values.
 * Without reduction only exactly constant regions are merged: the file holds every value exactly
 * (to the single precision the tree readers store).  Each tree reaches depth k, so readers that
 * take the resolution from the depth (bst_bsdf_read) get k back.
 * A tree transmission that equals the reciprocal of the other side's (f_T(in, out) =
 * f_T'(out, in), within recip_tol) is left out, as genBSDF does: libBSDF and bst_bsdf_read
 * rebuild it. */
typedef enum { BST_RANK_AUTO = 0, BST_RANK_3 = 3, BST_RANK_4 = 4 } bst_tree_rank;

/* Culling percentile (genBSDF's rttree_reduce -t 90). */
#define BST_REDUCE_PCT 90.0
/* Offset of sqrt(mean) in the variation measure (sqrt(1/sr)): keeps near-zero regions from
 * counting as highly variable (rttree_reduce uses the same 0.03). */
#define BST_REDUCE_FLOOR 0.03
/* Isotropy: TensorTree3 is chosen only if, for every component and every incident patch, the
 * flux accordance FA (bst_metrics_accordance: the stricter of its measures, which counts every difference
 * in proportion to its flux) between the component and its rank-3 form as bst_bsdf_to_layer
 * reads it back is at least this (percent).  A rank-3 tree read onto the grid and rebuilt from it
 * keeps FA >= 99.7 (RADIANCE's diffuser at k = 5: the loss is the rotational
 * smoothing of the grid's incident cells near normal incidence); clear glass gives about 54, a
 * venetian blind 10 to 20. */
#define BST_ISO_FA_MIN 99.0
/* Reciprocity test for leaving out a tree transmission: |Tf(o,i) - Tb(a(i),a(o))| <= recip_tol *
 * max|T| for every element (a = antipodal patch). */
#define BST_RECIP_TOL 1e-6
/* Corrections of a rank-3 tensor built from a grid matrix (see iso_refine). */
#define BST_ISO_REFINE 3

/* What was written for one (channel, component); passed to on_block. */
typedef struct {
    const char *channel;
    bst_comp comp;
    int written;            /* 0: left out: absent from the layer, or (rank 4) a transmission
                               that is the reciprocal of the other side's */
    bst_file_kind kind;     /* BST_FILE_KLEMS, BST_FILE_TT3 or BST_FILE_TT4 */
    size_t values;          /* numbers in the ScatteringData */
    size_t leaves;          /* tree leaves (0 for Klems) */
    uint64_t bytes;         /* bytes of the ScatteringData text */
    double threshold;       /* reduction threshold of the variation measure (0: lossless) */
    /* Error of the file against the layer's matrix, as a reader will see it (rank 3: against the
     * rank-3 tensor; iso_fa measures that step): */
    double l1_error;        /* sum |f - f_file| / sum |f| over all cells (0 when f is 0) */
    double max_error;       /* largest |f - f_file| (1/sr) */
    double hemi_error;      /* largest change of a directional-hemispherical value */
    double iso_fa;          /* rank 3: least FA (%) between the component and its rank-3 form;
                               NaN otherwise */
} bst_bsdf_write_block;

/* Output callback: write len bytes, return 0 on success. */
typedef int (*bst_bsdf_write_sink)(const char *buf, size_t len, void *opaque);

typedef struct {
    bst_tree_rank rank;     /* trees: AUTO (default), or force rank 3 or 4 */
    double reduce_pct;      /* trees: culling percentile in [0, 100); < 0 = no reduction;
                               default BST_REDUCE_PCT */
    double reduce_floor;    /* default BST_REDUCE_FLOOR */
    int digits;             /* significant digits of every value; 0 (default) = as many as needed
                               to read back exactly (float for trees, double for Klems) */
    double iso_fa_min;      /* default BST_ISO_FA_MIN */
    double recip_tol;       /* default BST_RECIP_TOL; < 0 always writes both transmissions */
    int iso_refine;         /* rank 3 built from the layer: corrections of the rank-3 tensor
                               towards the layer (each costs about one isotropy check), default
                               BST_ISO_REFINE */
    /* The file the layer was read from at its own order (may be NULL): when it holds rank-3 trees
     * of the layer's order and channels, and rank 3 is written, the rank-3 tensors are taken from
     * it exactly instead of being rebuilt from the layer (which loses about 1 % of FA near normal
     * incidence, see BST_ISO_FA_MIN). */
    const bst_bsdf *rank3_source;
    /* Metadata (NULL / <= 0: left out).  Material fields: */
    const char *name;       /* default: the layer's name */
    const char *manufacturer;
    const char *device_type;/* default "Other" */
    double thickness, width, height; /* meter */
    /* For the leading XML comment: */
    size_t nlayers;         /* the layers combined, exterior first (default: the layer's name) */
    const char *const *layers;
    const char *command;    /* the command line that made the file */
    const char *description;/* further free text for the comment (may hold several lines) */
    const char *date;       /* default: the current UTC time, ISO 8601 */
    void (*on_block)(const bst_bsdf_write_block *block, void *opaque); /* may be NULL */
    void *opaque;
} bst_bsdf_write_opts;

void bst_bsdf_write_opts_init(bst_bsdf_write_opts *opts);

/* Write layer (NULL opts = defaults) to a stream, a callback, or a file.  bst_bsdf_write_path writes
 * a temporary file next to path and renames it into place only when everything succeeded, so a
 * failed write leaves nothing behind.  Errors: BST_EIO (with the system's reason) when a write
 * fails, BST_EINVAL for a value that is not finite, BST_EBASIS for a basis that has no file form.
 * Peak memory beyond the layer: for a tree about 1/10 of one dense component (the variation
 * measures of the tree nodes); for rank 3 also the rank-3 tensors (1/2^(k+1) of a component). */
int bst_bsdf_write(bst_ctx *ctx, const bst_layer *layer, FILE *fp, const bst_bsdf_write_opts *opts);
int bst_bsdf_write_fn(bst_ctx *ctx, const bst_layer *layer, bst_bsdf_write_sink fn, void *opaque,
                      const bst_bsdf_write_opts *opts);
int bst_bsdf_write_path(bst_ctx *ctx, const bst_layer *layer, const char *path,
                        const bst_bsdf_write_opts *opts);

/* ---------------------------------------------------------------- analytic glass (glass) */

/* A clear (uncoated) pane: a homogeneous slab with two identical interfaces, incoherent multiple
 * reflections and bulk absorption along the refracted path; Fresnel for s and p, averaged.  Per side
 * and per channel (or per wavelength) it is fixed by the normal-incidence transmittance T0 and
 * reflectance R0, from which the interface reflectance, the refractive index n and the single-pass
 * internal transmittance tau0 follow, exactly as Windows-CalcEngine treats uncoated glass (see
 * bsdfstack-glass(5)).  T(90 deg) = 0, R(90 deg) = 1, finite everywhere; a side whose R0 differs
 * makes the pane asymmetric (Rf != Rb, and Tb differs from Tf where the data's Tb does).
 * Specs (the part after "glass:" on the command line):
 *   NAME                       the catalogue file NAME.glass in the catalogue directory
 *   PATH                       (contains '/' or ends in .tsv) normal-incidence spectral data:
 *                              wavelength (um), Tf, Tb, Rf, Rb; channels Visible and Solar
 *   d=6mm,n=1.52,tn=0.89       thickness, refractive index, normal-incidence transmittance
 *   d=6mm,n=1.52,k=25/m        thickness, index and extinction coefficient: tau0 = exp(-k d)
 *   t0=0.834,r0=0.0747[,r0b=]  normal-incidence T and R directly
 * Inline specs apply to the channels Visible and Solar alike.  (The type bst_glass is declared
 * with the stacks above, for bst_stack_combine_spectral.) */
/* catalogue_dir: where NAME.glass files and the band spectra (solar, D65, V, photopic grid) are;
 * NULL = the installed catalogue (BST_GLASS_DIR at build time). */
int bst_glass_parse(bst_ctx *ctx, const char *spec, const char *catalogue_dir, bst_glass **out);
void bst_glass_free(bst_glass *g);
size_t bst_glass_nchannels(const bst_glass *g);
const char *bst_glass_channel(const bst_glass *g, size_t ch);
/* Index of a channel by name (case-insensitive), -1 if none. */
int bst_glass_find_channel(const bst_glass *g, const char *name);
const char *bst_glass_description(const bst_glass *g);
/* Tf, Tb, Rf, Rb of channel ch at incidence angle theta (radians, 0..pi/2); each side follows its
 * own (T0, R0).  Any output may be NULL.  BST_EINVAL (no message: no ctx) for a bad ch or theta. */
int bst_glass_optics(const bst_glass *g, size_t ch, double theta, double *tf, double *tb,
                     double *rf, double *rb);
/* The slab behind channel ch: refractive index and single-pass internal transmittance at normal
 * incidence of the front (back = 0) or back side.  For a spectral pane the values at wavelength
 * lambda_um (data interpolated linearly) whatever ch; for a band channel lambda_um is ignored. */
int bst_glass_slab(const bst_glass *g, size_t ch, double lambda_um, int back, double *n,
                   double *tau0);

/* Spectral panes, for stacks that combine layers per wavelength and average afterwards (WCE's way
 * for multi-layer systems; averaging first and combining band values is not the same).
 * bst_glass_nwavelengths: the number of measured wavelengths (0 for a pane without spectral data),
 * bst_glass_wavelength: the i-th (um).  bst_glass_optics_spectral: Tf, Tb, Rf, Rb at any wavelength,
 * the data interpolated linearly to it (constant outside) and then the angular model. */
size_t bst_glass_nwavelengths(const bst_glass *g);
double bst_glass_wavelength(const bst_glass *g, size_t i);
int bst_glass_optics_spectral(const bst_glass *g, double lambda_um, double theta, double *tf,
                              double *tb, double *rf, double *rb);
/* Add a spectral band channel (Visible, Solar, CIE-X, CIE-Y, CIE-Z) to a spectral pane; no-op if it
 * has the channel.  Visible = CIE-Y = D65 x V(lambda); CIE-X/Z weight D65 by the CIE 1931 x-bar,
 * z-bar (analytic fit) and are normalised by their own integrals (grey pane: X = Y = Z). */
int bst_glass_add_channel(bst_ctx *ctx, bst_glass *g, const char *name);
/* The integration grid of a spectral band channel (um; Solar: the ASTM E891 table's wavelengths,
 * the others the 5 nm photopic grid), NULL for other channels.  WCE evaluates a stack on the union
 * of its layers' measured wavelengths, or on this grid when that is shorter. */
const double *bst_glass_channel_grid(const bst_glass *g, size_t ch, size_t *n);
/* Weights w[0..n-1] such that sum_k w[k] P(wl[k]) is channel ch's average of a property P known at
 * the increasing wavelengths wl[] (um): P interpolated linearly onto the channel's integration grid
 * (constant outside wl's range), weighted by source x detector, trapezoid rule over the band's range;
 * the weights sum to 1.  Reproduces WCE's multi-layer averages to rounding. */
int bst_glass_channel_weights(bst_ctx *ctx, const bst_glass *g, size_t ch, size_t n,
                              const double *wl, double *w);

/* The pane as a layer over basis: four DIAGONAL components (O(N) storage in any basis); each patch
 * value is the patch's directional T (or R) divided by the patch's Lambda, so that Lambda times the
 * value, which is also the component's directional-hemispherical value, is the patch's T (or R):
 *  - at_centre = 0 (bsdfstack's default): the property averaged over the patch uniformly in
 *    projected solid angle (8 x 8 points of bst_basis_sample), which keeps the hemispherical
 *    integrals of the property (diffuse-diffuse T, R) of the continuous pane;
 *  - at_centre = 1: the property at the patch centre (WINDOW's and WCE's choice).
 * The two differ most at grazing patches (figures in bsdfstack-glass(5)).  channels (may be NULL =
 * all of the pane's) selects and orders the channels. */
int bst_glass_layer(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, size_t nchannels,
                    const char *const *channels, int at_centre, bst_layer **out);
/* Parse and build in one step (used for "glass:SPEC" layer arguments; patch averages); a spectral
 * pane is also averaged over any requested band it lacks (CIE-X, ...). */
int bst_glass_layer_from_spec(bst_ctx *ctx, const char *spec, const char *catalogue_dir,
                              const bst_basis *basis, size_t nchannels,
                              const char *const *channels, bst_layer **out);

/* The pane at one wavelength (um) as a one-channel layer ("Spectral") over basis: the data
 * interpolated to the wavelength, then the angular model; at_centre as in bst_glass_layer.  Only for
 * panes with spectral data. */
int bst_glass_layer_at(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, double lambda_um,
                       int at_centre, bst_layer **out);

/* ---------------------------------------------------------------- version */

/* "MAJOR.MINOR.PATCH" of the library actually linked. */
const char *bst_version(void);

#ifdef __cplusplus
}
#endif
#endif /* BSDFSTACK_H */
