/* layout.c - prints the size of each structure of include/bsdfstack.h that the Python package
 * mirrors with ctypes, and every field's offset, one "struct field offset" line each, for
 * python/tests/test_layout.py to compare with ctypes' own. */
#include <stddef.h>
#include <stdio.h>

#include "bsdfstack.h"

#define FIELD(t, f) printf("%s %s %zu\n", #t, #f, offsetof(t, f))
#define SIZE(t) printf("%s sizeof %zu\n", #t, sizeof(t))

int main(void)
{
    SIZE(bst_stack_opts);
    FIELD(bst_stack_opts, comps), FIELD(bst_stack_opts, drop_tol), FIELD(bst_stack_opts, rcond_warn);
    FIELD(bst_stack_opts, energy_tol), FIELD(bst_stack_opts, strict);
    FIELD(bst_stack_opts, force_dense), FIELD(bst_stack_opts, precision);
    FIELD(bst_stack_opts, on_step), FIELD(bst_stack_opts, opaque);
    SIZE(bst_spectral_opts);
    FIELD(bst_spectral_opts, at_centre), FIELD(bst_spectral_opts, dual_f);
    FIELD(bst_spectral_opts, tol);
    SIZE(bst_spectral_layer);
    FIELD(bst_spectral_layer, pane), FIELD(bst_spectral_layer, bands);
    SIZE(bst_columns_opts);
    FIELD(bst_columns_opts, tol), FIELD(bst_columns_opts, max_iter), FIELD(bst_columns_opts, back);
    FIELD(bst_columns_opts, iterations), FIELD(bst_columns_opts, residual);
    SIZE(bst_bsdf_read_opts);
    FIELD(bst_bsdf_read_opts, comps), FIELD(bst_bsdf_read_opts, nchannels);
    FIELD(bst_bsdf_read_opts, channels), FIELD(bst_bsdf_read_opts, precision);
    SIZE(bst_bsdf_write_opts);
    FIELD(bst_bsdf_write_opts, rank), FIELD(bst_bsdf_write_opts, reduce_pct);
    FIELD(bst_bsdf_write_opts, reduce_floor), FIELD(bst_bsdf_write_opts, reduce_tol);
    FIELD(bst_bsdf_write_opts, digits);
    FIELD(bst_bsdf_write_opts, iso_fa_min), FIELD(bst_bsdf_write_opts, recip_tol);
    FIELD(bst_bsdf_write_opts, iso_refine), FIELD(bst_bsdf_write_opts, rank3_source);
    FIELD(bst_bsdf_write_opts, name), FIELD(bst_bsdf_write_opts, manufacturer);
    FIELD(bst_bsdf_write_opts, device_type), FIELD(bst_bsdf_write_opts, thickness);
    FIELD(bst_bsdf_write_opts, width), FIELD(bst_bsdf_write_opts, height);
    FIELD(bst_bsdf_write_opts, nlayers), FIELD(bst_bsdf_write_opts, layers);
    FIELD(bst_bsdf_write_opts, command), FIELD(bst_bsdf_write_opts, description);
    FIELD(bst_bsdf_write_opts, date), FIELD(bst_bsdf_write_opts, on_block);
    FIELD(bst_bsdf_write_opts, opaque);
    SIZE(bst_glass_meta);
    FIELD(bst_glass_meta, source), FIELD(bst_glass_meta, path), FIELD(bst_glass_meta, type);
    FIELD(bst_glass_meta, model_from), FIELD(bst_glass_meta, product_name);
    FIELD(bst_glass_meta, manufacturer), FIELD(bst_glass_meta, coating_name);
    FIELD(bst_glass_meta, coated_side), FIELD(bst_glass_meta, wavelength_units);
    FIELD(bst_glass_meta, nfrc_id), FIELD(bst_glass_meta, thickness_mm);
    FIELD(bst_glass_meta, conductivity), FIELD(bst_glass_meta, emissivity_front);
    FIELD(bst_glass_meta, emissivity_back), FIELD(bst_glass_meta, ir_transmittance);
    return 0;
}
