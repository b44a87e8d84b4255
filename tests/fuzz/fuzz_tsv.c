/* fuzz_tsv.c - libFuzzer target: the two readers of the table `combine --incident` writes, on any
 * bytes: compare's whole-file reader (src/cli/incident_tsv.c, with the layer it makes of the
 * columns) and plot's one-column reader (src/cli/incident_table.c).  The input is written to a
 * memory file (memfd) and read through /proc/self/fd, as the program reads a path.
 *
 * Checked: a table read has columns over a basis of n patches, each with a channel, a component
 * and an incident patch in range, and gives a layer over that basis; a column read has a basis
 * and its values; a failure (one line on stderr, as the program prints it) leaves nothing to free
 * (cli_tsv_read once freed its file twice on failure: SIGABRT).  Seeds: corpus/tsv. */
#include <config.h>

#include <math.h>
#include <sys/mman.h>
#include <unistd.h>

#include "cli.h"
#include "fuzz.h"
#include "incident_table.h"
#include "incident_tsv.h"

static void check_table(bst_ctx *ctx, const struct cli_tsv *t)
{
    fuzz_require(t->basis && t->n == bst_basis_size(t->basis), "a basis of n patches");
    fuzz_require(t->ncols >= 1 && t->cols, "columns");
    for (size_t q = 0; q < t->ncols; q++) {
        const struct cli_tsv_col *c = &t->cols[q];
        fuzz_require(c->channel && (unsigned)c->comp < BST_NCOMP, "a channel and a component");
        fuzz_require(c->patch_in < t->n && c->bsdf, "an incident patch in range, and values");
    }
    bst_layer *l = NULL;
    if (cli_tsv_layer("fuzz", ctx, t, t->cols[0].channel, &l) == CLI_OK) {
        fuzz_require(l && bst_layer_nchannels(l) == 1, "a layer of one channel");
        bst_layer_free(l);
    } else {
        fuzz_require(!l, "no layer on failure");
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > FUZZ_MAX_INPUT)
        return 0;
    int fd = memfd_create("fuzz_tsv", MFD_CLOEXEC);
    fuzz_require(fd >= 0, "a memory file (memfd_create)");
    for (size_t done = 0; done < size;) {
        ssize_t n = write(fd, data + done, size - done);
        fuzz_require(n > 0, "the input written to the memory file");
        done += (size_t)n;
    }
    char path[64];
    snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
    bst_ctx *ctx = bst_ctx_new();
    fuzz_require(ctx, "a context");

    struct cli_tsv t;
    if (cli_tsv_read("fuzz", ctx, path, &t) == CLI_OK)
        check_table(ctx, &t);
    else
        fuzz_require(!t.cols && !t.basis && t.ncols == 0, "nothing held after a failure");
    cli_tsv_free(&t);

    /* plot's reader: the first column, and the Tf column at normal incidence of channel Visible */
    static const double normal[2] = {0.0, 0.0};
    for (int pass = 0; pass < 2; pass++) {
        struct cli_incident_column col;
        if (cli_incident_column_read("fuzz", path, pass ? "Visible" : NULL, BST_TF,
                                     pass ? normal : NULL, &col) == CLI_OK) {
            fuzz_require(col.basis && col.bsdf, "a column over a basis");
            for (size_t i = 0; i < bst_basis_size(col.basis); i++)
                fuzz_require(!isnan(col.bsdf[i]), "values that are numbers");
        }
        cli_incident_column_free(&col);
    }
    bst_ctx_free(ctx);
    close(fd);
    return 0;
}
