/* incident_tsv.c - `combine --incident`'s TSV read back as columns (incident_tsv.h).
 *
 * The file does not name its basis: the exit patches of every column run 0..n-1, so n gives it
 * (4^k: Shirley-Chiu of order k; 145, 77, 41: Klems full, half, quarter), and every row's exit
 * direction (theta_out, phi_out, printed to 1e-4 degrees) must be the centre of its patch in that
 * basis, and every column's incident direction must lie in its patch_in: a file of another basis,
 * or edited, is refused rather than misread. */
#include <config.h>

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "incident_tsv.h"

#define LINE_MAX_TSV 512
#define DIR_TOL 1e-5 /* |unit vector difference| allowed against a patch centre (1e-4 degree prints) */

int cli_tsv_detect(const char *path)
{
    if (strcmp(path, "-") == 0)
        return 0;
    FILE *fp = fopen(path, "r");
    if (!fp)
        return 0;
    char line[sizeof CLI_TSV_HEADER + 1];
    size_t n = fread(line, 1, sizeof CLI_TSV_HEADER - 1, fp);
    fclose(fp);
    return n == sizeof CLI_TSV_HEADER - 1 && memcmp(line, CLI_TSV_HEADER, n) == 0;
}

void cli_tsv_free(struct cli_tsv *t)
{
    for (size_t q = 0; t->cols && q < t->ncols; q++) {
        free(t->cols[q].channel);
        free(t->cols[q].bsdf);
    }
    free(t->cols);
    bst_basis_free(t->basis);
    memset(t, 0, sizeof *t);
}

/* A row as read: the column's key and one value. */
struct row {
    char channel[LINE_MAX_TSV];
    int comp;
    double theta, phi, theta_out, phi_out, bsdf;
    size_t patch_in, patch_out;
};

static int parse_row(char *line, struct row *r)
{
    char *f[10], *save = NULL;
    int n = 0;
    line[strcspn(line, "\r\n")] = '\0';
    for (char *tok = strtok_r(line, "\t", &save); tok && n < 10; tok = strtok_r(NULL, "\t", &save))
        f[n++] = tok;
    if (n != 10 || strtok_r(NULL, "\t", &save))
        return -1;
    snprintf(r->channel, sizeof r->channel, "%s", f[0]);
    if ((r->comp = bst_comp_parse(f[1])) < 0)
        return -1;
    size_t *idx[2] = {&r->patch_in, &r->patch_out};
    for (int i = 0; i < 2; i++) {
        char *end;
        errno = 0;
        unsigned long long v = strtoull(f[4 + i], &end, 10);
        if (end == f[4 + i] || *end || errno || f[4 + i][0] == '-')
            return -1;
        *idx[i] = (size_t)v;
    }
    double dsf;
    if (cli_parse_double(f[2], &r->theta) || cli_parse_double(f[3], &r->phi) ||
        cli_parse_double(f[6], &r->theta_out) || cli_parse_double(f[7], &r->phi_out) ||
        cli_parse_double(f[8], &r->bsdf) || cli_parse_double(f[9], &dsf))
        return -1;
    return 0;
}

static void direction(double theta, double phi, double d[3])
{
    double t = theta * M_PI / 180, p = phi * M_PI / 180;
    d[0] = sin(t) * cos(p), d[1] = sin(t) * sin(p), d[2] = cos(t);
}

bst_basis *cli_tsv_basis_of(bst_ctx *ctx, size_t n)
{
    bst_basis *b = NULL;
    for (int k = BST_K_MIN; k <= BST_K_MAX; k++)
        if (n == (size_t)1 << (2 * k) && bst_basis_new_sc(ctx, k, &b) >= 0)
            return b;
    static const struct { size_t n; const char *name; } klems[] = {{145, "full"}, {77, "half"}, {41, "quarter"}};
    for (size_t i = 0; i < 3; i++)
        if (n == klems[i].n && bst_basis_new_klems(ctx, klems[i].name, &b) >= 0)
            return b;
    return NULL;
}

/* The second pass over fp (path), which cli_tsv_read read into t, from its start: every exit
 * direction at the centre of its patch of t->basis, every column's incidence in its patch_in. */
static int check_directions(const char *sub, const char *path, FILE *fp, const struct cli_tsv *t)
{
    if (fseek(fp, 0, SEEK_SET) != 0)
        return cli_fail(sub, "%s: cannot read it a second time: %s", path, strerror(errno));
    char *line = NULL;
    size_t size = 0;
    struct row r;
    int rc = CLI_OK;
    ssize_t got;
    for (long ln = 1; rc == CLI_OK && (got = cli_read_line(sub, path, ln, &line, &size, fp)) != -1; ln++) {
        if (got < 0) {
            rc = CLI_FAIL;
            break;
        }
        if (ln == 1 || line[0] == '\n' || line[0] == '#')
            continue;
        if (parse_row(line, &r) != 0)
            continue;
        double d[3], e[3];
        direction(r.theta_out, r.phi_out, d);
        if (r.patch_out >= t->n)
            continue;
        bst_basis_center(t->basis, r.patch_out, e);
        double dist = sqrt((d[0] - e[0]) * (d[0] - e[0]) + (d[1] - e[1]) * (d[1] - e[1]) + (d[2] - e[2]) * (d[2] - e[2]));
        if (dist > DIR_TOL) {
            rc = cli_fail(sub, "%s:%ld: exit direction (%g, %g) is not the centre of patch %zu of "
                          "%s with %zu patches", path, ln, r.theta_out, r.phi_out, r.patch_out,
                          bst_basis_name(t->basis), t->n);
            break;
        }
        if (r.patch_out == 0) {
            /* as combine: off cell boundaries to the +x, +y side */
            if (cli_incident_patch(t->basis, r.theta, r.phi) != r.patch_in) {
                rc = cli_fail(sub, "%s:%ld: incidence (%g, %g) does not lie in patch %zu", path, ln,
                              r.theta, r.phi, r.patch_in);
                break;
            }
        }
    }
    free(line);
    return rc;
}

int cli_tsv_read(const char *sub, bst_ctx *ctx, const char *path, struct cli_tsv *t)
{
    memset(t, 0, sizeof *t);
    FILE *fp = fopen(path, "r");
    if (!fp)
        return cli_fail(sub, "%s: cannot open: %s", path, strerror(errno));
    char *line = NULL;
    size_t size = 0;
    struct row r;
    size_t cap = 0, fill = 0, bcap = 0; /* fill: rows of the open (last) column */
    int rc = CLI_OK;
    long ln = 1;
    ssize_t got = cli_read_line(sub, path, ln, &line, &size, fp);
    if (got == -2)
        rc = CLI_FAIL;
    else if (got < 0 || strncmp(line, CLI_TSV_HEADER, sizeof CLI_TSV_HEADER - 1) != 0)
        rc = cli_fail(sub, "%s: not a TSV of combine --incident (its first line is not the header)", path);
    /* columns in the order written: rows of one column are consecutive, patch_out 0, 1, ... */
    while (rc == CLI_OK && (got = cli_read_line(sub, path, ln + 1, &line, &size, fp)) != -1) {
        ln++;
        if (got < 0) {
            rc = CLI_FAIL;
            break;
        }
        if (line[0] == '\n' || line[0] == '#')
            continue;
        if (parse_row(line, &r) != 0) {
            rc = cli_fail(sub, "%s:%ld: not a row of 10 fields (channel, comp, theta_in, phi_in, "
                          "patch_in, patch_out, theta_out, phi_out, BSDF, DSF)", path, ln);
            break;
        }
        if (r.patch_out == 0) { /* a new column */
            if (t->ncols && t->n == 0)
                t->n = fill;
            if (t->ncols && fill != t->n) {
                rc = cli_fail(sub, "%s:%ld: the column before ends after %zu exit patches, not %zu",
                              path, ln, fill, t->n);
                break;
            }
            if (t->ncols == cap) {
                size_t nc = cap ? 2 * cap : 16;
                struct cli_tsv_col *c = realloc(t->cols, nc * sizeof *c);
                if (!c) {
                    rc = cli_fail(sub, "out of memory");
                    break;
                }
                t->cols = c, cap = nc;
            }
            struct cli_tsv_col *c = &t->cols[t->ncols++];
            memset(c, 0, sizeof *c);
            c->channel = strdup(r.channel);
            c->comp = (bst_comp)r.comp;
            c->theta = r.theta, c->phi = r.phi, c->patch_in = r.patch_in;
            bcap = t->n ? t->n : 64;
            c->bsdf = malloc(bcap * sizeof *c->bsdf);
            if (!c->channel || !c->bsdf) {
                rc = cli_fail(sub, "out of memory");
                break;
            }
            fill = 0;
        } else if (!t->ncols || r.patch_out != fill) {
            rc = cli_fail(sub, "%s:%ld: exit patch %zu out of order (expected %zu)", path, ln,
                          r.patch_out, t->ncols ? fill : 0);
            break;
        }
        struct cli_tsv_col *c = &t->cols[t->ncols - 1];
        if (strcmp(c->channel, r.channel) != 0 || c->comp != (bst_comp)r.comp || c->theta != r.theta ||
            c->phi != r.phi || c->patch_in != r.patch_in) {
            rc = cli_fail(sub, "%s:%ld: the column changes (channel, comp or incidence) before its "
                          "last exit patch", path, ln);
            break;
        }
        if (t->n && fill >= t->n) {
            rc = cli_fail(sub, "%s:%ld: more exit patches than the first column's %zu", path, ln, t->n);
            break;
        }
        if (fill == bcap) {
            double *b = realloc(c->bsdf, 2 * bcap * sizeof *b);
            if (!b) {
                rc = cli_fail(sub, "out of memory");
                break;
            }
            c->bsdf = b, bcap *= 2;
        }
        c->bsdf[fill++] = r.bsdf;
    }
    if (rc == CLI_OK && ferror(fp))
        rc = cli_fail(sub, "%s: read error: %s", path, strerror(errno ? errno : EIO));
    if (rc == CLI_OK && t->ncols == 0)
        rc = cli_fail(sub, "%s: no columns", path);
    if (rc == CLI_OK) {
        if (t->n == 0)
            t->n = fill;
        if (fill != t->n)
            rc = cli_fail(sub, "%s: the last column ends after %zu exit patches, not %zu", path, fill, t->n);
    }
    if (rc == CLI_OK && !(t->basis = cli_tsv_basis_of(ctx, t->n)))
        rc = cli_fail(sub, "%s: %zu exit patches per column: no basis has that many (4^k for "
                      "Shirley-Chiu, 145, 77 or 41 for Klems)", path, t->n);
    free(line);
    /* one FILE, closed once whatever failed (a failed first pass closed it twice: SIGABRT) */
    if (rc == CLI_OK)
        rc = check_directions(sub, path, fp, t);
    fclose(fp);
    if (rc != CLI_OK)
        cli_tsv_free(t);
    return rc;
}

int cli_tsv_layer(const char *sub, bst_ctx *ctx, const struct cli_tsv *t, const char *channel,
                  bst_layer **out)
{
    *out = NULL;
    const char *chs[1] = {channel};
    bst_layer *l;
    if (bst_layer_new(ctx, t->basis, 1, chs, &l) < 0)
        return cli_fail_ctx(sub, NULL, ctx);
    size_t n = t->n;
    size_t *ri = malloc(n * t->ncols * sizeof *ri + 1), *ci = malloc(n * t->ncols * sizeof *ci + 1);
    double *v = malloc(n * t->ncols * sizeof *v + 1);
    unsigned char *seen = calloc(n, 1);
    int rc = ri && ci && v && seen ? CLI_OK : cli_fail(sub, "out of memory");
    for (int c = 0; rc == CLI_OK && c < BST_NCOMP; c++) {
        size_t nnz = 0, any = 0;
        memset(seen, 0, n);
        for (size_t q = 0; q < t->ncols; q++) {
            const struct cli_tsv_col *col = &t->cols[q];
            if (col->comp != (bst_comp)c || strcmp(col->channel, channel) != 0)
                continue;
            any = 1;
            if (seen[col->patch_in])
                continue;
            seen[col->patch_in] = 1;
            for (size_t o = 0; o < n; o++)
                if (col->bsdf[o] != 0.0)
                    ri[nnz] = o, ci[nnz] = col->patch_in, v[nnz++] = col->bsdf[o];
        }
        if (!any)
            continue;
        bst_mat *m;
        if (bst_mat_new_sparse(ctx, n, n, nnz, ri, ci, v, &m) < 0 ||
            bst_layer_set(ctx, l, 0, (bst_comp)c, m) < 0)
            rc = cli_fail_ctx(sub, NULL, ctx);
    }
    free(ri), free(ci), free(v), free(seen);
    if (rc != CLI_OK) {
        bst_layer_free(l);
        return rc;
    }
    *out = l;
    return CLI_OK;
}
