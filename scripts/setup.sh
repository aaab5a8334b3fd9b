#!/usr/bin/env bash
# The first command: install what is missing, build the CLI and the Python module in Release,
# render the default scene. Only the CLI, its image module and the Python module are built here
# (the tests and benchmarks, most of a full build's time, are scripts/test.sh's), through ccache
# when it is installed.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
# Set either way, so that a build directory configured with ccache still builds once it is gone.
launcher=""
command -v ccache >/dev/null && launcher=ccache
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER_LAUNCHER="$launcher"
targets=(lancer_cli)
# The Python module (build/python, docs/python.md), when CMake found pybind11 and numpy.
# (grep reads the whole list: -q would close the pipe early, and pipefail call that a failure.)
if cmake --build build --target help | grep '\blancer_python\b' >/dev/null; then
  targets+=(lancer_python)
fi
cmake --build build -j"$(nproc)" --target "${targets[@]}"
mkdir -p out
build/lancer render scenes/lorenzi-reflections.json -o out/lorenzi-reflections.png
