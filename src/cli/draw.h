/* draw.h - the program's figures drawn with cairo (`plot`, `compare --map`): the output format
 * from an option or a file name, a cairo surface that writes PNG, SVG or PDF to a stream (a
 * cli_out's FILE, so that regular files are still replaced atomically), and the colour ramp and
 * text helpers the figures share.  Lengths are pixels in a PNG, points (1/72 in) in SVG and PDF. */
#ifndef BST_CLI_DRAW_H
#define BST_CLI_DRAW_H

#include <stdio.h>
#include <cairo.h>

enum cli_draw_format { CLI_DRAW_PNG = 0, CLI_DRAW_SVG = 1, CLI_DRAW_PDF = 2 };

/* "png", "svg" or "pdf" (case-insensitive) to a format; -1 for anything else. */
int cli_draw_format_parse(const char *name);
/* The format a file name asks for by its extension (.png, .svg, .pdf, any case); "-" (standard
 * output) is PNG; -1 when the name has none of these extensions. */
int cli_draw_format_of_path(const char *path);
/* "png", "svg", "pdf". */
const char *cli_draw_format_name(int format);

struct cli_draw {
    cairo_surface_t *surface;
    cairo_t *cr;
    int format;
    FILE *fp;
    int discard; /* abandoned: write nothing more */
};

/* Start a figure of width x height (rounded up to whole pixels for PNG) written to fp in the
 * given format; title goes into a PDF's metadata (may be NULL).  CAIRO_STATUS_SUCCESS, or a
 * cairo status (out of memory) and nothing to free. */
cairo_status_t cli_draw_begin(struct cli_draw *d, FILE *fp, int format, double width, double height,
                              const char *title);
/* Finish the figure: a PNG is encoded and written now, a vector format completed.  The first
 * cairo error of the drawing (out of memory), or CAIRO_STATUS_SUCCESS; write errors are the
 * stream's (ferror, and the caller's flush says why).  Frees everything either way. */
cairo_status_t cli_draw_end(struct cli_draw *d);

/* Abandon the figure (an error while drawing): nothing more is written, everything is freed.
 * Safe on a zeroed struct. */
void cli_draw_abort(struct cli_draw *d);

/* The colour scale's ramp, t in 0..1 (clamped): dark blue through teal and green to pale yellow,
 * lightness growing monotonically so that it reads in grey too.  rgb in 0..1. */
void cli_draw_ramp(double t, double rgb[3]);

/* The program's sans-serif face at size pt. */
void cli_draw_font(cairo_t *cr, double size);
/* Text with its reference point at x, y: align 0 left, 0.5 centre, 1 right of x; y is the
 * baseline plus valign times the font's ascent (0.5 centres digits on y). */
void cli_draw_text(cairo_t *cr, double x, double y, double align, double valign, const char *s);
/* The width of s in the current font. */
double cli_draw_text_width(cairo_t *cr, const char *s);

#endif
