/* cmd_combine.c - `bsdfstack combine`: load layers (exterior first), resample them to one basis,
 * combine them by the matrix formalism (bst_stack_combine) and write the system as BSDF XML. */
#include <config.h>

#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "cli.h"
#include "layers.h"

static const char help[] =
    "Usage: bsdfstack combine [-k K | --klems[=full|half|quarter]] [--only Tf,Rf,Tb,Rb]\n"
    "                         [--channels NAMES] [--precision double|single] [--drop-tol X]\n"
    "                         [--reduce PCT | --no-reduce] [--dense] [--absorptance FILE]\n"
    "                         [--strict] [-v] -o OUT LAYER LAYER...\n"
    "Combines the layers, listed exterior first, with every inter-reflection between them, and\n"
    "writes the system's BSDF as BSDF XML.\n"
    "\n"
    "Layers:\n"
    "  FILE.xml           a BSDF XML file (Klems, TensorTree3/4, any resolution)\n"
    "  glass:NAME         a pane of the glass catalogue (bsdfstack-glass(5)); glass:PATH a spectral\n"
    "                     data file; glass:d=6mm,n=1.52,tn=0.89 an inline pane\n"
    "  LAYER^             the layer installed reversed (back side facing the exterior)\n"
    "\n"
    "Options:\n"
    "  -k K               Shirley-Chiu tensor-tree basis of order K (1..7); default: the finest\n"
    "                     order among tensor-tree layers, else 5\n"
    "  --klems[=WHICH]    Klems basis: full (default, 145 patches), half or quarter\n"
    "  --only COMPS       only these components (comma-separated Tf, Rf, Tb, Rb)\n"
    "  --channels NAMES   only these channels (e.g. Visible,Solar); default: all in common\n"
    "  --precision P      double (default) or single precision for dense work\n"
    "  --drop-tol X       drop sparse fill-in below X times a product's largest value (default 0)\n"
    "  --reduce PCT       tensor-tree reduction percentile written (default 90); --no-reduce: none\n"
    "  --dense            force every matrix dense (the baseline for comparisons)\n"
    "  --absorptance FILE also write per-layer absorptance per incident patch (TSV: channel,\n"
    "                     side, patch, theta, phi of the propagation direction, A1..An, T, R)\n"
    "  --strict           ill-conditioning and energy imbalance in an input are errors\n"
    "  -v                 print each step's structures, time and peak memory\n"
    "  -o OUT             output file ('-' = standard output), written atomically\n";

static void verbose_step(const bst_stack_step *s, void *opaque)
{
    (void)opaque;
    static const char *const names[] = {"zero", "diagonal", "sparse", "dense"};
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    fprintf(stderr, "bsdfstack combine: layers 1-%zu %s %s: %s, %zu stored, %.3f s, rcond %.3g, "
            "peak RSS %.1f MiB\n", s->step + 1, s->channel, bst_comp_name(s->comp),
            names[s->structure], s->nnz, s->seconds, s->rcond, ru.ru_maxrss / 1024.0);
}

/* --absorptance: one row per channel, side and incident patch: the patch direction (the light's
 * propagation direction), each layer's absorptance, and the system's T and R for the balance. */
static int write_absorptance(bst_ctx *ctx, const char *sub, const char *path,
                             const struct cli_layers *set, const bst_layer *sys, const bst_stack_opts *so)
{
    size_t n = set->n, N = bst_basis_size(set->basis);
    double *af = malloc(n * N * sizeof *af), *ab = malloc(n * N * sizeof *ab);
    double *t = malloc(2 * N * sizeof *t), *r = t ? t + N : NULL;
    struct cli_out out = {0};
    int rc = (af && ab && t) ? cli_out_open(&out, sub, path) : cli_fail(sub, "out of memory");
    if (rc == CLI_OK) {
        fprintf(out.fp, "channel\tside\tpatch\ttheta_deg\tphi_deg");
        for (size_t i = 0; i < n; i++)
            fprintf(out.fp, "\tA%zu", i + 1);
        fprintf(out.fp, "\tT\tR\n");
    }
    for (size_t ch = 0; rc == CLI_OK && ch < bst_layer_nchannels(sys); ch++) {
        const char *name = bst_layer_channel(sys, ch);
        size_t c0 = (size_t)bst_layer_find_channel(set->layers[0], name);
        int st = bst_stack_absorptance(ctx, n, (const bst_layer *const *)set->layers, c0, so, af, ab);
        if (st < 0) {
            rc = cli_fail_ctx(sub, path, ctx);
            break;
        }
        for (int side = 0; side < 2 && rc == CLI_OK; side++) {
            bst_layer_hemispherical(ctx, sys, ch, side ? BST_TB : BST_TF, t);
            bst_layer_hemispherical(ctx, sys, ch, side ? BST_RB : BST_RF, r);
            for (size_t j = 0; j < N; j++) {
                double d[3];
                bst_basis_center(set->basis, j, d);
                double th = acos(d[2]) * 180 / M_PI, ph = atan2(d[1], d[0]) * 180 / M_PI;
                fprintf(out.fp, "%s\t%s\t%zu\t%.4f\t%.4f", name, side ? "back" : "front", j, th,
                        ph < 0 ? ph + 360 : ph);
                for (size_t i = 0; i < n; i++)
                    fprintf(out.fp, "\t%.8f", (side ? ab : af)[i * N + j]);
                fprintf(out.fp, "\t%.8f\t%.8f\n", t[j], r[j]);
            }
        }
    }
    if (rc == CLI_OK)
        rc = cli_out_commit(&out, sub);
    else
        cli_out_abort(&out);
    free(af), free(ab), free(t);
    return rc;
}

int cmd_combine(int argc, char **argv)
{
    enum { O_KLEMS = 256, O_ONLY, O_CHANNELS, O_PRECISION, O_DROP, O_REDUCE, O_NOREDUCE, O_DENSE,
           O_ABS, O_STRICT, O_HELP };
    static const struct option longopts[] = {
        {"klems", optional_argument, NULL, O_KLEMS}, {"only", required_argument, NULL, O_ONLY},
        {"channels", required_argument, NULL, O_CHANNELS},
        {"precision", required_argument, NULL, O_PRECISION},
        {"drop-tol", required_argument, NULL, O_DROP}, {"reduce", required_argument, NULL, O_REDUCE},
        {"no-reduce", no_argument, NULL, O_NOREDUCE}, {"dense", no_argument, NULL, O_DENSE},
        {"absorptance", required_argument, NULL, O_ABS}, {"strict", no_argument, NULL, O_STRICT},
        {"help", no_argument, NULL, O_HELP}, {NULL, 0, NULL, 0}};
    const char *sub = "combine";
    struct cli_basis_choice basis = {0};
    const char *outpath = NULL, *channels = NULL, *abspath = NULL;
    double reduce = 90.0;
    int verbose = 0;
    bst_stack_opts so;
    bst_stack_opts_init(&so);
    optind = 1;
    opterr = 0;
    int c;
    while ((c = getopt_long(argc, argv, ":k:o:vh", longopts, NULL)) != -1) {
        switch (c) {
        case 'k':
        case O_KLEMS:
            if (cli_parse_basis_option(sub, c == 'k' ? 'k' : 'K', optarg, &basis) != CLI_OK)
                return CLI_USAGE;
            break;
        case O_ONLY: {
            so.comps = 0;
            char *list = strdup(optarg), *save = NULL;
            for (char *t = strtok_r(list, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
                int comp = bst_comp_parse(t);
                if (comp < 0) {
                    int rc = cli_usage(sub, "--only: unknown component '%s' (use Tf, Rf, Tb, Rb)", t);
                    free(list);
                    return rc;
                }
                so.comps |= BST_COMP_BIT(comp);
            }
            free(list);
            if (!so.comps)
                return cli_usage(sub, "--only: no component given");
            break;
        }
        case O_CHANNELS: channels = optarg; break;
        case O_PRECISION:
            if (strcmp(optarg, "double") == 0)
                so.precision = BST_DOUBLE;
            else if (strcmp(optarg, "single") == 0)
                so.precision = BST_FLOAT;
            else
                return cli_usage(sub, "--precision %s: use double or single", optarg);
            break;
        case O_DROP:
            if (cli_parse_double(optarg, &so.drop_tol) || so.drop_tol < 0 || so.drop_tol >= 1)
                return cli_usage(sub, "--drop-tol %s: a number in [0, 1) is required", optarg);
            break;
        case O_REDUCE:
            if (cli_parse_double(optarg, &reduce) || reduce < 0 || reduce >= 100)
                return cli_usage(sub, "--reduce %s: a percentile in [0, 100) is required", optarg);
            break;
        case O_NOREDUCE: reduce = -1; break;
        case O_DENSE: so.force_dense = 1; break;
        case O_ABS: abspath = optarg; break;
        case O_STRICT: so.strict = 1; break;
        case 'v': verbose = 1; break;
        case 'o': outpath = optarg; break;
        case 'h':
        case O_HELP: fputs(help, stdout); return CLI_OK;
        case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    if (!outpath)
        return cli_usage(sub, "no output file: give -o OUT");
    if (argc - optind < 1)
        return cli_usage(sub, "no layers given");
    if (verbose)
        so.on_step = verbose_step;

    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    struct cli_layers set;
    int rc = cli_layers_load(&set, ctx, sub, (size_t)(argc - optind), argv + optind, &basis,
                             channels);
    bst_layer *sys = NULL;
    if (rc == CLI_OK) {
        int st = bst_stack_combine(ctx, set.n, (const bst_layer *const *)set.layers, &so, &sys);
        if (st < 0)
            rc = cli_fail_ctx(sub, "combining", ctx);
        else
            cli_warn_ctx(sub, NULL, st, ctx);
    }
    if (rc == CLI_OK && abspath)
        rc = write_absorptance(ctx, sub, abspath, &set, sys, &so);
    if (rc == CLI_OK)
        rc = cli_write_layer(ctx, sub, sys, outpath, reduce, argc, argv, &set);
    bst_layer_free(sys);
    cli_layers_free(&set);
    bst_ctx_free(ctx);
    return rc;
}
