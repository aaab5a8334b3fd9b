#!/usr/bin/env bash
# The first command: install what is missing, build in Release, render the default scene.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"
mkdir -p out
build/lancer render scenes/lorenzi-reflections.json -o out/lorenzi-reflections.png
