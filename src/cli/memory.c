/* memory.c - the memory guard (layers.h, cli_memory_check): the need, by the library's model
 * (bst_plan_memory), against the memory this process may take. */
#include <config.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "cli.h"
#include "layers.h"

/* The memory this process may still take: MemAvailable, or the cgroup's limit less its use when
 * lower; 0 when neither can be read. */
static double memory_available(void)
{
    double avail = 0;
    FILE *fp = fopen("/proc/meminfo", "r");
    if (fp) {
        char line[256];
        unsigned long long kb;
        while (fgets(line, sizeof line, fp))
            if (sscanf(line, "MemAvailable: %llu kB", &kb) == 1)
                avail = 1024.0 * (double)kb;
        fclose(fp);
    }
    double lim = 0, use = 0;
    fp = fopen("/sys/fs/cgroup/memory.max", "r");
    if (fp) {
        if (fscanf(fp, "%lf", &lim) != 1)
            lim = 0; /* "max": no limit */
        fclose(fp);
    }
    fp = fopen("/sys/fs/cgroup/memory.current", "r");
    if (fp) {
        if (fscanf(fp, "%lf", &use) != 1)
            use = 0;
        fclose(fp);
    }
    if (lim > 0 && (avail == 0 || lim - use < avail))
        avail = lim - use > 0 ? lim - use : 1;
    return avail;
}

/* What the need counts, for the message: "4 dense components of 0.125 GiB", "factored results
 * written one component at a time through a grid of 2 GiB", "no dense component" (diagonal and
 * sparse ones alone), ... */
static void counted(const bst_plan_need *got, double cells, int combining, char *buf, size_t size)
{
    double gib = 1073741824.0, each = got->dense ? got->dense_bytes / (double)got->dense : 0;
    if (got->expanded)
        snprintf(buf, size, "factored %s written one component at a time through a grid of %.3g "
                 "GiB", combining ? "results" : "components", got->expanded_bytes / gib);
    else if (got->dense && each != 4.0 * cells && each != 8.0 * cells) /* files' floats, made doubles */
        snprintf(buf, size, "%zu dense components, %.3g GiB in all", got->dense,
                 got->dense_bytes / gib);
    else if (!got->dense)
        snprintf(buf, size, "no dense component");
    else
        snprintf(buf, size, "%zu dense component%s of %.3g GiB", got->dense,
                 got->dense == 1 ? "" : "s", each / gib);
}

/* The options that lower a combination's or conversion's need, in precision prec: --precision
 * single only where dense components count (factored or sparse results and the writer's grid of
 * doubles are the same in either precision). */
static const char *lower_hint(bst_precision prec)
{
    return prec == BST_FLOAT ? "a lower -k or fewer --channels"
                             : "a lower -k, --precision single or fewer --channels";
}

int cli_memory_check_held(const char *sub, const bst_basis *basis, size_t n,
                          const bst_plan_held *held, unsigned comps, bst_precision prec,
                          const struct cli_basis_choice *choice)
{
    bst_plan_need got;
    double need = bst_plan_memory_held(basis, n, held, comps, prec, choice->combining, choice->work,
                                       &got);
    double limit = choice->max_memory > 0 ? choice->max_memory : memory_available();
    if (limit <= 0 || need <= limit)
        return CLI_OK;
    double gib = 1073741824.0, cells = (double)bst_basis_size(basis) * (double)bst_basis_size(basis);
    char where[64], what[160];
    if (bst_basis_kind_of(basis) == BST_BASIS_SHIRLEY_CHIU)
        snprintf(where, sizeof where, "k = %d", bst_basis_order(basis));
    else
        snprintf(where, sizeof where, "%s", bst_basis_name(basis));
    counted(&got, cells, choice->combining, what, sizeof what);
    const char *lower = choice->lower ? choice->lower : lower_hint(got.dense ? prec : BST_FLOAT);
    return cli_fail(sub, "%s needs about %.3g GiB (%s%s), more than the %.3g GiB %s: use %s; or "
                    "raise the limit with --max-memory SIZE", where, need / gib, what,
                    choice->combining ? " and the combination's work" : "", limit / gib,
                    choice->max_memory > 0 ? "--max-memory allows" : "available", lower);
}

int cli_memory_check(const char *sub, const bst_basis *basis, size_t n, bst_bsdf *const *files,
                     unsigned comps, bst_precision prec, const struct cli_basis_choice *choice)
{
    bst_plan_held one[8] = {{0}}, *held = n <= 8 ? one : calloc(n, sizeof *held);
    if (!held)
        return cli_fail(sub, "out of memory");
    for (size_t i = 0; i < n; i++)
        held[i] = (bst_plan_held){.file = files ? files[i] : NULL};
    int rc = cli_memory_check_held(sub, basis, n, held, comps, prec, choice);
    if (held != one)
        free(held);
    return rc;
}
