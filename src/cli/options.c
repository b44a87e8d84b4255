/* options.c - parsing the options the stack commands share (layers.h): the basis (-k, --klems),
 * combine's and batch's stack options, memory sizes, the reduction's tolerance. */
#include <config.h>

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "cli.h"
#include "layers.h"

int cli_parse_basis_option(const char *sub, int opt, const char *value, struct cli_basis_choice *choice)
{
    if (opt == 'k') {
        if (cli_parse_int(value, &choice->k) || choice->k < BST_K_MIN || choice->k > BST_K_MAX)
            return cli_usage(sub, "-k %s: the order must be an integer from %d to %d", value,
                             BST_K_MIN, BST_K_MAX);
    } else {
        choice->klems = value ? value : "full";
        if (strcmp(choice->klems, "full") && strcmp(choice->klems, "half") && strcmp(choice->klems, "quarter"))
            return cli_usage(sub, "--klems=%s: use full, half or quarter", choice->klems);
    }
    if (choice->k && choice->klems)
        return cli_usage(sub, "-k and --klems exclude each other");
    return CLI_OK;
}

void cli_basis_choice_of(const bst_basis *b, struct cli_basis_choice *choice)
{
    static const char *const klems[] = {"LBNL/Klems Full", "full", "LBNL/Klems Half", "half",
                                        "LBNL/Klems Quarter", "quarter"};
    memset(choice, 0, sizeof *choice);
    if (bst_basis_kind_of(b) == BST_BASIS_SHIRLEY_CHIU)
        choice->k = bst_basis_order(b);
    for (size_t i = 0; i < 6; i += 2)
        if (bst_basis_kind_of(b) == BST_BASIS_KLEMS && strcmp(bst_basis_name(b), klems[i]) == 0)
            choice->klems = klems[i + 1];
}

void cli_stack_args_init(struct cli_stack_args *a)
{
    memset(a, 0, sizeof *a);
    a->reduce.pct = BST_REDUCE_PCT;
    a->reduce.tol = BST_REDUCE_TOL;
    bst_stack_opts_init(&a->so);
    bst_spectral_opts_init(&a->sp);
}

int cli_stack_option(const char *sub, int c, const char *arg, struct cli_stack_args *a)
{
    switch (c) {
    case 'k':
    case CLI_O_KLEMS: return cli_parse_basis_option(sub, c == 'k' ? 'k' : 'K', arg, &a->basis);
    case CLI_O_ONLY: return cli_parse_comps(sub, arg, &a->so.comps);
    case CLI_O_CHANNELS: a->channels = arg; return cli_parse_channels(sub, "--channels", arg);
    case CLI_O_PRECISION: return cli_parse_precision(sub, arg, &a->so.precision);
    case CLI_O_DROP:
        if (cli_parse_double(arg, &a->so.drop_tol) || a->so.drop_tol < 0 || a->so.drop_tol >= 1)
            return cli_usage(sub, "--drop-tol %s: a number in [0, 1) is required", arg);
        return CLI_OK;
    case CLI_O_REDUCE:
        if (cli_parse_double(arg, &a->reduce.pct) || a->reduce.pct < 0 || a->reduce.pct >= 100)
            return cli_usage(sub, "--reduce %s: a percentile in [0, 100) is required", arg);
        return CLI_OK;
    case CLI_O_NOREDUCE: a->reduce.pct = -1; return CLI_OK;
    case CLI_O_REDUCETOL: return cli_parse_reduce_tol(sub, arg, &a->reduce.tol);
    case CLI_O_DENSE: a->so.force_dense = 1; return CLI_OK;
    case CLI_O_STRICT: a->so.strict = 1; return CLI_OK;
    case CLI_O_PERCH: a->per_channel = 1; return CLI_OK;
    case CLI_O_MAXMEM: return cli_parse_memory(sub, arg, &a->basis.max_memory);
    case CLI_O_SPTOL:
        if (cli_parse_double(arg, &a->sp.tol) || !(a->sp.tol >= 0 && a->sp.tol <= 1))
            return cli_usage(sub, "--spectral-tol %s: a number in [0, 1] is required", arg);
        return CLI_OK;
    case CLI_O_GLASSRULE:
        if (strcmp(arg, "centre") && strcmp(arg, "average"))
            return cli_usage(sub, "--glass-rule %s: use average or centre", arg);
        a->basis.at_centre = a->sp.at_centre = strcmp(arg, "centre") == 0;
        return CLI_OK;
    case CLI_O_RANK3:
        if (strcmp(arg, "exact") && strcmp(arg, "native"))
            return cli_usage(sub, "--rank3 %s: use exact (sampled at the order combined) or native "
                             "(at the tree's own order, held factored)", arg);
        a->basis.rank3 = strcmp(arg, "native") == 0 ? BST_RANK3_NATIVE : BST_RANK3_EXACT;
        return CLI_OK;
    default: return -1;
    }
}

int cli_parse_memory(const char *sub, const char *value, double *bytes)
{
    char *end;
    double v = strtod(value, &end);
    static const char units[] = "KMGT";
    const char *u = *end ? strchr(units, toupper((unsigned char)*end)) : NULL;
    if (u && *u) {
        v *= pow(1024.0, (double)(u - units + 1));
        end++;
        if (toupper((unsigned char)*end) == 'B' || *end == 'i') /* 16G, 16GB, 16GiB */
            end += *end == 'i' ? 1 + (end[1] == 'B') : 1;
    }
    if (end == value || *end || !(v > 0) || !isfinite(v))
        return cli_usage(sub, "--max-memory %s: give a size such as 16G, 800M or 2000000000", value);
    *bytes = v;
    return CLI_OK;
}

int cli_parse_reduce_tol(const char *sub, const char *arg, double *tol)
{
    if (strcmp(arg, "none") == 0) {
        *tol = INFINITY;
        return CLI_OK;
    }
    if (cli_parse_double(arg, tol) || !(*tol >= 0.0) || !isfinite(*tol))
        return cli_usage(sub, "--reduce-tol %s: a directional-hemispherical change >= 0 (e.g. "
                         "0.002), or none", arg);
    return CLI_OK;
}
