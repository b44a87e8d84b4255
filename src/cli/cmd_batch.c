/* cmd_batch.c - `bsdfstack batch FILE`: many stacks, one per line, every distinct layer loaded once
 * onto one basis; each system written as `combine` writes it. */
#include <config.h>

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cli.h"
#include "layers.h"

static const char help[] =
    "Usage: bsdfstack batch [-k K | --klems[=full|half|quarter]] [--only Tf,Rf,Tb,Rb]\n"
    "                       [--channels NAMES] [--precision double|single] [--drop-tol X]\n"
    "                       [--reduce PCT | --no-reduce] [--dense] [--per-channel]\n"
    "                       [--spectral-tol X] [--glass-rule average|centre] [--strict]\n"
    "                       [--max-memory SIZE] FILE\n"
    "Combines many stacks, one per line of FILE ('-' = standard input):\n"
    "  OUT LAYER LAYER...\n"
    "the output file, then the layers, exterior first, as `bsdfstack combine` takes them\n"
    "(FILE.xml, glass:SPEC, a trailing ^ for a reversed layer); words are separated by blanks, so\n"
    "paths must not contain any.  Blank lines and lines starting with # are skipped; relative\n"
    "paths are taken from the current directory.  Every distinct layer is loaded once, onto one\n"
    "basis for the whole batch (-k, --klems; else the finest tensor-tree order among the batch's\n"
    "files; with no tree the Klems basis of the first Klems file; with panes only k = 5), and\n"
    "kept until the end.  The whole file and every layer are checked before the first stack is\n"
    "combined.  A stack that fails is reported with its line number and the others go on; the\n"
    "exit status is then 1.  Each system is written as `combine -o OUT` writes it (a regular file\n"
    "atomically; its metadata names the layers and the batch line), and one line per stack on\n"
    "standard output gives OUT, the front T and R at normal incidence of the first channel\n"
    "(- where not computed) and the seconds taken.\n"
    "\n"
    "Options: as for `bsdfstack combine`.\n";

struct stack_line {
    size_t lineno;
    char *out;
    size_t n;
    size_t *layer; /* indices into the distinct layer specs */
};

/* Index of spec among the distinct ones, adding it when new; (size_t)-1 when out of memory. */
static size_t spec_index(char ***specs, size_t *nspecs, size_t *cap, const char *spec)
{
    for (size_t i = 0; i < *nspecs; i++)
        if (strcmp((*specs)[i], spec) == 0)
            return i;
    if (*nspecs == *cap) {
        size_t nc = *cap ? 2 * *cap : 16;
        char **s = realloc(*specs, nc * sizeof *s);
        if (!s)
            return (size_t)-1;
        *specs = s, *cap = nc;
    }
    if (!((*specs)[*nspecs] = strdup(spec)))
        return (size_t)-1;
    return (*nspecs)++;
}

/* Read FILE into stack lines and distinct layer specs.  CLI_OK or one error line. */
static int parse_file(const char *sub, const char *path, struct stack_line **lines, size_t *nlines,
                      char ***specs, size_t *nspecs)
{
    FILE *fp = strcmp(path, "-") == 0 ? stdin : fopen(path, "r");
    if (!fp)
        return cli_fail(sub, "%s: cannot open: %s", path, strerror(errno));
    size_t cap_lines = 0, cap_specs = 0, lineno = 0;
    char *buf = NULL;
    size_t bufsize = 0;
    int rc = CLI_OK;
    *lines = NULL, *nlines = 0, *specs = NULL, *nspecs = 0;
    while (rc == CLI_OK && getline(&buf, &bufsize, fp) >= 0) {
        lineno++;
        char *save = NULL, *w = strtok_r(buf, " \t\r\n", &save);
        if (!w || w[0] == '#')
            continue;
        if (*nlines == cap_lines) {
            size_t nc = cap_lines ? 2 * cap_lines : 16;
            struct stack_line *l = realloc(*lines, nc * sizeof *l);
            if (!l) {
                rc = cli_fail(sub, "out of memory");
                break;
            }
            *lines = l, cap_lines = nc;
        }
        struct stack_line *sl = &(*lines)[*nlines];
        memset(sl, 0, sizeof *sl);
        sl->lineno = lineno;
        (*nlines)++;
        if (!(sl->out = strdup(w))) {
            rc = cli_fail(sub, "out of memory");
            break;
        }
        size_t cap = 0;
        while ((w = strtok_r(NULL, " \t\r\n", &save))) {
            if (sl->n == cap) {
                size_t nc = cap ? 2 * cap : 4, *l = realloc(sl->layer, nc * sizeof *l);
                if (!l) {
                    rc = cli_fail(sub, "out of memory");
                    break;
                }
                sl->layer = l, cap = nc;
            }
            size_t k = spec_index(specs, nspecs, &cap_specs, w);
            if (k == (size_t)-1) {
                rc = cli_fail(sub, "out of memory");
                break;
            }
            sl->layer[sl->n++] = k;
        }
        if (rc == CLI_OK && sl->n == 0)
            rc = cli_fail(sub, "%s:%zu: no layers after the output file '%s': give OUT LAYER LAYER...",
                          path, lineno, sl->out);
        for (size_t i = 0; rc == CLI_OK && i + 1 < *nlines; i++)
            if (strcmp((*lines)[i].out, sl->out) == 0)
                rc = cli_fail(sub, "%s:%zu: '%s' is written by line %zu already", path, lineno, sl->out,
                              (*lines)[i].lineno);
    }
    if (rc == CLI_OK && ferror(fp))
        rc = cli_fail(sub, "%s: read error: %s", fp == stdin ? "standard input" : path,
                      strerror(errno ? errno : EIO));
    if (rc == CLI_OK && *nlines == 0)
        rc = cli_fail(sub, "%s: no stacks: give one line OUT LAYER LAYER... per stack", path);
    free(buf);
    if (fp != stdin)
        fclose(fp);
    return rc;
}

/* Combine and write one stack; CLI_OK or one error line naming FILE:LINE. */
static int run_stack(bst_ctx *ctx, const char *sub, const char *path, const struct stack_line *sl,
                     const struct cli_layers *all, char *const *specs, const bst_spectral_opts *sp,
                     const bst_stack_opts *so, int per_channel, double reduce, int argc, char **argv)
{
    char where[512];
    snprintf(where, sizeof where, "%s:%zu", path, sl->lineno);
    struct cli_layers view = {.n = sl->n, .basis = all->basis};
    view.layers = malloc(sl->n * sizeof *view.layers);
    view.panes = malloc(sl->n * sizeof *view.panes);
    size_t len = 128 + strlen(path);
    for (size_t i = 0; i < sl->n; i++)
        len += strlen(specs[sl->layer[i]]) + 2;
    view.description = malloc(len);
    bst_layer *sys = NULL;
    int rc = view.layers && view.panes && view.description ? CLI_OK : cli_fail(sub, "out of memory");
    if (rc == CLI_OK) {
        snprintf(view.description, len, "layers (exterior first):");
        for (size_t i = 0; i < sl->n; i++) {
            strcat(view.description, i ? ", " : " ");
            strcat(view.description, specs[sl->layer[i]]);
            view.layers[i] = all->layers[sl->layer[i]];
            view.panes[i] = all->panes[sl->layer[i]];
            view.npanes += view.panes[i] != NULL;
        }
        snprintf(view.description + strlen(view.description), len - strlen(view.description),
                 "\nbatch: %s line %zu", path, sl->lineno);
    }
    char why[2048];
    int spectral = rc == CLI_OK && cli_spectral_plan(&view, per_channel, why, sizeof why);
    if (rc == CLI_OK)
        rc = cli_note_spectral(sub, &view, why, 0);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    if (rc == CLI_OK && spectral) {
        double *abs[2] = {NULL, NULL};
        if (cli_combine_spectral(ctx, sub, &view, sp, so, abs, &sys) != CLI_OK)
            rc = CLI_FAIL;
    } else if (rc == CLI_OK) {
        int st = bst_stack_combine(ctx, view.n, (const bst_layer *const *)view.layers, so, &sys);
        if (st < 0)
            rc = cli_fail_ctx(sub, where, ctx);
        else
            cli_warn_ctx(sub, where, st, ctx);
    }
    if (rc == CLI_OK)
        rc = cli_write_layer(ctx, sub, sys, sl->out, reduce, argc, argv, &view);
    if (rc == CLI_OK) {
        const bst_basis *b = all->basis;
        size_t n = bst_basis_size(b);
        double normal[3] = {1e-9, 1e-9, 1.0}, *h = malloc(n * sizeof *h);
        size_t j = bst_basis_patch(b, normal);
        char t[32] = "-", r[32] = "-";
        if (h && bst_layer_get(sys, 0, BST_TF) && bst_layer_hemispherical(ctx, sys, 0, BST_TF, h) >= 0)
            snprintf(t, sizeof t, "%.4f", h[j]);
        if (h && bst_layer_get(sys, 0, BST_RF) && bst_layer_hemispherical(ctx, sys, 0, BST_RF, h) >= 0)
            snprintf(r, sizeof r, "%.4f", h[j]);
        free(h);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        printf("%s\tT %s\tR %s\t%.2f s\n", sl->out, t, r,
               (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec));
        /* the stack itself is written: a lost summary line fails the run (main), not the stack */
        if (fflush(stdout) != 0)
            cli_stdout_failed(sub, errno);
    }
    bst_layer_free(sys);
    free(view.layers), free(view.panes), free(view.description);
    return rc;
}

int cmd_batch(int argc, char **argv)
{
    enum { O_HELP = CLI_O_OWN };
    static const struct option longopts[] = {CLI_STACK_LONGOPTS, {"help", no_argument, NULL, O_HELP},
                                             {NULL, 0, NULL, 0}};
    const char *sub = "batch";
    struct cli_stack_args args;
    cli_stack_args_init(&args);
    int c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":k:h", longopts, NULL)) != -1) {
        int shared = cli_stack_option(sub, c, optarg, &args);
        if (shared == CLI_USAGE)
            return CLI_USAGE;
        if (shared == CLI_OK)
            continue;
        switch (c) {
        case 'h':
        case O_HELP: fputs(help, stdout); return CLI_OK;
        case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    if (argc - optind != 1)
        return cli_usage(sub, argc - optind < 1 ? "no batch file given" : "one batch file expected");
    const char *path = argv[optind];
    struct stack_line *lines = NULL;
    size_t nlines = 0, nspecs = 0;
    char **specs = NULL;
    int rc = parse_file(sub, path, &lines, &nlines, &specs, &nspecs);
    bst_ctx *ctx = rc == CLI_OK ? cli_ctx_new(sub) : NULL;
    if (rc == CLI_OK && !ctx)
        rc = CLI_FAIL;
    struct cli_layers all;
    memset(&all, 0, sizeof all);
    args.basis.combining = 1;
    args.basis.work = args.so.precision;
    args.basis.lower = "a lower -k, --precision single or --only";
    if (rc == CLI_OK)
        rc = cli_layers_load(&all, ctx, sub, nspecs, specs, &args.basis, args.channels, 0,
                             args.so.precision);
    size_t failed = 0;
    for (size_t i = 0; rc == CLI_OK && i < nlines; i++)
        if (run_stack(ctx, sub, path, &lines[i], &all, specs, &args.sp, &args.so, args.per_channel, args.reduce,
                      argc, argv) != CLI_OK) {
            failed++;
            bst_ctx_clear(ctx);
        }
    if (rc == CLI_OK && failed)
        rc = cli_fail(sub, "%s: %zu of %zu stacks failed (reported above)", path, failed, nlines);
    if (all.layers)
        cli_layers_free(&all);
    for (size_t i = 0; i < nlines; i++)
        free(lines[i].out), free(lines[i].layer);
    free(lines);
    for (size_t i = 0; i < nspecs; i++)
        free(specs[i]);
    free(specs);
    bst_ctx_free(ctx);
    return rc;
}
