/* cmd_plot.c - `bsdfstack plot FILE`: the scattered light of one component for one incidence
 * direction, drawn over the exit hemisphere as a disk (PNG or SVG) with a colour scale (drawing:
 * hemimap.c).  Incidence directions are those the light propagates in, as in `compare` and
 * `info`.  The PNG is evaluated pixel by pixel exactly as RADIANCE's libBSDF evaluates the file;
 * the SVG draws the cells of the file's own basis (Klems patches, or Shirley-Chiu cells at the
 * tree's order) with the value at each cell's centre. */
#include <config.h>

#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "cli.h"
#include "hemimap.h"

static const char help[] =
    "Usage: bsdfstack plot [--comp Tf|Rf|Tb|Rb] [--incident THETA,PHI] [--channel NAME] [--dsf]\n"
    "                      [--decades N | --linear] [--range MIN,MAX] [--projection disk|angle]\n"
    "                      [--size PIXELS] [--format png|svg] -o OUT FILE\n"
    "Draws the BSDF (1/sr) that FILE holds for one component and one incidence direction over the\n"
    "exit hemisphere, as a disk with a colour scale, and prints the peak and the\n"
    "directional-hemispherical value.  The disk shows exit directions at their x, y components in\n"
    "the file's frame (+X right, +Y up, the window seen from its interior side); a ring marks the\n"
    "direction of the incident light continued (transmission) or mirrored (reflection).\n"
    "\n"
    "Options:\n"
    "  --comp C           component: Tf (default), Rf, Tb or Rb\n"
    "  --incident T,P     direction the incident light propagates in, degrees (default 0,0):\n"
    "                     theta from the normal of the incidence side, phi from +X towards +Y\n"
    "  --channel NAME     spectral channel (default: the file's first)\n"
    "  --dsf              plot the DSF, BSDF x cos(theta_out), the light's distribution\n"
    "  --decades N        logarithmic scale over N decades below the peak (default 4)\n"
    "  --linear           linear scale from 0 to the peak\n"
    "  --range MIN,MAX    the scale's ends (MIN > 0 on a logarithmic scale)\n"
    "  --projection P     disk (default: radius sin theta, each tree cell the same area) or\n"
    "                     angle (radius theta / 90 degrees)\n"
    "  --size PIXELS      diameter of the disk, 64-4096 (default 480)\n"
    "  --format F         png or svg (default: from OUT's extension; png for -o -)\n"
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

/* ------------------------------------------------------------------ the command */

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
                                             {"output", required_argument, NULL, 'o'},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *sub = "plot", *channel = NULL, *outpath = NULL, *format = NULL;
    int comp = BST_TF, dsf = 0, linear = 0, angle = 0, size = 480, c, have_decades = 0;
    double incident[2] = {0, 0}, decades = 4, rmin = NAN, rmax = NAN;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":ho:", longopts, NULL)) != -1) {
        char extra;
        switch (c) {
        case 'C':
            if ((comp = bst_comp_parse(optarg)) < 0)
                return cli_usage(sub, "--comp %s: use Tf, Rf, Tb or Rb", optarg);
            break;
        case 'i':
            if (cli_parse_incident(sub, optarg, incident) != CLI_OK)
                return CLI_USAGE;
            break;
        case 'c': channel = optarg; break;
        case 'D': dsf = 1; break;
        case 'd':
            if (cli_parse_double(optarg, &decades) != 0 || decades < 0.1 || decades > 30)
                return cli_usage(sub, "--decades %s: give a number between 0.1 and 30", optarg);
            have_decades = 1;
            break;
        case 'l': linear = 1; break;
        case 'r':
            if (sscanf(optarg, "%lf,%lf%c", &rmin, &rmax, &extra) != 2 || !isfinite(rmin) ||
                !isfinite(rmax) || rmin < 0 || rmax <= rmin)
                return cli_usage(sub, "--range %s: give MIN,MAX with 0 <= MIN < MAX", optarg);
            break;
        case 'p':
            if (strcmp(optarg, "disk") == 0)
                angle = 0;
            else if (strcmp(optarg, "angle") == 0)
                angle = 1;
            else
                return cli_usage(sub, "--projection %s: use disk or angle", optarg);
            break;
        case 's':
            if (cli_parse_int(optarg, &size) != 0 || size < 64 || size > 4096)
                return cli_usage(sub, "--size %s: give a diameter of 64 to 4096 pixels", optarg);
            break;
        case 'f':
            if (strcmp(optarg, "png") != 0 && strcmp(optarg, "svg") != 0)
                return cli_usage(sub, "--format %s: use png or svg", optarg);
            format = optarg;
            break;
        case 'o': outpath = optarg; break;
        case 'h': fputs(help, stdout); return CLI_OK;
        case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    if (argc - optind != 1)
        return cli_usage(sub, argc - optind < 1 ? "no file given" : "one file expected");
    if (!outpath)
        return cli_usage(sub, "no output given: -o OUT.png, -o OUT.svg or -o - for standard output");
    if (linear && have_decades)
        return cli_usage(sub, "--linear and --decades exclude each other");
    if (!linear && rmin == 0 && rmax > 0)
        return cli_usage(sub, "--range: a logarithmic scale needs MIN > 0 (or use --linear)");
    const char *path = argv[optind];
    if (strncmp(path, "glass:", 6) == 0)
        return cli_fail(sub, "%s: a clear pane scatters nothing off the specular direction; plot "
                        "reads BSDF files (see bsdfstack glass for its T and R)", path);
    if (!format) {
        size_t n = strlen(outpath);
        if (strcmp(outpath, "-") == 0 || (n > 4 && strcasecmp(outpath + n - 4, ".png") == 0))
            format = "png";
        else if (n > 4 && strcasecmp(outpath + n - 4, ".svg") == 0)
            format = "svg";
        else
            return cli_usage(sub, "-o %s: name a .png or .svg file, or give --format", outpath);
    }

    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    bst_bsdf *b = NULL;
    bst_basis *sc_basis = NULL;
    double *cell = NULL;
    struct cli_out out = {0};
    int rc = CLI_OK;
    if (bst_bsdf_read(ctx, path, NULL, &b) < 0) {
        rc = cli_fail_ctx(sub, path, ctx);
        goto done;
    }
    cli_warn_bsdf(sub, path, b);
    bst_ctx_clear(ctx);
    struct plot p = {ctx, b, 0, (bst_comp)comp, {0, 0, 0}, 0, dsf};
    if (channel) {
        while (p.ch < bst_bsdf_nchannels(b) && strcasecmp(bst_bsdf_channel(b, p.ch), channel) != 0)
            p.ch++;
        if (p.ch == bst_bsdf_nchannels(b)) {
            rc = cli_fail(sub, "%s: no channel '%s' in the file", path, channel);
            goto done;
        }
    }
    /* incidence side: front (Tf, Rf) light travels towards +Z; in points back at the source */
    int front = comp == BST_TF || comp == BST_RF;
    double theta = incident[0], phi = incident[1];
    double t = theta * M_PI / 180, f = phi * M_PI / 180;
    double prop[3] = {sin(t) * cos(f), sin(t) * sin(f), (front ? 1 : -1) * cos(t)};
    p.in[0] = -prop[0], p.in[1] = -prop[1], p.in[2] = -prop[2];
    p.exit_sign = (comp == BST_TF || comp == BST_RB) ? 1 : -1;
    double mark[3] = {prop[0], prop[1], fabs(prop[2])}; /* continued or mirrored: same x, y */

    /* the file's own cells: peak and hemispherical value, and the SVG's polygons */
    const bst_basis *basis = bst_bsdf_klems_basis(b);
    if (!basis) {
        if (bst_basis_new_sc(ctx, bst_bsdf_order(b), &sc_basis) < 0) {
            rc = cli_fail_ctx(sub, path, ctx);
            goto done;
        }
        basis = sc_basis;
    }
    size_t n = bst_basis_size(basis), jmax = 0;
    const double *lambda = bst_basis_lambda(basis);
    cell = malloc(n * sizeof *cell);
    if (!cell) {
        rc = cli_fail(sub, "out of memory");
        goto done;
    }
    double hem = 0;
    for (size_t j = 0; j < n; j++) {
        double d[3], bsdf;
        bst_basis_center(basis, j, d);
        if (value_at(ctx, &p, d, &cell[j]) < 0) {
            rc = cli_fail_ctx(sub, path, ctx);
            goto done;
        }
        bsdf = dsf ? cell[j] / d[2] : cell[j];
        if (!isfinite(cell[j]) || cell[j] < 0) {
            rc = cli_fail(sub, "%s: value %g at exit patch %zu: not a BSDF", path, cell[j], j);
            goto done;
        }
        hem += bsdf * lambda[j];
        jmax = cell[j] > cell[jmax] ? j : jmax;
    }
    double peak = cell[jmax];
    struct cli_hemimap map = {.log = !linear};
    if (isfinite(rmin))
        map.lo = rmin, map.hi = rmax;
    else if (peak <= 0)
        map.lo = linear ? 0 : 1e-4, map.hi = 1; /* all zero: a scale that shows it */
    else
        map.lo = linear ? 0 : peak * pow(10.0, -decades), map.hi = peak;

    const char *quantity = dsf ? "DSF" : "BSDF";
    char title[1024];
    const char *base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    snprintf(title, sizeof title, "%s %s, %s, incidence theta %g phi %g, %s 1/sr", base,
             bst_comp_name(p.comp), bst_bsdf_channel(b, p.ch), theta, phi, quantity);
    double dm[3];
    bst_basis_center(basis, jmax, dm);
    FILE *info = strcmp(outpath, "-") == 0 ? stderr : stdout;
    fprintf(info, "%s %s, channel %s, incidence (theta, phi) = (%g, %g) deg\n", path,
            bst_comp_name(p.comp), bst_bsdf_channel(b, p.ch), theta, phi);
    fprintf(info, "peak %s %.6g 1/sr at exit (theta, phi) = (%.1f, %.1f) deg; directional-"
                  "hemispherical %.4f\n", quantity, peak, acos(dm[2]) * 180 / M_PI,
            fmod(atan2(dm[1], dm[0]) * 180 / M_PI + 360, 360), hem);
    fprintf(info, "scale %s %.4g .. %.4g 1/sr\n", map.log ? "log" : "linear", map.lo, map.hi);

    map.basis = basis, map.cell = cell, map.value = pixel_value, map.opaque = &p;
    map.angle = angle, map.size = size, map.title = title, map.unit = "1/sr";
    memcpy(map.mark, mark, sizeof mark);
    if ((rc = cli_out_open(&out, sub, outpath)) != CLI_OK)
        goto done;
    int st = cli_hemimap_write(out.fp, strcmp(format, "svg") == 0, &map);
    if (st == CLI_HEMIMAP_EVALUE)
        rc = cli_fail_ctx(sub, path, ctx);
    else if (st < 0 && (rc = cli_out_flush(&out, sub)) == CLI_OK) /* a write error is told there */
        rc = cli_fail(sub, "%s: out of memory drawing the image", outpath);
    if (rc == CLI_OK && info == stdout)
        rc = cli_stdout_check(sub); /* the image appears only when its summary was printed */
    if (rc == CLI_OK)
        rc = cli_out_commit(&out, sub);
    else
        cli_out_abort(&out);
done:
    free(cell);
    bst_basis_free(sc_basis);
    bst_bsdf_free(b);
    bst_ctx_free(ctx);
    return rc;
}
