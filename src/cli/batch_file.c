/* batch_file.c - reading a `bsdfstack batch` file into stack lines and distinct layer specs
 * (batch_file.h).  Nothing here prints: the one error line goes back to the caller, which names
 * the subcommand (cmd_batch.c). */
#include <config.h>

#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "batch_file.h"

#define BATCH_BLANKS " \t\r\n"

/* Record the one error line in *err (malloc'd, or NULL when even that fails); returns -1. */
static int failf(char **err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static int failf(char **err, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    free(*err);
    *err = n >= 0 ? malloc((size_t)n + 1) : NULL;
    if (*err) {
        va_start(ap, fmt);
        vsnprintf(*err, (size_t)n + 1, fmt, ap);
        va_end(ap);
    }
    return -1;
}

/* Index of spec among the distinct ones, adding it when new; (size_t)-1 when out of memory. */
static size_t spec_index(struct batch_file *bf, size_t *cap, const char *spec)
{
    for (size_t i = 0; i < bf->nspecs; i++)
        if (strcmp(bf->specs[i], spec) == 0)
            return i;
    if (bf->nspecs == *cap) {
        size_t nc = *cap ? 2 * *cap : 16;
        char **s = realloc(bf->specs, nc * sizeof *s);
        if (!s)
            return (size_t)-1;
        bf->specs = s, *cap = nc;
    }
    if (!(bf->specs[bf->nspecs] = strdup(spec)))
        return (size_t)-1;
    return bf->nspecs++;
}

/* The words after the output file of one line into sl; 0 or -1 (out of memory). */
static int read_layers(struct batch_file *bf, size_t *cap_specs, struct batch_line *sl, char **save)
{
    size_t cap = 0;
    char *w;
    while ((w = strtok_r(NULL, BATCH_BLANKS, save))) {
        if (sl->n == cap) {
            size_t nc = cap ? 2 * cap : 4, *l = realloc(sl->layer, nc * sizeof *l);
            if (!l)
                return -1;
            sl->layer = l, cap = nc;
        }
        size_t k = spec_index(bf, cap_specs, w);
        if (k == (size_t)-1)
            return -1;
        sl->layer[sl->n++] = k;
    }
    return 0;
}

int batch_file_parse(FILE *fp, const char *path, struct batch_file *bf, char **err)
{
    memset(bf, 0, sizeof *bf);
    *err = NULL;
    size_t cap_lines = 0, cap_specs = 0, lineno = 0;
    char *buf = NULL;
    size_t bufsize = 0;
    int rc = 0;
    while (rc == 0 && getline(&buf, &bufsize, fp) >= 0) {
        lineno++;
        char *save = NULL, *w = strtok_r(buf, BATCH_BLANKS, &save);
        if (!w || w[0] == '#')
            continue;
        if (bf->nlines == cap_lines) {
            size_t nc = cap_lines ? 2 * cap_lines : 16;
            struct batch_line *l = realloc(bf->lines, nc * sizeof *l);
            if (!l) {
                rc = failf(err, "out of memory");
                break;
            }
            bf->lines = l, cap_lines = nc;
        }
        struct batch_line *sl = &bf->lines[bf->nlines];
        memset(sl, 0, sizeof *sl);
        sl->lineno = lineno;
        bf->nlines++;
        if (!(sl->out = strdup(w)) || read_layers(bf, &cap_specs, sl, &save) < 0) {
            rc = failf(err, "out of memory");
            break;
        }
        if (sl->n == 0)
            rc = failf(err, "%s:%zu: no layers after the output file '%s': give OUT LAYER "
                       "LAYER...", path, lineno, sl->out);
        for (size_t i = 0; rc == 0 && i + 1 < bf->nlines; i++)
            if (strcmp(bf->lines[i].out, sl->out) == 0)
                rc = failf(err, "%s:%zu: '%s' is written by line %zu already", path, lineno,
                           sl->out, bf->lines[i].lineno);
    }
    if (rc == 0 && ferror(fp))
        rc = failf(err, "%s: read error", path);
    if (rc == 0 && bf->nlines == 0)
        rc = failf(err, "%s: no stacks: give one line OUT LAYER LAYER... per stack", path);
    free(buf);
    return rc;
}

void batch_file_free(struct batch_file *bf)
{
    if (!bf)
        return;
    for (size_t i = 0; i < bf->nlines; i++)
        free(bf->lines[i].out), free(bf->lines[i].layer);
    free(bf->lines);
    for (size_t i = 0; i < bf->nspecs; i++)
        free(bf->specs[i]);
    free(bf->specs);
    memset(bf, 0, sizeof *bf);
}
