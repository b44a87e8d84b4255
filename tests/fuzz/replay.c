/* replay.c - runs one libFuzzer target (fuzz_TARGET.c, linked in) over files, without libFuzzer:
 * in `make check` over the target's seed corpus and its regression inputs, so that every input a
 * fuzzer once broke stays fixed, under the normal build, valgrind and `make check-asan` alike.
 *
 *   replay_TARGET            every file of $BST_SRCDIR/tests/fuzz/corpus/TARGET and
 *                            $BST_SRCDIR/tests/fuzz/regress/TARGET, in name order
 *   replay_TARGET FILE...    those files (a crash reproducer, say)
 *
 * A regression input listed in tests/fuzz/regress/OPEN (one "TARGET/NAME reason" a line) is a bug
 * found but not fixed yet: it is skipped and named.  Each input gets REPLAY_SECONDS of wall clock
 * (an alarm): far more than any input needs (milliseconds), so that only a hang fails. */
#include <config.h>

#include <dirent.h>
#include <signal.h>
#include <unistd.h>

#include "fuzz.h"

#ifndef FUZZ_TARGET
#error "FUZZ_TARGET must name the target (xml, ttree, glass, batch)"
#endif

#define REPLAY_SECONDS 60

/* LLVMFuzzerInitialize is optional in a target. */
#pragma weak LLVMFuzzerInitialize

static const char *current = "";

static void on_alarm(int sig)
{
    (void)sig;
    static const char msg[] = "replay: input runs longer than the alarm (a hang): ";
    if (write(2, msg, sizeof msg - 1) < 0 || write(2, current, strlen(current)) < 0 ||
        write(2, "\n", 1) < 0)
        _exit(1);
    _exit(1);
}

static int read_file(const char *path, uint8_t **data, size_t *size)
{
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return -1;
    size_t cap = 4096, n = 0;
    uint8_t *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, fp);
        if (n < cap)
            break;
        uint8_t *b = realloc(buf, 2 * cap);
        if (!b) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = b, cap *= 2;
    }
    int bad = !buf || ferror(fp);
    fclose(fp);
    if (bad) {
        free(buf);
        return -1;
    }
    *data = buf, *size = n;
    return 0;
}

static int replay(const char *path)
{
    uint8_t *data;
    size_t size;
    if (read_file(path, &data, &size) < 0) {
        fprintf(stderr, "replay: %s: cannot read\n", path);
        return -1;
    }
    current = path;
    alarm(REPLAY_SECONDS);
    LLVMFuzzerTestOneInput(data, size);
    alarm(0);
    free(data);
    printf("ok: %s (%zu bytes)\n", path, size);
    return 0;
}

/* Whether tests/fuzz/regress/OPEN lists FUZZ_TARGET/name. */
static int listed_open(const char *srcdir, const char *name)
{
    char path[4096], line[1024], want[512];
    snprintf(path, sizeof path, "%s/tests/fuzz/regress/OPEN", srcdir);
    snprintf(want, sizeof want, "%s/%s", FUZZ_TARGET, name);
    FILE *fp = fopen(path, "r");
    if (!fp)
        return 0;
    int found = 0;
    while (!found && fgets(line, sizeof line, fp)) {
        size_t n = strcspn(line, " \t\r\n");
        found = line[0] != '#' && n == strlen(want) && strncmp(line, want, n) == 0;
    }
    fclose(fp);
    return found;
}

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Replay every file of srcdir/tests/fuzz/KIND/FUZZ_TARGET; the number that failed. */
static int replay_dir(const char *srcdir, const char *kind, size_t *count)
{
    char dir[4096];
    snprintf(dir, sizeof dir, "%s/tests/fuzz/%s/%s", srcdir, kind, FUZZ_TARGET);
    DIR *d = opendir(dir);
    if (!d)
        return strcmp(kind, "corpus") == 0 ? (fprintf(stderr, "replay: no %s\n", dir), 1) : 0;
    char **names = NULL;
    size_t n = 0, cap = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.')
            continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            char **q = realloc(names, cap * sizeof *q);
            fuzz_require(q, "memory for the file list");
            names = q;
        }
        names[n] = strdup(e->d_name);
        fuzz_require(names[n], "memory for the file list");
        n++;
    }
    closedir(d);
    if (n)
        qsort(names, n, sizeof *names, by_name);
    int failed = 0;
    for (size_t i = 0; i < n; i++) {
        char path[4600];
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        if (strcmp(kind, "regress") == 0 && listed_open(srcdir, names[i]))
            printf("skipped (open, tests/fuzz/regress/OPEN): %s\n", path);
        else if (replay(path) < 0)
            failed++;
        else
            ++*count;
        free(names[i]);
    }
    free(names);
    return failed;
}

int main(int argc, char **argv)
{
    signal(SIGALRM, on_alarm);
    if (LLVMFuzzerInitialize)
        LLVMFuzzerInitialize(&argc, &argv);
    int failed = 0;
    size_t count = 0;
    if (argc > 1) {
        for (int i = 1; i < argc; i++) {
            if (replay(argv[i]) < 0)
                failed++;
            else
                count++;
        }
    } else {
        const char *srcdir = getenv("BST_SRCDIR");
        if (!srcdir || !*srcdir)
            srcdir = ".";
        failed += replay_dir(srcdir, "corpus", &count);
        failed += replay_dir(srcdir, "regress", &count);
    }
    printf("replay %s: %zu inputs, %d failed\n", FUZZ_TARGET, count, failed);
    return failed ? 1 : 0;
}
