/* hemimap.h - a function over the exit hemisphere drawn as a disk with a colour scale (PNG, SVG
 * or PDF, with cairo), for `bsdfstack plot` and `bsdfstack compare --map`.  Conventions in
 * hemimap.c. */
#ifndef BST_CLI_HEMIMAP_H
#define BST_CLI_HEMIMAP_H

#include <stdio.h>
#include "bsdfstack.h"

struct cli_hemimap {
    const bst_basis *basis;  /* the cells an SVG or PDF draws */
    const double *cell;      /* the value of every cell (at its centre) */
    /* The value at an exit direction d (unit, z >= 0) for a PNG pixel; < 0 on an error, which
     * the caller reads from its own context.  NULL: the value of the cell d falls in. */
    int (*value)(void *opaque, const double d[3], double *v);
    void *opaque;
    int log;                 /* logarithmic scale (lo > 0), else linear */
    double lo, hi;           /* the scale's ends; values beyond take the end colours */
    int angle;               /* projection: 0 disk (radius sin theta), 1 angle (theta / 90) */
    int size;                /* diameter of the disk in pixels (points in SVG and PDF) */
    double mark[3];          /* a direction marked by a ring (z >= 0) */
    const char *title;       /* UTF-8: the caption above the disk, and a PDF's title */
    const char *unit;        /* UTF-8, above the colour bar */
};

/* Formats: 0 PNG, 1 SVG, 2 PDF (CLI_DRAW_PNG.. in draw.h; `svg` of old callers is 0 or 1). */
enum { CLI_HEMIMAP_EWRITE = -1, CLI_HEMIMAP_EVALUE = -2 };

/* Write the map to fp in the given format.  0, CLI_HEMIMAP_EWRITE (cairo failed: out of memory)
 * or CLI_HEMIMAP_EVALUE (the value callback failed; nothing written to a PNG, a vector format's
 * stream is incomplete).  A write error is left in fp's error flag: flush fp to see it. */
int cli_hemimap_write(FILE *fp, int format, const struct cli_hemimap *m);

/* Where the disk lies in the image of m: centre (cx, cy) from the top left corner, radius r, and
 * the image's size, all in pixels (points). */
void cli_hemimap_geometry(const struct cli_hemimap *m, double *cx, double *cy, double *r,
                          double *width, double *height);

#endif
