/* cmd_compare.c - `bsdfstack compare A B`: how far two BSDFs agree, on one basis: global and flux
 * accordance of the scattered light and directional-hemispherical values, at chosen incidence
 * directions and summarised over every incident patch. */
#include <config.h>

#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "draw.h"
#include "hemimap.h"
#include "incident_tsv.h"
#include "layers.h"

static const char help[] =
    "Usage: bsdfstack compare [-k K | --klems[=full|half|quarter]] [--channel NAME]\n"
    "                         [--only Tf,Rf,Tb,Rb] [--incident THETA,PHI]... [--fail-below GA]\n"
    "                         [--fail-hem D] [--map OUT.png|OUT.svg|OUT.tsv] A B\n"
    "Compares two BSDFs (files or glass: specs, a trailing ^ reverses one), both resampled onto one\n"
    "basis (default: the finer tensor-tree order of the two, else the Klems basis of a Klems file).\n"
    "For each component and incidence direction it prints\n"
    "  GA  global accordance (%), Grobe 2017 eq. 7: 100 (1 - sum (a-b)^2 / sum (a+b)^2) over the\n"
    "      exit patches of the two DSFs (Klems terms weighted by projected solid angle); ruled by\n"
    "      the peaks: a copy scaled by 1.1 scores 99.77 (the paper compares at -k 5)\n"
    "  FA  flux accordance (%): the share of the scattered flux that A and B place alike; it\n"
    "      counts diffuse light by its flux, and every percent of noise costs it about a point\n"
    "  the directional-hemispherical value of A and of B\n"
    "and, over every incident patch, the least and the mean GA and FA and the largest\n"
    "hemispherical difference; a closing table gives, per component, the largest |hem A - hem B|\n"
    "over every incident patch (what a reduced or converted file changed of the T and R users\n"
    "compute with) and the least FA.  Directions are those the light propagates in, (theta, phi)\n"
    "in degrees as in `info`; a direction on a cell boundary takes the cell on its +x, +y side.\n"
    "\n"
    "Options:\n"
    "  -k K               Shirley-Chiu order of the common basis (1-7)\n"
    "  --klems[=WHICH]    compare in a Klems basis (default full)\n"
    "  --channel NAME     spectral channel (default: A's first; B must have it too)\n"
    "  --only LIST        components to compare (default: every one either holds)\n"
    "  --incident T,P     an incidence direction, repeatable (default: 0,0 25,90 45,90 50,90 45,45\n"
    "                     65,90, the last five Grobe 2017's)\n"
    "  --fail-below GA    exit status 1 when any printed GA falls below GA\n"
    "  --fail-hem D       exit status 1 when any component's largest |hem A - hem B| exceeds D\n"
    "                     (e.g. 0.002, a reduced file against the same file written with\n"
    "                     --no-reduce)\n"
    "  --map OUT          the local accordance LA = 100 (1 - |a - b| / (a + b)) of every exit\n"
    "                     cell for the first component and the first direction, by the extension:\n"
    "                     drawn as PNG or SVG (as `plot` draws, +X right, +Y up, seen from +Z), or\n"
    "                     .tsv, a table of one row per exit patch: patch, theta and phi of its\n"
    "                     centre, A's and B's BSDF, LA ('-': standard output, and the report goes\n"
    "                     to standard error)\n"
    "Either of A and B may be the TSV that `combine --incident` writes: its columns are compared,\n"
    "in the basis they were made in (told by their exit patches), against the other TSV's columns\n"
    "of the same incident patches or the BSDF file's, with the same GA, FA and hemispherical\n"
    "values; the directions default to the TSV's (A's when both are TSVs), --incident picks some\n"
    "of them, and there is no summary over every incident patch.\n";

#define MAX_DIRS 64

/* What --map writes, told by OUT's extension; "-" is the table on standard output. */
enum map_kind { MAP_PNG = CLI_DRAW_PNG, MAP_SVG = CLI_DRAW_SVG, MAP_TSV };

/* --map's table: a header line, then per exit patch its centre, A's and B's BSDF and LA. */
static void la_table(FILE *fp, const bst_layer *a, const bst_layer *b, bst_comp c, size_t j,
                     const double dir[2], char **specs, const double *la)
{
    const bst_basis *basis = bst_layer_basis(a);
    const bst_mat *ma = bst_layer_get(a, 0, c), *mb = bst_layer_get(b, 0, c);
    fprintf(fp, "# local accordance LA (%%, Grobe 2017 eq. 8) of A %s and B %s: %s, channel %s, "
            "incidence theta %g phi %g (patch %zu); columns: patch, theta_deg and phi_deg of its "
            "centre, A and B (BSDF, 1/sr), LA\n", specs[0], specs[1], bst_comp_name(c),
            bst_layer_channel(a, 0), dir[0], dir[1], j);
    for (size_t o = 0; o < bst_basis_size(basis); o++) {
        double th, ph;
        cli_patch_direction(basis, o, &th, &ph);
        fprintf(fp, "%zu\t%.4f\t%.4f\t%.9g\t%.9g\t%.9g\n", o, th, ph, ma ? bst_mat_get(ma, o, j) : 0.0,
                mb ? bst_mat_get(mb, o, j) : 0.0, la[o]);
    }
}

/* The local accordance of component c for incident patch j over the exit cells (into la),
 * drawn or as a table, and a line saying so in the report rep. */
static int write_map(bst_ctx *ctx, const char *sub, const char *path, enum map_kind kind, FILE *rep,
                     const bst_layer *a, const bst_layer *b, bst_comp c, size_t j,
                     const double dir[2], char **specs, double *la)
{
    if (bst_metrics_accordance(ctx, a, b, 0, c, j, NULL, NULL, la) < 0)
        return cli_fail_ctx(sub, NULL, ctx);
    struct cli_out out;
    int rc = cli_out_open(&out, sub, path);
    if (rc != CLI_OK)
        return rc;
    if (kind == MAP_TSV) {
        la_table(out.fp, a, b, c, j, dir, specs, la);
        if ((rc = cli_out_commit(&out, sub)) == CLI_OK)
            fprintf(rep, "  local accordance at (%g, %g) written to %s\n", dir[0], dir[1],
                    strcmp(path, "-") == 0 ? "standard output" : path);
        return rc;
    }
    char title[1024];
    const char *na = strrchr(specs[0], '/') ? strrchr(specs[0], '/') + 1 : specs[0];
    const char *nb = strrchr(specs[1], '/') ? strrchr(specs[1], '/') + 1 : specs[1];
    snprintf(title, sizeof title, "local accordance %s vs %s, %s, %s, incidence theta %g phi %g, %%",
             na, nb, bst_comp_name(c), bst_layer_channel(a, 0), dir[0], dir[1]);
    double t = dir[0] * M_PI / 180, p = dir[1] * M_PI / 180;
    struct cli_hemimap m = {.basis = bst_layer_basis(a), .cell = la, .log = 0, .lo = 0, .hi = 100,
                            .size = 480, .title = title, .unit = "%",
                            .mark = {sin(t) * cos(p), sin(t) * sin(p), cos(t)}};
    if (cli_hemimap_write(out.fp, (int)kind, &m) < 0) {
        if ((rc = cli_out_flush(&out, sub)) == CLI_OK) /* a write error is told there */
            rc = cli_fail(sub, "%s: out of memory drawing the image", path);
        cli_out_abort(&out);
        return rc;
    }
    if ((rc = cli_out_commit(&out, sub)) == CLI_OK)
        fprintf(rep, "  local accordance at (%g, %g) drawn in %s\n", dir[0], dir[1], path);
    return rc;
}

/* What the closing table shows of a component: where its hemispherical values differ most, its
 * least FA and GA over every incident patch. */
struct worst {
    bst_comp comp;
    size_t patch;
    double ha, hb, fa, ga;
};

static void print_summary(FILE *rep, const bst_basis *basis, const struct worst *w, int n)
{
    fprintf(rep, "\nOver every incident patch: the largest change of a directional-hemispherical value,\n"
                 "where it is, and the least FA and GA\n"
                 "  comp  |hem A - hem B|  patch  theta    phi    hem A    hem B  FA least  GA least\n");
    for (int q = 0; q < n; q++) {
        double d[3];
        bst_basis_center(basis, w[q].patch, d);
        double th = acos(d[2]) * 180 / M_PI, ph = atan2(d[1], d[0]) * 180 / M_PI;
        fprintf(rep, "  %-4s  %15.6f %6zu %6.1f %6.1f %8.4f %8.4f %9.2f %9.3f\n",
                bst_comp_name(w[q].comp), fabs(w[q].ha - w[q].hb), w[q].patch, th, ph < 0 ? ph + 360 : ph,
                w[q].ha, w[q].hb, w[q].fa, w[q].ga);
    }
}

/* The BSDF file or glass spec loaded over the TSV's basis (its channel only). */
static int file_side(const char *sub, bst_ctx *ctx, char *spec, const struct cli_tsv *t,
                     const char *channel, unsigned comps, struct cli_layers *set, bst_layer **l)
{
    *l = NULL;
    struct cli_basis_choice choice;
    cli_basis_choice_of(t->basis, &choice);
    int rc = cli_layers_load(set, ctx, sub, 1, &spec, &choice, channel, comps, BST_DOUBLE);
    if (rc == CLI_OK)
        *l = set->layers[0];
    return rc;
}

/* 1 when t holds a column of (channel, comp) at incident patch j. */
static int has_column(const struct cli_tsv *t, const char *channel, bst_comp comp, size_t j)
{
    for (size_t r = 0; r < t->ncols; r++)
        if (t->cols[r].comp == comp && t->cols[r].patch_in == j && strcmp(t->cols[r].channel, channel) == 0)
            return 1;
    return 0;
}

/* compare with a TSV of combine --incident on either side (help text above). */

/* The report's lines above the table: the basis (with where it came from), A, B, the channel,
 * the legend. */
static void print_header(FILE *rep, const bst_basis *basis, char **specs, const char *channel,
                         const char *from)
{
    size_t n = bst_basis_size(basis);
    if (bst_basis_kind_of(basis) == BST_BASIS_KLEMS)
        fprintf(rep, "basis     %s, %zu patches per hemisphere%s\n", bst_basis_name(basis), n, from);
    else
        fprintf(rep, "basis     Shirley-Chiu k = %d, %zu patches per hemisphere%s\n",
                bst_basis_order(basis), n, from);
    fprintf(rep, "A         %s\nB         %s\nchannel   %s\n", specs[0], specs[1], channel);
    fprintf(rep, "GA: global accordance (Grobe 2017 eq. 7, %%); FA: flux accordance (share of the\n"
                 "scattered flux that A and B place alike, %%); hem:\n"
                 "directional-hemispherical value.  Directions: light propagation, degrees.\n");
}

static int compare_tsv(const char *sub, bst_ctx *ctx, char **specs, const int is_tsv[2],
                       const char *channel, unsigned comps, size_t ndirs, double (*dirs)[2],
                       double fail_below, const char *mappath, enum map_kind map_kind, FILE *rep)
{
    struct cli_tsv tt[2];
    memset(tt, 0, sizeof tt);
    int first = is_tsv[0] ? 0 : 1, rc = CLI_OK;
    for (int i = 0; rc == CLI_OK && i < 2; i++)
        if (is_tsv[i])
            rc = cli_tsv_read(sub, ctx, specs[i], &tt[i]);
    if (rc != CLI_OK) {
        cli_tsv_free(&tt[0]), cli_tsv_free(&tt[1]);
        return rc;
    }
    const struct cli_tsv t = tt[first];
    if (is_tsv[0] && is_tsv[1] && !bst_basis_equal(tt[0].basis, tt[1].basis))
        rc = cli_fail(sub, "%s: columns over %zu patches, %s's over %zu: not one basis", specs[1],
                      tt[1].n, specs[0], tt[0].n);
    if (!channel)
        channel = t.cols[0].channel;
    struct cli_layers set[2] = {{0}, {0}};
    bst_layer *side[2] = {NULL, NULL};
    for (int i = 0; rc == CLI_OK && i < 2; i++)
        rc = is_tsv[i] ? cli_tsv_layer(sub, ctx, &tt[i], channel, &side[i])
                       : file_side(sub, ctx, specs[i], &t, channel, comps, &set[i], &side[i]);
    /* the directions: those asked, else the TSV's own (first column of each incident patch) */
    size_t n = t.n, m = 0;
    double (*d)[2] = malloc((t.ncols + ndirs + 1) * sizeof *d);
    double *ha = malloc(n * sizeof *ha), *hb = malloc(n * sizeof *hb), *la = malloc(n * sizeof *la);
    if (rc == CLI_OK && (!d || !ha || !hb || !la))
        rc = cli_fail(sub, "out of memory");
    for (size_t q = 0; rc == CLI_OK && q < (ndirs ? ndirs : t.ncols); q++) {
        double th = ndirs ? dirs[q][0] : t.cols[q].theta, ph = ndirs ? dirs[q][1] : t.cols[q].phi;
        int dup = 0;
        for (size_t r = 0; r < m; r++)
            dup |= d[r][0] == th && d[r][1] == ph;
        if (!dup && (ndirs || strcmp(t.cols[q].channel, channel) == 0))
            d[m][0] = th, d[m++][1] = ph;
    }
    if (rc == CLI_OK && m == 0)
        rc = cli_fail(sub, "%s: no column of channel '%s'", specs[first], channel);
    if (rc == CLI_OK) {
        print_header(rep, t.basis, specs, channel, " (from the TSV)");
    }
    int below = 0, shown = 0;
    for (int cc = 0; cc < BST_NCOMP && rc == CLI_OK; cc++) {
        bst_comp comp = (bst_comp)cc;
        const bst_layer *a = side[0], *b = side[1];
        /* the components the TSV(s) hold (and --only keeps) */
        int in_t = 0;
        for (size_t q = 0; q < t.ncols; q++)
            in_t |= t.cols[q].comp == comp && strcmp(t.cols[q].channel, channel) == 0;
        if (!in_t || (comps && !(comps & (1u << cc))))
            continue;
        if (bst_layer_hemispherical(ctx, a, 0, comp, ha) < 0 || bst_layer_hemispherical(ctx, b, 0, comp, hb) < 0) {
            rc = cli_fail_ctx(sub, NULL, ctx);
            break;
        }
        const char *sd = comp == BST_TF || comp == BST_RF ? "front" : "back";
        fprintf(rep, "\n%s (%s incidence)%s%s\n", bst_comp_name(comp), sd,
                bst_layer_get(a, 0, comp) ? "" : ": absent from A",
                bst_layer_get(b, 0, comp) ? "" : ": absent from B");
        fprintf(rep, "  theta    phi  patch       GA      FA    hem A    hem B\n");
        for (size_t q = 0; q < m && rc == CLI_OK; q++) {
            size_t j = cli_incident_patch(t.basis, d[q][0], d[q][1]);
            /* every TSV side must hold this column */
            for (int i = 0; i < 2 && rc == CLI_OK; i++)
                if (is_tsv[i] && !has_column(&tt[i], channel, comp, j))
                    rc = cli_fail(sub, "%s: no %s %s column at (%g, %g) (patch %zu)", specs[i], channel,
                                  bst_comp_name(comp), d[q][0], d[q][1], j);
            double ga, fa;
            if (rc == CLI_OK && bst_metrics_accordance(ctx, a, b, 0, comp, j, &ga, &fa, la) < 0)
                rc = cli_fail_ctx(sub, NULL, ctx);
            if (rc != CLI_OK)
                break;
            fprintf(rep, "%7.2f %6.2f %6zu %8.3f %7.2f %8.4f %8.4f\n", d[q][0], d[q][1], j, ga, fa,
                    ha[j], hb[j]);
            below |= ga < fail_below;
            if (mappath && q == 0)
                rc = write_map(ctx, sub, mappath, map_kind, rep, a, b, comp, j, d[0], specs, la);
        }
        mappath = NULL;
        shown++;
    }
    if (rc == CLI_OK && !shown)
        rc = cli_fail(sub, "%s holds none of the components asked for", specs[first]);
    if (rc == CLI_OK && below)
        rc = cli_fail(sub, "GA below %g at a direction shown", fail_below);
    free(d), free(ha), free(hb), free(la);
    for (int i = 0; i < 2; i++) {
        if (is_tsv[i])
            bst_layer_free(side[i]);
        cli_layers_free(&set[i]);
    }
    cli_tsv_free(&tt[0]), cli_tsv_free(&tt[1]);
    return rc;
}

/* What the command line asks for. */
struct compare_req {
    const char *channel, *mappath;
    enum map_kind map_kind;
    struct cli_basis_choice choice;
    unsigned comps;
    double dirs[MAX_DIRS][2], fail_below, fail_hem;
    size_t ndirs;
    int help;
    char **specs; /* A and B */
};

/* --map PATH: its kind from the name's ending. */
static int parse_map(const char *sub, const char *arg, struct compare_req *q)
{
    static const struct { const char *ext; enum map_kind kind; } kinds[] = {
        {".png", MAP_PNG}, {".svg", MAP_SVG}, {".tsv", MAP_TSV}};
    const size_t nk = sizeof kinds / sizeof kinds[0];
    size_t n = strlen(arg), e = 0;
    while (e < nk && !(n > 4 && strcmp(arg + n - 4, kinds[e].ext) == 0))
        e++;
    if (e == nk && strcmp(arg, "-") != 0)
        return cli_usage(sub, "--map %s: name a .png, .svg or .tsv file, or - for the table on "
                         "standard output", arg);
    q->map_kind = e < nk ? kinds[e].kind : MAP_TSV;
    q->mappath = arg;
    return CLI_OK;
}

static int parse(int argc, char **argv, struct compare_req *q)
{
    static const struct option longopts[] = {{"klems", optional_argument, NULL, 'K'},
                                             {"channel", required_argument, NULL, 'c'},
                                             {"only", required_argument, NULL, 'o'},
                                             {"incident", required_argument, NULL, 'i'},
                                             {"fail-below", required_argument, NULL, 'f'},
                                             {"fail-hem", required_argument, NULL, 'H'},
                                             {"map", required_argument, NULL, 'm'},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *sub = "compare";
    memset(q, 0, sizeof *q);
    q->map_kind = MAP_PNG;
    q->fail_below = -INFINITY, q->fail_hem = INFINITY;
    int c, rc = CLI_OK;
    optind = 1;
    opterr = 0;
    while (rc == CLI_OK && (c = getopt_long(argc, argv, ":hk:", longopts, NULL)) != -1) {
        switch (c) {
        case 'k':
        case 'K': rc = cli_parse_basis_option(sub, c, optarg, &q->choice); break;
        case 'c':
            q->channel = optarg;
            rc = cli_parse_channels(sub, "--channel", optarg);
            break;
        case 'o': rc = cli_parse_comps(sub, optarg, &q->comps); break;
        case 'i':
            if (q->ndirs == MAX_DIRS)
                return cli_usage(sub, "--incident: at most %d directions", MAX_DIRS);
            if ((rc = cli_parse_incident(sub, optarg, q->dirs[q->ndirs])) == CLI_OK)
                q->ndirs++;
            break;
        case 'f':
            if (cli_parse_double(optarg, &q->fail_below) != 0 || q->fail_below < 0 || q->fail_below > 100)
                return cli_usage(sub, "--fail-below %s: give a GA between 0 and 100", optarg);
            break;
        case 'H':
            if (cli_parse_double(optarg, &q->fail_hem) != 0 || !(q->fail_hem >= 0) ||
                !isfinite(q->fail_hem))
                return cli_usage(sub, "--fail-hem %s: give a hemispherical difference >= 0", optarg);
            break;
        case 'm': rc = parse_map(sub, optarg, q); break;
        case 'h': q->help = 1; fputs(help, stdout); return CLI_OK;
        case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    if (rc != CLI_OK)
        return rc;
    if (argc - optind != 2)
        return cli_usage(sub, argc - optind < 2 ? "two BSDFs expected, A and B" : "only two BSDFs, A and B");
    q->specs = argv + optind;
    return CLI_OK;
}

/* Both over one basis, one channel: A's first unless named (loaded again with that channel alone
 * when B holds it at another index). */
static int load_pair(bst_ctx *ctx, const char *sub, const struct compare_req *q, struct cli_layers *set)
{
    char **specs = q->specs;
    int rc = cli_layers_load(set, ctx, sub, 2, specs, &q->choice, q->channel, q->comps, BST_DOUBLE);
    if (rc != CLI_OK || q->channel)
        return rc;
    const char *name = bst_layer_channel(set->layers[0], 0);
    int chb = bst_layer_find_channel(set->layers[1], name);
    if (chb < 0) {
        rc = cli_fail(sub, "%s has no channel '%s' (the first of %s): name one both hold with "
                      "--channel", specs[1], name, specs[0]);
        cli_layers_free(set);
    } else if (chb != 0) {
        char *keep = strdup(name);
        cli_layers_free(set);
        rc = keep ? cli_layers_load(set, ctx, sub, 2, specs, &q->choice, keep, q->comps, BST_DOUBLE)
                  : cli_fail(sub, "out of memory");
        free(keep);
    }
    return rc;
}

/* Work arrays of the comparison, one value per incident patch. */
struct per_patch {
    double *ha, *hb, *ga, *fa, *la;
};

/* One component: the table at the asked directions (with the map of the first, when asked),
 * then the line over every incident patch; its worst patches into *w. */
static int compare_comp(bst_ctx *ctx, const char *sub, struct compare_req *q, FILE *rep,
                        const struct cli_layers *set, bst_comp comp, struct per_patch *v,
                        int *below, struct worst *w)
{
    const bst_layer *a = set->layers[0], *b = set->layers[1];
    const bst_basis *basis = set->basis;
    size_t n = bst_basis_size(basis);
    int in_a = bst_layer_get(a, 0, comp) != NULL, in_b = bst_layer_get(b, 0, comp) != NULL;
    if (bst_metrics_accordance_all(ctx, a, b, 0, comp, v->ga, v->fa) < 0 ||
        bst_layer_hemispherical(ctx, a, 0, comp, v->ha) < 0 ||
        bst_layer_hemispherical(ctx, b, 0, comp, v->hb) < 0)
        return cli_fail_ctx(sub, NULL, ctx);
    const char *side = comp == BST_TF || comp == BST_RF ? "front" : "back";
    fprintf(rep, "\n%s (%s incidence)%s%s\n", bst_comp_name(comp), side,
            in_a ? "" : ": absent from A", in_b ? "" : ": absent from B");
    fprintf(rep, "  theta    phi  patch       GA      FA    hem A    hem B\n");
    for (size_t k = 0; k < q->ndirs; k++) {
        size_t j = cli_incident_patch(basis, q->dirs[k][0], q->dirs[k][1]);
        fprintf(rep, "%7.2f %6.2f %6zu %8.3f %7.2f %8.4f %8.4f\n", q->dirs[k][0], q->dirs[k][1], j,
                v->ga[j], v->fa[j], v->ha[j], v->hb[j]);
        *below |= v->ga[j] < q->fail_below;
        if (q->mappath && k == 0) {
            int rc = write_map(ctx, sub, q->mappath, q->map_kind, rep, a, b, comp, j, q->dirs[0],
                               q->specs, v->la);
            if (rc != CLI_OK)
                return rc;
        }
    }
    q->mappath = NULL; /* one map: the first component's */
    const double *ga = v->ga, *fa = v->fa, *ha = v->ha, *hb = v->hb;
    size_t jg = 0, jf = 0, jh = 0;
    double mg = 0, mf = 0;
    for (size_t j = 0; j < n; j++) {
        jg = ga[j] < ga[jg] ? j : jg, jf = fa[j] < fa[jf] ? j : jf;
        jh = fabs(ha[j] - hb[j]) > fabs(ha[jh] - hb[jh]) ? j : jh;
        mg += ga[j] / n, mf += fa[j] / n;
    }
    double dg[3], df[3], dh[3];
    bst_basis_center(basis, jg, dg), bst_basis_center(basis, jf, df), bst_basis_center(basis, jh, dh);
    fprintf(rep, "  all %zu incident patches: GA mean %.3f, least %.3f (patch %zu, theta %.1f); "
            "FA mean %.2f, least %.2f (patch %zu, theta %.1f); largest |hem A - hem B| %.4f "
            "(patch %zu, theta %.1f)\n", n, mg, ga[jg], jg, acos(dg[2]) * 180 / M_PI, mf, fa[jf],
            jf, acos(df[2]) * 180 / M_PI, fabs(ha[jh] - hb[jh]), jh, acos(dh[2]) * 180 / M_PI);
    *w = (struct worst){comp, jh, ha[jh], hb[jh], fa[jf], ga[jg]};
    return CLI_OK;
}

/* Two BSDF files (or layers) over one basis. */
static int compare_layers(bst_ctx *ctx, const char *sub, struct compare_req *q, FILE *rep)
{
    if (!q->ndirs) {
        static const double paper[][2] = {{0, 0}, {25, 90}, {45, 90}, {50, 90}, {45, 45}, {65, 90}};
        q->ndirs = sizeof paper / sizeof paper[0];
        memcpy(q->dirs, paper, sizeof paper);
    }
    struct cli_layers set = {0};
    int rc = load_pair(ctx, sub, q, &set);
    if (rc != CLI_OK)
        return rc;
    size_t n = bst_basis_size(set.basis);
    struct per_patch v = {malloc(n * sizeof(double)), malloc(n * sizeof(double)),
                          malloc(n * sizeof(double)), malloc(n * sizeof(double)),
                          malloc(n * sizeof(double))};
    if (!v.ha || !v.hb || !v.ga || !v.fa || !v.la)
        rc = cli_fail(sub, "out of memory");
    else
        print_header(rep, set.basis, q->specs, bst_layer_channel(set.layers[0], 0), "");
    int below = 0, shown = 0;
    struct worst summary[BST_NCOMP];
    for (int cc = 0; cc < BST_NCOMP && rc == CLI_OK; cc++) {
        bst_comp comp = (bst_comp)cc;
        int in_a = bst_layer_get(set.layers[0], 0, comp) != NULL;
        int in_b = bst_layer_get(set.layers[1], 0, comp) != NULL;
        if (q->comps ? !(q->comps & (1u << cc)) : !(in_a || in_b))
            continue;
        rc = compare_comp(ctx, sub, q, rep, &set, comp, &v, &below, &summary[shown]);
        shown += rc == CLI_OK;
    }
    if (rc == CLI_OK && shown)
        print_summary(rep, set.basis, summary, shown);
    for (int k = 0; rc == CLI_OK && k < shown; k++)
        if (fabs(summary[k].ha - summary[k].hb) > q->fail_hem)
            rc = cli_fail(sub, "%s: the hemispherical values differ by %.6f at patch %zu, more than %g",
                          bst_comp_name(summary[k].comp), fabs(summary[k].ha - summary[k].hb),
                          summary[k].patch, q->fail_hem);
    if (rc == CLI_OK && !shown)
        rc = cli_fail(sub, "neither BSDF holds %s", q->comps ? "the components asked for" : "any component");
    if (rc == CLI_OK && below)
        rc = cli_fail(sub, "GA below %g at a direction shown", q->fail_below);
    free(v.ha), free(v.hb), free(v.ga), free(v.fa), free(v.la);
    cli_layers_free(&set);
    return rc;
}

int cmd_compare(int argc, char **argv)
{
    const char *sub = "compare";
    struct compare_req q;
    int rc = parse(argc, argv, &q);
    if (rc != CLI_OK || q.help)
        return rc;
    FILE *rep = q.mappath && strcmp(q.mappath, "-") == 0 ? stderr : stdout; /* the report */
    int is_tsv[2] = {cli_tsv_detect(q.specs[0]), cli_tsv_detect(q.specs[1])};
    if ((is_tsv[0] || is_tsv[1]) && (q.choice.k || q.choice.klems))
        return cli_usage(sub, "a TSV of combine --incident keeps its basis: no -k or --klems");
    if ((is_tsv[0] || is_tsv[1]) && isfinite(q.fail_hem))
        return cli_usage(sub, "--fail-hem needs every incident patch: not with a TSV");
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    if (is_tsv[0] || is_tsv[1])
        rc = compare_tsv(sub, ctx, q.specs, is_tsv, q.channel, q.comps, q.ndirs, q.dirs,
                         q.fail_below, q.mappath, q.map_kind, rep);
    else
        rc = compare_layers(ctx, sub, &q, rep);
    bst_ctx_free(ctx);
    return rc;
}
