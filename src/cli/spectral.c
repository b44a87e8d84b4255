/* spectral.c - a stack per wavelength or per channel, as the library's plan decides
 * (bst_plan_spectral), and the per-wavelength combination and columns run from the program's
 * loaded layers (layers.h). */
#include <config.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "cli.h"
#include "layers.h"

/* A layer read from a file (not a pane: its name is not glass:...). */
static int is_file_layer(const bst_layer *l)
{
    const char *name = bst_layer_name(l);
    return !name || strncmp(name, "glass:", 6) != 0;
}

int cli_spectral_plan(bst_ctx *ctx, const char *sub, struct cli_layers *set, int per_channel,
                      char *why, size_t size)
{
    bst_plan_layer *pl = calloc(set->n + 1, sizeof *pl);
    if (!pl) {
        cli_fail(sub, "out of memory");
        return -1;
    }
    for (size_t i = 0; i < set->n; i++)
        pl[i] = (bst_plan_layer){set->layers[i], set->panes[i], is_file_layer(set->layers[i])};
    int spectral = 0, st = bst_plan_spectral(ctx, set->n, pl, per_channel, why, size, &spectral,
                                             &set->plan_warn);
    free(pl);
    if (st < 0) {
        cli_fail_ctx(sub, NULL, ctx);
        return -1;
    }
    return spectral;
}

int cli_combine_spectral(bst_ctx *ctx, const char *sub, const struct cli_layers *set,
                         const bst_spectral_opts *sp, const bst_stack_opts *so, double *abs[2],
                         bst_layer **sys)
{
    const char **names = malloc((bst_layer_nchannels(set->layers[0]) + 1) * sizeof *names);
    bst_spectral_layer *l = calloc(set->n, sizeof *l);
    if (!names || !l) {
        free(names), free(l);
        return cli_fail(sub, "out of memory");
    }
    size_t nch = bst_plan_channels(set->n, (const bst_layer *const *)set->layers, names);
    for (size_t i = 0; i < set->n; i++) {
        l[i].pane = set->panes[i];
        l[i].bands = set->panes[i] ? NULL : set->layers[i];
    }
    int st = bst_stack_combine_spectral_layers(ctx, set->n, l, set->basis, nch, names, sp, so,
                                               sys, abs[0], abs[1]);
    free(names), free(l);
    if (st < 0)
        return cli_fail_ctx(sub, "combining per wavelength", ctx);
    cli_warn_ctx(sub, NULL, st, ctx);
    return CLI_OK;
}

int cli_columns_spectral(bst_ctx *ctx, const char *sub, const struct cli_layers *set,
                         const bst_spectral_opts *sp, const char *channel, size_t ncols,
                         const size_t *cols, bst_columns_opts *o, bst_mat **tf, bst_mat **rf)
{
    bst_spectral_layer *l = calloc(set->n, sizeof *l);
    if (!l)
        return cli_fail(sub, "out of memory");
    for (size_t i = 0; i < set->n; i++) {
        l[i].pane = set->panes[i];
        l[i].bands = set->panes[i] ? NULL : set->layers[i];
    }
    int st = bst_stack_columns_spectral_layers(ctx, set->n, l, set->basis, channel, sp, ncols, cols,
                                               o, tf, rf);
    free(l);
    if (st < 0)
        return cli_fail_ctx(sub, "iterating per wavelength", ctx);
    cli_warn_ctx(sub, NULL, st, ctx);
    return CLI_OK;
}

int cli_note_spectral(const char *sub, struct cli_layers *set, const char *why, int verbose)
{
    if (verbose)
        fprintf(stderr, "bsdfstack %s: spectral: %s\n", sub, why);
    else if (set->plan_warn) /* not what a user of --channels Solar expects: say so */
        fprintf(stderr, "bsdfstack %s: warning: %s\n", sub, why);
    char *d = realloc(set->description, strlen(set->description) + strlen(why) + 12);
    if (!d)
        return cli_fail(sub, "out of memory");
    strcat(d, "\nspectral: ");
    strcat(d, why);
    set->description = d;
    return CLI_OK;
}
