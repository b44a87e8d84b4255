/* test_write.c - writing BSDF XML: the tensor-tree emitter against an independent parser and
 * RADIANCE's worked examples (CONVENTIONS.md 12), reduction and its reported error, the XML writer
 * against the reference files (round trips, directional-hemispherical tables, Klems conversions,
 * sizes), rank-3 selection, metadata, and every error path. */
#include <config.h>

#include <dirent.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <libxml/parser.h>
#include <libxml/tree.h>

#include "testutil.h"
#include "ttree_write.h"

static bst_ctx *ctx;
static void setup(void) { ctx = bst_ctx_new(); }
static void teardown(void) { bst_ctx_free(ctx); }

/* ------------------------------------------------------------------ helpers */

/* Output collected in memory; fails once more than `limit` bytes were offered (0 = never). */
struct membuf {
    char *p;
    size_t n, cap, limit;
    int calls;
};

static int mem_write(const char *buf, size_t len, void *opaque)
{
    struct membuf *m = opaque;
    m->calls++;
    if (m->limit && m->n + len > m->limit)
        return -1;
    if (m->n + len + 1 > m->cap) {
        m->cap = (m->n + len + 1) * 2;
        m->p = realloc(m->p, m->cap);
        ck_assert_ptr_nonnull(m->p);
    }
    memcpy(m->p + m->n, buf, len);
    m->n += len;
    m->p[m->n] = '\0';
    return 0;
}

static char *tree_text(const bsti_tensor *t, double pct, bsti_tree_stats *st)
{
    struct membuf m = {0};
    bsti_sink *s = malloc(sizeof *s);
    bsti_sink_init(s, mem_write, &m);
    bsti_reduce r = {pct, BST_REDUCE_FLOOR, 0};
    int rc = bsti_ttree_write(ctx, t, &r, s, st);
    ck_assert_msg(rc == BST_OK, "tree write: %s", bst_ctx_message(ctx));
    ck_assert_int_eq(bsti_sink_flush(s), 0);
    free(s);
    return m.p;
}

/* An independent reader of tree text (recursive descent on the string): fills grid (G^dim values,
 * row-major with dimension 0 slowest) and returns the depth, or -1 on a syntax error. */
struct pt {
    const char *s;
    int dim;
    size_t G;
    double *grid;
    size_t leaves, values;
    int depth;
};

static void skip(struct pt *p)
{
    while (*p->s == ' ' || *p->s == '\n' || *p->s == '\t' || *p->s == ',' || *p->s == '\r')
        p->s++;
}

static int pt_node(struct pt *p, const size_t *corner, size_t side, int depth)
{
    skip(p);
    if (*p->s != '{')
        return -1;
    p->s++;
    skip(p);
    if (*p->s == '{') { /* branch: child n covers the upper half of dimension i when bit i is set */
        if (side < 2)
            return -1;
        for (int n = 0; n < (1 << p->dim); n++) {
            size_t c[4];
            for (int i = 0; i < p->dim; i++)
                c[i] = corner[i] + ((size_t)((n >> i) & 1)) * (side / 2);
            if (pt_node(p, c, side / 2, depth + 1) < 0)
                return -1;
        }
    } else { /* leaf: g^dim values, dimension 0 slowest */
        double v[4096];
        size_t nv = 0;
        while (*p->s && *p->s != '}') {
            char *end;
            v[nv] = strtod(p->s, &end);
            if (end == p->s || nv >= 4095)
                return -1;
            nv++;
            p->s = end;
            skip(p);
        }
        size_t g = 1;
        int lv = 0;
        for (;;) {
            size_t cells = 1;
            for (int i = 0; i < p->dim; i++)
                cells *= g;
            if (cells == nv)
                break;
            if (cells > nv || g > side)
                return -1;
            g *= 2, lv++;
        }
        if (g > side)
            return -1;
        size_t rep = side / g;
        for (size_t j = 0; j < nv; j++) {
            size_t cell[4], q = j;
            for (int i = p->dim - 1; i >= 0; i--) {
                cell[i] = corner[i] + (q % g) * rep;
                q /= g;
            }
            size_t r0, r1, r2, r3, nr3 = p->dim == 4 ? rep : 1;
            for (r0 = 0; r0 < rep; r0++)
                for (r1 = 0; r1 < rep; r1++)
                    for (r2 = 0; r2 < rep; r2++)
                        for (r3 = 0; r3 < nr3; r3++) {
                            size_t idx = ((cell[0] + r0) * p->G + cell[1] + r1) * p->G + cell[2] + r2;
                            if (p->dim == 4)
                                idx = idx * p->G + cell[3] + r3;
                            p->grid[idx] = (double)(float)v[j]; /* readers store floats */
                        }
        }
        p->leaves++;
        p->values += nv;
        if (depth + lv > p->depth)
            p->depth = depth + lv;
    }
    skip(p);
    if (*p->s != '}')
        return -1;
    p->s++;
    return 0;
}

static int parse_tree(const char *text, int dim, int k, double *grid, size_t *leaves, size_t *values)
{
    struct pt p = {text, dim, (size_t)1 << k, grid, 0, 0, 0};
    size_t corner[4] = {0, 0, 0, 0};
    if (pt_node(&p, corner, p.G, 0) < 0)
        return -1;
    skip(&p);
    if (*p.s)
        return -1;
    if (leaves)
        *leaves = p.leaves, *values = p.values;
    return p.depth;
}

/* The ScatteringData text of a (reference) file. */
static char *scattering_data(const char *path)
{
    FILE *fp = fopen(path, "r");
    ck_assert_ptr_nonnull(fp);
    static char buf[1 << 16];
    size_t n = fread(buf, 1, sizeof buf - 1, fp);
    fclose(fp);
    buf[n] = '\0';
    char *a = strstr(buf, "<ScatteringData>"), *b = strstr(buf, "</ScatteringData>");
    ck_assert(a && b);
    *b = '\0';
    return a + strlen("<ScatteringData>");
}

/* Whitespace-normalised token list ("{", "}", numbers as %.9g) of tree text. */
static char *tokens(const char *s)
{
    size_t cap = strlen(s) * 2 + 16, n = 0;
    char *out = malloc(cap);
    while (*s) {
        if (*s == '{' || *s == '}') {
            n += (size_t)snprintf(out + n, cap - n, "%c ", *s++);
        } else if (*s == ' ' || *s == '\n' || *s == '\t' || *s == '\r' || *s == ',') {
            s++;
        } else {
            char *end;
            double v = strtod(s, &end);
            ck_assert_ptr_ne(end, s);
            n += (size_t)snprintf(out + n, cap - n, "%.9g ", v);
            s = end;
        }
    }
    return out;
}

static char *tmp_path(const char *tag)
{
    static char path[256];
    snprintf(path, sizeof path, "/tmp/bst_write_%s_XXXXXX", tag);
    int fd = mkstemp(path);
    ck_assert_int_ge(fd, 0);
    close(fd);
    return path;
}

static bst_bsdf *read_ok(const char *path)
{
    bst_bsdf *b;
    int rc = bst_bsdf_read(ctx, path, NULL, &b);
    ck_assert_msg(rc >= 0, "%s: %s", path, bst_ctx_message(ctx));
    return b;
}

static bst_layer *layer_of(const bst_bsdf *b, const bst_basis *target)
{
    bst_layer *l;
    int rc = bst_bsdf_to_layer(ctx, b, target, &l);
    ck_assert_msg(rc >= 0, "to_layer: %s", bst_ctx_message(ctx));
    return l;
}

static void write_ok(const bst_layer *l, const char *path, const bst_write_opts *o)
{
    int rc = bst_xml_write_path(ctx, l, path, o);
    ck_assert_msg(rc == BST_OK, "write %s: %s", path, bst_ctx_message(ctx));
}

static long file_size(const char *path)
{
    struct stat st;
    ck_assert_int_eq(stat(path, &st), 0);
    return (long)st.st_size;
}

/* Every element of two layers' component c equal (rtol relative to the component's largest). */
static double max_diff(const bst_layer *a, const bst_layer *b, size_t ch, bst_comp c)
{
    const bst_mat *x = bst_layer_get(a, ch, c), *y = bst_layer_get(b, ch, c);
    size_t n = bst_basis_size(bst_layer_basis(a));
    double d = 0;
    for (size_t i = 0; i < n; i++)
        for (size_t o = 0; o < n; o++)
            d = fmax(d, fabs((x ? bst_mat_get(x, o, i) : 0) - (y ? bst_mat_get(y, o, i) : 0)));
    return d;
}

/* Collects on_block reports. */
struct reports {
    bst_write_block b[64];
    int n;
};
static void collect(const bst_write_block *b, void *opaque)
{
    struct reports *r = opaque;
    if (r->n < 64)
        r->b[r->n++] = *b;
}

/* ------------------------------------------------------------------ number text */

START_TEST(test_format)
{
    char buf[32];
    float back;
    double dback;
    static const struct { double v; const char *want; } cases[] = {
        {141.4, "141.4"}, {0.1, "0.1"}, {1e-30, "1e-30"}, {0, "0"}, {287.0, "287"},
        {1.684e+02, "168.4"}, {3e38, "3e+38"}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        bsti_format_float(cases[i].v, 0, buf, &back);
        ck_assert_str_eq(buf, cases[i].want);
        ck_assert(back == (float)cases[i].v);
    }
    bsti_format_float(3.14159, 3, buf, &back);
    ck_assert_str_eq(buf, "3.14");
    ck_assert(back == 3.14f);
    tu_rng r;
    tu_rng_seed(&r, 7);
    for (int i = 0; i < 20000; i++) {
        double v = exp(tu_rng_uniform(&r) * 120 - 60) * (tu_rng_uniform(&r) < 0.5 ? 1 : 3.7);
        int len = bsti_format_float(v, 0, buf, &back);
        ck_assert(strtof(buf, NULL) == (float)v && back == (float)v);
        ck_assert_int_le(len, 15);
        /* shortest: one significant digit less does not read back */
        int digits = 0;
        for (const char *p = buf; *p && *p != 'e'; p++)
            digits += *p >= '0' && *p <= '9';
        for (const char *p = buf; *p == '0' || *p == '.'; p++)
            digits -= *p == '0';
        char shorter[400];
        if (digits > 1) {
            snprintf(shorter, sizeof shorter, "%.*g", digits - 1, (double)(float)v);
            ck_assert_msg(strtof(shorter, NULL) != (float)v, "%s is not the shortest (%s)", buf, shorter);
        }
        len = bsti_format_double(v, 0, buf, &dback);
        ck_assert(strtod(buf, NULL) == v && dback == v);
        ck_assert_int_le(len, 24);
    }
    bsti_format_double(1.0 / 3.0, 0, buf, &dback);
    ck_assert(strtod(buf, NULL) == 1.0 / 3.0);
    bsti_format_double(0.25, 0, buf, &dback);
    ck_assert_str_eq(buf, "0.25");
}
END_TEST

/* ------------------------------------------------------------------ emitter: worked examples */

/* CONVENTIONS.md 12.1 and 12.2: the hand-made rank-4 trees, rebuilt from their description as full
 * tensors, must come out as exactly the example files' text (the bit-order trap: branch children
 * with dimension 0 lowest, leaf values with dimension 0 slowest). */
START_TEST(test_examples_rank4)
{
    double t1[16], t2[256];
    for (int i = 0; i < 16; i++)
        t1[i] = i + 1; /* value number 8 b0 + 4 b1 + 2 b2 + b3 (+1) = full tensor order at k = 1 */
    bsti_tensor a = {4, 1, t1, NULL, NULL, NULL};
    char *got = tree_text(&a, -1, NULL);
    char *x = tokens(got), *y = tokens(scattering_data(tu_ref("examples/k1_4d_TF.xml")));
    ck_assert_str_eq(x, y);
    free(got), free(x), free(y);
    /* k = 2: child c = sum (cell_i >> 1) << i, leaf index = sum (cell_i & 1) << (3 - i) */
    for (size_t c0 = 0; c0 < 4; c0++)
        for (size_t c1 = 0; c1 < 4; c1++)
            for (size_t c2 = 0; c2 < 4; c2++)
                for (size_t c3 = 0; c3 < 4; c3++) {
                    int child = (int)((c0 >> 1) | (c1 >> 1) << 1 | (c2 >> 1) << 2 | (c3 >> 1) << 3);
                    int leaf = (int)((c0 & 1) << 3 | (c1 & 1) << 2 | (c2 & 1) << 1 | (c3 & 1));
                    t2[((c0 * 4 + c1) * 4 + c2) * 4 + c3] = 100 * (child + 1) + leaf + 1;
                }
    bsti_tensor b = {4, 2, t2, NULL, NULL, NULL};
    got = tree_text(&b, -1, NULL);
    x = tokens(got), y = tokens(scattering_data(tu_ref("examples/k2_4d_TF.xml")));
    ck_assert_str_eq(x, y);
    free(got), free(x), free(y);
}
END_TEST

/* CONVENTIONS.md 12.3: rank 3 at k = 2.  The emitter writes only the live lower half of p0: the
 * even children equal the example's, the odd (unreachable) ones are zero. */
START_TEST(test_examples_rank3)
{
    double t[2 * 4 * 4];
    for (size_t c0 = 0; c0 < 2; c0++)
        for (size_t c1 = 0; c1 < 4; c1++)
            for (size_t c2 = 0; c2 < 4; c2++) {
                int child = (int)((c0 >> 1) | (c1 >> 1) << 1 | (c2 >> 1) << 2);
                int leaf = (int)((c0 & 1) << 2 | (c1 & 1) << 1 | (c2 & 1));
                t[(c0 * 4 + c1) * 4 + c2] = 100 * (child + 1) + leaf + 1;
            }
    bsti_tensor a = {3, 2, t, NULL, NULL, NULL};
    char *got = tree_text(&a, -1, NULL);
    char *x = tokens(got);
    ck_assert_str_eq(x, "{ { 101 102 103 104 105 106 107 108 } { 0 } "
                        "{ 301 302 303 304 305 306 307 308 } { 0 } "
                        "{ 501 502 503 504 505 506 507 508 } { 0 } "
                        "{ 701 702 703 704 705 706 707 708 } { 0 } } ");
    /* the example file's even children are the same leaves */
    char *y = tokens(scattering_data(tu_ref("examples/k2_3d_TF.xml")));
    ck_assert_ptr_nonnull(strstr(y, "{ 701 702 703 704 705 706 707 708 }"));
    ck_assert_ptr_nonnull(strstr(y, "{ 101 102 103 104 105 106 107 108 }"));
    free(got), free(x), free(y);
}
END_TEST

/* The emitted k = 2 trees in an XML file, read by bst_bsdf_read and evaluated at the direction
 * pairs of CONVENTIONS.md 12.2 and 12.3: the stored values of the tables. */
START_TEST(test_examples_read_back)
{
    double t4[256], t3[32];
    for (size_t q = 0; q < 256; q++) {
        size_t c0 = q >> 6, c1 = (q >> 4) & 3, c2 = (q >> 2) & 3, c3 = q & 3;
        int child = (int)((c0 >> 1) | (c1 >> 1) << 1 | (c2 >> 1) << 2 | (c3 >> 1) << 3);
        int leaf = (int)((c0 & 1) << 3 | (c1 & 1) << 2 | (c2 & 1) << 1 | (c3 & 1));
        t4[q] = 100 * (child + 1) + leaf + 1;
    }
    for (size_t q = 0; q < 32; q++) {
        size_t c0 = q >> 4, c1 = (q >> 2) & 3, c2 = q & 3;
        int child = (int)((c1 >> 1) << 1 | (c2 >> 1) << 2);
        int leaf = (int)((c0 & 1) << 2 | (c1 & 1) << 1 | (c2 & 1));
        t3[q] = 100 * (child + 1) + leaf + 1;
    }
    static const struct { int rank; double in[3], out[3], want; } rows[] = {
        {4, {-0.3, -0.4, -0.866}, {0.5, 0.2, 0.8426}, 1607},
        {4, {0.1, -0.6, -0.7937}, {-0.2, 0.7, 0.6856}, 1116},
        {4, {0.7, 0.1, -0.7071}, {0.05, -0.3, 0.9526}, 506},
        {4, {-0.05, 0.02, -0.9985}, {0.04, -0.03, 0.9987}, 606},
        {4, {-0.8, 0.5, -0.3317}, {0.6, 0.55, 0.5809}, 1412},
        {3, {-0.3420, 0, -0.9397}, {0.4162, 0.0734, 0.9063}, 705},
        {3, {-0.3420, 0, -0.9397}, {0.4162, -0.0734, 0.9063}, 306},
        {3, {-0.3420, 0, -0.9397}, {-0.6330, 0.1116, 0.7660}, 505},
        {3, {-0.8660, 0, -0.5}, {0.4162, 0.0734, 0.9063}, 701},
        {3, {0, -0.8660, -0.5}, {-0.0734, 0.4162, 0.9063}, 701},
        {3, {0, -0.8660, -0.5}, {-0.0734, -0.4162, 0.9063}, 503},
        {3, {0.1632, 0.0594, -0.9848}, {0.8138, 0.4698, 0.3420}, 106},
    };
    for (int rank = 3; rank <= 4; rank++) {
        bsti_tensor t = {rank, 2, rank == 4 ? t4 : t3, NULL, NULL, NULL};
        char *text = tree_text(&t, -1, NULL);
        const char *path = tmp_path("ex");
        FILE *fp = fopen(path, "w");
        fprintf(fp, "<?xml version=\"1.0\"?>\n<WindowElement><FileType>BSDF</FileType><Optical><Layer>"
                    "<DataDefinition><IncidentDataStructure>TensorTree%d</IncidentDataStructure>"
                    "</DataDefinition><WavelengthData><Wavelength>Visible</Wavelength>"
                    "<WavelengthDataBlock><WavelengthDataDirection>Transmission Front"
                    "</WavelengthDataDirection><AngleBasis>LBNL/Shirley-Chiu</AngleBasis>"
                    "<ScatteringData>%s</ScatteringData></WavelengthDataBlock></WavelengthData>"
                    "</Layer></Optical></WindowElement>\n", rank, text);
        fclose(fp);
        bst_bsdf *b = read_ok(path);
        for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
            if (rows[i].rank != rank)
                continue;
            double v;
            ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, rows[i].in, rows[i].out, &v), BST_OK);
            ck_assert_msg(v == rows[i].want, "rank %d row %zu: %g vs %g", rank, i, v, rows[i].want);
        }
        bst_bsdf_free(b);
        unlink(path);
        free(text);
    }
}
END_TEST

/* ------------------------------------------------------------------ emitter: exactness, reduction */

/* A random tensor with constant regions of every size (zero and non-zero) and noise. */
static void random_tensor(tu_rng *r, int rank, int k, double *t, size_t n)
{
    size_t G = (size_t)1 << k;
    double c = 0.5 + tu_rng_uniform(r);
    for (size_t q = 0; q < n; q++) {
        size_t c0 = rank == 4 ? q / (G * G * G) : q / (G * G);
        double u = tu_rng_uniform(r);
        if (c0 < G / 4)
            t[q] = 0.0;                  /* large zero region */
        else if (c0 < G / 2 && (q / 16) % 3 == 0)
            t[q] = c;                    /* constant runs */
        else
            t[q] = u < 0.1 ? 0.0 : exp(6 * u - 3); /* noisy, 4 decades */
    }
}

/* Un-reduced: every value comes back exactly (as float), the depth is k, nothing is lost; with
 * float storage and with an accessor the text is the same. */
START_TEST(test_lossless_random)
{
    tu_rng r;
    tu_rng_seed(&r, 11);
    for (int rank = 3; rank <= 4; rank++)
        for (int k = 1; k <= 4; k++) {
            size_t G = (size_t)1 << k, n = rank == 4 ? G * G * G * G : G * G * G / 2;
            size_t full = rank == 4 ? n : G * G * G;
            double *t = malloc(n * sizeof *t), *grid = malloc(full * sizeof *grid);
            float *f = malloc(n * sizeof *f);
            random_tensor(&r, rank, k, t, n);
            for (size_t q = 0; q < n; q++)
                f[q] = (float)t[q];
            bsti_tensor a = {rank, k, t, NULL, NULL, NULL}, b = {rank, k, NULL, f, NULL, NULL};
            bsti_tree_stats st;
            char *text = tree_text(&a, -1, &st), *text_f = tree_text(&b, -1, NULL);
            ck_assert_str_eq(text, text_f);
            size_t leaves, values;
            for (size_t q = 0; q < full; q++)
                grid[q] = NAN;
            int depth = parse_tree(text, rank, k, grid, &leaves, &values);
            ck_assert_int_eq(depth, k);
            ck_assert_uint_eq(leaves, st.leaves);
            ck_assert_uint_eq(values, st.values);
            ck_assert(st.threshold == 0.0);
            for (size_t q = 0; q < full; q++) {
                double want = q < n ? (double)(float)t[q] : 0.0; /* rank 3: upper half of p0 is 0 */
                ck_assert_msg(grid[q] == want, "rank %d k %d cell %zu: %g vs %g", rank, k, q, grid[q], want);
            }
            ck_assert_double_le(st.l1_error, 1e-7); /* float rounding only */
            ck_assert_double_le(st.max_error, 1e-7 * 30);
            ck_assert_uint_eq(st.bytes, strlen(text));
            free(t), free(f), free(grid), free(text), free(text_f);
        }
}
END_TEST

/* Reduction: the finest blocks written whole are at most the (100 - pct) % above the percentile
 * (plus the path that keeps depth k), fewer values as pct grows, depth always k, and the reported
 * errors are those of the text as an independent reader sees it. */
START_TEST(test_reduce)
{
    tu_rng r;
    tu_rng_seed(&r, 5);
    const int k = 4;
    const size_t G = 16, n = G * G * G * G;
    double *t = malloc(n * sizeof *t), *grid = malloc(n * sizeof *grid);
    /* smooth lobe along the diagonal plus Poisson-like noise, 10 % zero cells */
    for (size_t q = 0; q < n; q++) {
        size_t c0 = q >> 12, c1 = (q >> 8) & 15, c2 = (q >> 4) & 15, c3 = q & 15;
        double d2 = pow((double)c0 - (double)c2, 2) + pow((double)c1 - (double)c3, 2);
        double mean = 0.2 + 40 * exp(-d2 / 4);
        double u = tu_rng_uniform(&r);
        t[q] = u < 0.1 ? 0.0 : mean * (1 + 0.3 * sqrt(1 / (mean + 1)) * (tu_rng_uniform(&r) - 0.5));
    }
    bsti_tensor a = {4, k, t, NULL, NULL, NULL};
    size_t last_values = SIZE_MAX;
    static const double pcts[] = {0, 50, 90, 99};
    for (size_t p = 0; p < 4; p++) {
        bsti_tree_stats st;
        char *text = tree_text(&a, pcts[p], &st);
        size_t leaves, values;
        ck_assert_int_eq(parse_tree(text, 4, k, grid, &leaves, &values), k);
        size_t nblocks = n / 16;
        ck_assert_uint_eq(st.blocks, nblocks);
        ck_assert_uint_le(st.blocks_kept, (size_t)ceil((1 - pcts[p] / 100) * nblocks) + 1);
        ck_assert_uint_le(values, last_values);
        last_values = values;
        /* errors recomputed from the parsed text */
        double sa = 0, se = 0, me = 0, hemi[256] = {0}, hmax = 0;
        for (size_t q = 0; q < n; q++) {
            double e = t[q] - grid[q];
            sa += fabs(t[q]), se += fabs(e), me = fmax(me, fabs(e));
            hemi[q >> 8] += e;
        }
        for (int i = 0; i < 256; i++)
            hmax = fmax(hmax, fabs(hemi[i]) * M_PI / 256);
        tu_assert_close(st.l1_error, se / sa, 1e-9, 1e-12);
        tu_assert_close(st.max_error, me, 1e-9, 1e-12);
        tu_assert_close(st.hemi_error, hmax, 1e-6, 1e-9);
        if (pcts[p] == 0)
            ck_assert_double_le(st.l1_error, 1e-7); /* only exact constants merged */
        else
            ck_assert_double_gt(st.l1_error, 1e-6);
        printf("reduce %2.0f %%: %5zu values (%4.1f %%), %zu of %zu blocks kept, L1 error %.2e, "
               "max %.2e, hemispherical %.2e\n", pcts[p], values, 100.0 * values / n,
               st.blocks_kept, nblocks, st.l1_error, st.max_error, st.hemi_error);
        free(text);
    }
    free(t), free(grid);
}
END_TEST

/* A constant or zero tensor still reaches depth k (readers take k from the depth). */
START_TEST(test_constant_depth)
{
    double t[4096];
    for (int rank = 3; rank <= 4; rank++)
        for (int k = 1; k <= 3; k++) {
            size_t G = (size_t)1 << k, n = rank == 4 ? G * G * G * G : G * G * G / 2;
            for (size_t q = 0; q < n; q++)
                t[q] = 2.5 * (rank - 3);
            bsti_tensor a = {rank, k, t, NULL, NULL, NULL};
            double grid[4096];
            for (int red = 0; red < 2; red++) {
                char *text = tree_text(&a, red ? 90 : -1, NULL);
                ck_assert_int_eq(parse_tree(text, rank, k, grid, NULL, NULL), k);
                for (size_t q = 0; q < n; q++)
                    ck_assert(grid[q] == t[q]);
                free(text);
            }
        }
}
END_TEST

static int failing_after(const char *buf, size_t len, void *opaque)
{
    (void)buf;
    size_t *left = opaque;
    if (len > *left)
        return -1;
    *left -= len;
    return 0;
}

START_TEST(test_tree_errors)
{
    double t[256] = {0};
    t[17] = NAN;
    bsti_tensor a = {4, 2, t, NULL, NULL, NULL};
    struct membuf m = {0};
    bsti_sink *s = malloc(sizeof *s);
    bsti_sink_init(s, mem_write, &m);
    bsti_reduce r = {90, BST_REDUCE_FLOOR, 0};
    ck_assert_int_eq(bsti_ttree_write(ctx, &a, &r, s, NULL), BST_EINVAL);
    ck_assert_uint_eq(s->total, 0); /* nothing written */
    t[17] = 1e39;                   /* beyond single precision */
    ck_assert_int_eq(bsti_ttree_write(ctx, &a, &r, s, NULL), BST_EINVAL);
    t[17] = 1.0;
    bsti_tensor bad = {5, 2, t, NULL, NULL, NULL};
    ck_assert_int_eq(bsti_ttree_write(ctx, &bad, &r, s, NULL), BST_EINVAL);
    bsti_reduce badr = {100, BST_REDUCE_FLOOR, 0};
    ck_assert_int_eq(bsti_ttree_write(ctx, &a, &badr, s, NULL), BST_EINVAL);
    /* a sink that fails part way (a k = 4 tree is larger than the sink's buffer) */
    double *big = malloc(65536 * sizeof *big);
    tu_rng rng;
    tu_rng_seed(&rng, 3);
    for (int i = 0; i < 65536; i++)
        big[i] = tu_rng_uniform(&rng);
    bsti_tensor b = {4, 4, big, NULL, NULL, NULL};
    size_t left = 70000; /* the exact tree is about 10 times longer */
    bsti_sink_init(s, failing_after, &left);
    bsti_reduce exact = {-1, BST_REDUCE_FLOOR, 0};
    int rc = bsti_ttree_write(ctx, &b, &exact, s, NULL);
    ck_assert_int_eq(rc, BST_EIO);
    /* allocation failures: every one reported, nothing leaked */
    for (long fail = 1; fail <= 4; fail++) {
        tu_alloc al = {fail, 0, 0};
        bst_ctx *c2 = bst_ctx_new();
        bst_ctx_set_allocator(c2, tu_alloc_malloc, tu_alloc_free, &al);
        bsti_sink_init(s, mem_write, &m);
        rc = bsti_ttree_write(c2, &b, &r, s, NULL);
        if (al.count >= fail)
            ck_assert_int_eq(rc, BST_ENOMEM);
        else
            ck_assert_int_eq(rc, BST_OK);
        bst_ctx_free(c2);
        ck_assert_int_eq(al.live, 0);
    }
    free(big), free(s), free(m.p);
}
END_TEST

/* ------------------------------------------------------------------ XML writer: reference files */

/* Tensor trees at their own k: read, write (with and without reduction), read back.  Without
 * reduction every matrix comes back exactly; the reference files are RADIANCE-reduced already, so
 * the 90 % culling finds >= 90 % of the finest blocks constant and is exact too (threshold 0). The
 * Transmission Front is left out (reciprocal) and rebuilt by the reader exactly.  File sizes are
 * compared with RADIANCE's. */
START_TEST(test_reference_round_trip)
{
    static const char *const names[] = {"L_glass_t4k5", "L_blind0_t4k5", "L_blind45_t4k5"};
    char file[64];
    snprintf(file, sizeof file, "%s.xml", names[_i]);
    bst_bsdf *b = read_ok(tu_ref(file));
    bst_layer *l = layer_of(b, NULL);
    for (int red = 0; red < 2; red++) {
        bst_write_opts o;
        bst_write_opts_init(&o);
        struct reports rep = {.n = 0};
        o.on_block = collect, o.opaque = &rep;
        if (!red)
            o.reduce_pct = -1;
        const char *path = tmp_path("rt");
        write_ok(l, path, &o);
        bst_bsdf *b2 = read_ok(path);
        ck_assert_int_eq(bst_bsdf_kind(b2), BST_FILE_TT4);
        ck_assert_int_eq(bst_bsdf_order(b2), 5);
        ck_assert(!bst_bsdf_stored(b2, 0, BST_TF) && bst_bsdf_stored(b2, 0, BST_TB));
        bst_layer *l2 = layer_of(b2, NULL);
        for (int c = 0; c < BST_NCOMP; c++)
            ck_assert_msg(max_diff(l, l2, 0, (bst_comp)c) == 0.0, "%s %s differs", names[_i],
                          bst_comp_name((bst_comp)c));
        ck_assert_int_eq(rep.n, 4);
        ck_assert(!rep.b[BST_TF].written);
        for (int c = 1; c < 4; c++)
            ck_assert(rep.b[c].written && rep.b[c].threshold == 0.0 && rep.b[c].l1_error == 0.0);
        long ours = file_size(path), theirs = file_size(tu_ref(file));
        printf("%s %s: %ld bytes (RADIANCE %ld, ratio %.2f)\n", names[_i],
               red ? "reduced 90 %" : "exact", ours, theirs, (double)ours / theirs);
        ck_assert_double_le((double)ours, 1.5 * (double)theirs);
        bst_layer_free(l2), bst_bsdf_free(b2);
        unlink(path);
    }
    bst_layer_free(l), bst_bsdf_free(b);
}
END_TEST

/* T and R of a file for one hemi.tsv row, over a 64 x 64 grid of outgoing cell centres, and the
 * outgoing distributions for the accordance. */
static void hemi_row(bst_bsdf *b, const bst_basis *g, int front, double th, double ph, double *t,
                     double *r, double *tv, double *rv)
{
    double d = M_PI / 180;
    double prop[3] = {sin(th * d) * cos(ph * d), sin(th * d) * sin(ph * d), (front ? 1 : -1) * cos(th * d)};
    double in[3];
    for (int q = 0; q < 3; q++)
        in[q] = round(-prop[q] * 1e12) / 1e12; /* as the table was made (see test_xml.c) */
    *t = *r = 0;
    for (size_t o = 0; o < 4096; o++) {
        double c[3], out[3];
        bst_basis_center(g, o, c);
        out[0] = c[0], out[1] = c[1], out[2] = (front ? 1 : -1) * c[2];
        ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, in, out, &tv[o]), BST_OK);
        out[2] = -out[2];
        ck_assert_int_eq(bst_bsdf_eval(ctx, b, 0, in, out, &rv[o]), BST_OK);
        *t += tv[o] * M_PI / 4096, *r += rv[o] * M_PI / 4096;
    }
}

static double accordance(const double *a, const double *b, size_t n)
{
    double d = 0, s = 0;
    for (size_t i = 0; i < n; i++)
        d += fabs(a[i] - b[i]), s += a[i] + b[i];
    return s > 0 ? 100 * (1 - d / s) : 100;
}

/* Every reference layer written as a (reduced) tree at its own k: directional-hemispherical T and
 * R at the hemi.tsv directions within 1e-3 of RADIANCE's table, and global accordance >= 99.9 with
 * the original over the outgoing grid.  The rank-3 diffuser is written as rank 3 from its file. */
START_TEST(test_reference_hemi)
{
    static const char *const names[] = {"L_glass_t4k5", "L_blind0_t4k5", "L_blind45_t4k5",
                                        "L_diffuser_t3k5"};
    char file[64], tsv[64];
    snprintf(file, sizeof file, "%s.xml", names[_i]);
    snprintf(tsv, sizeof tsv, "%s.hemi.tsv", names[_i]);
    bst_bsdf *b = read_ok(tu_ref(file));
    bst_layer *l = layer_of(b, NULL);
    bst_write_opts o;
    bst_write_opts_init(&o);
    o.rank3_source = b;
    const char *path = tmp_path("hemi");
    write_ok(l, path, &o);
    bst_bsdf *b2 = read_ok(path);
    ck_assert_int_eq(bst_bsdf_kind(b2), bst_bsdf_kind(b));
    long ours = file_size(path), theirs = file_size(tu_ref(file));
    ck_assert_double_le((double)ours, 1.5 * (double)theirs);
    bst_basis *g;
    ck_assert_int_eq(bst_basis_new_sc(ctx, 6, &g), BST_OK);
    FILE *fp = fopen(tu_ref(tsv), "r");
    ck_assert_ptr_nonnull(fp);
    char line[512];
    int rows = 0;
    double worst_dt = 0, worst_ga = 100;
    static double tv[4096], rv[4096], tv0[4096], rv0[4096];
    while (fgets(line, sizeof line, fp)) {
        double th, ph, t_ref, r_ref, t, r, t0, r0;
        char side[32];
        if (line[0] == '#' || sscanf(line, "%31s %*s %lf %lf %lf %lf", side, &th, &ph, &t_ref, &r_ref) != 5)
            continue;
        int front = strncmp(side, "front", 5) == 0;
        hemi_row(b2, g, front, th, ph, &t, &r, tv, rv);
        hemi_row(b, g, front, th, ph, &t0, &r0, tv0, rv0);
        ck_assert_msg(fabs(t - t_ref) <= 1e-3 && fabs(r - r_ref) <= 1e-3, "%s %s %g %g: T %.5f "
                      "vs %.4f, R %.5f vs %.4f", names[_i], side, th, ph, t, t_ref, r, r_ref);
        double ga = fmin(accordance(tv, tv0, 4096), accordance(rv, rv0, 4096));
        ck_assert_msg(ga >= 99.9, "%s %s %g %g: GA %.3f", names[_i], side, th, ph, ga);
        worst_dt = fmax(worst_dt, fmax(fabs(t - t_ref), fabs(r - r_ref)));
        worst_ga = fmin(worst_ga, ga);
        rows++;
    }
    fclose(fp);
    ck_assert_int_eq(rows, 26);
    printf("%s -> tree (90 %% reduction): %ld bytes (RADIANCE %ld, ratio %.2f), hemispherical "
           "T/R off the table by <= %.1e, GA >= %.3f\n", names[_i], ours, theirs,
           (double)ours / theirs, worst_dt, worst_ga);
    bst_basis_free(g), bst_bsdf_free(b2), bst_layer_free(l), bst_bsdf_free(b);
    unlink(path);
}
END_TEST

/* ------------------------------------------------------------------ suite */

static Suite *suite(void)
{
    Suite *s = suite_create("write");
    TCase *tc = tcase_create("tree");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_add_test(tc, test_format);
    tcase_add_test(tc, test_examples_rank4);
    tcase_add_test(tc, test_examples_rank3);
    tcase_add_test(tc, test_examples_read_back);
    tcase_add_test(tc, test_lossless_random);
    tcase_add_test(tc, test_reduce);
    tcase_add_test(tc, test_constant_depth);
    tcase_add_test(tc, test_tree_errors);
    suite_add_tcase(s, tc);
    tc = tcase_create("xml");
    tcase_add_checked_fixture(tc, setup, teardown);
    tcase_set_timeout(tc, 300);
    tcase_add_loop_test(tc, test_reference_round_trip, 0, 3);
    tcase_add_loop_test(tc, test_reference_hemi, 0, 4);
    suite_add_tcase(s, tc);
    return s;
}

int main(void)
{
    return tu_run(suite());
}
