/* xml_write.c - BSDF XML output: TensorTree4 (optionally reduced) for Shirley-Chiu layers and
 * Klems matrices for Klems layers.  File conventions: CONVENTIONS.md 2 (layout), 6 (tree syntax:
 * branch children with dimension 0 the LEAST significant bit, leaf values with dimension 0 the
 * SLOWEST), 7 (Klems "Columns" order).  Our components map onto the XML labels one to one
 * (Front = exterior in both), and our matrix element (o, i) is the tree cell (ix, iy, ox, oy) of
 * i = ix 2^k + iy, o = ox 2^k + oy. */
#include <config.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "basis.h"
#include "ctx.h"
#include "layer.h"

/* rttree_reduce's variation measure: histogram of 300 bins over [0, 4). */
#define VAR_BINS 300
#define VAR_MAX 4.0
#define VAR_FLOOR 0.03

void bst_write_opts_init(bst_write_opts *o)
{
    memset(o, 0, sizeof *o);
    o->reduce_pct = BST_REDUCE_PCT;
}

static double variation(double vmin, double vmax, double vavg)
{
    return sqrt((vmax - vmin) / (sqrt(fmax(vavg, 0.0)) + VAR_FLOOR));
}

static void put_value(FILE *fp, double v, int digits)
{
    if (v == 0.0)
        fputs(" 0", fp);
    else
        fprintf(fp, " %.*g", digits, v);
}

/* Pyramid of node statistics: level l has 16^l nodes indexed by interleaved coordinates. */
struct pyramid {
    int k;
    size_t g, n;
    const double *m;       /* N x N, M[o + N i] */
    float *mn[16], *mx[16], *avg[16];
    double thr;
    int digits;
    FILE *fp;
};

static size_t node_index(int l, const size_t c[4])
{
    size_t s = (size_t)1 << l;
    return ((c[0] * s + c[1]) * s + c[2]) * s + c[3];
}

static double cell(const struct pyramid *p, size_t ix, size_t iy, size_t ox, size_t oy)
{
    return p->m[(ox * p->g + oy) + p->n * (ix * p->g + iy)];
}

static int build_pyramid(bst_ctx *ctx, struct pyramid *p)
{
    for (int l = p->k - 1; l >= 0; l--) {
        size_t cnt = (size_t)1 << (4 * l);
        p->mn[l] = bsti_alloc_array(ctx, cnt, sizeof(float));
        p->mx[l] = bsti_alloc_array(ctx, cnt, sizeof(float));
        p->avg[l] = bsti_alloc_array(ctx, cnt, sizeof(float));
        if (!p->mn[l] || !p->mx[l] || !p->avg[l])
            return BST_ENOMEM;
        size_t s = (size_t)1 << l;
        for (size_t a = 0; a < s; a++)
            for (size_t b = 0; b < s; b++)
                for (size_t e = 0; e < s; e++)
                    for (size_t f = 0; f < s; f++) {
                        size_t c[4] = {a, b, e, f};
                        size_t id = node_index(l, c);
                        double lo = INFINITY, hi = -INFINITY, sum = 0;
                        for (int q = 0; q < 16; q++) {
                            size_t cc[4] = {2 * a + (q >> 3 & 1), 2 * b + (q >> 2 & 1),
                                            2 * e + (q >> 1 & 1), 2 * f + (q & 1)};
                            double v0, v1, va;
                            if (l == p->k - 1) {
                                v0 = v1 = va = cell(p, cc[0], cc[1], cc[2], cc[3]);
                            } else {
                                size_t ci = node_index(l + 1, cc);
                                v0 = p->mn[l + 1][ci], v1 = p->mx[l + 1][ci], va = p->avg[l + 1][ci];
                            }
                            lo = fmin(lo, v0), hi = fmax(hi, v1), sum += va;
                        }
                        p->mn[l][id] = (float)lo, p->mx[l][id] = (float)hi;
                        p->avg[l][id] = (float)(sum / 16.0);
                    }
    }
    return BST_OK;
}

/* Emit node (l, c); l = k - 1 nodes are the finest 2x2x2x2 blocks. */
static void emit(struct pyramid *p, int l, const size_t c[4], int depth)
{
    size_t id = node_index(l, c);
    double var = variation(p->mn[l][id], p->mx[l][id], p->avg[l][id]);
    for (int i = 0; i < depth; i++)
        fputc('\t', p->fp);
    if (var <= p->thr) {
        fputs("{", p->fp);
        put_value(p->fp, p->avg[l][id], p->digits);
        fputs(" }\n", p->fp);
        return;
    }
    if (l == p->k - 1) { /* 16 values, dimension 0 slowest */
        fputs("{", p->fp);
        for (int q = 0; q < 16; q++)
            put_value(p->fp, cell(p, 2 * c[0] + (q >> 3 & 1), 2 * c[1] + (q >> 2 & 1),
                                  2 * c[2] + (q >> 1 & 1), 2 * c[3] + (q & 1)), p->digits);
        fputs(" }\n", p->fp);
        return;
    }
    fputs("{\n", p->fp);
    for (int child = 0; child < 16; child++) { /* dimension 0 least significant */
        size_t cc[4];
        for (int i = 0; i < 4; i++)
            cc[i] = 2 * c[i] + (size_t)((child >> i) & 1);
        emit(p, l + 1, cc, depth + 1);
    }
    for (int i = 0; i < depth; i++)
        fputc('\t', p->fp);
    fputs("}\n", p->fp);
}

static int write_tree(bst_ctx *ctx, FILE *fp, const double *m, int k, const bst_write_opts *o)
{
    size_t g = (size_t)1 << k, n = g * g;
    if (o->reduce_pct < 0) { /* one leaf of every cell: (ix, iy, ox, oy), oy fastest = M[o + N i] */
        int digits = o->digits > 0 ? o->digits : 17;
        fputs("{", fp);
        for (size_t q = 0; q < n * n; q++) {
            put_value(fp, m[q], digits);
            if (q % 16 == 15)
                fputc('\n', fp);
        }
        fputs(" }\n", fp);
        return BST_OK;
    }
    struct pyramid p = {.k = k, .g = g, .n = n, .m = m, .fp = fp, .digits = o->digits > 0 ? o->digits : 4};
    int rc = BST_OK;
    if (k == 0)
        return bsti_error(ctx, BST_EINVAL, "write: a tree needs k >= 1");
    rc = build_pyramid(ctx, &p);
    if (rc >= 0) {
        /* threshold: the reduce_pct-th percentile of the finest blocks' variation */
        size_t hist[VAR_BINS] = {0}, cnt = (size_t)1 << (4 * (k - 1));
        for (size_t q = 0; q < cnt; q++) {
            double v = variation(p.mn[k - 1][q], p.mx[k - 1][q], p.avg[k - 1][q]);
            int bin = (int)(v / VAR_MAX * VAR_BINS);
            hist[bin < 0 ? 0 : bin >= VAR_BINS ? VAR_BINS - 1 : bin]++;
        }
        size_t want = (size_t)(o->reduce_pct / 100.0 * (double)cnt), acc = 0;
        int bin = 0;
        while (bin < VAR_BINS - 1 && acc + hist[bin] <= want)
            acc += hist[bin++];
        p.thr = (double)bin * VAR_MAX / VAR_BINS;
        size_t c[4] = {0, 0, 0, 0};
        emit(&p, 0, c, 0);
    }
    for (int l = 0; l < 16; l++) {
        bsti_free(ctx, p.mn[l]);
        bsti_free(ctx, p.mx[l]);
        bsti_free(ctx, p.avg[l]);
    }
    return rc;
}

static void put_escaped(FILE *fp, const char *s, int comment)
{
    for (; *s; s++) {
        if (comment && s[0] == '-' && s[1] == '-')
            fputs("- ", fp); /* "--" may not appear in an XML comment */
        else if (!comment && *s == '&')
            fputs("&amp;", fp);
        else if (!comment && *s == '<')
            fputs("&lt;", fp);
        else if (!comment && *s == '>')
            fputs("&gt;", fp);
        else
            fputc(*s, fp);
    }
}

int bst_xml_write(bst_ctx *ctx, const bst_layer *l, FILE *fp, const bst_write_opts *opts_in)
{
    if (!ctx || !l || !fp)
        return ctx ? bsti_error(ctx, BST_EINVAL, "write: NULL argument") : BST_EINVAL;
    bst_write_opts o;
    if (opts_in)
        o = *opts_in;
    else
        bst_write_opts_init(&o);
    if (!(o.reduce_pct < 100.0) || isnan(o.reduce_pct))
        return bsti_error(ctx, BST_EINVAL, "write: reduction percentile %g is not below 100", o.reduce_pct);
    if (o.digits < 0 || o.digits > 17)
        return bsti_error(ctx, BST_EINVAL, "write: %d significant digits (1..17)", o.digits);
    const bst_basis *b = l->basis;
    int klems = b->kind == BST_BASIS_KLEMS;
    size_t n = b->n;
    for (size_t ch = 0; ch < l->nchannels; ch++)
        for (int c = 0; c < BST_NCOMP; c++) {
            const bst_mat *m = bst_layer_get(l, ch, (bst_comp)c);
            if (m && !bst_mat_all_finite(m))
                return bsti_error(ctx, BST_EINVAL, "write: %s of channel %s has non-finite values",
                                  bst_comp_name((bst_comp)c), l->channels[ch]);
        }
    double *buf = bsti_alloc_array(ctx, n * n, sizeof *buf);
    if (!buf)
        return BST_ENOMEM;
    char date[64];
    time_t now = time(NULL);
    struct tm tmv;
    strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", gmtime_r(&now, &tmv));
    fputs("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n", fp);
    fprintf(fp, "<!-- Created by bsdfstack %s on %s; basis %s", PACKAGE_VERSION, date, b->name);
    if (!klems)
        fprintf(fp, " k=%d", b->k);
    if (o.description) {
        fputs("\n", fp);
        put_escaped(fp, o.description, 1);
    }
    fputs(" -->\n", fp);
    fputs("<WindowElement xmlns=\"http://windows.lbl.gov\" xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
          "xsi:schemaLocation=\"http://windows.lbl.gov/BSDF-v1.4.xsd\">\n"
          "<WindowElementType>System</WindowElementType>\n<FileType>BSDF</FileType>\n<Optical>\n<Layer>\n"
          "\t<Material>\n\t\t<Name>", fp);
    put_escaped(fp, o.name ? o.name : "bsdfstack system", 0);
    fprintf(fp, "</Name>\n\t\t<Manufacturer>bsdfstack %s</Manufacturer>\n"
            "\t\t<DeviceType>Other</DeviceType>\n\t</Material>\n\t<DataDefinition>\n", PACKAGE_VERSION);
    if (klems) {
        fprintf(fp, "\t\t<IncidentDataStructure>Columns</IncidentDataStructure>\n\t\t<AngleBasis>\n"
                "\t\t\t<AngleBasisName>%s</AngleBasisName>\n", b->name);
        for (size_t i = 0; i < b->nbands; i++)
            fprintf(fp, "\t\t\t<AngleBasisBlock>\n\t\t\t\t<Theta>%g</Theta>\n\t\t\t\t<nPhis>%d</nPhis>\n"
                    "\t\t\t\t<ThetaBounds>\n\t\t\t\t\t<LowerTheta>%g</LowerTheta>\n"
                    "\t\t\t\t\t<UpperTheta>%g</UpperTheta>\n\t\t\t\t</ThetaBounds>\n\t\t\t</AngleBasisBlock>\n",
                    i == 0 ? 0.0 : 0.5 * (b->theta[i] + b->theta[i + 1]), b->nphi[i], b->theta[i],
                    b->theta[i + 1]);
        fputs("\t\t</AngleBasis>\n", fp);
    } else {
        fputs("\t\t<IncidentDataStructure>TensorTree4</IncidentDataStructure>\n", fp);
    }
    fputs("\t</DataDefinition>\n", fp);
    static const char *const dirs[BST_NCOMP] = {"Transmission Front", "Reflection Front",
                                                "Transmission Back", "Reflection Back"};
    static const int order[BST_NCOMP] = {BST_TF, BST_TB, BST_RF, BST_RB};
    int rc = BST_OK;
    for (size_t ch = 0; rc >= 0 && ch < l->nchannels; ch++) {
        const char *name = l->channels[ch];
        int vis = strcasecmp(name, "Visible") == 0;
        for (int q = 0; rc >= 0 && q < BST_NCOMP; q++) {
            int c = order[q];
            const bst_mat *m = bst_layer_get(l, ch, (bst_comp)c);
            if (!m)
                continue;
            fputs("\t<WavelengthData>\n\t\t<LayerNumber>System</LayerNumber>\n", fp);
            fputs("\t\t<Wavelength unit=\"Integral\">", fp);
            put_escaped(fp, name, 0);
            fprintf(fp, "</Wavelength>\n\t\t<SourceSpectrum>%s</SourceSpectrum>\n"
                    "\t\t<DetectorSpectrum>%s</DetectorSpectrum>\n\t\t<WavelengthDataBlock>\n"
                    "\t\t\t<WavelengthDataDirection>%s</WavelengthDataDirection>\n",
                    vis ? "CIE Illuminant D65 1nm.ssp" : "None", vis ? "ASTM E308 1931 Y.dsp" : "None",
                    dirs[c]);
            if (klems)
                fprintf(fp, "\t\t\t<ColumnAngleBasis>%s</ColumnAngleBasis>\n"
                        "\t\t\t<RowAngleBasis>%s</RowAngleBasis>\n", b->name, b->name);
            else
                fputs("\t\t\t<AngleBasis>LBNL/Shirley-Chiu</AngleBasis>\n", fp);
            fputs("\t\t\t<ScatteringDataType>BTDF</ScatteringDataType>\n\t\t\t<ScatteringData>\n", fp);
            rc = bst_mat_to_dense_array(ctx, m, buf);
            if (rc >= 0 && klems) {
                int digits = o.digits > 0 ? o.digits : 6;
                for (size_t oo = 0; oo < n; oo++) {
                    for (size_t i = 0; i < n; i++)
                        put_value(fp, buf[oo + n * i], digits);
                    fputc('\n', fp);
                }
            } else if (rc >= 0) {
                rc = write_tree(ctx, fp, buf, b->k, &o);
            }
            fputs("\t\t\t</ScatteringData>\n\t\t</WavelengthDataBlock>\n\t</WavelengthData>\n", fp);
            bsti_progress(ctx, (double)(ch * BST_NCOMP + (size_t)q + 1) / (double)(l->nchannels * BST_NCOMP), "writing");
        }
    }
    fputs("</Layer>\n</Optical>\n</WindowElement>\n", fp);
    bsti_free(ctx, buf);
    if (rc >= 0 && ferror(fp))
        rc = bsti_error(ctx, BST_EIO, "write: output error");
    return rc;
}
