/* fuzz_batch.c - libFuzzer target: the parser of `bsdfstack batch` files (src/cli/batch_file.c)
 * on any bytes, read through a memory stream as the program reads its file.
 *
 * Checked: a parsed file has stack lines, each with an output file and layers whose indices name
 * distinct specs, no output twice, increasing line numbers, and each spec the place "fuzz.txt:N"
 * of a line naming it (batch_file_places); a failure has one line of text.
 * Seeds: corpus/batch. */
#include <config.h>

#include "batch_file.h"
#include "fuzz.h"

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static void check_file(const struct batch_file *bf)
{
    fuzz_require(bf->nlines >= 1, "a stack line");
    char **outs = malloc(bf->nlines * sizeof *outs);
    fuzz_require(outs, "memory for the check");
    for (size_t i = 0; i < bf->nlines; i++) {
        const struct batch_line *l = &bf->lines[i];
        fuzz_require(l->out && l->out[0] && l->out[0] != '#', "an output file");
        fuzz_require(i == 0 || l->lineno > bf->lines[i - 1].lineno, "increasing line numbers");
        fuzz_require(l->n >= 1, "layers on every line");
        for (size_t j = 0; j < l->n; j++)
            fuzz_require(l->layer[j] < bf->nspecs, "layer indices in range");
        outs[i] = l->out;
    }
    qsort(outs, bf->nlines, sizeof *outs, by_name);
    for (size_t i = 1; i < bf->nlines; i++)
        fuzz_require(strcmp(outs[i - 1], outs[i]) != 0, "no output written twice");
    free(outs);
    char **specs = malloc(bf->nspecs * sizeof *specs);
    fuzz_require(specs, "memory for the check");
    memcpy(specs, bf->specs, bf->nspecs * sizeof *specs);
    qsort(specs, bf->nspecs, sizeof *specs, by_name);
    for (size_t i = 1; i < bf->nspecs; i++)
        fuzz_require(strcmp(specs[i - 1], specs[i]) != 0, "distinct layer specs");
    free(specs);
    char **places = batch_file_places(bf, "fuzz.txt");
    fuzz_require(places, "the layers' places");
    for (size_t i = 0; i < bf->lines[0].n; i++) { /* the first line's layers are its own */
        char want[48];
        snprintf(want, sizeof want, "fuzz.txt:%zu", bf->lines[0].lineno);
        fuzz_require(strcmp(places[bf->lines[0].layer[i]], want) == 0, "a layer's first line");
    }
    for (size_t i = 0; i < bf->nspecs; i++)
        fuzz_require(strncmp(places[i], "fuzz.txt:", 9) == 0, "a place for every layer");
    free(places);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > FUZZ_MAX_INPUT)
        return 0;
    /* fmemopen wants a buffer of its own, and a size of at least 1 */
    char *copy = malloc(size + 1);
    fuzz_require(copy, "memory for the input");
    memcpy(copy, data, size);
    copy[size] = '\0';
    FILE *fp = fmemopen(copy, size ? size : 1, "r");
    fuzz_require(fp, "a memory stream");
    struct batch_file bf;
    char *err = NULL;
    if (batch_file_parse(fp, "fuzz.txt", &bf, &err) == 0) {
        fuzz_require(!err, "no message on success");
        check_file(&bf);
    } else {
        fuzz_require(err && err[0], "an error message");
        fuzz_require(!strchr(err, '\n'), "an error message of one line");
    }
    free(err);
    batch_file_free(&bf);
    fclose(fp);
    free(copy);
    return 0;
}
