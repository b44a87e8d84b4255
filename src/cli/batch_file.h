/* batch_file.h - the text of a `bsdfstack batch` file: one stack a line, "OUT LAYER LAYER...",
 * words separated by blanks, '#' lines and blank lines skipped.  Parsing is kept apart from
 * running the stacks (cmd_batch.c) so that it can be tested and fuzzed alone (tests/fuzz). */
#ifndef BST_CLI_BATCH_FILE_H
#define BST_CLI_BATCH_FILE_H

#include <stddef.h>
#include <stdio.h>

struct batch_line {
    size_t lineno; /* 1-based line of the file */
    char *out;     /* the output file */
    size_t n;      /* number of layers */
    size_t *layer; /* indices into batch_file.specs, exterior first */
};

/* A parsed file: its stack lines, and every distinct layer spec once (in order of appearance). */
struct batch_file {
    struct batch_line *lines;
    size_t nlines;
    char **specs;
    size_t nspecs;
};

/* Read the stack lines of fp (named path in messages) into bf.  0 on success; -1 with one line
 * of text (no program name, no newline) in *err, to free: a line without layers, an output
 * written twice, a NUL byte, no stacks at all, a read error, out of memory (*err NULL when even the message
 * could not be allocated).  bf holds whatever was read either way; release it with
 * batch_file_free. */
int batch_file_parse(FILE *fp, const char *path, struct batch_file *bf, char **err);
/* For each distinct layer spec i, "PATH:LINE" of the first line naming it (the place its
 * messages name: cli_basis_choice.where), as an array of bf->nspecs strings in one allocation
 * (free() it); NULL when out of memory. */
char **batch_file_places(const struct batch_file *bf, const char *path);
/* Release what batch_file_parse allocated; bf may be zeroed or NULL. */
void batch_file_free(struct batch_file *bf);

#endif
