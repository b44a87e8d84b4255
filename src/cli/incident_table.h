/* incident_table.h - reading back the TSV that `bsdfstack combine --incident` writes (columns
 * channel, comp, theta_in, phi_in, patch_in, patch_out, theta_out, phi_out, BSDF, DSF; one row
 * per exit patch, per direction, component and channel; see bsdfstack-combine(1)): one column of
 * it, with the basis its exit patches belong to. */
#ifndef BST_CLI_INCIDENT_TABLE_H
#define BST_CLI_INCIDENT_TABLE_H

#include "bsdfstack.h"
#include "incident_tsv.h" /* CLI_TSV_HEADER, the header line; the whole-file reader compare uses */

/* 1 when path names such a table: its name ends in .tsv, or its first line starts like the
 * header; 0 otherwise (a BSDF XML file, or one that cannot be read: the XML reader says why). */
int cli_incident_table_is(const char *path);

/* One column of a table: channel NULL = the first channel in the file, comp, and the incidence
 * direction dir (theta, phi, degrees, as combine printed them, to 6 significant digits), or the
 * first direction of that channel and component when dir is NULL. */
struct cli_incident_column {
    char channel[64];
    bst_comp comp;
    double theta_in, phi_in;
    bst_basis *basis; /* the exit patches' basis (Shirley-Chiu 4^k, or Klems full, half, quarter) */
    double *bsdf;     /* BSDF (1/sr) per exit patch, bst_basis_size(basis) values */
    bst_ctx *ctx;     /* the basis's */
};

/* Read the column; CLI_OK, or one error line printed (file and line, and what is wrong: a header
 * or row with other columns, a value that is not a number, no such channel, component or
 * direction, exit patches that do not cover a basis) and CLI_FAIL. */
int cli_incident_column_read(const char *sub, const char *path, const char *channel, bst_comp comp,
                             const double *dir, struct cli_incident_column *col);
void cli_incident_column_free(struct cli_incident_column *col);

#endif
