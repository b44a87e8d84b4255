/* cmd_convert.c - `bsdfstack convert IN -o OUT`: read any supported BSDF XML file, resample it to
 * another basis, write it. */
#include <config.h>

#include <getopt.h>
#include <string.h>

#include "cli.h"
#include "layers.h"

static const char help[] =
    "Usage: bsdfstack convert [-k K | --klems[=full|half|quarter]] [--reduce PCT | --no-reduce]\n"
    "                         [--channels NAMES] -o OUT IN\n"
    "Reads a BSDF XML file (Klems, TensorTree3 or TensorTree4), resamples it to the chosen basis\n"
    "and writes it as BSDF XML: a TensorTree4 for -k, a Klems matrix file for --klems.\n"
    "\n"
    "Options:\n"
    "  -k K               Shirley-Chiu tensor-tree basis of order K (1..7); default: the file's own\n"
    "  --klems[=WHICH]    Klems basis: full (default), half or quarter\n"
    "  --reduce PCT       tensor-tree reduction percentile (default 90); --no-reduce: every cell\n"
    "  --channels NAMES   only these channels (comma-separated)\n"
    "  -o OUT             output file ('-' = standard output), written atomically\n";

int cmd_convert(int argc, char **argv)
{
    enum { O_KLEMS = 256, O_REDUCE, O_NOREDUCE, O_CHANNELS, O_HELP };
    static const struct option longopts[] = {
        {"klems", optional_argument, NULL, O_KLEMS}, {"reduce", required_argument, NULL, O_REDUCE},
        {"no-reduce", no_argument, NULL, O_NOREDUCE}, {"channels", required_argument, NULL, O_CHANNELS},
        {"help", no_argument, NULL, O_HELP}, {NULL, 0, NULL, 0}};
    const char *sub = "convert", *outpath = NULL, *channels = NULL;
    struct cli_basis_choice basis = {0};
    double reduce = BST_REDUCE_PCT;
    int c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":k:o:h", longopts, NULL)) != -1) {
        switch (c) {
        case 'k':
        case O_KLEMS:
            if (cli_parse_basis_option(sub, c == 'k' ? 'k' : 'K', optarg, &basis) != CLI_OK)
                return CLI_USAGE;
            break;
        case O_REDUCE:
            if (cli_parse_double(optarg, &reduce) || reduce < 0 || reduce >= 100)
                return cli_usage(sub, "--reduce %s: a percentile in [0, 100) is required", optarg);
            break;
        case O_NOREDUCE: reduce = -1; break;
        case O_CHANNELS: channels = optarg; break;
        case 'o': outpath = optarg; break;
        case 'h':
        case O_HELP: fputs(help, stdout); return CLI_OK;
        case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    if (!outpath)
        return cli_usage(sub, "no output file: give -o OUT");
    if (argc - optind != 1)
        return cli_usage(sub, argc - optind < 1 ? "no input file given" : "one input file expected");
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    struct cli_layers set;
    int rc = cli_layers_load(&set, ctx, sub, 1, argv + optind, &basis, channels);
    if (rc == CLI_OK)
        rc = cli_write_layer(ctx, sub, set.layers[0], outpath, reduce, argc, argv, &set);
    cli_layers_free(&set);
    bst_ctx_free(ctx);
    return rc;
}
