/* test_interrupt.c - the program's signal handling (src/cli/interrupt.c): a signal removes the
 * temporaries held and the process dies of it; one that lands while a temporary is being made and
 * not yet held (the window CI once hit: the file made, the signal, then the hold) waits until the
 * temporary is held, then removes it; a signal ignored at the start stays ignored.
 * Each case runs in a child of its own, which must die of the signal it was sent. */
#include <config.h>

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "interrupt.h"
#include "testutil.h"

/* A fresh file's path (mkstemp) in the test's temporary directory. */
static void make_file(char *path, size_t size)
{
    const char *dir = getenv("TMPDIR");
    snprintf(path, size, "%s/test_interrupt.XXXXXX", dir && *dir ? dir : "/tmp");
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    close(fd);
}

/* The child's end: the signal that killed it, 0 when it exited with 0, -1 on another exit
 * (its status: what it found wrong). */
static int child_end(pid_t p)
{
    int st;
    ck_assert_int_eq(waitpid(p, &st, 0), p);
    if (WIFSIGNALED(st))
        return WTERMSIG(st);
    ck_assert_msg(WIFEXITED(st) && WEXITSTATUS(st) == 0, "the child exited with %d",
                  WIFEXITED(st) ? WEXITSTATUS(st) : -1);
    return 0;
}

static int exists(const char *path) { return access(path, F_OK) == 0; }

/* A signal while a temporary is held: removed, and the process dies of the signal. */
START_TEST(test_held)
{
    static const int sigs[] = {SIGINT, SIGTERM, SIGHUP};
    int sig = sigs[_i];
    char path[4096];
    make_file(path, sizeof path);
    pid_t p = fork();
    ck_assert_int_ge(p, 0);
    if (p == 0) {
        signal(sig, SIG_DFL);
        cli_interrupt_setup();
        cli_interrupt_hold(path);
        raise(sig);
        _exit(3); /* not reached */
    }
    ck_assert_int_eq(child_end(p), sig);
    ck_assert_msg(!exists(path), "%s left behind", path);
}
END_TEST

static void *wait_forever(void *arg)
{
    (void)arg;
    for (;;)
        pause();
    return NULL;
}

/* A child that makes a temporary between cli_interrupt_opening and its hold gets sig meanwhile:
 * raised on its own thread, or (other_thread) sent to another thread alone, a BLAS worker say,
 * whose handler leaves the dying to the main thread's cli_interrupt_opened.  The child must die
 * of sig, its temporary removed. */
static void signal_while_opening(int sig, int other_thread)
{
    char path[4096];
    make_file(path, sizeof path);
    unlink(path);
    pid_t p = fork();
    ck_assert_int_ge(p, 0);
    if (p == 0) {
        signal(sig, SIG_DFL);
        cli_interrupt_setup();
        pthread_t waiter;
        if (other_thread && pthread_create(&waiter, NULL, wait_forever, NULL) != 0)
            _exit(6);
        cli_interrupt_opening();
        int fd = open(path, O_CREAT | O_EXCL | O_WRONLY, 0600);
        if (fd < 0)
            _exit(4);
        if (other_thread) {
            pthread_kill(waiter, sig); /* to that thread alone */
            usleep(200000);            /* its handler has run (and returned) by now */
        } else {
            raise(sig); /* delivered here, to this thread; it must wait */
        }
        if (!exists(path))
            _exit(5);
        cli_interrupt_hold(path);
        cli_interrupt_opened();
        _exit(3); /* not reached: opened dies of the signal */
    }
    ck_assert_int_eq(child_end(p), sig);
    ck_assert_msg(!exists(path), "%s left behind", path);
}

/* Between the temporary made and held: the signal waits, then the temporary goes and the process
 * dies.  Without the wait the file stays behind (the process dies before it is held). */
START_TEST(test_opening)
{
    signal_while_opening(SIGTERM, 0);
}
END_TEST

/* The same with the signal taken by another thread. */
START_TEST(test_opening_other_thread)
{
    signal_while_opening(SIGHUP, 1);
}
END_TEST

/* No signal: opening and opened change nothing, and a released temporary is not removed by a
 * later signal. */
START_TEST(test_quiet)
{
    char path[4096];
    make_file(path, sizeof path);
    pid_t p = fork();
    ck_assert_int_ge(p, 0);
    if (p == 0) {
        signal(SIGINT, SIG_DFL);
        cli_interrupt_setup();
        cli_interrupt_opening();
        int slot = cli_interrupt_hold(path);
        cli_interrupt_opened();
        if (slot < 0)
            _exit(4);
        cli_interrupt_release(slot);
        raise(SIGINT);
        _exit(3);
    }
    ck_assert_int_eq(child_end(p), SIGINT);
    ck_assert_msg(exists(path), "a released temporary was removed");
    unlink(path);
}
END_TEST

/* A signal ignored when the program starts (nohup) stays ignored. */
START_TEST(test_ignored)
{
    pid_t p = fork();
    ck_assert_int_ge(p, 0);
    if (p == 0) {
        signal(SIGHUP, SIG_IGN);
        cli_interrupt_setup();
        raise(SIGHUP);
        _exit(0);
    }
    ck_assert_int_eq(child_end(p), 0);
}
END_TEST

static Suite *interrupt_suite(void)
{
    Suite *s = suite_create("interrupt");
    TCase *tc = tcase_create("signals");
    tcase_add_loop_test(tc, test_held, 0, 3);
    tcase_add_test(tc, test_opening);
    tcase_add_test(tc, test_opening_other_thread);
    tcase_add_test(tc, test_quiet);
    tcase_add_test(tc, test_ignored);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(interrupt_suite());
}
