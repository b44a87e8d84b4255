/* cmd_glass.c - `bsdfstack glass SPEC`: a pane's T, Rf, Rb and absorptance against angle. */
#include <config.h>

#include <dirent.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"

static const char help[] =
    "Usage: bsdfstack glass [--list] SPEC\n"
    "Prints, for every channel of the pane, Tf, Tb, Rf, Rb and the absorptances Af = 1 - Tf - Rf\n"
    "and Ab = 1 - Tb - Rb against the incidence angle theta = 0..90 degrees in 5 degree steps, 89 and 89.9.\n"
    "\n"
    "SPEC: a catalogue NAME (see --list and bsdfstack-glass(5)), d=6mm,n=1.52,tn=0.89 (thickness,\n"
    "refractive index, normal-incidence transmittance) or t0=0.834,r0=0.0747[,r0b=...].\n"
    "The catalogue directory is $BSDFSTACK_GLASS_DIR, else the installed one.\n"
    "\n"
    "Options:\n"
    "  --list   list the catalogue's panes\n";

int cmd_glass(int argc, char **argv)
{
    static const struct option longopts[] = {{"list", no_argument, NULL, 'l'},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *sub = "glass";
    const char *dir = getenv("BSDFSTACK_GLASS_DIR");
    int list = 0, c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'l': list = 1; break;
        case 'h': fputs(help, stdout); return CLI_OK;
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    if (list) {
        const char *d = dir ? dir : BST_GLASS_DIR;
        DIR *dp = opendir(d);
        if (!dp) {
            bst_ctx_free(ctx);
            return cli_fail(sub, "%s: cannot open the glass catalogue", d);
        }
        struct dirent *e;
        char **names = NULL;
        size_t n = 0;
        while ((e = readdir(dp))) {
            size_t len = strlen(e->d_name);
            if (len > 6 && strcmp(e->d_name + len - 6, ".glass") == 0) {
                char **nn = realloc(names, (n + 1) * sizeof *names);
                if (!nn)
                    break;
                names = nn;
                names[n++] = strndup(e->d_name, len - 6);
            }
        }
        closedir(dp);
        qsort(names, n, sizeof *names, (int (*)(const void *, const void *))strcmp);
        for (size_t i = 0; i < n; i++) {
            bst_glass *g;
            if (names[i] && bst_glass_parse(ctx, names[i], d, &g) >= 0) {
                printf("%-14s %s\n", names[i], bst_glass_description(g));
                bst_glass_free(g);
            }
            free(names[i]);
        }
        free(names);
        bst_ctx_free(ctx);
        return CLI_OK;
    }
    if (argc - optind != 1) {
        bst_ctx_free(ctx);
        return cli_usage(sub, argc - optind ? "one pane expected" : "no pane given");
    }
    const char *spec = argv[optind];
    if (strncmp(spec, "glass:", 6) == 0)
        spec += 6;
    bst_glass *g;
    if (bst_glass_parse(ctx, spec, dir, &g) < 0) {
        int rc = cli_fail_ctx(sub, NULL, ctx);
        bst_ctx_free(ctx);
        return rc;
    }
    printf("# %s\n", bst_glass_description(g));
    printf("channel\ttheta\tTf\tTb\tRf\tRb\tAf\tAb\n");
    static const double extra[] = {89.0, 89.9};
    for (size_t ch = 0; ch < bst_glass_nchannels(g); ch++)
        for (int i = 0; i <= 20; i++) {
            double deg = i <= 18 ? 5.0 * i : extra[i - 19];
            if (i == 18) /* 90 comes last */
                continue;
            double t, tb, rf, rb;
            bst_glass_optics(g, ch, deg * M_PI / 180, &t, &tb, &rf, &rb);
            printf("%s\t%g\t%.6f\t%.6f\t%.6f\t%.6f\t%.6f\t%.6f\n", bst_glass_channel(g, ch), deg,
                   t, tb, rf, rb, 1 - t - rf, 1 - tb - rb);
            if (i == 20) {
                bst_glass_optics(g, ch, M_PI / 2, &t, &tb, &rf, &rb);
                printf("%s\t90\t%.6f\t%.6f\t%.6f\t%.6f\t%.6f\t%.6f\n", bst_glass_channel(g, ch), t,
                       tb, rf, rb, 1 - t - rf, 1 - tb - rb);
            }
        }
    bst_glass_free(g);
    bst_ctx_free(ctx);
    return CLI_OK;
}
