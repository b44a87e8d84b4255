/* write.c - a combined system written as BSDF XML (layers.h): the description and command line
 * recorded in it, the date ($SOURCE_DATE_EPOCH), the reduction asked, and the output file made
 * atomically. */
#include <config.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "cli.h"
#include "layers.h"

#define LAST_SOURCE_DATE 253402300799LL /* 9999-12-31T23:59:59Z: the date keeps four digits */

/* cli_write_layer, and cli_write_varres when v is set (l the coarse system). */
static int write_any(bst_ctx *ctx, const char *sub, const bst_layer *l, const bst_varres *v,
                     const char *path, const struct cli_reduce *reduce, int argc, char **argv,
                     const struct cli_layers *set)
{
    size_t len = 64 + (set && set->description ? strlen(set->description) : 0);
    for (int i = 0; i < argc; i++)
        len += strlen(argv[i]) + 1;
    char *desc = malloc(len);
    if (!desc)
        return cli_fail(sub, "out of memory");
    snprintf(desc, len, "%s\ncommand: bsdfstack", set && set->description ? set->description : "");
    for (int i = 0; i < argc; i++) {
        if (cli_threads_arg(argc, argv, &i)) /* changes no output byte: not recorded */
            continue;
        strcat(desc, " ");
        strcat(desc, argv[i]);
    }
    bst_bsdf_write_opts wo;
    bst_bsdf_write_opts_init(&wo);
    wo.reduce_pct = reduce->pct;
    wo.reduce_tol = reduce->tol;
    wo.description = desc;
    char date[64];
    struct cli_out out;
    int rc = cli_source_date(sub, date, sizeof date, &wo.date);
    if (rc == CLI_OK)
        rc = cli_out_open(&out, sub, path);
    if (rc == CLI_OK) {
        int st = v ? bst_bsdf_write_varres(ctx, l, v, out.fp, &wo) : bst_bsdf_write(ctx, l, out.fp, &wo);
        if (st < 0) {
            rc = cli_out_fail_ctx(&out, sub, ctx);
        } else {
            cli_warn_ctx(sub, path, st, ctx); /* (BST_WACCURACY: the file as asked) */
            rc = cli_out_commit(&out, sub);
        }
    }
    free(desc);
    return rc;
}

int cli_source_date(const char *sub, char *buf, size_t size, const char **date)
{
    *date = NULL;
    const char *epoch = getenv("SOURCE_DATE_EPOCH");
    if (!epoch || !*epoch)
        return CLI_OK;
    char *end;
    errno = 0;
    long long secs = strtoll(epoch, &end, 10);
    time_t t = (time_t)secs;
    struct tm tm;
    if (epoch[0] >= '0' && epoch[0] <= '9' && *end == '\0' && errno == 0 &&
        secs <= LAST_SOURCE_DATE && gmtime_r(&t, &tm) && strftime(buf, size, "%Y-%m-%dT%H:%M:%SZ", &tm)) {
        *date = buf;
        return CLI_OK;
    }
    char shown[64];
    snprintf(shown, sizeof shown, "%s", epoch); /* cut, so that the reason is seen */
    return cli_fail(sub, "SOURCE_DATE_EPOCH '%s'%s is not a whole number of seconds since 1970 "
                    "(0 to %lld): unset it or give one", shown, strlen(epoch) >= sizeof shown ? "..." : "",
                    (long long)LAST_SOURCE_DATE);
}

int cli_write_layer(bst_ctx *ctx, const char *sub, const bst_layer *l, const char *path,
                    const struct cli_reduce *reduce, int argc, char **argv, const struct cli_layers *set)
{
    return write_any(ctx, sub, l, NULL, path, reduce, argc, argv, set);
}

int cli_write_varres(bst_ctx *ctx, const char *sub, const bst_layer *coarse, const bst_varres *v,
                     const char *path, const struct cli_reduce *reduce, int argc, char **argv,
                     const struct cli_layers *set)
{
    return write_any(ctx, sub, coarse, v, path, reduce, argc, argv, set);
}
