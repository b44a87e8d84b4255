/* cmd_info.c - `bsdfstack info FILE`: what a BSDF file holds, its directional-hemispherical T and R
 * by incidence angle, its energy balance and the reciprocity of its transmissions; with
 * --reference, how far its T and R are from another BSDF's at every incident patch. */
#include <config.h>

#include <fcntl.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"
#include "layers.h"

static const char help[] =
    "Usage: bsdfstack info [--max-memory SIZE] [--reference REF] FILE[^]\n"
    "       bsdfstack info glass:SPEC[^] | shade:FILE.json[,KEYS][^] | venetian:KEYS[^] | ...\n"
    "Prints the basis and channels of a BSDF XML file, which components it stores (Tf(derived):\n"
    "made from the other transmission by reciprocity; Rf(absent): not in the file, read as zero,\n"
    "its values printed as '-'), the directional-hemispherical transmittance T and reflectance R\n"
    "for front (exterior) and back incidence at theta = 0, 15, 30, 45, 60, 75 degrees\n"
    "(propagation azimuth 0 and 90), and the energy balance: the largest T + R over all incident\n"
    "patches of each side (the largest T or R alone, and which is absent, where the file lacks\n"
    "one; nothing where it lacks both), and the reciprocity error of the transmissions: the\n"
    "largest |Tf(o,i) - Tb(a(i),a(o))| (a: the antipodal patch) relative to the largest T, and\n"
    "the patches (incident -> outgoing) where it is largest.  The file is taken whole at its\n"
    "own basis; --max-memory SIZE (16G, 800M; default: the memory available now) refuses it\n"
    "first when the estimate exceeds SIZE.\n"
    "--reference REF (a BSDF file or glass: spec, read at FILE's basis): for each channel of\n"
    "FILE (REF must hold it) and each component, the largest difference of a directional-\n"
    "hemispherical value over every incident patch, where it is, and the least flux\n"
    "accordance FA (the share of the scattered flux placed alike, as `compare` prints it):\n"
    "what a reduced, resampled or converted file changed of the T and R users compute with\n"
    "(REF: the same system written with --no-reduce, say).\n"
    "A file bsdfstack wrote lists its layers as its header records them, and for each pane its\n"
    "angular model and why, its source and what its file says of it.\n"
    "glass:SPEC (a pane, bsdfstack-glass(5)): its description, source, angular model and why,\n"
    "metadata, channels, and T and R at the angles above (a pane is specular: its directional-\n"
    "hemispherical values are the model's at that angle; `bsdfstack glass` prints more).\n"
    "shade:FILE.json[,KEYS] (an IGSDB shading record, bsdfstack-glass(5)): the product, its\n"
    "kind, geometry and material (band values Tf Tb Rf Rb, specular and diffuse), and the model\n"
    "its layer is made from, as the venetian:, perforated: or woven: spec that makes the same\n"
    "layer (KEYS override the record's values); venetian:KEYS and the others: that model.\n"
    "A trailing ^ (FILE^, glass:SPEC^, venetian:KEYS^, ...) takes the layer reversed, as\n"
    "combine does: its back side faces the exterior, and front values are its back side's.\n"
    "FILE - (standard input) is not supported.\n";

/* The layers a file written by bsdfstack records in its header comment ("layers (exterior first):
 * ..." and one "layer N SPEC: ..." line per pane), printed as "layers    ..." lines; nothing for
 * other files.  Only the comment before the root element is looked at, and only in a regular file:
 * a FIFO or a device the reader has drained would wait for a writer for ever. */
#define INFO_HEADER_MAX 65536
static void print_recorded_layers(const char *path)
{
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    struct stat st;
    FILE *fp = fd >= 0 && fstat(fd, &st) == 0 && S_ISREG(st.st_mode) ? fdopen(fd, "r") : NULL;
    if (!fp) {
        if (fd >= 0)
            close(fd);
        return;
    }
    char line[4096];
    int in = 0, ours = 0;
    long read = 0;
    while (fgets(line, sizeof line, fp) && (read += (long)strlen(line)) < INFO_HEADER_MAX) {
        if (!in && strstr(line, "<WindowElement"))
            break;
        if (!in) {
            in = strstr(line, "<!--") != NULL;
            continue;
        }
        if (strstr(line, "-->"))
            break;
        size_t len = strlen(line);
        if (len && line[len - 1] != '\n') /* longer than line: its start, cut, and a newline */
            line[len - 1] = '\n';
        if (strncmp(line, "  Written by bsdfstack ", 23) == 0)
            ours = 1;
        else if (ours && strncmp(line, "  layers (exterior first): ", 27) == 0)
            printf("layers    %s", line + 27); /* the specs, exterior first */
        else if (ours && strncmp(line, "  layer ", 8) == 0)
            printf("          %s", line + 2); /* "layer N SPEC: model, source, metadata" */
    }
    fclose(fp);
}

/* `info glass:SPEC`: what the pane is and where its model comes from, and its T and R by angle;
 * glass:SPEC^, the pane reversed (its back side to the exterior), as combine installs it. */
static int info_pane(const char *sub, const char *spec)
{
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    int flip;
    char *gspec = strndup(spec + 6, cli_spec_reversed(spec, &flip) - 6);
    bst_glass *g = NULL;
    if (!gspec || bst_glass_parse(ctx, gspec, getenv("BSDFSTACK_GLASS_DIR"), &g) < 0) {
        int rc = gspec ? cli_fail_ctx(sub, NULL, ctx) : cli_fail(sub, "out of memory");
        free(gspec);
        bst_ctx_free(ctx);
        return rc;
    }
    free(gspec);
    printf("pane      %s\n", spec);
    if (flip)
        printf("reversed  its back side faces the exterior: front below is the pane's back side\n");
    printf("          %s\n", bst_glass_description(g));
    cli_glass_describe(stdout, g, "          ");
    size_t nw = bst_glass_nwavelengths(g);
    if (nw)
        printf("spectral  %zu wavelengths, %g..%g um\n", nw, bst_glass_wavelength(g, 0),
               bst_glass_wavelength(g, nw - 1));
    for (size_t ch = 0; ch < bst_glass_nchannels(g); ch++)
        printf("channel   %s: Tf Rf Tb Rb, diagonal in every basis (a specular pane)\n",
               bst_glass_channel(g, ch));
    for (size_t ch = 0; ch < bst_glass_nchannels(g); ch++) {
        printf("\n%s: T and R of the pane at incidence theta\n", bst_glass_channel(g, ch));
        printf("theta  T_front R_front  T_back  R_back\n");
        for (int t = 0; t <= 75; t += 15) {
            double tf, tb, rf, rb;
            bst_glass_optics(g, ch, t * M_PI / 180, &tf, &tb, &rf, &rb);
            if (flip) /* a pane is isotropic: reversed, its sides swap */
                printf("%5d %8.4f %7.4f %7.4f %7.4f\n", t, tb, rb, tf, rf);
            else
                printf("%5d %8.4f %7.4f %7.4f %7.4f\n", t, tf, rf, tb, rb);
        }
    }
    bst_glass_free(g);
    bst_ctx_free(ctx);
    return CLI_OK;
}

/* The record's material values of one band, as "Tf Tb Rf Rb" specular / diffuse ("-" absent). */
static void print_band(const char *name, const bst_shade_band *b)
{
    printf("          %-8s", name);
    for (int part = 0; part < 2; part++) {
        const double *v = part ? b->diffuse : b->specular;
        printf("%s", part ? "  diffuse" : "specular");
        for (int c = 0; c < 4; c++)
            printf(isnan(v[c]) ? "       -" : " %7.4f", v[c]);
    }
    printf("\n");
}

/* What an IGSDB shading record says (`info shade:FILE`): product, kind, geometry, material. */
static int print_record(bst_ctx *ctx, const char *body)
{
    /* the file as bst_shade_parse takes it: to the first comma, unless the whole names a file */
    const char *comma = strchr(body, ',');
    char *file = strndup(body, comma && access(body, F_OK) != 0 ? (size_t)(comma - body) : strlen(body));
    bst_shade *s = NULL;
    bst_shade_band vis, sol;
    int rc = file ? bst_shade_read_igsdb(ctx, file, &s) : BST_ENOMEM;
    free(file);
    if (rc >= 0)
        rc = bst_shade_band_values(ctx, s, getenv("BSDFSTACK_GLASS_DIR"), &vis, &sol);
    if (rc < 0) {
        bst_shade_free(s);
        return rc;
    }
    printf("product   %s (IGSDB %ld%s%s), %s\n", s->name, s->product_id, *s->manufacturer ? ", " : "",
           s->manufacturer, bst_shade_kind_name(s->kind));
    if (s->kind == BST_SHADE_VENETIAN)
        printf("geometry  slat width %g mm, spacing %g mm, curvature %g mm, tilt %g, %d segments\n",
               s->geometry.venetian.slat_width, s->geometry.venetian.slat_spacing,
               s->geometry.venetian.slat_curvature, s->geometry.venetian.slat_tilt,
               s->geometry.venetian.number_segments);
    else if (s->kind == BST_SHADE_WOVEN)
        printf("geometry  thread diameter %g mm, spacing %g mm, shade thickness %g mm\n",
               s->geometry.woven.thread_diameter, s->geometry.woven.thread_spacing,
               s->geometry.woven.shade_thickness);
    else
        printf("geometry  %s holes %g x %g mm (radius if circular), pitch %g x %g mm\n",
               s->geometry.perforated.type == BST_PERFORATION_CIRCULAR ? "circular"
               : s->geometry.perforated.type == BST_PERFORATION_SQUARE ? "square" : "rectangular",
               s->geometry.perforated.dimension_x, s->geometry.perforated.dimension_y,
               s->geometry.perforated.spacing_x, s->geometry.perforated.spacing_y);
    printf("material  %s, thickness %g mm", s->material.name, s->material.thickness_mm);
    if (s->material.n)
        printf(", %zu spectral rows %g..%g um (band averages below)\n", s->material.n,
               s->material.wl[0], s->material.wl[s->material.n - 1]);
    else
        printf(", dual-band values\n");
    if (!isnan(s->permeability))
        printf("openness  %g (measured_data.permeability_factor, not used by the optics)\n", s->permeability);
    printf("bands     Tf Tb Rf Rb:\n");
    print_band("Visible", &vis);
    print_band("Solar", &sol);
    bst_shade_free(s);
    return BST_OK;
}

/* `info shade:FILE[,KEYS]` (or venetian:, perforated:, woven:): the record, and the model the layer
 * is made from, as its spec. */
static int info_shade(const char *sub, const char *spec)
{
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    bst_shade_model m;
    int rc = strncmp(spec, "shade:", 6) == 0 ? print_record(ctx, spec + 6) : BST_OK;
    if (rc >= 0)
        rc = cli_shade_parse(ctx, spec, &m);
    if (rc < 0) {
        rc = cli_fail_ctx(sub, NULL, ctx);
        bst_ctx_free(ctx);
        return rc;
    }
    char text[1024];
    int flip;
    cli_spec_reversed(spec, &flip);
    bst_shade_model_spec(&m, text, sizeof text);
    printf("model     %s%s\n", text, flip ? "^" : "");
    if (flip) /* the ^ as combine reads it (bst_layer_flip of the model's layer) */
        printf("reversed  the layer made from this model, its back side to the exterior\n");
    printf("channel   Visible, Solar (a value A/B: A for Visible, B for Solar)\n");
    bst_ctx_free(ctx);
    return CLI_OK;
}

/* What a file holds of a component: stored, derived (a transmission the reader makes from the
 * other side's by reciprocity, as every TensorTree4 file expects) or absent (the reader takes it
 * as zero: nothing is known of it). */
enum comp_state { STORED, DERIVED, ABSENT };
static const char *const state_mark[] = {"", "(derived)", "(absent)"};

/* The state of component c of the channel named `name` in file b, read reversed (flip: the file's
 * back side to the exterior, so that its Tb is the layer's Tf, and so on) or not. */
static enum comp_state comp_state(const bst_bsdf *b, const char *name, int flip, int c)
{
    if (flip)
        c = c == BST_TF ? BST_TB : c == BST_TB ? BST_TF : c == BST_RF ? BST_RB : BST_RF;
    int other = c == BST_TF ? BST_TB : c == BST_TB ? BST_TF : -1;
    for (size_t k = 0; k < bst_bsdf_nchannels(b); k++)
        if (strcmp(bst_bsdf_channel(b, k), name) == 0)
            return bst_bsdf_stored(b, k, (bst_comp)c) ? STORED
                   : other >= 0 && bst_bsdf_stored(b, k, (bst_comp)other) ? DERIVED : ABSENT;
    return ABSENT;
}

/* The reciprocity line of channel ch of layer l; st: the channel's component states. */
static void print_reciprocity(bst_ctx *ctx, const bst_layer *l, size_t ch, const enum comp_state st[])
{
    const bst_basis *basis = bst_layer_basis(l);
    double err, din[3], dout[3];
    size_t i, o;
    if (st[BST_TF] == ABSENT) { /* then Tb too: neither is there to derive the other from */
        printf("reciprocity not computed (neither Tf nor Tb is in the file)\n");
        return;
    }
    if (st[BST_TF] == DERIVED || st[BST_TB] == DERIVED) {
        /* exactly reciprocal by construction (and finite, as read): no N^2 passes */
        printf("reciprocity 0 (one transmission is derived from the other)\n");
        return;
    }
    if (bst_metrics_reciprocity(ctx, l, ch, &err, &i, &o) < 0) {
        printf("reciprocity not computed: %s\n", bst_ctx_message(ctx));
        return;
    }
    bst_basis_center(basis, i, din);
    bst_basis_center(basis, o, dout);
    printf("reciprocity %.3g, largest at patch %zu (theta %.1f deg) -> %zu (theta %.1f deg)\n",
           err, i, acos(din[2]) * 180 / M_PI, o, acos(dout[2]) * 180 / M_PI);
}

/* The per-incident-patch change of FILE's (path, read as l) hemispherical values against ref,
 * channel by channel (both loaded again over l's basis with that channel alone). */
static int print_against(bst_ctx *ctx, const char *sub, const char *path, const char *ref,
                         const bst_layer *l)
{
    struct cli_basis_choice choice;
    cli_basis_choice_of(bst_layer_basis(l), &choice);
    size_t n = bst_basis_size(bst_layer_basis(l));
    double *ha = malloc(4 * n * sizeof *ha), *hb = ha + n, *fa = hb + n, *ga = fa + n;
    if (!ha)
        return cli_fail(sub, "out of memory");
    int rc = CLI_OK, any = 0;
    for (size_t ch = 0; rc == CLI_OK && ch < bst_layer_nchannels(l); ch++) {
        char *specs[2] = {(char *)path, (char *)ref};
        struct cli_layers set;
        const char *name = bst_layer_channel(l, ch);
        bst_ctx_clear(ctx);
        if (cli_layers_load(&set, ctx, sub, 2, specs, &choice, name, 0, BST_DOUBLE) != CLI_OK) {
            rc = CLI_FAIL; /* (told) */
            break;
        }
        const bst_layer *a = set.layers[0], *b = set.layers[1];
        if (ch == 0)
            printf("\nagainst   %s (read at this file's basis): the largest change of a directional-\n"
                   "hemispherical value over every incident patch, where it is, and the least FA\n", ref);
        printf("%s:\n  comp  |FILE - REF|  patch  theta    phi     FILE      REF  FA least\n", name);
        for (int c = 0; c < BST_NCOMP && rc == CLI_OK; c++) {
            bst_comp comp = (bst_comp)c;
            if (!bst_layer_get(a, 0, comp) && !bst_layer_get(b, 0, comp))
                continue;
            if (bst_layer_hemispherical(ctx, a, 0, comp, ha) < 0 ||
                bst_layer_hemispherical(ctx, b, 0, comp, hb) < 0 ||
                bst_metrics_accordance_all(ctx, a, b, 0, comp, ga, fa) < 0) {
                rc = cli_fail_ctx(sub, NULL, ctx);
                break;
            }
            size_t jh = 0, jf = 0;
            for (size_t j = 0; j < n; j++) {
                jh = fabs(ha[j] - hb[j]) > fabs(ha[jh] - hb[jh]) ? j : jh;
                jf = fa[j] < fa[jf] ? j : jf;
            }
            double d[3];
            bst_basis_center(bst_layer_basis(a), jh, d);
            double th = acos(d[2]) * 180 / M_PI, ph = atan2(d[1], d[0]) * 180 / M_PI;
            printf("  %-4s %12.6f %6zu %6.1f %6.1f %8.4f %8.4f %9.2f\n", bst_comp_name(comp),
                   fabs(ha[jh] - hb[jh]), jh, th, ph < 0 ? ph + 360 : ph, ha[jh], hb[jh], fa[jf]);
            any = 1;
        }
        cli_layers_free(&set);
    }
    if (rc == CLI_OK && !any)
        rc = cli_fail(sub, "%s and %s hold no component in common", path, ref);
    free(ha);
    return rc;
}

/* Values of a sane file (|v| < INFO_FIXED_MAX) print with 4 decimals; anything a broken file holds,
 * 1e300 say, as %.4g: one short line rather than 300 digits. */
#define INFO_FIXED_MAX 1e6

/* v in width columns; NaN (a component not in the file) as "-". */
static const char *value(char buf[32], int width, double v)
{
    if (isnan(v))
        snprintf(buf, 32, "%*s", width, "-");
    else
        snprintf(buf, 32, fabs(v) < INFO_FIXED_MAX ? "%*.4f" : "%*.4g", width, v);
    return buf;
}

/* The energy line of one side: the largest T + R over the incident patches (h: that side's T, then
 * its R, n values each; st: their states).  A component not in the file is not summed as zero:
 * the line says which is missing, and gives the largest of the other alone. */
static void print_energy(const bst_basis *basis, size_t n, int side, const double *h,
                         const enum comp_state st[2])
{
    const char *name = side ? "back " : "front", *t = side ? "Tb" : "Tf", *r = side ? "Rb" : "Rf";
    if (st[0] == ABSENT && st[1] == ABSENT) {
        printf("energy    %s: not computed (neither %s nor %s is in the file)\n", name, t, r);
        return;
    }
    int tw = st[0] != ABSENT, rw = st[1] != ABSENT; /* the terms summed */
    size_t worst = 0;
    for (size_t j = 0; j < n; j++)
        if (tw * h[j] + rw * h[n + j] > tw * h[worst] + rw * h[n + worst])
            worst = j;
    double s = tw * h[worst] + rw * h[n + worst], d[3];
    char v[32], missing[32] = "";
    bst_basis_center(basis, worst, d);
    if (!tw || !rw) /* T alone (or R alone) is a lower bound of T + R: past 1, T + R is too */
        snprintf(missing, sizeof missing, "; %s absent", tw ? r : t);
    printf("energy    %s: largest %s = %s at patch %zu (theta %.1f deg%s)%s\n", name,
           tw && rw ? "T + R" : tw ? t : r, value(v, 0, s), worst, acos(d[2]) * 180 / M_PI, missing,
           s > 1.0 + BST_ENERGY_TOL ? "  ** exceeds 1 **" : "");
}

int cmd_info(int argc, char **argv)
{
    const char *sub = "info";
    if (argc == 2 && (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0)) {
        fputs(help, stdout);
        return CLI_OK;
    }
    struct cli_basis_choice limit = {.lower = "'bsdfstack convert -k K' to a coarser file first"};
    const char *ref = NULL;
    while (argc >= 2 && (strcmp(argv[1], "--max-memory") == 0 || strcmp(argv[1], "--reference") == 0)) {
        if (argc < 3)
            return cli_usage(sub, "option '%s' needs a value", argv[1]);
        if (argv[1][2] == 'r')
            ref = argv[2];
        else if (cli_parse_memory(sub, argv[2], &limit.max_memory) != CLI_OK)
            return CLI_USAGE;
        argv += 2, argc -= 2;
    }
    if (argc < 2)
        return cli_usage(sub, "no file given");
    if (argc > 2)
        return cli_usage(sub, "one file expected");
    if (strcmp(argv[1], "-") == 0)
        return cli_usage(sub, "'-': reading standard input is not supported: name a file");
    if (argv[1][0] == '-')
        return cli_usage(sub, "unknown option '%s'", argv[1]);
    const char *path = argv[1];
    if (strncmp(path, "glass:", 6) == 0) {
        if (ref)
            return cli_usage(sub, "--reference compares a BSDF file, not a pane");
        return info_pane(sub, path);
    }
    if (cli_is_shade(path)) {
        if (ref)
            return cli_usage(sub, "--reference compares a BSDF file, not a shade's spec");
        return info_shade(sub, path);
    }
    bst_ctx *ctx = cli_ctx_new(sub);
    if (!ctx)
        return CLI_FAIL;
    bst_bsdf *b = NULL;
    bst_layer *l = NULL;
    /* FILE^: the layer reversed (its back side to the exterior), as combine installs it */
    int flip;
    char *file = strndup(path, cli_spec_reversed(path, &flip));
    int st = file ? bst_bsdf_read(ctx, file, NULL, &b) : BST_ENOMEM;
    if (st < 0) {
        int rc = file ? cli_fail_ctx(sub, NULL, ctx) : cli_fail(sub, "out of memory");
        free(file);
        bst_ctx_free(ctx);
        return rc;
    }
    cli_warn_bsdf(sub, file, b);
    bst_ctx_clear(ctx);
    /* the file is taken whole at its own basis: refuse before printing when that cannot fit */
    bst_basis *own = NULL;
    if (bst_bsdf_kind(b) != BST_FILE_KLEMS && bst_basis_new_sc(ctx, bst_bsdf_order(b), &own) < 0) {
        bst_bsdf_free(b), bst_ctx_free(ctx), free(file);
        return cli_fail(sub, "out of memory");
    }
    int fits = cli_memory_check(sub, own ? own : bst_bsdf_klems_basis(b), 1, &b, 0, BST_DOUBLE, &limit);
    bst_basis_free(own);
    if (fits != CLI_OK) {
        bst_bsdf_free(b), bst_ctx_free(ctx), free(file);
        return fits;
    }
    static const char *const kinds[] = {"Klems matrix", "", "", "TensorTree3 (isotropic)", "TensorTree4"};
    printf("file      %s\nformat    %s", file, kinds[bst_bsdf_kind(b)]);
    if (bst_bsdf_kind(b) != BST_FILE_KLEMS)
        printf(", order k = %d (%d x %d cells per hemisphere)\n", bst_bsdf_order(b),
               1 << bst_bsdf_order(b), 1 << bst_bsdf_order(b));
    else
        printf(", %s, %zu patches\n", bst_basis_name(bst_bsdf_klems_basis(b)),
               bst_basis_size(bst_bsdf_klems_basis(b)));
    if (flip)
        printf("reversed  its back side faces the exterior: front below is the file's back side\n");
    print_recorded_layers(file);
    for (size_t ch = 0; ch < bst_bsdf_nchannels(b); ch++) {
        printf("channel   %s:", bst_bsdf_channel(b, ch));
        for (int c = 0; c < BST_NCOMP; c++)
            printf(" %s%s", bst_comp_name((bst_comp)c),
                   state_mark[comp_state(b, bst_bsdf_channel(b, ch), flip, c)]);
        printf("\n");
    }
    if (bst_bsdf_to_layer(ctx, b, NULL, &l) < 0) {
        int rc = cli_fail_ctx(sub, file, ctx);
        bst_bsdf_free(b), bst_ctx_free(ctx), free(file);
        return rc;
    }
    if (flip) {
        bst_layer *f = NULL;
        int rc = bst_layer_flip(ctx, l, &f) < 0 ? cli_fail_ctx(sub, path, ctx) : CLI_OK;
        bst_layer_free(l);
        l = f;
        if (rc != CLI_OK) {
            bst_bsdf_free(b), bst_ctx_free(ctx), free(file);
            return rc;
        }
    }
    const bst_basis *basis = bst_layer_basis(l);
    size_t n = bst_basis_size(basis);
    double *h = malloc(4 * n * sizeof *h);
    if (!h) {
        bst_layer_free(l), bst_bsdf_free(b), bst_ctx_free(ctx), free(file);
        return cli_fail(sub, "out of memory");
    }
    for (size_t ch = 0; ch < bst_layer_nchannels(l); ch++) {
        enum comp_state cs[BST_NCOMP];
        for (int c = 0; c < BST_NCOMP; c++) {
            cs[c] = comp_state(b, bst_layer_channel(l, ch), flip, c);
            bst_layer_hemispherical(ctx, l, ch, (bst_comp)c, h + (size_t)c * n);
        }
        printf("\n%s: directional-hemispherical values (incident patch of the propagation direction)\n",
               bst_layer_channel(l, ch));
        printf("theta  phi   T_front R_front  T_back  R_back\n");
        for (int t = 0; t <= 75; t += 15)
            for (int p = 0; p <= 90; p += 90) {
                if (t == 0 && p)
                    continue;
                size_t j = cli_incident_patch(basis, t, p);
                char v[4][32];
                for (int c = 0; c < BST_NCOMP; c++)
                    value(v[c], c ? 7 : 8, cs[c] == ABSENT ? NAN : h[(size_t)c * n + j]);
                printf("%5d %4d %s %s %s %s\n", t, p, v[0], v[1], v[2], v[3]);
            }
        for (int side = 0; side < 2; side++)
            print_energy(basis, n, side, h + 2 * side * n, cs + 2 * side);
        print_reciprocity(ctx, l, ch, cs);
    }
    int rc = ref ? print_against(ctx, sub, path, ref, l) : CLI_OK;
    free(h);
    free(file);
    bst_layer_free(l);
    bst_bsdf_free(b);
    bst_ctx_free(ctx);
    return rc;
}
