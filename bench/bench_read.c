/* bench_read.c - reading a BSDF file into a layer, timed and fingerprinted:
 *   bench/bench_read [-k K | --klems NAME] [--float] [--runs R] [--sum] FILE
 * Reads FILE (bst_bsdf_read) and puts it on a basis (bst_bsdf_to_layer: order K, a Klems basis, or
 * by default the file's own), R times (default 1), and prints per run the CPU seconds (user +
 * system) and wall seconds of each step, the MB/s of XML per CPU-second of both, and at the end the
 * peak RSS.  --sum prints, per channel and component, the structure, precision, non-zero count and
 * a 64-bit FNV-1a hash of the exact values (dense: the stored bytes; diagonal: the doubles; sparse:
 * its dense double expansion), so that two builds of the library can be compared value for value
 * (bench/README.md).  Only the public API is used: the same source links any version. */
#include <config.h>

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <time.h>

#include "bsdfstack.h"

static double clock_of(clockid_t id)
{
    struct timespec t;
    clock_gettime(id, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void die(bst_ctx *ctx, const char *what)
{
    fprintf(stderr, "bench_read: %s: %s\n", what, ctx ? bst_ctx_message(ctx) : "failed");
    exit(1);
}

static uint64_t fnv(uint64_t h, const void *p, size_t len)
{
    const unsigned char *c = p;
    for (size_t i = 0; i < len; i++)
        h = (h ^ c[i]) * 0x100000001b3ULL;
    return h;
}

static void print_sums(bst_ctx *ctx, bst_layer *l)
{
    static const char *const st[] = {"zero", "diag", "sparse", "dense"};
    size_t n = bst_basis_size(bst_layer_basis(l));
    for (size_t ch = 0; ch < bst_layer_nchannels(l); ch++)
        for (int c = 0; c < BST_NCOMP; c++) {
            bst_mat *m = (bst_mat *)bst_layer_get(l, ch, (bst_comp)c);
            uint64_t h = 0xcbf29ce484222325ULL;
            bst_structure s = bst_mat_structure(m);
            if (s == BST_DENSE) {
                size_t es = bst_mat_precision(m) == BST_DOUBLE ? sizeof(double) : sizeof(float);
                h = fnv(h, bst_mat_dense_data(m), n * n * es);
            } else if (s == BST_DIAG) {
                h = fnv(h, bst_mat_diag_data(m), n * sizeof(double));
            } else if (s == BST_SPARSE) {
                double *d = malloc(n * n * sizeof *d);
                if (!d || bst_mat_to_dense_array(ctx, m, d) < 0)
                    die(ctx, "sparse to dense");
                h = fnv(h, d, n * n * sizeof *d);
                free(d);
            }
            printf("%s %s %s %s nnz %zu fnv %016llx\n", bst_layer_channel(l, ch),
                   bst_comp_name((bst_comp)c), st[s],
                   s == BST_DENSE && bst_mat_precision(m) == BST_FLOAT ? "float" : "double",
                   bst_mat_nnz(m), (unsigned long long)h);
        }
}

int main(int argc, char **argv)
{
    int k = 0, runs = 1, sums = 0;
    const char *klems = NULL, *path = NULL;
    bst_bsdf_read_opts ro = {0};
    for (int a = 1; a < argc; a++) {
        if (strcmp(argv[a], "-k") == 0 && a + 1 < argc)
            k = atoi(argv[++a]);
        else if (strcmp(argv[a], "--klems") == 0 && a + 1 < argc)
            klems = argv[++a];
        else if (strcmp(argv[a], "--runs") == 0 && a + 1 < argc)
            runs = atoi(argv[++a]);
        else if (strcmp(argv[a], "--float") == 0)
            ro.precision = BST_FLOAT;
        else if (strcmp(argv[a], "--sum") == 0)
            sums = 1;
        else if (argv[a][0] != '-' && !path)
            path = argv[a];
        else {
            fprintf(stderr, "usage: bench_read [-k K | --klems NAME] [--float] [--runs R] [--sum] FILE\n");
            return 2;
        }
    }
    if (!path || runs < 1) {
        fprintf(stderr, "usage: bench_read [-k K | --klems NAME] [--float] [--runs R] [--sum] FILE\n");
        return 2;
    }
    struct stat sb;
    double mb = stat(path, &sb) == 0 ? (double)sb.st_size / 1e6 : 0.0;
    bst_ctx *ctx = bst_ctx_new();
    if (!ctx)
        die(NULL, "context");
    bst_basis *basis = NULL;
    if ((klems && bst_basis_new_klems(ctx, klems, &basis) < 0) || (k && bst_basis_new_sc(ctx, k, &basis) < 0))
        die(ctx, "basis");
    for (int r = 0; r < runs; r++) {
        bst_bsdf *b;
        bst_layer *l;
        double c0 = clock_of(CLOCK_PROCESS_CPUTIME_ID), w0 = clock_of(CLOCK_MONOTONIC);
        if (bst_bsdf_read(ctx, path, &ro, &b) < 0)
            die(ctx, path);
        double c1 = clock_of(CLOCK_PROCESS_CPUTIME_ID), w1 = clock_of(CLOCK_MONOTONIC);
        if (bst_bsdf_to_layer(ctx, b, basis, &l) < 0)
            die(ctx, "to layer");
        double c2 = clock_of(CLOCK_PROCESS_CPUTIME_ID), w2 = clock_of(CLOCK_MONOTONIC);
        printf("run %d: read %.3f cpu %.3f wall, to_layer %.3f cpu %.3f wall, both %.3f cpu %.3f wall, "
               "%.0f MB/s per cpu-s\n", r + 1, c1 - c0, w1 - w0, c2 - c1, w2 - w1, c2 - c0, w2 - w0,
               mb / (c2 - c0));
        bst_bsdf_free(b);
        if (sums && r == runs - 1)
            print_sums(ctx, l);
        bst_layer_free(l);
    }
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("peak RSS %.0f MiB\n", (double)ru.ru_maxrss / 1024.0);
    bst_basis_free(basis);
    bst_ctx_free(ctx);
    return 0;
}
