/* glass_json.h - what the IGSDB JSON readers share (glass_json.c: v1 records and the dispatch,
 * glass_json2.c: v2 glazing records): the file for messages, one-line errors naming it, and
 * member lookup that treats null as absent. */
#ifndef BST_GLASS_JSON_H
#define BST_GLASS_JSON_H

#include <jansson.h>

#include "bsdfstack.h"
#include "glass.h"

/* The file being read, for messages. */
struct bsti_jr {
    bst_ctx *ctx;
    const char *path;
};

/* "PATH: message" as status in the context; returns status. */
int bsti_json_error(const struct bsti_jr *jr, int status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
/* obj.key, NULL when obj is not an object, the key is absent or its value null. */
json_t *bsti_json_member(json_t *obj, const char *key);
/* Row k of a pane's data (wavelength wl; v: Tf, Tb, Rf, Rb) checked against the row before
 * (bsti_glass_row_check, `where` naming it in the file) and stored. */
int bsti_json_row(const struct bsti_jr *jr, const char *where, struct bsti_glass_data *d,
                  size_t k, double wl, const double v[4]);

#endif
