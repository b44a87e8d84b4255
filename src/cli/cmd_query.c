/* cmd_query.c - `bsdfstack query FILE`: the BSDF value a file holds for pairs of directions, as
 * RADIANCE's libBSDF evaluates it (the public, testable face of the reader). */
#include <config.h>

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "cli.h"

static const char help[] =
    "Usage: bsdfstack query [--channel NAME] [--degrees COMP] FILE\n"
    "Reads direction pairs from standard input and prints f(in, out), the BSDF (1/sr) that FILE\n"
    "holds for each pair, one per line (%.6e), in input order.\n"
    "\n"
    "Input lines (blank lines and lines starting with # are skipped):\n"
    "  in_x in_y in_z out_x out_y out_z\n"
    "      two vectors in the file's own frame (+Z = interior, XML Front = exterior = -Z side),\n"
    "      both pointing away from the surface: in towards the light source, out along the\n"
    "      scattered light; they are normalised (any finite, non-zero length).  The component\n"
    "      follows from the z signs: Tf in_z<0<out_z, Tb out_z<0<in_z, Rf both<0, Rb both>0.\n"
    "      (RADIANCE's bsdfquery reads the same two vectors in the other order: out, then in.)\n"
    "  with --degrees COMP:  theta_in phi_in theta_out phi_out\n"
    "      angles in degrees of the same two vectors, theta (0 to 90) from the normal of the side\n"
    "      each vector lies on (in: the incidence side of COMP, out: its exit side), phi from +X\n"
    "      towards +Y of the vector itself.\n"
    "\n"
    "Options:\n"
    "  --channel NAME   spectral channel (default: the first in the file, usually Visible)\n"
    "  --degrees COMP   read angles for component COMP (Tf, Rf, Tb, Rb)\n";

int cmd_query(int argc, char **argv)
{
    static const struct option longopts[] = {{"channel", required_argument, NULL, 'c'},
                                             {"degrees", required_argument, NULL, 'd'},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *sub = "query", *channel = NULL;
    int comp = -1, c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'c': channel = optarg; break;
        case 'd':
            if ((comp = bst_comp_parse(optarg)) < 0)
                return cli_usage(sub, "--degrees %s: use Tf, Rf, Tb or Rb", optarg);
            break;
        case 'h': fputs(help, stdout); return CLI_OK;
        case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    if (argc - optind != 1)
        return cli_usage(sub, argc - optind < 1 ? "no file given" : "one file expected");
    const char *path = argv[optind];
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    bst_bsdf *b;
    int st = bst_bsdf_read(ctx, path, NULL, &b);
    if (st < 0) {
        int rc = cli_fail_ctx(sub, NULL, ctx);
        bst_ctx_free(ctx);
        return rc;
    }
    /* completion notes are for combine -v, query answers as libBSDF does; but values read other
     * than the file states (negatives read as 0, a tree averaged) are said, as info says them */
    cli_warn_bsdf(sub, path, b);
    bst_ctx_clear(ctx);
    size_t ch = 0;
    if (channel) {
        size_t i = 0;
        while (i < bst_bsdf_nchannels(b) && strcasecmp(bst_bsdf_channel(b, i), channel) != 0)
            i++;
        if (i == bst_bsdf_nchannels(b)) {
            bst_bsdf_free(b);
            bst_ctx_free(ctx);
            return cli_fail(sub, "%s: no channel '%s' in the file", path, channel);
        }
        ch = i;
    }
    char *line = NULL;
    size_t size = 0;
    long lineno = 0;
    int rc = CLI_OK;
    ssize_t got;
    while (rc == CLI_OK && (got = cli_read_line(sub, "standard input", lineno + 1, &line, &size, stdin)) != -1) {
        lineno++;
        if (got < 0) {
            rc = CLI_FAIL;
            break;
        }
        char *s = line;
        while (*s == ' ' || *s == '\t')
            s++;
        if (*s == '#' || *s == '\n' || *s == '\0')
            continue;
        double v[6], in[3], out[3], f;
        int need = comp >= 0 ? 4 : 6, got = 0;
        char *end = s;
        while (got < need) {
            char *e;
            v[got] = strtod(end, &e);
            if (e == end || !isfinite(v[got]))
                break;
            got++;
            end = e;
        }
        while (*end == ' ' || *end == '\t' || *end == '\n' || *end == '\r')
            end++;
        if (got != need || *end) {
            rc = cli_fail(sub, "standard input line %ld: expected %d numbers", lineno, need);
            break;
        }
        if (comp >= 0 && (v[0] < 0 || v[0] > 90 || v[2] < 0 || v[2] > 90)) {
            double bad = v[0] < 0 || v[0] > 90 ? v[0] : v[2];
            rc = cli_fail(sub, "standard input line %ld: theta %g is out of range: give theta_in "
                          "and theta_out in [0, 90] degrees", lineno, bad);
            break;
        }
        if (comp >= 0) {
            double d = M_PI / 180.0;
            double zin = (comp == BST_TF || comp == BST_RF) ? -1.0 : 1.0;
            double zout = (comp == BST_TF || comp == BST_RB) ? 1.0 : -1.0;
            in[0] = sin(v[0] * d) * cos(v[1] * d), in[1] = sin(v[0] * d) * sin(v[1] * d);
            in[2] = zin * cos(v[0] * d);
            out[0] = sin(v[2] * d) * cos(v[3] * d), out[1] = sin(v[2] * d) * sin(v[3] * d);
            out[2] = zout * cos(v[2] * d);
        } else {
            memcpy(in, v, sizeof in);
            memcpy(out, v + 3, sizeof out);
        }
        if (bst_bsdf_eval(ctx, b, ch, in, out, &f) < 0) {
            rc = cli_fail(sub, "standard input line %ld: %s", lineno, bst_ctx_message(ctx));
            break;
        }
        if (printf("%.6e\n", f) < 0) {
            rc = cli_stdout_failed(sub, errno);
            break;
        }
    }
    /* getline ends at a read error as at the end: a directory or a closed descriptor is no input */
    if (rc == CLI_OK && ferror(stdin))
        rc = cli_fail(sub, "error reading standard input: %s", strerror(errno ? errno : EIO));
    free(line);
    bst_bsdf_free(b);
    bst_ctx_free(ctx);
    return rc;
}
