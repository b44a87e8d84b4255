/* ttree.c - tensor trees: a streaming parser of the ScatteringData text, lookup, expansion onto a
 * regular grid (that in ttree_expand.c).  Conventions in ttree.h.
 *
 * The parser never holds the text: it tokenizes each chunk as it arrives, keeping at most one
 * partial number between chunks, and appends leaf values to one float array, so the tree costs
 * 4 bytes per stored value plus 8 per node. */
#include <config.h>

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ctx.h"
#include "numtext.h"
#include "ttree.h"

/* Deepest nesting accepted (k <= 16 with one-value leaves). */
#define TT_MAX_NESTING 20
#define TT_TOKEN_MAX 64

struct open_node {
    uint32_t id;
    uint32_t kids[16];
    int nkids;
    size_t value0; /* first value of this node */
    size_t nvalues;
};

struct bsti_tparse {
    bst_ctx *ctx;
    bsti_ttree *t;
    struct open_node stack[TT_MAX_NESTING + 1];
    int top;          /* number of open nodes */
    int closed_root;
    char tok[TT_TOKEN_MAX + 1];
    int ntok;
    size_t failed_at; /* the offset in the last chunk fed of what failed in it */
};

static int grow(bst_ctx *ctx, void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return BST_OK;
    size_t nc = *cap ? *cap : 1024;
    while (nc < need)
        nc *= 2;
    void *q = bsti_alloc_array(ctx, nc, elem);
    if (!q)
        return BST_ENOMEM;
    if (*p)
        memcpy(q, *p, *cap * elem);
    bsti_free(ctx, *p);
    *p = q;
    *cap = nc;
    return BST_OK;
}

int bsti_tparse_new(bst_ctx *ctx, int dim, bsti_tparse **out)
{
    *out = NULL;
    if (dim != 3 && dim != 4)
        return bsti_error(ctx, BST_EINVAL, "tensor tree of rank %d (3 or 4 expected)", dim);
    bsti_tparse *p = bsti_calloc(ctx, 1, sizeof *p);
    if (!p)
        return BST_ENOMEM;
    p->ctx = ctx;
    if (!(p->t = bsti_calloc(ctx, 1, sizeof *p->t))) {
        bsti_free(ctx, p);
        return BST_ENOMEM;
    }
    p->t->ctx = ctx;
    p->t->dim = dim;
    *out = p;
    return BST_OK;
}

void bsti_ttree_free(bsti_ttree *t)
{
    if (!t)
        return;
    bsti_free(t->ctx, t->nodes);
    bsti_free(t->ctx, t->kids);
    bsti_free(t->ctx, t->values);
    bsti_free(t->ctx, t);
}

void bsti_tparse_free(bsti_tparse *p)
{
    if (!p)
        return;
    bsti_ttree_free(p->t);
    bsti_free(p->ctx, p);
}

static int open_node(bsti_tparse *p)
{
    bsti_ttree *t = p->t;
    if (p->closed_root)
        return bsti_error(p->ctx, BST_EFORMAT, "text after the root node of the tree");
    if (p->top > 0 && p->stack[p->top - 1].nvalues)
        return bsti_error(p->ctx, BST_EFORMAT, "a tree node mixes values and child nodes");
    if (p->top >= TT_MAX_NESTING)
        return bsti_error(p->ctx, BST_EFORMAT, "tree nesting deeper than %d", TT_MAX_NESTING);
    if (p->top > 0 && p->stack[p->top - 1].nkids >= (1 << t->dim))
        return bsti_error(p->ctx, BST_EFORMAT, "a branch has more than %d children", 1 << t->dim);
    if (t->nnodes >= UINT32_MAX - 1)
        return bsti_error(p->ctx, BST_EFORMAT, "tree has too many nodes");
    int rc = grow(p->ctx, (void **)&t->nodes, &t->cap_nodes, t->nnodes + 1, sizeof *t->nodes);
    if (rc < 0)
        return rc;
    struct open_node *o = &p->stack[p->top++];
    o->id = (uint32_t)t->nnodes++;
    o->nkids = 0;
    o->value0 = t->nvalues;
    o->nvalues = 0;
    memset(&t->nodes[o->id], 0, sizeof t->nodes[o->id]);
    return BST_OK;
}

static int close_node(bsti_tparse *p)
{
    bsti_ttree *t = p->t;
    if (p->top == 0)
        return bsti_error(p->ctx, BST_EFORMAT, "'}' without a matching '{' in the tree");
    struct open_node *o = &p->stack[p->top - 1];
    struct bsti_tnode *n = &t->nodes[o->id];
    int depth = p->top - 1; /* the root is at depth 0 */
    if (o->nvalues) {
        /* 2^(dim L) values */
        int level = 0;
        size_t cells = 1;
        while (cells < o->nvalues && level < 16) {
            cells <<= t->dim;
            level++;
        }
        if (cells != o->nvalues)
            return bsti_error(p->ctx, BST_EFORMAT, "a tree leaf holds %zu values, not a power of %d",
                              o->nvalues, 1 << t->dim);
        n->leaf = 1;
        n->level = (uint8_t)level;
        n->first = (uint32_t)o->value0;
        if (depth + level > t->depth)
            t->depth = depth + level;
    } else if (o->nkids == (1 << t->dim)) {
        int rc = grow(p->ctx, (void **)&t->kids, &t->cap_kids, t->nkids + (size_t)o->nkids, sizeof *t->kids);
        if (rc < 0)
            return rc;
        n = &t->nodes[o->id];
        n->leaf = 0;
        n->first = (uint32_t)t->nkids;
        memcpy(t->kids + t->nkids, o->kids, (size_t)o->nkids * sizeof *o->kids);
        t->nkids += (size_t)o->nkids;
    } else if (o->nkids == 0) {
        return bsti_error(p->ctx, BST_EFORMAT, "an empty tree node '{ }'");
    } else {
        return bsti_error(p->ctx, BST_EFORMAT, "a tree branch has %d children, not %d", o->nkids,
                          1 << t->dim);
    }
    uint32_t id = o->id;
    p->top--;
    if (p->top == 0)
        p->closed_root = 1;
    else
        p->stack[p->top - 1].kids[p->stack[p->top - 1].nkids++] = id;
    return BST_OK;
}

/* Character classes of the tree text: what ends a token, and the braces among those. */
enum { CH_TOKEN = 0, CH_SPACE = 1, CH_OPEN = 2, CH_CLOSE = 3 };
static const unsigned char char_class[256] = {
    [' '] = CH_SPACE, ['\t'] = CH_SPACE, ['\n'] = CH_SPACE, ['\r'] = CH_SPACE, [','] = CH_SPACE,
    ['{'] = CH_OPEN, ['}'] = CH_CLOSE,
};

int bsti_value_check(bst_ctx *ctx, double v, const char *what)
{
    if (!isfinite(v))
        return bsti_error(ctx, BST_EFORMAT, "%s is not finite", what);
    if (fabs(v) > FLT_MAX)
        return bsti_error(ctx, BST_EFORMAT, "%s exceeds the single-precision range (%.4g) in "
                          "which BSDF values are held", what, (double)FLT_MAX);
    return BST_OK;
}

/* The number of the len characters at s; s is p->tok or the text fed (read in place). */
static int number(bsti_tparse *p, const char *s, size_t len)
{
    bsti_ttree *t = p->t;
    double v;
    int ok = bsti_parse_double(s, len, &v);
    if (!ok || !isfinite(v) || fabs(v) > FLT_MAX || p->top == 0 || p->stack[p->top - 1].nkids) {
        if (s != p->tok) /* the message quotes it */
            memcpy(p->tok, s, len);
        p->tok[len] = '\0';
        if (!ok)
            return bsti_error(p->ctx, BST_EFORMAT, "'%s' is not a number", p->tok);
        char what[sizeof p->tok + 16];
        snprintf(what, sizeof what, "value '%s'", p->tok);
        int st = bsti_value_check(p->ctx, v, what);
        if (st < 0)
            return st;
        if (p->top == 0)
            return bsti_error(p->ctx, BST_EFORMAT, "number '%s' outside any tree node", p->tok);
        return bsti_error(p->ctx, BST_EFORMAT, "a tree node mixes values and child nodes");
    }
    if (v < 0) { /* as libBSDF: negative values read as 0 */
        v = 0;
        t->negatives++;
    }
    if (t->nvalues == t->cap_values) {
        int rc = grow(p->ctx, (void **)&t->values, &t->cap_values, t->nvalues + 1, sizeof *t->values);
        if (rc < 0)
            return rc;
    }
    t->values[t->nvalues++] = (float)v;
    p->stack[p->top - 1].nvalues++;
    return BST_OK;
}

static int too_long(bsti_tparse *p)
{
    return bsti_error(p->ctx, BST_EFORMAT, "a token longer than %d characters", TT_TOKEN_MAX);
}

/* A token is read in place where the chunk holds all of it; one cut by the chunk's end waits in
 * p->tok for the rest. */
int bsti_tparse_feed(bsti_tparse *p, const char *s, size_t len)
{
    const unsigned char *c = (const unsigned char *)s, *end = c + len;
    p->failed_at = 0;
    if (p->ntok) { /* the rest of a token cut at the end of the last chunk */
        const unsigned char *q = c;
        while (q < end && char_class[*q] == CH_TOKEN)
            q++;
        size_t more = (size_t)(q - c);
        if ((size_t)p->ntok + more > TT_TOKEN_MAX)
            return too_long(p);
        memcpy(p->tok + p->ntok, c, more);
        p->ntok += (int)more;
        if (q == end)
            return BST_OK;
        size_t n = (size_t)p->ntok;
        p->ntok = 0;
        int rc = number(p, p->tok, n);
        if (rc < 0)
            return rc;
        c = q;
    }
    while (c < end) {
        unsigned cls = char_class[*c];
        if (cls == CH_SPACE) {
            c++;
            continue;
        }
        const unsigned char *at = c;
        int rc;
        if (cls == CH_OPEN) {
            rc = open_node(p);
            c++;
        } else if (cls == CH_CLOSE) {
            rc = close_node(p);
            c++;
        } else {
            const unsigned char *q = c + 1;
            while (q < end && char_class[*q] == CH_TOKEN)
                q++;
            size_t n = (size_t)(q - c);
            if (n > TT_TOKEN_MAX) {
                p->failed_at = (size_t)(at - (const unsigned char *)s);
                return too_long(p);
            }
            if (q == end) { /* it may go on in the next chunk */
                memcpy(p->tok, c, n);
                p->ntok = (int)n;
                return BST_OK;
            }
            rc = number(p, (const char *)c, n);
            c = q;
        }
        if (rc < 0) {
            p->failed_at = (size_t)(at - (const unsigned char *)s);
            return rc;
        }
    }
    return BST_OK;
}

size_t bsti_tparse_failed_at(const bsti_tparse *p) { return p->failed_at; }

int bsti_tparse_finish(bsti_tparse *p, bsti_ttree **out)
{
    *out = NULL;
    int rc = BST_OK;
    if (p->ntok) {
        size_t n = (size_t)p->ntok;
        p->ntok = 0;
        rc = number(p, p->tok, n);
    }
    if (rc >= 0 && p->top > 0)
        rc = bsti_error(p->ctx, BST_EFORMAT, "the tree ends with %d unclosed node%s", p->top,
                        p->top > 1 ? "s" : "");
    if (rc >= 0 && !p->closed_root)
        rc = bsti_error(p->ctx, BST_EFORMAT, "no tree data (expected '{ ... }')");
    if (rc >= 0) {
        *out = p->t;
        p->t = NULL;
    }
    bsti_tparse_free(p);
    return rc;
}

double bsti_ttree_eval(const bsti_ttree *t, const double *pin)
{
    double p[4];
    for (int i = 0; i < t->dim; i++)
        p[i] = fmin(fmax(pin[i], 0.0), 0x1.fffffffffffffp-1);
    const struct bsti_tnode *n = &t->nodes[0];
    while (!n->leaf) {
        int child = 0;
        for (int i = 0; i < t->dim; i++) {
            int b = p[i] >= 0.5;
            child |= b << i;
            p[i] = 2.0 * p[i] - b;
        }
        n = &t->nodes[t->kids[n->first + (uint32_t)child]];
    }
    size_t g = (size_t)1 << n->level, flat = 0;
    for (int i = 0; i < t->dim; i++) {
        size_t c = (size_t)(p[i] * (double)g);
        flat = flat * g + (c < g ? c : g - 1);
    }
    return t->values[n->first + flat];
}

/* Share of the hypercube under node id (of volume vol) where the tree's value is not zero. */
static double fill(const bsti_ttree *t, uint32_t id, double vol)
{
    const struct bsti_tnode *n = &t->nodes[id];
    if (!n->leaf) {
        double f = 0;
        for (uint32_t c = 0; c < (1u << t->dim); c++)
            f += fill(t, t->kids[n->first + c], vol / (double)(1u << t->dim));
        return f;
    }
    size_t cells = (size_t)1 << (t->dim * n->level), nz = 0;
    for (size_t i = 0; i < cells; i++)
        nz += t->values[n->first + i] != 0.0f;
    return vol * (double)nz / (double)cells;
}

double bsti_ttree_fill(const bsti_ttree *t)
{
    return fill(t, 0, 1.0);
}
