/* interrupt.h - what SIGINT, SIGTERM and SIGHUP do to the program (and bsdfstack-mpi's ranks):
 * the temporaries of the outputs being written are removed, a batch's workers get the same signal,
 * and the process then dies of the signal as it would have (its status says so).  A signal that
 * was ignored when the program started (nohup) stays ignored.
 *
 * The handler reads only what it was handed here, in fixed slots (no allocation, no locks), and
 * calls only async-signal-safe functions (unlink, kill, sigaction, sigprocmask, raise) and
 * lock-free atomics. */
#ifndef BST_CLI_INTERRUPT_H
#define BST_CLI_INTERRUPT_H

#include <sys/types.h>

/* Outputs held at once (combine: -o and --absorptance; a batch: the summary and a stack's). */
#define CLI_INTERRUPT_SLOTS 8

/* Install the handler; at the start of main. */
void cli_interrupt_setup(void);
/* A temporary to remove if a signal comes: its slot, or -1 when it could not be held (every slot
 * taken, or a path too long: it then stays behind on a signal, as before). */
int cli_interrupt_hold(const char *tmp);
/* Around making an output's temporary and holding it: a signal that comes between the two (the
 * file made, not yet held) waits for cli_interrupt_opened, which then removes the temporary and
 * dies of it.  Not nested. */
void cli_interrupt_opening(void);
void cli_interrupt_opened(void);
/* The temporary of slot is renamed or removed: forget it (slot -1: nothing). */
void cli_interrupt_release(int slot);
/* A batch's workers, pid[0..n-1] (0: an ended one, skipped), to pass a signal on to; NULL: none.
 * The array stays the caller's and must outlive the registration. */
void cli_interrupt_workers(const pid_t *pid, const volatile int *n);
/* In a worker just forked from the batch process parent: drop what the parent held (its
 * temporaries are not the worker's to remove) and die with SIGTERM when the parent dies, even of
 * SIGKILL (PR_SET_PDEATHSIG), or has died already. */
void cli_interrupt_worker_started(pid_t parent);

#endif
