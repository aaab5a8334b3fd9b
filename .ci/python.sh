#!/usr/bin/env bash
# The Python module (docs/python.md): its tests (tests/python, pytest) and the example notebook
# (examples/notebook/course.ipynb) executed headless with jupyter nbconvert, against BUILD_DIR's
# module (BUILD_DIR/python), CLI and bench/lancer_api_rays. The notebook checks inside that each
# image it shows is `lancer render`'s PNG, byte for byte.
#
#   .ci/python.sh [BUILD_DIR]        (default: build)
set -euo pipefail
root="$(cd -- "$(dirname -- "$0")/.." >/dev/null && pwd)"
build="$(cd -- "${1:-build}" >/dev/null && pwd)"
# Debian's interpreter: python3-numpy, python3-pytest and the notebook's packages are its.
py=/usr/bin/python3
if ! ls "$build"/python/lancer/_lancer*.so >/dev/null 2>&1; then
  echo "python: no module in $build/python (scripts/deps.sh installs pybind11-dev and" \
       "python3-numpy; the build then makes it)" >&2
  exit 1
fi
export PYTHONPATH="$build/python" LANCER_BUILD="$build" PYTHONDONTWRITEBYTECODE=1
# No cache directory in the tree; exit status 5 (no test collected) fails the stage like any other.
"$py" -m pytest -q -p no:cacheprovider "$root/tests/python"

scratch="$(mktemp -d "${TMPDIR:-/tmp}/lancer-notebook.XXXXXX")"
trap 'rm -rf "$scratch"' EXIT
# Executed where it lies (the notebook finds scenes/ above it), written to the scratch folder.
if ! "$py" -m nbconvert --to notebook --execute --ExecutePreprocessor.timeout=600 \
     --output-dir "$scratch" "$root/examples/notebook/course.ipynb" >"$scratch/log" 2>&1; then
  cat "$scratch/log" >&2
  echo "python: examples/notebook/course.ipynb failed (above)" >&2
  exit 1
fi
echo "python: pytest passed; examples/notebook/course.ipynb ran clean, its images the CLI's"
