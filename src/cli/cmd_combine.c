/* cmd_combine.c - `bsdfstack combine`: load layers (exterior first), resample them to one basis,
 * combine them by the matrix formalism (bst_stack_combine) and write the system as BSDF XML. */
#include <config.h>

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <time.h>

#include "cli.h"
#include "incident_tsv.h"
#include "layers.h"

static const char help[] =
    "Usage: bsdfstack combine [-k K | --klems[=full|half|quarter]] [--only Tf,Rf,Tb,Rb]\n"
    "                         [--channels NAMES] [--precision double|single] [--drop-tol X]\n"
    "                         [--reduce PCT | --no-reduce] [--reduce-tol T] [--dense]\n"
    "                         [--absorptance FILE]\n"
    "                         [--per-channel] [--spectral-tol X] [--glass-rule average|centre]\n"
    "                         [--strict] [--max-memory SIZE]\n"
    "                         [--incident THETA,PHI]...\n"
    "                         [--incident-file FILE]\n"
    "                         [--fine-incident THETA,PHI]... [--fine-incident-file FILE]\n"
    "                         [--sun-path LAT,LON,MERIDIAN [--azimuth DEG] [--sun-step MIN]]\n"
    "                         [--coarse-k KC] [--threads N] [-v] -o OUT LAYER LAYER...\n"
    "Combines the layers, listed exterior first, with every inter-reflection between them, and\n"
    "writes the system's BSDF as BSDF XML.  When at least one layer is a pane with spectral data\n"
    "and every other layer is a file with Solar and Visible channels (WINDOW's dual-band\n"
    "material: Visible inside 0.38..0.78 um, (Solar - 0.499 Visible) / 0.501 outside), the stack\n"
    "is combined wavelength by wavelength and averaged per channel afterwards (as WINDOW does);\n"
    "otherwise each channel's band values are combined.  The output's metadata says which and\n"
    "why; -v prints it.\n"
    "\n"
    "Layers:\n"
    "  FILE.xml           a BSDF XML file (Klems, TensorTree3/4, any resolution)\n"
    "  glass:NAME         a pane of the glass catalogue (bsdfstack-glass(5)); glass:FILE a spectral\n"
    "                     data file (table, Optics file, IGSDB record); glass:d=6mm,n=1.52,tn=0.89\n"
    "                     an inline pane; ,model=coated|uncoated after any of them\n"
    "  venetian:KEYS      a venetian blind from its geometry: width=16mm,spacing=14.5mm,tilt=45,\n"
    "                     rs=0.765,r=0.085,roughness=0.02 (also curvature, vertical, r-up,\n"
    "                     r-down, t, segments, samples; bsdfstack-glass(5))\n"
    "  LAYER^             the layer installed reversed (back side facing the exterior)\n"
    "\n"
    "Options:\n"
    "  -k K               Shirley-Chiu tensor-tree basis of order K (1..7)\n"
    "  --klems[=WHICH]    Klems basis: full (default, 145 patches), half or quarter\n"
    "                     Neither given: the finest order among tensor-tree layers; with no tree,\n"
    "                     the Klems basis of the first Klems file (Klems output); with panes\n"
    "                     only, k = 5\n"
    "  --only COMPS       only these components (comma-separated Tf, Rf, Tb, Rb)\n"
    "  --channels NAMES   only these channels (e.g. Visible,Solar); default: all in common\n"
    "  --precision P      double (default) or single precision for dense work\n"
    "  --drop-tol X       drop sparse fill-in below X times a product's largest value (default 0)\n"
    "  --reduce PCT       tensor-tree reduction percentile written (default 90); --no-reduce: none\n"
    "  --reduce-tol T     ... merging only where every incident patch's hemispherical T and R\n"
    "                     stay within T (default 0.002; none: the percentile alone)\n"
    "  --dense            force every matrix dense (the baseline for comparisons)\n"
    "  --absorptance FILE also write per-layer absorptance per incident patch (TSV: channel,\n"
    "                     side, patch, theta, phi of the propagation direction, A1..An, T, R)\n"
    "  --per-channel      combine band values even when the stack could go per wavelength\n"
    "  --spectral-tol X   per wavelength: combine once per group of wavelengths, grouped so\n"
    "                     that the band-weighted RMS deviation of the panes'\n"
    "                     normal-incidence T and R from their group means is within X (default\n"
    "                     0.004: T, R and A within 5.1e-5 of X = 0; 0: every distinct wavelength)\n"
    "  --glass-rule R     panes' patch values: average (default) over the patch, or at its\n"
    "                     centre (centre, WINDOW's and WCE's); they differ by up to 0.08 in T\n"
    "                     in the Klems 75-90 degree ring\n"
    "  --strict           ill-conditioning and energy imbalance (input or system) are errors\n"
    "  --max-memory SIZE  refuse when the estimated peak exceeds SIZE (16G, 800M; default: the\n"
    "                     memory available now)\n"
    "  --incident T,P     only this incidence direction (repeatable): iterate the light between\n"
    "                     the layers for its columns (--only's components) and write them as TSV\n"
    "                     (channel, comp, theta_in, phi_in, patch_in, patch_out, theta_out, phi_out,\n"
    "                     BSDF, DSF = BSDF cos theta_in); O(N^2) per direction instead of O(N^3)\n"
    "  --incident-file F  more such directions, one 'THETA PHI' a line (# comments; '-' = stdin)\n"
    "Variable resolution (one tensor tree whose depth varies; needs -k K, the fine order):\n"
    "  --fine-incident T,P  a front incidence direction (as --incident, repeatable) whose Tf and\n"
    "                     Rf columns are computed and written at order K; every other incident\n"
    "                     patch, and Tb and Rb, at order KC (the whole system at KC)\n"
    "  --fine-incident-file F  more such directions, one 'THETA PHI' a line\n"
    "  --coarse-k KC      the coarse order, 1 <= KC < K (default 4)\n"
    "  --sun-path LAT,LON,MER  the fine directions are the sun positions of a year in front of a\n"
    "                     vertical window, by gensky's formulas: latitude (north +), longitude and\n"
    "                     time zone meridian (degrees WEST of Greenwich positive, as gensky -a -o -m)\n"
    "  --azimuth DEG      the window's outward normal, from south, positive towards west (as\n"
    "                     gensky's sun azimuth): 0 faces south (default), 90 west, -90 east\n"
    "  --sun-step MIN     minutes of standard time between sun positions (default 60: every hour)\n"
    "  The file's fine columns are checked against the coarse system: a fine patch whose\n"
    "  hemispherical Tf or Rf differs from its coarse patch's by more than 0.02 is warned of\n"
    "  --threads N        threads that write a tensor tree's text and lay rank-3 layers onto the\n"
    "                     grid (default 0: one per CPU, up to 8); the same bytes with any N\n"
    "  -v                 print the time and peak memory of reading, of each step (with its\n"
    "                     structures) and of writing\n"
    "  -o OUT             output file ('-' = standard output); a regular file is replaced\n"
    "                     atomically, a symbolic link's target is written, a device or FIFO\n"
    "                     directly (also for --absorptance)\n";

/* the dense kernels' floating-point operations of every step so far (-v; steps are reported one at
 * a time, also by the spectral workers) */
static double steps_flops;
/* -v on a stack combined per wavelength: each group of wavelengths is a combination of its own,
 * so its steps (hundreds) are summed into one line: how many, and the least rcond */
static size_t steps_seen;
static double steps_least_rcond = INFINITY;

static void count_step(const bst_stack_step *s, void *opaque)
{
    (void)opaque;
    steps_flops += s->flops;
    steps_seen++;
    steps_least_rcond = fmin(steps_least_rcond, s->rcond);
}

static void verbose_step(const bst_stack_step *s, void *opaque)
{
    (void)opaque;
    steps_flops += s->flops;
    static const char *const names[] = {"zero", "diagonal", "sparse", "dense"};
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    fprintf(stderr, "bsdfstack combine: layers 1-%zu %s %s: %s, %zu stored, %.3f s, %.3g GFLOP, "
            "rcond %.3g, peak RSS %.1f MiB\n", s->step + 1, s->channel, bst_comp_name(s->comp),
            names[s->structure], s->nnz, s->seconds, s->flops * 1e-9, s->rcond, ru.ru_maxrss / 1024.0);
}

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* -v: one line for reading the layers or writing the result, with its time and the peak so far */
static void verbose_phase(const char *what, double t0)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    fprintf(stderr, "bsdfstack combine: %s: %.3f s, peak RSS %.1f MiB\n", what, now_s() - t0,
            ru.ru_maxrss / 1024.0);
}

/* Per-layer absorptance of every channel of sys: abs[side][(ch * n + i) * N + j]. */
static int absorptance(bst_ctx *ctx, const char *sub, const struct cli_layers *set,
                       const bst_layer *sys, const bst_stack_opts *so, double *abs[2])
{
    size_t n = set->n, N = bst_basis_size(set->basis);
    for (size_t ch = 0; ch < bst_layer_nchannels(sys); ch++) {
        size_t c0 = (size_t)bst_layer_find_channel(set->layers[0], bst_layer_channel(sys, ch));
        int st = bst_stack_absorptance(ctx, n, (const bst_layer *const *)set->layers, c0, so,
                                       abs[0] + ch * n * N, abs[1] + ch * n * N);
        if (st < 0)
            return cli_fail_ctx(sub, "absorptance", ctx);
    }
    return CLI_OK;
}

/* --absorptance: one row per channel, side and incident patch: the patch direction (the light's
 * propagation direction), each layer's absorptance, and the system's T and R for the balance.
 * Written into out, opened and flushed here and left for the caller to commit once the system is
 * written (both files or neither); on an error out is aborted. */
static int write_absorptance(bst_ctx *ctx, const char *sub, const char *path, struct cli_out *out,
                             const struct cli_layers *set, const bst_layer *sys, double *const abs[2])
{
    size_t n = set->n, N = bst_basis_size(set->basis);
    double *t = malloc(2 * N * sizeof *t), *r = t ? t + N : NULL;
    int rc = t ? cli_out_open(out, sub, path) : cli_fail(sub, "out of memory");
    if (rc == CLI_OK) {
        fprintf(out->fp, "channel\tside\tpatch\ttheta_deg\tphi_deg");
        for (size_t i = 0; i < n; i++)
            fprintf(out->fp, "\tA%zu", i + 1);
        fprintf(out->fp, "\tT\tR\n");
    }
    for (size_t ch = 0; rc == CLI_OK && ch < bst_layer_nchannels(sys); ch++) {
        const char *name = bst_layer_channel(sys, ch);
        for (int side = 0; side < 2; side++) {
            const double *a = abs[side] + ch * n * N;
            bst_layer_hemispherical(ctx, sys, ch, side ? BST_TB : BST_TF, t);
            bst_layer_hemispherical(ctx, sys, ch, side ? BST_RB : BST_RF, r);
            for (size_t j = 0; j < N; j++) {
                double th, ph;
                cli_patch_direction(set->basis, j, &th, &ph);
                fprintf(out->fp, "%s\t%s\t%zu\t%.4f\t%.4f", name, side ? "back" : "front", j, th, ph);
                for (size_t i = 0; i < n; i++)
                    fprintf(out->fp, "\t%.8f", a[i * N + j]);
                fprintf(out->fp, "\t%.8f\t%.8f\n", t[j], r[j]);
            }
        }
    }
    if (rc == CLI_OK)
        rc = cli_out_flush(out, sub); /* a write error shows before the system is written */
    else
        cli_out_abort(out);
    free(t);
    return rc;
}

#define MAX_INCIDENT 100000 /* directions per run */
#define DEFAULT_COARSE_K 4
#define COLUMN_BATCH 64      /* iterated together: N x 64 blocks */

/* --incident: the columns of the asked directions (light propagating along (theta, phi)) of the
 * components comps, front and back incidence each iterated once (bst_stack_columns), as TSV. */
static int write_columns(bst_ctx *ctx, const char *sub, FILE *fp, const struct cli_layers *set,
                         const bst_spectral_opts *sp, unsigned comps, size_t ndirs,
                         const double (*dirs)[2], int verbose)
{
    size_t N = bst_basis_size(set->basis), cols[COLUMN_BATCH];
    for (size_t q = 0; q < ndirs; q++) { /* off cell boundaries onto the +x, +y side, as compare */
        double t = dirs[q][0] * M_PI / 180, p = dirs[q][1] * M_PI / 180;
        double d[3] = {sin(t) * cos(p) + 1e-9, sin(t) * sin(p) + 1e-9, cos(t)};
        cols[q] = bst_basis_patch(set->basis, d);
    }
    int rc = CLI_OK;
    for (size_t ch = 0; rc == CLI_OK && ch < bst_layer_nchannels(set->layers[0]); ch++) {
        const char *name = bst_layer_channel(set->layers[0], ch);
        int everywhere = 1; /* the channels all layers have, as the combination's output */
        for (size_t i = 1; i < set->n; i++)
            everywhere &= bst_layer_find_channel(set->layers[i], name) >= 0;
        if (!everywhere)
            continue;
        for (int back = 0; rc == CLI_OK && back < 2; back++) {
            bst_comp tc = back ? BST_TB : BST_TF, r = back ? BST_RB : BST_RF;
            if (!(comps & (BST_COMP_BIT(tc) | BST_COMP_BIT(r))))
                continue;
            bst_columns_opts o;
            bst_columns_opts_init(&o);
            o.back = back;
            bst_mat *m[2] = {NULL, NULL};
            if (sp) { /* per wavelength (cli_spectral_plan) */
                rc = cli_columns_spectral(ctx, sub, set, sp, name, ndirs, cols, &o, &m[0], &m[1]);
                if (rc != CLI_OK)
                    break;
            } else {
                int st = bst_stack_columns(ctx, set->n, (const bst_layer *const *)set->layers, name,
                                           ndirs, cols, &o, &m[0], &m[1]);
                if (st < 0) {
                    rc = cli_fail_ctx(sub, "iterating", ctx);
                    break;
                }
                cli_warn_ctx(sub, NULL, st, ctx);
            }
            if (verbose)
                fprintf(stderr, "bsdfstack %s: %s, %s incidence: %d sweeps, last change %.2e of the "
                        "incident flux\n", sub, name, back ? "back" : "front", o.iterations, o.residual);
            for (int c = 0; c < 2; c++) {
                bst_comp comp = c ? r : tc;
                for (size_t q = 0; (comps & BST_COMP_BIT(comp)) && q < ndirs; q++) {
                    double cin = cos(dirs[q][0] * M_PI / 180);
                    for (size_t e = 0; e < N; e++) {
                        double th, ph, v = bst_mat_get(m[c], e, q);
                        cli_patch_direction(set->basis, e, &th, &ph);
                        fprintf(fp, "%s\t%s\t%g\t%g\t%zu\t%zu\t%.4f\t%.4f\t%.9g\t%.9g\n", name,
                                bst_comp_name(comp), dirs[q][0], dirs[q][1], cols[q], e, th, ph, v,
                                v * cin);
                    }
                }
            }
            bst_mat_free(m[0]), bst_mat_free(m[1]);
        }
    }
    return rc;
}

/* Every direction, COLUMN_BATCH at a time, into one TSV file (sp: per wavelength, else NULL). */
static int write_all_columns(bst_ctx *ctx, const char *sub, const char *path, const struct cli_layers *set,
                             const bst_spectral_opts *sp, unsigned comps, size_t ndirs,
                             const double (*dirs)[2], int verbose)
{
    struct cli_out out = {0};
    int rc = cli_out_open(&out, sub, path);
    if (rc == CLI_OK)
        fprintf(out.fp, "%s\n", CLI_TSV_HEADER);
    for (size_t q = 0; rc == CLI_OK && q < ndirs; q += COLUMN_BATCH)
        rc = write_columns(ctx, sub, out.fp, set, sp, comps,
                           ndirs - q < COLUMN_BATCH ? ndirs - q : COLUMN_BATCH, dirs + q, verbose);
    if (rc == CLI_OK)
        rc = cli_out_commit(&out, sub);
    else
        cli_out_abort(&out);
    return rc;
}

/* --incident-file: one direction a line, "THETA PHI" or "THETA,PHI" in --incident's convention;
 * blank lines and lines starting with # are skipped.  Appends to *dirs. */
static int read_directions(const char *sub, const char *path, double (**dirs)[2], size_t *n, size_t *cap)
{
    FILE *fp = strcmp(path, "-") == 0 ? stdin : fopen(path, "r");
    if (!fp)
        return cli_fail(sub, "%s: cannot open: %s", path, strerror(errno));
    const char *name = fp == stdin ? "standard input" : path;
    char *line = NULL;
    size_t size = 0;
    ssize_t got;
    int rc = CLI_OK;
    for (long ln = 1; rc == CLI_OK && (got = cli_read_line(sub, name, ln, &line, &size, fp)) != -1; ln++) {
        if (got < 0) {
            rc = CLI_FAIL;
            break;
        }
        char *p = line + strspn(line, " \t");
        if (*p == '#' || *p == '\n' || *p == '\r' || *p == '\0')
            continue;
        double t, f;
        char extra[2];
        for (char *c = p; *c; c++)
            if (*c == ',')
                *c = ' ';
        if (sscanf(p, "%lf %lf %1s", &t, &f, extra) != 2 || !isfinite(t) || !isfinite(f) || t < 0 || t >= 90) {
            rc = cli_fail(sub, "%s:%ld: give THETA PHI in degrees, 0 <= THETA < 90", path, ln);
            break;
        }
        if (*n == MAX_INCIDENT) {
            rc = cli_fail(sub, "%s:%ld: more than %d directions", path, ln, MAX_INCIDENT);
            break;
        }
        if (*n == *cap) {
            size_t nc = *cap ? 2 * *cap : 64;
            double (*d)[2] = realloc(*dirs, nc * sizeof **dirs);
            if (!d) {
                rc = cli_fail(sub, "out of memory");
                break;
            }
            *dirs = d, *cap = nc;
        }
        (*dirs)[*n][0] = t, (*dirs)[(*n)++][1] = f;
    }
    if (rc == CLI_OK && ferror(fp))
        rc = cli_fail(sub, "%s: read error: %s", name, strerror(errno ? errno : EIO));
    if (rc == CLI_OK && *n == 0)
        rc = cli_fail(sub, "%s: no directions", path);
    free(line);
    if (fp != stdin)
        fclose(fp);
    return rc;
}

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return x < y ? -1 : x > y;
}

/* The fine directions' patches at order k, increasing, without repeats. */
static int fine_patches(const char *sub, bst_ctx *ctx, int k, size_t ndirs, const double (*dirs)[2],
                        size_t **cols, size_t *ncols)
{
    bst_basis *b;
    *cols = NULL;
    if (bst_basis_new_sc(ctx, k, &b) < 0)
        return cli_fail_ctx(sub, NULL, ctx);
    size_t *c = malloc((ndirs + 1) * sizeof *c), m = 0;
    if (!c) {
        bst_basis_free(b);
        return cli_fail(sub, "out of memory");
    }
    for (size_t q = 0; q < ndirs; q++) { /* off cell boundaries onto the +x, +y side, as --incident */
        double t = dirs[q][0] * M_PI / 180, p = dirs[q][1] * M_PI / 180;
        double d[3] = {sin(t) * cos(p) + 1e-9, sin(t) * sin(p) + 1e-9, cos(t)};
        c[q] = bst_basis_patch(b, d);
    }
    qsort(c, ndirs, sizeof *c, cmp_size);
    for (size_t q = 0; q < ndirs; q++)
        if (m == 0 || c[q] != c[m - 1])
            c[m++] = c[q];
    bst_basis_free(b);
    *cols = c, *ncols = m;
    return CLI_OK;
}

/* Variable resolution: the whole system at order kc, the Tf and Rf columns of the fine patches at
 * order k (bst_stack_columns), their consistency checked, one file (bst_bsdf_write_varres).  Both
 * parts are combined alike: per wavelength where cli_spectral_plan says so (the same groups of
 * wavelengths), else by band values per channel. */
static int combine_varres(bst_ctx *ctx, const char *sub, struct cli_stack_args *args, int kc,
                          size_t nspecs, char **specs, size_t ndirs, const double (*dirs)[2],
                          const char *outpath, int verbose, int argc, char **argv)
{
    int k = args->basis.k;
    size_t *cols = NULL, ncols = 0;
    int rc = fine_patches(sub, ctx, k, ndirs, dirs, &cols, &ncols);
    if (rc != CLI_OK)
        return rc;
    if (verbose)
        fprintf(stderr, "bsdfstack %s: %zu fine directions in %zu patches of order %d over order %d\n",
                sub, ndirs, ncols, k, kc);
    /* the coarse system at kc */
    struct cli_layers set = {0}, fset = {0};
    struct cli_basis_choice choice = args->basis;
    choice.k = kc;
    choice.combining = 1;
    bst_layer *sys = NULL;
    double t0 = now_s();
    rc = cli_layers_load(&set, ctx, sub, nspecs, specs, &choice, args->channels, 0, args->so.precision);
    char why[2048];
    int spectral = rc == CLI_OK ? cli_spectral_plan(ctx, sub, &set, args->per_channel, why, sizeof why) : 0;
    if (spectral < 0)
        rc = CLI_FAIL;
    if (rc == CLI_OK)
        rc = cli_note_spectral(sub, &set, why, verbose);
    if (rc == CLI_OK && spectral) { /* both parts per wavelength, grouped alike */
        double *none[2] = {NULL, NULL};
        rc = cli_combine_spectral(ctx, sub, &set, &args->sp, &args->so, none, &sys);
    } else if (rc == CLI_OK) {
        int st = bst_stack_combine_consume(ctx, set.n, set.layers, &args->so, &sys);
        if (st < 0)
            rc = cli_fail_ctx(sub, "combining", ctx);
        else
            cli_warn_ctx(sub, NULL, st, ctx);
    }
    if (rc == CLI_OK && verbose)
        verbose_phase("the coarse system", t0);
    /* the fine columns at k, front incidence, per channel of the coarse system */
    size_t nch = sys ? bst_layer_nchannels(sys) : 0;
    bst_mat **tf = calloc(2 * nch + 1, sizeof *tf), **rf = tf ? tf + nch : NULL;
    if (rc == CLI_OK && !tf)
        rc = cli_fail(sub, "out of memory");
    unsigned want = args->so.comps ? args->so.comps : BST_COMP_ALL;
    t0 = now_s();
    if (rc == CLI_OK && (want & (BST_COMP_BIT(BST_TF) | BST_COMP_BIT(BST_RF)))) {
        choice.k = k;
        choice.combining = 0;
        rc = cli_layers_load(&fset, ctx, sub, nspecs, specs, &choice, args->channels, 0,
                             args->so.precision);
        for (size_t ch = 0; rc == CLI_OK && ch < nch; ch++) {
            bst_columns_opts o;
            bst_columns_opts_init(&o);
            const char *name = bst_layer_channel(sys, ch);
            if (spectral) {
                rc = cli_columns_spectral(ctx, sub, &fset, &args->sp, name, ncols, cols, &o, &tf[ch],
                                          &rf[ch]);
                if (rc != CLI_OK)
                    break;
            } else {
                int st = bst_stack_columns(ctx, fset.n, (const bst_layer *const *)fset.layers, name,
                                           ncols, cols, &o, &tf[ch], &rf[ch]);
                if (st < 0) {
                    rc = cli_fail_ctx(sub, "fine columns", ctx);
                    break;
                }
                cli_warn_ctx(sub, NULL, st, ctx);
            }
            if (!(want & BST_COMP_BIT(BST_TF)))
                bst_mat_free(tf[ch]), tf[ch] = NULL;
            if (!(want & BST_COMP_BIT(BST_RF)))
                bst_mat_free(rf[ch]), rf[ch] = NULL;
            if (verbose)
                fprintf(stderr, "bsdfstack %s: %s fine columns: %d sweeps, last change %.2e of the "
                        "incident flux\n", sub, name, o.iterations, o.residual);
        }
        if (rc == CLI_OK && verbose)
            verbose_phase("the fine columns", t0);
    }
    bst_varres v = {k, ncols, cols, (const bst_mat *const *)tf, (const bst_mat *const *)rf};
    /* consistency: each fine column's hemispherical value against its coarse patch's */
    double *diff = malloc((ncols + 1) * sizeof *diff);
    if (rc == CLI_OK && !diff)
        rc = cli_fail(sub, "out of memory");
    for (size_t ch = 0; rc == CLI_OK && ch < nch; ch++)
        for (int c = 0; rc == CLI_OK && c < 2; c++) {
            bst_comp comp = c ? BST_RF : BST_TF;
            double worst;
            if (!(c ? rf : tf)[ch] || !bst_layer_get(sys, ch, comp))
                continue;
            if (bst_varres_hemi_diff(ctx, sys, &v, ch, comp, diff, &worst) < 0) {
                rc = cli_fail_ctx(sub, "consistency", ctx);
                break;
            }
            size_t beyond = 0, qw = 0;
            for (size_t q = 0; q < ncols; q++) {
                beyond += fabs(diff[q]) > BST_VARRES_HEMI_TOL;
                qw = fabs(diff[q]) > fabs(diff[qw]) ? q : qw;
            }
            size_t G = (size_t)1 << k;
            double cx = ((double)(cols[qw] / G) + 0.5) / (double)G, cy = ((double)(cols[qw] % G) + 0.5) / (double)G;
            if (beyond || verbose)
                fprintf(stderr, "bsdfstack %s: %s%s %s: fine columns' hemispherical value minus "
                        "their coarse patch's: largest %+.4f (fine patch %zu, square (%.3f, %.3f)); "
                        "%zu of %zu beyond %g\n", sub, beyond ? "warning: " : "",
                        bst_layer_channel(sys, ch), bst_comp_name(comp), diff[qw], cols[qw], cx, cy,
                        beyond, ncols, BST_VARRES_HEMI_TOL);
        }
    cli_layers_free(&fset);
    t0 = now_s();
    if (rc == CLI_OK)
        rc = cli_write_varres(ctx, sub, sys, &v, outpath, &args->reduce, argc, argv, &set);
    if (rc == CLI_OK && verbose)
        verbose_phase("wrote the file", t0);
    for (size_t i = 0; tf && i < 2 * nch; i++)
        bst_mat_free(tf[i]);
    free(tf), free(diff), free(cols);
    bst_layer_free(sys);
    cli_layers_free(&set);
    return rc;
}

/* --sun-path LAT,LON,MER into site; CLI_OK or a usage error. */
static int parse_site(const char *sub, const char *s, bst_sun_site *site)
{
    char extra;
    if (sscanf(s, "%lf,%lf,%lf%c", &site->latitude, &site->longitude, &site->meridian, &extra) != 3 ||
        !isfinite(site->latitude) || !isfinite(site->longitude) || !isfinite(site->meridian))
        return cli_usage(sub, "--sun-path %s: give LAT,LON,MERIDIAN in degrees", s);
    if (fabs(site->latitude) > 90)
        return cli_usage(sub, "--sun-path %s: latitude %g outside -90..90", s, site->latitude);
    if (fabs(site->longitude) > 180 || fabs(site->meridian) > 180)
        return cli_usage(sub, "--sun-path %s: longitude and meridian must lie in -180..180 (degrees "
                         "west positive)", s);
    return CLI_OK;
}

int cmd_combine(int argc, char **argv)
{
    enum { O_ABS = CLI_O_OWN, O_INCIDENT, O_INCFILE, O_FINE, O_FINEFILE, O_COARSEK, O_SUN, O_AZI,
           O_SUNSTEP, O_THREADS, O_HELP };
    static const struct option longopts[] = {
        CLI_STACK_LONGOPTS, {"absorptance", required_argument, NULL, O_ABS},
        {"incident", required_argument, NULL, O_INCIDENT},
        {"incident-file", required_argument, NULL, O_INCFILE},
        {"fine-incident", required_argument, NULL, O_FINE},
        {"fine-incident-file", required_argument, NULL, O_FINEFILE},
        {"coarse-k", required_argument, NULL, O_COARSEK}, {"sun-path", required_argument, NULL, O_SUN},
        {"azimuth", required_argument, NULL, O_AZI}, {"sun-step", required_argument, NULL, O_SUNSTEP},
        {"threads", required_argument, NULL, O_THREADS},
        {"help", no_argument, NULL, O_HELP}, {NULL, 0, NULL, 0}};
    const char *sub = "combine";
    const char *outpath = NULL, *abspath = NULL;
    int verbose = 0, threads = 0;
    double (*dirs)[2] = NULL, one[2];
    size_t ndirs = 0, cap = 0;
    const char *dirfile = NULL, *finefile = NULL;
    double (*fine)[2] = NULL, azimuth = 0.0, sun_step = 60.0;
    size_t nfine = 0, fcap = 0;
    int kc = 0, sun = 0, azimuth_set = 0, step_set = 0;
    bst_sun_site site = {0, 0, 0};
    struct cli_stack_args args;
    cli_stack_args_init(&args);
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":k:o:vh", longopts, NULL)) != -1) {
        int shared = cli_stack_option(sub, c, optarg, &args);
        if (shared == CLI_USAGE)
            return CLI_USAGE;
        if (shared == CLI_OK)
            continue;
        switch (c) {
        case 'o': outpath = optarg; break;
        case O_ABS: abspath = optarg; break;
        case O_INCIDENT:
            if (cli_parse_incident(sub, optarg, one) != CLI_OK) {
                free(dirs);
                return CLI_USAGE;
            }
            if (ndirs == cap) {
                double (*d)[2] = ndirs < MAX_INCIDENT ? realloc(dirs, (cap = cap ? 2 * cap : 16) * sizeof *dirs) : NULL;
                if (!d) {
                    free(dirs);
                    return cli_fail(sub, "--incident: too many directions");
                }
                dirs = d;
            }
            dirs[ndirs][0] = one[0], dirs[ndirs++][1] = one[1];
            break;
        case O_INCFILE: dirfile = optarg; break;
        case O_FINE: {
            double t, p;
            char extra;
            if (sscanf(optarg, "%lf,%lf%c", &t, &p, &extra) == 2 && isfinite(t) && t >= 90 && t <= 180) {
                free(dirs), free(fine);
                return cli_usage(sub, "--fine-incident %s: the direction is behind the window "
                                 "(theta >= 90); give front incidence, 0 <= THETA < 90", optarg);
            }
            if (cli_parse_incident(sub, optarg, one) != CLI_OK) {
                free(dirs), free(fine);
                return CLI_USAGE;
            }
            if (nfine == fcap) {
                double (*d)[2] = nfine < MAX_INCIDENT ? realloc(fine, (fcap = fcap ? 2 * fcap : 16) * sizeof *fine) : NULL;
                if (!d) {
                    free(dirs), free(fine);
                    return cli_fail(sub, "--fine-incident: too many directions");
                }
                fine = d;
            }
            fine[nfine][0] = one[0], fine[nfine++][1] = one[1];
            break;
        }
        case O_FINEFILE: finefile = optarg; break;
        case O_COARSEK:
            if (cli_parse_int(optarg, &kc) != 0 || kc < BST_K_MIN || kc >= BST_K_MAX) {
                free(dirs), free(fine);
                return cli_usage(sub, "--coarse-k %s: give an order from %d to %d", optarg, BST_K_MIN,
                                 BST_K_MAX - 1);
            }
            break;
        case O_SUN:
            if (parse_site(sub, optarg, &site) != CLI_OK) {
                free(dirs), free(fine);
                return CLI_USAGE;
            }
            sun = 1;
            break;
        case O_AZI:
            if (cli_parse_double(optarg, &azimuth) != 0 || fabs(azimuth) > 360) {
                free(dirs), free(fine);
                return cli_usage(sub, "--azimuth %s: give the window's azimuth in degrees from south, "
                                 "positive towards west (-360..360)", optarg);
            }
            azimuth_set = 1;
            break;
        case O_SUNSTEP:
            if (cli_parse_double(optarg, &sun_step) != 0 || sun_step < 1 || sun_step > 1440) {
                free(dirs), free(fine);
                return cli_usage(sub, "--sun-step %s: give minutes from 1 to 1440", optarg);
            }
            step_set = 1;
            break;
        case O_THREADS:
            if (cli_parse_int(optarg, &threads) != 0 || threads < 0) {
                free(dirs), free(fine);
                return cli_usage(sub, "--threads %s: use 0 (one per CPU) or a positive count", optarg);
            }
            break;
        case 'v': verbose = 1; break;
        case 'h':
        case O_HELP: /* longer than a stdout buffer: a failed write is told with its own errno */
            return fputs(help, stdout) == EOF ? cli_stdout_failed(sub, errno) : CLI_OK;
        case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    if (!outpath)
        return cli_usage(sub, "no output file: give -o OUT");
    if (argc - optind < 1)
        return cli_usage(sub, "no layers given");
    int rc = CLI_OK;
    int varres = nfine || finefile || sun;
    if (!sun && (azimuth_set || step_set))
        rc = cli_usage(sub, "--azimuth and --sun-step go with --sun-path");
    else if (!varres && kc)
        rc = cli_usage(sub, "--coarse-k goes with --fine-incident, --fine-incident-file or --sun-path");
    else if (varres && (ndirs || dirfile || abspath))
        rc = cli_usage(sub, "--fine-incident and --sun-path do not go with %s",
                       abspath ? "--absorptance" : "--incident");
    else if (varres && args.basis.klems)
        rc = cli_usage(sub, "variable resolution is for tensor trees: give -k K, not --klems");
    else if (varres && !args.basis.k)
        rc = cli_usage(sub, "--fine-incident and --sun-path need -k K, the fine order");
    else if (varres && (kc ? kc : DEFAULT_COARSE_K) >= args.basis.k)
        rc = cli_usage(sub, "--coarse-k %d must be below -k %d", kc ? kc : DEFAULT_COARSE_K,
                       args.basis.k);
    char early[64];
    const char *epoch_date;
    if (rc == CLI_OK) /* a malformed SOURCE_DATE_EPOCH fails before the work, not after it */
        rc = cli_source_date(sub, early, sizeof early, &epoch_date);
    if (rc != CLI_OK) {
        free(dirs), free(fine);
        return rc;
    }
    if (varres) {
        if (finefile)
            rc = read_directions(sub, finefile, &fine, &nfine, &fcap);
        if (rc == CLI_OK && sun) {
            long m = bst_sun_path(&site, azimuth, sun_step, 0, NULL);
            double (*d)[2] = m > 0 ? realloc(fine, (nfine + (size_t)m) * sizeof *fine) : NULL;
            if (m <= 0)
                rc = cli_fail(sub, "--sun-path: the sun never stands in front of a window facing "
                              "azimuth %g at latitude %g", azimuth, site.latitude);
            else if (!d)
                rc = cli_fail(sub, "out of memory");
            else {
                fine = d;
                bst_sun_path(&site, azimuth, sun_step, (size_t)m, fine + nfine);
                nfine += (size_t)m;
                if (verbose)
                    fprintf(stderr, "bsdfstack %s: %ld sun positions of a year in front of the "
                            "window\n", sub, m);
            }
        }
        bst_ctx *vctx = rc == CLI_OK ? cli_ctx_new(sub) : NULL;
        if (rc == CLI_OK && !vctx)
            rc = CLI_FAIL;
        if (vctx)
            bst_ctx_set_threads(vctx, threads);
        if (rc == CLI_OK)
            rc = combine_varres(vctx, sub, &args, kc ? kc : DEFAULT_COARSE_K, (size_t)(argc - optind),
                                argv + optind, nfine, (const double (*)[2])fine, outpath, verbose,
                                argc, argv);
        bst_ctx_free(vctx);
        free(dirs), free(fine);
        return rc;
    }
    int same = 0;
    if ((ndirs || dirfile) && abspath)
        rc = cli_usage(sub, "--incident and --absorptance do not go together");
    else if (abspath && (same = cli_out_same(abspath, outpath)) != 0)
        rc = same < 0 ? cli_fail(sub, "out of memory")
                      : cli_usage(sub, "--absorptance %s and -o %s name the same file", abspath, outpath);
    if (rc == CLI_OK && dirfile)
        rc = read_directions(sub, dirfile, &dirs, &ndirs, &cap);
    if (rc != CLI_OK) {
        free(dirs);
        return rc;
    }
    if (verbose)
        args.so.on_step = verbose_step;

    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx) {
        free(dirs);
        return CLI_FAIL;
    }
    bst_ctx_set_threads(ctx, threads);
    struct cli_layers set;
    double t0 = now_s();
    args.basis.combining = ndirs == 0; /* columns (--incident) need little beyond the layers */
    args.basis.work = args.so.precision;
    args.basis.lower = "a lower -k, --precision single or --only";
    rc = cli_layers_load(&set, ctx, sub, (size_t)(argc - optind), argv + optind, &args.basis,
                             args.channels, 0, args.so.precision);
    if (rc == CLI_OK && verbose) {
        char what[96];
        snprintf(what, sizeof what, "read %zu layer%s onto %zu patches", set.n, set.n == 1 ? "" : "s",
                 bst_basis_size(set.basis));
        verbose_phase(what, t0);
    }
    t0 = now_s();
    bst_layer *sys = NULL;
    double *abs[2] = {NULL, NULL};
    if (rc == CLI_OK && ndirs) {
        char why[2048];
        int spectral = cli_spectral_plan(ctx, sub, &set, args.per_channel, why, sizeof why);
        if (spectral < 0)
            rc = CLI_FAIL;
        else if (verbose)
            fprintf(stderr, "bsdfstack %s: spectral: %s\n", sub, why);
        if (rc == CLI_OK)
            rc = write_all_columns(ctx, sub, outpath, &set, spectral ? &args.sp : NULL, args.so.comps,
                                   ndirs, (const double (*)[2])dirs, verbose);
        free(dirs);
        cli_layers_free(&set);
        bst_ctx_free(ctx);
        return rc;
    }
    char why[2048];
    int spectral = rc == CLI_OK ? cli_spectral_plan(ctx, sub, &set, args.per_channel, why, sizeof why) : 0;
    if (spectral < 0)
        rc = CLI_FAIL;
    if (rc == CLI_OK && abspath) {
        size_t sz = bst_layer_nchannels(set.layers[0]) * set.n * bst_basis_size(set.basis);
        abs[0] = malloc(2 * sz * sizeof(double));
        abs[1] = abs[0] ? abs[0] + sz : NULL;
        if (!abs[0])
            rc = cli_fail(sub, "out of memory");
    }
    if (rc == CLI_OK)
        rc = cli_note_spectral(sub, &set, why, verbose);
    if (rc == CLI_OK && spectral) {
        if (verbose)
            args.so.on_step = count_step;
        rc = cli_combine_spectral(ctx, sub, &set, &args.sp, &args.so, abs, &sys);
        if (rc == CLI_OK && verbose)
            fprintf(stderr, "bsdfstack %s: per wavelength: %zu steps over the groups of wavelengths, "
                    "least rcond %.3g\n", sub, steps_seen, steps_seen ? steps_least_rcond : 1.0);
    } else if (rc == CLI_OK) {
        /* without --absorptance the layers die with the combination: let it free each component
         * at its last use (a pane and a dense layer at k = 7: 12 instead of 20 GiB in double) */
        const bst_stack_opts *so = &args.so;
        int st = abspath ? bst_stack_combine(ctx, set.n, (const bst_layer *const *)set.layers, so, &sys)
                         : bst_stack_combine_consume(ctx, set.n, set.layers, so, &sys);
        if (st < 0)
            rc = cli_fail_ctx(sub, "combining", ctx);
        else
            cli_warn_ctx(sub, NULL, st, ctx);
        if (rc == CLI_OK && abspath)
            rc = absorptance(ctx, sub, &set, sys, &args.so, abs);
    }
    cli_blas_rest(); /* writing does no BLAS work */
    if (rc == CLI_OK && verbose) {
        char what[96];
        snprintf(what, sizeof what, "combined, %.4g GFLOP in dense kernels", steps_flops * 1e-9);
        verbose_phase(what, t0);
    }
    struct cli_out abs_out = {0};
    if (rc == CLI_OK && abspath)
        rc = write_absorptance(ctx, sub, abspath, &abs_out, &set, sys, abs);
    /* the layers are dead once the system exists: free them before writing (at k = 7 a dense
     * layer holds 8 GiB that the writer can use) */
    for (size_t i = 0; rc == CLI_OK && i < set.n; i++) {
        bst_layer_free(set.layers[i]);
        set.layers[i] = NULL;
    }
    t0 = now_s();
    if (rc == CLI_OK)
        rc = cli_write_layer(ctx, sub, sys, outpath, &args.reduce, argc, argv, &set);
    if (rc == CLI_OK && abspath)
        rc = cli_out_commit(&abs_out, sub);
    else
        cli_out_abort(&abs_out);
    struct stat st_out;
    if (rc == CLI_OK && verbose) {
        char what[64] = "wrote the result";
        if (strcmp(outpath, "-") != 0 && stat(outpath, &st_out) == 0)
            snprintf(what, sizeof what, "wrote %.1f MB", st_out.st_size / 1e6);
        verbose_phase(what, t0);
    }
    free(abs[0]);
    free(dirs);
    bst_layer_free(sys);
    cli_layers_free(&set);
    bst_ctx_free(ctx);
    return rc;
}
