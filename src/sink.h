/* sink.h - a small buffered text output used by the writers (tensor trees, XML): bytes go to a
 * callback in chunks of at most BSTI_SINK_BUF (a piece at least that long is passed on as it is, after
 * what is buffered), so the sink itself holds nothing larger than that buffer.
 * The first failure of the callback is remembered; later writes are dropped and the writer
 * checks bsti_sink_failed() to stop early. */
#ifndef BST_SINK_H
#define BST_SINK_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "bsdfstack.h"

#define BSTI_SINK_BUF 65536

typedef struct bsti_sink {
    bst_bsdf_write_sink fn;    /* returns 0 on success */
    void *opaque;
    char buf[BSTI_SINK_BUF];
    size_t n;           /* bytes waiting in buf */
    uint64_t total;     /* bytes accepted so far */
    int failed;
    int err;            /* errno after the failed write (0 if unknown) */
} bsti_sink;

void bsti_sink_init(bsti_sink *s, bst_bsdf_write_sink fn, void *opaque);
void bsti_sink_put(bsti_sink *s, const char *text, size_t len);
void bsti_sink_puts(bsti_sink *s, const char *text);
void bsti_sink_printf(bsti_sink *s, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* Pass everything buffered to the callback; returns 0, or -1 when any write failed. */
int bsti_sink_flush(bsti_sink *s);
static inline int bsti_sink_failed(const bsti_sink *s) { return s->failed; }

/* The callback for a stdio stream (opaque = FILE *). */
int bsti_sink_file(const char *buf, size_t len, void *opaque);

/* XML text (the writer's, xml_write.c).  Names, paths and command lines arrive as bytes while the
 * file declares UTF-8: a byte that starts no character XML 1.0 allows is written as U+FFFD,
 * control characters other than tab and newline as a space. */
/* Text content or an attribute value, the XML specials escaped. */
void bsti_sink_xml_text(bsti_sink *s, const char *text);
/* Text inside an XML comment: "--" may not occur there, so a space goes between two '-', and a
 * comment may not end in '-'; a newline starts a new line indented by `indent`. */
void bsti_sink_xml_comment(bsti_sink *s, const char *text, const char *indent);
/* indent, then <name>text</name> and a newline. */
void bsti_sink_xml_element(bsti_sink *s, const char *indent, const char *name, const char *text);

#endif
