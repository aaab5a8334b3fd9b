#!/usr/bin/env bash
# The first command: install what is missing, build the CLI in Release, render the default scene.
# Only the CLI and its image module are built here (the tests and benchmarks, most of a full
# build's time, are scripts/test.sh's), through ccache when it is installed.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
# Set either way, so that a build directory configured with ccache still builds once it is gone.
launcher=""
command -v ccache >/dev/null && launcher=ccache
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER_LAUNCHER="$launcher"
cmake --build build -j"$(nproc)" --target lancer_cli
mkdir -p out
build/lancer render scenes/lorenzi-reflections.json -o out/lorenzi-reflections.png
