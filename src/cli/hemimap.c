/* hemimap.c - a function over the exit hemisphere drawn with cairo as a disk with a colour scale,
 * as PNG, SVG or PDF: `bsdfstack plot` (a BSDF) and `bsdfstack compare --map` (local accordance).
 *
 * The disk shows each exit direction at its x, y components in the layer's frame (+X to the
 * right, +Y up: the window seen from its interior side, +Z), so every Shirley-Chiu cell has the
 * same area ("disk" projection, area = projected solid angle), or at radius theta / 90 degrees
 * ("angle" projection, which spreads the grazing directions).  A PNG is coloured pixel by pixel,
 * each at its pixel's centre (by a callback, or by the value of the basis cell the direction
 * falls in), and clipped to the disk with an anti-aliased edge; SVG and PDF draw the basis cells
 * as vector polygons in the colour of their values.  Grid, labels and colour bar are vector
 * drawing in every format. */
#include <config.h>

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "draw.h"
#include "hemimap.h"

/* ------------------------------------------------------------------ colour scale */

struct scale {
    int log;
    double lo, hi;
};

/* position of a value on the scale, 0..1 (a zero or a value below a log scale's end is 0) */
static double scale_t(const struct scale *s, double v)
{
    double t;
    if (s->log)
        t = v <= s->lo ? 0 : (log10(v) - log10(s->lo)) / (log10(s->hi) - log10(s->lo));
    else
        t = (v - s->lo) / (s->hi - s->lo);
    return t < 0 ? 0 : t > 1 ? 1 : t;
}

/* Tick values: decades on a log scale (or both ends when none falls inside), "nice" steps on a
 * linear one.  Returns how many (<= 16). */
static int scale_ticks(const struct scale *s, double *ticks)
{
    int n = 0;
    if (s->log) {
        for (int d = (int)ceil(log10(s->lo) - 1e-9); d <= (int)floor(log10(s->hi) + 1e-9) && n < 16; d++)
            ticks[n++] = pow(10.0, d);
        if (n < 2)
            n = 0, ticks[n++] = s->lo, ticks[n++] = s->hi;
        return n;
    }
    double raw = (s->hi - s->lo) / 4, mag = pow(10.0, floor(log10(raw))), step;
    step = raw / mag < 1.5 ? mag : raw / mag < 3.5 ? 2 * mag : raw / mag < 7.5 ? 5 * mag : 10 * mag;
    for (double v = ceil(s->lo / step - 1e-9) * step; v <= s->hi + 1e-9 * step && n < 16; v += step)
        ticks[n++] = fabs(v) < 1e-12 * step ? 0 : v;
    return n;
}

/* ------------------------------------------------------------------ geometry */

#define RIM (1 - 1e-6) /* the largest radius (of 1) a pixel's direction is taken at */

struct layout {
    double fs;               /* font size */
    double margin, top;      /* around the disk; the caption's band above */
    double cx, cy, radius;   /* the disk (y down) */
    double bar_x, bar_w;     /* the colour bar, as high as the disk */
    double width, height;
    int angle;               /* projection: 0 disk, 1 angle */
};

static struct layout layout_for(const struct cli_hemimap *m)
{
    struct layout L;
    L.fs = fmax(9, m->size / 36.0);
    L.margin = 2.6 * L.fs + 6; /* room for the phi labels ("180°") */
    L.top = 2 * L.fs;
    L.radius = m->size / 2.0;
    L.cx = L.margin + L.radius;
    L.cy = L.top + L.margin + L.radius;
    L.bar_x = 2 * L.margin + m->size;
    L.bar_w = 1.2 * L.fs;
    L.width = ceil(L.bar_x + L.bar_w + 5.5 * L.fs);
    L.height = ceil(L.top + 2 * L.margin + m->size);
    L.angle = m->angle;
    return L;
}

void cli_hemimap_geometry(const struct cli_hemimap *m, double *cx, double *cy, double *r,
                          double *width, double *height)
{
    struct layout L = layout_for(m);
    *cx = L.cx, *cy = L.cy, *r = L.radius, *width = L.width, *height = L.height;
}

/* An exit direction (either hemisphere: only x, y and |z| count) to image coordinates. */
static void to_image(const struct layout *L, const double d[3], double *px, double *py)
{
    double x = d[0], y = d[1], r = hypot(x, y);
    if (L->angle && r > 0) {
        double s = atan2(r, fabs(d[2])) / (M_PI / 2) / r;
        x *= s, y *= s;
    }
    *px = L->cx + L->radius * x;
    *py = L->cy - L->radius * y;
}

/* Image coordinates to an exit direction (z > 0); a point on or beyond the rim takes the
 * direction just inside it (the anti-aliased edge needs its colour, and the plane z = 0 holds no
 * exit direction). */
static void from_image(const struct layout *L, double px, double py, double d[3])
{
    double x = (px - L->cx) / L->radius, y = (L->cy - py) / L->radius, r = hypot(x, y);
    if (r > RIM)
        x *= RIM / r, y *= RIM / r, r = RIM;
    if (L->angle && r > 0) {
        double th = r * M_PI / 2;
        x *= sin(th) / r, y *= sin(th) / r;
    }
    double rr = x * x + y * y;
    d[0] = x, d[1] = y, d[2] = rr < 1 ? sqrt(1 - rr) : 0;
}

static void direction(double theta_deg, double phi_deg, double d[3])
{
    double t = theta_deg * M_PI / 180, p = phi_deg * M_PI / 180;
    d[0] = sin(t) * cos(p), d[1] = sin(t) * sin(p), d[2] = cos(t);
}

static void set_ramp(cairo_t *cr, double t)
{
    double rgb[3];
    cli_draw_ramp(t, rgb);
    cairo_set_source_rgb(cr, rgb[0], rgb[1], rgb[2]);
}

/* ------------------------------------------------------------------ the hemisphere */

/* PNG: every pixel of the disk's bounding square at its centre, into an image painted through a
 * circular clip. */
static int paint_pixels(cairo_t *cr, const struct cli_hemimap *m, const struct layout *L,
                        const struct scale *sc)
{
    int x0 = (int)floor(L->cx - L->radius) - 1, y0 = (int)floor(L->cy - L->radius) - 1;
    int n = (int)ceil(2 * L->radius) + 3;
    cairo_surface_t *img = cairo_image_surface_create(CAIRO_FORMAT_RGB24, n, n);
    if (cairo_surface_status(img) != CAIRO_STATUS_SUCCESS) {
        cairo_surface_destroy(img);
        return CLI_HEMIMAP_EWRITE;
    }
    cairo_surface_flush(img);
    unsigned char *data = cairo_image_surface_get_data(img);
    int stride = cairo_image_surface_get_stride(img);
    double reach = 1 + 2 / L->radius; /* pixels this far out still show at the clipped edge */
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            double px = x0 + i + 0.5, py = y0 + j + 0.5, d[3], val, rgb[3];
            if (hypot(px - L->cx, py - L->cy) > reach * L->radius)
                continue;
            from_image(L, px, py, d);
            if (m->value) {
                if (m->value(m->opaque, d, &val) < 0) {
                    cairo_surface_destroy(img);
                    return CLI_HEMIMAP_EVALUE;
                }
            } else {
                val = m->cell[bst_basis_patch(m->basis, d)];
            }
            cli_draw_ramp(scale_t(sc, val), rgb);
            uint32_t pix = (uint32_t)lround(rgb[0] * 255) << 16 | (uint32_t)lround(rgb[1] * 255) << 8 |
                           (uint32_t)lround(rgb[2] * 255);
            memcpy(data + (size_t)j * (size_t)stride + 4 * (size_t)i, &pix, 4);
        }
    cairo_surface_mark_dirty(img);
    cairo_save(cr);
    cairo_arc(cr, L->cx, L->cy, L->radius, 0, 2 * M_PI);
    cairo_clip(cr);
    cairo_set_source_surface(cr, img, x0, y0);
    cairo_pattern_set_filter(cairo_get_source(cr), CAIRO_FILTER_NEAREST);
    cairo_paint(cr);
    cairo_restore(cr);
    cairo_surface_destroy(img);
    return 0;
}

/* SVG, PDF: each cell as a polygon through points along its edges; a hairline stroke in the
 * fill colour hides the seams renderers leave between neighbouring polygons. */
static void paint_cells(cairo_t *cr, const struct cli_hemimap *m, const struct layout *L,
                        const struct scale *sc)
{
    const bst_basis *basis = m->basis;
    size_t n = bst_basis_size(basis);
    int per_edge = bst_basis_kind_of(basis) == BST_BASIS_KLEMS ? 8 : bst_basis_order(basis) >= 6 ? 2 : 4;
    cairo_save(cr);
    cairo_set_line_width(cr, 0.6);
    cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
    for (size_t j = 0; j < n; j++) {
        for (int e = 0; e < 4; e++)
            for (int i = 0; i < per_edge; i++) {
                double t = (double)i / per_edge, uv[4][2] = {{t, 0}, {1, t}, {1 - t, 1}, {0, 1 - t}};
                double d[3], px, py;
                bst_basis_sample(basis, j, uv[e][0], uv[e][1], d);
                to_image(L, d, &px, &py);
                cairo_line_to(cr, px, py);
            }
        cairo_close_path(cr);
        set_ramp(cr, scale_t(sc, m->cell[j]));
        cairo_fill_preserve(cr);
        cairo_stroke(cr);
    }
    cairo_restore(cr);
}

/* ------------------------------------------------------------------ grid, mark, scale, caption */

static void draw_grid(cairo_t *cr, const struct layout *L)
{
    double px, py, qx, qy, d[3];
    cairo_set_source_rgb(cr, 150 / 255.0, 150 / 255.0, 150 / 255.0);
    cairo_set_line_width(cr, 0.8);
    for (int t = 30; t <= 60; t += 30) { /* theta = const is a circle in both projections */
        direction(t, 0, d);
        to_image(L, d, &px, &py);
        cairo_new_sub_path(cr);
        cairo_arc(cr, L->cx, L->cy, px - L->cx, 0, 2 * M_PI);
    }
    for (int ph = 0; ph < 360; ph += 90) {
        direction(90, ph, d);
        to_image(L, d, &qx, &qy);
        cairo_move_to(cr, L->cx, L->cy);
        cairo_line_to(cr, qx, qy);
    }
    cairo_stroke(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1);
    cairo_arc(cr, L->cx, L->cy, L->radius, 0, 2 * M_PI);
    cairo_stroke(cr);
    cli_draw_font(cr, L->fs);
    for (int ph = 0; ph < 360; ph += 90) {
        char lab[16];
        snprintf(lab, sizeof lab, "%d\xc2\xb0", ph);
        direction(90, ph, d);
        to_image(L, d, &qx, &qy);
        double g = 0.4 * L->fs;
        if (ph == 0)
            cli_draw_text(cr, qx + g, qy, 0, 0.5, lab);
        else if (ph == 180)
            cli_draw_text(cr, qx - g, qy, 1, 0.5, lab);
        else
            cli_draw_text(cr, qx, ph == 90 ? qy - g : qy + g, 0.5, ph == 90 ? 0 : 1, lab);
    }
    cairo_set_source_rgb(cr, 150 / 255.0, 150 / 255.0, 150 / 255.0);
    cli_draw_font(cr, 0.85 * L->fs);
    for (int t = 30; t <= 60; t += 30) {
        char lab[16];
        snprintf(lab, sizeof lab, "%d\xc2\xb0", t);
        direction(t, 45, d);
        to_image(L, d, &px, &py);
        cli_draw_text(cr, px + 2, py - 2, 0, 0, lab);
    }
}

/* a red ring with a black outline, readable on every colour of the ramp */
static void draw_mark(cairo_t *cr, const struct layout *L, const double mark[3])
{
    double mx, my, r = 0.45 * L->fs + 1;
    to_image(L, mark, &mx, &my);
    cairo_new_sub_path(cr);
    cairo_arc(cr, mx, my, r, 0, 2 * M_PI);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 3.2);
    cairo_stroke_preserve(cr);
    cairo_set_source_rgb(cr, 1, 60 / 255.0, 60 / 255.0);
    cairo_set_line_width(cr, 1.6);
    cairo_stroke(cr);
}

static void draw_bar(cairo_t *cr, const struct cli_hemimap *m, const struct layout *L,
                     const struct scale *sc)
{
    double top = L->cy - L->radius, bot = L->cy + L->radius;
    cairo_pattern_t *g = cairo_pattern_create_linear(0, bot, 0, top); /* bottom = low end */
    for (int i = 0; i <= 32; i++) {
        double rgb[3];
        cli_draw_ramp(i / 32.0, rgb);
        cairo_pattern_add_color_stop_rgb(g, i / 32.0, rgb[0], rgb[1], rgb[2]);
    }
    cairo_rectangle(cr, L->bar_x, top, L->bar_w, bot - top);
    cairo_set_source(cr, g);
    cairo_fill(cr);
    cairo_pattern_destroy(g);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1);
    cli_draw_font(cr, L->fs);
    double ticks[16];
    int nt = scale_ticks(sc, ticks);
    for (int i = 0; i < nt; i++) {
        double y = bot - scale_t(sc, ticks[i]) * (bot - top);
        char lab[32];
        snprintf(lab, sizeof lab, "%g", ticks[i]);
        cairo_move_to(cr, L->bar_x + L->bar_w, y);
        cairo_line_to(cr, L->bar_x + L->bar_w + 0.3 * L->fs, y);
        cairo_stroke(cr);
        cli_draw_text(cr, L->bar_x + L->bar_w + 0.45 * L->fs, y, 0, 0.5, lab);
    }
    if (m->unit)
        cli_draw_text(cr, L->bar_x, top - 0.6 * L->fs, 0, 0, m->unit);
}

/* the caption across the top, in a smaller face when it would not fit */
static void draw_caption(cairo_t *cr, const struct layout *L, const char *title)
{
    if (!title)
        return;
    double fs = L->fs;
    cli_draw_font(cr, fs);
    double w = cli_draw_text_width(cr, title), room = L->width - 2 * 0.5 * L->fs;
    if (w > room) {
        fs = fmax(5, fs * room / w);
        cli_draw_font(cr, fs);
    }
    cairo_set_source_rgb(cr, 0, 0, 0);
    cli_draw_text(cr, 0.5 * L->fs, 1.35 * L->fs, 0, 0, title);
}

int cli_hemimap_write(FILE *fp, int format, const struct cli_hemimap *m)
{
    struct layout L = layout_for(m);
    struct scale sc = {m->log, m->lo, m->hi};
    struct cli_draw d;
    if (cli_draw_begin(&d, fp, format, L.width, L.height, m->title) != CAIRO_STATUS_SUCCESS)
        return CLI_HEMIMAP_EWRITE;
    if (format == CLI_DRAW_PNG) {
        int rc = paint_pixels(d.cr, m, &L, &sc);
        if (rc < 0) {
            cli_draw_abort(&d);
            return rc;
        }
    } else {
        paint_cells(d.cr, m, &L, &sc);
    }
    draw_grid(d.cr, &L);
    draw_mark(d.cr, &L, m->mark);
    draw_bar(d.cr, m, &L, &sc);
    draw_caption(d.cr, &L, m->title);
    return cli_draw_end(&d) == CAIRO_STATUS_SUCCESS ? 0 : CLI_HEMIMAP_EWRITE;
}
