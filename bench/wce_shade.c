/* wce_shade.c - writes Windows-CalcEngine's two-band shade 2011-SA1 (its Solar and Visible Klems
 * full matrices, ../shared/reference/wce/matrices/bsdf_2011SA1_full_{solar,visible}_{Tf,Rf,Tb,Rb}.tsv,
 * rows = outgoing patch, in WCE's order, which is bsdfstack's) as one Klems BSDF XML file with the
 * channels Solar and Visible: the shade of the spectral benchmark (bench/run-spectral).
 *
 *   bench/wce_shade REFDIR OUT.xml */
#include <stdio.h>
#include <stdlib.h>

#include "bsdfstack.h"

/* Matrix `band`/`comp` of the shade, column-major (j * N + i: outgoing i, incident j). */
static double *read_matrix(const char *dir, const char *band, const char *comp, size_t N)
{
    char path[1024], line[65536];
    snprintf(path, sizeof path, "%s/wce/matrices/bsdf_2011SA1_full_%s_%s.tsv", dir, band, comp);
    FILE *fp = fopen(path, "r");
    if (!fp) {
        fprintf(stderr, "wce_shade: cannot open %s\n", path);
        return NULL;
    }
    double *m = malloc(N * N * sizeof *m);
    size_t i = 0;
    while (m && i < N && fgets(line, sizeof line, fp)) {
        if (line[0] == '#')
            continue;
        char *p = line, *e;
        for (size_t j = 0; j < N; j++, p = e) {
            m[j * N + i] = strtod(p, &e);
            if (e == p) {
                fprintf(stderr, "wce_shade: %s: row %zu has fewer than %zu values\n", path, i + 1, N);
                free(m);
                fclose(fp);
                return NULL;
            }
        }
        i++;
    }
    fclose(fp);
    if (m && i < N) {
        fprintf(stderr, "wce_shade: %s: %zu rows, not %zu\n", path, i, N);
        free(m);
        return NULL;
    }
    return m;
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: wce_shade REFDIR OUT.xml\n");
        return 2;
    }
    static const char *const bands[2] = {"solar", "visible"};
    static const char *const channels[2] = {"Solar", "Visible"};
    bst_ctx *ctx = bst_ctx_new();
    bst_basis *b = NULL;
    bst_layer *l = NULL;
    int rc = ctx ? bst_basis_new_klems(ctx, "full", &b) : BST_ENOMEM;
    if (rc >= 0)
        rc = bst_layer_new(ctx, b, 2, channels, &l);
    size_t N = b ? bst_basis_size(b) : 0;
    for (size_t ch = 0; ch < 2 && rc >= 0; ch++)
        for (int c = 0; c < BST_NCOMP && rc >= 0; c++) {
            double *m = read_matrix(argv[1], bands[ch], bst_comp_name((bst_comp)c), N);
            bst_mat *d = NULL;
            if (!m)
                rc = BST_ENOTFOUND;
            if (rc >= 0)
                rc = bst_mat_new_dense(ctx, N, N, BST_DOUBLE, &d);
            for (size_t q = 0; rc >= 0 && q < N * N; q++)
                ((double *)bst_mat_dense_data(d))[q] = m[q];
            free(m);
            if (rc >= 0)
                rc = bst_layer_set(ctx, l, ch, (bst_comp)c, d);
        }
    if (rc >= 0)
        rc = bst_bsdf_write_path(ctx, l, argv[2], NULL);
    if (rc < 0 && rc != BST_ENOTFOUND)
        fprintf(stderr, "wce_shade: %s\n", bst_ctx_message(ctx));
    bst_layer_free(l);
    bst_basis_free(b);
    bst_ctx_free(ctx);
    return rc < 0;
}
