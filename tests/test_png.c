/* test_png.c - the plot's PNG writer, checked by decoders we did not write: every deflate stream
 * is wrapped as a gzip file and decompressed by gzip(1), which also checks our CRC-32 against its
 * own; the checksums against their published check values; a whole PNG is taken apart chunk by
 * chunk and its pixels recovered through gzip. */
#include <config.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/png.h"
#include "testutil.h"

/* Decompress one raw deflate stream with gzip(1): wraps it with a gzip header and a trailer of
 * the CRC-32 and length of `expect`; returns what gzip printed (malloc'd, *n its length), or NULL
 * when gzip rejected it. */
static unsigned char *gunzip(const unsigned char *def, size_t ndef, const unsigned char *expect,
                             size_t nexpect, size_t *n)
{
    char in[] = "/tmp/bst_png_XXXXXX", out[] = "/tmp/bst_png_out_XXXXXX";
    int fd = mkstemp(in), fo = mkstemp(out);
    ck_assert(fd >= 0 && fo >= 0);
    close(fo);
    FILE *fp = fdopen(fd, "wb");
    static const unsigned char head[10] = {0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3};
    uint32_t crc = cli_crc32_update(0, expect, nexpect), len = (uint32_t)nexpect;
    unsigned char tail[8];
    for (int i = 0; i < 4; i++)
        tail[i] = (unsigned char)(crc >> (8 * i)), tail[4 + i] = (unsigned char)(len >> (8 * i));
    fwrite(head, 1, 10, fp);
    fwrite(def, 1, ndef, fp);
    fwrite(tail, 1, 8, fp);
    ck_assert_int_eq(fclose(fp), 0);
    char cmd[128];
    snprintf(cmd, sizeof cmd, "gzip -dc < %s > %s 2>/dev/null", in, out);
    int rc = system(cmd);
    unsigned char *buf = NULL;
    if (rc == 0) {
        fp = fopen(out, "rb");
        ck_assert_ptr_nonnull(fp);
        buf = malloc(nexpect + 16);
        *n = fread(buf, 1, nexpect + 16, fp);
        fclose(fp);
    }
    unlink(in);
    unlink(out);
    return buf;
}

static void roundtrip(const unsigned char *data, size_t n)
{
    unsigned char *def;
    size_t ndef, got;
    ck_assert_int_eq(cli_deflate_fixed(data, n, &def, &ndef), 0);
    unsigned char *back = gunzip(def, ndef, data, n, &got);
    ck_assert_msg(back != NULL, "gzip rejected the stream of %zu bytes", n);
    ck_assert_uint_eq(got, n);
    ck_assert(n == 0 || memcmp(back, data, n) == 0);
    free(back);
    free(def);
}

START_TEST(test_checksums)
{
    /* the check values of CRC-32 (ISO-HDLC) and Adler-32's worked example (RFC 1950's algorithm) */
    ck_assert_uint_eq(cli_crc32_update(0, (const unsigned char *)"123456789", 9), 0xCBF43926u);
    ck_assert_uint_eq(cli_adler32((const unsigned char *)"Wikipedia", 9), 0x11E60398u);
    ck_assert_uint_eq(cli_adler32(NULL, 0), 1u);
    /* updating in pieces equals one pass */
    uint32_t c = cli_crc32_update(0, (const unsigned char *)"1234", 4);
    ck_assert_uint_eq(cli_crc32_update(c, (const unsigned char *)"56789", 5), 0xCBF43926u);
}
END_TEST

START_TEST(test_deflate_runs)
{
    /* every match length 3..258 and the splits around it, after literals and after matches */
    unsigned char buf[2048] = {0};
    roundtrip(buf, 0);
    buf[0] = 7;
    roundtrip(buf, 1);
    for (size_t len = 1; len <= 600; len += len < 270 ? 1 : 37) {
        size_t n = 0;
        buf[n++] = 200;
        memset(buf + n, 9, len), n += len;
        buf[n++] = 143, buf[n++] = 144, buf[n++] = 255, buf[n++] = 0;
        memset(buf + n, 144, len), n += len;
        roundtrip(buf, n);
    }
}
END_TEST

START_TEST(test_deflate_random)
{
    tu_rng r;
    tu_rng_seed(&r, 11);
    size_t n = 200000;
    unsigned char *buf = malloc(n);
    /* random bytes with random runs: every literal value and many lengths */
    for (size_t i = 0; i < n;) {
        unsigned char v = (unsigned char)(256 * tu_rng_uniform(&r));
        size_t run = tu_rng_uniform(&r) < 0.5 ? 1 : 1 + (size_t)(400 * tu_rng_uniform(&r));
        for (size_t j = 0; j < run && i < n; j++)
            buf[i++] = v;
    }
    roundtrip(buf, n);
    free(buf);
}
END_TEST

static uint32_t get32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

START_TEST(test_png_file)
{
    enum { W = 37, H = 23 };
    unsigned char pix[W * H], pal[5][3] = {{0, 0, 0}, {255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {9, 8, 7}};
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            pix[y * W + x] = (unsigned char)((x / 5 + (y > 10 ? y / 3 : 0)) % 5);
    const char *text[] = {"Title", "Tf \xce\xb8 = 45", NULL};
    struct cli_png img = {W, H, pix, (const unsigned char(*)[3])pal, 5, text};
    char *mem = NULL;
    size_t nmem = 0;
    FILE *fp = open_memstream(&mem, &nmem);
    ck_assert_int_eq(cli_png_write(fp, &img), 0);
    fclose(fp);
    const unsigned char *p = (const unsigned char *)mem, *end = p + nmem;
    ck_assert(memcmp(p, "\x89PNG\r\n\x1a\n", 8) == 0);
    p += 8;
    unsigned char *idat = malloc(nmem);
    size_t nidat = 0;
    int seen_ihdr = 0, seen_plte = 0, seen_text = 0, seen_end = 0;
    while (p + 12 <= end) {
        uint32_t len = get32(p);
        ck_assert(p + 12 + len <= end);
        ck_assert_uint_eq(get32(p + 8 + len), cli_crc32_update(0, p + 4, 4 + len));
        const unsigned char *d = p + 8;
        if (memcmp(p + 4, "IHDR", 4) == 0) {
            ck_assert_int_eq(seen_ihdr++, 0);
            ck_assert_uint_eq(len, 13);
            ck_assert_uint_eq(get32(d), W);
            ck_assert_uint_eq(get32(d + 4), H);
            ck_assert_int_eq(d[8], 8);
            ck_assert_int_eq(d[9], 3);
        } else if (memcmp(p + 4, "PLTE", 4) == 0) {
            seen_plte++;
            ck_assert_uint_eq(len, 15);
            ck_assert(memcmp(d, pal, 15) == 0);
        } else if (memcmp(p + 4, "iTXt", 4) == 0) {
            seen_text++;
            ck_assert(memcmp(d, "Title\0\0\0\0\0Tf \xce\xb8 = 45", len) == 0);
        } else if (memcmp(p + 4, "IDAT", 4) == 0) {
            memcpy(idat + nidat, d, len), nidat += len;
        } else if (memcmp(p + 4, "IEND", 4) == 0) {
            seen_end++;
            ck_assert(p + 12 == end);
        }
        p += 12 + len;
    }
    ck_assert(seen_ihdr && seen_plte && seen_text && seen_end);
    ck_assert_int_eq((idat[0] * 256 + idat[1]) % 31, 0);
    ck_assert_int_eq(idat[0] & 0x0F, 8); /* deflate */
    /* The rows as stored: gzip writes the data out before it checks the trailer, so a first pass
     * with a zeroed trailer reads them; each must un-filter (0 none, 2 up) to the image.  Then the
     * same stream with the true CRC-32 and length must pass gzip's check as a whole. */
    size_t nraw = (size_t)(W + 1) * H, got;
    unsigned char *raw = malloc(nraw), *back;
    {
        char in[] = "/tmp/bst_png_XXXXXX";
        int fd = mkstemp(in);
        FILE *f = fdopen(fd, "wb");
        static const unsigned char head[10] = {0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3};
        fwrite(head, 1, 10, f);
        fwrite(idat + 2, 1, nidat - 6, f);
        fwrite("\0\0\0\0\0\0\0\0", 1, 8, f);
        fclose(f);
        char cmd[96];
        snprintf(cmd, sizeof cmd, "gzip -dc < %s 2>/dev/null", in);
        FILE *pp = popen(cmd, "r");
        got = fread(raw, 1, nraw, pp);
        pclose(pp);
        unlink(in);
        ck_assert_uint_eq(got, nraw);
    }
    for (int y = 0; y < H; y++) {
        unsigned char *row = raw + (size_t)y * (W + 1);
        ck_assert(row[0] == 0 || (row[0] == 2 && y > 0));
        for (int x = 0; x < W; x++) {
            unsigned char above = y ? pix[(y - 1) * W + x] : 0;
            ck_assert_int_eq((unsigned char)(row[1 + x] + (row[0] == 2 ? above : 0)), pix[y * W + x]);
        }
    }
    /* and now with the true CRC and length: gzip must accept the stream as a whole */
    back = gunzip(idat + 2, nidat - 6, raw, nraw, &got);
    ck_assert_ptr_nonnull(back);
    ck_assert_uint_eq(got, nraw);
    ck_assert_uint_eq(get32(idat + nidat - 4), cli_adler32(raw, nraw));
    free(back);
    free(raw);
    free(idat);
    free(mem);
}
END_TEST

int main(void)
{
    Suite *s = suite_create("png");
    TCase *tc = tcase_create("png");
    tcase_set_timeout(tc, 60);
    tcase_add_test(tc, test_checksums);
    tcase_add_test(tc, test_deflate_runs);
    tcase_add_test(tc, test_deflate_random);
    tcase_add_test(tc, test_png_file);
    suite_add_tcase(s, tc);
    return tu_run(s);
}
