/* bench_precision.c - single against double precision on one stack:
 *   bench/bench_precision K [REFDIR [SCRATCH]]
 * Combines pane + L_diffuser_t3k5 + pane (the bench_stack "diffuser" stack, a dense layer between
 * analytic panes) at order K twice, dense work in single and then in double precision, and prints
 * per component: the largest value, the largest and the RMS absolute difference (1/sr), both
 * relative to the largest value, and the least and median GA (Grobe 2017 eq. 7) over the incident
 * patches, with the patch where GA is least.
 *
 * To keep the peak at one combination's, the single result is written raw to SCRATCH (default
 * /tmp), freed, and read back through mmap column by column while the double result is in memory.
 * GA is computed here by eq. 7 with equal weights (Shirley-Chiu patches all have the same projected
 * solid angle); at K <= 4 the program also checks it against bst_metrics_accordance_all on the two
 * results and fails if they differ by more than 1e-9. */
#include <config.h>

#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include "bsdfstack.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static void die(bst_ctx *ctx, const char *what)
{
    fprintf(stderr, "bench_precision: %s: %s\n", what, ctx ? bst_ctx_message(ctx) : "failed");
    exit(1);
}

/* pane + diffuser + pane at basis b, dense components read in precision prec, combined with dense
 * work in prec (the CLI's --precision). */
static bst_layer *combine(bst_ctx *ctx, const bst_basis *b, const char *ref, bst_precision prec,
                          double *seconds)
{
    const char *vis[] = {"Visible"};
    char path[4096];
    snprintf(path, sizeof path, "%s/L_diffuser_t3k5.xml", ref);
    bst_layer *l[3] = {0};
    bst_bsdf_read_opts ro = {0};
    ro.precision = prec;
    bst_bsdf *f;
    if (bst_glass_layer_from_spec(ctx, "t0=0.8815,r0=0.0786", NULL, b, 1, vis, &l[0]) < 0 ||
        bst_glass_layer_from_spec(ctx, "t0=0.8815,r0=0.0786", NULL, b, 1, vis, &l[2]) < 0)
        die(ctx, "glass");
    if (bst_bsdf_read(ctx, path, &ro, &f) < 0 || bst_bsdf_to_layer(ctx, f, b, &l[1]) < 0)
        die(ctx, path);
    bst_bsdf_free(f);
    bst_stack_opts o;
    bst_stack_opts_init(&o);
    o.precision = prec;
    bst_layer *sys;
    double t = now();
    if (bst_stack_combine_consume(ctx, 3, l, &o, &sys) < 0)
        die(ctx, "combine");
    *seconds = now() - t;
    return sys;
}

/* Column j of component m as doubles into col (dense float or double, or any structure). */
static void column(const bst_mat *m, size_t n, size_t j, double *col)
{
    if (bst_mat_structure(m) == BST_DENSE) {
        void *p = bst_mat_dense_data((bst_mat *)m);
        if (bst_mat_precision(m) == BST_FLOAT)
            for (size_t i = 0; i < n; i++)
                col[i] = ((const float *)p)[j * n + i];
        else
            memcpy(col, (const double *)p + j * n, n * sizeof *col);
    } else {
        for (size_t i = 0; i < n; i++)
            col[i] = bst_mat_get(m, i, j);
    }
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: bench_precision K [REFDIR [SCRATCH]]\n");
        return 2;
    }
    int k = atoi(argv[1]);
    const char *ref = argc > 2 ? argv[2] : "../shared/reference";
    const char *scratch = argc > 3 ? argv[3] : "/tmp";
    bst_ctx *ctx = bst_ctx_new();
    bst_basis *b;
    if (!ctx || bst_basis_new_sc(ctx, k, &b) < 0)
        die(ctx, "basis");
    size_t n = bst_basis_size(b);

    double ts, td;
    bst_layer *s = combine(ctx, b, ref, BST_FLOAT, &ts);
    char path[4096];
    snprintf(path, sizeof path, "%s/bench_precision.%ld.raw", scratch, (long)getpid());
    int fd = open(path, O_RDWR | O_CREAT | O_TRUNC, 0600);
    if (fd < 0)
        die(NULL, path);
    unlink(path); /* the descriptor keeps it until exit */
    float *buf = malloc(n * sizeof *buf);
    double *col = malloc(n * sizeof *col), *cd = malloc(n * sizeof *cd);
    if (!buf || !col || !cd)
        die(NULL, "out of memory");
    for (int c = 0; c < 4; c++)
        for (size_t j = 0; j < n; j++) {
            column(bst_layer_get(s, 0, c), n, j, col);
            for (size_t i = 0; i < n; i++)
                buf[i] = (float)col[i];
            if (write(fd, buf, n * sizeof *buf) != (ssize_t)(n * sizeof *buf))
                die(NULL, "writing the scratch file");
        }
    bst_layer *s_small = k <= 4 ? s : NULL;
    if (!s_small)
        bst_layer_free(s);
    size_t bytes = 4 * n * n * sizeof(float);
    const float *sv = mmap(NULL, bytes, PROT_READ, MAP_SHARED, fd, 0);
    if (sv == MAP_FAILED)
        die(NULL, "mmap");

    bst_layer *d = combine(ctx, b, ref, BST_DOUBLE, &td);
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("k = %d (N = %zu), pane + L_diffuser_t3k5 + pane: combining %.1f s single, %.1f s "
           "double; peak RSS %.2f GiB\n", k, n, ts, td, ru.ru_maxrss / 1048576.0);
    printf("comp\tmax|f|\tmax|d|\tmax|d|/max|f|\trms(d)\trms(d)/max|f|\tleast GA\tat patch\t"
           "median GA\n");
    double *ga = malloc(n * sizeof *ga), *ga_lib = malloc(n * sizeof *ga_lib);
    if (!ga || !ga_lib)
        die(NULL, "out of memory");
    int bad = 0;
    for (int c = 0; c < 4; c++) {
        const bst_mat *m = bst_layer_get(d, 0, c);
        double fmax = 0, dmax = 0, dsum2 = 0;
        size_t least = 0;
        for (size_t j = 0; j < n; j++) {
            column(m, n, j, cd);
            const float *cs = sv + ((size_t)c * n + j) * n;
            double num = 0, den = 0;
            for (size_t i = 0; i < n; i++) {
                double x = cd[i], y = cs[i], e = x - y;
                fmax = fmax > fabs(x) ? fmax : fabs(x);
                dmax = dmax > fabs(e) ? dmax : fabs(e);
                dsum2 += e * e;
                num += e * e;
                den += (x + y) * (x + y);
            }
            ga[j] = den > 0 ? 100 * (1 - num / den) : 100;
            if (ga[j] < ga[least])
                least = j;
        }
        double rms = sqrt(dsum2 / ((double)n * n)), least_ga = ga[least];
        if (s_small) {
            if (bst_metrics_accordance_all(ctx, d, s_small, 0, c, ga_lib, NULL) < 0)
                die(ctx, "accordance");
            for (size_t j = 0; j < n; j++)
                if (!(fabs(ga_lib[j] - ga[j]) <= 1e-9)) {
                    fprintf(stderr, "bench_precision: %s patch %zu: GA %.12g here, %.12g by "
                            "bst_metrics_accordance_all\n", bst_comp_name(c), j, ga[j], ga_lib[j]);
                    bad = 1;
                }
        }
        qsort(ga, n, sizeof *ga, cmp_double);
        printf("%s\t%.6g\t%.3g\t%.3g\t%.3g\t%.3g\t100 - %.2g\t%zu\t100 - %.2g\n", bst_comp_name(c),
               fmax, dmax, fmax > 0 ? dmax / fmax : 0, rms, fmax > 0 ? rms / fmax : 0,
               100 - least_ga, least, 100 - ga[n / 2]);
    }
    munmap((void *)sv, bytes);
    close(fd);
    free(ga);
    free(ga_lib);
    free(buf);
    free(col);
    free(cd);
    bst_layer_free(s_small);
    bst_layer_free(d);
    bst_basis_free(b);
    bst_ctx_free(ctx);
    return bad;
}
