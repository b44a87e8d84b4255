/* plot_curve.c - `bsdfstack plot --curve`: directional-hemispherical T and R against incidence
 * angle theta for one or more BSDF files in one chart per channel, with a legend (the paper's
 * Figure 9: the steps each resolution's patches make).
 *
 * Each file is taken whole at its own basis (as `info` takes it: bst_bsdf_to_layer, then
 * bst_layer_hemispherical per incident patch).  Along the plane of incidence at propagation
 * azimuth phi the direction (theta, phi) crosses a sequence of incident patches; the curve is
 * the step function that holds each patch's value over the theta range the plane spends in it,
 * which is all the file says.  A direction on a patch boundary takes the patch on its +x, +y
 * side, exactly as info's table does (cli_incident_patch), so that the steps agree with it. */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "cli.h"
#include "draw.h"
#include "layers.h"
#include "plot.h"

#define SCAN_STEP 0.01    /* degrees between the theta samples that find the patch changes */
#define BOUNDARY_TOL 1e-9 /* degrees: how closely a change is bisected */

struct step {
    double t0, t1, v; /* the value over theta t0 .. t1 (degrees) */
    size_t patch;
};

struct curve {
    size_t file;
    char channel[64];
    int comp;          /* index into the options' comps */
    char basis[48];    /* for the summary */
    struct step *s;
    size_t n;
};

struct curves {
    struct curve *c;
    size_t n, cap;
};

/* The patches along the plane, as steps with the values h (one per patch). */
static int make_steps(const bst_basis *basis, double phi, const double *h, struct curve *c)
{
    size_t cap = 64, prev = cli_incident_patch(basis, 0, phi);
    double start = 0, lo = 0;
    c->n = 0;
    if (!(c->s = malloc(cap * sizeof *c->s)))
        return -1;
    int nscan = (int)lround(90 / SCAN_STEP);
    for (int i = 1; i <= nscan + 1; i++) {
        double hi = i <= nscan ? i * SCAN_STEP : 90;
        /* the end closes the last */
        size_t p = i <= nscan ? cli_incident_patch(basis, hi, phi) : (size_t)-1;
        while (p != prev) {
            double a = lo, b = hi; /* prev at a, another patch at b */
            if (p != (size_t)-1)
                while (b - a > BOUNDARY_TOL) {
                    double m = 0.5 * (a + b);
                    if (cli_incident_patch(basis, m, phi) == prev)
                        a = m;
                    else
                        b = m;
                }
            if (c->n == cap) {
                struct step *s = realloc(c->s, 2 * cap * sizeof *s);
                if (!s)
                    return -1;
                c->s = s, cap *= 2;
            }
            c->s[c->n++] = (struct step){start, b, h[prev], prev};
            if (p == (size_t)-1)
                return 0;
            start = lo = b;
            prev = cli_incident_patch(basis, b, phi);
        }
        lo = hi;
    }
    return 0;
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

/* One file's curves: every channel (or the asked one) and component. */
static int file_curves(const char *sub, const char *path, size_t fi, const struct cli_curve_opts *o,
                       struct curves *all)
{
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    bst_bsdf *b = NULL;
    bst_layer *l = NULL;
    bst_basis *own = NULL;
    double *h = NULL;
    int rc = CLI_OK;
    if (strncmp(path, "glass:", 6) == 0) {
        rc = cli_fail(sub, "%s: --curve reads BSDF files (bsdfstack glass prints a pane's T and R "
                      "against angle)", path);
        goto done;
    }
    if (bst_bsdf_read(ctx, path, NULL, &b) < 0) {
        rc = cli_fail_ctx(sub, path, ctx);
        goto done;
    }
    cli_warn_bsdf(sub, path, b);
    bst_ctx_clear(ctx);
    if (bst_bsdf_kind(b) != BST_FILE_KLEMS && bst_basis_new_sc(ctx, bst_bsdf_order(b), &own) < 0) {
        rc = cli_fail(sub, "out of memory");
        goto done;
    }
    struct cli_basis_choice limit = {.max_memory = o->max_memory,
                                     .lower = "'bsdfstack convert -k K' to a coarser file first"};
    if ((rc = cli_memory_check(sub, own ? own : bst_bsdf_klems_basis(b), 1, &b, 0, BST_DOUBLE, &limit)) != CLI_OK)
        goto done;
    if (bst_bsdf_to_layer(ctx, b, NULL, &l) < 0) {
        rc = cli_fail_ctx(sub, path, ctx);
        goto done;
    }
    const bst_basis *basis = bst_layer_basis(l);
    size_t n = bst_basis_size(basis), nch = bst_layer_nchannels(l);
    int only = -1;
    if (o->channel && (only = bst_layer_find_channel(l, o->channel)) < 0) {
        rc = cli_fail(sub, "%s: no channel '%s' in the file", path, o->channel);
        goto done;
    }
    if (!(h = malloc(n * sizeof *h))) {
        rc = cli_fail(sub, "out of memory");
        goto done;
    }
    for (size_t ch = 0; ch < nch && rc == CLI_OK; ch++) {
        if (only >= 0 && ch != (size_t)only)
            continue;
        for (int k = 0; k < o->ncomps && rc == CLI_OK; k++) {
            if (bst_layer_hemispherical(ctx, l, ch, o->comps[k], h) < 0) {
                rc = cli_fail_ctx(sub, path, ctx);
                break;
            }
            if (all->n == all->cap) {
                size_t nc = all->cap ? 2 * all->cap : 16;
                struct curve *c = realloc(all->c, nc * sizeof *c);
                if (!c) {
                    rc = cli_fail(sub, "out of memory");
                    break;
                }
                all->c = c, all->cap = nc;
            }
            struct curve *c = &all->c[all->n++];
            memset(c, 0, sizeof *c);
            c->file = fi, c->comp = k;
            snprintf(c->channel, sizeof c->channel, "%s", bst_layer_channel(l, ch));
            if (make_steps(basis, o->phi, h, c) < 0)
                rc = cli_fail(sub, "out of memory");
            for (size_t i = 0; rc == CLI_OK && i < c->n; i++)
                if (!isfinite(c->s[i].v))
                    rc = cli_fail(sub, "%s: %s %s at incident patch %zu is %g: not a hemispherical value",
                                  path, c->channel, bst_comp_name(o->comps[k]), c->s[i].patch, c->s[i].v);
            snprintf(c->basis, sizeof c->basis, "%s", bst_basis_kind_of(basis) == BST_BASIS_KLEMS ?
                     bst_basis_name(basis) : "Shirley-Chiu");
        }
    }
done:
    free(h);
    bst_layer_free(l);
    bst_basis_free(own);
    bst_bsdf_free(b);
    bst_ctx_free(ctx);
    return rc;
}

/* ------------------------------------------------------------------ the chart */

/* Okabe and Ito's colours, told apart also by readers with a colour vision deficiency */
static const double palette[][3] = {{0, 114, 178},  {213, 94, 0},   {0, 158, 115}, {204, 121, 167},
                                    {230, 159, 0},  {86, 180, 233}, {0, 0, 0}};
#define NPALETTE (sizeof palette / sizeof palette[0])

static void set_style(cairo_t *cr, size_t file, int comp, double lw)
{
    const double *c = palette[file % NPALETTE];
    cairo_set_source_rgb(cr, c[0] / 255, c[1] / 255, c[2] / 255);
    cairo_set_line_width(cr, lw);
    static const double dash[4][4] = {{0}, {6, 3}, {1.5, 2.5}, {6, 2.5, 1.5, 2.5}};
    static const int ndash[4] = {0, 2, 2, 4};
    double d[4];
    for (int i = 0; i < ndash[comp]; i++)
        d[i] = dash[comp][i] * lw;
    cairo_set_dash(cr, d, ndash[comp], 0);
}

static const char *comp_words(bst_comp c)
{
    static const char *const w[] = {"T front", "R front", "T back", "R back"};
    return w[c];
}

/* a round step for about 5 ticks over 0 .. span */
static double nice_step(double span)
{
    double raw = span / 5, mag = pow(10.0, floor(log10(raw))), f = raw / mag;
    return (f < 1.5 ? 1 : f < 3.5 ? 2 : f < 7.5 ? 5 : 10) * mag;
}

struct chart {
    double fs, left, right, pw, ph, panel_h, top, legend_x, width, height;
    double ymin, ymax, ystep;
};

static double xpos(const struct chart *ch, double theta)
{
    return ch->left + ch->pw * theta / 90;
}

static double ypos(const struct chart *ch, double top, double v)
{
    return top + ch->ph * (1 - (v - ch->ymin) / (ch->ymax - ch->ymin));
}

static void legend_label(char *buf, size_t size, char **files, size_t f, const struct cli_curve_opts *o, int k)
{
    if (o->ncomps > 1)
        snprintf(buf, size, "%s, %s", base_name(files[f]), comp_words(o->comps[k]));
    else
        snprintf(buf, size, "%s", base_name(files[f]));
}

/* The chart's geometry into ch: the legend's width measured in the figure's face, the panels
 * stacked, the vertical axis (--range, or 0 to a round value above the largest); -1 when cairo
 * fails. */
static int layout(struct chart *ch, size_t nfiles, char **files, const struct cli_curve_opts *o,
                  const struct curves *all, size_t npanels)
{
    ch->fs = fmax(9, o->size / 60.0);
    cairo_surface_t *scratch = cairo_image_surface_create(CAIRO_FORMAT_RGB24, 1, 1);
    cairo_t *m = cairo_create(scratch);
    cli_draw_font(m, ch->fs);
    double lw = 0;
    for (size_t f = 0; f < nfiles; f++)
        for (int k = 0; k < o->ncomps; k++) {
            char lab[512];
            legend_label(lab, sizeof lab, files, f, o, k);
            lw = fmax(lw, cli_draw_text_width(m, lab));
        }
    cairo_status_t st = cairo_status(m);
    cairo_destroy(m);
    cairo_surface_destroy(scratch);
    if (st != CAIRO_STATUS_SUCCESS)
        return -1;
    lw = fmin(lw, 0.45 * o->size);
    ch->width = o->size;
    ch->left = 4.2 * ch->fs;
    ch->right = ch->width - (lw + 5.4 * ch->fs);
    if (ch->right - ch->left < 0.4 * ch->width)
        ch->right = ch->left + 0.4 * ch->width;
    ch->pw = ch->right - ch->left;
    ch->legend_x = ch->right + 1.2 * ch->fs;
    ch->ph = 0.6 * ch->pw;
    ch->top = 2.2 * ch->fs;                    /* a panel's title band */
    ch->panel_h = ch->top + ch->ph + 3.4 * ch->fs; /* and its axis labels */
    ch->height = ceil(npanels * ch->panel_h + 0.5 * ch->fs);
    ch->width = fmax(ch->width, ceil(ch->legend_x + 3 * ch->fs + lw + ch->fs));
    /* the vertical axis: --range, or 0 to a round value above the largest */
    double vmax = 0;
    for (size_t i = 0; i < all->n; i++)
        for (size_t j = 0; j < all->c[i].n; j++)
            vmax = fmax(vmax, all->c[i].s[j].v);
    if (isfinite(o->ymin)) {
        ch->ymin = o->ymin, ch->ymax = o->ymax, ch->ystep = nice_step(ch->ymax - ch->ymin);
    } else {
        ch->ymin = 0;
        ch->ystep = nice_step(vmax > 0 ? vmax : 1);
        ch->ymax = ch->ystep * ceil((vmax > 0 ? vmax : 1) / ch->ystep - 1e-9);
    }
    return 0;
}

/* Panel p (channel panels[p]): its title, grid, ticks, the curves' steps and the legend. */
static void draw_panel(cairo_t *cr, const struct chart *ch, size_t p, const char *panel,
                       const char *title, size_t nfiles, char **files,
                       const struct cli_curve_opts *o, const struct curves *all)
{
    double y0 = p * ch->panel_h, top = y0 + ch->top, bot = top + ch->ph;
    char head[512];
    snprintf(head, sizeof head, "%s: %s", panel, title);
    cli_draw_font(cr, ch->fs);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cli_draw_text(cr, ch->left, y0 + 1.5 * ch->fs, 0, 0, head);
    /* grid and ticks */
    cairo_set_line_width(cr, 0.6);
    cairo_set_source_rgb(cr, 0.85, 0.85, 0.85);
    for (int t = 0; t <= 90; t += 15) {
        cairo_move_to(cr, xpos(ch, t), top);
        cairo_line_to(cr, xpos(ch, t), bot);
    }
    for (double v = ch->ymin; v <= ch->ymax + 1e-9 * ch->ystep; v += ch->ystep) {
        cairo_move_to(cr, ch->left, ypos(ch, top, v));
        cairo_line_to(cr, ch->right, ypos(ch, top, v));
    }
    cairo_stroke(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1);
    cairo_rectangle(cr, ch->left, top, ch->pw, ch->ph);
    cairo_stroke(cr);
    for (int t = 0; t <= 90; t += 15) {
        char lab[16];
        snprintf(lab, sizeof lab, "%d\xc2\xb0", t);
        cli_draw_text(cr, xpos(ch, t), bot + 0.5 * ch->fs, 0.5, 1, lab);
    }
    for (double v = ch->ymin; v <= ch->ymax + 1e-9 * ch->ystep; v += ch->ystep) {
        char lab[32];
        snprintf(lab, sizeof lab, "%g", fabs(v) < 1e-12 * ch->ystep ? 0 : v);
        cli_draw_text(cr, ch->left - 0.4 * ch->fs, ypos(ch, top, v), 1, 0.5, lab);
    }
    snprintf(head, sizeof head, "incidence \xce\xb8 (degrees from the normal of the incident side)");
    cli_draw_text(cr, ch->left + ch->pw / 2, bot + 2.9 * ch->fs, 0.5, 0, head);
    /* the steps, clipped to the plot area (a --range may cut them) */
    cairo_save(cr);
    cairo_rectangle(cr, ch->left, top, ch->pw, ch->ph);
    cairo_clip(cr);
    cairo_set_line_join(cr, CAIRO_LINE_JOIN_MITER);
    for (size_t i = 0; i < all->n; i++) {
        const struct curve *c = &all->c[i];
        if (strcasecmp(c->channel, panel) != 0)
            continue;
        for (size_t j = 0; j < c->n; j++) {
            double y = ypos(ch, top, c->s[j].v);
            if (j == 0)
                cairo_move_to(cr, xpos(ch, c->s[j].t0), y);
            else
                cairo_line_to(cr, xpos(ch, c->s[j].t0), y);
            cairo_line_to(cr, xpos(ch, c->s[j].t1), y);
        }
        set_style(cr, c->file, c->comp, fmax(1.2, ch->fs / 8));
        cairo_stroke(cr);
    }
    cairo_restore(cr);
    cairo_set_dash(cr, NULL, 0, 0);
    /* the legend beside the plot area */
    double ly = top + 0.8 * ch->fs;
    for (size_t f = 0; f < nfiles; f++)
        for (int k = 0; k < o->ncomps; k++, ly += 1.5 * ch->fs) {
            char lab[512];
            legend_label(lab, sizeof lab, files, f, o, k);
            set_style(cr, f, k, fmax(1.2, ch->fs / 8));
            cairo_move_to(cr, ch->legend_x, ly);
            cairo_line_to(cr, ch->legend_x + 2.4 * ch->fs, ly);
            cairo_stroke(cr);
            cairo_set_dash(cr, NULL, 0, 0);
            cairo_set_source_rgb(cr, 0, 0, 0);
            cli_draw_text(cr, ch->legend_x + 3 * ch->fs, ly, 0, 0.5, lab);
        }
}

static int draw_chart(FILE *fp, size_t nfiles, char **files, const struct cli_curve_opts *o,
                      const struct curves *all, char (*panels)[64], size_t npanels)
{
    struct chart ch;
    if (layout(&ch, nfiles, files, o, all, npanels) < 0)
        return -1;
    char what[64] = "";
    for (int k = 0; k < o->ncomps; k++)
        snprintf(what + strlen(what), sizeof what - strlen(what), "%s%s", k ? ", " : "", comp_words(o->comps[k]));
    char title[256];
    snprintf(title, sizeof title, "directional-hemispherical %s against incidence \xce\xb8, \xcf\x86 = %g\xc2\xb0",
             what, o->phi);
    struct cli_draw d;
    if (cli_draw_begin(&d, fp, o->format, ch.width, ch.height, title) != CAIRO_STATUS_SUCCESS)
        return -1;
    cairo_t *cr = d.cr;
    for (size_t p = 0; p < npanels; p++)
        draw_panel(cr, &ch, p, panels[p], title, nfiles, files, o, all);
    return cli_draw_end(&d) == CAIRO_STATUS_SUCCESS ? 0 : -1;
}

static int write_tsv(FILE *fp, char **files, const struct cli_curve_opts *o, const struct curves *all)
{
    fprintf(fp, "file\tchannel\tcomp\tphi\ttheta_from\ttheta_to\tpatch\tvalue\n");
    for (size_t i = 0; i < all->n; i++)
        for (size_t j = 0; j < all->c[i].n; j++)
            fprintf(fp, "%s\t%s\t%s\t%g\t%.6f\t%.6f\t%zu\t%.9g\n", files[all->c[i].file], all->c[i].channel,
                    bst_comp_name(o->comps[all->c[i].comp]), o->phi, all->c[i].s[j].t0, all->c[i].s[j].t1,
                    all->c[i].s[j].patch, all->c[i].s[j].v);
    return ferror(fp) ? -1 : 0;
}

int cli_plot_curves(const char *sub, size_t nfiles, char **files, const struct cli_curve_opts *o)
{
    int to_stdout = strcmp(o->outpath, "-") == 0 || (o->tsvpath && strcmp(o->tsvpath, "-") == 0);
    FILE *info = to_stdout ? stderr : stdout;
    struct curves all = {0};
    char (*panels)[64] = NULL;
    size_t npanels = 0;
    struct cli_out img = {0}, tsv = {0};
    /* the outputs first: a path that cannot be written is the one line said */
    int rc = o->tsvpath ? cli_out_open(&tsv, sub, o->tsvpath) : CLI_OK;
    if (rc == CLI_OK)
        rc = cli_out_open(&img, sub, o->outpath);
    for (size_t f = 0; f < nfiles && rc == CLI_OK; f++)
        rc = file_curves(sub, files[f], f, o, &all);
    /* one panel per channel, in the order the files name them */
    if (rc == CLI_OK && !(panels = malloc((all.n + 1) * sizeof *panels)))
        rc = cli_fail(sub, "out of memory");
    for (size_t i = 0; rc == CLI_OK && i < all.n; i++) {
        size_t p = 0;
        while (p < npanels && strcasecmp(panels[p], all.c[i].channel) != 0)
            p++;
        if (p == npanels)
            memcpy(panels[npanels++], all.c[i].channel, sizeof *panels);
    }
    if (rc == CLI_OK && o->tsvpath) {
        write_tsv(tsv.fp, files, o, &all);
        rc = cli_out_flush(&tsv, sub); /* a write error shows before the figure is written */
    }
    if (rc == CLI_OK && draw_chart(img.fp, nfiles, files, o, &all, panels, npanels) < 0 &&
        (rc = cli_out_flush(&img, sub)) == CLI_OK) /* a write error is told there */
        rc = cli_fail(sub, "%s: out of memory drawing the chart", o->outpath);
    for (size_t i = 0; rc == CLI_OK && i < all.n; i++) {
        const struct curve *c = &all.c[i];
        fprintf(info, "%s: %s %s, %s: %zu steps in the plane phi = %g deg, %.4f at normal incidence\n",
                files[c->file], c->channel, bst_comp_name(o->comps[c->comp]), c->basis, c->n, o->phi,
                c->s[0].v);
    }
    if (rc == CLI_OK && info == stdout)
        rc = cli_stdout_check(sub); /* the figure appears only when its summary was printed */
    if (rc == CLI_OK && o->tsvpath)
        rc = cli_out_commit(&tsv, sub);
    if (rc == CLI_OK)
        rc = cli_out_commit(&img, sub);
    cli_out_abort(&tsv);
    cli_out_abort(&img);
    for (size_t i = 0; i < all.n; i++)
        free(all.c[i].s);
    free(all.c);
    free(panels);
    return rc;
}
