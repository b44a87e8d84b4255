/* blas_threads.c - one OpenBLAS thread for the triangular solves of small systems (blas_threads.h
 * says why). */
#include <config.h>

#include <cblas.h>

#include "blas_threads.h"

int bsti_blas_serial_begin(size_t n)
{
    if (n > BSTI_BLAS_SERIAL_N)
        return 0;
    int threads = openblas_get_num_threads();
    if (threads <= 1)
        return 0;
    openblas_set_num_threads(1);
    return threads;
}

void bsti_blas_serial_end(int saved)
{
    if (saved > 1)
        openblas_set_num_threads(saved);
}
