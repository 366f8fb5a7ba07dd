#!/usr/bin/env bash
# The Python package as a user installs it: `pip install .` into a fresh virtual environment
# (scikit-build-core and pybind11 from PyPI, in pip's isolated build environment), then the Python
# tests with pytest against the installed package and its `trilevel` command.
#   bash .ci/python-package.sh [VENV_DIR]     (default build-venv; PYTHON picks the interpreter)
# The venv sees the system's site-packages: Debian's numpy, pytest and dask.distributed
# (.ci/install-deps.sh), which only Debian's own python3 imports.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=$(realpath -m "${1:-build-venv}")
python=${PYTHON:-/usr/bin/python3}
rm -rf "$venv"
"$python" -m venv --system-site-packages "$venv"
start=$(date +%s)
"$venv/bin/pip" install --quiet --disable-pip-version-check .
echo "pip install .: $(( $(date +%s) - start )) s"
export PATH="$venv/bin:$PATH"  # the venv's `trilevel` is the CLI the tests compare with
# The tests must see the installed package, not the checkout's python/trilevel (no compiled module).
(cd / && python - "$venv" <<'PY'
import os, shutil, sys
import trilevel
venv = sys.argv[1]
assert trilevel.__file__.startswith(venv + os.sep), trilevel.__file__
assert shutil.which("trilevel") == os.path.join(venv, "bin", "trilevel"), shutil.which("trilevel")
print("trilevel", trilevel.__version__, "from", os.path.dirname(trilevel.__file__))
PY
)
trilevel --help >/dev/null
python -m pytest -q -p no:cacheprovider python/tests
