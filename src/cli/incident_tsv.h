/* incident_tsv.h - reading the TSV that `combine --incident` writes (one row per channel,
 * component, incident direction and exit patch: channel, comp, theta_in, phi_in, patch_in,
 * patch_out, theta_out, phi_out, BSDF, DSF) back into columns over the basis it was made in. */
#ifndef BST_CLI_INCIDENT_TSV_H
#define BST_CLI_INCIDENT_TSV_H

#include <stddef.h>
#include "bsdfstack.h"

/* The header line combine writes. */
#define CLI_TSV_HEADER "channel\tcomp\ttheta_in\tphi_in\tpatch_in\tpatch_out\ttheta_out\tphi_out\tBSDF\tDSF"

/* One column: the BSDF of (channel, comp) for light propagating along (theta, phi) (degrees),
 * incident patch patch_in, over every exit patch. */
struct cli_tsv_col {
    char *channel;
    bst_comp comp;
    double theta, phi;
    size_t patch_in;
    double *bsdf; /* n values */
};

struct cli_tsv {
    bst_basis *basis; /* identified from the rows: n = 4^k Shirley-Chiu, or a Klems basis, checked
                         against every row's exit direction */
    size_t n;
    size_t ncols;
    struct cli_tsv_col *cols;
};

/* The basis with n patches per hemisphere (4^k: Shirley-Chiu of order k; 145, 77, 41: Klems full,
 * half, quarter), made in ctx; NULL when none has n (or out of memory). */
bst_basis *cli_tsv_basis_of(bst_ctx *ctx, size_t n);
/* 1 when the file at path (not "-") begins with CLI_TSV_HEADER, 0 otherwise (also when it cannot be
 * read: the BSDF reader then says why). */
int cli_tsv_detect(const char *path);
/* Read the whole file; CLI_OK, or one error line naming the file (and line) and CLI_FAIL. */
int cli_tsv_read(const char *sub, bst_ctx *ctx, const char *path, struct cli_tsv *t);
void cli_tsv_free(struct cli_tsv *t);
/* A layer over t->basis with one channel `channel` whose component c holds the columns of t of that
 * channel and component at their incident patches (zero elsewhere); the first column of a patch
 * wins.  Components t lacks are absent.  CLI_OK or an error line. */
int cli_tsv_layer(const char *sub, bst_ctx *ctx, const struct cli_tsv *t, const char *channel,
                  bst_layer **out);

#endif
