/* run.c - the run step of `combine` and `batch`: the library's plan decides how the stack is
 * combined (per wavelength or by band values per channel, bst_plan_spectral, with its reason kept
 * in the output's metadata), then the stack is combined that way, per-layer absorptance beside it
 * when asked.  Both commands go parse -> load -> cli_combine_run -> write. */
#include <config.h>

#include <stdio.h>
#include <stdlib.h>

#include "cli.h"
#include "layers.h"

/* Per-layer absorptance of every channel of sys: abs[side][(ch * n + i) * N + j]. */
static int absorptance(bst_ctx *ctx, const char *sub, const struct cli_layers *set,
                       const bst_layer *sys, const bst_stack_opts *so, double *const abs[2])
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

int cli_combine_run(bst_ctx *ctx, const char *sub, const char *where, struct cli_layers *set,
                    const struct cli_stack_args *args, const struct cli_run_opts *ro, bst_layer **sys)
{
    *sys = NULL;
    char why[2048];
    int spectral = cli_spectral_plan(ctx, sub, set, args->per_channel, why, sizeof why);
    if (spectral < 0)
        return CLI_FAIL;
    set->spectral = spectral;
    int rc = cli_note_spectral(sub, set, why, ro->verbose);
    if (rc == CLI_OK && spectral) {
        double *abs[2] = {ro->abs[0], ro->abs[1]};
        bst_stack_opts so = args->so;
        if (ro->spectral_step)
            so.on_step = ro->spectral_step;
        rc = cli_combine_spectral(ctx, sub, set, &args->sp, &so, abs, sys);
    } else if (rc == CLI_OK) {
        /* a stack whose layers die with the combination lets it free each component at its last
         * use (a pane and a dense layer at k = 7: 12 instead of 20 GiB in double) */
        int st = ro->consume && !ro->abs[0]
                     ? bst_stack_combine_consume(ctx, set->n, set->layers, &args->so, sys)
                     : bst_stack_combine(ctx, set->n, (const bst_layer *const *)set->layers,
                                         &args->so, sys);
        if (st < 0)
            return cli_fail_ctx(sub, where ? where : "combining", ctx);
        if (st > 0 && ro->warning) {
            const char *msg = bst_ctx_message(ctx);
            snprintf(ro->warning, ro->warning_size, "%s", msg && *msg ? msg : bst_strerror(st));
        }
        cli_warn_ctx(sub, where, st, ctx);
        if (ro->abs[0])
            rc = absorptance(ctx, sub, set, *sys, &args->so, ro->abs);
    }
    if (rc != CLI_OK) {
        bst_layer_free(*sys);
        *sys = NULL;
    }
    return rc;
}
