"""ctypes declarations of the part of libbsdfstack (include/bsdfstack.h) the package calls.

The shared library is found, in this order, at $BSDFSTACK_LIBRARY, at the path _config.py names
(the build tree's .libs for a build-tree package, $(libdir) for an installed one; make writes it)
and by the dynamic linker's own search.  Every prototype is declared, so that ctypes converts
size_t, double and pointers as the header states; the structures mirror the header's field by
field (tests/test_layout.py compares their offsets with the C compiler's).

ctypes.CDLL, not PyDLL: every foreign call releases the GIL for its duration.
"""
import ctypes
import ctypes.util
import os

from ctypes import (CFUNCTYPE, POINTER, Structure, c_char, c_char_p, c_double, c_int, c_long,
                    c_size_t, c_uint, c_void_p)

try:
    from . import _config
except ImportError:  # a package copied by hand, without make's _config.py
    _config = None


def _find():
    env = os.environ.get("BSDFSTACK_LIBRARY")
    if env:
        return env
    if _config is not None and os.path.exists(_config.LIBRARY):
        return _config.LIBRARY
    found = ctypes.util.find_library("bsdfstack")
    if found:
        return found
    raise ImportError("libbsdfstack not found: build it (make), install it (make install), or set "
                      "BSDFSTACK_LIBRARY to its path")


PATH = _find()
lib = ctypes.CDLL(PATH)

# OpenBLAS's kernels without AVX2: its fallback (Prescott) for a CPU model it does not know, and
# older cores (the program's list, src/cli/cli.c)
_OLD_KERNELS = {"prescott", "core2", "penryn", "dunnington", "nehalem", "atom", "sandybridge"}


def blas_kernels():
    """OpenBLAS's name of the kernels this process runs ('SkylakeX', 'Prescott', ...), or None
    where the library runs another BLAS."""
    try:
        name = ctypes.CDLL("libopenblas.so.0").openblas_get_corename
    except (OSError, AttributeError):
        return None
    name.restype = c_char_p
    return name().decode()


def better_kernels():
    """The OPENBLAS_CORETYPE the program would set (bsdfstack(1), ENVIRONMENT), where OpenBLAS
    runs kernels without AVX2 and this CPU has AVX2 and FMA and the user set none: 'SkylakeX'
    (AVX-512) or 'Haswell'; else None.  OpenBLAS reads it only as it loads, so a Python process
    (numpy loads it first) must have it from its start."""
    core = blas_kernels()
    if "OPENBLAS_CORETYPE" in os.environ or not core or core.lower() not in _OLD_KERNELS:
        return None
    try:
        with open("/proc/cpuinfo") as f:
            flags = set(next((line.split(":", 1)[1].split() for line in f
                              if line.startswith("flags")), []))
    except OSError:
        return None
    if {"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"} <= flags:
        return "SkylakeX"
    if {"avx2", "fma"} <= flags:
        return "Haswell"
    return None

size_p = POINTER(c_size_t)
double_p = POINTER(c_double)

PROGRESS_FN = CFUNCTYPE(None, c_double, c_char_p, c_void_p)


class StackOpts(Structure):
    """bst_stack_opts."""
    _fields_ = [("comps", c_uint), ("drop_tol", c_double), ("rcond_warn", c_double),
                ("energy_tol", c_double), ("strict", c_int), ("force_dense", c_int),
                ("precision", c_int), ("on_step", c_void_p), ("opaque", c_void_p)]


class SpectralOpts(Structure):
    """bst_spectral_opts."""
    _fields_ = [("at_centre", c_int), ("dual_f", c_double), ("tol", c_double)]


class SpectralLayer(Structure):
    """bst_spectral_layer: exactly one of pane and bands set."""
    _fields_ = [("pane", c_void_p), ("bands", c_void_p)]


class PlanBasis(Structure):
    """bst_plan_basis: the basis rule's pick."""
    _fields_ = [("k", c_int), ("klems", c_char_p), ("file", c_long), ("given", c_long),
                ("finest", c_int), ("why", c_char * 160), ("note", c_char * 320)]


class PlanLayer(Structure):
    """bst_plan_layer: a stack's layer as the spectral plan sees it."""
    _fields_ = [("layer", c_void_p), ("pane", c_void_p), ("from_file", c_int)]


class ColumnsOpts(Structure):
    """bst_columns_opts."""
    _fields_ = [("tol", c_double), ("max_iter", c_int), ("back", c_int), ("iterations", c_int),
                ("residual", c_double)]


class GlassMeta(Structure):
    """bst_glass_meta: where a pane comes from and what its file says of it (owned by the pane)."""
    _fields_ = [("source", c_char_p), ("path", c_char_p), ("type", c_char_p),
                ("model_from", c_char_p), ("product_name", c_char_p), ("manufacturer", c_char_p),
                ("coating_name", c_char_p), ("coated_side", c_char_p),
                ("wavelength_units", c_char_p), ("nfrc_id", c_long), ("thickness_mm", c_double),
                ("conductivity", c_double), ("emissivity_front", c_double),
                ("emissivity_back", c_double), ("ir_transmittance", c_double)]


class ReadOpts(Structure):
    """bst_bsdf_read_opts."""
    _fields_ = [("comps", c_uint), ("nchannels", c_size_t), ("channels", POINTER(c_char_p)),
                ("precision", c_int)]


class WriteOpts(Structure):
    """bst_bsdf_write_opts."""
    _fields_ = [("rank", c_int), ("reduce_pct", c_double), ("reduce_floor", c_double),
                ("reduce_tol", c_double), ("digits", c_int), ("iso_fa_min", c_double), ("recip_tol", c_double),
                ("iso_refine", c_int), ("rank3_source", c_void_p), ("name", c_char_p),
                ("manufacturer", c_char_p), ("device_type", c_char_p), ("thickness", c_double),
                ("width", c_double), ("height", c_double), ("nlayers", c_size_t),
                ("layers", POINTER(c_char_p)), ("command", c_char_p), ("description", c_char_p),
                ("date", c_char_p), ("on_block", c_void_p), ("opaque", c_void_p)]


# name: (restype, argtypes)
_PROTOTYPES = {
    "bst_version": (c_char_p, []),
    "bst_strerror": (c_char_p, [c_int]),
    "bst_ctx_new": (c_void_p, []),
    "bst_ctx_free": (None, [c_void_p]),
    "bst_ctx_message": (c_char_p, [c_void_p]),
    "bst_ctx_status": (c_int, [c_void_p]),
    "bst_ctx_clear": (None, [c_void_p]),
    "bst_ctx_set_progress": (None, [c_void_p, PROGRESS_FN, c_void_p]),
    "bst_mat_structure": (c_int, [c_void_p]),
    "bst_mat_precision": (c_int, [c_void_p]),
    "bst_mat_rows": (c_size_t, [c_void_p]),
    "bst_mat_cols": (c_size_t, [c_void_p]),
    "bst_mat_nnz": (c_size_t, [c_void_p]),
    "bst_mat_dense_data": (c_void_p, [c_void_p]),
    "bst_mat_free": (None, [c_void_p]),
    "bst_mat_to_dense_array": (c_int, [c_void_p, c_void_p, double_p]),
    "bst_basis_new_sc": (c_int, [c_void_p, c_int, POINTER(c_void_p)]),
    "bst_basis_new_klems": (c_int, [c_void_p, c_char_p, POINTER(c_void_p)]),
    "bst_basis_copy": (c_int, [c_void_p, c_void_p, POINTER(c_void_p)]),
    "bst_basis_free": (None, [c_void_p]),
    "bst_basis_kind_of": (c_int, [c_void_p]),
    "bst_basis_size": (c_size_t, [c_void_p]),
    "bst_basis_order": (c_int, [c_void_p]),
    "bst_basis_name": (c_char_p, [c_void_p]),
    "bst_basis_lambda": (double_p, [c_void_p]),
    "bst_basis_patch": (c_size_t, [c_void_p, double_p]),
    "bst_basis_center": (None, [c_void_p, c_size_t, double_p]),
    "bst_basis_equal": (c_int, [c_void_p, c_void_p]),
    "bst_comp_name": (c_char_p, [c_int]),
    "bst_comp_parse": (c_int, [c_char_p]),
    "bst_layer_new": (c_int, [c_void_p, c_void_p, c_size_t, POINTER(c_char_p), POINTER(c_void_p)]),
    "bst_layer_free": (None, [c_void_p]),
    "bst_layer_basis": (c_void_p, [c_void_p]),
    "bst_layer_nchannels": (c_size_t, [c_void_p]),
    "bst_layer_channel": (c_char_p, [c_void_p, c_size_t]),
    "bst_layer_find_channel": (c_int, [c_void_p, c_char_p]),
    "bst_layer_get": (c_void_p, [c_void_p, c_size_t, c_int]),
    "bst_layer_set": (c_int, [c_void_p, c_void_p, c_size_t, c_int, c_void_p]),
    "bst_layer_set_name": (c_int, [c_void_p, c_void_p, c_char_p]),
    "bst_layer_name": (c_char_p, [c_void_p]),
    "bst_layer_flip": (c_int, [c_void_p, c_void_p, POINTER(c_void_p)]),
    "bst_layer_hemispherical": (c_int, [c_void_p, c_void_p, c_size_t, c_int, double_p]),
    "bst_mat_convert": (c_int, [c_void_p, c_void_p, c_int, c_int, POINTER(c_void_p)]),
    "bst_stack_opts_init": (None, [POINTER(StackOpts)]),
    "bst_stack_combine": (c_int, [c_void_p, c_size_t, POINTER(c_void_p), POINTER(StackOpts),
                                  POINTER(c_void_p)]),
    "bst_stack_absorptance": (c_int, [c_void_p, c_size_t, POINTER(c_void_p), c_size_t,
                                      POINTER(StackOpts), double_p, double_p]),
    "bst_spectral_opts_init": (None, [POINTER(SpectralOpts)]),
    "bst_stack_combine_spectral_layers": (
        c_int, [c_void_p, c_size_t, POINTER(SpectralLayer), c_void_p, c_size_t, POINTER(c_char_p),
                POINTER(SpectralOpts), POINTER(StackOpts), POINTER(c_void_p), double_p, double_p]),
    "bst_columns_opts_init": (None, [POINTER(ColumnsOpts)]),
    "bst_stack_columns": (c_int, [c_void_p, c_size_t, POINTER(c_void_p), c_char_p, c_size_t, size_p,
                                  POINTER(ColumnsOpts), POINTER(c_void_p), POINTER(c_void_p)]),
    "bst_stack_columns_spectral_layers": (
        c_int, [c_void_p, c_size_t, POINTER(SpectralLayer), c_void_p, c_char_p, POINTER(SpectralOpts),
                c_size_t, size_p, POINTER(ColumnsOpts), POINTER(c_void_p), POINTER(c_void_p)]),
    "bst_metrics_accordance": (c_int, [c_void_p, c_void_p, c_void_p, c_size_t, c_int, c_size_t,
                                       double_p, double_p, double_p]),
    "bst_metrics_accordance_all": (c_int, [c_void_p, c_void_p, c_void_p, c_size_t, c_int,
                                           double_p, double_p]),
    "bst_bsdf_read": (c_int, [c_void_p, c_char_p, POINTER(ReadOpts), POINTER(c_void_p)]),
    "bst_bsdf_free": (None, [c_void_p]),
    "bst_bsdf_kind": (c_int, [c_void_p]),
    "bst_bsdf_order": (c_int, [c_void_p]),
    "bst_bsdf_depth": (c_int, [c_void_p]),
    "bst_bsdf_set_rank3_rule": (c_int, [c_void_p, c_void_p, c_int]),
    "bst_bsdf_rank3_rule": (c_int, [c_void_p]),
    "bst_bsdf_negatives": (c_size_t, [c_void_p]),
    "bst_bsdf_klems_basis": (c_void_p, [c_void_p]),
    "bst_plan_pick_basis": (None, [c_size_t, c_void_p, c_void_p, c_int, c_char_p,
                                   POINTER(PlanBasis)]),
    "bst_plan_make_basis": (c_int, [c_void_p, POINTER(PlanBasis), c_size_t, c_void_p, c_void_p,
                                    POINTER(c_void_p)]),
    "bst_plan_channels": (c_size_t, [c_size_t, c_void_p, POINTER(c_char_p)]),
    "bst_plan_is_band": (c_int, [c_char_p]),
    "bst_plan_spectral": (c_int, [c_void_p, c_size_t, POINTER(PlanLayer), c_int, c_char_p,
                                  c_size_t, POINTER(c_int), POINTER(c_int)]),
    "bst_bsdf_nchannels": (c_size_t, [c_void_p]),
    "bst_bsdf_channel": (c_char_p, [c_void_p, c_size_t]),
    "bst_bsdf_stored": (c_int, [c_void_p, c_size_t, c_int]),
    "bst_bsdf_to_layer": (c_int, [c_void_p, c_void_p, c_void_p, POINTER(c_void_p)]),
    "bst_bsdf_write_opts_init": (None, [POINTER(WriteOpts)]),
    "bst_bsdf_write_path": (c_int, [c_void_p, c_void_p, c_char_p, POINTER(WriteOpts)]),
    "bst_glass_parse": (c_int, [c_void_p, c_char_p, c_char_p, POINTER(c_void_p)]),
    "bst_glass_parse_bands": (c_int, [c_void_p, c_char_p, c_char_p, c_size_t, POINTER(c_char_p),
                                      POINTER(c_void_p)]),
    "bst_glass_free": (None, [c_void_p]),
    "bst_glass_nchannels": (c_size_t, [c_void_p]),
    "bst_glass_channel": (c_char_p, [c_void_p, c_size_t]),
    "bst_glass_find_channel": (c_int, [c_void_p, c_char_p]),
    "bst_glass_description": (c_char_p, [c_void_p]),
    "bst_glass_nwavelengths": (c_size_t, [c_void_p]),
    "bst_glass_add_channel": (c_int, [c_void_p, c_void_p, c_char_p]),
    "bst_glass_get_model": (c_int, [c_void_p]),
    "bst_glass_model_name": (c_char_p, [c_int]),
    "bst_glass_metadata": (POINTER(GlassMeta), [c_void_p]),
    "bst_glass_layer_nodes": (c_size_t, [c_void_p, c_size_t, size_p]),
    "bst_glass_layer": (c_int, [c_void_p, c_void_p, c_void_p, c_size_t, POINTER(c_char_p), c_int,
                                POINTER(c_void_p)]),
    "bst_shade_spec_model": (c_int, [c_void_p, c_char_p, c_char_p, c_char_p, c_size_t]),
    "bst_shade_spec_layer": (c_int, [c_void_p, c_char_p, c_char_p, c_void_p, c_size_t,
                                     POINTER(c_char_p), POINTER(c_void_p)]),
}

for _name, (_res, _args) in _PROTOTYPES.items():
    _f = getattr(lib, _name)
    _f.restype = _res
    _f.argtypes = _args

# include/bsdfstack.h's enumerations and defaults
BST_ZERO, BST_DIAG, BST_SPARSE, BST_DENSE, BST_FACTORED, BST_PLUS_LR = 0, 1, 2, 3, 4, 5
BST_DOUBLE, BST_FLOAT = 0, 1
BST_BASIS_SHIRLEY_CHIU, BST_BASIS_KLEMS = 0, 1
BST_FILE_KLEMS = 0
BST_WDATA = 3
BST_WACCURACY = 4
BST_K_MIN, BST_K_MAX = 1, 7
COMPS = ("Tf", "Rf", "Tb", "Rb")


def text(b):
    """A C string from the library as str (None stays None)."""
    return None if b is None else b.decode("utf-8", "replace")


class Error(Exception):
    """An error of libbsdfstack (its message; .status is the bst_status code, 0 for errors found
    by this package before any library call).  bsdfstack.Error; defined here for cstr."""

    def __init__(self, message, status=0):
        super().__init__(message)
        self.status = status
        self.message = message


Error.__module__ = "bsdfstack"


def cstr(s):
    """A str, bytes or path as the C string the library reads (file names in the file system's
    encoding).  A NUL inside would end it there, unseen (a path cut short): Error instead."""
    if s is None:
        return None
    b = os.fsencode(s) if not isinstance(s, bytes) else s
    if b"\0" in b:
        raise Error("%r holds a NUL character: the library would read only what comes before it" % (s,))
    return b


def cstr_array(names):
    """A char *[] of names (the array keeps its bytes alive through its _keep attribute)."""
    enc = [cstr(n) for n in names]
    arr = (c_char_p * max(1, len(enc)))(*enc)
    arr._keep = enc
    return arr
