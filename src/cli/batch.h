/* batch.h - what `bsdfstack batch` (cmd_batch.c: one process, or -j forked workers) and
 * bsdfstack-mpi (batch_mpi.c: MPI ranks) share: the options, one stack's run and result, the
 * batch-key of --resume, the --summary table and the progress line.  Both write the same files
 * for the same line and options. */
#ifndef BST_CLI_BATCH_H
#define BST_CLI_BATCH_H

#include <stdatomic.h>
#include <stdint.h>
#include <sys/types.h>
#include <time.h>

#include "batch_file.h"
#include "cli.h"
#include "layers.h"

/* A stack's state and result (under -j in memory the workers share with the parent; under MPI
 * sent from the rank that combined it to rank 0 as bytes: the ranks run the same program). */
enum { ST_PENDING, ST_RUNNING, ST_OK, ST_FAILED, ST_SKIPPED };
#define SUMMARY_CHANNELS 16 /* channels given in the summary; more are cut, with a note */
struct stack_result {
    atomic_int state;
    pid_t worker;   /* the process that combined it (RUNNING: holds it) */
    double seconds; /* wall clock */
    long peak_kib;  /* getrusage(RUSAGE_SELF).ru_maxrss of that process at the stack's end */
    int nch, more;  /* channels given, and whether there were more */
    char channel[SUMMARY_CHANNELS][32];
    double t[SUMMARY_CHANNELS], r[SUMMARY_CHANNELS]; /* NAN where not computed */
    char warnings[512];
};

/* What every stack needs, the same for all. */
struct batch {
    const char *sub, *path;
    struct batch_line *lines;
    size_t nlines;
    char **specs;
    size_t nspecs;
    struct cli_layers all; /* layers[i] for specs[i] (under MPI: NULL until a stack needs it) */
    struct cli_stack_args args;
    int argc;    /* the command as the metadata records it: without -j, --summary, --resume */
    char **argv;
    int resume;
    int progress; /* draw the progress line after each stack (-j 1 on a terminal) */
    int quiet;    /* no standard output line per stack (under MPI rank 0 prints them) */
    struct timespec start;
};

/* The batch's options (argv[0] is "batch"), into b (b->sub set by the caller; b->argv, b->argc:
 * the recorded command, to free) and *jobs, *summary.  mpi_help: NULL for `bsdfstack batch`;
 * else bsdfstack-mpi's --help, and -j is refused (the ranks take its place).  CLI_OK to go on,
 * CLI_USAGE after a usage error, -1 after --help was printed (exit 0). */
int batch_options(int argc, char **argv, struct batch *b, int *jobs, const char **summary,
                  const char *mpi_help);
/* Every file the batch writes is a different one, compared by what the paths name (cli_out_key),
 * not by their spelling: the outputs of bf's lines, --summary (NULL: none), and none of them the
 * batch file at path itself.  CLI_OK, or one error line naming the two (exit status 1). */
int batch_check_outputs(const char *sub, const char *path, const struct batch_file *bf,
                        const char *summary);
/* Remove the temporaries (OUT.tmpXXXXXX) that writers of lines[0..n-1]'s outputs left behind,
 * killed (bst_output_clean), saying how many on stderr: --resume, and a worker that died.  CLI_OK
 * or one error line (out of memory). */
int batch_clean_temporaries(bst_ctx *ctx, const struct batch *b, const struct batch_line *lines,
                            size_t n);
/* Seconds since t0 (CLOCK_MONOTONIC). */
double batch_since(const struct timespec *t0);
/* "batch-key: fnv1a64 HEX" of line sl into key[0..size-1]. */
void batch_key(const struct batch *b, const struct batch_line *sl, char *key, size_t size);
/* Whether path is a regular file, complete, holding key_text (--resume may skip its stack); a
 * FIFO or device is never read (opened without waiting, then passed over). */
int batch_up_to_date(const char *path, const char *key_text);
/* Combine and write one stack, or skip it (--resume); ST_OK, ST_SKIPPED, or ST_FAILED after one
 * error line naming FILE:LINE.  The result goes to r.  The layers b->all.layers[sl->layer[i]]
 * must be loaded. */
int batch_run_stack(bst_ctx *ctx, const struct batch *b, const struct batch_line *sl,
                    struct stack_result *r);
/* The standard output line of a stack: OUT, T, R of the first channel, seconds; or OUT skipped. */
void batch_print_result(const struct batch *b, const struct batch_line *sl,
                        const struct stack_result *r, int state);
/* The progress line on stderr (a terminal); last: erase it. */
void batch_progress(const struct batch *b, size_t done, size_t failed, size_t skipped, int last);
/* The --summary table from res[0..b->nlines-1], committed to o. */
int batch_write_summary(struct cli_out *o, const struct batch *b, const struct stack_result *res);
/* "FILE: N of M stacks failed (line L, ...; reported above)"; CLI_FAIL. */
int batch_report_failures(const struct batch *b, const struct stack_result *res, size_t failed);
/* The CPUs this process may run on. */
int batch_cores(void);

#endif
