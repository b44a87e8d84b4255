/* glass_json2.c - IGSDB v2 glazing records (the shape the database's v2 API and its "LBNL-JSON"
 * exports give a product): a pane's spectral data and metadata.  glass_json.c reads the file,
 * tells v1 from v2 (v2 has physical_properties and no product_id) and hands a v2 glazing record
 * here.
 *
 * Fields read (bsdfstack-glass(5), "IGSDB records"): type ("GLAZING", any case), subtype (the
 * material type: MONOLITHIC, COATED, LAMINATE, APPLIED_FILM, ...; it picks the angular model),
 * name, manufacturer_name, nfrc_id, coating_name, coated_side, emissivity_front, emissivity_back,
 * tir_front; physical_properties {is_specular, thickness (mm), predefined_emissivity_front and
 * _back (when the record's own are absent), bulk_properties_override.conductivity,
 * optical_properties.optical_data.angle_blocks: [{incidence_angle, wavelength_data: [{w (um),
 * specular {tf, tb, rf, rb}, diffuse {...}}]}]}; material_bulk_properties.conductivity when no
 * override.  v2 writes most numbers as strings ("0.0476"): a number or a string holding exactly
 * one finite number is taken.  Only the block at incidence_angle 0 is read (the angular model
 * gives the other angles).  A pane is specular: a record with is_specular false or a row with a
 * diffuse part other than 0 is refused, as an Optics file's hazy rows are.  Every error is one line
 * naming the file and the field. */
#include <config.h>

#include <errno.h>
#include <jansson.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "ctx.h"
#include "glass.h"
#include "glass_json.h"

/* obj.key as a number, given as one or as a string holding one (at: obj's path); NaN when absent
 * and not required. */
static int number(const struct bsti_jr *jr, json_t *obj, const char *at, const char *key, int required,
                  double *x)
{
    json_t *v = bsti_json_member(obj, key);
    *x = NAN;
    if (!v)
        return required ? bsti_json_error(jr, BST_EFORMAT, "%s%s%s: missing (a number)", at, *at ? "." : "", key) : BST_OK;
    if (json_is_number(v)) {
        *x = json_number_value(v);
        return BST_OK;
    }
    const char *s = json_is_string(v) ? json_string_value(v) : NULL;
    char *end = NULL;
    errno = 0;
    double y = s ? strtod(s, &end) : NAN;
    while (end && (*end == ' ' || *end == '\t'))
        end++;
    if (!s || end == s || *end || errno || !isfinite(y))
        return bsti_json_error(jr, BST_EFORMAT, "%s%s%s is not a number", at, *at ? "." : "", key);
    *x = y;
    return BST_OK;
}

/* obj.key as a string (owned by the tree), "" when absent. */
static int text(const struct bsti_jr *jr, json_t *obj, const char *key, int required, const char **s)
{
    json_t *v = bsti_json_member(obj, key);
    *s = "";
    if (!v)
        return required ? bsti_json_error(jr, BST_EFORMAT, "%s: missing (a string)", key) : BST_OK;
    if (!json_is_string(v))
        return bsti_json_error(jr, BST_EFORMAT, "%s is not a string", key);
    *s = json_string_value(v);
    return BST_OK;
}

#define V2_BLOCKS "physical_properties.optical_properties.optical_data.angle_blocks"

/* The wavelength_data of the angle block at normal incidence, NULL after an error. */
static json_t *normal_block(const struct bsti_jr *jr, json_t *pp, char *at, size_t size)
{
    json_t *blocks = bsti_json_member(bsti_json_member(bsti_json_member(pp, "optical_properties"), "optical_data"), "angle_blocks");
    if (!json_is_array(blocks) || !json_array_size(blocks)) {
        bsti_json_error(jr, BST_EFORMAT, V2_BLOCKS ": %s", blocks ? "not a non-empty list" : "missing (the spectral data)");
        return NULL;
    }
    for (size_t b = 0; b < json_array_size(blocks); b++) {
        json_t *blk = json_array_get(blocks, b);
        double angle;
        snprintf(at, size, V2_BLOCKS "[%zu]", b);
        if (number(jr, blk, at, "incidence_angle", 1, &angle) < 0)
            return NULL;
        if (angle != 0.0)
            continue;
        json_t *rows = bsti_json_member(blk, "wavelength_data");
        if (!json_is_array(rows) || json_array_size(rows) < 2) {
            bsti_json_error(jr, BST_EFORMAT, "%s.wavelength_data: %s", at, !rows ? "missing" : json_is_array(rows)
                 ? "fewer than two rows" : "is not a list");
            return NULL;
        }
        return rows;
    }
    bsti_json_error(jr, BST_EFORMAT, V2_BLOCKS ": no block at incidence_angle 0 (normal incidence)");
    return NULL;
}

/* The rows of the normal-incidence block into g->data, checked as every format's rows are. */
static int read_rows2(const struct bsti_jr *jr, json_t *pp, struct bsti_glass_data *d)
{
    char at[200];
    json_t *rows = normal_block(jr, pp, at, sizeof at);
    if (!rows)
        return BST_EFORMAT;
    size_t cap = 0, n = json_array_size(rows);
    int rc = bsti_glass_data_reserve(jr->ctx, d, &cap, n);
    static const char *const key[4] = {"tf", "tb", "rf", "rb"};
    for (size_t k = 0; k < n && rc >= 0; k++) {
        char where[260], part[300];
        snprintf(where, sizeof where, "%s.wavelength_data[%zu]", at, k);
        json_t *r = json_array_get(rows, k), *spec = bsti_json_member(r, "specular"), *dif = bsti_json_member(r, "diffuse");
        double wl, v[4], x;
        if ((rc = number(jr, r, where, "w", 1, &wl)) < 0)
            return rc;
        snprintf(part, sizeof part, "%s.specular", where);
        for (int i = 0; i < 4 && rc >= 0; i++)
            rc = number(jr, spec, part, key[i], 1, &v[i]);
        snprintf(part, sizeof part, "%s.diffuse", where);
        for (int i = 0; i < 4 && rc >= 0; i++)
            if ((rc = number(jr, dif, part, key[i], 0, &x)) >= 0 && !isnan(x) && x != 0.0)
                rc = bsti_json_error(jr, BST_EFORMAT, "%s.%s = %g: a pane is specular, and hazy "
                                     "products (diffuse parts) are not modelled", part, key[i], x);
        if (rc < 0)
            return rc;
        if ((rc = bsti_json_row(jr, where, d, k, wl, v)) < 0)
            return rc;
    }
    return rc;
}

/* The record's numbers into g->meta: thickness, conductivity, emissivities, IR transmittance. */
static int read_physical(const struct bsti_jr *jr, json_t *root, json_t *pp, bst_glass_meta *m)
{
    const char *at = "physical_properties";
    double c;
    int rc;
    if ((rc = number(jr, pp, at, "thickness", 0, &m->thickness_mm)) < 0 ||
        (rc = number(jr, root, "", "emissivity_front", 0, &m->emissivity_front)) < 0 ||
        (rc = number(jr, root, "", "emissivity_back", 0, &m->emissivity_back)) < 0 ||
        (rc = number(jr, root, "", "tir_front", 0, &m->ir_transmittance)) < 0 ||
        (isnan(m->emissivity_front) &&
         (rc = number(jr, pp, at, "predefined_emissivity_front", 0, &m->emissivity_front)) < 0) ||
        (isnan(m->emissivity_back) &&
         (rc = number(jr, pp, at, "predefined_emissivity_back", 0, &m->emissivity_back)) < 0) ||
        (rc = number(jr, bsti_json_member(pp, "bulk_properties_override"),
                     "physical_properties.bulk_properties_override", "conductivity", 0, &c)) < 0 ||
        (isnan(c) && (rc = number(jr, bsti_json_member(root, "material_bulk_properties"),
                                  "material_bulk_properties", "conductivity", 0, &c)) < 0))
        return rc;
    m->conductivity = c;
    if (!isnan(m->thickness_mm) &&
        !(m->thickness_mm > 0.0 && m->thickness_mm <= BSTI_GLASS_MAX_THICKNESS_MM))
        return bsti_json_error(jr, BST_EFORMAT, "physical_properties.thickness = %g is not a thickness in mm",
                    m->thickness_mm);
    if (!isnan(c) && !(c > 0.0 && c <= BSTI_GLASS_MAX_CONDUCTIVITY))
        return bsti_json_error(jr, BST_EFORMAT, "conductivity = %g is not one in W/(m K)", c);
    return BST_OK;
}

int bsti_glass_read_glazing_v2(bst_ctx *ctx, const char *path, bst_glass *g, struct json_t *root)
{
    const struct bsti_jr jr = {ctx, path};
    bst_glass_meta *m = &g->meta;
    const char *subtype, *name, *maker, *coating, *side;
    int rc;
    if ((rc = text(&jr, root, "subtype", 1, &subtype)) < 0 ||
        (rc = text(&jr, root, "name", 0, &name)) < 0 ||
        (rc = text(&jr, root, "manufacturer_name", 0, &maker)) < 0 ||
        (rc = text(&jr, root, "coating_name", 0, &coating)) < 0 ||
        (rc = text(&jr, root, "coated_side", 0, &side)) < 0)
        return rc;
    json_t *id = bsti_json_member(root, "nfrc_id");
    if (id && !json_is_integer(id))
        return bsti_json_error(&jr, BST_EFORMAT, "nfrc_id is not an integer");
    m->nfrc_id = id ? (long)json_integer_value(id) : -1;
    json_t *pp = bsti_json_member(root, "physical_properties"), *specular = bsti_json_member(pp, "is_specular");
    if (!json_is_object(pp))
        return bsti_json_error(&jr, BST_EFORMAT, "physical_properties is not an object");
    if (specular && !json_is_boolean(specular))
        return bsti_json_error(&jr, BST_EFORMAT, "physical_properties.is_specular is not true or false");
    if (json_is_false(specular))
        return bsti_json_error(&jr, BST_EFORMAT, "physical_properties.is_specular is false: a diffusing glazing product "
                    "(a pane is specular, and hazy products are not modelled)");
    if ((rc = read_physical(&jr, root, pp, m)) < 0 || (rc = read_rows2(&jr, pp, &g->data)) < 0)
        return rc;
    if ((rc = bsti_glass_meta_set(g, &m->type, subtype)) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->product_name, name)) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->manufacturer, maker)) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->coating_name, coating)) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->coated_side, side)) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->wavelength_units, "Microns")) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->source, "igsdb")) < 0)
        return rc;
    return bsti_glass_meta_set(g, &m->path, path);
}
