/* cmd_batch.c - `bsdfstack batch FILE`: many stacks, one per line, every distinct layer loaded once
 * onto one basis; each system written as `combine` writes it. */
#include <config.h>

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "batch_file.h"
#include "cli.h"
#include "layers.h"

static const char help[] =
    "Usage: bsdfstack batch [-k K | --klems[=full|half|quarter]] [--only Tf,Rf,Tb,Rb]\n"
    "                       [--channels NAMES] [--precision double|single] [--drop-tol X]\n"
    "                       [--reduce PCT | --no-reduce] [--dense] [--per-channel] [--strict]\n"
    "                       FILE\n"
    "Combines many stacks, one per line of FILE ('-' = standard input):\n"
    "  OUT LAYER LAYER...\n"
    "the output file, then the layers, exterior first, as `bsdfstack combine` takes them\n"
    "(FILE.xml, glass:SPEC, a trailing ^ for a reversed layer); words are separated by blanks, so\n"
    "paths must not contain any.  Blank lines and lines starting with # are skipped; relative\n"
    "paths are taken from the current directory.  Every distinct layer is loaded once, onto one\n"
    "basis for the whole batch (-k, --klems, or the finest tensor-tree order among the batch's\n"
    "files, else 5), and kept until the end.  The whole file and every layer are checked before\n"
    "the first stack is combined.  A stack that fails is reported with its line number and the\n"
    "others go on; the exit status is then 1.  Each system is written as `combine -o OUT` writes\n"
    "it (atomically; its metadata names the layers and the batch line), and one line per stack on\n"
    "standard output gives OUT, the front T and R at normal incidence of the first channel\n"
    "(- where not computed) and the seconds taken.\n"
    "\n"
    "Options: as for `bsdfstack combine`.\n";

/* Read FILE ('-' = standard input) into stack lines and distinct layer specs.  CLI_OK or one
 * error line. */
static int parse_file(const char *sub, const char *path, struct batch_file *bf)
{
    memset(bf, 0, sizeof *bf);
    FILE *fp = strcmp(path, "-") == 0 ? stdin : fopen(path, "r");
    if (!fp)
        return cli_fail(sub, "%s: cannot open: %s", path, strerror(errno));
    char *err = NULL;
    int rc = CLI_OK;
    if (batch_file_parse(fp, path, bf, &err) < 0)
        rc = cli_fail(sub, "%s", err ? err : "out of memory");
    free(err);
    if (fp != stdin)
        fclose(fp);
    return rc;
}

/* Combine and write one stack; CLI_OK or one error line naming FILE:LINE. */
static int run_stack(bst_ctx *ctx, const char *sub, const char *path, const struct batch_line *sl,
                     const struct cli_layers *all, char *const *specs, const bst_stack_opts *so,
                     int per_channel, double reduce, int argc, char **argv)
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
    int spectral = !per_channel && view.npanes == view.n;
    if (rc == CLI_OK)
        rc = cli_note_spectral(sub, &view, spectral, per_channel);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    if (rc == CLI_OK && spectral) {
        double *abs[2] = {NULL, NULL};
        if (cli_combine_spectral(ctx, sub, &view, so, abs, &sys) != CLI_OK)
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
        fflush(stdout);
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
    struct batch_file bf;
    int rc = parse_file(sub, path, &bf);
    bst_ctx *ctx = rc == CLI_OK ? cli_ctx_new(sub) : NULL;
    if (rc == CLI_OK && !ctx)
        rc = CLI_FAIL;
    struct cli_layers all;
    memset(&all, 0, sizeof all);
    if (rc == CLI_OK)
        rc = cli_layers_load(&all, ctx, sub, bf.nspecs, bf.specs, &args.basis, args.channels, 0,
                             args.so.precision);
    size_t failed = 0;
    for (size_t i = 0; rc == CLI_OK && i < bf.nlines; i++)
        if (run_stack(ctx, sub, path, &bf.lines[i], &all, bf.specs, &args.so, args.per_channel,
                      args.reduce, argc, argv) != CLI_OK) {
            failed++;
            bst_ctx_clear(ctx);
        }
    if (rc == CLI_OK && failed)
        rc = cli_fail(sub, "%s: %zu of %zu stacks failed (reported above)", path, failed, bf.nlines);
    if (all.layers)
        cli_layers_free(&all);
    batch_file_free(&bf);
    bst_ctx_free(ctx);
    return rc;
}
