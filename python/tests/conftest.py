"""Shared fixtures of the Python package's tests: where the program, the reference data and the
sources are.  make check sets BSDFSTACK, BST_REFDIR, BST_SRCDIR, BST_BUILDDIR and
BSDFSTACK_GLASS_DIR (python/tests/pytest.sh puts the build tree's package on PYTHONPATH); run by
hand, they default to this checkout's build tree and ../shared/reference."""
import os
import subprocess

import pytest

import bsdfstack

HERE = os.path.dirname(os.path.abspath(__file__))
SRCDIR = os.environ.get("BST_SRCDIR") or os.path.dirname(os.path.dirname(HERE))
BUILDDIR = os.environ.get("BST_BUILDDIR") or SRCDIR
REFDIR = os.environ.get("BST_REFDIR") or os.path.join(os.path.dirname(SRCDIR), "shared", "reference")
PROGRAM = os.environ.get("BSDFSTACK") or os.path.join(BUILDDIR, "bsdfstack")
os.environ.setdefault("BSDFSTACK_GLASS_DIR", os.path.join(SRCDIR, "layers", "glass"))


def ref(name):
    path = os.path.join(REFDIR, name)
    if not os.path.exists(path):
        pytest.skip("reference file %s not found (BST_REFDIR)" % path)
    return path


def run_cli(*args, check=True):
    """Run the program; (stdout, stderr, exit status).  It runs this process's OpenBLAS kernels
    (the program would choose its own where OpenBLAS's pick lacks AVX2: bsdfstack(1),
    OPENBLAS_CORETYPE), so that the two compute alike to the last bit."""
    env = dict(os.environ, SOURCE_DATE_EPOCH="0")
    core = bsdfstack.blas_kernels()
    if core:
        env["OPENBLAS_CORETYPE"] = core
    p = subprocess.run([PROGRAM] + [str(a) for a in args], capture_output=True, text=True, env=env)
    if check and p.returncode != 0:
        raise AssertionError("bsdfstack %s: exit %d: %s" % (" ".join(map(str, args)), p.returncode,
                                                           p.stderr))
    return p.stdout, p.stderr, p.returncode


@pytest.fixture(scope="session")
def diffuser():
    """The reference diffuser (TensorTree3, k = 5), read once for the session."""
    return bsdfstack.load(ref("L_diffuser_t3k5.xml"))


@pytest.fixture(scope="session")
def pane():
    return bsdfstack.glass("clear-6mm")


def rel_max(a, b):
    """max |a - b| / max |b| (0 when both are zero)."""
    import numpy as np
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = np.abs(b).max()
    return float(np.abs(a - b).max() / scale) if scale else float(np.abs(a).max())
