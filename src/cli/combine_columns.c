/* combine_columns.c - `combine --incident`: only the columns of the asked incidence directions,
 * the light iterated between the layers (bst_stack_columns: O(N^2) a direction instead of the
 * whole system's O(N^3)), written as TSV (incident_tsv.h's header). */
#include <config.h>

#include <math.h>
#include <stdio.h>

#include "combine.h"
#include "incident_tsv.h"

#define COLUMN_BATCH 64 /* iterated together: N x 64 blocks */

/* --incident: the columns of the asked directions (light propagating along (theta, phi)) of the
 * components comps, front and back incidence each iterated once (bst_stack_columns), as TSV. */
static int write_columns(bst_ctx *ctx, const char *sub, FILE *fp, const struct cli_layers *set,
                         const bst_spectral_opts *sp, unsigned comps, size_t ndirs,
                         const double (*dirs)[2], int verbose)
{
    size_t N = bst_basis_size(set->basis), cols[COLUMN_BATCH];
    for (size_t q = 0; q < ndirs; q++) /* off cell boundaries onto the +x, +y side, as compare */
        cols[q] = cli_incident_patch(set->basis, dirs[q][0], dirs[q][1]);
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

/* Every direction, COLUMN_BATCH at a time. */
int combine_columns(bst_ctx *ctx, const char *sub, const char *path, const struct cli_layers *set,
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

