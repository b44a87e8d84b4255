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
 * - One section below per module, titled with its source files; its names share one prefix
 *   (bst_<module>_), and the figures behind its defaults are in the man pages.
 */
#ifndef BSDFSTACK_H
#define BSDFSTACK_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* -------------------------------------------------------------------- status and context: ctx.c */

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
    BST_ENOTIMPL = -10,  /* valid input that this version cannot model yet (e.g. a geometric shade) */
    BST_WILLCOND = 1,    /* warning: ill-conditioned solve, see the returned rcond */
    BST_WENERGY = 2,     /* warning: energy imbalance beyond tolerance in an input */
    BST_WDATA = 3,       /* warning: input data repaired or completed (e.g. reciprocity used) */
    BST_WACCURACY = 4    /* warning: a file written as asked (a forced TensorTree3, values cut to
                            few digits) moves a directional-hemispherical value beyond the
                            tolerance; the message says by how much */
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

/* The allocator of every library-owned buffer made with ctx (not SuiteSparse's own storage); set it
 * before creating any object.  Objects keep their ctx, which must outlive them. */
int bst_ctx_set_allocator(bst_ctx *ctx, bst_malloc_fn m, bst_free_fn f, void *opaque);

/* The message of the last error or warning ("" if none), valid until the next call with ctx. */
const char *bst_ctx_message(const bst_ctx *ctx);
/* The status that produced that message (0 if none). */
int bst_ctx_status(const bst_ctx *ctx);
void bst_ctx_clear(bst_ctx *ctx);

/* Progress of long operations, a fraction in [0, 1] and a label, a few hundred calls at most. */
typedef void (*bst_progress_fn)(double fraction, const char *label, void *opaque);
void bst_ctx_set_progress(bst_ctx *ctx, bst_progress_fn fn, void *opaque);

/* Threads the library may use for work that splits without changing a result (today: writing
 * tensor trees, whose text is the same bytes with any count, laying a rank-3 tree onto a grid
 * as it is read, and a spectral pane's angular table, the same values with any count): 0 (the
 * default) = one per online CPU, up to BST_THREADS_MAX; 1 = none besides the caller's; n > 1 = up
 * to n.  A context with a custom allocator always works on the caller's thread alone.  BST_EINVAL
 * when n < 0. */
#define BST_THREADS_MAX 8
int bst_ctx_set_threads(bst_ctx *ctx, int n);
int bst_ctx_threads(const bst_ctx *ctx);

/* --------------------------- structured matrices: mat.c, mat_mul.c (products), mat_add.c (sums) */

typedef enum {
    BST_ZERO = 0,    /* no storage: every element is 0 */
    BST_DIAG = 1,    /* square, only the diagonal is stored: O(N) */
    BST_SPARSE = 2,  /* compressed sparse column (CHOLMOD), always double */
    BST_DENSE = 3,   /* column-major, double or float */
    BST_FACTORED = 4, /* D + U K V^T: a diagonal and a low-rank part over a coarse map (a tree of
                         depth d read at a finer order is P M_d P^T exactly), double */
    BST_PLUS_LR = 5   /* B + U W^T: a diagonal, sparse or dense B and a part of small rank m, U and
                         W dense (rows x m, cols x m, double): a venetian blind with a mirror part
                         and diffuse slats, its strips' diffuse light of rank 2 x segments */
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

/* A copy in structure s and precision prec; BST_EINVAL when m does not fit DIAG or ZERO. */
int bst_mat_convert(bst_ctx *ctx, const bst_mat *m, bst_structure s, bst_precision prec,
                    bst_mat **out);
/* A copy in the cheapest structure that holds m exactly (sparse up to sparse_max_fill non-zeros). */
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

/* out[j] = sum_i w[i] M(i, j) (w NULL = ones; w = Lambda: directional-hemispherical values). */
int bst_mat_col_weighted_sum(bst_ctx *ctx, const bst_mat *m, const double *w, double *out);
/* Column-major double copy of any matrix into out (rows * cols entries). */
int bst_mat_to_dense_array(bst_ctx *ctx, const bst_mat *m, double *out);
/* The columns cols[0..ncols-1] of m, in m's structure (a diagonal one's come back sparse). */
int bst_mat_select_cols(bst_ctx *ctx, const bst_mat *m, size_t ncols, const size_t *cols,
                        bst_mat **out);
/* 1 when every stored value is finite (0 for NULL). */
int bst_mat_all_finite(const bst_mat *m);
/* Largest magnitude of a stored value (0 for zero matrices, NaN for NULL). */
double bst_mat_max_abs(const bst_mat *m);

/* ------------------------------------------------------------------------------ solves: solve.c */

/* X = (I - A)^-1 B (left) and Y = B (I - A)^-1 (right), I - A factored once.  *rcond (may be
 * NULL): 1 / (max(1, |I - A|_1) |(I - A)^-1|_1), estimated (see solve.c).  BST_WILLCOND (with the
 * result) below rcond_warn (at least sqrt(FLT_EPSILON) in float); BST_ESINGULAR when singular. */
#define BST_RCOND_WARN 1e-8
int bst_solve_left(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double rcond_warn,
                   bst_mat **x, double *rcond);
int bst_solve_right(bst_ctx *ctx, const bst_mat *a, const bst_mat *b, double rcond_warn,
                    bst_mat **y, double *rcond);

/* ------------------------------------------------------------------------------- bases: basis.c */

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
/* Patch of a direction (only dir[0], dir[1] are used; |(x, y)| <= 1, a longer (x, y) taken at
 * the rim).  A direction whose x or y is not finite has none: bst_basis_size(b) is returned, which
 * every function taking a patch refuses (BST_EINVAL). */
size_t bst_basis_patch(const bst_basis *b, const double dir[3]);
/* Centre direction of a patch: unit vector with z >= 0. */
void bst_basis_center(const bst_basis *b, size_t patch, double dir[3]);
/* A direction inside a patch: (u, v) in [0,1)^2 maps uniformly in projected solid angle onto it. */
void bst_basis_sample(const bst_basis *b, size_t patch, double u, double v, double dir[3]);
/* The patch of the point-reflected direction (x, y) -> (-x, -y), for reciprocity. */
size_t bst_basis_antipode(const bst_basis *b, size_t patch);
/* 1 when a and b define the same patches. */
int bst_basis_equal(const bst_basis *a, const bst_basis *b);

/* ------------------------------------------------------------------------------ layers: layer.c */

/* A layer (or a combined stack) is four components per spectral channel over one basis. */
typedef enum { BST_TF = 0, BST_RF = 1, BST_TB = 2, BST_RB = 3 } bst_comp;
#define BST_NCOMP 4
/* "Tf", "Rf", "Tb", "Rb". */
const char *bst_comp_name(bst_comp c);
/* BST_TF.. from "Tf" (case-insensitive); -1 if unknown. */
int bst_comp_parse(const char *name);

typedef struct bst_layer bst_layer;

/* A layer over a copy of basis with the named channels ("Visible", "Solar", ...) and no component. */
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
/* Set (or replace) a component, N x N; the layer owns m from here on, also on failure. */
int bst_layer_set(bst_ctx *ctx, bst_layer *l, size_t channel, bst_comp c, bst_mat *m);
/* Detach a component (the caller owns it; NULL if absent). */
bst_mat *bst_layer_take(bst_layer *l, size_t channel, bst_comp c);
/* Free-form name and description kept with the layer (e.g. the file it came from). */
int bst_layer_set_name(bst_ctx *ctx, bst_layer *l, const char *name);
const char *bst_layer_name(const bst_layer *l);

/* The layer reversed (back side to the exterior): rotated 180 degrees about Y, sides swapped. */
int bst_layer_flip(bst_ctx *ctx, const bst_layer *l, bst_layer **out);

/* out[j] = sum_i Lambda_i M(i, j): directional-hemispherical T or R per incident patch (N values). */
int bst_layer_hemispherical(bst_ctx *ctx, const bst_layer *l, size_t ch, bst_comp c, double *out);

/* ------------------------------------------------------------------ stacks: stack.c, spectral.c */

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
    double flops;           /* floating-point operations of its dense kernels (GEMM, LU, triangular
                               solves, sparse by dense products; LAPACK Working Note 41's counts),
                               O(N^2) element-wise work not counted; see bsdfstack-combine(1) */
    size_t rank;            /* BST_FACTORED: the rank of the low-rank part, else 0 */
    int mirror;             /* 1: a dense factorization of the step was split in two halves by
                               the layers' mirror symmetry about x = 0 (a quarter of its flops;
                               bsdfstack-combine(1)), else 0 */
} bst_stack_step;

typedef struct {
    unsigned comps;         /* requested output components, BST_COMP_BIT mask; default all */
    double drop_tol;        /* sparse fill-in drop tolerance (relative), default 0 = exact */
    double rcond_warn;      /* warn below this reciprocal condition number, default BST_RCOND_WARN */
    double energy_tol;      /* warn when an input's or the system's T + R exceeds 1 + energy_tol
                               for some incident patch (or the system's T or R is below
                               -energy_tol), default BST_ENERGY_TOL */
    int strict;             /* 1: ill-conditioning and energy imbalance are errors, default 0 */
    int force_dense;        /* 1: convert every matrix to dense first and split no solve by
                               mirror symmetry (the baseline), default 0 */
    bst_precision precision;/* precision of dense work, default BST_DOUBLE */
    /* Called after each component of each step (for -v); may be NULL. */
    void (*on_step)(const bst_stack_step *step, void *opaque);
    void *opaque;
} bst_stack_opts;
#define BST_ENERGY_TOL 0.01

void bst_stack_opts_init(bst_stack_opts *opts);
/* Combine n >= 1 layers (exterior first) over their common channels; the highest warning or an error. */
int bst_stack_combine(bst_ctx *ctx, size_t n, const bst_layer *const *layers,
                      const bst_stack_opts *opts, bst_layer **out);
/* The same, freeing each input component after its last use (lower peak, see bsdfstack-combine(1));
 * on return every layers[i] is freed (a layer listed twice once) and NULL. */
int bst_stack_combine_consume(bst_ctx *ctx, size_t n, bst_layer **layers,
                              const bst_stack_opts *opts, bst_layer **out);

/* Per-layer absorptance (Klems 1994, part 2): abs_front[i * N + j] is the share of unit flux from
 * front patch j absorbed by layer i; abs_back from the back (either may be NULL). */
int bst_stack_absorptance(bst_ctx *ctx, size_t n, const bst_layer *const *layers, size_t ch,
                          const bst_stack_opts *opts, double *abs_front, double *abs_back);

/* Columns cols[0..m-1] of the system's Tf and Rf (or Tb and Rb, opts->back; the channel by name, NULL = the
 * first layer's first) as N x m matrices,
 * iterated between the layers without (I - A)^-1 (columns.c); BST_WILLCOND when max_iter sweeps do
 * not bring a sweep's change of flux below tol times the incident flux. */
typedef struct {
    double tol;       /* default BST_COLUMNS_TOL */
    int max_iter;     /* default BST_COLUMNS_MAX_ITER */
    int back;         /* 1: back incidence, tf and rf receive Tb and Rb; default 0 */
    int iterations;   /* out: sweeps made */
    double residual;  /* out: the last sweep's change of flux over the incident flux */
} bst_columns_opts;
#define BST_COLUMNS_TOL 1e-12
#define BST_COLUMNS_TOL_FLOAT 1e-6 /* the tolerance at least, when a layer holds float values */
#define BST_COLUMNS_MAX_ITER 1000
void bst_columns_opts_init(bst_columns_opts *opts);
int bst_stack_columns(bst_ctx *ctx, size_t n, const bst_layer *const *layers, const char *channel,
                      size_t ncols, const size_t *cols, bst_columns_opts *opts, bst_mat **tf,
                      bst_mat **rf);

/* A clear pane (analytic glass, below). */
typedef struct bst_glass bst_glass;

/* One position of a stack combined wavelength by wavelength: a spectral pane, or a layer known only
 * by band values that carries both a "Solar" and a "Visible" channel (a shade from a BSDF file, any
 * basis).  The second enters as WINDOW's dual-band material does: at wavelengths inside
 * [BST_DUAL_BAND_LO, BST_DUAL_BAND_HI] um (inclusive) its Visible matrices, outside them
 * max(0, (Solar - f Visible) / (1 - f)) element by element, f = bst_spectral_opts.dual_f.  Exactly
 * one of the two fields is set. */
typedef struct {
    bst_glass *pane;          /* a pane with spectral data; the first one also gives the bands'
                                 weights, and a requested band it lacks is added to it */
    const bst_layer *bands;   /* a layer with Solar and Visible channels over the stack's basis */
} bst_spectral_layer;

#define BST_DUAL_BAND_F 0.499 /* WCE's share of the solar band taken as visible */
#define BST_DUAL_BAND_LO 0.38 /* um, the visible range of a dual-band material */
#define BST_DUAL_BAND_HI 0.78

typedef struct {
    int at_centre;            /* 1: panes at patch centres (WINDOW's), 0: patch averages; default 0 */
    double dual_f;            /* f of dual-band layers, default BST_DUAL_BAND_F; 0 <= f < 1 */
    double tol;               /* wavelengths are combined once per group, grouped so that the
                                 band-weighted RMS deviation of every pane's normal-incidence
                                 T and R from their group's mean is within tol
                                 (spectral.c); 0: only equal data share a combination, < 0: none
                                 does; default BST_SPECTRAL_TOL */
} bst_spectral_opts;
#define BST_SPECTRAL_TOL 0.004 /* T, R, A within 5.1e-5 of tol 0, see bsdfstack-combine(1) */
void bst_spectral_opts_init(bst_spectral_opts *opts);

/* Layers (exterior first, at least one a spectral pane) combined wavelength by wavelength, then
 * averaged per band channel (Visible, Solar, CIE-X, CIE-Y, CIE-Z) as WINDOW and WCE do (see
 * spectral.c): out has the requested channels; abs_front / abs_back (may be NULL), each
 * nchannels * n * N values, [(c * n + i) * N + j], the share of unit flux from patch j absorbed by
 * layer i, averaged over the band like the matrices.  sopts NULL = defaults.  The groups run on
 * up to one thread a core (spectral.c, up to 1024 patches, not with a custom allocator), OpenBLAS
 * set to one thread meanwhile; opts->on_step may then be called from those threads, one at a time. */
int bst_stack_combine_spectral_layers(bst_ctx *ctx, size_t n, const bst_spectral_layer *layers,
                                      const bst_basis *basis, size_t nchannels,
                                      const char *const *channels, const bst_spectral_opts *sopts,
                                      const bst_stack_opts *opts, bst_layer **out,
                                      double *abs_front, double *abs_back);
/* Columns cols[0..m-1] of such a stack's Tf and Rf (Tb and Rb with copts->back) in one band channel
 * (Visible, Solar, CIE-X, CIE-Y, CIE-Z): each group of wavelengths iterated as bst_stack_columns
 * does (never forming (I - A)^-1), summed with the band's weights as
 * bst_stack_combine_spectral_layers sums the whole system, so that the columns equal that
 * system's to the iteration's tolerance.  copts (may be NULL) out: the most sweeps of any group and
 * the largest last change; BST_WILLCOND when a group did not converge. */
int bst_stack_columns_spectral_layers(bst_ctx *ctx, size_t n, const bst_spectral_layer *layers,
                                      const bst_basis *basis, const char *channel,
                                      const bst_spectral_opts *sopts, size_t ncols,
                                      const size_t *cols, bst_columns_opts *copts, bst_mat **tf,
                                      bst_mat **rf);
/* The same for a stack of spectral panes only (at_centre as in bst_spectral_opts; tol 0: panes
 * alone stay diagonal, O(N) a wavelength, and are not grouped). */
int bst_stack_combine_spectral(bst_ctx *ctx, size_t n, bst_glass *const *panes,
                               const bst_basis *basis, size_t nchannels,
                               const char *const *channels, int at_centre,
                               const bst_stack_opts *opts, bst_layer **out, double *abs_front,
                               double *abs_back);

/* --------------------------------------------------------------------------- metrics: metrics.c */

/* Accordance (%) of column `incident` of component c, channel ch, of a and b (Grobe 2017, with
 * L_i the projected solid angles; see bsdfstack-compare(1)); any of ga, fa, la (N), not all NULL:
 *   GA = 100 (1 - sum L_i (a_i - b_i)^2 / sum L_i (a_i + b_i)^2)     global, eq. 7
 *   LA_i = 100 (1 - |a_i - b_i| / (a_i + b_i)), 100 where both are 0  local, eq. 8
 *   FA = 100 (1 - sum L_i |a_i - b_i| / sum L_i (a_i + b_i))          flux (not the paper's)
 * A negative value (round-off) counts as 0, as bst_bsdf_read reads one; BST_EINVAL for NaN or Inf. */
int bst_metrics_accordance(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch,
                           bst_comp c, size_t incident, double *ga, double *fa, double *la);
/* GA and FA (either may be NULL) for every incident patch: N values each. */
int bst_metrics_accordance_all(bst_ctx *ctx, const bst_layer *a, const bst_layer *b, size_t ch,
                               bst_comp c, double *ga, double *fa);
/* Reciprocity error of the transmissions of channel ch: reciprocity (f(in, out) = f(out, in)) reads
 * Tf(o, i) = Tb(a(i), a(o)) in this header's index convention, a = bst_basis_antipode, with no
 * Lambda weights (a patch and its antipode have the same projected solid angle);
 *   *err = max over (o, i) of |Tf(o, i) - Tb(a(i), a(o))| / max(max|Tf|, max|Tb|)
 * (0 when both are zero; an absent component counts as zero), and the incident and outgoing
 * patch of Tf where that maximum is (either may be NULL).  A transmission derived from the other
 * by reciprocity scores 0; BST_EINVAL for non-finite values. */
int bst_metrics_reciprocity(bst_ctx *ctx, const bst_layer *l, size_t ch, double *err,
                            size_t *incident, size_t *outgoing);

/* -------------------------------------------------- BSDF XML reader: xml.c, ttree.c, resample.c */

/* A BSDF XML file as stored (Klems matrices or tensor trees), read by streaming (SAX). */
typedef struct bst_bsdf bst_bsdf;
typedef enum { BST_FILE_KLEMS = 0, BST_FILE_TT3 = 3, BST_FILE_TT4 = 4 } bst_file_kind;

typedef struct {
    unsigned comps;                /* components to read, BST_COMP_BIT mask; 0 = all */
    size_t nchannels;              /* channels to read (by name); 0 = all */
    const char *const *channels;
    bst_precision precision;       /* of the dense components bst_bsdf_to_layer makes; default
                                      BST_DOUBLE, BST_FLOAT halves their memory */
} bst_bsdf_read_opts;

/* Read a file (opts NULL = defaults); BST_WDATA when it is read other than it states: a missing
 * component completed (a transmission by reciprocity, a reflection as zero), a tree of depth
 * BST_K_MAX + 1 read at BST_K_MAX (deeper ones are refused), negative values read as 0.  A file
 * holds one kind of data (its bst_file_kind): one mixing Klems and tree blocks, or trees of both
 * ranks, is BST_EFORMAT, whichever channels and components opts asks for. */
int bst_bsdf_read(bst_ctx *ctx, const char *path, const bst_bsdf_read_opts *opts, bst_bsdf **out);
void bst_bsdf_free(bst_bsdf *b);
bst_file_kind bst_bsdf_kind(const bst_bsdf *b);
/* Tensor-tree resolution k at which the file is read (its finest cells' depth, at most
 * BST_K_MAX), 0 for Klems files. */
int bst_bsdf_order(const bst_bsdf *b);
/* Depth of the finest tree cells as stored (above the order when averaged), 0 for Klems files. */
int bst_bsdf_depth(const bst_bsdf *b);
/* Share of component c's incident x outgoing domain (as read: stored or by reciprocity) where
 * the file's value is not zero: a rank-4 tree's measured share, 1 for rank-3 trees and Klems
 * matrices (their resampling spreads), 0 for a component taken as zero. */
double bst_bsdf_fill(const bst_bsdf *b, size_t ch, bst_comp c);
/* Negative values in the file, read as 0. */
size_t bst_bsdf_negatives(const bst_bsdf *b);
/* The Klems basis of a Klems file (NULL for trees). */
const bst_basis *bst_bsdf_klems_basis(const bst_bsdf *b);
size_t bst_bsdf_nchannels(const bst_bsdf *b);
const char *bst_bsdf_channel(const bst_bsdf *b, size_t ch);
/* 1 when the file stores the component (0 when it is derived or zero). */
int bst_bsdf_stored(const bst_bsdf *b, size_t ch, bst_comp c);
/* f(in, out) (1/sr) as libBSDF evaluates it (less its 2e-4 perturbation); in towards the source,
 * out along the scattered light, vectors in the file's frame of any finite, non-zero length
 * (normalised here; BST_EINVAL otherwise); the signs of their z pick the component (Tf: in_z < 0
 * < out_z, Tb: out_z < 0 < in_z, Rf: both < 0, Rb: both > 0). */
int bst_bsdf_eval(bst_ctx *ctx, const bst_bsdf *b, size_t ch, const double in[3],
                  const double out[3], double *value);
/* The file's BSDF as a layer over target (NULL: the file's own basis), each component in its
 * cheapest structure, dense ones in the read precision; resampling: bsdfstack-convert(1). */
int bst_bsdf_to_layer(bst_ctx *ctx, const bst_bsdf *b, const bst_basis *target, bst_layer **out);
/* Change the precision of the dense components bst_bsdf_to_layer makes from b (the read option
 * bst_bsdf_read_opts.precision) once the file's kind is known: a rank-4 tree at its own depth
 * (bst_bsdf_depth = bst_bsdf_order) expanded to its own order holds only single-precision values
 * of the file, so BST_FLOAT keeps them exactly in half the memory. */
int bst_bsdf_set_precision(bst_ctx *ctx, bst_bsdf *b, bst_precision prec);
/* How bst_bsdf_to_layer lays a rank-3 (isotropic) tree of depth d on a Shirley-Chiu grid of order
 * k > d.  BST_RANK3_EXACT (the default) samples the tree at order k; BST_RANK3_NATIVE expands it
 * at its own order d and holds each component factored, P M_d P^T (P the prolongation of order-d
 * cells to their order-k cells, issue #31): the cost and memory of order d, at the price of
 * values constant over each pair of order-d cells, a speed-for-accuracy trade measured in
 * bench/README.md ("Rank-3 trees at their own order").  Rank-4 trees and Klems files are not
 * affected (they are factored exactly where they are coarser than the grid). */
typedef enum { BST_RANK3_EXACT = 0, BST_RANK3_NATIVE = 1 } bst_rank3_rule;
int bst_bsdf_set_rank3_rule(bst_ctx *ctx, bst_bsdf *b, bst_rank3_rule rule);
bst_rank3_rule bst_bsdf_rank3_rule(const bst_bsdf *b);

/* ----------------------------------------------------------------------------- plans: plan.c */

/* The decisions a stack's combination takes, made here for every client (the program's combine,
 * batch and MPI ranks, Python), each with a sentence saying why.
 *
 * The basis when none is asked: the finest tensor-tree order among the files (at most
 * BST_K_MAX; a finer one only repeats their values), else the first Klems file's Klems basis,
 * else the basis of the first layer given over one (a system already combined, say), else
 * Shirley-Chiu k = 5.  files[i] is layer i's file or NULL (a pane; either array may be NULL),
 * given[i] the basis of a layer given over one, or NULL.  k > 0 or klems ("full", "half",
 * "quarter") is the basis asked.  The pick names the basis so that another process (an MPI rank)
 * makes the same one with bst_plan_make_basis (from the same n files and given bases; a pick
 * naming a layer that is not among them is refused). */
typedef struct {
    int k;                  /* Shirley-Chiu order, 0 when not this */
    const char *klems;      /* Klems basis name, or NULL */
    long file;              /* the Klems file whose basis it is, -1 when not this */
    long given;             /* the layer given over it, -1 when not this */
    int finest;             /* the finest tree order among the files (0: none) */
    char why[160];          /* which rule chose */
    char note[320];         /* a warning worth printing before a combination, or "": every layer
                               a rank-4 tree of an order below the k asked (their order's system
                               repeated, written as that order's trees) */
} bst_plan_basis;
void bst_plan_pick_basis(size_t n, const bst_bsdf *const *files, const bst_basis *const *given,
                         int k, const char *klems, bst_plan_basis *pick);
int bst_plan_make_basis(bst_ctx *ctx, const bst_plan_basis *pick, size_t n,
                        const bst_bsdf *const *files, const bst_basis *const *given, bst_basis **out);

/* The channels every layer holds, in layer 0's order, into names (room for layer 0's count): how
 * many.  The names are the layers'. */
size_t bst_plan_channels(size_t n, const bst_layer *const *layers, const char **names);
/* 1 for a channel the per-wavelength combination averages over: Visible, Solar, CIE-X, CIE-Y,
 * CIE-Z (any case). */
int bst_plan_is_band(const char *name);

/* A stack's layer as the spectral plan sees it: the layer over the stack's basis, the spectral
 * pane it was made from (NULL: not a pane with spectral data, or reversed), and whether it was
 * read from a file (one with Solar and Visible channels enters as WINDOW's dual-band material). */
typedef struct {
    const bst_layer *layer;
    const bst_glass *pane;
    int from_file;
} bst_plan_layer;
/* *spectral = 1 when the stack combines wavelength by wavelength (bst_stack_combine_spectral_layers:
 * every layer a spectral pane or dual-band, every common channel a band, not per_channel), 0 when
 * it combines band values per channel (bst_stack_combine); why (size bytes) says which and why,
 * and which layers enter as dual-band; *warn (may be NULL) is 1 where the reason is one a user
 * would not expect (a file layer with Solar but not Visible: --channels Solar).  BST_OK or an
 * error. */
int bst_plan_spectral(bst_ctx *ctx, size_t n, const bst_plan_layer *layers, int per_channel,
                      char *why, size_t size, int *spectral, int *warn);

/* The work of a stack's steps, as the combination meets them: step i (i = 1..n-1) combines the
 * system of layers 1..i with layer i + 1 (structure[j]: layer j's widest component, as loaded);
 * the partial system takes the widest structure so far (products keep a dense operand dense).
 * A step costs about N values of that structure per value: N for diagonal, N^2 for sparse (fill-in
 * at most dense), N^3 for dense (factorization, solves and products: -v's GFLOP counts about 9 N^3
 * a channel for a pane and a dense layer), none for zero.  work (may be NULL) gets step i's
 * estimate at work[i - 1]; returns their sum.  An order of work, not a time: bsdfstack-mpi hands
 * out the costliest stacks first by it. */
double bst_plan_work(size_t n, const bst_structure *structure, size_t N, double *work);

/* Bytes a command needs at its peak, by the model bench/README.md checks against measured peaks:
 * a component a file's layer holds is dense (N^2 values of the read precision) unless the file's
 * values fill at most BST_SPARSE_MAX_FILL of its domain (specular trees: sparse, 16 bytes a
 * value); on top of them a conversion needs one double grid, a combination (combining)
 * 3 N^2 values of the work precision, whichever is more; a rank-4 tree of depth d below the
 * Shirley-Chiu order asked is held factored (BST_FACTORED; so is a rank-3 one under
 * BST_RANK3_NATIVE): its 4^d x 4^d doubles, and a combination of such layers alone three of the
 * largest, and the tree writer one N^2 grid of doubles (it expands a factored component, one at
 * a time, to write it); for the rest (the program, its libraries, diagonal and sparse parts)
 * 64 MiB and N^2 / 2 bytes.  comps: the components read
 * (BST_COMP_BIT mask, 0 = all); *ndense (may be NULL): the dense components counted. */
double bst_plan_memory(const bst_basis *basis, size_t n, const bst_bsdf *const *files,
                       unsigned comps, bst_precision read, int combining, bst_precision work,
                       size_t *ndense);
/* A layer as the model sees it before it is made: read from `file` (as above), or made from a
 * spec (file NULL): what it will hold, all channels together, as bst_shade_model_plan tells (a
 * pane: all zero, its components diagonal). */
typedef struct {
    const bst_bsdf *file; /* the file it is read from, or NULL: made */
    size_t nchannels;     /* made: its channels (0: not known, a pane) */
    size_t dense;         /* made: components held dense, N x N values of `precision` each */
    size_t factored;      /* made: components held factored over a wide map (mat.h: a venetian
                             blind's strips), the diagonal and width x width values each */
    size_t width;         /* made: that map's columns (every row holds at most that many) */
    bst_precision precision; /* made: the dense components' (bst_venetian's precision) */
    size_t plus;          /* made: components held sparse plus low rank (BST_PLUS_LR: a venetian
                             blind with a mirror part and diffuse slats), counted as sparse */
} bst_plan_held;
/* What the need counts beyond the base, for a message. */
typedef struct {
    size_t dense;          /* N x N components the layers hold dense */
    double dense_bytes;    /* their bytes: files' in the read precision, made layers' in double */
    size_t expanded;       /* components expanded at once from factored ones over wide maps:
                              1, the writer's grid (0 where a layer is dense) */
    double expanded_bytes; /* its bytes: N^2 doubles */
} bst_plan_need;
/* bst_plan_memory over layers some of which are made from specs: their dense components count
 * as a file's, in double; their factored ones count their own size (the diagonal, width x width
 * values and the map's N x width entries of 16 bytes, once a channel), and where no layer holds
 * a dense component, the writer's one N^2 grid of doubles (it expands a factored component at a
 * time, a combination's results staying factored) and 64 MiB of column blocks (the readers of
 * such components).  A made layer held sparse (a mirror blind, black slats) or sparse plus low
 * rank in a combination of three or more layers counts the results dense from its second step
 * on: four N^2 of the work precision a channel, one N^2 more of work and a quarter of N^2 doubles
 * of sparse partial stack; otherwise its sparse parts and those of the results formed from it
 * count a quarter of N^2 doubles a channel, and sparse plus low-rank components (written as
 * factored ones are) the writer's grid and column blocks.
 * Not counted: a wavelength-by-wavelength combination's per-channel sums (bst_plan_spectral).
 * comps selects the components read from files; *need (may be NULL) gets what was counted. */
double bst_plan_memory_held(const bst_basis *basis, size_t n, const bst_plan_held *layers,
                            unsigned comps, bst_precision read, int combining, bst_precision work,
                            bst_plan_need *need);

/* --------------------------- BSDF XML writer: xml_write.c, ttree_write.c, ttree_rank3.c, sink.c */

/* A layer as LBNL WindowElement BSDF XML (libBSDF, WINDOW, EnergyPlus): Klems matrices on a Klems
 * basis, else a RADIANCE tensor tree of order k, TensorTree3 when isotropic, reduced by a
 * variation criterion as genBSDF's rttree_reduce, bounded so that every incident patch's
 * directional-hemispherical T and R stay within reduce_tol of the layer's (xml_write.c,
 * ttree_write.c, write_bound.h; figures in bsdfstack-convert(1)).  No conversion at
 * the boundary: our front is the XML "Front".  A component absent from the layer is left out
 * (write a zero matrix to state zero), and so is a tree transmission reciprocal to the other's. */
typedef enum { BST_RANK_AUTO = 0, BST_RANK_3 = 3, BST_RANK_4 = 4 } bst_tree_rank;

/* Culling percentile (genBSDF's rttree_reduce -t 90). */
#define BST_REDUCE_PCT 90.0
/* Offset of sqrt(mean) in the variation measure (sqrt(1/sr)), as rttree_reduce. */
#define BST_REDUCE_FLOOR 0.03
/* Largest change a reduction may make to any incident patch's directional-hemispherical T or R
 * (and to T + R above the layer's largest on that side). */
#define BST_REDUCE_TOL 0.002
/* Significant digits of a reduced tree's values: each within 5e-5 of itself (rttree_reduce writes
 * seven decimals below 10, four digits above); the bound counts their rounding too. */
#define BST_REDUCE_DIGITS 5
#define BST_DIGITS_AUTO (-1)
/* TensorTree3 only when every incident patch keeps this flux accordance FA (%) in rank 3. */
#define BST_ISO_FA_MIN 99.0
/* A tree transmission is left out when bst_metrics_reciprocity's error is <= recip_tol. */
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
    /* Appended (libtool 7:0:0 continued): */
    double iso_hemi;        /* rank 3: the largest change of a directional-hemispherical value
                               between the component and its rank-3 form as read back (the step
                               iso_fa measures; the tree's own error, hemi_error, comes on top);
                               NaN otherwise (rank 4, or copied from a rank-3 file) */
    double recip_error;     /* rank 4, a transmission whose other side is left out as its
                               reciprocal: the largest change of the left-out one's directional-
                               hemispherical value as a reader rebuilds it (this block's sums over
                               incidence); NaN otherwise */
} bst_bsdf_write_block;

/* Output callback: write len bytes, return 0 on success. */
typedef int (*bst_bsdf_write_sink)(const char *buf, size_t len, void *opaque);

typedef struct {
    bst_tree_rank rank;     /* trees: AUTO (default), or force rank 3 or 4; a forced rank 3 whose
                               rank-3 form moves a directional-hemispherical value by more than
                               reduce_tol (BST_REDUCE_TOL when INFINITY) is written, and the write
                               returns BST_WACCURACY with the largest change in the message */
    double reduce_pct;      /* trees: culling percentile in [0, 100); < 0 = no reduction;
                               default BST_REDUCE_PCT */
    double reduce_floor;    /* default BST_REDUCE_FLOOR */
    double reduce_tol;      /* trees: >= 0, default BST_REDUCE_TOL; INFINITY: the percentile alone
                               (rttree_reduce's rule, which may change hemispherical values) */
    int digits;             /* significant digits of every value; 0 = as many as needed to read
                               back exactly (float for trees, double for Klems); BST_DIGITS_AUTO
                               (default): 0, but in a reduced tree BST_REDUCE_DIGITS, or more where
                               a tight reduce_tol needs them.  A reduced tree under reduce_tol keeps
                               its promise with any digits asked: where rounding to them alone
                               could move a directional-hemispherical value beyond its budget, the
                               write fails (BST_EINVAL, nothing written) naming the fewest digits
                               that keep it.  Elsewhere (Klems, no reduction, reduce_tol INFINITY)
                               digits > 0 are written as asked, and the write returns
                               BST_WACCURACY where they moved a directional-hemispherical value
                               (measured as written) by more than reduce_tol (BST_REDUCE_TOL when
                               INFINITY) */
    double iso_fa_min;      /* default BST_ISO_FA_MIN */
    double recip_tol;       /* default BST_RECIP_TOL; < 0 always writes both transmissions */
    int iso_refine;         /* rank 3 built from the layer: corrections of the rank-3 tensor
                               towards the layer (each costs about one isotropy check), default
                               BST_ISO_REFINE */
    /* The file the layer was read from (may be NULL): rank-3 trees of its order are copied from
     * it instead of being rebuilt from the layer. */
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

/* Write layer (opts NULL = defaults) to a stream, a callback or a file; _path writes through
 * bst_output (below): the file appears only on success (BST_WACCURACY is a success: the file is
 * written as asked, the message says what it moved).  Memory: bsdfstack-convert(1). */
int bst_bsdf_write(bst_ctx *ctx, const bst_layer *layer, FILE *fp, const bst_bsdf_write_opts *opts);
int bst_bsdf_write_fn(bst_ctx *ctx, const bst_layer *layer, bst_bsdf_write_sink fn, void *opaque,
                      const bst_bsdf_write_opts *opts);
int bst_bsdf_write_path(bst_ctx *ctx, const bst_layer *layer, const char *path,
                        const bst_bsdf_write_opts *opts);

/* Variable resolution (issue 19): a system known at a coarse order kc for every incident patch
 * (the layer `coarse`) and at a finer order k for a few front-incidence patches (their Tf and Rf
 * columns, e.g. bst_stack_columns' at the sun positions of a year), written as ONE rank-4 tensor
 * tree per block whose depth varies (ttree_write.c): inside an incident cell of order k that is
 * one of `cols`, the tree goes down to order k in every dimension; everywhere else it stops at kc
 * (and reduction may merge further).  Read at order k, the file gives the fine columns exactly
 * (to single precision) and every other incident patch the value of the coarse cell holding it.
 * Tb and Rb stay at order kc.  Consistency of the two parts: both come from the same layers by the
 * same formula, the fine ones at order k; bst_varres_hemi_diff measures, per fine patch, the
 * directional-hemispherical T or R of its column minus that of the coarse cell holding it (the
 * coarse cell averages a region of incidences, so they differ by the variation of T and R over
 * it plus the resolution error; a stack of panes and a blind at k = 6 over kc = 4: see
 * bsdfstack-combine(1)).  opts as bst_bsdf_write (rank AUTO or 4; the culling percentile is taken
 * over the finest blocks inside the fine incident cells); reciprocity never omits a block. */
#define BST_VARRES_HEMI_TOL 0.02 /* |difference| a consistency check (the CLI's) accepts */
typedef struct {
    int k;                     /* fine order, kc < k <= BST_K_MAX */
    size_t ncols;              /* fine incident patches (Shirley-Chiu order k), increasing */
    const size_t *cols;
    const bst_mat *const *tf;  /* per channel of coarse: 4^k x ncols, the system's Tf columns at
                                  cols; tf NULL or tf[ch] NULL: the coarse values there too */
    const bst_mat *const *rf;  /* the same for Rf */
} bst_varres;
int bst_bsdf_write_varres(bst_ctx *ctx, const bst_layer *coarse, const bst_varres *v, FILE *fp,
                          const bst_bsdf_write_opts *opts);
int bst_bsdf_write_varres_path(bst_ctx *ctx, const bst_layer *coarse, const bst_varres *v,
                               const char *path, const bst_bsdf_write_opts *opts);
/* diff[q] = hemispherical value of fine column q of component c (BST_TF or BST_RF) minus that of
 * coarse's incident patch holding it (ncols values); *worst (may be NULL) the largest |diff|. */
int bst_varres_hemi_diff(bst_ctx *ctx, const bst_layer *coarse, const bst_varres *v, size_t ch,
                         bst_comp c, double *diff, double *worst);

/* ------------------------------------------------------------------ output files: output.c */

/* A file that appears whole or not at all, written as what its path names demands: a regular
 * file (or none yet) through a temporary beside it, renamed over it by commit, keeping an existing
 * file's mode (and owner, where allowed); a symbolic link's final target the same way, the links
 * kept; a device, FIFO or socket directly; a directory is an error.  Write to bst_output_file;
 * commit flushes, closes and renames (an error names the path and the reason), abort removes the
 * temporary; both free the object (NULL-safe). */
typedef struct bst_output bst_output;
int bst_output_open(bst_ctx *ctx, const char *path, bst_output **out);
FILE *bst_output_file(const bst_output *o);
const char *bst_output_path(const bst_output *o);
/* Flush and check for a write error so far (the object stays open). */
int bst_output_flush(bst_output *o);
/* Which file path writes, as a key (text, into key[0..size-1]; BST_OUTPUT_KEY_MAX is enough for a
 * name of up to 255 bytes): two paths with one key write one file, however they are spelt (a.xml,
 * ./a.xml, d/../a.xml, a symbolic link or hard link to it).  An existing file is known by its
 * device and inode, through any links; a file not there yet by those of the directory it will be
 * created in, and its name.  BST_EIO (no key) when neither can be found (a missing directory, no
 * permission): opening the path would then fail too. */
#define BST_OUTPUT_KEY_MAX 320
int bst_output_key(bst_ctx *ctx, const char *path, char *key, size_t size);
/* The temporary o writes (renamed over the file by commit, removed by abort), NULL when o writes
 * its path directly: for a program's signal handler, which may remove it (unlink) and die. */
const char *bst_output_temporary(const bst_output *o);
/* Remove the temporaries that writers of paths[0..n-1] left behind, killed before they committed
 * or aborted: PATH.tmpXXXXXX beside the file each path's links lead to, when no writer holds it
 * (a writer locks its temporary, flock, from creation to rename).  Each directory is read once.
 * *removed (may be NULL): how many.  Paths that name nothing to look into are passed over. */
int bst_output_clean(bst_ctx *ctx, size_t n, const char *const *paths, size_t *removed);
int bst_output_commit(bst_output *o);
void bst_output_abort(bst_output *o);

/* ------------------- analytic glass: glass.c, glass_spec.c (specs), glass_band.c, glass_layer.c,
 *                     glass_coated.c (coated model), glass_optics.c and glass_json.c (files) */

/* A pane fixed per side and channel by its normal-incidence T0 and R0, whose angular behaviour
 * follows Windows-CalcEngine's model for uncoated glass or WINDOW's for coated glass (below);
 * specs ("glass:SPEC"), files and the models: bsdfstack-glass(5).
 * (bst_glass is declared with the stacks, for bst_stack_combine_spectral.) */
/* The catalogue directory used when none is given: the installed one, or the source tree's
 * layers/glass when this library runs from its build tree (not installed). */
const char *bst_glass_catalogue_dir(void);
/* Parse a spec; catalogue_dir NULL = bst_glass_catalogue_dir(). */
int bst_glass_parse(bst_ctx *ctx, const char *spec, const char *catalogue_dir, bst_glass **out);
/* The same for a caller that knows the channels it will take: spectral data named without bands
 * (glass:FILE, or a catalogue's "spectral FILE" line) are averaged over those of
 * channels[0..nchannels) that are spectral bands (Visible, Solar, CIE-X, CIE-Y, CIE-Z) instead
 * of Visible and Solar, so that data covering only the visible serve a Visible-only stack.  With
 * no band among the channels, as bst_glass_parse. */
int bst_glass_parse_bands(bst_ctx *ctx, const char *spec, const char *catalogue_dir,
                          size_t nchannels, const char *const *channels, bst_glass **out);
void bst_glass_free(bst_glass *g);
size_t bst_glass_nchannels(const bst_glass *g);
const char *bst_glass_channel(const bst_glass *g, size_t ch);
/* Index of a channel by name (case-insensitive), -1 if none. */
int bst_glass_find_channel(const bst_glass *g, const char *name);
const char *bst_glass_description(const bst_glass *g);
/* Tf, Tb, Rf, Rb (any may be NULL) of channel ch at incidence theta (radians, 0..pi/2). */
int bst_glass_optics(const bst_glass *g, size_t ch, double theta, double *tf, double *tb,
                     double *rf, double *rb);
/* Refractive index and internal transmittance tau0 of a side (spectral pane: at lambda_um). */
int bst_glass_slab(const bst_glass *g, size_t ch, double lambda_um, int back, double *n,
                   double *tau0);

/* Spectral panes: the measured wavelengths (um; none without spectral data) and the optics at
 * any wavelength (data interpolated linearly, constant outside). */
size_t bst_glass_nwavelengths(const bst_glass *g);
double bst_glass_wavelength(const bst_glass *g, size_t i);
int bst_glass_optics_spectral(const bst_glass *g, double lambda_um, double theta, double *tf,
                              double *tb, double *rf, double *rb);
/* A layer of a spectral pane sums the model over a channel's wavelengths at every angle it
 * averages (up to 9001 angles per channel): a file of 10^5 rows was 9 10^8 evaluations.  Past
 * BST_GLASS_LAYER_ROWS wavelengths of weight in a channel, its layer sums over that many groups of
 * adjacent wavelengths instead, each evaluated at its weighted mean data (as combining per
 * wavelength evaluates a group); up to it, every wavelength as before.  The change this makes to a
 * layer's patch values and its cost: bsdfstack-glass(5).  bst_glass_set_layer_rows changes the
 * bound (0: every wavelength, whatever the cost; 1 is refused); bst_glass_layer_nodes tells how
 * many nodes a layer of channel ch sums (*rows: the wavelengths of weight, may be NULL). */
#define BST_GLASS_LAYER_ROWS 5000
int bst_glass_set_layer_rows(bst_ctx *ctx, bst_glass *g, size_t max);
size_t bst_glass_layer_nodes(const bst_glass *g, size_t ch, size_t *rows);
/* Add a band channel (Visible, Solar, CIE-X, CIE-Y, CIE-Z) to a spectral pane (see glass_band.c);
 * BST_EFORMAT, the pane unchanged, when its data do not reach both ends of the band (1e-6 um). */
int bst_glass_add_channel(bst_ctx *ctx, bst_glass *g, const char *name);
/* The integration grid (um) of a band channel, NULL for other channels. */
const double *bst_glass_channel_grid(const bst_glass *g, size_t ch, size_t *n);
/* Weights w (summing to 1) with sum_k w[k] P(wl[k]) = channel ch's average of P known at wl (um). */
int bst_glass_channel_weights(bst_ctx *ctx, const bst_glass *g, size_t ch, size_t n,
                              const double *wl, double *w);

/* The pane as a layer of four diagonal components whose Lambda-weighted values are the patches'
 * T and R: averaged over the patch (at_centre = 0, the default) or at its centre (WINDOW's, WCE's);
 * channels NULL = all.  Figures: bsdfstack-glass(5). */
int bst_glass_layer(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, size_t nchannels,
                    const char *const *channels, int at_centre, bst_layer **out);
/* Parse and build in one step ("glass:SPEC" layers; a requested band a spectral pane lacks added). */
int bst_glass_layer_from_spec(bst_ctx *ctx, const char *spec, const char *catalogue_dir,
                              const bst_basis *basis, size_t nchannels,
                              const char *const *channels, bst_layer **out);

/* A spectral pane at one wavelength (um) as a one-channel layer ("Spectral"). */
int bst_glass_layer_at(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, double lambda_um,
                       int at_centre, bst_layer **out);

/* The angular model of a pane's sides (bsdfstack-glass(5), MODEL): the uncoated slab (glass.c) or
 * WINDOW's correlations for coated glass, laminates and films (glass_coated.c).  A pane read from a
 * file that names its material type takes the model WINDOW takes for that type
 * (bst_glass_model_for_type); "model=" in the spec or bst_glass_set_model overrides it. */
typedef enum { BST_GLASS_UNCOATED = 0, BST_GLASS_COATED = 1 } bst_glass_model;
/* The coated model follows its "clear" reference glass where a side's normal-incidence T0 exceeds
 * this, else its "bronze" one (WINDOW's switch, a fixed part of the model). */
#define BST_GLASS_COATED_CLEAR_T0 0.645
bst_glass_model bst_glass_get_model(const bst_glass *g);
int bst_glass_set_model(bst_ctx *ctx, bst_glass *g, bst_glass_model model);
/* The model WINDOW takes for a material type (Monolithic, Interlayer: uncoated; Coated, Film,
 * Applied Film, Laminate, Electrochromic, Thermochromic: coated; case, blanks, '-' and '_' are not
 * significant): 0 and *model set, or BST_ENOTFOUND for a type it does not know. */
int bst_glass_model_for_type(const char *type, bst_glass_model *model);
/* Model names as specs write them ("uncoated", "coated"). */
const char *bst_glass_model_name(bst_glass_model model);

/* Where a pane comes from and what its file says of it.  Strings are "" and numbers NaN (nfrc_id
 * -1) where the source gives nothing; all are owned by the pane.  Thickness in millimetres,
 * conductivity in W/(m K); emissivities and IR transmittance are kept for the record, not used. */
typedef struct {
    const char *source;       /* "catalogue", "table" (bsdfstack's spectral TSV), "optics" (Optics /
                                 IGDB text file), "igsdb" (IGSDB JSON record) or "inline" */
    const char *path;         /* the file read (catalogue: the .glass file), "" inline */
    const char *type;         /* material type as the source names it ("" none) */
    const char *model_from;   /* why the pane has its model: "type", "spec" (model=), "catalogue"
                                 (a model line), "set" (bst_glass_set_model) or "default" */
    const char *product_name, *manufacturer, *coating_name, *coated_side;
    const char *wavelength_units; /* as the file declares them ("" none: micrometres) */
    long nfrc_id;
    double thickness_mm, conductivity, emissivity_front, emissivity_back, ir_transmittance;
} bst_glass_meta;
const bst_glass_meta *bst_glass_metadata(const bst_glass *g);

/* ------------------------------------------------------ IGSDB shading products: glass_json.c */

/* A shading product of the International Glazing and Shading Database (an IGSDB JSON record of
 * type "shading"): its material and its geometry, read and validated, for a geometric shade model
 * to turn into a layer (bst_shade_model_of below; "shade:FILE" specs).  glass: specs refuse these
 * records (BST_EINVAL, naming shade:FILE).  Lengths in millimetres, angles in degrees, wavelengths
 * in micrometres.  IGSDB v1 field names are given beside each member. */
typedef enum { BST_SHADE_VENETIAN, BST_SHADE_WOVEN, BST_SHADE_PERFORATED } bst_shade_kind;
typedef enum { BST_PERFORATION_CIRCULAR, BST_PERFORATION_RECTANGULAR,
               BST_PERFORATION_SQUARE } bst_perforation;
/* Normal-incidence values of one band: {Tf, Tb, Rf, Rb}; NaN where the record gives none. */
typedef struct {
    double specular[4], diffuse[4];
} bst_shade_band;
typedef struct {
    bst_ctx *ctx;                   /* the context that allocated it (bst_shade_free) */
    char *name, *manufacturer;      /* name, manufacturer_name */
    long product_id;                /* product_id */
    bst_shade_kind kind;            /* subtype: venetian, woven, perforated-screen */
    double permeability;            /* measured_data.permeability_factor (openness), NaN none */
    struct {                        /* composition[0].child_product */
        char *name;
        double thickness_mm, conductivity, emissivity_front, emissivity_back, ir_transmittance;
        size_t n;                   /* spectral_data.spectral_data rows (0: none) */
        double *wl, *tf, *tb, *rf, *rb; /* T (both sides), Rf, Rb per wavelength */
        int has_dual_band;          /* spectral_data.dual_band_values present */
        bst_shade_band solar, visible; /* *_sol_*, *_vis_* */
    } material;
    union {                         /* composition[0].extra_data.geometry */
        struct {
            double slat_width, slat_spacing; /* slat_width, slat_spacing (> 0) */
            double slat_curvature;           /* slat_curvature: radius, 0 = flat (else >= width/2) */
            double slat_tilt;                /* slat_tilt, -90..90 */
            int number_segments;             /* number_segments (>= 1) */
        } venetian;
        struct {
            double thread_diameter, thread_spacing, shade_thickness; /* diameter <= spacing */
        } woven;
        struct {
            bst_perforation type;            /* perforation_type */
            double spacing_x, spacing_y;     /* spacing_x, spacing_y */
            double dimension_x, dimension_y; /* Circular: dimension_x is the hole's RADIUS (as
                                                LBNL's WinCalc hands it to Windows-CalcEngine);
                                                Square: dimension_x is the side */
        } perforated;
    } geometry;
    char *path;                     /* the file read */
} bst_shade;
/* Read one IGSDB v1 shading record (a JSON file); every error names the file and the field. */
int bst_shade_read_igsdb(bst_ctx *ctx, const char *path, bst_shade **out);
void bst_shade_free(bst_shade *s);
/* "venetian", "woven", "perforated-screen". */
const char *bst_shade_kind_name(bst_shade_kind kind);

/* ------------------------------ venetian blinds: venetian_spec.c, venetian_trace.c, venetian_layer.c */

/* A venetian blind from its geometry (bsdfstack-glass(5), "venetian:" specs).  Slats of zero
 * thickness, flat or circular arcs, infinitely long along X (a vertical blind: along Y), stacked
 * every `spacing` along Y (X).  The tilt is the slat's angle about its long axis: a slat's profile runs from its
 * exterior edge to its interior edge along (0, sin tilt, cos tilt) in (x, y, z), so tilt 0 holds
 * the slats horizontal (normal +-Y, the reference blind L_blind0) and a POSITIVE tilt puts the
 * exterior edge LOWER than the interior edge (the reference blind L_blind45 is tilt = +45); a
 * vertical blind takes X for Y (positive tilt: the exterior edge towards -X).  Each slat face
 * reflects rs specularly (a mirror in the slat's plane; `roughness`, RADIANCE metal's rms slope,
 * turns its facets as Ward's Gaussian lobe) and r_up / r_down diffusely (the face looking +Y at
 * tilt 0, +X for a vertical blind, and the other), and transmits t diffusely.  The layer's
 * unobstructed and mirrored light is followed exactly in the blind's profile plane (the X
 * component of a direction survives every reflection) and averaged over each incident patch by
 * samples^2 directions (a Halton set; a rough slat draws its facets from the same points); the
 * light the slats scatter diffusely is a radiosity exchange between `segments` strips per slat
 * face (the diffuse part has rank 2 segments at most).  A curved slat (curvature R > 0) is the arc
 * of radius R whose chord is the flat slat of the same tilt (width = the chord), bowed towards
 * r_up's side: convex upward, the crown towards +Y (the sky) at tilt 0 as real blinds and WINDOW's
 * positive slat curvature (IGSDB slat_curvature), turning with the tilt; r_up is its convex face.
 * Its light is followed in the whole periodic array of arcs (mirrored about the arc's normal where
 * it meets one), N^2 directions a patch each from 8 positions across the slat's shadow, the
 * unobstructed share exact; its strips (equal arc lengths) exchange light traced from the arcs,
 * not their chords. */
typedef struct {
    double width, spacing;  /* m, > 0 */
    double tilt;            /* degrees, -90..90 */
    double curvature;       /* m, 0 = flat; else the arc's radius, >= width / 2 (crown +Y at tilt 0) */
    int vertical;           /* slats along Y */
    int segments;           /* strips per slat face for the radiosity, default BST_VENETIAN_SEGMENTS */
    int samples;            /* samples^2 directions per patch; 0 (default): BST_VENETIAN_SAMPLES
                             * at k <= 6 and in Klems bases, half of it at k = 7 */
    double r_up, r_down, t; /* diffuse reflectances of the two faces, diffuse transmittance */
    double rs, roughness;   /* specular reflectance, rms slope of its lobe (0: a mirror) */
    double solar[4];        /* r_up, r_down, t, rs of a channel named Solar (dual-band slats, spec
                             * values "VISIBLE/SOLAR"); NaN (default): the values above */
    int rule;               /* BST_VENETIAN_AVERAGE (default, the model above) or
                             * BST_VENETIAN_CENTRE: WINDOW's model (venetian_wce.c) */
    int distribution;       /* BST_VENETIAN_CENTRE only: BST_VENETIAN_DIRECTIONAL (default)
                             * or BST_VENETIAN_UNIFORM */
    bst_precision precision;/* of the dense components (diffuse slats with a mirror part, or
                             * WINDOW's model): BST_DOUBLE (default), or BST_FLOAT, each converted
                             * as it is made, so that a dense blind holds half the memory (k = 7:
                             * 1 GiB a component); factored and sparse ones stay double.  Not a
                             * spec key: the program sets it to its --precision. */
} bst_venetian;
#define BST_VENETIAN_SEGMENTS 8
#define BST_VENETIAN_SAMPLES 32
/* WINDOW's venetian model (rule=centre), as Windows-CalcEngine (v1.0.75) computes it, so that a
 * Klems-type basis gets WINDOW's numbers: flat diffuse slats (r_up, r_down, t; rs = 0) split into
 * `segments` strips per slat (5 when a spec gives rule=centre without segments=), every patch
 * evaluated at its centre direction only (a ring of one patch at azimuth 180, as WCE).  Light entering a channel lands on the strips (exact
 * shares), the strips exchange it by crossed-strings view factors, and what leaves is spread:
 * UNIFORM, each incident patch's scattered flux by 1/pi over every outgoing patch; DIRECTIONAL,
 * by the radiance of the strips seen from each outgoing patch's centre (WCE solves the strips'
 * exchange for their exitance as (I - F^T E)^-1 E b, F the view factors, E the strips' r and t,
 * b the first arrivals: the radiosity, and reciprocal, only for E = r I, i.e. t = 0 and
 * r_up = r_down).  The unobstructed share of the centre direction goes on the diagonal over
 * Lambda.  Neither distribution conserves energy exactly with lossless slats but the uniform one
 * (directional: T + R off 1 by up to 0.06 in Klems full for r = 0.8, t = 0.2).  With dual-band
 * slats the Solar channel is WCE's dual-band rule applied to the slats: BST_DUAL_BAND_F times the
 * layer of the visible values plus 1 - BST_DUAL_BAND_F times that of (solar - f visible) / (1 - f)
 * (at least 0; r + t of these above 1 is refused), so that a spectral stack's dual-band rule
 * gives WCE's per-wavelength layers.  A vertical blind is turned in both
 * distributions (WCE v1.0.75 turns it only in the uniform one); |tilt| is held below 89.99999 as
 * WCE holds it. */
enum { BST_VENETIAN_AVERAGE = 0, BST_VENETIAN_CENTRE = 1 };
enum { BST_VENETIAN_DIRECTIONAL = 0, BST_VENETIAN_UNIFORM = 1 };
#define BST_VENETIAN_WCE_SEGMENTS 5
/* The defaults: no geometry (width = spacing = NaN), tilt 0, flat, black slats. */
void bst_venetian_init(bst_venetian *v);
/* Parse "width=16mm,spacing=14.5mm,tilt=45,rs=0.765,r=0.085,..." (the text after "venetian:")
 * into v (initialised here) and check it; every error names the key.  rule=centre without
 * segments= sets segments = BST_VENETIAN_WCE_SEGMENTS (a struct filled by hand sets its own). */
int bst_venetian_parse(bst_ctx *ctx, const char *spec, bst_venetian *v);
/* The checks bst_venetian_parse makes, for a struct filled by hand. */
int bst_venetian_check(bst_ctx *ctx, const bst_venetian *v);
/* The key=value items of spec applied to v as it is (a record's blind, bst_shade_model_of), then
 * checked: each key replaces what v had (a plain r, r-up, r-down, t or rs its Solar value too). */
int bst_venetian_update(bst_ctx *ctx, const char *spec, bst_venetian *v);
/* The blind as a layer over basis with the channels named (nchannels 0: "Visible" and "Solar"):
 * Solar from the solar values where given, every other channel from the others. */
int bst_venetian_layer(bst_ctx *ctx, const bst_venetian *v, const bst_basis *basis,
                       size_t nchannels, const char *const *channels, bst_layer **out);

/* ------------------------------------------------------------ perforated screens: perforated.c */

/* A perforated screen from its geometry ("perforated:" specs, bsdfstack-glass(5)): a sheet of
 * thickness `thickness` with holes on a rectangular grid, pitch x along X (phi = 0) and y along Y,
 * each a circle of radius `radius` or a hole-x by hole-y rectangle, straight through the sheet.
 * Light passes undeviated where a hole lets it through (the overlap of the hole's two ends seen
 * along the direction: exact for every direction, averaged over each patch by samples^2
 * directions); the rest meets the sheet and is reflected (rf from the front, rb from the back) and
 * transmitted (t) diffusely, spread over the outgoing patches in proportion to their closed share
 * so that the layer is reciprocal: R(o, i) = r (1 - F_i)(1 - F_o) / (pi (1 - F)), F_i the open
 * share of patch i, F its hemispherical mean.  Lengths in m. */
typedef struct {
    double x, y;              /* hole pitch along X and Y (> 0) */
    double thickness;         /* >= 0 */
    double radius;            /* circular holes (> 0), or NaN for rectangular ones */
    double hole_x, hole_y;    /* rectangular holes (> 0, <= the pitch), NaN for circular ones */
    double rf, rb, t;         /* diffuse reflectances (front, back) and transmittance */
    int samples;              /* samples^2 directions per patch; 0: BST_VENETIAN_SAMPLES */
    double solar[3];          /* rf, rb, t of a channel named Solar (spec values "VISIBLE/SOLAR");
                                 NaN (default): the values above */
    int rule;                 /* BST_VENETIAN_AVERAGE (default, the model above) or
                               * BST_VENETIAN_CENTRE: WINDOW's model (below; sheet_wce.c) */
} bst_perforated;
/* WINDOW's model of a perforated screen (rule=centre), as Windows-CalcEngine (v1.0.75) computes
 * it, so that a Klems-type basis gets WINDOW's numbers: every patch i taken at its centre
 * direction only (theta_i, phi_i); its open share F_i on the diagonal of Tf and Tb over Lambda_i;
 * the rest (1 - F_i) of the incident light transmitted (t) and reflected (rf from the front, rb
 * from the back) and spread by 1/pi over every outgoing patch: Tf(o, i) = F_i delta_oi /
 * Lambda_i + (1 - F_i) t / pi, Rf(o, i) = (1 - F_i) rf / pi (energy is conserved for r + t = 1,
 * the layer is reciprocal only where F is constant).  WCE's open shares: rectangular holes the
 * product of (hole - thickness |tan psi|)+ / pitch along X and Y, psi the direction's projected
 * angle there (exact, as the default model's); circular holes not the lens of the default model
 * but (pi a^2 - pi a thickness tan(theta) / 2) / (x y) up to tan(theta) = 2 a / thickness, 0
 * beyond.  No `distribution`: WCE spreads a screen's scattered light uniformly only.  A Solar
 * channel with its own values weighs the layers of the visible ones and of (solar - f visible)
 * / (1 - f) f : 1 - f (f = BST_DUAL_BAND_F), as the venetian WINDOW mode does. */
/* The defaults: no geometry (pitch, radius and holes NaN), thickness 0, a black sheet. */
void bst_perforated_init(bst_perforated *p);
/* Parse "x=5mm,y=5mm,radius=1mm,thickness=1mm,r=0.7" (the text after "perforated:"); every error
 * names its key. */
int bst_perforated_parse(bst_ctx *ctx, const char *spec, bst_perforated *p);
/* The items of spec applied to p as it is, then checked (as bst_venetian_update; radius replaces
 * rectangular holes and hole-x or hole-y a radius). */
int bst_perforated_update(bst_ctx *ctx, const char *spec, bst_perforated *p);
/* The screen as a layer over basis, every channel named (nchannels 0: Visible and Solar) the same. */
int bst_perforated_layer(bst_ctx *ctx, const bst_perforated *p, const bst_basis *basis,
                         size_t nchannels, const char *const *channels, bst_layer **out);

/* ------------------------------------------------------------------- woven fabrics: woven.c */

/* A woven fabric from its geometry ("woven:" specs, bsdfstack-glass(5)): cylindrical threads of
 * `diameter` along X and along Y every `spacing` (m).  The open share along a direction is
 * (1 - d / (s cos theta_x))+ (1 - d / (s cos theta_y))+, theta_x and theta_y its angles from the
 * normal across each set of threads (the openness (1 - d / s)^2 at the normal); the rest is
 * reflected (rf from the front, rb from the back) and transmitted (t) diffusely as by a perforated
 * screen. */
typedef struct {
    double diameter, spacing;
    double rf, rb, t;
    int samples;            /* samples^2 directions per patch; 0: BST_VENETIAN_SAMPLES */
    double solar[3];        /* rf, rb, t of a channel named Solar; NaN (default): the values above */
    int rule;               /* BST_VENETIAN_AVERAGE (default) or BST_VENETIAN_CENTRE: WINDOW's
                             * model (below; sheet_wce.c) */
} bst_woven;
/* WINDOW's woven model (rule=centre), as Windows-CalcEngine (v1.0.75) computes it: the centre
 * rule and uniform spreading of the perforated screen's WINDOW mode, with WCE's open share
 * Tx Ty, Tx = (1 - g / cos a)+ for the direction's angle a from the normal in the XZ plane,
 * Ty = (1 - g / cos b)+ for b = atan(tan(alt) / cos(alt)), alt = asin(sin theta sin phi)
 * (g = diameter / spacing; not the angle in the YZ plane of the default model), and WCE's
 * empirical scattering through the threads S(g, alt, a, r) (r the reflectance of the side the
 * light does not meet) moved from reflection to transmission: Tf(o, i) = F_i delta_oi / Lambda_i
 * + ((1 - F_i) t + S_i(rb)) / pi, Rf(o, i) = ((1 - F_i) rf - S_i(rb)) / pi, the back with rf and
 * rb swapped. */
/* The defaults: no geometry (NaN), black threads. */
void bst_woven_init(bst_woven *w);
/* Parse "diameter=0.5mm,spacing=2mm,r=0.7,t=0.1" (the text after "woven:"). */
int bst_woven_parse(bst_ctx *ctx, const char *spec, bst_woven *w);
/* The items of spec applied to w as it is, then checked (as bst_venetian_update). */
int bst_woven_update(bst_ctx *ctx, const char *spec, bst_woven *w);
int bst_woven_layer(bst_ctx *ctx, const bst_woven *w, const bst_basis *basis, size_t nchannels,
                    const char *const *channels, bst_layer **out);

/* ------------------------------------------- IGSDB shading products as layers: shade.c */

/* The band values a record's material gives the shade models (bsdfstack-glass(5), "IGSDB shading
 * records"): from its spectral rows when it has them, averaged over Visible (D65 x V) and Solar
 * (ASTM E891) as a spectral pane's channels average its rows (glass_band.c, the band spectra read
 * from catalogue_dir, NULL = bst_glass_catalogue_dir()), every value diffuse (specular 0, Tf = Tb
 * = T); else its dual_band_values as the record gives them (NaN where absent). */
int bst_shade_band_values(bst_ctx *ctx, const bst_shade *s, const char *catalogue_dir,
                          bst_shade_band *visible, bst_shade_band *solar);

/* A shade made from its geometry: the model of `kind`, the one of the three structs filled. */
typedef struct {
    bst_shade_kind kind;
    bst_venetian venetian;     /* BST_SHADE_VENETIAN */
    bst_perforated perforated; /* BST_SHADE_PERFORATED */
    bst_woven woven;           /* BST_SHADE_WOVEN */
} bst_shade_model;
/* Front and back values of one band that a model holds as one (a slat's or thread's diffuse
 * transmittance Tf and Tb; a slat's specular reflectance of its two faces) are averaged when they
 * differ by at most this, else the record is refused. */
#define BST_SHADE_SIDE_TOL 0.005
/* The record as its kind's model, then overrides (the key=value items of that kind's spec,
 * bst_venetian_update etc.; NULL or "" for none) applied and the result checked.  Venetian: width,
 * spacing, tilt (IGSDB's sign is ours), curvature and segments from the geometry; the material's
 * Rf on the face looking up (r-up; WINDOW's front), Rb on the other (r-down), specular parts as
 * rs, T (spectral rows) or Tf + Tb's specular and diffuse parts as the diffuse t.  Perforated:
 * pitch spacing_x, spacing_y, radius dimension_x (Circular) or holes dimension_x by dimension_y
 * (Rectangular; Square: dimension_x both ways), thickness the material's; woven: diameter and
 * spacing; both with rf, rb, t the material's whole R and T (their light scattered diffusely).
 * Every error is one line naming the file (s->path) and the field or key. */
int bst_shade_model_of(bst_ctx *ctx, const bst_shade *s, const char *catalogue_dir,
                       const char *overrides, bst_shade_model *m);
/* A shade spec as the program's layers name it, parsed into m: "venetian:KEYS", "perforated:KEYS",
 * "woven:KEYS" or "shade:FILE[,KEYS]" (an IGSDB shading record read, bst_shade_model_of; FILE
 * ends at its first comma unless the whole text names a file). */
int bst_shade_parse(bst_ctx *ctx, const char *spec, const char *catalogue_dir, bst_shade_model *m);
/* The model as a layer over basis (nchannels 0: Visible and Solar), by its kind's *_layer. */
int bst_shade_model_layer(bst_ctx *ctx, const bst_shade_model *m, const bst_basis *basis,
                          size_t nchannels, const char *const *channels, bst_layer **out);
/* What the model's layer over basis (channels as bst_shade_model_layer takes them) will hold,
 * for the memory model (bst_plan_memory_held), without making it.  Per channel: a venetian blind
 * of WINDOW's model (rule=centre) four dense components; of the default model with diffuse slats
 * (r_up, r_down or t above 0), four factored over the strips' map (width 8 segments) when it has
 * no mirror part (rs = 0) and 8 segments is below N / 2 (mat.h, BSTI_LR_DENSE_SHARE), else four
 * dense; mirror or black slats sparse (none counted).  A perforated screen or a woven fabric with
 * diffuse values: four factored components (the diagonal and rank at most 5 over a wide map,
 * both rules), else diagonal.  BST_OK, or BST_EINVAL for a NULL argument or an unknown kind. */
int bst_shade_model_plan(bst_ctx *ctx, const bst_shade_model *m, const bst_basis *basis,
                         size_t nchannels, const char *const *channels, bst_plan_held *out);
/* The model as the spec that makes it ("venetian:width=16mm,...", values as VISIBLE/SOLAR where
 * the Solar channel differs), into buf (size bytes, truncated); returns the length it needs. */
size_t bst_shade_model_spec(const bst_shade_model *m, char *buf, size_t size);
/* Bindings that do not hold the struct: bst_shade_parse, then the model's spec into buf (size
 * bytes; BST_EINVAL when it does not fit), or the model's layer. */
int bst_shade_spec_model(bst_ctx *ctx, const char *spec, const char *catalogue_dir, char *buf,
                         size_t size);
int bst_shade_spec_layer(bst_ctx *ctx, const char *spec, const char *catalogue_dir,
                         const bst_basis *basis, size_t nchannels, const char *const *channels,
                         bst_layer **out);

/* ---------------------------------------------------------------------- sun positions: sun.c */

/* The sun's position by RADIANCE's gensky/gendaylit formulas (src/gen/sun.c there: declination and
 * equation of time by short sine series of the day of the year, no leap years), and its direction
 * as light reaching a vertical window.  Angles in degrees; site as gensky's -a, -o, -m: latitude
 * north positive, longitude and the time zone's standard meridian WEST positive.  Azimuths as
 * gensky prints them: from south, positive towards west (-90 east, 90 west). */
typedef struct {
    double latitude, longitude, meridian;
} bst_sun_site;
/* Day of the year (1..365) of a month (1..12) and day, as gensky (no leap years). */
int bst_sun_day(int month, int day);
/* Solar time (hours) at standard time `hour` of day `jd` (gensky without +). */
double bst_sun_solar_time(const bst_sun_site *site, int jd, double hour);
/* Declination (degrees) of day jd. */
double bst_sun_declination(int jd);
/* Altitude and azimuth (degrees) at solar time st (hours) on day jd. */
void bst_sun_position(const bst_sun_site *site, int jd, double st, double *altitude,
                      double *azimuth);
/* The light of a sun at (altitude, azimuth) on a vertical window whose outward normal faces
 * window_azimuth (as the sun's: 0 = the window faces south, 90 = west): its propagation direction
 * (theta, phi) in this header's frame (+Z into the room, Y up, X to the right seen from the room),
 * as combine's --incident takes it.  Returns 1 when the sun is in front of the window and above
 * the horizon (theta < 90), else 0 (theta, phi still set); 0 also for an angle that is not
 * finite. */
int bst_sun_incident(double altitude, double azimuth, double window_azimuth, double *theta,
                     double *phi);
/* The sun positions of a year in front of the window: every `step_min` minutes of standard time
 * (0:00, step, ...) on days 1..365, those with the sun above the horizon and in front; up to max
 * directions (theta, phi) into dirs (may be NULL to count).  Returns how many there are (even
 * beyond max), or BST_EINVAL for a site outside latitude [-90, 90], longitude and meridian
 * [-360, 360] or a step outside [1, 1440]. */
long bst_sun_path(const bst_sun_site *site, double window_azimuth, double step_min, size_t max,
                  double (*dirs)[2]);

/* ------------------------------------------------------------------------------- version: ctx.c */

/* "MAJOR.MINOR.PATCH" of the library actually linked. */
const char *bst_version(void);

#ifdef __cplusplus
}
#endif
#endif /* BSDFSTACK_H */
