/* png.c - a small PNG writer for `bsdfstack plot`: 8-bit palette images, compressed by deflate
 * with its fixed Huffman codes and run-length matches (distance 1).  Plots are flat colours in
 * cells, so runs are what there is to compress; no zlib is needed.
 *
 * Formats: PNG (ISO/IEC 15948) chunks are length, type, data, CRC-32 of type and data, big-endian;
 * the image data is a zlib stream (RFC 1950: 2-byte header, deflate data, Adler-32 big-endian) of
 * the rows, each led by its filter byte; deflate (RFC 1951) packs fields from the least
 * significant bit, Huffman codes from their most significant bit. */
#include <config.h>

#include <stdlib.h>
#include <string.h>

#include "png.h"

uint32_t cli_crc32_update(uint32_t crc, const unsigned char *p, size_t n)
{
    crc = ~crc;
    for (size_t i = 0; i < n; i++) {
        crc ^= p[i];
        for (int b = 0; b < 8; b++)
            crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

uint32_t cli_adler32(const unsigned char *p, size_t n)
{
    uint32_t a = 1, b = 0;
    for (size_t i = 0; i < n; i++) {
        a = (a + p[i]) % 65521u;
        b = (b + a) % 65521u;
    }
    return b << 16 | a;
}

/* A growing byte buffer with a bit accumulator for deflate. */
struct bits {
    unsigned char *buf;
    size_t len, cap;
    uint32_t acc;
    int nacc;
    int failed;
};

static void put_byte(struct bits *s, unsigned char c)
{
    if (s->failed)
        return;
    if (s->len == s->cap) {
        size_t cap = s->cap ? 2 * s->cap : 4096;
        unsigned char *nb = realloc(s->buf, cap);
        if (!nb) {
            s->failed = 1;
            return;
        }
        s->buf = nb, s->cap = cap;
    }
    s->buf[s->len++] = c;
}

/* n <= 16 bits of v, least significant first */
static void put_bits(struct bits *s, uint32_t v, int n)
{
    s->acc |= v << s->nacc;
    s->nacc += n;
    while (s->nacc >= 8) {
        put_byte(s, (unsigned char)(s->acc & 0xFF));
        s->acc >>= 8;
        s->nacc -= 8;
    }
}

/* a Huffman code of n bits, most significant bit first */
static void put_code(struct bits *s, uint32_t code, int n)
{
    uint32_t r = 0;
    for (int i = 0; i < n; i++)
        r |= ((code >> i) & 1u) << (n - 1 - i);
    put_bits(s, r, n);
}

/* the fixed literal/length code (RFC 1951 3.2.6) */
static void put_symbol(struct bits *s, int sym)
{
    if (sym < 144)
        put_code(s, 0x30u + (uint32_t)sym, 8);
    else if (sym < 256)
        put_code(s, 0x190u + (uint32_t)(sym - 144), 9);
    else if (sym < 280)
        put_code(s, (uint32_t)(sym - 256), 7);
    else
        put_code(s, 0xC0u + (uint32_t)(sym - 280), 8);
}

/* a match of len (3..258) bytes at distance 1 */
static void put_match(struct bits *s, int len)
{
    static const int base[29] = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                                 31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
    static const int extra[29] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                                  2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
    int i = 28;
    while (base[i] > len)
        i--;
    put_symbol(s, 257 + i);
    if (extra[i])
        put_bits(s, (uint32_t)(len - base[i]), extra[i]);
    put_code(s, 0, 5); /* distance code 0: distance 1, no extra bits */
}

int cli_deflate_fixed(const unsigned char *data, size_t n, unsigned char **out, size_t *outlen)
{
    struct bits s = {0};
    put_bits(&s, 1, 1); /* BFINAL: the only block */
    put_bits(&s, 1, 2); /* BTYPE 01: fixed Huffman codes */
    size_t i = 0;
    while (i < n) {
        size_t run = 0;
        if (i > 0)
            while (run < 258 && i + run < n && data[i + run] == data[i - 1])
                run++;
        if (run >= 3) {
            put_match(&s, (int)run);
            i += run;
        } else {
            put_symbol(&s, data[i]);
            i++;
        }
    }
    put_symbol(&s, 256); /* end of block */
    if (s.nacc)
        put_bits(&s, 0, 8 - s.nacc);
    if (s.failed) {
        free(s.buf);
        return -1;
    }
    *out = s.buf;
    *outlen = s.len;
    return 0;
}

static void be32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v >> 24), p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8), p[3] = (unsigned char)v;
}

static int chunk(FILE *fp, const char *type, const unsigned char *data, size_t n)
{
    unsigned char head[8], tail[4];
    be32(head, (uint32_t)n);
    memcpy(head + 4, type, 4);
    uint32_t crc = cli_crc32_update(0, head + 4, 4);
    crc = cli_crc32_update(crc, data, n);
    be32(tail, crc);
    return fwrite(head, 1, 8, fp) == 8 && (n == 0 || fwrite(data, 1, n, fp) == n) &&
                   fwrite(tail, 1, 4, fp) == 4 ? 0 : -1;
}

/* Sum of run breaks: the fewer, the longer the runs deflate finds. */
static size_t breaks(const unsigned char *row, size_t n)
{
    size_t b = 0;
    for (size_t i = 1; i < n; i++)
        b += row[i] != row[i - 1];
    return b;
}

int cli_png_write(FILE *fp, const struct cli_png *img)
{
    size_t w = img->width, h = img->height, stride = w + 1;
    if (w == 0 || h == 0 || img->npalette < 1 || img->npalette > 256)
        return -1;
    unsigned char *raw = malloc(stride * h), *up = malloc(w);
    if (!raw || !up) {
        free(raw), free(up);
        return -1;
    }
    /* per row the filter (0 none, 2 up) whose bytes break into fewer runs */
    for (size_t y = 0; y < h; y++) {
        const unsigned char *row = img->pixels + y * w, *prev = y ? row - w : NULL;
        unsigned char *dst = raw + y * stride;
        for (size_t x = 0; x < w; x++)
            up[x] = (unsigned char)(row[x] - (prev ? prev[x] : 0));
        int use_up = prev && breaks(up, w) < breaks(row, w);
        dst[0] = use_up ? 2 : 0;
        memcpy(dst + 1, use_up ? up : row, w);
    }
    free(up);
    unsigned char *def = NULL;
    size_t ndef = 0;
    int rc = cli_deflate_fixed(raw, stride * h, &def, &ndef);
    uint32_t adler = cli_adler32(raw, stride * h);
    free(raw);
    if (rc != 0)
        return -1;
    unsigned char *z = malloc(ndef + 6);
    if (!z) {
        free(def);
        return -1;
    }
    z[0] = 0x78, z[1] = 0x01; /* deflate, 32 KiB window, check bits: 0x7801 % 31 == 0 */
    memcpy(z + 2, def, ndef);
    be32(z + 2 + ndef, adler);
    free(def);

    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    unsigned char ihdr[13];
    be32(ihdr, (uint32_t)w), be32(ihdr + 4, (uint32_t)h);
    ihdr[8] = 8, ihdr[9] = 3, ihdr[10] = 0, ihdr[11] = 0, ihdr[12] = 0; /* 8-bit palette */
    int ok = fwrite(sig, 1, 8, fp) == 8 && chunk(fp, "IHDR", ihdr, 13) == 0 &&
             chunk(fp, "PLTE", &img->palette[0][0], 3 * (size_t)img->npalette) == 0;
    /* text as iTXt (UTF-8): keyword, 0, compression flag 0, method 0, empty language and
     * translated keyword, text */
    for (size_t t = 0; ok && img->text && img->text[t]; t += 2) {
        size_t nk = strlen(img->text[t]), nv = strlen(img->text[t + 1]);
        unsigned char *c = malloc(nk + nv + 5);
        if (!c) {
            ok = 0;
            break;
        }
        memcpy(c, img->text[t], nk);
        memset(c + nk, 0, 5);
        memcpy(c + nk + 5, img->text[t + 1], nv);
        ok = chunk(fp, "iTXt", c, nk + nv + 5) == 0;
        free(c);
    }
    ok = ok && chunk(fp, "IDAT", z, ndef + 6) == 0 && chunk(fp, "IEND", NULL, 0) == 0;
    free(z);
    return ok ? 0 : -1;
}
