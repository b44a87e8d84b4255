/* layers.c - loading a stack's layers (layers.h): files read, the basis picked by the library's
 * rule (bst_plan_pick_basis), the memory guard, each layer made over the basis (glass:,
 * venetian:, perforated: and woven: specs, reversed layers), and the checks a batch makes before its first stack. */
#include <config.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "cli.h"
#include "layers.h"

#define MAX_CH 16
/* A spectral pane's layer costs its wavelengths times the angles it averages over (about 0.5 ms a
 * wavelength at k = 5 on one core, glass_layer.c): past this many, a warning says so first. */
#define CLI_MANY_WAVELENGTHS 5000
#define CLI_CATALOGUE_WAVELENGTHS 113 /* NFRC 102's data rows, for scale */

/* Split "a,b,c" into at most max names (pointers into a copy the caller frees). */
static size_t split(char *s, const char **out, size_t max)
{
    size_t n = 0;
    char *save = NULL;
    for (char *t = strtok_r(s, ",", &save); t && n < max; t = strtok_r(NULL, ",", &save))
        out[n++] = t;
    return n;
}

void cli_layers_free(struct cli_layers *set)
{
    if (!set)
        return;
    for (size_t i = 0; i < set->n; i++) {
        bst_layer_free(set->layers[i]);
        if (set->panes)
            bst_glass_free(set->panes[i]);
        if (set->notes)
            free(set->notes[i]);
    }
    free(set->notes);
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


size_t cli_spec_reversed(const char *spec, int *reversed)
{
    size_t len = strlen(spec);
    int r = len > 0 && spec[len - 1] == '^';
    if (reversed)
        *reversed = r;
    return len - (size_t)r;
}

static int is_glass(const char *spec)
{
    return strncmp(spec, "glass:", 6) == 0;
}

/* A layer made from a spec rather than read from a file. */
static int is_made(const char *spec)
{
    return is_glass(spec) || cli_is_shade(spec);
}

/* The name messages about spec i go by: what (NULL: the message names the spec itself), after
 * the place the spec was given (choice->where, "FILE:LINE") where there is one; in buf. */
static const char *named(const struct cli_basis_choice *choice, size_t i, const char *what,
                         char *buf, size_t size)
{
    if (!choice || !choice->where)
        return what;
    snprintf(buf, size, "%s%s%s", choice->where[i], what ? ": " : "", what ? what : "");
    return buf;
}

/* Read the file a spec names (a trailing ^ dropped) into *file, printing the reader's warnings
 * unless quiet, and give it the choice's rank-3 rule (choice may be NULL: the default).  Messages
 * name `what`, or the file when what is NULL. */
static int read_one(bst_ctx *ctx, const char *sub, const char *what, const char *spec,
                    const bst_bsdf_read_opts *ro, const struct cli_basis_choice *choice, int quiet,
                    bst_bsdf **file)
{
    char *path = strndup(spec, cli_spec_reversed(spec, NULL));
    if (!path)
        return cli_fail(sub, "out of memory");
    int rc = CLI_OK, st = bst_bsdf_read(ctx, path, ro, file);
    if (st < 0)
        rc = cli_fail_ctx(sub, what, ctx);
    else if (quiet)
        bst_ctx_clear(ctx);
    else if (st == BST_WDATA)
        cli_warn_zero_components(sub, path, *file, ro->comps, "taken", ctx);
    else
        cli_warn_ctx(sub, what, st, ctx);
    if (rc == CLI_OK && choice && bst_bsdf_set_rank3_rule(ctx, *file, choice->rank3) < 0)
        rc = cli_fail_ctx(sub, what, ctx);
    free(path);
    return rc;
}

/* Steps 1 and 2 of loading: every file among specs read into files[i] (NULL for glass:), and the
 * basis chosen (the finest tree order, else the first Klems file's basis, else k = 5, unless the
 * choice names one), told in *pick; then the memory guard over all of them, the layers made
 * from shade specs as their models will make them. */
static int read_all(bst_ctx *ctx, const char *sub, size_t n, char **specs,
                    const struct cli_basis_choice *choice, const bst_bsdf_read_opts *ro,
                    bst_precision prec, bst_bsdf **files, bst_basis **basis, struct cli_basis_pick *pick)
{
    int rc = CLI_OK;
    char what[4200];
    for (size_t i = 0; i < n && rc == CLI_OK; i++)
        if (!is_made(specs[i]))
            rc = read_one(ctx, sub, named(choice, i, NULL, what, sizeof what), specs[i], ro, choice,
                          0, &files[i]);
    if (rc != CLI_OK)
        return rc;
    bst_plan_basis plan; /* the library's rule (plan.c) */
    bst_plan_pick_basis(n, (const bst_bsdf *const *)files, NULL, choice->k, choice->klems, &plan);
    if (choice->combining && plan.note[0])
        fprintf(stderr, "bsdfstack %s: warning: %s\n", sub, plan.note);
    memset(pick, 0, sizeof *pick);
    pick->k = plan.k;
    pick->file = plan.file;
    snprintf(pick->why, sizeof pick->why, "%s", plan.why);
    if (plan.klems)
        snprintf(pick->klems, sizeof pick->klems, "%s", plan.klems);
    if (bst_plan_make_basis(ctx, &plan, n, (const bst_bsdf *const *)files, NULL, basis) < 0)
        return cli_fail_ctx(sub, NULL, ctx);
    /* what each layer will hold: a file's components, a shade's as its model makes them (a
     * pane's are diagonal) */
    bst_plan_held *held = calloc(n, sizeof *held);
    if (!held)
        return cli_fail(sub, "out of memory");
    for (size_t i = 0; i < n && rc == CLI_OK; i++) {
        held[i].file = files[i];
        if (cli_is_shade(specs[i]) &&
            cli_shade_plan(ctx, specs[i], *basis, ro->nchannels, ro->channels, prec, &held[i]) < 0)
            rc = cli_fail_ctx(sub, named(choice, i, specs[i], what, sizeof what), ctx);
    }
    if (rc == CLI_OK)
        rc = cli_memory_check_held(sub, *basis, n, held, ro->comps, prec, choice);
    free(held);
    return rc;
}

/* Step 3 for one spec: its layer over basis from the file read (file, freed here) or from the
 * glass: spec, reversed where it ends in ^, named by the spec; a spectral pane not reversed also
 * goes to *pane (else NULL).  Errors name `what`. */
/* A spectral pane of many rows: one line before its layer is built, saying which channels sum the
 * model over groups of adjacent wavelengths (bst_glass_layer_nodes) and how many, or, when every
 * wavelength is summed (rows=all, or no grouping agreed), what that costs. */
static void warn_rows(const char *sub, const char *what, const bst_glass *g, size_t nch,
                      const char **chnames)
{
    char grouped[512] = "";
    size_t len = 0, most = 0, nodes = 0;
    for (size_t c = 0; c < (nch ? nch : bst_glass_nchannels(g)); c++) {
        int ch = nch ? bst_glass_find_channel(g, chnames[c]) : (int)c;
        size_t rows, n = ch >= 0 ? bst_glass_layer_nodes(g, (size_t)ch, &rows) : 0;
        most = ch >= 0 && rows > most ? rows : most;
        if (ch >= 0 && n < rows && len < sizeof grouped - 64) {
            len += (size_t)snprintf(grouped + len, sizeof grouped - len, "%s%s's %zu", len ? ", " : "",
                                    bst_glass_channel(g, (size_t)ch), rows);
            nodes = n;
        }
    }
    if (len)
        fprintf(stderr, "bsdfstack %s: warning: %s: its layer sums the model over %zu groups of "
                "adjacent wavelengths (each at their weighted mean data) instead of %s wavelengths "
                "one by one; rows=all after the file name takes each, at %.0f times a catalogue "
                "pane's cost\n", sub, what, nodes, grouped, (double)most / CLI_CATALOGUE_WAVELENGTHS);
    else if (most > CLI_MANY_WAVELENGTHS) /* the cost grows with them: say so before */
        fprintf(stderr, "bsdfstack %s: warning: %s: %zu wavelengths: the pane is evaluated at "
                "each of them at every angle its layer averages (rows=all, or data too uneven for "
                "groups of adjacent wavelengths to agree), %.0f times the work of a catalogue "
                "pane's %d\n", sub, what, most,
                (double)most / CLI_CATALOGUE_WAVELENGTHS, CLI_CATALOGUE_WAVELENGTHS);
}

static int make_layer(bst_ctx *ctx, const char *sub, const char *what, const char *spec,
                      bst_bsdf *file, const bst_basis *basis, size_t nch, const char **chnames,
                      bst_precision prec, int at_centre, bst_layer **out, bst_glass **pane,
                      char **note)
{
    int flip, st;
    size_t len = cli_spec_reversed(spec, &flip);
    bst_layer *l = NULL;
    *out = NULL;
    *pane = NULL;
    if (file) {
        st = bst_bsdf_to_layer(ctx, file, basis, &l);
        bst_bsdf_free(file);
    } else if (cli_is_shade(spec)) {
        st = cli_shade_layer(ctx, spec, basis, nch, chnames, prec, &l);
    } else {
        char *gspec = strndup(spec + 6, len - 6);
        bst_glass *g = NULL;
        /* spectral data without bands averaged over the bands asked for (Visible alone: data
           that cover only the visible) */
        st = gspec ? bst_glass_parse_bands(ctx, gspec, getenv("BSDFSTACK_GLASS_DIR"), nch,
                                           chnames, &g)
                   : BST_ENOMEM;
        /* a spectral pane is averaged over any further band asked for (CIE-X, ...) */
        for (size_t c = 0; st >= 0 && c < nch; c++)
            if (bst_glass_find_channel(g, chnames[c]) < 0 && bst_glass_nwavelengths(g) &&
                bst_plan_is_band(chnames[c]))
                st = bst_glass_add_channel(ctx, g, chnames[c]);
        if (st >= 0)
            warn_rows(sub, what ? what : spec, g, nch, chnames);
        if (st >= 0)
            st = bst_glass_layer(ctx, g, basis, nch, nch ? chnames : NULL, at_centre, &l);
        if (st >= 0 && note) { /* the pane's model, source and metadata, for the output's header */
            char buf[1024];
            cli_glass_summary(g, buf, sizeof buf);
            if (!(*note = strdup(buf))) {
                bst_layer_free(l), bst_glass_free(g), free(gspec);
                return cli_fail(sub, "out of memory");
            }
        }
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

int cli_note_panes(const char *sub, char **description, const struct cli_layers *all, size_t n,
                   const size_t *idx, char *const *specs)
{
    for (size_t j = 0; all->notes && j < n; j++) {
        const char *note = all->notes[idx ? idx[j] : j], *spec = specs[idx ? idx[j] : j];
        if (!note)
            continue;
        size_t len = strlen(*description), more = strlen(spec) + strlen(note) + 48;
        char *d = realloc(*description, len + more);
        if (!d)
            return cli_fail(sub, "out of memory");
        snprintf(d + len, more, "\nlayer %zu %s: %s", j + 1, spec, note);
        *description = d;
    }
    return CLI_OK;
}

int cli_layers_load(struct cli_layers *set, bst_ctx *ctx, const char *sub, size_t n, char **specs,
                    const struct cli_basis_choice *choice, const char *channels,
                    unsigned comps, bst_precision prec)
{
    memset(set, 0, sizeof *set);
    set->layers = calloc(n, sizeof *set->layers);
    set->panes = calloc(n, sizeof *set->panes);
    set->notes = calloc(n, sizeof *set->notes);
    bst_bsdf **files = calloc(n, sizeof *files);
    char *chcopy = channels ? strdup(channels) : NULL;
    const char *chnames[MAX_CH];
    size_t nch = chcopy ? split(chcopy, chnames, MAX_CH) : 0;
    size_t desc_len = 64;
    for (size_t i = 0; i < n; i++)
        desc_len += strlen(specs[i]) + 4;
    set->description = malloc(desc_len);
    int rc = CLI_OK;
    if (!set->layers || !set->panes || !set->notes || !files || !set->description ||
        (channels && !chcopy)) {
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
    snprintf(set->basis_why, sizeof set->basis_why, "%s", pick.why);
    /* 3. every layer over that basis, reversed where asked */
    char what[4200];
    for (size_t i = 0; i < n && rc == CLI_OK; i++) {
        rc = make_layer(ctx, sub, named(choice, i, specs[i], what, sizeof what), specs[i], files[i],
                        set->basis, nch, chnames, prec, choice->at_centre, &set->layers[i],
                        &set->panes[i], &set->notes[i]);
        files[i] = NULL;
        if (rc == CLI_OK) {
            set->npanes += set->panes[i] != NULL;
            set->n++;
        }
    }
    if (rc == CLI_OK)
        rc = cli_note_panes(sub, &set->description, set, n, NULL, specs);
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
                     bst_precision prec, struct cli_basis_pick *pick, bst_structure *structure)
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
            structure[i] = fill > BST_SPARSE_MAX_FILL ? BST_DENSE : fill > 0 ? BST_SPARSE : BST_DIAG;
            continue;
        }
        char what[4200];
        if (cli_is_shade(specs[i])) { /* its errors show now; dense when it scatters */
            if (cli_shade_check(ctx, specs[i], &structure[i]) < 0)
                rc = cli_fail_ctx(sub, named(choice, i, specs[i], what, sizeof what), ctx);
            continue;
        }
        /* a pane: made once here (cheap: one diagonal per component) so that its errors show now */
        bst_layer *l = NULL;
        bst_glass *pane = NULL;
        rc = make_layer(ctx, sub, named(choice, i, specs[i], what, sizeof what), specs[i], NULL, basis,
                        nch, chnames, prec, choice->at_centre, &l, &pane, NULL);
        bst_layer_free(l);
        bst_glass_free(pane);
        structure[i] = BST_DIAG;
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
    *basis = NULL;
    bst_plan_basis plan = {.k = pick->k, .klems = pick->klems[0] ? pick->klems : NULL,
                           .file = pick->file, .given = -1};
    /* the plan's basis made as the picking process made it: only the named file is read */
    size_t n = pick->file >= 0 ? (size_t)pick->file + 1 : 0;
    bst_bsdf **files = n ? calloc(n, sizeof *files) : NULL;
    int rc = n && !files ? cli_fail(sub, "out of memory") : CLI_OK;
    if (rc == CLI_OK && n) {
        char *chcopy = channels ? strdup(channels) : NULL;
        const char *chnames[MAX_CH];
        size_t nch = chcopy ? split(chcopy, chnames, MAX_CH) : 0;
        bst_bsdf_read_opts ro = {.nchannels = nch, .channels = chnames, .precision = prec};
        rc = channels && !chcopy ? cli_fail(sub, "out of memory")
                                 : read_one(ctx, sub, NULL, specs[n - 1], &ro, NULL, 1, &files[n - 1]);
        free(chcopy);
    }
    if (rc == CLI_OK && bst_plan_make_basis(ctx, &plan, n, (const bst_bsdf *const *)files, NULL,
                                            basis) < 0)
        rc = cli_fail_ctx(sub, NULL, ctx);
    if (files)
        bst_bsdf_free(files[n - 1]);
    free(files);
    return rc;
}

int cli_layer_load(bst_ctx *ctx, const char *sub, const char *what, const char *spec,
                   const bst_basis *basis, const struct cli_basis_choice *choice,
                   const char *channels, bst_precision prec, bst_layer **layer, bst_glass **pane,
                   char **note)
{
    char *chcopy = channels ? strdup(channels) : NULL;
    const char *chnames[MAX_CH];
    size_t nch = chcopy ? split(chcopy, chnames, MAX_CH) : 0;
    bst_bsdf_read_opts ro = {.nchannels = nch, .channels = chnames, .precision = prec};
    bst_bsdf *file = NULL;
    int rc = channels && !chcopy ? cli_fail(sub, "out of memory") : CLI_OK;
    *layer = NULL;
    *pane = NULL;
    if (rc == CLI_OK && !is_made(spec))
        rc = read_one(ctx, sub, what, spec, &ro, choice, 1, &file);
    if (rc == CLI_OK)
        rc = make_layer(ctx, sub, what, spec, file, basis, nch, chnames, prec, choice->at_centre, layer,
                        pane, note);
    free(chcopy);
    return rc;
}
