/* glass_text.c - a pane's source, angular model and why, and what its file says of it, as text:
 * the # lines of `bsdfstack glass`, the lines of `info glass:SPEC`, and the one line per pane that
 * `combine` records in its output's header (where `info FILE` finds it).  Shared by bsdfstack and
 * bsdfstack-mpi (layers.c writes the header line). */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "cli.h"

/* Why the pane has its model, in a few words (g->meta.model_from). */
static void model_reason(const bst_glass_meta *m, char *buf, size_t size)
{
    if (strcmp(m->model_from, "type") == 0)
        snprintf(buf, size, "from the type %s", m->type);
    else if (strcmp(m->model_from, "spec") == 0)
        snprintf(buf, size, "model= in the spec%s%s", *m->type ? ", type " : "", m->type);
    else if (strcmp(m->model_from, "catalogue") == 0)
        snprintf(buf, size, "the catalogue's model line");
    else if (strcmp(m->model_from, "set") == 0)
        snprintf(buf, size, "set by the caller");
    else
        snprintf(buf, size, "no type given");
}

/* What the pane's file says of it, as fields of line `which` (0: product, 1: thickness and
 * coating, 2: thermal values, kept and not used) joined by "; ", appended to buf (len bytes used
 * of size); the new length.  Fields the file does not give are left out. */
static size_t meta_fields(const bst_glass_meta *m, int which, char *buf, size_t len, size_t size)
{
    const struct {
        int line;
        const char *fmt, *text;
        double x;
    } f[] = {
        {0, "product %s", m->product_name, NAN},
        {0, "manufacturer %s", m->manufacturer, NAN},
        {0, "NFRC ID %.0f", NULL, m->nfrc_id >= 0 ? (double)m->nfrc_id : NAN},
        {1, "thickness %g mm", NULL, m->thickness_mm},
        {1, "coating %s", m->coating_name, NAN},
        {1, "coated side %s", m->coated_side, NAN},
        {2, "emissivity front %g", NULL, m->emissivity_front},
        {2, "back %g", NULL, m->emissivity_back},
        {2, "conductivity %g W/(m K)", NULL, m->conductivity},
        {2, "IR transmittance %g", NULL, m->ir_transmittance},
    };
    size_t first = len;
    for (size_t i = 0; i < sizeof f / sizeof f[0]; i++) {
        if (f[i].line != which || (f[i].text ? !*f[i].text : isnan(f[i].x)) || size - len < 3)
            continue;
        char *p = buf + len;
        size_t room = size - len;
        int w = snprintf(p, room, "%s", len > first ? "; " : "");
        if (f[i].text)
            w += snprintf(p + w, room - (size_t)w, f[i].fmt, f[i].text);
        else
            w += snprintf(p + w, room - (size_t)w, f[i].fmt, f[i].x);
        len = (size_t)w < room ? len + (size_t)w : size - 1;
    }
    return len;
}

void cli_glass_summary(const bst_glass *g, char *buf, size_t size)
{
    const bst_glass_meta *m = bst_glass_metadata(g);
    char why[200];
    model_reason(m, why, sizeof why);
    int w = snprintf(buf, size, "%s model (%s); source %s%s%s",
                     bst_glass_model_name(bst_glass_get_model(g)), why, m->source,
                     *m->path ? " " : "", m->path);
    size_t len = w < 0 ? 0 : (size_t)w < size ? (size_t)w : size - 1;
    for (int k = 0; k < 3 && size - len > 3; k++) {
        size_t before = len;
        len = meta_fields(m, k, buf, len + 2, size);
        if (len == before + 2) /* nothing on that line: take the separator back */
            len = before;
        else
            memcpy(buf + before, "; ", 2);
        buf[len] = '\0';
    }
}

void cli_glass_describe(FILE *fp, const bst_glass *g, const char *prefix)
{
    const bst_glass_meta *m = bst_glass_metadata(g);
    bst_glass_model model = bst_glass_get_model(g);
    char why[200], buf[600];
    model_reason(m, why, sizeof why);
    fprintf(fp, "%ssource: %s%s%s\n", prefix, m->source, *m->path ? " " : "", m->path);
    fprintf(fp, "%smodel: %s (%s; %s)\n", prefix, bst_glass_model_name(model),
            model == BST_GLASS_COATED ? "WINDOW's correlations for coated glass"
                                      : "Windows-CalcEngine's uncoated slab", why);
    for (int k = 0; k < 3; k++)
        if (meta_fields(m, k, buf, 0, sizeof buf))
            fprintf(fp, "%s%s%s\n", prefix, buf, k == 2 ? " (kept, not used)" : "");
}
