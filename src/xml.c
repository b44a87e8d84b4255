/* xml.c - reading BSDF XML (LBNL WindowElement, as written by WINDOW, wrapBSDF and genBSDF) and
 * evaluating it as libBSDF does; resample.c turns it into layers.
 *
 * File conventions (../shared/reference/CONVENTIONS.md 1, 2, 5, 7): XML "Front" is the exterior
 * (-Z) side, which is also bsdfstack's front, so "Transmission Front" is our Tf and so on: no side
 * swap is needed.  Tensor trees index the incident square by the propagation direction (-in) and
 * the outgoing one by the exit direction, as our matrices do.  Klems "Columns" data lists, for
 * each outgoing patch (a text row), the values of every incident patch.
 *
 * The parser is libxml2's SAX interface pulling the file as it goes: the ScatteringData text goes
 * straight into the tensor-tree or Klems tokenizer and is never held as a whole. */
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
#include "bsdf.h"
#include "ctx.h"
#include "numtext.h"
#include "ttree.h"

#define TEXT_MAX 256
#define MAX_CHANNELS BSTI_BSDF_MAX_CHANNELS
#define MAX_DEPTH 32
/* Values a Klems matrix's first buffer holds; it doubles as the values come. */
#define BSTI_KLEMS_FIRST_ROOM 65536

/* ------------------------------------------------------------------ SAX state */

struct reader {
    bst_ctx *ctx;
    const char *path;
    const bst_bsdf_read_opts *opts;
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
    size_t nkm, kmax, kcap; /* values read, the basis's n * n, room in km */
    char tok[64];
    int ntok;
    int tok_line;           /* the line where the Klems token in tok began */
    int at_line;            /* a failure's line, where not the parser's (0) */
    size_t negatives; /* Klems values below 0, read as 0 */
    int layers;       /* <Layer> elements seen */
    int kind;         /* bst_file_kind of the first <ScatteringData>, -1 before it */
    char kind_structure[TEXT_MAX]; /* the <IncidentDataStructure> that set it */
};

static const char *parent(struct reader *r, int up)
{
    return r->depth - 1 - up >= 0 ? r->elems[r->depth - 1 - up] : "";
}

/* A message is one line: line breaks and other control characters the file put in it (a number
 * spanning lines, libxml2's "Bytes: ..." second line) become blanks. */
static void one_line(char *msg)
{
    size_t n = strlen(msg);
    while (n && (msg[n - 1] == '\n' || msg[n - 1] == '\r' || msg[n - 1] == ' '))
        msg[--n] = '\0';
    for (char *c = msg; *c; c++)
        if ((unsigned char)*c < 0x20 || *c == 0x7f)
            *c = ' ';
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
    one_line(msg);
    r->status = bsti_error(r->ctx, status, "%s: line %d: %s", r->path,
                           r->at_line ? r->at_line
                                      : r->pctxt ? xmlSAX2GetLineNumber(r->pctxt) : 0, msg);
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

/* The file kind an <IncidentDataStructure> gives its blocks, -1 for an unknown one. */
static int structure_kind(const char *structure)
{
    if (strcmp(structure, "TensorTree3") == 0)
        return BST_FILE_TT3;
    if (strcmp(structure, "TensorTree4") == 0)
        return BST_FILE_TT4;
    if (strcmp(structure, "Columns") == 0 || strcmp(structure, "Rows") == 0)
        return BST_FILE_KLEMS;
    return -1;
}

/* A file is of one kind: every block, read or skipped, has the structure kind of the first (a
 * bst_bsdf holds Klems matrices or trees of one rank, never a mixture, and every caller relies
 * on that).  Columns and Rows are both Klems. */
static int same_kind(struct reader *r)
{
    int kind = structure_kind(r->structure);
    if (kind < 0)
        return BST_OK; /* start_data says what is wrong with it */
    if (r->kind < 0) {
        r->kind = kind;
        snprintf(r->kind_structure, sizeof r->kind_structure, "%s", r->structure);
        return BST_OK;
    }
    if (kind != r->kind)
        return fail(r, BST_EFORMAT, "a %s block after %s blocks: a file holds one kind of "
                    "scattering data (give each kind its own file)", r->structure, r->kind_structure);
    return BST_OK;
}

static void start_data(struct reader *r)
{
    r->in_data = 1;
    r->skip = 0;
    if (same_kind(r) < 0)
        return;
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
        /* room grows with the values read (klems_number), so that a short file declaring a huge
           basis costs what its text holds, not n * n doubles up front */
        r->kcap = r->kmax < BSTI_KLEMS_FIRST_ROOM ? r->kmax : BSTI_KLEMS_FIRST_ROOM;
        if (!(r->km = bsti_alloc_array(r->ctx, r->kcap, sizeof *r->km)))
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
    size_t len = (size_t)r->ntok;
    r->ntok = 0;
    r->at_line = r->tok_line; /* the value's own line in what fails below */
    double v;
    if (!bsti_parse_double(r->tok, len, &v)) {
        fail(r, BST_EFORMAT, "<ScatteringData>: '%s' is not a number", r->tok);
        return;
    }
    char what[sizeof r->tok + 48];
    snprintf(what, sizeof what, "value no. %zu, '%s',", r->nkm + 1, r->tok);
    if (bsti_value_check(r->ctx, v, what) < 0) { /* the trees' bound (ttree.h) */
        fail_ctx(r, BST_EFORMAT, "ScatteringData");
        return;
    }
    if (r->nkm >= r->kmax) {
        fail(r, BST_EFORMAT, "<ScatteringData> holds more than the %zu values of its basis", r->kmax);
        return;
    }
    if (r->nkm == r->kcap) {
        size_t cap = r->kcap > r->kmax / 2 ? r->kmax : 2 * r->kcap;
        double *km = bsti_alloc_array(r->ctx, cap, sizeof *km);
        if (!km) {
            fail(r, BST_ENOMEM, "out of memory for %zu values of a Klems matrix", cap);
            return;
        }
        memcpy(km, r->km, r->nkm * sizeof *km);
        bsti_free(r->ctx, r->km);
        r->km = km;
        r->kcap = cap;
    }
    if (v < 0) { /* as libBSDF and the tree reader: negatives are 0 */
        v = 0;
        r->negatives++;
    }
    r->km[r->nkm++] = v;
    r->at_line = 0;
}

/* Line breaks in s[from .. len). */
static int breaks(const char *s, size_t from, size_t len)
{
    int n = 0;
    for (size_t i = from; i < len; i++)
        n += s[i] == '\n';
    return n;
}

static void data_chars(struct reader *r, const char *s, size_t len)
{
    if (r->skip || r->status < 0)
        return;
    /* libxml2 hands the text over in chunks of some hundred lines, its line count at the chunk's
       end: a token's line is that less the line breaks after it */
    int line = r->pctxt ? xmlSAX2GetLineNumber(r->pctxt) : 0;
    if (r->tp) {
        int rc = bsti_tparse_feed(r->tp, s, len);
        if (rc < 0) {
            r->at_line = line - breaks(s, bsti_tparse_failed_at(r->tp), len);
            fail_ctx(r, rc, "ScatteringData");
        }
        return;
    }
    line -= breaks(s, 0, len);
    for (size_t i = 0; i < len && r->status >= 0; i++) {
        char c = s[i];
        line += c == '\n';
        if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == ',') {
            if (r->ntok)
                klems_number(r);
            continue;
        }
        if (!r->ntok)
            r->tok_line = line;
        if (r->ntok >= (int)sizeof r->tok - 1) {
            r->at_line = r->tok_line;
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
        r->negatives += (size_t)t->negatives;
        if (t->depth > BST_K_MAX + 1)
            fail(r, BST_EFORMAT, "<ScatteringData>: a tensor tree of depth %d; bsdfstack reads trees "
                 "up to depth %d (at k = %d, averaging the finest cells)", t->depth, BST_K_MAX + 1,
                 BST_K_MAX);
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
    if (strcmp(name, "Layer") == 0) {
        if (r->layers++ > 0)
            fail(r, BST_EFORMAT, "a second <Layer>: bsdfstack reads one layer a file (the system's "
                 "BSDF); give each layer its own file");
    } else if (strcmp(name, "WavelengthData") == 0) {
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
    one_line(msg);
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

static void silent(void *ctx, const char *msg, ...)
{
    (void)ctx, (void)msg;
}

/* The file, handed to libxml2's pull parser as it asks: its buffer slides over the text, so
 * memory stays bounded, and its scans stay linear (the push parser of libxml2 2.9 rescans a
 * comment, CDATA section or attribute value from its start at every chunk: quadratic). */
struct source {
    FILE *fp;
    bst_ctx *ctx;
    double size, done;
    int err;
    int utf32; /* the text began as UTF-32 does: refused (libxml2 said "Document is empty") */
};

/* 1 when the first four bytes are UTF-32's: a byte-order mark, or '<' in four bytes. */
static int looks_utf32(const unsigned char *p)
{
    static const unsigned char sig[4][4] = {{0, 0, 0xFE, 0xFF}, {0xFF, 0xFE, 0, 0}, {0, 0, 0, '<'},
                                            {'<', 0, 0, 0}};
    for (int i = 0; i < 4; i++)
        if (memcmp(p, sig[i], 4) == 0)
            return 1;
    return 0;
}

static int source_read(void *opaque, char *buf, int len)
{
    struct source *s = opaque;
    size_t n = fread(buf, 1, (size_t)len, s->fp);
    if (n == 0 && ferror(s->fp)) {
        s->err = errno ? errno : EIO;
        return -1;
    }
    if (s->done == 0 && n >= 4 && looks_utf32((const unsigned char *)buf)) {
        s->utf32 = 1;
        return -1;
    }
    s->done += (double)n;
    bsti_progress(s->ctx, s->done / s->size, "reading");
    return (int)n;
}

/* The file through libxml2's SAX parser into r (r->status: the first error). */
static void parse(struct reader *r, FILE *fp, double size)
{
    bst_ctx *ctx = r->ctx;
    const char *path = r->path;
    xmlSAXHandler sax;
    memset(&sax, 0, sizeof sax);
    sax.initialized = XML_SAX2_MAGIC;
    sax.startElementNs = on_start;
    sax.endElementNs = on_end;
    sax.characters = on_chars;
    sax.serror = on_error;
    struct source src = {.fp = fp, .ctx = ctx, .size = size};
    /* libxml2 reports some errors (encoding conversion, I/O) through its per-thread generic
     * handler, which prints on stderr; a library does not print: silenced while reading (the
     * parse fails with its own message) and given back after. */
    xmlGenericErrorFunc saved_fn = xmlGenericError;
    void *saved_ctx = xmlGenericErrorContext;
    xmlSetGenericErrorFunc(NULL, silent);
    if (!(r->pctxt = xmlCreateIOParserCtxt(&sax, r, source_read, NULL, &src,
                                                  XML_CHAR_ENCODING_NONE)) || !r->b->path) {
        r->status = bsti_error(ctx, BST_ENOMEM, "%s: out of memory starting the XML parser", path);
    } else {
        xmlCtxtUseOptions(r->pctxt, XML_PARSE_HUGE | XML_PARSE_NONET);
        int e = xmlParseDocument(r->pctxt);
        /* what libxml2 calls "Document is empty" or an encoding error, said as it is; emptiness
         * as read, not as stat says it (a /proc file has size 0 and text) */
        if (src.utf32)
            r->status = bsti_error(ctx, BST_EFORMAT, "%s: UTF-32 text; BSDF XML is read in UTF-8 or "
                                  "UTF-16 (iconv -f UTF-32 -t UTF-8 converts it)", path);
        else if (src.done == 0 && !src.err)
            r->status = bsti_error(ctx, BST_EFORMAT, "%s: the file is empty", path);
        if (r->status >= 0 && src.err)
            r->status = bsti_error(ctx, BST_EIO, "%s: read error: %s", path, strerror(src.err));
        if (r->status >= 0 && (e || !r->pctxt->wellFormed))
            r->status = bsti_error(ctx, BST_EFORMAT, "%s: malformed or truncated XML", path);
        bsti_progress(ctx, 1.0, "reading");
    }
    xmlSetGenericErrorFunc(saved_ctx, saved_fn);
    if (r->pctxt) {
        /* An internal DTD subset makes libxml2 build a document to hold it, even under SAX. */
        if (r->pctxt->myDoc)
            xmlFreeDoc(r->pctxt->myDoc);
        xmlFreeParserCtxt(r->pctxt);
    }
}

/* What the parse left checked: channels found, a basis, and the components the file lacks told
 * in note (completed by reciprocity or as zero). */
static int check_read(struct reader *r, const bst_bsdf_read_opts *opts, char *note, size_t size)
{
    bst_ctx *ctx = r->ctx;
    const char *path = r->path;
    bst_bsdf *b = r->b;
    int rc = r->status;
    if (rc >= 0) {
        /* the kind of the blocks read, not of the last <IncidentDataStructure> seen */
        b->kind = r->kind < 0 ? BST_FILE_KLEMS : (bst_file_kind)r->kind;
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
    unsigned comps = opts && opts->comps ? opts->comps : BST_COMP_ALL;
    for (size_t ch = 0; rc >= 0 && ch < b->nch; ch++) {
        for (int c = 0; c < BST_NCOMP; c++) {
            if (!(comps & BST_COMP_BIT(c)) || bsti_bsdf_stored(b, ch, c))
                continue;
            int other = bsti_bsdf_reciprocal(c);
            const char *how = other >= 0 && bsti_bsdf_stored(b, ch, other) ? "from reciprocity" : "as zero";
            size_t len = strlen(note);
            snprintf(note + len, size - len, "%s%s %s %s", len ? "; " : "", b->channels[ch],
                     bst_comp_name((bst_comp)c), how);
        }
    }
    return rc;
}

/* What was read other than stated (note: completed components), in one warning. */
static int read_warning(bst_ctx *ctx, const char *path, bst_bsdf *b, const char *note,
                        size_t negatives)
{
    char warn[512] = "";
    if (note[0])
        snprintf(warn, sizeof warn, "not in the file, completed: %s", note);
    b->depth = b->kind == BST_FILE_KLEMS ? 0 : b->k;
    b->negatives = negatives;
    if (b->kind != BST_FILE_KLEMS && b->k > BST_K_MAX) {
        size_t len = strlen(warn);
        snprintf(warn + len, sizeof warn - len, "%sa tensor tree of depth %d, read at k = %d (its "
                 "finest cells averaged)", len ? "; " : "", b->k, BST_K_MAX);
        b->k = BST_K_MAX;
    }
    if (negatives) {
        size_t len = strlen(warn);
        snprintf(warn + len, sizeof warn - len, "%s%zu negative value%s read as 0 (as libBSDF does)",
                 len ? "; " : "", negatives, negatives > 1 ? "s" : "");
    }
    if (warn[0])
        return bsti_error(ctx, BST_WDATA, "%s: %s", path, warn);
    return BST_OK;
}

int bst_bsdf_read(bst_ctx *ctx, const char *path, const bst_bsdf_read_opts *opts, bst_bsdf **out)
{
    if (!ctx || !out)
        return ctx ? bsti_error(ctx, BST_EINVAL, "read: NULL argument") : BST_EINVAL;
    *out = NULL;
    if (!path)
        return bsti_error(ctx, BST_EINVAL, "read: no file name");
    bst_precision prec = opts ? opts->precision : BST_DOUBLE;
    if (prec != BST_DOUBLE && prec != BST_FLOAT)
        return bsti_error(ctx, BST_EINVAL, "read: unknown precision %d", (int)prec);
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return bsti_error(ctx, BST_EIO, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    int known = fstat(fileno(fp), &st) == 0;
    double size = known && st.st_size > 0 ? (double)st.st_size : 1.0;
    if (known && S_ISDIR(st.st_mode)) { /* opened, but no read gives anything */
        fclose(fp);
        return bsti_error(ctx, BST_EIO, "%s: a directory, not a BSDF XML file", path);
    }
    struct reader r = {.ctx = ctx, .path = path, .opts = opts, .comp = -1, .kind = -1};
    r.b = bsti_calloc(ctx, 1, sizeof *r.b);
    if (!r.b) {
        fclose(fp);
        return BST_ENOMEM;
    }
    r.b->ctx = ctx;
    r.b->prec = prec;
    r.b->path = bsti_strdup(ctx, path);
    parse(&r, fp, size);
    fclose(fp);
    bsti_tparse_free(r.tp);
    bsti_free(ctx, r.km);
    char note[256] = "";
    int rc = check_read(&r, opts, note, sizeof note);
    bst_bsdf *b = r.b;
    if (rc < 0) {
        bst_bsdf_free(b);
        return rc;
    }
    *out = b;
    return read_warning(ctx, path, b, note, r.negatives);
}

bst_file_kind bst_bsdf_kind(const bst_bsdf *b) { return b->kind; }
int bst_bsdf_order(const bst_bsdf *b) { return b->kind == BST_FILE_KLEMS ? 0 : b->k; }
int bst_bsdf_depth(const bst_bsdf *b) { return b->depth; }
int bst_bsdf_set_precision(bst_ctx *ctx, bst_bsdf *b, bst_precision prec)
{
    if (!ctx || !b || (prec != BST_DOUBLE && prec != BST_FLOAT))
        return ctx ? bsti_error(ctx, BST_EINVAL, "set_precision: NULL BSDF or unknown precision %d",
                                (int)prec) : BST_EINVAL;
    b->prec = prec;
    return BST_OK;
}
int bst_bsdf_set_rank3_rule(bst_ctx *ctx, bst_bsdf *b, bst_rank3_rule rule)
{
    if (!ctx || !b || (rule != BST_RANK3_EXACT && rule != BST_RANK3_NATIVE))
        return ctx ? bsti_error(ctx, BST_EINVAL, "set_rank3_rule: NULL BSDF or unknown rule %d",
                                (int)rule) : BST_EINVAL;
    b->rank3 = rule;
    return BST_OK;
}
bst_rank3_rule bst_bsdf_rank3_rule(const bst_bsdf *b) { return b->rank3; }
double bst_bsdf_fill(const bst_bsdf *b, size_t ch, bst_comp c)
{
    if (ch >= b->nch || (unsigned)c >= BST_NCOMP)
        return 0.0;
    int from = bsti_bsdf_stored(b, ch, c) ? (int)c : bsti_bsdf_reciprocal(c);
    if (from < 0 || !bsti_bsdf_stored(b, ch, from))
        return 0.0;
    if (b->tree[ch][from])
        return b->tree[ch][from]->dim == 4 ? bsti_ttree_fill(b->tree[ch][from]) : 1.0;
    return 1.0;
}
size_t bst_bsdf_negatives(const bst_bsdf *b) { return b->negatives; }
const bst_basis *bst_bsdf_klems_basis(const bst_bsdf *b) { return b->klems; }
size_t bst_bsdf_nchannels(const bst_bsdf *b) { return b->nch; }
const char *bst_bsdf_channel(const bst_bsdf *b, size_t ch) { return ch < b->nch ? b->channels[ch] : NULL; }
int bst_bsdf_stored(const bst_bsdf *b, size_t ch, bst_comp c)
{
    return ch < b->nch && (unsigned)c < BST_NCOMP && bsti_bsdf_stored(b, ch, c);
}
