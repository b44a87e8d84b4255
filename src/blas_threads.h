/* blas_threads.h - one OpenBLAS thread for the solves and products of small systems.
 *
 * OpenBLAS splits a getrs's triangular solves (dtrsm), and GEMMs above 64^3 multiply-adds, over
 * all its threads, and its worker then spins in sched_yield for about 0.1 s after each call
 * (THREAD_TIMEOUT): in the Klems spectral combine of issue #14 that is 0.1-0.2 s of system time,
 * a core taken from whatever else runs, and 0.12-0.21 s wall against 0.10 s with
 * OPENBLAS_NUM_THREADS=1.  Systems of order at most BSTI_BLAS_SERIAL_N solve on one thread, as
 * their factorizations already did (solve.c): OpenBLAS splits a solve by right-hand sides, and
 * with some of its kernels (Haswell's, as OPENBLAS_CORETYPE=Haswell selects on an AVX-512
 * machine) a column's last bits then depend on the split, so only one thread gives every machine
 * the same result (tests/test_threads.c).  GEMMs whose
 * dimensions are all at most BSTI_BLAS_SERIAL_N run on one thread too (mat_mul.c): OpenBLAS
 * splits a product by rows as well and its edge kernels round differently, so a product of order
 * 101..199 changed in its last bits with the thread count, and a Klems stack of two dense layers
 * with it; on one thread every machine writes the same file (and the spinning worker is gone).
 * The thread count is OpenBLAS's, process-wide: it is set back at once, and a caller that already
 * runs one thread (the spectral workers) changes nothing. */
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
