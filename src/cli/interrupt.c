/* interrupt.c - SIGINT, SIGTERM and SIGHUP: remove the temporaries, pass the signal on to the
 * workers, die of it (interrupt.h). */
#include <config.h>

#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdatomic.h>
#include <string.h>
#include <sys/prctl.h>
#include <unistd.h>

#include "interrupt.h"

static const int handled[] = {SIGINT, SIGTERM, SIGHUP};

/* A slot's path is written before it is marked used, and unmarked before it is reused. */
static char slot_path[CLI_INTERRUPT_SLOTS][PATH_MAX];
static volatile sig_atomic_t slot_used[CLI_INTERRUPT_SLOTS];
static const pid_t *volatile workers;
static const volatile int *nworkers;
/* An output's temporary is being made and not held yet (cli_interrupt_opening), and the signal
 * that came meanwhile.  Atomics, not sig_atomic_t: the handler may run on any of the threads. */
static atomic_int opening, deferred;
#if ATOMIC_INT_LOCK_FREE != 2
#error "interrupt.c needs lock-free atomic int (async-signal-safe)"
#endif

/* Remove the temporaries, pass sig on to the workers, and die of it. */
static void die_of(int sig)
{
    for (int i = 0; i < CLI_INTERRUPT_SLOTS; i++)
        if (slot_used[i])
            unlink(slot_path[i]);
    const pid_t *w = workers;
    for (int i = 0; w && nworkers && i < *nworkers; i++)
        if (w[i] > 0)
            kill(w[i], sig);
    /* die of sig: its default action, unblocked (it is blocked while its handler runs) */
    struct sigaction dfl;
    memset(&dfl, 0, sizeof dfl);
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    sigaction(sig, &dfl, NULL);
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, sig);
    sigprocmask(SIG_UNBLOCK, &set, NULL);
    raise(sig);
}

static void on_signal(int sig)
{
    int saved = errno;
    /* stored before opening is read: either this sees opening cleared (its temporary held), or
     * cli_interrupt_opened, clearing it later, sees sig */
    atomic_store(&deferred, sig);
    if (!atomic_load(&opening))
        die_of(sig);
    errno = saved; /* deferred to cli_interrupt_opened */
}

void cli_interrupt_setup(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sa.sa_flags = SA_RESTART; /* a deferred signal returns into the opening */
    sigemptyset(&sa.sa_mask);
    for (size_t i = 0; i < sizeof handled / sizeof handled[0]; i++)
        sigaddset(&sa.sa_mask, handled[i]); /* one handler at a time */
    for (size_t i = 0; i < sizeof handled / sizeof handled[0]; i++) {
        struct sigaction old;
        if (sigaction(handled[i], NULL, &old) == 0 && old.sa_handler != SIG_IGN)
            sigaction(handled[i], &sa, NULL);
    }
}

int cli_interrupt_hold(const char *tmp)
{
    if (!tmp || strlen(tmp) >= sizeof slot_path[0])
        return -1;
    for (int i = 0; i < CLI_INTERRUPT_SLOTS; i++)
        if (!slot_used[i]) {
            strcpy(slot_path[i], tmp);
            slot_used[i] = 1;
            return i;
        }
    return -1;
}

void cli_interrupt_opening(void)
{
    atomic_store(&opening, 1);
}

void cli_interrupt_opened(void)
{
    atomic_store(&opening, 0);
    int sig = atomic_exchange(&deferred, 0);
    if (sig)
        die_of(sig);
}

void cli_interrupt_release(int slot)
{
    if (slot >= 0 && slot < CLI_INTERRUPT_SLOTS)
        slot_used[slot] = 0;
}

void cli_interrupt_workers(const pid_t *pid, const volatile int *n)
{
    nworkers = n;
    workers = pid;
}

void cli_interrupt_worker_started(pid_t parent)
{
    workers = NULL;
    atomic_store(&opening, 0);
    atomic_store(&deferred, 0);
    for (int i = 0; i < CLI_INTERRUPT_SLOTS; i++)
        slot_used[i] = 0;
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) /* the parent died before prctl */
        raise(SIGTERM);
}
