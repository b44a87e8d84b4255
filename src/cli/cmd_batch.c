/* cmd_batch.c - `bsdfstack batch FILE`: many stacks, one per line, every distinct layer loaded once
 * onto one basis; each system written as `combine` writes it.
 *
 * -j N combines N stacks at once in N worker processes, forked after every layer is loaded: the
 * layers are read-only from then on, so fork's copy-on-write shares them without a copy, each
 * worker has its own bst_ctx and stdio for free, and a worker that crashes or is killed for memory
 * takes down only the stack it held (the parent reports that line; the others go on).  Threads
 * would share the same memory but need a context, an output buffer and a crash boundary each
 * made by hand.  Each worker sets OpenBLAS to max(1, cores / N) threads (cores: the CPUs this
 * process may run on, sched_getaffinity), so that N workers keep the cores busy without
 * oversubscribing them; -j 1 runs in the process through the same code and leaves OpenBLAS as
 * configured; the tree writer's threads (bst_ctx_set_threads) get the same share.  Workers claim lines in file order from a counter in shared memory
 * (MAP_SHARED | MAP_ANONYMOUS) and leave each stack's result there (state, seconds, peak memory,
 * T and R at normal incidence per channel, warnings); the parent draws the progress line on a
 * terminal and writes --summary from them once every worker has ended.
 *
 * --resume: every output's metadata holds "batch-key: fnv1a64 HEX", a hash of the line's words,
 * of the size and modification time of each layer that names a file, and of the command as
 * recorded in the metadata (less -j, --summary and --resume, which do not change a result).  A
 * stack is skipped when its output holds the key it would be written with and ends with the XML
 * writer's last line (a file cut short does not).  Outputs are written atomically, so a killed
 * batch leaves each of them whole or absent. */
#include <config.h>

#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <inttypes.h>
#include <math.h>
#include <sched.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "batch.h"
#include "interrupt.h"

#ifdef HAVE_OPENBLAS_SET_NUM_THREADS
void openblas_set_num_threads(int num_threads); /* OpenBLAS's cblas.h */
#endif

static const char help[] =
    "Usage: bsdfstack batch [-k K | --klems[=full|half|quarter]] [--only Tf,Rf,Tb,Rb]\n"
    "                       [--channels NAMES] [--precision double|single] [--drop-tol X]\n"
    "                       [--reduce PCT | --no-reduce] [--reduce-tol T] [--dense]\n"
    "                       [--per-channel] [--rank3 exact|native]\n"
    "                       [--spectral-tol X] [--glass-rule average|centre] [--strict]\n"
    "                       [--max-memory SIZE] [-j N] [--summary FILE] [--resume] FILE\n"
    "Combines many stacks, one per line of FILE ('-' = standard input):\n"
    "  OUT LAYER LAYER...\n"
    "the output file, then the layers, exterior first, as `bsdfstack combine` takes them\n"
    "(FILE.xml, glass:SPEC, a trailing ^ for a reversed layer); words are separated by blanks, so\n"
    "paths must not contain any.  Blank lines and lines starting with # are skipped; relative\n"
    "paths are taken from the current directory.  Every distinct layer is loaded once, onto one\n"
    "basis for the whole batch (-k, --klems; else the finest tensor-tree order among the batch's\n"
    "files; with no tree the Klems basis of the first Klems file; with panes only k = 5), and\n"
    "kept until the end.  The whole file and every layer are checked before the first stack is\n"
    "combined, and so are the outputs: two that name one file however spelt (a.xml, ./a.xml, a\n"
    "link to it), or --summary or an output naming another output or FILE, are an error.  A\n"
    "stack that fails is reported with its line number and the others go on; the\n"
    "exit status is then 1.  Each system is written as `combine -o OUT` writes it (a regular file\n"
    "atomically; its metadata names the layers, the batch line and its batch-key), and one line\n"
    "per stack on standard output gives OUT, the front T and R at normal incidence of the first\n"
    "channel (- where not computed) and the seconds taken, or OUT and 'skipped' (--resume).\n"
    "On a terminal, standard error shows stacks done, failed, time elapsed and left.\n"
    "\n"
    "  -j, --jobs N      combine N stacks at once, in N processes sharing the loaded layers,\n"
    "                    each with max(1, cores / N) OpenBLAS threads (default 1); standard\n"
    "                    output's lines then come in the order the stacks end; a signal to\n"
    "                    the batch (INT, TERM, HUP) is passed on, and workers die with it\n"
    "      --summary FILE  one tab-separated row per stack: line, output, status (ok, failed,\n"
    "                    skipped), seconds, peak_rss_kib (the peak resident memory of the process\n"
    "                    that combined it, so far), T_normal and R_normal (front, at normal\n"
    "                    incidence, CHANNEL=VALUE per channel), warnings\n"
    "      --resume      skip a stack whose OUT is a regular file, complete, with the batch-key of\n"
    "                    the same line, layer files (size, time) and options; first remove\n"
    "                    the temporaries (OUT.tmpXXXXXX) a killed writer left\n"
    "\n"
    "Other options: as for `bsdfstack combine`.\n"
    "Over the ranks of an MPI job (bsdfstack-mpi, built when configure finds MPI):\n"
    "  mpirun -n N bsdfstack-mpi [these options but -j] FILE   (bsdfstack-mpi --help)\n";

/* Read FILE ('-' = standard input) into stack lines and distinct layer specs.  CLI_OK or one
 * error line. */
static int parse_file(const char *sub, const char *path, struct batch_file *bf)
{
    memset(bf, 0, sizeof *bf);
    FILE *fp = strcmp(path, "-") == 0 ? stdin : fopen(path, "r");
    if (!fp)
        return cli_fail(sub, "%s: cannot open: %s", path, strerror(errno));
    char *err = NULL;
    int rc = CLI_OK;
    if (batch_file_parse(fp, path, bf, &err) < 0)
        rc = cli_fail(sub, "%s", err ? err : "out of memory");
    free(err);
    if (fp != stdin)
        fclose(fp);
    return rc;
}

/* The results, in memory the workers share with the parent. */
struct shared {
    atomic_size_t next;                       /* the next line to claim */
    atomic_size_t done, failed, skipped;      /* counts, for the progress line */
    struct stack_result res[];
};

double batch_since(const struct timespec *t0)
{
    struct timespec t1;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    return (double)(t1.tv_sec - t0->tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0->tv_nsec);
}

/* FNV-1a, 64 bits: a stable hash (not a secure one; resume guards against mistakes, not forgery). */
static uint64_t fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 1099511628211u;
    return h;
}

/* The batch-key of line sl: its words, each layer file's size and modification time (a spec less
 * its glass: prefix and trailing ^ that names a file), and the recorded command. */
static uint64_t line_key(const struct batch *b, const struct batch_line *sl)
{
    uint64_t h = 14695981039346656037u;
    h = fnv1a(h, sl->out, strlen(sl->out) + 1);
    for (size_t i = 0; i < sl->n; i++) {
        const char *spec = b->specs[sl->layer[i]];
        h = fnv1a(h, spec, strlen(spec) + 1);
        if (strncmp(spec, "glass:", 6) == 0)
            spec += 6;
        char file[4096];
        size_t len = cli_spec_reversed(spec, NULL);
        struct stat st;
        if (len < sizeof file) {
            memcpy(file, spec, len);
            file[len] = '\0';
            char *model = strstr(file, ",model="); /* a pane's model option follows its file */
            if (model && stat(file, &st) != 0)
                *model = '\0';
            if (stat(file, &st) == 0) {
                int64_t v[3] = {(int64_t)st.st_size, (int64_t)st.st_mtim.tv_sec, (int64_t)st.st_mtim.tv_nsec};
                h = fnv1a(h, v, sizeof v);
            }
        }
    }
    for (int i = 0; i < b->argc; i++)
        h = fnv1a(h, b->argv[i], strlen(b->argv[i]) + 1);
    return h;
}

void batch_key(const struct batch *b, const struct batch_line *sl, char *key, size_t size)
{
    snprintf(key, size, "batch-key: fnv1a64 %016" PRIx64, line_key(b, sl));
}

/* Whether path is complete and holds key_text in its header (where the writer puts the
 * metadata: the first 64 KiB). */
int batch_up_to_date(const char *path, const char *key_text)
{
    static const char last[] = "</WindowElement>\n";
    /* only a regular file can be complete: a FIFO, a terminal or another device is written
     * again, and is never read here (opening a FIFO to read waited for a writer for ever) */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    struct stat st;
    if (fd < 0)
        return 0;
    FILE *fp = fstat(fd, &st) == 0 && S_ISREG(st.st_mode) ? fdopen(fd, "rb") : NULL;
    if (!fp) {
        close(fd);
        return 0;
    }
    char *head = malloc(65536), tail[sizeof last];
    size_t n = head ? fread(head, 1, 65535, fp) : 0;
    int ok = 0;
    if (head) {
        head[n] = '\0';
        ok = strstr(head, key_text) != NULL && fseek(fp, -(long)(sizeof last - 1), SEEK_END) == 0 &&
             fread(tail, 1, sizeof last - 1, fp) == sizeof last - 1 &&
             memcmp(tail, last, sizeof last - 1) == 0;
    }
    free(head);
    fclose(fp);
    return ok;
}

/* Front T and R at normal incidence, per channel of sys, into r. */
static void normal_tr(bst_ctx *ctx, const bst_basis *basis, const bst_layer *sys, struct stack_result *r)
{
    size_t n = bst_basis_size(basis), nch = bst_layer_nchannels(sys);
    double normal[3] = {1e-9, 1e-9, 1.0}, *h = malloc(n * sizeof *h);
    size_t j = bst_basis_patch(basis, normal);
    r->more = nch > SUMMARY_CHANNELS;
    r->nch = (int)(r->more ? SUMMARY_CHANNELS : nch);
    for (int c = 0; c < r->nch; c++) {
        snprintf(r->channel[c], sizeof r->channel[c], "%s", bst_layer_channel(sys, (size_t)c));
        r->t[c] = r->r[c] = NAN;
        if (h && bst_layer_get(sys, (size_t)c, BST_TF) &&
            bst_layer_hemispherical(ctx, sys, (size_t)c, BST_TF, h) >= 0)
            r->t[c] = h[j];
        if (h && bst_layer_get(sys, (size_t)c, BST_RF) &&
            bst_layer_hemispherical(ctx, sys, (size_t)c, BST_RF, h) >= 0)
            r->r[c] = h[j];
    }
    bst_ctx_clear(ctx);
    free(h);
}

void batch_print_result(const struct batch *b, const struct batch_line *sl,
                        const struct stack_result *r, int state)
{
    if (state == ST_SKIPPED) {
        printf("%s\tskipped\n", sl->out);
    } else {
        char t[32] = "-", rr[32] = "-";
        if (r->nch > 0 && !isnan(r->t[0]))
            snprintf(t, sizeof t, "%.4f", r->t[0]);
        if (r->nch > 0 && !isnan(r->r[0]))
            snprintf(rr, sizeof rr, "%.4f", r->r[0]);
        printf("%s\tT %s\tR %s\t%.2f s\n", sl->out, t, rr, r->seconds);
    }
    /* the stack itself is written: a lost summary line fails the run (main), not the stack */
    if (fflush(stdout) != 0)
        cli_stdout_failed(b->sub, errno);
}

int batch_run_stack(bst_ctx *ctx, const struct batch *b, const struct batch_line *sl,
                     struct stack_result *r)
{
    const char *sub = b->sub;
    char where[512], key[64];
    struct timespec t0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    snprintf(where, sizeof where, "%s:%zu", b->path, sl->lineno);
    batch_key(b, sl, key, sizeof key);
    if (b->resume && batch_up_to_date(sl->out, key)) {
        if (!b->quiet)
            batch_print_result(b, sl, r, ST_SKIPPED);
        return ST_SKIPPED;
    }
    struct cli_layers view = {.n = sl->n, .basis = b->all.basis};
    view.layers = malloc(sl->n * sizeof *view.layers);
    view.panes = malloc(sl->n * sizeof *view.panes);
    size_t len = 128 + strlen(b->path) + strlen(key);
    for (size_t i = 0; i < sl->n; i++)
        len += strlen(b->specs[sl->layer[i]]) + 2;
    view.description = malloc(len);
    bst_layer *sys = NULL;
    int rc = view.layers && view.panes && view.description ? CLI_OK : cli_fail(sub, "out of memory");
    if (rc == CLI_OK) {
        snprintf(view.description, len, "layers (exterior first):");
        for (size_t i = 0; i < sl->n; i++) {
            strcat(view.description, i ? ", " : " ");
            strcat(view.description, b->specs[sl->layer[i]]);
            view.layers[i] = b->all.layers[sl->layer[i]];
            view.panes[i] = b->all.panes[sl->layer[i]];
            view.npanes += view.panes[i] != NULL;
        }
    }
    if (rc == CLI_OK)
        rc = cli_note_panes(sub, &view.description, &b->all, sl->n, sl->layer, b->specs);
    if (rc == CLI_OK) {
        size_t used = strlen(view.description), room = used + strlen(b->path) + strlen(key) + 64;
        char *d = realloc(view.description, room);
        if (d)
            snprintf(d + used, room - used, "\nbatch: %s line %zu\n%s", b->path, sl->lineno, key);
        view.description = d ? d : view.description;
        rc = d ? CLI_OK : cli_fail(sub, "out of memory");
    }
    struct cli_run_opts ro = {.warning = r->warnings, .warning_size = sizeof r->warnings};
    if (rc == CLI_OK)
        rc = cli_combine_run(ctx, sub, where, &view, &b->args, &ro, &sys);
    if (rc == CLI_OK)
        rc = cli_write_layer(ctx, sub, sys, sl->out, &b->args.reduce, b->argc, b->argv, &view);
    if (rc == CLI_OK)
        normal_tr(ctx, b->all.basis, sys, r);
    r->seconds = batch_since(&t0);
    if (rc == CLI_OK && !b->quiet)
        batch_print_result(b, sl, r, ST_OK);
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) == 0)
        r->peak_kib = ru.ru_maxrss; /* KiB on Linux */
    bst_layer_free(sys);
    free(view.layers), free(view.panes), free(view.description);
    return rc == CLI_OK ? ST_OK : ST_FAILED;
}

/* "1h02m", "3m05s", "12s". */
static void duration(char *buf, size_t size, double s)
{
    long t = (long)(s + 0.5);
    if (t >= 3600)
        snprintf(buf, size, "%ldh%02ldm", t / 3600, t / 60 % 60);
    else if (t >= 60)
        snprintf(buf, size, "%ldm%02lds", t / 60, t % 60);
    else
        snprintf(buf, size, "%lds", t);
}

/* The progress line on stderr (a terminal): done, failed, elapsed, and the time left at the rate
 * of the stacks combined so far (skipped ones take none). */
void batch_progress(const struct batch *b, size_t done, size_t failed, size_t skipped, int last)
{
    size_t computed = done - skipped;
    double elapsed = batch_since(&b->start);
    char e[32], left[32] = "?";
    duration(e, sizeof e, elapsed);
    if (computed > 0)
        duration(left, sizeof left, elapsed / (double)computed * (double)(b->nlines - done));
    if (last)
        fputs("\r\033[K", stderr);
    else
        fprintf(stderr, "\r\033[Kbatch: %zu of %zu stacks done, %zu failed, %s elapsed, ~%s left", done,
                b->nlines, failed, e, left);
    fflush(stderr);
}

static void progress(const struct batch *b, const struct shared *sh, int last)
{
    batch_progress(b, atomic_load(&sh->done), atomic_load(&sh->failed), atomic_load(&sh->skipped), last);
}

/* Claim lines from sh->next and combine them until none is left. */
static void work(bst_ctx *ctx, const struct batch *b, struct shared *sh)
{
    for (;;) {
        size_t i = atomic_fetch_add(&sh->next, 1);
        if (i >= b->nlines)
            break;
        struct stack_result *r = &sh->res[i];
        r->worker = getpid();
        atomic_store(&r->state, ST_RUNNING);
        int st = batch_run_stack(ctx, b, &b->lines[i], r);
        if (st == ST_FAILED)
            bst_ctx_clear(ctx), atomic_fetch_add(&sh->failed, 1);
        if (st == ST_SKIPPED)
            atomic_fetch_add(&sh->skipped, 1);
        atomic_store(&r->state, st);
        atomic_fetch_add(&sh->done, 1);
        if (b->progress)
            progress(b, sh, 0);
    }
}

int batch_clean_temporaries(bst_ctx *ctx, const struct batch *b, const struct batch_line *lines,
                            size_t n)
{
    const char **paths = malloc((n ? n : 1) * sizeof *paths);
    if (!paths)
        return cli_fail(b->sub, "out of memory");
    for (size_t i = 0; i < n; i++)
        paths[i] = lines[i].out;
    size_t removed = 0;
    int rc = bst_output_clean(ctx, n, paths, &removed) < 0 ? cli_fail_ctx(b->sub, NULL, ctx) : CLI_OK;
    free(paths);
    if (removed)
        fprintf(stderr, "bsdfstack %s: removed %zu temporar%s that a killed writer left beside %s\n",
                b->sub, removed, removed == 1 ? "y" : "ies", n == 1 ? lines[0].out : "the outputs");
    return rc;
}

/* The CPUs this process may run on. */
int batch_cores(void)
{
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0)
        return CPU_COUNT(&set);
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}

/* Run the batch in `jobs` workers (the process itself for 1); stacks whose worker ended before
 * finishing them are reported and marked failed. */
static void run_all(bst_ctx *ctx, struct batch *b, struct shared *sh, int jobs)
{
    if (jobs <= 1) {
        work(ctx, b, sh);
        return;
    }
    pid_t *pid = calloc((size_t)jobs, sizeof *pid), parent = getpid();
    static volatile int started; /* read by the signal handler, which passes a signal on */
    started = 0;
    cli_interrupt_workers(pid, &started);
    fflush(NULL); /* nothing buffered is written twice */
    while (pid && started < jobs) {
        pid_t p = fork();
        if (p < 0) {
            fprintf(stderr, "bsdfstack %s: warning: fork: %s; going on with %d worker%s\n", b->sub,
                    strerror(errno), started, started == 1 ? "" : "s");
            break;
        }
        if (p == 0) {
            cli_interrupt_worker_started(parent); /* dies with the batch, even of SIGKILL */
#ifdef HAVE_OPENBLAS_SET_NUM_THREADS
            /* OPENBLAS_NUM_THREADS, when set, wins (as under bsdfstack-mpi): the last bit of some
               products follows the thread count, so equal counts give byte-identical files */
            int per = batch_cores() / jobs;
            const char *env = getenv("OPENBLAS_NUM_THREADS");
            if (!env || !*env)
                openblas_set_num_threads(per > 1 ? per : 1);
#endif
            /* the tree writer's threads: the same share (any count writes the same bytes) */
            bst_ctx_set_threads(ctx, batch_cores() / jobs > 1 ? batch_cores() / jobs : 1);
            work(ctx, b, sh);
            fflush(stdout);
            _exit(0);
        }
        pid[started++] = p;
    }
    if (started == 0) {
        cli_interrupt_workers(NULL, NULL);
        b->progress = isatty(STDERR_FILENO);
        work(ctx, b, sh);
        free(pid);
        return;
    }
    int tty = isatty(STDERR_FILENO);
    for (int left = started; left > 0;) {
        int status;
        pid_t p = waitpid(-1, &status, tty ? WNOHANG : 0);
        if (p < 0 && errno == EINTR)
            continue;
        if (p < 0)
            break;
        if (p == 0) {
            progress(b, sh, 0);
            struct timespec pause = {0, 200000000};
            nanosleep(&pause, NULL);
            continue;
        }
        left--;
        for (int w = 0; w < started; w++)
            if (pid[w] == p)
                pid[w] = 0; /* reaped: its number may be another process's now */
        for (size_t i = 0; i < b->nlines; i++) {
            struct stack_result *r = &sh->res[i];
            if (r->worker != p || atomic_load(&r->state) != ST_RUNNING)
                continue;
            char how[64];
            if (WIFSIGNALED(status))
                snprintf(how, sizeof how, "signal %d (%s)", WTERMSIG(status), strsignal(WTERMSIG(status)));
            else
                snprintf(how, sizeof how, "exit status %d", WEXITSTATUS(status));
            cli_fail(b->sub, "%s:%zu: the worker combining this stack ended by %s", b->path,
                     b->lines[i].lineno, how);
            batch_clean_temporaries(ctx, b, &b->lines[i], 1); /* killed: it may have left one */
            atomic_store(&r->state, ST_FAILED);
            atomic_fetch_add(&sh->failed, 1);
            atomic_fetch_add(&sh->done, 1);
        }
    }
    if (tty)
        progress(b, sh, 1);
    cli_interrupt_workers(NULL, NULL);
    free(pid);
}

/* The --summary table (a header row, then one row per stack in file order). */
int batch_write_summary(struct cli_out *o, const struct batch *b, const struct stack_result *res)
{
    static const char *const names[] = {"pending", "running", "ok", "failed", "skipped"};
    FILE *fp = o->fp;
    fputs("line\toutput\tstatus\tseconds\tpeak_rss_kib\tT_normal\tR_normal\twarnings\n", fp);
    for (size_t i = 0; i < b->nlines; i++) {
        const struct stack_result *r = &res[i];
        int st = atomic_load(&r->state);
        fprintf(fp, "%zu\t%s\t%s\t", b->lines[i].lineno, b->lines[i].out, names[st]);
        if (st == ST_OK || st == ST_FAILED)
            fprintf(fp, "%.3f\t%ld\t", r->seconds, r->peak_kib);
        else
            fputs("-\t-\t", fp);
        for (int side = 0; side < 2; side++) {
            const double *v = side ? r->r : r->t;
            for (int c = 0; c < r->nch; c++) {
                fprintf(fp, "%s%s=", c ? "," : "", r->channel[c]);
                fprintf(fp, isnan(v[c]) ? "-" : "%.6f", v[c]);
            }
            fputs(r->nch == 0 ? "-\t" : r->more ? ",...\t" : "\t", fp);
        }
        /* one field: the warning's tabs and newlines become blanks */
        char w[sizeof r->warnings];
        snprintf(w, sizeof w, "%s", r->warnings[0] ? r->warnings : "-");
        for (char *p = w; *p; p++)
            if (*p == '\t' || *p == '\n' || *p == '\r')
                *p = ' ';
        fprintf(fp, "%s\n", w);
    }
    return cli_out_commit(o, b->sub);
}

/* argv less the options that do not change any output (-j, --jobs, --summary, --resume), for the
 * metadata and the batch-key; pointers into argv, in a new array. */
static char **recorded_argv(int argc, char **argv, int *n)
{
    char **v = malloc(((size_t)argc + 1) * sizeof *v);
    if (!v)
        return NULL;
    *n = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--") == 0) {
            while (i < argc)
                v[(*n)++] = argv[i++];
            break;
        }
        if (strcmp(a, "-j") == 0 || strcmp(a, "--jobs") == 0 || strcmp(a, "--summary") == 0) {
            i++; /* and its value */
            continue;
        }
        if ((strncmp(a, "-j", 2) == 0) || strncmp(a, "--jobs=", 7) == 0 ||
            strncmp(a, "--summary=", 10) == 0 || strcmp(a, "--resume") == 0)
            continue;
        v[(*n)++] = argv[i];
    }
    v[*n] = NULL;
    return v;
}

int batch_report_failures(const struct batch *b, const struct stack_result *res, size_t failed)
{
    char lines[160] = "";
    size_t len = 0, shown = 0;
    for (size_t i = 0; i < b->nlines && len < sizeof lines; i++) {
        if (atomic_load(&res[i].state) != ST_FAILED)
            continue;
        if (shown == 8 || len + 24 >= sizeof lines) {
            len += (size_t)snprintf(lines + len, sizeof lines - len, ", ...");
            break;
        }
        len += (size_t)snprintf(lines + len, sizeof lines - len, "%s %zu", shown ? "," : failed == 1 ? "line" : "lines",
                                b->lines[i].lineno);
        shown++;
    }
    return cli_fail(b->sub, "%s: %zu of %zu stacks failed (%s; reported above)", b->path, failed,
                    b->nlines, lines);
}

int batch_options(int argc, char **argv, struct batch *b, int *jobs, const char **summary,
                  const char *mpi_help)
{
    enum { O_HELP = CLI_O_OWN, O_SUMMARY, O_RESUME };
    static const struct option longopts[] = {CLI_STACK_LONGOPTS,
                                             {"jobs", required_argument, NULL, 'j'},
                                             {"summary", required_argument, NULL, O_SUMMARY},
                                             {"resume", no_argument, NULL, O_RESUME},
                                             {"help", no_argument, NULL, O_HELP},
                                             {NULL, 0, NULL, 0}};
    const char *sub = b->sub;
    cli_stack_args_init(&b->args);
    /* before getopt permutes argv */
    if (!(b->argv = recorded_argv(argc, argv, &b->argc)))
        return cli_fail(sub, "out of memory");
    *summary = NULL;
    *jobs = 1;
    int c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":k:hj:", longopts, NULL)) != -1) {
        int shared = cli_stack_option(sub, c, optarg, &b->args);
        if (shared == CLI_USAGE)
            return CLI_USAGE;
        if (shared == CLI_OK)
            continue;
        switch (c) {
        case 'j':
            if (mpi_help)
                return cli_usage(sub, "-j %s: under MPI the ranks (mpirun -n N) combine the stacks at once", optarg);
            if (cli_parse_int(optarg, jobs) != 0 || *jobs < 1)
                return cli_usage(sub, "-j %s: give a whole number of stacks at once, 1 or more", optarg);
            break;
        case O_SUMMARY:
            if (cli_parse_path(sub, "--summary", optarg) != CLI_OK)
                return CLI_USAGE;
            *summary = optarg;
            break;
        case O_RESUME: b->resume = 1; break;
        case 'h':
        case O_HELP: fputs(mpi_help ? mpi_help : help, stdout); return -1;
        case ':': return cli_usage(sub, "option %s needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    if (argc - optind != 1)
        return cli_usage(sub, argc - optind < 1 ? "no batch file given" : "one batch file expected");
    b->path = argv[optind];
    if (cli_parse_path(sub, "the batch file", b->path) != CLI_OK)
        return CLI_USAGE;
    char early[64];
    const char *epoch_date; /* a malformed SOURCE_DATE_EPOCH fails before the first stack */
    return cli_source_date(sub, early, sizeof early, &epoch_date);
}

/* One file the batch writes or reads, for batch_check_outputs: its key and who names it. */
struct named_file {
    char *key;
    size_t who; /* a line's index, or one of: */
};
#define WHO_SUMMARY ((size_t)-1)
#define WHO_BATCH ((size_t)-2)

static int by_key(const void *a, const void *b)
{
    const struct named_file *x = a, *y = b;
    int c = strcmp(x->key, y->key);
    return c ? c : x->who < y->who ? -1 : x->who > y->who; /* lines first, in file order */
}

int batch_check_outputs(const char *sub, const char *path, const struct batch_file *bf,
                        const char *summary)
{
    size_t n = 0;
    struct named_file *f = malloc((bf->nlines + 2) * sizeof *f);
    int rc = f ? CLI_OK : cli_fail(sub, "out of memory");
    for (size_t i = 0; rc == CLI_OK && i < bf->nlines + 2; i++) {
        size_t who = i < bf->nlines ? i : i == bf->nlines ? WHO_SUMMARY : WHO_BATCH;
        const char *p = who == WHO_SUMMARY ? summary : who == WHO_BATCH ? path : bf->lines[i].out;
        if (!p || (who == WHO_BATCH && strcmp(p, "-") == 0)) /* no summary; the batch on stdin */
            continue;
        if (!(f[n].key = cli_out_key(p)))
            rc = cli_fail(sub, "out of memory");
        else
            f[n++].who = who;
    }
    if (rc == CLI_OK)
        qsort(f, n, sizeof *f, by_key);
    /* of the pairs that name one file, the one whose second name comes first in the file */
    size_t first = n;
    for (size_t i = 1; rc == CLI_OK && i < n; i++)
        if (strcmp(f[i - 1].key, f[i].key) == 0 && (first == n || f[i].who < f[first].who))
            first = i;
    if (rc == CLI_OK && first < n) {
        const struct named_file *a = &f[first - 1], *b = &f[first];
        if (a->who == WHO_BATCH) /* then b is the summary: who sorts WHO_BATCH before it */
            rc = cli_fail(sub, "--summary %s is the batch file %s", summary, path);
        else if (b->who == WHO_BATCH)
            rc = cli_fail(sub, "%s:%zu: the output '%s' is the batch file itself", path,
                          bf->lines[a->who].lineno, bf->lines[a->who].out);
        else if (b->who == WHO_SUMMARY)
            rc = cli_fail(sub, "%s:%zu: the output '%s' is the --summary file %s", path,
                          bf->lines[a->who].lineno, bf->lines[a->who].out, summary);
        else
            rc = cli_fail(sub, "%s:%zu: '%s' is the file line %zu writes already ('%s')", path,
                          bf->lines[b->who].lineno, bf->lines[b->who].out, bf->lines[a->who].lineno,
                          bf->lines[a->who].out);
    }
    for (size_t i = 0; i < n; i++)
        free(f[i].key);
    free(f);
    return rc;
}

int cmd_batch(int argc, char **argv)
{
    const char *sub = "batch";
    struct batch b;
    memset(&b, 0, sizeof b);
    b.sub = sub;
    const char *summary = NULL;
    int jobs = 1;
    int rc = batch_options(argc, argv, &b, &jobs, &summary, NULL);
    if (rc != CLI_OK)
        return free(b.argv), rc < 0 ? CLI_OK : rc;
    struct batch_file bf;
    rc = parse_file(sub, b.path, &bf);
    if (rc == CLI_OK)
        rc = batch_check_outputs(sub, b.path, &bf, summary);
    b.lines = bf.lines, b.nlines = bf.nlines, b.specs = bf.specs, b.nspecs = bf.nspecs;
    bst_ctx *ctx = rc == CLI_OK ? cli_ctx_new(sub) : NULL;
    if (rc == CLI_OK && !ctx)
        rc = CLI_FAIL;
    b.args.basis.combining = 1;
    b.args.basis.work = b.args.so.precision;
    /* a layer's messages name the line that first gives it */
    char **places = rc == CLI_OK ? batch_file_places(&bf, b.path) : NULL;
    if (rc == CLI_OK && !places)
        rc = cli_fail(sub, "out of memory");
    b.args.basis.where = places;
    if (rc == CLI_OK)
        rc = cli_layers_load(&b.all, ctx, sub, b.nspecs, b.specs, &b.args.basis, b.args.channels, 0,
                             b.args.so.precision);
    b.args.basis.where = NULL;
    free(places);
    if (rc == CLI_OK && b.resume) /* what a killed run left behind */
        rc = batch_clean_temporaries(ctx, &b, b.lines, b.nlines);
    struct cli_out sum;
    memset(&sum, 0, sizeof sum);
    if (rc == CLI_OK && summary)
        rc = cli_out_open(&sum, sub, summary);
    size_t shsize = sizeof(struct shared) + b.nlines * sizeof(struct stack_result);
    struct shared *sh = MAP_FAILED;
    if (rc == CLI_OK) {
        sh = mmap(NULL, shsize, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
        if (sh == MAP_FAILED)
            rc = cli_fail(sub, "shared memory for %zu results: %s", b.nlines, strerror(errno));
    }
    if (rc == CLI_OK) {
        /* the batch's own progress line replaces the per-stack bar, which workers would mix */
        bst_ctx_set_progress(ctx, NULL, NULL);
        b.progress = jobs == 1 && isatty(STDERR_FILENO);
        clock_gettime(CLOCK_MONOTONIC, &b.start);
        run_all(ctx, &b, sh, jobs < (int)b.nlines ? jobs : (int)b.nlines);
        if (b.progress)
            progress(&b, sh, 1);
        size_t failed = atomic_load(&sh->failed);
        if (summary && batch_write_summary(&sum, &b, sh->res) != CLI_OK)
            rc = CLI_FAIL;
        if (failed)
            rc = batch_report_failures(&b, sh->res, failed);
    }
    cli_out_abort(&sum);
    if (sh != MAP_FAILED)
        munmap(sh, shsize);
    if (b.all.layers)
        cli_layers_free(&b.all);
    batch_file_free(&bf);
    free(b.argv);
    bst_ctx_free(ctx);
    return rc;
}
