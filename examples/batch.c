/* batch.c - many stacks through the C library, each layer loaded once.
 *
 * Combines a diffusing shade between pairs of panes from the glass catalogue (every exterior pane
 * with every interior pane) and prints each system's directional-hemispherical transmittance and
 * reflectance at normal incidence.  The shade file is read and resampled once; glass layers are
 * analytic (diagonal, O(N)).
 *
 *   cc batch.c $(pkg-config --cflags --libs bsdfstack) -o batch
 *   ./batch shade.xml [k]
 */
#include <stdio.h>
#include <stdlib.h>

#include <bsdfstack.h>

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s SHADE.xml [k]\n", argv[0]);
        return 2;
    }
    int k = argc > 2 ? atoi(argv[2]) : 4;
    static const char *const panes[] = {"clear-4mm", "clear-6mm", "lowiron-6mm", "nfrc-103"};
    const size_t npanes = sizeof panes / sizeof panes[0];
    const char *glass_dir = getenv("BSDFSTACK_GLASS_DIR"); /* NULL: bst_glass_catalogue_dir() */
    const char *channels[] = {"Visible"};
    bst_ctx *ctx = bst_ctx_new();
    if (!ctx) {
        fprintf(stderr, "batch: out of memory\n");
        return 1;
    }
    /* on any error: one message, then everything below is freed */
    bst_basis *basis = NULL;
    bst_bsdf *file = NULL;
    bst_layer *shade = NULL, *glass[4] = {0};
    double *t = NULL, *r = NULL;
    int rc = bst_basis_new_sc(ctx, k, &basis);
    if (rc >= 0)
        rc = bst_bsdf_read(ctx, argv[1], NULL, &file);
    if (rc >= 0)
        rc = bst_bsdf_to_layer(ctx, file, basis, &shade);
    for (size_t i = 0; rc >= 0 && i < npanes; i++)
        rc = bst_glass_layer_from_spec(ctx, panes[i], glass_dir, basis, 1, channels, &glass[i]);
    if (rc < 0) {
        fprintf(stderr, "batch: %s\n", bst_ctx_message(ctx));
    } else if (!(t = malloc(bst_basis_size(basis) * sizeof *t)) ||
               !(r = malloc(bst_basis_size(basis) * sizeof *r))) {
        fprintf(stderr, "batch: out of memory\n");
        rc = BST_ENOMEM;
    } else {
        /* the incident patch of normal incidence */
        double normal[3] = {1e-9, 1e-9, 1.0};
        size_t j = bst_basis_patch(basis, normal);
        bst_stack_opts opts;
        bst_stack_opts_init(&opts);
        opts.comps = BST_COMP_BIT(BST_TF) | BST_COMP_BIT(BST_RF);
        printf("exterior\tinterior\tT(0)\tR(0)\n");
        for (size_t a = 0; a < npanes && rc >= 0; a++)
            for (size_t b = 0; b < npanes && rc >= 0; b++) {
                const bst_layer *stack[3] = {glass[a], shade, glass[b]};
                bst_layer *sys;
                rc = bst_stack_combine(ctx, 3, stack, &opts, &sys);
                if (rc < 0)
                    break;
                bst_layer_hemispherical(ctx, sys, 0, BST_TF, t);
                bst_layer_hemispherical(ctx, sys, 0, BST_RF, r);
                printf("%s\t%s\t%.4f\t%.4f\n", panes[a], panes[b], t[j], r[j]);
                if (!(t[j] >= 0 && r[j] >= 0 && t[j] + r[j] <= 1.0 + 1e-9))
                    rc = BST_EINVAL; /* an unphysical result would be a bug */
                bst_layer_free(sys);
            }
        if (rc < 0)
            fprintf(stderr, "batch: %s\n", bst_ctx_message(ctx));
    }
    free(t), free(r);
    for (size_t i = 0; i < npanes; i++)
        bst_layer_free(glass[i]);
    bst_layer_free(shade);
    bst_bsdf_free(file);
    bst_basis_free(basis);
    bst_ctx_free(ctx);
    return rc < 0 ? 1 : 0;
}
