/* fuzz_glass.c - libFuzzer target: glass specifications and catalogue files (glass_spec.c, with
 * glass_band.c for spectral data tables, glass_optics.c and glass_json.c for Optics files and IGSDB
 * records, glass.c and glass_coated.c for the models), then the pane's optics and a small layer
 * of it (glass_layer.c).
 *
 * Input, two modes:
 *   - one line (no '\n'): a specification, what follows "glass:" (d=6mm,n=1.52,tn=0.89; clear-6mm;
 *     a data file), parsed against the shipped catalogue ($BSDFSTACK_GLASS_DIR, else the source
 *     tree's layers/glass);
 *   - several lines: a catalogue file, read as pane "fuzz" of a scratch catalogue directory; text
 *     after a line "%%" becomes that directory's data.tsv, which "spectral data.tsv" reads (in
 *     whichever format its first characters say: a table, an Optics file, an IGSDB record).  The
 *     directory links the shipped band spectra and NFRC data tables.
 * Inputs naming dev/, proc/, sys/ or fd/ are skipped: a spec or catalogue may name any file, and
 * reading /dev/zero is not the parser's concern.  Seeds: corpus/glass, dictionary glass.dict. */
#include <config.h>

#include <math.h>
#include <unistd.h>

#include "fuzz.h"

#ifndef FUZZ_GLASS_DIR
#define FUZZ_GLASS_DIR "layers/glass"
#endif

static const char *glass_dir;
static char scratch[64];

static const char *const linked[] = {"solar_ASTM_E891_87_Table1.tsv", "photopic_source_D65.tsv",
                                     "photopic_detector_V.tsv", "photopic_wavelength_set.tsv",
                                     "spectral_NFRC_102.tsv", "spectral_NFRC_103.tsv"};
#define NLINKED (sizeof linked / sizeof linked[0])

static void scratch_path(char *buf, size_t len, const char *name)
{
    snprintf(buf, len, "%s/%s", scratch, name);
}

static void remove_scratch(void)
{
    char p[1200];
    for (size_t i = 0; i < NLINKED; i++) {
        scratch_path(p, sizeof p, linked[i]);
        unlink(p);
    }
    scratch_path(p, sizeof p, "fuzz.glass");
    unlink(p);
    scratch_path(p, sizeof p, "data.tsv");
    unlink(p);
    rmdir(scratch);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    glass_dir = getenv("BSDFSTACK_GLASS_DIR");
    if (!glass_dir || !*glass_dir)
        glass_dir = FUZZ_GLASS_DIR;
    const char *tmp = getenv("TMPDIR");
    snprintf(scratch, sizeof scratch, "%s/bst-fuzz-glass-XXXXXX",
             tmp && *tmp && strlen(tmp) < 32 ? tmp : "/tmp");
    fuzz_require(mkdtemp(scratch), "a scratch catalogue directory");
    char src[1200], dst[1200];
    for (size_t i = 0; i < NLINKED; i++) {
        snprintf(src, sizeof src, "%s/%s", glass_dir, linked[i]);
        if (src[0] != '/') { /* a relative catalogue: link through the absolute path */
            char cwd[1024];
            fuzz_require(getcwd(cwd, sizeof cwd), "the working directory");
            snprintf(src, sizeof src, "%s/%s/%s", cwd, glass_dir, linked[i]);
        }
        scratch_path(dst, sizeof dst, linked[i]);
        fuzz_require(symlink(src, dst) == 0, "a link in the scratch catalogue");
    }
    atexit(remove_scratch);
    return 0;
}

static int write_file(const char *name, const char *text, size_t len)
{
    char p[1200];
    scratch_path(p, sizeof p, name);
    FILE *fp = fopen(p, "wb");
    if (!fp)
        return -1;
    int ok = fwrite(text, 1, len, fp) == len;
    return fclose(fp) == 0 && ok ? 0 : -1;
}

/* T, R in [0, 1] with T + R <= 1 (rounding allowed), as every slab gives. */
static void check_optics(double tf, double tb, double rf, double rb)
{
    const double slack = 1e-9;
    double v[4] = {tf, tb, rf, rb};
    for (int i = 0; i < 4; i++)
        fuzz_require(isfinite(v[i]) && v[i] >= -slack && v[i] <= 1.0 + slack, "T and R in [0, 1]");
    fuzz_require(tf + rf <= 1.0 + slack && tb + rb <= 1.0 + slack, "T + R <= 1");
}

static void exercise(bst_ctx *ctx, bst_glass *g)
{
    size_t nch = bst_glass_nchannels(g);
    fuzz_require(nch >= 1, "a channel");
    fuzz_require(bst_glass_description(g) != NULL, "a description");
    static const double theta[] = {0.0, 0.3, 1.0, 1.5, M_PI / 2};
    for (size_t ch = 0; ch < nch; ch++) {
        const char *name = bst_glass_channel(g, ch);
        fuzz_require(name && bst_glass_find_channel(g, name) == (int)ch, "channels found by name");
        for (size_t i = 0; i < sizeof theta / sizeof theta[0]; i++) {
            double tf, tb, rf, rb;
            fuzz_require(bst_glass_optics(g, ch, theta[i], &tf, &tb, &rf, &rb) == BST_OK, "optics");
            check_optics(tf, tb, rf, rb);
        }
        double n, tau;
        for (int back = 0; back < 2; back++)
            if (bst_glass_slab(g, ch, 0.55, back, &n, &tau) == BST_OK)
                fuzz_require(n >= 1.0 && tau >= 0.0 && tau <= 1.0, "a slab of index >= 1");
    }
    size_t nwl = bst_glass_nwavelengths(g);
    if (nwl) {
        double lo = bst_glass_wavelength(g, 0), hi = bst_glass_wavelength(g, nwl - 1);
        fuzz_require(lo <= hi, "increasing wavelengths");
        double probe[] = {lo - 0.1, lo, 0.5 * (lo + hi), hi, hi + 1.0};
        for (size_t i = 0; i < sizeof probe / sizeof probe[0]; i++) {
            double tf, tb, rf, rb;
            if (bst_glass_optics_spectral(g, probe[i], 0.7, &tf, &tb, &rf, &rb) == BST_OK)
                check_optics(tf, tb, rf, rb);
        }
        int st = bst_glass_add_channel(ctx, g, "CIE-X");
        if (st < 0)
            fuzz_require_error(ctx, st);
    }
    bst_basis *basis = NULL;
    fuzz_require(bst_basis_new_sc(ctx, 1, &basis) == BST_OK, "a basis");
    bst_layer *l = NULL;
    int st = bst_glass_layer(ctx, g, basis, 0, NULL, 1, &l);
    if (st < 0)
        fuzz_require_error(ctx, st);
    else
        fuzz_require(l && bst_layer_nchannels(l) == bst_glass_nchannels(g), "a layer");
    bst_layer_free(l);
    bst_basis_free(basis);
}

static int names_special_file(const char *s, size_t len)
{
    static const char *const bad[] = {"dev/", "proc/", "sys/", "fd/"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        if (memmem(s, len, bad[i], strlen(bad[i])))
            return 1;
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > FUZZ_MAX_INPUT || names_special_file((const char *)data, size))
        return 0;
    char *text = malloc(size + 1);
    fuzz_require(text, "memory for the input");
    memcpy(text, data, size);
    text[size] = '\0';
    bst_ctx *ctx = bst_ctx_new();
    fuzz_require(ctx, "a context");
    bst_glass *g = NULL;
    int st;
    if (!memchr(text, '\n', size)) {
        st = bst_glass_parse(ctx, text, glass_dir, &g);
    } else {
        char *sep = memmem(text, size, "\n%%\n", 4);
        size_t cat = sep ? (size_t)(sep - text) + 1 : size;
        const char *tsv = sep ? sep + 4 : "";
        fuzz_require(write_file("fuzz.glass", text, cat) == 0 &&
                         write_file("data.tsv", tsv, sep ? size - cat - 3 : 0) == 0,
                     "the scratch catalogue written");
        st = bst_glass_parse(ctx, "fuzz", scratch, &g);
    }
    if (st < 0) {
        fuzz_require_error(ctx, st);
        fuzz_require(!g, "no pane on failure");
    } else {
        fuzz_require(g, "a pane");
        exercise(ctx, g);
    }
    bst_glass_free(g);
    bst_ctx_free(ctx);
    free(text);
    return 0;
}
