/* view_data.c - the page `bsdfstack view` writes: src/cli/view/page.html (embedded at build time
 * as view_page.h by src/cli/view/embed.sh) with its markers replaced by the title, view.css,
 * the data and view.js.
 *
 * The data is one JSON object, read by view.js:
 *   files     [{name, format}], in the order given
 *   basis     {kind: "sc", k, name} or {kind: "klems", name, theta: band bounds (deg), nphi}
 *   lambda    the patches' projected solid angles (sr), float64, base64: the weights `info`
 *             sums a column with, so that the page's hemispherical values are info's
 *   cols      the embedded incident patches, or null for all of them
 *   note      what the page says of the resolution, or null
 *   channels  names
 *   m         m[file][channel][comp]: null (zero), {d: float32 column-major, the embedded
 *             columns one after the other} or {p: uint32 column starts, r: uint16 rows,
 *             v: float32 values} (CSC, for diagonal and sparse components), each base64 of
 *             little-endian numbers.
 * Index convention: the library's (column = incident patch of the propagation direction). */
#include <config.h>

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "view.h"
#include "cli/view_page.h"

#define VIEW_CHUNK 256 /* columns converted at a time */

/* ------------------------------------------------------------------ base64, streamed */

struct b64 {
    FILE *fp;
    unsigned char rem[3];
    int nrem;
    char buf[4096];
    size_t len;
};

static const char b64_alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

static void b64_quad(struct b64 *e, const unsigned char *s, int n)
{
    unsigned v = (unsigned)s[0] << 16 | (unsigned)(n > 1 ? s[1] : 0) << 8 | (n > 2 ? s[2] : 0);
    if (e->len + 4 > sizeof e->buf)
        fwrite(e->buf, 1, e->len, e->fp), e->len = 0;
    for (int i = 0; i < 4; i++)
        e->buf[e->len++] = i <= n ? b64_alphabet[v >> (18 - 6 * i) & 63] : '=';
}

static void b64_put(struct b64 *e, const unsigned char *p, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        e->rem[e->nrem++] = p[i];
        if (e->nrem == 3)
            b64_quad(e, e->rem, 3), e->nrem = 0;
    }
}

static void b64_end(struct b64 *e)
{
    if (e->nrem)
        b64_quad(e, e->rem, e->nrem);
    fwrite(e->buf, 1, e->len, e->fp);
    e->len = 0, e->nrem = 0;
}

static void put_u32(struct b64 *e, uint32_t v)
{
    unsigned char b[4] = {v & 255, v >> 8 & 255, v >> 16 & 255, v >> 24 & 255};
    b64_put(e, b, 4);
}

static void put_f32(struct b64 *e, float f)
{
    uint32_t v;
    memcpy(&v, &f, 4);
    put_u32(e, v);
}

/* ------------------------------------------------------------------ JSON */

/* A JSON string that is also safe inside a <script> element (no '<', '>', '&' as such). */
static void json_string(FILE *fp, const char *s)
{
    fputc('"', fp);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p < 0x20 || *p == '"' || *p == '\\' || *p == '<' || *p == '>' || *p == '&')
            fprintf(fp, "\\u%04x", *p);
        else
            fputc(*p, fp);
    }
    fputc('"', fp);
}

/* Polar angle (degrees) where sampling puts u of patch p (bst_basis_sample): u = 0 and 1 are
 * its band's bounds. */
static double band_edge(const bst_basis *b, size_t p, double u)
{
    double d[3];
    bst_basis_sample(b, p, u, 0.5, d);
    return asin(fmin(1, hypot(d[0], d[1]))) * 180 / M_PI;
}

/* The Klems bands, from the patches themselves: a band's patches share their bounds. */
static void json_klems(FILE *fp, const bst_basis *b)
{
    size_t n = bst_basis_size(b), count = 1;
    fputs("\"theta\":[0", fp);
    for (size_t p = 1; p < n; p++)
        if (fabs(band_edge(b, p, 0) - band_edge(b, p - 1, 0)) > 1e-9)
            fprintf(fp, ",%.10g", band_edge(b, p - 1, 1));
    fputs(",90],\"nphi\":[", fp);
    for (size_t p = 1; p <= n; p++) {
        if (p == n || fabs(band_edge(b, p, 0) - band_edge(b, p - 1, 0)) > 1e-9) {
            fprintf(fp, "%zu%s", count, p == n ? "]" : ",");
            count = 0;
        }
        count++;
    }
}

/* ------------------------------------------------------------------ the components */

static size_t ncols_of(const struct cli_view *v)
{
    return v->cols ? v->ncols : bst_basis_size(v->basis);
}

static int is_sparse(const bst_mat *m)
{
    return bst_mat_structure(m) == BST_DIAG || bst_mat_structure(m) == BST_SPARSE;
}

double cli_view_data_size(const struct cli_view *v)
{
    double n = (double)bst_basis_size(v->basis), nc = (double)ncols_of(v), bytes = 8 * n;
    for (size_t f = 0; f < v->nfiles; f++)
        for (size_t ch = 0; ch < v->nchannels; ch++) {
            int lc = bst_layer_find_channel(v->files[f].l, v->channels[ch]);
            for (int c = 0; c < BST_NCOMP; c++) {
                const bst_mat *m = lc < 0 ? NULL : bst_layer_get(v->files[f].l, (size_t)lc, (bst_comp)c);
                if (!m || bst_mat_structure(m) == BST_ZERO)
                    continue;
                /* a sparse one's selected columns hold at most its nnz */
                bytes += is_sparse(m) ? 4 * (nc + 1) + 6.0 * (double)bst_mat_nnz(m) : 4 * n * nc;
            }
        }
    return bytes * 4 / 3;
}

/* Columns j0 .. j0+nc-1 of the embedded ones, as doubles column-major into buf (N x nc). */
static int chunk(bst_ctx *ctx, const struct cli_view *v, const bst_mat *m, size_t j0, size_t nc,
                 size_t *idx, double *buf)
{
    for (size_t j = 0; j < nc; j++)
        idx[j] = v->cols ? v->cols[j0 + j] : j0 + j;
    bst_mat *sub = NULL;
    int st = bst_mat_select_cols(ctx, m, nc, idx, &sub);
    if (st >= 0)
        st = bst_mat_to_dense_array(ctx, sub, buf);
    bst_mat_free(sub);
    return st;
}

/* One component's entry: its values, checked as a BSDF's (finite, not negative). */
static int json_component(bst_ctx *ctx, const char *sub, FILE *fp, const struct cli_view *v,
                          size_t f, const bst_mat *m, double *buf, size_t *idx)
{
    size_t n = bst_basis_size(v->basis), nc = ncols_of(v), nnz = 0, cap = 0;
    uint32_t *colstart = NULL, *rows = NULL;
    float *vals = NULL;
    int sparse = is_sparse(m), rc = CLI_OK;
    struct b64 e = {.fp = fp};
    if (sparse && !(colstart = malloc((nc + 1) * sizeof *colstart)))
        return cli_fail(sub, "out of memory");
    fputs(sparse ? "{\"p\":\"" : "{\"d\":\"", fp);
    for (size_t j0 = 0; j0 < nc && rc == CLI_OK; j0 += VIEW_CHUNK) {
        size_t w = nc - j0 < VIEW_CHUNK ? nc - j0 : VIEW_CHUNK;
        if (chunk(ctx, v, m, j0, w, idx, buf) < 0) {
            rc = cli_fail_ctx(sub, v->files[f].path, ctx);
            break;
        }
        for (size_t j = 0; j < w && rc == CLI_OK; j++) {
            if (sparse)
                colstart[j0 + j] = (uint32_t)nnz;
            for (size_t i = 0; i < n; i++) {
                double x = buf[j * n + i];
                if (!isfinite(x) || x < 0) {
                    rc = cli_fail(sub, "%s: value %g at incident patch %zu, exit patch %zu: not a BSDF",
                                  v->files[f].path, x, idx[j], i);
                    break;
                }
                if (!sparse) {
                    put_f32(&e, (float)x);
                } else if (x != 0) {
                    if (nnz == cap) {
                        size_t c2 = cap ? 2 * cap : 1024;
                        uint32_t *r2 = realloc(rows, c2 * sizeof *rows);
                        float *v2 = r2 ? realloc(vals, c2 * sizeof *vals) : NULL;
                        rows = r2 ? r2 : rows, vals = v2 ? v2 : vals;
                        if (!r2 || !v2) {
                            rc = cli_fail(sub, "out of memory");
                            break;
                        }
                        cap = c2;
                    }
                    rows[nnz] = (uint32_t)i, vals[nnz++] = (float)x;
                }
            }
        }
    }
    if (rc == CLI_OK && sparse) {
        colstart[nc] = (uint32_t)nnz;
        for (size_t j = 0; j <= nc; j++)
            put_u32(&e, colstart[j]);
        b64_end(&e);
        fputs("\",\"r\":\"", fp);
        for (size_t q = 0; q < nnz; q++) {
            unsigned char b[2] = {rows[q] & 255, rows[q] >> 8 & 255};
            b64_put(&e, b, 2);
        }
        b64_end(&e);
        fputs("\",\"v\":\"", fp);
        for (size_t q = 0; q < nnz; q++)
            put_f32(&e, vals[q]);
    }
    b64_end(&e);
    fputs("\"}", fp);
    free(colstart), free(rows), free(vals);
    return rc;
}

/* ------------------------------------------------------------------ the page */

static int json_data(bst_ctx *ctx, const char *sub, FILE *fp, const struct cli_view *v)
{
    size_t n = bst_basis_size(v->basis);
    fputs("{\"files\":[", fp);
    for (size_t f = 0; f < v->nfiles; f++) {
        const char *base = strrchr(v->files[f].path, '/');
        fprintf(fp, "%s{\"name\":", f ? "," : "");
        json_string(fp, base ? base + 1 : v->files[f].path);
        fputs(",\"format\":", fp);
        json_string(fp, v->files[f].format);
        fputc('}', fp);
    }
    if (bst_basis_kind_of(v->basis) == BST_BASIS_SHIRLEY_CHIU) {
        int k = bst_basis_order(v->basis);
        fprintf(fp, "],\"basis\":{\"kind\":\"sc\",\"k\":%d,\"name\":\"Shirley-Chiu k = %d (%d x %d)\"}", k, k,
                1 << k, 1 << k);
    } else {
        fputs("],\"basis\":{\"kind\":\"klems\",\"name\":", fp);
        json_string(fp, bst_basis_name(v->basis));
        fputc(',', fp);
        json_klems(fp, v->basis);
        fputc('}', fp);
    }
    struct b64 e = {.fp = fp};
    fputs(",\"lambda\":\"", fp);
    for (size_t i = 0; i < n; i++) {
        double l = bst_basis_lambda(v->basis)[i];
        uint64_t u;
        memcpy(&u, &l, 8);
        put_u32(&e, (uint32_t)(u & 0xffffffffu));
        put_u32(&e, (uint32_t)(u >> 32));
    }
    b64_end(&e);
    fputs("\",\"cols\":", fp);
    if (v->cols)
        for (size_t j = 0; j < v->ncols; j++)
            fprintf(fp, "%c%zu", j ? ',' : '[', v->cols[j]);
    fputs(v->cols ? "],\"note\":" : "null,\"note\":", fp);
    if (v->note)
        json_string(fp, v->note);
    else
        fputs("null", fp);
    fputs(",\"channels\":[", fp);
    for (size_t ch = 0; ch < v->nchannels; ch++) {
        fputs(ch ? "," : "", fp);
        json_string(fp, v->channels[ch]);
    }
    fputs("],\"m\":[", fp);
    size_t nc = ncols_of(v), w = nc < VIEW_CHUNK ? nc : VIEW_CHUNK;
    double *buf = malloc(n * w * sizeof *buf);
    size_t *idx = malloc(w * sizeof *idx);
    int rc = buf && idx ? CLI_OK : cli_fail(sub, "out of memory");
    for (size_t f = 0; f < v->nfiles && rc == CLI_OK; f++) {
        fputs(f ? ",[" : "[", fp);
        for (size_t ch = 0; ch < v->nchannels && rc == CLI_OK; ch++) {
            int lc = bst_layer_find_channel(v->files[f].l, v->channels[ch]);
            fputs(ch ? ",{" : "{", fp);
            for (int c = 0; c < BST_NCOMP && rc == CLI_OK; c++) {
                const bst_mat *m = bst_layer_get(v->files[f].l, (size_t)lc, (bst_comp)c);
                fprintf(fp, "%s\"%s\":", c ? "," : "", bst_comp_name((bst_comp)c));
                if (!m || bst_mat_structure(m) == BST_ZERO)
                    fputs("null", fp);
                else
                    rc = json_component(ctx, sub, fp, v, f, m, buf, idx);
            }
            fputc('}', fp);
        }
        fputc(']', fp);
    }
    fputs("]}", fp);
    free(buf), free(idx);
    return rc;
}

/* The page's text from `from` up to the marker (or its end): where the marker was, or NULL. */
static const char *page_until(FILE *fp, const char *from, const char *marker)
{
    const char *at = strstr(from, marker);
    fwrite(from, 1, at ? (size_t)(at - from) : strlen(from), fp);
    return at ? at + strlen(marker) : NULL;
}

int cli_view_write(bst_ctx *ctx, const char *sub, FILE *fp, const struct cli_view *v)
{
    const char *p = page_until(fp, view_page, "@TITLE@");
    for (size_t f = 0; f < v->nfiles; f++) {
        const char *base = strrchr(v->files[f].path, '/');
        base = base ? base + 1 : v->files[f].path;
        fputs(f ? ", " : "", fp);
        for (; *base; base++) /* text inside <title>: no markup */
            if (*base == '<')
                fputs("&lt;", fp);
            else if (*base == '&')
                fputs("&amp;", fp);
            else
                fputc(*base, fp);
    }
    if (!p || !(p = page_until(fp, p, "@CSS@")))
        return cli_fail(sub, "the page's template lacks its markers (a broken build)");
    fputs(view_css, fp);
    if (!(p = page_until(fp, p, "@DATA@")))
        return cli_fail(sub, "the page's template lacks its markers (a broken build)");
    int rc = json_data(ctx, sub, fp, v);
    if (rc != CLI_OK)
        return rc;
    if (!(p = page_until(fp, p, "@JS@")))
        return cli_fail(sub, "the page's template lacks its markers (a broken build)");
    fputs(view_js, fp);
    fputs(p, fp);
    return CLI_OK;
}
