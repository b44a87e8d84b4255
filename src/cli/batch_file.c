/* batch_file.c - reading a `bsdfstack batch` file into stack lines and distinct layer specs
 * (batch_file.h).  Nothing here prints: the one error line goes back to the caller, which names
 * the subcommand (cmd_batch.c).  Output files and layer specs are looked up in hash tables, so a
 * file of n lines costs O(n) however many stacks and distinct layers it names. */
#include <config.h>

#include <errno.h>

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
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

/* Strings owned elsewhere (bf's specs and output names), each with an index: open addressing
 * with linear probing, at most half full. */
struct name_slot {
    const char *key; /* NULL: empty */
    size_t value;
};
struct name_index {
    struct name_slot *slot;
    size_t cap; /* 0 or a power of two */
    size_t n;
};

static uint64_t name_hash(const char *s)
{
    uint64_t h = 14695981039346656037u; /* FNV-1a, 64 bits */
    for (; *s; s++)
        h = (h ^ (unsigned char)*s) * 1099511628211u;
    return h;
}

/* The slot holding key, or the empty one where it goes; ix->cap > ix->n. */
static struct name_slot *name_find(const struct name_index *ix, const char *key)
{
    size_t mask = ix->cap - 1, i = (size_t)name_hash(key) & mask;
    while (ix->slot[i].key && strcmp(ix->slot[i].key, key) != 0)
        i = (i + 1) & mask;
    return &ix->slot[i];
}

/* Room for one more key (slots found before this call move); 0 or -1 when out of memory. */
static int name_reserve(struct name_index *ix)
{
    if (2 * (ix->n + 1) <= ix->cap)
        return 0;
    struct name_index grown = {.cap = ix->cap ? 2 * ix->cap : 64, .n = ix->n};
    if (!(grown.slot = calloc(grown.cap, sizeof *grown.slot)))
        return -1;
    for (size_t i = 0; i < ix->cap; i++)
        if (ix->slot[i].key)
            *name_find(&grown, ix->slot[i].key) = ix->slot[i];
    free(ix->slot);
    *ix = grown;
    return 0;
}

/* Index of spec among the distinct ones, adding it when new; (size_t)-1 when out of memory. */
static size_t spec_index(struct batch_file *bf, struct name_index *known, size_t *cap,
                         const char *spec)
{
    if (name_reserve(known) < 0)
        return (size_t)-1;
    struct name_slot *s = name_find(known, spec);
    if (s->key)
        return s->value;
    if (bf->nspecs == *cap) {
        size_t nc = *cap ? 2 * *cap : 16;
        char **l = realloc(bf->specs, nc * sizeof *l);
        if (!l)
            return (size_t)-1;
        bf->specs = l, *cap = nc;
    }
    if (!(bf->specs[bf->nspecs] = strdup(spec)))
        return (size_t)-1;
    s->key = bf->specs[bf->nspecs], s->value = bf->nspecs;
    known->n++;
    return bf->nspecs++;
}

/* The words after the output file of one line into sl; 0 or -1 (out of memory). */
static int read_layers(struct batch_file *bf, struct name_index *known, size_t *cap_specs,
                       struct batch_line *sl, char **save)
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
        size_t k = spec_index(bf, known, cap_specs, w);
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
    struct name_index specs = {0}, outs = {0}; /* specs: index in bf->specs; outs: in bf->lines */
    int rc = 0;
    ssize_t len;
    while (rc == 0 && (len = getline(&buf, &bufsize, fp)) >= 0) {
        lineno++;
        /* the words end at a NUL: what follows it would be dropped without a word */
        char *nul = memchr(buf, '\0', (size_t)len);
        if (nul) {
            rc = failf(err, "%s:%zu: a NUL byte at column %zu: not a text line", path, lineno,
                       (size_t)(nul - buf) + 1);
            break;
        }
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
        if (!(sl->out = strdup(w)) || read_layers(bf, &specs, &cap_specs, sl, &save) < 0) {
            rc = failf(err, "out of memory");
            break;
        }
        if (sl->n == 0) {
            rc = failf(err, "%s:%zu: no layers after the output file '%s': give OUT LAYER "
                       "LAYER...", path, lineno, sl->out);
            break;
        }
        if (name_reserve(&outs) < 0) {
            rc = failf(err, "out of memory");
            break;
        }
        struct name_slot *o = name_find(&outs, sl->out);
        if (o->key) {
            rc = failf(err, "%s:%zu: '%s' is written by line %zu already", path, lineno, sl->out,
                       bf->lines[o->value].lineno);
            break;
        }
        o->key = sl->out, o->value = bf->nlines - 1;
        outs.n++;
    }
    free(specs.slot);
    free(outs.slot);
    if (rc == 0 && ferror(fp))
        rc = failf(err, "%s: read error: %s", strcmp(path, "-") == 0 ? "standard input" : path,
                   strerror(errno ? errno : EIO));
    if (rc == 0 && bf->nlines == 0)
        rc = failf(err, "%s: no stacks: give one line OUT LAYER LAYER... per stack", path);
    free(buf);
    return rc;
}

char **batch_file_places(const struct batch_file *bf, const char *path)
{
    size_t each = strlen(path) + 24; /* ":" and a line number */
    if (bf->nspecs > ((size_t)-1 / 2) / (each + sizeof(char *)))
        return NULL;
    char **place = malloc(bf->nspecs * (sizeof *place + each) + 1);
    if (!place)
        return NULL;
    char *text = (char *)(place + bf->nspecs);
    for (size_t i = 0; i < bf->nspecs; i++)
        place[i] = NULL;
    for (size_t l = 0; l < bf->nlines; l++) /* lines in file order: the first to name it */
        for (size_t j = 0; j < bf->lines[l].n; j++) {
            size_t i = bf->lines[l].layer[j];
            if (!place[i]) {
                place[i] = text + i * each;
                snprintf(place[i], each, "%s:%zu", path, bf->lines[l].lineno);
            }
        }
    for (size_t i = 0; i < bf->nspecs; i++) /* every spec is some line's: not reached */
        if (!place[i])
            place[i] = (char *)path;
    return place;
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
