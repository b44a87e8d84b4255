/* cmd_plot.c - `bsdfstack plot`: two figures, drawn with cairo as PNG, SVG or PDF.
 *
 * The map (default): the scattered light of one component for one incidence direction, over the
 * exit hemisphere as a disk with a colour scale (drawing: hemimap.c), from a BSDF XML file or
 * from a column of the TSV `combine --incident` writes (incident_table.c).  Incidence directions
 * are those the light propagates in, as in `compare` and `info`.  A PNG of a file is evaluated
 * pixel by pixel exactly as RADIANCE's libBSDF evaluates the file, for light from the incident
 * patch info's table takes (incidence()); SVG and PDF draw the cells of the file's own basis
 * (Klems patches, or Shirley-Chiu cells at the tree's order) with the value at each cell's
 * centre, and so does every format for a table, which holds only those values.
 *
 * The curves (--curve): directional-hemispherical values against incidence theta, plot_curve.c. */
#include <config.h>

#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "cli.h"
#include "draw.h"
#include "hemimap.h"
#include "incident_table.h"
#include "layers.h"
#include "plot.h"

static const char help[] =
    "Usage: bsdfstack plot [--comp Tf|Rf|Tb|Rb] [--incident THETA,PHI] [--channel NAME] [--dsf]\n"
    "                      [--decades N | --linear] [--range MIN,MAX] [--projection disk|angle]\n"
    "                      [--size PIXELS] [--format png|svg|pdf] -o OUT FILE\n"
    "       bsdfstack plot --curve [--comp LIST] [--phi PHI] [--channel NAME] [--range MIN,MAX]\n"
    "                      [--size PIXELS] [--format png|svg|pdf] [--tsv VALUES]\n"
    "                      [--max-memory SIZE] -o OUT FILE...\n"
    "Draws the BSDF (1/sr) that FILE holds for one component and one incidence direction over the\n"
    "exit hemisphere, as a disk with a colour scale, and prints the peak and the\n"
    "directional-hemispherical value.  The disk shows exit directions at their x, y components in\n"
    "the file's frame (+X right, +Y up, the window seen from its interior side); a ring marks the\n"
    "direction of the incident light continued (transmission) or mirrored (reflection).  FILE is\n"
    "a BSDF XML file or the TSV 'bsdfstack combine --incident' writes (named *.tsv, or starting\n"
    "with its header line), of which one column is drawn.\n"
    "With --curve, draws the directional-hemispherical value of each FILE (BSDF XML) against the\n"
    "incidence angle theta, as steps over the file's own incident patches along the plane of\n"
    "incidence --phi, one chart per channel, with a legend.\n"
    "\n"
    "Options:\n"
    "  --comp C           component: Tf (default), Rf, Tb or Rb; with --curve a comma-separated\n"
    "                     list, e.g. Tf,Rf for T and R of front incidence (default Tf)\n"
    "  --incident T,P     direction the incident light propagates in, degrees (default 0,0; for a\n"
    "                     table its first direction): theta from the normal of the incidence\n"
    "                     side, phi from +X towards +Y; a patch boundary takes the patch on the\n"
    "                     +x, +y side, as in info's table\n"
    "  --channel NAME     spectral channel (default: the file's first; with --curve every channel,\n"
    "                     one chart each)\n"
    "  --dsf              plot the DSF, BSDF x cos(theta_out), the light's distribution\n"
    "  --decades N        logarithmic scale over N decades below the peak (default 4)\n"
    "  --linear           linear scale from 0 to the peak\n"
    "  --range MIN,MAX    the scale's ends (MIN > 0 on a logarithmic scale); with --curve the\n"
    "                     vertical axis's (default 0 to a round value above the largest)\n"
    "  --projection P     disk (default: radius sin theta, each tree cell the same area) or\n"
    "                     angle (radius theta / 90 degrees)\n"
    "  --curve            draw hemispherical values against incidence theta instead of a map\n"
    "  --phi PHI          with --curve: the propagation azimuth of the plane of incidence, degrees\n"
    "                     (default 0); a patch boundary in it takes the patch on the +x, +y side,\n"
    "                     as in info's table\n"
    "  --tsv VALUES       with --curve: also write the steps as TSV (file, channel, comp, phi,\n"
    "                     theta_from, theta_to, patch, value); - for standard output\n"
    "  --max-memory SIZE  with --curve: refuse a file whose layer would need more (16G, 800M;\n"
    "                     default: the memory available now), as info does\n"
    "  --size PIXELS      diameter of the disk, 64-4096 (default 480); with --curve the chart's\n"
    "                     width (default 720)\n"
    "  --format F         png, svg or pdf (default: from OUT's extension, .png, .svg or .pdf;\n"
    "                     png for -o -); SVG and PDF sizes are in points\n"
    "  -o OUT             the image; - writes it to standard output (a regular file is replaced\n"
    "                     atomically, a symbolic link's target is written, a device or FIFO\n"
    "                     directly)\n";

/* ------------------------------------------------------------------ the BSDF, sampled */

struct plot {
    bst_ctx *ctx;
    const bst_bsdf *b;
    size_t ch;
    bst_comp comp;
    double in[3];        /* towards the source, the file's frame */
    double exit_sign;    /* sign of z of exit directions */
    int dsf;
};

static int value_at(bst_ctx *ctx, const struct plot *p, const double d[3], double *v)
{
    if (!ctx)
        ctx = p->ctx;
    double out[3] = {d[0], d[1], p->exit_sign * d[2]};
    if (bst_bsdf_eval(ctx, p->b, p->ch, p->in, out, v) < 0)
        return -1;
    if (p->dsf)
        *v *= d[2];
    return 0;
}

static int pixel_value(void *opaque, const double d[3], double *v)
{
    return value_at(NULL, opaque, d, v);
}

/* ------------------------------------------------------------------ the map */

struct map_opts {
    bst_comp comp;
    const char *channel;
    int have_incident, dsf, linear, angle, size, format;
    double incident[2], decades, rmin, rmax;
    const char *outpath;
};

/* What the map draws: a value per cell of basis, and how a PNG's pixel gets its value. */
struct map_data {
    const bst_basis *basis;
    double *cell;
    const char *channel;
    double theta, phi;        /* the incidence drawn */
    struct plot *eval;        /* a file: pixel by pixel; NULL: by cell */
};

/* Where the light comes from (in, towards the source) for the incidence o asks.  A Klems matrix
 * or a rank-4 tree holds one value per incident patch of its own basis, so the light comes from
 * the centre of the patch info's table takes (cli_incident_patch).  The direction asked would do
 * off the patch boundaries, but 0,0 and the planes phi = 0, 90 lie on them: a transmission the
 * file stores only for the other side is read with in and out exchanged, and the boundary,
 * exchanged, is taken to the patch mirrored through the normal; a centre's image lies inside the
 * antipodal patch, the one reciprocity pairs with it.  A rank-3 tree turns with the incidence
 * azimuth: the direction asked. */
static void incidence(const bst_bsdf *b, const bst_basis *basis, const struct map_opts *o,
                      double in[3])
{
    double t = o->incident[0] * M_PI / 180, f = o->incident[1] * M_PI / 180;
    double d[3] = {sin(t) * cos(f), sin(t) * sin(f), cos(t)}; /* the light's propagation */
    if (bst_bsdf_kind(b) != BST_FILE_TT3)
        bst_basis_center(basis, cli_incident_patch(basis, o->incident[0], o->incident[1]), d);
    /* front (Tf, Rf) light travels towards +Z */
    int front = o->comp == BST_TF || o->comp == BST_RF;
    in[0] = -d[0], in[1] = -d[1], in[2] = (front ? -1 : 1) * d[2];
}

/* The cells' values of a file: at each cell's centre, as libBSDF evaluates the file. */
static int file_cells(const char *sub, const char *path, const struct map_opts *o, bst_ctx *ctx,
                      bst_bsdf **b, bst_basis **sc_basis, struct plot *p, struct map_data *md)
{
    if (bst_bsdf_read(ctx, path, NULL, b) < 0)
        return cli_fail_ctx(sub, path, ctx);
    cli_warn_bsdf(sub, path, *b);
    bst_ctx_clear(ctx);
    *p = (struct plot){ctx, *b, 0, o->comp, {0, 0, 0}, 0, o->dsf};
    if (o->channel) {
        while (p->ch < bst_bsdf_nchannels(*b) && strcasecmp(bst_bsdf_channel(*b, p->ch), o->channel) != 0)
            p->ch++;
        if (p->ch == bst_bsdf_nchannels(*b))
            return cli_fail(sub, "%s: no channel '%s' in the file", path, o->channel);
    }
    md->basis = bst_bsdf_klems_basis(*b);
    if (!md->basis) {
        if (bst_basis_new_sc(ctx, bst_bsdf_order(*b), sc_basis) < 0)
            return cli_fail_ctx(sub, path, ctx);
        md->basis = *sc_basis;
    }
    incidence(*b, md->basis, o, p->in);
    p->exit_sign = (o->comp == BST_TF || o->comp == BST_RB) ? 1 : -1;
    size_t n = bst_basis_size(md->basis);
    if (!(md->cell = malloc(n * sizeof *md->cell)))
        return cli_fail(sub, "out of memory");
    for (size_t j = 0; j < n; j++) {
        double d[3];
        bst_basis_center(md->basis, j, d);
        if (value_at(ctx, p, d, &md->cell[j]) < 0)
            return cli_fail_ctx(sub, path, ctx);
    }
    md->channel = bst_bsdf_channel(*b, p->ch);
    md->theta = o->incident[0], md->phi = o->incident[1];
    md->eval = p;
    return CLI_OK;
}

/* The cells' values of a table's column (the DSF: times the cosine of each cell's centre). */
static int table_cells(const char *sub, const char *path, const struct map_opts *o,
                       struct cli_incident_column *col, struct map_data *md)
{
    int rc = cli_incident_column_read(sub, path, o->channel, o->comp, o->have_incident ? o->incident : NULL, col);
    if (rc != CLI_OK)
        return rc;
    md->basis = col->basis;
    md->cell = col->bsdf;
    col->bsdf = NULL; /* md owns it now */
    if (o->dsf)
        for (size_t j = 0; j < bst_basis_size(md->basis); j++) {
            double d[3];
            bst_basis_center(md->basis, j, d);
            md->cell[j] *= d[2];
        }
    md->channel = col->channel;
    md->theta = col->theta_in, md->phi = col->phi_in;
    md->eval = NULL;
    return CLI_OK;
}

static int plot_map(const char *sub, const char *path, const struct map_opts *o)
{
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    bst_bsdf *b = NULL;
    bst_basis *sc_basis = NULL;
    struct cli_incident_column col = {0};
    struct plot p;
    struct map_data md = {0};
    struct cli_out out = {0};
    int rc = cli_incident_table_is(path) ? table_cells(sub, path, o, &col, &md)
                                         : file_cells(sub, path, o, ctx, &b, &sc_basis, &p, &md);
    if (rc != CLI_OK)
        goto done;
    size_t n = bst_basis_size(md.basis), jmax = 0;
    const double *lambda = bst_basis_lambda(md.basis);
    double hem = 0;
    for (size_t j = 0; j < n; j++) {
        double d[3];
        bst_basis_center(md.basis, j, d);
        if (!isfinite(md.cell[j]) || md.cell[j] < 0) {
            rc = cli_fail(sub, "%s: value %g at exit patch %zu: not a BSDF", path, md.cell[j], j);
            goto done;
        }
        hem += (o->dsf ? md.cell[j] / d[2] : md.cell[j]) * lambda[j];
        jmax = md.cell[j] > md.cell[jmax] ? j : jmax;
    }
    double peak = md.cell[jmax];
    struct cli_hemimap map = {.log = !o->linear};
    if (isfinite(o->rmin))
        map.lo = o->rmin, map.hi = o->rmax;
    else if (peak <= 0)
        map.lo = o->linear ? 0 : 1e-4, map.hi = 1; /* all zero: a scale that shows it */
    else
        map.lo = o->linear ? 0 : peak * pow(10.0, -o->decades), map.hi = peak;

    /* the output first: a path that cannot be written is the one line said */
    if ((rc = cli_out_open(&out, sub, o->outpath)) != CLI_OK)
        goto done;
    const char *quantity = o->dsf ? "DSF" : "BSDF";
    char title[1024];
    const char *base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    snprintf(title, sizeof title, "%s %s, %s, incidence \xce\xb8 %g\xc2\xb0 \xcf\x86 %g\xc2\xb0, %s",
             base, bst_comp_name(o->comp), md.channel, md.theta, md.phi, quantity);
    double dm[3];
    bst_basis_center(md.basis, jmax, dm);
    FILE *info = strcmp(o->outpath, "-") == 0 ? stderr : stdout;
    fprintf(info, "%s %s, channel %s, incidence (theta, phi) = (%g, %g) deg\n", path,
            bst_comp_name(o->comp), md.channel, md.theta, md.phi);
    fprintf(info, "peak %s %.6g 1/sr at exit (theta, phi) = (%.1f, %.1f) deg; directional-"
                  "hemispherical %.4f\n", quantity, peak, acos(dm[2]) * 180 / M_PI,
            fmod(atan2(dm[1], dm[0]) * 180 / M_PI + 360, 360), hem);
    fprintf(info, "scale %s %.4g .. %.4g 1/sr\n", map.log ? "log" : "linear", map.lo, map.hi);

    /* the incident light continued (transmission) or mirrored (reflection): the same x, y */
    double t = md.theta * M_PI / 180, f = md.phi * M_PI / 180;
    map.mark[0] = sin(t) * cos(f), map.mark[1] = sin(t) * sin(f), map.mark[2] = cos(t);
    map.basis = md.basis, map.cell = md.cell;
    map.value = md.eval ? pixel_value : NULL, map.opaque = md.eval;
    map.angle = o->angle, map.size = o->size, map.title = title, map.unit = "1/sr";
    double cx, cy, r, w, h;
    cli_hemimap_geometry(&map, &cx, &cy, &r, &w, &h);
    fprintf(info, "image %g x %g %s, disk centre (%g, %g) radius %g\n", w, h,
            o->format == CLI_DRAW_PNG ? "pixels" : "points", cx, cy, r);
    int st = cli_hemimap_write(out.fp, o->format, &map);
    if (st == CLI_HEMIMAP_EVALUE)
        rc = cli_fail_ctx(sub, path, ctx);
    else if (st < 0 && (rc = cli_out_flush(&out, sub)) == CLI_OK) /* a write error is told there */
        rc = cli_fail(sub, "%s: out of memory drawing the image", o->outpath);
    if (rc == CLI_OK && info == stdout)
        rc = cli_stdout_check(sub); /* the image appears only when its summary was printed */
    if (rc == CLI_OK)
        rc = cli_out_commit(&out, sub);
    else
        cli_out_abort(&out);
done:
    cli_out_abort(&out);
    free(md.cell);
    cli_incident_column_free(&col);
    bst_basis_free(sc_basis);
    bst_bsdf_free(b);
    bst_ctx_free(ctx);
    return rc;
}

/* ------------------------------------------------------------------ the command */

/* --comp: one component, or with --curve a list without repeats */
static int parse_comps(const char *sub, const char *arg, struct cli_curve_opts *c)
{
    char buf[64];
    if (strlen(arg) >= sizeof buf)
        return cli_usage(sub, "--comp %s: use Tf, Rf, Tb or Rb, or a list of them", arg);
    strcpy(buf, arg);
    c->ncomps = 0;
    for (char *s = buf, *e; s; s = e) {
        if ((e = strchr(s, ',')))
            *e++ = '\0';
        int k = bst_comp_parse(s);
        if (k < 0)
            return cli_usage(sub, "--comp %s: use Tf, Rf, Tb or Rb, or a list of them", arg);
        for (int i = 0; i < c->ncomps; i++)
            if (c->comps[i] == (bst_comp)k)
                return cli_usage(sub, "--comp %s: %s twice", arg, s);
        c->comps[c->ncomps++] = (bst_comp)k;
    }
    return CLI_OK;
}

enum { O_CURVE = 256, O_PHI, O_TSV, O_MAXMEM };

/* What the command line asks for: a map (m) or curves (cv). */
struct plot_req {
    struct map_opts m;
    struct cli_curve_opts cv;
    const char *map_only, *curve_only; /* an option given that only a map, or curves, take */
    int have_decades, curve;
};

/* Option c with value arg into q: CLI_OK, a usage error, or -1 when c is not one of these. */
static int option(const char *sub, int c, const char *arg, struct plot_req *q)
{
    char extra;
    switch (c) {
    case 'C':
        if (parse_comps(sub, arg, &q->cv) != CLI_OK)
            return CLI_USAGE;
        q->m.comp = q->cv.comps[0];
        break;
    case 'i':
        if (cli_parse_incident(sub, arg, q->m.incident) != CLI_OK)
            return CLI_USAGE;
        q->m.have_incident = 1, q->map_only = "--incident";
        break;
    case 'c': q->m.channel = q->cv.channel = arg; break;
    case 'D': q->m.dsf = 1, q->map_only = "--dsf"; break;
    case 'd':
        if (cli_parse_double(arg, &q->m.decades) != 0 || q->m.decades < 0.1 || q->m.decades > 30)
            return cli_usage(sub, "--decades %s: give a number between 0.1 and 30", arg);
        q->have_decades = 1, q->map_only = "--decades";
        break;
    case 'l': q->m.linear = 1, q->map_only = "--linear"; break;
    case 'r':
        if (sscanf(arg, "%lf,%lf%c", &q->m.rmin, &q->m.rmax, &extra) != 2 || !isfinite(q->m.rmin) ||
            !isfinite(q->m.rmax) || q->m.rmin < 0 || q->m.rmax <= q->m.rmin)
            return cli_usage(sub, "--range %s: give MIN,MAX with 0 <= MIN < MAX", arg);
        q->cv.ymin = q->m.rmin, q->cv.ymax = q->m.rmax;
        break;
    case 'p':
        if (strcmp(arg, "disk") == 0)
            q->m.angle = 0;
        else if (strcmp(arg, "angle") == 0)
            q->m.angle = 1;
        else
            return cli_usage(sub, "--projection %s: use disk or angle", arg);
        q->map_only = "--projection";
        break;
    case 's':
        if (cli_parse_int(arg, &q->m.size) != 0 || q->m.size < 64 || q->m.size > 4096)
            return cli_usage(sub, "--size %s: give 64 to 4096 pixels", arg);
        break;
    case 'f':
        if ((q->m.format = cli_draw_format_parse(arg)) < 0)
            return cli_usage(sub, "--format %s: use png, svg or pdf", arg);
        break;
    case O_CURVE: q->curve = 1; break;
    case O_PHI:
        if (cli_parse_double(arg, &q->cv.phi) != 0 || q->cv.phi < -360 || q->cv.phi > 360)
            return cli_usage(sub, "--phi %s: give an azimuth in degrees, -360 to 360", arg);
        q->curve_only = "--phi";
        break;
    case O_TSV:
        q->cv.tsvpath = arg, q->curve_only = "--tsv";
        return cli_parse_path(sub, "--tsv", arg);
    case O_MAXMEM:
        if (cli_parse_memory(sub, arg, &q->cv.max_memory) != CLI_OK)
            return CLI_USAGE;
        q->curve_only = "--max-memory";
        break;
    case 'o': q->m.outpath = arg; return cli_parse_path(sub, "-o", arg);
    default: return -1;
    }
    return CLI_OK;
}

int cmd_plot(int argc, char **argv)
{
    static const struct option longopts[] = {{"comp", required_argument, NULL, 'C'},
                                             {"incident", required_argument, NULL, 'i'},
                                             {"channel", required_argument, NULL, 'c'},
                                             {"dsf", no_argument, NULL, 'D'},
                                             {"decades", required_argument, NULL, 'd'},
                                             {"linear", no_argument, NULL, 'l'},
                                             {"range", required_argument, NULL, 'r'},
                                             {"projection", required_argument, NULL, 'p'},
                                             {"size", required_argument, NULL, 's'},
                                             {"format", required_argument, NULL, 'f'},
                                             {"curve", no_argument, NULL, O_CURVE},
                                             {"phi", required_argument, NULL, O_PHI},
                                             {"tsv", required_argument, NULL, O_TSV},
                                             {"max-memory", required_argument, NULL, O_MAXMEM},
                                             {"output", required_argument, NULL, 'o'},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *sub = "plot";
    struct plot_req q = {
        .m = {.comp = BST_TF, .size = 0, .format = -1, .decades = 4, .rmin = NAN, .rmax = NAN},
        .cv = {.ncomps = 1, .comps = {BST_TF}, .phi = 0, .ymin = NAN, .ymax = NAN}};
    struct map_opts *m = &q.m;
    struct cli_curve_opts *cv = &q.cv;
    int c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":ho:", longopts, NULL)) != -1) {
        int rc = option(sub, c, optarg, &q);
        if (rc == CLI_OK)
            continue;
        if (rc != -1)
            return rc;
        switch (c) {
        case 'h': fputs(help, stdout); return CLI_OK;
        case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    int nfiles = argc - optind;
    if (q.curve && q.map_only)
        return cli_usage(sub, "%s draws a map; --curve takes --comp, --phi, --channel, --range, --size, "
                         "--format, --tsv and --max-memory", q.map_only);
    if (!q.curve && q.curve_only)
        return cli_usage(sub, "%s goes with --curve", q.curve_only);
    if (!q.curve && cv->ncomps > 1)
        return cli_usage(sub, "--comp: a map draws one component (lists go with --curve)");
    if (nfiles < 1 || (!q.curve && nfiles > 1))
        return cli_usage(sub, nfiles < 1 ? "no file given" : "one file expected (several go with --curve)");
    if (!m->outpath)
        return cli_usage(sub, "no output given: -o OUT.png, OUT.svg, OUT.pdf or - for standard output");
    if (m->format < 0 && (m->format = cli_draw_format_of_path(m->outpath)) < 0)
        return cli_usage(sub, "-o %s: name a .png, .svg or .pdf file, or give --format", m->outpath);
    if (q.curve) {
        int same = cv->tsvpath ? cli_out_same(cv->tsvpath, m->outpath) : 0;
        if (same < 0)
            return cli_fail(sub, "out of memory");
        if (same && strcmp(m->outpath, "-") == 0)
            return cli_usage(sub, "--tsv - and -o - would both write to standard output");
        if (same)
            return cli_usage(sub, "--tsv %s and -o %s name the same file", cv->tsvpath, m->outpath);
        cv->size = m->size ? m->size : 720;
        cv->format = m->format;
        cv->outpath = m->outpath;
        return cli_plot_curves(sub, (size_t)nfiles, argv + optind, cv);
    }
    if (m->linear && q.have_decades)
        return cli_usage(sub, "--linear and --decades exclude each other");
    if (!m->linear && m->rmin == 0 && m->rmax > 0)
        return cli_usage(sub, "--range: a logarithmic scale needs MIN > 0 (or use --linear)");
    if (!m->size)
        m->size = 480;
    const char *path = argv[optind];
    if (strncmp(path, "glass:", 6) == 0)
        return cli_fail(sub, "%s: a clear pane scatters nothing off the specular direction; plot "
                        "reads BSDF files (see bsdfstack glass for its T and R)", path);
    return plot_map(sub, path, m);
}
