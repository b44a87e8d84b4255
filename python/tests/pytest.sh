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
export PYTHONPATH PYTHONDONTWRITEBYTECODE
exec "$py" -m pytest -q -p no:cacheprovider "$here"
