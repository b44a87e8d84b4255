/* glass_layer.c - a clear pane as a layer over a basis: each patch's value is the pane's T or R
 * averaged over the patch (or taken at its centre), divided by the patch's Lambda.
 *
 * A layer's components are diagonal in every basis (index convention of bsdfstack.h: the
 * transmitted and the mirror-reflected beam keep the incident patch's index).  The average is
 * uniform in projected solid angle, with a quadrature rule over bst_basis_sample's (u, v) square
 * (patch_rule); the pane being isotropic, patches with the same incidence angles share one
 * evaluation (patch_representatives), and the hundreds of directions per patch are evaluated
 * through an angular table of the model (glass.h: BST_GLASS_TABLE_STEPS, its error bound; its
 * angles on the context's threads), or on two threads where they are many and exact
 * (BSTI_GLASS_PAR_MIN).  Each evaluation sums the model over the channel's wavelengths; past
 * BST_GLASS_LAYER_ROWS of them, over groups of adjacent ones where that agrees with every
 * wavelength's sum (group_channel), so that a file of 10^5 rows costs what one of 5000 does. */
#include <config.h>

#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "basis.h"
#include "ctx.h"
#include "glass.h"

/* A catalogue channel's exact patch averages (each direction a sum over the channel's ~100
 * wavelengths) of at least this many directions run on two threads (Shirley-Chiu k = 3: 10 orbits x 256 =
 * 2560 directions; a thread starts in ~0.05 ms; Klems full's 9 rings x 32 = 288 stay on one).  Per-wavelength layers (spectral.c's workers,
 * already parallel), table lookups and a context with its own allocator stay on one. */
#define BSTI_GLASS_PAR_MIN 1024
/* Threads an angular table uses at most (the context's count, bsti_ctx_workers, caps it). */
#define BSTI_GLASS_THREADS_MAX BST_THREADS_MAX

/* What a layer is evaluated from: channel ch of pane g (chan: its nodes, or the groups of them
 * that stand for its wavelengths past g->layer_rows, group_channel; NULL: g->ch[ch]), or
 * (sides != NULL) the two slab sides of one wavelength, front and back, set up once from its
 * normal-incidence T and R rather than at every one of the directions a patch average visits. */
struct source {
    const bst_glass *g;
    const struct bsti_glass_side *sides;
    const struct bsti_glass_channel *chan;
};

/* Tf, Tb, Rf, Rb of the source (channel ch unless it is one wavelength's sides) at theta. */
static void optics_at(const struct source *s, size_t ch, double theta, double p[4])
{
    if (s->sides) {
        bsti_glass_side_optics(&s->sides[0], theta, &p[0], &p[2]);
        bsti_glass_side_optics(&s->sides[1], theta, &p[1], &p[3]);
    } else {
        bsti_glass_channel_optics(s->chan ? s->chan : &s->g->ch[ch], theta, p);
    }
}

/* Angles (degrees) at which a grouping is checked against the sum over every wavelength, and how
 * far apart they may be (T, R absolute): BSTI_GLASS_GROUP_TOL, below the table's own error in a
 * patch value (BST_GLASS_TABLE_ERR).  A patch value averages the pane over angles, so it moves by
 * about as much as the pane does at these. */
static const double group_check_deg[] = {0, 30, 50, 60, 70, 80, 85, 89};
#define BSTI_GLASS_GROUP_TOL 1e-8

/* Channel c's wavelengths of weight in G groups of adjacent ones, of (nearly) equal count, each
 * with the group's summed weight and the slab of its weighted mean normal-incidence T and R per
 * side, into out (w, front, back, nk = G: allocated here).  BST_EINVAL (nothing kept, no message)
 * when a mean has no slab, BST_ENOMEM. */
static int make_groups(bst_ctx *ctx, const bst_glass *g, const struct bsti_glass_channel *c,
                       size_t rows, size_t G, struct bsti_glass_channel *out)
{
    memset(out, 0, sizeof *out);
    out->w = bsti_alloc_array(ctx, G, sizeof *out->w);
    out->front = bsti_alloc_array(ctx, G, sizeof *out->front);
    out->back = bsti_alloc_array(ctx, G, sizeof *out->back);
    int rc = out->w && out->front && out->back ? BST_OK : BST_ENOMEM;
    size_t k = 0, seen = 0; /* c's node, and how many of weight came before it */
    for (size_t j = 0; j < G && rc == BST_OK; j++) {
        size_t end = (j + 1) * rows / G; /* group j: the wavelengths of weight seen .. end - 1 */
        double s[5] = {0, 0, 0, 0, 0}; /* weight; weighted Tf, Rf, Tb, Rb */
        for (; seen < end; k++) {
            double w = c->w[k];
            if (w == 0.0)
                continue;
            s[0] += w, s[1] += w * c->front[k].t0, s[2] += w * c->front[k].r0;
            s[3] += w * c->back[k].t0, s[4] += w * c->back[k].r0;
            seen++;
        }
        out->w[j] = s[0];
        if (bsti_glass_side_model(&out->front[j], s[1] / s[0], s[2] / s[0], g->model) ||
            bsti_glass_side_model(&out->back[j], s[3] / s[0], s[4] / s[0], g->model))
            rc = BST_EINVAL;
    }
    if (rc != BST_OK) {
        bsti_free(ctx, out->w), bsti_free(ctx, out->front), bsti_free(ctx, out->back);
        return rc;
    }
    out->nk = G;
    return BST_OK;
}

/* The nodes channel ch's layer sums when it has more wavelengths of weight than g->layer_rows
 * (bst_glass_set_layer_rows): groups of adjacent ones (make_groups), g->layer_rows of them, twice
 * as many, ... the first grouping whose T and R agree with the sum over every wavelength within
 * BSTI_GLASS_GROUP_TOL at the checked angles (smooth data: the first; noisy data may need every
 * wavelength).  *made = 0 (out untouched) when the channel is within the bound or no grouping
 * agrees; free with free_groups. */
static int group_channel(bst_ctx *ctx, const bst_glass *g, size_t ch,
                         struct bsti_glass_channel *out, int *made)
{
    const struct bsti_glass_channel *c = &g->ch[ch];
    enum { NA = sizeof group_check_deg / sizeof group_check_deg[0] };
    double every[NA][4];
    size_t rows = 0;
    *made = 0;
    for (size_t k = 0; k < c->nk; k++)
        rows += c->w[k] != 0.0;
    if (!g->layer_rows || rows <= g->layer_rows)
        return BST_OK;
    for (size_t a = 0; a < NA; a++)
        bsti_glass_channel_optics(c, group_check_deg[a] * (M_PI / 180), every[a]);
    for (size_t G = g->layer_rows; G < rows; G = G < rows / 2 ? 2 * G : rows) {
        int rc = make_groups(ctx, g, c, rows, G, out);
        if (rc == BST_ENOMEM)
            return rc;
        if (rc < 0) /* a mean without a slab: every wavelength */
            return BST_OK;
        double worst = 0, v[4];
        for (size_t a = 0; a < NA; a++) {
            bsti_glass_channel_optics(out, group_check_deg[a] * (M_PI / 180), v);
            for (int i = 0; i < 4; i++)
                worst = fmax(worst, fabs(v[i] - every[a][i]));
        }
        if (worst <= BSTI_GLASS_GROUP_TOL) {
            *made = 1;
            return BST_OK;
        }
        bsti_free(ctx, out->w), bsti_free(ctx, out->front), bsti_free(ctx, out->back);
    }
    return BST_OK;
}

size_t bst_glass_layer_nodes(const bst_glass *g, size_t ch, size_t *rows)
{
    size_t n = 0;
    for (size_t k = 0; g && ch < g->nch && k < g->ch[ch].nk; k++)
        n += g->ch[ch].w[k] != 0.0;
    if (rows)
        *rows = n;
    struct bsti_glass_channel groups;
    int made = 0;
    if (g && ch < g->nch && group_channel(g->ctx, g, ch, &groups, &made) >= 0 && made) {
        n = groups.nk;
        bsti_free(g->ctx, groups.w), bsti_free(g->ctx, groups.front), bsti_free(g->ctx, groups.back);
    }
    return n;
}

static void free_groups(bst_ctx *ctx, struct bsti_glass_channel *c)
{
    bsti_free(ctx, c->w), bsti_free(ctx, c->front), bsti_free(ctx, c->back);
}

/* A share of an angular table: the angles first, first + step, ... (each angle's value is the
 * same sum whichever thread takes it, so the table is the same to the bit on any number of
 * threads).  The share of index 0 runs on the caller's thread and reports the progress as the
 * part [base, base + span] of the layer's (span 0: none). */
struct table_part {
    bst_ctx *ctx;
    const struct source *s;
    size_t ch, first, step;
    double *t, base, span;
};

static void *table_run(void *arg)
{
    const struct table_part *p = arg;
    size_t count = 0;
    for (size_t a = p->first; a <= BST_GLASS_TABLE_STEPS; a += p->step) {
        optics_at(p->s, p->ch, (double)a / BST_GLASS_TABLE_STEPS * (M_PI / 2), &p->t[4 * a]);
        if (p->first == 0 && p->span > 0 && ++count % 256 == 0)
            bsti_progress(p->ctx, p->base + p->span * (double)a / BST_GLASS_TABLE_STEPS,
                          "glass layer");
    }
    return NULL;
}

/* The angular table of channel ch.  It costs its angles times the channel's wavelengths (a
 * spectral pane's data rows for Solar: 10^5 rows are 9 10^8 evaluations of the model), so it runs
 * on the context's threads (bst_ctx_set_threads) once the channel has more than
 * BSTI_GLASS_TABLE_PAR_NODES wavelengths, and reports its progress. */
#define BSTI_GLASS_TABLE_PAR_NODES 1000
static double *table_at(bst_ctx *ctx, const struct source *s, size_t ch, double base, double span)
{
    double *t = bsti_alloc_array(ctx, 4 * (size_t)(BST_GLASS_TABLE_STEPS + 1), sizeof *t);
    if (!t)
        return NULL;
    size_t nk = s->sides ? 1 : s->chan ? s->chan->nk : s->g->ch[ch].nk;
    int nw = nk > BSTI_GLASS_TABLE_PAR_NODES ? bsti_ctx_workers(ctx, BSTI_GLASS_THREADS_MAX) : 1;
    struct table_part part[BSTI_GLASS_THREADS_MAX];
    pthread_t tid[BSTI_GLASS_THREADS_MAX];
    int started[BSTI_GLASS_THREADS_MAX] = {0};
    for (int i = 0; i < nw; i++)
        part[i] = (struct table_part){ctx, s, ch, (size_t)i, (size_t)nw, t, base, span};
    for (int i = 1; i < nw; i++)
        started[i] = pthread_create(&tid[i], NULL, table_run, &part[i]) == 0;
    table_run(&part[0]);
    for (int i = 1; i < nw; i++) {
        if (started[i])
            pthread_join(tid[i], NULL);
        else /* the thread did not start: its share here */
            table_run(&part[i]);
    }
    return t;
}

double *bsti_glass_table(bst_ctx *ctx, const bst_glass *g, size_t ch)
{
    const struct source s = {g, NULL, NULL};
    return table_at(ctx, &s, ch, 0.0, 0.0);
}

void bsti_glass_table_optics(const double *tab, double theta, double v[4])
{
    double x = fmin(fmax(theta / (M_PI / 2), 0.0), 1.0) * BST_GLASS_TABLE_STEPS;
    size_t a = (size_t)x;
    if (a >= BST_GLASS_TABLE_STEPS)
        a = BST_GLASS_TABLE_STEPS - 1;
    double f = x - (double)a;
    for (int i = 0; i < 4; i++)
        v[i] = (1 - f) * tab[4 * a + i] + f * tab[4 * a + 4 + i];
}

/* Incidence angle of a unit direction, accurate near the normal too. */
static double dir_theta(const double d[3])
{
    return atan2(hypot(d[0], d[1]), fabs(d[2]));
}

/* Gauss-Legendre nodes and weights of order m on [0, 1] (Newton's method on P_m from Tricomi's
 * estimates; weights sum to 1). */
static void gauss_legendre(int m, double *x, double *w)
{
    for (int i = 0; i < m; i++) {
        double z = cos(M_PI * (i + 0.75) / (m + 0.5)), dp = 1.0;
        for (int it = 0; it < 100; it++) {
            double p0 = 1.0, p1 = z;
            for (int k = 2; k <= m; k++) {
                double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
                p0 = p1, p1 = p2;
            }
            dp = m * (z * p1 - p0) / (z * z - 1.0);
            double dz = p1 / dp;
            z -= dz;
            if (fabs(dz) < 1e-15)
                break;
        }
        x[i] = 0.5 * (1.0 - z);
        w[i] = 1.0 / ((1.0 - z * z) * dp * dp);
    }
}

/* The rule for a patch average over bst_basis_sample's (u, v) square: points u[], v[] with weights
 * w[] (*np of each, weights sum to 1).
 * An isotropic pane's property depends on the radius r = sin(theta) alone, and is a smooth function
 * of r^2 except at the rim, where cos(theta) = sqrt(1 - r^2) has a square-root singularity.
 * Klems: r^2 is linear in u and independent of v (bst_basis_sample), so the average is a 1-D
 * integral over u: 4 m Gauss-Legendre points in u (v = 1/2) after the substitution
 * u = q^2 (3 - 2 q), which turns sqrt(1 - u) into the smooth (1 - q) sqrt(1 + 2 q).
 * Shirley-Chiu: the concentric map has r = max(|a|, |b|) in square coordinates, with a kink along
 * the cell diagonals of the cells that lie on the square's diagonals.  So the square is split by
 * both its diagonals into four triangles (centre, corner, next corner), every kink and singular
 * edge becomes a triangle edge, and each triangle, collapsed onto [0, 1]^2 by
 * p = c + s (p1 + t (p2 - p1) - c) (Jacobian s / 2), gets an m x m Gauss-Legendre rule after the
 * same substitution in s and t: 4 m^2 points.  A plain midpoint rule errs by up to 1e-2 in rim
 * patches; these by < 3e-6 (bench/bench_glass). */
static int patch_rule(bst_ctx *ctx, const bst_basis *b, int m, size_t *np, double **u, double **v,
                      double **w)
{
    int klems = b->kind != BST_BASIS_SHIRLEY_CHIU, mq = klems ? 4 * m : m;
    *np = klems ? 4 * (size_t)m : 4 * (size_t)m * (size_t)m;
    double *x = bsti_alloc_array(ctx, (size_t)mq, sizeof *x), *gw = bsti_alloc_array(ctx, (size_t)mq, sizeof *gw);
    *u = bsti_alloc_array(ctx, *np, sizeof **u);
    *v = bsti_alloc_array(ctx, *np, sizeof **v);
    *w = bsti_alloc_array(ctx, *np, sizeof **w);
    if (!x || !gw || !*u || !*v || !*w) {
        bsti_free(ctx, x), bsti_free(ctx, gw);
        bsti_free(ctx, *u), bsti_free(ctx, *v), bsti_free(ctx, *w);
        *u = *v = *w = NULL;
        return -1;
    }
    gauss_legendre(mq, x, gw);
    for (int i = 0; i < mq; i++) { /* the substitution q -> q^2 (3 - 2 q) */
        double q = x[i];
        x[i] = q * q * (3.0 - 2.0 * q);
        gw[i] *= 6.0 * q * (1.0 - q);
    }
    if (klems) {
        for (int i = 0; i < mq; i++)
            (*u)[i] = x[i], (*v)[i] = 0.5, (*w)[i] = gw[i];
        bsti_free(ctx, x), bsti_free(ctx, gw);
        return 0;
    }
    static const double corner[5][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}};
    size_t k = 0;
    for (int tri = 0; tri < 4; tri++) {
        const double *p1 = corner[tri], *p2 = corner[tri + 1];
        for (int i = 0; i < m; i++)
            for (int j = 0; j < m; j++, k++) {
                double sv = x[i], tv = x[j];
                (*u)[k] = 0.5 + sv * (p1[0] + tv * (p2[0] - p1[0]) - 0.5);
                (*v)[k] = 0.5 + sv * (p1[1] + tv * (p2[1] - p1[1]) - 0.5);
                (*w)[k] = 0.5 * sv * gw[i] * gw[j];
            }
    }
    bsti_free(ctx, x), bsti_free(ctx, gw);
    return 0;
}

struct bsti_glass_rule {
    size_t n, np;  /* patches, points per patch */
    size_t ndistinct; /* points of the representative patches: the evaluations a layer needs */
    double *theta; /* theta[j * np + q]: incidence angle of point q of patch j */
    double *w;     /* its weight (sum 1 per patch) */
    size_t *rep;   /* rep[j] <= j: a patch with the same incidence angles and Lambda as j */
};

void bsti_glass_rule_free(bst_ctx *ctx, bsti_glass_rule *r)
{
    if (r)
        bsti_free(ctx, r->theta), bsti_free(ctx, r->w), bsti_free(ctx, r->rep), bsti_free(ctx, r);
}

/* A pane is isotropic, so a patch's average depends only on the incidence angles of its points.
 * Shirley-Chiu: the concentric map commutes with the 8 symmetries of the square (quarter turns,
 * mirrors), and the patch rule's points are symmetric too, so the patches of one orbit share their
 * angles; the orbit's least index stands for it (8x fewer evaluations).  Klems: a patch's angles
 * depend only on its band, whose first patch stands for it. */
static void patch_representatives(const bst_basis *b, size_t *rep)
{
    size_t n = bst_basis_size(b);
    if (b->kind == BST_BASIS_SHIRLEY_CHIU) {
        size_t G = b->g;
        for (size_t j = 0; j < n; j++) {
            size_t x = j / G, y = j % G, best = j;
            size_t xs[2] = {x, G - 1 - x}, ys[2] = {y, G - 1 - y};
            for (int a = 0; a < 2; a++)
                for (int c = 0; c < 2; c++) {
                    size_t p = xs[a] * G + ys[c], q = ys[c] * G + xs[a];
                    best = p < best ? p : best;
                    best = q < best ? q : best;
                }
            rep[j] = best;
        }
    } else {
        for (size_t band = 0; band < b->nbands; band++) {
            size_t end = band + 1 < b->nbands ? b->first[band + 1] : n;
            for (size_t j = b->first[band]; j < end; j++)
                rep[j] = b->first[band];
        }
    }
}

int bsti_glass_rule_new(bst_ctx *ctx, const bst_basis *basis, int at_centre, int samples,
                        bsti_glass_rule **out)
{
    *out = NULL;
    if (!at_centre && samples < 1)
        return bsti_error(ctx, BST_EINVAL, "glass layer: %d samples per patch", samples);
    size_t n = bst_basis_size(basis), np = 1;
    double *qu = NULL, *qv = NULL, *qw = NULL;
    if (!at_centre && patch_rule(ctx, basis, samples, &np, &qu, &qv, &qw) < 0)
        return BST_ENOMEM;
    bsti_glass_rule *r = bsti_calloc(ctx, 1, sizeof *r);
    if (!r || !(r->theta = bsti_alloc_array(ctx, n * np, sizeof *r->theta)) ||
        !(r->w = bsti_alloc_array(ctx, n * np, sizeof *r->w)) ||
        !(r->rep = bsti_alloc_array(ctx, n, sizeof *r->rep))) {
        bsti_glass_rule_free(ctx, r);
        bsti_free(ctx, qu), bsti_free(ctx, qv), bsti_free(ctx, qw);
        return BST_ENOMEM;
    }
    r->n = n, r->np = np;
    patch_representatives(basis, r->rep);
    for (size_t j = 0; j < n; j++)
        r->ndistinct += r->rep[j] == j ? np : 0;
    for (size_t j = 0; j < n; j++)
        for (size_t q = 0; q < np; q++) {
            double d[3];
            if (at_centre)
                bst_basis_center(basis, j, d);
            else
                bst_basis_sample(basis, j, qu[q], qv[q], d);
            r->theta[j * np + q] = dir_theta(d);
            r->w[j * np + q] = at_centre ? 1.0 : qw[q];
        }
    bsti_free(ctx, qu), bsti_free(ctx, qv), bsti_free(ctx, qw);
    *out = r;
    return BST_OK;
}

/* Two threads are used only with the default allocator, as in spectral.c: a caller that brings its
 * own (the tests' failure injection) keeps everything on its thread, and so the tests can compare
 * one thread with two. */
static int default_allocator(const bst_ctx *ctx)
{
    bst_ctx *probe = bst_ctx_new();
    int yes = probe && probe->malloc_fn == ctx->malloc_fn && probe->free_fn == ctx->free_fn;
    bst_ctx_free(probe);
    return yes;
}

/* A share of one channel's patch averages: the representative patches number first, first + step,
 * ... in the order of their index (each patch's sum in the same order whichever thread takes it,
 * so the values are the same to the bit on one thread or two). */
struct part {
    const struct source *src;
    const bsti_glass_rule *r;
    size_t ch;
    const double *tab, *lam;
    double *v;
    size_t first, step;
};

static void *part_run(void *arg)
{
    const struct part *a = arg;
    const bsti_glass_rule *r = a->r;
    size_t n = r->n, count = 0;
    double *v = a->v;
    for (size_t j = 0; j < n; j++) {
        if (r->rep[j] != j || count++ % a->step != a->first)
            continue;
        double sum[4] = {0, 0, 0, 0}, p[4];
        for (size_t q = j * r->np; q < (j + 1) * r->np; q++) {
            if (a->tab)
                bsti_glass_table_optics(a->tab, r->theta[q], p);
            else
                optics_at(a->src, a->ch, r->theta[q], p);
            for (int i = 0; i < 4; i++)
                sum[i] += r->w[q] * p[i];
        }
        double w = 1.0 / a->lam[j];
        /* p[] order Tf, Tb, Rf, Rb; v blocks in bst_comp order Tf, Rf, Tb, Rb */
        v[j] = sum[0] * w, v[n + j] = sum[2] * w, v[2 * n + j] = sum[1] * w;
        v[3 * n + j] = sum[3] * w;
    }
    return NULL;
}

/* The layer over basis of the source's channels idx[0..nc-1] (names[]), or of its one wavelength
 * (one channel, names[0]), averaged with rule r over each patch.  A patch average evaluates
 * hundreds of directions per patch: through the angular table when that is cheaper (more distinct
 * directions than table angles: Shirley-Chiu k >= 4, 36 orbits x 256 = 9216 at k = 4) unless exact;
 * else, and for every rule of patch centres, exactly (Klems full: 9 rings x 32 = 288). */
static int build_layer(bst_ctx *ctx, const struct source *src, const bst_basis *basis,
                       const bsti_glass_rule *r, size_t nc, const size_t *idx,
                       const char *const *names, int exact, bst_layer **out)
{
    bst_layer *l;
    int rc = bst_layer_new(ctx, basis, nc, names, &l);
    if (rc < 0)
        return rc;
    size_t n = bst_basis_size(basis);
    const double *lam = bst_basis_lambda(basis);
    double *v = bsti_alloc_array(ctx, 4 * n, sizeof *v);
    if (!v) {
        bst_layer_free(l);
        return BST_ENOMEM;
    }
    int par = !src->sides && r->ndistinct >= BSTI_GLASS_PAR_MIN &&
              sysconf(_SC_NPROCESSORS_ONLN) > 1 && default_allocator(ctx);
    for (size_t c = 0; c < nc && rc >= 0; c++) {
        double *tab = NULL;
        struct bsti_glass_channel groups;
        int grouped = 0;
        struct source sc = *src; /* this channel's nodes, or their groups */
        if (!src->sides && (rc = group_channel(ctx, src->g, idx[c], &groups, &grouped)) < 0)
            break;
        sc.chan = grouped ? &groups : NULL;
        if (r->np > 1 && !exact && r->ndistinct > BST_GLASS_TABLE_STEPS + 1 &&
            !(tab = table_at(ctx, &sc, idx[c], (double)c / (double)nc, 1.0 / (double)nc))) {
            rc = BST_ENOMEM;
            if (grouped)
                free_groups(ctx, &groups);
            break;
        }
        struct part part[2] = {{&sc, r, idx[c], tab, lam, v, 0, 1}, {&sc, r, idx[c], tab, lam, v, 0, 1}};
        pthread_t helper;
        int two = par && !tab;
        if (two) /* every other representative patch on a second thread */
            part[0].step = part[1].step = 2, part[1].first = 1;
        two = two && pthread_create(&helper, NULL, part_run, &part[1]) == 0;
        part_run(&part[0]);
        if (two)
            pthread_join(helper, NULL);
        else if (part[1].first) /* the thread did not start: its share here */
            part_run(&part[1]);
        for (size_t j = 0; j < n; j++)
            if (r->rep[j] != j) /* the same angles (and Lambda) as an earlier patch */
                for (int k = 0; k < 4; k++)
                    v[(size_t)k * n + j] = v[(size_t)k * n + r->rep[j]];
        bsti_free(ctx, tab);
        if (grouped)
            free_groups(ctx, &groups);
        for (int k = 0; k < BST_NCOMP && rc >= 0; k++) {
            bst_mat *m;
            rc = bst_mat_new_diag(ctx, n, v + (size_t)k * n, &m);
            if (rc >= 0)
                rc = bst_layer_set(ctx, l, c, (bst_comp)k, m);
        }
        bsti_progress(ctx, (double)(c + 1) / (double)nc, "glass layer");
    }
    bsti_free(ctx, v);
    if (rc >= 0 && src->g->description)
        rc = bst_layer_set_name(ctx, l, src->g->description);
    if (rc < 0) {
        bst_layer_free(l);
        return rc;
    }
    *out = l;
    return BST_OK;
}

int bsti_glass_layer(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, size_t nchannels,
                     const char *const *channels, int at_centre, int samples, int exact,
                     bst_layer **out)
{
    if (!ctx || !g || !basis || !out || (nchannels && !channels))
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass layer: NULL argument") : BST_EINVAL;
    *out = NULL;
    if (!at_centre && samples < 1)
        return bsti_error(ctx, BST_EINVAL, "glass layer: %d samples per patch", samples);
    size_t idx[BSTI_GLASS_MAX_CH], nc = nchannels ? nchannels : g->nch;
    const char *names[BSTI_GLASS_MAX_CH];
    if (nc > BSTI_GLASS_MAX_CH)
        return bsti_error(ctx, BST_EINVAL, "glass layer: more than %d channels", BSTI_GLASS_MAX_CH);
    for (size_t c = 0; c < nc; c++) {
        int k = nchannels ? bst_glass_find_channel(g, channels[c]) : (int)c;
        if (k < 0)
            return bsti_error(ctx, BST_ENOTFOUND, "%s: no channel %s", g->where, channels[c]);
        idx[c] = (size_t)k;
        names[c] = g->ch[k].name;
    }
    bsti_glass_rule *r;
    int rc = bsti_glass_rule_new(ctx, basis, at_centre, samples, &r);
    if (rc < 0)
        return rc;
    const struct source src = {g, NULL, NULL};
    rc = build_layer(ctx, &src, basis, r, nc, idx, names, exact, out);
    bsti_glass_rule_free(ctx, r);
    return rc;
}

int bsti_glass_layer_data(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis,
                          const bsti_glass_rule *rule, const double d[4], bst_layer **out)
{
    if (!ctx || !g || !basis || !rule || !d || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass layer: NULL argument") : BST_EINVAL;
    *out = NULL;
    if (rule->n != bst_basis_size(basis))
        return bsti_error(ctx, BST_EINVAL, "glass layer: the patch rule is for another basis");
    struct bsti_glass_side sides[2];
    if (bsti_glass_side_model(&sides[0], d[0], d[2], g->model) ||
        bsti_glass_side_model(&sides[1], d[1], d[3], g->model))
        return bsti_error(ctx, BST_EINVAL, "%s: no slab has Tf %g, Tb %g, Rf %g, Rb %g at normal "
                          "incidence", g->where, d[0], d[1], d[2], d[3]);
    static const size_t zero = 0;
    static const char *const name[] = {"Spectral"};
    const struct source src = {g, sides, NULL};
    return build_layer(ctx, &src, basis, rule, 1, &zero, name, 0, out);
}

int bsti_glass_layer_at(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis,
                        const bsti_glass_rule *rule, double lambda_um, bst_layer **out)
{
    if (!ctx || !g || !basis || !rule || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass layer: NULL argument") : BST_EINVAL;
    *out = NULL;
    if (!g->data.n)
        return bsti_error(ctx, BST_EINVAL, "%s: no spectral data, so no layer per wavelength", g->where);
    if (!(lambda_um > 0) || !isfinite(lambda_um))
        return bsti_error(ctx, BST_EINVAL, "%s: wavelength %g um is not positive", g->where, lambda_um);
    double d[4];
    bsti_glass_data_at(&g->data, lambda_um, &d[0], &d[1], &d[2], &d[3]);
    return bsti_glass_layer_data(ctx, g, basis, rule, d, out);
}

int bst_glass_layer_at(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, double lambda_um,
                       int at_centre, bst_layer **out)
{
    if (!ctx || !basis || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "glass layer: NULL argument") : BST_EINVAL;
    bsti_glass_rule *r;
    int rc = bsti_glass_rule_new(ctx, basis, at_centre, BST_GLASS_SAMPLES, &r);
    if (rc < 0)
        return rc;
    rc = bsti_glass_layer_at(ctx, g, basis, r, lambda_um, out);
    bsti_glass_rule_free(ctx, r);
    return rc;
}

int bst_glass_layer(bst_ctx *ctx, const bst_glass *g, const bst_basis *basis, size_t nchannels,
                    const char *const *channels, int at_centre, bst_layer **out)
{
    return bsti_glass_layer(ctx, g, basis, nchannels, channels, at_centre, BST_GLASS_SAMPLES, 0, out);
}

int bst_glass_layer_from_spec(bst_ctx *ctx, const char *spec, const char *catalogue_dir,
                              const bst_basis *basis, size_t nchannels,
                              const char *const *channels, bst_layer **out)
{
    if (out)
        *out = NULL;
    bst_glass *g;
    int rc = bst_glass_parse_bands(ctx, spec, catalogue_dir, channels ? nchannels : 0, channels, &g);
    if (rc < 0)
        return rc;
    /* a spectral pane is averaged over any further band the caller asks for (CIE-X, ...) */
    for (size_t c = 0; c < nchannels && rc >= 0 && channels; c++)
        if (bst_glass_find_channel(g, channels[c]) < 0 && bst_glass_nwavelengths(g) &&
            bsti_glass_find_band(channels[c]))
            rc = bst_glass_add_channel(ctx, g, channels[c]);
    if (rc >= 0)
        rc = bst_glass_layer(ctx, g, basis, nchannels, channels, 0, out);
    bst_glass_free(g);
    return rc;
}
