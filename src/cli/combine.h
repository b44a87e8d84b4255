/* combine.h - `bsdfstack combine`, in four files: the request parsed from the command line
 * (combine_args.c), the whole system (cmd_combine.c: load -> cli_combine_run -> write), the
 * columns of chosen directions (combine_columns.c, --incident) and the variable-resolution file
 * (combine_varres.c, --fine-incident and --sun-path). */
#ifndef BST_CLI_COMBINE_H
#define BST_CLI_COMBINE_H

#include <stddef.h>

#include "cli.h"
#include "layers.h"

#define COMBINE_MAX_INCIDENT 100000 /* directions per run */
#define COMBINE_COARSE_K 4          /* --coarse-k's default */

/* What the command line asks for. */
struct combine_req {
    struct cli_stack_args args; /* the options combine shares with batch */
    const char *outpath, *abspath;
    int verbose, threads, help;
    double (*dirs)[2];          /* --incident, then --incident-file's: (theta, phi) in degrees */
    size_t ndirs, dcap;
    const char *dirfile;
    double (*fine)[2];          /* --fine-incident, then --fine-incident-file's and the sun's */
    size_t nfine, fcap;
    const char *finefile;
    int kc;                     /* --coarse-k, 0 when not given */
    int sun;                    /* --sun-path given: site, azimuth, sun_step */
    int azimuth_set, step_set;  /* --azimuth, --sun-step given */
    bst_sun_site site;
    double azimuth, sun_step;
    size_t nspecs;              /* the layers, exterior first */
    char **specs;
    int argc;                   /* the whole command line, for the output's metadata */
    char **argv;
};

/* Parse and check the command line into q (q->help: --help was printed, nothing else to do).
 * CLI_OK, or the usage or error line printed and its code; combine_req_free either way. */
int combine_parse(int argc, char **argv, struct combine_req *q);
void combine_req_free(struct combine_req *q);
/* Append the directions of a file, one "THETA PHI" a line, to *dirs. */
int combine_read_directions(const char *sub, const char *path, double (**dirs)[2], size_t *n,
                            size_t *cap);

/* -v: a line for a phase (reading, combining, writing) begun at t0 (combine_now()), with its time
 * and the peak memory so far. */
double combine_now(void);
void combine_phase(const char *what, double t0);

/* --incident: the columns of the asked directions into one TSV file at path (sp: per wavelength,
 * else NULL). */
int combine_columns(bst_ctx *ctx, const char *sub, const char *path, const struct cli_layers *set,
                    const bst_spectral_opts *sp, unsigned comps, size_t ndirs,
                    const double (*dirs)[2], int verbose);
/* --fine-incident, --sun-path: the variable-resolution file. */
int combine_varres(struct combine_req *q);

#endif
