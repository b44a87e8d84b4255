/* cmd_view.c - `bsdfstack view`: one self-contained HTML page to look at BSDF files with: the
 * scattered light of a chosen component, channel and incidence direction as a disk map, its
 * directional-hemispherical value and peak, T and R against incidence angle, several files side
 * by side or as their local accordance.  The page (src/cli/view/, written by view_data.c) does
 * its own arithmetic on the embedded matrices; this file chooses what is embedded.
 *
 * Resolution: every file is read over one basis: the Klems basis they share, else Shirley-Chiu
 * at the finest tree order among them; while the data would exceed --max-size, one order
 * coarser (the page says so).  With --incident, only those incident patches are embedded, at
 * the files' own resolution.  Incidence directions are those the light propagates in, as in
 * `plot`, `info` and `compare`. */
#include <config.h>

#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "incident_table.h"
#include "layers.h"
#include "view.h"

static const char help[] =
    "Usage: bsdfstack view [-o OUT.html] [--max-size SIZE] [--incident THETA,PHI]...\n"
    "                      [--max-memory SIZE] FILE...\n"
    "Writes one self-contained HTML page (no network, nothing beside it) that shows the BSDF XML\n"
    "files: the incident hemisphere as a disk to click or drag on, the outgoing distribution of\n"
    "the chosen component (Tf, Rf, Tb, Rb) and channel as a disk map on a logarithmic colour\n"
    "scale, its directional-hemispherical value (as info sums it) and the peak's direction, T\n"
    "and R against incidence theta in the plane of the chosen azimuth, and two or more files side\n"
    "by side or as the local accordance LA of each with the first (Grobe 2017, eq. 8) and the\n"
    "difference of their hemispherical values.  The page's state is its URL fragment, e.g.\n"
    "  OUT.html#incident=45,90&comp=Tf&channel=Visible&mode=la\n"
    "Every file is read over one basis: the Klems basis they share, else Shirley-Chiu at the\n"
    "finest tree order among them, one order coarser at a time while the data would exceed\n"
    "--max-size (the page says so).\n"
    "\n"
    "Options:\n"
    "  -o OUT.html        the page (default: the first FILE's name with .html, in the current\n"
    "                     directory); - writes it to standard output (a regular file is replaced\n"
    "                     atomically)\n"
    "  --max-size SIZE    the most the embedded data may take (30M default; K, M, G: powers of\n"
    "                     1024)\n"
    "  --incident T,P     embed only the incident patches of these propagation directions\n"
    "                     (degrees; repeat the option), at the files' own resolution: the way to\n"
    "                     look at a k = 7 file (whose columns are then evaluated at the cells'\n"
    "                     centres, as libBSDF does, without the whole layer)\n"
    "  --max-memory SIZE  refuse files whose layers would need more memory (default: the memory\n"
    "                     available now), as info does\n";

#define VIEW_MAX_SIZE_DEFAULT (30.0 * 1048576)
#define VIEW_MAX_INCIDENT 256

struct view_opts {
    const char *outpath;
    double max_size, max_memory;
    size_t nincident;
    double incident[VIEW_MAX_INCIDENT][2];
};

/* Read the files; the channels all of them hold, in the first's order. */
static int read_files(bst_ctx *ctx, const char *sub, struct cli_view *v)
{
    bst_bsdf_read_opts ro = {.precision = BST_FLOAT}; /* a tree's values are float as stored */
    for (size_t f = 0; f < v->nfiles; f++) {
        struct cli_view_file *vf = &v->files[f];
        if (strncmp(vf->path, "glass:", 6) == 0)
            return cli_fail(sub, "%s: view reads BSDF files (a pane: bsdfstack glass, or combine "
                            "it into a file first)", vf->path);
        if (cli_incident_table_is(vf->path))
            return cli_fail(sub, "%s: view reads BSDF XML files; a table of 'combine --incident' "
                            "is drawn by 'bsdfstack plot %s'", vf->path, vf->path);
        if (bst_bsdf_read(ctx, vf->path, &ro, &vf->b) < 0)
            return cli_fail_ctx(sub, vf->path, ctx);
        cli_warn_bsdf(sub, vf->path, vf->b);
        bst_ctx_clear(ctx);
        if (bst_bsdf_kind(vf->b) == BST_FILE_KLEMS)
            snprintf(vf->format, sizeof vf->format, "Klems, %s", bst_basis_name(bst_bsdf_klems_basis(vf->b)));
        else
            snprintf(vf->format, sizeof vf->format, "TensorTree%d, k = %d", (int)bst_bsdf_kind(vf->b),
                     bst_bsdf_order(vf->b));
    }
    const bst_bsdf *b0 = v->files[0].b;
    if (!(v->channels = malloc(bst_bsdf_nchannels(b0) * sizeof *v->channels)))
        return cli_fail(sub, "out of memory");
    for (size_t ch = 0; ch < bst_bsdf_nchannels(b0); ch++) {
        const char *name = bst_bsdf_channel(b0, ch);
        size_t f = 1;
        for (; f < v->nfiles; f++) {
            size_t k = 0;
            while (k < bst_bsdf_nchannels(v->files[f].b) && strcmp(bst_bsdf_channel(v->files[f].b, k), name))
                k++;
            if (k == bst_bsdf_nchannels(v->files[f].b))
                break;
        }
        if (f == v->nfiles)
            v->channels[v->nchannels++] = name;
    }
    if (!v->nchannels)
        return cli_fail(sub, "%s and the other files hold no channel in common", v->files[0].path);
    return CLI_OK;
}

/* The basis the files share, or the finest tree order (Klems files only: k = 5); *k its order
 * (0: the Klems basis in *klems). */
static void own_basis(const struct cli_view *v, const bst_basis **klems, int *k)
{
    *klems = NULL, *k = 0;
    for (size_t f = 0; f < v->nfiles; f++)
        if (bst_bsdf_kind(v->files[f].b) != BST_FILE_KLEMS && bst_bsdf_order(v->files[f].b) > *k)
            *k = bst_bsdf_order(v->files[f].b);
    if (*k)
        return;
    *klems = bst_bsdf_klems_basis(v->files[0].b);
    for (size_t f = 1; f < v->nfiles; f++)
        if (!bst_basis_equal(*klems, bst_bsdf_klems_basis(v->files[f].b)))
            *klems = NULL, *k = 5;
}

/* The data's size at N patches before loading, from the files' fill (a coarser grid fills at
 * least as much): where to start looking for the order that fits. */
static double estimate(const struct cli_view *v, double n, double ncols)
{
    double bytes = 8 * n;
    for (size_t f = 0; f < v->nfiles; f++)
        for (size_t ch = 0; ch < v->nchannels; ch++) {
            size_t k = 0;
            while (strcmp(bst_bsdf_channel(v->files[f].b, k), v->channels[ch]))
                k++;
            for (int c = 0; c < BST_NCOMP; c++) {
                double fill = bst_bsdf_fill(v->files[f].b, k, (bst_comp)c);
                if (fill > 0)
                    bytes += fmin(4 * n * ncols, 4 * (ncols + 1) + 6 * fill * n * ncols);
            }
        }
    return bytes * 4 / 3;
}

static void free_layers(struct cli_view *v)
{
    for (size_t f = 0; f < v->nfiles; f++)
        bst_layer_free(v->files[f].l), v->files[f].l = NULL;
}

/* Load every file over basis (NULL where it is the file's own). */
static int load_layers(bst_ctx *ctx, const char *sub, struct cli_view *v, const bst_basis *basis,
                       double max_memory)
{
    struct cli_basis_choice choice = {.max_memory = max_memory,
                                      .lower = "a smaller --max-size or --incident directions"};
    bst_bsdf **files = malloc(v->nfiles * sizeof *files);
    if (!files)
        return cli_fail(sub, "out of memory");
    for (size_t f = 0; f < v->nfiles; f++)
        files[f] = v->files[f].b;
    int rc = cli_memory_check(sub, basis, v->nfiles, files, 0, BST_FLOAT, &choice);
    free(files);
    for (size_t f = 0; f < v->nfiles && rc == CLI_OK; f++)
        if (bst_bsdf_to_layer(ctx, v->files[f].b, basis, &v->files[f].l) < 0)
            rc = cli_fail_ctx(sub, v->files[f].path, ctx);
    return rc;
}

/* One column of component c of file b, channel ch (the file's index), as libBSDF evaluates it at
 * the patches' centres: incident patch j of the propagation direction, exit patches i. */
static int eval_column(bst_ctx *ctx, const bst_bsdf *b, size_t ch, bst_comp c, const bst_basis *basis,
                       size_t j, double *col)
{
    double in[3], out[3];
    int front = c == BST_TF || c == BST_RF, exit_sign = c == BST_TF || c == BST_RB ? 1 : -1;
    bst_basis_center(basis, j, in); /* towards the source: the propagation direction reversed */
    in[0] = -in[0], in[1] = -in[1], in[2] = front ? -in[2] : in[2];
    for (size_t i = 0; i < bst_basis_size(basis); i++) {
        bst_basis_center(basis, i, out);
        out[2] *= exit_sign;
        if (bst_bsdf_eval(ctx, b, ch, in, out, &col[i]) < 0)
            return -1;
    }
    return 0;
}

/* The embedded columns of every file at the finest order (k = 7: a whole component is 2^28
 * values) without the whole layers: each component a sparse matrix holding those columns alone,
 * evaluated at the cells' centres (a rank-4 tree's cells' own values). */
static int eval_layers(bst_ctx *ctx, const char *sub, struct cli_view *v)
{
    size_t n = bst_basis_size(v->basis), nc = v->ncols;
    size_t *row = malloc(n * nc * sizeof *row), *colj = malloc(n * nc * sizeof *colj);
    double *val = malloc(n * nc * sizeof *val);
    int rc = row && colj && val ? CLI_OK : cli_fail(sub, "out of memory");
    for (size_t f = 0; f < v->nfiles && rc == CLI_OK; f++) {
        struct cli_view_file *vf = &v->files[f];
        if (bst_layer_new(ctx, v->basis, v->nchannels, v->channels, &vf->l) < 0) {
            rc = cli_fail_ctx(sub, vf->path, ctx);
            break;
        }
        for (size_t ch = 0; ch < v->nchannels && rc == CLI_OK; ch++) {
            size_t fc = 0;
            while (strcmp(bst_bsdf_channel(vf->b, fc), v->channels[ch]))
                fc++;
            for (int c = 0; c < BST_NCOMP && rc == CLI_OK; c++) {
                if (bst_bsdf_fill(vf->b, fc, (bst_comp)c) <= 0)
                    continue;
                for (size_t q = 0; q < nc; q++)
                    if (eval_column(ctx, vf->b, fc, (bst_comp)c, v->basis, v->cols[q], val + q * n) < 0)
                        rc = cli_fail_ctx(sub, vf->path, ctx), q = nc;
                for (size_t q = 0; q < n * nc; q++)
                    row[q] = q % n, colj[q] = v->cols[q / n];
                bst_mat *m = NULL;
                if (rc == CLI_OK && (bst_mat_new_sparse(ctx, n, n, n * nc, row, colj, val, &m) < 0 ||
                                     bst_layer_set(ctx, vf->l, ch, (bst_comp)c, m) < 0))
                    rc = cli_fail_ctx(sub, vf->path, ctx);
            }
        }
    }
    free(row), free(colj), free(val);
    return rc;
}

static const char *mib(char buf[32], double bytes)
{
    snprintf(buf, 32, "%.3g MB", bytes / 1048576);
    return buf;
}

/* The incident patches of --incident (repeats once), over basis; info's rule on boundaries. */
static int pick_columns(const char *sub, const struct view_opts *o, const bst_basis *basis, size_t **cols,
                        size_t *n)
{
    if (!(*cols = malloc(o->nincident * sizeof **cols)))
        return cli_fail(sub, "out of memory");
    *n = 0;
    for (size_t i = 0; i < o->nincident; i++) {
        size_t j = cli_incident_patch(basis, o->incident[i][0], o->incident[i][1]), k = 0;
        while (k < *n && (*cols)[k] != j)
            k++;
        if (k == *n)
            (*cols)[(*n)++] = j;
    }
    return CLI_OK;
}

/* Choose the basis (coarser until the data fits o->max_size) and load the layers over it. */
static int choose_and_load(bst_ctx *ctx, const char *sub, struct cli_view *v, const struct view_opts *o,
                           bst_basis **basis, size_t **cols, char *note, size_t notelen)
{
    const bst_basis *klems;
    int k0, k;
    char a[32], b[32];
    own_basis(v, &klems, &k0);
    k = k0;
    if (!klems && !o->nincident) /* start where the estimate fits: no k = 7 grid loaded in vain */
        while (k > 1 && estimate(v, ldexp(1, 2 * k), ldexp(1, 2 * k)) > o->max_size)
            k--;
    for (;; k--) {
        int st = klems ? bst_basis_copy(ctx, klems, basis) : bst_basis_new_sc(ctx, k, basis);
        if (st < 0)
            return cli_fail(sub, "out of memory");
        if (o->nincident && pick_columns(sub, o, *basis, cols, &v->ncols) != CLI_OK)
            return CLI_FAIL;
        v->basis = *basis, v->cols = *cols;
        if (!v->cols)
            v->ncols = bst_basis_size(*basis);
        if (o->nincident && k == BST_K_MAX ? eval_layers(ctx, sub, v) != CLI_OK
                                           : load_layers(ctx, sub, v, *basis, o->max_memory) != CLI_OK)
            return CLI_FAIL;
        double size = cli_view_data_size(v);
        if (size <= o->max_size)
            break;
        if (klems || o->nincident || k == 1)
            return cli_fail(sub, "%s: the page's data would take %s%s, more than --max-size %s",
                            v->files[0].path, mib(a, size),
                            klems ? " (Klems)" : o->nincident ? "" : " at k = 1", mib(b, o->max_size));
        free_layers(v);
        bst_basis_free(*basis), *basis = NULL;
    }
    if (k < k0)
        snprintf(note, notelen, "Shown at k = %d, coarser than the files' own k = %d: their data at k = %d "
                 "would exceed --max-size %s (bsdfstack view --max-size, or --incident to embed chosen "
                 "directions at full resolution).", k, k0, k + 1, mib(a, o->max_size));
    else if (o->nincident)
        snprintf(note, notelen, "Only %zu chosen incident direction%s embedded (--incident), at the "
                 "files' own resolution.", v->ncols, v->ncols > 1 ? "s are" : " is");
    v->note = *note ? note : NULL;
    return CLI_OK;
}

/* OUT: -o, or the first file's name with .html in the current directory. */
static char *default_output(const char *path)
{
    const char *base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    size_t len = strlen(base);
    const char *dot = strrchr(base, '.');
    if (dot && dot != base)
        len = (size_t)(dot - base);
    char *out = malloc(len + 6);
    if (out)
        memcpy(out, base, len), strcpy(out + len, ".html");
    return out;
}

static int view_run(const char *sub, int nfiles, char **paths, const struct view_opts *o)
{
    bst_ctx *ctx = cli_ctx_new(sub);
    struct cli_view v = {.nfiles = (size_t)nfiles};
    bst_basis *basis = NULL;
    size_t *cols = NULL;
    char note[512] = "", *outpath = o->outpath ? NULL : default_output(paths[0]);
    struct cli_out out = {0};
    int rc = ctx && (o->outpath || outpath) ? CLI_OK : cli_fail(sub, "out of memory");
    if (rc == CLI_OK && !(v.files = calloc((size_t)nfiles, sizeof *v.files)))
        rc = cli_fail(sub, "out of memory");
    for (int f = 0; rc == CLI_OK && f < nfiles; f++)
        v.files[f].path = paths[f];
    if (rc == CLI_OK)
        rc = read_files(ctx, sub, &v);
    if (rc == CLI_OK)
        rc = choose_and_load(ctx, sub, &v, o, &basis, &cols, note, sizeof note);
    if (rc == CLI_OK)
        rc = cli_out_open(&out, sub, o->outpath ? o->outpath : outpath);
    if (rc == CLI_OK)
        rc = cli_view_write(ctx, sub, out.fp, &v);
    if (rc == CLI_OK)
        rc = cli_out_commit(&out, sub);
    cli_out_abort(&out);
    if (rc == CLI_OK && strcmp(o->outpath ? o->outpath : outpath, "-") != 0) {
        char k[32] = "";
        if (bst_basis_order(basis))
            snprintf(k, sizeof k, " k = %d", bst_basis_order(basis));
        printf("%s: %zu file%s over %s%s, %zu incident patch%s%s\n", o->outpath ? o->outpath : outpath,
               v.nfiles, v.nfiles > 1 ? "s" : "", bst_basis_name(basis), k, v.ncols, v.ncols > 1 ? "es" : "",
               v.note && !o->nincident ? " (coarser than the files': the page says why)" : "");
    }
    for (size_t f = 0; v.files && f < v.nfiles; f++)
        bst_layer_free(v.files[f].l), bst_bsdf_free(v.files[f].b);
    free(v.files), free(v.channels), free(cols), free(outpath);
    bst_basis_free(basis);
    bst_ctx_free(ctx);
    return rc;
}

/* SIZE: bytes, or a number with K, M or G (powers of 1024, as --max-memory's); 0 on success. */
static int parse_size(const char *s, double *bytes)
{
    char *end;
    double v = strtod(s, &end);
    const char *u = *end ? strchr("KMG", *end & ~0x20) : NULL;
    if (u && *u)
        v *= pow(1024.0, (double)(u - "KMG" + 1)), end++;
    if (end == s || *end || !(v >= 1) || !isfinite(v))
        return -1;
    *bytes = v;
    return 0;
}

int cmd_view(int argc, char **argv)
{
    enum { O_MAXSIZE = 256, O_INCIDENT, O_MAXMEM };
    static const struct option longopts[] = {{"max-size", required_argument, NULL, O_MAXSIZE},
                                             {"incident", required_argument, NULL, O_INCIDENT},
                                             {"max-memory", required_argument, NULL, O_MAXMEM},
                                             {"output", required_argument, NULL, 'o'},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *sub = "view";
    static struct view_opts o; /* large: --incident's table */
    memset(&o, 0, sizeof o);
    o.max_size = VIEW_MAX_SIZE_DEFAULT;
    int c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":ho:", longopts, NULL)) != -1) {
        switch (c) {
        case O_MAXSIZE:
            if (parse_size(optarg, &o.max_size) != 0)
                return cli_usage(sub, "--max-size %s: give a size such as 30M, 500K or 100000000", optarg);
            break;
        case O_INCIDENT:
            if (o.nincident == VIEW_MAX_INCIDENT)
                return cli_usage(sub, "--incident: at most %d directions", VIEW_MAX_INCIDENT);
            if (cli_parse_incident(sub, optarg, o.incident[o.nincident]) != CLI_OK)
                return CLI_USAGE;
            o.nincident++;
            break;
        case O_MAXMEM:
            if (cli_parse_memory(sub, optarg, &o.max_memory) != CLI_OK)
                return CLI_USAGE;
            break;
        case 'o':
            if (cli_parse_path(sub, "-o", optarg) != CLI_OK)
                return CLI_USAGE;
            o.outpath = optarg;
            break;
        case 'h': fputs(help, stdout); return CLI_OK;
        case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    if (optind >= argc)
        return cli_usage(sub, "no file given");
    return view_run(sub, argc - optind, argv + optind, &o);
}
