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
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"
#include "interrupt.h"

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
    /* the library often names the file or spec itself: name it once, also after the place it was
     * given ("FILE:LINE: SPEC", a batch line) */
    if (!what || !*what)
        return cli_fail(sub, "%s", msg);
    const char *last = what;
    for (const char *p = strstr(what, ": "); p; p = strstr(p + 2, ": "))
        last = p + 2;
    size_t wl = strlen(last);
    if (strncmp(msg, last, wl) == 0 && msg[wl] == ':')
        return cli_fail(sub, "%.*s%s", (int)(last - what), what, msg);
    return cli_fail(sub, "%s: %s", what, msg);
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
 * bst_output writes what PATH names as it demands (output.c); "-" is standard output. */

static int stdout_reported; /* standard output's error is told once, however many writes fail */

/* The message of o's failure, then abort. */
static int out_fail(struct cli_out *o, const char *sub)
{
    int rc = cli_fail(sub, "%s", o->ctx ? bst_ctx_message(o->ctx) : "out of memory");
    cli_out_abort(o);
    return rc;
}

int cli_out_open(struct cli_out *o, const char *sub, const char *path)
{
    memset(o, 0, sizeof *o);
    if (strcmp(path, "-") == 0) {
        o->fp = stdout;
        return CLI_OK;
    }
    if (!(o->ctx = bst_ctx_new()) || !(o->path = strdup(path)))
        return out_fail(o, sub);
    cli_interrupt_opening(); /* a signal before the temporary is held waits for it */
    int rc = bst_output_open(o->ctx, path, &o->out);
    if (rc == BST_OK)
        o->held = cli_interrupt_hold(bst_output_temporary(o->out)) + 1; /* a signal removes it */
    cli_interrupt_opened();
    if (rc < 0)
        return out_fail(o, sub);
    o->fp = bst_output_file(o->out);
    return CLI_OK;
}

char *cli_out_key(const char *path)
{
    if (strcmp(path, "-") == 0)
        return strdup("-");
    char key[BST_OUTPUT_KEY_MAX];
    bst_ctx *ctx = bst_ctx_new();
    if (!ctx)
        return NULL;
    int found = bst_output_key(ctx, path, key, sizeof key) == BST_OK;
    bst_ctx_free(ctx);
    if (found)
        return strdup(key);
    char *p = malloc(strlen(path) + 3);
    if (p)
        strcpy(p, "P "), strcpy(p + 2, path);
    return p;
}

int cli_out_same(const char *a, const char *b)
{
    char *ka = cli_out_key(a), *kb = cli_out_key(b);
    int same = ka && kb ? strcmp(ka, kb) == 0 : -1;
    free(ka), free(kb);
    return same;
}

int cli_out_flush(struct cli_out *o, const char *sub)
{
    if (o->fp == stdout)
        return cli_stdout_check(sub);
    return bst_output_flush(o->out) < 0 ? out_fail(o, sub) : CLI_OK;
}

int cli_out_commit(struct cli_out *o, const char *sub)
{
    if (o->fp == stdout) {
        o->fp = NULL;
        return cli_stdout_check(sub);
    }
    int st = bst_output_commit(o->out);
    o->out = NULL;
    o->fp = NULL;
    if (st < 0)
        return out_fail(o, sub);
    cli_out_abort(o);
    return CLI_OK;
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
    bst_output_abort(o->out);
    cli_interrupt_release(o->held - 1); /* renamed into place or removed by now */
    bst_ctx_free(o->ctx);
    free(o->path);
    memset(o, 0, sizeof *o);
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

/* OpenBLAS (pthreads) parks its worker threads only after spinning on sched_yield for a while
 * (2^28 cycles, about 0.1 s) since their start and since each job: a core's CPU time burnt beside
 * the reading, resampling and writing around the algebra (S1 at k = 5: 0.25 of its 1.08 CPU
 * seconds; convert --no-reduce of the k = 6 blind, which does no BLAS work at all: 0.2-0.35 of
 * 1.6-1.8).  Its blas_thread_shutdown_ (exported for fork handlers; weak here, so that another BLAS
 * links too) stops them, and its next threaded call starts them again (OpenBLAS's lazy
 * re-initialization after a fork).  Called from the main thread between phases, when no BLAS call
 * can be in flight: at the start and after a combination. */
extern int blas_thread_shutdown_(void) __attribute__((weak));
extern void openblas_read_env(void) __attribute__((weak));

void cli_blas_rest(void)
{
    if (blas_thread_shutdown_)
        blas_thread_shutdown_();
}

/* The spin between the BLAS calls of a combination (while this thread does its own work between
 * them) is the same waste, and no phase boundary reaches it.  OpenBLAS reads how long a worker
 * spins, 2^OPENBLAS_THREAD_TIMEOUT cycles, from the environment when it loads and applies it when
 * it starts its workers; so unless the user set it, set it here, have OpenBLAS read its
 * environment again (openblas_read_env, exported) and stop the workers: their next start spins
 * 2^20 cycles (about 0.3 ms), long enough for the bursts of small calls inside a factorization.
 * S1 at k = 5 (2 cores): 1.04 -> 0.82 CPU-s at the same 0.52 s wall (bench/README.md). */
#define CLI_BLAS_SPIN "20"

void cli_blas_setup(void)
{
    if (openblas_read_env && blas_thread_shutdown_ && !getenv("OPENBLAS_THREAD_TIMEOUT") &&
        setenv("OPENBLAS_THREAD_TIMEOUT", CLI_BLAS_SPIN, 0) == 0)
        openblas_read_env();
    cli_blas_rest();
}

/* OpenBLAS's DYNAMIC_ARCH build (Debian's) picks its kernels by the CPU's model number as it
 * loads, and takes Prescott's (SSE3) for a model it does not know: 0.3.21 does so on this project's
 * AVX-512 Xeons, where a 2048^3 DGEMM runs at 21 GFLOP/s with them and at 146 with SkylakeX's
 * (bench/README.md).  It reads OPENBLAS_CORETYPE, its own way to choose, only as it loads; so where
 * the user has not set it, OpenBLAS picked a core without AVX2 kernels and the CPU (and the
 * system, as libgcc's cpuid check says) has AVX2 and FMA, the program sets it to the best such
 * core this OpenBLAS holds (AVX-512 F, CD, BW, DQ and VL: SkylakeX; else Haswell) and runs itself
 * again with the same arguments and environment.  CLI_BLAS_PICKED_ENV keeps OpenBLAS's own pick for
 * -v.  Results change in their last bits only (another kernel's order of additions). */
extern char *openblas_get_corename(void) __attribute__((weak));
extern char gotoblas_SKYLAKEX[] __attribute__((weak));
extern char gotoblas_HASWELL[] __attribute__((weak));
#define CLI_BLAS_PICKED_ENV "BSDFSTACK_OPENBLAS_PICKED"

static int blas_core_old(const char *name)
{
    static const char *const old[] = {"prescott", "core2", "penryn", "dunnington", "nehalem",
                                      "atom", "sandybridge", NULL};
    for (size_t i = 0; old[i]; i++)
        if (strcasecmp(name, old[i]) == 0)
            return 1;
    return 0;
}

static const char *blas_core_better(void)
{
#if defined(__x86_64__) && defined(__GNUC__)
    __builtin_cpu_init();
    if (gotoblas_SKYLAKEX && __builtin_cpu_supports("avx512f") &&
        __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512bw") &&
        __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl"))
        return "SkylakeX";
    if (gotoblas_HASWELL && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
        return "Haswell";
#endif
    return NULL;
}

void cli_blas_kernels(char **argv)
{
    if (!openblas_get_corename || getenv("OPENBLAS_CORETYPE"))
        return;
    const char *picked = openblas_get_corename(), *better = blas_core_better();
    if (!picked || !better || !blas_core_old(picked))
        return;
    if (setenv(CLI_BLAS_PICKED_ENV, picked, 1) == 0 && setenv("OPENBLAS_CORETYPE", better, 1) == 0)
        execv("/proc/self/exe", argv);
    unsetenv("OPENBLAS_CORETYPE"); /* not run again: on as it is */
    unsetenv(CLI_BLAS_PICKED_ENV);
}

void cli_blas_note(const char *sub)
{
    if (!openblas_get_corename)
        return;
    const char *picked = getenv(CLI_BLAS_PICKED_ENV), *core = openblas_get_corename();
    if (picked && getenv("OPENBLAS_CORETYPE"))
        fprintf(stderr, "bsdfstack %s: dense algebra: OpenBLAS's %s kernels (it picked %s for this "
                "CPU, which has better; OPENBLAS_CORETYPE chooses)\n", sub, core, picked);
    else
        fprintf(stderr, "bsdfstack %s: dense algebra: OpenBLAS's %s kernels\n", sub, core);
}

ssize_t cli_read_line(const char *sub, const char *name, long ln, char **buf, size_t *cap, FILE *fp)
{
    ssize_t len = getline(buf, cap, fp);
    if (len < 0)
        return -1;
    const char *nul = memchr(*buf, '\0', (size_t)len);
    if (nul) {
        cli_fail(sub, "%s:%ld: a NUL byte at column %zu: not a text line", name, ln,
                 (size_t)(nul - *buf) + 1);
        return -2;
    }
    return len;
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

int cli_parse_path(const char *sub, const char *what, const char *path)
{
    return *path ? CLI_OK : cli_usage(sub, "%s '': an empty file name", what);
}

int cli_parse_channels(const char *sub, const char *opt, const char *list)
{
    if (!*list)
        return cli_usage(sub, "%s '': no channel named", opt);
    for (const char *p = list;; p++) {
        size_t n = strcspn(p, ",");
        if (n == 0)
            return cli_usage(sub, "%s '%s': an empty channel name", opt, list);
        if (!p[n])
            return CLI_OK;
        p += n;
    }
}

int cli_parse_incident(const char *sub, const char *s, double dir[2])
{
    char extra;
    if (sscanf(s, "%lf,%lf%c", &dir[0], &dir[1], &extra) != 2 || !isfinite(dir[0]) ||
        !isfinite(dir[1]) || dir[0] < 0 || dir[0] >= 90)
        return cli_usage(sub, "--incident %s: give THETA,PHI in degrees, 0 <= THETA < 90", s);
    return CLI_OK;
}

void cli_patch_direction(const bst_basis *b, size_t p, double *theta, double *phi)
{
    double d[3];
    bst_basis_center(b, p, d);
    *theta = acos(d[2]) * 180 / M_PI;
    *phi = atan2(d[1], d[0]) * 180 / M_PI;
    if (*phi < 0)
        *phi += 360;
}

size_t cli_incident_patch(const bst_basis *b, double theta, double phi)
{
    double t = fmin(theta, 90 - 1e-7) * M_PI / 180, p = phi * M_PI / 180;
    double d[3] = {sin(t) * cos(p) + 1e-9, sin(t) * sin(p) + 1e-9, cos(t)};
    return bst_basis_patch(b, d);
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

int cli_threads_arg(int argc, char **argv, int *i)
{
    const char *a = argv[*i];
    if (strncmp(a, "--threads=", 10) == 0)
        return 1;
    if (strcmp(a, "--threads") != 0)
        return 0;
    if (*i + 1 < argc)
        (*i)++;
    return 1;
}
