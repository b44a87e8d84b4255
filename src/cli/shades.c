/* shades.c - layers made from a shade's geometry, `venetian:`, `perforated:`, `woven:` specs and
 * IGSDB shading records as `shade:FILE.json[,KEY=VALUE...]` (bsdfstack-glass(5)), for the loader
 * (layers.c): the library parses each (bst_shade_parse: a record's band values need the band
 * spectra of the glass catalogue, $BSDFSTACK_GLASS_DIR or the library's) and tells here whether
 * the shade scatters (then its layer is dense, for the memory guard and the batch's cost order). */
#include <config.h>

#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "layers.h"

static const char *const prefixes[] = {"venetian:", "perforated:", "woven:", "shade:"};
#define NPREFIXES (sizeof prefixes / sizeof prefixes[0])

int cli_is_shade(const char *spec)
{
    for (size_t i = 0; i < NPREFIXES; i++)
        if (strncmp(spec, prefixes[i], strlen(prefixes[i])) == 0)
            return 1;
    return 0;
}

/* Whether any channel's diffuse values are not all zero (the layer is then dense). */
static int scatters(const bst_shade_model *m)
{
    const double *sol;
    double d[3];
    if (m->kind == BST_SHADE_VENETIAN) {
        const bst_venetian *b = &m->venetian;
        d[0] = b->r_up, d[1] = b->r_down, d[2] = b->t, sol = b->solar; /* solar[3] is rs */
    } else if (m->kind == BST_SHADE_PERFORATED) {
        d[0] = m->perforated.rf, d[1] = m->perforated.rb, d[2] = m->perforated.t;
        sol = m->perforated.solar;
    } else {
        d[0] = m->woven.rf, d[1] = m->woven.rb, d[2] = m->woven.t, sol = m->woven.solar;
    }
    for (int k = 0; k < 3; k++)
        if (d[k] > 0 || sol[k] > 0)
            return 1;
    return 0;
}

/* The spec (a trailing ^ dropped) parsed into *m. */
int cli_shade_parse(bst_ctx *ctx, const char *spec, bst_shade_model *m)
{
    char *d = strndup(spec, cli_spec_reversed(spec, NULL));
    int st = d ? bst_shade_parse(ctx, d, getenv("BSDFSTACK_GLASS_DIR"), m) : BST_ENOMEM;
    free(d);
    return st;
}

/* The spec parsed, a dense blind's components to be made in precision prec. */
static int parse_at(bst_ctx *ctx, const char *spec, bst_precision prec, bst_shade_model *m)
{
    int st = cli_shade_parse(ctx, spec, m);
    if (st >= 0 && m->kind == BST_SHADE_VENETIAN)
        m->venetian.precision = prec;
    return st;
}

int cli_shade_layer(bst_ctx *ctx, const char *spec, const bst_basis *basis, size_t nch,
                    const char **chnames, bst_precision prec, bst_layer **l)
{
    bst_shade_model m;
    int st = parse_at(ctx, spec, prec, &m);
    return st < 0 ? st : bst_shade_model_layer(ctx, &m, basis, nch, nch ? chnames : NULL, l);
}

int cli_shade_check(bst_ctx *ctx, const char *spec, bst_structure *structure)
{
    bst_shade_model m;
    int st = cli_shade_parse(ctx, spec, &m);
    /* mirror and black slats are sparse, an open sheet's direct light diagonal */
    *structure = st >= 0 && scatters(&m) ? BST_DENSE
                 : st >= 0 && m.kind == BST_SHADE_VENETIAN ? BST_SPARSE : BST_DIAG;
    return st;
}

int cli_shade_plan(bst_ctx *ctx, const char *spec, const bst_basis *basis, size_t nch,
                   const char *const *chnames, bst_precision prec, bst_plan_held *held)
{
    bst_shade_model m;
    int st = parse_at(ctx, spec, prec, &m);
    return st < 0 ? st : bst_shade_model_plan(ctx, &m, basis, nch, nch ? chnames : NULL, held);
}
