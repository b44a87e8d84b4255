/* fuzz.h - shared by the libFuzzer targets in tests/fuzz (fuzz_*.c) and by replay.c, which runs a
 * target over its seed corpus and its regression inputs in `make check`.
 *
 * A target takes any bytes, never trusts them, frees everything it made whatever the outcome, and
 * checks the contracts every caller relies on: a failing call returns a negative status with a
 * one-line message and no result; a successful one returns a usable result.  A broken contract
 * stops the run with a message (fuzz_require), which libFuzzer reports as a crash. */
#ifndef BST_FUZZ_H
#define BST_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bsdfstack.h"

/* Inputs longer than this are ignored (1 MB; fuzz runs use -max_len=100000). */
#define FUZZ_MAX_INPUT ((size_t)1 << 20)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerInitialize(int *argc, char ***argv);

#define fuzz_require(cond, what)                                                                   \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            fprintf(stderr, "%s:%d: broken contract: %s\n", __FILE__, __LINE__, (what));           \
            abort();                                                                               \
        }                                                                                          \
    } while (0)

/* The contract of a failed library call: status < 0 and ctx holding one non-empty line (the
 * program prints it as its one error line).  BST_FUZZ_MULTILINE=1 in the environment lets
 * messages of several lines pass, to fuzz on past a known one. */
static inline void fuzz_require_error(const bst_ctx *ctx, int status)
{
    const char *msg = bst_ctx_message(ctx), *lax = getenv("BST_FUZZ_MULTILINE");
    fuzz_require(status < 0, "an error status");
    fuzz_require(msg && msg[0], "an error message");
    if (!(lax && strcmp(lax, "1") == 0) && strchr(msg, '\n')) {
        fprintf(stderr, "message: %s\n", msg);
        fuzz_require(0, "an error message of one line");
    }
}

#endif
