/* glass_optics.c - a pane's spectral data from an Optics / IGDB text file (the files WINDOW and
 * Optics exchange, named after the product and its maker: CLEAR_6.DAT, *.LOF, *.afg, ...), and the
 * sniffing that tells the data formats apart.
 *
 * Such a file (bsdfstack-glass(5), "Optics files") is a header of lines with braces, then one data
 * row per wavelength.  Header lines read here:
 *   { Units, Wavelength Units } SI Microns     (or Nanometers; the unit system must be SI)
 *   { Thickness } 3.048                        (mm)        { Conductivity } 1     (W/(m K))
 *   { IR Transmittance } TIR=0                 { Emissivity, front back } Emis= 0.84 0.84
 *   { Product Name: ... }  { Manufacturer: ... }  { NFRC ID: 102 }  { Type: Monolithic }
 *   { Coating Name: ... }  { Coated Side: ... }
 * the type chooses the angular model (bst_glass_model_for_type), the rest is kept as metadata
 * (g->meta); every other line with a brace is ignored.  A data row is 4 numbers (wavelength, T,
 * Rf, Rb: T is both sides') or 9 (wavelength, then Tf, Tb, Rf and Rb, each as a direct and a
 * diffuse part: Tf_dir Tf_dif Tb_dir Tb_dif Rf_dir Rf_dif Rb_dir Rb_dif).  A pane here is specular,
 * so a row whose diffuse parts are not all zero (a hazy product) is refused rather than misplaced.
 * Line endings may be CR LF.  Every error names the file and the line. */
#include <config.h>

#include <ctype.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "ctx.h"
#include "glass.h"

/* Longest line read (characters, newline included, plus the NUL). */
#define OPTICS_LINE_MAX 4096

int bsti_glass_sniff(bst_ctx *ctx, const char *path, enum bsti_glass_format *fmt)
{
    FILE *fp = fopen(path, "r");
    if (!fp)
        return bsti_error(ctx, BST_EIO, "%s: cannot open: %s", path, strerror(errno));
    int c;
    *fmt = BSTI_GLASS_TABLE;
    while ((c = getc(fp)) != EOF && (isspace(c) || c == 0xEF || c == 0xBB || c == 0xBF))
        ; /* white space and a UTF-8 byte order mark */
    if (c == '[') {
        *fmt = BSTI_GLASS_IGSDB;
    } else if (c == '{') {
        while ((c = getc(fp)) == ' ' || c == '\t')
            ;
        *fmt = c == '"' || c == '\n' || c == '\r' || c == EOF ? BSTI_GLASS_IGSDB : BSTI_GLASS_OPTICS;
    }
    fclose(fp);
    return BST_OK;
}

/* s without leading and trailing white space (in place). */
static char *trim(char *s)
{
    while (isspace((unsigned char)*s))
        s++;
    size_t n = strlen(s);
    while (n && isspace((unsigned char)s[n - 1]))
        s[--n] = '\0';
    return s;
}

/* The one number in text (after an optional label such as "TIR="); -1 if it is not one. */
static int one_number(const char *text, const char *label, double *x)
{
    if (label) {
        const char *p = strstr(text, label);
        if (!p)
            return -1;
        text = p + strlen(label);
    }
    char *end;
    errno = 0;
    *x = strtod(text, &end);
    if (end == text || errno || !isfinite(*x))
        return -1;
    while (isspace((unsigned char)*end))
        end++;
    return *end ? -1 : 0;
}

/* Where the reader is (file, line) and what it has learnt: the wavelength divisor (1 for
 * micrometres, 1000 for nanometres), the rows read, their capacity and layout. */
struct optics_state {
    const char *path;
    int line;
    double wl_div;
    size_t rows, cap;
    int ncol; /* 4 or 9, fixed by the first row */
};

static int optics_error(bst_ctx *ctx, const struct optics_state *st, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static int optics_error(bst_ctx *ctx, const struct optics_state *st, const char *fmt, ...)
{
    char msg[600];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return bsti_error(ctx, BST_EFORMAT, "%s:%d: %s", st->path, st->line, msg);
}

/* "{ Units, Wavelength Units } SI Microns": the unit system and the wavelength unit. */
static int header_units(bst_ctx *ctx, bst_glass *g, struct optics_state *st, char *rest)
{
    char *save = NULL, *sys = strtok_r(rest, " \t", &save), *wl = strtok_r(NULL, " \t", &save);
    if (!sys || !wl || strtok_r(NULL, " \t", &save))
        return optics_error(ctx, st, "the units line needs a unit system and a wavelength unit "
                            "(SI Microns, SI Nanometers)");
    if (strcasecmp(sys, "SI") != 0)
        return optics_error(ctx, st, "unit system '%s': bsdfstack reads SI files (thickness in mm)",
                            sys);
    if (st->rows)
        return optics_error(ctx, st, "the units line comes after data rows");
    static const char *const um[] = {"Microns", "Micrometers", "Micrometres", "um", NULL};
    static const char *const nm[] = {"Nanometers", "Nanometres", "nm", NULL};
    st->wl_div = 0;
    for (int i = 0; um[i]; i++)
        if (strcasecmp(wl, um[i]) == 0)
            st->wl_div = 1.0;
    for (int i = 0; nm[i]; i++)
        if (strcasecmp(wl, nm[i]) == 0)
            st->wl_div = 1000.0;
    if (st->wl_div == 0)
        return optics_error(ctx, st, "wavelength unit '%s' (Microns or Nanometers)", wl);
    return bsti_glass_meta_set(g, &g->meta.wavelength_units, wl);
}

/* "{ Emissivity, front back } Emis= 0.84 0.84": the order of the words says which is which. */
static int header_emissivity(bst_ctx *ctx, bst_glass *g, struct optics_state *st, const char *key,
                             const char *rest)
{
    const char *p = strstr(rest, "Emis=");
    if (!p)
        return BST_OK; /* no values: nothing to keep */
    char *end;
    double e[2];
    p += 5;
    for (int i = 0; i < 2; i++, p = end) {
        errno = 0;
        e[i] = strtod(p, &end);
        if (end == p || errno || !(e[i] >= 0.0 && e[i] <= 1.0))
            return optics_error(ctx, st, "the emissivity line needs two values in [0, 1] after "
                                "Emis=");
    }
    const char *f = strstr(key, "front"), *b = strstr(key, "back");
    int back_first = f && b && b < f;
    g->meta.emissivity_front = e[back_first], g->meta.emissivity_back = e[!back_first];
    return BST_OK;
}

/* A line with a brace: "{ KEY } VALUE" or "{ KEY: VALUE }". */
static int header_line(bst_ctx *ctx, bst_glass *g, struct optics_state *st, char *line)
{
    char *open = strchr(line, '{'), *close = strchr(open, '}'), *rest = (char *)"";
    if (close)
        *close = '\0', rest = trim(close + 1);
    char *key = trim(open + 1), *colon = strchr(key, ':'), *value = NULL;
    if (colon)
        *colon = '\0', value = trim(colon + 1), key = trim(key);
    static const struct {
        const char *key;
        size_t off;
    } texts[] = {
        {"Product Name", offsetof(bst_glass_meta, product_name)},
        {"Manufacturer", offsetof(bst_glass_meta, manufacturer)},
        {"Type", offsetof(bst_glass_meta, type)},
        {"Coating Name", offsetof(bst_glass_meta, coating_name)},
        {"Coated Side", offsetof(bst_glass_meta, coated_side)},
    };
    if (value) {
        for (size_t i = 0; i < sizeof texts / sizeof texts[0]; i++)
            if (strcasecmp(key, texts[i].key) == 0)
                return bsti_glass_meta_set(g, (const char **)((char *)&g->meta + texts[i].off),
                                           value);
        if (strcasecmp(key, "NFRC ID") == 0) {
            double id;
            if (!*value || strcasecmp(value, "N/A") == 0)
                return BST_OK;
            if (one_number(value, NULL, &id) < 0 || id != floor(id) || !(id >= 0 && id < (double)LONG_MAX))
                return optics_error(ctx, st, "NFRC ID '%s' is not a number", value);
            g->meta.nfrc_id = (long)id;
        }
        return BST_OK;
    }
    struct {
        const char *key, *label;
        double *x;
        double lo, hi;
    } nums[] = {
        {"Thickness", NULL, &g->meta.thickness_mm, 0.0, BSTI_GLASS_MAX_THICKNESS_MM},
        {"Conductivity", NULL, &g->meta.conductivity, 0.0, BSTI_GLASS_MAX_CONDUCTIVITY},
        {"IR Transmittance", "TIR=", &g->meta.ir_transmittance, 0.0, 1.0},
    };
    for (size_t i = 0; i < sizeof nums / sizeof nums[0]; i++)
        if (strcasecmp(key, nums[i].key) == 0) {
            double x;
            if (one_number(rest, nums[i].label, &x) < 0 || !(x >= nums[i].lo && x <= nums[i].hi))
                return optics_error(ctx, st, "{ %s } needs a number in %g..%g%s%s, not '%s'",
                                    nums[i].key, nums[i].lo, nums[i].hi,
                                    nums[i].label ? " after " : "",
                                    nums[i].label ? nums[i].label : "", rest);
            *nums[i].x = x;
            return BST_OK;
        }
    if (strncasecmp(key, "Units", 5) == 0) /* "Units, Wavelength Units", however spaced */
        return header_units(ctx, g, st, rest);
    if (strncasecmp(key, "Emissivity", 10) == 0)
        return header_emissivity(ctx, g, st, key, rest);
    return BST_OK; /* a header line bsdfstack has no use for */
}

/* A data row of 4 or 9 numbers. */
static int data_row(bst_ctx *ctx, bst_glass *g, struct optics_state *st, const char *line)
{
    double x[10];
    int n = 0;
    const char *p = line;
    while (*p) {
        char *end;
        errno = 0;
        double v = strtod(p, &end);
        if (end == p || errno || !isfinite(v) || (*end && !isspace((unsigned char)*end))) {
            int len = 0;
            while (p[len] && !isspace((unsigned char)p[len]) && len < 40)
                len++;
            return optics_error(ctx, st, "'%.*s' is not a number (a data row is 4 or 9 numbers)",
                                len, p);
        }
        if (n < 10)
            x[n] = v;
        n++;
        for (p = end; isspace((unsigned char)*p); p++)
            ;
    }
    if (n != 4 && n != 9)
        return optics_error(ctx, st, "%d numbers: a data row has 4 (wavelength, T, Rf, Rb) or 9 "
                            "(wavelength, then Tf, Tb, Rf, Rb each direct and diffuse)", n);
    if (st->ncol && n != st->ncol)
        return optics_error(ctx, st, "%d numbers after rows of %d", n, st->ncol);
    st->ncol = n;
    double v[4]; /* Tf, Tb, Rf, Rb */
    if (n == 4) {
        v[0] = v[1] = x[1], v[2] = x[2], v[3] = x[3];
    } else {
        static const char *const part[4] = {"Tf", "Tb", "Rf", "Rb"};
        for (int i = 0; i < 4; i++) {
            if (x[2 + 2 * i] != 0.0)
                return optics_error(ctx, st, "diffuse part %s_dif = %g: a pane is specular, and "
                                    "hazy products (diffuse parts) are not modelled (the "
                                    "product's BSDF file can be a layer instead)", part[i],
                                    x[2 + 2 * i]);
            v[i] = x[1 + 2 * i];
        }
    }
    /* the divisor rather than a factor 1e-3: 305 / 1000 is the double nearest 0.305, as a file in
     * micrometres would give it */
    double um = x[0] / st->wl_div;
    char where[600];
    snprintf(where, sizeof where, "%s:%d", st->path, st->line);
    struct bsti_glass_data *d = &g->data;
    int rc = bsti_glass_row_check(ctx, where, d->n ? d->wl[d->n - 1] : -INFINITY, um, v);
    if (rc >= 0)
        rc = bsti_glass_data_reserve(ctx, d, &st->cap, d->n + 1);
    if (rc < 0)
        return rc;
    d->wl[d->n] = um, d->tf[d->n] = v[0], d->tb[d->n] = v[1], d->rf[d->n] = v[2];
    d->rb[d->n] = v[3];
    d->n++, st->rows++;
    return BST_OK;
}

int bsti_glass_read_optics(bst_ctx *ctx, bst_glass *g, const char *path)
{
    FILE *fp = fopen(path, "r");
    if (!fp)
        return bsti_error(ctx, BST_EIO, "%s: cannot open: %s", path, strerror(errno));
    struct optics_state st = {path, 0, 1.0, 0, 0, 0};
    char *buf = bsti_malloc(ctx, OPTICS_LINE_MAX);
    int rc = buf ? BST_OK : BST_ENOMEM, got;
    while (rc >= 0 && (got = bsti_glass_read_line(fp, buf, OPTICS_LINE_MAX)) != 0) {
        st.line++;
        if (got < 0) {
            rc = bsti_glass_line_error(ctx, path, st.line, got, OPTICS_LINE_MAX);
            break;
        }
        char *line = trim(buf);
        if (!*line)
            continue;
        rc = strchr(line, '{') ? header_line(ctx, g, &st, line) : data_row(ctx, g, &st, line);
    }
    if (rc >= 0 && ferror(fp))
        rc = bsti_error(ctx, BST_EIO, "%s: read error", path);
    fclose(fp);
    bsti_free(ctx, buf);
    if (rc >= 0 && g->data.n < 2)
        rc = bsti_error(ctx, BST_EFORMAT, "%s: %zu data rows (an Optics file needs at least two)",
                        path, g->data.n);
    if (rc >= 0)
        rc = bsti_glass_meta_set(g, &g->meta.source, "optics");
    if (rc >= 0)
        rc = bsti_glass_meta_set(g, &g->meta.path, path);
    return rc;
}
