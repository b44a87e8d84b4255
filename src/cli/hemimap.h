/* hemimap.h - a function over the exit hemisphere drawn as a disk with a colour scale (PNG or
 * SVG), for `bsdfstack plot` and `bsdfstack compare --map`.  Conventions in hemimap.c. */
#ifndef BST_CLI_HEMIMAP_H
#define BST_CLI_HEMIMAP_H

#include <stdio.h>
#include "bsdfstack.h"

struct cli_hemimap {
    const bst_basis *basis;  /* the cells an SVG draws */
    const double *cell;      /* the value of every cell (at its centre) */
    /* The value at an exit direction d (unit, z >= 0) for a PNG pixel; < 0 on an error, which
     * the caller reads from its own context.  NULL: the value of the cell d falls in. */
    int (*value)(void *opaque, const double d[3], double *v);
    void *opaque;
    int log;                 /* logarithmic scale (lo > 0), else linear */
    double lo, hi;           /* the scale's ends; values beyond take the end colours */
    int angle;               /* projection: 0 disk (radius sin theta), 1 angle (theta / 90) */
    int size;                /* diameter of the disk in pixels */
    double mark[3];          /* a direction marked by a ring (z >= 0) */
    const char *title;       /* UTF-8: the SVG's title and caption, the PNG's Title text */
    const char *unit;        /* above the colour bar; a PNG draws digits, . - + e / s r % */
};

enum { CLI_HEMIMAP_EWRITE = -1, CLI_HEMIMAP_EVALUE = -2 };

/* Write the map as SVG (svg = 1) or PNG.  0, CLI_HEMIMAP_EWRITE (write error or out of memory) or
 * CLI_HEMIMAP_EVALUE (the value callback failed). */
int cli_hemimap_write(FILE *fp, int svg, const struct cli_hemimap *m);

#endif
