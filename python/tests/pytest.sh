#!/bin/sh
# pytest.sh - make check's entry to the Python package's tests (python/tests/test_*.py): runs
# pytest with the python3 configure found ($BST_PYTHON) and the build tree's package first on
# PYTHONPATH ($BST_PYTHONPATH); exit 77 (skipped) when python3, numpy or pytest is missing.
py=${BST_PYTHON:-}
if [ -z "$py" ] || [ "$py" = : ] || ! "$py" -c 'import numpy, pytest' 2>/dev/null; then
    echo "skipped: no python3 with numpy and pytest (configure --disable-python, or install"
    echo "python3-numpy and python3-pytest)"
    exit 77
fi
here=$(cd "$(dirname "$0")" && pwd)
PYTHONPATH=$BST_PYTHONPATH${PYTHONPATH:+:$PYTHONPATH}
PYTHONDONTWRITEBYTECODE=1
# small matrices gain nothing from OpenBLAS threads, which on a loaded 2-core machine made the
# 1,000-combination test 3x slower; the program the tests compare with inherits the same
OPENBLAS_NUM_THREADS=${OPENBLAS_NUM_THREADS:-1}
export PYTHONPATH PYTHONDONTWRITEBYTECODE OPENBLAS_NUM_THREADS
# Under make check-asan the library is built with AddressSanitizer, whose runtime must be loaded
# before anything else in an uninstrumented python3: BST_ASAN_RUNTIME names it.  Leaks are left
# to the C suites (the interpreter keeps memory until it exits).  Freed blocks wait in ASan's
# quarantine before reuse, 256 MB by default, which test_memory.py's resident-set count would
# take for growth (68 MB over its 1,000 stacks): 32 MB here, still far more than one stack frees.
if [ -n "${BST_ASAN_RUNTIME:-}" ]; then
    if [ ! -f "$BST_ASAN_RUNTIME" ]; then
        echo "skipped: the AddressSanitizer runtime '$BST_ASAN_RUNTIME' is not a file"
        exit 77
    fi
    LD_PRELOAD=$BST_ASAN_RUNTIME${LD_PRELOAD:+:$LD_PRELOAD}
    ASAN_OPTIONS=${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0:quarantine_size_mb=32
    export LD_PRELOAD ASAN_OPTIONS
fi
exec "$py" -m pytest -q -p no:cacheprovider "$here"
