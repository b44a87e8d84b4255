/* glass_json.c - IGSDB JSON product records (the International Glazing and Shading Database's API,
 * v1: igsdb.lbl.gov/api/v1/products/ID): a glazing product becomes a pane's spectral data and
 * metadata, a shading product a bst_shade (its material and geometry, validated; shade.c makes
 * it a layer of its geometric model).  A v2 record (physical_properties, no product_id) of a
 * glazing product is read by glass_json2.c.
 *
 * Fields read (bsdfstack-glass(5), "IGSDB records"): product_id, type ("glazing" or "shading"),
 * subtype (glazing: the material type that picks the angular model; shading: venetian, woven,
 * perforated-screen), name, product_name, manufacturer_name, nfrc_id, coating_name, coated_side,
 * unit_system (SI, when given), measured_data {is_specular (false: refused, a diffusing product),
 * thickness (mm), conductivity, emissivity_front, emissivity_back, tir_front,
 * permeability_factor}, spectral_data {spectral_data: [{wavelength (um), T, Rf, Rb}],
 * dual_band_values}; a shading product's composition[0] {child_product: its
 * material, a record of the same shape; extra_data.geometry}.  JSON null is the same as absent.
 * Other fields are ignored.  Every error is one line naming the file and the field.
 *
 * The JSON library is jansson (Debian libjansson-dev) rather than json-c: it parses strict RFC 8259
 * JSON and reports a syntax error's line and column (json-c gives a byte offset only, and accepts
 * comments and other extensions by default), it rejects duplicate keys on request
 * (JSON_REJECT_DUPLICATES: a record that names its thickness twice is ambiguous), and its API is
 * small: what is read here is a handful of typed getters on a tree that json_decref frees whole.
 * Its allocations go through its own allocator (setting another, json_set_alloc_funcs, is global
 * state, which the library avoids); everything kept goes through the context's. */
#include <config.h>

#include <jansson.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "ctx.h"
#include "glass.h"
#include "glass_json.h"

int bsti_json_error(const struct bsti_jr *jr, int status, const char *fmt, ...)
{
    char msg[700];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return bsti_error(jr->ctx, status, "%s: %s", jr->path, msg);
}

json_t *bsti_json_member(json_t *obj, const char *key)
{
    json_t *v = json_is_object(obj) ? json_object_get(obj, key) : NULL;
    return json_is_null(v) ? NULL : v;
}

int bsti_json_row(const struct bsti_jr *jr, const char *where, struct bsti_glass_data *d,
                  size_t k, double wl, const double v[4])
{
    char full[400];
    snprintf(full, sizeof full, "%s: %s", jr->path, where);
    int rc = bsti_glass_row_check(jr->ctx, full, k ? d->wl[k - 1] : -INFINITY, wl, v);
    if (rc < 0)
        return rc;
    d->wl[k] = wl, d->tf[k] = v[0], d->tb[k] = v[1], d->rf[k] = v[2], d->rb[k] = v[3];
    d->n = k + 1;
    return BST_OK;
}
/* obj.key as a number or a string (at: obj's path for messages); *v NULL when it is absent and
 * not required. */
static int field(const struct bsti_jr *jr, json_t *obj, const char *at, const char *key, int required,
                 int number, json_t **v)
{
    const char *what = number ? "a number" : "a string", *dot = *at ? "." : "";
    *v = bsti_json_member(obj, key);
    if (!*v)
        return required ? bsti_json_error(jr, BST_EFORMAT, "%s%s%s: missing (%s)", at, dot, key, what) : BST_OK;
    if (number ? !json_is_number(*v) : !json_is_string(*v))
        return bsti_json_error(jr, BST_EFORMAT, "%s%s%s is not %s", at, dot, key, what);
    return BST_OK;
}

/* A number obj.key: NaN when absent and not required. */
static int get_number(const struct bsti_jr *jr, json_t *obj, const char *at, const char *key,
                      int required, double *x)
{
    json_t *v;
    int rc = field(jr, obj, at, key, required, 1, &v);
    *x = v && rc >= 0 ? json_number_value(v) : NAN;
    return rc;
}

/* A string obj.key (owned by the tree): "" when absent and not required. */
static int get_string(const struct bsti_jr *jr, json_t *obj, const char *at, const char *key,
                      int required, const char **s)
{
    json_t *v;
    int rc = field(jr, obj, at, key, required, 0, &v);
    *s = v && rc >= 0 ? json_string_value(v) : "";
    return rc;
}

/* Read a record; the root must be an IGSDB product, v1 (product_id) or v2 (physical_properties). */
static int load(const struct bsti_jr *jr, json_t **root, const char **type)
{
    json_error_t e;
    *root = json_load_file(jr->path, JSON_REJECT_DUPLICATES, &e);
    if (!*root) {
        if (e.line < 1)
            return bsti_error(jr->ctx, BST_EFORMAT, "%s: %s", jr->path, e.text);
        return bsti_error(jr->ctx, BST_EFORMAT, "%s:%d:%d: not valid JSON: %s", jr->path, e.line,
                          e.column, e.text);
    }
    if (json_is_array(*root))
        return bsti_json_error(jr, BST_EFORMAT, "a list of %zu records: give one product record",
                    json_array_size(*root));
    if (!json_is_object(*root))
        return bsti_json_error(jr, BST_EFORMAT, "not an IGSDB product record (a JSON object)");
    if (!json_object_get(*root, "product_id") && !json_object_get(*root, "physical_properties"))
        return bsti_json_error(jr, BST_EFORMAT, json_object_get(*root, "id")
                    ? "an IGSDB v2 record without physical_properties: not a product record"
                    : "no product_id (v1) or physical_properties (v2): not an IGSDB product record");
    const char *units;
    int rc = get_string(jr, *root, "", "type", 1, type);
    if (rc >= 0)
        rc = get_string(jr, *root, "", "unit_system", 0, &units);
    if (rc >= 0 && *units && strcasecmp(units, "SI") != 0)
        rc = bsti_json_error(jr, BST_EFORMAT, "unit_system \"%s\": bsdfstack reads SI records (lengths in mm, "
                  "wavelengths in um)", units);
    return rc;
}

/* The rows of sd.spectral_data (at: sd's path) into d, checked as every format's rows are. */
static int read_rows(const struct bsti_jr *jr, json_t *sd, const char *at, struct bsti_glass_data *d)
{
    json_t *rows = bsti_json_member(sd, "spectral_data");
    if (!json_is_array(rows) || json_array_size(rows) < 2)
        return bsti_json_error(jr, BST_EFORMAT, "%s.spectral_data: %s", at,
                    !rows ? "missing (a list of {wavelength, T, Rf, Rb})"
                    : json_is_array(rows) ? "fewer than two rows" : "is not a list");
    size_t cap = 0, n = json_array_size(rows);
    int rc = bsti_glass_data_reserve(jr->ctx, d, &cap, n);
    for (size_t k = 0; k < n && rc >= 0; k++) {
        char where[160];
        snprintf(where, sizeof where, "%s.spectral_data[%zu]", at, k);
        json_t *r = json_array_get(rows, k);
        double wl, t, v[4];
        if (!json_is_object(r))
            return bsti_json_error(jr, BST_EFORMAT, "%s is not an object", where);
        if ((rc = get_number(jr, r, where, "wavelength", 1, &wl)) < 0 ||
            (rc = get_number(jr, r, where, "T", 1, &t)) < 0 ||
            (rc = get_number(jr, r, where, "Rf", 1, &v[2])) < 0 ||
            (rc = get_number(jr, r, where, "Rb", 1, &v[3])) < 0)
            return rc;
        v[0] = v[1] = t;
        if ((rc = bsti_json_row(jr, where, d, k, wl, v)) < 0)
            return rc;
    }
    return rc;
}

/* measured_data's numbers (at: the record's path, "" for the root). */
static int read_measured(const struct bsti_jr *jr, json_t *rec, const char *at, double *thickness,
                         double *conductivity, double *ef, double *eb, double *tir)
{
    char md[160];
    snprintf(md, sizeof md, "%s%smeasured_data", at, *at ? "." : "");
    json_t *m = bsti_json_member(rec, "measured_data");
    int rc;
    if ((rc = get_number(jr, m, md, "thickness", 0, thickness)) < 0 ||
        (rc = get_number(jr, m, md, "conductivity", 0, conductivity)) < 0 ||
        (rc = get_number(jr, m, md, "emissivity_front", 0, ef)) < 0 ||
        (rc = get_number(jr, m, md, "emissivity_back", 0, eb)) < 0 ||
        (rc = get_number(jr, m, md, "tir_front", 0, tir)) < 0)
        return rc;
    if (!isnan(*thickness) && !(*thickness > 0.0 && *thickness <= BSTI_GLASS_MAX_THICKNESS_MM))
        return bsti_json_error(jr, BST_EFORMAT, "%s.thickness = %g is not a thickness in mm", md, *thickness);
    return BST_OK;
}

/* ------------------------------------------------------------------ glazing products */

static int read_glazing(const struct bsti_jr *jr, bst_glass *g, json_t *root)
{
    bst_glass_meta *m = &g->meta;
    const char *subtype, *name, *product, *maker, *coating, *side;
    int rc;
    if ((rc = get_string(jr, root, "", "subtype", 1, &subtype)) < 0 ||
        (rc = get_string(jr, root, "", "name", 0, &name)) < 0 ||
        (rc = get_string(jr, root, "", "product_name", 0, &product)) < 0 ||
        (rc = get_string(jr, root, "", "manufacturer_name", 0, &maker)) < 0 ||
        (rc = get_string(jr, root, "", "coating_name", 0, &coating)) < 0 ||
        (rc = get_string(jr, root, "", "coated_side", 0, &side)) < 0)
        return rc;
    json_t *id = bsti_json_member(root, "nfrc_id");
    if (id && !json_is_integer(id))
        return bsti_json_error(jr, BST_EFORMAT, "nfrc_id is not an integer");
    m->nfrc_id = id ? (long)json_integer_value(id) : -1;
    json_t *specular = bsti_json_member(bsti_json_member(root, "measured_data"), "is_specular");
    if (specular && !json_is_boolean(specular))
        return bsti_json_error(jr, BST_EFORMAT, "measured_data.is_specular is not true or false");
    if (json_is_false(specular)) /* its rows hold direct and diffuse light as one */
        return bsti_json_error(jr, BST_EFORMAT, "measured_data.is_specular is false: a diffusing glazing "
                    "product (a pane is specular, and hazy products are not modelled)");
    if ((rc = read_measured(jr, root, "", &m->thickness_mm, &m->conductivity,
                            &m->emissivity_front, &m->emissivity_back, &m->ir_transmittance)) < 0)
        return rc;
    json_t *sd = bsti_json_member(root, "spectral_data");
    if (!sd)
        return bsti_json_error(jr, BST_EFORMAT, "spectral_data: missing (a glazing record needs its spectral "
                    "data)");
    if ((rc = read_rows(jr, sd, "spectral_data", &g->data)) < 0)
        return rc;
    if ((rc = bsti_glass_meta_set(g, &m->type, subtype)) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->product_name, *product ? product : name)) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->manufacturer, maker)) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->coating_name, coating)) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->coated_side, side)) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->wavelength_units, "Microns")) < 0 ||
        (rc = bsti_glass_meta_set(g, &m->source, "igsdb")) < 0)
        return rc;
    return bsti_glass_meta_set(g, &m->path, jr->path);
}

/* ------------------------------------------------------------------ shading products */

static const char *const shade_kinds[] = {"venetian", "woven", "perforated-screen"};

const char *bst_shade_kind_name(bst_shade_kind kind)
{
    return (unsigned)kind < 3 ? shade_kinds[kind] : "unknown";
}

void bst_shade_free(bst_shade *s)
{
    if (!s)
        return;
    bst_ctx *ctx = s->ctx;
    bsti_free(ctx, s->name), bsti_free(ctx, s->manufacturer), bsti_free(ctx, s->material.name);
    bsti_free(ctx, s->path);
    bsti_free(ctx, s->material.wl), bsti_free(ctx, s->material.tf), bsti_free(ctx, s->material.tb);
    bsti_free(ctx, s->material.rf), bsti_free(ctx, s->material.rb);
    bsti_free(ctx, s);
}

/* spectral_data.dual_band_values of the material (at: its path) into s->material. */
static int read_dual_band(const struct bsti_jr *jr, json_t *sd, const char *at, bst_shade *s)
{
    static const char *const comp[4] = {"Tf", "Tb", "Rf", "Rb"};
    json_t *db = bsti_json_member(sd, "dual_band_values");
    char where[240];
    snprintf(where, sizeof where, "%s.dual_band_values", at);
    for (int band = 0; band < 2; band++) {
        bst_shade_band *b = band ? &s->material.visible : &s->material.solar;
        for (int part = 0; part < 2; part++)
            for (int c = 0; c < 4; c++) {
                char key[32];
                snprintf(key, sizeof key, "%s_%s_%s", comp[c], band ? "vis" : "sol",
                         part ? "diffuse" : "specular");
                double *x = part ? &b->diffuse[c] : &b->specular[c];
                int rc = get_number(jr, db, where, key, 0, x);
                if (rc < 0)
                    return rc;
                if (!isnan(*x) && !(*x >= 0.0 && *x <= 1.0))
                    return bsti_json_error(jr, BST_EFORMAT, "%s.%s = %g is not a value in [0, 1]", where, key,
                                *x);
                s->material.has_dual_band |= !isnan(*x);
            }
    }
    return BST_OK;
}

/* composition[0].child_product: the material the shade is made of. */
static int read_material(const struct bsti_jr *jr, json_t *mat, const char *at, bst_shade *s)
{
    const char *name;
    int rc = get_string(jr, mat, at, "name", 0, &name);
    if (rc >= 0 && !(s->material.name = bsti_strdup(jr->ctx, name)))
        rc = BST_ENOMEM;
    if (rc >= 0)
        rc = read_measured(jr, mat, at, &s->material.thickness_mm, &s->material.conductivity,
                           &s->material.emissivity_front, &s->material.emissivity_back,
                           &s->material.ir_transmittance);
    if (rc < 0)
        return rc;
    char sdat[200];
    snprintf(sdat, sizeof sdat, "%s.spectral_data", at);
    json_t *sd = bsti_json_member(mat, "spectral_data");
    if (sd && bsti_json_member(sd, "spectral_data")) {
        struct bsti_glass_data d = {0, NULL, NULL, NULL, NULL, NULL};
        rc = read_rows(jr, sd, sdat, &d);
        s->material.n = d.n, s->material.wl = d.wl, s->material.tf = d.tf;
        s->material.tb = d.tb, s->material.rf = d.rf, s->material.rb = d.rb;
        if (rc < 0)
            return rc;
    }
    if ((rc = read_dual_band(jr, sd, sdat, s)) < 0)
        return rc;
    if (!s->material.n && !s->material.has_dual_band)
        return bsti_json_error(jr, BST_EFORMAT, "%s: neither spectral rows (spectral_data) nor "
                    "dual_band_values: the material's optics are missing", sdat);
    return BST_OK;
}

/* A positive length g.key (mm). */
static int get_length(const struct bsti_jr *jr, json_t *g, const char *at, const char *key, double *x)
{
    int rc = get_number(jr, g, at, key, 1, x);
    if (rc >= 0 && !(*x > 0.0 && *x <= BSTI_SHADE_MAX_LENGTH_MM))
        rc = bsti_json_error(jr, BST_EFORMAT, "%s.%s = %g is not a length in mm (> 0)", at, key, *x);
    return rc;
}

static int read_venetian(const struct bsti_jr *jr, json_t *g, const char *at, bst_shade *s)
{
    double *w = &s->geometry.venetian.slat_width, *c = &s->geometry.venetian.slat_curvature;
    double *tilt = &s->geometry.venetian.slat_tilt, segs;
    int rc;
    if ((rc = get_length(jr, g, at, "slat_width", w)) < 0 ||
        (rc = get_length(jr, g, at, "slat_spacing", &s->geometry.venetian.slat_spacing)) < 0 ||
        (rc = get_number(jr, g, at, "slat_curvature", 1, c)) < 0 ||
        (rc = get_number(jr, g, at, "slat_tilt", 0, tilt)) < 0 ||
        (rc = get_number(jr, g, at, "number_segments", 1, &segs)) < 0)
        return rc;
    if (isnan(*tilt))
        *tilt = 0.0; /* IGSDB's default */
    if (!(*c == 0.0 || *c >= *w / 2))
        return bsti_json_error(jr, BST_EFORMAT, "%s.slat_curvature = %g mm: a slat's radius is 0 (flat) or at "
                    "least half its width (%g mm)", at, *c, *w / 2);
    if (!(*tilt >= -90.0 && *tilt <= 90.0))
        return bsti_json_error(jr, BST_EFORMAT, "%s.slat_tilt = %g is not an angle in -90..90 degrees", at,
                    *tilt);
    if (!(segs >= 1 && segs <= BSTI_SHADE_MAX_SEGMENTS && segs == floor(segs)))
        return bsti_json_error(jr, BST_EFORMAT, "%s.number_segments = %g is not a count in 1..%d", at, segs,
                    BSTI_SHADE_MAX_SEGMENTS);
    s->geometry.venetian.number_segments = (int)segs;
    return BST_OK;
}

static int read_woven(const struct bsti_jr *jr, json_t *g, const char *at, bst_shade *s)
{
    double *d = &s->geometry.woven.thread_diameter, *p = &s->geometry.woven.thread_spacing;
    int rc;
    if ((rc = get_length(jr, g, at, "thread_diameter", d)) < 0 ||
        (rc = get_length(jr, g, at, "thread_spacing", p)) < 0 ||
        (rc = get_length(jr, g, at, "shade_thickness", &s->geometry.woven.shade_thickness)) < 0)
        return rc;
    if (*d > *p)
        return bsti_json_error(jr, BST_EFORMAT, "%s: thread_diameter %g mm exceeds thread_spacing %g mm", at,
                    *d, *p);
    return BST_OK;
}

static int read_perforated(const struct bsti_jr *jr, json_t *g, const char *at, bst_shade *s)
{
    static const char *const types[] = {"Circular", "Rectangular", "Square"};
    double *sx = &s->geometry.perforated.spacing_x, *sy = &s->geometry.perforated.spacing_y;
    double *dx = &s->geometry.perforated.dimension_x, *dy = &s->geometry.perforated.dimension_y;
    const char *type;
    int rc, t = -1;
    if ((rc = get_length(jr, g, at, "spacing_x", sx)) < 0 ||
        (rc = get_length(jr, g, at, "spacing_y", sy)) < 0 ||
        (rc = get_length(jr, g, at, "dimension_x", dx)) < 0 ||
        (rc = get_string(jr, g, at, "perforation_type", 1, &type)) < 0)
        return rc;
    for (int i = 0; i < 3; i++)
        if (strcasecmp(type, types[i]) == 0)
            t = i;
    if (t < 0)
        return bsti_json_error(jr, BST_EFORMAT, "%s.perforation_type \"%s\" (Circular, Rectangular, Square)",
                    at, type);
    s->geometry.perforated.type = (bst_perforation)t;
    /* a circle or a square has one dimension; IGSDB may still carry a dimension_y */
    if (t == BST_PERFORATION_RECTANGULAR && (rc = get_length(jr, g, at, "dimension_y", dy)) < 0)
        return rc;
    if (t != BST_PERFORATION_RECTANGULAR)
        *dy = *dx;
    if (t == BST_PERFORATION_CIRCULAR && 2 * *dx > fmin(*sx, *sy))
        return bsti_json_error(jr, BST_EFORMAT, "%s: a Circular hole of radius (dimension_x) %g mm does not "
                    "fit its cell of %g x %g mm", at, *dx, *sx, *sy);
    if (*dx > *sx || *dy > *sy)
        return bsti_json_error(jr, BST_EFORMAT, "%s: a %s hole of %g x %g mm does not fit its cell of %g x %g "
                    "mm", at, types[t], *dx, *dy, *sx, *sy);
    return BST_OK;
}

/* The shade of a record of type "shading". */
static int read_shade(const struct bsti_jr *jr, json_t *root, bst_shade *s)
{
    const char *subtype, *name, *maker;
    double id;
    int rc, k = -1;
    if ((rc = get_string(jr, root, "", "subtype", 1, &subtype)) < 0 ||
        (rc = get_string(jr, root, "", "name", 1, &name)) < 0 ||
        (rc = get_string(jr, root, "", "manufacturer_name", 0, &maker)) < 0 ||
        (rc = get_number(jr, root, "", "product_id", 1, &id)) < 0 ||
        (rc = get_number(jr, bsti_json_member(root, "measured_data"), "measured_data", "permeability_factor",
                         0, &s->permeability)) < 0)
        return rc;
    for (int i = 0; i < 3; i++)
        if (strcmp(subtype, shade_kinds[i]) == 0)
            k = i;
    if (k < 0)
        return bsti_json_error(jr, BST_EFORMAT, "subtype \"%s\": the shades read are venetian, woven and "
                    "perforated-screen", subtype);
    s->kind = (bst_shade_kind)k, s->product_id = (long)id;
    if (!(s->name = bsti_strdup(jr->ctx, name)) || !(s->manufacturer = bsti_strdup(jr->ctx, maker)))
        return BST_ENOMEM;
    if (!isnan(s->permeability) && !(s->permeability >= 0.0 && s->permeability <= 1.0))
        return bsti_json_error(jr, BST_EFORMAT, "measured_data.permeability_factor = %g is not in [0, 1]",
                    s->permeability);
    json_t *comp = bsti_json_member(root, "composition"), *c0 = json_array_get(comp, 0);
    if (!json_is_object(c0))
        return bsti_json_error(jr, BST_EFORMAT, "composition[0]: missing (a shading record names its material "
                    "and geometry there)");
    json_t *mat = bsti_json_member(c0, "child_product"), *geo = bsti_json_member(bsti_json_member(c0, "extra_data"), "geometry");
    if (!json_is_object(mat))
        return bsti_json_error(jr, BST_EFORMAT, "composition[0].child_product: missing (the material)");
    if (!json_is_object(geo))
        return bsti_json_error(jr, BST_EFORMAT, "composition[0].extra_data.geometry: missing (the geometry)");
    if ((rc = read_material(jr, mat, "composition[0].child_product", s)) < 0)
        return rc;
    static const char at[] = "composition[0].extra_data.geometry";
    switch (s->kind) {
    case BST_SHADE_VENETIAN: return read_venetian(jr, geo, at, s);
    case BST_SHADE_WOVEN: return read_woven(jr, geo, at, s);
    default: return read_perforated(jr, geo, at, s);
    }
}

static bst_shade *shade_new(bst_ctx *ctx)
{
    bst_shade *s = bsti_calloc(ctx, 1, sizeof *s);
    if (!s)
        return NULL;
    s->ctx = ctx;
    s->permeability = NAN;
    bst_shade_band *b[2] = {&s->material.solar, &s->material.visible};
    for (int i = 0; i < 2; i++)
        for (int c = 0; c < 4; c++)
            b[i]->specular[c] = b[i]->diffuse[c] = NAN;
    return s;
}

int bst_shade_read_igsdb(bst_ctx *ctx, const char *path, bst_shade **out)
{
    if (!ctx || !path || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "shade: NULL argument") : BST_EINVAL;
    *out = NULL;
    const struct bsti_jr jr = {ctx, path};
    json_t *root;
    const char *type;
    int rc = load(&jr, &root, &type);
    if (rc >= 0 && !json_object_get(root, "product_id"))
        rc = bsti_json_error(&jr, BST_EFORMAT, "an IGSDB v2 record: shading products are read from their v1 "
                  "record (igsdb.lbl.gov/api/v1/products/ID)");
    else if (rc >= 0 && strcmp(type, "shading") != 0)
        rc = bsti_json_error(&jr, BST_EFORMAT, "type \"%s\": not a shading product%s", type,
                  strcmp(type, "glazing") == 0 ? " (a pane: read it as glass:FILE)" : "");
    bst_shade *s = NULL;
    if (rc >= 0 && !(s = shade_new(ctx)))
        rc = BST_ENOMEM;
    if (rc >= 0 && !(s->path = bsti_strdup(ctx, path)))
        rc = BST_ENOMEM;
    if (rc >= 0)
        rc = read_shade(&jr, root, s);
    json_decref(root);
    if (rc < 0) {
        bst_shade_free(s);
        return rc;
    }
    *out = s;
    return BST_OK;
}

int bsti_glass_read_igsdb(bst_ctx *ctx, bst_glass *g, const char *path)
{
    const struct bsti_jr jr = {ctx, path};
    json_t *root;
    const char *type;
    int rc = load(&jr, &root, &type);
    int v2 = rc >= 0 && !json_object_get(root, "product_id");
    if (v2 && strcasecmp(type, "glazing") == 0) {
        rc = bsti_glass_read_glazing_v2(jr.ctx, jr.path, g, root);
    } else if (v2) {
        rc = bsti_json_error(&jr, strcasecmp(type, "shading") == 0 ? BST_ENOTIMPL : BST_EFORMAT,
                  "type \"%s\" in an IGSDB v2 record: bsdfstack reads v2 glazing records (a pane); "
                  "a shading product is read from its v1 record", type);
    } else if (rc >= 0 && strcmp(type, "glazing") == 0) {
        rc = read_glazing(&jr, g, root);
    } else if (rc >= 0 && strcmp(type, "shading") == 0) {
        bst_shade *s = shade_new(ctx);
        rc = s ? read_shade(&jr, root, s) : BST_ENOMEM;
        if (rc >= 0) /* a valid shade: a layer of its geometric model, not a pane */
            rc = bsti_json_error(&jr, BST_EINVAL, "IGSDB shading product \"%s\" (%s): this is a shading "
                      "record, not a pane: name it shade:%s", s->name, bst_shade_kind_name(s->kind),
                      jr.path);
        bst_shade_free(s);
    } else if (rc >= 0) {
        rc = bsti_json_error(&jr, BST_EFORMAT, "type \"%s\": a pane is a glazing product%s", type,
                  strcmp(type, "material") == 0 ? " (this is a shade's material)" : "");
    }
    json_decref(root);
    return rc;
}
