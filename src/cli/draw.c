/* draw.c - cairo surfaces for the program's figures, written through a stdio stream, and the
 * pieces every figure shares (format names, colour ramp, text).  Conventions in draw.h. */
#include <config.h>

#include <math.h>
#include <string.h>
#include <strings.h>

#include <cairo-pdf.h>
#include <cairo-svg.h>

#include "draw.h"

static const char *const format_names[] = {"png", "svg", "pdf"};

int cli_draw_format_parse(const char *name)
{
    for (int f = 0; f < 3; f++)
        if (strcasecmp(name, format_names[f]) == 0)
            return f;
    return -1;
}

int cli_draw_format_of_path(const char *path)
{
    if (strcmp(path, "-") == 0)
        return CLI_DRAW_PNG;
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    if (!dot || dot == path || (slash && dot < slash) || dot[-1] == '/')
        return -1;
    return cli_draw_format_parse(dot + 1);
}

const char *cli_draw_format_name(int format)
{
    return format >= 0 && format < 3 ? format_names[format] : "?";
}

/* Text that reaches a figure (file names in a legend or title) is bytes; cairo takes UTF-8 only,
 * and a string that is not puts the drawing into an error state (it was reported as "out of
 * memory").  Such bytes are drawn as '?'. */
#define DRAW_TEXT_MAX 1024

/* Bytes of the well-formed UTF-8 character at p (RFC 3629's table: no overlong form, surrogate
 * or code point past U+10FFFF), or 0. */
static size_t utf8_len(const unsigned char *p)
{
    if (p[0] < 0x80)
        return 1;
    if (p[0] < 0xC2 || p[0] > 0xF4)
        return 0;
    size_t n = p[0] < 0xE0 ? 2 : p[0] < 0xF0 ? 3 : 4;
    unsigned lo = p[0] == 0xE0 ? 0xA0 : p[0] == 0xF0 ? 0x90 : 0x80;
    unsigned hi = p[0] == 0xED ? 0x9F : p[0] == 0xF4 ? 0x8F : 0xBF;
    if (p[1] < lo || p[1] > hi)
        return 0;
    for (size_t i = 2; i < n; i++)
        if ((p[i] & 0xC0) != 0x80)
            return 0;
    return n;
}

/* s itself when it is UTF-8, else a copy in buf (DRAW_TEXT_MAX bytes, cut there) with '?' for
 * each byte that is not. */
static const char *drawable(const char *s, char *buf)
{
    const unsigned char *p = (const unsigned char *)s;
    size_t n;
    while (*p && (n = utf8_len(p)) > 0)
        p += n;
    if (!*p)
        return s;
    size_t o = 0;
    for (p = (const unsigned char *)s; *p && o + 5 < DRAW_TEXT_MAX;) {
        n = utf8_len(p);
        if (n)
            memcpy(buf + o, p, n), o += n, p += n;
        else
            buf[o++] = '?', p++;
    }
    buf[o] = '\0';
    return buf;
}

/* cairo's stream callback.  A failed write is left to the stream's error flag, and cairo goes
 * on: the caller's flush of the stream then meets the error again and says why (ENOSPC, EPIPE),
 * as for any other output file.  Nothing once the figure is abandoned (a vector surface still
 * writes its trailer when it is destroyed). */
static cairo_status_t write_stream(void *closure, const unsigned char *data, unsigned int length)
{
    struct cli_draw *d = closure;
    if (!d->discard)
        fwrite(data, 1, length, d->fp);
    return CAIRO_STATUS_SUCCESS;
}

cairo_status_t cli_draw_begin(struct cli_draw *d, FILE *fp, int format, double width, double height,
                              const char *title)
{
    memset(d, 0, sizeof *d);
    d->fp = fp;
    d->format = format;
    if (format == CLI_DRAW_PNG)
        d->surface = cairo_image_surface_create(CAIRO_FORMAT_RGB24, (int)ceil(width), (int)ceil(height));
    else if (format == CLI_DRAW_SVG)
        d->surface = cairo_svg_surface_create_for_stream(write_stream, d, width, height);
    else
        d->surface = cairo_pdf_surface_create_for_stream(write_stream, d, width, height);
    cairo_status_t st = cairo_surface_status(d->surface);
    if (st == CAIRO_STATUS_SUCCESS && format == CLI_DRAW_PDF) {
        char buf[DRAW_TEXT_MAX];
        if (title)
            cairo_pdf_surface_set_metadata(d->surface, CAIRO_PDF_METADATA_TITLE, drawable(title, buf));
        cairo_pdf_surface_set_metadata(d->surface, CAIRO_PDF_METADATA_CREATOR, "bsdfstack " PACKAGE_VERSION);
    }
    if (st == CAIRO_STATUS_SUCCESS) {
        d->cr = cairo_create(d->surface);
        st = cairo_status(d->cr);
    }
    if (st != CAIRO_STATUS_SUCCESS) {
        cli_draw_abort(d);
        return st;
    }
    /* white ground: a PNG has no alpha, and a vector figure looks the same on any page */
    cairo_set_source_rgb(d->cr, 1, 1, 1);
    cairo_paint(d->cr);
    return CAIRO_STATUS_SUCCESS;
}

cairo_status_t cli_draw_end(struct cli_draw *d)
{
    cairo_status_t st = cairo_status(d->cr);
    cairo_destroy(d->cr);
    if (st == CAIRO_STATUS_SUCCESS && d->format == CLI_DRAW_PNG)
        st = cairo_surface_write_to_png_stream(d->surface, write_stream, d);
    cairo_surface_finish(d->surface); /* a vector format writes its last parts here */
    if (st == CAIRO_STATUS_SUCCESS)
        st = cairo_surface_status(d->surface);
    cairo_surface_destroy(d->surface);
    memset(d, 0, sizeof *d);
    return st;
}

void cli_draw_ramp(double t, double rgb[3])
{
    static const double cp[][4] = {{0.0, 8, 8, 32},     {0.2, 40, 40, 140},  {0.4, 30, 120, 170},
                                   {0.6, 40, 175, 120}, {0.8, 200, 210, 60}, {1.0, 255, 250, 200}};
    t = !(t > 0) ? 0 : t > 1 ? 1 : t; /* NaN takes the low end */
    int i = 0;
    while (i < 4 && t > cp[i + 1][0])
        i++;
    double f = (t - cp[i][0]) / (cp[i + 1][0] - cp[i][0]);
    for (int c = 0; c < 3; c++)
        rgb[c] = (cp[i][c + 1] + f * (cp[i + 1][c + 1] - cp[i][c + 1])) / 255;
}

void cli_draw_font(cairo_t *cr, double size)
{
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, size);
}

void cli_draw_text(cairo_t *cr, double x, double y, double align, double valign, const char *text)
{
    char buf[DRAW_TEXT_MAX];
    const char *s = drawable(text, buf);
    cairo_text_extents_t te, digit;
    cairo_text_extents(cr, s, &te);
    cairo_text_extents(cr, "0", &digit); /* the height of digits and capitals */
    cairo_move_to(cr, x - align * te.x_advance, y + valign * digit.height);
    cairo_show_text(cr, s);
    cairo_new_path(cr);
}

double cli_draw_text_width(cairo_t *cr, const char *text)
{
    char buf[DRAW_TEXT_MAX];
    const char *s = drawable(text, buf);
    cairo_text_extents_t te;
    cairo_text_extents(cr, s, &te);
    return te.x_advance;
}

void cli_draw_abort(struct cli_draw *d)
{
    d->discard = 1;
    cairo_destroy(d->cr);
    cairo_surface_destroy(d->surface);
    memset(d, 0, sizeof *d);
}
