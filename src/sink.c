/* sink.c - buffered text output through a callback (see sink.h). */
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
