/* incident_table.c - one column of a `combine --incident` table (format: incident_table.h).  The
 * file is read line by line and only the rows of the asked column are kept, so that a table of
 * many directions at k = 7 needs no more memory than one column.  Every line is checked, so that
 * a damaged table is refused rather than partly drawn. */
#include <config.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "cli.h"
#include "incident_table.h"

#define NCOLS 10

int cli_incident_table_is(const char *path)
{
    size_t n = strlen(path);
    if (n > 4 && strcmp(path + n - 4, ".tsv") == 0)
        return 1;
    FILE *fp = fopen(path, "r");
    if (!fp)
        return 0;
    char head[16] = {0};
    size_t got = fread(head, 1, sizeof head - 1, fp);
    fclose(fp);
    return got >= 13 && strncmp(head, "channel\tcomp\t", 13) == 0;
}

/* a whole field as a finite number; an underflow to (nearly) zero is a number too */
static int number(const char *s, double *v)
{
    char *end;
    errno = 0;
    *v = strtod(s, &end);
    return end != s && *end == '\0' && isfinite(*v) && (errno != ERANGE || fabs(*v) < 1);
}

static int index_field(const char *s, size_t *v)
{
    char *end;
    errno = 0;
    unsigned long long u = strtoull(s, &end, 10);
    *v = (size_t)u;
    return end != s && *end == '\0' && s[0] != '-' && errno == 0;
}

/* the same direction as combine printed it (%g: 6 significant digits) */
static int same_angle(double a, double b)
{
    return fabs(a - b) <= 5e-6 * fmax(1, fabs(b));
}

struct row {
    size_t patch;
    double theta, phi, bsdf;
};

/* The rows cover every patch of a basis once, each at its patch's centre (as printed: 4 decimals). */
static int check_rows(const char *sub, const char *path, struct row *rows, size_t n,
                      struct cli_incident_column *col)
{
    if (!(col->ctx = bst_ctx_new()))
        return cli_fail(sub, "out of memory");
    if (!(col->basis = cli_tsv_basis_of(col->ctx, n)))
        return cli_fail(sub, "%s: %zu exit patches in the %s column at (%g, %g): no Shirley-Chiu "
                        "(4^k) or Klems (145, 77, 41) basis has that many", path, n,
                        bst_comp_name(col->comp), col->theta_in, col->phi_in);
    if (!(col->bsdf = malloc(n * sizeof *col->bsdf)))
        return cli_fail(sub, "out of memory");
    char *seen = calloc(n, 1);
    if (!seen)
        return cli_fail(sub, "out of memory");
    int rc = CLI_OK;
    for (size_t i = 0; i < n && rc == CLI_OK; i++) {
        size_t e = rows[i].patch;
        double c[3], t = rows[i].theta * M_PI / 180, f = rows[i].phi * M_PI / 180;
        double d[3] = {sin(t) * cos(f), sin(t) * sin(f), cos(t)};
        if (e >= n || seen[e]) {
            rc = cli_fail(sub, "%s: exit patch %zu %s in the %s column at (%g, %g) of %zu patches", path,
                          e, e >= n ? "out of range" : "twice", bst_comp_name(col->comp), col->theta_in,
                          col->phi_in, n);
            break;
        }
        seen[e] = 1;
        bst_basis_center(col->basis, e, c);
        if (hypot(hypot(c[0] - d[0], c[1] - d[1]), c[2] - d[2]) > 1e-3) {
            double ct, cp;
            cli_patch_direction(col->basis, e, &ct, &cp);
            char name[80];
            if (bst_basis_kind_of(col->basis) == BST_BASIS_SHIRLEY_CHIU)
                snprintf(name, sizeof name, "Shirley-Chiu k = %d", bst_basis_order(col->basis));
            else
                snprintf(name, sizeof name, "%s", bst_basis_name(col->basis));
            rc = cli_fail(sub, "%s: exit patch %zu at (%g, %g) deg, but patch %zu of %s lies at "
                          "(%.4f, %.4f): not a column of that basis", path, e, rows[i].theta,
                          rows[i].phi, e, name, ct, cp);
        }
        col->bsdf[e] = rows[i].bsdf;
    }
    free(seen);
    return rc;
}

int cli_incident_column_read(const char *sub, const char *path, const char *channel, bst_comp comp,
                             const double *dir, struct cli_incident_column *col)
{
    memset(col, 0, sizeof *col);
    col->comp = comp;
    FILE *fp = fopen(path, "r");
    if (!fp)
        return cli_fail(sub, "%s: cannot open: %s", path, strerror(errno));
    char *line = NULL, *f[NCOLS + 1];
    size_t cap = 0, n = 0, rcap = 0;
    struct row *rows = NULL;
    int rc = CLI_OK, have_channel = 0, have_comp = 0, have_dir = 0;
    ssize_t len;
    long ln = 0;
    unsigned comps_seen = 0;
    while (rc == CLI_OK && (len = cli_read_line(sub, path, ln + 1, &line, &cap, fp)) != -1) {
        ln++;
        if (len < 0) {
            rc = CLI_FAIL;
            break;
        }
        if (len > 0 && line[len - 1] == '\n')
            line[--len] = '\0';
        if (len > 0 && line[len - 1] == '\r')
            line[--len] = '\0';
        if (ln == 1) {
            if (strcmp(line, CLI_TSV_HEADER) != 0)
                rc = cli_fail(sub, "%s:1: not a 'combine --incident' table: the first line must name the "
                              "columns channel, comp, theta_in, phi_in, patch_in, patch_out, theta_out, "
                              "phi_out, BSDF, DSF (tab-separated)", path);
            continue;
        }
        int nf = 0;
        for (char *p = line, *tab; nf <= NCOLS; p = tab + 1) {
            f[nf++] = p;
            if (!(tab = strchr(p, '\t')))
                break;
            *tab = '\0';
        }
        double v[6];
        size_t pin, pout;
        int c = -1;
        if (nf != NCOLS) {
            rc = cli_fail(sub, "%s:%ld: %s%d tab-separated columns, expected %d (channel .. DSF)", path, ln,
                          nf > NCOLS ? "more than " : "", nf > NCOLS ? NCOLS : nf, NCOLS);
        } else if (!f[0][0] || strlen(f[0]) >= sizeof col->channel) {
            rc = cli_fail(sub, "%s:%ld: channel name empty or longer than %zu characters", path, ln,
                          sizeof col->channel - 1);
        } else if ((c = bst_comp_parse(f[1])) < 0) {
            rc = cli_fail(sub, "%s:%ld: component '%s': expected Tf, Rf, Tb or Rb", path, ln, f[1]);
        } else if (!number(f[2], &v[0]) || !number(f[3], &v[1]) || !index_field(f[4], &pin) ||
                   !index_field(f[5], &pout) || !number(f[6], &v[2]) || !number(f[7], &v[3]) ||
                   !number(f[8], &v[4]) || !number(f[9], &v[5])) {
            rc = cli_fail(sub, "%s:%ld: columns 3 to 10 must be numbers (patches: whole numbers >= 0)",
                          path, ln);
        }
        if (rc != CLI_OK)
            break;
        if (!have_channel && (!channel || strcasecmp(channel, f[0]) == 0))
            snprintf(col->channel, sizeof col->channel, "%s", f[0]), have_channel = 1;
        if (!have_channel || strcmp(col->channel, f[0]) != 0)
            continue;
        comps_seen |= BST_COMP_BIT(c);
        if (c != (int)comp)
            continue;
        have_comp = 1;
        if (!have_dir && (!dir || (same_angle(v[0], dir[0]) && same_angle(v[1], dir[1]))))
            col->theta_in = v[0], col->phi_in = v[1], have_dir = 1;
        if (!have_dir || v[0] != col->theta_in || v[1] != col->phi_in)
            continue;
        if (n == rcap) {
            size_t nc = rcap ? 2 * rcap : 256;
            struct row *r = nc <= (size_t)1 << 20 ? realloc(rows, nc * sizeof *rows) : NULL;
            if (!r) {
                rc = cli_fail(sub, "%s:%ld: more rows in one column than any basis has", path, ln);
                break;
            }
            rows = r, rcap = nc;
        }
        rows[n++] = (struct row){pout, v[2], v[3], v[4]};
    }
    if (rc == CLI_OK && ferror(fp))
        rc = cli_fail(sub, "%s: read error: %s", path, strerror(errno ? errno : EIO));
    else if (rc == CLI_OK && ln == 0)
        rc = cli_fail(sub, "%s: empty file: not a 'combine --incident' table", path);
    else if (rc == CLI_OK && !have_channel)
        rc = channel ? cli_fail(sub, "%s: no channel '%s' in the table", path, channel)
                     : cli_fail(sub, "%s: the table has no rows", path);
    else if (rc == CLI_OK && !have_comp) {
        char list[32] = "";
        for (int c = 0; c < BST_NCOMP; c++)
            if (comps_seen & BST_COMP_BIT(c))
                strcat(strcat(list, *list ? ", " : ""), bst_comp_name((bst_comp)c));
        rc = cli_fail(sub, "%s: no %s column for channel %s (the table has %s; combine --only chooses)",
                      path, bst_comp_name(comp), col->channel, list);
    } else if (rc == CLI_OK && !have_dir)
        rc = cli_fail(sub, "%s: no %s column at incidence (%g, %g) for channel %s", path,
                      bst_comp_name(comp), dir[0], dir[1], col->channel);
    else if (rc == CLI_OK)
        rc = check_rows(sub, path, rows, n, col);
    free(line);
    free(rows);
    fclose(fp);
    if (rc != CLI_OK)
        cli_incident_column_free(col);
    return rc;
}

void cli_incident_column_free(struct cli_incident_column *col)
{
    bst_basis_free(col->basis);
    bst_ctx_free(col->ctx);
    free(col->bsdf);
    col->basis = NULL, col->ctx = NULL, col->bsdf = NULL;
}
