/* blas_threads.h - one OpenBLAS thread for the triangular solves of small systems.
 *
 * OpenBLAS splits a getrs's triangular solves (dtrsm) over all its threads.  At Klems size
 * (N = 145, 145 right-hand sides) the hand-off costs more than the half of the work it moves,
 * and the worker then spins in sched_yield until OpenBLAS's THREAD_TIMEOUT (about 0.1 s) after
 * each call: in a Klems spectral combine that was up to 0.2 s of system time next to 0.35 s of
 * work, and a core taken from whatever else runs.  Systems of order at most BSTI_BLAS_SERIAL_N
 * therefore solve on one thread, as their factorizations already did (solve.c).  OpenBLAS splits
 * a solve by right-hand sides, so each column's arithmetic, and every bit of the result, is the
 * same on one thread or two (tests/test_threads.c; N <= 300 and 1..700 right-hand sides
 * checked by hand).  GEMM is left alone: OpenBLAS splits it by rows too, and its edge kernels
 * round differently, so a product of order 101..199 changes in the last bits with the thread
 * count, and main's files with it.  The thread count is OpenBLAS's, process-wide: it is set back
 * at once, and a caller that already runs one thread (the spectral workers) changes nothing. */
#ifndef BST_BLAS_THREADS_H
#define BST_BLAS_THREADS_H

#include <stddef.h>

/* Klems full (145) and Shirley-Chiu k <= 3 (64) solve on one thread, k >= 4 (256) on all. */
#define BSTI_BLAS_SERIAL_N 200

/* Before the solves of a system of order n: the thread count to give back to
 * bsti_blas_serial_end, 0 where nothing was changed. */
int bsti_blas_serial_begin(size_t n);
void bsti_blas_serial_end(int saved);

#endif
