/* fuzz_xml.c - libFuzzer target: the BSDF XML reader (xml.c, with ttree.c for tensor trees and
 * basis.c for Klems bases defined in the file) on any bytes, then what a caller does with what
 * it read: evaluation (bst_bsdf_eval) and, for small files, the layer over the file's own basis
 * and over a small other one (resample.c).
 *
 * The reader takes a path, so the input is written to a memory file (memfd) and read through
 * /proc/self/fd.  The reader's options vary with the input's length (size % 4): defaults, two
 * components only, two named channels, single precision.  Seeds: corpus/xml, dictionary xml.dict. */
#include <config.h>

#include <math.h>
#include <sys/mman.h>
#include <unistd.h>

#include "fuzz.h"

/* Layers are made for Klems files of at most this many patches and trees of at most this
 * order: enough for every code path, cheap enough to keep the fuzzer fast. */
#define FUZZ_LAYER_MAX_PATCHES 160
#define FUZZ_LAYER_MAX_ORDER 3

static int write_all(int fd, const uint8_t *data, size_t size)
{
    while (size) {
        ssize_t n = write(fd, data, size);
        if (n <= 0)
            return -1;
        data += n, size -= (size_t)n;
    }
    return 0;
}

/* Directions (unit vectors, file frame) in both hemispheres: normal, oblique, grazing, and the
 * patch boundaries of a Klems basis at 5 and 15 degrees. */
static void direction(int i, double v[3])
{
    static const double theta_deg[] = {0.0, 5.0, 15.0, 47.0, 89.9};
    static const double phi_deg[] = {0.0, 90.0, 200.0};
    double t = theta_deg[i % 5] * M_PI / 180.0, p = phi_deg[(i / 5) % 3] * M_PI / 180.0;
    double z = (i / 15) % 2 ? cos(t) : -cos(t);
    v[0] = sin(t) * cos(p), v[1] = sin(t) * sin(p), v[2] = z;
}

static void check_layer(bst_ctx *ctx, const bst_bsdf *b, const bst_basis *target)
{
    bst_layer *l = NULL;
    int st = bst_bsdf_to_layer(ctx, b, target, &l);
    if (st < 0) {
        fuzz_require_error(ctx, st);
        fuzz_require(!l, "no layer on failure");
        return;
    }
    fuzz_require(l, "a layer");
    fuzz_require(bst_layer_nchannels(l) == bst_bsdf_nchannels(b), "a layer of every channel");
    bst_layer_free(l);
}

static void exercise(bst_ctx *ctx, const bst_bsdf *b)
{
    bst_file_kind kind = bst_bsdf_kind(b);
    fuzz_require(kind == BST_FILE_KLEMS || kind == BST_FILE_TT3 || kind == BST_FILE_TT4, "a kind");
    const bst_basis *klems = bst_bsdf_klems_basis(b);
    fuzz_require((kind == BST_FILE_KLEMS) == (klems != NULL), "a Klems basis for Klems files");
    int order = bst_bsdf_order(b);
    fuzz_require(kind == BST_FILE_KLEMS ? order == 0 : order >= 1, "an order for trees");
    size_t nch = bst_bsdf_nchannels(b);
    fuzz_require(nch >= 1, "a channel");
    for (size_t ch = 0; ch < nch; ch++) {
        fuzz_require(bst_bsdf_channel(b, ch) != NULL, "a channel name");
        for (int i = 0; i < 30; i++)
            for (int o = 0; o < 30; o += 7) {
                double in[3], out[3], v = -1.0;
                direction(i, in);
                direction(o, out);
                int st = bst_bsdf_eval(ctx, b, ch, in, out, &v);
                fuzz_require(st == BST_OK, "evaluation at a valid direction pair");
                fuzz_require(isfinite(v) && v >= 0.0, "a finite non-negative BSDF value");
            }
    }
    fuzz_require(bst_bsdf_channel(b, nch) == NULL, "no channel past the last");
    /* layers: the file's own basis, then a small other one (tree -> Klems, Klems -> tree) */
    size_t n = klems ? bst_basis_size(klems) : 0;
    if (kind == BST_FILE_KLEMS ? n <= FUZZ_LAYER_MAX_PATCHES : order <= FUZZ_LAYER_MAX_ORDER) {
        check_layer(ctx, b, NULL);
        bst_basis *other = NULL;
        int st = kind == BST_FILE_KLEMS ? bst_basis_new_sc(ctx, 1, &other)
                                        : bst_basis_new_klems(ctx, "quarter", &other);
        fuzz_require(st == BST_OK, "a small basis");
        check_layer(ctx, b, other);
        bst_basis_free(other);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > FUZZ_MAX_INPUT)
        return 0;
    int fd = memfd_create("fuzz_xml", MFD_CLOEXEC);
    fuzz_require(fd >= 0, "a memory file (memfd_create)");
    fuzz_require(write_all(fd, data, size) == 0, "the input written to the memory file");
    char path[64];
    snprintf(path, sizeof path, "/proc/self/fd/%d", fd);

    static const char *const channels[] = {"Visible", "Solar"};
    bst_bsdf_read_opts opts = {0};
    switch (size % 4) {
    case 1: opts.comps = BST_COMP_BIT(BST_TF) | BST_COMP_BIT(BST_RB); break;
    case 2: opts.nchannels = 2, opts.channels = channels; break;
    case 3: opts.precision = BST_FLOAT; break;
    default: break;
    }
    bst_ctx *ctx = bst_ctx_new();
    fuzz_require(ctx, "a context");
    bst_bsdf *b = NULL;
    int st = bst_bsdf_read(ctx, path, size % 4 ? &opts : NULL, &b);
    if (st < 0) {
        fuzz_require_error(ctx, st);
        fuzz_require(!b, "no result on failure");
    } else {
        fuzz_require(b, "a result");
        exercise(ctx, b);
    }
    bst_bsdf_free(b);
    bst_ctx_free(ctx);
    close(fd);
    return 0;
}
