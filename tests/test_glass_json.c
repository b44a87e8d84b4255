/* test_glass_json.c - IGSDB JSON records (glass_json.c), made up in the shape of IGSDB's v1 API.
 *  - a glazing record holding NFRC 102's data gives the same pane and two-pane stack as the same
 *    data in bsdfstack's table, to the bit, with its metadata; its subtype picks the model;
 *  - one shading record of each kind (venetian, woven, perforated-screen) is read into bst_shade
 *    with its material and geometry, and refused as a pane with one line naming shade:FILE;
 *  - malformed JSON, missing fields, wrong units, impossible geometry: one line each, naming the
 *    file and the field; allocation failure;
 *  - the same glazing record in IGSDB v2's shape (numbers as strings, angle blocks) gives the same
 *    pane and stack; v2's refusals (diffusing, hazy rows, no normal-incidence block, shading). */
#include <config.h>

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "testglass.h"
#include "testutil.h"

/* The fixture (tg_setup): tg_ctx, NFRC 102's rows tg_nfrc102, a scratch directory. */

/* A glazing record of NFRC 102 (the fields IGSDB's record of it has, values of our own where not
 * the optics): subtype, unit_system ("" to leave it out), wavelengths in nm if nm. */
static const char *write_glazing(const char *name, const char *subtype, const char *units, int nm)
{
    const char *path;
    FILE *fp = tg_create(name, &path);
    fprintf(fp, "{\"product_id\": 363, \"name\": \"Generic Clear Glass\", \"product_name\": null,\n"
                " \"nfrc_id\": 102, \"type\": \"glazing\", \"subtype\": \"%s\",\n"
                " \"manufacturer_name\": \"Generic\", \"coating_name\": \"N/A\",\n"
                " \"coated_side\": \"Neither\", %s%s%s\n"
                " \"measured_data\": {\"is_specular\": true, \"thickness\": 3.048,\n"
                "   \"tir_front\": 0.0, \"emissivity_front\": 0.84, \"emissivity_back\": 0.83,\n"
                "   \"conductivity\": 1.0, \"permeability_factor\": null},\n"
                " \"spectral_data\": {\"spectral_data\": [\n",
            subtype, *units ? "\"unit_system\": \"" : "", units, *units ? "\"," : "");
    for (size_t k = 0; k < tg_nfrc102.n; k++) {
        char (*v)[24] = tg_nfrc102.v[k];
        ck_assert_str_eq(v[1], v[2]); /* one T for both sides, as IGSDB v1 records have */
        char wl[32];
        if (nm)
            snprintf(wl, sizeof wl, "%.6g", atof(v[0]) * 1000);
        else
            snprintf(wl, sizeof wl, "%s", v[0]);
        fprintf(fp, "   {\"T\": %s, \"Rb\": %s, \"Rf\": %s, \"wavelength\": %s}%s\n", v[1], v[4], v[3],
                wl, k + 1 < tg_nfrc102.n ? "," : "");
    }
    fprintf(fp, " ]}}\n");
    fclose(fp);
    return path;
}

START_TEST(test_glazing)
{
    bst_glass *table = tg_parse(tg_ctx, tu_ref("wce/data/spectral_NFRC_102.tsv"));
    const char *path = write_glazing("363.json", "monolithic", "SI", 0);
    bst_glass *g = tg_parse(tg_ctx, path);
    tg_same_pane(g, table);
    tg_same_stack(tg_ctx, g, table);
    const bst_glass_meta *m = bst_glass_metadata(g);
    ck_assert_str_eq(m->source, "igsdb");
    ck_assert_str_eq(m->path, path);
    ck_assert_str_eq(m->product_name, "Generic Clear Glass"); /* name, product_name being null */
    ck_assert_str_eq(m->manufacturer, "Generic");
    ck_assert_str_eq(m->type, "monolithic");
    ck_assert_str_eq(m->coated_side, "Neither");
    ck_assert_int_eq(m->nfrc_id, 102);
    ck_assert(m->thickness_mm == 3.048 && m->conductivity == 1 && m->ir_transmittance == 0);
    ck_assert(m->emissivity_front == 0.84 && m->emissivity_back == 0.83);
    ck_assert_int_eq(bst_glass_get_model(g), BST_GLASS_UNCOATED);
    ck_assert_str_eq(m->model_from, "type");
    bst_glass_free(g);
    /* a coated subtype: WINDOW's coated model; unit_system may be left out */
    static const char *const coated[] = {"coated", "laminate", "applied-film"};
    for (int i = 0; i < 3; i++) {
        g = tg_parse(tg_ctx, write_glazing("c.json", coated[i], "", 0));
        ck_assert_int_eq(bst_glass_get_model(g), BST_GLASS_COATED);
        bst_glass_free(g);
    }
    bst_glass_free(table);
}
END_TEST

/* The material of the shades below: three spectral rows and dual-band values. */
static const char material[] =
    "{\"product_id\": 9001, \"name\": \"white slat (made up)\", \"type\": \"material\",\n"
    " \"subtype\": \"monolithic\", \"measured_data\": {\"thickness\": 0.2, \"conductivity\": 160,\n"
    " \"emissivity_front\": 0.9, \"emissivity_back\": 0.88, \"tir_front\": 0},\n"
    " \"spectral_data\": {\"spectral_data\": [\n"
    "  {\"T\": 0, \"Rf\": 0.6, \"Rb\": 0.55, \"wavelength\": 0.3},\n"
    "  {\"T\": 0.01, \"Rf\": 0.7, \"Rb\": 0.65, \"wavelength\": 0.5},\n"
    "  {\"T\": 0, \"Rf\": 0.75, \"Rb\": 0.7, \"wavelength\": 2.5}],\n"
    "  \"dual_band_values\": {\"Rf_sol_diffuse\": 0.68, \"Rb_sol_diffuse\": 0.64,\n"
    "   \"Tf_vis_specular\": 0.0, \"Rf_vis_diffuse\": 0.74, \"Rb_vis_specular\": null}}}";

/* A shading record of subtype with geometry (the text inside the braces). */
static const char *write_shade(const char *name, const char *subtype, const char *geometry)
{
    const char *path;
    FILE *fp = tg_create(name, &path);
    static const char record[] =
        "{\"product_id\": 9100, \"name\": \"made-up %s\", \"type\": \"shading\", \"subtype\": \"%s\",\n"
        " \"manufacturer_name\": \"nobody\", \"measured_data\": {\"permeability_factor\": 0.12},\n"
        " \"composition\": [{\"child_product\": %s, \"extra_data\": {\"geometry\": {%s}}}]}\n";
    fprintf(fp, record, subtype, subtype, material, geometry);
    fclose(fp);
    return path;
}

static const char venetian[] = "\"slat_width\": 16, \"slat_spacing\": 12, \"slat_curvature\": 0, "
                               "\"slat_tilt\": 45, \"tilt_choice\": \"45\", \"number_segments\": 5";
static const char woven[] = "\"thread_diameter\": 0.5, \"thread_spacing\": 0.8, "
                            "\"shade_thickness\": 0.6";
static const char perforated[] = "\"spacing_x\": 1.7, \"spacing_y\": 1.7, \"dimension_x\": 0.6, "
                                 "\"dimension_y\": 6.35, \"perforation_type\": \"Circular\"";

START_TEST(test_shades)
{
    const char *geo[3] = {venetian, woven, perforated};
    static const char *const kinds[3] = {"venetian", "woven", "perforated-screen"};
    for (int k = 0; k < 3; k++) {
        char name[32];
        snprintf(name, sizeof name, "shade%d.json", k);
        const char *path = write_shade(name, kinds[k], geo[k]);
        bst_shade *s;
        ck_assert_msg(bst_shade_read_igsdb(tg_ctx, path, &s) == BST_OK, "%s", bst_ctx_message(tg_ctx));
        ck_assert_int_eq(s->kind, k);
        ck_assert_str_eq(bst_shade_kind_name(s->kind), kinds[k]);
        ck_assert_int_eq(s->product_id, 9100);
        ck_assert(s->permeability == 0.12 && strcmp(s->manufacturer, "nobody") == 0);
        ck_assert_str_eq(s->material.name, "white slat (made up)");
        ck_assert(s->material.thickness_mm == 0.2 && s->material.conductivity == 160);
        ck_assert(s->material.emissivity_back == 0.88);
        ck_assert_uint_eq(s->material.n, 3);
        ck_assert(s->material.wl[1] == 0.5 && s->material.tf[1] == 0.01 && s->material.tb[1] == 0.01);
        ck_assert(s->material.rf[2] == 0.75 && s->material.rb[2] == 0.7);
        ck_assert(s->material.has_dual_band);
        ck_assert(s->material.solar.diffuse[2] == 0.68 && s->material.solar.diffuse[3] == 0.64);
        ck_assert(s->material.visible.specular[0] == 0 && s->material.visible.diffuse[2] == 0.74);
        ck_assert(isnan(s->material.visible.specular[3]) && isnan(s->material.solar.specular[0]));
        if (k == 0)
            ck_assert(s->geometry.venetian.slat_width == 16 && s->geometry.venetian.slat_spacing == 12 &&
                      s->geometry.venetian.slat_curvature == 0 && s->geometry.venetian.slat_tilt == 45 &&
                      s->geometry.venetian.number_segments == 5);
        if (k == 1)
            ck_assert(s->geometry.woven.thread_diameter == 0.5 &&
                      s->geometry.woven.thread_spacing == 0.8 && s->geometry.woven.shade_thickness == 0.6);
        if (k == 2) /* a circle's dimension_y is its dimension_x (its radius), whatever the record says */
            ck_assert(s->geometry.perforated.type == BST_PERFORATION_CIRCULAR &&
                      s->geometry.perforated.spacing_y == 1.7 && s->geometry.perforated.dimension_x == 0.6 &&
                      s->geometry.perforated.dimension_y == 0.6);
        bst_shade_free(s);
        /* as a pane: one line naming the spec that takes it, no pane */
        bst_glass *g = (bst_glass *)1;
        ck_assert_int_eq(bst_glass_parse(tg_ctx, path, NULL, &g), BST_EINVAL);
        ck_assert_ptr_null(g);
        ck_assert(strstr(bst_ctx_message(tg_ctx), "this is a shading record, not a pane: name it shade:"));
        ck_assert(strstr(bst_ctx_message(tg_ctx), kinds[k]) && !strchr(bst_ctx_message(tg_ctx), '\n'));
    }
    bst_shade_free(NULL);
    bst_shade *s = (bst_shade *)1;
    ck_assert_int_eq(bst_shade_read_igsdb(tg_ctx, write_glazing("g.json", "monolithic", "SI", 0), &s),
                     BST_EFORMAT);
    ck_assert_ptr_null(s);
    ck_assert(strstr(bst_ctx_message(tg_ctx), "not a shading product (a pane"));
}
END_TEST

/* A file of the given text, refused as a pane (and as a shade) with expect in its one line. */
static void refused_text(const char *text, const char *expect, int as_shade)
{
    const char *path;
    FILE *fp = tg_create("bad.json", &path);
    fputs(text, fp);
    fclose(fp);
    char want[400]; /* ":..." follows the file's name; other expectations stand alone */
    snprintf(want, sizeof want, "%s%s", *expect == ':' ? tg_path("bad.json") : "", expect);
    if (!as_shade) {
        tg_refused(tg_ctx, tg_path("bad.json"), want);
        return;
    }
    bst_shade *s = (bst_shade *)1;
    ck_assert_int_lt(bst_shade_read_igsdb(tg_ctx, tg_path("bad.json"), &s), 0);
    ck_assert_ptr_null(s);
    ck_assert_msg(strstr(bst_ctx_message(tg_ctx), want), "message '%s' lacks '%s'",
                  bst_ctx_message(tg_ctx), want);
}

/* A shading record whose geometry is geo, refused with expect. */
static void refused_shade(const char *kind, const char *geo, const char *expect)
{
    const char *path = write_shade("s.json", kind, geo);
    FILE *fp = fopen(path, "r");
    char text[8192];
    size_t n = fread(text, 1, sizeof text - 1, fp);
    fclose(fp);
    text[n] = '\0';
    refused_text(text, expect, 1);
    refused_text(text, expect, 0); /* the pane reader validates the shade first */
}

#define HEAD "{\"product_id\": 1, \"type\": \"glazing\", \"subtype\": \"monolithic\", "
#define ROWS "{\"spectral_data\": [{\"T\": 0.8, \"Rf\": 0.08, \"Rb\": 0.08, \"wavelength\": 0.3}, " \
             "{\"T\": 0.8, \"Rf\": 0.08, \"Rb\": 0.08, \"wavelength\": 2.5}]}"

START_TEST(test_malformed)
{
    refused_text("{\"product_id\": 1,\n \"type\": \"glazing\",,\n}", ":2:", 0);
    refused_text("{\"product_id\": 1, \"product_id\": 2, \"type\": \"glazing\"}", ":1:", 0);
    refused_text("{\"product_id\": 1, \"type\": \"glazing\" /* a comment */}", ":1:", 0);
    /* and the same record well formed is read */
    const char *path;
    FILE *fp = tg_create("ok.json", &path);
    fputs(HEAD "\"spectral_data\": " ROWS "}", fp);
    fclose(fp);
    bst_glass_free(tg_parse(tg_ctx, path));
}
END_TEST

START_TEST(test_missing_fields)
{
    refused_text("{\"type\": \"glazing\"}", ": no product_id", 0);
    refused_text("{\"id\": \"x\", \"type\": \"glazing\"}", ": an IGSDB v2 record", 0);
    refused_text("[{\"product_id\": 1}, {\"product_id\": 2}]", ": a list of 2 records", 0);
    refused_text("{\"product_id\": 1}", ": type: missing (a string)", 0);
    refused_text("{\"product_id\": 1, \"type\": 3}", ": type is not a string", 0);
    refused_text("{\"product_id\": 1, \"type\": \"material\"}", ": type \"material\": a pane is a "
                 "glazing product (this is a shade's material)", 0);
    refused_text("{\"product_id\": 1, \"type\": \"glazing\", \"spectral_data\": " ROWS "}",
                 ": subtype: missing", 0);
    refused_text(HEAD "\"spectral_data\": null}", ": spectral_data: missing", 0);
    refused_text(HEAD "\"spectral_data\": {\"spectral_data\": []}}",
                 ": spectral_data.spectral_data: fewer than two rows", 0);
    refused_text(HEAD "\"spectral_data\": {\"spectral_data\": [{\"T\": 0.8, \"Rf\": 0.08, "
                 "\"wavelength\": 0.3}, {}]}}", ": spectral_data.spectral_data[0].Rb: missing", 0);
    refused_text(HEAD "\"spectral_data\": {\"spectral_data\": [{\"T\": \"0.8\", \"Rf\": 0.08, "
                 "\"Rb\": 0.08, \"wavelength\": 0.3}, {}]}}",
                 ": spectral_data.spectral_data[0].T is not a number", 0);
    refused_text(HEAD "\"nfrc_id\": 1.5, \"spectral_data\": " ROWS "}", ": nfrc_id is not an integer", 0);
    refused_text(HEAD "\"measured_data\": {\"is_specular\": false}, \"spectral_data\": " ROWS "}",
                 ": measured_data.is_specular is false: a diffusing glazing product", 0);
    refused_text(HEAD "\"measured_data\": {\"is_specular\": \"yes\"}, \"spectral_data\": " ROWS "}",
                 ": measured_data.is_specular is not true or false", 0);
    refused_text(HEAD "\"measured_data\": {\"thickness\": -3}, \"spectral_data\": " ROWS "}",
                 ": measured_data.thickness = -3 is not a thickness", 0);
    char shade[600];
    snprintf(shade, sizeof shade, "{\"product_id\": 2, \"type\": \"shading\", \"subtype\": "
             "\"venetian\", \"name\": \"x\", \"composition\": []}");
    refused_text(shade, ": composition[0]: missing", 1);
    refused_shade("venetian", "\"slat_spacing\": 12, \"slat_curvature\": 0, \"number_segments\": 5",
                  ": composition[0].extra_data.geometry.slat_width: missing (a number)");
    refused_shade("woven", "\"thread_diameter\": 0.5, \"shade_thickness\": 0.6",
                  ": composition[0].extra_data.geometry.thread_spacing: missing");
    refused_shade("perforated-screen", "\"spacing_x\": 1, \"spacing_y\": 1, \"dimension_x\": 0.5",
                  ": composition[0].extra_data.geometry.perforation_type: missing");
    refused_shade("roller", venetian, ": subtype \"roller\": the shades read are venetian");
}
END_TEST

START_TEST(test_wrong_units)
{
    /* a unit system other than SI, and wavelengths in nanometres where IGSDB has micrometres */
    refused_text(HEAD "\"unit_system\": \"IP\", \"spectral_data\": " ROWS "}",
                 ": unit_system \"IP\": bsdfstack reads SI records", 0);
    const char *nm = write_glazing("nm.json", "monolithic", "SI", 1);
    char want[300];
    snprintf(want, sizeof want, "%s: spectral_data.spectral_data[0]: wavelength 300 um is not in", nm);
    tg_refused(tg_ctx, nm, want);
    /* impossible geometry in the record's units (mm, degrees) */
    refused_shade("venetian", "\"slat_width\": 16, \"slat_spacing\": 12, \"slat_curvature\": 5, "
                  "\"number_segments\": 5", ".slat_curvature = 5 mm: a slat's radius is 0 (flat)");
    refused_shade("venetian", "\"slat_width\": 16, \"slat_spacing\": 12, \"slat_curvature\": 0, "
                  "\"slat_tilt\": 135, \"number_segments\": 5", ".slat_tilt = 135 is not an angle");
    refused_shade("venetian", "\"slat_width\": 0.016, \"slat_spacing\": -0.012, "
                  "\"slat_curvature\": 0, \"number_segments\": 5", ".slat_spacing = -0.012 is not a length in mm");
    refused_shade("woven", "\"thread_diameter\": 0.9, \"thread_spacing\": 0.8, \"shade_thickness\": 0.6",
                  ".geometry: thread_diameter 0.9 mm exceeds thread_spacing 0.8 mm");
    refused_shade("perforated-screen", "\"spacing_x\": 1, \"spacing_y\": 1, \"dimension_x\": 0.5, "
                  "\"dimension_y\": 2, \"perforation_type\": \"Rectangular\"",
                  ".geometry: a Rectangular hole of 0.5 x 2 mm does not fit its cell");
    refused_shade("perforated-screen", "\"spacing_x\": 1, \"spacing_y\": 1, \"dimension_x\": 0.5, "
                  "\"perforation_type\": \"Hexagonal\"", ".perforation_type \"Hexagonal\"");
    /* a circle's dimension_x is its radius: 0.6 mm does not fit a 1 mm cell */
    refused_shade("perforated-screen", "\"spacing_x\": 1, \"spacing_y\": 1.5, \"dimension_x\": 0.6, "
                  "\"perforation_type\": \"Circular\"", ".geometry: a Circular hole of radius (dimension_x) 0.6 mm");
}
END_TEST

/* NFRC 102 as an IGSDB v2 glazing record (the shape of the database's v2 API: numbers mostly as
 * strings, the data in physical_properties' angle blocks); extra: more fields, spliced into the
 * physical_properties object; a block at 8 degrees that must be passed over comes first. */
static const char *write_glazing_v2(const char *name, const char *subtype, const char *extra)
{
    const char *path;
    FILE *fp = tg_create(name, &path);
    fprintf(fp, "{\"id\": null, \"component_id\": \"made-up\", \"type\": \"GLAZING\",\n"
                " \"subtype\": \"%s\", \"token\": \"generic-clear-3\", \"name\": \"Generic Clear Glass\",\n"
                " \"nfrc_id\": 102, \"igdb_id\": 1, \"manufacturer_name\": \"Generic\",\n"
                " \"coating_name\": null, \"coated_side\": \"NA\", \"emissivity_front\": 0.84,\n"
                " \"emissivity_back\": null, \"tir_front\": 0.0, \"composition\": [],\n"
                " \"material_bulk_properties\": {\"name\": \"GLASS\", \"conductivity\": \"1.0\"},\n"
                " \"physical_properties\": {\"is_specular\": true, \"thickness\": 3.048,\n"
                "  \"predefined_emissivity_front\": 0.5, \"predefined_emissivity_back\": 0.83,\n"
                "  %s\n"
                "  \"optical_properties\": {\"optical_data_type\": \"DISCRETE\", \"optical_data\": {\n"
                "   \"number_incidence_angles\": 2, \"angle_blocks\": [\n"
                "    {\"incidence_angle\": 8, \"wavelength_data\": []},\n"
                "    {\"incidence_angle\": 0, \"num_wavelengths\": %zu, \"wavelength_data\": [\n",
            subtype, extra, tg_nfrc102.n);
    for (size_t k = 0; k < tg_nfrc102.n; k++) {
        char (*v)[24] = tg_nfrc102.v[k];
        fprintf(fp, "     {\"w\": \"%s\", \"specular\": {\"rb\": \"%s\", \"rf\": \"%s\", \"tb\": \"%s\", "
                    "\"tf\": %s}%s}%s\n", v[0], v[4], v[3], v[2], v[1],
                k ? "" : ", \"diffuse\": {\"tf\": \"0\", \"rf\": 0}", k + 1 < tg_nfrc102.n ? "," : "");
    }
    fprintf(fp, "    ]}]}}}}\n");
    fclose(fp);
    return path;
}

START_TEST(test_glazing_v2)
{
    bst_glass *table = tg_parse(tg_ctx, tu_ref("wce/data/spectral_NFRC_102.tsv"));
    const char *path = write_glazing_v2("v2.json", "MONOLITHIC",
                                        "\"bulk_properties_override\": null,");
    bst_glass *g = tg_parse(tg_ctx, path);
    tg_same_pane(g, table);
    tg_same_stack(tg_ctx, g, table);
    const bst_glass_meta *m = bst_glass_metadata(g);
    ck_assert_str_eq(m->source, "igsdb");
    ck_assert_str_eq(m->product_name, "Generic Clear Glass");
    ck_assert_str_eq(m->manufacturer, "Generic");
    ck_assert_str_eq(m->type, "MONOLITHIC");
    ck_assert_str_eq(m->coated_side, "NA");
    ck_assert_int_eq(m->nfrc_id, 102);
    /* the record's own emissivity first, the predefined one where the record's is null */
    ck_assert(m->thickness_mm == 3.048 && m->conductivity == 1 && m->ir_transmittance == 0);
    ck_assert(m->emissivity_front == 0.84 && m->emissivity_back == 0.83);
    ck_assert_int_eq(bst_glass_get_model(g), BST_GLASS_UNCOATED);
    bst_glass_free(g);
    g = tg_parse(tg_ctx, write_glazing_v2("v2c.json", "APPLIED_FILM",
                                          "\"bulk_properties_override\": {\"conductivity\": \"0.9\"},"));
    ck_assert_int_eq(bst_glass_get_model(g), BST_GLASS_COATED);
    ck_assert(bst_glass_metadata(g)->conductivity == 0.9);
    bst_glass_free(g);
    bst_glass_free(table);
}
END_TEST

/* A v2 record with text spliced in after its head, refused with expect. */
static void refused_v2(const char *head, const char *expect)
{
    char text[2048];
    snprintf(text, sizeof text, "{\"id\": 5, \"type\": \"GLAZING\", \"subtype\": \"MONOLITHIC\", %s}", head);
    refused_text(text, expect, 0);
}

#define V2_BLOCK(rows) "\"optical_properties\": {\"optical_data\": {\"angle_blocks\": " \
    "[{\"incidence_angle\": 0, \"wavelength_data\": [" rows "]}]}}"
#define V2_ROW(w, dif) "{\"w\": " w ", \"specular\": {\"tf\": 0.8, \"tb\": 0.8, \"rf\": 0.08, " \
    "\"rb\": 0.08}" dif "}"

START_TEST(test_v2_refused)
{
    /* the same record is read when nothing is wrong */
    const char *path;
    FILE *fp = tg_create("ok2.json", &path);
    fputs("{\"id\": 5, \"type\": \"glazing\", \"subtype\": \"monolithic\", \"physical_properties\": {"
          V2_BLOCK(V2_ROW("0.3", "") ", " V2_ROW("\"2.5\"", "")) "}}", fp);
    fclose(fp);
    bst_glass_free(tg_parse(tg_ctx, path));
    refused_v2("\"physical_properties\": {\"is_specular\": false}",
               ": physical_properties.is_specular is false: a diffusing glazing product");
    refused_v2("\"physical_properties\": {" V2_BLOCK(V2_ROW("0.3", ", \"diffuse\": {\"tf\": \"0.02\"}") ", "
               V2_ROW("2.5", "")) "}", ".wavelength_data[0].diffuse.tf = 0.02: a pane is specular");
    refused_v2("\"physical_properties\": {" V2_BLOCK(V2_ROW("\"0.3 um\"", "") ", " V2_ROW("2.5", "")) "}",
               ".angle_blocks[0].wavelength_data[0].w is not a number");
    refused_v2("\"physical_properties\": {" V2_BLOCK(V2_ROW("300", "") ", " V2_ROW("2500", "")) "}",
               ".wavelength_data[0]: wavelength 300 um is not in");
    refused_v2("\"physical_properties\": {\"optical_properties\": {\"optical_data\": {\"angle_blocks\": "
               "[{\"incidence_angle\": 10, \"wavelength_data\": []}]}}}", ".angle_blocks: no block at incidence_angle 0");
    refused_v2("\"physical_properties\": {\"thickness\": \"3.048\"}",
               ": physical_properties.optical_properties.optical_data.angle_blocks: missing");
    refused_v2("\"physical_properties\": {\"thickness\": 3048000, " V2_BLOCK(V2_ROW("0.3", "") ", "
               V2_ROW("2.5", "")) "}", ": physical_properties.thickness = 3.048e+06 is not a thickness");
    refused_v2("\"physical_properties\": 3", ": physical_properties is not an object");
    refused_text("{\"id\": 5, \"type\": \"SHADING\", \"subtype\": \"VENETIAN\", \"physical_properties\": {}}",
                 ": type \"SHADING\" in an IGSDB v2 record: bsdfstack reads v2 glazing records", 0);
    refused_text("{\"id\": 5, \"type\": \"SHADING\", \"subtype\": \"VENETIAN\", \"physical_properties\": {}}",
                 ": an IGSDB v2 record: shading products are read from their v1 record", 1);
}
END_TEST

/* Every allocation of reading a record may fail: an error, never a leak. */
static int read_shade(bst_ctx *c, void *path)
{
    bst_shade *s = (bst_shade *)1;
    int rc = bst_shade_read_igsdb(c, path, &s);
    if (rc < 0)
        ck_assert_ptr_null(s);
    else
        bst_shade_free(s);
    return rc;
}

START_TEST(test_alloc_failure)
{
    char path[3][256]; /* tg_path's buffer is reused */
    snprintf(path[0], sizeof path[0], "%s", write_glazing("a.json", "coated", "SI", 0));
    snprintf(path[1], sizeof path[1], "%s", write_shade("s.json", "venetian", venetian));
    tg_alloc_sweep("a glazing record", 400, tg_read_pane, path[0]);
    tg_alloc_sweep("a shading record", 400, read_shade, path[1]);
    snprintf(path[2], sizeof path[2], "%s", write_glazing_v2("v2a.json", "COATED", ""));
    tg_alloc_sweep("a v2 glazing record", 400, tg_read_pane, path[2]);
}
END_TEST

int main(void)
{
    const TTest *const tests[] = {test_glazing, test_shades, test_malformed, test_missing_fields,
                                  test_wrong_units, test_glazing_v2, test_v2_refused,
                                  test_alloc_failure};
    return tu_run(tg_suite("glass_json", tg_setup, tg_teardown, 120, tests,
                           sizeof tests / sizeof tests[0]));
}
