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

int cli_memory_check(const char *sub, const bst_basis *basis, size_t n, bst_bsdf *const *files,
                     unsigned comps, bst_precision prec, const struct cli_basis_choice *choice)
{
    size_t held;
    double need = bst_plan_memory(basis, n, (const bst_bsdf *const *)files, comps, prec,
                                  choice->combining, choice->work, &held);
    double limit = choice->max_memory > 0 ? choice->max_memory : memory_available();
    if (limit <= 0 || need <= limit)
        return CLI_OK;
    double gib = 1073741824.0;
    char where[64];
    if (bst_basis_kind_of(basis) == BST_BASIS_SHIRLEY_CHIU)
        snprintf(where, sizeof where, "k = %d", bst_basis_order(basis));
    else
        snprintf(where, sizeof where, "%s", bst_basis_name(basis));
    return cli_fail(sub, "%s needs about %.3g GiB (%zu dense component%s of %.3g GiB%s), more than "
                    "the %.3g GiB %s: use %s; or raise the limit with --max-memory SIZE", where,
                    need / gib, held, held == 1 ? "" : "s",
                    (double)bst_basis_size(basis) * (double)bst_basis_size(basis) *
                        (prec == BST_FLOAT ? 4.0 : 8.0) / gib,
                    choice->combining ? " and the combination's work" : "", limit / gib,
                    choice->max_memory > 0 ? "--max-memory allows" : "available",
                    choice->lower ? choice->lower : "a lower -k");
}
