/* cli.c - helpers shared by the subcommands: one-line errors, progress on a terminal, output
 * files (atomic where PATH is a regular file), standard output's write errors, strict number
 * parsing. */
#include <config.h>

#include <errno.h>
#include <fcntl.h>
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

/* ------------------------------------------------------------------ output files
 *
 * What PATH names decides how it is written:
 *   a regular file, or nothing yet   a temporary beside it, renamed over it on commit (atomic);
 *                                    an existing file keeps its mode and, where we may, its owner,
 *                                    a new one gets 0666 & ~umask as fopen would give it
 *   a symbolic link (chain)          the same beside the file the links lead to: the links stay
 *   a device, FIFO or socket         opened and written directly, no temporary
 *   a directory                      an error
 *   "-"                              standard output */

static int stdout_reported; /* standard output's error is told once, however many writes fail */

#define CLI_MAX_LINKS 40 /* symbolic links followed before giving up (ELOOP), as Linux does */

/* The target of the symbolic link at path, malloc'd; NULL with errno set. */
static char *read_link(const char *path)
{
    for (size_t size = 256;; size *= 2) {
        char *buf = malloc(size);
        if (!buf)
            return NULL;
        ssize_t n = readlink(path, buf, size);
        if (n < 0) {
            int e = errno;
            free(buf);
            errno = e;
            return NULL;
        }
        if ((size_t)n < size) {
            buf[n] = '\0';
            return buf;
        }
        free(buf);
    }
}

/* The path that path's chain of symbolic links finally names (which need not exist yet), each
 * relative link taken from the directory holding the link; malloc'd, NULL with errno set. */
static char *follow_links(const char *path)
{
    char *cur = strdup(path);
    for (int hops = 0; cur; hops++) {
        struct stat st;
        if (lstat(cur, &st) != 0 || !S_ISLNK(st.st_mode))
            return cur; /* not there (yet), or not a link: later steps report what is wrong */
        char *link = hops < CLI_MAX_LINKS ? read_link(cur) : NULL;
        if (!link) {
            int e = hops < CLI_MAX_LINKS ? errno : ELOOP;
            free(cur);
            errno = e;
            return NULL;
        }
        const char *slash = strrchr(cur, '/');
        size_t dirlen = link[0] == '/' || !slash ? 0 : (size_t)(slash - cur) + 1;
        char *next = malloc(dirlen + strlen(link) + 1);
        if (next) {
            memcpy(next, cur, dirlen);
            strcpy(next + dirlen, link);
        }
        free(link);
        free(cur);
        cur = next;
    }
    return NULL;
}

/* Open o->path directly (a device, FIFO or socket): the kernel follows any links. */
static int open_direct(struct cli_out *o, const char *sub)
{
    int fd = open(o->path, O_WRONLY | O_NOCTTY);
    if (fd < 0)
        return cli_fail(sub, "%s: cannot open for writing: %s", o->path, strerror(errno));
    if (!(o->fp = fdopen(fd, "w"))) {
        int e = errno;
        close(fd);
        return cli_fail(sub, "%s: cannot open for writing: %s", o->path, strerror(e));
    }
    return CLI_OK;
}

/* A temporary beside o->target, with the permissions (and owner) of old, the regular file it will
 * replace, or those of a new file when old is NULL. */
static int open_temporary(struct cli_out *o, const char *sub, const struct stat *old)
{
    size_t n = strlen(o->target);
    if (!(o->tmp = malloc(n + 16)))
        return cli_fail(sub, "%s: out of memory", o->path);
    snprintf(o->tmp, n + 16, "%s.tmpXXXXXX", o->target); /* same directory: rename() is atomic */
    int fd = mkstemp(o->tmp);
    if (fd < 0) {
        int e = errno;
        free(o->tmp);
        o->tmp = NULL;
        return cli_fail(sub, "%s: cannot create output file: %s", o->path, strerror(e));
    }
    if (old) {
        /* best effort: only root may give the file away; chown before chmod, which it may clear */
        if (fchown(fd, old->st_uid, old->st_gid) != 0) {
            /* the replacement is then ours, with the old permissions */
        }
        fchmod(fd, old->st_mode & 07777);
    } else {
        mode_t mask = umask(0); /* mkstemp creates 0600: give what a plain fopen would */
        umask(mask);
        fchmod(fd, 0666 & ~mask);
    }
    if (!(o->fp = fdopen(fd, "w"))) {
        int e = errno;
        close(fd);
        return cli_fail(sub, "%s: cannot open output file: %s", o->path, strerror(e));
    }
    return CLI_OK;
}

int cli_out_open(struct cli_out *o, const char *sub, const char *path)
{
    memset(o, 0, sizeof *o);
    if (strcmp(path, "-") == 0) {
        o->fp = stdout;
        return CLI_OK;
    }
    if (!*path)
        return cli_fail(sub, "an empty output file name");
    if (!(o->path = strdup(path)))
        return cli_fail(sub, "%s: out of memory", path);
    struct stat st; /* through any links */
    int exists = stat(path, &st) == 0, rc;
    if (exists && S_ISDIR(st.st_mode)) {
        rc = cli_fail(sub, "%s: is a directory; name an output file", path);
    } else if (exists && !S_ISREG(st.st_mode)) {
        rc = open_direct(o, sub);
    } else {
        if (!(o->target = follow_links(path)))
            rc = cli_fail(sub, "%s: %s", path, strerror(errno));
        else
            rc = open_temporary(o, sub, exists ? &st : NULL);
    }
    if (rc != CLI_OK)
        cli_out_abort(o);
    return rc;
}

int cli_out_flush(struct cli_out *o, const char *sub)
{
    if (o->fp == stdout)
        return cli_stdout_check(sub);
    /* the reason of an error: the failed flush's errno, or EIO for an error an earlier write met */
    errno = 0;
    if (fflush(o->fp) == 0 && !ferror(o->fp))
        return CLI_OK;
    int rc = cli_fail(sub, "%s: error writing: %s", o->path, strerror(errno ? errno : EIO));
    cli_out_abort(o);
    return rc;
}

int cli_out_commit(struct cli_out *o, const char *sub)
{
    int rc = cli_out_flush(o, sub);
    if (o->fp == stdout || rc != CLI_OK) {
        o->fp = NULL;
        return rc;
    }
    int closed = fclose(o->fp) == 0;
    o->fp = NULL;
    if (!closed)
        rc = cli_fail(sub, "%s: error writing: %s", o->path, strerror(errno));
    else if (o->tmp && rename(o->tmp, o->target) != 0)
        rc = cli_fail(sub, "%s: cannot rename output into place: %s", o->path, strerror(errno));
    else {
        free(o->tmp); /* in place: nothing to remove */
        o->tmp = NULL;
    }
    cli_out_abort(o);
    return rc;
}

int cli_out_fail_ctx(struct cli_out *o, const char *sub, bst_ctx *ctx)
{
    int to_stdout = o->fp == stdout;
    int rc = cli_fail_ctx(sub, to_stdout ? "standard output" : o->path, ctx);
    if (to_stdout && ferror(stdout))
        stdout_reported = 1; /* that was standard output's error: main need not say it again */
    cli_out_abort(o);
    return rc;
}

void cli_out_abort(struct cli_out *o)
{
    if (o->fp && o->fp != stdout)
        fclose(o->fp);
    o->fp = NULL;
    if (o->tmp)
        unlink(o->tmp);
    free(o->tmp);
    free(o->target);
    free(o->path);
    o->tmp = o->target = o->path = NULL;
}

/* ------------------------------------------------------------------ standard streams */

int cli_stdout_failed(const char *sub, int e)
{
    if (stdout_reported)
        return CLI_FAIL;
    stdout_reported = 1;
    return cli_fail(sub, "error writing to standard output: %s", strerror(e ? e : EIO));
}

int cli_stdout_check(const char *sub)
{
    errno = 0;
    if (fflush(stdout) == 0 && !ferror(stdout))
        return CLI_OK;
    return cli_stdout_failed(sub, errno);
}

void cli_hold_std_fds(void)
{
    for (int fd = 0; fd <= 2; fd++) {
        if (fcntl(fd, F_GETFD) >= 0 || errno != EBADF)
            continue;
        /* the wrong way round on purpose: reading fd 0 or writing fd 1, 2 fails with EBADF */
        int got = open("/dev/null", fd == 0 ? O_WRONLY : O_RDONLY);
        if (got >= 0 && got != fd) {
            dup2(got, fd);
            close(got);
        }
    }
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
