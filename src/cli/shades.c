/* shades.c - layers made from a shade's geometry, `venetian:`, `perforated:` and `woven:` specs
 * (bsdfstack-glass(5)), for the loader (layers.c): one table of the kinds, each with its parser,
 * its layer and whether it scatters (then its layer is dense, for the memory guard and the
 * batch's cost order). */
#include <config.h>

#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "layers.h"

union shade {
    bst_venetian v;
    bst_perforated p;
    bst_woven w;
};

static int venetian_parse(bst_ctx *c, const char *s, union shade *u)
{
    bst_venetian_init(&u->v);
    return bst_venetian_parse(c, s, &u->v);
}
static int venetian_layer(bst_ctx *c, const union shade *u, const bst_basis *b, size_t n,
                          const char *const *ch, bst_layer **l)
{
    return bst_venetian_layer(c, &u->v, b, n, ch, l);
}
static int venetian_scatters(const union shade *u)
{
    int d = u->v.r_up > 0 || u->v.r_down > 0 || u->v.t > 0;
    for (int k = 0; k < 3; k++)
        d |= u->v.solar[k] > 0; /* the Solar channel's r-up, r-down, t */
    return d;
}

static int perforated_parse(bst_ctx *c, const char *s, union shade *u)
{
    return bst_perforated_parse(c, s, &u->p);
}
static int perforated_layer(bst_ctx *c, const union shade *u, const bst_basis *b, size_t n,
                            const char *const *ch, bst_layer **l)
{
    return bst_perforated_layer(c, &u->p, b, n, ch, l);
}
static int perforated_scatters(const union shade *u)
{
    return u->p.rf > 0 || u->p.rb > 0 || u->p.t > 0 || u->p.solar[0] > 0 || u->p.solar[1] > 0 ||
           u->p.solar[2] > 0;
}

static int woven_parse(bst_ctx *c, const char *s, union shade *u)
{
    return bst_woven_parse(c, s, &u->w);
}
static int woven_layer(bst_ctx *c, const union shade *u, const bst_basis *b, size_t n,
                       const char *const *ch, bst_layer **l)
{
    return bst_woven_layer(c, &u->w, b, n, ch, l);
}
static int woven_scatters(const union shade *u)
{
    return u->w.rf > 0 || u->w.rb > 0 || u->w.t > 0 || u->w.solar[0] > 0 || u->w.solar[1] > 0 ||
           u->w.solar[2] > 0;
}

static const struct kind {
    const char *prefix;
    int (*parse)(bst_ctx *, const char *, union shade *);
    int (*layer)(bst_ctx *, const union shade *, const bst_basis *, size_t, const char *const *,
                 bst_layer **);
    int (*scatters)(const union shade *);
    bst_structure clear; /* the structure of a shade that scatters nothing */
} kinds[] = {
    {"venetian:", venetian_parse, venetian_layer, venetian_scatters, BST_SPARSE},
    {"perforated:", perforated_parse, perforated_layer, perforated_scatters, BST_DIAG},
    {"woven:", woven_parse, woven_layer, woven_scatters, BST_DIAG},
};
#define NKINDS (sizeof kinds / sizeof kinds[0])

static const struct kind *kind_of(const char *spec)
{
    for (size_t i = 0; i < NKINDS; i++)
        if (strncmp(spec, kinds[i].prefix, strlen(kinds[i].prefix)) == 0)
            return &kinds[i];
    return NULL;
}

int cli_is_shade(const char *spec)
{
    return kind_of(spec) != NULL;
}

/* The spec's description (its prefix and a trailing ^ dropped) parsed into *u. */
static int parse(bst_ctx *ctx, const struct kind *k, const char *spec, union shade *u)
{
    size_t len = strlen(spec), pl = strlen(k->prefix);
    int flip = len > pl && spec[len - 1] == '^';
    char *d = strndup(spec + pl, len - pl - (size_t)flip);
    memset(u, 0, sizeof *u);
    int st = d ? k->parse(ctx, d, u) : BST_ENOMEM;
    free(d);
    return st;
}

int cli_shade_layer(bst_ctx *ctx, const char *spec, const bst_basis *basis, size_t nch,
                    const char **chnames, bst_layer **l)
{
    const struct kind *k = kind_of(spec);
    union shade u;
    int st = parse(ctx, k, spec, &u);
    return st < 0 ? st : k->layer(ctx, &u, basis, nch, nch ? chnames : NULL, l);
}

int cli_shade_check(bst_ctx *ctx, const char *spec, bst_structure *structure)
{
    const struct kind *k = kind_of(spec);
    union shade u;
    int st = parse(ctx, k, spec, &u);
    *structure = st >= 0 && k->scatters(&u) ? BST_DENSE : k->clear;
    return st;
}
