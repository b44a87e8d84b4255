/* testglass.h - helpers of the glass file-format suites (test_glass_optics, test_glass_json): the
 * NFRC 102 reference data as text, a scratch directory, panes and stacks compared with the same
 * data read from bsdfstack's own table, and refused files. */
#ifndef BST_TESTGLASS_H
#define BST_TESTGLASS_H

#include <check.h>
#include <stddef.h>
#include <stdio.h>
#include "bsdfstack.h"

/* NFRC 102's rows from ../shared/reference/wce/data/spectral_NFRC_102.tsv, each value as the text
 * the file has (so that a file written from them holds the very same numbers). */
struct tg_rows {
    size_t n;
    char (*v)[5][24]; /* wavelength (um), Tf, Tb, Rf, Rb */
};
void tg_rows_read(struct tg_rows *r);
void tg_rows_free(struct tg_rows *r);

/* The file-format suites' fixture: a context, NFRC 102's rows and a scratch directory. */
extern bst_ctx *tg_ctx;
extern struct tg_rows tg_nfrc102;
void tg_setup(void);
void tg_teardown(void);

/* A fresh scratch directory (removed by tg_scratch_remove), the path of a file in it (a buffer
 * the next call reuses), and a new file there opened for writing (*path: tg_path's). */
const char *tg_scratch(void);
void tg_scratch_remove(void);
const char *tg_path(const char *name);
const char *tg_dir(void);
FILE *tg_create(const char *name, const char **path);

/* The pane of a spec; fails the test on error. */
bst_glass *tg_parse(bst_ctx *ctx, const char *spec);
/* a and b give the same Tf, Tb, Rf, Rb to the bit in every channel at 0..90 degrees, per
 * wavelength too, and have the same data. */
void tg_same_pane(const bst_glass *a, const bst_glass *b);
/* a and b, each in front of NFRC 103, give the same system to the bit: a two-pane stack combined
 * per wavelength (Klems quarter, WCE's patch centres, Solar and Visible). */
void tg_same_stack(bst_ctx *ctx, bst_glass *a, bst_glass *b);
/* spec is refused with one line that holds expect; nothing is returned. */
void tg_refused(bst_ctx *ctx, const char *spec, const char *expect);

/* step(c, arg) with a context whose n-th allocation fails, n = 1, 2, ... until it succeeds (at
 * most max tries): every run ends in BST_OK or BST_ENOMEM and leaks nothing; step frees what it
 * made.  what names the case in messages. */
void tg_alloc_sweep(const char *what, long max, int (*step)(bst_ctx *c, void *arg), void *arg);

/* A tg_alloc_sweep step: the pane of the spec (a char *) read and freed. */
int tg_read_pane(bst_ctx *c, void *spec);

/* A suite of one test case with a fixture and a timeout (seconds). */
Suite *tg_suite(const char *name, void (*setup)(void), void (*teardown)(void), int timeout,
                const TTest *const *tests, size_t n);

#endif
