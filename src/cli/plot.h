/* plot.h - `bsdfstack plot --curve` (plot_curve.c), called by cmd_plot.c once it has parsed the
 * options both figures share. */
#ifndef BST_CLI_PLOT_H
#define BST_CLI_PLOT_H

#include <stddef.h>
#include "bsdfstack.h"

struct cli_curve_opts {
    int ncomps;
    bst_comp comps[BST_NCOMP]; /* in the order asked; the first draws solid, the next dashed, .. */
    const char *channel;       /* NULL: every channel of the files, one panel each */
    double phi;                /* the plane of incidence: propagation azimuth, degrees */
    double ymin, ymax;         /* --range, or NAN: 0 to a round number above the largest value */
    double max_memory;         /* --max-memory (bytes), 0: the memory available now */
    int size;                  /* the chart's width in pixels (points) */
    int format;                /* CLI_DRAW_* */
    const char *outpath;       /* the figure; "-" standard output */
    const char *tsvpath;       /* the values as TSV, or NULL */
};

/* Directional-hemispherical values of the files' components against incidence theta, as steps
 * over their own patches, drawn in one chart per channel.  CLI_OK or one error line and CLI_FAIL
 * (nothing written). */
int cli_plot_curves(const char *sub, size_t nfiles, char **files, const struct cli_curve_opts *o);

#endif
