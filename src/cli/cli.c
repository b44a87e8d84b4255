/* cli.c - helpers shared by the subcommands: one-line errors, progress on a terminal, atomic
 * output files, strict number parsing. */
#include <config.h>

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"

static void vreport(const char *sub, const char *fmt, va_list ap)
{
    fprintf(stderr, "bsdfstack%s%s: ", sub ? " " : "", sub ? sub : "");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
}

int cli_fail(const char *sub, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vreport(sub, fmt, ap);
    va_end(ap);
    return CLI_FAIL;
}

int cli_usage(const char *sub, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vreport(sub, fmt, ap);
    va_end(ap);
    fprintf(stderr, "Try 'bsdfstack %s%s--help' for more information.\n", sub ? sub : "",
            sub ? " " : "");
    return CLI_USAGE;
}

int cli_fail_ctx(const char *sub, const char *what, bst_ctx *ctx)
{
    const char *msg = bst_ctx_message(ctx);
    if (!msg || !*msg)
        msg = bst_strerror(bst_ctx_status(ctx));
    /* the library often names the file or spec itself: name it once */
    size_t wl = what ? strlen(what) : 0;
    if (wl && !(strncmp(msg, what, wl) == 0 && msg[wl] == ':'))
        return cli_fail(sub, "%s: %s", what, msg);
    return cli_fail(sub, "%s", msg);
}

void cli_warn_bsdf(const char *sub, const char *path, const bst_bsdf *b)
{
    if (bst_bsdf_depth(b) > bst_bsdf_order(b))
        fprintf(stderr, "bsdfstack %s: warning: %s: a tensor tree of depth %d, read at k = %d (its "
                "finest cells averaged)\n", sub, path, bst_bsdf_depth(b), bst_bsdf_order(b));
    if (bst_bsdf_negatives(b))
        fprintf(stderr, "bsdfstack %s: warning: %s: %zu negative value%s read as 0 (as libBSDF does)\n",
                sub, path, bst_bsdf_negatives(b), bst_bsdf_negatives(b) > 1 ? "s" : "");
}

void cli_warn_ctx(const char *sub, const char *what, int status, bst_ctx *ctx)
{
    if (status <= 0)
        return;
    const char *msg = bst_ctx_message(ctx);
    if (!msg || !*msg)
        msg = bst_strerror(status);
    fprintf(stderr, "bsdfstack %s: warning: %s%s%s\n", sub, what ? what : "", what ? ": " : "", msg);
    bst_ctx_clear(ctx);
}

struct progress_state {
    int last_permille;
};

static void terminal_progress(double fraction, const char *label, void *opaque)
{
    struct progress_state *st = opaque;
    int permille = (int)(fraction * 1000.0);
    if (permille == st->last_permille)
        return;
    st->last_permille = permille;
    fprintf(stderr, "\r%-40.40s %5.1f%%", label ? label : "", permille / 10.0);
    if (fraction >= 1.0)
        fputs("\r\033[K", stderr);
    fflush(stderr);
}

bst_ctx *cli_ctx_new(const char *sub)
{
    static struct progress_state state = {-1};
    bst_ctx *ctx = bst_ctx_new();
    if (!ctx) {
        cli_fail(sub, "out of memory");
        return NULL;
    }
    if (isatty(STDERR_FILENO))
        bst_ctx_set_progress(ctx, terminal_progress, &state);
    return ctx;
}

int cli_out_open(struct cli_out *o, const char *sub, const char *path)
{
    memset(o, 0, sizeof *o);
    if (strcmp(path, "-") == 0) {
        o->fp = stdout;
        return CLI_OK;
    }
    size_t n = strlen(path);
    o->path = malloc(n + 1);
    o->tmp = malloc(n + 16);
    if (!o->path || !o->tmp) {
        cli_out_abort(o);
        return cli_fail(sub, "%s: out of memory", path);
    }
    memcpy(o->path, path, n + 1);
    /* The temporary lives in the same directory so that rename() is atomic. */
    snprintf(o->tmp, n + 16, "%s.tmpXXXXXX", path);
    int fd = mkstemp(o->tmp);
    if (fd < 0) {
        int e = errno;
        free(o->tmp);
        o->tmp = NULL;
        cli_out_abort(o);
        return cli_fail(sub, "%s: cannot create output file: %s", path, strerror(e));
    }
    /* mkstemp creates the file 0600; give the result the permissions a plain fopen would */
    mode_t mask = umask(0);
    umask(mask);
    fchmod(fd, 0666 & ~mask);
    o->fp = fdopen(fd, "w");
    if (!o->fp) {
        close(fd);
        cli_out_abort(o);
        return cli_fail(sub, "%s: cannot open output file", path);
    }
    return CLI_OK;
}

int cli_out_commit(struct cli_out *o, const char *sub)
{
    if (o->fp == stdout) {
        o->fp = NULL;
        if (fflush(stdout) != 0 || ferror(stdout))
            return cli_fail(sub, "error writing to standard output");
        return CLI_OK;
    }
    int bad = ferror(o->fp) != 0;
    bad |= fclose(o->fp) != 0;
    o->fp = NULL;
    if (bad) {
        int e = errno;
        char *p = o->path;
        o->path = NULL;
        cli_out_abort(o);
        int rc = cli_fail(sub, "%s: error writing: %s", p, strerror(e));
        free(p);
        return rc;
    }
    if (rename(o->tmp, o->path) != 0) {
        int e = errno;
        char *p = o->path;
        o->path = NULL;
        cli_out_abort(o);
        int rc = cli_fail(sub, "%s: cannot rename output into place: %s", p, strerror(e));
        free(p);
        return rc;
    }
    free(o->tmp);
    free(o->path);
    o->tmp = o->path = NULL;
    return CLI_OK;
}

void cli_out_abort(struct cli_out *o)
{
    if (o->fp && o->fp != stdout)
        fclose(o->fp);
    o->fp = NULL;
    if (o->tmp)
        unlink(o->tmp);
    free(o->tmp);
    free(o->path);
    o->tmp = o->path = NULL;
}

int cli_parse_double(const char *s, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || *end != '\0' || errno == ERANGE || !isfinite(v))
        return -1;
    *out = v;
    return 0;
}

int cli_parse_int(const char *s, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (end == s || *end != '\0' || errno == ERANGE || v < -2147483647L || v > 2147483647L)
        return -1;
    *out = (int)v;
    return 0;
}

int cli_parse_comps(const char *sub, const char *list, unsigned *comps)
{
    char *copy = strdup(list), *save = NULL;
    if (!copy)
        return cli_fail(sub, "out of memory");
    *comps = 0;
    for (char *t = strtok_r(copy, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        int c = bst_comp_parse(t);
        if (c < 0) {
            int rc = cli_usage(sub, "--only: unknown component '%s' (use Tf, Rf, Tb, Rb)", t);
            free(copy);
            return rc;
        }
        *comps |= BST_COMP_BIT(c);
    }
    free(copy);
    return *comps ? CLI_OK : cli_usage(sub, "--only: no component given");
}

int cli_parse_incident(const char *sub, const char *s, double dir[2])
{
    char extra;
    if (sscanf(s, "%lf,%lf%c", &dir[0], &dir[1], &extra) != 2 || !isfinite(dir[0]) ||
        !isfinite(dir[1]) || dir[0] < 0 || dir[0] >= 90)
        return cli_usage(sub, "--incident %s: give THETA,PHI in degrees, 0 <= THETA < 90", s);
    return CLI_OK;
}

int cli_parse_precision(const char *sub, const char *s, bst_precision *prec)
{
    if (strcmp(s, "double") == 0)
        *prec = BST_DOUBLE;
    else if (strcmp(s, "single") == 0)
        *prec = BST_FLOAT;
    else
        return cli_usage(sub, "--precision %s: use double or single", s);
    return CLI_OK;
}

void cli_print_help(FILE *fp, const char *text)
{
    fputs(text, fp);
}
