/* hemimap.c - a function over the exit hemisphere drawn as a disk with a colour scale, as PNG or
 * SVG: `bsdfstack plot` (a BSDF) and `bsdfstack compare --map` (local accordance).
 *
 * The disk shows each exit direction at its x, y components in the layer's frame (+X to the
 * right, +Y up: the window seen from its interior side, +Z), so every Shirley-Chiu cell has the
 * same area ("disk" projection, area = projected solid angle), or at radius theta / 90 degrees
 * ("angle" projection, which spreads the grazing directions).  A PNG is coloured pixel by pixel
 * (by a callback, or by the value of the basis cell the pixel's direction falls in); an SVG draws
 * the basis cells as polygons in the colour of their values. */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "hemimap.h"
#include "png.h"

/* ------------------------------------------------------------------ colour scale */

enum { RAMP = 200, BG = RAMP, INK, GRID, MARK, NPAL };

/* A ramp from dark blue through teal and green to pale yellow; lightness grows monotonically, so
 * it reads in grey too.  Control points (t, r, g, b). */
static void ramp_rgb(double t, unsigned char rgb[3])
{
    static const double cp[][4] = {{0.0, 8, 8, 32},       {0.2, 40, 40, 140},  {0.4, 30, 120, 170},
                                   {0.6, 40, 175, 120},   {0.8, 200, 210, 60}, {1.0, 255, 250, 200}};
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    int i = 0;
    while (i < 4 && t > cp[i + 1][0])
        i++;
    double f = (t - cp[i][0]) / (cp[i + 1][0] - cp[i][0]);
    for (int c = 0; c < 3; c++)
        rgb[c] = (unsigned char)lround(cp[i][c + 1] + f * (cp[i + 1][c + 1] - cp[i][c + 1]));
}

struct scale {
    int log;
    double lo, hi;
};

/* position of a value on the scale, 0..1 (a zero or a value below a log scale's end is 0) */
static double scale_t(const struct scale *s, double v)
{
    if (s->log)
        return v <= s->lo ? 0 : (log10(v) - log10(s->lo)) / (log10(s->hi) - log10(s->lo));
    return (v - s->lo) / (s->hi - s->lo);
}

static int scale_index(const struct scale *s, double v)
{
    double t = scale_t(s, v);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return (int)lround(t * (RAMP - 1));
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

struct view {
    int angle;              /* projection: 0 disk, 1 angle */
    double cx, cy, radius;  /* the disk in image pixels (y down) */
};

/* An exit direction (z >= 0 side, any sign of z is taken as its hemisphere) to image pixels. */
static void to_image(const struct view *v, const double d[3], double *px, double *py)
{
    double x = d[0], y = d[1], r = hypot(x, y);
    if (v->angle && r > 0) {
        double s = atan2(r, fabs(d[2])) / (M_PI / 2) / r;
        x *= s, y *= s;
    }
    *px = v->cx + v->radius * x;
    *py = v->cy - v->radius * y;
}

/* Image pixels to an exit direction with |z| from the projection; 0 outside the disk. */
static int from_image(const struct view *v, double px, double py, double d[3])
{
    double x = (px - v->cx) / v->radius, y = (v->cy - py) / v->radius, r = hypot(x, y);
    if (r > 1)
        return 0;
    if (v->angle && r > 0) {
        double th = r * M_PI / 2;
        x *= sin(th) / r, y *= sin(th) / r;
    }
    double rr = x * x + y * y;
    d[0] = x, d[1] = y, d[2] = rr < 1 ? sqrt(1 - rr) : 0;
    return 1;
}

/* ------------------------------------------------------------------ PNG */

/* A 5 x 7 font for the scale's numbers; rows top down, bit 4 the leftmost pixel. */
static const char glyph_chars[] = "0123456789.-+e/sr%";
static const unsigned char glyphs[][7] = {
    {14, 17, 19, 21, 25, 17, 14}, {4, 12, 4, 4, 4, 4, 14},   {14, 17, 1, 2, 4, 8, 31},
    {31, 2, 4, 2, 1, 17, 14},     {2, 6, 10, 18, 31, 2, 2},  {31, 16, 30, 1, 1, 17, 14},
    {6, 8, 16, 30, 17, 17, 14},   {31, 1, 2, 4, 8, 8, 8},    {14, 17, 17, 14, 17, 17, 14},
    {14, 17, 17, 15, 1, 2, 12},   {0, 0, 0, 0, 0, 12, 12},   {0, 0, 0, 31, 0, 0, 0},
    {0, 4, 4, 31, 4, 4, 0},       {0, 0, 14, 17, 31, 16, 14}, {0, 1, 2, 4, 8, 16, 0},
    {0, 0, 14, 16, 14, 1, 30},    {0, 0, 22, 25, 16, 16, 16}, {24, 25, 2, 4, 8, 19, 3}};

struct canvas {
    size_t w, h;
    unsigned char *pix;
};

static void put(struct canvas *c, long x, long y, unsigned char idx)
{
    if (x >= 0 && y >= 0 && (size_t)x < c->w && (size_t)y < c->h)
        c->pix[(size_t)y * c->w + (size_t)x] = idx;
}

/* text with its left edge at x and its vertical middle at y, in pixels of size s */
static void text(struct canvas *c, long x, long y, int s, const char *str)
{
    y -= 7 * s / 2;
    for (; *str; str++, x += 6 * s) {
        const char *g = strchr(glyph_chars, *str);
        if (!g)
            continue; /* a space, or a character the font lacks */
        const unsigned char *rows = glyphs[g - glyph_chars];
        for (int r = 0; r < 7; r++)
            for (int col = 0; col < 5; col++)
                if (rows[r] >> (4 - col) & 1)
                    for (int i = 0; i < s; i++)
                        for (int j = 0; j < s; j++)
                            put(c, x + col * s + j, y + r * s + i, INK);
    }
}

static void circle(struct canvas *c, double cx, double cy, double r, unsigned char idx)
{
    int n = (int)(2 * M_PI * r) + 8;
    for (int i = 0; i < n; i++) {
        double a = 2 * M_PI * i / n;
        put(c, lround(cx + r * cos(a)), lround(cy + r * sin(a)), idx);
    }
}

static void segment(struct canvas *c, double x0, double y0, double x1, double y1, unsigned char idx)
{
    int n = (int)hypot(x1 - x0, y1 - y0) + 1;
    for (int i = 0; i <= n; i++)
        put(c, lround(x0 + (x1 - x0) * i / n), lround(y0 + (y1 - y0) * i / n), idx);
}

static void fmt_tick(char *buf, size_t n, double v)
{
    snprintf(buf, n, "%g", v);
}

struct layout {
    int size, s, margin, bar_x, bar_w, width, height;
};

static struct layout layout_for(int size)
{
    struct layout L;
    L.size = size;
    L.s = size >= 360 ? 2 : 1;              /* font pixel size */
    L.margin = 8 + 3 * 6 * L.s;             /* room for the phi labels ("180") */
    L.bar_x = 2 * L.margin + size;
    L.bar_w = 8 * L.s;
    L.width = L.bar_x + L.bar_w + 6 * L.s + 6 * 6 * L.s + L.margin;
    L.height = 2 * L.margin + size;
    return L;
}

static void grid_points(const struct view *v, double theta_deg, double phi_deg, double *px, double *py)
{
    double t = theta_deg * M_PI / 180, p = phi_deg * M_PI / 180;
    double d[3] = {sin(t) * cos(p), sin(t) * sin(p), cos(t)};
    to_image(v, d, px, py);
}

static int write_png(FILE *fp, const struct cli_hemimap *m, const struct view *v,
                     const struct layout *L, const struct scale *sc)
{
    struct canvas c = {(size_t)L->width, (size_t)L->height, NULL};
    c.pix = malloc(c.w * c.h);
    if (!c.pix)
        return CLI_HEMIMAP_EWRITE;
    memset(c.pix, BG, c.w * c.h);
    /* the hemisphere, pixel by pixel, at pixel centres */
    for (size_t y = 0; y < c.h; y++)
        for (size_t x = 0; x < c.w; x++) {
            double d[3], val;
            if (!from_image(v, x + 0.5, y + 0.5, d))
                continue;
            if (m->value) {
                if (m->value(m->opaque, d, &val) < 0) {
                    free(c.pix);
                    return CLI_HEMIMAP_EVALUE;
                }
            } else {
                val = m->cell[bst_basis_patch(m->basis, d)];
            }
            c.pix[y * c.w + x] = (unsigned char)scale_index(sc, val);
        }
    /* grid: theta = 30, 60, 90 degrees, phi every 90 degrees, and the phi labels */
    double px, py, qx, qy;
    for (int t = 30; t <= 90; t += 30) {
        int n = 720;
        for (int i = 0; i < n; i++) {
            grid_points(v, t, 360.0 * i / n, &px, &py);
            put(&c, lround(px - 0.5), lround(py - 0.5), t == 90 ? INK : GRID);
        }
    }
    for (int ph = 0; ph < 360; ph += 90) {
        grid_points(v, 0, ph, &px, &py);
        grid_points(v, 90, ph, &qx, &qy);
        segment(&c, px - 0.5, py - 0.5, qx - 0.5, qy - 0.5, GRID);
        char lab[8];
        snprintf(lab, sizeof lab, "%d", ph);
        long tw = (long)strlen(lab) * 6 * L->s;
        double ox = ph == 0 ? 4 : ph == 180 ? -4 - tw : -tw / 2.0, oy = ph == 90 ? -6 * L->s : ph == 270 ? 6 * L->s : 0;
        text(&c, lround(qx + ox), lround(qy + oy), L->s, lab);
    }
    /* the incident light continued or mirrored */
    to_image(v, m->mark, &px, &py);
    circle(&c, px - 0.5, py - 0.5, 3 * L->s + 2, INK);
    circle(&c, px - 0.5, py - 0.5, 3 * L->s + 1, MARK);
    circle(&c, px - 0.5, py - 0.5, 3 * L->s, INK);
    /* colour bar with ticks and labels, bottom = low end */
    long top = L->margin, bot = L->margin + L->size - 1;
    for (long y = top; y <= bot; y++) {
        unsigned char idx = (unsigned char)lround((double)(bot - y) / (bot - top) * (RAMP - 1));
        for (long x = L->bar_x; x < L->bar_x + L->bar_w; x++)
            put(&c, x, y, idx);
    }
    double ticks[16];
    int nt = scale_ticks(sc, ticks);
    for (int i = 0; i < nt; i++) {
        long y = lround(bot - scale_t(sc, ticks[i]) * (bot - top));
        segment(&c, L->bar_x + L->bar_w, y, L->bar_x + L->bar_w + 3 * L->s, y, INK);
        char lab[24];
        fmt_tick(lab, sizeof lab, ticks[i]);
        text(&c, L->bar_x + L->bar_w + 5 * L->s, y, L->s, lab);
    }
    text(&c, L->bar_x, top - 7 * L->s, L->s, m->unit);
    unsigned char pal[NPAL][3];
    for (int i = 0; i < RAMP; i++)
        ramp_rgb((double)i / (RAMP - 1), pal[i]);
    memcpy(pal[BG], (unsigned char[3]){255, 255, 255}, 3);
    memcpy(pal[INK], (unsigned char[3]){0, 0, 0}, 3);
    memcpy(pal[GRID], (unsigned char[3]){150, 150, 150}, 3);
    memcpy(pal[MARK], (unsigned char[3]){255, 60, 60}, 3);
    const char *meta[] = {"Title", m->title, "Software", "bsdfstack " PACKAGE_VERSION, NULL};
    struct cli_png img = {c.w, c.h, c.pix, (const unsigned char(*)[3])pal, NPAL, meta};
    int rc = cli_png_write(fp, &img) == 0 ? 0 : CLI_HEMIMAP_EWRITE;
    free(c.pix);
    return rc;
}

/* ------------------------------------------------------------------ SVG */

static void svg_escaped(FILE *fp, const char *s)
{
    for (; *s; s++)
        switch (*s) {
        case '&': fputs("&amp;", fp); break;
        case '<': fputs("&lt;", fp); break;
        case '>': fputs("&gt;", fp); break;
        case '"': fputs("&quot;", fp); break;
        default: fputc(*s, fp);
        }
}

static void svg_colour(char buf[8], double t)
{
    unsigned char rgb[3];
    ramp_rgb(t, rgb);
    snprintf(buf, 8, "#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
}

static int write_svg(FILE *fp, const struct cli_hemimap *m, const struct view *v,
                     const struct layout *L, const struct scale *sc)
{
    const bst_basis *basis = m->basis;
    const double *cell = m->cell;
    const char *title = m->title;
    fprintf(fp, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%d\" height=\"%d\" "
                "viewBox=\"0 0 %d %d\" font-family=\"sans-serif\" font-size=\"%d\">\n<title>",
            L->width, L->height + 24, L->width, L->height + 24, 6 + 4 * L->s);
    svg_escaped(fp, title);
    fprintf(fp, "</title>\n<rect width=\"100%%\" height=\"100%%\" fill=\"#ffffff\"/>\n<text x=\"%d\" "
                "y=\"%d\">", L->margin, L->height + 16);
    svg_escaped(fp, title);
    fputs("</text>\n<g stroke-width=\"0.6\">\n", fp);
    /* each cell as a polygon through points along its edges; the stroke in the fill colour hides
     * the seams renderers leave between neighbouring polygons */
    size_t n = bst_basis_size(basis);
    int per_edge = bst_basis_kind_of(basis) == BST_BASIS_KLEMS ? 8 : bst_basis_order(basis) >= 6 ? 2 : 4;
    for (size_t j = 0; j < n; j++) {
        char col[8];
        svg_colour(col, scale_t(sc, cell[j]));
        fprintf(fp, "<path fill=\"%s\" stroke=\"%s\" d=\"", col, col);
        for (int e = 0; e < 4; e++)
            for (int i = 0; i < per_edge; i++) {
                double t = (double)i / per_edge, uv[4][2] = {{t, 0}, {1, t}, {1 - t, 1}, {0, 1 - t}};
                double d[3], px, py;
                bst_basis_sample(basis, j, uv[e][0], uv[e][1], d);
                to_image(v, d, &px, &py);
                fprintf(fp, "%s%.2f %.2f", e + i ? " L" : "M", px, py);
            }
        fputs("Z\"/>\n", fp);
    }
    fputs("</g>\n<g fill=\"none\" stroke=\"#969696\" stroke-width=\"0.8\">\n", fp);
    for (int t = 30; t <= 60; t += 30) {
        double px, py;
        fputs("<path d=\"", fp);
        for (int i = 0; i <= 180; i++) {
            grid_points(v, t, 2.0 * i, &px, &py);
            fprintf(fp, "%s%.2f %.2f", i ? " L" : "M", px, py);
        }
        fputs("\"/>\n", fp);
    }
    for (int ph = 0; ph < 360; ph += 90) {
        double px, py, qx, qy;
        grid_points(v, 0, ph, &px, &py);
        grid_points(v, 90, ph, &qx, &qy);
        fprintf(fp, "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\"/>\n", px, py, qx, qy);
    }
    fprintf(fp, "</g>\n<circle cx=\"%.2f\" cy=\"%.2f\" r=\"%.2f\" fill=\"none\" stroke=\"#000000\"/>\n",
            v->cx, v->cy, v->radius);
    for (int ph = 0; ph < 360; ph += 90) {
        double qx, qy;
        grid_points(v, 90, ph, &qx, &qy);
        const char *anchor = ph == 0 ? "start" : ph == 180 ? "end" : "middle";
        double dx = ph == 0 ? 4 : ph == 180 ? -4 : 0, dy = ph == 90 ? -6 : ph == 270 ? 6 + 4 * L->s : 4;
        fprintf(fp, "<text x=\"%.2f\" y=\"%.2f\" text-anchor=\"%s\">%d&#176;</text>\n", qx + dx, qy + dy,
                anchor, ph);
    }
    for (int t = 30; t <= 60; t += 30) {
        double px, py;
        grid_points(v, t, 45, &px, &py);
        fprintf(fp, "<text x=\"%.2f\" y=\"%.2f\" fill=\"#969696\">%d&#176;</text>\n", px + 2, py - 2, t);
    }
    double mx, my;
    to_image(v, m->mark, &mx, &my);
    fprintf(fp, "<circle cx=\"%.2f\" cy=\"%.2f\" r=\"%d\" fill=\"none\" stroke=\"#ff3c3c\" "
                "stroke-width=\"2\"/>\n", mx, my, 3 * L->s + 1);
    /* colour bar: 100 steps, bottom = low end */
    double top = L->margin, h = L->size;
    for (int i = 0; i < 100; i++) {
        char col[8];
        svg_colour(col, (i + 0.5) / 100);
        fprintf(fp, "<rect x=\"%d\" y=\"%.2f\" width=\"%d\" height=\"%.2f\" fill=\"%s\"/>\n", L->bar_x,
                top + h * (99 - i) / 100, L->bar_w, h / 100 + 0.3, col);
    }
    double ticks[16];
    int nt = scale_ticks(sc, ticks);
    for (int i = 0; i < nt; i++) {
        double y = top + h - scale_t(sc, ticks[i]) * h;
        char lab[24];
        fmt_tick(lab, sizeof lab, ticks[i]);
        fprintf(fp, "<line x1=\"%d\" y1=\"%.2f\" x2=\"%d\" y2=\"%.2f\" stroke=\"#000000\"/>"
                    "<text x=\"%d\" y=\"%.2f\">%s</text>\n", L->bar_x + L->bar_w, y,
                L->bar_x + L->bar_w + 3 * L->s, y, L->bar_x + L->bar_w + 5 * L->s, y + 2 + 2 * L->s, lab);
    }
    fprintf(fp, "<text x=\"%d\" y=\"%d\">", L->bar_x, L->margin - 6);
    svg_escaped(fp, m->unit);
    fputs("</text>\n</svg>\n", fp);
    return ferror(fp) ? CLI_HEMIMAP_EWRITE : 0;
}

int cli_hemimap_write(FILE *fp, int svg, const struct cli_hemimap *m)
{
    struct layout L = layout_for(m->size);
    struct view v = {m->angle, L.margin + m->size / 2.0, L.margin + m->size / 2.0, m->size / 2.0};
    struct scale sc = {m->log, m->lo, m->hi};
    return svg ? write_svg(fp, m, &v, &L, &sc) : write_png(fp, m, &v, &L, &sc);
}
