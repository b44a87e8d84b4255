/* cli.h - shared pieces of the bsdfstack program: the subcommand table, error reporting, output
 * files and standard output's errors.  Every subcommand is a function in its own file,
 * cmd_<name>.c. */
#ifndef BST_CLI_H
#define BST_CLI_H

#include <stdio.h>
#include <sys/types.h>
#include "bsdfstack.h"

/* Exit statuses of the program. */
enum { CLI_OK = 0, CLI_FAIL = 1, CLI_USAGE = 2 };

struct cli_command {
    const char *name;
    int (*run)(int argc, char **argv); /* argv[0] is the subcommand name */
    const char *summary;
};

/* Every subcommand (the table is in main.c; each function in its cmd_<name>.c). */
extern const struct cli_command cli_commands[];
int cmd_version(int argc, char **argv);
int cmd_query(int argc, char **argv);
int cmd_glass(int argc, char **argv);
int cmd_combine(int argc, char **argv);
int cmd_convert(int argc, char **argv);
int cmd_info(int argc, char **argv);
int cmd_compare(int argc, char **argv);
int cmd_batch(int argc, char **argv);
int cmd_plot(int argc, char **argv);
int cmd_view(int argc, char **argv);

/* A pane's source, angular model and why, and what its file says of it (cmd_glass.c): as # lines
 * of `bsdfstack glass` (each line starts with prefix), or as one line into buf[0..size-1]
 * ("coated model (from the type Coated); source optics PATH; product ...; thickness ...") for
 * `info` and the header of a file that combines the pane. */
void cli_glass_describe(FILE *fp, const bst_glass *g, const char *prefix);
void cli_glass_summary(const bst_glass *g, char *buf, size_t size);

/* "bsdfstack SUB: message" on stderr, one line.  Returns CLI_FAIL. */
int cli_fail(const char *sub, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* Usage error: the message and a pointer to --help.  Returns CLI_USAGE. */
int cli_usage(const char *sub, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* Report a library error from ctx ("bsdfstack SUB: WHAT: message"; WHAT once where the message
 * starts with it, or with its part after the last ": ").  Returns CLI_FAIL. */
int cli_fail_ctx(const char *sub, const char *what, bst_ctx *ctx);
/* Print library warnings held by ctx after a call that returned status > 0. */
/* What the reader read other than the file states (a tree averaged to BST_K_MAX, negative
 * values read as 0), one warning line each. */
void cli_warn_bsdf(const char *sub, const char *path, const bst_bsdf *b);
void cli_warn_ctx(const char *sub, const char *what, int status, bst_ctx *ctx);

/* A context with a terminal progress bar on stderr when stderr is a terminal. */
bst_ctx *cli_ctx_new(const char *sub);

/* An output file, as every subcommand writes one (-o, --absorptance, --map, batch lines): a regular
 * file (or a new one) is written to a temporary beside it and renamed over it on commit, keeping
 * its mode and, where allowed, its owner; a symbolic link is followed, so that the link survives
 * and the file it names is replaced the same way; a device, FIFO or socket is written directly;
 * a directory is an error; "-" is standard output. */
struct cli_out {
    FILE *fp;        /* bst_output_file(out), or stdout */
    bst_output *out; /* NULL for standard output */
    bst_ctx *ctx;    /* out's messages */
    char *path;      /* as given, for messages; NULL for standard output */
    int held;        /* the temporary's slot for a signal (interrupt.h) + 1; 0: none */
};
/* Open path for writing; CLI_OK, or one error line printed and nothing left behind. */
int cli_out_open(struct cli_out *o, const char *sub, const char *path);
/* Flush and check for write errors so far; on one, report it and abort (a file that must not be
 * renamed into place before another is written checks its own content with this first). */
int cli_out_flush(struct cli_out *o, const char *sub);
/* Flush, close and rename into place; on any failure (a write error named with its reason) remove
 * the temporary and fail. */
int cli_out_commit(struct cli_out *o, const char *sub);
/* A library writer's failure on o (its message in ctx), named by path or as standard output, then
 * cli_out_abort.  Returns CLI_FAIL. */
int cli_out_fail_ctx(struct cli_out *o, const char *sub, bst_ctx *ctx);
/* Remove the temporary (on an error path). Safe to call after commit or on a zeroed struct. */
void cli_out_abort(struct cli_out *o);
/* Which file an output path writes, as a string to compare (malloc'd; NULL when out of memory):
 * "-" for standard output, else bst_output_key's (file or directory identity), else, where the
 * path names nothing that can be found (its write will fail and say why), the path itself.
 * Outputs of one command are compared by these, never by their spelling. */
char *cli_out_key(const char *path);
/* 1 when paths a and b write one file (cli_out_key), 0 when not, -1 when out of memory. */
int cli_out_same(const char *a, const char *b);

/* Standard output's write errors: "bsdfstack SUB: error writing to standard output: REASON",
 * printed once per run however many writes fail.  cli_stdout_failed reports errno e of a write that just
 * failed; cli_stdout_check flushes and reports an error of this or any earlier write (main calls
 * it after every command).  Both return CLI_FAIL on an error, cli_stdout_check CLI_OK otherwise. */
int cli_stdout_failed(const char *sub, int e);
int cli_stdout_check(const char *sub);

/* Keep a standard stream the caller closed (<&-, >&-, 2>&-) closed in effect: its descriptor is
 * taken by /dev/null opened the wrong way round, so that using it fails with EBADF as it would
 * have, and no file the program opens (an output, its temporary) lands on 0, 1 or 2. */
void cli_hold_std_fds(void);
/* Stop OpenBLAS's idle worker threads, which spin for about 0.1 s after their last job (cli.c);
 * only when no BLAS call is in flight. */
void cli_blas_rest(void);
/* At the start: OpenBLAS's workers to spin about 0.3 ms after a job instead of 0.1 s, unless the
 * user's OPENBLAS_THREAD_TIMEOUT says otherwise (cli.c), then cli_blas_rest. */
void cli_blas_setup(void);
/* First thing in main: where OpenBLAS picked kernels without AVX2 on a CPU that has it (cli.c),
 * and the user did not set OPENBLAS_CORETYPE, set it and run the program again (returns only when
 * nothing is to be done or that failed). */
void cli_blas_kernels(char **argv);
/* -v: one line on standard error naming OpenBLAS's kernels (and its own pick, where overruled). */
void cli_blas_note(const char *sub);

/* One line of a text input (getline: any length, into *buf, its newline kept): its length, -1 at
 * the end of the input (or a read error: ferror says), or -2 after one error line "NAME:LN: a NUL
 * byte at column C" (what followed a NUL would be dropped unseen by string functions). */
ssize_t cli_read_line(const char *sub, const char *name, long ln, char **buf, size_t *cap, FILE *fp);

/* Parse a double / int option value strictly (the whole string, finite). 0 on success. */
int cli_parse_double(const char *s, double *out);
int cli_parse_int(const char *s, int *out);
/* Is argv[*i] a --threads option (its value skipped: *i advanced past "--threads N")?  The thread
 * count changes no output byte, so the command line recorded in a file leaves it out. */
int cli_threads_arg(int argc, char **argv, int *i);

/* --only LIST (comma-separated Tf, Rf, Tb, Rb) into a BST_COMP_BIT mask; --precision double|single.
 * CLI_OK or a usage error (printed). */
int cli_parse_comps(const char *sub, const char *list, unsigned *comps);
int cli_parse_precision(const char *sub, const char *s, bst_precision *prec);
/* A file named by an option or argument (what: "-o", "--absorptance", "the input file"): CLI_OK,
 * or the usage error "WHAT '': an empty file name" (printed), as every other malformed option
 * value is one (exit 2; it failed with 1, after the work where the output was opened last). */
int cli_parse_path(const char *sub, const char *what, const char *path);
/* --channels NAMES (comma-separated) or --channel NAME: CLI_OK, or a usage error when the value
 * names no channel or holds an empty name ("", ",", "Visible,,Solar"): it was taken as "every
 * channel" or as the first. */
int cli_parse_channels(const char *sub, const char *opt, const char *list);
/* --incident THETA,PHI (degrees, 0 <= THETA < 90) into dir[0], dir[1]; CLI_OK or a usage error. */
int cli_parse_incident(const char *sub, const char *s, double dir[2]);

/* Theta and phi (degrees, phi in [0, 360)) of the centre of patch p of b (bst_basis_center): the
 * exit direction of every TSV the program writes. */
void cli_patch_direction(const bst_basis *b, size_t p, double *theta, double *phi);
/* The incident patch of b for light propagating at (theta, phi) (degrees; theta clamped below 90):
 * a direction on a patch boundary takes the patch on its +x, +y side (1e-9 added to x and y), the
 * rule of info's table, which plot's map and curves share. */
size_t cli_incident_patch(const bst_basis *b, double theta, double phi);

/* Print a subcommand's help text (the same text as its man page's synopsis and options). */
void cli_print_help(FILE *fp, const char *text);

#endif
