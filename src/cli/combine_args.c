/* combine_args.c - `bsdfstack combine`'s command line: its help, and the request (combine.h) parsed
 * and checked before any work, so that a wrong option costs nothing. */
#include <config.h>

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "combine.h"

static const char help[] =
    "Usage: bsdfstack combine [-k K | --klems[=full|half|quarter]] [--only Tf,Rf,Tb,Rb]\n"
    "                         [--channels NAMES] [--precision double|single] [--drop-tol X]\n"
    "                         [--reduce PCT | --no-reduce] [--reduce-tol T] [--dense]\n"
    "                         [--absorptance FILE]\n"
    "                         [--per-channel] [--spectral-tol X] [--glass-rule average|centre]\n"
    "                         [--rank3 exact|native] [--strict] [--max-memory SIZE]\n"
    "                         [--incident THETA,PHI]...\n"
    "                         [--incident-file FILE]\n"
    "                         [--fine-incident THETA,PHI]... [--fine-incident-file FILE]\n"
    "                         [--sun-path LAT,LON,MERIDIAN [--azimuth DEG] [--sun-step MIN]]\n"
    "                         [--coarse-k KC] [--threads N] [-v] -o OUT LAYER LAYER...\n"
    "Combines the layers, listed exterior first, with every inter-reflection between them, and\n"
    "writes the system's BSDF as BSDF XML.  When at least one layer is a pane with spectral data\n"
    "and every other layer is a file with Solar and Visible channels (WINDOW's dual-band\n"
    "material: Visible inside 0.38..0.78 um, (Solar - 0.499 Visible) / 0.501 outside), the stack\n"
    "is combined wavelength by wavelength and averaged per channel afterwards (as WINDOW does);\n"
    "otherwise each channel's band values are combined.  The output's metadata says which and\n"
    "why; -v prints it.\n"
    "\n"
    "Layers:\n"
    "  FILE.xml           a BSDF XML file (Klems, TensorTree3/4, any resolution)\n"
    "  glass:NAME         a pane of the glass catalogue (bsdfstack-glass(5)); glass:FILE a spectral\n"
    "                     data file (table, Optics file, IGSDB record); glass:d=6mm,n=1.52,tn=0.89\n"
    "                     an inline pane; ,model=coated|uncoated after any of them\n"
    "  venetian:KEYS      a venetian blind from its geometry: width=16mm,spacing=14.5mm,tilt=45,\n"
    "                     rs=0.765,r=0.085,roughness=0.02 (also curvature, vertical, r-up,\n"
    "                     r-down, t, segments, samples; rule=centre for WINDOW's model with\n"
    "                     distribution=directional|uniform; bsdfstack-glass(5))\n"
    "  perforated:KEYS    a perforated screen: x=5mm,y=5mm,radius=1.5mm,thickness=1mm,r=0.7\n"
    "                     (or hole-x, hole-y for rectangular holes; rf, rb, t, samples;\n"
    "                     rule=centre for WINDOW's model)\n"
    "  woven:KEYS         a woven fabric: diameter=0.5mm,spacing=2mm,r=0.6,t=0.1 (or rf, rb;\n"
    "                     rule=centre for WINDOW's model)\n"
    "  shade:FILE.json    an IGSDB shading record (venetian, perforated-screen, woven) as the\n"
    "                     layer of its geometric model; ,KEY=VALUE,... after the file name\n"
    "                     overrides the record's values with that model's keys (tilt=30,\n"
    "                     segments=8); `bsdfstack info shade:FILE.json` shows the model\n"
    "  LAYER^             the layer installed reversed (back side facing the exterior)\n"
    "\n"
    "Options:\n"
    "  -k K               Shirley-Chiu tensor-tree basis of order K (1..7)\n"
    "  --klems[=WHICH]    Klems basis: full (default, 145 patches), half or quarter\n"
    "                     Neither given: the finest order among tensor-tree layers; with no tree,\n"
    "                     the Klems basis of the first Klems file (Klems output); with panes\n"
    "                     only, k = 5\n"
    "  --only COMPS       only these components (comma-separated Tf, Rf, Tb, Rb)\n"
    "  --channels NAMES   only these channels (e.g. Visible,Solar); default: all in common\n"
    "  --precision P      double (default) or single precision for dense work\n"
    "  --drop-tol X       drop sparse fill-in below X times a product's largest value (default 0)\n"
    "  --reduce PCT       tensor-tree reduction percentile written (default 90); --no-reduce: none\n"
    "  --reduce-tol T     ... merging only where every incident patch's hemispherical T and R\n"
    "                     stay within T (default 0.002; none: the percentile alone)\n"
    "  --dense            force every matrix dense (the baseline for comparisons)\n"
    "  --absorptance FILE also write per-layer absorptance per incident patch (TSV: channel,\n"
    "                     side, patch, theta, phi of the propagation direction, A1..An, T, R)\n"
    "  --per-channel      combine band values even when the stack could go per wavelength\n"
    "  --spectral-tol X   per wavelength: combine once per group of wavelengths, grouped so\n"
    "                     that the band-weighted RMS deviation of the panes'\n"
    "                     normal-incidence T and R from their group means is within X (default\n"
    "                     0.004: T, R and A within 5.1e-5 of X = 0; 0: every distinct wavelength)\n"
    "  --glass-rule R     panes' patch values: average (default) over the patch, or at its\n"
    "                     centre (centre, WINDOW's and WCE's); they differ by up to 0.08 in T\n"
    "                     in the Klems 75-90 degree ring\n"
    "  --rank3 R          rank-3 (isotropic) trees on a finer order than their depth d: exact\n"
    "                     (default) samples them at the order combined; native expands them at\n"
    "                     order d and keeps them factored (P M_d P^T): pane + the depth-5\n"
    "                     diffuser + pane at k = 6 in a fifth of the time and an eighth of the\n"
    "                     memory, GA 99.7 against exact at the paper's directions, the same T and R\n"
    "  --strict           ill-conditioning and energy imbalance (input or system) are errors\n"
    "  --max-memory SIZE  refuse when the estimated peak exceeds SIZE (16G, 800M; default: the\n"
    "                     memory available now)\n"
    "  --incident T,P     only this incidence direction (repeatable): iterate the light between\n"
    "                     the layers for its columns (--only's components) and write them as TSV\n"
    "                     (channel, comp, theta_in, phi_in, patch_in, patch_out, theta_out, phi_out,\n"
    "                     BSDF, DSF = BSDF cos theta_in); O(N^2) per direction instead of O(N^3)\n"
    "  --incident-file F  more such directions, one 'THETA PHI' a line (# comments; '-' = stdin)\n"
    "Variable resolution (one tensor tree whose depth varies; needs -k K, the fine order):\n"
    "  --fine-incident T,P  a front incidence direction (as --incident, repeatable) whose Tf and\n"
    "                     Rf columns are computed and written at order K; every other incident\n"
    "                     patch, and Tb and Rb, at order KC (the whole system at KC)\n"
    "  --fine-incident-file F  more such directions, one 'THETA PHI' a line\n"
    "  --coarse-k KC      the coarse order, 1 <= KC < K (default 4)\n"
    "  --sun-path LAT,LON,MER  the fine directions are the sun positions of a year in front of a\n"
    "                     vertical window, by gensky's formulas: latitude (north +), longitude and\n"
    "                     time zone meridian (degrees WEST of Greenwich positive, as gensky -a -o -m)\n"
    "  --azimuth DEG      the window's outward normal, from south, positive towards west (as\n"
    "                     gensky's sun azimuth): 0 faces south (default), 90 west, -90 east\n"
    "  --sun-step MIN     minutes of standard time between sun positions (default 60: every hour)\n"
    "  The file's fine columns are checked against the coarse system: a fine patch whose\n"
    "  hemispherical Tf or Rf differs from its coarse patch's by more than 0.02 is warned of\n"
    "  --threads N        threads that write trees, lay rank-3 layers onto the grid, make venetian\n"
    "                     blinds and evaluate panes of many wavelengths (default 0: one per CPU,\n"
    "                     up to 8; same bytes)\n"
    "  -v                 print OpenBLAS's kernels, the time and peak memory of reading, of\n"
    "                     each step (with its structures) and of writing\n"
    "  -o OUT             output file ('-' = standard output); a regular file is replaced\n"
    "                     atomically, a symbolic link's target is written, a device or FIFO\n"
    "                     directly (also for --absorptance)\n";

enum { O_ABS = CLI_O_OWN, O_INCIDENT, O_INCFILE, O_FINE, O_FINEFILE, O_COARSEK, O_SUN, O_AZI,
       O_SUNSTEP, O_THREADS, O_HELP };

/* --sun-path LAT,LON,MER into site; CLI_OK or a usage error. */
static int parse_site(const char *sub, const char *s, bst_sun_site *site)
{
    char extra;
    if (sscanf(s, "%lf,%lf,%lf%c", &site->latitude, &site->longitude, &site->meridian, &extra) != 3 ||
        !isfinite(site->latitude) || !isfinite(site->longitude) || !isfinite(site->meridian))
        return cli_usage(sub, "--sun-path %s: give LAT,LON,MERIDIAN in degrees", s);
    if (fabs(site->latitude) > 90)
        return cli_usage(sub, "--sun-path %s: latitude %g outside -90..90", s, site->latitude);
    if (fabs(site->longitude) > 180 || fabs(site->meridian) > 180)
        return cli_usage(sub, "--sun-path %s: longitude and meridian must lie in -180..180 (degrees "
                         "west positive)", s);
    return CLI_OK;
}

/* --incident-file: one direction a line, "THETA PHI" or "THETA,PHI" in --incident's convention;
 * blank lines and lines starting with # are skipped.  Appends to *dirs. */
int combine_read_directions(const char *sub, const char *path, double (**dirs)[2], size_t *n,
                            size_t *cap)
{
    FILE *fp = strcmp(path, "-") == 0 ? stdin : fopen(path, "r");
    if (!fp)
        return cli_fail(sub, "%s: cannot open: %s", path, strerror(errno));
    const char *name = fp == stdin ? "standard input" : path;
    char *line = NULL;
    size_t size = 0;
    ssize_t got;
    int rc = CLI_OK;
    for (long ln = 1; rc == CLI_OK && (got = cli_read_line(sub, name, ln, &line, &size, fp)) != -1; ln++) {
        if (got < 0) {
            rc = CLI_FAIL;
            break;
        }
        char *p = line + strspn(line, " \t");
        if (*p == '#' || *p == '\n' || *p == '\r' || *p == '\0')
            continue;
        double t, f;
        char extra[2];
        for (char *c = p; *c; c++)
            if (*c == ',')
                *c = ' ';
        if (sscanf(p, "%lf %lf %1s", &t, &f, extra) != 2 || !isfinite(t) || !isfinite(f) || t < 0 || t >= 90) {
            rc = cli_fail(sub, "%s:%ld: give THETA PHI in degrees, 0 <= THETA < 90", path, ln);
            break;
        }
        if (*n == COMBINE_MAX_INCIDENT) {
            rc = cli_fail(sub, "%s:%ld: more than %d directions", path, ln, COMBINE_MAX_INCIDENT);
            break;
        }
        if (*n == *cap) {
            size_t nc = *cap ? 2 * *cap : 64;
            double (*d)[2] = realloc(*dirs, nc * sizeof **dirs);
            if (!d) {
                rc = cli_fail(sub, "out of memory");
                break;
            }
            *dirs = d, *cap = nc;
        }
        (*dirs)[*n][0] = t, (*dirs)[(*n)++][1] = f;
    }
    if (rc == CLI_OK && ferror(fp))
        rc = cli_fail(sub, "%s: read error: %s", name, strerror(errno ? errno : EIO));
    if (rc == CLI_OK && *n == 0)
        rc = cli_fail(sub, "%s: no directions", path);
    free(line);
    if (fp != stdin)
        fclose(fp);
    return rc;
}

/* One more (theta, phi) of option opt from s into *list (*n of *cap). */
static int add_direction(const char *sub, const char *opt, const char *s, double (**list)[2],
                         size_t *n, size_t *cap)
{
    double one[2];
    if (cli_parse_incident(sub, s, one) != CLI_OK)
        return CLI_USAGE;
    if (*n == *cap) {
        size_t nc = *cap ? 2 * *cap : 16;
        double (*d)[2] = *n < COMBINE_MAX_INCIDENT ? realloc(*list, nc * sizeof **list) : NULL;
        if (!d)
            return cli_fail(sub, "%s: too many directions", opt);
        *list = d, *cap = nc;
    }
    (*list)[*n][0] = one[0], (*list)[(*n)++][1] = one[1];
    return CLI_OK;
}

/* An option of combine's own (not one cli_stack_option takes): CLI_OK or its error. */
static int own_option(const char *sub, int c, const char *arg, struct combine_req *q)
{
    switch (c) {
    case 'o': q->outpath = arg; return cli_parse_path(sub, "-o", arg);
    case 'v': q->verbose = 1; return CLI_OK;
    case O_ABS: q->abspath = arg; return cli_parse_path(sub, "--absorptance", arg);
    case O_INCIDENT: return add_direction(sub, "--incident", arg, &q->dirs, &q->ndirs, &q->dcap);
    case O_INCFILE: q->dirfile = arg; return cli_parse_path(sub, "--incident-file", arg);
    case O_FINE: {
        double t, p;
        char extra;
        if (sscanf(arg, "%lf,%lf%c", &t, &p, &extra) == 2 && isfinite(t) && t >= 90 && t <= 180)
            return cli_usage(sub, "--fine-incident %s: the direction is behind the window "
                             "(theta >= 90); give front incidence, 0 <= THETA < 90", arg);
        return add_direction(sub, "--fine-incident", arg, &q->fine, &q->nfine, &q->fcap);
    }
    case O_FINEFILE: q->finefile = arg; return cli_parse_path(sub, "--fine-incident-file", arg);
    case O_COARSEK:
        if (cli_parse_int(arg, &q->kc) != 0 || q->kc < BST_K_MIN || q->kc >= BST_K_MAX)
            return cli_usage(sub, "--coarse-k %s: give an order from %d to %d", arg, BST_K_MIN,
                             BST_K_MAX - 1);
        return CLI_OK;
    case O_SUN:
        q->sun = 1;
        return parse_site(sub, arg, &q->site);
    case O_AZI:
        if (cli_parse_double(arg, &q->azimuth) != 0 || fabs(q->azimuth) > 360)
            return cli_usage(sub, "--azimuth %s: give the window's azimuth in degrees from south, "
                             "positive towards west (-360..360)", arg);
        q->azimuth_set = 1;
        return CLI_OK;
    case O_SUNSTEP:
        if (cli_parse_double(arg, &q->sun_step) != 0 || q->sun_step < 1 || q->sun_step > 1440)
            return cli_usage(sub, "--sun-step %s: give minutes from 1 to 1440", arg);
        q->step_set = 1;
        return CLI_OK;
    case O_THREADS:
        if (cli_parse_int(arg, &q->threads) != 0 || q->threads < 0)
            return cli_usage(sub, "--threads %s: use 0 (one per CPU) or a positive count", arg);
        return CLI_OK;
    default: return -1;
    }
}

/* The options that go together, and the files that must differ. */
static int check(const char *sub, struct combine_req *q)
{
    int varres = q->nfine || q->finefile || q->sun, k = q->args.basis.k;
    int kc = q->kc ? q->kc : COMBINE_COARSE_K, same;
    if (!q->outpath)
        return cli_usage(sub, "no output file: give -o OUT");
    if (q->nspecs < 1)
        return cli_usage(sub, "no layers given");
    if (!q->sun && (q->azimuth_set || q->step_set))
        return cli_usage(sub, "--azimuth and --sun-step go with --sun-path");
    if (!varres && q->kc)
        return cli_usage(sub, "--coarse-k goes with --fine-incident, --fine-incident-file or "
                         "--sun-path");
    if (varres && (q->ndirs || q->dirfile || q->abspath))
        return cli_usage(sub, "--fine-incident and --sun-path do not go with %s",
                         q->abspath ? "--absorptance" : "--incident");
    if (varres && q->args.basis.klems)
        return cli_usage(sub, "variable resolution is for tensor trees: give -k K, not --klems");
    if (varres && !k)
        return cli_usage(sub, "--fine-incident and --sun-path need -k K, the fine order");
    if (varres && kc >= k)
        return cli_usage(sub, "--coarse-k %d must be below -k %d", kc, k);
    if ((q->ndirs || q->dirfile) && q->abspath)
        return cli_usage(sub, "--incident and --absorptance do not go together");
    if (q->abspath && (same = cli_out_same(q->abspath, q->outpath)) != 0)
        return same < 0 ? cli_fail(sub, "out of memory")
                        : cli_usage(sub, "--absorptance %s and -o %s name the same file",
                                    q->abspath, q->outpath);
    char early[64];
    const char *epoch_date; /* a malformed SOURCE_DATE_EPOCH fails before the work, not after it */
    int rc = cli_source_date(sub, early, sizeof early, &epoch_date);
    if (rc == CLI_OK && q->dirfile)
        rc = combine_read_directions(sub, q->dirfile, &q->dirs, &q->ndirs, &q->dcap);
    return rc;
}

int combine_parse(int argc, char **argv, struct combine_req *q)
{
    static const struct option longopts[] = {
        CLI_STACK_LONGOPTS, {"absorptance", required_argument, NULL, O_ABS},
        {"incident", required_argument, NULL, O_INCIDENT},
        {"incident-file", required_argument, NULL, O_INCFILE},
        {"fine-incident", required_argument, NULL, O_FINE},
        {"fine-incident-file", required_argument, NULL, O_FINEFILE},
        {"coarse-k", required_argument, NULL, O_COARSEK}, {"sun-path", required_argument, NULL, O_SUN},
        {"azimuth", required_argument, NULL, O_AZI}, {"sun-step", required_argument, NULL, O_SUNSTEP},
        {"threads", required_argument, NULL, O_THREADS},
        {"help", no_argument, NULL, O_HELP}, {NULL, 0, NULL, 0}};
    const char *sub = "combine";
    *q = (struct combine_req){.sun_step = 60.0, .argc = argc, .argv = argv};
    cli_stack_args_init(&q->args);
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":k:o:vh", longopts, NULL)) != -1) {
        int rc = cli_stack_option(sub, c, optarg, &q->args);
        if (rc == -1)
            rc = own_option(sub, c, optarg, q);
        if (rc == -1) {
            switch (c) {
            case 'h':
            case O_HELP: /* longer than a stdout buffer: a failed write is told with its own errno */
                q->help = 1;
                return fputs(help, stdout) == EOF ? cli_stdout_failed(sub, errno) : CLI_OK;
            case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
            default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
            }
        }
        if (rc != CLI_OK)
            return rc;
    }
    q->nspecs = (size_t)(argc - optind);
    q->specs = argv + optind;
    return check(sub, q);
}

void combine_req_free(struct combine_req *q)
{
    free(q->dirs), free(q->fine);
    q->dirs = q->fine = NULL;
}
