/* xml.c - reading BSDF XML (LBNL WindowElement, as written by WINDOW, wrapBSDF and genBSDF) and
 * turning it into layers.
 *
 * File conventions (../shared/reference/CONVENTIONS.md 1, 2, 5, 7): XML "Front" is the exterior
 * (-Z) side, which is also bsdfstack's front, so "Transmission Front" is our Tf and so on: no side
 * swap is needed.  Tensor trees index the incident square by the propagation direction (-in) and
 * the outgoing one by the exit direction, as our matrices do.  Klems "Columns" data lists, for
 * each outgoing patch (a text row), the values of every incident patch.
 *
 * The parser is libxml2's SAX interface fed in chunks: the ScatteringData text goes straight into
 * the tensor-tree or Klems tokenizer and is never held as a whole. */
#include <config.h>

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include <libxml/parser.h>
#include <libxml/SAX2.h>

#include "basis.h"
#include "ctx.h"
#include "layer.h"
#include "mat.h"
#include "ttree.h"

#define XML_CHUNK 65536
#define TEXT_MAX 256
#define MAX_CHANNELS 16
#define MAX_DEPTH 32
/* Sample points per cell when a rank-3 tree is expanded (DESIGN.md 1). */
#define TT3_IN_SAMPLES 2
#define TT3_OUT_SAMPLES 3

struct bst_bsdf {
    bst_ctx *ctx;
    char *path;
    bst_file_kind kind;
    int k;
    bst_basis *klems;
    size_t nch;
    char *channels[MAX_CHANNELS];
    bsti_ttree *tree[MAX_CHANNELS][BST_NCOMP];
    double *mat[MAX_CHANNELS][BST_NCOMP]; /* Klems, column-major N x N, M[o + N i] */
};

/* ------------------------------------------------------------------ SAX state */

struct reader {
    bst_ctx *ctx;
    const char *path;
    const bst_read_opts *opts;
    xmlParserCtxtPtr pctxt;
    bst_bsdf *b;
    int status;
    char elems[MAX_DEPTH][32];
    int depth;
    char text[TEXT_MAX];
    size_t ntext;
    char structure[TEXT_MAX];
    /* Klems basis from DataDefinition */
    char basis_name[TEXT_MAX];
    size_t nbands;
    double lo[BSTI_KLEMS_MAX_BANDS], hi[BSTI_KLEMS_MAX_BANDS];
    int nphi[BSTI_KLEMS_MAX_BANDS];
    /* current WavelengthData / block */
    char channel[TEXT_MAX];
    int comp;
    char block_basis[TEXT_MAX];
    /* ScatteringData */
    int in_data;
    int skip;
    bsti_tparse *tp;
    double *km;
    size_t nkm, kmax;
    char tok[64];
    int ntok;
};

static const char *parent(struct reader *r, int up)
{
    return r->depth - 1 - up >= 0 ? r->elems[r->depth - 1 - up] : "";
}

static int fail(struct reader *r, int status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static int fail(struct reader *r, int status, const char *fmt, ...)
{
    if (r->status < 0)
        return r->status;
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    r->status = bsti_error(r->ctx, status, "%s: line %d: %s", r->path,
                           r->pctxt ? xmlSAX2GetLineNumber(r->pctxt) : 0, msg);
    if (r->pctxt)
        xmlStopParser(r->pctxt);
    return r->status;
}

/* Prefix a message recorded by a lower layer (tokenizers) with the file and line. */
static void fail_ctx(struct reader *r, int status, const char *element)
{
    if (r->status < 0)
        return;
    char msg[BSTI_MSG_MAX];
    snprintf(msg, sizeof msg, "%s", bst_ctx_message(r->ctx));
    fail(r, status, "<%s>: %s", element, msg);
}

static int wanted_channel(struct reader *r, const char *name)
{
    if (!r->opts || r->opts->nchannels == 0)
        return 1;
    for (size_t i = 0; i < r->opts->nchannels; i++)
        if (strcasecmp(r->opts->channels[i], name) == 0)
            return 1;
    return 0;
}

static int channel_index(struct reader *r, const char *name)
{
    bst_bsdf *b = r->b;
    for (size_t i = 0; i < b->nch; i++)
        if (strcasecmp(b->channels[i], name) == 0)
            return (int)i;
    if (b->nch >= MAX_CHANNELS)
        return fail(r, BST_EFORMAT, "more than %d spectral channels", MAX_CHANNELS);
    if (!(b->channels[b->nch] = bsti_strdup(r->ctx, name)))
        return fail(r, BST_ENOMEM, "out of memory");
    return (int)b->nch++;
}

static void start_data(struct reader *r)
{
    r->in_data = 1;
    r->skip = 0;
    if (r->comp < 0) {
        fail(r, BST_EFORMAT, "<ScatteringData> before its <WavelengthDataDirection>");
        return;
    }
    if (!r->channel[0]) {
        fail(r, BST_EFORMAT, "<ScatteringData> without a <Wavelength>");
        return;
    }
    unsigned comps = r->opts && r->opts->comps ? r->opts->comps : BST_COMP_ALL;
    /* a transmission may have to come from the other side's by reciprocity: read both */
    if (comps & (BST_COMP_BIT(BST_TF) | BST_COMP_BIT(BST_TB)))
        comps |= BST_COMP_BIT(BST_TF) | BST_COMP_BIT(BST_TB);
    if (!(comps & BST_COMP_BIT(r->comp)) || !wanted_channel(r, r->channel)) {
        r->skip = 1;
        return;
    }
    if (strcmp(r->structure, "TensorTree3") == 0 || strcmp(r->structure, "TensorTree4") == 0) {
        if (strcmp(r->block_basis, "LBNL/Shirley-Chiu") != 0) {
            fail(r, BST_EBASIS, "<AngleBasis> '%s' of a tensor tree (expected LBNL/Shirley-Chiu)",
                 r->block_basis);
            return;
        }
        int rc = bsti_tparse_new(r->ctx, r->structure[10] - '0', &r->tp);
        if (rc < 0)
            fail_ctx(r, rc, "ScatteringData");
    } else if (strcmp(r->structure, "Columns") == 0 || strcmp(r->structure, "Rows") == 0) {
        if (!r->b->klems) {
            fail(r, BST_EBASIS, "<ScatteringData> of a Klems matrix without a Klems <AngleBasis> "
                 "in <DataDefinition>");
            return;
        }
        if (strcmp(r->block_basis, r->b->klems->name) != 0) {
            fail(r, BST_EBASIS, "<ColumnAngleBasis> '%s' is not the defined basis '%s'",
                 r->block_basis, r->b->klems->name);
            return;
        }
        size_t n = bst_basis_size(r->b->klems);
        r->kmax = n * n;
        r->nkm = 0;
        r->ntok = 0;
        if (!(r->km = bsti_alloc_array(r->ctx, r->kmax, sizeof *r->km)))
            fail(r, BST_ENOMEM, "out of memory for a %zu x %zu matrix", n, n);
    } else if (!r->structure[0]) {
        fail(r, BST_EFORMAT, "<ScatteringData> without an <IncidentDataStructure>");
    } else {
        fail(r, BST_EFORMAT, "unknown <IncidentDataStructure> '%s' (TensorTree3, TensorTree4, "
             "Columns or Rows expected)", r->structure);
    }
}

static void klems_number(struct reader *r)
{
    r->tok[r->ntok] = '\0';
    r->ntok = 0;
    char *end;
    double v = strtod(r->tok, &end);
    if (end == r->tok || *end != '\0') {
        fail(r, BST_EFORMAT, "<ScatteringData>: '%s' is not a number", r->tok);
        return;
    }
    if (!isfinite(v)) {
        fail(r, BST_EFORMAT, "<ScatteringData>: value %zu is not finite", r->nkm + 1);
        return;
    }
    if (r->nkm >= r->kmax) {
        fail(r, BST_EFORMAT, "<ScatteringData> holds more than the %zu values of its basis", r->kmax);
        return;
    }
    r->km[r->nkm++] = v < 0 ? 0.0 : v; /* as libBSDF and the tree reader: negatives are 0 */
}

static void data_chars(struct reader *r, const char *s, size_t len)
{
    if (r->skip || r->status < 0)
        return;
    if (r->tp) {
        int rc = bsti_tparse_feed(r->tp, s, len);
        if (rc < 0)
            fail_ctx(r, rc, "ScatteringData");
        return;
    }
    for (size_t i = 0; i < len && r->status >= 0; i++) {
        char c = s[i];
        if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == ',') {
            if (r->ntok)
                klems_number(r);
        } else if (r->ntok >= (int)sizeof r->tok - 1) {
            fail(r, BST_EFORMAT, "<ScatteringData>: a token longer than %zu characters", sizeof r->tok - 1);
        } else {
            r->tok[r->ntok++] = c;
        }
    }
}

static void end_data(struct reader *r)
{
    r->in_data = 0;
    if (r->skip || r->status < 0)
        return;
    int ch = channel_index(r, r->channel);
    if (ch < 0)
        return;
    bst_bsdf *b = r->b;
    if (b->tree[ch][r->comp] || b->mat[ch][r->comp]) {
        fail(r, BST_EFORMAT, "%s of channel %s given twice", bst_comp_name((bst_comp)r->comp), r->channel);
        return;
    }
    if (r->tp) {
        bsti_ttree *t;
        int rc = bsti_tparse_finish(r->tp, &t);
        r->tp = NULL;
        if (rc < 0) {
            fail_ctx(r, rc, "ScatteringData");
            return;
        }
        b->tree[ch][r->comp] = t;
        if (t->depth > b->k)
            b->k = t->depth;
        if (t->depth > BST_K_MAX + 1)
            fail(r, BST_EFORMAT, "<ScatteringData>: tree depth %d exceeds %d", t->depth, BST_K_MAX + 1);
        return;
    }
    if (r->ntok)
        klems_number(r);
    if (r->status < 0)
        return;
    if (r->nkm != r->kmax) {
        fail(r, BST_EFORMAT, "<ScatteringData> holds %zu values, the basis %s needs %zu", r->nkm,
             b->klems->name, r->kmax);
        return;
    }
    size_t n = bst_basis_size(b->klems);
    /* "Columns": value k is (incident k mod n, outgoing k div n): M[o + n i] = v[o n + i] */
    double *m = bsti_alloc_array(r->ctx, r->kmax, sizeof *m);
    if (!m) {
        fail(r, BST_ENOMEM, "out of memory");
        return;
    }
    int rows = strcmp(r->structure, "Rows") == 0;
    for (size_t o = 0; o < n; o++)
        for (size_t i = 0; i < n; i++)
            m[o + n * i] = rows ? r->km[i * n + o] : r->km[o * n + i];
    bsti_free(r->ctx, r->km);
    r->km = NULL;
    b->mat[ch][r->comp] = m;
}

static void on_start(void *ud, const xmlChar *local, const xmlChar *prefix, const xmlChar *uri,
                     int nns, const xmlChar **ns, int nattr, int ndef, const xmlChar **attr)
{
    (void)prefix, (void)uri, (void)nns, (void)ns, (void)nattr, (void)ndef, (void)attr;
    struct reader *r = ud;
    if (r->status < 0)
        return;
    const char *name = (const char *)local;
    if (r->depth >= MAX_DEPTH) {
        fail(r, BST_EFORMAT, "elements nested deeper than %d", MAX_DEPTH);
        return;
    }
    if (r->in_data) {
        fail(r, BST_EFORMAT, "element <%s> inside <ScatteringData>", name);
        return;
    }
    snprintf(r->elems[r->depth++], sizeof r->elems[0], "%s", name);
    r->ntext = 0;
    if (r->depth == 1 && strcmp(name, "WindowElement") != 0) {
        fail(r, BST_EFORMAT, "root element <%s> is not <WindowElement>", name);
        return;
    }
    if (strcmp(name, "WavelengthData") == 0) {
        r->channel[0] = '\0';
    } else if (strcmp(name, "WavelengthDataBlock") == 0) {
        r->comp = -1;
        r->block_basis[0] = '\0';
    } else if (strcmp(name, "AngleBasisBlock") == 0) {
        if (r->nbands >= BSTI_KLEMS_MAX_BANDS) {
            fail(r, BST_EBASIS, "more than %d <AngleBasisBlock>s", BSTI_KLEMS_MAX_BANDS);
            return;
        }
        r->lo[r->nbands] = r->hi[r->nbands] = NAN;
        r->nphi[r->nbands++] = 0;
    } else if (strcmp(name, "ScatteringData") == 0) {
        start_data(r);
    }
}

static int text_number(struct reader *r, const char *elem, double *v)
{
    char *end;
    errno = 0;
    *v = strtod(r->text, &end);
    while (*end == ' ' || *end == '\n' || *end == '\t' || *end == '\r')
        end++;
    if (end == r->text || *end || !isfinite(*v))
        return fail(r, BST_EFORMAT, "<%s> '%s' is not a number", elem, r->text);
    return BST_OK;
}

static void on_end(void *ud, const xmlChar *local, const xmlChar *prefix, const xmlChar *uri)
{
    (void)prefix, (void)uri;
    struct reader *r = ud;
    if (r->status < 0)
        return;
    const char *name = (const char *)local;
    r->text[r->ntext] = '\0';
    /* trim */
    char *t = r->text;
    while (*t == ' ' || *t == '\n' || *t == '\t' || *t == '\r')
        t++;
    size_t n = strlen(t);
    while (n && (t[n - 1] == ' ' || t[n - 1] == '\n' || t[n - 1] == '\t' || t[n - 1] == '\r'))
        t[--n] = '\0';
    memmove(r->text, t, n + 1);
    const char *up = parent(r, 1);
    double v;
    if (strcmp(name, "ScatteringData") == 0) {
        end_data(r);
    } else if (strcmp(name, "IncidentDataStructure") == 0) {
        snprintf(r->structure, sizeof r->structure, "%s", r->text);
        if (strcmp(r->text, "TensorTree3") && strcmp(r->text, "TensorTree4") &&
            strcmp(r->text, "Columns") && strcmp(r->text, "Rows"))
            fail(r, BST_EFORMAT, "unknown <IncidentDataStructure> '%s' (TensorTree3, TensorTree4, "
                 "Columns or Rows expected)", r->text);
    } else if (strcmp(name, "FileType") == 0) {
        if (strcmp(r->text, "BSDF") != 0)
            fail(r, BST_EFORMAT, "<FileType> '%s' is not BSDF", r->text);
    } else if (strcmp(name, "AngleBasisName") == 0) {
        snprintf(r->basis_name, sizeof r->basis_name, "%s", r->text);
    } else if (strcmp(name, "nPhis") == 0 && r->nbands) {
        if (text_number(r, name, &v) == BST_OK) {
            if (v < 1 || v > 100000 || v != floor(v))
                fail(r, BST_EBASIS, "<nPhis> %s is not a patch count", r->text);
            r->nphi[r->nbands - 1] = (int)v;
        }
    } else if (strcmp(name, "LowerTheta") == 0 && r->nbands) {
        if (text_number(r, name, &v) == BST_OK)
            r->lo[r->nbands - 1] = v;
    } else if (strcmp(name, "UpperTheta") == 0 && r->nbands) {
        if (text_number(r, name, &v) == BST_OK)
            r->hi[r->nbands - 1] = v;
    } else if (strcmp(name, "AngleBasis") == 0 && strcmp(up, "DataDefinition") == 0) {
        double bounds[BSTI_KLEMS_MAX_BANDS + 1];
        for (size_t i = 0; i < r->nbands; i++) {
            if (isnan(r->lo[i]) || isnan(r->hi[i]) || r->nphi[i] < 1) {
                fail(r, BST_EBASIS, "<AngleBasisBlock> %zu lacks ThetaBounds or nPhis", i + 1);
                return;
            }
            if (i > 0 && fabs(r->lo[i] - r->hi[i - 1]) > 1e-9) {
                fail(r, BST_EBASIS, "<AngleBasisBlock> %zu starts at %g, the previous ends at %g",
                     i + 1, r->lo[i], r->hi[i - 1]);
                return;
            }
            bounds[i] = r->lo[i];
        }
        if (r->nbands)
            bounds[r->nbands] = r->hi[r->nbands - 1];
        if (r->b->klems) {
            fail(r, BST_EBASIS, "a second <AngleBasis> definition");
            return;
        }
        int rc = bst_basis_new_klems_bands(r->ctx, r->basis_name[0] ? r->basis_name : "Klems",
                                           r->nbands, bounds, r->nphi, &r->b->klems);
        if (rc < 0)
            fail_ctx(r, rc, "AngleBasis");
    } else if ((strcmp(name, "AngleBasis") == 0 || strcmp(name, "ColumnAngleBasis") == 0) &&
               strcmp(up, "WavelengthDataBlock") == 0) {
        snprintf(r->block_basis, sizeof r->block_basis, "%s", r->text);
    } else if (strcmp(name, "RowAngleBasis") == 0) {
        if (r->b->klems && strcmp(r->text, r->b->klems->name) != 0)
            fail(r, BST_EBASIS, "<RowAngleBasis> '%s' is not the defined basis '%s'", r->text,
                 r->b->klems->name);
    } else if (strcmp(name, "Wavelength") == 0 && strcmp(up, "WavelengthData") == 0) {
        if (!r->text[0])
            fail(r, BST_EFORMAT, "empty <Wavelength>");
        snprintf(r->channel, sizeof r->channel, "%s", strcasecmp(r->text, "CIE-Y") == 0 ? "Visible" : r->text);
    } else if (strcmp(name, "WavelengthDataDirection") == 0) {
        static const char *const dirs[BST_NCOMP] = {"Transmission Front", "Reflection Front",
                                                    "Transmission Back", "Reflection Back"};
        r->comp = -1;
        for (int c = 0; c < BST_NCOMP; c++)
            if (strcasecmp(r->text, dirs[c]) == 0)
                r->comp = c;
        if (r->comp < 0)
            fail(r, BST_EFORMAT, "<WavelengthDataDirection> '%s' is not Transmission/Reflection "
                 "Front/Back", r->text);
    }
    r->depth--;
    r->ntext = 0;
}

static void on_chars(void *ud, const xmlChar *ch, int len)
{
    struct reader *r = ud;
    if (r->status < 0)
        return;
    if (r->in_data) {
        data_chars(r, (const char *)ch, (size_t)len);
        return;
    }
    size_t n = (size_t)len;
    if (r->ntext + n >= TEXT_MAX)
        n = TEXT_MAX - 1 - r->ntext; /* long free text (comments, geometry) is not needed */
    memcpy(r->text + r->ntext, ch, n);
    r->ntext += n;
}

static void on_error(void *ud, xmlErrorPtr e)
{
    struct reader *r = ud;
    if (r->status < 0 || !e || e->level < XML_ERR_ERROR)
        return;
    char msg[300];
    snprintf(msg, sizeof msg, "%s", e->message ? e->message : "malformed XML");
    size_t n = strlen(msg);
    while (n && msg[n - 1] == '\n')
        msg[--n] = '\0';
    r->status = bsti_error(r->ctx, BST_EFORMAT, "%s: line %d: malformed XML: %s", r->path, e->line, msg);
}

/* ------------------------------------------------------------------ the bsdf object */

void bst_bsdf_free(bst_bsdf *b)
{
    if (!b)
        return;
    for (size_t ch = 0; ch < MAX_CHANNELS; ch++) {
        for (int c = 0; c < BST_NCOMP; c++) {
            bsti_ttree_free(b->tree[ch][c]);
            bsti_free(b->ctx, b->mat[ch][c]);
        }
        bsti_free(b->ctx, b->channels[ch]);
    }
    bst_basis_free(b->klems);
    bsti_free(b->ctx, b->path);
    bsti_free(b->ctx, b);
}

static int stored(const bst_bsdf *b, size_t ch, int c)
{
    return b->tree[ch][c] || b->mat[ch][c];
}

int bst_bsdf_read(bst_ctx *ctx, const char *path, const bst_read_opts *opts, bst_bsdf **out)
{
    if (!ctx || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "read: NULL argument") : BST_EINVAL;
    *out = NULL;
    if (!path)
        return bsti_error(ctx, BST_EINVAL, "read: no file name");
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return bsti_error(ctx, BST_EIO, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    double size = fstat(fileno(fp), &st) == 0 && st.st_size > 0 ? (double)st.st_size : 1.0;
    struct reader r = {.ctx = ctx, .path = path, .opts = opts, .comp = -1};
    r.b = bsti_calloc(ctx, 1, sizeof *r.b);
    char *buf = bsti_malloc(ctx, XML_CHUNK);
    if (!r.b || !buf) {
        fclose(fp);
        bsti_free(ctx, r.b);
        bsti_free(ctx, buf);
        return BST_ENOMEM;
    }
    r.b->ctx = ctx;
    r.b->path = bsti_strdup(ctx, path);
    xmlSAXHandler sax;
    memset(&sax, 0, sizeof sax);
    sax.initialized = XML_SAX2_MAGIC;
    sax.startElementNs = on_start;
    sax.endElementNs = on_end;
    sax.characters = on_chars;
    sax.serror = on_error;
    r.pctxt = xmlCreatePushParserCtxt(&sax, &r, NULL, 0, path);
    if (!r.pctxt || !r.b->path) {
        r.status = bsti_error(ctx, BST_ENOMEM, "%s: out of memory starting the XML parser", path);
    } else {
        xmlCtxtUseOptions(r.pctxt, XML_PARSE_HUGE | XML_PARSE_NONET);
        double done = 0;
        size_t n;
        while (r.status >= 0 && (n = fread(buf, 1, XML_CHUNK, fp)) > 0) {
            int e = xmlParseChunk(r.pctxt, buf, (int)n, 0);
            done += (double)n;
            bsti_progress(ctx, done / size, "reading");
            if (e && r.status >= 0)
                r.status = bsti_error(ctx, BST_EFORMAT, "%s: malformed XML (error %d)", path, e);
        }
        if (r.status >= 0 && ferror(fp))
            r.status = bsti_error(ctx, BST_EIO, "%s: read error", path);
        if (r.status >= 0) {
            int e = xmlParseChunk(r.pctxt, buf, 0, 1);
            if (e && r.status >= 0)
                r.status = bsti_error(ctx, BST_EFORMAT, "%s: malformed or truncated XML (error %d)", path, e);
        }
        bsti_progress(ctx, 1.0, "reading");
    }
    if (r.pctxt)
        xmlFreeParserCtxt(r.pctxt);
    fclose(fp);
    bsti_free(ctx, buf);
    bsti_tparse_free(r.tp);
    bsti_free(ctx, r.km);
    bst_bsdf *b = r.b;
    int rc = r.status;
    if (rc >= 0) {
        if (strncmp(r.structure, "TensorTree", 10) == 0)
            b->kind = r.structure[10] == '3' ? BST_FILE_TT3 : BST_FILE_TT4;
        else
            b->kind = BST_FILE_KLEMS;
        if (b->nch == 0 && opts && opts->nchannels) {
            char names[256] = "";
            for (size_t i = 0; i < opts->nchannels; i++) {
                size_t len = strlen(names);
                snprintf(names + len, sizeof names - len, "%s'%s'", i ? ", " : "", opts->channels[i]);
            }
            rc = bsti_error(ctx, BST_EFORMAT, "%s: no <ScatteringData> for channel %s%s", path, names,
                            opts->comps ? " and the requested components" : "");
        } else if (b->nch == 0) {
            rc = bsti_error(ctx, BST_EFORMAT, "%s: no <ScatteringData> %s", path,
                            opts && opts->comps ? "for the requested components" : "found");
        }
    }
    if (rc >= 0 && b->kind != BST_FILE_KLEMS && b->k < 1)
        rc = bsti_error(ctx, BST_EFORMAT, "%s: tensor trees of depth 0 (a single value) have no basis", path);
    /* Completion: reciprocity for a missing transmission, zero for a missing reflection. */
    char note[256] = "";
    unsigned comps = opts && opts->comps ? opts->comps : BST_COMP_ALL;
    for (size_t ch = 0; rc >= 0 && ch < b->nch; ch++) {
        for (int c = 0; c < BST_NCOMP; c++) {
            if (!(comps & BST_COMP_BIT(c)) || stored(b, ch, c))
                continue;
            int other = c == BST_TF ? BST_TB : c == BST_TB ? BST_TF : -1;
            const char *how = other >= 0 && stored(b, ch, other) ? "from reciprocity" : "as zero";
            size_t len = strlen(note);
            snprintf(note + len, sizeof note - len, "%s%s %s %s", len ? "; " : "", b->channels[ch],
                     bst_comp_name((bst_comp)c), how);
        }
    }
    if (rc < 0) {
        bst_bsdf_free(b);
        return rc;
    }
    *out = b;
    if (note[0])
        return bsti_error(ctx, BST_WDATA, "%s: not in the file, completed: %s", path, note);
    return BST_OK;
}

bst_file_kind bst_bsdf_kind(const bst_bsdf *b) { return b->kind; }
int bst_bsdf_order(const bst_bsdf *b) { return b->kind == BST_FILE_KLEMS ? 0 : b->k; }
const bst_basis *bst_bsdf_klems_basis(const bst_bsdf *b) { return b->klems; }
size_t bst_bsdf_nchannels(const bst_bsdf *b) { return b->nch; }
const char *bst_bsdf_channel(const bst_bsdf *b, size_t ch) { return ch < b->nch ? b->channels[ch] : NULL; }
int bst_bsdf_stored(const bst_bsdf *b, size_t ch, bst_comp c)
{
    return ch < b->nch && (unsigned)c < BST_NCOMP && stored(b, ch, c);
}

/* ------------------------------------------------------------------ evaluation */

/* Stored component c at (in, out), no reciprocity. */
static double eval_stored(const bst_bsdf *b, size_t ch, int c, const double in[3], const double out[3])
{
    if (b->mat[ch][c]) {
        size_t n = bst_basis_size(b->klems);
        double prop[3] = {-in[0], -in[1], -in[2]};
        return b->mat[ch][c][bst_basis_patch(b->klems, out) + n * bst_basis_patch(b->klems, prop)];
    }
    const bsti_ttree *t = b->tree[ch][c];
    double p[4];
    if (t->dim == 4) {
        bsti_sc_disk_to_square(-in[0], -in[1], &p[0], &p[1]);
        bsti_sc_disk_to_square(out[0], out[1], &p[2], &p[3]);
    } else {
        /* rank 3: sin(theta_in) on the lower half of p0; the exit vector rotated so that the
         * incident light travels towards +x (CONVENTIONS.md 5.2) */
        p[0] = 0.5 - 1e-6 - 0.5 * sqrt(in[0] * in[0] + in[1] * in[1]);
        double phi = atan2(-in[1], -in[0]), c0 = cos(phi), s0 = sin(phi);
        bsti_sc_disk_to_square(out[0] * c0 + out[1] * s0, -out[0] * s0 + out[1] * c0, &p[1], &p[2]);
    }
    return bsti_ttree_eval(t, p);
}

static double eval_comp(const bst_bsdf *b, size_t ch, int c, const double in[3], const double out[3])
{
    if (stored(b, ch, c))
        return eval_stored(b, ch, c, in, out);
    int other = c == BST_TF ? BST_TB : c == BST_TB ? BST_TF : -1;
    if (other >= 0 && stored(b, ch, other))
        return eval_stored(b, ch, other, out, in); /* reciprocity: f(in, out) = f(out, in) */
    return 0.0;
}

int bst_bsdf_eval(bst_ctx *ctx, const bst_bsdf *b, size_t ch, const double in_raw[3],
                  const double out_raw[3], double *value)
{
    if (!ctx || !b || !in_raw || !out_raw || !value)
        return ctx ? bsti_error(ctx, BST_EINVAL, "eval: NULL argument") : BST_EINVAL;
    if (ch >= b->nch)
        return bsti_error(ctx, BST_EINVAL, "eval: channel %zu of %zu", ch, b->nch);
    double in[3], out[3], li = 0, lo = 0;
    for (int i = 0; i < 3; i++)
        li += in_raw[i] * in_raw[i], lo += out_raw[i] * out_raw[i];
    if (!(li > 0 && lo > 0 && isfinite(li) && isfinite(lo)))
        return bsti_error(ctx, BST_EINVAL, "eval: direction vectors must be finite and non-zero");
    for (int i = 0; i < 3; i++)
        in[i] = in_raw[i] / sqrt(li), out[i] = out_raw[i] / sqrt(lo);
    if (in[2] == 0.0 || out[2] == 0.0)
        return bsti_error(ctx, BST_EINVAL, "eval: a direction lies in the surface plane (z = 0)");
    int c = in[2] < 0 ? (out[2] > 0 ? BST_TF : BST_RF) : (out[2] < 0 ? BST_TB : BST_RB);
    *value = eval_comp(b, ch, c, in, out);
    return BST_OK;
}

/* ------------------------------------------------------------------ resampling */

/* The Klems patch of every Shirley-Chiu cell centre (map, n entries) and how many cells each Klems
 * patch holds (cnt, nk entries): the correspondence both directions of Klems <-> Shirley-Chiu
 * resampling use.  The caller frees both. */
static int centre_map(bst_ctx *ctx, const bst_basis *sc, const bst_basis *kb, size_t **map, double **cnt)
{
    size_t n = bst_basis_size(sc);
    *map = bsti_alloc_array(ctx, n, sizeof **map);
    *cnt = bsti_calloc(ctx, bst_basis_size(kb), sizeof **cnt);
    if (!*map || !*cnt) {
        bsti_free(ctx, *map), bsti_free(ctx, *cnt);
        *map = NULL, *cnt = NULL;
        return BST_ENOMEM;
    }
    for (size_t j = 0; j < n; j++) {
        double d[3];
        bst_basis_center(sc, j, d);
        (*map)[j] = bst_basis_patch(kb, d);
        (*cnt)[(*map)[j]] += 1.0;
    }
    return BST_OK;
}

/* A rank-3 tree on the Shirley-Chiu grid of order k, M[o + N i] as bsti_ttree_expand4 lays it
 * out: the average over TT3_IN_SAMPLES^2 points of incident cell i and TT3_OUT_SAMPLES^2 points of
 * outgoing cell o of the tree at (sin(theta_in) on the lower half of p0, the exit point turned by
 * -phi_in).  A cell coarser than both the tree's and order 5's gets 2^j times as many points per
 * side, 2^j being how much wider it is: 2 x 2 x 3 x 3 points in a cell 4 tree cells wide miss a
 * peaked distribution's cell mean by up to 5 % of its light (tests/test_xml.c).
 * The tree is first laid on a grid of its own finest cells (a lookup there is the tree's lookup),
 * and sample points are kept in polar form, so a turn is a subtraction; a point on a cell
 * boundary takes the mean of the cells there (bsti_sc_polar_cells).  The result is invariant
 * under quarter turns of both cells (the concentric map commutes with them and the sample points
 * of a cell turn into those of the turned cell), so only incident cells of one quadrant are
 * computed and the other three columns are copied. */
static int expand3(bst_ctx *ctx, const bsti_ttree *t, int k, double *m)
{
    size_t G = (size_t)1 << k, n = G * G;
    size_t gd = (size_t)1 << t->depth, h0 = gd > 1 ? gd / 2 : 1;
    /* cells coarser than the tree's get proportionally more points, up to those of order 5 */
    int fine = (t->depth < 5 ? t->depth : 5) - k;
    size_t f = fine > 0 ? (size_t)1 << fine : 1;
    size_t S = TT3_IN_SAMPLES * f, T = TT3_OUT_SAMPLES * f, ni = S * S, no = T * T;
    float *grid = bsti_alloc_array(ctx, h0 * gd * gd, sizeof *grid);
    double *pin = NULL, *pol = NULL;
    if (!grid || bsti_sc_cell_points(ctx, G, S, &pin) < 0 || bsti_sc_cell_points(ctx, G, T, &pol) < 0) {
        bsti_free(ctx, grid), bsti_free(ctx, pin), bsti_free(ctx, pol);
        return BST_ENOMEM;
    }
    for (size_t i0 = 0; i0 < h0; i0++) /* p0 < 1/2 only: sin(theta_in) lies there */
        for (size_t q = 0; q < gd * gd; q++) {
            double p[3] = {(i0 + 0.5) / gd, (q / gd + 0.5) / gd, (q % gd + 0.5) / gd};
            grid[i0 * gd * gd + q] = (float)bsti_ttree_eval(t, p);
        }
    size_t lo = G > 1 ? G / 2 : 0, done = 0, todo = (G - lo) * (G - lo);
    for (size_t ix = lo; ix < G; ix++)
        for (size_t iy = lo; iy < G; iy++) {
            size_t i = ix * G + iy;
            double *col = m + n * i;
            memset(col, 0, n * sizeof *col);
            for (size_t si = 0; si < ni; si++) {
                double r = pin[2 * (i * ni + si)], phi = pin[2 * (i * ni + si) + 1];
                size_t i0 = (size_t)((0.5 - 1e-6 - 0.5 * r) * (double)gd);
                const float *slab = grid + (i0 < h0 ? i0 : h0 - 1) * gd * gd;
                for (size_t o = 0; o < n; o++) {
                    const double *po = pol + 2 * o * no;
                    double sum = 0;
                    for (size_t s = 0; s < no; s++) {
                        size_t cells[4];
                        int nc = bsti_sc_polar_cells(po[2 * s], po[2 * s + 1] - phi, gd, cells);
                        double v = 0.0;
                        for (int j = 0; j < nc; j++)
                            v += slab[cells[j]];
                        sum += v / nc;
                    }
                    col[o] += sum / (double)(no * ni);
                }
            }
            if (++done % 16 == 0)
                bsti_progress(ctx, (double)done / (double)todo, "expanding an isotropic tree");
        }
    /* the three other quadrants, by quarter turns of both cells */
    for (size_t ix = lo; G > 1 && ix < G; ix++)
        for (size_t iy = lo; iy < G; iy++) {
            const double *src = m + n * (ix * G + iy);
            for (int turn = 1; turn < 4; turn++) {
                double *dst = m + n * bsti_sc_turn(ix * G + iy, turn, G);
                for (size_t o = 0; o < n; o++)
                    dst[bsti_sc_turn(o, turn, G)] = src[o];
            }
        }
    bsti_free(ctx, grid), bsti_free(ctx, pin), bsti_free(ctx, pol);
    return BST_OK;
}

/* Component c of channel ch on a Shirley-Chiu grid of order k: m is N x N (N = 4^k). */
static int to_sc(bst_ctx *ctx, const bst_bsdf *b, size_t ch, int c, int k, double *m)
{
    const bst_basis *sc = NULL;
    bst_basis *own = NULL;
    int rc = bst_basis_new_sc(ctx, k, &own);
    if (rc < 0)
        return rc;
    sc = own;
    size_t n = bst_basis_size(sc);
    if (b->tree[ch][c] && b->tree[ch][c]->dim == 4) {
        rc = bsti_ttree_expand4(b->tree[ch][c], k, m);
    } else if (b->tree[ch][c]) {
        rc = expand3(ctx, b->tree[ch][c], k, m);
    } else {
        /* Klems -> Shirley-Chiu: each cell takes the value of the Klems patch holding its centre,
         * weighted so that every incident patch keeps its hemispherical totals. */
        const bst_basis *kb = b->klems;
        size_t nk = bst_basis_size(kb), *map;
        double *cnt;
        if ((rc = centre_map(ctx, sc, kb, &map, &cnt)) < 0) {
            bst_basis_free(own);
            return rc;
        }
        const double *lk = bst_basis_lambda(kb), lsc = M_PI / (double)n;
        const double *km = b->mat[ch][c];
        for (size_t i = 0; i < n; i++)
            for (size_t o = 0; o < n; o++)
                m[o + n * i] = km[map[o] + nk * map[i]] * lk[map[o]] / (cnt[map[o]] * lsc);
        bsti_free(ctx, map);
        bsti_free(ctx, cnt);
    }
    bst_basis_free(own);
    return rc;
}

/* Exact overlap of Shirley-Chiu cells and Klems patches.  The concentric map preserves area and
 * sends a circle sin(theta) = r to the square ring max(|a|, |b|) = r and, inside each of its four
 * wedges, an azimuth to a ray through the centre ((a, b) = 2 (sx, sy) - 1; in wedge w, turned by
 * -w 90 degrees into (u, v): u = r, v = r (phi - w pi/2) / (pi/4)).  So the part of a Klems patch
 * inside a wedge is the trapezoid r0 <= u <= r1, t0 u <= v <= t1 u, and its overlap with a cell
 * (an axis-parallel square) is a convex polygon clip. */
struct kpiece {
    size_t patch;
    int wedge;
    double r0, r1, t0, t1;
};

/* Clip the polygon (x[i], y[i]), n vertices, by alpha x + beta y + gamma >= 0. */
static int clip(double *x, double *y, int n, double alpha, double beta, double gamma)
{
    double ox[16], oy[16];
    int m = 0;
    for (int i = 0; i < n; i++) {
        int j = (i + 1) % n;
        double di = alpha * x[i] + beta * y[i] + gamma, dj = alpha * x[j] + beta * y[j] + gamma;
        if (di >= 0)
            ox[m] = x[i], oy[m++] = y[i];
        if ((di >= 0) != (dj >= 0) && m < 16) {
            double t = di / (di - dj);
            ox[m] = x[i] + t * (x[j] - x[i]), oy[m++] = y[i] + t * (y[j] - y[i]);
        }
    }
    memcpy(x, ox, (size_t)m * sizeof *x);
    memcpy(y, oy, (size_t)m * sizeof *y);
    return m;
}

/* Area (in (a, b) units) of cell [a0, a1] x [b0, b1] inside piece pc. */
static double piece_overlap(const struct kpiece *pc, double a0, double a1, double b0, double b1)
{
    double ca[4] = {a0, a1, a1, a0}, cb[4] = {b0, b0, b1, b1}, x[16], y[16];
    for (int i = 0; i < 4; i++) {
        double a = ca[i], b = cb[i];
        switch (pc->wedge) { /* turn by -w 90 degrees */
        case 0: x[i] = a, y[i] = b; break;
        case 1: x[i] = b, y[i] = -a; break;
        case 2: x[i] = -a, y[i] = -b; break;
        default: x[i] = -b, y[i] = a; break;
        }
    }
    int n = 4;
    double umin = fmin(fmin(x[0], x[1]), fmin(x[2], x[3])), umax = fmax(fmax(x[0], x[1]), fmax(x[2], x[3]));
    if (umax <= pc->r0 || umin >= pc->r1)
        return 0.0;
    n = clip(x, y, n, 1, 0, -pc->r0);
    if (n)
        n = clip(x, y, n, -1, 0, pc->r1);
    if (n)
        n = clip(x, y, n, -pc->t0, 1, 0);
    if (n)
        n = clip(x, y, n, pc->t1, -1, 0);
    double area = 0.0;
    for (int i = 0; i < n; i++) {
        int j = (i + 1) % n;
        area += x[i] * y[j] - x[j] * y[i];
    }
    return fabs(area) / 2;
}

/* The trapezoids of every patch of kb: at most 4 per patch (a patch spanning all azimuths). */
static size_t klems_pieces(const bst_basis *kb, struct kpiece *pc)
{
    size_t np = 0;
    for (size_t band = 0; band < kb->nbands; band++) {
        int n = kb->nphi[band];
        double r0 = sin(kb->theta[band] * M_PI / 180), r1 = sin(kb->theta[band + 1] * M_PI / 180);
        for (int j = 0; j < n; j++) {
            double lo = 2 * M_PI * (j - 0.5) / n, hi = 2 * M_PI * (j + 0.5) / n;
            if (n == 1)
                lo = -M_PI / 4, hi = 7 * M_PI / 4;
            for (int w = 0; w < 4; w++)
                for (int shift = -1; shift <= 1; shift++) {
                    double wl = w * M_PI / 2 - M_PI / 4 + shift * 2 * M_PI, wh = wl + M_PI / 2;
                    double a = fmax(lo, wl), b = fmin(hi, wh);
                    if (b - a <= 1e-12)
                        continue;
                    double c = wl + M_PI / 4; /* wedge centre */
                    pc[np++] = (struct kpiece){kb->first[band] + (size_t)j, w, r0, r1,
                                               (a - c) / (M_PI / 4), (b - c) / (M_PI / 4)};
                }
        }
    }
    return np;
}

/* Shirley-Chiu (order k) matrix -> Klems basis kb by the exact overlaps of cells and patches: the
 * incident side averages the cells over each patch weighted by the part of each cell inside it,
 * the outgoing side sums the flux of the part of each cell inside each patch.  So every incident
 * patch keeps exactly the projected-solid-angle average of its directions' directional-
 * hemispherical values (a cell-centre assignment missed it by up to 0.02 where a Klems band edge
 * cuts a ring of cells near grazing). */
static int sc_to_klems(bst_ctx *ctx, int k, const double *m, const bst_basis *kb, double *out)
{
    bst_basis *sc;
    int rc = bst_basis_new_sc(ctx, k, &sc);
    if (rc < 0)
        return rc;
    size_t n = bst_basis_size(sc), nk = bst_basis_size(kb);
    size_t G = (size_t)1 << k, maxe = 0;
    for (size_t band = 0; band < kb->nbands; band++)
        maxe += 4 * (size_t)kb->nphi[band];
    struct kpiece *pc = bsti_alloc_array(ctx, maxe, sizeof *pc);
    size_t *first = bsti_alloc_array(ctx, n + 1, sizeof *first);
    size_t cap = 4 * n, *patch = bsti_alloc_array(ctx, cap, sizeof *patch);
    double *w = bsti_alloc_array(ctx, cap, sizeof *w);
    double *area = bsti_calloc(ctx, nk, sizeof *area), *row = bsti_alloc_array(ctx, nk, sizeof *row);
    if (!pc || !first || !patch || !w || !area || !row) {
        rc = BST_ENOMEM;
        goto done;
    }
    size_t npc = klems_pieces(kb, pc), ne = 0;
    double cell = (2.0 / (double)G) * (2.0 / (double)G);
    for (size_t c = 0; c < n; c++) {
        first[c] = ne;
        double a0 = 2.0 * (double)(c / G) / (double)G - 1, b0 = 2.0 * (double)(c % G) / (double)G - 1;
        for (size_t q = 0; q < npc; q++) {
            double f = piece_overlap(&pc[q], a0, a0 + 2.0 / (double)G, b0, b0 + 2.0 / (double)G) / cell;
            if (f <= 1e-14)
                continue;
            size_t e = first[c];
            while (e < ne && patch[e] != pc[q].patch)
                e++;
            if (e == ne) {
                if (ne == cap) { /* grow */
                    size_t *np2 = bsti_alloc_array(ctx, 2 * cap, sizeof *np2);
                    double *nw = bsti_alloc_array(ctx, 2 * cap, sizeof *nw);
                    if (!np2 || !nw) {
                        bsti_free(ctx, np2), bsti_free(ctx, nw);
                        rc = BST_ENOMEM;
                        goto done;
                    }
                    memcpy(np2, patch, ne * sizeof *patch), memcpy(nw, w, ne * sizeof *w);
                    bsti_free(ctx, patch), bsti_free(ctx, w);
                    patch = np2, w = nw, cap *= 2;
                }
                patch[ne] = pc[q].patch, w[ne++] = 0.0;
            }
            w[e] += f;
        }
        for (size_t e = first[c]; e < ne; e++)
            area[patch[e]] += w[e];
    }
    first[n] = ne;
    for (size_t q = 0; q < nk; q++)
        if (area[q] == 0.0) {
            rc = bsti_error(ctx, BST_EBASIS, "Klems patch %zu overlaps no cell of the Shirley-Chiu "
                            "grid of order %d", q, k);
            goto done;
        }
    memset(out, 0, nk * nk * sizeof *out);
    const double *lk = bst_basis_lambda(kb), lsc = M_PI / (double)n;
    for (size_t i = 0; i < n; i++) {
        memset(row, 0, nk * sizeof *row); /* flux of incident cell i into each outgoing patch */
        for (size_t o = 0; o < n; o++) {
            double v = m[o + n * i];
            if (v != 0.0)
                for (size_t e = first[o]; e < first[o + 1]; e++)
                    row[patch[e]] += v * w[e];
        }
        for (size_t e = first[i]; e < first[i + 1]; e++) {
            double wi = w[e] / area[patch[e]];
            double *col = out + nk * patch[e];
            for (size_t q = 0; q < nk; q++)
                col[q] += row[q] * wi * lsc / lk[q];
        }
    }
done:
    bsti_free(ctx, pc), bsti_free(ctx, first), bsti_free(ctx, patch), bsti_free(ctx, w);
    bsti_free(ctx, area), bsti_free(ctx, row), bst_basis_free(sc);
    return rc;
}

/* In place on a Shirley-Chiu matrix (antipode(j) = N - 1 - j): M'[o + N i] = M[a(i) + N a(o)], the
 * transmission of the other side by reciprocity.  The map swaps pairs, so it is its own inverse. */
static void antipode_transpose(double *m, size_t n)
{
    for (size_t i = 0; i < n; i++)
        for (size_t o = 0; o < n; o++) {
            size_t p = o + n * i, q = (n - 1 - i) + n * (n - 1 - o);
            if (p < q) {
                double t = m[p];
                m[p] = m[q];
                m[q] = t;
            }
        }
}

/* Order of the Shirley-Chiu grid through which a Klems file goes to another Klems basis (trees go
 * through their own order, which holds them exactly). */
#define KLEMS_VIA_ORDER 6

int bst_bsdf_to_layer(bst_ctx *ctx, const bst_bsdf *b, const bst_basis *target, bst_layer **out)
{
    return bst_bsdf_to_layer_prec(ctx, b, target, BST_DOUBLE, out);
}

/* The component in work (N x N column-major, recip: to be taken as its reciprocal) as a matrix in
 * its cheapest structure; a dense one is filled straight from work in precision prec. */
static int component_from_work(bst_ctx *ctx, const bst_basis *target, const double *work, int recip,
                               bst_precision prec, bst_mat **out)
{
    size_t n = bst_basis_size(target), nnz = 0;
    int diag_only = 1;
    /* the reciprocal maps (o, i) to (a(i), a(o)): diagonal to diagonal, so the census is the same */
    for (size_t q = 0; q < n * n; q++)
        if (work[q] != 0.0) {
            nnz++;
            diag_only &= q % (n + 1) == 0;
        }
    int rc;
    bst_mat *d;
    if (nnz > 0 && !diag_only && (double)nnz > BST_SPARSE_MAX_FILL * (double)n * (double)n) {
        if ((rc = bst_mat_new_dense(ctx, n, n, prec, &d)) < 0)
            return rc;
        double *dd = prec == BST_DOUBLE ? bst_mat_dense_data(d) : NULL;
        float *df = prec == BST_FLOAT ? bst_mat_dense_data(d) : NULL;
        for (size_t i = 0; i < n; i++) {
            size_t ai = recip ? bst_basis_antipode(target, i) : 0;
            for (size_t o = 0; o < n; o++) {
                double v = recip ? work[ai + n * bst_basis_antipode(target, o)] : work[o + n * i];
                if (dd)
                    dd[o + n * i] = v;
                else
                    df[o + n * i] = (float)v;
            }
        }
        *out = d;
        return BST_OK;
    }
    if ((rc = bst_mat_new_dense(ctx, n, n, BST_DOUBLE, &d)) < 0)
        return rc;
    double *dd = bst_mat_dense_data(d);
    if (recip) { /* Tf[o][i] = Tb[a(i)][a(o)], a = antipode */
        for (size_t i = 0; i < n; i++) {
            size_t ai = bst_basis_antipode(target, i);
            for (size_t o = 0; o < n; o++)
                dd[o + n * i] = work[ai + n * bst_basis_antipode(target, o)];
        }
    } else {
        memcpy(dd, work, n * n * sizeof *dd);
    }
    rc = bst_mat_compact(ctx, d, BST_SPARSE_MAX_FILL, out);
    bst_mat_free(d);
    return rc;
}

int bst_bsdf_to_layer_prec(bst_ctx *ctx, const bst_bsdf *b, const bst_basis *target_in,
                           bst_precision prec, bst_layer **out)
{
    if (!ctx || !b || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "to_layer: NULL argument") : BST_EINVAL;
    if (prec != BST_DOUBLE && prec != BST_FLOAT)
        return bsti_error(ctx, BST_EINVAL, "to_layer: unknown precision %d", (int)prec);
    *out = NULL;
    bst_basis *native = NULL;
    int rc = BST_OK;
    if (!target_in) {
        rc = b->kind == BST_FILE_KLEMS ? bst_basis_copy(ctx, b->klems, &native)
                                       : bst_basis_new_sc(ctx, b->k > BST_K_MAX ? BST_K_MAX : b->k, &native);
        if (rc < 0)
            return rc;
    }
    const bst_basis *target = target_in ? target_in : native;
    size_t n = bst_basis_size(target);
    bst_layer *l = NULL;
    rc = bst_layer_new(ctx, target, b->nch, (const char *const *)b->channels, &l);
    if (rc >= 0)
        rc = bst_layer_set_name(ctx, l, b->path);
    double *work = NULL, *sc = NULL;
    size_t nsc = 0;
    int ksc = 0;
    if (rc >= 0 && !(work = bsti_alloc_array(ctx, n * n, sizeof *work)))
        rc = BST_ENOMEM;
    int direct_klems = b->kind == BST_FILE_KLEMS && target->kind == BST_BASIS_KLEMS &&
                       bst_basis_equal(target, b->klems);
    if (rc >= 0 && target->kind == BST_BASIS_KLEMS && !direct_klems) {
        ksc = b->kind == BST_FILE_KLEMS ? KLEMS_VIA_ORDER : b->k;
        if (ksc > BST_K_MAX)
            ksc = BST_K_MAX;
        nsc = (size_t)1 << (2 * ksc);
        if (!(sc = bsti_alloc_array(ctx, nsc * nsc, sizeof *sc)))
            rc = BST_ENOMEM;
    }
    for (size_t ch = 0; rc >= 0 && ch < b->nch; ch++) {
        for (int c = 0; rc >= 0 && c < BST_NCOMP; c++) {
            int src = c;
            int recip = 0;
            if (!stored(b, ch, c)) {
                int other = c == BST_TF ? BST_TB : c == BST_TB ? BST_TF : -1;
                if (other < 0 || !stored(b, ch, other)) {
                    bst_mat *z;
                    if ((rc = bst_mat_new_zero(ctx, n, n, &z)) >= 0)
                        rc = bst_layer_set(ctx, l, ch, (bst_comp)c, z);
                    continue;
                }
                src = other;
                recip = 1;
            }
            if (direct_klems) {
                memcpy(work, b->mat[ch][src], n * n * sizeof *work);
            } else if (target->kind == BST_BASIS_SHIRLEY_CHIU) {
                rc = to_sc(ctx, b, ch, src, target->k, work);
            } else if ((rc = to_sc(ctx, b, ch, src, ksc, sc)) >= 0) {
                /* A Klems patch is not a union of cells of the other side's patches: apply
                 * reciprocity on the fine grid, where it is exact, then average (otherwise the
                 * hemispherical Tf of a file storing only Tb is not kept). */
                if (recip) {
                    antipode_transpose(sc, nsc);
                    recip = 0;
                }
                rc = sc_to_klems(ctx, ksc, sc, target, work);
            }
            if (rc < 0)
                break;
            bst_mat *m;
            rc = component_from_work(ctx, target, work, recip, prec, &m);
            if (rc >= 0)
                rc = bst_layer_set(ctx, l, ch, (bst_comp)c, m);
        }
    }
    bsti_free(ctx, work);
    bsti_free(ctx, sc);
    bst_basis_free(native);
    if (rc < 0) {
        bst_layer_free(l);
        return rc;
    }
    *out = l;
    return BST_OK;
}
