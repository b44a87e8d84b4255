/* test_glass_optics.c - Optics / IGDB text files as glass:FILE (glass_optics.c).
 *  - NFRC 102's data (../shared/reference/wce) written as an Optics file in both column layouts
 *    (4: wavelength T Rf Rb; 9: direct and diffuse parts) and both wavelength units gives the same
 *    pane (every channel, angle and wavelength) and the same two-pane stack with NFRC 103 as the
 *    same data in bsdfstack's table, to the bit;
 *  - the header: metadata kept, the type choosing the model (Monolithic: uncoated; Coated,
 *    Laminate: coated; model= overriding it), other lines ignored, CR LF line ends;
 *  - a catalogue pane whose spectral file is an Optics file;
 *  - bad files refused with one line naming file:line; allocation failure. */
#include <config.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "glass.h"
#include "testglass.h"
#include "testutil.h"

/* The fixture (tg_setup): tg_ctx, NFRC 102's rows tg_nfrc102, a scratch directory. */

/* The header of IGDB's file for NFRC 102 in outline, with a line of our own that means nothing
 * to bsdfstack. */
static const char header[] = "{ Units, Wavelength Units } SI %s\n"
                             "{ Thickness } 3.048\n"
                             "{ Conductivity } 1\n"
                             "{ IR Transmittance } TIR=0\n"
                             "{ Emissivity, back front } Emis= 0.83 0.84\n"
                             "{ }\n"
                             "{ Ef_Source: Material }\n"
                             "{ Product Name: Generic Clear Glass }\n"
                             "{ Manufacturer: Generic }\n"
                             "{ NFRC ID: 102 }\n"
                             "{ Type: %s }\n"
                             "{ Coating Name: N/A }\n"
                             "{ Coated Side: Neither }\n"
                             "{ Appearance: Clear }\n"
                             "{ Something bsdfstack does not read: 42 }\n";

/* NFRC 102 as an Optics file: ncol 4 or 9, wavelengths in nm or um, line ends "\n" or "\r\n". */
static const char *write_optics(const char *name, int ncol, int nm, const char *type, const char *eol)
{
    const char *path;
    FILE *fp = tg_create(name, &path);
    fprintf(fp, header, nm ? "Nanometers" : "Microns", type);
    for (size_t k = 0; k < tg_nfrc102.n; k++) {
        char (*v)[24] = tg_nfrc102.v[k];
        char wl[32];
        if (nm) /* the same decimal number, shifted: 0.305 -> 305 */
            snprintf(wl, sizeof wl, "%.6g", atof(v[0]) * 1000);
        else
            snprintf(wl, sizeof wl, "%s", v[0]);
        ck_assert_str_eq(v[1], v[2]); /* NFRC 102: one T for both sides, as 4 columns need */
        if (ncol == 4)
            fprintf(fp, "%s    %s    %s    %s%s", wl, v[1], v[3], v[4], eol);
        else
            fprintf(fp, "%s  %s 0  %s 0.0000  %s 0  %s 0%s", wl, v[1], v[2], v[3], v[4], eol);
    }
    fclose(fp);
    return path;
}

/* Both layouts and both units are the table's pane and stack. */
START_TEST(test_same_as_table)
{
    bst_glass *table = tg_parse(tg_ctx, tu_ref("wce/data/spectral_NFRC_102.tsv"));
    ck_assert_str_eq(bst_glass_metadata(table)->source, "table");
    for (int v = 0; v < 4; v++) {
        char name[32];
        snprintf(name, sizeof name, "CLEAR_3_%d.DAT", v);
        const char *path = write_optics(name, v & 1 ? 9 : 4, v >> 1, "Monolithic", v ? "\n" : "\r\n");
        bst_glass *g = tg_parse(tg_ctx, path);
        tg_same_pane(g, table);
        if (v == 0 || v == 3)
            tg_same_stack(tg_ctx, g, table);
        const bst_glass_meta *m = bst_glass_metadata(g);
        ck_assert_str_eq(m->source, "optics");
        ck_assert_str_eq(m->path, path);
        ck_assert_str_eq(m->product_name, "Generic Clear Glass");
        ck_assert_str_eq(m->manufacturer, "Generic");
        ck_assert_str_eq(m->type, "Monolithic");
        ck_assert_str_eq(m->coated_side, "Neither");
        ck_assert_str_eq(m->coating_name, "N/A");
        ck_assert_str_eq(m->wavelength_units, v >> 1 ? "Nanometers" : "Microns");
        ck_assert_int_eq(m->nfrc_id, 102);
        ck_assert(m->thickness_mm == 3.048 && m->conductivity == 1 && m->ir_transmittance == 0);
        ck_assert(m->emissivity_front == 0.84 && m->emissivity_back == 0.83); /* "back front" */
        ck_assert_str_eq(m->model_from, "type");
        ck_assert_int_eq(bst_glass_get_model(g), BST_GLASS_UNCOATED);
        ck_assert(strstr(bst_glass_description(g), "Generic Clear Glass"));
        bst_glass_free(g);
    }
    bst_glass_free(table);
}
END_TEST

/* The type picks WINDOW's model; model= overrides it; a type WINDOW does not know needs model=. */
START_TEST(test_type_and_model)
{
    static const struct {
        const char *type;
        bst_glass_model model;
    } t[] = {{"Coated", BST_GLASS_COATED},       {"Laminate", BST_GLASS_COATED},
             {"Applied Film", BST_GLASS_COATED}, {"Interlayer", BST_GLASS_UNCOATED}};
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++) {
        const char *path = write_optics("TYPED.DAT", 4, 0, t[i].type, "\n");
        bst_glass *g = tg_parse(tg_ctx, path);
        ck_assert_int_eq(bst_glass_get_model(g), t[i].model);
        ck_assert_str_eq(bst_glass_metadata(g)->model_from, "type");
        ck_assert_str_eq(bst_glass_metadata(g)->type, t[i].type);
        char spec[300];
        snprintf(spec, sizeof spec, "%s,model=%s", path,
                 t[i].model == BST_GLASS_COATED ? "uncoated" : "coated");
        bst_glass *h = tg_parse(tg_ctx, spec);
        ck_assert_int_ne(bst_glass_get_model(h), t[i].model);
        ck_assert_str_eq(bst_glass_metadata(h)->model_from, "spec");
        /* the coated pane per wavelength is the correlation's */
        bst_glass *c = t[i].model == BST_GLASS_COATED ? g : h;
        double tf, rf, t0, r0, tw, rw;
        ck_assert_int_eq(bst_glass_optics_spectral(c, 0.55, 1.0, &tf, NULL, &rf, NULL), BST_OK);
        ck_assert_int_eq(bst_glass_optics_spectral(c, 0.55, 0.0, &t0, NULL, &r0, NULL), BST_OK);
        bsti_glass_coated_optics(t0, r0, cos(1.0), &tw, &rw);
        ck_assert(tf == tw && rf == rw);
        bst_glass_free(g), bst_glass_free(h);
    }
    const char *path = write_optics("TINTED.DAT", 4, 0, "Tinted", "\n");
    tg_refused(tg_ctx, path, "material type 'Tinted'");
    char spec[300];
    snprintf(spec, sizeof spec, "%s,model=coated", path);
    bst_glass *g = tg_parse(tg_ctx, spec);
    ck_assert_str_eq(bst_glass_metadata(g)->type, "Tinted");
    bst_glass_free(g);
}
END_TEST

/* A catalogue pane whose data are an Optics file, and the catalogue's type and model lines. */
START_TEST(test_catalogue)
{
    write_optics("CLEAR_3.DAT", 4, 1, "Monolithic", "\n");
    char cmd[600]; /* the band spectra live in the catalogue directory */
    snprintf(cmd, sizeof cmd, "cp '%s'/*.tsv '%s'", getenv("BSDFSTACK_GLASS_DIR"), tg_path(""));
    ck_assert_int_eq(system(cmd), 0);
    static const char *const pane[] = {"spectral CLEAR_3.DAT\n",
                                       "description laminated\ntype Laminate\nVisible t0=0.8,r0=0.08\n",
                                       "type Laminate\nmodel uncoated\nVisible t0=0.8,r0=0.08\n",
                                       "model shiny\nVisible t0=0.8,r0=0.08\n"};
    for (int i = 0; i < 4; i++) {
        const char *path;
        FILE *fp = tg_create("p.glass", &path);
        fputs(pane[i], fp);
        fclose(fp);
        bst_glass *g = NULL;
        int rc = bst_glass_parse(tg_ctx, "p", tg_dir(), &g);
        if (i == 3) {
            ck_assert_int_lt(rc, 0);
            ck_assert(strstr(bst_ctx_message(tg_ctx), "p.glass: line 1: model 'shiny'"));
            continue;
        }
        ck_assert_msg(rc == BST_OK, "%s", bst_ctx_message(tg_ctx));
        const bst_glass_meta *m = bst_glass_metadata(g);
        ck_assert_str_eq(m->source, "catalogue");
        ck_assert(strstr(m->path, "p.glass"));
        ck_assert_int_eq(bst_glass_get_model(g), i == 1 ? BST_GLASS_COATED : BST_GLASS_UNCOATED);
        static const char *const from[3] = {"type", "type", "catalogue"};
        ck_assert_str_eq(m->model_from, from[i]);
        if (i == 0)
            ck_assert(m->nfrc_id == 102 && strcmp(m->product_name, "Generic Clear Glass") == 0);
        bst_glass_free(g);
    }
}
END_TEST

/* An Optics file of the given body (after a units line) and what its refusal must say. */
static void refused_body(const char *body, const char *expect)
{
    const char *path;
    FILE *fp = tg_create("BAD.DAT", &path);
    fprintf(fp, "%s", body);
    fclose(fp);
    char want[300];
    snprintf(want, sizeof want, "%s%s", tg_path("BAD.DAT"), expect);
    tg_refused(tg_ctx, tg_path("BAD.DAT"), want);
}

START_TEST(test_bad_files)
{
#define U "{ Units, Wavelength Units } SI Microns\n"
    refused_body(U "0.3 0.8 0.08 0.08 0.1\n0.4 0.8 0.08 0.08\n", ":2: 5 numbers: a data row has 4");
    refused_body(U "0.3 0.8 0.08 0.08\n0.4 0.8 O.08 0.08\n", ":3: 'O.08' is not a number");
    refused_body(U "0.3 0.8 0.08 0.08\n0.4 0.8,0.08 0.08\n", ":3: '0.8,0.08' is not a number");
    refused_body(U "0.4 0.8 0.08 0.08\n0.3 0.8 0.08 0.08\n", ":3: wavelengths must increase");
    refused_body(U "0.3 1.2 0.08 0.08\n0.4 0.8 0.08 0.08\n", ":2: Tf = 1.2 is not a value in [0, 1]");
    refused_body(U "0.3 0.8 0.08 -0.01\n0.4 0.8 0.08 0.08\n", ":2: Rb = -0.01 is not a value");
    refused_body(U "0.3 0.8 0.3 0.08\n0.4 0.8 0.08 0.08\n", ":2: T + R exceeds 1");
    refused_body(U "0.3 0.8 0 0.8 0 0.08 0.01 0.08 0\n", ":2: diffuse part Rf_dif = 0.01");
    refused_body(U "0.3 0.8 0 0.8 0 0.08 0 0.08 0\n0.4 0.8 0.08 0.08\n", ":3: 4 numbers after rows of 9");
    refused_body("{ Units, Wavelength Units } IP Microns\n", ":1: unit system 'IP'");
    refused_body("{ Units, Wavelength Units } SI Furlongs\n", ":1: wavelength unit 'Furlongs'");
    refused_body("{ Units, Wavelength Units } SI\n", ":1: the units line needs");
    refused_body(U "0.3 0.8 0.08 0.08\n" U, ":3: the units line comes after data rows");
    refused_body("{ Thickness } thick\n", ":1: { Thickness } needs a number");
    refused_body("{ IR Transmittance } TIR=2\n", ":1: { IR Transmittance } needs a number");
    refused_body("{ Emissivity, front back } Emis= 0.84\n", ":1: the emissivity line needs two");
    refused_body("{ NFRC ID: one-o-two }\n", ":1: NFRC ID 'one-o-two' is not a number");
    refused_body(U "300 0.8 0.08 0.08\n400 0.8 0.08 0.08\n", ":2: wavelength 300 um is not in");
    refused_body(U "0.3 0.8 0.08 0.08\n", ": 1 data rows (an Optics file needs at least two)");
    refused_body("{ Units, Wavelength Units } SI Nanometers\n{ Type: Coated }\n", ": 0 data rows");
#undef U
    /* a file that is no pane's data at all */
    const char *path;
    FILE *fp = tg_create("NUL.DAT", &path);
    fputs("{ Units, Wavelength Units } SI Microns\n0.3 0.8", fp);
    fputc('\0', fp);
    fputs(" 0.08 0.08\n", fp);
    fclose(fp);
    tg_refused(tg_ctx, tg_path("NUL.DAT"), "line 2 holds a NUL byte");
}
END_TEST

/* Every allocation of reading an Optics file may fail: an error, never a leak or a crash. */
START_TEST(test_alloc_failure)
{
    char path[256];
    snprintf(path, sizeof path, "%s", write_optics("CLEAR_3.DAT", 9, 1, "Coated", "\r\n"));
    tg_alloc_sweep("an Optics file", 400, tg_read_pane, path);
}
END_TEST

int main(void)
{
    const TTest *const tests[] = {test_same_as_table, test_type_and_model, test_catalogue,
                                  test_bad_files, test_alloc_failure};
    return tu_run(tg_suite("glass_optics", tg_setup, tg_teardown, 120, tests,
                           sizeof tests / sizeof tests[0]));
}
