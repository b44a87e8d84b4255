/* test_shade.c - IGSDB shading records as layers (shade.c), records made up in the shape of
 * IGSDB's v1 API (as test_glass_json.c makes them):
 *  - a venetian, a perforated-screen (circular, rectangular, square holes) and a woven record each
 *    give exactly the layer of the equivalent hand-written spec (the record's values written out
 *    by hand from the record: a closed-form equivalence, values equal to rounding);
 *  - band values from spectral rows: constant rows give the constant; NFRC 102's rows as a shade's
 *    material give the pane's own Visible and Solar T and R at normal incidence (the glass path
 *    reading the same rows from the reference's table) and WCE's averages of them
 *    (../shared/reference/wce/glass/glass_angular_averaged_wce.tsv, theta 0);
 *  - overrides (tilt, segments, rule=centre for WINDOW's perforated and woven models, a plain
 *    value replacing a dual-band one, a thickness the record lacks), and refusals with one line
 *    naming the file and the field or key: unknown key, a glazing record, Tf and Tb or the two
 *    faces' specular reflectances that differ, a missing component; a curved slat's radius (mm)
 *    becomes the model's curvature;
 *  - allocation failure at every allocation of reading a record into its model: BST_ENOMEM and
 *    nothing leaked. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "testglass.h"
#include "testutil.h"

static bst_ctx *ctx;
static char dir[64];
/* the band spectra: the catalogue directory the harness names (as test_glass's) */
static const char *cat(void) { return getenv("BSDFSTACK_GLASS_DIR"); }
static void setup(void)
{
    ctx = bst_ctx_new();
    snprintf(dir, sizeof dir, "/tmp/bst_shade_XXXXXX");
    ck_assert_ptr_nonnull(mkdtemp(dir));
}
static void teardown(void)
{
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    ck_assert_int_eq(system(cmd), 0);
    bst_ctx_free(ctx);
}

/* A shading record in the scratch directory: subtype, the material's measured_data and
 * spectral_data (JSON text) and the geometry (the text inside its braces). */
static const char *record(const char *name, const char *subtype, const char *measured,
                          const char *optics, const char *geometry)
{
    static char path[256];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *fp = fopen(path, "w");
    ck_assert_ptr_nonnull(fp);
    fprintf(fp, "{\"product_id\": 9100, \"name\": \"made-up %s\", \"type\": \"shading\",\n"
                " \"subtype\": \"%s\", \"manufacturer_name\": \"nobody\",\n"
                " \"composition\": [{\"child_product\": {\"product_id\": 9001, \"name\": \"m\",\n"
                "   \"type\": \"material\", \"subtype\": \"monolithic\", \"measured_data\": {%s},\n"
                "   \"spectral_data\": %s},\n"
                "  \"extra_data\": {\"geometry\": {%s}}}]}\n",
            subtype, subtype, measured, optics, geometry);
    fclose(fp);
    return path;
}

/* Dual-band values: Tf, Tb, Rf, Rb of Visible then Solar, specular then diffuse ("null": absent). */
static const char *dual(const char *const v[16])
{
    static char text[1200];
    static const char *const comp[4] = {"Tf", "Tb", "Rf", "Rb"};
    size_t n = (size_t)snprintf(text, sizeof text, "{\"dual_band_values\": {");
    for (int k = 0; k < 16; k++)
        n += (size_t)snprintf(text + n, sizeof text - n, "%s\"%s_%s_%s\": %s", k ? ", " : "",
                              comp[k % 4], k / 8 ? "sol" : "vis", k % 8 < 4 ? "specular" : "diffuse", v[k]);
    snprintf(text + n, sizeof text - n, "}}");
    return text;
}

static bst_layer *layer_of(const char *spec, const bst_basis *b)
{
    bst_layer *l = NULL;
    ck_assert_msg(bst_shade_spec_layer(ctx, spec, cat(), b, 0, NULL, &l) == BST_OK, "%s: %s", spec,
                  bst_ctx_message(ctx));
    return l;
}

/* Every component of every channel of a and b equal to rounding (|a - b| <= 1e-13 max |b|). */
static void same_layer(const bst_layer *a, const bst_layer *b, const char *what)
{
    size_t n = bst_basis_size(bst_layer_basis(b));
    ck_assert_uint_eq(bst_layer_nchannels(a), bst_layer_nchannels(b));
    double *x = malloc(n * n * sizeof *x), *y = malloc(n * n * sizeof *y);
    ck_assert(x && y);
    for (size_t ch = 0; ch < bst_layer_nchannels(b); ch++)
        for (int c = 0; c < BST_NCOMP; c++) {
            ck_assert_int_eq(bst_mat_to_dense_array(ctx, bst_layer_get(a, ch, (bst_comp)c), x), BST_OK);
            ck_assert_int_eq(bst_mat_to_dense_array(ctx, bst_layer_get(b, ch, (bst_comp)c), y), BST_OK);
            double big = 0, diff = 0;
            for (size_t i = 0; i < n * n; i++)
                big = fmax(big, fabs(y[i])), diff = fmax(diff, fabs(x[i] - y[i]));
            ck_assert_msg(diff <= 1e-13 * big, "%s: channel %zu comp %d differs by %g of %g", what,
                          ch, c, diff, big);
        }
    free(x), free(y);
}

/* shade:PATH[,overrides] and the hand-written spec give the same layer over basis b. */
static void same_as(const char *path, const char *overrides, const char *spec, const bst_basis *b)
{
    char s[1200];
    snprintf(s, sizeof s, "shade:%s%s%s", path, *overrides ? "," : "", overrides);
    bst_layer *l1 = layer_of(s, b), *l2 = layer_of(spec, b);
    same_layer(l1, l2, spec);
    bst_layer_free(l1), bst_layer_free(l2);
}

static const char venetian_geo[] = "\"slat_width\": 16, \"slat_spacing\": 12, \"slat_curvature\": 0, "
                                   "\"slat_tilt\": 45, \"tilt_choice\": \"45\", \"number_segments\": 5";
/* slats: Visible Rf 0.05 + 0.7, Rb 0.05 + 0.55, T 0.04 (Tb absent: Tf's); Solar rs 0.1,
 * Rf 0.6, Rb 0.5, T 0.05 */
static const char *const slat[16] = {"0", "null", "0.05", "0.05", "0.04", "null", "0.7", "0.55",
                                     "0", "0", "0.1", "0.1", "0.05", "0.05", "0.6", "0.5"};

START_TEST(test_venetian)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_klems(ctx, "quarter", &b), BST_OK);
    const char *path = record("v.json", "venetian", "\"thickness\": 0.2", dual(slat), venetian_geo);
    same_as(path, "", "venetian:width=16mm,spacing=12mm,tilt=45,segments=5,r-up=0.7/0.6,"
            "r-down=0.55/0.5,t=0.04/0.05,rs=0.05/0.1", b);
    /* users rotate blinds: the record's tilt is a default; a plain value is both channels' */
    same_as(path, "tilt=-30,segments=8,rs=0", "venetian:width=16mm,spacing=12mm,tilt=-30,segments=8,"
            "r-up=0.7/0.6,r-down=0.55/0.5,t=0.04/0.05", b);
    /* the model as its spec, and that spec parsed back */
    bst_shade_model m;
    char s[600], spec[1100];
    snprintf(s, sizeof s, "shade:%s", path);
    ck_assert_int_eq(bst_shade_parse(ctx, s, cat(), &m), BST_OK);
    ck_assert_int_eq(m.kind, BST_SHADE_VENETIAN);
    ck_assert_uint_lt(bst_shade_model_spec(&m, spec, sizeof spec), sizeof spec);
    ck_assert_str_eq(spec, "venetian:width=16mm,spacing=12mm,tilt=45,curvature=0mm,segments=5,"
                     "r-up=0.7/0.6,r-down=0.55/0.5,t=0.04/0.05,rs=0.05/0.1");
    /* WINDOW's model by an override: its spec names the rule and the distribution */
    snprintf(s, sizeof s, "shade:%s,rs=0,rule=centre,distribution=uniform", path);
    ck_assert_int_eq(bst_shade_parse(ctx, s, cat(), &m), BST_OK);
    ck_assert_uint_lt(bst_shade_model_spec(&m, spec, sizeof spec), sizeof spec);
    ck_assert_str_eq(spec, "venetian:width=16mm,spacing=12mm,tilt=45,curvature=0mm,segments=5,"
                     "r-up=0.7/0.6,r-down=0.55/0.5,t=0.04/0.05,rs=0,rule=centre,distribution=uniform");
    bst_basis_free(b);
}
END_TEST

/* Constant rows (T 0.1, Rf 0.6, Rb 0.3 at every wavelength): rf, rb, t those constants. */
static const char constant_rows[] =
    "{\"spectral_data\": [{\"wavelength\": 0.3, \"T\": 0.1, \"Rf\": 0.6, \"Rb\": 0.3},"
    " {\"wavelength\": 0.55, \"T\": 0.1, \"Rf\": 0.6, \"Rb\": 0.3},"
    " {\"wavelength\": 2.5, \"T\": 0.1, \"Rf\": 0.6, \"Rb\": 0.3}]}";

START_TEST(test_perforated)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &b), BST_OK);
    static const char *const geo[3] = {
        "\"spacing_x\": 1.7, \"spacing_y\": 2, \"dimension_x\": 0.6, \"dimension_y\": 6.35, "
        "\"perforation_type\": \"Circular\"",
        "\"spacing_x\": 1.7, \"spacing_y\": 2, \"dimension_x\": 0.6, \"dimension_y\": 1.5, "
        "\"perforation_type\": \"Rectangular\"",
        "\"spacing_x\": 1.7, \"spacing_y\": 2, \"dimension_x\": 0.6, \"perforation_type\": \"Square\""};
    static const char *const holes[3] = {"radius=0.6mm", "hole-x=0.6mm,hole-y=1.5mm",
                                         "hole-x=0.6mm,hole-y=0.6mm"};
    for (int k = 0; k < 3; k++) {
        const char *path = record("p.json", "perforated-screen", "\"thickness\": 0.2", constant_rows, geo[k]);
        char spec[300];
        snprintf(spec, sizeof spec, "perforated:x=1.7mm,y=2mm,thickness=0.2mm,%s,rf=0.6,rb=0.3,t=0.1",
                 holes[k]);
        same_as(path, "", spec, b);
    }
    /* WINDOW's model by an override (the record's layer then is not the default one: the sheet
     * is 0.2 mm thick), and the model's spec says so */
    const char *rec = record("p.json", "perforated-screen", "\"thickness\": 0.2", constant_rows, geo[0]);
    same_as(rec, "rule=centre", "perforated:x=1.7mm,y=2mm,thickness=0.2mm,radius=0.6mm,rf=0.6,"
            "rb=0.3,t=0.1,rule=centre", b);
    bst_shade_model mc;
    char sc[600], spc[600];
    snprintf(sc, sizeof sc, "shade:%s,rule=centre", rec);
    ck_assert_int_eq(bst_shade_parse(ctx, sc, cat(), &mc), BST_OK);
    ck_assert_int_eq(mc.perforated.rule, BST_VENETIAN_CENTRE);
    ck_assert_uint_lt(bst_shade_model_spec(&mc, spc, sizeof spc), sizeof spc);
    ck_assert_str_eq(spc, "perforated:x=1.7mm,y=2mm,thickness=0.2mm,radius=0.6mm,rf=0.6,rb=0.3,"
                     "t=0.1,rule=centre");
    /* a material without a thickness: refused, unless thickness= is given */
    const char *path = record("p.json", "perforated-screen", "\"conductivity\": 160", constant_rows, geo[0]);
    char s[600];
    snprintf(s, sizeof s, "shade:%s", path);
    bst_shade_model m;
    ck_assert_int_eq(bst_shade_parse(ctx, s, cat(), &m), BST_EFORMAT);
    ck_assert(strstr(bst_ctx_message(ctx), "measured_data.thickness: missing") &&
              strstr(bst_ctx_message(ctx), path));
    same_as(path, "thickness=1mm", "perforated:x=1.7mm,y=2mm,thickness=1mm,radius=0.6mm,rf=0.6,"
            "rb=0.3,t=0.1", b);
    bst_basis_free(b);
}
END_TEST

START_TEST(test_woven)
{
    bst_basis *b;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 3, &b), BST_OK);
    /* fabric: specular and diffuse parts summed, the faces apart, Tb absent */
    static const char *const fabric[16] = {"0.02", "null", "0", "0", "0.08", "null", "0.5", "0.3",
                                           "0.01", "0.01", "0", "0", "0.09", "0.09", "0.45", "0.25"};
    const char *path = record("w.json", "woven", "\"thickness\": 0.6", dual(fabric),
                              "\"thread_diameter\": 0.5, \"thread_spacing\": 0.8, \"shade_thickness\": 0.6");
    /* 0.02 + 0.08 and 0.01 + 0.09 as the model sums them */
    char spec[300];
    snprintf(spec, sizeof spec, "woven:diameter=0.5mm,spacing=0.8mm,rf=0.5/0.45,rb=0.3/0.25,t=%.17g/%.17g",
             0.02 + 0.08, 0.01 + 0.09);
    same_as(path, "", spec, b);
    strcat(spec, ",rule=centre"); /* WINDOW's woven model by an override */
    same_as(path, "rule=centre", spec, b);
    bst_basis_free(b);
}
END_TEST

/* Band values of rows: constants stay, NFRC 102's rows give the pane's and WCE's averages. */
START_TEST(test_band_values)
{
    bst_shade *s;
    bst_shade_band vis, sol;
    const char *path = record("c.json", "woven", "", constant_rows,
                              "\"thread_diameter\": 0.5, \"thread_spacing\": 0.8, \"shade_thickness\": 0.6");
    ck_assert_int_eq(bst_shade_read_igsdb(ctx, path, &s), BST_OK);
    ck_assert_int_eq(bst_shade_band_values(ctx, s, cat(), &vis, &sol), BST_OK);
    static const double want[4] = {0.1, 0.1, 0.6, 0.3};
    for (int c = 0; c < 4; c++) {
        ck_assert(vis.specular[c] == 0 && sol.specular[c] == 0);
        ck_assert_msg(tu_close(vis.diffuse[c], want[c], 1e-14, 0) && tu_close(sol.diffuse[c], want[c], 1e-14, 0),
                      "comp %d: %.17g %.17g", c, vis.diffuse[c], sol.diffuse[c]);
    }
    bst_shade_free(s);
    /* NFRC 102's rows (T both sides, as a v1 record has them) */
    FILE *in = fopen(tu_ref("wce/data/spectral_NFRC_102.tsv"), "r");
    ck_assert_ptr_nonnull(in);
    static char rows[200000];
    size_t n = (size_t)snprintf(rows, sizeof rows, "{\"spectral_data\": [");
    char line[256];
    int first = 1;
    while (fgets(line, sizeof line, in)) {
        double wl, tf, tb, rf, rb;
        if (line[0] == '#' || sscanf(line, "%lf %lf %lf %lf %lf", &wl, &tf, &tb, &rf, &rb) != 5)
            continue;
        ck_assert(tf == tb);
        n += (size_t)snprintf(rows + n, sizeof rows - n, "%s{\"wavelength\": %.17g, \"T\": %.17g, "
                              "\"Rf\": %.17g, \"Rb\": %.17g}", first ? "" : ", ", wl, tf, rf, rb);
        first = 0;
    }
    fclose(in);
    snprintf(rows + n, sizeof rows - n, "]}");
    path = record("n.json", "woven", "", rows,
                  "\"thread_diameter\": 0.5, \"thread_spacing\": 0.8, \"shade_thickness\": 0.6");
    ck_assert_int_eq(bst_shade_read_igsdb(ctx, path, &s), BST_OK);
    ck_assert_int_eq(bst_shade_band_values(ctx, s, cat(), &vis, &sol), BST_OK);
    bst_shade_free(s);
    bst_glass *g;
    ck_assert_int_eq(bst_glass_parse(ctx, tu_ref("wce/data/spectral_NFRC_102.tsv"), cat(), &g), BST_OK);
    const bst_shade_band *band[2] = {&vis, &sol};
    static const char *const name[2] = {"Visible", "Solar"};
    /* WCE's averages of NFRC 102 at theta 0 (glass_angular_averaged_wce.tsv): T, R */
    double wce[2][2] = {{NAN, NAN}, {NAN, NAN}};
    in = fopen(tu_ref("wce/glass/glass_angular_averaged_wce.tsv"), "r");
    ck_assert_ptr_nonnull(in);
    char hdr[512];
    ck_assert_ptr_nonnull(fgets(hdr, sizeof hdr, in));
    while (fgets(line, sizeof line, in)) {
        char glass[32], bandname[32];
        double th, tf, tb, rf, rb;
        if (sscanf(line, "%31s %31s %lf %lf %lf %lf %lf", glass, bandname, &th, &tf, &tb, &rf, &rb) == 7 &&
            strstr(glass, "102") && th == 0)
            for (int k = 0; k < 2; k++)
                if (strncasecmp(bandname, name[k], 3) == 0)
                    wce[k][0] = tf, wce[k][1] = rf;
    }
    fclose(in);
    for (int k = 0; k < 2; k++) {
        double tf, tb, rf, rb;
        int ch = bst_glass_find_channel(g, name[k]);
        ck_assert_int_ge(ch, 0);
        bst_glass_optics(g, (size_t)ch, 0.0, &tf, &tb, &rf, &rb);
        printf("%s: shade T %.9f Rf %.9f Rb %.9f; pane %.9f %.9f %.9f; WCE %.6f %.6f\n", name[k],
               band[k]->diffuse[0], band[k]->diffuse[2], band[k]->diffuse[3], tf, rf, rb, wce[k][0], wce[k][1]);
        ck_assert(tu_close(band[k]->diffuse[0], tf, 1e-12, 0) && tu_close(band[k]->diffuse[1], tb, 1e-12, 0));
        ck_assert(tu_close(band[k]->diffuse[2], rf, 1e-12, 0) && tu_close(band[k]->diffuse[3], rb, 1e-12, 0));
        ck_assert_msg(fabs(band[k]->diffuse[0] - wce[k][0]) < 1e-5 && fabs(band[k]->diffuse[2] - wce[k][1]) < 1e-5,
                      "%s: WCE's %g %g", name[k], wce[k][0], wce[k][1]);
    }
    bst_glass_free(g);
}
END_TEST

/* shade:SPEC is refused with status st and one line holding each of the texts given. */
static void refused(const char *spec, int st, const char *a, const char *b)
{
    bst_shade_model m;
    ck_assert_int_eq(bst_shade_parse(ctx, spec, cat(), &m), st);
    const char *msg = bst_ctx_message(ctx);
    ck_assert_msg(strstr(msg, a) && (!b || strstr(msg, b)) && !strchr(msg, '\n'),
                  "%s: '%s' lacks '%s' / '%s'", spec, msg, a, b ? b : "");
}

START_TEST(test_refused)
{
    char s[600];
    const char *path = record("v.json", "venetian", "", dual(slat), venetian_geo);
    snprintf(s, sizeof s, "shade:%s,tilt=30,colour=red", path);
    refused(s, BST_EINVAL, "unknown key 'colour'", path);
    snprintf(s, sizeof s, "shade:%s,tilt=100", path);
    refused(s, BST_EINVAL, "tilt = 100", path);
    /* a curved slat: the record's radius (mm) is the model's curvature (m) */
    const char *curved = record("c.json", "venetian", "", dual(slat), "\"slat_width\": 16, "
                                "\"slat_spacing\": 12, \"slat_curvature\": 30, \"number_segments\": 5");
    snprintf(s, sizeof s, "shade:%s", curved);
    bst_shade_model m;
    int st = bst_shade_parse(ctx, s, cat(), &m);
    ck_assert_msg(st == BST_OK, "%d %s", st, bst_ctx_message(ctx));
    ck_assert_double_eq_tol(m.venetian.curvature, 0.030, 1e-15);
    /* Tf and Tb apart, the faces' specular reflectances apart, a component missing */
    const char *v[16];
    memcpy(v, slat, sizeof v);
    v[5] = "0.2";
    snprintf(s, sizeof s, "shade:%s", record("t.json", "venetian", "", dual(v), venetian_geo));
    refused(s, BST_ENOTIMPL, "Tf_vis 0.04 and Tb_vis 0.2 differ", NULL);
    memcpy(v, slat, sizeof v);
    v[11] = "0.3";
    snprintf(s, sizeof s, "shade:%s", record("r.json", "venetian", "", dual(v), venetian_geo));
    refused(s, BST_ENOTIMPL, "Rf_sol_specular 0.1 and Rb_sol_specular 0.3 differ", NULL);
    memcpy(v, slat, sizeof v);
    v[3] = v[7] = "null";
    snprintf(s, sizeof s, "shade:%s", record("m.json", "venetian", "", dual(v), venetian_geo));
    refused(s, BST_EFORMAT, "Rb_vis_specular and _diffuse both missing", NULL);
    /* a glazing record, a file that is not there, no file, not a shade */
    snprintf(s, sizeof s, "%s/g.json", dir);
    FILE *fp = fopen(s, "w");
    fprintf(fp, "{\"product_id\": 1, \"type\": \"glazing\", \"subtype\": \"monolithic\"}");
    fclose(fp);
    char g[700];
    snprintf(g, sizeof g, "shade:%s", s);
    refused(g, BST_EFORMAT, "not a shading product (a pane: read it as glass:FILE)", NULL);
    snprintf(g, sizeof g, "shade:%s/none.json,tilt=3", dir);
    refused(g, BST_EFORMAT, "none.json", NULL);
    refused("shade:", BST_EINVAL, "no file named", NULL);
    refused("roller:x=1", BST_EINVAL, "is not a shade", NULL);
    /* as a pane: refused, naming shade:FILE */
    bst_glass *pane = NULL;
    ck_assert_int_eq(bst_glass_parse(ctx, path, cat(), &pane), BST_EINVAL);
    ck_assert_ptr_null(pane);
    ck_assert(strstr(bst_ctx_message(ctx), "name it shade:"));
}
END_TEST

static int parse_step(bst_ctx *c, void *spec)
{
    bst_shade_model m;
    return bst_shade_parse(c, spec, cat(), &m);
}

START_TEST(test_alloc_failure)
{
    char s[2][600];
    snprintf(s[0], sizeof s[0], "shade:%s,tilt=10", record("v.json", "venetian", "", dual(slat), venetian_geo));
    snprintf(s[1], sizeof s[1], "shade:%s", record("p.json", "perforated-screen", "\"thickness\": 0.2",
             constant_rows, "\"spacing_x\": 1.7, \"spacing_y\": 2, \"dimension_x\": 0.6, "
             "\"perforation_type\": \"Circular\""));
    tg_alloc_sweep("a dual-band venetian record", 200, parse_step, s[0]);
    tg_alloc_sweep("a screen record of spectral rows", 200, parse_step, s[1]);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("shade");
    TCase *tc = tcase_create("records");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 120);
    tcase_add_test(tc, test_venetian);
    tcase_add_test(tc, test_perforated);
    tcase_add_test(tc, test_woven);
    tcase_add_test(tc, test_band_values);
    tcase_add_test(tc, test_refused);
    tcase_add_test(tc, test_alloc_failure);
    suite_add_tcase(s, tc);
    return tu_run(s);
}
