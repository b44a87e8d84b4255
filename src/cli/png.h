/* png.h - a small PNG writer (8-bit palette images) for `bsdfstack plot`. */
#ifndef BST_CLI_PNG_H
#define BST_CLI_PNG_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

struct cli_png {
    size_t width, height;
    const unsigned char *pixels;         /* width x height palette indices, rows top down */
    const unsigned char (*palette)[3];   /* RGB */
    int npalette;                        /* 1..256 */
    const char *const *text;             /* UTF-8 keyword, value pairs, NULL-terminated, or NULL */
};

/* Write img as PNG to fp.  0, or -1 on a write error or out of memory. */
int cli_png_write(FILE *fp, const struct cli_png *img);

/* The pieces, for tests: one final deflate block of data with the fixed Huffman codes (*out is
 * malloc'd; 0 or -1 when out of memory), and the checksums PNG, gzip and zlib use. */
int cli_deflate_fixed(const unsigned char *data, size_t n, unsigned char **out, size_t *outlen);
uint32_t cli_crc32_update(uint32_t crc, const unsigned char *p, size_t n);
uint32_t cli_adler32(const unsigned char *p, size_t n);

#endif
