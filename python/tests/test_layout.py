"""The ctypes structures of bsdfstack._lib against the C compiler's layout of include/bsdfstack.h
(python/tests/layout prints every size and offset): a field added to or moved in the header
fails here instead of corrupting a call."""
import ctypes
import os
import subprocess

import pytest

from bsdfstack import _lib
from conftest import BUILDDIR

STRUCTS = {"bst_stack_opts": _lib.StackOpts, "bst_spectral_opts": _lib.SpectralOpts,
           "bst_spectral_layer": _lib.SpectralLayer, "bst_columns_opts": _lib.ColumnsOpts,
           "bst_bsdf_read_opts": _lib.ReadOpts,
           "bst_bsdf_write_opts": _lib.WriteOpts, "bst_glass_meta": _lib.GlassMeta}


def test_structures_match_the_header():
    prog = os.path.join(BUILDDIR, "python", "tests", "layout")
    if not os.path.exists(prog):
        pytest.skip("python/tests/layout not built (make check builds it)")
    out = subprocess.run([prog], capture_output=True, text=True, check=True).stdout
    seen = {name: set() for name in STRUCTS}
    for line in out.split("\n"):
        if not line:
            continue
        struct, field, value = line.split()
        cls = STRUCTS[struct]
        if field == "sizeof":
            assert ctypes.sizeof(cls) == int(value), struct
        else:
            assert getattr(cls, field).offset == int(value), (struct, field)
            seen[struct].add(field)
    for name, cls in STRUCTS.items():  # every ctypes field is one the header has
        assert seen[name] == {f[0] for f in cls._fields_}, name
