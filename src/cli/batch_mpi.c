/* batch_mpi.c - bsdfstack-mpi: `bsdfstack batch` over the ranks of an MPI job,
 *   mpirun -n N bsdfstack-mpi [batch options but -j] FILE
 * for batches larger than one machine.  It is a program of its own, built only when configure
 * finds MPI, so that `bsdfstack` never loads an MPI library (nor needs mpirun's environment);
 * the batch code itself is shared (batch.h), and each output is written, byte for byte, as
 * `bsdfstack batch` writes it (the command in the metadata reads "bsdfstack batch ...").
 *
 * Rank 0 parses the options and the file, checks the file and every layer (each file read, the
 * basis chosen, the memory guard, each pane made: cli_layers_check), sends the file's text and
 * the chosen basis to every rank, leaves out what --resume may skip, and hands out the remaining
 * stacks one at a time, the most expensive first (cost_of below), to whichever rank asks next.
 * It combines none itself unless it is alone (mpirun -n 1), and waits by polling with short
 * sleeps, so that it takes no core from the ranks that work.  A working rank loads a layer the
 * first time one of its stacks needs it and keeps it for its later stacks; a stack that fails is
 * reported by its rank with the line number, and the others go on.  Results (those of
 * --summary) come back to rank 0, which prints the standard output line of each stack as it
 * ends and writes the summary.
 *
 * OpenBLAS threads per rank: max(1, cores / W), cores being the CPUs the rank may run on and W
 * the ranks that combine stacks on its node (MPI_Comm_split_type SHARED; rank 0 does not count
 * when other ranks work); OPENBLAS_NUM_THREADS, when set, wins.  Byte-identical outputs need the
 * same thread count as the run compared with: OpenBLAS splits a product by its threads, and the
 * last bit of some sums follows the split (measured: Klems full, 1 against 2 threads; not at
 * k <= 3, whose matrices stay on one thread).
 *
 * Results travel as bytes of struct stack_result: every rank runs this program on one kind of
 * machine.  A rank that dies ends the whole job (MPI's default); --resume then finishes it. */
#include <config.h>

#include <errno.h>
#include <math.h>
#include <mpi.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "batch.h"
#include "interrupt.h"

#ifdef HAVE_OPENBLAS_SET_NUM_THREADS
void openblas_set_num_threads(int num_threads); /* OpenBLAS's cblas.h */
#endif

static const char help[] =
    "Usage: mpirun -n N bsdfstack-mpi [-k K | --klems[=full|half|quarter]] [--only Tf,Rf,Tb,Rb]\n"
    "                       [--channels NAMES] [--precision double|single] [--drop-tol X]\n"
    "                       [--reduce PCT | --no-reduce] [--reduce-tol T] [--dense]\n"
    "                       [--per-channel] [--rank3 exact|native]\n"
    "                       [--spectral-tol X] [--glass-rule average|centre] [--strict]\n"
    "                       [--max-memory SIZE] [--summary FILE] [--resume] FILE\n"
    "`bsdfstack batch` over the N ranks of an MPI job: the same file, options and outputs (byte\n"
    "for byte), without -j.  Rank 0 checks the file and every layer, then hands out the stacks,\n"
    "the most expensive first (cost: channels x the sum over the stack's steps of N^3, N^2 or N\n"
    "for a dense, sparse or diagonal partial system, N patches), one at a time to the rank that\n"
    "asks; it combines none itself unless alone.  Each rank loads the layers its stacks need when\n"
    "first needed and keeps them, with max(1, cores / ranks working on its node) OpenBLAS\n"
    "threads.  Standard output's lines (rank 0) come in the order the stacks end; --summary is\n"
    "written by rank 0, in file order.  See `bsdfstack batch --help` and bsdfstack-batch(1).\n";

enum { TAG_TASK = 1, TAG_RESULT = 2 };

/* A result on its way to rank 0. */
struct result_msg {
    long line; /* index into the batch's lines */
    int state; /* ST_OK or ST_FAILED */
    struct stack_result r;
};

/* Wait for req without spinning a core: OpenMPI's blocking calls poll busily, which would take a
 * core from the working ranks on a small machine.  The pause grows from 50 us to 1 ms (a
 * thousand wake-ups a second cost well under 1% of a core). */
static void wait_quietly(MPI_Request *req, MPI_Status *status)
{
    long ns = 50000;
    for (;;) {
        int done = 0;
        MPI_Test(req, &done, status);
        if (done)
            return;
        struct timespec pause = {0, ns};
        nanosleep(&pause, NULL);
        if (ns < 1000000)
            ns = ns * 2 < 1000000 ? ns * 2 : 1000000;
    }
}

/* A rank's cost estimate of line sl, by the plan's work model (bst_plan_work): the layers'
 * structures over N patches.  Only the order matters. */
static double cost_of(const struct batch_line *sl, const bst_structure *structure, size_t N)
{
    bst_structure *s = malloc((sl->n + 1) * sizeof *s);
    if (!s)
        return 0.0; /* dealt out last: no harm */
    for (size_t i = 0; i < sl->n; i++)
        s[i] = structure[sl->layer[i]];
    double cost = bst_plan_work(sl->n, s, N, NULL);
    free(s);
    return cost;
}

struct todo {
    size_t line;
    double cost;
};
static int by_cost(const void *pa, const void *pb)
{
    const struct todo *a = pa, *b = pb;
    if (a->cost != b->cost)
        return a->cost > b->cost ? -1 : 1;
    return a->line < b->line ? -1 : a->line > b->line;
}

/* Load what line i needs that this rank does not hold yet, then combine it; ST_OK or ST_FAILED
 * (reported, with the line). */
static int run_line(bst_ctx *ctx, struct batch *b, size_t i, struct stack_result *r)
{
    const struct batch_line *sl = &b->lines[i];
    memset(r, 0, sizeof *r);
    r->worker = getpid();
    for (size_t j = 0; j < sl->n; j++) {
        size_t k = sl->layer[j];
        if (b->all.layers[k])
            continue;
        char what[4200];
        snprintf(what, sizeof what, "%s:%zu: %s", b->path, sl->lineno, b->specs[k]);
        if (cli_layer_load(ctx, b->sub, what, b->specs[k], b->all.basis, &b->args.basis,
                           b->args.channels, b->args.so.precision, &b->all.layers[k],
                           &b->all.panes[k], &b->all.notes[k]) != CLI_OK) {
            bst_ctx_clear(ctx);
            return ST_FAILED;
        }
    }
    int st = batch_run_stack(ctx, b, sl, r);
    if (st == ST_FAILED)
        bst_ctx_clear(ctx);
    return st;
}

/* Rank 0's part of the run: the stacks in todo[0..ntodo-1] handed out to ranks 1..size-1, or
 * combined here when alone; results into res, printed as they come. */
static void dispatch(bst_ctx *ctx, struct batch *b, const struct todo *todo, size_t ntodo,
                     struct stack_result *res, int size, size_t *done, size_t *failed, size_t skipped)
{
    int tty = isatty(STDERR_FILENO);
    if (size == 1) {
        for (size_t t = 0; t < ntodo; t++) {
            size_t i = todo[t].line;
            int st = run_line(ctx, b, i, &res[i]);
            atomic_store(&res[i].state, st);
            if (st == ST_OK)
                batch_print_result(b, &b->lines[i], &res[i], st);
            *failed += st == ST_FAILED;
            ++*done;
            if (tty)
                batch_progress(b, *done, *failed, skipped, 0);
        }
        return;
    }
    size_t next = 0;
    int active = 0;
    for (int w = 1; w < size; w++) {
        long task = next < ntodo ? (long)todo[next++].line : -1;
        MPI_Send(&task, 1, MPI_LONG, w, TAG_TASK, MPI_COMM_WORLD);
        active += task >= 0;
    }
    while (active > 0) {
        struct result_msg m;
        MPI_Request req;
        MPI_Status status;
        MPI_Irecv(&m, (int)sizeof m, MPI_BYTE, MPI_ANY_SOURCE, TAG_RESULT, MPI_COMM_WORLD, &req);
        wait_quietly(&req, &status);
        long task = next < ntodo ? (long)todo[next++].line : -1;
        MPI_Send(&task, 1, MPI_LONG, status.MPI_SOURCE, TAG_TASK, MPI_COMM_WORLD);
        active -= task < 0;
        if (m.line < 0 || (size_t)m.line >= b->nlines)
            continue;
        res[m.line] = m.r;
        atomic_store(&res[m.line].state, m.state);
        if (m.state == ST_OK)
            batch_print_result(b, &b->lines[m.line], &res[m.line], ST_OK);
        *failed += m.state == ST_FAILED;
        ++*done;
        if (tty)
            batch_progress(b, *done, *failed, skipped, 0);
    }
}

/* A working rank's part: stacks from rank 0 until it sends -1. */
static void work(bst_ctx *ctx, struct batch *b)
{
    for (;;) {
        long task;
        MPI_Request req;
        MPI_Irecv(&task, 1, MPI_LONG, 0, TAG_TASK, MPI_COMM_WORLD, &req);
        wait_quietly(&req, MPI_STATUS_IGNORE);
        if (task < 0 || (size_t)task >= b->nlines)
            return;
        struct result_msg m;
        memset(&m, 0, sizeof m);
        m.line = task;
        m.state = run_line(ctx, b, (size_t)task, &m.r);
        MPI_Send(&m, (int)sizeof m, MPI_BYTE, 0, TAG_RESULT, MPI_COMM_WORLD);
    }
}

/* The whole of the batch file (or standard input) into a string; NULL after an error line. */
static char *slurp(const char *sub, const char *path, size_t *len)
{
    FILE *fp = strcmp(path, "-") == 0 ? stdin : fopen(path, "rb");
    if (!fp) {
        cli_fail(sub, "%s: cannot open: %s", path, strerror(errno));
        return NULL;
    }
    size_t cap = 4096, n = 0;
    char *text = malloc(cap);
    while (text) {
        n += fread(text + n, 1, cap - n, fp);
        if (n < cap)
            break;
        char *t = realloc(text, 2 * cap);
        if (!t)
            free(text);
        text = t, cap *= 2;
    }
    int err = ferror(fp);
    if (fp != stdin)
        fclose(fp);
    if (!text) {
        cli_fail(sub, "out of memory");
        return NULL;
    }
    if (err) {
        cli_fail(sub, "%s: read error", strcmp(path, "-") == 0 ? "standard input" : path);
        free(text);
        return NULL;
    }
    *len = n;
    return text;
}

/* Parse the file's text into bf, as `bsdfstack batch` parses the file; CLI_OK or one error line
 * (printed when loud). */
static int parse_text(const char *sub, const char *path, char *text, size_t len,
                      struct batch_file *bf, int loud)
{
    static char empty[] = "\n";
    memset(bf, 0, sizeof *bf);
    FILE *fp = len ? fmemopen(text, len, "r") : fmemopen(empty, 1, "r");
    char *err = NULL;
    int rc = CLI_OK;
    if (!fp || batch_file_parse(fp, path, bf, &err) < 0)
        rc = loud ? cli_fail(sub, "%s", err ? err : "out of memory") : CLI_FAIL;
    free(err);
    if (fp)
        fclose(fp);
    return rc;
}

/* The OpenBLAS threads and the writer's: the CPUs this rank may use, shared by the working ranks
 * of its node (rank 0 only dispatches when there are others). */
static void share_cpus(bst_ctx *ctx, int rank, int size)
{
    MPI_Comm node;
    int node_size = 1, has_zero = rank == 0;
    MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank, MPI_INFO_NULL, &node);
    MPI_Comm_size(node, &node_size);
    MPI_Allreduce(MPI_IN_PLACE, &has_zero, 1, MPI_INT, MPI_MAX, node);
    MPI_Comm_free(&node);
    int working = node_size - (has_zero && size > 1), per = batch_cores() / (working > 0 ? working : 1);
    const char *env = getenv("OPENBLAS_NUM_THREADS");
#ifdef HAVE_OPENBLAS_SET_NUM_THREADS
    if (!env || !*env)
        openblas_set_num_threads(per > 1 ? per : 1);
#else
    (void)env;
#endif
    bst_ctx_set_threads(ctx, per > 1 ? per : 1); /* the writer's threads: the same share */
}

/* Rank 0: the lines to do, costliest first, dealt out to the other ranks; the summary and the
 * failures told.  The run's status. */
static int lead(bst_ctx *ctx, struct batch *b, const struct cli_basis_pick *pick,
                const bst_structure *structure, const char *summary, struct cli_out *sum, int size)
{
    const char *sub = b->sub;
    int rc = CLI_OK;
    struct stack_result *res = calloc(b->nlines, sizeof *res);
    struct todo *todo = calloc(b->nlines, sizeof *todo);
    size_t ntodo = 0, done = 0, failed = 0, skipped = 0;
    size_t N = pick->k ? (size_t)1 << (2 * pick->k) : 145;
    if (!res || !todo) {
        rc = cli_fail(sub, "out of memory");
        MPI_Abort(MPI_COMM_WORLD, CLI_FAIL);
    }
    for (size_t i = 0; i < b->nlines; i++) {
        char key[64];
        batch_key(b, &b->lines[i], key, sizeof key);
        if (b->resume && batch_up_to_date(b->lines[i].out, key)) {
            atomic_store(&res[i].state, ST_SKIPPED);
            batch_print_result(b, &b->lines[i], &res[i], ST_SKIPPED);
            skipped++, done++;
            continue;
        }
        todo[ntodo].line = i;
        todo[ntodo++].cost = cost_of(&b->lines[i], structure, N);
    }
    qsort(todo, ntodo, sizeof *todo, by_cost);
    b->resume = 0; /* decided here, once */
    dispatch(ctx, b, todo, ntodo, res, size, &done, &failed, skipped);
    if (isatty(STDERR_FILENO))
        batch_progress(b, done, failed, skipped, 1);
    if (summary && batch_write_summary(sum, b, res) != CLI_OK)
        rc = CLI_FAIL;
    if (failed)
        rc = batch_report_failures(b, res, failed);
    free(res);
    free(todo);
    return rc;
}

/* Everything after MPI_Init; the rank's exit status (rank 0's tells the run). */
static int run(int argc, char **argv, int rank, int size)
{
    const char *sub = "batch";
    struct batch b;
    memset(&b, 0, sizeof b);
    b.sub = sub;
    /* the options as `bsdfstack batch` takes them (and records them: argv[0] is "batch") */
    char **args = malloc(((size_t)argc + 1) * sizeof *args);
    if (!args)
        return cli_fail(sub, "out of memory");
    args[0] = (char *)"batch";
    for (int i = 1; i <= argc; i++)
        args[i] = argv[i];
    const char *summary = NULL;
    int jobs, rc = CLI_OK;
    /* rank 0 parses first, so that a usage error or --help is printed once */
    if (rank == 0)
        rc = batch_options(argc, args, &b, &jobs, &summary, help);
    MPI_Bcast(&rc, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (rc == CLI_OK && rank != 0)
        rc = batch_options(argc, args, &b, &jobs, &summary, help);
    if (rc != CLI_OK) {
        free(b.argv), free(args);
        return rank == 0 ? (rc < 0 ? CLI_OK : rc) : CLI_OK;
    }
    b.args.basis.combining = 1;
    b.args.basis.work = b.args.so.precision;

    /* rank 0 reads and checks the file and every layer; the others get its text and the basis */
    char *text = NULL;
    size_t len = 0;
    struct batch_file bf;
    memset(&bf, 0, sizeof bf);
    struct cli_basis_pick pick = {.file = -1};
    bst_structure *structure = NULL;
    bst_ctx *ctx = cli_ctx_new(sub);
    rc = ctx ? CLI_OK : CLI_FAIL;
    if (rank == 0 && rc == CLI_OK)
        rc = (text = slurp(sub, b.path, &len)) ? CLI_OK : CLI_FAIL;
    if (rank == 0 && rc == CLI_OK)
        rc = parse_text(sub, b.path, text, len, &bf, 1);
    if (rank == 0 && rc == CLI_OK)
        rc = batch_check_outputs(sub, b.path, &bf, summary);
    if (rank == 0 && rc == CLI_OK && b.resume) /* what a killed run left behind */
        rc = batch_clean_temporaries(ctx, &b, bf.lines, bf.nlines);
    if (rank == 0 && rc == CLI_OK && !(structure = calloc(bf.nspecs, sizeof *structure)))
        rc = cli_fail(sub, "out of memory");
    if (rank == 0 && rc == CLI_OK) { /* a layer's messages name the line that first gives it */
        char **places = batch_file_places(&bf, b.path);
        b.args.basis.where = places;
        rc = places ? cli_layers_check(ctx, sub, bf.nspecs, bf.specs, &b.args.basis, b.args.channels,
                                       b.args.so.precision, &pick, structure)
                    : cli_fail(sub, "out of memory");
        b.args.basis.where = NULL;
        free(places);
    }
    struct cli_out sum;
    memset(&sum, 0, sizeof sum);
    if (rank == 0 && rc == CLI_OK && summary)
        rc = cli_out_open(&sum, sub, summary);
    MPI_Bcast(&rc, 1, MPI_INT, 0, MPI_COMM_WORLD);
    unsigned long long wire = len;
    if (rc == CLI_OK) {
        MPI_Bcast(&wire, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
        MPI_Bcast(&pick, (int)sizeof pick, MPI_BYTE, 0, MPI_COMM_WORLD);
        if (rank != 0 && !(text = malloc(wire + 1)))
            rc = cli_fail(sub, "out of memory"), MPI_Abort(MPI_COMM_WORLD, CLI_FAIL);
        /* in pieces: a count is an int */
        for (unsigned long long at = 0; at < wire; at += 1u << 30) {
            unsigned long long piece = wire - at < (1u << 30) ? wire - at : 1u << 30;
            MPI_Bcast(text + at, (int)piece, MPI_CHAR, 0, MPI_COMM_WORLD);
        }
        len = (size_t)wire;
        if (rank != 0 && parse_text(sub, b.path, text, len, &bf, 0) != CLI_OK)
            rc = cli_fail(sub, "%s: the batch file from rank 0 could not be parsed here", b.path);
    }
    b.lines = bf.lines, b.nlines = bf.nlines, b.specs = bf.specs, b.nspecs = bf.nspecs;
    b.quiet = 1;
    if (rc == CLI_OK) {
        b.all.layers = calloc(b.nspecs, sizeof *b.all.layers);
        b.all.panes = calloc(b.nspecs, sizeof *b.all.panes);
        b.all.notes = calloc(b.nspecs, sizeof *b.all.notes);
        b.all.n = b.nspecs;
        if (!b.all.layers || !b.all.panes || !b.all.notes)
            rc = cli_fail(sub, "out of memory");
    }
    /* only ranks that combine stacks need the basis */
    if (rc == CLI_OK && (rank != 0 || size == 1))
        rc = cli_basis_make(ctx, sub, &pick, b.specs, b.args.channels, b.args.so.precision, &b.all.basis);

    share_cpus(ctx, rank, size);
    /* a rank that could not set up cannot take part; the run cannot go on without it */
    int all_ok = rc == CLI_OK;
    MPI_Allreduce(MPI_IN_PLACE, &all_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (!all_ok && rc == CLI_OK && rank == 0)
        rc = cli_fail(sub, "%s: a rank could not set up (reported above)", b.path);

    if (all_ok) {
        bst_ctx_set_progress(ctx, NULL, NULL);
        clock_gettime(CLOCK_MONOTONIC, &b.start);
        if (rank == 0) {
            rc = lead(ctx, &b, &pick, structure, summary, &sum, size);
        } else {
            b.resume = 0;
            work(ctx, &b);
        }
    }
    cli_out_abort(&sum);
    /* the layers this rank loaded, then the rest */
    for (size_t i = 0; b.all.layers && i < b.nspecs; i++) {
        bst_layer_free(b.all.layers[i]);
        bst_glass_free(b.all.panes[i]);
        free(b.all.notes[i]);
    }
    free(b.all.layers), free(b.all.panes), free(b.all.notes);
    bst_basis_free(b.all.basis);
    batch_file_free(&bf);
    free(structure);
    free(text);
    free(b.argv);
    free(args);
    bst_ctx_free(ctx);
    return rank == 0 ? rc : CLI_OK;
}

int main(int argc, char **argv)
{
    cli_blas_kernels(argv); /* the serial program's kernels (may run this again: before MPI) */
    cli_hold_std_fds();
    if (MPI_Init(&argc, &argv) != MPI_SUCCESS) {
        fprintf(stderr, "bsdfstack-mpi: MPI_Init failed\n");
        return CLI_FAIL;
    }
    cli_interrupt_setup(); /* after MPI's own: mpirun passes SIGINT and SIGTERM on to the ranks */
    int rank = 0, size = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    int rc = run(argc, argv, rank, size);
    if (rank == 0 && cli_stdout_check("batch") != CLI_OK)
        rc = CLI_FAIL;
    /* ranks that finished early wait here without spinning */
    MPI_Request req;
    MPI_Ibarrier(MPI_COMM_WORLD, &req);
    wait_quietly(&req, MPI_STATUS_IGNORE);
    MPI_Finalize();
    return rc;
}
