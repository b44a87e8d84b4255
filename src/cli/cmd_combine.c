/* cmd_combine.c - `bsdfstack combine`: parse the request (combine_args.c), load the layers
 * (exterior first) onto one basis, run the plan's combination (cli_combine_run: per wavelength or
 * per channel, by the matrix formalism) and write the system as BSDF XML, with per-layer
 * absorptance beside it when asked.  --incident and variable resolution branch off to
 * combine_columns.c and combine_varres.c after parsing. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <time.h>

#include "combine.h"

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
    static const char *const names[] = {"zero", "diagonal", "sparse", "dense", "factored",
                                        "sparse+low-rank"};
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    char rank[32] = "";
    if (s->structure == BST_FACTORED || s->structure == BST_PLUS_LR)
        snprintf(rank, sizeof rank, " rank %zu", s->rank);
    fprintf(stderr, "bsdfstack combine: layers 1-%zu %s %s: %s%s, %zu stored, %.3f s, %.3g GFLOP%s, "
            "rcond %.3g, peak RSS %.1f MiB\n", s->step + 1, s->channel, bst_comp_name(s->comp),
            names[s->structure], rank, s->nnz, s->seconds, s->flops * 1e-9,
            s->mirror ? " (mirror halves)" : "", s->rcond,
            ru.ru_maxrss / 1024.0);
}

double combine_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* -v: one line for reading the layers or writing the result, with its time and the peak so far */
void combine_phase(const char *what, double t0)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    fprintf(stderr, "bsdfstack combine: %s: %.3f s, peak RSS %.1f MiB\n", what, combine_now() - t0,
            ru.ru_maxrss / 1024.0);
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

/* Load the layers (-v: how long it took). */
static int load(bst_ctx *ctx, const char *sub, struct combine_req *q, struct cli_layers *set)
{
    double t0 = combine_now();
    if (q->verbose)
        cli_blas_note(sub);
    q->args.basis.combining = q->ndirs == 0; /* columns (--incident) need little beyond the layers */
    q->args.basis.work = q->args.so.precision;
    int rc = cli_layers_load(set, ctx, sub, q->nspecs, q->specs, &q->args.basis, q->args.channels,
                             0, q->args.so.precision);
    if (rc == CLI_OK && q->verbose) {
        char what[256];
        snprintf(what, sizeof what, "read %zu layer%s onto %zu patches (%s)", set->n,
                 set->n == 1 ? "" : "s", bst_basis_size(set->basis), set->basis_why);
        combine_phase(what, t0);
    }
    return rc;
}

/* --incident: the columns alone, per wavelength where the plan says so. */
static int columns(bst_ctx *ctx, const char *sub, struct combine_req *q, struct cli_layers *set)
{
    char why[2048];
    int spectral = cli_spectral_plan(ctx, sub, set, q->args.per_channel, why, sizeof why);
    if (spectral < 0)
        return CLI_FAIL;
    if (q->verbose)
        fprintf(stderr, "bsdfstack %s: spectral: %s\n", sub, why);
    return combine_columns(ctx, sub, q->outpath, set, spectral ? &q->args.sp : NULL,
                           q->args.so.comps, q->ndirs, (const double (*)[2])q->dirs, q->verbose);
}

/* The whole system: plan and combine (with absorptance when asked), then write; the layers are
 * freed before writing (at k = 7 a dense layer holds 8 GiB that the writer can use). */
static int whole(bst_ctx *ctx, const char *sub, struct combine_req *q, struct cli_layers *set)
{
    size_t sz = bst_layer_nchannels(set->layers[0]) * set->n * bst_basis_size(set->basis);
    double *abs = q->abspath ? malloc(2 * sz * sizeof *abs) : NULL;
    if (q->abspath && !abs)
        return cli_fail(sub, "out of memory");
    struct cli_run_opts ro = {.verbose = q->verbose, .consume = 1, .abs = {abs, abs ? abs + sz : NULL}};
    if (q->verbose) {
        q->args.so.on_step = verbose_step;
        ro.spectral_step = count_step;
    }
    double t0 = combine_now();
    bst_layer *sys = NULL;
    int rc = cli_combine_run(ctx, sub, NULL, set, &q->args, &ro, &sys);
    if (rc == CLI_OK && set->spectral && q->verbose)
        fprintf(stderr, "bsdfstack %s: per wavelength: %zu steps over the groups of wavelengths, "
                "least rcond %.3g\n", sub, steps_seen, steps_seen ? steps_least_rcond : 1.0);
    cli_blas_rest(); /* writing does no BLAS work but expanding factored components (GEMM bursts) */
    if (rc == CLI_OK && q->verbose) {
        char what[96];
        snprintf(what, sizeof what, "combined, %.4g GFLOP in dense kernels", steps_flops * 1e-9);
        combine_phase(what, t0);
    }
    struct cli_out abs_out = {0};
    if (rc == CLI_OK && abs)
        rc = write_absorptance(ctx, sub, q->abspath, &abs_out, set, sys, ro.abs);
    for (size_t i = 0; rc == CLI_OK && i < set->n; i++) {
        bst_layer_free(set->layers[i]);
        set->layers[i] = NULL;
    }
    t0 = combine_now();
    if (rc == CLI_OK)
        rc = cli_write_layer(ctx, sub, sys, q->outpath, &q->args.reduce, q->argc, q->argv, set);
    if (rc == CLI_OK && abs)
        rc = cli_out_commit(&abs_out, sub);
    else
        cli_out_abort(&abs_out);
    struct stat st_out;
    if (rc == CLI_OK && q->verbose) {
        char what[64] = "wrote the result";
        if (strcmp(q->outpath, "-") != 0 && stat(q->outpath, &st_out) == 0)
            snprintf(what, sizeof what, "wrote %.1f MB", st_out.st_size / 1e6);
        combine_phase(what, t0);
    }
    free(abs);
    bst_layer_free(sys);
    return rc;
}

int cmd_combine(int argc, char **argv)
{
    const char *sub = "combine";
    struct combine_req q;
    int rc = combine_parse(argc, argv, &q);
    if (rc != CLI_OK || q.help) {
        combine_req_free(&q);
        return rc;
    }
    if (q.nfine || q.finefile || q.sun) {
        rc = combine_varres(&q);
        combine_req_free(&q);
        return rc;
    }
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx) {
        combine_req_free(&q);
        return CLI_FAIL;
    }
    bst_ctx_set_threads(ctx, q.threads);
    struct cli_layers set = {0};
    rc = load(ctx, sub, &q, &set);
    if (rc == CLI_OK)
        rc = q.ndirs ? columns(ctx, sub, &q, &set) : whole(ctx, sub, &q, &set);
    cli_layers_free(&set);
    combine_req_free(&q);
    bst_ctx_free(ctx);
    return rc;
}
