/* layers.c - see layers.h. */
#include <config.h>

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "cli.h"
#include "layers.h"

#define MAX_CH 16
/* A spectral pane's layer costs its wavelengths times the angles it averages over (about 0.5 ms a
 * wavelength at k = 5 on one core, glass_layer.c): past this many, a warning says so first. */
#define CLI_MANY_WAVELENGTHS 5000
#define CLI_CATALOGUE_WAVELENGTHS 113 /* NFRC 102's data rows, for scale */
#define LAST_SOURCE_DATE 253402300799LL /* 9999-12-31T23:59:59Z: the date keeps four digits */

/* Split "a,b,c" into at most max names (pointers into a copy the caller frees). */
static size_t split(char *s, const char **out, size_t max)
{
    size_t n = 0;
    char *save = NULL;
    for (char *t = strtok_r(s, ",", &save); t && n < max; t = strtok_r(NULL, ",", &save))
        out[n++] = t;
    return n;
}

int cli_parse_basis_option(const char *sub, int opt, const char *value, struct cli_basis_choice *choice)
{
    if (opt == 'k') {
        if (cli_parse_int(value, &choice->k) || choice->k < BST_K_MIN || choice->k > BST_K_MAX)
            return cli_usage(sub, "-k %s: the order must be an integer from %d to %d", value,
                             BST_K_MIN, BST_K_MAX);
    } else {
        choice->klems = value ? value : "full";
        if (strcmp(choice->klems, "full") && strcmp(choice->klems, "half") && strcmp(choice->klems, "quarter"))
            return cli_usage(sub, "--klems=%s: use full, half or quarter", choice->klems);
    }
    if (choice->k && choice->klems)
        return cli_usage(sub, "-k and --klems exclude each other");
    return CLI_OK;
}

void cli_basis_choice_of(const bst_basis *b, struct cli_basis_choice *choice)
{
    static const char *const klems[] = {"LBNL/Klems Full", "full", "LBNL/Klems Half", "half",
                                        "LBNL/Klems Quarter", "quarter"};
    memset(choice, 0, sizeof *choice);
    if (bst_basis_kind_of(b) == BST_BASIS_SHIRLEY_CHIU)
        choice->k = bst_basis_order(b);
    for (size_t i = 0; i < 6; i += 2)
        if (bst_basis_kind_of(b) == BST_BASIS_KLEMS && strcmp(bst_basis_name(b), klems[i]) == 0)
            choice->klems = klems[i + 1];
}

void cli_stack_args_init(struct cli_stack_args *a)
{
    memset(a, 0, sizeof *a);
    a->reduce.pct = BST_REDUCE_PCT;
    a->reduce.tol = BST_REDUCE_TOL;
    bst_stack_opts_init(&a->so);
    bst_spectral_opts_init(&a->sp);
}

int cli_stack_option(const char *sub, int c, const char *arg, struct cli_stack_args *a)
{
    switch (c) {
    case 'k':
    case CLI_O_KLEMS: return cli_parse_basis_option(sub, c == 'k' ? 'k' : 'K', arg, &a->basis);
    case CLI_O_ONLY: return cli_parse_comps(sub, arg, &a->so.comps);
    case CLI_O_CHANNELS: a->channels = arg; return CLI_OK;
    case CLI_O_PRECISION: return cli_parse_precision(sub, arg, &a->so.precision);
    case CLI_O_DROP:
        if (cli_parse_double(arg, &a->so.drop_tol) || a->so.drop_tol < 0 || a->so.drop_tol >= 1)
            return cli_usage(sub, "--drop-tol %s: a number in [0, 1) is required", arg);
        return CLI_OK;
    case CLI_O_REDUCE:
        if (cli_parse_double(arg, &a->reduce.pct) || a->reduce.pct < 0 || a->reduce.pct >= 100)
            return cli_usage(sub, "--reduce %s: a percentile in [0, 100) is required", arg);
        return CLI_OK;
    case CLI_O_NOREDUCE: a->reduce.pct = -1; return CLI_OK;
    case CLI_O_REDUCETOL: return cli_parse_reduce_tol(sub, arg, &a->reduce.tol);
    case CLI_O_DENSE: a->so.force_dense = 1; return CLI_OK;
    case CLI_O_STRICT: a->so.strict = 1; return CLI_OK;
    case CLI_O_PERCH: a->per_channel = 1; return CLI_OK;
    case CLI_O_MAXMEM: return cli_parse_memory(sub, arg, &a->basis.max_memory);
    case CLI_O_SPTOL:
        if (cli_parse_double(arg, &a->sp.tol) || !(a->sp.tol >= 0 && a->sp.tol <= 1))
            return cli_usage(sub, "--spectral-tol %s: a number in [0, 1] is required", arg);
        return CLI_OK;
    case CLI_O_GLASSRULE:
        if (strcmp(arg, "centre") && strcmp(arg, "average"))
            return cli_usage(sub, "--glass-rule %s: use average or centre", arg);
        a->basis.at_centre = a->sp.at_centre = strcmp(arg, "centre") == 0;
        return CLI_OK;
    default: return -1;
    }
}

int cli_parse_memory(const char *sub, const char *value, double *bytes)
{
    char *end;
    double v = strtod(value, &end);
    static const char units[] = "KMGT";
    const char *u = *end ? strchr(units, toupper((unsigned char)*end)) : NULL;
    if (u && *u) {
        v *= pow(1024.0, (double)(u - units + 1));
        end++;
        if (toupper((unsigned char)*end) == 'B' || *end == 'i') /* 16G, 16GB, 16GiB */
            end += *end == 'i' ? 1 + (end[1] == 'B') : 1;
    }
    if (end == value || *end || !(v > 0) || !isfinite(v))
        return cli_usage(sub, "--max-memory %s: give a size such as 16G, 800M or 2000000000", value);
    *bytes = v;
    return CLI_OK;
}

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

void cli_layers_free(struct cli_layers *set)
{
    if (!set)
        return;
    for (size_t i = 0; i < set->n; i++) {
        bst_layer_free(set->layers[i]);
        if (set->panes)
            bst_glass_free(set->panes[i]);
    }
    free(set->layers);
    free(set->panes);
    bst_basis_free(set->basis);
    free(set->description);
    memset(set, 0, sizeof *set);
}

void cli_warn_zero_components(const char *sub, const char *path, const bst_bsdf *b, unsigned comps,
                              const char *how, bst_ctx *ctx)
{
    char note[256] = "";
    for (size_t ch = 0; ch < bst_bsdf_nchannels(b); ch++)
        for (int c = 0; c < BST_NCOMP; c++) {
            int other = c == BST_TF ? BST_TB : c == BST_TB ? BST_TF : -1;
            if ((comps && !(comps & BST_COMP_BIT(c))) || bst_bsdf_stored(b, ch, (bst_comp)c) || (other >= 0 && bst_bsdf_stored(b, ch, (bst_comp)other)))
                continue;
            size_t len = strlen(note);
            snprintf(note + len, sizeof note - len, "%s%s %s", len ? ", " : "", bst_bsdf_channel(b, ch),
                     bst_comp_name((bst_comp)c));
        }
    if (note[0])
        fprintf(stderr, "bsdfstack %s: warning: %s: not in the file, %s as zero: %s\n", sub, path, how,
                note);
    cli_warn_bsdf(sub, path, b);
    bst_ctx_clear(ctx);
}


static int is_glass(const char *spec)
{
    return strncmp(spec, "glass:", 6) == 0;
}

/* Read the file a spec names (a trailing ^ dropped) into *file, printing the reader's warnings
 * unless quiet.  Messages name `what`, or the file when what is NULL. */
static int read_one(bst_ctx *ctx, const char *sub, const char *what, const char *spec,
                    const bst_bsdf_read_opts *ro, int quiet, bst_bsdf **file)
{
    char *path = strdup(spec);
    if (!path)
        return cli_fail(sub, "out of memory");
    size_t len = strlen(path);
    if (len && path[len - 1] == '^')
        path[len - 1] = '\0';
    int rc = CLI_OK, st = bst_bsdf_read(ctx, path, ro, file);
    if (st < 0)
        rc = cli_fail_ctx(sub, what, ctx);
    else if (quiet)
        bst_ctx_clear(ctx);
    else if (st == BST_WDATA)
        cli_warn_zero_components(sub, path, *file, ro->comps, "taken", ctx);
    else
        cli_warn_ctx(sub, what, st, ctx);
    free(path);
    return rc;
}

/* Steps 1 and 2 of loading: every file among specs read into files[i] (NULL for glass:), and the
 * basis chosen (the finest tree order, else the first Klems file's basis, else k = 5, unless the
 * choice names one), told in *pick; then the memory guard over all of them. */
static int read_all(bst_ctx *ctx, const char *sub, size_t n, char **specs,
                    const struct cli_basis_choice *choice, const bst_bsdf_read_opts *ro,
                    bst_precision prec, bst_bsdf **files, bst_basis **basis, struct cli_basis_pick *pick)
{
    int rc = CLI_OK;
    for (size_t i = 0; i < n && rc == CLI_OK; i++)
        if (!is_glass(specs[i]))
            rc = read_one(ctx, sub, NULL, specs[i], ro, 0, &files[i]);
    if (rc != CLI_OK)
        return rc;
    bst_plan_basis plan; /* the library's rule (plan.c) */
    bst_plan_pick_basis(n, (const bst_bsdf *const *)files, NULL, choice->k, choice->klems, &plan);
    if (choice->combining && plan.note[0])
        fprintf(stderr, "bsdfstack %s: warning: %s\n", sub, plan.note);
    memset(pick, 0, sizeof *pick);
    pick->k = plan.k;
    pick->file = plan.file;
    if (plan.klems)
        snprintf(pick->klems, sizeof pick->klems, "%s", plan.klems);
    if (bst_plan_make_basis(ctx, &plan, (const bst_bsdf *const *)files, NULL, basis) < 0)
        return cli_fail_ctx(sub, NULL, ctx);
    return cli_memory_check(sub, *basis, n, files, ro->comps, prec, choice);
}

/* Step 3 for one spec: its layer over basis from the file read (file, freed here) or from the
 * glass: spec, reversed where it ends in ^, named by the spec; a spectral pane not reversed also
 * goes to *pane (else NULL).  Errors name `what`. */
static int make_layer(bst_ctx *ctx, const char *sub, const char *what, const char *spec,
                      bst_bsdf *file, const bst_basis *basis, size_t nch, const char **chnames,
                      int at_centre, bst_layer **out, bst_glass **pane)
{
    size_t len = strlen(spec);
    int flip = len && spec[len - 1] == '^', st;
    bst_layer *l = NULL;
    *out = NULL;
    *pane = NULL;
    if (file) {
        st = bst_bsdf_to_layer(ctx, file, basis, &l);
        bst_bsdf_free(file);
    } else {
        char *gspec = strndup(spec + 6, len - 6 - (size_t)flip);
        bst_glass *g = NULL;
        st = gspec ? bst_glass_parse(ctx, gspec, getenv("BSDFSTACK_GLASS_DIR"), &g) : BST_ENOMEM;
        /* a spectral pane is averaged over any further band asked for (CIE-X, ...) */
        for (size_t c = 0; st >= 0 && c < nch; c++)
            if (bst_glass_find_channel(g, chnames[c]) < 0 && bst_glass_nwavelengths(g) &&
                bst_plan_is_band(chnames[c]))
                st = bst_glass_add_channel(ctx, g, chnames[c]);
        size_t nw = st >= 0 ? bst_glass_nwavelengths(g) : 0;
        if (nw > CLI_MANY_WAVELENGTHS) /* the layer's cost grows with them: say so before */
            fprintf(stderr, "bsdfstack %s: warning: %s: %zu wavelengths: the pane is evaluated at "
                    "each of them at every angle its layer averages, %.0f times the work of a "
                    "catalogue pane's %d; a coarser table is as good where the data are smooth\n",
                    sub, what ? what : spec, nw, (double)nw / CLI_CATALOGUE_WAVELENGTHS,
                    CLI_CATALOGUE_WAVELENGTHS);
        if (st >= 0)
            st = bst_glass_layer(ctx, g, basis, nch, nch ? chnames : NULL, at_centre, &l);
        /* a pane with spectral data can also be evaluated per wavelength */
        if (st >= 0 && !flip && bst_glass_nwavelengths(g) > 0)
            *pane = g;
        else
            bst_glass_free(g);
        free(gspec);
    }
    if (st < 0)
        return cli_fail_ctx(sub, what, ctx);
    if (flip) {
        bst_layer *f;
        st = bst_layer_flip(ctx, l, &f);
        bst_layer_free(l);
        if (st < 0) {
            bst_glass_free(*pane);
            *pane = NULL;
            return cli_fail_ctx(sub, what, ctx);
        }
        l = f;
    }
    bst_layer_set_name(ctx, l, spec);
    *out = l;
    return CLI_OK;
}

int cli_layers_load(struct cli_layers *set, bst_ctx *ctx, const char *sub, size_t n, char **specs,
                    const struct cli_basis_choice *choice, const char *channels,
                    unsigned comps, bst_precision prec)
{
    memset(set, 0, sizeof *set);
    set->layers = calloc(n, sizeof *set->layers);
    set->panes = calloc(n, sizeof *set->panes);
    bst_bsdf **files = calloc(n, sizeof *files);
    char *chcopy = channels ? strdup(channels) : NULL;
    const char *chnames[MAX_CH];
    size_t nch = chcopy ? split(chcopy, chnames, MAX_CH) : 0;
    size_t desc_len = 64;
    for (size_t i = 0; i < n; i++)
        desc_len += strlen(specs[i]) + 4;
    set->description = malloc(desc_len);
    int rc = CLI_OK;
    if (!set->layers || !set->panes || !files || !set->description || (channels && !chcopy)) {
        rc = cli_fail(sub, "out of memory");
        goto out;
    }
    strcpy(set->description, "layers (exterior first):");
    for (size_t i = 0; i < n; i++) {
        strcat(set->description, i ? ", " : " ");
        strcat(set->description, specs[i]);
    }
    /* 1. read the files, 2. the target basis */
    bst_bsdf_read_opts ro = {.nchannels = nch, .channels = chnames, .comps = comps, .precision = prec};
    struct cli_basis_pick pick;
    if ((rc = read_all(ctx, sub, n, specs, choice, &ro, prec, files, &set->basis, &pick)) != CLI_OK)
        goto out;
    /* 3. every layer over that basis, reversed where asked */
    for (size_t i = 0; i < n && rc == CLI_OK; i++) {
        rc = make_layer(ctx, sub, specs[i], specs[i], files[i], set->basis, nch, chnames,
                        choice->at_centre, &set->layers[i], &set->panes[i]);
        files[i] = NULL;
        if (rc == CLI_OK) {
            set->npanes += set->panes[i] != NULL;
            set->n++;
        }
    }
out:
    for (size_t i = 0; files && i < n; i++)
        bst_bsdf_free(files[i]);
    free(files);
    free(chcopy);
    if (rc != CLI_OK)
        cli_layers_free(set);
    return rc;
}

int cli_layers_check(bst_ctx *ctx, const char *sub, size_t n, char **specs,
                     const struct cli_basis_choice *choice, const char *channels,
                     bst_precision prec, struct cli_basis_pick *pick, int *structure)
{
    bst_bsdf **files = calloc(n, sizeof *files);
    char *chcopy = channels ? strdup(channels) : NULL;
    const char *chnames[MAX_CH];
    size_t nch = chcopy ? split(chcopy, chnames, MAX_CH) : 0;
    if (!files || (channels && !chcopy)) {
        free(files), free(chcopy);
        return cli_fail(sub, "out of memory");
    }
    bst_bsdf_read_opts ro = {.nchannels = nch, .channels = chnames, .precision = prec};
    bst_basis *basis = NULL;
    int rc = read_all(ctx, sub, n, specs, choice, &ro, prec, files, &basis, pick);
    for (size_t i = 0; i < n && rc == CLI_OK; i++) {
        if (files[i]) {
            /* the structure bst_bsdf_to_layer will give: dense above BST_SPARSE_MAX_FILL */
            double fill = 0;
            for (size_t ch = 0; ch < bst_bsdf_nchannels(files[i]); ch++)
                for (int c = 0; c < BST_NCOMP; c++)
                    if (bst_bsdf_fill(files[i], ch, (bst_comp)c) > fill)
                        fill = bst_bsdf_fill(files[i], ch, (bst_comp)c);
            structure[i] = fill > BST_SPARSE_MAX_FILL ? CLI_DENSE : fill > 0 ? CLI_SPARSE : CLI_DIAGONAL;
            continue;
        }
        /* a pane: made once here (cheap: one diagonal per component) so that its errors show now */
        bst_layer *l = NULL;
        bst_glass *pane = NULL;
        rc = make_layer(ctx, sub, specs[i], specs[i], NULL, basis, nch, chnames, choice->at_centre,
                        &l, &pane);
        bst_layer_free(l);
        bst_glass_free(pane);
        structure[i] = CLI_DIAGONAL;
    }
    for (size_t i = 0; i < n; i++)
        bst_bsdf_free(files[i]);
    free(files);
    free(chcopy);
    bst_basis_free(basis);
    return rc;
}

int cli_basis_make(bst_ctx *ctx, const char *sub, const struct cli_basis_pick *pick, char **specs,
                   const char *channels, bst_precision prec, bst_basis **basis)
{
    int st;
    *basis = NULL;
    if (pick->klems[0])
        st = bst_basis_new_klems(ctx, pick->klems, basis);
    else if (pick->k)
        st = bst_basis_new_sc(ctx, pick->k, basis);
    else {
        char *chcopy = channels ? strdup(channels) : NULL;
        const char *chnames[MAX_CH];
        size_t nch = chcopy ? split(chcopy, chnames, MAX_CH) : 0;
        bst_bsdf_read_opts ro = {.nchannels = nch, .channels = chnames, .precision = prec};
        bst_bsdf *file = NULL;
        int rc = channels && !chcopy ? cli_fail(sub, "out of memory")
                                     : read_one(ctx, sub, NULL, specs[pick->file], &ro, 1, &file);
        free(chcopy);
        if (rc != CLI_OK)
            return rc;
        st = bst_basis_copy(ctx, bst_bsdf_klems_basis(file), basis);
        bst_bsdf_free(file);
    }
    return st < 0 ? cli_fail_ctx(sub, NULL, ctx) : CLI_OK;
}

int cli_layer_load(bst_ctx *ctx, const char *sub, const char *what, const char *spec,
                   const bst_basis *basis, const struct cli_basis_choice *choice,
                   const char *channels, bst_precision prec, bst_layer **layer, bst_glass **pane)
{
    char *chcopy = channels ? strdup(channels) : NULL;
    const char *chnames[MAX_CH];
    size_t nch = chcopy ? split(chcopy, chnames, MAX_CH) : 0;
    bst_bsdf_read_opts ro = {.nchannels = nch, .channels = chnames, .precision = prec};
    bst_bsdf *file = NULL;
    int rc = channels && !chcopy ? cli_fail(sub, "out of memory") : CLI_OK;
    *layer = NULL;
    *pane = NULL;
    if (rc == CLI_OK && !is_glass(spec))
        rc = read_one(ctx, sub, what, spec, &ro, 1, &file);
    if (rc == CLI_OK)
        rc = make_layer(ctx, sub, what, spec, file, basis, nch, chnames, choice->at_centre, layer, pane);
    free(chcopy);
    return rc;
}

/* cli_write_layer, and cli_write_varres when v is set (l the coarse system). */
static int write_any(bst_ctx *ctx, const char *sub, const bst_layer *l, const bst_varres *v,
                     const char *path, const struct cli_reduce *reduce, int argc, char **argv,
                     const struct cli_layers *set)
{
    size_t len = 64 + (set && set->description ? strlen(set->description) : 0);
    for (int i = 0; i < argc; i++)
        len += strlen(argv[i]) + 1;
    char *desc = malloc(len);
    if (!desc)
        return cli_fail(sub, "out of memory");
    snprintf(desc, len, "%s\ncommand: bsdfstack", set && set->description ? set->description : "");
    for (int i = 0; i < argc; i++) {
        if (cli_threads_arg(argc, argv, &i)) /* changes no output byte: not recorded */
            continue;
        strcat(desc, " ");
        strcat(desc, argv[i]);
    }
    bst_bsdf_write_opts wo;
    bst_bsdf_write_opts_init(&wo);
    wo.reduce_pct = reduce->pct;
    wo.reduce_tol = reduce->tol;
    wo.description = desc;
    char date[64];
    struct cli_out out;
    int rc = cli_source_date(sub, date, sizeof date, &wo.date);
    if (rc == CLI_OK)
        rc = cli_out_open(&out, sub, path);
    if (rc == CLI_OK) {
        int st = v ? bst_bsdf_write_varres(ctx, l, v, out.fp, &wo) : bst_bsdf_write(ctx, l, out.fp, &wo);
        if (st < 0) {
            rc = cli_out_fail_ctx(&out, sub, ctx);
        } else {
            rc = cli_out_commit(&out, sub);
        }
    }
    free(desc);
    return rc;
}

int cli_parse_reduce_tol(const char *sub, const char *arg, double *tol)
{
    if (strcmp(arg, "none") == 0) {
        *tol = INFINITY;
        return CLI_OK;
    }
    if (cli_parse_double(arg, tol) || !(*tol >= 0.0) || !isfinite(*tol))
        return cli_usage(sub, "--reduce-tol %s: a directional-hemispherical change >= 0 (e.g. "
                         "0.002), or none", arg);
    return CLI_OK;
}

int cli_source_date(const char *sub, char *buf, size_t size, const char **date)
{
    *date = NULL;
    const char *epoch = getenv("SOURCE_DATE_EPOCH");
    if (!epoch || !*epoch)
        return CLI_OK;
    char *end;
    errno = 0;
    long long secs = strtoll(epoch, &end, 10);
    time_t t = (time_t)secs;
    struct tm tm;
    if (epoch[0] >= '0' && epoch[0] <= '9' && *end == '\0' && errno == 0 &&
        secs <= LAST_SOURCE_DATE && gmtime_r(&t, &tm) && strftime(buf, size, "%Y-%m-%dT%H:%M:%SZ", &tm)) {
        *date = buf;
        return CLI_OK;
    }
    char shown[64];
    snprintf(shown, sizeof shown, "%s", epoch); /* cut, so that the reason is seen */
    return cli_fail(sub, "SOURCE_DATE_EPOCH '%s'%s is not a whole number of seconds since 1970 "
                    "(0 to %lld): unset it or give one", shown, strlen(epoch) >= sizeof shown ? "..." : "",
                    (long long)LAST_SOURCE_DATE);
}

int cli_write_layer(bst_ctx *ctx, const char *sub, const bst_layer *l, const char *path,
                    const struct cli_reduce *reduce, int argc, char **argv, const struct cli_layers *set)
{
    return write_any(ctx, sub, l, NULL, path, reduce, argc, argv, set);
}

int cli_write_varres(bst_ctx *ctx, const char *sub, const bst_layer *coarse, const bst_varres *v,
                     const char *path, const struct cli_reduce *reduce, int argc, char **argv,
                     const struct cli_layers *set)
{
    return write_any(ctx, sub, coarse, v, path, reduce, argc, argv, set);
}

/* A layer read from a file (not a pane: its name is not glass:...). */
static int is_file_layer(const bst_layer *l)
{
    const char *name = bst_layer_name(l);
    return !name || strncmp(name, "glass:", 6) != 0;
}

int cli_spectral_plan(bst_ctx *ctx, const char *sub, struct cli_layers *set, int per_channel,
                      char *why, size_t size)
{
    bst_plan_layer *pl = calloc(set->n + 1, sizeof *pl);
    if (!pl) {
        cli_fail(sub, "out of memory");
        return -1;
    }
    for (size_t i = 0; i < set->n; i++)
        pl[i] = (bst_plan_layer){set->layers[i], set->panes[i], is_file_layer(set->layers[i])};
    int spectral = 0, st = bst_plan_spectral(ctx, set->n, pl, per_channel, why, size, &spectral,
                                             &set->plan_warn);
    free(pl);
    if (st < 0) {
        cli_fail_ctx(sub, NULL, ctx);
        return -1;
    }
    return spectral;
}

int cli_combine_spectral(bst_ctx *ctx, const char *sub, const struct cli_layers *set,
                         const bst_spectral_opts *sp, const bst_stack_opts *so, double *abs[2],
                         bst_layer **sys)
{
    const char **names = malloc((bst_layer_nchannels(set->layers[0]) + 1) * sizeof *names);
    bst_spectral_layer *l = calloc(set->n, sizeof *l);
    if (!names || !l) {
        free(names), free(l);
        return cli_fail(sub, "out of memory");
    }
    size_t nch = bst_plan_channels(set->n, (const bst_layer *const *)set->layers, names);
    for (size_t i = 0; i < set->n; i++) {
        l[i].pane = set->panes[i];
        l[i].bands = set->panes[i] ? NULL : set->layers[i];
    }
    int st = bst_stack_combine_spectral_layers(ctx, set->n, l, set->basis, nch, names, sp, so,
                                               sys, abs[0], abs[1]);
    free(names), free(l);
    if (st < 0)
        return cli_fail_ctx(sub, "combining per wavelength", ctx);
    cli_warn_ctx(sub, NULL, st, ctx);
    return CLI_OK;
}

int cli_columns_spectral(bst_ctx *ctx, const char *sub, const struct cli_layers *set,
                         const bst_spectral_opts *sp, const char *channel, size_t ncols,
                         const size_t *cols, bst_columns_opts *o, bst_mat **tf, bst_mat **rf)
{
    bst_spectral_layer *l = calloc(set->n, sizeof *l);
    if (!l)
        return cli_fail(sub, "out of memory");
    for (size_t i = 0; i < set->n; i++) {
        l[i].pane = set->panes[i];
        l[i].bands = set->panes[i] ? NULL : set->layers[i];
    }
    int st = bst_stack_columns_spectral_layers(ctx, set->n, l, set->basis, channel, sp, ncols, cols,
                                               o, tf, rf);
    free(l);
    if (st < 0)
        return cli_fail_ctx(sub, "iterating per wavelength", ctx);
    cli_warn_ctx(sub, NULL, st, ctx);
    return CLI_OK;
}

int cli_note_spectral(const char *sub, struct cli_layers *set, const char *why, int verbose)
{
    if (verbose)
        fprintf(stderr, "bsdfstack %s: spectral: %s\n", sub, why);
    else if (set->plan_warn) /* not what a user of --channels Solar expects: say so */
        fprintf(stderr, "bsdfstack %s: warning: %s\n", sub, why);
    char *d = realloc(set->description, strlen(set->description) + strlen(why) + 12);
    if (!d)
        return cli_fail(sub, "out of memory");
    strcat(d, "\nspectral: ");
    strcat(d, why);
    set->description = d;
    return CLI_OK;
}
