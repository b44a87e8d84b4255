/* cmd_glass.c - `bsdfstack glass SPEC`: a pane's Tf, Tb, Rf, Rb and absorptances against the
 * incidence angle, per channel, after # lines that say where the pane comes from, its angular model
 * and why, and its file's metadata; `--list` lists the catalogue.  The catalogue directory is
 * $BSDFSTACK_GLASS_DIR, else bst_glass_catalogue_dir(). */
#include <config.h>

#include <dirent.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "layers.h"

static const char help[] =
    "Usage: bsdfstack glass [--channels NAMES] SPEC\n"
    "       bsdfstack glass --list\n"
    "Prints, for every channel of a pane, Tf, Tb, Rf, Rb and the absorptances Af = 1 - Tf - Rf and\n"
    "Ab = 1 - Tb - Rb against the incidence angle theta = 0..85 degrees in 5 degree steps, 89,\n"
    "89.9 and 90 (tab-separated; lines starting with # describe the pane: where it comes from, its\n"
    "angular model and why, and what its file says of it).\n"
    "\n"
    "SPEC (optionally prefixed by glass:, optionally followed by ,model=uncoated|coated and, for a\n"
    "FILE, ,rows=all|N: its layers sum every wavelength, or group them past N instead of 5000;\n"
    "a trailing ^ reverses the pane, as in combine: its back side faces the exterior, so that\n"
    "Tf, Rf, Af are the pane's back-side values and Tb, Rb, Ab its front's):\n"
    "  NAME                      a pane of the catalogue (see --list, bsdfstack-glass(5))\n"
    "  FILE                      normal-incidence spectral data: bsdfstack's table (wavelength in\n"
    "                            um, Tf, Tb, Rf, Rb), an Optics / IGDB text file (CLEAR_6.DAT) or\n"
    "                            an IGSDB JSON record\n"
    "  d=6mm,n=1.52,tn=0.89      thickness, refractive index, normal-incidence transmittance\n"
    "  d=6mm,n=1.52,k=25/m       thickness, refractive index, extinction coefficient\n"
    "  t0=0.834,r0=0.0747[,r0b=0.08]  normal-incidence transmittance and reflectance(s)\n"
    "model=coated takes WINDOW's angular model for coated glass, model=uncoated the uncoated\n"
    "slab's; without it a file's material type decides as WINDOW does (Monolithic: uncoated;\n"
    "Coated, Laminate, Applied Film, ...: coated), else the pane is uncoated.\n"
    "\n"
    "Options:\n"
    "  --channels NAMES   only these channels, in this order (e.g. Solar,CIE-X); a pane with\n"
    "                     spectral data is averaged over any of Visible, Solar, CIE-X, CIE-Y, CIE-Z\n"
    "  --list             list the catalogue's panes\n"
    "  --help             this text\n"
    "\n"
    "The catalogue directory is $BSDFSTACK_GLASS_DIR, else the installed one (the source tree's\n"
    "layers/glass when run from the build tree).\n";

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static int list_catalogue(const char *sub, bst_ctx *ctx, const char *dir)
{
    DIR *dp = opendir(dir);
    if (!dp)
        return cli_fail(sub, "%s: cannot open the glass catalogue", dir);
    struct dirent *e;
    char **names = NULL;
    size_t n = 0;
    int rc = CLI_OK;
    while ((e = readdir(dp))) {
        size_t len = strlen(e->d_name);
        if (len > 6 && strcmp(e->d_name + len - 6, ".glass") == 0) {
            char **nn = realloc(names, (n + 1) * sizeof *names);
            if (!nn || !(nn[n] = strndup(e->d_name, len - 6))) {
                names = nn ? nn : names;
                rc = cli_fail(sub, "out of memory");
                break;
            }
            names = nn;
            n++;
        }
    }
    closedir(dp);
    if (n)
        qsort(names, n, sizeof *names, by_name);
    for (size_t i = 0; i < n; i++) {
        bst_glass *g;
        if (rc == CLI_OK) {
            if (bst_glass_parse(ctx, names[i], dir, &g) >= 0) {
                printf("%-17s %s\n", names[i], bst_glass_description(g));
                bst_glass_free(g);
            } else {
                printf("%-17s (unreadable: %s)\n", names[i], bst_ctx_message(ctx));
            }
        }
        free(names[i]);
    }
    free(names);
    return rc;
}

/* Describe the pane and the slab (or the coated model's reference glass) behind each channel in
 * # lines; flip: the pane reversed (front and back swapped). */
static void describe(const bst_glass *g, size_t nch, const size_t *idx, int flip)
{
    printf("# %s\n", bst_glass_description(g));
    if (flip)
        printf("# reversed (^): the pane's back side faces the exterior; front below is its back\n");
    cli_glass_describe(stdout, g, "# ");
    int coated = bst_glass_get_model(g) == BST_GLASS_COATED;
    size_t nw = bst_glass_nwavelengths(g);
    if (nw)
        printf("# spectral data: %zu wavelengths, %g..%g um; per wavelength %s\n", nw,
               bst_glass_wavelength(g, 0), bst_glass_wavelength(g, nw - 1),
               coated ? "the correlations scale the data" : "n and tau0 follow from the data");
    for (size_t c = 0; c < nch; c++) {
        double nf, tf, nb, tb, t0f, t0b;
        if (!nw && coated && bst_glass_optics(g, idx[c], 0.0, flip ? &t0b : &t0f, flip ? &t0f : &t0b,
                                             NULL, NULL) >= 0)
            printf("# %s: reference glass %s (front), %s (back): clear where T0 > %g\n",
                   bst_glass_channel(g, idx[c]), t0f > BST_GLASS_COATED_CLEAR_T0 ? "clear" : "bronze",
                   t0b > BST_GLASS_COATED_CLEAR_T0 ? "clear" : "bronze", BST_GLASS_COATED_CLEAR_T0);
        else if (!nw && bst_glass_slab(g, idx[c], NAN, flip, &nf, &tf) >= 0 &&
                 bst_glass_slab(g, idx[c], NAN, !flip, &nb, &tb) >= 0)
            printf("# %s: n %.4f, tau0 %.4f (front); n %.4f, tau0 %.4f (back)\n",
                   bst_glass_channel(g, idx[c]), nf, tf, nb, tb);
    }
}

int cmd_glass(int argc, char **argv)
{
    enum { O_CHANNELS = 256 };
    static const struct option longopts[] = {{"list", no_argument, NULL, 'l'},
                                             {"channels", required_argument, NULL, O_CHANNELS},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *sub = "glass";
    const char *dir = getenv("BSDFSTACK_GLASS_DIR");
    const char *channels = NULL;
    int list = 0, c;
    optind = 1;
    opterr = 0;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'l': list = 1; break;
        case O_CHANNELS: channels = optarg; break;
        case 'h': fputs(help, stdout); return CLI_OK;
        case ':': return cli_usage(sub, "option '%s' needs a value", argv[optind - 1]);
        default: return cli_usage(sub, "unknown option '%s'", argv[optind - 1]);
        }
    }
    if (list && argc - optind)
        return cli_usage(sub, "--list takes no pane");
    if (!list && argc - optind != 1)
        return cli_usage(sub, argc - optind ? "one pane expected" : "no pane given");
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return cli_fail(sub, "out of memory");
    if (list) {
        int rc = list_catalogue(sub, ctx, dir ? dir : bst_glass_catalogue_dir());
        bst_ctx_free(ctx);
        return rc;
    }
    const char *arg = argv[optind];
    if (strncmp(arg, "glass:", 6) == 0)
        arg += 6;
    int flip; /* SPEC^: the pane reversed, as combine reads the ^ */
    char *spec = strndup(arg, cli_spec_reversed(arg, &flip));
    /* the channels to print, in order; spectral data without bands are averaged over those */
    const char *asked[16];
    size_t nasked = 0;
    char *names = channels ? strdup(channels) : NULL, *save = NULL;
    int rc = !spec || (channels && !names) ? cli_fail(sub, "out of memory") : CLI_OK;
    for (char *t = names ? strtok_r(names, ",", &save) : NULL; t && rc == CLI_OK;
         t = strtok_r(NULL, ",", &save)) {
        if (nasked == sizeof asked / sizeof asked[0])
            rc = cli_fail(sub, "--channels: too many channels");
        else
            asked[nasked++] = t;
    }
    if (rc == CLI_OK && channels && nasked == 0)
        rc = cli_usage(sub, "--channels: no channel named");
    bst_glass *g = NULL;
    if (rc == CLI_OK && bst_glass_parse_bands(ctx, spec, dir, nasked, asked, &g) < 0)
        rc = cli_fail_ctx(sub, NULL, ctx);
    free(spec);
    size_t idx[16], nch = 0;
    if (rc == CLI_OK && channels) {
        for (size_t k = 0; k < nasked && rc == CLI_OK; k++) {
            if (bst_glass_find_channel(g, asked[k]) < 0 && bst_glass_add_channel(ctx, g, asked[k]) < 0)
                rc = cli_fail_ctx(sub, NULL, ctx);
            else
                idx[nch++] = (size_t)bst_glass_find_channel(g, asked[k]);
        }
    } else if (rc == CLI_OK) {
        for (nch = 0; nch < bst_glass_nchannels(g) && nch < sizeof idx / sizeof idx[0]; nch++)
            idx[nch] = nch;
    }
    if (rc == CLI_OK) {
        describe(g, nch, idx, flip);
        printf("channel\ttheta\tTf\tTb\tRf\tRb\tAf\tAb\n");
        static const double extra[] = {89.0, 89.9, 90.0};
        for (size_t k = 0; k < nch; k++)
            for (int i = 0; i < 21; i++) {
                double d = i < 18 ? 5.0 * i : extra[i - 18], t, tb, rf, rb;
                bst_glass_optics(g, idx[k], d == 90.0 ? M_PI / 2 : d * M_PI / 180, flip ? &tb : &t,
                                 flip ? &t : &tb, flip ? &rb : &rf, flip ? &rf : &rb);
                printf("%s\t%g\t%.6f\t%.6f\t%.6f\t%.6f\t%.6f\t%.6f\n", bst_glass_channel(g, idx[k]), d,
                       t, tb, rf, rb, 1 - t - rf, 1 - tb - rb);
            }
    }
    bst_glass_free(g);
    free(names);
    bst_ctx_free(ctx);
    return rc;
}
