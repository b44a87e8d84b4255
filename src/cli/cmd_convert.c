/* cmd_convert.c - `bsdfstack convert IN -o OUT`: read any BSDF XML file the reader supports (or a
 * glass:SPEC pane, or a reversed layer LAYER^), resample it to another basis if asked
 * (bst_bsdf_to_layer), write it (bst_bsdf_write) through an atomic output file.  A plain file keeps
 * its own basis exactly when no other is asked, a rank-3 file its rank-3 trees; a rank-4 tree kept
 * at its own order is held in single precision (its values are the file's floats). */
#include <config.h>

#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/resource.h>
#include <time.h>

#include "cli.h"
#include "layers.h"

#define MAX_CHANNELS 16

static const char help[] =
    "Usage: bsdfstack convert [OPTIONS] IN -o OUT\n"
    "Reads the BSDF XML file IN (Klems matrices or RADIANCE tensor trees; or glass:SPEC, a pane of\n"
    "the glass catalogue; a shade from its geometry, venetian:KEYS, perforated:KEYS, woven:KEYS\n"
    "or shade:FILE.json (an IGSDB shading record); LAYER^ for a reversed layer), resamples it to\n"
    "another basis if asked and writes it as BSDF XML to OUT ('-' = standard output).  Without a\n"
    "basis option a file keeps its own (a tree its order, a Klems file its basis; glass: and the\n"
    "shades Shirley-Chiu k = 5).  Shirley-Chiu\n"
    "output is a tensor tree: TensorTree3 when every component is isotropic, else TensorTree4;\n"
    "Klems output holds every component with each text row one outgoing patch, as WINDOW,\n"
    "EnergyPlus and RADIANCE read it.  OUT appears only when everything was written.\n"
    "\n"
    "Options:\n"
    "  -o, --output OUT     output file (required; '-' = standard output): a regular file is\n"
    "                       replaced atomically, a symbolic link's target is written, a device\n"
    "                       or FIFO directly\n"
    "  -k, --order K        Shirley-Chiu tensor tree of order K (1..7, 2^K x 2^K patches)\n"
    "      --klems[=WHICH]  Klems basis: full (default), half or quarter\n"
    "      --reduce PCT     tree reduction: merge regions whose variation is below the PCT-th\n"
    "                       percentile of the finest blocks' (0 <= PCT < 100, default 90 as\n"
    "                       genBSDF)\n"
    "      --reduce-tol T   ... but only where every incident patch's directional-hemispherical\n"
    "                       T and R stay within T of the unreduced values (default 0.002;\n"
    "                       none: the percentile alone, as rttree_reduce)\n"
    "      --no-reduce      write every tree value (only exactly constant regions merged)\n"
    "      --rank 3|4       force a TensorTree3 or TensorTree4 (default: by an isotropy test);\n"
    "                       a forced TensorTree3 that moves a hemispherical T or R by more than\n"
    "                       the tolerance is written with a warning saying by how much\n"
    "      --digits N|exact significant digits per value, or as many as read back exactly\n"
    "                       (default: exact, but 5 in a reduced tree, more if the tolerance\n"
    "                       needs them); in a reduced tree, N whose rounding could move a\n"
    "                       hemispherical T or R beyond the tolerance is refused; elsewhere\n"
    "                       a warning states what N moved beyond it\n"
    "      --channels NAMES only these spectral channels (comma-separated)\n"
    "      --precision P    double (default) or single: the precision in which a resampled\n"
    "                       file's dense components and a made shade's dense ones are held\n"
    "                       (single: half the memory; a dense blind at k = 7 peaks at 4.1 GiB\n"
    "                       a channel against 8.2); the values written are floats either way\n"
    "      --name NAME      the Material Name written (default: the input file's name)\n"
    "      --max-memory SIZE refuse when the estimated need exceeds SIZE (16G, 800M; default:\n"
    "                       the memory available now)\n"
    "      --threads N      threads that write a tensor tree's text, lay a rank-3 input onto the\n"
    "                       grid and make a venetian blind (default 0: one per CPU, up to 8); the\n"
    "                       same bytes with any N\n"
    "  -v, --verbose        one line per written block on standard error: values, bytes and\n"
    "                       the reduction's error (L1, largest, hemispherical); then the\n"
    "                       size, time, CPU time and peak memory of the write\n"
    "  -h, --help           this text\n";

struct verbose {
    int on;
};

static double seconds(const struct timespec *t)
{
    return (double)t->tv_sec + 1e-9 * (double)t->tv_nsec;
}

static double cpu_seconds(const struct rusage *r)
{
    return (double)(r->ru_utime.tv_sec + r->ru_stime.tv_sec) +
           1e-6 * (double)(r->ru_utime.tv_usec + r->ru_stime.tv_usec);
}

static void report(const bst_bsdf_write_block *b, void *opaque)
{
    const struct verbose *v = opaque;
    if (!v->on)
        return;
    if (!b->written) {
        fprintf(stderr, "bsdfstack convert: %s %s: left out (the reciprocal of the other "
                        "transmission)\n", b->channel, bst_comp_name(b->comp));
        return;
    }
    fprintf(stderr, "bsdfstack convert: %s %s: %s, %zu values, %llu bytes", b->channel,
            bst_comp_name(b->comp), b->kind == BST_FILE_KLEMS ? "Klems" :
            b->kind == BST_FILE_TT3 ? "TensorTree3" : "TensorTree4", b->values,
            (unsigned long long)b->bytes);
    if (b->kind != BST_FILE_KLEMS)
        fprintf(stderr, ", %zu leaves, error L1 %.2e, largest %.2e 1/sr, hemispherical %.2e",
                b->leaves, b->l1_error, b->max_error, b->hemi_error);
    else
        fprintf(stderr, ", hemispherical error %.2e", b->hemi_error);
    if (!isnan(b->recip_error))
        fprintf(stderr, ", Tf as its reciprocal %.2e", b->recip_error);
    if (!isnan(b->iso_fa))
        fprintf(stderr, ", rank-3 flux accordance %.2f %%", b->iso_fa);
    if (!isnan(b->iso_hemi))
        fprintf(stderr, " (hemispherical %.2e)", b->iso_hemi);
    fputc('\n', stderr);
}

/* What the command line asks for. */
struct convert_req {
    const char *in, *out, *name, *channels;
    struct cli_basis_choice basis;
    int rank, digits, threads, help, no_reduce;
    bst_precision precision;
    double pct, tol;
    struct verbose verbose;
};

static int parse(int argc, char **argv, struct convert_req *q)
{
    enum { OPT_KLEMS = 256, OPT_REDUCE, OPT_NO_REDUCE, OPT_RANK, OPT_DIGITS, OPT_NAME, OPT_CHANNELS,
           OPT_MAXMEM, OPT_THREADS, OPT_REDUCE_TOL, OPT_PRECISION };
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'}, {"order", required_argument, NULL, 'k'},
        {"klems", optional_argument, NULL, OPT_KLEMS}, {"reduce", required_argument, NULL, OPT_REDUCE},
        {"no-reduce", no_argument, NULL, OPT_NO_REDUCE}, {"rank", required_argument, NULL, OPT_RANK},
        {"reduce-tol", required_argument, NULL, OPT_REDUCE_TOL},
        {"digits", required_argument, NULL, OPT_DIGITS}, {"name", required_argument, NULL, OPT_NAME},
        {"channels", required_argument, NULL, OPT_CHANNELS},
        {"precision", required_argument, NULL, OPT_PRECISION},
        {"max-memory", required_argument, NULL, OPT_MAXMEM},
        {"threads", required_argument, NULL, OPT_THREADS},
        {"verbose", no_argument, NULL, 'v'}, {"help", no_argument, NULL, 'h'}, {NULL, 0, NULL, 0}};
    const char *sub = "convert";
    *q = (struct convert_req){.digits = BST_DIGITS_AUTO, .pct = BST_REDUCE_PCT, .tol = BST_REDUCE_TOL};
    int reduce_set = 0, c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":o:k:vh", longopts, NULL)) != -1) {
        switch (c) {
        case 'o': q->out = optarg; break;
        case 'k':
        case OPT_KLEMS:
            if (cli_parse_basis_option(sub, c == 'k' ? 'k' : 'K', optarg, &q->basis) != CLI_OK)
                return CLI_USAGE;
            break;
        case OPT_CHANNELS: q->channels = optarg; break;
        case OPT_PRECISION:
            if (cli_parse_precision(sub, optarg, &q->precision) != CLI_OK)
                return CLI_USAGE;
            break;
        case OPT_REDUCE:
            if (cli_parse_double(optarg, &q->pct) || q->pct < 0 || q->pct >= 100)
                return cli_usage(sub, "--reduce %s: the percentile must be in [0, 100)", optarg);
            reduce_set = 1;
            break;
        case OPT_NO_REDUCE: q->no_reduce = 1; break;
        case OPT_REDUCE_TOL:
            if (cli_parse_reduce_tol(sub, optarg, &q->tol) != CLI_OK)
                return CLI_USAGE;
            reduce_set = 1;
            break;
        case OPT_RANK:
            if (cli_parse_int(optarg, &q->rank) || (q->rank != 3 && q->rank != 4))
                return cli_usage(sub, "--rank %s: use 3 or 4", optarg);
            break;
        case OPT_DIGITS:
            if (strcmp(optarg, "exact") == 0)
                q->digits = 0;
            else if (cli_parse_int(optarg, &q->digits) || q->digits < 1 || q->digits > 17)
                return cli_usage(sub, "--digits %s: use 1 to 17, or exact", optarg);
            break;
        case OPT_NAME: q->name = optarg; break;
        case OPT_MAXMEM:
            if (cli_parse_memory(sub, optarg, &q->basis.max_memory) != CLI_OK)
                return CLI_USAGE;
            break;
        case OPT_THREADS:
            if (cli_parse_int(optarg, &q->threads) || q->threads < 0)
                return cli_usage(sub, "--threads %s: use 0 (one per CPU) or a positive count", optarg);
            break;
        case 'v': q->verbose.on = 1; break;
        case 'h': q->help = 1; fputs(help, stdout); return CLI_OK;
        case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    if (argc - optind != 1)
        return cli_usage(sub, argc - optind < 1 ? "no input file given" : "one input file expected");
    if (!q->out)
        return cli_usage(sub, "no output file given (-o OUT, or -o - for standard output)");
    if (cli_parse_path(sub, "-o", q->out) != CLI_OK || cli_parse_path(sub, "the input file", argv[optind]) != CLI_OK ||
        (q->channels && cli_parse_channels(sub, "--channels", q->channels) != CLI_OK))
        return CLI_USAGE;
    q->in = argv[optind];
    char early[64];
    const char *epoch_date;
    if (cli_source_date(sub, early, sizeof early, &epoch_date) != CLI_OK) /* before the work */
        return CLI_FAIL;
    if (reduce_set && q->no_reduce)
        return cli_usage(sub, "--reduce and --no-reduce exclude each other");
    if (q->rank && q->basis.klems)
        return cli_usage(sub, "--rank applies to tensor trees, not to --klems");
    return CLI_OK;
}

/* A BSDF XML file read (*b, kept for its rank-3 trees) and made a layer (*l) at the asked basis,
 * or exactly at its own (then *target NULL). */
static int read_file(bst_ctx *ctx, const char *sub, struct convert_req *q, bst_bsdf **b,
                     bst_basis **target, bst_layer **l)
{
    const char *in = q->in, *klems = q->basis.klems;
    int k = q->basis.k;
    char *chcopy = q->channels ? strdup(q->channels) : NULL;
    const char *chnames[MAX_CHANNELS];
    bst_bsdf_read_opts ro = {.channels = chnames, .precision = q->precision};
    if (q->channels && !chcopy)
        return cli_fail(sub, "out of memory");
    for (char *save = NULL, *t = chcopy ? strtok_r(chcopy, ",", &save) : NULL;
         t && ro.nchannels < MAX_CHANNELS; t = strtok_r(NULL, ",", &save))
        chnames[ro.nchannels++] = t;
    int st = bst_bsdf_read(ctx, in, &ro, b);
    free(chcopy);
    if (st < 0)
        return cli_fail_ctx(sub, NULL, ctx);
    if (q->verbose.on)
        cli_warn_ctx(sub, NULL, st, ctx);
    else if (st == BST_WDATA) /* a component taken as zero is written as zeros: say so, as combine */
        cli_warn_zero_components(sub, in, *b, 0, "written", ctx);
    else
        cli_warn_bsdf(sub, in, *b);
    bst_ctx_clear(ctx);
    /* the file's own basis is read exactly (NULL target) */
    int own = (k && bst_bsdf_kind(*b) != BST_FILE_KLEMS && k == bst_bsdf_order(*b)) || (!k && !klems);
    st = BST_OK;
    if (!own && k)
        st = bst_basis_new_sc(ctx, k, target);
    else if (!own && klems)
        st = bst_basis_new_klems(ctx, klems, target);
    if (st >= 0 && *target && bst_bsdf_kind(*b) == BST_FILE_KLEMS &&
        bst_basis_equal(*target, bst_bsdf_klems_basis(*b))) {
        bst_basis_free(*target);
        *target = NULL;
    }
    /* a rank-4 tree kept at its own order: every value is a float of the file, held exactly in
     * single precision (half the memory and the traffic of double) */
    bst_precision prec = q->precision;
    if (st >= 0 && !*target && bst_bsdf_kind(*b) == BST_FILE_TT4 &&
        bst_bsdf_depth(*b) == bst_bsdf_order(*b)) {
        prec = BST_FLOAT;
        st = bst_bsdf_set_precision(ctx, *b, prec);
    }
    if (st >= 0) {
        bst_basis *own_basis = NULL;
        if (!*target && bst_bsdf_kind(*b) != BST_FILE_KLEMS)
            st = bst_basis_new_sc(ctx, bst_bsdf_order(*b), &own_basis);
        const bst_basis *at = *target ? *target : own_basis ? own_basis : bst_bsdf_klems_basis(*b);
        int rc = st >= 0 ? cli_memory_check(sub, at, 1, b, 0, prec, &q->basis) : CLI_OK;
        bst_basis_free(own_basis);
        if (rc != CLI_OK)
            return rc;
    }
    if (st >= 0)
        st = bst_bsdf_to_layer(ctx, *b, *target, l);
    return st < 0 ? cli_fail_ctx(sub, in, ctx) : CLI_OK;
}

/* The command line for the file's comment (what changes no output byte left out), or NULL. */
static char *command_line(int argc, char **argv)
{
    size_t len = strlen("bsdfstack") + 1;
    for (int i = 0; i < argc; i++)
        len += strlen(argv[i]) + 1;
    char *command = malloc(len);
    if (!command)
        return NULL;
    strcpy(command, "bsdfstack");
    for (int i = 0; i < argc; i++)
        if (!cli_threads_arg(argc, argv, &i))
            strcat(strcat(command, " "), argv[i]);
    return command;
}

/* Write lw (b: its file, for rank-3 trees, or NULL) to q->out, atomically. */
static int write_out(bst_ctx *ctx, const char *sub, struct convert_req *q, const bst_layer *lw,
                     const bst_bsdf *b, int argc, char **argv)
{
    char *command = command_line(argc, argv);
    if (!command)
        return cli_fail(sub, "out of memory");
    bst_bsdf_write_opts o;
    bst_bsdf_write_opts_init(&o);
    o.rank = (bst_tree_rank)q->rank;
    o.reduce_pct = q->no_reduce ? -1.0 : q->pct;
    o.reduce_tol = q->tol;
    o.digits = q->digits;
    o.name = q->name;
    o.nlayers = 1;
    o.layers = &q->in;
    o.command = command;
    o.rank3_source = b;
    o.on_block = report;
    o.opaque = &q->verbose;
    char date[64];
    struct cli_out co;
    if (cli_source_date(sub, date, sizeof date, &o.date) != CLI_OK ||
        cli_out_open(&co, sub, q->out) != CLI_OK) {
        free(command);
        return CLI_FAIL;
    }
    struct timespec w0, w1;
    struct rusage r0, r1;
    clock_gettime(CLOCK_MONOTONIC, &w0);
    getrusage(RUSAGE_SELF, &r0);
    int st = bst_bsdf_write(ctx, lw, co.fp, &o);
    free(command);
    if (st < 0)
        return cli_out_fail_ctx(&co, sub, ctx);
    cli_warn_ctx(sub, q->out, st, ctx); /* BST_WACCURACY: written as asked, by how much it moved */
    long pos = co.fp ? ftell(co.fp) : -1;
    int rc = cli_out_commit(&co, sub);
    if (rc == CLI_OK && q->verbose.on) { /* the write's time (its decisions included), as combine -v */
        clock_gettime(CLOCK_MONOTONIC, &w1);
        getrusage(RUSAGE_SELF, &r1);
        fprintf(stderr, "bsdfstack convert: wrote %.1f MB: %.3f s, %.3f CPU-s, peak RSS %.1f MiB\n",
                pos >= 0 ? pos / 1e6 : 0.0, seconds(&w1) - seconds(&w0),
                cpu_seconds(&r1) - cpu_seconds(&r0), r1.ru_maxrss / 1024.0);
    }
    return rc;
}

int cmd_convert(int argc, char **argv)
{
    const char *sub = "convert";
    struct convert_req q;
    int rc = parse(argc, argv, &q);
    if (rc != CLI_OK || q.help)
        return rc;
    size_t inlen = strlen(q.in);
    /* glass: specs, shades (venetian:, perforated:, woven:, shade:) and LAYER^ go through the
     * shared loader (no rank-3 source then) */
    int via_loader = strncmp(q.in, "glass:", 6) == 0 || cli_is_shade(q.in) ||
                     (inlen && q.in[inlen - 1] == '^');
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    bst_ctx_set_threads(ctx, q.threads);
    bst_bsdf *b = NULL;
    bst_basis *target = NULL;
    bst_layer *l = NULL;
    struct cli_layers set = {0};
    if (via_loader) {
        char *spec = (char *)q.in;
        rc = cli_layers_load(&set, ctx, sub, 1, &spec, &q.basis, q.channels, 0, q.precision);
    } else {
        rc = read_file(ctx, sub, &q, &b, &target, &l);
    }
    if (rc == CLI_OK)
        rc = write_out(ctx, sub, &q, via_loader ? set.layers[0] : l, b, argc, argv);
    cli_layers_free(&set);
    bst_layer_free(l);
    bst_basis_free(target);
    bst_bsdf_free(b);
    bst_ctx_free(ctx);
    return rc;
}
