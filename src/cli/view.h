/* view.h - `bsdfstack view` (cmd_view.c): the files loaded over one basis, and the page written
 * from them (view_data.c: the data as JSON inside the page of src/cli/view/). */
#ifndef BST_CLI_VIEW_H
#define BST_CLI_VIEW_H

#include <stdio.h>
#include "bsdfstack.h"

struct cli_view_file {
    const char *path;
    bst_bsdf *b;
    bst_layer *l;      /* over the view's basis */
    char format[128];  /* as stored: "TensorTree4, k = 6", "Klems, LBNL/Klems Full" */
};

struct cli_view {
    size_t nfiles;
    struct cli_view_file *files;
    const bst_basis *basis;   /* every layer's */
    size_t nchannels;         /* those every file holds, in the first file's order */
    const char **channels;
    size_t ncols;             /* the incident patches embedded: cols[0..ncols-1] */
    const size_t *cols;       /* NULL: every patch (ncols = the basis's size) */
    const char *note;         /* what the page says of the resolution, or NULL */
};

/* Bytes the page's data will take: every component of every file and channel over the basis
 * and columns, dense (float32) or sparse (CSC) as its structure is, in base64. */
double cli_view_data_size(const struct cli_view *v);

/* The page: page.html with view.css, the data and view.js in place.  CLI_OK, or one error line
 * (a value that is no BSDF, out of memory) and CLI_FAIL; write errors are the caller's
 * (ferror). */
int cli_view_write(bst_ctx *ctx, const char *sub, FILE *fp, const struct cli_view *v);

#endif
