/* sink.c - the buffered text output of the writers (sink.h), and XML-safe text into it. */
#include <config.h>

#include <errno.h>
#include <stdarg.h>
#include <string.h>

#include "sink.h"

void bsti_sink_init(bsti_sink *s, bst_bsdf_write_sink fn, void *opaque)
{
    s->fn = fn;
    s->opaque = opaque;
    s->n = 0;
    s->total = 0;
    s->failed = 0;
    s->err = 0;
}

int bsti_sink_flush(bsti_sink *s)
{
    if (!s->failed && s->n) {
        errno = 0;
        if (s->fn(s->buf, s->n, s->opaque) != 0) {
            s->failed = 1;
            s->err = errno;
        }
    }
    s->n = 0;
    return s->failed ? -1 : 0;
}

void bsti_sink_put(bsti_sink *s, const char *text, size_t len)
{
    if (s->failed)
        return;
    s->total += len;
    if (len >= BSTI_SINK_BUF) { /* a large piece (a tree's text made ahead) goes as it is */
        if (bsti_sink_flush(s) != 0)
            return;
        errno = 0;
        if (s->fn(text, len, s->opaque) != 0) {
            s->failed = 1;
            s->err = errno;
        }
        return;
    }
    while (len) {
        size_t room = BSTI_SINK_BUF - s->n, k = len < room ? len : room;
        memcpy(s->buf + s->n, text, k);
        s->n += k;
        text += k;
        len -= k;
        if (s->n == BSTI_SINK_BUF && bsti_sink_flush(s) != 0)
            return;
    }
}

void bsti_sink_puts(bsti_sink *s, const char *text)
{
    bsti_sink_put(s, text, strlen(text));
}

void bsti_sink_printf(bsti_sink *s, const char *fmt, ...)
{
    char line[1024];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof line)
        s->failed = 1; /* only short formatted pieces go through here; user text uses put */
    else
        bsti_sink_put(s, line, (size_t)n);
}

int bsti_sink_file(const char *buf, size_t len, void *opaque)
{
    FILE *fp = opaque;
    return fwrite(buf, 1, len, fp) == len ? 0 : -1;
}

/* ------------------------------------------------------------------ XML text */

/* Text reaches the file from names and paths the system hands over as bytes (file names, -o,
 * --name, a command line), while the file declares UTF-8: a byte sequence that is not the UTF-8 of
 * an XML 1.0 character would leave a file no parser reads back.  Each byte of such a sequence is
 * written as U+FFFD, the replacement character; control characters other than tab and newline,
 * which XML 1.0 does not allow either, as a space. */
#define XML_REPLACEMENT "\xEF\xBF\xBD"

/* Bytes of the UTF-8 sequence at p that encodes one character XML 1.0 allows (#x9, #xA, #xD,
 * #x20-#xD7FF, #xE000-#xFFFD, #x10000-#x10FFFF), in its shortest form; 0 when it is not one. */
static size_t xml_char_len(const char *text)
{
    const unsigned char *p = (const unsigned char *)text;
    size_t n;
    unsigned long cp, least;
    if (p[0] < 0x80)
        return p[0] >= 0x20 || p[0] == '\t' || p[0] == '\n' || p[0] == '\r';
    if ((p[0] & 0xE0) == 0xC0)
        n = 2, cp = p[0] & 0x1Fu, least = 0x80;
    else if ((p[0] & 0xF0) == 0xE0)
        n = 3, cp = p[0] & 0x0Fu, least = 0x800;
    else if ((p[0] & 0xF8) == 0xF0)
        n = 4, cp = p[0] & 0x07u, least = 0x10000;
    else
        return 0; /* a continuation byte, or a lead byte no UTF-8 has */
    for (size_t i = 1; i < n; i++) {
        if ((p[i] & 0xC0) != 0x80) /* also stops at the terminating NUL */
            return 0;
        cp = cp << 6 | (p[i] & 0x3Fu);
    }
    if (cp < least || (cp >= 0xD800 && cp <= 0xDFFF) || cp == 0xFFFE || cp == 0xFFFF || cp > 0x10FFFF)
        return 0; /* overlong, a surrogate, a non-character XML excludes, beyond Unicode */
    return n;
}

/* The character at *p as the file may hold it: its bytes, a space for a control character, or
 * U+FFFD for a byte that starts no valid character; *p moves past what was taken. */
static void put_char(bsti_sink *s, const char **p)
{
    size_t n = xml_char_len(*p);
    if (n) {
        bsti_sink_put(s, *p, n);
        *p += n;
        return;
    }
    bsti_sink_puts(s, (unsigned char)**p < 0x80 ? " " : XML_REPLACEMENT);
    (*p)++;
}

void bsti_sink_xml_text(bsti_sink *s, const char *text)
{
    for (const char *p = text; *p;) {
        switch (*p) {
        case '&': bsti_sink_puts(s, "&amp;"), p++; break;
        case '<': bsti_sink_puts(s, "&lt;"), p++; break;
        case '>': bsti_sink_puts(s, "&gt;"), p++; break;
        case '"': bsti_sink_puts(s, "&quot;"), p++; break;
        case '\r': bsti_sink_put(s, " ", 1), p++; break; /* a reader would make it a newline */
        default: put_char(s, &p);
        }
    }
}

void bsti_sink_xml_comment(bsti_sink *s, const char *text, const char *indent)
{
    char prev = 0;
    for (const char *p = text; *p;) {
        if (*p == '\n') {
            if (prev == '-')
                bsti_sink_put(s, " ", 1);
            bsti_sink_put(s, "\n", 1);
            bsti_sink_puts(s, indent);
            prev = 0;
            p++;
            continue;
        }
        if (*p == '-' && prev == '-')
            bsti_sink_put(s, " ", 1);
        prev = *p;
        if (*p == '\r')
            bsti_sink_put(s, " ", 1), p++;
        else
            put_char(s, &p);
    }
    if (prev == '-')
        bsti_sink_put(s, " ", 1);
}

void bsti_sink_xml_element(bsti_sink *s, const char *indent, const char *name, const char *text)
{
    bsti_sink_puts(s, indent);
    bsti_sink_printf(s, "<%s>", name);
    bsti_sink_xml_text(s, text);
    bsti_sink_printf(s, "</%s>\n", name);
}
